"""Test-session set-up: the two workers share the first compilation of the kernels.

On a fresh checkout every Numba kernel compiles on first use (then it is cached on disk).
With two pytest-xdist workers, both start with the same tests' kernels and compile them
side by side: the same work twice. Here each worker first compiles one half of the
heaviest kernels, by calling the public functions on tiny inputs, and writes them to the
shared cache; whichever kernels of the other half it then needs it loads from there.
Nothing here asserts anything: a warm-up that fails leaves the kernels to compile in the
tests, which report any error themselves.
"""

from __future__ import annotations

import contextlib
import os
import sys

import numpy as np

# PYTHONDONTWRITEBYTECODE (set on some CI images) would make every process of the run
# compile the same sources again: each worker's assertion rewriting of every test module
# (2 s), and every interpreter the tests start (commands, the demo's and Dask's workers,
# the first-run helper: 0.15-0.5 s each, 40-50 of them). Writing bytecode into
# __pycache__ is Python's default, and Numba's cache lives there anyway.
sys.dont_write_bytecode = False
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)

# the commands' first-run helper (adavar._compile_ahead) would compile, beside a test on a
# fresh checkout, kernels that the other worker's warm-up is compiling: tests of it set it
os.environ.setdefault("ADAVAR_COMPILE_AHEAD", "0")


def _group_a() -> None:
    import adavar
    from adavar.kurtosis import kurtosis_contribution, sliding_kurtosis

    x = np.random.default_rng(0).standard_normal(3000)
    r = adavar.deviation(x, rate=1.0)
    adavar.fit_noise(r)
    adavar.deviation(x, rate=1.0, data_type="phase", stat="mdev")
    for stat in ("adev", "hdev", "ohdev", "totdev"):
        adavar.deviation(x, rate=1.0, stat=stat)
    surface = adavar.davar(x, rate=1.0, window=300)
    adavar.fit_noise(surface)
    sliding_kurtosis(x, window=300)
    kurtosis_contribution(x, window=300, segment=50)
    kurtosis_contribution(x, window=300, reference="record")
    for stat in ("mtotdev", "htotdev", "pdev"):
        adavar.deviation(x[:600], rate=1.0, stat=stat)
    # the streamed noise identification: both workers reached it within seconds
    from adavar.stream import noise_types

    noise_types(x, np.array([1, 2, 4, 8]), 2)


def _group_b() -> None:
    import adavar

    x = np.random.default_rng(1).standard_normal(3000)
    adavar.adaptive_schedule(x, rate=1.0, lmax=300, lmin=200, l=50)
    for stat in ("theo1", "theobr", "mtie", "tierms"):
        adavar.deviation(x[:800], rate=1.0, stat=stat)
    adavar.deviation(x[:800], rate=1.0, stat="theo1", taus="all")
    y = x.copy()
    y[100:110] = np.nan
    adavar.deviation(y, rate=1.0, gaps="omit")
    adavar.davar(y, rate=1.0, window=300, gaps="omit")
    for stat in ("ohvar", "mvar"):
        adavar.davar(x, rate=1.0, window=300, stat=stat)


def pytest_sessionstart(session) -> None:
    worker = os.environ.get("PYTEST_XDIST_WORKER")
    group = {"gw0": _group_a, "gw1": _group_b}.get(worker or "")
    if group is None:  # one process (or a third worker): the tests compile as they go
        return
    with contextlib.suppress(Exception):
        group()

"""Test-session set-up: the two workers share the first compilation of the kernels.

On a fresh checkout every Numba kernel compiles on first use (then it is cached on disk).
With two pytest-xdist workers, both start with the same tests' kernels and compile them
side by side: the same work twice. Here each worker first compiles one half of the
stages of ``adavar precompile`` (:mod:`adavar.pipeline.precompile`) and writes them to the
shared cache; whichever kernels of the other half it then needs it loads from there.
Nothing here asserts anything: a warm-up that fails leaves the kernels to compile in the
tests, which report any error themselves.
"""

from __future__ import annotations

import contextlib
import os
import sys

# PYTHONDONTWRITEBYTECODE (set on some CI images) would make every process of the run
# compile the same sources again: each worker's assertion rewriting of every test module
# (2 s), and every interpreter the tests start (commands, the demo's and Dask's workers,
# 0.15-0.5 s each, 40-50 of them). Writing bytecode into
# __pycache__ is Python's default, and Numba's cache lives there anyway.
sys.dont_write_bytecode = False
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)


def _share(k: int) -> None:
    """Compile every other stage of ``adavar precompile``, from the ``k``-th on."""
    from adavar.pipeline.precompile import STAGES, precompile

    precompile(list(STAGES)[k::2])


def pytest_sessionstart(session) -> None:
    worker = os.environ.get("PYTEST_XDIST_WORKER")
    share = {"gw0": 0, "gw1": 1}.get(worker or "")
    if share is None:  # one process (or a third worker): the tests compile as they go
        return
    with contextlib.suppress(Exception):
        _share(share)

"""Compile every kernel ahead of a first analysis (``adavar precompile``).

adavar's kernels are compiled by Numba on first use and kept in Numba's on-disk cache
(``cache=True``; the folder is ``NUMBA_CACHE_DIR`` when set, else ``__pycache__`` beside
the sources). A first analysis therefore spends seconds compiling before it computes.
:func:`precompile` does that work once, explicitly, for example right after ``pip
install`` or when a container image is built: every later process loads the machine code
from the cache.

Each stage is compiled by calling the public functions on a few thousand samples of white
noise, the same code path as a real call, so the kernels get the signatures the commands
use (``tests/test_precompile.py`` checks that the commands then compile nothing). Stages
are independent: with ``workers`` above 1 they are compiled in separate processes at the
same time (Numba writes each cache entry under a temporary name and renames it, so two
processes never see half an entry).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["STAGES", "PrecompileResult", "precompile"]


def _white(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).standard_normal(n)


def _deviation() -> None:
    from adavar.fit.noise_model import fit_noise
    from adavar.stats.statistics import deviation

    x = _white(3000, 0)
    fit_noise(deviation(x, rate=1.0))
    deviation(x, rate=1.0, data_type="phase", stat="mdev")
    for stat in ("adev", "mdev", "hdev", "ohdev", "tdev", "totdev"):
        deviation(x, rate=1.0, stat=stat)


def _families() -> None:
    from adavar.stats.statistics import deviation

    x = _white(800, 1)
    for stat in ("mtotdev", "htotdev", "pdev", "theo1", "theobr", "mtie", "tierms"):
        deviation(x, rate=1.0, stat=stat)
    deviation(x, rate=1.0, stat="theo1", taus="all")


def _gaps() -> None:
    from adavar.dynamic.surface import davar
    from adavar.stats.statistics import deviation

    x = _white(3000, 2)
    x[100:110] = np.nan
    deviation(x, rate=1.0, gaps="omit")
    davar(x, rate=1.0, window=300, gaps="omit")


def _surface() -> None:
    from adavar.dynamic.surface import davar
    from adavar.fit.noise_model import fit_noise

    x = _white(3000, 3)
    fit_noise(davar(x, rate=1.0, window=300))
    for stat in ("ohvar", "mvar"):
        davar(x, rate=1.0, window=300, stat=stat)


def _controller() -> None:
    from adavar.dynamic.schedule import adaptive_schedule

    adaptive_schedule(_white(3000, 4), rate=1.0, lmax=300, lmin=200, l=50)


def _kurtosis() -> None:
    from adavar.dynamic.kurtosis import kurtosis_contribution, sliding_kurtosis

    x = _white(3000, 5)
    sliding_kurtosis(x, window=300)
    kurtosis_contribution(x, window=300, segment=50)
    kurtosis_contribution(x, window=300, reference="record")


def _streamed() -> None:
    from adavar.stats.stream import noise_types

    noise_types(_white(3000, 6), np.array([1, 2, 4, 8]), 2)


def _simulate() -> None:
    from adavar.simulation.generators import sensor

    sensor(
        3000,
        rate=200.0,
        bandwidth=50.0,
        lsb=1e-4,
        seed=8,
        angle_random_walk=3e-3,
        bias_instability=5e-4,
        rate_random_walk=1e-4,
    )


def _large() -> None:
    from adavar._kernels.differences import RECORD_THREADS_MIN
    from adavar.stats.statistics import deviation

    # records from RECORD_THREADS_MIN samples on take the kernels that run in parts
    x = _white(RECORD_THREADS_MIN + 4096, 7)
    deviation(x, rate=1.0)
    deviation(x, rate=1.0, stat="mdev")


#: stage name -> the calls that compile its kernels (listed heaviest first, so that two
#: workers taking them in turn get about equal shares)
STAGES: dict[str, Callable[[], None]] = {
    "deviation": _deviation,
    "controller": _controller,
    "surface": _surface,
    "kurtosis": _kurtosis,
    "families": _families,
    "gaps": _gaps,
    "streamed": _streamed,
    "simulate": _simulate,
    "large": _large,
}


@dataclass(frozen=True)
class PrecompileResult:
    """What :func:`precompile` did.

    Attributes
    ----------
    stages : tuple of str
        The stages run, in :data:`STAGES` order.
    compiled : int
        Compilations (kernels and the Numba functions inside them; 0 when the cache
        held every kernel).
    seconds : float
        Wall time.
    cache_dir : str or None
        ``NUMBA_CACHE_DIR`` as Numba reads it (None: ``__pycache__`` beside the sources).
    """

    stages: tuple[str, ...]
    compiled: int
    seconds: float
    cache_dir: str | None


def _run(names: Sequence[str]) -> int:
    """Run the stages ``names`` here; the number of kernel versions compiled."""
    from adavar._kernels._jit import compilations

    with compilations() as compiled:
        for name in names:
            STAGES[name]()
    return len(compiled)


def precompile(stages: Sequence[str] | None = None, *, workers: int = 1) -> PrecompileResult:
    """Compile the kernels of ``stages`` (all by default) into Numba's on-disk cache.

    Parameters
    ----------
    stages : sequence of str, optional
        Names of :data:`STAGES`; all of them by default.
    workers : int
        Processes that compile side by side (1: this process only), each taking the
        next stage as it finishes one; the stages share some small kernels, which are
        then compiled in more than one of them.

    Returns
    -------
    PrecompileResult

    Raises
    ------
    ValueError
        An unknown stage or ``workers`` below 1.
    """
    import numba

    names = list(STAGES) if stages is None else list(stages)
    unknown = [name for name in names if name not in STAGES]
    if unknown:
        raise ValueError(f"unknown stage {unknown[0]!r}: choose from {', '.join(STAGES)}")
    if int(workers) != workers or workers < 1:
        raise ValueError(f"workers must be a whole number of at least 1, got {workers!r}")
    names = [name for name in STAGES if name in names]
    start = time.perf_counter()
    if int(workers) <= 1 or len(names) <= 1:
        compiled = _run(names)
    else:
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        # spawn: fresh interpreters, whatever threads this one runs; each process takes
        # the next stage when it is through with one (the stages differ tenfold in cost)
        context = mp.get_context("spawn")
        with ProcessPoolExecutor(min(int(workers), len(names)), mp_context=context) as pool:
            compiled = sum(pool.map(_run, [[name] for name in names]))
    cache_dir = numba.config.CACHE_DIR or None
    return PrecompileResult(tuple(names), compiled, time.perf_counter() - start, cache_dir)

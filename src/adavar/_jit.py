"""Numba entry points with the project's defaults (on-disk cache, no fast-math by default).

Threads. The parallel kernels run on Numba's threading layer. Two settings make them
behave on a machine that is doing something else too:

- ``OMP_WAIT_POLICY=PASSIVE`` (set here unless the environment sets it): a worker thread
  that has finished its share sleeps instead of spinning, so it does not take a core from
  another process, nor from the thread that still works when a core is busy;
- ``ADAVAR_THREADS=N``: the number of threads of every parallel kernel (default: Numba's,
  the number of cores; ``NUMBA_NUM_THREADS`` caps it). ``ADAVAR_THREADS=1`` runs everything
  on one thread.
"""

from __future__ import annotations

import os

# before the OpenMP runtime starts (it reads the policy once, when Numba loads it)
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numba

__all__ = ["get_num_threads", "jit", "parallel_jit", "prange", "thread_setting"]

prange = numba.prange
get_num_threads = numba.get_num_threads


def thread_setting() -> int | None:
    """``ADAVAR_THREADS`` as a thread count (None when unset), applied to Numba."""
    text = os.environ.get("ADAVAR_THREADS", "").strip()
    if not text:
        return None
    try:
        count = int(text)
    except ValueError:
        count = 0
    if count < 1:
        from adavar.errors import AdavarInputError

        raise AdavarInputError(
            f"ADAVAR_THREADS={text!r} is not a positive whole number: give e.g. "
            "ADAVAR_THREADS=1, or unset it for every core"
        )
    count = min(count, numba.config.NUMBA_NUM_THREADS)
    numba.set_num_threads(count)
    return count


def jit(*args, **kwargs):
    """``numba.njit`` with ``cache=True`` so compiled kernels persist between runs."""
    kwargs.setdefault("cache", True)
    return numba.njit(*args, **kwargs)


def parallel_jit(*args, **kwargs):
    """``jit`` with ``parallel=True`` (``ADAVAR_SERIAL_KERNELS=1``: compiled serially)."""
    kwargs.setdefault("parallel", os.environ.get("ADAVAR_SERIAL_KERNELS", "") != "1")
    return jit(*args, **kwargs)


thread_setting()

"""Numba entry points with the project's defaults (on-disk cache, no fast-math by default)."""

from __future__ import annotations

import numba

__all__ = ["get_num_threads", "jit", "parallel_jit", "prange"]

prange = numba.prange
get_num_threads = numba.get_num_threads


def jit(*args, **kwargs):
    """``numba.njit`` with ``cache=True`` so compiled kernels persist between runs."""
    kwargs.setdefault("cache", True)
    return numba.njit(*args, **kwargs)


def parallel_jit(*args, **kwargs):
    """``jit`` with ``parallel=True``."""
    kwargs.setdefault("parallel", True)
    return jit(*args, **kwargs)

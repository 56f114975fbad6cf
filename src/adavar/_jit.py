"""Numba entry points with the project's defaults (on-disk cache, no fast-math by default).

Threads. The parallel kernels run on Numba's threading layer. Two settings make them
behave on a machine that is doing something else too:

- ``OMP_WAIT_POLICY=PASSIVE`` (set here unless the environment sets it): a worker thread
  that has finished its share sleeps instead of spinning, so it does not take a core from
  another process, nor from the thread that still works when a core is busy;
- ``ADAVAR_THREADS=N``: the number of threads of every parallel kernel (default: Numba's,
  the number of cores; ``NUMBA_NUM_THREADS`` caps it). ``ADAVAR_THREADS=1`` runs everything
  on one thread.

Compilation. ``NUMBA_OPT=2`` (set here unless the environment sets it) has LLVM optimise
at -O2 rather than Numba's -O3: the kernels compile about 18 % faster on a first run
(an empty cache: 27.4 -> 22.5 s for every kernel of ``adavar demo`` in one process) and
ran as fast in every benchmark measured (``docs/benchmarks.md``, ninth pass). Numba reads
the setting at each compilation, so it applies to other Numba code of the same process
too; ``NUMBA_OPT=3`` in the environment restores Numba's default.
"""

from __future__ import annotations

import contextlib
import os
import types
from collections.abc import Iterator

# before the OpenMP runtime starts (it reads the policy once, when Numba loads it)
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
os.environ.setdefault("NUMBA_OPT", "2")

import numba

__all__ = [
    "SERIAL_WORK",
    "TwinKernel",
    "compilations",
    "get_num_threads",
    "jit",
    "parallel_jit",
    "prange",
    "read_only",
    "thread_setting",
]

prange = numba.prange
get_num_threads = numba.get_num_threads


def thread_setting() -> int | None:
    """``ADAVAR_THREADS`` as a thread count (None when unset), applied to Numba."""
    from adavar.settings import requested_threads

    count = requested_threads()
    if count is None:
        return None
    count = min(count, numba.config.NUMBA_NUM_THREADS)
    numba.set_num_threads(count)
    return count


@contextlib.contextmanager
def compilations() -> Iterator[list]:
    """Record the kernels this process compiles meanwhile (not those loaded from the cache).

    Yields a list that holds one entry per compilation once the block has run: empty
    when every kernel came from the on-disk cache (a warm cache).
    """
    from numba.core import event

    with event.install_recorder("numba:compile") as recorder:
        yield recorder.buffer


def _one_signature_per_type(dispatcher):
    """Compile calls from other kernels for plain types, not for the constants passed.

    A kernel that calls ``f(a, 0)`` makes Numba compile ``f`` for ``Literal[int](0)`` as
    well as for ``int64``: a second copy of the same machine code, and first-run time for
    nothing. The argument types of such calls are widened to their non-literal types
    (every kernel here takes plain numbers), so each callee compiles once per array layout.
    """
    base = type(dispatcher).get_call_template

    def get_call_template(args, kws):
        args = tuple(numba.types.unliteral(a) for a in args)
        kws = {k: numba.types.unliteral(v) for k, v in kws.items()}
        return base(dispatcher, args, kws)

    dispatcher.get_call_template = get_call_template
    return dispatcher


def jit(*args, **kwargs):
    """``numba.njit`` with ``cache=True`` so compiled kernels persist between runs.

    Calls from other kernels compile for plain argument types only
    (:func:`_one_signature_per_type`).
    """
    kwargs.setdefault("cache", True)
    if args and callable(args[0]):
        return _one_signature_per_type(numba.njit(**kwargs)(args[0]))
    decorate = numba.njit(*args, **kwargs)
    return lambda func: _one_signature_per_type(decorate(func))


def read_only(values, dtype=None):
    """``values`` as a contiguous, read-only array (a view when no copy is needed).

    Kernels read their inputs through read-only views so that a read-only array of the
    caller (a memory map, a frozen result) and a writable one share one compiled version.
    """
    import numpy as np

    view = np.ascontiguousarray(values, dtype=dtype).view()
    view.flags.writeable = False
    return view


#: work (inner-loop steps, about 5-20 ns each) below which a twin kernel runs serially:
#: under about a millisecond of arithmetic, waking the thread pool costs more than it saves
#: (and on a busy machine a descheduled worker holds up the whole call)
SERIAL_WORK = 1 << 18


class TwinKernel:
    """A kernel compiled twice from one source: with ``prange`` parallel, and serially.

    ``kernel(*args)`` runs the parallel version; ``kernel.run(work, *args)`` picks the
    serial one when ``work < SERIAL_WORK``, when one thread is set (``ADAVAR_THREADS=1``,
    :func:`numba.set_num_threads`) or when ``ADAVAR_SERIAL_KERNELS=1``. Each version is
    compiled on its first call only, so small inputs (and a first run on them) never pay
    for compiling the parallel one; the two have separate on-disk cache entries.
    """

    def __init__(self, func, kwargs):
        self.py_func = func
        self.parallel = jit(parallel=True, **kwargs)(func)
        twin = types.FunctionType(
            func.__code__, func.__globals__, func.__name__, func.__defaults__, func.__closure__
        )
        # a name of its own: Numba's cache keys on the function's name, not on its options
        twin.__qualname__ = func.__qualname__ + "__serial"
        twin.__module__ = func.__module__
        twin.__doc__ = func.__doc__
        # a parallel region divides as NumPy does (inf/nan, no exception): so does the twin
        self.serial = jit(parallel=False, **{"error_model": "numpy", **kwargs})(twin)
        self.__doc__ = func.__doc__
        self.__name__ = func.__name__

    def __call__(self, *args):
        return self.parallel(*args)

    def run(self, work, *args):
        """Run on the version that suits ``work`` (see the class notes)."""
        serial = (
            work < SERIAL_WORK
            or numba.get_num_threads() == 1
            or os.environ.get("ADAVAR_SERIAL_KERNELS", "") == "1"
        )
        return (self.serial if serial else self.parallel)(*args)


def parallel_jit(*args, **kwargs):
    """A :class:`TwinKernel`: ``jit`` with ``parallel=True`` and a serial twin."""
    if args and callable(args[0]):
        return TwinKernel(args[0], kwargs)
    return lambda func: TwinKernel(func, kwargs)


thread_setting()

"""Numba entry points with the project's defaults (on-disk cache, no fast-math by default).

Threads. The kernels that split their work (:class:`ThreadedKernel`) are compiled once,
serially and ``nogil``, and run in parts on a pool of Python threads; the operating
system schedules those, so on a machine that is doing something else too no thread spins
while it waits, and a thread that a busy core slows down takes fewer parts.

- ``ADAVAR_THREADS=N``: the number of threads of every such kernel (default: Numba's
  thread count, the number of cores; ``NUMBA_NUM_THREADS`` caps it).
  ``ADAVAR_THREADS=1`` runs everything on one thread; so does
  ``ADAVAR_SERIAL_KERNELS=1``.
- No kernel uses Numba's ``parallel=True`` (OpenMP): nothing here depends on
  ``OMP_WAIT_POLICY``, and importing adavar changes no environment variable.

Compilation. The ``adavar`` command sets ``NUMBA_OPT=2`` for its own process (unless the
environment sets it, :func:`adavar.cli.run`): LLVM optimises at -O2 rather than Numba's
-O3, and the kernels compile about 18 % faster on a first run and ran as fast in every
benchmark measured. The library leaves Numba's setting as the user's process has it.

Caching. Every kernel is compiled with ``cache=True`` and only through Numba's public API:
a first run compiles what it reaches and stores it on disk; ``adavar precompile``
compiles every kernel ahead of a first analysis (:mod:`adavar.pipeline.precompile`).
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterator

import numba

__all__ = [
    "ITEMS_PER_THREAD",
    "SERIAL_WORK",
    "ThreadedKernel",
    "compilations",
    "get_num_threads",
    "grouped_items",
    "jit",
    "prange",
    "read_only",
    "thread_setting",
    "threaded_jit",
    "work_items",
]

prange = numba.prange
get_num_threads = numba.get_num_threads


def thread_setting() -> int | None:
    """``ADAVAR_THREADS`` as a thread count (None when unset), applied to Numba."""
    from adavar.core.settings import requested_threads

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


def jit(*args, **kwargs):
    """``numba.njit`` with ``cache=True``: compiled kernels persist between runs.

    Only Numba's documented options are used. ``adavar precompile`` (or any first call)
    fills the on-disk cache; later processes load the machine code from there.
    """
    kwargs.setdefault("cache", True)
    if args and callable(args[0]):
        return numba.njit(**kwargs)(args[0])
    return numba.njit(*args, **kwargs)


def read_only(values, dtype=None):
    """``values`` as a contiguous, read-only array (a view when no copy is needed).

    Kernels read their inputs through read-only views so that a read-only array of the
    caller (a memory map, a frozen result) and a writable one share one compiled version.
    """
    import numpy as np

    view = np.ascontiguousarray(values, dtype=dtype).view()
    view.flags.writeable = False
    return view


#: work (inner-loop steps, about 5-20 ns each) below which a threaded kernel runs on the
#: calling thread alone: under about a millisecond of arithmetic, handing parts to other
#: threads costs more than it saves (and on a busy machine a descheduled thread would hold
#: up the whole call)
SERIAL_WORK = 1 << 18


#: work items a threaded kernel's input is cut into, per thread: a thread that a busy core
#: slows down then takes fewer of them instead of holding up the call
ITEMS_PER_THREAD = 4


def work_items(units: int) -> int:
    """Work items for ``units`` indivisible units of work (at least 1)."""
    return int(max(1, min(ITEMS_PER_THREAD * numba.get_num_threads(), units)))


def grouped_items(units: int, least: int = 1) -> tuple[int, int]:
    """``(per, items)``: :func:`work_items` of ``units`` consecutive units, ``per`` units
    each (at least ``least``; the last item may hold fewer)."""
    per = max(int(least), -(-units // work_items(units)))
    return per, -(-units // per)


class _Parts:
    """Items ``0..n-1`` of one call, taken one at a time by whichever thread is free."""

    def __init__(self, kernel, args: tuple, n: int) -> None:
        import threading

        self.kernel, self.args, self.n = kernel, args, n
        self.lock = threading.Lock()
        self.finished = threading.Event()
        self.next = self.done = 0
        self.error: BaseException | None = None

    def stop(self, exc: BaseException) -> None:
        """Start no further item (the items running finish)."""
        with self.lock:
            self.error = self.error or exc
            self.finished.set()

    def work(self) -> None:
        while True:
            with self.lock:
                k = self.next
                if k >= self.n or self.error is not None:
                    return
                self.next = k + 1
            try:
                self.kernel(*self.args, k, k + 1)
            except BaseException as exc:  # re-raised by the calling thread
                self.stop(exc)
                return
            with self.lock:
                self.done += 1
                if self.done == self.n:
                    self.finished.set()


_POOL: dict = {}  # "pool", "size", "pid": the threads that run parts of kernels
_POOL_LOCK = threading.Lock()


def _new_pool_lock() -> None:
    global _POOL_LOCK
    _POOL_LOCK = threading.Lock()  # a child forked while another thread held it


os.register_at_fork(after_in_child=_new_pool_lock)


def _pool(size: int):
    """The process's thread pool for kernel parts, of at least ``size`` threads."""
    from concurrent.futures import ThreadPoolExecutor

    with _POOL_LOCK:  # callers on several threads at once share one pool
        pool = _POOL.get("pool")
        if pool is not None and _POOL["pid"] == os.getpid() and _POOL["size"] >= size:
            return pool
        # a forked child inherits the pool object but not its threads: a new one there;
        # a pool too small (more threads set since) lets its threads end once idle
        if pool is not None and _POOL["pid"] == os.getpid():
            pool.shutdown(wait=False)
        pool = ThreadPoolExecutor(max_workers=size, thread_name_prefix="adavar-kernel")
        _POOL.update(pool=pool, size=size, pid=os.getpid())
        return pool


class ThreadedKernel:
    """A kernel compiled once, serially and ``nogil``, whose items run on several threads.

    The function's last two arguments are the range ``[lo, hi)`` of the items (work units
    that write disjoint parts of the output) it runs. ``kernel.run(work, items, *args)``
    runs items ``0..items-1``: on the calling thread alone when ``work < SERIAL_WORK``,
    when one thread is set (``ADAVAR_THREADS=1``, :func:`numba.set_num_threads`) or when
    ``ADAVAR_SERIAL_KERNELS=1``; else the calling thread and up to ``threads - 1`` pool
    threads each take the next item not yet started until none is left. A thread that a
    busy core slows down therefore takes fewer items rather than holding up the others,
    and no thread spins while it waits. The result does not depend on the thread count:
    each item is computed the same way by whichever thread runs it.

    Numba's ``parallel=True`` (parfors) compiled a second version of every such kernel,
    as long to compile as the serial one (several seconds each on a first run).
    """

    def __init__(self, func, kwargs):
        self.py_func = func
        # divisions as NumPy's (inf/nan, no exception), as the parfors versions had them
        self.kernel = jit(nogil=True, **{"error_model": "numpy", **kwargs})(func)
        self.__doc__ = func.__doc__
        self.__name__ = func.__name__

    def __call__(self, *args):
        """The kernel itself (every argument given, the item range included)."""
        return self.kernel(*args)

    def run(self, work, items, *args):
        """Run items ``0..items-1`` on the threads that suit ``work`` (class notes)."""
        threads = 1
        if work >= SERIAL_WORK and os.environ.get("ADAVAR_SERIAL_KERNELS", "") != "1":
            threads = min(numba.get_num_threads(), items)
        if threads <= 1:
            self.kernel(*args, 0, items)
            return
        parts = _Parts(self.kernel, args, items)
        pool = _pool(threads - 1)
        for _ in range(threads - 1):
            pool.submit(parts.work)
        try:
            parts.work()
            parts.finished.wait()
        except BaseException as exc:  # Ctrl-C: the other threads start no further item
            parts.stop(exc)
            raise
        if parts.error is not None:
            raise parts.error


def threaded_jit(*args, **kwargs):
    """A :class:`ThreadedKernel` (``jit`` options as keywords)."""
    if args and callable(args[0]):
        return ThreadedKernel(args[0], kwargs)
    return lambda func: ThreadedKernel(func, kwargs)


thread_setting()

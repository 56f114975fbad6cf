"""A second process for work that runs beside this one (the demo's realisations, figures).

Light on purpose (standard library only): the command line starts the process before it
imports the modules the work needs, so both processes import at the same time.
"""

from __future__ import annotations

import atexit
import contextlib
import gc
import importlib
import multiprocessing as mp
import os
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any


def _prepare(modules: tuple[str, ...], collect: bool) -> None:
    """In the worker: import ``modules`` now, and exit without the final collection.

    The interpreter's last garbage collection walks every object of the imported
    libraries (0.5 s after a demo); the process's memory is released on exit anyway.
    ``collect=False`` turns the automatic collection off for the process's life.
    """
    if not collect:
        gc.disable()
    for name in modules:
        importlib.import_module(name)
    atexit.register(gc.freeze)


def worker_pool(
    workers: int | None,
    preload: Sequence[str] = (),
    *,
    start: bool = False,
    collect: bool = True,
) -> ProcessPoolExecutor | None:
    """One worker process, or None.

    Parameters
    ----------
    workers : int or None
        1 for none, 2 (or more) for one, None for one where two cores are free to this
        process.
    preload : sequence of str
        Modules the worker imports as it starts, before any work arrives.
    start : bool
        Start the process now (it is otherwise started by the first ``submit``).
    collect : bool
        False turns the worker's automatic garbage collection off (:func:`gc.disable`):
        for a bounded piece of work, where the collector's passes over every object of
        NumPy, SciPy, Numba and Matplotlib cost more than the few cycles they free.

    Returns
    -------
    ProcessPoolExecutor or None
        A pool of one process started by ``spawn``; the caller shuts it down. None where
        a pool cannot start (no ``fork``/``spawn`` allowed, no semaphores): the work then
        runs in the caller's process.
    """
    if workers is None:
        affinity = getattr(os, "sched_getaffinity", None)  # Linux; elsewhere every core
        cores = len(affinity(0)) if affinity is not None else os.cpu_count() or 1
        workers = 2 if cores >= 2 else 1
    if workers < 2:
        return None
    try:
        # spawn: a fresh interpreter, safe whatever threads (Numba's, OpenMP's) this one runs
        pool = ProcessPoolExecutor(
            max_workers=1, mp_context=mp.get_context("spawn"), initializer=_prepare,
            initargs=(tuple(preload), bool(collect)),
        )  # fmt: skip
        if start:
            pool.submit(int)  # the process is started by a first task: a trivial one
    except (OSError, ImportError, NotImplementedError, RuntimeError):
        return None
    return pool


class SharedJobs:
    """Jobs shared by a worker process and this one, results in the jobs' order.

    Every job is submitted to ``pool`` in order (None: no worker, every job runs here).
    :meth:`results` runs here, from the last, the jobs the worker has not started
    (``Future.cancel`` succeeds only for those), waits for the others, and runs here any
    job of a worker that died. Whichever process runs a job, its result is the same.

    Parameters
    ----------
    pool : ProcessPoolExecutor or None
        The worker.
    func : callable
        Module-level (the worker receives it by reference).
    jobs : sequence of tuple
        The arguments of each call.
    """

    def __init__(self, pool: Any, func: Callable[..., Any], jobs: Sequence[tuple[Any, ...]]):
        self.func = func
        self.jobs = [tuple(job) for job in jobs]
        self.futures: list[Future[Any] | None] = []
        for job in self.jobs:
            future = None
            if pool is not None:
                with contextlib.suppress(BrokenProcessPool, RuntimeError):  # dead or shut
                    future = pool.submit(func, *job)
            self.futures.append(future)

    def wait_first(self) -> None:
        """Wait for the first job (a failure shows again in :meth:`results`)."""
        if self.futures and self.futures[0] is not None:
            with contextlib.suppress(Exception):
                self.futures[0].result()

    def results(self) -> list[Any]:
        """Every job's result, in order."""
        out: list[Any] = [None] * len(self.jobs)
        here = [False] * len(self.jobs)
        for k in range(len(self.jobs) - 1, -1, -1):
            future = self.futures[k]
            if future is not None and not future.cancel():  # started, or queued in the pipe
                break
            out[k], here[k] = self.func(*self.jobs[k]), True
        for k, future in enumerate(self.futures):
            if here[k]:
                continue
            try:
                if future is None:  # could not be submitted
                    raise BrokenProcessPool
                out[k] = future.result()
            except BrokenProcessPool:  # the worker died (killed, out of memory)
                out[k] = self.func(*self.jobs[k])
        return out

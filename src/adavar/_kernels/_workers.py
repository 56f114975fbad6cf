"""A second process for work that runs beside this one (the demo's realisations, figures).

Light on purpose (standard library only): the command line starts the process before it
imports the modules the work needs, so both processes import at the same time.
"""

from __future__ import annotations

import importlib
import multiprocessing as mp
import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any


def _prepare(modules: tuple[str, ...]) -> None:
    """In the worker: import ``modules`` now, before any work arrives."""
    for name in modules:
        importlib.import_module(name)


def free_cores() -> int:
    """2 where two cores are free to this process, else 1 (a second process's worth)."""
    affinity = getattr(os, "sched_getaffinity", None)  # Linux; elsewhere every core
    cores = len(affinity(0)) if affinity is not None else os.cpu_count() or 1
    return 2 if cores >= 2 else 1


def worker_pool(
    workers: int | None,
    preload: Sequence[str] = (),
    *,
    start: bool = False,
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

    Returns
    -------
    ProcessPoolExecutor or None
        A pool of one process started by ``spawn``; the caller shuts it down. None where
        a pool cannot start (no ``fork``/``spawn`` allowed, no semaphores): the work then
        runs in the caller's process.
    """
    if workers is None:
        workers = free_cores()
    if workers < 2:
        return None
    try:
        # spawn: a fresh interpreter, safe whatever threads (Numba's, OpenMP's) this one runs
        pool = ProcessPoolExecutor(
            max_workers=1, mp_context=mp.get_context("spawn"), initializer=_prepare,
            initargs=(tuple(preload),),
        )  # fmt: skip
        if start:
            pool.submit(int)  # the process is started by a first task: a trivial one
    except (OSError, ImportError, NotImplementedError, RuntimeError):
        return None
    return pool


class SharedJobs:
    """Jobs shared by a worker process and this one, results in the jobs' order.

    The worker takes the jobs from the first on, one at a time (a feeder thread here
    submits the next when the previous is done, so none waits in the pool's queue);
    :meth:`results` runs here the jobs from the last on, until the two meet, then waits
    for the worker's last one. Neither process idles while a job is left (but for the
    last job of the worker), and a worker that dies leaves its job and those it did not
    reach to this process. Without a pool (None) every job runs here. Whichever process
    runs a job, its result is the same.

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
        self._out: list[Any] = [None] * len(self.jobs)
        self._lost: list[int] = []  # jobs the worker took but could not finish
        self._error: BaseException | None = None
        self._lock = threading.Lock()
        self._front, self._back = 0, len(self.jobs)
        self._first = threading.Event()
        self._feeder: threading.Thread | None = None
        if pool is None or not self.jobs:
            self._first.set()
            return
        self._feeder = threading.Thread(
            target=self._feed, args=(pool,), name="adavar-worker-feeder", daemon=True
        )
        self._feeder.start()

    def _take(self, front: bool) -> int | None:
        with self._lock:
            if self._front >= self._back:
                return None
            if front:
                self._front += 1
                return self._front - 1
            self._back -= 1
            return self._back

    def _feed(self, pool: Any) -> None:
        try:
            while (k := self._take(front=True)) is not None:
                try:
                    future: Future[Any] = pool.submit(self.func, *self.jobs[k])
                except (BrokenProcessPool, RuntimeError):  # dead, or shut down
                    self._lost.append(k)
                    return
                try:
                    self._out[k] = future.result()
                except BrokenProcessPool:  # the worker died (killed, out of memory)
                    self._lost.append(k)
                    return
                except BaseException as exc:  # a real error: results() raises it
                    self._error = exc
                    return
                finally:
                    self._first.set()
        finally:
            self._first.set()

    def wait_first(self) -> None:
        """Wait until the worker has finished (or failed) its first job."""
        self._first.wait()

    def results(self) -> list[Any]:
        """Every job's result, in order."""
        while (k := self._take(front=False)) is not None:
            self._out[k] = self.func(*self.jobs[k])
        if self._feeder is not None:
            self._feeder.join()
        if self._error is not None:
            raise self._error
        for k in self._lost:
            self._out[k] = self.func(*self.jobs[k])
        return self._out

"""Where the tasks of ``adavar batch`` run: no cluster, a ``distributed.LocalCluster``, or
the workers of a running ``dask scheduler``; and the wait for their results, which gives up
when the cluster has had no worker for ``worker_timeout`` seconds (every worker died or
left) instead of waiting forever.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import time
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

from adavar.core.errors import AdavarInputError

__all__ = [
    "DEFAULT_WORKER_TIMEOUT",
    "WORKERS_PER_CORE",
    "WORKER_MEMORY",
    "check_workers",
    "connect",
    "gather",
    "max_workers",
    "n_workers",
]

#: Seconds a batch waits on a cluster without any worker before it gives up.
DEFAULT_WORKER_TIMEOUT = 120.0
#: Worker processes of a LocalCluster per core, at most: the tasks are single-threaded and
#: CPU-bound (a little of their time is reading the file), so more only add memory and
#: contention.
WORKERS_PER_CORE = 2
#: Bytes of memory a LocalCluster worker needs, at least: 160 MiB once it has imported
#: adavar, 220 MiB after the report of a 1e5-sample record (measured with
#: distributed 2025, Python 3.11); a longer record needs more.
WORKER_MEMORY = 256 * 2**20
#: A scheduler address: optional protocol, host (name, IPv4 or [IPv6]) and port.
_ADDRESS = re.compile(r"^(?:[a-z][a-z0-9+]*://)?(?:\[[0-9a-fA-F:.]+\]|[^\s:/\[\]]+):\d{1,5}$")
#: Seconds between two looks for finished tasks, and between two counts of the workers.
_POLL_S = 0.1
_WORKERS_POLL_S = 1.0


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())


def check_worker_timeout(worker_timeout: Any) -> float:
    """``worker_timeout`` as a positive number of seconds.

    Raises
    ------
    AdavarInputError
        Not a positive finite number.
    """
    try:
        value = float(worker_timeout)
    except (TypeError, ValueError):
        value = float("nan")
    if isinstance(worker_timeout, bool) or not (0 < value < float("inf")):
        raise AdavarInputError(
            f"worker_timeout must be a positive number of seconds, got {worker_timeout!r}"
        )
    return value


def _cores() -> int:
    affinity = getattr(os, "sched_getaffinity", None)  # Linux; elsewhere every core
    return len(affinity(0)) if affinity is not None else os.cpu_count() or 1


def max_workers() -> tuple[int, str]:
    """The most worker processes a LocalCluster of this machine may start, and why.

    Returns
    -------
    int
        :data:`WORKERS_PER_CORE` per core this process may use, and no more than the free
        memory holds at :data:`WORKER_MEMORY` each (at least 1).
    str
        What bounds it (the cores, the free memory), for a message.
    """
    from adavar.io.sources import available_memory

    cores = _cores()
    most = WORKERS_PER_CORE * cores
    why = f"{cores} core{'s' if cores != 1 else ''} ({WORKERS_PER_CORE} workers a core)"
    free = available_memory()
    if free is not None and free // WORKER_MEMORY < most:
        most = int(free // WORKER_MEMORY)
        why = (f"{free / 2**30:.1f} GiB of free memory (about {WORKER_MEMORY // 2**20} MiB "
               "a worker)")  # fmt: skip
    return max(1, most), why


def check_workers(workers: Any) -> int | None:
    """``workers`` (None, or a positive integer this machine can start), before any work.

    Raises
    ------
    AdavarInputError
        Not a positive integer, or more workers than :func:`max_workers` (each is a
        process: a million of them fill the memory long before the first task runs).
    """
    if workers is None:
        return None
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise AdavarInputError(f"workers must be a positive integer, got {workers!r}")
    most, why = max_workers()
    if workers > most:
        raise AdavarInputError(
            f"--workers {workers} is more worker processes than this machine can run: its "
            f"{why} allow {most}; give --workers {most} or fewer, or --scheduler ADDRESS "
            "for a cluster of several machines"
        )
    return workers


@contextlib.contextmanager
def connect(
    scheduler: str | None, workers: int | None, timeout: float
) -> Iterator[tuple[Any, str]]:
    """A ``distributed.Client`` (None: in process) and a description of where it runs."""
    if scheduler is not None and workers is not None:
        raise AdavarInputError(
            "give --scheduler ADDRESS (an existing cluster) or --workers N (a local one), not both"
        )
    if scheduler is None and workers is None:
        yield None, "in this process (no cluster)"
        return
    from distributed import Client, LocalCluster

    if workers is not None:
        check_workers(workers)
        # one single-threaded process per core: the numba kernels must not oversubscribe.
        # No dashboard; the scheduler's HTTP server (health, metrics) on a free local port:
        # by default it takes port 8787 on every interface, and a second batch running
        # meanwhile printed a warning that the port was in use
        with LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
            silence_logs=logging.ERROR, env={"NUMBA_NUM_THREADS": "1"},
        ) as cluster, Client(cluster, set_as_default=False) as client:  # fmt: skip
            yield (
                client,
                f"on a LocalCluster of {workers} worker process{'es' if workers > 1 else ''}",
            )
        return
    address = str(scheduler)
    by_file = address.lower().endswith(".json") and Path(address).is_file()
    hint = (
        "check that 'dask scheduler' runs there and that this machine can reach it (the "
        "address it prints, e.g. tcp://HOST:8786, or its --scheduler-file), or use "
        "--workers N for a local cluster"
    )
    if not by_file and not _ADDRESS.match(address):
        raise AdavarInputError(
            f"--scheduler {address!r} is not a scheduler address: give the address 'dask "
            "scheduler' prints (tcp://HOST:PORT, e.g. tcp://10.0.0.5:8786) or the path of its "
            "--scheduler-file JSON"
        )
    try:
        if by_file:
            client = Client(scheduler_file=address, timeout=timeout, set_as_default=False)
        else:
            client = Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        raise AdavarInputError(
            f"cannot connect to the dask scheduler at {address} ({_one_line(exc)}): {hint}"
        ) from None
    with client:
        try:
            client.wait_for_workers(1, timeout=timeout)
        except (OSError, TimeoutError) as exc:
            raise AdavarInputError(
                f"the dask scheduler at {address} has no worker ({_one_line(exc) or 'timed out'}"
                f"): start some with 'dask worker {address} --nthreads 1', or use --workers N"
            ) from None
        n = len(client.scheduler_info().get("workers", {}))
        yield client, f"on the scheduler {address} ({n} worker{'s' if n != 1 else ''} at the start)"


def n_workers(client: Any) -> int:
    """How many workers the client's scheduler has now (0 if it cannot be asked)."""
    try:
        try:
            info = client.scheduler_info(n_workers=1)  # totals only: cheap on a big cluster
        except TypeError:  # distributed before 2025: no n_workers
            info = client.scheduler_info()
        return int(info.get("n_workers", len(info.get("workers") or {})))
    except Exception:  # a scheduler gone or unreachable: no worker either
        return 0


def _task_failure(exc: Any, connected: bool = True) -> str:
    """The row's message of a task the cluster gave up on (one line, no task key).

    ``connected``: whether the client still had its scheduler. A task cancelled while it
    had none was lost with the scheduler, whatever reason dask gives (it sometimes says
    "unknown" when the cancellation arrives before the lost connection is noticed).
    """
    text = _one_line(exc)
    lost = "scheduler-connection-lost" in text or "lost the connection to the scheduler" in text
    if lost or (not connected and "Cancelled" in type(exc).__name__):
        return (
            "not analysed: the connection to the dask scheduler was lost (it stopped, or "
            "the network failed): restart it and rerun with the same --out (the finished "
            "files are skipped)"
        )
    return f"the task failed on the cluster: {type(exc).__name__}: {text}"


def gather(
    client: Any,
    function: Callable[..., dict[str, Any]],
    jobs: Mapping[int, tuple[Any, ...]],
    finished: Callable[[int, dict[str, Any]], None],
    failed: Callable[[int, str], dict[str, Any]],
    worker_timeout: float,
) -> list[int]:
    """Run ``function(*jobs[i])`` on the cluster, calling ``finished(i, row)`` as each ends.

    A task the cluster gave up on (a lost worker, after the scheduler's retries) ends with
    ``failed(i, message)``. When the scheduler has had no worker for ``worker_timeout``
    seconds, the tasks still pending are cancelled and returned (their rows are the
    caller's).

    Parameters
    ----------
    client : distributed.Client
    function : callable
        The task; returns the row of its file.
    jobs : mapping
        Index -> the task's arguments.
    finished : callable
        Called with the index and the row of every task that ended.
    failed : callable
        The row of a task that failed on the cluster, from its index and a message.
    worker_timeout : float
        Seconds without any worker before giving up.

    Returns
    -------
    list of int
        The indices of the tasks that never ran (empty unless the workers were gone).
    """
    from distributed import as_completed

    futures = {client.submit(function, *args, pure=False): i for i, args in jobs.items()}
    pending = set(futures)
    # with_results: the rows are fetched on the client's loop, so a row lost with its
    # worker (the task runs again) never blocks this loop and its count of the workers
    done = as_completed(list(futures), loop=client.loop, with_results=True,
                        raise_errors=False)  # fmt: skip
    seen_worker = next_count = time.monotonic()
    while pending:
        batch = done.next_batch(block=False)
        for future, result in batch:
            i = futures[future]
            if future.status == "error" or not isinstance(result, dict):
                # a lost worker, a task the cluster gave up on
                exc = result[1] if isinstance(result, tuple) and len(result) > 1 else result
                connected = getattr(client, "status", "running") == "running"
                row = failed(i, _task_failure(exc, connected))
            else:
                row = result
            pending.discard(future)
            finished(i, row)
            future.release()
        if not batch:
            time.sleep(_POLL_S)
        now = time.monotonic()
        if now < next_count:
            continue
        next_count = now + min(_WORKERS_POLL_S, worker_timeout / 4)
        if n_workers(client) > 0:
            seen_worker = now
        elif now - seen_worker >= worker_timeout and pending:
            left = sorted(futures[f] for f in pending)
            with contextlib.suppress(Exception):
                client.cancel(list(pending))
            return left
    return []

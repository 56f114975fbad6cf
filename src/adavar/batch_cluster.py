"""Where the tasks of ``adavar batch`` run: no cluster, a ``distributed.LocalCluster``, or
the workers of a running ``dask scheduler``; and the wait for their results, which gives up
when the cluster has had no worker for ``worker_timeout`` seconds (every worker died or
left) instead of waiting forever.
"""

from __future__ import annotations

import contextlib
import logging
import re
import time
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

from adavar.errors import AdavarInputError

__all__ = ["DEFAULT_WORKER_TIMEOUT", "connect", "gather", "n_workers"]

#: Seconds a batch waits on a cluster without any worker before it gives up.
DEFAULT_WORKER_TIMEOUT = 120.0
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
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise AdavarInputError(f"workers must be a positive integer, got {workers!r}")
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
                row = failed(i, f"the task failed on the cluster: {type(exc).__name__}: "
                                f"{_one_line(exc)}")  # fmt: skip
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

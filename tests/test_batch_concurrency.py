"""adavar batch under load and under concurrent use (issue 40, items 5, 9 and 14).

- ``--workers N`` beyond what the machine runs is a one-line error before any process
  starts (``--workers 1000000`` printed nothing and grew the memory for minutes);
- two runs into one ``--out`` at once: the second stops at once, naming the first one's pid
  (they lost each other's rows: the summary kept one run's, the state file the other's);
  a killed run leaves no stale lock;
- a dask scheduler that dies mid-batch: one line per file, no traceback of dask's logging
  before adavar's error.

The last test starts a real ``dask scheduler`` and ``dask worker`` (about 10 s).
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import adavar.io.sources
from adavar import simulate
from adavar.core.errors import AdavarInputError
from adavar.io.writers import PAUSE_BEFORE_RENAME_ENV
from adavar.pipeline import batch_cluster
from adavar.pipeline.batch import run_batch
from adavar.pipeline.batch_state import BATCH_LOCK, BATCH_STATE, folder_name, locked

from .cli_helpers import assert_one_line_error, run

RATE = 100.0
BATCH = ["--rate", str(RATE), "--units", "deg/s", "--taus", "octave", "--no-html"]


@pytest.fixture
def gyros(tmp_path):
    paths = []
    for k in range(2):
        paths.append(tmp_path / f"gyro{k}.npy")
        np.save(paths[-1], simulate.white(4000, rate=RATE, seed=40 + k))
    return paths


def _no_cluster(*args, **kwargs):
    raise AssertionError("a LocalCluster was started")


# --------------------------------------------------------------------------------------
# 5. --workers bounded by the cores and the memory
# --------------------------------------------------------------------------------------


def test_a_million_workers_is_an_error_before_any_process(capsys, gyros, tmp_path, monkeypatch):
    import distributed

    monkeypatch.setattr(distributed, "LocalCluster", _no_cluster)
    out = tmp_path / "out"
    start = time.monotonic()
    code, stdout, err = run(capsys, ["batch", str(gyros[0]), *BATCH, "--out", str(out),
                                     "--workers", "1000000"])  # fmt: skip
    most, _ = batch_cluster.max_workers()
    assert_one_line_error(code, stdout, err, "--workers 1000000", f"--workers {most} or fewer",
                          "core")  # fmt: skip
    assert time.monotonic() - start < 5 and not out.exists()
    with pytest.raises(AdavarInputError, match="--workers"):
        run_batch(gyros, out=out, options={"units": "deg/s", "rate": RATE}, workers=most + 1)
    assert not out.exists()


def test_workers_are_bounded_by_the_free_memory(capsys, gyros, tmp_path, monkeypatch):
    import distributed

    monkeypatch.setattr(distributed, "LocalCluster", _no_cluster)
    monkeypatch.setattr(batch_cluster, "_cores", lambda: 64)
    monkeypatch.setattr(
        adavar.io.sources, "available_memory", lambda: 3 * batch_cluster.WORKER_MEMORY
    )
    assert batch_cluster.max_workers()[0] == 3
    code, stdout, err = run(capsys, ["batch", str(gyros[0]), *BATCH, "--out",
                                     str(tmp_path / "out"), "--workers", "4"])  # fmt: skip
    assert_one_line_error(code, stdout, err, "GiB of free memory", "--workers 3 or fewer")
    monkeypatch.setattr(adavar.io.sources, "available_memory", lambda: None)  # unknown: cores
    assert batch_cluster.max_workers()[0] == 64 * batch_cluster.WORKERS_PER_CORE


# --------------------------------------------------------------------------------------
# 9. one run at a time into an --out
# --------------------------------------------------------------------------------------


def _wait_for(condition, proc, what, seconds=120):
    deadline = time.monotonic() + seconds
    while not condition():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, what
        time.sleep(0.05)


def test_a_second_run_into_the_same_out_stops_naming_the_first(capsys, gyros, tmp_path):
    out = tmp_path / "out"
    env = {**os.environ, PAUSE_BEFORE_RENAME_ENV: "120"}  # the first run holds the folder
    first = subprocess.Popen(
        [sys.executable, "-m", "adavar.cli", "batch", str(gyros[0]), *BATCH, "--out", str(out)],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:

        def holding():
            with contextlib.suppress(OSError, ValueError):
                return json.loads((out / BATCH_LOCK).read_text())["pid"] == first.pid
            return False

        _wait_for(holding, first, "the first run never took the folder")
        _wait_for(lambda: any(p.name.startswith(".gyro0-") for p in out.iterdir()), first,
                  "the first run never started its file")  # fmt: skip
        code, stdout, err = run(capsys, ["batch", str(gyros[1]), *BATCH, "--out", str(out)])
        message = (f"{out} is being written by another adavar run (pid {first.pid}); wait "
                   "for it or choose another --out")  # fmt: skip
        assert_one_line_error(code, stdout, err, message)
        assert not (out / "summary.csv").exists()  # the second run wrote nothing
        state = json.loads((out / BATCH_STATE).read_text(encoding="utf-8"))
        assert [e["file"] for e in state["files"].values()] == [str(gyros[0])]
        first.send_signal(signal.SIGKILL)  # a run killed outright: its lock goes with it
        first.communicate(timeout=60)
    finally:
        if first.poll() is None:
            first.kill()
            first.communicate()
    code, stdout, err = run(capsys, ["batch", str(gyros[1]), *BATCH, "--out", str(out),
                                     "--json"])  # fmt: skip
    assert code == 0, err
    payload = json.loads(stdout)
    assert [row["status"] for row in payload["rows"]] == ["ok"]
    assert any("removed 1 temporary folder(s)" in note for note in payload["notes"])
    assert (out / folder_name(gyros[1]) / "result.json").is_file()


def test_the_lock_is_held_for_the_whole_run_and_released(gyros, tmp_path):
    out = tmp_path / "out"
    seen = []

    def progress(done, total, row):  # during the run: a second holder is refused
        with pytest.raises(AdavarInputError, match=rf"pid {os.getpid()}\)"), locked(out):
            pass
        seen.append(done)

    run_batch(gyros, out=out, options={"units": "deg/s", "rate": RATE, "taus": "octave"},
              html=False, progress=progress)  # fmt: skip
    assert seen == [1, 2]
    with locked(out):  # released at the end
        pass


# --------------------------------------------------------------------------------------
# 14. a dask scheduler that dies: one line per file, no traceback
# --------------------------------------------------------------------------------------


@contextlib.contextmanager
def _dask(folder):
    """A ``dask scheduler`` and one ``dask worker`` as subprocesses on 127.0.0.1 (their
    own process groups), killed at the end; yields (scheduler process, scheduler file)."""
    dask = Path(sys.executable).parent / "dask"
    scheduler_file = folder / "scheduler.json"
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    procs = []
    with open(folder / "dask.log", "w") as log:
        try:
            procs.append(subprocess.Popen(
                [dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                 "--scheduler-file", scheduler_file],
                env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
            ))  # fmt: skip
            _wait_for(scheduler_file.is_file, procs[0], "the dask scheduler did not start", 60)
            procs.append(subprocess.Popen(
                [dask, "worker", "--scheduler-file", scheduler_file, "--nthreads", "1",
                 "--nworkers", "1", "--host", "127.0.0.1", "--no-dashboard"],
                env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
            ))  # fmt: skip
            # the worker is in: the batch's connect and reconnect timeouts can be short
            _wait_for(lambda: "Register worker" in (folder / "dask.log").read_text(),
                      procs[1], "the dask worker did not start", 60)  # fmt: skip
            yield procs[0], scheduler_file
        finally:
            for proc in reversed(procs):
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()


def test_a_dead_scheduler_gives_one_line_per_file_and_no_traceback(tmp_path):
    files = []
    for k in range(12):
        files.append(tmp_path / f"r{k}.npy")
        np.save(files[-1], simulate.white(200_000, rate=RATE, seed=k))
    out = tmp_path / "out"
    with _dask(tmp_path) as (scheduler, scheduler_file):
        proc = subprocess.Popen(
            [sys.executable, "-m", "adavar.cli", "batch", *map(str, files), "--rate", "100",
             "--units", "deg/s", "--adaptive", "--no-html", "--out", str(out), "--scheduler",
             str(scheduler_file), "--timeout", "3", "--worker-timeout", "10"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        try:
            _wait_for((out / BATCH_STATE).is_file, proc, "the batch never connected")
            scheduler.send_signal(signal.SIGTERM)
            stdout, err = proc.communicate(timeout=120)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
    assert proc.returncode == 1, err  # internal errors: the cluster, not the files
    assert "Traceback" not in err
    assert err.strip() and all(line.startswith("adavar: ") for line in err.splitlines()), err
    lost = [line for line in stdout.splitlines() if line.startswith("  error in ")]
    assert lost and all("connection to the dask scheduler was lost" in line for line in lost)
    assert re.search(r"\d+ failed", stdout)


def test_a_task_cancelled_without_its_scheduler_was_lost_with_it():
    """dask sometimes cancels the futures of a dead scheduler "for reason: unknown" before
    the client notices the lost connection (seen once in the test above): those rows say
    the scheduler was lost, as the others do; a cancellation while connected does not."""
    from concurrent.futures import CancelledError

    from adavar.pipeline.batch_cluster import _task_failure

    class FutureCancelledError(CancelledError):
        pass

    exc = FutureCancelledError("_process_file-5f12 cancelled for reason: unknown.")
    assert "connection to the dask scheduler was lost" in _task_failure(exc, connected=False)
    assert "connection to the dask scheduler was lost" not in _task_failure(exc)

"""What --out writes is safe (tracker issue 14): batch folders stable and unique per file,
reruns that redo what the options need, failures and dropped files never silent, --force
that never deletes a folder adavar did not write, a batch that gives up on a cluster
without workers, no temporaries left by SIGTERM or SIGKILL, and plain CSV that
``pandas.read_csv`` and spreadsheets read as it is.

Tiny records (4000 samples at 100 Hz), octave taus: every test is fast.
"""

from __future__ import annotations

import csv
import json
import logging
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from adavar import simulate
from adavar.io import writers
from adavar.io.writers import OUTPUT_MARKER
from adavar.pipeline import batch
from adavar.pipeline.batch import run_batch
from adavar.pipeline.batch_state import BATCH_STATE, folder_name

from .cli_helpers import assert_one_line_error, run

RATE = 100.0
N = 4000
BATCH = ["--rate", str(RATE), "--units", "deg/s", "--taus", "octave", "--json"]


def _batch(capsys, inputs, out, *extra):
    code, text, err = run(capsys, ["batch", *map(str, inputs), *BATCH, "--out", str(out),
                                   *extra])  # fmt: skip
    return code, (json.loads(text) if text.strip() else None), err


def _by_file(payload):
    return {row["file"]: row for row in payload["rows"]}


def _summary(out):
    with open(out / "summary.csv", encoding="utf-8", newline="") as handle:
        return {row["file"]: row for row in csv.DictReader(handle)}


def _stored(out, name):
    return json.loads((out / name / "result.json").read_text(encoding="utf-8"))


def _listing(folder):
    return sorted(p.name for p in Path(folder).iterdir())


@pytest.fixture
def gyros(tmp_path):
    """a/gyro.npy and b/gyro.npy: the same name in two folders, different data."""
    paths = {}
    for k, sub in enumerate("ab"):
        (tmp_path / sub).mkdir()
        paths[sub] = tmp_path / sub / "gyro.npy"
        np.save(paths[sub], simulate.white(N, rate=RATE, seed=20 + k))
    return paths


@pytest.fixture(scope="module")
def gyro_csv(tmp_path_factory):
    """Two channels with a disturbance (events for adaptive), a time column."""
    path = tmp_path_factory.mktemp("csv") / "imu.csv"
    gx = simulate.white(N, rate=RATE, seed=1)
    gx[2000:2600] *= 6.0
    gy = simulate.white(N, rate=RATE, seed=2)
    lines = ["time,gx,gy"] + [f"{k / RATE!r},{a!r},{b!r}" for k, (a, b) in
                              enumerate(zip(gx.tolist(), gy.tolist(), strict=True))]  # fmt: skip
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


# --------------------------------------------------------------------------------------
# 1. one folder per file, stable and unique; the summary keyed by path
# --------------------------------------------------------------------------------------


def test_two_batches_with_the_same_file_name_keep_both(capsys, gyros, tmp_path):
    out = tmp_path / "out"
    code, first, err = _batch(capsys, [gyros["a"]], out, "--no-html")
    assert code == 0, err
    name_a = first["rows"][0]["name"]
    assert re.fullmatch(r"gyro-[0-9a-f]{6}", name_a) and name_a == folder_name(gyros["a"])
    stamp = (out / name_a / "result.json").stat().st_mtime_ns
    code, second, err = _batch(capsys, [gyros["b"]], out, "--no-html")
    assert code == 0, err
    name_b = second["rows"][0]["name"]
    assert name_b != name_a and (out / name_a).is_dir() and (out / name_b).is_dir()
    assert (out / name_a / "result.json").stat().st_mtime_ns == stamp  # a's folder untouched
    assert _stored(out, name_a)["file"] == str(gyros["a"])
    assert _stored(out, name_b)["file"] == str(gyros["b"])
    # the summary keeps a's row (keyed by its path), marked as not in this run
    summary = _summary(out)
    assert summary[str(gyros["b"])]["status"] == "ok"
    assert summary[str(gyros["a"])]["status"] == "absent"
    assert summary[str(gyros["a"])]["N"] == repr(first["rows"][0]["N"])
    assert second["counts"]["absent"] == 1
    assert any("not among this run's inputs" in note and str(gyros["a"]) in note
               for note in second["notes"])  # fmt: skip
    # both together: the same folders, both done (nothing recomputed, nothing orphaned)
    code, both, err = _batch(capsys, [gyros["a"], gyros["b"]], out, "--no-html")
    assert code == 0, err
    rows = _by_file(both)
    assert [rows[str(gyros[k])]["name"] for k in "ab"] == [name_a, name_b]
    assert [rows[str(gyros[k])]["status"] for k in "ab"] == ["done", "done"]
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == sorted([name_a, name_b])
    assert not both["notes"]


def test_a_symlink_is_the_same_file(capsys, gyros, tmp_path):
    link = tmp_path / "link.npy"
    link.symlink_to(gyros["a"])
    code, payload, err = _batch(capsys, [gyros["a"], link], tmp_path / "out", "--no-html")
    assert code == 0, err
    assert len(payload["rows"]) == 1 and payload["rows"][0]["name"] == folder_name(link)


# --------------------------------------------------------------------------------------
# 4. a rerun redoes what the new options need
# --------------------------------------------------------------------------------------


def test_no_html_then_html_writes_the_report(capsys, gyros, tmp_path):
    out = tmp_path / "out"
    name = folder_name(gyros["a"])
    code, payload, err = _batch(capsys, [gyros["a"]], out, "--no-html")
    assert code == 0, err
    assert not (out / name / "report.html").exists()
    assert _stored(out, name)["outputs"]["html"] is False
    code, payload, err = _batch(capsys, [gyros["a"]], out)
    assert code == 0, err
    assert payload["rows"][0]["status"] == "ok"  # redone: the report was missing
    assert (out / name / "report.html").is_file()
    assert _stored(out, name)["outputs"]["html"] is True
    # with the report there, --no-html needs nothing more: done
    code, payload, err = _batch(capsys, [gyros["a"]], out, "--no-html")
    assert payload["rows"][0]["status"] == "done"
    # an expected output that went missing is written again
    (out / name / "deviation.csv").unlink()
    code, payload, err = _batch(capsys, [gyros["a"]], out, "--no-html")
    assert payload["rows"][0]["status"] == "ok" and (out / name / "deviation.csv").is_file()


# --------------------------------------------------------------------------------------
# 5. a file that turned invalid, a file dropped from the input, a folder deleted
# --------------------------------------------------------------------------------------


def test_a_file_that_turned_invalid_replaces_its_old_folder(capsys, gyros, tmp_path):
    out = tmp_path / "out"
    name = folder_name(gyros["a"])
    code, payload, err = _batch(capsys, [gyros["a"], gyros["b"]], out, "--no-html")
    assert code == 0, err
    broken = simulate.white(N, rate=RATE, seed=3)
    broken[10] = np.nan
    np.save(gyros["a"], broken)
    code, payload, err = _batch(capsys, [gyros["a"], gyros["b"]], out, "--no-html")
    assert code == 2
    row = _by_file(payload)[str(gyros["a"])]
    assert row["status"] == "error" and "NaN" in row["error"]
    stored = _stored(out, name)
    assert stored["status"] == "error" and stored["error"] == row["error"]
    assert stored["summary"]["status"] == "error"
    assert _listing(out / name) == [OUTPUT_MARKER, "result.json"]  # no stale "ok" results
    assert _summary(out)[str(gyros["a"])]["status"] == "error"
    # fixed again: recomputed (an error is never "done")
    np.save(gyros["a"], simulate.white(N, rate=RATE, seed=20))
    code, payload, err = _batch(capsys, [gyros["a"]], out, "--no-html")
    assert code == 0 and payload["rows"][0]["status"] == "ok"


def test_dropped_files_are_reported_and_deleted_folders_forgotten(capsys, gyros, tmp_path):
    out = tmp_path / "out"
    code, _, err = run(capsys, ["batch", str(gyros["a"]), str(gyros["b"]), *BATCH[:-1],
                                "--no-html", "--out", str(out)])  # fmt: skip
    assert code == 0, err
    code, text, err = run(capsys, ["batch", str(gyros["b"]), *BATCH[:-1], "--no-html",
                                   "--out", str(out)])  # fmt: skip
    assert code == 0, err
    assert "1 of earlier runs not in this one" in text
    assert re.search(r"note: 1 file\(s\) of earlier runs are not among this run's inputs.*"
                     + re.escape(str(gyros["a"])), text)  # fmt: skip
    assert _summary(out)[str(gyros["a"])]["status"] == "absent"
    # the user deletes a's folder: a leaves the summary, with a note
    import shutil

    shutil.rmtree(out / folder_name(gyros["a"]))
    code, payload, err = _batch(capsys, [gyros["b"]], out, "--no-html")
    assert list(_summary(out)) == [str(gyros["b"])]
    assert any("forgot 1 file(s)" in note and str(gyros["a"]) in note
               for note in payload["notes"])  # fmt: skip
    state = json.loads((out / BATCH_STATE).read_text(encoding="utf-8"))
    assert list(state["files"]) == [os.path.realpath(gyros["b"])]


def test_an_older_batch_folder_is_adopted(capsys, gyros, tmp_path):
    """A folder of an adavar without stable names (``gyro``) keeps its name, is redone in
    place (another output layout), and no orphan is left."""
    out = tmp_path / "out"
    code, payload, err = _batch(capsys, [gyros["a"]], out, "--no-html")
    name = payload["rows"][0]["name"]
    os.rename(out / name, out / "gyro")
    (out / BATCH_STATE).unlink()
    (out / "gyro" / OUTPUT_MARKER).unlink()
    result = out / "gyro" / "result.json"
    stored = json.loads(result.read_text(encoding="utf-8"))
    stored["name"] = "gyro"
    del stored["outputs"]
    result.write_text(json.dumps(stored), encoding="utf-8")
    code, payload, err = _batch(capsys, [gyros["a"]], out, "--no-html")
    assert code == 0, err
    assert payload["rows"][0]["name"] == "gyro" and payload["rows"][0]["status"] == "ok"
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == ["gyro"]


# --------------------------------------------------------------------------------------
# 6. --force replaces only folders adavar wrote
# --------------------------------------------------------------------------------------


FORCE_COMMANDS = {
    "avar": ["avar", "{csv}", "--column", "gx", "--rate", "100", "--units", "deg/s"],
    "davar": ["davar", "{csv}", "--column", "gx", "--rate", "100", "--units", "deg/s",
              "--window", "1000", "--taus", "octave", "--step", "500"],
    "adaptive": ["adaptive", "{csv}", "--column", "gx", "--rate", "100", "--units", "deg/s",
                 "--lmax", "600", "--lmin", "400", "--taus", "octave", "--step", "500"],
    "compare": ["compare", "--scenario", "1", "--taus", "octave"],
    "demo": ["demo"],
}  # fmt: skip


@pytest.mark.parametrize("command", sorted(FORCE_COMMANDS))
def test_force_never_deletes_a_folder_adavar_did_not_write(capsys, gyro_csv, tmp_path,
                                                           command):  # fmt: skip
    mine = tmp_path / "thesis"
    mine.mkdir()
    (mine / "thesis.tex").write_text("four years of work")
    argv = [a.format(csv=gyro_csv) for a in FORCE_COMMANDS[command]]
    code, out, err = run(capsys, [*argv, "--out", str(mine), "--force"])
    assert_one_line_error(code, out, err, str(mine), "not written by adavar",
                          "remove it yourself")  # fmt: skip
    assert _listing(mine) == ["thesis.tex"]
    assert (mine / "thesis.tex").read_text() == "four years of work"
    assert _listing(tmp_path) == ["thesis"]  # no temporary either


def test_force_replaces_a_folder_adavar_wrote_or_an_empty_one(capsys, gyro_csv, tmp_path):
    out = tmp_path / "out"
    argv = [a.format(csv=gyro_csv) for a in FORCE_COMMANDS["avar"]]
    argv += ["--figures", "none", "--out", str(out)]  # the folders' tables are enough here
    code, _, err = run(capsys, argv)
    assert code == 0, err
    assert OUTPUT_MARKER in _listing(out)  # every folder adavar writes carries the marker
    marker = json.loads((out / OUTPUT_MARKER).read_text(encoding="utf-8"))
    assert marker["pid"] == os.getpid() and marker["written_by"].startswith("adavar ")
    code, _, err = run(capsys, [*argv, "--force"])
    assert code == 0, err
    empty = tmp_path / "empty"
    empty.mkdir()
    code, _, err = run(capsys, [*argv[:-1], str(empty), "--force"])
    assert code == 0, err
    assert "deviation.csv" in _listing(empty)


def test_batch_never_replaces_a_foreign_folder_in_out(capsys, gyros, tmp_path):
    out = tmp_path / "out"
    code, payload, err = _batch(capsys, [gyros["b"]], out, "--no-html")
    assert code == 0, err
    mine = out / folder_name(gyros["a"])  # a user's folder where a's would go
    mine.mkdir()
    (mine / "thesis.tex").write_text("x")
    for extra in ([], ["--force"]):
        code, payload, err = _batch(capsys, [gyros["a"]], out, "--no-html", *extra)
        assert code == 2
        row = payload["rows"][0]
        assert row["status"] == "error" and "not written by adavar" in row["error"]
        assert str(mine) in row["error"] and "\n" not in row["error"]
        assert _listing(mine) == ["thesis.tex"]


# --------------------------------------------------------------------------------------
# 9. a cluster whose workers all died: time out, write the rows done so far
# --------------------------------------------------------------------------------------


#: Held shut by the cluster test: every task but the first waits on it (so that they are
#: still running when the workers go), and is let go at the end.
_GATE = threading.Event()
_FIRST: list[str] = []
_PROCESS_FILE = batch._process_file


def _gated(path, *args, **kwargs):
    """The batch's task, for a worker thread of the in-process cluster below: but for the
    first file, it waits (a task on a worker about to die) and does nothing (it died)."""
    if path not in _FIRST:
        _GATE.wait(60)
        return None
    return _PROCESS_FILE(path, *args, **kwargs)


def test_a_cluster_without_workers_times_out_with_the_rows_done(gyros, tmp_path, monkeypatch):
    from distributed import LocalCluster

    files = [gyros["a"], gyros["b"]]
    for k in range(2):
        path = tmp_path / f"c{k}.npy"
        np.save(path, simulate.white(N, rate=RATE, seed=30 + k))
        files.append(path)
    monkeypatch.setattr(batch, "_process_file", _gated)
    monkeypatch.setattr(sys.modules[__name__], "_FIRST", [str(files[0])])
    _GATE.clear()
    killer = []
    with LocalCluster(n_workers=1, threads_per_worker=4, processes=False, protocol="tcp://",
                      host="127.0.0.1", scheduler_port=0, dashboard_address=None,
                      scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                      silence_logs=logging.CRITICAL) as cluster:  # fmt: skip

        def kill_workers(done, total, row):
            if done == 1:  # the other three are running: every worker goes, none comes back
                killer.append(threading.Thread(target=cluster.scale, args=(0,)))
                killer[0].start()

        start = time.monotonic()
        try:
            result = run_batch(
                files, out=tmp_path / "out", scheduler=cluster.scheduler_address,
                options={"units": "deg/s", "rate": RATE, "taus": "octave"}, html=False,
                worker_timeout=1.0, progress=kill_workers,
            )  # fmt: skip
        finally:
            _GATE.set()
            for thread in killer:
                thread.join(60)
        assert time.monotonic() - start < 30
    assert [row["status"] for row in result.rows] == ["ok", "error", "error", "error"]
    for row in result.rows[1:]:
        assert row["error_type"] == "internal" and "had no worker for 1 s" in row["error"]
        assert "--worker-timeout" in row["error"] and "rerun with the same --out" in row["error"]
        assert _stored(tmp_path / "out", row["name"])["status"] == "error"
    assert result.counts["internal_errors"] == 3
    assert any("gave up after 1 s without any dask worker: 3 of 4" in n for n in result.notes)
    # the summary holds every row, done or not
    summary = _summary(tmp_path / "out")
    assert [summary[str(p)]["status"] for p in files] == ["ok", "error", "error", "error"]


def test_worker_timeout_must_be_positive(capsys, gyros, tmp_path):
    code, out, err = run(capsys, ["batch", str(gyros["a"]), *BATCH, "--out",
                                  str(tmp_path / "out"), "--worker-timeout", "0"])  # fmt: skip
    assert_one_line_error(code, out, err, "--worker-timeout")
    with pytest.raises(writers.AdavarInputError, match="worker_timeout"):
        run_batch([gyros["a"]], out=tmp_path / "out", options={"units": "deg/s", "rate": 1},
                  worker_timeout=-1)  # fmt: skip
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------------------
# 14. SIGTERM and SIGKILL leave no temporary behind
# --------------------------------------------------------------------------------------


def _temporaries(folder):
    return sorted(p.name for p in Path(folder).iterdir() if re.match(r"^\..+\.(tmp|old)-", p.name))


def test_sigterm_during_the_write_removes_the_temporary(gyro_csv, tmp_path):
    out = tmp_path / "out"
    env = {**os.environ, writers.PAUSE_BEFORE_RENAME_ENV: "120"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "adavar.cli", "avar", str(gyro_csv), "--column", "gx", "--rate",
         "100", "--units", "deg/s", "--out", str(out)],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        while not any((tmp_path / t / "result.json").is_file() for t in _temporaries(tmp_path)):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "the write never started"
            time.sleep(0.05)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 143, err
    assert "terminated" in err and "Traceback" not in err
    assert _temporaries(tmp_path) == [] and not out.exists()


def test_the_signal_handler_is_only_there_while_writing(tmp_path):
    before = signal.getsignal(signal.SIGTERM)
    with writers.atomic_directory(tmp_path / "out") as tmp:
        assert signal.getsignal(signal.SIGTERM) is not before
        (tmp / "f.txt").write_text("x")
    assert signal.getsignal(signal.SIGTERM) is before


def _dead_pid():
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def _fake_temporary(parent, name, *, pid, age_s=0.0, marker=True):
    folder = parent / name
    folder.mkdir()
    (folder / "big.bin").write_bytes(b"\0" * 100_000)
    if marker:
        (folder / OUTPUT_MARKER).write_text(json.dumps({
            "pid": pid, "host": socket.gethostname(), "created": time.time() - age_s}))  # fmt: skip
    return folder


def test_stale_temporaries_of_killed_runs_are_swept(capsys, gyro_csv, tmp_path):
    dead = _dead_pid()
    _fake_temporary(tmp_path, ".out.tmp-0123456789ab", pid=dead)  # SIGKILLed writer
    _fake_temporary(tmp_path, ".other.tmp-aaaaaaaaaaaa", pid=dead, age_s=60)
    _fake_temporary(tmp_path, ".old.tmp-bbbbbbbbbbbb", pid=os.getpid(), age_s=7 * 3600)
    _fake_temporary(tmp_path, ".live.tmp-cccccccccccc", pid=os.getpid())  # still writing
    _fake_temporary(tmp_path, ".user.tmp-dddddddddddd", pid=dead, marker=False)  # not ours
    # a replacement killed between the two renames: the old folder comes back
    aside = _fake_temporary(tmp_path, ".kept.old-eeeeeeeeeeee", pid=dead)
    (aside / "kept").mkdir()
    (aside / "kept" / "result.json").write_text("{}")
    argv = [a.format(csv=gyro_csv) for a in FORCE_COMMANDS["avar"]]
    code, _, err = run(capsys, [*argv, "--out", str(tmp_path / "out")])
    assert code == 0, err
    assert _temporaries(tmp_path) == [".live.tmp-cccccccccccc", ".user.tmp-dddddddddddd"]
    assert (tmp_path / "kept" / "result.json").is_file()


def test_a_batch_sweeps_its_own_folder(capsys, gyros, tmp_path):
    out = tmp_path / "out"
    code, _, err = _batch(capsys, [gyros["a"]], out, "--no-html")
    assert code == 0, err
    _fake_temporary(out, f".{folder_name(gyros['b'])}.tmp-0123456789ab", pid=_dead_pid())
    code, payload, err = _batch(capsys, [gyros["a"], gyros["b"]], out, "--no-html")
    assert code == 0, err
    assert _temporaries(out) == []
    assert any("removed 1 temporary folder(s)" in note for note in payload["notes"])


# --------------------------------------------------------------------------------------
# 20. plain CSV: pandas.read_csv(path) reads every CSV adavar writes; no formula runs
# --------------------------------------------------------------------------------------


#: Text columns of adavar's CSVs (every other column is numeric).
TEXT_COLUMNS = {
    "file", "name", "status", "error_type", "error", "units", "column", "event_times_s",
    "worker", "node", "method", "metric", *(f"{c}_unit" for c in "QNBKR"),
}  # fmt: skip


def _check_csv(path):
    with open(path, encoding="utf-8", newline="") as handle:
        header = next(csv.reader(handle))
    assert not header[0].startswith("#"), path
    frame = pd.read_csv(path)
    assert list(frame.columns) == header, path
    assert len(frame) > 0 or path.name == "events.csv", path  # a record may have no event
    for column in header:
        if column not in TEXT_COLUMNS and frame[column].notna().any():
            assert pd.api.types.is_numeric_dtype(frame[column]), (path, column)
    return frame


def test_every_csv_is_read_by_pandas_as_it_is(capsys, gyro_csv, tmp_path):
    runs = {
        "avar": ["avar", str(gyro_csv), "--column", "gx,gy", "--rate", "100", "--units",
                 "deg/s", "--fit"],
        "avar1": [*FORCE_COMMANDS["avar"], "--fit"],
        "davar": FORCE_COMMANDS["davar"],
        "adaptive": FORCE_COMMANDS["adaptive"],
        "compare": ["compare", "--scenario", "1", "--seeds", "2", "--taus", "octave"],
        "batch": ["batch", str(gyro_csv), "--column", "gx", *BATCH[:-1], "--no-html"],
    }  # fmt: skip
    found = {}
    for label, argv in runs.items():
        out = tmp_path / label
        # the tables are the subject: no figures (but the batch's, which has no --figures)
        figures = [] if label == "batch" else ["--figures", "none"]
        code, _, err = run(capsys, [a.format(csv=gyro_csv) for a in argv] + ["--out", str(out),
                                                                            *figures])  # fmt: skip
        assert code == 0, (label, err)
        for path in sorted(out.rglob("*.csv")):
            found[f"{label}/{path.relative_to(out)}"] = _check_csv(path)
    names = {re.sub(r"-[0-9a-f]{6}/", "-HASH/", key) for key in found}
    assert names >= {
        "avar/gx_deviation.csv", "avar/gy_deviation.csv", "avar1/deviation.csv",
        "davar/coefficients.csv", "adaptive/coefficients.csv", "adaptive/events.csv",
        *(f"compare/{n}.csv" for n in ("nodes", "intervals", "metrics", "arw", "crossings",
                                       "seeds_nodes")),
        "batch/summary.csv", "batch/imu-HASH/deviation.csv",
    }  # fmt: skip
    assert found["avar1/deviation.csv"].dtypes["n"].kind == "i"
    # adavar still reads what it wrote (the deviation back, the compare's descriptions)
    from adavar.io.text_column import read_text

    dev, _ = read_text(tmp_path / "avar1" / "deviation.csv", column="dev")
    assert np.array_equal(dev, found["avar1/deviation.csv"]["dev"].to_numpy())
    described = json.loads((tmp_path / "compare" / "result.json").read_text())["out"]["tables"]
    assert set(described) == {f"{n}.csv" for n in ("nodes", "intervals", "metrics", "arw",
                                                   "crossings", "seeds_nodes")}  # fmt: skip
    assert "node times" in described["nodes.csv"]
    summary = json.loads((tmp_path / "batch" / "summary.json").read_text())
    assert summary["columns"][0] == "file" and "absent" in summary["description"]


def test_spreadsheet_formulas_are_neutralised_but_numbers_are_not(tmp_path):
    from adavar.output.export import write_table_csv

    cells = ["=1+2", "+x", "-x", "@SUM(A1)", "\tx", "\rx", "-1.5", "-inf", "plain", -1.5, 2]
    path = write_table_csv(tmp_path / "t.csv", [cells], [f"c{k}" for k in range(10)] + ["=c"])
    with open(path, encoding="utf-8", newline="") as handle:
        header, row = list(csv.reader(handle))
    assert header[-1] == "'=c"
    assert row == ["'=1+2", "'+x", "'-x", "'@SUM(A1)", "'\tx", "'\rx", "-1.5", "-inf", "plain",
                   "-1.5", "2"]  # fmt: skip


def test_a_column_named_like_a_formula_is_text_in_the_summary(capsys, tmp_path):
    data = tmp_path / "f.csv"
    x = simulate.white(N, rate=RATE, seed=5)
    data.write_text("=HYPERLINK(x)\n" + "\n".join(map(repr, x.tolist())) + "\n")
    out = tmp_path / "out"
    code, payload, err = _batch(capsys, [data], out, "--no-html", "--column", "=HYPERLINK(x)")
    assert code == 0, err
    assert payload["rows"][0]["column"] == "=HYPERLINK(x)"  # the JSON keeps the text
    assert _summary(out)[str(data)]["column"] == "'=HYPERLINK(x)"

"""adavar batch: many files, one task per file, on dask.distributed clusters and in process.

The batch runs on a ``distributed.LocalCluster`` of two worker processes and on a real
``dask scheduler`` and ``dask worker`` started as subprocesses on 127.0.0.1; every file's
numbers are compared with ``adavar report`` / ``adavar avar --fit`` run on that file alone.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from adavar import cli, simulate
from adavar.comparison import schedule_nodes
from adavar.dynamic.adaptive import record_windows
from adavar.io import writers
from adavar.io.writers import OUTPUT_MARKER
from adavar.output import report as report_module
from adavar.pipeline import analysis, batch, report_analysis
from adavar.pipeline.batch import (
    BATCH_MARKER,
    SUMMARY_COLUMNS,
    analyse_file,
    collect_files,
    output_names,
    report_options,
    run_batch,
)
from adavar.pipeline.batch_state import BATCH_LOCK, BATCH_STATE, folder_name

from .cli_helpers import assert_one_line_error, run

RATE = 100.0
N_SAMPLES = 10_000
#: The disturbance of g2.npy: four times the noise from 60 s to 80 s.
DISTURBED = (6_000, 8_000)
ANALYSIS = ["--rate", str(RATE), "--units", "deg/s", "--adaptive"]


def _cli(argv):
    """Exit code, stdout and stderr of ``adavar ARGV`` in this process (any fixture scope)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


@contextlib.contextmanager
def _numba_threads(n):
    """Run numba's parallel kernels on ``n`` threads (the workers of a batch use one)."""
    before = numba.get_num_threads()
    numba.set_num_threads(n)
    try:
        yield
    finally:
        numba.set_num_threads(before)


def _write_csv(path, x):
    path.write_text("x\n" + "\n".join(map(repr, x.tolist())) + "\n", encoding="utf-8")


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """Three good records (two with the stem g1) and one with a NaN, at 100 Hz in deg/s."""
    folder = tmp_path_factory.mktemp("records")
    (folder / "sub").mkdir()
    files = {
        "g1": folder / "g1.csv",
        "sub__g1": folder / "sub" / "g1.csv",
        "g2": folder / "g2.npy",
        "bad": folder / "bad.csv",
    }
    _write_csv(files["g1"], simulate.sensor(N_SAMPLES, rate=RATE, seed=1, angle_random_walk=0.1))
    _write_csv(files["sub__g1"], simulate.white(N_SAMPLES, std=0.3, rate=RATE, seed=3) + 1e6)
    y = simulate.sensor(N_SAMPLES, rate=RATE, seed=2, angle_random_walk=0.1)
    y[DISTURBED[0] : DISTURBED[1]] *= 4.0
    np.save(files["g2"], y)
    z = simulate.white(N_SAMPLES, rate=RATE, seed=4)
    z[17] = np.nan
    _write_csv(files["bad"], z)
    return files


@pytest.fixture(scope="module")
def single_runs(records, tmp_path_factory):
    """``adavar report --json`` and ``adavar avar --fit --json`` of every good file alone,
    with numba on one thread as on the batch's workers."""
    folder = tmp_path_factory.mktemp("single")
    out = {}
    with _numba_threads(1):
        for name in ("g1", "sub__g1", "g2"):
            code, text, err = _cli(["report", records[name], *ANALYSIS, "-o",
                                    folder / f"{name}.html", "--json"])  # fmt: skip
            assert code == 0, err
            report = json.loads(text)
            code, text, err = _cli(["avar", records[name], "--rate", RATE, "--units", "deg/s",
                                    "--fit", "--json"])  # fmt: skip
            assert code == 0, err
            out[name] = {"report": report, "avar": json.loads(text)}
    return out


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def dask_cluster(tmp_path_factory):
    """A ``dask scheduler`` and one ``dask worker`` (one thread) as subprocesses on
    127.0.0.1, both killed at the end whatever happens."""
    folder = tmp_path_factory.mktemp("dask")
    scheduler_file = folder / "scheduler.json"
    dask = Path(sys.executable).parent / "dask"
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    log = open(folder / "dask.log", "w")  # closed in the finally block
    procs = []
    try:
        procs.append(subprocess.Popen(
            [dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
             "--scheduler-file", scheduler_file],
            cwd=folder, env=env, stdout=log, stderr=subprocess.STDOUT,
            start_new_session=True,  # its own process group: the worker's children too
        ))  # fmt: skip
        deadline = time.monotonic() + 60
        address = None
        while address is None:
            assert time.monotonic() < deadline, "the dask scheduler did not start"
            assert procs[0].poll() is None, (folder / "dask.log").read_text()
            with contextlib.suppress(OSError, ValueError, KeyError):
                address = json.loads(scheduler_file.read_text())["address"]
            time.sleep(0.2)
        procs.append(subprocess.Popen(
            [dask, "worker", "--scheduler-file", scheduler_file, "--nthreads", "1",
             "--nworkers", "1", "--host", "127.0.0.1", "--no-dashboard"],
            cwd=folder, env=env, stdout=log, stderr=subprocess.STDOUT,
            start_new_session=True,  # its own process group: the worker's children too
        ))  # fmt: skip
        yield {"address": address, "file": scheduler_file}
    finally:
        for proc in reversed(procs):
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGTERM)
        for proc in reversed(procs):
            try:
                proc.wait(timeout=3)
            except subprocess.TimeoutExpired:
                pass
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)  # whatever is left of the group
            proc.wait()
        log.close()


def _result(out, name):
    return json.loads((out / name / "result.json").read_text(encoding="utf-8"))


def _read_summary_csv(path):
    return list(csv.DictReader(path.read_text(encoding="utf-8").splitlines()))  # plain CSV


def _labelled(rows, records):
    """The rows by the label of their file in ``records`` (its folder name is its own)."""
    label = {str(path): name for name, path in records.items()}
    return {label[row["file"]]: row for row in rows}


def _by_stem(rows):
    return {Path(row["file"]).stem: row for row in rows}


# --------------------------------------------------------------------------------------
# a LocalCluster of two workers
# --------------------------------------------------------------------------------------


def _check_rows_equal_single_runs(out, rows, single_runs):
    for name, alone in single_runs.items():
        stored = _result(out, rows[name]["name"])
        # the same function as adavar report: every number of the fit is the same
        assert stored["fit"] == alone["report"]["fit"]
        assert stored["fit"] == alone["avar"]["fit"]
        assert stored["input"]["n_samples"] == alone["report"]["input"]["n_samples"] == N_SAMPLES
        assert stored["surface"] == alone["report"]["surface"]
        row = rows[name]
        assert row["status"] == "ok" and row["error"] is None
        assert row["worker"].startswith("tcp://127.0.0.1:")
        assert row["n_samples"] == N_SAMPLES and row["rate_hz"] == RATE
        assert row["units"] == "deg/s"
        conventional = alone["report"]["fit"]["conventional"]
        for term, letter in (("quantization", "Q"), ("angle_random_walk", "N"),
                             ("bias_instability", "B"), ("rate_random_walk", "K"),
                             ("rate_ramp", "R")):  # fmt: skip
            assert row[letter] == conventional[term]["value"]
            assert row[f"{letter}_uncertainty"] == conventional[term]["uncertainty"]
            assert row[f"{letter}_unit"] == conventional[term]["unit"]
    assert rows["g1"]["N_unit"] == "deg/sqrt(h)"
    # N of white rate noise: sigma * sqrt(tau0), here 0.1 deg/s/sqrt(Hz) = 6 deg/sqrt(h)
    assert rows["g1"]["N"] == pytest.approx(6.0, rel=0.05)


def _check_summary_files(out, payload):
    import pyarrow.parquet as pq

    rows = payload["rows"]
    assert payload["summary"] == {
        "csv": str(out / "summary.csv"),
        "parquet": str(out / "summary.parquet"),
        "json": str(out / "summary.json"),
    }
    about = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert about["columns"] == list(SUMMARY_COLUMNS) and about["counts"] == payload["counts"]
    table = pq.read_table(out / "summary.parquet")
    assert table.column_names == list(SUMMARY_COLUMNS)
    assert table.to_pylist() == rows
    from_csv = _read_summary_csv(out / "summary.csv")
    assert [r["name"] for r in from_csv] == [r["name"] for r in rows]
    for text, row in zip(from_csv, rows, strict=True):
        for column in SUMMARY_COLUMNS:
            value = row[column]
            if value is None:
                assert text[column] == ""
            elif isinstance(value, float):
                assert float(text[column]) == value  # shortest round-trip form
            else:
                assert text[column] == str(value)


def _check_broken_row(out, rows, err, records):
    bad = rows["bad"]
    assert bad["status"] == "error" and bad["error_type"] == "input"
    assert "\n" not in bad["error"]
    for fragment in (str(records["bad"]), "NaN", "--nan"):
        assert fragment in bad["error"]
    assert bad["N"] is None and bad["n_samples"] is None
    # the failed file's folder says so, and holds nothing else
    assert sorted(p.name for p in (out / bad["name"]).iterdir()) == [OUTPUT_MARKER, "result.json"]
    stored = _result(out, bad["name"])
    assert stored["status"] == "error" and stored["error"] == bad["error"]
    # the other files are complete, and nothing half-written is left in OUT
    for name in ("g1", "sub__g1", "g2"):
        folder = out / rows[name]["name"]
        assert folder.name == folder_name(records[name])  # stem-hash, e.g. g1-3f2a9c
        assert sorted(p.name for p in folder.iterdir()) == [
            OUTPUT_MARKER, "deviation.csv", "report.html", "result.json"]  # fmt: skip
        html = (folder / "report.html").read_text(encoding="utf-8")
        assert html.lower().startswith("<!doctype html>") and "plotly" in html
        header = (folder / "deviation.csv").read_text().splitlines()[0]
        assert header == "tau_s,n,m,alpha,edf,dev,dev_low,dev_high"
    assert sorted(p.name for p in out.iterdir()) == sorted([
        BATCH_MARKER, BATCH_STATE, BATCH_LOCK, *(row["name"] for row in rows.values()),
        "summary.csv", "summary.json", "summary.parquet"])  # fmt: skip
    # one stderr line that names the file and the way out
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("adavar: error: 1 of 4 files failed")
    assert str(records["bad"]) in lines[0] and "rerun" in lines[0]


def _check_result_json(out, rows, records):
    stored = _result(out, rows["g2"]["name"])
    assert stored["file"] == str(records["g2"])
    st_ = records["g2"].stat()
    assert stored["input"]["fingerprint"] == {"size": st_.st_size, "mtime_ns": st_.st_mtime_ns}
    # no window flags: the options say so, the windows follow the record's length
    assert stored["options"]["adaptive"] is True and stored["options"]["lmax"] is None
    assert stored["input"]["preprocessing"] == []
    n_samples = stored["input"]["n_samples"]
    assert stored["parameters"]["controller lmax"] == record_windows(n_samples)[0]
    events = stored["events"]
    assert events["method"] == "adaptive" and events["count"] == len(events["items"]) >= 1
    assert rows["g2"]["n_events"] == events["count"]
    assert rows["g2"]["event_times_s"] == ";".join(repr(e["start_s"]) for e in events["items"])
    assert stored["summary"] == rows["g2"]


def test_batch_on_a_local_cluster_equals_each_file_alone(records, single_runs, tmp_path):
    # one test, so that the cluster starts once even when xdist splits the module
    out = tmp_path / "out"
    folder = records["g1"].parent
    # with dask's default HTTP port taken (another batch, a dashboard), no warning: the
    # local scheduler's HTTP server listens on a free port of this machine's loopback
    with socket.socket() as busy, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with contextlib.suppress(OSError):  # taken already: the same situation
            busy.bind(("", 8787))
            busy.listen()
        code, text, err = _cli(["batch", folder / "*.csv", folder / "sub" / "*.csv",
                                records["g2"], *ANALYSIS, "--out", out, "--workers", 2,
                                "--json"])  # fmt: skip
    assert not [w for w in caught if "already in use" in str(w.message)]
    assert code == 2, err  # the broken file is a user error
    payload = json.loads(text)
    assert payload["counts"] == {"files": 4, "ok": 3, "done": 0, "error": 1, "input_errors": 1,
                                 "internal_errors": 0, "absent": 0}  # fmt: skip
    assert "LocalCluster of 2 worker processes" in payload["cluster"]
    rows = _labelled(payload["rows"], records)
    assert list(rows) == ["bad", "g1", "sub__g1", "g2"]  # the order given
    _check_rows_equal_single_runs(out, rows, single_runs)
    _check_summary_files(out, payload)
    _check_broken_row(out, rows, err, records)
    _check_result_json(out, rows, records)


# --------------------------------------------------------------------------------------
# a real scheduler and worker, started as subprocesses
# --------------------------------------------------------------------------------------


def test_batch_on_a_dask_scheduler_and_worker(dask_cluster, records, single_runs, tmp_path):
    out = tmp_path / "out"
    folder = records["g1"].parent
    code, text, err = _cli(["batch", folder / "*.csv", folder / "sub" / "g1.csv",
                            records["g2"], *ANALYSIS, "--out", out, "--scheduler",
                            dask_cluster["address"], "--timeout", 30, "--json"])  # fmt: skip
    assert code == 2, err
    payload = json.loads(text)
    assert dask_cluster["address"] in payload["cluster"]
    rows = _labelled(payload["rows"], records)
    workers = {row["worker"] for row in payload["rows"]}
    assert len(workers) == 1 and workers.pop().startswith("tcp://127.0.0.1:")
    _check_rows_equal_single_runs(out, rows, single_runs)
    _check_summary_files(out, payload)
    _check_broken_row(out, rows, err, records)
    _check_result_json(out, rows, records)
    # the scheduler file names the scheduler too
    code, text, err = _cli(["batch", records["g1"], *ANALYSIS, "--out", tmp_path / "again",
                            "--scheduler", dask_cluster["file"], "--json"])  # fmt: skip
    assert code == 0, err
    name = rows["g1"]["name"]  # the same folder name in every --out
    assert _result(tmp_path / "again", name)["fit"] == _result(out, name)["fit"]


# --------------------------------------------------------------------------------------
# reruns, --force, atomic outputs (in process: the same task function)
# --------------------------------------------------------------------------------------


@pytest.fixture
def small_records(tmp_path):
    """Two short good records and a bad one: the rerun logic does not need long ones."""
    folder = tmp_path / "in"
    folder.mkdir()
    for k in range(2):
        _write_csv(folder / f"r{k}.csv", simulate.white(3000, rate=RATE, seed=10 + k))
    (folder / "r9.csv").write_text("x\n1.0\n2.0\n", encoding="utf-8")  # too short
    return folder


def _batch_small(folder, out, *extra):
    return _cli(
        [
            "batch",
            folder / "*.csv",
            "--rate",
            RATE,
            "--units",
            "deg/s",
            "--out",
            out,
            "--json",
            *extra,
        ]
    )


def test_rerun_skips_done_files_and_force_recomputes(small_records, tmp_path):
    out = tmp_path / "out"
    code, text, err = _batch_small(small_records, out)
    assert code == 2, err
    first = _by_stem(json.loads(text)["rows"])
    assert [first[n]["status"] for n in ("r0", "r1", "r9")] == ["ok", "ok", "error"]
    assert first["r9"]["error_type"] == "input" and "2 samples" in first["r9"]["error"]
    names = {n: first[n]["name"] for n in first}
    stamps = {n: (out / names[n] / "result.json").stat().st_mtime_ns for n in ("r0", "r1")}

    code, text, err = _batch_small(small_records, out)
    assert code == 2, err
    second = _by_stem(json.loads(text)["rows"])
    assert [second[n]["status"] for n in ("r0", "r1", "r9")] == ["done", "done", "error"]
    for name in ("r0", "r1"):
        assert {**second[name], "status": "ok"} == first[name]  # the stored numbers
        assert (out / names[name] / "result.json").stat().st_mtime_ns == stamps[name]

    # a changed input is recomputed, the others are not
    _write_csv(small_records / "r1.csv", simulate.white(3000, rate=RATE, seed=99))
    code, text, err = _batch_small(small_records, out)
    third = _by_stem(json.loads(text)["rows"])
    assert [third[n]["status"] for n in ("r0", "r1")] == ["done", "ok"]
    assert third["r1"]["N"] != first["r1"]["N"]

    # other options recompute every file (the stored ones no longer apply); --force too
    options = report_options({"units": "deg/s", "rate": RATE})
    r0 = str(small_records / "r0.csv")
    assert batch._done_row(out, r0, names["r0"], options) is not None
    assert batch._done_row(out, r0, names["r0"],
                           {**options, "terms": ("angle_random_walk",)}) is None  # fmt: skip
    assert batch._done_row(out, r0, names["r1"], options) is None  # another file's folder
    code, text, err = _batch_small(small_records, out, "--force")
    assert [row["status"] for row in json.loads(text)["rows"]] == ["ok", "ok", "error"]
    assert (out / names["r0"] / "result.json").stat().st_mtime_ns != stamps["r0"]
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == [
        BATCH_MARKER, BATCH_STATE, BATCH_LOCK]  # fmt: skip


def test_all_ok_exits_0_and_prints_a_table(small_records, tmp_path):
    (small_records / "r9.csv").unlink()
    code, out, err = _cli(["batch", small_records / "*.csv", "--rate", RATE, "--units", "deg/s",
                           "--out", tmp_path / "out"])  # fmt: skip
    assert code == 0 and err == ""
    assert "2 files in this process (no cluster)" in out and "2 ok" in out
    assert "N = " in out and "deg/sqrt(h)" in out
    assert f"wrote {tmp_path / 'out' / 'summary.csv'}" in out
    # the report is the one adavar report writes (but for the time in its footer)
    alone = tmp_path / "alone.html"
    code, _, err = _cli(["report", small_records / "r0.csv", "--rate", RATE, "--units",
                         "deg/s", "-o", alone])  # fmt: skip
    assert code == 0, err
    stamp = re.compile(r"on \d{4}-\d\d-\d\d \d\d:\d\d:\d\d UTC")
    folder = folder_name(small_records / "r0.csv")
    batch_html = (tmp_path / "out" / folder / "report.html").read_text(encoding="utf-8")
    assert stamp.sub("", batch_html) == stamp.sub("", alone.read_text(encoding="utf-8"))


def test_no_html_keeps_the_numbers_and_drops_the_report(small_records, tmp_path):
    (small_records / "r9.csv").unlink()
    args = ["batch", small_records / "*.csv", "--rate", RATE, "--units", "deg/s", "--json"]
    code, out, err = _cli([*args, "--out", tmp_path / "with"])
    assert code == 0, err
    code, out2, err = _cli([*args, "--out", tmp_path / "without", "--no-html"])
    assert code == 0, err
    for stem in ("r0", "r1"):
        name = folder_name(small_records / f"{stem}.csv")  # the same in both folders
        assert (tmp_path / "with" / name / "report.html").is_file()
        assert not (tmp_path / "without" / name / "report.html").exists()
        assert (tmp_path / "without" / name / "deviation.csv").read_text() == (
            tmp_path / "with" / name / "deviation.csv"
        ).read_text()
    keep = ("Q", "N", "B", "K", "R", "status")
    rows = [{k: r[k] for k in keep} for r in json.loads(out)["rows"]]
    assert rows == [{k: r[k] for k in keep} for r in json.loads(out2)["rows"]]


@pytest.mark.parametrize("failure", [OSError, KeyboardInterrupt])
def test_a_failed_write_leaves_no_half_written_folder(small_records, tmp_path, monkeypatch,
                                                      failure):  # fmt: skip
    def broken(path, *args, **kwargs):
        assert (path.parent / "report.html").is_file()  # written, then the failure
        raise failure("disk full")

    monkeypatch.setattr(writers, "write_deviation_csv", broken)
    out = tmp_path / "out"
    code, text, _ = _batch_small(small_records, out)
    if failure is KeyboardInterrupt:
        assert code == 130 and not (out / "summary.csv").exists()
        assert sorted(p.name for p in out.iterdir() if p.is_dir()) == []  # no folder, no temp
    else:
        assert code == 1  # an internal error in a task: its row, exit 1
        rows = json.loads(text)["rows"]
        assert [r["error_type"] for r in rows[:2]] == ["internal", "internal"]
        assert "disk full" in rows[0]["error"]
        # no temporary; every file's folder holds its error, nothing half-written
        folders = sorted(p.name for p in out.iterdir() if p.is_dir())
        assert folders == sorted(r["name"] for r in rows)
        for row in rows:
            assert sorted(p.name for p in (out / row["name"]).iterdir()) == [
                OUTPUT_MARKER, "result.json"]  # fmt: skip
            assert _result(out, row["name"])["status"] == "error"


# --------------------------------------------------------------------------------------
# bad usage: one line, exit 2, no --out
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("extra", "fragments"),
    [
        (["{dir}/nothing/*.csv"], ["no file matches", "nothing/*.csv", "quote"]),
        (["{file}", "--scheduler", "tcp://127.0.0.1:{port}", "--timeout", "0.2"],
         ["tcp://127.0.0.1:", "dask scheduler", "--workers N"]),
        (["{file}", "--scheduler", "nonsense"], ["'nonsense'", "tcp://HOST:PORT"]),
        (["{file}", "--scheduler", "tcp://127.0.0.1:1", "--workers", "2"], ["not both"]),
        (["{file}", "--files-from", "{dir}/missing.txt"], ["--files-from", "one path per line"]),
        ([], ["no input files"]),
        (["{file}", "--tau0", "0.01"], ["exactly one of --rate"]),
        (["{file}", "--preprocess", "decimate:0"], ["decimat"]),
    ],
)  # fmt: skip
def test_bad_usage_is_one_line_and_writes_nothing(capsys, records, tmp_path, extra, fragments):
    port = _free_port()
    argv = [a.format(dir=tmp_path, file=records["g1"], port=port) for a in extra]
    code, out, err = run(capsys, ["batch", *argv, "--rate", str(RATE), "--units", "deg/s",
                                  "--out", str(tmp_path / "out")])  # fmt: skip
    assert_one_line_error(code, out, err, *fragments)
    if "--scheduler" in argv and "--workers" not in argv and "nonsense" not in argv:
        assert f"tcp://127.0.0.1:{port}" in err
    assert not (tmp_path / "out").exists()


def test_units_are_required_and_out_must_be_a_batch_folder(capsys, records, tmp_path):
    code, out, err = run(capsys, ["batch", str(records["g1"]), "--rate", "100", "--out",
                                  str(tmp_path / "out")])  # fmt: skip
    assert_one_line_error(code, out, err, "--units")
    other = tmp_path / "mine"
    other.mkdir()
    (other / "notes.txt").write_text("keep me")
    code, out, err = run(capsys, ["batch", str(records["g1"]), "--rate", "100", "--units",
                                  "deg/s", "--out", str(other)])  # fmt: skip
    assert_one_line_error(code, out, err, "not an adavar batch folder", BATCH_MARKER)
    assert sorted(p.name for p in other.iterdir()) == ["notes.txt"]
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------------------
# the library pieces
# --------------------------------------------------------------------------------------


def test_run_batch_library_progress_and_no_pyarrow(small_records, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # import pyarrow -> ImportError
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    seen = []
    result = run_batch(
        sorted(small_records.glob("*.csv")), out=tmp_path / "out",
        options={"units": "deg/s", "rate": RATE, "terms": ("angle_random_walk",)},
        progress=lambda done, total, row: seen.append((done, total, row["status"])),
    )  # fmt: skip
    assert seen == [(1, 3, "ok"), (2, 3, "ok"), (3, 3, "error")]
    assert result.counts["ok"] == 2 and result.counts["input_errors"] == 1
    assert result.summary_parquet is None and not (tmp_path / "out" / "summary.parquet").exists()
    assert any("pyarrow" in note for note in result.notes)
    assert result.rows[0]["N"] > 0 and result.rows[0]["n_events"] is None
    assert [Path(row["file"]).stem for row in _read_summary_csv(result.summary_csv)] == [
        "r0", "r1", "r9"]  # fmt: skip
    with pytest.raises(batch.AdavarInputError, match="unknown analysis option 'widnow'"):
        run_batch([small_records / "r0.csv"], out=tmp_path / "x", options={"widnow": 3})


def test_batch_options_are_those_of_report():
    parser = cli.build_parser()
    args = parser.parse_args(["batch", "f.csv", "--out", "o"])
    defaults = report_options()
    assert set(defaults) <= set(vars(args))
    assert {k: getattr(args, k) for k in defaults} == defaults
    assert {"units", "rate", "tau0", "window", "adaptive", "lmax", "preprocess"} <= set(defaults)
    args = parser.parse_args(["batch", "f.csv", "--out", "o", "--k2", "3.5", "--l", "50"])
    assert report_options(args, ignore_unknown=True)["k2"] == 3.5
    assert report_options({"l": 50})["segment"] == 50


def test_collect_files_globs_lists_and_duplicates(tmp_path):
    (tmp_path / "a").mkdir()
    for name in ("a/x.csv", "a/y.csv", "z.npy"):
        (tmp_path / name).write_text("1\n")
    listing = tmp_path / "list.txt"
    listing.write_text("# the line's files\n\na/y.csv\n" + str(tmp_path / "z.npy") + "\n")
    files = collect_files([tmp_path / "a" / "*.csv", tmp_path / "missing.csv"],
                          files_from=listing)  # fmt: skip
    assert files == [str(tmp_path / "a/x.csv"), str(tmp_path / "a/y.csv"),
                     str(tmp_path / "missing.csv"), str(tmp_path / "z.npy")]  # fmt: skip
    assert collect_files([str(tmp_path / "**" / "*.csv")]) == files[:2]


def test_output_names_are_unique_and_readable():
    names = output_names(["/d/a/gyro.csv", "/d/b/gyro.csv", "/d/c.csv"])
    assert [re.sub(r"-[0-9a-f]{6}$", "", n) for n in names] == ["gyro", "gyro", "c"]
    assert len(set(names)) == 3
    # a file's name is its own: the same whatever the other files
    assert output_names(["/d/b/gyro.csv"]) == [names[1]] == [folder_name("/d/b/gyro.csv")]
    assert len(set(output_names(["/d/gyro.csv", "/d/gyro.npy"]))) == 2
    names = output_names(["/d/a b.csv", "/d/a_b.csv"])
    assert names[0] != names[1] and all(n.startswith("a_b-") for n in names)
    assert output_names(["/d/summary.csv.csv"])[0].startswith("summary.csv-")
    assert [n[:-7] for n in output_names(["/d/.hidden.csv", "/d/<x>.csv"])] == ["hidden", "x"]
    # a recorded name is kept; a new name never takes a recorded one
    taken = folder_name("/d/a/gyro.csv")
    assert output_names(["/d/a/gyro.csv"], {"/d/a/gyro.csv": "gyro"}) == ["gyro"]
    other = output_names(["/d/a/gyro.csv"], {"/d/z/gyro.csv": taken})[0]
    assert other != taken and other.startswith(taken)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.lists(st.sampled_from(["a", "A", "b", "a b", "a_b", ".", "x.csv", "x.npy"]),
                         min_size=1, max_size=3), min_size=1, max_size=8))  # fmt: skip
def test_output_names_never_collide(parts):
    paths = list(dict.fromkeys(os.path.normpath("/r/" + "/".join(p)) for p in parts))
    names = output_names(paths)
    assert len({n.casefold() for n in names}) == len(paths)
    assert output_names(paths) == names  # deterministic: reruns find their folders
    assert all(n and not n.startswith(".") and "/" not in n for n in names)


def _slow_runs(mask):
    out, start = [], None
    for k, flag in enumerate(mask):
        if flag and start is None:
            start = k
        if not flag and start is not None:
            out.append((start, k - 1))
            start = None
    if start is not None:
        out.append((start, len(mask) - 1))
    return out


@settings(max_examples=200, deadline=None)
@given(st.lists(st.booleans(), max_size=60))
def test_runs_equal_a_plain_loop(mask):
    assert report_analysis._runs(np.array(mask, dtype=bool)) == _slow_runs(mask)


def test_events_are_the_node_times_of_the_schedule(records):
    # the paper's windows (without them the windows follow the record's length)
    options = {"units": "deg/s", "rate": RATE, "adaptive": True, "lmax": 600, "lmin": 400,
               "l": 100}  # fmt: skip
    analysis = analyse_file(records["g2"], options)
    events = analysis.events()
    window = np.asarray(analysis.adaptive.window)
    time_s = np.asarray(analysis.adaptive.time)
    # every run of shortened windows, by a plain loop, with its nodes (METHOD.md section 6)
    expected = []
    for a, b in _slow_runs(window < 600):
        e = b
        while e > a and window[e - 1] < window[e]:
            e -= 1
        expected.append((time_s[a], time_s[e], time_s[b + 1] if b + 1 < window.size else None))
    got = [(i["beginning_s"], i["end_node_s"], i["restore_s"]) for i in events["runs"]]
    assert got == expected
    # the stretches start at a change (the leading edge before a shrink), not at a node
    from adavar.dynamic.events import find_events

    fit = analysis.coefficients
    stretches = find_events(window, analysis.adaptive.centre, time_s, 600, 1 / RATE,
                            {n: fit.term(n).value for n in fit.terms},
                            duration=analysis.n_samples / RATE)  # fmt: skip
    assert [e.start_s for e in stretches] == [i["start_s"] for i in events["items"]]
    assert events["count"] == len(events["items"])
    # the nodes compare.schedule_nodes finds around the end of the disturbance are an event's
    change = DISTURBED[1] / RATE
    nodes = schedule_nodes(window, [change], lmax=600, rate=RATE, time=time_s)[0]
    assert (nodes.beginning, nodes.end, nodes.restore) in got
    assert nodes.beginning < change < nodes.restore


def test_fixed_window_events_follow_the_controller_flags(records):
    from adavar.dynamic.adaptive import adaptive_schedule

    analysis = analyse_file(records["g2"], {"units": "deg/s", "rate": RATE, "window": 1000,
                                            "l": 100})  # fmt: skip
    events = analysis.events()
    # the report's thresholds: calibrated for 0.1 false events per stationary hour
    sched = adaptive_schedule(np.load(records["g2"]), method="fixed", lmax=1000, lmin=1000,
                              rate=RATE, thresholds="calibrated",
                              false_alarm_per_hour=0.1)  # fmt: skip
    assert events["method"] == "fixed" and len(events["runs"]) == len(_slow_runs(sched.f)) >= 1
    assert [i["beginning_s"] for i in events["runs"]] == [
        a / RATE for a, _ in _slow_runs(sched.f)]  # fmt: skip
    # one change per run of flags (runs closer than the window merged), at its leading edge
    starts = [a for k, (a, _) in enumerate(_slow_runs(sched.f))
              if k == 0 or a - _slow_runs(sched.f)[k - 1][1] >= 1000]  # fmt: skip
    changes = [(a + 500) / RATE for a in starts]
    assert [i["start_s"] for i in events["items"]] == changes[::2]
    assert [i["end_s"] for i in events["items"]] == [*changes[1::2], None][: len(changes[::2])]
    short = analyse_file(records["g2"], {"units": "deg/s", "rate": RATE, "window": 90, "l": 100})
    assert short.events()["items"] is None and "l + 3" in short.events()["note"]
    # without --l, l is a sixth of the fixed window (the paper's proportion): events again
    fitting = analyse_file(records["g2"], {"units": "deg/s", "rate": RATE, "window": 90})
    assert fitting.events()["items"] is not None
    assert analyse_file(records["g2"], {"units": "deg/s", "rate": RATE}).events() is None


@pytest.mark.parametrize(
    "options",
    [{"adaptive": True, "lmax": 600, "lmin": 400, "l": 100},
     {"adaptive": True, "step": 3, "taus": "all"}, {"window": 1000, "l": 100},
     {"adaptive": True, "data_type": "phase"}],
    ids=["adaptive", "step-all-taus", "fixed", "phase"],
)  # fmt: skip
def test_keep_figures_gives_the_same_report_and_events(records, options, monkeypatch):
    """``keep="figures"`` (what adavar report and batch use) fits the surface a block at a
    time and keeps its drawn rows: the same page, events and shape as the whole surface."""
    monkeypatch.setattr(sys.modules["adavar.dynamic.surface"], "BLOCK_VALUES", 4096)  # many blocks
    options = {"units": "deg/s", "rate": RATE, **options}
    whole = analyse_file(records["g2"], options)
    blocks = analyse_file(records["g2"], options, keep="figures")
    assert analysis.surface_shape(blocks.surface) == analysis.surface_shape(whole.surface)
    assert blocks.surface.drawn.avar.shape[0] < whole.surface.avar.shape[0]
    assert writers.dumps(blocks.events()) == writers.dumps(whole.events())
    stamp = re.compile(r" on \d{4}-\d\d-\d\d \d\d:\d\d:\d\d UTC")
    assert stamp.sub("", blocks.html()) == stamp.sub("", whole.html())
    # the whole fit of the windows the coefficient figure draws; every window's terms
    fit, want = blocks.coefficients, whole.coefficients
    rows = blocks.surface.fit_rows
    np.testing.assert_array_equal(rows, report_module.series_rows(want.time.size))
    for name in ("coefficients", "coefficient_uncertainty", "chi2", "time"):
        np.testing.assert_array_equal(getattr(fit, name), getattr(want, name)[rows], name)
    for name in want.terms:
        np.testing.assert_array_equal(blocks.surface.term_values(name), want.term(name).value)
    if whole.adaptive is not None:
        for name in ("window", "centre", "kurtosis", "s", "f"):
            np.testing.assert_array_equal(getattr(blocks.adaptive, name),
                                          getattr(whole.adaptive, name), err_msg=name)  # fmt: skip
    with pytest.raises(analysis.AdavarInputError, match="unknown keep"):
        analyse_file(records["g2"], options, keep="some")

"""What adavar writes survives signals and never takes the user's files (issue 40, items 10
and 14).

- a file written atomically (``simulate -o``, ``report -o``, ``kalibr -o``) leaves no
  temporary when SIGTERM ends the run (a 47-177 MB ``.s.csv.*.tmp`` was left and never
  swept), and the temporaries of runs killed outright are swept by the next run into the
  same folder (only adavar's, only once their writer is gone);
- ``--force`` replaces an output folder only while it holds nothing but what adavar wrote
  there: a file the user added stops it, named in the error;
- ``simulate`` refuses coefficients whose samples overflow; ``davar --t0`` far from the
  record (float64 times 128 s apart at 1e18 s) is an error;
- the HTML report isolates user text (a file name with U+202E) in ``<bdi>``.
"""

from __future__ import annotations

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

from adavar import simulate
from adavar.core import atomic
from adavar.io.writers import OUTPUT_MARKER, PAUSE_FILE_RENAME_ENV, foreign_files
from adavar.pipeline.batch_state import folder_name

from .cli_helpers import assert_one_line_error, run

RATE = 100.0
N = 4000


@pytest.fixture(scope="module")
def gyro_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("csv") / "gyro.csv"
    x = simulate.white(N, rate=RATE, seed=7)
    rows = "".join(f"{k / RATE!r},{v!r}\n" for k, v in enumerate(x.tolist()))
    path.write_text("time,gx\n" + rows, encoding="utf-8")
    return path


def _partials(folder):
    """The temporaries of atomic_file in ``folder`` (any adavar version's names)."""
    return sorted(p.name for p in Path(folder).iterdir() if re.fullmatch(r"\..+\.tmp", p.name))


def _start_paused(argv, folder):
    """``adavar ARGV`` in a subprocess that pauses once its file is written, before the
    rename; returns when its temporary is in ``folder``."""
    env = {**os.environ, PAUSE_FILE_RENAME_ENV: "120"}
    # Ctrl-C as a terminal sends it: a test run started in the background (`pytest &`,
    # `nohup`) ignores SIGINT, and its children would inherit that
    proc = subprocess.Popen([sys.executable, "-m", "adavar.cli", *map(str, argv)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
                            )  # fmt: skip
    deadline = time.monotonic() + 120
    while not _partials(folder):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the write never started"
        time.sleep(0.05)
    return proc


def _stop(proc, signum):
    try:
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    return err


# --------------------------------------------------------------------------------------
# 10. temporaries of atomic_file: removed on SIGTERM, swept after SIGKILL
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(("command", "signum"), [("simulate", signal.SIGTERM),
                                               ("report", signal.SIGTERM),
                                               ("simulate", signal.SIGINT)])  # fmt: skip
def test_a_signal_while_a_file_is_written_removes_its_temporary(gyro_csv, tmp_path, command,
                                                                signum):  # fmt: skip
    target = tmp_path / ("s.csv" if command == "simulate" else "r.html")
    argv = {
        "simulate": ["simulate", "-o", target, "--arw", "0.1", "--n", "20000"],
        "report": ["report", gyro_csv, "--column", "gx", "--rate", "100", "--units", "deg/s",
                   "--taus", "octave", "-o", target],
    }[command]  # fmt: skip
    proc = _start_paused(argv, tmp_path)
    err = _stop(proc, signum)
    if signum == signal.SIGTERM:
        assert proc.returncode == 143, err
        assert "terminated (signal 15)" in err and "Traceback" not in err
    else:  # Ctrl-C
        assert proc.returncode == 130 and err.strip() == "adavar: interrupted", err
    assert _partials(tmp_path) == [] and not target.exists()


def test_temporaries_of_killed_runs_are_swept_by_the_next_write(tmp_path):
    proc = _start_paused(["simulate", "-o", tmp_path / "s.csv", "--arw", "0.1", "--n",
                          "20000"], tmp_path)  # fmt: skip
    _stop(proc, signal.SIGKILL)  # no chance to clean up
    [killed] = _partials(tmp_path)
    assert killed.startswith(".s.csv.adavar-") and f"-{proc.pid}-" in killed
    # an adavar before 0.2 named them .NAME.HEX.tmp: swept when nobody wrote it for 6 h
    old = tmp_path / ".s.csv.0123456789ab.tmp"
    recent = tmp_path / ".t.csv.abcdef012345.tmp"
    for path in (old, recent):
        path.write_bytes(b"x" * 1000)
    aged = time.time() - atomic.STALE_TEMPORARY_S - 60
    os.utime(old, (aged, aged))
    live = atomic.partial_name(tmp_path / "u.csv")  # this process's: still being written
    live.write_bytes(b"x")
    (tmp_path / ".notes.tmp").write_text("the user's")  # not a name adavar gives
    code = subprocess.run([sys.executable, "-m", "adavar.cli", "simulate", "-o",
                           tmp_path / "other.csv", "--arw", "0.1", "--n", "1000"],
                          capture_output=True, text=True)  # fmt: skip
    assert code.returncode == 0, code.stderr
    assert _partials(tmp_path) == sorted([".notes.tmp", recent.name, live.name])


def test_the_file_signal_handler_is_only_there_while_writing(tmp_path):
    before = signal.getsignal(signal.SIGTERM)
    with atomic.atomic_file(tmp_path / "f.bin") as handle:
        assert signal.getsignal(signal.SIGTERM) is not before
        handle.write(b"x")
    assert signal.getsignal(signal.SIGTERM) is before
    assert (tmp_path / "f.bin").read_bytes() == b"x" and _partials(tmp_path) == []


# --------------------------------------------------------------------------------------
# 14. --force replaces only what adavar wrote
# --------------------------------------------------------------------------------------


def _avar(gyro_csv, out, *extra):
    return ["avar", str(gyro_csv), "--column", "gx", "--rate", "100", "--units", "deg/s",
            "--figures", "none", "--out", str(out), *extra]  # fmt: skip


def test_force_refuses_a_folder_holding_a_users_files(capsys, gyro_csv, tmp_path):
    out = tmp_path / "out"
    code, _, err = run(capsys, _avar(gyro_csv, out))
    assert code == 0, err
    marker = json.loads((out / OUTPUT_MARKER).read_text(encoding="utf-8"))
    written = sorted(p.name for p in out.iterdir() if p.name != OUTPUT_MARKER)
    assert marker["files"] == written and foreign_files(out) == []
    (out / "notes.txt").write_text("my notes")
    (out / "extra").mkdir()
    (out / "extra" / "plot.py").write_text("print(1)")
    code, stdout, err = run(capsys, _avar(gyro_csv, out, "--force"))
    assert_one_line_error(code, stdout, err, "2 file(s) adavar did not write",
                          "extra/plot.py", "notes.txt", "move them out")  # fmt: skip
    assert (out / "notes.txt").read_text() == "my notes"
    assert (out / "extra" / "plot.py").is_file()
    assert [p.name for p in tmp_path.iterdir()] == ["out"]  # no temporary left either
    (out / "notes.txt").unlink()
    (out / "extra" / "plot.py").unlink()  # an empty folder holds nothing to lose
    code, _, err = run(capsys, _avar(gyro_csv, out, "--force"))
    assert code == 0, err


def test_force_on_a_folder_of_an_older_adavar(capsys, gyro_csv, tmp_path):
    """A marker without the list of files: the files changed after it are the user's."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "deviation.csv").write_text("old")
    (out / OUTPUT_MARKER).write_text(json.dumps({"pid": 1, "host": "h", "created": 0}))
    then = time.time() - 3600
    for name in ("deviation.csv", OUTPUT_MARKER):
        os.utime(out / name, (then, then))
    (out / "notes.txt").write_text("added later")
    assert foreign_files(out) == ["notes.txt"]
    code, stdout, err = run(capsys, _avar(gyro_csv, out, "--force"))
    assert_one_line_error(code, stdout, err, "notes.txt", "adavar did not write")
    (out / "notes.txt").unlink()
    code, _, err = run(capsys, _avar(gyro_csv, out, "--force"))
    assert code == 0, err
    assert (out / "deviation.csv").read_text() != "old"


def test_batch_force_keeps_a_users_file_in_a_files_folder(capsys, tmp_path):
    path = tmp_path / "gyro.npy"
    np.save(path, simulate.white(N, rate=RATE, seed=8))
    out = tmp_path / "out"
    argv = ["batch", str(path), "--rate", "100", "--units", "deg/s", "--taus", "octave",
            "--no-html", "--out", str(out), "--json"]  # fmt: skip
    code, _, err = run(capsys, argv)
    assert code == 0, err
    mine = out / folder_name(path) / "notes.txt"
    mine.write_text("calibration run 3")
    code, stdout, _ = run(capsys, [*argv, "--force"])
    assert code == 2
    [row] = json.loads(stdout)["rows"]
    assert row["status"] == "error" and "notes.txt" in row["error"]
    assert "adavar did not write" in row["error"] and "\n" not in row["error"]
    assert mine.read_text() == "calibration run 3"


# --------------------------------------------------------------------------------------
# 14. values that overflow or lose their resolution
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("flags", [["--arw", "1e308"], ["--rate-ramp", "1e307"],
                                   ["--bias", "1.7e308", "--rrw", "1e308"]])  # fmt: skip
def test_simulate_refuses_samples_that_overflow(capsys, tmp_path, flags):
    target = tmp_path / "s.csv"
    code, out, err = run(capsys, ["simulate", "-o", str(target), "--n", "10000", *flags])
    assert_one_line_error(code, out, err, "overflow float64", "smaller coefficients")
    assert not target.exists() and list(tmp_path.iterdir()) == []


def test_simulate_keeps_large_finite_samples(capsys, tmp_path):
    code, _, err = run(capsys, ["simulate", "-o", str(tmp_path / "s.csv"), "--n", "1000",
                                "--arw", "1e200"])  # fmt: skip
    assert code == 0, err


def _davar(gyro_csv, *extra):
    return ["davar", str(gyro_csv), "--column", "gx", "--rate", "100", "--units", "deg/s",
            "--window", "1000", "--step", "500", "--taus", "octave", "--json", *extra]  # fmt: skip


def test_davar_t0_too_far_from_the_record_is_an_error(capsys, gyro_csv):
    code, out, err = run(capsys, _davar(gyro_csv, "--t0", "1e18"))
    assert_one_line_error(code, out, err, "t0 = 1e+18 s", "128 s apart", "0.01 s")
    code, out, err = run(capsys, _davar(gyro_csv, "--t0", "1.7e9"))  # a Unix time: fine
    assert code == 0, err
    times = json.loads(out)["time"]  # every 500 samples at 100 Hz: 5 s apart
    assert times["first"] == 1.7e9 + 5.0 * 0 and times["spacing"] == pytest.approx(5.0)


# --------------------------------------------------------------------------------------
# 14. the report isolates user text
# --------------------------------------------------------------------------------------


def test_a_right_to_left_override_in_a_file_name_stays_in_it(capsys, gyro_csv, tmp_path):
    name = "gyro\u202ev.csv"  # U+202E: the text after it is shown right to left
    path = tmp_path / name
    path.write_bytes(gyro_csv.read_bytes())
    html = tmp_path / "r.html"
    code, _, err = run(capsys, ["report", str(path), "--column", "gx", "--rate", "100",
                                "--units", "deg/s", "--taus", "octave", "-o",
                                str(html)])  # fmt: skip
    assert code == 0, err
    doc = html.read_text(encoding="utf-8")
    heading = re.search(r"<h1>(.*?)</h1>", doc, re.S).group(1)
    assert heading == f"<bdi><bdi>{name}</bdi>, column gx</bdi>"
    title = re.search(r"<title>(.*?)</title>", doc, re.S).group(1)
    assert title == f"\u2068\u2068{name}\u2069, column gx\u2069"  # FSI ... PDI: no markup there
    # everywhere else the name appears as text, it is inside a <bdi> of its own
    body = doc.split("<body>", 1)[1].split("<script", 1)[0]
    for found in re.finditer("\u202e", body):
        before = body[: found.start()]
        assert before.rfind("<bdi>") > before.rfind("</bdi>"), body[found.start() - 80 :]

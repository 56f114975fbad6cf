"""Progress on stderr: every command says what it is doing when stderr is a terminal, and
writes nothing extra when it is not (a pipe, a file, a CI log)."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from functools import partial

import numpy as np
import pytest

from adavar.cli.output import Status

from .cli_helpers import run

CLEAR = "\r" + " " * 79 + "\r"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A 2-channel gyro record (1500 samples at 10 Hz, a change at 75 s) and a 6-axis one."""
    folder = tmp_path_factory.mktemp("progress")
    rng = np.random.default_rng(8)
    x = rng.standard_normal((1500, 2))
    x[750:] *= 2.0
    two = folder / "gyro.csv"
    two.write_text("time,gx,gy\n" + "".join(f"{k / 10!r},{a!r},{b!r}\n" for k, (a, b) in
                                            enumerate(x.tolist())))  # fmt: skip
    six = folder / "imu.csv"
    y = rng.standard_normal((3000, 6)) * 0.01
    six.write_text("gx,gy,gz,ax,ay,az\n" + "".join(",".join(map(repr, row)) + "\n"
                                                  for row in y.tolist()))  # fmt: skip
    return {"two": two, "six": six}


def commands(files, out):
    """(argv, the steps a terminal sees) of every command that can run for a while."""
    two, six = str(files["two"]), str(files["six"])
    gyro = ["--units", "deg/s"]
    return {
        "avar": ([ "avar", two, *gyro, "--column", "gx,gy", "--fit", "--out", str(out / "avar")],
                 ["reading", "gx (1/2): computing the oadev", "gy (2/2): fitting the noise",
                  "writing"]),
        "davar": (["davar", two, *gyro, "--column", "gx", "--window", "200", "--taus",
                   "octave", "--out", str(out / "davar")],
                  ["reading", "computing the DAVAR surface of 1500 samples",
                   "fitting the noise terms of every window", "drawing the figures",
                   "writing"]),
        "adaptive": (["adaptive", two, *gyro, "--column", "gx,gy", "--lmax", "200", "--lmin",
                      "100", "--l", "30", "--taus", "octave"],
                     ["gx (1/2): computing the adaptive DAVAR surface",
                      "gy (2/2): fitting the noise terms"]),
        "report": (["report", two, *gyro, "--column", "gy", "--window", "200", "-o",
                    str(out / "r.html")],
                   ["reading", "deviation and noise fit",
                    "DAVAR surface and noise coefficients of every window",
                    "building the figures and the HTML", "writing"]),
        "kalibr": (["kalibr", six, "--rate", "100", "--gyro-units", "rad/s", "--accel-units",
                    "m/s^2", "--pinned", "bound", "-o", str(out / "imu.yaml")],
                   ["reading", "gx (1/6): computing the oadev",
                    "az (6/6): fitting the noise terms", "writing"]),
        "simulate": (["simulate", "-o", str(out / "s.csv"), "--n", "5000", "--arw", "0.1"],
                     ["simulating 5000 samples", "writing"]),
        "compare": (["compare", two, *gyro, "--column", "gx", "--change-times", "75",
                     "--lmax", "200", "--lmin", "100", "--l", "30", "--taus", "octave"],
                    ["reading", "running the methods", "kurtosis threshold crossings"]),
        "demo": (["demo", "--out", str(out / "demo"), "--workers", "1"],
                 ["NIST check values", "drawing the figures", "building the HTML report",
                  "writing"]),
    }  # fmt: skip


@pytest.fixture
def quick_demo(monkeypatch):
    """The demo without the paper's scenario (its part is timed by test_cli), on a tenth of
    the gyro's samples (the status lines are the same)."""
    import adavar.pipeline.demo

    monkeypatch.setattr(
        adavar.pipeline.demo, "run_demo", partial(adavar.pipeline.demo.run_demo, paper=False)
    )
    monkeypatch.setattr(adavar.pipeline.demo, "GYRO_SAMPLES", 100_000)


@pytest.mark.parametrize(
    "name", ["avar", "davar", "adaptive", "report", "kalibr", "simulate", "compare", "demo"]
)
def test_status_on_a_terminal_only(capsys, monkeypatch, tmp_path, files, quick_demo, name):
    (tmp_path / "plain").mkdir()
    argv, steps = commands(files, tmp_path / "plain")[name]
    if name == "demo":  # its stdout is not compared below: no figures, the same status
        argv = [*argv, "--figures", "none"]
    code, plain_out, plain_err = run(capsys, argv)
    assert code == 0, plain_err
    assert plain_err == ""  # not a terminal: nothing but the results

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    (tmp_path / "tty").mkdir()
    argv, _ = commands(files, tmp_path / "tty")[name]
    code, out, err = run(capsys, argv)
    assert code == 0, err
    for step in steps:
        assert f"\r{step}" in err, (step, err)
    assert "\n" not in err  # one line, rewritten in place
    assert err.endswith(CLEAR)  # and erased before the results
    assert all(len(line) <= 79 for line in err.split("\r"))
    if name in ("avar", "davar", "adaptive"):  # the same results, on stdout only
        tty_text = out.replace(str(tmp_path / "tty"), "DIR")
        assert tty_text == plain_out.replace(str(tmp_path / "plain"), "DIR")
    assert out.strip()


def test_a_failed_command_erases_its_status_line(capsys, monkeypatch, files):
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    code, out, err = run(capsys, ["davar", str(files["two"]), "--units", "deg/s", "--column",
                                  "gx", "--window", "5000"])  # fmt: skip
    assert code == 2 and out == ""
    status, _, message = err.rpartition(CLEAR)
    assert "\rreading" in status
    assert message.startswith("adavar: error: ") and "longer than the record" in message


def test_long_channel_names_are_cut_to_one_line(capsys, monkeypatch):
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    status = Status()
    status("x" * 200)
    status.close()
    status.close()  # a second close writes nothing more
    err = capsys.readouterr().err
    assert err.count(CLEAR) == 1 and all(len(line) <= 79 for line in err.split("\r"))


def _read_all(fd: int, into: list[bytes]) -> None:
    while True:
        try:
            chunk = os.read(fd, 4096)
        except OSError:  # EIO: the terminal's other end is closed
            return
        if not chunk:
            return
        into.append(chunk)


def _run_with_stderr(argv: list[str], terminal: bool) -> tuple[int, str, str]:
    """Run ``python -m adavar.cli ARGV`` with stderr on a pseudo-terminal or a pipe."""
    command = [sys.executable, "-m", "adavar.cli", *argv]
    if not terminal:
        done = subprocess.run(command, capture_output=True, text=True, timeout=120)
        return done.returncode, done.stdout, done.stderr
    primary, secondary = os.openpty()
    chunks: list[bytes] = []
    reader = threading.Thread(target=_read_all, args=(primary, chunks), daemon=True)
    reader.start()
    try:
        proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=secondary, text=True)
        os.close(secondary)
        out, _ = proc.communicate(timeout=120)
        reader.join(timeout=10)
    finally:
        os.close(primary)
    return proc.returncode, out, b"".join(chunks).decode()


@pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs a pseudo-terminal")
def test_real_terminal_and_pipe(files, tmp_path):
    """The same run with stderr on a pseudo-terminal, then on a pipe."""
    argv = ["avar", str(files["two"]), "--units", "deg/s", "--column", "gx", "--fit"]
    code, out, err = _run_with_stderr(argv, terminal=True)
    assert code == 0, err
    assert "\rreading" in err and "\rcomputing the oadev of 1500 samples" in err
    assert "\rfitting the noise terms" in err and err.endswith(CLEAR)
    assert "Noise fit" in out and "\r" not in out
    code, piped_out, piped_err = _run_with_stderr(argv, terminal=False)
    assert code == 0 and piped_err == ""
    assert piped_out == out

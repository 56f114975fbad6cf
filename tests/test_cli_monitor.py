"""``adavar monitor``: standard input, a file being appended to, UDP on localhost."""

from __future__ import annotations

import inspect
import json
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from adavar.dynamic.online import OnlineAdaptive
from adavar.simulate import sensor

from .cli_helpers import assert_one_line_error, run

RATE = 200.0
ARGS = ["--rate", "200", "--units", "deg/s", "--lmax", "240"]


@pytest.fixture(scope="module")
def stream():
    """A 200 Hz gyro log with a x3 burst, as text, and the library's events on it."""
    x = sensor(12_000, rate=RATE, bandwidth=40, lsb=1 / 131, angle_random_walk=0.01, seed=2)
    x[5000:6500] *= 3.0
    text = "".join(f"{v:.9g}\n" for v in x)
    x = np.array([float(v) for v in text.split()])  # the samples as the command reads them
    live = OnlineAdaptive(rate=RATE, lmax=240, thresholds="calibrated",
                          false_alarm_per_hour=0.1)  # the command's defaults  # fmt: skip
    live.push(x)
    live.finish()
    expected = [e.as_dict() for e in live.events]
    assert expected
    return x, text, expected


def parse(out: str) -> list[dict]:
    lines = [json.loads(line) for line in out.splitlines() if line.strip()]
    for k, obj in enumerate(lines):
        assert obj.pop("event") == k
        assert obj.pop("units") == "deg/s"
        # the levels' own units (an audit: N in deg/sqrt(s) under "units": "deg/s")
        units = obj.pop("coefficient_units")
        assert units["angle_random_walk"] == "deg/sqrt(s)"
        assert units["rate_random_walk"] == "deg/s/sqrt(s)"
        obj.pop("final")
        assert obj.pop("lost_datagrams", 0) == obj.pop("bad_datagrams", 0) == 0  # UDP only
    return lines


def test_stdin_subprocess(stream):
    _, text, expected = stream
    proc = subprocess.run(
        [sys.executable, "-m", "adavar.cli", "monitor", "-", *ARGS], input=text.encode(),
        capture_output=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == b""  # no status line off a terminal
    assert parse(proc.stdout.decode()) == expected


def test_stdin_in_process_columns(stream, capsys, monkeypatch):
    import io

    x, _, expected = stream
    table = "time,gx\n" + "".join(f"{i / RATE},{float(v)!r}\n" for i, v in enumerate(x))
    monkeypatch.setattr(sys, "stdin", io.StringIO(table))
    code, out, err = run(capsys, ["monitor", "-", *ARGS, "--column", "1"])
    assert code == 0, err
    assert parse(out) == expected


def test_file_appended_by_a_thread(stream, tmp_path, capsys):
    _, text, expected = stream
    path = tmp_path / "live.txt"
    path.write_text("")
    lines = text.splitlines(keepends=True)

    def writer():
        with path.open("a") as f:
            for i in range(0, len(lines), 1500):
                f.write("".join(lines[i : i + 1500]))
                f.flush()
                time.sleep(0.05)

    thread = threading.Thread(target=writer)
    thread.start()
    code, out, err = run(capsys, ["monitor", str(path), *ARGS, "--idle-timeout", "1"])
    thread.join()
    assert code == 0, err
    assert parse(out) == expected


def wait_for_listener(port: int) -> None:
    """Until a socket is bound to the UDP port (Linux: /proc/net/udp; else a few seconds)."""
    table = Path("/proc/net/udp")
    if not table.exists():  # pragma: no cover - not Linux
        time.sleep(5.0)
        return
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:  # the command binds after its imports
        if f":{port:04X} " in table.read_text():
            return
        time.sleep(0.05)


def test_udp_localhost(stream, capsys):
    x, _, _ = stream
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    data = x.astype("<f4")

    def sender():
        wait_for_listener(port)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            for i in range(0, data.size, 250):
                sock.sendto(data[i : i + 250].tobytes(), ("127.0.0.1", port))
                time.sleep(0.002)

    thread = threading.Thread(target=sender)
    thread.start()
    code, out, err = run(capsys, ["monitor", f"udp://127.0.0.1:{port}", *ARGS, "--format",
                                  "f32", "--idle-timeout", "1"])  # fmt: skip
    thread.join()
    assert code == 0, err
    live = OnlineAdaptive(rate=RATE, lmax=240, thresholds="calibrated",
                          false_alarm_per_hour=0.1)  # fmt: skip
    live.push(data.astype(float))
    live.finish()
    assert parse(out) == [e.as_dict() for e in live.events]


@pytest.mark.parametrize(
    ("text", "argv", "fragments"),
    [
        ("1\n2\nabc\n", [], ["line 3", "not a number"]),
        ("1,2\n", [], ["--column"]),
        ("1\nnan\n", [], ["nan", "interpolate"]),
        ("1\n2\n", [], ["ended after 2 samples", "--lmax 240"]),
        ("1\n", ["--noise-type", "record"], ["no whole record"]),
    ],
)
def test_bad_input(text, argv, fragments, capsys, monkeypatch):
    import io

    monkeypatch.setattr(sys, "stdin", io.StringIO(text))
    assert_one_line_error(*run(capsys, ["monitor", "-", *ARGS, *argv]), *fragments)


def test_bad_sources(capsys, tmp_path):
    assert_one_line_error(*run(capsys, ["monitor", str(tmp_path / "no.txt"), *ARGS]),
                          "no such file")  # fmt: skip
    assert_one_line_error(*run(capsys, ["monitor", "udp://127.0.0.1:0", *ARGS]), "PORT")
    assert_one_line_error(*run(capsys, ["monitor", "-", "--units", "deg/s"]), "--rate")


def test_every_keyword_has_a_flag():
    """OnlineAdaptive's keywords reach the command line (or say why not)."""
    from adavar.cli import build_parser

    parser = build_parser()
    flags = {o for _, _, a in parser.commands["monitor"].options for o in a.option_strings}
    not_flags = {"fit_options": "--bandwidth", "keep": "the command keeps recent rows",
                 "l": "--l", "thresholds": "--thresholds",
                 "pairing": "the command pairs by level (the default)",
                 "settings": "the controller's flags, as one object",
                 "method_options": "--method, --dependence, ... as one object"}  # fmt: skip
    for name in inspect.signature(OnlineAdaptive).parameters:
        flag = "--" + name.replace("_", "-")
        assert flag in flags or name in not_flags, name


def wait_for_end_of_file(pid: int, path: Path) -> None:
    """Until process ``pid`` has read ``path`` to its end (Linux: /proc; else a few seconds)."""
    fds = Path(f"/proc/{pid}/fd")
    if not fds.exists():  # pragma: no cover - not Linux
        time.sleep(5.0)
        return
    size = path.stat().st_size
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        for fd in fds.iterdir():
            try:
                if Path(os.readlink(fd)) == path:
                    info = (Path(f"/proc/{pid}/fdinfo") / fd.name).read_text()
                    if int(info.split()[1]) >= size:  # "pos: N"
                        time.sleep(0.2)  # and the last chunk pushed
                        return
            except OSError:
                continue
        time.sleep(0.05)


def test_ctrl_c_finishes_the_pass(stream, tmp_path):
    """Following a file without --idle-timeout: Ctrl-C ends it, the remaining events follow."""
    import signal

    x, text, _ = stream
    live = OnlineAdaptive(rate=RATE, lmax=240, thresholds="paper")  # events at once
    live.push(x)
    live.finish()
    expected = [e.as_dict() for e in live.events]
    assert len(expected) > 1 and expected[0]["end_s"] is not None
    path = tmp_path / "log.txt"
    path.write_text(text)
    # Ctrl-C as a user in a terminal sends it: a test run started in the background
    # (`pytest &` in a script) ignores SIGINT, and its children inherit that
    proc = subprocess.Popen(
        [sys.executable, "-m", "adavar.cli", "monitor", str(path), *ARGS, "--thresholds",
         "paper", "--final"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, bufsize=0,  # no read-ahead
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    first = proc.stdout.readline()  # the first event: the file is being followed
    wait_for_end_of_file(proc.pid, path)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert b"Traceback" not in err
    assert parse((first + out).decode()) == expected  # --final: the complete summaries


def test_events_as_confirmed(stream, capsys, monkeypatch):
    """By default an event is printed when its end is seen, its "after" still to come."""
    import io

    x, text, _ = stream
    live = OnlineAdaptive(rate=RATE, lmax=240, thresholds="paper")
    live.push(x)
    live.finish()
    monkeypatch.setattr(sys, "stdin", io.StringIO(text))
    code, out, err = run(capsys, ["monitor", "-", *ARGS, "--thresholds", "paper"])
    assert code == 0, err
    printed = [json.loads(line) for line in out.splitlines()]
    assert len(printed) == len(live.events)
    for obj, event in zip(printed, live.events, strict=True):
        for key in ("start_s", "end_s", "before", "during"):
            assert obj[key] == getattr(event, key)
        if not obj["final"]:
            assert obj["after"]["angle_random_walk"]["windows"] == 0


def test_status_line_on_a_terminal(stream, capsys, monkeypatch):
    import io

    _, text, _ = stream
    monkeypatch.setattr(sys, "stdin", io.StringIO(text))
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    code, out, err = run(capsys, ["monitor", "-", *ARGS, "--thresholds", "paper"])
    assert code == 0
    assert "monitor: 12000 samples" in err and "\r" in err  # then erased
    assert err.endswith("\r")
    assert out.count("\n") >= 1


def test_same_events_as_adaptive(tmp_path, capsys):
    """On a record without a filter roll-off, monitor prints adaptive --json's events."""
    rng = np.random.default_rng(18)
    x = rng.standard_normal(6000)
    x[3000:4000] *= 3.0
    path = tmp_path / "rec.txt"
    np.savetxt(path, x)
    flags = ["--rate", "1", "--units", "deg/s", "--lmax", "600"]
    code, out, err = run(capsys, ["adaptive", str(path), *flags, "--taus", "octave",
                                  "--noise-type", "0", "--terms", "N", "--json"])  # fmt: skip
    assert code == 0, err
    offline = json.loads(out)["events"]
    code, out, err = run(capsys, ["monitor", str(path), *flags, "--idle-timeout", "0.1"])
    assert code == 0, err
    printed = [json.loads(line) for line in out.splitlines()]
    for obj in printed:
        del obj["event"], obj["units"], obj["final"], obj["coefficient_units"]
    assert printed == offline and offline


def test_ici_stdin_same_events_as_adaptive(tmp_path, capsys, monkeypatch):
    """--method ici through standard input prints adaptive --method ici's events."""
    import io

    rng = np.random.default_rng(18)
    x = rng.standard_normal(6000)
    x[3000:4000] *= 3.0
    path = tmp_path / "rec.txt"
    np.savetxt(path, x)
    flags = ["--rate", "1", "--units", "deg/s", "--lmax", "600", "--method", "ici",
             "--ici-edf-samples", "2000"]  # fmt: skip
    code, out, err = run(capsys, ["adaptive", str(path), *flags, "--taus", "octave",
                                  "--noise-type", "0", "--terms", "N", "--json"])  # fmt: skip
    assert code == 0, err
    offline = json.loads(out)["events"]
    monkeypatch.setattr(sys, "stdin", io.StringIO(path.read_text()))
    code, out, err = run(capsys, ["monitor", "-", *flags, "--final"])  # "after" final
    assert code == 0, err
    printed = [json.loads(line) for line in out.splitlines()]
    for obj in printed:
        del obj["event"], obj["units"], obj["final"], obj["coefficient_units"]
    assert printed == offline and len(offline) == 1
    monkeypatch.setattr(sys, "stdin", io.StringIO("1\n"))
    assert_one_line_error(*run(capsys, ["monitor", "-", *flags, "--ici-edf", "engine"]),
                          "ici_edf='correlation'")  # fmt: skip

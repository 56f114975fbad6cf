"""``adavar monitor`` in a process of its own: a followed file rotated, truncated and
deleted (like ``tail -F``), and SIGTERM finishing the pass (issue 40)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from adavar.dynamic.online import OnlineAdaptive
from adavar.simulate import sensor

RATE = 200.0
ARGS = ["--rate", "200", "--units", "deg/s", "--lmax", "240", "--thresholds", "paper"]

pytestmark = pytest.mark.skipif(
    not Path("/proc/self/fdinfo").exists(), reason="Linux: /proc says how far a process has read"
)


@pytest.fixture(scope="module")
def record():
    """A 200 Hz gyro log with a x3 burst, as the command reads it back from text."""
    x = sensor(12_000, rate=RATE, bandwidth=40, lsb=1 / 131, angle_random_walk=0.01, seed=2)
    x[5000:6500] *= 3.0
    return np.array([float(f"{v:.9g}") for v in x])


def text(x: np.ndarray) -> str:
    return "".join(f"{float(v)!r}\n" for v in x)


def library_events(x: np.ndarray) -> list[dict]:
    live = OnlineAdaptive(rate=RATE, lmax=240, thresholds="paper")
    live.push(x)
    live.finish()
    return [e.as_dict() for e in live.events]


def read_to_end(proc: subprocess.Popen, path: Path) -> None:
    """Until the monitor has read ``path`` to its end (its descriptor's position)."""
    size = path.stat().st_size
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        for fd in Path(f"/proc/{proc.pid}/fd").iterdir():
            try:
                if Path(os.readlink(fd)) == path:
                    info = Path(f"/proc/{proc.pid}/fdinfo/{fd.name}").read_text()
                    if int(info.split()[1]) >= size:  # "pos: N"
                        time.sleep(0.2)  # and the last piece pushed
                        return
            except OSError:
                continue
        time.sleep(0.02)
    raise AssertionError(f"{path.name} not read to its end (exit code {proc.poll()})")


class Lines:
    """The lines a pipe gives, collected by a thread; wait for one holding a fragment."""

    def __init__(self, proc: subprocess.Popen, pipe) -> None:
        self.proc = proc
        self.lines: list[str] = []
        self.thread = threading.Thread(target=self._read, args=(pipe,), daemon=True)
        self.thread.start()

    def _read(self, pipe) -> None:
        for line in iter(pipe.readline, b""):
            self.lines.append(line.decode())

    def wait_for(self, fragment: str, timeout: float = 60.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if any(fragment in line for line in self.lines):
                return
            if self.proc.poll() is not None:
                break
            time.sleep(0.02)
        raise AssertionError(f"no line with {fragment!r} in {self.lines}")


def monitor(source: str, *extra: str, **popen) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "adavar.cli", "monitor", source, *ARGS, "--final",
         "--summary", *extra],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, bufsize=0, **popen,
    )  # fmt: skip


def finished(proc: subprocess.Popen, out: Lines, err: Lines) -> tuple[list[dict], dict]:
    """SIGTERM, then the events and the summary it printed."""
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=120) == 0, err.lines  # before: killed (-15), events lost
    out.thread.join(10)
    err.thread.join(10)
    assert not any("Traceback" in line for line in err.lines)
    printed = [json.loads(line) for line in out.lines]
    summary = printed.pop()["summary"]
    for k, obj in enumerate(printed):
        assert obj.pop("event") == k and obj.pop("final") is True
        del obj["units"], obj["coefficient_units"]
    return printed, summary


def test_rotation_truncation_and_deletion(record, tmp_path):
    """Followed like tail -F: every sample of every file, in order, and each change said.

    Before, the monitor kept reading the rotated file (and the old offset of a truncated
    one, and a deleted file) forever: only the first file's samples were seen.
    """
    parts = np.split(record, [4000, 7000, 9500])
    path = tmp_path / "live.txt"
    path.write_text(text(parts[0]))
    proc = monitor(str(path))
    out, err = Lines(proc, proc.stdout), Lines(proc, proc.stderr)
    read_to_end(proc, path)
    # rotation: the old file moved aside, a new one (with a header) at the path
    os.link(path, tmp_path / "live.txt.1")
    new = tmp_path / "new.txt"
    new.write_text("gx\n" + text(parts[1]))
    os.replace(new, path)
    err.wait_for("was replaced (rotated)")
    read_to_end(proc, path)
    # truncation (copytruncate), then new lines
    path.write_text("")
    err.wait_for("was truncated (from")
    with path.open("a") as f:
        f.write(text(parts[2]))
    read_to_end(proc, path)
    # deletion, then a new file of the same name
    path.unlink()
    err.wait_for("was deleted or moved away")
    path.write_text(text(parts[3]))
    err.wait_for("has appeared: following the new file")
    read_to_end(proc, path)
    printed, summary = finished(proc, out, err)
    assert summary == {"samples": record.size, "events": len(printed), "ended_by": "SIGTERM",
                       "file_truncated": 1, "file_replaced": 1, "file_deleted": 1}  # fmt: skip
    assert printed == library_events(record)


def test_sigterm_on_standard_input(record):
    """SIGTERM ends a pipe that stays open as Ctrl-C does: the pass is finished, exit 0."""
    proc = monitor("-", stdin=subprocess.PIPE)
    out, err = Lines(proc, proc.stdout), Lines(proc, proc.stderr)
    proc.stdin.write(text(record).encode())  # and the pipe stays open
    out.wait_for('"event": 0')  # the first event (final): the stream is being read
    time.sleep(0.3)
    printed, summary = finished(proc, out, err)
    proc.stdin.close()
    assert summary["ended_by"] == "SIGTERM"
    # the pass of every sample read before the signal, finished
    assert printed == library_events(record[: summary["samples"]])
    assert len(printed) == summary["events"] > 1

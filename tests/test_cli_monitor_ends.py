"""``adavar monitor`` loses nothing without a word (issue 40): a bad line or sample ends
the stream with the events of the samples before it, a wrongly sized datagram is dropped and
counted (it shifted every later sample), the kernel's drops are counted to the datagram."""

from __future__ import annotations

import json
import socket
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from adavar.dynamic.online import OnlineAdaptive

from .cli_helpers import assert_one_line_error, run
from .test_cli_monitor import ARGS, RATE, parse, stream, wait_for_listener

__all__ = ["free_udp_port", "stream"]  # the fixture, shared


def test_bad_line_finishes_the_pass(stream, capsys, monkeypatch):
    """A bad line ends the stream: the events of the samples before it, then exit 2."""
    import io

    x, text, _ = stream
    live = OnlineAdaptive(rate=RATE, lmax=240, thresholds="paper")
    live.push(x[:10_000])
    live.finish()
    expected = [e.as_dict() for e in live.events]
    assert expected
    lines = text.splitlines(keepends=True)
    bad = "".join(lines[:10_000]) + "1.5e\n" + "".join(lines[10_000:])
    monkeypatch.setattr(sys, "stdin", io.StringIO(bad))
    code, out, err = run(capsys, ["monitor", "-", *ARGS, "--thresholds", "paper", "--final"])
    assert code == 2
    assert parse(out) == expected  # before: nothing printed
    assert err.strip().splitlines() == [
        "adavar: error: line 10001: '1.5e' is not a number (one sample a line, or --column N "
        "of delimited lines)"
    ]


def test_bad_binary_sample_finishes_the_pass(stream, tmp_path, capsys):
    x, _, _ = stream
    data = x.astype("<f4")
    live = OnlineAdaptive(rate=RATE, lmax=240, thresholds="paper")
    live.push(data[:9000].astype(float))
    live.finish()
    data[9000] = np.nan
    path = tmp_path / "log.f32"
    path.write_bytes(data.tobytes())
    argv = ["monitor", str(path), *ARGS, "--thresholds", "paper", "--format", "f32",
            "--idle-timeout", "0.2", "--final"]  # fmt: skip
    code, out, err = run(capsys, argv)
    assert code == 2
    assert parse(out) == [e.as_dict() for e in live.events]
    assert_one_line_error(code, "", err, "sample 9000 is nan", "interpolate")


def free_udp_port() -> int:
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    return port


def test_wrongly_sized_datagram_is_dropped_and_counted(stream, capsys):
    """A 6-byte f32 datagram shifted every later sample by two bytes: now dropped, counted."""
    x, _, _ = stream
    port = free_udp_port()
    data = x.astype("<f4")

    def sender():
        wait_for_listener(port)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            for i in range(0, data.size, 250):
                if i == 4000:
                    sock.sendto(b"\x00" * 6, ("127.0.0.1", port))
                sock.sendto(data[i : i + 250].tobytes(), ("127.0.0.1", port))
                time.sleep(0.002)

    thread = threading.Thread(target=sender)
    thread.start()
    code, out, err = run(capsys, ["monitor", f"udp://127.0.0.1:{port}", *ARGS, "--format",
                                  "f32", "--idle-timeout", "1", "--summary"])  # fmt: skip
    thread.join()
    assert code == 0, err
    live = OnlineAdaptive(rate=RATE, lmax=240, thresholds="calibrated",
                          false_alarm_per_hour=0.1)  # fmt: skip
    live.push(data.astype(float))
    live.finish()
    lines = [json.loads(line) for line in out.splitlines()]
    summary = lines.pop()["summary"]
    assert summary["samples"] == data.size and summary["bad_datagrams"] == 1
    assert summary["lost_datagrams"] == 0 and summary["ended_by"] == "idle timeout"
    for obj in lines:  # every event is confirmed after the bad datagram (at 20 s)
        assert obj.pop("bad_datagrams") == 1 and obj.pop("lost_datagrams") == 0
        del obj["event"], obj["units"], obj["final"], obj["coefficient_units"]
    assert lines == [e.as_dict() for e in live.events]
    assert "dropped a datagram of 6 bytes, not a whole number of 4-byte samples" in err
    assert f"udp://127.0.0.1:{port}: 48 datagrams, 0 lost, 1 malformed" in err


def test_a_bad_text_datagram_is_dropped_and_counted(stream, capsys):
    """One text datagram that is no line of numbers ended the stream (exit 2), where a
    binary one of a wrong size is dropped and counted (an independent audit)."""
    x, _, _ = stream
    port = free_udp_port()

    def sender():
        wait_for_listener(port)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            for i in range(0, x.size, 250):
                if i == 4000:
                    sock.sendto(b"hello\n", ("127.0.0.1", port))
                block = "".join(f"{float(v)!r}\n" for v in x[i : i + 250])
                sock.sendto(block.encode(), ("127.0.0.1", port))
                time.sleep(0.002)

    thread = threading.Thread(target=sender)
    thread.start()
    code, out, err = run(capsys, ["monitor", f"udp://127.0.0.1:{port}", *ARGS,
                                  "--idle-timeout", "1", "--summary"])  # fmt: skip
    thread.join()
    assert code == 0, err
    summary = json.loads(out.splitlines()[-1])["summary"]
    assert summary["samples"] == x.size and summary["bad_datagrams"] == 1
    assert summary["ended_by"] == "idle timeout"
    assert "dropped a datagram that is not lines of numbers" in err


@pytest.mark.skipif(not Path("/proc/net/udp").exists(), reason="Linux: SO_RXQ_OVFL, /proc")
def test_kernel_drops_are_counted(monkeypatch):
    """Datagrams the kernel drops (a full receive buffer) are counted, to the datagram."""
    from adavar.cli import monitor_sources

    monkeypatch.setattr(monitor_sources, "RECEIVE_BUFFER", 4096)  # the smallest Linux allows
    port = free_udp_port()
    source = monitor_sources.UdpSource(f"udp://127.0.0.1:{port}", "127.0.0.1", port, 0.3, 4)
    sent = 400
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        with source._lock:  # the reader stops at its first datagram: the buffer fills
            for i in range(sent):
                sock.sendto(np.float32(i).tobytes(), ("127.0.0.1", port))
        received = b"".join(chunk for chunk in source if chunk)  # until 0.3 s idle
    source.close()
    assert source.ended == "idle timeout"
    kept = np.frombuffer(received, dtype="<f4")
    assert source.lost > sent // 2
    assert kept.size == source.datagrams == sent - source.lost
    assert np.all(np.diff(kept) > 0)  # in order
    assert any("datagrams lost so far" in notice for notice in source.notices)

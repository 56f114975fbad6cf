"""``adavar monitor udp://``: 10 000 datagrams a second of one sample each, on one core,
nothing lost (issue 40: the kernel dropped 48 269 of 60 000 at that rate, silently)."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from adavar.dynamic.online import OnlineAdaptive
from adavar.simulate import sensor

from .test_cli_monitor_ends import free_udp_port

RATE = 10_000
COUNT = 30_000  # 3 s at the rate (benchmarks/bench_monitor_udp.py: longer)


def one_core() -> None:
    """Run the monitor on one core (its reader thread and its pass share it)."""
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {max(os.sched_getaffinity(0))})


@pytest.mark.skipif(not Path("/proc/net/udp").exists(), reason="Linux: /proc/net/udp")
def test_ten_thousand_datagrams_a_second_on_one_core():
    x = sensor(COUNT, rate=RATE, bandwidth=2000, angle_random_walk=0.01, seed=40)
    x[20_000:26_000] *= 3.0
    data = x.astype("<f4")
    port = free_udp_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "adavar.cli", "monitor", f"udp://127.0.0.1:{port}", "--rate",
         str(RATE), "--units", "deg/s", "--lmax", "0.5s", "--format", "f32",
         "--idle-timeout", "0.5", "--summary", "--final"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=one_core,
    )  # fmt: skip
    deadline = time.monotonic() + 60
    while f":{port:04X} " not in Path("/proc/net/udp").read_text():  # bound after its imports
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.02)
    payloads = [data[i : i + 1].tobytes() for i in range(COUNT)]
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        start = time.monotonic()
        sent = 0
        while sent < COUNT:  # paced: at most RATE a second, in bursts of about a millisecond
            due = min(COUNT, int((time.monotonic() - start) * RATE) + 1)
            for payload in payloads[sent:due]:
                sock.sendto(payload, ("127.0.0.1", port))
            sent = due
            time.sleep(0.0005)
        elapsed = time.monotonic() - start
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert COUNT / elapsed > 0.9 * RATE  # the test did send at the rate
    lines = [json.loads(line) for line in out.decode().splitlines()]
    summary = lines.pop()["summary"]
    assert summary["datagrams"] == summary["samples"] == COUNT
    assert summary["lost_datagrams"] == summary["bad_datagrams"] == 0
    assert summary["receive_buffer"] > 0
    assert f"{COUNT} datagrams, 0 lost, 0 malformed" in err.decode()
    live = OnlineAdaptive(rate=RATE, lmax=RATE // 2, thresholds="calibrated",
                          false_alarm_per_hour=0.1)  # the command's defaults  # fmt: skip
    live.push(data.astype(float))
    live.finish()
    for obj in lines:
        del (
            obj["event"],
            obj["units"],
            obj["final"],
            obj["coefficient_units"],
            obj["lost_datagrams"],
            obj["bad_datagrams"],
        )
    assert lines == [e.as_dict() for e in live.events]

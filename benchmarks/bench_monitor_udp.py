"""``adavar monitor udp://`` (issue 40): datagrams lost at 1 000 .. 20 000 a second.

A sender paces datagrams of one little-endian float32 sample each to a monitor on
loopback, for ``--seconds`` seconds at each rate; the monitor runs in a process of its own
pinned to one core (its reader thread and its pass share it), ``--lmax 2s``, the default
(calibrated) thresholds, ``--idle-timeout 2``. Per rate it prints the datagrams sent, the
kernel's receive-buffer drops during the run (``RcvbufErrors`` of ``/proc/net/snmp``: every
UDP socket of the machine, only this traffic here), the samples the monitor's pass received
and the losses it reported (``--summary``), and its CPU time.

``--previous REV`` also runs the monitor of git revision REV (its ``src/adavar/cli/
monitor.py``, on today's library) in the same way, in the same run: before issue 40 it
read one datagram at a time between pushes, with the default receive buffer, and reported
no loss.

Linux only (``/proc/net/snmp``, ``/proc/net/udp``). Run:
``python benchmarks/bench_monitor_udp.py [--seconds 6] [--rates 1000,3000,10000,20000]
[--previous REV]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _machine import describe

ROOT = Path(__file__).resolve().parents[1]
#: runs the monitor module given as argv[1] (a file) with the rest of the arguments
PREVIOUS_RUNNER = """
import importlib.util, sys
spec = importlib.util.spec_from_file_location("previous_monitor", sys.argv[1])
module = importlib.util.module_from_spec(spec)
spec.loader.exec_module(module)
from adavar.cli.parser import Parser
parser = Parser(prog="adavar")
module.add_monitor_parser(parser.add_subparsers(dest="command", parser_class=Parser))
args = parser.parse_args(["monitor", *sys.argv[2:]])
try:
    sys.exit(args.handler(args))
except Exception as exc:
    print(f"adavar: error: {exc}", file=sys.stderr)
    sys.exit(2)
"""


def udp_counters() -> dict[str, int]:
    rows = [line.split() for line in Path("/proc/net/snmp").read_text().splitlines()
            if line.startswith("Udp:")]  # fmt: skip
    return dict(zip(rows[0][1:], map(int, rows[1][1:]), strict=True))


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def one_core() -> None:
    os.sched_setaffinity(0, {max(os.sched_getaffinity(0))})


def run(command: list[str], rate: int, seconds: float) -> dict:
    """One monitor at one rate: what was sent, dropped, received, reported, spent."""
    port = free_port()
    count = int(rate * seconds)
    payloads = [np.float32(v).tobytes() for v in np.random.default_rng(rate).standard_normal(count)]
    flags = ["--rate", str(rate), "--units", "deg/s", "--lmax", "2s", "--format", "f32",
             "--idle-timeout", "2"]  # fmt: skip
    before_cpu = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.Popen([*command, f"udp://127.0.0.1:{port}", *flags],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=one_core)  # fmt: skip
    while f":{port:04X} " not in Path("/proc/net/udp").read_text():
        if proc.poll() is not None:
            raise RuntimeError(proc.communicate()[1].decode())
        time.sleep(0.02)
    counters = udp_counters()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        start, sent = time.monotonic(), 0
        while sent < count:
            due = min(count, int((time.monotonic() - start) * rate) + 1)
            for payload in payloads[sent:due]:
                sock.sendto(payload, ("127.0.0.1", port))
            sent = due
            time.sleep(0.0005)
        elapsed = time.monotonic() - start
    out, _ = proc.communicate(timeout=600)
    dropped = udp_counters()["RcvbufErrors"] - counters["RcvbufErrors"]
    after_cpu = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after_cpu.ru_utime - before_cpu.ru_utime) + (after_cpu.ru_stime - before_cpu.ru_stime)
    summary = {}
    for line in out.decode().splitlines():
        obj = json.loads(line)
        summary = obj.get("summary", summary)
    return dict(sent=count, send_rate=count / elapsed, kernel_drops=dropped,
                received=summary.get("samples"), reported=summary.get("lost_datagrams"),
                code=proc.returncode, cpu=cpu)  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=6.0)
    parser.add_argument("--rates", default="1000,3000,10000,20000")
    parser.add_argument("--previous", metavar="REV", help="also run this revision's monitor")
    options = parser.parse_args()
    print(describe())
    print(f"one f32 sample a datagram, {options.seconds:g} s at each rate, monitor on one core")
    monitors = {"now": [sys.executable, "-m", "adavar.cli", "monitor", "--summary"]}
    folder = tempfile.TemporaryDirectory()
    if options.previous:
        source = subprocess.run(["git", "show", f"{options.previous}:src/adavar/cli/monitor.py"],
                                cwd=ROOT, check=True, capture_output=True).stdout  # fmt: skip
        module = Path(folder.name) / "previous_monitor.py"
        module.write_bytes(source)
        monitors[options.previous] = [sys.executable, "-c", PREVIOUS_RUNNER, str(module)]
    print(f"{'monitor':>10} {'rate/s':>7} {'sent':>7} {'kernel drops':>13} {'received':>9} "
          f"{'reported':>9} {'cpu s':>6} exit")  # fmt: skip
    for rate in (int(r) for r in options.rates.split(",")):
        for name, command in monitors.items():
            r = run(command, rate, options.seconds)
            lost = f"{r['kernel_drops']} ({r['kernel_drops'] / r['sent']:.1%})"
            print(f"{name:>10} {r['send_rate']:7.0f} {r['sent']:7d} {lost:>13} "
                  f"{r['received'] if r['received'] is not None else '-':>9} "
                  f"{r['reported'] if r['reported'] is not None else '-':>9} {r['cpu']:6.2f} "
                  f"{r['code']}", flush=True)  # fmt: skip
    folder.cleanup()


if __name__ == "__main__":
    main()

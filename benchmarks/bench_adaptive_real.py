"""The adaptive window on realistic sensor logs, with the record-based default windows.

For each sample rate, the bandwidth-limited, quantised simulator (filter at a fifth of the
rate, 1/131 deg/s LSB; N 0.3 deg/sqrt(h), B 7 deg/h, K 21 deg/h/sqrt(h)):

* **stationary**: 2-hour records; the fraction of centres where the window shrank and the
  number of shrink episodes (false events) per hour;
* **disturbed**: 1-hour records with the white noise x3 or x1.5 from 20 to 40 minutes; the
  event's start and end (:func:`adavar.dynamic.events.find_events`: the window's leading edge at
  the first shrink of each episode, changes paired into stretches), their errors against
  the truth and against ``Lmin/2``.

The windows are :func:`adavar.dynamic.adaptive.record_windows` of the record (Lmax a tenth of it),
the thresholds those of ``adavar adaptive``'s defaults: calibrated for 0.1 false events per
stationary hour (``--thresholds paper`` for the paper's: ``--paper``). A false event is a
shrink episode (episodes less than Lmax/4 apart are one). The last part times ``adavar
adaptive`` on a 1-hour 200 Hz 3-axis CSV with default flags.

Run: ``python benchmarks/bench_adaptive_real.py [--seeds 10]``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from _machine import describe

import adavar
from adavar import simulate
from adavar.dynamic.adaptive import record_windows
from adavar.dynamic.events import find_events

NOISE = dict(angle_random_walk=0.005, bias_instability=0.002, rate_random_walk=1e-4, lsb=1 / 131)


def _record(n: int, rate: float, seed: int, factor: float | None = None) -> np.ndarray:
    kw = dict(NOISE, rate=rate, bandwidth=rate / 5)
    x = simulate.sensor(n, seed=seed, **kw)
    if factor is not None:
        loud = simulate.sensor(n, seed=seed + 10_000, **{**kw, "angle_random_walk": 0.005 * factor})
        a, b = int(1200 * rate), int(2400 * rate)
        x[a:b] = loud[a:b]
    return x


def _episodes(window: np.ndarray, lmax: int, step: int) -> int:
    short = np.concatenate(([0], (window < lmax).astype(np.int8), [0]))
    edges = np.diff(short)
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    if starts.size == 0:
        return 0
    return 1 + int(np.sum((starts[1:] - ends[:-1]) * step > lmax / 4))


#: The controller's thresholds: the command line's default, or the paper's (--paper).
THRESHOLDS = {"thresholds": "calibrated", "false_alarm_per_hour": 0.1}


def stationary(rate: float, seeds: int) -> str:
    n = int(2 * 3600 * rate)
    lmax, lmin, seg = record_windows(n)
    fractions, events = [], []
    for seed in range(seeds):
        sched = adavar.adaptive_schedule(_record(n, rate, seed), rate=rate, lmax=lmax,
                                         lmin=lmin, l=seg, step=10, **THRESHOLDS)  # fmt: skip
        fractions.append(float(np.mean(sched.window < lmax)))
        events.append(_episodes(np.asarray(sched.window), lmax, 10) / 2.0)
    return (f"| {rate:g} Hz | stationary 2 h | Lmax {lmax} ({lmax / rate:g} s) | shrunk "
            f"{100 * np.mean(fractions):.2f} % of centres | {np.mean(events):.2f} false "
            f"events/h |")  # fmt: skip


def disturbed(rate: float, factor: float, seeds: int) -> str:
    n = int(3600 * rate)
    lmax, lmin, seg = record_windows(n)
    starts, ends, found = [], [], 0
    for seed in range(seeds):
        x = _record(n, rate, seed, factor)
        sched = adavar.adaptive_schedule(x, rate=rate, lmax=lmax, lmin=lmin, l=seg, step=10,
                                         **THRESHOLDS)  # fmt: skip
        events = find_events(sched.window, sched.centre, sched.centre / rate, lmax, 1 / rate,
                             {}, duration=n / rate)  # fmt: skip
        near = [e for e in events if abs(e.start_s - 1200.0) < lmax / rate]
        if near:
            found += 1
            starts.append(near[0].start_s - 1200.0)
            if near[0].end_s is not None:
                ends.append(near[0].end_s - 2400.0)
    half = lmin / 2 / rate
    both = sum(abs(a) <= half for a in starts) if starts else 0
    good_end = sum(abs(b) <= half for b in ends)
    med = lambda v: f"{np.median(v):+.1f} s" if v else "-"  # noqa: E731
    return (f"| {rate:g} Hz | x{factor:g} for 20 min | Lmin/2 = {half:g} s | found {found}/"
            f"{seeds}; start within Lmin/2 {both}/{seeds}, end {good_end}/{seeds} | median "
            f"error start {med(starts)}, end {med(ends)} |")  # fmt: skip


def cli_run() -> str:
    rate, n = 200.0, 720_000
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "imu.csv")
        cols = [_record(n, rate, seed) for seed in range(3)]
        t = np.arange(n) / rate
        np.savetxt(path, np.column_stack([t, *cols]), delimiter=",", header="time,gx,gy,gz",
                   comments="", fmt="%.9g")  # fmt: skip
        out = os.path.join(tmp, "out")
        cmd = ["/usr/bin/time", "-v", sys.executable, "-m", "adavar.cli", "adaptive", path,
               "--column", "gx,gy,gz", "--units", "deg/s", "--out", out]  # fmt: skip
        start = time.perf_counter()
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        wall = time.perf_counter() - start
        rss = next((line.split(":")[1].strip() for line in done.stderr.splitlines()
                    if "Maximum resident" in line), "?")  # fmt: skip
        size = sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(out) for f in fs)
    return (
        f"`adavar adaptive` 1 h, 200 Hz, 3 axes, default flags: exit {done.returncode}, "
        f"{wall:.1f} s, peak RSS {int(rss) / 1024:.0f} MB, outputs {size / 2**20:.0f} MB"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--paper", action="store_true", help="the paper's thresholds")
    parser.add_argument("--no-cli", action="store_true", help="skip the CLI timing")
    parser.add_argument("--rates", default="100,200,1000")
    args = parser.parse_args()
    if args.paper:
        THRESHOLDS.clear()
        THRESHOLDS["thresholds"] = "paper"
    print(f"thresholds: {THRESHOLDS}")
    print(f"machine: {describe()}")
    print("| rate | record | window | result | |")
    print("|---|---|---|---|---|")
    for rate in map(float, args.rates.split(",")):
        print(stationary(rate, args.seeds))
        for factor in (3.0, 1.5):
            print(disturbed(rate, factor, args.seeds))
    if not args.no_cli:
        print(cli_run())


if __name__ == "__main__":
    main()

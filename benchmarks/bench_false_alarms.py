"""False events per stationary hour of the per-hour calibrated thresholds, against target.

For white noise, for the bandwidth-limited, quantised sensor simulator (filter at a fifth
of the rate, 1/131 deg/s LSB) and for white noise behind a 4th-order Butterworth at a tenth
of the rate (``filtered``: scipy, independent of adavar's simulator; ``c4`` about 3), at
several window lengths (the paper's proportions Lmin =
Lmax - 2 round(Lmax/6), l = round(Lmax/6)), the adaptive controller runs over many hours of
stationary data with ``thresholds="calibrated", false_alarm_per_hour=F`` and the shrink
episodes (less than Lmax/4 apart: one) are counted. The calibration is an upper bound
(docs/method.md section 8): the ratio measured/target should be at most 1. With the paper's
thresholds for comparison.

Run: ``python benchmarks/bench_false_alarms.py [--hours 40]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _machine import describe

import adavar


def _episodes(window: np.ndarray, lmax: int) -> int:
    edges = np.diff(np.concatenate(([0], (window < lmax).astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return 0 if starts.size == 0 else 1 + int(np.sum(starts[1:] - ends[:-1] > lmax / 4))


def run(rate: float, lmax: int, kind: str, target: float | None, hours: float) -> str:
    seg = round(lmax / 6)
    lmin = lmax - 2 * seg
    piece_h = min(hours, 5.0)
    n = int(piece_h * 3600 * rate)
    count, done, seed, elapsed = 0, 0.0, 0, 0.0
    while done < hours - 1e-9:
        if kind == "white":
            x = np.random.default_rng(seed).standard_normal(n)
        elif kind == "filtered":
            from scipy import signal

            b, a = signal.butter(4, 0.2)  # a tenth of the rate (0.2 of Nyquist)
            x = signal.lfilter(b, a, np.random.default_rng(seed).standard_normal(n))
        else:
            x = adavar.simulate.sensor(n, rate=rate, angle_random_walk=0.005,
                                       bandwidth=rate / 5, lsb=1 / 131, seed=seed)  # fmt: skip
        kw = ({"thresholds": "paper"} if target is None else
              {"thresholds": "calibrated", "false_alarm_per_hour": target})  # fmt: skip
        start = time.perf_counter()
        sched = adavar.adaptive_schedule(x, rate=rate, lmax=lmax, lmin=lmin, l=seg, **kw)
        elapsed += time.perf_counter() - start
        count += _episodes(np.asarray(sched.window), lmax)
        done += piece_h
        seed += 1
    per_hour = count / done
    ratio = "-" if target is None else f"{per_hour / target:.2f}"
    name = "paper" if target is None else f"{target:g}/h"
    return (f"| {rate:g} Hz | {kind} | Lmax {lmax} ({lmax / rate:g} s) | {name} | {done:g} h "
            f"| {count} | {per_hour:.3g}/h | {ratio} | {elapsed:.1f} s |")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=40.0)
    parser.add_argument("--targets", default="10,60", help="per-hour targets, comma-separated")
    args = parser.parse_args()
    targets = [None] + [float(t) for t in args.targets.split(",")]
    print(f"machine: {describe()}")
    print(
        "| rate | noise | window | thresholds | hours | events | per hour | measured/target "
        "| controller time |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for rate, lmax in ((100.0, 600), (100.0, 6000), (200.0, 36000)):
        for kind in ("white", "sensor", "filtered"):
            for target in targets:
                print(run(rate, lmax, kind, target, args.hours), flush=True)


if __name__ == "__main__":
    main()

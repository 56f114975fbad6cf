"""Warm kernel speed of this tree against a baseline tree (e.g. the previous main), one run.

Each case runs in a fresh process per tree, alternating the trees, on a warm Numba cache
(a first call compiles or loads, then the best of ``--repeat`` calls is timed), on records
written here (not ``adavar.simulate``): a band-limited, quantised gyro at 200 Hz with a
random walk and a level step, one hour (720 000 samples), and a tenth of a missing-sample
mask for the gapped cases. The cases are the paths every command reaches: the deviation
with intervals (OADEV, MDEV, TOTDEV; the noise identification), the noise fit, a DAVAR
surface (Allan, Hadamard, with gaps), the adaptive schedule (kurtosis controller), the
record-form kurtosis contribution, the noise fit of every window and the out-of-core
deviation.

Run: ``python benchmarks/bench_kernels.py --baseline OTHER/src [--repeat 5]``. Prints one
table: each case's best time for both trees and their ratio (baseline / this tree: above
1, this tree is faster).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(__file__))
from _machine import describe, speed_probe

_CASE = r"""
import json, sys, time, warnings
import numpy as np
warnings.simplefilter("ignore")
import adavar

case, path, repeat = sys.argv[1], sys.argv[2], int(sys.argv[3])
x = np.load(path)
gapped = x.copy()
gapped[np.random.default_rng(9).random(x.size) < 0.1] = np.nan
small = x[:200_000]


def fit_of_curve():
    curve = adavar.deviation(x, rate=200.0, units="deg/s")
    return lambda: adavar.fit_noise(curve)


def fit_of_windows():
    surface = adavar.davar(small, rate=200.0, window=6000, taus="octave", step=200)
    return lambda: adavar.fit_noise(surface)


cases = {
    "deviation oadev (intervals)": lambda: adavar.deviation(x, rate=200.0),
    "deviation mdev": lambda: adavar.deviation(x, rate=200.0, stat="mdev"),
    "deviation totdev, 2e5": lambda: adavar.deviation(small, rate=200.0, stat="totdev"),
    "deviation oadev, gaps omitted": lambda: adavar.deviation(gapped, rate=200.0, gaps="omit"),
    "deviation oadev, out of core": lambda: adavar.deviation(x, rate=200.0, chunk_size=1 << 16),
    "fit_noise": fit_of_curve,
    "davar oavar, 2e5": lambda: adavar.davar(small, rate=200.0, window=6000, taus="octave",
                                             step=20),
    "davar ohvar, 2e5": lambda: adavar.davar(small, rate=200.0, window=6000, taus="octave",
                                             step=20, stat="ohvar"),
    "davar, gaps omitted, 2e5": lambda: adavar.davar(gapped[:200_000], rate=200.0,
                                                     window=6000, taus="octave", step=20,
                                                     gaps="omit"),
    "adaptive_schedule": lambda: adavar.adaptive_schedule(x, rate=200.0, lmax=6000,
                                                          lmin=4000, l=1000),
    "kurtosis_contribution": lambda: adavar.kurtosis_contribution(x, window=6000,
                                                                 reference="record"),
    "fit of every window": fit_of_windows,
}
fn = cases[case]
if case.startswith("fit"):  # its input (a curve, a surface) made here, not timed
    fn = fn()
fn()  # compiled or loaded from the cache, not timed
best = min(
    (lambda t0: (fn(), time.perf_counter() - t0)[1])(time.perf_counter())
    for _ in range(repeat)
)
print(json.dumps(best))
"""

CASES = [
    "deviation oadev (intervals)",
    "deviation mdev",
    "deviation totdev, 2e5",
    "deviation oadev, gaps omitted",
    "deviation oadev, out of core",
    "fit_noise",
    "davar oavar, 2e5",
    "davar ohvar, 2e5",
    "davar, gaps omitted, 2e5",
    "adaptive_schedule",
    "kurtosis_contribution",
    "fit of every window",
]


def _record(path: str) -> None:
    import numpy as np

    rng = np.random.default_rng(2026)
    n = 720_000
    white = rng.standard_normal(n + 15)
    smooth = np.convolve(white, np.ones(16) / 16, mode="valid")[:n] * 4e-3
    walk = np.cumsum(2e-6 * rng.standard_normal(n))
    x = smooth + walk
    x[n // 2 :] += 5e-3
    np.save(path, np.round(x / 1e-4) * 1e-4)


def _time(src: str | None, case: str, path: str, repeat: int) -> float:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = src
    done = subprocess.run([sys.executable, "-c", _CASE, case, path, str(repeat)], env=env,
                          capture_output=True, text=True, check=True)  # fmt: skip
    return float(json.loads(done.stdout.strip().splitlines()[-1]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", required=True, help="the src folder of the other tree")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    print(f"machine: {describe()}")
    print(f"at the start, {speed_probe()}")
    print("| case | this tree | baseline | baseline / this tree |")
    print("|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        path = f"{folder}/gyro.npy"
        _record(path)
        for case in CASES:
            # the trees alternate, twice each: a machine that slows down mid-run slows both
            ours, theirs = [], []
            for _ in range(2):
                ours.append(_time(None, case, path, args.repeat))
                theirs.append(_time(args.baseline, case, path, args.repeat))
            ours, theirs = min(ours), min(theirs)
            print(f"| {case} | {ours * 1e3:.1f} ms | {theirs * 1e3:.1f} ms | "
                  f"{theirs / ours:.2f} |", flush=True)  # fmt: skip
    print(f"at the end, {speed_probe()}")


if __name__ == "__main__":
    main()

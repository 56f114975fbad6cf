"""MTOT, TTOT, HTOT and PDEV: adavar against allantools, measured in the same run.

Usage: python benchmarks/bench_total_family.py [--n 20000] [--n-long 1000000]
       [--peer-max-m 32] [--repeat 3]

The record is white-FM phase (``--n`` points), octave taus, no intervals
(``confidence=None``) and no bias correction (allantools has none), so both compute the same
numbers; the largest relative difference is printed. adavar runs every octave tau.
allantools' mtotdev, ttotdev and htotdev are Python loops of about ``(N - 3m) 9m`` steps per
tau (minutes at the long taus): they run on ``m <= --peer-max-m`` only, each tau timed on its
own, and their time for every tau is extrapolated from a fit ``t(m) = (N - 3m + 1)(a + b m)``
to those timings (printed as "fit"); the ratio on the taus both ran is printed too.
allantools' pdev (a loop over terms with a vectorised inner sum) runs at every tau. Then
adavar alone on ``--n-long`` points (every tau; with and without the bias correction, whose
noise identification costs extra).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import allantools
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe, timed

import adavar

PEERS = {
    "mtotdev": allantools.mtotdev,
    "ttotdev": allantools.ttotdev,
    "htotdev": allantools.htotdev,
    "pdev": allantools.pdev,
}


def ours(x: np.ndarray, stat: str, taus, bias: bool = False):
    options = {} if stat == "pdev" else {"bias_correction": bias}
    return adavar.deviation(x, stat=stat, data_type="phase", taus=taus, confidence=None, **options)


def peer_per_tau(stat: str, x: np.ndarray, ms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """allantools' time and deviation at each factor, one call per factor."""
    times, devs = [], []
    for m in ms:
        t = time.perf_counter()
        _, dev, _, _ = PEERS[stat](x, rate=1.0, data_type="phase", taus=[float(m)])
        times.append(time.perf_counter() - t)
        devs.append(dev[0])
    return np.array(times), np.array(devs)


def extrapolate(n: int, ms: np.ndarray, times: np.ndarray, every: np.ndarray) -> float:
    """Total time at ``every`` factor from ``t(m) = (n - 3m + 1)(a + b m)`` fitted to ``times``."""
    terms = n - 3 * ms + 1
    design = np.stack([terms, terms * ms], axis=1).astype(np.float64)
    (a, b), *_ = np.linalg.lstsq(design, times, rcond=None)
    a, b = max(a, 0.0), max(b, 0.0)
    return float(np.sum((n - 3 * every + 1) * (a + b * every)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20_000)
    ap.add_argument("--n-long", type=int, default=1_000_000)
    ap.add_argument("--peer-max-m", type=int, default=32, help="largest m allantools runs")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(describe())
    rng = np.random.default_rng(1)
    small = np.cumsum(rng.standard_normal(3000))
    for stat in PEERS:  # load the compiled kernels (cached on disk)
        ours(small, stat, "octave", True)

    n = args.n
    x = np.cumsum(rng.standard_normal(n))
    print(f"N = {n} phase points, octave taus; allantools mtot/ttot/htot on m <= "
          f"{args.peer_max_m}, pdev on every tau")  # fmt: skip
    for stat in PEERS:
        t_all, _, r = timed(lambda stat=stat: ours(x, stat, "octave"), args.repeat)
        few = r.m if stat == "pdev" else r.m[r.m <= args.peer_max_m]
        t_few, _, r_few = timed(
            lambda stat=stat, few=few: ours(x, stat, few.astype(float)), args.repeat
        )
        peer_times, peer_devs = peer_per_tau(stat, x, few)
        rel = float(np.max(np.abs(r_few.dev / peer_devs - 1)))
        line = (
            f"{stat:8s} {r.m.size:2d} taus m = 1 .. {r.m[-1]:5d}: adavar {t_all:8.4f} s | "
            f"{few.size:2d} taus (m <= {few[-1]}): adavar {t_few:8.4f} s, allantools "
            f"{peer_times.sum():8.2f} s, ratio {peer_times.sum() / t_few:7.0f}x"
        )
        if stat != "pdev":
            total = extrapolate(n, few, peer_times, r.m)
            line += f" | every tau: allantools {total:8.0f} s (fit), ratio {total / t_all:7.0f}x"
        print(line + f" | max rel diff {rel:.1e}")

    n = args.n_long
    x = np.cumsum(rng.standard_normal(n))
    print(f"N = {n} phase points, octave taus, adavar alone (best of 2)")
    for stat in PEERS:
        t, _, r = timed(lambda stat=stat: ours(x, stat, "octave"), 2)
        per = t / (r.m.size * n) * 1e9
        line = f"{stat:8s} {r.m.size:2d} taus m = 1 .. {r.m[-1]:6d}: {t:7.2f} s "
        line += f"({per:5.0f} ns/point/tau)"
        if stat != "pdev":
            tb, _, _ = timed(lambda stat=stat: ours(x, stat, "octave", True), 1)
            line += f", with the bias correction {tb:7.2f} s"
        print(line)


if __name__ == "__main__":
    main()

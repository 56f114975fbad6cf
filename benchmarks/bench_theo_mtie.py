"""Theo1 and MTIE: adavar against allantools, measured in the same run.

Usage: python benchmarks/bench_theo_mtie.py [--n-theo 20000] [--n-mtie 1000000] [--repeat 3]

Theo1 on ``--n-theo`` white-FM phase points at octave taus (m = 2, 4, ..., largest even
power of two), MTIE on ``--n-mtie`` points at octave taus (m = 1 .. 2**k <= N - 1). adavar
runs every tau. allantools' theo1 (a Python double loop) and mtie (a max over a strided
window view) cost about ``sum_m (N - m) m / 2`` and ``sum_m (N - m) (m + 1)`` element
operations, far too many to run at every tau: they run on the first few taus only, and
their time for all taus is that time scaled by the ratio of the operation counts (printed,
marked "scaled"). Where both ran, the deviations are compared.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import allantools
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe, timed

import adavar


def theo_ops(n: int, ms: np.ndarray) -> float:
    return float(np.sum((n - ms) * (ms // 2)))


def mtie_ops(n: int, ms: np.ndarray) -> float:
    return float(np.sum((n - ms) * (ms + 1)))


def report(name: str, ours: float, peer: float, scaled: bool, rel: float) -> None:
    tag = " (scaled)" if scaled else ""
    print(
        f"{name:8s} adavar {ours:9.4f} s   allantools {peer:10.2f} s{tag:9s}  "
        f"ratio {peer / ours:9.0f}x   max rel diff {rel:.1e}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-theo", type=int, default=20_000)
    ap.add_argument("--n-mtie", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--peer-theo-max-m", type=int, default=16, help="largest m allantools runs")
    ap.add_argument("--peer-mtie-max-m", type=int, default=64, help="largest m allantools runs")
    args = ap.parse_args()
    print(describe())
    rng = np.random.default_rng(1)
    small = np.cumsum(rng.standard_normal(3000))
    for stat in ("theo1", "mtie"):  # load the compiled kernels (cached on disk)
        adavar.deviation(small, stat=stat, data_type="phase", confidence=None)

    # Theo1
    n = args.n_theo
    x = np.cumsum(rng.standard_normal(n))
    ours, _, r = timed(
        lambda: adavar.deviation(
            x, stat="theo1", data_type="phase", taus="octave", confidence=None
        ),
        args.repeat,
    )
    few = r.m[r.m <= args.peer_theo_max_m]
    peer, _, (ptau, pdev, _, _) = timed(
        lambda: allantools.theo1(x, rate=1.0, data_type="phase", taus=few.astype(float)), 1
    )
    factor = theo_ops(n, r.m) / theo_ops(n, few)
    _, i, j = np.intersect1d(r.m, np.round(ptau).astype(np.int64), return_indices=True)
    rel = float(np.max(np.abs(r.dev[i] / pdev[j] - 1)))
    print(f"Theo1: N = {n}, {r.m.size} octave taus m = {r.m[0]} .. {r.m[-1]}; allantools ran "
          f"m <= {few[-1]} ({few.size} taus) in {peer:.2f} s")  # fmt: skip
    report("theo1", ours, peer * factor, True, rel)

    # MTIE
    n = args.n_mtie
    x = np.cumsum(rng.standard_normal(n))
    ours, _, r = timed(
        lambda: adavar.deviation(x, stat="mtie", data_type="phase", taus="octave", confidence=None),
        args.repeat,
    )
    few = r.m[r.m <= args.peer_mtie_max_m]
    peer, _, (ptau, pdev, _, _) = timed(
        lambda: allantools.mtie(x, rate=1.0, data_type="phase", taus=few.astype(float)), 1
    )
    factor = mtie_ops(n, r.m) / mtie_ops(n, few)
    _, i, j = np.intersect1d(r.m, np.round(ptau).astype(np.int64), return_indices=True)
    rel = float(np.max(np.abs(r.dev[i] / pdev[j] - 1)))
    print(f"MTIE: N = {n}, {r.m.size} octave taus m = {r.m[0]} .. {r.m[-1]}; allantools ran "
          f"m <= {few[-1]} ({few.size} taus) in {peer:.2f} s")  # fmt: skip
    report("mtie", ours, peer * factor, True, rel)
    same, _, _ = timed(
        lambda: adavar.deviation(
            x, stat="mtie", data_type="phase", taus=few.astype(float), confidence=None
        ),
        args.repeat,
    )
    report("mtie", same, peer, False, rel)  # the same taus, both measured


if __name__ == "__main__":
    main()

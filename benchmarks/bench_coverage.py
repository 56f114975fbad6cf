"""Coverage of adavar's 68.3 % confidence intervals, by simulation.

For each power-law noise (white PM, flicker PM: phase input; white FM, flicker FM,
random-walk FM: rate input) ``--records`` records of ``--n`` samples are drawn with the
generators of :mod:`adavar.simulate`; for oadev, mdev, hdev and totdev the fraction of
records whose interval ``[dev_low, dev_high]`` contains the truth is printed at every octave
tau with at least 8 non-overlapping clusters (``N // m >= 8``), with the noise
identification adavar does by default. The truth is the expectation of the estimator for
that noise and record length: the Monte Carlo mean of the variance over ``--truth``
independent records (for the finite Kasdin-Walter flicker filter no closed form exists; for
the other noises it equals the theory to the Monte Carlo precision, ~1 %). A DAVAR table
(window ``--window`` on white FM, mirrored ends) gives coverage by window position.

Run: ``python benchmarks/bench_coverage.py`` (a few minutes on 2 cores). ``--plain`` passes
no option that adavar gained with issue 11, so the same script measures an older checkout:
``PYTHONPATH=<old checkout>/src python benchmarks/bench_coverage.py --plain``.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _machine

import adavar
from adavar import simulate as sim

STATS = ("oadev", "mdev", "hdev", "totdev")
BAND = (0.62, 0.74)


def noises(n: int) -> dict[str, tuple[Callable[[int], np.ndarray], str]]:
    """Generators per noise: (seed -> record, data_type)."""
    return {
        "white PM": (lambda s: sim.white(n + 1, seed=s), "phase"),
        "flicker PM": (lambda s: sim.flicker(n + 1, seed=s), "phase"),
        "white FM": (lambda s: sim.white(n, seed=s), "rate"),
        "flicker FM": (lambda s: sim.flicker(n, seed=s), "rate"),
        "random-walk FM": (lambda s: sim.random_walk(n, seed=s), "rate"),
    }


def coverage(
    n: int, records: int, truth_records: int, stats: tuple[str, ...] = STATS
) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """{(noise, stat): (m, covered fraction, mean alpha)} for octave taus with N // m >= 8."""
    out = {}
    for name, (gen, dtype) in noises(n).items():
        for stat in stats:

            def run(seed, confidence, stat=stat, gen=gen, dtype=dtype):
                return adavar.deviation(
                    gen(seed), stat=stat, data_type=dtype, confidence=confidence
                )

            # truth from independent seeds (1_000_000 + ...), coverage from 0 ...
            truth = np.mean(
                [run(1_000_000 + s, None).dev ** 2 for s in range(truth_records)], axis=0
            )
            hits, alphas = [], []
            for s in range(records):
                r = run(s, 0.683)
                hits.append((r.dev_low**2 <= truth) & (truth <= r.dev_high**2))
                alphas.append(r.alpha)
            keep = n // r.m >= 8
            out[(name, stat)] = (
                r.m[keep],
                np.mean(hits, axis=0)[keep],
                np.mean(alphas, axis=0)[keep],
            )
    return out


def davar_coverage(n: int, window: int, records: int, edge_edf: str | None):
    """Coverage per window position (white FM, octave taus, mirrored ends)."""
    pos = np.array([0, 5, 10, 20, 30, 50, window // 2, n // 2])
    hits = []
    for s in range(records):
        kw = {} if edge_edf is None else {"edge_edf": edge_edf}
        d = adavar.davar(sim.white(n, seed=s), window=window, taus="octave", **kw)
        hits.append((d.avar_low <= 1.0 / d.m) & (1.0 / d.m <= d.avar_high))
    # white FM: E[AVAR] = 1/m exactly for every window, mirrored or not
    h = np.mean(hits, axis=0)
    return pos, d.m, h[pos]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=4096)
    ap.add_argument("--records", type=int, default=400)
    ap.add_argument("--truth", type=int, default=2000)
    ap.add_argument("--window", type=int, default=200)
    ap.add_argument("--plain", action="store_true", help="no issue-11 options (older adavar)")
    args = ap.parse_args(argv)
    # thousands of small records: one thread (parallel launches cost more than the work)
    numba.set_num_threads(1)
    t0 = time.perf_counter()
    print(f"# machine: {_machine.describe()}")
    print(
        f"# N = {args.n}, {args.records} records per cell, truth = mean of {args.truth} "
        f"records; band {BAND[0]:.0%}-{BAND[1]:.0%}"
    )
    table = coverage(args.n, args.records, args.truth)
    bad = 0
    print(
        "| noise | stat | " + " | ".join(f"m={m}" for m in table[("white FM", "oadev")][0]) + " |"
    )
    for (name, stat), (_ms, cov, alpha) in table.items():
        cells = []
        for c, a in zip(cov, alpha, strict=True):
            flag = "" if BAND[0] <= c <= BAND[1] else " !"
            bad += bool(flag)
            cells.append(f"{100 * c:.0f}{flag} (a {a:+.1f})")
        print(f"| {name} | {stat} | " + " | ".join(cells) + " |")
    edge = None if args.plain else "distinct"
    pos, ms, cov = davar_coverage(args.n, args.window, args.records, edge)
    print(f"\n# DAVAR, white FM, window {args.window}, edges=mirror, edge_edf={edge!r}")
    print("| centre | " + " | ".join(f"m={m}" for m in ms) + " |")
    for p, row in zip(pos, cov, strict=True):
        cells = []
        for c in row:
            if np.isnan(c):
                cells.append("-")
                continue
            flag = "" if BAND[0] <= c <= BAND[1] else " !"
            bad += bool(flag)
            cells.append(f"{100 * c:.0f}{flag}")
        print(f"| {p} | " + " | ".join(cells) + " |")
    print(f"\n# {bad} cells outside the band; {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

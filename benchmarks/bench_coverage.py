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

``--input-types`` (issue 39) measures instead whether the input type matters: the five
noises from the independent generator ``tests/independent_noise.py`` (FFT flicker, running
sums; no adavar code), each passed as phase (``x``) and as rate data (``diff(x)``), against
the exact expectation of each estimator on those records
(``independent_noise.expected_variance``), at every octave m up to N/8, with the default
noise identification and, in the same run, the previous rule (``noise_id="input"``: rate
data identified on the m-averaged rate).

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
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import _machine
import independent_noise as ind

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


def coverage_by_input(n: int, records: int, stats: tuple[str, ...] = STATS):
    """{(noise, stat, input, rule): (m, covered fraction, mean alpha)}, exact truths, octave
    m with N // m >= 8 (``n`` phase points; the rate record has ``n - 1`` samples)."""
    out = {}
    ms = 2 ** np.arange(int(np.log2((n - 1) // 8)) + 1)
    for alpha, name in ind.POWER_LAWS.items():
        records_x = [ind.power_law(alpha, n, s) for s in range(records)]
        for stat in stats:
            truth = np.array([ind.expected_variance(stat, alpha, n, int(m)) for m in ms])
            for dtype, rule in (("phase", "sp1065"), ("rate", "sp1065"), ("rate", "input")):
                hits, alphas = [], []
                for x in records_x:
                    data = x if dtype == "phase" else np.diff(x)
                    r = adavar.deviation(data, stat=stat, data_type=dtype, taus=ms, noise_id=rule)
                    hits.append((r.dev_low**2 <= truth) & (truth <= r.dev_high**2))
                    alphas.append(r.alpha)
                out[(name, stat, dtype, rule)] = (
                    ms,
                    np.mean(hits, axis=0),
                    np.mean(alphas, axis=0),
                )
    return out


def print_by_input(table) -> int:
    """Print :func:`coverage_by_input`'s table; returns the cells outside the band (the
    previous rule's rows not counted)."""
    bad = 0
    first = next(iter(table.values()))[0]
    print("| noise | stat | input (rule) | " + " | ".join(f"m={m}" for m in first) + " |")
    print("|---|---|---|" + "---|" * len(first))
    for (name, stat, dtype, rule), (_ms, cov, alpha) in table.items():
        cells = []
        for c, a in zip(cov, alpha, strict=True):
            flag = "" if BAND[0] <= c <= BAND[1] else " !"
            bad += bool(flag) and rule != "input"
            cells.append(f"{100 * c:.0f}{flag} (a {a:+.1f})")
        label = dtype if rule == "sp1065" else f"{dtype} (before: noise_id='input')"
        print(f"| {name} | {stat} | {label} | " + " | ".join(cells) + " |")
    return bad


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
    ap.add_argument(
        "--input-types",
        action="store_true",
        help="phase vs rate input of the independent generator's noises (issue 39)",
    )
    args = ap.parse_args(argv)
    # thousands of small records: one thread (parallel launches cost more than the work)
    numba.set_num_threads(1)
    t0 = time.perf_counter()
    print(f"# machine: {_machine.describe()}")
    if args.input_types:
        n = args.n + 1  # phase points: the rate record has args.n samples
        print(f"# N = {n} phase points, {args.records} records per cell, exact truths; band "
              f"{BAND[0]:.0%}-{BAND[1]:.0%}")  # fmt: skip
        bad = print_by_input(coverage_by_input(n, args.records))
        print(f"\n# {bad} cells outside the band (default rule); "
              f"{time.perf_counter() - t0:.0f} s")  # fmt: skip
        return 0
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

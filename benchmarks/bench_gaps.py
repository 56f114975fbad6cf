"""Records with missing samples, ``deviation(..., gaps="omit")``: interval coverage and speed.

Coverage. For each power-law noise (white FM, flicker FM, random-walk FM: rate input;
white PM, flicker PM: phase input) ``--records`` records of ``--n`` samples are drawn with
the generators of :mod:`adavar.simulate`, and about ``--fraction`` of their samples are set
to NaN in gaps of random position and random length (1 .. ``--longest`` samples, uniform).
For oadev, adev, mdev, hdev and ohdev the fraction of records whose 68.3 % interval
``[dev_low, dev_high]`` (EDF from the kept count, noise type identified on the kept data)
contains the truth is printed at every octave tau that keeps a term in every record, with
the mean identified alpha and the mean fraction of terms kept. The truth is the Monte Carlo
mean of the gap-free variance over ``--truth`` independent records (the expectation of the
estimator: every term has the same expectation, kept or not).

Speed. A 1e6-sample white-noise record, complete and with 10 % missing (gaps of 1..200),
for every statistic with and without intervals: best of 5 calls, milliseconds.

Run: ``python benchmarks/bench_gaps.py`` (about 10 minutes on 2 cores at the defaults;
``--records 200 --n 4096`` for a quick look).
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

STATS = ("oadev", "adev", "mdev", "hdev", "ohdev")
BAND = (0.62, 0.74)


def punch(x: np.ndarray, seed: int, fraction: float, longest: int) -> np.ndarray:
    """``x`` with about ``fraction`` of its samples NaN, in gaps of 1..longest samples."""
    rng = np.random.default_rng(10_000_000 + seed)
    x = np.array(x, dtype=np.float64)
    missing = np.zeros(x.size, dtype=bool)
    while missing.mean() < fraction:
        start = int(rng.integers(0, x.size))
        missing[start : start + int(rng.integers(1, longest + 1))] = True
    x[missing] = np.nan
    return x


def noises(n: int) -> dict[str, tuple[Callable[[int], np.ndarray], str]]:
    """Generators per noise: (seed -> record, data_type)."""
    return {
        "white FM": (lambda s: sim.white(n, seed=s), "rate"),
        "flicker FM": (lambda s: sim.flicker(n, seed=s), "rate"),
        "random-walk FM": (lambda s: sim.random_walk(n, seed=s), "rate"),
        "white PM": (lambda s: sim.white(n + 1, seed=s), "phase"),
        "flicker PM": (lambda s: sim.flicker(n + 1, seed=s), "phase"),
    }


def coverage(args: argparse.Namespace) -> dict[tuple[str, str], tuple[np.ndarray, ...]]:
    """{(noise, stat): (m, covered fraction, mean alpha, kept fraction)}."""
    taus = [2**k for k in range(int(np.log2(args.n // 8)) + 1)]
    out = {}
    for name, (gen, dtype) in noises(args.n).items():
        for stat in STATS:
            full = [adavar.deviation(gen(1_000_000 + s), stat=stat, data_type=dtype,
                                     taus=taus, confidence=None)
                    for s in range(args.truth)]  # fmt: skip
            ms = full[0].m
            truth = np.mean([r.dev**2 for r in full], axis=0)
            n_full = full[0].n.astype(float)
            hits = np.full((args.records, ms.size), np.nan)
            alphas = hits.copy()
            kept = hits.copy()
            for s in range(args.records):
                x = punch(gen(s), s, args.fraction, args.longest)
                r = adavar.deviation(x, stat=stat, data_type=dtype, taus=taus, gaps="omit")
                at = np.searchsorted(ms, r.m)
                t = truth[at]
                hits[s, at] = (r.dev_low**2 <= t) & (t <= r.dev_high**2)
                alphas[s, at] = r.alpha
                kept[s, at] = r.n / n_full[at]
            every = ~np.isnan(hits).any(axis=0)  # taus with a term in every record
            out[(name, stat)] = (
                ms[every],
                hits[:, every].mean(axis=0),
                alphas[:, every].mean(axis=0),
                kept[:, every].mean(axis=0),
            )
    return out


def speed(repeat: int = 5) -> list[str]:
    """Milliseconds per call at 1e6 samples, complete and with 10 % missing."""
    n = 1_000_000
    rng = np.random.default_rng(1)
    x = rng.standard_normal(n)
    gapped = punch(x, 0, 0.10, 200)
    lines = ["| stat | confidence | gap-free | gaps='omit', no NaN | gaps='omit', 10 % NaN |",
             "|---|---|---|---|---|"]  # fmt: skip
    for stat in STATS:
        for conf in (None, 0.683):
            cells = []
            for data, gaps in ((x, "error"), (x, "omit"), (gapped, "omit")):
                adavar.deviation(data, stat=stat, confidence=conf, gaps=gaps)  # compile
                call = dict(stat=stat, confidence=conf, gaps=gaps)
                best, _, _ = _machine.timed(
                    lambda d=data, kw=call: adavar.deviation(d, **kw), repeat
                )
                cells.append(f"{1e3 * best:.1f}")
            lines.append(f"| {stat} | {conf} | " + " | ".join(cells) + " |")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=16384)
    ap.add_argument("--records", type=int, default=1000)
    ap.add_argument("--truth", type=int, default=1000)
    ap.add_argument("--fraction", type=float, default=0.10)
    ap.add_argument("--longest", type=int, default=64, help="longest gap, samples")
    ap.add_argument("--no-speed", action="store_true", help="skip the 1e6-sample timings")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    print(f"# machine: {_machine.describe()}")
    if not args.no_speed:
        print("\n# speed at 1e6 samples, ms (best of 5)")
        print("\n".join(speed()))
    # thousands of small records: one thread (parallel launches cost more than the work)
    numba.set_num_threads(1)
    print(
        f"\n# coverage: N = {args.n}, {args.fraction:.0%} missing in gaps of 1..{args.longest}, "
        f"{args.records} records per cell, truth = mean of {args.truth} gap-free records; "
        f"band {BAND[0]:.0%}-{BAND[1]:.0%}; cells: coverage % (mean alpha, terms kept %)"
    )
    bad = 0
    for (name, stat), (ms, cov, alpha, kept) in coverage(args).items():
        cells = []
        for m, c, a, k in zip(ms, cov, alpha, kept, strict=True):
            flag = "" if BAND[0] <= c <= BAND[1] else " !"
            bad += bool(flag)
            cells.append(f"m={m}: {100 * c:.0f}{flag} ({a:+.1f}, {100 * k:.0f})")
        print(f"| {name} | {stat} | " + " | ".join(cells) + " |")
    print(f"\n# {bad} cells outside the band; {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

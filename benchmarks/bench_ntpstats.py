"""adavar against ntpstats (PyPI 3.8, its allantools-compatible API) in the same run.

For each statistic of issue 16 (and oadev for scale): the same phase record (white FM,
2e4 points, tau0 = 1 s), octave taus, no intervals on either side (ntpstats' compat layer
computes none), best of 3 after a warm-up call (Numba compiled, ntpstats' caches filled).
The values are compared where both give the same taus (the total family without bias
correction, as allantools and ntpstats' compat layer compute it).

Run: ``python benchmarks/bench_ntpstats.py [--n 20000]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _machine import describe

import adavar

STATS = ("oadev", "mtotdev", "ttotdev", "htotdev", "theo1", "mtie", "tierms")


def _best(call, repeats: int = 3) -> float:
    call()
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20_000)
    args = parser.parse_args()
    from ntpstats.compat import allantools as nts

    x = np.concatenate([[0.0], np.cumsum(np.random.default_rng(0).standard_normal(args.n))])
    print(f"machine: {describe()}; {args.n} phase points, octave taus, no intervals")
    print("| statistic | adavar | ntpstats | ntpstats / adavar | largest relative difference |")
    print("|---|---|---|---|---|")
    for stat in STATS:
        opts = {"bias_correction": False} if stat in ("mtotdev", "ttotdev", "htotdev") else {}

        def ours(stat=stat, opts=opts):
            return adavar.deviation(x, stat=stat, data_type="phase", taus="octave",
                                    confidence=None, **opts)  # fmt: skip

        def theirs(stat=stat):
            return getattr(nts, stat)(x, rate=1.0, data_type="phase", taus="octave")

        t_ours, t_theirs = _best(ours), _best(theirs)
        r, (tau, dev, _, _) = ours(), theirs()
        common = np.intersect1d(np.round(r.tau, 9), np.round(tau, 9))
        a = r.dev[np.isin(np.round(r.tau, 9), common)]
        b = np.asarray(dev)[np.isin(np.round(tau, 9), common)]
        diff = float(np.max(np.abs(a / b - 1))) if common.size else float("nan")
        row = (f"| {stat} | {1e3 * t_ours:.2f} ms | {1e3 * t_theirs:.2f} ms | "
               f"{t_theirs / t_ours:.1f} | {diff:.1e} ({common.size} taus) |")  # fmt: skip
        print(row, flush=True)


if __name__ == "__main__":
    main()

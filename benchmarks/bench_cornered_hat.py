"""Coverage of the cornered-hat and Groslambert-covariance intervals, by simulation.

For each case ``--records`` sets of independent instruments (``--n`` samples) are drawn,
their pairwise differences formed (:func:`adavar.cornered_hat` with
``kind="instruments"``) and the fraction of (record, tau) cells whose interval
``[dev_low, dev_high]`` holds the true deviation printed per instrument, at 68.3 % and
95 %, over the octave taus with at least 16 clusters (``m <= n / 16``); also the fraction
of negative variance estimates. The truth is the theory of each noise (white FM
``sigma^2 tau0 / tau``, random walk FM ``K^2 tau / 3`` for bin averages, white PM
``3 sigma_x^2 / tau^2``). The Groslambert covariance of ``A - B`` and ``A - C`` is checked
the same way against ``sigma_A^2``.

Run: ``python benchmarks/bench_cornered_hat.py`` (a few minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _machine

import adavar
from adavar import simulate

#: case -> (data type, [(noise, level), ...])
CASES = {
    "white FM 1, 2, 3": ("rate", [("wfm", 1.0), ("wfm", 2.0), ("wfm", 3.0)]),
    "white FM 0.3, 1, 1 (quiet A)": ("rate", [("wfm", 0.3), ("wfm", 1.0), ("wfm", 1.0)]),
    "white FM, RW FM, white FM": ("rate", [("wfm", 1.0), ("rw", 0.05), ("wfm", 2.0)]),
    "white PM 1, 5, 10 (phase)": ("phase", [("wpm", 1.0), ("wpm", 5.0), ("wpm", 10.0)]),
    "4 white FM (least squares)": ("rate", [("wfm", v) for v in (0.5, 1.0, 1.5, 2.0)]),
    "5 mixed (least squares)": (
        "rate",
        [("wfm", 1.0), ("wfm", 0.5), ("rw", 0.03), ("wfm", 2.0), ("rw", 0.01)],
    ),
}


def draw(noise: str, level: float, n: int, rng: np.random.Generator) -> np.ndarray:
    if noise == "wfm":
        return level * rng.standard_normal(n)
    if noise == "wpm":
        return level * rng.standard_normal(n)  # phase samples
    return simulate.rate_random_walk(n, level, seed=rng, sampling="average")


def truth(noise: str, level: float, tau: np.ndarray) -> np.ndarray:
    if noise == "wfm":
        return level**2 / tau
    if noise == "wpm":
        return 3.0 * level**2 / tau**2
    return level**2 * tau / 3.0


def run_case(dtype, specs, n, records, confidence, seed):
    hits, negs = [], []
    for s in range(records):
        rng = np.random.default_rng(seed + s)
        xs = [draw(noise, level, n, rng) for noise, level in specs]
        got = adavar.cornered_hat(xs, kind="instruments", data_type=dtype,
                                  confidence=confidence)  # fmt: skip
        keep = got.m <= n // 16
        dev = np.sqrt([truth(noise, level, got.tau[keep]) for noise, level in specs])
        hits.append((got.dev_low[:, keep] <= dev) & (dev <= got.dev_high[:, keep]))
        negs.append(got.negative[:, keep])
    return np.array(hits), np.array(negs)


def gcodev_coverage(n, records, confidence, seed):
    hits = []
    for s in range(records):
        rng = np.random.default_rng(seed + s)
        u = rng.standard_normal((3, n)) * np.array([[0.5], [1.0], [2.0]])
        got = adavar.gcodev(u[0] - u[1], u[0] - u[2], data_type="rate", confidence=confidence)
        keep = got.m <= n // 16
        c = 0.25 / got.tau[keep]
        hits.append((got.covar_low[keep] <= c) & (c <= got.covar_high[keep]))
    return float(np.mean(hits))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1 << 13, help="samples per record")
    parser.add_argument("--records", type=int, default=300, help="records per case")
    parser.add_argument("--seed", type=int, default=50_000)
    args = parser.parse_args()
    print(_machine.describe())
    print(f"{args.records} records of {args.n} samples per case; octave taus with m <= n/16\n")
    for confidence in (0.683, 0.95):
        print(f"confidence {confidence}")
        for name, (dtype, specs) in CASES.items():
            t0 = time.perf_counter()
            hits, negs = run_case(dtype, specs, args.n, args.records, confidence, args.seed)
            cover = " ".join(f"{v:.3f}" for v in hits.mean(axis=(0, 2)))
            neg = " ".join(f"{v:.3f}" for v in negs.mean(axis=(0, 2)))
            ms = (time.perf_counter() - t0) / args.records * 1e3
            print(f"  {name:<30s} coverage {cover:<32s} negative {neg}  ({ms:.0f} ms/record)")
            quiet = hits[:, 0, :].mean(axis=0)
            print(f"  {'':<30s} first instrument per tau: " + " ".join(f"{v:.2f}" for v in quiet))
        cov = gcodev_coverage(args.n, args.records, confidence, args.seed)
        print(f"  {'gcodev(A-B, A-C), A quiet':<30s} coverage {cov:.3f}\n")


if __name__ == "__main__":
    main()

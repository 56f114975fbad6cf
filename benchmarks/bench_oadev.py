"""OADEV of a long record: adavar against allantools, measured in the same run.

Usage: python benchmarks/bench_oadev.py [--n 10000000] [--repeat 5]

Both libraries get the same white-noise rate record and octave taus. Each call is timed
``--repeat`` times and the best time is reported (the first call of each is also shown:
it pays for fresh memory pages, which on some virtual machines costs more than the sums).
adavar is timed twice: the deviation alone (``confidence=None``, the same work as
``allantools.oadev``) and with its per-tau noise identification and Greenhall-Riley
confidence intervals, which allantools does not compute.
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    print(describe())
    y = np.random.default_rng(1).standard_normal(args.n)
    adavar.deviation(y[:5000])  # load the compiled kernels (cached on disk)

    peer, peer_first, (ptau, pdev, _, _) = timed(
        lambda: allantools.oadev(y, rate=1.0, data_type="freq", taus="octave"), args.repeat
    )
    bare, bare_first, r = timed(lambda: adavar.deviation(y, confidence=None), args.repeat)
    full, full_first, _ = timed(lambda: adavar.deviation(y), args.repeat)
    common, i, j = np.intersect1d(r.tau, ptau, return_indices=True)
    rel = float(np.max(np.abs(r.dev[i] / pdev[j] - 1)))

    print(
        f"N = {args.n:.0e} white-noise rate samples, {r.tau.size} octave taus, "
        f"best of {args.repeat} (first call in brackets)"
    )
    print(f"{'':44s}{'seconds':>10s}{'first':>10s}{'speed-up':>10s}")
    print(f"{'allantools.oadev':44s}{peer:10.3f}{peer_first:10.3f}{1.0:10.1f}")
    print(
        f"{'adavar.deviation(confidence=None)':44s}{bare:10.3f}{bare_first:10.3f}"
        f"{peer / bare:10.1f}"
    )
    print(
        f"{'adavar.deviation (with EDF intervals)':44s}{full:10.3f}{full_first:10.3f}"
        f"{peer / full:10.1f}"
    )
    print(f"max relative difference of the {common.size} common taus: {rel:.1e}")


if __name__ == "__main__":
    main()

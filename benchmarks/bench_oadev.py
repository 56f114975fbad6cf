"""OADEV at octave taus: adavar against allantools, measured alternately in the same run.

Usage: python benchmarks/bench_oadev.py [--sizes 1e3,1e4,1e5,1e6,1e7] [--repeat 7]

Both libraries get the same white-noise rate record and octave taus. The calls are timed
in rounds, one call of each per round in turn (a machine whose load changes meanwhile
slows them alike), ``--repeat`` rounds, and the best time of each is reported; a call
shorter than a few milliseconds is repeated within its measurement. Three adavar rows:

- ``confidence=None, stationarity_check=False``: the same work as ``allantools.oadev``;
- the default call (``adavar.deviation(y)``): the deviation with its per-tau noise
  identification and Greenhall-Riley confidence intervals (``confidence=0.683``) and
  the whole-record stationarity check, which allantools does not compute.

The speed-up is allantools' best time over adavar's. The load average of the machine
(``os.getloadavg``) is printed before and after: on a machine that is doing something
else too, adavar's threaded kernels have fewer free cores than the one allantools uses.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import allantools
import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe

import adavar

CALLS = {
    "allantools.oadev": lambda y: allantools.oadev(y, rate=1.0, data_type="freq", taus="octave"),
    "adavar (same work: no EDF, no check)": lambda y: adavar.deviation(
        y, confidence=None, stationarity_check=False
    ),
    "adavar.deviation(y) (default)": lambda y: adavar.deviation(y),
}


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.2f} (1 min), {five:.2f} (5 min)"


def measure(y: np.ndarray, repeat: int) -> dict[str, float]:
    """Best seconds per call of each of :data:`CALLS`, timed alternately."""
    inner = max(1, 200_000 // y.size)  # short calls: several per measurement
    best = dict.fromkeys(CALLS, np.inf)
    for _ in range(repeat):
        for name, call in CALLS.items():
            start = time.perf_counter()
            for _ in range(inner):
                call(y)
            best[name] = min(best[name], (time.perf_counter() - start) / inner)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1e3,1e4,1e5,1e6,1e7")
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    sizes = [int(float(s)) for s in args.sizes.split(",")]
    print(describe())
    print(f"kernel threads: {numba.get_num_threads()}; before: {_load()}")
    rng = np.random.default_rng(1)
    adavar.deviation(rng.standard_normal(5000))  # load the compiled kernels (cached on disk)
    names = list(CALLS)
    head = "".join(f"{'ms ' + str(k + 1):>11s}" for k in range(len(names)))
    ratios = "".join(f"{'x ' + str(k + 1):>8s}" for k in range(1, len(names)))
    print("columns: " + "; ".join(f"{k + 1} = {n}" for k, n in enumerate(names)))
    print(f"best of {args.repeat} alternating rounds, milliseconds; x k = ms 1 / ms k")
    print(f"{'N':>10s}{'taus':>6s}{head}{ratios}{'max rel diff':>14s}")
    for n in sizes:
        y = rng.standard_normal(n)
        for call in CALLS.values():
            call(y)  # first calls: fresh memory pages, caches
        best = measure(y, args.repeat)
        tau, dev = CALLS[names[0]](y)[:2]
        r = adavar.deviation(y, confidence=None, stationarity_check=False)
        _, i, j = np.intersect1d(r.tau, tau, return_indices=True)
        rel = float(np.max(np.abs(r.dev[i] / dev[j] - 1)))
        secs = "".join(f"{1e3 * best[name]:11.3f}" for name in names)
        speed = "".join(f"{best[names[0]] / best[name]:8.1f}" for name in names[1:])
        print(f"{n:10.0e}{r.tau.size:6d}{secs}{speed}{rel:14.1e}")
    print(f"after: {_load()}")


if __name__ == "__main__":
    main()

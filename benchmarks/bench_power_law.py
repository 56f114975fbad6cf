"""Recovery of known power-law coefficients h_-2 .. h_2 and the calibration of their errors.

For each case ``--records`` clocks of ``--n`` samples are simulated with the generators of
``tests/test_power_law.py`` (white PM: white phase; flicker PM: a phase spectrum exactly
``h_1 / (4 pi^2 f)`` up to Nyquist; white FM; random walk FM as bin averages; flicker FM:
the Kasdin-Walter filter, fitted from tau = 16 tau0 on), the statistic computed with
:func:`adavar.deviation` (68.3 % EDF), and :func:`adavar.fit_power_law` fitted with every
true term and ``select="none"``. Printed per coefficient: the mean relative error with its
Monte Carlo standard error, the scatter, and the mean and standard deviation of the pulls
``(h_hat - h) / sigma_h`` (calibrated uncertainties: 0 and 1).

Run: ``python benchmarks/bench_power_law.py`` (about two minutes on 2 cores with the
defaults).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the tests' generators
sys.path.insert(0, str(Path(__file__).resolve().parent))
import _machine

import adavar
from tests.test_power_law import clock

NAMES = ("random_walk_fm", "flicker_fm", "white_fm", "flicker_pm", "white_pm")

#: name -> (statistic, h_-2 .. h_2, tau range)
CASES = {
    "oadev WPM+WFM+RWFM": ("oadev", (1e-5, 0, 1.0, 0, 3.0), None),
    "adev WPM+WFM+RWFM": ("adev", (1e-5, 0, 1.0, 0, 3.0), None),
    "totdev WFM+RWFM": ("totdev", (1e-5, 0, 1.0, 0, 0), None),
    "oadev WFM+FFM": ("oadev", (0, 1e-2, 1.0, 0, 0), (16, None)),
    "mdev WPM+FPM+WFM+RWFM": ("mdev", (1e-5, 0, 1.0, 1.0, 3.0), None),
    "tdev WPM+FPM+WFM": ("tdev", (0, 0, 1.0, 1.0, 3.0), None),
    "hdev WPM+WFM+RWFM": ("hdev", (1e-5, 0, 1.0, 0, 3.0), None),
    "hdev WFM+FFM+RWFM": ("hdev", (1e-5, 1e-2, 1.0, 0, 0), (16, None)),
    "ohdev WPM+WFM+RWFM": ("ohdev", (1e-5, 0, 1.0, 0, 3.0), None),
}


def run_case(stat, h, tau_range, n, records, seed):
    truth = np.array(h)
    terms = tuple(name for name, v in zip(NAMES, h, strict=True) if v > 0)
    k = [NAMES.index(t) for t in terms]
    rel, pulls = [], []
    for s in range(records):
        r = adavar.deviation(clock(n, h, seed=seed + s), stat=stat)
        fit = adavar.fit_power_law(r, terms=terms, select="none", tau_range=tau_range)
        rel.append(fit.h[k] / truth[k] - 1.0)
        pulls.append((fit.h[k] - truth[k]) / fit.h_sigma[k])
    return terms, np.array(rel), np.array(pulls)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1 << 15, help="samples per record")
    parser.add_argument("--records", type=int, default=200, help="records per case")
    parser.add_argument("--seed", type=int, default=10_000)
    args = parser.parse_args()
    print(_machine.describe())
    print(f"{args.records} records of {args.n} samples per case\n")
    print(f"{'case':<24s} {'term':<15s} {'bias %':>16s} {'scatter %':>10s} "
          f"{'pull mean':>10s} {'pull sd':>8s}")  # fmt: skip
    for name, (stat, h, tau_range) in CASES.items():
        t0 = time.perf_counter()
        terms, rel, pulls = run_case(stat, h, tau_range, args.n, args.records, args.seed)
        err = rel.std(axis=0) / np.sqrt(len(rel))
        for j, term in enumerate(terms):
            bias = f"{100 * rel[:, j].mean():+.2f} ± {100 * err[j]:.2f}"
            print(f"{name if j == 0 else '':<24s} {term:<15s} {bias:>16s} "
                  f"{100 * rel[:, j].std():>10.2f} {pulls[:, j].mean():>+10.2f} "
                  f"{pulls[:, j].std():>8.2f}")  # fmt: skip
        print(f"{'':<24s} ({(time.perf_counter() - t0) / args.records * 1e3:.0f} ms per record)")


if __name__ == "__main__":
    main()

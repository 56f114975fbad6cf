"""Theo1, ThêoBR and MTIE: adavar against allantools, measured in the same run.

Usage: python benchmarks/bench_theo_mtie.py [--n-theo 20000] [--n-theobr 5000 20000]
       [--n-mtie 1000000] [--repeat 3]

Theo1 on ``--n-theo`` white-FM phase points at taus="all" (every even m up to N - 1) and
"octave" (m = 2, 4, ..., the largest power of two); ThêoBR's exact bias ratio (SP 1065 Eq.
33: AVAR(9 + 3i) / Theo1(12 + 4i) for all ``i <= N/6 - 3``) on each of ``--n-theobr``
points; MTIE on ``--n-mtie`` points at octave taus. adavar runs every tau, and is shown
twice for Theo1: as it runs (the all-tau kernel, or the exact one where that costs less)
and with the exact ``O(N m)`` kernel only (``method="exact"``, the algorithm before the
all-tau kernel).

allantools' theo1 (a Python double loop) and mtie (a max over a strided window view) cost
about ``sum_m (N - m) m / 2`` and ``sum_m (N - m) (m + 1)`` element operations, far too many
to run at every tau: they run on the first few taus only, and their time for all taus is
that time scaled by the ratio of the operation counts (printed, marked "scaled"). The exact
kernel is scaled the same way, from every k-th tau, where it would take more than
``--exact-budget`` seconds.
allantools has no ThêoBR: its cost there is that of its theo1 at the ``12 + 4i`` factors
(scaled from the same measured rate) plus its oadev at the ``9 + 3i`` factors (measured).
Where both ran, the deviations are compared.
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
from adavar.stats import theo_family as tf


def theo_ops(n: int, ms: np.ndarray) -> float:
    return float(np.sum((n - ms) * (ms // 2)))


def mtie_ops(n: int, ms: np.ndarray) -> float:
    return float(np.sum((n - ms) * (ms + 1)))


def report(name: str, ours: float, peer: float, scaled: bool, rel: float) -> None:
    tag = " (scaled)" if scaled else ""
    print(
        f"{name:14s} adavar {ours:9.4f} s   allantools {peer:12.2f} s{tag:9s}  "
        f"ratio {peer / ours:10.0f}x   max rel diff {rel:.1e}"
    )


def peer_theo1(x: np.ndarray, ms: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """allantools' theo1 at ``ms`` (seconds, its m, its deviations)."""
    t, _, (ptau, pdev, _, _) = timed(
        lambda: allantools.theo1(x, rate=1.0, data_type="phase", taus=ms.astype(float)), 1
    )
    return t, np.round(ptau).astype(np.int64), pdev


def exact_kernel(x: np.ndarray, ms: np.ndarray, budget: float, repeat: int) -> tuple[float, bool]:
    """Seconds of the exact kernel at ``ms``: measured, or scaled from every k-th tau.

    The estimate (its cost model) picks ``k``; the taus measured span the whole range, so
    the scaling by operation counts does not lean on the cheap short taus.
    """
    u = np.diff(x)
    n = x.size
    estimate = tf._exact_cost(n, ms) * 1e-9
    if estimate <= budget:
        t, _, _ = timed(lambda: tf.theo1_double_sums(u, ms, "exact"), repeat)
        return t, False
    few = ms[:: int(np.ceil(estimate / budget))]
    t, _, _ = timed(lambda: tf.theo1_double_sums(u, few, "exact"), 1)
    return t * theo_ops(n, ms) / theo_ops(n, few), True


def bench_theo1(x: np.ndarray, args: argparse.Namespace) -> None:
    n = x.size
    for taus in ("all", "octave"):
        ours, _, r = timed(
            lambda taus=taus: adavar.deviation(
                x, stat="theo1", data_type="phase", taus=taus, confidence=None
            ),
            args.repeat,
        )
        before, before_scaled = exact_kernel(x, r.m, args.exact_budget, args.repeat)
        few = r.m[r.m <= args.peer_theo_max_m]
        peer, pm, pdev = peer_theo1(x, few)
        _, i, j = np.intersect1d(r.m, pm, return_indices=True)
        rel = float(np.max(np.abs(r.dev[i] / pdev[j] - 1)))
        tag = " (scaled)" if before_scaled else ""
        print(f"Theo1 taus={taus}: N = {n}, {r.m.size} taus m = {r.m[0]} .. {r.m[-1]}; "
              f"exact kernel {before:.2f} s{tag} ({before / ours:.0f}x slower); allantools "
              f"ran m <= {few[-1]} ({few.size} taus) in {peer:.2f} s")  # fmt: skip
        report(f"theo1 {taus}", ours, peer * theo_ops(n, r.m) / theo_ops(n, few), True, rel)


def bench_theobr(x: np.ndarray, args: argparse.Namespace) -> None:
    for n in args.n_theobr:
        u = np.diff(x[:n])
        ours, _, kf = timed(lambda u=u: tf.theobr_ratio(u), args.repeat)
        m_avar, m_theo = tf.ratio_factors(n)
        before, before_scaled = exact_kernel(x[:n], m_theo, args.exact_budget, 1)
        few = m_theo[m_theo <= args.peer_theobr_max_m]
        peer, pm, pdev = peer_theo1(x[:n], few)
        peer_avar, _, (_, padev, _, _) = timed(
            lambda n=n, m=m_avar: allantools.oadev(
                x[:n], rate=1.0, data_type="phase", taus=m.astype(float)
            ),
            1,
        )
        mine = np.sqrt(tf._theo1_var(u, few))
        rel = float(np.max(np.abs(mine / pdev[np.searchsorted(pm, few)] - 1)))
        # the ratios both can form: allantools' oadev over its theo1 at the first pairs
        theirs = padev[: few.size] ** 2 / pdev[np.searchsorted(pm, few)] ** 2
        ours_r = tf._oavar(adavar._kernels.differences.anchored_phase(u), m_avar[: few.size])
        rel = max(rel, float(np.max(np.abs(ours_r / mine**2 / theirs - 1))))
        peer_total = peer * theo_ops(n, m_theo) / theo_ops(n, few) + peer_avar
        tag = " (scaled)" if before_scaled else ""
        print(f"ThêoBR exact bias ratio: N = {n}, {m_theo.size} pairs (Theo1 m = {m_theo[0]} .. "
              f"{m_theo[-1]}), kf = {kf:.5f}; exact kernel {before:.2f} s{tag} "
              f"({before / ours:.0f}x slower); allantools theo1 ran m <= {few[-1]} in "
              f"{peer:.2f} s, oadev (all pairs) {peer_avar:.2f} s")  # fmt: skip
        report("theobr ratio", ours, peer_total, True, rel)


def bench_mtie(rng: np.random.Generator, args: argparse.Namespace) -> None:
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-theo", type=int, default=20_000)
    ap.add_argument("--n-theobr", type=int, nargs="+", default=[5_000, 20_000])
    ap.add_argument("--n-mtie", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--peer-theo-max-m", type=int, default=16, help="largest m allantools runs")
    ap.add_argument("--peer-theobr-max-m", type=int, default=28, help="same, for ThêoBR")
    ap.add_argument("--peer-mtie-max-m", type=int, default=64, help="largest m allantools runs")
    ap.add_argument(
        "--exact-budget", type=float, default=2.0, help="seconds the exact kernel may run"
    )
    args = ap.parse_args()
    print(describe())
    rng = np.random.default_rng(1)
    small = np.cumsum(rng.standard_normal(3000))
    for stat in ("theo1", "theobr", "mtie"):  # load the compiled kernels (cached on disk)
        for taus in ("all", "octave"):
            adavar.deviation(small, stat=stat, data_type="phase", taus=taus, confidence=None)

    x = np.cumsum(rng.standard_normal(max(args.n_theo, *args.n_theobr)))
    bench_theo1(x[: args.n_theo], args)
    bench_theobr(x, args)
    bench_mtie(rng, args)


if __name__ == "__main__":
    main()

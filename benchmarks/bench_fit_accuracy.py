"""Accuracy of adavar's noise-coefficient fit against allan_variance.estimate_parameters.

Simulated sensors with known angle random walk N and rate random walk K (white rate noise
``N * randn / sqrt(tau0)`` plus the random walk ``cumsum(K * sqrt(tau0) * randn)``), 4e5
samples at 1 Hz, 20 seeds each. For every record:

* adavar: ``adavar.stats.statistics.deviation(stat="oadev")`` (edf from the Greenhall-Riley
  algorithm with the noise type identified per tau) then ``adavar.fit.noise_model.fit_noise``
  (non-negative least squares weighted by ``edf / (2 avar^2)``, iteratively reweighted with
  the model). Two tau grids: ``"octave"`` (1, 2, 4, ... up to half the record), the
  documented choice (the NIST SP 1065 / IEEE Std 952 convention and adavar's default), and
  ``"log"`` (10 per decade) for comparison; the denser grid adds no accuracy, because
  neighbouring overlapping estimates are strongly correlated.
* peer: ``allan_variance.compute_avar`` (its default: 100 log-spaced cluster sizes up to a
  tenth of the record) then ``allan_variance.estimate_parameters`` (non-negative least
  squares on the relative residuals, i.e. weights ``1 / avar_measured^2``), with the same
  terms: ``["white", "walk"]`` for the two-term model, all five effects for the full one.

The table gives the median over seeds of the relative error ``|fitted / true - 1|`` of N
and K, the ratio adavar / peer (< 1: adavar is more accurate) and the median time of one
fit (the statistic itself excluded). Run with ``python benchmarks/bench_fit_accuracy.py``.
"""

from __future__ import annotations

import os
import platform
import time

import numpy as np
from allan_variance import compute_avar, estimate_parameters

from adavar.fit.noise_model import TERM_NAMES, fit_noise
from adavar.stats.statistics import deviation

N_SAMPLES = 400_000
TAU0 = 1.0
SEEDS = range(20)

# (label, N [unit*sqrt(s)], K [unit/sqrt(s)])
SENSORS = [
    ("N=1e-2, K=1e-4 (crossover 173 s)", 1e-2, 1e-4),
    # a tactical-grade gyro in deg/s: ARW 0.05 deg/sqrt(h), RRW 0.5 deg/h/sqrt(h)
    ("tactical gyro deg/s (crossover 623 s)", 0.05 / 60.0, 0.5 / 3600.0 / 60.0),
]
# (label, adavar terms, allan_variance effects)
MODELS = [
    ("N+K", ("angle_random_walk", "rate_random_walk"), ["white", "walk"]),
    ("all 5", TERM_NAMES, None),
]
ADAVAR_TAUS = [("octave", {"taus": "octave"}), ("log10", {"taus": "log", "points_per_decade": 10})]


def simulate(n_coef: float, k_coef: float, seed: int) -> np.ndarray:
    """White rate noise of coefficient N plus a rate random walk of coefficient K."""
    rng = np.random.default_rng(seed)
    white = n_coef * rng.standard_normal(N_SAMPLES) / np.sqrt(TAU0)
    walk = np.cumsum(k_coef * np.sqrt(TAU0) * rng.standard_normal(N_SAMPLES))
    return white + walk


def main() -> None:
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}"
    )
    print(f"records: {N_SAMPLES} samples at {1 / TAU0:g} Hz, {len(SEEDS)} seeds per sensor\n")
    # errors[(sensor, model, method)] = list of (rel err N, rel err K, fit seconds)
    errors: dict[tuple[str, str, str], list[tuple[float, float, float]]] = {}
    warmed = False
    t_start = time.perf_counter()
    for label, n_true, k_true in SENSORS:
        for seed in SEEDS:
            y = simulate(n_true, k_true, seed)
            curves = {
                name: deviation(y, stat="oadev", rate=1 / TAU0, **kw) for name, kw in ADAVAR_TAUS
            }
            tau_p, avar_p = compute_avar(y, dt=TAU0)
            if not warmed:  # load the compiled kernel before timing
                fit_noise(curves["octave"])
                warmed = True
            for model, terms, effects in MODELS:
                for name, res in curves.items():
                    t0 = time.perf_counter()
                    fit = fit_noise(res, terms=terms)
                    dt = time.perf_counter() - t0
                    errors.setdefault((label, model, f"adavar {name}"), []).append(
                        (
                            fit.angle_random_walk.value / n_true - 1.0,
                            fit.rate_random_walk.value / k_true - 1.0,
                            dt,
                        )
                    )
                t0 = time.perf_counter()
                params, _ = estimate_parameters(tau_p, avar_p, effects=effects)
                dt = time.perf_counter() - t0
                errors.setdefault((label, model, "allan_variance"), []).append(
                    (params["white"] / n_true - 1.0, params["walk"] / k_true - 1.0, dt)
                )

    header = (
        f"{'sensor':<38} {'terms':<6} {'method':<15} {'med|dN|/N':>10} {'ratio':>6} "
        f"{'med|dK|/K':>10} {'ratio':>6} {'mean dN':>8} {'mean dK':>8} {'fit ms':>7}"
    )
    print(header)
    print("-" * len(header))
    for label, _, _ in SENSORS:
        for model, _, _ in MODELS:
            peer = np.asarray(errors[(label, model, "allan_variance")])
            peer_n, peer_k = np.median(np.abs(peer[:, 0])), np.median(np.abs(peer[:, 1]))
            for method in [f"adavar {n}" for n, _ in ADAVAR_TAUS] + ["allan_variance"]:
                e = np.asarray(errors[(label, model, method)])
                med_n, med_k = np.median(np.abs(e[:, 0])), np.median(np.abs(e[:, 1]))
                bias_n, bias_k = 100 * np.mean(e[:, 0]), 100 * np.mean(e[:, 1])
                print(
                    f"{label:<38} {model:<6} {method:<15} {100 * med_n:9.3f}% "
                    f"{med_n / peer_n:6.2f} {100 * med_k:9.2f}% {med_k / peer_k:6.2f} "
                    f"{bias_n:+7.3f}% {bias_k:+7.2f}% {1e3 * np.median(e[:, 2]):7.2f}"
                )
        print()
    print("ratio = adavar median error / allan_variance median error (< 1: adavar better);")
    print("mean dN, dK = mean signed relative error (bias); fit ms = median time of one fit.")
    print(f"total time {time.perf_counter() - t_start:.1f} s")


if __name__ == "__main__":
    main()

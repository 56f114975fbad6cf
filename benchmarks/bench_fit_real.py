"""The noise fit on realistic sensor records: accuracy against truth, calibration, peers.

For each scenario, ``--seeds`` records (3 h at 100 Hz by default) are simulated with
:func:`adavar.simulate.sensor`; the overlapping ADEV at octave taus is fitted by

* adavar's default fit (full covariance, term selection, roll-off handling: ``method="gls"``),
* adavar's previous default (``method="wls"``, diagonal EDF weights, all five terms),
* ``allan_variance.estimate_parameters`` (the peer, relative least squares, same taus),
* the slope-line read-offs (``fit.slopes``: N at 1 s, B = min / 0.664, K at 3 s).

Printed per scenario and term: mean and spread of estimate / truth, the calibration of the
uncertainties (standard deviation of ``(estimate - truth) / uncertainty`` and the fraction
of ``|z| < 1``; ideal 1 and 0.683), how often a term is pinned at 0 or appears where the
truth has none, and how often the model follows the curve (within the 68 % interval or
+-10 % at every fitted tau from 1 s to min(1000 s, a tenth of the record)), B within 20 %
of min / 0.664, N within 5 % of the 1-s slope read-off.

Run: ``python benchmarks/bench_fit_real.py [--seeds 200] [--hours 3]``.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from _machine import describe

import adavar
from adavar import simulate

RATE = 100.0
NAMES = ("angle_random_walk", "bias_instability", "rate_random_walk")
SCENARIOS = {
    "white + RRW": dict(angle_random_walk=0.005, rate_random_walk=2e-4),
    "white + flicker + RRW": dict(
        angle_random_walk=0.005, bias_instability=0.002, rate_random_walk=2e-4
    ),
    "MEMS: 10 Hz filter, 1/131 LSB": dict(
        angle_random_walk=0.005,
        bias_instability=0.0056,
        rate_random_walk=4e-4,
        bandwidth=10.0,
        lsb=1 / 131,
    ),
}
_PEER_NAMES = {"angle_random_walk": "white", "bias_instability": "flicker",
               "rate_random_walk": "walk"}  # fmt: skip
_B = math.sqrt(2 * math.log(2) / math.pi)


def _follows(r, fit, record_s: float, level: float = 0.683) -> bool:
    """Model inside the ``level`` interval or within 10 % at every fitted tau of 1 s .. limit."""
    from adavar.stats.edf import chi2_interval

    top = min(1000.0, record_s / 10.0)
    model = fit.fitted_dev
    sel = (r.tau >= 1.0) & (r.tau <= top) & fit.used
    lo, hi = chi2_interval(r.dev**2, r.edf, level)
    inside = (model**2 >= lo) & (model**2 <= hi)
    close = np.abs(model / r.dev - 1.0) <= 0.10
    return bool(np.all((inside | close)[sel]))


def _has_flat_region(r) -> bool:
    """The curve's local slope within +-0.1 over three consecutive taus (a factor 4)."""
    slope = np.gradient(np.log10(r.dev), np.log10(r.tau))
    flat = np.abs(slope) <= 0.1
    return bool(np.any(flat[:-2] & flat[1:-1] & flat[2:]))


def _peer(r) -> dict[str, float]:
    import allan_variance

    params, _ = allan_variance.estimate_parameters(r.tau, r.dev**2)
    return {k: float(np.asarray(params[_PEER_NAMES[k]]).ravel()[0]) for k in NAMES}


def _peer_ramp(r) -> float:
    import allan_variance

    params, _ = allan_variance.estimate_parameters(r.tau, r.dev**2)
    return float(np.asarray(params["ramp"]).ravel()[0])


def run(seeds: int, hours: float) -> None:
    n = int(hours * 3600 * RATE)
    print(f"machine: {describe()}")
    print(f"{seeds} records per scenario, {hours:g} h at {RATE:g} Hz ({n} samples), octave taus")
    for sname, kw in SCENARIOS.items():
        est = {m: {k: [] for k in NAMES} for m in ("gls", "wls", "peer", "slopes")}
        zs = {m: {k: [] for k in NAMES} for m in ("gls", "wls")}
        follows = {"gls": 0, "wls": 0}
        follows95 = {"gls": 0, "wls": 0}
        n_flat = 0
        spurious = {"gls": 0, "wls": 0, "peer": 0}
        b_ok = n_ok = n_readoff = 0
        t_fit = {"gls": 0.0, "wls": 0.0}
        for seed in range(seeds):
            w = simulate.sensor(n, rate=RATE, seed=seed, **kw)
            r = adavar.deviation(w, rate=RATE, taus="octave")
            fits = {}
            for m in ("gls", "wls"):
                t0 = time.perf_counter()
                fits[m] = adavar.fit_noise(r, method=m)
                t_fit[m] += time.perf_counter() - t0
            peer = _peer(r)
            for k in NAMES:
                truth = kw.get(k, 0.0)
                for m, fit in fits.items():
                    term = getattr(fit, k)
                    if truth > 0:
                        est[m][k].append(term.value / truth)
                        zs[m][k].append((term.value - truth) / term.uncertainty)
                    elif term.value > 0 and k == "bias_instability":
                        spurious[m] += 1
                if truth > 0:
                    est["peer"][k].append(peer[k] / truth)
                    est["slopes"][k].append(fits["gls"].slopes.values[k] / truth)
                elif peer[k] > 0 and k == "bias_instability":
                    spurious["peer"] += 1
            for m, fit in fits.items():  # a rate ramp is never simulated
                spurious[m] += bool(fit.rate_ramp.value > 0)
            spurious["peer"] += bool(_peer_ramp(r) > 0)
            for m, fit in fits.items():
                follows[m] += _follows(r, fit, n / RATE)
                follows95[m] += _follows(r, fit, n / RATE, 0.95)
            g = fits["gls"]
            if _has_flat_region(r) and math.isfinite(g.slopes.values["bias_instability"]):
                n_flat += 1
                b_ok += (
                    abs(g.bias_instability.value / g.slopes.values["bias_instability"] - 1) <= 0.2
                )
            n_read = g.slopes.values["angle_random_walk"]
            # "where the -1/2 slope holds": the anchor's local slope within 0.05 of it
            if abs(g.slopes.anchor_slope["angle_random_walk"] + 0.5) <= 0.05:
                n_readoff += 1
                n_ok += abs(g.angle_random_walk.value / n_read - 1) <= 0.05
        print(f"\n## {sname}  ({', '.join(f'{k}={v:g}' for k, v in kw.items())})")
        print(f"fit time per record: gls {1e3 * t_fit['gls'] / seeds:.1f} ms, "
              f"wls {1e3 * t_fit['wls'] / seeds:.1f} ms")  # fmt: skip
        print(f"model follows the curve (1 s .. min(1000 s, T/10)): gls {follows['gls']}/{seeds}, "
              f"wls {follows['wls']}/{seeds}")  # fmt: skip
        print(f"  same with the 95 % interval: gls {follows95['gls']}/{seeds}, "
              f"wls {follows95['wls']}/{seeds}")  # fmt: skip
        print(f"B within 20 % of min/0.664 where a flat region exists: {b_ok}/{n_flat}; "
              "N within 5 % of the 1-s read-off "
              f"where the -1/2 slope holds (+-0.05): {n_ok}/{n_readoff}")  # fmt: skip
        print(
            f"spurious B plus spurious R terms (value > 0 where the truth has none): "
            f"gls {spurious['gls']}, wls {spurious['wls']}, allan-variance {spurious['peer']}"
        )
        print("| term | method | mean est/truth | sd | pinned at 0 | sd(z) | P(|z|<1) |")
        print("|---|---|---|---|---|---|---|")
        for k in NAMES:
            if not est["gls"][k]:
                continue
            for m in ("gls", "wls", "peer", "slopes"):
                e = np.array(est[m][k], dtype=float)
                line = (
                    f"| {k} | {m} | {np.nanmean(e):.3f} | {np.nanstd(e):.3f} "
                    f"| {np.mean(e == 0):.2f} |"
                )
                if m in zs:
                    z = np.array(zs[m][k])
                    line += f" {np.std(z):.2f} | {np.mean(np.abs(z) < 1):.2f} |"
                else:
                    line += " - | - |"
                print(line)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=200)
    parser.add_argument("--hours", type=float, default=3.0)
    args = parser.parse_args()
    run(args.seeds, args.hours)


if __name__ == "__main__":
    main()

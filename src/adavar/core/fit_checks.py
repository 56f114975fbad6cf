"""Warnings about a noise fit whose terms the curve cannot tell apart.

Two terms with a strong negative correlation of their estimates trade off: the data fix
their sum over the fitted taus, not each one. That is harmless while each term dominates the
curve somewhere (its own slope pins it), and misleading when one of them dominates nowhere:
its value is then an extrapolation, and the other term's value moves with it. The classic
case is a quantization term ``Q`` above short taus that were excluded because the curve
rolls off there: the excluded points lie *below* the white-noise line, which a positive
``Q`` would lift, so the data that could pin ``Q`` contradict it, and ``N`` comes out low.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from adavar.core.terms import LETTERS, POWERS, TERM_NAMES

__all__ = ["TRADEOFF_CORRELATION", "tradeoff_warnings"]

#: Correlation of two coefficients' estimates below which they are said to trade off.
TRADEOFF_CORRELATION = -0.9
#: A term dominates the curve where it holds more than this share of the model variance.
_DOMINANT = 0.5


def tradeoff_warnings(fit: Any) -> list[str]:
    """One line per active term the curve does not identify (a full-covariance fit of one
    curve; anything else gives none)."""
    cov = getattr(fit, "coefficient_covariance", None)
    used = getattr(fit, "used", None)
    if cov is None or used is None or np.ndim(fit.coefficients) != 1:
        return []
    coef = np.asarray(fit.coefficients, dtype=float)
    tau = np.asarray(fit.tau, dtype=float)[np.asarray(used, dtype=bool)]
    if tau.size == 0:
        return []
    model = fit.model_avar(tau)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.sqrt(np.diag(cov))
        corr = cov / np.outer(d, d)
    active = [k for k in range(5) if coef[k] > 0]
    rolled = any(str(r).startswith("short-tau") for r in getattr(fit, "exclusions", ()))
    out = []
    for k in active:
        share = coef[k] * tau ** POWERS[k] / model
        if np.nanmax(share) > _DOMINANT:
            continue
        partners = [
            (float(corr[k, j]), j) for j in active
            if j != k and np.isfinite(corr[k, j]) and corr[k, j] < TRADEOFF_CORRELATION
        ]  # fmt: skip
        if not partners:
            continue
        r, j = min(partners)
        name, other = TERM_NAMES[k], TERM_NAMES[j]
        line = (
            f"{LETTERS[name]} ({name}) dominates the curve at no fitted tau and trades off "
            f"against {LETTERS[other]} (correlation {r:.2f}): {LETTERS[name]} is not "
            f"identified by this curve and {LETTERS[other]} moves with it"
        )
        if k == 0 and rolled:
            line += (
                "; a positive Q contradicts the short taus excluded for a roll-off (the "
                "curve falls below the white-noise line there, Q would lift it)"
            )
        out.append(line + f"; compare the fit without {name} (terms=...)")
    return out

"""The classical slope-line read-offs of an Allan-deviation curve (IEEE Std 952 practice).

Engineers compare fits with the values read off the log-log ADEV plot, as in IEEE Std 952,
datasheets and MATLAB's ``allanvar`` example: a line of the term's slope is laid through the
point of the curve whose local slope is nearest to it, and read at the term's tau:

=====================  =======  =====================  ================================
term                   slope    read at                value
=====================  =======  =====================  ================================
quantization Q         -1       ``tau = sqrt(3)`` s    ``sigma(sqrt 3)``
angle random walk N    -1/2     ``tau = 1`` s          ``sigma(1)``
bias instability B     0        the minimum            ``min sigma / sqrt(2 ln2 / pi)``
rate random walk K     +1/2     ``tau = 3`` s          ``sigma(3)``
rate ramp R            +1       ``tau = sqrt(2)`` s    ``sigma(sqrt 2)``
=====================  =======  =====================  ================================

A line is laid only where the curve has that slope (local slope within ``tolerance`` of it;
for B, an interior minimum), falling lines left of the curve's minimum and rising ones
right of it; elsewhere the read-off is NaN. Each read-off carries the
relative half-width of the deviation's confidence interval at its anchor point as its
1-sigma uncertainty (NaN without intervals). The read-offs are biased where terms overlap
(the minimum includes N and K, so ``min / 0.664`` over-reads B): they are the reference
users compare against, not an estimator of choice.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["SLOPE_TOLERANCE", "SlopeReadoff", "read_slopes"]

#: Largest difference between the local slope and the term's slope where a line is laid.
SLOPE_TOLERANCE = 0.15
_B_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)  # 0.6643
# term -> (slope of sigma, tau where the line is read, factor sigma -> coefficient)
_LINES = {
    "quantization": (-1.0, math.sqrt(3.0)),
    "angle_random_walk": (-0.5, 1.0),
    "rate_random_walk": (0.5, 3.0),
    "rate_ramp": (1.0, math.sqrt(2.0)),
}


@dataclass(frozen=True)
class SlopeReadoff:
    """Slope-line read-offs of one curve.

    Attributes
    ----------
    values : dict of str to float
        Term name -> read-off coefficient in the data's units (NaN where the curve has no
        stretch of that slope).
    uncertainty : dict of str to float
        Term name -> 1-sigma (relative half-width of the interval at the anchor).
    anchor_tau : dict of str to float
        Term name -> tau (s) of the curve point the line passes through.
    anchor_slope : dict of str to float
        Term name -> the curve's local slope there (how well the term's slope holds).
    tolerance : float
        The slope tolerance used.
    """

    values: dict[str, float]
    uncertainty: dict[str, float]
    anchor_tau: dict[str, float]
    anchor_slope: dict[str, float]
    tolerance: float

    def __getitem__(self, name: str) -> float:
        return self.values[name]


def read_slopes(
    tau: Any,
    dev: Any,
    dev_low: Any = None,
    dev_high: Any = None,
    *,
    tolerance: float = SLOPE_TOLERANCE,
    tau_max: float | None = None,
) -> SlopeReadoff:
    """Read the five coefficients off a deviation curve with slope lines.

    Parameters
    ----------
    tau, dev : array_like, shape (M,)
        Averaging times (s) and the Allan deviation.
    dev_low, dev_high : array_like, optional
        Confidence bounds of ``dev``, for the uncertainties.
    tolerance : float
        Largest ``|local slope - term slope|`` at which a line is laid.
    tau_max : float, optional
        Read only taus up to this (s). :func:`adavar.fit_noise` passes a tenth of the
        record: beyond it the estimates have a few degrees of freedom, and a low one would
        pass for the minimum or for a slope.

    Returns
    -------
    SlopeReadoff
    """
    tau = np.asarray(tau, dtype=float)
    dev = np.asarray(dev, dtype=float)
    ok = np.isfinite(dev) & (dev > 0) & np.isfinite(tau) & (tau > 0)
    if tau_max is not None:
        ok &= tau <= tau_max
    order = np.flatnonzero(ok)[np.argsort(tau[ok])]
    t, d = tau[order], dev[order]
    if dev_low is not None and dev_high is not None:
        rel = (np.asarray(dev_high, float)[order] - np.asarray(dev_low, float)[order]) / (2 * d)
    else:
        rel = np.full(t.size, np.nan)
    values = dict.fromkeys(("quantization", "angle_random_walk", "bias_instability",
                            "rate_random_walk", "rate_ramp"), math.nan)  # fmt: skip
    unc = dict(values)
    anchor = dict(values)
    anchor_slope = dict(values)
    if t.size >= 3:
        lt, ld = np.log10(t), np.log10(d)
        slope = np.gradient(ld, lt)
        j_min = int(np.argmin(d))
        for name, (target, at) in _LINES.items():
            # falling lines left of the minimum, rising ones right of it: a filter's
            # roll-off at short taus also rises, and is not rate random walk
            side = np.arange(t.size) <= j_min if target < 0 else np.arange(t.size) >= j_min
            cand = np.where(side, np.abs(slope - target), np.inf)
            j = int(np.argmin(cand))
            if cand[j] <= tolerance:
                intercept = ld[j] - target * lt[j]
                values[name] = 10.0 ** (target * math.log10(at) + intercept)
                unc[name] = values[name] * rel[j]
                anchor[name] = float(t[j])
                anchor_slope[name] = float(slope[j])
        j = int(np.argmin(d))
        if 0 < j < t.size - 1:
            values["bias_instability"] = d[j] / _B_FACTOR
            unc["bias_instability"] = values["bias_instability"] * rel[j]
            anchor["bias_instability"] = float(t[j])
            anchor_slope["bias_instability"] = float(slope[j])
    return SlopeReadoff(values, unc, anchor, anchor_slope, float(tolerance))

"""Compiled helpers of :mod:`adavar.stats.gaps`: filling the missing samples, and the lag-1
statistics of a series with gaps.

The sums that leave out the terms touching a missing sample are the gap-free sums'
own kernels (:mod:`adavar._kernels.differences`) given the missing samples as an argument.
"""

from __future__ import annotations

import numpy as np

from adavar._kernels._jit import jit

__all__ = [
    "fill_missing",
    "fit_moments",
    "lag1_moments",
]

# ---------------------------------------------------------------------------------------
# filling the gaps, and the lag-1 statistics of a series with gaps


@jit
def fill_missing(x, missing, out):  # pragma: no cover - compiled
    """``out = x`` with each missing run interpolated linearly between its neighbours
    (held at the first / last present value at the ends). Needs one present sample."""
    n = x.size
    prev = -1
    for i in range(n):
        if missing[i]:
            continue
        if prev < 0:
            for j in range(i):
                out[j] = x[i]
        elif i - prev > 1:
            a = x[prev]
            slope = (x[i] - a) / (i - prev)
            for j in range(prev + 1, i):
                out[j] = a + slope * (j - prev)
        out[i] = x[i]
        prev = i
    for j in range(prev + 1, n):
        out[j] = x[prev]


@jit
def fit_moments(z, ok):  # pragma: no cover - compiled
    """Moments of the kept entries for a least-squares polynomial of degree <= 2 on the
    abscissa ``t = (k - kc) / kc`` (in [-1, 1]): ``[sum t^0..t^4, sum z t^0..t^2, max|z|]``."""
    n = z.size
    kc = 0.5 * (n - 1)
    h = max(kc, 1.0)
    mom = np.zeros(9)
    for k in range(n):
        if not ok[k]:
            continue
        t = (k - kc) / h
        t2 = t * t
        mom[0] += 1.0
        mom[1] += t
        mom[2] += t2
        mom[3] += t2 * t
        mom[4] += t2 * t2
        mom[5] += z[k]
        mom[6] += t * z[k]
        mom[7] += t2 * z[k]
        mom[8] = max(mom[8], abs(z[k]))
    return mom


@jit
def _order_step(x, v, prev, pok, a):  # pragma: no cover - compiled
    """One entry of one difference order into its accumulators ``a`` (a 7-tuple)."""
    n0, s1, s2, n1, spp, sprev, scur = a
    if v:
        n0 += 1.0
        s1 += x
        s2 += x * x
        if pok:
            n1 += 1.0
            spp += prev * x
            sprev += prev
            scur += x
    return n0, s1, s2, n1, spp, sprev, scur


@jit
def lag1_moments(z, ok, coef, dmax):  # pragma: no cover - compiled
    """Per difference order ``d = 0 .. dmax`` (<= 3) of the residual ``z - poly(t)``:
    ``[kept, sum x, sum x^2, kept pairs, sum x_prev x, sum x_prev, sum x]`` (pairs of
    adjacent kept entries). An entry of order ``d`` is kept when both parents are."""
    n = z.size
    kc = 0.5 * (n - 1)
    h = max(kc, 1.0)
    c0, c1, c2 = coef[0], coef[1], coef[2]
    zero = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    a0 = a1 = a2 = a3 = zero
    q0 = q1 = q2 = q3 = 0.0  # previous entries of each order
    k0 = k1 = k2 = k3 = np.bool_(False)  # ... and whether they are kept
    for k in range(n):
        t = (k - kc) / h
        x0 = z[k] - (c0 + t * (c1 + t * c2))
        v0 = ok[k]
        a0 = _order_step(x0, v0, q0, k0, a0)
        x1 = x0 - q0
        v1 = v0 and k0
        x2 = x1 - q1
        v2 = v1 and k1
        x3 = x2 - q2
        v3 = v2 and k2
        if dmax >= 1:
            a1 = _order_step(x1, v1, q1, k1, a1)
        if dmax >= 2:
            a2 = _order_step(x2, v2, q2, k2, a2)
        if dmax >= 3:
            a3 = _order_step(x3, v3, q3, k3, a3)
        q0, q1, q2, q3 = x0, x1, x2, x3
        k0, k1, k2, k3 = v0, v1, v2, v3
    acc = np.zeros((dmax + 1, 7))
    for j in range(7):
        acc[0, j] = a0[j]
        if dmax >= 1:
            acc[1, j] = a1[j]
        if dmax >= 2:
            acc[2, j] = a2[j]
        if dmax >= 3:
            acc[3, j] = a3[j]
    return acc

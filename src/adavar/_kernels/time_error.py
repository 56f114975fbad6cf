"""Compiled kernels of the time-error statistics (:mod:`adavar.stats.time_error`).

Both work on the phase ``x[k] = u[0] + ... + u[k-1]`` held as a normalised double-double
(``xh + xl``), so that neither a frequency offset (which MTIE and TIE keep: they are not
blind to it) nor a drift or a long record costs digits: every difference ``x[a] - x[b]`` is
formed from the two parts and rounds once, relative to itself.
"""

from __future__ import annotations

import numpy as np

from adavar._kernels._jit import jit
from adavar._kernels.double_double import two_sum

__all__ = ["dd_phase", "mtie_values", "tie_square_sums"]


@jit
def dd_phase(u, xh, xl):  # pragma: no cover - compiled
    """``x[0] = 0``, ``x[k+1] = x[k] + u[k]`` in double-double (normalised pairs).

    The running sum ``hi`` and its rounding errors ``lo`` are carried apart (Neumaier's
    summation: one dependent addition per sample); each stored pair is renormalised.
    """
    hi = 0.0
    lo = 0.0
    xh[0] = 0.0
    xl[0] = 0.0
    for k in range(u.size):
        hi, e = two_sum(hi, u[k])
        lo += e
        xh[k + 1], xl[k + 1] = two_sum(hi, lo)


@jit
def _above(ah, al, bh, bl):  # pragma: no cover - compiled
    """``a > b`` for normalised double-doubles (their order is that of ``(high, low)``)."""
    return ah > bh or (ah == bh and al > bl)


@jit
def mtie_values(xh, xl, ms, out):  # pragma: no cover - compiled
    """``max_i (max - min of x[i .. i+m])`` for every ``m``: a doubling (sparse) table.

    ``T_p[i]`` holds the maximum (and minimum) of the ``p + 1`` points ``x[i .. i+p]`` for
    ``p`` a power of two; ``T_2p[i] = max(T_p[i], T_p[i+p])``, built in place. A window of
    ``m + 1`` points with ``p <= m < 2p`` is the union of the two overlapping windows
    starting at ``i`` and ``i + m - p``, so its extremes are two comparisons: O(N) per
    factor with no data-dependent branching, and O(N log m) to build the levels, taken in
    increasing ``m``. Extremes compare both parts of the double-double, so each is exact
    and the span rounds once: a frequency offset costs no digits.
    """
    npts = xh.size
    mxh = xh.copy()  # level p = 0: every point its own window
    mxl = xl.copy()
    mnh = xh.copy()
    mnl = xl.copy()
    p = 0
    for idx in np.argsort(ms):
        m = ms[idx]
        while (1 if p == 0 else 2 * p) <= m:  # raise the table to the largest p <= m
            step = 1 if p == 0 else p
            p = 1 if p == 0 else 2 * p
            for i in range(npts - p):
                j = i + step
                if _above(mxh[j], mxl[j], mxh[i], mxl[i]):
                    mxh[i] = mxh[j]
                    mxl[i] = mxl[j]
                if _above(mnh[i], mnl[i], mnh[j], mnl[j]):
                    mnh[i] = mnh[j]
                    mnl[i] = mnl[j]
        best = 0.0
        off = m - p
        for i in range(npts - m):
            j = i + off
            if _above(mxh[j], mxl[j], mxh[i], mxl[i]):
                hh = mxh[j]
                hl = mxl[j]
            else:
                hh = mxh[i]
                hl = mxl[i]
            if _above(mnh[i], mnl[i], mnh[j], mnl[j]):
                lh = mnh[j]
                ll = mnl[j]
            else:
                lh = mnh[i]
                ll = mnl[i]
            span = (hh - lh) + (hl - ll)
            if span > best:
                best = span
        out[idx] = best


@jit
def tie_square_sums(xh, xl, ms, out):  # pragma: no cover - compiled
    """``sum_i (x[i+m] - x[i])**2`` over ``i = 0 .. N - m - 1`` for every ``m``."""
    npts = xh.size
    for idx in range(ms.size):
        m = ms[idx]
        count = npts - m
        a0 = 0.0
        a1 = 0.0
        blocks = count // 2
        for b in range(blocks):
            i = 2 * b
            d0 = (xh[i + m] - xh[i]) + (xl[i + m] - xl[i])
            d1 = (xh[i + 1 + m] - xh[i + 1]) + (xl[i + 1 + m] - xl[i + 1])
            a0 += d0 * d0
            a1 += d1 * d1
        for i in range(2 * blocks, count):
            d = (xh[i + m] - xh[i]) + (xl[i + m] - xl[i])
            a0 += d * d
        out[idx] = a0 + a1

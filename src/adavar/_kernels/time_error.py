"""Compiled kernels of the time-error statistics (:mod:`adavar.time_error`).

Both work on the phase ``x[k] = u[0] + ... + u[k-1]`` held as a normalised double-double
(``xh + xl``), so that neither a frequency offset (which MTIE and TIE keep: they are not
blind to it) nor a drift or a long record costs digits: every difference ``x[a] - x[b]`` is
formed from the two parts and rounds once, relative to itself.
"""

from __future__ import annotations

import numpy as np

from adavar._jit import jit
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
def mtie_values(xh, xl, ms, out):  # pragma: no cover - compiled
    """``max_i (max - min of x[i .. i+m])`` for every ``m``, by monotone deques: O(N) per m.

    Each index enters and leaves each deque once; the deques live in two index arrays.
    The deques order the points by ``xh`` (a tie within one ulp of ``x`` may pick either
    point, which changes the span by at most that ulp); the span itself is taken from both
    parts, so a frequency offset costs no digits.
    """
    npts = xh.size
    qmax = np.empty(npts, dtype=np.int64)
    qmin = np.empty(npts, dtype=np.int64)
    for idx in range(ms.size):
        w = ms[idx] + 1  # a window of m + 1 points spans m sample intervals
        hmax = 0
        tmax = 0
        hmin = 0
        tmin = 0
        best = 0.0
        for k in range(npts):
            xk = xh[k]
            while tmax > hmax and xk >= xh[qmax[tmax - 1]]:
                tmax -= 1
            qmax[tmax] = k
            tmax += 1
            while tmin > hmin and xk <= xh[qmin[tmin - 1]]:
                tmin -= 1
            qmin[tmin] = k
            tmin += 1
            first = k - w + 1
            if qmax[hmax] < first:
                hmax += 1
            if qmin[hmin] < first:
                hmin += 1
            if first >= 0:
                a = qmax[hmax]
                b = qmin[hmin]
                span = (xh[a] - xh[b]) + (xl[a] - xl[b])
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

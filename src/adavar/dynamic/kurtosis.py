"""Sliding kurtosis and the sliding kurtosis contribution coefficient (paper Eq. 14-15).

:func:`sliding_kurtosis` gives the Pearson kurtosis (biased moments, 3 for Gaussian data)
of the window centred at every centre; :func:`kurtosis_contribution` the coefficient

    ``S = (kurt(X) - kurt(c)) / kurt(X)``

of docs/method.md section 7, where ``c`` is the reference sequence ``X`` without a segment ``s``:
either the adaptive controller's form (``X`` the window, ``s`` its newest samples) or the
paper's section 3 demonstration (``X`` the whole record, ``s`` the window).

How it works. The centres are cut into chunks of consecutive centres (spanning about
8 000 samples, more for longer windows). Per chunk, an anchor ``a`` (the median of 65 of
the chunk's samples: a data value) and a power of two ``f`` (so that ``|f (x - a)| < 1``)
are chosen, and the sums of ``d**k``, ``d = f (x - a)``, ``k = 1..4``, are accumulated over
the chunk's span in double-double: the powers are formed with fused multiply-adds that keep
their rounding errors. A window's raw power sums are then a difference of two prefix
values, O(1) whatever its length, and its central moments follow around the anchor: in
double precision when the window's mean lies within 4 of its standard deviations of the
anchor (stationary data: nearly always; at most a factor 256 on eps), in double-double
otherwise (drifts, level changes). Removing the anchor takes out any offset exactly; the
power-of-two scaling is exact and keeps the fourth powers of data at any scale clear of
underflow and overflow. Constant windows are found exactly, from the runs of equal values.

Every window also gets a rigorous bound on the rounding error of its central sums (the
prefix values it differences carry everything accumulated before it in the chunk, and the
conversion amplifies errors by ``(distance to anchor / sigma)**4``). When the bound exceeds
2**-40 of the sums, the window is evaluated from backward (suffix) sums of the chunk,
which do not hold the samples before it, and failing that summed directly in two passes,
O(L). On ordinary records (noise with offsets, drifts, random walks, bursts of 1e4x the
noise) that almost never happens; it does for windows within a chunk of spikes above about
3e4 sigma on both sides, or on the far side of a level step above about 1e4 sigma from
their chunk's anchor, and those cost O(L) each.

The record form (``X`` the whole record) never subtracts the window from the record: the
complement's moments are merged (Pébay's pairwise formulas) from the record before the
chunk and after it (two-pass moments of 1024-sample blocks, chained by merges) and from the
chunk's forward sums up to the window and backward sums from its end.

Cost: O(N) for the whole record, independent of the window lengths and of how they change
from one centre to the next (save the fallback above); the chunks run in parallel.

Accuracy: measured against a two-pass ``math.fsum`` reference (tests/test_kurtosis.py)
the absolute error of the kurtosis stays below 5e-13, and that of ``S`` below 3e-13, on
white noise, with an offset of 1e6 standard deviations, a drift of 1e6 sigma across the
record, float32 data, bursts of 1e4x the noise, spikes of 1e8 sigma, level steps of 1e6
sigma, random walks, and scales 1e-13 and 1e12; windows fixed or changing length at every
centre. A record far from 1 (beyond 2**±64) is first scaled by a power of two, exactly, so
that data near the float64 limit or of subnormal numbers give the kurtosis of the same
values at scale 1, bit for bit.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from adavar._kernels._jit import grouped_items, jit, read_only, threaded_jit, work_items
from adavar._kernels.double_double import (
    dd_add,
    dd_div_d,
    dd_mul,
    dd_mul_d,
    fast_two_sum,
    fma,
    two_sum,
)
from adavar._kernels.window_avar import sample_median
from adavar.core.errors import AdavarInputError
from adavar.core.inputs import as_samples, scaled
from adavar.dynamic.windows import window_schedule

__all__ = ["MIN_COMPLEMENT", "REFERENCES", "kurtosis_contribution", "sliding_kurtosis"]

#: forms of the contribution coefficient: the adaptive controller's and the paper's Fig. 7
REFERENCES = ("window", "record")
#: fewest samples left in the window once the segment is removed (``reference="window"``)
MIN_COMPLEMENT = 4

#: samples per chunk of centres (times ``step``), at least the longest window
_SPAN = 8192
#: record-form grid: prefix and suffix moments are kept at multiples of this
_GRID = 1024
#: data values sampled to choose a chunk's anchor (median)
_ANCHOR_SAMPLES = 65
#: double-precision conversion when ``n * mean**2 <= _FAST * S2`` (mean within 4 sigma)
_FAST = 15.0 / 16.0
#: square of the unit roundoff
_EPS2 = 2.0**-106
#: largest relative error bound on a window's central sums before it is summed directly
_TOL = 2.0**-40


# ---------------------------------------------------------------------------------------
# double-double arithmetic (never compiled with fast-math: it relies on exact rounding)


# ---------------------------------------------------------------------------------------
# per-chunk kernels


@jit
def _power_of_two_scale(big):  # pragma: no cover - compiled
    """``2**-e`` with ``big * 2**-e`` in [0.5, 1) (1 for 0 or inf; no overflow if subnormal)."""
    if big == 0.0 or not np.isfinite(big):
        return 1.0
    return math.ldexp(1.0, min(-math.frexp(big)[1], 1021))


@jit
def _anchor_scale(y, lo, hi, tmp):  # pragma: no cover - compiled
    """Median of an even sample of ``y[lo:hi]`` and a power of two ``f`` with |f (y - a)| < 1."""
    anchor = sample_median(y, lo, hi, tmp)
    big = 0.0
    for j in range(lo, hi):
        big = max(big, abs(y[j] - anchor))
    return anchor, _power_of_two_scale(big)


@jit
def _dd_accumulate(s, e, y, q):  # pragma: no cover - compiled
    """``(s, e) + y + q`` for a double ``y`` and a small correction ``q``, renormalised.

    The error of one step is about eps**2 |s|, so a prefix of ``j`` terms is off by at most
    about ``eps**2 * j * max|s|``.
    """
    t = s + y
    bb = t - s
    e = e + (((s - (t - bb)) + (y - bb)) + q)
    s = t + e
    return s, e - (s - t)


@jit
def _add_powers(s1, e1, s2, e2, s3, e3, s4, e4, d):  # pragma: no cover - compiled
    """Add ``d, d**2, d**3, d**4`` (exact to eps**2: FMAs keep the products' errors)."""
    p2 = d * d
    q2 = fma(d, d, -p2)
    p3 = p2 * d
    q3 = fma(p2, d, -p3) + q2 * d
    p4 = p2 * p2
    q4 = fma(p2, p2, -p4) + 2.0 * p2 * q2
    s1, e1 = _dd_accumulate(s1, e1, d, 0.0)
    s2, e2 = _dd_accumulate(s2, e2, p2, q2)
    s3, e3 = _dd_accumulate(s3, e3, p3, q3)
    s4, e4 = _dd_accumulate(s4, e4, p4, q4)
    return s1, e1, s2, e2, s3, e3, s4, e4


@jit
def _store(row, s1, e1, s2, e2, s3, e3, s4, e4):  # pragma: no cover - compiled
    row[0] = s1
    row[1] = s2
    row[2] = s3
    row[3] = s4
    row[4] = e1
    row[5] = e2
    row[6] = e3
    row[7] = e4


@jit
def _prefix_moments(y, lo, hi, anchor, scale, P, R):  # pragma: no cover - compiled
    """Double-double prefix sums of ``d**k`` (``d = scale (y - anchor)``) over ``y[lo:hi]``.

    ``P[j, k-1] + P[j, k+3]`` is ``sum(d[lo:lo+j]**k)`` for ``k = 1..4`` (high parts, then
    low parts). The powers are exact to eps**2 (fused multiply-adds keep the products'
    rounding errors). ``R[j]`` is the first index of the run of equal values that holds
    sample ``lo + j`` (local indices), so ``y[lo+a : lo+b]`` is constant iff
    ``R[b - 1] <= a``.
    """
    s1 = s2 = s3 = s4 = 0.0
    e1 = e2 = e3 = e4 = 0.0
    for k in range(8):
        P[0, k] = 0.0
    prev = y[lo]
    run = 0
    for j in range(hi - lo):
        v = y[lo + j]
        s1, e1, s2, e2, s3, e3, s4, e4 = _add_powers(
            s1, e1, s2, e2, s3, e3, s4, e4, (v - anchor) * scale
        )
        _store(P[j + 1], s1, e1, s2, e2, s3, e3, s4, e4)
        if v != prev:
            run = j
            prev = v
        R[j] = run


@jit
def _suffix_moments(y, lo, hi, anchor, scale, Q):  # pragma: no cover - compiled
    """Like :func:`_prefix_moments`, backwards: ``Q[j]`` sums ``d[lo+j : hi]``."""
    s1 = s2 = s3 = s4 = 0.0
    e1 = e2 = e3 = e4 = 0.0
    span = hi - lo
    for k in range(8):
        Q[span, k] = 0.0
    for j in range(span - 1, -1, -1):
        s1, e1, s2, e2, s3, e3, s4, e4 = _add_powers(
            s1, e1, s2, e2, s3, e3, s4, e4, (y[lo + j] - anchor) * scale
        )
        _store(Q[j], s1, e1, s2, e2, s3, e3, s4, e4)


@jit
def _raw_dd(P, a, b, k):  # pragma: no cover - compiled
    """``sum d[a:b]**(k+1)`` as a normalised double-double."""
    s, e = two_sum(P[b, k], -P[a, k])
    return fast_two_sum(s, e + (P[b, k + 4] - P[a, k + 4]))


@jit
def _central_dd(P, a, b, n):  # pragma: no cover - compiled
    """Mean offset and central sums ``M2, M3, M4`` of ``n`` samples, double-double.

    The raw sums are ``P[b] - P[a]`` (prefix sums: ``d[a:b]``, ``b = a + n``; suffix sums:
    ``d[b:a]``). With ``delta = S1 / n``: ``M2 = S2 - delta S1``,
    ``M3 = S3 - delta (3 S2 - 2 delta S1)``, ``M4 = S4 - delta (4 S3 - delta (6 S2 - 3 delta
    S1))``. Returns the high parts.
    """
    s1h, s1l = _raw_dd(P, a, b, np.int64(0))
    s2h, s2l = _raw_dd(P, a, b, np.int64(1))
    s3h, s3l = _raw_dd(P, a, b, np.int64(2))
    s4h, s4l = _raw_dd(P, a, b, np.int64(3))
    dh, dl = dd_div_d(s1h, s1l, float(n))
    # delta * S1
    th, tl = dd_mul(dh, dl, s1h, s1l)
    m2h, _ = dd_add(s2h, s2l, -th, -tl)
    # M3 (products by 3 and 6 are not exact in double: done in double-double)
    ah, al = dd_mul_d(s2h, s2l, 3.0)
    uh, ul = dd_add(ah, al, -2.0 * th, -2.0 * tl)
    uh, ul = dd_mul(dh, dl, uh, ul)
    m3h, _ = dd_add(s3h, s3l, -uh, -ul)
    # M4
    ah, al = dd_mul_d(s2h, s2l, 6.0)
    bh, bl = dd_mul_d(th, tl, 3.0)
    uh, ul = dd_add(ah, al, -bh, -bl)
    uh, ul = dd_mul(dh, dl, uh, ul)
    uh, ul = dd_add(4.0 * s3h, 4.0 * s3l, -uh, -ul)
    uh, ul = dd_mul(dh, dl, uh, ul)
    m4h, _ = dd_add(s4h, s4l, -uh, -ul)
    return dh, m2h, m3h, m4h


@jit
def _direct_kurtosis(y, first, n, scale):  # pragma: no cover - compiled
    """Kurtosis of ``y[first:first+n]`` in two passes around its first sample (O(n))."""
    x0 = y[first]
    s = 0.0
    c = 0.0
    for j in range(first, first + n):
        s, e = two_sum(s, (y[j] - x0) * scale)
        c += e
    mean = (s + c) / n
    r = 0.0
    for j in range(first, first + n):
        r += (y[j] - x0) * scale - mean
    mean += r / n
    m2 = 0.0
    m4 = 0.0
    for j in range(first, first + n):
        d = (y[j] - x0) * scale - mean
        d2 = d * d
        m2 += d2
        m4 += d2 * d2
    return n * m4 / (m2 * m2)


@jit(inline="always")  # once per centre: a call would cost 7 %
def _sums_kurtosis(P, a, b, n, top, count):  # pragma: no cover - compiled
    """Kurtosis of ``n`` samples with raw sums ``P[b] - P[a]``, or -1 if not trustworthy.

    ``P[top]`` is the later of the two accumulated values and ``count`` the number of terms
    accumulated into it. One step of the accumulation errs by at most about eps**2 of the
    running sum, and the powers by eps**2 of themselves, so each sum of ``|d|**k`` is off by
    at most ``kappa = eps**2 (2 count + 8)`` of its value at ``top``. With ``delta`` the mean
    offset from the anchor and ``(|d| + |delta|)**4 <= 8 (d**4 + delta**4)``, the central
    sums are off by at most ``8 kappa (P4[top] + count delta**4)`` (M4) and
    ``2 kappa (P2[top] + count delta**2)`` (M2). When that exceeds ``_TOL`` of the sums
    (data far larger than the window's, or far from the anchor, in the accumulated range:
    a spike of 1e6 sigma, a level step of 1e4 sigma) the answer is -1.
    """
    s1 = (P[b, 0] - P[a, 0]) + (P[b, 4] - P[a, 4])
    s2 = (P[b, 1] - P[a, 1]) + (P[b, 5] - P[a, 5])
    delta = s1 / n
    t = delta * s1
    if t <= _FAST * s2:
        # mean within 4 sigma of the anchor: every term below is at most 16 M2 (256 M4)
        s3 = (P[b, 2] - P[a, 2]) + (P[b, 6] - P[a, 6])
        s4 = (P[b, 3] - P[a, 3]) + (P[b, 7] - P[a, 7])
        m2 = s2 - t
        m4 = s4 - delta * (4.0 * s3 - delta * (6.0 * s2 - 3.0 * t))
    else:
        delta, m2, _, m4 = _central_dd(P, a, b, n)
    d2 = delta * delta
    kappa = _EPS2 * (2.0 * count + 8.0)
    if (
        8.0 * kappa * (P[top, 3] + count * d2 * d2) <= _TOL * m4
        and 2.0 * kappa * (P[top, 1] + count * d2) <= _TOL * m2
    ):
        return n * m4 / (m2 * m2)
    return -1.0


@jit
def _chunk_span(starts, lengths, c0, c1):  # pragma: no cover - compiled
    lo = starts[c0]
    hi = starts[c0] + lengths[c0]
    for k in range(c0 + 1, c1):
        lo = min(lo, starts[k])
        hi = max(hi, starts[k] + lengths[k])
    return lo, hi


@threaded_jit
def _sliding(y, starts, lengths, segment, chunk, workers, out, w_lo, w_hi):  # pragma: no cover
    """Kurtosis (``segment == 0``) or the window-form contribution of every window.

    Window ``k`` holds ``y[starts[k] : starts[k] + lengths[k]]``; its complement for the
    contribution is the first ``lengths[k] - segment`` of them. Chunks of ``chunk`` centres
    are dealt round-robin to ``workers`` work items, each with its own scratch; this call
    runs items ``w_lo .. w_hi - 1``.
    """
    nc = starts.size
    nch = (nc + chunk - 1) // chunk
    for w in range(w_lo, w_hi):
        P = np.empty((1, 8))
        Q = np.empty((1, 8))
        R = np.empty(0, dtype=np.int64)
        tmp = np.empty(_ANCHOR_SAMPLES)
        for ch in range(w, nch, workers):
            c0 = ch * chunk
            c1 = min(c0 + chunk, nc)
            lo, hi = _chunk_span(starts, lengths, c0, c1)
            span = hi - lo
            if span + 1 > P.shape[0]:
                P = np.empty((span + 1, 8))
                Q = np.empty((span + 1, 8))
                R = np.empty(span, dtype=np.int64)
            anchor, scale = _anchor_scale(y, lo, hi, tmp)
            _prefix_moments(y, lo, hi, anchor, scale, P, R)
            have_suffix = False
            for k in range(c0, c1):
                a = starts[k] - lo
                for part in range(2 if segment else 1):
                    n = lengths[k] - part * segment
                    b = a + n
                    if R[b - 1] <= a:  # all equal: no kurtosis
                        v = np.nan
                    else:
                        # forward sums hold everything in the chunk before the window: after
                        # a spike or far from the anchor, try the backward sums, then the data
                        v = _sums_kurtosis(P, a, b, n, b, b)
                        if v < 0.0:
                            if not have_suffix:
                                _suffix_moments(y, lo, hi, anchor, scale, Q)
                                have_suffix = True
                            v = _sums_kurtosis(Q, b, a, n, a, span - a)
                        if v < 0.0:
                            v = _direct_kurtosis(y, lo + a, n, scale)
                    if part == 0:
                        out[k] = v
                    else:
                        out[k] = (out[k] - v) / out[k]


# ---------------------------------------------------------------------------------------
# record form: complements as merges of prefix and suffix moments


@jit
def _merge(na, ma, a2, a3, a4, nb, mb, b2, b3, b4):  # pragma: no cover - compiled
    """Count, mean and central sums M2..M4 of the union of two sets (Pébay 2008)."""
    if na == 0.0:
        return nb, mb, b2, b3, b4
    if nb == 0.0:
        return na, ma, a2, a3, a4
    n = na + nb
    d = mb - ma
    dn = d / n
    mean = ma + nb * dn
    m2 = a2 + b2 + d * dn * na * nb
    m3 = a3 + b3 + d * dn * dn * na * nb * (na - nb) + 3.0 * dn * (na * b2 - nb * a2)
    m4 = (
        a4
        + b4
        + d * dn * dn * dn * na * nb * (na * na - na * nb + nb * nb)
        + 6.0 * dn * dn * (na * na * b2 + nb * nb * a2)
        + 4.0 * dn * (na * b3 - nb * a3)
    )
    return n, mean, m2, m3, m4


@threaded_jit
def _grid_blocks(x, anchor, scale, grid, per, blocks, p_lo, p_hi):  # pragma: no cover
    """Moments (count, mean, M2, M3, M4) of ``scale (x - anchor)`` over each block of
    ``grid`` samples, in two passes; work item ``p`` is blocks ``p per .. (p + 1) per - 1``,
    and this call runs items ``p_lo .. p_hi - 1``."""
    n = x.size
    nb = blocks.shape[0]
    for b in range(p_lo * per, min(p_hi * per, nb)):
        j0 = b * grid
        j1 = min(j0 + grid, n)
        s = 0.0
        for j in range(j0, j1):
            s += (x[j] - anchor) * scale
        mean = s / (j1 - j0)
        m2 = m3 = m4 = 0.0
        for j in range(j0, j1):
            d = (x[j] - anchor) * scale - mean
            d2 = d * d
            m2 += d2
            m3 += d2 * d
            m4 += d2 * d2
        blocks[b, 0] = j1 - j0
        blocks[b, 1] = mean
        blocks[b, 2] = m2
        blocks[b, 3] = m3
        blocks[b, 4] = m4


@jit
def _grid_chain(blocks):  # pragma: no cover - compiled
    """Moments over ``[0, g grid)`` and ``[g grid, N)`` for every g: the blocks of
    :func:`_grid_blocks` chained with :func:`_merge` (no subtraction of sums anywhere)."""
    nb = blocks.shape[0]
    pre = np.zeros((nb + 1, 5))
    suf = np.zeros((nb + 1, 5))
    for b in range(nb):
        r = _merge(
            pre[b, 0],
            pre[b, 1],
            pre[b, 2],
            pre[b, 3],
            pre[b, 4],
            blocks[b, 0],
            blocks[b, 1],
            blocks[b, 2],
            blocks[b, 3],
            blocks[b, 4],
        )
        for k in range(5):
            pre[b + 1, k] = r[k]
    for b in range(nb - 1, -1, -1):
        r = _merge(
            blocks[b, 0],
            blocks[b, 1],
            blocks[b, 2],
            blocks[b, 3],
            blocks[b, 4],
            suf[b + 1, 0],
            suf[b + 1, 1],
            suf[b + 1, 2],
            suf[b + 1, 3],
            suf[b + 1, 4],
        )
        for k in range(5):
            suf[b, k] = r[k]
    return pre, suf


@jit
def _piece(P, a, b, n, offset):  # pragma: no cover - compiled
    """Moments of ``n`` chunk samples with raw sums ``P[b] - P[a]``, in the grid's frame."""
    if n == 0:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    s1 = (P[b, 0] - P[a, 0]) + (P[b, 4] - P[a, 4])
    s2 = (P[b, 1] - P[a, 1]) + (P[b, 5] - P[a, 5])
    delta = s1 / n
    t = delta * s1
    if t <= _FAST * s2:  # as in _window_kurtosis: at most a factor 256 on eps
        s3 = (P[b, 2] - P[a, 2]) + (P[b, 6] - P[a, 6])
        s4 = (P[b, 3] - P[a, 3]) + (P[b, 7] - P[a, 7])
        m2 = s2 - t
        m3 = s3 - delta * (3.0 * s2 - 2.0 * t)
        m4 = s4 - delta * (4.0 * s3 - delta * (6.0 * s2 - 3.0 * t))
    else:
        delta, m2, m3, m4 = _central_dd(P, a, b, n)
    return float(n), offset + delta, m2, m3, m4


@threaded_jit
def _record(
    x,
    a_arr,
    b_arr,
    chunk,
    workers,
    anchor,
    scale,
    pre,
    suf,
    grid,
    kx,
    const,
    out,
    w_lo,
    w_hi,
):  # pragma: no cover - compiled
    """Record-form contribution: ``X = x``, ``s = x[a:b]``, ``c = x[:a] + x[b:]``.

    Chunks and work items as in :func:`_sliding`.

    ``const = (f, g, ends_equal)``: first index whose value differs from ``x[0]``, last
    index whose value differs from ``x[-1]``, and whether ``x[0] == x[-1]``: the complement
    is constant iff ``a <= f``, ``b > g`` and (``a == 0`` or ``b == N`` or ends equal).
    """
    n_all = x.size
    nc = a_arr.size
    nch = (nc + chunk - 1) // chunk
    f_first, g_last, ends_equal = const[0], const[1], const[2]
    for w in range(w_lo, w_hi):
        P = np.empty((1, 8))
        Q = np.empty((1, 8))
        R = np.empty(0, dtype=np.int64)
        tmp = np.empty(_ANCHOR_SAMPLES)
        for ch in range(w, nch, workers):
            c0 = ch * chunk
            c1 = min(c0 + chunk, nc)
            lo = a_arr[c0]
            hi = b_arr[c0]
            for k in range(c0 + 1, c1):
                lo = min(lo, a_arr[k])
                hi = max(hi, b_arr[k])
            g_lo = lo // grid
            g_hi = (hi + grid - 1) // grid
            lo = g_lo * grid
            hi = min(g_hi * grid, n_all)
            if hi - lo + 1 > P.shape[0]:
                P = np.empty((hi - lo + 1, 8))
                Q = np.empty((hi - lo + 1, 8))
                R = np.empty(hi - lo, dtype=np.int64)
            ca, _ = _anchor_scale(x, lo, hi, tmp)
            _prefix_moments(x, lo, hi, ca, scale, P, R)
            _suffix_moments(x, lo, hi, ca, scale, Q)
            offset = (ca - anchor) * scale
            for k in range(c0, c1):
                a = a_arr[k]
                b = b_arr[k]
                if a == 0 and b == n_all:
                    out[k] = np.nan
                    continue
                if a <= f_first and b > g_last and (a == 0 or b == n_all or ends_equal != 0):
                    out[k] = np.nan
                    continue
                # the record before s from forward sums, after s from backward sums: neither
                # holds s, so a shock in s cannot swamp them
                p = _piece(P, np.int64(0), a - lo, a - lo, offset)
                q = _piece(Q, hi - lo, b - lo, hi - b, offset)
                left = _merge(
                    pre[g_lo, 0],
                    pre[g_lo, 1],
                    pre[g_lo, 2],
                    pre[g_lo, 3],
                    pre[g_lo, 4],
                    p[0],
                    p[1],
                    p[2],
                    p[3],
                    p[4],
                )
                right = _merge(
                    q[0],
                    q[1],
                    q[2],
                    q[3],
                    q[4],
                    suf[g_hi, 0],
                    suf[g_hi, 1],
                    suf[g_hi, 2],
                    suf[g_hi, 3],
                    suf[g_hi, 4],
                )
                c = _merge(
                    left[0],
                    left[1],
                    left[2],
                    left[3],
                    left[4],
                    right[0],
                    right[1],
                    right[2],
                    right[3],
                    right[4],
                )
                kc = c[0] * c[4] / (c[2] * c[2])
                out[k] = (kx - kc) / kx


# ---------------------------------------------------------------------------------------
# public API


def _chunk(longest: int, step: int) -> int:
    """Centres per chunk: a span of about max(_SPAN, longest) samples."""
    return max(1, max(_SPAN, int(longest)) // int(step))


def _workers(n_centres: int, chunk: int) -> int:
    return work_items(-(-n_centres // chunk))


def _finish(centre: np.ndarray, values: np.ndarray, return_centres: bool):
    if return_centres:
        return centre, values
    return values


def sliding_kurtosis(
    data: Any,
    *,
    window: Any,
    edges: str = "mirror",
    step: int = 1,
    return_centres: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Pearson kurtosis of the window centred at every centre (paper Eq. 14).

    ``kurt = mean((x - mu)**4) / mean((x - mu)**2)**2`` with biased moments: 3 for Gaussian
    data, the same as ``scipy.stats.kurtosis(x, fisher=False)``.

    Parameters
    ----------
    data : array_like
        The record (float32 and integers are promoted to float64).
    window : int or array_like of int
        Window length: one for all, one per sample of the record, or one per centre
        (``edges="mirror"`` only); at least 3 samples, at most the record.
    edges : {"mirror", "valid"}
        ``"mirror"``: every ``step``-th sample is a centre, and the record is extended at
        both ends by time reversal (``numpy.pad(x, k, mode="symmetric")``); ``"valid"``:
        only the centres whose whole window lies inside the record.
    step : int
        Spacing of the candidate centres (samples 0, step, 2 step, ...).
    return_centres : bool
        Also return the centres.

    Returns
    -------
    ndarray of float64, or (centre, kurtosis)
        One value per centre, in centre order; with ``return_centres`` a tuple of the
        centres' sample indices (int64) and the values. A window whose samples are all
        equal has no kurtosis: NaN.

    Raises
    ------
    AdavarInputError
        Non-numeric, non-finite or too short data, or a bad window, ``edges`` or ``step``.

    Notes
    -----
    The window of ``L`` samples centred at ``p`` holds samples ``p - (L-1)//2`` to
    ``p - (L-1)//2 + L - 1`` (:mod:`adavar.dynamic.windows`). The cost is O(N) whatever the window
    lengths and however they change between centres; see the module notes for the accuracy.
    """
    x, _ = scaled(as_samples(data))  # scale-free: at scale 1, |x - anchor| cannot overflow
    sched = window_schedule(x.size, window, edges=edges, step=step)
    y = read_only(sched.extend(x), np.float64)
    starts = read_only(sched.start, np.int64)
    lengths = read_only(sched.length, np.int64)
    out = np.empty(starts.size)
    chunk = _chunk(int(lengths.max()), sched.step)
    workers = _workers(starts.size, chunk)
    _sliding.run(y.size, workers, y, starts, lengths, 0, chunk, workers, out)
    return _finish(sched.centre, out, return_centres)


def _as_segment(segment: Any, shortest: int) -> int:
    if segment is None:
        raise AdavarInputError(
            "reference='window' needs segment, the number of newest samples of each window "
            "to test (e.g. segment=100)"
        )
    if isinstance(segment, (float, np.floating)) and float(segment).is_integer():
        segment = int(segment)
    if isinstance(segment, bool) or not isinstance(segment, (int, np.integer)):
        raise AdavarInputError(f"segment must be a whole number of samples, got {segment!r}")
    segment = int(segment)
    if segment < 1:
        raise AdavarInputError(f"segment must be at least 1 sample, got {segment}")
    if shortest - segment < MIN_COMPLEMENT:
        raise AdavarInputError(
            f"segment of {segment} samples leaves {shortest - segment} of the shortest window "
            f"({shortest} samples); at least {MIN_COMPLEMENT} must remain: use a segment of at "
            f"most {shortest - MIN_COMPLEMENT} or longer windows"
        )
    return segment


def kurtosis_contribution(
    data: Any,
    *,
    window: Any,
    segment: int | None = None,
    reference: str = "window",
    edges: str = "mirror",
    step: int = 1,
    return_centres: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Sliding kurtosis contribution coefficient ``S = (kurt(X) - kurt(c)) / kurt(X)`` (Eq. 15).

    ``c`` is the reference sequence ``X`` without the segment ``s``. ``S`` is near 0 when
    the segment looks like the rest and grows positive when it holds a shock.

    Parameters
    ----------
    data : array_like
        The record.
    window : int or array_like of int
        Window length(s) per centre, as in :func:`sliding_kurtosis`.
    segment : int, optional
        ``reference="window"`` only (required there): the number ``l`` of newest samples.
    reference : {"window", "record"}
        ``"window"`` (the adaptive controller): ``X`` is the window of ``L`` samples
        centred at each centre (mirror-extended at the record's ends), ``s`` its last
        ``segment`` samples (the leading edge) and ``c`` its first ``L - segment``; at least
        :data:`MIN_COMPLEMENT` samples must remain. ``"record"`` (the paper's section 3
        demonstration, Fig. 7): ``X`` is the whole record, ``s`` the window centred at each
        centre *clipped to the record* (near the ends it is shorter; there is no
        mirroring, since ``X`` is the record itself), and ``c`` the record without ``s``.
    edges : {"mirror", "valid"}
        Which centres: every ``step``-th sample (``"mirror"``), or only those whose whole
        window lies in the record (``"valid"``).
    step : int
        Spacing of the candidate centres.
    return_centres : bool
        Also return the centres.

    Returns
    -------
    ndarray of float64, or (centre, S)
        One value per centre. NaN where ``kurt(X)`` or ``kurt(c)`` is undefined: all of
        ``X``, or all of ``c``, equal (or, record form, ``s`` the whole record).

    Raises
    ------
    AdavarInputError
        Bad data, window, ``edges`` or ``step`` (as :func:`sliding_kurtosis`), an unknown
        ``reference``, a missing or too long ``segment`` with ``reference="window"``, or a
        ``segment`` given with ``reference="record"``.

    Notes
    -----
    O(N) for the whole record in both forms, whatever the window lengths. Record form:
    ``kurt(c)`` comes from the moments of the record before ``s`` and after it, merged
    with Pébay's pairwise formulas, never from subtracting ``s``'s sums from the record's,
    so a shock inside ``s`` does not swamp the quiet rest.
    """
    if reference not in REFERENCES:
        raise AdavarInputError(f"unknown reference {reference!r}: use 'window' or 'record'")
    x, _ = scaled(as_samples(data))  # scale-free: at scale 1, |x - anchor| cannot overflow
    sched = window_schedule(x.size, window, edges=edges, step=step)
    lengths = read_only(sched.length, np.int64)
    out = np.empty(lengths.size)
    chunk = _chunk(int(lengths.max()), sched.step)
    workers = _workers(lengths.size, chunk)
    if reference == "window":
        seg = _as_segment(segment, int(lengths.min()))
        y = read_only(sched.extend(x), np.float64)
        starts = read_only(sched.start, np.int64)
        _sliding.run(2 * y.size, workers, y, starts, lengths, seg, chunk, workers, out)
        return _finish(sched.centre, out, return_centres)
    if segment is not None:
        raise AdavarInputError(
            "segment is only used with reference='window'; with reference='record' the "
            "segment is the window itself: drop segment"
        )
    # in place: each array of the record's length costs its size again (a long record)
    a = sched.centre - (lengths - 1) // 2
    b = a + lengths
    a = read_only(np.clip(a, 0, x.size, out=a), np.int64)
    b = read_only(np.clip(b, 0, x.size, out=b), np.int64)
    differs = x != x[0]
    if not differs.any():  # a constant record has no kurtosis
        out[:] = np.nan
        return _finish(sched.centre, out, return_centres)
    first = int(differs.argmax())
    del differs
    last = x.size - 1 - int((x[::-1] != x[-1]).argmax())
    anchor = float(np.median(x[:: max(1, x.size // _ANCHOR_SAMPLES)]))
    # max |x - anchor|, each difference rounded as it would be (rounding is monotonic)
    big = max(abs(float(x.max()) - anchor), abs(anchor - float(x.min())))
    scale = _power_of_two_scale(big)
    x = read_only(x, np.float64)
    blocks = np.zeros((-(-x.size // _GRID), 5))
    per, items = grouped_items(blocks.shape[0])
    _grid_blocks.run(2 * x.size, items, x, anchor, scale, _GRID, per, blocks)
    pre, suf = _grid_chain(blocks)
    kx = pre[-1, 0] * pre[-1, 4] / pre[-1, 2] ** 2
    const = read_only(np.array([first, last, int(x[0] == x[-1])], dtype=np.int64))
    work = 2 * x.size + 8 * a.size
    _record.run(
        work, workers, x, a, b, chunk, workers, anchor, scale, pre, suf, _GRID, kx, const, out
    )
    return _finish(sched.centre, out, return_centres)

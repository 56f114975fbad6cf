"""Compiled sums of squared differences that leave out the terms touching a missing sample.

The kernels of :mod:`adavar.gaps`. They read the anchored phase of a record whose missing
samples were filled with finite values (:mod:`adavar.differences`) and, term by term, a
*keep test* in O(1):

``cnt[i + w] - cnt[i] + sum_k pm[i + k m] == 0``

``cnt`` is a prefix count of missing samples and ``pm`` a 0/1 array of missing phase
points; rate data use ``cnt`` (a window of ``w`` rate samples) with ``pm`` all zeros, phase
data of the Allan and Hadamard statistics use ``pm`` (the points ``i + k m`` only) with
``w = 0``, and the modified statistics use ``cnt`` over their whole window. A kept term
involves no filled value, so it is the exact difference of the true record; the others
cost their arithmetic and are not summed. Every kernel returns the sums and the number of
terms kept, per averaging factor.
"""

from __future__ import annotations

import numpy as np

from adavar._jit import jit
from adavar._kernels.double_double import two_sum
from adavar.differences import (
    SUPERBLOCK,
    anchor_combo,
    difference_combo,
    fill_second_differences,
    segment_end,
)

__all__ = [
    "fill_missing",
    "fit_moments",
    "kept_modified_sums",
    "kept_overlapping_sums",
    "kept_strided_sums",
    "lag1_moments",
]

_MOD_CHUNK = 1 << 14


@jit(fastmath=True)
def _rate_kept2(r, c, lo, hi, m, cnt, w):  # pragma: no cover - compiled
    x0 = r[lo:hi]
    x1 = r[lo + m : hi + m]
    x2 = r[lo + 2 * m : hi + 2 * m]
    a = cnt[lo:hi]
    b = cnt[lo + w : hi + w]
    acc = 0.0
    n = 0
    for k in range(hi - lo):
        v = c + ((x0[k] + x2[k]) - 2.0 * x1[k])
        keep = a[k] == b[k]
        acc += v * v if keep else 0.0
        n += 1 if keep else 0
    return acc, n


@jit(fastmath=True)
def _rate_kept3(r, c, lo, hi, m, cnt, w):  # pragma: no cover - compiled
    x0 = r[lo:hi]
    x1 = r[lo + m : hi + m]
    x2 = r[lo + 2 * m : hi + 2 * m]
    x3 = r[lo + 3 * m : hi + 3 * m]
    a = cnt[lo:hi]
    b = cnt[lo + w : hi + w]
    acc = 0.0
    n = 0
    for k in range(hi - lo):
        v = c + ((x3[k] - x0[k]) + 3.0 * (x1[k] - x2[k]))
        keep = a[k] == b[k]
        acc += v * v if keep else 0.0
        n += 1 if keep else 0
    return acc, n


@jit(fastmath=True)
def _phase_kept2(r, c, lo, hi, m, pm):  # pragma: no cover - compiled
    x0 = r[lo:hi]
    x1 = r[lo + m : hi + m]
    x2 = r[lo + 2 * m : hi + 2 * m]
    p0 = pm[lo:hi]
    p1 = pm[lo + m : hi + m]
    p2 = pm[lo + 2 * m : hi + 2 * m]
    acc = 0.0
    n = 0
    for k in range(hi - lo):
        v = c + ((x0[k] + x2[k]) - 2.0 * x1[k])
        keep = (p0[k] + p1[k] + p2[k]) == 0
        acc += v * v if keep else 0.0
        n += 1 if keep else 0
    return acc, n


@jit(fastmath=True)
def _phase_kept3(r, c, lo, hi, m, pm):  # pragma: no cover - compiled
    x0 = r[lo:hi]
    x1 = r[lo + m : hi + m]
    x2 = r[lo + 2 * m : hi + 2 * m]
    x3 = r[lo + 3 * m : hi + 3 * m]
    p0 = pm[lo:hi]
    p1 = pm[lo + m : hi + m]
    p2 = pm[lo + 2 * m : hi + 2 * m]
    p3 = pm[lo + 3 * m : hi + 3 * m]
    acc = 0.0
    n = 0
    for k in range(hi - lo):
        v = c + ((x3[k] - x0[k]) + 3.0 * (x1[k] - x2[k]))
        keep = ((p0[k] + p1[k]) + (p2[k] + p3[k])) == 0
        acc += v * v if keep else 0.0
        n += 1 if keep else 0
    return acc, n


@jit
def kept_overlapping_sums(r, hh, hl, ms, counts, coefs, cnt, ws, pm):  # pragma: no cover
    """Overlapping sums ``sum_i keep_i (sum_k coefs[k] S[i + k m])^2``, ``i < counts[t]``.

    ``coefs`` of order 2 or 3. ``ws[t] > 0``: the prefix test over ``ws[t]`` samples
    (rate data); ``ws[t] == 0``: the missing-point test on the term's points (phase
    data). Fused over taus as :func:`adavar.differences.overlapping_sums_kernel`: each
    superblock of ``i`` is run for every tau while its part of ``r`` is in cache.
    Returns ``(sums, kept)``.
    """
    nt = ms.size
    kp = coefs.size
    imax = 0
    for t in range(nt):
        imax = max(imax, counts[t])
    sums = np.zeros(nt)
    kept = np.zeros(nt, dtype=np.int64)
    for b0 in range(0, imax, SUPERBLOCK):
        b1 = b0 + SUPERBLOCK
        for t in range(nt):
            hi = min(b1, counts[t])
            if b0 >= hi:
                continue
            m = ms[t]
            w = ws[t]
            acc = 0.0
            n = 0
            i = b0
            while i < hi:
                e = segment_end(i, hi, m, kp)
                c = anchor_combo(hh, hl, i, m, coefs)
                if w > 0:
                    if kp == 3:
                        a, k = _rate_kept2(r, c, i, e, m, cnt, w)
                    else:
                        a, k = _rate_kept3(r, c, i, e, m, cnt, w)
                elif kp == 3:
                    a, k = _phase_kept2(r, c, i, e, m, pm)
                else:
                    a, k = _phase_kept3(r, c, i, e, m, pm)
                acc += a
                n += k
                i = e
            sums[t] += acc
            kept[t] += n
    return sums, kept


@jit
def kept_strided_sums(r, hh, hl, ms, counts, coefs, cnt, ws, pm):  # pragma: no cover
    """Non-overlapping version: terms at ``i = 0, m, 2m, ...`` (``counts[t]`` of them)."""
    nt = ms.size
    kp = coefs.size
    sums = np.zeros(nt)
    kept = np.zeros(nt, dtype=np.int64)
    for t in range(nt):
        m = ms[t]
        w = ws[t]
        acc = 0.0
        n = 0
        for q in range(counts[t]):
            i = q * m
            bad = cnt[i + w] - cnt[i]
            for k in range(kp):
                bad += pm[i + k * m]
            if bad == 0:
                v = difference_combo(r, hh, hl, i, m, coefs)
                acc += v * v
                n += 1
        sums[t] = acc
        kept[t] = n
    return sums, kept


@jit
def kept_modified_sums(r, hh, hl, ms, counts, cnt, ws):  # pragma: no cover - compiled
    """MVAR numerators ``sum_j keep_j (sum_{i=j}^{j+m-1} d_m[i])^2``, ``j < counts[t]``.

    The m-sum slides along ``j`` with a compensated running total over every ``j`` (kept or
    not: the filled values are finite), as in :func:`adavar.differences.modified_sums_kernel`;
    only the kept ones (``cnt[j + ws[t]] == cnt[j]``) are summed.
    """
    nt = ms.size
    sums = np.zeros(nt)
    kept = np.zeros(nt, dtype=np.int64)
    for t in range(nt):
        m = ms[t]
        w = ws[t]
        count = counts[t]
        first = np.empty(m)
        fill_second_differences(r, hh, hl, m, 0, m, first)
        s = 0.0
        c = 0.0
        for k in range(m):
            s, e = two_sum(s, first[k])
            c += e
        acc = 0.0
        n = 0
        if cnt[w] == cnt[0]:
            total = s + c
            acc = total * total
            n = 1
        enter = np.empty(_MOD_CHUNK)
        leave = np.empty(_MOD_CHUNK)
        j = 1
        while j < count:
            size = min(_MOD_CHUNK, count - j)
            fill_second_differences(r, hh, hl, m, j + m - 1, j + m - 1 + size, enter)
            fill_second_differences(r, hh, hl, m, j - 1, j - 1 + size, leave)
            for q in range(size):
                s, e = two_sum(s, enter[q])
                c += e
                s, e = two_sum(s, -leave[q])
                c += e
                if cnt[j + q + w] == cnt[j + q]:
                    v = s + c
                    acc += v * v
                    n += 1
            j += size
        sums[t] = acc
        kept[t] = n
    return sums, kept


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
    k0 = k1 = k2 = k3 = False  # ... and whether they are kept
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

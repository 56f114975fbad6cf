"""Compiled kernels of :mod:`adavar.stats.total_family`: MTOT/HTOT and PVAR sums in O(N) per tau.

MTOT and HTOT (NIST SP 1065, 5.2.12-5.2.14) share one inner sum. For every subsequence
``x[n : n + 3m]`` (phase for MTOT, rate for HTOT) the half-average slope ``s_n`` is removed,
``y = x - s_n k``, ``y`` is extended by uninverted even reflection to ``9m`` points and the
``6m`` second differences of ``m``-sums ``D_j`` are squared and summed. Done directly that is
O(m) per subsequence and O(N m) per tau. Here it is O(N):

* The reflected sequence is one period of the even ``6m``-periodic extension of ``y``, so in
  terms of the prefix sums ``Y(c) = y[0] + ... + y[c-1]`` every ``D_j`` is a third
  difference (lag ``m``) of the odd extension of ``Y`` about one of the two junctions, and
  ``sum_j D_j**2 = J(Y) + J(V) - 2 D_mid**2``, ``V`` the prefix sums of ``y`` reversed,
  ``D_mid = Y(3m) - 3 Y(2m) + 3 Y(m)`` and

  ``J(Y) = 2 sum_{r=0}^{m} [Y(r) + G(m - r)]**2 + sum_{p=1}^{m-1} [F(p) + F(m - p)]**2``

  with ``G(q) = 3 Y(q) - 3 Y(q + m) + Y(q + 2m)``, ``F(p) = Y(p + m) - 3 Y(p)``.
* ``Y_n(c) = P[n + c] - P[n] - s_n c (c - 1) / 2`` (``P`` the prefix sums of the record), so
  each square expands into sliding sums of ``P``-combinations, of their squares and of their
  products with a quadratic weight (prefix sums, O(1) per ``n``), and one cross term
  ``sum_r A[n + r] B[n + m - r]`` whose index sum moves with ``n``. That one is summed over
  ``n`` first: for fixed ``i = n + r`` the partner indices ``2n + m - i`` step by two, a
  stride-2 prefix sum (O(1) per ``i``).
* ``J(V)`` is ``J`` of the reversed record.

Accuracy: the expansion trades the per-subsequence detrending for cancellation between
sums, so the record is cut into blocks of ``3m`` subsequences and each block is computed
from its own span of ``6m - 1`` points, re-anchored at its start: for MTOT the phase
integrated in double-double from the rate less a local sample median (MTOT is blind to a
phase offset and a frequency offset), for HTOT the rate less a local line (it is blind to a
frequency offset and drift), subtracted exactly. The terms then cancel by about the square
of the block-to-subsequence length ratio, not by the record's dynamic range (blocks of 64 at
m = 1 lose 8 digits after a level step); the block sums are added with compensation.
Measured against the long-double definition: a few ulps with an offset of 1e9 or 2.5e12,
a level step of 1e6, a spike of 1e8 or a drift of 1e4 noise levels per sample. PVAR
(Vernotte et al. 2016) is one linear functional per term, computed the same way from
block-local phase (blocks of ``max(2m, 64)`` terms).
"""

from __future__ import annotations

import numpy as np

from adavar._kernels._jit import jit
from adavar._kernels.double_double import fma, two_sum
from adavar._kernels.window_avar import MEDIAN_SAMPLES, sample_median

__all__ = ["MIN_BLOCK", "left_sums", "pvar_sums"]

#: fewest PVAR terms per block: below it the per-block set-up dominates (PVAR's terms are
#: single linear functionals: longer blocks cost no digits worth measuring)
MIN_BLOCK = 64


@jit
def _local_prefix(u, start, count, integrate, detrend, tmp, p):  # pragma: no cover - compiled
    """``p[c]``, ``c = 0..count``: prefix sums of the local series of ``count`` values.

    ``integrate``: the series is the phase ``x[k] = sum_{l<k} (u[start + l] - c)`` (uses
    ``u[start : start + count - 1]``); else the rate ``x[k] = u[start + k] - c``, less
    ``d (k - k0)`` too with ``detrend`` (a line through the medians of the first and last
    thirds: HTOT is blind to a linear frequency drift, and a drift of 10 noise levels per
    sample otherwise costs 8 digits). ``c`` is the median of a few samples (a data value,
    so each ``u - c`` rounds relative to the residual); the line is subtracted in
    double-double (an exact product), and both sums run in double-double; ``p`` gets them
    rounded.
    """
    stop = start + (count - 1 if integrate else count)
    stop = max(stop, start + 1)
    c = sample_median(u, start, stop, tmp)
    d = 0.0
    k0 = 0.0
    if detrend and not integrate and count >= 6:
        third = count // 3
        c = sample_median(u, start, start + third, tmp)
        c1 = sample_median(u, stop - third, stop, tmp)
        k0 = float((third - 1) // 2)  # about where the median of a monotone third sits
        d = (c1 - c) / float(count - third)
        c += _residual_median(u, start, count, c, d, k0, tmp)  # the line's offset
    xh = 0.0
    xl = 0.0
    ph = 0.0
    pl = 0.0
    p[0] = 0.0
    for k in range(count):
        if not integrate:
            xh, xl = two_sum(u[start + k], -c)
            if d != 0.0:
                lh = d * (k - k0)
                ll = fma(d, k - k0, -lh)
                s, e = two_sum(xh, -lh)
                e += xl - ll
                xh = s + e
                xl = e - (xh - s)
        # p += x (double-double)
        s, e = two_sum(ph, xh)
        e += pl + xl
        ph = s + e
        pl = e - (ph - s)
        p[k + 1] = ph
        if integrate and k < count - 1:
            y, q = two_sum(u[start + k], -c)
            s, e = two_sum(xh, y)
            e += xl + q
            xh = s + e
            xl = e - (xh - s)


@jit
def _residual_median(u, start, count, c, d, k0, tmp):  # pragma: no cover - compiled
    """Median of ``u[start + k] - c - d (k - k0)`` at up to ``tmp.size`` spread ``k``.

    Rounded residuals are good enough: the value only re-centres the line, whose exact
    subtraction is what keeps the statistic unchanged.
    """
    n = min(tmp.size, count)
    for i in range(n):
        k = (i * (count - 1)) // max(n - 1, 1)
        v = (u[start + k] - c) - d * (k - k0)
        j = i
        while j > 0 and tmp[j - 1] > v:  # insertion sort: n is small
            tmp[j] = tmp[j - 1]
            j -= 1
        tmp[j] = v
    return tmp[(n - 1) // 2]


@jit
def _moments(f, first, last, origin, out):  # pragma: no cover - compiled
    """Prefix sums over ``f[first..last]`` of ``f``, ``d f``, ``d**2 f`` and ``f**2``.

    ``d = i - origin``; ``out[k, i + 1 - first]`` holds the sum over ``first .. i``, and
    ``out[:, 0] = 0``.
    """
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    sq = 0.0
    out[0, 0] = 0.0
    out[1, 0] = 0.0
    out[2, 0] = 0.0
    out[3, 0] = 0.0
    for i in range(first, last + 1):
        v = f[i]
        d = float(i - origin)
        s0 += v
        s1 += d * v
        s2 += d * d * v
        sq += v * v
        k = i + 1 - first
        out[0, k] = s0
        out[1, k] = s1
        out[2, k] = s2
        out[3, k] = sq


@jit
def _weighted(mom, first, a, b, t, origin, c0, c1, c2):  # pragma: no cover - compiled
    """``sum_{i=a}^{b} w(i - t) f[i]``, ``w(z) = c0 + c1 z + c2 z**2``, from ``_moments``."""
    e = float(origin - t)
    b0 = c0 + c1 * e + c2 * e * e
    b1 = c1 + 2.0 * c2 * e
    lo = a - first
    hi = b + 1 - first
    return (
        b0 * (mom[0, hi] - mom[0, lo])
        + b1 * (mom[1, hi] - mom[1, lo])
        + c2 * (mom[2, hi] - mom[2, lo])
    )


@jit
def _stride2(f, first, last, out):  # pragma: no cover - compiled
    """``out[j + 2 - first] = f[j] + f[j - 2] + ...`` (from ``first``); ``out[0] = out[1] = 0``."""
    out[0] = 0.0
    out[1] = 0.0
    for j in range(first, last + 1):
        k = j - first + 2
        out[k] = f[j] + out[k - 2]


@jit
def _quadratic(v0, v1, v2):  # pragma: no cover - compiled
    """Coefficients of the quadratic through ``(0, v0), (1, v1), (2, v2)``."""
    c2 = 0.5 * (v2 - 2.0 * v1 + v0)
    return v0, v1 - v0 - c2, c2


@jit
def _q(c):  # pragma: no cover - compiled
    return 0.5 * c * (c - 1.0)


@jit
def _psi1(r, m):  # pragma: no cover - compiled
    """Detrend weight of ``Y(r) + G(m - r)``."""
    return _q(r) + 3.0 * _q(m - r) - 3.0 * _q(2.0 * m - r) + _q(3.0 * m - r)


@jit
def _psi2(p, m):  # pragma: no cover - compiled
    """Detrend weight of ``F(p) + F(m - p)``."""
    return _q(p + m) - 3.0 * _q(p) + _q(2.0 * m - p) - 3.0 * _q(m - p)


@jit
def _add(s, c, v):  # pragma: no cover - compiled
    """Neumaier step: ``(s, c) + v``."""
    t, e = two_sum(s, v)
    return t, c + e


@jit
def left_sums(u, m, integrate, middle, block):  # pragma: no cover - compiled
    """``sum_n J(Y_n)`` and (``middle``) ``sum_n D_mid**2`` over every subsequence.

    ``u``: rate samples (float64, contiguous); the series is their integral (``integrate``,
    MTOT: ``u.size + 1`` phase points) or the samples themselves (HTOT). ``m >= 1``,
    ``block`` subsequences per block. Returns ``(J sum, middle sum)``.
    """
    L = 3 * m
    h = L // 2
    nx = u.size + 1 if integrate else u.size
    ns = nx - L + 1
    fm = float(m)
    # the detrend weights as quadratics in r (or p), and their sums
    a0, a1, a2 = _quadratic(_psi1(0.0, fm), _psi1(1.0, fm), _psi1(2.0, fm))
    b0, b1, b2 = _quadratic(_psi1(fm, fm), _psi1(fm - 1.0, fm), _psi1(fm - 2.0, fm))
    g0, g1, g2 = _quadratic(_psi2(0.0, fm), _psi2(1.0, fm), _psi2(2.0, fm))
    s1 = 0.0
    s1q = 0.0
    for r in range(m + 1):
        w = _psi1(float(r), fm)
        s1 += w
        s1q += w * w
    s2 = 0.0
    s2q = 0.0
    for p in range(1, m):
        w = _psi2(float(p), fm)
        s2 += w
        s2q += w * w
    slope_norm = 1.0 / (float(h) * float(L - h))
    size = min(block, ns) + L + 2  # the span's prefix sums
    terms = min(block, ns) + m + 2  # the indices of G and F a term reads, and one
    pp = np.empty(size)
    gp = np.empty(terms)
    fp = np.empty(terms)
    mom_p = np.empty((4, terms))
    mom_g = np.empty((4, terms))
    mom_f = np.empty((4, terms))
    e2g = np.empty(terms + 2)
    e2f = np.empty(terms + 2)
    tmp = np.empty(MEDIAN_SAMPLES)
    zero = np.int64(0)  # typed: a literal 0 compiles the callees a second time
    tot = 0.0
    tot_c = 0.0
    mid = 0.0
    mid_c = 0.0
    for n0 in range(0, ns, block):
        nb = min(block, ns - n0)
        count = nb + L - 1
        _local_prefix(u, n0, count, integrate, np.bool_(True), tmp, pp)
        top = nb - 1 + m  # last index of G and F that a term reads
        for i in range(top + 1):
            gp[i] = 3.0 * pp[i] - 3.0 * pp[i + m] + pp[i + 2 * m]
            fp[i] = pp[i + m] - 3.0 * pp[i]
        origin = nb // 2
        _moments(pp, zero, top, origin, mom_p)
        _moments(gp, zero, top, origin, mom_g)
        _moments(fp, zero, top, origin, mom_f)
        for t in range(nb):
            pt = pp[t]
            s = ((pp[t + L] - pp[t + L - h]) - (pp[t + h] - pt)) * slope_norm
            lo = t
            hi = t + m + 1
            sa = mom_p[0, hi] - mom_p[0, lo]
            sb = mom_g[0, hi] - mom_g[0, lo]
            qa = mom_p[3, hi] - mom_p[3, lo]
            qb = mom_g[3, hi] - mom_g[3, lo]
            wa = _weighted(mom_p, zero, t, t + m, t, origin, a0, a1, a2)
            wb = _weighted(mom_g, zero, t, t + m, t, origin, b0, b1, b2)
            c = -2.0 * pt
            t1 = qa + qb + (m + 1) * c * c + s * s * s1q
            t1 += 2.0 * c * (sa + sb) - 2.0 * s * (wa + wb) - 2.0 * c * s * s1
            t2 = 0.0
            if m > 1:
                sf = mom_f[0, t + m] - mom_f[0, t + 1]
                qf = mom_f[3, t + m] - mom_f[3, t + 1]
                wf = _weighted(mom_f, zero, t + 1, t + m - 1, t, origin, g0, g1, g2)
                c2 = 4.0 * pt
                t2 = 2.0 * qf + (m - 1) * c2 * c2 + s * s * s2q
                t2 += 4.0 * c2 * sf - 4.0 * s * wf - 2.0 * c2 * s * s2
            tot, tot_c = _add(tot, tot_c, 2.0 * t1 + t2)
            if middle:
                d = (pp[t + L] - pt) - 3.0 * (pp[t + 2 * m] - pp[t + m])
                mid, mid_c = _add(mid, mid_c, d * d)
        # the cross terms, summed over the block's subsequences (stride-2 prefix sums)
        _stride2(gp, zero, top, e2g)
        cross = 0.0
        for i in range(nb + m):
            tl = max(0, i - m)
            th = min(nb - 1, i)
            jl = 2 * tl + m - i
            jh = 2 * th + m - i
            cross += pp[i] * (e2g[jh + 2] - e2g[jl])
        tot, tot_c = _add(tot, tot_c, 4.0 * cross)
        if m > 1:
            _stride2(fp, zero, top, e2f)
            cross = 0.0
            for i in range(1, nb + m - 1):
                tl = max(0, i - m + 1)
                th = min(nb - 1, i - 1)
                if tl > th:
                    continue
                jl = 2 * tl + m - i
                jh = 2 * th + m - i
                cross += fp[i] * (e2f[jh + 2] - e2f[jl])
            tot, tot_c = _add(tot, tot_c, 2.0 * cross)
    return tot + tot_c, mid + mid_c


@jit
def pvar_sums(u, m, block):  # pragma: no cover - compiled
    """``sum_i S_i**2``, ``S_i = sum_{k<m} ((m-1)/2 - k) (x[i+k] - x[i+k+m])`` (``m >= 2``).

    ``x`` is the integral of ``u`` (``u.size + 1`` phase points); ``i = 0 .. N - 2m - 1``
    with ``N`` phase points (Vernotte et al. 2016; allantools and SigmaTheta).
    """
    nx = u.size + 1
    count_terms = nx - 2 * m
    size = min(block, count_terms) + 2 * m + 2
    pp = np.empty(size)
    d = np.empty(size)
    mom = np.empty((4, size))
    tmp = np.empty(MEDIAN_SAMPLES)
    zero = np.int64(0)  # typed: a literal 0 compiles the callees a second time
    half = 0.5 * (m - 1)
    tot = 0.0
    tot_c = 0.0
    for i0 in range(0, count_terms, block):
        nb = min(block, count_terms - i0)
        count = nb + 2 * m - 1
        # the local phase is the prefix sum of the local rate: pp[k] = x[i0 + k] - line
        _local_prefix(u, i0, count - 1, np.bool_(False), np.bool_(False), tmp, pp)
        top = nb + m - 2
        for j in range(top + 1):
            d[j] = pp[j] - pp[j + m]
        origin = nb // 2
        _moments(d, zero, top, origin, mom)
        for t in range(nb):
            sd = mom[0, t + m] - mom[0, t]
            sk = (mom[1, t + m] - mom[1, t]) + (origin - t) * sd
            v = half * sd - sk
            tot, tot_c = _add(tot, tot_c, v * v)
    return tot + tot_c

"""Compiled kernels of the Theo family (:mod:`adavar.stats.theo_family`).

Theo1 at an even averaging factor ``m = 2k`` is (SP 1065 Eq. 30, with ``j = k - delta``)

    S(m) = sum_{j=1}^{k} (1/j) T(m, j),
    T(m, j) = sum_{i=0}^{N-m-1} [x_i - x_{i+j} - x_{i+m-j} + x_{i+m}]^2.

Two kernels compute it.

:func:`theo1_sums` (exact, ``O(N m)`` per factor) writes the term as ``D_j(i + m - j) -
D_j(i)`` with ``D_j(k) = x[k+j] - x[k] = u[k] + ... + u[k+j-1]``, a window sum of the
increments. It walks ``j = 1, 2, ...`` once, growing ``D_j`` from ``D_{j-1}`` by one exact
addition per element (kept as a double-double), and adds the ``j`` term of every requested
``m`` from the same array: a frequency offset cancels exactly, the result is a few ulps of
the sum itself. It costs ``sum_m (N - m) m / 2`` multiply-adds.

:func:`theo1_fast_sums` (all factors, ``O(N)`` per factor; the decomposition of J. A. Lewis,
"An algorithm for the fast computation of all-tau Theo1", IEEE TUFFC 2020, re-derived here)
expands the square into lag products of the phase. With ``R_L = sum_i x_i x_{i+L}`` (the
whole record), ``P`` the prefix sums of ``x^2``, ``Hx(m, L)`` / ``Hy(m, L)`` the lag-``L``
products inside the first / last ``m`` points and ``Cx(k, v)`` / ``Cy(k, v)`` the products
``x_{c-v} x_{c+v}`` centred on the first / last ``k`` points,

    T(m, j) = c(m) + F_{k-j}(k) + E_j(m) + E_{m-j}(m),
    c(m)     = P[N-m] + P[N] - P[m] + 2 R_m,
    E_L(m)   = P[N-L] - P[L] - 4 R_L + 2 (Hx(m, L) + Hy(m, L)),
    F_v(k)   = 2 R_{2v} - 2 (Cx(k, v) + Cy(k, v)).

Stepping ``k`` to ``k + 1`` adds four products to every ``E_L`` and two to every ``F_v``,
so all factors up to ``m`` cost ``sum_L (N - L)`` products for ``R`` (blocked, vectorised)
plus about ``1.25 m^2`` for the updates and ``k`` additions per factor evaluated.

The expansion cancels: the products are of size ``max|x|^2`` while ``T`` may be far
smaller (a random walk of frequency, a drift). So the phase is first centred (the
least-squares line removed, to which Theo1 is blind, in double-double from the increments:
a frequency offset never enters), then every product is formed exactly (``fma``) and every
sum kept in double-double; ``T(m, j) >= 0`` is rounded to a double only once complete and
the ``1/j`` weights applied to those. The error of ``S(m)`` is then below ``H_k 2^-98 (N +
2)^2 max|x|^2 + 2^-42 S(m)`` (``H_k`` the harmonic number), which the caller checks factor
by factor against ``S(m)`` itself, falling back to :func:`theo1_sums` where it is not small
enough. Every inner loop is a helper over slices: with offset indices LLVM does not
vectorise them (8x slower).
"""

from __future__ import annotations

import numpy as np

from adavar._kernels._jit import jit
from adavar._kernels.double_double import fast_two_sum, fma, two_sum

__all__ = ["centred_phase", "theo1_fast_sums", "theo1_sums"]

#: lags per tile of the lag-product pass: two double-double tiles stay in L1
_LAG_TILE = 512
#: terms per plain (reassociated) partial sum of the weighted ``T(m, j)``
_SUM_BLOCK = 256


# ---------------------------------------------------------------------------------------
# exact: window sums of the increments


@jit
def _lagged_square_sum(dh, dl, lag, count):  # pragma: no cover - compiled
    """``sum_{i < count} ((dh[i+lag] - dh[i]) + (dl[i+lag] - dl[i]))**2``.

    Four independent accumulators: the additions stay in order within each (no fast-math,
    which could regroup the double-double difference), yet do not wait on one another.
    """
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    a3 = 0.0
    blocks = count // 4
    for b in range(blocks):
        i = 4 * b
        d0 = (dh[i + lag] - dh[i]) + (dl[i + lag] - dl[i])
        d1 = (dh[i + 1 + lag] - dh[i + 1]) + (dl[i + 1 + lag] - dl[i + 1])
        d2 = (dh[i + 2 + lag] - dh[i + 2]) + (dl[i + 2 + lag] - dl[i + 2])
        d3 = (dh[i + 3 + lag] - dh[i + 3]) + (dl[i + 3 + lag] - dl[i + 3])
        a0 += d0 * d0
        a1 += d1 * d1
        a2 += d2 * d2
        a3 += d3 * d3
    for i in range(4 * blocks, count):
        d = (dh[i + lag] - dh[i]) + (dl[i + lag] - dl[i])
        a0 += d * d
    return (a0 + a1) + (a2 + a3)


@jit
def theo1_sums(u, ms, out):  # pragma: no cover - compiled
    """Add ``S(m)`` (the Theo1 double sum, unnormalised) of every even ``m`` to ``out``.

    ``u``: the ``N - 1`` increments of the phase; ``ms``: even factors, ``2 <= m <= N - 1``.
    """
    n = u.size
    n_points = n + 1
    hmax = 0
    for idx in range(ms.size):
        hmax = max(hmax, ms[idx] // 2)
    dh = np.zeros(n)
    dl = np.zeros(n)
    for j in range(1, hmax + 1):
        # D_j(k) = D_{j-1}(k) + u[k + j - 1] for k = 0 .. n - j; the rounding goes to dl
        for k in range(n - j + 1):
            s, e = two_sum(dh[k], u[k + j - 1])
            dh[k] = s
            dl[k] += e
        w = 1.0 / j
        for idx in range(ms.size):
            m = ms[idx]
            if 2 * j <= m:
                out[idx] += w * _lagged_square_sum(dh, dl, m - j, n_points - m)


# ---------------------------------------------------------------------------------------
# fast: lag products of the centred phase


# plain ``jit`` (LLVM inlines them): as fast as ``inline="always"``, and compiles faster
@jit
def _prod(ah, al, bh, bl):  # pragma: no cover - compiled
    """``(ah + al)(bh + bl)`` as (high, low): the high product exact, the rest ~2^-105."""
    p = ah * bh
    return p, fma(ah, bh, -p) + (ah * bl + al * bh)


@jit
def _add(ah, al, bh, bl):  # pragma: no cover - compiled
    """Double-double sum; absolute error below ``2^-104 (|a| + |b|)``."""
    s, e = two_sum(ah, bh)
    return fast_two_sum(s, e + (al + bl))


@jit
def centred_phase(u, c, xh, xl):  # pragma: no cover - compiled
    """The phase of ``u``, less its least-squares line, in double-double.

    ``x[k] = sum_{t<k} (u[t] - c) - (a + b (k - (N-1)/2))`` with ``a``, ``b`` fitted to it:
    ``u[t] - c`` is split exactly (two-sum), so an offset ``c`` never costs a digit, and
    any line (Theo1 ignores it) keeps the values, hence the lag products, small. Returns the
    largest magnitude met on the way (it bounds the rounding of ``x``).
    """
    n = u.size + 1
    sh = 0.0
    sl = 0.0
    xh[0] = 0.0
    xl[0] = 0.0
    big = 0.0
    for k in range(1, n):
        dh, dl = two_sum(u[k - 1], -c)
        sh, sl = _add(sh, sl, dh, dl)
        xh[k] = sh
        xl[k] = sl
        big = max(big, abs(sh))
    mid = 0.5 * (n - 1)
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    for k in range(n):
        t = k - mid
        s0 += xh[k]
        s1 += t * xh[k]
        s2 += t * t
    a = s0 / n
    b = s1 / s2 if s2 > 0 else 0.0
    for k in range(n):
        ph, pl = _prod(b, 0.0, k - mid, 0.0)  # k - mid is exact (a multiple of 1/2)
        hh, hl = _add(xh[k], xl[k], -ph, -pl)
        xh[k], xl[k] = _add(hh, hl, -a, 0.0)
        big = max(big, abs(ph), abs(hh))
    return max(big, abs(a))


@jit
def _lag_products(xh, xl, lag_max, rh, rl):  # pragma: no cover - compiled
    """``R_L = sum_i x_i x_{i+L}`` for ``L = 0 .. lag_max``, in tiles of lags.

    The inner loop runs over the lags of a tile (independent accumulators in a local
    array, so it vectorises without reassociating any sum); it reads slices, whose plain
    indices let the compiler vectorise it (offset indices do not).
    """
    n = xh.size
    th = np.zeros(_LAG_TILE)
    tl = np.zeros(_LAG_TILE)
    for l0 in range(0, lag_max + 1, _LAG_TILE):
        l1 = min(l0 + _LAG_TILE, lag_max + 1)
        th[:] = 0.0
        tl[:] = 0.0
        for i in range(n - l0):
            top = min(l1, n - i) - l0
            ah = xh[i]
            al = xl[i]
            bh = xh[i + l0 : i + l0 + top]
            bl = xl[i + l0 : i + l0 + top]
            for t in range(top):
                p, e = _prod(ah, al, bh[t], bl[t])
                th[t], tl[t] = _add(th[t], tl[t], p, e)
        rh[l0:l1] = th[: l1 - l0]
        rl[l0:l1] = tl[: l1 - l0]


@jit(fastmath={"reassoc", "nsz"})
def _plain_sum(a):  # pragma: no cover - compiled
    """``sum(a)`` in any order (error below ``a.size eps sum|a|``), vectorised."""
    s = 0.0
    for i in range(a.size):
        s += a[i]
    return s


@jit
def _blocked_sum(a, count):  # pragma: no cover - compiled
    """``sum(a[:count])``: plain sums of ``_SUM_BLOCK`` terms, added exactly."""
    sh = 0.0
    sl = 0.0
    for b in range(0, count, _SUM_BLOCK):
        sh, e = two_sum(sh, _plain_sum(a[b : min(b + _SUM_BLOCK, count)]))
        sl += e
    return sh + sl


@jit
def _grow_heads(
    eh, el, y1h, y1l, y0h, y0l, x1h, x1l, x0h, x0l, ah, al, bh, bl, ch, cl, dh, dl
):  # pragma: no cover - compiled
    """``E[t] += y1[t] a + y0[t] b + x1[t] c + x0[t] d`` (double-double, slices)."""
    for t in range(eh.size):
        qh, ql = _prod(y1h[t], y1l[t], ah, al)
        p, e = _prod(y0h[t], y0l[t], bh, bl)
        qh, r = two_sum(qh, p)
        ql += r + e
        p, e = _prod(x1h[t], x1l[t], ch, cl)
        qh, r = two_sum(qh, p)
        ql += r + e
        p, e = _prod(x0h[t], x0l[t], dh, dl)
        qh, r = two_sum(qh, p)
        ql += r + e
        eh[t], el[t] = _add(eh[t], el[t], qh, ql)


@jit
def _grow_centres(fh, fl, ah, al, bh, bl, ch, cl, dh, dl):  # pragma: no cover - compiled
    """``F[v] -= 2 (a[v] b[v] + c[v] d[v])`` (double-double, slices)."""
    for v in range(fh.size):
        qh, ql = _prod(ah[v], al[v], bh[v], bl[v])
        p, e = _prod(ch[v], cl[v], dh[v], dl[v])
        qh, r = two_sum(qh, p)
        ql += r + e
        fh[v], fl[v] = _add(fh[v], fl[v], -2.0 * qh, -2.0 * ql)


@jit
def _weighted_terms(ch, cl, fh, fl, e1h, e1l, e2h, e2l, w, terms):  # pragma: no cover - compiled
    """``terms[v] = w[v] round(c + F[v] + E1[v] + E2[v])``: the highs summed exactly."""
    for v in range(fh.size):
        s1, r1 = two_sum(ch, fh[v])
        s2, r2 = two_sum(e1h[v], e2h[v])
        s, r3 = two_sum(s1, s2)
        low = ((r1 + r2) + (r3 + cl)) + (fl[v] + (e1l[v] + e2l[v]))
        terms[v] = (s + low) * w[v]


@jit
def theo1_fast_sums(xh, xl, ms, out):  # pragma: no cover - compiled
    """``S(m)`` of every even ``m`` in ``ms`` (sorted) into ``out``, from the centred phase.

    ``xh + xl``: the phase (double-double, best centred: :func:`centred_phase`), ``N``
    points; ``ms``: increasing even factors, ``2 <= m <= N - 1``. See the module docstring.
    """
    n = xh.size
    kmax = ms[ms.size - 1] // 2
    mmax = 2 * kmax
    yh = xh[::-1].copy()  # the record reversed: its head is the tail of x, read forwards
    yl = xl[::-1].copy()
    rh = np.zeros(mmax + 1)
    rl = np.zeros(mmax + 1)
    _lag_products(xh, xl, mmax, rh, rl)
    ph = np.zeros(n + 1)  # P[i] = sum_{t<i} x_t^2
    pl = np.zeros(n + 1)
    for i in range(n):
        p, e = _prod(xh[i], xl[i], xh[i], xl[i])
        ph[i + 1], pl[i + 1] = _add(ph[i], pl[i], p, e)
    eh = np.zeros(mmax + 1)
    el = np.zeros(mmax + 1)
    fh = np.zeros(kmax + 1)
    fl = np.zeros(kmax + 1)
    terms = np.empty(kmax)
    bufh = np.empty(kmax)
    bufl = np.empty(kmax)
    top = kmax
    inv = np.empty(kmax)  # inv[top - j] = 1 / j: the weights of j = k, k - 1, ... read forwards
    for j in range(1, kmax + 1):
        inv[top - j] = 1.0 / j
    idx = 0
    for k in range(1, kmax + 1):
        m = 2 * k
        # lags m - 2 and m - 1 enter: E_L = P[N-L] - P[L] - 4 R_L before any head product
        for lag in range(max(m - 2, 1), m):
            zh, zl = _add(ph[n - lag], pl[n - lag], -ph[lag], -pl[lag])
            eh[lag], el[lag] = _add(zh, zl, -4.0 * rh[lag], -4.0 * rl[lag])
        # the heads (and tails) grow by the points m - 2, m - 1: pairs (m-2-L, m-2),
        # (m-1-L, m-1); x_{m-1-L} = y_{N-m+L} keeps every read forwards
        ah = 2.0 * xh[m - 2]
        al = 2.0 * xl[m - 2]
        bh = 2.0 * xh[m - 1]
        bl = 2.0 * xl[m - 1]
        ch = 2.0 * yh[m - 2]
        cl = 2.0 * yl[m - 2]
        dh = 2.0 * yh[m - 1]
        dl = 2.0 * yl[m - 1]
        _grow_heads(
            eh[1 : m - 1], el[1 : m - 1],
            yh[n - m + 2 : n], yl[n - m + 2 : n], yh[n - m + 1 : n - 1], yl[n - m + 1 : n - 1],
            xh[n - m + 2 : n], xl[n - m + 2 : n], xh[n - m + 1 : n - 1], xl[n - m + 1 : n - 1],
            ah, al, bh, bl, ch, cl, dh, dl,
        )  # fmt: skip
        qh, ql = _prod(yh[n - 1], yl[n - 1], bh, bl)  # lag m - 1: x_0 x_{m-1} + y_0 y_{m-1}
        p, e = _prod(xh[n - 1], xl[n - 1], dh, dl)
        qh, ql = _add(qh, ql, p, e)
        eh[m - 1], el[m - 1] = _add(eh[m - 1], el[m - 1], qh, ql)
        # the centre k - 1 enters: F_v -= 2 (x_{k-1-v} x_{k-1+v} + y_{k-1-v} y_{k-1+v})
        fh[k - 1] = 2.0 * rh[m - 2]
        fl[k - 1] = 2.0 * rl[m - 2]
        _grow_centres(
            fh[:k], fl[:k], yh[n - k :], yl[n - k :], xh[k - 1 : m - 1], xl[k - 1 : m - 1],
            xh[n - k :], xl[n - k :], yh[k - 1 : m - 1], yl[k - 1 : m - 1],
        )  # fmt: skip
        if m == ms[idx]:
            ch, cl = _add(ph[n - m], pl[n - m], ph[n], pl[n])
            ch, cl = _add(ch, cl, -ph[m], -pl[m])
            ch, cl = _add(ch, cl, 2.0 * rh[m], 2.0 * rl[m])
            for v in range(k):  # E_{k-v}, reversed into a buffer so that every read is forwards
                bufh[v] = eh[k - v]
                bufl[v] = el[k - v]
            _weighted_terms(
                ch, cl, fh[:k], fl[:k], bufh[:k], bufl[:k], eh[k:m], el[k:m], inv[top - k :],
                terms[:k],
            )  # fmt: skip
            out[idx] = _blocked_sum(terms, k)
            idx += 1

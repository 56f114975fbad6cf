"""Slow, obviously correct reference implementations (NIST SP 1065 definitions).

Every difference of the integrated signal is written as a signed list of the original
samples and summed with ``math.fsum`` (correctly rounded), so these references are exact to
one rounding whatever offset, drift or scale the data carry. They cost O(N * m) per tau.
"""

from __future__ import annotations

import math

import numpy as np


def _seg(y, a, b, w=1):
    """Terms of w * sum(y[a:b]) as a list of exactly representable values (|w| copies)."""
    vals = [float(v) for v in y[a:b]]
    if w < 0:
        vals = [-v for v in vals]
    return vals * abs(w)


def d2_terms(y, i, m):
    """Rate data: (x[i+2m] - 2x[i+m] + x[i]) / tau0 as terms of y (x = tau0 * cumsum)."""
    return _seg(y, i + m, i + 2 * m) + _seg(y, i, i + m, -1)


def d3_terms(y, i, m):
    """Rate data: (x[i+3m] - 3x[i+2m] + 3x[i+m] - x[i]) / tau0 as terms of y."""
    return _seg(y, i + 2 * m, i + 3 * m) + _seg(y, i + m, i + 2 * m, -2) + _seg(y, i, i + m)


def _pd(x, i, m, coefs):
    """sum_k coefs[k] * x[i + k m] exactly (a coefficient c is |c| copies of the value)."""
    out = []
    for k, c in enumerate(coefs):
        v = float(x[i + k * m])
        out += [v if c > 0 else -v] * abs(c)
    return out


def _exact_multiples(values, weights):
    """Terms whose sum is sum(weights * values) exactly: each weight split into powers of 2."""
    out = []
    for v, w in zip(values, weights, strict=True):
        w = int(w)
        sign = 1.0 if w > 0 else -1.0
        w = abs(w)
        b = 0
        while w:
            if w & 1:
                out.append(sign * math.ldexp(float(v), b))
            w >>= 1
            b += 1
    return out


def _modified_terms(y, j, m, phase):
    """sum_{i=j}^{j+m-1} d2_m[i] as exact terms (integer weights on the samples)."""
    if phase:
        # d2 on phase: weights +1 at i, -2 at i+m, +1 at i+2m, summed over i = j..j+m-1
        w = np.zeros(3 * m, dtype=np.int64)
        for i in range(m):
            w[i] += 1
            w[i + m] -= 2
            w[i + 2 * m] += 1
        return _exact_multiples(y[j : j + 3 * m], w)
    # rate: d2 = sum(y[i+m:i+2m]) - sum(y[i:i+m]); weights are a signed triangle pair
    w = np.zeros(3 * m - 1, dtype=np.int64)
    for i in range(m):
        w[i + m : i + 2 * m] += 1
        w[i : i + m] -= 1
    return _exact_multiples(y[j : j + 3 * m - 1], w)


def variance(data, m, stat, data_type="rate", tau0=1.0):
    """Reference variance of ``stat`` at averaging factor ``m`` (tdev returns TVAR)."""
    y = np.asarray(data, dtype=np.float64)
    phase = data_type == "phase"
    npts = y.size if phase else y.size + 1
    tau = m * tau0

    def d(i, order):
        if phase:
            return _pd(y, i, m, (1, -2, 1) if order == 2 else (-1, 3, -3, 1))
        return d2_terms(y, i, m) if order == 2 else d3_terms(y, i, m)

    def sq(terms):
        v = math.fsum(terms)
        return v * v

    # scale: rate data differences are in units of y*samples, i.e. phase/tau0
    unit = 1.0 if not phase else 1.0 / tau0**2
    if stat == "oadev":
        n = npts - 2 * m
        s = math.fsum(sq(d(i, 2)) for i in range(n))
        return unit * s / (2 * m * m * n)
    if stat == "adev":
        n = (npts - 1) // m - 1
        s = math.fsum(sq(d(q * m, 2)) for q in range(n))
        return unit * s / (2 * m * m * n)
    if stat == "ohdev":
        n = npts - 3 * m
        s = math.fsum(sq(d(i, 3)) for i in range(n))
        return unit * s / (6 * m * m * n)
    if stat == "hdev":
        n = (npts - 1) // m - 2
        s = math.fsum(sq(d(q * m, 3)) for q in range(n))
        return unit * s / (6 * m * m * n)
    if stat in ("mdev", "tdev"):
        n = npts - 3 * m + 1
        s = math.fsum(sq(_modified_terms(y, j, m, phase)) for j in range(n))
        mvar = unit * s / (2 * m**4 * n)
        return mvar * tau * tau / 3 if stat == "tdev" else mvar
    if stat == "totdev":
        u = np.diff(y) if phase else y  # phase: one rounding per difference
        ext = np.pad(u, npts - 2, mode="symmetric")
        pad = npts - 2
        n = npts - 2
        s = math.fsum(sq(d2_terms(ext, pad + 1 - m + k, m)) for k in range(n))
        return unit * s / (2 * m * m * n)
    raise ValueError(stat)


def deviation(data, ms, stat, data_type="rate", tau0=1.0):
    return np.sqrt([variance(data, int(m), stat, data_type, tau0) for m in ms])


def davar_reference(x, window, *, edges="mirror", step=1, data_type="rate", tau0=1.0, ms=None):
    """Dynamic Allan variance straight from its definition (slow: O(sum L * m) per window).

    The rate samples ``v`` (``diff(x)`` for phase input) are extended by ``np.pad(v, k,
    mode="symmetric")``; every ``step``-th sample ``p`` is a centre, its window is the ``L``
    samples from ``p - (L - 1) // 2``, and at each ``m`` with ``3 m <= L``

        avar = sum_i (sum(w[i+m:i+2m]) - sum(w[i:i+m]))**2 / (2 m**2 (L - 2m + 1))

    with every second difference and the sum of squares taken with ``math.fsum``.
    ``window`` is an int, one length per sample, or one per centre. ``edges="valid"`` keeps
    the centres whose window lies inside the record. ``ms`` defaults to ``1 .. Lmax // 3``.

    Returns ``(centre, length, ms, avar)`` with ``avar`` of shape (centres, taus).
    """
    x = np.asarray(x, dtype=np.float64)
    v = np.diff(x) if data_type == "phase" else x
    unit = 1.0 / tau0**2 if data_type == "phase" else 1.0
    n = v.size
    centres = list(range(0, n, step))
    w = np.asarray(window)
    if w.ndim == 0:
        lengths = [int(w)] * len(centres)
    elif w.size == n:
        lengths = [int(w[p]) for p in centres]
    else:
        assert w.size == len(centres)
        lengths = [int(v_) for v_ in w]
    pairs = [(p, L) for p, L in zip(centres, lengths, strict=True)]
    if edges == "valid":
        pairs = [(p, L) for p, L in pairs if p - (L - 1) // 2 >= 0 and p - (L - 1) // 2 + L <= n]
    k = max(L for _, L in pairs)
    ext = np.pad(v, k, mode="symmetric")  # ext[k + j] = v[j]
    if ms is None:
        ms = range(1, k // 3 + 1)
    ms = [int(m) for m in ms]
    out = np.full((len(pairs), len(ms)), np.nan)
    for row, (p, L) in enumerate(pairs):
        a = p - (L - 1) // 2
        win = [float(s) for s in ext[k + a : k + a + L]]
        for col, m in enumerate(ms):
            if 3 * m > L:
                continue
            count = L - 2 * m + 1
            d = [
                math.fsum(win[i + m : i + 2 * m] + [-s for s in win[i : i + m]])
                for i in range(count)
            ]
            out[row, col] = unit * math.fsum(di * di for di in d) / (2 * m * m * count)
    centre = np.array([p for p, _ in pairs], dtype=np.int64)
    length = np.array([L for _, L in pairs], dtype=np.int64)
    return centre, length, np.asarray(ms, dtype=np.int64), out


# ---------------------------------------------------------------------------------------
# kurtosis (adavar.dynamic.kurtosis)


def pearson_kurtosis(values):
    """Pearson kurtosis (biased moments) in two passes with ``math.fsum``; NaN if constant.

    The mean is the correctly rounded sum over ``n``; the deviations from it are squared
    and summed with ``math.fsum``, so there is no cancellation whatever the offset. The
    element-wise steps (a difference, a product) are NumPy's on float64: each rounds once,
    exactly as the same operation on Python floats.
    """
    vals = np.asarray(values, dtype=np.float64).ravel()
    n = vals.size
    if n == 0 or np.all(vals == vals[0]):
        return math.nan
    mean = math.fsum(vals.tolist()) / n
    dev = vals - mean
    # the rounded mean is off by at most half an ulp: centre once more on the exact residual
    shift = math.fsum(dev.tolist()) / n
    dev = dev - shift
    # an exact power-of-two rescaling keeps the fourth powers of any scale representable
    big = float(np.max(np.abs(dev)))
    if big > 0:
        dev = dev * math.ldexp(1.0, -math.frexp(big)[1])
    squares = dev * dev
    m2 = math.fsum(squares.tolist()) / n
    m4 = math.fsum((squares * squares).tolist()) / n
    return m4 / (m2 * m2)


def _kurtosis_windows(n, window, edges, step):
    """(centre, length, start) of every window, straight from the convention."""
    centres = list(range(0, n, step))
    w = np.asarray(window)
    if w.ndim == 0:
        lengths = [int(w)] * len(centres)
    elif w.size == n:
        lengths = [int(w[p]) for p in centres]
    else:
        assert w.size == len(centres)
        lengths = [int(v) for v in w]
    rows = [(p, L, p - (L - 1) // 2) for p, L in zip(centres, lengths, strict=True)]
    if edges == "valid":
        rows = [(p, L, a) for p, L, a in rows if a >= 0 and a + L <= n]
    return rows


def kurtosis_reference(x, window, *, edges="mirror", step=1):
    """Sliding Pearson kurtosis by explicit loops; returns ``(centre, kurtosis)``.

    The record is extended by ``np.pad(x, k, mode="symmetric")`` (``k`` the longest window)
    and the window of ``L`` samples centred at ``p`` holds ``p - (L-1)//2 ..`` (L samples).
    """
    x = np.asarray(x, dtype=np.float64)
    rows = _kurtosis_windows(x.size, window, edges, step)
    k = max(L for _, L, _ in rows)
    ext = np.pad(x, k, mode="symmetric")  # ext[k + j] = x[j]
    out = [pearson_kurtosis(ext[k + a : k + a + L]) for _, L, a in rows]
    return np.array([p for p, _, _ in rows], dtype=np.int64), np.array(out)


def contribution_reference(x, window, segment=None, *, reference="window", edges="mirror", step=1):
    """Sliding kurtosis contribution ``(kurt(X) - kurt(c)) / kurt(X)`` by explicit loops.

    ``reference="window"``: ``X`` the (mirror-extended) window, ``c`` its first
    ``L - segment`` samples. ``reference="record"``: ``X`` the record, ``s`` the window
    clipped to the record, ``c`` the record without ``s``. Returns ``(centre, S)``.
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.size
    rows = _kurtosis_windows(n, window, edges, step)
    out = []
    if reference == "window":
        k = max(L for _, L, _ in rows)
        ext = np.pad(x, k, mode="symmetric")
        for _, L, a in rows:
            win = ext[k + a : k + a + L]
            kx = pearson_kurtosis(win)
            kc = pearson_kurtosis(win[: L - segment])
            out.append((kx - kc) / kx)
    else:
        kx = pearson_kurtosis(x)
        for _, L, a in rows:
            lo, hi = max(a, 0), min(a + L, n)
            kc = pearson_kurtosis(np.concatenate([x[:lo], x[hi:]]))
            out.append((kx - kc) / kx)
    return np.array([p for p, _, _ in rows], dtype=np.int64), np.array(out)

"""The one set of inner kernels behind every whole-record sum of squared differences.

A difference ``sum_k c_k S[i + k m]`` of the anchored phase (:mod:`adavar._kernels.differences`)
splits into an anchor part, exact in double-double and constant while no ``i + k m``
crosses a block boundary, plus a local part ``sum_k c_k r[i + k m]``. The kernels here take
the local parts as *views*: ``x_k[j] = r[base + j + k m]``. In memory the views are slices
of one array (``r``, ``r[m:]``, ``r[2 m:]``); out of core each is a window of the record
read piece by piece; with missing samples, views of the keep tests ride along. The same
loops, in the same order, serve all three, so their results agree bit for bit.

Missing samples enter as an optional argument (``None``: every term counts). Numba
compiles a separate version for ``None``, so the gap-free loops carry no test.
"""

from __future__ import annotations

import numpy as np

from adavar._kernels._jit import jit, read_only
from adavar._kernels.double_double import dd_scaled_add, two_sum

__all__ = [
    "BLOCK",
    "SECOND",
    "SHIFT",
    "THIRD",
    "accumulate",
    "anchor_combo",
    "difference_combo",
    "fill2",
    "segment_end",
    "slide_window_sum",
    "squares",
    "strided_run",
]

SHIFT = 10
BLOCK = 1 << SHIFT  # anchor spacing, samples
SECOND = read_only(np.array([1, -2, 1], dtype=np.int64))  # coefficients of the Allan difference
THIRD = read_only(np.array([-1, 3, -3, 1], dtype=np.int64))  # and of the Hadamard one


# ---------------------------------------------------------------------------------------
# the anchor part


@jit
def anchor_combo(hh, hl, i, m, coefs):  # pragma: no cover - compiled
    """Round-to-double of ``sum_k coefs[k] * H[(i + k m) // BLOCK]`` computed in double-double."""
    ah = 0.0
    al = 0.0
    for k in range(coefs.size):
        b = (i + k * m) >> SHIFT
        ah, al = dd_scaled_add(ah, al, coefs[k], hh[b], hl[b])
    return ah + al


@jit
def difference_combo(r, hh, hl, i, m, coefs):  # pragma: no cover - compiled
    """``sum_k coefs[k] * S[i + k m]`` to a few ulps."""
    local = 0.0
    for k in range(coefs.size):
        local += coefs[k] * r[i + k * m]
    return anchor_combo(hh, hl, i, m, coefs) + local


@jit
def segment_end(i, hi, m, npts_k):  # pragma: no cover - compiled
    """First index after ``i`` (capped at ``hi``) where some ``i + k m`` enters a new block."""
    end = hi
    for k in range(npts_k):
        j = i + k * m
        e = i + ((((j >> SHIFT) + 1) << SHIFT) - j)
        end = min(end, e)
    return end


# ---------------------------------------------------------------------------------------
# runs of i with a constant anchor part: ``x[lo + k s : hi + k s]`` is the local part of
# point ``k`` of the terms ``lo .. hi - 1`` (``s`` the stride between the points in ``x``).
# Slices and a 0-based counter let LLVM drop Numba's negative-index checks and vectorise.


@jit(fastmath=True)
def _squares2(x, c, lo, hi, s):  # pragma: no cover - compiled
    x0 = x[lo:hi]
    x1 = x[lo + s : hi + s]
    x2 = x[lo + 2 * s : hi + 2 * s]
    acc = 0.0
    for k in range(hi - lo):
        v = c + ((x0[k] + x2[k]) - 2.0 * x1[k])
        acc += v * v
    return acc


@jit(fastmath=True)
def _squares3(x, c, lo, hi, s):  # pragma: no cover - compiled
    x0 = x[lo:hi]
    x1 = x[lo + s : hi + s]
    x2 = x[lo + 2 * s : hi + 2 * s]
    x3 = x[lo + 3 * s : hi + 3 * s]
    acc = 0.0
    for k in range(hi - lo):
        v = c + ((x3[k] - x0[k]) + 3.0 * (x1[k] - x2[k]))
        acc += v * v
    return acc


@jit(fastmath=True)
def _window_kept2(x, c, lo, hi, s, cnt, w):  # pragma: no cover - compiled
    # kept: no missing sample in the term's window (prefix counts equal at both ends)
    x0 = x[lo:hi]
    x1 = x[lo + s : hi + s]
    x2 = x[lo + 2 * s : hi + 2 * s]
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
def _window_kept3(x, c, lo, hi, s, cnt, w):  # pragma: no cover - compiled
    x0 = x[lo:hi]
    x1 = x[lo + s : hi + s]
    x2 = x[lo + 2 * s : hi + 2 * s]
    x3 = x[lo + 3 * s : hi + 3 * s]
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
def _points_kept2(x, c, lo, hi, s, pm):  # pragma: no cover - compiled
    # kept: none of the term's points is missing
    x0 = x[lo:hi]
    x1 = x[lo + s : hi + s]
    x2 = x[lo + 2 * s : hi + 2 * s]
    p0 = pm[lo:hi]
    p1 = pm[lo + s : hi + s]
    p2 = pm[lo + 2 * s : hi + 2 * s]
    acc = 0.0
    n = 0
    for k in range(hi - lo):
        v = c + ((x0[k] + x2[k]) - 2.0 * x1[k])
        keep = (p0[k] + p1[k] + p2[k]) == 0
        acc += v * v if keep else 0.0
        n += 1 if keep else 0
    return acc, n


@jit(fastmath=True)
def _points_kept3(x, c, lo, hi, s, pm):  # pragma: no cover - compiled
    x0 = x[lo:hi]
    x1 = x[lo + s : hi + s]
    x2 = x[lo + 2 * s : hi + 2 * s]
    x3 = x[lo + 3 * s : hi + 3 * s]
    p0 = pm[lo:hi]
    p1 = pm[lo + s : hi + s]
    p2 = pm[lo + 2 * s : hi + 2 * s]
    p3 = pm[lo + 3 * s : hi + 3 * s]
    acc = 0.0
    n = 0
    for k in range(hi - lo):
        v = c + ((x3[k] - x0[k]) + 3.0 * (x1[k] - x2[k]))
        keep = ((p0[k] + p1[k]) + (p2[k] + p3[k])) == 0
        acc += v * v if keep else 0.0
        n += 1 if keep else 0
    return acc, n


@jit(inline="always")
def squares(x, s, base, q0, q1, m, hh, hl, coefs, missing):  # pragma: no cover - compiled
    """Sum of squared differences ``i = base + q0 .. base + q1 - 1`` and how many were kept.

    ``x[j + k s] = r[base + j + k m]``: in memory ``x`` is ``r`` itself (``s = m``,
    ``base = 0``); out of core a window of it, or the ``order + 1`` windows that far apart
    points need laid end to end (``s`` their length). ``missing`` is ``None`` (every term)
    or ``(cnt, w, pm)`` indexed like ``x``: with ``w > 0`` a term is kept when ``cnt[j] ==
    cnt[j + w]`` (prefix counts: no missing sample in its window), with ``w == 0`` when its
    points' flags ``pm[j + k s]`` are all 0.
    """
    acc = 0.0
    i = base + q0
    end = base + q1
    if missing is None:
        while i < end:
            e = segment_end(i, end, m, coefs.size)
            c = anchor_combo(hh, hl, i, m, coefs)
            if coefs.size == 3:
                acc += _squares2(x, c, i - base, e - base, s)
            else:
                acc += _squares3(x, c, i - base, e - base, s)
            i = e
        return acc, q1 - q0
    cnt, w, pm = missing
    n = 0
    while i < end:
        e = segment_end(i, end, m, coefs.size)
        c = anchor_combo(hh, hl, i, m, coefs)
        if w > 0:
            if coefs.size == 3:
                a, k = _window_kept2(x, c, i - base, e - base, s, cnt, w)
            else:
                a, k = _window_kept3(x, c, i - base, e - base, s, cnt, w)
        elif coefs.size == 3:
            a, k = _points_kept2(x, c, i - base, e - base, s, pm)
        else:
            a, k = _points_kept3(x, c, i - base, e - base, s, pm)
        acc += a
        n += k
        i = e
    return acc, n


@jit(fastmath=True)
def _fill_run(x0, x1, x2, c, a, b, out):  # pragma: no cover - compiled
    y0 = x0[a:b]
    y1 = x1[a:b]
    y2 = x2[a:b]
    o = out[a:b]
    for k in range(b - a):
        o[k] = c + ((y0[k] + y2[k]) - 2.0 * y1[k])


@jit
def fill2(x0, x1, x2, lo, hi, m, hh, hl, out):  # pragma: no cover - compiled
    """``out[i - lo] = S[i] - 2 S[i+m] + S[i+2m]`` for ``i`` in ``[lo, hi)``;
    ``x_k[j] = r[lo + j + k m]``."""
    coefs = SECOND
    i = lo
    while i < hi:
        e = segment_end(i, hi, m, np.int64(3))
        c = anchor_combo(hh, hl, i, m, coefs)
        _fill_run(x0, x1, x2, c, i - lo, e - lo, out)
        i = e


# ---------------------------------------------------------------------------------------
# non-overlapping differences and the modified statistics' sliding sums


@jit
def strided_run(vals, q_first, q_end, m, hh, hl, coefs, acc, n, missing):  # pragma: no cover
    """Add the squared differences ``q = q_first .. q_end - 1`` at ``i = q m`` to ``acc``.

    ``vals[k] = r[(q_first + k) m]``. ``missing`` is ``None`` or ``(g0, g1, pv)``, indexed
    like ``vals``: prefix counts at each term's ends and the points' missing flags; a term
    counts when ``g1 - g0`` plus its points' flags is 0. Returns ``(acc, n)``, ``n`` the
    count of terms added plus the one given.
    """
    kp = coefs.size
    for q in range(q_first, q_end):
        j = q - q_first
        if missing is not None:
            g0, g1, pv = missing
            bad = g1[j] - g0[j]
            for k in range(kp):
                bad += pv[j + k]
            if bad != 0:
                continue
        local = 0.0
        for k in range(kp):
            local += coefs[k] * vals[j + k]
        v = anchor_combo(hh, hl, q * m, m, coefs) + local
        acc += v * v
        n += 1
    return acc, n


@jit
def accumulate(d, n, s, c):  # pragma: no cover - compiled
    """Add ``d[:n]`` to the compensated sum ``s + c``; returns ``(s, c)``."""
    for k in range(n):
        s, e = two_sum(s, d[k])
        c += e
    return s, c


@jit
def slide_window_sum(enter, leave, n, s, c, acc, kept, keep):  # pragma: no cover - compiled
    """Slide a window sum kept as ``s + c`` (compensated) ``n`` starts on.

    Each start adds ``enter[q]``, drops ``leave[q]`` and adds the new sum's square to
    ``acc`` (and 1 to ``kept``) unless ``keep`` (``None`` or two prefix-count views) has
    ``keep[0][q] != keep[1][q]``. Returns ``(s, c, acc, kept)``. The MVAR numerator's step,
    in memory, out of core and with gaps.
    """
    for q in range(n):
        s, e = two_sum(s, enter[q])
        c += e
        s, e = two_sum(s, -leave[q])
        c += e
        if keep is not None:
            if keep[0][q] != keep[1][q]:
                continue
        v = s + c
        acc += v * v
        kept += 1
    return s, c, acc, kept

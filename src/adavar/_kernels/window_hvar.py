"""The dynamic Hadamard and modified Allan variance kernels: every window at every factor.

The engine of :mod:`adavar._kernels.window_avar` with other terms. A work item takes a chunk
of consecutive centres, re-centres the span of their windows on a local reference (the
median of up to 65 samples) and integrates it once in double-double (``P = ph + pl``, see
``window_avar._local_prefix``). Per averaging factor ``m`` it fills the terms of the
statistic over the span, prefix-sums their squares with compensation (``_prefix_squares``,
the third part when a window's error bound asks for it) and reads each window's sum as the
difference of two prefix values: O(1) per (window, factor) whatever the window length.

- ``"ohvar"``, the overlapping Hadamard variance (NIST SP 1065): the third
  differences ``P[i + 3m] - 3 P[i + 2m] + 3 P[i + m] - P[i]``, from three exact two-sums of
  the high parts, the next two levels of differences exact as well, and the low parts,
  rounded once (correct to an ulp or so of the term, like the second differences of the
  Allan kernel), over ``n = L - 3m + 1`` starts, times ``1 / (6 m**2 n)``.
- ``"mvar"``, the modified Allan variance (SP 1065): the sums of ``m`` consecutive
  second differences. Each second difference is kept to its last bits, they are
  prefix-summed in two compensated parts (``D``; the errors accumulated before a term are a
  constant that cancels in ``D[j + m] - D[j]``, and ``|D|`` stays near ``m**2`` times the
  local rate however long the span), and each term is that difference rounded once;
  ``n = L - 3m + 2`` terms, times ``1 / (2 m**4 n)``.

Measured against an exact per-window computation (``math.fsum`` of the terms written on
the rate samples, tests/test_davar_stats.py): 3.3e-16 relative at worst over every cell of
1500 random records (offsets of 1e9, level steps of 1e6 sigma, drifts, rate ramps, bursts
of 1e10, scales 1e-13 .. 1e12, float32 input, rate and phase data), and 2.2e-16 in windows
of 5000 samples on a 1e9 offset with a 1e6-sigma step and 1e12-sigma bursts in their span.
"""

from __future__ import annotations

import numpy as np

from adavar._jit import jit, threaded_jit
from adavar._kernels.double_double import two_sum
from adavar._kernels.window_avar import (
    MEDIAN_SAMPLES,
    _eval_uniform,
    _local_prefix,
    _prefix_squares,
    _window_sum,
    chunk_layout,
    prepare_windows,
    sample_median,
)

__all__ = ["KINDS", "MVAR", "OHVAR", "window_hvar", "window_hvar_kernel"]

#: the statistic of a kernel call (plain integers: one compiled version serves both)
OHVAR = 1
MVAR = 2
KINDS = {"ohvar": OHVAR, "mvar": MVAR}
#: scratch rows: prefix high and low parts, the moving sums' prefix (2), the terms, and
#: their squares' prefix (3 parts)
_ROWS = 8


@jit
def _fill_third(ph, pl, m, first, count, out):  # pragma: no cover - compiled
    """``out[k] = P[j+3m] - 3 P[j+2m] + 3 P[j+m] - P[j]``, ``j = first + k``, rounded once."""
    h0 = ph[first : first + count]
    h1 = ph[first + m : first + m + count]
    h2 = ph[first + 2 * m : first + 2 * m + count]
    h3 = ph[first + 3 * m : first + 3 * m + count]
    l0 = pl[first : first + count]
    l1 = pl[first + m : first + m + count]
    l2 = pl[first + 2 * m : first + 2 * m + count]
    l3 = pl[first + 3 * m : first + 3 * m + count]
    dst = out[:count]
    for k in range(count):
        a, ea = two_sum(h3[k], -h2[k])
        b, eb = two_sum(h2[k], -h1[k])
        c, ec = two_sum(h1[k], -h0[k])
        s, es = two_sum(a, -b)
        t, et = two_sum(b, -c)
        h, eh = two_sum(s, -t)
        low = ((l3[k] - l2[k]) - (l2[k] - l1[k])) - ((l2[k] - l1[k]) - (l1[k] - l0[k]))
        dst[k] = h + (eh + ((es - et) + (((ea - eb) - (eb - ec)) + low)))


#: steps of the moving sums' prefix between two renormalisations of its two parts
_RENORMALISE = 16


@jit
def _fill_moving(ph, pl, m, first, count, dh, dl, out):  # pragma: no cover - compiled
    """``out[k] = sum_{i=j}^{j+m-1} (P[i+2m] - 2 P[i+m] + P[i])``, ``j = first + k``.

    ``dh + dl`` receives the prefix ``D`` of the second differences, each taken exactly
    to its last bits (high part ``h`` and the sum of its error terms, in a first pass that
    vectorises): ``dh`` is the plain running sum of the ``h``, ``dl`` gathers its rounding
    errors (two-sums) and the low parts, and the pair is renormalised every
    :data:`_RENORMALISE` steps, so ``|dl|`` stays within a few ulps of ``dh`` and the loop
    carries one add per part (not the chain of a double-double add). Every term is
    ``D[k + m] - D[k]`` rounded once.
    """
    total = count + m - 1  # second differences first .. first + total - 1
    h0 = ph[first : first + total]
    h1 = ph[first + m : first + m + total]
    h2 = ph[first + 2 * m : first + 2 * m + total]
    l0 = pl[first : first + total]
    l1 = pl[first + m : first + m + total]
    l2 = pl[first + 2 * m : first + 2 * m + total]
    hs = dh[1 : total + 1]
    ls = dl[1 : total + 1]
    for k in range(total):
        a, ea = two_sum(h2[k], -h1[k])
        b, eb = two_sum(h1[k], -h0[k])
        hs[k], eh = two_sum(a, -b)
        ls[k] = eh + ((ea - eb) + ((l2[k] - l1[k]) - (l1[k] - l0[k])))
    # the prefix in place: each step reads its difference before it writes the sum there
    s = 0.0
    c = 0.0
    dh[0] = 0.0
    dl[0] = 0.0
    k0 = 1
    while k0 <= total:
        k1 = min(k0 + _RENORMALISE, total + 1)
        for k in range(k0, k1):
            h = dh[k]
            t = s + h
            bb = t - s
            c += ((s - (t - bb)) + (h - bb)) + dl[k]
            s = t
            dh[k] = s
            dl[k] = c
        s, c = two_sum(s, c)
        k0 = k1
    dst = out[:count]
    a0 = dh[:count]
    a1 = dh[m : m + count]
    b0 = dl[:count]
    b1 = dl[m : m + count]
    for k in range(count):
        s, e = two_sum(a1[k], -a0[k])
        dst[k] = s + (e + (b1[k] - b0[k]))


@jit
def _fill_terms(work, kind, m, first, count):  # pragma: no cover - compiled
    """The statistic's ``count`` terms from start ``first`` into ``work[4]``."""
    if kind == OHVAR:
        _fill_third(work[0], work[1], m, first, count, work[4])
    else:
        _fill_moving(work[0], work[1], m, first, count, work[2], work[3], work[4])


@jit
def _terms_of(kind, L, m):  # pragma: no cover - compiled
    """Terms of a window of ``L`` samples at ``m`` (``3 m <= L``)."""
    return L - 3 * m + (2 if kind == MVAR else 1)


@jit
def _norm_of(kind, m, scale):  # pragma: no cover - compiled
    """The factor of a window's sum of squares, before the division by its term count."""
    mm = float(m) * float(m)
    return scale / (2.0 * mm * mm) if kind == MVAR else scale / (6.0 * mm)


@jit
def _eval_runs(q, aloc, lens, runs, n_runs, kind, m, norm, res):  # pragma: no cover - compiled
    """Any windows, as runs of one length with consecutive starts (``runs[j]`` .. next)."""
    for j in range(n_runs):
        k0 = runs[j]
        k1 = runs[j + 1]
        L = lens[k0]
        if 3 * m > L:
            for k in range(k0, k1):
                res[k] = np.nan
            continue
        n = _terms_of(kind, L, m)
        if k1 - k0 == 1:
            a = aloc[k0]
            res[k0] = max(_window_sum(q, a, a + n), 0.0) * (norm / n)
        else:
            _eval_uniform(q, aloc[k0], n, k1 - k0, norm, res, k0)


@jit
def _own_span(work, kind, m, first, n):  # pragma: no cover - compiled
    """Sum of the squares of the ``n`` terms from ``first``, summed from zero (small q[1])."""
    q = work[5:]
    _fill_terms(work, kind, m, first, n)
    _prefix_squares(work[4], n, q, False)
    return q[0, n] + q[1, n]


@jit
def _one_window(u, a, L, ms, kind, scale, work, tmp, row):  # pragma: no cover - compiled
    """Every factor of the window ``u[a:a+L]`` alone, over its own span, into ``row``."""
    _local_prefix(u, a, a + L, sample_median(u, a, a + L, tmp), work[0], work[1])
    for t in range(ms.size):
        m = ms[t]
        if 3 * m > L:
            row[t] = np.nan
            continue
        n = _terms_of(kind, L, m)
        row[t] = max(_own_span(work, kind, m, 0, n), 0.0) * (_norm_of(kind, m, scale) / n)


@threaded_jit
def window_hvar_kernel(
    u, ms, centres, lengths, offset, chunk, workers, kind, scale, out, w_lo, w_hi
):  # fmt: skip  # pragma: no cover - compiled
    """Overlapping Hadamard (``kind = OHVAR``) or modified Allan (``MVAR``) variance of
    every window at every averaging factor.

    Windows as in ``window_avar_kernel``: window ``c`` covers ``u[a : a + lengths[c]]``,
    ``a = centres[c] - (lengths[c] - 1) // 2 + offset``; chunks of ``chunk`` consecutive
    centres are dealt round-robin to ``workers`` work items, of which this call runs
    ``w_lo .. w_hi - 1``. Cells with ``3m > L`` are NaN.

    The chunk's code is written out in the loop rather than called: a separate compiled
    function took about 0.4 s more to compile on a first run (Numba optimises and
    compiles a callee's code again inside its caller), for the same speed.
    """
    nc = centres.size
    nch = (nc + chunk - 1) // chunk
    for item in range(w_lo, w_hi):
        work = np.empty((_ROWS, 1))
        tmp = np.empty(MEDIAN_SAMPLES)
        for ch in range(item, nch, workers):
            c0 = ch * chunk
            c1 = min(c0 + chunk, nc)
            size = c1 - c0
            lens = lengths[c0:c1]
            starts = np.empty(size, dtype=np.int64)
            lo, hi, spread, need = chunk_layout(centres, lengths, offset, c0, c1, starts)
            if need > work.shape[1]:
                work = np.empty((_ROWS, need))
            if spread:
                for k in range(size):
                    _one_window(u, starts[k], lens[k], ms, kind, scale, work, tmp, out[c0 + k])
                continue
            q = work[5:]
            _local_prefix(u, lo, hi, sample_median(u, lo, hi, tmp), work[0], work[1])
            aloc = np.empty(size, dtype=np.int64)
            runs = np.empty(size + 1, dtype=np.int64)
            n_runs = 0
            for k in range(size):
                aloc[k] = starts[k] - lo
                # runs of one length with consecutive starts take the contiguous fast path
                if k == 0 or lens[k] != lens[k - 1] or aloc[k] != aloc[k - 1] + 1:
                    runs[n_runs] = k
                    n_runs += 1
            runs[n_runs] = size
            res = np.empty(size)
            for t in range(ms.size):
                m = ms[t]
                norm = _norm_of(kind, m, scale)
                # span of this m's terms, and whether one prefix over it pays (the windows overlap)
                span = 0
                total = 0
                for k in range(size):
                    if 3 * m <= lens[k]:
                        n = _terms_of(kind, lens[k], m)
                        span = max(span, aloc[k] + n)
                        total += n
                if total > 0 and span <= 2 * total:
                    _fill_terms(work, kind, m, 0, span)
                    big = _prefix_squares(work[4], span, q, False)
                    _eval_runs(q, aloc, lens, runs, n_runs, kind, m, norm, res)
                    # as in window_avar: a cell below big * norm / 8 may have lost bits to q[1]
                    floor = big * norm / 8.0
                    for k in range(size):
                        if res[k] < floor:
                            _prefix_squares(work[4], span, q, True)
                            _eval_runs(q, aloc, lens, runs, n_runs, kind, m, norm, res)
                            break
                else:
                    for k in range(size):
                        L = lens[k]
                        if 3 * m > L:
                            res[k] = np.nan
                            continue
                        n = _terms_of(kind, L, m)
                        res[k] = max(_own_span(work, kind, m, aloc[k], n), 0.0) * (norm / n)
                for k in range(size):
                    out[c0 + k, t] = res[k]


def window_hvar(
    samples: np.ndarray,
    ms: np.ndarray,
    centres: np.ndarray,
    lengths: np.ndarray,
    *,
    stat: str,
    offset: int = 0,
    scale: float = 1.0,
    chunk: int = 4096,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Overlapping Hadamard or modified Allan variance of many windows of ``samples``.

    Parameters
    ----------
    samples : ndarray of float64
        The (mirror-extended) rate samples, or phase increments.
    ms : ndarray of int
        Averaging factors.
    centres, lengths : ndarray of int
        Window ``c`` holds ``samples[a : a + lengths[c]]``,
        ``a = centres[c] - (lengths[c] - 1) // 2 + offset``.
    stat : {"ohvar", "mvar"}
        The statistic.
    offset, scale, chunk, out
        As for :func:`adavar._kernels.window_avar.window_avar`.

    Returns
    -------
    ndarray, shape (len(centres), len(ms))
        NaN where ``3 m > L``.
    """
    kind = KINDS.get(stat)
    if kind is None:
        raise ValueError(f"internal: unknown window statistic {stat!r}")
    u, ms, centres, lengths, out, chunk, workers, span = prepare_windows(
        samples, ms, centres, lengths, offset, chunk, out
    )
    if centres.size:
        # the moving sums cost about twice a third difference per sample
        work = span * ms.size * (2 if kind == MVAR else 1)
        window_hvar_kernel.run(
            work, workers, u, ms, centres, lengths, int(offset), chunk, workers, int(kind),
            float(scale), out,
        )  # fmt: skip
    return out

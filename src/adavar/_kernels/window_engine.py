"""The DAVAR engine: one kernel for every window statistic, with or without missing samples.

A work item takes a chunk of consecutive centres, re-centres the span of their windows on a
local reference (the median of up to 65 samples) and integrates it once in double-double
(:mod:`adavar._kernels.window_avar`: ``_local_prefix``). Per averaging factor ``m`` it
fills the statistic's terms over the span (:func:`_fill`: the second differences of the
overlapping Allan variance, the third differences of the Hadamard one, the moving sums of
the modified Allan variance, :mod:`adavar._kernels.window_hvar`), prefix-sums their
squares with compensation (the third part when a window's error bound asks for it) and
reads each window's sum as the difference of two prefix values: O(1) per (window, factor)
whatever the window length. Windows far apart are computed one by one over their own span.

Missing samples are an argument of the same kernel (``gaps``, ``davar(..., gaps="omit")``):
the record's missing samples are filled with finite values beforehand
(:func:`adavar.stats.gaps.filled_increments`), each term that touches one is set to zero before
its square enters the prefix, and a second, integer prefix counts the kept terms; a cell is
the sum of its kept squares over their count, NaN when none is kept. The keep test of the
term starting at (extended) index ``j`` is that of the whole-record sums: ``cnt[j + w] ==
cnt[j]`` when ``w > 0`` (``cnt`` the prefix count of missing samples of the mirror-extended
record), else no missing phase point among ``pm[j + k m]`` (phase data, Allan and Hadamard
terms). A kept term is computed from the same double-double prefix as without gaps and
involves no filled value. ``gaps=None`` compiles a version without any of it.
"""

from __future__ import annotations

import numpy as np

from adavar._kernels._jit import jit, read_only, threaded_jit, work_items
from adavar._kernels.window_avar import (
    MEDIAN_SAMPLES,
    _eval_uniform,
    _fill_differences,
    _local_prefix,
    _prefix_squares,
    _window_extent,
    _window_sum,
    chunk_layout,
    prepare_windows,
    sample_median,
)
from adavar._kernels.window_hvar import MVAR, OHVAR, _fill_terms, _norm_of, _terms_of

__all__ = ["KINDS", "OAVAR", "window_gaps", "window_kernel", "window_variance"]

#: the statistic of a kernel call (plain integers: one compiled version serves them all)
OAVAR = 0
KINDS = {"oavar": OAVAR, "oadev": OAVAR, "ohvar": OHVAR, "ohdev": OHVAR, "mvar": MVAR,
         "mdev": MVAR}  # fmt: skip
#: scratch rows: prefix high and low parts, the moving sums' prefix (2), the terms, and
#: their squares' prefix (3 parts)
_ROWS = 8


@jit
def _terms(kind, L, m):  # pragma: no cover - compiled
    """Terms of a window of ``L`` samples at ``m`` (``3 m <= L``)."""
    if kind == OAVAR:
        return L - 2 * m + 1
    return _terms_of(kind, L, m)


@jit
def _norm(kind, m, scale):  # pragma: no cover - compiled
    """The factor of a window's sum of squares, before the division by its term count."""
    if kind == OAVAR:
        return scale / (2.0 * m * m)
    return _norm_of(kind, m, scale)


@jit
def _fill(work, kind, m, first, count):  # pragma: no cover - compiled
    """The statistic's ``count`` terms from local start ``first`` into ``work[4]``."""
    if kind == OAVAR:
        _fill_differences(work[0], work[1], m, first, count, work[4])
    else:
        _fill_terms(work, kind, m, first, count)


@jit
def _mask_terms(d, kc, j0, count, m, w, kind, cnt, pm):  # pragma: no cover - compiled
    """Zero the terms ``d[:count]`` that touch a missing sample (term ``k`` starts at
    extended index ``j0 + k``) and write the prefix count of the kept ones into ``kc``."""
    kc[0] = 0
    n = 0
    if w > 0:
        a = cnt[j0 : j0 + count]
        b = cnt[j0 + w : j0 + w + count]
        for k in range(count):
            if a[k] == b[k]:
                n += 1
            else:
                d[k] = 0.0
            kc[k + 1] = n
        return
    for k in range(count):
        j = j0 + k
        bad = pm[j] + pm[j + m] + pm[j + 2 * m]
        if kind == OHVAR:
            bad += pm[j + 3 * m]
        if bad == 0:
            n += 1
        else:
            d[k] = 0.0
        kc[k + 1] = n


@jit
def _own_sum(work, kc, kind, m, w, first, j0, n, gaps):  # pragma: no cover - compiled
    """Sum of the (kept) squares of the ``n`` terms from local start ``first`` (extended
    index ``j0``), summed from zero (a small ``q[1]``), and how many were kept."""
    q = work[5:]
    _fill(work, kind, m, first, n)
    if gaps is None:
        _prefix_squares(work[4], n, q, np.bool_(False))
        return q[0, n] + q[1, n], n
    cnt, pm = gaps
    _mask_terms(work[4], kc, j0, n, m, w, kind, cnt, pm)
    _prefix_squares(work[4], n, q, np.bool_(False))
    return q[0, n] + q[1, n], kc[n]


@jit
def _one_window(
    u, a, L, ms, ws, kind, scale, gaps, work, kc, tmp, row, kept
):  # fmt: skip  # pragma: no cover - compiled
    """Every factor of the window ``u[a:a+L]`` alone, over its own span."""
    _local_prefix(u, a, a + L, sample_median(u, a, a + L, tmp), work[0], work[1])
    for t in range(ms.size):
        m = ms[t]
        kept[t] = 0
        if 3 * m > L:
            row[t] = np.nan
            continue
        n = _terms(kind, L, m)
        s, c = _own_sum(work, kc, kind, m, ws[t], np.int64(0), a, n, gaps)
        kept[t] = c
        row[t] = np.nan if c == 0 else max(s, 0.0) * (_norm(kind, m, scale) / c)


@jit
def _eval_runs(q, aloc, lens, runs, n_runs, kind, m, norm, res):  # pragma: no cover
    """Any windows, as runs of one length with consecutive starts (``runs[j]`` .. next).

    An adaptive schedule holds its length for long stretches (at ``Lmax`` most of the
    time): each such run takes the contiguous, vectorised path.
    """
    for j in range(n_runs):
        k0 = runs[j]
        k1 = runs[j + 1]
        L = lens[k0]
        if 3 * m > L:
            for k in range(k0, k1):
                res[k] = np.nan
            continue
        n = _terms(kind, L, m)
        if k1 - k0 == 1:
            a = aloc[k0]
            res[k0] = max(_window_sum(q, a, a + n), 0.0) * (norm / n)
        else:
            _eval_uniform(q, aloc[k0], n, k1 - k0, norm, res, k0)


@jit
def _eval_kept(q, kc, aloc, lens, kind, m, norm, big, res, counts):  # pragma: no cover
    """Every window's kept mean from the prefixes; True when a cell lies below the error
    floor of the two-part sums (``big``: the caller redoes them in three parts; ``big = 0``
    never asks)."""
    redo = False
    floor = big * norm / 8.0
    for k in range(aloc.size):
        L = lens[k]
        counts[k] = 0
        if 3 * m > L:
            res[k] = np.nan
            continue
        n = _terms(kind, L, m)
        a = aloc[k]
        c = kc[a + n] - kc[a]
        counts[k] = c
        if c == 0:
            res[k] = np.nan
            continue
        s = max(_window_sum(q, a, a + n), 0.0)
        # the bound is per summed term: n of them in the prefix range
        if s * (norm / n) < floor:
            redo = True
        res[k] = s * (norm / c)
    return redo


@threaded_jit
def window_kernel(
    u, ms, ws, centres, lengths, offset, chunk, workers, kind, scale, gaps, out, kept,
    w_lo, w_hi,
):  # fmt: skip  # pragma: no cover - compiled
    """Variance of every window at every averaging factor (module notes).

    Window ``c`` covers ``u[a : a + lengths[c]]`` with
    ``a = centres[c] - (lengths[c] - 1) // 2 + offset``. The windows are cut into chunks of
    ``chunk`` consecutive centres, dealt round-robin to ``workers`` work items, of which
    this call runs ``w_lo .. w_hi - 1`` (the scratch is allocated once per item: fresh
    pages for every chunk cost more than the arithmetic). ``gaps`` is None or ``(cnt,
    pm)``, ``ws[t]`` the keep test's window at ``ms[t]`` (0: the missing-point test).
    Writes ``out`` (NaN where ``3m > L`` or no term is kept) and, with ``gaps``, ``kept``
    (the terms of each cell).

    The chunk's code is written out in the loop rather than called: a separate compiled
    function took about 0.4 s more to compile on a first run (Numba optimises and
    compiles a callee's code again inside its caller), for the same speed.
    """
    nc = centres.size
    nch = (nc + chunk - 1) // chunk
    for item in range(w_lo, w_hi):
        work = np.empty((_ROWS, 1))
        kc = np.empty(2, dtype=np.int64)
        tmp = np.empty(MEDIAN_SAMPLES)
        spare = np.empty(ms.size, dtype=np.int64)  # a window's kept counts, without gaps
        for ch in range(item, nch, workers):
            c0 = ch * chunk
            c1 = min(c0 + chunk, nc)
            size = c1 - c0
            lens = lengths[c0:c1]
            starts = np.empty(size, dtype=np.int64)
            lo, hi, spread, need = chunk_layout(centres, lengths, offset, c0, c1, starts)
            if need > work.shape[1]:
                work = np.empty((_ROWS, need))
                kc = np.empty(need + 1, dtype=np.int64)
            if spread:
                for k in range(size):
                    row_kept = spare if gaps is None else kept[c0 + k]
                    _one_window(u, starts[k], lens[k], ms, ws, kind, scale, gaps, work, kc,
                                tmp, out[c0 + k], row_kept)  # fmt: skip
                continue
            q = work[5:]
            _local_prefix(u, lo, hi, sample_median(u, lo, hi, tmp), work[0], work[1])
            aloc = np.empty(size, dtype=np.int64)
            runs = np.empty(size + 1, dtype=np.int64)
            n_runs = np.int64(0)
            for k in range(size):
                aloc[k] = starts[k] - lo
                # runs of one length with consecutive starts take the contiguous fast path
                if k == 0 or lens[k] != lens[k - 1] or aloc[k] != aloc[k - 1] + 1:
                    runs[n_runs] = k
                    n_runs += 1
            runs[n_runs] = size
            res = np.empty(size)
            counts = np.empty(size, dtype=np.int64)
            for t in range(ms.size):
                m = ms[t]
                w = ws[t]
                norm = _norm(kind, m, scale)
                # span of this m's terms, and whether one prefix over it pays (the windows
                # overlap)
                span = np.int64(0)
                total = 0
                for k in range(size):
                    if 3 * m <= lens[k]:
                        n = _terms(kind, lens[k], m)
                        span = max(span, aloc[k] + n)
                        total += n
                if total > 0 and span <= 2 * total:
                    _fill(work, kind, m, np.int64(0), span)
                    if gaps is None:
                        big = _prefix_squares(work[4], span, q, np.bool_(False))
                        _eval_runs(q, aloc, lens, runs, n_runs, kind, m, norm, res)
                        # a window's error is at most n 2**-53 big, i.e. 2**-50 of its sum
                        # when its value (sum * norm / n) is at least big * norm / 8: else
                        # the three-part sums
                        floor = big * norm / 8.0
                        for k in range(size):
                            if res[k] < floor:
                                _prefix_squares(work[4], span, q, np.bool_(True))
                                _eval_runs(q, aloc, lens, runs, n_runs, kind, m, norm, res)
                                break
                    else:
                        cnt, pm = gaps
                        _mask_terms(work[4], kc, lo, span, m, w, kind, cnt, pm)
                        big = _prefix_squares(work[4], span, q, np.bool_(False))
                        if _eval_kept(q, kc, aloc, lens, kind, m, norm, big, res, counts):
                            _prefix_squares(work[4], span, q, np.bool_(True))
                            _eval_kept(q, kc, aloc, lens, kind, m, norm, 0.0, res, counts)
                else:
                    for k in range(size):
                        L = lens[k]
                        counts[k] = 0
                        if 3 * m > L:
                            res[k] = np.nan
                            continue
                        n = _terms(kind, L, m)
                        s, c = _own_sum(work, kc, kind, m, w, aloc[k], lo + aloc[k], n, gaps)
                        counts[k] = c
                        res[k] = np.nan if c == 0 else max(s, 0.0) * (norm / c)
                for k in range(size):
                    out[c0 + k, t] = res[k]
                if gaps is not None:
                    for k in range(size):
                        kept[c0 + k, t] = counts[k]


def _run(u, ms, ws, centres, lengths, offset, chunk, workers, kind, scale, gaps, out, kept,
         span) -> None:  # fmt: skip
    if centres.size:
        # the moving sums cost about twice a difference per sample
        work = span * ms.size * (2 if kind == MVAR else 1)
        window_kernel.run(work, workers, u, ms, ws, centres, lengths, int(offset), chunk,
                          workers, int(kind), float(scale), gaps, out, kept)  # fmt: skip


def window_variance(
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
    """Overlapping Allan, Hadamard or modified Allan variance of many windows of ``samples``.

    Parameters
    ----------
    samples : ndarray of float64
        The (mirror-extended) rate samples, or phase increments.
    ms : ndarray of int
        Averaging factors.
    centres, lengths : ndarray of int
        Window ``c`` holds ``samples[a : a + lengths[c]]``,
        ``a = centres[c] - (lengths[c] - 1) // 2 + offset`` (the convention of
        :mod:`adavar.dynamic.windows`).
    stat : {"oavar", "ohvar", "mvar"}
        The statistic (or its deviation's name: ``"oadev"``, ``"ohdev"``, ``"mdev"``).
    offset : int
        Shift from centre indices to indices of ``samples`` (the mirrored samples before
        the record, less the start of a piece read out of core).
    scale : float
        Multiplies every variance (``1 / tau0**2`` for phase input).
    chunk : int
        Consecutive windows per unit of work.
    out : ndarray, shape (len(centres), len(ms)), optional
        Written in place (rows of a larger surface).

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
    no_kept = np.zeros((0, 0), dtype=np.int64)
    _run(u, ms, np.zeros(ms.size, dtype=np.int64), centres, lengths, offset, chunk, workers,
         kind, scale, None, out, no_kept, span)  # fmt: skip
    return out


def window_gaps(
    samples: np.ndarray,
    ms: np.ndarray,
    centres: np.ndarray,
    lengths: np.ndarray,
    *,
    stat: str,
    cnt: np.ndarray,
    pm: np.ndarray,
    ws: np.ndarray,
    offset: int = 0,
    scale: float = 1.0,
    chunk: int = 4096,
) -> tuple[np.ndarray, np.ndarray]:
    """Variance of the kept terms of many windows of ``samples`` at every factor ``ms``.

    Parameters
    ----------
    samples : ndarray of float64
        The mirror-extended rate samples or phase increments, missing ones filled with
        finite values.
    ms : ndarray of int
        Averaging factors.
    centres, lengths : ndarray of int
        Window ``c`` holds ``samples[a : a + lengths[c]]``,
        ``a = centres[c] - (lengths[c] - 1) // 2 + offset``.
    stat : {"oadev", "ohdev", "mdev"}
        The statistic.
    cnt : ndarray of int64
        Prefix count of the missing samples (or phase points) of the extended record.
    pm : ndarray of uint8
        Missing flag of every extended phase point (read only where ``ws`` is 0).
    ws : ndarray of int64
        The keep test's window per factor (:meth:`adavar.stats.gaps.GapLayout.windows`).
    offset, scale, chunk
        As for :func:`window_variance`.

    Returns
    -------
    avar : ndarray, shape (len(centres), len(ms))
        NaN where ``3 m > L`` or no term is kept.
    kept : ndarray of int64, same shape
        Kept terms per cell.
    """
    kind = KINDS.get(stat)
    if kind is None:
        raise ValueError(f"internal: unknown window statistic {stat!r}")
    u = read_only(samples, np.float64)
    ms = read_only(ms, np.int64)
    ws = read_only(ws, np.int64)
    centres = read_only(centres, np.int64)
    lengths = read_only(lengths, np.int64)
    cnt = read_only(cnt, np.int64)
    pm = read_only(pm, np.uint8)
    if centres.shape != lengths.shape or centres.ndim != 1 or ws.shape != ms.shape:
        raise ValueError("internal: centres/lengths or ms/ws of different shapes")
    nc, nt = centres.size, ms.size
    out = np.empty((nc, nt))
    kept = np.zeros((nc, nt), dtype=np.int64)
    if not nc:
        return out, kept
    first, stop = _window_extent(centres, lengths, int(offset))
    if first < 0 or stop > u.size or cnt.size < u.size + 2 or pm.size < u.size + 1:
        raise ValueError("internal: a window runs past the data or its gap layout")
    chunk = int(max(chunk, 1))
    workers = work_items(-(-nc // chunk))
    _run(u, ms, ws, centres, lengths, offset, chunk, workers, kind, scale, (cnt, pm), out,
         kept, max(nc, stop - first))  # fmt: skip
    return out, kept

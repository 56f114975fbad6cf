"""Exact finite differences of the integrated signal, and fast sums of their squares.

Every Allan-family statistic is a sum of squared finite differences of the integrated
signal (the "phase" ``S[j] = sum(u[0..j-1])`` of the increments ``u``). Computed from a plain
cumulative sum these lose digits: with a constant offset of 1e6 standard deviations, or a
drift, or a random walk, ``S`` grows far larger than the differences taken from it.

This module stores the integrated signal in an *anchored* form: every ``BLOCK`` samples an
anchor ``H[b] = S[b * BLOCK]`` held in double-double precision (``hh + hl``), and inside the
block the local sum ``r[j] = S[j] - H[j // BLOCK]`` as a plain double computed with a
compensated sum. ``r`` never exceeds one block's worth of data, so a difference
``sum_k c_k S[i + k m]`` splits into an exactly computed anchor part (constant over runs of
``i``) plus a small local part that vectorises. The error of every difference is then a few
ulps of the difference itself, whatever the offset, drift or length of the record.

The kernels here know nothing about statistics; :mod:`adavar.stats.statistics` builds on them.
The DAVAR engine's window kernel lives in :mod:`adavar._kernels.window_engine` (it keeps a
window's span in double-double instead).
"""

from __future__ import annotations

import numpy as np

# The integration pass and the overlapping sums run their independent blocks on several
# threads from RECORD_THREADS_MIN samples on (threaded kernels, :class:`adavar._kernels._jit.
# ThreadedKernel`), serially below: on 2 cores the serial form is faster up to about 1e6
# samples (a thread's start costs more than the work), the threaded one about 1.7x faster at
# 1e7 (issue 42). Each block is computed the same way on any thread and the partial sums
# are added in block order, so the result does not depend on the thread count.
from adavar._kernels._jit import grouped_items, jit, prange, read_only, threaded_jit
from adavar._kernels.difference_runs import (
    BLOCK,
    SHIFT,
    accumulate,
    fill2,
    slide_window_sum,
    squares,
    strided_run,
)
from adavar._kernels.double_double import dd_add, two_sum

__all__ = [
    "BLOCK",
    "FUSED_LEVELS",
    "AnchoredPhase",
    "anchored_phase",
    "cluster_lag1",
    "cluster_sums",
    "fused_lag1",
    "fused_lag1_levels",
    "modified_sums_kernel",
    "overlapping_sums_kernel",
    "strided_sums_kernel",
]

SUPERBLOCK = 1 << 14  # terms per parallel work item; each touches a few 128 KiB chunks
#: Samples (or terms) from which the whole-record kernels use every thread.
RECORD_THREADS_MIN = 1 << 21


# ---------------------------------------------------------------------------------------
# building the anchored phase


#: Averaging factors whose lag-1 noise-identification sums ride along the integration pass.
FUSED_LEVELS = 6  # m = 1, 2, 4, ..., 32


@jit(fastmath=True)
def _block_cluster_stats(rb, total, m, k_first, count, kc, out):  # pragma: no cover
    """Moments of one block's m-cluster sums (cluster k covers increments k m .. k m + m - 1).

    ``rb`` is the block's local integral (``rb[0] = 0``), ``total`` the integral at the block
    end. Fills ``out`` with sum z, sum (k - kc) z, sum z^2, sum z_{k-1} z_k (pairs inside
    the block), max |z|, first z, last z, and the number of clusters.
    """
    nq = max(min(rb.size // m, count - k_first), 0)
    s1 = 0.0
    st = 0.0
    s2 = 0.0
    s11 = 0.0
    zmax = 0.0
    prev = 0.0
    first = 0.0
    z = 0.0
    for q in range(nq):
        hi = (q + 1) * m
        z = (rb[hi] if hi < rb.size else total) - rb[q * m]
        s1 += z
        st += (k_first + q - kc) * z
        s2 += z * z
        if q > 0:
            s11 += prev * z
        else:
            first = z
        zmax = max(zmax, abs(z))
        prev = z
    out[0] = s1
    out[1] = st
    out[2] = s2
    out[3] = s11
    out[4] = zmax
    out[5] = first
    out[6] = z
    out[7] = nq


#: entries of a block's row of moments per level: 8 of the cluster sums
#: (:func:`_block_cluster_stats`), 4 of the decimated phase (:func:`_block_phase_moments`)
STATS_WIDTH = 12


@jit(fastmath=True)
def _block_phase_moments(rb, j0, n, nlev, out, buf):  # pragma: no cover - compiled
    """Moments of one block's points of the decimated phase ``S[k m]`` at every fused
    level, for the lag-1 test on the phase (:mod:`adavar._kernels.decimated_phase`).

    At level ``m = 2**lev`` the points are the cluster starts of
    :func:`_block_cluster_stats`, ``q = 0 .. nq-1``, taken as the block's local sums
    ``rb[q m]`` (the anchor is added when the blocks are combined); each level's points
    are every other one of the level below, copied into ``buf`` (so that every sum runs
    over contiguous values). Fills ``out[lev, 8:12]`` with sum rb, sum q rb, sum q^2 rb
    and sum rb^2. Any summation order will do (fast-math): those sums are used with a
    bound on their error.
    """
    points = rb
    at = 0
    for lev in range(nlev):
        if lev > 0:
            below = points
            points = buf[at : at + (below.size + 1) // 2]
            for i in range(points.size):
                points[i] = below[2 * i]
            at += points.size
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        s3 = 0.0
        for q in range(max(min(rb.size >> lev, (n >> lev) - (j0 >> lev)), 0)):
            p = points[q]
            fq = float(q)
            s0 += p
            s1 += fq * p
            s2 += (fq * fq) * p
            s3 += p * p
        out[lev, 8] = s0
        out[lev, 9] = s1
        out[lev, 10] = s2
        out[lev, 11] = s3


@threaded_jit
def _prefix_blocks(u, shift, nlev, stats, r, tot_h, tot_l, per, lo, hi):  # pragma: no cover
    """Blocks ``lo * per .. hi * per - 1`` of the integration: each block's local sums
    ``r`` (compensated), its total, and its cluster and decimated-phase moments for the
    fused levels."""
    n = u.size
    npts = n + 1
    nb = tot_h.size
    buf = np.empty(BLOCK)  # the decimated-phase points of levels 1, 2, ...
    for b in range(lo * per, min(hi * per, nb)):
        j0 = b << SHIFT
        j1 = min(j0 + BLOCK, npts)
        # the block's increments, including the one that leads to the next anchor
        seg = u[j0 : min(j0 + BLOCK, n)]
        out = r[j0 + 1 : j1]
        s = 0.0
        c = 0.0
        r[j0] = 0.0
        for k in range(out.size):
            s, e = two_sum(s, seg[k] - shift)
            c += e
            out[k] = s + c
        if seg.size > out.size:
            s, e = two_sum(s, seg[seg.size - 1] - shift)
            c += e
        h = s + c
        tot_h[b] = h
        tot_l[b] = c - (h - s)
        for lev in range(nlev):
            m = 1 << lev
            count = n // m
            k_first = j0 // m
            if k_first < count:
                _block_cluster_stats(
                    r[j0:j1], h, m, k_first, count, 0.5 * (count - 1), stats[b, lev]
                )
        if nlev:
            _block_phase_moments(r[j0:j1], j0, n, nlev, stats[b], buf)


@jit
def _anchored_prefix(n, nlev, stats, fused, tot_h, tot_l):  # pragma: no cover - compiled
    # stats (one row per block and level, filled by _prefix_blocks) and fused come
    # from the caller: allocating them here would compile np.zeros for 3-D and 2-D arrays
    nb = tot_h.size
    hh = np.empty(nb)
    hl = np.empty(nb)
    ah = 0.0
    al = 0.0
    for b in range(nb):
        hh[b] = ah
        hl[b] = al
        ah, al = dd_add(ah, al, tot_h[b], tot_l[b])

    # per level m = 2**lev, from the block moments: the order-0 lag-1 statistics of the
    # detrended m-cluster sums, fused[lev] = (r1, den, zmax, ok), the least-squares line
    # removed algebraically; ok = 0 (and r1 NaN) with fewer than 8 clusters, or where the
    # series is so dominated by its trend that the algebra would cancel away the noise.
    # (Written out here, scalars only: a helper kernel, or array temporaries, cost about
    # 0.4 s more to compile on a cold cache.)
    for lev in range(nlev):
        fused[lev, 0] = np.nan
        fused[lev, 1] = 0.0
        fused[lev, 2] = 0.0
        fused[lev, 3] = 0.0
        c = n >> lev
        if c < 8:
            continue
        z1 = 0.0
        zt = 0.0
        z2 = 0.0
        zin = 0.0
        zs = 0.0  # lag products inside blocks, and of the pairs straddling block boundaries
        zmax = 0.0
        z_first = 0.0
        z_last = 0.0
        for b in range(nb):
            if stats[b, lev, 7] <= 0:  # the blocks holding clusters are a prefix
                break
            z1 += stats[b, lev, 0]
            zt += stats[b, lev, 1]
            z2 += stats[b, lev, 2]
            zin += stats[b, lev, 3]
            if stats[b, lev, 4] > zmax:
                zmax = stats[b, lev, 4]
            if b == 0:
                z_first = stats[b, lev, 5]
            else:
                zs += z_last * stats[b, lev, 5]
            z_last = stats[b, lev, 6]
        cf = 1.0 * c  # exact; its square rounds once, as the integer's would
        kc = 0.5 * (cf - 1.0)
        stt = cf * (cf * cf - 1.0) / 12.0
        alpha = z1 / cf
        beta = zt / stt
        den = z2 - cf * alpha * alpha - stt * beta * beta
        fused[lev, 1] = den
        fused[lev, 2] = zmax
        # below 1e-6 the cancellation would cost r1 more than 1e-9: stream the data instead
        if not den > 1e-6 * z2:
            continue
        # t_first = -kc, t_last = kc: the abscissae of the first and last clusters
        cross1 = alpha * (z1 - z_last) + beta * (zt - kc * z_last) + beta * (z1 - z_last)
        cross2 = alpha * (z1 - z_first) + beta * (zt + kc * z_first) - beta * (z1 - z_first)
        lines = (
            (cf - 1.0) * alpha * alpha
            + alpha * beta * (cf - 1.0 - 2.0 * kc)
            + beta * beta * (stt - kc * kc - kc)
        )
        fused[lev, 0] = ((zin + zs) - cross1 - cross2 + lines) / den
        fused[lev, 3] = 1.0
    return hh, hl


def _median(values: np.ndarray) -> float:
    """``numpy.median`` of a short finite array, bit for bit, without its overhead."""
    n = values.size
    half = n // 2
    part = values.copy()
    part.partition((half - 1, half, n - 1) if n > 1 else (0,))
    if part[-1] != part[-1]:  # a NaN sorts last and makes the median NaN
        return float("nan")
    if n % 2:
        return float(part[half])
    return float((part[half - 1] + part[half]) / 2)


class AnchoredPhase:
    """The integrated signal ``S[j] = sum(u[0..j-1] - shift)``, ``j = 0..len(u)``, anchored.

    Parameters
    ----------
    r : ndarray
        Local part, ``S[j] - H[j // BLOCK]``.
    hh, hl : ndarray
        Anchors ``H[b] = S[b * BLOCK]`` as double-double (high, low).
    shift : float
        Constant removed from every increment before summing. Differences whose
        coefficients annihilate linear sequences (all the ones used here) do not depend on it.
    """

    __slots__ = ("cluster_stats", "fused", "hh", "hl", "r", "shift")

    def __init__(
        self,
        r: np.ndarray,
        hh: np.ndarray,
        hl: np.ndarray,
        shift: float,
        cluster_stats: np.ndarray | None = None,
        fused: np.ndarray | None = None,
    ) -> None:
        self.r = r
        self.hh = hh
        self.hl = hl
        self.shift = shift
        #: per block and level m = 2**lev: the moments of :func:`_block_cluster_stats`
        #: (entries 0-7) and of :func:`_block_phase_moments` (8-11)
        self.cluster_stats = cluster_stats
        #: per level: the order-0 lag-1 statistics computed from them (r1, den, zmax, ok)
        self.fused = fused

    @property
    def n_points(self) -> int:
        """Number of points of the integrated signal (increments + 1)."""
        return int(self.r.size)

    def values(self) -> np.ndarray:
        """``S`` rounded to double (for tests and small diagnostics)."""
        b = np.arange(self.r.size) >> SHIFT
        return (self.hh[b] + self.r) + self.hl[b]


def anchored_phase(
    increments: np.ndarray, shift: float | None = None, *, cluster_stats: bool = False
) -> AnchoredPhase:
    """Integrate ``increments`` into an :class:`AnchoredPhase`.

    Parameters
    ----------
    increments : ndarray of float64
        ``u[i] = S[i+1] - S[i]``: rate samples times ``tau0`` or first differences of phase.
    shift : float, optional
        Constant subtracted from each increment first; default the median of the first
        block, which removes a constant offset exactly (the subtraction rounds relative to
        the residual only) and is not dragged away by a spike. The local sums ``r`` grow
        with the distance of the data's level from ``shift``, so two excursions cost
        digits (measured on unit white noise): a level step of ``D`` standard deviations
        (not a drift, which the anchors absorb) about ``1e-13 * D`` relative in the
        differences after it (1e3 sigma: 1e-10; 1e6 sigma: 1e-7); a spike of ``D`` sigma
        about ``1e-16 * D`` in the rest of its 1024-sample block. A whole-record statistic
        across such a step is dominated by the step's own terms; the DAVAR windows, which
        need not hold it, are computed from a double-double span instead
        (:mod:`adavar._kernels.window_engine`) and lose nothing.
    cluster_stats : bool
        Also gather, in the same pass, the moments that the lag-1 noise identification
        needs for ``m = 1, 2, 4, ..., 2**(FUSED_LEVELS-1)``: of the cluster sums (see
        :func:`fused_lag1`) and of the decimated phase
        (:func:`adavar._kernels.decimated_phase.fused_phase_levels`).
    """
    u = np.ascontiguousarray(increments, dtype=np.float64)
    if shift is None:
        shift = _median(u[:BLOCK]) if u.size else 0.0
    nlev = FUSED_LEVELS if cluster_stats else 0
    stats = np.zeros((1 + (u.size >> SHIFT), max(nlev, 1), STATS_WIDTH))  # a row per block
    fused = np.empty((max(nlev, 1), 4))
    nb = (u.size + BLOCK) >> SHIFT  # blocks of the u.size + 1 phase points
    r = np.empty(u.size + 1)
    tot_h = np.zeros(nb)
    tot_l = np.zeros(nb)
    per, items = grouped_items(nb, least=16)
    work = u.size if u.size >= RECORD_THREADS_MIN else 0
    _prefix_blocks.run(work, items, read_only(u), float(shift), nlev, stats, r, tot_h, tot_l,
                       per)  # fmt: skip
    hh, hl = _anchored_prefix(u.size, nlev, stats, fused, tot_h, tot_l)
    if not cluster_stats:
        return AnchoredPhase(r, hh, hl, shift)
    return AnchoredPhase(r, hh, hl, shift, stats, fused)


# ---------------------------------------------------------------------------------------
# drivers: the whole record's sums, from the inner kernels of adavar._kernels.difference_runs.
# ``gaps`` is None, or ``(cnt, ws, pm)`` (adavar.stats.gaps.GapLayout: prefix counts of missing
# samples, the keep test's window per tau, missing phase points) to leave out the terms
# that touch a missing sample and count those kept.


@threaded_jit
def _overlap_partials(
    r, hh, hl, ms, starts, counts, coefs, gaps, partial, kept, per, lo, hi
):  # pragma: no cover
    """Superblocks ``lo * per .. hi * per - 1`` of :func:`overlapping_sums_kernel`: every
    tau's sum over each, into ``partial[sb * nt + t]`` (terms summed: ``kept``)."""
    nt = ms.size
    nsb = partial.size // nt
    for sb in range(lo * per, min(hi * per, nsb)):
        b0 = sb * SUPERBLOCK
        b1 = b0 + SUPERBLOCK
        for t in range(nt):
            lo_t = max(b0, starts[t])
            hi_t = min(b1, starts[t] + counts[t])
            if lo_t >= hi_t:
                continue
            m = ms[t]
            if gaps is None:
                acc, n = squares(r, m, np.int64(0), lo_t, hi_t, m, hh, hl, coefs, None)
            else:
                cnt, ws, pm = gaps
                acc, n = squares(r, m, np.int64(0), lo_t, hi_t, m, hh, hl, coefs, (cnt, ws[t], pm))
            partial[sb * nt + t] = acc
            kept[sb * nt + t] = n


@jit
def _superblock_totals(partial, kept, nt):  # pragma: no cover - compiled
    """Each tau's sum of its superblocks' partial sums, in superblock order, and terms."""
    nsb = partial.size // nt
    out = np.zeros(nt)
    terms = np.zeros(nt, dtype=np.int64)
    for t in range(nt):
        total = 0.0
        n = 0
        for sb in range(nsb):
            total += partial[sb * nt + t]
            n += kept[sb * nt + t]
        out[t] = total
        terms[t] = n
    return out, terms


def overlapping_sums_kernel(
    r, hh, hl, ms, starts, counts, coefs, gaps=None
) -> tuple[np.ndarray, np.ndarray]:
    """``sum_{i=start}^{start+count-1} (sum_k coefs[k] S[i + k m])^2`` for every tau, and
    the number of terms summed (``counts`` without ``gaps``).

    Fused over taus: each work item takes superblocks of ``i`` and runs every tau over
    them, so the chunks of ``r`` that neighbouring octaves share stay in cache; from
    :data:`RECORD_THREADS_MIN` terms on, on every thread.
    """
    nt = ms.size
    imax = int(np.max(starts + counts)) if nt else 0
    nsb = (imax + SUPERBLOCK - 1) // SUPERBLOCK
    partial = np.zeros(nsb * nt)
    kept = np.zeros(nsb * nt, dtype=np.int64)
    per, items = grouped_items(nsb)
    work = imax if imax >= RECORD_THREADS_MIN else 0
    _overlap_partials.run(work, max(items, 1), r, hh, hl, ms, starts, counts, coefs, gaps,
                          partial, kept, per)  # fmt: skip
    return _superblock_totals(partial, kept, nt)


@jit
def strided_sums_kernel(r, hh, hl, ms, counts, coefs, gaps):  # pragma: no cover - compiled
    """Non-overlapping version: terms at ``i = 0, m, 2m, ...`` (``counts[t]`` of them);
    returns the sums and the terms summed."""
    nt = ms.size
    out = np.zeros(nt)
    kept = np.zeros(nt, dtype=np.int64)
    for t in range(nt):
        m = ms[t]
        zero = np.int64(0)
        if gaps is None:
            out[t], kept[t] = strided_run(r[::m], zero, counts[t], m, hh, hl, coefs, 0.0, zero,
                                          None)  # fmt: skip
        else:
            cnt, ws, pm = gaps
            missing = (cnt[::m], cnt[ws[t] :: m], pm[::m])
            out[t], kept[t] = strided_run(r[::m], zero, counts[t], m, hh, hl, coefs, 0.0, zero,
                                          missing)  # fmt: skip
    return out, kept


_MOD_CHUNK = 1 << 14
#: Starts ``j`` of one work item of the modified sums (fixed: the sums do not depend on the
#: thread count; a record shorter than this is one item, the sequential pass itself)
MOD_PART = 1 << 21


@jit
def _modified_part(r, hh, hl, m, j0, j1, cnt, w):  # pragma: no cover - compiled
    """``sum_{j=j0}^{j1-1} (sum_{i=j}^{j+m-1} d_m[i])^2``, the window sum started afresh
    at ``j0`` and slid with a compensated running total, and the terms summed (with prefix
    counts ``cnt``, only the starts ``j`` with ``cnt[j + w] == cnt[j]``)."""
    first = np.empty(m)
    fill2(r[j0:], r[j0 + m :], r[j0 + 2 * m :], j0, j0 + m, m, hh, hl, first)
    s, c = accumulate(first, m, 0.0, 0.0)
    total = s + c
    acc = 0.0
    n = np.int64(0)
    keep_first = True
    if cnt is not None:
        keep_first = cnt[j0 + w] == cnt[j0]
    if keep_first:
        acc = total * total
        n = np.int64(1)
    enter = np.empty(min(_MOD_CHUNK, max(j1 - j0 - 1, 0)))  # no more than one chunk needs
    leave = np.empty(enter.size)
    j = j0 + 1
    while j < j1:
        size = min(_MOD_CHUNK, j1 - j)
        a = j + m - 1  # d[a] enters, d[j - 1] leaves
        fill2(r[a:], r[a + m :], r[a + 2 * m :], a, a + size, m, hh, hl, enter)
        fill2(r[j - 1 :], r[j - 1 + m :], r[j - 1 + 2 * m :], j - 1, j - 1 + size, m, hh, hl,
              leave)  # fmt: skip
        if cnt is None:
            s, c, acc, n = slide_window_sum(enter, leave, size, s, c, acc, n, None)
        else:
            s, c, acc, n = slide_window_sum(enter, leave, size, s, c, acc, n,
                                            (cnt[j:], cnt[j + w :]))  # fmt: skip
        j += size
    return acc, n


@threaded_jit
def _modified_partials(
    r, hh, hl, ms, counts, first_part, size, cnt, ws, partial, kept, lo, hi
):  # pragma: no cover
    """Items ``lo .. hi - 1``: item ``k`` is part ``k - first_part[t]`` (starts ``size``
    apart) of tau ``t``, where ``first_part[t] <= k < first_part[t + 1]``."""
    t = 0
    for k in range(lo, hi):
        while first_part[t + 1] <= k:
            t += 1
        j0 = (k - first_part[t]) * size
        partial[k], kept[k] = _modified_part(r, hh, hl, ms[t], j0, min(counts[t], j0 + size),
                                             cnt, ws[t])  # fmt: skip


def modified_sums_kernel(
    r, hh, hl, ms, counts, gaps=None, part=None
) -> tuple[np.ndarray, np.ndarray]:
    """``sum_j (sum_{i=j}^{j+m-1} d_m[i])^2`` for ``j = 0..count-1``: the MVAR numerator,
    and the number of terms summed.

    The inner sum slides along ``j`` with a compensated running total, fed by chunks of
    second differences computed exactly (entering and leaving streams), so the cost is
    O(N) per tau whatever ``m``. Parts of ``part`` starts (default :data:`MOD_PART`) run
    on every thread from :data:`RECORD_THREADS_MIN` terms on, each part's sum added in
    order. ``gaps`` is ``None`` or ``(cnt, ws)`` (prefix counts of missing samples, the
    window of the keep test per tau).
    """
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    counts = np.ascontiguousarray(counts, dtype=np.int64)
    size = int(MOD_PART if part is None else part)  # an argument: compiled, a global freezes
    parts = np.maximum(1, -(-counts // size))
    first_part = np.concatenate(([0], np.cumsum(parts))).astype(np.int64)
    partial = np.zeros(int(first_part[-1]))
    kept = np.zeros(partial.size, dtype=np.int64)
    terms = int(counts.sum()) if counts.size else 0
    work = terms if terms >= RECORD_THREADS_MIN else 0
    cnt, ws = gaps if gaps is not None else (None, np.zeros(ms.size, dtype=np.int64))
    if partial.size:
        _modified_partials.run(work, partial.size, r, hh, hl, ms, counts, first_part, size,
                               cnt, ws, partial, kept)  # fmt: skip
    sums = np.array([partial[first_part[t] : first_part[t + 1]].sum() if parts[t] > 1
                     else partial[first_part[t]] for t in range(ms.size)])  # fmt: skip
    terms_kept = np.array([kept[first_part[t] : first_part[t + 1]].sum()
                           for t in range(ms.size)], dtype=np.int64)  # fmt: skip
    return sums, terms_kept


@jit
def cluster_sum(r, hh, hl, j0, m):  # pragma: no cover - compiled
    """``S[j0 + m] - S[j0]``; plain difference when both ends share an anchor block."""
    j1 = j0 + m
    b0 = j0 >> SHIFT
    b1 = j1 >> SHIFT
    if b0 == b1:
        return r[j1] - r[j0]
    dh, dl = dd_add(hh[b1], hl[b1], -hh[b0], -hl[b0])
    return (dh + (r[j1] - r[j0])) + dl


@jit
def cluster_differences(r, hh, hl, m, count):  # pragma: no cover - compiled
    """``S[(k+1) m] - S[k m]`` for ``k = 0..count-1`` (sums over non-overlapping clusters)."""
    out = np.empty(count)
    for q in range(count):
        out[q] = cluster_sum(r, hh, hl, q * m, m)
    return out


@jit
def cluster_lag1_sums(r, hh, hl, m, count, dmax):  # pragma: no cover - compiled
    """Lag-1 autocorrelations of the linearly detrended cluster sums, differenced 0..dmax times.

    Streams the cluster sums twice (line fit, then all difference orders at once) in
    parallel chunks instead of materialising and refitting the series: O(N/m) time, O(1)
    extra memory. ``dmax`` <= 3.
    """
    # (arrays are flat and reduced by loops, in chunk order as np.sum would: 2-D and 3-D
    # np.zeros, np.sum, np.max, np.full cost over a second of compilation on a cold cache)
    nch = max(1, min(256, count // 8192))
    kc = 0.5 * (count - 1)
    part1 = np.zeros(nch * 3)  # [ch, 0..2]
    for ch in prange(nch):
        k0 = (count * ch) // nch
        k1 = (count * (ch + 1)) // nch
        sz = 0.0
        stz = 0.0
        zmax = 0.0
        for k in range(k0, k1):
            z = cluster_sum(r, hh, hl, k * m, m)
            sz += z
            stz += (k - kc) * z
            zmax = max(zmax, abs(z))
        part1[3 * ch] = sz
        part1[3 * ch + 1] = stz
        part1[3 * ch + 2] = zmax
    sz = 0.0
    stz = 0.0
    zmax = 0.0  # the largest of non-negative numbers
    for ch in range(nch):
        sz += part1[3 * ch]
        stz += part1[3 * ch + 1]
        zmax = max(zmax, part1[3 * ch + 2])
    stt = count * (count * count - 1.0) / 12.0
    a = sz / count
    b = stz / stt if stt > 0 else 0.0

    # per chunk and order d: sum x, sum x^2, sum x_{k-1} x_k (pairs whose later index is here)
    nd = dmax + 1
    part2 = np.zeros(nch * 12)  # [ch, d, 0..2]
    for ch in prange(nch):
        k0 = (count * ch) // nch
        k1 = (count * (ch + 1)) // nch
        q0 = 0.0  # previous values of orders 0..3
        q1 = 0.0
        q2 = 0.0
        q3 = 0.0
        # local accumulators (kept in registers): sum x, sum x^2, sum of lag products
        a0 = a1 = a2 = a3 = 0.0
        b0 = b1 = b2 = b3 = 0.0
        c0 = c1 = c2 = c3 = 0.0
        for k in range(max(0, k0 - 4), k1):
            x0 = cluster_sum(r, hh, hl, k * m, m) - (a + b * (k - kc))
            x1 = x0 - q0
            x2 = x1 - q1
            x3 = x2 - q2
            if k >= k0:
                a0 += x0
                b0 += x0 * x0
                if k >= 1:
                    c0 += q0 * x0
                if nd > 1:
                    if k >= 1:
                        a1 += x1
                        b1 += x1 * x1
                    if k >= 2:
                        c1 += q1 * x1
                        a2 += x2
                        b2 += x2 * x2
                    if k >= 3:
                        c2 += q2 * x2
                        a3 += x3
                        b3 += x3 * x3
                    if k >= 4:
                        c3 += q3 * x3
            q0 = x0
            q1 = x1
            q2 = x2
            q3 = x3
        at = 12 * ch
        part2[at] = a0
        part2[at + 1] = b0
        part2[at + 2] = c0
        part2[at + 3] = a1
        part2[at + 4] = b1
        part2[at + 5] = c1
        part2[at + 6] = a2
        part2[at + 7] = b2
        part2[at + 8] = c2
        part2[at + 9] = a3
        part2[at + 10] = b3
        part2[at + 11] = c3

    # first and last values of each order, for the centred lag-1 sum (count >= 4)
    h = np.empty(4)
    t = np.empty(4)
    for q in range(4):
        h[q] = cluster_sum(r, hh, hl, q * m, m) - (a + b * (q - kc))
        k = count - 4 + q
        t[q] = cluster_sum(r, hh, hl, k * m, m) - (a + b * (k - kc))
    first = np.empty(4)
    first[0] = h[0]
    first[1] = h[1] - h[0]
    first[2] = (h[2] - h[1]) - (h[1] - h[0])
    first[3] = h[3] - 3 * h[2] + 3 * h[1] - h[0]
    last = np.empty(4)
    last[0] = t[3]
    last[1] = t[3] - t[2]
    last[2] = (t[3] - t[2]) - (t[2] - t[1])
    last[3] = t[3] - 3 * t[2] + 3 * t[1] - t[0]

    r1 = np.empty(nd)
    den = np.zeros(nd)
    for d in range(nd):
        r1[d] = np.nan
        c = count - d
        if c < 2:
            continue
        s1 = 0.0
        s2 = 0.0
        s11 = 0.0
        for ch in range(nch):
            s1 += part2[12 * ch + 3 * d]
            s2 += part2[12 * ch + 3 * d + 1]
            s11 += part2[12 * ch + 3 * d + 2]
        mean = s1 / c
        den[d] = s2 - c * mean * mean
        num = s11 - mean * ((s1 - last[d]) + (s1 - first[d])) + (c - 1) * mean * mean
        if den[d] > 0:
            r1[d] = num / den[d]
    return r1, den, zmax


# ---------------------------------------------------------------------------------------
# the noise identification's cluster statistics


def cluster_lag1(phase: AnchoredPhase, m: int, dmax: int):
    """Lag-1 autocorrelation of the linearly detrended m-cluster sums.

    Returns ``(r1, den, n, zmax)``: for ``d = 0..dmax`` differences the autocorrelation
    (NaN where undefined), its denominator ``sum (x - mean)^2`` and the series length, and
    the largest absolute cluster sum (the scale of the raw series).
    """
    count = (phase.n_points - 1) // m
    if count < 8 or not 0 <= dmax <= 3:
        raise ValueError("internal: lag-1 statistics need >= 8 clusters and dmax <= 3")
    r1, den, zmax = cluster_lag1_sums(phase.r, phase.hh, phase.hl, int(m), count, int(dmax))
    return r1, den, np.maximum(count - np.arange(dmax + 1), 0), zmax


def fused_lag1_levels(phase: AnchoredPhase):
    """Order-0 lag-1 statistics of every fused level ``m = 1, 2, 4, ...`` at once.

    The quantity of ``cluster_lag1(phase, m, 0)`` for each ``m = 2**level`` below
    ``2**FUSED_LEVELS``, from the moments gathered during integration (no further pass over
    the data), with the least-squares line removed algebraically. Returns ``None`` without
    moments, else ``(r1, den, counts, zmax, ok)``, one entry per level: ``ok`` is False
    where there are fewer than 8 clusters or the series is so dominated by its trend that
    the algebraic removal would lose the noise (the caller then streams the data with
    :func:`cluster_lag1`); ``r1`` is NaN there.
    """
    out = phase.fused  # computed with the moments, by _anchored_prefix
    if out is None:
        return None
    counts = (phase.n_points - 1) >> np.arange(out.shape[0], dtype=np.int64)
    return out[:, 0], out[:, 1], counts, out[:, 2], out[:, 3] > 0


def fused_lag1(phase: AnchoredPhase, m: int):
    """Order-0 lag-1 autocorrelation of the detrended m-cluster sums from the fused moments.

    Same quantity as ``cluster_lag1(phase, m, 0)`` but from the moments gathered during
    integration (one level of :func:`fused_lag1_levels`). Returns ``None`` when ``m`` is not
    a fused level, or when the series is too short or so dominated by its trend that the
    algebraic removal would lose the noise (the caller then streams the data with
    :func:`cluster_lag1`).
    """
    if phase.cluster_stats is None or m & (m - 1) or m >= (1 << FUSED_LEVELS):
        return None
    level = m.bit_length() - 1
    r1, den, c, zmax, ok = fused_lag1_levels(phase)
    if not ok[level]:
        return None
    return (
        r1[level : level + 1],
        den[level : level + 1],
        c[level : level + 1].astype(np.int64),
        float(zmax[level]),
    )


def cluster_sums(phase: AnchoredPhase, m: int) -> np.ndarray:
    """Sums of the increments over non-overlapping clusters of ``m`` (shift added back)."""
    count = (phase.n_points - 1) // m
    out = cluster_differences(phase.r, phase.hh, phase.hl, int(m), count)
    return out + phase.shift * m

"""The whole record's Allan-family sums, chunk by chunk: the one entry to every engine.

:func:`overlapping_sums`, :func:`strided_sums` and :func:`modified_sums` take the anchored
phase of a record in memory (:class:`adavar._kernels.differences.AnchoredPhase`: one chunk, the
kernels run over it at once, on every thread) or of a record read piece by piece
(:class:`StreamedPhase`, built by :func:`streamed_phase` from a
:class:`~adavar.io.sources.ChunkedSource`). Both run the inner kernels of
:mod:`adavar._kernels.difference_runs`; records with missing samples run them too, with
the missing samples as an argument (:mod:`adavar.stats.gaps`).

Out of core, the integrated signal is the same anchored form
(double-double anchors ``H[b]`` every ``BLOCK`` samples, a compensated local sum ``r``
inside each block, the same shift), but only the anchors (16 bytes per 1024 samples) are
kept for the whole record: the local part is recomputed on demand over windows that slide
along the record. Every difference is computed from the same ``H`` and ``r`` values, by the
same kernels, as in memory, so the sums agree with :mod:`adavar._kernels.differences` to a few ulps
whatever the chunk size (only the order of the additions between pieces differs).

Passes over the record (``C`` the chunk size, ``K`` the difference order, ``N`` the length):

* one to build the anchors (:func:`streamed_phase`);
* overlapping differences: one sweep for every ``m`` with ``K m <= C`` (windows of
  ``C + K m`` samples whose overlap is carried, not re-read), then per longer ``m`` ``K``
  streams side by side, ``K (N - K m)`` samples read;
* non-overlapping (strided) differences: one sweep for ``m <= C``, then one short read (at
  most a block) per point ``q m`` for longer ``m``;
* modified sums: as overlapping, with windows of ``C + 3 m`` and four streams for long ``m``.

Working memory is a few ``C`` samples plus the anchors; every window read starts at most one
block (1023 samples) before the samples it needs.
"""

from __future__ import annotations

import numpy as np

from adavar._kernels import differences as diff
from adavar._kernels._jit import grouped_items, jit, threaded_jit
from adavar._kernels.difference_runs import (
    SECOND,
    THIRD,
    accumulate,
    fill2,
    slide_window_sum,
    squares,
    strided_run,
)
from adavar._kernels.double_double import dd_add, two_sum
from adavar.io.sources import DEFAULT_CHUNK, ChunkedSource, read_extended

__all__ = [
    "Phase",
    "ReflectedSource",
    "StreamedPhase",
    "initial_shift",
    "modified_sums",
    "overlapping_sums",
    "streamed_phase",
    "strided_sums",
]

BLOCK = diff.BLOCK
SHIFT = diff.SHIFT
_MASK = BLOCK - 1
_SUPERBLOCK = diff.SUPERBLOCK  # terms per parallel work item
_PARALLEL_MIN = 4 * _SUPERBLOCK  # shorter runs are not worth waking the thread pool


# ---------------------------------------------------------------------------------------
# the anchored phase, piece by piece (exact rounding: no fast-math here)


@jit
def _block_totals(u, u_first, shift, s, c, tot_h, tot_l):  # pragma: no cover - compiled
    """Continue the compensated sum of ``u - shift`` (``u[0]`` is increment ``u_first``).

    Restarts at every block start, and stores each finished block's total as double-double,
    exactly as :func:`adavar._kernels.differences.anchored_phase` does. Returns the running state.
    """
    for q in range(u.size):
        i = u_first + q
        if i & _MASK == 0:
            s = 0.0
            c = 0.0
        s, e = two_sum(s, u[q] - shift)
        c += e
        if (i + 1) & _MASK == 0:
            h = s + c
            tot_h[i >> SHIFT] = h
            tot_l[i >> SHIFT] = c - (h - s)
    return s, c


@jit
def _anchors(tot_h, tot_l, hh, hl):  # pragma: no cover - compiled
    ah = 0.0
    al = 0.0
    for b in range(hh.size):
        hh[b] = ah
        hl[b] = al
        ah, al = dd_add(ah, al, tot_h[b], tot_l[b])


@jit
def _advance(u, u_first, p, q, shift, s, c, out, out_first):  # pragma: no cover - compiled
    """Local phase ``r[j]`` for ``j = p .. q - 1`` into ``out[j - out_first]`` (``j >= out_first``).

    ``(s, c)`` is the compensated state at ``j = p - 1``; ``u[0]`` is increment ``u_first``.
    Returns the state at ``q - 1``.
    """
    for j in range(p, q):
        if j & _MASK == 0:
            s = 0.0
            c = 0.0
            v = 0.0
        else:
            s, e = two_sum(s, u[j - 1 - u_first] - shift)
            c += e
            v = s + c
        if j >= out_first:
            out[j - out_first] = v
    return s, c


@threaded_jit
def _advance_blocks(
    u, u_first, head, q, shift, out, out_first, per, fs, fc, k_lo, k_hi
):  # pragma: no cover - compiled
    """:func:`_advance` over whole blocks from ``head``, each restarting at its start.

    Work item ``k`` is blocks ``k per .. (k + 1) per - 1``; this call runs items
    ``k_lo .. k_hi - 1`` and writes each block's final state into ``fs``, ``fc``.
    """
    for b in range(k_lo * per, min(k_hi * per, fs.size)):
        j0 = head + (b << SHIFT)
        fs[b], fc[b] = _advance(u, u_first, j0, min(j0 + BLOCK, q), shift, 0.0, 0.0, out, out_first)


def _advance_in_threads(u, u_first, p, q, shift, s, c, out, out_first):
    """:func:`_advance` with the whole blocks on several threads."""
    head = min(q, ((p + _MASK) >> SHIFT) << SHIFT)
    s, c = _advance(u, u_first, p, head, shift, s, c, out, out_first)
    nb = (q - head + _MASK) >> SHIFT
    if nb == 0:
        return s, c
    fs = np.empty(nb)
    fc = np.empty(nb)
    per, items = grouped_items(nb, least=16)
    _advance_blocks.run(q - head, items, u, u_first, head, q, shift, out, out_first, per, fs, fc)
    return float(fs[-1]), float(fc[-1])


class StreamedPhase:
    """The anchored integrated signal of a chunked record (see :class:`diff.AnchoredPhase`).

    Parameters
    ----------
    source : ChunkedSource
        The increments ``u`` (rate samples, or first differences of phase).
    shift : float
        Constant removed from every increment before summing.
    hh, hl : ndarray
        Anchors ``H[b] = S[b * BLOCK]`` as double-double.
    chunk_size : int
        Samples per piece.
    """

    __slots__ = ("chunk_size", "hh", "hl", "shift", "source")

    def __init__(
        self,
        source: ChunkedSource,
        shift: float,
        hh: np.ndarray,
        hl: np.ndarray,
        chunk_size: int,
    ) -> None:
        self.source = source
        self.shift = shift
        self.hh = hh
        self.hl = hl
        self.chunk_size = chunk_size

    @property
    def n_points(self) -> int:
        """Number of points of the integrated signal (increments + 1)."""
        return int(self.source.size) + 1


def initial_shift(source: ChunkedSource) -> float:
    """The shift :func:`adavar._kernels.differences.anchored_phase` would choose: median of block
    0."""
    n = source.size
    return float(np.median(source.read(0, min(n, BLOCK)))) if n else 0.0


def streamed_phase(
    source: ChunkedSource, chunk_size: int = DEFAULT_CHUNK, shift: float | None = None
) -> StreamedPhase:
    """Anchor the integral of ``source`` in one pass of ``chunk_size`` pieces.

    Parameters
    ----------
    source : ChunkedSource
        The increments.
    chunk_size : int
        Samples per read.
    shift : float, optional
        As in :func:`adavar._kernels.differences.anchored_phase`; default the median of block 0.
    """
    chunk = max(1, int(chunk_size))
    if shift is None:
        shift = initial_shift(source)
    n = int(source.size)
    nb = (n + BLOCK) >> SHIFT  # blocks of the n + 1 phase points
    tot_h = np.zeros(nb)
    tot_l = np.zeros(nb)
    s = c = 0.0
    for start in range(0, n, chunk):
        u = source.read(start, min(n, start + chunk))
        s, c = _block_totals(u, start, float(shift), s, c, tot_h, tot_l)
    hh = np.empty(nb)
    hl = np.empty(nb)
    _anchors(tot_h, tot_l, hh, hl)
    return StreamedPhase(source, float(shift), hh, hl, chunk)


#: the anchored phase of a record, in memory (one chunk) or read piece by piece
Phase = diff.AnchoredPhase | StreamedPhase


class _Window:
    """Local phase ``r[lo:hi]`` over ranges that slide forward; the overlap is kept, not re-read."""

    __slots__ = ("buf", "c", "lo", "p", "phase", "s")

    def __init__(self, phase: StreamedPhase, buf: np.ndarray | None = None) -> None:
        self.phase = phase
        self.buf = np.empty(0) if buf is None else buf  # a caller's row: filled in place
        self.lo = 0  # buf[k] holds r[lo + k] for lo + k < p
        self.p = -1  # next point to compute; -1: nothing yet
        self.s = 0.0  # compensated state at p - 1
        self.c = 0.0

    def get(self, lo: int, hi: int) -> np.ndarray:
        """``r[lo:hi]`` as a view (valid until the next call)."""
        keep = 0
        if self.p < 0 or lo < self.lo or lo > self.p:
            # start afresh at the block start: r restarts there
            self.p = lo & ~_MASK
            self.s = self.c = 0.0
        else:
            keep = self.p - lo
            if lo > self.lo and keep > 0:
                self.buf[:keep] = self.buf[lo - self.lo : self.p - self.lo]
        self.lo = lo
        if hi - lo > self.buf.size:
            grown = np.empty(hi - lo)
            grown[:keep] = self.buf[:keep]
            self.buf = grown
        if hi > self.p:
            ph = self.phase
            # r[p] needs increment p - 1, except at a block start
            u_first = self.p if self.p & _MASK == 0 else self.p - 1
            u = ph.source.read(u_first, hi - 1) if hi - 1 > u_first else np.empty(0)
            args = (u, u_first, self.p, hi, ph.shift, self.s, self.c, self.buf, lo)
            if hi - self.p >= _PARALLEL_MIN:
                self.s, self.c = _advance_in_threads(*args)
            else:
                self.s, self.c = _advance(*args)
            self.p = hi
        return self.buf[: hi - lo]


# ---------------------------------------------------------------------------------------
# overlapping differences: x_k[q] = r[lo + q + k m], k = 0..order


@threaded_jit
def _sq_partials(x, s, lo, hi, m, hh, hl, coefs, partial, sb_lo, sb_hi):  # pragma: no cover
    """The squared differences of superblocks ``sb_lo .. sb_hi - 1`` into ``partial``."""
    n = hi - lo
    for sb in range(sb_lo, sb_hi):
        q0 = sb * _SUPERBLOCK
        partial[sb] = squares(x, s, lo, q0, min(q0 + _SUPERBLOCK, n), m, hh, hl, coefs, None)[0]


def _squares(x, s, lo, hi, m, phase, coefs) -> float:
    """Sum of the squared differences ``i = lo .. hi - 1``, ``x[j + k s] = r[lo + j + k m]``."""
    hh, hl = phase.hh, phase.hl
    if hi - lo >= _PARALLEL_MIN:
        partial = np.zeros(-(-(hi - lo) // _SUPERBLOCK))
        _sq_partials.run(hi - lo, partial.size, x, s, lo, hi, m, hh, hl, coefs, partial)
        total = 0.0
        for value in partial.tolist():  # in order, whichever thread summed which part
            total += value
        return total
    return float(squares(x, s, lo, 0, hi - lo, m, hh, hl, coefs, None)[0])


def overlapping_sums(
    phase: Phase,
    ms: np.ndarray,
    order: int,
    starts: np.ndarray | None = None,
    counts: np.ndarray | None = None,
) -> np.ndarray:
    """Sums of squared overlapping differences of ``order`` 2 or 3 at each ``m``.

    ``i`` runs over ``starts[t] .. starts[t] + counts[t] - 1``; by default over every start
    that keeps ``i + order * m`` inside the data.
    """
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    coefs = SECOND if order == 2 else THIRD
    npts = phase.n_points
    starts = np.zeros_like(ms) if starts is None else np.ascontiguousarray(starts, np.int64)
    counts = npts - order * ms if counts is None else np.ascontiguousarray(counts, np.int64)
    if np.any(counts < 1) or np.any(starts < 0):
        raise ValueError("internal: empty or out-of-range difference sum")
    if np.any(starts + counts - 1 + order * ms >= npts):
        raise ValueError("internal: difference sum runs past the data")
    if isinstance(phase, diff.AnchoredPhase):  # one chunk: every tau over it at once
        return diff.overlapping_sums_kernel(phase.r, phase.hh, phase.hl, ms, starts, counts,
                                            coefs)[0]  # fmt: skip
    chunk = phase.chunk_size
    sums = np.zeros(ms.size)
    ends = starts + counts
    small = np.flatnonzero(order * ms <= chunk)
    if small.size:
        # one sweep: a window of C + order * max(m) points serves every short m. It starts
        # on a block boundary, so the in-memory kernel (fused over taus, parallel) runs on
        # it as it is, with the anchors from that block on.
        reach = int(order * ms[small].max())
        window = _Window(phase)
        first, last = int(starts[small].min()), int(ends[small].max())
        for a in range(first, last, chunk):
            b = min(a + chunk, last)
            base = a & ~_MASK
            i0 = np.maximum(a, starts[small])
            i1 = np.minimum(b, ends[small])
            live = i1 > i0
            if not live.any():
                continue
            x = window.get(base, min(b + reach, npts))
            if b - a >= _SUPERBLOCK:
                blk = base >> SHIFT
                sums[small[live]] += diff.overlapping_sums_kernel(
                    x, phase.hh[blk:], phase.hl[blk:], ms[small][live],
                    i0[live] - base, (i1 - i0)[live], coefs,
                )[0]  # fmt: skip
                continue
            # short pieces: tau by tau, without waking the thread pool
            for t, lo, hi in zip(small[live], i0[live], i1[live], strict=True):
                m = int(ms[t])
                sums[t] += _squares(x[lo - base :], m, int(lo), int(hi), m, phase, coefs)
    piece = max(1, chunk // (order + 1))
    for t in np.flatnonzero(order * ms > chunk):
        # order + 1 streams side by side, one per point of the difference
        m = int(ms[t])
        # each point's window fills a row of x: the rows are the kernel's strides
        x = np.empty((order + 1) * piece)
        windows = [_Window(phase, x[k * piece : (k + 1) * piece]) for k in range(order + 1)]
        for a in range(int(starts[t]), int(ends[t]), piece):
            b = min(a + piece, int(ends[t]))
            for k, w in enumerate(windows):
                w.get(a + k * m, b + k * m)
            sums[t] += _squares(x, piece, a, b, m, phase, coefs)
    return sums


# ---------------------------------------------------------------------------------------
# non-overlapping differences: points q m only


class _StridedSum:
    """Running sum of one ``m``'s non-overlapping differences, fed points in order."""

    __slots__ = ("acc", "coefs", "count", "m", "phase", "q_next", "tail")

    def __init__(self, phase: StreamedPhase, m: int, count: int, coefs: np.ndarray) -> None:
        self.phase, self.m, self.count, self.coefs = phase, m, count, coefs
        self.acc = 0.0
        self.q_next = 0  # next difference to add; tail holds r at q_next * m, ...
        self.tail = np.empty(0)

    def feed(self, values: np.ndarray) -> None:
        vals = np.concatenate([self.tail, values])
        q_end = min(self.count, self.q_next + vals.size - self.coefs.size + 1)
        if q_end > self.q_next:
            ph = self.phase
            self.acc = strided_run(
                vals, self.q_next, q_end, self.m, ph.hh, ph.hl, self.coefs, self.acc, 0, None
            )[0]
        self.tail = vals[max(0, q_end - self.q_next) :]
        self.q_next = max(self.q_next, q_end)


def strided_sums(phase: Phase, ms: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Sums of squared non-overlapping differences (stride ``m``); returns (sums, counts)."""
    ms = np.asarray(ms, dtype=np.int64)
    coefs = SECOND if order == 2 else THIRD
    npts = phase.n_points
    counts = (npts - 1) // ms - order + 1
    if np.any(counts < 1):
        raise ValueError("internal: empty difference sum")
    if isinstance(phase, diff.AnchoredPhase):
        sums = diff.strided_sums_kernel(phase.r, phase.hh, phase.hl, ms, counts, coefs, None)
        return sums[0], counts
    chunk = phase.chunk_size
    acc = [_StridedSum(phase, int(m), int(c), coefs) for m, c in zip(ms, counts, strict=True)]
    last_point = ((npts - 1) // ms) * ms  # the last point each m needs
    small = np.flatnonzero(ms <= chunk)
    if small.size:
        window = _Window(phase)
        stop = int(last_point[small].max()) + 1
        for a in range(0, stop, chunk):
            b = min(a + chunk, stop)
            x = window.get(a, b)
            for t in small:
                m = int(ms[t])
                j0 = -(-a // m) * m
                j1 = min(b - 1, int(last_point[t]))
                if j0 <= j1:
                    acc[t].feed(x[j0 - a : j1 - a + 1 : m])
    for t in np.flatnonzero(ms > chunk):
        # at most N / C points: a short read (within one block) for each
        m = int(ms[t])
        window = _Window(phase)
        points = range(0, int(last_point[t]) + 1, m)
        for p0 in range(0, len(points), chunk):
            batch = points[p0 : p0 + chunk]
            acc[t].feed(np.array([window.get(j, j + 1)[0] for j in batch]))
    return np.array([a.acc for a in acc]), counts


# ---------------------------------------------------------------------------------------
# modified Allan: sliding m-term sums of second differences


def modified_sums(phase: Phase, ms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MVAR numerators ``sum_j (sum_{i=j}^{j+m-1} d_m[i])^2``; returns (sums, counts).

    Window sum ``j`` is built from ``j - 1`` by adding ``d[j + m - 1]`` and removing
    ``d[j - 1]`` with a compensated running total carried from piece to piece. In memory
    the running total restarts every :data:`adavar._kernels.differences.MOD_PART` starts, and the
    parts run on every thread (:func:`adavar._kernels.differences.modified_sums_kernel`).
    """
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    npts = phase.n_points
    counts = npts - 3 * ms + 1
    if np.any(counts < 1):
        raise ValueError("internal: empty difference sum")
    if isinstance(phase, diff.AnchoredPhase):
        return diff.modified_sums_kernel(phase.r, phase.hh, phase.hl, ms, counts)[0], counts
    chunk = phase.chunk_size
    hh, hl = phase.hh, phase.hl
    sums = np.zeros(ms.size)
    state = np.zeros((ms.size, 2))  # (s, c) of each running window sum

    small = np.flatnonzero(3 * ms <= chunk)
    if small.size:
        reach = int(3 * ms[small].max())
        enter, leave = np.empty(chunk), np.empty(chunk)
        window = _Window(phase)
        x = window.get(0, min(chunk + reach, npts))
        for t in small:  # window sum j = 0
            m = int(ms[t])
            fill2(x[:m], x[m : 2 * m], x[2 * m : 3 * m], 0, m, m, hh, hl, leave)
            s, c = accumulate(leave, m, 0.0, 0.0)
            state[t] = s, c
            sums[t] = (s + c) ** 2
        last = int(counts[small].max())
        for a in range(1, last, chunk):
            # starts j in [a, b): d[j - 1] leaves, d[j + m - 1] enters
            b = min(a + chunk, last)
            x = window.get(a - 1, min(b - 1 + reach, npts))
            for t in small:
                m = int(ms[t])
                bt = min(b, int(counts[t]))
                if a >= bt:
                    continue
                n = bt - a
                xs = [x[k * m : k * m + n] for k in range(4)]
                fill2(xs[0], xs[1], xs[2], a - 1, bt - 1, m, hh, hl, leave)
                fill2(xs[1], xs[2], xs[3], a + m - 1, bt + m - 1, m, hh, hl, enter)
                s, c, sums[t], _ = slide_window_sum(
                    enter, leave, n, state[t, 0], state[t, 1], sums[t], 0, None
                )
                state[t] = s, c

    piece = max(1, chunk // 4)
    enter, leave = np.empty(piece), np.empty(piece)
    for t in np.flatnonzero(3 * ms > chunk):
        m, count = int(ms[t]), int(counts[t])
        windows = [_Window(phase) for _ in range(4)]
        s = c = 0.0
        for a in range(0, m, piece):  # window sum j = 0, streamed
            b = min(a + piece, m)
            xs = [w.get(a + k * m, b + k * m) for k, w in enumerate(windows[:3])]
            fill2(xs[0], xs[1], xs[2], a, b, m, hh, hl, leave)
            s, c = accumulate(leave, b - a, s, c)
        acc = (s + c) ** 2
        for a in range(1, count, piece):
            b = min(a + piece, count)
            xs = [w.get(a - 1 + k * m, b - 1 + k * m) for k, w in enumerate(windows)]
            fill2(xs[0], xs[1], xs[2], a - 1, b - 1, m, hh, hl, leave)
            fill2(xs[1], xs[2], xs[3], a + m - 1, b + m - 1, m, hh, hl, enter)
            s, c, acc, _ = slide_window_sum(enter, leave, b - a, s, c, acc, 0, None)
        sums[t] = acc
    return sums, counts


# ---------------------------------------------------------------------------------------
# the reflected record of the total deviation


class ReflectedSource(ChunkedSource):
    """A record extended by time reversal at both ends (``numpy.pad(..., "symmetric")``).

    Parameters
    ----------
    source : ChunkedSource
        The record.
    pad : int
        Samples added at each end (at most the record's length).
    """

    def __init__(self, source: ChunkedSource, pad: int) -> None:
        if not 0 <= pad <= source.size:
            raise ValueError("internal: reflection longer than the record")
        self.source = source
        self.pad = int(pad)
        self.size = int(source.size) + 2 * self.pad
        self.name = source.name

    def _read_raw(self, start: int, stop: int) -> np.ndarray:
        if stop <= start:
            return np.empty(0)
        return read_extended(self.source, start, stop, self.pad)

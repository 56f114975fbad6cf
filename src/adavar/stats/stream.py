"""Records larger than memory: the streamed noise identification, and the sources.

The sources a record is read from piece by piece live in :mod:`adavar.io.sources` (they are
importable from here as well, as before). This module holds what is computed from them in
one or two passes: :func:`noise_types`, the power-law noise type per averaging factor with
the same rules and, to rounding, the same statistics as the in-memory identification.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from adavar._kernels import differences as diff
from adavar._kernels._jit import jit
from adavar._kernels.decimated_phase import (
    decimated_phase_lag1,
    phase_lag1_result,
    phase_moments,
    phase_residual_lag,
    quadratic_fit,
)
from adavar._kernels.difference_runs import SHIFT
from adavar._kernels.differences import cluster_sum
from adavar._kernels.double_double import dd_add
from adavar.io.sources import (
    DEFAULT_CHUNK,
    PARALLEL_MIN,
    ArraySource,
    ChunkedSource,
    DaskSource,
    DifferencedSource,
    HDF5Source,
    NpyFileSource,
    ParquetSource,
    as_source,
    available_memory,
    check_chunk_size,
    is_chunked,
    is_dask,
    memmap_source,
    open_record,
    read_extended,
    threads_for,
)
from adavar.stats import noise_id as nid
from adavar.stats import record_sums

__all__ = [
    "DEFAULT_CHUNK",
    "PARALLEL_MIN",
    "ArraySource",
    "ChunkedSource",
    "DaskSource",
    "DifferencedSource",
    "HDF5Source",
    "NpyFileSource",
    "ParquetSource",
    "as_source",
    "available_memory",
    "check_chunk_size",
    "is_chunked",
    "is_dask",
    "memmap_source",
    "noise_types",
    "open_record",
    "read_extended",
    "threads_for",
]


# ---------------------------------------------------------------------------------------
# noise identification out of core: the lag-1 statistics of the cluster sums, streamed

#: a lag-1 series of at most this many cluster sums is collected whole in the first pass
SMALL_SERIES = 4096


@jit
def _straddling_sum(r, hh, hl, j1, carry):  # pragma: no cover - compiled
    """A cluster that began in an earlier piece and ends at ``j1``: the carry plus ``S[j1]``
    of the piece's own anchored phase (``S[0] = 0``)."""
    b = j1 >> SHIFT
    zh, zl = dd_add(carry[0], carry[1], hh[b], hl[b])
    zh, zl = dd_add(zh, zl, r[j1], 0.0)
    return zh + zl


@jit
def _carry_to_end(r, hh, hl, p0, p1, m, k, count, carry):  # pragma: no cover - compiled
    """The part of cluster ``k`` (open at ``p1``) summed so far, as a double-double."""
    if k >= count or k * m >= p1:
        carry[0] = 0.0
        carry[1] = 0.0
        return
    npl = p1 - p0
    b1 = npl >> SHIFT
    if k * m >= p0:  # it began in this piece
        j0 = k * m - p0
        b0 = j0 >> SHIFT
        dh, dl = dd_add(hh[b1], hl[b1], -hh[b0], -hl[b0])
        ch, cl = dd_add(dh, dl, r[npl] - r[j0], 0.0)
    else:
        ch, cl = dd_add(carry[0], carry[1], hh[b1], hl[b1])
        ch, cl = dd_add(ch, cl, r[npl], 0.0)
    carry[0] = ch
    carry[1] = cl


@jit
def _line_moments(zs, nz, k0, count, mom, head, tail):  # pragma: no cover - compiled
    """First pass: sum z, sum (k - kc) z, max |z|; the first and last four values."""
    kc = 0.5 * (count - 1)
    s1 = 0.0
    st = 0.0
    zmax = mom[2]
    for q in range(nz):
        z = zs[q]
        s1 += z
        st += (k0 + q - kc) * z
        zmax = max(zmax, abs(z))
    mom[0] += s1
    mom[1] += st
    mom[2] = zmax
    for k in range(k0, min(k0 + nz, 4)):
        head[k] = zs[k - k0]
    for k in range(max(k0, count - 4), k0 + nz):
        tail[k - (count - 4)] = zs[k - k0]


@jit
def _lag_moments(zs, nz, k0, a, b, count, q, acc):  # pragma: no cover - compiled
    """Second pass: per difference order 0..3 of the detrended series, sum x, sum x^2 and
    sum x_{k-1} x_k, carrying the last values ``q`` (the sums of ``cluster_lag1_sums``)."""
    kc = 0.5 * (count - 1)
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    a0 = a1 = a2 = a3 = 0.0
    b0 = b1 = b2 = b3 = 0.0
    c0 = c1 = c2 = c3 = 0.0
    for i in range(nz):
        k = k0 + i
        x0 = zs[i] - (a + b * (k - kc))
        x1 = x0 - q0
        x2 = x1 - q1
        x3 = x2 - q2
        a0 += x0
        b0 += x0 * x0
        if k >= 1:
            c0 += q0 * x0
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
        q0, q1, q2, q3 = x0, x1, x2, x3
    q[0], q[1], q[2], q[3] = q0, q1, q2, q3
    acc[0, 0] += a0
    acc[0, 1] += b0
    acc[0, 2] += c0
    acc[1, 0] += a1
    acc[1, 1] += b1
    acc[1, 2] += c1
    acc[2, 0] += a2
    acc[2, 1] += b2
    acc[2, 2] += c2
    acc[3, 0] += a3
    acc[3, 1] += b3
    acc[3, 2] += c3


#: what a pass does with an averaging factor's cluster sums
_SKIP, _LINE, _LAG, _COLLECT = 0, 1, 2, 3


#: cluster sums per partial moment sum (the partials keep the long sums accurate)
_PART = 1 << 15


@jit
def _cluster_pass(
    r, hh, hl, p0, p1, ms, counts, mode, carry, mom, head, tail, line, q, acc, buf, at, zs,
    on_phase, pm, pcoef, ps,
):  # pragma: no cover - compiled  # fmt: skip
    """One piece of ``r, hh, hl`` (its own anchored phase), every averaging factor.

    O(piece / m) per factor. ``carry[t]`` holds, as a double-double, the part of the
    cluster open at ``p0`` that earlier pieces summed (updated to ``p1``). Serial: the
    integration before it is parallel, and many short parallel regions here (a few per
    factor per piece) cost more in thread wake-ups on a busy machine than they save.
    """
    for t in range(ms.size):
        if mode[t] == _SKIP:
            continue
        count = counts[t]
        m = ms[t]
        # the cluster sums S[(k+1) m] - S[k m] that end in this piece (increments p0 .. p1-1)
        k = p0 // m
        k0 = k
        nz = np.int64(0)
        if k < count and k * m < p0 and (k + 1) * m <= p1:
            zs[0] = _straddling_sum(r, hh, hl, (k + 1) * m - p0, carry[t])
            nz = np.int64(1)
            k += 1
        full = max(0, min(count, p1 // m) - k)
        for i in range(full):  # the clusters wholly inside the piece
            zs[nz + i] = cluster_sum(r, hh, hl, (k + i) * m - p0, m)
        nz += full
        _carry_to_end(r, hh, hl, p0, p1, m, k + full, count, carry[t])
        if nz == 0:
            continue
        nch = max(1, min(64, nz // _PART))
        if mode[t] == _LINE:
            if on_phase:  # the decimated phase's moments, in cluster order
                phase_moments(zs, nz, k0, count, pm[t])
            part = np.zeros((nch, 3))
            for c in range(nch):
                i0 = (nz * c) // nch
                i1 = (nz * (c + 1)) // nch
                _line_moments(zs[i0:i1], i1 - i0, k0 + i0, count, part[c], head[t], tail[t])
            mom[t, 0] += np.sum(part[:, 0])
            mom[t, 1] += np.sum(part[:, 1])
            mom[t, 2] = max(mom[t, 2], np.max(part[:, 2]))
        elif mode[t] == _LAG:
            if on_phase:
                phase_residual_lag(zs, nz, k0, count, pcoef[t], ps[t])
            a = line[t, 0]
            b = line[t, 1]
            part = np.zeros((nch, 4, 3))
            last = np.zeros((nch, 4))
            for c in range(nch):
                i0 = (nz * c) // nch
                i1 = (nz * (c + 1)) // nch
                if c == 0:
                    last[c, :] = q[t]
                else:  # four values ahead rebuild every difference order's previous value
                    four = np.int64(4)
                    _lag_moments(zs[i0 - 4 : i0], four, k0 + i0 - 4, a, b, count, last[c], part[c])
                    part[c, :, :] = 0.0
                _lag_moments(zs[i0:i1], i1 - i0, k0 + i0, a, b, count, last[c], part[c])
            for d in range(4):
                for j in range(3):
                    acc[t, d, j] += np.sum(part[:, d, j])
            q[t, :] = last[nch - 1]
        else:
            buf[at[t] + k0 : at[t] + k0 + nz] = zs[:nz]


def _line(count: int, mom: np.ndarray) -> tuple[float, float]:
    """Least-squares line ``a + b (k - kc)`` through the cluster sums."""
    stt = count * (count * count - 1.0) / 12.0
    return mom[0] / count, (mom[1] / stt if stt > 0 else 0.0)


def _lag1_from_moments(
    count: int, dmax: int, mom: np.ndarray, head: np.ndarray, tail: np.ndarray,
    acc: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:  # fmt: skip
    """``(r1, den, n, zmax)`` per difference order, as
    :func:`adavar._kernels.differences.cluster_lag1`."""
    a, b = _line(count, mom)
    kc = 0.5 * (count - 1)
    h = head - (a + b * (np.arange(4) - kc))
    t = tail - (a + b * (np.arange(count - 4, count) - kc))
    first = np.array(
        [h[0], h[1] - h[0], (h[2] - h[1]) - (h[1] - h[0]), h[3] - 3 * h[2] + 3 * h[1] - h[0]]
    )
    last = np.array(
        [t[3], t[3] - t[2], (t[3] - t[2]) - (t[2] - t[1]), t[3] - 3 * t[2] + 3 * t[1] - t[0]]
    )
    nd = dmax + 1
    r1 = np.full(nd, np.nan)
    den = np.zeros(nd)
    n = np.zeros(nd, dtype=np.int64)
    for d in range(nd):
        c = count - d
        n[d] = max(c, 0)
        if c < 2:
            continue
        s1, s2, s11 = acc[d]
        mean = s1 / c
        den[d] = s2 - c * mean * mean
        num = s11 - mean * ((s1 - last[d]) + (s1 - first[d])) + (c - 1) * mean * mean
        if den[d] > 0:
            r1[d] = num / den[d]
    return r1, den, n, float(mom[2])


def _cluster_statistics(
    source: ChunkedSource, ms: np.ndarray, dmax: int, chunk_size: int
) -> tuple[list[Any], float]:
    """:func:`_cluster_statistics_all` without the decimated-phase statistics."""
    stats, _, shift = _cluster_statistics_all(source, ms, dmax, chunk_size)
    return stats, shift


def _cluster_statistics_all(
    source: ChunkedSource, ms: np.ndarray, dmax: int, chunk_size: int, on_phase: bool = False
) -> tuple[list[Any], list[Any], float]:
    """Per averaging factor: ``(r1, den, n, zmax)`` of the lag-1 rule when there are at
    least :data:`adavar.stats.edf.MIN_POINTS_LAG1` clusters, else the cluster sums themselves
    (relative to the shift); and the shift.

    Two passes over ``source`` at most (line fit, then the lag sums), each reading it once
    in pieces of ``chunk_size`` increments for every factor at once; series short enough
    are collected in the first pass and need no second. With ``on_phase`` the same passes
    also give the lag-1 statistics of the quadratically detrended decimated phase
    (:func:`adavar.stats.noise_id.decimated_phase_lag1`), returned as the second list (None
    for the B1 series).
    """
    n = source.size
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    nt = ms.size
    counts = n // ms
    # the shift of the in-memory integration: the median of the first block
    shift = float(np.median(source.read(0, min(diff.BLOCK, n)))) if n else 0.0
    lag1 = counts >= nid.MIN_POINTS_LAG1
    mode = np.where(lag1, _LINE, _COLLECT).astype(np.int64)
    budget = max(int(chunk_size), SMALL_SERIES)
    held = int(counts[~lag1].sum())
    for t in np.argsort(counts, kind="stable"):
        if lag1[t] and counts[t] <= SMALL_SERIES and held + counts[t] <= budget:
            mode[t] = _COLLECT
            held += int(counts[t])
    at = np.zeros(nt, dtype=np.int64)
    collect = mode == _COLLECT
    at[collect] = np.concatenate([[0], np.cumsum(counts[collect])[:-1]])
    buf = np.empty(held)
    carry = np.zeros((nt, 2))
    mom = np.zeros((nt, 3))
    head = np.zeros((nt, 4))
    tail = np.zeros((nt, 4))
    line = np.zeros((nt, 2))
    q = np.zeros((nt, 4))
    acc = np.zeros((nt, 4, 3))
    chunk = max(1, int(chunk_size))
    if chunk >= diff.BLOCK:  # pieces on the anchor blocks: the in-memory local sums exactly
        chunk -= chunk % diff.BLOCK
    zs = np.empty(min(chunk, n) + 1)
    pm = np.zeros((nt, 5))
    pcoef = np.zeros((nt, 3))
    ps = np.zeros((nt, 6))
    kept: diff.AnchoredPhase | None = None

    def run_pass() -> None:
        nonlocal kept
        for p0 in range(0, n, chunk):
            p1 = min(n, p0 + chunk)
            with threads_for(p1 - p0):
                if kept is None:
                    phase = diff.anchored_phase(source.read(p0, p1), shift=shift)
                else:
                    phase = kept
            if p1 - p0 == n:  # one piece: the second pass reuses it
                kept = phase
            _cluster_pass(
                phase.r, phase.hh, phase.hl, p0, p1, ms, counts, mode, carry, mom, head,
                tail, line, q, acc, buf, at, zs, bool(on_phase), pm, pcoef, ps,
            )  # fmt: skip

    run_pass()
    streamed = mode == _LINE
    if streamed.any():
        for t in np.flatnonzero(streamed):
            line[t] = _line(int(counts[t]), mom[t])
            pcoef[t] = quadratic_fit(int(counts[t]), pm[t])
        mode[streamed] = _LAG
        mode[~streamed] = _SKIP
        carry[:] = 0.0
        run_pass()

    stats: list[Any] = []
    pstats: list[Any] = []
    for t in range(nt):
        count = int(counts[t])
        if streamed[t]:
            stats.append(_lag1_from_moments(count, dmax, mom[t], head[t], tail[t], acc[t]))
            r1, den, scale = phase_lag1_result(count, pm[t], ps[t])
            pstats.append((r1, den, count + 1, scale) if on_phase else None)
            continue
        z = buf[at[t] : at[t] + count]
        if not lag1[t]:
            stats.append(z)
            pstats.append(None)
            continue
        _line_moments(z, count, 0, count, mom[t], head[t], tail[t])
        a, b = _line(count, mom[t])
        _lag_moments(z, count, 0, a, b, count, q[t], acc[t])
        stats.append(_lag1_from_moments(count, dmax, mom[t], head[t], tail[t], acc[t]))
        pstats.append(decimated_phase_lag1(z) if on_phase else None)
    return stats, pstats, shift


def noise_types(
    source: ChunkedSource | Any,
    ms: np.ndarray | Sequence[int],
    dmax: int = 2,
    *,
    chunk_size: int | None = None,
    data_type: str = "rate",
    noise_id: str = "sp1065",
) -> tuple[np.ndarray, tuple[str, ...]]:
    """Power-law noise exponent per averaging factor of a record read piece by piece.

    The same rule and, to rounding, the same statistics as the in-memory identification of
    :func:`adavar.deviation` and :func:`adavar.davar` (``noise_type="record"``): per ``m``,
    with at least :data:`adavar.stats.edf.MIN_POINTS_LAG1` clusters the lag-1 rule (where
    :func:`adavar.stats.noise_id.starts_on_phase` says so, started on the quadratically detrended
    decimated phase, then the linearly detrended sums of ``m`` increments, differenced up
    to ``dmax - 1`` times; otherwise the sums, up to ``dmax`` times); else the B1 ratio of
    the cluster means with R(n) = MVAR/AVAR when B1 says PM; a tau that neither
    identifies takes its nearest identified neighbour's type. Alphas are clamped to the
    statistic's range.

    Parameters
    ----------
    source : ChunkedSource or array_like
        The increments (rate samples; first differences of phase).
    ms : array_like of int
        Averaging factors.
    dmax : int
        Most differences taken (2 for the Allan family, 3 for Hadamard).
    chunk_size : int, optional
        Increments per piece (default :data:`DEFAULT_CHUNK`).
    data_type : {"rate", "phase"}
        What the increments are the increments of (``"phase"``: of the user's phase).
    noise_id : {"sp1065", "stable32"}
        As in :func:`adavar.deviation`.

    Returns
    -------
    alpha : ndarray of int64
        One per factor.
    notes : tuple of str
        Says so when no tau could be identified (alpha 0, white noise, is then used).

    Notes
    -----
    Reads the record at most twice (a line fit, then the lag sums of every difference
    order), each time once for all factors, from cluster sums that are differences of a
    double-double running integral carried across pieces: O(N sum(1/m)) work. Held in
    memory: one piece, its integral, and the cluster sums of the short series (at most
    ``max(chunk_size, SMALL_SERIES)`` values beyond the B1 ones). R(n) for the few B1
    taus that read "PM" costs one more streamed pass (overlapping and modified sums).
    """
    from adavar.stats.noise_id import (
        avar_of_sum,
        averaged_rule,
        b1_with_rn,
        mvar_of_sum,
        pm_with_rn,
        rn_ratio,
        starts_on_phase,
    )

    src = as_source(source)
    ms = np.atleast_1d(np.asarray(ms, dtype=np.int64))
    if not 0 <= int(dmax) <= 3:
        raise ValueError("internal: dmax must lie in 0..3")
    chunk = DEFAULT_CHUNK if chunk_size is None else max(1, int(chunk_size))
    strict = noise_id == "stable32"
    on_phase = starts_on_phase(data_type, noise_id)
    stats, pstats, shift = _cluster_statistics_all(src, ms, int(dmax), chunk, on_phase)
    alpha = np.full(ms.size, np.nan)
    rn_cache: dict[int, float | None] = {}
    phase_src: list[Any] = []

    def rn(m: int) -> float | None:
        if m not in rn_cache:
            if not phase_src:
                phase_src.append(record_sums.streamed_phase(src, chunk))
            ph = phase_src[0]
            one = np.array([m], dtype=np.int64)
            total = float(record_sums.overlapping_sums(ph, one, 2)[0])
            sums, n = record_sums.modified_sums(ph, one)
            rn_cache[m] = rn_ratio(
                avar_of_sum(total, m, src.size + 1 - 2 * m),
                mvar_of_sum(float(sums[0]), m, int(n[0])),
            )
        return rn_cache[m]

    for t, (m, st, pst) in enumerate(zip(ms, stats, pstats, strict=True)):
        m = int(m)
        try:
            if isinstance(st, tuple):
                if on_phase:
                    got = nid.alpha_from_phase_lag1(pst, None, dmax=int(dmax))
                    if got is not None:
                        got = pm_with_rn(got, m, lambda m=m: rn(m))
                    else:
                        r1, den, sizes, zmax = st
                        k = int(dmax)  # the rate orders 0 .. dmax - 1, stopping as in memory
                        if r1[0] / (1.0 + r1[0]) < 0.25:
                            k = 1
                        sub = (r1[:k], den[:k], sizes[:k], zmax)
                        got = nid.alpha_from_phase_lag1(
                            pst, sub, dmax=int(dmax), averaged=averaged_rule(noise_id, m)
                        )
                    alpha[t] = got
                else:
                    r1, den, sizes, zmax = st
                    alpha[t] = nid.clamp_alpha(
                        nid.alpha_from_lag1(
                            r1,
                            den,
                            sizes,
                            zmax,
                            data_type="rate",
                            dmax=r1.size - 1,
                            averaged=averaged_rule(noise_id, m),
                        )[0],
                        int(dmax),
                    )
            else:
                z = (st + shift * m) / m
                alpha[t] = b1_with_rn(z, m, int(dmax), lambda m=m: rn(m), strict=strict)
        except nid.NoiseIdError:
            continue
    return nid.fill_unidentified(alpha)

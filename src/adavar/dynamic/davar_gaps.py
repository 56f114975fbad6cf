"""The dynamic Allan variance of a record with missing samples: ``davar(..., gaps="omit")``.

A missing sample is a NaN on the regular grid (as for :func:`adavar.deviation` with
``gaps="omit"``, :mod:`adavar.stats.gaps`). In every window each difference term that touches a
missing sample is left out, by the rules of :mod:`adavar.stats.gaps`: for rate data a term over
the phase points ``i .. i + w`` is left out if any rate sample ``i .. i + w - 1`` is missing
(``w`` = 2m for oavar, 3m for ohvar, 3m - 1 for mvar); for phase data if one of its own
points is (``i + k m``; mvar: any point of ``i .. i + 3m - 1``). A cell's variance is the
mean of its kept squared terms with the statistic's usual factor, ``result.terms`` holds
the kept counts, and a cell with no kept term is NaN.

How it is computed
------------------
In O(N M), like the gap-free surface: the missing samples are filled with finite values
(:func:`adavar.stats.gaps.filled_increments`), the record is mirror-extended, and the window
kernel (:mod:`adavar._kernels.window_engine`, given the gaps) zeroes the terms that fail
the keep test before prefix-summing their squares, and prefix-counts the kept ones. A kept
term involves no filled value: it is the term of the true record, to the accuracy of the
gap-free kernels.

Mirror edges: the extension reflects the missing flags with the samples. For rate data
the extension repeats the rate samples, so a missing one is missing in its image; for
phase data an extended point is ``2 x[0] - x[j]`` (``2 x[N] - x[N - j]`` at the end), so
it is missing where ``x[j]`` or the reflection point ``x[0]`` is.

EDF and intervals
-----------------
The noise type per tau is identified on the whole record's kept data
(:func:`adavar.stats.gaps.gap_noise_types`). A cell's EDF is the Greenhall-Riley EDF of a
gap-free window giving as many terms as were kept: ``gaps.effective_points(stat, m,
kept)`` phase points (:func:`adavar.dynamic.surface_common.edf_of_counts`: exact up to 64 terms, a
fixed interpolation grid beyond, 1e-3). With ``edge_edf="distinct"`` a window reaching into the
mirror has its kept count scaled by the gap-free ratio ``M / (M + 2 D)`` of
:func:`adavar.dynamic.surface_common.edf_table`. The per-cell EDFs are stored as an ``edf_table`` of
one row per centre (``window_class = arange(T)``).

Out of core: a chunked record (a source, a memory map) is scanned for NaN first; without
one it takes the usual out-of-core path; with one it is read into memory (an explicit
``chunk_size`` is then an error). A lazy dask surface is not computed with gaps.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from adavar._kernels import differences as diff
from adavar._kernels.window_engine import window_gaps
from adavar.core.durations import to_samples
from adavar.core.errors import AdavarInputError
from adavar.core.inputs import data_exponent, tau_factors, unscale
from adavar.core.results import DavarResult
from adavar.dynamic.surface_common import (
    DavarStatResult,
    bound_factors,
    centre_chunk_size,
    check_surface_memory,
    edf_of_counts,
    noise_alpha,
    plural_name,
    term_width,
)
from adavar.dynamic.windows import check_window_times, window_overhang, window_schedule
from adavar.io import sources
from adavar.stats.gaps import (
    GAP_RULES,
    GapLayout,
    effective_points,
    filled_increments,
    gap_noise_types,
    read_whole,
    samples_with_gaps,
)

__all__ = ["extended_layout", "gap_davar", "missing_record"]

_IN_MEMORY = (
    "the record has missing (NaN) samples, and davar(gaps='omit') computes such a record "
    "in memory: leave out chunk_size (--chunk-size), or load the record (numpy.asarray)"
)


def missing_record(
    data: Any, *, gaps: str, chunk_size: int | None, lazy: bool | None
) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]] | None:
    """``(x, missing, notes)`` of a record with NaN for the gap path, or None when it has
    none (the gap-free path then takes ``data`` as it is: the same result bit for bit)."""
    if gaps not in GAP_RULES:
        raise AdavarInputError(f"unknown gaps {gaps!r}: use one of {', '.join(GAP_RULES)}")
    if gaps == "error" or (lazy and not sources.is_dask(data)):  # davar names the latter
        return None
    if sources.is_dask(data) and lazy is not False:
        raise AdavarInputError(
            "davar(gaps='omit') does not compute a lazy surface: pass lazy=False (the record "
            "is scanned, and read into memory if it has missing samples) or numpy.asarray(data)"
        )
    if sources.is_chunked(data):
        source = sources.as_source(data)
        for start in range(0, source.size, sources.DEFAULT_CHUNK):
            raw = source.read_unchecked(start, min(source.size, start + sources.DEFAULT_CHUNK))
            if raw.dtype.kind in "fc" and np.isnan(raw).any():
                break
        else:
            return None
        if chunk_size is not None:
            raise AdavarInputError(_IN_MEMORY)
        x = samples_with_gaps(read_whole(source))
        notes: tuple[str, ...] = (f"{source.name} holds missing samples: it was read into memory",)
    else:
        x = samples_with_gaps(data)
        notes = ()
    missing = np.isnan(x)
    if not missing.any():
        return None
    if chunk_size is not None and not notes:
        raise AdavarInputError(_IN_MEMORY)
    return x, missing, notes


def extended_layout(
    missing: np.ndarray, data_type: str, pad_before: int, pad_after: int
) -> tuple[np.ndarray, np.ndarray]:
    """``(cnt, pm)`` of the mirror-extended record for the window kernel.

    ``cnt`` (``N_ext + 2`` entries, the last repeated) is the prefix count of the missing
    rate samples (rate data) or phase points (phase data) of the extended record; ``pm``
    (``N_ext + 1``) flags the missing extended phase points (all zero for rate data).
    """
    if data_type == "rate":
        flags = np.pad(missing, (pad_before, pad_after), mode="symmetric")
        pm = np.zeros(flags.size + 1, dtype=np.uint8)
    else:
        # extended point p - j is 2 x[0] - x[j]: missing with x[j] or with x[0]
        flags = np.pad(missing, (pad_before, pad_after), mode="reflect")
        flags[:pad_before] |= missing[0]
        if pad_after:
            flags[flags.size - pad_after :] |= missing[-1]
        pm = flags.astype(np.uint8)
    cnt = np.empty(flags.size + 2, dtype=np.int64)
    cnt[0] = 0
    np.cumsum(flags, out=cnt[1 : flags.size + 1])
    cnt[-1] = cnt[-2]
    return cnt, pm


def _cell_edf(
    kept: np.ndarray, sched: Any, n: int, ms: np.ndarray, alpha: np.ndarray, stat: str,
    confidence: float, edge_edf: str,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Per-cell EDF (T, M) and bound factors (2, T, M) from the kept counts.

    The counts are small integers: each tau's EDFs and factors are computed once per
    distinct count and gathered through a lookup table (no sort of the T cells).
    """
    by_tau = np.ascontiguousarray(kept.T)  # (M, T): each tau's cells contiguous
    out = np.empty((3, *by_tau.shape))  # EDF and the two bound factors
    overhang = window_overhang(sched.centre, sched.length, n)
    edge = np.flatnonzero(overhang > 0) if edge_edf == "distinct" else np.zeros(0, np.int64)
    for t, m in enumerate(ms):
        m = int(m)
        count = by_tau[t]
        width = term_width(stat, m)
        edge_count = None
        if edge.size:
            # the mirrored repeats of edf_table, in proportion to the terms kept
            c = count[edge].astype(np.float64)
            terms = sched.length[edge] + 1 - width
            repeats = np.maximum(0, overhang[edge] - width // 2)
            scaled = np.maximum(1.0, np.round(c * terms / np.maximum(terms + 2 * repeats, 1)))
            edge_count = np.where(c > 0, scaled, 0.0).astype(np.int64)
        size = int(count.max()) + 1  # an edge's scaled count is at most its kept count
        seen = np.bincount(count, minlength=size)
        if edge_count is not None:
            seen += np.bincount(edge_count, minlength=size)
        values = np.flatnonzero(seen)
        values = values[values > 0]
        lut = np.full((3, seen.size), np.nan)
        lut[1:, 0] = 0.0  # no term: bound factors 0, as where 3m > L
        if values.size:
            # effective_points(stat, m, c) == c + width: the points edf_of_counts hands on
            assert int(effective_points(stat, m, values[0])) == int(values[0]) + width
            lut[0, values] = edf_of_counts(values, int(alpha[t]), m, stat)
            lut[1, values], lut[2, values] = bound_factors(lut[0, values], confidence)
        out[:, t] = lut[:, count]
        if edge_count is not None:
            out[:, t, edge] = lut[:, edge_count]
    return np.ascontiguousarray(out[0].T), np.ascontiguousarray(out[1:].transpose(0, 2, 1))


def gap_davar(
    x: np.ndarray,
    missing: np.ndarray,
    *,
    notes: tuple[str, ...],
    window: Any,
    stat: str,
    rate: float,
    tau0: float | None,
    dt: float,
    data_type: str,
    taus: Any,
    edges: str,
    step: Any,
    confidence: float | None,
    t0: float,
    points_per_decade: int,
    noise_type: Any,
    units: str | None,
    edge_edf: str,
) -> DavarResult:
    """The DAVAR surface of ``x`` with NaN at ``missing`` (options checked by
    :func:`adavar.davar`; ``stat`` the deviation name, ``dt`` the resolved tau0)."""
    min_length = 4 if data_type == "phase" else 3
    n_missing = int(missing.sum())
    if x.size - n_missing < min_length:
        raise AdavarInputError(
            f"the record has {x.size - n_missing} samples that are not missing (of {x.size}); "
            f"at least {min_length} are needed"
        )
    k = data_exponent(x[~missing])
    if k:
        x = np.ldexp(x, -k)
    dt_mantissa, dt_exponent = np.frexp(dt)
    scale = 1.0 if data_type == "rate" else 1.0 / float(dt_mantissa) ** 2
    exponent = 0 if data_type == "rate" else -2 * int(dt_exponent)
    layout = GapLayout.of(missing, data_type)
    u = filled_increments(x, missing, data_type)
    n = u.size
    sched = window_schedule(
        n, to_samples(window, dt, "window"), edges=edges, step=to_samples(step, dt, "step")
    )
    longest = int(sched.length.max())
    ms, tau_notes = tau_factors(taus, longest // 3, dt, points_per_decade)
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    check_surface_memory(sched.centre.size, ms.size, 2 if confidence is None else 5)

    cnt, pm = extended_layout(missing, data_type, sched.pad_before, sched.pad_after)
    avar, kept = window_gaps(
        sched.extend(u), ms, sched.centre, sched.length, stat=stat, cnt=cnt, pm=pm,
        ws=layout.windows(stat, ms), offset=sched.pad_before, scale=scale,
        chunk=centre_chunk_size(sched.centre.size, longest, sched.step),
    )  # fmt: skip
    avar = unscale(avar, 2 * k + exponent, plural_name(stat), underflow=False)
    runs = layout.runs()
    valid = 3 * ms[None, :] <= sched.length[:, None]
    empty = int(np.count_nonzero(valid & (kept == 0)))
    notes = (
        *tau_notes,
        *notes,
        f"gaps='omit': {n_missing} of {x.size} samples are missing (NaN), in {runs.size} "
        f"gap(s) of up to {int(runs.max())} samples; every difference term that touches a "
        "missing sample is left out of its window (result.terms: the terms kept), and each "
        "cell's EDF is that of a gap-free window with as many terms",
    )
    if empty:
        notes = (*notes, f"{empty} cell(s) have no term free of missing samples: NaN")

    table = bounds = window_class = None
    if confidence is None:
        alpha = np.full(ms.size, -1, dtype=np.int64)
    else:
        dmax = 3 if stat == "ohdev" else 2

        def identify() -> tuple[np.ndarray, tuple[str, ...]]:
            return gap_noise_types(diff.anchored_phase(u), layout, ms, dmax, data_type=data_type)

        alpha, id_notes = noise_alpha(noise_type, ms, identify, stat)
        notes = notes + id_notes
        table, bounds = _cell_edf(kept, sched, n, ms, alpha, stat, float(confidence), edge_edf)
        window_class = np.arange(sched.centre.size, dtype=np.int64)
    with np.errstate(over="ignore"):
        time = t0 + (sched.centre * dt if tau0 is not None else sched.centre / float(rate))
    check_window_times(time, sched.centre, t0, dt)  # overflow, or too coarse for dt
    surface = dict(
        time=time, tau=ms * dt, avar=avar, window=sched.length, centre=sched.centre, m=ms,
        alpha=alpha, tau0=dt, data_type=data_type, edges=sched.edges, step=sched.step,
        confidence=float("nan") if confidence is None else float(confidence),
        n_samples=int(x.size), units=units, notes=notes, edf_table=table,
        window_class=window_class, bound_table=bounds, terms=kept,
    )  # fmt: skip
    if stat == "oadev":
        return DavarResult(**surface)
    return DavarStatResult(**surface, stat=stat)

"""The dynamic Allan variance (DAVAR) engine: every window, every tau, in O(N*M), exactly.

:func:`davar` is the one place where a DAVAR surface is computed, for a fixed window
(DAVAR-L) or any per-centre schedule (the adaptive controllers feed theirs in here).

How it works (docs/method.md sections 5-6): the rate record is extended at both ends by time
reversal (``edges="mirror"``) and handed to a parallel kernel
(:mod:`adavar._kernels.window_engine`) that, per chunk of consecutive centres, re-centres the
chunk's span on a local reference (the median of 65 of its samples) and integrates it in
double-double; per averaging factor ``m`` it computes the second differences ``d_m[i]``
over the span to an ulp, prefix-sums their squares with compensation, and reads each
window's sum as the difference of two prefix values. The cost is O(1) per (centre, tau)
whatever the window length, and a window's variance is exact to a few ulps even on records
with a bias of 1e9 standard deviations, a drift, a level step of 1e6 sigma inside the span
(2.2e-16 relative against an exact per-window computation; the single-double anchored
phase used before gave 9.7e-9 there), or a burst of up to 1e12 times the noise next to a
quiet window.
Centres far apart (``step`` larger than the window) are summed window by window instead.
A record far from 1 (beyond 2**±64) is computed at scale 1 and its variances scaled back by
a power of four (exact); variances beyond the float64 range are an error, not inf.

``stat="ohvar"`` and ``stat="mvar"`` give the dynamic overlapping Hadamard and modified
Allan variances from the same engine (:mod:`adavar._kernels.window_engine`: third differences,
and moving sums of second differences, with the same double-double span), with the same
windows, edges, EDFs (of the statistic) and out-of-core paths.
"""

from __future__ import annotations

import dataclasses
import inspect
import itertools
import math
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from adavar._kernels import differences as diff
from adavar._kernels._jit import jit, read_only
from adavar._kernels.window_engine import window_variance
from adavar.core.durations import Length, to_samples
from adavar.core.errors import AdavarInputError
from adavar.core.inputs import (
    DATA_TYPE_ALIASES,
    as_samples,
    check_confidence,
    refuse_masked,
    scaled,
    tau_factors,
    unscale,
)
from adavar.core.results import DavarResult
from adavar.core.settings import RATE_DEFAULT
from adavar.dynamic.surface_common import (
    STATS,
    DavarStatResult,
    bound_factors,
    centre_chunk_size,
    check_surface_memory,
    edf_table,
    interior_edf_table,
    noise_alpha,
    plural_name,
)
from adavar.dynamic.windows import check_window_times, window_classes, window_schedule
from adavar.io import sources
from adavar.io.sampling import resolve_rate
from adavar.io.scaling import scaled_source
from adavar.stats import stream
from adavar.stats.statistics import OMIT_HINT, deviation, record_noise_types

__all__ = ["STATS", "DavarStatResult", "davar", "edf_table"]


#: a gap this long (samples) between a group's windows and the next starts a new group
GROUP_GAP = 1 << 16


@jit
def _centre_groups(centres, lengths, offset, span, gap):  # pragma: no cover - compiled
    """Groups of consecutive centres for the out-of-core path.

    A group's windows span at most ``span`` samples of the extended record together (a
    single window may be longer), and a window that starts more than ``gap`` samples after
    the group's end starts a new group (sparse centres are read window by window). Returns
    ``(bounds, lo, hi)``: group ``g`` holds centres ``bounds[g] .. bounds[g+1] - 1`` and
    reads extended samples ``lo[g] .. hi[g] - 1``.
    """
    nc = centres.size
    bounds = np.empty(nc + 1, dtype=np.int64)
    los = np.empty(nc, dtype=np.int64)
    his = np.empty(nc, dtype=np.int64)
    ng = 0
    c = 0
    while c < nc:
        lo = centres[c] - (lengths[c] - 1) // 2 + offset
        hi = lo + lengths[c]
        c1 = c + 1
        while c1 < nc:
            a = centres[c1] - (lengths[c1] - 1) // 2 + offset
            new_lo = min(lo, a)
            new_hi = max(hi, a + lengths[c1])
            if new_hi - new_lo > span or a > hi + gap:
                break
            lo = new_lo
            hi = new_hi
            c1 += 1
        bounds[ng] = c
        los[ng] = lo
        his[ng] = hi
        ng += 1
        c = c1
    bounds[ng] = nc
    return bounds[: ng + 1].copy(), los[:ng].copy(), his[:ng].copy()


def _window_surface(
    stat: str, samples: np.ndarray, ms: np.ndarray, centres: np.ndarray, lengths: np.ndarray,
    **options: Any,
) -> np.ndarray:  # fmt: skip
    """The window engine's variance of ``stat`` (``"oadev"``, ``"ohdev"``, ``"mdev"``)."""
    return window_variance(samples, ms, centres, lengths, stat=stat, **options)


def _chunked_avar(
    source: sources.ChunkedSource, sched: Any, ms: np.ndarray, scale: float, chunk: int,
    stat: str = "oadev", start: int = 0, stop: int | None = None,
) -> np.ndarray:  # fmt: skip
    """The window engine over groups of centres read piece by piece.

    Each group's span of the mirror-extended record is read and handed to the window
    kernel, which writes the group's rows of the output in place. The kernel re-centres
    every chunk of windows on its own reference and keeps its span in double-double, so a
    cell does not depend on where a piece starts: the result is the in-memory one to an ulp
    or so. ``start``, ``stop``: those rows only (a block of :func:`davar_blocks`).
    """
    pad = sched.pad_before
    centre, length = sched.window_centre[start:stop], sched.length[start:stop]
    bounds, los, his = _centre_groups(
        read_only(centre), read_only(length), pad, int(chunk), GROUP_GAP
    )
    out = np.empty((centre.size, ms.size))
    for g in range(los.size):
        c0, c1, lo, hi = int(bounds[g]), int(bounds[g + 1]), int(los[g]), int(his[g])
        with sources.threads_for(max(hi - lo, (c1 - c0) * ms.size)):  # the group's work
            lengths = length[c0:c1]
            _window_surface(
                stat, sources.read_extended(source, lo, hi, pad), ms, centre[c0:c1], lengths,
                offset=pad - lo, scale=scale, out=out[c0:c1],
                chunk=centre_chunk_size(c1 - c0, int(lengths.max()), sched.step),
            )  # fmt: skip
    return out


#: values per block of a lazy (dask) surface: 128 MiB of float64
LAZY_BLOCK_VALUES = 1 << 24


def _group_rows(
    piece: np.ndarray, ms: np.ndarray, centres: np.ndarray, lengths: np.ndarray,
    offset: int, scale: float, step: int, exponent: int, stat: str = "oadev",
) -> np.ndarray:  # fmt: skip
    """One block of a lazy surface: the rows of ``centres`` from their span of the record.

    The piece is computed at scale 1 (:func:`adavar.stats.statistics.scaled`) and its rows scaled
    back by ``4**k * 2**exponent``.
    """
    piece = np.asarray(piece, dtype=np.float64)
    finite = np.isfinite(piece)
    if not finite.all():
        raise AdavarInputError(
            f"the record holds a non-finite value ({piece[np.argmin(finite)]!r}): "
            f"{OMIT_HINT if np.isnan(piece).any() else ''}remove or interpolate non-finite "
            "samples first"
        )
    piece, k = scaled(piece)
    per = centre_chunk_size(centres.size, int(lengths.max()), step)
    rows = _window_surface(stat, piece, ms, centres, lengths, offset=offset, scale=scale, chunk=per)
    return unscale(rows, 2 * k + exponent, plural_name(stat), underflow=False)


def _lazy_avar(
    array: Any, dtype: str, sched: Any, ms: np.ndarray, scale: float, chunk: int, exponent: int,
    stat: str = "oadev",
) -> Any:  # fmt: skip
    """The surface of a dask array as a dask array: one task per group of centres.

    Each task reads its span of the mirror-extended record and computes its rows as
    :func:`_chunked_avar` does; nothing is read until the result is computed.
    """
    import dask
    import dask.array as da

    x = array.astype(np.float64)
    u = x if dtype == "rate" else da.diff(x)
    n = int(u.shape[0])
    pad, after = sched.pad_before, sched.pad_after
    parts = [u]
    if pad:
        parts.insert(0, u[:pad][::-1])
    if after:
        parts.append(u[n - after :][::-1])
    ext = da.concatenate(parts) if len(parts) > 1 else u
    centre, length = sched.window_centre, sched.length
    # blocks of at most LAZY_BLOCK_VALUES output values, at least one window each
    rows = max(1, LAZY_BLOCK_VALUES // max(1, ms.size))
    span = int(min(chunk, max(2 * int(length.max()), rows * sched.step)))
    bounds, los, his = _centre_groups(read_only(centre), read_only(length), pad, span, GROUP_GAP)
    blocks = []
    for g in range(los.size):
        c0, c1, lo = int(bounds[g]), int(bounds[g + 1]), int(los[g])
        task = dask.delayed(_group_rows, pure=True)(
            ext[lo : int(his[g])], ms, centre[c0:c1], length[c0:c1], pad - lo,
            float(scale), sched.step, int(exponent), stat,
        )  # fmt: skip
        blocks.append(da.from_delayed(task, shape=(c1 - c0, ms.size), dtype=np.float64))
    return da.concatenate(blocks, axis=0)


def davar(
    data: Sequence[float] | np.ndarray | sources.ChunkedSource | Any,
    *,
    window: Length | Sequence[int] | np.ndarray,
    stat: str = "oavar",
    rate: float = RATE_DEFAULT,
    data_type: str = "rate",
    taus: str | Sequence[float] | np.ndarray = "all",
    edges: str = "mirror",
    step: Length = 1,
    confidence: float | None = 0.683,
    tau0: float | None = None,
    t0: float = 0.0,
    points_per_decade: int = 10,
    noise_type: str | int | Sequence[int] = "record",
    units: str | None = None,
    chunk_size: int | None = None,
    lazy: bool | None = None,
    edge_edf: str = "distinct",
    gaps: str = "error",
    shift: Sequence[int] | np.ndarray | None = None,
    bounds: bool = True,
    rows: tuple[int, int] | None = None,
) -> DavarResult:
    """Dynamic Allan variance: the overlapping Allan (or Hadamard, modified) variance of a
    sliding window.

    Parameters
    ----------
    data : array_like, ChunkedSource, dask.array.Array or numpy.memmap
        The record, one sample per ``tau0``. A :class:`adavar.stats.stream.ChunkedSource`, a 1-D
        ``dask.array`` or a memory map of a ``.npy`` file (``numpy.load(path,
        mmap_mode="r")``, read back with file reads, not through the map) is processed out
        of core (see ``chunk_size``).
    window : int, str, Duration, timedelta or array_like of int
        Window length in samples, or a duration for a fixed window (``"10min"``,
        :func:`adavar.seconds`; rounded to whole samples): an int for a fixed window
        (DAVAR-L), or one length per
        sample of the record (any schedule, e.g. the adaptive controller's), or one per
        computed centre (``ceil(N / step)`` values). At least 3 and at most the record
        length. For even ``L`` the window holds ``L/2 - 1`` samples before its centre and
        ``L/2`` after (see :mod:`adavar.dynamic.windows`).
    stat : {"oavar", "ohvar", "mvar"}
        The variance of every window (NIST SP 1065). ``"oavar"`` (default): the
        overlapping Allan variance, ``sum d_m**2 / (2 tau**2 (L - 2m + 1))``.
        ``"ohvar"``: the overlapping Hadamard variance, third differences
        ``x[i+3m] - 3x[i+2m] + 3x[i+m] - x[i]`` of the phase,
        ``sum / (6 tau**2 (L - 3m + 1))``; it is insensitive to a rate ramp (a linear drift
        of the rate) in a window inside the record, and converges for noise down to
        alpha = -4. ``"mvar"``: the modified Allan variance, the sums of ``m`` consecutive
        second differences, ``sum / (2 m**2 tau**2 (L - 3m + 2))``; it tells white from
        flicker PM. The same taus (up to a third of each window), edges, per-cell EDF (of
        that statistic: :func:`adavar.stats.edf.edf` ``"ohdev"`` / ``"mdev"``) and out-of-core
        paths; ``result.stat`` is ``"oadev"``, ``"ohdev"`` or ``"mdev"``, and the noise
        model's fit (:func:`adavar.fit_noise`) takes only the Allan surface. With
        ``edges="mirror"`` the windows at the ends see the time-reversed record, where a
        rate ramp folds into a V: the Hadamard surface is insensitive to the ramp only where
        the window lies inside the record. There the reflection also biases the longest
        taus of a window half in the mirror (white FM, L = 200, first centre, mean over the
        interior's): 0.87 (oavar), 1.9 (ohvar), 0.03 (mvar: a modified term centred on the
        record's end is its own negative) at m = 64; 1.01, 1.04, 0.73 at m = 48; within
        4 % at m <= 32. Use ``edges="valid"`` where that matters.
    rate : float, optional
        Sample rate in Hz (ignored when ``tau0`` is given); by default as :func:`deviation`.
    data_type : {"rate", "phase"}
        Rate samples (gyro rate, accelerometer output, fractional frequency) or their
        integral (angle, velocity, time error). Phase input is differenced first; windows,
        centres and lengths then count its first differences.
    taus : {"all", "octave", "decade", "log"} or sequence of float
        Averaging times. ``"all"`` (the paper, the default here): ``m = 1 .. floor(Lmax /
        3)``. Taus beyond a third of a window are NaN for that window. The ``davar``
        command chooses ``taus`` and ``step`` when they are not given (``"all"`` up to 200
        taus, else ``"log"``; every centre while the surface fits ``--max-memory``, 200 MB,
        else every ``step``-th: :func:`adavar.dynamic.window_defaults.surface_resolution`); here
        the defaults are every tau and every centre, and a surface beyond the free memory
        is an error that says so: give ``taus="log"`` or ``"octave"`` and a ``step`` for
        long windows.
    edges : {"mirror", "valid"}
        ``"mirror"`` (docs/method.md section 6, the paper): every ``step``-th sample is a centre
        and windows at the ends run into the time-reversed record; ``"valid"``: only
        centres whose whole window lies inside the record.
    step : int, str, Duration or timedelta
        Compute every ``step``-th centre only (samples, or a duration).
    confidence : float or None
        Two-sided level of the per-cell chi-square bounds (default 0.683, 1 sigma). The
        EDF is the Greenhall-Riley EDF of the statistic (an overlapping Allan variance by
        default) of ``L + 1`` phase points (``L - 2m + 1`` terms for the Allan variance).
        The bounds are formed when first read (each costs the memory of ``avar``).
        ``None`` skips the noise identification and the bounds.
    tau0 : float, optional
        Sample interval in seconds, instead of ``rate``.
    t0 : float
        Time of the first sample, seconds (``time = t0 + centre * tau0``).
    points_per_decade : int
        Density of ``taus="log"``.
    noise_type : "record" or int or sequence of int
        Power-law noise exponent alpha used for the EDF. ``"record"`` (default): identified
        per tau on the whole record (lag-1 autocorrelation, B1 fallback), as
        :func:`adavar.deviation` does; noise *levels* change from window to window, their
        type at a given tau rarely does. An int applies one alpha everywhere (0: white rate
        noise/ARW, -1: bias instability, -2: rate random walk, 1/2: flicker/white PM or
        quantization); a sequence gives one per tau.
    edge_edf : {"distinct", "interior"}
        EDF of a window that reaches into the mirrored extension (``edges="mirror"``).
        ``"distinct"`` (default): that of an overlapping AVAR over its distinct terms,
        the mirrored ones counted as repeats (:func:`edf_table`), which keeps the 68 %
        intervals covering within ``L/2`` of the ends. ``"interior"``: the full window's
        EDF as before (coverage 47-57 % near the ends).
    gaps : {"error", "omit"}
        A NaN sample is an error (default), or (``"omit"``) a missing sample on the regular
        grid: in every window each difference term that touches one is left out (the
        rules of ``deviation(gaps="omit")``), each cell is the mean of its kept terms,
        ``result.terms`` holds their counts (NaN cells where none is kept) and each cell's
        EDF is that of a gap-free window with as many terms; the noise type is identified
        on the whole record's kept data. A record without NaN gives the gap-free result
        bit for bit. Computed in memory (a chunked record with NaN is read into memory;
        not with an explicit ``chunk_size`` nor a lazy surface). See
        :mod:`adavar.dynamic.davar_gaps`.
    shift : array_like of int, optional
        Windows that do not centre on their centre: the row of centre ``p`` is computed on
        the window of its length centred at ``p + shift`` (one value per sample or per
        computed centre, as ``window``), e.g. a one-sided window ending at ``p``
        (``shift = -(L // 2)``) or starting there (``shift = (L - 1) // 2``), which the
        adaptive window of :mod:`adavar.dynamic.ici` uses next to a change. The EDF of a row
        follows its actual window (its overhang into the mirrored ends); the result keeps
        the offsets (``result.shift``). Not with ``gaps="omit"`` on a record with NaN.
    units : str, optional
        Declared unit of the *rate* (e.g. ``"deg/s"``; for phase input the unit of its
        derivative: angle in deg gives ``"deg/s"``), carried to the fit's unit conversions
        and the figures. Never guessed.
    chunk_size : int, optional
        Process out of core, reading about this many samples at a time. Default: in memory
        for an array, :data:`adavar.stats.stream.DEFAULT_CHUNK` (4 Mi samples) for a chunked
        input. Consecutive centres are grouped so that their windows span about
        ``chunk_size`` samples of the mirror-extended record (one window when a window is
        longer; centres further apart than 65536 samples are read window by window); each
        group's span is read and handed to the same kernel. The noise identification
        (``noise_type="record"``)
        reads the record twice more in pieces of ``chunk_size``
        (:func:`adavar.stats.stream.noise_types`). The result equals the in-memory one to
        rounding (1e-15 relative in practice), with the same schedule, alpha and EDFs, for
        any ``chunk_size``. Held in memory: the output (``N_centres x M`` values and the
        per-centre centres, lengths and classes), one piece and its integral (about 6 x 8
        bytes per sample of ``max(chunk_size, longest window)``), and for phase input one
        more copy of the piece.
    lazy : bool, optional
        Return ``avar`` (and the bounds and ``adev`` derived from it) as a ``dask.array``
        that is computed on demand, one task per group of centres (blocks of at most
        :data:`LAZY_BLOCK_VALUES` values, ``chunk_size`` samples of record). Default: lazy
        when ``data`` is a dask array, so a per-sample surface of a long record can be
        reduced, sliced or written (``result.to_xarray().to_netcdf``) block by block. The
        schedule, ``alpha`` and the EDF table are computed at once; the noise
        identification (``confidence`` with ``noise_type="record"``) reads the record in
        pieces at once, so pass an integer ``noise_type`` or ``confidence=None`` to read
        nothing until the result is computed. ``lazy=False`` computes a dask input now
        (out of core, as above).

    bounds : bool
        Make the per-length bound factors (``bound_table``; default). False leaves
        ``bound_table``, ``avar_low`` and ``avar_high`` None while the noise types and the
        EDF table are made as usual (a noise fit weights by them): for surfaces whose
        bounds nothing reads (``compare(..., keep="figures")``), without the chi-square
        quantile of every distinct EDF.
    rows : (int, int), optional
        Only the rows (centres) ``start .. stop - 1`` of the surface (``stop`` past the
        last centre stops there): a block of it, for a
        caller that works through the surface of a long record piece by piece
        (:mod:`adavar.dynamic.surface_fit`). Every row equals that row of the whole surface bit
        for bit; ``time``, ``avar``, ``window``, ``centre``, ``window_class`` and ``shift``
        hold the block's rows, every other field (``alpha``, the EDF and bound tables,
        ``notes``) is the whole surface's. An in-memory record without missing samples
        (not ``lazy``, ``chunk_size`` or ``gaps="omit"``).

    Returns
    -------
    DavarResult
        ``time``, ``tau``, ``avar`` (time x tau), ``avar_low``, ``avar_high``, ``window``,
        ``centre``, ``.adev``, ``.edf``, ``.to_xarray()``, ``.to_pandas()``. For
        ``stat="ohvar"`` or ``"mvar"`` a :class:`DavarStatResult` (a DavarResult whose
        ``avar`` holds that statistic and whose ``stat`` says which).

    Raises
    ------
    AdavarInputError
        Bad data (non-finite, or a masked array with masked samples), a window shorter
        than 3 or longer than the record, a rate that is not a positive number (or whose
        taus overflow), unknown options, a surface too large for the free memory, or
        variances beyond the float64 range (data near 1e154 and above, or near 1e-154 and
        below: rescale the data).

    Notes
    -----
    Cost O(N_centres * M) after an O(N) integration, independent of the window length,
    parallel over chunks of centres (``"ohvar"`` about 1.1 and ``"mvar"`` about 1.5 times
    the time of ``"oavar"``). ``davar(x, window=L, edges="valid")`` at a centre equals
    ``adavar.deviation(x[a:a+L], stat="oadev")`` to rounding (``stat="ohvar"``, ``"mvar"``:
    ``stat="ohdev"``, ``"mdev"``). Out of core the record is read about three times (twice
    for the noise identification, once for the windows: only their spans, so a sparse
    ``step`` reads little) and the cost is that of the in-memory path plus the reads.
    """
    result = next(_surfaces(
        data, window=window, stat=stat, rate=rate, data_type=data_type, taus=taus,
        edges=edges, step=step, confidence=confidence, tau0=tau0, t0=t0,
        points_per_decade=points_per_decade, noise_type=noise_type, units=units,
        chunk_size=chunk_size, lazy=lazy, edge_edf=edge_edf, gaps=gaps, shift=shift,
        bounds=bounds, rows=rows, block_values=None,
    ))  # fmt: skip
    return with_record_curve(result, data, chunk_size=chunk_size, lazy=lazy, gaps=gaps)


def with_record_curve(
    result: DavarResult, data: Any, *, chunk_size: int | None = None,
    lazy: bool | None = None, gaps: str = "error", out_of_core: bool = False,
) -> DavarResult:  # fmt: skip
    """``result`` with the whole record's octave OADEV (:attr:`DavarResult.record_curve`),
    the reference of its windows' fit; unchanged out of core or lazily, where the curve
    would read the whole file once more (``adavar davar`` gives ``reference=`` there),
    unless ``out_of_core`` (the blocks of :func:`davar_blocks`, which read it many times:
    one more streamed pass gives their fit the in-memory one's reference)."""
    elsewhere = chunk_size is not None or sources.is_chunked(data) or sources.is_dask(data)
    if getattr(result, "stat", "oadev") != "oadev" or result.n_samples < 8 or lazy:
        return result
    if elsewhere and not out_of_core:
        return result
    try:
        curve = deviation(data, tau0=result.tau0, data_type=result.data_type, taus="octave",
                          units=result.units, gaps="error" if gaps == "error" else "omit",
                          stationarity_check=False, chunk_size=chunk_size)  # fmt: skip
    except (ValueError, AdavarInputError):  # too short for a curve: the windows go without
        return result
    return dataclasses.replace(result, record_curve=curve)


def davar_blocks(
    data: Sequence[float] | np.ndarray, *, block_values: int | None = None, **options: Any
) -> Iterator[DavarResult]:
    """:func:`davar` a block of consecutive windows at a time, for a surface too large to hold.

    Parameters
    ----------
    data : array_like or source
        The record without missing samples: in memory, or read piece by piece (a file
        memory map, a :class:`~adavar.io.sources.ChunkedSource`; ``chunk_size=`` too), a
        block's span at a time (each row then equals the whole surface's to an ulp or so).
    block_values : int, optional
        Values per block (default :data:`BLOCK_VALUES`): whole rows, a multiple of the
        window kernel's chunk of centres (at least one chunk).
    **options
        Keywords of :func:`davar` but ``rows``.

    Yields
    ------
    DavarResult
        Consecutive blocks of rows (``centre`` tells which), each as ``davar(...,
        rows=)`` gives it: every row equals that row of the whole surface bit for bit,
        ``alpha``, the EDF and bound tables and ``notes`` are the whole surface's. The
        record is read, the schedule made and the noise types identified once. The
        per-window fields (``time``, ``window``, ``centre``, ``window_class``, ``shift``)
        are read-only views of the whole surface's arrays: consecutive blocks join into
        them without a copy, and a block kept keeps them.
    """
    arguments = inspect.signature(davar).bind(data, **options)
    arguments.apply_defaults()
    if arguments.arguments["rows"] is not None:
        raise AdavarInputError("davar_blocks chooses the rows itself: leave rows= out")
    values = BLOCK_VALUES if block_values is None else int(block_values)
    if values < 1:
        raise AdavarInputError(f"block_values must be a positive number, got {block_values!r}")
    blocks = _surfaces(**arguments.arguments, block_values=values)
    return _blocks_with_curve(blocks, data, arguments.arguments["chunk_size"])


def _blocks_with_curve(
    blocks: Iterator[DavarResult], data: Any, chunk_size: int | None
) -> Iterator[DavarResult]:
    """The blocks, each with the whole record's curve (computed once, with the first)."""
    first = next(blocks, None)
    curve = None
    if first is not None:
        curve = with_record_curve(first, data, chunk_size=chunk_size, out_of_core=True)
        curve = curve.record_curve
    for block in itertools.chain(() if first is None else (first,), blocks):
        yield dataclasses.replace(block, record_curve=curve)


#: surface values per block of :func:`davar_blocks` (8 MiB of float64; a block and its
#: noise fit hold about 7 times that at their peak; larger blocks were no faster)
BLOCK_VALUES = 1 << 20


def _surfaces(
    data: Any, *, window: Any, stat: str, rate: float, data_type: str, taus: Any, edges: str,
    step: Any, confidence: float | None, tau0: float | None, t0: float, points_per_decade: int,
    noise_type: Any, units: str | None, chunk_size: int | None, lazy: bool | None,
    edge_edf: str, gaps: str, shift: Any, bounds: bool, rows: tuple[int, int] | None,
    block_values: int | None,
) -> Iterator[DavarResult]:  # fmt: skip
    """The body of :func:`davar`: one result, or (``block_values``) blocks of rows."""
    dtype = DATA_TYPE_ALIASES.get(str(data_type).lower())
    if dtype is None:
        raise AdavarInputError(f"unknown data_type {data_type!r}: use 'rate' or 'phase'")
    name = STATS.get(stat) if isinstance(stat, str) else None
    if name is None:
        raise AdavarInputError(f"unknown stat {stat!r}: use 'oavar', 'ohvar' or 'mvar'")
    check_confidence(confidence)
    if edge_edf not in ("distinct", "interior"):
        raise AdavarInputError(f"unknown edge_edf {edge_edf!r}: use 'distinct' or 'interior'")
    try:
        t0 = float(t0)
    except (TypeError, ValueError):
        raise AdavarInputError(f"t0 must be a number of seconds, got {t0!r}") from None
    rate, tau0, dt = resolve_rate(data, rate, tau0)  # a time index gives it, or 1 Hz
    min_length = 4 if dtype == "phase" else 3
    if gaps != "error":  # loaded on first use
        from adavar.dynamic.davar_gaps import gap_davar, missing_record

        found = missing_record(data, gaps=gaps, chunk_size=chunk_size, lazy=lazy)
        if found is not None and shift is not None:
            raise AdavarInputError(
                "shifted windows (shift=) are not supported on a record with missing "
                "samples: fill the gaps first, or use centred windows"
            )
        if found is not None and (rows is not None or block_values is not None):  # in memory
            raise AdavarInputError(
                "rows of a surface (rows=, davar_blocks) are for records without missing "
                "samples: compute the whole surface"
            )
        if found is not None:
            result = gap_davar(
                found[0], found[1], notes=found[2], window=window, stat=name, rate=rate,
                tau0=tau0, dt=dt, data_type=dtype, taus=taus, edges=edges, step=step,
                confidence=confidence, t0=t0, points_per_decade=points_per_decade,
                noise_type=noise_type, units=units, edge_edf=edge_edf,
            )  # fmt: skip
            yield result if bounds else dataclasses.replace(result, bound_table=None)
            return
    refuse_masked(data)
    # computed at scale 1 (exact: powers of two), the variances scaled back by 2**exponent
    dt_mantissa, dt_exponent = math.frexp(dt)
    scale = 1.0 if dtype == "rate" else 1.0 / dt_mantissa**2
    exponent = 0 if dtype == "rate" else -2 * dt_exponent
    chunked = chunk_size is not None or sources.is_chunked(data)
    if lazy is None:
        lazy = sources.is_dask(data)
    elif lazy and not sources.is_dask(data):
        raise AdavarInputError("lazy=True needs a dask array as data: leave lazy out")
    if chunked:
        chunk = sources.check_chunk_size(chunk_size) if chunk_size is not None else None
        chunk = sources.DEFAULT_CHUNK if chunk is None else chunk
        source = sources.open_record(data, min_length)
        n_samples = source.size
        n = n_samples - 1 if dtype == "phase" else n_samples
        scaled_increments: list[tuple[sources.ChunkedSource, int]] = []

        def increments() -> tuple[sources.ChunkedSource, int]:
            """The scaled increments (read only when needed: a lazy surface reads nothing)."""
            if not scaled_increments:
                src, k = scaled_source(source)
                inc = src if dtype == "rate" else sources.DifferencedSource(src)
                scaled_increments.append((inc, k))
            return scaled_increments[0]

    else:
        x, k = scaled(as_samples(data, min_length=min_length, missing_hint=OMIT_HINT))
        u = x if dtype == "rate" else np.diff(x)
        n_samples, n = x.size, u.size

    # a duration (``"10min"``, ``adavar.seconds(600)``) is samples of this record
    window = to_samples(window, dt, "window")
    step = to_samples(step, dt, "step")
    sched = window_schedule(n, window, edges=edges, step=step, shift=shift)
    longest = int(sched.length.max())
    ms, notes = tau_factors(taus, longest // 3, dt, points_per_decade)
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    n_rows = sched.centre.size
    if (rows is not None or block_values is not None) and lazy:
        raise AdavarInputError(
            "rows of a surface (rows=, davar_blocks) are for an array or a file read piece "
            "by piece, not a lazy (dask) surface: leave lazy out"
        )
    if rows is not None:
        start, stop = (int(r) for r in rows)
        if not 0 <= start < min(stop, n_rows):
            raise AdavarInputError(
                f"rows=({start}, {stop}) must start in 0 .. {n_rows - 1} (the centres) "
                "before it stops"
            )
        stop = min(stop, n_rows)
    else:
        start, stop = 0, n_rows
    if not lazy:
        held = stop - start
        if block_values is not None:
            held = min(
                n_rows,
                max(
                    block_values // max(1, ms.size),
                    centre_chunk_size(n_rows, longest, sched.step),
                ),
            )
        check_surface_memory(held, ms.size, 1)

    dmax = 3 if name == "ohdev" else 2  # differences of the statistic, as deviation()

    def identify() -> tuple[np.ndarray, tuple[str, ...]]:
        if chunked:
            return stream.noise_types(increments()[0], ms, dmax, chunk_size=chunk, data_type=dtype)
        return record_noise_types(
            diff.anchored_phase(u, cluster_stats=True), ms, dmax, data_type=dtype
        )

    bound_table = table = classes = None
    if confidence is None:
        alpha = np.full(ms.size, -1, dtype=np.int64)
    else:
        alpha, id_notes = noise_alpha(noise_type, ms, identify, name)
        notes = notes + id_notes
        # the windows near the two ends that hold mirrored samples get rows of their own;
        # each block's classes are found when it is made (none for every window at once)
        classes = window_classes(sched, edges_apart=edge_edf == "distinct")
        table = interior_edf_table(classes.lengths, ms, alpha, name)
        if classes.edge_pairs.size:
            pairs = classes.edge_pairs
            table = np.vstack([table, edf_table(pairs[:, 0], ms, alpha, overhang=pairs[:, 1],
                                                stat=name)])  # fmt: skip
        if bounds:
            bound_table = np.stack(bound_factors(table, float(confidence)))

    with np.errstate(over="ignore"):
        # dividing by an integral rate rounds once: 3999 / 10 is 399.9, 3999 * 0.1 is not
        time = t0 + (sched.centre * dt if tau0 is not None else sched.centre / float(rate))
    check_window_times(time, sched.centre, t0, dt)  # overflow, or too coarse for dt
    # the kernel computes chunks of centres each on its own: a block that starts and ends
    # on them (or is cut from whole ones) has the whole surface's rows
    chunk_rows = centre_chunk_size(n_rows, longest, sched.step)
    extended = None if lazy or chunked else sched.extend(u)

    def block(start: int, stop: int) -> DavarResult:
        """Rows ``start .. stop - 1`` of the surface (all of them: the whole surface)."""
        whole = (start, stop) == (0, n_rows)
        power = 0 if chunked else k  # the record's scale (out of core: once it is read)
        if lazy:
            avar = _lazy_avar(data, dtype, sched, ms, scale, chunk, exponent, name)
        elif chunked:
            inc, power = increments()
            avar = _chunked_avar(inc, sched, ms, scale, chunk, name, start, stop)
        else:
            a = start - start % chunk_rows
            b = min(n_rows, -(-stop // chunk_rows) * chunk_rows)
            avar = _window_surface(
                name, extended, ms, sched.window_centre[a:b], sched.length[a:b],
                offset=sched.pad_before, scale=scale, chunk=chunk_rows,
            )  # fmt: skip
            if (a, b) != (start, stop):  # the block's rows alone, not a view of the chunks
                avar = avar[start - a : stop - a].copy()
        if not lazy:
            avar = unscale(avar, 2 * power + exponent, plural_name(name), underflow=False)

        def rows_of(values: np.ndarray | None) -> np.ndarray | None:
            """A block's rows: for ``rows=``, arrays of their own (a view would hold the
            record's); for the blocks of :func:`davar_blocks`, read-only views of the whole
            surface's per-window arrays (its consumer joins them without a copy)."""
            if values is None or whole:
                return values
            if block_values is None:
                return values[start:stop].copy()
            view = values[start:stop]
            view.flags.writeable = False
            return view

        surface = dict(
            time=rows_of(time),
            tau=ms * dt,
            avar=avar,
            window=rows_of(sched.length),
            centre=rows_of(sched.centre),
            m=ms,
            alpha=alpha,
            tau0=dt,
            data_type=dtype,
            edges=sched.edges,
            step=sched.step,
            confidence=float("nan") if confidence is None else float(confidence),
            n_samples=int(n_samples),
            units=units,
            notes=notes,
            edf_table=table,
            window_class=None if classes is None else classes.rows(start, stop),
            bound_table=bound_table,
            shift=rows_of(sched.shift),
        )
        if name == "oadev":
            return DavarResult(**surface)
        return DavarStatResult(**surface, stat=name)

    if block_values is None:
        yield block(start, stop)
        return
    per_block = max(1, block_values // max(1, ms.size) // chunk_rows) * chunk_rows
    for first in range(0, n_rows, per_block):
        yield block(first, min(first + per_block, n_rows))

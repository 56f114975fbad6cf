"""The analysis of one file: the pipeline behind ``adavar davar``, ``adaptive``, ``report``
and ``batch``.

A command builds one :class:`~adavar.core.request.AnalysisRequest` from its flags and calls
:func:`run`: read (:func:`read_input`: the record, its rate and unit, preprocessed; a file
piece by piece where it can) -> the window-like lengths in samples of the record
(:func:`resolve_lengths`) and the surface's resolution (:func:`resolve_resolution`) ->
analyse each channel (:func:`analyse_channel`: deviation and noise fit, the DAVAR surface
and the coefficients over time). :func:`adavar.pipeline.report_analysis.analyse_file` is the same
for one file as ``adavar report FILE`` and every task of ``adavar batch`` compute it.

The keyword layer: :func:`analyse_channel` and :func:`resolve_lengths` also take an
options object with the flags' names (an ``argparse.Namespace``), and
:func:`fit_keywords` and :func:`controller_settings` turn a request
or options into the library functions' keywords, in one place. Problems with the input
raise :class:`adavar.core.errors.AdavarInputError`; nothing is printed.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from adavar.core.durations import to_samples
from adavar.core.errors import AdavarInputError
from adavar.core.request import AnalysisRequest, RecordRequest
from adavar.core.settings import ControllerSettings, FitSettings
from adavar.dynamic.adaptive import adaptive_davar
from adavar.dynamic.schedule import window_lengths
from adavar.dynamic.surface import davar
from adavar.dynamic.window_defaults import record_windows, surface_resolution
from adavar.fit.noise_model import fit_noise
from adavar.io import sources
from adavar.stats.statistics import deviation

__all__ = [
    "AnalysisRun",
    "ChannelAnalysis",
    "LoadedInput",
    "aliasing_notes",
    "analyse_channel",
    "controller_settings",
    "fit_keywords",
    "is_constant",
    "rate_keywords",
    "read_input",
    "refuse_constant_channels",
    "resolve_lengths",
    "resolve_resolution",
    "run",
    "window_fit_keywords",
]


@dataclass(eq=False)
class LoadedInput:
    """A record as :func:`read_input` read it.

    Attributes
    ----------
    channels : dict
        Name -> samples (an array, or a source read piece by piece); with ``--gaps split``
        one entry per gap-free piece.
    units : dict
        Name -> the samples' unit.
    meta : dict
        How they were read (``path``, ``column`` (the first), ``kind``, ``rate_from``,
        ``reader``, ``preprocessing``, ``columns``, ``pieces``).
    tau0 : float
        Sample interval (s).
    record : RecordRequest
        The request as read: ``data_type`` as the file says (a Stable32 ``.phd`` file holds
        phase), ``rate`` or ``tau0`` as the analysis uses them.
    """

    channels: dict[str, Any]
    units: dict[str, str]
    meta: dict[str, Any]
    tau0: float
    record: RecordRequest

    @property
    def first(self) -> tuple[Any, str]:
        """The first channel's samples and unit."""
        name = next(iter(self.channels))
        return self.channels[name], self.units[name]


def _channel_units(record: RecordRequest, read: Any) -> dict[str, str | None]:
    """The unit of every channel read: ``units`` (or each of ``unit_groups``), which must
    agree with the units the file declares, else the file's own; none is an error."""
    if not record.unit_groups:
        given = record.units.strip() if record.units and record.units.strip() else None
        units_of = read.units_of(given)
        if not all(units_of.values()):
            raise AdavarInputError(
                "declare the unit of the samples with --units (e.g. --units deg/s); adavar "
                "never guesses units"
            )
        return units_of
    units_of: dict[str, str | None] = {}
    for group in record.unit_groups:
        given = group.units.strip() if group.units and group.units.strip() else None
        declared = read.units_of(given, names=list(group.columns), flag=group.flag)
        # one unit a group (a sensor): the declared one, else its first channel's
        units_of.update(dict.fromkeys(group.columns, declared[group.columns[0]]))
    missing = [c for c in read.names if not units_of.get(c)]
    if missing:
        flags = " and ".join(f"{g.flag} (e.g. {g.example})" for g in record.unit_groups)
        raise AdavarInputError(f"declare the units with {flags}; adavar never guesses units")
    return units_of


def read_input(
    record: RecordRequest,
    *,
    several: bool = False,
    pieces: bool | None = None,
    out_of_core: bool = False,
    hint: str = " (or several, comma-separated, e.g. --column a,b)",
) -> LoadedInput:
    """Read a record's channels, preprocess them, and settle their unit and tau0 (seconds).

    With ``out_of_core`` (the analyses that stream), a memory-mapped ``.npy`` column or a
    lazy HDF5/Parquet channel is passed on as it is, so a record larger than memory is read
    piece by piece; preprocessing loads it.

    With ``several``, every selected channel (``column="gx,gy,gz"``, or all numeric
    columns) is read; else the file must have one (or ``column`` choose it; ``hint`` ends
    that error). With ``pieces`` (default: ``several``), ``gaps="split"`` gives each
    gap-free piece of a channel as a channel of its own.

    The rate comes from ``rate``/``tau0`` or from the file's time stamps (both: they must
    agree); the unit from ``units`` or from the format (ROS bags declare rad/s and m/s^2).
    ``record`` is not changed: :attr:`LoadedInput.record` is the request as read.
    """
    from adavar._kernels._heap import release_free_memory
    from adavar.io.preprocess import preprocess
    from adavar.readers import file_data_type, read_record

    if record.rate is not None and record.tau0 is not None:
        raise AdavarInputError("give exactly one of --rate HZ or --tau0 SECONDS (both given)")
    declared = record.rate if record.rate is not None else (
        1.0 / record.tau0 if record.tau0 is not None else None
    )  # fmt: skip
    gaps, nan = record.reader_gaps()
    read = read_record(
        record.file, columns=record.column, rate=declared,
        time_column=record.time_column, time_format=record.time_format,
        gaps=gaps, nan=nan, dataset=record.dataset, topic=record.topic,
        gap_tolerance=record.gap_tolerance, lazy=record.lazy,
        memory_map=False,  # .npy read with file reads: a file cut short is an error, no SIGBUS
    )  # fmt: skip
    # a Stable32 .phd file holds phase, a .frd frequency
    data_type = file_data_type(record.file, record.data_type)
    if len(read.names) != 1 and not several:
        raise AdavarInputError(
            f"{record.file} has {len(read.names)} channels ({', '.join(read.names)}): "
            f"choose one with --column{hint}"
        )
    units_of = _channel_units(record, read)
    rate = float(read.rate)
    steps: list[dict[str, Any]] = []
    channels: dict[str, Any] = {}
    split = read.segments is not None and len(read.segments) > 1
    if split and not (several if pieces is None else pieces):
        raise AdavarInputError(
            f"{record.file} has {len(read.segments)} gap-free pieces: --gaps split is for "
            "adavar avar; here use --gaps interpolate, or give a file with one piece"
        )
    for name in read.names:
        parts = read.pieces(name) if split else [read.channel(name)]
        for k, piece in enumerate(parts):
            preprocessing = bool(record.preprocess)
            if out_of_core and not preprocessing and sources.is_chunked(piece):
                x = piece
            else:
                x = np.asarray(piece, dtype=np.float64)
            if preprocessing:
                x, new_rate, steps = preprocess(x, rate=float(read.rate),
                                                steps=record.preprocess)  # fmt: skip
                rate = float(new_rate)
            key = f"{name} piece {k + 1}" if split else name
            channels[key] = x
            units_of[key] = units_of[name]
    name = next(iter(channels))
    tau0 = float(record.tau0) if record.tau0 is not None and not steps else 1.0 / rate
    # the rate as the analysis gives it: as declared (times are centre / rate, without
    # rounding), from the time stamps, or tau0 as declared
    used_rate = float(record.rate) if record.rate is not None and not steps else rate
    rate_tau0 = (used_rate, None) if record.tau0 is None or steps else (None, tau0)
    meta = {
        "path": str(record.file), "column": name, "kind": read.kind,
        "rate_from": "declared" if declared is not None else "time stamps",
        "reader": read.meta, "preprocessing": steps, "columns": list(read.names),
        "preprocessing_notes": aliasing_notes(steps, data_type),
        "pieces": None if not split else [
            [float(read.time[sl.start]), float(read.time[sl.stop - 1])]
            for sl in read.segments
        ],
    }  # fmt: skip
    # the record's other columns, its time stamps and the parser threads' arenas are
    # freed now: their pages go back before the analysis makes its peak
    read = piece = parts = x = None
    release_free_memory()
    as_read = dataclasses.replace(record, data_type=data_type, rate=rate_tau0[0],
                                  tau0=rate_tau0[1])  # fmt: skip
    return LoadedInput(channels={k: channels[k] for k in channels},
                       units={k: units_of[k] for k in channels}, meta=meta, tau0=tau0,
                       record=as_read)  # fmt: skip


def _lengths(
    tau0: float, n_samples: int | None, *, window: Any, lmax: Any, lmin: Any, segment: Any,
    step: Any, adaptive: bool,
) -> dict[str, Any]:  # fmt: skip
    """The window-like lengths in samples (the one rule of :func:`resolve_lengths`)."""
    out: dict[str, Any] = {}
    if window is not None:
        out["window"] = to_samples(window, tau0, "--window")
    if not adaptive:
        if step is not None:
            out["step"] = to_samples(step, tau0, "--step")
        return out
    if None in (lmax, lmin, segment):
        if lmax is None and n_samples is None:  # pragma: no cover - callers pass it
            raise AdavarInputError("the record's length is needed to choose the windows")
        given = None if lmax is None else to_samples(lmax, tau0, "--lmax")
        chosen = record_windows(n_samples or 0, given)
        out["windows_from"] = "record" if lmax is None else "lmax"
        lmax, lmin, segment = (chosen[k] if v is None else v
                               for k, v in enumerate((lmax, lmin, segment)))  # fmt: skip
    else:
        out["windows_from"] = "flags"
    out["lmax"], out["lmin"], out["segment"], chosen_step = window_lengths(
        tau0, lmax=lmax, lmin=lmin, l=segment, step=1 if step is None else step,
    )  # fmt: skip
    if step is not None:  # None: resolve_resolution chooses it
        out["step"] = chosen_step
    return out


def is_constant(samples: Any, chunk_size: int | None = None) -> bool:
    """Whether every sample equals the first (NaN equals nothing), read a piece at a time:
    a streamed record (a :class:`adavar.io.sources.ChunkedSource`) is not loaded for it."""
    source = sources.as_source(samples)
    chunk_size = sources.DEFAULT_CHUNK if chunk_size is None else chunk_size
    if source.size == 0:
        return False
    first = source.read_unchecked(0, 1)[0]
    for start in range(0, source.size, chunk_size):
        if not np.all(source.read_unchecked(start, min(source.size, start + chunk_size)) == first):
            return False
    return True


def refuse_constant_channels(loaded: LoadedInput, what: str) -> None:
    """A one-line error for a constant channel of ``loaded`` (a dead axis, or the wrong
    column): it has no noise for ``what`` (e.g. "a dynamic Allan variance")."""
    for name, samples in loaded.channels.items():
        if is_constant(samples):
            value = float(sources.as_source(samples).read_unchecked(0, 1)[0])
            raise AdavarInputError(
                f"column {name!r} is constant ({value:g} in every sample): it has no noise "
                f"for {what}; check --column and that the sensor was recording"
            )


def resolve_lengths(args: Any, tau0: float, n_samples: int | None = None) -> Any:
    """The request (or options) with the window-like lengths (``window``, ``lmax``,
    ``lmin``, ``segment`` = ``l``, ``step``) in samples of this record: a copy, the one
    given is left as it is.

    Durations (``"10min"``) are converted with ``tau0``. An adaptive window not given
    (``lmax``, ``lmin`` or ``segment`` None) takes the paper's proportions
    (:func:`adavar.dynamic.adaptive.record_windows`): Lmax a tenth of the ``n_samples``-sample
    record, Lmin two thirds and l a sixth of Lmax. ``windows_from`` says which:
    ``"flags"``, ``"lmax"`` (Lmin and l from it) or ``"record"``.

    ``args`` is an :class:`~adavar.core.request.AnalysisRequest` (a new one is returned) or an
    options object with the flags' names (the controller's lengths resolved only when it
    has ``lmax``).
    """
    if isinstance(args, AnalysisRequest):
        c, w = args.controller, args.window
        # the controller's lengths: for the adaptive window, or given (a fixed window's
        # events read l)
        controller = w.adaptive or any(v is not None for v in (c.lmax, c.lmin, c.l))
        out = _lengths(tau0, n_samples, window=w.window, lmax=c.lmax, lmin=c.lmin,
                       segment=c.l, step=w.step, adaptive=controller)  # fmt: skip
        if "segment" in out:
            out["l"] = out.pop("segment")
        if args.windows_from is not None:  # resolved before: where they came from stays
            out.pop("windows_from", None)
        return args.with_lengths(**out)
    out = _lengths(tau0, n_samples, window=getattr(args, "window", None),
                   lmax=getattr(args, "lmax", None), lmin=getattr(args, "lmin", None),
                   segment=getattr(args, "segment", None), step=getattr(args, "step", None),
                   adaptive=hasattr(args, "lmax"))  # fmt: skip
    args = copy.copy(args)
    for name, value in out.items():
        setattr(args, name, value)
    return args


def resolve_resolution(
    request: AnalysisRequest, tau0: float, n_samples: int, channels: int = 1
) -> tuple[AnalysisRequest, str | None]:
    """Taus and centres of a surface the user left to adavar (``taus`` / ``step`` None).

    The rule of :func:`adavar.dynamic.adaptive.surface_resolution` (the library's default too):
    ``taus`` ``"all"`` while that is at most :data:`~adavar.core.settings.MAX_ALL_TAUS` taus, else
    ``"log"`` (10 per decade); ``step`` every centre while the surfaces of the ``channels``
    channels fit ``max_memory`` MB together at
    :data:`adavar.dynamic.window_defaults.CELL_BYTES` a cell, else every ``step``-th. Returns a
    new request with them and a sentence saying what was chosen and why (None when
    nothing was).
    """
    w = request.window
    longest = request.controller.lmax if w.adaptive else w.window
    # a window longer than the record is refused by the statistic, in its own words; its
    # taus here are those of the record (a window of 1e21 samples has no tau grid)
    longest = min(int(longest), max(int(n_samples), 1))
    taus, step, why = surface_resolution(
        longest, n_samples, tau0, taus=w.taus, step=w.step,
        points_per_decade=w.points_per_decade, max_memory=w.max_memory, channels=channels,
    )  # fmt: skip
    request = request.with_lengths(taus=taus, step=step)
    if not why:
        return request, None
    shared = f" ({channels} channels' surfaces together)" if channels > 1 else ""
    return request, (
        "resolution: " + ", ".join(why) + f", to keep the surface within --max-memory "
        f"{w.max_memory:g} MB{shared} (give --taus / --step to choose)"
    )


@dataclass(eq=False)
class ChannelAnalysis:
    """One channel's analysis (:func:`analyse_channel`).

    Attributes
    ----------
    result : DeviationResult or None
        The whole record's deviation (``whole="fit"``; ``whole="reference"``: the octave
        curve of the windows' reference fit, or None).
    fit : NoiseFit or None
        Its noise fit (``whole="reference"``: the full-covariance reference, or None).
    surface, adaptive, coefficients
        The DAVAR surface (a result, or a :class:`~adavar.dynamic.surface_fit.BlockFit` with
        ``keep="figures"``), the adaptive windows (None for a fixed window) and the fit of
        every window (None without bounds or for a variance other than the Allan
        variance); all None without ``window`` or ``adaptive``.
    units, rate_units : str
        The samples' unit and the rate unit of the deviation.
    samples : int
        Number of samples.
    request : AnalysisRequest
        The request as used: the window-like lengths in samples of this record
        (:func:`resolve_lengths`).
    events, shape, controller : dict or None
        Filled in by the commands that show them (the events, :func:`surface_shape`, the
        controller's parameters).
    """

    result: Any
    fit: Any
    surface: Any
    adaptive: Any
    coefficients: Any
    units: str
    rate_units: str
    samples: int
    request: AnalysisRequest
    events: dict[str, Any] | None = None
    shape: dict[str, Any] | None = None
    controller: dict[str, Any] | None = None

    @property
    def options(self) -> Any:
        """The request as used, flat, by the flags' names (:meth:`AnalysisRequest.options`)."""
        return self.request.options()


#: What :func:`analyse_channel` and :func:`analyse_file` keep of a surface.
KEEP = ("all", "figures")
#: Which channels :func:`run` analyses.
CHANNELS = ("chosen", "one", "all")
#: What :func:`analyse_channel` computes of the whole record.
WHOLE = ("fit", "curve", "reference")


def as_request(options: Any) -> AnalysisRequest:
    """An :class:`~adavar.core.request.AnalysisRequest` as it is, or one from options by the
    flags' names (the keyword layer)."""
    return options if isinstance(options, AnalysisRequest) else (
        AnalysisRequest.from_options(options)
    )  # fmt: skip


def rate_keywords(request: AnalysisRequest, tau0: float) -> dict[str, Any]:
    """``rate``/``tau0`` for the library: the rate as given (times are centre / rate,
    without rounding noise), else tau0."""
    rate = request.record.rate
    return dict(rate=rate if rate is not None else 1.0, tau0=None if rate is not None else tau0)


def analyse_channel(
    request: AnalysisRequest | Any, samples: Any, units: str, tau0: float,
    status: Callable[[str], None] | None = None, tag: str = "", keep: str = "all",
    whole: str = "fit", name: str | None = None,
) -> ChannelAnalysis:  # fmt: skip
    """One channel's analysis: the whole record's deviation and noise fit, and (with a
    window) the DAVAR surface and the fit of every window.

    ``request`` is an :class:`~adavar.core.request.AnalysisRequest` (or options by the flags'
    names); ``status`` receives one line per step.

    ``whole="fit"`` (``adavar report``, ``adavar batch``, ``adavar avar --fit``): the
    deviation (``request.deviation``) and noise fit of the whole record, the reference of
    the windows' fits when it is a full-covariance fit; ``whole="curve"``: the deviation
    alone. ``whole="reference"`` (``adavar davar``, ``adavar adaptive``): only the
    full-covariance fit of the octave curve the windows' fits take as reference (the
    sensor's roll-off is the same in every window), and only when the windows are fitted
    (bounds on, the Allan variance) with ``fit.method`` ``"auto"`` or ``"gls"``; a record
    too short for it has none.

    ``keep="figures"``: the surface is computed and fitted a block of windows at a time
    (:mod:`adavar.dynamic.surface_fit`); ``surface`` is then a
    :class:`~adavar.dynamic.surface_fit.BlockFit` (the rows the report draws, every window's time,
    length, centre and coefficients), ``adaptive`` its windows without their cells
    (:attr:`BlockFit.windows`) and ``coefficients`` the whole fit of the windows the report's
    coefficient figure draws (:func:`adavar.output.report.series_rows`). The report is the same; the
    peak memory is a block, not the surface.
    """
    if keep not in KEEP:
        raise AdavarInputError(f"unknown keep {keep!r}: use one of {', '.join(KEEP)}")
    if whole not in WHOLE:
        raise AdavarInputError(f"unknown whole {whole!r}: use one of {', '.join(WHOLE)}")
    from adavar.core.units import rate_unit

    status = status or (lambda what: None)
    request = resolve_lengths(as_request(request), tau0, int(np.size(samples)))
    record, w = request.record, request.window
    rate_u = rate_unit(units, record.data_type)
    rate_kw = rate_keywords(request, tau0)
    n = int(np.size(samples))
    fit_windows = w.surface and w.confidence is not None and w.stat == "oavar"
    result = fit = None
    if whole != "reference":
        stat = request.deviation.stat
        if whole == "fit" and w.surface:  # the report's first of its steps
            status(f"{tag}deviation and noise fit of {n} samples")
        else:
            status(f"{tag}computing the {stat} of {n} samples")
        result = deviation(_as_the_statistic_reads(request, samples), units=rate_u,
                           data_type=record.data_type, gaps=record.omit,
                           **request.deviation.keywords(), **record.chunk_keywords(),
                           **rate_kw)  # fmt: skip
    if whole == "fit":
        if not w.surface:
            status(f"{tag}fitting the noise terms")
        try:
            fit = fit_noise(result, settings=request.fit)
        except ValueError as exc:
            where = "" if name is None else f"column {name!r}: "
            raise AdavarInputError(f"{where}{exc}") from None
    surface = adaptive = coefficients = None
    common = dict(data_type=record.data_type, taus=w.taus, step=w.step, units=rate_u,
                  **rate_kw)  # fmt: skip
    if keep == "figures" and w.surface:
        kind = "adaptive " if w.adaptive else ""
        status(f"{tag}{kind}DAVAR surface and noise coefficients of every window")
        surface = _fit_in_blocks(request, samples, fit, common)
        coefficients = surface.fit
        adaptive = surface.windows if w.adaptive else None
    elif w.surface:
        status(f"{tag}computing the {'adaptive ' if w.adaptive else ''}DAVAR surface of "
               f"{n} samples")  # fmt: skip
        common.update(w.keywords(), **record.chunk_keywords())
        if w.adaptive:
            adaptive = adaptive_davar(samples, settings=request.controller,
                                      method_options=request.method_options,
                                      **common)  # fmt: skip
            surface = adaptive
        else:
            surface = davar(samples, window=w.window, stat=w.stat, gaps=record.omit, **common)
    if surface is not None and coefficients is None and fit_windows:
        if whole == "fit":
            status(f"{tag}noise coefficients of every window")
        else:
            status(f"{tag}fitting the noise terms of every window")
            if request.fit.method in ("auto", "gls"):
                result, fit = _reference_fit(request, samples, rate_u, rate_kw)
        try:
            # the windows' coefficients only: no per-cell residuals (a surface's size)
            coefficients = fit_noise(surface, **window_fit_keywords(request, fit), cells=False)
        except ValueError as exc:
            raise AdavarInputError(str(exc)) from None
    return ChannelAnalysis(
        result=result, fit=fit, surface=surface, adaptive=adaptive, coefficients=coefficients,
        units=units, rate_units=rate_u, samples=n, request=request,
    )  # fmt: skip


def _as_the_statistic_reads(request: AnalysisRequest, samples: Any) -> Any:
    """The record as the statistic reads it: the Allan family reads a file piece by piece;
    the other statistics (Theo1, MTIE, TIE, the total family but totdev, ...) run on the
    record in memory, so a file read piece by piece is loaded for them when it fits."""
    from adavar.core.extended_statistics import SPECS

    stat = request.deviation.stat
    if stat not in SPECS or not sources.is_chunked(samples):
        return samples
    if request.record.chunk_size is not None:
        raise AdavarInputError(
            f"--stat {stat} is computed on the record in memory: leave out --chunk-size, or "
            "use an Allan statistic (oadev, mdev, ...), which reads the file piece by piece"
        )
    need = 3 * 8 * int(samples.size)  # the record in float64 and the statistic's copies
    free = sources.available_memory()
    if free is not None and need > 0.8 * free:
        raise AdavarInputError(
            f"--stat {stat} holds the record in memory: {samples.size} samples need about "
            f"{need / 2**30:.1f} GiB but {free / 2**30:.1f} GiB is free: use an Allan "
            "statistic (oadev, mdev, ...), which reads the file piece by piece, or a shorter "
            "record"
        )
    return np.asarray(samples, dtype=np.float64)


def _reference_fit(
    request: AnalysisRequest, samples: Any, rate_u: str, rate_kw: dict[str, Any]
) -> tuple[Any, Any]:  # fmt: skip
    """The full-covariance fit of the whole record's octave curve (and the curve): the
    reference of the windows' fits. (None, None) if the record is too short for it."""
    try:
        curve = deviation(samples, data_type=request.record.data_type, taus="octave",
                          units=rate_u, gaps=request.record.omit, **rate_kw,
                          **request.record.chunk_keywords())  # fmt: skip
        return curve, fit_noise(curve, **{**fit_keywords(request), "method": "gls"})
    except (ValueError, AdavarInputError):  # too short a record for the curve: no reference
        return None, None


@dataclass(eq=False)
class AnalysisRun:
    """What :func:`run` computed for one file.

    Attributes
    ----------
    channels : dict
        Name -> :class:`ChannelAnalysis`.
    meta : dict
        How the file was read (:class:`LoadedInput`).
    tau0 : float
        Sample interval (s).
    request : AnalysisRequest
        The request as used: the record as read, the lengths of the first channel in
        samples, the resolution chosen.
    resolution : str or None
        What was chosen of a surface's taus and centres and why (None: nothing).
    samples : dict
        Name -> the samples analysed.
    """

    channels: dict[str, ChannelAnalysis]
    meta: dict[str, Any]
    tau0: float
    request: AnalysisRequest
    resolution: str | None
    samples: dict[str, Any]


def run(
    request: AnalysisRequest | Mapping[str, Any],
    *,
    status: Callable[[str], None] | None = None,
    channels: str = "chosen",
    keep: str = "all",
    whole: str = "fit",
    check: Callable[[AnalysisRequest, LoadedInput], None] | None = None,
    each: Callable[[str, ChannelAnalysis, Any], None] | None = None,
) -> AnalysisRun:
    """Read the record of ``request`` and analyse each of its channels.

    The pipeline behind ``adavar avar``, ``davar``, ``adaptive``, ``report``, ``kalibr``
    and (one channel a file) ``batch``: :func:`read_input` (the file, piece by piece where
    it can), the window-like lengths in samples of the record (:func:`resolve_lengths`), the
    surface's taus and centres when left to adavar (:func:`resolve_resolution`), then
    :func:`analyse_channel` for each channel.

    Parameters
    ----------
    request : AnalysisRequest
        What to read and compute (or options by the flags' names, a mapping or a namespace:
        :meth:`AnalysisRequest.from_options`).
    status : callable, optional
        Receives one line per step.
    channels : {"chosen", "one", "all"}
        ``"chosen"``: several channels when ``record.column`` names them; ``"one"``: the
        one channel ``column`` chooses (a file of several needs it); ``"all"``: every
        numeric column unless ``column`` chooses, and with ``gaps="split"`` each gap-free
        piece as a channel of its own (``adavar avar``).
    keep, whole : str
        As :func:`analyse_channel`.
    check : callable, optional
        Called with the request (the record as read) and the :class:`LoadedInput` once
        the record is read (the checks that need it).
    each : callable, optional
        Called with each channel's name, analysis and samples as soon as it is done (its
        figures drawn before the next channel is computed).

    Returns
    -------
    AnalysisRun
    """
    request = as_request(request)
    status = status or (lambda what: None)
    status(f"reading {request.record.file}")
    if channels not in CHANNELS:
        raise AdavarInputError(f"unknown channels {channels!r}: use one of {', '.join(CHANNELS)}")
    several = channels == "all" or (channels == "chosen" and request.record.column is not None)
    loaded = read_input(request.record, several=several,
                        pieces=None if channels == "all" else False,
                        out_of_core=True)  # fmt: skip
    request = dataclasses.replace(request, record=loaded.record)
    first, _ = loaded.first
    n_samples = int(getattr(first, "size", np.size(first)))
    if check is not None:
        check(request, loaded)
    request = resolve_lengths(request, loaded.tau0, n_samples)
    resolution = None
    if request.window.surface:
        request, resolution = resolve_resolution(request, loaded.tau0, n_samples,
                                                 len(loaded.channels))  # fmt: skip
    names = list(loaded.channels)
    out: dict[str, ChannelAnalysis] = {}
    for k, name in enumerate(names):
        tag = f"{name} ({k + 1}/{len(names)}): " if len(names) > 1 else ""
        out[name] = analyse_channel(request, loaded.channels[name], loaded.units[name],
                                    loaded.tau0, status, tag, keep=keep, whole=whole,
                                    name=name)  # fmt: skip
        if each is not None:
            each(name, out[name], loaded.channels[name])
    return AnalysisRun(channels=out, meta=loaded.meta, tau0=loaded.tau0, request=request,
                       resolution=resolution, samples=loaded.channels)  # fmt: skip


def _fit_in_blocks(
    request: AnalysisRequest, samples: Any, whole: Any, common: dict[str, Any]
) -> Any:  # fmt: skip
    """The surface of ``analyse_channel(..., keep="figures")``: a :class:`BlockFit`."""
    from adavar.dynamic.surface_fit import fit_adaptive_in_blocks, fit_davar_in_blocks
    from adavar.output.report_parts import MAX_SURFACE_TIMES, series_rows

    # the windows' coefficients only: no per-cell residuals (a surface's size); no
    # per-cell bounds (neither the report nor the fit reads them); the whole fit of the
    # windows the coefficient figure draws; the coefficients of every window (five a
    # window) wait in temporary files for the events, which read their stretches only
    options = dict(fit_options={**window_fit_keywords(request, whole), "cells": False},
                   drawn=MAX_SURFACE_TIMES, bounds=False, fit_rows=series_rows, spill=True,
                   **common)  # fmt: skip
    try:
        if request.window.adaptive:
            return fit_adaptive_in_blocks(samples, **request.controller.keywords(), **options)
        return fit_davar_in_blocks(samples, window=request.window.window, **options)
    except ValueError as exc:
        raise AdavarInputError(str(exc)) from None


def surface_shape(surface: Any) -> dict[str, Any] | None:
    """What a command's JSON says of a surface (a result or a :class:`BlockFit`; None
    without one): ``{"windows", "taus", "method"}``."""
    from adavar.dynamic.surface_fit import BlockFit

    if surface is None:
        return None
    if isinstance(surface, BlockFit):  # its drawn rows carry the kind of surface
        windows, taus, result = surface.n_windows, surface.n_taus, surface.drawn
    else:
        (windows, taus), result = np.shape(surface.avar), surface
    return {"windows": int(windows), "taus": int(taus),
            "method": getattr(result, "method", "fixed")}  # fmt: skip


def aliasing_notes(steps: list[dict[str, Any]], data_type: str) -> list[str]:
    """A line for each ``decimate:K`` step that kept 1 sample of ``K`` of rate data: white
    rate noise aliases, and its coefficient N reads ``sqrt(K)`` times the record's."""
    out = []
    for step in steps:
        p = step.get("parameters", {})
        if step.get("name") == "decimate" and p.get("method") == "keep" and data_type == "rate":
            k = int(p["factor"])
            out.append(
                f"{step['spec']} kept 1 rate sample of {k} (the paper's step): white rate "
                f"noise aliases, so N (and the short taus) read sqrt({k}) = {k**0.5:.3g} times "
                f"the record's; decimate:{k}:average keeps them"
            )
    return out


def controller_settings(args: Any) -> dict[str, Any]:
    """The controller keywords of :func:`adavar.adaptive_davar` from a request or options."""
    if isinstance(args, AnalysisRequest):
        return args.controller.keywords()
    return ControllerSettings.from_options(args).keywords()


def fit_keywords(args: Any) -> dict[str, Any]:
    """The keywords of :func:`adavar.fit_noise` from a request, fit settings or options."""
    if isinstance(args, AnalysisRequest):
        return args.fit.keywords()
    if isinstance(args, FitSettings):
        return args.keywords()
    return FitSettings.from_options(args).keywords()


def window_fit_keywords(args: Any, whole: Any) -> dict[str, Any]:
    """:func:`fit_keywords` for a surface's windows, with the whole-record fit ``whole`` as
    the reference of the sensor's roll-off when it is a full-covariance fit."""
    keywords = fit_keywords(args)
    if (
        whole is not None
        and getattr(whole, "method", None) == "gls"
        and (keywords["method"] in ("auto", "wls"))
    ):
        keywords["reference"] = whole
    return keywords

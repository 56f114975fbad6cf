"""The analysis of one file: the pipeline behind ``adavar avar``, ``davar``, ``adaptive``,
``report`` and ``batch``.

load (:func:`load_input`: read the record, its rate and unit, preprocess it) -> analyse
(:func:`analyse_channel`: deviation and noise fit, the DAVAR surface and the coefficients
over time). :func:`analyse_file` does both for one file exactly as ``adavar report FILE``
and every task of ``adavar batch`` compute it (:class:`ReportAnalysis`).

The options are any object with the commands' option names as attributes (an
``argparse.Namespace`` from the command line, or the options of
:func:`adavar.batch.run_batch`, completed by :func:`report_options` from
:data:`adavar.settings.ANALYSIS_DEFAULTS`); :func:`fit_keywords`,
:func:`controller_settings` and :func:`chunk_keywords` turn them into the library
functions' keywords, in one place. Problems with the input raise
:class:`adavar.errors.AdavarInputError`; nothing is printed.
"""

from __future__ import annotations

import argparse
import copy
import functools
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from adavar import sources
from adavar.adaptive import (
    adaptive_davar,
    record_windows,
    surface_resolution,
    window_lengths,
)
from adavar.durations import to_samples
from adavar.errors import AdavarInputError
from adavar.noise_model import TERM_NAMES, fit_noise
from adavar.settings import ControllerSettings, FitSettings
from adavar.statistics import deviation
from adavar.surface import davar

__all__ = [
    "ChannelAnalysis",
    "ReportAnalysis",
    "analyse_channel",
    "analyse_file",
    "chunk_keywords",
    "controller_settings",
    "fit_keywords",
    "load_input",
    "report_options",
    "report_parameters",
    "resolve_lengths",
    "resolve_resolution",
    "window_fit_keywords",
]

_ALIASES = {"l": "segment"}
_LENGTHS = ("window", "lmax", "lmin", "segment", "step")


def load_input(
    args: Any,
    *,
    several: bool = False,
    pieces: bool | None = None,
    out_of_core: bool = False,
) -> tuple[Any, dict[str, Any], Any, float]:
    """Read FILE's column, preprocess it, and settle its unit and tau0 (seconds).

    With ``out_of_core`` (commands whose analysis streams: avar, davar, adaptive), a
    memory-mapped ``.npy`` column or a lazy HDF5/Parquet channel is passed on as it is,
    so a record larger than memory is read piece by piece; preprocessing loads it.

    With ``several``, every selected channel (``--column gx,gy,gz``, or all numeric
    columns) is returned: a dict name -> samples, and a dict name -> unit. With
    ``pieces`` (default: ``several``), ``--gaps split`` gives each gap-free piece of a
    channel as a channel of its own.

    The rate comes from --rate/--tau0 or from the file's time stamps (both: they must
    agree); the unit from --units or from the format (ROS bags declare rad/s and m/s^2).
    """
    from adavar._heap import release_free_memory
    from adavar.preprocess import preprocess
    from adavar.readers import file_data_type, read_record

    if args.rate is not None and args.tau0 is not None:
        raise AdavarInputError("give exactly one of --rate HZ or --tau0 SECONDS (both given)")
    declared = args.rate if args.rate is not None else (
        1.0 / args.tau0 if args.tau0 is not None else None
    )  # fmt: skip
    option = partial(getattr, args)
    record = read_record(
        args.file, columns=args.column, rate=declared,
        time_column=option("time_column", None), time_format=option("time_format", "auto"),
        gaps=option("gaps", "error"), nan=option("nan", "error"),
        dataset=option("dataset", None), topic=option("topic", None),
        gap_tolerance=option("gap_tolerance", 0.5), lazy=option("lazy", None),
        memory_map=False,  # .npy read with file reads: a file cut short is an error, no SIGBUS
    )  # fmt: skip
    if hasattr(args, "data_type"):  # a Stable32 .phd file holds phase, a .frd frequency
        args.data_type = file_data_type(args.file, args.data_type)
    if len(record.names) != 1 and not several:
        raise AdavarInputError(
            f"{args.file} has {len(record.names)} channels ({', '.join(record.names)}): "
            "choose one with --column"
            + ("" if getattr(args, "command", None) == "compare"
               else " (or several, comma-separated, e.g. --column a,b)")
        )  # fmt: skip
    given = args.units.strip() if args.units and args.units.strip() else None
    units_of = record.units_of(given)  # --units must agree with the units the file declares
    if not all(units_of.values()):
        raise AdavarInputError(
            "declare the unit of the samples with --units (e.g. --units deg/s); adavar never "
            "guesses units"
        )
    rate = float(record.rate)
    steps: list[dict[str, Any]] = []
    channels: dict[str, np.ndarray] = {}
    split = record.segments is not None and len(record.segments) > 1
    if split and not (several if pieces is None else pieces):
        raise AdavarInputError(
            f"{args.file} has {len(record.segments)} gap-free pieces: --gaps split is for "
            "adavar avar; here use --gaps interpolate, or give a file with one piece"
        )
    for name in record.names:
        pieces = record.pieces(name) if split else [record.channel(name)]
        for k, piece in enumerate(pieces):
            preprocessing = bool(getattr(args, "preprocess", None))
            if out_of_core and not preprocessing and sources.is_chunked(piece):
                x = piece
            else:
                x = np.asarray(piece, dtype=np.float64)
            if preprocessing:
                x, new_rate, steps = preprocess(x, rate=float(record.rate),
                                                steps=args.preprocess)  # fmt: skip
                rate = float(new_rate)
            key = f"{name} piece {k + 1}" if split else name
            channels[key] = x
            units_of[key] = units_of[name]
    name = next(iter(channels))
    samples = channels[name]
    units = units_of[name]
    if args.tau0 is not None and not steps:
        tau0 = float(args.tau0)
    else:
        tau0 = 1.0 / rate
    if args.rate is not None and not steps:
        args_rate = float(args.rate)
    else:
        args_rate = rate
    args.rate, args.tau0 = (args_rate, None) if args.tau0 is None or steps else (None, tau0)
    meta = {
        "path": str(args.file), "column": name, "kind": record.kind,
        "rate_from": "declared" if declared is not None else "time stamps",
        "reader": record.meta, "preprocessing": steps, "columns": list(record.names),
        "pieces": None if not split else [
            [float(record.time[sl.start]), float(record.time[sl.stop - 1])]
            for sl in record.segments
        ],
    }  # fmt: skip
    # the record's other columns, its time stamps and the parser threads' arenas are
    # freed now: their pages go back before the analysis makes its peak
    record = piece = pieces = x = None
    release_free_memory()
    if several:
        return channels, meta, units_of, tau0
    return samples, meta, units, tau0


def resolve_lengths(args: Any, tau0: float, n_samples: int | None = None) -> Any:
    """The options with the window-like ones (``window``, ``lmax``, ``lmin``, ``segment``
    = ``l``, ``step``) in samples of this record: a copy, ``args`` is left as it is.

    Durations (``"10min"``) are converted with ``tau0``. An adaptive window not given
    (``lmax``, ``lmin`` or ``segment`` None) takes the paper's proportions
    (:func:`adavar.adaptive.record_windows`): Lmax a tenth of the ``n_samples``-sample
    record, Lmin two thirds and l a sixth of Lmax. ``windows_from`` says which:
    ``"flags"``, ``"lmax"`` (Lmin and l from it) or ``"record"``.
    """
    args = copy.copy(args)
    if getattr(args, "window", None) is not None:
        args.window = to_samples(args.window, tau0, "--window")
    if hasattr(args, "lmax"):
        chosen = args.lmax, args.lmin, args.segment
        if None in chosen:
            if args.lmax is None and n_samples is None:  # pragma: no cover - callers pass it
                raise AdavarInputError("the record's length is needed to choose the windows")
            given = None if args.lmax is None else to_samples(args.lmax, tau0, "--lmax")
            lmax, lmin, seg = record_windows(n_samples or 0, given)
            args.windows_from = "record" if args.lmax is None else "lmax"
            args.lmax = lmax if args.lmax is None else args.lmax
            args.lmin = lmin if args.lmin is None else args.lmin
            args.segment = seg if args.segment is None else args.segment
        else:
            args.windows_from = "flags"
        step = getattr(args, "step", None)
        args.lmax, args.lmin, args.segment, chosen_step = window_lengths(
            tau0, lmax=args.lmax, lmin=args.lmin, l=args.segment,
            step=1 if step is None else step,
        )  # fmt: skip
        if step is not None:  # None: resolve_resolution chooses it
            args.step = chosen_step
    elif getattr(args, "step", None) is not None:
        args.step = to_samples(args.step, tau0, "--step")
    return args


def resolve_resolution(
    args: Any, tau0: float, n_samples: int, channels: int = 1
) -> tuple[Any, str | None]:
    """Taus and centres of a surface the user left to adavar (``taus`` / ``step`` None).

    The rule of :func:`adavar.adaptive.surface_resolution` (the library's default too):
    ``taus`` ``"all"`` while that is at most :data:`~adavar.settings.MAX_ALL_TAUS` taus, else
    ``"log"`` (10 per decade); ``step`` every centre while the surfaces of the ``channels``
    channels fit ``args.max_memory`` MB together at
    :data:`adavar.window_defaults.CELL_BYTES` a cell, else every ``step``-th. Returns a
    copy of the options with them (``args`` is left as it is) and a sentence saying what
    was chosen and why (None when nothing was).
    """
    args = copy.copy(args)
    longest = args.lmax if getattr(args, "command", None) == "adaptive" else args.window
    args.taus, args.step, why = surface_resolution(
        int(longest), n_samples, tau0, taus=args.taus, step=args.step,
        points_per_decade=args.points_per_decade, max_memory=args.max_memory,
        channels=channels,
    )  # fmt: skip
    if not why:
        return args, None
    shared = f" ({channels} channels' surfaces together)" if channels > 1 else ""
    return args, (
        "resolution: " + ", ".join(why) + f", to keep the surface within --max-memory "
        f"{args.max_memory:g} MB{shared} (give --taus / --step to choose)"
    )


@dataclass(eq=False)
class ChannelAnalysis:
    """One channel's analysis (:func:`analyse_channel`).

    Attributes
    ----------
    result : DeviationResult
        The deviation at the chosen taus.
    fit : NoiseFit
        Its noise fit.
    surface, adaptive, coefficients
        The DAVAR surface (a result, or a :class:`~adavar.surface_fit.BlockFit` with
        ``keep="figures"``), the adaptive windows (None for a fixed window) and the fit of
        every window; all None without ``window`` or ``adaptive``.
    units, rate_units : str
        The samples' unit and the rate unit of the deviation.
    samples : int
        Number of samples.
    options : object
        The options as used: a copy of the given ones with the window-like lengths in
        samples of this record (:func:`resolve_lengths`).
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
    options: Any
    events: dict[str, Any] | None = None
    shape: dict[str, Any] | None = None
    controller: dict[str, Any] | None = None


def analyse_channel(
    args: Any, samples: np.ndarray, units: str, tau0: float, status: Callable[[str], None],
    tag: str = "", keep: str = "all",
) -> ChannelAnalysis:  # fmt: skip
    """The analysis of one channel that ``adavar report`` shows and ``adavar batch`` writes.

    The deviation at the chosen taus, its noise fit, and (with ``window`` or ``adaptive``)
    the DAVAR surface and the fit of every window. ``status`` receives one line per step.
    ``keep="figures"``: the surface is computed and fitted a block of windows at a time
    (:mod:`adavar.surface_fit`); ``surface`` is then a :class:`~adavar.surface_fit.BlockFit`
    (the rows the report draws, every window's time, length, centre and coefficients),
    ``adaptive`` its windows without their cells (:attr:`BlockFit.windows`) and
    ``coefficients`` the whole fit of the windows the report's coefficient figure draws
    (:func:`adavar.report.series_rows`). The report is the same; the peak memory is a
    block, not the surface.
    """
    if keep not in KEEP:
        raise AdavarInputError(f"unknown keep {keep!r}: use one of {', '.join(KEEP)}")
    from adavar.units import rate_unit

    rate_u = rate_unit(units, args.data_type)
    args = resolve_lengths(args, tau0, int(np.size(samples)))
    rate_kw = dict(
        rate=args.rate if args.rate is not None else 1.0,
        tau0=None if args.rate is not None else tau0,
    )  # fmt: skip
    status(f"{tag}deviation and noise fit of {samples.size} samples")
    result = deviation(samples, data_type=args.data_type, units=rate_u, **rate_kw)
    try:
        fit = fit_noise(result, **fit_keywords(args))
    except ValueError as exc:
        raise AdavarInputError(str(exc)) from None
    surface = adaptive = coefficients = None
    common = dict(data_type=args.data_type, taus=args.taus, step=args.step, units=rate_u,
                  **rate_kw)  # fmt: skip
    if keep == "figures" and (args.adaptive or args.window is not None):
        kind = "adaptive " if args.adaptive else ""
        status(f"{tag}{kind}DAVAR surface and noise coefficients of every window")
        surface = _fit_in_blocks(args, samples, fit, common)
        coefficients = surface.fit
        adaptive = surface.windows if args.adaptive else None
    elif args.adaptive:
        status(f"{tag}adaptive DAVAR surface")
        adaptive = adaptive_davar(samples, **controller_settings(args), **common)
        surface = adaptive
    elif args.window is not None:
        status(f"{tag}DAVAR surface")
        surface = davar(samples, window=args.window, **common)
    if surface is not None and coefficients is None:
        status(f"{tag}noise coefficients of every window")
        try:
            # the windows' coefficients only: no per-cell residuals (a surface's size)
            coefficients = fit_noise(surface, **window_fit_keywords(args, fit), cells=False)
        except ValueError as exc:
            raise AdavarInputError(str(exc)) from None
    return ChannelAnalysis(
        result=result, fit=fit, surface=surface, adaptive=adaptive, coefficients=coefficients,
        units=units, rate_units=rate_u, samples=int(samples.size), options=args,
    )  # fmt: skip


#: What :func:`analyse_channel` and :func:`analyse_file` keep of a surface.
KEEP = ("all", "figures")


def _fit_in_blocks(
    args: Any, samples: np.ndarray, whole: Any, common: dict[str, Any]
) -> Any:  # fmt: skip
    """The surface of ``analyse_channel(..., keep="figures")``: a :class:`BlockFit`."""
    from adavar.report import MAX_SURFACE_TIMES, series_rows
    from adavar.surface_fit import fit_adaptive_in_blocks, fit_davar_in_blocks

    # the windows' coefficients only: no per-cell residuals (a surface's size); no
    # per-cell bounds (neither the report nor the fit reads them); the whole fit of the
    # windows the coefficient figure draws, the coefficients of every window
    # the coefficients of every window (five a window) wait in temporary files for the
    # events, which read their stretches only
    options = dict(fit_options={**window_fit_keywords(args, whole), "cells": False},
                   drawn=MAX_SURFACE_TIMES, bounds=False, fit_rows=series_rows, spill=True,
                   **common)  # fmt: skip
    try:
        if args.adaptive:
            return fit_adaptive_in_blocks(samples, **controller_settings(args), **options)
        return fit_davar_in_blocks(samples, window=args.window, **options)
    except ValueError as exc:
        raise AdavarInputError(str(exc)) from None


def surface_shape(surface: Any) -> dict[str, Any] | None:
    """What a command's JSON says of a surface (a result or a :class:`BlockFit`; None
    without one): ``{"windows", "taus", "method"}``."""
    from adavar.surface_fit import BlockFit

    if surface is None:
        return None
    if isinstance(surface, BlockFit):  # its drawn rows carry the kind of surface
        windows, taus, result = surface.n_windows, surface.n_taus, surface.drawn
    else:
        (windows, taus), result = np.shape(surface.avar), surface
    return {"windows": int(windows), "taus": int(taus),
            "method": getattr(result, "method", "fixed")}  # fmt: skip


def controller_settings(args: Any) -> dict[str, Any]:
    """The controller keywords of :func:`adavar.adaptive_davar` from the options."""
    return ControllerSettings.from_options(args).keywords()


def fit_keywords(args: Any) -> dict[str, Any]:
    """The keywords of :func:`adavar.fit_noise` from the options."""
    return dict(terms=args.terms or TERM_NAMES, n_reweight=args.n_reweight,
                spacing=args.spacing, method=args.fit_method, select=args.select,
                significance=args.significance, exclude=args.exclude, rolloff=args.rolloff,
                tau_range=args.tau_range, bandwidth=args.bandwidth,
                markov=getattr(args, "markov", "auto"),
                bound_level=getattr(args, "bound_level", FitSettings.bound_level))  # fmt: skip


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


def chunk_keywords(args: Any) -> dict[str, Any]:
    """``chunk_size`` for the library, only when --chunk-size is given."""
    size = getattr(args, "chunk_size", None)
    return {} if size is None else {"chunk_size": size}


# --------------------------------------------------------------------------------------
# Options: those of adavar report
# --------------------------------------------------------------------------------------


@functools.cache
def _report_defaults() -> tuple[tuple[str, Any], ...]:
    """The analysis options of ``adavar report`` and their defaults (one definition:
    :data:`adavar.settings.ANALYSIS_DEFAULTS`, which the command line's parser agrees with)."""
    from adavar.settings import ANALYSIS_DEFAULTS

    return tuple(sorted(ANALYSIS_DEFAULTS.items()))


def report_options(
    options: Mapping[str, Any] | argparse.Namespace | None = None, *, ignore_unknown: bool = False
) -> dict[str, Any]:
    """Every analysis option of ``adavar report``: its defaults, updated with ``options``.

    Parameters
    ----------
    options : mapping or argparse.Namespace, optional
        Option values by the destination names of the flags of ``adavar report`` (``units``,
        ``rate``, ``tau0``, ``column``, ``data_type``, ``preprocess``, ``window``,
        ``adaptive``, ``taus``, ``step``, ``terms``, ``lmax``, ``lmin``, ``k1``, ``k2``,
        ``s2``, ``segment`` (or ``l``), ``thresholds``, ``nan``, ``gaps``, ...); dashes may
        be written as underscores or dashes.
    ignore_unknown : bool
        Skip keys that are not analysis options (for a command-line namespace) instead of
        raising.

    Returns
    -------
    dict
        Name -> value for every analysis option.

    Raises
    ------
    AdavarInputError
        An unknown option name (unless ``ignore_unknown``).
    """
    defaults = dict(_report_defaults())
    if options is None:
        given: dict[str, Any] = {}
    elif isinstance(options, argparse.Namespace):
        given = dict(vars(options))
    else:
        given = dict(options)
    out = dict(defaults)
    for key, value in given.items():
        name = _ALIASES.get(str(key), str(key).replace("-", "_"))
        if name in defaults:
            out[name] = value
        elif not ignore_unknown:
            raise AdavarInputError(
                f"unknown analysis option {key!r}: use the names of the flags of 'adavar "
                f"report' ({', '.join(sorted(defaults))})"
            )
    return out


# --------------------------------------------------------------------------------------
# One file: what adavar report computes
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ReportAnalysis:
    """Everything ``adavar report`` computes for one file (from :func:`analyse_file`).

    Attributes
    ----------
    path : str
        The file as given.
    title : str
        Title of the report.
    samples : ndarray or source
        The samples analysed (after preprocessing); a file read piece by piece (a
        :class:`~adavar.sources.ChunkedSource`).
    meta : dict
        How they were read (``path``, ``column``, ``kind``, ``rate_from``, ``reader``,
        ``preprocessing``, ...).
    units : str
        Declared unit of the samples.
    rate_units : str
        Unit of the rate samples (the integrated unit per second for phase data).
    tau0 : float
        Sample interval, seconds.
    rate_options : dict
        The ``rate``/``tau0`` keywords given to the analysis functions.
    options : dict
        Every analysis option (:func:`report_options`).
    deviation : DeviationResult
        The whole-record overlapping Allan deviation.
    fit : NoiseFit
        Its noise fit.
    surface, adaptive : DavarResult, AdaptiveResult or None
        The DAVAR surface (``window``) or the adaptive one (``adaptive``; then both are it).
        With ``analyse_file(..., keep="figures")``: ``surface`` is a
        :class:`adavar.surface_fit.BlockFit` (the rows the report draws, every window's
        time, length, centre and coefficients: ``surface.term_values(name)``) and
        ``adaptive`` its :attr:`~BlockFit.windows` (every window's controller record, no
        cells).
    coefficients : NoiseFit or None
        The fit of every window of the surface (without the per-cell ``used`` and
        ``residuals``: ``fit_noise(..., cells=False)``); with ``keep="figures"`` of the
        windows the report's coefficient figure draws (``surface.fit_rows``).
    parameters : dict
        The parameter table of the report.
    preprocessing : list of str
        The preprocessing steps, in order.
    """

    path: str
    title: str
    samples: Any  # ndarray, or a source read piece by piece
    meta: dict[str, Any]
    units: str
    rate_units: str
    tau0: float
    rate_options: dict[str, Any]
    options: dict[str, Any]
    deviation: Any
    fit: Any
    surface: Any = None
    adaptive: Any = None
    coefficients: Any = None
    parameters: dict[str, Any] = field(default_factory=dict)
    preprocessing: list[str] = field(default_factory=list)

    @property
    def n_samples(self) -> int:
        """Number of samples analysed."""
        return int(self.samples.size)

    def html(self) -> str:
        """The report (:func:`adavar.report.build_report`) of ``adavar report``."""
        from adavar.report import build_report

        return build_report(
            title=self.title,
            source={"file": self.meta["path"], "column": self.meta["column"],
                    "format": self.meta["kind"], "samples": self.n_samples},
            deviation=self.deviation, fit=self.fit, surface=self.surface,
            coefficients=self.coefficients, adaptive=self.adaptive,
            parameters=self.parameters, preprocessing=self.preprocessing,
            units=self.rate_units, events=(self.events() or {}).get("items"),
        )  # fmt: skip

    def events(self) -> dict[str, Any] | None:
        """The non-stationary stretches the window detected: None without ``window`` or
        ``adaptive``.

        Returns
        -------
        dict or None
            ``{"method", "rule", "count", "items", "runs", "note"}``. ``items`` are the
            stretches of :func:`adavar.events.find_events` (``start_s``, ``end_s``: the
            estimated times of the changes into and out of it, seconds from the first
            sample; ``before``, ``during``, ``after``: each fitted term's median and 16-84 %
            range over the windows wholly outside/inside it); ``count`` their number.
            ``runs`` are the raw runs of shortened (adaptive) or flagged (fixed) windows,
            with the window-centre nodes of the paper: ``beginning_s`` (first centre of
            the run), ``end_node_s`` (adaptive: the start of the last regrowth; fixed: the
            last flagged centre), ``restore_s`` (adaptive: back at Lmax), ``leading_edge_s``
            and ``min_window``. (Before 0.2 ``items`` were these runs, with ``start_s`` the
            Beginning node.)
        """
        if self.surface is None:
            return None
        from adavar.events import find_events, run_change_times

        surface = self.adaptive if self.adaptive is not None else self.surface
        time_s = np.asarray(surface.time, dtype=float)
        centre = np.asarray(surface.centre, dtype=np.int64)
        t0 = float(time_s[0] - self._seconds(centre[0])) if time_s.size else 0.0
        from adavar.surface_fit import BlockFit

        fit = self.coefficients
        if isinstance(self.surface, BlockFit):  # every window's terms (fit: a few windows)
            terms = {name: self.surface.term_reader(name) for name in fit.terms}
        else:
            terms = {} if fit is None else {name: fit.term(name).value for name in fit.terms}
        duration = t0 + float(self._seconds(self.n_samples))
        if self.adaptive is not None:
            lmax = int(self.adaptive.parameters["lmax"])
            window = np.asarray(self.adaptive.window)
            runs = []
            for a, b in _runs(window < lmax):
                e = b
                while e > a and window[e - 1] < window[e]:
                    e -= 1
                runs.append({
                    "beginning_s": float(time_s[a]), "end_node_s": float(time_s[e]),
                    "restore_s": float(time_s[b + 1]) if b + 1 < window.size else None,
                    "leading_edge_s": float(time_s[a] + self._seconds(lmax // 2)),
                    "min_window": int(window[a : b + 1].min()),
                })  # fmt: skip
            rule = (f"episodes of windows shorter than Lmax = {lmax}: a change up (at the "
                    "leading edge before the shrink) or down (at the trailing edge where the "
                    "window regrows) by N on each side opens or closes a stretch; an episode "
                    "with no change of level (a spike) is an event of its own")  # fmt: skip
            if self.adaptive.method == "ici":  # its own steps, ramps and long-tau changes
                from adavar.ici_events import ici_events

                found = ici_events(window, centre, time_s, lmax, self.tau0, terms, t0=t0,
                                   duration=duration,
                                   parameters=self.adaptive.parameters)  # fmt: skip
                rule = "the ICI window's steps (paired into stretches), ramps and long-tau changes"
            else:
                found = find_events(window, centre, time_s, lmax, self.tau0, terms, t0=t0,
                                    duration=duration)  # fmt: skip
            return {
                "method": self.adaptive.method,
                "rule": rule,
                "count": len(found), "items": [e.as_dict() for e in found], "runs": runs,
                "note": None,
            }  # fmt: skip
        return self._fixed_window_events(find_events, run_change_times, terms, t0, duration)

    def _seconds(self, samples: Any) -> Any:
        """Sample counts as seconds, as the DAVAR times are (``n / rate`` or ``n * tau0``)."""
        n = np.asarray(samples, dtype=float)
        if self.rate_options.get("tau0") is None:
            return n / float(self.rate_options["rate"])
        return n * float(self.rate_options["tau0"])

    def _fixed_window_events(
        self, find_events: Any, run_change_times: Any, terms: dict, t0: float,
        duration: float,
    ) -> dict[str, Any]:  # fmt: skip
        from adavar.adaptive import adaptive_schedule

        length = int(self.options["window"])
        settings = controller_settings(argparse.Namespace(**self.options))
        settings.update(lmax=length, lmin=length)
        if not self.options.get("segment_given", True):  # l in proportion to this window
            settings["l"] = record_windows(0, length)[2]
        rule = (f"changes at the leading edge of the first window of each run of centres "
                f"where the adaptive controller's test flags the fixed {length}-sample "
                "window, classified by N on each side into stretches and short events")  # fmt: skip
        if settings["l"] > length - 4:
            note = (
                f"no events: the S test needs a window of more than l + 3 = "
                f"{settings['l'] + 3} samples (give a longer --window or a smaller --l)"
            )
            return {"method": "fixed", "rule": rule, "count": None, "items": None,
                    "runs": None, "note": note}  # fmt: skip
        u = self.samples
        if self.options["data_type"] != "rate":  # the phase's increments
            u = (sources.DifferencedSource(sources.as_source(u)) if sources.is_chunked(u)
                 else np.diff(u))  # fmt: skip
        # the runs of flags only: no per-centre array (memory: one piece of the record)
        sched = adaptive_schedule(u, method="fixed", keep="runs", **settings,
                                  **self.rate_options)  # fmt: skip
        flagged = sched.flag_runs()
        runs = [
            {"beginning_s": float(t0 + self._seconds(a)),
             "end_node_s": float(t0 + self._seconds(b)), "restore_s": None,
             "leading_edge_s": float(t0 + self._seconds(a + length // 2)),
             "min_window": length}
            for a, b in flagged.tolist()
        ]  # fmt: skip
        changes = run_change_times(flagged, length, self.tau0, t0)
        surface = self.surface
        found = find_events(
            surface.window, surface.centre, surface.time, length, self.tau0, terms, t0=t0,
            duration=duration, changes=changes,
        )  # fmt: skip
        return {"method": "fixed", "rule": rule, "count": len(found),
                "items": [e.as_dict() for e in found], "runs": runs,
                "note": None}  # fmt: skip


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """First and last index of every run of True in a 1-D boolean array."""
    edges = np.diff(np.concatenate(([0], np.asarray(mask, dtype=np.int8), [0])))
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1) - 1
    return list(zip(starts.tolist(), stops.tolist(), strict=True))


def report_parameters(
    options: Any, units: str, tau0: float, meta: Mapping[str, Any], surface: bool,
    controller: Mapping[str, Any] | None,
) -> dict[str, Any]:  # fmt: skip
    """The report's table of parameters: the statistic, data, fit and DAVAR settings used.

    ``options`` as used (:attr:`ChannelAnalysis.options`), ``surface`` whether there is a
    DAVAR surface, ``controller`` the adaptive window's parameters (None for a fixed one).
    """
    terms = options.terms or TERM_NAMES
    parameters: dict[str, Any] = {
        "statistic": "oadev", "data type": options.data_type, "units": units,
        "rate [Hz]": 1.0 / tau0, "rate from": meta["rate_from"], "terms": ", ".join(terms),
    }  # fmt: skip
    if options.n_reweight != 3 or options.spacing != "octave":
        parameters.update({"fit reweighting passes": options.n_reweight,
                           "fit tau spacing": options.spacing})  # fmt: skip
    if surface:
        parameters.update({"DAVAR taus": str(options.taus), "DAVAR step": options.step})
        if controller is not None:
            parameters.update({f"controller {k}": v for k, v in controller.items()
                               if v is not None})  # fmt: skip
        else:
            parameters["DAVAR window [samples]"] = options.window
    return parameters


def analyse_file(
    path: str | os.PathLike[str],
    options: Mapping[str, Any] | argparse.Namespace | None = None,
    *,
    title: str | None = None,
    keep: str = "all",
) -> ReportAnalysis:
    """Read, preprocess and analyse one file exactly as ``adavar report FILE`` does.

    ``adavar report`` and every task of :func:`run_batch` call this, so a file's numbers are
    the same in both.

    Parameters
    ----------
    path : str or path-like
        The record (any format of :func:`adavar.readers.read_record`).
    options : mapping or argparse.Namespace, optional
        Analysis options (:func:`report_options`); ``units`` and ``rate`` or ``tau0`` (unless
        the file has time stamps) are needed.
    title : str, optional
        Title of the report (default: the file and column).
    keep : {"all", "figures"}
        ``"all"``: the whole surface (``surface.avar`` of every window and tau);
        ``"figures"`` (what ``adavar report`` and ``adavar batch`` use): the surface
        computed and fitted a block of windows at a time, keeping what the report and
        the events read (see :class:`ReportAnalysis`): the same report and numbers in the
        memory of a block instead of the surface.

    Returns
    -------
    ReportAnalysis

    Raises
    ------
    AdavarInputError
        An unreadable or bad file, or bad options (a missing unit, both rate and tau0,
        ...).
    """
    opts = report_options(options, ignore_unknown=isinstance(options, argparse.Namespace))
    args = argparse.Namespace(file=os.fspath(path), **opts)
    # as adavar report: read (sets args.rate / args.tau0 as every command does), then the
    # channel's deviation, fit and surface by the report's own function
    chosen = args.column is not None
    # as adavar report: a file is read piece by piece
    loaded, meta, units_of, tau0 = load_input(args, several=chosen, pieces=False,
                                              out_of_core=True)  # fmt: skip
    if chosen:
        if len(loaded) != 1:
            raise AdavarInputError(
                f"{path}: --column {args.column} selects {len(loaded)} channels; a batch "
                "analyses one column per file: run one batch per column (e.g. --column "
                f"{next(iter(loaded))}) with its own --out"
            )
        name = next(iter(loaded))
        samples, units = loaded[name], units_of[name]
    else:
        samples, units = loaded, units_of
    segment_given = opts.get("segment") is not None
    run = analyse_channel(args, samples, units, tau0, lambda what: None, "", keep=keep)
    args = run.options  # the lengths as used (durations and the record's windows resolved)
    opts = {**opts, **{k: getattr(args, k) for k in _LENGTHS if hasattr(args, k)}}
    opts["segment_given"] = segment_given
    opts["data_type"] = args.data_type  # as read: a Stable32 .phd file holds phase
    rate_kw = dict(
        rate=args.rate if args.rate is not None else 1.0,
        tau0=None if args.rate is not None else tau0,
    )  # fmt: skip
    parameters = report_parameters(
        args,
        units,
        tau0,
        meta,
        run.surface is not None,
        None if run.adaptive is None else run.adaptive.parameters,
    )
    surface, adaptive = run.surface, run.adaptive
    steps = [step.get("spec", str(step)) for step in meta["preprocessing"]]
    return ReportAnalysis(
        path=os.fspath(path),
        title=title or f"{Path(meta['path']).name}, column {meta['column']}",
        samples=samples, meta=meta, units=units, rate_units=run.rate_units,
        tau0=float(tau0), rate_options=rate_kw, options=opts, deviation=run.result,
        fit=run.fit, surface=surface, adaptive=adaptive,
        coefficients=run.coefficients, parameters=parameters, preprocessing=steps,
    )  # fmt: skip

"""One file as ``adavar report`` and every task of ``adavar batch`` analyse it.

:func:`analyse_file` reads and analyses one file through :func:`adavar.pipeline.analysis.run` and
returns a :class:`ReportAnalysis`: the numbers, the events and the report's parameter table
(:func:`report_parameters`), so that a file's numbers are the same in both commands.
:func:`report_options` completes a mapping of options with the defaults of
:data:`adavar.core.settings.ANALYSIS_DEFAULTS`.
"""

from __future__ import annotations

import argparse
import functools
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.core.request import AnalysisRequest, WindowSettings
from adavar.core.terms import TERM_NAMES
from adavar.dynamic.window_defaults import record_windows
from adavar.io import sources
from adavar.pipeline.analysis import (
    LoadedInput,
    controller_settings,
    rate_keywords,
    run,
)

__all__ = [
    "ReportAnalysis",
    "analyse_file",
    "report_options",
    "report_parameters",
]

_ALIASES = {"l": "segment"}
_LENGTHS = ("window", "lmax", "lmin", "segment", "step")


# --------------------------------------------------------------------------------------
# Options: those of adavar report
# --------------------------------------------------------------------------------------


@functools.cache
def _report_defaults() -> tuple[tuple[str, Any], ...]:
    """The analysis options of ``adavar report`` and their defaults (one definition:
    :data:`adavar.core.settings.ANALYSIS_DEFAULTS`, which the command line's parser agrees with)."""
    from adavar.core.settings import ANALYSIS_DEFAULTS

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
        An unknown option name (unless ``ignore_unknown``), or both ``window`` and
        ``adaptive``.
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
    WindowSettings(window=out["window"], adaptive=out["adaptive"])  # both: an error, now
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
        :class:`~adavar.io.sources.ChunkedSource`).
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
        :class:`adavar.dynamic.surface_fit.BlockFit` (the rows the report draws, every window's
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
        """The report (:func:`adavar.output.report.build_report`) of ``adavar report``."""
        from adavar.output.report import build_report

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
            stretches of :func:`adavar.dynamic.events.find_events` (``start_s``, ``end_s``: the
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
        from adavar.dynamic.events import find_events, run_change_times

        surface = self.adaptive if self.adaptive is not None else self.surface
        time_s = np.asarray(surface.time, dtype=float)
        centre = np.asarray(surface.centre, dtype=np.int64)
        t0 = float(time_s[0] - self._seconds(centre[0])) if time_s.size else 0.0
        from adavar.dynamic.surface_fit import BlockFit

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
                from adavar.dynamic.ici_events import ici_events

                found = ici_events(window, centre, time_s, lmax, self.tau0, terms, t0=t0,
                                   duration=duration,
                                   parameters=self.adaptive.parameters)  # fmt: skip
                rule = (
                    "the ICI window's steps and ramps, paired into stretches by level, and "
                    "its long-tau changes"
                )
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
        from adavar.dynamic.schedule import adaptive_schedule

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
    request = AnalysisRequest.from_options({"file": os.fspath(path), **opts})

    def one_channel(request: AnalysisRequest, loaded: LoadedInput) -> None:
        if request.record.column is not None and len(loaded.channels) != 1:
            raise AdavarInputError(
                f"{path}: --column {request.record.column} selects {len(loaded.channels)} "
                "channels; a batch analyses one column per file: run one batch per column "
                f"(e.g. --column {next(iter(loaded.channels))}) with its own --out"
            )

    # as adavar report: the file read piece by piece, the channel's deviation, fit and
    # surface by the same pipeline
    done = run(request, keep=keep, check=one_channel)
    name, analysis = next(iter(done.channels.items()))
    samples, units, meta, tau0 = done.samples[name], analysis.units, done.meta, done.tau0
    used = analysis.options  # the lengths as used (durations and the record's windows)
    opts = {**opts, **{k: getattr(used, k) for k in _LENGTHS}}
    opts["segment_given"] = request.controller.l is not None
    opts["data_type"] = used.data_type  # as read: a Stable32 .phd file holds phase
    rate_kw = rate_keywords(analysis.request, tau0)
    parameters = report_parameters(
        used,
        units,
        tau0,
        meta,
        analysis.surface is not None,
        None if analysis.adaptive is None else analysis.adaptive.parameters,
    )
    run_ = analysis
    surface, adaptive = run_.surface, run_.adaptive
    steps = [step.get("spec", str(step)) for step in meta["preprocessing"]]
    return ReportAnalysis(
        path=os.fspath(path),
        title=title or f"{Path(meta['path']).name}, column {meta['column']}",
        samples=samples, meta=meta, units=units, rate_units=run_.rate_units,
        tau0=float(tau0), rate_options=rate_kw, options=opts, deviation=run_.result,
        fit=run_.fit, surface=surface, adaptive=adaptive,
        coefficients=run_.coefficients, parameters=parameters, preprocessing=steps,
    )  # fmt: skip

"""DAVAR-Lmin, DAVAR-Lmax, DAVAR-K and A-DAVAR on the same signal: methods side by side.

:func:`compare` runs several window strategies on one record (a fixed window of ``Lmin`` and
of ``Lmax`` samples, the kurtosis-only controller DAVAR-K, the adaptive A-DAVAR, optionally
the oracle schedule), fits the noise model to every window and returns, per method, the
window schedule, ``N(t)``, the node times around every change (:mod:`adavar.paper.nodes`,
docs/method.md section 9), the interval means ``ARW(a~b)`` and, when the true noise level is
known (the paper's simulations, :func:`adavar.paper.scenarios.paper_scenario`), ground-truth
metrics of confidence and tracking. :func:`run_comparison` is the engine behind it and
behind the paper's many-seed study.

The paper's part lives in :mod:`adavar.paper`: its published values
(:mod:`adavar.paper.reference`), the node rules (:mod:`adavar.paper.nodes`) and its studies
(:mod:`adavar.paper.studies`: :func:`~adavar.paper.studies.compare_seeds`, which sets the
node medians over many realisations beside the paper's Table 1,
:func:`~adavar.paper.studies.threshold_study`, the paper's Fig. 8, and
:func:`~adavar.paper.studies.kurtosis_study`, its Figs. 6-7), which build on this module.

Ground-truth metrics
--------------------
With the true ``N`` of every sample (``truth``) and the change times:

- confidence: ``r = N(t) / N_true(t) - 1`` over the stationary centres, those farther than
  ``Lmax tau0 / 2`` from every change (no window of any method there holds a change):
  mean (``bias``), standard deviation (``std``) and ``1.4826 x`` the median absolute
  deviation (``mad``, a standard deviation robust to the odd outlier);
- tracking, per change ``X`` (centres within ``Lmax tau0`` of ``X``): ``error``, the mean of
  ``|N - N_true| / N_true``; ``delay``, the first centre at which ``N(t)`` is past the
  midpoint between the two true levels (in the direction of the change) minus ``X``;
  ``rise``, the time ``N(t)`` takes from 10 % to 90 % of the step (from its last
  centre short of 10 % before the first passage of 90 %, so that noise ahead of the
  change does not count).

Here ``N_true(t)`` is the level of the sample at the window centre, a step at ``X``: every
windowed estimate smears the step over about a window, and the error and rise time measure
how much. On unit white noise the five-term least-squares fit (the paper's, the default
``terms``) puts ``N`` about 3 % low (some power goes into the Q, B and K terms); fitting
``terms=("angle_random_walk",)`` removes that bias.

Speed
-----
On records shorter than :data:`SMALL_RECORD` samples the numba kernels run on one thread
within these functions: their parallel launch costs 10-30 ms per call on a busy 2-core
machine, more than the work on 6000 samples. :func:`~adavar.paper.studies.compare_seeds`
(through :func:`run_comparison` with an :class:`EdfCache`) also computes each
surface without confidence bounds and weights the fit with equivalent degrees of freedom
computed once per (window length, tau) for white rate noise (``alpha = 0``, the scenarios'
truth) instead of identifying the noise type of every realisation; its default
``taus="octave"`` keeps 8 taus instead of 200 (on scenario 1 the ``N`` of a window moves
by 0.2 % in the median, 1 % at the 95th percentile, between the two tau sets).
"""

from __future__ import annotations

import contextlib
import itertools
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from adavar.core.durations import count_text
from adavar.core.errors import AdavarInputError
from adavar.core.inputs import as_samples
from adavar.core.request import settings_keywords
from adavar.core.results import DavarResult, NoiseFit
from adavar.core.settings import CONTROLLER, DEFAULT_MAX_MEMORY_MB, ControllerSettings
from adavar.core.terms import TERM_NAMES
from adavar.dynamic.schedule import Schedule, adaptive_schedule
from adavar.dynamic.surface import davar
from adavar.dynamic.surface_common import edf_table
from adavar.dynamic.surface_fit import drawn_rows, fit_davar_in_blocks, fit_rows
from adavar.dynamic.window_defaults import comparison_step
from adavar.dynamic.windows import window_overhang
from adavar.fit.noise_model import fit_avar, fit_noise
from adavar.io.sources import DEFAULT_CHUNK, check_chunk_size, is_chunked, open_record
from adavar.io.writers import jsonable
from adavar.paper.metrics import ChangeMetrics, Metrics, interval_means, tracking_metrics
from adavar.paper.nodes import NODE_NAMES, Nodes, fixed_nodes, schedule_nodes
from adavar.paper.reference import (
    PAPER_FIG8_CROSSINGS,
    PAPER_LABELS,
    PAPER_REFERENCE,
    PAPER_TABLE1_ARW,
    PAPER_TABLE1_NODES,
    PAPER_TABLE3_NODES,
    paper_nodes,
)

__all__ = [
    "FIGURE_WINDOWS",
    "NODE_NAMES",
    "PAPER_FIG8_CROSSINGS",
    "PAPER_LABELS",
    "PAPER_REFERENCE",
    "PAPER_TABLE1_ARW",
    "PAPER_TABLE1_NODES",
    "PAPER_TABLE3_NODES",
    "SMALL_RECORD",
    "ChangeMetrics",
    "Comparison",
    "MethodRun",
    "Metrics",
    "Nodes",
    "compare",
    "default_methods",
    "fixed_nodes",
    "interval_means",
    "schedule_nodes",
    "tracking_metrics",
]

#: Records shorter than this run the numba kernels on one thread here (see "Speed").
SMALL_RECORD = 100_000


# ---------------------------------------------------------------------------------------
# methods


@dataclass(frozen=True)
class _Method:
    name: str
    label: str
    kind: str  # "fixed", "kurtosis", "adaptive", "oracle", "ici"
    window: int = 0
    options: tuple[tuple[str, Any], ...] = ()


def default_methods(lmin: int = 400, lmax: int = 600) -> tuple[str, ...]:
    """The paper's comparison: DAVAR-Lmin, DAVAR-Lmax, DAVAR-K and A-DAVAR.

    Parameters
    ----------
    lmin, lmax : int
        Shortest and longest window of the adaptive controllers.

    Returns
    -------
    tuple of str
        ``("davar-<lmin>", "davar-<lmax>", "davar-k", "a-davar")``.
    """
    return (f"davar-{int(lmin)}", f"davar-{int(lmax)}", "davar-k", "a-davar")


def _parse_method(name: str, k2: float, thresholds: str = "paper") -> _Method:
    key = str(name).strip().lower()
    calibrated = thresholds == "calibrated"
    if key in ("a-davar", "adaptive"):
        return _Method("a-davar", "A-DAVAR (calibrated)" if calibrated else "A-DAVAR",
                       "adaptive")  # fmt: skip
    if key in ("davar-k", "kurtosis"):
        return _Method("davar-k", "DAVAR-K (calibrated)" if calibrated else f"DAVAR-K-{k2:g}",
                       "kurtosis")  # fmt: skip
    if key == "oracle":
        return _Method("oracle", "oracle", "oracle")
    if key == "ici":
        return _Method("ici", "ICI", "ici")
    if key in ("ici-centred", "ici-centered"):
        return _Method("ici-centred", "ICI (centred)", "ici", options=(("ici_sides", "centred"),))
    if key.startswith("davar-"):
        try:
            length = int(key[6:])
        except ValueError:
            length = 0
        if length >= 3:
            return _Method(f"davar-{length}", f"DAVAR-{length}", "fixed", length)
    raise AdavarInputError(
        f"unknown method {name!r}: use davar-<L> (a fixed window of L >= 3 samples), davar-k, "
        "a-davar, oracle, ici or ici-centred"
    )


# ---------------------------------------------------------------------------------------
# compare


@dataclass(frozen=True, eq=False)
class MethodRun:
    """One window strategy applied to the record.

    Attributes
    ----------
    name : str
        ``"davar-400"``, ``"davar-k"``, ``"a-davar"``, ``"oracle"``, ...
    label : str
        For tables and legends: ``"DAVAR-400"``, ``"DAVAR-K-3.3"``, ``"A-DAVAR"``, ...
    window : ndarray of int64, shape (T,)
        Window length at every centre (read-only; a fixed window: one value, broadcast).
    schedule : Schedule or None
        The controller's record (kurtosis, S, f1, f2, f); None for a fixed window.
    result : DavarResult
        The DAVAR surface on ``window`` (with ``keep="figures"`` only the windows the
        surface figure draws, see :func:`compare`).
    fit : NoiseFit
        The noise model fitted to every window (``keep="figures"``: to the windows of
        ``result``, without the per-cell ``used`` and ``residuals``).
    arw : ndarray, shape (T,)
        ``N(t)``, the angle random walk of every window (``fit.angle_random_walk.value``).
    nodes : tuple of Nodes
        One per change time.
    intervals : dict
        ``(a, b) -> ARW(a~b)``.
    metrics : Metrics or None
        Ground-truth metrics (None when the truth is unknown).
    """

    name: str
    label: str
    window: np.ndarray
    schedule: Schedule | None
    result: DavarResult
    fit: NoiseFit
    arw: np.ndarray
    nodes: tuple[Nodes, ...]
    intervals: dict[tuple[float, float], float]
    metrics: Metrics | None

    def node(self, node: str, change: float) -> float:
        """The time of ``node`` around ``change`` (NaN if that change was not given)."""
        for item in self.nodes:
            if abs(item.change - change) < 1e-9:
                return item.get(node)
        return math.nan


@dataclass(frozen=True, eq=False)
class Comparison:
    """Several window strategies on one record: what :func:`compare` returns.

    Attributes
    ----------
    time : ndarray, shape (T,)
        Window-centre times, seconds.
    data : ndarray, shape (N,), or ChunkedSource
        The rate samples.
    rate : float
        Sample rate, Hz.
    methods : dict
        Method name -> :class:`MethodRun`, in the order requested.
    change_times : tuple of float
        Change times used for the nodes and metrics (seconds; may be empty).
    truth : ndarray or None
        The true ``N`` at every centre, if known.
    intervals : tuple of (float, float)
        The ``ARW(a~b)`` intervals.
    parameters : dict
        Every setting used.
    description : str
        What the record is.
    scenario : int or None
        The paper scenario (1 or 2) the record comes from, if any.
    units : str or None
        Declared unit of the rate samples.
    """

    time: np.ndarray
    data: np.ndarray
    rate: float
    methods: dict[str, MethodRun]
    change_times: tuple[float, ...]
    truth: np.ndarray | None
    intervals: tuple[tuple[float, float], ...]
    parameters: dict[str, Any]
    description: str
    scenario: int | None = None
    units: str | None = None

    @property
    def labels(self) -> dict[str, str]:
        """Method name -> label."""
        return {name: run.label for name, run in self.methods.items()}

    def paper_nodes(self) -> dict[str, dict[tuple[str, float], float]]:
        """The paper's node values for this record's scenario ({} for other records)."""
        return paper_nodes(self.scenario)

    def node_rows(self) -> list[dict[str, Any]]:
        """The node table: one row per (change, node) with every method's time.

        Returns
        -------
        list of dict
            ``{"node", "change", "values": {method: s}, "paper": {method: s}}``; ``paper``
            holds the paper's values for scenario 1 (Table 1) and 2 (Table 3, measured).
        """
        paper = self.paper_nodes()
        rows = []
        for change in self.change_times:
            for node in NODE_NAMES:
                values = {name: run.node(node, change) for name, run in self.methods.items()}
                if node == "restore" and all(math.isnan(v) for v in values.values()):
                    continue
                rows.append({
                    "node": node, "change": change, "values": values,
                    "paper": {m: v[(node, change)] for m, v in paper.items()
                              if (node, change) in v},
                })  # fmt: skip
        return rows

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (no per-window arrays; NaN as None)."""
        return jsonable({
            "description": self.description,
            "scenario": self.scenario,
            "rate": self.rate,
            "n_samples": int(self.data.size),
            "units": self.units,
            "change_times": list(self.change_times),
            "parameters": self.parameters,
            "methods": {
                name: {
                    "label": run.label,
                    "window": {"min": int(run.window.min()), "max": int(run.window.max()),
                               "mean": float(run.window.mean())},
                    "nodes": [_nodes_dict(n) for n in run.nodes],
                    "intervals": [{"a": a, "b": b, "arw": v}
                                  for (a, b), v in run.intervals.items()],
                    "metrics": None if run.metrics is None else _metrics_dict(run.metrics),
                }
                for name, run in self.methods.items()
            },
            "paper": {"reference": PAPER_REFERENCE, "nodes": _paper_rows(self.paper_nodes())},
        })  # fmt: skip


def _paper_rows(table: Mapping[str, Mapping[tuple[str, float], float]]) -> dict[str, Any]:
    return {m: [{"node": k[0], "change": k[1], "value": v} for k, v in vals.items()]
            for m, vals in table.items()}  # fmt: skip


def _nodes_dict(n: Nodes) -> dict[str, float]:
    return {"change": n.change, "beginning": n.beginning, "end": n.end, "restore": n.restore}


def _metrics_dict(m: Metrics) -> dict[str, Any]:
    return {
        "bias": m.bias, "std": m.std, "mad": m.mad, "n_stationary": m.n_stationary,
        "changes": [{"change": c.change, "before": c.before, "after": c.after,
                     "error": c.error, "delay": c.delay, "rise": c.rise, "span": c.span}
                    for c in m.changes],
    }  # fmt: skip


@contextlib.contextmanager
def threads_for(n_samples: int) -> Iterator[None]:
    """One numba thread for small records (parallel launch costs more than the work).

    Parameters
    ----------
    n_samples : int
        Length of the record; below :data:`SMALL_RECORD` the context runs numba on one
        thread and restores the previous count on exit.
    """
    if n_samples >= SMALL_RECORD:
        yield
        return
    import numba

    old = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(old)


class EdfCache:
    """EDF rows per (window length, taus, alpha), computed once (white-noise fast path)."""

    def __init__(self) -> None:
        self._rows: dict[tuple[tuple[int, ...], tuple[int, ...]], dict[tuple[int, int], Any]] = {}

    def cells(self, result: DavarResult, alpha: np.ndarray) -> np.ndarray:
        """The EDF of every cell of ``result`` for the noise exponents ``alpha`` (per tau).

        Parameters
        ----------
        result : DavarResult
            A surface computed without bounds.
        alpha : ndarray of int, shape (n_taus,)
            Noise exponent of each tau.

        Returns
        -------
        ndarray, shape (n_windows, n_taus)
        """
        ms = tuple(int(m) for m in result.m)
        al = tuple(int(a) for a in alpha)
        # a window reaching into the mirrored ends has fewer distinct terms (as in davar)
        n = result.n_samples - (1 if result.data_type == "phase" else 0)
        centre = result.centre if result.shift is None else result.centre + result.shift
        overhang = (
            window_overhang(centre, result.window, n)
            if result.edges == "mirror"
            else np.zeros(np.size(result.window), dtype=np.int64)
        )
        # one integer per (length, overhang) pair, in the pairs' order: a 1-D unique, about
        # 10x faster than np.unique(axis=0) (both are at most n, so no overflow below 2**31)
        base = n + 2
        if base < 2**31:
            codes, inverse = np.unique(
                np.asarray(result.window, dtype=np.int64) * base + overhang, return_inverse=True
            )
            keys = np.stack([codes // base, codes % base], axis=1)
        else:
            keys, inverse = np.unique(
                np.stack([np.asarray(result.window), overhang], axis=1), axis=0,
                return_inverse=True,
            )  # fmt: skip
        held = self._rows.setdefault((ms, al), {})  # (L, h) -> EDF row, for these taus
        pairs = list(zip(keys[:, 0].tolist(), keys[:, 1].tolist(), strict=True))
        missing = [pair for pair in pairs if pair not in held]
        if missing:
            table = edf_table(
                np.array([L for L, _ in missing]), np.asarray(ms), np.asarray(al),
                overhang=np.array([h for _, h in missing]),
            )  # fmt: skip
            held.update(zip(missing, table, strict=True))
        rows = np.stack([held[pair] for pair in pairs])
        return rows[inverse.ravel()]


def as_record(data: Any, *, streamed: bool = False) -> tuple[Any, dict[str, Any]]:
    """Samples and what a scenario object knows (rate, changes, truth, intervals, ...).

    Parameters
    ----------
    data : array_like or PaperScenario
        Rate samples, or an object with ``data``, ``rate``, ``change_times`` and ``arw``
        (and optionally ``intervals``, ``description``, ``number``).
    streamed : bool
        Keep a record read piece by piece (a source, a dask array, a memory-mapped file)
        as a source instead of loading it (for code that reads it piece by piece).

    Returns
    -------
    samples : ndarray or ChunkedSource
        At least 3 of them.
    known : dict
        ``rate``, ``change_times``, ``truth``, ``intervals``, ``description``, ``scenario``
        of a scenario; ``{}`` for plain samples.
    """
    known: dict[str, Any] = {}
    if hasattr(data, "data") and hasattr(data, "change_times"):
        known = {
            "rate": float(data.rate),
            "change_times": tuple(float(t) for t in data.change_times),
            "truth": np.asarray(data.arw, dtype=float),
            "intervals": tuple(getattr(data, "intervals", ()) or ()),
            "description": str(getattr(data, "description", "")),
            "scenario": getattr(data, "number", None),
        }
        data = data.data
    if streamed and is_chunked(data):  # a file read piece by piece stays on disk
        return open_record(data, 3), known
    return as_samples(data, min_length=3), known


def check_rate(rate: Any) -> float:
    """``rate`` as a positive, finite float (Hz).

    Raises
    ------
    AdavarInputError
        For anything else.
    """
    try:
        value = float(rate)
    except (TypeError, ValueError):
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise AdavarInputError(f"rate must be a positive number of Hz, got {rate!r}")
    return value


def compare(
    data: Any,
    *,
    methods: Sequence[str] | None = None,
    rate: float | None = None,
    change_times: Sequence[float] | None = None,
    truth: Sequence[float] | np.ndarray | None = None,
    intervals: Sequence[tuple[float, float]] | None = None,
    lmax: int = CONTROLLER.lmax,
    lmin: int = CONTROLLER.lmin,
    k1: float = CONTROLLER.k1,
    k2: float = CONTROLLER.k2,
    s1: float = CONTROLLER.s1,
    s2: float = CONTROLLER.s2,
    l: int = CONTROLLER.l,  # noqa: E741 - the paper's name
    dl0: int = CONTROLLER.dl0,
    dl1: int = CONTROLLER.dl1,
    s_test: str = CONTROLLER.s_test,
    combine: str = CONTROLLER.combine,
    thresholds: str = CONTROLLER.thresholds,
    false_alarm: float = CONTROLLER.false_alarm,
    taus: str | Sequence[float] = "all",
    terms: Sequence[str] = TERM_NAMES,
    confidence: float = 0.683,
    noise_type: str | int | Sequence[int] = "record",
    points_per_decade: int = 10,
    units: str | None = None,
    description: str | None = None,
    keep: str = "all",
    step: int | None = None,
    max_memory: float = DEFAULT_MAX_MEMORY_MB,
    chunk_size: int | None = None,
    settings: ControllerSettings | None = None,
) -> Comparison:
    """Run DAVAR-Lmin, DAVAR-Lmax, DAVAR-K and A-DAVAR (or other methods) on one record.

    Parameters
    ----------
    data : array_like or PaperScenario
        Rate samples, or a scenario from :func:`adavar.simulate.paper_scenario`, which
        brings its rate, change times, true ``N`` and the paper's ARW intervals (explicit
        arguments override them).
    methods : sequence of str, optional
        From ``"davar-<L>"`` (fixed window of ``L`` samples), ``"davar-k"`` (the kurtosis
        controller, ``f = f1``), ``"a-davar"`` (the adaptive controller), ``"oracle"``
        (the ideal schedule; needs ``change_times``), ``"ici"`` (the
        intersection-of-confidence-intervals window of :mod:`adavar.dynamic.ici`, with one-sided
        windows, its defaults) and ``"ici-centred"`` (the same, centred windows only). Default
        :func:`default_methods` ``(lmin, lmax)``.
    rate : float, optional
        Sample rate in Hz (default 1, or the scenario's).
    change_times : sequence of float, optional
        Known change times (s) for the nodes and the metrics.
    truth : array_like, optional
        The true ``N`` of every sample (``std * sqrt(tau0)`` for white noise), for the
        ground-truth metrics.
    intervals : sequence of (float, float), optional
        ``ARW(a~b)`` intervals (s). Default: the scenario's (the paper's), else the
        stretches between consecutive changes (the whole record without changes).
    lmax, lmin, k1, k2, s1, s2, l, dl0, dl1, s_test, combine, thresholds, false_alarm
        Controller settings, as in :func:`adavar.adaptive_davar` (the paper's by default).
    taus : str or sequence of float
        Taus of every surface (``"all"``, the paper's, by default).
    terms : sequence of str
        Terms of the noise fit of every window (all five, the paper's least squares).
    confidence : float
        Level of the per-cell bounds (the fit needs the EDF behind them).
    noise_type : "record" or int or sequence of int
        Noise type for the EDF, as in :func:`adavar.davar`.
    points_per_decade : int
        Density of ``taus="log"``.
    units : str, optional
        Declared unit of the rate samples.
    description : str, optional
        What the record is (for reports).
    keep : {"all", "figures"}
        ``"all"`` (default): every method's whole surface (``MethodRun.result``) and the
        per-cell residuals of its fit, held together. ``"figures"``: what the tables and
        :func:`adavar.output.plots.comparison_figures` read: each surface is freed once fitted,
        keeping only the :data:`FIGURE_WINDOWS` windows (evenly spread over the record)
        that :func:`adavar.output.plots.davar_surface_figure` draws, with the fits of those
        windows only (without per-cell ``used`` and ``residuals``; ``arw`` holds every
        window's N), and the surfaces without confidence bounds (``avar_low``,
        ``avar_high`` and ``bound_table`` None; ``davar(..., bounds=False)``); every other
        value is the same, and each surface is computed and fitted a block of windows at a
        time (:mod:`adavar.dynamic.surface_fit`; ``adavar compare`` uses it).
    step : int, optional
        Windows at every ``step``-th centre only (the controllers still visit every
        sample; nodes and metrics are read on that grid). Default: every centre while all
        methods' per-centre series fit ``max_memory`` MB, else the smallest step that fits
        (:func:`adavar.dynamic.window_defaults.comparison_step`; ``parameters["step"]``).
    max_memory : float
        Budget in MB of the per-centre series when ``step`` is left to adavar.
    chunk_size : int, optional
        Samples the controllers and surfaces (``keep="figures"``) read at a time, for a
        record read piece by piece. Default: :data:`adavar.io.sources.DEFAULT_CHUNK` with a
        ``step`` > 1 (the same windows), else each function's own.
    settings : ControllerSettings, optional
        The controller's keywords (``lmax`` ... ``false_alarm``) as one object
        (:class:`adavar.ControllerSettings`, the paper's by default); its fields replace
        those keywords, a keyword also given with another value is an error, and
        ``false_alarm_per_hour`` must stay None (the comparison's thresholds are per step).

    Returns
    -------
    Comparison

    Raises
    ------
    AdavarInputError
        Bad data, an unknown method, ``"oracle"`` without change times, a truth of the
        wrong length, or bad controller settings.
    """
    if settings is not None:
        given = {k: v for k, v in locals().items() if k not in ("data", "settings")}
        return compare(data, **settings_keywords(compare, given, (settings, ControllerSettings)))
    return run_comparison(
        data, methods=methods, rate=rate, change_times=change_times, truth=truth,
        intervals=intervals, controller=dict(
            lmax=lmax, lmin=lmin, k1=k1, k2=k2, s1=s1, s2=s2, l=l, dl0=dl0, dl1=dl1,
            s_test=s_test, combine=combine, thresholds=thresholds, false_alarm=false_alarm,
        ), taus=taus, terms=terms, confidence=confidence, noise_type=noise_type,
        points_per_decade=points_per_decade, units=units, description=description,
        edf_cache=None, keep=keep, step=step, max_memory=max_memory, chunk_size=chunk_size,
    )  # fmt: skip


#: Bytes a method's run holds per surface cell: the variance and the per-window fit.
_RUN_CELL_BYTES = 8 * 2
#: Windows of a surface kept with ``keep="figures"``: those
#: :func:`adavar.output.plots.davar_surface_figure` draws (its ``max_times``).
FIGURE_WINDOWS = 400


def _check_memory(
    n_methods: int, n: int, taus: Any, longest: int, tau0: float, points_per_decade: int,
    keep: str = "all",
) -> None:  # fmt: skip
    """A one-line error, before any work, when the runs would not fit in free memory."""
    from adavar.core.taus import averaging_factors
    from adavar.io.sources import available_memory

    ms, _ = averaging_factors(taus, max(1, longest // 3), tau0,
                              points_per_decade=points_per_decade)  # fmt: skip
    held = n_methods * _RUN_CELL_BYTES if keep == "all" else 8  # "figures": one surface
    need = n * ms.size * held
    free = available_memory()
    if free is not None and need > 0.8 * free:
        one = "" if keep == "all" else " (one at a time)"
        raise AdavarInputError(
            f"comparing {n_methods} methods on {n} windows at {ms.size} taus keeps "
            f"{need / 2**30:.1f} GiB of surfaces{one} but {free / 2**30:.1f} GiB is free: use "
            "taus='octave' (--taus octave), fewer methods, or a shorter record"
        )


def run_comparison(
    data: Any,
    *,
    methods: Sequence[str] | None,
    rate: float | None,
    change_times: Sequence[float] | None,
    truth: Any,
    intervals: Sequence[tuple[float, float]] | None,
    controller: dict[str, Any],
    taus: Any,
    terms: Sequence[str],
    confidence: float,
    noise_type: Any,
    points_per_decade: int,
    units: str | None,
    description: str | None,
    edf_cache: EdfCache | None,
    keep: str = "all",
    step: int | None = None,
    max_memory: float = DEFAULT_MAX_MEMORY_MB,
    chunk_size: int | None = None,
) -> Comparison:
    """:func:`compare` with the controller settings as one dict, and an optional fast path.

    Parameters
    ----------
    data, methods, rate, change_times, truth, intervals, taus, terms, confidence
        As in :func:`compare` (every one required here).
    noise_type, points_per_decade, units, description
        As in :func:`compare`.
    controller : dict
        The controller keywords of :func:`compare` (``lmax``, ``lmin``, ``k1``, ...).
    edf_cache : EdfCache or None
        None: every surface with its confidence bounds and a fit weighted by their EDF (what
        :func:`compare` does). An :class:`EdfCache`: surfaces without bounds, the fit
        weighted by the cached EDF of noise exponent ``noise_type`` (the many-seed study).
    keep, step, max_memory, chunk_size
        As in :func:`compare`.

    Returns
    -------
    Comparison
    """
    if keep not in ("all", "figures"):
        raise AdavarInputError(f"unknown keep {keep!r}: use 'all' or 'figures'")
    x, known = as_record(data, streamed=True)
    n = x.size
    fs = check_rate(rate if rate is not None else known.get("rate", 1.0))
    tau0 = 1.0 / fs
    changes = tuple(float(c) for c in (change_times if change_times is not None
                                        else known.get("change_times", ())))  # fmt: skip
    duration = n * tau0
    for c in changes:
        if not (0.0 < c < duration):
            raise AdavarInputError(
                f"change time {c:g} s lies outside the record (0 .. {duration:g} s)"
            )
    if list(changes) != sorted(changes):
        raise AdavarInputError("change_times must be increasing")
    true = truth if truth is not None else known.get("truth")
    if true is not None:
        true = np.asarray(true, dtype=float)
        if true.shape != (n,) or not np.all(np.isfinite(true)) or not np.all(true > 0):
            raise AdavarInputError(
                f"truth must hold one positive, finite N per sample ({n}), got shape {true.shape}"
            )
    if intervals is None:
        intervals = known.get("intervals") or None
    if intervals is None:
        edges_ = (0.0, *changes, duration)
        intervals = tuple(itertools.pairwise(edges_))
    ivals = tuple((float(a), float(b)) for a, b in intervals)
    for a, b in ivals:
        if not a < b:
            raise AdavarInputError(f"interval ({a:g}, {b:g}) is empty: give a < b")

    lmax = int(controller["lmax"])
    lmin = int(controller["lmin"])
    specs = [
        _parse_method(m, float(controller["k2"]), str(controller["thresholds"]))
        for m in (methods if methods is not None else default_methods(lmin, lmax))
    ]
    if not specs:
        raise AdavarInputError("give at least one method")
    names = [s.name for s in specs]
    if len(set(names)) != len(names):
        raise AdavarInputError(f"methods repeat: {', '.join(names)}")
    if any(s.kind == "oracle" for s in specs) and not changes:
        raise AdavarInputError("method 'oracle' needs change_times")
    for s in specs:
        if s.kind == "fixed" and s.window > n:
            raise AdavarInputError(
                f"DAVAR-{count_text(s.window)}: a window of {count_text(s.window)} samples is "
                f"longer than the record ({n})"
            )

    if not isinstance(x, np.ndarray) and (
        keep == "all" or edf_cache is not None or any(s.kind == "ici" for s in specs)
    ):  # whole surfaces, the cached EDFs and ICI run on the record in memory
        x = as_samples(x, min_length=3)
    if step is not None and (isinstance(step, bool) or not isinstance(step, (int, np.integer))
                             or step < 1):  # fmt: skip
        raise AdavarInputError(f"step must be a whole number of samples >= 1, got {step!r}")
    step, _ = comparison_step(n, len(specs), step, max_memory)
    _check_memory(len(specs), -(-n // step), taus, max(lmax, *(s.window or 0 for s in specs)), tau0,
                  points_per_decade, keep)  # fmt: skip
    runs: dict[str, MethodRun] = {}
    # with a step, the controllers' per-sample record is kept a piece at a time (the same
    # windows bit for bit): the transient is a piece, not 40 bytes a sample of the record
    piece = {"chunk_size": DEFAULT_CHUNK} if step > 1 and n > DEFAULT_CHUNK else {}
    if chunk_size is not None:
        piece = {"chunk_size": check_chunk_size(chunk_size)}
    centres: tuple[np.ndarray, np.ndarray] | None = None  # the first run's times, centres
    with threads_for(n):
        for spec in specs:
            sched = None
            if spec.kind == "fixed":
                window: Any = spec.window
            else:
                sched = adaptive_schedule(
                    x, method=spec.kind, rate=fs,
                    change_times=changes if spec.kind == "oracle" else None, step=step,
                    **controller, **dict(spec.options), **({} if spec.kind == "ici" else piece),
                )  # fmt: skip
                window = sched.window
            shift = None if sched is None else sched.shift  # ICI's one-sided windows
            surface = dict(window=window, rate=fs, taus=taus, confidence=confidence,
                           noise_type=noise_type, points_per_decade=points_per_decade,
                           units=units, shift=shift, step=step)  # fmt: skip
            blocks = None
            try:
                if edf_cache is None and keep == "all":
                    result = davar(x, **surface)
                    fit = fit_noise(result, terms=terms, cells=True)
                elif edf_cache is None:  # a block of windows at a time, the terms on disk
                    blocks = fit_davar_in_blocks(
                        x, fit_options=dict(terms=terms, cells=False), drawn=FIGURE_WINDOWS,
                        bounds=False, fit_rows="drawn", spill=True, **surface,
                        **({} if chunk_size is None else piece),
                    )  # fmt: skip
                    result, fit = blocks.drawn, blocks.fit
            except ValueError as exc:
                raise AdavarInputError(str(exc)) from None
            if edf_cache is not None:
                result = davar(x, window=window, rate=fs, taus=taus, confidence=None,
                               points_per_decade=points_per_decade, units=units,
                               shift=shift, step=step)  # fmt: skip
                alpha = np.broadcast_to(np.asarray(noise_type, dtype=np.int64), result.m.shape)
                fit = fit_avar(result.tau, result.avar, edf_cache.cells(result, alpha),
                               terms=terms, cells=keep == "all")  # fmt: skip
            arw = np.asarray(fit.angle_random_walk.value if blocks is None
                             else blocks.term_values("angle_random_walk"), dtype=float)  # fmt: skip
            rows = result if blocks is None else blocks  # every window's time, length, centre
            t = np.asarray(rows.time, dtype=float)
            w = np.asarray(rows.window, dtype=np.int64)
            # held once: the schedule's lengths, or a fixed window as a read-only view
            if sched is not None and np.array_equal(sched.window, w):
                w = sched.window
            elif spec.kind == "fixed":
                w = np.broadcast_to(np.int64(spec.window), w.shape)
            if centres is None:
                centres = t, np.asarray(rows.centre)
            if spec.kind == "fixed":
                nodes = fixed_nodes(changes, spec.window, rate=fs)
            else:
                nodes = schedule_nodes(w, changes, lmax=lmax, rate=fs, time=t)
            metrics = None
            if true is not None:
                metrics = tracking_metrics(
                    t, arw, true[rows.centre], changes, margin=0.5 * lmax * tau0,
                    span=lmax * tau0,
                )  # fmt: skip
            if keep != "all" and blocks is None:  # the figures' windows only from here
                drawn = drawn_rows(result, FIGURE_WINDOWS)
                fit, result = fit_rows(fit, drawn[0]), drawn[1]
            runs[spec.name] = MethodRun(
                name=spec.name, label=spec.label, window=w, schedule=sched, result=result,
                fit=fit, arw=arw, nodes=nodes, intervals=interval_means(t, arw, ivals),
                metrics=metrics,
            )  # fmt: skip
    assert centres is not None  # at least one method ran
    parameters = dict(
        methods=names, rate=fs, taus=taus if isinstance(taus, str) else list(map(float, taus)),
        terms=list(terms), confidence=confidence, noise_type=noise_type, step=step,
        **{k: v for k, v in controller.items()},
    )  # fmt: skip
    return Comparison(
        time=centres[0],
        data=x,
        rate=fs,
        methods=runs,
        change_times=changes,
        truth=None if true is None else true[centres[1]],
        intervals=ivals,
        parameters=parameters,
        description=description or known.get("description") or f"{n} samples at {fs:g} Hz",
        scenario=known.get("scenario"),
        units=units,
    )

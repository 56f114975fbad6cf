"""The paper's studies: its Figs. 6-8 (kurtosis of fixed windows) and many seeds of a scenario.

:func:`kurtosis_study` computes the paper's Figs. 6-7 (the kurtosis of fixed windows and the
record-form contribution coefficient S), :func:`threshold_study` its Fig. 8 (where the
kurtosis of a fixed window crosses a threshold), and :func:`compare_seeds` repeats
:func:`adavar.comparison.compare` over many realisations of a scenario
(:func:`adavar.paper.scenarios.paper_scenario`) and sets the node medians beside the paper's
Table 1 (:data:`adavar.paper.reference.PAPER_TABLE1_NODES`). :func:`compare_seeds` takes the
fast path described in :mod:`adavar.comparison` ("Speed"): one numba thread, surfaces without
bounds, EDFs for white noise computed once, octave taus by default.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from adavar.comparison import EdfCache, as_record, check_rate, run_comparison, threads_for
from adavar.core.errors import AdavarInputError
from adavar.core.request import settings_keywords
from adavar.core.settings import CONTROLLER, ControllerSettings
from adavar.core.terms import TERM_NAMES
from adavar.io.writers import jsonable
from adavar.paper.nodes import NODE_NAMES
from adavar.paper.reference import (
    PAPER_FIG6_WINDOWS,
    PAPER_FIG7_SEGMENT,
    PAPER_FIG8_THRESHOLDS,
    PAPER_REFERENCE,
    paper_arw,
    paper_crossings,
    paper_nodes,
)
from adavar.paper.scenarios import paper_scenario

__all__ = [
    "KurtosisStudy",
    "SeedStudy",
    "ThresholdStudy",
    "compare_seeds",
    "concatenate_seed_studies",
    "finite_median",
    "kurtosis_study",
    "threshold_study",
]


# ---------------------------------------------------------------------------------------
# the paper's Fig. 6-8: kurtosis of fixed windows


@dataclass(frozen=True, eq=False)
class KurtosisStudy:
    """The paper's Figs. 6-7: the kurtosis of fixed windows and the record-form S.

    Attributes
    ----------
    time : ndarray, shape (N,)
        Time of every sample (and window centre), seconds.
    data : ndarray, shape (N,)
        The record.
    kurtosis : dict
        Window length -> kurtosis of the window centred at every sample (Fig. 6).
    segment : int
        Window of the contribution coefficient (11 in the paper's Fig. 7).
    contribution : ndarray, shape (N,)
        ``S`` of the ``segment``-sample window against the whole record (Fig. 7).
    change_times : tuple of float
        Known changes, for the figures.
    """

    time: np.ndarray
    data: np.ndarray
    kurtosis: dict[int, np.ndarray]
    segment: int
    contribution: np.ndarray
    change_times: tuple[float, ...] = ()


def kurtosis_study(
    data: Any,
    *,
    rate: float = 1.0,
    windows: Sequence[int] = PAPER_FIG6_WINDOWS,
    segment: int = PAPER_FIG7_SEGMENT,
    change_times: Sequence[float] = (),
) -> KurtosisStudy:
    """Sliding kurtosis at a few window lengths and the record-form contribution ``S``.

    Parameters
    ----------
    data : array_like or PaperScenario
        The record (a scenario brings its rate and change times).
    rate : float
        Sample rate, Hz.
    windows : sequence of int
        Window lengths of the kurtosis (the paper's Fig. 6: 11, 201, 601).
    segment : int
        Window of ``S`` against the whole record (the paper's Fig. 7: 11).
    change_times : sequence of float
        Known changes (s), carried to the figures.

    Returns
    -------
    KurtosisStudy
    """
    from adavar.dynamic.kurtosis import kurtosis_contribution, sliding_kurtosis

    x, known = as_record(data)
    fs = check_rate(known.get("rate", rate))
    changes = tuple(change_times) or known.get("change_times", ())
    with threads_for(x.size):
        kurt = {int(w): np.asarray(sliding_kurtosis(x, window=int(w))) for w in windows}
        s = np.asarray(kurtosis_contribution(x, window=int(segment), reference="record"))
    return KurtosisStudy(
        time=np.arange(x.size) / fs, data=x, kurtosis=kurt, segment=int(segment),
        contribution=s, change_times=tuple(float(c) for c in changes),
    )  # fmt: skip


@dataclass(frozen=True, eq=False)
class ThresholdStudy:
    """The paper's Fig. 8: where the kurtosis of a fixed window crosses each threshold.

    Attributes
    ----------
    time : ndarray, shape (T,)
        Window-centre times, seconds.
    kurtosis : ndarray, shape (T,)
        Kurtosis of the fixed window at every centre.
    window : int
        The window length (600 in the paper).
    thresholds : tuple of float
        The upper kurtosis thresholds ``K2`` studied.
    change_times : tuple of float
        The changes.
    crossings : dict
        Threshold -> ndarray (n_changes, 2): for each change, the time the kurtosis rises
        above the threshold and the time it falls back to or below it (seconds; NaN if
        the kurtosis never exceeds the threshold near that change).
    expected : ndarray or None
        Kurtosis of the window under the true noise levels (Gaussian mixture), if known.
    expected_crossings : dict or None
        The same crossings of ``expected``.
    """

    time: np.ndarray
    kurtosis: np.ndarray
    window: int
    thresholds: tuple[float, ...]
    change_times: tuple[float, ...]
    crossings: dict[float, np.ndarray]
    expected: np.ndarray | None = None
    expected_crossings: dict[float, np.ndarray] | None = None


def _crossings(
    t: np.ndarray,
    k: np.ndarray,
    changes: Sequence[float],
    threshold: float,
    window: int,
    tau0: float,
) -> np.ndarray:
    """(rise, fall) per change: the run above ``threshold`` holding the peak near the change.

    The peak is the largest kurtosis among the centres whose window holds the change
    (``|t - X| <= window tau0 / 2``); the run is the maximal stretch of centres above the
    threshold around it; rise = its first centre, fall = the first centre after it.
    """
    out = np.full((len(changes), 2), np.nan)
    above = k > threshold
    for j, x in enumerate(changes):
        near = np.flatnonzero(np.abs(t - x) <= 0.5 * window * tau0)
        if near.size == 0:
            continue
        vals = np.where(np.isfinite(k[near]), k[near], -np.inf)
        peak = int(near[np.argmax(vals)])
        if not above[peak]:
            continue
        a = peak
        while a > 0 and above[a - 1]:
            a -= 1
        b = peak
        while b + 1 < k.size and above[b + 1]:
            b += 1
        out[j, 0] = t[a]
        out[j, 1] = t[b + 1] if b + 1 < t.size else np.nan
    return out


def _expected_kurtosis(std: np.ndarray, window: int) -> np.ndarray:
    """Kurtosis of a window of zero-mean Gaussian samples with these stds (mirror edges)."""
    pad = window // 2 + 1
    s = np.pad(np.asarray(std, dtype=float), pad, mode="symmetric")
    c2 = np.concatenate([[0.0], np.cumsum(s**2)])
    c4 = np.concatenate([[0.0], np.cumsum(s**4)])
    start = np.arange(std.size) + pad - (window - 1) // 2
    m2 = (c2[start + window] - c2[start]) / window
    m4 = 3.0 * (c4[start + window] - c4[start]) / window
    return m4 / m2**2


def threshold_study(
    data: Any,
    *,
    change_times: Sequence[float] | None = None,
    window: int = 600,
    thresholds: Sequence[float] = PAPER_FIG8_THRESHOLDS,
    rate: float | None = None,
    std: Sequence[float] | np.ndarray | None = None,
) -> ThresholdStudy:
    """Crossing times of a fixed window's kurtosis (the paper's Fig. 8).

    For each change ``X``, the kurtosis of the fixed window peaks while the window holds a
    little of the other level; the run of centres above a threshold ``K2`` around that peak
    starts when a kurtosis controller would start shrinking and ends when it would regrow.
    On scenario 1 the paper reads 2700 s and 3228 s for ``K2 = 3.3`` (the first run) and
    3840 s for the second (:data:`~adavar.paper.reference.PAPER_FIG8_CROSSINGS`).

    Parameters
    ----------
    data : array_like or PaperScenario
        The record (a scenario brings its rate, changes and true std).
    change_times : sequence of float, optional
        The changes, seconds (required for a plain array).
    window : int
        The fixed window, samples.
    thresholds : sequence of float
        The thresholds ``K2``.
    rate : float, optional
        Sample rate, Hz.
    std : array_like, optional
        True standard deviation of every sample: adds the expected kurtosis (a Gaussian
        mixture) and its crossings.

    Returns
    -------
    ThresholdStudy
    """
    from adavar.dynamic.kurtosis import sliding_kurtosis

    x, known = as_record(data)
    fs = check_rate(rate if rate is not None else known.get("rate", 1.0))
    changes = tuple(float(c) for c in (change_times if change_times is not None
                                        else known.get("change_times", ())))  # fmt: skip
    if not changes:
        raise AdavarInputError("threshold_study needs the change times")
    if std is None and "truth" in known:
        std = known["truth"] * math.sqrt(fs)
    window = int(window)
    if not 3 <= window <= x.size:
        raise AdavarInputError(f"window must lie in 3 .. {x.size} samples, got {window}")
    with threads_for(x.size):
        k = np.asarray(sliding_kurtosis(x, window=window))
    t = np.arange(x.size) / fs
    ths = tuple(float(v) for v in thresholds)
    crossings = {th: _crossings(t, k, changes, th, window, 1.0 / fs) for th in ths}
    expected = expected_crossings = None
    if std is not None:
        sd = np.asarray(std, dtype=float)
        if sd.shape != x.shape:
            raise AdavarInputError(f"std must hold one value per sample ({x.size})")
        expected = _expected_kurtosis(sd, window)
        expected_crossings = {th: _crossings(t, expected, changes, th, window, 1.0 / fs)
                              for th in ths}  # fmt: skip
    return ThresholdStudy(
        time=t, kurtosis=k, window=window, thresholds=ths, change_times=changes,
        crossings=crossings, expected=expected, expected_crossings=expected_crossings,
    )  # fmt: skip


# ---------------------------------------------------------------------------------------
# many seeds


@dataclass(frozen=True, eq=False)
class SeedStudy:
    """:func:`~adavar.comparison.compare` over many realisations of a paper scenario.

    Attributes
    ----------
    scenario : int
        1 or 2.
    variance_reading : bool
        The disturbance's reading (see :func:`adavar.paper.scenarios.paper_scenario`).
    seeds : tuple of int
        The realisations.
    methods : tuple of str
        Method names, in table order.
    labels : dict
        Method name -> label.
    change_times : tuple of float
        The scenario's changes.
    intervals : tuple of (float, float)
        The ARW intervals.
    nodes : dict
        Method -> ndarray (n_seeds, n_changes, 3) of Beginning, End, Restore (seconds).
    arw : dict
        Method -> ndarray (n_seeds, n_intervals) of ``ARW(a~b)``.
    confidence : dict
        Method -> ndarray (n_seeds, 3): bias, std, mad of ``N / N_true - 1``.
    tracking : dict
        Method -> ndarray (n_seeds, n_changes, 3): error, delay, rise.
    crossings : dict
        Threshold -> ndarray (n_seeds, n_changes, 2): the Fig. 8 rise and fall times.
    expected_crossings : dict
        Threshold -> ndarray (n_changes, 2): the same for the expected kurtosis.
    crossing_window : int
        The fixed window of the Fig. 8 study.
    parameters : dict
        Every setting used.
    elapsed : float
        Wall-clock seconds.
    """

    scenario: int
    variance_reading: bool
    seeds: tuple[int, ...]
    methods: tuple[str, ...]
    labels: dict[str, str]
    change_times: tuple[float, ...]
    intervals: tuple[tuple[float, float], ...]
    nodes: dict[str, np.ndarray]
    arw: dict[str, np.ndarray]
    confidence: dict[str, np.ndarray]
    tracking: dict[str, np.ndarray]
    crossings: dict[float, np.ndarray]
    expected_crossings: dict[float, np.ndarray]
    crossing_window: int
    parameters: dict[str, Any] = field(default_factory=dict)
    elapsed: float = 0.0

    def paper_nodes(self) -> dict[str, dict[tuple[str, float], float]]:
        """The paper's node values for this scenario (Table 1, or Table 3: measured)."""
        return paper_nodes(self.scenario)

    def node_rows(self) -> list[dict[str, Any]]:
        """The node table over seeds: median, quartiles and missed count per method.

        Returns
        -------
        list of dict
            ``{"node", "change", "stats": {method: {"median", "q25", "q75", "p05", "p95",
            "missed"}}, "paper": {method: s}}``; the Restore row only where some method has
            one.
        """
        paper = self.paper_nodes()
        rows = []
        for j, change in enumerate(self.change_times):
            for k, node in enumerate(NODE_NAMES):
                stats = {m: _summary(self.nodes[m][:, j, k]) for m in self.methods}
                if node == "restore" and all(s["missed"] == len(self.seeds)
                                             for s in stats.values()):  # fmt: skip
                    continue
                rows.append({
                    "node": node, "change": change, "stats": stats,
                    "paper": {m: v[(node, change)] for m, v in paper.items()
                              if (node, change) in v},
                })  # fmt: skip
        return rows

    def metric_rows(self) -> list[dict[str, Any]]:
        """Ground-truth metrics, the median over seeds per method.

        Returns
        -------
        list of dict
            ``{"metric", "change" (or None), "unit", "values": {method: median}}``.
        """
        rows = []
        for k, name in enumerate(("bias", "std", "mad")):
            rows.append({"metric": name, "change": None, "unit": "1",
                         "values": {m: finite_median(self.confidence[m][:, k])
                                    for m in self.methods}})  # fmt: skip
        for j, change in enumerate(self.change_times):
            for k, (name, unit) in enumerate((("error", "1"), ("delay", "s"), ("rise", "s"))):
                rows.append({"metric": name, "change": change, "unit": unit,
                             "values": {m: finite_median(self.tracking[m][:, j, k])
                                        for m in self.methods}})  # fmt: skip
        return rows

    def arw_rows(self) -> list[dict[str, Any]]:
        """``ARW(a~b)`` per interval: the median over seeds per method, and the paper's.

        Returns
        -------
        list of dict
            ``{"interval": (a, b), "values": {method: median}, "paper": {method: value}}``
            (paper values in 1e-3 deg/sqrt(h), scenario 1 only).
        """
        paper = paper_arw(self.scenario)
        return [
            {"interval": iv, "values": {m: finite_median(self.arw[m][:, j]) for m in self.methods},
             "paper": {m: v[iv] for m, v in paper.items() if iv in v}}
            for j, iv in enumerate(self.intervals)
        ]  # fmt: skip

    def crossing_rows(self) -> list[dict[str, Any]]:
        """Fig. 8: median crossing times per threshold and change, expected and paper.

        Returns
        -------
        list of dict
            ``{"threshold", "change", "rise": {median, q25, q75, missed}, "fall": {...},
            "expected": (rise, fall), "paper": (rise, fall) or None}``.
        """
        rows = []
        for th, values in self.crossings.items():
            paper = paper_crossings(self.scenario, th)
            for j, change in enumerate(self.change_times):
                rows.append({
                    "threshold": th, "change": change,
                    "rise": _summary(values[:, j, 0]), "fall": _summary(values[:, j, 1]),
                    "expected": tuple(float(v) for v in self.expected_crossings[th][j]),
                    "paper": paper.get(change),
                })  # fmt: skip
        return rows

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (NaN as None)."""
        return jsonable({
            "scenario": self.scenario, "variance_reading": self.variance_reading,
            "n_seeds": len(self.seeds), "seeds": [self.seeds[0], self.seeds[-1]],
            "methods": {m: self.labels[m] for m in self.methods},
            "change_times": list(self.change_times),
            "nodes": self.node_rows(), "metrics": self.metric_rows(),
            "arw": [dict(r, interval=list(r["interval"])) for r in self.arw_rows()],
            "crossings": self.crossing_rows(), "crossing_window": self.crossing_window,
            "parameters": self.parameters, "elapsed_s": self.elapsed,
            "paper": {"reference": PAPER_REFERENCE},
        })  # fmt: skip


def concatenate_seed_studies(parts: Sequence[SeedStudy]) -> SeedStudy:
    """One :class:`SeedStudy` of the realisations of several, in the order given.

    The realisations are independent, so ``compare_seeds(1, range(0, 10))`` equals the
    concatenation of ``compare_seeds(1, range(0, 4))`` and ``compare_seeds(1, range(4, 10))``
    (to the last bit; only ``elapsed`` differs): several processes can share a study.

    Parameters
    ----------
    parts : sequence of SeedStudy
        Studies of the same scenario with the same settings.

    Returns
    -------
    SeedStudy
        Its ``elapsed`` is the sum of the parts' (the work, not the wall-clock time).

    Raises
    ------
    AdavarInputError
        No part, or parts of another scenario, method, change, interval or setting.
    """
    if not parts:
        raise AdavarInputError("give at least one SeedStudy")
    first = parts[0]
    for part in parts[1:]:
        same = (
            part.scenario == first.scenario
            and part.variance_reading == first.variance_reading
            and part.methods == first.methods
            and part.change_times == first.change_times
            and part.intervals == first.intervals
            and part.crossing_window == first.crossing_window
            and part.parameters == first.parameters
            and part.crossings.keys() == first.crossings.keys()
        )
        if not same:
            raise AdavarInputError(
                "the studies differ in scenario, methods or settings: concatenate studies "
                "made by compare_seeds with the same arguments but the seeds"
            )

    def joined(name: str) -> dict[Any, np.ndarray]:
        return {
            k: np.concatenate([getattr(p, name)[k] for p in parts]) for k in getattr(first, name)
        }

    return replace(
        first,
        seeds=tuple(s for p in parts for s in p.seeds),
        nodes=joined("nodes"),
        arw=joined("arw"),
        confidence=joined("confidence"),
        tracking=joined("tracking"),
        crossings=joined("crossings"),
        elapsed=float(sum(p.elapsed for p in parts)),
    )


def finite_median(values: np.ndarray) -> float:
    """The median of the finite values (NaN when there are none).

    Parameters
    ----------
    values : array_like

    Returns
    -------
    float
    """
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if v.size else math.nan


def _summary(values: np.ndarray) -> dict[str, float]:
    v = np.asarray(values, dtype=float)
    ok = v[np.isfinite(v)]
    if ok.size == 0:
        return {"median": math.nan, "q25": math.nan, "q75": math.nan, "p05": math.nan,
                "p95": math.nan, "missed": int(v.size)}  # fmt: skip
    q = np.percentile(ok, [50, 25, 75, 5, 95])
    return {"median": float(q[0]), "q25": float(q[1]), "q75": float(q[2]), "p05": float(q[3]),
            "p95": float(q[4]), "missed": int(v.size - ok.size)}  # fmt: skip


def compare_seeds(
    scenario: int = 1,
    seeds: Iterable[int] = range(100),
    *,
    variance_reading: bool = False,
    methods: Sequence[str] | None = None,
    taus: str | Sequence[float] = "octave",
    terms: Sequence[str] = TERM_NAMES,
    crossing_window: int | None = None,
    crossing_thresholds: Sequence[float] = PAPER_FIG8_THRESHOLDS,
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
    progress: Callable[[int, int], None] | None = None,
    settings: ControllerSettings | None = None,
) -> SeedStudy:
    """:func:`~adavar.comparison.compare` on many realisations of a paper scenario, and Fig. 8.

    Per seed: the scenario (:func:`adavar.paper.scenarios.paper_scenario`), every method's
    schedule, surface and ``N(t)``, its nodes, ``ARW(a~b)`` and ground-truth metrics, and
    the crossings of the fixed window's kurtosis (:func:`threshold_study`). See the notes
    of :mod:`adavar.comparison` ("Speed") for what is done differently from ``compare`` to
    keep 100 seeds
    within seconds: one numba thread, surfaces without bounds, EDFs for white noise
    computed once, octave taus by default. ``thresholds="calibrated"`` is much slower
    (about 1 s per adaptive method and seed): :func:`adavar.dynamic.adaptive.adaptive_schedule`
    recomputes the calibrated thresholds on every call.

    Parameters
    ----------
    scenario : {1, 2}
        The paper scenario.
    seeds : iterable of int
        Seeds of the realisations.
    variance_reading : bool
        Disturbance of variance 3 instead of standard deviation 3.
    methods : sequence of str, optional
        As in :func:`adavar.comparison.compare`.
    taus : str or sequence of float
        Taus of the surfaces (``"octave"`` by default).
    terms : sequence of str
        Terms of the noise fit.
    crossing_window : int, optional
        Fixed window of the Fig. 8 study (default ``lmax``).
    crossing_thresholds : sequence of float
        Its thresholds.
    lmax, lmin, k1, k2, s1, s2, l, dl0, dl1, s_test, combine, thresholds, false_alarm
        Controller settings, as in :func:`adavar.comparison.compare`.

    progress : callable, optional
        Called as ``progress(done, total)`` before each realisation (the command line draws
        a progress bar with it).
    settings : ControllerSettings, optional
        The controller settings as one object, as in :func:`adavar.comparison.compare`.

    Returns
    -------
    SeedStudy
    """
    if settings is not None:
        given = {k: v for k, v in locals().items() if k not in ("scenario", "seeds", "settings")}
        keywords = settings_keywords(compare_seeds, given, (settings, ControllerSettings))
        return compare_seeds(scenario, seeds, **keywords)
    start = _time.perf_counter()
    seed_list = tuple(int(s) for s in seeds)
    if not seed_list:
        raise AdavarInputError("give at least one seed")
    if isinstance(scenario, bool) or scenario not in (1, 2):
        raise AdavarInputError(f"scenario must be 1 or 2, got {scenario!r}")
    controller = dict(
        lmax=lmax, lmin=lmin, k1=k1, k2=k2, s1=s1, s2=s2, l=l, dl0=dl0, dl1=dl1,
        s_test=s_test, combine=combine, thresholds=thresholds, false_alarm=false_alarm,
    )  # fmt: skip
    cwin = int(lmax if crossing_window is None else crossing_window)
    cache = EdfCache()
    nodes: dict[str, list] = {}
    arw: dict[str, list] = {}
    conf: dict[str, list] = {}
    track: dict[str, list] = {}
    cross: dict[float, list] = {}
    expected: dict[float, np.ndarray] = {}
    labels: dict[str, str] = {}
    changes: tuple[float, ...] = ()
    intervals: tuple[tuple[float, float], ...] = ()
    for done, seed in enumerate(seed_list):
        if progress is not None:
            progress(done, len(seed_list))
        sc = paper_scenario(scenario, seed=seed, variance_reading=variance_reading)
        comp = run_comparison(
            sc, methods=methods, rate=None, change_times=None, truth=None, intervals=None,
            controller=controller, taus=taus, terms=terms, confidence=0.683, noise_type=0,
            points_per_decade=10, units=None, description=None, edf_cache=cache,
            keep="figures",  # only nodes, interval means and metrics are read
        )  # fmt: skip
        changes, intervals = comp.change_times, comp.intervals
        for name, run in comp.methods.items():
            labels[name] = run.label
            nodes.setdefault(name, []).append([[n.beginning, n.end, n.restore] for n in run.nodes])
            arw.setdefault(name, []).append([run.intervals[iv] for iv in intervals])
            m = run.metrics
            assert m is not None  # the scenario brings its truth
            conf.setdefault(name, []).append([m.bias, m.std, m.mad])
            track.setdefault(name, []).append([[c.error, c.delay, c.rise] for c in m.changes])
        study = threshold_study(sc, window=cwin, thresholds=crossing_thresholds)
        for th, values in study.crossings.items():
            cross.setdefault(th, []).append(values)
        if not expected and study.expected_crossings is not None:
            expected = study.expected_crossings
    names = tuple(labels)
    return SeedStudy(
        scenario=int(scenario), variance_reading=bool(variance_reading), seeds=seed_list,
        methods=names, labels=labels, change_times=changes, intervals=intervals,
        nodes={m: np.asarray(v, dtype=float).reshape(len(seed_list), len(changes), 3)
               for m, v in nodes.items()},
        arw={m: np.asarray(v, dtype=float) for m, v in arw.items()},
        confidence={m: np.asarray(v, dtype=float) for m, v in conf.items()},
        tracking={m: np.asarray(v, dtype=float).reshape(len(seed_list), len(changes), 3)
                  for m, v in track.items()},
        crossings={th: np.asarray(v, dtype=float) for th, v in cross.items()},
        expected_crossings=expected, crossing_window=cwin,
        parameters=dict(methods=list(names), taus=taus if isinstance(taus, str)
                        else list(map(float, taus)), terms=list(terms),
                        noise_type="white (alpha = 0), EDF cached", **controller),
        elapsed=_time.perf_counter() - start,
    )  # fmt: skip

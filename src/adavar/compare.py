"""DAVAR-Lmin, DAVAR-Lmax, DAVAR-K and A-DAVAR on the same signal: the paper's Table 1 and more.

:func:`compare` runs several window strategies on one record (a fixed window of ``Lmin`` and
of ``Lmax`` samples, the kurtosis-only controller DAVAR-K, the adaptive A-DAVAR, optionally
the oracle schedule), fits the noise model to every window and returns, per method, the
window schedule, ``N(t)``, the node times around every change (docs/method.md section 9), the
interval means ``ARW(a~b)`` and, when the true noise level is known (the paper's simulations,
:func:`adavar.simulate.paper_scenario`), ground-truth metrics of confidence and tracking.
:func:`compare_seeds` repeats this over many realisations of a scenario and sets the node
medians beside the paper's Table 1 (:data:`PAPER_TABLE1_NODES`); :func:`threshold_study` is
the paper's Fig. 8 (where the kurtosis of a fixed window crosses a threshold) and
:func:`kurtosis_study` its Figs. 6-7.

Node times (all are window-centre times, seconds)
-------------------------------------------------
For a fixed window of ``L`` samples, by definition: ``Beginning(X) = X - L tau0 / 2`` (the
window's leading edge reaches the change), ``End(X) = X + L tau0 / 2`` (its trailing edge
leaves it); ``Restore`` does not apply (NaN).

For a window schedule ``L(p)`` (A-DAVAR, DAVAR-K, oracle) the paper's wording ("the first
``p`` where ``L`` drops / starts to increase") is fragile on one realisation: a random false
alarm anywhere before the change would count. The rule used here anchors every node on the
regrowth that follows the change:

1. ``Restore(X)``: the first centre ``p >= X`` with ``L(p) == Lmax``.
2. ``End(X)``: the first centre of the final regrowth run before ``Restore(X)``, its
   lowest point (the last centre before ``L`` grows): walk back from ``Restore(X)`` while
   ``L`` keeps increasing (``L(p - 1) < L(p)``).
3. ``Beginning(X)``: the first centre of the run of ``L < Lmax`` that contains ``End(X)``
   (walk back from ``End(X)`` while ``L(p - 1) < Lmax``), i.e. where ``L`` dropped below
   ``Lmax`` before the change.

If ``L`` is already ``Lmax`` just before ``Restore(X)`` (no shrinking around ``X`` at all, a
missed change) or never returns to ``Lmax`` after ``X``, the three nodes are NaN. A false
alarm whose shrinking has not recovered when the change is sensed merges with it and moves
``Beginning`` earlier; a false alarm during the regrowth restarts the regrowth run and moves
``End`` later: both are what the schedule did, and the spread over seeds shows them. With
this rule, the A-DAVAR medians over 200 seeds of scenario 1 are 2702 / 3172 / 3748 /
4198 s against the paper's 2703 / 3156 / 3740 / 4200 s (``benchmarks/bench_paper.py``).

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
machine, more than the work on 6000 samples. :func:`compare_seeds` also computes each
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
import time as _time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from adavar.adaptive import Schedule, adaptive_schedule
from adavar.davar import davar, edf_table
from adavar.errors import AdavarInputError
from adavar.noise_model import TERM_NAMES, NoiseFit, fit_avar, fit_noise
from adavar.results import DavarResult
from adavar.statistics import as_samples
from adavar.windows import window_overhang

__all__ = [
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
    "KurtosisStudy",
    "MethodRun",
    "Metrics",
    "Nodes",
    "SeedStudy",
    "ThresholdStudy",
    "compare",
    "compare_seeds",
    "default_methods",
    "fixed_nodes",
    "interval_means",
    "kurtosis_study",
    "schedule_nodes",
    "threshold_study",
    "tracking_metrics",
]

#: The paper all the reference values below come from.
PAPER_REFERENCE = (
    "Micromachines 2018, 9(8), 373: 'Random Error Analysis of MEMS Gyroscope Based on an "
    "Improved DAVAR Algorithm'"
)

#: The paper's names of the methods of its tables (its DAVAR-K used K2 = 3.3).
PAPER_LABELS: dict[str, str] = {
    "davar-400": "DAVAR-400", "davar-600": "DAVAR-600", "davar-k": "DAVAR-K-3.3",
    "a-davar": "A-DAVAR",
}  # fmt: skip

#: The node names, in table order.
NODE_NAMES = ("beginning", "end", "restore")

#: Table 1 of the paper (simulation 1), node times in seconds (window centres):
#: method -> {(node, change time): value}. Reproduced by scenario 1 with a std-3 disturbance.
PAPER_TABLE1_NODES: dict[str, dict[tuple[str, float], float]] = {
    "davar-400": {("beginning", 3000.0): 2800.0, ("end", 3000.0): 3200.0,
                  ("beginning", 4000.0): 3800.0, ("end", 4000.0): 4200.0},
    "davar-600": {("beginning", 3000.0): 2702.0, ("end", 3000.0): 3300.0,
                  ("beginning", 4000.0): 3700.0, ("end", 4000.0): 4300.0},
    "a-davar": {("beginning", 3000.0): 2703.0, ("end", 3000.0): 3156.0,
                ("beginning", 4000.0): 3740.0, ("end", 4000.0): 4200.0},
}  # fmt: skip

#: Table 1 of the paper, ARW interval means in 1e-3 deg/sqrt(h): method -> {(a, b): value}.
#: The absolute scale cannot be reproduced from the paper's text (docs/method.md section 9):
#: compare ratios between intervals and methods.
PAPER_TABLE1_ARW: dict[str, dict[tuple[float, float], float]] = {
    "davar-400": {(0.0, 2000.0): 4.03, (3000.0, 4000.0): 10.97},
    "davar-600": {(0.0, 2000.0): 3.87, (3000.0, 4000.0): 10.32},
    "a-davar": {(0.0, 2000.0): 3.83, (3000.0, 4000.0): 9.45},
}

#: Table 3 of the paper: the *measured* gyroscope of its experiment 2 (disturbances at
#: 1000-2000 s and 4000-5000 s), not a simulation; scenario 2 has its shape only.
PAPER_TABLE3_NODES: dict[str, dict[tuple[str, float], float]] = {
    "davar-400": {("beginning", 1000.0): 800.0, ("end", 1000.0): 1200.0,
                  ("beginning", 2000.0): 1800.0, ("end", 2000.0): 2200.0,
                  ("beginning", 4000.0): 3800.0, ("end", 4000.0): 4200.0,
                  ("beginning", 5000.0): 4800.0, ("end", 5000.0): 5200.0},
    "davar-600": {("beginning", 1000.0): 700.0, ("end", 1000.0): 1300.0,
                  ("beginning", 2000.0): 1700.0, ("end", 2000.0): 2300.0,
                  ("beginning", 4000.0): 3700.0, ("end", 4000.0): 4300.0,
                  ("beginning", 5000.0): 4700.0, ("end", 5000.0): 5300.0},
    "davar-k": {("beginning", 1000.0): 738.0, ("end", 1000.0): 1288.0,
                ("restore", 1000.0): 1616.0,
                ("beginning", 2000.0): 1616.0, ("end", 2000.0): 2297.0,
                ("beginning", 4000.0): 3760.0, ("end", 4000.0): 4167.0,
                ("beginning", 5000.0): 4713.0, ("end", 5000.0): 5301.0},
    "a-davar": {("beginning", 1000.0): 738.0, ("end", 1000.0): 1209.0,
                ("restore", 1000.0): 1388.0,
                ("beginning", 2000.0): 1697.0, ("end", 2000.0): 2215.0,
                ("beginning", 4000.0): 3760.0, ("end", 4000.0): 4128.0,
                ("beginning", 5000.0): 4739.0, ("end", 5000.0): 5126.0},
}  # fmt: skip

#: The paper's Fig. 8 (section 4.2): where the kurtosis of a fixed 600-sample window on
#: simulation 1 crosses a threshold: threshold -> {change: (rises above, falls back below)}
#: in seconds. For 3.3 the text gives 3228 s and 3840 s only; the 2700 s rise is the one it
#: gives for the other thresholds (the leading edge meets 3000 s).
PAPER_FIG8_CROSSINGS: dict[float, dict[float, tuple[float, float]]] = {
    4.0: {3000.0: (2700.0, 3115.0), 4000.0: (3963.0, 4300.0)},
    3.45: {3000.0: (2700.0, 3201.0), 4000.0: (3868.0, 4300.0)},
    3.3: {3000.0: (2700.0, 3228.0), 4000.0: (3840.0, math.nan)},
}

#: Records shorter than this run the numba kernels on one thread here (see "Speed").
SMALL_RECORD = 100_000

_MAD_TO_STD = 1.482602218505602  # 1 / Phi^-1(3/4)


# ---------------------------------------------------------------------------------------
# methods


@dataclass(frozen=True)
class _Method:
    name: str
    label: str
    kind: str  # "fixed", "kurtosis", "adaptive", "oracle"
    window: int = 0


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
    if key.startswith("davar-"):
        try:
            length = int(key[6:])
        except ValueError:
            length = 0
        if length >= 3:
            return _Method(f"davar-{length}", f"DAVAR-{length}", "fixed", length)
    raise AdavarInputError(
        f"unknown method {name!r}: use davar-<L> (a fixed window of L >= 3 samples), davar-k, "
        "a-davar or oracle"
    )


# ---------------------------------------------------------------------------------------
# nodes


@dataclass(frozen=True)
class Nodes:
    """The node times of one method around one change (window-centre times, seconds).

    Attributes
    ----------
    change : float
        The change time ``X``.
    beginning : float
        ``Beginning(X)``: the window starts to sense ``X`` (and shrinks).
    end : float
        ``End(X)``: the window has lost ``X`` (and starts to regrow).
    restore : float
        ``Restore(X)``: back at ``Lmax`` (NaN for a fixed window).
    """

    change: float
    beginning: float
    end: float
    restore: float

    def get(self, node: str) -> float:
        """The time of ``node`` (one of :data:`NODE_NAMES`)."""
        if node not in NODE_NAMES:
            raise KeyError(f"unknown node {node!r}: use one of {', '.join(NODE_NAMES)}")
        return float(getattr(self, node))


_NAN_NODE = (math.nan, math.nan, math.nan)


def _change_index(time: np.ndarray, change: float, tau0: float) -> int:
    """Index of the first centre at or after ``change`` (seconds)."""
    return int(np.searchsorted(time, change - 1e-6 * tau0, side="left"))


def schedule_nodes(
    window: Sequence[int] | np.ndarray,
    change_times: Iterable[float],
    *,
    lmax: int,
    rate: float = 1.0,
    time: Sequence[float] | np.ndarray | None = None,
) -> tuple[Nodes, ...]:
    """Node times of a window schedule around each change (the module's rule).

    ``Restore(X)`` is the first centre at or after ``X`` with ``L == lmax``; ``End(X)`` the
    start (lowest point) of the regrowth run that ends there; ``Beginning(X)`` the first
    centre of the run
    of ``L < lmax`` that contains ``End(X)``. NaN for all three when the schedule does not
    shrink around ``X`` or never returns to ``lmax`` after it.

    Parameters
    ----------
    window : array_like of int, shape (T,)
        Window length at each centre.
    change_times : iterable of float
        Change times ``X``, seconds.
    lmax : int
        The longest window of the schedule.
    rate : float
        Sample rate in Hz; the centres are at ``p / rate`` unless ``time`` is given.
    time : array_like, optional
        Time of each centre (increasing), seconds.

    Returns
    -------
    tuple of Nodes
        One per change, in the order given.
    """
    w = np.asarray(window, dtype=np.int64)
    if w.ndim != 1 or w.size == 0:
        raise AdavarInputError("window must be a non-empty 1-D schedule")
    tau0 = 1.0 / float(rate)
    t = np.arange(w.size) * tau0 if time is None else np.asarray(time, dtype=float)
    if t.shape != w.shape:
        raise AdavarInputError(f"time has {t.size} values for {w.size} windows")
    at_max = w == int(lmax)
    out = []
    for change in change_times:
        start = _change_index(t, float(change), tau0)
        hits = np.flatnonzero(at_max[start:])
        if hits.size == 0:
            out.append(Nodes(float(change), *_NAN_NODE))
            continue
        r = start + int(hits[0])
        e = r
        while e > 0 and w[e - 1] < w[e]:
            e -= 1
        if e == r:  # L == lmax just before: no shrinking around X
            out.append(Nodes(float(change), *_NAN_NODE))
            continue
        b = e
        while b > 0 and w[b - 1] < lmax:
            b -= 1
        out.append(Nodes(float(change), float(t[b]), float(t[e]), float(t[r])))
    return tuple(out)


def fixed_nodes(
    change_times: Iterable[float], window: int, *, rate: float = 1.0
) -> tuple[Nodes, ...]:
    """Node times of a fixed window of ``window`` samples: ``X -/+ window tau0 / 2``.

    Parameters
    ----------
    change_times : iterable of float
        Change times, seconds.
    window : int
        Window length, samples.
    rate : float
        Sample rate, Hz.

    Returns
    -------
    tuple of Nodes
        ``restore`` is NaN (a fixed window has nothing to restore).
    """
    half = 0.5 * int(window) / float(rate)
    return tuple(Nodes(float(x), float(x) - half, float(x) + half, math.nan)
                 for x in change_times)  # fmt: skip


# ---------------------------------------------------------------------------------------
# interval means and ground-truth metrics


def interval_means(
    time: Sequence[float] | np.ndarray,
    values: Sequence[float] | np.ndarray,
    intervals: Iterable[tuple[float, float]],
) -> dict[tuple[float, float], float]:
    """``ARW(a~b)``: the mean of ``values`` over the centres with ``a <= time <= b``.

    Parameters
    ----------
    time, values : array_like, shape (T,)
        Centre times (s) and the per-window values (e.g. ``N(t)``); NaN values are skipped.
    intervals : iterable of (float, float)
        ``(a, b)`` in seconds.

    Returns
    -------
    dict
        ``(a, b) -> mean`` (NaN when no finite value lies in the interval).
    """
    t = np.asarray(time, dtype=float)
    v = np.asarray(values, dtype=float)
    out = {}
    for a, b in intervals:
        sel = (t >= a) & (t <= b) & np.isfinite(v)
        out[(float(a), float(b))] = float(v[sel].mean()) if sel.any() else math.nan
    return out


@dataclass(frozen=True)
class ChangeMetrics:
    """How one method's ``N(t)`` follows one change of the true level.

    Attributes
    ----------
    change : float
        Change time ``X``, seconds.
    before, after : float
        True ``N`` just before and at ``X``.
    error : float
        Mean of ``|N - N_true| / N_true`` over the centres within ``span`` of ``X``.
    delay : float
        First centre at which ``N`` is past the midpoint of the two levels (in the
        direction of the change), minus ``X``, seconds (negative: ahead of the change).
    rise : float
        Seconds from 10 % of the step to 90 %: from the centre after the last one short of
        10 % (before the first passage of 90 %) to the first passage of 90 %.
    span : float
        Half-width of the evaluation window, seconds (``Lmax tau0``).
    """

    change: float
    before: float
    after: float
    error: float
    delay: float
    rise: float
    span: float


@dataclass(frozen=True)
class Metrics:
    """Ground-truth confidence and tracking metrics of one method (see the module notes).

    Attributes
    ----------
    bias, std, mad : float
        Mean, standard deviation and robust spread (1.4826 x MAD) of ``N / N_true - 1``
        over the stationary centres.
    n_stationary : int
        Number of those centres.
    changes : tuple of ChangeMetrics
        One per change.
    """

    bias: float
    std: float
    mad: float
    n_stationary: int
    changes: tuple[ChangeMetrics, ...]

    @property
    def error(self) -> float:
        """Mean tracking error over the changes."""
        return float(np.mean([c.error for c in self.changes])) if self.changes else math.nan

    @property
    def abs_delay(self) -> float:
        """Mean ``|delay|`` over the changes, seconds."""
        return float(np.mean([abs(c.delay) for c in self.changes])) if self.changes else math.nan

    @property
    def rise(self) -> float:
        """Mean 10-90 % rise time over the changes, seconds."""
        return float(np.mean([c.rise for c in self.changes])) if self.changes else math.nan


def _first_past(values: np.ndarray, level: float, direction: float) -> int:
    hits = np.flatnonzero(direction * (values - level) > 0)
    return int(hits[0]) if hits.size else -1


def tracking_metrics(
    time: Sequence[float] | np.ndarray,
    arw: Sequence[float] | np.ndarray,
    truth: Sequence[float] | np.ndarray,
    change_times: Sequence[float],
    *,
    margin: float,
    span: float,
) -> Metrics:
    """Confidence and tracking of ``N(t)`` against the true ``N`` (module notes).

    Parameters
    ----------
    time : array_like, shape (T,)
        Centre times, seconds (increasing).
    arw : array_like, shape (T,)
        The estimate ``N(t)`` of every window.
    truth : array_like, shape (T,)
        The true ``N`` at every centre (positive).
    change_times : sequence of float
        Times at which the true level changes, seconds.
    margin : float
        Centres farther than ``margin`` seconds from every change are stationary
        (``Lmax tau0 / 2``: no window holds a change).
    span : float
        Half-width of the tracking evaluation around each change, seconds (``Lmax tau0``).

    Returns
    -------
    Metrics
    """
    t = np.asarray(time, dtype=float)
    n = np.asarray(arw, dtype=float)
    true = np.asarray(truth, dtype=float)
    if not (t.shape == n.shape == true.shape):
        raise AdavarInputError("time, arw and truth must have the same length")
    if not np.all(true > 0):
        raise AdavarInputError("the true N must be positive everywhere")
    rel = n / true - 1.0
    stationary = np.ones(t.size, dtype=bool)
    for x in change_times:
        stationary &= np.abs(t - x) > margin
    r = rel[stationary & np.isfinite(rel)]
    if r.size:
        bias, std = float(r.mean()), float(r.std(ddof=1)) if r.size > 1 else math.nan
        mad = float(_MAD_TO_STD * np.median(np.abs(r - np.median(r))))
    else:
        bias = std = mad = math.nan
    tau0 = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    changes = []
    for x in change_times:
        i = _change_index(t, float(x), tau0)
        before = float(true[max(i - 1, 0)])
        after = float(true[min(i, t.size - 1)])
        sel = np.abs(t - x) <= span
        ts, ns, tr = t[sel], n[sel], true[sel]
        error = float(np.nanmean(np.abs(ns - tr) / tr)) if ts.size else math.nan
        step = after - before
        direction = math.copysign(1.0, step) if step != 0 else 0.0
        delay = rise = math.nan
        if direction != 0.0 and ts.size:
            k = _first_past(ns, before + 0.5 * step, direction)
            if k >= 0:
                delay = float(ts[k] - x)
            k90 = _first_past(ns, before + 0.9 * step, direction)
            if k90 >= 0:
                # the start of the final passage: after the last centre before k90 still
                # short of 10 % (robust to noise excursions ahead of the change)
                short = np.flatnonzero(direction * (ns[:k90] - (before + 0.1 * step)) <= 0)
                if short.size:
                    rise = float(ts[k90] - ts[short[-1] + 1])
        changes.append(ChangeMetrics(float(x), before, after, error, delay, rise, float(span)))
    return Metrics(bias, std, mad, int(r.size), tuple(changes))


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
        Window length at every centre.
    schedule : Schedule or None
        The controller's record (kurtosis, S, f1, f2, f); None for a fixed window.
    result : DavarResult
        The DAVAR surface on ``window``.
    fit : NoiseFit
        The noise model fitted to every window.
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
    data : ndarray, shape (N,)
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
        return _paper_nodes(self.scenario)

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
        return _clean({
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


def _paper_nodes(scenario: int | None) -> dict[str, dict[tuple[str, float], float]]:
    if scenario == 1:
        return PAPER_TABLE1_NODES
    if scenario == 2:
        return PAPER_TABLE3_NODES
    return {}


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


def _clean(obj: Any) -> Any:
    """Plain Python for JSON: numpy scalars and arrays converted, NaN/inf as None."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _clean(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    return obj


@contextlib.contextmanager
def _threads_for(n_samples: int) -> Iterator[None]:
    """One numba thread for small records (parallel launch costs more than the work)."""
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


class _EdfCache:
    """EDF rows per (window length, taus, alpha), computed once (white-noise fast path)."""

    def __init__(self) -> None:
        self._rows: dict[tuple[int, tuple[int, ...], tuple[int, ...]], np.ndarray] = {}

    def cells(self, result: DavarResult, alpha: np.ndarray) -> np.ndarray:
        ms = tuple(int(m) for m in result.m)
        al = tuple(int(a) for a in alpha)
        # a window reaching into the mirrored ends has fewer distinct terms (as in davar)
        n = result.n_samples - (1 if result.data_type == "phase" else 0)
        overhang = (
            window_overhang(result.centre, result.window, n)
            if result.edges == "mirror"
            else np.zeros(np.size(result.window), dtype=np.int64)
        )
        keys, inverse = np.unique(
            np.stack([np.asarray(result.window), overhang], axis=1), axis=0, return_inverse=True
        )
        missing = [(int(L), int(h)) for L, h in keys if (int(L), int(h), ms, al) not in self._rows]
        if missing:
            table = edf_table(
                np.array([L for L, _ in missing]), np.asarray(ms), np.asarray(al),
                overhang=np.array([h for _, h in missing]),
            )  # fmt: skip
            for (L, h), row in zip(missing, table, strict=True):
                self._rows[(L, h, ms, al)] = row
        rows = np.stack([self._rows[(int(L), int(h), ms, al)] for L, h in keys])
        return rows[inverse.ravel()]


def _as_record(data: Any) -> tuple[np.ndarray, dict[str, Any]]:
    """Samples and what a scenario object knows (rate, changes, truth, intervals, ...)."""
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
    return as_samples(data, min_length=3), known


def _check_rate(rate: Any) -> float:
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
    lmax: int = 600,
    lmin: int = 400,
    k1: float = 2.5,
    k2: float = 3.3,
    s1: float = 0.0,
    s2: float = 0.07,
    l: int = 100,  # noqa: E741 - the paper's name
    dl0: int = 2,
    dl1: int = 2,
    s_test: str = "upper",
    combine: str = "or",
    thresholds: str = "paper",
    false_alarm: float = 0.01,
    taus: str | Sequence[float] = "all",
    terms: Sequence[str] = TERM_NAMES,
    confidence: float = 0.683,
    noise_type: str | int | Sequence[int] = "record",
    points_per_decade: int = 10,
    units: str | None = None,
    description: str | None = None,
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
        controller, ``f = f1``), ``"a-davar"`` (the adaptive controller) and ``"oracle"``
        (the ideal schedule; needs ``change_times``). Default
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

    Returns
    -------
    Comparison

    Raises
    ------
    AdavarInputError
        Bad data, an unknown method, ``"oracle"`` without change times, a truth of the
        wrong length, or bad controller settings.
    """
    return _compare(
        data, methods=methods, rate=rate, change_times=change_times, truth=truth,
        intervals=intervals, controller=dict(
            lmax=lmax, lmin=lmin, k1=k1, k2=k2, s1=s1, s2=s2, l=l, dl0=dl0, dl1=dl1,
            s_test=s_test, combine=combine, thresholds=thresholds, false_alarm=false_alarm,
        ), taus=taus, terms=terms, confidence=confidence, noise_type=noise_type,
        points_per_decade=points_per_decade, units=units, description=description,
        edf_cache=None,
    )  # fmt: skip


def _compare(
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
    edf_cache: _EdfCache | None,
) -> Comparison:
    x, known = _as_record(data)
    n = x.size
    fs = _check_rate(rate if rate is not None else known.get("rate", 1.0))
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
                f"{s.label}: a window of {s.window} samples is longer than the record ({n})"
            )

    runs: dict[str, MethodRun] = {}
    with _threads_for(n):
        for spec in specs:
            sched = None
            if spec.kind == "fixed":
                window: Any = spec.window
            else:
                sched = adaptive_schedule(
                    x, method=spec.kind, rate=fs,
                    change_times=changes if spec.kind == "oracle" else None, **controller,
                )  # fmt: skip
                window = sched.window
            if edf_cache is None:
                result = davar(
                    x, window=window, rate=fs, taus=taus, confidence=confidence,
                    noise_type=noise_type, points_per_decade=points_per_decade, units=units,
                )  # fmt: skip
                try:
                    fit = fit_noise(result, terms=terms)
                except ValueError as exc:
                    raise AdavarInputError(str(exc)) from None
            else:
                result = davar(x, window=window, rate=fs, taus=taus, confidence=None,
                               points_per_decade=points_per_decade, units=units)  # fmt: skip
                alpha = np.broadcast_to(np.asarray(noise_type, dtype=np.int64), result.m.shape)
                fit = fit_avar(result.tau, result.avar, edf_cache.cells(result, alpha),
                               terms=terms)  # fmt: skip
            arw = np.asarray(fit.angle_random_walk.value, dtype=float)
            t = np.asarray(result.time, dtype=float)
            w = np.asarray(result.window, dtype=np.int64)
            if spec.kind == "fixed":
                nodes = fixed_nodes(changes, spec.window, rate=fs)
            else:
                nodes = schedule_nodes(w, changes, lmax=lmax, rate=fs, time=t)
            metrics = None
            if true is not None:
                metrics = tracking_metrics(
                    t, arw, true[result.centre], changes, margin=0.5 * lmax * tau0,
                    span=lmax * tau0,
                )  # fmt: skip
            runs[spec.name] = MethodRun(
                name=spec.name, label=spec.label, window=w, schedule=sched, result=result,
                fit=fit, arw=arw, nodes=nodes, intervals=interval_means(t, arw, ivals),
                metrics=metrics,
            )  # fmt: skip
    first = next(iter(runs.values()))
    parameters = dict(
        methods=names, rate=fs, taus=taus if isinstance(taus, str) else list(map(float, taus)),
        terms=list(terms), confidence=confidence, noise_type=noise_type,
        **{k: v for k, v in controller.items()},
    )  # fmt: skip
    return Comparison(
        time=np.asarray(first.result.time, dtype=float),
        data=x,
        rate=fs,
        methods=runs,
        change_times=changes,
        truth=None if true is None else true[first.result.centre],
        intervals=ivals,
        parameters=parameters,
        description=description or known.get("description") or f"{n} samples at {fs:g} Hz",
        scenario=known.get("scenario"),
        units=units,
    )


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
    windows: Sequence[int] = (11, 201, 601),
    segment: int = 11,
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
    from adavar.kurtosis import kurtosis_contribution, sliding_kurtosis

    x, known = _as_record(data)
    fs = _check_rate(known.get("rate", rate))
    changes = tuple(change_times) or known.get("change_times", ())
    with _threads_for(x.size):
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
    thresholds: Sequence[float] = (3.3, 3.45, 4.0),
    rate: float | None = None,
    std: Sequence[float] | np.ndarray | None = None,
) -> ThresholdStudy:
    """Crossing times of a fixed window's kurtosis (the paper's Fig. 8).

    For each change ``X``, the kurtosis of the fixed window peaks while the window holds a
    little of the other level; the run of centres above a threshold ``K2`` around that peak
    starts when a kurtosis controller would start shrinking and ends when it would regrow.
    On scenario 1 the paper reads 2700 s and 3228 s for ``K2 = 3.3`` (the first run) and
    3840 s for the second (:data:`PAPER_FIG8_CROSSINGS`).

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
    from adavar.kurtosis import sliding_kurtosis

    x, known = _as_record(data)
    fs = _check_rate(rate if rate is not None else known.get("rate", 1.0))
    changes = tuple(float(c) for c in (change_times if change_times is not None
                                        else known.get("change_times", ())))  # fmt: skip
    if not changes:
        raise AdavarInputError("threshold_study needs the change times")
    if std is None and "truth" in known:
        std = known["truth"] * math.sqrt(fs)
    window = int(window)
    if not 3 <= window <= x.size:
        raise AdavarInputError(f"window must lie in 3 .. {x.size} samples, got {window}")
    with _threads_for(x.size):
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
    """:func:`compare` over many realisations of a paper scenario.

    Attributes
    ----------
    scenario : int
        1 or 2.
    variance_reading : bool
        The disturbance's reading (see :func:`adavar.simulate.paper_scenario`).
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
        return _paper_nodes(self.scenario)

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
                         "values": {m: _median(self.confidence[m][:, k])
                                    for m in self.methods}})  # fmt: skip
        for j, change in enumerate(self.change_times):
            for k, (name, unit) in enumerate((("error", "1"), ("delay", "s"), ("rise", "s"))):
                rows.append({"metric": name, "change": change, "unit": unit,
                             "values": {m: _median(self.tracking[m][:, j, k])
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
        paper = PAPER_TABLE1_ARW if self.scenario == 1 else {}
        return [
            {"interval": iv, "values": {m: _median(self.arw[m][:, j]) for m in self.methods},
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
            paper = PAPER_FIG8_CROSSINGS.get(th, {}) if self.scenario == 1 else {}
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
        return _clean({
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


def _median(values: np.ndarray) -> float:
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
    crossing_thresholds: Sequence[float] = (3.3, 3.45, 4.0),
    lmax: int = 600,
    lmin: int = 400,
    k1: float = 2.5,
    k2: float = 3.3,
    s1: float = 0.0,
    s2: float = 0.07,
    l: int = 100,  # noqa: E741 - the paper's name
    dl0: int = 2,
    dl1: int = 2,
    s_test: str = "upper",
    combine: str = "or",
    thresholds: str = "paper",
    false_alarm: float = 0.01,
    progress: Callable[[int, int], None] | None = None,
) -> SeedStudy:
    """:func:`compare` on many realisations of a paper scenario, and the Fig. 8 crossings.

    Per seed: the scenario (:func:`adavar.simulate.paper_scenario`), every method's
    schedule, surface and ``N(t)``, its nodes, ``ARW(a~b)`` and ground-truth metrics, and
    the crossings of the fixed window's kurtosis (:func:`threshold_study`). See the module
    notes ("Speed") for what is done differently from :func:`compare` to keep 100 seeds
    within seconds: one numba thread, surfaces without bounds, EDFs for white noise
    computed once, octave taus by default. ``thresholds="calibrated"`` is much slower
    (about 1 s per adaptive method and seed): :func:`adavar.adaptive.adaptive_schedule`
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
        As in :func:`compare`.
    taus : str or sequence of float
        Taus of the surfaces (``"octave"`` by default).
    terms : sequence of str
        Terms of the noise fit.
    crossing_window : int, optional
        Fixed window of the Fig. 8 study (default ``lmax``).
    crossing_thresholds : sequence of float
        Its thresholds.
    lmax, lmin, k1, k2, s1, s2, l, dl0, dl1, s_test, combine, thresholds, false_alarm
        Controller settings, as in :func:`compare`.

    progress : callable, optional
        Called as ``progress(done, total)`` before each realisation (the command line draws
        a progress bar with it).

    Returns
    -------
    SeedStudy
    """
    from adavar.simulate import paper_scenario

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
    cache = _EdfCache()
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
        comp = _compare(
            sc, methods=methods, rate=None, change_times=None, truth=None, intervals=None,
            controller=controller, taus=taus, terms=terms, confidence=0.683, noise_type=0,
            points_per_decade=10, units=None, description=None, edf_cache=cache,
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

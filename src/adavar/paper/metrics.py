"""How well a method's ``N(t)`` follows the truth: interval means and ground-truth metrics.

The tables of :func:`adavar.compare` (:mod:`adavar.comparison` describes the metrics):
:func:`interval_means` (``ARW(a~b)``, the paper's Table 1) and :func:`tracking_metrics`
(confidence over the stationary centres, tracking around each change).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.paper.nodes import change_index

__all__ = ["ChangeMetrics", "Metrics", "interval_means", "tracking_metrics"]

_MAD_TO_STD = 1.482602218505602  # 1 / Phi^-1(3/4)


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
        i = change_index(t, float(x), tau0)
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

"""The node times of a window around a change: the paper's Beginning, End and Restore.

:func:`fixed_nodes` gives them for a fixed window, :func:`schedule_nodes` for a window
schedule (A-DAVAR, DAVAR-K, the oracle); :func:`adavar.comparison.compare` applies them to
every method and :mod:`adavar.paper.reference` holds the paper's values
(docs/method.md section 9).

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
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from adavar.core.errors import AdavarInputError

__all__ = [
    "NODE_NAMES",
    "NODE_TITLES",
    "Nodes",
    "change_index",
    "fixed_nodes",
    "schedule_nodes",
]

#: The node names, in table order.
NODE_NAMES = ("beginning", "end", "restore")

#: The node names as table headings.
NODE_TITLES = {"beginning": "Beginning", "end": "End", "restore": "Restore"}


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


def change_index(time: np.ndarray, change: float, tau0: float) -> int:
    """Index of the first centre at or after ``change`` (seconds).

    Parameters
    ----------
    time : ndarray
        Increasing centre times, seconds.
    change : float
        The change time, seconds.
    tau0 : float
        Sample interval, seconds (the tolerance is ``1e-6 tau0``).

    Returns
    -------
    int
    """
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
        start = change_index(t, float(change), tau0)
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

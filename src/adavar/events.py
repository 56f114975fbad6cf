"""Non-stationary stretches of a record, read off the adaptive window.

The controller shrinks its window when a change in the noise enters the window's leading
edge, and while it shrinks by ``dL1 = 2`` a step with the centre moving one sample, the
leading edge stays pinned on the change (docs/method.md section 8). So each episode of
shortened windows marks one change, at the leading edge of the last full window before the
first shrink: ``centre + Lmax // 2`` (episodes less than ``Lmax / 4`` apart are one change:
the window regrew a step and shrank again). A stretch of different noise is bounded by two
changes (into it and out of it): consecutive changes are paired, the first with the second,
the third with the fourth, ...; an unpaired last change opens a stretch that lasts to the
end of the record (``end_s`` None).

For each stretch the noise coefficient ``N(t)`` (or any term) of the windows wholly before,
inside and after it (window centres farther than ``Lmax / 2`` from either change) is given
by its median and its 16-84 % range over those windows.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Event", "change_times", "find_events", "flag_change_times", "stretch_summary"]


@dataclass(frozen=True)
class Event:
    """One non-stationary stretch.

    Attributes
    ----------
    start_s, end_s : float or None
        Estimated times of the changes into and out of the stretch (s); ``end_s`` None if
        the record ends inside it.
    before, during, after : dict
        For each fitted term: ``{"median", "low", "high", "windows"}`` over the windows
        wholly before, inside and after the stretch (``low``/``high`` the 16 and 84 %
        points; None where no window qualifies).
    """

    start_s: float
    end_s: float | None
    before: dict[str, Any]
    during: dict[str, Any]
    after: dict[str, Any]

    def as_dict(self) -> dict[str, Any]:
        """The JSON form: ``start_s``, ``end_s``, ``before``, ``during``, ``after``."""
        return {"start_s": self.start_s, "end_s": self.end_s, "before": self.before,
                "during": self.during, "after": self.after}  # fmt: skip


def change_times(window: Any, centre: Any, lmax: int, tau0: float, t0: float = 0.0) -> list[float]:
    """Times (s) of the changes the adaptive window detected, one per shrink episode.

    Parameters
    ----------
    window, centre : array_like of int
        The window length at each kept centre, and the centres (samples).
    lmax : int
        The controller's longest window.
    tau0 : float
        Sample interval (s).
    t0 : float
        Time of the first sample.

    Returns
    -------
    list of float
        ``t0 + (centre + lmax // 2) * tau0`` at the last full window before each episode.
    """
    window = np.asarray(window, dtype=np.int64)
    centre = np.asarray(centre, dtype=np.int64)
    short = np.concatenate(([0], (window < lmax).astype(np.int8), [0]))
    starts = np.flatnonzero(np.diff(short) == 1)
    out = []
    for a in starts:
        # the last centre with the full window (or, at the very start, the first shrunk one)
        c = centre[a - 1] if a > 0 else centre[a]
        out.append(float(t0 + (c + lmax // 2) * tau0))
    return out


def flag_change_times(
    flags: Any, centre: Any, length: int, tau0: float, t0: float = 0.0
) -> list[float]:
    """Times (s) of the changes the controller's test flags in a *fixed* window.

    A change is flagged while it lies inside the ``length``-sample window, first when it
    enters the leading edge, so each run of flagged centres (runs less than ``length``
    apart are one: the test fires on and off while the change crosses the window) marks one
    change at the leading edge of its first flagged window, ``centre + length // 2``.
    """
    flags = np.asarray(flags, dtype=bool)
    centre = np.asarray(centre, dtype=np.int64)
    edges = np.diff(np.concatenate(([0], flags.astype(np.int8), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    out: list[float] = []
    last = None
    for a, b in zip(starts, stops, strict=True):
        if last is None or centre[a] - centre[last] >= length:
            out.append(float(t0 + (centre[a] + length // 2) * tau0))
        last = b
    return out


def stretch_summary(values: np.ndarray) -> dict[str, Any]:
    """``{"median", "low", "high", "windows"}`` of a term's finite values over a stretch.

    ``low`` and ``high`` are the 16 and 84 % points; all None (and ``windows`` 0) when no
    value is finite. The summaries of :class:`Event` (and of :class:`adavar.OnlineAdaptive`).
    """
    values = values[np.isfinite(values)]
    if values.size == 0:
        return {"median": None, "low": None, "high": None, "windows": 0}
    low, median, high = np.percentile(values, [16, 50, 84])
    return {"median": float(median), "low": float(low), "high": float(high),
            "windows": int(values.size)}  # fmt: skip


def find_events(
    window: Any,
    centre: Any,
    time: Any,
    lmax: int,
    tau0: float,
    coefficients: dict[str, Any],
    *,
    t0: float = 0.0,
    duration: float | None = None,
    changes: Any = None,
) -> list[Event]:
    """The non-stationary stretches of a record (see the module docstring).

    Parameters
    ----------
    window, centre, time : array_like
        Window length, centre (samples) and time (s) of each kept window.
    lmax : int
        The controller's longest window (samples).
    tau0 : float
        Sample interval (s).
    coefficients : dict of str to array_like
        Term name -> its value at each window (``fit.angle_random_walk.value``, ...): an
        array, or any object whose slices ``values[start:stop]`` give those windows'
        values (:meth:`adavar.surface_fit.BlockFit.term_reader`, which reads them from
        disk); only the windows of the stretches are read.
    t0 : float
        Time of the first sample.
    duration : float, optional
        Length of the record (s), for the last stretch; default the last window's time.
    changes : sequence of float, optional
        The change times, if known otherwise (a fixed window's :func:`flag_change_times`);
        default :func:`change_times` of the adaptive window.

    Returns
    -------
    list of Event
    """
    time = np.asarray(time, dtype=float)
    found = change_times(window, centre, lmax, tau0, t0) if changes is None else changes
    changes = []
    for c in found:
        # a window that regrows a step and shrinks again saw the same change
        if not changes or c - changes[-1] > 0.25 * lmax * tau0:
            changes.append(c)
    end_of_record = float(duration if duration is not None else time[-1])
    margin = 0.5 * lmax * tau0
    # the windows are in time order: each stretch is a range of them, read alone
    ordered = bool(np.all(np.diff(time) >= 0))

    def summaries(low: float, high: float) -> dict[str, Any]:
        """Each term's summary over the windows with ``low < time < high``."""
        if ordered:
            start = int(np.searchsorted(time, low, side="right"))
            stop = max(start, int(np.searchsorted(time, high, side="left")))
            return {name: stretch_summary(np.asarray(v[start:stop], dtype=float))
                    for name, v in coefficients.items()}  # fmt: skip
        inside = (time > low) & (time < high)
        return {name: stretch_summary(np.asarray(v[:], dtype=float)[inside])
                for name, v in coefficients.items()}  # fmt: skip

    events = []
    for k in range(0, len(changes), 2):
        start = changes[k]
        end = changes[k + 1] if k + 1 < len(changes) else None
        previous = changes[k - 1] if k > 0 else -np.inf
        following = changes[k + 2] if k + 2 < len(changes) else np.inf
        stop = end if end is not None else end_of_record
        events.append(Event(
            start_s=start, end_s=end,
            before=summaries(previous + margin, start - margin),
            during=summaries(start + margin, stop - margin),
            # a stretch open at the end of the record has no windows after it
            after=summaries(stop + margin, following - margin) if end is not None
            else summaries(np.inf, -np.inf),
        ))  # fmt: skip
    return events

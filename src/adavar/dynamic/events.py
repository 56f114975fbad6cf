"""Non-stationary stretches of a record, read off the adaptive window.

Episodes. The controller shrinks its window when a change in the noise enters the window's
leading edge; while it shrinks by ``dL1 = 2`` a step with the centre moving one sample,
the leading edge stays pinned on the change, and while it regrows by ``dL0 = 2`` its
trailing edge stays pinned on where the disturbance ended (docs/method.md section 8). So
each episode of shortened windows (a run of windows shorter than Lmax; runs whose leads
are less than ``Lmax / 4`` apart, or with no whole window between them, are one) gives
two times: its *lead*, the leading edge of the last full window before the first shrink
(``centre + Lmax // 2``), and its *trail*, the trailing edge at the start of its last
regrowth (``centre - (L - 1) // 2``; None when the record ends inside the episode). A
step up of the noise is found as soon as it enters the window: its lead is the change,
its trail comes early. A step down is found late, when the quieter samples fill a good
part of the window: its trail is the change. A spike or a burst shorter than the window
spans lead to trail.

Pairing by level. Each episode is classified by the noise level (``N``, the
``angle_random_walk`` term by default) of the whole windows on either side of it (centres
farther than ``Lmax / 2`` from the episode, at most :data:`LEVEL_SPAN` Lmax of them, and
none past the neighbouring episodes): *up* or *down* when the medians differ by more than
a factor :data:`LEVEL_RATIO` (or by more than their windows' own 16-84 % spread), else
*no change of level*. Then, in time order:

* an episode with no change of level (a spike, a burst) is an event of its own, from its
  lead to its trail (``start_s <= end_s``, a few seconds apart for a spike);
* an up (or down) episode opens a stretch at its change time (the lead of an up, the
  trail of a down); the stretch closes at the first episode of the other sign that brings
  the level back at least halfway (in log) to the level before the stretch, and lasts to
  the end of the record (``end_s`` None) if none does; episodes inside an open stretch
  (a spike in it, a second step) belong to it.

So an outlier never flips the stretches after it: one spike is one short event. Without
the level term (no fit, or ``N`` not fitted) every episode is an event of its own.
``pairing="parity"`` gives the rule before 0.2: consecutive change times (the leads)
paired, the first with the second, the third with the fourth, ...

For each event the noise coefficient ``N(t)`` (or any term) of the windows wholly before,
inside and after it (window centres farther than ``Lmax / 2`` from its start and end, and
from the neighbouring episodes) is given by its median and its 16-84 % range over those
windows. :class:`EventTracker` does the pairing as the windows come (for
:class:`adavar.OnlineAdaptive`); :func:`find_events` runs it over a whole record, so the
two give the same events.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from adavar.core.errors import AdavarInputError

__all__ = [
    "LEVEL_RATIO",
    "LEVEL_SPAN",
    "PAIRINGS",
    "Event",
    "EventTracker",
    "change_episodes",
    "change_times",
    "comes_back",
    "find_events",
    "flag_change_times",
    "flag_runs",
    "join_runs",
    "run_change_times",
    "stretch_summary",
]

#: ratio of the noise levels on the two sides of an episode below which it changes no level
LEVEL_RATIO = 1.2
#: the windows that measure the level on each side of an episode span at most this many Lmax
LEVEL_SPAN = 2.0
#: name of a level given per window to find_events (not a term)
_LEVEL = " level"
#: ``pairing=``: episodes classified by the noise level on each side (default), or the leads
#: paired in turn (before 0.2)
PAIRINGS = ("level", "parity")


@dataclass(frozen=True)
class Event:
    """One non-stationary stretch.

    Attributes
    ----------
    start_s, end_s : float or None
        Estimated times of the changes into and out of the stretch (s); ``end_s`` None if
        the record ends inside it. For an episode with no change of level (a spike, a
        burst), its lead and trail (``start_s <= end_s``; module notes).
    before, during, after : dict
        For each fitted term: ``{"median", "low", "high", "windows"}`` over the windows
        wholly before, inside and after the stretch (``low``/``high`` the 16 and 84 %
        points; None where no window qualifies).
    ramp : bool
        True for a gradual change (the noise level drifts from ``start_s`` to ``end_s``
        rather than stepping at each); for the ICI window's stretches, True when the change
        into or out of it is gradual (:mod:`adavar.dynamic.ici_events`).
    tau_s : float or None
        The averaging time (s) at which the change was seen when it is a change of a
        long-tau term (rate random walk, bias instability) found at a longer tau than the
        controller's; None for the controller's own (shortest-tau) detection.
    """

    start_s: float
    end_s: float | None
    before: dict[str, Any]
    during: dict[str, Any]
    after: dict[str, Any]
    ramp: bool = False
    tau_s: float | None = None

    def as_dict(self) -> dict[str, Any]:
        """The JSON form: ``start_s``, ``end_s``, ``before``, ``during``, ``after``,
        ``ramp``, ``tau_s``."""
        return {"start_s": self.start_s, "end_s": self.end_s, "before": self.before,
                "during": self.during, "after": self.after, "ramp": self.ramp,
                "tau_s": self.tau_s}  # fmt: skip


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


def flag_runs(flags: Any, first: int = 0) -> np.ndarray:
    """``(first, last)`` index of every run of True in ``flags``, shape (R, 2) int64.

    ``first`` is added to both (the index of ``flags[0]``: the centre of the first flag).
    Runs of consecutive pieces join with :func:`join_runs`.
    """
    edges = np.diff(np.concatenate(([0], np.asarray(flags, dtype=np.int8), [0])))
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1) - 1
    return np.stack([starts, stops], axis=1).astype(np.int64) + int(first)


def join_runs(runs: list[np.ndarray]) -> np.ndarray:
    """The runs of consecutive pieces' :func:`flag_runs` as one array: a run that ends on
    a piece's last centre and one that starts on the next piece's first are one run."""
    parts = [r for r in runs if r.size]
    if not parts:
        return np.empty((0, 2), dtype=np.int64)
    out = np.concatenate(parts)
    joined = np.flatnonzero(out[1:, 0] == out[:-1, 1] + 1)  # a run continued
    if joined.size:
        keep = np.ones(len(out), dtype=bool)
        keep[joined + 1] = False
        # each kept run ends where the last run of its chain ends
        chain_end = np.flatnonzero(np.append(keep[1:], True))
        out = np.stack([out[keep, 0], out[chain_end, 1]], axis=1)
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
    centre = np.asarray(centre, dtype=np.int64)
    runs = flag_runs(flags)
    return run_change_times(centre[runs] if runs.size else runs, length, tau0, t0)


def run_change_times(runs: np.ndarray, length: int, tau0: float, t0: float = 0.0) -> list[float]:
    """:func:`flag_change_times` from the runs' ``(first, last)`` centres (sample indices,
    ``Schedule.flag_runs()``): no per-centre arrays needed."""
    out: list[float] = []
    last = None
    for a, b in np.asarray(runs, dtype=np.int64).reshape(-1, 2).tolist():
        if last is None or a - last >= length:
            out.append(float(t0 + (a + length // 2) * tau0))
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


def change_episodes(
    window: Any, centre: Any, lmax: int, tau0: float, t0: float = 0.0
) -> list[tuple[float, float | None]]:
    """``(lead, trail)`` of every run of windows shorter than ``lmax`` (module notes).

    Parameters
    ----------
    window, centre : array_like of int
        The window length at each kept centre, and the centres (samples), in time order.
    lmax : int
        The controller's longest window.
    tau0 : float
        Sample interval (s).
    t0 : float
        Time of the first sample.

    Returns
    -------
    list of (float, float or None)
        The lead, ``t0 + (centre + lmax // 2) tau0`` at the last full window before the
        run, and the trail, ``t0 + (centre - (L - 1) // 2) tau0`` at the first window of the
        run's last regrowth (None for a run that lasts to the last window). Runs are not
        merged here (:class:`EventTracker` does).
    """
    window = np.asarray(window, dtype=np.int64)
    centre = np.asarray(centre, dtype=np.int64)
    edges = np.diff(np.concatenate(([0], (window < lmax).astype(np.int8), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    out: list[tuple[float, float | None]] = []
    for a, b in zip(starts.tolist(), stops.tolist(), strict=True):
        # the last centre with the full window (or, at the very start, the first shrunk one)
        c = centre[a - 1] if a > 0 else centre[a]
        trail = None
        if b < window.size - 1:
            e = _regrowth_start(window, b, a)
            trail = float(t0 + (centre[e] - (window[e] - 1) // 2) * tau0)
        out.append((float(t0 + (c + lmax // 2) * tau0), trail))
    return out


def _regrowth_start(window: np.ndarray, last: int, first: int) -> int:
    """First index ``>= first`` of the strictly increasing run of lengths that ends at
    ``last``: where the window's trailing edge was pinned on the end of the disturbance."""
    e = last
    while e > first and window[e - 1] < window[e]:
        e -= 1
    return e


def _level_kind(before: dict | None, after: dict | None) -> int | None:
    """+1 (up), -1 (down), 0 (no change of level) from two level summaries; None if a side
    has no window."""
    if not before or not after:
        return None
    b, a = before["median"], after["median"]
    if b is None or a is None or not (b > 0.0 and a > 0.0):
        return None
    tol = max(math.log(LEVEL_RATIO), math.hypot(_log_spread(before), _log_spread(after)))
    ratio = math.log(a / b)
    return 0 if abs(ratio) < tol else (1 if ratio > 0 else -1)


def comes_back(base: float, before: float, after: float, spread: float = 0.0) -> bool:
    """Whether a change from the noise level ``before`` to ``after`` brings it at least
    halfway back (in log) to ``base``, the level before the stretch, or within
    :data:`LEVEL_RATIO` (or ``spread``, in log) of it: the change that closes a stretch
    (amplitudes, all positive)."""
    tol = max(math.log(LEVEL_RATIO), spread)
    away = abs(math.log(after / base))
    return away < max(tol, 0.5 * abs(math.log(before / base)))


def _log_spread(summary: dict) -> float:
    """Half the 16-84 % range of a level summary, in log: one window's own scatter."""
    low, high = summary["low"], summary["high"]
    return 0.5 * math.log(high / low) if low and high and low > 0.0 and high > 0.0 else 0.0


class _Episode:
    """A (possibly merged) run of shortened windows: the lead of its first run, the trail
    of its last, whether that has ended, and the earliest and latest of its leads and
    trails (``lo``, ``hi``: the whole windows before and after it lie beyond them)."""

    __slots__ = ("ended", "hi", "lead", "lo", "trail")

    def __init__(self, lead: float) -> None:
        self.lead = self.lo = self.hi = lead
        self.trail: float | None = None
        self.ended = False

    def close(self, trail: float) -> None:
        self.trail, self.ended = trail, True
        self.lo, self.hi = min(self.lo, trail), max(self.hi, trail)

    def clip(self, end: float) -> None:
        """No time past ``end``, the end of the record."""
        self.lead, self.lo, self.hi = min(self.lead, end), min(self.lo, end), min(self.hi, end)
        if self.trail is not None:
            self.trail = min(self.trail, end)

    def absorb(self, other: _Episode) -> None:
        """``other``, the run after this one, is part of it."""
        self.trail, self.ended = other.trail, other.ended
        self.lo, self.hi = min(self.lo, other.lo), max(self.hi, other.hi)


class EventTracker:
    """Episodes in, events out, as the windows come (module notes).

    Feed the episodes in time order: :meth:`start` with each run's lead, :meth:`end` with
    its trail, and :meth:`advance` with the time up to which every window (and its
    coefficients) is known; it returns the events it can now decide. At the end of the
    record, ``advance(..., final=True)``. An event's ``after`` summary waits for the next
    episode (or the end): the first :attr:`final_count` of :attr:`events` are final.

    Parameters
    ----------
    lmax : int
        The controller's longest window (samples).
    tau0 : float
        Sample interval (s).
    summaries : callable
        ``summaries(low, high, names)`` -> ``{name: stretch_summary}`` of the windows with
        ``low < time < high`` (``names`` None: every term; else only those).
    level : str or None
        The term whose level classifies the episodes (``"angle_random_walk"``); None, or a
        term ``summaries`` does not give: every episode is an event of its own.
    pairing : {"level", "parity"}
        See :func:`find_events`.
    t0 : float
        Time of the record's first sample: no trail is put before it (a window regrowing
        at the start of the record reaches back into the mirrored extension).
    """

    def __init__(
        self,
        lmax: int,
        tau0: float,
        summaries: Callable[..., dict[str, Any]],
        *,
        level: str | None = "angle_random_walk",
        pairing: str = "level",
        t0: float = -math.inf,
    ) -> None:
        if pairing not in PAIRINGS:
            raise AdavarInputError(
                f"unknown pairing {pairing!r}: use 'level' (by the noise level on each side) "
                "or 'parity' (consecutive changes, before 0.2)"
            )
        self.margin = 0.5 * lmax * tau0
        self.span = LEVEL_SPAN * lmax * tau0
        self._merge = 0.25 * lmax * tau0
        self._summaries = summaries
        self.level = level
        self.pairing = pairing
        self.t0 = float(t0)
        self._pending: list[_Episode] = []  # not yet decided, in time order
        self._previous = -np.inf  # end (hi) of the last decided episode
        self._open: dict[str, Any] | None = None  # the stretch opened and not yet closed
        self._waiting: list[tuple[int, float]] = []  # (event, its end): "after" to come
        self.events: list[Event] = []
        self.final_count = 0

    # ------------------------------------------------------------------ feeding

    def start(self, lead: float) -> None:
        """A run of shortened windows begins (its lead, s)."""
        if self._pending:
            last = self._pending[-1]
            near = lead - last.lead <= self._merge
            if self.pairing == "level":  # no whole window between them: one episode
                near = near or lead - last.hi <= 2.0 * self.margin
            if last.ended and near:  # the window regrew a step and shrank again
                last.trail, last.ended = None, False
                return
        self._pending.append(_Episode(lead))

    def end(self, trail: float) -> None:
        """The current run ends (its trail, s)."""
        episode = self._pending[-1]
        episode.close(max(trail, self.t0))
        if self.pairing == "level" and len(self._pending) > 1:
            # its trail came before its lead (a step down is seen late): no whole window
            # may be left between it and the run before, which then it joins
            before = self._pending[-2]
            if episode.lo - before.hi <= 2.0 * self.margin:
                before.absorb(self._pending.pop())

    def keep_from(self) -> float:
        """Earliest time whose windows a summary still to come reads (-inf: all)."""
        times = [self._previous + self.margin]
        if self._open is not None:
            times.append(self._open["hi"] + self.margin)
        times += [end + self.margin for _, end in self._waiting]
        if self._pending:
            times.append(self._pending[0].lo - self.margin - self.span)
        return min(times)

    def advance(
        self, horizon: float, *, final: bool = False, end_of_record: float | None = None
    ) -> list[Event]:
        """The events decided once every window up to ``horizon`` (s) is known.

        ``final``: the record has ended (at ``end_of_record``, s): every episode is
        decided, an open stretch lasts to the end, every summary is made final. An
        episode whose lead lies at or past ``end_of_record`` is dropped: its windows
        shortened when their leading edge was already in the mirrored extension, where no
        sample is new (on stationary records, zero-length events at the record's end,
        an independent audit); other times past the end are put at the end.
        """
        new: list[Event] = []
        if final and end_of_record is not None:
            end = float(end_of_record)
            self._pending = [e for e in self._pending if e.lead < end]
            for episode in self._pending:
                episode.clip(end)
        while self._pending:
            episode = self._pending[0]
            following = self._pending[1].lead if len(self._pending) > 1 else None
            if not final:
                if not episode.ended:
                    break
                # with no next episode yet, one could still join this one, and the level
                # after it is measured up to its end plus margin plus span; a next one
                # joins it or not when it ends
                if following is None and horizon < episode.hi + self.margin + self.span:
                    break
                if following is not None and not self._pending[1].ended:
                    break
            self._pending.pop(0)
            new += self._decide(episode, following)
        if final:
            new += self._finish(np.inf if end_of_record is None else float(end_of_record))
        return new

    # ------------------------------------------------------------------ internals

    def _level(self, low: float, high: float) -> dict | None:
        if self.level is None:
            return None
        return self._summaries(low, high, (self.level,)).get(self.level)

    def _finalise_after(self, following: float) -> None:
        """The events waiting for their "after": it ends before the next episode's lead."""
        for index, end in self._waiting:
            after = self._summaries(end + self.margin, following - self.margin, None)
            self.events[index] = replace(self.events[index], after=after)
        self._waiting = []
        self.final_count = len(self.events)

    def _emit(self, event_fields: dict[str, Any], end: float | None) -> Event:
        empty = self._summaries(np.inf, -np.inf, None)
        event = Event(**event_fields, after=empty)
        self.events.append(event)
        if end is not None:
            self._waiting.append((len(self.events) - 1, end))
        else:
            self.final_count = len(self.events)
        return event

    def _decide(self, episode: _Episode, following: float | None) -> list[Event]:
        self._finalise_after(episode.lead)
        parity = self.pairing == "parity"
        lo, hi = (episode.lead, episode.lead) if parity else (episode.lo, episode.hi)
        margin = self.margin
        previous, self._previous = self._previous, hi
        if parity:
            kind = -1 if self._open is not None else 1
            before_level = after_level = None
        else:
            before_level = self._level(max(previous + margin, lo - margin - self.span),
                                       lo - margin)  # fmt: skip
            after_level = None
            if episode.trail is not None:
                stop = hi + margin + self.span
                if following is not None:
                    stop = min(stop, following - margin)
                after_level = self._level(hi + margin, stop)
            kind = _level_kind(before_level, after_level)
        # the change time: an up is seen as it enters the window, a down as it leaves it
        when = episode.lead if parity or kind != -1 or episode.trail is None else episode.trail
        out: list[Event] = []
        stretch = self._open
        if stretch is None:
            before = self._summaries(previous + margin, lo - margin, None)
            if kind in (1, -1) or episode.trail is None:  # into a different level
                base = None if before_level is None else before_level["median"]
                self._open = {"start": when, "hi": hi, "before": before, "base": base}
            else:  # a spike, a burst: an event of its own, from the leading edge that met
                # it to the trailing edge that left it
                start, end = episode.lead, max(episode.lead, episode.trail or episode.lead)
                during = self._summaries(lo + margin, hi - margin, None)
                out.append(self._emit(dict(start_s=start, end_s=end, before=before,
                                           during=during), hi))  # fmt: skip
            return out
        if kind is None or kind == 0 or not self._returns(stretch, kind, before_level, after_level):
            return out  # inside the stretch: a spike in it, a second step
        during = self._summaries(stretch["hi"] + margin, lo - margin, None)
        out.append(self._emit(dict(start_s=stretch["start"], end_s=when,
                                   before=stretch["before"], during=during), hi))  # fmt: skip
        self._open = None
        return out

    def _returns(
        self, stretch: dict[str, Any], kind: int, before: dict | None, after: dict | None
    ) -> bool:
        """Whether this episode closes the open stretch (parity: always; level: a change
        against the stretch's that brings the level at least halfway back, in log)."""
        if self.pairing == "parity":
            return True
        base = stretch["base"]
        if base is None or before is None or after is None:
            return True  # no level before the stretch to come back to: the change closes it
        if (math.log(before["median"] / base) > 0) == (kind > 0):
            return False  # further from the level before the stretch
        spread = math.hypot(_log_spread(before), _log_spread(after))
        return comes_back(base, before["median"], after["median"], spread)

    def _finish(self, end_of_record: float) -> list[Event]:
        self._finalise_after(np.inf)
        stretch = self._open
        if stretch is None:
            return []
        self._open = None
        during = self._summaries(stretch["hi"] + self.margin, end_of_record - self.margin, None)
        return [self._emit(dict(start_s=stretch["start"], end_s=None, before=stretch["before"],
                                during=during), None)]  # fmt: skip


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
    level: Any = "angle_random_walk",
    pairing: str = "level",
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
        values (:meth:`adavar.dynamic.surface_fit.BlockFit.term_reader`, which reads them from
        disk); only the windows of the stretches are read.
    t0 : float
        Time of the first sample.
    duration : float, optional
        Length of the record (s), for the last stretch; default the last window's time.
    changes : sequence, optional
        The changes, if known otherwise: times (s; a fixed window's
        :func:`flag_change_times`, the ICI change points), each an episode whose lead and
        trail are that time, or ``(lead, trail)`` pairs. Default: the episodes of the
        adaptive window (:func:`change_episodes`).
    level : str, array_like or None
        The term whose level on each side classifies the episodes (default N,
        ``"angle_random_walk"``), or a level per window (e.g. the square root of each
        window's shortest-tau Allan variance, when nothing was fitted); None, or a term
        not in ``coefficients``: every episode is an event of its own.
    pairing : {"level", "parity"}
        ``"level"`` (default): episodes paired by the noise level on each side (module
        notes). ``"parity"``: the rule before 0.2, consecutive change times (leads)
        paired in turn, which one outlier inverts for the rest of the record.

    Returns
    -------
    list of Event
        In time order; ``start_s <= end_s`` (an event of its own may last zero seconds).
    """
    time = np.asarray(time, dtype=float)
    if changes is None:
        episodes = change_episodes(window, centre, lmax, tau0, t0)
    else:
        episodes = sorted((c, c) if np.ndim(c) == 0 else (c[0], c[1]) for c in changes)
    end_of_record = float(duration if duration is not None else time[-1])
    # the windows are in time order: each stretch is a range of them, read alone
    ordered = bool(np.all(np.diff(time) >= 0))

    sources = dict(coefficients)
    if level is not None and not isinstance(level, str):  # a level per window
        sources[_LEVEL] = level
        level = _LEVEL

    def summaries(low: float, high: float, names: Any = None) -> dict[str, Any]:
        """Each term's summary over the windows with ``low < time < high`` (the level's
        only when asked for by name)."""
        chosen = {name: v for name, v in sources.items()
                  if (name in names if names is not None else name in coefficients)}  # fmt: skip
        if ordered:
            start = int(np.searchsorted(time, low, side="right"))
            stop = max(start, int(np.searchsorted(time, high, side="left")))
            return {name: stretch_summary(np.asarray(v[start:stop], dtype=float))
                    for name, v in chosen.items()}  # fmt: skip
        inside = (time > low) & (time < high)
        return {name: stretch_summary(np.asarray(v[:], dtype=float)[inside])
                for name, v in chosen.items()}  # fmt: skip

    usable = level if level in sources else None
    tracker = EventTracker(lmax, tau0, summaries, level=usable, pairing=pairing, t0=t0)
    for lead, trail in episodes:
        tracker.start(float(lead))
        if trail is not None:
            tracker.end(float(trail))
    tracker.advance(np.inf, final=True, end_of_record=end_of_record)
    return tracker.events

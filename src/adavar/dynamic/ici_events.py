"""The events of the ICI window: its steps, its ramps and the long-tau changes.

docs/method.md section 11. ``adaptive_davar(..., method="ici")`` records what its episodes
found: every step and ramp of the white-noise level in time order
(``parameters["ici_found"]``: first and last sample, whether it is a ramp, whether it
raises the level, the mean squared difference before and after it;
:class:`adavar.dynamic.ici_episodes.Episode`) and, with ``ici_long_tau``, the changes of the
long-tau terms (``"ici_long_tau"``, :func:`adavar.dynamic.long_tau.long_tau_changes`).
:class:`IciEventTracker` turns the steps and ramps into :class:`adavar.dynamic.events.Event`,
offline (:func:`ici_events`) and live (:class:`adavar.OnlineAdaptive`) alike:

* a step or a ramp opens a stretch; the next change the other way that brings the level at
  least halfway back to the one before the stretch (in log, or within ``LEVEL_RATIO``)
  closes it, the changes between belong to it (a staircase). A burst is one event from
  its start to its end, however short; a ramp up and a step down (or the other way round)
  are one event from the ramp's first sample to the step, ``ramp=True``;
* a ramp that nothing closes is an event from its first to its last sample, ``ramp=True``;
  a step that nothing closes opens a stretch to the end of the record (``end_s`` None);
* the long-tau changes farther than ``Lmax`` plus twice their ``tau`` from every step and
  ramp (a change of the white level shows at every ``tau``) pair into stretches
  (:meth:`adavar.dynamic.long_tau.LongTauChanges.stretches`), ``tau_s`` the averaging time of the
  change into each (offline only).

``before``, ``during`` and ``after`` summarise the windows wholly before, inside and after
each event (centres farther than ``Lmax / 2`` from its ends and the neighbouring changes;
``during`` starts after the change into it has ended and stops before the change out of it
begins; a ramp's, or where no window fits there, the windows centred on the event).

Before 0.3.1 the ramps stayed out of the pairing and a change closed a stretch by its
direction alone: after a ramp up the step back down opened a stretch at the level before
the ramp, to the end of the record, and a staircase down (x2, x1.5, x1) closed at its
first step and opened again at its second. The results of older versions (no
``"ici_found"``) are still read by that rule, and without ``ici_episodes`` (the rule
before 0.3) the steps are paired by :func:`adavar.dynamic.events.find_events`. Events are in
order of their start.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from adavar.dynamic.events import Event, comes_back, stretch_summary
from adavar.dynamic.ici_episodes import Episode, pair_changes
from adavar.dynamic.long_tau import LongTauChange, LongTauChanges

__all__ = ["IciEventTracker", "ici_events"]

#: a long-tau change this many of its ``tau`` (plus ``Lmax``) from a step or ramp is that one
_TAU_MARGIN = 2.0


def _summaries(time: np.ndarray, coefficients: dict[str, Any], low: float, high: float) -> dict:
    """Each term's :func:`adavar.dynamic.events.stretch_summary` over the windows with ``low <
    time < high`` (``time`` increasing)."""
    start = int(np.searchsorted(time, low, side="right"))
    stop = max(start, int(np.searchsorted(time, high, side="left")))
    return {name: stretch_summary(np.asarray(v[start:stop], dtype=float))
            for name, v in coefficients.items()}  # fmt: skip


@dataclass(frozen=True)
class _Change:
    """A step (``start == end``) or ramp of the white-noise level, in seconds; ``before``
    and ``after`` the mean squares of the differences on either side."""

    start: float
    end: float
    ramp: bool
    rise: bool
    before: float
    after: float


class IciEventTracker:
    """The ICI's steps and ramps in, events out (module notes), offline and live alike.

    Feed the changes in time order with :meth:`add`, each once every window up to its end
    (and its coefficients) is known, and call :meth:`advance` for the events decided since
    the last call; at the end of the record ``advance(..., final=True)``. An event's
    ``after`` summary waits for the next change (or the end): the first
    :attr:`final_count` of :attr:`events` are final.

    Parameters
    ----------
    lmax : int
        The longest window (samples).
    tau0 : float
        Sample interval (s).
    summaries : callable
        ``summaries(low, high, names)`` -> ``{name: stretch_summary}`` of the windows with
        ``low < time < high`` (``names`` None: every term).
    """

    def __init__(self, lmax: int, tau0: float, summaries: Callable[..., dict[str, Any]]) -> None:
        self.margin = 0.5 * lmax * tau0
        self._summaries = summaries
        self._group: list[_Change] = []  # the open stretch: its opener first
        self._low = -np.inf  # end of the change before the open stretch
        self._last = -np.inf  # end of the last change
        self._waiting: list[tuple[int, float]] = []  # (event, its end): "after" to come
        self._new: list[Event] = []
        self.events: list[Event] = []
        self.final_count = 0

    def add(
        self, start: float, end: float, *, ramp: bool, rise: bool, before: float, after: float
    ) -> None:
        """The next change: a step at ``start == end`` or a ramp from ``start`` to ``end``
        (s), whether it raises the level, and the mean squares before and after it."""
        change = _Change(float(start), float(end), bool(ramp), bool(rise), float(before),
                         float(after))  # fmt: skip
        for index, stop in self._waiting:  # their "after" ends where this change begins
            after_ = self._summaries(stop + self.margin, change.start - self.margin, None)
            self.events[index] = replace(self.events[index], after=after_)
        self._waiting = []
        self.final_count = len(self.events)
        if not self._group:
            self._group, self._low = [change], self._last
        elif self._closes(change):
            self._emit(self._group[0], change, closed=True)
            self._group = []
        else:
            self._group.append(change)
        self._last = change.end

    def add_episode(self, episode: Episode, t0: float, tau0: float) -> None:
        """:meth:`add` of an :class:`adavar.dynamic.ici_episodes.Episode` (samples) of a
        record whose first sample is at ``t0`` (s), ``tau0`` apart."""
        self.add(float(t0 + episode.start * tau0), float(t0 + episode.end * tau0),
                 ramp=episode.ramp, rise=episode.rise, before=episode.before,
                 after=episode.after)  # fmt: skip

    def advance(
        self, horizon: float = np.inf, *, final: bool = False, end_of_record: float | None = None
    ) -> list[Event]:
        """The events decided since the last call (every change is decided as it is
        added; ``horizon`` is taken for the interface of
        :class:`adavar.dynamic.events.EventTracker`). ``final``: the record has ended (at
        ``end_of_record``, s): the open stretch is an event, every summary final."""
        if final:
            for index, stop in self._waiting:
                after = self._summaries(stop + self.margin, np.inf, None)
                self.events[index] = replace(self.events[index], after=after)
            self._waiting = []
            self.final_count = len(self.events)
            if self._group:
                end = np.inf if end_of_record is None else float(end_of_record)
                opener = self._group[0]
                if len(self._group) == 1 and opener.ramp:  # a ramp to a new level
                    self._emit(opener, opener, closed=False)
                    after = self._summaries(opener.end + self.margin, np.inf, None)
                    self.events[-1] = replace(self.events[-1], after=after)
                else:
                    self._emit(opener, None, closed=False, stop=end)
                self._group = []
                self.final_count = len(self.events)
        new, self._new = self._new, []
        return new

    def keep_from(self) -> float:
        """Earliest time whose windows a summary still to come reads."""
        times = [self._last + self.margin]
        if self._group:
            times.append(self._low + self.margin)
        times += [stop + self.margin for _, stop in self._waiting]
        return min(times)

    # ------------------------------------------------------------------ internals

    def _closes(self, change: _Change) -> bool:
        """A change against the stretch's that brings the amplitude at least halfway back
        (in log) to the one before the stretch, or within ``LEVEL_RATIO`` of it."""
        opener = self._group[0]
        if change.rise == opener.rise:
            return False
        levels = (opener.before, change.before, change.after)  # mean squares
        if not all(v > 0.0 for v in levels):
            return True  # no level to compare: the change closes it, as by direction
        return comes_back(*(math.sqrt(v) for v in levels))

    def _emit(
        self, opener: _Change, closer: _Change | None, *, closed: bool, stop: float = np.inf
    ) -> None:
        margin = self.margin
        start = opener.start
        end = closer.end if closer is not None else None
        ramp = any(c.ramp for c in self._group) or (closer is not None and closer.ramp)
        inner_stop = closer.start if closer is not None else stop
        if closer is opener:  # a ramp of its own: the windows centred on it
            inside = (opener.start, opener.end)
        elif ramp and inner_stop - opener.end <= 2.0 * margin:
            inside = (start, end if end is not None else stop)
        else:
            inside = (opener.end + margin, inner_stop - margin)
        event = Event(
            start_s=start, end_s=end,
            before=self._summaries(self._low + margin, start - margin, None),
            during=self._summaries(*inside, None),
            after=self._summaries(np.inf, -np.inf, None),
            ramp=ramp,
        )  # fmt: skip
        self.events.append(event)
        self._new.append(event)
        if closed and end is not None:
            self._waiting.append((len(self.events) - 1, end))
        else:
            self.final_count = len(self.events)


def ici_events(
    window: Any,
    centre: Any,
    time: Any,
    lmax: int,
    tau0: float,
    coefficients: dict[str, Any],
    *,
    t0: float,
    duration: float,
    parameters: dict[str, Any],
) -> list[Event]:
    """The events of an ICI result (module notes).

    Parameters
    ----------
    window, centre, time : array_like
        Window length, centre (samples) and time (s) of each kept window (in time order).
    lmax : int
        The longest window (samples).
    tau0 : float
        Sample interval (s).
    coefficients : dict of str to array_like
        Term name -> its value at each window (as :func:`adavar.dynamic.events.find_events`).
    t0 : float
        Time of the first sample (s).
    duration : float
        End of the record (s).
    parameters : dict
        The result's ``parameters`` (``ici_found``, ``ici_long_tau``; from older versions
        ``ici_changes``, ``ici_rises``, ``ici_ramps``).

    Returns
    -------
    list of Event
    """
    time = np.asarray(time, dtype=float)
    steps = [t0 + c * tau0 for c in parameters.get("ici_changes") or ()]
    rises = parameters.get("ici_rises")
    ramps = [(t0 + a * tau0, t0 + b * tau0) for a, b in parameters.get("ici_ramps") or ()]
    margin = 0.5 * lmax * tau0
    # every change an event's neighbouring windows must keep clear of
    bounds = np.sort(np.asarray([*steps, *(t for r in ramps for t in r)], dtype=float))

    def event(start: float, end: float | None, **kind: Any) -> Event:
        previous = bounds[bounds < start]
        low = previous[-1] if previous.size else -np.inf
        stop = end if end is not None else duration
        following = bounds[bounds > stop]
        high = following[0] if following.size else np.inf
        inside = (start, stop) if kind.get("ramp") else (start + margin, stop - margin)
        return Event(
            start_s=start, end_s=end,
            before=_summaries(time, coefficients, low + margin, start - margin),
            during=_summaries(time, coefficients, *inside),
            after=_summaries(time, coefficients, stop + margin, high - margin)
            if end is not None else _summaries(time, coefficients, np.inf, -np.inf),
            **kind,
        )  # fmt: skip

    listed = parameters.get("ici_found")
    if listed is not None:
        tracker = IciEventTracker(
            lmax, tau0, lambda low, high, names=None: _summaries(time, coefficients, low, high)
        )
        for e in listed:
            tracker.add_episode(Episode(**e), t0, tau0)
        tracker.advance(final=True, end_of_record=duration)
        events = list(tracker.events)
    elif rises is None or len(rises) != len(steps):  # the rule before 0.3
        from adavar.dynamic.events import find_events

        events = find_events(window, centre, time, lmax, tau0, coefficients, t0=t0,
                             duration=duration, changes=steps)  # fmt: skip
        events += [event(a, b, ramp=True) for a, b in ramps]
    else:  # the rule before 0.3.1: by direction, the ramps apart
        events = [event(steps[a], None if b is None else steps[b])
                  for a, b in pair_changes([bool(r) for r in rises])]  # fmt: skip
        events += [event(a, b, ramp=True) for a, b in ramps]
    found = parameters.get("ici_long_tau")
    if found:
        changes = LongTauChanges(changes=tuple(LongTauChange(**c) for c in found),
                                 taus=np.zeros(0))  # fmt: skip
        # the long-tau scan counts its times from the first sample
        known = [s - t0 for s in steps] + [(a - t0, b - t0) for a, b in ramps]
        for into, out in changes.stretches(known, margin=lmax * tau0, per_tau=_TAU_MARGIN):
            end = None if out is None else t0 + out.time_s
            events.append(event(t0 + into.time_s, end, tau_s=into.tau_s))
    return sorted(events, key=lambda e: e.start_s)

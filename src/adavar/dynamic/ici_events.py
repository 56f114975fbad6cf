"""The events of the ICI window: its steps, its ramps and the long-tau changes.

docs/method.md section 11. ``adaptive_davar(..., method="ici")`` records what its episodes
found (:mod:`adavar.dynamic.ici_episodes`): the steps of the white-noise level
(``parameters["ici_changes"]``, samples, and ``"ici_rises"``, whether each raises the
level), the gradual changes (``"ici_ramps"``, first and last sample) and, with
``ici_long_tau``, the changes of the long-tau terms (``"ici_long_tau"``,
:func:`adavar.dynamic.long_tau.long_tau_changes`). :func:`ici_events` turns them into
:class:`adavar.dynamic.events.Event`:

* the steps pair into stretches by direction (:func:`adavar.dynamic.ici_episodes.pair_changes`:
  a step opens a stretch, the next step the other way closes it): a burst is one event
  from its start to its end, however short;
* each ramp is one event from its first to its last sample, ``ramp=True``;
* the long-tau changes farther than ``Lmax`` plus twice their ``tau`` from every step and
  ramp (a change of the white level shows at every ``tau``) pair into stretches
  (:meth:`adavar.dynamic.long_tau.LongTauChanges.stretches`), ``tau_s`` the averaging time of the
  change into each.

``before``, ``during`` and ``after`` summarise the windows wholly before, inside and after
each event (centres farther than ``Lmax / 2`` from its ends and the neighbouring changes;
a ramp's ``during``: the windows centred on it). Without ``ici_episodes`` (the rule before
0.3) the steps are paired by :func:`adavar.dynamic.events.find_events`. Events are in order of
their start.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from adavar.dynamic.events import Event, stretch_summary
from adavar.dynamic.ici_episodes import pair_changes
from adavar.dynamic.long_tau import LongTauChange, LongTauChanges

__all__ = ["ici_events"]

#: a long-tau change this many of its ``tau`` (plus ``Lmax``) from a step or ramp is that one
_TAU_MARGIN = 2.0


def _summaries(time: np.ndarray, coefficients: dict[str, Any], low: float, high: float) -> dict:
    """Each term's :func:`adavar.dynamic.events.stretch_summary` over the windows with ``low <
    time < high`` (``time`` increasing)."""
    start = int(np.searchsorted(time, low, side="right"))
    stop = max(start, int(np.searchsorted(time, high, side="left")))
    return {name: stretch_summary(np.asarray(v[start:stop], dtype=float))
            for name, v in coefficients.items()}  # fmt: skip


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
        The result's ``parameters`` (``ici_changes``, ``ici_rises``, ``ici_ramps``,
        ``ici_long_tau``).

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

    if rises is None or len(rises) != len(steps):  # the rule before 0.3
        from adavar.dynamic.events import find_events

        events = find_events(window, centre, time, lmax, tau0, coefficients, t0=t0,
                             duration=duration, changes=steps)  # fmt: skip
    else:
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

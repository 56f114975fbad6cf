"""Public face of :mod:`adavar.dynamic.events`:
``import adavar.events`` works as documented.

The names are defined and documented in :mod:`adavar.dynamic.events`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.dynamic.events import (
    LEVEL_RATIO,
    LEVEL_SPAN,
    PAIRINGS,
    Event,
    EventTracker,
    change_episodes,
    change_times,
    find_events,
    flag_change_times,
    flag_runs,
    join_runs,
    run_change_times,
    stretch_summary,
)

__all__ = [
    "LEVEL_RATIO",
    "LEVEL_SPAN",
    "PAIRINGS",
    "Event",
    "EventTracker",
    "change_episodes",
    "change_times",
    "find_events",
    "flag_change_times",
    "flag_runs",
    "join_runs",
    "run_change_times",
    "stretch_summary",
]

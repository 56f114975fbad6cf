"""Public face of :mod:`adavar.dynamic.adaptive`:
``import adavar.adaptive`` works as documented.

The names are defined and documented in :mod:`adavar.dynamic.adaptive`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.dynamic.adaptive import (
    METHODS,
    AdaptiveResult,
    Schedule,
    adaptive_blocks,
    adaptive_davar,
    adaptive_schedule,
    calibrated_thresholds,
    dependence_stages,
    false_alarm_rate,
    oracle_schedule,
    record_windows,
    resolve_windows,
    surface_resolution,
    window_lengths,
)

__all__ = [
    "METHODS",
    "AdaptiveResult",
    "Schedule",
    "adaptive_blocks",
    "adaptive_davar",
    "adaptive_schedule",
    "calibrated_thresholds",
    "dependence_stages",
    "false_alarm_rate",
    "oracle_schedule",
    "record_windows",
    "resolve_windows",
    "surface_resolution",
    "window_lengths",
]

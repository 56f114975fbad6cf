"""Public face of :mod:`adavar.core.settings`:
``import adavar.settings`` works as documented.

The names are defined and documented in :mod:`adavar.core.settings`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.core.settings import (
    ANALYSIS_DEFAULTS,
    BAND_ONLY,
    CALIBRATED_ONLY,
    CALIBRATED_REPLACES,
    CONTROLLER,
    DATA_TYPE_DEFAULT,
    DEPENDENCE_FIRST,
    EFFICIENT_CHUNK,
    FIT,
    HOURLY_FALSE_ALARMS,
    HOURLY_ONLY,
    PAPER,
    RATE_AGREEMENT,
    RATE_DEFAULT,
    STREAM_LMAX_SECONDS,
    THRESHOLDS,
    ControllerSettings,
    FileDefault,
    FitSettings,
    RateDefault,
    requested_threads,
    threshold_mode,
)

__all__ = [
    "ANALYSIS_DEFAULTS",
    "BAND_ONLY",
    "CALIBRATED_ONLY",
    "CALIBRATED_REPLACES",
    "CONTROLLER",
    "DATA_TYPE_DEFAULT",
    "DEPENDENCE_FIRST",
    "EFFICIENT_CHUNK",
    "FIT",
    "HOURLY_FALSE_ALARMS",
    "HOURLY_ONLY",
    "PAPER",
    "RATE_AGREEMENT",
    "RATE_DEFAULT",
    "STREAM_LMAX_SECONDS",
    "THRESHOLDS",
    "ControllerSettings",
    "FileDefault",
    "FitSettings",
    "RateDefault",
    "requested_threads",
    "threshold_mode",
]

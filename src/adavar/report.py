"""Public face of :mod:`adavar.output.report`:
``import adavar.report`` works as documented.

The names are defined and documented in :mod:`adavar.output.report`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.output.report import (
    MAX_SERIES_POINTS,
    MAX_SURFACE_TAUS,
    MAX_SURFACE_TIMES,
    build_report,
    channel_section,
    channels_page,
    series_rows,
    write_report,
)

__all__ = [
    "MAX_SERIES_POINTS",
    "MAX_SURFACE_TAUS",
    "MAX_SURFACE_TIMES",
    "build_report",
    "channel_section",
    "channels_page",
    "series_rows",
    "write_report",
]

"""Public face of :mod:`adavar.output.report_parts`:
``import adavar.report_parts`` works as documented.

The names are defined and documented in :mod:`adavar.output.report_parts`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.output.report_parts import (
    MAX_SERIES_POINTS,
    MAX_SURFACE_TAUS,
    MAX_SURFACE_TIMES,
    block_fit_of,
    coefficient_plot,
    coefficient_table,
    comparison_plot,
    comparison_tables,
    controller_plot,
    deviation_plot,
    escape,
    event_shapes,
    events_table,
    mapping_table,
    notes_html,
    plain_text,
    script_json,
    series_rows,
    surface_plot,
    user_text,
    user_title,
)

__all__ = [
    "MAX_SERIES_POINTS",
    "MAX_SURFACE_TAUS",
    "MAX_SURFACE_TIMES",
    "block_fit_of",
    "coefficient_plot",
    "coefficient_table",
    "comparison_plot",
    "comparison_tables",
    "controller_plot",
    "deviation_plot",
    "escape",
    "event_shapes",
    "events_table",
    "mapping_table",
    "notes_html",
    "plain_text",
    "script_json",
    "series_rows",
    "surface_plot",
    "user_text",
    "user_title",
]

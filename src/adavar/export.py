"""Public face of :mod:`adavar.output.export`:
``import adavar.export`` works as documented.

The names are defined and documented in :mod:`adavar.output.export`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.output.export import (
    COEFFICIENT_COLUMNS,
    KALIBR_KEYS,
    coefficient_rows,
    kalibr_imu_yaml,
    kalibr_values,
    write_json,
    write_table_csv,
    write_text,
)

__all__ = [
    "COEFFICIENT_COLUMNS",
    "KALIBR_KEYS",
    "coefficient_rows",
    "kalibr_imu_yaml",
    "kalibr_values",
    "write_json",
    "write_table_csv",
    "write_text",
]

"""Public face of :mod:`adavar.dynamic.surface`:
``import adavar.surface`` works as documented.

The names are defined and documented in :mod:`adavar.dynamic.surface`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.dynamic.surface import (
    STATS,
    DavarStatResult,
    davar,
    edf_table,
)
from adavar.dynamic.surface import davar_blocks as davar_blocks  # documented, not in __all__

__all__ = [
    "STATS",
    "DavarStatResult",
    "davar",
    "edf_table",
]

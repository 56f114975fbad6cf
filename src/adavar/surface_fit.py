"""Public face of :mod:`adavar.dynamic.surface_fit`:
``import adavar.surface_fit`` works as documented.

The names are defined and documented in :mod:`adavar.dynamic.surface_fit`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.dynamic.surface_fit import (
    FIT_ROWS,
    BlockFit,
    concatenate_fits,
    drawn_rows,
    fit_adaptive_in_blocks,
    fit_blocks,
    fit_davar_in_blocks,
    fit_rows,
)

__all__ = [
    "FIT_ROWS",
    "BlockFit",
    "concatenate_fits",
    "drawn_rows",
    "fit_adaptive_in_blocks",
    "fit_blocks",
    "fit_davar_in_blocks",
    "fit_rows",
]

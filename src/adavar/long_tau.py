"""Public face of :mod:`adavar.dynamic.long_tau`:
``import adavar.long_tau`` works as documented.

The names are defined and documented in :mod:`adavar.dynamic.long_tau`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.dynamic.long_tau import (
    LONG_TAU_MIN_M,
    LONG_TAU_SAMPLES,
    LongTauChange,
    LongTauChanges,
    long_tau_changes,
)

__all__ = [
    "LONG_TAU_MIN_M",
    "LONG_TAU_SAMPLES",
    "LongTauChange",
    "LongTauChanges",
    "long_tau_changes",
]

"""Public face of :mod:`adavar.dynamic.surface_fit`:
``import adavar.surface_fit`` works as documented.

The names are defined and documented in :mod:`adavar.dynamic.surface_fit`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.dynamic.surface_fit import *  # noqa: F403 - the names of its __all__
from adavar.dynamic.surface_fit import __all__ as __all__

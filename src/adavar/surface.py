"""Public face of :mod:`adavar.dynamic.surface`:
``import adavar.surface`` works as documented.

The names are defined and documented in :mod:`adavar.dynamic.surface`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.dynamic.surface import *  # noqa: F403 - the names of its __all__
from adavar.dynamic.surface import __all__ as __all__
from adavar.dynamic.surface import davar_blocks as davar_blocks  # documented, not in __all__

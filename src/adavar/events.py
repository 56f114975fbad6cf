"""Public face of :mod:`adavar.dynamic.events`:
``import adavar.events`` works as documented.

The names are defined and documented in :mod:`adavar.dynamic.events`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.dynamic.events import *  # noqa: F403 - the names of its __all__
from adavar.dynamic.events import __all__ as __all__

"""Public face of :mod:`adavar.dynamic.adaptive`:
``import adavar.adaptive`` works as documented.

The names are defined and documented in :mod:`adavar.dynamic.adaptive`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.dynamic.adaptive import *  # noqa: F403 - the names of its __all__
from adavar.dynamic.adaptive import __all__ as __all__

"""Public face of :mod:`adavar.stats.stream`:
``import adavar.stream`` works as documented.

The names are defined and documented in :mod:`adavar.stats.stream`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.stats.stream import *  # noqa: F403 - the names of its __all__
from adavar.stats.stream import __all__ as __all__

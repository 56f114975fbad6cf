"""Public face of :mod:`adavar.core.settings`:
``import adavar.settings`` works as documented.

The names are defined and documented in :mod:`adavar.core.settings`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.core.settings import *  # noqa: F403 - the names of its __all__
from adavar.core.settings import __all__ as __all__

"""Public face of :mod:`adavar.pipeline.demo`:
``import adavar.demo`` works as documented.

The names are defined and documented in :mod:`adavar.pipeline.demo`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.pipeline.demo import *  # noqa: F403 - the names of its __all__
from adavar.pipeline.demo import __all__ as __all__

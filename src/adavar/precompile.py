"""Public face of :mod:`adavar.pipeline.precompile`:
``import adavar.precompile`` works as documented.

The names are defined and documented in :mod:`adavar.pipeline.precompile`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.pipeline.precompile import *  # noqa: F403 - the names of its __all__
from adavar.pipeline.precompile import __all__ as __all__

"""Public face of :mod:`adavar.output.export`:
``import adavar.export`` works as documented.

The names are defined and documented in :mod:`adavar.output.export`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.output.export import *  # noqa: F403 - the names of its __all__
from adavar.output.export import __all__ as __all__

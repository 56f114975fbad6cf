"""Public face of :mod:`adavar.output.plots`:
``import adavar.plots`` works as documented.

The names are defined and documented in :mod:`adavar.output.plots`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.output.plots import *  # noqa: F403 - the names of its __all__
from adavar.output.plots import __all__ as __all__

"""Public face of :mod:`adavar.pipeline.batch`:
``import adavar.batch`` works as documented.

The names are defined and documented in :mod:`adavar.pipeline.batch`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.pipeline.batch import *  # noqa: F403 - the names of its __all__
from adavar.pipeline.batch import __all__ as __all__

"""Public face of :mod:`adavar.pipeline.analysis`:
``import adavar.analysis`` works as documented.

The names are defined and documented in :mod:`adavar.pipeline.analysis`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.pipeline.analysis import *  # noqa: F403 - the names of its __all__
from adavar.pipeline.analysis import __all__ as __all__

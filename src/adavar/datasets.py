"""Public face of :mod:`adavar.core.datasets`:
``import adavar.datasets`` works as documented.

The names are defined and documented in :mod:`adavar.core.datasets`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.core.datasets import *  # noqa: F403 - the names of its __all__
from adavar.core.datasets import __all__ as __all__

"""Public face of :mod:`adavar.dynamic.long_tau`:
``import adavar.long_tau`` works as documented.

The names are defined and documented in :mod:`adavar.dynamic.long_tau`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.dynamic.long_tau import *  # noqa: F403 - the names of its __all__
from adavar.dynamic.long_tau import __all__ as __all__

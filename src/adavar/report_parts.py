"""Public face of :mod:`adavar.output.report_parts`:
``import adavar.report_parts`` works as documented.

The names are defined and documented in :mod:`adavar.output.report_parts`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.output.report_parts import *  # noqa: F403 - the names of its __all__
from adavar.output.report_parts import __all__ as __all__

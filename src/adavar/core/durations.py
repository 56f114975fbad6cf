"""Window lengths as durations or as samples.

Every window-like parameter (``window``, ``lmax``, ``lmin``, ``l``, ``step``) takes either a
number of samples (a bare integer, as the paper writes them) or a duration: a string with a
unit (``"600s"``, ``"10min"``, ``"2h"``, ``"250ms"``, ``"1.5 h"``), a
:class:`datetime.timedelta`, or :func:`seconds` (``adavar.seconds(600)``). A duration is
converted with the record's sample interval and rounded to the nearest whole sample; a
string of digits alone (``"600"``) is samples, as on the command line.
"""

from __future__ import annotations

import datetime as _dt
import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from adavar.core.errors import AdavarInputError

__all__ = [
    "UNITS",
    "Duration",
    "Length",
    "count_text",
    "is_duration",
    "parse_duration",
    "seconds",
    "to_samples",
]

#: Sample counts up to this are written out in messages; larger ones (a duration of 1e300 s
#: in samples, 301 digits) as ``1e+302``.
EXACT_COUNT = 10**15


def count_text(n: Any) -> str:
    """A sample count for a message: every digit up to :data:`EXACT_COUNT`, then ``:g``."""
    try:
        big = abs(n) > EXACT_COUNT
    except TypeError:
        return str(n)
    return f"{float(n):g}" if big else str(n)


#: Units of a duration string, in seconds.
UNITS: dict[str, float] = {
    "ms": 1e-3, "s": 1.0, "sec": 1.0, "min": 60.0, "h": 3600.0, "hr": 3600.0, "d": 86400.0,
}  # fmt: skip
_PATTERN = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([a-zA-Z]+)\s*$")


@dataclass(frozen=True)
class Duration:
    """A length of time, for the window-like parameters.

    Attributes
    ----------
    seconds : float
        The duration in seconds (positive, finite).
    """

    seconds: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.seconds) and self.seconds > 0):
            raise AdavarInputError(f"a duration must be positive and finite, got {self.seconds}")

    def __str__(self) -> str:
        return f"{self.seconds:g}s"


#: A window-like parameter: samples (int), or a duration.
Length = int | str | Duration | _dt.timedelta


def seconds(value: float) -> Duration:
    """A duration of ``value`` seconds (``adavar.davar(x, window=adavar.seconds(600))``)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise AdavarInputError(f"seconds() takes a number, got {value!r}") from None
    return Duration(number)


def parse_duration(text: str) -> Duration | None:
    """``"10min"`` -> Duration(600); a string of digits alone -> None (samples).

    Raises
    ------
    AdavarInputError
        Neither digits nor a number with a known unit.
    """
    stripped = text.strip()
    if stripped.isdigit():
        return None
    match = _PATTERN.match(stripped)
    unit = match.group(2).lower() if match else None
    if unit not in UNITS:
        raise AdavarInputError(
            f"{text!r} is neither a number of samples nor a duration: write e.g. 600 "
            f"(samples), 600s, 10min or 2h (units: {', '.join(UNITS)})"
        )
    return Duration(float(match.group(1)) * UNITS[unit])


def is_duration(value: Any) -> bool:
    """True for a :class:`Duration`, a timedelta or a duration string (not for samples)."""
    if isinstance(value, (Duration, _dt.timedelta)):
        return True
    return isinstance(value, str) and parse_duration(value) is not None


def to_samples(value: Any, tau0: float, name: str) -> Any:
    """Samples of a window-like parameter: durations converted, anything else unchanged.

    Parameters
    ----------
    value : int, str, Duration or datetime.timedelta
        Samples, or a duration.
    tau0 : float
        Sample interval (s).
    name : str
        The parameter's name, for messages.

    Returns
    -------
    int or the value as given
        ``round(seconds / tau0)`` for a duration; the value itself otherwise (an int, or
        anything else, which the caller validates as before). A digit string is an int.

    Raises
    ------
    AdavarInputError
        A bad duration string, or a duration shorter than one sample.
    """
    if isinstance(value, str):
        parsed = parse_duration(value)
        if parsed is None:
            return int(value.strip())
        value = parsed
    if isinstance(value, _dt.timedelta):
        value = Duration(value.total_seconds())
    if not isinstance(value, Duration):
        return value
    samples = int(np.rint(value.seconds / tau0))
    if samples < 1:
        raise AdavarInputError(
            f"{name} = {value} is shorter than one sample ({tau0:g} s): give a longer duration"
        )
    return samples

"""Values of command-line flags: each parser turns the text of one flag into its value, or
raises :class:`argparse.ArgumentTypeError` with a one-line reason and what to give instead
(argparse then prints it with the flag's name and exits with status 2)."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

from adavar.core.durations import parse_duration
from adavar.core.errors import AdavarInputError
from adavar.core.settings import (
    MAX_POINTS_PER_DECADE,
    RATE_LIMITS,
)
from adavar.core.taus import TAU_KEYWORDS
from adavar.core.terms import ALIASES, TERM_NAMES
from adavar.dynamic.windows import MIN_WINDOW
from adavar.io.preprocess import parse_steps
from adavar.output._figures import FIGURE_FORMATS


def number(text: str) -> float:
    """``text`` as a float, NaN if it is not a number (the parsers' errors then say why)."""
    try:
        return float(text)
    except ValueError:
        return math.nan


def positive_float(what: str) -> Callable[[str], float]:
    def parse(text: str) -> float:
        value = number(text)
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"must be a positive number of {what}, got {text!r}")
        return value

    return parse


#: The sample rates ``--rate`` accepts, Hz (``--tau0``: their inverses): the library's
MIN_RATE, MAX_RATE = RATE_LIMITS


def sample_rate(flag: str) -> Callable[[str], float]:
    """The type of ``--rate`` (``flag="--rate"``, Hz) or ``--tau0`` (seconds): a positive
    number within :data:`MIN_RATE` .. :data:`MAX_RATE` Hz."""
    interval = flag == "--tau0"
    unit = "seconds" if interval else "Hz"
    lo, hi = (1.0 / MAX_RATE, 1.0 / MIN_RATE) if interval else (MIN_RATE, MAX_RATE)

    def parse(text: str) -> float:
        value = positive_float(unit)(text)
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(
                f"must lie in {lo:g} .. {hi:g} {unit} (a sample every 1 ps to 31,700 years), "
                f"got {text!r}: check the unit ({flag} is in {unit})"
            )
        return value

    return parse


def figure_formats(text: str) -> tuple[str, ...]:
    """``--figures``: comma-separated formats (each once, in order), or ``none`` for ()."""
    items = [item.strip().lower() for item in text.split(",") if item.strip()]
    if items == ["none"]:
        return ()
    unknown = [item for item in items if item not in FIGURE_FORMATS]
    if not items or unknown:
        raise argparse.ArgumentTypeError(
            f"must be comma-separated formats among {', '.join(FIGURE_FORMATS)}, or none; "
            f"got {text!r}"
        )
    return tuple(dict.fromkeys(items))


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return value


def points_per_decade(text: str) -> int:
    """``--points-per-decade``: 1 to the library's ``MAX_POINTS_PER_DECADE``."""
    value = positive_int(text)
    if value > MAX_POINTS_PER_DECADE:
        raise argparse.ArgumentTypeError(
            f"must be at most {MAX_POINTS_PER_DECADE}, got {text!r}: denser taus add no "
            "information (use --taus all for every averaging factor)"
        )
    return value


def parse_confidence(text: str) -> float:
    value = number(text)
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(
            f"must be a probability strictly between 0 and 1 (e.g. 0.683 or 0.95), got {text!r}"
        )
    return value


def confidence_or_none(text: str) -> float | None:
    if text.strip().lower() in ("none", "off"):
        return None
    value = number(text)
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(
            "must be a probability strictly between 0 and 1 (e.g. 0.683 or 0.95), or none "
            f"for no bounds and no fit, got {text!r}"
        )
    return value


def window_length(text: str) -> int | str:
    """Samples (at least MIN_WINDOW), or a duration (``600s``, ``10min``) kept as text until
    the record's rate is known."""
    return length_arg(MIN_WINDOW, "(one Allan-variance term at m = 1)")(text)


def length_arg(minimum: int, why: str = "") -> Callable[[str], int | str]:
    """A window-like flag: whole samples (at least ``minimum``) or a duration string."""

    def parse(text: str) -> int | str:
        stripped = text.strip()
        whole = stripped.isdigit()
        if not whole:
            try:
                float(stripped)
            except ValueError:  # not a number: a duration, or nothing we know
                try:
                    parse_duration(stripped)
                except AdavarInputError as exc:
                    raise argparse.ArgumentTypeError(str(exc)) from None
                return stripped
        if not whole or int(stripped) < minimum:
            samples = (
                "a positive integer (samples)"
                if minimum == 1
                else f"a whole number of samples, at least {minimum}{' ' + why if why else ''}"
            )
            raise argparse.ArgumentTypeError(
                f"must be {samples}, or a duration such as 600s or 10min; got {text!r}"
            )
        return int(stripped)

    return parse


def _items(text: str) -> list[str]:
    """The comma-separated items of a list flag; an empty one (a trailing or doubled comma)
    is an error rather than dropped."""
    parts = [part.strip() for part in text.split(",")]
    if text.strip() and not all(parts):
        raise argparse.ArgumentTypeError(
            f"empty item in {text!r}: remove the trailing or doubled comma"
        )
    return [part for part in parts if part]


def _positive_numbers(text: str) -> list[float]:
    """Comma-separated positive finite numbers, or [] if any item is not one."""
    try:
        values = [float(part) for part in _items(text)]
    except ValueError:
        return []
    return values if all(math.isfinite(v) and v > 0 for v in values) else []


def parse_taus(text: str) -> str | list[float]:
    key = text.strip().lower()
    if key in TAU_KEYWORDS:
        return key
    values = _positive_numbers(text)
    if not values:
        raise argparse.ArgumentTypeError(
            f"expected {', '.join(TAU_KEYWORDS)} or comma-separated positive seconds "
            f"(e.g. 0.1,1,10), got {text!r}"
        )
    return values


def _between(text: str, low: float, high: float, what: str) -> float:
    """``text`` as a number strictly between ``low`` and ``high``, or ``what`` as the error."""
    value = number(text)
    if not low < value < high:
        raise argparse.ArgumentTypeError(f"{what}, got {text!r}")
    return value


def fraction(text: str) -> float:
    return _between(text, 0.0, 1.0, "must be a fraction between 0 and 1")


def parse_seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text!r}")
    return value


def finite_float(text: str) -> float:
    value = number(text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def _positive_list(what: str, example: str) -> Callable[[str], list[float]]:
    """A parser of comma-separated positive finite numbers (``what`` names them)."""

    def parse(text: str) -> list[float]:
        values = _positive_numbers(text)
        if not values:
            raise argparse.ArgumentTypeError(
                f"expected comma-separated positive {what} (e.g. {example}), got {text!r}"
            )
        return values

    return parse


seconds_list = _positive_list("times in seconds", "3000,4000")


threshold_list = _positive_list("kurtosis thresholds", "3.3,4")


def parse_intervals(text: str) -> list[tuple[float, float]]:
    out = []
    for part in _items(text):
        try:
            a, b = (float(v) for v in part.split(":"))
        except ValueError:
            a = b = math.nan
        if not (math.isfinite(a) and math.isfinite(b) and 0 <= a < b):
            raise argparse.ArgumentTypeError(
                f"expected comma-separated A:B intervals in seconds with A < B (e.g. "
                f"0:3000,3000:4000), got {part.strip()!r}"
            )
        out.append((a, b))
    if not out:
        raise argparse.ArgumentTypeError("give at least one A:B interval")
    return out


def number_tuple(flag: str, least: int, most: int) -> Callable[[str], tuple[float, ...]]:
    def parse(text: str) -> tuple[float, ...]:
        try:
            values = tuple(float(part) for part in text.split(","))
        except ValueError:
            values = ()
        if not least <= len(values) <= most or not all(math.isfinite(v) for v in values):
            raise argparse.ArgumentTypeError(
                f"{flag} takes {least}{'' if least == most else f' or {most}'} comma-separated "
                f"numbers, got {text!r}"
            )
        return values

    return parse


def parse_names(text: str) -> list[str]:
    names = [part.lower() for part in _items(text)]
    if not names:
        raise argparse.ArgumentTypeError("give at least one method, e.g. davar-400,a-davar")
    return names


def parse_terms(text: str) -> tuple[str, ...]:
    out = []
    for key in _items(text):
        name = key if key in TERM_NAMES else ALIASES.get(key.lower())
        if name is None:
            raise argparse.ArgumentTypeError(
                f"unknown noise term {key!r}: use {', '.join(TERM_NAMES)} or the letters "
                "Q, N, B, K, R"
            )
        if name not in out:
            out.append(name)
    if not out:
        raise argparse.ArgumentTypeError("give at least one noise term")
    return tuple(out)


def parse_preprocess(text: str) -> str:
    """``--preprocess``: the steps checked now (before the record is read), kept as text."""
    try:
        parse_steps(text)
    except AdavarInputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text.strip()


def parse_noise_type(text: str) -> str | int | list[int]:
    value = text.strip().lower()
    if value == "record":
        return "record"
    try:
        alphas = [int(part) for part in value.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: use 'record', an integer alpha from -2 to 2, or one per tau "
            "(comma-separated)"
        ) from None
    if not all(-2 <= alpha <= 2 for alpha in alphas):
        raise argparse.ArgumentTypeError(f"{text!r}: alpha must lie in -2 .. 2")
    return alphas[0] if len(alphas) == 1 else alphas


def tau_range(text: str) -> tuple[float | None, float | None]:
    """``MIN:MAX`` seconds, either side may be empty (open)."""
    parts = text.split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        lo, hi = (float(p) if p.strip() else None for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--tau-range takes MIN:MAX in seconds (either may be empty), got {text!r}"
        ) from None
    for v in (lo, hi):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise argparse.ArgumentTypeError(f"--tau-range bounds must be positive, got {text!r}")
    if lo is not None and hi is not None and not lo < hi:
        raise argparse.ArgumentTypeError(f"--tau-range {text!r}: MIN must be below MAX")
    return lo, hi


def probability(text: str) -> float:
    """A one-sided confidence level strictly between 0.5 and 1."""
    return _between(text, 0.5, 1.0, "takes a probability between 0.5 and 1")


def whole_list(text: str) -> list[int]:
    """Comma-separated whole numbers >= 1 (``--ici-lengths``, ``--ici-taus``)."""
    try:
        values = [int(part) for part in text.replace(" ", "").split(",") if part]
    except ValueError:
        values = []
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated whole numbers >= 1 (e.g. 50,100,400,600), got {text!r}"
        )
    return values

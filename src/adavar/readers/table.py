"""A file's columns as one table, shared by the text, NumPy, HDF5 and Parquet readers.

Each reader turns its file into a :class:`Table` (column names, a kind per column:
numbers, ISO 8601 strings, datetime nanoseconds or unusable text, and a way to get each
column); :func:`channels_from_table` then chooses the channels (``columns``) and the time
column (``time_column``, else found by its name or as the only date-time column), and
reads the time column in its unit (``time_format``, else the unit written in the column
name, else seconds) as seconds from the first stamp. ``time_format`` contradicting the unit
written in the column name is an error, as is a column taken for the time column (by its
name) asked for as a channel; ``time_column="none"`` reads no time column.
"""

from __future__ import annotations

import datetime as _dt
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.core.inputs import check_exact_integers
from adavar.io.sources import ChunkedSource, memmap_source
from adavar.readers.errors import fail, locate
from adavar.readers.lazy import no_time_column

#: Values of ``time_format``.
TIME_FORMATS = ("auto", "s", "ms", "us", "ns", "iso", "mjd")

#: Cells read as a missing sample (NaN) in text files (case-insensitive).
MISSING = frozenset({"", "na", "n/a", "nan", "null", "none", "nat", "-nan", "+nan"})
_UNIT_FACTOR = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "mjd": 86400.0}
_UNIT_ALIASES = {"sec": "s", "secs": "s", "seconds": "s", "µs": "us", "μs": "us"}
_MJD_UNIX_EPOCH = 40587.0
#: The longest median step (in the column's numbers) of a time column of no declared unit
#: read as seconds: whole seconds 1 apart (1 Hz clocks), with room for jittery stamps.
_MAX_ASSUMED_STEP = 1.01
#: Stamps of no declared unit in this range (Modified Julian Days 1968-2077) whose steps
#: would be faster than this many Hz as seconds are asked for their unit: days, most likely.
_MJD_RANGE = (40000.0, 80000.0)
_MJD_RATE = 1e5
#: Column / field / key names taken for a time column when ``time_column`` is not given.
_TIME_NAME = re.compile(
    r"^(?:t|time|times|timestamp|timestamps|time_stamp|datetime|date_time|stamp|epoch|utc"
    r"|elapsed|elapsed_time|mjd)"
    r"(?:\s*[_\-\s]?\s*[\[(]?\s*(?P<unit>s|sec|secs|seconds|ms|us|µs|μs|ns)\s*[\])]?)?$",
    re.IGNORECASE,
)


def resolve(key: str | int, names: Sequence[str], src: str, what: str = "column") -> str:
    """The name of ``key`` (a name, case-insensitive if unique, or a 0-based index)."""
    if isinstance(key, bool):
        raise fail(f"{what} must be a name or a 0-based index, got {key!r}")
    listed = ", ".join(repr(n) for n in names[:30]) + (", ..." if len(names) > 30 else "")
    if isinstance(key, str):
        text = key.strip()
        if text in names:
            if text.isdigit() and int(text) < len(names) and names[int(text)] != text:
                # header 'time,2,1': is '1' the column named so, or the second one?
                raise fail(
                    f"{what} {key!r} of {src} is both a column's name and the index of "
                    f"another ({names[int(text)]!r}): rename the columns, or give the "
                    f"index as a number (columns=[{int(text)}] in Python)"
                )
            return text
        folded = [n for n in names if n.casefold() == text.casefold()]
        if len(folded) == 1:
            return folded[0]
        if not text.lstrip("+").isdigit():
            raise fail(f"unknown {what} {key!r} in {src}; available: {listed}")
        key = int(text)
    if isinstance(key, (int, np.integer)) and 0 <= int(key) < len(names):
        return names[int(key)]
    raise fail(f"{what} {key!r} is not in {src}; available: {listed}")


def as_list(columns: str | int | Sequence[str | int] | None) -> list[str | int] | None:
    """The ``columns`` option as a list (a comma-separated string split), or None."""
    if columns is None:
        return None
    if isinstance(columns, str):
        items: list[str | int] = [c.strip() for c in columns.split(",") if c.strip()]
    elif isinstance(columns, (int, np.integer)):
        items = [int(columns)]
    else:
        items = list(columns)
    if not items:
        raise fail("columns is empty: give at least one column name, or leave it out")
    return items


def time_name_unit(name: str) -> tuple[bool, str | None]:
    """(is a time column name, unit written in the name)."""
    match = _TIME_NAME.match(name.strip())
    if not match:
        return False, None
    unit = match.group("unit")
    if unit is None and name.strip().casefold() == "mjd":
        return True, "mjd"
    if unit is not None:
        unit = _UNIT_ALIASES.get(unit.casefold(), unit.casefold())
    return True, unit


#: A unit written after a column's name, in brackets or parentheses: ``gx [rad/s]``.
_UNIT_IN_NAME = re.compile(r"^.*?\S\s*[\[(]\s*(?P<unit>[^\[\]()]+?)\s*[\])]$")


def unit_in_name(name: str) -> str | None:
    """The unit written in a column's name (``gx [rad/s]``, ``ax (m/s^2)``), when adavar
    knows it as a unit of samples; else None (a free label is no declaration)."""
    from adavar.core.units import unit_info

    match = _UNIT_IN_NAME.match(name.strip())
    if match is None:
        return None
    try:
        unit_info(match.group("unit"))
    except (TypeError, ValueError):
        return None
    return match.group("unit")


def is_iso(cell: str) -> bool:
    """Whether ``cell`` is an ISO 8601 date-time (starting with a year)."""
    cell = cell.strip()
    if len(cell) < 8 or not cell[:4].isdigit():  # a year first: not a header word
        return False
    try:
        _dt.datetime.fromisoformat(cell)
    except ValueError:
        return False
    return True


@dataclass
class Table:
    """Columns of one file. ``kinds``: ``"num"`` (a numeric array), ``"iso"`` (strings),
    ``"ns"`` (int64 nanoseconds since the epoch, e.g. datetime64), ``"text"`` (unusable)."""

    names: list[str]
    kinds: dict[str, str]
    get: Callable[[str], Any]
    n: int
    rows: np.ndarray | None = None  # file line numbers, for messages
    why_not: dict[str, str] = field(default_factory=dict)  # why a column is not numeric
    units: dict[str, str] = field(default_factory=dict)
    bad: dict[str, tuple[int, str]] = field(default_factory=dict)  # text: first bad cell


def _time_column_chosen(name: str, src: str) -> AdavarInputError:
    """The error for the time column ``name`` asked for as a channel."""
    return fail(
        f"column {name!r} of {src} is the time column: leave it out of --column (columns), "
        "name another time column with --time-column NAME, or analyse it as data with "
        "--time-column none (time_column='none') and --rate HZ"
    )


def _pick_time(
    tab: Table, time_column: str | int | None, exclude: set[str], src: str
) -> str | None:
    if no_time_column(time_column, tab.names):
        return None
    if time_column is not None:
        name = resolve(time_column, tab.names, src, "time column")
        if tab.kinds[name] == "text":
            raise fail(
                f"time column {name!r} in {src} holds neither numbers nor ISO 8601 times "
                f"({tab.why_not.get(name, 'not numeric')}): fix it or choose another column"
            )
        return name
    candidates = [
        n for n in tab.names if tab.kinds[n] != "text" and time_name_unit(n)[0]
    ]  # fmt: skip
    unread = [n for n in tab.names if tab.kinds[n] == "text" and time_name_unit(n)[0]]
    if not candidates and unread and unread[0] not in exclude:
        name = unread[0]
        raise fail(
            f"column {name!r} of {src} is named like time stamps but holds neither numbers "
            f"nor ISO 8601 times ({tab.why_not.get(name, 'text')}): write them as ISO 8601 "
            "(2024-03-05T12:00:00.01) or as numbers, or read the samples without them: "
            "--time-column none --rate HZ"
        )
    free = [n for n in candidates if n not in exclude]
    if len(free) > 1:  # 'T' (a temperature) beside 'time': no way to tell which
        names = ", ".join(repr(n) for n in free)
        raise fail(
            f"{src} has several columns named like time stamps ({names}): name the time "
            "column with --time-column NAME (time_column=), or --time-column none and "
            "--rate HZ"
        )
    if free:
        return free[0]
    if candidates:  # a channel: the stamps would be analysed as data
        raise _time_column_chosen(candidates[0], src)
    dated = [n for n in tab.names if n not in exclude and tab.kinds[n] in ("iso", "ns")]
    if len(dated) == 1:
        return dated[0]
    return None


def _time_from_table(
    tab: Table, name: str, time_format: str, src: str
) -> tuple[np.ndarray, float | None, dict[str, Any]]:
    """(seconds from the first valid stamp, with NaN where missing; absolute t0; meta)."""
    kind = tab.kinds[name]
    info: dict[str, Any] = {"time_column": name}
    if kind == "iso":
        if time_format not in ("auto", "iso"):
            raise fail(
                f"time column {name!r} in {src} holds date-times, not numbers: use "
                "time_format 'iso' (or 'auto')"
            )
        rel, t0, tz = _iso_seconds(tab.get(name), tab.rows, name, src)
        info.update(time_format="iso", timezone=tz, time_resolution=1e-6)
        return rel, t0, info
    if kind == "ns":
        values = np.asarray(_raw(tab.get(name)), dtype=np.int64)
        bad = values == np.iinfo(np.int64).min  # NaT
        rel = np.full(values.shape, np.nan)
        if (~bad).any():
            first = values[np.argmax(~bad)]
            rel[~bad] = (values[~bad] - first) / 1e9
            t0 = float(first) / 1e9
        else:
            t0 = None
        info.update(time_format="datetime", time_resolution=1e-9)
        return rel, t0, info
    if time_format == "iso":
        raise fail(
            f"time column {name!r} in {src} holds numbers, not ISO 8601 times: give "
            "time_format 's', 'ms', 'us', 'ns' or 'mjd' (or 'auto' for seconds)"
        )
    _, named_unit = time_name_unit(name)
    if time_format != "auto" and named_unit is not None and time_format != named_unit:
        raise fail(
            f"time_format {time_format!r} (--time-format {time_format}) contradicts the "
            f"unit written in the name of time column {name!r} of {src} ({named_unit}): "
            "leave out --time-format, or correct it (or the column name)"
        )
    if time_format != "auto":
        unit, how = time_format, "declared"
    elif named_unit is not None:
        unit, how = named_unit, "from the column name"
    else:
        unit, how = "s", "assumed: set time_format if the column is not in seconds"
    values = np.asarray(_raw(tab.get(name)))
    factor = _UNIT_FACTOR[unit]
    if np.issubdtype(values.dtype, np.integer):
        rel = (values - values[0]).astype(np.float64) * factor  # exact for int64 ns stamps
        first = float(values[0])
        resolution = factor  # one unit: the stamps are rounded to it
    else:
        values = values.astype(np.float64, copy=False)
        finite = np.isfinite(values)
        stamps = values if finite.all() else values[finite]
        first = float(stamps[0]) if stamps.size else math.nan
        rel = values - first
        rel *= factor
        # the largest |stamp|, from the extremes (no N-sample |values| array)
        largest = max(abs(float(stamps.max())), abs(float(stamps.min()))) if stamps.size else 0.0
        resolution = float(np.spacing(largest)) * factor  # float rounding of a stamp
    if how.startswith("assumed"):
        _check_seconds(values, first, name, src)
    t0 = (first - _MJD_UNIX_EPOCH) * 86400.0 if unit == "mjd" else first * factor
    info.update(time_format=unit, time_unit_source=how, time_resolution=resolution)
    return rel, (t0 if math.isfinite(t0) else None), info


def _check_seconds(values: np.ndarray, first: float, name: str, src: str) -> None:
    """Fail when a time column of no declared unit cannot be in seconds, or could as well be
    in ms, us or ns: stamps after the year 5000, or a median step of more than 1 (5 apart:
    0.2 Hz in seconds, 200 Hz in milliseconds), whole numbers or not: the median is not
    moved by a few fractional, jittery or missing stamps or by gaps. Whole seconds 1 apart
    (1 Hz) are read."""
    named = f"or in the column name (e.g. {name.strip()}_ms)"
    if math.isfinite(first) and abs(first) > 1e11:
        raise fail(
            f"time column {name!r} of {src} starts at {first:.4g}, too large for seconds "
            f"(after the year 5000): give its unit with time_format 'ms', 'us' or 'ns' "
            f"(--time-format), {named}"
        )
    if values.size < 2:
        return
    stamps = values
    if values.dtype.kind == "f":
        finite = np.isfinite(values)
        stamps = values if finite.all() else values[finite]
    if stamps.size < 2:
        return
    step = float(np.median(np.diff(stamps)))
    if _MJD_RANGE[0] <= first <= _MJD_RANGE[1] and 0 < step < 1.0 / _MJD_RATE:
        # days since 1858 (MJD) in a column called time: as seconds, megahertz
        raise fail(
            f"time column {name!r} of {src} starts at {first:.10g} and steps by {step:.3g}: "
            f"as seconds that is {1.0 / step:.4g} Hz, as Modified Julian Days "
            f"{1.0 / (step * 86400.0):.6g} Hz: give its unit with time_format 'mjd' or 's' "
            f"(--time-format), {named}"
        )
    if not step > _MAX_ASSUMED_STEP:  # also NaN: stamps going back are reported later
        return
    if stamps.dtype.kind != "f" or np.array_equal(stamps, np.round(stamps)):
        held = f"whole numbers {step:g} apart"
    else:
        held = f"stamps {step:.6g} apart (the median interval)"
    raise fail(
        f"time column {name!r} of {src} holds {held}, so its unit is unclear "
        f"({1 / step:.4g} Hz if they are seconds, {1000 / step:.4g} Hz if milliseconds): "
        f"give its unit with time_format 's', 'ms', 'us' or 'ns' (--time-format), {named}"
    )


def _iso_seconds(
    cells: Sequence[str], rows: np.ndarray | None, name: str, src: str
) -> tuple[np.ndarray, float | None, str]:
    stamps: list[_dt.datetime | None] = []
    for i, cell in enumerate(cells):
        text = cell.strip()
        if text.casefold() in MISSING:
            stamps.append(None)
            continue
        try:
            stamps.append(_dt.datetime.fromisoformat(text))
        except ValueError:
            raise fail(
                f"{src}: {locate(rows, i)}, time column {name!r} is not an ISO 8601 "
                f"date-time ({text!r}): fix or remove that row"
            ) from None
    valid = [s for s in stamps if s is not None]
    if not valid:
        return np.full(len(cells), np.nan), None, "none"
    aware = {s.tzinfo is not None for s in valid}
    if len(aware) > 1:
        raise fail(
            f"{src}: time column {name!r} mixes times with and without a UTC offset: "
            "give every time with an offset (e.g. Z), or none"
        )
    tz = "given" if aware.pop() else "none given, read as UTC"
    base = valid[0]
    step = _dt.timedelta(microseconds=1)
    micro = np.array(
        [np.nan if s is None else float((s - base) // step) for s in stamps], dtype=np.float64
    )
    first = base if base.tzinfo is not None else base.replace(tzinfo=_dt.UTC)
    return micro / 1e6, first.timestamp(), tz


def channels_from_table(
    tab: Table,
    *,
    columns: list[str | int] | None,
    time_column: str | int | None,
    time_format: str,
    src: str,
    allow_time: bool = True,
) -> tuple[dict[str, np.ndarray], np.ndarray | None, float | None, dict[str, Any]]:
    """(channels, seconds from the first stamp or None, t0, meta) of ``tab``."""
    if tab.n == 0:
        raise fail(f"{src} has no samples: give a file with data")
    chosen = None if columns is None else [resolve(c, tab.names, src) for c in columns]
    tname = None
    if allow_time:
        tname = _pick_time(tab, time_column, set(chosen or ()), src)
    if chosen is None:
        chosen = [n for n in tab.names if tab.kinds[n] == "num" and n != tname]
        if not chosen:
            described = ", ".join(
                f"{n!r} ({tab.why_not.get(n, tab.kinds[n])})" for n in tab.names[:10]
            )
            raise fail(
                f"{src} has no numeric column besides the time column ({described}): "
                "give a file with numeric samples, or name the columns with --column"
            )
    for name in chosen:
        if tab.kinds[name] != "num":
            reason = tab.why_not.get(name, "it holds date-times")
            raise fail(
                f"column {name!r} of {src} is not numeric ({reason}): choose numeric columns "
                "with --column"
            )
        if name == tname:
            raise _time_column_chosen(name, src)
    if len(set(chosen)) != len(chosen):
        raise fail(f"a column is named twice in --column ({', '.join(chosen)}): name each once")
    channels = {n: as_channel(tab.get(n), n, src, tab.rows) for n in chosen}
    info: dict[str, Any] = {"columns": list(tab.names), "channels": list(chosen)}
    units = {n: tab.units.get(n) or unit_in_name(n) for n in chosen}
    if any(units.values()):
        info["units"] = {n: u for n, u in units.items() if u}
    if tname is None:
        return channels, None, None, info
    rel, t0, tinfo = _time_from_table(tab, tname, time_format, src)
    info.update(tinfo)
    return channels, rel, t0, info


def _raw(values: Any) -> Any:
    """A column's values as stored (a source read whole with file reads: exact integers)."""
    if isinstance(values, ChunkedSource):
        return values.read_unchecked(0, values.size)
    return values


def as_channel(
    values: Any, name: str = "", src: str = "", rows: np.ndarray | None = None
) -> np.ndarray:
    """float64 samples; a memory-mapped file column stays mapped, in the file's own dtype,
    and a column read piece by piece stays a source, so that a record larger than memory is
    never read whole (the analyses stream it, checking each piece as they read it).

    Integers beyond 2**53 are refused: float64 would round them (silently flattening the
    noise of a record with a large offset)."""
    if isinstance(values, ChunkedSource):
        return values  # type: ignore[return-value]
    if (
        isinstance(values, np.memmap)
        and values.ndim == 1
        and values.dtype.kind in "fiu"
        and memmap_source(values) is not None
    ):
        return values
    values = np.asarray(values)
    check_exact_integers(values, f"column {name!r} of {src}", where=lambda i: locate(rows, i))
    return np.asarray(values, dtype=np.float64)


def numeric_kind(dtype: np.dtype) -> str:
    """The :class:`Table` kind of a column of ``dtype``."""
    if np.issubdtype(dtype, np.datetime64):
        return "ns"
    if dtype.kind in "iuf":
        return "num"
    return "text"


def array_table(arr: np.ndarray, src: str, label: str) -> Table:
    """Columns of one array: fields of a structured array, columns of a 2-D array, or the
    single column of a 1-D array (named ``label``)."""
    if arr.dtype.names:
        if arr.ndim != 1:
            raise fail(f"{src}: a structured array must be 1-D, got shape {arr.shape}")
        names = list(arr.dtype.names)
        kinds = {n: numeric_kind(arr.dtype[n]) for n in names}
        return Table(names, kinds, lambda n: dt64_ns(arr[n]), len(arr))
    kind = numeric_kind(arr.dtype)
    if arr.dtype.hasobject or kind == "text":
        raise fail(f"{src} holds {arr.dtype} values, not numbers: save a numeric array")
    if arr.ndim == 1:
        return Table([label], {label: kind}, lambda n: dt64_ns(arr), len(arr))
    if arr.ndim == 2:
        if arr.shape[0] < arr.shape[1]:  # (7, 20000) read as 7 samples of 20000 channels
            raise fail(
                f"{src} holds an array of shape {arr.shape}: fewer rows than columns, so it "
                "looks stored as channels x samples; adavar reads samples x channels: save "
                "its transpose (x.T)"
            )
        names = [str(j) for j in range(arr.shape[1])]
        return Table(
            names, dict.fromkeys(names, kind), lambda n: dt64_ns(arr[:, int(n)]), arr.shape[0]
        )
    raise fail(
        f"{src} holds an array of shape {arr.shape}: give a 1-D array, or 2-D (samples x channels)"
    )


def dt64_ns(values: np.ndarray) -> np.ndarray:
    """datetime64 values as int64 nanoseconds since the epoch, other values as they are."""
    if np.issubdtype(values.dtype, np.datetime64):
        return values.astype("datetime64[ns]").astype(np.int64)
    return values

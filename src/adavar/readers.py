"""Reading sensor and clock records from the files people actually have.

:func:`read_record` reads one or several channels of a record, with its sampling rate and
(when the file has one) its time base, from:

=================================  ============  ==========================================
file                               ``kind``      needs
=================================  ============  ==========================================
``.csv .tsv .txt .dat``            "csv"         nothing (NumPy)
``.phd .frd`` (Stable32)           "stable32"    nothing
``.npy``                           "npy"         nothing (memory-mapped)
``.npz``                           "npz"         nothing (uncompressed members memory-mapped)
``.h5 .hdf5 .he5``                 "hdf5"        h5py
``.parquet .pq``                   "parquet"     pyarrow
ROS 2 bag folder (or its           "ros2"        rosbags (sqlite3 or MCAP storage)
``.db3`` / ``.mcap`` file)
ROS 1 ``.bag``                     "ros1"        rosbags
=================================  ============  ==========================================

Nothing is guessed silently: the sampling rate comes from a time column (or time stamps)
or is declared with ``rate``; a numeric time column is in seconds unless its name carries
a unit (``t_ms``, ``time [us]``, ``stamp_ns``) or ``time_format`` says otherwise; every
step taken (rows dropped, gaps split or filled, samples interpolated) is listed in
:attr:`Record.meta` so a result can be reproduced.

Every problem with the input raises :class:`adavar.errors.AdavarInputError` with a
one-line message that names the problem, where it is, and the way out.
"""

from __future__ import annotations

import csv
import datetime as _dt
import itertools
import math
import numbers
import os
import re
import struct
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from adavar.errors import AdavarInputError
from adavar.stream import (
    DEFAULT_CHUNK,
    ChunkedSource,
    HDF5Source,
    ParquetSource,
    available_memory,
    memmap_source,
)

__all__ = [
    "GAP_POLICIES",
    "NAN_POLICIES",
    "SUFFIXES",
    "TIME_FORMATS",
    "Record",
    "read_record",
]

#: Values of ``gaps``: what to do with gaps and non-uniform sampling in a time base.
GAP_POLICIES = ("error", "split", "interpolate")
#: Values of ``nan``: what to do with NaN / infinite / empty samples.
NAN_POLICIES = ("error", "drop", "interpolate")
#: Values of ``time_format``.
TIME_FORMATS = ("auto", "s", "ms", "us", "ns", "iso", "mjd")
#: File-name suffix -> reader kind (ROS 2 bags are also recognised as folders).
SUFFIXES: dict[str, str] = {
    ".csv": "csv",
    ".tsv": "csv",
    ".txt": "csv",
    ".dat": "csv",
    ".phd": "stable32",
    ".frd": "stable32",
    ".npy": "npy",
    ".npz": "npz",
    ".h5": "hdf5",
    ".hdf5": "hdf5",
    ".he5": "hdf5",
    ".parquet": "parquet",
    ".pq": "parquet",
    ".bag": "ros1",
    ".db3": "ros2",
    ".mcap": "ros2",
}

#: Lines starting with one of these (after leading blanks) are comments in text files.
COMMENT_PREFIXES = ("#", "%")
#: Cells read as a missing sample (NaN) in text files (case-insensitive).
_MISSING = frozenset({"", "na", "n/a", "nan", "null", "none", "nat", "-nan", "+nan"})
_UNIT_FACTOR = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "mjd": 86400.0}
_UNIT_ALIASES = {"sec": "s", "secs": "s", "seconds": "s", "µs": "us", "μs": "us"}
_MJD_UNIX_EPOCH = 40587.0
#: Column / field / key names taken for a time column when ``time_column`` is not given.
_TIME_NAME = re.compile(
    r"^(?:t|time|times|timestamp|timestamps|time_stamp|datetime|date_time|stamp|epoch|utc"
    r"|elapsed|elapsed_time|mjd)"
    r"(?:\s*[_\-\s]?\s*[\[(]?\s*(?P<unit>s|sec|secs|seconds|ms|us|µs|μs|ns)\s*[\])]?)?$",
    re.IGNORECASE,
)
_IMU_CHANNELS = {
    "gx": ("angular_velocity", "x"),
    "gy": ("angular_velocity", "y"),
    "gz": ("angular_velocity", "z"),
    "ax": ("linear_acceleration", "x"),
    "ay": ("linear_acceleration", "y"),
    "az": ("linear_acceleration", "z"),
}
_IMU_UNITS = {"gx": "rad/s", "gy": "rad/s", "gz": "rad/s", "ax": "m/s^2", "ay": "m/s^2",
              "az": "m/s^2"}  # fmt: skip
_IMU_TYPE = "sensor_msgs/msg/Imu"
_RATE_AGREEMENT = 0.01  # a declared rate and a time column must agree within 1 %
_MAX_LISTED = 50  # gaps / dropped rows listed one by one in meta


def _fail(message: str) -> AdavarInputError:
    return AdavarInputError(" ".join(str(message).split()))


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 160 else text[:157] + "..."


# --------------------------------------------------------------------------------------
# The record
# --------------------------------------------------------------------------------------


@dataclass
class Record:
    """Channels of a uniformly sampled record, with where they came from.

    Attributes
    ----------
    channels : dict of str to ndarray
        Samples per channel (all the same length, in file order): float64, except columns
        of ``.npy``/uncompressed ``.npz`` files, which stay read-only memory-mapped views
        in the file's dtype (the analyses read them piece by piece; ``np.asarray(...,
        dtype=float)`` loads one).
    rate : float
        Sampling rate (Hz).
    time : ndarray or None
        Time of every sample in seconds from the first one (float64), when the file has a
        time base; None when the rate was only declared.
    t0 : float or None
        Absolute time of the first sample, in the time column's own scale: seconds since
        1970-01-01 UTC for ISO 8601, MJD, datetime and ROS time stamps (naive ISO times are
        read as UTC), otherwise the first value of the numeric time column in seconds.
        None without a time base.
    source : str
        The path read.
    kind : str
        The reader: ``"csv"``, ``"stable32"``, ``"npy"``, ``"npz"``, ``"hdf5"``,
        ``"parquet"``, ``"ros2"`` or ``"ros1"``.
    meta : dict
        What was read and done (JSON-serialisable): the options, the time source, rate
        source, units declared by the format, NaN rows dropped or values interpolated,
        gaps found and how they were handled...
    segments : list of slice or None
        With ``gaps="split"``: the contiguous gap-free pieces, as slices into every
        channel (and ``time``); None otherwise.
    """

    channels: dict[str, np.ndarray]
    rate: float
    time: np.ndarray | None = None
    t0: float | None = None
    source: str = ""
    kind: str = ""
    meta: dict[str, Any] = field(default_factory=dict)
    segments: list[slice] | None = None

    @property
    def names(self) -> list[str]:
        """The channel names, in order."""
        return list(self.channels)

    @property
    def n_samples(self) -> int:
        """Number of samples per channel."""
        return len(next(iter(self.channels.values()))) if self.channels else 0

    def __len__(self) -> int:
        return self.n_samples

    def channel(self, name: str | None = None) -> np.ndarray:
        """One channel's samples.

        Parameters
        ----------
        name : str, optional
            The channel (exact, or case-insensitive if that is unique); may be omitted when
            the record has only one channel.

        Returns
        -------
        ndarray of float64

        Raises
        ------
        AdavarInputError
            An unknown name, or no name with several channels.
        """
        if name is None:
            if len(self.channels) == 1:
                return next(iter(self.channels.values()))
            raise _fail(
                f"{self.source} has {len(self.channels)} channels ({', '.join(self.names)}): "
                "choose one with --column NAME"
            )
        return self.channels[_resolve(name, self.names, self.source, "channel")]

    def pieces(self, name: str | None = None) -> list[np.ndarray]:
        """The channel cut into its gap-free segments (one piece when not split)."""
        values = self.channel(name)
        if self.segments is None:
            return [values]
        return [values[s] for s in self.segments]


# --------------------------------------------------------------------------------------
# Small helpers
# --------------------------------------------------------------------------------------


def _resolve(key: str | int, names: Sequence[str], src: str, what: str = "column") -> str:
    """The name of ``key`` (a name, case-insensitive if unique, or a 0-based index)."""
    if isinstance(key, bool):
        raise _fail(f"{what} must be a name or a 0-based index, got {key!r}")
    listed = ", ".join(repr(n) for n in names[:30]) + (", ..." if len(names) > 30 else "")
    if isinstance(key, str):
        text = key.strip()
        if text in names:
            return text
        folded = [n for n in names if n.casefold() == text.casefold()]
        if len(folded) == 1:
            return folded[0]
        if not text.lstrip("+").isdigit():
            raise _fail(f"unknown {what} {key!r} in {src}; available: {listed}")
        key = int(text)
    if isinstance(key, (int, np.integer)) and 0 <= int(key) < len(names):
        return names[int(key)]
    raise _fail(f"{what} {key!r} is not in {src}; available: {listed}")


def _as_list(columns: str | int | Sequence[str | int] | None) -> list[str | int] | None:
    if columns is None:
        return None
    if isinstance(columns, str):
        items: list[str | int] = [c.strip() for c in columns.split(",") if c.strip()]
    elif isinstance(columns, (int, np.integer)):
        items = [int(columns)]
    else:
        items = list(columns)
    if not items:
        raise _fail("columns is empty: give at least one column name, or leave it out")
    return items


def _time_name_unit(name: str) -> tuple[bool, str | None]:
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


def _is_iso(cell: str) -> bool:
    cell = cell.strip()
    if len(cell) < 8 or not cell[:4].isdigit():  # a year first: not a header word
        return False
    try:
        _dt.datetime.fromisoformat(cell)
    except ValueError:
        return False
    return True


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


# --------------------------------------------------------------------------------------
# A table of columns, common to text, NumPy, HDF5 and Parquet
# --------------------------------------------------------------------------------------


@dataclass
class _Table:
    """Columns of one file. ``kinds``: ``"num"`` (a numeric array), ``"iso"`` (strings),
    ``"ns"`` (int64 nanoseconds since the epoch, e.g. datetime64), ``"text"`` (unusable)."""

    names: list[str]
    kinds: dict[str, str]
    get: Callable[[str], Any]
    n: int
    rows: np.ndarray | None = None  # file line numbers, for messages
    why_not: dict[str, str] = field(default_factory=dict)  # why a column is not numeric
    units: dict[str, str] = field(default_factory=dict)


def _where(rows: np.ndarray | None, i: int, word: str = "sample") -> str:
    return f"row {int(rows[i])}" if rows is not None else f"{word} {i}"


def _pick_time(
    tab: _Table, time_column: str | int | None, exclude: set[str], src: str
) -> str | None:
    if time_column is not None:
        name = _resolve(time_column, tab.names, src, "time column")
        if tab.kinds[name] == "text":
            raise _fail(
                f"time column {name!r} in {src} holds neither numbers nor ISO 8601 times "
                f"({tab.why_not.get(name, 'not numeric')}): fix it or choose another column"
            )
        return name
    candidates = [
        n for n in tab.names
        if n not in exclude and tab.kinds[n] != "text" and _time_name_unit(n)[0]
    ]  # fmt: skip
    if candidates:
        return candidates[0]
    dated = [n for n in tab.names if n not in exclude and tab.kinds[n] in ("iso", "ns")]
    if len(dated) == 1:
        return dated[0]
    return None


def _time_from_table(
    tab: _Table, name: str, time_format: str, src: str
) -> tuple[np.ndarray, float | None, dict[str, Any]]:
    """(seconds from the first valid stamp, with NaN where missing; absolute t0; meta)."""
    kind = tab.kinds[name]
    info: dict[str, Any] = {"time_column": name}
    if kind == "iso":
        if time_format not in ("auto", "iso"):
            raise _fail(
                f"time column {name!r} in {src} holds date-times, not numbers: use "
                "time_format 'iso' (or 'auto')"
            )
        rel, t0, tz = _iso_seconds(tab.get(name), tab.rows, name, src)
        info.update(time_format="iso", timezone=tz)
        return rel, t0, info
    if kind == "ns":
        values = np.asarray(tab.get(name), dtype=np.int64)
        bad = values == np.iinfo(np.int64).min  # NaT
        rel = np.full(values.shape, np.nan)
        if (~bad).any():
            first = values[np.argmax(~bad)]
            rel[~bad] = (values[~bad] - first) / 1e9
            t0 = float(first) / 1e9
        else:
            t0 = None
        info.update(time_format="datetime")
        return rel, t0, info
    if time_format == "iso":
        raise _fail(
            f"time column {name!r} in {src} holds numbers, not ISO 8601 times: give "
            "time_format 's', 'ms', 'us', 'ns' or 'mjd' (or 'auto' for seconds)"
        )
    _, named_unit = _time_name_unit(name)
    if time_format != "auto":
        unit, how = time_format, "declared"
    elif named_unit is not None:
        unit, how = named_unit, "from the column name"
    else:
        unit, how = "s", "assumed: set time_format if the column is not in seconds"
    values = np.asarray(tab.get(name))
    factor = _UNIT_FACTOR[unit]
    if np.issubdtype(values.dtype, np.integer):
        rel = (values - values[0]).astype(np.float64) * factor  # exact for int64 ns stamps
        first = float(values[0])
    else:
        values = values.astype(np.float64, copy=False)
        finite = np.isfinite(values)
        first = float(values[np.argmax(finite)]) if finite.any() else math.nan
        rel = (values - first) * factor
    if how.startswith("assumed") and math.isfinite(first) and abs(first) > 1e11:
        raise _fail(
            f"time column {name!r} of {src} starts at {first:.4g}, too large for seconds "
            "(after the year 5000): give its unit with time_format 'ms', 'us' or 'ns' "
            "(--time-format)"
        )
    t0 = (first - _MJD_UNIX_EPOCH) * 86400.0 if unit == "mjd" else first * factor
    info.update(time_format=unit, time_unit_source=how)
    return rel, (t0 if math.isfinite(t0) else None), info


def _iso_seconds(
    cells: Sequence[str], rows: np.ndarray | None, name: str, src: str
) -> tuple[np.ndarray, float | None, str]:
    stamps: list[_dt.datetime | None] = []
    for i, cell in enumerate(cells):
        text = cell.strip()
        if text.casefold() in _MISSING:
            stamps.append(None)
            continue
        try:
            stamps.append(_dt.datetime.fromisoformat(text))
        except ValueError:
            raise _fail(
                f"{src}: {_where(rows, i)}, time column {name!r} is not an ISO 8601 "
                f"date-time ({text!r}): fix or remove that row"
            ) from None
    valid = [s for s in stamps if s is not None]
    if not valid:
        return np.full(len(cells), np.nan), None, "none"
    aware = {s.tzinfo is not None for s in valid}
    if len(aware) > 1:
        raise _fail(
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


def _channels_from_table(
    tab: _Table,
    *,
    columns: list[str | int] | None,
    time_column: str | int | None,
    time_format: str,
    src: str,
    allow_time: bool = True,
) -> tuple[dict[str, np.ndarray], np.ndarray | None, float | None, dict[str, Any]]:
    if tab.n == 0:
        raise _fail(f"{src} has no samples: give a file with data")
    chosen = None if columns is None else [_resolve(c, tab.names, src) for c in columns]
    tname = None
    if allow_time:
        tname = _pick_time(tab, time_column, set(chosen or ()), src)
    if chosen is None:
        chosen = [n for n in tab.names if tab.kinds[n] == "num" and n != tname]
        if not chosen:
            described = ", ".join(
                f"{n!r} ({tab.why_not.get(n, tab.kinds[n])})" for n in tab.names[:10]
            )
            raise _fail(
                f"{src} has no numeric column besides the time column ({described}): "
                "give a file with numeric samples, or name the columns with --column"
            )
    for name in chosen:
        if tab.kinds[name] != "num":
            reason = tab.why_not.get(name, "it holds date-times")
            raise _fail(
                f"column {name!r} of {src} is not numeric ({reason}): choose numeric columns "
                "with --column"
            )
        if name == tname:
            raise _fail(
                f"column {name!r} of {src} is the time column: choose other columns, or "
                "another time column with --time-column"
            )
    if len(set(chosen)) != len(chosen):
        raise _fail(f"a column is named twice in --column ({', '.join(chosen)}): name each once")
    channels = {n: _as_channel(tab.get(n)) for n in chosen}
    info: dict[str, Any] = {"columns": list(tab.names), "channels": list(chosen)}
    if tab.units:
        info["units"] = {n: tab.units[n] for n in chosen if n in tab.units}
    if tname is None:
        return channels, None, None, info
    rel, t0, tinfo = _time_from_table(tab, tname, time_format, src)
    info.update(tinfo)
    return channels, rel, t0, info


# --------------------------------------------------------------------------------------
# Text (CSV / TSV / whitespace / Stable32)
# --------------------------------------------------------------------------------------


def _read_lines(path: Path) -> list[tuple[int, str]]:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise _fail(
            f"{path} is not a UTF-8 text file: export the data as plain CSV or text"
        ) from None
    except OSError as exc:
        raise _fail(f"cannot read {path}: {exc.strerror or exc}") from None
    return [
        (number, line)
        for number, raw in enumerate(text.splitlines(), start=1)
        if (line := raw.strip()) and not line.startswith(COMMENT_PREFIXES)
    ]


def _split(text: str, delim: str | None) -> list[str]:
    if delim is None:
        return text.split()
    if text.endswith(delim):  # one trailing separator is common in exported files
        text = text[: -len(delim)]
    row = next(csv.reader([text], delimiter=delim, skipinitialspace=True), [])
    return [cell.strip() for cell in row]


def _sniff(sample: list[str]) -> str | None:
    """Tab, semicolon or comma (in that order) if it splits most sample lines into the
    same number (> 1) of fields; otherwise None (runs of whitespace)."""
    for delim in ("\t", ";", ","):
        counts = [len(_split(line, delim)) for line in sample]
        best = max(set(counts), key=counts.count)
        if best > 1 and 2 * counts.count(best) > len(counts):
            return delim
    return None


def _is_data(cells: list[str]) -> bool:
    """A data row: at least half of its non-empty cells are numbers (NaN and Inf count) or
    ISO 8601 times, and it has at least one (header words and preamble sentences do not)."""
    filled = [cell for cell in cells if cell]
    values = sum(1 for cell in filled if _is_number(cell) or _is_iso(cell))
    return values > 0 and 2 * values >= len(filled)


_DELIM_NAMES = {",": "comma", ";": "semicolon", "\t": "tab", None: "whitespace"}


def _text_table(path: Path, src: str, *, preamble: bool) -> tuple[_Table, dict[str, Any]]:
    lines = _read_lines(path)
    if not lines:
        raise _fail(f"{src} is empty (no data rows): give a file with one sample per row")
    delim = _sniff([text for _, text in lines[-50:]])
    # header / preamble: the non-data lines before the first data line
    counts = [len(_split(text, delim)) for _, text in lines[-50:]]
    width = max(set(counts), key=counts.count)  # fields in a data row
    first_data = None
    for k, (_, text) in enumerate(lines[:1000]):
        cells = _split(text, delim)
        if len(cells) == width and _is_data(cells):
            first_data = k
            break
    if first_data is None:
        within = " in its first 1000 lines" if len(lines) > 1000 else ""
        raise _fail(f"{src} has no numeric data rows{within}: give a file with one sample per row")
    data = lines[first_data:]
    n_cols = len(_split(data[0][1], delim))
    if first_data > 1 and not preamble and n_cols > 1:
        number = lines[1][0]
        raise _fail(
            f"{src}: row {number} is neither a number row nor the header: remove the extra "
            "header lines or comment them out with #"
        )
    names: list[str] | None = None
    if first_data >= 1:
        head = _split(lines[first_data - 1][1], delim)
        if len(head) == n_cols and (n_cols > 1 or first_data == 1):
            names = [cell if cell else f"column {j}" for j, cell in enumerate(head)]
    has_header = names is not None
    if names is None:
        names = [str(j) for j in range(n_cols)]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise _fail(f"{src}: the header names column {dupes[0]!r} twice: rename one of them")
    numbers = np.array([number for number, _ in data], dtype=np.int64)
    texts = [text for _, text in data]
    if delim is not None and any(text.endswith(delim) for text in texts):
        texts = [text[: -len(delim)] if text.endswith(delim) else text for text in texts]
    if delim is None:
        rows = [text.split() for text in texts]
    elif not any('"' in text for text in texts):
        rows = [text.split(delim) for text in texts]  # cells stripped below where needed
    else:
        reader = csv.reader(texts, delimiter=delim, skipinitialspace=True)
        rows = [[cell.strip() for cell in row] for row in reader]
    if len({len(row) for row in rows}) > 1 or len(rows[0]) != n_cols:
        for i, row in enumerate(rows):
            if len(row) != n_cols:
                raise _fail(
                    f"{src}: row {numbers[i]} has {len(row)} fields, expected {n_cols} "
                    f"({_DELIM_NAMES[delim]}-separated): fix or remove that row"
                )
    cols: list[Sequence[str]] = list(zip(*rows, strict=True))
    del rows
    kinds: dict[str, str] = {}
    why_not: dict[str, str] = {}
    parsed: dict[str, np.ndarray] = {}
    for j, name in enumerate(names):
        values = _parse_numeric(cols[j])
        if values is not None:
            kinds[name], parsed[name] = "num", values
            continue
        cells = cols[j] = [cell.strip() for cell in cols[j]]
        if all(c.casefold() in _MISSING or _is_iso(c) for c in cells[:200]) and any(
            _is_iso(c) for c in cells[:200]
        ):
            kinds[name] = "iso"
            continue
        kinds[name] = "text"
        for i, cell in enumerate(cells):
            if cell.casefold() not in _MISSING and not _is_number(cell):
                hint = "; decimal commas are not read" if _is_number(cell.replace(",", ".")) else ""
                why_not[name] = f"row {numbers[i]}: {cell!r}{hint}"
                break
    by_name = dict(zip(names, cols, strict=True))

    def get(name: str) -> Any:
        return parsed[name] if name in parsed else by_name[name]

    tab = _Table(names, kinds, get, len(numbers), numbers, why_not)
    meta = {
        "delimiter": _DELIM_NAMES[delim],
        "header": has_header,
        "skipped_lines_before_data": first_data,
    }
    return tab, meta


def _parse_numeric(cells: Sequence[str]) -> np.ndarray | None:
    """The cells as int64 (if all are integers) or float64 (missing cells NaN), or None."""
    try:
        return np.array(cells, dtype=np.int64)
    except (ValueError, OverflowError):
        pass
    try:
        return np.array(cells, dtype=np.float64)
    except ValueError:
        pass
    filled = ["nan" if c.strip().casefold() in _MISSING else c for c in cells]
    if all(c == "nan" for c in filled):
        return None
    try:
        return np.array(filled, dtype=np.float64)
    except ValueError:
        return None


def _read_text(path: Path, src: str, opts: dict[str, Any], *, stable32: bool) -> _Raw:
    tab, meta = _text_table(path, src, preamble=stable32)
    time_column, time_format = opts["time_column"], opts["time_format"]
    columns = opts["columns"]
    if stable32:
        quantity = "phase" if path.suffix.lower() == ".phd" else "frequency"
        if len(tab.names) > 2:
            raise _fail(
                f"{src} has {len(tab.names)} columns; a Stable32 file has one (data) or two "
                "(MJD time tag, data): export one column, or rename the file to .csv"
            )
        if len(tab.names) == 2 and time_column is None:
            time_column = tab.names[0]
            if time_format == "auto":
                time_format = "mjd"  # Stable32 time tags are Modified Julian Dates
        data_name = tab.names[-1]
        if columns is None:
            columns = [data_name]
        meta["quantity"] = quantity
    channels, rel, t0, info = _channels_from_table(
        tab, columns=columns, time_column=time_column, time_format=time_format, src=src
    )
    if stable32 and list(channels) == [tab.names[-1]]:
        channels = {meta["quantity"]: channels[tab.names[-1]]}
        info["channels"] = [meta["quantity"]]
    meta.update(info)
    return _Raw(channels, rel, t0, tab.rows, "row", meta)


# --------------------------------------------------------------------------------------
# NumPy
# --------------------------------------------------------------------------------------


def _numeric_kind(dtype: np.dtype) -> str:
    if np.issubdtype(dtype, np.datetime64):
        return "ns"
    if dtype.kind in "iuf":
        return "num"
    return "text"


#: auto ``lazy``: read a file column piece by piece from this size (bytes) or a quarter
#: of the available memory, whichever is smaller
LAZY_BYTES = 1 << 30


def _lazy_wanted(opts: dict[str, Any], nbytes: int) -> bool:
    lazy = opts.get("lazy")
    if lazy is not None:
        return bool(lazy)
    if opts.get("nan", "error") != "error" or opts.get("time_column") is not None:
        return False
    free = available_memory()
    limit = LAZY_BYTES if free is None else min(LAZY_BYTES, free // 4)
    return nbytes > limit


def _lazy_refused(src: str, why: str) -> AdavarInputError:
    return _fail(f"{src} cannot be read piece by piece ({why}): leave out lazy=True / --lazy")


def _as_channel(values: Any) -> np.ndarray:
    """float64 samples; a memory-mapped file column stays mapped, in the file's own dtype,
    so that a record larger than memory is never read whole (the analyses stream it)."""
    if isinstance(values, ChunkedSource):
        return values  # type: ignore[return-value]
    if (
        isinstance(values, np.memmap)
        and values.ndim == 1
        and values.dtype.kind in "fiu"
        and memmap_source(values) is not None
    ):
        return values
    return np.asarray(values, dtype=np.float64)


def _array_table(arr: np.ndarray, src: str, label: str) -> _Table:
    """Columns of one array: fields of a structured array, columns of a 2-D array, or the
    single column of a 1-D array (named ``label``)."""
    if arr.dtype.names:
        if arr.ndim != 1:
            raise _fail(f"{src}: a structured array must be 1-D, got shape {arr.shape}")
        names = list(arr.dtype.names)
        kinds = {n: _numeric_kind(arr.dtype[n]) for n in names}
        return _Table(names, kinds, lambda n: _dt64_ns(arr[n]), len(arr))
    kind = _numeric_kind(arr.dtype)
    if arr.dtype.hasobject or kind == "text":
        raise _fail(f"{src} holds {arr.dtype} values, not numbers: save a numeric array")
    if arr.ndim == 1:
        return _Table([label], {label: kind}, lambda n: _dt64_ns(arr), len(arr))
    if arr.ndim == 2:
        names = [str(j) for j in range(arr.shape[1])]
        return _Table(
            names, dict.fromkeys(names, kind), lambda n: _dt64_ns(arr[:, int(n)]), arr.shape[0]
        )
    raise _fail(
        f"{src} holds an array of shape {arr.shape}: give a 1-D array, or 2-D (samples x channels)"
    )


def _dt64_ns(values: np.ndarray) -> np.ndarray:
    if np.issubdtype(values.dtype, np.datetime64):
        return values.astype("datetime64[ns]").astype(np.int64)
    return values


def _read_npy(path: Path, src: str, opts: dict[str, Any]) -> _Raw:
    with open(path, "rb") as fh:
        if fh.read(6) != b"\x93NUMPY":
            raise _fail(f"{src} is not a valid .npy file (no NumPy header): re-save it")
    try:
        arr = np.load(path, mmap_mode="r", allow_pickle=False)
    except ValueError as exc:
        if "pickle" in str(exc).casefold() or "object" in str(exc).casefold():
            raise _fail(
                f"{src} holds Python objects (needs pickle, which is not loaded for safety): "
                "save a plain numeric array"
            ) from None
        raise _fail(f"{src} is not a valid .npy file ({_one_line(exc)}): re-save it") from None
    except (OSError, EOFError) as exc:
        raise _fail(f"{src} is not a valid .npy file ({_one_line(exc)}): re-save it") from None
    tab = _array_table(arr, src, "0")
    channels, rel, t0, info = _channels_from_table(
        tab, columns=opts["columns"], time_column=opts["time_column"],
        time_format=opts["time_format"], src=src,
    )  # fmt: skip
    info.update(memory_mapped=isinstance(arr, np.memmap), shape=list(arr.shape))
    return _Raw(channels, rel, t0, None, "sample", info)


def _npz_member_memmap(path: Path, info: zipfile.ZipInfo) -> np.ndarray | None:
    """A read-only memory map of a stored (uncompressed) ``.npy`` member, or None."""
    if info.compress_type != zipfile.ZIP_STORED or info.flag_bits & 0x1:
        return None
    fmt = np.lib.format
    with open(path, "rb") as fh:
        fh.seek(info.header_offset)
        local = fh.read(30)
        if len(local) != 30 or local[:4] != b"PK\x03\x04":
            return None
        name_len, extra_len = struct.unpack("<HH", local[26:30])
        fh.seek(info.header_offset + 30 + name_len + extra_len)
        version = fmt.read_magic(fh)
        if version == (1, 0):
            shape, fortran, dtype = fmt.read_array_header_1_0(fh)
        elif version == (2, 0):
            shape, fortran, dtype = fmt.read_array_header_2_0(fh)
        else:
            return None
        offset = fh.tell()
    if dtype.hasobject or math.prod(shape) == 0:
        return None
    return np.memmap(
        path, dtype=dtype, mode="r", offset=offset, shape=shape, order="F" if fortran else "C"
    )


def _read_npz(path: Path, src: str, opts: dict[str, Any]) -> _Raw:
    arrays: dict[str, np.ndarray] = {}
    mapped: list[str] = []
    try:
        with zipfile.ZipFile(path) as zf, np.load(path, allow_pickle=False) as npz:
            infos = {i.filename[:-4]: i for i in zf.infolist() if i.filename.endswith(".npy")}
            for key in npz.files:
                arr = _npz_member_memmap(path, infos[key]) if key in infos else None
                if arr is None:
                    arr = npz[key]
                else:
                    mapped.append(key)
                arrays[key] = arr
    except ValueError as exc:
        if "pickle" in str(exc).casefold() or "object" in str(exc).casefold():
            raise _fail(
                f"{src} holds Python objects (needs pickle, which is not loaded for safety): "
                "save plain numeric arrays"
            ) from None
        raise _fail(f"{src} is not a valid .npz file ({_one_line(exc)}): re-save it") from None
    except (OSError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise _fail(f"{src} is not a valid .npz file ({_one_line(exc)}): re-save it") from None
    if not arrays:
        raise _fail(f"{src} holds no arrays: save the samples with numpy.savez")
    if len(arrays) == 1 and next(iter(arrays.values())).ndim != 1:
        key, arr = next(iter(arrays.items()))
        tab = _array_table(arr, src, key)
    else:
        series = {
            k: a for k, a in arrays.items()
            if a.ndim == 1 and not a.dtype.names and _numeric_kind(a.dtype) != "text"
        }  # fmt: skip
        lengths = {len(a) for a in series.values()}
        if not series:
            raise _fail(
                f"{src} holds no 1-D numeric array (keys: {', '.join(arrays)}): save each "
                "channel as a 1-D array"
            )
        if len(lengths) > 1:
            sizes = ", ".join(f"{k}: {len(a)}" for k, a in series.items())
            raise _fail(
                f"the 1-D arrays of {src} differ in length ({sizes}): save channels of equal length"
            )
        names = list(series)
        tab = _Table(
            names, {k: _numeric_kind(a.dtype) for k, a in series.items()},
            lambda n: _dt64_ns(series[n]), lengths.pop(),
        )  # fmt: skip
    channels, rel, t0, info = _channels_from_table(
        tab, columns=opts["columns"], time_column=opts["time_column"],
        time_format=opts["time_format"], src=src,
    )  # fmt: skip
    info.update(
        keys=list(arrays), memory_mapped=bool(mapped) and all(k in mapped for k in channels)
    )
    return _Raw(channels, rel, t0, None, "sample", info)


# --------------------------------------------------------------------------------------
# HDF5
# --------------------------------------------------------------------------------------


def _require(module: str, what: str) -> Any:
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        package = module.split(".")[0]
        raise _fail(
            f"reading {what} needs {package}, which is not installed: pip install {package}"
        ) from None


def _read_hdf5(path: Path, src: str, opts: dict[str, Any]) -> _Raw:
    h5py = _require("h5py", "HDF5")
    try:
        handle = h5py.File(path, "r")
    except OSError as exc:
        raise _fail(f"{src} is not a readable HDF5 file ({_one_line(exc)}): re-export it") from None
    with handle as f:
        found: list[str] = []

        def visit(name: str, obj: Any) -> None:
            if (
                isinstance(obj, h5py.Dataset)
                and (obj.dtype.names or _numeric_kind(obj.dtype) != "text")
                and obj.ndim in (1, 2)
            ):
                found.append("/" + name)

        f.visititems(visit)
        listed = ", ".join(found[:10]) + (", ..." if len(found) > 10 else "")
        dataset = opts["dataset"]
        if dataset is not None:
            obj = f.get(dataset)
            if obj is None:
                raise _fail(
                    f"no dataset {dataset!r} in {src}; numeric datasets: {listed or 'none'}"
                )
        elif len(found) == 1:
            obj = f[found[0]]
        elif not found:
            raise _fail(f"{src} holds no numeric 1-D or 2-D dataset: give another file")
        else:
            parents = {p.rsplit("/", 1)[0] for p in found}
            lengths = {f[p].shape[0] for p in found}
            if len(parents) == 1 and len(lengths) == 1 and all(f[p].ndim == 1 for p in found):
                obj = f[parents.pop() or "/"]
            else:
                raise _fail(
                    f"{src} holds {len(found)} numeric datasets ({listed}): choose one (or a "
                    "group of 1-D datasets) with --dataset PATH"
                )
        if isinstance(obj, h5py.Group):
            members = {
                k: v for k, v in obj.items()
                if isinstance(v, h5py.Dataset) and v.ndim == 1 and not v.dtype.names
                and _numeric_kind(v.dtype) != "text"
            }  # fmt: skip
            if not members:
                raise _fail(
                    f"group {obj.name!r} of {src} holds no 1-D numeric dataset; numeric "
                    f"datasets: {listed or 'none'}"
                )
            lengths = {k: v.shape[0] for k, v in members.items()}
            if len(set(lengths.values())) > 1:
                raise _fail(
                    f"the datasets of group {obj.name!r} in {src} differ in length "
                    f"({', '.join(f'{k}: {n}' for k, n in lengths.items())}): choose one "
                    "with --dataset PATH"
                )
            data = {k: _dt64_ns(v[()]) for k, v in members.items()}
            names = list(data)
            tab = _Table(
                names, {k: _numeric_kind(v.dtype) for k, v in members.items()},
                data.__getitem__, next(iter(lengths.values())),
            )  # fmt: skip
            tab.units = {k: _attr_text(v.attrs.get("units")) for k, v in members.items()
                         if v.attrs.get("units") is not None}  # fmt: skip
            where = obj.name
        elif _lazy_wanted(opts, obj.size * obj.dtype.itemsize) and _lazy_hdf5_ok(obj, opts, src):
            dname, flat = obj.name, obj.ndim == 1
            names = [dname.rsplit("/", 1)[-1]] if flat else [str(j) for j in range(obj.shape[1])]
            tab = _Table(
                names, dict.fromkeys(names, "num"),
                lambda n: HDF5Source(path, dname, None if flat else int(n)), int(obj.shape[0]),
            )  # fmt: skip
            if obj.attrs.get("units") is not None and len(names) == 1:
                tab.units = {names[0]: _attr_text(obj.attrs["units"])}
            where = obj.name
        else:
            try:
                arr = obj[()]
            except (TypeError, ValueError, OSError) as exc:
                raise _fail(
                    f"cannot read dataset {obj.name!r} of {src}: {_one_line(exc)}"
                ) from None
            tab = _array_table(np.asarray(arr), f"{src}:{obj.name}", obj.name.rsplit("/", 1)[-1])
            if obj.attrs.get("units") is not None and len(tab.names) == 1:
                tab.units = {tab.names[0]: _attr_text(obj.attrs["units"])}
            where = obj.name
        channels, rel, t0, info = _channels_from_table(
            tab, columns=opts["columns"], time_column=opts["time_column"],
            time_format=opts["time_format"], src=src,
        )  # fmt: skip
    info["dataset"] = where
    return _Raw(channels, rel, t0, None, "sample", info)


def _lazy_hdf5_ok(obj: Any, opts: dict[str, Any], src: str) -> bool:
    """A plain numeric 1-D/2-D dataset, no time column: readable piece by piece."""
    why = None
    if obj.dtype.names or _numeric_kind(obj.dtype) != "num":
        why = "a compound or date-time dataset"
    elif obj.ndim not in (1, 2):
        why = f"shape {obj.shape}"
    elif opts.get("time_column") is not None:
        why = "a time column needs every time stamp in memory"
    if why is not None and opts.get("lazy"):
        raise _lazy_refused(src, why)
    return why is None


def _attr_text(value: Any) -> str:
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray) and value.size == 1:
        return _attr_text(value.reshape(-1)[0])
    return str(value)


# --------------------------------------------------------------------------------------
# Parquet
# --------------------------------------------------------------------------------------


def _lazy_parquet(path: Path, src: str, opts: dict[str, Any], pa: Any, pq: Any) -> _Raw | None:
    """The numeric columns as :class:`ParquetSource` pieces, when reading lazily applies."""
    try:
        meta = pq.ParquetFile(path).metadata
        schema = pq.ParquetFile(path).schema_arrow
    except (OSError, pa.ArrowException, ValueError):
        return None  # the full read below reports it
    numeric = {
        name: pa.types.is_integer(typ) or pa.types.is_floating(typ)
        for name, typ in zip(schema.names, schema.types, strict=True)
    }
    width = sum(8 for v in numeric.values() if v) or 8
    if not _lazy_wanted(opts, int(meta.num_rows) * width):
        return None
    kinds = {n: ("num" if ok else "text") for n, ok in numeric.items()}
    tab = _Table(list(schema.names), kinds, lambda n: ParquetSource(path, n), int(meta.num_rows))
    timed = [
        n for n, typ in zip(schema.names, schema.types, strict=True)
        if _time_name_unit(n)[0] or pa.types.is_timestamp(typ) or pa.types.is_date(typ)
        or pa.types.is_string(typ) or pa.types.is_large_string(typ)
    ]  # fmt: skip
    if timed or opts.get("time_column") is not None:
        if opts.get("lazy"):
            raise _lazy_refused(src, "a time column needs every time stamp in memory")
        return None
    channels, rel, t0, info = _channels_from_table(
        tab, columns=opts["columns"], time_column=None, time_format=opts["time_format"],
        src=src,
    )  # fmt: skip
    return _Raw(channels, rel, t0, None, "sample", info)


def _read_parquet(path: Path, src: str, opts: dict[str, Any]) -> _Raw:
    pa = _require("pyarrow", "Parquet")
    pq = _require("pyarrow.parquet", "Parquet")
    lazy = _lazy_parquet(path, src, opts, pa, pq)
    if lazy is not None:
        return lazy
    try:
        table = pq.read_table(path)
    except (OSError, pa.ArrowException, ValueError) as exc:
        raise _fail(
            f"{src} is not a readable Parquet file ({_one_line(exc)}): re-export it"
        ) from None
    kinds: dict[str, str] = {}
    why_not: dict[str, str] = {}
    for name, typ in zip(table.column_names, table.schema.types, strict=True):
        if pa.types.is_integer(typ) or pa.types.is_floating(typ) or pa.types.is_decimal(typ):
            kinds[name] = "num"
        elif pa.types.is_timestamp(typ) or pa.types.is_date(typ):
            kinds[name] = "ns"
        elif pa.types.is_string(typ) or pa.types.is_large_string(typ):
            sample = [s for s in table.column(name).slice(0, 50).to_pylist() if s]
            kinds[name] = "iso" if sample and all(_is_iso(s) for s in sample) else "text"
            why_not[name] = "text"
        else:
            kinds[name] = "text"
            why_not[name] = str(typ)

    def get(name: str) -> Any:
        col = table.column(name)
        kind = kinds[name]
        if kind == "ns":
            col = col.cast(pa.timestamp("ns")).cast(pa.int64())
            return col.fill_null(np.iinfo(np.int64).min).to_numpy()
        if kind == "iso":
            return ["" if s is None else s for s in col.to_pylist()]
        if pa.types.is_decimal(col.type) or col.null_count:
            col = col.cast(pa.float64())
            return col.to_numpy()  # nulls -> NaN
        return col.to_numpy()

    tab = _Table(list(table.column_names), kinds, get, table.num_rows, None, why_not)
    channels, rel, t0, info = _channels_from_table(
        tab, columns=opts["columns"], time_column=opts["time_column"],
        time_format=opts["time_format"], src=src,
    )  # fmt: skip
    return _Raw(channels, rel, t0, None, "sample", info)


# --------------------------------------------------------------------------------------
# ROS bags
# --------------------------------------------------------------------------------------


def _read_bag(path: Path, src: str, opts: dict[str, Any], *, ros2: bool) -> _Raw:
    _require("rosbags", "ROS bags")
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE if ros2 else Stores.ROS1_NOETIC)
    topic = opts["topic"]
    time_column = opts["time_column"]
    if time_column not in (None, "header", "bag"):
        raise _fail(
            f"time_column {time_column!r} does not apply to a ROS bag: use 'header' "
            "(the messages' header stamps) or 'bag' (the recording time stamps)"
        )
    wanted = _as_list(opts["columns"])
    names = list(_IMU_CHANNELS)
    chosen = names if wanted is None else [_resolve(c, names, src, "IMU channel") for c in wanted]
    try:
        with AnyReader([path], default_typestore=store) as reader:
            imu = sorted({c.topic for c in reader.connections if c.msgtype == _IMU_TYPE})
            if not imu:
                others = ", ".join(sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections}))
                raise _fail(
                    f"{src} has no {_IMU_TYPE} topic (topics: {others or 'none'}): record the "
                    "IMU topic, or export the data to CSV"
                )
            if topic is None:
                if len(imu) > 1:
                    raise _fail(
                        f"{src} has {len(imu)} IMU topics ({', '.join(imu)}): choose one with "
                        "--topic NAME"
                    )
                topic = imu[0]
            elif topic not in imu:
                raise _fail(
                    f"no {_IMU_TYPE} topic {topic!r} in {src}; IMU topics: {', '.join(imu)}"
                )
            conns = [c for c in reader.connections if c.topic == topic]
            n = sum(c.msgcount for c in conns)
            data = np.empty((n, 6), dtype=np.float64)
            stamp = np.empty(n, dtype=np.int64)
            recorded = np.empty(n, dtype=np.int64)
            k = 0
            for conn, bag_ns, raw in reader.messages(connections=conns):
                msg: Any = reader.deserialize(raw, conn.msgtype)
                if k == n:  # more messages than the index said
                    data = np.concatenate([data, np.empty_like(data)])
                    stamp = np.concatenate([stamp, np.empty_like(stamp)])
                    recorded = np.concatenate([recorded, np.empty_like(recorded)])
                w, a = msg.angular_velocity, msg.linear_acceleration
                data[k] = (w.x, w.y, w.z, a.x, a.y, a.z)
                stamp[k] = int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)
                recorded[k] = bag_ns
                k += 1
    except AdavarInputError:
        raise
    except Exception as exc:  # rosbags raises many kinds on damaged bags
        what = "ROS 2 bag" if ros2 else "ROS 1 bag"
        raise _fail(f"{src} is not a readable {what} ({_one_line(exc)}): check the file") from None
    data, stamp, recorded = data[:k], stamp[:k], recorded[:k]
    if k == 0:
        raise _fail(f"topic {topic!r} of {src} has no messages: give a bag with IMU data")
    if time_column is None:
        time_column = "bag" if not stamp.any() else "header"
    ns = stamp if time_column == "header" else recorded
    channels = {c: data[:, names.index(c)].copy() for c in chosen}
    info = {
        "topic": topic,
        "message_type": _IMU_TYPE,
        "channels": chosen,
        "units": {c: _IMU_UNITS[c] for c in chosen},
        "time_source": "header stamps" if time_column == "header" else "bag time stamps",
        "n_messages": int(k),
    }
    if time_column == "header" and not stamp.any():
        raise _fail(
            f"the header stamps of {topic!r} in {src} are all zero: use time_column='bag' "
            "(--time-column bag) for the recording time stamps"
        )
    rel = (ns - ns[0]).astype(np.float64) / 1e9
    return _Raw(channels, rel, float(ns[0]) / 1e9, None, "message", info)


# --------------------------------------------------------------------------------------
# Rate, NaN and gaps
# --------------------------------------------------------------------------------------


@dataclass
class _Raw:
    channels: dict[str, np.ndarray]
    time: np.ndarray | None  # seconds from the first valid stamp (NaN where missing)
    t0: float | None
    rows: np.ndarray | None  # file line numbers, for messages
    word: str  # "row", "sample", "message": how a sample is named without line numbers
    meta: dict[str, Any]


def _fmt_t(value: float) -> str:
    return f"{value:.6g} s"


def _all_finite_by_file(raw: _Raw) -> bool:
    """Whether every channel is a file memory map with only finite samples, checked piece by
    piece with file reads: a large ``.npy`` is scanned without its pages piling up in the
    process's resident memory (and without an N-sample mask)."""
    if raw.time is not None or not raw.channels:
        return False
    sources = [memmap_source(v) for v in raw.channels.values()]
    if any(s is None for s in sources):
        return False
    for source in sources:
        for start in range(0, source.size, DEFAULT_CHUNK):
            piece = source._read_raw(start, min(source.size, start + DEFAULT_CHUNK))
            if not np.isfinite(piece).all():
                return False
    return True


def _handle_nan(raw: _Raw, policy: str, src: str, meta: dict[str, Any]) -> _Raw:
    if all(isinstance(v, ChunkedSource) for v in raw.channels.values()):
        meta["lazy"] = True  # each piece is checked as it is read (the error names the sample)
        return raw
    if _all_finite_by_file(raw):
        return raw
    names = list(raw.channels)
    n = len(raw.channels[names[0]])
    bad_t = None if raw.time is None else ~np.isfinite(raw.time)
    bad = np.zeros(n, dtype=bool)
    for values in raw.channels.values():
        bad |= ~np.isfinite(values)
    any_t = bad_t is not None and bool(bad_t.any())
    if not bad.any() and not any_t:
        return raw

    def where(i: int) -> str:
        return _where(raw.rows, i, raw.word)

    def first_bad_cell(i: int) -> tuple[str, str]:
        for name in names:
            v = raw.channels[name][i]
            if not np.isfinite(v):
                return name, ("NaN or empty" if np.isnan(v) else str(v).replace("inf", "Inf"))
        return names[0], "?"

    tname = meta.get("time_column", "time")
    if policy == "error":
        if any_t and (not bad.any() or np.argmax(bad_t) <= np.argmax(bad)):
            i = int(np.argmax(bad_t))
            raise _fail(
                f"{src}: {where(i)}, time column {tname!r} is missing or not finite: fix or "
                "remove that row, or use --nan drop"
            )
        i = int(np.argmax(bad))
        name, value = first_bad_cell(i)
        raise _fail(
            f"{src}: {where(i)}, column {name!r} is {value}: fix or remove that row, or use "
            "--nan drop or --nan interpolate"
        )
    rows_bad = bad | bad_t if bad_t is not None else bad
    if policy == "drop":
        idx = np.flatnonzero(rows_bad)
        if raw.time is None:
            good = np.flatnonzero(~rows_bad)
            if good.size == 0:
                raise _fail(f"{src}: every row has a NaN or infinite sample: nothing is left")
            inner = idx[(idx > good[0]) & (idx < good[-1])]
            if inner.size:
                i = int(inner[0])
                name, value = first_bad_cell(i)
                raise _fail(
                    f"{src}: {where(i)}, column {name!r} is {value}, and dropping it would "
                    "shift every later sample in time (there is no time column): use --nan "
                    "interpolate, or give a time column"
                )
        keep = ~rows_bad
        if not keep.any():
            raise _fail(f"{src}: every row has a NaN or infinite sample: nothing is left")
        meta["nan_rows_dropped"] = int(idx.size)
        meta["nan_dropped_at"] = [where(int(i)) for i in idx[:_MAX_LISTED]]
        return _Raw(
            {k: v[keep] for k, v in raw.channels.items()},
            None if raw.time is None else raw.time[keep],
            raw.t0,
            None if raw.rows is None else raw.rows[keep],
            raw.word,
            raw.meta,
        )
    # interpolate: first the time stamps over the index, then the channels over time
    columns = dict(raw.channels)
    series = ({"__time__": raw.time} if raw.time is not None else {}) | columns
    start, stop = 0, n
    for name, values in series.items():
        ok = np.flatnonzero(np.isfinite(values))
        if ok.size == 0:
            label = tname if name == "__time__" else name
            raise _fail(f"{src}: column {label!r} has no finite value: choose another column")
        start, stop = max(start, int(ok[0])), min(stop, int(ok[-1]) + 1)
    if start >= stop:
        raise _fail(f"{src}: no row where every column is finite: nothing to interpolate from")
    sl = slice(start, stop)
    time = None
    counts: dict[str, int] = {}
    index = np.arange(start, stop, dtype=np.float64)
    if raw.time is not None:
        time = np.array(raw.time[sl], dtype=np.float64)
        miss = ~np.isfinite(time)
        if miss.any():
            time[miss] = np.interp(index[miss], index[~miss], time[~miss])
            counts[tname] = int(miss.sum())
    axis = index if time is None else time
    for name, values in columns.items():
        part = values[sl]
        miss = ~np.isfinite(part)
        if miss.any():
            part = np.array(part, dtype=np.float64)
            part[miss] = np.interp(axis[miss], axis[~miss], part[~miss])
            counts[name] = int(miss.sum())
        columns[name] = part
    meta["nan_values_interpolated"] = counts
    meta["nan_rows_trimmed"] = int(n - (stop - start))
    return _Raw(
        columns, time, raw.t0, None if raw.rows is None else raw.rows[sl], raw.word, raw.meta
    )


def _finish(
    raw: _Raw,
    *,
    rate: float | None,
    gaps: str,
    nan: str,
    tol: float,
    src: str,
    kind: str,
    meta: dict[str, Any],
) -> Record:
    meta.update(raw.meta)
    raw = _handle_nan(raw, nan, src, meta)
    names = list(raw.channels)
    n = len(raw.channels[names[0]])
    if n == 0:
        raise _fail(f"{src} has no samples: give a file with data")
    t = raw.time
    t0 = raw.t0

    def where(i: int) -> str:
        return _where(raw.rows, i, raw.word)

    if t is None:
        if rate is None:
            raise _fail(
                f"{src} has no time column, so the sampling rate is unknown: declare it with "
                "--rate HZ, or name the time column with --time-column NAME"
            )
        meta.update(rate_source="declared", time_source=meta.get("time_source", "none"))
        return Record(dict(raw.channels), float(rate), None, None, src, kind, meta)
    if n < 2:
        raise _fail(f"{src} has a single sample: at least two are needed to find the rate")
    meta.setdefault("time_source", f"column {meta.get('time_column')!r}")
    t0 = t0 + float(t[0]) if t0 is not None else None
    t = t - t[0]
    dt = np.diff(t)
    back = np.flatnonzero(dt <= 0)
    if back.size:
        i = int(back[0])
        what = "repeats" if dt[i] == 0 else "goes back"
        raise _fail(
            f"{src}: time {what} at {where(i + 1)} (t = {_fmt_t(t[i + 1])} after "
            f"{_fmt_t(t[i])}): sort the rows by time and remove duplicates"
        )
    step = float(np.median(dt))
    found = 1.0 / step
    if rate is not None:
        if abs(found - rate) > _RATE_AGREEMENT * rate:
            raise _fail(
                f"{src}: the declared rate {rate:g} Hz disagrees with the time stamps "
                f"({found:.6g} Hz from the median interval {step:.6g} s): leave out --rate, "
                "or correct it"
            )
        meta["rate_source"] = "declared, agrees with the time stamps"
        grid_step = 1.0 / rate
    else:
        rate = found
        meta["rate_source"] = "median time interval"
        grid_step = step
    meta["median_interval"] = step
    long_ = np.flatnonzero(dt > (1.0 + tol) * step)
    short = np.flatnonzero(dt < (1.0 - tol) * step)
    jitter = np.abs(dt - step) / step
    meta["max_jitter"] = float(jitter.max())
    meta["n_gaps"] = int(long_.size)
    meta["gap_list"] = [
        {"after": where(int(i)), "t": float(t[i]), "size": float(dt[i])}
        for i in long_[:_MAX_LISTED]
    ]

    def gap_error() -> AdavarInputError:
        i = int(long_[0])
        more = f" and {long_.size - 1} more" if long_.size > 1 else ""
        return _fail(
            f"{src}: gap of {dt[i]:.4g} s after {where(i)} (t = {_fmt_t(t[i])}; the median "
            f"interval is {step:.4g} s){more}: use --gaps split or --gaps interpolate"
        )

    def uneven_error() -> AdavarInputError:
        i = int(short[0])
        more = f" and {short.size - 1} more" if short.size > 1 else ""
        return _fail(
            f"{src}: non-uniform sampling: interval of {dt[i]:.4g} s after {where(i)} "
            f"(t = {_fmt_t(t[i])}) is more than {tol:.0%} shorter than the median "
            f"{step:.4g} s{more}: use --gaps interpolate to resample onto a uniform grid"
        )

    channels = dict(raw.channels)
    segments = None
    if gaps == "error" or (gaps == "split" and short.size):
        if short.size and (not long_.size or short[0] < long_[0]):
            raise uneven_error()
        if long_.size:
            raise gap_error()
    elif gaps == "split" and long_.size:
        cuts = [0, *(long_ + 1).tolist(), n]
        segments = [slice(a, b) for a, b in itertools.pairwise(cuts)]
        meta["gaps"] = "split"
        meta["segment_lengths"] = [b - a for a, b in itertools.pairwise(cuts)]
    elif gaps == "interpolate" and (long_.size or short.size):
        if short.size:  # non-uniform: resample everything onto the uniform grid
            count = math.floor(t[-1] / grid_step + 1e-9) + 1
            new_t = np.arange(count) * grid_step
            meta["resampled"] = True
        else:  # only gaps: keep every sample, fill each gap with evenly spaced points
            per = np.ones(n - 1, dtype=np.int64)
            per[long_] = np.maximum(1, np.rint(dt[long_] / grid_step)).astype(np.int64)
            starts = np.repeat(t[:-1], per)
            offsets = np.arange(per.sum()) - np.repeat(np.cumsum(per) - per, per)
            new_t = np.append(starts + np.repeat(dt / per, per) * offsets, t[-1])
            meta["resampled"] = False
        channels = {k: np.interp(new_t, t, v) for k, v in channels.items()}
        meta["gaps"] = "interpolate"
        meta["n_samples_read"] = int(n)
        meta["n_interpolated"] = int(new_t.size - n) if not short.size else int(new_t.size)
        t = new_t
    meta["n_samples"] = len(t)
    return Record(channels, float(rate), t, t0, src, kind, meta, segments)


# --------------------------------------------------------------------------------------
# The entry point
# --------------------------------------------------------------------------------------


def _kind_of(path: Path) -> str:
    if path.is_dir():
        if (path / "metadata.yaml").is_file():
            return "ros2"
        raise _fail(
            f"{path} is a folder without metadata.yaml (not a ROS 2 bag): give the path of a "
            "data file"
        )
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        known = " ".join(sorted(SUFFIXES))
        raise _fail(
            f"{path}: unknown file type {suffix or '(no suffix)'!r}: use one of {known} "
            "(rename the file if its content is one of these)"
        )
    return SUFFIXES[suffix]


def read_record(
    path: str | os.PathLike[str],
    *,
    columns: str | int | Sequence[str | int] | None = None,
    rate: float | None = None,
    time_column: str | int | None = None,
    time_format: str = "auto",
    gaps: str = "error",
    nan: str = "error",
    dataset: str | None = None,
    topic: str | None = None,
    gap_tolerance: float = 0.5,
    lazy: bool | None = None,
) -> Record:
    """Read the channels of a record, with its sampling rate and time base.

    Parameters
    ----------
    path : str or path-like
        The file (or ROS 2 bag folder); its suffix chooses the reader (see
        :data:`SUFFIXES`). Text files: UTF-8, blank lines and lines starting with ``#`` or
        ``%`` skipped, delimiter sniffed among tab, semicolon, comma and whitespace, a
        header row when the first line is not numbers (Stable32 ``.phd``/``.frd`` and
        single-column files may have several header lines), empty / ``NA`` / ``nan``
        cells read as missing samples.
    columns : str, int or sequence of them, optional
        The channels: names (case-insensitive if unique) or 0-based indices, as a list or a
        comma-separated string (``"gx,gy,gz"``). By default every numeric column except the
        time column. Columns of a file without header are named ``"0"``, ``"1"``...;
        a 1-D ``.npy`` array is ``"0"``; ``.npz`` keys and HDF5 dataset names are used as
        they are; ROS IMU channels are ``gx gy gz`` (rad/s) and ``ax ay az`` (m/s^2);
        a Stable32 file gives ``"phase"`` (``.phd``) or ``"frequency"`` (``.frd``).
    rate : float, optional
        The sampling rate (Hz). Needed when the file has no time column; when it has one,
        the two must agree within 1 % (median interval), and the declared rate is used.
    time_column : str or int, optional
        The time column (name or index). By default a column named like ``t``, ``time``,
        ``timestamp``, ``stamp``, ``datetime``, ``epoch``, ``mjd`` (optionally with a unit:
        ``time_s``, ``t [ms]``, ``stamp_ns``), else the only column of ISO 8601 or datetime
        values; none otherwise. For a two-column Stable32 file, the first column (MJD time
        tags). For ROS bags: ``"header"`` (header stamps; the default unless they are all
        zero) or ``"bag"`` (recording time stamps).
    time_format : {"auto", "s", "ms", "us", "ns", "iso", "mjd"}
        The time column's unit: ``"auto"`` reads strings as ISO 8601 (naive times as UTC)
        and numbers in the unit written in the column name, else in seconds (recorded in
        ``meta["time_unit_source"]`` as assumed).
    gaps : {"error", "split", "interpolate"}
        What to do when an interval between time stamps is longer than
        ``(1 + gap_tolerance)`` times the median (a gap) or shorter than
        ``(1 - gap_tolerance)`` times it (non-uniform sampling). ``"error"`` names the
        first one. ``"split"`` keeps every sample and sets :attr:`Record.segments` to the
        gap-free pieces (non-uniform sampling is still an error). ``"interpolate"`` fills
        each gap with evenly spaced, linearly interpolated samples (the samples read are
        kept as they are); with non-uniform sampling, every channel is linearly resampled
        onto the uniform grid ``k / rate``. Without a time base there is nothing to check.
    nan : {"error", "drop", "interpolate"}
        What to do with NaN, infinite or missing samples (and missing time stamps).
        ``"error"`` names the first bad row and column. ``"drop"`` removes those rows: with
        a time base, a hole left behind is then a gap like any other (handled by ``gaps``);
        without one only leading and trailing rows may be dropped, since dropping an
        inner row would shift every later sample in time (use ``"interpolate"``).
        ``"interpolate"`` replaces each bad value by linear interpolation over time (or
        sample index) between its finite neighbours; leading and trailing rows where a
        channel has no finite value yet are trimmed.
    dataset : str, optional
        HDF5 only: the dataset (a 1-D array, a 2-D samples x channels array, a compound
        dataset whose fields are columns) or a group of equal-length 1-D datasets. By
        default the only numeric dataset, or the group holding all of them if they are
        1-D, of equal length and in the same group.
    topic : str, optional
        ROS bags only: the ``sensor_msgs/msg/Imu`` topic, needed when there are several.
    gap_tolerance : float
        Relative tolerance on the sampling interval, in (0, 1).
    lazy : bool, optional
        HDF5 datasets and Parquet columns: ``True`` returns each channel as a
        :class:`adavar.stream.ChunkedSource` that is read piece by piece (by the
        out-of-core analyses; ``np.asarray`` loads it whole), ``False`` reads it into
        memory. By default (None) lazily when the numeric data exceed 1 GiB or a quarter
        of the available memory and there is no time column and ``nan="error"`` (NaN/Inf
        are then reported, with their sample, when the analysis reads them). A time column
        needs every stamp in memory, so ``lazy=True`` with one is an error. ``.npy`` and
        uncompressed ``.npz`` columns are always memory-mapped and read piece by piece.

    Returns
    -------
    Record
        ``meta`` lists the options and everything done (see :class:`Record`).

    Raises
    ------
    AdavarInputError
        A missing, unreadable, corrupt or unknown file; a missing optional package (the
        message names it); no numeric column, an unknown or non-numeric column; no rate and
        no time column, or a declared rate disagreeing with the time stamps; time stamps
        that repeat or go back; a gap, non-uniform sampling or a NaN/infinite sample under
        the ``"error"`` policies (naming the row, time and size); invalid options.
    """
    if gaps not in GAP_POLICIES:
        raise _fail(f"unknown gaps policy {gaps!r}: use one of {', '.join(GAP_POLICIES)}")
    if nan not in NAN_POLICIES:
        raise _fail(f"unknown nan policy {nan!r}: use one of {', '.join(NAN_POLICIES)}")
    fmt = str(time_format).strip().lower()
    fmt = {"sec": "s", "seconds": "s", "µs": "us"}.get(fmt, fmt)
    if fmt not in TIME_FORMATS:
        raise _fail(f"unknown time format {time_format!r}: use one of {', '.join(TIME_FORMATS)}")
    if isinstance(gap_tolerance, bool) or not (
        isinstance(gap_tolerance, numbers.Real) and 0 < gap_tolerance < 1
    ):
        raise _fail(f"gap tolerance must be a number between 0 and 1, got {gap_tolerance!r}")
    if rate is not None:
        if (
            isinstance(rate, bool)
            or not isinstance(rate, numbers.Real)
            or not (math.isfinite(rate) and rate > 0)
        ):
            raise _fail(f"rate must be a positive number of Hz, got {rate!r}")
        rate = float(rate)
    target = Path(path)
    src = str(target)
    if not target.exists():
        raise _fail(f"{src}: no such file: check the path")
    kind = _kind_of(target)
    if kind == "ros2" and not target.is_dir():
        if not (target.parent / "metadata.yaml").is_file():
            raise _fail(
                f"{src} is not in a ROS 2 bag folder (no metadata.yaml next to it): give the "
                "bag folder"
            )
        target = target.parent
    if lazy and kind not in ("hdf5", "parquet", "npy", "npz"):
        raise _fail(
            f"{src} is read whole (lazy reading is for .npy, HDF5 and Parquet files): leave "
            "out lazy=True / --lazy, or convert the file to .npy"
        )
    if lazy and nan != "error":
        raise _fail(
            f"nan={nan!r} needs the whole record in memory, so it cannot be read lazily: "
            "leave out lazy=True / --lazy, or remove the bad samples first"
        )
    if dataset is not None and kind != "hdf5":
        raise _fail(f"--dataset applies to HDF5 files only, not to {src}: leave it out")
    if topic is not None and kind not in ("ros1", "ros2"):
        raise _fail(f"--topic applies to ROS bags only, not to {src}: leave it out")
    cols = _as_list(columns)
    opts = {
        "columns": cols,
        "time_column": time_column,
        "time_format": fmt,
        "dataset": dataset,
        "topic": topic,
        "lazy": lazy,
        "nan": nan,
    }
    meta: dict[str, Any] = {
        "path": src,
        "kind": kind,
        "options": {
            "columns": cols, "rate": rate, "time_column": time_column, "time_format": fmt,
            "gaps": gaps, "nan": nan, "dataset": dataset, "topic": topic,
            "gap_tolerance": float(gap_tolerance),
        },
    }  # fmt: skip
    if kind == "csv":
        raw = _read_text(target, src, opts, stable32=False)
    elif kind == "stable32":
        raw = _read_text(target, src, opts, stable32=True)
    elif kind == "npy":
        raw = _read_npy(target, src, opts)
    elif kind == "npz":
        raw = _read_npz(target, src, opts)
    elif kind == "hdf5":
        raw = _read_hdf5(target, src, opts)
    elif kind == "parquet":
        raw = _read_parquet(target, src, opts)
    else:
        raw = _read_bag(target, src, opts, ros2=kind == "ros2")
    return _finish(
        raw, rate=rate, gaps=gaps, nan=nan, tol=float(gap_tolerance), src=src, kind=kind,
        meta=meta,
    )  # fmt: skip

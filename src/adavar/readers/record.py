"""The record a reader returns, and the steps every format shares after reading.

A format reader returns a :class:`RawRecord` (its channels, time stamps with NaN where
missing, and what it read); :func:`finish_record` applies the NaN policy
(:data:`NAN_POLICIES`), infers the sampling rate from the time stamps (or checks a declared
one against them), finds gaps and non-uniform sampling and applies the gap policy
(:data:`GAP_POLICIES`), and returns the :class:`Record` that :func:`adavar.readers.read_record`
hands to the analyses, every step listed in its ``meta``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.core.settings import RATE_AGREEMENT
from adavar.io.sources import DEFAULT_CHUNK, ChunkedSource, NpyFileSource, memmap_source
from adavar.readers.errors import GapError, fail, locate
from adavar.readers.table import resolve

#: Values of ``gaps``: what to do with gaps and non-uniform sampling in a time base.
GAP_POLICIES = ("error", "split", "interpolate", "nan")
#: Values of ``nan``: what to do with NaN / infinite / empty samples.
NAN_POLICIES = ("error", "drop", "interpolate", "keep")

_MAX_LISTED = 50  # gaps / dropped rows listed one by one in meta
_NOMINAL = "nominal rate of the time stamps (every interval equals it within their resolution)"
_MEAN = "mean time interval (gaps excluded)"
_SPAN = "the stamps' span over their count (jittering stamps: every interval counted)"


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
            raise fail(
                f"{self.source} has {len(self.channels)} channels ({', '.join(self.names)}): "
                "choose one with --column NAME"
            )
        return self.channels[resolve(name, self.names, self.source, "channel")]

    def units_of(
        self, given: str | None = None, names: Sequence[str] | None = None, flag: str = "--units"
    ) -> dict[str, str | None]:
        """The unit of every channel: ``given`` (``--units``), else the unit the file
        declares (ROS bags: rad/s and m/s^2; HDF5 ``units`` attributes), else None.

        Parameters
        ----------
        given : str, optional
            The unit the user declared for every channel.
        names : sequence of str, optional
            The channels it is declared for (default: every channel), e.g. the three gyro
            axes of ``adavar kalibr --gyro-units``.
        flag : str
            The option named in the error message.

        Returns
        -------
        dict of str to str or None

        Raises
        ------
        AdavarInputError
            ``given`` contradicts a unit the file declares (``deg/s`` for data declared in
            rad/s is 57.3 times off; an angular rate for an acceleration is no unit of it).
            A declared unit adavar does not know (a free label) is not compared.
        """
        declared = self.meta.get("units") or {}
        chosen = list(self.names if names is None else names)
        if given is None:
            return {name: declared.get(name) for name in chosen}
        for name in chosen:
            unit = declared.get(name)
            if unit is None or not _contradicts(given, unit):
                continue
            units = {n: declared[n] for n in chosen if n in declared}
            if len(set(units.values())) == 1:
                way_out = f"leave out {flag}, or give {flag} {unit}"
            else:
                listed = ", ".join(f"{n} in {u}" for n, u in units.items())
                way_out = f"leave out {flag} (the file declares {listed})"
            raise fail(
                f"{flag} {given} contradicts {self.source}, which declares channel {name!r} "
                f"in {unit}{_what_differs(given, unit)}: {way_out}"
            )
        return dict.fromkeys(chosen, given)

    def pieces(self, name: str | None = None) -> list[np.ndarray]:
        """The channel cut into its gap-free segments (one piece when not split)."""
        values = self.channel(name)
        if self.segments is None:
            return [values]
        return [values[s] for s in self.segments]


def _contradicts(given: str, declared: str) -> bool:
    """Whether unit ``given`` is not the unit ``declared`` by the file (which adavar knows)."""
    from adavar.core.units import unit_info

    try:
        info = unit_info(declared)
    except (TypeError, ValueError):
        return False  # a free label: nothing to compare with
    try:
        return unit_info(given) != info
    except (TypeError, ValueError):
        return True  # the file's unit is known, and the given one is not it


def _what_differs(given: str, declared: str) -> str:
    """`` (deg/s is an angular rate, m/s^2 an acceleration)`` when the two units measure
    different quantities, else ""."""
    from adavar.core.units import unit_info

    kinds = {("gyro", 0.0): "an angular rate", ("accelerometer", 0.0): "an acceleration",
             ("gyro", 1.0): "an angle", ("accelerometer", 1.0): "a velocity"}  # fmt: skip
    try:
        g, d = unit_info(given), unit_info(declared)
    except (TypeError, ValueError):
        return ""
    what_g = kinds.get((g.sensor, g.time_power), f"a {g.sensor} unit")
    what_d = kinds.get((d.sensor, d.time_power), f"a {d.sensor} unit")
    return "" if what_g == what_d else f" ({given} is {what_g}, {declared} {what_d})"


@dataclass
class RawRecord:
    """What a format reader read, before the NaN and gap policies and the rate."""

    channels: dict[str, np.ndarray]
    time: np.ndarray | None  # seconds from the first valid stamp (NaN where missing)
    t0: float | None
    rows: np.ndarray | None  # file line numbers, for messages
    word: str  # "row", "sample", "message": how a sample is named without line numbers
    meta: dict[str, Any]


#: The times of the messages count from the first time stamp (a file whose stamps start at
#: 1e6 s said "t = 4.99 s"): said so.
_FROM_FIRST = "after the first stamp"


def _fmt_t(value: float) -> str:
    return f"{value:.6g} s"


def _npy_source(values: Any) -> NpyFileSource | None:
    """The ``.npy`` file source of a channel (read with file reads, or a memory map)."""
    return values if isinstance(values, NpyFileSource) else memmap_source(values)


def _all_finite_by_file(raw: RawRecord) -> bool:
    """Whether every channel is a ``.npy`` file column (a memory map or a source of file
    reads) with only finite samples, checked piece by piece with file reads: a large
    ``.npy`` is scanned without its pages piling up in the process's resident memory (and
    without an N-sample mask)."""
    if raw.time is not None or not raw.channels:
        return False
    sources = [_npy_source(v) for v in raw.channels.values()]
    if any(s is None for s in sources):
        return False
    for source in sources:
        for start in range(0, source.size, DEFAULT_CHUNK):
            piece = source.read_unchecked(start, min(source.size, start + DEFAULT_CHUNK))
            if not np.isfinite(piece).all():
                return False
    return True


def _handle_nan(raw: RawRecord, policy: str, src: str, meta: dict[str, Any]) -> RawRecord:
    lazy = [isinstance(v, ChunkedSource) for v in raw.channels.values()]
    if all(lazy) and not any(isinstance(v, NpyFileSource) for v in raw.channels.values()):
        meta["lazy"] = True  # each piece is checked as it is read (the error names the sample)
        return raw
    if policy == "keep" and raw.time is None:  # nothing to do: every sample stays in place
        if not any(_npy_source(v) is not None for v in raw.channels.values()):
            meta["nan_values_kept"] = _non_finite_counts(raw)
        return raw
    if _all_finite_by_file(raw):
        return raw
    if any(lazy):  # .npy sources with a bad sample: in memory, to name it as a text file's
        channels = {
            k: np.asarray(v.read_unchecked(0, v.size), dtype=np.float64)
            if isinstance(v, NpyFileSource) else v
            for k, v in raw.channels.items()
        }  # fmt: skip
        raw = RawRecord(channels, raw.time, raw.t0, raw.rows, raw.word, raw.meta)
    if all(np.isfinite(v).all() for v in raw.channels.values()) and (
        raw.time is None or np.isfinite(raw.time).all()
    ):
        return raw  # the common case, without an N-row mask
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
        return locate(raw.rows, i, raw.word)

    def first_bad_cell(i: int) -> tuple[str, str]:
        for name in names:
            v = raw.channels[name][i]
            if not np.isfinite(v):
                return name, ("NaN or empty" if np.isnan(v) else str(v).replace("inf", "Inf"))
        return names[0], "?"

    tname = meta.get("time_column", "time")
    if policy == "keep":
        return _keep_nan(raw, bad, bad_t, tname, src, meta, where)
    if policy == "error":
        if any_t and (not bad.any() or np.argmax(bad_t) <= np.argmax(bad)):
            i = int(np.argmax(bad_t))
            raise fail(
                f"{src}: {where(i)}, time column {tname!r} is missing or not finite: fix or "
                "remove that row, or use --nan drop"
            )
        i = int(np.argmax(bad))
        name, value = first_bad_cell(i)
        raise fail(
            f"{src}: {where(i)}, column {name!r} is {value}: fix or remove that row, or use "
            "--nan drop or --nan interpolate (adavar avar: --gaps omit leaves it out)"
        )
    rows_bad = bad | bad_t if bad_t is not None else bad
    if policy == "drop":
        idx = np.flatnonzero(rows_bad)
        if raw.time is None:
            good = np.flatnonzero(~rows_bad)
            if good.size == 0:
                raise fail(f"{src}: every row has a NaN or infinite sample: nothing is left")
            inner = idx[(idx > good[0]) & (idx < good[-1])]
            if inner.size:
                i = int(inner[0])
                name, value = first_bad_cell(i)
                raise fail(
                    f"{src}: {where(i)}, column {name!r} is {value}, and dropping it would "
                    "shift every later sample in time (there is no time column): use --nan "
                    "interpolate, or give a time column"
                )
        keep = ~rows_bad
        if not keep.any():
            raise fail(f"{src}: every row has a NaN or infinite sample: nothing is left")
        meta["nan_rows_dropped"] = int(idx.size)
        meta["nan_dropped_at"] = [where(int(i)) for i in idx[:_MAX_LISTED]]
        return RawRecord(
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
            raise fail(f"{src}: column {label!r} has no finite value: choose another column")
        start, stop = max(start, int(ok[0])), min(stop, int(ok[-1]) + 1)
    if start >= stop:
        raise fail(f"{src}: no row where every column is finite: nothing to interpolate from")
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
    return RawRecord(
        columns, time, raw.t0, None if raw.rows is None else raw.rows[sl], raw.word, raw.meta
    )


def _non_finite_counts(raw: RawRecord) -> dict[str, int]:
    return {name: int(np.count_nonzero(~np.isfinite(v))) for name, v in raw.channels.items()}


def _keep_nan(
    raw: RawRecord,
    bad: np.ndarray,
    bad_t: np.ndarray | None,
    tname: str,
    src: str,
    meta: dict[str, Any],
    where: Any,
) -> RawRecord:
    """``nan="keep"``: bad samples stay in place (missing samples for ``gaps="omit"``); a
    row whose time stamp is missing is dropped (its time is unknown), which leaves a gap in
    the time base for the gap policy."""
    meta["nan_values_kept"] = _non_finite_counts(raw)
    if bad_t is None or not bad_t.any():
        return raw
    keep = ~bad_t
    if not keep.any():
        raise fail(f"{src}: time column {tname!r} has no finite value: choose another column")
    idx = np.flatnonzero(bad_t)
    meta["nan_time_rows_dropped"] = int(idx.size)
    meta["nan_dropped_at"] = [where(int(i)) for i in idx[:_MAX_LISTED]]
    return RawRecord(
        {k: v[keep] for k, v in raw.channels.items()},
        raw.time[keep],
        raw.t0,
        None if raw.rows is None else raw.rows[keep],
        raw.word,
        raw.meta,
    )


def _farthest(lo: float, hi: float, centre: float) -> float:
    """The largest ``|x - centre|`` of values ``x`` from ``lo`` to ``hi``: exactly the
    largest of the values' own (rounding ``x - centre`` is monotonic in ``x``), without an
    N-sample array."""
    return max(abs(lo - centre), abs(hi - centre))


def sampling_interval(
    dt: np.ndarray, step: float, tol: float, resolution: float
) -> tuple[float, float, bool]:
    """(interval in s, rate in Hz, nominal) from the intervals ``dt`` between time stamps.

    The intervals within ``tol`` of the median ``step`` are the regular ones (gaps and
    non-uniform intervals left out). When every regular interval equals a round value (at
    most 6 significant digits, of the rate or of the interval) within ``2 * resolution``
    (the stamps' rounding: a unit of integer stamps, a float spacing), and their mean
    agrees with it to within what the stamps' rounding allows over the record, that value
    is the nominal interval: epoch stamps like ``1.7e9 + k / 200`` give exactly 200 Hz, not
    199.995. Otherwise the mean regular interval (more accurate than the median when the
    stamps are rounded or jitter).
    """
    regular = (dt >= (1.0 - tol) * step) & (dt <= (1.0 + tol) * step)
    reg = dt if regular.all() else dt[regular]
    mean = float(np.mean(reg))
    runs = 1 + dt.size - reg.size  # gap-free stretches
    lo, hi = float(reg.min()), float(reg.max())
    if _farthest(lo, hi, mean) > 4.0 * resolution + 2e-9 * mean:
        return mean, 1.0 / mean, False  # the intervals vary more than the stamps' rounding
    for digits in range(1, 7):
        for value, is_rate in ((1.0 / mean, True), (mean, False)):
            rounded = float(f"{value:.{digits}g}")
            cand = 1.0 / rounded if is_rate else rounded
            slack = 2.0 * resolution + 1e-9 * cand
            if abs(mean - cand) > 2.0 * resolution * runs / reg.size + 1e-12 * cand:
                continue
            if _farthest(lo, hi, cand) <= slack:
                return cand, (rounded if is_rate else 1.0 / rounded), True
    return mean, 1.0 / mean, False


#: Stamps lying within this many of their rounding step of a uniform grid (spread ``max -
#: min`` about the grid of the span over the count, whose two ends are rounded too) are
#: read as that grid rounded.
_ROUNDED_SPREAD = 2.05
#: ... when at least this share of the intervals (and 3) differ from the median one: a
#: duplicated stamp or a dropped sample is a single irregular interval.
_ROUNDED_SHARE = 0.005
#: Samples at a time when the spread of the stamps about the grid is measured.
_GRID_BLOCK = 1 << 20


def _rounded_stamps(
    t: np.ndarray, dt: np.ndarray, resolution: float, src: str
) -> AdavarInputError | None:
    """The error for stamps that are a uniform grid rounded to a coarser step, else None.

    Such stamps (75 Hz written to 0.01 s; 100 Hz to whole seconds; seconds since 1970 as
    float32 or with 7 digits) have intervals of a few multiples of their rounding ``q`` (0
    among them when ``q`` is longer than the interval), many of them off the median one,
    and every stamp lies within about ``q`` of the grid of the span over the count; a real
    gap moves every later stamp a whole interval off it. Their rate is the span's, but the
    gap and repeat checks would read them as gaps or duplicates (and a gap policy resample
    at the most common interval): the error names the rate.
    """
    n = t.size
    span = float(t[-1])
    way_out = "read the samples as evenly spaced with --time-column none --rate HZ"
    if n >= 3 and span == 0.0:
        return fail(
            f"{src}: every time stamp is the same ({n} samples): they are rounded to a step "
            f"longer than the record (e.g. seconds since 1970 as float32 or to 7 digits): "
            f"{way_out}, or write the stamps with more digits"
        )
    positive = dt[dt > 0]
    if n < 3 or span <= 0 or positive.size == 0:
        return None
    repeats = dt.size - positive.size
    if 2 * repeats > dt.size:  # most stamps repeat the one before: not duplicated rows
        return fail(
            f"{src}: {repeats} of {dt.size} time stamps repeat the one before: they are "
            f"rounded to about {float(positive.min()):.4g} s, coarser than the sampling "
            f"interval (e.g. seconds since 1970 as float32): {way_out}, or write the stamps "
            "with more digits"
        )
    irregular = int(np.count_nonzero(np.abs(dt - np.median(dt)) > 2.0 * resolution))
    if irregular < max(3, _ROUNDED_SHARE * dt.size):
        return None
    q = float(positive.min())
    interval = span / (n - 1)
    lo = hi = 0.0
    for a in range(0, n, _GRID_BLOCK):
        r = t[a : a + _GRID_BLOCK] - np.arange(a, min(a + _GRID_BLOCK, n)) * interval
        lo, hi = min(lo, float(r.min())), max(hi, float(r.max()))
    if hi - lo > _ROUNDED_SPREAD * q + 4.0 * resolution:
        return None
    steps = sorted({float(v) for v in np.unique(np.round(dt / q))})[:4]
    shown = ", ".join(f"{v * q:.4g}" for v in steps)
    rate = 1.0 / interval
    for digits in range(1, 7):  # the roundest rate whose grid the stamps fit as well
        rate = float(f"{1.0 / interval:.{digits}g}")
        if abs(1.0 / rate - interval) * (n - 1) <= 0.5 * q:
            break
    within = 2.0 * q / span / interval  # both ends of the span rounded
    return fail(
        f"{src}: the time stamps are rounded to about {q:.4g} s, coarser than their interval "
        f"(the intervals take the values {shown} s, and every stamp lies within about that "
        f"of a uniform grid of {interval:.6g} s): {way_out} (the stamps give "
        f"{rate:g} Hz to within {within:.2g} Hz), or write the stamps with more digits"
    )


def finish_record(
    raw: RawRecord,
    *,
    rate: float | None,
    gaps: str,
    nan: str,
    tol: float,
    src: str,
    kind: str,
    meta: dict[str, Any],
) -> Record:
    """The :class:`Record` of ``raw``: NaN policy, rate, gaps; every step in ``meta``."""
    meta.update(raw.meta)
    raw = _handle_nan(raw, nan, src, meta)
    names = list(raw.channels)
    n = len(raw.channels[names[0]])
    if n == 0:
        raise fail(f"{src} has no samples: give a file with data")
    t = raw.time
    t0 = raw.t0

    def where(i: int) -> str:
        return locate(raw.rows, i, raw.word)

    if t is None:
        if rate is None:
            raise fail(
                f"{src} has no time column, so the sampling rate is unknown: declare it with "
                "--rate HZ, or name the time column with --time-column NAME"
            )
        meta.update(rate_source="declared", time_source=meta.get("time_source", "none"))
        return Record(dict(raw.channels), float(rate), None, None, src, kind, meta)
    if n < 2:
        raise fail(f"{src} has a single sample: at least two are needed to find the rate")
    meta.setdefault("time_source", f"column {meta.get('time_column')!r}")
    t0 = t0 + float(t[0]) if t0 is not None else None
    t = t - t[0]
    dt = np.diff(t)
    resolution = float(meta.get("time_resolution", 0.0)) + float(np.spacing(t[-1]))
    back = np.flatnonzero(dt <= 0)
    if back.size and not np.any(dt < 0):
        rounded = _rounded_stamps(t, dt, resolution, src)
        if rounded is not None:
            raise rounded
    if back.size:
        i = int(back[0])
        what = "repeats" if dt[i] == 0 else "goes back"
        raise fail(
            f"{src}: time {what} at {where(i + 1)} (t = {_fmt_t(t[i + 1])} {_FROM_FIRST}, "
            + (f"as in {where(i)}" if dt[i] == 0 else f"before {where(i)}'s {_fmt_t(t[i])}")
            + "): sort the rows by time and remove duplicates"
        )
    step = float(np.median(dt))  # robust: gaps and outliers do not move it
    long_ = np.flatnonzero(dt > (1.0 + tol) * step)
    short = np.flatnonzero(dt < (1.0 - tol) * step)
    if long_.size or short.size:
        # stamps rounded coarser than the interval look like gaps (75 Hz written to 0.01 s:
        # intervals of 0.01 and 0.02 s), and any gap policy would resample at the wrong rate
        # (checked before a declared rate, which the median interval would contradict)
        rounded = _rounded_stamps(t, dt, resolution, src)
        if rounded is not None:
            raise rounded
    interval, found, nominal = sampling_interval(dt, step, tol, resolution)
    if rate is not None:
        if abs(found - rate) > RATE_AGREEMENT * rate:
            raise fail(
                f"{src}: the declared rate {rate:g} Hz disagrees with the time stamps "
                f"({found:.6g} Hz from the median interval {step:.6g} s): leave out --rate, "
                "or correct it"
            )
        meta["rate_source"] = "declared, agrees with the time stamps"
        grid_step = 1.0 / rate
    else:
        rate = found
        meta["rate_source"] = _NOMINAL if nominal else _MEAN
        grid_step = interval
    # stamps that jitter: intervals off the median both ways, in numbers (not one stamp
    # out of place), whose short ones make up for at least half of what the long ones add
    # (a gap adds time, nothing takes it back). Receive-time stamps (ROS, serial loggers)
    # do this; the intervals within tol of the median are then a biased sample (200.9 Hz
    # for 200), their sum over the record is not
    jitter = bool(long_.size and short.size >= max(3, 1e-3 * (n - 1))) and (
        float(np.sum(step - dt[short])) >= 0.5 * float(np.sum(dt[long_] - step))
    )
    if jitter and meta["rate_source"] in (_NOMINAL, _MEAN):
        interval = float(t[-1]) / (n - 1)
        rate, grid_step = 1.0 / interval, interval
        meta["rate_source"] = _SPAN
    meta["median_interval"] = step
    meta["mean_interval"] = interval if not nominal or jitter else 1.0 / found
    meta["max_jitter"] = _farthest(float(dt.min()), float(dt.max()), step) / step
    meta["n_gaps"] = int(long_.size)
    meta["gap_list"] = [
        {"after": where(int(i)), "t": float(t[i]), "size": float(dt[i])}
        for i in long_[:_MAX_LISTED]
    ]

    def gap_error() -> GapError:
        i = int(long_[0])
        more = f" and {long_.size - 1} more" if long_.size > 1 else ""
        return GapError(
            f"{src}: gap of {dt[i]:.4g} s after {where(i)} (t = {_fmt_t(t[i])} {_FROM_FIRST}; "
            f"the median interval is {step:.4g} s){more}",
            "use --gaps split or --gaps interpolate (adavar avar: --gaps omit)",
        )

    def uneven_error() -> AdavarInputError:
        i = int(short[0])
        more = f" and {short.size - 1} more" if short.size > 1 else ""
        return fail(
            f"{src}: non-uniform sampling: interval of {dt[i]:.4g} s after {where(i)} "
            f"(t = {_fmt_t(t[i])} {_FROM_FIRST}) is more than {tol:.0%} shorter than the median "
            f"{step:.4g} s{more}: use --gaps interpolate to resample onto a uniform grid"
        )

    def jitter_error() -> AdavarInputError:
        off = long_.size + short.size
        return fail(
            f"{src}: the time stamps jitter: {off} of {n - 1} intervals lie more than "
            f"{tol:.0%} from the median {step:.4g} s, yet they span {n - 1} intervals of "
            f"{t[-1] / (n - 1):.6g} s, so no sample seems missing. Stamps taken on receipt "
            "(ROS, a serial logger) jitter like this while the sensor samples evenly: ignore "
            f"them with --time-column none --rate {1.0 / (t[-1] / (n - 1)):.6g}; if the "
            "sensor sampled at these times, --gaps interpolate resamples onto a uniform grid"
        )

    channels = dict(raw.channels)
    segments = None
    if gaps == "error" or (gaps in ("split", "nan") and short.size):
        if jitter:
            raise jitter_error()
        if short.size and (not long_.size or short[0] < long_[0]):
            raise uneven_error()
        if long_.size:
            raise gap_error()
    elif gaps == "split" and long_.size:
        cuts = [0, *(long_ + 1).tolist(), n]
        segments = [slice(a, b) for a, b in itertools.pairwise(cuts)]
        meta["gaps"] = "split"
        meta["segment_lengths"] = [b - a for a, b in itertools.pairwise(cuts)]
    elif gaps == "nan" and long_.size:
        # every sample stays at its place; round(gap / interval) - 1 NaN rows fill a gap
        per = np.ones(n - 1, dtype=np.int64)
        per[long_] = np.maximum(1, np.rint(dt[long_] / grid_step)).astype(np.int64)
        starts = np.repeat(t[:-1], per)
        offsets = np.arange(per.sum()) - np.repeat(np.cumsum(per) - per, per)
        new_t = np.append(starts + np.repeat(dt / per, per) * offsets, t[-1])
        at = np.concatenate(([0], np.cumsum(per)))
        filled = {}
        for k, v in channels.items():
            out = np.full(new_t.size, np.nan)
            out[at] = v
            filled[k] = out
        channels = filled
        meta["gaps"] = "nan"
        meta["n_samples_read"] = int(n)
        meta["n_missing_inserted"] = int(new_t.size - n)
        t = new_t
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

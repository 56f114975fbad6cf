"""The entry point: :func:`read_record` checks its options and chooses the reader.

The file name's suffix (:data:`SUFFIXES`), or a folder with ``metadata.yaml`` (a ROS 2
bag), chooses the format module (:mod:`~adavar.readers.text`,
:mod:`~adavar.readers.stable32`, :mod:`~adavar.readers.npy`, :mod:`~adavar.readers.hdf5`,
:mod:`~adavar.readers.parquet`, :mod:`~adavar.readers.rosbag`); what it read is finished
into a :class:`~adavar.readers.record.Record` by
:func:`~adavar.readers.record.finish_record`, the same for every format.
"""

from __future__ import annotations

import errno
import math
import numbers
import os
import stat
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from adavar.io.sources import FileState, check_unchanged, file_state
from adavar.readers.errors import fail
from adavar.readers.hdf5 import read_hdf5
from adavar.readers.npy import read_npy, read_npz
from adavar.readers.parquet import read_parquet
from adavar.readers.record import GAP_POLICIES, NAN_POLICIES, Record, finish_record
from adavar.readers.rosbag import read_rosbag
from adavar.readers.stable32 import read_stable32
from adavar.readers.table import TIME_FORMATS, as_list
from adavar.readers.text import read_text

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


def _kind_of(path: Path) -> str:
    if path.is_dir():
        if (path / "metadata.yaml").is_file():
            return "ros2"
        raise fail(
            f"{path} is a folder without metadata.yaml (not a ROS 2 bag): give the path of a "
            "data file"
        )
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        known = " ".join(sorted(SUFFIXES))
        raise fail(
            f"{path}: unknown file type {suffix or '(no suffix)'!r}: use one of {known} "
            "(rename the file if its content is one of these)"
        )
    return SUFFIXES[suffix]


def _opened_state(target: Path, src: str) -> FileState:
    """The state of the file (or bag folder) to read, after the checks that it is one:
    a clear error for a missing file, a symbolic link loop or one to nothing, a file that
    may not be read, and a named pipe or device (never opened: opening a pipe with no
    writer would wait forever, and a record is read whole, its end too)."""
    try:
        st = os.stat(target)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise fail(
                f"{src}: symbolic link loop (too many levels of symbolic links): point the "
                "link at the data file"
            ) from None
        if exc.errno == errno.ENOENT and os.path.islink(target):
            raise fail(
                f"{src} is a symbolic link to {os.readlink(target)}, which does not exist: "
                "point the link at the data file"
            ) from None
        if exc.errno == errno.ENOENT:
            raise fail(f"{src}: no such file: check the path") from None
        raise fail(f"cannot read {src}: {exc.strerror or exc}") from None
    if stat.S_ISFIFO(st.st_mode):
        raise fail(
            f"{src} is a named pipe (FIFO), not a file: a record is read whole, its end too; "
            "save the stream to a file first (cat FIFO > record.csv), or follow it live "
            "with adavar monitor"
        )
    if not (stat.S_ISREG(st.st_mode) or stat.S_ISDIR(st.st_mode)):
        raise fail(f"{src} is not a regular file (a device or socket?): give a data file")
    if not os.access(target, os.R_OK):
        raise fail(f"cannot read {src}: permission denied")
    state = file_state(target)
    if state is None:  # pragma: no cover - deleted between the two calls
        raise fail(f"{src}: no such file: check the path")
    return state


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
    memory_map: bool = True,
) -> Record:
    """Read the channels of a record, with its sampling rate and time base.

    Parameters
    ----------
    path : str or path-like
        The file (or ROS 2 bag folder); its suffix chooses the reader (see
        :data:`SUFFIXES`). Text files: UTF-8 (a binary, compressed or UTF-16 file is
        refused with what it is), streamed in blocks (the memory used is the columns', not
        the text's), blank lines and lines starting with ``#`` or ``%`` skipped, delimiter
        sniffed among tab, semicolon, comma and whitespace, decimal commas read in a file
        separated by semicolons, tabs or spaces whose numbers have no decimal point, a
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
        the two must agree within 1 %, and the declared rate is used. Found from the time
        stamps, it is the nominal rate when every regular interval equals a round value
        (of the rate or the interval) within the stamps' rounding and their mean agrees
        (``meta["rate_source"]``), else the mean interval, gaps left out.
    time_column : str or int, optional
        The time column (name or index). By default a column named like ``t``, ``time``,
        ``timestamp``, ``stamp``, ``datetime``, ``epoch``, ``mjd`` (optionally with a unit:
        ``time_s``, ``t [ms]``, ``stamp_ns``), else the only column of ISO 8601 or datetime
        values; none otherwise. For a two-column Stable32 file, the first column (MJD time
        tags). For ROS bags: ``"header"`` (header stamps; the default unless they are all
        zero) or ``"bag"`` (recording time stamps). ``"none"``: no time column (give
        ``rate``); the columns named like one are then data. A channel in ``columns`` that
        is the time column is an error.
    time_format : {"auto", "s", "ms", "us", "ns", "iso", "mjd"}
        The time column's unit: ``"auto"`` reads strings as ISO 8601 (naive times as UTC)
        and numbers in the unit written in the column name, else in seconds (recorded in
        ``meta["time_unit_source"]`` as assumed), unless that is unclear: stamps whose
        median step is more than 1 (5 apart: 0.2 Hz in seconds, 200 Hz in milliseconds;
        whole numbers or not, so a few fractional or jittery stamps change nothing) or
        values past the year 5000 in seconds are an error asking for the unit; whole
        seconds 1 apart (1 Hz clocks) are read. A unit given here that contradicts the
        one written in the column name is an error.
    gaps : {"error", "split", "interpolate", "nan"}
        What to do when an interval between time stamps is longer than
        ``(1 + gap_tolerance)`` times the median (a gap) or shorter than
        ``(1 - gap_tolerance)`` times it (non-uniform sampling). ``"error"`` names the
        first one. ``"split"`` keeps every sample and sets :attr:`Record.segments` to the
        gap-free pieces (non-uniform sampling is still an error). ``"interpolate"`` fills
        each gap with evenly spaced, linearly interpolated samples (the samples read are
        kept as they are); with non-uniform sampling, every channel is linearly resampled
        onto the uniform grid ``k / rate``. ``"nan"`` keeps every sample read at its
        place and marks the samples missing from the grid: a gap of ``g`` sample
        intervals gets ``round(g) - 1`` NaN rows (at evenly spaced times, as
        ``"interpolate"`` places them), for ``deviation(..., gaps="omit")`` to leave out
        (non-uniform sampling is still an error; ``meta["n_missing_inserted"]``). Without
        a time base there is nothing to check.
    nan : {"error", "drop", "interpolate", "keep"}
        What to do with NaN, infinite or missing samples (and missing time stamps).
        ``"error"`` names the first bad row and column. ``"drop"`` removes those rows: with
        a time base, a hole left behind is then a gap like any other (handled by ``gaps``);
        without one only leading and trailing rows may be dropped, since dropping an
        inner row would shift every later sample in time (use ``"interpolate"``).
        ``"interpolate"`` replaces each bad value by linear interpolation over time (or
        sample index) between its finite neighbours; leading and trailing rows where a
        channel has no finite value yet are trimmed. ``"keep"`` leaves every value in place
        (NaN, and Inf, which the analyses refuse): NaN samples are then missing samples for
        ``deviation(..., gaps="omit")``; a row whose time stamp is missing is dropped (its
        time is unknown), leaving a gap in the time base for ``gaps`` (``"nan"`` marks it
        missing again). Counts in ``meta["nan_values_kept"]``.
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
        :class:`adavar.stats.stream.ChunkedSource` that is read piece by piece (by the
        out-of-core analyses; ``np.asarray`` loads it whole), ``False`` reads it into
        memory. By default (None) lazily when the numeric data exceed 1 GiB or a quarter
        of the available memory and there is no time column and ``nan="error"`` (NaN/Inf
        are then reported, with their sample, when the analysis reads them). A time column
        needs every stamp in memory, so ``lazy=True`` with one is an error. ``.npy`` and
        uncompressed ``.npz`` columns are memory-mapped (``memory_map``) and read piece by
        piece.
    memory_map : bool
        ``.npy`` and uncompressed ``.npz`` columns: ``True`` (default) returns them as
        read-only memory maps in the file's dtype; ``False`` as
        :class:`adavar.stats.stream.ChunkedSource` pieces read with file reads, never through a
        map (the command line's choice): a file truncated while it is read is then an
        error naming it, where touching a map past the file's new end kills the process
        (SIGBUS). Either way the analyses read them piece by piece. With a time column,
        or ``nan`` other than ``"error"``, ``False`` loads them with file reads.

    Returns
    -------
    Record
        ``meta`` lists the options and everything done (see :class:`Record`).

    Raises
    ------
    AdavarInputError
        A missing, unreadable, corrupt or unknown file, a symbolic link loop, a named pipe
        or device, a file that changed while it was read; a missing optional package (the
        message names it); no numeric column, an unknown or non-numeric column; no rate and
        no time column, or a declared rate disagreeing with the time stamps; time stamps
        that repeat or go back; a gap, non-uniform sampling or a NaN/infinite sample under
        the ``"error"`` policies (naming the row, time and size); invalid options.

    Notes
    -----
    A file that changes while it is read (its size, modification time or identity differ
    after reading, or out of core after each piece) is an error, as is one deleted
    meanwhile: a record is never analysed half old, half new.
    """
    if gaps not in GAP_POLICIES:
        raise fail(f"unknown gaps policy {gaps!r}: use one of {', '.join(GAP_POLICIES)}")
    if nan not in NAN_POLICIES:
        raise fail(f"unknown nan policy {nan!r}: use one of {', '.join(NAN_POLICIES)}")
    fmt = str(time_format).strip().lower()
    fmt = {"sec": "s", "seconds": "s", "µs": "us"}.get(fmt, fmt)
    if fmt not in TIME_FORMATS:
        raise fail(f"unknown time format {time_format!r}: use one of {', '.join(TIME_FORMATS)}")
    if isinstance(gap_tolerance, bool) or not (
        isinstance(gap_tolerance, numbers.Real) and 0 < gap_tolerance < 1
    ):
        raise fail(f"gap tolerance must be a number between 0 and 1, got {gap_tolerance!r}")
    if rate is not None:
        if (
            isinstance(rate, bool)
            or not isinstance(rate, numbers.Real)
            or not (math.isfinite(rate) and rate > 0)
        ):
            raise fail(f"rate must be a positive number of Hz, got {rate!r}")
        rate = float(rate)
    target = Path(path)
    src = str(target)
    before = _opened_state(target, src)
    kind = _kind_of(target)
    if kind == "ros2" and not target.is_dir():
        if not (target.parent / "metadata.yaml").is_file():
            raise fail(
                f"{src} is not in a ROS 2 bag folder (no metadata.yaml next to it): give the "
                "bag folder"
            )
        target = target.parent
        before = _opened_state(target, src)
    if lazy and kind not in ("hdf5", "parquet", "npy", "npz"):
        raise fail(
            f"{src} is read whole (lazy reading is for .npy, HDF5 and Parquet files): leave "
            "out lazy=True / --lazy, or convert the file to .npy"
        )
    if lazy and nan not in ("error", "keep"):
        raise fail(
            f"nan={nan!r} needs the whole record in memory, so it cannot be read lazily: "
            "leave out lazy=True / --lazy, or remove the bad samples first"
        )
    if dataset is not None and kind != "hdf5":
        raise fail(f"--dataset applies to HDF5 files only, not to {src}: leave it out")
    if topic is not None and kind not in ("ros1", "ros2"):
        raise fail(f"--topic applies to ROS bags only, not to {src}: leave it out")
    cols = as_list(columns)
    opts = {
        "columns": cols,
        "time_column": time_column,
        "time_format": fmt,
        "dataset": dataset,
        "topic": topic,
        "lazy": lazy,
        "nan": nan,
        "memory_map": bool(memory_map),
        "state": before,
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
    readers = {"csv": read_text, "stable32": read_stable32, "npy": read_npy,
               "npz": read_npz, "hdf5": read_hdf5, "parquet": read_parquet}  # fmt: skip
    try:
        if kind in readers:
            raw = readers[kind](target, src, opts)
        else:
            raw = read_rosbag(target, src, opts, ros2=kind == "ros2")
        record = finish_record(
            raw, rate=rate, gaps=gaps, nan=nan, tol=float(gap_tolerance), src=src, kind=kind,
            meta=meta,
        )  # fmt: skip
    except Exception:
        check_unchanged(target, before, src)  # a file cut short reads as nonsense
        raise
    check_unchanged(target, before, src)
    return record

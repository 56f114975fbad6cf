"""NumPy files: ``.npy`` arrays and ``.npz`` archives.

A 1-D array is one channel, a 2-D array is samples x channels, a structured array's fields
are columns; an ``.npz`` archive's 1-D arrays of equal length are columns (or its only
array is read as a ``.npy``). Files are never unpickled; a ``.npy`` and the stored
(uncompressed) members of an ``.npz`` are memory-mapped, so the analyses read a record
larger than memory piece by piece. With ``memory_map=False`` (the command line) their
columns are :class:`adavar.io.sources.NpyFileSource` pieces read with file reads instead, and
nothing is read through the map (whose pages, touched past the end of a file truncated
meanwhile, would kill the process with SIGBUS).
"""

from __future__ import annotations

import math
import struct
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from adavar.io.sources import ChunkedSource, FileState, check_unchanged, memmap_source
from adavar.readers.errors import fail, one_line
from adavar.readers.record import RawRecord
from adavar.readers.table import (
    Table,
    array_table,
    as_channel,
    channels_from_table,
    dt64_ns,
    numeric_kind,
)


def _read_whole(path: Path, arr: np.memmap, src: str, state: FileState | None) -> np.ndarray:
    """The array behind memory map ``arr``, read with file reads (the map left untouched)."""
    with open(path, "rb") as fh:
        fh.seek(int(arr.offset))
        flat = np.fromfile(fh, dtype=arr.dtype, count=arr.size)
    if flat.size != arr.size:
        check_unchanged(path, state, src)
        raise fail(f"{src} is shorter than its header says: re-save it")
    fortran = arr.ndim > 1 and arr.flags.f_contiguous and not arr.flags.c_contiguous
    return flat.reshape(arr.shape, order="F" if fortran else "C")


def _file_column(view: Any, state: FileState | None) -> Any:
    """A numeric 1-D view of a memory map as a source read with file reads, or None."""
    if not isinstance(view, np.memmap) or view.dtype.kind not in "iuf":
        return None
    source = memmap_source(view)
    if source is not None:
        source.state = state
    return source


def _unmapped_table(arr: np.memmap, path: Path, src: str, label: str, opts: dict) -> Table:
    """:func:`array_table` of ``arr`` with nothing read through the map: a numeric column is
    a source of file reads, anything else (structured arrays, date-times) the array read
    whole with file reads."""
    tab = array_table(arr, src, label)  # the names and kinds: nothing read yet
    state = opts.get("state")
    loaded: list[Table] = []

    def get(name: str) -> Any:
        if not arr.dtype.names and tab.kinds[name] == "num":
            column = _file_column(arr if arr.ndim == 1 else arr[:, int(name)], state)
            if column is not None:
                return column
        if not loaded:
            loaded.append(array_table(_read_whole(path, arr, src, state), src, label))
        return loaded[0].get(name)

    return Table(tab.names, tab.kinds, get, tab.n)


def _loaded(channels: dict[str, Any], src: str, opts: dict, timed: bool) -> dict[str, Any]:
    """Sources of file reads loaded whole where the record is needed in memory, as a memory
    map would be: with a time base (gaps, segments) or NaN to drop or interpolate (masks,
    fills). NaN kept stay in the file for the analyses (``gaps="omit"``) to stream."""
    if not timed and opts.get("nan", "error") in ("error", "keep"):
        return channels
    return {
        k: as_channel(v.read_unchecked(0, v.size), k, src) if isinstance(v, ChunkedSource) else v
        for k, v in channels.items()
    }


def read_npy(path: Path, src: str, opts: dict[str, Any]) -> RawRecord:
    """The record of a ``.npy`` file (memory-mapped)."""
    with open(path, "rb") as fh:
        if fh.read(6) != b"\x93NUMPY":
            raise fail(f"{src} is not a valid .npy file (no NumPy header): re-save it")
    try:
        arr = np.load(path, mmap_mode="r", allow_pickle=False)
    except ValueError as exc:
        if "pickle" in str(exc).casefold() or "object" in str(exc).casefold():
            raise fail(
                f"{src} holds Python objects (needs pickle, which is not loaded for safety): "
                "save a plain numeric array"
            ) from None
        raise fail(f"{src} is not a valid .npy file ({one_line(exc)}): re-save it") from None
    except (OSError, EOFError) as exc:
        raise fail(f"{src} is not a valid .npy file ({one_line(exc)}): re-save it") from None
    mapped = opts.get("memory_map", True) or not isinstance(arr, np.memmap)
    tab = array_table(arr, src, "0") if mapped else _unmapped_table(arr, path, src, "0", opts)
    channels, rel, t0, info = channels_from_table(
        tab, columns=opts["columns"], time_column=opts["time_column"],
        time_format=opts["time_format"], src=src,
    )  # fmt: skip
    if not mapped:
        channels = _loaded(channels, src, opts, rel is not None)
    info.update(memory_mapped=mapped and isinstance(arr, np.memmap), shape=list(arr.shape))
    return RawRecord(channels, rel, t0, None, "sample", info)


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


def read_npz(path: Path, src: str, opts: dict[str, Any]) -> RawRecord:
    """The record of an ``.npz`` file (stored members memory-mapped)."""
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
            raise fail(
                f"{src} holds Python objects (needs pickle, which is not loaded for safety): "
                "save plain numeric arrays"
            ) from None
        raise fail(f"{src} is not a valid .npz file ({one_line(exc)}): re-save it") from None
    except (OSError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise fail(f"{src} is not a valid .npz file ({one_line(exc)}): re-save it") from None
    if not arrays:
        raise fail(f"{src} holds no arrays: save the samples with numpy.savez")
    unmapped = not opts.get("memory_map", True)
    if len(arrays) == 1 and next(iter(arrays.values())).ndim != 1:
        key, arr = next(iter(arrays.items()))
        if unmapped and isinstance(arr, np.memmap):
            tab = _unmapped_table(arr, path, src, key, opts)
        else:
            tab = array_table(arr, src, key)
    else:
        series = {
            k: a for k, a in arrays.items()
            if a.ndim == 1 and not a.dtype.names and numeric_kind(a.dtype) != "text"
        }  # fmt: skip
        lengths = {len(a) for a in series.values()}
        if not series:
            raise fail(
                f"{src} holds no 1-D numeric array (keys: {', '.join(arrays)}): save each "
                "channel as a 1-D array"
            )
        if len(lengths) > 1:
            sizes = ", ".join(f"{k}: {len(a)}" for k, a in series.items())
            raise fail(
                f"the 1-D arrays of {src} differ in length ({sizes}): save channels of equal length"
            )
        names = list(series)

        def get(name: str) -> Any:
            column = _file_column(series[name], opts.get("state")) if unmapped else None
            if column is None and unmapped and isinstance(series[name], np.memmap):
                return dt64_ns(_read_whole(path, series[name], src, opts.get("state")))
            return dt64_ns(series[name]) if column is None else column

        tab = Table(
            names, {k: numeric_kind(a.dtype) for k, a in series.items()}, get, lengths.pop()
        )  # fmt: skip
    channels, rel, t0, info = channels_from_table(
        tab, columns=opts["columns"], time_column=opts["time_column"],
        time_format=opts["time_format"], src=src,
    )  # fmt: skip
    if unmapped:
        channels = _loaded(channels, src, opts, rel is not None)
        mapped = []
    info.update(
        keys=list(arrays), memory_mapped=bool(mapped) and all(k in mapped for k in channels)
    )
    return RawRecord(channels, rel, t0, None, "sample", info)

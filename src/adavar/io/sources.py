"""Records larger than memory: sources that are read piece by piece.

A :class:`ChunkedSource` is a 1-D record that is never loaded whole: the out-of-core paths
of :func:`adavar.davar`, :func:`adavar.adaptive_davar` and :func:`adavar.deviation` read it
``chunk_size`` samples at a time (plus an overlap of the longest window) and carry their
sequential state from chunk to chunk, so the result equals the in-memory one.

Where the data comes from:

- a ``.npy`` file (:class:`NpyFileSource`) or a :class:`numpy.memmap` of one: read with
  ordinary file reads into a fresh buffer, *not* through the memory map, so that the pages
  of an 800 MB file do not pile up in the process's resident memory;
- a ``dask.array`` (:class:`DaskSource`): each piece is computed on demand;
- an HDF5 dataset (:class:`HDF5Source`) or a Parquet column (:class:`ParquetSource`);
- any in-memory array (:class:`ArraySource`), for tests and for forcing the chunked path.

Every piece is returned as float64 and checked to be finite; a NaN or Inf is an error that
names its sample.
"""

from __future__ import annotations

import datetime
import os
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numba
import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.core.inputs import check_exact_integers

__all__ = [
    "DEFAULT_CHUNK",
    "ArraySource",
    "ChunkedSource",
    "DaskSource",
    "DifferencedSource",
    "FileState",
    "HDF5Source",
    "NpyFileSource",
    "ParquetSource",
    "as_source",
    "available_memory",
    "changed_error",
    "check_chunk_size",
    "check_unchanged",
    "file_state",
    "is_chunked",
    "is_dask",
    "memmap_source",
    "open_record",
    "read_extended",
    "threads_for",
]

#: samples per piece by default: 32 MiB of float64, a few times that in working memory
DEFAULT_CHUNK = 1 << 22
#: pieces shorter than this are integrated on the calling thread only
PARALLEL_MIN = 1 << 16


@dataclass(frozen=True)
class FileState:
    """What tells that a file changed: its size, modification time and identity.

    A folder (a ROS 2 bag) is the sum of its files' sizes and the latest of their times.
    """

    size: int
    mtime_ns: int
    inode: int
    device: int

    @classmethod
    def of(cls, st: os.stat_result) -> FileState:
        return cls(int(st.st_size), int(st.st_mtime_ns), int(st.st_ino), int(st.st_dev))


def file_state(path: str | os.PathLike[str]) -> FileState | None:
    """The :class:`FileState` of ``path`` now, or None when it is gone."""
    try:
        st = os.stat(path)
        if not stat.S_ISDIR(st.st_mode):
            return FileState.of(st)
        size, mtime = 0, int(st.st_mtime_ns)
        with os.scandir(path) as entries:
            for entry in entries:
                if entry.is_file():
                    est = entry.stat()
                    size += int(est.st_size)
                    mtime = max(mtime, int(est.st_mtime_ns))
        return FileState(size, mtime, int(st.st_ino), int(st.st_dev))
    except FileNotFoundError:
        return None


def _when(ns: int) -> str:
    return datetime.datetime.fromtimestamp(ns / 1e9).isoformat(sep=" ", timespec="milliseconds")


def changed_error(name: str, before: FileState, after: FileState | None) -> AdavarInputError:
    """The error for file ``name`` that changed (``after``) since it was first read."""
    way_out = "copy it first, or wait until its writer is done"
    if after is None:
        return AdavarInputError(f"{name} was deleted or moved while being read: {way_out}")
    what = []
    if (after.inode, after.device) != (before.inode, before.device):
        what.append("replaced by another file")
    if after.size != before.size:
        what.append(f"size {before.size} -> {after.size} bytes")
    if after.mtime_ns != before.mtime_ns:
        what.append(f"modified {_when(before.mtime_ns)} -> {_when(after.mtime_ns)}")
    return AdavarInputError(f"{name} changed while being read ({', '.join(what)}): {way_out}")


def check_unchanged(path: str | os.PathLike[str], before: FileState | None, name: str) -> None:
    """Fail with :func:`changed_error` when ``path`` is no longer in state ``before``."""
    if before is None:
        return
    after = file_state(path)
    if after != before:
        raise changed_error(name, before, after)


class ChunkedSource:
    """A 1-D record read piece by piece.

    Subclasses implement :meth:`_read_raw`; :meth:`read` converts to float64 and checks that
    every sample is finite.

    Attributes
    ----------
    size : int
        Number of samples.
    name : str
        What the record is (a file name and column), for error messages.
    """

    size: int = 0
    name: str = "record"
    dtype: np.dtype = np.dtype(np.float64)
    #: the file read and its state when it was opened (sources of a file): every read
    #: checks that it has not changed since, so a record is never read half old, half new
    path: Path | None = None
    state: FileState | None = None

    def __len__(self) -> int:
        return self.size

    @property
    def shape(self) -> tuple[int]:
        return (self.size,)

    def _read_raw(self, start: int, stop: int) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _read_file(self, start: int, stop: int) -> np.ndarray:
        """:meth:`_read_raw`, for a file source checked against its state after the read
        (and when the read fails: a truncated file is reported as changed, not as short)."""
        if self.state is None or self.path is None:
            return self._read_raw(start, stop)
        try:
            raw = self._read_raw(start, stop)
        except Exception:
            check_unchanged(self.path, self.state, self.name)
            raise
        check_unchanged(self.path, self.state, self.name)
        return raw

    def read_unchecked(self, start: int, stop: int) -> np.ndarray:
        """Samples ``start .. stop - 1`` in the source's own dtype, NaN and Inf included
        (for a scan that looks for them: :func:`adavar.readers.read_record`)."""
        return self._read_file(int(start), int(stop))

    def read(self, start: int, stop: int) -> np.ndarray:
        """Samples ``start .. stop - 1`` as a new float64 array (finite, checked)."""
        start, stop = int(start), int(stop)
        if not 0 <= start <= stop <= self.size:
            raise ValueError(f"internal: read({start}, {stop}) outside 0..{self.size}")
        raw = np.asarray(self._read_file(start, stop))
        check_exact_integers(raw, self.name, start)
        out = np.asarray(raw, dtype=np.float64)
        if out.shape != (stop - start,):  # pragma: no cover - a source broke its contract
            raise AdavarInputError(
                f"{self.name}: expected {stop - start} samples at {start}, got shape {out.shape}"
            )
        finite = np.isfinite(out)
        if not finite.all():
            first = int(np.argmin(finite))
            raise AdavarInputError(
                f"sample {start + first} of {self.name} is {float(out[first])}: remove or "
                "interpolate non-finite samples first"
            )
        return out

    ndim = 1

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> np.ndarray:
        """The whole record in memory (for code paths that need it; they say so)."""
        out = self.read(0, self.size)
        return out if dtype is None else out.astype(dtype, copy=False)

    def chunks(self, chunk_size: int = DEFAULT_CHUNK):
        """Yield ``(start, samples)`` over the whole record."""
        chunk_size = max(1, int(chunk_size))
        for start in range(0, self.size, chunk_size):
            yield start, self.read(start, min(self.size, start + chunk_size))


class ArraySource(ChunkedSource):
    """An in-memory 1-D array, read in pieces (forces the chunked path; used by tests)."""

    def __init__(self, array: Any, name: str = "array") -> None:
        arr = np.asarray(array)
        if arr.ndim != 1:
            arr = np.squeeze(arr)
        _check_numeric(arr, name)
        self.array = arr
        self.size = int(arr.size)
        self.dtype = arr.dtype
        self.name = name

    def _read_raw(self, start: int, stop: int) -> np.ndarray:
        return self.array[start:stop]


class NpyFileSource(ChunkedSource):
    """A ``.npy`` file (1-D, or one column of a 2-D C-ordered array), read with file reads.

    Parameters
    ----------
    path : str or Path
        The file.
    column : int, optional
        Column of a 2-D (samples x channels) array.
    offset, shape, dtype, fortran_order
        Header fields, when already known (from a :class:`numpy.memmap`).
    state : FileState, optional
        The file's state when its reading began (default: now); a read that finds it
        changed fails (:func:`changed_error`).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        column: int | None = None,
        *,
        offset: int | None = None,
        shape: tuple[int, ...] | None = None,
        dtype: Any = None,
        fortran_order: bool = False,
        state: FileState | None = None,
    ) -> None:
        self.path = Path(path)
        self.name = self.path.name if column is None else f"{self.path.name} column {column}"
        self.state = file_state(self.path) if state is None else state
        if offset is None or shape is None or dtype is None:
            with open(self.path, "rb") as fh:
                fmt = np.lib.format
                major, _ = fmt.read_magic(fh)
                header = fmt.read_array_header_1_0 if major == 1 else fmt.read_array_header_2_0
                shape, fortran_order, dtype = header(fh)
                offset = fh.tell()
        dtype = np.dtype(dtype)
        _check_numeric(np.empty(0, dtype=dtype), self.name)
        if len(shape) == 1 or (len(shape) == 2 and shape[1] == 1 and column in (None, 0)):
            self.stride, self.column = 1, 0
        elif len(shape) == 2:
            if column is None:
                raise AdavarInputError(
                    f"{self.path.name} holds {shape[1]} channels: choose one with a column index"
                )
            if not 0 <= int(column) < shape[1]:
                raise AdavarInputError(
                    f"{self.path.name} has columns 0..{shape[1] - 1}, not {column}"
                )
            if fortran_order:  # a column is contiguous
                offset += int(column) * shape[0] * dtype.itemsize
                self.stride, self.column = 1, 0
            else:
                self.stride, self.column = int(shape[1]), int(column)
        else:
            raise AdavarInputError(
                f"{self.path.name} holds an array of shape {tuple(shape)}: give 1-D or 2-D"
            )
        self.size = int(shape[0])
        self.dtype = dtype
        self.offset = int(offset)

    def _read_raw(self, start: int, stop: int) -> np.ndarray:
        if stop == start:
            return np.empty(0, dtype=self.dtype)
        # from this channel's first sample to its last: no trailing row past the file's end
        count = (stop - start - 1) * self.stride + 1
        try:
            fh = open(self.path, "rb")
        except FileNotFoundError:
            check_unchanged(self.path, self.state, self.name)
            raise
        with fh:
            fh.seek(self.offset + (start * self.stride + self.column) * self.dtype.itemsize)
            raw = np.fromfile(fh, dtype=self.dtype, count=count)
        if raw.size != count:
            check_unchanged(self.path, self.state, self.name)  # truncated meanwhile?
            raise AdavarInputError(f"{self.path.name} is shorter than its header says: re-save it")
        return raw if self.stride == 1 else raw[:: self.stride]


class DaskSource(ChunkedSource):
    """A 1-D ``dask.array``; each piece is computed when read."""

    def __init__(self, array: Any, name: str = "dask array") -> None:
        if array.ndim != 1:
            raise AdavarInputError(
                f"the dask array has shape {array.shape}: pass one channel (1-D)"
            )
        if any(np.isnan(s) for s in array.shape):
            raise AdavarInputError(
                "the dask array has unknown chunk sizes: call .compute_chunk_sizes() first"
            )
        _check_numeric(np.empty(0, dtype=array.dtype), name)
        self.array = array
        self.size = int(array.shape[0])
        self.dtype = np.dtype(array.dtype)
        self.name = name

    def _read_raw(self, start: int, stop: int) -> np.ndarray:
        return np.asarray(self.array[start:stop].compute())


class HDF5Source(ChunkedSource):
    """A 1-D HDF5 dataset (or one column of a 2-D one), read by hyperslabs."""

    def __init__(self, path: str | os.PathLike[str], dataset: str, column: int | None = None):
        import h5py

        self.path = Path(path)
        self.dataset = dataset
        self.column = column
        with h5py.File(self.path, "r") as f:
            obj = f[dataset]
            shape, dtype = obj.shape, obj.dtype
        _check_numeric(np.empty(0, dtype=dtype), f"{self.path.name}:{dataset}")
        if len(shape) == 2 and column is None and shape[1] != 1:
            raise AdavarInputError(
                f"{self.path.name}:{dataset} holds {shape[1]} channels: choose a column"
            )
        if len(shape) not in (1, 2):
            raise AdavarInputError(f"{self.path.name}:{dataset} has shape {shape}: give 1-D/2-D")
        self.size = int(shape[0])
        self.dtype = np.dtype(dtype)
        self.name = f"{self.path.name}:{dataset}"
        self.state = file_state(self.path)
        self._handle: Any = None

    def _read_raw(self, start: int, stop: int) -> np.ndarray:
        import h5py

        if self._handle is None:
            self._handle = h5py.File(self.path, "r")
        obj = self._handle[self.dataset]
        if obj.ndim == 1:
            return obj[start:stop]
        return obj[start:stop, 0 if self.column is None else int(self.column)]

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["_handle"] = None
        return state


class ParquetSource(ChunkedSource):
    """One numeric column of a Parquet file, read row group by row group."""

    def __init__(self, path: str | os.PathLike[str], column: str) -> None:
        import pyarrow.parquet as pq

        self.path = Path(path)
        self.column = column
        meta = pq.ParquetFile(self.path).metadata
        self._group_rows = np.array(
            [meta.row_group(g).num_rows for g in range(meta.num_row_groups)], dtype=np.int64
        )
        self._group_start = np.concatenate([[0], np.cumsum(self._group_rows)])
        self.size = int(meta.num_rows)
        self.name = f"{self.path.name} column {column!r}"
        self.state = file_state(self.path)
        self._file: Any = None
        self._cache: tuple[int, np.ndarray] | None = None

    def _group(self, g: int) -> np.ndarray:
        import pyarrow.parquet as pq

        if self._cache is not None and self._cache[0] == g:
            return self._cache[1]
        if self._file is None:
            self._file = pq.ParquetFile(self.path)
        col = self._file.read_row_group(g, columns=[self.column]).column(0)
        values = col.to_numpy(zero_copy_only=False).astype(np.float64)
        self._cache = (g, values)
        return values

    def _read_raw(self, start: int, stop: int) -> np.ndarray:
        out = np.empty(stop - start)
        g = int(np.searchsorted(self._group_start, start, side="right") - 1)
        pos = start
        while pos < stop:
            g0 = int(self._group_start[g])
            values = self._group(g)
            take = min(stop, g0 + values.size) - pos
            out[pos - start : pos - start + take] = values[pos - g0 : pos - g0 + take]
            pos += take
            g += 1
        return out

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["_file"] = None
        state["_cache"] = None
        return state


class DifferencedSource(ChunkedSource):
    """First differences ``x[i + 1] - x[i]`` of another source (phase in, increments out)."""

    def __init__(self, source: ChunkedSource) -> None:
        self.source = source
        self.size = max(0, source.size - 1)
        self.name = source.name

    def _read_raw(self, start: int, stop: int) -> np.ndarray:
        return np.diff(self.source.read(start, stop + 1))


def _check_numeric(arr: np.ndarray, name: str) -> None:
    if arr.dtype == object or not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool):
        raise AdavarInputError(f"{name} is not numeric: pass a 1-D array of samples")
    if np.iscomplexobj(arr):
        raise AdavarInputError(f"{name} is complex: pass real samples")


def is_dask(data: Any) -> bool:
    return type(data).__module__.startswith("dask.") and hasattr(data, "compute")


def is_chunked(data: Any) -> bool:
    """Whether ``data`` is read piece by piece: a source, a dask array or a file memory map."""
    return isinstance(data, ChunkedSource) or is_dask(data) or _memmap_file(data) is not None


def _memmap_file(data: Any) -> NpyFileSource | None:
    """A file source for a 1-D view of a file memory map (any offset and stride), or None.

    ``np.load(..., mmap_mode="r")`` gives such maps, and a column of a 2-D one is a strided
    view of the same map; both are read back with file reads at the view's own position.
    """
    if not isinstance(data, np.memmap) or getattr(data, "filename", None) is None:
        return None
    import mmap

    mm = data.base  # a view's base is the map it was taken from; the map's, the mmap
    while isinstance(mm, np.ndarray):
        mm = mm.base
    if not isinstance(mm, mmap.mmap) or data.ndim != 1 or data.size == 0:
        return None
    itemsize = data.dtype.itemsize
    stride = data.strides[0]
    if stride <= 0 or stride % itemsize:
        return None
    try:
        base = np.frombuffer(mm, dtype=np.uint8).__array_interface__["data"][0]
    except (TypeError, ValueError):  # pragma: no cover - a closed or exotic map
        return None
    # np.memmap maps from the allocation-granularity boundary below its offset
    start = int(data.offset) - int(data.offset) % mmap.ALLOCATIONGRANULARITY
    position = start + data.__array_interface__["data"][0] - base
    src = NpyFileSource.__new__(NpyFileSource)
    src.path = Path(data.filename)
    src.name = src.path.name
    src.size = int(data.size)
    src.dtype = data.dtype
    src.offset = int(position)
    src.stride = stride // itemsize
    src.column = 0
    src.state = file_state(src.path)
    _check_numeric(np.empty(0, dtype=data.dtype), src.name)
    return src


def memmap_source(data: Any) -> NpyFileSource | None:
    """The file behind a 1-D :class:`numpy.memmap` view, read with file reads; None otherwise."""
    return _memmap_file(data)


def as_source(data: Any, *, name: str = "record") -> ChunkedSource:
    """A :class:`ChunkedSource` for ``data`` (a source, a dask array, a memory map or an array).

    Parameters
    ----------
    data : ChunkedSource, dask.array.Array, numpy.memmap or array_like
        The record.
    name : str
        How errors name it.
    """
    if isinstance(data, ChunkedSource):
        return data
    if is_dask(data):
        return DaskSource(data, name=name)
    mapped = _memmap_file(data)
    if mapped is not None:
        return mapped
    return ArraySource(data, name=name)


def check_chunk_size(value: Any) -> int:
    """``chunk_size`` as a positive int, or a one-line error."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise AdavarInputError(
            f"chunk_size must be a positive whole number of samples, got {value!r}"
        )
    return int(value)


def open_record(data: Any, min_length: int) -> ChunkedSource:
    """The record as a source, checked like :func:`adavar.stats.statistics.as_samples`."""
    source = as_source(data)
    if isinstance(source, ArraySource) and source.array.ndim != 1:
        raise AdavarInputError(
            f"data must be one channel (1-D); got shape {np.shape(data)}: pass one column"
        )
    if source.size < min_length:
        raise AdavarInputError(
            f"the record has {source.size} samples; at least {min_length} are needed"
        )
    return source


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (Linux), or None if unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:  # pragma: no cover - not Linux
        return None
    return None  # pragma: no cover


def read_extended(source: ChunkedSource, start: int, stop: int, pad_before: int) -> np.ndarray:
    """Samples ``start .. stop - 1`` of the record extended by time reversal at both ends.

    Index ``e`` of the extended record is sample ``e - pad_before`` of the record, mirrored
    as ``numpy.pad(..., mode="symmetric")`` does (``-1 -> 0``, ``n -> n - 1``) when it
    falls outside. Reads only the samples it needs.
    """
    n = source.size
    lo, hi = int(start) - int(pad_before), int(stop) - int(pad_before)
    if lo >= 0 and hi <= n:
        return source.read(lo, hi)
    if lo < -n or hi > 2 * n:
        raise ValueError("internal: the extension reaches past one full reflection")
    idx = np.arange(lo, hi)
    idx = np.where(idx < 0, -idx - 1, idx)
    idx = np.where(idx >= n, 2 * n - 1 - idx, idx)
    first, last = int(idx.min()), int(idx.max())
    return source.read(first, last + 1)[idx - first]


@contextmanager
def threads_for(size: int) -> Iterator[None]:
    """Run the parallel kernels on one thread for a piece of fewer than PARALLEL_MIN samples.

    Waking the thread pool costs microseconds on an idle machine but milliseconds on a
    busy one (a descheduled worker holds up the barrier), far more than a short piece's
    arithmetic; out-of-core paths with many short pieces would pay it every time.
    """
    if size >= PARALLEL_MIN:
        yield
        return
    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(previous)

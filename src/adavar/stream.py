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

import os
from pathlib import Path
from typing import Any

import numpy as np

from adavar.errors import AdavarInputError

__all__ = [
    "DEFAULT_CHUNK",
    "ArraySource",
    "ChunkedSource",
    "DaskSource",
    "DifferencedSource",
    "HDF5Source",
    "NpyFileSource",
    "ParquetSource",
    "as_source",
    "is_chunked",
    "read_extended",
]

#: samples per piece by default: 32 MiB of float64, a few times that in working memory
DEFAULT_CHUNK = 1 << 22


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

    def __len__(self) -> int:
        return self.size

    @property
    def shape(self) -> tuple[int]:
        return (self.size,)

    def _read_raw(self, start: int, stop: int) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def read(self, start: int, stop: int) -> np.ndarray:
        """Samples ``start .. stop - 1`` as a new float64 array (finite, checked)."""
        start, stop = int(start), int(stop)
        if not 0 <= start <= stop <= self.size:
            raise ValueError(f"internal: read({start}, {stop}) outside 0..{self.size}")
        out = np.asarray(self._read_raw(start, stop), dtype=np.float64)
        if out.shape != (stop - start,):  # pragma: no cover - a source broke its contract
            raise AdavarInputError(
                f"{self.name}: expected {stop - start} samples at {start}, got shape {out.shape}"
            )
        finite = np.isfinite(out)
        if not finite.all():
            first = int(np.argmin(finite))
            raise AdavarInputError(
                f"sample {start + first} of {self.name} is {out[first]!r}: remove or "
                "interpolate non-finite samples first"
            )
        return out

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
    ) -> None:
        self.path = Path(path)
        self.name = self.path.name if column is None else f"{self.path.name} column {column}"
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
        count = (stop - start) * self.stride
        with open(self.path, "rb") as fh:
            fh.seek(self.offset + start * self.stride * self.dtype.itemsize)
            raw = np.fromfile(fh, dtype=self.dtype, count=count)
        if raw.size != count:
            raise AdavarInputError(f"{self.path.name} is shorter than its header says: re-save it")
        return raw if self.stride == 1 else raw[self.column :: self.stride]


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


def _is_dask(data: Any) -> bool:
    return type(data).__module__.startswith("dask.") and hasattr(data, "compute")


def is_chunked(data: Any) -> bool:
    """Whether ``data`` is read piece by piece: a source, a dask array or a file memory map."""
    return isinstance(data, ChunkedSource) or _is_dask(data) or _memmap_file(data) is not None


def _memmap_file(data: Any) -> NpyFileSource | None:
    """A file source for a read-only-able memory map of a ``.npy`` file, or None."""
    if not isinstance(data, np.memmap) or getattr(data, "filename", None) is None:
        return None
    base = data
    # np.load(mmap_mode=...) views: a 1-D map, or a column of a C-ordered 2-D map
    if base.ndim == 1 and base.flags.c_contiguous:
        offset = int(getattr(base, "offset", 0))
        return NpyFileSource(base.filename, offset=offset, shape=base.shape, dtype=base.dtype)
    return None


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
    if _is_dask(data):
        return DaskSource(data, name=name)
    mapped = _memmap_file(data)
    if mapped is not None:
        return mapped
    return ArraySource(data, name=name)


def read_extended(
    source: ChunkedSource, start: int, stop: int, pad_before: int
) -> np.ndarray:
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

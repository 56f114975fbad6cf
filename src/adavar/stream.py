"""Public face of :mod:`adavar.stats.stream`:
``import adavar.stream`` works as documented.

The names are defined and documented in :mod:`adavar.stats.stream`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.stats.stream import (
    DEFAULT_CHUNK,
    PARALLEL_MIN,
    ArraySource,
    ChunkedSource,
    DaskSource,
    DifferencedSource,
    HDF5Source,
    NpyFileSource,
    ParquetSource,
    as_source,
    available_memory,
    check_chunk_size,
    is_chunked,
    is_dask,
    memmap_source,
    noise_types,
    open_record,
    read_extended,
    threads_for,
)

__all__ = [
    "DEFAULT_CHUNK",
    "PARALLEL_MIN",
    "ArraySource",
    "ChunkedSource",
    "DaskSource",
    "DifferencedSource",
    "HDF5Source",
    "NpyFileSource",
    "ParquetSource",
    "as_source",
    "available_memory",
    "check_chunk_size",
    "is_chunked",
    "is_dask",
    "memmap_source",
    "noise_types",
    "open_record",
    "read_extended",
    "threads_for",
]

"""Parquet files (``.parquet .pq``), read with pyarrow (imported when a file is read).

Integer, floating and decimal columns are numeric, timestamp and date columns are time
stamps, string columns of ISO 8601 times are time stamps too (other strings are unusable);
null cells are missing samples. Large numeric columns, with no time column, are read piece
by piece (:mod:`adavar.readers.lazy`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from adavar.io.sources import ParquetSource
from adavar.readers.errors import fail, one_line, require
from adavar.readers.lazy import has_time_column, lazy_refused, lazy_wanted, no_time_column
from adavar.readers.record import RawRecord
from adavar.readers.table import Table, channels_from_table, is_iso, time_name_unit


def _lazy_parquet(path: Path, src: str, opts: dict[str, Any], pa: Any, pq: Any) -> RawRecord | None:
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
    if not lazy_wanted(opts, int(meta.num_rows) * width):
        return None
    kinds = {n: ("num" if ok else "text") for n, ok in numeric.items()}
    tab = Table(list(schema.names), kinds, lambda n: ParquetSource(path, n), int(meta.num_rows))
    tab.units = _field_units(schema)
    timed = [
        n for n, typ in zip(schema.names, schema.types, strict=True)
        if time_name_unit(n)[0] or pa.types.is_timestamp(typ) or pa.types.is_date(typ)
        or pa.types.is_string(typ) or pa.types.is_large_string(typ)
    ]  # fmt: skip
    no_time = no_time_column(opts.get("time_column"), schema.names)
    if (timed and not no_time) or has_time_column(opts, schema.names):
        if opts.get("lazy"):
            raise lazy_refused(src, "a time column needs every time stamp in memory")
        return None
    channels, rel, t0, info = channels_from_table(
        tab, columns=opts["columns"], time_column=opts["time_column"] if no_time else None,
        time_format=opts["time_format"], src=src,
    )  # fmt: skip
    return RawRecord(channels, rel, t0, None, "sample", info)


def read_parquet(path: Path, src: str, opts: dict[str, Any]) -> RawRecord:
    """The record of a Parquet file (numeric columns piece by piece when lazy)."""
    pa = require("pyarrow", "Parquet")
    pq = require("pyarrow.parquet", "Parquet")
    lazy = _lazy_parquet(path, src, opts, pa, pq)
    if lazy is not None:
        return lazy
    try:
        table = pq.read_table(path)
    except (OSError, pa.ArrowException, ValueError) as exc:
        raise fail(
            f"{src} is not a readable Parquet file ({one_line(exc)}): re-export it"
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
            kinds[name] = "iso" if sample and all(is_iso(s) for s in sample) else "text"
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

    tab = Table(list(table.column_names), kinds, get, table.num_rows, None, why_not)
    tab.units = _field_units(table.schema)
    channels, rel, t0, info = channels_from_table(
        tab, columns=opts["columns"], time_column=opts["time_column"],
        time_format=opts["time_format"], src=src,
    )  # fmt: skip
    return RawRecord(channels, rel, t0, None, "sample", info)


def _field_units(schema: Any) -> dict[str, str]:
    """The ``units`` (or ``unit``) metadata of each field that has one."""
    out = {}
    for field in schema:
        meta = field.metadata or {}
        value = meta.get(b"units", meta.get(b"unit"))
        if value:
            out[field.name] = value.decode("utf-8", "replace")
    return out

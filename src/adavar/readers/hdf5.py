"""HDF5 files (``.h5 .hdf5 .he5``), read with h5py (imported when a file is read).

The record is one dataset (1-D, 2-D samples x channels, or compound with fields as
columns) or a group of equal-length 1-D datasets, chosen with ``dataset`` or found as the
only numeric dataset (or the group holding all of them); a ``units`` attribute is kept in
``meta``. A large plain numeric dataset without a time column is read piece by piece
(:mod:`adavar.readers.lazy`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from adavar.io.sources import HDF5Source
from adavar.readers.errors import fail, one_line, require
from adavar.readers.lazy import has_time_column, lazy_refused, lazy_wanted
from adavar.readers.record import RawRecord
from adavar.readers.table import Table, array_table, channels_from_table, dt64_ns, numeric_kind


def read_hdf5(path: Path, src: str, opts: dict[str, Any]) -> RawRecord:
    """The record of an HDF5 file (the dataset or group chosen, or found)."""
    h5py = require("h5py", "HDF5")
    try:
        handle = h5py.File(path, "r")
    except OSError as exc:
        raise fail(f"{src} is not a readable HDF5 file ({one_line(exc)}): re-export it") from None
    with handle as f:
        found: list[str] = []

        def visit(name: str, obj: Any) -> None:
            if (
                isinstance(obj, h5py.Dataset)
                and (obj.dtype.names or numeric_kind(obj.dtype) != "text")
                and obj.ndim in (1, 2)
            ):
                found.append("/" + name)

        f.visititems(visit)
        listed = ", ".join(found[:10]) + (", ..." if len(found) > 10 else "")
        dataset = opts["dataset"]
        if dataset is not None:
            obj = f.get(dataset)
            if obj is None:
                raise fail(f"no dataset {dataset!r} in {src}; numeric datasets: {listed or 'none'}")
        elif len(found) == 1:
            obj = f[found[0]]
        elif not found:
            raise fail(f"{src} holds no numeric 1-D or 2-D dataset: give another file")
        else:
            parents = {p.rsplit("/", 1)[0] for p in found}
            lengths = {f[p].shape[0] for p in found}
            if len(parents) == 1 and len(lengths) == 1 and all(f[p].ndim == 1 for p in found):
                obj = f[parents.pop() or "/"]
            else:
                raise fail(
                    f"{src} holds {len(found)} numeric datasets ({listed}): choose one (or a "
                    "group of 1-D datasets) with --dataset PATH"
                )
        if isinstance(obj, h5py.Group):
            members = {
                k: v for k, v in obj.items()
                if isinstance(v, h5py.Dataset) and v.ndim == 1 and not v.dtype.names
                and numeric_kind(v.dtype) != "text"
            }  # fmt: skip
            if not members:
                raise fail(
                    f"group {obj.name!r} of {src} holds no 1-D numeric dataset; numeric "
                    f"datasets: {listed or 'none'}"
                )
            lengths = {k: v.shape[0] for k, v in members.items()}
            if len(set(lengths.values())) > 1:
                raise fail(
                    f"the datasets of group {obj.name!r} in {src} differ in length "
                    f"({', '.join(f'{k}: {n}' for k, n in lengths.items())}): choose one "
                    "with --dataset PATH"
                )
            data = {k: _unpacked(v, v[()], src) for k, v in members.items()}
            names = list(data)
            tab = Table(
                names, {k: numeric_kind(data[k].dtype) for k in names},
                data.__getitem__, next(iter(lengths.values())),
            )  # fmt: skip
            tab.units = {k: _attr_text(v.attrs.get("units")) for k, v in members.items()
                         if v.attrs.get("units") is not None}  # fmt: skip
            where = obj.name
        elif lazy_wanted(opts, obj.size * obj.dtype.itemsize) and _lazy_hdf5_ok(obj, opts, src):
            dname, flat = obj.name, obj.ndim == 1
            names = [dname.rsplit("/", 1)[-1]] if flat else [str(j) for j in range(obj.shape[1])]
            tab = Table(
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
                raise fail(f"cannot read dataset {obj.name!r} of {src}: {one_line(exc)}") from None
            arr = _unpacked(obj, np.asarray(arr), src)
            tab = array_table(arr, f"{src}:{obj.name}", obj.name.rsplit("/", 1)[-1])
            if obj.attrs.get("units") is not None and len(tab.names) == 1:
                tab.units = {tab.names[0]: _attr_text(obj.attrs["units"])}
            where = obj.name
        channels, rel, t0, info = channels_from_table(
            tab, columns=opts["columns"], time_column=opts["time_column"],
            time_format=opts["time_format"], src=src,
        )  # fmt: skip
    info["dataset"] = where
    return RawRecord(channels, rel, t0, None, "sample", info)


def _packing(obj: Any) -> tuple[float, float] | None:
    """``(scale_factor, add_offset)`` of a dataset stored packed (the CF convention:
    value = stored * scale_factor + add_offset), or None."""
    scale, offset = obj.attrs.get("scale_factor"), obj.attrs.get("add_offset")
    if scale is None and offset is None:
        return None
    return (1.0 if scale is None else scale), (0.0 if offset is None else offset)


def _unpacked(obj: Any, values: np.ndarray, src: str) -> np.ndarray:
    """``values`` of dataset ``obj`` unpacked by its ``scale_factor`` and ``add_offset``
    (float64), as any CF reader does; else as they are (date-times as nanoseconds)."""
    packing = _packing(obj)
    if packing is None:
        return dt64_ns(values)
    try:
        scale, offset = (float(np.asarray(v, dtype=float).reshape(-1)[0]) for v in packing)
    except (TypeError, ValueError, IndexError):
        raise fail(
            f"dataset {obj.name!r} of {src} has a scale_factor or add_offset that is not a "
            "number: fix the attribute, or store the values unpacked"
        ) from None
    if obj.dtype.names or numeric_kind(obj.dtype) != "num":
        raise fail(
            f"dataset {obj.name!r} of {src} has a scale_factor or add_offset but holds "
            f"{obj.dtype} values: store numbers, or the values unpacked"
        )
    return np.asarray(values, dtype=np.float64) * scale + offset


def _lazy_hdf5_ok(obj: Any, opts: dict[str, Any], src: str) -> bool:
    """A plain numeric 1-D/2-D dataset, no time column: readable piece by piece."""
    why = None
    if obj.dtype.names or numeric_kind(obj.dtype) != "num":
        why = "a compound or date-time dataset"
    elif obj.ndim not in (1, 2):
        why = f"shape {obj.shape}"
    elif has_time_column(opts):
        why = "a time column needs every time stamp in memory"
    elif _packing(obj) is not None:
        why = "its values are packed (scale_factor, add_offset)"
    if why is not None and opts.get("lazy"):
        raise lazy_refused(src, why)
    return why is None


def _attr_text(value: Any) -> str:
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray) and value.size == 1:
        return _attr_text(value.reshape(-1)[0])
    return str(value)

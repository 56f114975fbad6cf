"""Writing results: output folders and files atomically, the DAVAR surface, JSON and CSV.

:func:`atomic_directory` builds an output folder under a temporary sibling name and moves it
into place only when everything in it was written, so an interrupted or failed run never
leaves a half-written folder behind (SIGTERM removes the temporary; a later run sweeps the
temporaries of killed runs); every folder it writes holds :data:`OUTPUT_MARKER` with the
list of its files, and only such a folder that holds nothing else is ever replaced.
:func:`atomic_file` does the same for one file (both from :mod:`adavar.core.atomic`).
:func:`write_surface` writes a DAVAR surface as NetCDF (readable by xarray, netCDF4,
``scipy.io.netcdf_file``, ncdump, ...) or Parquet (pandas, pyarrow, polars, DuckDB, ...),
so that it can be read without adavar. :func:`dumps`, :func:`deviation_json` and
:func:`fit_json` give the JSON that ``adavar ... --json`` prints and ``result.json`` holds;
:func:`csv_text` (from :mod:`adavar.core.csv_tables`, re-exported here) makes every CSV adavar
writes (plain: the header row first, text cells a spreadsheet would run as a formula
neutralised), :func:`write_deviation_csv` the ``deviation.csv`` of ``avar`` and ``batch``.

Every problem with the user's input raises :class:`adavar.core.errors.AdavarInputError` with a
one-line message that names the problem and the way out.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adavar.core.atomic import (
    BATCH_MARKER,
    DEMO_MARKER,
    OUTPUT_MARKER,
    PAUSE_BEFORE_RENAME_ENV,
    PAUSE_FILE_RENAME_ENV,
    STALE_TEMPORARY_S,
    atomic_directory,
    atomic_file,
    check_output_directory,
    foreign_files,
    is_adavar_folder,
    partial_name,
    remove_partial_files,
    sweep_partial_files,
    sweep_stale_temporaries,
    write_marker,
)
from adavar.core.csv_tables import (
    CSV_PIECE_ROWS,
    block_rows,
    csv_cell,
    csv_pieces,
    csv_text,
    spreadsheet_safe,
    write_pieces,
)
from adavar.core.errors import AdavarInputError

if TYPE_CHECKING:
    from adavar.core.results import DavarResult, DeviationResult, NoiseFit

__all__ = [
    "BATCH_MARKER",
    "CSV_PIECE_ROWS",
    "DEMO_MARKER",
    "OUTPUT_MARKER",
    "PAUSE_BEFORE_RENAME_ENV",
    "PAUSE_FILE_RENAME_ENV",
    "STALE_TEMPORARY_S",
    "SURFACE_FORMATS",
    "atomic_directory",
    "atomic_file",
    "block_rows",
    "check_output_directory",
    "check_surface_format",
    "conventional",
    "csv_cell",
    "csv_pieces",
    "csv_text",
    "deviation_json",
    "dumps",
    "fit_json",
    "foreign_files",
    "is_adavar_folder",
    "jsonable",
    "partial_name",
    "remove_partial_files",
    "spreadsheet_safe",
    "sweep_partial_files",
    "sweep_stale_temporaries",
    "write_deviation_csv",
    "write_marker",
    "write_pieces",
    "write_surface",
]


def _fail(message: str) -> AdavarInputError:
    return AdavarInputError(message)


# --------------------------------------------------------------------------------------
# DAVAR surfaces
# --------------------------------------------------------------------------------------

#: File formats of :func:`write_surface` and the file-name suffix of each.
SURFACE_FORMATS: dict[str, str] = {"nc": ".nc", "parquet": ".parquet"}

_FORMAT_ALIASES = {
    "nc": "nc",
    "netcdf": "nc",
    "cdf": "nc",
    "parquet": "parquet",
    "pq": "parquet",
}
#: A 64-bit-offset (CDF-2) NetCDF file holds variables of at most 4 GiB - 4 bytes.
_NETCDF_MAX_VARIABLE = 2**32 - 4
_INT32 = np.iinfo(np.int32)


def _require_pyarrow() -> tuple[Any, Any]:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise _fail(
            "writing Parquet needs pyarrow, which is not installed: pip install pyarrow "
            "(or write NetCDF, format 'nc', which needs nothing more)"
        ) from None
    return pa, pq


def check_surface_format(fmt: str) -> str:
    """Check a surface file format (and that its writer is installed) before any work.

    Parameters
    ----------
    fmt : str
        ``"nc"`` (also ``"netcdf"``, ``"cdf"``) or ``"parquet"`` (also ``"pq"``), case
        insensitive, with or without a leading dot.

    Returns
    -------
    str
        ``"nc"`` or ``"parquet"`` (a key of :data:`SURFACE_FORMATS`).

    Raises
    ------
    AdavarInputError
        An unknown format, or ``"parquet"`` without pyarrow installed (the message names
        the fix, ``pip install pyarrow``).
    """
    key = _FORMAT_ALIASES.get(str(fmt).strip().lower().lstrip("."))
    if key is None:
        raise _fail(f"unknown surface format {fmt!r}: use 'nc' (NetCDF) or 'parquet'")
    if key == "parquet":
        _require_pyarrow()
    return key


def _surface_format(path: Path, fmt: str | None) -> str:
    if fmt is not None:
        return check_surface_format(fmt)
    key = _FORMAT_ALIASES.get(path.suffix.lower().lstrip("."), "nc")
    return check_surface_format(key)


def _surface_variables(result: DavarResult) -> list[tuple[str, tuple[str, ...], Any, dict]]:
    """(name, dimensions, data, CF attributes) of every variable of a surface file."""
    unit = result.units
    unit2: str | None
    if unit is None:
        unit2 = None
    elif unit.strip() in ("", "1"):
        unit2 = "1"
    else:
        unit2 = f"({unit})^2"

    def with_unit(attrs: dict[str, Any]) -> dict[str, Any]:
        return attrs if unit2 is None else {"units": unit2, **attrs}

    out: list[tuple[str, tuple[str, ...], Any, dict]] = [
        ("time", ("time",), result.time, {"units": "s", "long_name": "window centre time"}),
        ("tau", ("tau",), result.tau, {"units": "s", "long_name": "averaging time"}),
        ("avar", ("time", "tau"), result.avar,
         with_unit({"long_name": "overlapping Allan variance of the window",
                    "comment": "NaN where tau exceeds a third of the window"})),
    ]  # fmt: skip
    if result.avar_low is not None and result.avar_high is not None:
        level = f"{100 * float(result.confidence):.4g} %"
        for name, data, side in (
            ("avar_low", result.avar_low, "lower"),
            ("avar_high", result.avar_high, "upper"),
        ):
            attrs = {
                "long_name": f"{side} bound of the {level} confidence interval of avar",
                "confidence": float(result.confidence),
            }
            out.append((name, ("time", "tau"), data, with_unit(attrs)))
    out += [
        ("window", ("time",), result.window,
         {"units": "1", "long_name": "window length in samples"}),
        ("centre", ("time",), result.centre,
         {"units": "1", "long_name": "index of the window's centre sample in the record"}),
        ("m", ("tau",), result.m, {"units": "1", "long_name": "averaging factor tau / tau0"}),
        ("alpha", ("tau",), result.alpha,
         {"units": "1",
          "long_name": "power-law noise exponent used for the EDF (-1: not identified)"}),
    ]  # fmt: skip
    return out


def _global_attributes(result: DavarResult) -> dict[str, Any]:
    from adavar import __version__

    return {
        "Conventions": "CF-1.8",
        "title": "Dynamic Allan variance",
        "source": f"adavar {__version__}",
        **result.metadata(),
    }


def _nc_attribute(value: Any) -> Any:
    """An attribute value scipy's NetCDF writer stores faithfully (doubles, not floats)."""
    if isinstance(value, str):
        return value.encode("utf-8")
    if isinstance(value, (bool, np.bool_)):
        return np.int32(value)
    if isinstance(value, (int, np.integer)):
        return np.int32(value) if _INT32.min <= value <= _INT32.max else np.float64(value)
    if isinstance(value, (float, np.floating)):
        return np.float64(value)
    return str(value).encode("utf-8")


def _write_netcdf(handle: Any, result: DavarResult) -> None:
    from scipy.io import netcdf_file

    n_time, n_tau = np.shape(result.avar)
    if 8 * n_time * n_tau > _NETCDF_MAX_VARIABLE:
        raise _fail(
            f"a surface of {n_time} windows x {n_tau} taus ({8 * n_time * n_tau / 2**30:.1f} "
            "GiB per variable) is too large for a NetCDF (64-bit offset) file: write Parquet "
            "(pip install pyarrow), or compute fewer windows or taus"
        )
    nc = netcdf_file(handle, "w", version=2)
    nc.createDimension("time", n_time)
    nc.createDimension("tau", n_tau)
    for name, dims, data, attrs in _surface_variables(result):
        array = np.asarray(data)
        if np.issubdtype(array.dtype, np.integer):
            fits = array.size == 0 or (
                _INT32.min <= int(array.min()) and int(array.max()) <= _INT32.max
            )
            typecode = "i" if fits else "d"
        else:
            typecode = "d"
        var = nc.createVariable(name, typecode, dims)
        var[...] = array
        if typecode == "d" and name.startswith("avar"):
            var._FillValue = np.float64(np.nan)  # NaN cells are missing to CF readers
        for key, value in attrs.items():
            setattr(var, key, _nc_attribute(value))
    for key, value in _global_attributes(result).items():
        name = key if not hasattr(nc, key) else f"adavar_{key}"  # never shadow internals
        setattr(nc, name, _nc_attribute(value))
    nc.close()  # writes the file (and closes the handle)


def _json_scalar(value: Any) -> Any:
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, (np.integer, np.bool_)):
        return value.item()
    return value


def _write_parquet(handle: Any, result: DavarResult) -> None:

    pa, pq = _require_pyarrow()
    n_time, n_tau = np.shape(result.avar)
    by_cell = {
        "time": lambda a: np.repeat(a, n_tau),
        "window": lambda a: np.repeat(a, n_tau),
        "centre": lambda a: np.repeat(a, n_tau),
        "tau": lambda a: np.tile(a, n_time),
        "m": lambda a: np.tile(a, n_time),
        "alpha": lambda a: np.tile(a, n_time),
    }
    arrays, fields = [], []
    for name, _dims, data, attrs in _surface_variables(result):
        array = np.asarray(data)
        column = by_cell[name](array) if name in by_cell else array.reshape(-1)
        arrays.append(pa.array(column))
        meta = {key: str(value) for key, value in attrs.items()}
        fields.append(pa.field(name, arrays[-1].type, metadata=meta))
    attributes = {key: _json_scalar(v) for key, v in _global_attributes(result).items()}
    schema_meta = {
        "adavar": json.dumps(
            {**attributes, "shape": [int(n_time), int(n_tau)],
             "layout": "one row per (time, tau) cell, time-major"},
            allow_nan=False,
        ),
        # pandas.read_parquet restores DataFrame.attrs from this key
        "PANDAS_ATTRS": json.dumps(attributes, allow_nan=False),
    }  # fmt: skip
    table = pa.Table.from_arrays(arrays, schema=pa.schema(fields, metadata=schema_meta))
    pq.write_table(table, handle)


def write_surface(
    path: str | os.PathLike[str], result: DavarResult, *, fmt: str | None = None
) -> Path:
    """Write a DAVAR surface to a file that can be read without adavar.

    The file is written under a temporary name in the target folder and moved into place
    with :func:`os.replace`: a reader never sees a half-written file, and a failure leaves
    any earlier file at ``path`` untouched.

    Parameters
    ----------
    path : str or path-like
        The file to write (replaced if it exists).
    result : DavarResult
        From :func:`adavar.davar`.
    fmt : {"nc", "parquet"}, optional
        The format; by default from the suffix of ``path`` (``.parquet``/``.pq`` Parquet,
        anything else NetCDF).

        ``"nc"``: NetCDF classic with 64-bit offsets (``scipy.io.netcdf_file``,
        ``version=2``). Dimensions ``time`` (T windows) and ``tau`` (M); variables
        ``time`` and ``tau`` (s), ``avar`` (T x M, in the square of the data's unit; NaN
        where tau exceeds a third of the window, with ``_FillValue = NaN``), ``avar_low``
        and ``avar_high`` (when the result has bounds), ``window``, ``centre``, ``m``,
        ``alpha`` (int32, or double if a value does not fit), each with CF ``units`` and
        ``long_name``; global attributes ``Conventions``, ``title``, ``source`` and
        :meth:`DavarResult.metadata`. Text attributes are UTF-8. Read it with
        ``xarray.open_dataset(path)`` or ``scipy.io.netcdf_file(path)``.

        ``"parquet"`` (needs pyarrow): a long table, one row per (time, tau) cell in
        time-major order, columns ``time, tau, avar, [avar_low, avar_high,] window,
        centre, m, alpha`` with ``units``/``long_name`` field metadata, and the global
        attributes as JSON in the schema metadata (key ``adavar``, and ``PANDAS_ATTRS`` so
        that ``pandas.read_parquet(path).attrs`` holds them). Read it with
        ``pandas.read_parquet(path)``; ``frame.pivot(index="time", columns="tau",
        values="avar")`` gives the T x M surface back.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    AdavarInputError
        An unknown format, Parquet without pyarrow (``pip install pyarrow``), a surface
        too large for NetCDF classic (a variable over 4 GiB), or a folder that cannot be
        written.
    """
    target = Path(path)
    kind = _surface_format(target, fmt)
    with atomic_file(target) as handle:
        if kind == "nc":
            _write_netcdf(handle, result)
        else:
            _write_parquet(handle, result)
    return target


# --------------------------------------------------------------------------------------
# JSON and CSV of the results
# --------------------------------------------------------------------------------------


def jsonable(obj: Any) -> Any:
    """Plain Python objects for json: arrays to lists, NaN/inf to None."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        value = float(obj)
        return value if math.isfinite(value) else None
    return obj


def dumps(payload: dict[str, Any]) -> str:
    """Indented JSON of ``payload``, arrays as lists, NaN and inf as null."""
    return json.dumps(jsonable(payload), indent=2, allow_nan=False)


def deviation_json(result: DeviationResult) -> dict[str, Any]:
    """The ``deviation`` object of the JSON output."""
    return {
        "stat": result.stat,
        "confidence": result.confidence,
        "tau": result.tau,
        "dev": result.dev,
        "dev_low": result.dev_low,
        "dev_high": result.dev_high,
        "edf": result.edf,
        "n": result.n,
        "m": result.m,
        "alpha": result.alpha,
        "notes": list(result.notes),
    }


def conventional(fit: NoiseFit) -> Any:
    """``fit.to_units()`` if the declared unit is an accepted rate unit, else None."""
    if fit.units is None:
        return None
    try:
        return fit.to_units()
    except ValueError:
        return None


def fit_json(fit: NoiseFit) -> dict[str, Any]:
    """The ``fit`` object of the JSON output: every term in data and conventional units."""
    from adavar.core.terms import TERM_NAMES
    from adavar.core.units import term_unit

    out: dict[str, Any] = {}
    for name in TERM_NAMES:
        term = fit.term(name)
        out[name] = {
            "value": term.value,
            "uncertainty": term.uncertainty,
            "upper": term.upper,
            "unit": term_unit(name, fit.units),
        }
    conv = conventional(fit)
    out["conventional"] = (
        None
        if conv is None
        else {
            name: {"value": t.value, "uncertainty": t.uncertainty, "upper": t.upper,
                   "unit": t.unit}
            for name, t in conv.as_dict().items()
        }
    )  # fmt: skip
    out["reduced_chi2"] = fit.reduced_chi2
    out["chi2"] = fit.chi2
    out["dof"] = fit.dof
    out["n_points"] = fit.n_points
    out["terms"] = list(fit.terms)
    out["method"] = fit.method
    out["dropped"] = list(fit.dropped)
    out["selection"] = fit.selection
    out["bound_level"] = fit.bound_level
    out["adequate"] = bool(fit.adequate)
    out["p_value"] = fit.p_value
    out["gof_chi2"] = fit.gof_chi2
    out["better_model"] = fit.better_model
    support = fit.term_support
    out["term_support"] = None if support is None else {
        name: (None if not np.isfinite(v) else float(v))
        for name, v in zip(TERM_NAMES, support, strict=True)
    }  # fmt: skip
    out["uncertainty_rule"] = fit.uncertainty_rule
    mk = fit.markov
    out["markov"] = None if mk is None else {
        "sigma": mk.sigma, "sigma_uncertainty": mk.sigma_uncertainty, "tau_c_s": mk.tau_c,
        "tau_c_range_s": list(mk.tau_c_range), "unit": fit.units,
    }  # fmt: skip
    out["rolloff"] = fit.rolloff
    out["warnings"] = list(fit.warnings)
    out["excluded"] = [
        {"tau_s": float(t), "reason": r} for t, r in zip(fit.tau, fit.exclusions, strict=True) if r
    ]
    out["residuals"] = None if fit.residuals is None else list(fit.residuals)
    if fit.slopes is not None:
        out["slopes"] = {
            n: {"value": v, "uncertainty": fit.slopes.uncertainty[n],
                "anchor_tau_s": fit.slopes.anchor_tau[n], "unit": term_unit(n, fit.units)}
            for n, v in fit.slopes.values.items()
        }  # fmt: skip
    return out


def write_deviation_csv(path: Path, result: DeviationResult, comment: str | None = None) -> None:
    """``deviation.csv``: a header row, then one row per tau (every digit kept).

    ``comment`` (optional, adavar passes none) goes before the header as a ``# `` line.
    """
    columns = ["tau_s", "n", "m", "alpha", "edf", "dev", "dev_low", "dev_high"]
    rows = (
        (float(tau), int(n), int(m), int(alpha), float(edf), float(dev), float(low), float(high))
        for tau, n, m, alpha, edf, dev, low, high in zip(
            result.tau, result.n, result.m, result.alpha, result.edf, result.dev,
            result.dev_low, result.dev_high, strict=True,
        )
    )  # fmt: skip
    path.write_text(csv_text(columns, rows, comment=comment), encoding="utf-8")

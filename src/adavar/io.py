"""Reading records from plain text files, and writing output folders and surfaces atomically.

:func:`read_text` reads one column of a CSV / TSV / semicolon- or whitespace-separated text
file into a float64 array. :func:`atomic_directory` builds an output folder under a
temporary sibling name and moves it into place only when everything in it was written, so
an interrupted or failed run never leaves a half-written folder behind.
:func:`write_surface` writes a DAVAR surface as NetCDF (readable by xarray, netCDF4,
``scipy.io.netcdf_file``, ncdump, ...) or Parquet (pandas, pyarrow, polars, DuckDB, ...),
so that it can be read without adavar.

Every problem with the user's input raises :class:`adavar.errors.AdavarInputError` with a
one-line message that names the problem and the way out.
"""

from __future__ import annotations

import contextlib
import csv
import os
import secrets
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

import numpy as np

from adavar.errors import AdavarInputError

if TYPE_CHECKING:
    from adavar.results import DavarResult

__all__ = [
    "COMMENT_PREFIXES",
    "SURFACE_FORMATS",
    "atomic_directory",
    "check_output_directory",
    "check_surface_format",
    "read_text",
    "write_surface",
]

#: Lines starting with one of these (after leading blanks) are comments.
COMMENT_PREFIXES = ("#", "%")

_DELIMITER_NAMES = {",": "comma", ";": "semicolon", "\t": "tab", None: "whitespace"}
_SNIFF_LINES = 50


def _fail(message: str) -> AdavarInputError:
    return AdavarInputError(message)


def _read_lines(path: Path) -> list[tuple[int, str]]:
    """(1-based line number, stripped text) of every non-blank, non-comment line."""
    if not path.exists():
        raise _fail(f"{path}: no such file: check the path")
    if path.is_dir():
        raise _fail(f"{path} is a directory: give the path of a text file")
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


def _sniff_delimiter(lines: list[str]) -> str | None:
    """The field separator: tab, semicolon or comma, tried in that order (so decimal commas
    inside a semicolon file are not taken for separators), is chosen if it splits the first
    line into more than one field and most of the first lines into as many; otherwise None
    (runs of whitespace). Ragged rows are reported later, by line number."""
    sample = lines[:_SNIFF_LINES]
    for delim in ("\t", ";", ","):
        counts = [len(_split_csv(line, delim)) for line in sample]
        if counts[0] > 1 and 2 * counts.count(counts[0]) > len(counts):
            return delim
    return None


def _split_csv(line: str, delim: str) -> list[str]:
    if line.endswith(delim):  # one trailing separator is common in exported files
        line = line[: -len(delim)]
    row = next(csv.reader([line], delimiter=delim, skipinitialspace=True), [])
    return [cell.strip() for cell in row]


def _split(line: str, delim: str | None) -> list[str]:
    return line.split() if delim is None else _split_csv(line, delim)


def _split_all(texts: list[str], delim: str | None) -> list[list[str]]:
    """:func:`_split` over many lines at once (one csv reader for the whole file)."""
    if delim is None:
        return [text.split() for text in texts]
    trimmed = (text[: -len(delim)] if text.endswith(delim) else text for text in texts)
    reader = csv.reader(trimmed, delimiter=delim, skipinitialspace=True)
    return [[cell.strip() for cell in row] for row in reader]


def _parse_column(
    numbers: list[int], rows: list[list[str]], index: int, label: str, path: Path
) -> np.ndarray:
    """The column as float64 (slow path); the first bad cell named by its line number."""
    cells = [row[index] for row in rows]
    try:
        values = np.array(cells, dtype=np.float64)
    except ValueError:
        values = None
    if values is None:  # find the first cell that is not a number, for the message
        for number, cell in zip(numbers, cells, strict=True):
            if _is_number(cell):
                continue
            if not cell:
                raise _fail(
                    f"{path}: row {number}, column {label!r} is empty: fill or remove that row"
                )
            hint = (
                ": decimal commas are not read, use points"
                if "," in cell and _is_number(cell.replace(",", "."))
                else ": fix or remove that row"
            )
            raise _fail(f"{path}: row {number}, column {label!r} is not a number ({cell!r}){hint}")
        values = np.array([float(cell) for cell in cells], dtype=np.float64)
    return values


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _describe_columns(names: list[str] | None, n_cols: int) -> str:
    if names is None:
        return f"{n_cols} unnamed columns, indices 0..{n_cols - 1}"
    return ", ".join(f"{name!r} ({i})" for i, name in enumerate(names))


def _select_column(
    column: str | int | None,
    names: list[str] | None,
    n_cols: int,
    get_rows: Callable[[], list[list[str]]],
    path: Path,
) -> int:
    """0-based index of the requested column."""
    if column is None:
        if n_cols == 1:
            return 0
        rows = get_rows()
        numeric = [j for j in range(n_cols) if all(_is_number(cells[j]) for cells in rows)]
        if len(numeric) == 1:
            return numeric[0]
        raise _fail(
            f"{path} has {n_cols} columns ({_describe_columns(names, n_cols)}): "
            "choose one with --column NAME or a 0-based index"
        )
    if isinstance(column, bool):
        raise _fail(f"column must be a name or a 0-based index, got {column!r}")
    if isinstance(column, str):
        key = column.strip()
        if names is not None:
            if key in names:
                return names.index(key)
            folded = [j for j, name in enumerate(names) if name.casefold() == key.casefold()]
            if len(folded) == 1:
                return folded[0]
        if key.lstrip("+").isdigit():
            column = int(key)
        elif names is None:
            raise _fail(
                f"{path} has no header row, so its columns have no names: give --column as "
                f"a 0-based index (0..{n_cols - 1})"
            )
        else:
            raise _fail(
                f"unknown column {column!r} in {path}; available columns: "
                f"{_describe_columns(names, n_cols)}"
            )
    try:
        index = int(column)
    except (TypeError, ValueError):
        raise _fail(f"column must be a name or a 0-based index, got {column!r}") from None
    if index != column or not 0 <= index < n_cols:
        raise _fail(
            f"column index {column!r} is out of range for {path}; available columns: "
            f"{_describe_columns(names, n_cols)}"
        )
    return index


def read_text(
    path: str | os.PathLike[str], *, column: str | int | None = None
) -> tuple[np.ndarray, dict[str, Any]]:
    """Read one numeric column of a plain text table.

    Parameters
    ----------
    path : str or path-like
        A CSV, TSV, semicolon- or whitespace-separated text file (UTF-8). Blank lines and
        lines starting with ``#`` or ``%`` are skipped. The first remaining line is a header
        row if any of its cells is not a number. The delimiter is sniffed among tab,
        semicolon, comma and runs of whitespace (a delimiter must split every line into the
        same number of fields; tab and semicolon are tried before comma).
    column : str or int, optional
        A header name (exact, or case-insensitive if that is unique), a 0-based index, or a
        string of digits (an index, unless a header name is spelled that way). Needed when
        the file has more than one numeric column.

    Returns
    -------
    samples : ndarray of float64
        The column, in file order.
    metadata : dict
        ``path`` (str), ``column`` (the header name, or the index as a string),
        ``column_index`` (int), ``n_rows`` (int), ``columns`` (all names, or None without a
        header), ``delimiter`` (``"comma"``, ``"semicolon"``, ``"tab"`` or
        ``"whitespace"``), ``header`` (bool).

    Raises
    ------
    AdavarInputError
        Missing or unreadable file, no data rows, ragged rows, an unknown or ambiguous
        column, a cell that is empty or not a number, or a NaN/infinite sample. Rows are
        named by their line number in the file (1-based, counting comments and header), so
        an editor's line number finds them.
    """
    path = Path(path)
    lines = _read_lines(path)
    if not lines:
        raise _fail(f"{path} is empty (no data rows): give a file with one sample per row")

    delim = _sniff_delimiter([text for _, text in lines])
    first = _split(lines[0][1], delim)
    header = not all(_is_number(cell) for cell in first)
    names: list[str] | None = None
    if header:
        names = [cell if cell else f"column {j}" for j, cell in enumerate(first)]
        data_lines = lines[1:]
    else:
        data_lines = lines
    if not data_lines:
        raise _fail(f"{path} has a header row but no data rows: give a file with samples")
    n_cols = len(first)

    numbers = [number for number, _ in data_lines]
    texts = [text for _, text in data_lines]
    if delim is not None and any(text.endswith(delim) for text in texts):
        texts = [text[: -len(delim)] if text.endswith(delim) else text for text in texts]
    quoted = delim is not None and any('"' in text for text in texts)
    split_rows: list[list[str]] | None = None

    def get_rows() -> list[list[str]]:
        nonlocal split_rows
        if split_rows is None:
            split_rows = _split_all(texts, delim)
        return split_rows

    if quoted:
        counts = [len(cells) for cells in get_rows()]
    elif delim is None:
        counts = [len(text.split()) for text in texts]
    else:
        counts = [text.count(delim) + 1 for text in texts]
    if counts.count(n_cols) != len(counts):
        k = next(k for k, c in enumerate(counts) if c != n_cols)
        raise _fail(
            f"{path}: row {numbers[k]} has {counts[k]} fields, expected {n_cols} "
            f"({_DELIMITER_NAMES[delim]}-separated): fix or remove that row"
        )

    index = _select_column(column, names, n_cols, get_rows, path)
    label = names[index] if names is not None else str(index)
    values = None
    if not quoted:  # numpy's C parser; the slow path below finds the bad cell if it fails
        try:
            values = np.loadtxt(
                texts, delimiter=delim, usecols=index, dtype=np.float64, comments=None,
                ndmin=1,
            )  # fmt: skip
        except ValueError:
            values = None
    if values is None:
        values = _parse_column(numbers, get_rows(), index, label, path)
    finite = np.isfinite(values)
    if not finite.all():
        k = int(np.argmin(finite))
        raise _fail(
            f"{path}: row {numbers[k]} is {float(values[k])!r} in column {label!r}: remove "
            "or interpolate it"
        )

    metadata = {
        "path": str(path),
        "column": label,
        "column_index": index,
        "n_rows": int(values.size),
        "columns": names,
        "delimiter": _DELIMITER_NAMES[delim],
        "header": header,
    }
    return values, metadata


# --------------------------------------------------------------------------------------
# Output folders
# --------------------------------------------------------------------------------------


def check_output_directory(path: str | os.PathLike[str], *, replace: bool = False) -> Path:
    """Check that an output folder can be created at ``path``, before any work is done.

    Parameters
    ----------
    path : str or path-like
        The folder to create.
    replace : bool
        Whether an existing folder may be replaced.

    Returns
    -------
    Path
        The absolute path.

    Raises
    ------
    AdavarInputError
        If ``path`` exists and ``replace`` is False, is an existing file, or its parent
        folder does not exist.
    """
    target = Path(path).expanduser().absolute()
    if target.exists() or target.is_symlink():
        if not target.is_dir() or target.is_symlink():
            raise _fail(f"{path} exists and is not a folder: choose another output folder")
        if not replace:
            raise _fail(
                f"output folder {path} exists already: choose another one, or pass --force "
                "to replace it"
            )
    if not target.parent.is_dir():
        raise _fail(
            f"the parent folder of {path} does not exist: create it first or choose "
            "another output folder"
        )
    return target


def _make_sibling(target: Path, tag: str) -> Path:
    """A new empty hidden folder next to ``target`` (os.mkdir honours the umask, where
    tempfile.mkdtemp would leave the final folder at mode 0700)."""
    while True:
        candidate = target.parent / f".{target.name}.{tag}-{secrets.token_hex(6)}"
        try:
            candidate.mkdir()
        except FileExistsError:
            continue
        except OSError as exc:
            reason = exc.strerror or exc
            raise _fail(f"cannot create a folder in {target.parent}: {reason}") from None
        return candidate


@contextlib.contextmanager
def atomic_directory(path: str | os.PathLike[str], *, replace: bool = False) -> Iterator[Path]:
    """Build a folder under a temporary sibling name and move it to ``path`` at the end.

    Use as ``with atomic_directory(out) as tmp: write files into tmp``. If the block raises,
    the temporary folder is removed and ``path`` is left as it was. If it completes, the
    temporary folder is renamed to ``path`` (when ``replace`` is True, an existing folder at
    ``path`` is first renamed aside, then deleted once the new one is in place).

    Parameters
    ----------
    path : str or path-like
        The final folder.
    replace : bool
        Whether an existing folder at ``path`` may be replaced.

    Yields
    ------
    Path
        The temporary folder to write into (same parent as ``path``).

    Raises
    ------
    AdavarInputError
        As :func:`check_output_directory` (checked again when the block is entered).
    """
    target = check_output_directory(path, replace=replace)
    tmp = _make_sibling(target, "tmp")
    try:
        yield tmp
        if target.exists():
            if not replace:
                raise _fail(
                    f"output folder {path} appeared while it was being written: choose "
                    "another one, or pass --force to replace it"
                )
            old = _make_sibling(target, "old")
            os.replace(target, old / target.name)
            try:
                os.replace(tmp, target)
            except BaseException:
                os.replace(old / target.name, target)  # put the old folder back
                raise
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, target)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


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
    import json

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


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike[str]) -> Iterator[BinaryIO]:
    """Write ``path`` all or nothing: a binary handle on a temporary sibling, renamed at the end.

    The temporary file sits in the destination folder (so ``os.replace`` is atomic), is
    created with ``open(..., "x")`` (the umask's permissions, not mkstemp's private 0600), is
    synced before the rename, and is removed if anything fails, so an interrupted or
    failed write leaves neither a half-written file nor a temporary behind.

    Raises
    ------
    AdavarInputError
        The folder does not exist, ``path`` is a folder, or the file cannot be written.
    """
    target = Path(path)
    if not target.parent.is_dir():
        raise _fail(
            f"the folder of {target} does not exist: create it first or choose another path"
        )
    if target.is_dir():
        raise _fail(f"{target} is a folder: give the path of the file to write")
    tmp = target.parent / f".{target.name}.{secrets.token_hex(6)}.tmp"
    try:
        with open(tmp, "xb") as handle:
            yield handle
        # data on disk before the name points at it (the writer may have closed the handle)
        with contextlib.suppress(OSError):
            fd = os.open(tmp, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        os.replace(tmp, target)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise _fail(f"cannot write {target}: {exc.strerror or exc}") from None
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


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

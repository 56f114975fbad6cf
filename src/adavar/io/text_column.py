"""Reading one column of a plain text file (:func:`read_text`).

The writers that ``adavar.io`` held before 0.3 are :mod:`adavar.io.writers`'s; they are
still importable from here (and from ``adavar.io``), unchanged. For reading a
record in any format, with time stamps, gaps and units, use :func:`adavar.readers.read_record`.

Every problem with the user's input raises :class:`adavar.core.errors.AdavarInputError` with a
one-line message that names the problem and the way out.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adavar.core.atomic import atomic_directory, atomic_file, check_output_directory
from adavar.core.errors import AdavarInputError
from adavar.io.writers import SURFACE_FORMATS, check_surface_format, write_surface
from adavar.readers.textscan import COMMENT_PREFIXES

if TYPE_CHECKING:
    pass

__all__ = [
    "COMMENT_PREFIXES",
    "SURFACE_FORMATS",
    "atomic_directory",
    "atomic_file",
    "check_output_directory",
    "check_surface_format",
    "read_text",
    "write_surface",
]


def _fail(message: str) -> AdavarInputError:
    return AdavarInputError(message)


def _describe_columns(names: list[str] | None, n_cols: int) -> str:
    if names is None:
        return f"{n_cols} unnamed columns, indices 0..{n_cols - 1}"
    return ", ".join(f"{name!r} ({i})" for i, name in enumerate(names))


def _select_column(
    column: str | int | None,
    names: list[str] | None,
    n_cols: int,
    numeric: list[int],
    path: Path,
) -> int:
    """0-based index of the requested column (``numeric``: the numeric columns' indices)."""
    if column is None:
        if n_cols == 1:
            return 0
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
        A CSV, TSV, semicolon- or whitespace-separated text file (UTF-8), read as
        :func:`adavar.readers.read_record` reads it (streamed, so its size is not limited
        by memory): blank lines and lines starting with ``#`` or ``%`` are skipped; the
        delimiter is sniffed among tab, semicolon, comma and runs of whitespace (tab and
        semicolon are tried before comma), and decimal commas are read in a file separated
        by semicolons, tabs or spaces whose numbers have no decimal point; the header row is
        the line just before the first row of numbers (a single-column file may have
        several header lines).
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
        ``"whitespace"``), ``decimal`` (``"point"`` or ``"comma"``), ``header`` (bool).

    Raises
    ------
    AdavarInputError
        Missing, unreadable or binary file, no data rows, ragged rows, an unknown or
        ambiguous column, a cell that is empty or not a number, or a NaN/infinite sample. Rows are
        named by their line number in the file (1-based, counting comments and header), so
        an editor's line number finds them.
    """
    from adavar.readers.text import cell_hint, text_table
    from adavar.readers.textscan import read_line, split

    path = Path(path)
    if not path.exists():
        raise _fail(f"{path}: no such file: check the path")
    if path.is_dir():
        raise _fail(f"{path} is a directory: give the path of a text file")
    tab, info = text_table(path, str(path), preamble=False)
    header = bool(info["header"])
    names = list(tab.names) if header else None
    n_cols = len(tab.names)
    numeric = [j for j, name in enumerate(tab.names) if tab.kinds[name] == "num"]
    index = _select_column(column, names, n_cols, numeric, path)
    name = tab.names[index]
    label = names[index] if names is not None else str(index)
    rows = tab.rows if tab.rows is not None else np.arange(tab.n)
    if tab.kinds[name] != "num":
        row, cell = tab.bad.get(name, (int(rows[0]) if tab.n else 0, ""))
        if not cell:
            raise _fail(f"{path}: row {row}, column {label!r} is empty: fill or remove that row")
        hint = cell_hint(cell, info["decimal"] == "comma", info["delimiter"] == "comma")
        raise _fail(
            f"{path}: row {row}, column {label!r} is not a number ({cell!r})"
            + (f": {hint}" if hint else ": fix or remove that row")
        )
    values = np.asarray(tab.get(name), dtype=np.float64)
    finite = np.isfinite(values)
    if not finite.all():
        k = int(np.argmin(finite))
        delim = {"comma": ",", "semicolon": ";", "tab": "\t"}.get(info["delimiter"])
        cells = split(read_line(path, int(rows[k])), delim)
        if index < len(cells) and not cells[index]:
            raise _fail(
                f"{path}: row {rows[k]}, column {label!r} is empty: fill or remove that row"
            )
        raise _fail(
            f"{path}: row {rows[k]} is {float(values[k])!r} in column {label!r}: remove "
            "or interpolate it"
        )

    metadata = {
        "path": str(path),
        "column": label,
        "column_index": index,
        "n_rows": int(values.size),
        "columns": names,
        "delimiter": info["delimiter"],
        "decimal": info["decimal"],
        "header": header,
    }
    return values, metadata

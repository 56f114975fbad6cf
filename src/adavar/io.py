"""Reading one column of a plain text file (:func:`read_text`).

The writers that lived here moved to :mod:`adavar.writers` (this module's name shadows the
standard library's ``io``); they are still importable from here, unchanged. For reading a
record in any format, with time stamps, gaps and units, use :func:`adavar.readers.read_record`.

Every problem with the user's input raises :class:`adavar.errors.AdavarInputError` with a
one-line message that names the problem and the way out.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adavar.errors import AdavarInputError
from adavar.writers import (
    SURFACE_FORMATS,
    atomic_directory,
    atomic_file,
    check_output_directory,
    check_surface_format,
    write_surface,
)

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

"""The CSV tables adavar writes: one place for how a cell, a row and a table are written.

Every CSV adavar writes is made by :func:`csv_text` or :func:`csv_pieces` (the same text in
pieces, for a table too large to hold as one string): a header row, then one line per row,
numbers in their shortest exact form and text made safe for spreadsheets
(:func:`spreadsheet_safe`). ``pandas.read_csv(path)`` and spreadsheets read them as they
are. :mod:`adavar.io.writers` re-exports these names.
"""

from __future__ import annotations

import csv
import io as _stdio
import numbers
import os
import re
from collections.abc import Iterable, Iterator, Sequence
from typing import Any

import numpy as np

__all__ = [
    "CSV_PIECE_ROWS",
    "block_rows",
    "csv_cell",
    "csv_pieces",
    "csv_text",
    "spreadsheet_safe",
    "write_pieces",
]


#: First characters that make a spreadsheet run a text cell as a formula (CSV injection).
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def spreadsheet_safe(text: str) -> str:
    """A text cell a spreadsheet shows as text: ``'`` before a leading ``=``, ``+``, ``-``,
    ``@``, tab or carriage return, unless the text is a number (``-1.5``, ``-inf``).

    Parameters
    ----------
    text : str

    Returns
    -------
    str
    """
    if not text.startswith(_FORMULA_START):
        return text
    try:
        float(text)
    except ValueError:
        return "'" + text
    return text


def csv_cell(value: Any) -> str:
    """The text of one CSV cell: numbers in their shortest exact form (``repr``; NaN as
    ``nan``), None as an empty cell, booleans as ``true``/``false``, text through
    :func:`spreadsheet_safe`.

    Raises
    ------
    TypeError
        A value that is not a number, text, a path or None.
    """
    kind = type(value)
    if kind is float:  # the common cells first: the checks below cost microseconds each
        return repr(value)
    if kind is int:
        return str(value)
    if value is None:
        return ""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        return repr(float(value))  # shortest round-trip form; nan, inf, -inf
    if isinstance(value, (str, os.PathLike)):
        return spreadsheet_safe(os.fspath(value))
    if isinstance(value, np.ndarray) and value.ndim == 0:
        return csv_cell(value.item())
    raise TypeError(f"a CSV cell must be a number, text or None, got {type(value).__name__}")


def csv_text(
    columns: Sequence[str], rows: Iterable[Sequence[Any]], *, comment: str | None = None
) -> str:
    """A plain CSV table: the header row first, then one line per row (:func:`csv_cell`).

    Every CSV adavar writes is made here: ``pandas.read_csv(path)`` and spreadsheets read
    it as it is (its metadata is in the ``result.json`` next to it).

    Parameters
    ----------
    columns : sequence of str
        The column names (made :func:`spreadsheet_safe` too).
    rows : iterable of sequence
        The cells of every row, in column order.
    comment : str, optional
        Only for callers that want it: free text written before the header as ``# `` lines
        (a reader then needs ``comment="#"``). adavar's own files have none.

    Returns
    -------
    str
    """
    return "".join(csv_pieces(columns, rows, comment=comment))


def block_rows(columns: Sequence[np.ndarray], block: int = 1 << 16) -> Iterator[tuple]:
    """The rows of columns of one length as Python numbers, ``block`` rows converted at a
    time (a list of every row's numbers holds tens of times the arrays).

    :func:`csv_pieces` writes the rows of numeric columns a column at a time (the same
    text, 1.3-1.5x faster).
    """
    return _ColumnRows([np.asarray(c) for c in columns], block)


class _ColumnRows:
    """:func:`block_rows`: an iterator of row tuples that keeps its columns."""

    def __init__(self, columns: list[np.ndarray], block: int) -> None:
        self.columns, self.block = columns, block
        self._rows: Iterator[tuple] | None = None

    def _generate(self) -> Iterator[tuple]:
        columns = self.columns
        size = int(np.size(columns[0])) if len(columns) else 0
        for start in range(0, size, self.block):
            yield from zip(*(c[start : start + self.block].tolist() for c in columns),
                           strict=True)  # fmt: skip

    def __iter__(self) -> Iterator[tuple]:
        return self

    def __next__(self) -> tuple:
        if self._rows is None:
            self._rows = self._generate()
        return next(self._rows)

    def numeric(self) -> bool:
        """Whether the rows are numbers only (1-D columns of one length), none read yet."""
        cols = self.columns
        return (
            self._rows is None
            and len(cols) > 0
            and all(c.ndim == 1 and c.dtype.kind in "biuf" for c in cols)
            and len({c.size for c in cols}) == 1
        )


def write_pieces(path: str | os.PathLike[str], pieces: Iterable[str]) -> None:
    """Write text made in pieces (:func:`csv_pieces`) to ``path`` (UTF-8) as they come."""
    with open(path, "w", encoding="utf-8") as file:
        file.writelines(pieces)


#: characters that make the csv module quote a cell (besides the delimiter)
_QUOTED = re.compile('["\\r\\n]')

#: rows of a CSV made into one piece of text by :func:`csv_pieces`
CSV_PIECE_ROWS = 1 << 14


def csv_pieces(
    columns: Sequence[str], rows: Iterable[Sequence[Any]], *, comment: str | None = None
) -> Iterator[str]:
    """:func:`csv_text` as consecutive pieces of text (:data:`CSV_PIECE_ROWS` rows each),
    for a table too large to hold as one string (``file.writelines(csv_pieces(...))``).

    ``columns``, ``rows`` (read as the pieces are) and ``comment`` are :func:`csv_text`'s;
    ``"".join`` of the pieces is ``csv_text(columns, rows, comment=comment)``.
    """
    buffer = _stdio.StringIO()
    if comment:
        for line in str(comment).splitlines() or [""]:
            buffer.write(f"# {line}".rstrip() + "\n")
    # csv quotes a cell holding a character of its line terminator: "\r\n" makes it quote a
    # carriage return too (which "\n" would not, and a reader takes for a line break);
    # each line then ends with "\n"
    line = _stdio.StringIO()
    writer = csv.writer(line, lineterminator="\r\n")

    def put(cells: list[str]) -> None:
        text = ",".join(cells)
        # nothing to quote (numbers never are): the csv module's line, without its cost
        if len(cells) > 1 and text.count(",") == len(cells) - 1 and not _QUOTED.search(text):
            buffer.write(text + "\n")
            return
        line.seek(0)
        line.truncate()
        writer.writerow(cells)
        buffer.write(line.getvalue()[:-2] + "\n")

    put([spreadsheet_safe(str(c)) for c in columns])
    if isinstance(rows, _ColumnRows) and rows.numeric() and len(rows.columns) > 1:
        # numbers are never quoted: each line is its cells joined, made a column at a time
        # (the same pieces as below: every CSV_PIECE_ROWS rows, then the rest)
        head, arrays = buffer.getvalue(), rows.columns
        size = arrays[0].size
        for start in range(0, size - size % CSV_PIECE_ROWS + 1, CSV_PIECE_ROWS):
            # csv_cell of each number (one rule for a cell's text), a column at a time
            cells = [
                list(map(csv_cell, a[start : start + CSV_PIECE_ROWS].tolist())) for a in arrays
            ]
            lines = "\n".join(map(",".join, zip(*cells, strict=True)))
            yield head + lines + ("\n" if lines else "")
            head = ""
        return
    count = 0
    for row in rows:
        put([csv_cell(c) for c in row])
        count += 1
        if count == CSV_PIECE_ROWS:
            yield buffer.getvalue()
            buffer.seek(0)
            buffer.truncate()
            count = 0
    yield buffer.getvalue()

"""Text files: CSV, TSV, semicolon- or whitespace-separated columns.

A UTF-8 file, blank lines and comment lines (:data:`COMMENT_PREFIXES`) skipped; the
delimiter is sniffed among tab, semicolon, comma and whitespace from the last lines, and
with it the decimal separator (decimal commas are read in a file separated by semicolons,
tabs or spaces whose numbers have no decimal point); the header is the line just before the
first data row (a row of numbers or ISO 8601 times); empty, ``NA``, ``nan``... cells are
missing samples. The data rows are streamed block by block (:mod:`adavar.readers.textscan`):
the memory used is the columns', not the text's. :func:`text_table` reads the columns (also
for Stable32 files, :mod:`adavar.readers.stable32`), :func:`read_text` the record.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from adavar.readers.errors import fail
from adavar.readers.record import RawRecord
from adavar.readers.table import MISSING, Table, channels_from_table, is_iso
from adavar.readers.textscan import (
    COMMENT_PREFIXES,
    HEAD,
    Layout,
    is_number,
    open_text,
    read_columns,
    split,
)

__all__ = ["COMMENT_PREFIXES", "cell_hint", "read_text", "text_table"]

_DELIM_NAMES = {",": "comma", ";": "semicolon", "\t": "tab", None: "whitespace"}
_SEARCHED = 1000  # lines searched for the first data row
#: a number written with a decimal comma: 1,5  -0,25  ,5  1,5e-3
_DECIMAL_COMMA = re.compile(r"^[+-]?\d*,\d+(?:[eE][+-]?\d+)?$")
#: a number with digit grouping: 1.234,5  1,234.5  1 234,5
_GROUPED = re.compile(r"^[+-]?\d{1,3}(?:[., \u00a0\u202f]\d{3})+(?:[.,]\d+)?$")


def _is_value(cell: str, decimal: str) -> bool:
    """A number (with the file's decimal separator) or an ISO 8601 time."""
    if decimal == "," and _DECIMAL_COMMA.match(cell):
        return True
    return is_number(cell) or is_iso(cell)


def _is_data(cells: list[str], decimal: str) -> bool:
    """A data row: at least half of its non-empty cells are numbers (NaN and Inf count) or
    ISO 8601 times, and it has at least one (header words and preamble sentences do not)."""
    filled = [cell for cell in cells if cell]
    values = sum(1 for cell in filled if _is_value(cell, decimal))
    return values > 0 and 2 * values >= len(filled)


_WHOLE = re.compile(r"^[+-]?\d+$")


def _split_decimal_commas(sample: list[str]) -> bool:
    """Whether a comma-separated sample is whole numbers only, the first field of no row
    with leading zeros and some later field with them (``0,012345``): numbers with decimal
    commas split in two (zero-padded integers pad every field)."""
    rows = [[c.strip() for c in line.split(",")] for line in sample if line.strip()]
    if not rows or not all(_WHOLE.match(c) for row in rows for c in row):
        return False

    def padded(cell: str) -> bool:
        digits = cell.lstrip("+-")
        return len(digits) > 1 and digits.startswith("0")

    # zero-padded integers (0817,0817) pad every field; an integer part is not padded
    if any(padded(row[0]) for row in rows):
        return False
    return any(padded(c) for row in rows for c in row[1:])


def _names_a_numeric_column(
    lines: list[tuple[int, int, str]], delim: str | None, decimal: str, width: int, src: str
) -> bool:
    """Whether the file's first line, taken for data (most of its cells are numbers), is
    the header: a cell that is no value over a column whose next rows all hold values."""
    if len(lines) < 3:
        return False
    first = split(lines[0][2], delim, src, lines[0][0])
    rows = [split(t, delim, src, n) for n, _, t in lines[1:11]]
    rows = [r for r in rows if len(r) == width]
    if len(first) != width or len(rows) < 2:
        return False
    return any(
        cell and cell.casefold() not in MISSING and not _is_value(cell, decimal)
        and all(_is_value(r[j], decimal) for r in rows)
        for j, cell in enumerate(first)
    )  # fmt: skip


def _decimal(sample: list[str], delim: str | None) -> str:
    """``","`` when the sample's numbers are written with decimal commas (and none with a
    decimal point), else ``"."``. A comma-separated file has decimal points."""
    if delim == ",":
        return "."
    comma = point = False
    for line in sample:
        for cell in split(line, delim):
            if _DECIMAL_COMMA.match(cell):
                comma = True
            elif "." in cell and (is_number(cell) or _GROUPED.match(cell)):
                point = True
    return "," if comma and not point else "."


def _spaced_decimal_commas(sample: list[str]) -> bool:
    """Whether most sample lines are runs of whitespace-separated numbers with decimal
    commas (``1,5 2,25``), which a comma split would cut into nonsense."""

    def numbers(line: str) -> bool:
        cells = line.split()
        return (
            len(cells) > 1
            and all(_DECIMAL_COMMA.match(c) or c.lstrip("+-").isdigit() for c in cells)
            and any(_DECIMAL_COMMA.match(c) for c in cells)
        )

    return 2 * sum(numbers(line) for line in sample) > len(sample)


def _sniff(sample: list[str]) -> tuple[str | None, str]:
    """(delimiter, decimal separator). Tab, semicolon or comma (in that order) if it splits
    most sample lines into the same number (> 1) of fields; otherwise None (runs of
    whitespace)."""
    for delim in ("\t", ";", ","):
        counts = [len(split(line, delim)) for line in sample]
        best = max(set(counts), key=counts.count)
        if best > 1 and 2 * counts.count(best) > len(counts):
            if delim == "," and _spaced_decimal_commas(sample):
                return None, ","
            return delim, _decimal(sample, delim)
    return None, _decimal(sample, None)


def cell_hint(cell: str, decimal_comma: bool, comma_separated: bool) -> str:
    """Why a cell that looks like a number is not read as one ("" if it does not)."""
    if _GROUPED.match(cell) and "," in cell and "." in cell:
        return "digit grouping is not read: export the numbers without thousands separators"
    if decimal_comma and "." in cell and is_number(cell):
        return (
            "a decimal point in a file whose numbers have decimal commas is ambiguous (1.500 "
            "may be 1500): write every number with one decimal separator"
        )
    if not decimal_comma and _DECIMAL_COMMA.match(cell):
        if comma_separated:
            return "decimal commas are not read in a comma-separated file"
        return (
            "decimal commas are read only in a file separated by ';', tabs or spaces whose "
            "numbers have no decimal points"
        )
    return ""


def _header_mismatch(src: str, row: int, n_head: int, n_cols: int, delim: str | None) -> Exception:
    """The error for a header whose names do not match the data rows' fields (dropping it
    would leave the columns unnamed, and the time column unfound, without a word)."""
    why = ""
    if delim == "," and n_head < n_cols:
        why = (
            "; decimal commas in a comma-separated file split every number in two: write the "
            "numbers with decimal points, or separate the columns with ';' or tabs"
        )
    return fail(
        f"{src}: the header (row {row}) has {n_head} field(s) but the data rows have {n_cols} "
        f"({_DELIM_NAMES[delim]}-separated){why}; otherwise give the header one name per "
        "column, or comment it out with #"
    )


def text_table(path: Path, src: str, *, preamble: bool) -> tuple[Table, dict[str, Any]]:
    """The columns of a text file, and what was found (delimiter, header, lines skipped)."""
    scan = open_text(path, src, n_head=_SEARCHED + 1)
    lines = scan.head
    if not lines:
        if scan.complete:
            raise fail(f"{src} is empty (no data rows): give a file with one sample per row")
        raise fail(
            f"{src} has no data rows in its first {HEAD >> 20} MiB (only comments or blank "
            "lines): give a file with one sample per row"
        )
    delim, decimal = _sniff(scan.tail)
    # header / preamble: the non-data lines before the first data line
    counts = [len(split(text, delim, src)) for text in scan.tail]
    width = max(set(counts), key=counts.count)  # fields in a data row
    first_data = None
    for k, (number, _, text) in enumerate(lines[:_SEARCHED]):
        cells = split(text, delim, src, number)
        if len(cells) == width and _is_data(cells, decimal):
            first_data = k
            break
    if first_data is None:
        if len(lines) == 1 and scan.complete:
            raise fail(f"{src} has a header row but no data rows: give a file with samples")
        within = f" in its first {_SEARCHED} lines" if len(lines) > _SEARCHED else ""
        cells = [c.strip().strip('"') for _, _, t in lines[1:50] for c in split(t, delim, src)]
        why = ""
        if delim == "," and cells and any(_DECIMAL_COMMA.match(c) for c in cells):
            why = (
                " (its quoted numbers have decimal commas, which a comma-separated file does "
                "not read: write decimal points, or separate the columns with ';' or tabs)"
            )
        raise fail(
            f"{src} has no numeric data rows{within}{why}: give a file with one sample per row"
        )
    if first_data == 0 and _names_a_numeric_column(lines, delim, decimal, width, src):
        first_data = 1  # 'time,100,200': names, two of them numbers, over numeric columns
    number, offset, text = lines[first_data]
    n_cols = len(split(text, delim, src, number))
    if first_data > 1 and not preamble and n_cols > 1:
        raise fail(
            f"{src}: row {lines[1][0]} is neither a number row nor the header: remove the "
            "extra header lines or comment them out with #"
        )
    names: list[str] | None = None
    if first_data >= 1:
        before = lines[first_data - 1]
        head = split(before[2], delim, src, before[0])
        if len(head) == n_cols and (n_cols > 1 or first_data == 1):
            names = [cell if cell else f"column {j}" for j, cell in enumerate(head)]
        elif n_cols > 1 and not preamble:
            raise _header_mismatch(src, before[0], len(head), n_cols, delim)
    has_header = names is not None
    if delim == "," and not has_header and _split_decimal_commas(scan.tail):
        raise fail(
            f"{src}: its comma-separated fields are whole numbers, the first without leading "
            f"zeros and others with ({scan.tail[-1].strip()!r}): numbers with decimal commas "
            "split in two: write them with decimal points, or separate the columns with ';' "
            "or tabs"
        )
    if names is None:
        names = [str(j) for j in range(n_cols)]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise fail(f"{src}: the header names column {dupes[0]!r} twice: rename one of them")
    sample = [*scan.tail, *(t for _, _, t in lines[first_data : first_data + 50])]
    spaced = delim is not None and any(f"{delim} " in t or '"' in t for t in sample)
    layout = Layout(delim, decimal, n_cols, src, _DELIM_NAMES[delim], spaced)
    columns, numbers = read_columns(path, offset, number, layout, scan.size - offset)
    kinds: dict[str, str] = {}
    why_not: dict[str, str] = {}
    bad: dict[str, tuple[int, str]] = {}
    values: dict[str, Any] = {}
    for name, column in zip(names, columns, strict=True):
        kinds[name] = str(column.kind)
        if column.kind == "num" and column.values is not None:
            values[name] = column.values.result()
        elif column.kind == "iso":
            values[name] = column.cells
        elif column.bad is not None:
            row, cell = column.bad
            if has_header and cell.strip() == name:
                raise fail(
                    f"{src}: row {row} repeats the header ({cell.strip()!r} under column "
                    f"{name!r}; files joined?): remove the repeated header rows"
                )
            hint = cell_hint(cell, decimal == ",", delim == ",")
            why_not[name] = f"row {row}: {cell!r}" + (f"; {hint}" if hint else "")
            bad[name] = column.bad
        else:
            why_not[name] = "no values, only empty or missing cells"

    def get(name: str) -> Any:
        return values[name]

    tab = Table(names, kinds, get, len(numbers), numbers, why_not, bad=bad)
    meta = {
        "delimiter": _DELIM_NAMES[delim],
        "decimal": "comma" if decimal == "," else "point",
        "header": has_header,
        "skipped_lines_before_data": first_data,
    }
    return tab, meta


def read_text(path: Path, src: str, opts: dict[str, Any]) -> RawRecord:
    """The record of a CSV / TSV / whitespace-separated text file."""
    tab, meta = text_table(path, src, preamble=False)
    channels, rel, t0, info = channels_from_table(
        tab, columns=opts["columns"], time_column=opts["time_column"],
        time_format=opts["time_format"], src=src,
    )  # fmt: skip
    meta.update(info)
    return RawRecord(channels, rel, t0, tab.rows, "row", meta)

"""Text files: CSV, TSV, semicolon- or whitespace-separated columns.

A UTF-8 file, blank lines and comment lines (:data:`COMMENT_PREFIXES`) skipped; the
delimiter is sniffed among tab, semicolon, comma and whitespace from the last lines; the
header is the line just before the first data row (a row of numbers or ISO 8601 times);
empty, ``NA``, ``nan``... cells are missing samples. :func:`text_table` reads the columns
(also for Stable32 files, :mod:`adavar.readers.stable32`), :func:`read_text` the record.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from adavar.readers.errors import fail
from adavar.readers.record import RawRecord
from adavar.readers.table import MISSING, Table, channels_from_table, is_iso

#: Lines starting with one of these (after leading blanks) are comments in text files.
COMMENT_PREFIXES = ("#", "%")


def _read_lines(path: Path) -> list[tuple[int, str]]:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise fail(
            f"{path} is not a UTF-8 text file: export the data as plain CSV or text"
        ) from None
    except OSError as exc:
        raise fail(f"cannot read {path}: {exc.strerror or exc}") from None
    return [
        (number, line)
        for number, raw in enumerate(text.splitlines(), start=1)
        if (line := raw.strip()) and not line.startswith(COMMENT_PREFIXES)
    ]


def _split(text: str, delim: str | None) -> list[str]:
    if delim is None:
        return text.split()
    if text.endswith(delim):  # one trailing separator is common in exported files
        text = text[: -len(delim)]
    row = next(csv.reader([text], delimiter=delim, skipinitialspace=True), [])
    return [cell.strip() for cell in row]


def _sniff(sample: list[str]) -> str | None:
    """Tab, semicolon or comma (in that order) if it splits most sample lines into the
    same number (> 1) of fields; otherwise None (runs of whitespace)."""
    for delim in ("\t", ";", ","):
        counts = [len(_split(line, delim)) for line in sample]
        best = max(set(counts), key=counts.count)
        if best > 1 and 2 * counts.count(best) > len(counts):
            return delim
    return None


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _is_data(cells: list[str]) -> bool:
    """A data row: at least half of its non-empty cells are numbers (NaN and Inf count) or
    ISO 8601 times, and it has at least one (header words and preamble sentences do not)."""
    filled = [cell for cell in cells if cell]
    values = sum(1 for cell in filled if _is_number(cell) or is_iso(cell))
    return values > 0 and 2 * values >= len(filled)


_DELIM_NAMES = {",": "comma", ";": "semicolon", "\t": "tab", None: "whitespace"}


def text_table(path: Path, src: str, *, preamble: bool) -> tuple[Table, dict[str, Any]]:
    """The columns of a text file, and what was found (delimiter, header, lines skipped)."""
    lines = _read_lines(path)
    if not lines:
        raise fail(f"{src} is empty (no data rows): give a file with one sample per row")
    delim = _sniff([text for _, text in lines[-50:]])
    # header / preamble: the non-data lines before the first data line
    counts = [len(_split(text, delim)) for _, text in lines[-50:]]
    width = max(set(counts), key=counts.count)  # fields in a data row
    first_data = None
    for k, (_, text) in enumerate(lines[:1000]):
        cells = _split(text, delim)
        if len(cells) == width and _is_data(cells):
            first_data = k
            break
    if first_data is None:
        within = " in its first 1000 lines" if len(lines) > 1000 else ""
        raise fail(f"{src} has no numeric data rows{within}: give a file with one sample per row")
    data = lines[first_data:]
    n_cols = len(_split(data[0][1], delim))
    if first_data > 1 and not preamble and n_cols > 1:
        number = lines[1][0]
        raise fail(
            f"{src}: row {number} is neither a number row nor the header: remove the extra "
            "header lines or comment them out with #"
        )
    names: list[str] | None = None
    if first_data >= 1:
        head = _split(lines[first_data - 1][1], delim)
        if len(head) == n_cols and (n_cols > 1 or first_data == 1):
            names = [cell if cell else f"column {j}" for j, cell in enumerate(head)]
    has_header = names is not None
    if names is None:
        names = [str(j) for j in range(n_cols)]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise fail(f"{src}: the header names column {dupes[0]!r} twice: rename one of them")
    numbers = np.array([number for number, _ in data], dtype=np.int64)
    texts = [text for _, text in data]
    if delim is not None and any(text.endswith(delim) for text in texts):
        texts = [text[: -len(delim)] if text.endswith(delim) else text for text in texts]
    if delim is None:
        rows = [text.split() for text in texts]
    elif not any('"' in text for text in texts):
        rows = [text.split(delim) for text in texts]  # cells stripped below where needed
    else:
        reader = csv.reader(texts, delimiter=delim, skipinitialspace=True)
        rows = [[cell.strip() for cell in row] for row in reader]
    if len({len(row) for row in rows}) > 1 or len(rows[0]) != n_cols:
        for i, row in enumerate(rows):
            if len(row) != n_cols:
                raise fail(
                    f"{src}: row {numbers[i]} has {len(row)} fields, expected {n_cols} "
                    f"({_DELIM_NAMES[delim]}-separated): fix or remove that row"
                )
    cols: list[Sequence[str]] = list(zip(*rows, strict=True))
    del rows
    kinds: dict[str, str] = {}
    why_not: dict[str, str] = {}
    parsed: dict[str, np.ndarray] = {}
    for j, name in enumerate(names):
        values = _parse_numeric(cols[j])
        if values is not None:
            kinds[name], parsed[name] = "num", values
            continue
        cells = cols[j] = [cell.strip() for cell in cols[j]]
        if all(c.casefold() in MISSING or is_iso(c) for c in cells[:200]) and any(
            is_iso(c) for c in cells[:200]
        ):
            kinds[name] = "iso"
            continue
        kinds[name] = "text"
        for i, cell in enumerate(cells):
            if cell.casefold() not in MISSING and not _is_number(cell):
                hint = "; decimal commas are not read" if _is_number(cell.replace(",", ".")) else ""
                why_not[name] = f"row {numbers[i]}: {cell!r}{hint}"
                break
    by_name = dict(zip(names, cols, strict=True))

    def get(name: str) -> Any:
        return parsed[name] if name in parsed else by_name[name]

    tab = Table(names, kinds, get, len(numbers), numbers, why_not)
    meta = {
        "delimiter": _DELIM_NAMES[delim],
        "header": has_header,
        "skipped_lines_before_data": first_data,
    }
    return tab, meta


def _parse_numeric(cells: Sequence[str]) -> np.ndarray | None:
    """The cells as int64 (if all are integers) or float64 (missing cells NaN), or None."""
    try:
        return np.array(cells, dtype=np.int64)
    except (ValueError, OverflowError):
        pass
    try:
        return np.array(cells, dtype=np.float64)
    except ValueError:
        pass
    filled = ["nan" if c.strip().casefold() in MISSING else c for c in cells]
    if all(c == "nan" for c in filled):
        return None
    try:
        return np.array(filled, dtype=np.float64)
    except ValueError:
        return None


def read_text(path: Path, src: str, opts: dict[str, Any]) -> RawRecord:
    """The record of a CSV / TSV / whitespace-separated text file."""
    tab, meta = text_table(path, src, preamble=False)
    channels, rel, t0, info = channels_from_table(
        tab, columns=opts["columns"], time_column=opts["time_column"],
        time_format=opts["time_format"], src=src,
    )  # fmt: skip
    meta.update(info)
    return RawRecord(channels, rel, t0, tab.rows, "row", meta)

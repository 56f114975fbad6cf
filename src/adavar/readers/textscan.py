"""Streaming a text table: binary checks, the first and last lines, blocks of data rows.

A text file is never read whole. :func:`open_text` checks its first kilobytes (binary data,
a UTF-16 or compressed file, a format known by its magic number) and returns its first
lines (:data:`HEAD` bytes, to find the header and the first data row) and last lines
(:data:`TAIL` bytes, to choose the delimiter). :func:`read_columns` then reads the data rows
in blocks of :data:`BLOCK` bytes: each block is checked (NUL bytes, UTF-8), its comment and
blank lines taken out, and parsed by pandas' C parser when pandas is installed (NumPy
otherwise); the columns grow block by block into NumPy arrays, so the memory used is the
samples' and one block's, not the text's.

Every line keeps its number in the file (1-based, counting comments and the header), so
that every message names the row an editor shows.
"""

from __future__ import annotations

import codecs
import csv
import io
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from adavar.errors import AdavarInputError
from adavar.readers.errors import fail
from adavar.readers.table import MISSING, is_iso

#: Bytes read at a time from a text file.
BLOCK = 8 << 20
#: Bytes at the start of a file searched for the header and the first data row.
HEAD = 1 << 20
#: Bytes at the end of a file whose lines choose the delimiter.
TAIL = 64 << 10
#: The longest line read (a longer one is not a table of samples).
MAX_LINE = 16 << 20
#: Lines starting with one of these (after leading blanks) are comments in text files.
COMMENT_PREFIXES = ("#", "%")

_CHECKED = 8192  # first bytes checked for binary data
_FORMATS = (
    "give CSV, TSV or whitespace-separated text (UTF-8), or name a binary file by its "
    "format (.npy .npz .h5 .parquet .bag .mcap .db3, or a ROS 2 bag folder)"
)
_MAGIC = (
    (b"\x1f\x8b", "a gzip-compressed file: decompress it first (gunzip)"),
    (b"\xfd7zXZ\x00", "an xz-compressed file: decompress it first (unxz)"),
    (b"\x28\xb5\x2f\xfd", "a zstd-compressed file: decompress it first (unzstd)"),
    (b"PK\x03\x04", "a ZIP archive (an Excel workbook?): export the sheet as CSV"),
    (b"\xd0\xcf\x11\xe0", "an old Excel/Office file: export the sheet as CSV"),
    (b"\x89HDF\r\n\x1a\n", "an HDF5 file: rename it to .h5"),
    (b"PAR1", "a Parquet file: rename it to .parquet"),
    (b"\x93NUMPY", "a NumPy array file: rename it to .npy"),
    (b"#ROSBAG", "a ROS 1 bag: rename it to .bag"),
    (b"\x89MCAP", "an MCAP file (a ROS 2 bag): rename it to .mcap"),
    (b"SQLite format 3\x00", "an SQLite database (a ROS 2 bag?): give the bag folder"),
)
_UTF16 = (b"\xff\xfe", b"\xfe\xff")
# cells pandas reads as missing; other spellings of MISSING are found by the NumPy path
_NA_VALUES = sorted({v for m in MISSING for v in (m, m.upper(), m.title())} | {"NaN"})


def not_utf8(src: str, where: str = "") -> Exception:
    """The error for a file that is not UTF-8 text."""
    return fail(f"{src} is not a UTF-8 text file{where}: export the data as plain CSV or text")


def is_number(cell: str) -> bool:
    """Whether ``cell`` reads as a float (NaN and Inf included)."""
    try:
        float(cell)
    except ValueError:
        return False
    return True


def split(text: str, delim: str | None, src: str = "", number: int | None = None) -> list[str]:
    """The cells of one line: runs of whitespace (``delim`` None), or CSV fields (quotes
    understood, one trailing separator dropped, cells stripped)."""
    if delim is None:
        return text.split()
    if text.endswith(delim):  # one trailing separator is common in exported files
        text = text[: -len(delim)]
    if '"' not in text:
        return [cell.strip() for cell in text.split(delim)]
    try:
        row = next(csv.reader([text], delimiter=delim, skipinitialspace=True), [])
    except csv.Error as exc:  # a quoted field longer than the csv module's limit
        where = f": row {number}" if number is not None else ""
        raise fail(
            f"{src}{where} cannot be split into fields ({exc}): fix the quotes of that row, "
            "or remove the long text column"
        ) from None
    return [cell.strip() for cell in row]


@dataclass
class TextHead:
    """The first content lines of a text file, as (line number, byte offset of the line,
    stripped text), and the last ones (comment and blank lines left out)."""

    head: list[tuple[int, int, str]]
    tail: list[str]
    size: int
    complete: bool  # the head holds the whole file


def _check_binary(start: bytes, src: str) -> None:
    """Fail on a file that is not text: UTF-16 text, a known binary format, NUL bytes or
    many control characters in its first kilobytes."""
    if start.startswith(_UTF16):
        raise fail(
            f"{src} is not a UTF-8 text file (it is UTF-16 text): save it as UTF-8 (in "
            "Excel: CSV UTF-8)"
        )
    for magic, what in _MAGIC:
        if start.startswith(magic):
            raise fail(f"{src} is {what}")
    sample = start[:_CHECKED]
    if b"\x00" in sample:
        raise fail(f"{src} is not a text file (NUL bytes in its first kilobytes): {_FORMATS}")
    control = sum(sample.count(bytes([c])) for c in (*range(1, 9), *range(14, 32), 127))
    if control > 0.05 * len(sample):
        raise fail(f"{src} is not a text file (binary bytes in its first kilobytes): {_FORMATS}")


def _content_lines(
    buf: bytes, number: int, start: int, end: int, src: str, limit: int | None = None
) -> list[tuple[int, int, str]]:
    """(number, offset, stripped text) of the non-blank, non-comment lines of
    ``buf[start:end]`` (whole lines), at most ``limit`` of them."""
    out: list[tuple[int, int, str]] = []
    pos = start
    while pos < end and (limit is None or len(out) < limit):
        stop = buf.find(b"\n", pos, end)
        stop = end if stop < 0 else stop
        try:
            text = buf[pos:stop].decode("utf-8").strip()
        except UnicodeDecodeError:
            raise not_utf8(src, f" (row {number})") from None
        if text and not text.startswith(COMMENT_PREFIXES):
            out.append((number, pos, text))
        number += 1
        pos = stop + 1
    return out


def open_text(path: Path, src: str, n_head: int = 1001, n_tail: int = 50) -> TextHead:
    """The first ``n_head`` and last ``n_tail`` content lines of a text file, after the
    checks that it is text."""
    try:
        with open(path, "rb") as f:
            size = f.seek(0, 2)
            f.seek(0)
            start = f.read(HEAD)
            tail_bytes = b""
            if size > len(start):
                f.seek(max(len(start), size - TAIL))
                tail_bytes = f.read()
    except OSError as exc:
        raise fail(f"cannot read {path}: {exc.strerror or exc}") from None
    _check_binary(start, src)
    bom = 3 if start.startswith(b"\xef\xbb\xbf") else 0
    complete = size <= len(start)
    end = len(start)
    if not complete:
        end = start.rfind(b"\n") + 1
        if end <= bom:
            raise fail(
                f"{src}: row 1 is longer than {HEAD >> 20} MiB: this is not a table of "
                f"samples ({_FORMATS})"
            )
    if start.find(b"\n", bom, end) < 0 and b"\r" in start[bom:end].rstrip(b"\r"):
        raise fail(f"{src} ends its lines with CR only (old Mac text): convert them to LF")
    head = _content_lines(start, 1, bom, end, src, n_head)
    if complete:
        tail = [text for _, _, text in head[-n_tail:]]
        if len(head) >= n_head:  # the head stopped early: the last lines are further on
            lines = _content_lines(start, 1, bom, end, src)
            tail = [text for _, _, text in lines[-n_tail:]]
    else:  # a binary or broken end is reported with its row when the blocks reach it
        lines = []
        if b"\x00" not in tail_bytes:
            try:
                lines = _content_lines(tail_bytes, 0, tail_bytes.find(b"\n") + 1,
                                       len(tail_bytes), src)  # fmt: skip
            except AdavarInputError:
                lines = []
        tail = [text for _, _, text in lines[-n_tail:]] or [t for _, _, t in head[-n_tail:]]
    return TextHead(head, tail, size, complete)


class _View(io.RawIOBase):
    """A read-only file over a buffer, for pandas (no copy of the block is made)."""

    def __init__(self, data: bytes | memoryview) -> None:
        self.view = memoryview(data)
        self.pos = 0

    def readable(self) -> bool:
        return True

    def readinto(self, b: Any) -> int:
        n = min(len(b), len(self.view) - self.pos)
        b[:n] = self.view[self.pos : self.pos + n]
        self.pos += n
        return n


def iter_blocks(
    path: Path, offset: int, number: int, src: str
) -> Iterator[tuple[memoryview, int, int]]:
    """(block of whole lines, number of its first line, number of lines) from byte
    ``offset`` on, each checked for NUL bytes and UTF-8. A block is a view of one buffer
    read into again for the next block (fresh 8 MiB buffers cost more than the parsing
    around them): use it before asking for the next one."""
    buf = bytearray(BLOCK)
    with open(path, "rb") as f:
        f.seek(offset)
        while True:
            got = f.readinto(buf)
            if not got:
                return
            nul = buf.find(b"\x00", 0, got)
            if nul >= 0:
                row = number + buf.count(b"\n", 0, nul)
                raise fail(f"{src}: row {row} holds NUL bytes (binary data, not text): {_FORMATS}")
            end = buf.rfind(b"\n", 0, got) + 1
            if end == 0 and got == len(buf):  # a line longer than the buffer
                if len(buf) >= MAX_LINE:
                    raise fail(
                        f"{src}: row {number} is longer than {MAX_LINE >> 20} MiB: this is not "
                        "a table of samples (check the file)"
                    )
                f.seek(-got, 1)
                buf = bytearray(2 * len(buf))
                continue
            last = end == 0  # the last line, without a line end
            if last:
                end = got
            elif end < got:
                f.seek(end - got, 1)
            codes = np.frombuffer(buf, np.uint8, count=end)
            count = int(np.count_nonzero(codes == 10)) + last
            view = memoryview(buf)[:end]
            if codes.max() >= 128:
                _check_utf8(view, number, src)
            yield view, number, count
            number += count


def _check_utf8(view: memoryview, number: int, src: str) -> None:
    try:
        codecs.utf_8_decode(view, "strict", True)
    except UnicodeDecodeError as exc:
        row = number + view[: exc.start].tobytes().count(b"\n")
        raise not_utf8(src, f" (row {row})") from None


def read_line(path: Path, number: int) -> str:
    """Line ``number`` (1-based) of a text file, stripped, for a message."""
    with open(path, "rb") as f:
        for k, raw in enumerate(f, start=1):
            if k == number:
                return raw.decode("utf-8", "replace").strip()
    return ""


# --------------------------------------------------------------------------------------
# blocks -> numbers or cells


def _pandas() -> Any:
    """pandas, or None when it is not installed (NumPy then parses the blocks)."""
    try:
        import pandas
    except ImportError:  # pragma: no cover - pandas is installed where the tests run
        return None
    return pandas


def _clean(block: memoryview, number: int) -> tuple[list[str], list[int]]:
    """The block's data lines (stripped; comments and blank lines left out), and their
    numbers."""
    texts: list[str] = []
    numbers: list[int] = []
    for k, raw in enumerate(str(block, "utf-8").split("\n")):
        text = raw.strip()
        if text and not text.startswith(COMMENT_PREFIXES):
            texts.append(text)
            numbers.append(number + k)
    return texts, numbers


@dataclass
class Layout:
    """How the data rows of a text file are written."""

    delim: str | None  # None: runs of whitespace
    decimal: str  # "." or ","
    n_cols: int
    src: str
    delim_name: str
    spaced: bool = True  # blanks after separators or quotes: pandas skips initial blanks


def _first_row_fits(data: bytes | memoryview, lay: Layout) -> bool:
    """Whether the block's first row has at most ``n_cols`` fields: pandas sizes the table
    by it, and with more fields there it would drop the extra ones with only a warning
    (more fields on a later row are an error)."""
    head = bytes(memoryview(data)[: 1 << 20])
    lines = head.split(b"\n", 8)
    if len(head) < len(data):
        lines = lines[:-1]  # the last piece may be cut
    for raw in lines[:8]:
        text = raw.decode("utf-8").strip()
        if text:
            return len(split(text, lay.delim, lay.src)) <= lay.n_cols
    return len(head) == len(data)


def _pandas_block(
    pd: Any, data: bytes | memoryview, n_rows: int, lay: Layout, text_cols: set[int]
) -> Any:
    """The block's columns (pandas Series) parsed by pandas' C parser, or None when the
    Python path must look at it: a row with too many or too few fields, a blank line (the
    row count differs), a quoted line end."""
    if not _first_row_fits(data, lay):
        return None
    names = list(range(lay.n_cols + 1))  # one more: a row with an extra field shows in it
    frame = None
    for spaced in (lay.spaced, True) if not lay.spaced and lay.delim is not None else (True,):
        try:
            frame = pd.read_csv(
                _View(data), sep=r"\s+" if lay.delim is None else lay.delim, header=None,
                names=names, index_col=False, dtype=dict.fromkeys(text_cols, str) or None,
                na_values=_NA_VALUES, keep_default_na=False, skipinitialspace=spaced,
                engine="c", low_memory=False, decimal=lay.decimal, encoding="utf-8",
            )  # fmt: skip
        except Exception:  # ParserError (a row with too many fields), a buffer overflow...
            return None
        if all(_numeric_dtype(frame[j].dtype) for j in range(lay.n_cols) if j not in text_cols):
            break  # else: text where numbers were expected: again, blanks after separators
    if frame is None:  # pragma: no cover - the loop runs at least once
        return None
    if len(frame) != n_rows or frame[lay.n_cols].notna().any():
        return None
    if lay.n_cols > 1:
        short = np.flatnonzero(frame[lay.n_cols - 1].isna().to_numpy())
        if short.size:  # pandas fills a short row with NaN: count those rows' fields
            lines = str(data, "utf-8").split("\n")
            if any(len(split(lines[int(i)].strip(), lay.delim)) != lay.n_cols for i in short):
                return None
    return [frame[j] for j in range(lay.n_cols)]


def _python_block(texts: list[str], numbers: Sequence[int], lay: Layout) -> list[Any]:
    """The block's cells split in Python, as lists of str; a ragged row is named."""
    delim = lay.delim
    if delim is None:
        rows = [text.split() for text in texts]
    else:
        rows = [split(text, delim, lay.src, n) for text, n in zip(texts, numbers, strict=True)]
    for i, row in enumerate(rows):
        if len(row) == lay.n_cols - 1 and delim is not None and texts[i].endswith(delim):
            row.append("")  # "1.5," with two columns: the separator ends an empty last cell
        if len(row) != lay.n_cols:
            raise fail(
                f"{lay.src}: row {numbers[i]} has {len(row)} fields, expected {lay.n_cols} "
                f"({lay.delim_name}-separated): fix or remove that row"
            )
    return [list(col) for col in zip(*rows, strict=True)]


def parse_numeric(cells: Sequence[str], decimal: str = ".") -> np.ndarray | None:
    """The cells as int64 (if all are integers) or float64 (missing cells NaN), or None.
    With decimal commas, a cell with a decimal point is not a number (``1.500`` may be 1500
    with digit grouping)."""
    if decimal == ",":
        if any("." in c for c in cells):
            return None
        cells = [c.replace(",", ".") for c in cells]
    try:
        return np.array(cells, dtype=np.int64)
    except (ValueError, OverflowError):
        pass
    try:
        return np.array(cells, dtype=np.float64)
    except ValueError:
        pass
    filled = ["nan" if c.strip().casefold() in MISSING else c for c in cells]
    try:
        return np.array(filled, dtype=np.float64)
    except ValueError:
        return None


class _Grow:
    """A 1-D array grown piece by piece (capacity from an estimate, then x1.5); int64 until
    a float piece comes."""

    def __init__(self, capacity: int, dtype: Any) -> None:
        self.buf = np.empty(max(capacity, 16), dtype=dtype)
        self.n = 0

    def append(self, piece: np.ndarray) -> None:
        if piece.dtype.kind == "f" and self.buf.dtype.kind == "i":
            self.buf = self.buf.astype(np.float64)
        end = self.n + piece.size
        if end > self.buf.size:
            grown = np.empty(max(end, int(self.buf.size * 1.5)), dtype=self.buf.dtype)
            grown[: self.n] = self.buf[: self.n]
            self.buf = grown
        self.buf[self.n : end] = piece
        self.n = end

    def result(self) -> np.ndarray:
        if self.n < 0.9 * self.buf.size:
            return self.buf[: self.n].copy()
        return self.buf[: self.n]


@dataclass
class Column:
    """One column of a text table, read block by block. ``kind``: ``"num"``, ``"iso"``
    (ISO 8601 strings), ``"text"`` (unusable; ``bad`` is its first bad cell) or None (only
    missing cells so far, ``n_missing`` of them)."""

    kind: str | None = None
    values: _Grow | None = None
    cells: list[str] = field(default_factory=list)
    n_missing: int = 0
    bad: tuple[int, str] | None = None
    filled: bool = False  # a value that is not missing was seen

    def add(self, piece: Any, numbers: np.ndarray, capacity: int, decimal: str) -> None:
        """Append one block's piece: a pandas Series, a NumPy array or a list of str."""
        if self.kind == "text":
            return
        if self.kind is None and self.values is None and _all_missing(piece):
            self.n_missing += len(numbers)
            return
        values = _numeric_piece(piece)
        if values is None:
            cells = _cells(piece)
            if self.kind == "iso":
                self.cells += [c.strip() for c in cells]
                return
            values = parse_numeric(cells, decimal)
            if values is None:
                head = [c.strip() for c in cells[:200]]
                if (
                    self.kind is None
                    and all(c.casefold() in MISSING or is_iso(c) for c in head)
                    and any(is_iso(c) for c in head)
                ):
                    self.kind = "iso"
                    self.cells = [""] * self.n_missing + [c.strip() for c in cells]
                    return
                self._make_text(cells, numbers, decimal)
                return
        if self.kind == "iso":
            self.cells += [str(v) for v in values.tolist()]
            return
        if self.values is None:
            self.values = _Grow(capacity, np.float64 if self.n_missing else values.dtype)
            if self.n_missing:
                self.values.append(np.full(self.n_missing, np.nan))
        self.values.append(values)
        self.kind = "num"
        if not self.filled:
            self.filled = values.dtype.kind == "i" or not bool(np.isnan(values).all())

    def _make_text(self, cells: list[str], numbers: np.ndarray, decimal: str) -> None:
        self.kind, self.values, self.cells = "text", None, []
        for i, cell in enumerate(cells):
            text = cell.strip()
            if decimal == ",":
                number_like = "." not in text and is_number(text.replace(",", "."))
            else:
                number_like = is_number(text)
            if text.casefold() not in MISSING and not number_like:
                self.bad = (int(numbers[i]), text)
                return

    def finish(self, n: int) -> None:
        """Settle the kind at the end: a column of only missing cells is not numeric."""
        if (self.kind == "num" and not self.filled) or self.kind is None:
            self.kind, self.values = "text", None
        if self.kind == "iso" and len(self.cells) < n:  # pragma: no cover - kept in step
            self.cells += [""] * (n - len(self.cells))


def _numeric_dtype(dtype: Any) -> bool:
    return isinstance(dtype, np.dtype) and dtype.kind in "iuf"


def _numeric_piece(piece: Any) -> np.ndarray | None:
    """A piece's numbers (int64 or float64), or None if it holds text."""
    if isinstance(piece, list):
        return None
    dtype = piece.dtype
    if not _numeric_dtype(dtype):
        return None
    values = piece.to_numpy() if hasattr(piece, "to_numpy") else np.asarray(piece)
    if dtype.kind == "u" or (dtype.kind == "f" and dtype != np.float64):
        return values.astype(np.float64)  # uint64 beyond int64: as float, like any number
    if dtype.kind == "i" and dtype != np.int64:
        return values.astype(np.int64)
    return values


def _cells(piece: Any) -> list[str]:
    """A piece's cells as strings ("" where pandas found a missing cell)."""
    if isinstance(piece, list):
        return piece
    return ["" if (v is None or (isinstance(v, float) and v != v)) else str(v) for v in piece]


def _all_missing(piece: Any) -> bool:
    """Whether every cell of a piece is missing (the column's kind is still open)."""
    values = _numeric_piece(piece)
    if values is not None:
        return values.dtype.kind == "f" and bool(np.isnan(values).all())
    return all(c.strip().casefold() in MISSING for c in _cells(piece))


def _contains(view: memoryview, sub: bytes) -> bool:
    """Whether a block (a view from the start of its buffer) holds ``sub``."""
    return view.obj.find(sub, 0, view.nbytes) >= 0  # type: ignore[union-attr]


def read_columns(
    path: Path, offset: int, number: int, lay: Layout, data_bytes: int
) -> tuple[list[Column], np.ndarray]:
    """The columns of the data rows from byte ``offset`` (line ``number``) to the end, and
    every data row's line number."""
    pd = _pandas()
    columns = [Column() for _ in range(lay.n_cols)]
    rows: _Grow | None = None
    capacity = 0
    for block, first, n_lines in iter_blocks(path, offset, number, lay.src):
        texts: list[str] | None = None
        data: bytes | memoryview = block
        if _contains(block, b"#") or _contains(block, b"%"):  # comment lines: out with them
            texts, numbers = _clean(block, first)
            data = ("\n".join(texts) + "\n").encode("utf-8")
            line_numbers = np.asarray(numbers, dtype=np.int64)
        else:
            line_numbers = np.arange(first, first + n_lines, dtype=np.int64)
        if rows is None:  # capacity from the first block's bytes per row
            per_row = max(1.0, len(block) / max(1, n_lines))
            capacity = int(1.05 * data_bytes / per_row) + 1024
            rows = _Grow(capacity, np.int64)
        pieces = None
        if pd is not None:
            text_cols = {j for j, c in enumerate(columns) if c.kind in ("iso", "text")}
            if line_numbers.size:
                pieces = _pandas_block(pd, data, line_numbers.size, lay, text_cols)
            if pieces is None and texts is None:  # blank lines, say: clean, then again
                texts, numbers = _clean(block, first)
                line_numbers = np.asarray(numbers, dtype=np.int64)
                if texts:
                    data = ("\n".join(texts) + "\n").encode("utf-8")
                    pieces = _pandas_block(pd, data, line_numbers.size, lay, text_cols)
        if pieces is None:
            if texts is None:
                texts, numbers = _clean(block, first)
                line_numbers = np.asarray(numbers, dtype=np.int64)
            if not texts:
                continue
            pieces = _python_block(texts, numbers, lay)
        for column, piece in zip(columns, pieces, strict=True):
            column.add(piece, line_numbers, capacity, lay.decimal)
        rows.append(line_numbers)
    n = 0 if rows is None else rows.n
    for column in columns:
        column.finish(n)
    return columns, (np.empty(0, np.int64) if rows is None else rows.result())

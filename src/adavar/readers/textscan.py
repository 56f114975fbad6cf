"""Streaming a text table: binary checks, the first and last lines, blocks of data rows.

A text file is never read whole. :func:`open_text` checks its first kilobytes (binary data,
a UTF-16 or compressed file, a format known by its magic number) and returns its first
lines (:data:`HEAD` bytes, to find the header and the first data row) and last lines
(:data:`TAIL` bytes, to choose the delimiter). :func:`read_columns` then reads the data rows
in blocks of :data:`BLOCK` bytes: each block is checked (NUL bytes, UTF-8), its comment and
blank lines taken out, and parsed by pandas' C parser when pandas is installed (NumPy
otherwise); the columns grow block by block into NumPy arrays, so the memory used is the
samples' and a few blocks', not the text's. The blocks are read and parsed on a few threads
at once (:func:`parse_threads`; pandas' C parser lets go of the GIL), a block in parts when
that reads the same; what they give, and the first error, are those of reading the blocks
one after the other.

Every line keeps its number in the file (1-based, counting comments and the header), so
that every message names the row an editor shows.
"""

from __future__ import annotations

import codecs
import csv
import io
import itertools
import os
import threading
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.readers.errors import fail
from adavar.readers.table import MISSING, is_iso

#: Bytes read at a time from a text file.
BLOCK = 8 << 20
#: The most threads parsing blocks of a text file at once.
THREADS = 4
#: The least bytes of a part of a block parsed on a thread of its own.
_MIN_PART = 1 << 20
#: Bytes at the start of a file searched for the header and the first data row.
HEAD = 1 << 20
#: Bytes at the end of a file whose lines choose the delimiter.
TAIL = 64 << 10
#: The longest line read (a longer one is not a table of samples).
MAX_LINE = 16 << 20
#: Lines starting with one of these (after leading blanks) are comments in text files.
COMMENT_PREFIXES = ("#", "%")
#: ``rostopic echo -p`` writes its CSV header as a comment, ``%time,field.header.seq,...``:
#: as the file's first line it is the header, ``%time`` read as ``time_ns`` (the receive
#: time in nanoseconds, as rostopic writes it)
ROSTOPIC_HEADER = "%time"

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
        if not out and text.startswith(ROSTOPIC_HEADER + ","):
            text = "time_ns" + text[len(ROSTOPIC_HEADER) :]  # the header, and its unit
            out.append((number, pos, text))
        elif text and not text.startswith(COMMENT_PREFIXES):
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
    """A read-only file over a block, for pandas: its one ``read`` hands over the block
    itself (no copy is made)."""

    def __init__(self, data: bytes) -> None:
        self.data = data
        self.pos = 0

    def readable(self) -> bool:
        return True

    def readinto(self, b: Any) -> int:
        n = min(len(b), len(self.data) - self.pos)
        b[:n] = self.data[self.pos : self.pos + n]
        self.pos += n
        return n

    def read(self, size: int = -1) -> bytes:
        """What is left, whatever ``size``: pandas' C parser tokenizes the bytes it is
        given, so the whole block in one piece spares it a copy and a call back into Python
        (and the GIL, which other threads may hold) every 256 KiB."""
        piece = self.data if self.pos == 0 else self.data[self.pos :]
        self.pos = len(self.data)
        return piece


#: Bytes at the end of a block's window read first, to find its last line end.
_PROBE = 64 << 10
_SEEK = threading.Lock()  # reads at an offset where there is no os.pread


def _read_at(f: Any, pos: int, size: int) -> bytes:
    """``size`` bytes from byte ``pos`` of unbuffered file ``f`` (fewer at its end), from
    any thread."""
    pieces: list[bytes] = []
    while size > 0:
        if hasattr(os, "pread"):
            piece = os.pread(f.fileno(), size, pos)
        else:  # pragma: no cover - Windows
            with _SEEK:
                f.seek(pos)
                piece = f.read(size)
        if not piece:
            break
        pieces.append(piece)
        pos += len(piece)
        size -= len(piece)
    return pieces[0] if len(pieces) == 1 else b"".join(pieces)


@dataclass
class _Part:
    """Part ``index`` of the ``parts`` of a block: ``size`` bytes from byte ``pos``
    (``data`` when already read). The last part carries the rest of the block's window
    after it (checked for NUL bytes too); ``too_long``: the block's first line is longer
    than :data:`MAX_LINE`."""

    pos: int
    size: int
    index: int = 0
    parts: int = 1
    rest: bytes = b""
    data: bytes | None = None
    too_long: bool = False


def _cuts(f: Any, pos: int, size: int, parts: int) -> list[int]:
    """Where ``parts`` parts of the ``size`` bytes from ``pos`` start: each after the first
    line end past an equal share; ``[pos]`` (one part) when a share has no line end within
    :data:`_PROBE` bytes."""
    cuts = [pos]
    for k in range(1, parts):
        target = pos + k * size // parts
        probe = _read_at(f, target, min(_PROBE, pos + size - target))
        cut = probe.find(b"\n") + 1
        if not cut or target + cut >= pos + size or target + cut <= cuts[-1]:
            return [pos]
        cuts.append(target + cut)
    return cuts


def _parts(f: Any, offset: int, width: int, parts: Callable[[int], int]) -> Iterator[_Part]:
    """The blocks of unbuffered file ``f`` from byte ``offset`` on: windows of ``width``
    bytes (doubled past a longer line) cut after their last line end, the last line of the
    file whole; each in ``parts(size)`` parts cut at line ends. Only the ends of a window
    and of its parts are read here, unless it holds no line end: the parts themselves are
    read by :func:`_load`, on the threads that parse them."""
    pos = offset
    while True:
        got = min(width, os.fstat(f.fileno()).st_size - pos)  # the window's bytes
        if got > _PROBE:
            probe = _read_at(f, pos + got - _PROBE, _PROBE)
            cut = probe.rfind(b"\n") + 1
            if len(probe) == _PROBE and cut:
                size = got - _PROBE + cut
                cuts = _cuts(f, pos, size, parts(size))
                ends = [*cuts[1:], pos + size]
                for k, (start, end) in enumerate(zip(cuts, ends, strict=True)):
                    rest = probe[cut:] if k == len(cuts) - 1 else b""
                    yield _Part(start, end - start, k, len(cuts), rest)
                pos += size
                continue
        raw = _read_at(f, pos, width)
        if not raw:
            return
        end = raw.rfind(b"\n") + 1
        if end == 0 and len(raw) == width:  # a line longer than the window
            if b"\x00" in raw or width >= MAX_LINE:
                yield _Part(pos, 0, rest=raw, data=b"", too_long=b"\x00" not in raw)
                return
            width *= 2
            continue
        end = end or len(raw)  # the last line, without line end
        yield _Part(pos, end, rest=raw[end:], data=raw if end == len(raw) else raw[:end])
        pos += end


class _AtRow(Exception):
    """A problem of a block's text (``"nul"``, ``"utf8"``, ``"long"``) at line ``row``,
    counted from the block's first line (which the reader knows when it gets there)."""

    def __init__(self, what: str, row: int) -> None:
        super().__init__(what, row)
        self.what, self.row = what, row

    def error(self, number: int, src: str) -> Exception:
        """The message, for a block whose first line is line ``number``."""
        row = number + self.row
        if self.what == "nul":
            return fail(f"{src}: row {row} holds NUL bytes (binary data, not text): {_FORMATS}")
        if self.what == "utf8":
            return not_utf8(src, f" (row {row})")
        return fail(
            f"{src}: row {row} is longer than {MAX_LINE >> 20} MiB: this is not a table of "
            "samples (check the file)"
        )


def _load(f: Any, part: _Part) -> tuple[bytes, int, _AtRow | None, _AtRow | None]:
    """A part's bytes and number of lines, and its problems (lines counted from its
    first): a NUL byte (also in the rest of its window), invalid UTF-8 (decoded only when
    it holds other than ASCII), a line longer than :data:`MAX_LINE`."""
    if part.too_long:
        return b"", 0, _AtRow("long", 0), None
    data = _read_at(f, part.pos, part.size) if part.data is None else part.data
    nul = (data + part.rest if b"\x00" in part.rest else data).find(b"\x00")
    if nul >= 0:
        return data, 0, _AtRow("nul", data.count(b"\n", 0, nul)), None
    codes = np.frombuffer(data, np.uint8)
    count = int(np.count_nonzero(codes == 10)) + (data[-1:] not in (b"", b"\n"))  # last line
    if codes.max() >= 128:
        try:
            codecs.utf_8_decode(data, "strict", True)
        except UnicodeDecodeError as exc:
            return data, count, None, _AtRow("utf8", data.count(b"\n", 0, exc.start))
    return data, count, None, None


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


def _clean(block: bytes, number: int) -> tuple[list[str], list[int]]:
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


def _first_row_fits(data: bytes, lay: Layout) -> bool:
    """Whether the block's first row has at most ``n_cols`` fields: pandas sizes the table
    by it, and with more fields there it would drop the extra ones with only a warning
    (more fields on a later row are an error)."""
    head = data[: 1 << 20]
    lines = head.split(b"\n", 8)
    if len(head) < len(data):
        lines = lines[:-1]  # the last piece may be cut
    for raw in lines[:8]:
        text = raw.decode("utf-8").strip()
        if text:
            return len(split(text, lay.delim, lay.src)) <= lay.n_cols
    return len(head) == len(data)


def _exact_first_row(data: bytes, lay: Layout) -> bool:
    """Whether the block's first line has exactly ``n_cols`` fields (no quote, no CR within
    it): pandas then sizes the table by them, and a later row with more fields is an error
    (so no extra column is needed to see it)."""
    if lay.delim is None or lay.n_cols < 2:
        return False
    head = data[: 1 << 16]
    end = head.find(b"\n")
    if end < 0 and len(head) < len(data):
        return False
    line = head[: end if end >= 0 else len(head)].removesuffix(b"\r")
    return (
        b'"' not in line
        and b"\r" not in line
        and line.count(lay.delim.encode("utf-8")) == lay.n_cols - 1
    )


def _read_frame(
    pd: Any, data: bytes, lay: Layout, text_cols: set[int], width: int, retry: bool = True
) -> Any:
    """The block as a pandas DataFrame of ``width`` columns, or None when pandas' C parser
    fails on it: a row with more fields (ParserError), a buffer overflow... Text where
    numbers were expected is read again with blanks after separators skipped (``retry``;
    without it, such a block is None)."""
    frame = None
    for spaced in (lay.spaced, True) if not lay.spaced and lay.delim is not None else (True,):
        try:
            frame = pd.read_csv(
                _View(data), sep=r"\s+" if lay.delim is None else lay.delim, header=None,
                names=list(range(width)), index_col=False,
                dtype=dict.fromkeys(text_cols, str) or None, na_values=_NA_VALUES,
                keep_default_na=False, skipinitialspace=spaced, engine="c", low_memory=False,
                decimal=lay.decimal, encoding="utf-8",
            )  # fmt: skip
        except Exception:
            return None
        if all(_numeric_dtype(frame[j].dtype) for j in range(lay.n_cols) if j not in text_cols):
            return frame
        if not retry:
            return None
    return frame  # text where numbers were expected, also with blanks skipped


def _pandas_block(
    pd: Any, data: bytes, n_rows: int, lay: Layout, text_cols: set[int], retry: bool = True
) -> Any:
    """The block's columns (pandas Series) parsed by pandas' C parser, or None when the
    Python path must look at it: a row with too many or too few fields, a blank line (the
    row count differs), a quoted line end (and, without ``retry``, text where numbers were
    expected)."""
    if not _first_row_fits(data, lay):
        return None
    frame = None
    if _exact_first_row(data, lay):  # n_cols columns: a longer row is a ParserError
        frame = _read_frame(pd, data, lay, text_cols, lay.n_cols, retry)
    if frame is None:  # one more column: a row with an extra field shows in it
        frame = _read_frame(pd, data, lay, text_cols, lay.n_cols + 1, retry)
        if frame is None or frame[lay.n_cols].notna().any():
            return None
    if len(frame) != n_rows:
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


@dataclass
class _Parsed:
    """A block, or a part of one, read and parsed (on a worker thread, see
    :func:`read_columns`): its bytes and number of lines, and the problems of its text
    (:func:`_load`); its pandas columns, or None for the Python path; its data lines when
    they were cleaned of comment and blank lines (else None) and their line numbers; every
    data row's line number (both counted from its first line); the columns read as text
    (``text_cols``), and the error raised, if any."""

    data: bytes
    n_lines: int
    pieces: list[Any] | None
    texts: list[str] | None = None
    numbers: Sequence[int] = ()
    line_numbers: np.ndarray = field(default_factory=lambda: np.empty(0, np.int64))
    text_cols: frozenset[int] = frozenset()
    error: Exception | None = None
    nul: _AtRow | None = None
    utf8: _AtRow | None = None


def _parse_block(
    pd: Any, block: bytes, n_lines: int, lay: Layout, text_cols: frozenset[int], part: bool = False
) -> _Parsed:
    """A block's pieces: pandas' C parser on the block (cleaned of comment lines first), or
    on its cleaned lines when the raw block does not parse; None for the Python path. A
    ``part`` of a block is parsed only the way the whole block would be at first (no second
    try with blanks skipped): its pieces are None where the block needs another way."""
    texts: list[str] | None = None
    numbers: Sequence[int] = ()
    data = block
    if b"#" in block or b"%" in block:  # comment lines: out with them
        texts, numbers = _clean(block, 0)
        data = ("\n".join(texts) + "\n").encode("utf-8")
        line_numbers = np.asarray(numbers, dtype=np.int64)
    else:
        line_numbers = np.arange(n_lines, dtype=np.int64)
    pieces = None
    if pd is not None:
        if line_numbers.size:
            pieces = _pandas_block(pd, data, line_numbers.size, lay, set(text_cols), not part)
        if pieces is None and texts is None and not part:  # blank lines, say: clean, again
            texts, numbers = _clean(block, 0)
            line_numbers = np.asarray(numbers, dtype=np.int64)
            if texts:
                data = ("\n".join(texts) + "\n").encode("utf-8")
                pieces = _pandas_block(pd, data, line_numbers.size, lay, set(text_cols))
    if pieces is None and texts is None and not part:
        texts, numbers = _clean(block, 0)
        line_numbers = np.asarray(numbers, dtype=np.int64)
    return _Parsed(block, n_lines, pieces, texts, numbers, line_numbers, text_cols)


def _read_part(pd: Any, f: Any, part: _Part, lay: Layout, text_cols: frozenset[int]) -> _Parsed:
    """A part read, checked and parsed (:func:`_parse_block`, as a part when the block
    has others). Problems and errors are kept for the reader to raise when it gets to the
    block (after the blocks before it)."""
    data, n_lines, nul, utf8 = _load(f, part)
    try:
        if nul is not None or utf8 is not None:
            parsed = _Parsed(data, n_lines, None)
        else:
            parsed = _parse_block(pd, data, n_lines, lay, text_cols, part.parts > 1)
    except Exception as exc:
        parsed = _Parsed(data, n_lines, None, error=exc)
    parsed.text_cols, parsed.nul, parsed.utf8 = text_cols, nul, utf8
    return parsed


def _in_step(parts: list[_Parsed], text_cols: frozenset[int]) -> bool:
    """Whether the parts of a block read as the whole block would: all through pandas at
    the first try, all raw or all cleaned of comment lines, with the block's
    ``text_cols``, and each column of one dtype in every part."""
    if any(p.pieces is None or p.text_cols != text_cols for p in parts):
        return False
    if len({p.texts is None for p in parts}) > 1:
        return False
    dtypes = [[piece.dtype for piece in p.pieces] for p in parts]  # type: ignore[union-attr]
    return all(d == dtypes[0] for d in dtypes)


def parse_threads(data_bytes: int) -> int:
    """Threads parsing the blocks of ``data_bytes`` of text at once: one when the text
    fits in one block; else the cores this process may use, at most :data:`THREADS` and
    ``ADAVAR_THREADS``."""
    blocks = -(-data_bytes // BLOCK)
    if blocks < 2:
        return 1
    from adavar.core.settings import requested_threads

    affinity = getattr(os, "sched_getaffinity", None)
    cores = len(affinity(0)) if affinity is not None else os.cpu_count() or 1
    return max(1, min(cores, THREADS, blocks, requested_threads() or cores))


def _in_order(
    items: Iterator[Any], work: Callable[..., Any], threads: int
) -> Iterator[tuple[Any, Any]]:
    """``(item, work(*item))`` for every item, in order, with ``work`` running on up to
    ``threads`` threads ahead of the caller (``threads`` items at most besides the one the
    caller holds). An error raised by ``items`` comes after the items before it."""
    if threads < 2:
        for item in items:
            yield item, work(*item)
        return
    pending: deque[tuple[Any, Future[Any]]] = deque()
    error: Exception | None = None
    with ThreadPoolExecutor(threads, thread_name_prefix="adavar-text") as pool:
        try:
            while True:
                try:
                    item = next(items)
                except StopIteration:
                    break
                except Exception as exc:  # a NUL byte, say: raised after the blocks before
                    error = exc
                    break
                pending.append((item, pool.submit(work, *item)))
                if len(pending) > threads:
                    done, future = pending.popleft()
                    yield done, future.result()
            while pending:
                done, future = pending.popleft()
                yield done, future.result()
        finally:
            for _, future in pending:
                future.cancel()
    if error is not None:
        raise error


def read_columns(
    path: Path, offset: int, number: int, lay: Layout, data_bytes: int
) -> tuple[list[Column], np.ndarray]:
    """The columns of the data rows from byte ``offset`` (line ``number``) to the end, and
    every data row's line number.

    The text is read in blocks (:func:`_parts`), and each block in parts that are read,
    checked and parsed on :func:`parse_threads` threads (pandas' C parser lets go of the
    GIL), a few parts ahead of the block added to the columns. The parts of a block stand
    for the whole block when they parse the plain way with the same column types (else the
    block is parsed whole); a block is parsed as text in the columns found to be text in
    the blocks before it (``text_cols``), and parsed again when a block it overtook made
    another column text; every problem is raised when the reader gets to its block: the
    result and the first error are those of reading the blocks one by one.
    """
    pd = _pandas()
    columns = [Column() for _ in range(lay.n_cols)]
    rows: _Grow | None = None
    capacity = 0
    threads = parse_threads(data_bytes) if pd is not None else 1  # NumPy: holds the GIL
    # a block is read in parts once the one before read plain (through pandas, no text
    # column), until the parts of a block do not read as the whole block would
    split = [False, threads < 2]  # [now, never again]

    def text_cols() -> frozenset[int]:
        return frozenset(j for j, c in enumerate(columns) if c.kind in ("iso", "text"))

    def parts(size: int) -> int:
        return threads if split[0] and not split[1] and size >= threads * _MIN_PART else 1

    with open(path, "rb", buffering=0) as f:
        jobs = ((pd, f, part, lay, text_cols()) for part in _parts(f, offset, BLOCK, parts))
        block: list[_Parsed] = []
        with closing(_in_order(jobs, _read_part, threads)) as done:
            for (_, _, part, _, _), parsed in done:
                block.append(parsed)
                if part.index < part.parts - 1:
                    continue
                got, block, now = block, [], text_cols()
                lines = [0, *itertools.accumulate(p.n_lines for p in got)]
                for problem in ("nul", "utf8"):
                    for start, p in zip(lines, got, strict=False):
                        if getattr(p, problem) is not None:
                            raise getattr(p, problem).error(number + start, lay.src)
                if len(got) > 1 and not _in_step(got, now):  # parse the block whole
                    split[1] = True
                    got = [_parse_block(pd, b"".join(p.data for p in got), lines[-1], lay, now)]
                elif got[0].text_cols != now:  # a block before made a column text
                    got = [_parse_block(pd, got[0].data, lines[-1], lay, now)]
                elif got[0].error is not None:
                    raise got[0].error
                if rows is None:  # capacity from the first block's bytes per row
                    per_row = max(1.0, sum(len(p.data) for p in got) / max(1, lines[-1]))
                    capacity = int(1.05 * data_bytes / per_row) + 1024
                    rows = _Grow(capacity, np.int64)
                for start, p in zip(lines, got, strict=False):
                    _add(columns, rows, p, number + start, capacity, lay)
                number += lines[-1]
                split[0] = all(p.pieces is not None for p in got) and not text_cols()
    n = 0 if rows is None else rows.n
    for column in columns:
        column.finish(n)
    return columns, (np.empty(0, np.int64) if rows is None else rows.result())


def _add(
    columns: list[Column], rows: _Grow, parsed: _Parsed, first: int, capacity: int, lay: Layout
) -> None:
    """Add a parsed block (or part) whose first line is line ``first`` to the columns."""
    pieces, line_numbers = parsed.pieces, parsed.line_numbers
    line_numbers += first
    if pieces is None:
        if not parsed.texts:
            return
        pieces = _python_block(parsed.texts, [first + k for k in parsed.numbers], lay)
    for column, piece in zip(columns, pieces, strict=True):
        column.add(piece, line_numbers, capacity, lay.decimal)
    rows.append(line_numbers)

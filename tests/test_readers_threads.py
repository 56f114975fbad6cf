"""Text read on several threads and in parts of blocks reads as one block after another
(issue 15, fast on text).

The blocks of a text file are read, checked and parsed on a few threads, a block in parts
when its parts read as the whole block would; each test compares with reading the blocks
one by one on one thread, or pins the message of the first problem in the file, whichever
thread or part meets it first.
"""

from __future__ import annotations

import numpy as np
import pytest

from adavar.core.errors import AdavarInputError
from adavar.readers import read_record, textscan
from adavar.readers.record import sampling_interval


def write(tmp_path, name, data):
    path = tmp_path / name
    path.write_bytes(data if isinstance(data, bytes) else data.encode("utf-8"))
    return path


def outcome(path, **kwargs):
    """What read_record gives (channels, time, rate, meta, rows) or its error message."""
    try:
        rec = read_record(path, **kwargs)
    except AdavarInputError as exc:
        message = str(exc)
        assert "\n" not in message
        return message
    return (
        {name: (v.dtype.str, v.tobytes()) for name, v in rec.channels.items()},
        None if rec.time is None else rec.time.tobytes(),
        rec.rate,
        rec.t0,
        repr(rec.meta),
        repr(rec.segments),
    )


@pytest.fixture
def blocks(monkeypatch):
    """Set how the text is cut: block bytes, threads, and whether blocks go in parts."""

    def set_up(block, threads, parts=False):
        monkeypatch.setattr(textscan, "HEAD", 8192)  # the rows past it are read in blocks only
        monkeypatch.setattr(textscan, "BLOCK", block)
        monkeypatch.setattr(textscan, "parse_threads", lambda data_bytes: threads)
        monkeypatch.setattr(textscan, "_PROBE", 256 if parts else 1 << 16)
        monkeypatch.setattr(textscan, "_MIN_PART", 16 if parts else 1 << 20)

    return set_up


def _rows(n=1250, seed=0):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n, 3))
    return [f"{k / 100:.2f},{a:.9g},{b:.9g},{c:.9g}" for k, (a, b, c) in enumerate(x)]


def _files():
    """Clean and messy files: each block reads the same whole, in parts, on any thread."""
    rows = _rows()
    files = {"plain.csv": "t,a,b,c\n" + "\n".join(rows) + "\n"}
    messy = list(rows)
    for k in (1100, 750, 450, 150):
        messy.insert(k, "# re-synchronised" if k % 300 else "")
    messy[617] = "6.17,NA,,nan"
    messy[900] = messy[900] + ","  # one trailing separator: dropped
    messy[500] = messy[500].replace(",", ", ")  # blanks after the separators
    files["messy.csv"] = "t,a,b,c\r\n" + "\r\n".join(messy) + "\r\n"
    late = list(rows)
    late[1050] = "10.50,abc,1,2"  # a text cell in a later block: column a is not numeric
    files["late_text.csv"] = "t,a,b,c\n" + "\n".join(late) + "\n"
    ints = [f"{k},{k},{k},{k if k < 850 else k + 0.5}" for k in range(1250)]
    files["int_then_float.csv"] = "t,a,b,c\n" + "\n".join(ints) + "\n"
    base = np.datetime64("2024-05-01T00:00:00", "ms")
    iso = [f"{base + np.timedelta64(10 * k, 'ms')}Z,{k % 7},{-k},OK" for k in range(1250)]
    files["iso.csv"] = "stamp,a,b,status\n" + "\n".join(iso) + "\n"
    commas = [f"{k / 100:.2f}\t{k % 5}.5\t{k}".replace(".", ",") for k in range(1250)]
    files["tabs.tsv"] = "t\ta\tb\n" + "\n".join(commas)  # no line end at the end
    return files


@pytest.mark.parametrize("name", sorted(_files()))
def test_threads_and_parts_read_as_one_block_after_another(tmp_path, blocks, name):
    path = write(tmp_path, name, _files()[name])
    options = [{"nan": "interpolate"}, {"columns": "a", "rate": 100.0}, {"nan": "drop"}]
    blocks(1 << 20, 1)
    expected = [outcome(path, **o) for o in options]
    for block, threads, parts in [(4096, 1, False), (4096, 3, False), (4096, 2, True),
                                  (2048, 3, True), (700, 2, True)]:  # fmt: skip
        blocks(block, threads, parts)
        assert [outcome(path, **o) for o in options] == expected, (block, threads, parts)


def test_parts_of_a_block_are_read_on_threads(tmp_path, blocks, monkeypatch):
    """The parts path is taken (and not only fallen back from) on a plain file."""
    path = write(tmp_path, "plain.csv", _files()["plain.csv"])
    blocks(4096, 2, parts=True)
    seen = []
    in_step = textscan._in_step
    monkeypatch.setattr(textscan, "_in_step", lambda p, t: seen.append(in_step(p, t)) or seen[-1])
    rec = read_record(path)
    assert rec.n_samples == 1250 and rec.rate == 100.0
    assert len(seen) > 5 and all(seen)


def _numbered(n, width=10):
    """n data rows of ``width`` bytes each ("0000,00001\\n"), after the header "a,b\\n"."""
    return b"a,b\n" + b"".join(b"%04d,%0*d\n" % (k % 10000, width - 6, k) for k in range(n))


@pytest.mark.parametrize(("threads", "parts"), [(1, False), (3, False), (2, True)])
def test_the_first_problem_in_the_file_is_raised(tmp_path, blocks, threads, parts):
    blocks(1024, threads, parts)

    def row(k, col=0):  # byte offset of column ``col`` of data row k (rows of 10 bytes)
        return 4 + 10 * k + col

    cases = [
        # a ragged row before a NUL byte several blocks later: the ragged row
        ([(row(300), b"0300,0,30\n"), (row(1500, 3), b"\0")], r"row 302 has 3 fields, expected 2"),
        # invalid UTF-8 in a block and a NUL byte past its last line end, in the rest of its
        # window: the window is checked for NUL bytes first. Block k holds data rows 102 k
        # to 102 k + 101 (1020 bytes), its window 4 bytes of the next row.
        ([(row(1050, 2), b"\xff"), (row(1122, 3), b"\0")], r"row 1124 holds NUL bytes"),
        ([(row(1050, 2), b"\xff")], r"not a UTF-8 text file \(row 1052\)"),
        # invalid UTF-8 late in a later block (in its second part, when in parts)
        ([(row(1700, 1), b"\xc3")], r"not a UTF-8 text file \(row 1702\)"),
        # a short row and a NUL byte in the same later block, the NUL byte after it
        ([(row(1650, 4), b"     "), (row(1690, 3), b"\0")], r"row 1692 holds NUL bytes"),
        ([(row(1650, 4), b"     ")], r"row 1652 has 1 fields, expected 2"),  # "1650     "
    ]
    for k, (edits, message) in enumerate(cases):
        data = bytearray(_numbered(2000))
        for at, new in edits:
            data[at : at + len(new)] = new
        with pytest.raises(AdavarInputError, match=message):
            read_record(write(tmp_path, f"{k}.csv", bytes(data)), rate=1)


@pytest.mark.parametrize("threads", [1, 2])
def test_a_line_longer_than_the_limit_after_good_blocks(tmp_path, blocks, monkeypatch, threads):
    blocks(1024, threads)
    monkeypatch.setattr(textscan, "MAX_LINE", 4096)
    data = _numbered(1000) + b"1," + b"2" * 9000 + b"\n" + _numbered(10)[4:]
    with pytest.raises(AdavarInputError, match=r"row 1002 is longer than"):
        read_record(write(tmp_path, "long.csv", data), rate=1)
    # a NUL byte in that line: the window is checked for NUL bytes first
    data = _numbered(1000) + b"1," + b"2" * 3000 + b"\x00" + b"2" * 6000 + b"\n"
    with pytest.raises(AdavarInputError, match=r"row 1002 holds NUL bytes"):
        read_record(write(tmp_path, "nul.csv", data), rate=1)


def test_jitter_and_interval_from_the_extremes_are_exact():
    """``meta`` figures computed from the extreme intervals equal the array formulas."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(2, 500))
        t = np.cumsum(rng.uniform(0.004, 0.006, n)) + rng.choice([0.0, 1.7e9])
        dt = np.diff(t - t[0])
        step = float(np.median(dt))
        tol = float(rng.uniform(0.05, 0.5))
        resolution = float(rng.choice([0.0, 1e-9, 1e-6]))
        regular = (dt >= (1.0 - tol) * step) & (dt <= (1.0 + tol) * step)
        reg = dt[regular]
        mean = float(np.mean(reg))
        got = sampling_interval(dt, step, tol, resolution)
        if float(np.max(np.abs(reg - mean))) > 4.0 * resolution + 2e-9 * mean:
            assert got == (mean, 1.0 / mean, False)
        lo, hi = float(dt.min()), float(dt.max())
        jitter = max(abs(lo - step), abs(hi - step)) / step
        assert jitter == float(np.max(np.abs(dt - step) / step))

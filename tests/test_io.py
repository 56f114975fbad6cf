"""Tests of adavar.io.text_column: the text reader and the atomic output folder."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from adavar.core.errors import AdavarInputError
from adavar.io.text_column import atomic_directory, check_output_directory, read_text
from adavar.io.writers import OUTPUT_MARKER, write_marker


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# --------------------------------------------------------------------------------------
# Formats
# --------------------------------------------------------------------------------------


def test_csv_with_header_by_name(tmp_path):
    path = write(tmp_path, "a.csv", "time,rate,temp\n0,1.5,20\n1,-2.5e-3,21\n2,3,22\n")
    values, meta = read_text(path, column="rate")
    np.testing.assert_array_equal(values, [1.5, -2.5e-3, 3.0])
    assert values.dtype == np.float64
    assert meta["column"] == "rate"
    assert meta["column_index"] == 1
    assert meta["n_rows"] == 3
    assert meta["columns"] == ["time", "rate", "temp"]
    assert meta["delimiter"] == "comma"
    assert meta["header"] is True
    assert meta["path"] == str(path)


def test_whitespace_separated(tmp_path):
    path = write(tmp_path, "w.txt", "t  x   y\n0 1.0\t2.0\n1   3.0  4.0\n")
    values, meta = read_text(path, column="y")
    np.testing.assert_array_equal(values, [2.0, 4.0])
    assert meta["delimiter"] == "whitespace"


def test_semicolon_separated(tmp_path):
    path = write(tmp_path, "s.csv", "a; b\n1;2\n3;4\n5;6\n")
    values, meta = read_text(path, column="b")
    np.testing.assert_array_equal(values, [2.0, 4.0, 6.0])
    assert meta["delimiter"] == "semicolon"


def test_tab_separated(tmp_path):
    path = write(tmp_path, "t.tsv", "a\tb\n1\t2\n3\t4\n")
    values, meta = read_text(path, column="a")
    np.testing.assert_array_equal(values, [1.0, 3.0])
    assert meta["delimiter"] == "tab"


def test_comments_and_blank_lines_skipped(tmp_path):
    text = "# exported by logger\n% matlab style\n\nx,y\n# mid comment\n1,2\n\n3,4\n"
    values, meta = read_text(write(tmp_path, "c.csv", text), column="y")
    np.testing.assert_array_equal(values, [2.0, 4.0])
    assert meta["n_rows"] == 2


def test_single_column_without_header_needs_no_column(tmp_path):
    values, meta = read_text(write(tmp_path, "one.txt", "1\n2.5\n-3e2\n"))
    np.testing.assert_array_equal(values, [1.0, 2.5, -300.0])
    assert meta["header"] is False
    assert meta["columns"] is None
    assert meta["column"] == "0"


def test_single_column_with_header(tmp_path):
    values, meta = read_text(write(tmp_path, "one.csv", "gyro\n1\n2\n"))
    np.testing.assert_array_equal(values, [1.0, 2.0])
    assert meta["column"] == "gyro"


@pytest.mark.parametrize("column", [1, "1", " 1 "])
def test_column_by_index(tmp_path, column):
    path = write(tmp_path, "n.txt", "1 10\n2 20\n3 30\n")
    values, meta = read_text(path, column=column)
    np.testing.assert_array_equal(values, [10.0, 20.0, 30.0])
    assert meta["column_index"] == 1


def test_index_also_works_with_header(tmp_path):
    values, _ = read_text(write(tmp_path, "h.csv", "a,b\n1,2\n"), column=0)
    np.testing.assert_array_equal(values, [1.0])


def test_case_insensitive_header_match(tmp_path):
    values, meta = read_text(write(tmp_path, "h.csv", "Time,Gyro_X\n1,2\n"), column="gyro_x")
    np.testing.assert_array_equal(values, [2.0])
    assert meta["column"] == "Gyro_X"


def test_quoted_header_and_trailing_delimiter(tmp_path):
    path = write(tmp_path, "q.csv", '"t","rate, deg/s",\n0,1.5,\n1,2.5,\n')
    values, _meta = read_text(path, column="rate, deg/s")
    np.testing.assert_array_equal(values, [1.5, 2.5])


def test_only_numeric_column_is_chosen_next_to_text(tmp_path):
    path = write(tmp_path, "ts.csv", "stamp,rate\n2024-01-01T00:00,1\n2024-01-01T00:01,2\n")
    values, meta = read_text(path)
    np.testing.assert_array_equal(values, [1.0, 2.0])
    assert meta["column"] == "rate"


def test_exact_round_trip_of_repr_floats(tmp_path):
    x = np.random.default_rng(1).standard_normal(500) * 1e-3 + 1e6
    path = tmp_path / "r.csv"
    path.write_text("x\n" + "\n".join(repr(float(v)) for v in x) + "\n")
    values, _ = read_text(path)
    np.testing.assert_array_equal(values, x)


# --------------------------------------------------------------------------------------
# Errors
# --------------------------------------------------------------------------------------


def one_line_error(path, **kwargs) -> str:
    with pytest.raises(AdavarInputError) as info:
        read_text(path, **kwargs)
    message = str(info.value)
    assert "\n" not in message
    return message


def test_missing_file(tmp_path):
    assert "no such file" in one_line_error(tmp_path / "nope.csv")


def test_directory_instead_of_file(tmp_path):
    assert "is a directory" in one_line_error(tmp_path)


@pytest.mark.parametrize("text", ["", "\n\n", "# only a comment\n"])
def test_empty_file(tmp_path, text):
    assert "empty" in one_line_error(write(tmp_path, "e.csv", text))


def test_header_without_data(tmp_path):
    assert "no data rows" in one_line_error(write(tmp_path, "h.csv", "a,b\n"))


def test_several_columns_need_column(tmp_path):
    message = one_line_error(write(tmp_path, "m.csv", "time,x,y\n0,1,2\n1,3,4\n"))
    assert "'time' (0), 'x' (1), 'y' (2)" in message
    assert "--column" in message


def test_unknown_column_lists_available(tmp_path):
    message = one_line_error(write(tmp_path, "m.csv", "time,x\n0,1\n"), column="gyro")
    assert "unknown column 'gyro'" in message
    assert "'time' (0), 'x' (1)" in message


def test_index_out_of_range(tmp_path):
    message = one_line_error(write(tmp_path, "m.txt", "0 1\n2 3\n"), column=5)
    assert "out of range" in message and "0..1" in message


def test_name_without_header(tmp_path):
    message = one_line_error(write(tmp_path, "m.txt", "0 1\n2 3\n"), column="x")
    assert "no header" in message and "0-based index" in message


def test_non_numeric_cell_names_row_and_column(tmp_path):
    text = "# comment\nt,x\n0,1\n1,oops\n2,3\n"
    message = one_line_error(write(tmp_path, "b.csv", text), column="x")
    assert "row 4" in message and "'x'" in message and "'oops'" in message


def test_empty_cell(tmp_path):
    message = one_line_error(write(tmp_path, "b.csv", "t,x\n0,1\n1,\n2,3\n"), column="x")
    assert "row 3" in message and "empty" in message


def test_decimal_comma_is_read_or_explained(tmp_path):
    # semicolon-separated, no decimal point anywhere: the commas are decimal commas
    values, meta = read_text(write(tmp_path, "d.csv", "t;x\n0;1,5\n1;-2,25e-1\n"), column="x")
    np.testing.assert_array_equal(values, [1.5, -0.225])
    assert meta["decimal"] == "comma"
    # decimal points and commas mixed: ambiguous, so not read, and said so
    message = one_line_error(write(tmp_path, "m.csv", "t;x\n0;1,5\n1;2.5\n"), column="x")
    assert "decimal comma" in message and "row 2" in message


@pytest.mark.parametrize("bad", ["nan", "NaN", "inf", "-inf"])
def test_non_finite_names_first_bad_row(tmp_path, bad):
    lines = ["x"] + [str(k) for k in range(15)] + [bad, "1", "nan"]
    message = one_line_error(write(tmp_path, "n.csv", "\n".join(lines) + "\n"))
    assert "row 17 is" in message
    assert "remove or interpolate it" in message


def test_ragged_row(tmp_path):
    message = one_line_error(write(tmp_path, "r.csv", "a,b,c\n1,2,3\n4,5\n"), column="a")
    assert "row 3 has 2 fields, expected 3" in message


# --------------------------------------------------------------------------------------
# Output folders
# --------------------------------------------------------------------------------------


def test_atomic_directory_success(tmp_path):
    out = tmp_path / "out"
    with atomic_directory(out) as tmp:
        assert tmp.parent == tmp_path and tmp != out
        (tmp / "f.txt").write_text("x")
        assert not out.exists()
    assert (out / "f.txt").read_text() == "x"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_atomic_directory_failure_leaves_nothing(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(RuntimeError), atomic_directory(out) as tmp:
        (tmp / "f.txt").write_text("x")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_atomic_directory_refuses_existing_and_replaces_with_flag(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with pytest.raises(AdavarInputError, match="exists already"), atomic_directory(out):
        pass
    assert (out / "old.txt").read_text() == "old"
    # a folder adavar did not write is never replaced (tests/test_output_safety.py)
    with pytest.raises(AdavarInputError, match="not written by adavar"):
        with atomic_directory(out, replace=True):
            pass
    write_marker(out)  # now it is adavar's
    with atomic_directory(out, replace=True) as tmp:
        (tmp / "new.txt").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == [OUTPUT_MARKER, "new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_check_output_directory_errors(tmp_path):
    with pytest.raises(AdavarInputError, match="parent folder"):
        check_output_directory(tmp_path / "missing" / "out")
    (tmp_path / "file").write_text("")
    with pytest.raises(AdavarInputError, match="not a folder"):
        check_output_directory(tmp_path / "file", replace=True)


def test_csv_pieces_cut_anywhere_join_to_the_text(monkeypatch):
    """A CSV made in pieces (rows per piece small here, so many boundaries) is the whole
    text, every row once, whatever the rows per piece; block_rows gives every row."""
    import csv as csv_module
    import io

    from adavar.core import csv_tables
    from adavar.io import writers

    rng = np.random.default_rng(4)
    columns = [rng.standard_normal(1000), np.arange(1000, dtype=np.int64)]
    whole = writers.csv_text(["x", "k"], zip(columns[0].tolist(), columns[1].tolist(),
                                              strict=True))  # fmt: skip
    for per_piece in (1, 7, 999, 1000, 5000):
        monkeypatch.setattr(csv_tables, "CSV_PIECE_ROWS", per_piece)
        pieces = list(writers.csv_pieces(["x", "k"], writers.block_rows(columns, block=64)))
        assert "".join(pieces) == whole
        assert len(pieces) == 1000 // per_piece + 1
    rows = list(csv_module.reader(io.StringIO(whole)))[1:]
    assert [float(r[0]) for r in rows] == columns[0].tolist()
    assert [int(r[1]) for r in rows] == columns[1].tolist()


@pytest.mark.parametrize("per_piece", [1, 3, 64, 1 << 14])
def test_numeric_columns_take_the_text_and_pieces_of_the_row_path(monkeypatch, per_piece):
    """block_rows of numeric columns is written a column at a time: the same text and the
    same pieces as the row-by-row path (csv_cell of every cell), for every numeric dtype
    and odd value; other columns (text, 2-D, unequal lengths) take the row path."""
    from adavar.core import csv_tables

    monkeypatch.setattr(csv_tables, "CSV_PIECE_ROWS", per_piece)
    rng = np.random.default_rng(8)
    n = 200
    x = rng.standard_normal(n) * 10.0 ** rng.integers(-300, 300, n)
    x[::7], x[::11], x[::13], x[::17], x[::19] = np.inf, -0.0, np.nan, -np.inf, 1e16
    columns = [x, rng.standard_normal(n).astype(np.float32), np.arange(n, dtype=np.int32) - 7,
               np.arange(n, dtype=np.uint64) * 2**60, rng.random(n) < 0.5,
               np.round(rng.standard_normal(n), 3)]  # fmt: skip
    names = [f"c{k}" for k in range(len(columns))]
    for cols in (columns, columns[:2], [c[:0] for c in columns], [c[:per_piece] for c in columns]):
        rows = csv_tables.block_rows(cols, block=5)
        assert rows.numeric()
        fast = list(csv_tables.csv_pieces(names[: len(cols)], rows))
        slow = list(csv_tables.csv_pieces(names[: len(cols)], iter(list(
            csv_tables.block_rows(cols, block=5)))))  # fmt: skip
        assert fast == slow
    assert not csv_tables.block_rows([x, x[:-1]]).numeric()
    with pytest.raises(ValueError):
        list(csv_tables.csv_pieces(["a", "b"], csv_tables.block_rows([x, x[:-1]])))
    text = np.array(["=1+1", "a"])
    assert not csv_tables.block_rows([text, x[:2]]).numeric()
    assert "".join(csv_tables.csv_pieces(["t", "x"], csv_tables.block_rows([text, x[:2]]))) == (
        f"t,x\n'=1+1,{float(x[0])!r}\na,{float(x[1])!r}\n"
    )


_CELLS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**20), 10**20),
    st.none(),
    st.booleans(),
    st.text(alphabet=st.sampled_from(list('ab ,"\r\n=+-@\t1.e')), max_size=8),
)


@settings(max_examples=300, deadline=None)
@given(rows=st.lists(st.lists(_CELLS, min_size=1, max_size=4), min_size=1, max_size=6))
def test_csv_rows_are_the_csv_modules_rows(rows):
    """Rows written without the csv module (nothing to quote) and with it (text that
    needs quotes) are, line for line, the csv module's, and read back as the cells."""
    import csv as csv_module
    import io

    from adavar.io import writers

    width = max(len(r) for r in rows)
    rows = [r + [None] * (width - len(r)) for r in rows]
    columns = [f"c{k}" for k in range(width)]
    text = writers.csv_text(columns, rows)
    line = io.StringIO()
    writer = csv_module.writer(line, lineterminator="\r\n")
    want = []
    for cells in [columns, *rows]:
        line.seek(0)
        line.truncate()
        writer.writerow(cells if cells is columns else [writers.csv_cell(c) for c in cells])
        want.append(line.getvalue()[:-2] + "\n")
    assert text == "".join(want)
    back = list(csv_module.reader(io.StringIO(text, newline="")))[1:]
    assert back == [[writers.csv_cell(c) for c in r] for r in rows]

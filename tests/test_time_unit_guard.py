"""The unit of a time column is never guessed, and the time column is never data.

A time column of no declared unit is read in seconds only when its median step says so:
a few fractional or jittery stamps (or float-rounded milliseconds) no longer slip past the
guard. A unit written in the column's name that contradicts ``--time-format`` is an error,
and so is asking for the time column as a channel (``--time-column none`` reads it as data).
"""

from __future__ import annotations

import numpy as np
import pytest

from adavar.core.errors import AdavarInputError
from adavar.readers import read_record

from .cli_helpers import assert_one_line_error, run

N = 2000
GX = np.random.default_rng(7).standard_normal(N)


def write(tmp_path, name, header, stamps, fmt=repr):
    """A CSV of ``header`` (time name, then gx) with ``stamps`` and white noise."""
    text = (
        header
        + "\n"
        + "".join(f"{fmt(float(t))},{g:.6f}\n" for t, g in zip(stamps, GX, strict=True))
    )
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def avar(path, *extra):
    return ["avar", str(path), "--units", "deg/s", *extra]


def fails(match, path, **kwargs):
    """read_record raises AdavarInputError, one line, matching ``match``."""
    with pytest.raises(AdavarInputError, match=match) as info:
        read_record(path, **kwargs)
    message = str(info.value)
    assert "\n" not in message
    return message


UNCLEAR = ("so its unit is unclear (0.1 Hz if they are seconds, 100 Hz if milliseconds)",
           "time_format 's', 'ms', 'us' or 'ns' (--time-format)", "time_ms")  # fmt: skip


# --------------------------------------------------------------------------------------
# Bug 1: the guard judges the median step, not whether every stamp is whole
# --------------------------------------------------------------------------------------


def one_fraction(tmp_path):
    t = np.arange(N) * 10.0
    t[N // 4] += 0.5
    return write(tmp_path, "tms_one.csv", "time,gx", t, fmt=lambda a: f"{a:.1f}")


def test_one_fractional_stamp_does_not_defeat_the_guard(capsys, tmp_path):
    path = one_fraction(tmp_path)
    code, out, err = run(capsys, avar(path))
    assert_one_line_error(code, out, err, "time column 'time'", "10 apart", *UNCLEAR)
    message = fails("10 apart", path)
    assert all(f in message for f in UNCLEAR)
    # the way out: its unit
    code, out, _ = run(capsys, avar(path, "--time-format", "ms"))
    assert code == 0 and "(100 Hz)" in out
    assert read_record(path, time_format="ms").rate == pytest.approx(100.0)


def test_float_millisecond_stamps_need_their_unit(capsys, tmp_path):
    # k / 100 * 1000 is 30.000000000000004 for k = 3: not whole numbers
    path = write(tmp_path, "tms_float.csv", "time,gx", np.arange(N) / 100 * 1000)
    code, out, err = run(capsys, avar(path))
    assert_one_line_error(code, out, err, "10 apart", *UNCLEAR)
    fails("10 apart", path)
    assert read_record(path, time_format="ms").rate == pytest.approx(100.0)


def test_jittery_millisecond_stamps_need_their_unit(capsys, tmp_path):
    jitter = np.random.default_rng(3).uniform(-0.2, 0.2, N)
    path = write(tmp_path, "jitter.csv", "t,gx", np.arange(N) * 10.0 + jitter)
    code, out, err = run(capsys, avar(path))
    assert_one_line_error(code, out, err, "time column 't'", "apart (the median interval)",
                          "--time-format", "t_ms")  # fmt: skip


def test_float_millisecond_parquet_needs_its_unit(capsys, tmp_path):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    path = tmp_path / "tms.parquet"
    pq.write_table(pa.table({"time": np.arange(N) / 100 * 1000, "gx": GX}), path)
    code, out, err = run(capsys, avar(path))
    assert_one_line_error(code, out, err, "time column 'time'", *UNCLEAR)
    fails("10 apart", path)
    assert read_record(path, time_format="ms").rate == pytest.approx(100.0)


def test_whole_milliseconds_keep_their_message(capsys, tmp_path):
    path = write(tmp_path, "int.csv", "time,gx", np.arange(N) * 10, fmt=lambda a: f"{a:.0f}")
    code, out, err = run(capsys, avar(path))
    assert_one_line_error(code, out, err, "holds whole numbers 10 apart", *UNCLEAR)


def test_seconds_at_100_hz_are_read(capsys, tmp_path):
    path = write(tmp_path, "s100.csv", "time,gx", np.arange(N) / 100)
    code, out, _ = run(capsys, avar(path))
    assert code == 0 and "tau0 = 0.01 s (100 Hz)" in out
    rec = read_record(path)
    assert rec.rate == 100.0 and rec.meta["time_unit_source"].startswith("assumed")


@pytest.mark.parametrize(
    "stamps",
    [np.arange(N, dtype=float), 1_700_000_000 + np.arange(N, dtype=float),
     np.arange(N) + np.random.default_rng(5).uniform(-1e-4, 1e-4, N)],
    ids=["whole", "epoch", "jittery"],
)  # fmt: skip
def test_clock_stamps_one_second_apart_are_read(capsys, tmp_path, stamps):
    # NIST-style phase data at tau0 = 1 s, stamped in seconds 0, 1, 2, ...
    path = write(tmp_path, "clock.csv", "time,phase", stamps, fmt=lambda a: f"{a:.6f}")
    code, out, _ = run(capsys, ["avar", str(path), "--data-type", "phase", "--units", "s"])
    assert code == 0 and "(1 Hz)" in out, out
    assert read_record(path).rate == pytest.approx(1.0)


def test_a_clock_ten_seconds_apart_names_its_way_out(capsys, tmp_path):
    path = write(tmp_path, "clock10.csv", "time,gx", np.arange(N) * 10.0)
    code, out, err = run(capsys, avar(path))
    assert_one_line_error(code, out, err, *UNCLEAR)
    code, out, _ = run(capsys, avar(path, "--time-format", "s"))
    assert code == 0 and "tau0 = 10 s (0.1 Hz)" in out
    assert read_record(path, time_format="s").rate == pytest.approx(0.1)
    named = write(tmp_path, "clock10_s.csv", "time_s,gx", np.arange(N) * 10.0)
    assert read_record(named).rate == pytest.approx(0.1)  # the unit in the name


# --------------------------------------------------------------------------------------
# Bug 2: --time-format contradicting the unit in the column name
# --------------------------------------------------------------------------------------


def ms_header(tmp_path):
    return write(tmp_path, "hdr_ms.csv", "time_ms,gx", np.arange(N) * 10, fmt=lambda a: f"{a:.0f}")


def ns_header(tmp_path):
    ns = 1_700_000_000_000_000_000 + np.arange(N, dtype=np.int64) * 10_000_000
    text = "t_ns,gx\n" + "".join(f"{t},{g:.6f}\n" for t, g in zip(ns.tolist(), GX, strict=True))
    path = tmp_path / "hdr_ns.csv"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("make", "flag", "named"), [(ms_header, "s", "ms"), (ns_header, "us", "ns")],
    ids=["ms-as-s", "ns-as-us"],
)  # fmt: skip
def test_time_format_contradicting_the_header_is_an_error(capsys, tmp_path, make, flag, named):
    path = make(tmp_path)
    code, out, err = run(capsys, avar(path, "--time-format", flag))
    assert_one_line_error(code, out, err, f"--time-format {flag}", "contradicts",
                          f"({named})", "leave out --time-format")  # fmt: skip
    message = fails("contradicts", path, time_format=flag)
    assert f"time_format {flag!r}" in message


@pytest.mark.parametrize(("make", "flag"), [(ms_header, "ms"), (ns_header, "ns")])
def test_time_format_agreeing_with_the_header_is_fine(capsys, tmp_path, make, flag):
    path = make(tmp_path)
    for extra in ([], ["--time-format", flag]):
        code, out, _ = run(capsys, avar(path, *extra))
        assert code == 0 and "tau0 = 0.01 s (100 Hz)" in out
    assert read_record(path, time_format=flag).rate == pytest.approx(100.0)


# --------------------------------------------------------------------------------------
# Bug 3: the time column asked for as a channel
# --------------------------------------------------------------------------------------


@pytest.fixture
def multi(tmp_path):
    path = tmp_path / "multi.csv"
    text = "time,gx,gy\n" + "".join(
        f"{k / 100!r},{g:.6f},{-g:.6f}\n" for k, g in enumerate(GX.tolist())
    )
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(
    "extra", [["--column", "time,gx", "--rate", "50"], ["--column", "time"],
              ["--column", "gx,time"], ["--column", "0"]],
    ids=["with-rate", "alone", "second", "by-index"],
)  # fmt: skip
def test_the_time_column_as_a_channel_is_an_error(capsys, multi, extra):
    code, out, err = run(capsys, avar(multi, *extra))
    assert_one_line_error(code, out, err, "column 'time' of", "is the time column",
                          "--time-column none")  # fmt: skip
    fails("is the time column", multi, columns=extra[1])


def test_the_rate_is_still_checked_against_the_stamps(capsys, multi):
    code, out, err = run(capsys, avar(multi, "--column", "gx", "--rate", "50"))
    assert_one_line_error(code, out, err, "disagrees with the time stamps")
    code, out, _ = run(capsys, avar(multi, "--column", "gx,gy"))
    assert code == 0 and out.count("tau0 = 0.01 s (100 Hz)") == 2


def test_time_column_none_analyses_the_stamps_as_data(capsys, multi):
    code, out, _ = run(capsys, avar(multi, "--column", "time", "--time-column", "none",
                                    "--rate", "100"))  # fmt: skip
    assert code == 0 and "column 'time'" in out and "(100 Hz)" in out
    code, out, err = run(capsys, avar(multi, "--column", "time", "--time-column", "none"))
    assert_one_line_error(code, out, err, "has no time column", "--rate HZ")
    rec = read_record(multi, columns="time", time_column="none", rate=100)
    assert rec.names == ["time"] and rec.time is None and rec.rate == 100.0
    np.testing.assert_allclose(rec.channel("time"), np.arange(N) / 100)
    # every numeric column, the stamps among them
    assert read_record(multi, time_column="None", rate=100).names == ["time", "gx", "gy"]


def test_an_explicit_time_column_leaves_a_time_named_channel_alone(tmp_path):
    stamps = np.arange(N) / 100
    text = "stamp,time,gx\n" + "".join(
        f"{s!r},{k},{g:.6f}\n" for k, (s, g) in enumerate(zip(stamps.tolist(), GX, strict=True))
    )
    path = tmp_path / "two.csv"
    path.write_text(text, encoding="utf-8")
    rec = read_record(path, columns="time,gx", time_column="stamp")
    assert rec.names == ["time", "gx"] and rec.rate == pytest.approx(100.0)


def test_time_column_none_reads_parquet_piece_by_piece(tmp_path):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    path = tmp_path / "lazy.parquet"
    pq.write_table(pa.table({"time": np.arange(N) / 100, "gx": GX}), path)
    rec = read_record(path, time_column="none", rate=100, lazy=True)
    assert rec.names == ["time", "gx"] and rec.time is None
    np.testing.assert_allclose(np.asarray(rec.channel("gx")), GX)
    with pytest.raises(AdavarInputError, match="cannot be read piece by piece"):
        read_record(path, lazy=True)  # a time column still needs every stamp in memory

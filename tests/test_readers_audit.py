"""Files that used to give a wrong number with exit 0 (an independent audit of the readers):
two columns named like time, an array stored channels x samples, HDF5 values packed with a
``scale_factor``, a unit written in a column's name or a Parquet field's metadata, and
Modified Julian Days in a column called ``time``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from adavar.core.errors import AdavarInputError
from adavar.readers.dispatch import read_record

from .cli_helpers import run


@pytest.fixture
def samples():
    return np.random.default_rng(4).standard_normal(20_000) * 0.05


def test_two_columns_named_like_time_are_an_error_not_the_first_one(tmp_path, samples):
    # 'T' (a temperature rising 0.0005 a row) was read as the time: 2000 Hz, silently
    t = np.arange(samples.size) / 100.0
    path = tmp_path / "tt.csv"
    np.savetxt(path, np.c_[20.0 + 0.0005 * np.arange(samples.size), t, samples], delimiter=",",
               header="T,time,gx", comments="", fmt="%.6f")  # fmt: skip
    with pytest.raises(AdavarInputError, match=r"several columns named like time stamps"):
        read_record(path, columns="gx")
    assert read_record(path, columns="gx", time_column="time").rate == pytest.approx(100.0)
    assert read_record(path, columns="T").rate == pytest.approx(100.0)  # the other is data


def test_an_array_stored_channels_by_samples_is_an_error(tmp_path, samples):
    path = tmp_path / "wide.npy"
    np.save(path, np.stack([samples] * 7))  # (7, 20000): was read as 7 samples
    with pytest.raises(AdavarInputError, match=r"shape \(7, 20000\).*transpose"):
        read_record(path, columns=1, rate=100.0)
    np.save(path, np.stack([samples] * 7).T)
    assert read_record(path, columns=1, rate=100.0).channel().size == samples.size


def test_hdf5_values_packed_with_a_scale_factor_are_unpacked(tmp_path, samples):
    h5py = pytest.importorskip("h5py")
    path = tmp_path / "packed.h5"
    with h5py.File(path, "w") as f:
        d = f.create_dataset("gx", data=np.round(samples / 0.001).astype(np.int16))
        d.attrs["scale_factor"] = 0.001
        d.attrs["add_offset"] = 0.25
        d.attrs["units"] = "deg/s"
    rec = read_record(path, rate=100.0)
    want = np.round(samples / 0.001).astype(np.int16) * 0.001 + 0.25
    np.testing.assert_allclose(rec.channel(), want, rtol=1e-15)
    with pytest.raises(AdavarInputError, match=r"packed \(scale_factor, add_offset\)"):
        read_record(path, rate=100.0, lazy=True)


def test_a_unit_in_a_column_name_or_a_parquet_field_is_checked(capsys, tmp_path, samples):
    path = tmp_path / "named.csv"
    t = np.arange(samples.size) / 100.0
    np.savetxt(path, np.c_[t, samples], delimiter=",", header="time,gx [rad/s]",
               comments="", fmt="%.6f")  # fmt: skip
    code, out, err = run(capsys, ["avar", str(path), "--column", "gx [rad/s]", "--units",
                                  "deg/s"])  # fmt: skip
    assert code == 2 and out == "" and "declares channel 'gx [rad/s]' in rad/s" in err
    code, out, _ = run(capsys, ["avar", str(path), "--column", "gx [rad/s]", "--json"])
    assert code == 0 and '"rad/s"' in out
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    field = pa.field("gx", pa.float64(), metadata={"units": "rad/s"})
    schema = pa.schema([pa.field("time", pa.float64()), field])
    table = pa.Table.from_arrays([pa.array(t), pa.array(samples)], schema=schema)
    pq.write_table(table, tmp_path / "f.parquet")
    code, out, err = run(capsys, ["avar", str(tmp_path / "f.parquet"), "--column", "gx",
                                  "--units", "deg/s"])  # fmt: skip
    assert code == 2 and "declares channel 'gx' in rad/s" in err


def test_modified_julian_days_in_a_column_called_time_ask_for_their_unit(tmp_path, samples):
    path = tmp_path / "mjd.csv"
    days = 60374.5 + np.arange(samples.size) / (100.0 * 86400.0)
    np.savetxt(path, np.c_[days, samples], delimiter=",", header="time,gx", comments="",
               fmt=["%.12f", "%.6f"])  # fmt: skip
    with pytest.raises(AdavarInputError, match=r"as Modified Julian Days 100(\.\d+)? Hz"):
        read_record(path, columns="gx")
    assert read_record(path, columns="gx", time_format="mjd").rate == pytest.approx(100.0, rel=1e-4)


def test_decimal_commas_without_a_header_are_an_error(tmp_path, samples):
    path = tmp_path / "dc.txt"
    path.write_text("\n".join(f"{v:.6f}".replace(".", ",") for v in samples[:2000]) + "\n")
    with pytest.raises(AdavarInputError, match="decimal commas split in two"):
        read_record(path, columns=1, rate=100.0)
    # zero-padded integers are integers
    padded = tmp_path / "padded.csv"
    padded.write_text("\n".join(f"{i % 997:04d},{(7 * i) % 991:04d}" for i in range(2000)) + "\n")
    assert read_record(padded, columns=1, rate=100.0).channel()[3] == 21.0


def test_a_header_with_numbers_for_names_is_the_header(tmp_path, samples):
    # 'time,100,200' was read as a data row (two of three cells numbers): n + 1 samples
    t = np.arange(samples.size) / 100.0
    path = tmp_path / "numhdr.csv"
    np.savetxt(path, np.c_[t, samples, samples[::-1]], delimiter=",", header="time,100,200",
               comments="", fmt="%.6f")  # fmt: skip
    rec = read_record(path, columns="100")
    assert rec.rate == pytest.approx(100.0) and rec.channel().size == samples.size
    np.testing.assert_array_equal(rec.channel(), np.round(samples, 6))
    # 'time,2,1': is column '1' the one so named or the second? Neither, silently
    np.savetxt(path, np.c_[t, samples, samples[::-1]], delimiter=",", header="time,2,1",
               comments="", fmt="%.6f")  # fmt: skip
    with pytest.raises(AdavarInputError, match="both a column's name and the index of another"):
        read_record(path, columns="1")
    assert read_record(path, columns=1).names == ["2"]


@pytest.mark.parametrize(
    ("lines", "fragment"),
    [
        # a repeated header (files joined): not "column 'gx' is not numeric"
        (["time,gx", "0.00,1.5", "0.01,2.5", "time,gx", "0.02,1.0", "0.03,0.5"],
         "row 4 repeats the header"),
        # quoted decimal commas in a comma-separated file: say so
        (['"time","gx"', '"0,00","1,5"', '"0,01","2,5"', '"0,02","0,5"'], "decimal commas"),
        # a time column in a format adavar does not read: not "has no time column"
        (["time,gx", "03/05/2024 12:00:00.00,1.5", "03/05/2024 12:00:00.01,2.5",
          "03/05/2024 12:00:00.02,0.5"], "named like time stamps but holds neither"),
    ],
)  # fmt: skip
def test_messages_name_the_real_problem(tmp_path, lines, fragment):
    path = tmp_path / "m.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(AdavarInputError, match=fragment):
        read_record(path, columns="gx")


def test_a_split_piece_says_where_its_times_start(capsys, tmp_path):
    # --gaps split: the second piece's warning gave times from its own start (485 s for a
    # change at 1495 s in the file) without saying so
    rng = np.random.default_rng(5)
    t = np.arange(300_000) / 100.0
    x = rng.standard_normal(t.size) * np.where((t > 1500) & (t < 2100), 2.0, 1.0)
    keep = ~((t >= 1000) & (t < 1010))
    path = tmp_path / "gap.csv"
    np.savetxt(path, np.c_[t[keep], x[keep]], delimiter=",", header="time,gx", comments="",
               fmt=["%.2f", "%.6f"])  # fmt: skip
    code, out, err = run(capsys, ["avar", str(path), "--column", "gx", "--units", "deg/s",
                                  "--gaps", "split", "--json"])  # fmt: skip
    assert code == 0, err
    pieces = json.loads(out)["channels"]
    assert pieces["gx piece 2"]["input"]["piece_start_s"] == pytest.approx(1010.0)
    assert "(times from its first sample, 1010 s after the file's first)" in err

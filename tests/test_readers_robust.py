"""Nothing lost, nothing silently wrong (issue 14) and fast, streamed text input (issue 15).

Every test here fails on the reader before these changes: declared units overridden
silently, time units and rates guessed, binary files and long fields ending as internal
errors, decimal commas refused, text read whole.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from adavar.core.errors import AdavarInputError
from adavar.io.text_column import read_text
from adavar.readers import Record, read_record, textscan
from tests.cli_helpers import assert_one_line_error, run


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def fails(match, path, **kwargs):
    """read_record raises AdavarInputError, one line, matching ``match``."""
    with pytest.raises(AdavarInputError, match=match) as info:
        read_record(path, **kwargs)
    message = str(info.value)
    assert "\n" not in message and message.strip() == message
    return message


# --------------------------------------------------------------------------------------
# Item 3: units declared by the file win over a contradicting --units
# --------------------------------------------------------------------------------------


def _record(units):
    channels = {name: np.zeros(4) for name in units}
    return Record(channels, 100.0, source="imu.bag", kind="ros2", meta={"units": units})


def test_units_given_must_agree_with_the_declared_ones():
    rec = _record({"gx": "rad/s", "gy": "rad/s"})
    assert rec.units_of(None) == {"gx": "rad/s", "gy": "rad/s"}
    assert rec.units_of("rad/s") == {"gx": "rad/s", "gy": "rad/s"}
    with pytest.raises(AdavarInputError, match=r"--units deg/s contradicts imu\.bag") as info:
        rec.units_of("deg/s")
    message = str(info.value)
    assert "declares channel 'gx' in rad/s" in message
    assert "leave out --units, or give --units rad/s" in message
    # a unit of another quantity: said so
    with pytest.raises(AdavarInputError, match=r"m/s\^2 is an acceleration, rad/s an angular"):
        rec.units_of("m/s^2")
    # a free label is no unit of rad/s data either
    with pytest.raises(AdavarInputError, match="contradicts"):
        rec.units_of("mV")


def test_units_of_an_accelerometer_channel_and_mixed_channels():
    acc = _record({"ax": "m/s^2"})
    with pytest.raises(AdavarInputError, match=r"deg/s is an angular rate, m/s\^2 an accel"):
        acc.units_of("deg/s")
    mixed = _record({"gx": "rad/s", "ax": "m/s^2"})
    with pytest.raises(AdavarInputError, match=r"leave out --units \(the file declares gx in"):
        mixed.units_of("rad/s")
    # a declared unit adavar does not know is a label: --units may name it in adavar's terms
    assert _record({"x": "radians per second"}).units_of("rad/s") == {"x": "rad/s"}


def _bag(tmp_path):
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    from tests.test_readers import _imu_messages

    store = get_typestore(Stores.ROS2_HUMBLE)
    bag = tmp_path / "bag"
    with Writer(bag, version=9) as writer:
        imu = writer.add_connection("/imu", "sensor_msgs/msg/Imu", typestore=store)
        for ns, msg in _imu_messages(store, 400, 200.0):
            writer.write(imu, ns, store.serialize_cdr(msg, "sensor_msgs/msg/Imu"))
    return bag


def test_ros_bag_units_flag_contradicting_the_bag_is_an_error(tmp_path, capsys):
    from adavar.core.request import RecordRequest
    from adavar.pipeline.analysis import read_input

    bag = _bag(tmp_path)
    with pytest.raises(AdavarInputError, match=r"--units deg/s contradicts .* in rad/s"):
        read_input(RecordRequest(str(bag), column="gx", units="deg/s"))
    loaded = read_input(RecordRequest(str(bag), column="gx"))
    assert loaded.units == {"gx": "rad/s"} and loaded.tau0 == 1 / 200.0
    code, out, err = run(capsys, ["avar", str(bag), "--column", "az", "--units", "deg/s"])
    assert_one_line_error(code, out, err, "contradicts", "'az' in m/s^2", "leave out --units")


def test_kalibr_units_contradicting_the_bag_are_an_error(tmp_path, capsys):
    bag = _bag(tmp_path)
    argv = ["kalibr", str(bag), "--gyro", "gx,gy,gz", "--accel", "ax,ay,az",
            "-o", str(tmp_path / "imu.yaml")]  # fmt: skip
    code, out, err = run(capsys, [*argv, "--gyro-units", "deg/s"])
    assert_one_line_error(code, out, err, "--gyro-units deg/s contradicts", "in rad/s",
                          "leave out --gyro-units")  # fmt: skip
    code, out, err = run(capsys, [*argv, "--accel-units", "deg/s"])
    assert_one_line_error(code, out, err, "--accel-units deg/s contradicts", "m/s^2")
    assert not (tmp_path / "imu.yaml").exists()


# --------------------------------------------------------------------------------------
# Item 7: the time unit and the rate are never guessed
# --------------------------------------------------------------------------------------


def test_integer_milliseconds_in_a_time_column_need_their_unit(tmp_path):
    text = "time,gx\n" + "".join(f"{5 * i},{np.sin(i):.6f}\n" for i in range(400))
    path = write(tmp_path, "ms.csv", text)
    message = fails(r"whole numbers 5 apart, so its unit is unclear \(0\.2 Hz if they", path)
    assert "200 Hz if milliseconds" in message
    assert "time_format 's', 'ms', 'us' or 'ns' (--time-format)" in message
    assert "time_ms" in message
    assert read_record(path, time_format="ms").rate == 200.0
    assert read_record(path, time_format="s").rate == 0.2  # declared: read as told
    named = write(tmp_path, "named.csv", text.replace("time,", "time_ms,"))
    assert read_record(named).rate == 200.0
    # whole seconds one apart are seconds (1 Hz), as before
    assert read_record(write(tmp_path, "s.csv", "t,x\n0,1\n1,2\n2,3\n")).rate == 1.0


def test_epoch_seconds_give_the_nominal_rate(tmp_path):
    stamps = 1_700_000_000 + np.arange(2000) / 200.0
    text = "timestamp,gx\n" + "".join(f"{s:.3f},{0.1 * k}\n" for k, s in enumerate(stamps))
    rec = read_record(write(tmp_path, "epoch.csv", text))
    assert rec.rate == 200.0  # exactly, not 199.995 from the float-rounded median
    assert rec.meta["rate_source"].startswith("nominal rate")
    assert rec.t0 == pytest.approx(1.7e9)
    # also through a declared rate: it agrees
    assert read_record(write(tmp_path, "e2.csv", text), rate=200).rate == 200.0


def test_a_clock_off_its_nominal_rate_is_not_snapped(tmp_path):
    # a clock 6.85 ppm fast, stamped in integer nanoseconds: every interval is within 1 ns
    # of 1/200 s, but their mean shows the drift
    true = 200.00137
    ns = 1_700_000_000 * 10**9 + np.round(np.arange(5000) * 1e9 / true).astype(np.int64)
    text = "stamp_ns,x\n" + "".join(f"{v},{k % 7}\n" for k, v in enumerate(ns))
    rec = read_record(write(tmp_path, "drift.csv", text))
    assert rec.rate == pytest.approx(true, rel=1e-9)
    assert rec.meta["rate_source"] == "mean time interval (gaps excluded)"
    # a nominal rate is any round value the stamps bear out exactly, 200.01 Hz too
    ns = np.round(np.arange(5000) * 1e9 / 200.01).astype(np.int64)
    text = "stamp_ns,x\n" + "".join(f"{v},{k % 7}\n" for k, v in enumerate(ns))
    assert read_record(write(tmp_path, "nominal.csv", text)).rate == 200.01


def test_stamps_rounded_to_microseconds_give_the_mean_rate(tmp_path):
    t = np.arange(3000) / 3000.0  # 3 kHz, written with 6 decimals: 333 or 334 us apart
    text = "t,x\n" + "".join(f"{v:.6f},{k}\n" for k, v in enumerate(t))
    rec = read_record(write(tmp_path, "khz.csv", text))
    assert rec.rate == pytest.approx(3000.0, rel=1e-6)  # the median said 3003 Hz


def test_jittered_stamps_and_gaps(tmp_path):
    rng = np.random.default_rng(7)
    t = np.arange(4000) * 0.01 + rng.uniform(-1e-4, 1e-4, 4000)
    t[2000:] += 0.5  # a gap
    text = "t,x\n" + "".join(f"{v:.7f},{k}\n" for k, v in enumerate(t))
    rec = read_record(write(tmp_path, "jit.csv", text), gaps="split")
    assert rec.rate == pytest.approx(100.0, rel=1e-4)
    assert rec.meta["rate_source"] == "mean time interval (gaps excluded)"
    assert [len(p) for p in rec.pieces("x")] == [2000, 2000]


# --------------------------------------------------------------------------------------
# Item 8: binary data, streamed text
# --------------------------------------------------------------------------------------


def test_a_file_of_nul_bytes_is_not_text(tmp_path):
    (tmp_path / "zeros.csv").write_bytes(b"\x00" * 100_000)
    message = fails(r"is not a text file \(NUL bytes in its first kilobytes\)",
                    tmp_path / "zeros.csv")  # fmt: skip
    assert ".npy" in message and ".parquet" in message and "CSV" in message
    with pytest.raises(AdavarInputError, match="not a text file"):
        read_text(tmp_path / "zeros.csv")


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (b"\x1f\x8b\x08\x00garbage", "gzip-compressed file: decompress it"),
        (b"PK\x03\x04\x14\x00\x06\x00", r"ZIP archive \(an Excel workbook\?\)"),
        (b"\x89HDF\r\n\x1a\n\x00\x00", r"HDF5 file: rename it to \.h5"),
        ("t,x\n0,1\n".encode("utf-16"), r"not a UTF-8 text file \(it is UTF-16 text\)"),
        (bytes(range(1, 9)) * 500, r"not a text file \(binary bytes"),
        (b"t,x\r0,1\r1,2\r", "ends its lines with CR only"),
    ],
)
def test_binary_and_foreign_files(tmp_path, data, match):
    (tmp_path / "f.csv").write_bytes(data)
    fails(match, tmp_path / "f.csv")


def test_garbage_after_a_valid_header(tmp_path, monkeypatch):
    good = "".join(f"{k / 100},{k}\n" for k in range(3000)).encode()  # past the first 8 KiB
    (tmp_path / "nul.csv").write_bytes(b"t,x\n" + good + b"\x00" * 50_000)
    fails(r"nul\.csv: row 3002 holds NUL bytes \(binary data, not text\): give CSV",
          tmp_path / "nul.csv")  # fmt: skip
    junk = bytes(np.random.default_rng(1).integers(128, 256, 5000, dtype=np.uint8))
    (tmp_path / "junk.csv").write_bytes(b"t,x\n" + good + b"1,2\n" + junk)
    fails(r"not a UTF-8 text file \(row 3003\)", tmp_path / "junk.csv")
    monkeypatch.setattr(textscan, "BLOCK", 256)  # found in a later block, too
    fails(r"row 3002 holds NUL bytes", tmp_path / "nul.csv")
    fails(r"not a UTF-8 text file \(row 3003\)", tmp_path / "junk.csv")
    # a 1 GiB file of NUL bytes is refused from its first block, never read whole
    monkeypatch.setattr(textscan, "BLOCK", 1 << 20)
    (tmp_path / "pad.csv").write_bytes(b"t,x\n" + good + b"\x00" * (4 << 20))
    fails(r"row 3002 holds NUL bytes", tmp_path / "pad.csv")


def _messy_text(n=3000):
    """A CSV with a preamble comment, comments and blank lines among the rows, CRLF line
    ends, NaN and NA cells, an ISO column and a text column."""
    base = np.datetime64("2024-05-01T00:00:00", "ms")
    lines = ["# logger 3.1, 100 Hz", "stamp,gx,gy,status,temp"]
    for k in range(n):
        if k % 700 == 350:
            lines.append("# re-synchronised")
        if k % 900 == 450:
            lines.append("")
        gy = "NA" if k == 1234 else f"{-0.5 * k:.1f}"
        lines.append(f"{base + np.timedelta64(10 * k, 'ms')}Z,{0.01 * k:.4f},{gy},OK,{20 + k % 3}")
    return "\r\n".join(lines) + "\r\n"


@pytest.mark.parametrize("block", [200, 4096, 1 << 20])
def test_streamed_blocks_read_the_same_as_one_block(tmp_path, monkeypatch, block):
    # blocks of a few lines: 1500 rows (750 blocks) hold every oddity of the text already
    n = 1500 if block < 1000 else 3000
    path = write(tmp_path, "messy.csv", _messy_text(n))
    monkeypatch.setattr(textscan, "BLOCK", block)
    message = fails(r"column 'gy' is NaN or empty", path)
    # data row 1234 is file line 3 + 1234, after two comment lines and one blank line
    assert "row 1240," in message
    rec = read_record(path, nan="interpolate")
    assert rec.names == ["gx", "gy", "temp"]
    assert rec.rate == 100.0 and rec.n_samples == n
    np.testing.assert_allclose(rec.channel("gx"), 0.01 * np.arange(n), atol=1e-12)
    np.testing.assert_allclose(rec.channel("gy"), -0.5 * np.arange(n), atol=1e-9)
    assert rec.meta["nan_values_interpolated"] == {"gy": 1}
    fails(r"column 'status' of .* is not numeric \(row 3: 'OK'\)", path, columns="status")


def test_without_pandas_the_numpy_path_reads_the_same(tmp_path, monkeypatch):
    path = write(tmp_path, "messy.csv", _messy_text(800))
    expected = read_record(path, nan="interpolate")
    monkeypatch.setattr(textscan, "_pandas", lambda: None)
    got = read_record(path, nan="interpolate")
    for name in expected.names:
        np.testing.assert_array_equal(got.channel(name), expected.channel(name))
    assert got.rate == expected.rate and got.meta == expected.meta
    fails(r"row 4 has 1 fields, expected 2", write(tmp_path, "r.csv", "a,b\n1,2\n3,4\n5\n"))


def test_plain_and_commented_blocks_go_through_the_c_parser(tmp_path, monkeypatch):
    def python_path(*args, **kwargs):
        raise AssertionError("the Python path parsed a block")

    text = _messy_text(2000)
    monkeypatch.setattr(textscan, "_python_block", python_path)
    monkeypatch.setattr(textscan, "BLOCK", 8192)
    rec = read_record(write(tmp_path, "m.csv", text), nan="drop", gaps="interpolate")
    assert rec.n_samples == 2000


def test_blanks_after_separators_and_quoted_numbers(tmp_path, monkeypatch):
    rows = [f"{k / 10},{k}" for k in range(300)]
    rows[100] = '10.0, "100"'  # far from the lines sampled for the layout
    rows[150] = "15.0, NA"
    path = write(tmp_path, "q.csv", "t,x\n" + "\n".join(rows) + "\n")
    for block in (1 << 20, 64):
        monkeypatch.setattr(textscan, "BLOCK", block)
        rec = read_record(path, nan="interpolate")
        np.testing.assert_array_equal(rec.channel("x"), np.arange(300))
    spaced = write(tmp_path, "s.csv", 't, x\n0, "1"\n0.5 , NA\n1.0,  3\n')
    np.testing.assert_array_equal(read_record(spaced, nan="interpolate").channel(), [1, 2, 3])


@pytest.mark.parametrize("block", [4, 1 << 20])  # 4 bytes: each row starts a block
@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("a,b\n1,2\n3,4,5\n6,7\n", r"row 3 has 3 fields, expected 2"),
        ("a,b\n1,2\n3,4,5,6\n6,7\n", r"row 3 has 4 fields, expected 2"),
        ("a,b\n1,2\n3\n6,7\n", r"row 3 has 1 fields, expected 2"),
        ("a b\n1 2\n3\n6 7\n", r"row 3 has 1 fields, expected 2 \(whitespace"),
        ("a b\n1 2\n3 4 5\n6 7\n", r"row 3 has 3 fields, expected 2 \(whitespace"),
    ],
)
def test_ragged_rows_are_never_filled_or_cut(tmp_path, monkeypatch, block, text, match):
    monkeypatch.setattr(textscan, "BLOCK", block)
    fails(match, write(tmp_path, "rg.csv", text), rate=1)


def test_memory_is_the_columns_not_the_text(tmp_path, monkeypatch):
    n = 40_000
    rng = np.random.default_rng(0)
    with open(tmp_path / "big.csv", "w") as f:
        f.write("time,gx,gy,gz,temp\n")
        np.savetxt(f, np.column_stack([np.arange(n) / 200, rng.standard_normal((n, 4))]),
                   delimiter=",", fmt="%.9e")  # fmt: skip
    monkeypatch.setattr(textscan, "BLOCK", 64 << 10)
    monkeypatch.setattr(textscan, "HEAD", 64 << 10)
    tracemalloc.start()
    try:
        rec = read_record(tmp_path / "big.csv")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    columns = 6 * 8 * n  # five columns and the row numbers: 1.9 MB
    # the 3.3 MB of text is never held: 3.4 MB at the peak (the whole-file reader: 33 MB)
    assert peak < 3 * columns, peak
    assert rec.n_samples == n and rec.rate == 200.0


# --------------------------------------------------------------------------------------
# Item 12: long fields, a --config file that is not UTF-8
# --------------------------------------------------------------------------------------


def test_a_field_longer_than_the_csv_module_limit(tmp_path):
    blob = "A" * 200_000
    text = "t,x,note\n" + "".join(f"{k / 10},{k},{blob if k == 5 else 'ok'}\n" for k in range(20))
    rec = read_record(write(tmp_path, "long.csv", text))
    assert rec.names == ["x"] and rec.rate == 10.0
    quoted = "t,x,note\n" + "".join(f'{k / 10},{k},"{blob},{k}"\n' for k in range(20))
    message = fails(r"cannot be split into fields", write(tmp_path, "q.csv", quoted))
    assert "field larger than field limit" in message and "remove the long text" in message


def test_config_file_that_is_not_utf8(tmp_path, capsys):
    config = tmp_path / "run.toml"
    config.write_bytes(b'units = "\xb0/s"\n')  # Latin-1 degree sign
    data = write(tmp_path, "x.csv", "x\n1\n2\n3\n4\n")
    code, out, err = run(capsys, ["avar", str(data), "--rate", "1", "--config", str(config)])
    assert_one_line_error(code, out, err, f"--config {config} is not UTF-8 text", "save it")


# --------------------------------------------------------------------------------------
# Item 16: decimal commas
# --------------------------------------------------------------------------------------


def test_semicolons_and_decimal_commas(tmp_path):
    text = "Zeit;Drehrate X;Drehrate Y\n" + "".join(
        f"{k / 200:.3f};{0.25 * k:.2f};-{k},5e-3\n".replace(".", ",") for k in range(400)
    )
    rec = read_record(write(tmp_path, "excel.csv", text), time_column="Zeit")
    assert rec.meta["decimal"] == "comma" and rec.meta["delimiter"] == "semicolon"
    assert rec.rate == 200.0
    np.testing.assert_allclose(rec.channel("Drehrate X"), 0.25 * np.arange(400))
    np.testing.assert_allclose(rec.channel("Drehrate Y"), -(np.arange(400) + 0.5) * 1e-3)


@pytest.mark.parametrize("sep", ["\t", "  "])
def test_decimal_commas_with_tabs_or_spaces(tmp_path, sep):
    text = "".join(f"{k / 10:.1f}{sep}{k * 1.5:.1f}\n".replace(".", ",") for k in range(30))
    rec = read_record(write(tmp_path, "d.txt", text), time_column=0)
    assert rec.meta["decimal"] == "comma"
    assert rec.rate == 10.0
    np.testing.assert_allclose(rec.channel("1"), 1.5 * np.arange(30))


def test_ambiguous_decimal_separators_are_explained(tmp_path):
    mixed = write(tmp_path, "mixed.csv", "t;x\n0;1,5\n1;2.5\n2;3,5\n")
    message = fails(r"column 'x' .* not numeric \(row 2: '1,5'; decimal commas are read", mixed,
                    columns="x")  # fmt: skip
    assert "no decimal points" in message
    grouped = write(tmp_path, "g.csv", "t;x\n0;1.234,5\n1;2.234,5\n")
    fails(r"digit grouping is not read", grouped, columns="x")
    # decimal commas in the last lines, a decimal point further up: not read as 1.5
    text = "t;x\n0;1.500\n" + "".join(f"{k};{k},5\n" for k in range(1, 80))
    fails(r"row 2: '1\.500'; a decimal point in a file whose numbers have decimal commas",
          write(tmp_path, "p.csv", text), columns="x", rate=1)  # fmt: skip


# --------------------------------------------------------------------------------------
# Issue 40: a header that does not fit its rows, integers beyond float64, Stable32 phase
# --------------------------------------------------------------------------------------


def test_decimal_commas_in_a_comma_file_under_a_header_are_an_error(tmp_path):
    # before: two header names over four fields: the header dropped, four columns 0..3
    rows = "".join(f"{k},5,1,{k % 7}5\n" for k in range(200))
    path = write(tmp_path, "x.csv", "t,x\n" + rows)
    message = fails("the header", path, rate=1.0)
    assert "row 1" in message and "2 field(s)" in message and "4 (comma-separated)" in message
    assert "decimal commas" in message and "';'" in message


def test_a_header_with_more_names_than_fields_is_an_error(tmp_path):
    rows = "".join(f"{k} {k * 0.5}\n" for k in range(200))
    path = write(tmp_path, "x.txt", "time [s]  rate [deg/s]\n" + rows)
    message = fails("the header", path)
    assert "4 field(s)" in message and "have 2" in message and "one name per column" in message


def test_a_matching_header_and_a_title_over_one_column_still_read(tmp_path):
    rows = "".join(f"{k * 0.1:.1f},{k}\n" for k in range(200))
    assert read_record(write(tmp_path, "a.csv", "t,x\n" + rows)).names == ["x"]
    one = "".join(f"{k}\n" for k in range(200))
    assert read_record(write(tmp_path, "b.txt", "gyro x output\n" + one), rate=1.0).names == ["0"]


BIG = (1 << 60) + np.arange(4000) % 7  # an offset beyond 2**53 and a few units of noise


def test_integers_beyond_2_53_in_a_text_file_are_an_error(tmp_path):
    # before: rounded to multiples of 256, the noise gone (adev 0)
    path = tmp_path / "x.csv"
    np.savetxt(path, BIG, fmt="%d")
    message = fails("beyond 2\\*\\*53", path, rate=1.0)
    assert "row 1" in message and str(int(BIG[0])) in message and "offset" in message


def test_integers_beyond_2_53_in_a_npy_are_an_error_when_read(tmp_path):
    from adavar.stats.statistics import deviation

    path = tmp_path / "x.npy"
    np.save(path, BIG.astype(np.int64))
    for memory_map in (True, False):  # the library's map, the command line's file reads
        record = read_record(path, rate=1.0, memory_map=memory_map)
        with pytest.raises(AdavarInputError, match="beyond 2\\*\\*53"):
            deviation(record.channel(), rate=1.0)
    with pytest.raises(AdavarInputError, match="sample 0 of data is the integer"):
        deviation(BIG.astype(np.int64))  # an array in memory
    small = deviation(BIG.astype(np.int64) - (1 << 60))  # the way out: exact
    assert small.dev[0] > 0


def _stable32(tmp_path, suffix):
    phase = np.cumsum(np.random.default_rng(3).standard_normal(3000)) * 1e-9
    path = tmp_path / f"clock{suffix}"
    np.savetxt(path, phase if suffix == ".phd" else np.diff(phase), fmt="%.15e")
    return path


def _first_dev(capsys, argv):
    import json

    code, out, err = run(capsys, [*argv, "--json"])
    assert code == 0, err
    payload = json.loads(out)
    return payload["input"]["data_type"], payload["dev"][0]


def test_a_stable32_phase_file_is_analysed_as_phase(tmp_path, capsys):
    # before: rate data by default (OADEV(1 s) 1.004e-2 instead of 1.741e-2 in the issue)
    path = str(_stable32(tmp_path, ".phd"))
    base = ["avar", path, "--rate", "1", "--units", "s"]
    kind, dev = _first_dev(capsys, base)
    assert kind == "phase"
    assert dev == _first_dev(capsys, [*base, "--data-type", "phase"])[1]
    code, out, err = run(capsys, [*base, "--data-type", "rate"])
    assert_one_line_error(code, out, err, "Stable32 phase file (.phd)", "--data-type rate",
                          "leave out --data-type", ".frd")  # fmt: skip


def test_a_stable32_frequency_file_is_rate_data(tmp_path, capsys):
    path = str(_stable32(tmp_path, ".frd"))
    base = ["avar", path, "--rate", "1", "--units", "s"]
    assert _first_dev(capsys, base)[0] == "rate"
    code, out, err = run(capsys, [*base, "--data-type", "phase"])
    assert_one_line_error(code, out, err, "Stable32 frequency file (.frd)", ".phd")


def test_file_data_type():
    from adavar.core.settings import DATA_TYPE_DEFAULT
    from adavar.readers import file_data_type

    assert file_data_type("a.PHD", DATA_TYPE_DEFAULT) == "phase"
    assert file_data_type("a.phd", None) == "phase"
    assert file_data_type("a.phd", "phase") == "phase"
    assert file_data_type("a.frd", "frequency") == "rate"
    assert file_data_type("a.csv", DATA_TYPE_DEFAULT) is DATA_TYPE_DEFAULT
    assert file_data_type("a.csv", "phase") == "phase"
    with pytest.raises(AdavarInputError, match="Stable32 phase file"):
        file_data_type("a.phd", "rate")

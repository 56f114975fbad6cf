"""Tests of adavar.readers: every reader on files written here, and every bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from adavar.core.errors import AdavarInputError
from adavar.readers import Record, read_record
from adavar.stats import stream


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


def iso_csv(n=50, rate=100.0, start="2024-03-01T12:00:00", skip=(), tz="Z"):
    base = np.datetime64(start, "us")
    lines = ["timestamp,gx,gy,status"]
    for i in range(n):
        if i in skip:
            continue
        stamp = base + np.timedelta64(round(i * 1e6 / rate), "us")
        lines.append(f"{stamp}{tz},{0.01 * i},{-0.5 * i},OK")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------
# Text
# --------------------------------------------------------------------------------------


def test_csv_header_iso_timestamps(tmp_path):
    rec = read_record(write(tmp_path, "imu.csv", iso_csv()))
    assert isinstance(rec, Record)
    assert rec.kind == "csv"
    assert rec.names == ["gx", "gy"]  # the text column 'status' is left out
    assert rec.rate == pytest.approx(100.0)
    assert len(rec) == 50 and rec.n_samples == 50
    np.testing.assert_allclose(rec.time, np.arange(50) / 100.0)
    np.testing.assert_allclose(rec.channel("gx"), 0.01 * np.arange(50))
    assert rec.channel("GY").dtype == np.float64
    assert rec.t0 == pytest.approx(np.datetime64("2024-03-01T12:00:00", "s").astype(float))
    assert rec.meta["time_column"] == "timestamp"
    assert rec.meta["time_format"] == "iso"
    assert rec.meta["rate_source"].startswith("nominal rate of the time stamps")
    assert rec.rate == 100.0  # exactly: the stamps are whole microseconds 10 000 apart
    assert rec.segments is None
    json.dumps(rec.meta)  # reproducible, serialisable


def test_tsv_without_header_declared_rate(tmp_path):
    text = "".join(f"{i}\t{2 * i}\t{3 * i}\n" for i in range(10))
    rec = read_record(write(tmp_path, "x.tsv", text), rate=50)
    assert rec.names == ["0", "1", "2"]
    assert rec.rate == 50.0
    assert rec.time is None and rec.t0 is None
    assert rec.meta["header"] is False
    assert rec.meta["delimiter"] == "tab"
    assert rec.meta["rate_source"] == "declared"
    np.testing.assert_array_equal(rec.channel("2"), 3 * np.arange(10))


def test_whitespace_with_comments(tmp_path):
    text = "# logger v2\n% matlab\n\ntime  gx   gz\n0.0 1 2\n# mid\n0.5   3\t4\n1.0 5 6\n"
    rec = read_record(write(tmp_path, "w.txt", text))
    assert rec.meta["delimiter"] == "whitespace"
    assert rec.names == ["gx", "gz"]
    assert rec.rate == pytest.approx(2.0)
    assert rec.meta["time_unit_source"].startswith("assumed")
    np.testing.assert_array_equal(rec.channel("gz"), [2, 4, 6])


def test_rostopic_echo_csv_header_and_nanoseconds(tmp_path):
    """``rostopic echo -p``: the header is a "comment" starting with %time (ns)."""
    head = ("%time,field.header.seq,field.header.stamp,field.header.frame_id,"
            "field.angular_velocity.x,field.angular_velocity.z\n")  # fmt: skip
    rows = "".join(f"{1_700_000_000_000_000_000 + 5_000_000 * i + 7},{i},"
                   f"{1_700_000_000_000_000_000 + 5_000_000 * i},imu,{i % 3},{-i}\n"
                   for i in range(40))  # fmt: skip
    path = write(tmp_path, "imu.csv", head + rows)
    rec = read_record(path, columns="field.angular_velocity.x,field.angular_velocity.z")
    assert rec.rate == pytest.approx(200.0)
    assert rec.meta["time_format"] == "ns"
    np.testing.assert_array_equal(rec.channel("field.angular_velocity.z"), -np.arange(40))
    # a MATLAB comment that only starts like it, or %time further down, stays a comment
    text = "% timing test\n%time of day\nt,x\n0,1\n0.5,2\n1.0,3\n"
    assert read_record(write(tmp_path, "m.csv", text)).names == ["x"]


def test_multichannel_selection(tmp_path):
    text = "t;gx;gy;gz\n" + "".join(f"{i / 10};{i};{10 + i};{20 + i}\n" for i in range(8))
    path = write(tmp_path, "s.csv", text)
    assert read_record(path, columns=["gz", "gx"]).names == ["gz", "gx"]
    assert read_record(path, columns="gx, gy").names == ["gx", "gy"]
    rec = read_record(path, columns=[3])
    assert rec.names == ["gz"] and rec.meta["delimiter"] == "semicolon"
    assert rec.rate == pytest.approx(10.0)


def test_time_unit_from_name_and_declared_rate_agrees(tmp_path):
    text = "t_ms,x\n" + "".join(f"{5 * i},{i}\n" for i in range(20))
    rec = read_record(write(tmp_path, "ms.csv", text), rate=200.0)
    assert rec.rate == 200.0
    assert rec.meta["time_format"] == "ms"
    assert rec.meta["rate_source"].startswith("declared")
    np.testing.assert_allclose(rec.time[-1], 0.095)


def test_explicit_time_column_and_format(tmp_path):
    text = "".join(f"{1_000_000_000 + 1_000_000 * i} {i}\n" for i in range(30))
    rec = read_record(write(tmp_path, "ns.dat", text), time_column=0, time_format="ns")
    assert rec.names == ["1"]
    assert rec.rate == pytest.approx(1000.0)
    assert rec.t0 == pytest.approx(1.0)


def test_epoch_nanoseconds_need_a_declared_unit(tmp_path):
    text = "timestamp,x\n" + "".join(
        f"{1_700_000_000_000_000_000 + 10**7 * i},{i}\n" for i in range(9)
    )
    path = write(tmp_path, "ns.csv", text)
    fails(r"too large for seconds .*: give its unit with time_format 'ms'", path)
    rec = read_record(path, time_format="ns")
    assert rec.rate == pytest.approx(100.0)
    assert rec.t0 == pytest.approx(1.7e9)


def test_headerless_iso_first_column(tmp_path):
    text = "".join(f"2024-01-01T00:00:{i:02d}+01:00,{i}\n" for i in range(10))
    rec = read_record(write(tmp_path, "iso.csv", text))
    assert rec.rate == pytest.approx(1.0)
    assert rec.meta["timezone"] == "given"
    assert rec.names == ["1"]


def test_stable32_phase_with_header_lines(tmp_path):
    text = "Phase data of H-maser\nTau0 = 1 s\nunits: seconds\n" + "".join(
        f"{1e-9 * i:.3e}\n" for i in range(12)
    )
    rec = read_record(write(tmp_path, "clock.phd", text), rate=1.0)
    assert rec.kind == "stable32"
    assert rec.names == ["phase"]
    assert rec.meta["skipped_lines_before_data"] == 3
    np.testing.assert_allclose(rec.channel(), 1e-9 * np.arange(12))


def test_stable32_frequency_with_mjd_tags(tmp_path):
    text = "".join(f"{60000 + i / 86400:.10f} {1e-12 * i:.3e}\n" for i in range(10))
    rec = read_record(write(tmp_path, "f.frd", text))
    assert rec.names == ["frequency"]
    assert rec.meta["time_format"] == "mjd"
    assert rec.rate == pytest.approx(1.0, rel=1e-4)
    assert rec.t0 == pytest.approx((60000 - 40587) * 86400.0)


def test_single_column_text_with_header_lines(tmp_path):
    text = "exported 2024\nfrequency data\n" + "".join(f"{i}\n" for i in range(5))
    rec = read_record(write(tmp_path, "one.txt", text), rate=2)
    assert rec.names == ["0"] and rec.n_samples == 5


# --------------------------------------------------------------------------------------
# Binary formats
# --------------------------------------------------------------------------------------


def test_npy_memory_mapped(tmp_path):
    data = np.arange(30, dtype=np.float64).reshape(10, 3)
    np.save(tmp_path / "a.npy", data)
    rec = read_record(tmp_path / "a.npy", rate=10, columns=[0, 2])
    assert rec.kind == "npy"
    assert rec.meta["memory_mapped"] is True
    assert rec.names == ["0", "2"]
    np.testing.assert_array_equal(rec.channel("2"), data[:, 2])
    assert isinstance(rec.channel("0").base, np.memmap) or isinstance(rec.channel("0"), np.memmap)


def test_npy_structured_with_time_field(tmp_path):
    arr = np.zeros(20, dtype=[("t", "f8"), ("gx", "f4")])
    arr["t"] = np.arange(20) / 4.0
    arr["gx"] = np.arange(20)
    np.save(tmp_path / "s.npy", arr)
    rec = read_record(tmp_path / "s.npy")
    assert rec.names == ["gx"] and rec.rate == pytest.approx(4.0)


def test_npz_stored_members_memory_mapped(tmp_path):
    t = np.arange(40) / 20.0
    np.savez(tmp_path / "a.npz", time=t, gx=np.sin(t), gy=np.cos(t))
    rec = read_record(tmp_path / "a.npz")
    assert rec.kind == "npz"
    assert rec.names == ["gx", "gy"]
    assert rec.rate == pytest.approx(20.0)
    assert rec.meta["memory_mapped"] is True
    np.testing.assert_allclose(rec.channel("gy"), np.cos(t))


def test_npz_datetime_key(tmp_path):
    stamps = np.datetime64("2024-01-01", "ns") + np.arange(10) * np.timedelta64(1, "s")
    np.savez(tmp_path / "dt.npz", stamp=stamps, x=np.arange(10.0))
    rec = read_record(tmp_path / "dt.npz")
    assert rec.names == ["x"] and rec.rate == pytest.approx(1.0)
    assert rec.t0 == pytest.approx(1704067200.0)


def test_npz_compressed_not_mapped(tmp_path):
    np.savez_compressed(tmp_path / "c.npz", x=np.arange(10.0))
    rec = read_record(tmp_path / "c.npz", rate=1.0)
    assert rec.meta["memory_mapped"] is False
    np.testing.assert_array_equal(rec.channel("x"), np.arange(10.0))


def test_npz_object_array_refused(tmp_path):
    np.savez(tmp_path / "o.npz", x=np.array([{"a": 1}, None], dtype=object))
    fails("pickle", tmp_path / "o.npz", rate=1)


def test_hdf5_dataset_path_and_group(tmp_path):
    h5py = pytest.importorskip("h5py")
    path = tmp_path / "log.h5"
    with h5py.File(path, "w") as f:
        f["imu/gyro"] = np.arange(60.0).reshape(20, 3)
        f["imu/gyro"].attrs["units"] = "deg/s"
        f["clock/time"] = np.arange(15) / 5.0
        f["clock/phase"] = np.arange(15) * 1e-9
    rec = read_record(path, dataset="/imu/gyro", rate=100, columns="1")
    assert rec.kind == "hdf5" and rec.names == ["1"]
    np.testing.assert_array_equal(rec.channel(), np.arange(60.0).reshape(20, 3)[:, 1])
    assert rec.meta["dataset"] == "/imu/gyro"
    rec = read_record(path, dataset="clock")
    assert rec.names == ["phase"] and rec.rate == pytest.approx(5.0)
    fails(r"numeric datasets .*--dataset", path)
    fails(r"no dataset 'nope'", path, dataset="nope")


def test_hdf5_compound_dataset(tmp_path):
    h5py = pytest.importorskip("h5py")
    arr = np.zeros(10, dtype=[("time", "f8"), ("gx", "f8")])
    arr["time"] = np.arange(10) * 0.5
    with h5py.File(tmp_path / "c.h5", "w") as f:
        f["d"] = arr
    rec = read_record(tmp_path / "c.h5")
    assert rec.names == ["gx"] and rec.rate == pytest.approx(2.0)


def test_hdf5_only_dataset(tmp_path):
    h5py = pytest.importorskip("h5py")
    with h5py.File(tmp_path / "one.hdf5", "w") as f:
        f["x"] = np.ones(8)
        f["x"].attrs["units"] = "rad/s"
    rec = read_record(tmp_path / "one.hdf5", rate=8)
    assert rec.names == ["x"] and rec.meta["units"] == {"x": "rad/s"}


def test_parquet_timestamp_column(tmp_path):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    stamps = np.datetime64("2024-01-01T00:00:00", "ns") + np.arange(25) * np.timedelta64(
        10_000_000, "ns"
    )
    table = pa.table(
        {"when": pa.array(stamps), "ax": np.arange(25.0), "label": ["a"] * 25,
         "ay": pa.array(np.arange(25), type=pa.int32())}
    )  # fmt: skip
    pq.write_table(table, tmp_path / "d.parquet")
    rec = read_record(tmp_path / "d.parquet")
    assert rec.kind == "parquet" and rec.names == ["ax", "ay"]
    assert rec.rate == pytest.approx(100.0)
    assert rec.meta["time_column"] == "when"
    fails("not numeric", tmp_path / "d.parquet", columns="label")


# --------------------------------------------------------------------------------------
# ROS bags
# --------------------------------------------------------------------------------------


def _imu_messages(store, n, rate, stamp_offset=1_700_000_000):
    Imu = store.types["sensor_msgs/msg/Imu"]
    Header = store.types["std_msgs/msg/Header"]
    Quat = store.types["geometry_msgs/msg/Quaternion"]
    Vec = store.types["geometry_msgs/msg/Vector3"]
    Time = store.types["builtin_interfaces/msg/Time"]
    ros1 = "seq" in Header.__dataclass_fields__
    for i in range(n):
        ns = stamp_offset * 1_000_000_000 + round(i * 1e9 / rate)
        stamp = Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        header = (
            Header(seq=i, stamp=stamp, frame_id="imu")
            if ros1
            else Header(stamp=stamp, frame_id="imu")
        )
        cov = np.zeros(9)
        yield ns, Imu(
            header=header, orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=cov, angular_velocity=Vec(x=0.001 * i, y=0.002, z=-0.003),
            angular_velocity_covariance=cov,
            linear_acceleration=Vec(x=0.1, y=0.2, z=9.81 + 0.001 * i),
            linear_acceleration_covariance=cov,
        )  # fmt: skip


def test_ros2_bag(tmp_path):
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    bag = tmp_path / "bag2"
    with Writer(bag, version=9) as writer:
        imu = writer.add_connection("/imu/data", "sensor_msgs/msg/Imu", typestore=store)
        other = writer.add_connection("/imu2", "sensor_msgs/msg/Imu", typestore=store)
        for ns, msg in _imu_messages(store, 40, 200.0):
            raw = store.serialize_cdr(msg, "sensor_msgs/msg/Imu")
            writer.write(imu, ns + 12345, raw)  # bag time: a little after the stamp
            writer.write(other, ns, raw)
    rec = read_record(bag, topic="/imu/data")
    assert rec.kind == "ros2"
    assert rec.names == ["gx", "gy", "gz", "ax", "ay", "az"]
    assert rec.rate == pytest.approx(200.0)
    assert rec.meta["units"]["gx"] == "rad/s" and rec.meta["units"]["az"] == "m/s^2"
    assert rec.meta["time_source"] == "header stamps"
    assert rec.t0 == pytest.approx(1_700_000_000.0)
    np.testing.assert_allclose(rec.channel("gx"), 0.001 * np.arange(40))
    np.testing.assert_allclose(rec.channel("az"), 9.81 + 0.001 * np.arange(40))
    sub = read_record(bag, topic="/imu2", columns="gz", time_column="bag")
    assert sub.names == ["gz"] and sub.meta["time_source"] == "bag time stamps"
    # the .db3 file inside the folder is read as the bag
    db3 = next(bag.glob("*.db3"))
    assert read_record(db3, topic="/imu2").n_samples == 40
    fails(r"2 IMU topics .*--topic", bag)
    fails(r"no sensor_msgs/msg/Imu topic '/nope'", bag, topic="/nope")


def test_ros2_bag_mcap_storage(tmp_path):
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    bag = tmp_path / "bag_mcap"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/imu", "sensor_msgs/msg/Imu", typestore=store)
        for ns, msg in _imu_messages(store, 20, 50.0):
            writer.write(conn, ns, store.serialize_cdr(msg, "sensor_msgs/msg/Imu"))
    rec = read_record(bag, columns=["ax", "ay", "az"])
    assert rec.names == ["ax", "ay", "az"] and rec.rate == pytest.approx(50.0)
    fails(r"unknown IMU channel 'wx'", bag, columns="wx")


def test_ros_bag_without_imu_topic(tmp_path):
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    Float = store.types["std_msgs/msg/Float64"]
    bag = tmp_path / "nobag"
    with Writer(bag, version=9) as writer:
        conn = writer.add_connection("/temp", "std_msgs/msg/Float64", typestore=store)
        writer.write(conn, 1, store.serialize_cdr(Float(data=1.0), "std_msgs/msg/Float64"))
    fails(r"no sensor_msgs/msg/Imu topic \(topics: /temp \(std_msgs/msg/Float64\)\)", bag)


def test_ros1_bag(tmp_path):
    pytest.importorskip("rosbags")
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    path = tmp_path / "imu.bag"
    with Writer(path) as writer:
        conn = writer.add_connection("/imu", "sensor_msgs/msg/Imu", typestore=store)
        for ns, msg in _imu_messages(store, 30, 100.0):
            writer.write(conn, ns, store.serialize_ros1(msg, "sensor_msgs/msg/Imu"))
    rec = read_record(path)
    assert rec.kind == "ros1"
    assert rec.rate == pytest.approx(100.0)
    assert rec.meta["topic"] == "/imu"
    np.testing.assert_allclose(rec.channel("gy"), 0.002)


def test_corrupt_bag(tmp_path):
    pytest.importorskip("rosbags")
    path = tmp_path / "bad.bag"
    path.write_bytes(b"#ROSBAG V2.0\n" + b"\x00" * 64)
    fails("not a readable ROS 1 bag", path)


# --------------------------------------------------------------------------------------
# Gaps, non-uniform sampling, NaN
# --------------------------------------------------------------------------------------


def gap_csv(tmp_path, name="gap.csv"):
    times = np.r_[np.arange(10), np.arange(15, 25)] * 0.1  # 0.6 s between rows 10 and 11
    text = "t,x\n" + "".join(f"{t:.3f},{t * 2:.3f}\n" for t in times)
    return write(tmp_path, name, text)


def test_gap_is_an_error_that_says_where(tmp_path):
    message = fails(r"gap of 0\.6 s after row 11 \(t = 0\.9 s", gap_csv(tmp_path))
    assert "--gaps split or --gaps interpolate" in message


def test_gap_split(tmp_path):
    rec = read_record(gap_csv(tmp_path), gaps="split")
    assert rec.segments == [slice(0, 10), slice(10, 20)]
    assert [len(p) for p in rec.pieces("x")] == [10, 10]
    assert rec.rate == pytest.approx(10.0)
    assert rec.meta["n_gaps"] == 1 and rec.meta["gap_list"][0]["after"] == "row 11"


def test_gap_interpolate(tmp_path):
    rec = read_record(gap_csv(tmp_path), gaps="interpolate")
    assert rec.n_samples == 25
    assert rec.meta["n_interpolated"] == 5 and rec.meta["resampled"] is False
    np.testing.assert_allclose(rec.time, np.arange(25) * 0.1, atol=1e-12)
    np.testing.assert_allclose(rec.channel("x"), 0.2 * np.arange(25), atol=1e-9)


def test_non_uniform_sampling(tmp_path):
    times = np.arange(20) * 0.1
    times[5] = 0.43  # 0.03 s after row 5
    text = "time,x\n" + "".join(f"{t:.3f},{t:.3f}\n" for t in times)
    path = write(tmp_path, "nu.csv", text)
    fails(r"non-uniform sampling: interval of 0\.03 s after row 6 .*--gaps interpolate", path)
    fails("non-uniform", path, gaps="split")
    rec = read_record(path, gaps="interpolate")
    assert rec.meta["resampled"] is True and rec.n_samples == 20
    np.testing.assert_allclose(rec.channel("x"), np.arange(20) * 0.1, atol=1e-9)


def test_time_goes_back(tmp_path):
    text = "t,x\n0,1\n1,2\n0.5,3\n2,4\n"
    fails(r"time goes back at row 4 .*sort the rows", write(tmp_path, "b.csv", text))


def test_nan_error_names_row_and_column(tmp_path):
    text = "t,gx,gy\n0,1,1\n1,2,nan\n2,,3\n3,4,4\n"
    message = fails(r"row 3, column 'gy' is NaN", write(tmp_path, "n.csv", text))
    assert "--nan drop or --nan interpolate" in message
    fails(r"row 3, column 'x' is Inf", write(tmp_path, "i.csv", "x\n1\ninf\n"), rate=1)


def test_nan_drop_with_time_makes_a_gap(tmp_path):
    text = "t,x\n" + "".join(f"{i},{'nan' if i == 5 else i}\n" for i in range(10))
    path = write(tmp_path, "d.csv", text)
    fails(r"gap of 2 s after row 6", path, nan="drop")
    rec = read_record(path, nan="drop", gaps="split")
    assert rec.meta["nan_rows_dropped"] == 1 and rec.meta["nan_dropped_at"] == ["row 7"]
    assert rec.segments == [slice(0, 5), slice(5, 9)]


def test_nan_drop_without_time(tmp_path):
    path = write(tmp_path, "e.txt", "nan\n1\n2\nnan\n3\nnan\n")
    fails(r"row 4, column '0' is NaN .*shift every later sample", path, rate=1, nan="drop")
    edge = write(tmp_path, "f.txt", "nan\n1\n2\n3\nnan\n")
    rec = read_record(edge, rate=1, nan="drop")
    np.testing.assert_array_equal(rec.channel(), [1, 2, 3])


def test_nan_interpolate(tmp_path):
    path = write(tmp_path, "g.txt", "nan\n1\n2\nnan\n4\n")
    rec = read_record(path, rate=1, nan="interpolate")
    np.testing.assert_array_equal(rec.channel(), [1, 2, 3, 4])
    assert rec.meta["nan_values_interpolated"] == {"0": 1}
    assert rec.meta["nan_rows_trimmed"] == 1


# --------------------------------------------------------------------------------------
# Bad input: each a one-line AdavarInputError
# --------------------------------------------------------------------------------------


def test_missing_file(tmp_path):
    fails("no such file", tmp_path / "nope.csv")


def test_unknown_suffix(tmp_path):
    fails(r"unknown file type '\.xlsx'", write(tmp_path, "a.xlsx", "1\n"))


def test_folder_that_is_not_a_bag(tmp_path):
    fails("not a ROS 2 bag", tmp_path)


def test_no_numeric_column(tmp_path):
    fails("no numeric column", write(tmp_path, "t.csv", "time,name\n0,a\n1,b\n"))


def test_unknown_column(tmp_path):
    path = write(tmp_path, "u.csv", "t,gx\n0,1\n1,2\n")
    fails(r"unknown column 'gz' .*available: 't', 'gx'", path, columns="gz")
    fails(r"unknown time column 'nope'", path, time_column="nope")
    fails(r"column 'gx' is named twice|named twice", path, columns="gx,gx")


def test_non_numeric_column_requested(tmp_path):
    path = write(tmp_path, "nn.csv", "x,y\n1,a\n2,b\n")
    fails(r"column 'y' of .* is not numeric \(row 2: 'a'\)", path, columns="y", rate=1)


def test_no_rate(tmp_path):
    message = fails("sampling rate is unknown", write(tmp_path, "r.txt", "1\n2\n3\n"))
    assert "--rate" in message and "--time-column" in message


def test_conflicting_rate(tmp_path):
    path = write(tmp_path, "c.csv", "t,x\n0,1\n0.1,2\n0.2,3\n")
    fails(r"declared rate 50 Hz disagrees .*10 Hz", path, rate=50)


def test_ragged_row(tmp_path):
    fails(r"row 3 has 1 fields, expected 2", write(tmp_path, "rg.csv", "a,b\n1,2\n3\n4,5\n"))


def test_corrupt_binary_files(tmp_path):
    (tmp_path / "bad.npy").write_bytes(b"\x93NUMPY garbage")
    fails("not a valid .npy file", tmp_path / "bad.npy", rate=1)
    (tmp_path / "text.npy").write_text("1\n2\n")
    fails(r"not a valid \.npy file \(no NumPy header\)", tmp_path / "text.npy", rate=1)
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    fails("not a valid .npz file", tmp_path / "bad.npz", rate=1)
    (tmp_path / "bad.h5").write_bytes(b"not hdf5 at all")
    fails("not a readable HDF5 file", tmp_path / "bad.h5", rate=1)
    (tmp_path / "bad.parquet").write_bytes(b"PAR1 broken")
    fails("not a readable Parquet file", tmp_path / "bad.parquet", rate=1)


def test_binary_text_file(tmp_path):
    (tmp_path / "bin.csv").write_bytes(b"\xff\xfe\x00\x01\x80")
    fails("not a UTF-8 text file", tmp_path / "bin.csv")


def test_bad_options(tmp_path):
    path = write(tmp_path, "o.txt", "1\n2\n")
    fails("unknown gaps policy", path, rate=1, gaps="fill")
    fails("unknown nan policy", path, rate=1, nan="zero")
    fails("unknown time format", path, rate=1, time_format="days")
    fails("rate must be a positive", path, rate=-1)
    fails("gap tolerance", path, rate=1, gap_tolerance=2)
    fails("--dataset applies to HDF5", path, rate=1, dataset="/x")
    fails("--topic applies to ROS", path, rate=1, topic="/imu")


def test_record_channel_errors(tmp_path):
    rec = read_record(write(tmp_path, "m.csv", "a,b\n1,2\n3,4\n"), rate=1)
    with pytest.raises(AdavarInputError, match="2 channels"):
        rec.channel()
    with pytest.raises(AdavarInputError, match="unknown channel 'c'"):
        rec.channel("c")


# --------------------------------------------------------------------------------------
# records larger than memory: lazy columns and memory maps


def test_npy_columns_stay_memory_mapped_in_their_dtype(tmp_path):
    y = np.random.default_rng(3).standard_normal((4000, 3)).astype(np.float32)
    np.save(tmp_path / "imu.npy", y)
    rec = read_record(tmp_path / "imu.npy", rate=100.0)
    for j, name in enumerate(rec.names):
        col = rec.channel(name)
        assert isinstance(col, np.memmap) and col.dtype == np.float32
        source = stream.memmap_source(col)
        assert source is not None
        np.testing.assert_array_equal(source.read(17, 3999), y[17:3999, j].astype(float))


def test_npy_nan_is_found_without_loading_the_file(tmp_path):
    y = np.random.default_rng(3).standard_normal(5000)
    y[4321] = np.nan
    np.save(tmp_path / "x.npy", y)
    with pytest.raises(AdavarInputError, match="4321"):
        read_record(tmp_path / "x.npy", rate=1.0)


@pytest.mark.parametrize("columns", [None, "2", "0,2"])
def test_lazy_hdf5_columns_read_piece_by_piece(tmp_path, columns):
    h5py = pytest.importorskip("h5py")
    y = np.random.default_rng(4).standard_normal((3001, 3))
    with h5py.File(tmp_path / "a.h5", "w") as f:
        f["imu/gyro"] = y
    rec = read_record(tmp_path / "a.h5", rate=10.0, lazy=True, columns=columns)
    assert rec.meta["lazy"] is True
    for name in rec.names:
        col = rec.channel(name)
        assert isinstance(col, stream.HDF5Source) and len(col) == 3001
        np.testing.assert_array_equal(col.read(5, 2999), y[5:2999, int(name)])
        np.testing.assert_array_equal(np.asarray(col), y[:, int(name)])


def test_lazy_parquet_across_row_groups(tmp_path):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    y = np.random.default_rng(5).standard_normal((5000, 2))
    pq.write_table(pa.table({"gx": y[:, 0], "gy": y[:, 1]}), tmp_path / "a.parquet",
                   row_group_size=700)  # fmt: skip
    rec = read_record(tmp_path / "a.parquet", rate=100.0, lazy=True)
    col = rec.channel("gy")
    assert isinstance(col, stream.ParquetSource)
    for a, b in [(0, 5000), (650, 2150), (699, 701), (4999, 5000)]:
        np.testing.assert_array_equal(col.read(a, b), y[a:b, 1])


def test_lazy_parquet_refuses_a_time_column(tmp_path):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    pq.write_table(pa.table({"time": np.arange(100) / 10, "gx": np.ones(100)}),
                   tmp_path / "t.parquet")  # fmt: skip
    with pytest.raises(AdavarInputError, match="time column needs every time stamp"):
        read_record(tmp_path / "t.parquet", lazy=True)
    assert read_record(tmp_path / "t.parquet").rate == pytest.approx(10.0)


def test_lazy_is_automatic_above_the_size_limit(tmp_path, monkeypatch):
    h5py = pytest.importorskip("h5py")
    from adavar.readers import lazy

    with h5py.File(tmp_path / "a.h5", "w") as f:
        f["x"] = np.arange(1000.0)
    assert isinstance(read_record(tmp_path / "a.h5", rate=1.0).channel(), np.ndarray)
    monkeypatch.setattr(lazy, "LAZY_BYTES", 4000)
    assert isinstance(read_record(tmp_path / "a.h5", rate=1.0).channel(), stream.HDF5Source)
    # other NaN policies need the whole record: read into memory
    got = read_record(tmp_path / "a.h5", rate=1.0, nan="drop").channel()
    assert isinstance(got, np.ndarray)


def test_lazy_nan_is_reported_with_its_sample_when_read(tmp_path):
    h5py = pytest.importorskip("h5py")
    x = np.arange(1000.0)
    x[777] = np.inf
    with h5py.File(tmp_path / "a.h5", "w") as f:
        f["x"] = x
    col = read_record(tmp_path / "a.h5", rate=1.0, lazy=True).channel()
    with pytest.raises(AdavarInputError, match=r"sample 777 .* inf"):
        col.read(0, 1000)


def test_lazy_refuses_text_files_and_nan_policies(tmp_path):
    h5py = pytest.importorskip("h5py")
    (tmp_path / "a.csv").write_text("1\n2\n3\n4\n")
    with pytest.raises(AdavarInputError, match=r"lazy reading is for \.npy, HDF5 and Parquet"):
        read_record(tmp_path / "a.csv", rate=1.0, lazy=True)
    with h5py.File(tmp_path / "a.h5", "w") as f:
        f["x"] = np.arange(100.0)
    with pytest.raises(AdavarInputError, match="nan='drop' needs the whole record"):
        read_record(tmp_path / "a.h5", rate=1.0, lazy=True, nan="drop")


def _receive_stamps(n: int, rate: float, seed: int) -> np.ndarray:
    """Stamps taken on receipt: even samples, each stamped after an exponential delay of
    0.3 of an interval on average, kept in order (as a ROS subscriber sees them)."""
    k = np.arange(n)
    arrival = k / rate + np.random.default_rng(seed).exponential(0.3 / rate, n)
    return 1.7e9 + np.maximum.accumulate(arrival - k * 2e-5) + k * 2e-5


def test_receive_time_jitter_is_not_taken_for_gaps(tmp_path):
    """Receive-time stamps jitter both ways: the intervals within 50 % of the median are a
    biased sample (200.9 Hz for 200), and --gaps interpolate added 0.4 % more samples."""
    n = 20_000
    t = _receive_stamps(n, 200.0, 4)
    x = np.random.default_rng(5).standard_normal(n)
    path = write(tmp_path, "rx.csv", "time,gx\n" + "".join(
        f"{a:.6f},{b:.9e}\n" for a, b in zip(t, x, strict=True)))  # fmt: skip
    message = fails(r"the time stamps jitter: .* no sample seems missing", path)
    assert "--time-column none --rate 200" in message and "--gaps interpolate" in message
    rec = read_record(path, gaps="interpolate")
    assert rec.rate == pytest.approx(200.0, rel=1e-4) and rec.n_samples == n
    # the way out the message names: the stamps ignored, the declared rate
    rec = read_record(path, time_column="none", rate=200.0)
    np.testing.assert_allclose(rec.channel("gx"), x, rtol=1e-9)
    assert rec.rate == 200.0 and rec.n_samples == n
    # a dropped sample among even stamps is still a gap
    even = 1.7e9 + np.delete(np.arange(n), 777) / 200.0
    path = write(tmp_path, "gap.csv", "time,gx\n" + "".join(f"{a:.6f},1\n" for a in even))
    fails(r"gap of 0.01 s after", path)

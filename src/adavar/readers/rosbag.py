"""ROS bags (ROS 2 folders with sqlite3 or MCAP storage, ROS 1 ``.bag``), read with rosbags.

The ``sensor_msgs/msg/Imu`` messages of one topic become the channels ``gx gy gz``
(angular velocity, rad/s) and ``ax ay az`` (linear acceleration, m/s^2); the time base is
the messages' header stamps, or the bag's recording time stamps (``time_column="bag"``, the
default when every header stamp is zero). rosbags is imported when a bag is read.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.readers.errors import fail, one_line, require
from adavar.readers.record import RawRecord
from adavar.readers.table import as_list, resolve

_IMU_CHANNELS = {
    "gx": ("angular_velocity", "x"),
    "gy": ("angular_velocity", "y"),
    "gz": ("angular_velocity", "z"),
    "ax": ("linear_acceleration", "x"),
    "ay": ("linear_acceleration", "y"),
    "az": ("linear_acceleration", "z"),
}
_IMU_UNITS = {"gx": "rad/s", "gy": "rad/s", "gz": "rad/s", "ax": "m/s^2", "ay": "m/s^2",
              "az": "m/s^2"}  # fmt: skip
_IMU_TYPE = "sensor_msgs/msg/Imu"


def read_rosbag(path: Path, src: str, opts: dict[str, Any], *, ros2: bool) -> RawRecord:
    """The record of one IMU topic of a ROS 2 (``ros2=True``) or ROS 1 bag."""
    require("rosbags", "ROS bags")
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE if ros2 else Stores.ROS1_NOETIC)
    topic = opts["topic"]
    time_column = opts["time_column"]
    if time_column not in (None, "header", "bag"):
        raise fail(
            f"time_column {time_column!r} does not apply to a ROS bag: use 'header' "
            "(the messages' header stamps) or 'bag' (the recording time stamps)"
        )
    wanted = as_list(opts["columns"])
    names = list(_IMU_CHANNELS)
    chosen = names if wanted is None else [resolve(c, names, src, "IMU channel") for c in wanted]
    try:
        with AnyReader([path], default_typestore=store) as reader:
            imu = sorted({c.topic for c in reader.connections if c.msgtype == _IMU_TYPE})
            if not imu:
                others = ", ".join(sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections}))
                raise fail(
                    f"{src} has no {_IMU_TYPE} topic (topics: {others or 'none'}): record the "
                    "IMU topic, or export the data to CSV"
                )
            if topic is None:
                if len(imu) > 1:
                    raise fail(
                        f"{src} has {len(imu)} IMU topics ({', '.join(imu)}): choose one with "
                        "--topic NAME"
                    )
                topic = imu[0]
            elif topic not in imu:
                raise fail(f"no {_IMU_TYPE} topic {topic!r} in {src}; IMU topics: {', '.join(imu)}")
            conns = [c for c in reader.connections if c.topic == topic]
            n = sum(c.msgcount for c in conns)
            data = np.empty((n, 6), dtype=np.float64)
            stamp = np.empty(n, dtype=np.int64)
            recorded = np.empty(n, dtype=np.int64)
            k = 0
            for conn, bag_ns, raw in reader.messages(connections=conns):
                msg: Any = reader.deserialize(raw, conn.msgtype)
                if k == n:  # more messages than the index said
                    data = np.concatenate([data, np.empty_like(data)])
                    stamp = np.concatenate([stamp, np.empty_like(stamp)])
                    recorded = np.concatenate([recorded, np.empty_like(recorded)])
                w, a = msg.angular_velocity, msg.linear_acceleration
                data[k] = (w.x, w.y, w.z, a.x, a.y, a.z)
                stamp[k] = int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)
                recorded[k] = bag_ns
                k += 1
    except AdavarInputError:
        raise
    except Exception as exc:  # rosbags raises many kinds on damaged bags
        what = "ROS 2 bag" if ros2 else "ROS 1 bag"
        raise fail(f"{src} is not a readable {what} ({one_line(exc)}): check the file") from None
    data, stamp, recorded = data[:k], stamp[:k], recorded[:k]
    if k == 0:
        raise fail(f"topic {topic!r} of {src} has no messages: give a bag with IMU data")
    if time_column is None:
        time_column = "bag" if not stamp.any() else "header"
    ns = stamp if time_column == "header" else recorded
    channels = {c: data[:, names.index(c)].copy() for c in chosen}
    info = {
        "topic": topic,
        "message_type": _IMU_TYPE,
        "channels": chosen,
        "units": {c: _IMU_UNITS[c] for c in chosen},
        "time_source": "header stamps" if time_column == "header" else "bag time stamps",
        "n_messages": int(k),
        "time_resolution": 1e-9,  # integer nanoseconds
    }
    if time_column == "header" and not stamp.any():
        raise fail(
            f"the header stamps of {topic!r} in {src} are all zero: use time_column='bag' "
            "(--time-column bag) for the recording time stamps"
        )
    rel = (ns - ns[0]).astype(np.float64) / 1e9
    return RawRecord(channels, rel, float(ns[0]) / 1e9, None, "message", info)

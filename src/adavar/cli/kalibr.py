"""``adavar kalibr``: Kalibr's imu.yaml from a static 6-axis recording."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from adavar import __version__
from adavar.cli.options import (
    EXIT_OK,
    UsageError,
    add_fit_range_arguments,
    add_time_arguments,
    check_not_stdin,
)
from adavar.cli.output import Status, check_output_file, output_error
from adavar.cli.values import parse_names, positive_float, sample_rate
from adavar.core.errors import AdavarInputError
from adavar.core.request import AnalysisRequest, RecordRequest, UnitGroup
from adavar.core.settings import FIT
from adavar.io.writers import dumps


def kalibr_request(args: argparse.Namespace) -> AnalysisRequest:
    """The request of ``adavar kalibr``: six columns, a unit for the gyro's three and one
    for the accelerometer's, the deviation and fit of the library's defaults."""
    if len(args.gyro) != 3 or len(args.accel) != 3:
        raise UsageError("--gyro and --accel take three columns each (x,y,z)")
    seen: dict[str, str] = {}  # column -> the flag that named it first
    for flag, column in [("--gyro", c) for c in args.gyro] + [("--accel", c) for c in args.accel]:
        if column in seen:  # the reader would say "named twice in --column"
            where = flag if seen[column] == flag else f"{seen[column]} and {flag}"
            raise UsageError(
                f"column {column!r} is named twice in {where} (--gyro {','.join(args.gyro)} "
                f"--accel {','.join(args.accel)}): each axis needs its own column; name each "
                "once"
            )
        seen[column] = flag
    groups = (
        UnitGroup(tuple(args.gyro), args.gyro_units, "--gyro-units", "rad/s, deg/s"),
        UnitGroup(tuple(args.accel), args.accel_units, "--accel-units", "m/s^2, g"),
    )
    record = RecordRequest(
        file=str(args.file), column=[*args.gyro, *args.accel], rate=args.rate,
        time_column=args.time_column, time_format=args.time_format, topic=args.topic,
        gaps=args.gaps, unit_groups=groups,
    )  # fmt: skip
    # the sensor's filter, when the user knows it, leaves its roll-off out up front (the
    # automatic exclusion misses a roll-off that only bends the curve a little)
    fit = replace(FIT, bandwidth=args.bandwidth, tau_range=args.tau_range)
    return AnalysisRequest(record=record, fit=fit)


def _no_constant_axis(args: argparse.Namespace) -> Callable[..., None]:
    """The check of :func:`adavar.pipeline.analysis.run`: a constant column (a dead axis,
    or the wrong column) has no noise to fit."""

    def check(request: AnalysisRequest, loaded: Any) -> None:
        from adavar.pipeline.analysis import is_constant  # reads a piece at a time

        for name, samples in loaded.channels.items():
            if is_constant(samples):
                flag = "--gyro" if name in args.gyro else "--accel"
                raise AdavarInputError(
                    f"column {name!r} is constant: it has no noise to fit; check {flag} (the "
                    "columns of the axes) and that the sensor was recording"
                )

    return check


def _cmd_kalibr(args: argparse.Namespace) -> int:
    from adavar.output.export import kalibr_imu_yaml, kalibr_values, write_text
    from adavar.pipeline.analysis import run

    check_not_stdin(args)
    output = check_output_file(args.output, args.force, (".yaml", ".yml"))
    request = kalibr_request(args)
    status = Status()
    done = run(request, status=status, channels="chosen", whole="fit",
               check=_no_constant_axis(args))  # fmt: skip
    fits = {name: channel.fit for name, channel in done.channels.items()}
    units = {name: channel.units for name, channel in done.channels.items()}
    rate = float(done.request.record.rate)  # as read: declared or from the time stamps
    n_samples = done.channels[args.gyro[0]].samples
    gyro_units, accel_units = units[args.gyro[0]], units[args.accel[0]]
    kwargs = dict(
        gyro_fits=[fits[g] for g in args.gyro], accel_fits=[fits[a] for a in args.accel],
        rate=rate, topic=args.topic or "/imu0", gyro_units=gyro_units,
        accel_units=accel_units, combine=args.combine, inflate=args.inflate,
        pinned=args.pinned, gyro_names=args.gyro, accel_names=args.accel,
    )  # fmt: skip
    try:
        text = kalibr_imu_yaml(**kwargs)
        values = kalibr_values(**{k: v for k, v in kwargs.items() if k not in ("rate", "topic")})
    except ValueError as exc:  # the library names its keyword; here it is a flag
        message = str(exc).replace("pinned='bound'", "--pinned bound")
        raise AdavarInputError(message) from None
    status(f"writing {output}")
    try:
        write_text(output, text)
    except OSError as exc:
        raise output_error(args.output, exc) from None
    status.close()
    if args.json:
        print(
            dumps(
                {
                    "adavar_version": __version__,
                    "output": str(output),
                    "rate": rate,
                    "n_samples": n_samples,
                    "kalibr": values,
                }
            )
        )
        return EXIT_OK
    print(f"{args.file}: {n_samples} samples at {rate:g} Hz; wrote {output}")
    print(text)
    return EXIT_OK


def add_kalibr_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``adavar kalibr`` to the sub-command parsers ``sub``."""
    kal = sub.add_parser(
        "kalibr",
        help="Kalibr imu.yaml (noise densities and random walks) from a static 6-axis log",
        description="Fit the noise terms of the three gyro and three accelerometer axes of "
        "a static IMU recording (a ROS bag with sensor_msgs/Imu, or any file with six "
        "columns) and write Kalibr's imu.yaml: gyroscope/accelerometer noise density (N) "
        "and random walk (K) in Kalibr's SI units, the axes combined conservatively (the "
        "largest), with every per-axis value and conversion in the file's comments.",
    )
    kal.add_argument(
        "file", metavar="FILE",
        help="ROS 1 .bag / ROS 2 bag folder (sensor_msgs/Imu) or a file with 6 columns",
    )  # fmt: skip
    kal.add_argument(
        "--gyro",
        type=parse_names,
        default=["gx", "gy", "gz"],
        metavar="X,Y,Z",
        help="gyro columns (default: gx,gy,gz, the names of a ROS bag)",
    )
    kal.add_argument(
        "--accel",
        type=parse_names,
        default=["ax", "ay", "az"],
        metavar="X,Y,Z",
        help="accelerometer columns (default: ax,ay,az)",
    )
    kal.add_argument("--gyro-units", metavar="UNIT",
                     help="unit of the gyro samples (default: the bag's rad/s; required "
                     "for other files)")  # fmt: skip
    kal.add_argument(
        "--accel-units",
        metavar="UNIT",
        help="unit of the accelerometer samples (default: the bag's m/s^2)",
    )
    kal.add_argument(
        "--rate",
        metavar="HZ",
        type=sample_rate("--rate"),
        help="sample rate, if the file has no time stamps",
    )
    add_time_arguments(kal)
    add_fit_range_arguments(kal)
    kal.add_argument("--topic", metavar="TOPIC", help="IMU topic of a ROS bag")
    kal.add_argument(
        "--gaps",
        default="error",
        choices=("error", "interpolate"),
        help="a gap in the time stamps is an error (default) or interpolated",
    )
    kal.add_argument(
        "--combine",
        default="max",
        choices=("max", "mean"),
        help="how the three axes are combined (default: max, conservative)",
    )
    kal.add_argument(
        "--pinned", default="error", choices=("error", "bound", "sigma"),
        help="an axis whose N or K the fit pins at 0 (e.g. K of a short record) is an error "
        "(default), or contributes its 99 %% upper bound (bound), or its 84 %% one (sigma: "
        "below the truth most of the time; the 'bound' of adavar 0.2)",
    )  # fmt: skip
    kal.add_argument(
        "--inflate",
        type=positive_float("a factor"),
        default=1.0,
        metavar="F",
        help="multiply all four values (default: 1, as fitted)",
    )
    kal.add_argument(
        "-o",
        "--output",
        metavar="imu.yaml",
        required=True,
        help="the file to write (atomically; existing needs --force)",
    )
    kal.add_argument("--json", action="store_true", help="print one JSON object")
    kal.add_argument("--force", action="store_true", help="replace an existing --output")
    kal.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )
    kal.gap_ways = ("interpolate",)
    kal.set_defaults(handler=_cmd_kalibr)
    return kal

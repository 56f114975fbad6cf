"""The ``adavar`` command line.

Commands
--------
``adavar avar FILE --rate HZ --units UNIT [...]``
    Allan-family deviation of one column of a text file, with confidence intervals, and
    optionally the IEEE Std 952 noise fit; a table, JSON, or an output folder.
``adavar davar FILE --rate HZ --units UNIT --window L [...]``
    The dynamic Allan variance of a sliding window and the noise coefficients of every
    window over time (N(t), B(t), ...); a summary, JSON, or an output folder with the
    surface (NetCDF or Parquet), the coefficients (CSV) and the figures.
``adavar compare (FILE --rate HZ --units UNIT | --scenario 1|2) [--seeds N] [...]``
    DAVAR-Lmin, DAVAR-Lmax, DAVAR-K and A-DAVAR on the same record: the node times around
    each change next to the paper's Table 1, ARW interval means, ground-truth confidence
    and tracking metrics (simulated scenarios), the kurtosis threshold crossings (Fig. 8);
    ``--out`` writes the tables (CSV, JSON) and the paper's figures.
``adavar demo [--out DIR] [--json] [--seed N]``
    The NIST SP 1065 check values, a simulated MEMS gyroscope and the paper's scenario 1.

``avar``, ``davar``, ``adaptive`` and ``report`` analyse several channels one by one with
``--column gx,gy,gz`` (``avar``: every numeric column by default); on a terminal every
command shows what it is doing on one status line of stderr (nothing when stderr is not a
terminal).

Exit codes: 0 success, 1 internal error (a bug: the traceback with ``--debug`` or
``ADAVAR_DEBUG=1``), 2 a user mistake (bad flag, unreadable file, bad data), reported as
one line ``adavar: error: ...`` on stderr. 130 when interrupted.

Only this module prints; the library functions it calls return data.
"""

from __future__ import annotations

import argparse
import csv
import io as _stdio
import json
import math
import os
import sys
import time
import traceback
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from adavar import __version__, stream
from adavar.adaptive import adaptive_davar
from adavar.davar import davar
from adavar.errors import AdavarInputError
from adavar.io import (
    SURFACE_FORMATS,
    atomic_directory,
    check_output_directory,
    check_surface_format,
    write_surface,
)
from adavar.noise_model import ALLAN_STATS, TERM_NAMES, NoiseFit, fit_noise
from adavar.results import DavarResult, DeviationResult
from adavar.statistics import STATISTICS, deviation
from adavar.taus import TAU_KEYWORDS
from adavar.windows import EDGES, MIN_WINDOW

__all__ = ["build_parser", "main"]

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130

#: Name of the marker file that identifies a folder written by ``adavar demo`` (such a
#: folder is replaced by the next run; any other existing folder needs --force).
DEMO_MARKER = ".adavar-demo"
DEMO_DEFAULT_OUT = "adavar-demo"

_TERM_ALIASES = {
    "q": "quantization",
    "n": "angle_random_walk",
    "arw": "angle_random_walk",
    "vrw": "angle_random_walk",
    "b": "bias_instability",
    "bi": "bias_instability",
    "k": "rate_random_walk",
    "rrw": "rate_random_walk",
    "r": "rate_ramp",
    "rr": "rate_ramp",
}
#: File name (without suffix) of the coefficient figure of each term in a davar --out folder.
_TERM_FILES = {
    "quantization": "q",
    "angle_random_walk": "arw",
    "bias_instability": "bi",
    "rate_random_walk": "rrw",
    "rate_ramp": "rr",
}
_TERM_LETTERS = {
    "quantization": "Q",
    "angle_random_walk": "N",
    "bias_instability": "B",
    "rate_random_walk": "K",
    "rate_ramp": "R",
}


class UsageError(Exception):
    """A mistake on the command line (exit code 2)."""


class _Parser(argparse.ArgumentParser):
    """ArgumentParser that raises :class:`UsageError` instead of printing usage and exiting."""

    def error(self, message: str) -> NoReturn:
        """Raise a one-line :class:`UsageError` pointing at this parser's ``--help``."""
        raise UsageError(f"{message} (see '{self.prog} --help')")


# --------------------------------------------------------------------------------------
# Flag values
# --------------------------------------------------------------------------------------


def _positive_float(what: str) -> Callable[[str], float]:
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"must be a positive number of {what}, got {text!r}")
        return value

    return parse


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return value


def _confidence(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(
            f"must be a probability strictly between 0 and 1 (e.g. 0.683 or 0.95), got {text!r}"
        )
    return value


def _confidence_or_none(text: str) -> float | None:
    if text.strip().lower() in ("none", "off"):
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(
            "must be a probability strictly between 0 and 1 (e.g. 0.683 or 0.95), or none "
            f"for no bounds and no fit, got {text!r}"
        )
    return value


def _window_length(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < MIN_WINDOW:
        raise argparse.ArgumentTypeError(
            f"must be a whole number of samples, at least {MIN_WINDOW} (one Allan-variance "
            f"term at m = 1), got {text!r}"
        )
    return value


def _taus(text: str) -> str | list[float]:
    key = text.strip().lower()
    if key in TAU_KEYWORDS:
        return key
    try:
        values = [float(part) for part in text.split(",") if part.strip()]
    except ValueError:
        values = []
    if not values or not all(math.isfinite(v) and v > 0 for v in values):
        raise argparse.ArgumentTypeError(
            f"expected {', '.join(TAU_KEYWORDS)} or comma-separated positive seconds "
            f"(e.g. 0.1,1,10), got {text!r}"
        )
    return values


def _fraction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"must be a fraction between 0 and 1, got {text!r}")
    return value


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text!r}")
    return value


def _finite_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def _positive_list(what: str, example: str) -> Callable[[str], list[float]]:
    """A parser of comma-separated positive finite numbers (``what`` names them)."""

    def parse(text: str) -> list[float]:
        try:
            values = [float(part) for part in text.split(",") if part.strip()]
        except ValueError:
            values = []
        if not values or not all(math.isfinite(v) and v > 0 for v in values):
            raise argparse.ArgumentTypeError(
                f"expected comma-separated positive {what} (e.g. {example}), got {text!r}"
            )
        return values

    return parse


_seconds_list = _positive_list("times in seconds", "3000,4000")
_threshold_list = _positive_list("kurtosis thresholds", "3.3,4")


def _intervals(text: str) -> list[tuple[float, float]]:
    out = []
    for part in text.split(","):
        if not part.strip():
            continue
        try:
            a, b = (float(v) for v in part.split(":"))
        except ValueError:
            a = b = math.nan
        if not (math.isfinite(a) and math.isfinite(b) and 0 <= a < b):
            raise argparse.ArgumentTypeError(
                f"expected comma-separated A:B intervals in seconds with A < B (e.g. "
                f"0:3000,3000:4000), got {part.strip()!r}"
            )
        out.append((a, b))
    if not out:
        raise argparse.ArgumentTypeError("give at least one A:B interval")
    return out


def _number_tuple(flag: str, least: int, most: int) -> Callable[[str], tuple[float, ...]]:
    def parse(text: str) -> tuple[float, ...]:
        try:
            values = tuple(float(part) for part in text.split(","))
        except ValueError:
            values = ()
        if not least <= len(values) <= most or not all(math.isfinite(v) for v in values):
            raise argparse.ArgumentTypeError(
                f"{flag} takes {least}{'' if least == most else f' or {most}'} comma-separated "
                f"numbers, got {text!r}"
            )
        return values

    return parse


def _names(text: str) -> list[str]:
    names = [part.strip().lower() for part in text.split(",") if part.strip()]
    if not names:
        raise argparse.ArgumentTypeError("give at least one method, e.g. davar-400,a-davar")
    return names


def _terms(text: str) -> tuple[str, ...]:
    out = []
    for part in text.split(","):
        key = part.strip()
        if not key:
            continue
        name = key if key in TERM_NAMES else _TERM_ALIASES.get(key.lower())
        if name is None:
            raise argparse.ArgumentTypeError(
                f"unknown noise term {key!r}: use {', '.join(TERM_NAMES)} or the letters "
                "Q, N, B, K, R"
            )
        if name not in out:
            out.append(name)
    if not out:
        raise argparse.ArgumentTypeError("give at least one noise term")
    return tuple(out)


# --------------------------------------------------------------------------------------
# Parser
# --------------------------------------------------------------------------------------


def _add_input_arguments(
    cmd: argparse.ArgumentParser, *, optional_file: bool = False, several: bool = True
) -> None:
    """FILE, --column, --rate/--tau0, --units and the reader's options of every command
    (``several``: the command analyses several channels one by one)."""
    cmd.add_argument(
        "file", metavar="FILE", nargs="?" if optional_file else None,
        help="the record: CSV/TSV/whitespace text (with or without header, a time column "
        "in s or ISO 8601, or a declared --rate), .npy/.npz, HDF5 (--dataset), Parquet, a "
        "ROS 1 .bag or ROS 2 bag folder (sensor_msgs/Imu: gx gy gz ax ay az), Stable32 "
        ".phd/.frd",
    )  # fmt: skip
    cmd.add_argument(
        "--time-column", metavar="NAME",
        help="column of time stamps (default: one named time, t, timestamp, ...; "
        "'header' or 'bag' for ROS bags)",
    )  # fmt: skip
    cmd.add_argument(
        "--time-format", default="auto", choices=("auto", "s", "ms", "us", "ns", "iso", "mjd"),
        help="unit or format of the time column (default: auto)",
    )  # fmt: skip
    cmd.add_argument(
        "--gaps", default="error", choices=("error", "split", "interpolate"),
        help="a gap in the time stamps is an error (default), splits the record into "
        "gap-free pieces analysed one by one (avar), or is filled by linear interpolation",
    )  # fmt: skip
    cmd.add_argument(
        "--gap-tolerance", type=_fraction, default=0.5, metavar="F",
        help="an interval longer than (1 + F) or shorter than (1 - F) times the median is a "
        "gap or non-uniform sampling (default: 0.5)",
    )  # fmt: skip
    cmd.add_argument(
        "--nan", default="error", choices=("error", "drop", "interpolate"),
        help="a NaN/Inf sample is an error (default), its row is dropped, or it is "
        "interpolated",
    )  # fmt: skip
    cmd.add_argument("--dataset", metavar="PATH", help="dataset of an HDF5 file")
    cmd.add_argument("--topic", metavar="TOPIC", help="IMU topic of a ROS bag")
    cmd.add_argument(
        "--lazy", action=argparse.BooleanOptionalAction, default=None,
        help="HDF5/Parquet: read the channels piece by piece (--lazy) or into memory "
        "(--no-lazy); default: piece by piece beyond 1 GiB or a quarter of the free memory",
    )  # fmt: skip
    cmd.add_argument(
        "--preprocess", metavar="STEPS",
        help="comma-separated steps applied in order: detrend:ORDER, mean, "
        "decimate:K[:average], select:START:STOP (seconds); e.g. detrend:3,decimate:100 "
        "(the paper's real-data steps)",
    )  # fmt: skip
    cmd.add_argument(
        "--column", metavar="NAME[,NAME...]" if several else "NAME",
        help="header name or 0-based index of the channel; several, comma-separated (e.g. "
        "gx,gy,gz), are analysed one by one (default: every numeric column but the time)"
        if several
        else "header name or 0-based index of the column (needed if there are several)",
    )  # fmt: skip
    cmd.add_argument(
        "--rate", metavar="HZ", type=_positive_float("Hz"),
        help="sample rate in Hz (required, or --tau0)",
    )  # fmt: skip
    cmd.add_argument(
        "--tau0", metavar="SECONDS", type=_positive_float("seconds"),
        help="sample interval in seconds, instead of --rate",
    )  # fmt: skip
    cmd.add_argument(
        "--units", metavar="UNIT",
        help="unit of the samples, e.g. deg/s, deg/h, rad/s, m/s^2, g (required); with "
        "--data-type phase the unit of the integrated samples, e.g. deg or s",
    )  # fmt: skip


def _add_output_arguments(cmd: argparse.ArgumentParser, out_help: str) -> None:
    """--out DIR, --force and the hidden --debug of an analysis command."""
    cmd.add_argument("--out", metavar="DIR", help=out_help)
    cmd.add_argument("--force", action="store_true", help="replace an existing --out folder")
    cmd.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )


def _add_controller_arguments(cmd: argparse.ArgumentParser) -> None:
    """The adaptive window's settings (docs/method.md section 8; the paper's values by default)."""
    cmd.add_argument("--lmax", type=_positive_int, default=600, metavar="L",
                      help="longest window, samples (default: 600)")  # fmt: skip
    cmd.add_argument("--lmin", type=_positive_int, default=400, metavar="L",
                      help="shortest window, samples (default: 400)")  # fmt: skip
    cmd.add_argument("--k1", type=_finite_float, default=2.5, metavar="K",
                      help="lower kurtosis threshold (default: 2.5)")  # fmt: skip
    cmd.add_argument("--k2", type=_finite_float, default=3.3, metavar="K",
                      help="upper kurtosis threshold (default: 3.3)")  # fmt: skip
    cmd.add_argument("--s1", type=_finite_float, default=0.0, metavar="S",
                      help="lower S threshold, --s-test band only (default: 0)")  # fmt: skip
    cmd.add_argument("--s2", type=_finite_float, default=0.07, metavar="S",
                      help="upper S threshold (default: 0.07)")  # fmt: skip
    cmd.add_argument("--l", type=_positive_int, default=100, metavar="N", dest="segment",
                      help="leading segment of the S test, samples (default: 100)")  # fmt: skip
    cmd.add_argument("--dl0", type=_seed, default=2, metavar="N",
                      help="regrow step, samples (default: 2)")  # fmt: skip
    cmd.add_argument("--dl1", type=_seed, default=2, metavar="N",
                      help="shrink step, samples (default: 2)")  # fmt: skip
    cmd.add_argument(
        "--s-test",
        default="upper",
        choices=("upper", "band", "abs"),
        help="f2 test: S > S2 (default), S outside [S1, S2], |S| > S2",
    )
    cmd.add_argument("--combine", default="or", choices=("or", "and"),
                      help="f = f1 or f2 (default) / f1 and f2")  # fmt: skip
    cmd.add_argument(
        "--thresholds", default="paper", choices=("paper", "calibrated"),
        help="paper: K1, K2, S2 as given (default); calibrated: from the sampling "
        "distribution of the kurtosis for --false-alarm",
    )  # fmt: skip
    cmd.add_argument("--false-alarm", type=_confidence, default=0.01, metavar="P",
                      help="per-step false-alarm rate of --thresholds calibrated (default: "
                      "0.01)")  # fmt: skip


def _noise_type(text: str) -> str | int | list[int]:
    value = text.strip().lower()
    if value == "record":
        return "record"
    try:
        alphas = [int(part) for part in value.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: use 'record', an integer alpha from -2 to 2, or one per tau "
            "(comma-separated)"
        ) from None
    if not all(-2 <= alpha <= 2 for alpha in alphas):
        raise argparse.ArgumentTypeError(f"{text!r}: alpha must lie in -2 .. 2")
    return alphas[0] if len(alphas) == 1 else alphas


def _tau_range(text: str) -> tuple[float | None, float | None]:
    """``MIN:MAX`` seconds, either side may be empty (open)."""
    parts = text.split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        lo, hi = (float(p) if p.strip() else None for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--tau-range takes MIN:MAX in seconds (either may be empty), got {text!r}"
        ) from None
    for v in (lo, hi):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise argparse.ArgumentTypeError(f"--tau-range bounds must be positive, got {text!r}")
    if lo is not None and hi is not None and not lo < hi:
        raise argparse.ArgumentTypeError(f"--tau-range {text!r}: MIN must be below MAX")
    return lo, hi


def _add_fit_arguments(cmd: argparse.ArgumentParser) -> None:
    """The noise fit's options (:func:`adavar.fit_noise`)."""
    cmd.add_argument(
        "--fit-method", default="auto", choices=("auto", "gls", "wls", "slopes"),
        help="noise fit: gls (full covariance of the taus, term selection, roll-off "
        "handling; the default for one curve), wls (diagonal edf weights, every term; the "
        "default for DAVAR windows and the behaviour before 0.2), slopes (the classical "
        "slope-line read-offs)",
    )  # fmt: skip
    cmd.add_argument(
        "--select", default="significance", choices=("significance", "none"),
        help="gls: keep a term only while C/sigma_C >= --significance (default), or keep "
        "every --terms term",
    )  # fmt: skip
    cmd.add_argument(
        "--significance", type=_positive_float("sigma"), default=2.0, metavar="Z",
        help="gls: the significance a term needs to stay in the model (default: 2)",
    )  # fmt: skip
    cmd.add_argument(
        "--exclude", default="auto", choices=("auto", "none"),
        help="gls: leave out the short taus where the curve rolls off below the model "
        "(a sensor filter, correlated noise; default auto), or fit every tau",
    )  # fmt: skip
    cmd.add_argument(
        "--rolloff", default="model", choices=("model", "none"),
        help="gls: let the tau^-2 term go negative to model a filter's roll-off (default) "
        "or keep Q >= 0",
    )  # fmt: skip
    cmd.add_argument(
        "--tau-range", type=_tau_range, metavar="MIN:MAX",
        help="fit only the taus from MIN to MAX seconds (either may be empty)",
    )  # fmt: skip
    cmd.add_argument(
        "--bandwidth", type=_positive_float("Hz"), metavar="HZ",
        help="the sensor's bandwidth (Hz, datasheet or filter setting): taus below "
        "2/bandwidth are left out of the fit",
    )  # fmt: skip
    cmd.add_argument(
        "--n-reweight", type=_seed, default=3, metavar="N",
        help="reweighting passes of the noise fit after the first, with the model's "
        "variance in the weights (default: 3; 0: weights of the measured variance)",
    )  # fmt: skip
    cmd.add_argument(
        "--spacing", default="octave", choices=("octave", "independent"),
        help="weights of densely spaced taus in the noise fit: octave (default: scaled by "
        "their spacing in octaves, so a dense grid does not count the same information "
        "many times) or independent (as they are)",
    )  # fmt: skip


def _add_chunk_argument(cmd: argparse.ArgumentParser) -> None:
    """--chunk-size: how many samples are read at a time (the out-of-core path)."""
    cmd.add_argument(
        "--chunk-size", type=_positive_int, metavar="N",
        help="read and process the record N samples at a time, for records larger than "
        "memory (default: all at once)",
    )  # fmt: skip


def _add_surface_arguments(cmd: argparse.ArgumentParser) -> None:
    """Options of a DAVAR surface: centres, taus, edges, data type, bounds, fit, file format."""
    cmd.add_argument(
        "--noise-type", type=_noise_type, default="record", metavar="ALPHA",
        help="noise exponent behind the per-cell EDF: record (default: identified per tau on "
        "the whole record), an integer alpha (0 white rate noise/ARW, -1 bias instability, "
        "-2 rate random walk, 1/2 flicker/white PM), or one per tau, comma-separated",
    )  # fmt: skip
    cmd.add_argument(
        "--t0", type=_finite_float, default=0.0, metavar="SECONDS",
        help="time of the first sample (default: 0); window times are t0 + centre / rate",
    )  # fmt: skip
    cmd.add_argument(
        "--step", metavar="S", type=_positive_int, default=1,
        help="centre a window on every S-th sample only (default: 1, every sample)",
    )  # fmt: skip
    cmd.add_argument(
        "--taus", default="all", type=_taus, metavar="SPEC",
        help="all (default: every multiple of tau0 up to a third of the window), octave, "
        "decade, log, or comma-separated taus in seconds",
    )  # fmt: skip
    cmd.add_argument(
        "--edges", default="mirror", choices=EDGES,
        help="mirror (default: every sample is a centre, the record is time-reversed at its "
        "ends) or valid (only windows inside the record)",
    )  # fmt: skip
    cmd.add_argument(
        "--data-type", default="rate", choices=("rate", "phase"),
        help="rate samples (gyro rate, acceleration, fractional frequency) or their "
        "integral (angle, velocity, time error); default: rate",
    )  # fmt: skip
    cmd.add_argument(
        "--confidence", default=0.683, type=_confidence_or_none, metavar="P",
        help="two-sided confidence level of the per-cell bounds (default: 0.683); none: no "
        "bounds and no noise fit (faster, a third of the memory)",
    )  # fmt: skip
    cmd.add_argument(
        "--points-per-decade", default=10, type=_positive_int, metavar="K",
        help="density of --taus log (default: 10)",
    )  # fmt: skip
    cmd.add_argument(
        "--terms", type=_terms, metavar="LIST",
        help="comma-separated terms of the fit of every window (names or Q,N,B,K,R; "
        "default: all five)",
    )  # fmt: skip
    cmd.add_argument(
        "--format", choices=tuple(SURFACE_FORMATS),
        help="file format of the surface in --out: nc (NetCDF, default) or parquet (needs "
        "pyarrow)",
    )  # fmt: skip
    _add_fit_arguments(cmd)
    _add_chunk_argument(cmd)


def build_parser() -> argparse.ArgumentParser:
    """The ``adavar`` argument parser (its ``error`` raises :class:`UsageError`).

    Returns
    -------
    argparse.ArgumentParser
    """
    parser = _Parser(
        prog="adavar",
        description="Allan-family statistics with confidence intervals and IEEE Std 952 "
        "noise-coefficient fits (avar), the dynamic Allan variance of a sliding window with "
        "the noise coefficients over time (davar), fixed and adaptive windows side by side "
        "(compare), and a demonstration (demo).",
    )
    parser.add_argument("--version", action="version", version=f"adavar {__version__}")
    parser.add_argument(
        "--debug", action="store_true", help="show the traceback of internal errors"
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    avar = sub.add_parser(
        "avar",
        help="deviation (and noise fit) of one column of a text file",
        description="Allan-family deviation of one column of a CSV/TSV/whitespace text file, "
        "with confidence intervals, and optionally the fit of the IEEE Std 952 noise terms. "
        "The sampling rate and the unit of the samples are required: adavar never guesses "
        "them.",
    )
    _add_input_arguments(avar)
    avar.add_argument(
        "--stat", default="oadev", choices=STATISTICS, help="statistic (default: oadev)"
    )
    avar.add_argument(
        "--data-type", default="rate", choices=("rate", "phase"),
        help="rate samples (gyro rate, acceleration, fractional frequency) or their "
        "integral (angle, velocity, time error); default: rate",
    )  # fmt: skip
    avar.add_argument(
        "--taus", default="octave", type=_taus, metavar="SPEC",
        help="octave (default), all, decade, log, or comma-separated taus in seconds",
    )  # fmt: skip
    avar.add_argument(
        "--points-per-decade", default=10, type=_positive_int, metavar="K",
        help="density of --taus log (default: 10)",
    )  # fmt: skip
    avar.add_argument(
        "--confidence", default=0.683, type=_confidence, metavar="P",
        help="two-sided confidence level of the intervals (default: 0.683)",
    )  # fmt: skip
    avar.add_argument("--fit", action="store_true", help="fit the IEEE Std 952 noise terms")
    avar.add_argument(
        "--terms", type=_terms, metavar="LIST",
        help="comma-separated terms of the fit (names or Q,N,B,K,R; default: all five); "
        "implies --fit",
    )  # fmt: skip
    _add_fit_arguments(avar)
    _add_chunk_argument(avar)
    avar.add_argument("--json", action="store_true", help="print one JSON object")
    _add_output_arguments(
        avar,
        "also write deviation.csv, result.json and the figure deviation.png/.svg to "
        "this new folder",
    )
    avar.set_defaults(handler=_cmd_avar)

    dav = sub.add_parser(
        "davar",
        help="dynamic Allan variance and noise coefficients over time",
        description="The dynamic Allan variance (DAVAR) of one column of a CSV/TSV/whitespace "
        "text file: the overlapping Allan variance of a window of --window samples centred "
        "on every --step-th sample, with per-cell confidence bounds, and the IEEE Std 952 "
        "noise coefficients of every window (N(t), B(t), ...). Prints a summary (or JSON); "
        "--out writes the surface, the coefficients and the figures. The sampling rate and "
        "the unit of the samples are required: adavar never guesses them.",
    )
    _add_input_arguments(dav)
    dav.add_argument(
        "--window", metavar="L", type=_window_length, required=True,
        help=f"window length in samples (at least {MIN_WINDOW}, at most the record); taus "
        "up to a third of it",
    )  # fmt: skip
    _add_surface_arguments(dav)
    dav.add_argument("--json", action="store_true", help="print one JSON object (a summary)")
    _add_output_arguments(
        dav,
        "also write surface.nc (or .parquet), coefficients.csv, result.json and the "
        "figures davar_surface, davar_heatmap and arw (N(t); of the first term when N is "
        "not fitted: q, bi, rrw or rr) as .png/.svg to this new folder",
    )
    dav.set_defaults(handler=_cmd_davar)

    ada = sub.add_parser(
        "adaptive",
        help="A-DAVAR: the dynamic Allan variance with the paper's adaptive window",
        description="The adaptive-window dynamic Allan variance (A-DAVAR, docs/method.md section "
        "5) of one column of a text file: the window shrinks from --lmax towards --lmin where "
        "the kurtosis leaves [--k1, --k2] or a shock enters its leading --l samples (S > "
        "--s2), and regrows where the noise is stationary; then the surface, its per-cell "
        "bounds and the noise coefficients of every window, as for davar. --method kurtosis "
        "runs DAVAR-K (the kurtosis test alone), --method oracle the ideal schedule for "
        "--change-times. The sampling rate and the unit are required: adavar never guesses.",
    )
    _add_input_arguments(ada)
    ada.add_argument(
        "--method", default="adaptive", choices=("adaptive", "kurtosis", "oracle"),
        help="adaptive (A-DAVAR, default), kurtosis (DAVAR-K) or oracle (needs "
        "--change-times)",
    )  # fmt: skip
    ada.add_argument(
        "--change-times", type=_seconds_list, metavar="T,...",
        help="known change times in seconds, for --method oracle",
    )  # fmt: skip
    _add_controller_arguments(ada)
    _add_surface_arguments(ada)
    ada.add_argument("--json", action="store_true", help="print one JSON object (a summary)")
    _add_output_arguments(
        ada,
        "also write surface.nc (or .parquet), coefficients.csv, result.json and the "
        "figures davar_surface, davar_heatmap, arw and controller (kurtosis, S, flags and "
        "window length over time) as .png/.svg to this new folder",
    )
    ada.set_defaults(handler=_cmd_davar, window=None)

    cmp_ = sub.add_parser(
        "compare",
        help="DAVAR-Lmin, DAVAR-Lmax, DAVAR-K and A-DAVAR side by side (the paper's Table 1)",
        description="Run fixed windows of Lmin and Lmax samples, the kurtosis-only controller "
        "(DAVAR-K) and the adaptive window (A-DAVAR) on the same record, fit N(t) of every "
        "window, and print the node times around each change next to the paper's values, "
        "the ARW interval means and, on a simulated scenario, the ground-truth confidence and "
        "tracking metrics and the kurtosis threshold crossings (the paper's Fig. 8). Give a "
        "data FILE (with --rate and --units, and --change-times for the nodes) or --scenario.",
    )
    _add_input_arguments(cmp_, optional_file=True, several=False)
    cmp_.add_argument(
        "--scenario", type=int, choices=(1, 2),
        help="simulate the paper's scenario 1 (disturbance at 3000-4000 s) or 2 (1000-2000 s "
        "and 4000-5000 s) instead of reading FILE",
    )  # fmt: skip
    cmp_.add_argument(
        "--variance-reading", action="store_true",
        help="scenario disturbance of variance 3 (the paper's text read literally) instead "
        "of standard deviation 3",
    )  # fmt: skip
    cmp_.add_argument(
        "--seed",
        type=_seed,
        default=2018,
        metavar="N",
        help="seed of the (first) simulated realisation (default: 2018)",
    )
    cmp_.add_argument(
        "--seeds", type=_positive_int, default=1, metavar="N",
        help="with --scenario: repeat over N realisations (seeds SEED .. SEED+N-1) and report "
        "medians and quartiles (default: 1)",
    )  # fmt: skip
    cmp_.add_argument(
        "--change-times", type=_seconds_list, metavar="T,...",
        help="known change times of FILE in seconds, for the nodes (and the oracle)",
    )  # fmt: skip
    cmp_.add_argument(
        "--methods", type=_names, metavar="LIST",
        help="comma-separated methods: davar-<L> (fixed window), davar-k, a-davar, oracle "
        "(default: davar-LMIN,davar-LMAX,davar-k,a-davar)",
    )  # fmt: skip
    _add_controller_arguments(cmp_)
    cmp_.add_argument(
        "--taus", type=_taus, metavar="SPEC",
        help="taus of every surface: all (default for one realisation, the paper's), octave "
        "(default with --seeds > 1), decade, log, or comma-separated seconds",
    )  # fmt: skip
    cmp_.add_argument(
        "--terms", type=_terms, metavar="LIST",
        help="terms of the noise fit of every window (default: all five, the paper's)",
    )  # fmt: skip
    cmp_.add_argument(
        "--confidence", default=0.683, type=_confidence, metavar="P",
        help="level of the per-cell bounds whose EDF weights the fits (default: 0.683)",
    )  # fmt: skip
    cmp_.add_argument(
        "--noise-type", type=_noise_type, default="record", metavar="ALPHA",
        help="noise exponent behind the per-cell EDF: record (default), an integer alpha "
        "from -2 to 2, or one per tau (comma-separated)",
    )  # fmt: skip
    cmp_.add_argument(
        "--points-per-decade", default=10, type=_positive_int, metavar="K",
        help="density of --taus log (default: 10)",
    )  # fmt: skip
    cmp_.add_argument(
        "--intervals", type=_intervals, metavar="A:B,...",
        help="ARW(A~B) interval means, seconds (default: the scenario's, the paper's; for a "
        "FILE the stretches between --change-times)",
    )  # fmt: skip
    cmp_.add_argument(
        "--truth-column", metavar="NAME",
        help="column of FILE holding the true N of every sample, for the ground-truth "
        "metrics",
    )  # fmt: skip
    cmp_.add_argument(
        "--crossing-window", type=_window_length, metavar="L",
        help="fixed window of the kurtosis-crossing study, the paper's Fig. 8 (default: "
        "--lmax)",
    )  # fmt: skip
    cmp_.add_argument(
        "--crossing-thresholds", type=_threshold_list, metavar="K,...",
        help="its K2 thresholds (default: 3.3,3.45,4 and --k2)",
    )  # fmt: skip
    cmp_.add_argument("--json", action="store_true", help="print one JSON object")
    _add_output_arguments(
        cmp_,
        "also write the tables (CSV), result.json and the figures (the paper's Figs. 6, "
        "7, 8, 10, 11, 12 as .png/.svg) to this new folder",
    )
    cmp_.set_defaults(handler=_cmd_compare)

    rep = sub.add_parser(
        "report",
        help="one self-contained interactive HTML report of a record",
        description="Analyse one column of a record (or several, --column a,b: a section "
        "each) and write ONE self-contained HTML file "
        "(interactive plots, no network): the overlapping Allan deviation with confidence "
        "bars and the fitted noise terms, the coefficient table with uncertainties, and with "
        "--window or --adaptive the rotatable DAVAR surface, the coefficients over time and "
        "(A-DAVAR) the controller's kurtosis, S, flags and window length; plus every "
        "parameter and preprocessing step used.",
    )
    _add_input_arguments(rep)
    rep.add_argument(
        "-o", "--output", metavar="FILE.html", required=True,
        help="the report to write (atomically; an existing file needs --force)",
    )  # fmt: skip
    rep.add_argument(
        "--data-type", default="rate", choices=("rate", "phase"),
        help="rate samples (default) or their integral (angle, velocity, time error)",
    )  # fmt: skip
    rep.add_argument(
        "--window", metavar="L", type=_window_length,
        help="also a fixed-window DAVAR of L samples (surface and coefficients over time)",
    )  # fmt: skip
    rep.add_argument(
        "--adaptive", action="store_true",
        help="also the adaptive-window DAVAR (A-DAVAR, the controller settings below)",
    )  # fmt: skip
    _add_controller_arguments(rep)
    rep.add_argument(
        "--taus", default="octave", type=_taus, metavar="SPEC",
        help="taus of the DAVAR surface: octave (default), all, decade, log or seconds",
    )  # fmt: skip
    rep.add_argument(
        "--step", metavar="S", type=_positive_int, default=1,
        help="DAVAR centres every S samples (default: 1)",
    )  # fmt: skip
    rep.add_argument(
        "--terms", type=_terms, metavar="LIST",
        help="terms of the noise fits (names or Q,N,B,K,R; default: all five)",
    )  # fmt: skip
    _add_fit_arguments(rep)
    rep.add_argument("--title", help="title of the report (default: the file and column)")
    rep.add_argument("--json", action="store_true", help="print one JSON object")
    rep.add_argument("--force", action="store_true", help="replace an existing --output")
    rep.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )
    rep.set_defaults(handler=_cmd_report)

    bat = sub.add_parser(
        "batch",
        help="many logs at once, one task per file, on a dask cluster or in this process",
        description="Analyse every file as 'adavar report FILE' does (same options, same "
        "numbers), one task per file: in this process one by one (default), on a local "
        "cluster of --workers N processes, or on the workers of a running 'dask scheduler' "
        "(--scheduler). Each file gets OUT/<name>/ with report.html, result.json (fit with "
        "uncertainties, events, parameters, preprocessing) and deviation.csv, written "
        "atomically; OUT/summary.csv and summary.parquet hold one row per file. A bad file "
        "is an error row and does not stop the batch; a rerun skips the files done (same "
        "size, modification time and options). Exit code 0: every file ok; 2: some file "
        "(or the command line) has a user error; 1: an internal error.",
    )
    bat.add_argument(
        "inputs", metavar="GLOB|FILE", nargs="*",
        help="files or quoted glob patterns ('logs/*.csv', 'data/**/*.npy')",
    )  # fmt: skip
    bat.add_argument("--files-from", metavar="LIST.txt",
                     help="also the files listed in this text file, one path per line "
                     "(relative to its folder; # comments)")  # fmt: skip
    # the analysis options are those of adavar report (the same objects: they cannot drift)
    for action in rep._actions:
        if action.dest not in ("help", "file", "output", "json", "force", "title", "debug",
                               "config"):  # fmt: skip
            bat._add_action(action)
    bat.add_argument("--out", metavar="DIR", required=True,
                     help="output folder (created; an earlier batch's folder is reused and "
                     "its finished files skipped)")  # fmt: skip
    bat.add_argument("--scheduler", metavar="ADDRESS",
                     help="address of a running dask scheduler (tcp://HOST:8786) or its "
                     "--scheduler-file JSON; its workers must see the files and --out")  # fmt: skip
    bat.add_argument("--workers", metavar="N", type=_positive_int,
                     help="start a local cluster of N single-threaded worker processes "
                     "(default: no cluster, the files one by one in this process)")  # fmt: skip
    bat.add_argument("--timeout", metavar="SECONDS", type=_positive_float("seconds"),
                     default=10.0, help="wait this long for the scheduler and its first "
                     "worker (default: 10)")  # fmt: skip
    bat.add_argument("--force", action="store_true",
                     help="recompute the files an earlier run of this --out finished")  # fmt: skip
    bat.add_argument("--no-html", dest="html", action="store_false",
                     help="skip each file's report.html (about 5 MB each: it embeds "
                     "plotly.js); result.json and deviation.csv are still written")  # fmt: skip
    bat.add_argument("--json", action="store_true", help="print one JSON object")
    bat.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                     help=argparse.SUPPRESS)  # fmt: skip
    bat.set_defaults(handler=_cmd_batch)

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
        type=_names,
        default=["gx", "gy", "gz"],
        metavar="X,Y,Z",
        help="gyro columns (default: gx,gy,gz, the names of a ROS bag)",
    )
    kal.add_argument(
        "--accel",
        type=_names,
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
        type=_positive_float("Hz"),
        help="sample rate, if the file has no time stamps",
    )
    kal.add_argument("--time-column", metavar="NAME", help="column of time stamps")
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
        "--pinned", default="error", choices=("error", "bound"),
        help="an axis whose N or K the fit pins at 0 (e.g. K of a short record) is an error "
        "(default) or contributes its 1-sigma upper bound",
    )  # fmt: skip
    kal.add_argument(
        "--inflate",
        type=_positive_float("a factor"),
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
    kal.set_defaults(handler=_cmd_kalibr)

    sim = sub.add_parser(
        "simulate",
        help="write a simulated record (a noisy sensor or the paper's scenarios) to CSV",
        description="Simulate rate samples with known noise terms (seeded), or the A-DAVAR "
        "paper's scenario 1 or 2, and write them as a CSV with a time column, ready for the "
        "other commands.",
    )
    sim.add_argument(
        "-o",
        "--output",
        metavar="FILE.csv",
        required=True,
        help="the CSV to write (atomically; existing needs --force)",
    )
    sim.add_argument(
        "--scenario",
        type=int,
        choices=(1, 2),
        help="the paper's scenario 1 or 2 (6000 s at 1 Hz, unit white noise)",
    )
    sim.add_argument(
        "--n",
        type=_positive_int,
        default=100_000,
        metavar="N",
        help="number of samples of a simulated sensor (default: 100000)",
    )
    sim.add_argument(
        "--rate",
        type=_positive_float("Hz"),
        default=100.0,
        metavar="HZ",
        help="sample rate of a simulated sensor (default: 100)",
    )
    for flag, name in (("--quantization", "Q, unit*s"), ("--arw", "N, unit*sqrt(s)"),
                       ("--bias-instability", "B, unit"), ("--rrw", "K, unit/sqrt(s)"),
                       ("--rate-ramp", "R, unit/s")):  # fmt: skip
        sim.add_argument(
            flag,
            type=_finite_float,
            default=0.0,
            metavar="VALUE",
            help=f"coefficient {name} (default: 0)",
        )
    sim.add_argument(
        "--bias",
        type=_finite_float,
        default=0.0,
        metavar="VALUE",
        help="constant bias added to every sample (default: 0)",
    )
    sim.add_argument("--markov", type=_number_tuple("--markov", 2, 2), metavar="STD,TAU",
                     help="first-order Gauss-Markov term: standard deviation (unit) and "
                     "correlation time (s)")  # fmt: skip
    sim.add_argument("--sinusoid", type=_number_tuple("--sinusoid", 2, 3),
                     metavar="AMP,HZ[,PHASE]",
                     help="deterministic sinusoid: amplitude (unit), frequency (Hz) and "
                     "phase (rad, default 0)")  # fmt: skip
    sim.add_argument("--bandwidth", type=_positive_float("Hz"), metavar="HZ",
                     help="the sensor's low-pass filter: -3 dB bandwidth in Hz, below "
                     "rate/2 (default: none)")  # fmt: skip
    sim.add_argument("--filter-order", type=_positive_int, default=2, metavar="N",
                     help="order of that Butterworth filter (default: 2)")  # fmt: skip
    sim.add_argument("--lsb", type=_positive_float("units"), metavar="STEP",
                     help="quantise the output to this step (the sensor's LSB, in the "
                     "unit; default: none)")  # fmt: skip
    sim.add_argument("--variance-reading", action="store_true",
                     help="--scenario disturbance of variance 3 (the paper's text read "
                     "literally) instead of standard deviation 3")  # fmt: skip
    sim.add_argument(
        "--units",
        default="deg/s",
        metavar="UNIT",
        help="unit written in the header (default: deg/s)",
    )
    sim.add_argument("--seed", type=_seed, default=2018, metavar="N", help="seed (default: 2018)")
    sim.add_argument("--json", action="store_true", help="print one JSON object")
    sim.add_argument("--force", action="store_true", help="replace an existing --output")
    sim.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )
    sim.set_defaults(handler=_cmd_simulate)

    demo = sub.add_parser(
        "demo",
        help="NIST SP 1065 check values, a simulated MEMS gyro and the paper's scenario 1",
        description="Reproduce the NIST SP 1065 published deviations, fit the noise terms "
        "of a simulated MEMS gyroscope with known coefficients, and run the A-DAVAR paper's "
        "scenario 1 end to end (DAVAR-400/600, DAVAR-K and A-DAVAR: nodes next to the paper's "
        "Table 1, metrics, Fig. 8 crossings); writes the figures and tables.",
    )
    demo.add_argument(
        "--out", metavar="DIR", default=DEMO_DEFAULT_OUT,
        help=f"output folder (default: ./{DEMO_DEFAULT_OUT}; replaced if it is an earlier "
        "demo's folder)",
    )  # fmt: skip
    demo.add_argument("--json", action="store_true", help="print one JSON object")
    demo.add_argument(
        "--seed", type=_seed, default=2018, metavar="N", help="seed of the simulated gyro"
    )
    demo.add_argument(
        "--force", action="store_true",
        help="replace --out even if it is not a folder written by adavar demo",
    )  # fmt: skip
    demo.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )
    demo.set_defaults(handler=_cmd_demo)
    for cmd in sub.choices.values():  # read by _with_config before parsing; listed for --help
        cmd.add_argument(
            "--config", metavar="FILE.toml",
            help="read options from a TOML file (top level or a [command] table, by long "
            "option name); flags on the command line override it",
        )  # fmt: skip
    return parser


# --------------------------------------------------------------------------------------
# JSON and tables
# --------------------------------------------------------------------------------------


def _jsonable(obj: Any) -> Any:
    """Plain Python objects for json: arrays to lists, NaN/inf to None."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_jsonable(v) for v in obj.tolist()]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        value = float(obj)
        return value if math.isfinite(value) else None
    return obj


def _dumps(payload: dict[str, Any]) -> str:
    return json.dumps(_jsonable(payload), indent=2, allow_nan=False)


def _deviation_json(result: DeviationResult) -> dict[str, Any]:
    return {
        "stat": result.stat,
        "confidence": result.confidence,
        "tau": result.tau,
        "dev": result.dev,
        "dev_low": result.dev_low,
        "dev_high": result.dev_high,
        "edf": result.edf,
        "n": result.n,
        "m": result.m,
        "alpha": result.alpha,
        "notes": list(result.notes),
    }


def _conventional(fit: NoiseFit) -> Any:
    """``fit.to_units()`` if the declared unit is an accepted rate unit, else None."""
    if fit.units is None:
        return None
    try:
        return fit.to_units()
    except ValueError:
        return None


def _fit_json(fit: NoiseFit) -> dict[str, Any]:
    from adavar.plots import term_unit

    out: dict[str, Any] = {}
    for name in TERM_NAMES:
        term = fit.term(name)
        out[name] = {
            "value": term.value,
            "uncertainty": term.uncertainty,
            "unit": term_unit(name, fit.units),
        }
    conv = _conventional(fit)
    out["conventional"] = (
        None
        if conv is None
        else {
            name: {"value": t.value, "uncertainty": t.uncertainty, "unit": t.unit}
            for name, t in conv.as_dict().items()
        }
    )
    out["reduced_chi2"] = fit.reduced_chi2
    out["chi2"] = fit.chi2
    out["dof"] = fit.dof
    out["n_points"] = fit.n_points
    out["terms"] = list(fit.terms)
    out["method"] = fit.method
    out["dropped"] = list(fit.dropped)
    out["adequate"] = bool(fit.adequate)
    out["p_value"] = fit.p_value
    out["rolloff"] = fit.rolloff
    out["warnings"] = list(fit.warnings)
    out["excluded"] = [
        {"tau_s": float(t), "reason": r} for t, r in zip(fit.tau, fit.exclusions, strict=True) if r
    ]
    out["residuals"] = None if fit.residuals is None else list(fit.residuals)
    if fit.slopes is not None:
        out["slopes"] = {
            n: {"value": v, "uncertainty": fit.slopes.uncertainty[n],
                "anchor_tau_s": fit.slopes.anchor_tau[n], "unit": term_unit(n, fit.units)}
            for n, v in fit.slopes.values.items()
        }  # fmt: skip
    return out


def _table(headers: Sequence[str], rows: Sequence[Sequence[str]], indent: str = "") -> str:
    """Right-aligned columns (the first left-aligned)."""
    widths = [max(len(h), *(len(r[j]) for r in rows)) for j, h in enumerate(headers)]

    def line(cells: Sequence[str]) -> str:
        parts = [
            cell.ljust(w) if j == 0 else cell.rjust(w)
            for j, (cell, w) in enumerate(zip(cells, widths, strict=True))
        ]
        return indent + "  ".join(parts).rstrip()

    return "\n".join([line(headers), *(line(r) for r in rows)])


def _deviation_table(result: DeviationResult, indent: str = "") -> str:
    headers = ["tau [s]", "n", "alpha", "edf", "dev", "dev_low", "dev_high"]
    rows = [
        [
            f"{tau:.6g}",
            f"{n:d}",
            f"{alpha:d}",
            f"{edf:.5g}",
            f"{dev:.6e}",
            f"{low:.6e}",
            f"{high:.6e}",
        ]
        for tau, n, alpha, edf, dev, low, high in zip(
            result.tau,
            result.n,
            result.alpha,
            result.edf,
            result.dev,
            result.dev_low,
            result.dev_high,
            strict=True,
        )
    ]
    return _table(headers, rows, indent)


def _fit_lines(fit: NoiseFit, indent: str = "", true: dict[str, Any] | None = None) -> list[str]:
    from adavar.plots import TERM_LABELS, format_pm, term_unit

    conv = _conventional(fit)
    red = float(fit.reduced_chi2)
    terms = "all five terms" if len(fit.terms) == 5 else ", ".join(fit.terms)
    how = {
        "gls": "generalised least squares with the covariance of the taus, terms kept where "
        "significant",
        "wls": "non-negative least squares weighted by each point's edf",
        "slopes": "slope-line read-offs",
    }[fit.method]
    lines = [
        f"{indent}Noise fit ({terms}; {how}): reduced chi2 = "
        f"{f'{red:.3g}' if math.isfinite(red) else 'n/a'} "
        f"(chi2 = {float(fit.chi2):.4g}, dof = {int(fit.dof)})"
    ]
    lines += [f"{indent}warning: {w}" for w in fit.warnings]
    if int(fit.n_points) < len(fit.terms):
        lines.append(
            f"{indent}(not fitted: {int(fit.n_points)} usable points for {len(fit.terms)} "
            "terms; use more taus, e.g. --taus all, or fewer --terms)"
        )
    if fit.units and conv is None:
        lines.append(
            f"{indent}(no conventional units for {fit.units!r}: declare deg/s, deg/h, rad/s, "
            "m/s^2 or g to get them)"
        )
    headers = ["term", "value ± 1 sigma (data units)"]
    if conv is not None:
        headers.append("value ± 1 sigma (conventional)")
    if true is not None:
        headers += ["true value", "error"]
    rows = []
    for name in TERM_NAMES:
        letter, long_name = TERM_LABELS[name]
        term = fit.term(name)
        row = [f"{letter}  {long_name}"]
        if name not in fit.terms:
            row += ["not in the model"] * (2 if conv is not None else 1)
        else:
            row.append(format_pm(term.value, term.uncertainty, term_unit(name, fit.units)))
            if conv is not None:
                c = conv[name]
                row.append(format_pm(c.value, c.uncertainty, c.unit))
        if true is not None:
            value, unit = true[name]
            row.append(f"{value:g} {unit}")
            fitted = float(conv[name].value) if conv is not None else float(term.value)
            row.append(f"{100 * (fitted / value - 1):+.1f} %" if value else "")
        rows.append(row)
    lines.append(_table(headers, rows, indent))
    lines.append(
        f"{indent}(0 (< x): pinned at zero or left out as not significant, x is a "
        "1-sigma upper bound)"
    )
    if fit.slopes is not None:
        read = []
        for n, v in fit.slopes.values.items():
            if math.isfinite(v):
                unc = fit.slopes.uncertainty[n]
                read.append(f"{TERM_LABELS[n][0]} {format_pm(v, unc, term_unit(n, fit.units))}")
        if read:
            lines.append(f"{indent}slope-line read-offs: " + "; ".join(read))
    return lines


def _write_csv(path: Path, result: DeviationResult, comment: str) -> None:
    buffer = _stdio.StringIO()
    buffer.write(f"# {comment}\n")
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["tau_s", "n", "m", "alpha", "edf", "dev", "dev_low", "dev_high"])
    for row in zip(
        result.tau, result.n, result.m, result.alpha, result.edf, result.dev,
        result.dev_low, result.dev_high, strict=True,
    ):  # fmt: skip
        tau, n, m, alpha, edf, dev, low, high = row
        writer.writerow(
            [repr(float(tau)), int(n), int(m), int(alpha), repr(float(edf)),
             repr(float(dev)), repr(float(low)), repr(float(high))]
        )  # fmt: skip
    path.write_text(buffer.getvalue(), encoding="utf-8")


def _guard_replacement(out: str, protected: Sequence[Path]) -> None:
    """Refuse to replace a folder that holds the current directory or a protected path."""
    target = Path(out).expanduser().resolve()
    if not target.is_dir():
        return
    for path in (Path.cwd(), *protected):
        resolved = path.resolve()
        if resolved == target or target in resolved.parents:
            raise AdavarInputError(
                f"--out {out} holds {path if path != Path.cwd() else 'the current folder'}; "
                "replacing it would delete that: choose another output folder"
            )


def _output_error(out: str | os.PathLike[str], exc: OSError) -> AdavarInputError:
    return AdavarInputError(f"cannot write the output folder {out}: {exc.strerror or exc}")


# --------------------------------------------------------------------------------------
# Commands
# --------------------------------------------------------------------------------------


def _load(
    args: argparse.Namespace,
    *,
    several: bool = False,
    pieces: bool | None = None,
    out_of_core: bool = False,
) -> tuple[Any, dict[str, Any], Any, float]:
    """Read FILE's column, preprocess it, and settle its unit and tau0 (seconds).

    With ``out_of_core`` (commands whose analysis streams: avar, davar, adaptive), a
    memory-mapped ``.npy`` column or a lazy HDF5/Parquet channel is passed on as it is,
    so a record larger than memory is read piece by piece; preprocessing loads it.

    With ``several``, every selected channel (``--column gx,gy,gz``, or all numeric
    columns) is returned: a dict name -> samples, and a dict name -> unit. With
    ``pieces`` (default: ``several``), ``--gaps split`` gives each gap-free piece of a
    channel as a channel of its own.

    The rate comes from --rate/--tau0 or from the file's time stamps (both: they must
    agree); the unit from --units or from the format (ROS bags declare rad/s and m/s^2).
    """
    from adavar.preprocess import preprocess
    from adavar.readers import read_record

    if args.rate is not None and args.tau0 is not None:
        raise UsageError("give exactly one of --rate HZ or --tau0 SECONDS (both given)")
    declared = args.rate if args.rate is not None else (
        1.0 / args.tau0 if args.tau0 is not None else None
    )  # fmt: skip
    option = partial(getattr, args)
    record = read_record(
        args.file, columns=args.column, rate=declared,
        time_column=option("time_column", None), time_format=option("time_format", "auto"),
        gaps=option("gaps", "error"), nan=option("nan", "error"),
        dataset=option("dataset", None), topic=option("topic", None),
        gap_tolerance=option("gap_tolerance", 0.5), lazy=option("lazy", None),
    )  # fmt: skip
    if len(record.names) != 1 and not several:
        raise UsageError(
            f"{args.file} has {len(record.names)} channels ({', '.join(record.names)}): "
            "choose one with --column"
            + ("" if getattr(args, "command", None) == "compare"
               else " (or several, comma-separated, e.g. --column a,b)")
        )  # fmt: skip
    declared_units = record.meta.get("units") or {}
    given = args.units.strip() if args.units and args.units.strip() else None
    units_of = {name: given or declared_units.get(name) for name in record.names}
    if not all(units_of.values()):
        raise UsageError(
            "declare the unit of the samples with --units (e.g. --units deg/s); adavar never "
            "guesses units"
        )
    rate = float(record.rate)
    steps: list[dict[str, Any]] = []
    channels: dict[str, np.ndarray] = {}
    split = record.segments is not None and len(record.segments) > 1
    if split and not (several if pieces is None else pieces):
        raise UsageError(
            f"{args.file} has {len(record.segments)} gap-free pieces: --gaps split is for "
            "adavar avar; here use --gaps interpolate, or give a file with one piece"
        )
    for name in record.names:
        pieces = record.pieces(name) if split else [record.channel(name)]
        for k, piece in enumerate(pieces):
            preprocessing = bool(getattr(args, "preprocess", None))
            if out_of_core and not preprocessing and stream.is_chunked(piece):
                x = piece
            else:
                x = np.asarray(piece, dtype=np.float64)
            if preprocessing:
                x, new_rate, steps = preprocess(x, rate=float(record.rate),
                                                steps=args.preprocess)  # fmt: skip
                rate = float(new_rate)
            key = f"{name} piece {k + 1}" if split else name
            channels[key] = x
            units_of[key] = units_of[name]
    name = next(iter(channels))
    samples = channels[name]
    units = units_of[name]
    if args.tau0 is not None and not steps:
        tau0 = float(args.tau0)
    else:
        tau0 = 1.0 / rate
    if args.rate is not None and not steps:
        args_rate = float(args.rate)
    else:
        args_rate = rate
    args.rate, args.tau0 = (args_rate, None) if args.tau0 is None or steps else (None, tau0)
    meta = {
        "path": str(args.file), "column": name, "kind": record.kind,
        "rate_from": "declared" if declared is not None else "time stamps",
        "reader": record.meta, "preprocessing": steps, "columns": list(record.names),
        "pieces": None if not split else [
            [float(record.time[sl.start]), float(record.time[sl.stop - 1])]
            for sl in record.segments
        ],
    }  # fmt: skip
    if several:
        return channels, meta, units_of, tau0
    return samples, meta, units, tau0


def _cmd_avar(args: argparse.Namespace) -> int:
    do_fit = args.fit or args.terms is not None
    if do_fit and args.stat not in ALLAN_STATS:
        raise UsageError(
            f"--fit needs an Allan statistic ({', '.join(sorted(ALLAN_STATS))}), not "
            f"--stat {args.stat}"
        )
    if args.out is not None:
        check_output_directory(args.out, replace=args.force)
        _guard_replacement(args.out, [Path(args.file)])

    status = _Status()
    status(f"reading {args.file}")
    channels, meta, units_of, tau0 = _load(args, several=True, out_of_core=True)
    runs = []
    for k, (name, samples) in enumerate(channels.items()):
        meta_c = {**meta, "column": name}
        tag = f"{name} ({k + 1}/{len(channels)}): " if len(channels) > 1 else ""
        runs.append(_avar_channel(args, samples, meta_c, units_of[name], tau0, do_fit,
                                  status, tag))  # fmt: skip
    several = len(runs) > 1
    if several:
        payload: dict[str, Any] = {
            "adavar_version": __version__,
            "input": {"file": meta["path"], "columns": list(channels), "rate": 1.0 / tau0,
                      "tau0": tau0, "data_type": args.data_type},
            "channels": {run["name"]: run["payload"] for run in runs},
        }  # fmt: skip
    else:
        payload = runs[0]["payload"]
    if meta["preprocessing"]:
        payload.setdefault("input", {})["preprocessing"] = [
            step.get("spec", str(step)) for step in meta["preprocessing"]
        ]
    text = _dumps(payload)

    written: list[str] = []
    if args.out is not None:
        from adavar.plots import deviation_figure, save_figure

        try:
            with atomic_directory(args.out, replace=args.force) as tmp:
                for run in runs:
                    status(f"writing {args.out}: {run['name']}")
                    prefix = f"{_safe_name(run['name'])}_" if several else ""
                    _write_csv(tmp / f"{prefix}deviation.csv", run["result"], run["comment"])
                    fig = deviation_figure(run["result"], run["fit"], title=run["title"])
                    save_figure(fig, tmp / f"{prefix}deviation")
                    written += [f"{prefix}deviation.csv", f"{prefix}deviation.png",
                                f"{prefix}deviation.svg"]  # fmt: skip
                (tmp / "result.json").write_text(text + "\n", encoding="utf-8")
                written.append("result.json")
        except OSError as exc:
            raise _output_error(args.out, exc) from None
    status.close()

    if args.json:
        print(text)
        if written:
            print(f"adavar: wrote {args.out}/ ({', '.join(written)})", file=sys.stderr)
        return EXIT_OK
    for k, run in enumerate(runs):
        if k:
            print()
        print("\n".join(run["lines"]))
    if written:
        print()
        print(f"wrote {args.out}/ ({', '.join(written)})")
    return EXIT_OK


def _safe_name(name: str) -> str:
    """A channel name usable in a file name."""
    cleaned = "".join(c if c.isalnum() or c in "-_." else "_" for c in name).strip("._")
    return cleaned or "channel"


def _avar_channel(
    args: argparse.Namespace, samples: np.ndarray, meta: dict[str, Any], units: str,
    tau0: float, do_fit: bool, status: _Status | None = None, tag: str = "",
) -> dict[str, Any]:  # fmt: skip
    """The deviation (and fit) of one channel: results, JSON payload and printed lines."""
    from adavar.plots import STAT_NAMES, deviation_unit, rate_unit

    status = status or _Status()
    rate_u = rate_unit(units, args.data_type)
    status(f"{tag}computing the {args.stat} of {samples.size} samples")
    result = deviation(
        samples,
        stat=args.stat,
        tau0=tau0,
        data_type=args.data_type,
        taus=args.taus,
        confidence=args.confidence,
        points_per_decade=args.points_per_decade,
        units=rate_u,
        **_chunk_keywords(args),
    )
    fit = None
    if do_fit:
        status(f"{tag}fitting the noise terms")
        try:
            fit = fit_noise(result, **_fit_keywords(args))
        except ValueError as exc:
            raise AdavarInputError(f"column {meta['column']!r}: {exc}") from None
    payload: dict[str, Any] = {
        "adavar_version": __version__,
        "input": {
            "file": meta["path"],
            "column": meta["column"],
            "rate": 1.0 / tau0,
            "tau0": tau0,
            "units": units,
            "data_type": args.data_type,
            "n_samples": result.n_samples,
        },
        "units": deviation_unit(args.stat, rate_u),
        **_deviation_json(result),
    }
    if fit is not None:
        payload["fit"] = _fit_json(fit)
    dev_u = deviation_unit(args.stat, rate_u)
    lines = [
        f"{meta['path']}, column {meta['column']!r}: {result.n_samples} samples, "
        f"{args.data_type} data in {units}, tau0 = {tau0:g} s ({1.0 / tau0:g} Hz)",
        f"{STAT_NAMES[args.stat]} ({args.stat.upper()})"
        + (f" [{dev_u}]" if dev_u else "")
        + f", {100 * result.confidence:.1f} % confidence intervals",
        _deviation_table(result),
    ]
    lines += [f"note: {note}" for note in result.notes]
    if result.dev.size and not np.any(result.dev):  # a constant column (no full pass)
        lines.append(f"note: column {meta['column']!r} is constant: its deviation is 0")
    if fit is not None:
        lines += ["", *_fit_lines(fit)]
    return {
        "name": meta["column"], "result": result, "fit": fit, "payload": payload,
        "lines": lines, "title": f"{Path(meta['path']).name}, column {meta['column']}",
        "comment": f"adavar {__version__}: {args.stat} of {meta['path']} column "
        f"{meta['column']!r}; {args.data_type} data, tau0 = {tau0:g} s, deviation in "
        f"{dev_u or 'data units'}",
    }  # fmt: skip


def _series_stats(values: Any, times: np.ndarray) -> dict[str, Any]:
    """Median, 5th/95th percentiles, extremes (with their times) and mean of a time series,
    over its finite values (None where there are none)."""
    v = np.asarray(values, dtype=float).reshape(-1)
    ok = np.isfinite(v)
    keys = ("median", "p05", "p95", "min", "max", "mean", "time_of_min", "time_of_max")
    if not ok.any():
        return {"n": 0, **dict.fromkeys(keys)}
    where = np.flatnonzero(ok)
    finite = v[ok]
    p05, median, p95 = np.percentile(finite, [5.0, 50.0, 95.0])
    return {
        "n": int(finite.size),
        "median": float(median),
        "p05": float(p05),
        "p95": float(p95),
        "min": float(finite.min()),
        "max": float(finite.max()),
        "mean": float(finite.mean()),
        "time_of_min": float(times[where[np.argmin(finite)]]),
        "time_of_max": float(times[where[np.argmax(finite)]]),
    }


def _fitted_windows(fit: NoiseFit) -> np.ndarray:
    """True for every window whose fit succeeded (all coefficients finite)."""
    return np.all(np.isfinite(np.asarray(fit.coefficients)), axis=-1).reshape(-1)


def _davar_fit_json(fit: NoiseFit, times: np.ndarray) -> dict[str, Any]:
    from adavar.plots import term_unit

    conv = _conventional(fit)
    fitted = _fitted_windows(fit)
    terms: dict[str, Any] = {}
    for name in TERM_NAMES:
        if name not in fit.terms:
            terms[name] = None
            continue
        term = fit.term(name)
        terms[name] = {
            "unit": term_unit(name, fit.units),
            "value": _series_stats(term.value, times),
            "uncertainty": _series_stats(term.uncertainty, times),
            "conventional": None
            if conv is None
            else {"unit": conv[name].unit, "value": _series_stats(conv[name].value, times)},
        }
    return {
        "terms": list(fit.terms),
        "n_windows": int(fitted.size),
        "n_fitted": int(np.count_nonzero(fitted)),
        "coefficients": terms,
        "reduced_chi2": _series_stats(fit.reduced_chi2, times),
    }


def _coefficient_term(fit: NoiseFit) -> str:
    """The term drawn in the coefficient figure: N if fitted, else the first fitted term."""
    return "angle_random_walk" if "angle_random_walk" in fit.terms else fit.terms[0]


def _write_coefficients(path: Path, result: DavarResult, fit: NoiseFit, comment: str) -> None:
    columns: list[tuple[str, Any]] = [("time_s", result.time), ("window", result.window)]
    for name in fit.terms:
        term = fit.term(name)
        columns += [(name, term.value), (f"{name}_uncertainty", term.uncertainty)]
    columns.append(("reduced_chi2", fit.reduced_chi2))
    lists = [np.asarray(values).reshape(-1).tolist() for _, values in columns]
    buffer = _stdio.StringIO()
    buffer.write(f"# {comment}\n")
    buffer.write(",".join(name for name, _ in columns) + "\n")
    # str() of a Python float is its shortest round-trip form, as repr()
    buffer.writelines(",".join(map(str, row)) + "\n" for row in zip(*lists, strict=True))
    path.write_text(buffer.getvalue(), encoding="utf-8")


def _davar_summary(
    result: DavarResult, fit: NoiseFit | None, meta: dict[str, Any], units: str,
    data_type: str, written: list[str], out: str | None,
) -> list[str]:  # fmt: skip
    from adavar.plots import TERM_LABELS, term_unit

    tau0 = float(result.tau0)
    window = np.asarray(result.window)
    n_time, n_tau = np.shape(result.avar)
    every = "every sample" if result.step == 1 else f"every {result.step} samples"
    bounds = (
        "no confidence bounds"
        if result.avar_low is None
        else f"{100 * result.confidence:.1f} % confidence bounds"
    )
    lines = [
        f"{meta['path']}, column {meta['column']!r}: {result.n_samples} samples, "
        f"{data_type} data in {units}, tau0 = {tau0:g} s ({1.0 / tau0:g} Hz), "
        f"{result.n_samples * tau0:g} s",
        (
            f"Dynamic Allan deviation: window {int(window[0])} samples "
            f"({int(window[0]) * tau0:g} s)"
            if not hasattr(result, "method")
            else f"Adaptive dynamic Allan deviation ({result.method}): window "
            f"{int(window.min())} .. {int(window.max())} samples, shorter than "
            f"{result.parameters['lmax']} at {np.mean(window < result.parameters['lmax']):.1%} "
            "of the centres,"
        )
        + f" centred on {every}, {result.edges} edges: "
        f"{n_time} window{'s' if n_time != 1 else ''} ({result.time[0]:g} s .. "
        f"{result.time[-1]:g} s) x {n_tau} tau{'s' if n_tau != 1 else ''} "
        f"({result.tau[0]:g} s .. {result.tau[-1]:g} s), {bounds}",
    ]
    lines += [f"note: {note}" for note in result.notes]
    if fit is None:
        lines.append("(no noise fit: --confidence none computes no EDF to weight it)")
    else:
        fitted = _fitted_windows(fit)
        terms = "all five terms" if len(fit.terms) == 5 else ", ".join(fit.terms)
        red = _series_stats(fit.reduced_chi2, result.time)["median"]
        lines.append("")
        lines.append(
            f"Noise coefficients of every window ({terms}): {int(fitted.sum())} of "
            f"{fitted.size} windows fitted; median reduced chi2 = "
            + (f"{red:.3g}" if red is not None else "n/a")
        )
        if not fitted.all():
            lines.append(
                f"({fitted.size - int(fitted.sum())} windows not fitted, too few taus for the "
                "terms: NaN; use more taus or fewer --terms)"
            )
        conv = _conventional(fit)
        times = np.asarray(result.time)

        def row(label: str, unit: str | None, values: Any) -> list[str]:
            st = _series_stats(values, times)
            if st["n"] == 0:
                return [label, unit or "", *(["n/a"] * 5)]
            return [
                label, unit or "1", f"{st['median']:.4g}", f"{st['p05']:.4g}",
                f"{st['p95']:.4g}", f"{st['max']:.4g}", f"{st['time_of_max']:g}",
            ]  # fmt: skip

        rows = []
        for name in fit.terms:
            letter, long_name = TERM_LABELS[name]
            rows.append(row(f"{letter}  {long_name}", term_unit(name, fit.units),
                            fit.term(name).value))  # fmt: skip
            if conv is not None:
                rows.append(row("", conv[name].unit, conv[name].value))
        headers = ["term", "unit", "median", "5 %", "95 %", "max", "max at t [s]"]
        lines.append(_table(headers, rows, "  "))
        if fit.units and conv is None:
            lines.append(
                f"  (no conventional units for {fit.units!r}: declare deg/s, deg/h, rad/s, "
                "m/s^2 or g to get them)"
            )
    if written:
        lines += ["", f"wrote {out}/ ({', '.join(written)})"]
    return lines


def _controller_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The controller keywords of :func:`adavar.adaptive_davar` from the parsed flags."""
    return dict(
        lmax=args.lmax, lmin=args.lmin, k1=args.k1, k2=args.k2, s1=args.s1, s2=args.s2,
        l=args.segment, dl0=args.dl0, dl1=args.dl1, s_test=args.s_test, combine=args.combine,
        thresholds=args.thresholds, false_alarm=args.false_alarm,
    )  # fmt: skip


def _schedule_of(result: Any) -> Any:
    """The controller record of an AdaptiveResult as a Schedule (for the Fig. 10 panels)."""
    from adavar.adaptive import Schedule, _fixed_thresholds, calibrated_thresholds

    p = result.parameters
    if p.get("thresholds") == "calibrated":
        th = calibrated_thresholds(p["lmin"], p["lmax"], p["l"], false_alarm=p["false_alarm"])
    else:
        th = _fixed_thresholds(p["lmax"], p["k1"], p["k2"], p["s2"])
    return Schedule(
        window=result.window, kurtosis=result.kurtosis, s=result.s, f1=result.f1,
        f2=result.f2, f=result.f, centre=result.centre, method=result.method,
        thresholds=th, parameters=p,
    )  # fmt: skip


def _cmd_davar(args: argparse.Namespace) -> int:
    if args.format is not None and args.out is None:
        raise UsageError("--format chooses the surface file of --out: give --out DIR as well")
    if args.confidence is None and args.terms is not None:
        raise UsageError(
            "--terms needs the confidence bounds (the fit is weighted by the EDF of every "
            "cell): drop --confidence none"
        )
    fmt = check_surface_format(args.format or "nc")  # before the work: pyarrow installed?
    if args.out is not None:
        check_output_directory(args.out, replace=args.force)
        _guard_replacement(args.out, [Path(args.file)])

    adaptive = args.command == "adaptive"
    if adaptive and args.method == "oracle" and not args.change_times:
        raise UsageError("--method oracle needs --change-times T,... (seconds)")
    status = _Status()
    status(f"reading {args.file}")
    # several channels only when --column names them: a surface of every numeric column
    # (a temperature too) is too costly to be a default
    chosen = args.column is not None
    loaded, meta, units_of, tau0 = _load(args, several=chosen, pieces=False, out_of_core=True)
    if not chosen:
        loaded, units_of = {meta["column"]: loaded}, {meta["column"]: units_of}
    names = list(loaded)
    several = len(names) > 1
    folders = _channel_folders(names) if several else {}
    runs = []
    for k, name in enumerate(names):
        out = args.out if args.out is None or not several else f"{args.out}/{folders[name]}"
        tag = f"{name} ({k + 1}/{len(names)}): " if several else ""
        runs.append(_davar_channel(args, loaded[name], {**meta, "column": name}, units_of[name],
                                   tau0, fmt, out, status, tag))  # fmt: skip
    if several:
        payload: dict[str, Any] = {
            "adavar_version": __version__,
            "input": {"file": meta["path"], "columns": names, "rate": 1.0 / tau0, "tau0": tau0,
                      "data_type": args.data_type},
            "channels": {run["name"]: run["payload"] for run in runs},
            "out": None if args.out is None else {"dir": args.out, "format": fmt,
                                                  "folders": folders},
        }  # fmt: skip
        if meta["preprocessing"]:
            payload["input"]["preprocessing"] = [
                step.get("spec", str(step)) for step in meta["preprocessing"]
            ]
        text = _dumps(payload)
        written = [f"{folders[name]}/" for name in names] + ["result.json"]
    else:
        text = runs[0]["text"]
        written = runs[0]["written"]

    if args.out is not None:
        try:
            with atomic_directory(args.out, replace=args.force) as tmp:
                for run in runs:
                    dest = tmp
                    if several:
                        dest = tmp / folders[run["name"]]
                        dest.mkdir()
                    _write_davar_channel(args, run, dest, fmt, status)
                if several:
                    (tmp / "result.json").write_text(text + "\n", encoding="utf-8")
        except OSError as exc:
            raise _output_error(args.out, exc) from None
    status.close()

    if args.json:
        print(text)
        if args.out is not None:
            print(f"adavar: wrote {args.out}/ ({', '.join(written)})", file=sys.stderr)
        return EXIT_OK
    for k, run in enumerate(runs):
        if k:
            print()
        print("\n".join(_davar_summary(run["result"], run["fit"], run["meta"], run["units"],
                                       args.data_type, [] if several else run["written"],
                                       args.out)))  # fmt: skip
    if several and args.out is not None:
        print()
        print(f"wrote {args.out}/ ({', '.join(written)}; in each folder: "
              f"{', '.join(runs[0]['written'])})")  # fmt: skip
    return EXIT_OK


def _channel_folders(names: Sequence[str]) -> dict[str, str]:
    """A distinct folder name for every channel (case-insensitively: not every file system
    tells gx from GX), never ``result.json``."""
    folders: dict[str, str] = {}
    used = {"result.json"}
    for name in names:
        base = candidate = _safe_name(name)
        k = 2
        while candidate.lower() in used:
            candidate = f"{base}_{k}"
            k += 1
        used.add(candidate.lower())
        folders[name] = candidate
    return folders


def _davar_channel(
    args: argparse.Namespace, samples: np.ndarray, meta: dict[str, Any], units: str,
    tau0: float, fmt: str, out: str | None, status: _Status, tag: str,
) -> dict[str, Any]:  # fmt: skip
    """The (adaptive) DAVAR surface and its noise fit of one channel, with its JSON payload
    and the names of the files its output folder ``out`` gets."""
    from adavar.plots import rate_unit

    adaptive = args.command == "adaptive"
    rate_u = rate_unit(units, args.data_type)
    status(f"{tag}computing the {'adaptive ' if adaptive else ''}DAVAR surface of "
           f"{samples.size} samples")  # fmt: skip
    common = dict(
        # the rate as given: times are centre / rate, without 0.1-step rounding noise
        rate=args.rate if args.rate is not None else 1.0,
        tau0=None if args.rate is not None else tau0,
        data_type=args.data_type,
        taus=args.taus,
        edges=args.edges,
        step=args.step,
        confidence=args.confidence,
        points_per_decade=args.points_per_decade,
        noise_type=args.noise_type,
        t0=args.t0,
        units=rate_u,
        **_chunk_keywords(args),
    )
    if adaptive:
        result = adaptive_davar(
            samples, method=args.method, change_times=args.change_times,
            **_controller_settings(args), **common,
        )  # fmt: skip
    else:
        result = davar(samples, window=args.window, **common)
    fit = None
    if args.confidence is not None:
        status(f"{tag}fitting the noise terms of every window")
        try:
            fit = fit_noise(result, **_fit_keywords(args))
        except ValueError as exc:
            raise AdavarInputError(str(exc)) from None

    written: list[str] = []
    if out is not None:
        written = [f"surface{SURFACE_FORMATS[fmt]}"]
        if fit is not None:
            written.append("coefficients.csv")
        figure_stems = ["davar_surface", "davar_heatmap"]
        if adaptive:
            figure_stems.append("controller")
        if fit is not None:
            figure_stems.append(_TERM_FILES[_coefficient_term(fit)])
        written += [f"{stem}.{ext}" for stem in figure_stems for ext in ("png", "svg")]
        written.append("result.json")

    n_time, n_tau = np.shape(result.avar)
    payload: dict[str, Any] = {
        "adavar_version": __version__,
        "input": {
            "file": meta["path"],
            "column": meta["column"],
            "rate": 1.0 / tau0,
            "tau0": tau0,
            "units": units,
            "data_type": args.data_type,
            "n_samples": result.n_samples,
        },
        "parameters": {
            "window": args.window,
            "window_s": None if args.window is None else args.window * tau0,
            "step": result.step,
            "edges": result.edges,
            "taus": args.taus,
            "points_per_decade": args.points_per_decade,
            "confidence": args.confidence,
            "terms": None if fit is None else list(fit.terms),
        },
        "units": rate_u,
        "shape": {"time": n_time, "tau": n_tau},
        "time": {
            "first": result.time[0],
            "last": result.time[-1],
            "spacing": result.step * tau0,
        },
        "tau": result.tau,
        "m": result.m,
        "alpha": result.alpha,
        "notes": list(result.notes),
        "fit": None if fit is None else _davar_fit_json(fit, np.asarray(result.time)),
        "out": None if out is None else {"dir": out, "format": fmt, "files": written},
    }
    if meta["preprocessing"]:
        payload["input"]["preprocessing"] = [
            step.get("spec", str(step)) for step in meta["preprocessing"]
        ]
    if adaptive:
        payload["parameters"]["controller"] = result.parameters
        payload["window"] = {
            "min": int(np.min(result.window)), "max": int(np.max(result.window)),
            "shrunk_fraction": float(np.mean(result.window < result.parameters["lmax"])),
        }  # fmt: skip
    return {
        "name": meta["column"], "result": result, "fit": fit, "meta": meta, "units": units,
        "tau0": tau0, "payload": payload, "text": _dumps(payload), "written": written,
        "tag": tag,
    }  # fmt: skip


def _write_davar_channel(
    args: argparse.Namespace, run: dict[str, Any], dest: Path, fmt: str, status: _Status
) -> None:
    """The surface, coefficients, figures and result.json of one channel into ``dest``."""
    from adavar.plots import (
        coefficient_figure,
        davar_heatmap_figure,
        davar_surface_figure,
        save_figure,
        term_unit,
    )

    adaptive = args.command == "adaptive"
    result, fit, meta, tau0 = run["result"], run["fit"], run["meta"], run["tau0"]
    status(f"{run['tag']}drawing the figures")
    title = f"{Path(meta['path']).name}, column {meta['column']}"
    figures = {
        "davar_surface": davar_surface_figure(result),
        "davar_heatmap": davar_heatmap_figure(result),
    }
    if adaptive:
        from adavar.plots import controller_figure

        figures["controller"] = controller_figure(
            _schedule_of(result), result.time, change_times=args.change_times or (),
            title=f"{title}: {result.method} window",
        )  # fmt: skip
    if fit is not None:
        term = _coefficient_term(fit)
        what = f"window {args.window} samples" if not adaptive else f"{result.method} window"
        figures[_TERM_FILES[term]] = coefficient_figure(fit, term=term, title=f"{title}: {what}")
    status(f"{run['tag']}writing the surface and the figures")
    write_surface(dest / run["written"][0], result, fmt=fmt)
    if fit is not None:
        units_text = ", ".join(
            f"{name} in {term_unit(name, fit.units) or '1'}" for name in fit.terms
        )
        _write_coefficients(
            dest / "coefficients.csv", result, fit,
            f"adavar {__version__}: noise coefficients of every DAVAR window of "
            f"{meta['path']} column {meta['column']!r} ({args.data_type} data, "
            f"tau0 = {tau0:g} s); time_s: window centre, window: samples; "
            f"{units_text}; uncertainties 1 sigma (an upper bound where the value "
            "is 0); nan: window not fitted",
        )  # fmt: skip
    for stem, fig in figures.items():
        save_figure(fig, dest / stem)
    (dest / "result.json").write_text(run["text"] + "\n", encoding="utf-8")


def _fit_keywords(args: argparse.Namespace) -> dict[str, Any]:
    """The keywords of :func:`adavar.fit_noise` from the parsed flags."""
    return dict(terms=args.terms or TERM_NAMES, n_reweight=args.n_reweight,
                spacing=args.spacing, method=args.fit_method, select=args.select,
                significance=args.significance, exclude=args.exclude, rolloff=args.rolloff,
                tau_range=args.tau_range, bandwidth=args.bandwidth)  # fmt: skip


def _chunk_keywords(args: argparse.Namespace) -> dict[str, Any]:
    """``chunk_size`` for the library, only when --chunk-size is given."""
    size = getattr(args, "chunk_size", None)
    return {} if size is None else {"chunk_size": size}


# --------------------------------------------------------------------------------------
# compare (and the paper part of the demo)
# --------------------------------------------------------------------------------------

_NODE_TITLES = {"beginning": "Beginning", "end": "End", "restore": "Restore"}
#: Thresholds of the Fig. 8 study (the paper's), plus --k2 when it differs.
_FIG8_THRESHOLDS = (3.3, 3.45, 4.0)


def _fmt_time(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{value:.0f}"


def _fmt_summary(stats: dict[str, float]) -> str:
    if not math.isfinite(stats["median"]):
        return "-"
    text = f"{stats['median']:.0f} [{stats['q25']:.0f},{stats['q75']:.0f}]"
    return text + (f" ({stats['missed']} missed)" if stats["missed"] else "")


def _paper_columns(comp: Any, paper: dict[str, Any]) -> list[str]:
    return [name for name in comp.methods if name in paper]


def _compare_node_lines(comp: Any, study: Any) -> list[str]:
    from adavar.compare import PAPER_LABELS

    if not comp.change_times:
        return ["Nodes: no change times (give --change-times T,... for a data file)"]
    labels = comp.labels
    if study is None:
        rows_in = comp.node_rows()
        paper = comp.paper_nodes()
    else:
        rows_in = study.node_rows()
        paper = study.paper_nodes()
    cols = _paper_columns(comp, paper)
    headers = ["node [s]", *labels.values(), *(f"paper {PAPER_LABELS[m]}" for m in cols)]
    rows = []
    for r in rows_in:
        name = f"{_NODE_TITLES[r['node']]}({r['change']:g})"
        if study is None:
            cells = [_fmt_time(r["values"][m]) for m in labels]
        else:
            cells = [_fmt_summary(r["stats"][m]) for m in labels]
        rows.append([name, *cells, *(_fmt_time(r["paper"].get(m, math.nan)) for m in cols)])
    if study is None:
        title = "Node times (window centres, s), one realisation"
    else:
        title = (f"Node times (window centres, s): median [quartiles] over {len(study.seeds)} "
                 "realisations")  # fmt: skip
    lines = [title, _table(headers, rows, "  ")]
    if comp.scenario == 2 and cols:
        lines.append("  (paper: its Table 3 is a measured gyroscope with this scenario's shape, "
                     "not this simulation)")  # fmt: skip
    lines.append("  (fixed windows: X -/+ L/2 by definition; adaptive: Restore = first centre "
                 ">= X at Lmax, End = start of the regrowth into it, Beginning = where L left "
                 "Lmax before it)")  # fmt: skip
    return lines


def _compare_interval_lines(comp: Any, study: Any) -> list[str]:
    from adavar.compare import PAPER_LABELS, PAPER_TABLE1_ARW

    labels = comp.labels
    paper = PAPER_TABLE1_ARW if comp.scenario == 1 else {}
    cols = _paper_columns(comp, paper)
    if study is None:
        values = {m: [run.intervals[iv] for iv in comp.intervals]
                  for m, run in comp.methods.items()}  # fmt: skip
    else:
        values = {m: [r["values"][m] for r in study.arw_rows()] for m in labels}
    headers = ["interval [s]", *labels.values(), *(f"paper {PAPER_LABELS[m]}" for m in cols)]
    rows = []
    for j, (a, b) in enumerate(comp.intervals):
        rows.append([f"ARW({a:g}~{b:g})", *(f"{values[m][j]:.4g}" for m in labels),
                     *(f"{paper[m].get((a, b), math.nan):.4g}" for m in cols)])  # fmt: skip
    a0, b0 = comp.intervals[0]
    for j, (a, b) in enumerate(comp.intervals[1:], start=1):
        ratio = [values[m][j] / values[m][0] for m in labels]
        pr = [paper[m].get((a, b), math.nan) / paper[m].get((a0, b0), math.nan) for m in cols]
        rows.append([f"  ARW({a:g}~{b:g}) / ARW({a0:g}~{b0:g})", *(f"{v:.3f}" for v in ratio),
                     *(f"{v:.3f}" for v in pr)])  # fmt: skip
    unit = None
    if comp.units:
        from adavar.plots import term_unit

        unit = term_unit("angle_random_walk", comp.units)
    what = f"N in {unit}" if unit else "N in sample unit x sqrt(s)"
    over = "" if study is None else f", median over {len(study.seeds)} realisations"
    lines = [f"ARW interval means ({what}{over})", _table(headers, rows, "  ")]
    if cols:
        lines.append("  (paper values in 1e-3 deg/sqrt(h), a scale its text does not define: "
                     "compare the ratios)")  # fmt: skip
    return lines


_METRIC_TEXT = {
    "bias": "bias of N/N_true - 1, stationary",
    "std": "std of N/N_true - 1, stationary",
    "mad": "1.4826 MAD of N/N_true - 1, stationary",
    "error": "error at {X}: mean |N/N_true - 1|",
    "delay": "delay at {X}: midpoint passage [s]",
    "rise": "rise at {X}: 10-90 % [s]",
}


def _compare_metric_lines(comp: Any, study: Any) -> list[str]:
    labels = comp.labels
    if study is None:
        if comp.truth is None:
            return []
        rows_in = []
        for key in ("bias", "std", "mad"):
            rows_in.append({"metric": key, "change": None,
                            "values": {m: getattr(r.metrics, key)
                                       for m, r in comp.methods.items()}})  # fmt: skip
        for j, change in enumerate(comp.change_times):
            for key in ("error", "delay", "rise"):
                rows_in.append({"metric": key, "change": change,
                                "values": {m: getattr(r.metrics.changes[j], key)
                                           for m, r in comp.methods.items()}})  # fmt: skip
    else:
        rows_in = study.metric_rows()
    rows = []
    for r in rows_in:
        key = r["metric"]
        vals = [r["values"][m] for m in labels]
        finite = [abs(v) for v in vals if math.isfinite(v)]
        best = min(finite) if finite else math.nan
        cells = []
        for v in vals:
            if not math.isfinite(v):
                cells.append("-")
                continue
            text = f"{100 * v:+.1f} %" if key == "bias" else (
                f"{100 * v:.1f} %" if key in ("std", "mad", "error") else f"{v:+.0f}"
                if key == "delay" else f"{v:.0f}")  # fmt: skip
            cells.append(text + ("*" if abs(v) == best else " "))
        change = "" if r["change"] is None else f"{r['change']:g} s"
        rows.append([_METRIC_TEXT[key].format(X=change), *cells])
    over = "one realisation" if study is None else f"median over {len(study.seeds)} realisations"
    return [
        f"Ground truth ({over}; * best; stationary: farther than Lmax/2 from every change; "
        "error around a change: within Lmax)",
        _table(["metric", *labels.values()], rows, "  "),
    ]


def _crossing_lines(thr: Any, study: Any, scenario: int | None) -> list[str]:
    from adavar.compare import PAPER_FIG8_CROSSINGS

    if thr is None:
        return []
    rows = []
    if study is None:
        for th in thr.thresholds:
            paper = PAPER_FIG8_CROSSINGS.get(th, {}) if scenario == 1 else {}
            for j, change in enumerate(thr.change_times):
                exp = (thr.expected_crossings[th][j] if thr.expected_crossings is not None
                       else (math.nan, math.nan))  # fmt: skip
                pp = paper.get(change, (math.nan, math.nan))
                rows.append([f"{th:g}", f"{change:g}", _fmt_time(thr.crossings[th][j, 0]),
                             _fmt_time(thr.crossings[th][j, 1]),
                             f"{_fmt_time(exp[0])} / {_fmt_time(exp[1])}",
                             f"{_fmt_time(pp[0])} / {_fmt_time(pp[1])}"])  # fmt: skip
        title = f"Kurtosis of a fixed window of {thr.window} samples crossing K2 (paper Fig. 8)"
    else:
        for r in study.crossing_rows():
            pp = r["paper"] or (math.nan, math.nan)
            rows.append([f"{r['threshold']:g}", f"{r['change']:g}", _fmt_summary(r["rise"]),
                         _fmt_summary(r["fall"]),
                         f"{_fmt_time(r['expected'][0])} / {_fmt_time(r['expected'][1])}",
                         f"{_fmt_time(pp[0])} / {_fmt_time(pp[1])}"])  # fmt: skip
        title = (
            f"Kurtosis of a fixed window of {study.crossing_window} samples crossing K2 "
            f"(paper Fig. 8): median [quartiles] over {len(study.seeds)} realisations"
        )
    headers = ["K2", "change [s]", "rises above [s]", "falls back [s]", "expected (truth)",
               "paper"]  # fmt: skip
    return [title, _table(headers, rows, "  ")]


def _compare_report(comp: Any, study: Any, thr: Any) -> list[str]:
    taus = comp.parameters["taus"]
    if study is not None:
        taus = f"{taus} (one realisation), {study.parameters['taus']} (over seeds)"
    lines = [f"{comp.description}", "methods: " + ", ".join(comp.labels.values())
             + f"; taus {taus}; fit terms "
             + ("all five" if len(comp.parameters["terms"]) == 5
                else ",".join(comp.parameters["terms"]))]  # fmt: skip
    p = comp.parameters
    if p["thresholds"] == "calibrated":
        limits = f"thresholds calibrated for a false-alarm rate of {p['false_alarm']:g}"
    else:
        limits = f"K1 {p['k1']:g}, K2 {p['k2']:g}, S2 {p['s2']:g}"
    lines.append(
        f"controller: Lmax {p['lmax']}, Lmin {p['lmin']}, l {p['l']}, dL0 {p['dl0']}, "
        f"dL1 {p['dl1']}, f2 test {p['s_test']}, combine {p['combine']}; {limits}"
    )
    for block in (_compare_node_lines(comp, study), _compare_interval_lines(comp, study),
                  _compare_metric_lines(comp, study),
                  _crossing_lines(thr, study, comp.scenario)):  # fmt: skip
        if block:
            lines += ["", *block]
    return lines


def _csv_text(header_comment: str, columns: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    buffer = _stdio.StringIO()
    buffer.write(f"# {header_comment}\n")
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        # NaN (a node that does not apply, a value the paper does not give) as "nan": an
        # empty last cell would read as a trailing delimiter
        writer.writerow([repr(float(v)) if isinstance(v, (float, np.floating)) else v
                         for v in row])  # fmt: skip
    return buffer.getvalue()


def _compare_tables(comp: Any, study: Any, thr: Any) -> dict[str, str]:
    """CSV file name -> text."""
    from adavar.compare import PAPER_FIG8_CROSSINGS, PAPER_REFERENCE, PAPER_TABLE1_ARW

    head = f"adavar {__version__}: {comp.description}"
    names = list(comp.methods)
    files: dict[str, str] = {}
    if comp.change_times:
        paper = comp.paper_nodes() if study is None else study.paper_nodes()
        cols = _paper_columns(comp, paper)
        if study is None:
            rows = [
                [
                    r["node"],
                    r["change"],
                    *(r["values"][m] for m in names),
                    *(r["paper"].get(m, math.nan) for m in cols),
                ]
                for r in comp.node_rows()
            ]
            columns = ["node", "change_s", *names]
        else:
            stats = ("median", "q25", "q75", "missed")
            rows = [
                [
                    r["node"],
                    r["change"],
                    *(r["stats"][m][k] for m in names for k in stats),
                    *(r["paper"].get(m, math.nan) for m in cols),
                ]
                for r in study.node_rows()
            ]
            columns = ["node", "change_s", *(f"{m}_{k}" for m in names for k in stats)]
        files["nodes.csv"] = _csv_text(
            f"{head}; node times (window centres) in s; paper_*: {PAPER_REFERENCE}",
            [*columns, *(f"paper_{m}" for m in cols)], rows,
        )  # fmt: skip
    paper_arw = PAPER_TABLE1_ARW if comp.scenario == 1 else {}
    cols = _paper_columns(comp, paper_arw)
    if study is None:
        vals = {m: [run.intervals[iv] for iv in comp.intervals] for m, run in comp.methods.items()}
    else:
        vals = {m: [r["values"][m] for r in study.arw_rows()] for m in names}
    files["intervals.csv"] = _csv_text(
        f"{head}; ARW(a~b) = mean of N(t) over centres in [a, b]"
        + ("" if study is None else f", median over {len(study.seeds)} realisations")
        + "; paper_* in 1e-3 deg/sqrt(h) (scale not reproducible: compare ratios)",
        ["a_s", "b_s", *names, *(f"paper_{m}" for m in cols)],
        [[a, b, *(vals[m][j] for m in names), *(paper_arw[m].get((a, b), math.nan) for m in cols)]
         for j, (a, b) in enumerate(comp.intervals)],
    )  # fmt: skip
    if study is not None or comp.truth is not None:
        rows = []
        if study is None:
            for m, run in comp.methods.items():
                met = run.metrics
                rows.append([m, "bias", "", met.bias])
                rows.append([m, "std", "", met.std])
                rows.append([m, "mad", "", met.mad])
                for c in met.changes:
                    rows += [[m, "error", c.change, c.error], [m, "delay", c.change, c.delay],
                             [m, "rise", c.change, c.rise]]  # fmt: skip
        else:
            for r in study.metric_rows():
                for m in names:
                    rows.append([m, r["metric"], "" if r["change"] is None else r["change"],
                                 r["values"][m]])  # fmt: skip
        files["metrics.csv"] = _csv_text(
            f"{head}; ground-truth metrics"
            + ("" if study is None else f", median over {len(study.seeds)} realisations")
            + "; bias/std/mad of N/N_true - 1 over stationary centres; error: mean "
            "|N/N_true - 1| within Lmax of the change; delay, rise in s",
            ["method", "metric", "change_s", "value"], rows,
        )  # fmt: skip
    cols_arw = ["time_s"] + (["true_N"] if comp.truth is not None else [])
    cols_arw += [f"N_{m}" for m in names] + [f"window_{m}" for m in names]
    arrays = [comp.time] + ([comp.truth] if comp.truth is not None else [])
    arrays += [comp.methods[m].arw for m in names] + [comp.methods[m].window for m in names]
    body = [[float(a[i]) if a.dtype.kind == "f" else int(a[i]) for a in arrays]
            for i in range(comp.time.size)]  # fmt: skip
    files["arw.csv"] = _csv_text(
        f"{head}; N(t) of every window (sample unit x sqrt(s)) and window lengths (samples)",
        cols_arw, body,
    )  # fmt: skip
    if thr is not None:
        rows = []
        for th in thr.thresholds:
            paper = PAPER_FIG8_CROSSINGS.get(th, {}) if comp.scenario == 1 else {}
            for j, change in enumerate(thr.change_times):
                if study is None:
                    rise, fall = thr.crossings[th][j]
                else:
                    rise = _median_of(study.crossings[th][:, j, 0])
                    fall = _median_of(study.crossings[th][:, j, 1])
                exp = (thr.expected_crossings[th][j] if thr.expected_crossings is not None
                       else (math.nan, math.nan))  # fmt: skip
                pp = paper.get(change, (math.nan, math.nan))
                rows.append([th, change, rise, fall, exp[0], exp[1], pp[0], pp[1]])
        files["crossings.csv"] = _csv_text(
            f"{head}; kurtosis of a fixed window of {thr.window} samples: times (s) at which it "
            "rises above K2 and falls back"
            + ("" if study is None else f" (median over {len(study.seeds)} realisations)"),
            ["k2", "change_s", "rise_s", "fall_s", "expected_rise_s", "expected_fall_s",
             "paper_rise_s", "paper_fall_s"], rows,
        )  # fmt: skip
    if study is not None:
        rows = []
        for i, seed in enumerate(study.seeds):
            for m in names:
                for j, change in enumerate(study.change_times):
                    rows.append([seed, m, change, *study.nodes[m][i, j]])
        files["seeds_nodes.csv"] = _csv_text(
            f"{head}; node times (s) of every realisation",
            ["seed", "method", "change_s", "beginning_s", "end_s", "restore_s"], rows,
        )  # fmt: skip
    return files


def _median_of(values: np.ndarray) -> float:
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if v.size else math.nan


def _compare_figures(comp: Any, kurt: Any, thr: Any) -> dict[str, Any]:
    from adavar.plots import comparison_figures

    return comparison_figures(comp, kurtosis=kurt, thresholds=thr)


def _crossings_json(thr: Any) -> Any:
    if thr is None:
        return None
    return {
        "window": thr.window,
        "rows": [
            {"threshold": th, "change": change, "rise": thr.crossings[th][j, 0],
             "fall": thr.crossings[th][j, 1],
             "expected": None if thr.expected_crossings is None
             else list(thr.expected_crossings[th][j])}
            for th in thr.thresholds for j, change in enumerate(thr.change_times)
        ],
    }  # fmt: skip


class _Status:
    """What the command is doing, on one line of stderr, only when stderr is a terminal.

    For steps that cannot report a fraction (reading a file, computing a surface); with
    the elapsed time of the previous step, so a slow step shows itself.
    """

    def __init__(self) -> None:
        self.enabled = sys.stderr.isatty()
        self.start = time.perf_counter()
        self.shown = False

    def __call__(self, what: str) -> None:
        if self.enabled:
            elapsed = time.perf_counter() - self.start
            print(f"\r{what} ... ({elapsed:.1f} s)".ljust(79)[:79], end="", file=sys.stderr,
                  flush=True)  # fmt: skip
            self.shown = True

    def close(self) -> None:
        """Erase the line (the command's output follows on a clean line)."""
        if self.enabled and self.shown:
            print("\r" + " " * 79 + "\r", end="", file=sys.stderr, flush=True)
            self.shown = False


class _ProgressBar:
    """A one-line progress bar on stderr, only when stderr is a terminal."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.enabled = sys.stderr.isatty()
        self.start = time.perf_counter()

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled or total <= 0:
            return
        width = 30
        filled = int(width * done / total)
        elapsed = time.perf_counter() - self.start
        bar = "#" * filled + "-" * (width - filled)
        print(f"\r{self.label} [{bar}] {done}/{total} {elapsed:.0f} s", end="",
              file=sys.stderr, flush=True)  # fmt: skip

    def close(self) -> None:
        if self.enabled:
            print("\r" + " " * 79 + "\r", end="", file=sys.stderr, flush=True)


def _truth_column(args: argparse.Namespace, size: int, tau0: float) -> np.ndarray:
    """The true N of every sample, from another column of the compared FILE."""
    from adavar.readers import read_record

    record = read_record(
        args.file, columns=[args.truth_column], rate=1.0 / tau0, gaps=args.gaps,
        nan=args.nan, gap_tolerance=args.gap_tolerance,
    )  # fmt: skip
    truth = np.asarray(record.channel(record.names[0]), dtype=np.float64)
    if truth.size != size:
        raise AdavarInputError(
            f"--truth-column {args.truth_column}: {truth.size} values for {size} samples "
            "(missing values dropped?): give a complete column"
        )
    return truth


def _cmd_compare(args: argparse.Namespace) -> int:
    from adavar import simulate
    from adavar.compare import compare, compare_seeds, kurtosis_study, threshold_study

    if (args.file is None) == (args.scenario is None):
        raise UsageError("give a data FILE or --scenario 1|2 (one of them)")
    units: str | None = None
    tau0 = 1.0
    if args.scenario is not None:
        file_flags = (("--column", args.column), ("--rate", args.rate),
                      ("--tau0", args.tau0), ("--units", args.units),
                      ("--change-times", args.change_times),
                      ("--truth-column", args.truth_column),
                      ("--time-column", args.time_column), ("--dataset", args.dataset),
                      ("--topic", args.topic), ("--preprocess", args.preprocess))  # fmt: skip
        for flag, value in file_flags:
            if value is not None:
                raise UsageError(
                    f"{flag} describes a data FILE; --scenario simulates its own record "
                    "(unit-less, 1 Hz, known changes): drop it"
                )
    else:
        if args.seeds > 1:
            raise UsageError("--seeds repeats a simulated --scenario; a data FILE is one record")
        if args.variance_reading:
            raise UsageError("--variance-reading chooses a --scenario's disturbance")
        if args.file is None:
            raise UsageError("give a data FILE (with --rate and --units) or --scenario 1|2")
    if args.out is not None:
        check_output_directory(args.out, replace=args.force)
        _guard_replacement(args.out, [Path(args.file)] if args.file is not None else [])

    controller = dict(
        lmax=args.lmax, lmin=args.lmin, k1=args.k1, k2=args.k2, s1=args.s1, s2=args.s2,
        l=args.segment, dl0=args.dl0, dl1=args.dl1, s_test=args.s_test,
        combine=args.combine, thresholds=args.thresholds, false_alarm=args.false_alarm,
    )  # fmt: skip
    terms = args.terms or TERM_NAMES
    if args.crossing_thresholds is not None:
        fig8 = tuple(sorted(set(args.crossing_thresholds)))
    else:
        fig8 = tuple(sorted({*_FIG8_THRESHOLDS, float(args.k2)}))
    crossing_window = args.crossing_window or args.lmax
    start = time.perf_counter()
    status = _Status()
    truth = None
    if args.scenario is not None:
        status(f"simulating scenario {args.scenario}")
        data: Any = simulate.paper_scenario(
            args.scenario, seed=args.seed, variance_reading=args.variance_reading
        )
        rate = None
        changes = None
        input_json: dict[str, Any] = {
            "scenario": args.scenario, "seed": args.seed,
            "variance_reading": args.variance_reading, "description": data.description,
        }  # fmt: skip
        description = None
    else:
        status(f"reading {args.file}")
        samples, meta, units, tau0 = _load(args)
        if args.truth_column is not None:
            truth = _truth_column(args, samples.size, tau0)
        data = samples
        rate = args.rate if args.rate is not None else 1.0 / tau0
        changes = args.change_times
        input_json = {
            "file": meta["path"], "column": meta["column"], "rate": 1.0 / tau0, "tau0": tau0,
            "units": units, "n_samples": int(samples.size),
        }  # fmt: skip
        description = (f"{meta['path']}, column {meta['column']!r}: {samples.size} samples at "
                       f"{1.0 / tau0:g} Hz in {units}")  # fmt: skip
    status("running " + ", ".join(args.methods) if args.methods else "running the methods")
    comp = compare(
        data, methods=args.methods, rate=rate, change_times=changes, taus=args.taus or "all",
        terms=terms, units=units, description=description, truth=truth,
        intervals=args.intervals, confidence=args.confidence, noise_type=args.noise_type,
        points_per_decade=args.points_per_decade, **controller,
    )  # fmt: skip
    thr = None
    if comp.change_times:
        status("kurtosis threshold crossings")
        thr = threshold_study(data, change_times=comp.change_times, window=crossing_window,
                              thresholds=fig8, rate=comp.rate)  # fmt: skip
    status.close()
    study = None
    if args.seeds > 1:
        bar = _ProgressBar(f"scenario {args.scenario}, {args.seeds} realisations")
        try:
            study = compare_seeds(
                args.scenario, range(args.seed, args.seed + args.seeds),
                variance_reading=args.variance_reading, methods=args.methods,
                taus=args.taus or "octave", terms=terms, crossing_thresholds=fig8,
                crossing_window=args.crossing_window, progress=bar, **controller,
            )  # fmt: skip
        finally:
            bar.close()
    kurt = None
    if args.out is not None:
        status("kurtosis study")
        windows = tuple(w for w in (11, 201, 601) if w <= comp.data.size)
        kurt = kurtosis_study(data, rate=comp.rate, windows=windows,
                              change_times=comp.change_times)  # fmt: skip
    elapsed = time.perf_counter() - start

    tables = _compare_tables(comp, study, thr)
    if args.out is not None:
        status("drawing the figures")
    figures = _compare_figures(comp, kurt, thr) if args.out is not None else {}
    written = [*tables, *(f"{stem}.{ext}" for stem in figures for ext in ("png", "svg")),
               "result.json"] if args.out is not None else []  # fmt: skip
    payload = {
        "adavar_version": __version__,
        "input": input_json,
        "comparison": comp.to_dict(),
        "crossings": _crossings_json(thr),
        "seeds": None if study is None else study.to_dict(),
        "elapsed_s": elapsed,
        "out": None if args.out is None else {"dir": args.out, "files": written},
    }
    text = _dumps(payload)
    if args.out is not None:
        from adavar.plots import save_figure

        status(f"writing {args.out}")
        try:
            with atomic_directory(args.out, replace=args.force) as tmp:
                for name, body in tables.items():
                    (tmp / name).write_text(body, encoding="utf-8")
                for stem, fig in figures.items():
                    save_figure(fig, tmp / stem)
                (tmp / "result.json").write_text(text + "\n", encoding="utf-8")
        except OSError as exc:
            raise _output_error(args.out, exc) from None
    status.close()
    if args.json:
        print(text)
        if written:
            print(f"adavar: wrote {args.out}/ ({', '.join(written)})", file=sys.stderr)
        return EXIT_OK
    lines = _compare_report(comp, study, thr)
    if written:
        lines += ["", f"wrote {args.out}/ ({', '.join(written)})"]
    lines.append(f"done in {elapsed:.1f} s of computation")
    print("\n".join(lines))
    return EXIT_OK


def _demo_json(demo: Any, out: str, files: list[str]) -> dict[str, Any]:
    gyro = demo.gyro
    return {
        "adavar_version": __version__,
        "nist": {
            "rows": [
                {
                    "stat": r.stat,
                    "averaging_factor": r.averaging_factor,
                    "tau": r.tau,
                    "computed": r.computed,
                    "published": r.published,
                    "rel_diff": r.rel_diff,
                }
                for r in demo.nist
            ],
            "max_rel_diff": demo.nist_max_rel_diff,
            "mean": {"computed": demo.nist_mean.computed, "published": demo.nist_mean.published},
            "std": {"computed": demo.nist_std.computed, "published": demo.nist_std.published},
        },
        "gyro": {
            "rate": gyro.rate,
            "n_samples": gyro.n_samples,
            "units": gyro.units,
            "seed": gyro.seed,
            "true": {
                name: {"value": value, "unit": unit}
                for name, (value, unit) in gyro.true_conventional.items()
            },
            **_deviation_json(gyro.result),
            "fit": _fit_json(gyro.fit),
        },
        "paper": None
        if demo.paper is None
        else {
            "comparison": demo.paper.comparison.to_dict(),
            "crossings": _crossings_json(demo.paper.thresholds),
            "seeds": demo.paper.study.to_dict(),
        },
        "out": {"dir": out, "files": files},
        "elapsed_s": demo.elapsed,
    }


def _check_demo_out(out: str, force: bool) -> None:
    path = Path(out)
    if path.is_dir() and not path.is_symlink() and not force:
        if any(path.iterdir()) and not (path / DEMO_MARKER).is_file():
            raise AdavarInputError(
                f"{out} exists and was not written by adavar demo: choose another --out, or "
                "pass --force to replace it"
            )
    check_output_directory(out, replace=True)
    _guard_replacement(out, [])


def _check_output_file(path: str, force: bool, suffixes: tuple[str, ...]) -> Path:
    """A file the command may write: right suffix, parent exists, not replaced silently."""
    output = Path(path)
    if suffixes and output.suffix.lower() not in suffixes:
        raise UsageError(f"--output {path!r}: name it *{suffixes[0]}")
    if output.is_dir():
        raise UsageError(f"{path} is a folder: give a file name")
    if output.exists() and not force:
        raise UsageError(f"{path} exists: use --force to replace it")
    if not output.parent.exists():
        raise UsageError(f"folder {str(output.parent)!r} does not exist: create it first")
    return output


def _cmd_kalibr(args: argparse.Namespace) -> int:
    from adavar.export import kalibr_imu_yaml, kalibr_values, write_text
    from adavar.readers import read_record

    output = _check_output_file(args.output, args.force, (".yaml", ".yml"))
    if len(args.gyro) != 3 or len(args.accel) != 3:
        raise UsageError("--gyro and --accel take three columns each (x,y,z)")
    status = _Status()
    status(f"reading {args.file}")
    record = read_record(
        args.file, columns=[*args.gyro, *args.accel], rate=args.rate,
        time_column=args.time_column, topic=args.topic, gaps=args.gaps,
    )  # fmt: skip
    declared = record.meta.get("units") or {}
    gyro_units = args.gyro_units or declared.get(args.gyro[0])
    accel_units = args.accel_units or declared.get(args.accel[0])
    if not gyro_units or not accel_units:
        raise UsageError(
            "declare the units with --gyro-units (e.g. rad/s, deg/s) and --accel-units "
            "(e.g. m/s^2, g); adavar never guesses units"
        )
    fits = {}
    for k, (name, units) in enumerate([*((g, gyro_units) for g in args.gyro),
                                       *((a, accel_units) for a in args.accel)]):  # fmt: skip
        status(f"fitting the noise terms of {name} ({k + 1}/6)")
        result = deviation(record.channel(name), rate=record.rate, units=units)
        try:
            fits[name] = fit_noise(result)
        except ValueError as exc:
            raise AdavarInputError(f"column {name!r}: {exc}") from None
    kwargs = dict(
        gyro_fits=[fits[g] for g in args.gyro], accel_fits=[fits[a] for a in args.accel],
        rate=record.rate, topic=args.topic or "/imu0", gyro_units=gyro_units,
        accel_units=accel_units, combine=args.combine, inflate=args.inflate,
        pinned=args.pinned,
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
        raise _output_error(args.output, exc) from None
    status.close()
    if args.json:
        print(
            _dumps(
                {
                    "adavar_version": __version__,
                    "output": str(output),
                    "rate": record.rate,
                    "n_samples": record.n_samples,
                    "kalibr": values,
                }
            )
        )
        return EXIT_OK
    print(f"{args.file}: {record.n_samples} samples at {record.rate:g} Hz; wrote {output}")
    print(text)
    return EXIT_OK


def _cmd_simulate(args: argparse.Namespace) -> int:
    from adavar import simulate
    from adavar.export import write_text

    output = _check_output_file(args.output, args.force, (".csv",))
    status = _Status()
    terms = {"quantization": args.quantization, "angle_random_walk": args.arw,
             "bias_instability": args.bias_instability,
             "rate_random_walk": args.rrw, "rate_ramp": args.rate_ramp}  # fmt: skip
    if args.scenario is not None:
        if any(terms.values()) or args.bias or args.markov or args.sinusoid:
            raise UsageError(
                "--scenario simulates the paper's record; the sensor terms (--arw, --bias, "
                "--markov, ...) describe another one: drop them or --scenario"
            )
        status(f"simulating scenario {args.scenario}")
        sc = simulate.paper_scenario(
            args.scenario, seed=args.seed, variance_reading=args.variance_reading
        )
        x, rate, what = np.asarray(sc.data), float(sc.rate), sc.description
    else:
        if args.variance_reading:
            raise UsageError("--variance-reading chooses a --scenario's disturbance")
        if not any(v > 0 for v in terms.values()) and not (args.markov or args.sinusoid):
            raise UsageError(
                "give at least one noise coefficient (--arw, --bias-instability, --rrw, "
                "--quantization, --rate-ramp, --markov, --sinusoid) or --scenario 1|2"
            )
        if any(v < 0 for v in terms.values()):
            raise UsageError("noise coefficients must not be negative")
        status(f"simulating {args.n} samples")
        try:
            x = simulate.sensor(args.n, rate=args.rate, seed=args.seed, bias=args.bias,
                                markov=args.markov, sinusoid=args.sinusoid,
                                bandwidth=args.bandwidth, filter_order=args.filter_order,
                                lsb=args.lsb, **terms)  # fmt: skip
        except ValueError as exc:  # e.g. a sinusoid above the Nyquist frequency
            raise AdavarInputError(str(exc)) from None
        rate = float(args.rate)
        what = ", ".join(f"{k}={v:g}" for k, v in terms.items() if v > 0)
        for name, value in (("markov", args.markov), ("sinusoid", args.sinusoid)):
            if value:
                what += f"{', ' if what else ''}{name}={','.join(f'{v:g}' for v in value)}"
        for name, one in (("bandwidth", args.bandwidth), ("lsb", args.lsb)):
            if one is not None:
                what += f", {name}={one:g}"
    status(f"writing {output}")
    t = np.arange(x.size) / rate
    body = "\n".join(f"{ti!r},{xi!r}" for ti, xi in zip(t.tolist(), x.tolist(), strict=True))
    header = (f"# adavar {__version__} simulate, seed {args.seed}: {what}; "
              f"rate {rate:g} Hz, samples in {args.units}\ntime,x\n")  # fmt: skip
    try:
        write_text(output, header + body + "\n")
    except OSError as exc:
        raise _output_error(args.output, exc) from None
    status.close()
    if args.json:
        print(
            _dumps(
                {
                    "output": str(output),
                    "n_samples": int(x.size),
                    "rate": rate,
                    "units": args.units,
                    "seed": args.seed,
                    "what": what,
                }
            )
        )
    else:
        print(f"wrote {output}: {x.size} samples at {rate:g} Hz ({what})")
    return EXIT_OK


def _cmd_report(args: argparse.Namespace) -> int:
    from adavar.report import build_report, write_report

    output = _check_output_file(args.output, args.force, (".html", ".htm"))
    terms = args.terms or TERM_NAMES
    status = _Status()
    status(f"reading {args.file}")
    chosen = args.column is not None  # several channels only when --column names them
    loaded, meta, units_of, tau0 = _load(args, several=chosen, pieces=False)
    if not chosen:
        loaded, units_of = {meta["column"]: loaded}, {meta["column"]: units_of}
    names = list(loaded)
    several = len(names) > 1
    runs = []
    for k, name in enumerate(names):
        tag = f"{name} ({k + 1}/{len(names)}): " if several else ""
        runs.append(_report_channel(args, loaded[name], units_of[name], tau0, status, tag))
    first = runs[0]
    units = first["units"] if not several else "; ".join(
        f"{name}: {units_of[name]}" for name in names
    )  # fmt: skip
    parameters: dict[str, Any] = {
        "statistic": "oadev", "data type": args.data_type, "units": units,
        "rate [Hz]": 1.0 / tau0, "rate from": meta["rate_from"], "terms": ", ".join(terms),
    }  # fmt: skip
    if args.n_reweight != 3 or args.spacing != "octave":
        parameters.update({"fit reweighting passes": args.n_reweight,
                           "fit tau spacing": args.spacing})  # fmt: skip
    if first["surface"] is not None:
        parameters.update({"DAVAR taus": str(args.taus), "DAVAR step": args.step})
        if first["adaptive"] is not None:
            parameters.update({f"controller {k}": v
                               for k, v in first["adaptive"].parameters.items()
                               if v is not None})  # fmt: skip
        else:
            parameters["DAVAR window [samples]"] = args.window
    steps = [step.get("spec", str(step)) for step in meta["preprocessing"]]
    status("building the figures and the HTML")
    if several:
        title = args.title or f"{Path(meta['path']).name}, columns {', '.join(names)}"
        html = _channels_report(
            title=title,
            source={"file": meta["path"], "columns": ", ".join(names), "format": meta["kind"],
                    "samples": int(first["samples"])},
            runs=dict(zip(names, runs, strict=True)), parameters=parameters,
            preprocessing=steps,
        )  # fmt: skip
    else:
        title = args.title or f"{Path(meta['path']).name}, column {meta['column']}"
        html = build_report(
            title=title,
            source={"file": meta["path"], "column": meta["column"], "format": meta["kind"],
                    "samples": int(first["samples"])},
            deviation=first["result"], fit=first["fit"], surface=first["surface"],
            coefficients=first["coefficients"], adaptive=first["adaptive"],
            parameters=parameters, preprocessing=steps, units=first["rate_units"],
        )  # fmt: skip
    status(f"writing {output}")
    try:
        write_report(output, html)
    except OSError as exc:
        raise _output_error(args.output, exc) from None
    status.close()

    def channel_json(name: str, run: dict[str, Any]) -> dict[str, Any]:
        surface = run["surface"]
        return {
            "input": {"file": meta["path"], "column": name, "rate": 1.0 / tau0,
                      "units": run["units"], "n_samples": int(run["samples"]),
                      "preprocessing": steps},
            "fit": _fit_json(run["fit"]),
            "surface": None if surface is None else {
                "windows": int(np.shape(surface.avar)[0]),
                "taus": int(np.shape(surface.avar)[1]),
                "method": getattr(surface, "method", "fixed"),
            },
        }  # fmt: skip

    payload: dict[str, Any] = {
        "adavar_version": __version__,
        "report": str(output),
        "bytes": len(html.encode("utf-8")),
    }
    if several:
        payload["input"] = {"file": meta["path"], "columns": names, "rate": 1.0 / tau0,
                            "preprocessing": steps}  # fmt: skip
        payload["channels"] = {name: channel_json(name, run)
                               for name, run in zip(names, runs, strict=True)}  # fmt: skip
    else:
        payload.update(channel_json(names[0], first))
    if args.json:
        print(_dumps(payload))
        return EXIT_OK
    print(f"wrote {output} ({payload['bytes'] / 1e6:.1f} MB): {title}")
    for name, run in zip(names, runs, strict=True):
        if several:
            print(f"  column {name!r} ({run['units']}):")
        print("\n".join(_fit_lines(run["fit"], "    " if several else "  ")))
    return EXIT_OK


def _report_channel(
    args: argparse.Namespace, samples: np.ndarray, units: str, tau0: float, status: _Status,
    tag: str,
) -> dict[str, Any]:  # fmt: skip
    """The results of one channel shown in the report: deviation, fit, optional surface."""
    from adavar.plots import rate_unit

    rate_u = rate_unit(units, args.data_type)
    rate_kw = dict(
        rate=args.rate if args.rate is not None else 1.0,
        tau0=None if args.rate is not None else tau0,
    )  # fmt: skip
    status(f"{tag}deviation and noise fit of {samples.size} samples")
    result = deviation(samples, data_type=args.data_type, units=rate_u, **rate_kw)
    try:
        fit = fit_noise(result, **_fit_keywords(args))
    except ValueError as exc:
        raise AdavarInputError(str(exc)) from None
    surface = adaptive = coefficients = None
    common = dict(data_type=args.data_type, taus=args.taus, step=args.step, units=rate_u,
                  **rate_kw)  # fmt: skip
    if args.adaptive:
        status(f"{tag}adaptive DAVAR surface")
        adaptive = adaptive_davar(samples, **_controller_settings(args), **common)
        surface = adaptive
    elif args.window is not None:
        status(f"{tag}DAVAR surface")
        surface = davar(samples, window=args.window, **common)
    if surface is not None:
        status(f"{tag}noise coefficients of every window")
        try:
            coefficients = fit_noise(surface, **_fit_keywords(args))
        except ValueError as exc:
            raise AdavarInputError(str(exc)) from None
    return {
        "result": result, "fit": fit, "surface": surface, "adaptive": adaptive,
        "coefficients": coefficients, "units": units, "rate_units": rate_u,
        "samples": samples.size,
    }  # fmt: skip


def _channels_report(
    *, title: str, source: dict[str, Any], runs: dict[str, dict[str, Any]],
    parameters: dict[str, Any], preprocessing: list[str],
) -> str:  # fmt: skip
    """One HTML report with a section per channel (plots and coefficient table of each).

    The page (head, data, parameters, preprocessing, footer) is :func:`build_report`'s;
    the channel sections are made of its figure and table builders, with plot ids
    prefixed by the channel's number so that they stay unique.
    """
    from adavar import report as rp

    figures: dict[str, dict[str, Any]] = {}

    def plot(key: str, figure: dict[str, Any]) -> str:
        figures[key] = figure
        return f'<div class="plot" id="{key}"></div>'

    sections = []
    for k, (name, run) in enumerate(runs.items(), start=1):
        units, dev, fit = run["rate_units"], run["result"], run["fit"]
        stat = rp.STAT_NAMES.get(dev.stat, dev.stat)
        cap = (
            f"{stat} of {dev.n_samples} samples at {dev.rate:.6g} Hz ({dev.data_type} data), "
            f"{dev.tau.size} taus; bars: {100 * dev.confidence:.1f} % confidence interval. "
            "Hover for values."
        )
        parts = [
            f'<section id="channel-{k}" class="channel"><h2>Channel {rp._esc(name)} '
            f"({rp._esc(run['units'])})</h2>",
            "<h3>Deviation and noise fit</h3>",
            plot(f"plot-{k}-deviation", rp._deviation_figure(dev, fit, units)),
            f'<p class="caption">{rp._esc(cap)}</p>{rp._notes(dev.notes)}',
            f"<h3>Noise coefficients</h3>{rp._coefficient_table(fit, units)}",
        ]
        surface = run["surface"]
        if surface is not None:
            figure, caption = rp._surface_figure(surface, units)
            parts += [
                "<h3>Dynamic Allan deviation surface</h3>",
                plot(f"plot-{k}-surface", figure),
                f'<p class="caption">{rp._esc(caption)}</p>{rp._notes(surface.notes)}',
            ]
            figure, terms = rp._coefficient_figure(run["coefficients"], units)
            parts.append("<h3>Noise coefficients over time</h3>")
            if figure:
                parts.append(plot(f"plot-{k}-coefficients", figure))
                cap = (
                    f"{', '.join(terms)} of every window over time; band: ±1σ (clipped at "
                    "0; from 0 to the 1-sigma upper bound where a term is pinned at 0)."
                )
            else:
                cap = "No term is non-zero in any window."
            parts.append(f'<p class="caption">{rp._esc(cap)}</p>')
        if run["adaptive"] is not None:
            parts += [
                "<h3>Adaptive window controller</h3>",
                plot(f"plot-{k}-adaptive", rp._adaptive_figure(run["adaptive"])),
            ]
        parts.append("</section>")
        sections.append("".join(parts))  # fmt: skip

    page = rp.build_report(title=title, source=source, parameters=parameters,
                           preprocessing=preprocessing)  # fmt: skip
    plotly_js, plotly_version = rp._plotly_js()
    scripts = (
        f"<script>{plotly_js}</script>\n"
        f'<script type="application/json" id="adavar-figures">'
        f"{rp._script_json(figures)}</script>\n<script>{rp._RENDER_JS}</script>\n"
    )
    # after the data section (or at the top of <main>), before the parameters
    anchor = '<section id="parameters">' if parameters else "\n</main>"
    page = page.replace(anchor, "\n".join(sections) + "\n" + anchor, 1)
    page = page.replace(
        ".</footer>", f"; plots by plotly.js {rp._esc(plotly_version)} (embedded).</footer>", 1
    )
    return page.replace("\n</body>", "\n" + scripts + "</body>", 1)  # fmt: skip


def _demo_report(demo: Any) -> str:
    """The demo's HTML report: the simulated gyro, and the paper's scenario 1 with A-DAVAR."""
    from adavar.report import build_report

    gyro = demo.gyro
    paper = demo.paper
    adaptive = coefficients = comparison = None
    if paper is not None:
        comparison = paper.comparison
        adaptive = adaptive_davar(comparison.data, rate=comparison.rate, taus="octave")
        coefficients = fit_noise(adaptive)
    return build_report(
        title="adavar demo: a simulated MEMS gyro and the A-DAVAR paper's scenario 1",
        source={"gyro": f"simulated, {gyro.n_samples} samples at {gyro.rate:g} Hz in "
                f"{gyro.units}, seed {gyro.seed}",
                "scenario": None if comparison is None else comparison.description},
        deviation=gyro.result, fit=gyro.fit, surface=adaptive, coefficients=coefficients,
        adaptive=adaptive, comparison=comparison,
        parameters={"gyro statistic": "oadev, octave taus",
                    "A-DAVAR": "Lmax 600, Lmin 400, K1 2.5, K2 3.3, S2 0.07, l 100"},
        units=gyro.units,
    )  # fmt: skip


def _cmd_demo(args: argparse.Namespace) -> int:
    from adavar.demo import GYRO_BANDWIDTH, GYRO_BIAS, GYRO_LSB, run_demo
    from adavar.plots import deviation_figure, save_figure

    start = time.perf_counter()
    _check_demo_out(args.out, args.force)
    status = _Status()
    status("NIST check values, a simulated gyro and the paper's scenario 1")
    demo = run_demo(seed=args.seed)
    gyro = demo.gyro
    status("drawing the figures")
    fig = deviation_figure(
        gyro.result, gyro.fit,
        title=f"Simulated MEMS gyro ({gyro.n_samples:,} samples at {gyro.rate:g} Hz, "
        f"seed {gyro.seed})",
    )  # fmt: skip
    files = ["gyro_oadev.png", "gyro_oadev.svg", "demo.json"]
    tables: dict[str, str] = {}
    figures: dict[str, Any] = {}
    paper = demo.paper
    if paper is not None:
        tables = {
            f"paper_{name}": body
            for name, body in _compare_tables(
                paper.comparison, paper.study, paper.thresholds
            ).items()
        }
        figures = _compare_figures(paper.comparison, paper.kurtosis, paper.thresholds)
        files += [*tables, *(f"{stem}.{ext}" for stem in figures for ext in ("png", "svg"))]
    files.append("report.html")
    status("building the HTML report")
    html = _demo_report(demo)
    payload = _demo_json(demo, str(args.out), files)
    text = _dumps(payload)
    status(f"writing {args.out}")
    try:
        with atomic_directory(args.out, replace=True) as tmp:
            save_figure(fig, tmp / "gyro_oadev")
            for name, body in tables.items():
                (tmp / name).write_text(body, encoding="utf-8")
            for stem, paper_fig in figures.items():
                save_figure(paper_fig, tmp / stem)
            (tmp / "demo.json").write_text(text + "\n", encoding="utf-8")
            (tmp / "report.html").write_text(html, encoding="utf-8")
            (tmp / DEMO_MARKER).write_text(
                "written by adavar demo; the next run replaces this folder\n", encoding="utf-8"
            )
    except OSError as exc:
        raise _output_error(args.out, exc) from None
    status.close()
    elapsed = time.perf_counter() - start

    if args.json:
        print(text)
        print(f"adavar: wrote {args.out}/ ({', '.join(files)})", file=sys.stderr)
        return EXIT_OK

    print("1. NIST SP 1065 1000-point test data (fractional frequency, tau0 = 1 s)")
    rows = [
        [r.stat.upper(), f"{r.averaging_factor}", f"{r.computed:.7e}", f"{r.published:.6e}",
         f"{r.rel_diff:+.1e}"]
        for r in demo.nist
    ]  # fmt: skip
    for r in (demo.nist_mean, demo.nist_std):
        rows.append([r.stat, "", f"{r.computed:.7e}", f"{r.published:.6e}", f"{r.rel_diff:+.1e}"])
    print(_table(["stat", "AF", "adavar", "published", "rel. diff"], rows, "   "))
    print(
        f"   largest |relative difference| of the deviations: {demo.nist_max_rel_diff:.1e} "
        "(the published values have 7 significant digits)"
    )
    print()
    print(
        f"2. Simulated MEMS gyro: {gyro.n_samples} samples at {gyro.rate:g} Hz in {gyro.units} "
        f"(bias {GYRO_BIAS:g} {gyro.units}, {GYRO_BANDWIDTH:g} Hz low-pass, LSB "
        f"{GYRO_LSB:.3g} {gyro.units}, seed {gyro.seed}), OADEV at octave taus"
    )
    print(_deviation_table(gyro.result, "   "))
    print()
    print("\n".join(_fit_lines(gyro.fit, "   ", true=gyro.true_conventional)))
    print()
    if paper is not None:
        print(
            "3. The A-DAVAR paper's scenario 1 (Micromachines 2018, 9(8), 373): "
            "DAVAR-400, DAVAR-600, DAVAR-K and A-DAVAR"
        )
        report = "\n".join(_compare_report(paper.comparison, paper.study, paper.thresholds))
        print("\n".join("   " + line if line else line for line in report.splitlines()))
        print()
    print(f"wrote {Path(args.out) / files[0]} and {', '.join(files[1:])}")
    print(f"done in {elapsed:.1f} s (computation {demo.elapsed:.2f} s)")
    return EXIT_OK


# --------------------------------------------------------------------------------------
# batch
# --------------------------------------------------------------------------------------

#: Most files listed one per line by ``adavar batch`` (beyond: the failed ones only).
_BATCH_LISTED = 50


def _duration(seconds: float) -> str:
    seconds = max(0, round(seconds))
    if seconds < 60:
        return f"{seconds} s"
    if seconds < 3600:
        return f"{seconds // 60} min {seconds % 60:02d} s"
    return f"{seconds // 3600} h {seconds // 60 % 60:02d} min"


class _BatchProgress(_ProgressBar):
    """The batch's bar: files done of all, errors so far, time left (only on a terminal)."""

    def __init__(self) -> None:
        super().__init__("batch")
        self.errors = 0
        self.computed = 0

    def __call__(self, done: int, total: int, row: dict[str, Any] | None = None) -> None:
        if row is not None:
            self.errors += row.get("status") == "error"
            self.computed += row.get("status") != "done"
        if not self.enabled or total <= 0:
            return
        elapsed = time.perf_counter() - self.start
        filled = int(20 * done / total)
        left = (f", {_duration(elapsed / self.computed * (total - done))} left"
                if self.computed and done < total else "")  # fmt: skip
        errors = f", {self.errors} error{'s' if self.errors != 1 else ''}" if self.errors else ""
        line = f"\rbatch [{'#' * filled}{'-' * (20 - filled)}] {done}/{total} files{errors}{left}"
        print(line.ljust(80)[:80], end="", file=sys.stderr, flush=True)


def _batch_row_line(row: dict[str, Any]) -> list[str]:
    from adavar.plots import format_pm

    n_value = row.get("N")
    coefficient = (
        "" if n_value is None else f"N = {format_pm(n_value, row['N_uncertainty'], row['N_unit'])}"
    )
    events = "" if row.get("n_events") is None else str(row["n_events"])
    elapsed = "" if row.get("elapsed_s") is None else f"{row['elapsed_s']:.1f}"
    return [row["name"], row["status"], coefficient, events, elapsed]


def _batch_error(row: dict[str, Any]) -> str:
    """A failed row's error, naming its file once."""
    error = row["error"] or "failed"
    return error if row["file"] in error else f"{row['file']}: {error}"


def _cmd_batch(args: argparse.Namespace) -> int:
    from adavar.batch import collect_files, report_options, run_batch

    files = collect_files(args.inputs, files_from=args.files_from)
    options = report_options(args, ignore_unknown=True)
    progress = _BatchProgress()
    try:
        result = run_batch(
            files, out=args.out, options=options, scheduler=args.scheduler,
            workers=args.workers, force=args.force, progress=progress, timeout=args.timeout,
            html=args.html,
        )  # fmt: skip
    finally:
        progress.close()
    counts = result.counts
    failed = [row for row in result.rows if row["status"] == "error"]
    code = EXIT_INTERNAL if counts["internal_errors"] else (EXIT_USAGE if failed else EXIT_OK)
    computed = counts["ok"] + counts["error"]
    summary = [str(result.summary_csv)]
    if result.summary_parquet is not None:
        summary.append(str(result.summary_parquet))
    if args.json:
        print(_dumps({
            "adavar_version": __version__, "out": str(result.out), "cluster": result.cluster,
            "counts": counts, "elapsed_s": result.elapsed_s,
            "files_per_minute": 60.0 * computed / result.elapsed_s if computed else None,
            "summary": {"csv": summary[0], "parquet": summary[1] if len(summary) > 1 else None},
            "notes": list(result.notes), "exit_code": code, "rows": result.rows,
        }))  # fmt: skip
    else:
        print(
            f"adavar batch: {counts['files']} files {result.cluster} in "
            f"{_duration(result.elapsed_s)}: {counts['ok']} ok, {counts['done']} done earlier "
            f"(skipped), {counts['error']} failed"
        )
        if len(result.rows) <= _BATCH_LISTED:
            rows = [_batch_row_line(row) for row in result.rows if row["status"] != "error"]
            if rows:
                print(_table(["output", "status", "whole-record fit", "events", "s"], rows,
                             "  "))  # fmt: skip
        for row in failed:
            print(f"  error in {row['name']}: {_batch_error(row)}")
        for note in result.notes:
            print(f"note: {note}")
        print(f"wrote {' and '.join(summary)}")
    if failed:
        first = failed[0]
        print(
            f"adavar: error: {len(failed)} of {counts['files']} files failed (first: "
            f"{_batch_error(first)}); every file's row is in {summary[0]}: fix them and "
            "rerun with the same --out (the finished files are skipped)",
            file=sys.stderr,
        )
    return code


# --------------------------------------------------------------------------------------
# Entry point
# --------------------------------------------------------------------------------------


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _with_config(parser: argparse.ArgumentParser, argv: list[str]) -> list[str]:
    """``argv`` with the settings of ``--config FILE.toml`` placed before the user's flags.

    The TOML file sets any option of the command by its long name (``window = 600``,
    ``taus = "octave"``, ``fit = true``, ``column = ["gx", "gy"]``), at its top level or
    in a table named after the command (``[davar]``, which wins). Flags given on the
    command line come later and so override the file. The data FILE stays on the command
    line.
    """
    if "--config" not in argv and not any(a.startswith("--config=") for a in argv):
        return argv
    import tomllib

    rest: list[str] = []
    path = None
    it = iter(argv)
    for token in it:
        if token == "--config":
            path = next(it, None)
            if path is None:
                raise UsageError("--config needs a FILE.toml")
        elif token.startswith("--config="):
            path = token.split("=", 1)[1]
        else:
            rest.append(token)
    if not rest or rest[0].startswith("-"):
        raise UsageError("--config belongs after a command, e.g. adavar davar --config run.toml")
    command = rest[0]
    try:
        with open(path, "rb") as fh:
            table = tomllib.load(fh)
    except FileNotFoundError:
        raise UsageError(f"--config {path}: no such file") from None
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise UsageError(f"--config {path}: not a readable TOML file ({exc})") from None
    settings = {k: v for k, v in table.items() if not isinstance(v, dict)}
    section = table.get(command, {})
    if not isinstance(section, dict):
        raise UsageError(f"--config {path}: [{command}] must be a table")
    settings.update(section)
    sub = next(
        (a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None
    )  # fmt: skip
    cmd_parser = None if sub is None else sub.choices.get(command)
    if cmd_parser is None:
        return rest  # argparse reports the unknown command
    options = {
        opt[2:]: action
        for action in cmd_parser._actions
        for opt in action.option_strings
        if opt.startswith("--")
    }
    tokens: list[str] = []
    for key, value in settings.items():
        name = str(key).replace("_", "-")
        action = options.get(name)
        if action is None or name in ("config", "help", "debug"):
            raise UsageError(
                f"--config {path}: {key!r} is not an option of 'adavar {command}' (see "
                f"'adavar {command} --help')"
            )
        if isinstance(action, argparse._StoreTrueAction):
            if not isinstance(value, bool):
                raise UsageError(f"--config {path}: {key} takes true or false")
            if value:
                tokens.append(f"--{name}")
            continue
        if isinstance(action, argparse.BooleanOptionalAction):  # --lazy / --no-lazy
            if not isinstance(value, bool) or name.startswith("no-"):
                raise UsageError(f"--config {path}: {key} takes true or false")
            tokens.append(f"--{name}" if value else f"--no-{name}")
            continue
        if isinstance(value, list):
            value = ",".join(str(v) for v in value)
        elif isinstance(value, bool):
            raise UsageError(f"--config {path}: {key} takes a value, not true/false")
        tokens += [f"--{name}", str(value)]
    return [command, *tokens, *rest[1:]]


def _clear_status_line() -> None:
    """Erase a status or progress line a failed command left on the terminal."""
    if sys.stderr.isatty():
        print("\r" + " " * 79 + "\r", end="", file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``adavar`` command line.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments after the program name; ``sys.argv[1:]`` by default.

    Returns
    -------
    int
        The exit code: 0 success, 1 internal error, 2 user error, 130 interrupted.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv or os.environ.get("ADAVAR_DEBUG", "").strip() not in ("", "0")
    try:
        parser = build_parser()
        argv = _with_config(parser, argv)
        args = parser.parse_args(argv)
        if args.command is None:
            raise UsageError(
                "choose a command: avar (deviation of a data file), davar (dynamic Allan "
                "variance of a data file), adaptive (A-DAVAR), compare (fixed and adaptive "
                "windows side by side), report (HTML report), batch (many files, on a "
                "cluster), kalibr (imu.yaml), simulate or demo (see 'adavar --help')"
            )
        return int(args.handler(args))
    except SystemExit as exc:  # --help, --version
        code = exc.code
        return code if isinstance(code, int) else (EXIT_OK if code is None else EXIT_USAGE)
    except (UsageError, AdavarInputError) as exc:
        _clear_status_line()
        print(f"adavar: error: {_one_line(str(exc))}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("adavar: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # e.g. `adavar avar ... | head`
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError, _stdio.UnsupportedOperation):
            pass
        return EXIT_INTERNAL
    except Exception as exc:
        _clear_status_line()
        if debug:
            traceback.print_exc()
        hint = "" if debug else " (rerun with --debug or ADAVAR_DEBUG=1 for the traceback)"
        print(
            f"adavar: internal error: {type(exc).__name__}: {_one_line(str(exc))}{hint}",
            file=sys.stderr,
        )
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())

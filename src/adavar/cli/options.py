"""Command-line options: exit codes, the usage error, the checks of flags against each other
and the option groups shared by several commands (the values of single flags are parsed by
:mod:`adavar.cli.values`)."""

from __future__ import annotations

import argparse
import os
import sys

from adavar.cli.values import (
    confidence_or_none,
    figure_formats,
    finite_float,
    fraction,
    length_arg,
    number_tuple,
    parse_confidence,
    parse_noise_type,
    parse_preprocess,
    parse_seed,
    parse_taus,
    parse_terms,
    points_per_decade,
    positive_float,
    positive_int,
    probability,
    sample_rate,
    tau_range,
    whole_list,
)
from adavar.core.settings import (
    CONTROLLER,
    DATA_TYPE_DEFAULT,
    DEFAULT_MAX_MEMORY_MB,
    FIT,
    HOURLY_FALSE_ALARMS,
    ICI_EDF,
    ICI_GAMMA,
    ICI_SIDES,
    MAX_ALL_TAUS,
)
from adavar.core.terms import TERMS
from adavar.core.units import RATE_UNITS, is_known_unit
from adavar.dynamic.windows import EDGES
from adavar.io.preprocess import MAX_DETREND_ORDER
from adavar.io.writers import (
    SURFACE_FORMATS,
)
from adavar.output._figures import DEFAULT_FIGURE_FORMATS, FIGURE_FORMATS

EXIT_OK = 0


EXIT_INTERNAL = 1


EXIT_USAGE = 2


EXIT_INTERRUPTED = 130


#: Destinations of the flags of the kurtosis controller (adaptive, kurtosis): --method ici
#: has no kurtosis or S test and ignores them.
KURTOSIS_CONTROLLER = frozenset({
    "k1", "k2", "s1", "s2", "dl0", "dl1", "s_test", "combine", "thresholds", "false_alarm",
    "false_alarm_per_hour", "dependence", "kurtosis_reference",
})  # fmt: skip

#: File name (without suffix) of the coefficient figure of each term in a davar --out folder.
TERM_FILES = {t.name: t.short for t in TERMS}


class UsageError(Exception):
    """A mistake on the command line (exit code 2)."""


#: The attribute of a parsed namespace that lists the flags given (destination -> the flag
#: as typed), for the checks of flags that the chosen mode ignores.
GIVEN = "given_flags"


def _note_given(namespace: argparse.Namespace, dest: str, flag: str | None) -> None:
    given = dict(getattr(namespace, GIVEN, None) or {})
    given[dest] = flag or f"--{dest.replace('_', '-')}"
    setattr(namespace, GIVEN, given)


class Given(argparse.Action):
    """``store``, noting the flag as given (on the command line or in ``--config``)."""

    def __call__(
        self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
        option_string: str | None = None,
    ) -> None:  # fmt: skip
        setattr(namespace, self.dest, values)
        _note_given(namespace, self.dest, option_string)


class GivenBoolean(argparse.BooleanOptionalAction):
    """``--flag/--no-flag``, noting the flag as given."""

    def __call__(
        self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
        option_string: str | None = None,
    ) -> None:  # fmt: skip
        super().__call__(parser, namespace, values, option_string)
        _note_given(namespace, self.dest, option_string)


def given_flags(args: argparse.Namespace) -> dict[str, str]:
    """The flags of ``args`` given on the command line (or in ``--config``), among those
    parsed by :class:`Given`: destination -> the flag as typed."""
    return dict(getattr(args, GIVEN, None) or {})


def check_not_stdin(args: argparse.Namespace) -> None:
    """FILE ``-`` (standard input) is an error naming the way out: the commands that read a
    FILE read it whole, from its path (``-`` said "-: no such file"); ``adavar monitor``
    reads a stream on standard input. A file named ``-`` is read as before."""
    file = getattr(args, "file", None)
    if file == "-" and not os.path.exists(file):
        command = getattr(args, "command", None) or "this command"
        live = ("" if command == "kalibr" else  # monitor writes no imu.yaml
                ", or run the adaptive window on the live stream with 'adavar monitor -' "
                "(see 'adavar monitor --help')")  # fmt: skip
        raise UsageError(
            f"adavar {command} does not read standard input (FILE -): save the samples to a "
            f"file and give its path{live}"
        )


def warn(message: str) -> None:
    """One ``adavar: warning:`` line on stderr."""
    print(f"adavar: warning: {' '.join(message.split())}", file=sys.stderr)


def check_arguments(args: argparse.Namespace) -> None:
    """Flags that contradict or miss each other, before any work: ``--force`` without
    ``--out``, an empty ``--s-test band``, ``--change-times`` that no method uses (a
    warning), and an ``--units`` adavar does not know (a warning: it is a free label)."""
    check_not_stdin(args)
    if getattr(args, "force", False) and "out" in vars(args) and args.out is None:
        raise UsageError(
            "--force replaces an existing --out folder: give --out DIR as well, or drop --force"
        )
    if getattr(args, "s_test", None) == "band" and getattr(args, "thresholds", "paper") == "paper":
        if not args.s1 < args.s2:
            raise UsageError(
                f"--s-test band flags S outside [S1, S2], but --s1 {args.s1:g} is not below "
                f"--s2 {args.s2:g}: give --s1 < --s2"
            )
    if getattr(args, "adaptive", False) and getattr(args, "window", None) is not None:
        raise UsageError(
            "--window L asks for a fixed window and --adaptive for the adaptive one: give one "
            "of them (the adaptive window's lengths are --lmax and --lmin)"
        )
    check_controller_flags(args)
    check_chunk_size(args)
    if getattr(args, "f_h", None) is not None and getattr(args, "power_law", None) == "off":
        raise UsageError(
            "--f-h is not used with --power-law off (it is the bandwidth of the power-law "
            "fit): drop --f-h, or --power-law off"
        )
    method = getattr(args, "method", None)
    if getattr(args, "command", None) == "adaptive" and args.change_times and method != "oracle":
        if args.out is None:
            warn(
                f"--change-times has no effect with --method {method} and no --out: add "
                "--method oracle (the ideal schedule of those changes), or --out DIR to mark "
                "them in the controller figure"
            )
        else:
            warn(
                f"--change-times only marks the changes in the controller figure: the window "
                f"is --method {method}'s; add --method oracle for the ideal schedule of them"
            )
    file = getattr(args, "file", None)
    if "data_type" in vars(args) and isinstance(file, str):  # a Stable32 .phd: phase
        from adavar.readers import file_data_type

        args.data_type = file_data_type(file, args.data_type)
    units = getattr(args, "units", None)
    if isinstance(units, str) and units.strip():
        data_type = getattr(args, "data_type", "rate")
        if not is_known_unit(units, data_type):
            warn(_unknown_units(units.strip(), data_type))


def _unknown_units(units: str, data_type: str) -> str:
    """The warning for ``--units`` that :func:`is_known_unit` does not take for
    ``data_type``, listing the ones it takes (for phase data: those it knows, not every
    rate unit's integral; a rate unit given with --data-type phase is said to be one)."""
    from adavar.core.units import known_phase_units

    free = "the results are in it as given, without conventional units"
    if data_type != "phase":
        known = f"{', '.join(RATE_UNITS)}; or a fractional frequency: 1, ns/s"
        return f"--units {units!r} is not a unit adavar knows for rate data ({known}): {free}"
    phase = f"a rate's integral or a clock's time error: {', '.join(known_phase_units())}"
    if is_known_unit(units, "rate"):
        return (f"--units {units!r} is a unit of rate data, not of --data-type phase ({phase})"
                f": drop --data-type phase if the samples are the rate; else {free}")  # fmt: skip
    return f"--units {units!r} is not a unit adavar knows for phase data ({phase}): {free}"


def listed_flags(flags: list[str]) -> str:
    return ", ".join(flags[:-1]) + f" and {flags[-1]}" if len(flags) > 1 else flags[0]


def ignored(flags: list[str], why: str, way_out: str) -> UsageError:
    verb = "are" if len(flags) > 1 else "is"
    return UsageError(f"{listed_flags(flags)} {verb} not used {why}: {way_out}")


def check_controller_flags(args: argparse.Namespace) -> None:
    """A flag of the adaptive window that the chosen mode ignores is an error (exit 2): the
    run would silently use something else than what was asked (``--k1 2`` with calibrated
    thresholds recorded 2 and ran with 2.62). One line naming the flags, the mode and the
    way out. Only flags given (:func:`given_flags`) count, never the defaults."""
    from adavar.core.settings import BAND_ONLY, CALIBRATED_ONLY, CALIBRATED_REPLACES, HOURLY_ONLY

    given = given_flags(args)
    if not given:
        return
    method = getattr(args, "method", None)
    ici = [flag for dest, flag in given.items() if dest.startswith("ici_")]
    if ici and method != "ici":
        raise ignored(ici, f"by --method {method or 'adaptive'} (only --method ici uses "
                       f"{'them' if len(ici) > 1 else 'it'})",
                       f"add --method ici, or drop {listed_flags(ici)}")  # fmt: skip
    if method == "ici":
        kurtosis = [flag for dest, flag in given.items() if dest in KURTOSIS_CONTROLLER]
        if kurtosis:
            way_out = f"drop {listed_flags(kurtosis)}, or choose --method adaptive"
            raise ignored(kurtosis, "by --method ici (it has no kurtosis or S test)", way_out)
        return
    thresholds = getattr(args, "thresholds", None)
    if thresholds is None:
        return
    how = "--thresholds calibrated" + ("" if "thresholds" in given else ", the default")
    if "false_alarm" in given and "false_alarm_per_hour" in given:
        raise UsageError(
            f"{given['false_alarm']} (false alarms a step) and {given['false_alarm_per_hour']} "
            "(false events an hour) both set the rate of the calibrated thresholds: give one "
            "of them"
        )
    if thresholds == "calibrated":
        replaced = [given[d] for d in CALIBRATED_REPLACES if d in given]
        if replaced:
            per_hour = "false_alarm" not in given and hasattr(args, "false_alarm_per_hour")
            rate = "--false-alarm-per-hour" if per_hour else "--false-alarm"
            raise ignored(replaced, f"with {how} (its K1, K2, S2 come from {rate})",
                           f"add --thresholds paper to use {'them' if len(replaced) > 1 else 'it'}"
                           f", or drop {listed_flags(replaced)}")  # fmt: skip
        hourly = [given[d] for d in HOURLY_ONLY if d in given]
        if hourly and "false_alarm" in given:
            raise ignored(hourly, f"with {given['false_alarm']} (per-step thresholds)",
                           f"drop {given['false_alarm']} for the hourly thresholds, or drop "
                           f"{listed_flags(hourly)}")  # fmt: skip
    else:
        calibrated = [given[d] for d in CALIBRATED_ONLY if d in given]
        if calibrated:
            way_out = f"add --thresholds calibrated, or drop {listed_flags(calibrated)}"
            raise ignored(calibrated, "with --thresholds paper (K1, K2, S2 as given)", way_out)
    s_test = getattr(args, "s_test", None)
    band = [given[d] for d in BAND_ONLY if d in given]
    if band and s_test != "band":
        raise ignored(band, f"with --s-test {s_test} (S1 bounds --s-test band only)",
                       f"add --s-test band, or drop {listed_flags(band)}")  # fmt: skip


def check_chunk_size(args: argparse.Namespace) -> None:
    """A warning for a ``--chunk-size`` so small that reading a piece costs more than
    analysing it (1e5 samples: 0.85 s in memory, 1.6 s at 64, 4.0 s at 16, 22 s at 1)."""
    from adavar.core.settings import EFFICIENT_CHUNK

    size = getattr(args, "chunk_size", None)
    if size is not None and size < EFFICIENT_CHUNK:
        warn(
            f"--chunk-size {size} reads the record {size} samples at a time: below "
            f"{EFFICIENT_CHUNK} each piece costs more than its samples (1e5 samples took 22 s "
            f"at 1, 1.6 s at 64, 0.9 s at {EFFICIENT_CHUNK}); give --chunk-size "
            f"{EFFICIENT_CHUNK} or more ({EFFICIENT_CHUNK} samples are "
            f"{8 * EFFICIENT_CHUNK // 1024} KiB)"
        )


def check_change_times(times: list[float] | None, n_samples: int, tau0: float) -> None:
    """``--change-times`` inside the record of ``n_samples`` samples every ``tau0`` s
    (the times count from its first sample, after any ``--preprocess``)."""
    duration = n_samples * tau0
    outside = [t for t in times or () if not 0.0 < t < duration]
    if outside:
        raise UsageError(
            f"--change-times {outside[0]:g} s lies outside the record (0 .. {duration:g} s, "
            "counted from its first sample): give times inside it"
        )


def add_time_arguments(cmd: argparse.ArgumentParser) -> None:
    """``--time-column`` and ``--time-format``: where the time stamps are, in what unit."""
    cmd.add_argument(
        "--time-column", metavar="NAME",
        help="column of time stamps (default: one named time, t, timestamp, ...; "
        "'header' or 'bag' for ROS bags; 'none': no time column, give --rate)",
    )  # fmt: skip
    cmd.add_argument(
        "--time-format", default="auto", choices=("auto", "s", "ms", "us", "ns", "iso", "mjd"),
        help="unit or format of the time column (default: auto; ROS stamps: ns)",
    )  # fmt: skip


def add_input_arguments(
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
    add_time_arguments(cmd)
    cmd.add_argument(
        "--gaps", default="error", choices=("error", "split", "interpolate"),
        help="a gap in the time stamps is an error (default), splits the record into "
        "gap-free pieces analysed one by one (avar), or is filled by linear interpolation",
    )  # fmt: skip
    cmd.gap_ways = ("interpolate",)  # type: ignore[attr-defined]  # a Parser's; avar widens it
    cmd.add_argument(
        "--gap-tolerance", type=fraction, default=0.5, metavar="F",
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
        "--preprocess", metavar="STEPS", type=parse_preprocess,
        help="comma-separated steps applied in order: detrend:ORDER (ORDER 0 to "
        f"{MAX_DETREND_ORDER}), mean, decimate:K[:average], select:START:STOP (seconds); e.g. "
        "detrend:3,decimate:100 (the paper's real-data steps)",
    )  # fmt: skip
    cmd.add_argument(
        "--column", metavar="NAME[,NAME...]" if several else "NAME",
        help="header name or 0-based index of the channel; several, comma-separated (e.g. "
        "gx,gy,gz), are analysed one by one (needed when the file has several numeric "
        "columns)"
        if several
        else "header name or 0-based index of the column (needed if there are several)",
    )  # fmt: skip
    cmd.add_argument(
        "--rate", metavar="HZ", type=sample_rate("--rate"),
        help="sample rate in Hz, 1e-12 .. 1e12 (required, or --tau0)",
    )  # fmt: skip
    cmd.add_argument(
        "--tau0", metavar="SECONDS", type=sample_rate("--tau0"),
        help="sample interval in seconds, 1e-12 .. 1e12, instead of --rate",
    )  # fmt: skip
    cmd.add_argument(
        "--units", metavar="UNIT",
        help="unit of the samples, e.g. deg/s, deg/h, rad/s, m/s^2, g (required); with "
        "--data-type phase the unit of the integrated samples, e.g. deg or s",
    )  # fmt: skip


def add_figures_argument(cmd: argparse.ArgumentParser, where: str, without: str) -> None:
    """``--figures FORMATS``: the figures written ``where``; ``none`` writes ``without``."""
    cmd.add_argument(
        "--figures", type=figure_formats, default=DEFAULT_FIGURE_FORMATS, metavar="FORMATS",
        help=f"formats of the figures{where}: comma-separated among "
        f"{', '.join(FIGURE_FORMATS)}, or none ({without} only, and no time spent drawing; "
        f"default: {','.join(DEFAULT_FIGURE_FORMATS)})",
    )  # fmt: skip


def add_output_arguments(cmd: argparse.ArgumentParser, out_help: str) -> None:
    """--out DIR, --figures, --force and the hidden --debug of an analysis command."""
    cmd.add_argument("--out", metavar="DIR", help=out_help)
    add_figures_argument(cmd, " written into --out", "tables and result.json")
    cmd.add_argument("--force", action="store_true",
                     help="replace an existing --out folder that adavar wrote")  # fmt: skip
    cmd.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )


def add_controller_arguments(cmd: argparse.ArgumentParser, *, hourly: bool = True) -> None:
    """The adaptive window's settings (docs/method.md section 8).

    ``hourly``: thresholds calibrated for ``--false-alarm-per-hour`` by default (adaptive,
    report, batch); otherwise the paper's (compare).
    """
    cmd.add_argument("--lmax", type=length_arg(5), metavar="L",
                      help="longest window: samples, or a duration such as 6s or 10min "
                      "(default: a tenth of the record, as the paper's 600 of 6000 "
                      "samples)")  # fmt: skip
    cmd.add_argument("--lmin", type=length_arg(5), metavar="L",
                      help="shortest window: samples or a duration (default: two thirds of "
                      "Lmax)")  # fmt: skip
    cmd.add_argument("--k1", type=finite_float, action=Given, default=CONTROLLER.k1, metavar="K",
                      help="lower kurtosis threshold, --thresholds paper only (default: "
                      "2.5)")  # fmt: skip
    cmd.add_argument("--k2", type=finite_float, action=Given, default=CONTROLLER.k2, metavar="K",
                      help="upper kurtosis threshold, --thresholds paper only (default: "
                      "3.3)")  # fmt: skip
    cmd.add_argument("--s1", type=finite_float, action=Given, default=CONTROLLER.s1, metavar="S",
                      help="lower S threshold, --s-test band only (default: 0)")  # fmt: skip
    cmd.add_argument("--s2", type=finite_float, action=Given, default=CONTROLLER.s2, metavar="S",
                      help="upper S threshold, --thresholds paper only (default: "
                      "0.07)")  # fmt: skip
    cmd.add_argument("--l", type=length_arg(1), metavar="N",
                      dest="segment",
                      help="leading segment of the S test: samples or a duration (default: a "
                      "sixth of Lmax)")  # fmt: skip
    cmd.add_argument("--dl0", type=parse_seed, action=Given, default=CONTROLLER.dl0, metavar="N",
                      help="regrow step, samples (default: 2)")  # fmt: skip
    cmd.add_argument("--dl1", type=parse_seed, action=Given, default=CONTROLLER.dl1, metavar="N",
                      help="shrink step, samples (default: 2)")  # fmt: skip
    cmd.add_argument(
        "--s-test",
        action=Given,
        default=CONTROLLER.s_test,
        choices=("upper", "band", "abs"),
        help="f2 test: S > S2 (default), S outside [S1, S2], |S| > S2",
    )
    cmd.add_argument("--combine", action=Given, default=CONTROLLER.combine,
                     choices=("or", "and"),
                      help="f = f1 or f2 (default) / f1 and f2")  # fmt: skip
    cmd.add_argument(
        "--thresholds", action=Given, default="calibrated" if hourly else "paper",
        choices=("paper", "calibrated"),
        help=("calibrated (default): for --false-alarm-per-hour false events per stationary "
              "hour; paper: K1, K2, S2 as given" if hourly else
              "paper: K1, K2, S2 as given (default); calibrated: from the sampling "
              "distribution of the kurtosis for --false-alarm"),
    )  # fmt: skip
    if hourly:
        cmd.add_argument("--false-alarm-per-hour", action=Given,
                          type=positive_float("false events per hour"),
                          default=HOURLY_FALSE_ALARMS, metavar="F",
                          help="false events per hour of stationary data of --thresholds "
                          "calibrated (default: 0.1)")  # fmt: skip
    cmd.add_argument(
        "--false-alarm",
        action=Given,
        type=parse_confidence,
        default=None if hourly else CONTROLLER.false_alarm,
        metavar="P",
        help="per-step false-alarm rate of --thresholds calibrated"
        + (" (instead of the per-hour rate)" if hourly else " (default: 0.01)"),
    )


def add_fit_range_arguments(cmd: argparse.ArgumentParser) -> None:
    """``--tau-range`` and ``--bandwidth``: the taus the noise fit may use."""
    cmd.add_argument(
        "--tau-range", type=tau_range, metavar="MIN:MAX",
        help="fit only the taus from MIN to MAX seconds (either may be empty)",
    )  # fmt: skip
    cmd.add_argument(
        "--bandwidth", type=positive_float("Hz"), metavar="HZ",
        help="the sensor's bandwidth (Hz, datasheet or filter setting): taus below "
        "2/bandwidth are left out of the fit",
    )  # fmt: skip


def add_fit_arguments(cmd: argparse.ArgumentParser) -> None:
    """The noise fit's options (:func:`adavar.fit_noise`)."""
    cmd.add_argument(
        "--fit-method", default=FIT.method, choices=("auto", "gls", "wls", "slopes"),
        help="noise fit: gls (full covariance of the taus, term selection, roll-off "
        "handling; the default for one curve), wls (diagonal edf weights, every term; the "
        "default for DAVAR windows and the behaviour before 0.2), slopes (the classical "
        "slope-line read-offs)",
    )  # fmt: skip
    cmd.add_argument(
        "--select", default=FIT.select, choices=("aic", "bic", "significance", "none"),
        help="gls: choose the terms by comparing the likelihoods of every subset, with "
        "Akaike's penalty (aic, default) or the Bayesian one (bic); or the elimination of "
        "terms below --significance sigma (the behaviour before 0.3); or keep every --terms "
        "term",
    )  # fmt: skip
    cmd.add_argument(
        "--significance", type=positive_float("sigma"), default=FIT.significance, metavar="Z",
        help="gls with --select significance: the significance a term needs to stay in the "
        "model (default: 2)",
    )  # fmt: skip
    cmd.add_argument(
        "--markov", default=FIT.markov, choices=("auto", "none"),
        help="gls with --select aic/bic: add a first-order Gauss-Markov term where the curve "
        "has a hump the IEEE terms cannot describe (default auto), or never",
    )  # fmt: skip
    cmd.add_argument(
        "--bound-level", type=probability, default=FIT.bound_level, metavar="P",
        help="gls: one-sided level of the upper bound of a term left out (default 0.99)",
    )  # fmt: skip
    cmd.add_argument(
        "--fit-uncertainty", default=FIT.uncertainty, choices=("conditional", "averaged"),
        help="gls with --select aic/bic: each chosen term's uncertainty with the doubt of "
        "the choice in it (default averaged: the weight of the models without the term), "
        "or given the model chosen (conditional, before 0.3.0)",
    )  # fmt: skip
    cmd.add_argument(
        "--exclude", default=FIT.exclude, choices=("auto", "none"),
        help="gls: leave out the short taus where the curve rolls off below the model "
        "(a sensor filter, correlated noise; default auto), or fit every tau",
    )  # fmt: skip
    cmd.add_argument(
        "--rolloff", default=FIT.rolloff, choices=("model", "none"),
        help="gls: let the tau^-2 term go negative to model a filter's roll-off (default) "
        "or keep Q >= 0",
    )  # fmt: skip
    add_fit_range_arguments(cmd)
    cmd.add_argument(
        "--n-reweight", type=parse_seed, default=FIT.n_reweight, metavar="N",
        help="reweighting passes of the noise fit after the first, with the model's "
        "variance in the weights (default: 3; 0: weights of the measured variance)",
    )  # fmt: skip
    cmd.add_argument(
        "--spacing", default=FIT.spacing, choices=("octave", "independent"),
        help="weights of densely spaced taus in the noise fit: octave (default: scaled by "
        "their spacing in octaves, so a dense grid does not count the same information "
        "many times) or independent (as they are)",
    )  # fmt: skip


def add_chunk_argument(cmd: argparse.ArgumentParser) -> None:
    """--chunk-size: how many samples are read at a time (the out-of-core path)."""
    cmd.add_argument(
        "--chunk-size", type=positive_int, metavar="N",
        help="read and process the record N samples at a time, for records larger than "
        "memory (default: all at once)",
    )  # fmt: skip


def add_surface_arguments(cmd: argparse.ArgumentParser) -> None:
    """Options of a DAVAR surface: centres, taus, edges, data type, bounds, fit, file format."""
    cmd.add_argument(
        "--noise-type", type=parse_noise_type, default="record", metavar="ALPHA",
        help="noise exponent behind the per-cell EDF: record (default: identified per tau on "
        "the whole record), an integer alpha (0 white rate noise/ARW, -1 bias instability, "
        "-2 rate random walk, 1/2 flicker/white PM), or one per tau, comma-separated",
    )  # fmt: skip
    cmd.add_argument(
        "--t0", type=finite_float, default=0.0, metavar="SECONDS",
        help="time of the first sample (default: 0); window times are t0 + centre / rate",
    )  # fmt: skip
    cmd.add_argument(
        "--step", metavar="S", type=length_arg(1),
        help="centre a window on every S-th sample only; samples or a duration such as 10s "
        "(default: every sample, or as few as keep the surface within --max-memory)",
    )  # fmt: skip
    cmd.add_argument(
        "--taus", type=parse_taus, metavar="SPEC",
        help="all (every multiple of tau0 up to a third of the window; the default up to "
        f"{MAX_ALL_TAUS} taus, log beyond), octave, decade, log, or comma-separated taus in "
        "seconds",
    )  # fmt: skip
    cmd.add_argument(
        "--max-memory", type=positive_float("MB"), default=DEFAULT_MAX_MEMORY_MB, metavar="MB",
        help="budget of the surface when --step is not given: every centre while it fits, "
        f"else every S-th (default: {DEFAULT_MAX_MEMORY_MB} MB)",
    )  # fmt: skip
    cmd.add_argument(
        "--edges", default="mirror", choices=EDGES,
        help="mirror (default: every sample is a centre, the record is time-reversed at its "
        "ends) or valid (only windows inside the record)",
    )  # fmt: skip
    cmd.add_argument(
        "--edge-edf", default="distinct", choices=("distinct", "interior"),
        help="EDF of a window that reaches into the mirrored ends: its distinct terms "
        "(default) or the full window's (before 0.2)",
    )  # fmt: skip
    cmd.add_argument(
        "--data-type", default=DATA_TYPE_DEFAULT, choices=("rate", "phase"),
        help="rate samples (gyro rate, acceleration, fractional frequency) or their "
        "integral (angle, velocity, time error); default: phase for a Stable32 .phd "
        "file, else rate",
    )  # fmt: skip
    cmd.add_argument(
        "--confidence", default=0.683, type=confidence_or_none, metavar="P",
        help="two-sided confidence level of the per-cell bounds (default: 0.683); none: no "
        "bounds and no noise fit (faster, a third of the memory)",
    )  # fmt: skip
    cmd.add_argument(
        "--points-per-decade", default=10, type=points_per_decade, metavar="K",
        help="density of --taus log (default: 10)",
    )  # fmt: skip
    cmd.add_argument(
        "--terms", type=parse_terms, metavar="LIST",
        help="comma-separated terms of the fit of every window (names or Q,N,B,K,R; "
        "default: all five)",
    )  # fmt: skip
    cmd.add_argument(
        "--format", choices=tuple(SURFACE_FORMATS),
        help="file format of the surface in --out: nc (NetCDF, default) or parquet (needs "
        "pyarrow)",
    )  # fmt: skip
    add_fit_arguments(cmd)
    add_chunk_argument(cmd)


def add_dependence_argument(cmd: argparse.ArgumentParser) -> None:
    """``--dependence C2,C4``: the record's correlation for the hourly thresholds, given."""
    cmd.add_argument(
        "--dependence", action=Given, type=number_tuple("--dependence", 2, 2), metavar="C2,C4",
        help="the record's (c2, c4) for the hourly thresholds, instead of measuring them on "
        "its first 8192 samples (or half Lmax) and refining them at every doubling up to 2^20 "
        "(result.json's dependence_stages); 'adavar adaptive' and 'adavar monitor' given the "
        "same give the same windows",
    )  # fmt: skip


def add_kurtosis_reference_argument(cmd: argparse.ArgumentParser) -> None:
    """``--kurtosis-reference``: what the calibrated kurtosis tests compare a window with."""
    cmd.add_argument(
        "--kurtosis-reference", action=Given, choices=("record", "gaussian"), default="record",
        help="with --thresholds calibrated: compare each window with the record's own "
        "stationary noise (default: fitted on the same first samples as the correlation, so "
        "that non-Gaussian noise such as a platykurtic gyro or Student-t noise gives no false "
        "events; docs/method.md section 8) or with Gaussian noise (before 0.2)",
    )  # fmt: skip


def add_ici_arguments(cmd: argparse.ArgumentParser, live: bool = False) -> None:
    """The options of ``--method ici`` (:func:`adavar.dynamic.ici.ici_schedule`); ``live``: without
    ``--ici-long-tau`` (the long-tau scan needs the whole record)."""
    group = cmd.group("ICI window (--method ici)")
    group.add_argument(
        "--ici-gamma", action=Given, type=positive_float("standard deviations"),
        default=ICI_GAMMA,
        metavar="G", help=f"half-width of the intervals in standard normal units (default "
        f"{ICI_GAMMA:g}; smaller shortens the window more readily)",
    )  # fmt: skip
    group.add_argument(
        "--ici-lengths", action=Given, type=whole_list, default=None, metavar="L,...",
        help="candidate window lengths in samples, holding --lmin and ending at --lmax; "
        "those below --lmin are probes (default: lmin/8, lmin/4, lmin/2, then 3 geometric "
        "steps from lmin to lmax)",
    )  # fmt: skip
    group.add_argument(
        "--ici-taus", action=Given, type=whole_list, default=[1], metavar="M,...",
        help="averaging factors of the estimates (default 1: the white-noise level)",
    )  # fmt: skip
    group.add_argument(
        "--ici-sides", action=Given, choices=ICI_SIDES, default="both",
        help="both: left, centred and right windows (default); centred: centred only",
    )  # fmt: skip
    group.add_argument(
        "--ici-edf", action=Given, choices=ICI_EDF, default="correlation",
        help="EDF of the estimates: from the record's correlation (default) or the "
        "engine's Greenhall EDF",
    )  # fmt: skip
    group.add_argument(
        "--ici-edf-samples", action=Given, type=positive_int, default=None, metavar="K",
        help="measure the correlation EDF on the first K samples only (what 'adavar "
        "monitor --method ici' knows when it starts; default: the whole record)",
    )  # fmt: skip
    group.add_argument(
        "--ici-kurtosis", action=GivenBoolean, default=True,
        help="scale the EDF by the record's robust excess kurtosis, wider intervals on "
        "heavy-tailed noise (default; --no-ici-kurtosis: the Gaussian EDF, before 0.3)",
    )  # fmt: skip
    group.add_argument(
        "--ici-episodes", action=GivenBoolean, default=True,
        help="locate the changes by segmenting each episode of disagreeing Lmax windows, "
        "report gradual changes as one ramp and track them (default; --no-ici-episodes: "
        "the largest contrast within Lmax/2, before 0.3)",
    )  # fmt: skip
    if not live:
        group.add_argument(
            "--ici-long-tau", action=GivenBoolean, default=True,
            help="also report changes of the long-tau terms (rate random walk, bias "
            "instability) found at long averaging times, events with tau_s (default)",
        )  # fmt: skip

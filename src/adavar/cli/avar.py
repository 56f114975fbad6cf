"""``adavar avar``: the deviation table and the noise fit of a whole record."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from adavar import __version__
from adavar.cli.options import (
    EXIT_OK,
    UsageError,
    add_chunk_argument,
    add_fit_arguments,
    add_input_arguments,
    add_output_arguments,
    check_arguments,
    warn,
)
from adavar.cli.output import (
    Status,
    deviation_table,
    fit_lines,
    guard_replacement,
    output_error,
    safe_name,
)
from adavar.cli.values import (
    parse_confidence,
    parse_taus,
    parse_terms,
    points_per_decade,
    positive_float,
    positive_int,
)
from adavar.core.atomic import atomic_directory, check_output_directory
from adavar.core.errors import AdavarInputError
from adavar.core.settings import ALL_STATISTICS, DATA_TYPE_DEFAULT
from adavar.io.writers import deviation_json, dumps, fit_json, write_deviation_csv


def _cmd_avar(args: argparse.Namespace) -> int:
    from adavar.fit.noise_model import ALLAN_STATS

    check_arguments(args)
    do_fit = args.fit or args.terms is not None
    if do_fit and args.stat not in ALLAN_STATS:
        raise UsageError(
            f"--fit needs an Allan statistic ({', '.join(sorted(ALLAN_STATS))}), not "
            f"--stat {args.stat}"
        )
    if args.out is not None:
        check_output_directory(args.out, replace=args.force)
        guard_replacement(args.out, [Path(args.file)])

    import dataclasses

    from adavar.core.request import AnalysisRequest, DeviationSettings
    from adavar.pipeline.analysis import run as run_analysis

    status = Status()
    request = dataclasses.replace(AnalysisRequest.from_options(args),
                                  deviation=DeviationSettings.from_options(args))  # fmt: skip
    done = run_analysis(
        request, status=status, channels="all", whole="fit" if do_fit else "curve",
        check=lambda request, loaded: _check_columns(args, loaded.meta["columns"]),
    )  # fmt: skip
    tau0, meta = done.tau0, done.meta
    # as read: a Stable32 .phd file holds phase
    args = argparse.Namespace(**{**vars(args), "data_type": done.request.record.data_type})
    runs = [_avar_channel(args, analysis, {**meta, "column": name}, tau0, do_fit)
            for name, analysis in done.channels.items()]  # fmt: skip
    several = len(runs) > 1
    if several:
        payload: dict[str, Any] = {
            "adavar_version": __version__,
            "input": {"file": meta["path"], "columns": list(done.channels), "rate": 1.0 / tau0,
                      "tau0": tau0, "data_type": args.data_type},
            "channels": {run["name"]: run["payload"] for run in runs},
        }  # fmt: skip
    else:
        payload = runs[0]["payload"]
    if meta["preprocessing"]:
        payload.setdefault("input", {})["preprocessing"] = [
            step.get("spec", str(step)) for step in meta["preprocessing"]
        ]
        if meta.get("preprocessing_notes"):
            payload["input"]["preprocessing_notes"] = list(meta["preprocessing_notes"])
    text = dumps(payload)

    written: list[str] = []
    if args.out is not None:
        from adavar.output.plots import deviation_figure, save_figure

        try:
            with atomic_directory(args.out, replace=args.force) as tmp:
                for run in runs:
                    status(f"writing {args.out}: {run['name']}")
                    prefix = f"{safe_name(run['name'])}_" if several else ""
                    write_deviation_csv(tmp / f"{prefix}deviation.csv", run["result"])
                    written.append(f"{prefix}deviation.csv")
                    if args.figures:
                        fig = deviation_figure(run["result"], run["fit"], title=run["title"])
                        save_figure(fig, tmp / f"{prefix}deviation", args.figures)
                        written += [f"{prefix}deviation.{ext}" for ext in args.figures]
                (tmp / "result.json").write_text(text + "\n", encoding="utf-8")
                written.append("result.json")
        except OSError as exc:
            raise output_error(args.out, exc) from None
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


def allow_gaps_omit(parser: argparse.ArgumentParser, split: str = "") -> None:
    """``--gaps omit`` on ``parser`` (avar, davar): NaN rows whose terms are left out;
    ``split`` describes ``--gaps split`` where the command has it."""
    gaps = parser.option("--gaps")
    gaps.choices = (*gaps.choices, "omit")
    # the ways out of a gap error: split only where the command splits (avar)
    parser.gap_ways = ("split", "interpolate", "omit") if split else ("interpolate", "omit")
    gaps.help = (
        f"a gap in the time stamps is an error (default), {split}is filled by linear "
        "interpolation, or (omit) its missing samples, and NaN/empty cells, are left out of "
        "the statistic: every difference term touching one is omitted (no interpolation)"
    )


def _check_columns(args: argparse.Namespace, columns: list[str]) -> None:
    """Several numeric columns and no --column: one --units would label them all (a
    temperature as deg/s), so the user chooses. A file that declares every channel's unit
    (a ROS bag, without --units) has them all analysed, each in its own unit."""
    if args.column is not None or len(columns) < 2 or not (args.units and args.units.strip()):
        return
    shown = ", ".join(columns[:10]) + (
        f", ... ({len(columns)} in all)" if len(columns) > 10 else ""
    )
    raise UsageError(
        f"{args.file} has {len(columns)} numeric columns ({shown}) and --units "
        f"{args.units.strip()} would label them all: choose with --column (e.g. --column "
        f"{columns[0]}, or several, comma-separated, analysed one by one)"
    )


def _piece_start(meta: dict[str, Any]) -> float | None:
    """The time (s after the file's first stamp) of the first sample of the ``--gaps
    split`` piece that ``meta['column']`` names ("gx piece 2"), else None."""
    pieces = meta.get("pieces")
    name, _, k = str(meta["column"]).rpartition(" piece ")
    if not pieces or not name or not k.isdigit() or not 1 <= int(k) <= len(pieces):
        return None
    return float(pieces[int(k) - 1][0])


def _avar_channel(
    args: argparse.Namespace, analysis: Any, meta: dict[str, Any], tau0: float, do_fit: bool,
) -> dict[str, Any]:  # fmt: skip
    """One channel's deviation (and fit) (:func:`adavar.pipeline.analysis.run`): its JSON payload
    and printed lines."""
    from adavar.core.units import deviation_unit
    from adavar.output.plots import STAT_NAMES

    result, fit, units, rate_u = analysis.result, analysis.fit, analysis.units, analysis.rate_units
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
        **deviation_json(result),
    }
    start = _piece_start(meta)
    if start is not None:  # a piece of --gaps split: its times count from its first sample
        payload["input"]["piece_start_s"] = start
    # not stationary: a warning, not an error (the exit code stays)
    payload["warnings"] = list(result.warnings)
    origin = (
        ""
        if start is None
        else f" (times from its first sample, {start:.6g} s after the file's first)"
    )
    for text in result.warnings:
        warn(f"column {meta['column']!r}{origin}: {text}")
    if fit is not None:
        payload["fit"] = fit_json(fit)
    power_law, power_law_note = _power_law(args, result, units, do_fit)
    if power_law is not None:
        payload["power_law"] = _power_law_json(power_law)
    dev_u = deviation_unit(args.stat, rate_u)
    lines = [
        f"{meta['path']}, column {meta['column']!r}: {result.n_samples} samples, "
        f"{args.data_type} data in {units}, tau0 = {tau0:g} s ({1.0 / tau0:g} Hz)",
        f"{STAT_NAMES[args.stat]} ({args.stat.upper()})"
        + (f" [{dev_u}]" if dev_u else "")
        + f", {100 * result.confidence:.1f} % confidence intervals",
        deviation_table(result),
    ]
    lines += [f"note: {note}" for note in (*meta.get("preprocessing_notes", ()), *result.notes)]
    if result.dev.size and not np.any(result.dev):  # a constant column (no full pass)
        lines.append(f"note: column {meta['column']!r} is constant: its deviation is 0")
    if fit is not None:
        lines += ["", *fit_lines(fit)]
    if power_law is not None:
        lines += ["", power_law.summary()]
    elif power_law_note:
        lines.append(f"note: {power_law_note}")
    return {
        "name": meta["column"], "result": result, "fit": fit, "payload": payload,
        "lines": lines, "title": f"{Path(meta['path']).name}, column {meta['column']}",
    }  # fmt: skip


def _power_law(args: argparse.Namespace, result: Any, units: str, do_fit: bool) -> tuple[Any, str]:
    """The clock model of ``--fit`` (``--power-law``): (PowerLawFit or None, why not)."""
    from adavar.core.units import sensor_kind
    from adavar.fit.power_law import POWER_LAW_STATS, fit_power_law

    choice = getattr(args, "power_law", "auto")
    wanted = choice == "on" or (
        choice == "auto" and do_fit and sensor_kind(units, args.data_type) == "clock"
    )
    if not wanted:
        return None, ""
    if result.stat not in POWER_LAW_STATS or args.confidence is None:
        return None, (
            f"no power-law fit: it needs one of {', '.join(POWER_LAW_STATS)} with intervals"
        )
    import dataclasses

    # the CLI's result carries the rate's unit; the clock model reads the samples' unit
    declared = dataclasses.replace(result, units=units)
    try:
        return fit_power_law(declared, f_h=getattr(args, "f_h", None)), ""
    except (AdavarInputError, ValueError) as exc:
        return None, f"no power-law fit: {exc}"


def _power_law_json(fit: Any) -> dict[str, Any]:
    """The ``"power_law"`` member of ``--json``: h coefficients with 1-sigma, by name."""
    h = {}
    for k, name in enumerate(fit.names):
        if name in fit.terms:
            h[name] = {
                "alpha": int(fit.alpha[k]), "label": fit.labels[name], "value": float(fit.h[k]),
                "sigma": float(fit.h_sigma[k]), "dropped": name in fit.dropped,
            }  # fmt: skip
    out: dict[str, Any] = {
        "stat": fit.stat, "f_h": float(fit.f_h), "f_h_source": fit.f_h_source, "h": h,
        "chi2": float(fit.chi2), "dof": int(fit.dof), "p_value": float(fit.p_value),
        "notes": list(fit.notes),
    }  # fmt: skip
    if "frequency_drift" in fit.terms:
        out["drift"] = {"value": float(fit.drift), "sigma": float(fit.drift_sigma)}
    return out


def add_avar_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``adavar avar`` to the sub-command parsers ``sub``."""
    avar = sub.add_parser(
        "avar",
        help="deviation (and noise fit) of one column of a text file",
        description="Allan-family deviation of one column of a CSV/TSV/whitespace text file, "
        "with confidence intervals, and optionally the fit of the IEEE Std 952 noise terms. "
        "The sampling rate and the unit of the samples are required: adavar never guesses "
        "them. A file with several numeric columns needs --column (one, or several analysed "
        "one by one), unless it declares every column's unit (a ROS bag: all six).",
    )
    add_input_arguments(avar)
    allow_gaps_omit(avar, "splits the record into gap-free pieces analysed one by one, ")
    avar.add_argument(
        "--stat", default="oadev", choices=ALL_STATISTICS, help="statistic (default: oadev)"
    )
    avar.add_argument(
        "--noise-id", default="sp1065", choices=("sp1065", "stable32", "input"),
        help="noise identification for the intervals: SP 1065 (default; rate and phase data "
        "on the decimated phase, B1 + R(n) below 30 clusters), Stable32's tables' rule, or "
        "'input' (rate data on the averaged rate: the rule before 0.2)",
    )  # fmt: skip
    avar.add_argument(
        "--totdev-edf", default="sp1065", choices=("sp1065", "stable32", "legacy"),
        help="EDF of totdev: SP 1065 for every noise type (default), Stable32's, or the "
        "rule before 0.2",
    )  # fmt: skip
    avar.add_argument(
        "--totdev-bias", action="store_true",
        help="divide out totdev's bias for flicker and random-walk FM (SP 1065)",
    )  # fmt: skip
    avar.add_argument(
        "--stationarity-check", action=argparse.BooleanOptionalAction, default=True,
        help="test whether the record's short-tau noise is stationary and warn if not "
        "(default; --no-stationarity-check skips the test)",
    )  # fmt: skip
    avar.add_argument(
        "--bias-correction", action=argparse.BooleanOptionalAction, default=None,
        help="apply the bias correction of a statistic that has one (htotdev); default: "
        "the statistic's own default",
    )  # fmt: skip
    avar.add_argument(
        "--total-edf", default=None, choices=("sp1065", "stable32"),
        help="EDF of mtotdev/ttotdev/htotdev: SP 1065 (default) or Stable32's",
    )  # fmt: skip
    avar.add_argument(
        "--theo-ratio-terms", type=positive_int, default=None, metavar="N",
        help="theobr/theoh: AVAR/Theo1 ratios in the bias ratio (default: all, as SP 1065)",
    )  # fmt: skip
    avar.add_argument(
        "--data-type", default=DATA_TYPE_DEFAULT, choices=("rate", "phase"),
        help="rate samples (gyro rate, acceleration, fractional frequency) or their "
        "integral (angle, velocity, time error); default: phase for a Stable32 .phd "
        "file, else rate",
    )  # fmt: skip
    avar.add_argument(
        "--taus", default="octave", type=parse_taus, metavar="SPEC",
        help="octave (default), all, decade, log, or comma-separated taus in seconds",
    )  # fmt: skip
    avar.add_argument(
        "--points-per-decade", default=10, type=points_per_decade, metavar="K",
        help="density of --taus log (default: 10)",
    )  # fmt: skip
    avar.add_argument(
        "--confidence", default=0.683, type=parse_confidence, metavar="P",
        help="two-sided confidence level of the intervals (default: 0.683)",
    )  # fmt: skip
    avar.add_argument("--fit", action="store_true", help="fit the IEEE Std 952 noise terms")
    avar.add_argument(
        "--power-law", default="auto", choices=("auto", "on", "off"),
        help="also fit the clock model h_-2 .. h_2 (adavar.fit_power_law): auto (default) "
        "with --fit when the units say clock (phase in s/ns/..., or a fractional "
        "frequency), on, or off",
    )  # fmt: skip
    avar.add_argument(
        "--f-h", type=positive_float("Hz"), default=None, metavar="HZ",
        help="measurement bandwidth of the PM terms of --power-law (default: Nyquist)",
    )  # fmt: skip
    avar.add_argument(
        "--terms", type=parse_terms, metavar="LIST",
        help="comma-separated terms of the fit (names or Q,N,B,K,R; default: all five); "
        "implies --fit",
    )  # fmt: skip
    add_fit_arguments(avar)
    add_chunk_argument(avar)
    avar.add_argument("--json", action="store_true", help="print one JSON object")
    add_output_arguments(
        avar,
        "also write deviation.csv, result.json and the figure deviation (.png/.svg, see "
        "--figures) to this new folder",
    )
    avar.set_defaults(handler=_cmd_avar)
    return avar

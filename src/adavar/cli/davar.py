"""``adavar davar`` and ``adavar adaptive``: the dynamic Allan variance and N(t), B(t), ..."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING as _TYPE_CHECKING
from typing import Any

import numpy as np

from adavar import __version__
from adavar.core.terms import TERM_NAMES

if _TYPE_CHECKING:  # pragma: no cover - annotations only
    from adavar.core.results import NoiseFit
from adavar.cli.avar import allow_gaps_omit
from adavar.cli.options import (
    EXIT_OK,
    TERM_FILES,
    UsageError,
    add_controller_arguments,
    add_dependence_argument,
    add_ici_arguments,
    add_input_arguments,
    add_kurtosis_reference_argument,
    add_output_arguments,
    add_surface_arguments,
)
from adavar.cli.output import Status, channel_folders, guard_replacement, output_error, text_table
from adavar.cli.values import seconds_list, window_length
from adavar.core.atomic import atomic_directory, check_output_directory, write_marker
from adavar.core.csv_tables import block_rows, csv_pieces, csv_text, write_pieces
from adavar.core.results import DavarResult
from adavar.core.settings import HOURLY_FALSE_ALARMS
from adavar.dynamic.windows import MIN_WINDOW
from adavar.io.writers import (
    SURFACE_FORMATS,
    check_surface_format,
    conventional,
    dumps,
    write_surface,
)

#: --stat -> what the summary calls the surface's deviation
STAT_TITLES = {
    "oavar": "Dynamic Allan deviation",
    "ohvar": "Dynamic overlapping Hadamard deviation",
    "mvar": "Dynamic modified Allan deviation",
}
#: why a Hadamard or modified surface gets no fit (the IEEE model is of the Allan variance)
NO_FIT = (
    "no noise fit: the IEEE Std 952 coefficients are defined on the Allan variance; "
    "--stat oavar fits them"
)


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
    from adavar.core.units import term_unit

    conv = conventional(fit)
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
        "warnings": list(fit.warnings),
    }


def _coefficient_term(fit: NoiseFit) -> str:
    """The term drawn in the coefficient figure: N if fitted, else the first fitted term."""
    return "angle_random_walk" if "angle_random_walk" in fit.terms else fit.terms[0]


def _write_coefficients(path: Path, result: DavarResult, fit: NoiseFit) -> None:
    """coefficients.csv: one row per window (its file, column and units: result.json)."""
    columns: list[tuple[str, Any]] = [("time_s", result.time), ("window", result.window)]
    for name in fit.terms:
        term = fit.term(name)
        columns += [(name, term.value), (f"{name}_uncertainty", term.uncertainty)]
    columns.append(("reduced_chi2", fit.reduced_chi2))
    arrays = [np.asarray(values).reshape(-1) for _, values in columns]
    write_pieces(path, csv_pieces([name for name, _ in columns], block_rows(arrays)))


def _davar_summary(
    result: DavarResult, fit: NoiseFit | None, meta: dict[str, Any], units: str,
    data_type: str, written: list[str], out: str | None,
) -> list[str]:  # fmt: skip
    from adavar.core.units import term_unit
    from adavar.output.plots import TERM_LABELS

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
            f"{STAT_TITLES[meta.get('stat', 'oavar')]}: window {int(window[0])} samples "
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
    origin = meta.get("windows_from")
    if origin in ("record", "lmax"):
        p = result.parameters
        lines.append(
            f"windows: Lmax {p['lmax']} samples ({p['lmax'] * tau0:g} s), Lmin {p['lmin']}, "
            f"l {p['l']}: "
            + ("a tenth of the record" if origin == "record" else "from --lmax")
            + " in the paper's proportions (600/400/100 of 6000 samples); give --lmax, "
            "--lmin, --l (samples or durations) to choose"
        )
    if hasattr(result, "method") and result.method in ("adaptive", "kurtosis"):
        lines.append(threshold_line(result.parameters))
    if meta.get("resolution"):
        lines.append(meta["resolution"])
    lines += [f"note: {note}" for note in (*meta.get("preprocessing_notes", ()), *result.notes)]
    if fit is None and meta.get("stat", "oavar") != "oavar":
        lines.append(f"({NO_FIT})")
    elif fit is None:
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
        lines += [f"warning: {w}" for w in fit.warnings]
        if not fitted.all():
            lines.append(
                f"({fitted.size - int(fitted.sum())} windows not fitted, too few taus for the "
                "terms: NaN; use more taus or fewer --terms)"
            )
        conv = conventional(fit)
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
        lines.append(text_table(headers, rows, "  "))
        if fit.units and conv is None:
            lines.append(
                f"  (no conventional units for {fit.units!r}: declare deg/s, deg/h, rad/s, "
                "m/s^2 or g to get them)"
            )
    if written:
        lines += ["", f"wrote {out}/ ({', '.join(written)})"]
    return lines


def _fixed_events_possible(args: argparse.Namespace, samples: Any) -> bool:
    """Events of a fixed window: rate data in memory or in a .npy file (read with file
    reads), a window the S test fits in, and no missing sample (--gaps omit: the
    controller's tests need every sample)."""
    from adavar.io.sources import DEFAULT_CHUNK, NpyFileSource

    def missing() -> bool:
        if not isinstance(samples, NpyFileSource):
            return bool(np.isnan(samples).any())
        return any(np.isnan(samples.read_unchecked(a, min(samples.size, a + DEFAULT_CHUNK))).any()
                   for a in range(0, samples.size, DEFAULT_CHUNK))  # fmt: skip

    return (args.data_type == "rate" and isinstance(samples, (np.ndarray, NpyFileSource))
            and args.window is not None and int(args.window) >= 16 and not missing())  # fmt: skip


def _fixed_window_changes(
    args: argparse.Namespace, samples: np.ndarray, common: dict[str, Any], tau0: float
) -> list[float]:
    """Change times flagged by the controller's tests in the fixed window (no adaptation);
    the record in pieces, only the runs of flags kept (memory: one piece)."""
    from adavar.dynamic.events import run_change_times
    from adavar.dynamic.schedule import adaptive_schedule
    from adavar.dynamic.window_defaults import record_windows

    length = int(args.window)
    sched = adaptive_schedule(
        samples, method="fixed", lmax=length, lmin=length, l=record_windows(0, length)[2],
        thresholds="calibrated", false_alarm_per_hour=HOURLY_FALSE_ALARMS,
        rate=common["rate"], tau0=common["tau0"], keep="runs",
        **({"chunk_size": common["chunk_size"]} if "chunk_size" in common else {}),
    )  # fmt: skip
    return run_change_times(sched.flag_runs(), length, tau0, float(args.t0))


def _schedule_of(result: Any) -> Any:
    """The controller record of an AdaptiveResult as a Schedule (for the Fig. 10 panels)."""
    from adavar.dynamic.schedule import Schedule
    from adavar.dynamic.thresholds import thresholds_for

    p = result.parameters
    return Schedule(
        window=result.window, kurtosis=result.kurtosis, s=result.s, f1=result.f1,
        f2=result.f2, f=result.f, centre=result.centre, method=result.method,
        thresholds=thresholds_for(p), parameters=p,
    )  # fmt: skip


def threshold_line(p: dict[str, Any]) -> str:
    """One line: the controller's thresholds and where they come from."""
    used = p.get("thresholds_used") or {}
    if p.get("thresholds") != "calibrated" or not used:
        return (f"thresholds: the paper's K1 {p['k1']:g}, K2 {p['k2']:g}, S2 {p['s2']:g} "
                "(--thresholds calibrated sets them for a false-alarm rate)")  # fmt: skip
    k1, k2, s2 = used["k1"], used["k2"], used["s2"]
    values = (f"K1 {k1[0]:.4f}, K2 {k2[0]:.4f}, S2 {s2[0]:.4f} at Lmax; K1 {k1[1]:.4f}, "
              f"K2 {k2[1]:.4f}, S2 {s2[1]:.4f} at Lmin")  # fmt: skip
    if p.get("false_alarm_per_hour") is not None:
        c4 = (p.get("dependence") or (1.0, 1.0))[1]
        return (f"thresholds calibrated for {p['false_alarm_per_hour']:g} false events per "
                f"stationary hour (the noise's short-range correlation widens them by "
                f"c4 = {c4:.3g}): {values}; --thresholds paper for the paper's")  # fmt: skip
    return f"thresholds calibrated for {p['false_alarm']:g} false alarms per step: {values}"


def _cmd_davar(args: argparse.Namespace) -> int:
    from adavar.cli.options import check_arguments

    check_arguments(args)
    if args.format is not None and args.out is None:
        raise UsageError("--format chooses the surface file of --out: give --out DIR as well")
    if args.confidence is None and args.terms is not None:
        raise UsageError(
            "--terms needs the confidence bounds (the fit is weighted by the EDF of every "
            "cell): drop --confidence none"
        )
    if getattr(args, "stat", "oavar") != "oavar" and args.terms is not None:
        raise UsageError(f"--terms with --stat {args.stat}: {NO_FIT}")
    fmt = check_surface_format(args.format or "nc")  # before the work: pyarrow installed?
    if args.out is not None:
        check_output_directory(args.out, replace=args.force)
        guard_replacement(args.out, [Path(args.file)])

    adaptive = args.command == "adaptive"
    if adaptive and args.method == "oracle" and not args.change_times:
        raise UsageError("--method oracle needs --change-times T,... (seconds)")
    return _run_davar(args, adaptive, fmt)


def _run_davar(args: argparse.Namespace, adaptive: bool, fmt: str) -> int:
    import dataclasses

    from adavar.cli.options import check_change_times
    from adavar.core.request import AnalysisRequest
    from adavar.pipeline.analysis import refuse_constant_channels
    from adavar.pipeline.analysis import run as run_analysis

    status = Status()
    request = AnalysisRequest.from_options(args)  # --gaps omit: NaN rows left out
    request = dataclasses.replace(
        request, window=dataclasses.replace(request.window, adaptive=adaptive)
    )

    def check(request: AnalysisRequest, loaded: Any) -> None:
        what = "the adaptive window to follow" if adaptive else "a dynamic Allan variance"
        refuse_constant_channels(loaded, what)
        if adaptive:
            samples, _ = loaded.first
            check_change_times(args.change_times, int(getattr(samples, "size", np.size(samples))),
                               loaded.tau0)  # fmt: skip

    # several channels only when --column names them: a surface of every numeric column
    # (a temperature too) is too costly to be a default
    done = run_analysis(request, status=status, whole="reference", check=check)
    meta, tau0, resolution = done.meta, done.tau0, done.resolution
    # the options as used: durations in samples, the record's windows, the resolution
    args = argparse.Namespace(**{**vars(args), **vars(done.request.options())})
    loaded = done.samples
    units_of = {name: analysis.units for name, analysis in done.channels.items()}
    names = list(loaded)
    several = len(names) > 1
    folders = channel_folders(names) if several else {}
    runs = []
    for k, name in enumerate(names):
        out = args.out if args.out is None or not several else f"{args.out}/{folders[name]}"
        tag = f"{name} ({k + 1}/{len(names)}): " if several else ""
        info = {**meta, "column": name, "windows_from": args.windows_from,
                "resolution": resolution, "stat": args.stat}  # fmt: skip
        runs.append(_davar_channel(args, done.channels[name], loaded[name], info,
                                   units_of[name], tau0, fmt, out, tag))  # fmt: skip
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
            if meta.get("preprocessing_notes"):
                payload["input"]["preprocessing_notes"] = list(meta["preprocessing_notes"])
        text = dumps(payload)
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
                        write_marker(dest)  # each channel's folder is an output of its own
                    _write_davar_channel(args, run, dest, fmt, status)
                if several:
                    (tmp / "result.json").write_text(text + "\n", encoding="utf-8")
        except OSError as exc:
            raise output_error(args.out, exc) from None
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
        if run.get("events") is not None:
            print("\n".join(_event_lines(run["events"], run["fit"])))
    if several and args.out is not None:
        print()
        print(f"wrote {args.out}/ ({', '.join(written)}; in each folder: "
              f"{', '.join(runs[0]['written'])})")  # fmt: skip
    return EXIT_OK


def _davar_channel(
    args: argparse.Namespace, analysis: Any, samples: Any, meta: dict[str, Any], units: str,
    tau0: float, fmt: str, out: str | None, tag: str,
) -> dict[str, Any]:  # fmt: skip
    """One channel's surface and fit (:func:`adavar.pipeline.analysis.run`): its events, its JSON
    payload and the names of the files its output folder ``out`` gets."""
    from adavar.pipeline.analysis import rate_keywords

    adaptive = args.command == "adaptive"
    result, fit, rate_u = analysis.surface, analysis.coefficients, analysis.rate_units
    stat = args.stat  # adaptive: the Allan variance
    common = {**rate_keywords(analysis.request, tau0),
              **analysis.request.record.chunk_keywords()}  # fmt: skip
    written: list[str] = []
    if out is not None:
        written = [f"surface{SURFACE_FORMATS[fmt]}"]
        if fit is not None:
            written.append("coefficients.csv")
        figure_stems = ["davar_surface", "davar_heatmap"]
        if adaptive and result.method != "ici":
            figure_stems.append("controller")
        if fit is not None:
            figure_stems.append(TERM_FILES[_coefficient_term(fit)])
        written += [f"{stem}.{ext}" for stem in figure_stems for ext in args.figures]
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
        "notes": list(result.notes) + ([NO_FIT] if stat != "oavar" else []),
        "fit": None if fit is None else _davar_fit_json(fit, np.asarray(result.time)),
        "out": None if out is None else {"dir": out, "format": fmt, "files": written},
    }
    if meta["preprocessing"]:
        payload["input"]["preprocessing"] = [
            step.get("spec", str(step)) for step in meta["preprocessing"]
        ]
        if meta.get("preprocessing_notes"):
            payload["input"]["preprocessing_notes"] = list(meta["preprocessing_notes"])
    payload["parameters"]["resolution"] = meta.get("resolution")
    if adaptive:
        payload["parameters"]["controller"] = result.parameters
        payload["parameters"]["windows_from"] = getattr(args, "windows_from", "flags")
        payload["window"] = {
            "min": int(np.min(result.window)), "max": int(np.max(result.window)),
            "shrunk_fraction": float(np.mean(result.window < result.parameters["lmax"])),
        }  # fmt: skip
    events = None
    if fit is not None and (adaptive or _fixed_events_possible(args, samples)):
        from adavar.dynamic.events import find_events

        lmax = int(result.parameters["lmax"]) if adaptive else int(args.window)
        changes = None if adaptive else _fixed_window_changes(args, samples, common, tau0)
        terms = {name: fit.term(name).value for name in fit.terms}
        duration = float(args.t0) + result.n_samples * tau0
        if adaptive and result.method == "ici":  # its steps, ramps and long-tau changes
            from adavar.dynamic.ici_events import ici_events

            events = ici_events(result.window, result.centre, result.time, lmax, tau0, terms,
                                t0=float(args.t0), duration=duration,
                                parameters=result.parameters)  # fmt: skip
        else:
            events = find_events(result.window, result.centre, result.time, lmax, tau0, terms,
                                 t0=float(args.t0), duration=duration,
                                 changes=changes)  # fmt: skip
        payload["events"] = [e.as_dict() for e in events]
        if not adaptive:
            payload["events_rule"] = (
                "changes flagged by the adaptive controller's tests in the fixed window "
                f"(l = a sixth of it, thresholds calibrated for {HOURLY_FALSE_ALARMS:g} false "
                "events per stationary hour)"
            )
        if out is not None:
            written.insert(-1, "events.csv")
    if result.terms is not None:  # --gaps omit on a record with missing samples
        payload["terms_kept"] = {  # per tau, over the windows (0: a NaN cell)
            "min": result.terms.min(axis=0),
            "median": np.median(result.terms, axis=0),
            "empty_cells": np.count_nonzero(result.terms == 0, axis=0),
        }
    payload["stat"] = stat  # the variance of every window (--stat); last: keys keep order
    return {
        "name": meta["column"], "result": result, "fit": fit, "meta": meta, "units": units,
        "tau0": tau0, "payload": payload, "text": dumps(payload), "written": written,
        "tag": tag, "events": events,
    }  # fmt: skip


def _write_events(path: Path, events: list[Any], fit: NoiseFit) -> None:
    """events.csv: one row per stretch, each term's median before, during and after it."""
    header = ["start_s", "end_s"]
    for name in fit.terms:
        for part in ("before", "during", "after"):
            header += [f"{name}_{part}", f"{name}_{part}_low", f"{name}_{part}_high"]
    rows = []
    for e in events:
        row = [e.start_s, e.end_s]
        for name in fit.terms:
            for part in (e.before, e.during, e.after):
                row += [part[name]["median"], part[name]["low"], part[name]["high"]]
        rows.append([None if v is None else float(v) for v in row])
    path.write_text(csv_text(header, rows), encoding="utf-8")


def _event_lines(events: list[Any], fit: NoiseFit) -> list[str]:
    """The events table of the printout: start, end, N before / during / after."""
    from adavar.core.units import convert_coefficient, term_unit

    name = "angle_random_walk"
    unit = term_unit(name, fit.units) or ""
    scale = 1.0
    conv = conventional(fit)
    if conv is not None:
        unit = conv[name].unit
        scale = float(convert_coefficient(1.0, name, fit.units, unit))
    if not events:
        return ["", "Events: none (the adaptive window never shortened)"]

    def cell(part: dict[str, Any]) -> str:
        v = part[name]
        if v["median"] is None:
            return "-"
        return f"{v['median'] * scale:.4g} [{v['low'] * scale:.3g}, {v['high'] * scale:.3g}]"

    rows = [
        [f"{e.start_s:.6g}", "-" if e.end_s is None else f"{e.end_s:.6g}", cell(e.before),
         cell(e.during), cell(e.after)]
        for e in events
    ]  # fmt: skip
    head = ["start [s]", "end [s]", f"N before [{unit}]", "N during", "N after"]
    return ["", "Events (non-stationary stretches; N median [16 %, 84 %] of the windows):",
            text_table(head, rows, "  ")]  # fmt: skip


def _channel_figures(args: argparse.Namespace, run: dict[str, Any]) -> dict[str, Any]:
    """The figures of one channel by file stem (none without --figures formats)."""
    if not args.figures:
        return {}
    from adavar.output.plots import coefficient_figure, davar_heatmap_figure, davar_surface_figure

    adaptive = args.command == "adaptive"
    result, fit, meta = run["result"], run["fit"], run["meta"]
    title = f"{Path(meta['path']).name}, column {meta['column']}"
    figures = {
        "davar_surface": davar_surface_figure(result),
        "davar_heatmap": davar_heatmap_figure(result),
    }
    if adaptive and result.method != "ici":  # ICI runs no kurtosis test: nothing to draw
        from adavar.output.paper_figures import controller_figure

        figures["controller"] = controller_figure(
            _schedule_of(result), result.time, change_times=args.change_times or (),
            title=f"{title}: {result.method} window",
        )  # fmt: skip
    if fit is not None:
        term = _coefficient_term(fit)
        what = f"window {args.window} samples" if not adaptive else f"{result.method} window"
        figures[TERM_FILES[term]] = coefficient_figure(
            fit, term=term, title=f"{title}: {what}", events=run.get("events") or ()
        )
    return figures


def _write_davar_channel(
    args: argparse.Namespace, run: dict[str, Any], dest: Path, fmt: str, status: Status
) -> None:
    """The surface, coefficients, figures and result.json of one channel into ``dest``."""
    from adavar.output.plots import save_figure

    result, fit = run["result"], run["fit"]
    if args.figures:
        status(f"{run['tag']}drawing the figures")
    figures = _channel_figures(args, run)
    status(f"{run['tag']}writing the surface and the figures")
    write_surface(dest / run["written"][0], result, fmt=fmt)
    if fit is not None:
        _write_coefficients(dest / "coefficients.csv", result, fit)
    if run.get("events") is not None:
        _write_events(dest / "events.csv", run["events"], fit)
    for stem, fig in figures.items():
        save_figure(fig, dest / stem, args.figures)
    (dest / "result.json").write_text(run["text"] + "\n", encoding="utf-8")


def add_davar_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``adavar davar`` to the sub-command parsers ``sub``."""
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
    add_input_arguments(dav)
    allow_gaps_omit(dav)
    dav.add_argument(
        "--window", metavar="L", type=window_length, required=True,
        help=f"window length: samples (at least {MIN_WINDOW}, at most the record) or a "
        "duration such as 600s or 10min; taus up to a third of it",
    )  # fmt: skip
    dav.add_argument(
        "--stat", default="oavar", choices=tuple(STAT_TITLES),
        help="variance of every window: oavar (overlapping Allan, default), ohvar "
        "(overlapping Hadamard: blind to a rate ramp) or mvar (modified Allan); only oavar "
        "gets the noise fit",
    )  # fmt: skip
    add_surface_arguments(dav)
    dav.add_argument("--json", action="store_true", help="print one JSON object (a summary)")
    add_output_arguments(
        dav,
        "also write surface.nc (or .parquet), coefficients.csv, result.json and the "
        "figures davar_surface, davar_heatmap and arw (N(t); of the first term when N is "
        "not fitted: q, bi, rrw or rr) as .png/.svg (see --figures) to this new folder",
    )
    dav.set_defaults(handler=_cmd_davar)
    return dav


def add_adaptive_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``adavar adaptive`` to the sub-command parsers ``sub``."""
    ada = sub.add_parser(
        "adaptive",
        help="A-DAVAR: the dynamic Allan variance with the paper's adaptive window",
        description="The adaptive-window dynamic Allan variance (A-DAVAR, docs/method.md section "
        "5) of one column of a text file: the window shrinks from --lmax towards --lmin where "
        "the kurtosis leaves [--k1, --k2] or a shock enters its leading --l samples (S > "
        "--s2), and regrows where the noise is stationary; then the surface, its per-cell "
        "bounds and the noise coefficients of every window, as for davar. --method kurtosis "
        "runs DAVAR-K (the kurtosis test alone), --method oracle the ideal schedule for "
        "--change-times, --method ici the window chosen by intersecting the confidence "
        "intervals of candidate windows (--ici-* options; one-sided windows next to a change; "
        "docs/method.md section 11). The sampling rate and the unit are required: adavar "
        "never guesses.",
    )
    add_input_arguments(ada)
    ada.add_argument(
        "--method", default="adaptive", choices=("adaptive", "kurtosis", "oracle", "ici"),
        help="adaptive (A-DAVAR, default), kurtosis (DAVAR-K), oracle (needs "
        "--change-times) or ici (intersection of confidence intervals, with one-sided "
        "windows next to a change; docs/method.md section 11; in memory only)",
    )  # fmt: skip
    ada.add_argument(
        "--change-times", type=seconds_list, metavar="T,...",
        help="known change times in seconds, for --method oracle",
    )  # fmt: skip
    add_controller_arguments(ada)
    add_dependence_argument(ada)
    add_kurtosis_reference_argument(ada)
    add_ici_arguments(ada)
    add_surface_arguments(ada)
    ada.add_argument("--json", action="store_true", help="print one JSON object (a summary)")
    add_output_arguments(
        ada,
        "also write surface.nc (or .parquet), coefficients.csv, result.json and the "
        "figures davar_surface, davar_heatmap, arw and controller (kurtosis, S, flags and "
        "window length over time) as .png/.svg (see --figures) to this new folder",
    )
    ada.set_defaults(handler=_cmd_davar, window=None)
    return ada

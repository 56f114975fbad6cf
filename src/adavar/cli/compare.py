"""``adavar compare``: fixed and adaptive windows side by side, the paper's tables."""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from adavar import __version__
from adavar.cli.options import (
    EXIT_OK,
    UsageError,
    add_chunk_argument,
    add_controller_arguments,
    add_input_arguments,
    add_output_arguments,
    check_arguments,
)
from adavar.cli.output import (
    ProgressBar,
    Status,
    guard_replacement,
    output_error,
    text_table,
)
from adavar.cli.values import (
    length_arg,
    parse_confidence,
    parse_intervals,
    parse_names,
    parse_noise_type,
    parse_seed,
    parse_taus,
    parse_terms,
    points_per_decade,
    positive_float,
    positive_int,
    seconds_list,
    threshold_list,
    window_length,
)
from adavar.core.atomic import atomic_directory, check_output_directory
from adavar.core.csv_tables import block_rows, csv_pieces, write_pieces
from adavar.core.errors import AdavarInputError
from adavar.core.settings import CONTROLLER, DEFAULT_MAX_MEMORY_MB, ControllerSettings
from adavar.core.terms import TERM_NAMES
from adavar.io.writers import dumps


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
    from adavar.paper.nodes import NODE_TITLES
    from adavar.paper.reference import PAPER_LABELS

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
        name = f"{NODE_TITLES[r['node']]}({r['change']:g})"
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
    lines = [title, text_table(headers, rows, "  ")]
    if comp.scenario == 2 and cols:
        lines.append("  (paper: its Table 3 is a measured gyroscope with this scenario's shape, "
                     "not this simulation)")  # fmt: skip
    lines.append("  (fixed windows: X -/+ L/2 by definition; adaptive: Restore = first centre "
                 ">= X at Lmax, End = start of the regrowth into it, Beginning = where L left "
                 "Lmax before it)")  # fmt: skip
    return lines


def _compare_interval_lines(comp: Any, study: Any) -> list[str]:
    from adavar.paper.reference import PAPER_LABELS, paper_arw

    labels = comp.labels
    paper = paper_arw(comp.scenario)
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
        from adavar.core.units import term_unit

        unit = term_unit("angle_random_walk", comp.units)
    what = f"N in {unit}" if unit else "N in sample unit x sqrt(s)"
    over = "" if study is None else f", median over {len(study.seeds)} realisations"
    lines = [f"ARW interval means ({what}{over})", text_table(headers, rows, "  ")]
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
        text_table(["metric", *labels.values()], rows, "  "),
    ]


def _crossing_lines(thr: Any, study: Any, scenario: int | None) -> list[str]:
    from adavar.paper.reference import paper_crossings

    if thr is None:
        return []
    rows = []
    if study is None:
        for th in thr.thresholds:
            paper = paper_crossings(scenario, th)
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
    return [title, text_table(headers, rows, "  ")]


def compare_report(comp: Any, study: Any, thr: Any) -> list[str]:
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


def compare_tables(
    comp: Any, study: Any, thr: Any, descriptions: dict[str, str] | None = None
) -> dict[str, Iterator[str]]:
    """CSV file name -> its text (plain CSV) in pieces, made as they are read
    (``file.writelines(pieces)``: ``arw.csv`` has a row per window, hundreds of MB on a
    long record); ``descriptions`` (if given) gets each file's description (for the
    result.json next to them)."""
    from adavar.paper.reference import PAPER_REFERENCE, paper_arw, paper_crossings
    from adavar.paper.studies import finite_median

    head = f"adavar {__version__}: {comp.description}"
    names = list(comp.methods)
    files: dict[str, Iterator[str]] = {}

    def table(name: str, description: str, columns: list[str], rows: Any) -> None:
        files[name] = csv_pieces(columns, rows)
        if descriptions is not None:
            descriptions[name] = description

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
        table(
            "nodes.csv",
            f"{head}; node times (window centres) in s; paper_*: {PAPER_REFERENCE}",
            [*columns, *(f"paper_{m}" for m in cols)], rows,
        )  # fmt: skip
    paper_means = paper_arw(comp.scenario)
    cols = _paper_columns(comp, paper_means)
    if study is None:
        vals = {m: [run.intervals[iv] for iv in comp.intervals] for m, run in comp.methods.items()}
    else:
        vals = {m: [r["values"][m] for r in study.arw_rows()] for m in names}
    table(
        "intervals.csv",
        f"{head}; ARW(a~b) = mean of N(t) over centres in [a, b]"
        + ("" if study is None else f", median over {len(study.seeds)} realisations")
        + "; paper_* in 1e-3 deg/sqrt(h) (scale not reproducible: compare ratios)",
        ["a_s", "b_s", *names, *(f"paper_{m}" for m in cols)],
        [[a, b, *(vals[m][j] for m in names), *(paper_means[m].get((a, b), math.nan) for m in cols)]
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
        table(
            "metrics.csv",
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
    arrays = [np.asarray(a, dtype=float if a.dtype.kind == "f" else np.int64) for a in arrays]

    table(
        "arw.csv",
        f"{head}; N(t) of every window (sample unit x sqrt(s)) and window lengths (samples)",
        cols_arw, block_rows(arrays),
    )  # fmt: skip
    if thr is not None:
        rows = []
        for th in thr.thresholds:
            paper = paper_crossings(comp.scenario, th)
            for j, change in enumerate(thr.change_times):
                if study is None:
                    rise, fall = thr.crossings[th][j]
                else:
                    rise = finite_median(study.crossings[th][:, j, 0])
                    fall = finite_median(study.crossings[th][:, j, 1])
                exp = (thr.expected_crossings[th][j] if thr.expected_crossings is not None
                       else (math.nan, math.nan))  # fmt: skip
                pp = paper.get(change, (math.nan, math.nan))
                rows.append([th, change, rise, fall, exp[0], exp[1], pp[0], pp[1]])
        table(
            "crossings.csv",
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
        table(
            "seeds_nodes.csv",
            f"{head}; node times (s) of every realisation",
            ["seed", "method", "change_s", "beginning_s", "end_s", "restore_s"], rows,
        )  # fmt: skip
    return files


def compare_figures(comp: Any, kurt: Any, thr: Any) -> dict[str, Any]:
    """The figures of the comparison by file stem, not yet drawn (one is drawn, written
    and dropped before the next: each holds tens of floats per centre)."""
    from adavar.output.plots import paper_figure_recipes

    return paper_figure_recipes(comp, kurtosis=kurt, thresholds=thr)


def crossings_json(thr: Any) -> Any:
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


def _truth_column(args: argparse.Namespace, size: int, tau0: float) -> np.ndarray:
    """The true N of every sample, from another column of the compared FILE."""
    from adavar.readers import read_record

    record = read_record(
        args.file, columns=[args.truth_column], rate=1.0 / tau0, gaps=args.gaps,
        nan=args.nan, gap_tolerance=args.gap_tolerance, memory_map=False,
    )  # fmt: skip
    truth = np.asarray(record.channel(record.names[0]), dtype=np.float64)
    if truth.size != size:
        raise AdavarInputError(
            f"--truth-column {args.truth_column}: {truth.size} values for {size} samples "
            "(missing values dropped?): give a complete column"
        )
    return truth


def _cmd_compare(args: argparse.Namespace) -> int:
    if (args.file is None) == (args.scenario is None):
        raise UsageError("give a data FILE or --scenario 1|2 (one of them)")
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
    check_arguments(args)
    if args.out is not None:
        check_output_directory(args.out, replace=args.force)
        guard_replacement(args.out, [Path(args.file)] if args.file is not None else [])
    return _run_compare(args)


def _in_memory(data: Any) -> Any:
    """The record for the kurtosis studies, which run in memory (a file read piece by
    piece is loaded for them; a scenario or an array is passed on)."""
    from adavar.io.sources import is_chunked

    return np.asarray(data) if is_chunked(data) else data


def _run_compare(args: argparse.Namespace) -> int:
    from adavar.comparison import compare
    from adavar.core.request import RecordRequest
    from adavar.paper.reference import PAPER_FIG6_WINDOWS, PAPER_FIG8_THRESHOLDS
    from adavar.paper.scenarios import paper_scenario
    from adavar.paper.studies import compare_seeds, kurtosis_study, threshold_study
    from adavar.pipeline.analysis import read_input, refuse_constant_channels, resolve_lengths

    units: str | None = None
    tau0 = 1.0
    terms = args.terms or TERM_NAMES
    if args.crossing_thresholds is not None:
        fig8 = tuple(sorted(set(args.crossing_thresholds)))
    else:
        fig8 = tuple(sorted({*PAPER_FIG8_THRESHOLDS, float(args.k2)}))
    start = time.perf_counter()
    status = Status()
    truth = None
    if args.scenario is not None:
        args = resolve_lengths(args, 1.0)  # the paper's scenarios are at 1 Hz
        status(f"simulating scenario {args.scenario}")
        data: Any = paper_scenario(
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
        # read piece by piece where the file allows: the methods stream it
        loaded = read_input(RecordRequest.from_options(args), out_of_core=True, hint="")
        refuse_constant_channels(loaded, "the windows to compare")
        samples, units = loaded.first
        meta, tau0, used_rate = loaded.meta, loaded.tau0, loaded.record.rate
        args = resolve_lengths(args, tau0)
        if args.truth_column is not None:
            truth = _truth_column(args, samples.size, tau0)
        data = samples
        rate = used_rate if used_rate is not None else 1.0 / tau0
        changes = args.change_times
        input_json = {
            "file": meta["path"], "column": meta["column"], "rate": 1.0 / tau0, "tau0": tau0,
            "units": units, "n_samples": int(samples.size),
        }  # fmt: skip
        description = (f"{meta['path']}, column {meta['column']!r}: {samples.size} samples at "
                       f"{1.0 / tau0:g} Hz in {units}")  # fmt: skip
    controller = ControllerSettings.from_options(args)  # the controller's flags, once
    crossing_window = args.crossing_window or args.lmax
    status("running " + ", ".join(args.methods) if args.methods else "running the methods")
    comp = compare(
        data, methods=args.methods, rate=rate, change_times=changes, taus=args.taus or "all",
        terms=terms, units=units, description=description, truth=truth,
        intervals=args.intervals, confidence=args.confidence, noise_type=args.noise_type,
        points_per_decade=args.points_per_decade, keep="figures", step=args.step,
        max_memory=args.max_memory, chunk_size=args.chunk_size, settings=controller,
    )  # fmt: skip
    chosen = comp.parameters["step"]
    resolution = None
    if args.step is None and chosen > 1:
        resolution = (f"resolution: one centre in {chosen} ({comp.time.size} windows), to keep "
                      f"the methods' series within --max-memory {args.max_memory:g} MB (give "
                      "--step to choose)")  # fmt: skip
    input_json["resolution"] = resolution
    thr = None
    if comp.change_times:
        status("kurtosis threshold crossings")
        thr = threshold_study(_in_memory(data), change_times=comp.change_times,
                              window=crossing_window, thresholds=fig8, rate=comp.rate)  # fmt: skip
    status.close()
    study = None
    if args.seeds > 1:
        bar = ProgressBar(f"scenario {args.scenario}, {args.seeds} realisations")
        try:
            study = compare_seeds(
                args.scenario, range(args.seed, args.seed + args.seeds),
                variance_reading=args.variance_reading, methods=args.methods,
                taus=args.taus or "octave", terms=terms, crossing_thresholds=fig8,
                crossing_window=args.crossing_window, progress=bar, settings=controller,
            )  # fmt: skip
        finally:
            bar.close()
    kurt = None
    if args.out is not None and args.figures:  # the study is drawn, not tabulated
        status("kurtosis study")
        windows = tuple(w for w in PAPER_FIG6_WINDOWS if w <= comp.data.size)
        kurt = kurtosis_study(_in_memory(data), rate=comp.rate, windows=windows,
                              change_times=comp.change_times)  # fmt: skip
    elapsed = time.perf_counter() - start

    descriptions: dict[str, str] = {}
    tables = compare_tables(comp, study, thr, descriptions)
    figures = compare_figures(comp, kurt, thr) if args.out is not None and args.figures else {}
    written = [*tables, *(f"{stem}.{ext}" for stem in figures for ext in args.figures),
               "result.json"] if args.out is not None else []  # fmt: skip
    payload = {
        "adavar_version": __version__,
        "input": input_json,
        "comparison": comp.to_dict(),
        "crossings": crossings_json(thr),
        "seeds": None if study is None else study.to_dict(),
        "elapsed_s": elapsed,
        "out": None
        if args.out is None
        else {"dir": args.out, "files": written, "tables": descriptions},
    }
    text = dumps(payload)
    if args.out is not None:
        from adavar._kernels._heap import release_free_memory
        from adavar.output.plots import save_figure

        status(f"writing {args.out}")
        try:
            with atomic_directory(args.out, replace=args.force) as tmp:
                for name, pieces in tables.items():
                    write_pieces(tmp / name, pieces)
                for stem, (draw, fig_args, fig_kwargs) in figures.items():
                    status(f"drawing {stem}")
                    fig = draw(*fig_args, **fig_kwargs)
                    save_figure(fig, tmp / stem, args.figures)
                    fig.clear()  # its artists' arrays go now, not at the next collection
                    del fig
                    release_free_memory()  # and their pages, before the next figure's
                (tmp / "result.json").write_text(text + "\n", encoding="utf-8")
        except OSError as exc:
            raise output_error(args.out, exc) from None
    status.close()
    if args.json:
        print(text)
        if written:
            print(f"adavar: wrote {args.out}/ ({', '.join(written)})", file=sys.stderr)
        return EXIT_OK
    lines = compare_report(comp, study, thr)
    if resolution:
        lines += ["", resolution]
    if written:
        lines += ["", f"wrote {args.out}/ ({', '.join(written)})"]
    lines.append(f"done in {elapsed:.1f} s of computation")
    print("\n".join(lines))
    return EXIT_OK


def add_compare_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``adavar compare`` to the sub-command parsers ``sub``."""
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
    add_input_arguments(cmp_, optional_file=True, several=False)
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
        type=parse_seed,
        default=2018,
        metavar="N",
        help="seed of the (first) simulated realisation (default: 2018)",
    )
    cmp_.add_argument(
        "--seeds", type=positive_int, default=1, metavar="N",
        help="with --scenario: repeat over N realisations (seeds SEED .. SEED+N-1) and report "
        "medians and quartiles (default: 1)",
    )  # fmt: skip
    cmp_.add_argument(
        "--change-times", type=seconds_list, metavar="T,...",
        help="known change times of FILE in seconds, for the nodes (and the oracle)",
    )  # fmt: skip
    cmp_.add_argument(
        "--methods", type=parse_names, metavar="LIST",
        help="comma-separated methods: davar-<L> (fixed window), davar-k, a-davar, oracle, "
        "ici (intersection of confidence intervals, one-sided windows next to a change), "
        "ici-centred (the same, centred windows only) (default: "
        "davar-LMIN,davar-LMAX,davar-k,a-davar)",
    )  # fmt: skip
    add_controller_arguments(cmp_, hourly=False)
    # the paper's windows stay the default of compare (its scenarios are the paper's)
    cmp_.set_defaults(lmax=CONTROLLER.lmax, lmin=CONTROLLER.lmin, segment=CONTROLLER.l)
    cmp_.add_argument(
        "--taus", type=parse_taus, metavar="SPEC",
        help="taus of every surface: all (default for one realisation, the paper's), octave "
        "(default with --seeds > 1), decade, log, or comma-separated seconds",
    )  # fmt: skip
    cmp_.add_argument(
        "--terms", type=parse_terms, metavar="LIST",
        help="terms of the noise fit of every window (default: all five, the paper's)",
    )  # fmt: skip
    cmp_.add_argument(
        "--confidence", default=0.683, type=parse_confidence, metavar="P",
        help="level of the per-cell bounds whose EDF weights the fits (default: 0.683)",
    )  # fmt: skip
    cmp_.add_argument(
        "--noise-type", type=parse_noise_type, default="record", metavar="ALPHA",
        help="noise exponent behind the per-cell EDF: record (default), an integer alpha "
        "from -2 to 2, or one per tau (comma-separated)",
    )  # fmt: skip
    cmp_.add_argument(
        "--points-per-decade", default=10, type=points_per_decade, metavar="K",
        help="density of --taus log (default: 10)",
    )  # fmt: skip
    cmp_.add_argument(
        "--step", metavar="S", type=length_arg(1),
        help="centre the windows on every S-th sample only; samples or a duration such as "
        "10s (default: every sample, or as few as keep every method's series of N(t), "
        "window and controller record within --max-memory)",
    )  # fmt: skip
    add_chunk_argument(cmp_)
    cmp_.add_argument(
        "--max-memory", type=positive_float("MB"), default=DEFAULT_MAX_MEMORY_MB, metavar="MB",
        help="budget of the methods' per-centre series when --step is not given: every "
        f"centre while they fit, else every S-th (default: {DEFAULT_MAX_MEMORY_MB} MB)",
    )  # fmt: skip
    cmp_.add_argument(
        "--intervals", type=parse_intervals, metavar="A:B,...",
        help="ARW(A~B) interval means, seconds (default: the scenario's, the paper's; for a "
        "FILE the stretches between --change-times)",
    )  # fmt: skip
    cmp_.add_argument(
        "--truth-column", metavar="NAME",
        help="column of FILE holding the true N of every sample, for the ground-truth "
        "metrics",
    )  # fmt: skip
    cmp_.add_argument(
        "--crossing-window", type=window_length, metavar="L",
        help="fixed window of the kurtosis-crossing study, the paper's Fig. 8 (default: "
        "--lmax)",
    )  # fmt: skip
    cmp_.add_argument(
        "--crossing-thresholds", type=threshold_list, metavar="K,...",
        help="its K2 thresholds (default: 3.3,3.45,4 and --k2)",
    )  # fmt: skip
    cmp_.add_argument("--json", action="store_true", help="print one JSON object")
    add_output_arguments(
        cmp_,
        "also write the tables (CSV), result.json and the figures (the paper's Figs. 6, "
        "7, 8, 10, 11, 12 as .png/.svg, see --figures) to this new folder",
    )
    cmp_.set_defaults(handler=_cmd_compare)
    return cmp_

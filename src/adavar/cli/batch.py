"""``adavar batch``: many files, one task each (:mod:`adavar.pipeline.batch`)."""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import sys
import time
from collections.abc import Iterator
from typing import Any

from adavar import __version__
from adavar.cli.options import EXIT_INTERNAL, EXIT_OK, EXIT_USAGE, check_arguments
from adavar.cli.output import ProgressBar, text_table
from adavar.cli.report import check_adaptive_only_flags
from adavar.cli.values import positive_float, positive_int
from adavar.io.writers import dumps
from adavar.pipeline.batch_cluster import DEFAULT_WORKER_TIMEOUT

#: Most files listed one per line by ``adavar batch`` (beyond: the failed ones only).
_BATCH_LISTED = 50


def _duration(seconds: float) -> str:
    seconds = max(0, round(seconds))
    if seconds < 60:
        return f"{seconds} s"
    if seconds < 3600:
        return f"{seconds // 60} min {seconds % 60:02d} s"
    return f"{seconds // 3600} h {seconds // 60 % 60:02d} min"


class _BatchProgress(ProgressBar):
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
    from adavar.core.units import format_pm

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


#: The loggers of the cluster's libraries that this command quiets (below CRITICAL).
_CLUSTER_LOGGERS = ("distributed", "tornado", "asyncio")


@contextlib.contextmanager
def _quiet_cluster_logs(cluster: bool, debug: bool) -> Iterator[None]:
    """While this command runs a cluster (not with ``--debug``): dask's loggers print
    nothing below CRITICAL. A scheduler that died logged a 35-line traceback before the
    one-line error; every file's row says what happened instead. Only this command's
    process, only while it runs: importing adavar leaves the loggers alone."""
    if not cluster or debug:
        yield
        return
    import distributed  # noqa: F401 - its logging set-up first, then ours over it

    names = [
        name for name in (*_CLUSTER_LOGGERS, *logging.root.manager.loggerDict)
        if name in _CLUSTER_LOGGERS or name.startswith(tuple(f"{n}." for n in _CLUSTER_LOGGERS))
    ]  # fmt: skip
    before = {name: logging.getLogger(name).level for name in names}
    for name in before:
        logging.getLogger(name).setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for name, level in before.items():
            logging.getLogger(name).setLevel(level)


def _cmd_batch(args: argparse.Namespace) -> int:
    from adavar.pipeline.batch import collect_files, run_batch
    from adavar.pipeline.batch_state import STATUS_ABSENT
    from adavar.pipeline.report_analysis import report_options

    check_adaptive_only_flags(args)  # as adavar report: no adaptive window without --adaptive
    check_arguments(args)
    files = collect_files(args.inputs, files_from=args.files_from)
    options = report_options(args, ignore_unknown=True)
    progress = _BatchProgress()
    cluster = args.scheduler is not None or args.workers is not None
    debug = bool(getattr(args, "debug", False)) or os.environ.get(
        "ADAVAR_DEBUG", ""
    ).strip() not in ("", "0")
    try:
        with _quiet_cluster_logs(cluster, debug):
            result = run_batch(
                files, out=args.out, options=options, scheduler=args.scheduler,
                workers=args.workers, force=args.force, progress=progress,
                timeout=args.timeout, html=args.html, worker_timeout=args.worker_timeout,
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
    if result.summary_json is not None:
        summary.append(str(result.summary_json))
    if args.json:
        print(dumps({
            "adavar_version": __version__, "out": str(result.out), "cluster": result.cluster,
            "counts": counts, "elapsed_s": result.elapsed_s,
            "files_per_minute": 60.0 * computed / result.elapsed_s if computed else None,
            "summary": {"csv": str(result.summary_csv),
                        "parquet": None if result.summary_parquet is None
                        else str(result.summary_parquet),
                        "json": None if result.summary_json is None
                        else str(result.summary_json)},
            "notes": list(result.notes), "exit_code": code, "rows": result.rows,
        }))  # fmt: skip
    else:
        print(
            f"adavar batch: {counts['files']} files {result.cluster} in "
            f"{_duration(result.elapsed_s)}: {counts['ok']} ok, {counts['done']} done earlier "
            f"(skipped), {counts['error']} failed"
            + (f"; {counts['absent']} of earlier runs not in this one" if counts["absent"] else "")
        )
        if len(result.rows) <= _BATCH_LISTED:
            rows = [_batch_row_line(row) for row in result.rows
                    if row["status"] not in ("error", STATUS_ABSENT)]  # fmt: skip
            if rows:
                print(text_table(["output", "status", "whole-record fit", "events", "s"], rows,
                             "  "))  # fmt: skip
        for row in failed:
            print(f"  error in {row['name']}: {_batch_error(row)}")
        for note in result.notes:
            print(f"note: {note}")
        print(f"wrote {', '.join(summary[:-1])} and {summary[-1]}" if len(summary) > 1
              else f"wrote {summary[0]}")  # fmt: skip
    if failed:
        first = failed[0]
        print(
            f"adavar: error: {len(failed)} of {counts['files']} files failed (first: "
            f"{_batch_error(first)}); every file's row is in {summary[0]}: fix them and "
            "rerun with the same --out (the finished files are skipped)",
            file=sys.stderr,
        )
    return code


def add_batch_parser(sub: Any, report: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Add ``adavar batch`` to the sub-command parsers ``sub``."""
    bat = sub.add_parser(
        "batch",
        help="many logs at once, one task per file, on a dask cluster or in this process",
        description="Analyse every file as 'adavar report FILE' does (same options, same "
        "numbers), one task per file: in this process one by one (default), on a local "
        "cluster of --workers N processes, or on the workers of a running 'dask scheduler' "
        "(--scheduler). Each file gets OUT/<name>/ with report.html, result.json (fit with "
        "uncertainties, events, parameters, preprocessing) and deviation.csv, written "
        "atomically; OUT/summary.csv, summary.parquet and summary.json hold one row per file "
        "(with the files of earlier runs into this --out, status absent). A file's folder "
        "is named after its stem and a hash of its path (gyro-3f2a9c), the same in every "
        "run. A bad file is an error row (its folder says so) and does not stop the batch; "
        "a rerun skips the files done (same size, modification time, options and outputs). "
        "One run at a time writes into an --out: a second one stops at once. "
        "Exit code 0: every file ok; 2: some file (or the command line) has a user error; "
        "1: an internal error.",
    )
    bat.add_argument(
        "inputs", metavar="GLOB|FILE", nargs="*",
        help="files or quoted glob patterns ('logs/*.csv', 'data/**/*.npy')",
    )  # fmt: skip
    bat.add_argument("--files-from", metavar="LIST.txt",
                     help="also the files listed in this text file, one path per line "
                     "(relative to its folder; # comments)")  # fmt: skip
    # the analysis options are those of adavar report (the same objects: they cannot drift)
    bat.copy_options(report, skip=("help", "file", "output", "json", "force", "title",
                                   "debug", "config"))  # fmt: skip
    column = bat.option("--column")
    if column is not None:  # a report takes several, a batch one per file
        column.metavar = "NAME"
        column.help = ("header name or 0-based index of the channel, the same in every file "
                       "(one: run one batch per column)")  # fmt: skip
    bat.add_argument("--out", metavar="DIR", required=True,
                     help="output folder (created; an earlier batch's folder is reused and "
                     "its finished files skipped)")  # fmt: skip
    bat.add_argument("--scheduler", metavar="ADDRESS",
                     help="address of a running dask scheduler (tcp://HOST:8786) or its "
                     "--scheduler-file JSON; its workers must see the files and --out")  # fmt: skip
    bat.add_argument("--workers", metavar="N", type=positive_int,
                     help="start a local cluster of N single-threaded worker processes, "
                     "at most two a core and as many as the free memory holds at 256 MiB "
                     "each (default: no cluster, the files one by one in this "
                     "process)")  # fmt: skip
    bat.add_argument("--timeout", metavar="SECONDS", type=positive_float("seconds"),
                     default=10.0, help="wait this long for the scheduler and its first "
                     "worker (default: 10)")  # fmt: skip
    bat.add_argument("--worker-timeout", metavar="SECONDS", type=positive_float("seconds"),
                     default=DEFAULT_WORKER_TIMEOUT, help="give up when the cluster has had "
                     "no worker for this long (every worker died): the files not analysed "
                     "are error rows, the summary is written (default: "
                     f"{DEFAULT_WORKER_TIMEOUT:g})")  # fmt: skip
    bat.add_argument("--force", action="store_true",
                     help="recompute the files an earlier run of this --out finished (only "
                     "folders adavar wrote are ever replaced)")  # fmt: skip
    bat.add_argument("--no-html", dest="html", action="store_false",
                     help="skip each file's report.html (about 5 MB each: it embeds "
                     "plotly.js); result.json and deviation.csv are still written")  # fmt: skip
    bat.add_argument("--json", action="store_true", help="print one JSON object")
    bat.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                     help=argparse.SUPPRESS)  # fmt: skip
    bat.set_defaults(handler=_cmd_batch)
    return bat

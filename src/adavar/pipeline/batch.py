"""Batches of records: one task per file, on a ``dask.distributed`` cluster or in process.

:func:`run_batch` analyses many logs (a production line's static gyro recordings, a fleet's
daily files) the way ``adavar report FILE`` analyses one: every file is one task that runs
:func:`adavar.pipeline.report_analysis.analyse_file` (the pipeline of ``adavar report``,
:func:`adavar.pipeline.analysis.run`: the same load and channel analysis, so a file's numbers in a
batch are those of running ``adavar report`` on it alone) and writes its own folder
``OUT/<name>/`` atomically, where ``<name>`` is the file's stem and a short hash of its
resolved path (``gyro-3f2a9c``), the same in every run whatever the other files
(:mod:`adavar.pipeline.batch_state`):

- ``report.html``: the self-contained interactive report of ``adavar report``;
- ``result.json``: the input (file, column, rate, unit, samples, preprocessing, the size and
  modification time of the file), every analysis option, the whole-record noise fit (Q, N,
  B, K, R with 1-sigma uncertainties, in the data's units and the conventional ones), the
  events (with ``window`` or ``adaptive``), the time taken and the worker, and the
  ``outputs`` it was written with;
- ``deviation.csv``: the overlapping Allan deviation with its confidence bounds (plain CSV).

A file that fails gets a folder with its ``result.json`` only (``status: "error"``, the
message), which replaces its earlier results. Then ``OUT/summary.csv`` and
``OUT/summary.parquet`` (with pyarrow) hold one row per file (:data:`SUMMARY_COLUMNS`), and
``OUT/summary.json`` what the columns mean and how the run went, rewritten atomically at the
end of every run (also when it gave up on a cluster without workers). The rows are keyed by
the file's path: a file of an earlier run that is not among this run's inputs keeps its
folder and its row, with status ``absent``.

Where the tasks run: ``workers=N`` starts a ``distributed.LocalCluster`` of N single-threaded
worker processes (each with ``NUMBA_NUM_THREADS=1``, so N files use N cores);
``scheduler="tcp://host:8786"`` (or the path of a ``--scheduler-file`` JSON) connects to an
existing scheduler, whose workers must see the same files and ``OUT`` (a shared file
system); neither runs the files one after another in this process (no cluster to start, the
numba kernels use every core for each file). A cluster without any worker for
``worker_timeout`` seconds (every worker died) ends the batch: the files not analysed are
error rows, and the summary holds every row done so far.

One run at a time writes into an ``OUT``: a second run into it while the first runs
stops at once (the folder's lock, :mod:`adavar.pipeline.batch_state`) rather than lose the first
one's rows from the summary. A file's outputs that adavar did not write (a note added to
``OUT/<name>/``) stop its replacement, also with ``force=True``: the row's error names them.

A bad file (unreadable, NaN, too short, ...) ends its own task with its one-line error in
its row (``status="error"``) and does not stop the batch. A rerun skips every file whose
``OUT/<name>/result.json`` exists with the same input size, modification time and options,
and every output this run needs (``report.html`` unless ``html=False``)
(``status="done"``; its numbers are the stored ones); ``force=True`` recomputes them.

Events (``result.json["events"]``, ``n_events`` and ``event_times_s`` of the summary): with
``adaptive``, every run of window centres where the adaptive window is shorter than Lmax,
with its node times (docs/method.md section 9: Beginning, End = start of the last regrowth,
Restore = back at Lmax); with a fixed ``window`` L, every run of centres where the
adaptive controller's test (kurtosis outside [K1, K2] or S > S2, the same settings) flags
the L-sample window. With the paper's thresholds this test fires on stationary noise too
(a few runs per thousand windows): ``thresholds="calibrated"`` sets its false-alarm rate.
"""

from __future__ import annotations

import datetime as _dt
import glob
import json
import os
import time
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from adavar.core.atomic import BATCH_MARKER
from adavar.core.errors import AdavarInputError
from adavar.core.terms import LETTERS
from adavar.pipeline.analysis import surface_shape
from adavar.pipeline.batch_cluster import (
    DEFAULT_WORKER_TIMEOUT,
    check_worker_timeout,
    check_workers,
    connect,
    gather,
)
from adavar.pipeline.batch_state import (
    STATUS_ABSENT,
    BatchState,
    file_key,
    locked,
    output_names,
    outputs_complete,
    outputs_record,
    read_result,
)
from adavar.pipeline.report_analysis import ReportAnalysis, analyse_file, report_options
from adavar.readers.errors import GapError

__all__ = [
    "BATCH_MARKER",
    "DEFAULT_WORKER_TIMEOUT",
    "STATUS_ABSENT",
    "SUMMARY_COLUMNS",
    "BatchResult",
    "ReportAnalysis",
    "analyse_file",
    "collect_files",
    "output_names",
    "report_options",
    "run_batch",
]

#: Columns of ``summary.csv`` / ``summary.parquet``, in order. ``status`` is ``ok``
#: (computed now), ``done`` (skipped: the stored result of an earlier run), ``error``
#: (``error_type`` ``input``: a problem with the file or the options; ``internal``: a bug,
#: a lost worker, a cluster left without workers) or ``absent`` (a file of an earlier run
#: that is not among this run's inputs: its stored row). Coefficients are in their
#: conventional unit (``N_unit``, e.g. deg/sqrt(h)) when the data's unit has one, else in
#: the data's unit times a power of seconds; ``N_uncertainty`` is 1 sigma.
#: ``event_times_s``: the Beginning node of every event, seconds from the first sample,
#: separated by ``;``.
SUMMARY_COLUMNS: tuple[str, ...] = (
    "file", "name", "status", "error_type", "error", "n_samples", "rate_hz", "units",
    "column",
    *(f"{letter}{suffix}" for letter in LETTERS.values()
      for suffix in ("", "_uncertainty", "_unit")),
    "reduced_chi2", "n_events", "event_times_s", "elapsed_s", "worker",
)  # fmt: skip

_INT_COLUMNS = frozenset({"n_samples", "n_events"})
_FLOAT_COLUMNS = frozenset(
    {"rate_hz", "reduced_chi2", "elapsed_s"}
    | {f"{letter}{suffix}" for letter in LETTERS.values() for suffix in ("", "_uncertainty")}
)
#: What the summary's columns and statuses mean (``summary.json``).
_SUMMARY_DESCRIPTION = (
    "one row per file; status ok (computed), done (skipped: analysed earlier with the same "
    "input, options and outputs), error (error_type input or internal) or absent (a file of "
    "an earlier run, not among this run's inputs); coefficients in their *_unit, "
    "uncertainties 1 sigma; event_times_s: Beginning node of every event (s from the first "
    "sample), ';'-separated"
)


# --------------------------------------------------------------------------------------
# Inputs and output names
# --------------------------------------------------------------------------------------


def collect_files(
    patterns: Sequence[str | os.PathLike[str]] = (),
    *,
    files_from: str | os.PathLike[str] | None = None,
) -> list[str]:
    """The files of a batch: glob patterns and paths, and the lines of a list file.

    Parameters
    ----------
    patterns : sequence of str or path-like
        Paths, or glob patterns (``*``, ``?``, ``[...]``; ``**`` crosses folders), each
        expanded in sorted order. A plain path is taken as it is (a missing file becomes an
        error row of its own).
    files_from : str or path-like, optional
        A text file with one path per line (blank lines and lines starting with ``#`` are
        skipped; relative paths are relative to the list file's folder).

    Returns
    -------
    list of str
        Absolute paths, each once, in the order given.

    Raises
    ------
    AdavarInputError
        A pattern that matches nothing, an unreadable list file, or no file at all.
    """
    found: list[str] = []
    for pattern in patterns:
        text = os.fspath(pattern)
        if glob.has_magic(text):
            matches = sorted(glob.glob(os.path.expanduser(text), recursive=True))
            if not matches:
                raise AdavarInputError(
                    f"no file matches {text!r}: check the pattern (quote it so that the shell "
                    "does not expand it, e.g. 'logs/*.csv'; ** crosses folders)"
                )
            found += matches
        else:
            found.append(os.path.expanduser(text))
    if files_from is not None:
        listing = Path(files_from)
        try:
            lines = listing.read_text(encoding="utf-8").splitlines()
        except (OSError, UnicodeDecodeError) as exc:
            reason = getattr(exc, "strerror", None) or exc
            raise AdavarInputError(
                f"--files-from {listing}: cannot read it ({reason}): give a text file with "
                "one path per line"
            ) from None
        for line in lines:
            entry = line.strip()
            if entry and not entry.startswith("#"):
                item = Path(os.path.expanduser(entry))
                found.append(str(item if item.is_absolute() else listing.parent / item))
    out: list[str] = []
    seen: set[str] = set()
    for item in found:
        full = os.path.abspath(item)
        if full not in seen:
            seen.add(full)
            out.append(full)
    if not out:
        raise AdavarInputError(
            "no input files: give files or glob patterns (e.g. 'logs/*.csv'), or "
            "--files-from LIST.txt with one path per line"
        )
    return out


def _fingerprint(path: str) -> dict[str, Any] | None:
    """Size and modification time of a file (a ROS 2 bag folder: of its files), or None."""
    target = Path(path)
    try:
        if target.is_dir():
            stats = [p.stat() for p in sorted(target.rglob("*")) if p.is_file()]
            return {"size": sum(s.st_size for s in stats),
                    "mtime_ns": max((s.st_mtime_ns for s in stats), default=0),
                    "files": len(stats)}  # fmt: skip
        st = target.stat()
    except OSError:
        return None
    return {"size": int(st.st_size), "mtime_ns": int(st.st_mtime_ns)}


# --------------------------------------------------------------------------------------
# One task
# --------------------------------------------------------------------------------------


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())


def _plain(obj: Any) -> Any:
    """JSON-ready objects (NaN and inf as None), compared after a JSON round trip."""
    from adavar.io.writers import jsonable

    return json.loads(json.dumps(jsonable(obj), allow_nan=False))


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return f"in-process (pid {os.getpid()})"


def _row(path: str, name: str, **values: Any) -> dict[str, Any]:
    row: dict[str, Any] = dict.fromkeys(SUMMARY_COLUMNS)
    row.update(file=path, name=name, **values)
    return row


def _summary_row(
    path: str, name: str, analysis: ReportAnalysis, fit_json: dict[str, Any],
    events: dict[str, Any] | None,
) -> dict[str, Any]:  # fmt: skip
    conventional = fit_json.get("conventional")
    row = _row(path, name, status="ok", n_samples=analysis.n_samples,
               rate_hz=1.0 / analysis.tau0, units=analysis.units,
               column=str(analysis.meta["column"]),
               reduced_chi2=fit_json.get("reduced_chi2"))  # fmt: skip
    for term, letter in LETTERS.items():
        source = conventional[term] if conventional else fit_json[term]
        row[letter] = source["value"]
        row[f"{letter}_uncertainty"] = source["uncertainty"]
        row[f"{letter}_unit"] = source["unit"]
    if events is not None and events["items"] is not None:
        row["n_events"] = events["count"]
        row["event_times_s"] = ";".join(repr(item["start_s"]) for item in events["items"])
    return row


def _write_outputs(
    target: Path, analysis: ReportAnalysis, payload: dict[str, Any], start: float,
    row: dict[str, Any], html: bool = True,
) -> None:  # fmt: skip
    """``report.html`` (if ``html``), ``deviation.csv`` and last ``result.json``, into one
    new folder (replacing the file's earlier one)."""
    from adavar.io import writers

    page = analysis.html() if html else None
    files = ["deviation.csv", "result.json", *(["report.html"] if page is not None else [])]
    with writers.atomic_directory(target, replace=True, sweep=False) as tmp:
        if page is not None:
            (tmp / "report.html").write_text(page, encoding="utf-8")
        writers.write_deviation_csv(tmp / "deviation.csv", analysis.deviation)
        row["elapsed_s"] = time.perf_counter() - start
        payload["elapsed_s"] = row["elapsed_s"]
        payload["outputs"] = outputs_record(html, files)
        payload["summary"] = row
        (tmp / "result.json").write_text(writers.dumps(payload) + "\n", encoding="utf-8")


def _write_error_folder(
    out: Path, row: dict[str, Any], options: dict[str, Any], html: bool
) -> dict[str, Any]:
    """``OUT/<name>/`` of a file that failed: its ``result.json`` only (status error, the
    message), in place of its earlier results. Returns the row (its error extended if even
    that could not be written)."""
    from adavar import __version__
    from adavar.core.atomic import atomic_directory
    from adavar.io.writers import dumps

    payload = {
        "adavar_version": __version__, "status": "error", "file": row["file"],
        "name": row["name"], "error_type": row["error_type"], "error": row["error"],
        "input": {"fingerprint": _fingerprint(row["file"])}, "options": _plain(options),
        "outputs": outputs_record(html, ["result.json"]), "worker": row["worker"],
        "finished": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"), "summary": row,
    }  # fmt: skip
    try:
        with atomic_directory(out / row["name"], replace=True, sweep=False) as tmp:
            (tmp / "result.json").write_text(dumps(payload) + "\n", encoding="utf-8")
    except Exception as exc:  # the row keeps its error; the folder could not say it
        reason = _one_line(exc)
        if reason not in row["error"]:
            row = {**row, "error": f"{row['error']} (and its folder was not updated: {reason})"}
    return row


def _process_file(
    path: str, name: str, out: str, options: dict[str, Any], html: bool = True
) -> dict[str, Any]:
    """The task of one file: analyse it, write ``OUT/<name>/``, return its summary row.

    Every exception but an interrupt becomes the row's error, so one bad file does not
    stop the batch. The file's freed memory goes back to the system before the next
    file (a batch's peak is then one file's, not one file's on top of the holes of the
    files before).
    """
    from adavar._kernels._heap import release_free_memory

    try:
        return _analyse_and_write(path, name, out, options, html)
    finally:
        release_free_memory()


def _analyse_and_write(
    path: str, name: str, out: str, options: dict[str, Any], html: bool
) -> dict[str, Any]:
    """The body of :func:`_process_file`."""
    from adavar import __version__
    from adavar.io.writers import fit_json as _fit_json

    start = time.perf_counter()
    worker = _worker_name()
    try:
        fingerprint = _fingerprint(path)
        analysis = analyse_file(path, options, keep="figures")
        events = analysis.events()
        fit_json = _fit_json(analysis.fit)
        row = _summary_row(path, name, analysis, fit_json, events)
        row["worker"] = worker
        payload: dict[str, Any] = {
            "adavar_version": __version__,
            "status": "ok",
            "file": path,
            "name": name,
            "input": {
                "file": analysis.meta["path"], "column": analysis.meta["column"],
                "format": analysis.meta["kind"], "rate": 1.0 / analysis.tau0,
                "tau0": analysis.tau0, "rate_from": analysis.meta["rate_from"],
                "units": analysis.units, "data_type": analysis.options["data_type"],
                "n_samples": analysis.n_samples, "preprocessing": analysis.preprocessing,
                "fingerprint": fingerprint,
            },
            "options": _plain(options),
            "parameters": analysis.parameters,
            "fit": fit_json,
            "surface": surface_shape(analysis.surface),
            "events": events,
            "worker": worker,
            "finished": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        }  # fmt: skip
        _write_outputs(Path(out) / name, analysis, payload, start, row, html)
        return row
    except GapError as exc:  # the reader names --gaps split and omit: not batch's
        error_type, message = "input", f"{exc.problem}: use --gaps interpolate"
    except AdavarInputError as exc:
        error_type, message = "input", _one_line(exc)
    except Exception as exc:  # a bug in one file's task is that file's row, not the batch's
        error_type, message = "internal", f"{type(exc).__name__}: {_one_line(exc)}"
    row = _row(path, name, status="error", error_type=error_type, error=message,
               elapsed_s=time.perf_counter() - start, worker=worker)  # fmt: skip
    return _write_error_folder(Path(out), row, options, html)


def _done_row(
    out: Path, path: str, name: str, options: dict[str, Any], html: bool = True
) -> dict[str, Any] | None:
    """The stored row of a file already analysed with these options into every output this
    run needs, or None."""
    stored = read_result(out / name)
    if stored is None or not isinstance(stored.get("summary"), dict):
        return None
    fingerprint = _fingerprint(path)
    if (
        fingerprint is None
        or stored["summary"].get("status") != "ok"
        or not isinstance(stored.get("file"), str)
        or file_key(stored["file"]) != file_key(path)
        or (stored.get("input") or {}).get("fingerprint") != fingerprint
        or stored.get("options") != _plain(options)
        or not outputs_complete(stored, out / name, html)
    ):
        return None
    row = _row(path, name)
    row.update({k: v for k, v in stored["summary"].items() if k in row})
    row["status"] = "done"
    return row


# --------------------------------------------------------------------------------------
# The batch
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BatchResult:
    """What :func:`run_batch` did.

    Attributes
    ----------
    rows : list of dict
        One summary row per file (keys :data:`SUMMARY_COLUMNS`): this run's files in input
        order, then those of earlier runs that are not among them (status ``absent``).
    counts : dict
        ``{"files", "ok", "done", "error", "input_errors", "internal_errors", "absent"}``
        (``files``: this run's).
    out : Path
        The output folder.
    summary_csv : Path
        ``OUT/summary.csv``.
    summary_parquet : Path or None
        ``OUT/summary.parquet`` (None without pyarrow).
    summary_json : Path or None
        ``OUT/summary.json``: what the columns mean, the counts, the options, the notes.
    cluster : str
        Where the tasks ran.
    elapsed_s : float
        Wall time of the batch, seconds.
    notes : tuple of str
        Anything the caller should know (no pyarrow, inputs inside OUT left out, ...).
    """

    rows: list[dict[str, Any]]
    counts: dict[str, int]
    out: Path
    summary_csv: Path
    summary_parquet: Path | None
    cluster: str
    elapsed_s: float
    notes: tuple[str, ...] = ()
    summary_json: Path | None = None


def _check_options(options: dict[str, Any], paths: Sequence[str]) -> None:
    """Mistakes in the options that would fail every file, before any work."""
    from adavar.io.preprocess import Pipeline
    from adavar.readers import SUFFIXES

    if options.get("rate") is not None and options.get("tau0") is not None:
        raise AdavarInputError("give exactly one of --rate HZ or --tau0 SECONDS (both given)")
    units = options.get("units")
    if not (isinstance(units, str) and units.strip()):
        # ROS bags declare their units; every other format needs --units
        bags = {suffix for suffix, kind in SUFFIXES.items() if kind in ("ros1", "ros2")}
        if not all(Path(p).is_dir() or Path(p).suffix.lower() in bags for p in paths):
            raise AdavarInputError(
                "declare the unit of the samples with --units (e.g. --units deg/s); adavar "
                "never guesses units"
            )
    steps = options.get("preprocess")
    if steps:
        Pipeline(str(steps))


def _check_out(out: str | os.PathLike[str]) -> Path:
    target = Path(out).expanduser().absolute()
    if target.exists() or target.is_symlink():
        if not target.is_dir():
            raise AdavarInputError(f"--out {out} exists and is not a folder: choose another one")
        if not (target / BATCH_MARKER).is_file() and any(target.iterdir()):
            raise AdavarInputError(
                f"--out {out} exists and is not an adavar batch folder (no {BATCH_MARKER} in "
                "it): choose a new or empty folder, or the --out of an earlier batch"
            )
    elif not target.parent.is_dir():
        raise AdavarInputError(
            f"the parent folder of --out {out} does not exist: create it first or choose "
            "another output folder"
        )
    return target


def _open_out(target: Path) -> None:
    try:
        target.mkdir(exist_ok=True)
        marker = target / BATCH_MARKER
        if not marker.is_file():
            marker.write_text(
                "written by adavar batch: a rerun with this --out skips the files already "
                "done\n", encoding="utf-8",
            )  # fmt: skip
    except OSError as exc:
        raise AdavarInputError(
            f"cannot write the output folder {target}: {exc.strerror or exc}"
        ) from None


def _write_summary(
    out: Path, rows: list[dict[str, Any]], notes: list[str], about: dict[str, Any]
) -> tuple[Path, Path | None]:
    """``summary.csv``, ``summary.parquet`` (with pyarrow) and ``summary.json`` (what the
    columns mean, the counts, the notes), each atomically."""
    from adavar import __version__
    from adavar.core.atomic import atomic_file
    from adavar.output.export import write_json, write_table_csv

    csv_path = Path(write_table_csv(out / "summary.csv", rows, SUMMARY_COLUMNS))
    parquet: Path | None = None
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        notes.append("pyarrow is not installed: wrote summary.csv only (pip install pyarrow "
                     "for summary.parquet)")  # fmt: skip
    else:

        def kind(column: str) -> Any:
            if column in _INT_COLUMNS:
                return pa.int64()
            return pa.float64() if column in _FLOAT_COLUMNS else pa.string()

        schema = pa.schema([pa.field(c, kind(c)) for c in SUMMARY_COLUMNS])
        table = pa.Table.from_pylist([{c: row[c] for c in SUMMARY_COLUMNS} for row in rows],
                                     schema=schema)  # fmt: skip
        parquet = out / "summary.parquet"
        with atomic_file(parquet) as handle:
            pq.write_table(table, handle)
    write_json(out / "summary.json", {
        "adavar_version": __version__, "description": _SUMMARY_DESCRIPTION,
        "columns": list(SUMMARY_COLUMNS), **about, "notes": list(notes),
        "finished": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    })  # fmt: skip
    return csv_path, parquet


def _absent_row(path: str, name: str, stored: dict[str, Any] | None) -> dict[str, Any]:
    """The row of a file of an earlier run that is not among this run's inputs."""
    row = _row(path, name, status=STATUS_ABSENT)
    summary = (stored or {}).get("summary")
    if isinstance(summary, dict):
        row.update({k: v for k, v in summary.items()
                    if k in row and k not in ("file", "name", "status")})  # fmt: skip
    return row


def run_batch(
    files: Sequence[str | os.PathLike[str]],
    *,
    out: str | os.PathLike[str],
    options: Mapping[str, Any] | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    force: bool = False,
    progress: Callable[[int, int, dict[str, Any]], None] | None = None,
    timeout: float = 10.0,
    html: bool = True,
    worker_timeout: float = DEFAULT_WORKER_TIMEOUT,
) -> BatchResult:
    """Analyse many files, one task per file, and write their results and a summary.

    Parameters
    ----------
    files : sequence of str or path-like
        The records (see :func:`collect_files` for globs and list files). Files inside
        ``out`` are left out; two paths of the same file (a symlink) count once.
    out : str or path-like
        Output folder: created if missing (its parent must exist); an existing one must be
        empty or an earlier batch's (it holds :data:`BATCH_MARKER`).
    options : mapping, optional
        Analysis options of every file (:func:`report_options`), e.g. ``{"units": "deg/s",
        "rate": 100, "adaptive": True}``.
    scheduler : str, optional
        Address of a running ``dask scheduler`` (``tcp://host:8786``) or the path of its
        ``--scheduler-file``; its workers must see the files and ``out``.
    workers : int, optional
        Start a ``distributed.LocalCluster`` of this many single-threaded processes: at
        most two a core, and no more than the free memory holds at 256 MiB each
        (:func:`adavar.pipeline.batch_cluster.max_workers`). Neither ``scheduler`` nor ``workers``:
        the files run one by one in this process.
    force : bool
        Recompute files analysed by an earlier run (default: skip them).
    progress : callable, optional
        Called as ``progress(done, total, row)`` after every file (skipped ones first).
    timeout : float
        Seconds to wait for the scheduler (and for its first worker).
    html : bool
        Write each file's ``report.html`` (default). It embeds plotly.js and weighs about
        5 MB; ``False`` keeps ``result.json`` and ``deviation.csv`` only, for fleets of
        thousands of files. A file done earlier without the report is redone with it.
    worker_timeout : float
        Seconds the batch waits while its cluster has no worker at all (every worker died
        or left) before it gives up: the files not analysed become error rows (internal)
        and the summary is written with every row done so far.

    Returns
    -------
    BatchResult

    Raises
    ------
    AdavarInputError
        Bad options, an unusable ``out``, both or a bad ``scheduler``/``workers`` (more
        workers than this machine runs), a scheduler that cannot be reached or has no
        worker: nothing is written then. Another run writing into ``out`` now (it holds
        the folder's lock, :func:`adavar.pipeline.batch_state.locked`): the message names its pid,
        and nothing of this run is written.
    """
    from adavar.core.atomic import sweep_partial_files, sweep_stale_temporaries

    start = time.perf_counter()
    target = _check_out(out)
    wait_s = check_worker_timeout(worker_timeout)
    check_workers(workers)  # before any work: a million processes fill the memory
    paths = [os.path.abspath(os.fspath(p)) for p in files]
    notes: list[str] = []
    inside = [p for p in paths if Path(p) == target or target in Path(p).parents]
    if inside:
        notes.append(f"left out {len(inside)} file(s) inside --out {out}")
        paths = [p for p in paths if p not in inside]
    by_key: dict[str, str] = {}
    for p in paths:
        by_key.setdefault(file_key(p), p)  # one task per file, whatever its path
    paths = list(by_key.values())
    if not paths:
        raise AdavarInputError(
            "no input files: give files or glob patterns (e.g. 'logs/*.csv'), or "
            "--files-from LIST.txt with one path per line"
        )
    opts = report_options(options)
    _check_options(opts, paths)
    total = len(paths)
    rows: list[dict[str, Any] | None] = [None] * total
    done = 0

    def finished(i: int, row: dict[str, Any]) -> None:
        nonlocal done
        rows[i] = row
        done += 1
        if progress is not None:
            progress(done, total, row)

    with connect(scheduler, workers, float(timeout)) as (client, where):
        _open_out(target)
        with locked(target, out):  # one run at a time writes into OUT
            swept = sweep_stale_temporaries(target)
            if swept:
                notes.append(f"removed {len(swept)} temporary folder(s) that killed runs "
                             f"left in --out {out}")  # fmt: skip
            swept_files = sweep_partial_files(target)
            if swept_files:
                notes.append(f"removed {len(swept_files)} temporary file(s) that killed runs "
                             f"left in --out {out}")  # fmt: skip
            state = BatchState.load(target)
            names = state.assign(paths)
            absent = [_absent_row(*item) for item in state.absent(set(by_key))]
            state.orphans()
            state.save()  # before any task: a killed run's folders are found again
            notes += state.notes
            pending = []
            for i, (path, name) in enumerate(zip(paths, names, strict=True)):
                row = None if force else _done_row(target, path, name, opts, html)
                if row is None:
                    pending.append(i)
                else:
                    finished(i, row)
            if client is None:
                for i in pending:
                    finished(i, _process_file(paths[i], names[i], str(target), opts, html))
            elif pending:

                def failed(i: int, message: str) -> dict[str, Any]:
                    row = _row(paths[i], names[i], status="error", error_type="internal",
                               error=message)  # fmt: skip
                    return _write_error_folder(target, row, opts, html)

                jobs = {i: (paths[i], names[i], str(target), opts, html) for i in pending}
                left = gather(client, _process_file, jobs, finished, failed, wait_s)
                if left:
                    message = (
                        f"not analysed: the cluster ({where}) had no worker for {wait_s:g} s "
                        "(every worker died or left): start workers and rerun with the same "
                        "--out (the finished files are skipped), or wait longer with "
                        "--worker-timeout SECONDS"
                    )
                    for i in left:
                        finished(i, failed(i, message))
                    notes.append(f"gave up after {wait_s:g} s without any dask worker: "
                                 f"{len(left)} of {total} file(s) not analysed")  # fmt: skip
            final = [row for row in rows if row is not None]
            counts = Counter(row["status"] for row in final)
            errors = Counter(row["error_type"] for row in final if row["status"] == "error")
            summary_counts = {
                "files": total, "ok": counts["ok"], "done": counts["done"],
                "error": counts["error"], "input_errors": errors["input"],
                "internal_errors": errors["internal"], "absent": len(absent),
            }  # fmt: skip
            about = {"counts": summary_counts, "cluster": where, "options": _plain(opts),
                     "html": html}  # fmt: skip
            # inside the lock: the summary is this run's rows and no other run's
            csv_path, parquet = _write_summary(target, final + absent, notes, about)
    return BatchResult(
        rows=final + absent, counts=summary_counts, out=target, summary_csv=csv_path,
        summary_parquet=parquet, cluster=where, elapsed_s=time.perf_counter() - start,
        notes=tuple(notes), summary_json=target / "summary.json",
    )  # fmt: skip

"""``adavar monitor``: the adaptive window on a live stream, one JSON line per event.

The samples come from standard input (``-``), a file that is being appended to (followed
like ``tail -f``) or UDP datagrams on a local port (``udp://127.0.0.1:PORT``), as text (one
number a line, or delimited columns with ``--column``) or little-endian binary floats
(``--format f32`` / ``f64``). They go to :class:`adavar.OnlineAdaptive` as they arrive;
each event (a non-stationary stretch) is printed on stdout as soon as it is confirmed.
At the end of the input, after ``--idle-timeout`` seconds without data, or on Ctrl-C, the
pass is finished (the record's right mirror) and the remaining events are printed.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import select
import socket
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from adavar.cli.options import (
    EXIT_OK,
    UsageError,
    add_controller_arguments,
    add_dependence_argument,
    add_ici_arguments,
    add_kurtosis_reference_argument,
    check_arguments,
    finite_float,
    ici_settings,
    length_arg,
    parse_noise_type,
    parse_taus,
    parse_terms,
    positive_float,
    positive_int,
)
from adavar.errors import AdavarInputError
from adavar.settings import ICI_EDF_SAMPLES, STREAM_LMAX_SECONDS

__all__ = ["add_monitor_parser"]

#: bytes read at a time from a file or a pipe
READ_BYTES = 1 << 16
#: seconds between polls of a file that has no new data
POLL_SECONDS = 0.05
#: seconds between status-line updates
STATUS_SECONDS = 0.25
_SPLIT = re.compile(rb"[,;\s]+")


def add_monitor_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``adavar monitor`` to the sub-command parsers ``sub``."""
    cmd = sub.add_parser(
        "monitor",
        help="the adaptive window on a live stream: one JSON line per detected event",
        description="Run the adaptive window (A-DAVAR, docs/method.md section 8) on a live "
        "stream of rate samples: SOURCE is - (standard input), a file that is being "
        "appended to (followed like tail -f) or udp://127.0.0.1:PORT (datagrams of text "
        "lines, or of binary floats with --format). Each non-stationary stretch is printed "
        "on stdout as one JSON object (start_s, end_s, and the noise coefficient N before, "
        "during and after it) as soon as its end is detected; at the end of the input, "
        "after --idle-timeout seconds without data, or on Ctrl-C, the pass is finished and "
        "the remaining events are printed. The defaults are those of 'adavar adaptive' "
        "(Lmin and l from Lmax, thresholds for 0.1 false events per stationary hour; "
        "--lmax 180 s, a stream having no length to take a tenth of); the first window "
        "comes after the first 8192 samples or half Lmax. The windows and the change times "
        "are those of 'adavar adaptive' on the same record with the same --lmax (on a "
        "30-minute record, also without), the events with their N summaries those of "
        "'adavar adaptive --taus octave --noise-type 0 --terms N' (where its whole-record "
        "fit finds no filter roll-off to take out of every window). A status line goes to "
        "stderr when it is a terminal.",
    )
    cmd.add_argument("source", metavar="SOURCE",
                     help="- (standard input), a file path, or udp://HOST:PORT")  # fmt: skip
    cmd.add_argument("--rate", metavar="HZ", type=positive_float("Hz"), required=True,
                     help="sample rate in Hz (required)")  # fmt: skip
    cmd.add_argument("--units", metavar="UNIT", required=True,
                     help="unit of the samples, e.g. deg/s, rad/s, m/s^2 (required)")  # fmt: skip
    cmd.add_argument(
        "--column", type=int, default=None, metavar="N",
        help="0-based column of delimited text lines (comma, semicolon, tab or spaces); "
        "default: the only one",
    )  # fmt: skip
    cmd.add_argument(
        "--format", default="text", choices=("text", "f32", "f64"), dest="input_format",
        help="text (default), or little-endian binary float32/float64 samples",
    )  # fmt: skip
    cmd.add_argument(
        "--idle-timeout", type=positive_float("seconds"), default=None, metavar="S",
        help="finish after S seconds without new data (default: follow a file or a UDP port "
        "until Ctrl-C, standard input until its end); a small value ends at the end of a "
        "complete file",
    )  # fmt: skip
    cmd.add_argument(
        "--method", default="adaptive", choices=("adaptive", "kurtosis", "ici"),
        help="adaptive (A-DAVAR, default), kurtosis (DAVAR-K) or ici (intersection of "
        "confidence intervals, one-sided windows next to a change: docs/method.md section "
        "11; its rows come about 3.3 Lmax after their centre, 1.5 Lmax with "
        "--no-ici-episodes)",
    )  # fmt: skip
    add_controller_arguments(cmd)
    add_ici_arguments(cmd, live=True)
    defaults = {  # a stream has no length: a tenth of a 30-minute record
        "lmax": "longest window: samples, or a duration such as 6s or 10min (default: "
        f"{STREAM_LMAX_SECONDS:g} s, a tenth of a 30-minute record; 'adavar adaptive' takes a "
        "tenth of the record)",
        "lmin": "shortest window: samples or a duration (default: two thirds of Lmax)",
        "segment": "leading segment of the S test: samples or a duration (default: a sixth "
        "of Lmax)",
    }
    defaults["ici_edf_samples"] = (
        "measure the correlation EDF of --method ici on the first K samples (default "
        f"{ICI_EDF_SAMPLES}); no row before they have arrived. 'adavar adaptive --method ici "
        "--ici-edf-samples K' gives the same windows"
    )
    for action in cmd._actions:
        if action.dest in defaults:
            action.help = defaults[action.dest]
    add_dependence_argument(cmd)
    add_kurtosis_reference_argument(cmd)
    cmd.add_argument(
        "--step", type=length_arg(1), default=1, metavar="S",
        help="keep every S-th centre's window and N (samples or a duration; default: every "
        "centre)",
    )  # fmt: skip
    cmd.add_argument(
        "--terms", type=parse_terms, default=("angle_random_walk",), metavar="LIST",
        help="terms fitted to every kept window and summarised in the events (names or "
        "Q,N,B,K,R; default: N)",
    )  # fmt: skip
    cmd.add_argument("--taus", type=parse_taus, default="octave", metavar="SPEC",
                     help="taus of the windows' fit (default: octave)")  # fmt: skip
    cmd.add_argument(
        "--noise-type", type=parse_noise_type, default=0, metavar="ALPHA",
        help="noise exponent behind the EDF of the fit's weights: an integer alpha (default "
        "0, white rate noise) or one per tau",
    )  # fmt: skip
    cmd.add_argument("--edge-edf", default="distinct", choices=("distinct", "interior"),
                     help="EDF of a window reaching into the mirrored ends")  # fmt: skip
    cmd.add_argument("--t0", type=finite_float, default=0.0, metavar="SECONDS",
                     help="time of the first sample (default: 0)")  # fmt: skip
    cmd.add_argument(
        "--bandwidth", type=positive_float("Hz"), metavar="HZ",
        help="the sensor's bandwidth: the fit leaves out taus below 2 / bandwidth",
    )  # fmt: skip
    cmd.add_argument(
        "--fit-batch", type=positive_int, default=1, metavar="N",
        help="fit the windows in batches of N (default: 1, at once; larger costs less per "
        "sample on a fast stream and delays N(t), not the events)",
    )  # fmt: skip
    cmd.add_argument(
        "--final", action="store_true",
        help="print each event once its 'after' summary is final (at the next event or the "
        "end) instead of when it is confirmed",
    )  # fmt: skip
    cmd.set_defaults(handler=_cmd_monitor)
    return cmd


# ---------------------------------------------------------------------------------------
# sources: byte chunks as they arrive (None: nothing new within the poll interval)


def _stdin_chunks(idle: float | None) -> Iterator[bytes | None]:
    stream = sys.stdin.buffer if hasattr(sys.stdin, "buffer") else None
    try:
        fd = (stream or sys.stdin).fileno()
    except (AttributeError, OSError, ValueError):
        fd = None
    if fd is None:  # an in-memory stdin (tests, notebooks): read it as it is
        data = sys.stdin.read()
        yield data.encode() if isinstance(data, str) else data
        return
    last = time.monotonic()
    while True:
        wait = STATUS_SECONDS if idle is None else min(STATUS_SECONDS, idle)
        try:
            ready, _, _ = select.select([fd], [], [], wait)
        except (OSError, ValueError):  # not selectable (Windows): blocking reads
            ready = [fd]
        if ready:
            data = os.read(fd, READ_BYTES)
            if not data:
                return
            last = time.monotonic()
            yield data
        elif idle is not None and time.monotonic() - last >= idle:
            return
        else:
            yield None


def _file_chunks(path: Path, idle: float | None) -> Iterator[bytes | None]:
    try:
        handle = path.open("rb")
    except OSError as exc:
        raise UsageError(f"cannot read {str(path)!r}: {exc.strerror or exc}") from None
    with handle:
        last = time.monotonic()
        while True:
            data = handle.read(READ_BYTES)
            if data:
                last = time.monotonic()
                yield data
                continue
            if idle is not None and time.monotonic() - last >= idle:
                return
            yield None
            time.sleep(POLL_SECONDS)


def _udp_chunks(host: str, port: int, idle: float | None, text: bool) -> Iterator[bytes | None]:
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_DGRAM)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise UsageError(f"cannot listen on udp://{host}:{port}: {exc.strerror or exc}") from None
    with sock:
        sock.settimeout(STATUS_SECONDS if idle is None else min(STATUS_SECONDS, idle))
        last = time.monotonic()
        while True:
            try:
                data = sock.recv(1 << 16)
            except TimeoutError:
                if idle is not None and time.monotonic() - last >= idle:
                    return
                yield None
                continue
            last = time.monotonic()
            # a datagram holds whole lines: end the last one
            yield data + b"\n" if text and data and not data.endswith(b"\n") else data


def _open_source(source: str, idle: float | None, text: bool) -> Iterator[bytes | None]:
    if source == "-":
        return _stdin_chunks(idle)
    if source.startswith("udp://"):
        match = re.fullmatch(r"udp://\[?([^\[\]]+?)\]?:(\d+)", source)
        if match is None or not 0 < int(match.group(2)) < 65536:
            raise UsageError(f"SOURCE {source!r}: give udp://127.0.0.1:PORT (PORT 1-65535)")
        host = "127.0.0.1" if match.group(1) == "localhost" else match.group(1)
        return _udp_chunks(host, int(match.group(2)), idle, text)
    path = Path(source)
    if not path.exists():
        raise UsageError(f"SOURCE {source!r}: no such file (give -, a file or udp://HOST:PORT)")
    if path.is_dir():
        raise UsageError(f"SOURCE {source!r} is a folder: give a file")
    return _file_chunks(path, idle)


# ---------------------------------------------------------------------------------------
# decoding: bytes -> samples


class _TextDecoder:
    """Complete lines -> numbers (one column); a header line before the first number skipped."""

    def __init__(self, column: int | None) -> None:
        self.column = column
        self.rest = b""
        self.line = 0
        self.started = False

    def __call__(self, data: bytes, final: bool = False) -> np.ndarray:
        data = self.rest + data
        cut = len(data) if final else data.rfind(b"\n") + 1
        self.rest = data[cut:]
        block = data[:cut]
        if self.column is None and self.started and b"#" not in block:
            # one number on every line (no blank ones): converted at once, in C
            tokens = block.split()
            lines = block.count(b"\n") + (0 if block.endswith(b"\n") or not block else 1)
            if len(tokens) == lines:
                try:
                    values = np.array(tokens, dtype=np.float64)
                except ValueError:
                    pass  # the line by line path below names the bad line
                else:
                    self.line += lines
                    return values
        lines = block.splitlines()
        values: list[float] = []
        for raw in lines:
            self.line += 1
            text = raw.strip()
            if not text or text.startswith(b"#"):
                continue
            fields = [f for f in _SPLIT.split(text) if f]
            if self.column is None and len(fields) > 1:
                raise AdavarInputError(
                    f"line {self.line} has {len(fields)} columns: choose one with --column N "
                    "(0-based)"
                )
            index = 0 if self.column is None else self.column
            if index >= len(fields):
                raise AdavarInputError(
                    f"line {self.line} has {len(fields)} columns, no column {index} "
                    "(--column is 0-based)"
                )
            try:
                values.append(float(fields[index]))
            except ValueError:
                if not self.started:  # a header
                    self.started = True
                    continue
                shown = fields[index].decode(errors="replace")[:40]
                raise AdavarInputError(
                    f"line {self.line}: {shown!r} is not a number (one sample a line, or "
                    "--column N of delimited lines)"
                ) from None
            self.started = True
        return np.asarray(values, dtype=float)


class _BinaryDecoder:
    def __init__(self, dtype: str) -> None:
        self.dtype = np.dtype(dtype)
        self.rest = b""

    def __call__(self, data: bytes, final: bool = False) -> np.ndarray:
        data = self.rest + data
        size = self.dtype.itemsize
        cut = len(data) // size * size
        self.rest = data[cut:]
        if final and self.rest:
            raise AdavarInputError(
                f"the input ends with {len(self.rest)} bytes, not a whole {size}-byte sample"
            )
        return np.frombuffer(data[:cut], dtype=self.dtype).astype(np.float64)


# ---------------------------------------------------------------------------------------
# the command


def _event_line(live: Any, index: int, units: str, final: bool) -> str:
    obj = {"event": index, **live.events[index].as_dict(), "units": units, "final": final}
    return json.dumps(obj)


class _Status:
    """One status line on stderr, only on a terminal, at most every STATUS_SECONDS."""

    def __init__(self) -> None:
        self.enabled = sys.stderr.isatty()
        self.last = 0.0
        self.shown = False

    def __call__(self, live: Any, units: str, force: bool = False) -> None:
        now = time.monotonic()
        if not self.enabled or (not force and now - self.last < STATUS_SECONDS):
            return
        self.last = now
        row = live.latest
        if not row:
            line = (f"monitor: {live.samples} samples, {live.waiting} more before the first "
                    "window")  # fmt: skip
        else:
            n = row.get("angle_random_walk")
            arw = "" if n is None else f", N {n:.4g} {units}*sqrt(s)"
            line = (f"monitor: {live.samples} samples, t {row['time']:.2f} s, window "
                    f"{row['window']}{arw}, {len(live.events)} events")  # fmt: skip
        print("\r" + line.ljust(79)[:79], end="", file=sys.stderr, flush=True)
        self.shown = True

    def close(self) -> None:
        if self.enabled and self.shown:
            print("\r" + " " * 79 + "\r", end="", file=sys.stderr, flush=True)
            self.shown = False


def _cmd_monitor(args: argparse.Namespace) -> int:
    from adavar.online import OnlineAdaptive
    from adavar.settings import ControllerSettings

    check_arguments(args)
    if not args.units.strip():
        raise UsageError("--units is empty: give the unit of the samples, e.g. deg/s")
    settings = ControllerSettings.from_options(
        argparse.Namespace(**{**vars(args), "segment": args.segment or 0})
    ).keywords()
    settings.pop("l")
    for name in ("lmax", "lmin"):  # not given: the paper's 600 and its proportions
        if getattr(args, name) is None:
            settings.pop(name)
    fit_options = {} if args.bandwidth is None else {"bandwidth": args.bandwidth}
    ici = ici_settings(args)
    if ici["ici_edf_samples"] is None:  # a stream has no whole record to measure it on
        ici["ici_edf_samples"] = ICI_EDF_SAMPLES
    live = OnlineAdaptive(
        rate=args.rate, method=args.method, **settings, l=args.segment, dependence=args.dependence,
        kurtosis_reference=args.kurtosis_reference, step=args.step, terms=args.terms,
        taus=args.taus, noise_type=args.noise_type,
        edge_edf=args.edge_edf, units=args.units.strip(), t0=args.t0,
        fit_options=fit_options, fit_batch=args.fit_batch, keep="recent", **ici,
    )  # fmt: skip
    text = args.input_format == "text"
    decode = _TextDecoder(args.column) if text else _BinaryDecoder(
        "<f4" if args.input_format == "f32" else "<f8"
    )  # fmt: skip
    units = args.units.strip()
    status = _Status()
    printed = 0  # events printed (confirmed, or final with --final)

    def emit() -> None:
        nonlocal printed
        ready = live.final_count if args.final else len(live.events)
        if printed < ready:
            status.close()
        while printed < ready:
            final = printed < live.final_count
            print(_event_line(live, printed, units, final), flush=True)
            printed += 1

    chunks = _open_source(args.source, args.idle_timeout, text)
    try:
        try:
            for data in chunks:
                if data:
                    samples = decode(data)
                    if samples.size:
                        live.push(samples)
                        emit()
                status(live, units)
            tail = decode(b"", final=True)
            if tail.size:
                live.push(tail)
        except KeyboardInterrupt:  # Ctrl-C ends the stream; the pass is finished below
            pass
        finally:
            close = getattr(chunks, "close", None)
            if close is not None:
                close()
        status.close()
        if live.samples < live.lmax:
            raise AdavarInputError(
                f"the stream ended after {live.samples} samples; the window needs at least "
                f"--lmax {live.lmax}"
            )
        live.finish()
        emit()
    finally:
        status.close()
    return EXIT_OK

"""``adavar monitor``: the adaptive window on a live stream, one JSON line per event.

The samples come from standard input (``-``), a file that is being appended to (followed
like ``tail -F``: through truncation, rotation and deletion) or UDP datagrams on a local
port (``udp://127.0.0.1:PORT``), as text (one number a line, or delimited columns with
``--column``) or little-endian binary floats (``--format f32`` / ``f64``); the readers are
in :mod:`adavar.cli.monitor_sources`. The samples go to :class:`adavar.OnlineAdaptive` as
they arrive; each event (a non-stationary stretch) is printed on stdout as soon as it is
confirmed. Whatever ends the stream (the end of the input, ``--idle-timeout`` seconds
without data, Ctrl-C, SIGTERM, a bad line or sample), the pass is finished with every sample
received before it (the record's right mirror) and the remaining events are printed; then
the command exits 0, or 2 for a bad line (its one-line error last).
"""

from __future__ import annotations

import argparse
import json
import math
import re
import signal
import sys
import threading
import time
from typing import Any

import numpy as np

from adavar.cli.monitor_sources import BOUNDARY, open_source
from adavar.cli.options import (
    EXIT_OK,
    UsageError,
    add_controller_arguments,
    add_dependence_argument,
    add_ici_arguments,
    add_kurtosis_reference_argument,
    check_arguments,
)
from adavar.cli.values import (
    finite_float,
    length_arg,
    parse_noise_type,
    parse_taus,
    parse_terms,
    positive_float,
    positive_int,
    sample_rate,
)
from adavar.core.errors import AdavarInputError
from adavar.core.settings import ICI_EDF_SAMPLES, STREAM_LMAX_SECONDS

__all__ = ["add_monitor_parser"]

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
        "appended to (followed like tail -F, through truncation, rotation and deletion, each "
        "noted on stderr) or udp://127.0.0.1:PORT (datagrams of text lines, or of binary "
        "floats with --format; datagrams lost or malformed are counted on the status line, "
        "on stderr at the end and in the JSON). Each non-stationary stretch is printed "
        "on stdout as one JSON object (start_s, end_s, and the noise coefficient N before, "
        "during and after it) as soon as its end is detected. At the end of the input, "
        "after --idle-timeout seconds without data, on Ctrl-C or SIGTERM (exit 0), or at a "
        "bad line or sample (exit 2, its error last), the pass is finished with the samples "
        "received before and the remaining events are printed. The defaults are those of "
        "'adavar adaptive' (Lmin and l from Lmax, thresholds for 0.1 false events per "
        "stationary hour; --lmax 180 s, a stream having no length to take a tenth of); the "
        "first window comes after the first 8192 samples or half Lmax. The windows and the "
        "change times "
        "are those of 'adavar adaptive' on the same record with the same --lmax (on a "
        "30-minute record, also without), the events with their N summaries those of "
        "'adavar adaptive --taus octave --noise-type 0 --terms N' (where its whole-record "
        "fit finds no filter roll-off to take out of every window). A status line goes to "
        "stderr when it is a terminal.",
    )
    cmd.add_argument("source", metavar="SOURCE",
                     help="- (standard input), a file path, or udp://HOST:PORT")  # fmt: skip
    cmd.add_argument("--rate", metavar="HZ", type=sample_rate("--rate"), required=True,
                     help="sample rate in Hz, 1e-12 .. 1e12 (required)")  # fmt: skip
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
    for _, _, action in cmd.options:
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
        "--summary", action="store_true",
        help="at the end, print one more JSON line: {\"summary\": {samples, events, ended_by "
        "(end of input, idle timeout, interrupt, SIGTERM or bad input), and the source's "
        "counts: datagrams, lost_datagrams, bad_datagrams and receive_buffer for UDP, "
        "file_truncated, file_replaced and file_deleted for a file}}",
    )  # fmt: skip
    cmd.add_argument(
        "--final", action="store_true",
        help="print each event once its 'after' summary is final (at the next event or the "
        "end) instead of when it is confirmed",
    )  # fmt: skip
    cmd.set_defaults(handler=_cmd_monitor)
    return cmd


# ---------------------------------------------------------------------------------------
# decoding: bytes -> samples. A bad line or sample stops the decoder: the samples before it
# are returned, ``error`` says what it was, and the command finishes the pass with them.

_NOT_FINITE = (
    "the pass needs finite samples: remove or interpolate missing ones (what 'adavar "
    "adaptive --nan interpolate' does offline)"
)


class _TextDecoder:
    """Complete lines -> numbers (one column); a header line before the first number skipped
    (at the start of the stream, and of each new file a followed file is replaced by)."""

    def __init__(self, column: int | None) -> None:
        self.column = column
        self.rest = b""
        self.line = 0
        self.started = False
        self.error: AdavarInputError | None = None

    def end_piece(self) -> tuple[np.ndarray, str]:
        """The last line of a file that ended (no newline needed); a header may follow."""
        values = self(b"", final=True)
        self.started = False
        self.line = 0
        return values, ""

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
                    if np.isfinite(values).all():
                        self.line += lines
                        return values
        values: list[float] = []
        for raw in block.splitlines():
            self.line += 1
            problem = self._line(raw, values)
            if problem:
                self.error = AdavarInputError(f"line {self.line}{problem}")
                self.rest = b""
                break
        return np.asarray(values, dtype=float)

    def _line(self, raw: bytes, values: list[float]) -> str:
        """Append the number of one line to ``values``; what is wrong with it, or ''
        (to follow "line N")."""
        text = raw.strip()
        if not text or text.startswith(b"#"):
            return ""
        fields = [f for f in _SPLIT.split(text) if f]
        if self.column is None and len(fields) > 1:
            return f" has {len(fields)} columns: choose one with --column N (0-based)"
        index = 0 if self.column is None else self.column
        if index >= len(fields):
            return f" has {len(fields)} columns, no column {index} (--column is 0-based)"
        try:
            value = float(fields[index])
        except ValueError:
            if not self.started:  # a header
                self.started = True
                return ""
            shown = fields[index].decode(errors="replace")[:40]
            return (
                f": {shown!r} is not a number (one sample a line, or --column N of delimited lines)"
            )
        if not math.isfinite(value):
            return f": {fields[index].decode(errors='replace')[:40]!r}: {_NOT_FINITE}"
        self.started = True
        values.append(value)
        return ""


def _datagram_check(column: int | None) -> Any:
    """What is wrong with one text datagram (whole lines of numbers), or None: UDP drops and
    counts a bad datagram as it does a binary one of a wrong size."""

    def check(data: bytes) -> str | None:
        decoder = _TextDecoder(column)
        decoder.started = True  # a datagram holds samples, not a header
        decoder(data, final=True)
        return None if decoder.error is None else str(decoder.error)

    return check


class _BinaryDecoder:
    def __init__(self, dtype: str) -> None:
        self.dtype = np.dtype(dtype)
        self.rest = b""
        self.samples = 0  # decoded so far
        self.error: AdavarInputError | None = None

    def end_piece(self) -> tuple[np.ndarray, str]:
        """A file that ended: a partial sample at its end is dropped, with a notice."""
        rest, self.rest = self.rest, b""
        if not rest:
            return np.empty(0), ""
        return np.empty(0), (
            f"dropped the last {len(rest)} bytes of the old file: not a whole "
            f"{self.dtype.itemsize}-byte sample"
        )

    def __call__(self, data: bytes, final: bool = False) -> np.ndarray:
        data = self.rest + data
        size = self.dtype.itemsize
        cut = len(data) // size * size
        self.rest = data[cut:]
        values = np.frombuffer(data[:cut], dtype=self.dtype).astype(np.float64)
        finite = np.isfinite(values)
        if not finite.all():
            first = int(np.argmin(finite))
            self.error = AdavarInputError(
                f"sample {self.samples + first} is {float(values[first])!r}: {_NOT_FINITE}"
            )
            values = values[:first]
        elif final and self.rest:
            self.error = AdavarInputError(
                f"the input ends with {len(self.rest)} bytes, not a whole {size}-byte sample"
            )
        self.samples += values.size
        return values


# ---------------------------------------------------------------------------------------
# the command


class _Stop:
    """SIGINT (Ctrl-C) and SIGTERM end the stream: they set ``reason``, which the loop reads
    between pushes (an exception in the middle of one would leave the pass half-updated). A
    second signal aborts (KeyboardInterrupt: exit 130), and so does one once the handlers are
    restored (the pass is being finished). A signal the process ignores stays ignored."""

    def __init__(self) -> None:
        self.reason: str | None = None
        self._saved: dict[int, Any] = {}

    def _handler(self, signum: int, _frame: Any) -> None:
        if self.reason is not None:
            raise KeyboardInterrupt
        self.reason = "SIGTERM" if signum == signal.SIGTERM else "interrupt"

    def __enter__(self) -> _Stop:
        if threading.current_thread() is threading.main_thread():
            for signum in (signal.SIGINT, signal.SIGTERM):
                try:
                    if signal.getsignal(signum) is not signal.SIG_IGN:
                        self._saved[signum] = signal.signal(signum, self._handler)
                except (OSError, ValueError):  # pragma: no cover - not settable here
                    continue
        return self

    def __exit__(self, *exc: object) -> None:
        for signum, handler in self._saved.items():
            signal.signal(signum, handler)
        self._saved.clear()


def _event_line(live: Any, index: int, units: str, final: bool, extra: dict) -> str:
    from adavar.core.terms import TERM_NAMES
    from adavar.core.units import term_unit

    obj = {"event": index, **live.events[index].as_dict(), "units": units, "final": final,
           # "units" is the samples'; the levels before/during/after are the terms'
           "coefficient_units": {t: term_unit(t, units) for t in TERM_NAMES}}  # fmt: skip
    return json.dumps({**obj, **extra})


class _Status:
    """One status line on stderr, only on a terminal, at most every STATUS_SECONDS; the
    source's notices as lines of their own, always."""

    def __init__(self) -> None:
        self.enabled = sys.stderr.isatty()
        self.last = 0.0
        self.shown = False

    def notify(self, source: Any) -> None:
        if source.notices:
            notices = source.notices[:]
            del source.notices[: len(notices)]
            self.close()
            for text in notices:
                print(f"adavar monitor: {text}", file=sys.stderr, flush=True)

    def __call__(self, live: Any, units: str, source: Any, force: bool = False) -> None:
        self.notify(source)
        now = time.monotonic()
        if not self.enabled or (not force and now - self.last < STATUS_SECONDS):
            return
        self.last = now
        row = live.latest
        if not row:
            line = (f"monitor: {live.samples} samples{source.status()}, {live.waiting} more "
                    "before the first window")  # fmt: skip
        else:
            n = row.get("angle_random_walk")
            arw = "" if n is None else f", N {n:.4g} {units}*sqrt(s)"
            line = (f"monitor: {live.samples} samples{source.status()}, t {row['time']:.2f} "
                    f"s, window {row['window']}{arw}, {len(live.events)} events")  # fmt: skip
        print("\r" + line.ljust(79)[:79], end="", file=sys.stderr, flush=True)
        self.shown = True

    def close(self) -> None:
        if self.enabled and self.shown:
            print("\r" + " " * 79 + "\r", end="", file=sys.stderr, flush=True)
            self.shown = False


def _cmd_monitor(args: argparse.Namespace) -> int:
    from adavar.core.request import MethodOptions
    from adavar.core.settings import ControllerSettings
    from adavar.dynamic.online import OnlineAdaptive

    check_arguments(args)
    if not args.units.strip():
        raise UsageError("--units is empty: give the unit of the samples, e.g. deg/s")
    fit_options = {} if args.bandwidth is None else {"bandwidth": args.bandwidth}
    # the controller's and the method's flags as the settings objects of a request (lmax,
    # lmin, l not given: a stream's proportions, adavar.core.settings.STREAM_LMAX_SECONDS)
    live = OnlineAdaptive(
        rate=args.rate, settings=ControllerSettings.from_options(args),
        method_options=MethodOptions.from_options(args), step=args.step, terms=args.terms,
        taus=args.taus, noise_type=args.noise_type, edge_edf=args.edge_edf,
        units=args.units.strip(), t0=args.t0, fit_options=fit_options,
        fit_batch=args.fit_batch, keep="recent",
    )  # fmt: skip
    text = args.input_format == "text"
    decode: Any = _TextDecoder(args.column) if text else _BinaryDecoder(
        "<f4" if args.input_format == "f32" else "<f8"
    )  # fmt: skip
    units = args.units.strip()
    status = _Status()
    printed = 0  # events printed (confirmed, or final with --final)
    source = open_source(args.source, args.idle_timeout, None if text else decode.dtype.itemsize,
                         _datagram_check(args.column) if text else None)  # fmt: skip

    def emit() -> None:
        nonlocal printed
        ready = live.final_count if args.final else len(live.events)
        if printed < ready:
            status.close()
        while printed < ready:
            final = printed < live.final_count
            line = _event_line(live, printed, units, final, source.event_fields())
            print(line, flush=True)
            printed += 1

    def push(samples: np.ndarray) -> None:
        if samples.size:
            live.push(samples)
            emit()

    # every way the stream ends finishes the pass with what came before it: the end of the
    # input, --idle-timeout, Ctrl-C, SIGTERM and a bad line or sample alike
    ended = None
    stop = _Stop()
    try:
        with stop:
            try:
                for data in source:
                    if data is BOUNDARY:  # a followed file was replaced or truncated
                        values, notice = decode.end_piece()
                        if notice:
                            source.notices.append(f"{args.source}: {notice}")
                        push(values)
                    elif data:
                        push(decode(data))
                    if decode.error is not None:
                        ended = "bad input"
                        break
                    status(live, units, source)
                    if stop.reason is not None:
                        ended = stop.reason
                        break
                else:
                    push(decode(b"", final=True))
                    ended = "bad input" if decode.error is not None else source.ended
            except KeyboardInterrupt:
                if stop.reason is not None:  # a second signal: abort (exit 130)
                    raise
                ended = "interrupt"  # no handler could be set (not the main thread)
            finally:
                source.close()
            if ended in ("interrupt", "SIGTERM"):  # what was received, not yet pushed
                push(decode(source.drain()))
                if decode.error is not None:
                    ended = "bad input"
        # the handlers are restored: a signal now aborts the finishing pass
        status.notify(source)
        status.close()
        if live.samples < live.lmax:
            if decode.error is not None:
                raise decode.error
            raise AdavarInputError(
                f"the stream ended after {live.samples} samples; the window needs at least "
                f"--lmax {live.lmax}"
            )
        live.finish()
        emit()
        if args.summary:
            obj = {"samples": live.samples, "events": len(live.events), "ended_by": ended}
            print(json.dumps({"summary": {**obj, **source.stats()}}), flush=True)
    finally:
        status.close()
        stats = source.stats()
        if "lost_datagrams" in stats:
            print(
                f"adavar monitor: {args.source}: {stats['datagrams']} datagrams, "
                f"{stats['lost_datagrams']} lost, {stats['bad_datagrams']} malformed "
                f"(receive buffer {stats['receive_buffer']} bytes)",
                file=sys.stderr, flush=True,
            )  # fmt: skip
    if decode.error is not None:
        raise decode.error
    return EXIT_OK

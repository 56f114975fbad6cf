"""The adaptive window's defaults on data nobody tuned them for (issue 39, item 7).

Records from ``tests/independent_noise.py`` (written without adavar's code):

* 30 minutes of white noise at 100 Hz whose level triples for 5 minutes in the middle
  (``changing("step", 1800, 100, seed)``: two real changes, at 750 s and 1050 s), and
  stationary white noise of the same length: the events of ``adaptive_davar(x, rate=100)``
  at the old library defaults (the paper's 600/400/100 samples and thresholds), at the old
  command-line defaults (a tenth of the record, hourly thresholds on the correlation of the
  first 2**20 samples) and at the new defaults (both: a tenth of the record, hourly
  thresholds, the correlation estimated in stages);
* stationary low-pass filtered noise at 200 Hz (a 4th-order Butterworth at 20 Hz), two
  hours, where the correlation matters: false events per hour with the staged estimate
  against the one made on the first 2**20 samples;
* the live pass with its defaults (:class:`adavar.OnlineAdaptive`) against the offline one:
  the same windows and events, and how soon a 200 Hz stream gives its first row and its
  first event (the old pass waited for 2**20 samples, 87 minutes).

Run: ``python benchmarks/bench_defaults.py [--seeds 100]``; prints its figures.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from _machine import describe

import adavar
from adavar.dynamic.events import find_events
from adavar.dynamic.thresholds import DEPENDENCE_SAMPLES, noise_dependence

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.independent_noise import changing, low_pass, white

OLD_LIBRARY = dict(lmax=600, lmin=400, l=100, thresholds="paper")
TOLERANCE_S = 30.0  # a detected change within this of a real one is that change


def head_dependence(x: np.ndarray) -> tuple[float, float]:
    """The old estimate: the correlation of the first 2**20 samples (rounded as before)."""
    c2, c4 = noise_dependence(x[:DEPENDENCE_SAMPLES])
    return round(c2, 3), round(c4, 3)


def events_of(x: np.ndarray, rate: float, **controller) -> tuple[list, float]:
    """The events (change times paired, adavar.dynamic.events.find_events) of the schedule, and
    half its Lmax in seconds."""
    sched = adavar.adaptive_schedule(x, rate=rate, **controller)
    lmax = int(sched.parameters["lmax"])
    time_s = sched.centre / rate
    events = find_events(sched.window, sched.centre, time_s, lmax, 1.0 / rate, {},
                         duration=x.size / rate)  # fmt: skip
    return events, lmax / 2 / rate


def score(
    found: tuple[list, float], truth: tuple[float, float] | None, duration: float
) -> tuple[int, int, int]:
    """(real changes found, false events, false events starting within half a window of
    either end of the record or beyond it, where the window reads the mirror): an event
    whose ends match the real changes is real; any other is false."""
    events, half = found
    real = false = ends = 0
    for e in events:
        start_ok = truth is not None and abs(e.start_s - truth[0]) <= TOLERANCE_S
        end = math.inf if e.end_s is None else e.end_s
        end_ok = truth is not None and abs(end - truth[1]) <= TOLERANCE_S
        real += start_ok + end_ok
        if not (start_ok or end_ok):
            false += 1
            ends += e.start_s <= half + 1e-9 or e.start_s >= duration - half
    return real, false, ends


def offline_table(seeds: int) -> None:
    rate, seconds = 100.0, 1800.0
    configs = {
        "old library defaults (600/400/100, paper thresholds)": lambda x: OLD_LIBRARY,
        "old CLI defaults (a tenth of the record, hourly, 2**20 head)": lambda x: dict(
            dependence=head_dependence(x)
        ),
        "new defaults (the same in the library and the CLI)": lambda x: {},
    }
    print("\n30 minutes at 100 Hz, white noise x3 from 750 to 1050 s (2 real changes),")
    print(f"and stationary white noise; {seeds} seeds each; a change within {TOLERANCE_S:g} s")
    print("| defaults | step records with both changes | false events on step records "
          "| false events, stationary | false events per hour (all) | of them within half a "
          "window of the ends | per hour elsewhere | time |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for name, options in configs.items():
        both = false_step = false_white = at_ends = 0
        start = time.perf_counter()
        for seed in range(seeds):
            x, change = changing("step", seconds, rate, seed)
            real, false, ends = score(events_of(x, rate, **options(x)), change.changes[0],
                                      seconds)  # fmt: skip
            both += real == 2
            false_step += false
            at_ends += ends
            w = white(x.size, 1e-3, rate, np.random.default_rng(10_000 + seed))
            _, false, ends = score(events_of(w, rate, **options(w)), None, seconds)
            false_white += false
            at_ends += ends
        hours = 2 * seeds * seconds / 3600
        total = false_step + false_white
        print(f"| {name} | {both}/{seeds} | {false_step} | {false_white} "
              f"| {total / hours:.3g} | {at_ends} | {(total - at_ends) / hours:.3g} | "
              f"{time.perf_counter() - start:.0f} s |")  # fmt: skip


def correlated_table(seeds: int) -> None:
    rate, seconds = 200.0, 7200.0
    n = int(rate * seconds)
    staged = given = 0
    early_staged = early_given = 0  # events starting in the first 2**20 samples
    cut = DEPENDENCE_SAMPLES / rate
    for seed in range(seeds):
        x = low_pass(white(n, 1e-3, rate, np.random.default_rng(20_000 + seed)), 20.0, rate)
        a, _ = events_of(x, rate)
        b, _ = events_of(x, rate, dependence=head_dependence(x))
        staged += len(a)
        given += len(b)
        early_staged += sum(e.start_s < cut for e in a)
        early_given += sum(e.start_s < cut for e in b)
    hours = seeds * seconds / 3600
    print(f"\nstationary low-pass noise (Butterworth 20 Hz) at 200 Hz, {seeds} x 2 h, the "
          f"default windows (Lmax 12 min): false events per hour")  # fmt: skip
    print("| correlation estimate | events | per hour | of them in the first 2**20 samples |")
    print("|---|---|---|---|")
    print(f"| staged (new) | {staged} | {staged / hours:.3g} | {early_staged} |")
    print(f"| first 2**20 samples (old) | {given} | {given / hours:.3g} | {early_given} |")


def live_table(seeds: int) -> None:
    rate, seconds = 100.0, 1800.0
    same = 0
    for seed in range(seeds):
        x, _ = changing("step", seconds, rate, seed)
        live = adavar.OnlineAdaptive(rate=rate, terms=None)
        for piece in np.array_split(x, 61):
            live.push(piece)
        live.finish()
        sched = adavar.adaptive_schedule(x, rate=rate)
        offline = find_events(sched.window, sched.centre, sched.centre / rate,
                              int(sched.parameters["lmax"]), 1 / rate, {},
                              duration=x.size / rate)  # fmt: skip
        same += bool(np.array_equal(live.window, sched.window)) and [
            (e.start_s, e.end_s) for e in live.events
        ] == [(e.start_s, e.end_s) for e in offline]
    print(f"\nlive defaults (Lmax {adavar.core.settings.STREAM_LMAX_SECONDS:g} s) against offline "
          f"defaults (a tenth of 30 min) on the step records: {same}/{seeds} with the same "
          "windows and events")  # fmt: skip

    # latency at 200 Hz: x3 noise from 240 to 600 s (longer than the 180 s window: a
    # shorter burst is one shrink episode, one change, whose stretch closes at the next),
    # pushed a second at a time
    rate = 200.0
    x = low_pass(white(int(900 * rate), 1e-3, rate, np.random.default_rng(7)), 40.0, rate)
    x[int(240 * rate) : int(600 * rate)] *= 3.0
    live = adavar.OnlineAdaptive(rate=rate)
    first_row = first_event = None
    per_push = []
    for k in range(900):
        start = time.perf_counter()
        live.push(x[int(k * rate) : int((k + 1) * rate)])
        per_push.append(time.perf_counter() - start)
        if first_row is None and live.window.size:
            first_row = k + 1
        if first_event is None and live.events:
            first_event = (k + 1, live.events[0])
    reported = "no event within 900 s"
    if first_event is not None:
        k, event = first_event
        end = "open" if event.end_s is None else f"{event.end_s:.1f}"
        reported = f"the first event after {k} s of data: {event.start_s:.1f} .. {end} s"
    print(f"\n200 Hz stream, default windows (Lmax {live.lmax} samples, latency "
          f"{live.latency / rate:g} s): first row after {first_row} s of data "
          f"(old: {DEPENDENCE_SAMPLES / rate / 60:.0f} min); x3 noise from 240 to 600 s: "
          f"{reported}; push of 1 s of data: median "
          f"{1e3 * float(np.median(per_push)):.2f} ms, "
          f"max {1e3 * max(per_push):.0f} ms")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--live-only", action="store_true", help="the live pass only")
    args = parser.parse_args()
    print(f"machine: {describe()}")
    if not args.live_only:
        offline_table(args.seeds)
        correlated_table(max(2, math.ceil(args.seeds / 10)))
    live_table(max(2, math.ceil(args.seeds / 10)))


if __name__ == "__main__":
    main()

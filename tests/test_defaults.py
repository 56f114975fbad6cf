"""One set of defaults (issue 39, item 7): ``adaptive_davar``, ``OnlineAdaptive``, ``adavar
adaptive`` and ``adavar monitor`` choose the same windows and thresholds, find the same
events, and a stream starts within minutes. Records from ``tests/independent_noise.py``."""

from __future__ import annotations

import io
import json
import sys

import numpy as np
import pytest

import adavar
from adavar.dynamic.events import change_times

from .cli_helpers import run
from .independent_noise import changing

#: 30 minutes at 100 Hz, white noise x3 from 750 to 1050 s (two real changes)
TRUTH = (750.0, 1050.0)


def test_the_library_defaults_follow_the_record():
    x, change = changing("step", 1800, 100.0, 0)
    assert change.changes == (TRUTH,)
    sched = adavar.adaptive_schedule(x, rate=100.0)
    p = sched.parameters
    assert (p["lmax"], p["lmin"], p["l"]) == (18_000, 12_000, 3000)  # a tenth of 30 min
    assert p["thresholds"] == "calibrated" and p["false_alarm_per_hour"] == 0.1
    found = change_times(sched.window, sched.centre, 18_000, 0.01)
    assert len(found) == 2 and np.allclose(found, TRUTH, atol=10.0)  # the two, no more
    # the paper's values one argument away: they flag white noise every few seconds
    paper = adavar.adaptive_schedule(x, rate=100.0, lmax=600, lmin=400, l=100,
                                     thresholds="paper")  # fmt: skip
    assert len(change_times(paper.window, paper.centre, 600, 0.01)) > 100
    # the surface's resolution as the command line's: a third of Lmax is 1200 taus, so
    # "log" (10 a decade), not "all"
    result = adavar.adaptive_davar(x[:36_000], rate=100.0, confidence=None)
    logs = adavar.adaptive_davar(x[:36_000], rate=100.0, confidence=None, taus="log", step=1)
    assert result.step == 1 and np.array_equal(result.tau, logs.tau)


@pytest.fixture(scope="module")
def ten_hz(tmp_path_factory):
    """30 minutes at 10 Hz with a x3 step, as a file, and ``adavar adaptive``'s JSON."""
    x, _ = changing("step", 1800, 10.0, 3)
    path = tmp_path_factory.mktemp("rec") / "x.npy"
    np.save(path, x)
    return x, path


def test_events_are_the_command_lines(capsys, ten_hz):
    x, path = ten_hz
    code, out, err = run(capsys, ["adaptive", str(path), "--rate", "10", "--units", "deg/s",
                                  "--json"])  # fmt: skip
    assert code == 0, err
    cli = json.loads(out)
    result = adavar.adaptive_davar(x, rate=10.0)
    assert result.parameters == cli["parameters"]["controller"]
    events = result.events
    assert [(e.start_s, e.end_s) for e in events] == [
        (e["start_s"], e["end_s"]) for e in cli["events"]
    ]
    # the stretch of x3 noise (the false-event rate is measured by bench_defaults.py)
    assert np.allclose([events[0].start_s, events[0].end_s], TRUTH, atol=30.0)
    for got, want in zip(events, cli["events"], strict=True):
        for part in ("before", "during", "after"):
            for term, summary in want[part].items():
                mine = getattr(got, part)[term]
                assert mine["windows"] == summary["windows"]
                if not summary["windows"]:
                    assert mine == summary
                    continue
                for key in ("median", "low", "high"):  # None where no window qualifies
                    assert mine[key] == pytest.approx(summary[key], rel=1e-9, abs=1e-300)
    assert result.events == events  # computed once
    # any fit's summaries; without bounds nothing to fit: the change times alone
    fit = adavar.fit_noise(result, terms=("angle_random_walk",), cells=False)
    alone = result.events_with(fit)
    assert [(e.start_s, e.end_s) for e in alone] == [(e.start_s, e.end_s) for e in events]
    assert list(alone[0].during) == ["angle_random_walk"]
    bare = adavar.adaptive_davar(x, rate=10.0, confidence=None, taus="octave").events
    assert [(e.start_s, e.end_s) for e in bare] == [(e.start_s, e.end_s) for e in events]
    assert bare[0].during == {}


def test_the_monitor_finds_the_offline_events(capsys, monkeypatch, ten_hz):
    """No window flags: the stream's 180 s is the offline tenth of 30 minutes."""
    x, _ = ten_hz
    live = adavar.OnlineAdaptive(rate=10.0, terms=None)
    for piece in np.array_split(x, 23):
        live.push(piece)
    live.finish()
    offline = adavar.adaptive_davar(x, rate=10.0)
    assert np.array_equal(live.window, offline.window)
    assert live.parameters["dependence_stages"] == offline.parameters["dependence_stages"]
    text = "".join(f"{v!r}\n" for v in x.tolist())
    monkeypatch.setattr(sys, "stdin", io.StringIO(text))
    code, out, err = run(capsys, ["monitor", "-", "--rate", "10", "--units", "deg/s"])
    assert code == 0, err
    printed = [json.loads(line) for line in out.splitlines()]
    assert [(e["start_s"], e["end_s"]) for e in printed] == [
        (e.start_s, e.end_s) for e in offline.events
    ]


def test_a_stream_starts_within_minutes():
    """200 Hz: the first row after 90 s (half the 180 s window), not 2**20 samples (87 min)."""
    live = adavar.OnlineAdaptive(rate=200.0, terms=None)
    assert (live.lmax, live.lmin, live.segment) == (36_000, 24_000, 6000)
    assert live.waiting == 18_001
    x = np.random.default_rng(1).standard_normal(18_001)
    live.push(x[:-1])
    assert live.window.size == 0
    live.push(x[-1:])
    assert live.window.size == 1 and live.parameters["dependence_stages"][0][:2] == [0, 18_001]

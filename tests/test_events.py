"""Non-stationary stretches read off the adaptive window (adavar.dynamic.events)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from adavar import simulate
from adavar.dynamic.adaptive import adaptive_davar, oracle_schedule
from adavar.dynamic.events import change_times, find_events

from .cli_helpers import run


def test_change_times_are_the_leading_edge_before_each_shrink():
    # centres every 10 samples; Lmax 100 until centre 300, shrink, regrow, again from 700
    centre = np.arange(0, 1000, 10)
    window = np.full(centre.size, 100)
    window[31:40] = 80
    window[71:75] = 90
    assert change_times(window, centre, 100, 0.5, t0=2.0) == [
        2.0 + (300 + 50) * 0.5,
        2.0 + (700 + 50) * 0.5,
    ]
    assert change_times(np.full(5, 100), np.arange(5), 100, 1.0) == []


def test_find_events_pairs_changes_and_summarises_each_side():
    # the ideal windows (the oracle's) for changes at 24.9 s and 64.9 s, every 10th centre:
    # the leading edge pinned on the change while the window shrinks, the trailing edge
    # while it regrows
    centre = np.arange(0, 10_000, 10)
    time = centre * 0.01
    window = oracle_schedule(10_000, [2490, 6490], lmax=1000, lmin=700)[centre]
    n = np.where((time > 24.9) & (time < 64.9), 3.0, 1.0)
    (event,) = find_events(window, centre, time, 1000, 0.01, {"angle_random_walk": n},
                           duration=100.0)  # fmt: skip
    # up: the lead (the leading edge before the shrink); down: the trail (the trailing
    # edge where the regrowth starts), to a row (0.1 s)
    assert event.start_s == pytest.approx(24.9) and event.end_s == pytest.approx(64.9, abs=0.1)
    assert event.before["angle_random_walk"]["median"] == 1.0
    assert event.during["angle_random_walk"]["median"] == 3.0
    assert event.after["angle_random_walk"]["median"] == 1.0
    # the windows within Lmax/2 = 5 s of a change are in no side
    inside = (time > event.start_s + 5) & (time < event.end_s - 5)
    assert event.during["angle_random_walk"]["windows"] == np.sum(inside)
    # a change with no return opens a stretch to the end of the record
    window = oracle_schedule(10_000, [2490], lmax=1000, lmin=700)[centre]
    (open_end,) = find_events(window, centre, time, 1000, 0.01, {"angle_random_walk": n},
                              duration=100.0)  # fmt: skip
    assert open_end.end_s is None and open_end.after["angle_random_walk"]["windows"] == 0


def test_cli_adaptive_reports_the_disturbance(capsys, tmp_path):
    rate = 100.0
    kw = dict(rate=rate, angle_random_walk=0.005, bias_instability=0.002, bandwidth=20.0,
              lsb=1 / 131)  # fmt: skip
    x = simulate.sensor(120_000, seed=1, **kw)
    loud = simulate.sensor(120_000, seed=2, **{**kw, "angle_random_walk": 0.015})
    x[40_000:80_000] = loud[40_000:80_000]  # x3 from 400 s to 800 s
    path = tmp_path / "gyro.npy"
    np.save(path, x)
    code, out, err = run(capsys, ["adaptive", str(path), "--rate", "100", "--units", "deg/s",
                                  "--taus", "octave", "--json"])  # fmt: skip
    assert code == 0, err
    payload = json.loads(out)
    (event,) = payload["events"]
    half_lmin = payload["parameters"]["controller"]["lmin"] / rate / 2
    assert abs(event["start_s"] - 400.0) <= half_lmin
    assert abs(event["end_s"] - 800.0) <= half_lmin
    n = {k: event[k]["angle_random_walk"]["median"] for k in ("before", "during", "after")}
    assert n["during"] == pytest.approx(3 * n["before"], rel=0.1)
    assert n["after"] == pytest.approx(n["before"], rel=0.05)
    code, out, err = run(capsys, ["adaptive", str(path), "--rate", "100", "--units", "deg/s",
                                  "--taus", "octave"])  # fmt: skip
    assert code == 0, err
    assert "Events (non-stationary stretches" in out


def _events_by_masks(window, centre, time, lmax, tau0, coefficients, t0, duration):
    """find_events as it was written first: boolean masks over every window."""
    from adavar.dynamic.events import stretch_summary

    time = np.asarray(time, dtype=float)
    changes = []
    for c in change_times(window, centre, lmax, tau0, t0):
        if not changes or c - changes[-1] > 0.25 * lmax * tau0:
            changes.append(c)
    margin = 0.5 * lmax * tau0
    out = []
    for k in range(0, len(changes), 2):
        start = changes[k]
        end = changes[k + 1] if k + 1 < len(changes) else None
        previous = changes[k - 1] if k > 0 else -np.inf
        following = changes[k + 2] if k + 2 < len(changes) else np.inf
        stop = end if end is not None else duration
        sides = [(time > previous + margin) & (time < start - margin),
                 (time > start + margin) & (time < stop - margin),
                 (time > stop + margin) & (time < following - margin)]  # fmt: skip
        if end is None:
            sides[2] = np.zeros(time.size, dtype=bool)
        out.append([{n: stretch_summary(np.asarray(v, dtype=float)[m])
                     for n, v in coefficients.items()} for m in sides])  # fmt: skip
    return out


class _Slices:
    """An object that gives its values by slices only (as a spilled block fit's terms)."""

    def __init__(self, values):
        self.values = np.asarray(values)

    def __len__(self):
        return self.values.size

    def __getitem__(self, rows):
        assert isinstance(rows, slice)
        return self.values[rows].copy()


@pytest.mark.parametrize("seed", range(12))
def test_find_events_reads_ranges_as_the_masks_did(seed):
    """Stretches read as ranges of windows (and from slice-only readers) give the events
    the boolean masks gave; windows out of time order fall back to the masks."""
    rng = np.random.default_rng(seed)
    # tau0 a power of two: the stretches' bounds fall exactly on window times, where the
    # strict inequalities of the masks decide
    n, lmax, tau0 = 3000, 60, 0.25
    window = np.full(n, lmax)
    for a in rng.integers(0, n - 40, rng.integers(1, 6)):
        window[a : a + rng.integers(2, 40)] = rng.integers(10, lmax)
    centre = np.arange(n) * int(rng.integers(1, 3))
    time = 5.0 + centre * tau0
    values = {"angle_random_walk": rng.lognormal(size=n), "bias_instability": rng.normal(size=n)}
    values["bias_instability"][rng.random(n) < 0.05] = np.nan
    duration = float(time[-1] + 1.0)
    want = _events_by_masks(window, centre, time, lmax, tau0, values, 5.0, duration)
    assert want  # every record has a change
    for given in (values, {k: _Slices(v) for k, v in values.items()}):
        got = find_events(window, centre, time, lmax, tau0, given, t0=5.0, duration=duration,
                          pairing="parity")  # fmt: skip
        assert [[e.before, e.during, e.after] for e in got] == want
    shuffled = rng.permutation(n)  # not in time order: every window is looked at
    got = find_events(window, centre, time[shuffled], lmax, tau0,
                      {k: v[shuffled] for k, v in values.items()}, t0=5.0,
                      duration=duration, pairing="parity")  # fmt: skip
    want = _events_by_masks(window, centre, time[shuffled], lmax, tau0,
                            {k: v[shuffled] for k, v in values.items()}, 5.0, duration)  # fmt: skip
    assert [[e.before, e.during, e.after] for e in got] == want


def test_no_event_time_lies_outside_the_record():
    # every 10th centre of 10 000 samples at 0.01 s, Lmax 1000: the windows of the last
    # half-window shrink (their leading edges in the mirrored extension, 100.0-104.9 s), and
    # those at the very start are short and regrow with the trailing edge before t0
    t0 = 5.0
    centre = np.arange(0, 10_000, 10)
    time = t0 + centre * 0.01
    window = np.full(centre.size, 1000)
    window[980:] = 1000 - 2 * np.arange(1, 21)  # shrinking to the end
    window[:30] = np.minimum(700 + 20 * np.arange(30), 1000)  # short at the start, regrowing
    n = np.ones(centre.size)
    duration = t0 + 100.0
    events = find_events(window, centre, time, 1000, 0.01, {"angle_random_walk": n}, t0=t0,
                         duration=duration)  # fmt: skip
    assert len(events) == 1
    for event in events:
        for when in (event.start_s, event.end_s):
            assert when is None or t0 <= when <= duration, (event.start_s, event.end_s)
    # the lead in the extension (107.9 s before 0.3, then put at the record's end) is no
    # event: no sample there is new
    assert events[0].start_s < duration


def test_a_white_record_gives_no_event_after_its_end():
    # white noise whose last windows shrink on the mirrored extension (found by an
    # independent audit: an event at 1887.8 s in a record that ends at 1800 s)
    x = np.random.default_rng(404).standard_normal(180_000)
    result = adaptive_davar(x, rate=100.0, units="deg/s", taus=[1, 100], step=50)
    for event in result.events:
        for when in (event.start_s, event.end_s):
            assert when is None or 0.0 <= when <= 1800.0, (event.start_s, event.end_s)


def test_the_live_tracker_drops_a_lead_past_the_end():
    from adavar.dynamic.events import EventTracker

    tracker = EventTracker(100, 0.1, lambda low, high, names=None: {}, level=None, t0=0.0)
    tracker.start(60.0)  # a lead in the extension of a record that ends at 50 s
    assert tracker.advance(np.inf, final=True, end_of_record=50.0) == []
    # a lead inside the record and a trail past its end: the trail is put at the end
    tracker = EventTracker(100, 0.1, lambda low, high, names=None: {}, level=None, t0=0.0)
    tracker.start(40.0)
    tracker.end(55.0)
    (event,) = tracker.advance(np.inf, final=True, end_of_record=50.0)
    assert event.start_s == 40.0 and event.end_s == 50.0

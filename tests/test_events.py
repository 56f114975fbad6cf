"""Non-stationary stretches read off the adaptive window (adavar.events)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from adavar import simulate
from adavar.events import change_times, find_events

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
    centre = np.arange(0, 10_000, 10)
    time = centre * 0.01
    window = np.full(centre.size, 1000)
    window[200:260] = 700  # the change at (1990 + 500) * 0.01 = 24.9 s
    window[600:660] = 700  # the change at 64.9 s
    n = np.where((time > 24.9) & (time < 64.9), 3.0, 1.0)
    (event,) = find_events(window, centre, time, 1000, 0.01, {"angle_random_walk": n},
                           duration=100.0)  # fmt: skip
    assert (event.start_s, event.end_s) == pytest.approx((24.9, 64.9))
    assert event.before["angle_random_walk"]["median"] == 1.0
    assert event.during["angle_random_walk"]["median"] == 3.0
    assert event.after["angle_random_walk"]["median"] == 1.0
    # the windows within Lmax/2 = 5 s of a change are in no side
    assert event.during["angle_random_walk"]["windows"] == np.sum((time > 29.9) & (time < 59.9))
    # an unpaired change opens a stretch to the end of the record
    window[600:660] = 1000
    (open_end,) = find_events(window, centre, time, 1000, 0.01, {"x": n}, duration=100.0)
    assert open_end.end_s is None and open_end.after["x"]["windows"] == 0


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

"""The ICI's steps and ramps paired into events by level (adavar.dynamic.ici_events).

An audit with its own generator found, at 100 Hz over 1 h: after a ramp up, the step back
down reported as a stretch at the level before the ramp lasting to the end of the record
(13 of 13 runs: the ramps stayed out of the pairing); a staircase down (x2, then x1.5 five
minutes later, then x1) taken for one step without end plus a ramp (6 of 6: the ramp test
compared the ramp with one step, not with the staircase the segmentation had found); and
the live pass (``adavar monitor --method ici``) reporting neither the ramp nor the stretch.

Own generator here (NumPy only): white noise whose amplitude follows a piecewise-linear
profile. Each shape below failed on the code before.
"""

from __future__ import annotations

import numpy as np
import pytest

import adavar
from adavar.dynamic import ici_episodes as ep
from adavar.dynamic.ici_events import IciEventTracker, ici_events
from adavar.dynamic.online import OnlineAdaptive

RATE, SECONDS, N = 100.0, 1800.0, 5e-3


def profiled(knots: list[tuple[float, float]], seed: int) -> np.ndarray:
    """White rate noise whose amplitude is ``numpy.interp`` through ``(t, factor)``."""
    rng = np.random.default_rng(seed)
    t = np.arange(round(SECONDS * RATE)) / RATE
    times, factors = zip(*knots, strict=True)
    return N * np.sqrt(RATE) * rng.standard_normal(t.size) * np.interp(t, times, factors)


STEP = 1e-3  # a step in a profile: the amplitude changes within one sample
SHAPES = {
    # ramp x1 -> x2 over 500-700 s, held, a step back at 1200 s
    "ramp-hold-step": ([(0, 1), (500, 1), (700, 2), (1200, 2), (1200 + STEP, 1), (1800, 1)],
                       (500, 1200, True)),
    # x2 at 600 s, x1.5 at 900 s, x1 at 1200 s: three steps, one event
    "stairs-down": ([(0, 1), (600, 1), (600 + STEP, 2), (900, 2), (900 + STEP, 1.5),
                     (1200, 1.5), (1200 + STEP, 1), (1800, 1)], (600, 1200, False)),
    # a step up at 500 s, a ramp back down over 900-1200 s
    "step-ramp-down": ([(0, 1), (500, 1), (500 + STEP, 2.5), (900, 2.5), (1200, 1), (1800, 1)],
                       (500, 1200, True)),
}  # fmt: skip


@pytest.mark.parametrize("shape", SHAPES)
def test_a_compound_disturbance_is_one_event(shape):
    knots, (start, end, ramp) = SHAPES[shape]
    x = profiled(knots, seed=1)
    result = adavar.adaptive_davar(x, rate=RATE, units="deg/s", method="ici", step=100,
                                   ici_long_tau=False)  # fmt: skip
    (event,) = result.events
    assert event.ramp is ramp
    assert abs(event.start_s - start) < 5 and event.end_s is not None
    assert abs(event.end_s - end) < 5
    fitted = adavar.fit_noise(result, terms=("angle_random_walk",))
    (event,) = result.events_with(fitted)
    level = {k: getattr(event, k)["angle_random_walk"]["median"]
             for k in ("before", "during", "after")}  # fmt: skip
    assert level["during"] > 1.3 * level["before"]  # the disturbed level, not the base
    assert level["after"] == pytest.approx(level["before"], rel=0.05)


def test_live_equals_offline_after_a_ramp():
    """The live pass pairs the steps and ramps as the offline one (before: the ramp was
    missing and the step was an event of zero length)."""
    x = profiled(SHAPES["ramp-hold-step"][0], seed=2)
    options = dict(method="ici", step=100, units="deg/s", ici_edf_samples=65536)
    result = adavar.adaptive_davar(x, rate=RATE, taus="octave", noise_type=0,
                                   ici_long_tau=False, **options)  # fmt: skip
    lmax = int(result.parameters["lmax"])
    live = OnlineAdaptive(rate=RATE, lmax=lmax, lmin=int(result.parameters["lmin"]), **options)
    for i in range(0, x.size, 7001):
        live.push(x[i : i + 7001])
    live.finish()
    arw = adavar.fit_noise(result, terms=("angle_random_walk",), reference=None)
    offline = ici_events(result.window, result.centre, result.time, lmax, 1 / RATE,
                         {"angle_random_walk": arw.angle_random_walk.value}, t0=0.0,
                         duration=x.size / RATE, parameters=result.parameters)  # fmt: skip
    assert [e.as_dict() for e in live.events] == [e.as_dict() for e in offline]
    assert len(offline) == 1 and offline[0].ramp and live.final_count == 1


def test_two_steps_one_way_are_not_a_ramp():
    """The segmentation's staircase against the best ramp: two steps 5 min apart stay two
    steps, a ramp stays a ramp (the region of a 3-min Lmax)."""
    kw = dict(dispersion=3.0, clipped=3.0, gamma=3.0)
    stairs = profiled(SHAPES["stairs-down"][0], seed=3)[48_000:132_000]
    found = ep.find_episodes(stairs, 48_000, **kw)
    assert [(e.ramp, e.rise) for e in found] == [(False, True), (False, False), (False, False)]
    starts = [e.start for e in found]
    assert np.all(np.abs(np.subtract(starts, (60_000, 90_000, 120_000))) <= 300), starts
    ramp = profiled([(0, 1), (700, 1), (1000, 2), (1800, 2)], seed=3)[48_000:132_000]
    (found,) = ep.find_episodes(ramp, 48_000, **kw)
    assert found.ramp and found.rise


# ---------------------------------------------------------------------------------------
# the pairing rule on its own: summaries that give the bounds they were asked for


def _tracker() -> IciEventTracker:
    return IciEventTracker(200, 0.1, lambda low, high, names=None: {"n": (low, high)})  # margin 10


def _fed(changes, end=1000.0) -> list:
    tracker = _tracker()
    for start, stop, ramp, before, after in changes:
        tracker.add(start, stop, ramp=ramp, rise=after > before, before=before, after=after)
    tracker.advance(final=True, end_of_record=end)
    return tracker.events


def test_pairing_by_level():
    # a staircase down closes where the level is back (x4 variance, x2.25, x1)
    (e,) = _fed([(100, 100, False, 1, 4), (300, 300, False, 4, 2.25), (500, 500, False, 2.25, 1)])
    assert (e.start_s, e.end_s, e.ramp) == (100, 500, False)
    assert e.during["n"] == (110, 490) and e.after["n"][0] == 510
    # a ramp up, a step down: one event from the ramp's first sample, during after the ramp
    (e,) = _fed([(100, 200, True, 1, 4), (600, 600, False, 4, 1)])
    assert (e.start_s, e.end_s, e.ramp) == (100, 600, True)
    assert e.during["n"] == (210, 590) and e.before["n"] == (-np.inf, 90)
    # a ramp up and straight back down: the windows centred on the event
    (e,) = _fed([(100, 200, True, 1, 4), (205, 300, True, 4, 1)])
    assert (e.start_s, e.end_s, e.ramp) == (100, 300, True) and e.during["n"] == (100, 300)
    # a ramp nothing closes: an event of its own, the level after it to the end
    (e,) = _fed([(100, 200, True, 1, 4)])
    assert (e.start_s, e.end_s) == (100, 200) and e.after["n"] == (210, np.inf)
    # a step nothing closes, and one that overshoots the base far: a stretch to the end
    for changes in (
        [(100, 100, False, 1, 4)],
        [(100, 100, False, 1, 4), (400, 400, False, 4, 0.2)],
    ):
        (e,) = _fed(changes)
        assert (e.start_s, e.end_s) == (100, None) and e.during["n"] == (110, 990)


def test_two_stretches_and_final_summaries():
    """The second stretch's ``before`` starts after the first's end; an ``after`` waits for
    the next change (``final_count``)."""
    tracker = _tracker()
    tracker.add(100, 100, ramp=False, rise=True, before=1, after=9)
    tracker.add(300, 300, ramp=False, rise=False, before=9, after=1)
    (first,) = tracker.advance()
    assert tracker.final_count == 0 and first.after["n"] == (np.inf, -np.inf)
    tracker.add(600, 600, ramp=False, rise=True, before=1, after=9)
    assert tracker.final_count == 1 and tracker.events[0].after["n"] == (310, 590)
    tracker.add(700, 700, ramp=False, rise=False, before=9, after=1)
    tracker.advance(final=True, end_of_record=1000)
    second = tracker.events[1]
    assert second.before["n"] == (310, 590) and second.after["n"] == (710, np.inf)
    assert tracker.final_count == 2

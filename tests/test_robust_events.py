"""Events on data nobody tuned for (issue 39, items 8 and 9).

Item 8: an outlier is an event of its own and never flips the pairing of the changes
after it (adavar.dynamic.events pairs episodes by the noise level on each side). Item 9: the
kurtosis tests compare each window with the record's own stationary noise
(adavar.dynamic.kurtosis_reference), so non-Gaussian stationary noise gives no false events while
steps and bursts are still found. The long version: benchmarks/bench_events_robust.py.
"""

from __future__ import annotations

import numpy as np
import pytest

import adavar
from adavar.core.errors import AdavarInputError
from adavar.dynamic.events import EventTracker, find_events
from adavar.dynamic.kurtosis_reference import KurtosisReference, record_reference
from adavar.dynamic.thresholds import thresholds_for

from . import independent_noise as ind

LMAX, LMIN = 600, 400


def events(x: np.ndarray, rate: float = 1.0, pairing: str = "level", **options) -> list:
    """The events of ``adaptive_davar``, with each window's N read off its shortest-tau
    Allan variance (white noise: ``N^2 = tau avar(tau)``; no fit, fast)."""
    result = adavar.adaptive_davar(x, rate=rate, lmax=LMAX, taus="octave", noise_type=0,
                                   **options)  # fmt: skip
    n = {"angle_random_walk": np.sqrt(result.avar[:, 0] * result.tau[0])}
    return find_events(result.window, result.centre, result.time, LMAX, 1 / rate, n,
                       duration=x.size / rate, pairing=pairing)  # fmt: skip


def spike_before_stretch(seed: int) -> np.ndarray:
    """Item 8: 10 000 s at 1 Hz, a 40 sd spike at 2000 s, x3 from 6000 to 7500 s."""
    x = ind.white(10_000, 1.0, 1.0, np.random.default_rng(seed))
    x[6000:7500] *= 3.0
    x[2000] += 40.0
    return x


# ---------------------------------------------------------------------------------------
# item 8: episodes paired by level


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_spike_is_a_short_event_of_its_own_and_flips_nothing(seed):
    found = events(spike_before_stretch(seed))
    spike = [e for e in found if e.start_s <= 2000 + LMIN / 2 and (e.end_s or 1e9) >= 1800]
    stretch = [e for e in found if e.end_s is not None and abs(e.start_s - 6000) <= LMIN / 2
               and abs(e.end_s - 7500) <= LMIN / 2]  # fmt: skip
    assert len(stretch) == 1, [(e.start_s, e.end_s) for e in found]
    assert len(spike) <= 1 and all(e.end_s - e.start_s <= LMIN for e in spike)
    n = {part: getattr(stretch[0], part)["angle_random_walk"]["median"]
         for part in ("before", "during", "after")}  # fmt: skip
    assert n["during"] == pytest.approx(3 * n["before"], rel=0.15)
    assert n["after"] == pytest.approx(n["before"], rel=0.1)


def test_the_parity_pairing_of_before_stays_reachable():
    """pairing="parity": consecutive changes paired, which the spike inverts (the old rule)."""
    old = events(spike_before_stretch(1), pairing="parity")
    assert old[0].start_s == pytest.approx(2000, abs=5)
    assert old[0].end_s == pytest.approx(6000, abs=LMIN / 2)  # the spike paired with the step
    with pytest.raises(AdavarInputError, match="pairing"):
        find_events(np.full(5, LMAX), np.arange(5), np.arange(5.0), LMAX, 1.0, {}, pairing="odd")


@pytest.mark.parametrize("seed", [3, 4])
def test_a_burst_is_one_event_and_a_change_with_no_return_lasts_to_the_end(seed):
    rng = np.random.default_rng(seed)
    x = ind.white(12_000, 1.0, 1.0, rng)
    x[3000:3020] *= 5.0  # a 20 s burst
    x[8000:] *= 3.0  # louder to the end
    found = events(x)
    burst = [e for e in found if e.end_s is not None and abs(e.start_s - 3000) <= LMIN / 2
             and abs(e.end_s - 3020) <= LMIN / 2]  # fmt: skip
    last = [e for e in found if e.end_s is None]
    assert len(burst) == 1 and len(last) == 1
    assert abs(last[0].start_s - 8000) <= LMIN / 2


def _tracker(levels: list[tuple[float, float]]):
    """An EventTracker over windows every second whose N is ``level`` from each
    ``(time, level)`` on (margin 5 s: Lmax 10 samples at 1 s)."""
    times = np.arange(0.0, 400.0)
    n = np.ones(times.size)
    for t, value in levels:
        n[times >= t] = value

    def summaries(low, high, names=None):
        from adavar.dynamic.events import stretch_summary

        inside = (times > low) & (times < high)
        return {"angle_random_walk": stretch_summary(n[inside])}

    return EventTracker(10, 1.0, summaries)


def test_steps_inside_a_stretch_belong_to_it():
    # up, up, a spike, down, down: one stretch from the first step to the last
    tracker = _tracker([(50, 3.0), (100, 9.0), (200, 3.0), (250, 1.0)])
    for lead, trail in [(50, 49), (100, 99), (150, 151), (205, 200), (255, 250)]:
        tracker.start(lead)
        tracker.end(trail)
    tracker.advance(np.inf, final=True, end_of_record=400.0)
    assert [(e.start_s, e.end_s) for e in tracker.events] == [(50, 250)]
    # 1 -> 3 -> 2: the level never comes back, the stretch lasts to the end
    tracker = _tracker([(50, 3.0), (200, 2.0)])
    for lead, trail in [(50, 49), (205, 200)]:
        tracker.start(lead)
        tracker.end(trail)
    tracker.advance(np.inf, final=True, end_of_record=400.0)
    assert [(e.start_s, e.end_s) for e in tracker.events] == [(50, None)]


def test_episodes_are_events_of_their_own_without_a_level():
    tracker = EventTracker(10, 1.0, lambda low, high, names=None: {}, level=None)
    tracker.start(50)
    tracker.end(52)
    # decided once the windows up to 5 s + 2 Lmax = 25 s after it are in (none could join it)
    assert tracker.advance(75.0) == []
    assert [(e.start_s, e.end_s) for e in tracker.advance(80.0)] == [(50, 52)]
    assert tracker.final_count == 0  # its "after" waits for the next episode
    tracker.start(205)
    tracker.end(210)
    tracker.advance(np.inf, final=True, end_of_record=400.0)
    assert [(e.start_s, e.end_s) for e in tracker.events] == [(50, 52), (205, 210)]
    assert tracker.final_count == 2


def test_a_run_whose_trail_leaves_no_window_before_it_joins_the_one_before():
    """A run seen late (its lead far on) whose trail comes back to within Lmax of the run
    before leaves no whole window between them: one episode with it (a 10 s disturbance
    seen as two runs is one event, not two)."""
    tracker = _tracker([(50, 3.0), (60, 1.0)])
    tracker.start(50)
    tracker.end(48)
    tracker.start(70)  # more than Lmax after the first's lead: a run of its own so far
    tracker.end(55)  # ... but its trail is within Lmax of the first: one episode
    tracker.advance(np.inf, final=True, end_of_record=400.0)
    assert [(e.start_s, e.end_s) for e in tracker.events] == [(50, 55)]


def test_live_events_are_those_of_find_events_on_the_same_windows():
    x = spike_before_stretch(2)
    live = adavar.OnlineAdaptive(rate=1.0, lmax=LMAX)
    for piece in np.array_split(x, 23):
        live.push(piece)
    live.finish()
    offline = find_events(live.window, live.centre, live.time, LMAX, 1.0, live.coefficients,
                          duration=x.size)  # fmt: skip
    assert [e.as_dict() for e in live.events] == [e.as_dict() for e in offline]
    assert live.final_count == len(live.events) >= 2


# ---------------------------------------------------------------------------------------
# item 9: the record's own kurtosis


def test_the_reference_leaves_gaussian_noise_as_it_is():
    rng = np.random.default_rng(5)
    for x in (rng.standard_normal(1 << 16), ind.quantise(rng.standard_normal(1 << 16), 0.5)):
        ref = record_reference(x, lmin=LMIN)
        assert ref.identity and ref.offset == 0.0
        assert ref.apply(x) is x


@pytest.mark.parametrize(
    ("shape", "low", "high"),
    [
        ("student5", 0.6, 1.0),
        ("laplace", 1.0, 1.5),
        ("uniform", -0.75, -0.75),
        ("platykurtic", -0.3, -0.05),
    ],
)
def test_the_reference_makes_stationary_noise_gaussian(shape, low, high):
    x = ind.white_shaped(1 << 17, 1.0, 1.0, np.random.default_rng(6), shape)
    ref = record_reference(x, lmin=LMIN)
    assert low <= ref.theta <= high
    y = ref.apply(x)
    rows = y[: y.size // LMIN * LMIN].reshape(-1, LMIN)
    d = rows - rows.mean(axis=1, keepdims=True)
    median = np.median((d**4).mean(axis=1) / (d**2).mean(axis=1) ** 2)
    # the median window kurtosis of the transformed record is the Gaussian one (2.98 at
    # 400 samples), up to the residual offset the band is moved by
    assert median - ref.offset == pytest.approx(ref.gaussian, abs=0.03)


def test_a_spike_or_a_step_does_not_move_the_reference():
    x = ind.white(1 << 16, 1.0, 1.0, np.random.default_rng(7))
    x[5000] += 40.0
    x[20_000:30_000] *= 3.0
    assert record_reference(x, lmin=LMIN).identity


@pytest.mark.parametrize("shape", ["student5", "laplace", "uniform", "platykurtic"])
def test_stationary_non_gaussian_noise_keeps_its_windows(shape):
    """10 hours at 1 Hz: the Gaussian reference shortened most windows (every one for
    Student-t, Laplace and uniform noise); the record's own keeps them."""
    x = ind.white_shaped(36_000, 1.0, 1.0, np.random.default_rng(8), shape)
    new = adavar.adaptive_schedule(x, rate=1.0, lmax=LMAX)
    old = adavar.adaptive_schedule(x, rate=1.0, lmax=LMAX, kurtosis_reference="gaussian")
    assert np.mean(old.window < LMAX) > 0.05
    assert np.mean(new.window < LMAX) < 0.01
    assert new.parameters["kurtosis_reference"] == "record"
    assert new.parameters["kurtosis_reference_fit"]["theta"] != 0.0


def test_coarse_quantisation_moves_the_band():
    """Three atoms no monotone map makes Gaussian: the band moves with the record's kurtosis
    (thresholds_for rebuilds the moved band from the parameters)."""
    x = ind.quantise(ind.white(36_000, 1.0, 1.0, np.random.default_rng(9)), 2.0)
    sched = adavar.adaptive_schedule(x, rate=1.0, lmax=LMAX)
    fit = sched.parameters["kurtosis_reference_fit"]
    assert fit["offset"] > 0.05
    plain = adavar.adaptive_schedule(x, rate=1.0, lmax=LMAX, kurtosis_reference="gaussian")
    moved = plain.thresholds.k2[LMAX] + fit["offset"] + fit["margin"]
    assert fit["margin"] > 0 and sched.thresholds.k2[LMAX] == pytest.approx(moved)
    rebuilt = thresholds_for(sched.parameters)
    assert np.array_equal(rebuilt.k1, sched.thresholds.k1, equal_nan=True)
    assert np.mean(sched.window < LMAX) < 0.01 < np.mean(plain.window < LMAX)


def test_the_paper_thresholds_and_a_given_fit():
    x = ind.white_shaped(20_000, 1.0, 1.0, np.random.default_rng(10), "student5")
    paper = adavar.adaptive_schedule(x, rate=1.0, lmax=LMAX, thresholds="paper")
    plain = adavar.adaptive_schedule(x, rate=1.0, lmax=LMAX, thresholds="paper",
                                     kurtosis_reference="gaussian")  # fmt: skip
    assert np.array_equal(paper.window, plain.window)  # the paper's band is left as it is
    assert paper.parameters["kurtosis_reference"] is None
    fitted = adavar.adaptive_schedule(x, rate=1.0, lmax=LMAX)
    fit = fitted.parameters["kurtosis_reference_fit"]
    given = adavar.adaptive_schedule(x, rate=1.0, lmax=LMAX, kurtosis_reference=fit,
                                     dependence=fitted.parameters["dependence"])  # fmt: skip
    assert given.parameters["kurtosis_reference"] == "given"
    assert KurtosisReference.from_dict(fit).theta == fit["theta"]
    assert np.mean(given.window < LMAX) < 0.01
    for bad, fragment in (("median", "unknown kurtosis_reference"),
                          ({"theta": 0.5}, "needs theta")):  # fmt: skip
        with pytest.raises(AdavarInputError, match=fragment):
            adavar.adaptive_schedule(x, rate=1.0, lmax=LMAX, kurtosis_reference=bad)


def test_live_pass_refits_the_reference_in_stages_as_offline():
    """A heavy-tailed record: the reference is fitted on the first 8192 samples, refitted at
    16384 and 32768; the live windows are the offline ones bit for bit."""
    x = ind.white_shaped(40_000, 1.0, 10.0, np.random.default_rng(11), "student5")
    x[25_000:27_000] *= 4.0
    offline = adavar.adaptive_schedule(x, rate=10.0, lmax=LMAX)
    live = adavar.OnlineAdaptive(rate=10.0, lmax=LMAX, terms=None)
    for piece in np.array_split(x, 9):
        live.push(piece)
    live.finish()
    assert np.array_equal(live.window, offline.window)
    assert live.parameters["kurtosis_reference_fit"] == offline.parameters["kurtosis_reference_fit"]
    assert np.mean(offline.window < LMAX) < 0.2  # the burst, not the heavy tail

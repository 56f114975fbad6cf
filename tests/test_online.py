"""adavar.OnlineAdaptive: the live pass equals the offline one (windows, N(t), events)."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import adavar
from adavar.core.errors import AdavarInputError
from adavar.dynamic.events import find_events
from adavar.dynamic.ici_events import ici_events
from adavar.dynamic.online import OnlineAdaptive
from adavar.paper.scenarios import paper_scenario
from adavar.simulate import sensor

RATE = 200.0
N_TERM = "angle_random_walk"
#: the windows of these records (a stream's default, 3 minutes, is longer than most of them)
WINDOWS = dict(lmax=600)


@functools.cache
def record(n: int = 24_000, seed: int = 1) -> np.ndarray:
    """A realistic 200 Hz gyro log (filtered, quantised) with a x3 noise burst."""
    x = sensor(n, rate=RATE, bandwidth=40, lsb=1 / 131, angle_random_walk=0.01,
               bias_instability=0.002, rate_random_walk=1e-4, seed=seed)  # fmt: skip
    x[n // 3 : n // 3 + 3000] *= 3.0
    x.flags.writeable = False
    return x


def pushed(x: np.ndarray, sizes, **options) -> OnlineAdaptive:
    """``x`` pushed in pieces of the given sizes (cycled), then finished."""
    live = OnlineAdaptive(rate=RATE, **WINDOWS | options)
    i = k = 0
    while i < x.size:
        size = int(sizes[k % len(sizes)])
        live.push(x[i : i + size])
        i += size
        k += 1
    live.finish()
    return live


def offline(x: np.ndarray, step: int = 1, **controller):
    """The offline result, its N(t) and events as ``adavar adaptive`` reports them."""
    result = adavar.adaptive_davar(x, rate=RATE, taus="octave", noise_type=0, step=step,
                                   **WINDOWS | controller)  # fmt: skip
    # a stream has no whole record: the live fit goes without its roll-off reference
    arw = adavar.fit_noise(result, terms=(N_TERM,), reference=None).angle_random_walk.value
    lmax = int(result.parameters["lmax"])
    events = find_events(result.window, result.centre, result.time, lmax, 1 / RATE,
                         {N_TERM: arw}, duration=x.size / RATE)  # fmt: skip
    return result, arw, events


def assert_same(live: OnlineAdaptive, x: np.ndarray, step: int = 1, **controller) -> None:
    result, arw, events = offline(x, step=step, **controller)
    assert live.window.dtype == np.int64
    assert np.array_equal(live.window, result.window)
    assert np.array_equal(live.centre, result.centre)
    assert np.array_equal(live.time, result.time)
    np.testing.assert_allclose(live.arw, arw, rtol=1e-12, atol=0)
    assert [e.as_dict() for e in live.events] == [e.as_dict() for e in events]
    assert live.final_count == len(live.events)


SETTINGS = [
    pytest.param(dict(), id="defaults"),
    pytest.param(dict(method="adaptive", thresholds="paper"), id="adaptive-paper"),
    pytest.param(dict(method="kurtosis", thresholds="paper"), id="kurtosis-paper"),
    pytest.param(
        dict(method="adaptive", thresholds="calibrated", false_alarm=0.01),
        id="adaptive-calibrated",
    ),
    pytest.param(
        dict(method="kurtosis", thresholds="calibrated", false_alarm_per_hour=0.1),
        id="kurtosis-hourly",
    ),
    pytest.param(dict(thresholds="calibrated", false_alarm_per_hour=0.1), id="adaptive-hourly"),
]


@pytest.mark.parametrize("controller", SETTINGS)
def test_equals_offline(controller):
    x = record()
    live = pushed(x, [1, 7, 333, 4096, 513, 20_000], **controller)
    assert_same(live, x, **controller)
    assert live.events  # the burst is seen


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(sizes=st.lists(st.integers(40, 9000), min_size=1, max_size=6))
def test_any_push_sizes(sizes):
    x = record(12_000, seed=3)
    controller = dict(lmax=240, lmin=160, l=40)
    assert_same(pushed(x, sizes, **controller), x, **controller)


def test_step_recent_and_input_types():
    x = record()
    step = 7
    live = pushed(x, [2500], step=step, keep="recent")
    result, _, events = offline(x, step=step)
    assert [e.as_dict() for e in live.events] == [e.as_dict() for e in events]
    held = live.window.size
    assert held < result.window.size  # only the recent rows are held ...
    assert np.array_equal(live.window, result.window[live.first_row :])  # ... unchanged
    counts = np.round(np.asarray(x) * 131).astype(np.int16)  # the sensor's integer counts
    for data in (counts, counts.astype(np.float32)):
        live = pushed(data, [999, 10_000], step=step)
        assert np.array_equal(live.window, offline(data.astype(float), step=step)[0].window)


def test_scale_and_given_dependence():
    x = np.asarray(record(12_000, seed=5)) * 1e30  # scaled by the first push's power of two
    controller = dict(lmax=240, lmin=160, l=40)
    assert_same(pushed(x, [100, 5000], **controller), x, **controller)
    hourly = dict(thresholds="calibrated", false_alarm_per_hour=0.1)
    first = pushed(x, [12_000], **hourly).parameters
    measured, fit = first["dependence"], first["kurtosis_reference_fit"]
    # the correlation and the kurtosis reference given: no wait for the head
    given_both = dict(dependence=tuple(measured), kurtosis_reference=fit)
    live = OnlineAdaptive(rate=RATE, **given_both, **WINDOWS, **hourly)
    live.push(x[:2000])
    assert live.window.size == 2000 - live.latency  # no wait for the head
    live.push(x[2000:])
    live.finish()
    given = offline(x, **given_both, **hourly)[0]
    assert np.array_equal(live.window, given.window)
    assert given.parameters["dependence"] == list(measured)
    assert given.parameters["kurtosis_reference_fit"] == fit


def test_hourly_thresholds_start_early_and_are_refined():
    """The hourly thresholds' correlation is estimated on the first 8192 samples (41 s at
    200 Hz; the old pass waited for 2**20, 87 minutes) and refined at every doubling up to
    DEPENDENCE_SAMPLES: no emitted row changes, and the windows are the offline ones."""
    from adavar.dynamic.thresholds import DEPENDENCE_SAMPLES

    n = DEPENDENCE_SAMPLES + 60_000
    x = sensor(n, rate=RATE, bandwidth=40, lsb=1 / 131, angle_random_walk=0.01, seed=7)
    x[DEPENDENCE_SAMPLES + 10_000 : DEPENDENCE_SAMPLES + 14_000] *= 3.0
    controller = dict(thresholds="calibrated", false_alarm_per_hour=0.1, lmax=2000,
                      lmin=1334, l=333)  # fmt: skip
    live = OnlineAdaptive(rate=RATE, step=50, terms=None, **controller)
    live.push(x[:8191])
    assert live.window.size == 0 and live.waiting == 1  # waiting for the first head
    live.push(x[8191:8192])
    assert live.window.size == -(-(8192 - live.latency) // 50)  # every row due so far
    early = []
    for piece in np.array_split(x[8192:], 97):
        live.push(piece)
        early.append(live.window.copy())
    live.finish()
    for rows in early:  # a refined estimate never revised an emitted row
        assert np.array_equal(live.window[: rows.size], rows)
    sched = adavar.adaptive_schedule(x, rate=RATE, step=50, **controller)
    assert np.array_equal(live.window, sched.window)
    stages = live.parameters["dependence_stages"]
    assert stages == sched.parameters["dependence_stages"]
    assert [h for _, h, _, _ in stages] == [8192 << k for k in range(8)]  # to 2**20
    assert live.parameters["dependence"] == sched.parameters["dependence"] == stages[-1][2:]
    assert stages[0][2] > 1.5  # the filtered sensor's correlation, seen on the first head


def test_latency_and_mirror():
    x = record(12_000)
    live = OnlineAdaptive(rate=RATE, lmax=240, lmin=160, l=40, thresholds="paper")
    assert live.latency == 120
    for i in range(0, 3000, 250):
        live.push(x[i : i + 250])
        assert live.window.size == i + 250 - live.latency  # every centre a latency back
    live.push(x[3000:])
    assert live.window.size == x.size - live.latency
    assert live.finish() == [] or live.events
    assert live.window.size == x.size  # the last centres with the right mirror
    assert live.latest["window"] == live.window[-1]
    assert live.push  # the object stays readable after finish
    with pytest.raises(AdavarInputError, match="finished"):
        live.push([1.0])


@pytest.mark.parametrize(
    ("samples", "fragment"),
    [
        ([1.0, float("nan")], "sample 1 of this push is nan"),
        ([1.0, float("inf")], "interpolate missing ones"),
        (["a", "b"], "numeric"),
        (np.zeros((3, 2)), "one channel"),
        ([1 + 2j], "real-valued"),
    ],
)
def test_bad_samples(samples, fragment):
    live = OnlineAdaptive(rate=RATE, lmax=60, lmin=40, l=10)
    with pytest.raises(AdavarInputError, match=fragment) as info:
        live.push(samples)
    assert "\n" not in str(info.value)


def test_bad_settings_and_short_record():
    for options, fragment in [
        (dict(method="oracle"), "does not run live"),
        (dict(keep="some"), "keep"),
        (dict(lmax=600, lmin=401), "even"),
        (dict(noise_type="record"), "no whole record"),
        (dict(terms=("nonsense",)), "unknown term"),
        (dict(fit_batch=0), "fit_batch"),
        (
            dict(thresholds="calibrated", false_alarm_per_hour=0.1, dependence=(0.5, 1.0)),
            "dependence",
        ),
    ]:
        with pytest.raises(AdavarInputError, match=fragment):
            OnlineAdaptive(rate=RATE, **options)
    live = OnlineAdaptive(rate=RATE, lmax=60, lmin=40, l=10)
    live.push(np.zeros(10))
    live.push(5.0)  # a scalar is one sample
    with pytest.raises(AdavarInputError, match="at least 60"):
        live.finish()


def test_fit_batch_and_no_terms():
    x = record(12_000)
    controller = dict(lmax=240, lmin=160, l=40)
    batched = pushed(x, [50], fit_batch=500, **controller)
    assert_same(batched, x, **controller)
    bare = pushed(x, [3000], terms=None, **controller)
    assert np.array_equal(bare.window, batched.window)
    assert bare.coefficients == {}
    # no N to tell a change of level from a spike: each episode is an event of its own,
    # as find_events gives them without coefficients
    alone = find_events(bare.window, bare.centre, bare.time, 240, 1 / RATE, {},
                        duration=x.size / RATE)  # fmt: skip
    assert [(e.start_s, e.end_s) for e in bare.events] == [(e.start_s, e.end_s) for e in alone]
    assert len(bare.events) >= len(batched.events) and bare.events
    assert all(e.before == {} for e in bare.events)
    with pytest.raises(AdavarInputError, match="angle_random_walk"):
        _ = bare.arw


# ---------------------------------------------------------------------------------------
# method="ici": the windows, sides, changes, N(t) and events of adaptive_davar(method="ici")

ICI = dict(method="ici", lmax=1200, lmin=800, ici_edf_samples=8000)


@functools.cache
def ici_record(n: int = 30_000, seed: int = 4) -> np.ndarray:
    """The realistic 200 Hz log with a x3 and a x1.5 stretch of noise."""
    x = sensor(n, rate=RATE, bandwidth=40, lsb=1 / 131, angle_random_walk=0.005,
               bias_instability=0.002, rate_random_walk=1e-4, seed=seed)  # fmt: skip
    x[6000:11_000] *= 3.0
    x[18_000:24_000] *= 1.5
    x.flags.writeable = False
    return x


@functools.cache
def ici_offline(x_key: str, step: int = 1, rate: float = RATE, **options):
    """The offline ICI result, its N(t) and the events ``adavar adaptive`` reports."""
    x = ici_record() if x_key == "sensor" else scenario_record()
    result = adavar.adaptive_davar(x, rate=rate, taus="octave", noise_type=0, step=step,
                                   **ICI | options)  # fmt: skip
    # a stream has no whole record: the live fit goes without its roll-off reference
    arw = adavar.fit_noise(result, terms=(N_TERM,), reference=None).angle_random_walk.value
    lmax = int(result.parameters["lmax"])
    events = ici_events(result.window, result.centre, result.time, lmax, 1 / rate,
                        {N_TERM: arw}, t0=0.0, duration=x.size / rate,
                        parameters=result.parameters)  # fmt: skip
    return result, arw, events


@functools.cache
def scenario_record() -> np.ndarray:
    x = np.asarray(paper_scenario(1, seed=5).data, dtype=float)
    x.flags.writeable = False
    return x


def assert_same_ici(live: OnlineAdaptive, x_key: str, **options) -> None:
    result, arw, events = ici_offline(x_key, **options)
    rows = slice(live.first_row, None)
    assert np.array_equal(live.window, result.window[rows])
    assert np.array_equal(live.shift, result.shift[rows])  # the side of every centre
    assert np.array_equal(live.centre, result.centre[rows])
    assert live.ici_changes == result.parameters["ici_changes"]
    np.testing.assert_allclose(live.arw, arw[rows], rtol=1e-12, atol=0)
    assert [e.as_dict() for e in live.events] == [e.as_dict() for e in events]
    assert live.final_count == len(live.events)


def test_ici_equals_offline():
    x = ici_record()
    live = pushed(x, [1, 333, 4096, 20_000], **ICI)
    assert_same_ici(live, "sensor")
    assert len(live.events) == 2  # the x3 and the x1.5 stretch
    assert np.any(live.shift != 0)  # one-sided windows next to the changes
    # the paper's scenario 1 (1 Hz, x3 from 3000 to 4000 s), Lmax 600, Lmin 400
    options = dict(lmax=600, lmin=400, ici_edf_samples=3000)
    live = OnlineAdaptive(rate=1.0, **ICI | options)
    for piece in np.array_split(scenario_record(), 13):
        live.push(piece)
    live.finish()
    assert_same_ici(live, "scenario", rate=1.0, **options)
    (event,) = live.events  # the x3 stretch, found within 10 s of each end
    assert abs(event.start_s - 3000) <= 10 and abs(event.end_s - 4000) <= 10


@settings(max_examples=2, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(sizes=st.lists(st.integers(1, 12_000), min_size=1, max_size=5))
def test_ici_any_push_sizes(sizes):
    assert_same_ici(pushed(ici_record(), [max(s, 200) for s in sizes], **ICI), "sensor")


def test_ici_step_recent_latency_and_refusals():
    x = ici_record()
    live = pushed(x, [2500], step=7, keep="recent", **ICI)
    assert_same_ici(live, "sensor", step=7)
    assert live.first_row > 0  # only the recent rows are held
    live = OnlineAdaptive(rate=RATE, **ICI)
    # an engine unit (lmax / 2 centres) and lmax, and 1.75 lmax a ramp of an episode may
    # reach (its region: lmax + lmax / 4 before its first split centre; the ramp: lmax / 2)
    assert live.latency == 600 + 1200 - 2 + 1200 + 300 + 600
    assert live.waiting == 8000  # the EDF's head
    live.push(x[:7999])
    assert live.window.size == 0
    live.push(x[7999:12_000])
    assert live.window.size >= 12_000 - live.latency - 1  # outside runs of tied sides
    assert live.parameters["ici_edf_samples"] == 8000
    with pytest.raises(AdavarInputError, match="ici_edf='correlation'"):
        OnlineAdaptive(rate=RATE, method="ici", ici_edf="engine")
    with pytest.raises(AdavarInputError, match="ici_edf_samples"):
        OnlineAdaptive(rate=RATE, method="ici", ici_edf_samples=None)


def test_ici_edf_samples_offline():
    """ici_edf_samples: the EDF of the first K samples; the whole record when K covers it."""
    from adavar.dynamic.ici import ici_schedule

    x = np.asarray(ici_record()[:9000])
    whole = ici_schedule(x, lmax=1200, lmin=800)
    assert whole.parameters["ici_edf_samples"] is None
    assert np.array_equal(ici_schedule(x, lmax=1200, lmin=800, edf_samples=x.size).edf,
                          whole.edf)  # fmt: skip
    head = ici_schedule(x, lmax=1200, lmin=800, edf_samples=4000)
    assert not np.array_equal(head.edf, whole.edf)
    with pytest.raises(AdavarInputError, match="ici_edf_samples"):
        ici_schedule(x, lmax=1200, lmin=800, edf_samples=1)


def test_a_backlog_is_fitted_in_blocks(monkeypatch):
    """Rows fitted a block at a time (a backlog after the hourly thresholds are set is up
    to DEPENDENCE_SAMPLES rows): the same windows, N(t) and events as one block, and as
    the offline pass."""
    import adavar.dynamic.online as online

    x = record()
    controller = dict(thresholds="calibrated", false_alarm_per_hour=0.1)
    whole = pushed(x, [x.size], **controller)
    monkeypatch.setattr(online, "FIT_ROWS", 997)
    blocks = pushed(x, [x.size], **controller)
    assert np.array_equal(blocks.arw, whole.arw)
    assert [e.as_dict() for e in blocks.events] == [e.as_dict() for e in whole.events]
    assert_same(blocks, x, **controller)
    # the controller over a backlog in parts too (at finish here: the record is shorter
    # than DEPENDENCE_SAMPLES), and over one large push with the paper's thresholds
    monkeypatch.setattr(online, "BACKLOG_CENTRES", 4 * online.REANCHOR)
    parts = pushed(x, [x.size], **controller)
    assert np.array_equal(parts.window, whole.window)
    assert np.array_equal(parts.arw, whole.arw)
    assert [e.as_dict() for e in parts.events] == [e.as_dict() for e in whole.events]
    assert_same(pushed(x, [x.size - 7000, 7000]), x)
    assert_same(pushed(x, [x.size], step=3), x, step=3)
    ici = pushed(x, [5000, x.size], method="ici")  # one-sided windows, in blocks too
    monkeypatch.setattr(online, "FIT_ROWS", 1 << 30)
    np.testing.assert_array_equal(ici.arw, pushed(x, [5000, x.size], method="ici").arw)


def test_masked_samples_refused_as_deviation_refuses_them():
    """A masked sample was pushed as whatever lay under the mask; deviation refuses it."""
    x = np.ma.masked_array(np.arange(100.0), mask=np.arange(100) == 7)
    with pytest.raises(AdavarInputError) as offline_error:
        adavar.deviation(x, rate=RATE)
    live = OnlineAdaptive(rate=RATE, lmax=60, lmin=40, l=10)
    with pytest.raises(AdavarInputError) as live_error:
        live.push(x)
    assert str(live_error.value) == str(offline_error.value)
    assert "masked" in str(live_error.value) and "sample 7" in str(live_error.value)
    assert live.samples == 0
    live.push(np.ma.masked_array(np.arange(100.0)))  # nothing masked: read as it is
    assert live.samples == 100


@pytest.mark.parametrize("terms", [(N_TERM,), None])
def test_huge_outlier_refused_in_one_push_and_in_pieces(terms):
    """A 1e300 sample in unit noise: its fourth powers overflowed (inf in the sums) when it
    came after the first push, and passed silently; in one push the scale it sets left the
    noise's fourth powers below the float64 range. Both are now the same clear error."""
    x = np.random.default_rng(3).standard_normal(3000)
    x[2000] = 1e300
    for sizes in ([3000], [1000], [1, 2999]):
        with pytest.raises(AdavarInputError, match=r"more than 2\*\*240 in magnitude") as info:
            pushed(x, sizes, lmax=240, lmin=160, l=40, thresholds="paper", terms=terms)
        assert "is 1e+300" in str(info.value) and "remove the outliers" in str(info.value)
    # magnitudes within 2**240 of the first push's: the offline windows, whatever the pieces
    y = np.asarray(record(12_000, seed=5)).copy()
    y[6000:] *= 1e40  # 2**133 beyond the first push's scale: that of the offline pass differs
    controller = dict(lmax=240, lmin=160, l=40)
    assert_same(pushed(y, [3000], **controller), y, **controller)

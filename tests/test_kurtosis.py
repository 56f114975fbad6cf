"""Sliding kurtosis and the kurtosis contribution coefficient against two-pass references."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.stats
from hypothesis import given, settings
from hypothesis import strategies as st

from adavar.core.errors import AdavarInputError
from adavar.dynamic import kurtosis as kmod
from adavar.dynamic.kurtosis import kurtosis_contribution, sliding_kurtosis
from adavar.dynamic.windows import window_schedule

from . import reference

ATOL = 1e-9  # absolute, on kurtoses near 3 (and on S)


def _noise(n, seed=0):
    return np.random.default_rng(seed).standard_normal(n)


def _burst(n, seed=0, factor=1e4):
    """White noise with a burst of ``factor`` times the noise next to quiet stretches."""
    x = _noise(n, seed)
    x[n // 3 : n // 3 + n // 10] *= factor
    x[3 * n // 4 : 3 * n // 4 + 7] *= factor
    return x


HARD = {
    "white": lambda n, s: _noise(n, s),
    "offset_1e6": lambda n, s: _noise(n, s) + 1e6,
    "negative_offset": lambda n, s: _noise(n, s) - 3.7e6,
    "drift_1e6": lambda n, s: _noise(n, s) + np.linspace(0.0, 1e6, n),
    "offset_and_drift": lambda n, s: _noise(n, s) + 1e6 + np.linspace(-1e6, 1e6, n),
    "float32": lambda n, s: (_noise(n, s) * 3.0 + 250.0).astype(np.float32),
    "burst_1e4": lambda n, s: _burst(n, s),
    "burst_offset": lambda n, s: _burst(n, s) + 1e6,
    "tiny": lambda n, s: 1e-13 * _noise(n, s),
    "tiny_offset": lambda n, s: 1e-13 * _noise(n, s) + 1e-7,
    "huge": lambda n, s: 1e12 * _noise(n, s),
    "huge_offset": lambda n, s: 1e12 * (_noise(n, s) + 1e6),
    "heavy_tails": lambda n, s: np.random.default_rng(s).standard_t(2.5, n),
    "random_walk": lambda n, s: np.cumsum(_noise(n, s)),
    # beyond the prefix sums' reach: windows between spikes, or on the far side of a level
    # step from their chunk's anchor, are summed from the other end or directly
    "spikes_1e8": lambda n, s: np.where(np.arange(n) % 97 == 5, 1e8, _noise(n, s)),
    "steps_1e6": lambda n, s: _noise(n, s) + 1e6 * ((np.arange(n) // 113) % 2),
}


def check_kurtosis(x, window, *, edges="mirror", step=1, atol=ATOL):
    centre, got = sliding_kurtosis(x, window=window, edges=edges, step=step, return_centres=True)
    want_centre, want = reference.kurtosis_reference(x, window, edges=edges, step=step)
    np.testing.assert_array_equal(centre, want_centre)
    np.testing.assert_allclose(got, want, rtol=0.0, atol=atol, equal_nan=True)
    return got, want


def check_contribution(
    x, window, segment=None, *, reference_form="window", edges="mirror", step=1, atol=ATOL
):
    centre, got = kurtosis_contribution(
        x,
        window=window,
        segment=segment,
        reference=reference_form,
        edges=edges,
        step=step,
        return_centres=True,
    )
    want_centre, want = reference.contribution_reference(
        x, window, segment, reference=reference_form, edges=edges, step=step
    )
    np.testing.assert_array_equal(centre, want_centre)
    np.testing.assert_allclose(got, want, rtol=0.0, atol=atol, equal_nan=True)
    return got, want


@pytest.fixture
def small_chunks(monkeypatch):
    """Chunks of a few dozen samples and a fine record grid: every boundary case is hit."""
    monkeypatch.setattr(kmod, "_SPAN", 48)
    monkeypatch.setattr(kmod, "_GRID", 16)


# ---------------------------------------------------------------------------------------
# the definition


def test_matches_scipy_pearson_kurtosis():
    x = _noise(300, 1)
    got = sliding_kurtosis(x, window=41, edges="valid")
    want = [scipy.stats.kurtosis(x[p - 20 : p + 21], fisher=False) for p in range(20, 280)]
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-12)


def test_gaussian_kurtosis_is_three():
    k = sliding_kurtosis(_noise(200_000, 2), window=20_001, edges="valid", step=10_000)
    np.testing.assert_allclose(k, 3.0, atol=0.15)


def test_known_values():
    # two values: kurtosis 1; one outlier among n: (n^2 - 3n + 3) / (n - 1)
    assert sliding_kurtosis([0.0, 1.0, 0.0, 1.0], window=4, edges="valid")[0] == 1.0
    n = 9
    x = np.zeros(n)
    x[4] = 5.0
    assert sliding_kurtosis(x, window=n, edges="valid")[0] == pytest.approx(
        (n * n - 3 * n + 3) / (n - 1), abs=1e-12
    )


def test_return_centres_follow_the_schedule():
    x = _noise(100)
    for edges, step in [("mirror", 1), ("mirror", 7), ("valid", 3)]:
        centre, k = sliding_kurtosis(x, window=15, edges=edges, step=step, return_centres=True)
        np.testing.assert_array_equal(
            centre, window_schedule(100, 15, edges=edges, step=step).centre
        )
        assert k.shape == centre.shape and k.dtype == np.float64
        np.testing.assert_array_equal(k, sliding_kurtosis(x, window=15, edges=edges, step=step))


# ---------------------------------------------------------------------------------------
# against the reference: windows, edges, steps and schedules


@pytest.mark.parametrize("L", [3, 4, 5, 10, 31, 64])
@pytest.mark.parametrize("edges", ["mirror", "valid"])
def test_fixed_windows(L, edges):
    check_kurtosis(_noise(150, L), L, edges=edges)


@pytest.mark.parametrize("step", [2, 5, 40])
def test_steps(step, small_chunks):
    x = _noise(300, step)
    check_kurtosis(x, 25, step=step)
    check_kurtosis(x, 24, step=step, edges="valid")
    per_centre = np.random.default_rng(step).integers(3, 60, size=-(-300 // step))
    check_kurtosis(x, per_centre, step=step)


def test_per_sample_schedule_changes_every_step(small_chunks):
    rng = np.random.default_rng(5)
    n = 400
    x = _noise(n, 5)
    for lo, hi in [(3, 9), (3, 120), (40, 400)]:
        schedule = rng.integers(lo, hi + 1, size=n)
        check_kurtosis(x, schedule)
        check_kurtosis(x, schedule, edges="valid", step=3)


def test_long_record_many_chunks_default_sizes():
    x = _noise(20_000, 9) + 1e6
    rng = np.random.default_rng(9)
    check_kurtosis(x, 7)
    check_kurtosis(x, rng.integers(5, 30, size=x.size), step=3)


@pytest.mark.parametrize("kind", sorted(HARD))
def test_hard_data(kind, small_chunks):
    x = HARD[kind](500, 11)
    check_kurtosis(x, 21)
    check_kurtosis(x, np.random.default_rng(3).integers(4, 90, size=x.size))
    check_contribution(x, 60, 15)
    check_contribution(x, 11, reference_form="record")


@pytest.mark.parametrize("kind", sorted(HARD))
def test_hard_data_default_chunks(kind):
    x = HARD[kind](9000, 12)
    check_kurtosis(x, 301, step=7)
    check_contribution(x, np.random.default_rng(4).integers(200, 300, size=x.size), 100, step=11)


@pytest.mark.parametrize("level", [1e4, 1e6, 1e9])
def test_level_step_and_spike(level, small_chunks):
    # windows on the far side of a level change, or after a spike, inside the same chunk:
    # the prefix sums there lose digits, and those windows are summed directly
    x = _noise(600, 13)
    x[300:] += level
    check_kurtosis(x, 31)
    check_kurtosis(x, np.random.default_rng(1).integers(5, 40, size=x.size))
    check_contribution(x, 30, 7)
    check_contribution(x, 11, reference_form="record")
    y = _noise(600, 14)
    y[::97] = level
    check_kurtosis(y, 31)
    check_contribution(y, 30, 7)
    check_contribution(y, 11, reference_form="record")


def test_quiet_next_to_burst(small_chunks):
    y = _noise(600, 14)
    y[200:260] *= 1e4
    check_kurtosis(y, 31)
    check_contribution(y, 40, 10)
    check_contribution(y, 11, reference_form="record")


@pytest.mark.parametrize("scale", [1e-300, 1e-150, 1e150, 1e300])
def test_extreme_scales(scale, small_chunks):
    # fourth powers of 1e-300 underflow and of 1e300 overflow: the power-of-two scaling
    x = _noise(200, 15) * scale
    check_kurtosis(x, 17)
    check_contribution(x, 17, 5)
    check_contribution(x, 17, reference_form="record")


def test_subnormal_data():
    x = _noise(200, 16)
    want = sliding_kurtosis(x, window=17)
    np.testing.assert_allclose(sliding_kurtosis(x * 1e-310, window=17), want, atol=1e-9)


# ---------------------------------------------------------------------------------------
# raw power sums cancel: the offset test has teeth


def _naive_sliding_kurtosis(x, L, centre_anchor=False):
    """Kurtosis of valid windows from plain cumulative sums of x**k (the textbook way)."""
    y = x - np.median(x) if centre_anchor else x
    P = [np.concatenate([[0.0], np.cumsum(y**k)]) for k in range(1, 5)]
    s1, s2, s3, s4 = (p[L:] - p[:-L] for p in P)
    mu = s1 / L
    m2 = s2 / L - mu**2
    m4 = s4 / L - 4 * mu * s3 / L + 6 * mu**2 * s2 / L - 3 * mu**4
    return m4 / m2**2


@pytest.mark.parametrize(
    ("kind", "centre_anchor"),
    [("offset_1e6", False), ("drift_1e6", True), ("burst_1e4", True)],
)
def test_naive_raw_sums_fail_where_this_holds(kind, centre_anchor):
    x = HARD[kind](3000, 21)
    L = 25
    got, want = check_kurtosis(x, L, edges="valid")
    assert np.nanmax(np.abs(got - want)) < ATOL
    naive = _naive_sliding_kurtosis(x, L, centre_anchor)
    with np.errstate(invalid="ignore"):
        assert not np.nanmax(np.abs(naive - want)) < 1e3 * ATOL  # NaN or far off


# ---------------------------------------------------------------------------------------
# contribution coefficient


@pytest.mark.parametrize(("L", "seg"), [(5, 1), (8, 4), (30, 10), (61, 57)])
def test_contribution_window_form(L, seg, small_chunks):
    x = _burst(300, L)
    check_contribution(x, L, seg)
    check_contribution(x, L, seg, edges="valid", step=2)


def test_contribution_window_form_schedule(small_chunks):
    rng = np.random.default_rng(8)
    x = _noise(400, 8) + 1e6
    check_contribution(x, rng.integers(20, 80, size=400), 16)
    check_contribution(x, rng.integers(20, 80, size=-(-400 // 3)), 16, step=3)


def test_contribution_window_form_complement_is_first_samples():
    x = _noise(200, 3)
    L, seg = 40, 12
    S = kurtosis_contribution(x, window=L, segment=seg, edges="valid")
    k_full = sliding_kurtosis(x, window=L, edges="valid")
    for i, p in enumerate(range(19, 200 - 20)):
        a = p - (L - 1) // 2
        kc = scipy.stats.kurtosis(x[a : a + L - seg], fisher=False)
        assert S[i] == pytest.approx((k_full[i] - kc) / k_full[i], abs=1e-12)


@pytest.mark.parametrize("L", [3, 11, 50, 299, 300])
def test_contribution_record_form(L, small_chunks):
    x = _noise(300, L)
    x[150] = 40.0  # a shock: S peaks at the windows that hold it
    S, _ = check_contribution(x, L, reference_form="record")
    check_contribution(x, L, reference_form="record", edges="valid", step=4 if L < 290 else 1)
    if L == 11:
        assert np.argmax(S) in range(145, 156)
        assert S.max() > 0.5


@pytest.mark.parametrize("spike", [1e3, 1e8, -1e12])
def test_contribution_record_form_single_shock(spike, small_chunks):
    # the complement of the windows that hold the shock is quiet: never from subtraction
    x = _noise(300, 6) + 5e5
    x[171] += spike
    S, _ = check_contribution(x, 11, reference_form="record")
    assert np.argmax(S) in range(166, 177)
    strided, _ = check_contribution(x, 11, reference_form="record", step=5)
    np.testing.assert_allclose(strided, S[::5], rtol=0.0, atol=ATOL)


def test_contribution_record_form_schedule(small_chunks):
    x = _burst(400, 17) - 2e6
    check_contribution(
        x, np.random.default_rng(2).integers(3, 100, size=400), reference_form="record"
    )


def test_contribution_record_form_long():
    x = np.random.default_rng(3).standard_t(3.0, 12_000) + np.linspace(0, 1e5, 12_000)
    S = kurtosis_contribution(x, window=11, reference="record", step=211)
    _, want = reference.contribution_reference(x, 11, reference="record", step=211)
    np.testing.assert_allclose(S, want, rtol=0.0, atol=ATOL)


# ---------------------------------------------------------------------------------------
# constant windows


def test_constant_windows_are_nan(small_chunks):
    x = _noise(200, 4)
    x[50:120] = 2.5
    x[150:160] = 1e6
    k, _ = check_kurtosis(x, 9)
    assert np.all(np.isnan(k[55:115])) and np.isfinite(k[:40]).all()
    S, _ = check_contribution(x, 20, 5)
    assert np.isnan(S[60:110]).all()
    check_contribution(x, 11, reference_form="record")


def test_constant_record():
    x = np.full(50, 3.0)
    assert np.isnan(sliding_kurtosis(x, window=5)).all()
    assert np.isnan(kurtosis_contribution(x, window=5, segment=1)).all()
    assert np.isnan(kurtosis_contribution(x, window=5, reference="record")).all()


def test_record_form_complement_constant_or_empty():
    x = np.zeros(30)
    x[10:13] = [1.0, -2.0, 3.0]
    S, _ = check_contribution(x, 5, reference_form="record")
    assert np.isnan(S[11])  # the window holds every non-zero sample
    y = _noise(20, 1)
    S = kurtosis_contribution(y, window=20, reference="record")
    assert np.isnan(S[9:11]).all()  # these windows are the whole record
    check_contribution(y, 20, reference_form="record")
    z = np.ones(40)
    z[:3] = [0.0, 5.0, 0.0]
    z[-3:] = [0.0, 7.0, 0.0]
    check_contribution(z, 9, reference_form="record")
    z[-3:] = [1.0, 1.0, 4.0]
    check_contribution(z, 9, reference_form="record")


# ---------------------------------------------------------------------------------------
# input errors


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"window": 2}, "too short"),
        ({"window": 101}, "longer than the record"),
        ({"window": 5.5}, "whole number"),
        ({"window": 5, "edges": "wrap"}, "edges"),
        ({"window": 5, "step": 0}, "step"),
        ({"window": np.full(7, 5)}, "window array"),
    ],
)
def test_sliding_kurtosis_errors(kwargs, match):
    with pytest.raises(AdavarInputError, match=match):
        sliding_kurtosis(_noise(100), **kwargs)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"window": 10}, "needs segment"),
        ({"window": 10, "segment": 0}, "at least 1"),
        ({"window": 10, "segment": 7}, "at least 4 must remain"),
        ({"window": np.r_[np.full(99, 30), 9], "segment": 6}, "shortest window"),
        ({"window": 10, "segment": 2.5}, "whole number"),
        ({"window": 10, "segment": "2"}, "whole number"),
        ({"window": 10, "segment": True}, "whole number"),
        ({"window": 10, "segment": 3, "reference": "record"}, "drop segment"),
        ({"window": 10, "segment": 3, "reference": "past"}, "unknown reference"),
    ],
)
def test_contribution_errors(kwargs, match):
    with pytest.raises(AdavarInputError, match=match):
        kurtosis_contribution(_noise(100), **kwargs)


def test_segment_as_whole_float():
    x = _noise(100)
    np.testing.assert_array_equal(
        kurtosis_contribution(x, window=10, segment=3.0),
        kurtosis_contribution(x, window=10, segment=np.int32(3)),
    )


def test_bad_data():
    with pytest.raises(AdavarInputError, match="non-finite"):
        sliding_kurtosis(np.r_[_noise(10), np.nan], window=5)
    with pytest.raises(AdavarInputError, match="numeric"):
        kurtosis_contribution(["a", "b", "c", "d"], window=3, reference="record")


# ---------------------------------------------------------------------------------------
# properties


@st.composite
def records(draw, max_n=70):
    n = draw(st.integers(5, max_n))
    ints = draw(st.lists(st.integers(-1000, 1000), min_size=n, max_size=n))
    x = np.asarray(ints, dtype=np.float64)
    if draw(st.booleans()):
        x[draw(st.integers(0, n - 1)) :: draw(st.integers(1, 9))] *= 1e4  # bursts
    scale = draw(st.sampled_from([1e-13, 1e-3, 1.0, 1e12]))
    offset = draw(st.sampled_from([0.0, 1e6, -4e6]))
    drift = draw(st.sampled_from([0.0, 1e6]))
    return scale * (x / 577.0 + offset + np.linspace(0.0, drift, n))


def _windows(draw, n, step):
    if draw(st.booleans()):
        return draw(st.integers(3, n))
    size = n if draw(st.booleans()) or step == 1 else -(-n // step)
    return np.asarray(draw(st.lists(st.integers(3, n), min_size=size, max_size=size)))


def _span(draw):
    return draw(st.sampled_from([1, 8, 40, kmod._SPAN]))


@settings(deadline=None, max_examples=100)
@given(data=st.data())
def test_property_sliding_kurtosis(data):
    x = data.draw(records())
    step = data.draw(st.integers(1, 4))
    window = _windows(data.draw, x.size, step)
    edges = (
        "mirror"
        if np.ndim(window) and window.size != x.size
        else data.draw(st.sampled_from(["mirror", "valid"]))
    )
    saved = kmod._SPAN
    kmod._SPAN = _span(data.draw)
    try:
        centre, k = sliding_kurtosis(x, window=window, edges=edges, step=step, return_centres=True)
    except AdavarInputError:
        return  # no valid centre
    finally:
        kmod._SPAN = saved
    want_centre, want = reference.kurtosis_reference(x, window, edges=edges, step=step)
    np.testing.assert_array_equal(centre, want_centre)
    # the kurtosis of n samples reaches n: hold the error to 1e-9 of a kurtosis of 3
    np.testing.assert_allclose(k, want, rtol=ATOL / 3, atol=ATOL, equal_nan=True)


@settings(deadline=None, max_examples=100)
@given(data=st.data())
def test_property_contribution(data):
    x = data.draw(records())
    step = data.draw(st.integers(1, 4))
    form = data.draw(st.sampled_from(["window", "record"]))
    window = _windows(data.draw, x.size, step)
    shortest = int(np.min(window))
    if form == "window":
        if shortest < 5:
            window = np.maximum(window, 5) if np.ndim(window) else 5
            shortest = 5
        segment = data.draw(st.integers(1, shortest - 4))
    else:
        segment = None
    edges = (
        "mirror"
        if np.ndim(window) and window.size != x.size
        else data.draw(st.sampled_from(["mirror", "valid"]))
    )
    saved = kmod._SPAN, kmod._GRID
    kmod._SPAN = _span(data.draw)
    kmod._GRID = data.draw(st.sampled_from([1, 4, 16, kmod._GRID]))
    try:
        centre, S = kurtosis_contribution(
            x,
            window=window,
            segment=segment,
            reference=form,
            edges=edges,
            step=step,
            return_centres=True,
        )
    except AdavarInputError:
        return
    finally:
        kmod._SPAN, kmod._GRID = saved
    want_centre, want = reference.contribution_reference(
        x, window, segment, reference=form, edges=edges, step=step
    )
    np.testing.assert_array_equal(centre, want_centre)
    np.testing.assert_allclose(S, want, rtol=ATOL / 3, atol=ATOL, equal_nan=True)

"""The dynamic Allan variance engine against its definition, at every centre and every tau."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import adavar
from adavar.core.errors import AdavarInputError
from adavar.core.results import DavarResult
from adavar.dynamic import surface_common
from adavar.dynamic.surface import davar
from adavar.dynamic.surface_common import EDF_EXACT_LENGTHS, edf_table
from adavar.stats import edf as edf_mod

from . import reference

RTOL = 1e-9


def _noise(n, seed=0, scale=1.0):
    return scale * np.random.default_rng(seed).standard_normal(n)


def check(x, window, *, edges="mirror", step=1, data_type="rate", tau0=1.0, **kw):
    """Run davar and the reference; compare centres, lengths, m and every cell to 1e-9."""
    kw.setdefault("confidence", None)
    res = davar(x, window=window, edges=edges, step=step, data_type=data_type, tau0=tau0, **kw)
    centre, length, ms, want = reference.davar_reference(
        x, window, edges=edges, step=step, data_type=data_type, tau0=tau0, ms=res.m
    )
    np.testing.assert_array_equal(res.centre, centre)
    np.testing.assert_array_equal(res.window, length)
    assert res.avar.shape == (centre.size, ms.size)
    # equal_nan also checks that the NaN cells (3m > L) coincide
    np.testing.assert_allclose(res.avar, want, rtol=RTOL, atol=0.0, equal_nan=True)
    return res


def _all_ms(lengths):
    return np.arange(1, int(np.max(lengths)) // 3 + 1)


# ---------------------------------------------------------------------------------------
# fixed windows (DAVAR-L), mirrored edges


@pytest.mark.parametrize("L", [3, 4, 5, 20, 21, 64])
def test_fixed_window_every_centre(L):
    x = _noise(200, seed=L)
    res = check(x, L)
    np.testing.assert_array_equal(res.centre, np.arange(200))
    np.testing.assert_array_equal(res.m, _all_ms([L]))


@pytest.mark.parametrize("L", [29, 30])
def test_window_as_long_as_the_record(L):
    """Windows of the whole record: the edge windows are half mirror image."""
    x = _noise(L, seed=3)
    check(x, L)


def test_even_window_convention():
    """Even L holds L/2 - 1 samples before its centre and L/2 after it."""
    x = _noise(60, seed=4)
    L = 10
    res = davar(x, window=L, edges="valid", confidence=None)
    row = int(np.flatnonzero(res.centre == 30)[0])
    window = x[30 - 4 : 30 + 6]
    ms = res.m
    want = [reference.variance(window, int(m), "oadev") for m in ms]
    np.testing.assert_allclose(res.avar[row], want, rtol=RTOL)


# ---------------------------------------------------------------------------------------
# window schedules


def test_per_sample_random_lengths():
    rng = np.random.default_rng(11)
    x = _noise(250, seed=12)
    lengths = rng.integers(5, 41, size=x.size)
    res = check(x, lengths)
    np.testing.assert_array_equal(res.window, lengths)


def test_per_sample_smooth_schedule():
    n = 300
    k = np.arange(n)
    lengths = np.round(20 + 15 * np.sin(2 * np.pi * k / n)).astype(np.int64)
    res = check(_noise(n, seed=13), lengths)
    np.testing.assert_array_equal(res.window, lengths)


def test_per_sample_whole_float_lengths_accepted():
    x = _noise(120, seed=14)
    lengths = np.full(x.size, 9.0)
    res = check(x, lengths)
    np.testing.assert_array_equal(res.avar, davar(x, window=9, confidence=None).avar)


@pytest.mark.parametrize("step", [2, 3, 7])
def test_per_centre_lengths_with_step(step):
    n = 200
    rng = np.random.default_rng(step)
    lengths = rng.integers(5, 41, size=math.ceil(n / step))
    res = check(_noise(n, seed=15), lengths, step=step)
    np.testing.assert_array_equal(res.centre, np.arange(0, n, step))
    np.testing.assert_array_equal(res.window, lengths)


@pytest.mark.parametrize("step", [2, 5, 13])
@pytest.mark.parametrize("L", [16, 17])
def test_fixed_window_with_step(step, L):
    res = check(_noise(211, seed=step + L), L, step=step)
    np.testing.assert_array_equal(res.centre, np.arange(0, 211, step))


@pytest.mark.parametrize("L", [7, 11, 24])
def test_step_larger_than_window_direct_sums(L):
    """Windows far apart are summed directly instead of through a prefix."""
    x = _noise(400, seed=L)
    check(x, L, step=50)
    check(x + 1e6, L, step=3 * L, edges="valid")
    lengths = np.random.default_rng(L).integers(5, 30, size=x.size)
    check(x, lengths, step=45)


def test_mixed_dense_and_sparse_taus():
    """A step between L/3 and L: short taus go through the prefix, long ones may not."""
    x = _noise(300, seed=21)
    for step in (8, 12, 20):
        check(x, 24, step=step)


# ---------------------------------------------------------------------------------------
# edges="valid"


@pytest.mark.parametrize("L", [4, 9, 10])
@pytest.mark.parametrize("step", [1, 4])
def test_valid_edges_fixed(L, step):
    n = 97
    res = check(_noise(n, seed=L * step), L, edges="valid", step=step)
    start = res.centre - (L - 1) // 2
    assert np.all(start >= 0) and np.all(start + L <= n)
    every = np.arange(0, n, step)
    every_start = every - (L - 1) // 2
    fits = every[(every_start >= 0) & (every_start + L <= n)]
    np.testing.assert_array_equal(res.centre, fits)


def test_valid_edges_per_sample_lengths():
    n = 150
    lengths = np.random.default_rng(5).integers(5, 41, size=n)
    res = check(_noise(n, seed=6), lengths, edges="valid")
    np.testing.assert_array_equal(res.window, lengths[res.centre])
    check(_noise(n, seed=6), lengths, edges="valid", step=3)


def test_valid_window_equals_deviation_of_the_slice():
    x = _noise(180, seed=7) + 3.0
    for L in (12, 25):
        res = davar(x, window=L, edges="valid", confidence=None)
        for row in (0, 37, res.centre.size - 1):
            a = int(res.centre[row]) - (L - 1) // 2
            dev = adavar.deviation(x[a : a + L], stat="oadev", taus=res.tau, confidence=None)
            np.testing.assert_array_equal(dev.m, res.m)
            np.testing.assert_allclose(res.avar[row], dev.dev**2, rtol=RTOL)


# ---------------------------------------------------------------------------------------
# input kinds and hard numerics


@pytest.mark.parametrize("edges", ["mirror", "valid"])
def test_phase_input(edges):
    y = _noise(160, seed=8)
    x = np.concatenate([[0.0], np.cumsum(y)]) * 0.5 + 100.0
    res = check(x, 15, data_type="phase", tau0=0.5, edges=edges, rate=None)
    assert res.data_type == "phase"
    # the windows count the first differences of the phase
    if edges == "mirror":
        np.testing.assert_array_equal(res.centre, np.arange(160))
    rate = davar(np.diff(x) / 0.5, window=15, edges=edges, tau0=0.5, confidence=None)
    np.testing.assert_allclose(res.avar, rate.avar, rtol=1e-7, equal_nan=True)


def test_phase_input_schedule_and_step():
    x = np.cumsum(_noise(181, seed=9))
    lengths = np.random.default_rng(9).integers(6, 33, size=180)
    check(x, lengths, data_type="phase", tau0=2.0, rate=None, step=2)


def test_float32_input():
    x = _noise(150, seed=10).astype(np.float32) + np.float32(40.0)
    res = check(x, 19)
    assert res.avar.dtype == np.float64


def test_offset_and_drift():
    """A bias of 1e6 standard deviations plus a drift of 1e3 sigma across the record."""
    n = 400
    x = 1e6 + 1e3 * np.arange(n) / n + _noise(n, seed=16)
    check(x, 33)
    check(x, 20, step=3)
    check(x, np.random.default_rng(16).integers(5, 41, size=n))
    check(-x, 41, edges="valid", step=60)


def test_huge_offset_and_drift():
    """A bias of 1e9 standard deviations (only 7 digits of noise left in each sample)."""
    n = 300
    x = 1e9 + 1e4 * np.arange(n) / n + _noise(n, seed=34)
    check(x, 27)
    check(x, np.random.default_rng(34).integers(5, 41, size=n), step=2)


def _check_segment(res, x, window, lo, hi, *, tail=False):
    """Rows of a long-record ``res`` for windows inside ``x[lo:hi]`` (or its mirrored end)."""
    sub_window = window if np.ndim(window) == 0 else window[lo:hi]
    centre, length, _, want = reference.davar_reference(
        x[lo:hi], sub_window, edges="mirror" if tail else "valid", ms=res.m
    )
    keep = centre >= int(np.max(length)) if tail else slice(None)
    rows = np.searchsorted(res.centre, lo + centre[keep])
    np.testing.assert_array_equal(res.centre[rows], lo + centre[keep])
    np.testing.assert_array_equal(res.window[rows], length[keep])
    np.testing.assert_allclose(res.avar[rows], want[keep], rtol=RTOL, equal_nan=True)


@pytest.mark.parametrize("kind", ["fixed", "schedule"])
def test_long_record_across_anchor_blocks(kind):
    """Windows that straddle the 1024-sample anchor blocks of the integrated record."""
    n = 3100
    x = 1e6 + 1e3 * np.arange(n) / n + _noise(n, seed=35)
    x[1000:1010] += _noise(10, seed=36, scale=1e4)  # a burst just before a block boundary
    if kind == "fixed":
        window = 40
    else:
        window = np.random.default_rng(35).integers(5, 61, size=n)
    res = davar(x, window=window, confidence=None)
    for lo, hi in ((950, 1110), (1990, 2110)):
        _check_segment(res, x, window, lo, hi)
    _check_segment(res, x, window, n - 150, n, tail=True)


@pytest.mark.parametrize("case", ["level step of 1e3 sigma", "spike of 1e4 sigma"])
def test_offset_that_differs_from_the_first_block(case):
    """A bias step of 1e3 sigma, or a spike in the block that sets the shift: still 1e-9."""
    n = 3100
    x = _noise(n, seed=35)
    if case.startswith("level"):
        x[1100:] += 1e3
    else:
        x[1000:1010] *= 1e4
        x = 1e6 + x
    res = davar(x, window=40, confidence=None)
    for lo, hi in ((100, 300), (1200, 1400), (1990, 2110)):
        _check_segment(res, x, 40, lo, hi)


@pytest.mark.parametrize("kind", ["step", "spike"])
@pytest.mark.parametrize("size", [1e6, 1e8, 1e10, 1e12])
def test_huge_excursions_cost_no_digits(kind, size):
    """The window kernel keeps each span in double-double (adavar._kernels.window_avar): a
    spike or a level step of D sigma costs nothing after it (the single-double anchored
    phase lost ~1e-16 * D and ~1e-13 * D relative)."""
    n = 3100
    x = _noise(n, seed=35)
    if kind == "step":
        x[1100:] += size
    else:
        x[1000:1010] *= size
    res = davar(x, window=40, confidence=None, taus="octave")
    worst = 0.0
    for lo, hi in ((1010, 1600), (1600, 2400)):
        centre, _, _, ref = reference.davar_reference(x[lo:hi], 40, edges="valid", ms=res.m)
        worst = max(worst, float(np.nanmax(np.abs(res.avar[lo + centre] / ref - 1.0))))
    assert worst < 1e-15, worst  # measured: 4.4e-16 at worst


@pytest.mark.parametrize("scale", [1e-13, 1e12])
def test_extreme_scales(scale):
    x = _noise(200, seed=17, scale=scale) + 5.0 * scale
    res = check(x, 18)
    assert np.all(np.isfinite(res.avar[:, : 18 // 3]))
    check(x, np.random.default_rng(17).integers(5, 30, size=x.size), step=2)


def test_constant_and_integer_ramp():
    res = davar(np.full(50, 3.7), window=10)
    ok = np.isfinite(res.avar)
    assert np.all(res.avar[ok] == 0.0)
    assert np.all(res.avar_low[ok] == 0.0) and np.all(res.avar_high[ok] == 0.0)
    ramp = np.arange(50)  # integer input; rate ramp: every interior d_m is m**2
    res = check(ramp, 10)
    inner = (res.centre >= 4) & (res.centre <= 44)  # windows p-4 .. p+5 inside 0..49
    np.testing.assert_allclose(res.avar[inner], np.broadcast_to(res.m**2 / 2.0, (41, 3)))


@pytest.mark.parametrize("L", [11, 12])
def test_burst_next_to_quiet_windows(L):
    """Bursts 1e4 times larger than the noise, in every chunk: the prefix is compensated."""
    n = 300
    x = _noise(n, seed=18)
    for a in (20, 84, 148, 212, 280):
        x[a : a + 10] *= 1e4
    res = check(x, L)
    # the quiet windows right after a burst really are 1e8 times smaller
    quiet = res.avar[40, 0]
    loud = res.avar[25, 0]
    assert loud > 1e6 * quiet
    check(x, L, step=2)
    check(x, np.random.default_rng(18).integers(5, 25, size=n))


@pytest.mark.parametrize("taus", ["all", "octave", "decade", "explicit"])
def test_taus(taus):
    x = _noise(200, seed=19)
    L = 48
    spec = [0.5, 1.5, 3.5, 7.5] if taus == "explicit" else taus
    res = check(x, L, taus=spec, tau0=0.5, rate=None)
    want_m = {
        "all": np.arange(1, 17),
        "octave": np.array([1, 2, 4, 8, 16]),
        "decade": np.array([1, 2, 4, 10]),
        "explicit": np.array([1, 3, 7, 15]),
    }[taus]
    np.testing.assert_array_equal(res.m, want_m)
    np.testing.assert_allclose(res.tau, want_m * 0.5)


def test_rate_only_sets_the_time_axis_for_rate_data():
    x = _noise(100, seed=20)
    a = davar(x, window=15, rate=1.0, confidence=None)
    b = davar(x, window=15, rate=8.0, t0=2.0, confidence=None)
    np.testing.assert_array_equal(a.avar, b.avar)
    np.testing.assert_allclose(b.time, 2.0 + b.centre / 8.0)
    np.testing.assert_allclose(b.tau, b.m / 8.0)


# ---------------------------------------------------------------------------------------
# property tests


@st.composite
def _cases(draw):
    n = draw(st.integers(8, 90))
    kind = draw(st.sampled_from(["int", "per_sample", "per_centre"]))
    edges = draw(st.sampled_from(["mirror", "valid"]))
    step = draw(st.integers(1, 9))
    hi = min(n, 30)
    if kind == "int":
        window = draw(st.integers(3, hi))
    else:
        count = n if kind == "per_sample" or edges == "valid" else math.ceil(n / step)
        window = np.array(draw(st.lists(st.integers(3, hi), min_size=count, max_size=count)))
    offset = draw(st.sampled_from([0.0, 1.0, -1e3, 1e6]))
    drift = draw(st.sampled_from([0.0, 1e2]))
    seed = draw(st.integers(0, 2**32 - 1))
    x = _noise(n, seed=seed) + offset + drift * np.arange(n) / n
    return x, window, edges, step


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_cases())
def test_property_matches_reference(case):
    x, window, edges, step = case
    try:
        reference_centres = reference.davar_reference(x, window, edges=edges, step=step)[0]
    except ValueError:  # no window fits (max() of nothing)
        with pytest.raises(AdavarInputError):
            davar(x, window=window, edges=edges, step=step)
        return
    assert reference_centres.size > 0
    res = check(x, window, edges=edges, step=step)
    assert np.all(np.isnan(res.avar) == (3 * res.m[None, :] > res.window[:, None]))
    assert np.all(res.avar[~np.isnan(res.avar)] >= 0)


@settings(max_examples=40, deadline=None)
@given(
    st.integers(10, 60),
    st.integers(3, 10),
    st.sampled_from([1e-9, 1.0, 1e9]),
    st.integers(0, 2**32 - 1),
)
def test_property_offset_invariance(n, L, scale, seed):
    """A constant rate offset changes nothing (mirroring keeps it constant)."""
    offset = 1e6 * scale
    y = _noise(n, seed=seed, scale=scale) + offset
    a = davar(y - offset, window=L, confidence=None)  # exact (Sterbenz): same noise as y
    b = davar(y, window=L, confidence=None)
    np.testing.assert_allclose(b.avar, a.avar, rtol=1e-8, equal_nan=True)


# ---------------------------------------------------------------------------------------
# result attributes


def test_nan_exactly_where_the_tau_exceeds_a_third_of_the_window():
    n = 120
    lengths = np.random.default_rng(22).integers(3, 40, size=n)
    res = davar(_noise(n, seed=22), window=lengths, confidence=0.9)
    undefined = 3 * res.m[None, :] > res.window[:, None]
    np.testing.assert_array_equal(np.isnan(res.avar), undefined)
    np.testing.assert_array_equal(np.isnan(res.avar_low), undefined)
    np.testing.assert_array_equal(np.isnan(res.avar_high), undefined)
    np.testing.assert_array_equal(np.isnan(res.edf), undefined)
    np.testing.assert_array_equal(
        res.n_terms, np.where(undefined, 0, res.window[:, None] - 2 * res.m[None, :] + 1)
    )


def test_attributes():
    x = _noise(101, seed=23)
    res = davar(x, window=20, step=4, tau0=0.25, t0=10.0, rate=None, units="deg/s")
    assert isinstance(res, DavarResult)
    np.testing.assert_array_equal(res.centre, np.arange(0, 101, 4))
    assert res.centre.dtype == np.int64 and res.window.dtype == np.int64
    np.testing.assert_allclose(res.time, 10.0 + 0.25 * res.centre)
    np.testing.assert_array_equal(res.window, np.full(res.centre.size, 20))
    np.testing.assert_array_equal(res.m, np.arange(1, 7))
    np.testing.assert_allclose(res.tau, 0.25 * res.m)
    assert res.tau0 == 0.25 and res.rate == 4.0
    assert res.step == 4 and res.edges == "mirror" and res.data_type == "rate"
    assert res.n_samples == 101 and res.units == "deg/s"
    assert res.confidence == 0.683
    np.testing.assert_allclose(res.adev, np.sqrt(res.avar))
    np.testing.assert_allclose(res.adev_low, np.sqrt(res.avar_low))
    np.testing.assert_allclose(res.adev_high, np.sqrt(res.avar_high))
    meta = res.metadata()
    assert meta["statistic"] == "oadev" and meta["step"] == 4 and meta["n_samples"] == 101
    assert meta["units"] == "deg/s" and meta["edges"] == "mirror"


def test_bounds_are_the_chi2_interval_of_the_cell_edf():
    n = 200
    lengths = np.random.default_rng(24).integers(6, 45, size=n)
    # interior EDF everywhere, so the table has one row per length (edge rows: below)
    res = davar(_noise(n, seed=24), window=lengths, confidence=0.9, edge_edf="interior")
    ok = np.isfinite(res.avar)
    assert ok.sum() > 0
    assert np.all(res.avar_low[ok] < res.avar[ok])
    assert np.all(res.avar[ok] < res.avar_high[ok])
    lo, hi = edf_mod.chi2_interval(res.avar[ok], res.edf[ok], 0.9)
    np.testing.assert_allclose(res.avar_low[ok], lo, rtol=1e-12)
    np.testing.assert_allclose(res.avar_high[ok], hi, rtol=1e-12)
    # the table rows belong to the window lengths
    distinct = np.unique(res.window)
    assert res.edf_table.shape == (distinct.size, res.m.size)
    np.testing.assert_array_equal(distinct[res.window_class], res.window)
    np.testing.assert_array_equal(res.edf, res.edf_table[res.window_class])


def test_wider_confidence_gives_wider_bounds():
    x = _noise(100, seed=25)
    narrow = davar(x, window=30, confidence=0.5)
    wide = davar(x, window=30, confidence=0.95)
    ok = np.isfinite(narrow.avar)
    np.testing.assert_array_equal(narrow.avar, wide.avar)
    assert np.all(wide.avar_low[ok] < narrow.avar_low[ok])
    assert np.all(wide.avar_high[ok] > narrow.avar_high[ok])


def test_confidence_none_gives_no_bounds():
    x = _noise(80, seed=26)
    res = davar(x, window=21, confidence=None)
    assert res.avar_low is None and res.avar_high is None
    assert res.adev_low is None and res.adev_high is None
    assert res.edf is None
    np.testing.assert_array_equal(res.alpha, -1)
    assert math.isnan(res.confidence)
    np.testing.assert_array_equal(res.avar, davar(x, window=21).avar)


@pytest.mark.parametrize("alpha", [-2, -1, 0, 1, 2])
def test_noise_type_int_gives_exact_edf(alpha):
    n = 150
    lengths = np.random.default_rng(27).integers(6, 45, size=n)
    # at most EDF_EXACT_LENGTHS distinct lengths: every EDF is computed exactly
    lengths = 6 + (lengths - 6) % EDF_EXACT_LENGTHS
    assert np.unique(lengths).size <= EDF_EXACT_LENGTHS
    res = davar(_noise(n, seed=27), window=lengths, noise_type=alpha)
    np.testing.assert_array_equal(res.alpha, alpha)
    for row in range(0, n, 7):
        for col, m in enumerate(res.m):
            L = int(res.window[row])
            # a window reaching into the mirrored ends counts only its distinct samples
            start = int(res.centre[row]) - (L - 1) // 2
            h = max(0, -start) + max(0, start + L - n)
            if 3 * m > L:
                assert math.isnan(res.edf[row, col])
            else:
                terms, repeats = L - 2 * int(m) + 1, max(0, h - int(m))
                effective = max(1, round(terms**2 / (terms + 2 * repeats)))
                want = edf_mod.edf("oadev", alpha, int(m), effective + 2 * int(m))
                # edf_table's vectorised EDF: the scalar's to a few ulps (summation order)
                assert res.edf[row, col] == pytest.approx(want, rel=1e-12, abs=0)


def test_noise_type_per_tau():
    x = _noise(120, seed=28)
    res0 = davar(x, window=30, taus="octave", confidence=None)
    alphas = [0, -1, -2, 1][: res0.m.size]
    res = davar(x, window=30, taus="octave", noise_type=alphas, edge_edf="interior")
    np.testing.assert_array_equal(res.alpha, alphas)
    want = edf_table(np.array([30]), res.m, np.array(alphas))
    np.testing.assert_array_equal(res.edf_table, want)
    with pytest.raises(AdavarInputError):
        davar(x, window=30, taus="octave", noise_type=[*alphas, 0])
    with pytest.raises(AdavarInputError):
        davar(x, window=30, noise_type=3)
    with pytest.raises(AdavarInputError):
        davar(x, window=30, noise_type="white")


def test_noise_type_record_matches_deviation():
    x = np.cumsum(_noise(3000, seed=29))  # a random walk of rate
    res = davar(x, window=300, taus="octave", step=100)
    dev = adavar.deviation(x, stat="oadev", taus=res.tau)
    np.testing.assert_array_equal(res.alpha, dev.alpha)


# ---------------------------------------------------------------------------------------
# EDF table


@pytest.mark.parametrize("alpha", [-2, 0, 2])
def test_edf_table_exact_with_few_lengths(alpha):
    lengths = np.unique(np.random.default_rng(30).integers(3, 200, size=EDF_EXACT_LENGTHS))
    ms = np.array([1, 2, 3, 5, 9, 20, 40])
    tab = edf_table(lengths, ms, np.full(ms.size, alpha))
    for i, L in enumerate(lengths):
        for j, m in enumerate(ms):
            if 3 * m > L:
                assert math.isnan(tab[i, j])
            else:
                want = edf_mod.edf("oadev", alpha, int(m), int(L) + 1)
                assert tab[i, j] == pytest.approx(want, rel=1e-12, abs=0)


def _edf_interpolation_error(lengths, ms, alphas):
    worst = 0.0
    for alpha in alphas:
        tab = edf_table(lengths, ms, np.full(ms.size, alpha))
        for j, m in enumerate(ms):
            valid = 3 * m <= lengths
            assert np.all(np.isnan(tab[~valid, j]))
            exact = np.array(
                [edf_mod.edf("oadev", alpha, int(m), int(L) + 1) for L in lengths[valid]]
            )
            if exact.size:
                worst = max(worst, float(np.max(np.abs(tab[valid, j] / exact - 1.0))))
    return worst


def test_edf_table_is_exact_for_a_moderate_number_of_pairs():
    lengths = np.arange(5, 41)  # 36 lengths, e.g. an adaptive schedule between 5 and 40
    ms = np.array([1, 2, 3, 4, 5, 7, 10, 13])
    assert _edf_interpolation_error(lengths, ms, range(-2, 3)) < 1e-12  # exact, to ulps


LENGTH_SETS = [
    np.arange(5, 41),
    np.arange(3, 200),
    np.arange(400, 601),
    np.unique(np.geomspace(3, 5000, 80).astype(np.int64)),
]


@pytest.mark.parametrize("lengths", LENGTH_SETS, ids=["5-40", "3-199", "400-600", "geom-3-5000"])
def test_edf_table_interpolation_accuracy(lengths, monkeypatch):
    """Interpolated (forced here): < 1e-3 except flicker PM (< 2 %), as documented."""
    monkeypatch.setattr(surface_common, "EDF_EXACT_PAIRS", 0)
    assert lengths.size > EDF_EXACT_LENGTHS
    ms = np.array([1, 2, 3, 4, 5, 7, 10, 16, 20, 33, 50, 66, 100, 133])
    assert _edf_interpolation_error(lengths, ms, [-2, -1, 0, 2]) < 1e-3
    assert _edf_interpolation_error(lengths, ms, [1]) < 2e-2


# ---------------------------------------------------------------------------------------
# exports


def test_to_xarray():
    x = _noise(90, seed=31)
    res = davar(x, window=15, step=2, tau0=0.5, rate=None, units="m/s")
    ds = res.to_xarray()
    assert dict(ds.sizes) == {"time": res.centre.size, "tau": res.m.size}
    np.testing.assert_array_equal(ds["time"].values, res.time)
    np.testing.assert_array_equal(ds["tau"].values, res.tau)
    np.testing.assert_array_equal(ds["avar"].values, res.avar)
    np.testing.assert_array_equal(ds["avar_low"].values, res.avar_low)
    np.testing.assert_array_equal(ds["avar_high"].values, res.avar_high)
    np.testing.assert_array_equal(ds["window"].values, res.window)
    np.testing.assert_array_equal(ds["centre"].values, res.centre)
    np.testing.assert_array_equal(ds["m"].values, res.m)
    assert ds["avar"].attrs["units"] == "(m/s)^2"
    assert ds.attrs["step"] == 2
    bare = davar(x, window=15, confidence=None).to_xarray()
    assert "avar_low" not in bare and "avar_high" not in bare


def test_to_pandas():
    x = _noise(90, seed=32)
    res = davar(x, window=16, step=3)
    df = res.to_pandas()
    nt, nm = res.avar.shape
    assert len(df) == nt * nm
    assert {"time", "tau", "window", "avar", "avar_low", "avar_high"} <= set(df.columns)
    np.testing.assert_array_equal(df["avar"].to_numpy().reshape(nt, nm), res.avar)
    np.testing.assert_array_equal(df["avar_high"].to_numpy().reshape(nt, nm), res.avar_high)
    np.testing.assert_array_equal(df["time"].to_numpy().reshape(nt, nm)[:, 0], res.time)
    np.testing.assert_array_equal(df["tau"].to_numpy().reshape(nt, nm)[0], res.tau)
    np.testing.assert_array_equal(df["window"].to_numpy().reshape(nt, nm)[:, 0], res.window)
    assert df.attrs["statistic"] == "oadev"
    bare = davar(x, window=16, confidence=None).to_pandas()
    assert "avar_low" not in bare.columns


# ---------------------------------------------------------------------------------------
# bad input


X = np.random.default_rng(33).standard_normal(50)
NAN_X = X.copy()
NAN_X[17] = np.nan

BAD = {
    "window 2": dict(window=2),
    "window 0": dict(window=0),
    "window -5": dict(window=-5),
    "window longer than the record": dict(window=51),
    "window array too short": dict(window=np.full(49, 10)),
    "window array one per centre without step": dict(window=np.full(25, 10), step=1),
    "window array with a short length": dict(window=np.r_[np.full(49, 10), 2]),
    "window array with a long length": dict(window=np.r_[np.full(49, 10), 51]),
    "window array 2-D": dict(window=np.full((5, 10), 10)),
    "window array empty": dict(window=np.array([], dtype=int)),
    "window array of fractions": dict(window=np.full(50, 10.5)),
    "window array with nan": dict(window=np.r_[np.full(49, 10.0), np.nan]),
    "window array of strings": dict(window=np.full(50, "10")),
    "window bool": dict(window=True),
    "step 0": dict(window=10, step=0),
    "step -1": dict(window=10, step=-1),
    "step float": dict(window=10, step=2.0),
    "step bool": dict(window=10, step=True),
    "edges": dict(window=10, edges="reflect"),
    "data_type": dict(window=10, data_type="angle"),
    "rate 0": dict(window=10, rate=0.0),
    "rate -1": dict(window=10, rate=-1.0),
    "tau0 0": dict(window=10, tau0=0.0),
    "rate and tau0": dict(window=10, rate=2.0, tau0=0.5),
    "nan in data": dict(window=10, data=NAN_X),
    "inf in data": dict(window=10, data=np.r_[X[:-1], np.inf]),
    "too short": dict(window=3, data=X[:2]),
    "2-D data": dict(window=3, data=np.ones((5, 5))),
    "confidence 0": dict(window=10, confidence=0.0),
    "confidence 1": dict(window=10, confidence=1.0),
    "confidence 1.5": dict(window=10, confidence=1.5),
    "confidence -0.1": dict(window=10, confidence=-0.1),
    "valid: no centre fits": dict(window=50, step=5, edges="valid"),
    "valid: no per-sample window fits": dict(
        window=np.r_[np.full(25, 3), np.full(25, 50)], step=25, edges="valid"
    ),
    "taus keyword": dict(window=10, taus="weekly"),
    "taus outside the window": dict(window=10, taus=[100.0]),
    "t0": dict(window=10, t0="noon"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_raises_one_line(case):
    kw = dict(BAD[case])
    data = kw.pop("data", X)
    with pytest.raises(AdavarInputError) as info:
        davar(data, **kw)
    message = str(info.value)
    assert message and "\n" not in message
    assert isinstance(info.value, ValueError)


@pytest.mark.parametrize("window", [7.5, 7.0, np.float64(7.0)])
def test_float_scalar_window(window):
    if float(window).is_integer():
        res = davar(X, window=window, confidence=None)
        np.testing.assert_array_equal(res.avar, davar(X, window=7, confidence=None).avar)
    else:
        with pytest.raises(AdavarInputError):
            davar(X, window=window)


def test_integer_like_windows_accepted():
    want = davar(X, window=7, confidence=None).avar
    for window in (np.int64(7), np.int32(7), np.array(7), np.full(50, 7, dtype=np.int32)):
        np.testing.assert_array_equal(davar(X, window=window, confidence=None).avar, want)


def test_edge_windows_count_distinct_samples():
    # issue 11: a mirrored window's EDF is that of its distinct samples, not the interior's
    x = _noise(400, seed=31)
    res = davar(x, window=101, taus=[1, 4, 16], noise_type=0)
    interior = davar(x, window=101, taus=[1, 4, 16], noise_type=0, edge_edf="interior")
    np.testing.assert_array_equal(res.avar, interior.avar)
    assert np.all(res.edf[0] < interior.edf[0])  # centre 0: 50 mirrored samples
    # centre 0: 50 mirrored samples, M = 94 terms at m = 4 of which 46 repeat
    assert res.edf[0, 1] == pytest.approx(
        edf_mod.edf("oadev", 0, 4, round(94**2 / (94 + 92)) + 8), rel=1e-12
    )
    # more than EDF_EXACT_LENGTHS counts at a tau: exact at nodes, interpolated between them
    for c in range(0, 51, 7):
        terms = 101 - 2 * 4 + 1
        repeats = max(0, 50 - c - 4)
        exact = edf_mod.edf("oadev", 0, 4, round(terms**2 / (terms + 2 * repeats)) + 8)
        assert res.edf[c, 1] == pytest.approx(exact, rel=1e-3)
    np.testing.assert_array_equal(res.edf[50:350], interior.edf[50:350])
    assert np.all(np.diff(res.edf[:51, 0]) >= -1e-12 * res.edf[50, 0])  # grows back
    np.testing.assert_array_equal(res.edf[::-1][:51], res.edf[:51])  # both ends alike
    with pytest.raises(AdavarInputError, match="edge_edf"):
        davar(x, window=101, edge_edf="nearest")


@pytest.mark.parametrize("gaps", [False, True])
def test_without_bounds_the_rest_is_the_same(gaps):
    """bounds=False: no bound table nor bounds; avar, alpha and the EDF table unchanged."""
    x = adavar.simulate.sensor(
        6000, rate=200.0, angle_random_walk=0.01, bias_instability=0.003, bandwidth=40.0,
        lsb=1 / 131, seed=4,
    )  # fmt: skip
    kw = {}
    if gaps:
        x[1000:1040] = np.nan
        kw["gaps"] = "omit"
    full = davar(x, window=np.r_[np.full(3000, 400), np.full(3000, 900)], rate=200.0, **kw)
    lean = davar(x, window=np.r_[np.full(3000, 400), np.full(3000, 900)], rate=200.0,
                 bounds=False, **kw)  # fmt: skip
    assert full.avar_low is not None and full.bound_table is not None
    assert lean.avar_low is None and lean.avar_high is None and lean.bound_table is None
    np.testing.assert_array_equal(lean.avar, full.avar)
    np.testing.assert_array_equal(lean.alpha, full.alpha)
    np.testing.assert_array_equal(lean.edf_table, full.edf_table)
    np.testing.assert_array_equal(lean.window_class, full.window_class)

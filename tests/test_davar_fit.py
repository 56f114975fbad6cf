"""Time-varying noise coefficients: the noise-model fit of every DAVAR window at once."""

from __future__ import annotations

import numpy as np
import pytest

import adavar
from adavar import fit_avar, fit_noise


@pytest.fixture(scope="module")
def step_change():
    """White noise of unit deviation whose deviation triples in 3000-4000 s (6000 s at 1 Hz)."""
    x = np.random.default_rng(2018).standard_normal(6000)
    x[3000:4000] *= 3.0
    return x


@pytest.mark.parametrize("taus", ["all", "octave"])
def test_arw_tracks_a_tripled_noise_level(step_change, taus):
    result = adavar.davar(step_change, window=600, taus=taus)
    fit = fit_noise(result)
    n_t = fit.angle_random_walk.value
    assert n_t.shape == (6000,)
    np.testing.assert_array_equal(fit.time, result.time)
    quiet = np.r_[0:2600, 4400:6000]  # windows that do not reach into the change
    inside = np.r_[3300:3700]  # windows entirely inside it
    assert np.median(n_t[quiet]) == pytest.approx(1.0, abs=0.05)
    assert np.median(n_t[inside]) == pytest.approx(3.0, abs=0.15)
    # the uncertainty is a fraction of the value, and scales with it
    sigma = fit.angle_random_walk.uncertainty
    assert np.all(np.isfinite(sigma))
    assert 0.005 < np.median(sigma[quiet] / n_t[quiet]) < 0.2
    # the change shows in time: halfway through the ramp-up of the windows
    crossing = np.argmax(n_t > 2.0)
    assert 3000 - 300 < crossing < 3000 + 300


def test_stack_fit_equals_single_window_fits(step_change):
    result = adavar.davar(step_change, window=600, taus="octave")
    stack = fit_noise(result)
    for p in (0, 17, 2999, 3333, 5999):
        single = fit_avar(result.tau, result.avar[p], result.edf[p])
        np.testing.assert_array_equal(stack.coefficients[p], single.coefficients)
        np.testing.assert_array_equal(
            stack.coefficient_uncertainty[p], single.coefficient_uncertainty
        )


def test_fit_skips_taus_beyond_a_third_of_short_windows():
    x = np.random.default_rng(5).standard_normal(4000)
    windows = np.where(np.arange(4000) < 2000, 150, 600)
    result = adavar.davar(x, window=windows, taus="all")
    assert np.isnan(result.avar[:1900, 50:]).all()  # m > 50 undefined in 150-sample windows
    fit = fit_noise(result, terms=("angle_random_walk",))
    n_t = fit.angle_random_walk.value
    assert np.isfinite(n_t).all()
    assert np.all(fit.n_points[:1900] == 50)
    assert np.median(n_t) == pytest.approx(1.0, abs=0.05)


def test_octave_spacing_weights_leave_octave_grids_alone():
    x = np.random.default_rng(9).standard_normal(2**14)
    dev = adavar.deviation(x)
    a = fit_noise(dev)
    b = fit_noise(dev, spacing="independent")
    np.testing.assert_array_equal(a.coefficients, b.coefficients)


def test_octave_spacing_downweights_dense_grids(step_change):
    result = adavar.davar(step_change[:3000], window=600, taus="all")
    dense = fit_noise(result, spacing="independent")
    octave = fit_noise(result)
    # counted as independent, the correlated dense long-tau points invent a quantization
    # term in many windows and pull N low; per-octave weights do not
    q_dense = np.mean(dense.quantization.value > 0)
    q_octave = np.mean(octave.quantization.value > 0)
    assert q_octave < q_dense
    err_dense = abs(np.median(dense.angle_random_walk.value) - 1.0)
    err_octave = abs(np.median(octave.angle_random_walk.value) - 1.0)
    assert err_octave < err_dense
    with pytest.raises(ValueError, match="spacing"):
        fit_noise(result, spacing="dense")


def test_fit_needs_bounds():
    x = np.random.default_rng(1).standard_normal(1000)
    result = adavar.davar(x, window=300, taus="octave", confidence=None)
    with pytest.raises(ValueError, match="edf"):
        fit_noise(result)


def test_windows_fitted_against_a_reference_that_misses_its_curve_say_so():
    # a Gauss-Markov hump the five terms cannot describe (markov="none"): the whole-record
    # fit that gives the windows their roll-off reference is inadequate, and every window
    # inherits it (an independent audit found window fits silent about that)
    from adavar import simulate

    x = simulate.sensor(200_000, rate=10.0, angle_random_walk=1e-3, markov=(0.05, 30.0), seed=2)
    surface = adavar.davar(x, rate=10.0, window=20_000, step=5_000, taus="octave")
    windows = fit_noise(surface, markov="none")
    assert "does not describe the record" in windows.reference_warning
    assert "Gauss-Markov" in windows.reference_warning
    assert windows.warnings == (windows.reference_warning,)
    # the reference with its hump describes the record: nothing to say
    assert fit_noise(surface).warnings == ()
    assert fit_noise(surface, reference=None, markov="none").warnings == ()


def test_a_filters_rolloff_follows_each_windows_white_level():
    # behind a low-pass filter the roll-off is the filter acting on the white noise: inside
    # a stretch of doubled noise it is four times the record's. Taken out as the record's
    # fixed variance it put N 3.6 % low there, 63 % of the 5-minute windows beyond 3 sigma
    # (an independent audit); riding on each window's white term, as outside the stretch
    from tests.independent_noise import changing, low_pass

    x, _ = changing("step", 3600, 100.0, 5, N=1e-3, at=1500.0, length=600.0, factor=2.0)
    x = low_pass(x, 10.0, 100.0)
    surface = adavar.davar(x, rate=100.0, window=30_000, step=1_500, taus="octave")
    fit = fit_noise(surface)
    centre = np.asarray(surface.centre) / 100.0
    inside = (centre - 150.0 >= 1500.0) & (centre + 150.0 < 2100.0)
    outside = (centre + 150.0 < 1500.0) | (centre - 150.0 >= 2100.0)
    n = np.asarray(fit.angle_random_walk.value)
    ratio_in = np.mean(n[inside]) / (2e-3)
    ratio_out = np.mean(n[outside]) / 1e-3
    assert inside.sum() >= 5 and outside.sum() >= 20
    assert abs(ratio_in - ratio_out) < 0.01, (ratio_in, ratio_out)
    assert ratio_in == pytest.approx(1.0, abs=0.03)

"""Tests of adavar.fit.noise_model (the IEEE noise-model fit) and adavar.core.units."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import nnls

from adavar.core.results import DeviationResult
from adavar.core.units import RATE_UNITS, conventional_units, convert, convert_coefficient
from adavar.fit.noise_model import TERM_NAMES, NoiseFit, fit_avar, fit_noise

POWERS = np.arange(-2, 3)
K_FACTORS = np.array([3.0, 1.0, 2.0 * math.log(2.0) / math.pi, 1.0 / 3.0, 0.5])
OCTAVE = 2.0 ** np.arange(0, 17)


# ----------------------------------------------------------------------------- helpers


def model_avar(coefficients: np.ndarray, tau: np.ndarray) -> np.ndarray:
    return (np.asarray(coefficients)[..., None, :] * tau[:, None] ** POWERS).sum(-1)


def coefficients_from_values(q=0.0, n=0.0, b=0.0, k=0.0, r=0.0) -> np.ndarray:
    return K_FACTORS * np.array([q, n, b, k, r]) ** 2


def oadev_avar(y: np.ndarray, ms: np.ndarray) -> np.ndarray:
    """Overlapping Allan variance of rate samples at tau0 = 1 (METHOD.md section 1)."""
    theta = np.concatenate(([0.0], np.cumsum(y)))
    out = np.empty(ms.size)
    for i, m in enumerate(ms):
        d = theta[2 * m :] - 2.0 * theta[m:-m] + theta[: -2 * m]
        out[i] = np.mean(d**2) / (2.0 * m * m)
    return out


def edf_oadev(n_phase: int, m: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """SP 1065 simple EDF approximations of the overlapping Allan variance.

    alpha 0 (white FM, the angle random walk) or -2 (random-walk FM, the rate random walk).
    """
    n = float(n_phase)
    m = np.asarray(m, dtype=float)
    white = (3.0 * (n - 1.0) / (2.0 * m) - 2.0 * (n - 2.0) / n) * 4.0 * m**2 / (4.0 * m**2 + 5.0)
    rw = (n - 2.0) / m * ((n - 1.0) ** 2 - 3.0 * m * (n - 1.0) + 4.0 * m**2) / (n - 3.0) ** 2
    return np.where(alpha == 0, white, rw)


def simulate_nk(n_true: float, k_true: float, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    white = n_true * rng.standard_normal(n)
    walk = np.cumsum(k_true * rng.standard_normal(n))
    return white + walk


def deviation_result(tau, avar, edf, stat="oadev", units=None) -> DeviationResult:
    """A DeviationResult built by hand (what adavar.stats.statistics.deviation returns)."""
    tau = np.asarray(tau, dtype=float)
    dev = np.sqrt(avar)
    nan = np.full(tau.shape, np.nan)
    return DeviationResult(
        tau=tau, dev=dev, dev_low=nan, dev_high=nan, edf=np.asarray(edf, dtype=float),
        n=nan, m=tau.astype(int), alpha=nan, stat=stat, data_type="rate", tau0=1.0,
        confidence=0.683, n_samples=0, units=units,
    )  # fmt: skip


def simulated_result(n_true, k_true, n, seed):
    y = simulate_nk(n_true, k_true, n, seed)
    ms = 2 ** np.arange(int(np.log2((n - 1) // 2)) + 1)
    avar = oadev_avar(y, ms)
    # noise type known from the truth: the dominant term at each tau
    alpha = np.where(n_true**2 / ms > k_true**2 * ms / 3.0, 0, -2)
    return deviation_result(ms.astype(float), avar, edf_oadev(n + 1, ms, alpha))


def noisy_curves(n_curves: int, coefficients, tau, edf, seed: int) -> np.ndarray:
    """Chi-square-distributed avar estimates around a model (independent taus)."""
    rng = np.random.default_rng(seed)
    truth = model_avar(coefficients, tau)
    return truth * rng.chisquare(edf, size=(n_curves, tau.size)) / edf


def scipy_irls(tau, avar, edf, terms, n_reweight):
    """Reference: the same reweighting loop around scipy.optimize.nnls."""
    sel = [TERM_NAMES.index(t) for t in terms]
    basis = tau[:, None] ** POWERS[sel]
    scale = np.sqrt((basis**2).sum(0))  # column scaling, the same problem reparametrised
    ok = np.isfinite(avar) & np.isfinite(edf)
    ref = avar.copy()
    for _ in range(n_reweight + 1):
        sw = np.sqrt(edf[ok] / (2.0 * ref[ok] ** 2))
        x, _ = nnls(sw[:, None] * basis[ok] / scale, sw * avar[ok])
        c = x / scale
        model = basis @ c
        ref = np.where(model > 0, model, avar)
    out = np.zeros(5)
    out[sel] = c
    return out


# ----------------------------------------------------------------------------- exact fits


def test_exact_recovery_noise_free_all_terms():
    values = dict(q=2e-3, n=1e-2, b=3e-4, k=1e-4, r=2e-7)
    c = coefficients_from_values(**values)
    tau = OCTAVE
    fit = fit_avar(tau, model_avar(c, tau), np.full(tau.size, 50.0))
    np.testing.assert_allclose(fit.coefficients, c, rtol=1e-9, atol=0)
    for name, v in zip(TERM_NAMES, values.values(), strict=True):
        np.testing.assert_allclose(fit.term(name).value, v, rtol=1e-9)
    assert fit.chi2 < 1e-20
    np.testing.assert_allclose(fit.fitted_avar, model_avar(c, tau), rtol=1e-12)
    assert fit.active.all()


@pytest.mark.parametrize("n_reweight", [0, 1, 4])
def test_exact_recovery_is_independent_of_reweighting_and_edf(n_reweight):
    c = coefficients_from_values(q=1e-1, n=3e-2, b=1e-3, k=5e-5, r=1e-8)
    tau = np.geomspace(0.01, 3e4, 25)
    edf = np.geomspace(1e4, 2.0, tau.size)
    fit = fit_avar(tau, model_avar(c, tau), edf, n_reweight=n_reweight)
    np.testing.assert_allclose(fit.coefficients, c, rtol=1e-9)


def test_single_curve_outputs_are_scalars_with_documented_units():
    c = coefficients_from_values(n=1e-2, k=1e-4)
    fit = fit_avar(OCTAVE, model_avar(c, OCTAVE), np.full(OCTAVE.size, 10.0))
    assert np.ndim(fit.angle_random_walk.value) == 0
    assert fit.coefficients.shape == (5,)
    assert fit.fitted_avar.shape == (OCTAVE.size,)
    # model_dev anywhere, term asymptotes
    t = np.array([0.5, 3.0, 1e5])
    np.testing.assert_allclose(fit.model_dev(t), np.sqrt(1e-4 / t + 1e-8 * t / 3), rtol=1e-9)
    np.testing.assert_allclose(fit.term_dev("angle_random_walk", t), 1e-2 / np.sqrt(t), rtol=1e-9)
    np.testing.assert_allclose(
        fit.term_dev("rate_random_walk", t), 1e-4 * np.sqrt(t / 3), rtol=1e-9
    )
    np.testing.assert_allclose(fit.fitted_dev, fit.model_dev(OCTAVE))


# ----------------------------------------------------------------------------- statistics


def test_recovers_n_and_k_on_simulated_white_plus_rate_random_walk():
    n_true, k_true = 1e-2, 1e-4
    rel_n, rel_k, z_n, z_k = [], [], [], []
    for seed in range(8):
        res = simulated_result(n_true, k_true, 100_000, seed)
        fit = fit_noise(res, terms=("angle_random_walk", "rate_random_walk"))
        n_fit, k_fit = fit.angle_random_walk, fit.rate_random_walk
        rel_n.append(n_fit.value / n_true - 1)
        rel_k.append(k_fit.value / k_true - 1)
        z_n.append((n_fit.value - n_true) / n_fit.uncertainty)
        z_k.append((k_fit.value - k_true) / k_fit.uncertainty)
        assert fit.quantization.value == 0 and np.isnan(fit.quantization.uncertainty)
    rel_n, rel_k = np.abs(rel_n), np.abs(rel_k)
    # statistical tolerances: N is known to ~0.3 %, K to ~5 % from 1e5 samples
    assert rel_n.max() < 0.015, rel_n
    assert rel_k.max() < 0.25, rel_k
    assert np.median(rel_k) < 0.08, rel_k
    # the uncertainties are of the right size: not wildly small nor large
    for z in (np.asarray(z_n), np.asarray(z_k)):
        rms = np.sqrt(np.mean(z**2))
        assert 0.3 < rms < 3.5, z


def test_reweighting_removes_the_low_bias_of_measured_weights():
    # measured avar in the weights favours points that fell low: the fitted K is biased low
    n_true, k_true = 1e-2, 1e-4
    tau = OCTAVE
    ms = tau.astype(int)
    c = coefficients_from_values(n=n_true, k=k_true)
    alpha = np.where(n_true**2 / ms > k_true**2 * ms / 3.0, 0, -2)
    edf = edf_oadev(200_001, ms, alpha)
    curves = noisy_curves(4000, c, tau, edf, seed=7)
    terms = ("angle_random_walk", "rate_random_walk")
    k0 = fit_avar(tau, curves, edf, terms=terms, n_reweight=0).rate_random_walk.value
    k3 = fit_avar(tau, curves, edf, terms=terms, n_reweight=3).rate_random_walk.value
    # measured: mean -8 %, scatter 18 % with n_reweight=0; -0.1 %, 2 % with 3 reweights
    assert np.mean(k0) / k_true - 1 < -0.05  # the bias this option exists for
    assert abs(np.mean(k3) / k_true - 1) < 0.005
    assert np.std(k3) < 0.3 * np.std(k0)


# ----------------------------------------------------------------------------- the constraint


def _curve_without_ramp():
    """A curve with no ramp that bends down at long tau, with a +-5 % zigzag (chi2 > dof)."""
    c = coefficients_from_values(n=1e-2, k=1e-4)
    tau = OCTAVE
    edf = np.geomspace(5e4, 3.0, tau.size)
    zigzag = 1.0 + 0.05 * (-1.0) ** np.arange(tau.size)
    avar = model_avar(c, tau) * (1.0 - 0.3 * (tau / tau[-1]) ** 0.5) * zigzag
    return tau, avar, edf


def test_constraint_pins_an_absent_ramp_at_zero():
    tau, avar, edf = _curve_without_ramp()
    # unconstrained weighted LS wants a negative C_2 here
    basis = tau[:, None] ** POWERS
    sw = np.sqrt(edf / (2.0 * avar**2))
    unconstrained = np.linalg.lstsq(sw[:, None] * basis, sw * avar, rcond=None)[0]
    assert unconstrained[4] < 0
    fit = fit_avar(tau, avar, edf, n_reweight=0)
    assert fit.rate_ramp.value == 0.0
    assert fit.coefficients[4] == 0.0
    assert not fit.active[4]
    assert np.isfinite(fit.rate_ramp.uncertainty) and fit.rate_ramp.uncertainty > 0
    assert (fit.coefficients >= 0).all()
    np.testing.assert_allclose(
        fit.coefficients, scipy_irls(tau, avar, edf, TERM_NAMES, 0), rtol=1e-8, atol=0
    )


def test_pinned_term_uncertainty_is_an_upper_bound_from_the_unconstrained_covariance():
    tau, avar, edf = _curve_without_ramp()
    fit = fit_avar(tau, avar, edf, n_reweight=0)
    assert not fit.active.all()
    # final weights = first-pass weights (n_reweight=0): edf / (2 avar^2)
    w = edf / (2.0 * avar**2)
    basis = tau[:, None] ** POWERS
    full_cov = np.linalg.inv(basis.T @ (w[:, None] * basis))
    active = fit.active
    act_cov = np.linalg.inv(basis[:, active].T @ (w[:, None] * basis[:, active]))
    resid = avar - basis @ fit.coefficients
    chi2 = np.sum(w * resid**2)
    np.testing.assert_allclose(fit.chi2, chi2, rtol=1e-9)
    assert chi2 / (tau.size - 5) > 2  # the scatter exceeds the weights: covariance inflated
    factor = max(1.0, chi2 / (tau.size - 5))
    sig = np.sqrt(np.diag(act_cov) * factor)
    np.testing.assert_allclose(fit.coefficient_uncertainty[active], sig, rtol=1e-7)
    c_act = fit.coefficients[active]
    np.testing.assert_allclose(
        [fit.term(n).uncertainty for n, a in zip(TERM_NAMES, active, strict=True) if a],
        sig / (2.0 * np.sqrt(K_FACTORS[active] * c_act)),
        rtol=1e-7,
    )
    sig_full = np.sqrt(np.diag(full_cov) * factor)
    for k in np.flatnonzero(~active):
        np.testing.assert_allclose(fit.coefficient_uncertainty[k], sig_full[k], rtol=1e-7)
        np.testing.assert_allclose(
            fit.term(TERM_NAMES[k]).uncertainty, np.sqrt(sig_full[k] / K_FACTORS[k]), rtol=1e-7
        )


@pytest.mark.parametrize("n_reweight", [0, 3])
def test_agrees_with_scipy_nnls_on_the_weighted_problem(n_reweight):
    tau = np.geomspace(1.0, 5e4, 14)
    edf = np.geomspace(2e4, 2.0, tau.size)
    c = coefficients_from_values(q=1e-3, n=1e-2, b=2e-4, k=1e-4, r=1e-8)
    curves = noisy_curves(40, c, tau, edf, seed=3)
    fit = fit_avar(tau, curves, edf, n_reweight=n_reweight)
    n_pinned = 0
    for i, avar in enumerate(curves):
        ref = scipy_irls(tau, avar, edf, TERM_NAMES, n_reweight)
        np.testing.assert_allclose(fit.coefficients[i], ref, rtol=1e-8, atol=0)
        n_pinned += int((ref == 0).sum())
    assert n_pinned > 10  # the constraint was active in many curves


def test_agrees_with_scipy_for_a_subset_of_terms():
    tau = OCTAVE[:12]
    edf = np.geomspace(1e4, 5.0, tau.size)
    c = coefficients_from_values(n=1e-2, b=1e-3, k=1e-5)
    curves = noisy_curves(20, c, tau, edf, seed=4)
    terms = ("rate_random_walk", "angle_random_walk", "bias_instability")  # any order
    fit = fit_avar(tau, curves, edf, terms=terms)
    assert fit.terms == ("angle_random_walk", "bias_instability", "rate_random_walk")
    for i, avar in enumerate(curves):
        np.testing.assert_allclose(
            fit.coefficients[i], scipy_irls(tau, avar, edf, fit.terms, 3), rtol=1e-8, atol=0
        )
    assert (fit.coefficients[:, [0, 4]] == 0).all()
    assert np.isnan(fit.rate_ramp.uncertainty).all()
    assert (fit.rate_ramp.value == 0).all()


# ----------------------------------------------------------------------------- stacks


def _stack_with_holes():
    tau = OCTAVE[:10]
    edf = np.geomspace(3e3, 3.0, tau.size)
    c = coefficients_from_values(q=5e-3, n=1e-2, b=3e-4, k=1e-4)
    curves = noisy_curves(60, c, tau, edf, seed=11)
    edf2 = np.broadcast_to(edf, curves.shape).copy()
    rng = np.random.default_rng(5)
    for i in range(60):  # DAVAR-like: NaN beyond a per-window limit, and scattered holes
        curves[i, rng.integers(5, 11) :] = np.nan
        if i % 7 == 0:
            edf2[i, rng.integers(0, 5)] = np.nan
    curves[3] = np.nan  # nothing at all
    curves[4, 4:] = np.nan  # 4 points < 5 terms
    return tau, curves, edf2


@pytest.mark.parametrize("repeat", [1, 20])  # 60 curves: one thread; 1200: in threads
def test_stack_equals_curve_by_curve_bit_for_bit(repeat, monkeypatch):
    from adavar._kernels import _jit

    monkeypatch.setattr(_jit, "SERIAL_WORK", 0)  # blocks in threads from 1024 curves
    tau, curves, edf = _stack_with_holes()
    fit = fit_avar(tau, np.tile(curves, (repeat, 1)), np.tile(edf, (repeat, 1)))
    assert fit.coefficients.shape == (60 * repeat, 5)
    for i in range(curves.shape[0] * repeat):
        one = fit_avar(tau, curves[i % 60], edf[i % 60])
        np.testing.assert_array_equal(one.coefficients, fit.coefficients[i])
        np.testing.assert_array_equal(one.coefficient_uncertainty, fit.coefficient_uncertainty[i])
        np.testing.assert_array_equal(one.chi2, fit.chi2[i])
        np.testing.assert_array_equal(one.n_points, fit.n_points[i])
        for name in TERM_NAMES:
            np.testing.assert_array_equal(one.term(name).value, fit.term(name).value[i])
            np.testing.assert_array_equal(one.term(name).uncertainty, fit.term(name).uncertainty[i])


def test_stack_with_several_leading_dimensions():
    tau, curves, edf = _stack_with_holes()
    fit = fit_avar(tau, curves.reshape(6, 10, tau.size), edf.reshape(6, 10, tau.size))
    flat = fit_avar(tau, curves, edf)
    assert fit.angle_random_walk.value.shape == (6, 10)
    assert fit.fitted_avar.shape == (6, 10, tau.size)
    assert fit.model_dev([1.0, 2.0, 3.0]).shape == (6, 10, 3)
    assert fit.term_dev("bias_instability", 5.0).shape == (6, 10)
    np.testing.assert_array_equal(fit.coefficients.reshape(60, 5), flat.coefficients)


def test_shared_edf_row_equals_per_curve_edf():
    tau, curves, _ = _stack_with_holes()
    edf = np.geomspace(3e3, 3.0, tau.size)
    shared = fit_avar(tau, curves, edf)
    for per_curve in (np.tile(edf, (60, 1)), edf[None, :]):
        np.testing.assert_array_equal(
            fit_avar(tau, curves, per_curve).coefficients, shared.coefficients
        )
    scalar = fit_avar(tau, curves, 7.0)
    np.testing.assert_array_equal(
        scalar.coefficients, fit_avar(tau, curves, np.full((60, tau.size), 7.0)).coefficients
    )


def test_nan_points_are_ignored_and_short_curves_are_nan():
    tau, curves, edf = _stack_with_holes()
    fit = fit_avar(tau, curves, edf)
    assert fit.n_points[3] == 0 and fit.n_points[4] == 4
    for i in (3, 4):
        assert np.isnan(fit.coefficients[i]).all()
        assert np.isnan(fit.angle_random_walk.value[i])
        assert np.isnan(fit.chi2[i]) and fit.dof[i] == 0
    # a curve with holes gives the fit of its valid points alone
    i = 7  # has a NaN edf
    ok = np.isfinite(curves[i]) & np.isfinite(edf[i])
    assert 5 <= ok.sum() < tau.size
    sub = fit_avar(tau[ok], curves[i, ok], edf[i, ok])
    np.testing.assert_allclose(fit.coefficients[i], sub.coefficients, rtol=1e-9, atol=0)
    assert fit.n_points[i] == ok.sum() and fit.dof[i] == ok.sum() - 5


@pytest.mark.parametrize("cells", [True, False])
def test_dense_taus_count_each_point_by_its_octave_share(cells):
    # taus="all"-like spacing: each valid point counts min(1, d log2 tau) toward the dof,
    # whatever the curve's holes, with or without the per-cell outputs
    tau = np.geomspace(1.0, 2.0**10, 41)  # a quarter octave apart
    edf = np.geomspace(3e3, 3.0, tau.size)
    c = coefficients_from_values(q=5e-3, n=1e-2, b=3e-4, k=1e-4)
    curves = noisy_curves(30, c, tau, edf, seed=21)
    rng = np.random.default_rng(2)
    for i in range(30):
        curves[i, rng.integers(20, 42) :] = np.nan
    fit = fit_avar(tau, curves, edf, cells=cells)
    share = np.minimum(1.0, np.gradient(np.log2(tau)))
    assert (share < 1).all()
    want = np.maximum(np.isfinite(curves) @ share - 5, 0.0)
    np.testing.assert_allclose(fit.dof, want, rtol=1e-13, atol=1e-13)
    assert (fit.used is None) != cells


def test_duck_typed_davar_result_with_dev_or_avar():
    tau, curves, edf = _stack_with_holes()
    fit = fit_avar(tau, curves, edf)
    by_avar = fit_noise(SimpleNamespace(tau=tau, avar=curves, edf=edf, stat="oadev"))
    by_dev = fit_noise(SimpleNamespace(tau=tau, dev=np.sqrt(curves), edf=edf))
    np.testing.assert_array_equal(by_avar.coefficients, fit.coefficients)
    np.testing.assert_allclose(by_dev.coefficients, fit.coefficients, rtol=1e-9)


def test_deviation_result_input_and_units_are_carried():
    c = coefficients_from_values(n=1e-2, k=1e-4)
    res = deviation_result(OCTAVE, model_avar(c, OCTAVE), np.full(OCTAVE.size, 9.0), units="deg/h")
    fit = fit_noise(res)
    assert isinstance(fit, NoiseFit) and fit.units == "deg/h"
    np.testing.assert_allclose(fit.to_units().angle_random_walk.value, 1e-2 / 60, rtol=1e-9)
    with pytest.raises(ValueError, match="contradicts"):
        fit_noise(res, units="deg/s")


def test_relative_weights_without_edf():
    tau = OCTAVE[:12]
    c = coefficients_from_values(n=1e-2, k=1e-4)
    avar = noisy_curves(1, c, tau, np.full(tau.size, 200.0), seed=2)[0]
    rel = fit_avar(tau, avar)
    ones = fit_avar(tau, avar, np.ones(tau.size))
    np.testing.assert_array_equal(rel.coefficients, ones.coefficients)
    assert not rel.weighted and rel.reduced_chi2 < 1
    # edf=None: covariance scaled by the reduced chi-square itself, not by max(1, it)
    ratio = rel.coefficient_uncertainty / ones.coefficient_uncertainty
    np.testing.assert_allclose(ratio[ones.active], np.sqrt(rel.reduced_chi2), rtol=1e-12)


# ----------------------------------------------------------------------------- errors


def test_stat_guard():
    c = coefficients_from_values(n=1e-2)
    for stat in ("adev", "oadev", "totdev"):
        fit_noise(deviation_result(OCTAVE, model_avar(c, OCTAVE), np.ones(17), stat=stat))
    for stat in ("mdev", "hdev", "tdev", "ohdev"):
        res = deviation_result(OCTAVE, model_avar(c, OCTAVE), np.ones(17), stat=stat)
        with pytest.raises(ValueError, match=r"Allan variance.*stat='oadev'"):
            fit_noise(res)


def test_bad_inputs():
    avar = model_avar(coefficients_from_values(n=1e-2), OCTAVE)
    edf = np.ones(OCTAVE.size)
    with pytest.raises(ValueError, match="1-D"):
        fit_avar(OCTAVE[None, :], avar, edf)
    with pytest.raises(ValueError, match="positive"):
        fit_avar(-OCTAVE, avar, edf)
    with pytest.raises(ValueError, match="shape"):
        fit_avar(OCTAVE[:-1], avar, edf)
    with pytest.raises(ValueError, match="broadcast"):
        fit_avar(OCTAVE, avar, edf[:-1])
    with pytest.raises(ValueError, match="n_reweight"):
        fit_avar(OCTAVE, avar, edf, n_reweight=-1)
    with pytest.raises(ValueError) as err:
        fit_avar(OCTAVE, avar, edf, terms=("angle_random_walk", "arw"))
    msg = str(err.value)
    assert "'arw'" in msg and "\n" not in msg
    assert all(name in msg for name in TERM_NAMES)
    with pytest.raises(ValueError, match="broadcast"):
        fit_avar(OCTAVE, avar, np.ones((3, OCTAVE.size)))
    with pytest.raises(ValueError, match="edf"):
        fit_noise(SimpleNamespace(tau=OCTAVE, avar=avar))
    with pytest.raises(ValueError, match="confidence"):
        fit_noise(SimpleNamespace(tau=OCTAVE, avar=avar, edf=np.full(OCTAVE.size, np.nan)))
    with pytest.raises(ValueError, match="unknown input rate unit"):
        fit_avar(OCTAVE, avar, edf, units="furlong/fortnight")


# ----------------------------------------------------------------------------- units


def _fit_deg_h():
    c = coefficients_from_values(q=0.7, n=3.0, b=0.5, k=2.0, r=4.0)
    # rate in deg/h, tau in s; 5 terms need taus where each one shows
    tau = np.geomspace(0.01, 1e4, 30)
    return c, fit_avar(tau, model_avar(c, tau), np.full(tau.size, 30.0), units="deg/h")


def test_method_md_unit_checks_for_deg_per_hour():
    c, fit = _fit_deg_h()
    u = fit.to_units()
    assert u.sensor == "gyro" and u.input_unit == "deg/h"
    np.testing.assert_allclose(u.angle_random_walk.value, np.sqrt(c[1]) / 60, rtol=1e-9)
    np.testing.assert_allclose(u.rate_random_walk.value, 60 * np.sqrt(3 * c[3]), rtol=1e-9)
    np.testing.assert_allclose(u.rate_ramp.value, 3600 * np.sqrt(2 * c[4]), rtol=1e-9)
    np.testing.assert_allclose(u.quantization.value, np.sqrt(c[0] / 3), rtol=1e-9)
    np.testing.assert_allclose(
        u.bias_instability.value, np.sqrt(c[2] / (2 * np.log(2) / np.pi)), rtol=1e-9
    )
    assert (u.quantization.unit, u.angle_random_walk.unit, u.bias_instability.unit) == (
        "arcsec",
        "deg/sqrt(h)",
        "deg/h",
    )
    assert (u.rate_random_walk.unit, u.rate_ramp.unit) == ("deg/h/sqrt(h)", "deg/h^2")
    # uncertainties converted with the same factor as the values
    for name in TERM_NAMES:
        t, conv = fit.term(name), u[name]
        np.testing.assert_allclose(
            conv.uncertainty / t.uncertainty, conv.value / t.value, rtol=1e-12
        )


def test_gyro_units_from_deg_per_second_and_rad_per_second():
    _, fit = _fit_deg_h()
    n_deg_h = fit.to_units().angle_random_walk.value
    for unit, per_deg_h in (("deg/s", 1 / 3600), ("rad/s", math.pi / 180 / 3600)):
        scaled = fit_avar(fit.tau, fit.fitted_avar * per_deg_h**2, np.full(30, 30.0), units=unit)
        u, ref = scaled.to_units(), fit.to_units()
        for name in TERM_NAMES:
            np.testing.assert_allclose(u[name].value, ref[name].value, rtol=1e-8)
            assert u[name].unit == ref[name].unit
    # 1 deg/sqrt(h) of ARW is 1/60 deg/sqrt(s)
    np.testing.assert_allclose(convert(1.0, "deg/sqrt(h)", "deg/sqrt(s)"), 1 / 60)
    assert n_deg_h == pytest.approx(3.0 / 60)


def test_accelerometer_units():
    # 1 mg of white noise per sqrt(Hz)-ish: N = 1e-3 g*sqrt(s), B = 2e-5 g
    c = coefficients_from_values(n=1e-3, b=2e-5, k=1e-6)
    tau = np.geomspace(0.1, 1e5, 25)
    fit = fit_avar(tau, model_avar(c, tau), np.full(tau.size, 30.0), units="g")
    u = fit.to_units()
    assert u.sensor == "accelerometer"
    np.testing.assert_allclose(u.angle_random_walk.value, 1e-3 * 9.80665 * 60, rtol=1e-9)
    assert u.angle_random_walk.unit == "m/s/sqrt(h)"
    np.testing.assert_allclose(u.bias_instability.value, 20.0, rtol=1e-9)  # micro-g
    assert u.bias_instability.unit == "ug"
    np.testing.assert_allclose(u.rate_random_walk.value, 1e-6 * 9.80665 * 60, rtol=1e-9)
    assert u.rate_random_walk.unit == "m/s^2/sqrt(h)"
    si = fit.to_units(output_units={"bias_instability": "m/s^2"})
    np.testing.assert_allclose(si.bias_instability.value, 2e-5 * 9.80665, rtol=1e-9)
    # m/s^2 input: Q in m/s, same numbers scaled by g
    fit2 = fit_avar(tau, fit.fitted_avar * 9.80665**2, np.full(tau.size, 30.0), units="m/s/s")
    np.testing.assert_allclose(
        fit2.to_units().bias_instability.value, u.bias_instability.value, rtol=1e-8
    )
    assert fit2.to_units().quantization.unit == "m/s"


def test_convert_and_unit_errors():
    assert convert(1.0, "deg/s", "deg/h") == pytest.approx(3600.0)
    assert convert(1.0, "g", "m/s^2") == pytest.approx(9.80665)
    assert convert(1.0, "ug", "m/s^2") == pytest.approx(9.80665e-6)
    # 1 deg/h over 1 s is 1/3600 deg = 1 arcsec
    assert convert_coefficient(1.0, "quantization", "deg/h", "arcsec") == pytest.approx(1.0)
    assert convert_coefficient(1.0, "quantization", "deg/s", "arcsec") == pytest.approx(3600.0)
    np.testing.assert_allclose(convert([1.0, 2.0], "rad/s", "deg/s"), np.degrees([1.0, 2.0]))
    assert conventional_units("deg/s")["angle_random_walk"] == "deg/sqrt(h)"
    with pytest.raises(ValueError, match="different quantities"):
        convert(1.0, "deg/s", "m/s^2")
    with pytest.raises(ValueError, match="unknown unit"):
        convert(1.0, "deg/fortnight", "deg/s")
    with pytest.raises(ValueError) as err:
        conventional_units("rpm")
    assert all(u in str(err.value) for u in ("deg/s", "deg/h", "rad/s", "m/s^2", "g"))
    assert set(RATE_UNITS) >= {"deg/s", "deg/h", "rad/s", "m/s^2", "g"}
    c = coefficients_from_values(n=1e-2)
    fit = fit_avar(OCTAVE, model_avar(c, OCTAVE), np.ones(17))
    with pytest.raises(ValueError, match="declare"):
        fit.to_units()
    _, fit_h = _fit_deg_h()
    with pytest.raises(ValueError, match="output_units"):
        fit_h.to_units("deg/s")
    with pytest.raises(ValueError, match="does not fit"):
        fit_h.to_units(output_units={"angle_random_walk": "deg/h"})

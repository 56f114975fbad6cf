"""Tests of adavar.simulate: seeding, term independence and the IEEE 952 scale conventions.

The statistical checks average the overlapping Allan variance of ``N_SEEDS`` independent
records and compare it with the IEEE Std 952 formula.  The tolerance is ``Z`` standard
deviations of that average, the standard deviation coming from the equivalent degrees of
freedom (EDF) of the overlapping AVAR (NIST SP 1065, Table 5 approximations, inflated by
``EDF_SAFETY`` because they are slightly optimistic for flicker and random-walk FM).  Every
check also asserts that its tolerance is below 0.5, so a sqrt(2) error in the scale factor
(a factor 2 in AVAR) cannot pass.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import welch

from adavar import simulate as sim

N_SEEDS = 4
Z = 5.0
EDF_SAFETY = 1.25  # multiplies the predicted relative standard deviation
LN2 = math.log(2.0)


def oavar(w: np.ndarray, tau0: float, m: int) -> float:
    """Reference overlapping Allan variance of rate samples ``w`` at ``tau = m tau0``."""
    theta = np.concatenate([[0.0], np.cumsum(w)]) * tau0
    d = theta[2 * m :] - 2.0 * theta[m:-m] + theta[: -2 * m]
    return float(np.mean(d**2) / (2.0 * (m * tau0) ** 2))


def edf_oavar(alpha: int, n_phase: int, m: int) -> float:
    """EDF of the overlapping AVAR for power-law noise ``S_y ~ f^alpha`` (NIST SP 1065)."""
    n = n_phase
    if alpha == 2:
        return (n + 1) * (n - 2 * m) / (2.0 * (n - m))
    if alpha == 0:
        return (3.0 * (n - 1) / (2 * m) - 2.0 * (n - 2) / n) * 4 * m * m / (4 * m * m + 5)
    if alpha == -1:
        if m == 1:
            return 2.0 * (n - 2) ** 2 / (2.3 * n - 4.9)
        return 5.0 * n * n / (4 * m * (n + 3 * m))
    if alpha == -2:
        return (n - 2) / m * ((n - 1) ** 2 - 3 * m * (n - 1) + 4 * m * m) / (n - 3) ** 2
    raise ValueError(alpha)


def check_avar(gen, alpha, n, rate, ms, expected, bias_allowance=0.0):
    """Average OAVAR of N_SEEDS records vs ``expected(tau)``; returns the measured ratios."""
    tau0 = 1.0 / rate
    records = [gen(seed) for seed in range(100, 100 + N_SEEDS)]
    ratios = []
    for m in ms:
        tau = m * tau0
        measured = np.mean([oavar(w, tau0, m) for w in records])
        rel_sd = EDF_SAFETY * math.sqrt(2.0 / (N_SEEDS * edf_oavar(alpha, n + 1, m)))
        tol = Z * rel_sd + bias_allowance
        assert tol < 0.5, f"test has no power at m={m}: tol={tol:.3f}"
        ratio = measured / expected(tau)
        assert abs(ratio - 1.0) < tol, f"m={m}: AVAR ratio {ratio:.4f}, tolerance {tol:.4f}"
        ratios.append(ratio)
    return ratios


# --------------------------------------------------------------------------------------------
# IEEE 952 scale conventions
# --------------------------------------------------------------------------------------------

N_AVAR = 2**17
RATE = 100.0


def test_quantization_avar():
    q = 0.02
    check_avar(
        lambda s: sim.quantization(N_AVAR, q, rate=RATE, seed=s),
        2,
        N_AVAR,
        RATE,
        [1, 8, 64, 512],
        lambda tau: 3.0 * q**2 / tau**2,
    )


def test_angle_random_walk_avar():
    big_n = 0.3
    check_avar(
        lambda s: sim.angle_random_walk(N_AVAR, big_n, rate=RATE, seed=s),
        0,
        N_AVAR,
        RATE,
        [1, 8, 64, 512],
        lambda tau: big_n**2 / tau,
    )


def test_bias_instability_avar_floor():
    b = 0.05
    check_avar(
        lambda s: sim.bias_instability(N_AVAR, b, rate=RATE, seed=s),
        -1,
        N_AVAR,
        RATE,
        [32, 128, 512],
        lambda tau: 2.0 * LN2 / math.pi * b**2,
        bias_allowance=0.005,  # discrete Kasdin-Walter excess, ~1/m^2, 0.1 % at m = 32
    )


def test_rate_random_walk_avar_point_sampling():
    k = 0.01
    check_avar(
        lambda s: sim.rate_random_walk(N_AVAR, k, rate=RATE, seed=s),
        -2,
        N_AVAR,
        RATE,
        [1, 8, 64, 512],
        # K^2 tau / 3 plus the documented point-sampling term K^2 tau0^2 / (6 tau)
        lambda tau: k**2 * tau / 3.0 + k**2 / RATE**2 / (6.0 * tau),
    )


def test_rate_random_walk_avar_average_sampling():
    k = 0.01
    check_avar(
        lambda s: sim.rate_random_walk(N_AVAR, k, rate=RATE, seed=s, sampling="average"),
        -2,
        N_AVAR,
        RATE,
        [1, 8, 64, 512],
        lambda tau: k**2 * tau / 3.0,
    )


def test_random_walk_step_std():
    step = 0.2
    w = sim.random_walk(50_000, step, seed=3)
    steps = np.diff(w)
    assert abs(steps.std() / step - 1.0) < Z / math.sqrt(2 * steps.size)
    assert w[0] != 0.0


def test_white_std():
    w = sim.white(100_000, 2.5, rate=10.0, seed=1)
    assert abs(w.std() / 2.5 - 1.0) < Z / math.sqrt(2 * w.size)


@pytest.mark.parametrize("rate", [1.0, 400.0])
def test_flicker_avar_floor(rate):
    h = 3.0e-4
    check_avar(
        lambda s: sim.flicker(N_AVAR, h_minus1=h, rate=rate, seed=s),
        -1,
        N_AVAR,
        rate,
        [16, 64, 256, 1024],
        lambda tau: 2.0 * LN2 * h,
        bias_allowance=0.006,  # c(16) - 1 = 0.0046, see flicker's docstring
    )


def test_flicker_avar_small_m_excess():
    """The documented discrete excess at m = 1 (1/ln2) and m = 4 (1.050)."""
    h = 1.0
    recs = [sim.flicker(N_AVAR, h_minus1=h, seed=s) for s in range(N_SEEDS)]
    for m, c in [(1, 1.0 / LN2), (4, 1.0500)]:
        ratio = np.mean([oavar(w, 1.0, m) for w in recs]) / (2.0 * LN2 * h * c)
        tol = Z * EDF_SAFETY * math.sqrt(2.0 / (N_SEEDS * edf_oavar(-1, N_AVAR + 1, max(m, 2))))
        assert abs(ratio - 1.0) < tol


def test_flicker_psd_level():
    """One-sided PSD equals h_{-1}/f over the mid band (Welch, Hann, 50 % overlap)."""
    n, rate, h, nperseg = 2**17, 50.0, 2.0, 4096
    n_seg = 2 * n // nperseg - 1
    bands = [(rate / 512, rate / 128), (rate / 128, rate / 32), (rate / 32, rate / 20)]
    ratios = np.zeros(len(bands))
    n_bins = np.zeros(len(bands), dtype=int)
    seeds = range(3)
    for seed in seeds:
        f, p = welch(sim.flicker(n, h_minus1=h, rate=rate, seed=seed), fs=rate, nperseg=nperseg)
        for i, (lo, hi) in enumerate(bands):
            sel = (f >= lo) & (f < hi)
            ratios[i] += np.mean(p[sel] * f[sel] / h) / len(seeds)
            n_bins[i] = sel.sum()
    for ratio, m_bins in zip(ratios, n_bins, strict=True):
        # relative sd of a Welch bin ~ 1/sqrt(n_seg); adjacent Hann bins correlated (factor 2)
        rel_sd = math.sqrt(2.0 / (n_seg * m_bins * len(seeds)))
        tol = Z * EDF_SAFETY * rel_sd + 0.005  # + pi f tau0 / sin(pi f tau0) - 1 <= 0.4 %
        assert tol < 0.5
        assert abs(ratio - 1.0) < tol, (ratio, tol)


def test_flicker_matches_kasdin_walter_direct_convolution():
    n = 300
    rng_w = np.random.default_rng(5).standard_normal(n) * math.sqrt(math.pi * 0.7)
    k = np.arange(1, n)
    hk = np.concatenate([[1.0], np.cumprod((k - 0.5) / k)])
    direct = np.convolve(rng_w, hk)[:n]
    got = sim.flicker(n, h_minus1=0.7, seed=5)
    np.testing.assert_allclose(got, direct, rtol=1e-9, atol=1e-12)
    assert got.base is None  # its own n samples, not a view of the padded transform


def test_bias_instability_is_scaled_flicker():
    b = 0.3
    np.testing.assert_allclose(
        sim.bias_instability(1000, b, rate=7.0, seed=2),
        sim.flicker(1000, h_minus1=b**2 / math.pi, rate=7.0, seed=2),
        rtol=1e-12,
    )


def test_rate_ramp_exact():
    r, rate, n = 0.003, 20.0, 5000
    w = sim.rate_ramp(n, r, rate=rate)
    np.testing.assert_allclose(w, r * np.arange(n) / rate, rtol=1e-15, atol=0)
    for m in [1, 10, 100, 1000]:
        tau = m / rate
        assert oavar(w, 1.0 / rate, m) == pytest.approx(r**2 * tau**2 / 2.0, rel=1e-9)


def test_sinusoid_values():
    w = sim.sinusoid(1000, 2.0, 3.0, phase=0.4, rate=50.0)
    t = np.arange(1000) / 50.0
    np.testing.assert_allclose(w, 2.0 * np.sin(2 * np.pi * 3.0 * t + 0.4), atol=1e-12)


# --------------------------------------------------------------------------------------------
# Gauss-Markov
# --------------------------------------------------------------------------------------------


def test_markov_variance_and_lag1_correlation():
    std, corr_time, rate, n = 0.3, 0.5, 100.0, 2**17
    phi = math.exp(-1.0 / (rate * corr_time))
    n_eff = n * (1 - phi) / (1 + phi)  # effective number of independent samples
    var_ratios, r1s = [], []
    for seed in range(N_SEEDS):
        x = sim.markov(n, std, corr_time, rate=rate, seed=seed)
        var_ratios.append(np.mean(x**2) / std**2)
        r1s.append(np.dot(x[1:], x[:-1]) / np.dot(x, x))
    tol_var = Z * EDF_SAFETY * math.sqrt(2.0 / (N_SEEDS * n_eff))
    assert tol_var < 0.5
    assert abs(np.mean(var_ratios) - 1.0) < tol_var
    tol_r1 = Z * EDF_SAFETY * math.sqrt((1 - phi**2) / (N_SEEDS * n)) + 10.0 / n
    assert abs(np.mean(r1s) - phi) < tol_r1


def test_markov_stationary_start():
    rng = np.random.default_rng(11)
    std = 2.0
    first = np.array([sim.markov(3, std, 50.0, seed=rng) for _ in range(4000)])
    for j in range(3):
        assert abs(np.var(first[:, j]) / std**2 - 1.0) < Z * math.sqrt(2.0 / 4000)


# --------------------------------------------------------------------------------------------
# Piecewise white noise
# --------------------------------------------------------------------------------------------


def test_piecewise_white_segment_std():
    n, stds, changes = 100_000, [0.5, 2.0, 1.0], [30_000, 70_000]
    w = sim.piecewise_white(n, stds, changes, seed=4)
    edges = [0, *changes, n]
    for s, a, b in zip(stds, edges[:-1], edges[1:], strict=True):
        seg = w[a:b]
        assert abs(seg.std() / s - 1.0) < Z / math.sqrt(2 * seg.size)


def test_piecewise_white_times_matches_samples():
    w_t = sim.piecewise_white_times(10.0, [1.0, 3.0, 0.5], [2.5, 7.0], rate=100.0, seed=9)
    w_s = sim.piecewise_white(1000, [1.0, 3.0, 0.5], [250, 700], rate=100.0, seed=9)
    assert w_t.shape == (1000,)
    np.testing.assert_array_equal(w_t, w_s)
    # round-off: 0.29 * 100 = 28.999999999999996 is sample 29
    w_r = sim.piecewise_white_times(1.0, [1.0, 0.0], [0.29], rate=100.0, seed=1)
    assert np.all(w_r[:29] != 0.0) and np.all(w_r[29:] == 0.0)


def test_piecewise_white_no_change_is_white():
    np.testing.assert_array_equal(
        sim.piecewise_white(500, [1.5], [], seed=8), sim.white(500, 1.5, seed=8)
    )


# --------------------------------------------------------------------------------------------
# Seeding, shapes, sensor independence
# --------------------------------------------------------------------------------------------

RANDOM_GENERATORS = {
    "white": lambda n, s: sim.white(n, 1.0, rate=10.0, seed=s),
    "random_walk": lambda n, s: sim.random_walk(n, 1.0, seed=s),
    "flicker": lambda n, s: sim.flicker(n, h_minus1=1.0, seed=s),
    "quantization": lambda n, s: sim.quantization(n, 0.1, rate=10.0, seed=s),
    "angle_random_walk": lambda n, s: sim.angle_random_walk(n, 0.1, seed=s),
    "bias_instability": lambda n, s: sim.bias_instability(n, 0.1, seed=s),
    "rate_random_walk": lambda n, s: sim.rate_random_walk(n, 0.1, seed=s),
    "rate_random_walk_avg": lambda n, s: sim.rate_random_walk(n, 0.1, seed=s, sampling="average"),
    "markov": lambda n, s: sim.markov(n, 1.0, 5.0, seed=s),
    "piecewise_white": lambda n, s: (
        sim.piecewise_white(n, [1.0, 2.0], [n // 2], seed=s)
        if n > 1
        else sim.piecewise_white(n, [1.0], [], seed=s)
    ),
    "sensor": lambda n, s: sim.sensor(n, angle_random_walk=0.1, bias_instability=0.1, seed=s),
}


@pytest.mark.parametrize("name", sorted(RANDOM_GENERATORS))
def test_reproducible_by_seed(name):
    gen = RANDOM_GENERATORS[name]
    a, b, c = gen(257, 42), gen(257, 42), gen(257, 43)
    assert a.dtype == np.float64 and a.shape == (257,)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    # a Generator seed is used in place: same state -> same draws
    np.testing.assert_array_equal(
        gen(257, np.random.default_rng(7)), gen(257, np.random.default_rng(7))
    )
    np.testing.assert_array_equal(
        gen(257, np.random.SeedSequence(3)), gen(257, np.random.SeedSequence(3))
    )
    assert gen(1, 0).shape == (1,)


def test_deterministic_shapes():
    assert sim.rate_ramp(1, 1.0).shape == (1,)
    assert sim.sinusoid(7, 1.0, 0.1).dtype == np.float64


def test_seed_none_gives_fresh_draws():
    assert not np.array_equal(sim.white(100, seed=None), sim.white(100, seed=None))


def test_sensor_terms_are_independent_streams():
    n, rate, seed = 4096, 50.0, 123
    parts = {
        "quantization": 0.01,
        "angle_random_walk": 0.2,
        "bias_instability": 0.05,
        "rate_random_walk": 0.003,
        "markov": (0.1, 2.0),
    }
    singles = {k: sim.sensor(n, rate=rate, seed=seed, **{k: v}) for k, v in parts.items()}
    # adding terms does not change the draws of the others: the sum is additive
    full = sim.sensor(
        n, rate=rate, seed=seed, bias=1.5, rate_ramp=1e-3, sinusoid=(0.2, 1.0), **parts
    )
    expected = (
        sum(singles.values())
        + 1.5
        + sim.rate_ramp(n, 1e-3, rate=rate)
        + sim.sinusoid(n, 0.2, 1.0, rate=rate)
    )
    np.testing.assert_allclose(full, expected, rtol=0, atol=1e-12)
    # each single term is a scaled version of its own unit-coefficient stream
    arw1 = sim.sensor(n, rate=rate, seed=seed, angle_random_walk=1.0)
    np.testing.assert_allclose(singles["angle_random_walk"], 0.2 * arw1, rtol=1e-12)
    # distinct terms use distinct streams (not the same normals rescaled)
    z_arw = singles["angle_random_walk"] / (0.2 * math.sqrt(rate))
    z_q = np.cumsum(singles["quantization"]) / rate / 0.01  # = e[k+1] - e[0]
    assert abs(np.corrcoef(z_arw[1:], np.diff(z_q))[0, 1]) < 0.1
    # components match the stand-alone generators fed with the sensor's child streams
    children = np.random.SeedSequence(seed).spawn(5)
    np.testing.assert_array_equal(
        singles["angle_random_walk"], sim.angle_random_walk(n, 0.2, rate=rate, seed=children[1])
    )


def test_sensor_bias_and_zero():
    np.testing.assert_array_equal(sim.sensor(10, bias=-2.0, seed=0), np.full(10, -2.0))
    np.testing.assert_array_equal(sim.sensor(10, seed=0), np.zeros(10))


# --------------------------------------------------------------------------------------------
# Argument validation
# --------------------------------------------------------------------------------------------

BAD_CALLS = {
    "n=0": lambda: sim.white(0),
    "n<0": lambda: sim.angle_random_walk(-5, 1.0),
    "n float": lambda: sim.flicker(10.0),
    "n bool": lambda: sim.white(True),
    "rate=0": lambda: sim.white(10, rate=0.0),
    "rate<0": lambda: sim.quantization(10, 1.0, rate=-1.0),
    "rate nan": lambda: sim.rate_ramp(10, 1.0, rate=float("nan")),
    "rate inf": lambda: sim.markov(10, 1.0, 1.0, rate=float("inf")),
    "std<0": lambda: sim.white(10, -1.0),
    "step<0": lambda: sim.random_walk(10, -1.0),
    "h<0": lambda: sim.flicker(10, h_minus1=-1.0),
    "Q<0": lambda: sim.quantization(10, -0.1),
    "N nan": lambda: sim.angle_random_walk(10, float("nan")),
    "B inf": lambda: sim.bias_instability(10, float("inf")),
    "K<0": lambda: sim.rate_random_walk(10, -1.0),
    "K sampling": lambda: sim.rate_random_walk(10, 1.0, sampling="midpoint"),
    "R<0": lambda: sim.rate_ramp(10, -1.0),
    "R str": lambda: sim.rate_ramp(10, "1"),
    "markov T=0": lambda: sim.markov(10, 1.0, 0.0),
    "markov std<0": lambda: sim.markov(10, -1.0, 1.0),
    "sin nyquist": lambda: sim.sinusoid(10, 1.0, 0.6, rate=1.0),
    "sin amp<0": lambda: sim.sinusoid(10, -1.0, 0.1),
    "sin phase nan": lambda: sim.sinusoid(10, 1.0, 0.1, phase=float("nan")),
    "seed<0": lambda: sim.white(10, seed=-1),
    "seed str": lambda: sim.white(10, seed="abc"),
    "sensor N<0": lambda: sim.sensor(10, angle_random_walk=-1.0),
    "sensor bias nan": lambda: sim.sensor(10, bias=float("nan")),
    "sensor markov len": lambda: sim.sensor(10, markov=(1.0,)),
    "sensor markov T": lambda: sim.sensor(10, markov=(1.0, -2.0)),
    "sensor sin len": lambda: sim.sensor(10, sinusoid=(1.0,)),
    "sensor seed": lambda: sim.sensor(10, seed=-3),
    "pw len": lambda: sim.piecewise_white(10, [1.0, 2.0], []),
    "pw order": lambda: sim.piecewise_white(10, [1.0, 2.0, 3.0], [6, 3]),
    "pw range": lambda: sim.piecewise_white(10, [1.0, 2.0], [10]),
    "pw zero": lambda: sim.piecewise_white(10, [1.0, 2.0], [0]),
    "pw std<0": lambda: sim.piecewise_white(10, [1.0, -2.0], [5]),
    "pw nonint": lambda: sim.piecewise_white(10, [1.0, 2.0], [2.5]),
    "pwt duration": lambda: sim.piecewise_white_times(0.0, [1.0], []),
    "pwt range": lambda: sim.piecewise_white_times(1.0, [1.0, 2.0], [1.5], rate=10.0),
    "pwt collide": lambda: sim.piecewise_white_times(1.0, [1.0, 2.0, 3.0], [0.51, 0.52], rate=10.0),
}


@pytest.mark.parametrize("case", sorted(BAD_CALLS))
def test_bad_inputs_raise(case):
    with pytest.raises(ValueError) as info:
        BAD_CALLS[case]()
    message = str(info.value)
    assert "\n" not in message and ";" in message  # one line: the problem; the fix

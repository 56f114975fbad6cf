"""The power-law clock model (adavar.fit.power_law): its variances, the fit, its calibration."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.integrate import quad

import adavar
from adavar import simulate
from adavar.core.errors import AdavarInputError
from adavar.core.units import term_names
from adavar.fit.power_law import expected_variance, fit_power_law, power_law_design

# --------------------------------------------------------------------------------------
# a power-law clock with exactly the model's spectrum (shared with the benchmark)


def flicker_phase(n: int, level: float, tau0: float, rng: np.random.Generator) -> np.ndarray:
    """Phase with one-sided PSD ``level / f`` up to Nyquist (the first half of 2n samples)."""
    size = 2 * n
    f = np.arange(size // 2 + 1) / (size * tau0)
    amp = np.zeros(f.size)
    amp[1:] = np.sqrt(level / f[1:] / (size * tau0))
    z = rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)
    spec = (size / 2) * amp * z
    spec[-1] = size * amp[-1] * math.sqrt(0.5) * z[-1].real  # the Nyquist bin: real, half
    return np.fft.irfft(spec, size)[:n]


def clock(n: int, h, *, tau0: float = 1.0, seed: int = 0, drift: float = 0.0) -> np.ndarray:
    """Fractional frequency of a clock with ``h = (h_-2, h_-1, h_0, h_1, h_2)``.

    White PM: white phase (f_h = Nyquist); flicker PM: the spectrum above; white FM and
    random walk FM (bin averages): exact; flicker FM: the Kasdin-Walter filter (its AVAR
    is 2 ln2 h_-1 only from tau = 16 tau0 on).
    """
    rng = np.random.default_rng(seed)
    hm2, hm1, h0, h1, h2 = h
    x = np.zeros(n + 1)
    if h2:
        x += math.sqrt(h2 / (8.0 * math.pi**2 * tau0)) * rng.standard_normal(n + 1)
    if h1:
        x += flicker_phase(n + 1, h1 / (4.0 * math.pi**2), tau0, rng)
    y = np.diff(x) / tau0
    if h0:
        y += simulate.white(n, math.sqrt(h0 / (2.0 * tau0)), rate=1 / tau0, seed=rng)
    if hm1:
        y += simulate.flicker(n, h_minus1=hm1, rate=1 / tau0, seed=rng)
    if hm2:
        k = math.sqrt(2.0 * math.pi**2 * hm2)  # K^2 tau / 3 = (2 pi^2 / 3) h_-2 tau
        y += simulate.rate_random_walk(n, k, rate=1 / tau0, seed=rng, sampling="average")
    return y + drift * tau0 * np.arange(n)


# --------------------------------------------------------------------------------------
# the variances of the model against slow references


def _weights(family: str, m: int) -> np.ndarray:
    """Phase weights of one term of the statistic, built sample by sample."""
    if family == "avar":
        w = np.zeros(2 * m + 1)
        w[[0, m, 2 * m]] = (1, -2, 1)
    elif family == "hvar":
        w = np.zeros(3 * m + 1)
        w[[0, m, 2 * m, 3 * m]] = (-1, 3, -3, 1)
    else:
        w = np.zeros(3 * m)
        for i in range(m):
            w[[i, i + m, i + 2 * m]] += (1, -2, 1)
    return w


def _norm(family: str, m: int, tau0: float) -> float:
    tau = m * tau0
    return {"avar": 2 * tau**2, "hvar": 6 * tau**2, "mvar": 2 * m * m * tau**2}[family]


def _spectral(family: str, alpha: int, m: int, tau0: float, f_h: float) -> float:
    """``int S_x |W(f)|^2 df / norm`` for ``S_y = f^alpha``; PM up to f_h, FM to 400/tau0."""
    tau = m * tau0

    def w2(f):
        if family == "avar":
            return 16 * math.sin(math.pi * f * tau) ** 4
        if family == "hvar":
            return 64 * math.sin(math.pi * f * tau) ** 6
        s = math.sin(math.pi * f * tau0)
        box = (math.sin(math.pi * f * tau) / s) ** 2 if abs(s) > 1e-12 else m * m
        return 16 * math.sin(math.pi * f * tau) ** 4 * box

    top = f_h if alpha > 0 else 400.0 / tau0
    edges = np.linspace(1e-12, top, int(top * tau * 8) + 2)
    total = sum(
        quad(lambda f: f ** (alpha - 2) / (4 * math.pi**2) * w2(f), a, b, limit=200)[0]
        for a, b in itertools.pairwise(edges)
    )
    return total / _norm(family, m, tau0)


@pytest.mark.parametrize("stat,family", [("oadev", "avar"), ("mdev", "mvar"), ("hdev", "hvar")])
@pytest.mark.parametrize("m", [1, 2, 3])
def test_design_matches_the_spectral_integral(stat, family, m):
    tau0, f_h = 0.5, 0.8  # f_h below Nyquist (1 Hz)
    row = power_law_design(stat, [m], tau0, f_h)[0]
    for col, alpha in ((0, -2), (1, -1), (3, 1), (4, 2)):
        want = _spectral(family, alpha, m, tau0, f_h)
        tol = 1e-12 if alpha > 0 else 3e-6  # the FM reference stops at 400 / tau0
        assert row[col] == pytest.approx(want, rel=tol), (alpha, row[col], want)


@pytest.mark.parametrize("family,stat", [("avar", "oadev"), ("mvar", "mdev"), ("hvar", "hdev")])
def test_white_fm_is_a_random_walk_of_phase(family, stat):
    # white FM (h_0 = 1): the phase is a random walk with steps of variance h_0 tau0 / 2
    tau0 = 0.25
    for m in (1, 2, 5):
        w = _weights(family, m)
        k = np.arange(w.size)
        cov = 0.5 * tau0 * np.minimum.outer(k, k)
        want = w @ cov @ w / _norm(family, m, tau0)
        got = power_law_design(stat, [m], tau0, 1.0)[0, 2]
        assert got == pytest.approx(want, rel=1e-12)


def test_large_m_gives_the_sp1065_relations():
    tau0, f_h, m = 1.0, 0.5, 1 << 14
    tau = m * tau0
    ln2, ln3, pi2 = math.log(2), math.log(3), math.pi**2
    avar = power_law_design("oadev", [m], tau0, f_h)[0]
    assert avar[:5] == pytest.approx(
        [2 * pi2 / 3 * tau, 2 * ln2, 1 / (2 * tau),
         (1.0385 + 3 * math.log(2 * math.pi * f_h * tau)) / (4 * pi2 * tau**2),
         3 * f_h / (4 * pi2 * tau**2)], rel=1e-4)  # fmt: skip
    assert avar[5] == pytest.approx(tau**2 / 2)
    mvar = power_law_design("mdev", [m], tau0, f_h)[0]
    flicker_pm = (12 * ln2 - 4.5 * ln3) / (4 * pi2 * tau**2)
    assert mvar[:5] == pytest.approx(
        [11 * pi2 / 20 * tau, 2 * (27 / 16 * ln3 - 2 * ln2), 1 / (4 * tau), flicker_pm,
         3 / (8 * pi2 * tau**3)], rel=1e-6)  # fmt: skip
    hvar = power_law_design("hdev", [m], tau0, f_h)[0]
    assert hvar[:5] == pytest.approx(
        [pi2 / 3 * tau, (8 * ln2 - 3 * ln3) / 2, 1 / (2 * tau), hvar[3],
         10 * f_h / (3 * 4 * pi2 * tau**2)], rel=1e-6)  # fmt: skip
    assert hvar[5] == 0.0
    tvar = power_law_design("tdev", [m], tau0, f_h)[0]
    np.testing.assert_allclose(tvar, mvar * tau**2 / 3, rtol=1e-14)
    # beyond the exact sums the large-m relations take over, continuously
    a, b = power_law_design("mdev", [1 << 16, (1 << 16) + 1], tau0, f_h)
    ratio = ((1 << 16) + 1) / (1 << 16)
    np.testing.assert_allclose(a[:5] / b[:5], ratio ** np.array([-1.0, 0, 1, 2, 3]), rtol=1e-8)


def test_expected_variance_matches_simulated_pm_noise():
    n, runs = 4096, 40
    for h in ((0, 0, 0, 1.0, 0), (0, 0, 0, 0, 1.0)):
        for stat in ("oadev", "mdev"):
            v = np.mean([adavar.deviation(clock(n, h, seed=s), stat=stat, confidence=None).dev ** 2
                         for s in range(runs)], axis=0)  # fmt: skip
            r = adavar.deviation(clock(n, h), stat=stat, confidence=None)
            want = expected_variance(h, r.tau, stat=stat)
            np.testing.assert_allclose(v[:6], want[:6], rtol=0.03)


# --------------------------------------------------------------------------------------
# recovery and calibration


def _pulls(stat, h, terms, runs, n=1 << 14, seed=0):
    pulls, rel = [], []
    truth = np.array(h)
    for s in range(runs):
        r = adavar.deviation(clock(n, h, seed=seed + s), stat=stat)
        fit = fit_power_law(r, terms=terms, select="none")
        k = [fit.names.index(t) for t in terms]
        pulls.append((fit.h[k] - truth[k]) / fit.h_sigma[k])
        rel.append(fit.h[k] / truth[k] - 1.0)
    return np.array(pulls), np.array(rel)


@pytest.mark.parametrize(
    "stat,h,terms",
    [
        ("oadev", (1e-5, 0, 1.0, 0, 3.0), ("random_walk_fm", "white_fm", "white_pm")),
        ("mdev", (1e-5, 0, 1.0, 1.0, 3.0),
         ("random_walk_fm", "white_fm", "flicker_pm", "white_pm")),
    ],
)  # fmt: skip
def test_recovery_and_calibration(stat, h, terms):
    pulls, rel = _pulls(stat, h, terms, runs=30)
    # unbiased within the Monte Carlo error, uncertainties calibrated within ~30 %
    err = rel.std(axis=0) / math.sqrt(len(rel))
    assert np.all(np.abs(rel.mean(axis=0)) < 3.5 * err + 0.01), rel.mean(axis=0)
    sd = pulls.std(axis=0)
    assert np.all((sd > 0.7) & (sd < 1.35)), sd
    assert np.all(np.abs(pulls.mean(axis=0)) < 0.6), pulls.mean(axis=0)


def test_the_gyro_fit_is_the_ieee_fit():
    # white FM is the angle random walk: h_0 = 2 N^2, h_-2 = K^2 / (2 pi^2)
    n = 1 << 15
    y = simulate.angle_random_walk(n, 0.01, rate=10, seed=1)
    y = y + simulate.rate_random_walk(n, 1e-4, rate=10, seed=2, sampling="average")
    r = adavar.deviation(y, rate=10, units="deg/s")
    ieee = adavar.fit_noise(r, terms=("angle_random_walk", "rate_random_walk"), select="none",
                            exclude="none")  # fmt: skip
    fit = fit_power_law(r, terms=("white_fm", "random_walk_fm"), select="none")
    n_hat = ieee.angle_random_walk.value
    assert fit["white_fm"].value == pytest.approx(2 * n_hat**2, rel=1e-6)
    assert fit["white_fm"].uncertainty == pytest.approx(
        4 * n_hat * ieee.angle_random_walk.uncertainty, rel=1e-3
    )
    k_hat = ieee.rate_random_walk.value
    assert fit["random_walk_fm"].value == pytest.approx(k_hat**2 / (2 * math.pi**2), rel=1e-6)
    assert fit.labels["white_fm"] == "angle random walk"
    assert "(deg/s)^2 s" in fit.summary()


def test_drift_and_flicker_fm():
    n = 1 << 15
    y = clock(n, (0, 1e-2, 1.0, 0, 0), seed=3, drift=1e-4)
    r = adavar.deviation(y, stat="oadev")
    fit = fit_power_law(r, drift=True, tau_range=(16, None))
    assert fit["frequency_drift"].value == pytest.approx(1e-4, rel=0.15)
    assert fit["flicker_fm"].value == pytest.approx(1e-2, rel=0.3)
    assert fit["white_fm"].value == pytest.approx(1.0, rel=0.05)
    assert "frequency drift" in fit.summary()
    assert fit.exclusions[0].startswith("outside tau_range")
    # the Hadamard variance does not see the drift
    fh = fit_power_law(adavar.deviation(y, stat="hdev"), drift=True, tau_range=(16, None))
    assert "frequency_drift" not in fh.terms
    assert any("Hadamard" in note for note in fh.notes)


def test_result_fields_and_text():
    y = clock(1 << 13, (0, 0, 1.0, 0, 1.0), seed=4)
    r = adavar.deviation(y, stat="oadev")
    fit = fit_power_law(r)
    assert fit.f_h == 0.5 and fit.f_h_source.startswith("default")
    assert any("Nyquist" in note for note in fit.notes)
    np.testing.assert_allclose(fit.model_var(r.tau), fit.fitted_var, rtol=1e-12)
    total = sum(fit.term_var(name, r.tau) for name in fit.as_dict())
    np.testing.assert_allclose(total, fit.fitted_var, rtol=1e-12)
    assert fit.model_dev(3.5).shape == ()  # between samples: the lags in seconds
    assert set(fit.dropped) <= set(fit.terms)
    for name in fit.dropped:  # value 0, a 1-sigma upper bound
        assert fit[name].value == 0 and fit[name].uncertainty > 0
    text = fit.summary()
    assert "white FM" in text and "f_h = 0.5 Hz" in text and "chi2/dof" in text
    assert repr(fit).startswith("PowerLawFit(stat='oadev'")
    assert fit.labels == term_names(None, "rate", sensor="clock")
    given = fit_power_law(r, f_h=0.25)
    assert given.f_h_source == "given" and not given.notes
    assert list(fit.alpha) == [-2, -1, 0, 1, 2]


def test_scale_is_exact():
    y = clock(1 << 12, (0, 0, 1.0, 0, 2.0), seed=5)
    a = fit_power_law(adavar.deviation(y), select="none")
    b = fit_power_law(adavar.deviation(y * 2.0**-45), select="none")  # a clock near 1e-13
    np.testing.assert_allclose(b.h, a.h * 4.0**-45, rtol=1e-9)
    np.testing.assert_allclose(b.h_sigma, a.h_sigma * 4.0**-45, rtol=1e-9)


def test_expected_variance_forms():
    tau = np.array([1.0, 10.0])
    a = expected_variance({"white_fm": 2.0}, tau)
    np.testing.assert_allclose(a, 1.0 / tau)
    b = expected_variance([0, 0, 2.0, 0, 0], tau, stat="mdev")
    np.testing.assert_allclose(b[1], 2.0 / (4 * 10.0), rtol=0.02)  # 1/(4 tau) at large m
    assert expected_variance([0] * 5, 2.0, drift=1.0) == pytest.approx(2.0)


@pytest.mark.parametrize(
    "call,match",
    [
        (lambda r: fit_power_law(object()), "DeviationResult"),
        (lambda r: fit_power_law(r, terms=("white_noise",)), "unknown power-law term"),
        (lambda r: fit_power_law(r, f_h=-1), "f_h must be"),
        (lambda r: fit_power_law(r, select="all"), "unknown select"),
        (lambda r: fit_power_law(r, significance=0), "significance"),
        (lambda r: fit_power_law(r, tau_range=(10, 1)), "minimum must be below"),
        (lambda r: fit_power_law(r, tau_range=(1e6, None)), "usable taus"),
        (lambda r: fit_power_law(r, n_iter=-1), "n_iter"),
        (lambda r: expected_variance([1, 2], 1.0), "5 coefficients"),
        (lambda r: expected_variance({"pink": 1}, 1.0), "unknown power-law term"),
        (lambda r: power_law_design("kurtosis", [1], 1.0, 0.5), "implemented for"),
    ],
)
def test_errors(call, match):
    r = adavar.deviation(clock(1 << 10, (0, 0, 1.0, 0, 0)))
    with pytest.raises(AdavarInputError, match=match) as info:
        call(r)
    assert "\n" not in str(info.value)


def test_a_result_without_edf_is_refused():
    r = adavar.deviation(clock(1 << 10, (0, 0, 1.0, 0, 0)), confidence=None)
    with pytest.raises(AdavarInputError, match="no EDF"):
        fit_power_law(r)


def test_term_names_per_instrument():
    assert term_names("s", "phase")["angle_random_walk"] == "white FM"
    assert term_names("", "rate")["rate_ramp"] == "frequency drift"
    assert term_names("deg/s")["white_fm"] == "angle random walk"
    assert term_names("m/s^2")["angle_random_walk"] == "velocity random walk"
    assert term_names("m/s^2")["rate_random_walk"] == "acceleration random walk"
    assert term_names("mV")["bias_instability"] == "bias instability"
    assert term_names("deg/s", sensor="clock")["quantization"] == "white PM"
    with pytest.raises(ValueError, match="unknown sensor"):
        term_names("deg/s", sensor="radio")


# --- the command line: clock data get the clock model with --fit ----------------------


def _clock_csv(tmp_path, sigma=1e-11, n=20_000):
    y = np.random.default_rng(3).standard_normal(n) * sigma  # white FM, tau0 = 1 s
    path = tmp_path / "clock.csv"
    np.savetxt(path, np.concatenate([[0.0], np.cumsum(y)]), header="phase", comments="",
               fmt="%.17e")  # fmt: skip
    return path


def test_cli_fits_the_clock_model_for_phase_in_seconds(capsys, tmp_path):
    import json

    from tests.cli_helpers import run

    argv = ["avar", str(_clock_csv(tmp_path)), "--rate", "1", "--units", "s", "--data-type",
            "phase", "--fit", "--json"]  # fmt: skip
    code, out, err = run(capsys, argv)
    assert code == 0, err
    payload = json.loads(out)
    h0 = payload["power_law"]["h"]["white_fm"]
    assert h0["label"] == "white FM" and h0["alpha"] == 0
    # white FM of sigma 1e-11 at tau0 = 1 s: h_0 = 2 sigma^2 tau0
    assert abs(h0["value"] / 2e-22 - 1) < 4 * h0["sigma"] / 2e-22
    assert "fit" in payload  # the IEEE fit is still there, unchanged
    code, out, _ = run(capsys, argv[:-1])
    assert "power-law fit of oadev" in out and "h_0  white FM" in out


def test_cli_power_law_is_off_for_a_gyro_unless_asked(capsys, tmp_path):
    import json

    from tests.cli_helpers import run

    path = _clock_csv(tmp_path)
    base = ["avar", str(path), "--rate", "1", "--units", "deg", "--data-type", "phase", "--fit",
            "--json"]  # fmt: skip
    code, out, err = run(capsys, base)
    assert code == 0, err
    assert "power_law" not in json.loads(out)
    code, out, err = run(capsys, [*base, "--power-law", "on"])
    assert code == 0, err
    assert json.loads(out)["power_law"]["h"]["white_fm"]["label"] == "angle random walk"

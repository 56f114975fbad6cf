"""The adaptive window controller against a slow, literal reading of METHOD.md section 5."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

import adavar
from adavar.core.errors import AdavarInputError
from adavar.dynamic.adaptive import (
    AdaptiveResult,
    adaptive_schedule,
    calibrated_thresholds,
    false_alarm_rate,
    oracle_schedule,
)

# the controller of docs/method.md with the paper's thresholds (the default is per hour)
SMALL = dict(lmax=200, lmin=120, l=30, thresholds="paper")  # l: the paper's segment name
#: the paper's controller, one argument each away from the defaults
PAPER = dict(lmax=600, lmin=400, l=100, thresholds="paper")


def pearson_kurtosis(w):
    """Eq. 14: the biased fourth moment over the squared biased variance (two passes), as
    ``scipy.stats.kurtosis(w, fisher=False)`` computes it, without its per-call overhead."""
    d = w - w.mean()
    d2 = d * d
    return float(np.mean(d2 * d2) / np.mean(d2) ** 2)


def literal_controller(
    x, *, lmax=600, lmin=400, k1=2.5, k2=3.3, s1=0.0, s2=0.07, l=100,  # noqa: E741
    dl0=2, dl1=2, s_test="upper", combine="or", kurtosis_only=False, thresholds="paper",
):  # fmt: skip
    """METHOD.md section 5, one step at a time, with a two-pass kurtosis (scipy's), and
    the thresholds as given (``thresholds="paper"``)."""
    assert thresholds == "paper"
    n = x.size
    pad = lmax // 2 + 1
    ext = np.pad(np.asarray(x, dtype=float), pad, mode="symmetric")
    L = lmax
    out = {"window": [], "kurtosis": [], "s": [], "f1": [], "f2": [], "f": []}
    for p in range(n):
        a = p + pad - (L - 1) // 2  # 1. the L samples centred at p (mirror-extended)
        window = ext[a : a + L]
        k = pearson_kurtosis(window)  # 2. Eq. 14, Eq. 16
        f1 = not (k1 <= k <= k2)
        k_rest = pearson_kurtosis(window[: L - l])  # 3. Eq. 15, s = last l
        s = (k - k_rest) / k
        if s_test == "upper":
            f2 = s > s2
        elif s_test == "band":
            f2 = not (s1 <= s <= s2)
        else:
            f2 = abs(s) > s2
        if kurtosis_only:  # 4. Eq. 18
            f = f1
        else:
            f = (f1 and f2) if combine == "and" else (f1 or f2)
        for key, value in zip(out, (L, k, s, f1, f2, f), strict=True):
            out[key].append(value)  # 6. the length in force at p
        L = max(L - dl1, lmin) if f else min(L + dl0, lmax)  # 5. Eq. 19-22
    return {key: np.array(value) for key, value in out.items()}


def scenario(seed, n=1800, burst=(900, 1200), factor=3.0):
    x = np.random.default_rng(seed).standard_normal(n)
    x[burst[0] : burst[1]] *= factor
    return x


def test_reference_kurtosis_is_scipys():
    w = np.random.default_rng(3).standard_normal(257) * 5.0 + 2.0
    assert pearson_kurtosis(w) == pytest.approx(stats.kurtosis(w, fisher=False), rel=1e-13)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
@pytest.mark.parametrize(
    "options",
    [
        {},
        {"method": "kurtosis"},
        {"s_test": "band"},
        {"s_test": "abs", "s2": 0.05},
        {"combine": "and"},
        {"dl0": 4, "dl1": 2},
    ],
    ids=["adaptive", "kurtosis", "band", "abs", "and", "asymmetric-steps"],
)
def test_controller_follows_method_md_step_by_step(seed, options):
    x = scenario(seed)
    got = adaptive_schedule(x, **SMALL, **options)
    kwargs = {k: v for k, v in options.items() if k != "method"}
    want = literal_controller(
        x, **SMALL, **kwargs, kurtosis_only=options.get("method") == "kurtosis"
    )
    np.testing.assert_array_equal(got.window, want["window"])
    np.testing.assert_allclose(got.kurtosis, want["kurtosis"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got.s, want["s"], rtol=0, atol=1e-9)
    for flag in ("f1", "f2", "f"):
        np.testing.assert_array_equal(getattr(got, flag), want[flag])
    # the window did adapt: it shrank around the burst
    assert got.window[900:1200].min() < SMALL["lmax"]


@pytest.mark.parametrize("transform", ["offset 1e6 sigma", "drift", "float32", "tiny"])
def test_kurtosis_is_exact_on_hard_data(transform):
    """Offsets of 1e6 sigma, drift, float32 and tiny scales: 1e-9 absolute on the kurtosis.

    The reference subtracts a sample of the window first (exact for nearby values), then
    takes two-pass moments with math.fsum.
    """
    x = scenario(7, n=3000)
    if transform == "offset 1e6 sigma":
        x = x + 1e6
    elif transform == "drift":
        x = x + 1e6 + np.linspace(0.0, 50.0, x.size)
    elif transform == "float32":
        x = x.astype(np.float32)
    else:
        x = x * 1e-13
    got = adaptive_schedule(x, **SMALL)
    ext = np.pad(np.asarray(x, dtype=float), SMALL["lmax"] // 2 + 1, mode="symmetric")
    worst = 0.0
    for p in range(0, x.size, 3):
        L = int(got.window[p])
        a = p + SMALL["lmax"] // 2 + 1 - (L - 1) // 2
        w = ext[a : a + L] - ext[a + L // 2]
        m = math.fsum(w) / L
        d = w - m
        k = math.fsum(d**4) / L / (math.fsum(d**2) / L) ** 2
        worst = max(worst, abs(k - got.kurtosis[p]))
    assert worst < 1e-9


def test_reanchoring_keeps_long_records_exact():
    """Thousands of steps and re-anchorings, and a burst 1e4x the noise that comes and goes."""
    x = np.random.default_rng(11).standard_normal(12_000) + 1e6
    x[5000:5010] = 1e6 + 1e4 * np.random.default_rng(12).standard_normal(10)
    got = adaptive_schedule(x, **SMALL)
    want = literal_controller(x - 1e6, **SMALL)  # the same windows, offset removed exactly
    np.testing.assert_array_equal(got.window, want["window"])
    np.testing.assert_allclose(got.kurtosis, want["kurtosis"], atol=1e-9, rtol=0)


def test_paper_scenario_one_nodes_of_one_realisation():
    """Scenario 1 with the paper's parameters: the window starts shrinking when the leading
    edge meets the change (about 3000 - 300 s) and is back at Lmax after 4000 + 300 s."""
    x = np.random.default_rng(2018).standard_normal(6000)
    x[3000:4000] *= 3.0
    sched = adaptive_schedule(x, **PAPER)
    w = sched.window
    assert 2650 <= 2400 + np.argmax(w[2400:] < 600) <= 2720
    assert w[3300:3700].min() == 400
    assert np.median(w[4400:5600]) == 600  # back to Lmax, apart from false alarms


def test_oracle_schedule_pins_the_edges():
    n, x0, lmax, lmin = 3000, 1500, 200, 120
    w = oracle_schedule(n, [x0], lmax=lmax, lmin=lmin)
    p = np.arange(n)
    lead = p + w // 2  # last sample of the window (even L)
    trail = p - (w - 1) // 2
    shrinking = (w < lmax) & (p < x0) & (w > lmin)
    assert np.all(lead[shrinking] == x0)  # leading edge pinned on the change
    regrowing = (w < lmax) & (p >= x0) & (w > lmin)
    assert np.all(trail[regrowing] == x0)  # trailing edge pinned on the first changed sample
    assert np.all(w[: x0 - lmax // 2 + 1] == lmax)
    assert np.all(np.abs(np.diff(w)) <= 2)
    assert w.min() == lmin
    # several changes: the shortest of the lengths
    both = oracle_schedule(n, [x0, 2500], lmax=lmax, lmin=lmin)
    np.testing.assert_array_equal(
        both, np.minimum(w, oracle_schedule(n, [2500], lmax=lmax, lmin=lmin))
    )


def test_adaptive_davar_surface_is_davar_on_the_schedule():
    x = scenario(5)
    res = adavar.adaptive_davar(x, taus="octave", **SMALL)
    assert isinstance(res, AdaptiveResult)
    sched = adaptive_schedule(x, **SMALL)
    np.testing.assert_array_equal(res.window, sched.window)
    plain = adavar.davar(x, window=sched.window, taus="octave")
    np.testing.assert_array_equal(res.avar, plain.avar)
    np.testing.assert_array_equal(res.avar_high, plain.avar_high)
    np.testing.assert_array_equal(res.kurtosis, sched.kurtosis)
    assert res.method == "adaptive" and res.parameters["lmax"] == 200
    fit = adavar.fit_noise(res)
    assert fit.angle_random_walk.value.shape == (x.size,)


def test_adaptive_davar_options():
    x = scenario(6)
    valid = adavar.adaptive_davar(x, taus="octave", edges="valid", **SMALL)
    assert valid.centre[0] == (SMALL["lmax"] - 1) // 2
    assert valid.centre[-1] == x.size - 1 - SMALL["lmax"] // 2
    stepped = adavar.adaptive_davar(x, taus="octave", step=7, **SMALL)
    full = adavar.adaptive_davar(x, taus="octave", **SMALL)
    np.testing.assert_array_equal(stepped.avar, full.avar[::7])
    np.testing.assert_array_equal(stepped.kurtosis, full.kurtosis[::7])
    oracle = adavar.adaptive_davar(
        x, taus="octave", method="oracle", change_times=[900.0, 1200.0], **SMALL
    )
    np.testing.assert_array_equal(
        oracle.window, oracle_schedule(x.size, [900, 1200], lmax=200, lmin=120)
    )
    fixed = adavar.adaptive_davar(x, taus="octave", method="fixed", **SMALL)
    assert np.all(fixed.window == SMALL["lmax"])
    np.testing.assert_array_equal(fixed.avar, adavar.davar(x, window=200, taus="octave").avar)


def test_calibrated_thresholds_hit_the_false_alarm_rate():
    th = calibrated_thresholds(400, 600, 100, false_alarm=0.02)
    # Pearson kurtosis of each row (scipy.stats.kurtosis gives the same, in 60x the time)
    d = np.random.default_rng(4).standard_normal((20_000, 600))
    d -= d.mean(axis=1, keepdims=True)
    d *= d
    k = (d * d).mean(axis=1) / d.mean(axis=1) ** 2
    below = np.mean(k < th.k1[600])
    above = np.mean(k > th.k2[600])
    assert below == pytest.approx(0.01, abs=0.003)
    assert above == pytest.approx(0.01, abs=0.003)
    assert th.k2[400] > th.k2[600] > 3.0 > th.k1[600] > th.k1[400]  # wider for short windows
    assert th.s2[400] > th.s2[600] > 0
    # the paper's fixed K2 = 3.3 at L = 600 sits inside the Gaussian spread (about 7 % above)
    assert 0.04 < np.mean(k > 3.3) < 0.1


def test_false_alarm_rates_paper_vs_calibrated():
    paper = false_alarm_rate(n=60_000, seeds=(0,), **PAPER)
    calibrated = false_alarm_rate(n=60_000, seeds=(0,), **{**PAPER, "thresholds": "calibrated"},
                                  false_alarm=0.01)  # fmt: skip
    assert calibrated["f1"] < paper["f1"]
    assert calibrated["f1"] == pytest.approx(0.01, abs=0.01)
    assert calibrated["shrunk"] < paper["shrunk"]


@pytest.mark.parametrize(
    "kwargs",
    [
        {"method": "magic"},
        {"s_test": "two-sided"},
        {"combine": "xor"},
        {"lmin": 700},
        {"lmin": 401},
        {"dl0": 3},
        {"l": 398},
        {"k1": 3.5},
        {"k2": float("nan")},
        {"method": "oracle"},
        {"thresholds": "tuned"},
        {"lmax": 7000},
        {"lmax": 600.5},
        {"edges": "wrap"},
    ],
)
def test_bad_settings_are_one_line_errors(kwargs):
    x = scenario(0, n=6000)
    with pytest.raises(AdavarInputError) as info:
        adaptive_schedule(x, **kwargs)
    assert "\n" not in str(info.value)


def test_controller_statistics_agree_with_the_kurtosis_module():
    """The controller's running kurtosis and S equal the O(N) sliding ones on its schedule."""
    x = scenario(8) + 1e3
    sched = adaptive_schedule(x, **SMALL)
    k = adavar.sliding_kurtosis(x, window=sched.window)
    s = adavar.kurtosis_contribution(x, window=sched.window, segment=SMALL["l"])
    np.testing.assert_allclose(sched.kurtosis, k, atol=1e-9, rtol=0)
    np.testing.assert_allclose(sched.s, s, atol=1e-9, rtol=0)


@pytest.mark.parametrize("segments", [3, 7])
def test_parallel_segments_reproduce_the_sequential_pass_bit_for_bit(monkeypatch, segments):
    """Speculative segments (started from Lmax, WARM_UP centres early) and the sequential
    pass agree exactly, including segments whose guess must be rerun."""
    from adavar.dynamic import controller

    x = np.random.default_rng(21).standard_normal(40_000) + 5e5
    for a in range(0, x.size, 3000):  # frequent disturbances: some guesses will not coalesce
        x[a : a + 700] = 5e5 + 3.0 * (x[a : a + 700] - 5e5)
    monkeypatch.setattr(controller, "WARM_UP", 512)
    monkeypatch.setattr(controller, "_segments", lambda n: 1)
    one = adaptive_schedule(x, **SMALL)
    monkeypatch.setattr(controller, "_segments", lambda n: segments)
    many = adaptive_schedule(x, **SMALL)
    for name in ("window", "kurtosis", "s", "f1", "f2", "f"):
        np.testing.assert_array_equal(getattr(many, name), getattr(one, name))
    # with no warm-up a segment's guess (lmax) is wrong wherever the true window is
    # shorter at its start: those segments must be rerun from the true length
    monkeypatch.setattr(controller, "WARM_UP", 0)
    x_reg = np.random.default_rng(22).standard_normal(40_000)
    x_reg[::2] *= 1.0 + (np.arange(20_000) % 1024 < 500)  # long non-stationary stretches
    monkeypatch.setattr(controller, "_segments", lambda n: 1)
    ref = adaptive_schedule(x_reg, **SMALL).window
    bounds = [
        (k * x_reg.size // segments) // controller.REANCHOR * controller.REANCHOR
        for k in range(1, segments)
    ]
    assert any(ref[b] != SMALL["lmax"] for b in bounds)  # a rerun is needed
    monkeypatch.setattr(controller, "_segments", lambda n: segments)
    np.testing.assert_array_equal(adaptive_schedule(x_reg, **SMALL).window, ref)

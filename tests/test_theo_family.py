"""Theo1, ThêoBR and ThêoH: slow references, Stable32's tables, adversarial records, EDF."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import adavar
from adavar.core.errors import AdavarInputError
from adavar.stats import theo_family as tf
from tests.stable32_data import read_data, stable32_root

SETTINGS = settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# ---------------------------------------------------------------------------------------
# slow references (long double, the formulas as printed)


def phase_ref(u: np.ndarray) -> np.ndarray:
    """x[0] = 0, x[k] = u[0] + ... + u[k-1] in long double."""
    return np.concatenate([[0.0], np.cumsum(np.asarray(u, dtype=np.longdouble))])


def theo1_ref(u: np.ndarray, m: int) -> float:
    """SP 1065 Eq. 30 with tau0 = 1, summed term by term over delta."""
    x = phase_ref(u)
    n = x.size
    h = m // 2
    i = np.arange(n - m)
    total = np.longdouble(0)
    for delta in range(h):
        t = (x[i] - x[i - delta + h]) + (x[i + m] - x[i + delta + h])
        total += np.sum(t * t) / (h - delta)
    return float(total / (np.longdouble(0.75) * (n - m) * m * m))


def oavar_ref(u: np.ndarray, m: int) -> float:
    x = phase_ref(u)
    d = x[2 * m :] - 2 * x[m:-m] + x[: -2 * m]
    return float(np.sum(d * d) / (2 * m * m * d.size))


def kf_ref(u: np.ndarray) -> float:
    n = u.size + 1
    ratios = [
        oavar_ref(u, 9 + 3 * i) / theo1_ref(u, 12 + 4 * i)
        for i in range(n // 6 - 3 + 1)
        if n - 2 * (9 + 3 * i) >= 1
    ]
    return float(np.mean(ratios))


def dev(u, stat, ms, **kw):
    return adavar.deviation(
        u, stat=stat, rate=1.0, taus=np.asarray(ms, float), confidence=None, **kw
    )


# ---------------------------------------------------------------------------------------
# against the references


@SETTINGS
@given(
    n=st.integers(20, 160),
    seed=st.integers(0, 2**32 - 1),
    kind=st.sampled_from(["white", "walk", "offset", "drift", "step", "tiny", "huge"]),
)
def test_theo1_matches_reference(n, seed, kind):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    if kind == "walk":
        u = np.cumsum(u)
    elif kind == "offset":
        u = u + 1e9
    elif kind == "drift":
        u = u + 1e3 * np.arange(n)
    elif kind == "step":
        u[n // 2 :] += 1e6
    # powers of two (about 1e-200 and 1e200): u * scale is then exactly the scaled record,
    # and the reference on u, times scale, is its exact answer (with 1e200 the rounding
    # of each scaled sample alone moved a cancelling TIE rms by 1e-12)
    scale = {"tiny": 2.0**-665, "huge": 2.0**665}.get(kind, 1.0)
    ms = np.unique(rng.integers(1, n // 2 + 1, size=3) * 2)
    ms = ms[ms <= n]
    got = dev(u * scale, "theo1", ms)
    # Theo1 is blind to a frequency offset: the reference sees u - u[0] (exact subtraction)
    ref = np.sqrt([theo1_ref(u - u[0], int(m)) for m in got.m])
    # after a 1e6 step the long-double reference itself keeps only ~1e-12 of d
    rtol = 1e-10 if kind == "step" else 1e-12
    np.testing.assert_allclose(got.dev / scale, ref, rtol=rtol, atol=0)
    np.testing.assert_array_equal(got.tau, 0.75 * got.m)
    np.testing.assert_array_equal(got.n, (n + 1 - got.m) * (got.m // 2))


@SETTINGS
@given(n=st.integers(20, 120), seed=st.integers(0, 2**32 - 1))
def test_theobr_matches_reference(n, seed):
    rng = np.random.default_rng(seed)
    u = np.cumsum(rng.standard_normal(n)) * 0.1 + rng.standard_normal(n)
    ms = np.array([2, 4, 2 * (n // 2)])
    got = dev(u, "theobr", ms)
    kf = kf_ref(u)
    ref = np.array([theo1_ref(u, int(m)) for m in got.m]) * kf
    np.testing.assert_allclose(got.dev**2, ref, rtol=1e-11)
    assert tf.theobr_ratio(u) == pytest.approx(kf, rel=1e-12)


def test_theoh_is_avar_then_theobr():
    rng = np.random.default_rng(3)
    u = rng.standard_normal(400)
    got = adavar.deviation(u, stat="theoh", rate=2.0, taus="all", confidence=None)
    assert np.all((got.m < 3) | (got.m % 3 == 0))
    assert got.m[-1] == tf.m_max("theoh", 401) == 300
    np.testing.assert_allclose(got.tau, got.m * 0.5)
    k = int(0.1 * 400)
    short = got.m < k
    oadev = adavar.deviation(u, stat="oadev", rate=2.0, taus=got.tau[short], confidence=None)
    np.testing.assert_allclose(got.dev[short], oadev.dev, rtol=1e-13)
    long = ~short
    br = adavar.deviation(u, stat="theobr", rate=2.0, taus=4 * got.tau[long] / 3, confidence=None)
    np.testing.assert_allclose(br.tau, got.tau[long])
    np.testing.assert_allclose(got.dev[long], br.dev, rtol=1e-13)
    assert any("multiple of 3" in s for s in got.notes)


def test_factors_and_notes():
    ms, notes = tf.factors("theo1", np.array([1, 2, 3, 8, 9]))
    np.testing.assert_array_equal(ms, [2, 4, 8, 10])
    assert "0.75 m tau0" in notes[0] and "odd" in notes[1]
    assert tf.m_max("theo1", 1001) == 1000 and tf.m_max("theo1", 1000) == 998
    ms, _ = tf.factors("theoh", np.array([1, 2, 4, 5, 8, 16]))
    np.testing.assert_array_equal(ms, [1, 2, 3, 6, 9, 15])


def test_rate_and_phase_agree():
    rng = np.random.default_rng(5)
    y = rng.standard_normal(300)
    x = np.concatenate([[0.0], np.cumsum(y)]) * 0.1  # phase of rate y sampled at 10 Hz
    a = adavar.deviation(y, stat="theo1", rate=10.0, taus="octave", confidence=None)
    b = adavar.deviation(
        x, stat="theo1", rate=10.0, data_type="phase", taus="octave", confidence=None
    )
    np.testing.assert_allclose(a.dev, b.dev, rtol=1e-10)
    np.testing.assert_allclose(a.tau, 0.75 * a.m * 0.1)


def test_bad_input():
    with pytest.raises(AdavarInputError, match="at least 18 phase points"):
        dev(np.ones(10) + np.arange(10.0), "theobr", [2])
    with pytest.raises(AdavarInputError, match="theo_ratio_terms"):
        dev(np.random.default_rng(0).standard_normal(100), "theobr", [2], theo_ratio_terms=1)
    with pytest.raises(AdavarInputError, match="does not apply to stat='theo1'"):
        dev(np.random.default_rng(0).standard_normal(100), "theo1", [2], theo_ratio_terms=8)


def test_ratio_terms_option_is_close():
    u = np.random.default_rng(8).standard_normal(600)
    exact = tf.theobr_ratio(u)
    assert tf.theobr_ratio(u, 200) == exact  # more terms asked than there are: all
    assert tf.theobr_ratio(u, 16) == pytest.approx(exact, rel=0.1)


# ---------------------------------------------------------------------------------------
# the all-tau kernel against the exact one (its raw output too, before any fallback)

KINDS = ["white", "walk", "run", "offset", "drift", "smooth", "step", "phase_step", "float32"]


def adversarial(kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` increments of a record that makes the lag products cancel (or lose digits)."""
    w = rng.standard_normal(n)
    k = np.arange(n, dtype=np.float64)
    if kind == "walk":  # random-walk FM: the phase grows as n^1.5
        return np.cumsum(w)
    if kind == "run":  # random-run FM, on a frequency offset
        return np.cumsum(np.cumsum(w)) + 1e9
    if kind == "offset":
        return w + 1e9
    if kind == "drift":
        return w + 1e3 * k
    if kind == "smooth":  # a pure drift, noise at 1e-8 of it
        return k + 1e-8 * w
    if kind == "step":  # level steps of the frequency
        return w + 1e6 * (k >= n // 2) - 3e5 * (k >= n // 3)
    if kind == "phase_step":
        return w + np.where(k == n // 2, 1e6, 0.0)
    if kind == "float32":
        return (w + 1e3).astype(np.float32).astype(np.float64)
    return w


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=st.integers(3, 400),
    seed=st.integers(0, 2**32 - 1),
    kind=st.sampled_from(KINDS),
    scale=st.sampled_from([1.0, 2.0**60, 2.0**-60]),
)
def test_fast_matches_exact(n, seed, kind, scale):
    rng = np.random.default_rng(seed)
    u = adversarial(kind, n, rng) * scale
    ms = np.arange(2, n + 1, 2)
    exact = tf.theo1_double_sums(u, ms, "exact")
    raw, bound = tf._fast_sums(np.ascontiguousarray(u), ms)
    # both kernels are within a few ulps of the rational value; the bound holds
    np.testing.assert_allclose(raw, exact, rtol=1e-12, atol=0)
    assert np.all(np.abs(raw - exact) <= bound + 1e-14 * exact)
    np.testing.assert_allclose(tf.theo1_double_sums(u, ms, "fast"), exact, rtol=1e-12, atol=0)


@pytest.mark.parametrize("kind", KINDS)
def test_fast_all_taus_adversarial(kind):
    # a longer record, every even factor, through deviation (scaled by 2**+-900 too)
    u = adversarial(kind, 1500, np.random.default_rng(4))
    ms = np.arange(2, 1501, 2)
    exact = tf.theo1_double_sums(u, ms, "exact")
    np.testing.assert_allclose(tf.theo1_double_sums(u, ms, "fast"), exact, rtol=1e-12, atol=0)
    got = dev(u, "theo1", ms)
    np.testing.assert_array_equal(got.m, ms)
    ref = np.sqrt(exact / (0.75 * (1501 - ms) * ms * ms))
    np.testing.assert_allclose(got.dev, ref, rtol=1e-12, atol=0)
    for e in (900, -900):
        scaled = dev(u * 2.0**e, "theo1", ms)
        np.testing.assert_array_equal(scaled.dev, np.ldexp(got.dev, e))


def test_fast_float32_input():
    y = np.random.default_rng(6).standard_normal(999).astype(np.float32) + np.float32(1e4)
    got = adavar.deviation(y, stat="theo1", rate=1.0, taus="all", confidence=None)
    ms = got.m
    exact = tf.theo1_double_sums(y.astype(np.float64), ms, "exact")
    np.testing.assert_allclose(got.dev**2 * 0.75 * (1000 - ms) * ms * ms, exact, rtol=1e-12)


def test_fast_falls_back_where_its_bound_is_loose(monkeypatch):
    u = adversarial("walk", 300, np.random.default_rng(1))
    ms = np.arange(2, 301, 2)
    exact = tf.theo1_double_sums(u, ms, "exact")
    real = tf._fast_sums

    def loose_at_short_taus(u, ms):
        sums, bound = real(u, ms)
        return sums * (1 + 1e-6 * (ms < 40)), np.where(ms < 40, np.inf, bound)

    monkeypatch.setattr(tf, "_fast_sums", loose_at_short_taus)
    got = tf.theo1_double_sums(u, ms, "fast")
    np.testing.assert_array_equal(got[ms < 40], exact[ms < 40])  # redone exactly
    np.testing.assert_allclose(got, exact, rtol=1e-12)
    monkeypatch.setattr(tf, "FAST_TOLERANCE", 0.0)  # nothing is certain: all exact
    np.testing.assert_array_equal(tf.theo1_double_sums(u, ms, "fast"), exact)


def test_method_choice_and_checks():
    n = 20000
    every = np.arange(2, n, 2)
    octave = 2 ** np.arange(1, 15)
    assert tf._fast_cost(n, every) < tf._exact_cost(n, every) / 100
    assert tf._fast_cost(n, tf.ratio_factors(n)[1]) < tf._exact_cost(n, tf.ratio_factors(n)[1])
    assert tf._exact_cost(n, octave[:4]) < tf._fast_cost(n, octave[:4])
    u = np.random.default_rng(0).standard_normal(99)
    got = tf.theo1_double_sums(u, [8, 2, 8, 4])  # any order, repeats
    np.testing.assert_array_equal(got, tf.theo1_double_sums(u, [2, 4, 8])[[2, 0, 2, 1]])
    for bad in ([3], [0], [100]):
        with pytest.raises(AdavarInputError, match="even factors"):
            tf.theo1_double_sums(u, bad)
    with pytest.raises(AdavarInputError, match="method"):
        tf.theo1_double_sums(u, [2], "slow")
    assert tf.theo1_double_sums(np.full(50, 3.0), [2, 10], "fast").tolist() == [0.0, 0.0]


@SETTINGS
@given(n=st.integers(17, 700), seed=st.integers(0, 2**32 - 1), kind=st.sampled_from(KINDS))
def test_theobr_ratio_fast_matches_exact(n, seed, kind):
    u = adversarial(kind, n, np.random.default_rng(seed))
    if n == 17:  # 18 points: the one pair has no AVAR term
        with pytest.raises(AdavarInputError, match="no AVAR/Theo1 pair"):
            tf.theobr_ratio(u)
        return
    m_avar, m_theo = tf.ratio_factors(n + 1)
    fast = tf._ratio(u, m_avar, tf._theo1_var(u, m_theo, "fast"))
    exact = tf._ratio(u, m_avar, tf._theo1_var(u, m_theo, "exact"))
    assert fast == pytest.approx(exact, rel=1e-12)


def test_theobr_exact_ratio_is_fast_and_right():
    rng = np.random.default_rng(9)
    u = np.cumsum(rng.standard_normal(3000)) + rng.normal(0, 30, 3000)  # white to walk FM
    m_avar, m_theo = tf.ratio_factors(3001)
    assert tf._fast_cost(3001, m_theo) < tf._exact_cost(3001, m_theo) / 10  # the fast kernel
    assert m_theo.size == 3001 // 6 - 3 + 1
    exact = tf._ratio(u, m_avar, tf._theo1_var(u, m_theo, "exact"))
    assert tf.theobr_ratio(u) == pytest.approx(exact, rel=1e-12)
    got = dev(u, "theobr", [2, 100, 3000])
    theo = tf._theo1_var(u, got.m, "exact")
    np.testing.assert_allclose(got.dev**2, theo * exact, rtol=1e-12)
    # the option still picks evenly spread terms, both ends included
    m_avar, m_theo = tf.ratio_factors(3001, 5)
    i = np.round(np.linspace(0, 497, 5)).astype(int)
    np.testing.assert_array_equal(m_theo, 12 + 4 * i)
    np.testing.assert_array_equal(m_avar, 9 + 3 * i)


# ---------------------------------------------------------------------------------------
# Stable32 (PHASE.DAT)


def _rows(path):
    out = []
    with open(path, encoding="latin-1") as f:
        for line in f:
            parts = line.split()
            if not line.startswith("#") and len(parts) == 7:
                out.append([float(v) for v in parts])
    return np.array(out)


@pytest.mark.parametrize(
    "table, stat",
    [
        ("phase_dat_theo1_alpha0.txt", "theo1"),
        ("phase_dat_theo1_alpha0_decade.txt", "theo1"),
        # Stable32's "Thêo1" with bias removal: ThêoBR, kf = 0.60279 on this record
        ("phase_dat_theo1.txt", "theobr"),
    ],
)
def test_stable32_phase_dat(table, stat):
    root = stable32_root() / "tests" / "phasedat"
    x = read_data(root / "PHASE.DAT")
    rows = _rows(root / table)
    got = adavar.deviation(
        x, stat=stat, rate=1.0, data_type="phase", taus=rows[:, 0], confidence=None
    )
    np.testing.assert_array_equal(got.m, rows[:, 0])
    np.testing.assert_allclose(got.tau, rows[:, 1], rtol=1e-12)
    printed = np.array([float(f"{v:.4e}") for v in got.dev])
    np.testing.assert_array_equal(printed, rows[:, 5])
    np.testing.assert_allclose(got.n, rows[:, 2], rtol=5e-5)  # "#" printed to 5 digits


# ---------------------------------------------------------------------------------------
# EDF


def test_theo1_edf_formulas():
    # SP 1065 white FM at N = 1001, m = 10 (r = 7.5), evaluated by hand
    assert tf.theo1_edf(0, 10, 1001) == pytest.approx(
        ((4.1 * 1001 + 0.8) / 7.5 - (3.1 * 1001 + 6.5) / 1001) * 7.5**1.5 / (7.5**1.5 + 5.2)
    )
    for alpha in (2, 1, 0, -1, -2, -3, 3):
        values = [tf.edf("theo1", alpha, m, 1001) for m in (2, 10, 100, 500, 1000)]
        assert all(np.isfinite(values)) and min(values) >= 1.0
    assert tf.edf("theo1", -3, 100, 1001) == tf.edf("theo1", -2, 100, 1001)  # clamped
    assert tf.edf("theobr", 0, 100, 1001) == tf.edf("theo1", 0, 100, 1001)
    assert tf.edf("theoh", 0, 300, 1001) == tf.edf("theo1", 0, 400, 1001)
    assert tf.edf("theoh", 0, 30, 1001) == adavar.stats.edf.edf("oadev", 0, 30, 1001)


def test_intervals_through_deviation():
    u = np.random.default_rng(2).standard_normal(500)
    got = adavar.deviation(u, stat="theo1", rate=1.0, taus="octave")
    assert np.all(got.dev_low < got.dev) and np.all(got.dev < got.dev_high)

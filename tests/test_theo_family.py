"""Theo1, ThêoBR and ThêoH: slow references, Stable32's tables, adversarial records, EDF."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import adavar
from adavar import theo_family as tf
from adavar.errors import AdavarInputError
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
    scale = {"tiny": 1e-200, "huge": 1e200}.get(kind, 1.0)
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
    assert tf.edf("theoh", 0, 30, 1001) == adavar.edf.edf("oadev", 0, 30, 1001)


def test_intervals_through_deviation():
    u = np.random.default_rng(2).standard_normal(500)
    got = adavar.deviation(u, stat="theo1", rate=1.0, taus="octave")
    assert np.all(got.dev_low < got.dev) and np.all(got.dev < got.dev_high)

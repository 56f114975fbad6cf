"""Allan-family statistics: published values, the allantools peer, and exactness."""

from __future__ import annotations

import allantools
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import adavar
from adavar.core.datasets import nist_1000
from adavar.core.errors import AdavarInputError
from adavar.stats.statistics import STATISTICS, deviation

from . import reference

# NIST SP 1065 section 12.4, via ../shared/spec/REFERENCE.md
NIST = {
    "adev": (2.922319e-01, 9.965736e-02, 3.897804e-02),
    "oadev": (2.922319e-01, 9.159953e-02, 3.241343e-02),
    "mdev": (2.922319e-01, 6.172376e-02, 2.170921e-02),
    "tdev": (1.687202e-01, 3.563623e-01, 1.253382e00),
    "hdev": (2.943883e-01, 1.052754e-01, 3.910861e-02),
    "ohdev": (2.943883e-01, 9.581083e-02, 3.237638e-02),
    "totdev": (2.922319e-01, 9.134743e-02, 3.406530e-02),
}
PEER = {
    "adev": allantools.adev,
    "oadev": allantools.oadev,
    "mdev": allantools.mdev,
    "tdev": allantools.tdev,
    "hdev": allantools.hdev,
    "ohdev": allantools.ohdev,
    "totdev": allantools.totdev,
}


def test_nist_generator_check_values():
    y = nist_1000()
    n = np.round(y * 2147483647).astype(np.int64)
    assert n[:4].tolist() == [1234567890, 395529916, 1209410747, 633705974]
    assert np.mean(y) == pytest.approx(4.897745e-01, rel=1e-6)
    assert np.std(y, ddof=1) == pytest.approx(2.884664e-01, rel=1e-6)


@pytest.mark.parametrize("stat", sorted(NIST))
@pytest.mark.parametrize("data_type", ["rate", "phase"])
def test_nist_published_values(stat, data_type):
    y = nist_1000()
    data = y if data_type == "rate" else np.concatenate([[0.0], np.cumsum(y)])
    r = deviation(data, stat=stat, data_type=data_type, taus=[1, 10, 100])
    np.testing.assert_array_equal(r.m, [1, 10, 100])
    np.testing.assert_allclose(r.dev, NIST[stat], rtol=1e-6)


def _power_law(kind, n, seed):
    rng = np.random.default_rng(seed)
    w = rng.standard_normal(n)
    if kind == "white":
        return w
    if kind == "random_walk":
        return np.cumsum(w)
    # flicker: 1/f by spectral shaping of white noise
    f = np.fft.rfftfreq(n)
    spec = np.fft.rfft(w)
    spec[1:] /= np.sqrt(f[1:])
    spec[0] = 0.0
    return np.fft.irfft(spec, n)


@pytest.mark.parametrize("kind", ["white", "random_walk", "flicker"])
@pytest.mark.parametrize("data_type", ["rate", "phase"])
@pytest.mark.parametrize("stat", STATISTICS)
def test_agrees_with_allantools(kind, data_type, stat):
    y = _power_law(kind, 3000, seed=len(kind) + len(stat))
    ours = deviation(y, stat=stat, rate=4.0, data_type=data_type, taus="all", confidence=None)
    t, dev, _, _ = PEER[stat](
        y, rate=4.0, data_type="freq" if data_type == "rate" else "phase", taus=ours.tau
    )
    common, i, j = np.intersect1d(ours.tau, t, return_indices=True)
    assert common.size > 0.6 * ours.tau.size
    np.testing.assert_allclose(ours.dev[i], dev[j], rtol=1e-9)


def _adversarial(kind, n, rng):
    w = rng.standard_normal(n)
    t = np.arange(n)
    if kind == "offset_drift":
        return 1e6 + w + 3.0 * t / n  # 1e6 sigma offset plus a drift across the record
    if kind == "random_walk":
        return np.cumsum(w) + 1e4
    if kind == "tiny":
        return 1e-13 * w + 1e-7
    if kind == "huge":
        return 1e12 * w - 5e17
    if kind == "steep_drift":
        return 1e3 * t + w
    raise ValueError(kind)


KINDS = ["offset_drift", "random_walk", "tiny", "huge", "steep_drift"]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("stat", STATISTICS)
def test_exact_against_slow_reference(kind, stat):
    rng = np.random.default_rng(7)
    y = _adversarial(kind, 157, rng)
    r = deviation(y, stat=stat, taus="all", confidence=None)
    want = reference.deviation(y, r.m, stat)
    np.testing.assert_allclose(r.dev, want, rtol=1e-9)


@pytest.mark.parametrize("stat", STATISTICS)
def test_exact_across_anchor_blocks(stat):
    """Differences that straddle anchor blocks (1024 samples) and parallel superblocks."""
    rng = np.random.default_rng(3)
    n = 3100
    y = 1e6 + rng.standard_normal(n) + np.linspace(0, 50, n)
    ms = [1, 3, 1000] if stat in ("mdev", "tdev", "hdev", "ohdev") else [1, 3, 1023, 1024, 1025]
    r = deviation(y, stat=stat, taus=np.array(ms, dtype=float), confidence=None)
    np.testing.assert_array_equal(r.m, ms)
    np.testing.assert_allclose(r.dev, reference.deviation(y, r.m, stat), rtol=1e-9)


@pytest.mark.parametrize("stat", ["oadev", "ohdev", "mdev", "tdev", "adev", "hdev"])
def test_phase_input_exact_with_offset(stat):
    rng = np.random.default_rng(11)
    x = 1e9 + np.cumsum(rng.standard_normal(200)) + 0.5 * np.arange(200)
    r = deviation(x, stat=stat, data_type="phase", rate=10.0, taus="all", confidence=None)
    want = reference.deviation(x, r.m, stat, data_type="phase", tau0=0.1)
    np.testing.assert_allclose(r.dev, want, rtol=1e-9)


def test_float32_input_is_promoted_and_exact():
    rng = np.random.default_rng(5)
    y32 = (1000.0 + rng.standard_normal(300)).astype(np.float32)
    r = deviation(y32, taus="all", confidence=None)
    want = reference.deviation(y32.astype(np.float64), r.m, "oadev")
    np.testing.assert_allclose(r.dev, want, rtol=1e-9)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=st.integers(12, 120),
    seed=st.integers(0, 2**32 - 1),
    offset=st.sampled_from([0.0, 1.0, -1e6, 1e9]),
    drift=st.sampled_from([0.0, 1e-3, 5.0, -1e4]),
    scale=st.sampled_from([1e-12, 1.0, 1e8]),
    stat=st.sampled_from(STATISTICS),
)
def test_property_matches_reference(n, seed, offset, drift, scale, stat):
    rng = np.random.default_rng(seed)
    y = scale * (rng.standard_normal(n) + offset + drift * np.arange(n) / n)
    r = deviation(y, stat=stat, taus="all", confidence=None)
    want = reference.deviation(y, r.m, stat)
    # relative 1e-9, or a few ulps of the samples where a tau's few terms cancel to far
    # below the noise (one Hadamard term 5 orders below its peers, after a 1e4-sigma ramp)
    floor = 16 * np.finfo(float).eps * float(np.max(np.abs(y)))
    np.testing.assert_array_less(np.abs(r.dev - want), 1e-9 * want + floor)


@settings(max_examples=25, deadline=None)
@given(
    c=st.integers(-(10**9), 10**9),
    k=st.integers(-30, 30),
    seed=st.integers(0, 1000),
    stat=st.sampled_from(STATISTICS),
)
def test_offset_invariance_and_scaling(c, k, seed, stat):
    # dyadic samples, so that the shifted and scaled records are exactly representable
    y = np.round(np.random.default_rng(seed).standard_normal(400) * 2**20) / 2**20
    base = deviation(y, stat=stat, confidence=None).dev
    moved = deviation(np.ldexp(y + c, k), stat=stat, confidence=None).dev
    np.testing.assert_allclose(moved, np.ldexp(base, k), rtol=1e-9)


def test_confidence_intervals_bracket_and_shrink():
    y = np.random.default_rng(2).standard_normal(20000)
    r = deviation(y, taus="octave")
    assert np.all(r.dev_low < r.dev) and np.all(r.dev < r.dev_high)
    assert np.all(r.edf > 0)
    width = (r.dev_high - r.dev_low) / r.dev
    assert width[0] < 0.05 and width[-1] > width[0]  # narrow at tau0, wide at the end
    assert np.all(r.alpha[:8] == 0)  # white FM identified at short taus
    wide = deviation(y, taus="octave", confidence=0.95)
    assert np.all(wide.dev_high - wide.dev_low > r.dev_high - r.dev_low)


def test_confidence_none_skips_intervals():
    r = deviation(np.random.default_rng(1).standard_normal(100), confidence=None)
    assert np.all(np.isnan(r.dev_low)) and np.all(np.isfinite(r.dev))


def test_tau_keywords_and_explicit_lists():
    y = np.random.default_rng(0).standard_normal(1000)
    assert deviation(y, taus="octave", rate=10).m.tolist() == [1, 2, 4, 8, 16, 32, 64, 128, 256]
    assert deviation(y, taus="decade").m.tolist() == [1, 2, 4, 10, 20, 40, 100, 200, 400]
    assert deviation(y, taus="all", confidence=None).m.tolist() == list(range(1, 501))
    log = deviation(y, taus="log", points_per_decade=5, confidence=None).m
    assert log[0] == 1 and np.all(np.diff(log) > 0) and log[-1] == 500
    r = deviation(y, rate=10.0, taus=[0.1, 0.26, 1.0, 1e6], confidence=None)
    np.testing.assert_allclose(r.tau, [0.1, 0.3, 1.0])
    assert any("rounded" in s for s in r.notes) and any("dropped" in s for s in r.notes)
    assert deviation(y, tau0=0.5, confidence=None).tau[1] == 1.0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"data": [1.0, np.nan, 2.0, 3.0]}, "sample 1"),
        ({"data": np.ones((10, 3))}, "one channel"),
        ({"data": [1.0, 2.0]}, "at least 3"),
        ({"stat": "foo"}, "unknown stat"),
        ({"data_type": "angle"}, "data_type"),
        ({"rate": -1.0}, "positive"),
        ({"confidence": 1.5}, "confidence"),
        ({"taus": "weekly"}, "taus keyword"),
        ({"taus": [1e9]}, "no requested tau"),
        ({"data": ["a", "b", "c"]}, "numeric"),
    ],
)
def test_bad_input_gives_clear_errors(kwargs, message):
    args = {"data": np.arange(50.0)} | kwargs
    data = args.pop("data")
    with pytest.raises(AdavarInputError, match=message):
        deviation(data, **args)


def test_public_api_exposes_deviation():
    assert adavar.deviation is deviation


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.one_of(st.none(), st.integers(-2, 2)), min_size=1, max_size=40).filter(
        lambda v: any(a is not None for a in v)
    )
)
def test_unidentified_taus_take_the_nearest_identified_one(values):
    # the bisection of fill_unidentified against the dense distance matrix it replaced
    # (which needed n_taus x n_known memory: 193 GiB for taus="all" on 720k samples)
    from adavar.stats.noise_id import fill_unidentified

    alpha = np.array([np.nan if v is None else v for v in values], dtype=float)
    known = np.flatnonzero(np.isfinite(alpha))
    index = np.arange(alpha.size)
    want = alpha[known[np.abs(index[:, None] - known[None, :]).argmin(axis=1)]]
    np.testing.assert_array_equal(fill_unidentified(alpha)[0], want.astype(np.int64))

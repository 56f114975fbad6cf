"""The anchored integral and the noise-identification kernels against slow references."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from adavar._kernels import differences as diff
from adavar.stats import edf


def _series(kind, n, seed):
    rng = np.random.default_rng(seed)
    w = rng.standard_normal(n)
    return {
        "white": w,
        "random_walk": np.cumsum(w),
        "offset_drift": 1e6 + w + np.linspace(0.0, 30.0, n),
        "white_pm": np.diff(rng.standard_normal(n + 1)),
        "steep": 1e3 * np.arange(n) + w,
    }[kind]


KINDS = ["white", "random_walk", "offset_drift", "white_pm", "steep"]


@pytest.mark.parametrize("kind", KINDS)
def test_anchored_integral_is_exact(kind):
    u = _series(kind, 5000, 1)
    p = diff.anchored_phase(u)
    # the exact integral of the shifted increments, up to the one rounding of each u - shift
    values = p.values()
    for j in (0, 1, 1023, 1024, 1025, 2048, 4999, 5000):
        want = math.fsum(list(u[:j]) + [-p.shift] * j)
        bound = 2 * np.finfo(float).eps * (np.abs(u[:j] - p.shift).sum() + abs(want))
        assert abs(values[j] - want) <= bound, j


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("m", [1, 2, 3, 7, 16, 100])
def test_cluster_sums_exact(kind, m):
    u = _series(kind, 3000, 2)
    got = diff.cluster_sums(diff.anchored_phase(u), m)
    want = [math.fsum(u[k * m : (k + 1) * m]) for k in range(3000 // m)]
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(u).max())


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("m", [1, 2, 4, 5, 32, 64])
@pytest.mark.parametrize("dmax", [0, 2, 3])
def test_streaming_lag1_matches_reference(kind, m, dmax):
    """The streaming kernel equals edf.identify_noise_lag1 on the materialised series."""
    u = _series(kind, 6000, 3)
    p = diff.anchored_phase(u)
    r1, den, sizes, scale = diff.cluster_lag1(p, m, dmax)
    z = np.array([math.fsum(u[k * m : (k + 1) * m]) for k in range(6000 // m)]) / m
    # reference r1 per order from the slow, materialised path
    x = z - np.polynomial.polynomial.polyval(
        np.linspace(-1, 1, z.size),
        np.polynomial.polynomial.polyfit(np.linspace(-1, 1, z.size), z, 1),
    )
    for d in range(dmax + 1):
        c = x - x.mean()
        want = np.dot(c[:-1], c[1:]) / np.dot(c, c)
        assert r1[d] == pytest.approx(want, abs=1e-8), d
        assert sizes[d] == z.size - d
        x = np.diff(x)
    try:
        want_alpha = edf.identify_noise_lag1(z, data_type="rate", dmax=dmax)
    except edf.NoiseIdError:
        with pytest.raises(edf.NoiseIdError):
            edf.alpha_from_lag1(r1, den / m**2, sizes, scale / m, data_type="rate", dmax=dmax)
        return
    got = edf.alpha_from_lag1(r1, den, sizes, scale, data_type="rate", dmax=dmax)
    assert got[0] == want_alpha[0]
    assert got[1] == pytest.approx(want_alpha[1], abs=1e-8)


@settings(max_examples=30, deadline=None)
@given(
    n=st.integers(300, 5000),
    seed=st.integers(0, 10**6),
    kind=st.sampled_from(KINDS),
    level=st.integers(0, diff.FUSED_LEVELS - 1),
)
def test_fused_lag1_equals_streaming(n, seed, kind, level):
    """The moments gathered while integrating give the streaming kernel's answer."""
    m = 1 << level
    u = _series(kind, n, seed)
    p = diff.anchored_phase(u, cluster_stats=True)
    fused = diff.fused_lag1(p, m)
    if n // m < 8:
        assert fused is None
        return
    streamed = diff.cluster_lag1(p, m, 0)
    if fused is None:  # only for trend-dominated series, where the algebra would cancel
        assert kind == "steep"
        return
    assert fused[0][0] == pytest.approx(streamed[0][0], abs=1e-9)
    assert fused[1][0] == pytest.approx(streamed[1][0], rel=1e-6)
    assert fused[2][0] == streamed[2][0]


def test_fused_lag1_only_for_fused_levels():
    p = diff.anchored_phase(np.random.default_rng(0).standard_normal(1000), cluster_stats=True)
    assert diff.fused_lag1(p, 3) is None
    assert diff.fused_lag1(p, 1 << diff.FUSED_LEVELS) is None
    assert diff.fused_lag1(diff.anchored_phase(np.ones(1000)), 1) is None  # no moments

"""Tests of adavar.simulation.iir against scipy.signal, the slow and obviously correct reference.

The Butterworth design, the steady-state initial conditions and the cascade filter are
compared with ``scipy.signal.butter``/``sosfilt_zi``/``sosfilt``/``lfilter`` on random and
adversarial inputs: orders 1 to 8, cutoffs from 1e-4 to 0.49 of the rate, lengths 1 to
1e5, offsets of 1e9, steps, a Nyquist-rate alternation, float32 samples and scales of
1e-30 and 1e30. Both do the same operations, so they agree to rounding (on the builds
tried, bit for bit); the tolerance is 1e-12 relative, or relative to the largest input
sample where the output cancels. The replacements in :mod:`adavar.simulate` (the
Kasdin-Walter FFT convolution, the Gauss-Markov recursion, the sensor's low-pass) are
checked against the scipy.signal calls they replace.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import signal

from adavar import simulate as sim
from adavar.simulation import generators, iir

RTOL = 1e-12
KINDS = (
    "normal",
    "offset",
    "step",
    "alternating",
    "impulse",
    "constant",
    "tiny",
    "huge",
    "float32",
)

orders = st.integers(1, 8)
# cutoff / rate, log-uniform over 1e-4 .. 0.49
ratios = st.floats(math.log10(1e-4), math.log10(0.49)).map(lambda u: 10.0**u)
rates = st.sampled_from([1.0, 100.0, 2500.0, 3.7e6])
lengths = st.one_of(st.integers(1, 40), st.integers(1, 100_000))
seeds = st.integers(0, 2**32 - 1)


def _samples(kind: str, n: int, seed: int) -> np.ndarray:
    """``n`` samples of one of the input kinds of :data:`KINDS`."""
    rng = np.random.default_rng(seed)
    z = rng.standard_normal(n)
    k = np.arange(n)
    if kind == "offset":
        return 1e9 + z
    if kind == "step":
        return np.where(k >= rng.integers(0, n), 5.0, -2.0)
    if kind == "alternating":
        return np.where(k % 2 == 1, 1.0, -1.0)
    if kind == "impulse":
        return np.where(k == rng.integers(0, n), 1.0, 0.0)
    if kind == "constant":
        return np.full(n, 7.25)
    if kind == "tiny":
        return 1e-30 * z
    if kind == "huge":
        return 1e30 * z
    if kind == "float32":
        return (3.0 * z).astype(np.float32)
    return z


def _assert_rows_close(got: np.ndarray, want: np.ndarray, rtol: float = 1e-13) -> None:
    """Sections agree, numerator and denominator each relative to its largest coefficient.

    A coefficient that is zero in exact arithmetic (``a1`` at a quarter of the rate) comes
    out as a rounding error: only its size relative to the row means anything.
    """
    assert got.shape == want.shape
    for part in (slice(0, 3), slice(3, 6)):
        scale = np.max(np.abs(want[:, part]), axis=1, keepdims=True)
        assert np.all(np.abs(got[:, part] - want[:, part]) <= rtol * scale), (got, want)


def _assert_filtered_close(got: np.ndarray, want: np.ndarray, x: np.ndarray) -> None:
    """Outputs agree to :data:`RTOL`, relative, or relative to the largest input sample."""
    assert got.dtype == np.float64
    assert got.shape == want.shape
    scale = float(np.max(np.abs(x))) if x.size else 0.0
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=RTOL * scale)


# ---------------------------------------------------------------------------------------
# the Butterworth design and its steady state


@settings(max_examples=300, deadline=None)
@given(order=orders, ratio=ratios, rate=rates)
def test_design_matches_scipy(order: int, ratio: float, rate: float) -> None:
    want = signal.butter(order, ratio * rate, btype="low", fs=rate, output="sos")
    got = iir.butter_lowpass_sos(order, ratio * rate, rate)
    _assert_rows_close(got, want)
    zi = iir.sosfilt_zi(want)
    ref = signal.sosfilt_zi(want)
    np.testing.assert_allclose(zi, ref, rtol=RTOL, atol=RTOL * np.max(np.abs(ref)))


@pytest.mark.parametrize("order", range(1, 9))
@pytest.mark.parametrize("ratio", [1e-4, 0.01, 0.2, 0.25, 0.3, 0.45, 0.49])
def test_design_pairing_and_gain(order: int, ratio: float) -> None:
    """Same sections in the same order, gain in the first, at the points where scipy's
    pairing changes (the extra zero at the origin of an odd order goes to the pole
    nearest to it; at a quarter of the rate the real pole sits at the origin)."""
    want = signal.butter(order, ratio, fs=1.0, output="sos")
    got = iir.butter_lowpass_sos(order, ratio, 1.0)
    _assert_rows_close(got, want)
    assert np.all(got[:, 3] == 1.0)
    # unit gain at DC
    dc = np.prod(got[:, :3].sum(axis=1) / got[:, 3:].sum(axis=1))
    assert dc == pytest.approx(1.0, rel=1e-6)


@pytest.mark.parametrize(
    ("order", "cutoff", "rate"),
    [(0, 1.0, 10.0), (9.0, 1.0, 10.0), (True, 1.0, 10.0), (2, 0.0, 10.0), (2, 5.0, 10.0),
     (2, -1.0, 10.0), (2, math.nan, 10.0), (2, 1.0, 0.0), (2, 1.0, math.inf)],
)  # fmt: skip
def test_design_rejects_bad_arguments(order: object, cutoff: float, rate: float) -> None:
    with pytest.raises(ValueError):
        iir.butter_lowpass_sos(order, cutoff, rate)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------------------
# the cascade filter


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(order=orders, ratio=ratios, n=lengths, kind=st.sampled_from(KINDS), seed=seeds)
def test_filter_matches_scipy(order: int, ratio: float, n: int, kind: str, seed: int) -> None:
    """Started in the steady state of the first sample, as simulate.sensor does."""
    x = _samples(kind, n, seed)
    sos = signal.butter(order, ratio, fs=1.0, output="sos")
    want = signal.sosfilt(sos, x, zi=signal.sosfilt_zi(sos) * x[0])[0]
    got = iir.sosfilt(sos, x, iir.sosfilt_zi(sos) * x[0])
    _assert_filtered_close(got, want, x)


@settings(max_examples=60, deadline=None)
@given(order=orders, ratio=ratios, n=lengths, kind=st.sampled_from(KINDS), seed=seeds)
def test_filter_from_rest_matches_scipy(
    order: int, ratio: float, n: int, kind: str, seed: int
) -> None:
    x = _samples(kind, n, seed)
    sos = signal.butter(order, ratio, fs=1.0, output="sos")
    _assert_filtered_close(iir.sosfilt(sos, x), signal.sosfilt(sos, x), x)


@settings(max_examples=100, deadline=None)
@given(
    phi=st.one_of(st.floats(0.0, 0.999999), st.sampled_from([1.0 - 1e-9, 1.0 - 2.0**-52])),
    gain=st.floats(1e-6, 10.0),
    n=lengths,
    kind=st.sampled_from(KINDS),
    seed=seeds,
)
def test_first_order_section_matches_lfilter(
    phi: float, gain: float, n: int, kind: str, seed: int
) -> None:
    """The AR(1) recursion ``y[k] = phi y[k-1] + gain x[k]`` of simulate.markov."""
    x = _samples(kind, n, seed)
    y0 = 0.75 * float(x[0])
    want, _ = signal.lfilter([gain], [1.0, -phi], x, zi=[phi * y0])
    section = np.array([[gain, 0.0, 0.0, 1.0, -phi, 0.0]])
    got = iir.sosfilt(section, x, np.array([[phi * y0, 0.0]]))
    _assert_filtered_close(got, want, x)


def test_filter_edge_shapes() -> None:
    sos = signal.butter(3, 0.1, output="sos")
    assert iir.sosfilt(sos, np.zeros(0)).shape == (0,)
    x = np.arange(10.0)[::2]  # not contiguous
    np.testing.assert_array_equal(iir.sosfilt(sos, x), signal.sosfilt(sos, x))
    np.testing.assert_array_equal(iir.sosfilt(sos, [1, 2, 3]), signal.sosfilt(sos, [1, 2, 3]))
    zi = iir.sosfilt_zi(sos)
    iir.sosfilt(sos, x, zi)
    np.testing.assert_array_equal(zi, signal.sosfilt_zi(sos))  # the state is not changed


@pytest.mark.parametrize(
    ("sos", "x", "zi"),
    [
        (np.ones((1, 5)), np.ones(3), None),
        (np.ones((0, 6)), np.ones(3), None),
        (np.array([[1.0, 0, 0, 2.0, 0, 0]]), np.ones(3), None),
        (np.array([[1.0, 0, 0, 1.0, 0, 0]]), np.ones((3, 2)), None),
        (np.array([[1.0, 0, 0, 1.0, 0, 0]]), np.ones(3), np.zeros((2, 2))),
    ],
)
def test_filter_rejects_bad_arguments(sos: np.ndarray, x: np.ndarray, zi: object) -> None:
    with pytest.raises(ValueError):
        iir.sosfilt(sos, x, zi)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------------------
# the simulator's uses


@pytest.mark.parametrize("n", [2, 3, 17, 1000, 65_537])
def test_flicker_is_scipy_fftconvolve(n: int) -> None:
    w = math.sqrt(math.pi * 2.0) * np.random.default_rng(n).standard_normal(n)
    want = signal.fftconvolve(w, generators._kasdin_walter_coefficients(n, 1.0))[:n]
    got = sim.flicker(n, h_minus1=2.0, seed=n)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15 * np.max(np.abs(want)))


@pytest.mark.parametrize("n", [2, 3, 1000, 65_537])
def test_markov_is_scipy_lfilter(n: int) -> None:
    std, corr, rate = 0.3, 7.0, 2.0
    z = np.random.default_rng(n).standard_normal(n)
    phi = math.exp(-1.0 / (rate * corr))
    gain = std * math.sqrt(-math.expm1(-2.0 / (rate * corr)))
    want = np.empty(n)
    want[0] = std * z[0]
    want[1:], _ = signal.lfilter([gain], [1.0, -phi], z[1:], zi=[phi * want[0]])
    _assert_filtered_close(sim.markov(n, std, corr, rate=rate, seed=n), want, z)


@pytest.mark.parametrize("order", range(1, 9))
def test_sensor_low_pass_is_scipy(order: int) -> None:
    kw = {"rate": 100.0, "angle_random_walk": 0.01, "bias": 0.2, "seed": 7}
    raw = sim.sensor(20_000, **kw)
    want_sos = signal.butter(order, 20.0, btype="low", fs=100.0, output="sos")
    want = signal.sosfilt(want_sos, raw, zi=signal.sosfilt_zi(want_sos) * raw[0])[0]
    got = sim.sensor(20_000, bandwidth=20.0, filter_order=order, **kw)
    _assert_filtered_close(got, want, raw)

r"""Seeded generators of inertial-sensor and clock noise (IEEE Std 952 terms).

Every generator returns a float64 array of ``n`` **rate** samples ``w[k]`` (angular rate,
specific force, fractional frequency, ...) taken every ``tau0 = 1 / rate`` seconds, sample
``k`` belonging to time ``t_k = k * tau0``.  The integrated signal (angle, velocity, phase)
is ``theta[k] = tau0 * sum(w[:k])``.  Below ``u`` denotes the unit of the rate samples
(e.g. deg/s); PSDs are **one-sided** (defined for ``f > 0``, integrating to the variance).

Allan variance (AVAR) of the IEEE Std 952 terms, ``tau = m * tau0``:

=====================  ==================  ======================  ==========================
term                   coefficient (unit)  one-sided rate PSD      AVAR
=====================  ==================  ======================  ==========================
quantization           Q (u*s)             2 (2 pi f)^2 Q^2 tau0   3 Q^2 / tau^2
angle random walk      N (u/sqrt(Hz))      2 N^2                   N^2 / tau
bias instability       B (u)               B^2 / (pi f)            (2 ln2 / pi) B^2
rate random walk       K (u*sqrt(Hz))      2 K^2 / (2 pi f)^2      K^2 tau / 3
rate ramp              R (u/s)             deterministic           R^2 tau^2 / 2
=====================  ==================  ======================  ==========================

IEEE Std 952 writes the same PSDs two-sided (half the one-sided values above:
``(2 pi f)^2 Q^2 tau0``, ``N^2``, ``B^2 / (2 pi f)``, ``K^2 / (2 pi f)^2``).  The AVAR
formulas are exact for every ``tau = m tau0`` for Q, N and R, and hold for ``m >~ 16`` for
B and ``m >~ 10`` for K (see the individual functions for the discrete corrections).

Seeds
-----
Each random generator takes ``seed``: an int, None (fresh OS entropy), a
:class:`numpy.random.SeedSequence` or a :class:`numpy.random.Generator`, passed to
:func:`numpy.random.default_rng`.  A Generator is used (and advanced) in place, and
:func:`sensor` spawns children from a Generator or SeedSequence (which advances its spawn
counter), so pass an int for reproducible calls.
:func:`sensor` draws every term from its own child stream
(:meth:`numpy.random.SeedSequence.spawn`), so switching one term on or off, or changing its
coefficient, does not change the draws of the others.

Users reach these through :mod:`adavar.simulate`, which also gives the A-DAVAR paper's
simulated records (:mod:`adavar.paper.scenarios`, built on these generators).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from adavar.core.settings import MAX_SAMPLES

__all__ = [
    "MAX_SAMPLES",
    "angle_random_walk",
    "bias_instability",
    "flicker",
    "markov",
    "piecewise_white",
    "piecewise_white_times",
    "quantization",
    "random_walk",
    "rate_ramp",
    "rate_random_walk",
    "sensor",
    "sinusoid",
    "white",
]

SeedLike = int | np.integer | np.random.SeedSequence | np.random.Generator | None
"""Anything :func:`numpy.random.default_rng` accepts as a seed."""

FloatArray = NDArray[np.float64]


# Order of the child streams of `sensor`.  Append new random terms at the END only, so that
# existing seeds keep producing the same draws for the existing terms.
_SENSOR_STREAMS = (
    "quantization",
    "angle_random_walk",
    "bias_instability",
    "rate_random_walk",
    "markov",
)


# --------------------------------------------------------------------------------------------
# Argument validation
# --------------------------------------------------------------------------------------------


def _check_n(n: object, name: str = "n") -> int:
    if isinstance(n, bool) or not isinstance(n, numbers.Integral):
        raise ValueError(
            f"{name} must be an integer number of samples (got {n!r} of type "
            f"{type(n).__name__}); pass e.g. int({name})."
        )
    if n < 1:
        raise ValueError(f"{name} must be >= 1 (got {n}); request at least one sample.")
    if n > MAX_SAMPLES:
        raise ValueError(
            f"{name} must be at most {MAX_SAMPLES:,} samples (got {n}): the record alone "
            f"would take {8 * int(n) / 2**30:.1f} GiB; simulate fewer samples."
        )
    return int(n)


def _check_real(value: object, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(
            f"{name} must be a real number (got {value!r} of type {type(value).__name__}); "
            "pass a float."
        )
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite (got {value}); pass a finite float.")
    return value


def _check_rate(rate: object) -> float:
    rate = _check_real(rate, "rate")
    if rate <= 0.0:
        raise ValueError(
            f"rate must be > 0 Hz (got {rate}); pass the sampling rate in Hz, e.g. rate=100.0."
        )
    return rate


def _check_nonneg(value: object, name: str) -> float:
    value = _check_real(value, name)
    if value < 0.0:
        raise ValueError(f"{name} must be >= 0 (got {value}); pass a non-negative value.")
    return value


def _check_positive(value: object, name: str) -> float:
    value = _check_real(value, name)
    if value <= 0.0:
        raise ValueError(f"{name} must be > 0 (got {value}); pass a positive value.")
    return value


def _rng(seed: SeedLike) -> np.random.Generator:
    try:
        return np.random.default_rng(seed)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"seed must be an int >= 0, None, a SeedSequence or a Generator (got {seed!r}); "
            "pass e.g. seed=42."
        ) from exc


def _spawn(seed: SeedLike, k: int) -> list[np.random.Generator]:
    """``k`` independent generators derived from ``seed`` (fixed order)."""
    if isinstance(seed, np.random.Generator):
        try:
            return list(seed.spawn(k))
        except TypeError:  # bit generator without a SeedSequence: draw fresh entropy from it
            entropy = seed.integers(0, 2**32, size=4, dtype=np.uint64)
            seq = np.random.SeedSequence([int(e) for e in entropy])
    elif isinstance(seed, np.random.SeedSequence):
        seq = seed
    else:
        _rng(seed)  # validate
        seq = np.random.SeedSequence(None if seed is None else int(seed))
    return [np.random.default_rng(child) for child in seq.spawn(k)]


# --------------------------------------------------------------------------------------------
# Generic processes
# --------------------------------------------------------------------------------------------


def white(n: int, std: float = 1.0, *, rate: float = 1.0, seed: SeedLike = None) -> FloatArray:
    r"""White Gaussian noise (white FM / angle random walk in the rate samples).

    Parameters
    ----------
    n : int
        Number of samples, ``1`` to :data:`MAX_SAMPLES`.
    std : float, default 1.0
        Standard deviation of each sample, in rate units ``u``; ``>= 0``.
    rate : float, default 1.0
        Sampling rate in Hz (``tau0 = 1/rate``).
    seed : int, None, SeedSequence or Generator
        Seed of the random stream.

    Returns
    -------
    ndarray of float64, shape (n,)
        ``std * z[k]`` with ``z`` i.i.d. standard normal.

    Notes
    -----
    One-sided PSD ``S(f) = 2 std^2 tau0`` (u^2/Hz) for ``0 < f < rate/2``; Allan variance
    ``std^2 tau0 / tau`` exactly for every ``tau = m tau0``.  See :func:`angle_random_walk`
    for the IEEE 952 parametrisation.
    """
    n = _check_n(n)
    _check_rate(rate)
    std = _check_nonneg(std, "std")
    return std * _rng(seed).standard_normal(n)


def random_walk(
    n: int, step_std: float = 1.0, *, rate: float = 1.0, seed: SeedLike = None
) -> FloatArray:
    r"""Discrete Gaussian random walk (random-walk FM in the rate samples).

    Parameters
    ----------
    n : int
        Number of samples, ``1`` to :data:`MAX_SAMPLES`.
    step_std : float, default 1.0
        Standard deviation of each step ``w[k] - w[k-1]``, in rate units ``u``; ``>= 0``.
    rate : float, default 1.0
        Sampling rate in Hz (``tau0 = 1/rate``).
    seed : int, None, SeedSequence or Generator
        Seed of the random stream.

    Returns
    -------
    ndarray of float64, shape (n,)
        ``w[k] = step_std * sum(z[:k+1])`` (the walk starts from 0 one sample before ``k=0``).

    Notes
    -----
    With ``q = step_std^2`` the one-sided PSD is ``S(f) = q tau0 / (2 sin^2(pi f tau0))``,
    ``~ 2 q / (tau0 (2 pi f)^2)`` at low frequency, and the Allan variance is exactly
    ``q (2 m^2 + 1) / (6 m) = (q/tau0) tau/3 + q tau0/(6 tau)``.  See
    :func:`rate_random_walk` for the IEEE 952 parametrisation.
    """
    n = _check_n(n)
    _check_rate(rate)
    step_std = _check_nonneg(step_std, "step_std")
    return np.cumsum(step_std * _rng(seed).standard_normal(n))


def _kasdin_walter_coefficients(n: int, alpha: float, size: int | None = None) -> FloatArray:
    """Impulse response of ``(1 - z^-1)^(-alpha/2)``: ``h_0 = 1, h_k = h_{k-1} (k-1+alpha/2)/k``.

    ``size``: the response followed by zeros up to that length (the padded input of an
    FFT), built in place: one array of ``size`` and one of ``n`` at a time.
    """
    out = np.zeros(max(n, size or n))
    out[0] = 1.0
    k = np.arange(1, n, dtype=np.float64)
    h = out[1:n]
    np.subtract(k, 1.0, out=h)
    h += 0.5 * alpha
    h /= k
    del k
    np.cumprod(h, out=h)
    return out


def flicker(
    n: int, *, h_minus1: float = 1.0, rate: float = 1.0, seed: SeedLike = None
) -> FloatArray:
    r"""Flicker (1/f) noise by the Kasdin–Walter fractional-integration filter.

    White Gaussian noise of variance ``sigma^2 = pi * h_minus1`` is filtered by the
    truncated impulse response of ``(1 - z^-1)^(-1/2)`` (Kasdin & Walter 1992, ``alpha = 1``):
    ``h_0 = 1``, ``h_k = h_{k-1} (k - 1/2) / k``, i.e. ``h_k = Gamma(k + 1/2) /
    (Gamma(1/2) Gamma(k + 1))``.  The convolution is evaluated by FFT in ``O(n log n)``.
    The filter starts from a zero history (the first sample is white), as in Kasdin–Walter.

    Parameters
    ----------
    n : int
        Number of samples, ``1`` to :data:`MAX_SAMPLES`.
    h_minus1 : float, default 1.0
        Level of the one-sided PSD ``S(f) = h_minus1 / f``, in u^2 (u^2/Hz times Hz); ``>= 0``.
    rate : float, default 1.0
        Sampling rate in Hz (``tau0 = 1/rate``).
    seed : int, None, SeedSequence or Generator
        Seed of the random stream.

    Returns
    -------
    ndarray of float64, shape (n,)
        Flicker-noise rate samples.

    Notes
    -----
    PSD convention.  The discrete filter has ``|H(f)|^2 = 1 / (2 sin(pi f tau0))``, so the
    one-sided PSD of the output is ``S(f) = 2 sigma^2 tau0 |H(f)|^2 = pi h_minus1 tau0 /
    sin(pi f tau0)``, which equals ``h_minus1 / f`` to within 0.5 % for
    ``1/(n tau0) << f <= rate/20`` (independent of ``rate``).

    Allan variance.  Flicker FM has ``AVAR = 2 ln2 h_minus1`` (flat).  For this discrete
    process the exact AVAR is ``2 ln2 h_minus1 * c(m)`` with ``c(1) = 1/ln2 = 1.443``,
    ``c(2) = 1.154``, ``c(4) = 1.050``, ``c(8) = 1.015``, ``c(16) = 1.005``, ``c(64) = 1.0004``
    (``c(m) - 1 ~ 1/m^2``): the floor is reached for ``tau >= 16 tau0`` and holds up to a
    good fraction of the record length.
    """
    n = _check_n(n)
    _check_rate(rate)
    h_minus1 = _check_nonneg(h_minus1, "h_minus1")
    rng = _rng(seed)
    if n == 1:
        return math.sqrt(math.pi * h_minus1) * rng.standard_normal(n)
    from scipy import fft

    # the linear convolution as scipy.signal.fftconvolve computes it (same transforms, same
    # length), without importing scipy.signal (a second, most of it scipy.stats). The
    # transforms of a long record are twice its size each: the filter's first, then the
    # noise's, each input padded in place, so that at most three such arrays coexist
    size = fft.next_fast_len(2 * n - 1, real=True)
    response = fft.rfft(_kasdin_walter_coefficients(n, 1.0, size), overwrite_x=True)
    padded = np.zeros(size)
    np.multiply(math.sqrt(math.pi * h_minus1), rng.standard_normal(n), out=padded[:n])
    spectrum = fft.rfft(padded, overwrite_x=True)
    del padded
    spectrum *= response
    del response
    full = fft.irfft(spectrum, size, overwrite_x=True)
    del spectrum
    return np.array(full[:n], np.float64)  # not a view that holds the padded 2 n


def markov(
    n: int,
    std: float,
    correlation_time: float,
    *,
    rate: float = 1.0,
    seed: SeedLike = None,
) -> FloatArray:
    r"""First-order Gauss–Markov process (exponentially correlated noise), stationary start.

    Exact discretisation of ``dx/dt = -x/T + noise``: ``x[0] ~ N(0, std^2)`` and
    ``x[k] = phi x[k-1] + std sqrt(1 - phi^2) z[k]`` with ``phi = exp(-tau0/T)``, so every
    sample has variance ``std^2`` and ``corr(x[k], x[k+j]) = exp(-j tau0 / T)``.

    Parameters
    ----------
    n : int
        Number of samples, ``1`` to :data:`MAX_SAMPLES`.
    std : float
        Stationary standard deviation, in rate units ``u``; ``>= 0``.
    correlation_time : float
        Correlation time ``T`` in seconds; ``> 0``.
    rate : float, default 1.0
        Sampling rate in Hz (``tau0 = 1/rate``).
    seed : int, None, SeedSequence or Generator
        Seed of the random stream.

    Returns
    -------
    ndarray of float64, shape (n,)
        Gauss–Markov rate samples.

    Notes
    -----
    One-sided PSD (continuous process) ``S(f) = 4 std^2 T / (1 + (2 pi f T)^2)`` (u^2/Hz).
    Allan variance (continuous process, IEEE Std 952 with ``q_c = 2 std^2 / T``)
    ``AVAR(tau) = (q_c T^2 / tau) [1 - (T / (2 tau)) (3 - 4 e^{-tau/T} + e^{-2 tau/T})]``:
    ``~ q_c tau / 3`` (rate random walk) for ``tau << T`` and ``~ q_c T^2 / tau`` (white) for
    ``tau >> T``, peaking near ``tau = 1.89 T``.  The sampled process matches it up to
    the usual point-sampling correction at ``tau ~ tau0``.
    """
    n = _check_n(n)
    tau0 = 1.0 / _check_rate(rate)
    std = _check_nonneg(std, "std")
    correlation_time = _check_positive(correlation_time, "correlation_time")
    phi = math.exp(-tau0 / correlation_time)
    innovation = std * math.sqrt(-math.expm1(-2.0 * tau0 / correlation_time))
    z = _rng(seed).standard_normal(n)
    x = np.empty(n)
    x[0] = std * z[0]
    if n > 1:
        from adavar.simulation.iir import sosfilt

        # x[k] = phi x[k-1] + innovation z[k]: one first-order section
        section = np.array([[innovation, 0.0, 0.0, 1.0, -phi, 0.0]])
        x[1:] = sosfilt(section, z[1:], np.array([[phi * x[0], 0.0]]))
    return x


def sinusoid(
    n: int,
    amplitude: float,
    frequency: float,
    *,
    phase: float = 0.0,
    rate: float = 1.0,
) -> FloatArray:
    r"""Deterministic sinusoid ``amplitude * sin(2 pi frequency t_k + phase)``.

    Parameters
    ----------
    n : int
        Number of samples, ``1`` to :data:`MAX_SAMPLES`.
    amplitude : float
        Amplitude ``Omega_0`` in rate units ``u``; ``>= 0``.
    frequency : float
        Frequency ``f_0`` in Hz, ``0 <= f_0 <= rate/2`` (above Nyquist it would alias).
    phase : float, default 0.0
        Phase in radians at ``t = 0``.
    rate : float, default 1.0
        Sampling rate in Hz; ``t_k = k / rate``.

    Returns
    -------
    ndarray of float64, shape (n,)

    Notes
    -----
    PSD: a line of power ``amplitude^2 / 2`` at ``f_0``.  Allan variance (IEEE Std 952,
    averaged over the phase) ``AVAR(tau) = amplitude^2 (sin^2(pi f_0 tau) / (pi f_0 tau))^2``.
    """
    n = _check_n(n)
    rate = _check_rate(rate)
    amplitude = _check_nonneg(amplitude, "amplitude")
    frequency = _check_nonneg(frequency, "frequency")
    phase = _check_real(phase, "phase")
    if frequency > rate / 2.0:
        raise ValueError(
            f"frequency {frequency} Hz exceeds the Nyquist frequency rate/2 = {rate / 2.0} Hz; "
            "pass the aliased frequency or raise rate."
        )
    t = np.arange(n, dtype=np.float64) / rate
    return amplitude * np.sin(2.0 * math.pi * frequency * t + phase)


# --------------------------------------------------------------------------------------------
# IEEE Std 952 terms
# --------------------------------------------------------------------------------------------


def quantization(
    n: int, coefficient: float, *, rate: float = 1.0, seed: SeedLike = None
) -> FloatArray:
    r"""Quantization noise with coefficient ``Q`` (white noise of the integrated signal).

    The integrated signal (angle) carries a white error ``e[k]`` of standard deviation ``Q``;
    the rate samples are its first difference, ``w[k] = (e[k+1] - e[k]) / tau0``.

    Parameters
    ----------
    n : int
        Number of samples, ``1`` to :data:`MAX_SAMPLES`.
    coefficient : float
        ``Q`` in u*s (e.g. deg for a gyro, m/s for an accelerometer, s for a clock); ``>= 0``.
    rate : float, default 1.0
        Sampling rate in Hz (``tau0 = 1/rate``).
    seed : int, None, SeedSequence or Generator
        Seed of the random stream.

    Returns
    -------
    ndarray of float64, shape (n,)

    Notes
    -----
    One-sided rate PSD ``S(f) = 8 Q^2 sin^2(pi f tau0) / tau0 ~ 2 (2 pi f)^2 Q^2 tau0``
    (u^2/Hz, white PM; IEEE 952 two-sided ``(2 pi f)^2 Q^2 tau0``).  Allan variance
    ``3 Q^2 / tau^2``, exact for every ``tau = m tau0``.
    """
    n = _check_n(n)
    rate = _check_rate(rate)
    q = _check_nonneg(coefficient, "coefficient (Q)")
    e = q * _rng(seed).standard_normal(n + 1)
    return np.diff(e) * rate


def angle_random_walk(
    n: int, coefficient: float, *, rate: float = 1.0, seed: SeedLike = None
) -> FloatArray:
    r"""Angle (velocity) random walk with coefficient ``N``: white rate noise.

    Parameters
    ----------
    n : int
        Number of samples, ``1`` to :data:`MAX_SAMPLES`.
    coefficient : float
        ``N`` in u/sqrt(Hz) = u*sqrt(s) (e.g. deg/sqrt(s)); ``>= 0``.  Each sample has
        standard deviation ``N / sqrt(tau0) = N sqrt(rate)``.
    rate : float, default 1.0
        Sampling rate in Hz (``tau0 = 1/rate``).
    seed : int, None, SeedSequence or Generator
        Seed of the random stream.

    Returns
    -------
    ndarray of float64, shape (n,)

    Notes
    -----
    One-sided rate PSD ``S(f) = 2 N^2`` (u^2/Hz; two-sided ``N^2``, the IEEE 952
    convention).  Allan variance ``N^2 / tau``, exact for every ``tau = m tau0``.
    """
    n = _check_n(n)
    rate = _check_rate(rate)
    big_n = _check_nonneg(coefficient, "coefficient (N)")
    return big_n * math.sqrt(rate) * _rng(seed).standard_normal(n)


def bias_instability(
    n: int, coefficient: float, *, rate: float = 1.0, seed: SeedLike = None
) -> FloatArray:
    r"""Bias instability with coefficient ``B``: flicker rate noise.

    :func:`flicker` with ``h_minus1 = B^2 / pi`` (the Kasdin–Walter filter is driven by white
    noise of standard deviation exactly ``B``).

    Parameters
    ----------
    n : int
        Number of samples, ``1`` to :data:`MAX_SAMPLES`.
    coefficient : float
        ``B`` in rate units u (e.g. deg/s); ``>= 0``.
    rate : float, default 1.0
        Sampling rate in Hz (``tau0 = 1/rate``).
    seed : int, None, SeedSequence or Generator
        Seed of the random stream.

    Returns
    -------
    ndarray of float64, shape (n,)

    Notes
    -----
    One-sided rate PSD ``S(f) = B^2 / (pi f)`` (u^2/Hz; IEEE 952 two-sided
    ``B^2 / (2 pi f)``).  Allan variance floor ``(2 ln2 / pi) B^2 = 0.4413 B^2``
    (``ADEV = 0.664 B``) for ``tau >= 16 tau0``; see :func:`flicker` for the small-``tau``
    excess of the discrete process.
    """
    b = _check_nonneg(coefficient, "coefficient (B)")
    return flicker(n, h_minus1=b * b / math.pi, rate=rate, seed=seed)


def rate_random_walk(
    n: int,
    coefficient: float,
    *,
    rate: float = 1.0,
    seed: SeedLike = None,
    sampling: Literal["point", "average"] = "point",
) -> FloatArray:
    r"""Rate random walk with coefficient ``K``: the rate is a Brownian motion ``K W(t)``.

    Parameters
    ----------
    n : int
        Number of samples, ``1`` to :data:`MAX_SAMPLES`.
    coefficient : float
        ``K`` in u*sqrt(Hz) = u/sqrt(s) (e.g. deg/s/sqrt(s)); ``>= 0``.
    rate : float, default 1.0
        Sampling rate in Hz (``tau0 = 1/rate``).
    seed : int, None, SeedSequence or Generator
        Seed of the random stream.
    sampling : {"point", "average"}, default "point"
        ``"point"``: discrete random walk, ``w[k] = w[k-1] + K sqrt(tau0) z[k]`` (steps of
        standard deviation ``K sqrt(tau0)``, walk starting at 0).  ``"average"``: each sample is
        the mean of ``K W(t)`` over its interval ``[k tau0, (k+1) tau0]`` (``W(0) = 0``), as an
        integrating sensor would deliver.

    Returns
    -------
    ndarray of float64, shape (n,)

    Notes
    -----
    One-sided rate PSD ``S(f) = 2 K^2 / (2 pi f)^2`` (u^2/Hz; IEEE 952 two-sided
    ``K^2 / (2 pi f)^2``).  Allan
    variance ``K^2 tau / 3``: exact for every ``tau = m tau0`` with ``sampling="average"``;
    with ``"point"`` it is ``K^2 tau / 3 + K^2 tau0^2 / (6 tau)``, i.e. ``K^2 tau/3`` times
    ``1 + 1/(2 m^2)`` (+50 % at ``m = 1``, +0.5 % at ``m = 10``).
    """
    n = _check_n(n)
    tau0 = 1.0 / _check_rate(rate)
    k = _check_nonneg(coefficient, "coefficient (K)")
    if sampling == "point":
        return np.cumsum(k * math.sqrt(tau0) * _rng(seed).standard_normal(n))
    if sampling == "average":
        z = _rng(seed).standard_normal((2, n))
        steps = math.sqrt(tau0) * z[0]  # W((k+1) tau0) - W(k tau0)
        start = np.concatenate([[0.0], np.cumsum(steps[:-1])])  # W(k tau0)
        # Mean of a Brownian bridge over [0, tau0] given its end: step/2, variance tau0/12.
        return k * (start + 0.5 * steps + math.sqrt(tau0 / 12.0) * z[1])
    raise ValueError(f"sampling must be 'point' or 'average' (got {sampling!r}); pick one.")


def rate_ramp(n: int, coefficient: float, *, rate: float = 1.0) -> FloatArray:
    r"""Rate ramp with coefficient ``R``: the deterministic rate ``R t_k``, ``t_k = k tau0``.

    Parameters
    ----------
    n : int
        Number of samples, ``1`` to :data:`MAX_SAMPLES`.
    coefficient : float
        ``R`` in u/s (e.g. deg/s^2); ``>= 0``.
    rate : float, default 1.0
        Sampling rate in Hz (``tau0 = 1/rate``).

    Returns
    -------
    ndarray of float64, shape (n,)

    Notes
    -----
    Adjacent ``tau``-averages differ by exactly ``R tau``, so the Allan variance is
    ``R^2 tau^2 / 2`` exactly (PSD ``~ R^2 / (2 pi f)^3`` in IEEE 952).
    """
    n = _check_n(n)
    rate = _check_rate(rate)
    r = _check_nonneg(coefficient, "coefficient (R)")
    return r * (np.arange(n, dtype=np.float64) / rate)


# --------------------------------------------------------------------------------------------
# Composite sensor and non-stationary white noise
# --------------------------------------------------------------------------------------------


def sensor(
    n: int,
    *,
    rate: float = 1.0,
    quantization: float = 0.0,
    angle_random_walk: float = 0.0,
    bias_instability: float = 0.0,
    rate_random_walk: float = 0.0,
    rate_ramp: float = 0.0,
    bias: float = 0.0,
    markov: tuple[float, float] | None = None,
    sinusoid: tuple[float, float] | tuple[float, float, float] | None = None,
    bandwidth: float | None = None,
    filter_order: int = 2,
    lsb: float | None = None,
    seed: SeedLike = None,
) -> FloatArray:
    r"""Rate output of a sensor: sum of independent IEEE 952 noise terms and disturbances.

    With ``bandwidth`` and ``lsb`` it is the output of a real MEMS sensor: the noise passes
    the sensor's digital low-pass (anti-aliasing) filter and the result is quantised to the
    output word's least significant bit, so the Allan deviation shows the short-tau roll-off
    and the correlated samples that real logs have.

    Parameters
    ----------
    n : int
        Number of samples, ``1`` to :data:`MAX_SAMPLES`.
    rate : float, default 1.0
        Sampling rate in Hz (``tau0 = 1/rate``).
    quantization : float, default 0.0
        ``Q`` in u*s, AVAR ``3 Q^2 / tau^2`` (see :func:`quantization`).
    angle_random_walk : float, default 0.0
        ``N`` in u/sqrt(Hz), AVAR ``N^2 / tau`` (see :func:`angle_random_walk`).
    bias_instability : float, default 0.0
        ``B`` in u, AVAR floor ``(2 ln2 / pi) B^2`` (see :func:`bias_instability`).
    rate_random_walk : float, default 0.0
        ``K`` in u*sqrt(Hz), AVAR ``K^2 tau / 3`` (point-sampled, see
        :func:`rate_random_walk`).
    rate_ramp : float, default 0.0
        ``R`` in u/s, AVAR ``R^2 tau^2 / 2`` (see :func:`rate_ramp`).
    bias : float, default 0.0
        Constant offset in u (any sign); no effect on the Allan variance.
    markov : (std, correlation_time) or None
        First-order Gauss–Markov term (see :func:`markov`).
    sinusoid : (amplitude, frequency) or (amplitude, frequency, phase) or None
        Deterministic sinusoid (see :func:`sinusoid`).
    bandwidth : float or None, default None
        -3 dB bandwidth in Hz of the sensor's digital low-pass filter, below the Nyquist
        frequency ``rate / 2`` (a MEMS gyro at 100 Hz with its filter at 20 Hz: 20.0). The
        sum of all terms (bias and ramp included) passes a Butterworth low-pass of order
        ``filter_order`` with unit gain at DC, started in its steady state so the record has
        no start-up transient. The long-tau Allan variance is unchanged; below a few
        ``1 / bandwidth`` the samples are correlated and the Allan deviation rolls off
        below the ``N / sqrt(tau)`` line. None: no filter.
    filter_order : int, default 2
        Order of that Butterworth filter (1 to 8).
    lsb : float or None, default None
        Quantisation step of the output in ``u`` (the sensor's least significant bit, e.g.
        ``1/131`` deg/s for a +-250 deg/s 16-bit gyro): the output is rounded to the
        nearest multiple of ``lsb``, after the filter. Where the noise spans many LSBs the
        rounding error is white with variance ``lsb**2 / 12``, which adds
        ``lsb**2 tau0 / (12 tau)`` to the Allan variance (an angle-random-walk-like term);
        where it spans less than one LSB the output is piecewise constant and the record
        becomes strongly correlated. None: no quantisation.
    seed : int, None, SeedSequence or Generator
        Root seed.  The random terms use fixed child streams of it, in the order
        quantization, angle random walk, bias instability, rate random walk, Markov, so each
        term's draws do not depend on which other terms are present.

    Returns
    -------
    ndarray of float64, shape (n,)

    Notes
    -----
    The terms are independent, so the PSDs and Allan variances add:
    ``AVAR = 3Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3 + R^2 tau^2/2 + ...``.
    ``bandwidth`` multiplies the PSD by the filter's ``|H(f)|^2`` (so the sum holds at
    ``tau >> 1/bandwidth``), and ``lsb`` adds the rounding error described above.

    Examples
    --------
    A 100 Hz MEMS gyro with a 20 Hz filter and a 16-bit output at +-250 deg/s:

    >>> from adavar import simulate
    >>> w = simulate.sensor(360_000, rate=100.0, angle_random_walk=0.005,
    ...                     bias_instability=0.002, rate_random_walk=1e-4,
    ...                     bandwidth=20.0, lsb=1 / 131, seed=1)
    """
    n = _check_n(n)
    rate = _check_rate(rate)
    if bandwidth is not None:
        bandwidth = _check_positive(bandwidth, "bandwidth")
        if not bandwidth < rate / 2.0:
            raise ValueError(
                f"bandwidth {bandwidth} Hz is not below the Nyquist frequency rate/2 = "
                f"{rate / 2.0} Hz; give a bandwidth below it, or None for no filter."
            )
        if isinstance(filter_order, bool) or filter_order not in range(1, 9):
            raise ValueError(f"filter_order must be an integer from 1 to 8, got {filter_order!r}")
    if lsb is not None:
        lsb = _check_positive(lsb, "lsb")
    bias = _check_real(bias, "bias")
    coefs = {
        "quantization": _check_nonneg(quantization, "quantization"),
        "angle_random_walk": _check_nonneg(angle_random_walk, "angle_random_walk"),
        "bias_instability": _check_nonneg(bias_instability, "bias_instability"),
        "rate_random_walk": _check_nonneg(rate_random_walk, "rate_random_walk"),
    }
    ramp = _check_nonneg(rate_ramp, "rate_ramp")
    markov_args: tuple[float, float] | None = None
    if markov is not None:
        items = _as_tuple(markov)
        if len(items) != 2:
            raise ValueError(
                f"markov must be a (std, correlation_time) pair (got {markov!r}); "
                "pass e.g. markov=(0.01, 100.0)."
            )
        markov_args = (
            _check_nonneg(items[0], "markov std"),
            _check_positive(items[1], "markov correlation_time"),
        )
    sin_args: tuple[float, ...] | None = None
    if sinusoid is not None:
        items = _as_tuple(sinusoid)
        if len(items) not in (2, 3):
            raise ValueError(
                f"sinusoid must be an (amplitude, frequency[, phase]) tuple (got {sinusoid!r}); "
                "pass e.g. sinusoid=(0.1, 2.0)."
            )
        sin_args = items

    streams = dict(zip(_SENSOR_STREAMS, _spawn(seed, len(_SENSOR_STREAMS)), strict=True))
    out = np.full(n, bias, dtype=np.float64)
    generators = {
        "quantization": _quantization,
        "angle_random_walk": _angle_random_walk,
        "bias_instability": _bias_instability,
        "rate_random_walk": _rate_random_walk,
    }
    for name, value in coefs.items():
        if value > 0.0:
            out += generators[name](n, value, rate=rate, seed=streams[name])
    if ramp > 0.0:
        out += _rate_ramp(n, ramp, rate=rate)
    if markov_args is not None and markov_args[0] > 0.0:
        out += _markov(n, *markov_args, rate=rate, seed=streams["markov"])
    if sin_args is not None:
        phase = sin_args[2] if len(sin_args) == 3 else 0.0
        out += _sinusoid(n, sin_args[0], sin_args[1], phase=phase, rate=rate)
    if bandwidth is not None:
        out = _low_pass(out, bandwidth, rate, int(filter_order))
    if lsb is not None:
        out = np.round(out / lsb) * lsb
    return out


def _low_pass(x: FloatArray, bandwidth: float, rate: float, order: int) -> FloatArray:
    """Butterworth low-pass, unit DC gain, initial state steady at the first sample."""
    from adavar.simulation.iir import butter_lowpass_sos, sosfilt, sosfilt_zi

    sos = butter_lowpass_sos(order, bandwidth, rate)
    return sosfilt(sos, x, sosfilt_zi(sos) * x[0])


def _as_tuple(value: object) -> tuple:
    try:
        return tuple(value)  # type: ignore[call-overload]
    except TypeError:
        return (value,)


# Module-level aliases: `sensor`'s keyword arguments shadow the generator names.
_quantization = quantization
_angle_random_walk = angle_random_walk
_bias_instability = bias_instability
_rate_random_walk = rate_random_walk
_rate_ramp = rate_ramp
_markov = markov
_sinusoid = sinusoid


def piecewise_white(
    n: int,
    stds: Sequence[float] | NDArray[np.floating],
    change_samples: Sequence[int] | NDArray[np.integer],
    *,
    rate: float = 1.0,
    seed: SeedLike = None,
) -> FloatArray:
    r"""White Gaussian noise whose standard deviation changes at given samples.

    Samples ``change_samples[k-1] <= i < change_samples[k]`` have standard deviation
    ``stds[k]`` (with ``change_samples[-1] := 0`` and ``change_samples[len] := n``).

    Parameters
    ----------
    n : int
        Number of samples, ``1`` to :data:`MAX_SAMPLES`.
    stds : sequence of float
        Per-segment standard deviation of the rate samples, in u (``>= 0``, finite);
        ``len(stds) == len(change_samples) + 1``.  (Segment ``k`` has angle random walk
        ``N_k = stds[k] * sqrt(tau0)``.)
    change_samples : sequence of int
        Indices of the first sample of segments ``1, 2, ...``; strictly increasing, in
        ``1 .. n-1``.  May be empty (stationary white noise).
    rate : float, default 1.0
        Sampling rate in Hz (``tau0 = 1/rate``).
    seed : int, None, SeedSequence or Generator
        Seed of the random stream.

    Returns
    -------
    ndarray of float64, shape (n,)

    Notes
    -----
    Within segment ``k``: one-sided PSD ``2 stds[k]^2 tau0`` and Allan variance
    ``stds[k]^2 tau0 / tau``.  The same seed gives the same standard-normal draws whatever
    the segmentation (``w = std_of_sample * z``).
    """
    n = _check_n(n)
    _check_rate(rate)
    try:
        s = np.asarray(stds, dtype=np.float64).ravel()
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"stds must be a sequence of numbers (got {stds!r}); give one float per segment."
        ) from exc
    c_raw = np.asarray(change_samples).ravel()
    if c_raw.size and not np.issubdtype(c_raw.dtype, np.integer):
        if not (np.issubdtype(c_raw.dtype, np.floating) and np.all(c_raw == np.round(c_raw))):
            raise ValueError(
                f"change_samples must be integer sample indices (got {change_samples!r}); "
                "use piecewise_white_times for times in seconds."
            )
    c = c_raw.astype(np.int64)
    if s.size != c.size + 1:
        raise ValueError(
            f"stds must have one more entry than change_samples (got {s.size} stds and "
            f"{c.size} change points); give one std per segment."
        )
    if not np.all(np.isfinite(s)) or np.any(s < 0):
        raise ValueError(f"stds must be finite and >= 0 (got {s.tolist()}); fix the segment stds.")
    if c.size and (c[0] < 1 or c[-1] > n - 1 or np.any(np.diff(c) <= 0)):
        raise ValueError(
            f"change_samples must be strictly increasing indices in 1..{n - 1} (got "
            f"{c.tolist()}); drop empty or out-of-range segments."
        )
    lengths = np.diff(np.concatenate([[0], c, [n]]))
    return np.repeat(s, lengths) * _rng(seed).standard_normal(n)


def piecewise_white_times(
    duration_s: float,
    stds: Sequence[float] | NDArray[np.floating],
    change_times_s: Sequence[float] | NDArray[np.floating],
    *,
    rate: float = 1.0,
    seed: SeedLike = None,
) -> FloatArray:
    r"""White noise whose standard deviation changes at given times (seconds).

    :func:`piecewise_white` with ``n = ceil(duration_s * rate)`` samples (those with
    ``t_k = k / rate < duration_s``) and change points at the first sample with
    ``t_k >= change_times_s[j]``, i.e. ``ceil(change_times_s[j] * rate)`` (with a 1e-9
    sample tolerance against round-off, so ``10.0 s`` at 100 Hz is sample 1000).

    Parameters
    ----------
    duration_s : float
        Record length in seconds, ``> 0``.
    stds : sequence of float
        Per-segment standard deviation of the rate samples, in u;
        ``len(stds) == len(change_times_s) + 1``.
    change_times_s : sequence of float
        Times (s) at which segments ``1, 2, ...`` start; strictly increasing within
        ``(0, duration_s)`` and at least one sample apart.
    rate : float, default 1.0
        Sampling rate in Hz.
    seed : int, None, SeedSequence or Generator
        Seed of the random stream.

    Returns
    -------
    ndarray of float64, shape (ceil(duration_s * rate),)
    """
    rate = _check_rate(rate)
    duration_s = _check_positive(duration_s, "duration_s")
    n = math.ceil(duration_s * rate - 1e-9)
    if n < 1:
        raise ValueError(
            f"duration_s = {duration_s} s holds no sample at rate {rate} Hz; "
            "pass a longer duration or a higher rate."
        )
    t = np.asarray(change_times_s, dtype=np.float64).ravel()
    if not np.all(np.isfinite(t)):
        raise ValueError(f"change_times_s must be finite (got {t.tolist()}); fix the times.")
    if t.size and (t[0] <= 0.0 or t[-1] >= duration_s or np.any(np.diff(t) <= 0)):
        raise ValueError(
            f"change_times_s must be strictly increasing within (0, {duration_s}) s "
            f"(got {t.tolist()}); drop out-of-range or repeated times."
        )
    idx = np.ceil(t * rate - 1e-9).astype(np.int64)
    if idx.size and (idx[0] < 1 or idx[-1] > n - 1 or np.any(np.diff(idx) <= 0)):
        raise ValueError(
            f"change_times_s {t.tolist()} fall on sample indices {idx.tolist()}, which leave an "
            f"empty segment at rate {rate} Hz; space the changes at least 1/rate apart."
        )
    return piecewise_white(n, stds, idx, rate=rate, seed=seed)

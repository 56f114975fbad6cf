"""Sensor records with known truth, generated without any of adavar's code.

The validation matrix (``benchmarks/bench_validation.py`` and ``tests/test_validation.py``)
checks adavar's outputs on records that nothing in ``adavar.simulate`` produced, so that a
shared mistake in the generator and the estimator cannot cancel. Everything here uses NumPy
and SciPy only:

* white rate noise (Gaussian, or Student-t scaled to the same variance for heavy tails),
* flicker (bias instability) by FFT shaping of white noise to a one-sided PSD ``B^2/(pi f)``
  on a record four times longer than needed (adavar's simulator uses the Kasdin-Walter
  filter instead),
* rate random walk as a cumulative sum, a first-order Gauss-Markov process as an AR(1)
  recursion, a sinusoid, a rate ramp,
* a causal Butterworth low-pass (``scipy.signal``) and rounding to a least significant bit,
* changes of the noise: steps, short bursts, gradual ramps of the white level, and changes
  of the long-tau terms (rate random walk, flicker) over a stretch.

The truth is analytic: :meth:`Truth.avar` is the Allan variance of the mix (IEEE Std 952
Annex C forms; the Gauss-Markov and sinusoid forms as in El-Sheimy et al. 2008), in the
rate unit squared.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

LN2_PI = 2.0 * math.log(2.0) / math.pi  # the flicker floor: avar = LN2_PI * B**2


@dataclass(frozen=True)
class Truth:
    """The noise mix of a record and its analytic Allan variance.

    Coefficients in the rate unit: ``N`` (unit sqrt(s)), ``B`` (unit), ``K`` (unit/sqrt(s)),
    ``R`` (unit/s), ``Q`` (unit s); ``markov`` = (sigma, tau_c s); ``sine`` = (amplitude,
    frequency Hz).
    """

    rate: float
    N: float = 0.0
    B: float = 0.0
    K: float = 0.0
    R: float = 0.0
    Q: float = 0.0
    markov: tuple[float, float] | None = None
    sine: tuple[float, float] | None = None
    extras: dict = field(default_factory=dict)

    def term_avar(self, name: str, tau: np.ndarray) -> np.ndarray:
        """The Allan variance of one component at ``tau`` (s)."""
        tau = np.asarray(tau, dtype=float)
        if name == "Q":
            return 3.0 * self.Q**2 / tau**2
        if name == "N":
            return self.N**2 / tau
        if name == "B":
            return np.full_like(tau, LN2_PI * self.B**2)
        if name == "K":
            return self.K**2 * tau / 3.0
        if name == "R":
            return self.R**2 * tau**2 / 2.0
        if name == "markov":
            if self.markov is None:
                return np.zeros_like(tau)
            sigma, tc = self.markov
            q2 = 2.0 * sigma**2 / tc  # driving noise of dx = -x/tc dt + q dW
            u = tau / tc
            return (q2 * tc**2 / tau) * (
                1.0 - (3.0 - 4.0 * np.exp(-u) + np.exp(-2.0 * u)) / (2.0 * u)
            )
        if name == "sine":
            if self.sine is None:
                return np.zeros_like(tau)
            amp, f0 = self.sine
            x = math.pi * f0 * tau
            return amp**2 * np.sin(x) ** 4 / x**2
        raise ValueError(name)

    def avar(self, tau: np.ndarray) -> np.ndarray:
        """The Allan variance of the whole mix at ``tau`` (s)."""
        return sum(self.term_avar(t, tau) for t in ("Q", "N", "B", "K", "R", "markov", "sine"))

    def dominant(self, tau: np.ndarray, terms=("N", "B", "K")) -> dict[str, bool]:
        """Whether each term carries most of the Allan variance over at least one octave
        of ``tau`` (the terms whose estimate the validation targets hold to 5 %)."""
        tau = np.asarray(tau, dtype=float)
        total = self.avar(tau)
        out = {}
        for name in terms:
            share = self.term_avar(name, tau) / total
            over = tau[share > 0.5]
            out[name] = bool(over.size >= 2 and math.log2(over.max() / over.min()) >= 1.0)
        return out


def _rng(seed) -> np.random.Generator:
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


def white(n: int, N: float, rate: float, rng, *, dof: float | None = None) -> np.ndarray:
    """White rate noise of ARW ``N``: sd ``N sqrt(rate)``; Student-t of ``dof`` if given."""
    rng = _rng(rng)
    sd = N * math.sqrt(rate)
    if dof is None:
        return sd * rng.standard_normal(n)
    return sd * math.sqrt((dof - 2.0) / dof) * rng.standard_t(dof, n)


#: shapes of :func:`white_shaped`: each of unit variance before scaling (kurtosis)
SHAPES = ("gaussian", "student5", "laplace", "uniform", "platykurtic")


def white_shaped(n: int, N: float, rate: float, rng, shape: str) -> np.ndarray:
    """White rate noise of ARW ``N`` with a non-Gaussian distribution of the same variance.

    ``shape``: ``"gaussian"`` (kurtosis 3), ``"student5"`` (Student-t, 5 dof: 9),
    ``"laplace"`` (6), ``"uniform"`` (1.8), ``"platykurtic"`` (Gaussian plus uniform of
    equal variance: 2.7, as a real MEMS gyro's 2.71).
    """
    rng = _rng(rng)
    sd = N * math.sqrt(rate)
    if shape == "gaussian":
        z = rng.standard_normal(n)
    elif shape == "student5":
        z = math.sqrt(3.0 / 5.0) * rng.standard_t(5.0, n)
    elif shape == "laplace":
        z = rng.laplace(0.0, 1.0 / math.sqrt(2.0), n)
    elif shape == "uniform":
        z = rng.uniform(-math.sqrt(3.0), math.sqrt(3.0), n)
    elif shape == "platykurtic":
        z = rng.standard_normal(n) + rng.uniform(-math.sqrt(3.0), math.sqrt(3.0), n)
        z /= math.sqrt(2.0)
    else:
        raise ValueError(shape)
    return sd * z


def flicker(n: int, B: float, rate: float, rng, scale: np.ndarray | None = None) -> np.ndarray:
    """Flicker rate noise of bias instability ``B`` by FFT shaping (one-sided PSD B^2/(pi f)).

    ``scale`` (length ``n``) multiplies the driving white noise sample by sample: a flicker
    level that changes over the record without a step in the rate.
    """
    rng = _rng(rng)
    from scipy.fft import next_fast_len

    # at least 4 n samples (the record is a slice of a longer process, not periodic); a
    # 5-smooth length, which the FFT takes 9x faster than the next power of two at 4e6
    size = next_fast_len(max(16, 4 * n), real=True)
    drive = rng.standard_normal(size)
    if scale is not None:
        drive[size - n :] *= scale
    spectrum = np.fft.rfft(drive)
    f = np.fft.rfftfreq(size, d=1.0 / rate)
    gain = np.zeros_like(f)
    # white noise of unit variance has the one-sided PSD 2/rate; scale it to B^2/(pi f)
    gain[1:] = np.sqrt(B**2 / (math.pi * f[1:]) * rate / 2.0)
    x = np.fft.irfft(spectrum * gain, size)
    start = size - n if scale is not None else int(rng.integers(0, size - n + 1))
    return x[start : start + n]


def rate_random_walk(n: int, K: float, rate: float, rng) -> np.ndarray:
    """Rate random walk ``K``: increments of sd ``K sqrt(1/rate)`` each sample."""
    rng = _rng(rng)
    return np.cumsum(K * math.sqrt(1.0 / rate) * rng.standard_normal(n))


def markov(n: int, sigma: float, tau_c: float, rate: float, rng) -> np.ndarray:
    """First-order Gauss-Markov (AR(1)) of stationary sd ``sigma`` and correlation time tau_c."""
    from scipy.signal import lfilter

    rng = _rng(rng)
    phi = math.exp(-1.0 / (rate * tau_c))
    drive = sigma * math.sqrt(1.0 - phi**2) * rng.standard_normal(n)
    x0 = sigma * rng.standard_normal()
    out, _ = lfilter([1.0], [1.0, -phi], drive, zi=[phi * x0])
    return out


def sinusoid(n: int, amplitude: float, freq: float, rate: float, rng) -> np.ndarray:
    """A sinusoid of random phase."""
    rng = _rng(rng)
    t = np.arange(n) / rate
    return amplitude * np.sin(2.0 * math.pi * freq * t + rng.uniform(0, 2 * math.pi))


def low_pass(x: np.ndarray, bandwidth: float, rate: float, order: int = 4) -> np.ndarray:
    """A causal Butterworth low-pass at ``bandwidth`` Hz (scipy.signal)."""
    from scipy.signal import butter, sosfilt

    sos = butter(order, bandwidth, fs=rate, output="sos")
    return sosfilt(sos, x)


def quantise(x: np.ndarray, lsb: float) -> np.ndarray:
    """Rounded to a multiple of ``lsb``."""
    return np.round(x / lsb) * lsb


#: The noise mixes of the validation matrix (rate units, deg/s-like scale).
MIXES = {
    "white": dict(N=1e-3),
    "white+RRW": dict(N=1e-3, K=1e-5),
    "white+flicker+RRW": dict(N=1e-3, B=2e-4, K=1e-5),
    "white+RRW+markov": dict(N=1e-3, K=1e-5, markov=(1e-3, 50.0)),
    "white+flicker+sine": dict(N=1e-3, B=2e-4, sine=(2e-3, 0.5)),
    "white+ramp": dict(N=1e-3, R=2e-7),
    "heavy-tailed white": dict(N=1e-3, dof=5.0),
    "filtered+quantised": dict(N=1e-3, B=2e-4, K=1e-5, bandwidth=0.2, lsb=0.25),
}


def record(mix: str | dict, seconds: float, rate: float, seed) -> tuple[np.ndarray, Truth]:
    """A stationary record of ``seconds`` at ``rate`` Hz and its truth.

    ``mix`` is a name of :data:`MIXES` or a dict of ``N, B, K, R, markov, sine, dof,
    bandwidth`` (as a fraction of the Nyquist frequency) and ``lsb`` (as a fraction of the
    white noise's per-sample sd). Quantisation adds white noise of variance ``lsb^2/12``,
    which the truth's ``N`` includes.
    """
    spec = dict(MIXES[mix]) if isinstance(mix, str) else dict(mix)
    rng = _rng(seed)
    n = round(seconds * rate)
    N, B, K, R = (float(spec.get(k, 0.0)) for k in ("N", "B", "K", "R"))
    x = white(n, N, rate, rng, dof=spec.get("dof"))
    if B:
        x += flicker(n, B, rate, rng)
    if K:
        x += rate_random_walk(n, K, rate, rng)
    if spec.get("markov"):
        x += markov(n, *spec["markov"], rate, rng)
    if spec.get("sine"):
        x += sinusoid(n, *spec["sine"], rate, rng)
    if R:
        x += R * np.arange(n) / rate
    extras = {}
    if spec.get("bandwidth"):
        bw = float(spec["bandwidth"]) * rate / 2.0
        x = low_pass(x, bw, rate)
        extras["bandwidth_hz"] = bw
    if spec.get("lsb"):
        lsb = float(spec["lsb"]) * N * math.sqrt(rate)
        x = quantise(x, lsb)
        N = math.sqrt(N**2 + lsb**2 / 12.0 / rate)
        extras["lsb"] = lsb
    truth = Truth(rate=rate, N=N, B=B, K=K, R=R, markov=spec.get("markov"),
                  sine=spec.get("sine"), extras=extras)  # fmt: skip
    return x, truth


@dataclass(frozen=True)
class Change:
    """A non-stationary record's truth: the white level over time and the change times."""

    truth: Truth
    level: np.ndarray  # multiplier of N at every sample (the true N(t) is truth.N * level)
    changes: tuple[tuple[float, float | None], ...]  # (start_s, end_s) of each episode
    kind: str
    ramp: bool = False


def changing(
    kind: str, seconds: float, rate: float, seed, *, N: float = 1e-3,
    at: float | None = None, length: float | None = None, factor: float | None = None,
    dof: float | None = None,
) -> tuple[np.ndarray, Change]:  # fmt: skip
    """A record whose noise changes, and its truth.

    ``kind``:

    * ``"step"``: white noise times ``factor`` (3) from ``at`` for ``length`` s,
    * ``"burst"``: times ``factor`` (5) for a short ``length`` (20 s),
    * ``"ramp"``: the level grows linearly from 1 to ``factor`` (3) over ``length`` s from
      ``at`` and stays there,
    * ``"spike"``: one sample of 40 sd at ``at`` (an outlier, not a change of the noise),
    * ``"rrw"``: rate random walk (K = N/100) with K times ``factor`` (10) over the stretch,
    * ``"flicker"``: bias instability (B = N/5) times ``factor`` (5) over the stretch.

    Defaults put the stretch in the middle third of the record.
    """
    rng = _rng(seed)
    n = round(seconds * rate)
    defaults = {"step": (3.0, seconds / 6), "burst": (5.0, 20.0), "ramp": (3.0, 900.0),
                "spike": (40.0, 0.0), "rrw": (10.0, seconds / 3),
                "flicker": (5.0, seconds / 3)}  # fmt: skip
    f0, l0 = defaults[kind]
    factor = f0 if factor is None else factor
    length = l0 if length is None else length
    at = seconds / 2 - length / 2 if at is None else at
    t = np.arange(n) / rate
    a, b = round(at * rate), round((at + length) * rate)
    level = np.ones(n)
    ramp = False
    truth = Truth(rate=rate, N=N)
    x = white(n, N, rate, rng, dof=dof)
    changes: tuple = ((at, at + length),)
    if kind in ("step", "burst"):
        level[a:b] = factor
        x *= level
    elif kind == "ramp":
        level = np.clip(1.0 + (factor - 1.0) * (t - at) / length, 1.0, factor)
        x *= level
        ramp = True
        changes = ((at, None),)
    elif kind == "spike":
        x[a] += factor * N * math.sqrt(rate)
        changes = ()
    elif kind == "rrw":
        K = N / 100.0
        scale = np.where((t >= at) & (t < at + length), factor, 1.0)
        steps = K * math.sqrt(1.0 / rate) * rng.standard_normal(n) * scale
        x += np.cumsum(steps)
        truth = replace(truth, K=K)
    elif kind == "flicker":
        B = N / 5.0
        inside = (t >= at) & (t < at + length)
        x += flicker(n, B, rate, rng, scale=np.where(inside, factor, 1.0))
        truth = replace(truth, B=B)
    else:
        raise ValueError(kind)
    return x, Change(truth=truth, level=level, changes=changes, kind=kind, ramp=ramp)


# ---------------------------------------------------------------------------------------
# The five power-law noises of frequency metrology, and the exact expectation of the
# Allan-family estimators on them (for interval coverage: the truth is what the estimator
# averages to on records of this length, not the asymptotic tau law)

#: rate-PSD exponent alpha (S_y ~ f^alpha) -> name; the phase PSD goes as f^(alpha - 2)
POWER_LAWS = {2: "white PM", 1: "flicker PM", 0: "white FM", -1: "flicker FM", -2: "random-walk FM"}


def _flicker_gain(size: int) -> np.ndarray:
    """rfft gain of a 1/f PSD on a circle of ``size`` samples (zero at DC)."""
    f = np.fft.rfftfreq(size)
    gain = np.zeros_like(f)
    gain[1:] = 1.0 / np.sqrt(f[1:])
    return gain


def _flicker_size(n: int) -> int:
    return 1 << max(4, math.ceil(math.log2(4 * n)))


def power_law(alpha: int, n: int, rng) -> np.ndarray:
    """``n`` phase points of power-law noise ``S_y(f) ~ f^alpha``, ``alpha`` in 2 .. -2.

    White PM is white phase; flicker PM is white noise shaped by ``f^-1/2`` in the
    frequency domain on a circle four times the record (a random stretch of it is
    returned); white and flicker FM are the running sums of white and flicker frequency
    (shaped the same way); random-walk FM the double running sum of white noise. The
    rate (fractional frequency) record of the same noise is ``np.diff`` of the phase, one
    sample shorter. Scales are arbitrary (coverage is scale-free).
    """
    rng = _rng(rng)
    alpha = int(alpha)

    def shaped(k: int) -> np.ndarray:
        size = _flicker_size(k)
        z = np.fft.irfft(np.fft.rfft(rng.standard_normal(size)) * _flicker_gain(size), size)
        start = int(rng.integers(0, size - k + 1))
        return z[start : start + k]

    def integrate(y: np.ndarray) -> np.ndarray:
        return np.concatenate(([0.0], np.cumsum(y)))

    if alpha == 2:
        return rng.standard_normal(n)
    if alpha == 1:
        return shaped(n)
    if alpha == 0:
        return integrate(rng.standard_normal(n - 1))
    if alpha == -1:
        return integrate(shaped(n - 1))
    if alpha == -2:
        return integrate(np.cumsum(rng.standard_normal(n - 1)))
    raise ValueError(f"alpha must be one of {sorted(POWER_LAWS)}, got {alpha}")


def _generalised_covariance(alpha: int, n: int):
    """``K(h)``, ``h`` integer lags: ``Var(sum a_j x_j) = sum a_i a_j K(i - j)`` for every
    combination ``a`` that annihilates constants (and, for random-walk FM, linear trends)
    of :func:`power_law`'s phase."""
    if alpha == 2:
        return lambda h: (np.asarray(h) == 0).astype(float)
    if alpha in (1, -1):
        size = _flicker_size(n if alpha == 1 else n - 1)
        acov = np.fft.irfft(_flicker_gain(size) ** 2, size)  # circular: the segment's too
        if alpha == 1:
            return lambda h: acov[np.abs(np.asarray(h))]
        # flicker FM: -1/2 the phase structure function V(k) = Var(x[j + k] - x[j])
        k = np.arange(n)
        ramp = np.cumsum(np.cumsum(acov[:n]))  # sum_{l<k} (k - l) c_l, shifted
        v = np.zeros(n)
        v[1:] = 2.0 * ramp[:-1] - k[1:] * acov[0]
        return lambda h: -0.5 * v[np.abs(np.asarray(h))]
    if alpha == 0:
        return lambda h: -0.5 * np.abs(np.asarray(h, dtype=float))
    if alpha == -2:  # the double running sum: (|h|^3 - |h|) / 12
        return lambda h: (np.abs(np.asarray(h, dtype=float)) ** 3 - np.abs(h)) / 12.0
    raise ValueError(f"alpha must be one of {sorted(POWER_LAWS)}, got {alpha}")


def _quadratic_mean(points: np.ndarray, coefs: np.ndarray, cov) -> np.ndarray:
    """``E[(sum_u coefs[t, u] x[points[t, u]])^2]`` for every row ``t``."""
    lag = points[:, :, None] - points[:, None, :]
    return np.einsum("tu,tv,tuv->t", coefs, coefs, cov(lag))


def expected_variance(stat: str, alpha: int, n: int, m: int) -> float:
    """What the estimator ``stat`` averages to on :func:`power_law` records of ``n`` phase
    points at averaging factor ``m`` (``tau0 = 1``), from the noise's covariance: SP 1065's
    definitions written out here (``"oadev"``, ``"mdev"``, ``"hdev"`` (non-overlapping:
    the same mean as overlapping), ``"totdev"``: the phase reflected at both ends,
    ``x*[-j] = 2 x[0] - x[j]``, ``N - 2`` terms)."""
    cov = _generalised_covariance(int(alpha), n)
    if stat in ("oadev", "adev"):
        pts = np.array([[0, m, 2 * m]])
        return float(_quadratic_mean(pts, np.array([[1.0, -2.0, 1.0]]), cov)[0]) / (2 * m * m)
    if stat == "hdev":
        pts = np.array([[0, m, 2 * m, 3 * m]])
        c = np.array([[1.0, -3.0, 3.0, -1.0]])
        return float(_quadratic_mean(pts, c, cov)[0]) / (6 * m * m)
    if stat in ("mdev", "tdev"):
        # the m-sum of second differences: their autocovariance at lags 1 - m .. m - 1
        lags = np.arange(-(m - 1), m)
        pts = np.stack([np.zeros_like(lags), np.full_like(lags, m), np.full_like(lags, 2 * m),
                        lags, lags + m, lags + 2 * m], axis=1)  # fmt: skip
        c = np.tile([1.0, -2.0, 1.0, 0.0, 0.0, 0.0], (lags.size, 1))
        d = np.tile([0.0, 0.0, 0.0, 1.0, -2.0, 1.0], (lags.size, 1))
        cross = np.einsum("tu,tv,tuv->t", c, d, cov(pts[:, :, None] - pts[:, None, :]))
        return float(np.sum((m - np.abs(lags)) * cross)) / (2.0 * m**4)
    if stat == "totdev":
        i = np.arange(1, n - 1)
        pts, coefs = [], []
        for offset, weight in ((-m, 1.0), (0, -2.0), (m, 1.0)):
            j = i + offset
            # x*[j] for j < 0: 2 x[0] - x[-j]; for j > n - 1: 2 x[n-1] - x[2(n-1) - j]
            low, high = j < 0, j > n - 1
            mirror = np.where(low, -j, np.where(high, 2 * (n - 1) - j, j))
            anchor = np.where(low, 0, n - 1)
            reflected = low | high
            pts += [mirror, anchor]
            coefs += [np.where(reflected, -weight, weight), np.where(reflected, 2 * weight, 0.0)]
        terms = _quadratic_mean(np.stack(pts, axis=1), np.stack(coefs, axis=1), cov)
        return float(terms.mean()) / (2 * m * m)
    raise ValueError(f"unknown statistic {stat!r}")

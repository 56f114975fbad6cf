"""Thresholds of the adaptive controller: the paper's, or calibrated for a false-alarm rate.

The paper fixes ``K1 = 2.5, K2 = 3.3, S2 = 0.07`` by hand (docs/method.md section 8);
:func:`calibrated_thresholds` sets them from the sampling distribution of the kurtosis of a
window of ``L`` Gaussian samples (Anscombe-Glynn) and of the contribution coefficient S, so
that a test fires on stationary noise with a chosen probability per step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.special import log_ndtr, ndtr, ndtri

from adavar.core.errors import AdavarInputError
from adavar.core.settings import CONTROLLER

__all__ = [
    "Thresholds",
    "calibrated_thresholds",
    "fixed_thresholds",
    "gaussian_kurtosis_spread",
    "hourly_thresholds",
    "noise_dependence",
    "shifted",
    "shortest_length",
    "thresholds_for",
]


def _anscombe_glynn(n: int) -> tuple[float, float, float]:
    """Mean and deviation of the kurtosis of ``n`` Gaussian samples, and the transform's A."""
    e = 3.0 * (n - 1) / (n + 1)
    sd = math.sqrt(24.0 * n * (n - 2) * (n - 3) / ((n + 1) ** 2 * (n + 3) * (n + 5)))
    sqrtbeta1 = (
        6.0 * (n * n - 5 * n + 2) / ((n + 7) * (n + 9))
        * math.sqrt(6.0 * (n + 3) * (n + 5) / (n * (n - 2) * (n - 3)))
    )  # fmt: skip
    a = 6.0 + 8.0 / sqrtbeta1 * (2.0 / sqrtbeta1 + math.sqrt(1 + 4.0 / sqrtbeta1**2))
    return e, sd, a


def _kurtosis_z(b2: float, n: int) -> float:
    """Anscombe-Glynn z-score of a sample kurtosis ``b2`` of ``n`` Gaussian samples.

    The transformation behind ``scipy.stats.kurtosistest`` (Anscombe & Glynn 1983); defined
    above its pole ``1 + x sqrt(2 / (A - 4)) = 0``.
    """
    e, sd, a = _anscombe_glynn(n)
    x = (b2 - e) / sd
    term1 = 1 - 2 / (9.0 * a)
    denom = 1 + x * math.sqrt(2 / (a - 4.0))
    term2 = np.cbrt((1 - 2.0 / a) / denom)
    return float((term1 - term2) / math.sqrt(2 / (9.0 * a)))


def _kurtosis_quantile(q: float, n: int) -> float:
    """Kurtosis of ``n`` Gaussian samples with lower-tail probability ``q`` (Anscombe-Glynn)."""
    from scipy.optimize import brentq

    z = ndtri(q)
    e, sd, a = _anscombe_glynn(n)
    pole = e - sd * math.sqrt((a - 4.0) / 2.0)  # z -> -inf just above it
    lo = pole + 1e-9 * sd
    return float(brentq(lambda b: _kurtosis_z(b, n) - z, lo, e + 40 * sd, xtol=1e-12))


#: Gaussian values drawn at a time by the S simulation (32 MiB): bounded memory for any L.
_DRAW_BATCH = 1 << 22


def _s_quantile(q: float, length: int, seg: int, draws: int, seed: int) -> float:
    """Quantile of S (last ``seg`` of ``length`` Gaussian samples) by simulation.

    The windows are drawn a batch of rows at a time from one stream: the same numbers as
    one ``(draws, length)`` array, in at most :data:`_DRAW_BATCH` values of memory.
    """
    rng = np.random.default_rng(seed)
    rows = max(1, _DRAW_BATCH // length)
    s = np.empty(draws)
    for a in range(0, draws, rows):
        x = rng.standard_normal((min(draws, a + rows) - a, length))
        kx = _row_kurtosis(x)
        kc = _row_kurtosis(x[:, : length - seg])
        s[a : a + x.shape[0]] = (kx - kc) / kx
    return float(np.quantile(s, q))


def _row_kurtosis(x: np.ndarray) -> np.ndarray:
    """Kurtosis ``m4 / m2^2`` of each row (NaN for a constant row).

    ``scipy.stats.kurtosis(x, axis=1, fisher=False)``, operation for operation (so the same
    numbers), without importing scipy.stats (about a second).
    """
    mean = x.mean(axis=1, keepdims=True)
    # one temporary squared in place twice (``** 2`` of a float array is ``np.square``):
    # the same numbers without two more arrays of the batch's size to fault in
    d = np.subtract(x, mean)
    np.square(d, out=d)
    m2 = d.mean(axis=1)
    np.square(d, out=d)
    m4 = d.mean(axis=1)
    with np.errstate(all="ignore"):
        zero = m2 <= (np.finfo(np.float64).eps * mean[:, 0]) ** 2
        return np.where(zero, np.nan, m4 / m2**2.0)


def shortest_length(lmin: int) -> int:
    """The shortest length whose ``K1`` and ``K2`` the calibrated tables hold: ``lmin // 2``
    (at least 8, at most ``lmin``).

    A window that reaches into the mirror-extended end of the record repeats up to half of
    its samples, and is tested at its effective size, down to half its length
    (docs/method.md section 8, "Windows at the record's ends").
    """
    return max(lmin // 2, min(lmin, 8))


@dataclass(frozen=True)
class Thresholds:
    """Per-length thresholds of the controller: ``k1[L]``, ``k2[L]``, ``s2[L]``.

    ``k1`` and ``k2`` of calibrated tables also cover the effective sizes of the windows
    that reach into the mirror-extended ends, down to :func:`shortest_length`.
    """

    k1: np.ndarray
    k2: np.ndarray
    s2: np.ndarray
    source: str
    #: ``K1``, ``K2`` of a window that reaches into the mirror, by its effective size
    #: (default: ``k1``, ``k2``)
    edge_k1: np.ndarray | None = None
    edge_k2: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.edge_k1 is None:
            object.__setattr__(self, "edge_k1", self.k1)
        if self.edge_k2 is None:
            object.__setattr__(self, "edge_k2", self.k2)


@lru_cache(maxsize=32)
def calibrated_thresholds(
    lmin: int,
    lmax: int,
    segment: int,
    *,
    false_alarm: float = CONTROLLER.false_alarm,
    s_false_alarm: float | None = None,
    draws: int = 20_000,
    seed: int = 0,
) -> Thresholds:
    """Thresholds from the sampling distribution of the kurtosis, for a target false-alarm rate.

    Beyond the paper, which fixes ``K1 = 2.5, K2 = 3.3, S2 = 0.07`` by hand (docs/method.md
    section 7). For a window of ``L`` Gaussian samples, ``K1(L)`` and ``K2(L)`` are the
    ``false_alarm / 2`` and ``1 - false_alarm / 2`` quantiles of its sample kurtosis (the
    Anscombe-Glynn normal approximation used by ``scipy.stats.kurtosistest``, accurate to
    a few 1e-3 in probability at these sizes), so ``f1`` fires on stationary Gaussian noise
    with probability ``false_alarm`` at every length. ``S2(L)`` is the ``1 - s_false_alarm``
    quantile of ``S`` (default ``s_false_alarm = false_alarm``), simulated with ``draws``
    Gaussian windows at ``L = lmin`` and ``L = lmax`` (seeded, so the thresholds are
    reproducible) and interpolated in ``1/L`` between them.

    Parameters
    ----------
    lmin, lmax : int
        Range of window lengths.
    segment : int
        The leading segment ``l`` of the S test.
    false_alarm : float
        Per-step probability that ``f1`` fires on stationary Gaussian noise.
    s_false_alarm : float, optional
        Per-step probability that ``f2`` fires (``S > S2``); default ``false_alarm``.
    draws : int
        Simulated windows per length for the S quantile.
    seed : int
        Seed of that simulation.

    Returns
    -------
    Thresholds
        Cached: the same settings return the same tables (do not modify them).
    """
    if not 0.0 < false_alarm < 1.0:
        raise AdavarInputError(f"false_alarm must lie in (0, 1), got {false_alarm}")
    sq = false_alarm if s_false_alarm is None else float(s_false_alarm)
    if not 0.0 < sq < 1.0:
        raise AdavarInputError(f"s_false_alarm must lie in (0, 1), got {s_false_alarm}")
    size = lmax + 1
    k1 = np.full(size, np.nan)
    k2 = np.full(size, np.nan)
    s2 = np.full(size, np.nan)
    # the quantiles are smooth in L: solve at a few lengths, interpolate in 1/L
    for a, b, count in ((lmin, lmax, 9), (shortest_length(lmin), lmin - 1, 4)):
        if a > b:
            continue
        nodes = np.unique(np.round(np.geomspace(a, b, count)).astype(np.int64))
        lo = [_kurtosis_quantile(false_alarm / 2, int(n)) for n in nodes]
        hi = [_kurtosis_quantile(1 - false_alarm / 2, int(n)) for n in nodes]
        inv = 1.0 / np.arange(a, b + 1)
        k1[a : b + 1] = np.interp(inv, 1.0 / nodes[::-1], np.array(lo)[::-1])
        k2[a : b + 1] = np.interp(inv, 1.0 / nodes[::-1], np.array(hi)[::-1])
    inv = 1.0 / np.arange(lmin, lmax + 1)
    ends = sorted({lmin, lmax})
    sv = [_s_quantile(1 - sq, int(n), segment, draws, seed) for n in ends]
    if len(ends) == 1:
        s2[lmin:] = sv[0]
    else:
        s2[lmin:] = np.interp(inv, [1.0 / ends[1], 1.0 / ends[0]], [sv[1], sv[0]])
    return Thresholds(k1=k1, k2=k2, s2=s2, source=f"calibrated, false alarm {false_alarm:g}")


def fixed_thresholds(lmax: int, k1: float, k2: float, s2: float) -> Thresholds:
    size = lmax + 1
    return Thresholds(
        k1=np.full(size, float(k1)), k2=np.full(size, float(k2)), s2=np.full(size, float(s2)),
        source="fixed",
    )  # fmt: skip


# ---------------------------------------------------------------------------------------
# thresholds for a false-alarm rate per hour of stationary data


def _ag_z(b: np.ndarray, n: float) -> np.ndarray:
    """Anscombe-Glynn z-scores of kurtoses ``b`` (vectorised; -inf at and below the pole)."""
    e, sd, a = _anscombe_glynn_real(n)
    x = (np.asarray(b, dtype=float) - e) / sd
    denom = 1 + x * math.sqrt(2 / (a - 4.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        term2 = np.cbrt((1 - 2.0 / a) / denom)
        z = (1 - 2 / (9.0 * a) - term2) / math.sqrt(2 / (9.0 * a))
    return np.where(denom > 0, z, -np.inf)


def _ag_inverse(z: np.ndarray, n: float) -> np.ndarray:
    """The kurtosis whose Anscombe-Glynn z-score is ``z`` (the transform solved exactly)."""
    e, sd, a = _anscombe_glynn_real(n)
    term2 = 1 - 2 / (9.0 * a) - np.asarray(z, dtype=float) * math.sqrt(2 / (9.0 * a))
    denom = (1 - 2.0 / a) / term2**3
    return e + (denom - 1) / math.sqrt(2 / (a - 4.0)) * sd


def _anscombe_glynn_real(n: float) -> tuple[float, float, float]:
    """:func:`_anscombe_glynn` for a real (effective) sample size ``n > 3``."""
    n = max(float(n), 8.0)
    e = 3.0 * (n - 1) / (n + 1)
    sd = math.sqrt(24.0 * n * (n - 2) * (n - 3) / ((n + 1) ** 2 * (n + 3) * (n + 5)))
    sqrtbeta1 = (
        6.0 * (n * n - 5 * n + 2) / ((n + 7) * (n + 9))
        * math.sqrt(6.0 * (n + 3) * (n + 5) / (n * (n - 2) * (n - 3)))
    )  # fmt: skip
    a = 6.0 + 8.0 / sqrtbeta1 * (2.0 / sqrtbeta1 + math.sqrt(1 + 4.0 / sqrtbeta1**2))
    return e, sd, a


def gaussian_kurtosis_spread(n: float) -> tuple[float, float]:
    """Median and standard deviation of the kurtosis of ``n`` Gaussian samples.

    Anscombe-Glynn at a real (effective) size ``n`` (at least 8): the median is the
    kurtosis of z-score 0. What :mod:`adavar.dynamic.kurtosis_reference` compares a record's
    median block kurtosis with.
    """
    return float(_ag_inverse(0.0, n)), _anscombe_glynn_real(n)[1]


def shifted(th: Thresholds, offset: float, margin: float = 0.0) -> Thresholds:
    """``th`` with ``K1`` and ``K2`` moved by ``offset`` and out by ``margin`` (``S2`` kept;
    the same object for 0 and 0).

    The band of a record whose stationary kurtosis lies ``offset`` above the Gaussian one,
    known to within ``margin`` (:class:`adavar.dynamic.kurtosis_reference.KurtosisReference`).
    """
    if offset == 0.0 and margin == 0.0:
        return th
    return Thresholds(k1=th.k1 + offset - margin, k2=th.k2 + offset + margin, s2=th.s2,
                      source=f"{th.source}, kurtosis band moved by {offset:+.4g} and "
                      f"widened by {margin:.3g}", edge_k1=th.edge_k1 + offset - margin,
                      edge_k2=th.edge_k2 + offset + margin)  # fmt: skip


#: Lags of the autocorrelation summed by :func:`noise_dependence`.
DEPENDENCE_LAGS = 256
#: Samples of the record :func:`noise_dependence` reads (from its start).
DEPENDENCE_SAMPLES = 1 << 20


def noise_dependence(x: np.ndarray) -> tuple[float, float]:
    """How much the record's short-range correlation inflates the tests' sampling spread.

    Returns ``(c2, c4) = (sum rho_k^2, sum rho_k^4)`` over lags ``|k| <=`` 256, from the
    first 2^20 samples with the mean of every 2048-sample block removed (so slow drift does
    not count; the sensor's filter does). For a Gaussian process the sample variance of
    ``L`` samples has the spread of ``L / c2`` independent ones and the sample kurtosis that
    of ``L / c4`` (its linear part is the mean of the Hermite polynomial ``H4``, whose
    lag-``k`` covariance is ``24 rho_k^4``); white noise gives ``(1, 1)``.
    """
    v = np.asarray(x[:DEPENDENCE_SAMPLES], dtype=float)
    block = 8 * DEPENDENCE_LAGS
    m = (v.size // block) * block
    if m < 4 * block:
        return 1.0, 1.0
    v = v[:m].reshape(-1, block)
    v = (v - v.mean(axis=1, keepdims=True)).ravel()
    var = float(np.dot(v, v))
    if not var > 0.0:
        return 1.0, 1.0
    size = 1 << int(np.ceil(np.log2(2 * v.size)))
    spec = np.fft.rfft(v, size)
    acf = np.fft.irfft(spec * np.conj(spec), size)[1 : DEPENDENCE_LAGS + 1] / var
    acf *= v.size / (v.size - np.arange(1, DEPENDENCE_LAGS + 1))
    # lags whose correlation is below the estimate's noise count as zero
    acf = np.where(np.abs(acf) > 3.0 / math.sqrt(v.size), acf, 0.0)
    return 1.0 + 2.0 * float(np.sum(acf**2)), 1.0 + 2.0 * float(np.sum(acf**4))


def _step_probability(per_sample: float, length: float) -> float:
    """Per-step tail probability of a sliding statistic over ``length`` samples whose
    excursions beyond its threshold start ``per_sample`` times per sample.

    A sliding mean of ``length`` terms has the correlation ``1 - |k| / length`` at lag
    ``k``: locally a Brownian-like (non-differentiable) process, whose excursions above a
    high level ``u`` start at the rate ``u^2 P(Z > u) / length`` per sample (Pickands'
    asymptotics with ``alpha = 1``, Pickands' constant 1; Rice's formula, which counts
    every wiggle across ``u``, would count each excursion ``sqrt(length)`` times over).
    Solved for ``u``, returned as ``P(Z > u)``.
    """
    from scipy.optimize import brentq

    target = math.log(per_sample * length)
    log_rate = lambda u: 2.0 * math.log(u) + float(log_ndtr(-u))  # noqa: E731
    if target >= log_rate(_LOWEST_LEVEL):  # more excursions asked than there are
        return float(ndtr(-_LOWEST_LEVEL))
    u = brentq(lambda v: log_rate(v) - target, _LOWEST_LEVEL, 40.0, xtol=1e-10)
    return float(ndtr(-u))


#: Lowest threshold level (sigma) of the per-hour calibration (the excursion rate peaks
#: near sqrt(2) and the asymptotics mean nothing below it).
_LOWEST_LEVEL = 1.5


_NODES = np.polynomial.hermite_e.hermegauss(48)
_WEIGHTS = _NODES[1] / _NODES[1].sum()


def _s_tail(s: float, length: int, seg: int, c2: float, c4: float) -> float:
    """``P(S > s)`` for a window of ``length`` stationary Gaussian samples, analytically.

    To first order the window's kurtosis is the segment's and the complement's mixed in
    proportion ``w = l / L``, plus ``3 w (1 - w) (a - b)^2`` from their sample variances
    ``1 + a`` and ``1 + b`` differing, so ``S = (kx - kc) / kx`` exceeds ``s`` when
    ``w (k_seg - k_c) + 3 w (1 - w) (a - b)^2 > s E[kx]``. The two kurtoses follow
    Anscombe-Glynn at their effective sizes (``l / c4``, ``(L - l) / c4``), ``a - b`` is
    normal with variance ``2 c2 (1/l + 1/(L - l))``; the probability is integrated by
    Gauss-Hermite quadrature over ``k_c`` and ``a - b``. Checked against simulated
    quantiles in tests/test_thresholds_hourly.py.
    """
    w = seg / length
    z = _NODES[0]
    kc = _ag_inverse(z, (length - seg) / c4)[:, None]
    var_ab = 2.0 * c2 * (1.0 / seg + 1.0 / (length - seg))
    mix = 3.0 * w * (1.0 - w) * var_ab * z[None, :] ** 2
    e = 3.0 * (length - 1) / (length + 1)
    needed = kc + (s * e - mix) / w
    p = ndtr(-_ag_z(needed, seg / c4))
    return float(_WEIGHTS @ p @ _WEIGHTS)


def _s_upper_quantile(q: float, length: int, seg: int, c2: float, c4: float) -> float:
    from scipy.optimize import brentq

    f = lambda s: _s_tail(s, length, seg, c2, c4) - q  # noqa: E731
    hi = 0.5
    while f(hi) > 0 and hi < 64:
        hi *= 2
    return float(brentq(f, -1.0, hi, xtol=1e-7))


#: Largest false-alarm rate per hour accepted (beyond it the tests flag stationary noise).
MAX_PER_HOUR = 3600.0


@lru_cache(maxsize=32)
def hourly_thresholds(
    lmin: int,
    lmax: int,
    segment: int,
    *,
    rate: float,
    per_hour: float = 0.1,
    dependence: tuple[float, float] = (1.0, 1.0),
    s_test: str = "upper",
) -> Thresholds:
    """Thresholds for a number of false events per hour of stationary data.

    Beyond the paper (docs/method.md section 8). The controller tests every sample; a false
    event is an excursion of one of its tests on stationary noise (the kurtosis below
    ``K1``, above ``K2``, or ``S`` above ``S2``; both tails of S for ``s_test="abs"``). Each
    test gets an equal share of ``per_hour / (3600 rate)`` excursions per sample; the
    excursion rate of a sliding statistic over ``L`` samples (``l`` for S, scaled by the
    record's correlation ``c4``) gives the per-step tail probability
    (:func:`_step_probability`), which sets ``K1(L)``, ``K2(L)`` as Anscombe-Glynn quantiles
    at the effective size ``L / c4`` and ``S2(L)`` as a quantile of the analytic
    distribution of S (:func:`_s_tail`). No simulation: milliseconds per length, bounded
    memory for any record. The rate of false events measured on simulated sensor records
    is in docs/benchmarks.md.

    Parameters
    ----------
    lmin, lmax, segment : int
        Window range and the S test's segment ``l``, samples.
    rate : float
        Samples per second.
    per_hour : float
        Target number of false events per hour of stationary data.
    dependence : (float, float)
        ``(c2, c4)`` of :func:`noise_dependence` (``(1, 1)``: white noise).
    s_test : {"upper", "band", "abs"}
        ``"abs"`` splits the S share between its two tails.

    Returns
    -------
    Thresholds
        Cached: the same settings return the same tables (do not modify them).
    """
    if not (math.isfinite(per_hour) and 0.0 < per_hour <= MAX_PER_HOUR):
        raise AdavarInputError(
            f"false_alarm_per_hour must lie in (0, {MAX_PER_HOUR:g}], got {per_hour}"
        )
    if not (math.isfinite(rate) and rate > 0.0):
        raise AdavarInputError(f"the sample rate must be a positive number, got {rate}")
    c2, c4 = (max(1.0, float(c)) for c in dependence)
    per_sample = per_hour / (3600.0 * rate) / 3.0
    size = lmax + 1
    k1 = np.full(size, np.nan)
    k2 = np.full(size, np.nan)
    s2 = np.full(size, np.nan)
    nodes = np.unique(np.round(np.geomspace(lmin, lmax, 9)).astype(np.int64))
    lo, hi, sv = [], [], []
    for n in nodes:
        q = _step_probability(per_sample, float(n))
        z = -ndtri(q)
        lo.append(float(_ag_inverse(-z, n / c4)))
        hi.append(float(_ag_inverse(z, n / c4)))
        qs = _step_probability(per_sample, float(segment))
        sv.append(_s_upper_quantile(qs / 2 if s_test == "abs" else qs, int(n), segment, c2, c4))
    inv = 1.0 / np.arange(lmin, lmax + 1)
    for table, values in ((k1, lo), (k2, hi), (s2, sv)):
        table[lmin:] = np.interp(inv, 1.0 / nodes[::-1], np.array(values)[::-1])
    # a window at the record's ends: the excursions of a window of lmax samples (where
    # the ends start), its kurtosis spread at the effective size (docs/method.md section 8)
    shortest = shortest_length(lmin)
    z = -ndtri(_step_probability(per_sample, float(lmax)))
    nodes = np.unique(np.round(np.geomspace(shortest, lmax, 9)).astype(np.int64))
    inv = 1.0 / np.arange(shortest, lmax + 1)
    e1 = np.full(size, np.nan)
    e2 = np.full(size, np.nan)
    for table, sign in ((e1, -1.0), (e2, 1.0)):
        values = [float(_ag_inverse(sign * z, n / c4)) for n in nodes]
        table[shortest:] = np.interp(inv, 1.0 / nodes[::-1], np.array(values)[::-1])
    return Thresholds(
        k1=k1, k2=k2, s2=s2,
        source=f"calibrated, {per_hour:g} false events per stationary hour",
        edge_k1=e1, edge_k2=e2,
    )  # fmt: skip


def thresholds_for(parameters: dict, lmax: int | None = None) -> Thresholds:
    """The thresholds a controller ran with, rebuilt from its recorded ``parameters``."""
    p = parameters
    lmax = int(p["lmax"] if lmax is None else lmax)
    if p.get("thresholds") != "calibrated":
        return fixed_thresholds(lmax, p["k1"], p["k2"], p["s2"])
    # a record whose stationary kurtosis the reference could not bring to 3 (its offset),
    # known to within its margin
    fit = p.get("kurtosis_reference_fit") or {}
    offset, margin = float(fit.get("offset", 0.0)), float(fit.get("margin", 0.0))
    if p.get("false_alarm_per_hour") is not None:
        return shifted(hourly_thresholds(
            int(p["lmin"]), lmax, int(p["l"]), rate=float(p["sample_rate"]),
            per_hour=float(p["false_alarm_per_hour"]),
            dependence=tuple(p.get("dependence") or (1.0, 1.0)), s_test=p.get("s_test", "upper"),
        ), offset, margin)  # fmt: skip
    return shifted(calibrated_thresholds(int(p["lmin"]), lmax, int(p["l"]),
                                         false_alarm=p["false_alarm"]), offset, margin)  # fmt: skip


def threshold_summary(th: Thresholds, lmin: int, lmax: int) -> dict[str, list[float]]:
    """``{"k1": [at Lmax, at Lmin], "k2": [...], "s2": [...]}``: the thresholds in force."""
    return {
        name: [float(getattr(th, name)[lmax]), float(getattr(th, name)[lmin])]
        for name in ("k1", "k2", "s2")
    }

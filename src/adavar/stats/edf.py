"""Equivalent degrees of freedom, power-law noise identification and chi-square intervals.

The confidence interval of an Allan-family variance is a chi-square interval whose number of
degrees of freedom (the EDF) depends on the statistic, the averaging factor ``m``, the record
length and the power-law noise type at that averaging time. This module provides

* :func:`greenhall_edf`, the general EDF algorithm of Greenhall & Riley, "Uncertainty of
  stability variances based on finite differences" (35th PTTI, 2003), for every variance built
  from d-th differences of phase (Allan d=2, Hadamard d=3; modified or not; overlapping or not);
* :func:`edf`, the dispatcher by statistic name, including the SP 1065 total-variance EDF,
  and :func:`edf_lengths`, the same at many record lengths at once (what a DAVAR asks for);
* :func:`identify_noise_lag1` (lag-1 autocorrelation, Riley & Greenhall 2004, SP 1065 5.6),
  :func:`identify_noise_b1` (Barnes B1 ratio, SP 1065 5.5.4) and :func:`identify_noise`
  (the Stable32 policy: lag-1 ACF, else B1, else give up with :class:`NoiseIdError`);
* :func:`chi2_interval`, the two-sided chi-square bounds of a variance (SP 1065 Eq. 45).

``alpha`` is always the exponent of the fractional-frequency (rate) PSD, ``S_y(f) ~ f**alpha``:
2 white PM (quantization), 1 flicker PM, 0 white FM (angle random walk), -1 flicker FM (bias
instability), -2 random-walk FM (rate random walk), -3 flicker walk FM, -4 random run FM.

References
----------
W. J. Riley, *Handbook of Frequency Stability Analysis*, NIST SP 1065 (2008).
C. A. Greenhall and W. J. Riley, "Uncertainty of stability variances based on finite
differences", Proc. 35th PTTI (2003).
W. J. Riley and C. A. Greenhall, "Power law noise identification using the lag 1
autocorrelation", Proc. 18th EFTF (2004).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache
from typing import Any, Final

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import gammaincinv

# noise identification lives in adavar.stats.noise_id; re-exported so existing imports keep working
from adavar.stats.noise_id import (  # noqa: F401
    MIN_POINTS_B1,
    MIN_POINTS_LAG1,
    RN_WHITE_FM,
    NoiseIdError,
    alpha_from_lag1,
    alpha_from_phase_lag1,
    b1_alpha,
    b1_theory,
    clamp_alpha,
    decimated_phase_lag1,
    detrend_poly,
    fill_unidentified,
    identify_noise,
    identify_noise_b1,
    identify_noise_lag1,
    rn_theory_pm,
)

__all__ = [
    "EDF_FLOOR",
    "MIN_POINTS_B1",
    "MIN_POINTS_LAG1",
    "STAT_ALPHA_RANGE",
    "TOTDEV_EDF_METHODS",
    "NoiseIdError",
    "chi2_bounds",
    "chi2_interval",
    "chi2_quantiles",
    "edf",
    "edf_lengths",
    "greenhall_edf",
    "identify_noise",
    "identify_noise_b1",
    "identify_noise_lag1",
    "interval_table",
]

#: Smallest EDF :func:`edf` returns. A variance estimate carries at least one degree of
#: freedom; the approximations (totvar ``b*T/tau - c``, Greenhall's tables) can dip below
#: that on very short records, where a chi-square with < 1 dof would give absurd intervals.
EDF_FLOOR: Final[float] = 1.0

#: Valid ``alpha`` range (inclusive) of each statistic for the EDF. Greenhall's algorithm needs
#: ``alpha + 2 d > 1`` (the variance converges), i.e. ``alpha >= -2`` for the Allan family
#: (d=2) and ``alpha >= -4`` for Hadamard (d=3); no power law bluer than white PM exists.
#: TOTVAR's EDF is tabulated for white/flicker/random-walk FM only (see :func:`edf`).
STAT_ALPHA_RANGE: Final[dict[str, tuple[int, int]]] = {
    "adev": (-2, 2),
    "oadev": (-2, 2),
    "mdev": (-2, 2),
    "tdev": (-2, 2),
    "hdev": (-4, 2),
    "ohdev": (-4, 2),
    "totdev": (-2, 2),
}

# (d, overlapping, modified) of the Greenhall estimator behind each statistic
_STAT_GREENHALL: Final[dict[str, tuple[int, bool, bool]]] = {
    "adev": (2, False, False),
    "oadev": (2, True, False),
    "mdev": (2, True, True),
    "tdev": (2, True, True),  # TVAR = tau^2 MVAR / 3: same chi-square shape as MVAR
    "hdev": (3, False, False),
    "ohdev": (3, True, False),
}

# SP 1065 Table 7, TOTVAR EDF = b * (T / tau) - c, keyed by alpha
_TOTVAR_BC: Final[dict[int, tuple[float, float]]] = {
    0: (1.50, 0.0),  # white FM
    -1: (1.17, 0.22),  # flicker FM
    -2: (0.93, 0.36),  # random-walk FM
}

# Greenhall & Riley 2003, Table 1: (a0, a1) for modified variances (F = 1), by alpha then d.
_TABLE1: Final[dict[int, dict[int, tuple[float, float]]]] = {
    2: {1: (2 / 3, 1 / 3), 2: (7 / 9, 1 / 2), 3: (22 / 25, 2 / 3)},
    1: {1: (0.840, 0.345), 2: (0.997, 0.616), 3: (1.141, 0.843)},
    0: {1: (1.079, 0.368), 2: (1.033, 0.607), 3: (1.184, 0.848)},
    -1: {2: (1.048, 0.534), 3: (1.180, 0.816)},
    -2: {2: (1.302, 0.535), 3: (1.175, 0.777)},
    -3: {3: (1.194, 0.703)},
    -4: {3: (1.489, 0.702)},
}
# Table 2: (a0, a1) for unmodified variances (F = m). The alpha = 2 row is exact:
# a0 = C(4d, 2d) / C(2d, d)^2, a1 = d / 2 (see case 4 below).
_TABLE2: Final[dict[int, dict[int, tuple[float, float]]]] = {
    2: {1: (3 / 2, 1 / 2), 2: (35 / 18, 1.0), 3: (231 / 100, 3 / 2)},
    1: {1: (78.6, 25.2), 2: (790.0, 410.0), 3: (9950.0, 6520.0)},
    0: {1: (2 / 3, 1 / 6), 2: (2 / 3, 1 / 3), 3: (7 / 9, 1 / 2)},
    -1: {2: (0.852, 0.375), 3: (0.997, 0.617)},
    -2: {2: (1.079, 0.368), 3: (1.033, 0.607)},
    -3: {3: (1.053, 0.553)},
    -4: {3: (1.302, 0.535)},
}
# Table 3: (b0, b1) with sz(0, m, 1, d) ~ b0 + b1 ln m, flicker PM unmodified
_TABLE3: Final[dict[int, tuple[float, float]]] = {1: (6.0, 4.0), 2: (15.23, 12.0), 3: (47.8, 40.0)}

_J_MAX: Final[int] = 100


# ---------------------------------------------------------------------------------------------
# Greenhall & Riley EDF
# ---------------------------------------------------------------------------------------------


def greenhall_sw(t: np.ndarray, alpha: int) -> np.ndarray:
    """Generalized autocovariance sw(t, alpha) of the phase integral (Greenhall Eq. 7).

    Only the shape matters: every EDF formula uses ratios of squares of one alpha's sw
    combinations, so constant factors (including signs) cancel.
    """
    a = np.abs(t)
    if alpha % 2 == 0:  # 2, 0, -2, -4: -|t|, |t|^3, |t|^5, |t|^7
        return -a if alpha == 2 else a ** (3 - alpha)
    # odd alpha (1, -1, -3): t^2 ln|t|, t^4 ln|t|, t^6 ln|t|; continuous, 0 at t = 0
    with np.errstate(divide="ignore", invalid="ignore"):
        out = a ** (3 - alpha) * np.log(a)
    return np.where(a > 0, out, 0.0)


def _sx_flicker_pm(t: np.ndarray, f: float | np.ndarray) -> np.ndarray:
    """sx(t, F, 1) = F^2 [2 sw(t) - sw(t - 1/F) - sw(t + 1/F)] without cancellation.

    With u = 1/(F |t|) < 1, exactly sx = -2 ln|t| - g(u) / u^2 where
    g(u) = (1 - u)^2 ln(1 - u) + (1 + u)^2 ln(1 + u)
         = 3 u^2 - sum_{k>=2} 4 u^(2k) / (2k (2k-1) (2k-2)).
    The direct F^2 second difference loses ~F^2 eps relative accuracy, i.e. everything at
    F ~ 1e8; the series keeps full precision for any F (needed: F = m is unbounded).
    ``f`` is a float > 1, or an array of them broadcasting against ``t`` (one F per row).
    """
    a = np.abs(t)
    f = np.asarray(f, dtype=np.float64)  # a float, or one per row
    fb, h = np.broadcast_to(f, a.shape), np.broadcast_to(1.0 / f, a.shape)
    out = np.empty_like(a)
    near = a <= h  # includes t = 0; here the direct formula has no cancellation problem
    if near.any():
        tn, hn, fn = t[near], h[near], fb[near]
        sw = greenhall_sw
        out[near] = fn * fn * (2.0 * sw(tn, 1) - sw(tn - hn, 1) - sw(tn + hn, 1))
    far = ~near
    if far.any():
        af = a[far]
        u = h[far] / af
        g_over_u2 = np.empty_like(u)
        small = u < 0.1
        us = u[small]
        u2 = us * us
        # series of g(u)/u^2 = 3 - sum_{k>=2} 4 u^(2k-2) / (2k (2k-1) (2k-2)); 9 terms < eps
        acc = np.zeros_like(us)
        for k in range(10, 1, -1):
            acc = acc * u2 + 4.0 / ((2 * k) * (2 * k - 1) * (2 * k - 2))
        g_over_u2[small] = 3.0 - acc * u2
        ub = u[~small]
        g_over_u2[~small] = ((1 - ub) ** 2 * np.log1p(-ub) + (1 + ub) ** 2 * np.log1p(ub)) / (
            ub * ub
        )
        out[far] = -2.0 * np.log(af) - g_over_u2
    return out


def _sx(t: np.ndarray, f: float | np.ndarray, alpha: int) -> np.ndarray:
    """Phase autocovariance sx(t, F, alpha) after a lowpass of width 1/F (Greenhall Eq. 8).

    ``f`` is a float, or an array of finite F > 1 broadcasting against ``t`` (one per row:
    the ``m'`` case of unmodified flicker PM, :func:`_greenhall_lengths`).
    """
    if np.ndim(f) > 0:
        if alpha == 1:
            return _sx_flicker_pm(t, f)
        h = 1.0 / f
        sw = greenhall_sw
        return f * f * (2.0 * sw(t, alpha) - sw(t - h, alpha) - sw(t + h, alpha))
    if math.isinf(f):
        return greenhall_sw(t, alpha + 2)
    if alpha == 1 and f > 1:
        return _sx_flicker_pm(t, f)
    h = 1.0 / f
    sw = greenhall_sw
    return f * f * (2.0 * sw(t, alpha) - sw(t - h, alpha) - sw(t + h, alpha))


def _sz(t: np.ndarray, f: float | np.ndarray, alpha: int, d: int) -> np.ndarray:
    """Autocovariance of the d-th difference sequence, sz(t, F, alpha, d) (Greenhall Eq. 9)."""
    t = np.asarray(t, dtype=np.float64)
    total = np.zeros_like(t)
    # sz(t) = sum_k (-1)^k C(2d, d + k) sx(t + k), k = -d..d
    for k in range(-d, d + 1):
        total += (-1) ** k * math.comb(2 * d, d + k) * _sx(t + k, f, alpha)
    return total


@lru_cache(maxsize=1 << 14)
def _sz_squared(j: int, s: float, f: float, alpha: int, d: int) -> np.ndarray:
    """``sz(k/S, F, alpha, d)^2`` at lags ``k = 0..J``: the same for every record length.

    A DAVAR asks for thousands of lengths at one (m, alpha), and they share this (the
    record length only moves the weights of :func:`_basic_sum`).
    """
    lags = np.arange(j + 1, dtype=np.float64)
    out = _sz(lags / s, f, alpha, d) ** 2
    out.flags.writeable = False
    return out


def _sz0_squared(f: float, alpha: int, d: int) -> float:
    """``sz(0, F, alpha, d)^2``, the normalisation of every basic sum."""
    return float(_sz_squared(0, 1.0, f, alpha, d)[0])


def _basic_sum(j: int, m_terms: float, s: float, f: float, alpha: int, d: int) -> float:
    """Greenhall Eq. (10): sum of squared normalised autocovariances over lags 0..J.

    BasicSum = sz(0)^2 + 2 sum_{j=1}^{J-1} (1 - j/M) sz(j/S)^2 + (1 - J/M) sz(J/S)^2.
    J <= J_max, so this is a bounded, vectorised evaluation whatever the record length.
    """
    lags = np.arange(j + 1, dtype=np.float64)
    sz2 = _sz_squared(j, s, f, alpha, d)
    weights = 2.0 * (1.0 - lags / m_terms)
    weights[0] = 1.0
    weights[-1] = 1.0 - j / m_terms  # J = 0 cannot occur: M >= 1 so J >= 1
    return float(np.dot(weights, sz2))


def greenhall_edf(
    alpha: int,
    d: int,
    m: int,
    n_phase: int,
    *,
    overlapping: bool,
    modified: bool,
    j_max: int = _J_MAX,
) -> float:
    """Equivalent degrees of freedom of a d-th difference variance (Greenhall & Riley 2003).

    Parameters
    ----------
    alpha : int
        Power-law exponent of the rate PSD, ``S_y(f) ~ f**alpha``, in ``[-4, 2]`` and with
        ``alpha + 2*d > 1`` (so ``alpha >= -2`` for d=2, ``alpha >= -4`` for d=3).
    d : int
        Order of the phase difference: 1 (first-difference variance), 2 (Allan), 3 (Hadamard).
    m : int
        Averaging factor, ``tau = m * tau0``.
    n_phase : int
        Number of phase points in the record (rate samples + 1).
    overlapping : bool
        Overlapping estimator: stride ``tau0`` (S = m) instead of ``tau`` (S = 1).
    modified : bool
        Modified variance (phase averaged over ``tau`` before differencing; F = 1) instead of
        the unmodified one (F = m).
    j_max : int, optional
        Largest number of lags summed explicitly (the paper's ``Jmax``, default 100). Beyond
        it the paper's closed-form tables or rescaled sums take over, so the cost is bounded
        (about ``j_max`` kernel evaluations) for any ``n_phase``.

    Returns
    -------
    float
        The EDF (not clipped; may be < 1 for records barely long enough).

    Raises
    ------
    ValueError
        Invalid ``d``, ``alpha`` outside the convergent range, ``m < 1``, or a record shorter
        than one estimator term needs (``L = m/F + m*d`` phase points).

    Notes
    -----
    Cases follow the paper: (1) modified variances; (2) unmodified, ``alpha <= 0``;
    (3) unmodified flicker PM, normalised by ``b0 + b1 ln m`` (Table 3); (4) unmodified
    white PM. When the explicit sum would exceed ``j_max`` lags, cases 1-3 use Tables 1/2 if
    ``r = M/S > d + 1`` and otherwise a sum over ``j_max`` lags with ``S`` replaced by
    ``m' = j_max / r``. Case 4 is exact for all ``r``; for ``ceil(r) <= d`` (fewer than
    ``d`` non-overlapping spans, e.g. overlapping ADEV with ``n_phase <= 4m``) the
    correlation sum is truncated to the lags that exist — allantools 2024.6 raises
    NotImplementedError there. For flicker PM the phase lowpass kernel is evaluated
    without cancellation, so large ``m`` (the paper warns of roundoff above ``m ~ 1e6``)
    keeps full precision.
    """
    alpha, d, m, n_phase = int(alpha), int(d), int(m), int(n_phase)
    if d not in (1, 2, 3):
        raise ValueError(f"d must be 1, 2 or 3, got {d}")
    if not -4 <= alpha <= 2 or alpha + 2 * d <= 1:
        raise ValueError(
            f"alpha={alpha} is outside the range where the d={d} variance converges "
            f"(need -4 <= alpha <= 2 and alpha + 2d > 1)"
        )
    if m < 1:
        raise ValueError(f"averaging factor m must be >= 1, got {m}")
    if j_max < 1:
        raise ValueError(f"j_max must be >= 1, got {j_max}")

    f_factor = 1 if modified else m  # F: 1 modified, m unmodified
    stride = m if overlapping else 1  # S: estimator stride is tau / S
    span = m // f_factor + m * d  # L = m/F + m d: phase points one estimator term needs
    if n_phase < span:
        raise ValueError(
            f"n_phase={n_phase} is too short for d={d}, m={m}: need at least {span} phase points"
        )
    n_terms = 1 + (stride * (n_phase - span)) // m  # M, the number of summed terms
    j = min(n_terms, (d + 1) * stride)  # J: lags beyond (d+1)S are (nearly) uncorrelated
    r = n_terms / stride

    if modified:  # case 1, all alpha, F = 1
        if j <= j_max:
            inv = _basic_sum(j, n_terms, stride, 1.0, alpha, d) / (
                _sz0_squared(1.0, alpha, d) * n_terms
            )
        elif r > d + 1:
            a0, a1 = _TABLE1[alpha][d]
            inv = (a0 - a1 / r) / r
        else:
            m_prime = j_max / r
            inv = _basic_sum(j_max, j_max, m_prime, 1.0, alpha, d) / (
                _sz0_squared(1.0, alpha, d) * j_max
            )
        return 1.0 / inv

    if alpha <= 0:  # case 2, unmodified, F = m
        if j <= j_max:
            # the paper models the phase as averaged over tau0 (F = m) while the explicit sum
            # stays short; for m (d+1) > Jmax it uses exact samples (F = inf) instead
            f_eff = float(m) if m * (d + 1) <= j_max else math.inf
            inv = _basic_sum(j, n_terms, stride, f_eff, alpha, d) / (
                _sz0_squared(f_eff, alpha, d) * n_terms
            )
        elif r > d + 1:
            a0, a1 = _TABLE2[alpha][d]
            inv = (a0 - a1 / r) / r
        else:
            m_prime = j_max / r
            inv = _basic_sum(j_max, j_max, m_prime, math.inf, alpha, d) / (
                _sz0_squared(math.inf, alpha, d) * j_max
            )
        return 1.0 / inv

    if alpha == 1:  # case 3, unmodified flicker PM
        if j <= j_max:
            inv = _basic_sum(j, n_terms, stride, float(m), 1, d) / (
                _sz0_squared(float(m), 1, d) * n_terms
            )
        else:
            b0, b1 = _TABLE3[d]
            norm = (b0 + b1 * math.log(m)) ** 2
            if r > d + 1:
                a0, a1 = _TABLE2[1][d]
                inv = (a0 - a1 / r) / (norm * r)
            else:
                m_prime = j_max / r
                inv = _basic_sum(j_max, j_max, m_prime, m_prime, 1, d) / (norm * j_max)
        return 1.0 / inv

    # case 4, unmodified white PM: the d-th differences of white phase samples are correlated
    # only at lags that are whole multiples of tau, with rho(k tau) = (-1)^k C(2d, d+k)/C(2d, d)
    # exactly, so 1/edf = (1/M) sum_{|k| < r, |k| <= d} (1 - |k|/r) rho(k tau)^2.
    k_max = min(d, math.ceil(r) - 1)
    c0 = math.comb(2 * d, d)
    inv = sum(
        (1.0 if k == 0 else 2.0) * (1.0 - k / r) * (math.comb(2 * d, d + k) / c0) ** 2
        for k in range(k_max + 1)
    )
    return n_terms / inv


# ---------------------------------------------------------------------------------------------
# Greenhall & Riley EDF at many record lengths
# ---------------------------------------------------------------------------------------------

#: rows of ``m'`` sums evaluated at once by :func:`_mprime_rows` (bounds the temporaries)
_MPRIME_ROWS: Final[int] = 1024
#: at most this many ``m'`` sums are kept by :func:`_mprime_sums` (then it starts afresh)
_MPRIME_KEPT: Final[int] = 1 << 16
#: (alpha, d, F or None for F = m') -> {m': basic sum}, every m' sum computed so far
_MPRIME_SUMS: dict[tuple[int, int, float | None], dict[float, float]] = {}


def _too_short(n_phase: np.ndarray, need: int, message: Callable[[int], str]) -> None:
    """Raise ``ValueError(message(n))`` for the first ``n`` of ``n_phase`` below ``need``."""
    short = n_phase < need
    if short.any():
        raise ValueError(message(int(n_phase[np.argmax(short)])))


def _mprime_rows(m_prime: np.ndarray, f: float | None, alpha: int, d: int) -> np.ndarray:
    """``_basic_sum(J_max, J_max, m', F, alpha, d)`` at every ``m'`` (F = ``m'`` if None).

    One row of ``J_max + 1`` lags per ``m'``, each reduced on its own (a pairwise sum of
    fixed length): a value does not depend on the other ``m'`` asked for.
    """
    lags = np.arange(_J_MAX + 1, dtype=np.float64)
    weights = 2.0 * (1.0 - lags / _J_MAX)
    weights[0] = 1.0
    weights[-1] = 1.0 - _J_MAX / _J_MAX
    out = np.empty(m_prime.size)
    for lo in range(0, m_prime.size, _MPRIME_ROWS):
        rows = m_prime[lo : lo + _MPRIME_ROWS, None]
        sz = _sz(lags / rows, rows if f is None else f, alpha, d)
        out[lo : lo + _MPRIME_ROWS] = (sz * sz * weights).sum(axis=1)
    return out


def _mprime_sums(m_prime: np.ndarray, f: float | None, alpha: int, d: int) -> np.ndarray:
    """:func:`_mprime_rows`, each ``m'`` computed once (a DAVAR asks for it again and again)."""
    held = _MPRIME_SUMS.setdefault((alpha, d, f), {})
    keys = m_prime.tolist()
    out = np.array([held.get(k, math.nan) for k in keys])
    missing = np.isnan(out)
    if missing.any():
        out[missing] = _mprime_rows(m_prime[missing], f, alpha, d)
        tables = list(_MPRIME_SUMS.values())  # a snapshot: other threads may add a key
        if sum(map(len, tables)) > _MPRIME_KEPT:
            for table in tables:
                table.clear()
        held.update(zip(m_prime[missing].tolist(), out[missing].tolist(), strict=True))
    return out


@lru_cache(maxsize=1 << 12)
def _explicit_sums(j: int, s: int, f: float, alpha: int, d: int) -> tuple[Any, Any, float]:
    """``P``, ``Q`` by number of lags ``J = 1..j`` and ``sz(0)^2``, for :func:`_greenhall_lengths`.

    ``BasicSum(J, M) = P[J] - Q[J] / M`` with ``P[J] = sz0^2 + 2 sum_{k<J} sz_k^2 + sz_J^2``
    and ``Q[J] = 2 sum_{k<J} k sz_k^2 + J sz_J^2`` (``sz_k = sz(k/S, F, alpha, d)``).
    """
    sz2 = _sz_squared(j, s, f, alpha, d)
    lags = np.arange(j + 1, dtype=np.float64)
    below = np.concatenate(([0.0], np.cumsum(sz2[1:-1])))  # sum_{1 <= k < J} sz_k^2
    moment = np.concatenate(([0.0], np.cumsum(lags[1:-1] * sz2[1:-1])))
    p = np.concatenate(([math.nan], sz2[0] + 2.0 * below + sz2[1:]))
    q = np.concatenate(([math.nan], 2.0 * moment + lags[1:] * sz2[1:]))
    for table in (p, q):
        table.flags.writeable = False
    return p, q, _sz0_squared(f, alpha, d)


def _greenhall_lengths(
    alpha: int, d: int, m: int, n_phase: np.ndarray, *, overlapping: bool, modified: bool
) -> np.ndarray:
    """:func:`greenhall_edf` (``j_max`` = 100) at every record length of ``n_phase``.

    The same cases and formulas, by groups: for one (alpha, d, m, estimator) the length
    enters only through the number of terms M (with ``J = min(M, (d+1)S)``, ``r = M/S``).
    Where ``J <= J_max`` the basic sum is ``P[J] - Q[J]/M`` (:func:`_explicit_sums`: one
    closed form for all ``M >= (d+1)S``); the tables are closed forms in ``r``; the
    ``m' = J_max / r`` sums are evaluated for all distinct M at once, and kept
    (:func:`_mprime_sums`). Agrees with :func:`greenhall_edf` to a few ulps (summation
    order), and each value depends on its own length only.

    Parameters
    ----------
    alpha, d, m : int
        As :func:`greenhall_edf`; ``alpha`` valid for ``d`` and ``m >= 1`` (not checked).
    n_phase : ndarray of int64, shape (K,)
        Record lengths, phase points.
    overlapping, modified : bool
        The estimator, as :func:`greenhall_edf`.

    Returns
    -------
    ndarray, shape (K,)
        The EDFs (not clipped).

    Raises
    ------
    ValueError
        A record shorter than one estimator term (the message of :func:`greenhall_edf`).
    """
    f_factor = 1 if modified else m
    stride = m if overlapping else 1
    span = m // f_factor + m * d
    _too_short(
        n_phase,
        span,
        lambda n: f"n_phase={n} is too short for d={d}, m={m}: need at least {span} phase points",
    )
    # M = 1 + S (N - L) // m, without the product (S is m or 1)
    n_terms = 1 + (n_phase - span if overlapping else (n_phase - span) // m)

    if not modified and alpha == 2:  # case 4, exact; the same sum as greenhall_edf
        r = n_terms / stride
        k_max = np.minimum(d, np.ceil(r) - 1.0)
        c0 = math.comb(2 * d, d)
        inv = np.zeros(r.shape)
        for k in range(d + 1):
            term = (1.0 if k == 0 else 2.0) * (1.0 - k / r) * (math.comb(2 * d, d + k) / c0) ** 2
            inv += np.where(k <= k_max, term, 0.0)
        return n_terms / inv

    if modified:  # case 1: F = 1 throughout
        f_sum = 1.0
    elif alpha <= 0:  # case 2: F = m for a short explicit sum, else exact samples
        f_sum = float(m) if m * (d + 1) <= _J_MAX else math.inf
    else:  # case 3, flicker PM: F = m
        f_sum = float(m)
    j_all = (d + 1) * stride
    j = np.minimum(n_terms, j_all)
    explicit = j <= _J_MAX
    p, q, sz0 = _explicit_sums(min(j_all, _J_MAX), stride, f_sum, alpha, d)
    if explicit.all():
        return 1.0 / ((p[j] - q[j] / n_terms) / (sz0 * n_terms))
    out = np.empty(n_terms.shape)
    je, me = j[explicit], n_terms[explicit]
    out[explicit] = 1.0 / ((p[je] - q[je] / me) / (sz0 * me))

    beyond = ~explicit
    r = n_terms[beyond] / stride
    tabled = r > d + 1
    flicker = not modified and alpha == 1
    norm = math.nan  # case 3's (b0 + b1 ln m)^2 beyond J_max
    if flicker:
        b0, b1 = _TABLE3[d]
        norm = (b0 + b1 * math.log(m)) ** 2
    values = np.empty(r.shape)
    if tabled.any():
        a0, a1 = (_TABLE1 if modified else _TABLE2)[alpha][d]
        rt = r[tabled]
        values[tabled] = 1.0 / ((a0 - a1 / rt) / (norm * rt if flicker else rt))
    rescaled = ~tabled
    if rescaled.any():
        # m' = J_max / r: a sum over J_max lags at stride m' (F = 1, exact samples, or m')
        terms, where = np.unique(n_terms[beyond][rescaled], return_inverse=True)
        f_prime = None if flicker else (1.0 if modified else math.inf)
        sums = _mprime_sums(_J_MAX / (terms / stride), f_prime, alpha, d)
        if flicker:
            inv = sums / (norm * _J_MAX)
        else:
            inv = sums / (_sz0_squared(1.0 if modified else math.inf, alpha, d) * _J_MAX)
        values[rescaled] = (1.0 / inv)[where.ravel()]
    out[beyond] = values
    return out


# ---------------------------------------------------------------------------------------------
# EDF by statistic
# ---------------------------------------------------------------------------------------------


#: TOTDEV EDF conventions accepted by :func:`edf` (``totdev_edf=``)
TOTDEV_EDF_METHODS: Final[tuple[str, ...]] = ("sp1065", "stable32", "legacy")

#: White PM TOTVAR: ``1/edf = 1/edf_oadev + C (m / (N_phase - 1))^2``. The reflected phase
#: ``2 x[0] - x[j]`` repeats the end samples' noise in ~m terms at each end. C is fitted to
#: the coverage of the 68.3 % interval, not to the variance of the estimate: the two end
#: samples' squares make TOTVAR's distribution skewed, and the chi-square of matched
#: variance (C 0.6-0.86) is too wide for its central part (coverage 77-80 % at m = N/8).
#: Coverage-matched C, 3000 records of N = 1025, 4097, 16385, m = N/128 .. N/8: 0.41-0.61
#: (0.41-0.45 at N/8); 0.6 before issue 39.
TOTVAR_WPM_END_FACTOR: Final[float] = 0.45


def edf_simple_avar(alpha: int, m: int, n_phase: int) -> float:
    """SP 1065 Table 5 simple AVAR EDF for PM noise (``N`` = phase points), as Stable32."""
    n = float(n_phase)
    if alpha == 2:
        return (n + 1.0) * (n - 2.0 * m) / (2.0 * (n - m))
    spans = math.log((n - 1.0) / (2.0 * m))
    return math.exp(math.sqrt(spans * math.log((2.0 * m + 1.0) * (n - 1.0) / 4.0)))


def edf(stat: str, alpha: int, m: int, n_phase: int, *, totdev_edf: str = "sp1065") -> float:
    """Equivalent degrees of freedom of a statistic at one averaging time.

    Results are cached (a DAVAR asks for the same few thousand (L, m) pairs again and
    again); the function is pure.

    Parameters
    ----------
    stat : {"adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev"}
        The statistic.
    alpha : int
        Power-law exponent of the rate PSD at this tau. Values outside the statistic's range
        (:data:`STAT_ALPHA_RANGE`) are clamped to the nearest valid one: the Allan family
        cannot tell alpha < -2 from alpha = -2 (its variance diverges there), Hadamard stops
        at -4, and nothing is bluer than white PM (2). Lag-1 noise identification can return
        such values (e.g. -3 with ``dmax=2``; allantools would then fail an assertion).
    m : int
        Averaging factor, ``tau = m * tau0``.
    n_phase : int
        Number of phase points of the record (rate samples + 1).
    totdev_edf : {"sp1065", "stable32", "legacy"}
        Convention for ``stat="totdev"`` (ignored otherwise); see Notes.

    Returns
    -------
    float
        The EDF, finite and ``>= EDF_FLOOR`` (1).

    Notes
    -----
    * adev, oadev, mdev/tdev, hdev, ohdev: :func:`greenhall_edf` with (d, overlapping,
      modified) = (2, F, F), (2, T, F), (2, T, T), (3, F, F), (3, T, F).
    * totdev, ``"sp1065"`` (default). White, flicker and random-walk FM: SP 1065 Table 7,
      ``edf = b (T/tau) - c`` with ``T/tau = (n_phase - 1)/m`` and (b, c) = (1.50, 0),
      (1.17, 0.22), (0.93, 0.36) -- except at ``m = 1``, where TOTVAR *is* the overlapping
      AVAR (the reflection adds no term) and gets its EDF: Table 7 is a fit for longer
      taus and at m = 1 gives white FM 1.5 N degrees of freedom where the terms, adjacent
      first differences with correlation -1/2, carry about 2N/3 (coverage 48-50 %).
      PM noise: SP 1065 gives no TOTVAR EDF and says TOTVAR behaves like AVAR there, so
      flicker PM takes the OADEV (Greenhall) EDF, which simulation confirms (within the
      Monte Carlo scatter). White PM takes the OADEV EDF reduced for the reflected ends,
      ``1/edf = 1/edf_oadev + C (m / (n_phase - 1))^2`` with
      C = :data:`TOTVAR_WPM_END_FACTOR`: the extension ``2 x[0] - x[j]`` repeats the two end
      samples' noise in about m terms each, so at m = N/8 TOTVAR has ~130 degrees of freedom
      where OADEV has ~1700.
    * totdev, ``"stable32"``: what Stable32 prints (and allantools' ``edf_totdev``):
      Table 7 with ``T/tau = n_phase / m`` at every m, and for PM noise the simple AVAR
      formulas of SP 1065 Table 5 (white PM ``(N+1)(N-2m)/(2(N-m))``, flicker PM
      ``exp(sqrt(ln((N-1)/2m) ln((2m+1)(N-1)/4)))``, N = ``n_phase``).
    * totdev, ``"legacy"``: adavar before the coverage work: Table 7 at every m and the
      OADEV EDF for PM noise.
    * TOTVAR's bias (SP 1065 5.2.11): it is unbiased for white FM, but for flicker and
      random-walk FM its expectation is ``AVAR (1 - a tau/T)``, a = 1/(3 ln 2) and 3/4;
      simulation shows a white PM bias of ``1 + 4 tau / (3 T)`` as well. The EDF here is
      that of the (biased) TOTVAR estimate about its own expectation;
      :func:`adavar.deviation` can remove the FM bias (``totdev_bias=True``).
    """
    method = str(totdev_edf).lower()
    if method not in TOTDEV_EDF_METHODS:
        raise ValueError(f"totdev_edf must be one of {TOTDEV_EDF_METHODS}, got {totdev_edf!r}")
    return _edf_cached(str(stat).lower(), int(alpha), int(m), int(n_phase), method)


@lru_cache(maxsize=1 << 16)
def _edf_cached(stat: str, alpha: int, m: int, n_phase: int, method: str = "sp1065") -> float:
    if stat not in STAT_ALPHA_RANGE:
        raise ValueError(f"unknown statistic {stat!r}; expected one of {sorted(STAT_ALPHA_RANGE)}")
    if m < 1:
        raise ValueError(f"averaging factor m must be >= 1, got {m}")
    lo, hi = STAT_ALPHA_RANGE[stat]
    a = min(max(int(alpha), lo), hi)

    if stat == "totdev":
        if n_phase < 2 * m + 1:  # TOTDEV is defined up to tau = T/2
            raise ValueError(
                f"n_phase={n_phase} is too short for totdev at m={m}: need >= {2 * m + 1}"
            )
        if method == "stable32":
            if a in _TOTVAR_BC:
                b, c = _TOTVAR_BC[a]
                value = b * n_phase / m - c
            else:
                value = edf_simple_avar(a, m, n_phase)
        elif a in _TOTVAR_BC and (m > 1 or method == "legacy"):
            b, c = _TOTVAR_BC[a]
            value = b * (n_phase - 1) / m - c
        else:
            value = greenhall_edf(a, 2, m, n_phase, overlapping=True, modified=False)
            if a == 2 and method == "sp1065":
                ends = TOTVAR_WPM_END_FACTOR * (m / (n_phase - 1)) ** 2
                value = 1.0 / (1.0 / value + ends)
    else:
        d, overlapping, modified = _STAT_GREENHALL[stat]
        value = greenhall_edf(a, d, m, n_phase, overlapping=overlapping, modified=modified)
    if not math.isfinite(value):  # pragma: no cover - defensive, the cases above are finite
        return EDF_FLOOR
    return max(value, EDF_FLOOR)


def edf_lengths(
    stat: str, alpha: int, m: int, n_phase: ArrayLike, *, totdev_edf: str = "sp1065"
) -> np.ndarray:
    """:func:`edf` of one statistic, noise type and averaging factor at many record lengths.

    What a DAVAR asks for: the EDF of windows of many lengths at one tau. The same values
    as ``[edf(stat, alpha, m, n) for n in n_phase]`` (to a few ulps: the sums are taken in
    another order), computed by groups (:func:`_greenhall_lengths`) instead of one Greenhall
    evaluation (~65 us) per length: ~10 us a call and a few ns a length, except lengths in
    Greenhall's ``m'`` case (overlapping estimators with ``J_max < M <= (d+1) m``): 2-15 us
    each the first time, then kept. Each value depends on its own length only, not on the
    others asked for.

    Parameters
    ----------
    stat : {"adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev"}
        The statistic.
    alpha : int
        Power-law exponent of the rate PSD, clamped to :data:`STAT_ALPHA_RANGE` as by
        :func:`edf`.
    m : int
        Averaging factor, ``tau = m * tau0``.
    n_phase : array_like of int
        Numbers of phase points of the records (rate samples + 1), any shape; repeats are
        allowed.
    totdev_edf : {"sp1065", "stable32", "legacy"}
        Convention for ``stat="totdev"`` (ignored otherwise), as :func:`edf`.

    Returns
    -------
    ndarray of float64, shape of ``n_phase``
        The EDFs, finite and ``>= EDF_FLOOR``.

    Raises
    ------
    ValueError
        What :func:`edf` raises: an unknown ``stat`` or ``totdev_edf``, ``m < 1``, or a
        record too short for one term (the message names the first such length).
    """
    method = str(totdev_edf).lower()
    if method not in TOTDEV_EDF_METHODS:
        raise ValueError(f"totdev_edf must be one of {TOTDEV_EDF_METHODS}, got {totdev_edf!r}")
    stat = str(stat).lower()
    if stat not in STAT_ALPHA_RANGE:
        raise ValueError(f"unknown statistic {stat!r}; expected one of {sorted(STAT_ALPHA_RANGE)}")
    m = int(m)
    if m < 1:
        raise ValueError(f"averaging factor m must be >= 1, got {m}")
    lengths = np.asarray(n_phase)
    n = lengths.astype(np.int64).ravel()
    lo, hi = STAT_ALPHA_RANGE[stat]
    a = min(max(int(alpha), lo), hi)
    if stat == "totdev":
        value = _totdev_lengths(a, m, n, method)
    else:
        d, overlapping, modified = _STAT_GREENHALL[stat]
        value = _greenhall_lengths(a, d, m, n, overlapping=overlapping, modified=modified)
    value = np.where(np.isfinite(value), np.maximum(value, EDF_FLOOR), EDF_FLOOR)
    return value.reshape(lengths.shape)


def _totdev_lengths(alpha: int, m: int, n_phase: np.ndarray, method: str) -> np.ndarray:
    """The totdev branch of :func:`edf` (not clipped) at every length of ``n_phase``."""
    _too_short(
        n_phase,
        2 * m + 1,
        lambda n: f"n_phase={n} is too short for totdev at m={m}: need >= {2 * m + 1}",
    )
    n = n_phase.astype(np.float64)
    if method == "stable32":
        if alpha in _TOTVAR_BC:
            b, c = _TOTVAR_BC[alpha]
            return b * n / m - c
        if alpha == 2:  # SP 1065 Table 5, as edf_simple_avar
            return (n + 1.0) * (n - 2.0 * m) / (2.0 * (n - m))
        spans = np.log((n - 1.0) / (2.0 * m))
        return np.exp(np.sqrt(spans * np.log((2.0 * m + 1.0) * (n - 1.0) / 4.0)))
    if alpha in _TOTVAR_BC and (m > 1 or method == "legacy"):
        b, c = _TOTVAR_BC[alpha]
        return b * (n - 1.0) / m - c
    value = _greenhall_lengths(alpha, 2, m, n_phase, overlapping=True, modified=False)
    if alpha == 2 and method == "sp1065":
        ends = TOTVAR_WPM_END_FACTOR * (m / (n - 1.0)) ** 2
        value = 1.0 / (1.0 / value + ends)
    return value


# ---------------------------------------------------------------------------------------------
# Chi-square interval
# ---------------------------------------------------------------------------------------------


def chi2_interval(
    var: np.ndarray, edf: np.ndarray, confidence: float = 0.683
) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided chi-square confidence interval of a variance (SP 1065 Eq. 45).

    Parameters
    ----------
    var : array_like
        Variance estimates (not deviations), ``>= 0``; NaN propagates.
    edf : array_like
        Equivalent degrees of freedom, ``> 0``; broadcast against ``var``. NaN propagates.
    confidence : float
        Two-sided confidence level in (0, 1); 0.683 is the usual "1 sigma".

    Returns
    -------
    var_low, var_high : ndarray
        ``var * edf / chi2.ppf((1 + c) / 2, edf)`` and ``var * edf / chi2.ppf((1 - c) / 2, edf)``.
        Take square roots for deviation bounds.

    Raises
    ------
    ValueError
        ``confidence`` not in (0, 1), a non-positive or infinite ``edf``, or a negative or
        infinite ``var``.
    """
    try:
        c = float(confidence)
    except (TypeError, ValueError):
        raise ValueError(f"confidence must be a number in (0, 1), got {confidence!r}") from None
    if not 0.0 < c < 1.0:
        raise ValueError(f"confidence must be in the open interval (0, 1), got {confidence!r}")
    v = np.asarray(var, dtype=np.float64)
    k = np.asarray(edf, dtype=np.float64)
    if np.any(k <= 0) or np.any(np.isinf(k)):
        raise ValueError("edf must be positive and finite")
    if np.any(v < 0) or np.any(np.isinf(v)):
        raise ValueError("var must be non-negative and finite")
    v, k = np.broadcast_arrays(v, k)
    return chi2_bounds(v, k, *chi2_quantiles(k, c))


def chi2_bounds(
    var: np.ndarray, edf: np.ndarray, upper: np.ndarray, lower: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(var * edf / upper, var * edf / lower)``: :func:`chi2_interval` given the quantiles.

    ``upper, lower`` are :func:`chi2_quantiles` of ``edf``; nothing is checked.
    """
    spread = var * edf
    return spread / upper, spread / lower


def chi2_quantiles(edf: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    """``chi2.ppf((1 + c) / 2, edf)`` and ``chi2.ppf((1 - c) / 2, edf)``, unchecked.

    ``chi2.ppf(q, k)`` is ``2 gammaincinv(k / 2, q)``, bit for bit, without scipy.stats'
    import and per-call overhead. The bounds of :func:`chi2_interval` are ``var * edf``
    divided by these (:func:`chi2_bounds`).
    """
    half = 0.5 * np.asarray(edf, dtype=np.float64)
    c = float(confidence)
    return 2.0 * gammaincinv(half, 0.5 * (1.0 + c)), 2.0 * gammaincinv(half, 0.5 * (1.0 - c))


def interval_table(
    stat: str,
    alpha: np.ndarray,
    ms: np.ndarray,
    n_phase: int,
    confidence: float,
    *,
    totdev_edf: str = "sp1065",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """EDF and chi-square quantiles of a whole tau grid, cached by the grid.

    ``(edf, upper, lower)``: :func:`edf` at every ``(alpha, m)`` pair, and
    :func:`chi2_quantiles` of those EDFs, as read-only arrays. A record of the same length,
    taus and noise types as an earlier one (repeated analyses, channels, windows) takes
    them from the cache.
    """
    alpha = np.ascontiguousarray(alpha, dtype=np.int64)
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    return _interval_table(
        str(stat).lower(),
        alpha.tobytes(),
        ms.tobytes(),
        int(n_phase),
        float(confidence),
        str(totdev_edf).lower(),
    )


@lru_cache(maxsize=256)
def _interval_table(
    stat: str, alpha: bytes, ms: bytes, n_phase: int, confidence: float, method: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    alphas, factors = np.frombuffer(alpha, np.int64).tolist(), np.frombuffer(ms, np.int64).tolist()
    pairs = zip(alphas, factors, strict=True)
    values = np.array([edf(stat, a, m, n_phase, totdev_edf=method) for a, m in pairs])
    upper, lower = chi2_quantiles(values, confidence)
    for table in (values, upper, lower):
        table.flags.writeable = False
    return values, upper, lower

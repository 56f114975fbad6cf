"""The total family of NIST SP 1065 (MTOT, TTOT, HTOT) and the parabolic deviation PDEV.

A family module of :mod:`adavar.core.extended_statistics` (``squared``, ``m_max``, ``factors``,
``edf``); reach it through ``adavar.deviation(x, stat="mtotdev" | "ttotdev" | "htotdev" |
"pdev", ...)``.

Definitions (W. J. Riley, *Handbook of Frequency Stability Analysis*, NIST SP 1065, 2008,
sections 5.2.12-5.2.14; ``tau = m tau0``, ``N`` phase points ``x``, ``N - 1`` rates ``y``):

``mtotdev``
    Modified total deviation. For each of the ``N - 3m + 1`` phase subsequences of ``3m``
    points the linear frequency trend is removed (half-average slope: the mean of the last
    half minus the mean of the first half, over the distance between them; the middle point
    is left out for odd ``3m``), the result is extended by uninverted even reflection to
    ``9m`` points, and its ``6m`` second differences of ``m``-point phase averages are
    squared and averaged. ``MTOT = 1 / (2 tau^2 (N - 3m + 1)) sum_n mean_j (...)^2``.
    Frequency kind, ``m <= N / 3``.
``ttotdev``
    Time total deviation, ``tau * mtotdev / sqrt(3)`` (SP 1065 Eq. 28 prints tau cubed; the
    square is what its tables and Stable32 use). Time kind.
``htotdev``
    Hadamard total deviation: the same recipe on the ``N - 3m`` frequency subsequences of
    ``3m`` points (drift removed, reflected to ``9m``), second differences of ``m``-point
    frequency averages, ``HTOT = 1 / (6 (N_y - 3m + 1)) sum_n mean_j (...)^2``. At ``m = 1``
    the overlapping Hadamard deviation is used instead (SP 1065, Stable32: "for best
    consistency"; the 3-point detrended subsequence halves the variance there). Frequency
    kind, noise identification up to ``dmax = 3``.
``pdev``
    Parabolic deviation (F. Vernotte, M. Lenczner, P.-Y. Bourgeois, E. Rubiola, "The
    parabolic variance (PVAR): a wavelet variance based on the least-square fit", IEEE
    TUFFC 63(4), 2016): ``PVAR = 72 / (M m^4 tau^2) sum_{i<M} [sum_{k<m} ((m-1)/2 - k)
    (x[i+k] - x[i+k+m])]^2`` with ``M = N - 2m`` (the term count of allantools 2024.6 and
    SigmaTheta, whose published PDEV of the SP 1065 1000-point set it reproduces); at
    ``m = 1`` the OADEV. Frequency kind.

Bias (``bias_correction``, default True). MTOT and HTOT are biased low with respect to MVAR
and HVAR. SP 1065's published values divide the variance by a factor of the noise type:
MTOT 0.94 (white PM), 0.83 (flicker PM), 0.73 (white FM), 0.70 (flicker FM), 0.69
(random-walk FM); HTOT 0.995 (white FM), 0.851 (flicker FM), 0.771 (random-walk FM), 0.717
(flicker walk FM), 0.679 (random run FM), none for PM (:data:`MTOT_BIAS`,
:data:`HTOT_BIAS`; Riley's notes on the Stable32 variance functions, wriley.com/CI2.pdf,
the source allantools cites). The default reproduces SP 1065 Table 31 (1000-point set, AF 1, 10,
100: MTOT 2.418528e-01, 6.499161e-02, 2.287774e-02; TTOT 1.396338e-01, 3.752293e-01,
1.320847e+00; HTOT 2.943883e-01, 9.614787e-02, 3.058103e-02) and its 10-point values.
Stable32 corrects HTOT in every run (its PHASE.DAT octave table) but MTOT and TTOT only in
its all-tau runs: its octave and decade MTOT/TTOT tables, and allantools 2024.6 (which
corrects nothing), are ``bias_correction=False``. TTOT takes MTOT's factor; HTOT at
``m = 1`` (OHDEV) is never corrected. The factor needs the noise type, which
:func:`squared` identifies itself, by the Stable32 rule (lag-1 autocorrelation of the
m-averaged rate, B1 below 30 clusters; ``result.alpha`` is that alpha with
``noise_id="stable32"``), also when ``confidence=None``.

EDF (``total_edf``, default ``"sp1065"``): see :func:`edf`.

Every sum is computed in O(N) per tau by :mod:`adavar._kernels.total_family` (prefix sums
over blocks of ``3m`` subsequences, each from its own double-double span), to within a few
ulps of the direct O(N m) definition on records with large offsets, drift, level steps or
spikes. Measured (benchmarks/bench_total_family.py, 2 shared cores): 2e4 points, octave
taus, 0.02-0.06 s per statistic; allantools 2024.6 needs 13-16 s for the six taus up to
m = 32 alone (367-1071x) and, extrapolated, 11-17 minutes for all thirteen; 1e6 points,
19 taus: about 2 s per statistic (PDEV 0.8 s).
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any, Final

import numpy as np

from adavar._kernels._jit import read_only
from adavar._kernels.total_family import MIN_BLOCK, left_sums, pvar_sums
from adavar.core.errors import AdavarInputError
from adavar.stats import edf as edf_mod

__all__ = [
    "HTOT_BIAS",
    "HTOT_EDF",
    "MTOT_BIAS",
    "MTOT_EDF_SP1065",
    "MTOT_EDF_STABLE32",
    "STATISTICS",
    "TOTAL_EDF_METHODS",
    "edf",
    "factors",
    "m_max",
    "squared",
]

#: the statistics of this family
STATISTICS: Final[tuple[str, ...]] = ("mtotdev", "ttotdev", "htotdev", "pdev")
#: EDF conventions of ``total_edf=``
TOTAL_EDF_METHODS: Final[tuple[str, ...]] = ("sp1065", "stable32")

#: MTOT (and TTOT) variance bias by alpha: MTOT / MVAR (SP 1065; Stable32)
MTOT_BIAS: Final[dict[int, float]] = {2: 0.94, 1: 0.83, 0: 0.73, -1: 0.70, -2: 0.69}
#: HTOT variance bias by alpha: HTOT / HVAR (SP 1065; Stable32); PM noise: none
HTOT_BIAS: Final[dict[int, float]] = {0: 0.995, -1: 0.851, -2: 0.771, -3: 0.717, -4: 0.679}

#: MTOT EDF ``b (T / tau) - c`` by alpha: SP 1065 Table 8
MTOT_EDF_SP1065: Final[dict[int, tuple[float, float]]] = {
    2: (1.90, 2.10),
    1: (1.20, 1.40),
    0: (1.10, 1.20),
    -1: (0.85, 0.50),
    -2: (0.75, 0.31),
}
#: the same with the revised coefficients (D. A. Howe, 2000) that Stable32 uses for m > 8
MTOT_EDF_STABLE32: Final[dict[int, tuple[float, float]]] = {
    2: (2.16, 2.28),
    1: (1.73, 2.99),
    0: (1.33, 1.89),
    -1: (0.92, 0.76),
    -2: (0.79, 0.37),
}
#: HTOT EDF ``(T / tau) / (b0 + b1 tau / T)`` by alpha, FM noise (SP 1065; Howe et al. 2000)
HTOT_EDF: Final[dict[int, tuple[float, float]]] = {
    0: (0.559, 1.004),
    -1: (0.868, 1.140),
    -2: (0.938, 1.696),
    -3: (0.974, 2.554),
    -4: (1.276, 3.149),
}
#: Stable32 takes the MDEV EDF for MTOT up to this factor (Howe's fit holds above it)
STABLE32_MTOT_MDEV_UP_TO: Final[int] = 8

_OPTIONS: Final[dict[str, tuple[str, ...]]] = {
    "mtotdev": ("bias_correction", "total_edf"),
    "ttotdev": ("bias_correction", "total_edf"),
    "htotdev": ("bias_correction", "total_edf"),
    "pdev": (),
}
#: largest factor at which the PDEV EDF sums every lag; above, the sum at this factor with
#: the same ratio of terms to factor (the normalised correlations converge in m / tau0)
_PDEV_EXACT_M: Final[int] = 128


def _options(stat: str, options: dict[str, Any]) -> tuple[bool, str]:
    """``(bias_correction, total_edf)`` from the keywords, checked (one-line errors)."""
    if stat not in _OPTIONS:
        raise AdavarInputError(
            f"unknown stat {stat!r} for adavar.stats.total_family: use {STATISTICS}"
        )
    unknown = sorted(set(options) - set(_OPTIONS[stat]))
    if unknown:
        raise AdavarInputError(
            f"{unknown[0]} does not apply to stat={stat!r}: drop it"
            + (f" (its options: {', '.join(_OPTIONS[stat])})" if _OPTIONS[stat] else "")
        )
    bias = options.get("bias_correction", True)
    if bias is None:
        bias = True
    if not isinstance(bias, (bool, np.bool_)):
        raise AdavarInputError(f"bias_correction must be True or False, got {bias!r}")
    method = str(options.get("total_edf", "sp1065") or "sp1065").lower()
    if method not in TOTAL_EDF_METHODS:
        raise AdavarInputError(
            f"unknown total_edf {options.get('total_edf')!r}: use one of {TOTAL_EDF_METHODS}"
        )
    return bool(bias), method


# ---------------------------------------------------------------------------------------
# the family's contract


def m_max(stat: str, n_points: int) -> int:
    """Largest averaging factor for ``n_points`` phase points (rates + 1).

    MTOT/TTOT: ``N / 3`` (one subsequence of ``3m`` phase points); HTOT: ``(N - 1) / 3``
    (one of ``3m`` rates); PDEV: ``(N - 1) / 2`` (``N - 2m >= 1`` terms).
    """
    _options(stat, {})
    n = int(n_points)
    if stat in ("mtotdev", "ttotdev"):
        return n // 3
    if stat == "htotdev":
        return (n - 1) // 3
    return (n - 1) // 2


def factors(stat: str, ms: np.ndarray) -> tuple[np.ndarray, tuple[str, ...]]:
    """Every averaging factor is usable: ``ms`` unchanged, no notes."""
    _options(stat, {})
    return np.asarray(ms, dtype=np.int64), ()


def squared(
    stat: str, u: np.ndarray, ms: np.ndarray, **options: Any
) -> tuple[np.ndarray, np.ndarray]:
    """The squared statistic at each factor for a sample interval of 1, and its term count.

    Parameters
    ----------
    stat : {"mtotdev", "ttotdev", "htotdev", "pdev"}
        The statistic.
    u : ndarray of float64
        Rate samples (or phase increments) at scale 1.
    ms : ndarray of int64
        Averaging factors, each within :func:`m_max`.
    **options
        ``bias_correction`` (bool, default True; MTOT/TTOT/HTOT) and ``total_edf`` (read by
        :func:`edf` only).

    Returns
    -------
    values, n : ndarray
        Variance of the rate (``ttotdev``: squared value in units of ``cumsum(u)``) and the
        number of terms: ``N - 3m + 1`` subsequences (MTOT/TTOT), ``N - 3m`` (HTOT; OHDEV's
        ``N - 3`` at ``m = 1``), ``N - 2m`` (PDEV), ``N`` phase points.
    """
    bias, _method = _options(stat, options)
    u = np.require(u, np.float64, ["C", "W"])
    ms = np.asarray(ms, dtype=np.int64)
    n_points = u.size + 1
    if ms.size and (ms.min() < 1 or ms.max() > m_max(stat, n_points)):
        raise AdavarInputError(
            f"averaging factors of {stat} must lie in 1 .. {m_max(stat, n_points)} for "
            f"{n_points} phase points: give shorter taus or a longer record"
        )
    values = np.empty(ms.size)
    counts = np.empty(ms.size, dtype=np.int64)
    if stat == "pdev":
        for k, m in enumerate(ms.tolist()):
            values[k], counts[k] = _pvar(u, m)
        return values, counts
    reversed_u = np.ascontiguousarray(u[::-1])
    for k, m in enumerate(ms.tolist()):
        if stat == "htotdev":
            values[k], counts[k] = _htot(u, reversed_u, m)
        else:
            values[k], counts[k] = _mtot(u, reversed_u, m)
    if bias:
        values = values / _bias(stat, u, ms)
    if stat == "ttotdev":
        values = values * ms.astype(np.float64) ** 2 / 3.0
    return values, counts


def edf(stat: str, alpha: int, m: int, n_points: int, **options: Any) -> float:
    """Equivalent degrees of freedom at one averaging factor (``>= 1``).

    ``total_edf="sp1065"`` (default) follows SP 1065; ``"stable32"`` reproduces the
    intervals Stable32 prints. ``T / tau`` is ``(N - 1) / m`` (the record's length) for
    ``"sp1065"`` and ``N / m`` (Stable32's ``N`` phase points) for ``"stable32"``.

    * ``mtotdev``, ``ttotdev`` (TTOT has MTOT's chi-square shape): ``b (T / tau) - c``,
      SP 1065 Table 8 (:data:`MTOT_EDF_SP1065`) for every noise type from white PM to
      random-walk FM (alpha outside -2 .. 2 clamped). ``"stable32"``: Howe's revised
      coefficients (:data:`MTOT_EDF_STABLE32`) for ``m > 8``, the MDEV EDF (Greenhall) up to
      ``m = 8``, as Stable32 does.
    * ``htotdev``: FM noise (alpha 0 .. -4), ``(T / tau) / (b0 + b1 tau / T)``
      (:data:`HTOT_EDF`, SP 1065 / Howe et al. 2000). PM noise has no published HTOT EDF:
      ``"sp1065"`` takes the OHDEV EDF (Greenhall), the Hadamard variance HTOT extends;
      it is conservative (a Monte Carlo of white PM, N = 512, m = 4 .. 64, gives HTOT 340 to
      370 degrees of freedom where OHDEV's are 160 to 220: intervals too wide, never too
      narrow). ``"stable32"`` takes the simple AVAR formulas of SP 1065 Table 5, as Stable32
      does for its Hadamard statistics at alpha 1 and 2 (at every ``m``). At ``m = 1`` the
      statistic is OHDEV and gets OHDEV's EDF. Stable32's intervals at ``m < 16`` come from
      an EDF it does not document (PHASE.DAT, white FM, m = 1 .. 8: this one's bounds are
      within 0.6 % of them).
    * ``pdev``: SP 1065 has no PVAR EDF. Here Greenhall's method (the one behind
      :func:`adavar.stats.edf.greenhall_edf`) applied to the PVAR filter itself
      (:func:`filter_edf`): ``edf = M / sum_j (1 - |j| / M) rho(j)^2`` over ``j <= 3m`` lags,
      ``rho`` the correlation of the PVAR terms under the power-law noise (Greenhall's generalised
      autocovariance of phase averaged over ``tau0``), exact for ``m <= 128`` and, above,
      the value at ``m = 128`` with the same ``M / m`` (converged: 1e-4 between 128 and 512).
      A Monte Carlo (N = 512, 1500 records, white PM, white and random-walk FM) agrees
      within its scatter at m = 16 and 64 and is 5 to 12 % higher at m = 4. At ``m = 1``:
      OADEV's EDF.
    """
    _bias_unused, method = _options(stat, options)
    alpha, m, n_points = int(alpha), int(m), int(n_points)
    if m < 1 or m > m_max(stat, n_points):
        raise AdavarInputError(
            f"averaging factor {m} is outside 1 .. {m_max(stat, n_points)} for {stat} on "
            f"{n_points} phase points: give shorter taus or a longer record"
        )
    if stat == "pdev":
        value = _pdev_edf(alpha, m, n_points)
    elif stat == "htotdev":
        value = _htot_edf(alpha, m, n_points, method)
    else:
        value = _mtot_edf(alpha, m, n_points, method)
    return max(float(value), edf_mod.EDF_FLOOR) if math.isfinite(value) else edf_mod.EDF_FLOOR


# ---------------------------------------------------------------------------------------
# the sums


def _block(m: int) -> int:
    # about one subsequence length per block: the expansion's terms cancel by the square of
    # the block-to-subsequence ratio (measured: a few ulps at 3m, 1e-8 at 64 for m = 1)
    return 3 * m


def _total_sum(u: np.ndarray, reversed_u: np.ndarray, m: int, integrate: bool) -> float:
    """``sum_n sum_j D_j**2`` over every subsequence (see the kernel module)."""
    # read-only views, as every kernel sharing sample_median takes its samples: one version
    forward, middle = left_sums(read_only(u, np.float64), m, integrate, True, _block(m))
    backward, _ = left_sums(read_only(reversed_u, np.float64), m, integrate, False, _block(m))
    return max(forward + backward - 2.0 * middle, 0.0)


def _mtot(u: np.ndarray, reversed_u: np.ndarray, m: int) -> tuple[float, int]:
    n = u.size + 1 - 3 * m + 1
    return _total_sum(u, reversed_u, m, True) / (12.0 * float(m) ** 5 * n), n


def _htot(u: np.ndarray, reversed_u: np.ndarray, m: int) -> tuple[float, int]:
    if m == 1:  # OHDEV: third differences of phase, second differences of the rate
        d = np.diff(np.diff(u))  # differences of floats round relative to the result
        n = u.size - 2
        return float(np.dot(d, d)) / (6.0 * n), n
    n = u.size - 3 * m + 1
    return _total_sum(u, reversed_u, m, False) / (36.0 * float(m) ** 3 * n), n


def _pvar(u: np.ndarray, m: int) -> tuple[float, int]:
    if m == 1:  # OADEV (the parabolic weights vanish)
        d = np.diff(u)
        n = u.size - 1
        return float(np.dot(d, d)) / (2.0 * n), n
    n = u.size + 1 - 2 * m
    total = pvar_sums(read_only(u, np.float64), m, max(2 * m, MIN_BLOCK))
    return 72.0 * total / (n * float(m) ** 6), n


def _bias(stat: str, u: np.ndarray, ms: np.ndarray) -> np.ndarray:
    """The bias factor per factor, from the noise type identified by Stable32's rule."""
    from adavar._kernels import differences as diff
    from adavar.stats.statistics import record_noise_types

    dmax = 3 if stat == "htotdev" else 2
    phase = diff.anchored_phase(u, cluster_stats=True)
    alpha, _notes = record_noise_types(phase, ms, dmax, data_type="rate", noise_id="stable32")
    if stat == "htotdev":
        table, lo = HTOT_BIAS, -4
    else:
        table, lo = MTOT_BIAS, -2
    factor = np.array([table.get(min(max(int(a), lo), 2), 1.0) for a in alpha])
    if stat == "htotdev":
        factor[ms == 1] = 1.0  # OHDEV
    return factor


# ---------------------------------------------------------------------------------------
# EDF, one place per formula


def _mtot_edf(alpha: int, m: int, n_points: int, method: str) -> float:
    a = min(max(alpha, -2), 2)
    if method == "stable32":
        if m <= STABLE32_MTOT_MDEV_UP_TO:
            return edf_mod.edf("mdev", a, m, n_points)
        b, c = MTOT_EDF_STABLE32[a]
        return b * n_points / m - c
    b, c = MTOT_EDF_SP1065[a]
    return b * (n_points - 1) / m - c


def _htot_edf(alpha: int, m: int, n_points: int, method: str) -> float:
    a = min(max(alpha, -4), 2)
    if a > 0 and method == "stable32":
        return edf_mod.edf_simple_avar(a, m, n_points)
    if m == 1 or a > 0:
        return edf_mod.edf("ohdev", a, m, n_points)
    ratio = (n_points if method == "stable32" else n_points - 1) / m
    b0, b1 = HTOT_EDF[a]
    return ratio / (b0 + b1 / ratio)


def _pdev_edf(alpha: int, m: int, n_points: int) -> float:
    a = min(max(alpha, -2), 2)
    if m == 1:
        return edf_mod.edf("oadev", a, 1, n_points)
    terms = n_points - 2 * m
    if m > _PDEV_EXACT_M:
        terms = max(1, round(terms * _PDEV_EXACT_M / m))
        m = _PDEV_EXACT_M
    return _pvar_edf(a, m, terms)


def pvar_filter(m: int) -> np.ndarray:
    """Weights of one PVAR term on the phase: ``S_i = sum_a c[a] x[i + a]``, ``a < 2m``."""
    w = (m - 1) / 2.0 - np.arange(m)
    return np.concatenate((w, -w))


@lru_cache(maxsize=1 << 12)
def _pvar_edf(alpha: int, m: int, terms: int) -> float:
    return filter_edf(pvar_filter(m), alpha, terms, min(terms, 3 * m))


def filter_edf(c: np.ndarray, alpha: int, terms: int, lags: int) -> float:
    """EDF of the mean of ``terms`` squared outputs of the phase filter ``c`` (stride 1).

    Greenhall & Riley (2003), Eq. 10 with a general filter: ``edf = M / [rho_0^2 + 2
    sum_{0<j<J} (1 - j/M) rho_j^2 + (1 - J/M) rho_J^2]``, ``J = lags``, ``rho_j`` the
    correlation of outputs ``j`` samples apart under power-law noise ``alpha``, from the
    phase autocovariance ``sx(k) = 2 sw(k) - sw(k - 1) - sw(k + 1)`` (phase averaged over
    ``tau0``, Greenhall's model for unmodified variances; ``sw`` of
    :func:`adavar.stats.edf.greenhall_sw`). With the Allan filter ``[1, -2, 1]`` at lag ``m`` it is
    :func:`adavar.stats.edf.greenhall_edf` for the overlapping ADEV whenever that sums explicitly.
    """
    c = np.asarray(c, dtype=np.float64)
    size = c.size
    auto = np.correlate(c, c, "full")  # lags -(size-1) .. size-1
    k = np.arange(-size, lags + size + 1, dtype=np.float64)
    sw = edf_mod.greenhall_sw
    sx = 2.0 * sw(k, alpha) - sw(k - 1.0, alpha) - sw(k + 1.0, alpha)
    # cov(j) = sum_d auto(d) sx(j + d): a sliding dot product over the lags
    cov = np.correlate(sx, auto, "valid")[1 : lags + 2]
    rho2 = (cov / cov[0]) ** 2
    j = np.arange(lags + 1)
    weights = 2.0 * (1.0 - j / terms)
    weights[0] = 1.0
    weights[-1] = 1.0 - lags / terms
    return float(terms / np.dot(weights, rho2))

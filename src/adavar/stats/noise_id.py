"""Power-law noise identification (NIST SP 1065 section 5.6, the Stable32 policy).

Split out of :mod:`adavar.stats.edf`, which re-exports every public name, so
``from adavar.stats.edf import identify_noise`` keeps working.

The policy, per averaging factor ``m`` with ``n = floor((N_phase - 1) / m)`` clusters:

* ``n >= MIN_POINTS_LAG1`` (30): the lag-1 autocorrelation method (Riley & Greenhall 2004).
  It starts, as SP 1065 prescribes for phase data, on the decimated phase ``x[::m]`` --
  for rate data too, integrated to their phase (``noise_id="input"`` starts rate data on
  the m-averaged rate, as adavar did before 0.2; a noise then got another type and EDF
  as rate data than as phase data) --
  (quadratically detrended): white PM stops there at ``d = 0`` with ``alpha ~ 2``. Only if
  that phase is too red (``delta >= 0.25``) does it go on to differences, which are the
  (linearly detrended) m-cluster sums, i.e. the rate path with one difference fewer.
  Starting on the rate instead puts white PM at ``r1 = -1/2``, the pole of
  ``delta = r1 / (1 + r1)``: alphas of 3..6 in a third of the records at 64 clusters.
* ``MIN_POINTS_B1 <= n < 30``: the Barnes B1 ratio, with the R(n) = MVAR / AVAR ratio
  deciding between white PM, flicker PM and white FM when B1 says "PM" (SP 1065 5.5.5).
* fewer: not identified (the caller takes the neighbouring tau's type).

Every returned alpha is clamped to the statistic's range (:func:`clamp_alpha`).
"""

from __future__ import annotations

import functools
import itertools
import math
from typing import Final

import numpy as np

from adavar._kernels._jit import jit, threaded_jit
from adavar._kernels.decimated_phase import (  # noqa: F401 - phase_* re-exported
    decimated_phase_lag1,
    decimated_phase_stats,
    fused_phase_levels,
    phase_lag1_result,
    phase_moments,
    phase_residual_lag,
    quadratic_fit,
)
from adavar._kernels.differences import AnchoredPhase, cluster_differences, cluster_lag1_sums
from adavar.stats.record_sums import modified_sums, overlapping_sums

__all__ = [
    "AVERAGED_FM_BOUNDS",
    "AVERAGED_FM_DELTAS",
    "MIN_POINTS_B1",
    "MIN_POINTS_LAG1",
    "NOISE_ID_RULES",
    "RN_WHITE_FM",
    "NoiseIdError",
    "alpha_from_lag1",
    "alpha_from_phase_lag1",
    "avar_of_sum",
    "averaged_rule",
    "b1_rn_alpha",
    "b1_with_rn",
    "clamp_alpha",
    "decimated_phase_lag1",
    "fill_unidentified",
    "identify_noise",
    "identify_noise_b1",
    "identify_noise_lag1",
    "lag1_decision",
    "mvar_of_sum",
    "pm_with_rn",
    "rate_noise_types",
    "rn_decision",
    "rn_ratio",
    "rn_theory_pm",
    "rn_value",
    "rn_wanted",
    "starts_on_phase",
]

#: Default minimum series length for the lag-1 ACF method (Riley & Greenhall 2004: "about 30").
MIN_POINTS_LAG1: Final[int] = 30

#: Default minimum number of frequency (rate) values for the B1-ratio method. Below ~10 the
#: sample B1 ratio has a relative scatter comparable to the spacing of the theoretical values
#: of adjacent noise types, so reusing a neighbouring tau's noise type is the better guess.
MIN_POINTS_B1: Final[int] = 10

#: Expected R(n) = MVAR / AVAR of white FM for m >> 1 (SP 1065 5.5.5: 0.50).
RN_WHITE_FM: Final[float] = 0.5

#: Expected lag-1 ``delta = r1 / (1 + r1)`` of the rate averaged over ``m >> 1`` samples and
#: differenced once: white FM -1 (r1 = -1/2), flicker FM -0.277 (r1 = (9 ln 3 - 16 ln 2) /
#: (8 ln 2)), random-walk FM 0.2 (r1 = 1/4), from the second differences of the phase at
#: spacing m. Averaging makes the redder two whiter than the fractional-difference values
#: (-1/2, 0) that R&G's rounding of ``2 delta`` assumes: flicker FM then lies next to the
#: boundary -0.25 and read as random-walk FM in 30-40 % of the records at m = 8-64 (intervals
#: covering 74-77 %). Within 0.06 of these from m = 4 on (m = 2: -0.33, 0.14).
_R1_FLICKER_FM: Final = (9.0 * math.log(3.0) - 16.0 * math.log(2.0)) / (8.0 * math.log(2.0))
AVERAGED_FM_DELTAS: Final = (-1.0, _R1_FLICKER_FM / (1.0 + _R1_FLICKER_FM), 0.2)
#: the boundaries used (``averaged=True``): the midpoints of :data:`AVERAGED_FM_DELTAS`
AVERAGED_FM_BOUNDS: Final = (
    0.5 * (AVERAGED_FM_DELTAS[0] + AVERAGED_FM_DELTAS[1]),
    0.5 * (AVERAGED_FM_DELTAS[1] + AVERAGED_FM_DELTAS[2]),
)

#: a lag-1 residual whose RMS is below this times the raw series' largest magnitude is
#: rounding, not noise (``alpha_from_lag1``)
_RESIDUAL_FLOOR: Final = float(1e3 * np.finfo(np.float64).eps)

_DATA_TYPES: Final[dict[str, str]] = {
    "phase": "phase",
    "rate": "freq",
    "freq": "freq",
    "frequency": "freq",
}


class NoiseIdError(ValueError):
    """The power-law noise type cannot be identified from this series.

    Raised when the series is too short for either method or degenerate (constant); the
    caller is expected to reuse the noise type of a neighbouring averaging time.
    """


def clamp_alpha(alpha: float, dmax: int) -> int:
    """``alpha`` rounded into the valid range: ``[-2, 2]`` (Allan, ``dmax <= 2``) or
    ``[-4, 2]`` (Hadamard, ``dmax = 3``).

    Nothing is bluer than white PM, and the Allan family cannot tell alpha < -2 from -2
    (its variance diverges there); the lag-1 rule can return values outside (up to 6 for
    white PM identified on the rate), which would otherwise be handed to the EDF.
    """
    lo = -4 if int(dmax) >= 3 else -2
    return int(min(max(int(alpha), lo), 2))


def _data_type(data_type: str) -> str:
    try:
        return _DATA_TYPES[data_type.lower()]
    except (KeyError, AttributeError):
        raise ValueError(
            f"data_type must be 'phase' or 'rate' (alias 'freq'), got {data_type!r}"
        ) from None


def _as_series(z: np.ndarray) -> np.ndarray:
    z = np.asarray(z, dtype=np.float64)
    if z.ndim != 1:
        raise ValueError(f"z must be a 1-D series, got shape {z.shape}")
    if not np.isfinite(z).all():
        raise ValueError("z contains non-finite values")
    return z


def detrend_poly(z: np.ndarray, deg: int) -> np.ndarray:
    """Residual of a least-squares polynomial fit (on a [-1, 1] abscissa, well conditioned)."""
    t = np.linspace(-1.0, 1.0, z.size)
    coef = np.polynomial.polynomial.polyfit(t, z, deg)
    return z - np.polynomial.polynomial.polyval(t, coef)


def identify_noise_lag1(
    z: np.ndarray,
    *,
    data_type: str,
    dmin: int = 0,
    dmax: int = 2,
    min_points: int = MIN_POINTS_LAG1,
    averaged: bool = False,
) -> tuple[int, float]:
    """Power-law noise type from the lag-1 autocorrelation (Riley & Greenhall 2004).

    Parameters
    ----------
    z : ndarray
        The series prepared for one averaging factor ``m``: for ``data_type="phase"`` the
        phase decimated by ``m`` (``x[::m]``), for ``"rate"``/``"freq"`` the rate averaged
        over non-overlapping groups of ``m``.
    data_type : {"phase", "rate", "freq"}
        ``"rate"`` and ``"freq"`` are synonyms (fractional frequency / sensor rate).
    dmin, dmax : int
        Minimum and maximum number of differences taken. ``dmax`` bounds the reddest type
        that can be recognised: on phase, 2 reaches random-walk FM (Allan), 3 random-run FM
        (Hadamard); on rate data one difference fewer suffices for the same alpha.
    min_points : int
        Shortest series accepted (the method is reliable from about 30 points).
    averaged : bool
        Rate data averaged over ``m >= 2`` samples: once differenced, white, flicker and
        random-walk FM are told apart at :data:`AVERAGED_FM_BOUNDS` (default False:
        Riley & Greenhall's rounding).

    Returns
    -------
    alpha_int : int
        The estimate rounded to the nearest integer (``p = -2 (delta + d)`` rounded as
        ``-round(2 delta) - 2 d``, plus 2 for phase data).
    alpha : float
        The un-rounded estimate.

    Raises
    ------
    NoiseIdError
        Too few points, or a degenerate (constant) series.

    Notes
    -----
    The series is detrended first (quadratic for phase: frequency offset and drift; linear
    for rate: drift). Then, with ``d = 0``: compute the lag-1 autocorrelation ``r1`` and
    ``delta = r1 / (1 + r1)``; if ``d >= dmin`` and (``delta < 0.25`` or ``d >= dmax``)
    stop with ``p = -2 (delta + d)``, otherwise difference the series and repeat. ``delta``
    estimates the fractional-integration order of the differenced series, which is
    stationary once ``delta < 0.25`` (PSD exponent of phase, ``beta = alpha - 2``, above
    -0.5). Same algorithm as ``allantools.ci.autocorr_noise_id`` minus its decimation step.
    """
    kind = _data_type(data_type)
    dmin, dmax = int(dmin), int(dmax)
    if not 0 <= dmin <= dmax:
        raise ValueError(f"need 0 <= dmin <= dmax, got dmin={dmin}, dmax={dmax}")
    x = _as_series(z)
    # a quadratic detrend and dmax differences need a few points even if min_points is tiny
    need = max(int(min_points), dmax + 4)
    if x.size < need:
        raise NoiseIdError(f"lag-1 ACF noise identification needs >= {need} points, got {x.size}")
    scale = float(np.max(np.abs(x)))
    sizes = x.size - np.arange(dmax + 1)
    x = detrend_poly(x, 2 if kind == "phase" else 1)
    r1 = np.full(dmax + 1, np.nan)
    den = np.zeros(dmax + 1)
    for d in range(dmax + 1):
        c = x - x.mean()
        den[d] = float(np.dot(c, c))
        if den[d] > 0:
            r1[d] = float(np.dot(c[:-1], c[1:])) / den[d]
        x = np.diff(x)
    return alpha_from_lag1(
        r1, den, sizes, scale, data_type=kind, dmin=dmin, dmax=dmax, averaged=averaged
    )


def alpha_from_lag1(
    r1: np.ndarray,
    den: np.ndarray,
    sizes: np.ndarray,
    scale: float,
    *,
    data_type: str,
    dmin: int = 0,
    dmax: int = 2,
    averaged: bool = False,
) -> tuple[int, float]:
    """Riley & Greenhall's decision rule, given the lag-1 autocorrelations per difference order.

    Parameters
    ----------
    r1, den, sizes : ndarray
        For ``d = 0..dmax`` differences of the detrended series: the lag-1 autocorrelation,
        its denominator ``sum (x - mean)^2`` and the series length.
    scale : float
        Magnitude of the raw series: a residual at its rounding level (a constant or a pure
        polynomial trend) is not noise and would give a random ``r1``.
    data_type, dmin, dmax
        As in :func:`identify_noise_lag1`.
    averaged : bool
        The series is rate averaged over ``m >= 2`` samples: once differenced, white,
        flicker and random-walk FM are told apart at :data:`AVERAGED_FM_BOUNDS`
        (:func:`lag1_decision`; :func:`averaged_rule` says when).

    Returns
    -------
    alpha_int, alpha : int, float
        As in :func:`identify_noise_lag1`.
    """
    kind = _data_type(data_type)
    offset = 2 if kind == "phase" else 0  # alpha = beta + 2 for phase data
    status, alpha_int, alpha = lag1_decision(
        r1, den, sizes, scale, offset, int(dmin), int(dmax), bool(averaged)
    )
    if status == _NO_NOISE:
        raise NoiseIdError("no noise left after removing the trend: cannot identify it")
    if status == _ALTERNATING:
        raise NoiseIdError("lag-1 autocorrelation is -1: series is not power-law noise")
    return alpha_int, alpha


#: :func:`lag1_decision`'s status codes besides 0 (decided)
_NO_NOISE: Final = 1
_ALTERNATING: Final = 2


def lag1_decision(r1, den, sizes, scale, offset, dmin, dmax, averaged=False):
    """Riley & Greenhall's rule on indexable inputs: ``(status, alpha_int, alpha)``.

    The one implementation of :func:`alpha_from_lag1` (which raises where ``status`` is
    not 0: 1, no noise left after the trend; 2, ``r1 = -1``), written so that Numba
    compiles it too (:func:`_lag1_decision_compiled`, for :func:`rate_noise_types`).
    ``averaged``: the series are rate averaged over ``m >= 2`` samples (cluster means);
    once differenced, white, flicker and random-walk FM are then told apart at
    :data:`AVERAGED_FM_BOUNDS` instead of R&G's rounding of ``2 delta``.
    """
    floor = (_RESIDUAL_FLOOR * scale) ** 2
    for d in range(dmax + 1):
        if not den[d] > floor * sizes[d]:
            return _NO_NOISE, 0, math.nan
        if not r1[d] > -1.0:  # perfectly alternating series: delta = -inf
            return _ALTERNATING, 0, math.nan
        delta = r1[d] / (1.0 + r1[d])
        if d >= dmin and (delta < 0.25 or d >= dmax):
            alpha = -2.0 * (delta + d) + offset
            step = round(2.0 * delta)  # round() as np.rint: half to even
            if averaged and offset == 0 and d == 1 and delta < 0.25:
                if delta >= AVERAGED_FM_BOUNDS[1]:
                    step = 0  # random-walk FM
                elif delta >= AVERAGED_FM_BOUNDS[0]:
                    step = -1  # flicker FM
                else:
                    step = min(step, -2)  # white FM, or bluer
            return 0, offset - 2 * d - step, float(alpha)
    raise AssertionError("unreachable: d reaches dmax")  # pragma: no cover


def fill_unidentified(alpha: np.ndarray) -> tuple[np.ndarray, tuple[str, ...]]:
    """Per-tau alphas with NaN (not identified) replaced by the nearest identified one.

    Too few clusters at the longest taus is the usual reason. With none identified at all,
    white noise (alpha 0) is assumed and a note says so. Returns ``(alpha int64, notes)``.
    """
    if isinstance(alpha, list):  # the usual case: identified up to some tau, none beyond
        known = 0
        while known < len(alpha) and math.isfinite(alpha[known]):
            known += 1
        if known and not any(map(math.isfinite, alpha[known:])):
            filled = alpha[:known] + [alpha[known - 1]] * (len(alpha) - known)
            return np.array(filled, dtype=np.int64), ()
    alpha = np.array(alpha, dtype=np.float64)
    known = np.flatnonzero(np.isfinite(alpha))
    if known.size and known[-1] == known.size - 1:
        alpha[known.size :] = alpha[known.size - 1]
        return alpha.astype(np.int64), ()
    if known.size == 0:
        alpha[:] = 0.0
        return alpha.astype(np.int64), (
            "noise type could not be identified at any tau; white noise assumed for EDF",
        )
    # nearest identified tau by bisection (ties to the shorter tau): O(n log n) memory-free;
    # taus="all" on a long record has ~1e5 taus and as many identified ones
    index = np.arange(alpha.size)
    above = np.clip(np.searchsorted(known, index), 0, known.size - 1)
    below = np.clip(above - 1, 0, known.size - 1)
    take_below = np.abs(index - known[below]) <= np.abs(known[above] - index)
    nearest = np.where(take_below, known[below], known[above])
    return alpha[nearest].astype(np.int64), ()


def b1_theory(n: int, mu: float) -> float:
    """Barnes B1(N, r=1, mu): expected N-sample over 2-sample variance for AVAR ~ tau^mu.

    B1 = N (1 - N^mu) / (2 (N - 1) (1 - 2^mu)), with the limit N ln N / (2 (N-1) ln 2)
    at mu = 0 (SP 1065 5.5.4; Howe, Beard & Greenhall 2000, Table 3).
    """
    if mu == 0:
        return n * math.log(n) / (2.0 * (n - 1) * math.log(2.0))
    # float powers: C's pow() in Python and in Numba alike (n**mu of two ints is the same)
    return n * (1.0 - float(n) ** float(mu)) / (2.0 * (n - 1) * (1.0 - 2.0 ** float(mu)))


def rn_theory_pm(m: int) -> tuple[float, float]:
    """Expected R(n) = MVAR/AVAR for white PM (1/m) and flicker PM (f_h = 1/(2 tau0))."""
    white = 1.0 / m
    mvar = 3.0 * math.log(256.0 / 27.0) / (8.0 * math.pi**2)
    avar = (1.038 + 3.0 * math.log(2.0 * math.pi * 0.5 * m)) / (4.0 * math.pi**2)
    return white, mvar / avar


#: the B1 test's candidates from white-most to red-most, alpha and mu; B1(N, mu) increases
#: with mu
_B1_ALPHAS: Final = (1, 0, -1, -2)
_B1_MUS: Final = (-2, -1, 0, 1)

#: what :func:`_b1_series_alpha` returns for a constant series (no noise to identify)
_CONSTANT_SERIES: Final = 99


def _b1_series_alpha(y: np.ndarray, dmax: int) -> int:
    """B1 alpha of a finite rate series before R(n), or ``_CONSTANT_SERIES``.

    The alpha in {1 (PM), 0, -1, -2} whose B1(N, mu) is nearest (geometrically) to the
    data's. With ``dmax >= 3`` a random-walk FM or redder answer is tested again on the
    differenced rate, whose alpha is 2 higher (see :func:`identify_noise_b1`). NumPy
    throughout: it runs on tens of values (the taus too long for the lag-1 test), where a
    compiled version saves microseconds and costs seconds of compilation on a first run.
    """
    values = y
    for first in range(2):  # the series, then (dmax >= 3) its differences
        if first:
            values = values[1:] - values[:-1]
        n = values.size
        steps = values[1:] - values[:-1]
        avar = 0.5 * (np.add.reduce(steps * steps) / (n - 1))
        if not avar > 0.0:
            return _CONSTANT_SERIES
        centred = values - np.add.reduce(values) / n
        ratio = (np.add.reduce(centred * centred) / (n - 1)) / avar
        found = _B1_ALPHAS[0]
        for k, boundary in enumerate(_b1_boundaries(n)):
            if ratio <= boundary:
                break
            found = _B1_ALPHAS[k + 1]
        if first:  # differencing raised alpha by 2: RWFM -> 0, FWFM -> -1, RRFM -> -2
            return min(-2, found - 2)
        alpha = found
        if not (alpha == -2 and dmax >= 3):
            break
    return alpha


@functools.lru_cache(maxsize=256)
def _b1_boundaries(n: int) -> tuple[float, ...]:
    """The B1 ratios between adjacent noise types at ``n`` values: the geometric means of
    their B1(n, mu)."""
    theory = [b1_theory(n, mu) for mu in _B1_MUS]
    return tuple(math.sqrt(lo * hi) for lo, hi in itertools.pairwise(theory))


def b1_alpha(y: np.ndarray) -> int:
    """alpha in {1 (PM), 0, -1, -2} whose B1(N, mu) is nearest (geometrically) to the data's."""
    alpha = _b1_series_alpha(np.array(y, dtype=np.float64), 0)
    if alpha == _CONSTANT_SERIES:
        raise NoiseIdError("the series is constant: no noise to identify")
    return alpha


def identify_noise_b1(
    z: np.ndarray,
    *,
    data_type: str,
    dmax: int = 2,
    rn_ratio: float | None = None,
    m: int | None = None,
    min_points: int = MIN_POINTS_B1,
) -> int:
    """Power-law noise type from the Barnes B1 ratio (SP 1065 section 5.5.4).

    Parameters
    ----------
    z : ndarray
        Series prepared as for :func:`identify_noise_lag1`: rate averaged over groups of
        ``m`` (``data_type="rate"``/``"freq"``) or phase decimated by ``m`` (``"phase"``;
        converted here to the rate series by differencing, the scale does not matter).
    data_type : {"phase", "rate", "freq"}
        Interpretation of ``z``.
    dmax : int
        3 (Hadamard statistics) also recognises flicker-walk and random-run FM (alpha -3,
        -4); otherwise the reddest type returned is random-walk FM (-2).
    rn_ratio : float, optional
        ``R(n) = MVAR / AVAR`` at this tau (overlapping estimators, computed by the caller
        from the full-rate record). B1 cannot separate white from flicker PM (both have
        mu = -2); if given together with ``m >= 4``, R(n) decides whenever B1 says "PM"
        (SP 1065 5.5.5): white PM below the geometric mean of the two PM values
        (``1/m`` and ``3.37 / (1.04 + 3 ln(pi m))``), white FM above the geometric mean of
        the flicker PM value and white FM's 0.5, else flicker PM. The last rule catches
        white FM whose short-series B1 fell below the PM/white-FM boundary (about one
        record in four at 10-30 clusters); R(n) rests on thousands of overlapping terms.
    m : int, optional
        Averaging factor, needed with ``rn_ratio``.
    min_points : int
        Fewest rate values accepted (default :data:`MIN_POINTS_B1`).

    Returns
    -------
    int
        ``alpha``. For PM noise without a usable ``rn_ratio`` this is 1 (flicker PM), the
        safe guess: for the overlapping estimators its EDF is far smaller than white PM's
        (oadev, m=1024, N=241218: 2.9e3 vs 1.2e5), while for the non-overlapping ones the
        white PM EDF is the smaller by only 5-25%.

    Raises
    ------
    NoiseIdError
        Too few points or a constant series.

    Notes
    -----
    The observed ratio ``B1 = s^2 / AVAR`` (``s^2`` the unbiased sample variance of the N
    rate values, AVAR the non-overlapping Allan variance at this tau) is compared with
    ``B1(N, mu)`` for mu = -2 (PM), -1 (white FM), 0 (flicker FM), 1 (random-walk FM);
    the boundaries between adjacent types are the geometric means of their theoretical
    values (``mu = -alpha - 1`` for ``-2 <= alpha <= 0``).

    Beyond random-walk FM the rate is not stationary-increment and the formal B1(N, mu >= 2)
    extension does not describe it (random-run FM is then misread as flicker walk). So with
    ``dmax >= 3``, once the ratio says random-walk FM or redder, the test is repeated on the
    differenced rate, whose alpha is 2 higher (SP 1065 / Stable32 "B1 of frequency data
    as phase"), and 2 is subtracted.
    """
    kind = _data_type(data_type)
    x = _as_series(z)
    alpha = _b1_rate_alpha(np.diff(x) if kind == "phase" else x, dmax, min_points)
    if alpha == 1 and rn_ratio is not None:
        if m is None:
            raise ValueError("rn_ratio needs the averaging factor m")
        white, flicker = rn_theory_pm(int(m))
        alpha = rn_decision(1, rn_ratio, int(m), white, flicker, True)
    return alpha


def _b1_rate_alpha(y: np.ndarray, dmax: int, min_points: int = MIN_POINTS_B1) -> int:
    """B1 alpha of a finite rate series, before R(n) (:func:`identify_noise_b1`)."""
    n = y.size
    if n < max(int(min_points), 4):  # >= 3 values left after the dmax=3 difference
        raise NoiseIdError(f"B1 noise identification needs >= {min_points} rate values, got {n}")
    alpha = _b1_series_alpha(np.array(y, dtype=np.float64), int(dmax))
    if alpha == _CONSTANT_SERIES:
        raise NoiseIdError("the series is constant: no noise to identify")
    return alpha


def rn_wanted(alpha: int, m: int, strict: bool) -> bool:
    """Whether R(n) is consulted after B1 said ``alpha`` (see :func:`rn_decision`)."""
    return alpha == 1 or (alpha == 0 and m >= 4 and not strict)


def rn_decision(alpha: int, ratio: float, m: int, white: float, flicker: float, strict: bool):
    """B1's ``alpha`` as R(n) = ``ratio`` decides it (SP 1065 5.5.5, :func:`b1_with_rn`).

    ``white`` and ``flicker`` are :func:`rn_theory_pm` of ``m``. A B1 "PM" (1) becomes white
    PM (2), stays flicker PM or becomes white FM (0); unless ``strict``, a B1 white FM (0)
    whose R(n) lies among the PM values becomes white or flicker PM. Below ``m = 4`` MVAR
    is about AVAR for any noise and R(n) carries no information.
    """
    if alpha == 1:
        if m >= 4:
            if flicker > white and ratio < math.sqrt(white * flicker):
                return 2
            if flicker < RN_WHITE_FM and ratio > math.sqrt(flicker * RN_WHITE_FM):
                return 0
        return 1
    if alpha == 0 and m >= 4 and not strict:
        if ratio < math.sqrt(white * flicker):
            return 2
        if ratio < math.sqrt(flicker * RN_WHITE_FM):
            return 1
    return alpha


def identify_noise(
    z: np.ndarray,
    *,
    data_type: str,
    dmax: int = 2,
    min_points_lag1: int = MIN_POINTS_LAG1,
    min_points_b1: int = MIN_POINTS_B1,
    rn_ratio: float | None = None,
    m: int | None = None,
) -> int:
    """Noise type at one averaging time with the Stable32 policy.

    Lag-1 autocorrelation (:func:`identify_noise_lag1`, ``dmin=0``) when
    ``len(z) >= min_points_lag1``; otherwise the B1 ratio (:func:`identify_noise_b1`) when
    there are at least ``min_points_b1`` rate values (``len(z) - 1`` for phase input);
    otherwise :class:`NoiseIdError`, and the caller should reuse a neighbouring tau's type.

    Parameters
    ----------
    z : ndarray
        Series prepared for this tau (see :func:`identify_noise_lag1`).
    data_type : {"phase", "rate", "freq"}
        Interpretation of ``z``.
    dmax : int
        2 for the Allan family, 3 for the Hadamard statistics.
    min_points_lag1, min_points_b1 : int
        Length thresholds of the two methods.
    rn_ratio, m : optional
        Passed to :func:`identify_noise_b1` to separate white from flicker PM.

    Returns
    -------
    int
        ``alpha``, the rate-PSD exponent, clamped to the statistic's range
        (:func:`clamp_alpha`; before 0.x it was returned unclamped).
    """
    x = _as_series(z)
    if x.size >= min_points_lag1:
        alpha = identify_noise_lag1(
            x, data_type=data_type, dmin=0, dmax=dmax, min_points=min_points_lag1
        )[0]
    else:
        alpha = identify_noise_b1(
            x, data_type=data_type, dmax=dmax, rn_ratio=rn_ratio, m=m, min_points=min_points_b1
        )
    return clamp_alpha(alpha, dmax)


# ---------------------------------------------------------------------------------------------
# Lag-1 test on the decimated phase: its sums live in adavar._kernels.decimated_phase
# (phase_moments, phase_residual_lag, quadratic_fit, phase_lag1_result and
# decimated_phase_lag1 are imported here from there, where they were defined before)
# ---------------------------------------------------------------------------------------------


def phase_order0(r1: float, den: float, size: int, scale: float) -> float:
    """Order 0 of the lag-1 rule on the decimated phase: alpha (unclamped), NaN if undecided.

    Decided when the phase is noise (``den`` above the rounding floor), not alternating,
    and ``delta = r1 / (1 + r1) < 0.25`` (white or flicker PM); written so that Numba
    compiles it too (:func:`_rate_noise_kernel`).
    """
    floor = (_RESIDUAL_FLOOR * scale) ** 2
    if den > floor * size and r1 > -1.0:
        delta = r1 / (1.0 + r1)
        if delta < 0.25:
            return 2.0 - np.rint(2.0 * delta)
    return math.nan


def alpha_from_phase_lag1(
    phase_stats: tuple[float, float, int, float],
    rate_stats: tuple[np.ndarray, np.ndarray, np.ndarray, float] | None,
    *,
    dmax: int = 2,
    averaged: bool = False,
) -> int | None:
    """SP 1065 lag-1 rule for phase data: order 0 on the decimated phase, then the rate.

    Parameters
    ----------
    phase_stats : tuple
        ``(r1, den, size, scale)`` of :func:`decimated_phase_lag1`.
    rate_stats : tuple or None
        ``(r1, den, sizes, scale)`` of the linearly detrended cluster sums for difference
        orders ``0 .. dmax - 1`` (the phase's orders ``1 .. dmax``); ``None`` asks only
        whether order 0 decides (the return value is then ``None`` if it does not).
    dmax : int
        2 (Allan) or 3 (Hadamard).
    averaged : bool
        As in :func:`alpha_from_lag1`, for the rate orders.

    Returns
    -------
    int or None
        ``alpha`` clamped to the statistic's range.

    Raises
    ------
    NoiseIdError
        A degenerate series.
    """
    got = phase_order0(*phase_stats)
    if not math.isnan(got):
        return clamp_alpha(got, dmax)
    if rate_stats is None:
        return None
    r1s, dens, sizes, rscale = rate_stats
    alpha = alpha_from_lag1(
        r1s, dens, sizes, rscale, data_type="rate", dmax=r1s.size - 1, averaged=averaged
    )[0]
    return clamp_alpha(alpha, dmax)


# ---------------------------------------------------------------------------------------------
# R(n) alongside lag-1 and B1 (the in-memory and streamed drivers share these rules)
# ---------------------------------------------------------------------------------------------

#: noise identification rules of :func:`adavar.deviation` (``noise_id=``)
NOISE_ID_RULES = ("sp1065", "stable32", "input")


def avar_of_sum(total: float, m: int, terms: int) -> float:
    """The overlapping Allan variance from its sum of squared second differences of the
    phase: ``total / (2 m^2 n)`` (the R(n) drivers' one normalisation)."""
    return total / (2.0 * m * m * terms)


def mvar_of_sum(total: float, m: int, terms: int) -> float:
    """The modified Allan variance from its sum of squared m-sums: ``total / (2 m^4 n)``.

    ``m^4`` as ``float(m*m)**2`` rounds once, as the exact integer would, for ``m`` below
    9.4e7 (and does not overflow a compiled integer).
    """
    square = float(m * m)
    return total / (2.0 * (square * square) * terms)


def rn_value(avar: float, mvar: float) -> float:
    """R(n) = MVAR / AVAR, or NaN where it is undefined."""
    return mvar / avar if avar > 0 and math.isfinite(mvar) else math.nan


def rn_ratio(avar: float, mvar: float) -> float | None:
    """R(n) = MVAR / AVAR, or None where it is undefined."""
    ratio = rn_value(avar, mvar)
    return None if math.isnan(ratio) else ratio


def pm_with_rn(alpha: int, m: int, rn) -> int:
    """Lag-1 "white PM" checked by R(n) (SP 1065 5.5.5): flicker PM if R(n) says so.

    On short decimated phase series (tens of points, detrended) the lag-1 test reads
    flicker PM as white PM often (delta of the finite-filter flicker phase falls below
    0.25: coverage 31-58 % at m = 16-128, N = 4096); R(n) = MVAR/AVAR, from every
    overlapping term, separates the two by a factor ~m/8.
    """
    if alpha != 2 or m < 4:
        return alpha
    ratio = rn()
    if ratio is None:
        return alpha
    white, flicker = rn_theory_pm(m)
    return 1 if ratio > math.sqrt(white * flicker) else 2


def b1_with_rn(z: np.ndarray, m: int, dmax: int, rn, *, strict: bool = False) -> float:
    """B1 on the cluster means; R(n) (``rn()``, computed only if needed) splits PM / white FM.

    SP 1065 consults R(n) when B1 says PM; it is consulted here when B1 says white FM too,
    where a short-series B1 of PM noise lands as often (at 8-16 clusters, N = 4096: 15-20
    % of white or flicker PM records): R(n) of white FM (0.5) is far from both PM values.
    ``strict`` keeps to SP 1065 (and Stable32's tables): R(n) only where B1 says PM.
    """
    alpha = _b1_rate_alpha(_as_series(z), dmax)  # identify_noise_b1(z, data_type="rate")
    ratio = rn() if rn_wanted(alpha, m, strict) else None
    return b1_rn_alpha(alpha, m, dmax, ratio, strict=strict)


def b1_rn_alpha(alpha: int, m: int, dmax: int, ratio: float | None, *, strict: bool) -> int:
    """The last step of :func:`b1_with_rn`: B1's ``alpha`` as R(n) = ``ratio`` (None: not
    consulted or undefined) decides it (:func:`rn_decision`, which leaves the types R(n)
    is not asked about alone), clamped to the statistic's range."""
    if ratio is not None:
        white, flicker = rn_theory_pm(m)
        alpha = rn_decision(alpha, ratio, int(m), white, flicker, strict)
    return clamp_alpha(alpha, dmax)


# ---------------------------------------------------------------------------------------------
# The whole rule for rate data in memory, compiled (one call per record)
# ---------------------------------------------------------------------------------------------


def phase_order0_settled(r1, den, size, scale, tol_r1, tol_den) -> int:
    """Whether :func:`phase_order0` decides (1), does not (0) or may do either (-1), for
    statistics known to within bounds: ``r1`` to within ``tol_r1``, ``den`` to within
    ``tol_den * den``, and a ``scale`` at most ``scale``.

    Order 0 decides where the phase is noise (``den`` above the rounding floor), not
    alternating (``r1 > -1``) and ``delta = r1 / (1 + r1) < 0.25``, i.e. ``r1 < 1/3``.
    Written so that Numba compiles it too (:func:`_rate_noise_kernel`).
    """
    if not (tol_r1 < 0.5 and tol_den < 0.5):  # NaN too: nothing known
        return -1
    if not den * (1.0 - tol_den) > (_RESIDUAL_FLOOR * scale) ** 2 * size:
        return -1
    if r1 - tol_r1 > 1.0 / 3.0:
        return 0
    if r1 + tol_r1 < 1.0 / 3.0 and r1 - tol_r1 > -1.0:
        return 1
    return -1


#: Cluster sums that :func:`rate_noise_types`' passes over the data read (an estimate,
#: :func:`_passes_over_the_data`) from which its taus run on every thread: each tau is
#: an item, and below about 2 ms of work a thread's start costs more than it saves.
NOISE_THREADS_MIN: Final = 1 << 19

_lag1_decision_compiled = jit(lag1_decision)
_clamp_alpha_compiled = jit(clamp_alpha)
_phase_order0_compiled = jit(phase_order0)
_phase_order0_settled_compiled = jit(phase_order0_settled)


@jit
def _decimated_phase_alpha(r, hh, hl, m, count):  # pragma: no cover - compiled
    """:func:`phase_order0` of the decimated phase ``x[::m]`` (:func:`decimated_phase_lag1`)."""
    r1, den, scale = decimated_phase_stats(r, hh, hl, m, count)
    return _phase_order0_compiled(r1, den, count + 1, scale)


@threaded_jit
def _rate_noise_kernel(
    r, hh, hl, fused, phase_fused, ms, dmax, on_phase, averaged, out, on_decimated, lo, hi
):  # pragma: no cover - compiled
    """Taus ``lo .. hi-1``: the lag-1 alpha per ``m`` into ``out`` (NaN: not identified)
    and whether the decimated phase decided it into ``on_decimated``; see
    :func:`rate_noise_types`."""
    n_increments = r.size - 1
    r1 = np.empty(dmax + 1)
    den = np.empty(dmax + 1)
    sizes = np.empty(dmax + 1, np.int64)
    # phase first: the rate orders stop one short (the phase's orders 1 .. dmax)
    rate_orders = dmax - 1 if on_phase else dmax
    for t in range(lo, hi):
        m = ms[t]
        count = n_increments // m
        out[t] = math.nan
        on_decimated[t] = False
        if count < MIN_POINTS_LAG1:
            continue
        level = 0
        while (1 << level) < m:
            level += 1
        fused_level = (1 << level) == m
        if on_phase:
            # order 0 on the decimated phase, from the fused statistics where they settle
            # it, else from the two sequential passes over the data
            decides = -1
            if fused_level and level < phase_fused.shape[0]:
                row = phase_fused[level]
                decides = _phase_order0_settled_compiled(
                    row[0], row[1], count + 1, row[2], row[3], row[4]
                )
            if decides == 1:  # delta < 0.25 there: alpha >= 2, white PM once clamped
                out[t] = _clamp_alpha_compiled(2.0, dmax)
                on_decimated[t] = True
                continue
            if decides == -1:
                got = _decimated_phase_alpha(r, hh, hl, m, count)
                if not math.isnan(got):
                    out[t] = _clamp_alpha_compiled(got, dmax)
                    on_decimated[t] = True
                    continue
        # order 0 first (most taus stop there: delta < 0.25), from the moments gathered
        # while integrating where m is a usable fused level, else one pass over the data
        if fused_level and level < fused.shape[0] and fused[level, 3] > 0:
            r1[0], den[0], scale = fused[level, 0], fused[level, 1], fused[level, 2]
        else:
            r1_0, den_0, scale = cluster_lag1_sums(r, hh, hl, m, count, np.int64(0))
            r1[0], den[0] = r1_0[0], den_0[0]
        orders = np.int64(0)
        if not (r1[0] == -1.0 or r1[0] / (1.0 + r1[0]) < 0.25):  # r1 = -1 stops too
            r1_all, den_all, scale = cluster_lag1_sums(r, hh, hl, m, count, rate_orders)
            for d in range(rate_orders + 1):
                r1[d], den[d] = r1_all[d], den_all[d]
            orders = rate_orders
        for d in range(orders + 1):
            sizes[d] = max(count - d, 0)
        status, alpha, _ = _lag1_decision_compiled(
            r1, den, sizes, scale, np.int64(0), np.int64(0), orders, averaged and m >= 2
        )
        if status == 0:
            out[t] = _clamp_alpha_compiled(float(alpha), dmax)


def _passes_over_the_data(
    ms: np.ndarray, n_increments: int, fused_levels: int, settled: list[int], on_phase: bool
) -> int:
    """The clusters :func:`_rate_noise_kernel` reads at most, tau by tau: the decimated
    phase's two passes where the fused statistics do not settle order 0, the rate's where
    ``m`` is not a fused level (a work estimate for the thread choice)."""
    work = 0
    for m in ms.tolist():
        count = n_increments // m
        if count < MIN_POINTS_LAG1:
            continue
        level = m.bit_length() - 1
        fused = m == 1 << level and level < fused_levels
        if on_phase and not (fused and level < len(settled) and settled[level] >= 0):
            work += 2 * count
        if not fused:
            work += 2 * count
    return work


def rate_noise_types(
    phase: AnchoredPhase,
    ms: np.ndarray,
    dmax: int,
    *,
    avar: np.ndarray | None = None,
    strict: bool = False,
    on_phase: bool = False,
    averaged: bool = False,
) -> list[float]:
    """Alpha per averaging factor of a record in memory, NaN where none is identified.

    The rule of :func:`identify_noise` on the record integrated in ``phase``
    (:func:`adavar._kernels.differences.anchored_phase`), every lag-1 tau in one compiled call: with
    at least :data:`MIN_POINTS_LAG1` clusters, ``on_phase`` first the decimated phase
    (:func:`phase_order0`; a "white PM" there checked by R(n), :func:`pm_with_rn`; where
    ``m`` is a fused level, from the integration's moments when their bounds settle the
    decision the sequential passes would reach, :func:`phase_order0_settled`, else from
    those passes, :mod:`adavar._kernels.decimated_phase`), then
    the lag-1 rule on the linearly detrended cluster sums (:func:`lag1_decision`; order 0
    from the moments gathered while integrating where ``m`` is a fused level, other orders
    only when order 0 does not decide; up to ``dmax - 1`` differences ``on_phase``, else
    ``dmax``); with at least :data:`MIN_POINTS_B1` the B1 ratio with R(n) as
    :func:`b1_with_rn` consults it (``strict``: only where B1 says PM), in NumPy on the
    few taus concerned. The integrated record is the phase whichever input carried it, so
    phase data and the rate data ``diff(x) / tau0`` of the same phase get the same types.
    ``averaged`` tells FM types apart on the averaged rate as :func:`averaged_rule` says.
    ``avar``, if given, is the overlapping Allan variance at every ``m`` (R(n) then
    reuses it). Each alpha is clamped to the statistic's range; NaN are left for
    :func:`fill_unidentified`. The taus run on every thread when the passes over the
    data read :data:`NOISE_THREADS_MIN` cluster sums or more; the result does not depend
    on the thread count (each tau is computed the same way on any thread).
    """
    fused = phase.fused if phase.fused is not None else np.empty((0, 4))
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    if avar is not None and len(avar) != len(ms):
        raise ValueError("internal: avar must give one value per averaging factor")
    phase_fused = fused_phase_levels(phase) if on_phase else None
    if phase_fused is None:
        phase_fused = np.empty((0, 5))
    n_increments = phase.n_points - 1
    work = 0  # (at most 4 passes over each tau's clusters: a short record has no need)
    if 4 * n_increments * ms.size >= NOISE_THREADS_MIN:
        settled = [
            phase_order0_settled(*row[:2], (n_increments >> lev) + 1, *row[2:])
            for lev, row in enumerate(phase_fused.tolist())
        ]
        work = _passes_over_the_data(ms, n_increments, fused.shape[0], settled, on_phase)
    values = np.empty(ms.size)
    on_decimated = np.zeros(ms.size, dtype=np.bool_)
    if ms.size:
        _rate_noise_kernel.run(
            work if work >= NOISE_THREADS_MIN else 0, ms.size, phase.r, phase.hh,
            phase.hl, fused, phase_fused, ms, int(dmax), bool(on_phase), bool(averaged),
            values, on_decimated,
        )  # fmt: skip
    out = values.tolist()
    n_points = phase.n_points
    b1: dict[int, int] = {}  # tau index -> B1 alpha, on the taus too long for lag-1
    for t, m in enumerate(ms.tolist()):
        count = (n_points - 1) // m
        if MIN_POINTS_B1 <= count < MIN_POINTS_LAG1:
            z = cluster_differences(phase.r, phase.hh, phase.hl, m, count)
            try:
                b1[t] = _b1_rate_alpha((z + phase.shift * m) / m, int(dmax))  # cluster means
            except NoiseIdError:  # a constant series: nothing to identify
                continue
    # R(n) where B1 or a decimated-phase "white PM" wants it, in one pass of each kernel
    asked = [t for t, alpha in b1.items() if rn_wanted(alpha, int(ms[t]), strict)]
    white_pm = [t for t in np.flatnonzero(on_decimated).tolist() if out[t] == 2 and ms[t] >= 4]
    ratios: dict[int, float | None] = {}
    if asked or white_pm:
        wanted = asked + white_pm
        m_asked = ms[wanted]
        sums = overlapping_sums(phase, m_asked, 2) if avar is None else None
        mod, counts = modified_sums(phase, m_asked)
        for k, t in enumerate(wanted):
            m = int(ms[t])
            if sums is None:
                var = float(avar[t])
            else:
                var = avar_of_sum(float(sums[k]), m, n_points - 2 * m)
            ratios[t] = rn_ratio(var, mvar_of_sum(float(mod[k]), m, int(counts[k])))
    for t, alpha in b1.items():
        out[t] = float(b1_rn_alpha(alpha, int(ms[t]), int(dmax), ratios.get(t), strict=strict))
    for t in white_pm:
        out[t] = float(pm_with_rn(2, int(ms[t]), lambda t=t: ratios[t]))
    return out


def averaged_rule(noise_id: str, m: int) -> bool:
    """Whether the lag-1 rule at averaging factor ``m`` tells white, flicker and random-walk
    FM apart at the averaged rate's boundaries (:data:`AVERAGED_FM_BOUNDS`): with
    ``noise_id="sp1065"`` and ``m >= 2``; ``"input"`` and ``"stable32"`` round ``2 delta``
    as Riley & Greenhall do (adavar before 0.2)."""
    return noise_id == "sp1065" and int(m) >= 2


def starts_on_phase(data_type: str, noise_id: str) -> bool:
    """Whether the lag-1 test starts on the decimated phase (:data:`NOISE_ID_RULES`).

    ``"sp1065"``: always, the rate record being integrated to its phase (the noise, not the
    input type, decides: flicker PM as rate data was read as white PM in half the records
    at m = 16-128 when the test started on the m-averaged rate); ``"input"``: for phase
    data only (adavar before); ``"stable32"``: never.
    """
    if noise_id == "stable32":
        return False
    return noise_id != "input" or _data_type(data_type) == "phase"

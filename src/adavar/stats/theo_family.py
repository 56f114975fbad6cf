"""Theo1, ThêoBR and ThêoH (NIST SP 1065 sections 5.2.15-5.2.17), for :func:`adavar.deviation`.

This is a family module of :mod:`adavar.core.extended_statistics` (``squared``, ``m_max``,
``factors``, ``edf``). All three are frequency-like deviations (units of the rate samples,
like ADEV).

``theo1`` (Howe & Tasset; SP 1065 Eq. 30): for an even averaging factor ``m``,
``2 <= m <= N - 1`` (``N`` phase points),

    Theo1(m) = 1 / (0.75 (N - m) (m tau0)^2) * sum_{i=1}^{N-m} sum_{delta=0}^{m/2-1}
               [(x_i - x_{i-delta+m/2}) + (x_{i+m} - x_{i+delta+m/2})]^2 / (m/2 - delta),

and it belongs to the averaging time **tau = 0.75 m tau0**, not ``m tau0``: it matches the
Allan variance at that tau for white FM. The factors asked for (``taus`` in seconds are read
as ``m tau0``, as for every statistic) must be even: an odd ``m`` is moved up to ``m + 1``
(``m_max`` is even, so this never leaves the range) and a note says so. ``n`` is the number
of squared terms, ``(N - m) m / 2`` (Stable32's "#" column).

``theobr`` (bias-removed Theo1, SP 1065 Eq. 33): Theo1 times the record's bias ratio

    kf = 1/(n+1) sum_{i=0}^{n} AVAR(m = 9 + 3i) / Theo1(m = 12 + 4i),  n = floor(N/6 - 3),

where AVAR is the overlapping Allan variance and each pair is at the same tau
(``(9 + 3i) tau0 = 0.75 (12 + 4i) tau0``), from ``9 tau0`` up to ``N/2 tau0``, the longest
Allan tau. A pair whose AVAR has no term (``N`` a multiple of 6 at ``i = n``) is left out of
the average. ThêoBR needs ``N >= 18``. It is an estimate of the Allan variance at
``0.75 m tau0`` whatever the noise type; Stable32's "Thêo1" with bias removal on
(``phase_dat_theo1.txt``) prints exactly this (``kf = 0.60279`` on PHASE.DAT).

``theoh`` (hybrid, SP 1065 Eq. 34) is given on the Allan grid, ``tau = m tau0``: the
overlapping AVAR for ``m < k`` and ThêoBR at the Theo1 factor ``4m/3`` (the same tau) for
``m >= k``, where ``k = floor(0.1 (N - 1))`` is the largest factor within 10 % of the
record span ``T = (N - 1) tau0``. So that ``4m/3`` is an even integer, ThêoH is computed at
multiples of 3 from ``m = 3`` on: any other ``m >= 3`` is moved to the nearest multiple of 3
(a note says so); ``m = 1, 2`` are always AVAR. ``m_max`` is the largest multiple of 3 with
``4m/3 <= N - 1`` (tau up to 75 % of the record).

Computation (:func:`theo1_double_sums`): two kernels of
:mod:`adavar._kernels.theo_family`, whichever its cost model says is cheaper for the
factors asked for. The exact one, ``theo1_sums``, works on window sums of the increments
(Theo1 is blind to a frequency offset; the kernel never forms it) in ``sum_m (N - m) m / 2``
multiply-adds: O(N m) per tau, the cheaper for a few short factors. The all-tau one,
``theo1_fast_sums`` (after J. A. Lewis, IEEE TUFFC 2020), expands the square into lag
products of the phase, centred and kept in double-double, and steps from one factor to the
next in O(m): O(N) per tau, every even factor of 2e4 points in about 0.25 s (the exact
kernel: about 5 minutes); octave taus on 2e4 points cost about 0.15 s either way. It bounds
its own error at every factor and hands any factor whose bound exceeds ``FAST_TOLERANCE``
(2^-36 relative) to the exact kernel (on 2e4 points of a drift or a random run of
frequency: m = 2). Both are within a few ulps of exact rational arithmetic, the all-tau one
usually within one (it sums in double-double throughout); they agree to ~1e-14 on offsets
of 1e9, drifts, steps and random walks of frequency. ThêoBR's exact bias ratio needs
Theo1 at ``N/6`` factors up to ``2N/3``: one all-tau pass, shared with the factors asked
for (2e4 points: about 0.13 s with the Allan variances, which come from
:mod:`adavar._kernels.differences`; the exact kernel alone: about 2 minutes).

EDF (``edf``): Theo1 uses SP 1065's empirical formulas (Table 9, Howe & Tasset 2004), in
terms of ``N`` and ``r = 0.75 m`` (the Theo1 tau in units of tau0), floored at 1:

* white PM (alpha 2): ``0.86 (N+1)(N - 4r/3) / (N - r) * r / (r + 1.14)``
* flicker PM (1): ``(4.798 N^2 - 6.374 N r + 12.387 r) / (sqrt(r + 36.6) (N - r)) * r / (r + 0.3)``
* white FM (0): ``((4.1 N + 0.8)/r - (3.1 N + 6.5)/N) * r^1.5 / (r^1.5 + 5.2)``
* flicker FM (-1): ``(2 N^2 - 1.3 N r - 3.5 r) / (N r) * r^3 / (r^3 + 2.3)``
* random-walk FM (-2): ``(4.4 N - 2)/(2.9 r) * ((4.4N - 1)^2 - 8.6 r (4.4N - 1) + 11.4 r^2)
  / (4.4 N - 3)^2``

(alpha clamped to ``[-2, 2]``). ``r`` is the Theo1 tau in tau0 units, not ``T/tau``: a
Monte Carlo check (600 records of 1024 points, ``2 E[v]^2 / Var[v]`` at m = 10, 64, 256,
700) gave 724, 779, 736, 540 for white PM (formula 763, 847, 809, 571), 434, 81, 20, 5.3
for white FM (444, 83, 19, 4.9) and 190, 25, 6.2, 1.5 for random-walk FM (204, 30, 5.3,
1.0). ThêoBR takes Theo1's EDF: ``kf`` is averaged over about
``N/6`` ratios and is treated as exact (its own scatter is not in the interval). ThêoH takes
the overlapping-ADEV EDF (:func:`adavar.stats.edf.edf`) on its AVAR part and Theo1's EDF at
``4m/3`` on its ThêoBR part. Stable32's tables print no Theo1 bounds, so there is no
Stable32 convention to offer.

References
----------
D. A. Howe and T. K. Peppler, "Very long-term frequency stability: estimation using a
special-purpose statistic", Proc. 2003 FCS. D. A. Howe and T. N. Tasset, "Thêo1:
characterization of very long-term frequency stability", Proc. 2004 EFTF. D. A. Howe,
J. McGee-Taylor and T. Tasset, "ThêoH bias-removal method", Proc. 2006 FCS. W. J. Riley,
NIST SP 1065 (2008), sections 5.2.15-5.2.17.
"""

from __future__ import annotations

import math

import numpy as np

from adavar._kernels import differences as diff
from adavar._kernels._jit import read_only
from adavar._kernels.theo_family import centred_phase, theo1_fast_sums, theo1_sums
from adavar.core.errors import AdavarInputError
from adavar.stats import edf as edf_mod
from adavar.stats import record_sums

__all__ = [
    "FAST_TOLERANCE",
    "STATS",
    "edf",
    "factors",
    "m_max",
    "ratio_factors",
    "squared",
    "theo1_double_sums",
    "theo1_edf",
    "theobr_ratio",
]

STATS = ("theo1", "theobr", "theoh")
#: fewest phase points with a ThêoBR bias ratio (n = floor(N/6 - 3) >= 0)
MIN_POINTS_THEOBR = 18
#: relative error bound the all-tau Theo1 must guarantee at a factor, else it is recomputed
#: by the exact kernel there
FAST_TOLERANCE = 2.0**-36


def _check(stat: str) -> None:
    if stat not in STATS:
        raise AdavarInputError(f"unknown Theo-family stat {stat!r}: use one of {STATS}")


def m_max(stat: str, n_points: int) -> int:
    """Largest averaging factor for ``n_points`` phase points (see the module docstring)."""
    _check(stat)
    if stat == "theoh":
        return 3 * ((n_points - 1) // 4)
    top = n_points - 1
    return top - (top % 2)


def factors(stat: str, ms: np.ndarray) -> tuple[np.ndarray, tuple[str, ...]]:
    """Move the factors to the ones the statistic has: even (Theo1), multiples of 3 (ThêoH)."""
    _check(stat)
    ms = np.asarray(ms, dtype=np.int64)
    if stat == "theoh":
        moved = np.where(ms >= 3, 3 * np.round(ms / 3.0).astype(np.int64), ms)
        notes = ["theoh: tau = m tau0 (AVAR below 10 % of the record, ThêoBR at 4m/3 above)"]
        if np.any(moved != ms):
            notes.append(
                "theoh: factors m >= 3 moved to the nearest multiple of 3 (ThêoBR needs the "
                "even Theo1 factor 4m/3)"
            )
    else:
        moved = ms + (ms % 2)
        notes = [f"{stat}: tau = 0.75 m tau0 (the factors asked for are m, m even)"]
        if np.any(moved != ms):
            notes.append(f"{stat}: odd averaging factors moved up to the next even one")
    return np.unique(moved), tuple(notes)


# cost of the two Theo1 kernels, nanoseconds per unit of work (fitted on 2e3 and 2e4 points)
_NS_EXACT = 0.65  # per multiply-add of the exact kernel
_NS_EXACT_WINDOW = 0.4  # per exact addition growing its window sums
_NS_FAST = 0.25  # per double-double lag product of the fast one
_NS_FAST_TERM = 1.0  # per term T(m, j) the fast one adds up
_NS_FAST_POINT = 50.0  # per phase point (centring, prefix sums, copies)


def _exact_cost(n_points: int, ms: np.ndarray) -> float:
    """Nanoseconds :func:`theo1_sums` needs (about)."""
    m = ms.astype(np.float64)
    work = float(np.sum((n_points - m) * m / 2))
    return _NS_EXACT * work + _NS_EXACT_WINDOW * n_points * float(m[-1]) / 2


def _fast_cost(n_points: int, ms: np.ndarray) -> float:
    """Nanoseconds :func:`theo1_fast_sums` needs (about)."""
    top = float(ms[-1])
    lags = (top + 1) * n_points - top * (top + 1) / 2
    terms = float(np.sum(ms)) / 2
    return _NS_FAST * (lags + 1.25 * top * top) + _NS_FAST_TERM * terms + _NS_FAST_POINT * n_points


def _exact_sums(u: np.ndarray, ms: np.ndarray) -> np.ndarray:
    """``S(m)`` from the exact kernel (a few ulps; ``O(N m)`` per factor)."""
    out = np.zeros(ms.size)
    theo1_sums(read_only(u, np.float64), read_only(ms, np.int64), out)
    return out


def _fast_sums(u: np.ndarray, ms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``S(m)`` from the all-tau kernel, and a bound on the error of each.

    The phase is centred and scaled by a power of two (exact) to ``max|x| < 1``; the bound
    is the kernel's (module docstring of :mod:`adavar._kernels.theo_family`) plus the effect
    of the rounding of ``x`` itself, ``|dS| <= 2 sqrt(S S_d) + S_d`` with
    ``S_d <= 16 d^2 (N - m) H_k`` for an error ``d`` per point.
    """
    n_points = u.size + 1
    xh = np.empty(n_points)
    xl = np.empty(n_points)
    u = read_only(u, np.float64)
    seen = centred_phase(u, float(np.mean(u)), xh, xl)
    top = float(np.max(np.abs(xh)))
    if top == 0.0:  # a linear phase: Theo1 is zero
        return np.zeros(ms.size), np.zeros(ms.size)
    e = math.frexp(top)[1]
    xh = np.ldexp(xh, -e)
    xl = np.ldexp(xl, -e)
    out = np.empty(ms.size)
    theo1_fast_sums(read_only(xh), read_only(xl), read_only(ms, np.int64), out)
    k = ms // 2
    harmonic = np.cumsum(1.0 / np.arange(1, k[-1] + 1))[k - 1]
    big = math.ldexp(top, -e) ** 2
    bound = harmonic * 2.0**-98 * (n_points + 2.0) ** 2 * big + 2.0**-42 * np.abs(out)
    d = (3.0 * n_points + 4.0) * 2.0**-104 * math.ldexp(seen, -e)  # N additions, 2 more
    s_d = 16.0 * d * d * (n_points - ms) * harmonic
    bound += 2.0 * np.sqrt(np.maximum(out, 0.0) * s_d + bound * s_d) + s_d
    return np.ldexp(out, 2 * e), np.ldexp(bound, 2 * e)


def theo1_double_sums(u: np.ndarray, ms: np.ndarray, method: str = "auto") -> np.ndarray:
    """The Theo1 double sum ``S(m)`` (unnormalised, SP 1065 Eq. 30) at even ``ms``.

    Parameters
    ----------
    u : ndarray of float64
        The ``N - 1`` increments of the phase, at scale 1.
    ms : ndarray of int64
        Even factors, ``2 <= m <= N - 1`` (any order).
    method : {"auto", "fast", "exact"}
        ``"exact"``: :func:`adavar._kernels.theo_family.theo1_sums`, ``O(N m)`` per factor;
        ``"fast"``: the all-tau kernel, ``O(N)`` per factor over all factors up to the
        largest, each checked against its error bound (relative ``2^-36``) and recomputed
        exactly where the bound is larger (at the shortest factors of a record with drift or
        a random walk of frequency, say); ``"auto"``: whichever costs less.

    Returns
    -------
    ndarray of float64
        ``sum_j (1/j) sum_i [...]^2`` per factor.
    """
    u = np.ascontiguousarray(u, dtype=np.float64)
    asked = np.asarray(ms, dtype=np.int64)
    if asked.size == 0:
        return np.zeros(0)
    n_points = u.size + 1
    bad = (asked % 2 != 0) | (asked < 2) | (asked > n_points - 1)
    if bad.any():
        raise AdavarInputError(
            f"Theo1 needs even factors 2 <= m <= N - 1 = {n_points - 1}, got m = "
            f"{int(asked[bad][0])}"
        )
    if method not in ("auto", "fast", "exact"):
        raise AdavarInputError(f"method must be 'auto', 'fast' or 'exact', got {method!r}")
    ms, back = np.unique(asked, return_inverse=True)
    return _double_sums(u, ms, method)[back]


def _double_sums(u: np.ndarray, ms: np.ndarray, method: str) -> np.ndarray:
    """:func:`theo1_double_sums` at increasing, distinct, valid ``ms``."""
    n_points = u.size + 1
    if method == "auto":
        cheaper = _fast_cost(n_points, ms) < _exact_cost(n_points, ms)
        method = "fast" if cheaper else "exact"
    if method == "exact":
        return _exact_sums(u, ms)
    sums, bound = _fast_sums(u, ms)
    redo = ~(bound <= FAST_TOLERANCE * sums)  # NaN-safe: a NaN bound is redone too
    if redo.any():
        sums[redo] = _exact_sums(u, ms[redo])
    return sums


def _theo1_var(u: np.ndarray, ms: np.ndarray, method: str = "auto") -> np.ndarray:
    """Theo1 variances at even ``ms`` (sample interval 1)."""
    n_points = u.size + 1
    m = ms.astype(np.float64)
    return theo1_double_sums(u, ms, method) / (0.75 * (n_points - m) * m * m)


def _oavar(phase: diff.AnchoredPhase, ms: np.ndarray) -> np.ndarray:
    """Overlapping Allan variances (sample interval 1) at ``ms`` (each ``2m < N``)."""
    m = ms.astype(np.float64)
    counts = phase.n_points - 2 * ms
    return record_sums.overlapping_sums(phase, ms, 2) / (2.0 * m * m * counts)


def ratio_factors(n_points: int, terms: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The AVAR and Theo1 factors of ThêoBR's bias ratio (see :func:`theobr_ratio`).

    Returns
    -------
    m_avar, m_theo : ndarray of int64
        ``9 + 3i`` and ``12 + 4i`` for the ``i`` averaged, a pair with no AVAR term left out.
    """
    if n_points < MIN_POINTS_THEOBR:
        raise AdavarInputError(
            f"theobr/theoh need at least {MIN_POINTS_THEOBR} phase points for the bias "
            f"ratio, got {n_points}: give a longer record or use stat='theo1' (--stat theo1)"
        )
    i = np.arange(n_points // 6 - 3 + 1, dtype=np.int64)
    if terms is not None:
        if isinstance(terms, bool) or not isinstance(terms, (int, np.integer)) or terms < 2:
            raise AdavarInputError(
                "theo_ratio_terms (--theo-ratio-terms) must be a whole number >= 2 (or None "
                f"for all), got {terms!r}"
            )
        if terms < i.size:
            i = np.unique(np.round(np.linspace(0, i[-1], int(terms))).astype(np.int64))
    m_avar = 9 + 3 * i
    keep = n_points - 2 * m_avar >= 1  # the last pair has no AVAR term when 6 divides N
    if not keep.any():  # N = 18: the one pair's AVAR (m = 9) needs 19 points
        raise AdavarInputError(
            f"theobr/theoh: no AVAR/Theo1 pair for the bias ratio on {n_points} phase points "
            "(AVAR at m = 9 needs 19): give a longer record or use stat='theo1' (--stat theo1)"
        )
    return m_avar[keep], (12 + 4 * i)[keep]


def _ratio(u: np.ndarray, m_avar: np.ndarray, theo: np.ndarray) -> float:
    """``mean(AVAR(m_avar) / theo)`` over the pairs whose Theo1 is not zero."""
    avar = _oavar(diff.anchored_phase(u), m_avar)
    ok = theo > 0
    if not ok.any():
        raise AdavarInputError(
            "theobr/theoh: Theo1 is zero at every tau of the bias ratio (a constant or "
            "linear phase): the bias-removed statistic is undefined, use stat='theo1' "
            "(--stat theo1)"
        )
    return float(np.mean(avar[ok] / theo[ok]))


def theobr_ratio(u: np.ndarray, terms: int | None = None) -> float:
    """ThêoBR's bias ratio ``kf`` (SP 1065 Eq. 33) of the increments ``u``.

    Parameters
    ----------
    u : ndarray of float64
        The ``N - 1`` increments of the phase (rate samples or phase differences).
    terms : int, optional
        Average only this many ratios, evenly spread over ``i = 0 .. n`` (both ends
        included). Default: all ``n + 1`` of them, as SP 1065 (and Stable32) do; they need
        Theo1 at ``N/6`` factors up to ``2N/3``, one pass of the all-tau kernel (20000
        points: about 0.13 s). Fewer terms save little time: the factors still reach 2N/3.

    Returns
    -------
    float
        ``mean_i AVAR(9 + 3i) / Theo1(12 + 4i)``, ``i = 0 .. floor(N/6 - 3)``.
    """
    u = np.ascontiguousarray(u, dtype=np.float64)
    m_avar, m_theo = ratio_factors(u.size + 1, terms)
    return _ratio(u, m_avar, _theo1_var(u, m_theo))


def _theo1_and_ratio(u: np.ndarray, ms: np.ndarray, terms: int | None) -> tuple[np.ndarray, float]:
    """Theo1 at ``ms`` and the bias ratio, from one pass over the union of their factors."""
    m_avar, m_theo = ratio_factors(u.size + 1, terms)
    every = np.union1d(ms, m_theo)
    var = _theo1_var(u, every)
    kf = _ratio(u, m_avar, var[np.searchsorted(every, m_theo)])
    return var[np.searchsorted(every, ms)], kf


def _theoh_split(ms: np.ndarray, n_points: int) -> np.ndarray:
    """True where ThêoH uses ThêoBR (``m >= k``, ``m`` a multiple of 3)."""
    k = math.floor(0.1 * (n_points - 1))
    return (ms >= max(k, 3)) & (ms % 3 == 0)


def squared(
    stat: str, u: np.ndarray, ms: np.ndarray, theo_ratio_terms: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Variances (sample interval 1) and term counts at the factors ``ms``.

    Parameters
    ----------
    stat : {"theo1", "theobr", "theoh"}
        The statistic.
    u : ndarray of float64
        Increments of the phase at scale 1 (contiguous).
    ms : ndarray of int64
        Factors already passed through :func:`factors`.
    theo_ratio_terms : int, optional
        ThêoBR/ThêoH: the ``terms`` of :func:`theobr_ratio` (``deviation(...,
        theo_ratio_terms=64)`` averages 64 evenly spread ratios instead of SP 1065's all;
        since the all-tau kernel it saves little time: the factors still reach ``2N/3``).

    Returns
    -------
    values, n : ndarray
        The squared deviation and the number of squared terms per factor.
    """
    _check(stat)
    u = np.ascontiguousarray(u, dtype=np.float64)
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    n_points = u.size + 1
    if stat == "theo1":
        return _theo1_var(u, ms), (n_points - ms) * (ms // 2)
    if stat == "theobr":
        var, kf = _theo1_and_ratio(u, ms, theo_ratio_terms)
        return var * kf, (n_points - ms) * (ms // 2)
    var = np.empty(ms.size)
    n = np.empty(ms.size, dtype=np.int64)
    br = _theoh_split(ms, n_points)
    if (~br).any():
        m_a = ms[~br]
        var[~br] = _oavar(diff.anchored_phase(u), m_a)
        n[~br] = n_points - 2 * m_a
    if br.any():
        m_t = np.ascontiguousarray(4 * ms[br] // 3)
        theo, kf = _theo1_and_ratio(u, m_t, theo_ratio_terms)
        var[br] = theo * kf
        n[br] = (n_points - m_t) * (m_t // 2)
    return var, n


def theo1_edf(alpha: int, m: int, n_points: int) -> float:
    """SP 1065's Theo1 EDF (module docstring) at the even factor ``m``, floored at 1."""
    a = min(max(int(alpha), -2), 2)
    n = float(n_points)
    r = 0.75 * m
    if a == 2:
        value = 0.86 * (n + 1) * (n - 4 * r / 3) / (n - r) * r / (r + 1.14)
    elif a == 1:
        value = (4.798 * n * n - 6.374 * n * r + 12.387 * r) / (math.sqrt(r + 36.6) * (n - r))
        value *= r / (r + 0.3)
    elif a == 0:
        value = ((4.1 * n + 0.8) / r - (3.1 * n + 6.5) / n) * r**1.5 / (r**1.5 + 5.2)
    elif a == -1:
        value = (2 * n * n - 1.3 * n * r - 3.5 * r) / (n * r) * r**3 / (r**3 + 2.3)
    else:
        c = 4.4 * n - 1
        value = (4.4 * n - 2) / (2.9 * r) * (c * c - 8.6 * r * c + 11.4 * r * r) / (c - 2) ** 2
    if not math.isfinite(value):
        return edf_mod.EDF_FLOOR
    return max(value, edf_mod.EDF_FLOOR)


def edf(stat: str, alpha: int, m: int, n_points: int, theo_ratio_terms: int | None = None) -> float:
    """Equivalent degrees of freedom at factor ``m`` (module docstring; the option is unused)."""
    _check(stat)
    if stat != "theoh":
        return theo1_edf(alpha, m, n_points)
    if _theoh_split(np.array([m]), n_points)[0]:
        return theo1_edf(alpha, 4 * m // 3, n_points)
    return edf_mod.edf("oadev", alpha, m, n_points)

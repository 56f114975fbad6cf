"""Theo1, ThêoBR and ThêoH (NIST SP 1065 sections 5.2.15-5.2.17), for :func:`adavar.deviation`.

This is a family module of :mod:`adavar.extended_statistics` (``squared``, ``m_max``,
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

Computation: :func:`adavar._kernels.theo_family.theo1_sums`, exact to a few ulps whatever
the frequency offset or drift (Theo1 is blind to a frequency offset; the kernel never forms
the offset), in ``sum_m (N - m) m / 2`` multiply-adds; the Allan variances come from
:mod:`adavar.differences`. That is the naive operation count, O(N m) per tau (octave taus
on 2e4 points: about 0.1 s), not the O(N) per tau of an all-tau algorithm; ThêoBR's exact
bias ratio needs Theo1 at about N/6 factors, about ``0.015 N^3`` multiply-adds (5000
points: 2 s), which ``theo_ratio_terms`` bounds (64 terms: 0.15 s at 5000 points).

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
the overlapping-ADEV EDF (:func:`adavar.edf.edf`) on its AVAR part and Theo1's EDF at
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

from adavar import differences as diff
from adavar import edf as edf_mod
from adavar._kernels.theo_family import theo1_sums
from adavar.errors import AdavarInputError

__all__ = ["STATS", "edf", "factors", "m_max", "squared", "theo1_edf", "theobr_ratio"]

STATS = ("theo1", "theobr", "theoh")
#: fewest phase points with a ThêoBR bias ratio (n = floor(N/6 - 3) >= 0)
MIN_POINTS_THEOBR = 18


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


def _theo1_var(u: np.ndarray, ms: np.ndarray) -> np.ndarray:
    """Theo1 variances at even ``ms`` (sample interval 1)."""
    n_points = u.size + 1
    sums = np.zeros(ms.size)
    theo1_sums(u, ms, sums)
    m = ms.astype(np.float64)
    return sums / (0.75 * (n_points - m) * m * m)


def _oavar(phase: diff.AnchoredPhase, ms: np.ndarray) -> np.ndarray:
    """Overlapping Allan variances (sample interval 1) at ``ms`` (each ``2m < N``)."""
    m = ms.astype(np.float64)
    counts = phase.n_points - 2 * ms
    return diff.overlapping_sums(phase, ms, 2) / (2.0 * m * m * counts)


def theobr_ratio(u: np.ndarray, terms: int | None = None) -> float:
    """ThêoBR's bias ratio ``kf`` (SP 1065 Eq. 33) of the increments ``u``.

    Parameters
    ----------
    u : ndarray of float64
        The ``N - 1`` increments of the phase (rate samples or phase differences).
    terms : int, optional
        Average only this many ratios, evenly spread over ``i = 0 .. n`` (both ends
        included). Default: all ``n + 1`` of them, as SP 1065 (and Stable32) do; that costs
        about ``0.015 N^3`` multiply-adds (5000 points: about 2 s; 20000: about 2 min).

    Returns
    -------
    float
        ``mean_i AVAR(9 + 3i) / Theo1(12 + 4i)``, ``i = 0 .. floor(N/6 - 3)``.
    """
    n_points = u.size + 1
    if n_points < MIN_POINTS_THEOBR:
        raise AdavarInputError(
            f"theobr/theoh need at least {MIN_POINTS_THEOBR} phase points for the bias "
            f"ratio, got {n_points}: give a longer record or use stat='theo1'"
        )
    i = np.arange(n_points // 6 - 3 + 1, dtype=np.int64)
    if terms is not None:
        if isinstance(terms, bool) or not isinstance(terms, (int, np.integer)) or terms < 2:
            raise AdavarInputError(
                f"theo_ratio_terms must be a whole number >= 2 (or None for all), got {terms!r}"
            )
        if terms < i.size:
            i = np.unique(np.round(np.linspace(0, i[-1], int(terms))).astype(np.int64))
    m_avar = 9 + 3 * i
    keep = n_points - 2 * m_avar >= 1  # the last pair has no AVAR term when 6 divides N
    m_avar, m_theo = m_avar[keep], (12 + 4 * i)[keep]
    avar = _oavar(diff.anchored_phase(u), m_avar)
    theo = _theo1_var(u, m_theo)
    ok = theo > 0
    if not ok.any():
        raise AdavarInputError(
            "theobr/theoh: Theo1 is zero at every tau of the bias ratio (a constant or "
            "linear phase): the bias-removed statistic is undefined, use stat='theo1'"
        )
    return float(np.mean(avar[ok] / theo[ok]))


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
        theo_ratio_terms=64)`` trades the exact SP 1065 ratio for speed on long records).

    Returns
    -------
    values, n : ndarray
        The squared deviation and the number of squared terms per factor.
    """
    _check(stat)
    u = np.ascontiguousarray(u, dtype=np.float64)
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    n_points = u.size + 1
    if stat != "theoh":
        var = _theo1_var(u, ms)
        if stat == "theobr":
            var = var * theobr_ratio(u, theo_ratio_terms)
        return var, (n_points - ms) * (ms // 2)
    var = np.empty(ms.size)
    n = np.empty(ms.size, dtype=np.int64)
    br = _theoh_split(ms, n_points)
    if (~br).any():
        m_a = ms[~br]
        var[~br] = _oavar(diff.anchored_phase(u), m_a)
        n[~br] = n_points - 2 * m_a
    if br.any():
        m_t = np.ascontiguousarray(4 * ms[br] // 3)
        var[br] = _theo1_var(u, m_t) * theobr_ratio(u, theo_ratio_terms)
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

"""MTIE and TIE rms (ITU-T G.810; NIST SP 1065 section 5.2.18), for :func:`adavar.deviation`.

This is a family module of :mod:`adavar.core.extended_statistics` (``squared``, ``m_max``,
``factors``, ``edf``). Both are time-like (units of the phase, like TDEV; for rate data the
phase is ``cumsum(rate) * tau0``) and neither is blind to a frequency offset: nothing is
removed from the record before they are computed.

``mtie`` at averaging factor ``m`` (``tau = m tau0``, ``1 <= m <= N - 1``): the largest
peak-to-peak phase excursion within any window of ``m + 1`` consecutive phase points,

    MTIE(m) = max_{i=0}^{N-m-1} ( max x[i..i+m] - min x[i..i+m] ),

with ``n = N - m`` windows: Stable32's convention (its "MTIE" and "MTIE (Fast)" tables on
PHASE.DAT and the Cs 5071A record agree with it at every printed digit; Stable32's decade
table prints ``N`` in its "#" column). Computed with monotone deques, O(N) per tau.

``tierms`` at ``m`` (``1 <= m <= N - 1``): the rms of the lag-``m`` phase differences,
**without** removing their mean (a frequency offset stays in, as in Stable32):

    TIErms(m) = sqrt( 1/(N - m) sum_{i=0}^{N-m-1} (x[i+m] - x[i])^2 ),  n = N - m.

Both use the phase as a double-double (:mod:`adavar._kernels.time_error`): a frequency
offset of 1e9, a drift or a million samples cost no digits.

EDF: MTIE is a maximum, for which no chi-square model exists, so its EDF is NaN and
:func:`adavar.deviation` reports NaN bounds (and a note). TIE rms squared is the overlapping
first-difference variance (``d = 1`` in Greenhall & Riley's framework: the mean of squared
unmodified first differences of the phase at stride ``tau0``), so its EDF is
:func:`adavar.stats.edf.greenhall_edf` with ``d = 1``, overlapping, unmodified, where that
variance converges: white PM, flicker PM and white FM (alpha 2, 1, 0). A Monte Carlo check
(2000 records of 1024 points, ``2 E[v]^2 / Var[v]`` of ``v = TIErms^2`` at m = 1, 8, 64)
agreed within 3 % for white PM (701, 676, 649 against 682, 679, 655), 10 % for flicker PM
(896, 385, 109 against 920, 360, 100) and white FM at m = 8, 64 (182, 22.9 against 177,
22.9); at m = 1 white FM gave 1040 (exactly N - 1 = 1023: iid squares) against 909. For
flicker FM and redder (alpha <= -1) the first differences of the phase are not stationary
with a finite variance and the EDF is NaN. The chi-square model also
assumes no deterministic frequency offset, which TIE rms keeps in; with one the bounds
describe only the noise part.
"""

from __future__ import annotations

import numpy as np

from adavar._kernels.time_error import dd_phase, mtie_values, tie_square_sums
from adavar.core.errors import AdavarInputError
from adavar.stats import edf as edf_mod

__all__ = ["STATS", "edf", "factors", "m_max", "phase_dd", "squared"]

STATS = ("mtie", "tierms")


def _check(stat: str) -> None:
    if stat not in STATS:
        raise AdavarInputError(f"unknown time-error stat {stat!r}: use one of {STATS}")


def m_max(stat: str, n_points: int) -> int:
    """Largest averaging factor: ``N - 1`` (one window, one difference)."""
    _check(stat)
    return n_points - 1


def factors(stat: str, ms: np.ndarray) -> tuple[np.ndarray, tuple[str, ...]]:
    """Every factor ``1 <= m <= N - 1`` is usable: ``ms`` unchanged, no notes."""
    _check(stat)
    return np.asarray(ms, dtype=np.int64), ()


def phase_dd(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The phase ``x[k] = sum(u[:k])`` as a double-double ``(high, low)``, ``x[0] = 0``."""
    u = np.ascontiguousarray(u, dtype=np.float64)
    xh = np.empty(u.size + 1)
    xl = np.empty(u.size + 1)
    dd_phase(u, xh, xl)
    return xh, xl


def squared(stat: str, u: np.ndarray, ms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Squared MTIE or TIE rms (units of ``cumsum(u)``) and the counts ``N - m``.

    Parameters
    ----------
    stat : {"mtie", "tierms"}
        The statistic.
    u : ndarray of float64
        Increments of the phase at scale 1 (contiguous).
    ms : ndarray of int64
        Averaging factors, ``1 <= m <= N - 1``.

    Returns
    -------
    values, n : ndarray
        ``MTIE(m)**2`` or ``TIErms(m)**2``, and ``N - m``.
    """
    _check(stat)
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    xh, xl = phase_dd(u)
    n = xh.size - ms
    out = np.empty(ms.size)
    if stat == "mtie":
        mtie_values(xh, xl, ms, out)
        return out * out, n
    tie_square_sums(xh, xl, ms, out)
    return out / n, n


def edf(stat: str, alpha: int, m: int, n_points: int) -> float:
    """NaN for MTIE; the ``d = 1`` Greenhall EDF for TIE rms (alpha >= 0), else NaN."""
    _check(stat)
    if stat == "mtie" or int(alpha) < 0:
        return float("nan")
    a = min(int(alpha), 2)
    value = edf_mod.greenhall_edf(a, 1, int(m), int(n_points), overlapping=True, modified=False)
    return max(value, edf_mod.EDF_FLOOR)

"""Choice of averaging times: keywords and explicit lists, mapped to whole averaging factors."""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np

from adavar.core.errors import AdavarInputError

__all__ = ["TAU_KEYWORDS", "averaging_factors", "tau_bounds"]

TAU_KEYWORDS = ("all", "octave", "decade", "log")


def averaging_factors(
    taus: str | Sequence[float] | np.ndarray,
    m_max: int,
    tau0: float,
    *,
    points_per_decade: int = 10,
) -> tuple[np.ndarray, tuple[str, ...]]:
    """Averaging factors ``m`` (``tau = m * tau0``) for a tau specification.

    Parameters
    ----------
    taus : {"all", "octave", "decade", "log"} or sequence of float
        ``"all"``: every ``m`` from 1 to ``m_max``; ``"octave"``: 1, 2, 4, ...;
        ``"decade"``: 1, 2, 4, 10, 20, 40, ... (Stable32's spacing); ``"log"``:
        ``points_per_decade`` log-spaced points per decade; or explicit taus in seconds,
        rounded to whole multiples of ``tau0``.
    m_max : int
        Largest averaging factor the statistic allows for this record.
    tau0 : float
        Sample interval, seconds.
    points_per_decade : int, optional
        Density of ``"log"``.

    Returns
    -------
    m : ndarray of int64
        Sorted unique averaging factors in ``[1, m_max]``.
    notes : tuple of str
        What was changed about an explicit list (rounding, dropped values).
    """
    notes: list[str] = []
    if m_max < 1:
        raise AdavarInputError(
            "the record is too short for this statistic: give more samples (at least 3)"
        )
    if isinstance(taus, str):
        key = taus.lower()
        if key == "all":
            return np.arange(1, m_max + 1, dtype=np.int64), ()
        if key not in TAU_KEYWORDS:
            raise AdavarInputError(
                f"unknown taus keyword {taus!r}: use one of {', '.join(TAU_KEYWORDS)} "
                "or a list of taus in seconds"
            )
        return _keyword_factors(key, int(m_max), points_per_decade).copy(), ()

    req = np.atleast_1d(np.asarray(taus, dtype=np.float64))
    if req.ndim != 1 or req.size == 0:
        raise AdavarInputError("taus must be a keyword or a non-empty list of seconds")
    if not np.all(np.isfinite(req)) or np.any(req <= 0):
        raise AdavarInputError("taus must be positive, finite numbers of seconds")
    with np.errstate(over="ignore"):  # a tau of 1e300 s: beyond every record
        ratio = np.round(req / tau0)
        off = np.abs(ratio * tau0 - req) > 1e-9 * req
    if np.any(off & np.isfinite(ratio)):
        notes.append(f"taus rounded to whole multiples of tau0 = {tau0:g} s")
    bad = ~((ratio >= 1) & (ratio <= m_max))
    m = np.where(bad, 0.0, ratio).astype(np.int64)  # only the factors in range are cast
    if np.any(bad):
        notes.append(
            f"dropped {int(bad.sum())} tau(s) outside {tau0:g} s .. {m_max * tau0:g} s "
            "(the range this statistic allows for this record)"
        )
    m = np.unique(m[~bad])
    if m.size == 0:
        raise AdavarInputError(
            f"no requested tau lies in {tau0:g} s .. {m_max * tau0:g} s: choose taus inside "
            "the record's range"
        )
    return m, tuple(notes)


@lru_cache(maxsize=64)
def _keyword_factors(key: str, m_max: int, points_per_decade: int) -> np.ndarray:
    """The factors of a sparse ``taus`` keyword, read-only (:func:`averaging_factors` copies)."""
    if key == "octave":
        m = 2 ** np.arange(int(np.floor(np.log2(m_max))) + 1)
    elif key == "decade":
        exps = 10 ** np.arange(int(np.floor(np.log10(m_max))) + 1)
        m = np.sort(np.concatenate([exps, 2 * exps, 4 * exps]))
    elif key == "log":
        if points_per_decade < 1:
            raise AdavarInputError("points_per_decade must be a positive integer")
        decades = np.log10(m_max)
        k = max(int(np.ceil(decades * points_per_decade)) + 1, 2)
        m = np.round(np.logspace(0.0, decades, k))
    m = np.unique(m.astype(np.int64))
    m = m[(m >= 1) & (m <= m_max)]
    m.flags.writeable = False
    return m


def tau_bounds(tau_range: object) -> tuple[float, float]:
    """``(min, max)`` seconds of a fit's ``tau_range`` (None ends are open), checked.

    Raises
    ------
    AdavarInputError
        Not a pair of numbers (or None), or a minimum not below the maximum.
    """
    try:
        lo, hi = tau_range  # type: ignore[misc]
        lo = -math.inf if lo is None else float(lo)
        hi = math.inf if hi is None else float(hi)
    except (TypeError, ValueError):
        raise AdavarInputError(
            f"tau_range must be (min, max) in seconds, got {tau_range!r}"
        ) from None
    if not lo < hi:
        raise AdavarInputError(f"tau_range {tau_range!r}: the minimum must be below the maximum")
    return lo, hi

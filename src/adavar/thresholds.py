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
from scipy import stats

from adavar.errors import AdavarInputError
from adavar.settings import CONTROLLER

__all__ = ["Thresholds", "calibrated_thresholds", "fixed_thresholds"]


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

    z = stats.norm.ppf(q)
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
        kx = stats.kurtosis(x, axis=1, fisher=False)
        kc = stats.kurtosis(x[:, : length - seg], axis=1, fisher=False)
        s[a : a + x.shape[0]] = (kx - kc) / kx
    return float(np.quantile(s, q))


@dataclass(frozen=True)
class Thresholds:
    """Per-length thresholds of the controller: ``k1[L]``, ``k2[L]``, ``s2[L]``."""

    k1: np.ndarray
    k2: np.ndarray
    s2: np.ndarray
    source: str


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
    lengths = np.arange(lmin, lmax + 1)
    # the quantiles are smooth in L: solve at a few lengths, interpolate in 1/L
    nodes = np.unique(np.round(np.geomspace(lmin, lmax, 9)).astype(np.int64))
    lo = [_kurtosis_quantile(false_alarm / 2, int(n)) for n in nodes]
    hi = [_kurtosis_quantile(1 - false_alarm / 2, int(n)) for n in nodes]
    inv = 1.0 / lengths
    k1[lmin:] = np.interp(inv, 1.0 / nodes[::-1], np.array(lo)[::-1])
    k2[lmin:] = np.interp(inv, 1.0 / nodes[::-1], np.array(hi)[::-1])
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

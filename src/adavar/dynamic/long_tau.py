"""Changes of the long-tau noise terms (rate random walk, bias instability).

docs/method.md section 11. The ICI rule watches the Allan variance at its short averaging
factors (``m = 1``: the white-noise level), where a change of the rate random walk ``K`` or
of the bias instability ``B`` does not show (``K`` ten times larger at ``K = N / 100``
moves the 1 Hz Allan variance at 1 s by 0.3 %). At longer ``tau`` they dominate. There the
same segmentation as the ICI's episodes (:func:`adavar.dynamic.ici_episodes.segment_squares`:
circular binary segmentation of the CUSUM of clipped squares against Kuiper's and
Kolmogorov's distributions) runs on the squared second differences of ``m``-sums,
``d_m(i)**2`` (mean ``2 m**2`` times the Allan variance at ``m tau0``), at the octave
factors ``m = 16, 32, ...`` up to ``n / 64`` (at least 64 non-overlapping differences),
over the whole record (a change of a long-tau term shows only over many ``tau``, longer
than any window of the ICI's), with:

* ``lambda`` (the long-run variance of the squares over their squared mean)
  ``2 (1 + 2 sum_k rho_k**2) + e / r`` from the autocorrelation ``rho`` of the sequence
  (lags to ``4m``, by FFT; beyond ``2m`` only those above 3 standard errors), ``e`` the
  record's robust excess kurtosis (:func:`adavar.dynamic.ici_episodes.excess_kurtosis`; its share
  falls as ``1 / m``);
* the squares taken every ``r = max(1, m / 8)`` samples (overlapping by ``2m``, the
  decimated sequence loses little and costs ``1 / r``), segments of at least ``2m``;
* the test level ``2 Phi(-gamma)`` shared among the factors (Bonferroni).

The cuts of all factors in order of time, a run of cuts in one direction is one change,
at its most significant cut and that cut's ``tau``; a change sits at the cut plus ``m``
(the middle of the difference). Changes pair into stretches: the first moves away from the
record's starting level, the next (the other direction) comes back, and so on; an unpaired
last change opens a stretch to the end of the record.

Accuracy (benchmarks/bench_ici.py): a change of a long-tau term is located to a fraction of
the ``tau`` it is seen at, not to the ICI's ``lmin / 2``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.special import ndtr, ndtri

from adavar.core.errors import AdavarInputError
from adavar.core.inputs import as_samples
from adavar.core.settings import ICI_GAMMA
from adavar.dynamic import ici_episodes
from adavar.io.sampling import resolve_tau0

__all__ = [
    "LONG_TAU_MIN_M",
    "LONG_TAU_SAMPLES",
    "LongTauChange",
    "LongTauChanges",
    "long_tau_changes",
]

#: the shortest averaging factor of the scan (shorter ones see what the ICI rule sees)
LONG_TAU_MIN_M = 16
#: at least this many non-overlapping differences at the longest factor
_MIN_DIFFERENCES = 64
#: the shortest record a scan runs on (64 differences of the shortest factor)
LONG_TAU_SAMPLES = _MIN_DIFFERENCES * LONG_TAU_MIN_M
#: squares per averaging factor kept (every ``m / _PER_M``-th)
_PER_M = 8


@dataclass(frozen=True)
class LongTauChange:
    """One change of the Allan variance at a long ``tau`` (module notes).

    Attributes
    ----------
    time_s : float
        Time of the change (s, from ``t0``).
    sample : int
        Its sample.
    tau_s : float
        The averaging time it was found at (s).
    rise : bool
        The Allan variance at ``tau_s`` is higher after it.
    ratio : float
        Allan variance at ``tau_s`` after it over before it (the neighbouring segments).
    statistic : float
        Its two-segment CUSUM in units of the null standard deviation.
    """

    time_s: float
    sample: int
    tau_s: float
    rise: bool
    ratio: float
    statistic: float

    def as_dict(self) -> dict[str, Any]:
        """The JSON form (every attribute)."""
        return {"time_s": self.time_s, "sample": self.sample, "tau_s": self.tau_s,
                "rise": self.rise, "ratio": self.ratio, "statistic": self.statistic}  # fmt: skip


@dataclass(frozen=True)
class LongTauChanges:
    """The long-tau changes of a record (:func:`long_tau_changes`).

    Attributes
    ----------
    changes : tuple of LongTauChange
        In order of time.
    taus : ndarray
        The averaging times scanned (s).
    parameters : dict
        ``gamma``, ``ms`` (the factors), ``excess_kurtosis``, ``rate``, ``t0``.
    """

    changes: tuple[LongTauChange, ...]
    taus: np.ndarray
    parameters: dict[str, Any] = field(default_factory=dict)

    def stretches(
        self, exclude: Sequence[Any] = (), margin: float = 0.0, per_tau: float = 0.0
    ) -> list[tuple[LongTauChange, LongTauChange | None]]:
        """The changes paired into stretches (module notes).

        Parameters
        ----------
        exclude : sequence of float or (float, float)
            Times (s, counted as ``time_s``), or intervals, of changes found otherwise (the
            ICI's steps and ramps): a change within ``margin + per_tau * tau_s`` of one is
            left out before the pairing.
        margin : float
            Seconds.
        per_tau : float
            More margin, in units of each change's ``tau_s``.

        Returns
        -------
        list of (LongTauChange, LongTauChange or None)
            The change into each stretch and the one out of it (None: to the end).
        """
        spans = [(float(e), float(e)) if np.ndim(e) == 0 else (float(e[0]), float(e[1]))
                 for e in exclude]  # fmt: skip
        merged: list[LongTauChange] = []
        for c in self.changes:
            reach = margin + per_tau * c.tau_s
            if any(a - reach <= c.time_s <= b + reach for a, b in spans):
                continue
            if merged and merged[-1].rise == c.rise:  # what is left of a run: its strongest
                if c.statistic > merged[-1].statistic:
                    merged[-1] = c
                continue
            merged.append(c)
        pairs = ici_episodes.pair_changes([c.rise for c in merged])
        return [(merged[a], None if b is None else merged[b]) for a, b in pairs]


def _autocorrelation(d: np.ndarray, lags: int) -> np.ndarray:
    """Autocorrelation of ``d`` (mean removed) at lags 1 .. ``lags`` by FFT."""
    n = d.size
    u = d - float(np.cumsum(d)[-1]) / n
    size = 1 << math.ceil(math.log2(2 * n))
    f = np.fft.rfft(u, size)
    a = np.fft.irfft(f * np.conj(f), size)[: lags + 1]
    if not a[0] > 0.0:
        return np.zeros(lags)
    return a[1:] / a[0] * n / (n - np.arange(1, lags + 1))


def _factor_cuts(
    x: np.ndarray, m: int, p: float, excess: float
) -> list[tuple[int, bool, float, float]]:
    """``(sample, rise, ratio, statistic)`` of the cuts at factor ``m`` (module notes)."""
    c = np.concatenate(([0.0], np.cumsum(x)))
    sums = c[m:] - c[:-m]
    d = sums[m:] - sums[:-m]  # d_m(i) = sum x[i+m : i+2m] - sum x[i : i+m]
    r = max(1, m // _PER_M)
    d = d[::r]
    if d.size < 4 * (2 * m // r):
        return []
    lags = min(d.size - 1, -(-4 * m // r))
    rho = _autocorrelation(d, lags)
    k = np.arange(1, lags + 1)
    rho = np.where((k * r < 2 * m) | (np.abs(rho) > 3.0 / math.sqrt(d.size * r / m)), rho, 0.0)
    lam = 2.0 * (1.0 + 2.0 * float(np.sum(rho**2))) + excess / r
    s = d * d
    shortest = max(2, 2 * m // r)
    gamma = -float(ndtri(p / 2.0))  # the level p as the segmentation's gamma
    guard = -(-2 * m // r)  # the decimated differences that share samples
    cuts = ici_episodes.segment_squares(s, lam, gamma, min_segment=shortest, guard=guard)
    edges = [0, *cuts, s.size]
    w = ici_episodes.clip_squares(s, guard)
    out = []
    for q, cut in enumerate(cuts):
        before = float(np.mean(s[edges[q] : cut]))
        after = float(np.mean(s[cut : edges[q + 2]]))
        z = ici_episodes.cusum_z(w[edges[q] : edges[q + 2]], cut - edges[q], lam)
        out.append((cut * r + m, after > before, after / before if before > 0 else math.inf, z))
    return out


def long_tau_changes(
    data: Sequence[float] | np.ndarray,
    *,
    rate: float = 1.0,
    tau0: float | None = None,
    t0: float = 0.0,
    gamma: float = ICI_GAMMA,
    taus: Sequence[float] | None = None,
) -> LongTauChanges:
    """Changes of the Allan variance at long averaging times (module notes).

    Parameters
    ----------
    data : array_like
        Rate samples (in memory).
    rate : float
        Sample rate (Hz), or give ``tau0``.
    tau0 : float, optional
        Sample interval (s).
    t0 : float
        Time of the first sample (s).
    gamma : float
        Test level (``2 Phi(-gamma)`` over all the factors, as the ICI's).
    taus : sequence of float, optional
        Averaging times (s) to scan instead of the octaves from ``16 tau0`` (rounded to
        whole factors of at least 2, each with at least 64 non-overlapping differences).

    Returns
    -------
    LongTauChanges

    Raises
    ------
    AdavarInputError
        Bad ``gamma`` or ``taus``, or a record too short for any factor.
    """
    dt = resolve_tau0(rate, tau0)
    try:
        g = float(gamma)
    except (TypeError, ValueError):
        g = math.nan
    if not (math.isfinite(g) and g > 0):
        raise AdavarInputError(f"gamma must be a positive number, got {gamma!r}")
    x = np.ascontiguousarray(as_samples(data, min_length=4), dtype=np.float64)
    n = x.size
    longest = n // _MIN_DIFFERENCES
    if taus is None:
        ms = [int(2**k) for k in range(4, 63) if LONG_TAU_MIN_M <= 2**k <= longest]
    else:
        try:
            asked = np.asarray(taus, dtype=float).ravel()
        except (TypeError, ValueError):
            asked = np.array([math.nan])
        if asked.size == 0 or not np.all(np.isfinite(asked)) or np.any(asked <= 0):
            raise AdavarInputError(f"taus must be positive averaging times (s), got {taus!r}")
        ms = sorted({max(2, round(v / dt)) for v in asked.tolist()})
        ms = [m for m in ms if m <= longest]
    if not ms:
        raise AdavarInputError(
            f"the record ({n} samples) is too short for a long-tau scan: it needs at least "
            f"{LONG_TAU_SAMPLES} samples (64 differences of 16 samples), or give taus= "
            "factors it holds 64 times"
        )
    excess = ici_episodes.excess_kurtosis(x)
    p = 2.0 * float(ndtr(-g)) / len(ms)
    cuts = []
    for m in ms:
        cuts += [(sample, m, *rest) for sample, *rest in _factor_cuts(x, m, p, excess)]
    cuts.sort(key=lambda c: (c[0], c[1]))
    changes: list[LongTauChange] = []
    for sample, m, rise, ratio, z in cuts:
        change = LongTauChange(time_s=float(t0 + sample * dt), sample=int(sample),
                               tau_s=float(m * dt), rise=bool(rise), ratio=float(ratio),
                               statistic=float(z))  # fmt: skip
        if changes and changes[-1].rise == change.rise:  # a run in one direction: one change
            if change.statistic > changes[-1].statistic:
                changes[-1] = change
            continue
        changes.append(change)
    parameters = dict(gamma=g, ms=ms, excess_kurtosis=float(excess), rate=1.0 / dt, t0=float(t0))
    return LongTauChanges(changes=tuple(changes), taus=np.asarray(ms, dtype=float) * dt,
                          parameters=parameters)  # fmt: skip

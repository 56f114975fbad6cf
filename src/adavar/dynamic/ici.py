"""The adaptive window by intersecting confidence intervals (ICI): docs/method.md section 11.

For every centre ``p`` the rule looks at a fixed, short list of candidate windows of growing
length ``L_1 < ... < L_J`` that all hold ``p``, and their estimates of the local noise level:
the log of the window's overlapping Allan variance at the short averaging factors ``m``
(default ``m = 1``, the white-noise level N). Each estimate has a confidence interval

    ``D_j = [log v_j - log(chi2_{1-q}(nu_j) / nu_j), log v_j - log(chi2_q(nu_j) / nu_j)]``,

``q = Phi(-gamma)``, with ``nu_j`` the equivalent degrees of freedom of that window's
variance. The adapted window is the longest ``L_j`` whose interval meets all the shorter
ones, ``max_{i <= j} lo_i <= min_{i <= j} hi_i`` (Goldenshluger and Nemirovski 1997,
Katkovnik 1999): while the windows see one level their estimates agree within their
intervals; the first window that reaches a change is biased by more than its interval and
the growth stops there. For a centred window the two halves of each candidate (``L_j / 2``
samples before and after ``p``) enter the chain before it: a change inside the window sets
them apart even where the neighbouring lengths agree. A window never shorter than ``lmin``
is returned: candidates below it (``probes``) only sharpen the test near the centre.

One-sided windows. A centred window over a change is biased whatever its length, so the rule
also grows, with its own probes, a window that ends at ``p`` (``left``) and one that starts
there (``right``), and keeps the side with the longest adapted window (ties: the centred
one). Where the left and right windows tie but disagree (their intervals do not meet), the
change lies between them: the side facing away from it is kept, the change located at the
largest standardised contrast of the two within that run of centres. The chosen window is
handed to :func:`adavar.davar` as a centred window at a shifted centre (``shift``).

Changes (``episodes``, default). Where the left and right ``lmax`` windows disagree the
level changed within ``lmax``; each run of such centres is an episode whose region is
segmented into steps and ramps, and the centres a ramp reaches get the window of least
error under the fitted ramp (:mod:`adavar.dynamic.ici_episodes`). Without ``episodes`` (the rule
before 0.3) a change is reported where the two windows disagree most (a moving two-sample
contrast, its largest value within ``lmax / 2``).

EDF. ``edf="correlation"`` (default) takes the record's short-range correlation into
account: for a Gaussian sequence of second differences with autocorrelation ``rho_k``, the
mean of ``n`` of their squares has ``nu = n / sum_{|k| < n} (1 - |k|/n) rho_k**2`` degrees
of freedom; ``rho`` is measured on the whole record (lags up to ``2m + 64``; on its first
``edf_samples`` with that option, what a live pass knows). On white rate
noise at ``m = 1`` that is ``nu = 2n/3`` (267 for ``L = 400`` in simulation, where the
Greenhall EDF of the engine gives 312); on a sensor's band-limited noise it is smaller
still. ``edf="engine"`` uses :func:`adavar.dynamic.surface_common.edf_table` with the record's noise
type. With ``kurtosis`` (default) either is scaled by the record's robust excess kurtosis ``e``,
``nu = 2n / (2n / nu_G + e)`` (:mod:`adavar.dynamic.ici_episodes`): heavy tails widen the intervals.

Cost: one call of the DAVAR engine per (side, candidate length) and per centred half, O(N)
each: O(N J) in all (7 candidates, 1.44e6 samples: 7.7 s on 2 cores, 3x the kurtosis
controller), and O(N M) memory; with ``episodes`` and ``step > 1`` the ``lmax`` windows of
every centre once more (the episodes are those of every centre, as live), and O(n log n) per
episode region. The engine works in units of :func:`ici_block` centres
aligned on centre 0, which makes every value independent of how much of the record is
known: :class:`adavar.OnlineAdaptive` (``method="ici"``, :mod:`adavar.dynamic.online_ici`)
repeats the schedule bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.special import ndtr

from adavar._kernels import differences as diff
from adavar._kernels.window_engine import window_variance
from adavar.core.errors import AdavarInputError
from adavar.core.inputs import as_samples
from adavar.core.settings import ICI_EDF, ICI_GAMMA, ICI_SIDES
from adavar.dynamic import ici_episodes as episodes_mod
from adavar.dynamic.surface_common import edf_table
from adavar.stats import edf as edf_mod
from adavar.stats.statistics import record_noise_types

__all__ = [
    "ICI_EDF",
    "ICI_GAMMA",
    "ICI_PROBES",
    "ICI_SIDES",
    "ICI_STEPS",
    "IciNoise",
    "IciOptions",
    "IciSchedule",
    "IciStats",
    "change_reach",
    "correlation_edf",
    "ici_block",
    "ici_candidates",
    "ici_centre_stats",
    "ici_contrast",
    "ici_edf",
    "ici_noise",
    "ici_options",
    "ici_schedule",
    "ici_side_parts",
    "ici_split",
    "region_changes",
    "settle_ties",
    "side_shift",
    "side_windows",
    "track_ramps",
]

#: default number of probe lengths below lmin (each half the next)
ICI_PROBES = 3
#: default number of steps from lmin to lmax (geometric)
ICI_STEPS = 3
#: extra lags of the correlation EDF beyond the ``2m`` of the second differences themselves
_EXTRA_LAGS = 64
#: side codes in :attr:`IciSchedule.side`
LEFT, CENTRED, RIGHT = -1, 0, 1


def side_shift(side: int, length: Any) -> Any:
    """Offset from ``p`` of the centre of a window of ``length`` on ``side`` of ``p``.

    With the window convention of :mod:`adavar.dynamic.windows`: ``left`` (-1) ends at ``p``
    (``-(L // 2)``), ``right`` (+1) starts at ``p`` (``(L - 1) // 2``), centred (0): 0.

    Parameters
    ----------
    side : {-1, 0, 1}
        Left, centred or right.
    length : int or ndarray of int
        Window lengths.

    Returns
    -------
    int or ndarray of int
    """
    if side == LEFT:
        return -(length // 2)
    if side == RIGHT:
        return (length - 1) // 2
    return 0 * length


def ici_candidates(
    lmin: int, lmax: int, *, probes: int = ICI_PROBES, steps: int = ICI_STEPS
) -> np.ndarray:
    """The default candidate lengths: probes below ``lmin``, then ``lmin`` .. ``lmax``.

    ``steps`` geometric steps from ``lmin`` to ``lmax`` and ``probes`` lengths below
    ``lmin``, each half the next; every length of ``lmax``'s parity, at least 8 samples,
    distinct.

    Parameters
    ----------
    lmin, lmax : int
        Shortest and longest returned window.
    probes : int
        Lengths below ``lmin`` (consistency checks only).
    steps : int
        Steps from ``lmin`` to ``lmax`` (0: ``lmax`` alone when ``lmin == lmax``).

    Returns
    -------
    ndarray of int64, increasing
    """
    if lmin > lmax:
        raise AdavarInputError(f"lmin ({lmin}) must not exceed lmax ({lmax})")
    parity = lmax % 2
    main = np.geomspace(lmin, lmax, max(1, int(steps)) + 1) if lmax > lmin else [lmax]
    low = [lmin / 2.0**k for k in range(int(probes), 0, -1)]
    values = [2 * math.floor(v / 2) + parity for v in (*low, *main)]
    values[-1] = lmax
    values = [v for v in values if v >= 8]
    return np.unique(np.clip(np.asarray(values, dtype=np.int64), 8, lmax))


@dataclass(frozen=True)
class IciSchedule:
    """The ICI rule's windows and what it saw.

    Attributes
    ----------
    window : ndarray of int64, shape (T,)
        Window length at each centre (at least ``lmin``).
    shift : ndarray of int64, shape (T,)
        Offset of each window's centre from the centre (0 centred; see :func:`side_shift`).
    side : ndarray of int8, shape (T,)
        -1 left (the window ends at the centre), 0 centred, 1 right (it starts there).
    adapted : ndarray of int64, shape (3, T)
        The adapted length of the left, centred and right windows (the longest candidate
        consistent with all shorter ones; may be a probe below ``lmin``; 0 where that side
        was not run).
    conflict : ndarray of bool, shape (T,)
        The left and right adapted windows disagree (their intervals do not meet).
    changes : ndarray of int64
        Sample index of each detected step of the level (``sides="both"`` only; empty
        otherwise): with ``episodes`` (default) located by segmenting each episode of
        disagreeing ``lmax`` windows (:mod:`adavar.dynamic.ici_episodes`; ramps are in ``ramps``);
        without, a centre where the left and right ``lmax`` windows disagree (intervals
        apart) and their standardised contrast is the largest within ``lmax / 2`` samples
        either side.
    centre : ndarray of int64, shape (T,)
        Sample index of each centre.
    lengths : ndarray of int64
        The candidate lengths.
    ms : ndarray of int64
        The averaging factors of the estimates.
    edf : ndarray, shape (J, M)
        Degrees of freedom of each candidate's estimate.
    gamma : float
    parameters : dict
    ramps : ndarray of int64, shape (K, 2)
        First and last sample of each gradual change (``episodes`` only; module notes).
    episodes : tuple of adavar.dynamic.ici_episodes.Episode
        The located steps and ramps (``episodes`` only).
    """

    window: np.ndarray
    shift: np.ndarray
    side: np.ndarray
    adapted: np.ndarray
    conflict: np.ndarray
    changes: np.ndarray
    centre: np.ndarray
    lengths: np.ndarray
    ms: np.ndarray
    edf: np.ndarray
    gamma: float
    parameters: dict[str, Any] = field(default_factory=dict)
    ramps: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    episodes: tuple = ()


def _check_options(
    lmin: int, lmax: int, lengths: Any, taus: Any, gamma: Any, sides: str, edf: str
) -> tuple[np.ndarray, np.ndarray, float]:
    if sides not in ICI_SIDES:
        raise AdavarInputError(f"unknown ici_sides {sides!r}: use 'both' or 'centred'")
    if edf not in ICI_EDF:
        raise AdavarInputError(f"unknown ici_edf {edf!r}: use 'correlation' or 'engine'")
    try:
        g = float(gamma)
    except (TypeError, ValueError):
        g = math.nan
    if not (math.isfinite(g) and g > 0):
        raise AdavarInputError(f"ici_gamma must be a positive number, got {gamma!r}")
    try:
        ms = np.unique(np.asarray(taus, dtype=np.int64).ravel())
    except (TypeError, ValueError):
        ms = np.zeros(0, dtype=np.int64)
    if ms.size == 0 or ms[0] < 1 or not np.all(np.asarray(taus, dtype=float) == np.asarray(
            taus, dtype=np.int64)):  # fmt: skip
        raise AdavarInputError(
            f"ici_taus must be averaging factors m >= 1 (whole numbers), got {taus!r}"
        )
    if lengths is None:
        cand = ici_candidates(lmin, lmax)
    else:
        try:
            arr = np.asarray(lengths, dtype=float).ravel()
        except (TypeError, ValueError):
            arr = np.zeros(0)
        if arr.size == 0 or not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
            raise AdavarInputError(f"ici_lengths must be whole numbers of samples, got {lengths!r}")
        cand = np.unique(arr.astype(np.int64))
        if cand[-1] != lmax or not np.any(cand == lmin):
            raise AdavarInputError(
                f"ici_lengths must hold lmin ({lmin}) and end at lmax ({lmax}); lengths "
                f"below lmin are probes: got {cand.tolist()}"
            )
    short = int(3 * ms[-1])
    if cand[0] < short:
        raise AdavarInputError(
            f"the shortest ICI candidate ({int(cand[0])} samples) must hold 3 m = {short} "
            "samples: give longer ici_lengths or smaller ici_taus"
        )
    return cand, ms, g


def _second_differences(x: np.ndarray, m: int) -> np.ndarray:
    """``d_m[i] = sum(x[i+m : i+2m]) - sum(x[i : i+m])`` from lag-``m`` differences first
    (no offset enters the sums)."""
    e = x[m:] - x[:-m]
    if m == 1:
        return e
    c = np.concatenate(([0.0], np.cumsum(e)))
    return c[m:] - c[:-m]


def _difference_rho(x: np.ndarray, m: int) -> np.ndarray:
    """Autocorrelation of ``d_m`` at lags 1 .. ``2m + 64`` (mean removed; lags beyond
    ``2m - 1`` within 3 standard errors of 0 set to 0)."""
    d = _second_differences(x, m)
    d = d - d.mean()
    var = float(np.dot(d, d))
    lags = min(2 * m + _EXTRA_LAGS, d.size - 1)
    if not var > 0.0 or lags < 1:
        return np.zeros(0)
    rho = np.array([np.dot(d[:-k], d[k:]) / var for k in range(1, lags + 1)])
    rho *= d.size / (d.size - np.arange(1, lags + 1))
    k = np.arange(1, lags + 1)
    return np.where((k < 2 * m) | (np.abs(rho) > 3.0 / math.sqrt(d.size)), rho, 0.0)


def correlation_edf(x: np.ndarray, lengths: np.ndarray, ms: np.ndarray) -> np.ndarray:
    """EDF of the window AVAR from the record's correlation of its second differences.

    ``nu(L, m) = n / sum_{|k| < n} (1 - |k| / n) rho_k**2``, ``n = L - 2m + 1``, with
    ``rho_k`` the autocorrelation of ``d_m`` on the whole record (mean removed; lags up to
    ``2m + 64``, lags beyond ``2m - 1`` whose correlation is within 3 standard errors of 0
    counted as 0). Gaussian noise: :func:`ici_noise` scales it by the record's kurtosis.

    Parameters
    ----------
    x : ndarray
        Rate samples.
    lengths : ndarray of int, shape (J,)
        Window lengths.
    ms : ndarray of int, shape (M,)
        Averaging factors.

    Returns
    -------
    ndarray, shape (J, M)
    """
    return _edf_of_rho([_difference_rho(x, int(m)) for m in ms], lengths, ms)


def _edf_of_rho(rhos: list, lengths: np.ndarray, ms: np.ndarray) -> np.ndarray:
    """:func:`correlation_edf` from the autocorrelation of ``d_m`` of each ``m``."""
    out = np.empty((lengths.size, ms.size))
    for t, m in enumerate(ms):
        rho = rhos[t]
        for j, L in enumerate(lengths):
            n = int(L) - 2 * int(m) + 1
            k = np.arange(1, min(rho.size, n - 1) + 1)
            c = 1.0 + 2.0 * float(np.sum((1.0 - k / n) * rho[: k.size] ** 2))
            out[j, t] = n / c
    return out


def interval_offsets(nu: np.ndarray, gamma: float) -> tuple[np.ndarray, np.ndarray]:
    """``(log(chi2_{1-q}(nu) / nu), log(chi2_q(nu) / nu))``, ``q = Phi(-gamma)``: what the
    interval of a log variance with ``nu`` degrees of freedom subtracts (once per EDF)."""
    q = float(ndtr(-gamma))
    # the chi2 quantiles at 1 - q and q: those of a two-sided interval of confidence 1 - 2q
    upper, lower = edf_mod.chi2_quantiles(nu, 1.0 - 2.0 * q)
    return np.log(upper / nu), np.log(lower / nu)


def _intervals(v: np.ndarray, offsets: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, ...]:
    """Log-domain chi-square interval of each variance ``v`` (:func:`interval_offsets`)."""
    y = np.log(np.maximum(v, np.finfo(float).tiny))
    return y - offsets[0], y - offsets[1]


class _Chain:
    """The intersection rule over one side's candidates, fed in order of length.

    Keeps the running intersection ``[max lo, min hi]`` (per m), whether every interval so
    far meets it, the index of the last candidate that did, and that candidate's interval.
    Entries with ``closes=None`` (the halves of a centred window) enter the intersection
    without being candidates themselves.
    """

    def __init__(self, size: int, n_m: int) -> None:
        self.run_lo = np.full((size, n_m), -np.inf)
        self.run_hi = np.full((size, n_m), np.inf)
        self.alive = np.ones(size, dtype=bool)
        self.index = np.full(size, -1, dtype=np.int64)
        self.sel_lo = np.full((size, n_m), -np.inf)
        self.sel_hi = np.full((size, n_m), np.inf)

    def add(self, lo: np.ndarray, hi: np.ndarray, fits: np.ndarray | None, closes: int | None):
        np.maximum(self.run_lo, lo, out=self.run_lo)
        np.minimum(self.run_hi, hi, out=self.run_hi)
        self.alive &= np.all(self.run_lo <= self.run_hi, axis=1)
        if fits is not None:
            self.alive &= fits
        if closes == 0:  # a fallback interval where even the first window is refused
            self.sel_lo[:], self.sel_hi[:] = lo, hi
        if closes is not None:
            self.index[self.alive] = closes
            self.sel_lo[self.alive] = lo[self.alive]
            self.sel_hi[self.alive] = hi[self.alive]


def ici_block(lmax: int) -> int:
    """Centres per unit of work of the DAVAR engine in the ICI pass (``window_variance``'s
    ``chunk``): half of ``lmax``, within 64 .. 4096.

    A window's variance is computed within its unit (a local reference and prefix sums
    over the unit's span), so its value, to the last bit, depends on which centres share
    the unit: units of a fixed size aligned on centre 0 make the estimate of every centre
    independent of how much of the record is known, which is what lets
    :class:`adavar.OnlineAdaptive` repeat the offline decisions. A unit is computed once
    all of its windows are known: half of ``lmax`` keeps that wait below ``lmax / 2``
    while the span (unit plus window) stays at most three times the unit's centres.
    """
    return int(min(4096, max(64, -(-int(lmax) // 2))))


@dataclass(frozen=True)
class IciOptions:
    """The checked options of the ICI rule (:func:`ici_options`)."""

    lmax: int
    lmin: int
    lengths: np.ndarray
    ms: np.ndarray
    gamma: float
    sides: str
    edf: str
    edf_samples: int | None
    kurtosis: bool = True
    episodes: bool = True

    @property
    def halves(self) -> np.ndarray:
        """The half of each candidate (the centred window's two halves)."""
        return self.lengths // 2


def ici_options(
    *,
    lmax: int,
    lmin: int,
    lengths: Sequence[int] | np.ndarray | None = None,
    taus: Sequence[int] = (1,),
    gamma: float = ICI_GAMMA,
    sides: str = "both",
    edf: str = "correlation",
    edf_samples: int | None = None,
    kurtosis: bool = True,
    episodes: bool = True,
) -> IciOptions:
    """The options of :func:`ici_schedule` checked, candidates resolved.

    Raises
    ------
    AdavarInputError
        A bad option (the message names the keyword and what to give).
    """
    for name, value in (("lmax", lmax), ("lmin", lmin)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise AdavarInputError(f"{name} must be a positive whole number, got {value!r}")
    if lmin > lmax:
        raise AdavarInputError(f"lmin ({lmin}) must not exceed lmax ({lmax})")
    if edf_samples is not None and (
        isinstance(edf_samples, bool)
        or not isinstance(edf_samples, (int, np.integer))
        or edf_samples < 2
    ):
        raise AdavarInputError(
            f"ici_edf_samples must be a whole number of samples >= 2 (or None: the whole "
            f"record), got {edf_samples!r}"
        )
    for name, value in (("ici_kurtosis", kurtosis), ("ici_episodes", episodes)):
        if not isinstance(value, (bool, np.bool_)):
            raise AdavarInputError(f"{name} must be True or False, got {value!r}")
    cand, ms, g = _check_options(lmin, lmax, lengths, taus, gamma, sides, edf)
    return IciOptions(
        lmax=int(lmax), lmin=int(lmin), lengths=cand, ms=ms, gamma=g, sides=sides, edf=edf,
        edf_samples=None if edf_samples is None else int(edf_samples),
        kurtosis=bool(kurtosis), episodes=bool(episodes),
    )  # fmt: skip


@dataclass(frozen=True)
class IciStats:
    """What the intersection rule found at each of a run of centres (pointwise).

    Attributes
    ----------
    adapted : ndarray of int64, shape (3, T)
        Adapted length of the left, centred and right windows (0: side not run).
    lo, hi : dict of int to ndarray, shape (T, M)
        Each side's interval of its adapted window.
    last : dict of int to tuple
        ``sides="both"``: the left and right ``lmax`` windows' ``(lo, hi)``.
    """

    adapted: np.ndarray
    lo: dict[int, np.ndarray]
    hi: dict[int, np.ndarray]
    last: dict[int, tuple[np.ndarray, np.ndarray]]


def ici_centre_stats(
    ext: np.ndarray,
    offset: int,
    centres: np.ndarray,
    options: IciOptions,
    nu: np.ndarray,
    nu_half: np.ndarray,
    *,
    n_samples: int | None = None,
) -> IciStats:
    """The intersection rule at ``centres`` (pointwise: each centre on its own).

    Parameters
    ----------
    ext : ndarray of float64
        Samples (mirror-extended) holding every candidate window of every centre.
    offset : int
        Index in ``ext`` of sample 0 of the record.
    centres : ndarray of int64
        Consecutive centres of the pass, starting at a multiple of :func:`ici_block`
        centres from its first one (the engine's units then hold the same centres whatever
        part of the record is given, and the values are those of the whole pass, bit for
        bit).
    options : IciOptions
    nu, nu_half : ndarray, shape (J, M)
        EDF of each candidate and of its half.
    n_samples : int, optional
        Length of the record for ``edges="valid"`` (only windows inside it are candidates);
        None: mirror.

    Returns
    -------
    IciStats
    """
    cand, ms, g = options.lengths, options.ms, options.gamma
    block = ici_block(options.lmax)
    # the chi-square quantiles once per EDF row (the same numbers as per call, bit for bit)
    off, off_half = interval_offsets(nu, g), interval_offsets(nu_half, g)
    halves = options.halves
    side_list = (CENTRED,) if options.sides == "centred" else (LEFT, CENTRED, RIGHT)

    def interval(at: np.ndarray, length: int, offsets: tuple) -> tuple:
        """The log-domain interval of the windows of ``length`` centred at ``at``, and
        whether each window lies where it may (edges="valid": inside the record)."""
        v = window_variance(ext, ms, at, np.full(at.size, length, dtype=np.int64),
                            stat="oavar", offset=offset, chunk=block)  # fmt: skip
        lo_, hi_ = _intervals(v, (offsets[0][None, :], offsets[1][None, :]))
        if n_samples is None:
            return lo_, hi_, None
        start = at - (length - 1) // 2
        return lo_, hi_, (start >= 0) & (start + length <= n_samples)

    # each side's chain, in order of length, kept as a running intersection (O(T M) memory)
    chains = {s: _Chain(centres.size, ms.size) for s in side_list}
    last: dict[int, tuple] = {}
    for j, L in enumerate(int(v) for v in cand):
        for s in side_list:
            chain = chains[s]
            if s == CENTRED and halves[j] >= 3 * ms[-1]:
                # the centred window must also agree with its own two halves (a change
                # inside it sets them apart even where the neighbouring lengths agree)
                h = int(halves[j])
                for at in (centres + side_shift(LEFT, h), centres + 1 + side_shift(RIGHT, h)):
                    chain.add(*interval(at, h, (off_half[0][j], off_half[1][j])), closes=None)
            entry = interval(centres + side_shift(s, L), L, (off[0][j], off[1][j]))
            chain.add(*entry, closes=j)
            if j == cand.size - 1 and s != CENTRED:
                last[s] = entry[:2]
    adapted = np.zeros((3, centres.size), dtype=np.int64)
    for s in side_list:
        index = chains[s].index
        adapted[s + 1] = np.where(index >= 0, cand[np.maximum(index, 0)], 0)
    return IciStats(
        adapted=adapted, lo={s: chains[s].sel_lo for s in side_list},
        hi={s: chains[s].sel_hi for s in side_list}, last=last,
    )  # fmt: skip


@dataclass(frozen=True)
class IciNoise:
    """What the ICI rule measures on the record (or its first ``edf_samples``) once.

    Attributes
    ----------
    nu, nu_half : ndarray, shape (J, M)
        EDF of each candidate's estimate and of its half (with ``kurtosis``: scaled by the
        record's excess kurtosis, :func:`adavar.dynamic.ici_episodes.kurtosis_edf`).
    excess : float
        The record's robust excess kurtosis (0 without ``kurtosis``).
    dispersion : float
        Long-run variance of the squared first differences over their squared mean,
        ``lambda_G + excess`` (3 on white Gaussian noise): the ramps' likelihood.
    clipped : float
        The same of the clipped squares: the segmentation's CUSUM.
    """

    nu: np.ndarray
    nu_half: np.ndarray
    excess: float
    dispersion: float
    clipped: float


def ici_noise(x: np.ndarray, options: IciOptions) -> IciNoise:
    """The EDF and dispersions of the ICI rule on ``x`` (its first ``edf_samples``).

    ``edf="correlation"``: :func:`correlation_edf` on the first ``edf_samples`` samples
    of ``x`` (all of them when None); ``"engine"``: the Greenhall EDF for the noise type
    identified on the whole of ``x``. With ``kurtosis`` both are scaled by the excess
    kurtosis of the same samples (:mod:`adavar.dynamic.ici_episodes`: heavy tails widen the
    intervals).
    """
    cand, ms = options.lengths, options.ms
    head = x if options.edf_samples is None else x[: options.edf_samples]
    wanted = {1, *ms.tolist()} if options.edf == "correlation" else {1}
    rhos = {int(m): _difference_rho(head, int(m)) for m in sorted(wanted)}  # each once
    if options.edf == "correlation":
        per_m = [rhos[int(m)] for m in ms]
        nu, nu_half = _edf_of_rho(per_m, cand, ms), _edf_of_rho(per_m, options.halves, ms)
    else:
        phase = diff.anchored_phase(x, cluster_stats=True)
        alpha, _ = record_noise_types(phase, ms, 2, data_type="rate")
        alpha = np.asarray(alpha, dtype=np.int64)
        nu, nu_half = edf_table(cand, ms, alpha), edf_table(options.halves, ms, alpha)
    excess = episodes_mod.excess_kurtosis(head) if options.kurtosis else 0.0
    if excess > 0.0:
        nu = episodes_mod.kurtosis_edf(nu, cand, ms, excess)
        nu_half = episodes_mod.kurtosis_edf(nu_half, options.halves, ms, excess)
    rho = rhos[1]
    gaussian = 2.0 * (1.0 + 2.0 * float(np.sum(rho**2)))
    clipped = episodes_mod.clipped_dispersion(head, rho)
    if not options.kurtosis:  # the Gaussian dispersion of the squares, clipped or not
        clipped = gaussian
    return IciNoise(nu=nu, nu_half=nu_half, excess=float(excess),
                    dispersion=gaussian + float(excess), clipped=float(clipped))  # fmt: skip


def ici_edf(x: np.ndarray, options: IciOptions) -> tuple[np.ndarray, np.ndarray]:
    """EDF of each candidate and of its half, ``(nu, nu_half)``, shapes (J, M)
    (:func:`ici_noise`)."""
    noise = ici_noise(x, options)
    return noise.nu, noise.nu_half


def ici_schedule(
    x: np.ndarray,
    *,
    lmax: int,
    lmin: int,
    lengths: Sequence[int] | np.ndarray | None = None,
    taus: Sequence[int] = (1,),
    gamma: float = ICI_GAMMA,
    sides: str = "both",
    edf: str = "correlation",
    edges: str = "mirror",
    step: int = 1,
    edf_samples: int | None = None,
    kurtosis: bool = True,
    episodes: bool = True,
) -> IciSchedule:
    """The ICI adaptive window of every centre (module notes).

    Parameters
    ----------
    x : ndarray of float64
        The rate samples (in memory; at least ``lmax``).
    lmax, lmin : int
        Longest and shortest returned window (samples).
    lengths : sequence of int, optional
        Candidate lengths, increasing; must hold ``lmin`` and end at ``lmax``; those below
        ``lmin`` are probes (consistency checks only). Default :func:`ici_candidates`:
        3 probes (``lmin/8``, ``lmin/4``, ``lmin/2``) and 3 geometric steps to ``lmax``.
    taus : sequence of int
        Averaging factors of the estimates (default ``(1,)``: the white-noise level); with
        several, a candidate must agree at every one.
    gamma : float
        Half-width of the intervals in standard normal units (``q = Phi(-gamma)`` in each
        tail of the chi-square). Default :data:`ICI_GAMMA`.
    sides : {"both", "centred"}
        ``"both"``: left, centred and right windows (module notes); ``"centred"``: centred
        windows only.
    edf : {"correlation", "engine"}
        Degrees of freedom of each estimate: from the record's correlation (default) or the
        engine's Greenhall EDF for the record's noise type
        (:func:`adavar.dynamic.surface_common.edf_table`).
    edges : {"mirror", "valid"}
        ``"mirror"``: every centre, windows reaching into the time-reversed ends;
        ``"valid"``: the centres whose centred ``lmax`` window fits, and only candidate
        windows inside the record.
    step : int
        Every ``step``-th centre (the rule is pointwise: only those are computed).
    edf_samples : int, optional
        ``edf="correlation"``: measure the correlation on the first ``edf_samples``
        samples only (what a live pass knows, :class:`adavar.OnlineAdaptive`); default
        None: the whole record.
    kurtosis : bool
        Scale the EDF by the record's robust excess kurtosis (default; heavy-tailed noise
        gets wider intervals, :mod:`adavar.dynamic.ici_episodes`). False: the Gaussian EDF (the
        behaviour before 0.3, 4.8 false changes an hour on Student-t noise at 100 Hz).
    episodes : bool
        Locate the changes by segmenting each episode of disagreeing ``lmax`` windows,
        report gradual changes as ramps and give the centres a ramp reaches the window of
        least error under the fitted ramp (default; :mod:`adavar.dynamic.ici_episodes`). False: a
        change at the largest contrast of the ``lmax`` windows within ``lmax / 2`` (the
        behaviour before 0.3: a staircase of changes on a ramp, changes up to ``lmax``
        away from a short burst).

    Returns
    -------
    IciSchedule

    Raises
    ------
    AdavarInputError
        Bad options (the message names the keyword and what to give).
    """
    if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or step < 1:
        raise AdavarInputError(f"step must be a positive whole number, got {step!r}")
    if edges not in ("mirror", "valid"):
        raise AdavarInputError(f"unknown edges {edges!r}: use 'mirror' or 'valid'")
    opts = ici_options(lmax=lmax, lmin=lmin, lengths=lengths, taus=taus, gamma=gamma,
                       sides=sides, edf=edf, edf_samples=edf_samples, kurtosis=kurtosis,
                       episodes=episodes)  # fmt: skip
    cand, ms, g = opts.lengths, opts.ms, opts.gamma
    x = np.ascontiguousarray(as_samples(x, min_length=lmax), dtype=np.float64)
    n = x.size
    first = (lmax - 1) // 2 if edges == "valid" else 0
    n_c = n - lmax + 1 if edges == "valid" else n
    c0 = -(-first // step) * step
    centres = np.arange(c0, first + n_c, step, dtype=np.int64)
    noise = ici_noise(x, opts)
    nu, nu_half = noise.nu, noise.nu_half
    pad = lmax
    ext = np.pad(x, pad, mode="symmetric")
    stats = ici_centre_stats(ext, pad, centres, opts, nu, nu_half,
                             n_samples=n if edges == "valid" else None)  # fmt: skip
    adapted = stats.adapted
    side = np.zeros(centres.size, dtype=np.int8)
    conflict = np.zeros(centres.size, dtype=bool)
    changes = np.zeros(0, dtype=np.int64)
    found: list = []
    if sides == "both" and opts.episodes:
        side, conflict = _choose_sides(adapted, stats.lo, stats.hi)
        split, _ = ici_contrast(*stats.last[LEFT], *stats.last[RIGHT])
        every = centres
        if step > 1:  # the episodes from every centre's flag, as the live pass sees them
            every = np.arange(first, first + n_c, dtype=np.int64)
            split, _ = ici_split(ext, pad, every, opts, nu)
        found = region_changes(x, every, split, opts, noise)
        changes = np.array([e.start for e in found if not e.ramp], dtype=np.int64)
    elif sides == "both":
        side, conflict = _choose_sides(adapted, stats.lo, stats.hi)
        # a change: where the left and right lmax windows disagree most (the two-sample
        # moving-window contrast peaks at a change), the largest within lmax / 2 either side
        split, contrast = ici_contrast(*stats.last[LEFT], *stats.last[RIGHT])
        reach = change_reach(lmax, step)
        from scipy.ndimage import maximum_filter1d  # here: 0.1 s of import the rest skips

        top = maximum_filter1d(contrast, size=2 * reach + 1, mode="nearest")
        peak = split & (contrast >= top)
        peak[1:] &= ~peak[:-1]  # a flat top counts once
        changes = centres[peak]
    window, shift = side_windows(adapted, side, lmin)
    ramps = [e for e in found if e.ramp]
    models = [m for m in (episodes_mod.ramp_model(e, lmax, lmin // 2) for e in ramps) if m]
    if models:
        track_ramps(centres, window, shift, side, models, opts, nu)
    parameters = dict(
        method="ici", lmax=int(lmax), lmin=int(lmin), ici_lengths=cand.tolist(),
        ici_taus=ms.tolist(), ici_gamma=g, ici_sides=sides, ici_edf=edf, edges=edges,
        ici_edf_samples=opts.edf_samples, ici_kurtosis=opts.kurtosis,
        ici_episodes=opts.episodes, ici_excess_kurtosis=noise.excess,
        ici_ramps=[[e.start, e.end] for e in ramps],
        ici_rises=[bool(e.rise) for e in found if not e.ramp] if opts.episodes else None,
        ici_found=[e.as_dict() for e in found] if opts.episodes else None,
    )  # fmt: skip
    return IciSchedule(
        window=window, shift=shift, side=side, adapted=adapted, conflict=conflict,
        changes=changes, centre=centres, lengths=cand, ms=ms, edf=nu, gamma=g,
        parameters=parameters,
        ramps=np.array([[e.start, e.end] for e in ramps], dtype=np.int64).reshape(-1, 2),
        episodes=tuple(found),
    )  # fmt: skip


def region_changes(
    x: np.ndarray, centres: np.ndarray, split: np.ndarray, options: IciOptions, noise: IciNoise
) -> list:
    """The episodes (:class:`adavar.dynamic.ici_episodes.Episode`) of the split centres of a whole
    record: each region segmented, grown while it ends in a ramp, the next starting where
    it ended (:mod:`adavar.dynamic.ici_episodes`)."""
    n, lmax = x.size, options.lmax
    keywords = dict(dispersion=noise.dispersion, clipped=noise.clipped, gamma=options.gamma)
    found: list = []
    end = 0
    for _, _, a, b in episodes_mod.episode_regions(split, centres, lmax, n):
        a = max(a, end)
        if a >= b:
            continue
        here = episodes_mod.find_episodes(x[a:b], a, **keywords)
        while (grown := episodes_mod.grown_end(here, b, lmax, n)) is not None:
            b = grown
            here = episodes_mod.find_episodes(x[a:b], a, **keywords)
        found += here
        end = b
    return found


def ici_split(
    ext: np.ndarray, offset: int, centres: np.ndarray, options: IciOptions, nu: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`ici_contrast` of the ``lmax`` windows ending and starting at each centre (are
    they apart, their standardised contrast), as :func:`ici_centre_stats` finds them (bit
    for bit: the same engine units when ``centres`` starts where that pass's do)."""
    j, length = options.lengths.size - 1, options.lmax
    off = interval_offsets(nu, options.gamma)
    entries = []
    for s in (LEFT, RIGHT):
        v = window_variance(ext, options.ms, centres + side_shift(s, length),
                            np.full(centres.size, length, dtype=np.int64), stat="oavar",
                            offset=offset, chunk=ici_block(options.lmax))  # fmt: skip
        entries.append(_intervals(v, (off[0][j][None, :], off[1][j][None, :])))
    return ici_contrast(*entries[0], *entries[1])


def track_ramps(
    centres: np.ndarray, window: np.ndarray, shift: np.ndarray, side: np.ndarray,
    models: list, options: IciOptions, nu: np.ndarray,
) -> None:  # fmt: skip
    """In place: the windows of least error of the centres the ramps reach
    (:func:`adavar.dynamic.ici_episodes.ramp_windows` of the
    :func:`~adavar.dynamic.ici_episodes.ramp_model` of each ramp; candidates of at least
    ``lmin``)."""
    keep = options.lengths >= options.lmin
    episodes_mod.ramp_windows(centres, window, shift, side, models, options.lengths[keep],
                              nu[keep, 0], options.lmax, side_shift)  # fmt: skip


def change_reach(lmax: int, step: int = 1) -> int:
    """Centres either side within which a change's contrast must be the largest."""
    return max(1, int(lmax) // (2 * int(step)))


def side_windows(adapted: np.ndarray, side: np.ndarray, lmin: int) -> tuple[np.ndarray, ...]:
    """``(window, shift)`` of each centre from the adapted lengths and the chosen side."""
    chosen = np.take_along_axis(adapted, (side.astype(np.int64) + 1)[None, :], axis=0)[0]
    window = np.maximum(chosen, lmin)
    shift = np.zeros(side.size, dtype=np.int64)
    for s in (LEFT, RIGHT):
        here = side == s
        shift[here] = side_shift(s, window[here])
    return window, shift


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` of every run of True in ``flags``."""
    padded = np.concatenate(([0], flags.astype(np.int8), [0]))
    edges = np.diff(padded)
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(),
                    strict=True))  # fmt: skip


def ici_contrast(
    llo: np.ndarray, lhi: np.ndarray, rlo: np.ndarray, rhi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Whether two sets of intervals (T, M) are apart, and the standardised difference of
    their centres at the first m (the half-widths stand in for the standard errors)."""
    apart = np.any((llo > rhi) | (rlo > lhi), axis=1)
    se = np.hypot(lhi[:, 0] - llo[:, 0], rhi[:, 0] - rlo[:, 0])
    diff_ = 0.5 * ((rlo[:, 0] + rhi[:, 0]) - (llo[:, 0] + lhi[:, 0]))
    return apart, np.abs(diff_) / np.maximum(se, np.finfo(float).tiny)


def ici_side_parts(adapted: np.ndarray, lo: dict, hi: dict) -> tuple[np.ndarray, ...]:
    """The pointwise part of the side choice (:func:`_choose_sides`).

    Returns ``(side, tie, conflict, contrast)``: the side of each centre where it is
    decided on its own; ``tie``, the centres where the left and right windows tie but
    disagree, whose side is settled over their run (the change at the largest
    ``contrast`` of the run); ``conflict``, the left and right intervals apart.
    """
    (llo, lhi), (clo, chi_), (rlo, rhi) = ((lo[s], hi[s]) for s in (LEFT, CENTRED, RIGHT))
    conflict, contrast = ici_contrast(llo, lhi, rlo, rhi)
    left, centred, right = adapted
    best = np.maximum(np.maximum(left, right), centred)
    side = np.zeros(adapted.shape[1], dtype=np.int8)
    side[(right == best) & (centred < best)] = RIGHT
    side[(left == best) & (centred < best)] = LEFT
    both = (left == best) & (right == best) & (centred < best)
    # a tie of the two sides: the one the centred window agrees with (it shares half of
    # each), else the one nearer to it; where the two disagree, the contrast rule below
    ly, cy, ry = 0.5 * (llo + lhi), 0.5 * (clo + chi_), 0.5 * (rlo + rhi)
    left_nearer = np.sum(np.abs(ly - cy), axis=1) <= np.sum(np.abs(ry - cy), axis=1)
    side[both & left_nearer] = LEFT
    side[both & ~left_nearer] = RIGHT
    return side, both & conflict, conflict, contrast


def settle_ties(side: np.ndarray, tie: np.ndarray, contrast: np.ndarray) -> None:
    """In place: each run of ``tie`` goes left before its largest ``contrast``, right from
    there (the runs must be whole: a run cut at an end is settled as it is)."""
    for a, b in _runs(tie):
        peak = a + int(np.argmax(contrast[a:b]))
        side[a:peak] = LEFT
        side[peak:b] = RIGHT


def _choose_sides(adapted: np.ndarray, lo: dict, hi: dict) -> tuple[np.ndarray, np.ndarray]:
    """Per centre the side with the longest admissible adapted window (module notes).

    The centred window is admissible where its interval meets those of the left and the
    right adapted windows (it holds both halves, so it must agree with both), and wins its
    ties. Otherwise the longer one-sided window; a left-right tie where the two disagree goes
    to the side away from the change, located at the largest standardised contrast of the
    two windows within the run of such ties.
    """
    side, tie, conflict, contrast = ici_side_parts(adapted, lo, hi)
    settle_ties(side, tie, contrast)
    return side, conflict

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
handed to :func:`adavar.davar` as a centred window at a shifted centre (``shift``). Changes
are reported where the left and right ``lmax`` windows disagree most (a moving two-sample
contrast, its largest value within ``lmax / 2``).

EDF. ``edf="correlation"`` (default) takes the record's short-range correlation into
account: for a Gaussian sequence of second differences with autocorrelation ``rho_k``, the
mean of ``n`` of their squares has ``nu = n / sum_{|k| < n} (1 - |k|/n) rho_k**2`` degrees
of freedom; ``rho`` is measured on the whole record (lags up to ``2m + 64``). On white rate
noise at ``m = 1`` that is ``nu = 2n/3`` (267 for ``L = 400`` in simulation, where the
Greenhall EDF of the engine gives 312); on a sensor's band-limited noise it is smaller
still. ``edf="engine"`` uses :func:`adavar.davar.edf_table` with the record's noise type.

Cost: one call of the DAVAR engine per (side, candidate length) and per centred half, O(N)
each: O(N J) in all (7 candidates, 1.44e6 samples: 7.7 s on 2 cores, 3x the kurtosis
controller), and O(N M) memory.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.ndimage import maximum_filter1d
from scipy.special import ndtr
from scipy.stats import chi2

from adavar import differences as diff
from adavar.davar import edf_table
from adavar.errors import AdavarInputError
from adavar.settings import ICI_EDF, ICI_GAMMA, ICI_SIDES
from adavar.statistics import as_samples, record_noise_types

__all__ = [
    "ICI_EDF",
    "ICI_GAMMA",
    "ICI_PROBES",
    "ICI_SIDES",
    "ICI_STEPS",
    "IciSchedule",
    "ici_candidates",
    "ici_schedule",
    "side_shift",
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

    With the window convention of :mod:`adavar.windows`: ``left`` (-1) ends at ``p``
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
        Sample index of each detected change: a centre where the left and right ``lmax``
        windows disagree (intervals apart) and their standardised contrast is the largest
        within ``lmax / 2`` samples either side (``sides="both"`` only; empty otherwise).
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


def correlation_edf(x: np.ndarray, lengths: np.ndarray, ms: np.ndarray) -> np.ndarray:
    """EDF of the window AVAR from the record's correlation of its second differences.

    ``nu(L, m) = n / sum_{|k| < n} (1 - |k| / n) rho_k**2``, ``n = L - 2m + 1``, with
    ``rho_k`` the autocorrelation of ``d_m`` on the whole record (mean removed; lags up to
    ``2m + 64``, lags beyond ``2m - 1`` whose correlation is within 3 standard errors of 0
    counted as 0).

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
    out = np.empty((lengths.size, ms.size))
    for t, m in enumerate(ms):
        m = int(m)
        d = _second_differences(x, m)
        d = d - d.mean()
        var = float(np.dot(d, d))
        lags = min(2 * m + _EXTRA_LAGS, d.size - 1)
        if not var > 0.0 or lags < 1:
            rho = np.zeros(0)
        else:
            rho = np.array([np.dot(d[:-k], d[k:]) / var for k in range(1, lags + 1)])
            rho *= d.size / (d.size - np.arange(1, lags + 1))
            k = np.arange(1, lags + 1)
            rho = np.where((k < 2 * m) | (np.abs(rho) > 3.0 / math.sqrt(d.size)), rho, 0.0)
        for j, L in enumerate(lengths):
            n = int(L) - 2 * m + 1
            k = np.arange(1, min(rho.size, n - 1) + 1)
            c = 1.0 + 2.0 * float(np.sum((1.0 - k / n) * rho[: k.size] ** 2))
            out[j, t] = n / c
    return out


def _intervals(v: np.ndarray, nu: np.ndarray, gamma: float) -> tuple[np.ndarray, np.ndarray]:
    """Log-domain chi-square interval of each variance ``v`` with ``nu`` degrees of freedom."""
    q = float(ndtr(-gamma))
    y = np.log(np.maximum(v, np.finfo(float).tiny))
    lo = y - np.log(chi2.isf(q, nu) / nu)
    hi = y - np.log(chi2.ppf(q, nu) / nu)
    return lo, hi


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
        engine's Greenhall EDF for the record's noise type (:func:`adavar.davar.edf_table`).
    edges : {"mirror", "valid"}
        ``"mirror"``: every centre, windows reaching into the time-reversed ends;
        ``"valid"``: the centres whose centred ``lmax`` window fits, and only candidate
        windows inside the record.
    step : int
        Every ``step``-th centre (the rule is pointwise: only those are computed).

    Returns
    -------
    IciSchedule

    Raises
    ------
    AdavarInputError
        Bad options (the message names the keyword and what to give).
    """
    for name, value in (("lmax", lmax), ("lmin", lmin), ("step", step)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise AdavarInputError(f"{name} must be a positive whole number, got {value!r}")
    if lmin > lmax:
        raise AdavarInputError(f"lmin ({lmin}) must not exceed lmax ({lmax})")
    if edges not in ("mirror", "valid"):
        raise AdavarInputError(f"unknown edges {edges!r}: use 'mirror' or 'valid'")
    cand, ms, g = _check_options(lmin, lmax, lengths, taus, gamma, sides, edf)
    x = np.ascontiguousarray(as_samples(x, min_length=lmax), dtype=np.float64)
    n = x.size
    first = (lmax - 1) // 2 if edges == "valid" else 0
    n_c = n - lmax + 1 if edges == "valid" else n
    c0 = -(-first // step) * step
    centres = np.arange(c0, first + n_c, step, dtype=np.int64)
    if edf == "correlation":
        nu = correlation_edf(x, cand, ms)
    else:
        phase = diff.anchored_phase(x, cluster_stats=True)
        alpha, _ = record_noise_types(phase, ms, 2, data_type="rate")
        nu = edf_table(cand, ms, np.asarray(alpha, dtype=np.int64))
    alpha = alpha if edf == "engine" else None
    pad = lmax
    ext = np.pad(x, pad, mode="symmetric")
    side_list = (CENTRED,) if sides == "centred" else (LEFT, CENTRED, RIGHT)
    halves = cand // 2
    nu_half = correlation_edf(x, halves, ms) if edf == "correlation" else edf_table(
        halves, ms, np.asarray(alpha, dtype=np.int64))  # fmt: skip

    def interval(at: np.ndarray, length: int, nu_row: np.ndarray) -> tuple:
        """The log-domain interval of the windows of ``length`` centred at ``at``, and
        whether each window lies where it may (edges="valid": inside the record)."""
        v = diff.window_avar(ext, ms, at, np.full(at.size, length, dtype=np.int64), offset=pad)
        lo_, hi_ = _intervals(v, nu_row[None, :], g)
        start = at - (length - 1) // 2
        fits = (start >= 0) & (start + length <= n) if edges == "valid" else None
        return lo_, hi_, fits

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
                    chain.add(*interval(at, h, nu_half[j]), closes=None)
            entry = interval(centres + side_shift(s, L), L, nu[j])
            chain.add(*entry, closes=j)
            if j == cand.size - 1 and s != CENTRED:
                last[s] = entry
    index = {s: chains[s].index for s in side_list}
    lo = {s: chains[s].sel_lo for s in side_list}
    hi = {s: chains[s].sel_hi for s in side_list}
    adapted = np.zeros((3, centres.size), dtype=np.int64)
    for s in side_list:
        adapted[s + 1] = np.where(index[s] >= 0, cand[np.maximum(index[s], 0)], 0)
    side = np.zeros(centres.size, dtype=np.int8)
    conflict = np.zeros(centres.size, dtype=bool)
    changes = np.zeros(0, dtype=np.int64)
    if sides == "both":
        side, conflict = _choose_sides(adapted, lo, hi)
        # a change: where the left and right lmax windows disagree most (the two-sample
        # moving-window contrast peaks at a change), the largest within lmax / 2 either side
        split, contrast = _contrast(last[LEFT][0], last[LEFT][1], last[RIGHT][0],
                                    last[RIGHT][1])  # fmt: skip
        reach = max(1, lmax // (2 * step))
        top = maximum_filter1d(contrast, size=2 * reach + 1, mode="nearest")
        peak = split & (contrast >= top)
        peak[1:] &= ~peak[:-1]  # a flat top counts once
        changes = centres[peak]
    chosen = np.take_along_axis(adapted, (side.astype(np.int64) + 1)[None, :], axis=0)[0]
    window = np.maximum(chosen, lmin)
    shift = np.zeros(centres.size, dtype=np.int64)
    for s in (LEFT, RIGHT):
        here = side == s
        shift[here] = side_shift(s, window[here])
    parameters = dict(
        method="ici", lmax=int(lmax), lmin=int(lmin), ici_lengths=cand.tolist(),
        ici_taus=ms.tolist(), ici_gamma=g, ici_sides=sides, ici_edf=edf, edges=edges,
    )  # fmt: skip
    return IciSchedule(
        window=window, shift=shift, side=side, adapted=adapted, conflict=conflict,
        changes=changes, centre=centres, lengths=cand, ms=ms, edf=nu, gamma=g,
        parameters=parameters,
    )  # fmt: skip


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` of every run of True in ``flags``."""
    padded = np.concatenate(([0], flags.astype(np.int8), [0]))
    edges = np.diff(padded)
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(),
                    strict=True))  # fmt: skip


def _contrast(
    llo: np.ndarray, lhi: np.ndarray, rlo: np.ndarray, rhi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Whether two sets of intervals (T, M) are apart, and the standardised difference of
    their centres at the first m (the half-widths stand in for the standard errors)."""
    apart = np.any((llo > rhi) | (rlo > lhi), axis=1)
    se = np.hypot(lhi[:, 0] - llo[:, 0], rhi[:, 0] - rlo[:, 0])
    diff_ = 0.5 * ((rlo[:, 0] + rhi[:, 0]) - (llo[:, 0] + lhi[:, 0]))
    return apart, np.abs(diff_) / np.maximum(se, np.finfo(float).tiny)


def _choose_sides(adapted: np.ndarray, lo: dict, hi: dict) -> tuple[np.ndarray, np.ndarray]:
    """Per centre the side with the longest admissible adapted window (module notes).

    The centred window is admissible where its interval meets those of the left and the
    right adapted windows (it holds both halves, so it must agree with both), and wins its
    ties. Otherwise the longer one-sided window; a left-right tie where the two disagree goes
    to the side away from the change, located at the largest standardised contrast of the
    two windows within the run of such ties.
    """
    t = np.arange(adapted.shape[1])
    (llo, lhi), (clo, chi_), (rlo, rhi) = ((lo[s], hi[s]) for s in (LEFT, CENTRED, RIGHT))

    conflict, contrast = _contrast(llo, lhi, rlo, rhi)
    left, centred, right = adapted
    best = np.maximum(np.maximum(left, right), centred)
    side = np.zeros(t.size, dtype=np.int8)
    side[(right == best) & (centred < best)] = RIGHT
    side[(left == best) & (centred < best)] = LEFT
    both = (left == best) & (right == best) & (centred < best)
    # a tie of the two sides: the one the centred window agrees with (it shares half of
    # each), else the one nearer to it; where the two disagree, the contrast rule below
    ly, cy, ry = 0.5 * (llo + lhi), 0.5 * (clo + chi_), 0.5 * (rlo + rhi)
    left_nearer = np.sum(np.abs(ly - cy), axis=1) <= np.sum(np.abs(ry - cy), axis=1)
    side[both & left_nearer] = LEFT
    side[both & ~left_nearer] = RIGHT
    both &= conflict
    for a, b in _runs(both):
        peak = a + int(np.argmax(contrast[a:b]))
        side[a:peak] = LEFT
        side[peak:b] = RIGHT
    return side, conflict

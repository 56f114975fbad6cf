"""Changes of the white-noise level seen by the ICI rule: located, classified, tracked.

docs/method.md section 11. The ICI rule (:mod:`adavar.dynamic.ici`) flags the centres where the
``lmax`` windows ending and starting there disagree (they are *split*). A flag says that
the level changed within ``lmax`` samples of the centre, not where or how: on a ramp of the
level the flags stay up all along it (the largest contrast within ``lmax / 2`` then gives a
staircase of changes), and a burst shorter than ``lmax`` flags the ``lmax`` centres before
it and after it alike (changes at random places on those two plateaus).

Episodes. Runs of split centres less than ``lmax`` apart form one episode; its *region* is
the samples within ``lmax`` of its split centres (where the changes that split them lie)
and ``lmax / 4`` more (the level before a change at that edge), starting no earlier than
the previous region ends. A region that ends in a ramp (less than
``lmax`` of level after it) grows by ``lmax`` at a time while it does: along a slow ramp
the far end splits the ``lmax`` windows only here and there.

Segmentation. In a region the squares ``s_i = (x[i+1] - x[i])**2`` (mean ``2 sigma**2``
on white noise) are cut by circular binary segmentation of their CUSUM (Olshen et al.
2004, Biostatistics 5, 557): over a segment of ``n`` squares with bridge ``B_k = S_k -
k S_n / n``, the range ``max B - min B`` in units of ``sqrt(n lambda) S_n / n`` has, while
the level is constant, the Kuiper distribution of the range of a Brownian bridge; above its
``1 - 2q`` point (``q = Phi(-gamma)``, the tail of the ICI intervals, ``gamma`` at least
``SEGMENT_GAMMA``) the segment is cut at the argmin and the argmax of ``B`` (one cut where
the other is at an end: a step; two: a burst or a stretch) and each part is segmented
again. Backward elimination then drops the
cut whose own two-segment CUSUM is smallest while it is below the Kolmogorov ``1 - 2q``
point, and every remaining cut moves to the maximum, between its neighbours, of the
Gaussian likelihood ratio of one change of variance (the CUSUM's extremes sit up to tens of
samples off on a short burst). The squares are clipped at ``CLIP`` times the mean of their
neighbours (3 to ``2 + KURTOSIS_HALF`` places away): one value of a heavy-tailed record then
moves the CUSUM no more than a 4-sigma Gaussian one, while a burst (its neighbours as large)
keeps its weight. ``lambda`` is the long-run variance of
the clipped squares over their squared mean: lags 0 and 1 from the record's locally
standardised squares, further lags from its correlation (``2 rho_k**2``); 3 on white noise.

Ramps. Consecutive cuts in the same direction are a gradual change or a staircase. On
their span (between the neighbouring cuts of the other direction) a ramp is fitted by
maximum likelihood to block means of the squares: level ``a`` up to ``c1``, the noise
amplitude linear from ``sqrt(a)`` to ``sqrt(b)`` over ``c1 .. c2``, ``b`` after (a gamma
likelihood with ``nu_b = 2 b / lambda`` degrees of freedom a block of ``b`` squares), and
compared to the best single step: twice the log-likelihood ratio above ``gamma**2`` makes
the group one ramp, unless the staircase of the group's own cuts (each level the mean of its
squares) beats the ramp by more than ``gamma**2`` for each number it has beyond the ramp's
four (``2k + 1`` for ``k`` cuts; two steps x2 then x1.5 five minutes apart were taken for
one ramp before 0.3.1); otherwise each cut is a step. The step, and the ends of the best ramp,
may fall inside a block (its expected mean is then that of the level over its squares): the
block a step falls in has a mean between the two levels, which a step at a block boundary
misfits by far when the levels are far apart, and a ramp over two blocks passed through it
(before 0.3.0 a x5 burst's edge at 100 Hz, blocks of 3 s, was taken for a ramp).

Windows on a ramp. On a ramp a window ending (or starting) at a centre is biased by half its
length times the slope, a centred one only by the ramp's curvature. For the centres whose
``lmax`` window reaches a ramp (``c1 - lmax/2 .. c2 + lmax/2``) the window (side and
candidate length of at least ``lmin``) that minimises the squared bias of its log variance
under the fitted ramp plus the variance ``2 / nu`` of that log variance replaces the ICI's;
the fitted level is averaged over ``lmin / 2`` samples first (at 1 Hz the fitted ends
scatter by about that much: 20 of 20 records tracked at least as well as both fixed windows,
18 without the averaging).

Kurtosis. The ICI's chi-square intervals assume Gaussian noise. For iid samples of excess
kurtosis ``e`` the mean of ``n`` squared second differences (of ``m``-sums) has the long-run
variance ``(lambda_G + e) mu**2 / n`` (the fourth-cumulant term of the overlapping
differences adds up to ``e`` for every ``m``), so its EDF is ``nu = 2n / (2n / nu_G + e)``,
``nu_G`` the Gaussian EDF (for iid Student-t of 5 degrees of freedom, ``e = 6``: a third
of the white-noise EDF at ``m = 1``). ``e`` is estimated robustly: every first difference
is standardised by the mean square of its neighbours 3 to ``2 + KURTOSIS_HALF`` samples
away (a level change, or a burst longer than about that, is not taken for heavy tails),
the kurtosis ``k`` of the standardised differences is corrected for the scatter of that
local mean, and ``e = 2 (k - 3)`` (the differences of iid samples have half their excess
kurtosis), at least 0.

Every function here reads only the samples it is given and sums sequentially
(``numpy.cumsum``): the live pass (:mod:`adavar.dynamic.online_ici`) repeats the offline results
bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

import numpy as np
from scipy.optimize import brentq
from scipy.special import kolmogi, ndtr

__all__ = [
    "CLIP",
    "KURTOSIS_HALF",
    "SEGMENT_GAMMA",
    "Episode",
    "RampModel",
    "clip_squares",
    "clipped_dispersion",
    "cusum_z",
    "episode_regions",
    "excess_kurtosis",
    "find_episodes",
    "grown_end",
    "kuiper_quantile",
    "kurtosis_edf",
    "local_level",
    "pair_changes",
    "ramp_model",
    "ramp_windows",
    "region_reach",
    "segment_squares",
]

#: squares above this many times their segment's level are clipped in the segmentation
CLIP = 16.0
#: neighbours either side (beyond a guard of 2) whose mean square standardises a difference
KURTOSIS_HALF = 32
#: the first differences within this many samples share a sample with the one standardised
_GUARD = 2
#: at most this many block means in a ramp fit (the block size follows), and coarse grid points
_RAMP_BLOCKS, _RAMP_GRID = 256, 40
#: the shortest segment of the segmentation (squares)
_MIN_SEGMENT = 8
#: the segmentation tests at ``max(gamma, SEGMENT_GAMMA)``: a smaller ICI ``gamma`` makes the
#: windows shrink more readily, not the reported changes more numerous (at 2.5, one x3
#: stretch of scenario 1 in six got a third, spurious change)
SEGMENT_GAMMA = 3.0


@dataclass(frozen=True)
class Episode:
    """One change of the white-noise level (module notes).

    Attributes
    ----------
    start, end : int
        Sample of a step (``end == start``), or the first and last sample of a ramp.
    ramp : bool
        A gradual change from ``start`` to ``end``.
    rise : bool
        The level is higher after it.
    before, after : float
        Mean squared first difference of the segments before and after it (``2 sigma**2``
        on white noise: ``after / before`` is the ratio of the variances).
    statistic : float
        A ramp's log-likelihood ratio over the best single step (``gamma**2`` or more), or
        a step's two-segment CUSUM in units of its null standard deviation.
    """

    start: int
    end: int
    ramp: bool
    rise: bool
    before: float
    after: float
    statistic: float

    def as_dict(self) -> dict[str, Any]:
        """The JSON form (``parameters["ici_found"]`` of a result): every attribute."""
        return {"start": int(self.start), "end": int(self.end), "ramp": bool(self.ramp),
                "rise": bool(self.rise), "before": float(self.before),
                "after": float(self.after), "statistic": float(self.statistic)}  # fmt: skip


# ------------------------------------------------------------------------------- kurtosis


def excess_kurtosis(x: np.ndarray) -> float:
    """Robust excess kurtosis of the rate samples ``x`` (module notes), at least 0.

    Parameters
    ----------
    x : ndarray of float64
        The samples (at least ``4 KURTOSIS_HALF`` of them, else 0 is returned).

    Returns
    -------
    float
        ``e = 2 (k - 3)``, ``k`` the kurtosis of the locally standardised first differences.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.size < 4 * KURTOSIS_HALF:
        return 0.0
    s = np.diff(x) ** 2
    level, count = local_level(s)
    ok = level > 0.0
    if np.count_nonzero(ok) < 2 * KURTOSIS_HALF:
        return 0.0
    z2 = s[ok] / level[ok]
    mean2 = float(np.cumsum(z2)[-1]) / z2.size
    if not mean2 > 0.0:
        return 0.0
    k = float(np.cumsum(z2 * z2)[-1]) / z2.size / mean2**2
    # dividing by a local mean of ``count`` squares scatters the ratio: E[1/V^2] / E[1/V]^2
    # = 1 + lambda / count, lambda = 3 + e (white noise): a fixed point in a few steps
    per = float(np.mean(count[ok]))
    e = 2.0 * (k - 3.0)
    for _ in range(4):
        e = 2.0 * (k / (1.0 + (3.0 + max(e, 0.0)) / per) - 3.0)
    return max(0.0, e)


def kurtosis_edf(nu: np.ndarray, lengths: np.ndarray, ms: np.ndarray, excess: float) -> np.ndarray:
    """The Gaussian EDF ``nu`` (J, M) of windows ``lengths`` at ``ms`` for samples of excess
    kurtosis ``excess``: ``2n / (2n / nu + excess)``, ``n = L - 2m + 1``."""
    n = np.asarray(lengths, dtype=float)[:, None] - 2.0 * np.asarray(ms, dtype=float)[None, :] + 1.0
    if not excess > 0.0:
        return np.asarray(nu, dtype=float)
    return 2.0 * n / (2.0 * n / np.asarray(nu, dtype=float) + float(excess))


def local_level(s: np.ndarray, guard: int = _GUARD) -> tuple[np.ndarray, np.ndarray]:
    """Mean of the squares ``guard + 1 .. guard + KURTOSIS_HALF`` places either side of each
    (fewer at the ends: within ``s`` only), and how many there are.

    The squares within ``guard`` share a sample with the one at the centre (first
    differences: 2; the differences of ``m``-sums: ``2m``) and are left out.
    """
    s = np.asarray(s, dtype=np.float64)
    n = s.size
    c = np.concatenate(([0.0], np.cumsum(s)))
    i = np.arange(n)
    a0, a1 = np.clip(i - guard - KURTOSIS_HALF, 0, n), np.clip(i - guard, 0, n)
    b0, b1 = np.clip(i + guard + 1, 0, n), np.clip(i + guard + 1 + KURTOSIS_HALF, 0, n)
    count = (a1 - a0) + (b1 - b0)
    return (c[a1] - c[a0] + c[b1] - c[b0]) / np.maximum(count, 1), count


def clipped_dispersion(x: np.ndarray, rho: np.ndarray) -> float:
    """``lambda`` of the segmentation: long-run variance of the clipped squares of the first
    differences over their squared mean (module notes).

    Parameters
    ----------
    x : ndarray
        Rate samples (the record, or its first samples).
    rho : ndarray
        Autocorrelation of the first differences at lags 1, 2, ... (``rho[0]`` is lag 1):
        lags from 2 on enter as ``2 rho_k**2``.

    Returns
    -------
    float
        3 for white Gaussian noise; more for heavy tails or correlated noise.
    """
    s = np.diff(np.asarray(x, dtype=np.float64)) ** 2
    level, _ = local_level(s)
    ok = level > 0.0
    extra = 4.0 * float(np.sum(np.asarray(rho[1:], dtype=float) ** 2))
    if np.count_nonzero(ok) < 2 * KURTOSIS_HALF:
        return 3.0 + extra
    w = np.minimum(s[ok] / level[ok], CLIP)  # the clipped squares, standardised
    mu = float(np.cumsum(w)[-1]) / w.size
    u = w - mu
    r0 = float(np.cumsum(u * u)[-1]) / u.size / mu**2
    r1 = float(np.cumsum(u[:-1] * u[1:])[-1]) / (u.size - 1) / mu**2
    return max(r0 + 2.0 * r1 + extra, 1e-3)


# ---------------------------------------------------------------------------- segmentation


def _kuiper_sf(v: float) -> float:
    """P(range of a Brownian bridge > v) (Kuiper)."""
    k = np.arange(1, 101, dtype=float)
    return float(2.0 * np.sum((4.0 * k**2 * v**2 - 1.0) * np.exp(-2.0 * k**2 * v**2)))


def kuiper_quantile(p: float) -> float:
    """The ``v`` with P(range of a Brownian bridge > v) = ``p`` (``0 < p < 0.5``)."""
    return float(brentq(lambda v: _kuiper_sf(v) - p, 0.8, 12.0, xtol=1e-12))


def clip_squares(s: np.ndarray, guard: int = _GUARD) -> np.ndarray:
    """The squares clipped at ``CLIP`` times the mean of their neighbours
    (:func:`local_level`): an isolated large value is clipped, a burst (whose neighbours
    are large too) is not."""
    s = np.asarray(s, dtype=np.float64)
    level, _ = local_level(s, guard)
    return np.where(level > 0.0, np.minimum(s, CLIP * level), s)


def cusum_z(w: np.ndarray, k: int, lam: float) -> float:
    """Two-segment CUSUM of ``w`` cut at ``k`` in units of its null standard deviation."""
    n = w.size
    c = np.cumsum(w)
    total = float(c[-1])
    if not total > 0.0:
        return 0.0
    return abs(float(c[k - 1]) - k / n * total) / (math.sqrt(n * lam) * total / n)


def _best_cut(w: np.ndarray, lo: int, hi: int) -> int:
    """The cut ``k`` in ``lo .. hi`` maximising the Gaussian likelihood ratio of one change
    of the mean square of ``w`` (``lo <= hi``)."""
    n = w.size
    c = np.concatenate(([0.0], np.cumsum(w)))
    k = np.arange(lo, hi + 1)
    tiny = np.finfo(float).tiny
    left = np.maximum(c[k] / k, tiny)
    right = np.maximum((c[-1] - c[k]) / (n - k), tiny)
    return int(k[np.argmax(-(k * np.log(left) + (n - k) * np.log(right)))])


def segment_squares(
    s: np.ndarray, lam: float, gamma: float, *, min_segment: int = _MIN_SEGMENT,
    guard: int = _GUARD,
) -> list[int]:  # fmt: skip
    """Cuts of a sequence of squares into segments of constant mean (module notes).

    Parameters
    ----------
    s : ndarray
        Squares (e.g. of first differences), in order.
    lam : float
        Long-run variance of the clipped squares over their squared mean
        (:func:`clipped_dispersion`).
    gamma : float
        The test level, as the ICI intervals': ``2 Phi(-gamma)`` a test.
    min_segment : int
        Shortest segment.
    guard : int
        The neighbours that share a sample (:func:`clip_squares`).

    Returns
    -------
    list of int
        Increasing cut indices ``k`` (a new segment starts at ``s[k]``).
    """
    w_all = clip_squares(s, guard)
    p = 2.0 * float(ndtr(-gamma))
    range_crit, cut_crit = kuiper_quantile(p), float(kolmogi(p))
    root = math.sqrt(lam)
    cuts: list[int] = []
    stack = [(0, w_all.size)]
    while stack:
        a, b = stack.pop()
        n = b - a
        if n < 2 * min_segment:
            continue
        w = w_all[a:b]
        bridge = np.concatenate(([0.0], np.cumsum(w)))
        total = float(bridge[-1])
        if not total > 0.0:
            continue
        bridge -= np.arange(n + 1) / n * total
        i, j = int(np.argmin(bridge)), int(np.argmax(bridge))
        if (bridge[j] - bridge[i]) / (math.sqrt(n) * root * total / n) <= range_crit:
            continue
        new = sorted(k for k in (i, j) if min_segment <= k <= n - min_segment)
        if not new:  # both extremes too near the ends to cut: the piece stays whole
            continue
        cuts += [a + k for k in new]
        edges = [a, *(a + k for k in new), b]
        stack += list(pairwise(edges))
    cuts = sorted(set(cuts))
    while cuts:  # backward elimination of the cuts that do not split their neighbours
        edges = [0, *cuts, w_all.size]
        z = [cusum_z(w_all[edges[q] : edges[q + 2]], edges[q + 1] - edges[q], lam)
             for q in range(len(cuts))]  # fmt: skip
        q = int(np.argmin(z))
        if z[q] > cut_crit:
            break
        del cuts[q]
    for q in range(len(cuts)):  # each cut to the likelihood maximum between its neighbours
        u = cuts[q - 1] if q else 0
        v = cuts[q + 1] if q + 1 < len(cuts) else w_all.size
        lo, hi = min_segment // 2, v - u - min_segment // 2
        if hi >= lo:
            cuts[q] = u + _best_cut(w_all[u:v], lo, hi)
    return cuts


# -------------------------------------------------------------------------------- ramps


def _flat_loglik(total: Any, count: Any) -> Any:
    """Gamma log-likelihood (over ``nu_b / 2``) of ``count`` block means of sum ``total``
    at their own mean."""
    tiny = np.finfo(float).tiny
    return -(count * np.log(np.maximum(total / np.maximum(count, 1), tiny)) + count)


def _inner_step_loglik(y: np.ndarray, squares: np.ndarray) -> float:
    """Log-likelihood (over ``nu_b / 2``) of the best single step of the block means ``y``
    of ``squares`` (``y.size`` blocks of equal size) placed at any square, not only at a
    block boundary: the block it falls in has the mean of the two levels weighted by the
    squares on either side.

    Where the level changes inside a block that block's mean lies between the two levels;
    a step at a block boundary fits it to one of them, far off when the levels are far
    apart (x5 amplitude: 25 times the variance), while a ramp over two blocks passes
    through it: a burst's edges were taken for ramps (module notes, Ramps).
    """
    g = y.size
    size = squares.size // g
    total = squares.size
    cs = np.concatenate(([0.0], np.cumsum(squares)))
    cy = np.concatenate(([0.0], np.cumsum(y)))
    k = np.arange(1, total)
    c, r = k // size, k % size
    tiny = np.finfo(float).tiny
    a = np.maximum(cs[k] / k, tiny)
    b = np.maximum((cs[-1] - cs[k]) / (total - k), tiny)
    v = np.maximum((r * a + (size - r) * b) / size, tiny)
    ll = (-(c * np.log(a) + cy[c] / a)
          - ((g - c - 1) * np.log(b) + (cy[-1] - cy[c + 1]) / b)
          - (np.log(v) + y[c] / v))  # fmt: skip
    return float(np.max(ll))


def _ramp_block_loglik(y: np.ndarray, cs: np.ndarray, size: int, k1: int, k2: int) -> float:
    """Log-likelihood (over ``nu_b / 2``) of the block means ``y`` under a ramp from square
    ``k1`` to ``k2`` (any squares, ``0 < k1 < k2 < y.size * size``; ``cs`` the cumulative
    sums of the squares, a leading 0 first): each block's expected mean is the mean of the
    fitted level over its squares (the ramp's ends may fall inside a block)."""
    total = cs.size - 1
    tiny = np.finfo(float).tiny
    a = max(float(cs[k1]) / k1, tiny)
    b = max(float(cs[-1] - cs[k2]) / (total - k2), tiny)
    p, span = math.sqrt(a), k2 - k1
    q = (math.sqrt(b) - p) / span
    t = np.arange(y.size + 1, dtype=float) * size  # block edges, in squares
    j = np.clip(t - k1, 0.0, span)  # squares of the ramp before each edge
    # sum over the first j squares of the ramp of (p + q (i + 1/2))**2, i = 0 .. j - 1
    ramp = j * p * p + p * q * j * j + q * q * (j**3 / 3.0 - j / 12.0)
    level = a * np.minimum(t, k1) + ramp + b * np.maximum(t - k2, 0.0)
    v = np.maximum(np.diff(level) / size, tiny)
    return float(-np.sum(np.log(v) + y / v))


def _stairs_block_loglik(y: np.ndarray, cs: np.ndarray, size: int, cuts: list[int]) -> float:
    """Log-likelihood (over ``nu_b / 2``) of the block means ``y`` under a staircase: the
    level constant between the ``cuts`` (squares, increasing, inside ``0 .. y.size * size``),
    each segment at the mean of its squares (``cs`` their cumulative sums, a leading 0
    first); a cut inside a block gives it the mean of the levels over its squares."""
    tiny = np.finfo(float).tiny
    edges = np.array([0, *cuts, cs.size - 1])
    levels = np.maximum(np.diff(cs[edges]) / np.diff(edges), tiny)
    t = np.arange(y.size + 1) * size  # block edges, in squares
    # the expected sum of the squares before each block edge
    seg = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, levels.size - 1)
    below = np.concatenate(([0.0], np.cumsum(levels * np.diff(edges))))
    level = below[seg] + levels[seg] * (t - edges[seg])
    v = np.maximum(np.diff(level) / size, tiny)
    return float(-np.sum(np.log(v) + y / v))


def _inner_ramp_loglik(y: np.ndarray, squares: np.ndarray, c1: int, c2: int, start: float) -> float:
    """The best of ``start`` and the ramps whose ends lie within a block of the blocks
    ``c1`` and ``c2`` at any square (coordinate ascent, each end on a grid of a sixteenth of a
    block): the ramp against the step at any square (:func:`_inner_step_loglik`) on equal
    terms."""
    g = y.size
    size = squares.size // g
    total = squares.size
    cs = np.concatenate(([0.0], np.cumsum(squares)))
    stride = max(1, size // 16)
    k1, k2 = c1 * size, c2 * size
    best = max(start, _ramp_block_loglik(y, cs, size, k1, k2))
    for _ in range(2):
        moved = False
        for first in (True, False):
            centre = k1 if first else k2
            for k in range(max(1, centre - size), min(total - 1, centre + size) + 1, stride):
                lo, hi = (k, k2) if first else (k1, k)
                if not 0 < lo < hi < total:
                    continue
                ll = _ramp_block_loglik(y, cs, size, lo, hi)
                if ll > best:
                    best, k1, k2, moved = ll, lo, hi, True
        if not moved:
            break
    return best


def _fit_ramp(
    y: np.ndarray, squares: np.ndarray | None = None
) -> tuple[float, float, int, int, float, float]:
    """Best single step and best ramp on block means ``y`` (block units).

    ``squares``: the squares ``y`` averages (``y.size`` blocks of equal size); given, the
    step may also fall inside a block (:func:`_inner_step_loglik`).

    Returns ``(loglik_step, loglik_ramp, c1, c2, a, b)``: log-likelihoods over ``nu_b / 2``,
    the ramp's first and end block (``c1 < c2``; the step's block twice when no ramp is
    better) and the flat levels before and after it.
    """
    g = y.size
    cy = np.concatenate(([0.0], np.cumsum(y)))
    k = np.arange(1, g)
    step_ll = _flat_loglik(cy[k], k) + _flat_loglik(cy[-1] - cy[k], g - k)
    j = int(np.argmax(step_ll))
    c = int(k[j])
    best = [float(step_ll[j]), c, c]

    def evaluate(first: np.ndarray, last: np.ndarray) -> None:
        for c1 in first.tolist():
            for c2 in last.tolist():
                if not 1 <= c1 < c2 <= g - 1:
                    continue
                a, b = cy[c1] / c1, (cy[-1] - cy[c2]) / (g - c2)
                t = (np.arange(c1, c2) + 0.5 - c1) / (c2 - c1)
                v = (math.sqrt(a) + (math.sqrt(b) - math.sqrt(a)) * t) ** 2
                if not np.all(v > 0.0):
                    continue
                ll = (float(_flat_loglik(cy[c1], c1) + _flat_loglik(cy[-1] - cy[c2], g - c2))
                      - float(np.cumsum(np.log(v) + y[c1:c2] / v)[-1]))  # fmt: skip
                if ll > best[0]:
                    best[:] = [ll, c1, c2]

    coarse = max(1, g // _RAMP_GRID)
    grid = np.arange(1, g, coarse)
    evaluate(grid, grid)
    c1, c2 = best[1], best[2]
    evaluate(np.arange(max(1, c1 - 2 * coarse), c1 + 2 * coarse + 1),
             np.arange(c2 - 2 * coarse, min(g - 1, c2 + 2 * coarse) + 1))  # fmt: skip
    c1, c2 = best[1], best[2]
    a = cy[c1] / c1
    b = (cy[-1] - cy[c2]) / (g - c2)
    step, ramp = float(step_ll[j]), float(best[0])
    if squares is not None:  # the ends of both at any square: the step and the ramp alike
        step = max(float(step_ll[j]), _inner_step_loglik(y, squares))
        if c2 > c1:
            ramp = _inner_ramp_loglik(y, squares, c1, c2, ramp)
    return step, ramp, int(c1), int(c2), float(a), float(b)


def _segment_mean(w: np.ndarray) -> float:
    return float(np.cumsum(w)[-1]) / w.size if w.size else math.nan


def find_episodes(
    x: np.ndarray, offset: int, *, dispersion: float, clipped: float, gamma: float
) -> list[Episode]:
    """The steps and ramps of one region (module notes).

    Parameters
    ----------
    x : ndarray of float64
        The region's samples.
    offset : int
        Sample index of ``x[0]`` in the record (the episodes are in record samples).
    dispersion : float
        ``lambda`` of the unclipped squares (``lambda_G + e``): the ramps' likelihood.
    clipped : float
        ``lambda`` of the clipped squares (:func:`clipped_dispersion`): the segmentation.
    gamma : float
        Test level: the segmentation's ``2 Phi(-max(gamma, SEGMENT_GAMMA))`` a test, the
        ramps' likelihood ratio ``gamma**2``.

    Returns
    -------
    list of Episode
        In order of time.
    """
    s = np.diff(np.asarray(x, dtype=np.float64)) ** 2
    cuts = segment_squares(s, clipped, max(gamma, SEGMENT_GAMMA))
    if not cuts:
        return []
    edges = [0, *cuts, s.size]
    w = clip_squares(s)
    levels = [_segment_mean(w[edges[q] : edges[q + 1]]) for q in range(len(edges) - 1)]
    rise = [levels[q + 1] > levels[q] for q in range(len(cuts))]
    out: list[Episode] = []
    q = 0
    while q < len(cuts):
        r = q
        while r + 1 < len(cuts) and rise[r + 1] == rise[q]:
            r += 1
        lo, hi = edges[q], edges[r + 2]  # the group's span, between the other cuts
        span = s[lo:hi]
        size = max(1, span.size // _RAMP_BLOCKS)
        g = span.size // size
        ramp = None
        if g >= 4:
            y = np.cumsum(span[: g * size].reshape(g, size), axis=1)[:, -1] / size
            step_ll, ramp_ll, c1, c2, a, b = _fit_ramp(y, span[: g * size])
            statistic = 2.0 * size / dispersion * (ramp_ll - step_ll)
            if r > q:  # steps in one direction: a ramp only if it beats their staircase
                cs = np.concatenate(([0.0], np.cumsum(span[: g * size])))
                inner = [k - lo for k in cuts[q : r + 1] if 0 < k - lo < g * size]
                stairs = (
                    2.0 * size / dispersion * (_stairs_block_loglik(y, cs, size, inner) - ramp_ll)
                )
                # a staircase of k steps has 2k + 1 free numbers, a ramp 4: gamma**2 each
                if len(inner) > 1 and stairs > gamma**2 * (2 * len(inner) - 3):
                    statistic = -math.inf
            if c2 - c1 >= 2 and statistic > gamma**2:
                ramp = Episode(start=offset + lo + c1 * size, end=offset + lo + c2 * size,
                               ramp=True, rise=rise[q], before=a, after=b,
                               statistic=float(statistic))  # fmt: skip
        if ramp is not None:
            out.append(ramp)
        else:
            for k in range(q, r + 1):
                out.append(Episode(
                    start=offset + cuts[k] + 1, end=offset + cuts[k] + 1, ramp=False,
                    rise=rise[k], before=levels[k], after=levels[k + 1],
                    statistic=cusum_z(w[edges[k] : edges[k + 2]], cuts[k] - edges[k], clipped),
                ))  # fmt: skip
        q = r + 1
    return out


def episode_regions(
    split: np.ndarray, centres: np.ndarray, lmax: int, n: int
) -> list[tuple[int, int, int, int]]:
    """The first regions of the episodes of split centres (module notes; a region ending in
    a ramp grows, :func:`grown_end`).

    Parameters
    ----------
    split : ndarray of bool
        Whether the left and right ``lmax`` windows of each centre disagree.
    centres : ndarray of int64
        The centres (increasing).
    lmax : int
        Longest window.
    n : int
        Samples in the record.

    Returns
    -------
    list of (int, int, int, int)
        ``(first, last, a, b)``: the first and last split centre of each episode and its
        region, samples ``a .. b - 1`` (overlapping the previous region: the caller starts
        it where that one ended).
    """
    flagged = np.asarray(centres)[np.asarray(split, dtype=bool)]
    if flagged.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(flagged) > lmax)
    firsts = np.concatenate((flagged[:1], flagged[breaks + 1])).tolist()
    lasts = np.concatenate((flagged[breaks], flagged[-1:])).tolist()
    reach = region_reach(lmax)
    return [(f, g, max(0, f - reach), min(n, g + reach))
            for f, g in zip(firsts, lasts, strict=True)]  # fmt: skip


def region_reach(lmax: int) -> int:
    """How far a region reaches beyond its first and last split centre: ``lmax`` (a change
    that splits a centre lies within ``lmax`` of it) and a quarter more, so that a change at
    that edge has samples of the level before it to be cut against."""
    return lmax + lmax // 4


def grown_end(found: list[Episode], b: int, lmax: int, n: int | None = None) -> int | None:
    """The next end of a region whose episodes are ``found`` if it must grow, else None.

    A ramp ending less than ``lmax`` before the region's end ``b`` may go on beyond it (its
    far end splits the ``lmax`` windows no more): the region grows by ``lmax`` and is
    segmented again, until the ramp ends ``lmax`` inside it or the record (of ``n``
    samples; None: not known yet) ends.
    """
    last = found[-1] if found else None
    if last is None or not last.ramp or b - last.end >= lmax or (n is not None and b >= n):
        return None
    return b + lmax if n is None else min(n, b + lmax)


def pair_changes(rises: list[bool]) -> list[tuple[int, int | None]]:
    """Changes paired into stretches by their direction: the first opens a stretch, the
    next one of the other direction closes it (those of the same direction between belong
    to it: a staircase), the next opens again; an unclosed stretch ends None.

    Parameters
    ----------
    rises : list of bool
        Whether each change (in order of time) raises the level.

    Returns
    -------
    list of (int, int or None)
        Index of the change into each stretch and of the one out of it.
    """
    out: list[tuple[int, int | None]] = []
    start = None
    for k, rise in enumerate(rises):
        if start is None:
            start = k
        elif rise != rises[start]:
            out.append((start, k))
            start = None
    if start is not None:
        out.append((start, None))
    return out


@dataclass(frozen=True)
class RampModel:
    """The level of a ramp's fit around it (:func:`ramp_model`).

    Attributes
    ----------
    episode : Episode
        The ramp.
    lo : int
        The first sample of the grid (every window a centre the ramp reaches can take).
    cumulative : ndarray
        Sums of the level over the grid from ``lo``, a leading 0 first.
    log_level : ndarray
        Log of the level at each sample of the grid.
    """

    episode: Episode
    lo: int
    cumulative: np.ndarray
    log_level: np.ndarray


def ramp_model(ep: Episode, lmax: int, smooth: int = 1) -> RampModel | None:
    """The fitted level around the ramp ``ep`` (flat ``before``, the amplitude linear over
    the ramp, flat ``after``), averaged over ``smooth`` samples (the fitted ends are that
    uncertain), on a grid fixed once, so every batch of centres reads the same sums. None
    where a level is not positive."""
    half, w = lmax // 2, max(1, int(smooth))
    lo, hi = ep.start - half - lmax - 1, ep.end + half + lmax + 2
    t = np.arange(lo - w // 2, hi + w - 1 - w // 2)
    frac = np.clip((t - ep.start) / max(ep.end - ep.start, 1), 0.0, 1.0)
    ra, rb = math.sqrt(max(ep.before, 0.0)), math.sqrt(max(ep.after, 0.0))
    v = (ra + (rb - ra) * frac) ** 2
    if w > 1:  # the moving average of w samples, one value per sample lo .. hi - 1
        c = np.concatenate(([0.0], np.cumsum(v)))
        v = (c[w:] - c[:-w]) / w
    if not np.all(v > 0.0):
        return None
    return RampModel(episode=ep, lo=int(lo), cumulative=np.concatenate(([0.0], np.cumsum(v))),
                     log_level=np.log(v))  # fmt: skip


def ramp_windows(
    centres: np.ndarray,
    window: np.ndarray,
    shift: np.ndarray,
    side: np.ndarray,
    models: list[RampModel],
    lengths: np.ndarray,
    nu: np.ndarray,
    lmax: int,
    offset_of: Callable[[int, Any], Any],
) -> None:
    """In place: the windows of the centres a ramp's ``lmax`` window reaches (module notes).

    Parameters
    ----------
    centres : ndarray of int64
        The centres of the rows.
    window, shift, side : ndarray
        Their windows, offsets and sides (-1, 0, 1), changed in place.
    models : list of RampModel
        The ramps (:func:`ramp_model`).
    lengths : ndarray of int64
        The candidate lengths a window may take (at least ``lmin``).
    nu : ndarray
        The EDF of each of them (at the first averaging factor).
    lmax : int
        Longest window.
    offset_of : callable
        ``offset_of(side, length)``: the offset of the centre of a window of ``length`` on
        ``side`` of its centre (:func:`adavar.dynamic.ici.side_shift`).
    """
    lengths = np.asarray(lengths, dtype=np.int64)
    variance = 2.0 / np.asarray(nu, dtype=float)
    half = lmax // 2
    for model in models:
        ep = model.episode
        here = np.flatnonzero((centres >= ep.start - half) & (centres <= ep.end + half))
        if here.size == 0:
            continue
        p = centres[here]
        cv = model.cumulative
        own = model.log_level[p - model.lo]
        best = np.full(p.size, np.inf)
        pick_len = np.zeros(p.size, dtype=np.int64)
        pick_side = np.zeros(p.size, dtype=np.int8)
        # centred first, longest first: ties keep the earlier (strict improvement only)
        for s in (0, -1, 1):
            for j in range(lengths.size - 1, -1, -1):
                length = int(lengths[j])
                start = p + offset_of(s, length) - (length - 1) // 2 - model.lo
                mean = (cv[start + length] - cv[start]) / length
                mse = (np.log(mean) - own) ** 2 + variance[j]
                better = mse < best
                best[better] = mse[better]
                pick_len[better] = length
                pick_side[better] = s
        window[here] = pick_len
        side[here] = pick_side
        for s in (-1, 0, 1):
            chosen = pick_side == s
            shift[here[chosen]] = offset_of(s, pick_len[chosen])

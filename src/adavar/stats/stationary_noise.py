"""Is the short-tau noise of a whole record stationary? A cheap, calibrated test.

A whole-record Allan deviation averages the noise over the record: a stretch where the
white noise is 2.5 times stronger for 10 minutes of an hour reads as one level (N = 0.41
where it is 0.30 for 83 % of the record) with an interval that says nothing about it.
:func:`stationarity` tells such a record from a stationary one, so that
:func:`adavar.deviation` can warn and point to the adaptive analysis.

The test (module notes):

* The record's shortest-tau Allan terms, ``d_k = x[k+2] - 2 x[k+1] + x[k]`` of the phase
  (the first differences of rate data), are the white-noise level sample by sample:
  flicker, random walk, Gauss-Markov and drift terms are differenced away (their
  contribution to ``d_k`` is stationary and small), so this is where a record that
  *should* be stationary is.
* The ``d_k^2`` are averaged over ``segments x blocks`` contiguous blocks (16 x 16 by
  default), and the logarithms of the block means compared across the segments by the
  Kruskal-Wallis rank test. Ranks make it distribution-free: heavy tails (Student-t),
  quantisation and a single outlier block change nothing under stationarity; the
  logarithm makes a level change a shift. Samples that are correlated (band-limited,
  filtered data) would correlate the blocks: a block is at least 20 correlation times of
  ``d_k^2`` long (estimated on the first 65536 differences, in windows each centred on
  its own mean; the layout falls back to 16 x 8, 8 x 8, 8 x 4, 4 x 4 blocks, and a record
  too short for 4 x 4 is not tested), and the statistic is divided by ``1 + 2 rho`` with
  ``rho`` the pooled lag-1 correlation of the within-segment rank residuals (floored at
  0), the variance inflation of a segment's mean rank left.
* A record whose differences are mostly (80 %) zero is not tested: its short-tau
  variation is quantisation steps, whose rate follows the slow wander of the signal
  across the levels (rate random walk under a coarse LSB), a modulation the test would
  flag in 0.5-8 % of stationary records.
* The p-value is the chi-square tail with ``segments - 1`` degrees of freedom; a record
  is called non-stationary below ``level`` (default 1e-3: on stationary records of the
  kinds above, under 1 % false alarms, measured in ``benchmarks/bench_stationarity.py``).
* The suspect stretch is the run of blocks whose ranks differ most from the rest's (the
  CUSUM statistic of a level that changes and changes back), to a block's resolution
  (1/256 of the record by default); its ratio compares the median log levels inside and
  outside.

Cost: the record's extremes (its check, and its scale), one pass over it (a difference,
a square and block sums: compiled, on every thread for a long record in memory), an FFT
of its first 65536 differences and a rank of ``segments x blocks`` numbers: about 30 ms
of one core for 1e7 samples (2.8 hours at 1 kHz; 70 ms before the compiled pass). It
does not see a burst much shorter than a block (a 20 s x5 burst in an hour:
:func:`adavar.dynamic.events.find_events` and the adaptive DAVAR do).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Final

import numpy as np
from scipy.special import gammaincc

from adavar._kernels import differences
from adavar._kernels._jit import grouped_items, jit, read_only, threaded_jit
from adavar.core.errors import AdavarInputError
from adavar.core.inputs import DATA_TYPE_ALIASES, as_samples
from adavar.io.sampling import resolve_tau0
from adavar.io.scaling import scaled_source
from adavar.io.sources import DEFAULT_CHUNK, check_chunk_size, is_chunked, open_record

__all__ = ["DEFAULT_LEVEL", "MIN_BLOCK", "StationarityResult", "stationarity"]

#: p-value below which a record is called non-stationary (:func:`stationarity`)
DEFAULT_LEVEL: Final[float] = 1e-3

#: fewest second differences per block: below, a block mean's logarithm is far from normal
#: and the test is not run (the result says so)
MIN_BLOCK: Final[int] = 16


#: samples per piece of a record in memory
_PIECE: Final = 1 << 20

#: differences read first: their correlation time sets the shortest block, and the
#: fraction of them that are 0 tells a record whose short-tau variation is quantisation
#: steps (at least ``_QUANTISED``: not tested, a slow wander across the levels, e.g. rate
#: random walk under a coarse LSB, modulates the step rate: 0.5-8 % of such stationary
#: records were flagged at 1e-3)
_HEAD: Final = 1 << 16
_QUANTISED: Final = 0.8
#: samples per window of :func:`_correlation_time`
_WINDOW: Final = 1 << 12
#: the shortest block, in correlation times of the squared differences: blocks much
#: shorter than the correlation make the segments' spread exceed what the blocks within
#: them show (low-passed records: 1-10 % flagged at 1e-3 with blocks of 0.2-3 times it)
_BLOCK_TIMES: Final = 20.0

#: the automatic (segments, blocks), most first (:func:`stationarity`)
_LAYOUTS: Final = ((16, 16), (16, 8), (8, 8), (8, 4), (4, 4))


@dataclass(frozen=True)
class StationarityResult:
    """The stationarity test of one record (:func:`stationarity`).

    Attributes
    ----------
    p_value : float
        Probability of a statistic at least this large on a stationary record; NaN when
        the test could not be run (record too short, no noise).
    statistic : float
        Kruskal-Wallis H divided by ``1 + 2 rho`` (the block correlation).
    dof : int
        Degrees of freedom of its chi-square reference, ``segments - 1``.
    stationary : bool
        ``p_value >= level`` (True when the test was not run).
    level : float
        The threshold used.
    stretch : tuple of float or None
        ``(start, end)`` in seconds from the first sample of the suspect stretch, when
        not stationary.
    ratio : float
        The short-tau noise level (a deviation: the square root of the mean ``d^2``) in
        the stretch over that of the rest of the record; NaN without a stretch.
    segments, blocks : int
        The segmentation used (``blocks`` per segment).
    reason : str or None
        Why the test was not run, if it was not (too short for its correlation,
        quantisation steps, no short-tau noise).
    """

    p_value: float
    statistic: float
    dof: int
    stationary: bool
    level: float
    stretch: tuple[float, float] | None
    ratio: float
    segments: int
    blocks: int
    reason: str | None = None

    def warning(self) -> str | None:
        """A one-line warning for a non-stationary record (None when stationary)."""
        if self.stationary:
            return None
        where = ""
        if self.stretch is not None:
            a, b = self.stretch
            where = (
                f"; its short-tau noise is {self.ratio:.2g} times that of the rest from "
                f"{a:.5g} s to {b:.5g} s"
            )
        return (
            f"the record is not stationary (p = {self.p_value:.2g}{where}): a whole-record "
            "deviation averages different noise levels; the adaptive DAVAR follows them "
            "(adavar adaptive, adavar.adaptive_davar)"
        )


def stationarity(
    data: np.ndarray,
    *,
    rate: float = 1.0,
    tau0: float | None = None,
    data_type: str = "rate",
    level: float = DEFAULT_LEVEL,
    segments: int | None = None,
    blocks: int | None = None,
    chunk_size: int | None = None,
    extremes: tuple[float, float] | None = None,
) -> StationarityResult:
    """Test whether the short-tau (white) noise level of a record is the same throughout.

    Parameters
    ----------
    data : array_like, ChunkedSource, dask.array.Array or numpy.memmap
        The record, one sample per ``tau0``; finite. A chunked record is read piece by
        piece (one pass), as :func:`adavar.deviation` reads it.
    rate : float
        Sample rate in Hz (ignored when ``tau0`` is given); only converts the stretch to
        seconds.
    tau0 : float, optional
        Sample interval in seconds, instead of ``rate``.
    data_type : {"rate", "phase"}
        ``"rate"``: the first differences of the samples are tested; ``"phase"``: the
        second differences.
    level : float
        p-value below which the record is called non-stationary (default 1e-3).
    segments, blocks : int, optional
        Number of segments compared and of blocks per segment (each >= 2). Default: the
        first of (16, 16), (16, 8), (8, 8), (8, 4), (4, 4) that leaves at least
        :data:`MIN_BLOCK` differences per block (a record of 4096 samples or more gets 16
        x 16; one below 256 is not tested).
    chunk_size : int, optional
        Samples per read of a chunked record (default :data:`adavar.io.sources.DEFAULT_CHUNK`);
        giving it reads an array that way too.
    extremes : (float, float), optional
        The smallest and largest sample of an in-memory float64 record that the caller has
        already checked to be finite (:func:`adavar.deviation` has both): the record is
        then not read twice more for them. Not checked against the record.

    Returns
    -------
    StationarityResult
        The p-value, the verdict and the suspect stretch (module notes).

    Raises
    ------
    AdavarInputError
        Non-finite samples, a bad ``data_type``, ``level`` outside (0, 1), fewer than 2
        segments or blocks.
    """

    step = resolve_tau0(rate, tau0)
    dtype = DATA_TYPE_ALIASES.get(str(data_type).lower())
    if dtype is None:
        raise AdavarInputError(f"unknown data_type {data_type!r}: use 'rate' or 'phase'")
    if not 0.0 < float(level) < 1.0:
        raise AdavarInputError(f"level must lie strictly between 0 and 1, got {level!r}")
    if is_chunked(data) or chunk_size is not None:
        source, _ = scaled_source(open_record(data, 1))  # power-of-two scale: no overflow
        size, read = source.size, source.read
        piece = DEFAULT_CHUNK if chunk_size is None else check_chunk_size(chunk_size)
        powers = functools.partial(_block_powers, read, piece=piece)
    else:
        given = extremes is not None and isinstance(data, np.ndarray) and data.ndim == 1
        if given and data.dtype == np.float64 and data.size:
            x, big = data, max(float(extremes[1]), -float(extremes[0]))
        else:
            x = as_samples(data, min_length=1)
            big = _max_abs(x)
        # by the largest magnitude, so that the squares neither overflow nor underflow
        # (x / 1 is x: a record of zeros stays as it is)
        scale = big if big > 0.0 else 1.0
        size, read, piece = x.size, (lambda a, b: x[a:b] / scale), _PIECE
        powers = functools.partial(_record_powers, x, scale, piece=piece)
    order = 2 if dtype == "phase" else 1
    # (no more than a piece: a streamed record's working memory stays a few pieces)
    first = min(size, min(_HEAD, piece) + order)
    head = np.diff(read(0, first), n=order) if size > order else np.empty(0)
    shortest = max(MIN_BLOCK, math.ceil(_BLOCK_TIMES * _correlation_time(head * head)))
    if segments is None and blocks is None:
        fits = [g for g in _LAYOUTS if (size - order) // (g[0] * g[1]) >= shortest]
        segments, blocks = fits[0] if fits else _LAYOUTS[-1]
    segments = 16 if segments is None else int(segments)
    blocks = 16 if blocks is None else int(blocks)
    if segments < 2 or blocks < 2:
        raise AdavarInputError(
            f"need at least 2 segments and 2 blocks per segment, got {segments} and {blocks}"
        )
    zeros = float(np.mean(head == 0.0)) if head.size else 1.0
    layout = (segments, blocks, shortest, zeros)
    return _test(powers, size, order, step, float(level), layout)


def _correlation_time(s: np.ndarray) -> float:
    """Integrated autocorrelation time of the series ``s`` (in samples, >= 1): ``1 + 2 sum
    rho_k`` up to the first lag where ``rho_k`` falls below 0.05, with ``rho`` pooled over
    windows of :data:`_WINDOW` samples each centred on its own mean (a change of the level
    in one of them, the thing tested for, then does not read as correlation)."""
    width = min(_WINDOW, s.size)
    if width < 16:
        return 1.0
    windows = s[: s.size // width * width].reshape(-1, width)
    c = windows - windows.mean(axis=1, keepdims=True)
    var = float(np.sum(c * c))
    if not var > 0.0:
        return 1.0
    spec = np.fft.rfft(c, 2 * width, axis=1)
    acf = np.fft.irfft(np.sum((spec * np.conj(spec)).real, axis=0))[: width // 8] / var
    below = np.flatnonzero(acf[1:] < 0.05)
    stop = int(below[0]) + 1 if below.size else acf.size
    return max(1.0, 1.0 + 2.0 * float(np.sum(acf[1:stop])))


def _block_powers(read, n_blocks: int, size: int, order: int, *, piece: int) -> np.ndarray:
    """Sums of the squared ``order``-th differences over ``n_blocks`` blocks of ``size``,
    reading ``piece`` samples at a time (``read(start, stop)``: samples ``start .. stop-1``).

    NumPy, for a streamed record; :func:`_record_powers` computes the same numbers for a
    record in memory."""
    power = np.zeros(n_blocks)
    used = n_blocks * size
    for start in range(0, used, piece):
        stop = min(used, start + piece)
        d = np.diff(read(start, stop + order), n=order)  # differences start .. stop - 1
        first = start // size
        edges = np.arange(first * size, stop, size)
        edges[0] = start
        power[first : first + edges.size] += np.add.reduceat(d * d, edges - start)
    return power


# ---------------------------------------------------------------------------------------
# the block powers of a record in memory, compiled: NumPy's numbers, one pass, every thread


def _max_abs(x: np.ndarray) -> float:
    """``float(np.max(np.abs(x)))`` of a finite record (0 when empty), without its copy."""
    return max(float(x.max()), -float(x.min())) if x.size else 0.0


@jit
def _pairwise(a, lo, n):  # pragma: no cover - compiled
    """``a[lo : lo + n]`` summed as NumPy's ``add.reduce`` sums float64 (pairwise: blocks
    of up to 128 in 8 running sums, halved above), the same number bit for bit."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    if n <= 128:
        r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
        r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
        i = 8
        while i < n - n % 8:
            j = lo + i
            r0 += a[j]
            r1 += a[j + 1]
            r2 += a[j + 2]
            r3 += a[j + 3]
            r4 += a[j + 4]
            r5 += a[j + 5]
            r6 += a[j + 6]
            r7 += a[j + 7]
            i += 8
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        for j in range(lo + i, lo + n):
            res += a[j]
        return res
    half = n // 2
    half -= half % 8
    return _pairwise(a, lo, half) + _pairwise(a, lo + half, n - half)


@threaded_jit
def _record_power_blocks(x, scale, order, size, piece, power, per, lo, hi):  # pragma: no cover
    """Blocks ``lo * per .. hi * per - 1`` of :func:`_record_powers`."""
    buf = np.empty(size + order)
    sq = np.empty(size)
    for i in range(lo * per, min(hi * per, power.size)):
        b0 = i * size
        for k in range(size + order):
            buf[k] = x[b0 + k] / scale
        for k in range(size):
            d = buf[k + 1] - buf[k]
            if order == 2:
                d = (buf[k + 2] - buf[k + 1]) - d
            sq[k] = d * d
        # the block's parts in the pieces NumPy reads, each summed as reduceat sums a
        # segment (its first term plus the pairwise sum of the rest), in piece order
        total = 0.0
        a = b0
        while a < b0 + size:
            e = min(b0 + size, (a // piece + 1) * piece)
            total += sq[a - b0] + _pairwise(sq, a - b0 + 1, e - a - 1)
            a = e
        power[i] = total


def _record_powers(
    x: np.ndarray, scale: float, n_blocks: int, size: int, order: int, *, piece: int
) -> np.ndarray:
    """:func:`_block_powers` of the record ``x / scale`` in memory, bit for bit, in one
    compiled pass, on every thread from :data:`adavar._kernels.differences.RECORD_THREADS_MIN`
    samples on: each block's squared differences of the scaled samples, summed in the
    pieces of ``piece`` samples the NumPy version reads, as NumPy sums them."""
    power = np.zeros(n_blocks)
    work = n_blocks * size
    threads = work >= differences.RECORD_THREADS_MIN
    per, items = grouped_items(n_blocks) if threads else (n_blocks, 1)
    _record_power_blocks.run(
        work if items > 1 else 0, items, read_only(x), float(scale), order, size, piece,
        power, per,
    )  # fmt: skip
    return power


def _test(
    powers,
    n_samples: int,
    order: int,
    step: float,
    level: float,
    layout: tuple[int, int, int, float],
) -> StationarityResult:
    """:func:`stationarity` of a checked record whose block powers ``powers(n_blocks,
    size, order)`` gives (:func:`_block_powers`, :func:`_record_powers`; ``order``
    differences); ``layout``: segments, blocks per segment, the shortest block and the
    fraction of the first differences that are 0."""
    segments, blocks, shortest, zeros = layout
    n_blocks = segments * blocks
    size = (n_samples - order) // n_blocks

    def skipped(reason: str) -> StationarityResult:
        return StationarityResult(
            math.nan, math.nan, segments - 1, True, level, None, math.nan, segments, blocks,
            reason,
        )  # fmt: skip

    if size < shortest:
        why = "" if shortest == MIN_BLOCK else " (its short-tau noise is correlated over "
        why += "" if shortest == MIN_BLOCK else f"~{shortest / _BLOCK_TIMES:.3g} samples)"
        return skipped(
            f"the record is too short for the stationarity test{why}: it needs "
            f"{n_blocks * shortest + order} samples"
        )
    quiet = "the record has no short-tau noise to test (constant, or a straight line)"
    if _QUANTISED <= zeros < 1.0:
        return skipped(
            f"the record's short-tau variation is quantisation steps ({100 * zeros:.0f} % of "
            "its differences are 0): their rate follows the slow wander of the signal across "
            "the levels, so the stationarity test is not run"
        )
    power = powers(n_blocks, size, order)
    if not np.all(power > 0.0):
        if not np.any(power > 0.0):
            return skipped(quiet)
        # a block without any change (a stuck sensor, a gap filled by a constant) is a
        # change of the noise: it ranks lowest
        power = np.where(power > 0.0, power, np.min(power[power > 0.0]) * 1e-3)
    z = np.log(power).reshape(segments, blocks)
    ranks = np.empty(n_blocks)
    ranks[np.argsort(z, axis=None, kind="stable")] = np.arange(1.0, n_blocks + 1.0)
    ranks = ranks.reshape(segments, blocks)
    mean_rank = ranks.mean(axis=1)
    centre = 0.5 * (n_blocks + 1.0)
    h = 12.0 * blocks * float(np.sum((mean_rank - centre) ** 2)) / (n_blocks * (n_blocks + 1.0))
    resid = ranks - mean_rank[:, None]
    lag1 = float(np.sum(resid[:, 1:] * resid[:, :-1]))
    rho = max(0.0, lag1 / float(np.sum(resid * resid))) if np.any(resid) else 0.0
    # the within-segment residuals carry a built-in lag-1 correlation of -1/(blocks - 1)
    rho = max(0.0, rho + 1.0 / (blocks - 1.0)) if rho > 0.0 else rho
    statistic = h / (1.0 + 2.0 * rho)
    dof = segments - 1
    p = float(gammaincc(0.5 * dof, 0.5 * statistic))
    stationary = p >= level
    stretch, ratio = None, math.nan
    if not stationary:
        stretch, ratio = _stretch(z, ranks, size, order, step)
    return StationarityResult(
        p, statistic, dof, stationary, level, stretch, ratio, segments, blocks
    )


def _stretch(z: np.ndarray, ranks: np.ndarray, size: int, order: int, step: float):
    """The suspect stretch (seconds) and its noise-level ratio (module notes).

    The run of blocks ``[a, b)`` whose ranks differ most from the rest's: the largest
    ``(S[b] - S[a])^2 / (L (n - L) / n)`` with ``S`` the running sum of the centred
    ranks and ``L = b - a`` (the CUSUM statistic of an "epidemic" change: a level that
    changes and changes back), over every run but the whole record.
    """
    n = ranks.size
    cusum = np.concatenate(([0.0], np.cumsum(ranks.ravel() - 0.5 * (n + 1.0))))
    length = np.arange(n + 1.0)[None, :] - np.arange(n + 1.0)[:, None]  # b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        score = (cusum[None, :] - cusum[:, None]) ** 2 / (length * (n - length) / n)
    score[~((length > 0) & (length < n))] = -1.0
    a, b = (int(k) for k in np.unravel_index(int(np.argmax(score)), score.shape))
    flat = z.ravel()

    def levels(a: int, b: int) -> tuple[float, float]:
        inside = np.zeros(n, dtype=bool)
        inside[a:b] = True
        return float(np.median(flat[inside])), float(np.median(flat[~inside]))

    # ends moved to the blocks beyond the midpoint of the two log levels (ranks of noise
    # blocks next to a strong change can extend the run by a few blocks)
    level_in, level_out = levels(a, b)
    mid, sign = 0.5 * (level_in + level_out), math.copysign(1.0, level_in - level_out)
    while b - a > 1 and sign * (flat[a] - mid) <= 0.0:
        a += 1
    while b - a > 1 and sign * (flat[b - 1] - mid) <= 0.0:
        b -= 1
    while a > 0 and b - a < n - 1 and sign * (flat[a - 1] - mid) > 0.0:
        a -= 1
    while b < n and b - a < n - 1 and sign * (flat[b] - mid) > 0.0:
        b += 1
    level_in, level_out = levels(a, b)
    return (a * size * step, (b * size + order) * step), math.exp(0.5 * (level_in - level_out))

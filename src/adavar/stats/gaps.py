"""Allan-family statistics of a record with missing samples: ``deviation(..., gaps="omit")``.

A missing sample is a NaN on a regular grid (sample ``k`` at ``k * tau0``, the grid goes on
through the gap). Every statistic of :func:`adavar.deviation` is a mean of squared finite
differences ("terms"); with ``gaps="omit"`` every term that touches a missing sample is left
out, and the variance at each tau is the sum over the kept terms divided by their number
(``result.n``) with the statistic's usual normalisation.

Which terms touch a missing sample
----------------------------------
Phase points are indexed ``j = 0 .. N_points - 1``; a term of averaging factor ``m``
starting at ``i`` uses

* oadev, adev: the points ``i, i + m, i + 2m``; hdev, ohdev: ``i, i + m, i + 2m, i + 3m``
  (adev and hdev at ``i = 0, m, 2m, ...`` only);
* mdev, tdev: every point ``i .. i + 3m - 1`` (the three m-sums of its averaged phase).

*Rate data* (``N`` rate samples, ``N + 1`` phase points): the phase increment from point
``j`` to ``j + 1`` is rate sample ``j``, so a missing rate sample leaves every phase
difference across it unknown. A term is omitted if any rate sample it spans is missing:
``i .. i + 2m - 1`` (Allan), ``i .. i + 3m - 1`` (Hadamard), ``i .. i + 3m - 2`` (modified).

*Phase data* (``N`` phase points): a missing point removes exactly the terms that use it:
for the Allan and Hadamard statistics only those with the point at ``i + k m`` (the other
points between them are not used), for the modified ones those whose window
``i .. i + 3m - 1`` holds it.

How it is computed
------------------
In O(N) per tau, like the gap-free path. The missing samples are filled by linear
interpolation between their neighbours (any finite value would do: no kept term involves
one; interpolation keeps the integrated signal free of steps, so no digits are lost to
them) and the record is integrated once into the anchored double-double phase of
:mod:`adavar._kernels.differences`. A kept term's phase differences are sums of rate samples inside
its window (rate data) or differences of its own points (phase data), none of them filled,
so it is the exact term of the true record (a few ulps, large offsets and drifts included).
Whether a term is kept is an O(1) test: a prefix count of missing samples over its window
(rate data, modified statistics) or a look at its 3 or 4 points (phase data). The kernels
are in :mod:`adavar._kernels.gaps`.

Confidence intervals
--------------------
The EDF is the Greenhall-Riley EDF of a gap-free record that would give as many terms as
were kept (:func:`effective_points`): ``n + 2m`` points for oadev, ``n + 3m`` for ohdev,
``n + 3m - 1`` for mdev/tdev, ``(n + 1) m + 1`` for adev and ``(n + 2) m + 1`` for hdev.
Gaps cut the correlation between the terms on either side, which for red noise makes the
kept terms more independent than a contiguous run of as many (so this EDF is on the safe
side) and for white FM removes as much as it adds (each gap-free piece contributes about
its own EDF); simulation (``tests/test_gaps.py``, ``benchmarks/bench_gaps.py``) gives a
coverage within the Monte Carlo scatter of the nominal 68.3 % on white and flicker FM with
10 % of the samples missing in random gaps.

The noise type per tau (:func:`gap_noise_types`) comes from the same rules as for a
complete record, applied to the kept data: the lag-1 autocorrelation of the m-cluster sums
uses the clusters that hold no missing sample and only the pairs of adjacent kept clusters
(and, for phase data, the decimated phase points that are not missing), with at least 30
kept clusters and 29 kept pairs; below that, the B1 ratio on the longest run of kept
clusters (at least 10), and R(n) = MVAR/AVAR from the kept terms; else the type of the
nearest identified tau.

Out of core (a memory map, a ``dask`` array, a :class:`~adavar.stats.stream.ChunkedSource`):
the record is streamed as usual, and on the first NaN it meets it is read into memory and
computed here (a ``chunk_size`` given explicitly then is an error: the gap path needs the
record in memory).

What a DAVAR (:mod:`adavar.dynamic.surface`) would need from here: :class:`GapLayout` (the prefix
count and missing-point mask of the whole record, built once), its keep tests and
:func:`effective_points`; a window of the surface is then a slice of ``cnt`` / ``pm``, the
kept count of a window is a difference of prefix sums of the keep flags, and the EDF of a
window follows from its kept count the same way.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from adavar._kernels import differences as diff
from adavar._kernels._jit import read_only
from adavar._kernels.difference_runs import SECOND, THIRD
from adavar._kernels.gaps import (
    fill_missing,
    fit_moments,
    lag1_moments,
)
from adavar.core import extended_statistics as ext
from adavar.core import inputs
from adavar.core.errors import AdavarInputError
from adavar.core.results import DeviationResult
from adavar.io import sources
from adavar.io.sampling import resolve_tau0
from adavar.stats import edf as edf_mod
from adavar.stats.noise_id import (
    MIN_POINTS_B1,
    MIN_POINTS_LAG1,
    NoiseIdError,
    alpha_from_lag1,
    alpha_from_phase_lag1,
    avar_of_sum,
    averaged_rule,
    b1_with_rn,
    clamp_alpha,
    fill_unidentified,
    mvar_of_sum,
    pm_with_rn,
    rn_ratio,
    starts_on_phase,
)

__all__ = [
    "GAP_RULES",
    "GAP_STATISTICS",
    "GapLayout",
    "deviation_omitting_gaps",
    "effective_points",
    "gap_noise_types",
    "kept_sums",
]

#: values of ``deviation(gaps=...)``
GAP_RULES = ("error", "omit")
#: the statistics computed with ``gaps="omit"`` on a record with missing samples
GAP_STATISTICS = ("oadev", "adev", "mdev", "tdev", "hdev", "ohdev")

_ORDER = {"oadev": 2, "adev": 2, "hdev": 3, "ohdev": 3, "mdev": 2, "tdev": 2}
_NORM = {"oadev": 2.0, "adev": 2.0, "hdev": 6.0, "ohdev": 6.0}


def _refuse_ungappable(stat: str, n_missing: int) -> None:
    if stat in GAP_STATISTICS:
        return
    why = (
        "its reflected extension of the record is undefined across a gap"
        if stat == "totdev"
        else "it is not computed with missing samples"
    )
    raise AdavarInputError(
        f"stat={stat!r} with gaps='omit' is not defined on a record with {n_missing} missing "
        f"(NaN) sample(s) ({why}): use one of {', '.join(GAP_STATISTICS)}, or fill the gaps "
        "first (read_record(..., nan='interpolate', gaps='interpolate'); --nan / --gaps "
        "interpolate)"
    )


# ---------------------------------------------------------------------------------------
# where the missing samples are


@dataclass(frozen=True)
class GapLayout:
    """The missing samples of a record, as the keep tests read them.

    Attributes
    ----------
    data_type : {"rate", "phase"}
        How the samples are read.
    missing : ndarray of bool
        One flag per input sample.
    cnt : ndarray of int64
        Prefix count, ``cnt[j]`` = missing samples among the first ``j`` (length ``N + 1``).
    pm : ndarray of uint8
        Per phase point, 1 where the point is missing: the missing flags for phase data,
        all zeros for rate data (whose phase points are never missing, only the increments
        between them).
    """

    data_type: str
    missing: np.ndarray
    cnt: np.ndarray
    pm: np.ndarray

    @classmethod
    def of(cls, missing: np.ndarray, data_type: str) -> GapLayout:
        """The layout of ``missing`` (one flag per sample) for ``data_type`` samples."""
        missing = np.ascontiguousarray(missing, dtype=bool)
        cnt = np.zeros(missing.size + 1, dtype=np.int64)
        np.cumsum(missing, out=cnt[1:])
        if data_type == "rate":
            pm = np.zeros(missing.size + 1, dtype=np.uint8)
        else:
            pm = missing.astype(np.uint8)
        return cls(data_type, missing, read_only(cnt), read_only(pm))

    @property
    def n_missing(self) -> int:
        """Number of missing samples."""
        return int(self.cnt[-1])

    def runs(self) -> np.ndarray:
        """Lengths of the runs of consecutive missing samples (the gaps), in order."""
        edges = np.diff(np.concatenate(([0], self.missing.view(np.int8), [0])))
        return np.flatnonzero(edges < 0) - np.flatnonzero(edges > 0)

    def windows(self, stat: str, ms: np.ndarray) -> np.ndarray:
        """``w`` of the prefix test ``cnt[i + w] == cnt[i]`` per averaging factor."""
        ms = np.asarray(ms, dtype=np.int64)
        modified = stat in ("mdev", "tdev")
        if self.data_type == "phase":
            return 3 * ms if modified else np.zeros_like(ms)
        return 3 * ms - 1 if modified else _ORDER[stat] * ms

    def clusters_kept(self, m: int, count: int) -> np.ndarray:
        """Whether each m-cluster sum ``S[(k+1) m] - S[k m]``, ``k < count``, is free of
        missing samples (rate data: its m samples; phase data: its two end points)."""
        if self.data_type == "rate":
            ends = self.cnt[: (count + 1) * m : m]
            return ends[1:] == ends[:-1]
        ok = self.points_kept(m, count)
        return ok[1:] & ok[:-1]

    def points_kept(self, m: int, count: int) -> np.ndarray:
        """Phase data: whether the decimated points ``k m``, ``k <= count``, are present."""
        return self.pm[: count * m + 1 : m] == 0


# ---------------------------------------------------------------------------------------
# the sums


def kept_sums(
    phase: diff.AnchoredPhase, layout: GapLayout, stat: str, ms: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Sums of the kept squared differences of ``stat`` and their numbers, per factor.

    ``phase`` is the anchored phase of the filled record (:func:`filled_increments`). The
    variance is ``sums / (c * m**2 * kept)`` with ``c`` = 2 (Allan), 6 (Hadamard), or
    ``sums / (2 m**4 kept)`` for the modified statistics.
    """
    ms = read_only(ms, np.int64)
    ws = read_only(layout.windows(stat, ms), np.int64)
    n_points = phase.n_points
    order = _ORDER[stat]
    coefs = SECOND if order == 2 else THIRD
    r, hh, hl = phase.r, phase.hh, phase.hl
    if stat in ("mdev", "tdev"):
        counts = read_only(n_points - 3 * ms + 1, np.int64)
        # one part per tau: the running window sum slides over the whole record
        part = max(int(counts.max()), 1) if counts.size else 1
        return diff.modified_sums_kernel(r, hh, hl, ms, counts, (layout.cnt, ws), part=part)
    gaps = (layout.cnt, ws, layout.pm)
    if stat in ("oadev", "ohdev"):
        counts = read_only(n_points - order * ms, np.int64)
        if np.any(counts < 1):
            raise ValueError("internal: empty difference sum")
        starts = np.zeros(ms.size, dtype=np.int64)
        return diff.overlapping_sums_kernel(r, hh, hl, ms, starts, counts, coefs, gaps)
    counts = read_only((n_points - 1) // ms - order + 1, np.int64)
    if np.any(counts < 1):
        raise ValueError("internal: empty difference sum")
    return diff.strided_sums_kernel(r, hh, hl, ms, counts, coefs, gaps)


def effective_points(stat: str, m: int | np.ndarray, kept: int | np.ndarray) -> Any:
    """Phase points of a gap-free record that gives ``kept`` terms of ``stat`` at ``m``.

    The record length handed to the Greenhall-Riley EDF: ``n + 2m`` (oadev), ``n + 3m``
    (ohdev), ``n + 3m - 1`` (mdev, tdev), ``(n + 1) m + 1`` (adev), ``(n + 2) m + 1``
    (hdev), ``n`` the kept count.
    """
    m = np.asarray(m, dtype=np.int64)
    n = np.asarray(kept, dtype=np.int64)
    if stat == "oadev":
        return n + 2 * m
    if stat == "ohdev":
        return n + 3 * m
    if stat in ("mdev", "tdev"):
        return n + 3 * m - 1
    if stat == "adev":
        return (n + 1) * m + 1
    if stat == "hdev":
        return (n + 2) * m + 1
    raise ValueError(f"internal: no effective length for {stat!r}")


def filled_increments(x: np.ndarray, missing: np.ndarray, data_type: str) -> np.ndarray:
    """The increments to integrate: the record with its missing samples interpolated
    linearly, and differenced for phase data.

    At the ends a rate is held at its first / last value; a phase is extrapolated along
    the line through its first / last two points (held, a phase with a large rate offset
    would put a spike of that size in the increments, and cost digits in the rest of its
    anchor block).
    """
    filled = np.empty(x.size)
    fill_missing(read_only(x, np.float64), read_only(missing, np.bool_), filled)
    if data_type == "rate":
        return filled
    have = np.flatnonzero(~missing)
    if have.size >= 2:
        for a, b, end in ((have[0], have[1], slice(0, have[0])),
                          (have[-1], have[-2], slice(have[-1] + 1, x.size))):  # fmt: skip
            slope = (x[b] - x[a]) / (b - a)
            filled[end] = x[a] + slope * (np.arange(x.size)[end] - a)
    return np.diff(filled)


# ---------------------------------------------------------------------------------------
# noise identification on the kept data


def _fit(z: np.ndarray, ok: np.ndarray, deg: int) -> tuple[np.ndarray, float]:
    """Least-squares polynomial of degree ``deg`` (1 or 2) through the kept entries of
    ``z`` (coefficients of ``t = (k - kc) / kc``, padded to 3) and ``max |z|`` over them."""
    mom = fit_moments(z, ok)
    size = deg + 1
    gram = np.array([[mom[i + j] for j in range(size)] for i in range(size)])
    coef = np.zeros(3)
    coef[:size] = np.linalg.lstsq(gram, mom[5 : 5 + size], rcond=None)[0]
    return read_only(coef), float(mom[8])


def _lag1_of(acc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(r1, den, sizes)`` per order from :func:`adavar._kernels.gaps.lag1_moments`.

    ``den = sum (x - mean)^2`` over the kept entries; ``r1`` is the mean centred lag
    product over the pairs of adjacent kept entries divided by ``den / (kept - 1)``:
    without gaps, the usual ``sum c_k c_{k+1} / sum c_k^2``.
    """
    nv, s1, s2, npairs, spp, sprev, scur = acc.T
    r1 = np.full(nv.size, np.nan)
    den = np.zeros(nv.size)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(nv > 0, s1 / np.maximum(nv, 1), 0.0)
        den = np.where(nv > 1, s2 - nv * mean * mean, 0.0)
        num = spp - mean * (sprev + scur) + npairs * mean * mean
        good = (npairs > 0) & (den > 0)
        r1[good] = (num[good] / den[good]) * (nv[good] - 1) / npairs[good]
    return r1, den, nv.astype(np.int64)


def gap_rate_lag1(z: np.ndarray, ok: np.ndarray, dmax: int):
    """Lag-1 statistics of the linearly detrended cluster sums ``z`` over the kept ones.

    Returns ``(r1, den, sizes, scale)`` for ``d = 0 .. dmax`` differences (as
    :func:`adavar._kernels.differences.cluster_lag1`); an entry of a differenced series is kept
    when both of its parents are, and only pairs of adjacent kept entries enter the lag
    products.
    """
    z = read_only(z, np.float64)
    ok = read_only(ok, np.bool_)
    coef, scale = _fit(z, ok, 1)
    r1, den, sizes = _lag1_of(lag1_moments(z, ok, coef, int(dmax)))
    return r1, den, sizes, scale


def gap_phase_lag1(p: np.ndarray, ok: np.ndarray) -> tuple[float, float, int, float]:
    """Lag-1 statistics of the quadratically detrended decimated phase ``p`` over its kept
    points (as :func:`adavar.stats.noise_id.decimated_phase_lag1`)."""
    p = read_only(p, np.float64)
    ok = read_only(ok, np.bool_)
    coef, scale = _fit(p, ok, 2)
    r1, den, sizes = _lag1_of(lag1_moments(p, ok, coef, 0))
    return float(r1[0]), float(den[0]), int(sizes[0]), scale


def _longest_run(ok: np.ndarray) -> slice:
    edges = np.diff(np.concatenate(([0], ok.view(np.int8), [0])))
    starts, stops = np.flatnonzero(edges > 0), np.flatnonzero(edges < 0)
    if starts.size == 0:
        return slice(0, 0)
    k = int(np.argmax(stops - starts))
    return slice(int(starts[k]), int(stops[k]))


def _gap_rn(phase: diff.AnchoredPhase, layout: GapLayout, m: int) -> float | None:
    """R(n) = MVAR / AVAR at ``m`` from the kept terms (None if either has none)."""
    ms = np.array([m], dtype=np.int64)
    a_sum, a_n = kept_sums(phase, layout, "oadev", ms)
    m_sum, m_n = kept_sums(phase, layout, "mdev", ms)
    if a_n[0] == 0 or m_n[0] == 0:
        return None
    avar = avar_of_sum(float(a_sum[0]), m, int(a_n[0]))
    return rn_ratio(avar, mvar_of_sum(float(m_sum[0]), m, int(m_n[0])))


def gap_noise_types(
    phase: diff.AnchoredPhase,
    layout: GapLayout,
    ms: np.ndarray,
    dmax: int,
    *,
    data_type: str = "rate",
    noise_id: str = "sp1065",
) -> tuple[np.ndarray, tuple[str, ...]]:
    """Noise exponent per tau of a record with gaps (the rules of
    :func:`adavar.stats.statistics.record_noise_types` on the kept data; module notes).

    Returns ``(alpha, notes)`` as :func:`adavar.stats.noise_id.fill_unidentified`.
    """
    strict = noise_id == "stable32"
    on_phase = starts_on_phase(data_type, noise_id)
    alpha = np.full(ms.size, np.nan)
    for k, m in enumerate(ms):
        m = int(m)
        count = (phase.n_points - 1) // m
        if count < 2:
            continue
        z = diff.cluster_differences(phase.r, phase.hh, phase.hl, m, count)
        ok = layout.clusters_kept(m, count)
        rn = lambda m=m: _gap_rn(phase, layout, m)  # noqa: E731 - evaluated if needed
        pairs = int(np.count_nonzero(ok[:-1] & ok[1:]))
        try:
            if int(ok.sum()) >= MIN_POINTS_LAG1 and pairs >= MIN_POINTS_LAG1 - 1:
                pstats = None
                if on_phase:
                    p = np.concatenate(([0.0], np.cumsum(z)))
                    pok = layout.points_kept(m, count)
                    pstats = gap_phase_lag1(p, pok)
                    got = alpha_from_phase_lag1(pstats, None, dmax=dmax)
                    if got is not None:
                        alpha[k] = pm_with_rn(got, m, rn)
                        continue
                stats = gap_rate_lag1(z, ok, dmax - 1 if on_phase else dmax)
                averaged = averaged_rule(noise_id, m)
                if on_phase:
                    alpha[k] = alpha_from_phase_lag1(pstats, stats, dmax=dmax, averaged=averaged)
                else:
                    r1, den, sizes, scale = stats
                    alpha[k] = clamp_alpha(
                        alpha_from_lag1(
                            r1, den, sizes, scale, data_type="rate", dmax=dmax, averaged=averaged
                        )[0],
                        dmax,
                    )
            else:
                run = _longest_run(ok)
                if run.stop - run.start >= MIN_POINTS_B1:
                    y = z[run] / m + phase.shift
                    alpha[k] = b1_with_rn(y, m, dmax, rn, strict=strict)
        except NoiseIdError:
            continue
    return fill_unidentified(alpha)


# ---------------------------------------------------------------------------------------
# deviation(..., gaps="omit")


_IN_MEMORY = (
    "the record has missing (NaN) samples, and gaps='omit' computes such a record in memory: "
    "leave out chunk_size (--chunk-size)"
)


class _MissingFound(Exception):
    """A streamed record holds a NaN: it is computed in memory instead."""


class _WatchedSource(sources.ChunkedSource):
    """A source that raises :class:`_MissingFound` on the first NaN it reads."""

    def __init__(self, source: sources.ChunkedSource) -> None:
        self.source = source
        self.size = source.size
        self.name = source.name
        self.dtype = source.dtype

    def _read_raw(self, start: int, stop: int) -> np.ndarray:
        raw = self.source.read_unchecked(start, stop)
        if raw.dtype.kind in "fc" and np.isnan(raw).any():
            raise _MissingFound
        return raw


def read_whole(source: sources.ChunkedSource) -> np.ndarray:
    out = np.empty(source.size)
    for start in range(0, source.size, sources.DEFAULT_CHUNK):
        stop = min(source.size, start + sources.DEFAULT_CHUNK)
        out[start:stop] = source.read_unchecked(start, stop)
    return out


def samples_with_gaps(data: Any) -> np.ndarray:
    """The record as a 1-D float64 array with NaN where missing (masked samples become
    NaN); everything else is checked as :func:`adavar.stats.statistics.as_samples` does."""
    if isinstance(data, np.ma.MaskedArray) and np.ma.getmaskarray(data).any():
        try:
            data = np.ma.asarray(data).astype(np.float64).filled(np.nan)
        except (TypeError, ValueError):
            pass  # not real numbers: as_samples names the problem
    try:
        x = np.asarray(data)
    except Exception as exc:  # pragma: no cover - exotic containers
        raise AdavarInputError(f"cannot read the data as an array: {exc}") from None
    if x.dtype.kind != "f":
        return inputs.as_samples(data, min_length=0)  # no NaN possible; its checks and errors
    missing = np.isnan(x)
    if not missing.any():
        return inputs.as_samples(x, min_length=0)
    inputs.as_samples(np.where(missing, 0.0, x), min_length=0)  # shape, Inf: its errors
    return np.asarray(np.squeeze(x) if x.ndim != 1 else x, dtype=np.float64)


def deviation_omitting_gaps(
    data: Any, *, whole: Callable[..., DeviationResult], gaps: str, **options: Any
) -> DeviationResult:
    """:func:`adavar.deviation` with ``gaps="omit"`` (see the module notes).

    A record without NaN goes to the gap-free path ``whole`` (:func:`adavar.deviation`
    with ``gaps="error"``, passed by its caller) unchanged: an identical result; one with
    NaN is computed here.
    """
    if gaps not in GAP_RULES:
        raise AdavarInputError(f"unknown gaps {gaps!r}: use one of {', '.join(GAP_RULES)}")
    if gaps == "error":
        return whole(data, gaps="error", **options)
    chunk_size = options.get("chunk_size")
    notes: tuple[str, ...] = ()
    if sources.is_chunked(data):
        try:
            return whole(_WatchedSource(sources.as_source(data)), gaps="error", **options)
        except _MissingFound:
            if chunk_size is not None:
                raise AdavarInputError(_IN_MEMORY) from None
        source = sources.as_source(data)
        x = samples_with_gaps(read_whole(source))  # Inf: the one-line error
        notes = (f"{source.name} holds missing samples: it was read into memory",)
    else:
        x = samples_with_gaps(data)
    missing = np.isnan(x)
    if not missing.any():
        return whole(x, gaps="error", **options)
    if chunk_size is not None and not notes:
        raise AdavarInputError(_IN_MEMORY)
    return _gap_deviation(x, missing, notes=notes, **options)


def _gap_deviation(
    x: np.ndarray,
    missing: np.ndarray,
    *,
    notes: tuple[str, ...],
    stat: str,
    rate: float,
    data_type: str,
    taus: str | Sequence[float] | np.ndarray,
    confidence: float | None,
    tau0: float | None,
    points_per_decade: int,
    units: str | None,
    noise_id: str,
    **others: Any,
) -> DeviationResult:
    """The deviation of a record with NaN (checked options, as :func:`adavar.deviation`).

    ``others``: the keywords of the statistics refused here (totdev's, those of
    :mod:`adavar.core.extended_statistics`, which must be None), and ``chunk_size`` (there is
    no out-of-core gap path).
    """
    dtype = inputs.DATA_TYPE_ALIASES[str(data_type).lower()]
    step = resolve_tau0(rate, tau0)
    n_missing = int(missing.sum())
    _refuse_ungappable(stat, n_missing)
    extended = {name for spec in ext.SPECS.values() for name in spec.options}
    for name in sorted(extended & set(others)):
        if others[name] is not None:
            raise AdavarInputError(f"{name} does not apply to stat={stat!r}: drop it")
    min_length = 4 if dtype == "phase" else 3
    n_valid = x.size - n_missing
    if n_valid < min_length:
        raise AdavarInputError(
            f"the record has {n_valid} samples that are not missing (of {x.size}); at least "
            f"{min_length} are needed"
        )
    exponent = inputs.data_exponent(x[~missing])
    if exponent:
        x = np.ldexp(x, -exponent)
    layout = GapLayout.of(missing, dtype)
    u = filled_increments(x, missing, dtype)
    n_points = u.size + 1
    step_mantissa, step_exponent = math.frexp(step)
    scale = 1.0 if dtype == "rate" else 1.0 / step_mantissa**2
    if dtype == "phase":
        exponent -= step_exponent
    most = inputs.largest_factor(stat, n_points)
    ms, tau_notes = inputs.tau_factors(taus, most, step, points_per_decade)
    phase = diff.anchored_phase(u)
    sums, kept = kept_sums(phase, layout, stat, ms)
    empty = kept == 0
    gap_sizes = layout.runs()
    notes = (
        *tau_notes,
        *notes,
        f"gaps='omit': {n_missing} of {x.size} samples are missing (NaN), in "
        f"{gap_sizes.size} gap(s) of up to {int(gap_sizes.max())} samples; every difference "
        "term that touches a missing sample is left out (n = terms kept), and the EDF is "
        "that of a gap-free record with as many terms",
    )
    if empty.all():
        raise AdavarInputError(
            f"no difference term of {stat} is free of missing samples at any tau "
            f"({n_missing} of {x.size} samples are NaN): give taus shorter than the stretches "
            "between the gaps, or fill the gaps first"
        )
    if empty.any():
        dropped = ", ".join(f"{m * step:g}" for m in ms[empty])
        notes = (*notes, f"taus with no term free of missing samples dropped: {dropped} s")
        ms, sums, kept = ms[~empty], sums[~empty], kept[~empty]
    m2 = ms.astype(np.float64) ** 2
    if stat in ("mdev", "tdev"):
        var = sums / (2.0 * m2 * m2 * kept)
    else:
        var = sums / (_NORM[stat] * m2 * kept)
    var = var * scale
    if stat == "tdev":
        var = var * (ms * step_mantissa) ** 2 / 3.0
        exponent += step_exponent

    if confidence is None:
        nan = np.full(ms.size, np.nan)
        alpha = np.full(ms.size, -1, dtype=np.int64)
        edf_values, low, high = nan, nan.copy(), nan.copy()
    else:
        dmax = 3 if stat in ("hdev", "ohdev") else 2
        alpha, id_notes = gap_noise_types(
            phase, layout, ms, dmax, data_type=dtype, noise_id=noise_id
        )
        notes = notes + id_notes
        points = effective_points(stat, ms, kept)
        edf_values = np.array(
            [
                edf_mod.edf(stat, int(a), int(m), int(p))
                for a, m, p in zip(alpha, ms, points, strict=True)
            ]
        )
        var_low, var_high = edf_mod.chi2_interval(var, edf_values, float(confidence))
        low = inputs.unscale(np.sqrt(var_low), exponent, "deviations")
        high = inputs.unscale(np.sqrt(var_high), exponent, "deviations")

    return DeviationResult(
        tau=ms * step,
        dev=inputs.unscale(np.sqrt(var), exponent, "deviations"),
        dev_low=low,
        dev_high=high,
        edf=edf_values,
        n=np.asarray(kept, dtype=np.int64),
        m=ms,
        alpha=alpha,
        stat=stat,
        data_type=dtype,
        tau0=step,
        confidence=float("nan") if confidence is None else float(confidence),
        n_samples=int(x.size),
        units=units,
        notes=notes,
    )

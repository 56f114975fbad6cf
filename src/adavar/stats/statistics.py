"""Allan-family statistics of a whole record, with confidence intervals.

One entry point, :func:`deviation`, for the non-overlapping and overlapping Allan deviation,
the modified Allan and time deviation, the non-overlapping and overlapping Hadamard deviation
and the total deviation (NIST SP 1065 definitions). Every statistic is a sum of squared
finite differences of the integrated signal computed by :mod:`adavar._kernels.differences` in O(N)
per averaging time and exactly (a few ulps), even on records with large offsets or drifts.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from adavar._kernels import differences as diff
from adavar._kernels.moments import difference_moments
from adavar.core import extended_statistics as ext
from adavar.core.errors import AdavarInputError
from adavar.core.inputs import (
    DATA_TYPE_ALIASES,
    DATA_TYPES,
    SAFE_EXPONENT,
    as_samples,
    check_confidence,
    data_exponent,
    largest_factor,
    range_exponent,
    refuse_masked,
    samples_and_range,
    scaled,
    tau_factors,
    unscale,
)
from adavar.core.results import DeviationResult
from adavar.core.settings import ALL_STATISTICS, MAX_POINTS_PER_DECADE, RATE_DEFAULT, STATISTICS
from adavar.io import sources
from adavar.io.sampling import resolve_rate, resolve_tau0
from adavar.io.scaling import ScaledSource, scaled_source
from adavar.stats import edf as edf_mod
from adavar.stats import record_sums, stream
from adavar.stats.noise_id import (
    NOISE_ID_RULES,
    avar_of_sum,
    averaged_rule,
    fill_unidentified,
    mvar_of_sum,
    rate_noise_types,
    rn_ratio,
    starts_on_phase,
)
from adavar.stats.stationary_noise import stationarity

__all__ = [
    "DATA_TYPES",
    "MAX_POINTS_PER_DECADE",
    "NOISE_ID_RULES",
    "RATE_DEFAULT",
    "SAFE_EXPONENT",
    "STATISTICS",
    "ScaledSource",
    "as_samples",
    "check_confidence",
    "data_exponent",
    "deviation",
    "refuse_masked",
    "resolve_rate",
    "resolve_tau0",
    "scaled",
    "scaled_source",
    "tau_factors",
    "unscale",
]


def _rn_in_memory(
    phase: diff.AnchoredPhase, ms: Sequence[int], avar: dict[int, float] | None = None
) -> dict[int, float | None]:
    """R(n) = MVAR / AVAR at each of ``ms`` (one call of each kernel for all of them).

    ``avar`` may hold the overlapping Allan variances already known (by ``m``).
    """
    ms = sorted(set(ms))
    avar = {} if avar is None else avar
    need = [m for m in ms if m not in avar]
    if need:
        sums = record_sums.overlapping_sums(phase, np.array(need, dtype=np.int64), 2).tolist()
        avar = avar | {
            m: avar_of_sum(total, m, phase.n_points - 2 * m)
            for m, total in zip(need, sums, strict=True)
        }
    mod_sums, counts = record_sums.modified_sums(phase, np.array(ms, dtype=np.int64))
    return {
        m: rn_ratio(avar[m], mvar_of_sum(mod_sum, m, count))
        for m, mod_sum, count in zip(ms, mod_sums.tolist(), counts.tolist(), strict=True)
    }


class _RnTable:
    """R(n) of the in-memory record by ``m``, computed when first asked for.

    The first request computes it for every tau of ``candidates`` (the B1 taus, which
    usually all need it) in one pass of each kernel; ``avar`` (by ``m``) are overlapping
    Allan variances known already.
    """

    def __init__(
        self,
        phase: diff.AnchoredPhase,
        candidates: Sequence[int],
        avar: dict[int, float] | None = None,
    ) -> None:
        self.phase = phase
        self.pending = set(candidates)
        self.avar = avar
        self.ratios: dict[int, float | None] = {}

    def __call__(self, m: int) -> float | None:
        if m not in self.ratios:
            self.ratios.update(_rn_in_memory(self.phase, self.pending | {m}, self.avar))
            self.pending.clear()
        return self.ratios[m]


def record_noise_types(
    phase: diff.AnchoredPhase,
    ms: np.ndarray,
    dmax: int,
    *,
    data_type: str = "rate",
    noise_id: str = "sp1065",
    avar: np.ndarray | None = None,
):
    """Power-law noise exponent per tau: lag-1 ACF, B1 + R(n) fallback, else the neighbour's.

    Every tau in one compiled call (:func:`adavar.stats.noise_id.rate_noise_types`), on the
    cluster sums of the anchored phase (no copy of the record per tau). With
    ``noise_id="sp1065"`` the lag-1 test starts on the decimated phase
    (:mod:`adavar.stats.noise_id`) for rate and phase data alike (the record integrated to its
    phase), and a "white PM" there is checked by R(n); ``"input"`` starts it there for phase data
    only and on the m-averaged rate for rate data (adavar before issue 39); ``"stable32"`` on the
    m-averaged rate for both (clamped) and uses R(n) only where B1 says PM. Short series go
    to the B1 ratio. ``avar``, if given, is the overlapping Allan variance of ``phase`` at
    every ``m`` (the OADEV being computed): R(n) then takes it instead of recomputing it.
    """
    return fill_unidentified(
        rate_noise_types(
            phase,
            ms,
            dmax,
            avar=avar,
            strict=noise_id == "stable32",
            on_phase=starts_on_phase(data_type, noise_id),
            averaged=averaged_rule(noise_id, 2),
        )
    )


TOTVAR_BIAS: dict[int, float] = {-1: 1.0 / (3.0 * np.log(2.0)), -2: 0.75}
OMIT_HINT = "pass gaps='omit' (--gaps omit) to leave out the terms that touch missing samples, or "


def deviation(
    data: Sequence[float] | np.ndarray | sources.ChunkedSource,
    *,
    stat: str = "oadev",
    rate: float = RATE_DEFAULT,
    data_type: str = "rate",
    taus: str | Sequence[float] | np.ndarray = "octave",
    confidence: float | None = 0.683,
    tau0: float | None = None,
    points_per_decade: int = 10,
    units: str | None = None,
    chunk_size: int | None = None,
    noise_id: str = "sp1065",
    totdev_edf: str = "sp1065",
    totdev_bias: bool = False,
    bias_correction: bool | None = None,
    theo_ratio_terms: int | None = None,
    total_edf: str | None = None,
    gaps: str = "error",
    stationarity_check: bool = True,
) -> DeviationResult:
    """Allan-family deviation of a whole record, with a confidence interval at every tau.

    Parameters
    ----------
    data : array_like, ChunkedSource, dask.array.Array or numpy.memmap
        The record, one sample per ``tau0``. A :class:`~adavar.stats.stream.ChunkedSource`, a
        ``dask.array`` or a memory map of a ``.npy`` file (``np.load(path, mmap_mode="r")``)
        is read piece by piece and never held whole (see Notes).
    stat : {"oadev", "adev", "mdev", "tdev", "hdev", "ohdev", "totdev"}
        ``adev`` non-overlapping Allan deviation (the paper's Eq. 1), ``oadev`` overlapping
        Allan, ``mdev`` modified Allan, ``tdev`` time deviation (``tau * mdev / sqrt(3)``,
        in phase units), ``hdev``/``ohdev`` non-overlapping/overlapping Hadamard, ``totdev``
        total deviation (reflected record, NIST SP 1065).
    rate : float, optional
        Sample rate in Hz (ignored when ``tau0`` is given). By default the rate of the time
        index of a pandas Series/DataFrame (DatetimeIndex, TimedeltaIndex) or of the time
        coordinate of an xarray DataArray, else 1 Hz (:func:`resolve_rate`: an index that
        is not evenly spaced, or a rate or tau0 given that contradicts it, is an error).
    data_type : {"rate", "phase"}
        ``"rate"``: rate samples (gyro angular rate, accelerometer output, fractional
        frequency); ``"phase"``: their integral (angle, velocity, time error).
    taus : {"octave", "all", "decade", "log"} or sequence of float
        Averaging times; see :func:`adavar.core.taus.averaging_factors`. Explicit taus are
        rounded to whole multiples of ``tau0`` and ones outside the allowed range dropped;
        ``result.notes`` says so.
    confidence : float or None
        Two-sided level of the chi-square interval (default 0.683, i.e. 1 sigma). The
        equivalent degrees of freedom follow the Greenhall-Riley algorithm (SP 1065), with
        the noise type identified per tau by the lag-1 autocorrelation (B1 ratio fallback,
        the Stable32 default). ``None`` skips noise identification and intervals
        (``dev_low``, ``dev_high``, ``edf``, ``alpha`` are NaN/-1) for speed.
    tau0 : float, optional
        Sample interval in seconds, instead of ``rate``.
    points_per_decade : int
        Density of ``taus="log"``, 1 .. :data:`MAX_POINTS_PER_DECADE` (denser taus add no
        information: neighbours would differ by less than 0.23 %).
    units : str, optional
        Declared unit of the samples (e.g. ``"deg/s"``), carried to the fit's unit
        conversions. Never guessed.
    chunk_size : int, optional
        Samples per read for the out-of-core computation. Giving it forces that path even
        for an in-memory array; for chunked ``data`` the default is
        :data:`adavar.stats.stream.DEFAULT_CHUNK`.
    noise_id : {"sp1065", "stable32", "input"}
        Noise identification for the intervals (see :mod:`adavar.stats.noise_id`). ``"sp1065"``
        (default): lag-1 autocorrelation with at least 30 clusters, started on the
        decimated phase ``x[::m]`` (SP 1065) for phase and rate data alike (rate data are
        integrated to their phase), where a "white PM" result is checked by R(n) =
        MVAR/AVAR (the short detrended decimated phase reads flicker PM as white PM at
        m >= 16); below 30 clusters the B1 ratio, with R(n) separating white PM, flicker
        PM and white FM whenever B1 says PM or white FM. A noise thus gets the same type
        and EDF whichever input type carries it. ``"input"``: the same, but rate data
        identified on the m-averaged rate (adavar before 0.2: flicker PM as rate data
        read as white PM in half the records at m = 16-128, intervals covering 48-59 %).
        ``"stable32"``: the rule Stable32's published tables follow: phase and rate data
        identified on the m-averaged rate (white PM then reads as alpha 3..6 in a third of
        the records, clamped to 2), R(n) only where B1 says PM. Every alpha is clamped to
        the statistic's range ([-2, 2]; Hadamard [-4, 2]).
    totdev_edf : {"sp1065", "stable32", "legacy"}
        TOTDEV EDF convention (:func:`adavar.stats.edf.edf`): ``"stable32"`` reproduces Stable32's
        bounds, ``"legacy"`` adavar's earlier choice.
    totdev_bias : bool
        Divide TOTVAR by its SP 1065 bias ``1 - a tau/T`` (a = 1/(3 ln 2) flicker FM, 3/4
        random-walk FM, per the identified alpha; T = N tau0), as Stable32 does for
        frequency data, so that ``dev`` estimates the Allan deviation. Default False: the
        plain TOTDEV of SP 1065 (its published values).
    bias_correction : bool, optional
        For the statistics of :mod:`adavar.core.extended_statistics` that have a bias correction
        (``htotdev``...): apply it or not; None (default) takes the statistic's default.
        An error for a statistic without one.
    total_edf : {"sp1065", "stable32"}, optional
        ``mtotdev``/``ttotdev``/``htotdev``: the EDF convention (default ``"sp1065"``; see
        :func:`adavar.stats.total_family.edf`).
    theo_ratio_terms : int, optional
        ``theobr``/``theoh``: how many AVAR/Theo1 ratios make the bias ratio (default: all,
        as SP 1065 and Stable32; fewer differs by up to 10 %, see
        :func:`adavar.stats.theo_family.theobr_ratio`).
    gaps : {"error", "omit"}
        What a NaN sample means. ``"error"`` (default): it is refused. ``"omit"``: it is a
        missing sample on the regular grid (sample ``k`` at ``k * tau0``), and every
        difference term that touches one is left out; ``result.n`` counts the terms kept,
        the variance is their mean with the usual normalisation, and a note gives the
        number of missing samples. Rate data: a term over phase points ``i .. i + L``
        touches the rate samples ``i .. i + L - 1`` (``L`` = 2m Allan, 3m Hadamard,
        3m - 1 modified) and is left out if any is missing. Phase data: an Allan or
        Hadamard term is left out only if one of its own points ``i + k m`` is missing,
        a modified one if any point of its m-sums, ``i .. i + 3m - 1``, is. The EDF is
        that of a gap-free record giving as many terms (:func:`adavar.stats.gaps.effective_points`)
        and the noise type is identified on the kept data (:mod:`adavar.stats.gaps`). For
        ``oadev``, ``adev``, ``mdev``, ``tdev``, ``hdev``, ``ohdev``; ``totdev`` and the
        other statistics are refused on a record with NaN. A masked array's masked
        samples are missing samples too. Without NaN the result is that of ``"error"``.
    stationarity_check : bool
        Test whether the record's short-tau noise is stationary
        (:func:`adavar.stationarity`, one more pass over the record; not with
        ``gaps="omit"`` on a record with NaN) and, if it is not (p < 1e-3), say so in
        ``result.warnings``,
        with the suspect stretch: one whole-record curve then averages different noise
        levels, and :func:`adavar.dynamic.adaptive` follows them. Default True; False skips it.

    Returns
    -------
    DeviationResult
        ``tau``, ``dev``, ``dev_low``, ``dev_high``, ``edf``, ``n``, ``m``, ``alpha`` and the
        inputs used.

    Notes
    -----
    The record is integrated once into an anchored double-double form; a constant rate
    offset is removed exactly (all statistics here are blind to it), so a bias of 1e6
    standard deviations or a drift costs no digits. For rate input ``tau0`` cancels from
    the variance; for phase input it sets the units (phase/second).

    Every statistic is homogeneous: a record beyond ``2**±SAFE_EXPONENT`` (values near
    1e306, or subnormal numbers) is computed at scale 1, scaled by a power of two (exact),
    and its deviations scaled back, so ``deviation(x * 2**k).dev == deviation(x).dev * 2**k``
    bit for bit; a deviation beyond the largest double is an :class:`AdavarInputError`, one
    below the normal range is the nearest subnormal. The binary exponent of ``tau0`` is
    carried the same way for phase data and TDEV. A :class:`numpy.ma.MaskedArray` with
    masked samples is refused (unless ``gaps="omit"``), as are a ``rate`` that is ``None``
    without ``tau0`` or a ``bool``, taus that overflow, and more than
    :data:`MAX_POINTS_PER_DECADE` points per decade.

    Out of core (chunked ``data`` or ``chunk_size`` given): the same anchored form is built
    by :mod:`adavar.stats.record_sums` in one pass, keeping only its double-double anchors
    (16 bytes per 1024 samples); the local sums are recomputed over windows that slide
    along the record, so every difference is the one the in-memory path computes and the
    result equals it (a few ulps; every field: ``n``, ``m``, ``edf``, ``alpha``, ``notes``)
    for any chunk size. Working memory is a few ``chunk_size`` samples. Cost: the short
    averaging factors take one sweep over the record; each ``m`` beyond about
    ``chunk_size / 2`` reads the record about twice (three times for the Hadamard
    statistics) in streams side by side, so ``taus="all"`` on a long record is slow here
    as it is in memory. ``totdev`` reads the reflected record (three times the length).
    Noise identification streams the record as well
    (:func:`adavar.stats.stream.noise_types`).
    """
    spec = ext.spec_of(stat)
    if stat not in STATISTICS and spec is None:
        raise AdavarInputError(f"unknown stat {stat!r}: use one of {', '.join(ALL_STATISTICS)}")
    if noise_id not in NOISE_ID_RULES:
        raise AdavarInputError(f"unknown noise_id {noise_id!r}: use one of {NOISE_ID_RULES}")
    if str(totdev_edf).lower() not in edf_mod.TOTDEV_EDF_METHODS:
        raise AdavarInputError(
            f"unknown totdev_edf {totdev_edf!r}: use one of {edf_mod.TOTDEV_EDF_METHODS}"
        )
    dtype = DATA_TYPE_ALIASES.get(str(data_type).lower())
    if dtype is None:
        raise AdavarInputError(f"unknown data_type {data_type!r}: use 'rate' or 'phase'")
    check_confidence(confidence)
    rate, tau0, step = resolve_rate(data, rate, tau0)  # a time index gives it, or 1 Hz
    min_length = 4 if dtype == "phase" else 3
    if gaps != "error":  # loaded on first use; a gap-free record comes back here
        from adavar.stats.gaps import deviation_omitting_gaps

        keywords = {k: v for k, v in locals().items() if k in _DEVIATION_KEYWORDS}
        return deviation_omitting_gaps(data, whole=deviation, **keywords)
    refuse_masked(data)

    # the record is computed at scale 1 (exact: a power of two), the deviations scaled back
    # by 2**exponent; the sample interval's binary exponent joins it for phase data and TDEV
    chunked = chunk_size is not None or sources.is_chunked(data)
    if chunked:
        chunk = sources.check_chunk_size(chunk_size) if chunk_size is not None else None
        chunk = sources.DEFAULT_CHUNK if chunk is None else chunk
        source, exponent = scaled_source(sources.open_record(data, min_length))
        increments = source if dtype == "rate" else sources.DifferencedSource(source)
        n_samples, n_points = source.size, increments.size + 1
    else:
        x, low, high = samples_and_range(data, min_length, OMIT_HINT)
        exponent = range_exponent(low, high)
        if exponent:
            x = np.ldexp(x, -exponent)  # scaled(x), with the range already known
        # the stationarity screen needs the range too: not read again (exact: ldexp)
        extremes = (math.ldexp(low, -exponent), math.ldexp(high, -exponent))
        u = x if dtype == "rate" else np.diff(x)
        n_samples, n_points = x.size, u.size + 1

    step_mantissa, step_exponent = math.frexp(step)
    scale = 1.0 if dtype == "rate" else 1.0 / step_mantissa**2
    if dtype == "phase":
        exponent -= step_exponent
    # options of the statistics beyond the Allan seven: None means the statistic's default
    given = {
        "bias_correction": bias_correction,
        "theo_ratio_terms": theo_ratio_terms,
        "total_edf": total_edf,
    }
    options = {k: v for k, v in given.items() if v is not None}
    unknown = sorted(set(options) - set(spec.options if spec is not None else ()))
    if unknown:
        raise AdavarInputError(
            f"{unknown[0]} does not apply to stat={stat!r}: drop it (it is an option of "
            + ", ".join(s.name for s in ext.SPECS.values() if unknown[0] in s.options)
            + ")"
        )
    if spec is not None:
        if chunked:
            raise AdavarInputError(
                f"stat={stat!r} is computed in memory: pass the record as an array "
                "(np.asarray(data)), or use one of the Allan statistics out of core"
            )
        return _with_warnings(_extended_deviation(
            spec, u, x.size, dtype, step, exponent, taus, points_per_decade, confidence,
            noise_id, units, options,
        ), x, step, dtype, stationarity_check)  # fmt: skip
    ms, notes = tau_factors(taus, largest_factor(stat, n_points), step, points_per_decade)
    if not chunked:
        phase = diff.anchored_phase(u, cluster_stats=confidence is not None)
    elif stat != "totdev":
        phase = record_sums.streamed_phase(increments, chunk)
    sums_of = record_sums  # either phase: in memory it is one chunk
    m2 = ms.astype(np.float64) ** 2

    oavar = None  # the overlapping AVAR of the phase, for R(n), when it is computed anyway
    if stat == "oadev":
        n = n_points - 2 * ms
        var = oavar = sums_of.overlapping_sums(phase, ms, 2) / (2.0 * m2 * n)
    elif stat == "adev":
        sums, n = sums_of.strided_sums(phase, ms, 2)
        var = sums / (2.0 * m2 * n)
    elif stat in ("mdev", "tdev"):
        sums, n = sums_of.modified_sums(phase, ms)
        var = sums / (2.0 * m2 * m2 * n)
    elif stat == "hdev":
        sums, n = sums_of.strided_sums(phase, ms, 3)
        var = sums / (6.0 * m2 * n)
    elif stat == "ohdev":
        n = n_points - 3 * ms
        var = sums_of.overlapping_sums(phase, ms, 3) / (6.0 * m2 * n)
    else:  # totdev: reflect the record at both ends (SP 1065), i.e. time-reverse the rate
        pad = n_points - 2
        n = np.full(ms.size, n_points - 2, dtype=np.int64)
        starts = pad + 1 - ms
        if chunked:
            # the reflected record is read through index arithmetic, never built
            extended = record_sums.streamed_phase(
                record_sums.ReflectedSource(increments, pad),
                chunk,
                shift=record_sums.initial_shift(increments),
            )
        else:
            extended = diff.anchored_phase(np.pad(u, pad, mode="symmetric"), shift=phase.shift)
        sums = record_sums.overlapping_sums(extended, ms, 2, starts=starts, counts=n)
        var = sums / (2.0 * m2 * n)
    if scale != 1.0:
        var = var * scale
    tau = ms * step
    if stat == "tdev":
        var = var * (ms * step_mantissa) ** 2 / 3.0
        exponent += step_exponent

    if confidence is None:
        nan = np.full(ms.size, np.nan)
        alpha = np.full(ms.size, -1, dtype=np.int64)
        edf_values, low, high = nan, nan.copy(), nan.copy()
    else:
        dmax = 3 if stat in ("hdev", "ohdev") else 2
        if chunked:
            alpha, id_notes = stream.noise_types(
                increments, ms, dmax, chunk_size=chunk, data_type=dtype, noise_id=noise_id
            )
        else:
            alpha, id_notes = record_noise_types(
                phase, ms, dmax, data_type=dtype, noise_id=noise_id, avar=oavar
            )
        notes = notes + id_notes
        edf_values, upper, lower = edf_mod.interval_table(
            stat, alpha, ms, n_points, float(confidence), totdev_edf=totdev_edf
        )
        if stat == "totdev" and totdev_bias:
            bias = np.array([TOTVAR_BIAS.get(int(a), 0.0) for a in alpha])
            var = var / (1.0 - bias * ms / (n_points - 1))
        # edf_mod.chi2_interval's bounds; nothing to check: var is finite, edf >= 1
        var_low, var_high = edf_mod.chi2_bounds(var, edf_values, upper, lower)
        edf_values = edf_values.copy()  # the result's own (the table is shared)
        low = unscale(np.sqrt(var_low), exponent, "deviations")
        high = unscale(np.sqrt(var_high), exponent, "deviations")

    result = _result(
        tau, unscale(np.sqrt(var), exponent, "deviations"), low, high, edf_values, n, ms,
        alpha, stat, dtype, step, confidence, n_samples, units, notes,
    )  # fmt: skip
    if chunked:
        result = replace(result, increment_kurtosis=increment_kurtosis(increments, chunk))
        return _with_warnings(result, source, step, dtype, stationarity_check, chunk)
    result = replace(result, increment_kurtosis=increment_kurtosis(u))
    return _with_warnings(result, x, step, dtype, stationarity_check, extremes=extremes)


#: Rate samples whose first differences :func:`increment_kurtosis` reads at most (from the
#: middle of the record): its sampling sd is then below 0.005 for Gaussian noise.
KURTOSIS_SAMPLES = 1 << 20


def increment_kurtosis(u: Any, chunk: int = KURTOSIS_SAMPLES) -> float:
    """Pearson kurtosis of the first differences of the rate samples ``u``.

    Differencing takes the slow terms (flicker, random walks, drifts) out, so this reads
    the tails of the white rate noise: for white noise of kurtosis ``k`` it is
    ``3 + (k - 3) / 2``. At most :data:`KURTOSIS_SAMPLES` differences from the middle of
    the record are read, ``chunk`` samples at a time (``u`` an array or a
    :class:`adavar.stats.stream.ChunkedSource`); NaN for fewer than 8 samples or a constant
    record.
    """
    n = len(u)
    if n < 8:
        return math.nan
    start = max(0, (n - KURTOSIS_SAMPLES) // 2)
    stop = min(n, start + KURTOSIS_SAMPLES + 1)
    read = u.read if hasattr(u, "read") else (lambda a, b: u[a:b])
    spans = [(a, min(stop, a + chunk + 1)) for a in range(start, stop - 1, chunk)]

    def pieces():
        for a, b in spans:
            yield np.ascontiguousarray(read(a, b), dtype=np.float64)

    count = stop - start - 1
    # the differences' sum telescopes: each piece's last sample less its first
    mean = math.fsum(float(p[-1]) - float(p[0]) for p in pieces()) / count
    m2 = m4 = 0.0
    for p in pieces():
        two, four = difference_moments(p, mean)
        m2 += two
        m4 += four
    m2, m4 = m2 / count, m4 / count
    return m4 / (m2 * m2) if m2 > 0 else math.nan


def _with_warnings(
    result: DeviationResult,
    record: Any,
    step: float,
    dtype: str,
    check: bool,
    chunk: int | None = None,
    extremes: tuple[float, float] | None = None,
) -> DeviationResult:
    """``result`` with the stationarity warning of ``record`` if ``check`` finds one."""
    if not check:
        return result
    text = stationarity(record, tau0=step, data_type=dtype, chunk_size=chunk,
                        extremes=extremes).warning()  # fmt: skip
    return result if text is None else replace(result, warnings=(*result.warnings, text))


#: the keywords of :func:`deviation` (passed on to the gaps path)
_DEVIATION_KEYWORDS = frozenset(
    deviation.__code__.co_varnames[1 : 1 + deviation.__code__.co_kwonlyargcount]
)


def _extended_deviation(
    spec: ext.StatisticSpec,
    u: np.ndarray,
    n_samples: int,
    dtype: str,
    step: float,
    exponent: int,
    taus: str | Sequence[float] | np.ndarray,
    points_per_decade: int,
    confidence: float | None,
    noise_id: str,
    units: str | None,
    options: dict[str, Any],
) -> DeviationResult:
    """:func:`deviation` for a statistic of :data:`adavar.core.extended_statistics.SPECS`."""
    family = spec.family()
    stat = spec.name
    n_points = u.size + 1
    if family.m_max(stat, n_points) < 1:  # the generic "at least 3" is not this stat's
        least = next(k for k in range(n_points + 1, n_points + 64) if family.m_max(stat, k) >= 1)
        least -= 1 if dtype == "rate" else 0  # phase points -> samples of this data type
        raise AdavarInputError(
            f"the record has {n_samples} samples; stat={stat!r} (--stat {stat}) needs at least "
            f"{least} samples of {dtype} data: give a longer record"
        )
    step_mantissa, step_exponent = math.frexp(step)  # ``exponent`` holds -step_exponent
    ms, notes = tau_factors(taus, family.m_max(stat, n_points), step, points_per_decade)
    ms, more = family.factors(stat, ms)
    notes = notes + tuple(more)
    if ms.size == 0:
        raise AdavarInputError(
            f"no averaging time is left for stat={stat!r} on {n_samples} samples: give "
            "longer data or other taus"
        )
    u = np.ascontiguousarray(u, dtype=np.float64)
    ms = np.ascontiguousarray(ms, dtype=np.int64)
    var, n = family.squared(stat, u, ms, **options)
    if spec.kind == "time":
        # time-like: in units of cumsum(u); times tau0 for rate data, as they are for phase
        if dtype == "rate":
            var = var * step_mantissa**2
            exponent += step_exponent
        else:
            exponent += step_exponent
    elif dtype == "phase":
        var = var / step_mantissa**2
    tau = spec.tau_factor * ms * step

    if confidence is None:
        nan = np.full(ms.size, np.nan)
        alpha = np.full(ms.size, -1, dtype=np.int64)
        edf_values, low, high = nan, nan.copy(), nan.copy()
    else:
        phase = diff.anchored_phase(u, cluster_stats=True)
        id_ms = np.minimum(ms, max(1, largest_factor("oadev", n_points)))
        alpha, id_notes = record_noise_types(
            phase, id_ms, spec.dmax, data_type=dtype, noise_id=noise_id
        )
        notes = notes + id_notes
        edf_values = np.array(
            [
                float(family.edf(stat, int(a), int(m), n_points, **options))
                for a, m in zip(alpha, ms, strict=True)
            ]
        )
        defined = np.isfinite(edf_values)
        var_low = np.full(ms.size, np.nan)
        var_high = np.full(ms.size, np.nan)
        if defined.any():
            var_low[defined], var_high[defined] = edf_mod.chi2_interval(
                var[defined], edf_values[defined], float(confidence)
            )
        else:
            notes = (*notes, f"{stat} has no chi-square interval: dev_low, dev_high are NaN")
        low = unscale(np.sqrt(var_low), exponent, "deviations")
        high = unscale(np.sqrt(var_high), exponent, "deviations")

    return _result(
        tau, unscale(np.sqrt(var), exponent, "deviations"), low, high, edf_values, n, ms,
        alpha, stat, dtype, step, confidence, n_samples, units, notes,
    )  # fmt: skip


def _result(
    tau, dev, low, high, edf_values, n, ms, alpha, stat, dtype, step, confidence, n_samples,
    units, notes,
) -> DeviationResult:  # fmt: skip
    """The :class:`DeviationResult` of :func:`deviation` (every statistic)."""
    return DeviationResult(
        tau=tau,
        dev=dev,
        dev_low=low,
        dev_high=high,
        edf=edf_values,
        n=np.asarray(n, dtype=np.int64),
        m=ms,
        alpha=alpha,
        stat=stat,
        data_type=dtype,
        tau0=step,
        confidence=float("nan") if confidence is None else float(confidence),
        n_samples=int(n_samples),
        units=units,
        notes=notes,
    )

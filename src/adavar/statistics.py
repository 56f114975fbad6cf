"""Allan-family statistics of a whole record, with confidence intervals.

One entry point, :func:`deviation`, for the non-overlapping and overlapping Allan deviation,
the modified Allan and time deviation, the non-overlapping and overlapping Hadamard deviation
and the total deviation (NIST SP 1065 definitions). Every statistic is a sum of squared
finite differences of the integrated signal computed by :mod:`adavar.differences` in O(N)
per averaging time and exactly (a few ulps), even on records with large offsets or drifts.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from adavar import differences as diff
from adavar import edf as edf_mod
from adavar import stream
from adavar import stream_statistics as sstat
from adavar.errors import AdavarInputError
from adavar.noise_id import NOISE_ID_RULES, b1_with_rn, pm_with_rn, rn_ratio
from adavar.results import DeviationResult
from adavar.taus import averaging_factors

__all__ = ["DATA_TYPES", "NOISE_ID_RULES", "STATISTICS", "as_samples", "deviation", "resolve_tau0"]

STATISTICS = ("adev", "oadev", "mdev", "hdev", "ohdev", "tdev", "totdev")
DATA_TYPES = ("rate", "phase")
DATA_TYPE_ALIASES = {"rate": "rate", "freq": "rate", "frequency": "rate", "phase": "phase"}


def resolve_tau0(rate: float | None, tau0: float | None) -> float:
    """Sample interval from either a sample rate (Hz) or an interval (s), not both."""
    if tau0 is not None:
        if rate not in (None, 1.0):
            raise AdavarInputError("give either rate or tau0, not both")
        value, name = tau0, "tau0"
    else:
        value, name = (1.0 if rate is None else rate), "rate"
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise AdavarInputError(f"{name} must be a number, got {value!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise AdavarInputError(f"{name} must be a positive number, got {value!r}")
    return value if name == "tau0" else 1.0 / value


def as_samples(data: object, *, min_length: int = 3) -> np.ndarray:
    """Validate a record: a finite 1-D numeric array of at least ``min_length`` samples.

    float32 and integer input is promoted to float64 (the sums need the precision).
    """
    try:
        x = np.asarray(data)
    except Exception as exc:  # pragma: no cover - exotic containers
        raise AdavarInputError(f"cannot read the data as an array: {exc}") from None
    if x.dtype == object or not (np.issubdtype(x.dtype, np.number) or x.dtype == bool):
        raise AdavarInputError("data must be numeric: pass a 1-D array of samples")
    if np.iscomplexobj(x):
        raise AdavarInputError("data must be real-valued, not complex")
    if x.ndim != 1:
        x = np.squeeze(x)
        if x.ndim != 1:
            raise AdavarInputError(
                f"data must be one channel (1-D); got shape {np.shape(data)}: pass one column"
            )
    if x.size < min_length:
        raise AdavarInputError(f"the record has {x.size} samples; at least {min_length} are needed")
    x = np.asarray(x, dtype=np.float64)
    finite = np.isfinite(x)
    if not finite.all():
        first = int(np.argmin(finite))
        raise AdavarInputError(
            f"sample {first} is {x[first]!r}: remove or interpolate non-finite samples first"
        )
    return x


def _m_max(stat: str, n_points: int) -> int:
    if stat in ("adev", "oadev", "totdev"):
        return (n_points - 1) // 2
    if stat in ("mdev", "tdev"):
        return n_points // 3
    return (n_points - 1) // 3  # hdev, ohdev


def _rn_in_memory(phase: diff.AnchoredPhase, m: int) -> float | None:
    ms = np.array([m], dtype=np.int64)
    n_avar = phase.n_points - 2 * m
    avar = diff.overlapping_sums(phase, ms, 2)[0] / (2.0 * m * m * n_avar)
    sums, n = diff.modified_sums(phase, ms)
    return rn_ratio(float(avar), float(sums[0] / (2.0 * m**4 * n[0])))


def record_noise_types(
    phase: diff.AnchoredPhase,
    ms: np.ndarray,
    dmax: int,
    *,
    data_type: str = "rate",
    noise_id: str = "sp1065",
):
    """Power-law noise exponent per tau: lag-1 ACF, B1 + R(n) fallback, else the neighbour's.

    The lag-1 statistics stream over the cluster sums of the anchored phase (no copy of the
    record per tau). Phase data (with ``noise_id="sp1065"``) start on the decimated phase
    (:mod:`adavar.noise_id`) and a "white PM" there is checked by R(n);
    ``noise_id="stable32"`` identifies phase data on the m-averaged rate as before
    (clamped) and uses R(n) only where B1 says PM. Short series go to the B1 ratio.
    """
    strict = noise_id == "stable32"
    on_phase = data_type == "phase" and not strict
    alpha = np.full(ms.size, np.nan)
    for k, m in enumerate(ms):
        m = int(m)
        count = (phase.n_points - 1) // m
        try:
            if count >= edf_mod.MIN_POINTS_LAG1:
                pstats = None
                if on_phase:
                    z = diff.cluster_differences(phase.r, phase.hh, phase.hl, m, count)
                    pstats = edf_mod.decimated_phase_lag1(z)
                    got = edf_mod.alpha_from_phase_lag1(pstats, None, dmax=dmax)
                    if got is not None:
                        alpha[k] = pm_with_rn(got, m, lambda m=m: _rn_in_memory(phase, m))
                        continue
                rate_dmax = dmax - 1 if on_phase else dmax
                # most taus stop at d = 0 (delta < 0.25): try that cheaper pass first, from
                # the moments gathered while integrating when m is short
                stats = diff.fused_lag1(phase, m) or diff.cluster_lag1(phase, m, 0)
                r1, den, sizes, scale = stats
                if not r1[0] / (1.0 + r1[0]) < 0.25:
                    stats = diff.cluster_lag1(phase, m, rate_dmax)
                if on_phase:
                    alpha[k] = edf_mod.alpha_from_phase_lag1(pstats, stats, dmax=dmax)
                else:
                    r1, den, sizes, scale = stats
                    alpha[k] = edf_mod.clamp_alpha(
                        edf_mod.alpha_from_lag1(
                            r1, den, sizes, scale, data_type="rate", dmax=r1.size - 1
                        )[0],
                        dmax,
                    )
            else:
                z = diff.cluster_sums(phase, m) / m
                rn = lambda m=m: _rn_in_memory(phase, m)  # noqa: E731 - evaluated if needed
                alpha[k] = b1_with_rn(z, m, dmax, rn, strict=strict)
        except edf_mod.NoiseIdError:
            continue
    return edf_mod.fill_unidentified(alpha)


TOTVAR_BIAS: dict[int, float] = {-1: 1.0 / (3.0 * np.log(2.0)), -2: 0.75}


def deviation(
    data: Sequence[float] | np.ndarray | stream.ChunkedSource,
    *,
    stat: str = "oadev",
    rate: float = 1.0,
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
) -> DeviationResult:
    """Allan-family deviation of a whole record, with a confidence interval at every tau.

    Parameters
    ----------
    data : array_like, ChunkedSource, dask.array.Array or numpy.memmap
        The record, one sample per ``tau0``. A :class:`~adavar.stream.ChunkedSource`, a
        ``dask.array`` or a memory map of a ``.npy`` file (``np.load(path, mmap_mode="r")``)
        is read piece by piece and never held whole (see Notes).
    stat : {"oadev", "adev", "mdev", "tdev", "hdev", "ohdev", "totdev"}
        ``adev`` non-overlapping Allan deviation (the paper's Eq. 1), ``oadev`` overlapping
        Allan, ``mdev`` modified Allan, ``tdev`` time deviation (``tau * mdev / sqrt(3)``,
        in phase units), ``hdev``/``ohdev`` non-overlapping/overlapping Hadamard, ``totdev``
        total deviation (reflected record, NIST SP 1065).
    rate : float
        Sample rate in Hz (ignored when ``tau0`` is given).
    data_type : {"rate", "phase"}
        ``"rate"``: rate samples (gyro angular rate, accelerometer output, fractional
        frequency); ``"phase"``: their integral (angle, velocity, time error).
    taus : {"octave", "all", "decade", "log"} or sequence of float
        Averaging times; see :func:`adavar.taus.averaging_factors`. Explicit taus are
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
        Density of ``taus="log"``.
    units : str, optional
        Declared unit of the samples (e.g. ``"deg/s"``), carried to the fit's unit
        conversions. Never guessed.
    chunk_size : int, optional
        Samples per read for the out-of-core computation. Giving it forces that path even
        for an in-memory array; for chunked ``data`` the default is
        :data:`adavar.stream.DEFAULT_CHUNK`.
    noise_id : {"sp1065", "stable32"}
        Noise identification for the intervals (see :mod:`adavar.noise_id`). ``"sp1065"``
        (default): lag-1 autocorrelation with at least 30 clusters, started on the
        decimated phase ``x[::m]`` for phase data (SP 1065), where a "white PM" result is
        checked by R(n) = MVAR/AVAR (the short detrended decimated phase reads flicker PM
        as white PM at m >= 16); below 30 clusters the B1 ratio, with R(n) separating
        white PM, flicker PM and white FM whenever B1 says PM or white FM.
        ``"stable32"``: the rule Stable32's published tables follow: phase data
        identified on the m-averaged rate (adavar's rule before; white PM then reads as
        alpha 3..6 in a third of the records, clamped to 2), R(n) only where B1 says PM.
        Rate data are identified on the m-averaged rate either way. Every alpha is
        clamped to the statistic's range ([-2, 2]; Hadamard [-4, 2]).
    totdev_edf : {"sp1065", "stable32", "legacy"}
        TOTDEV EDF convention (:func:`adavar.edf.edf`): ``"stable32"`` reproduces Stable32's
        bounds, ``"legacy"`` adavar's earlier choice.
    totdev_bias : bool
        Divide TOTVAR by its SP 1065 bias ``1 - a tau/T`` (a = 1/(3 ln 2) flicker FM, 3/4
        random-walk FM, per the identified alpha; T = N tau0), as Stable32 does for
        frequency data, so that ``dev`` estimates the Allan deviation. Default False: the
        plain TOTDEV of SP 1065 (its published values).

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

    Out of core (chunked ``data`` or ``chunk_size`` given): the same anchored form is built
    by :mod:`adavar.stream_statistics` in one pass, keeping only its double-double anchors
    (16 bytes per 1024 samples); the local sums are recomputed over windows that slide
    along the record, so every difference is the one the in-memory path computes and the
    result equals it (a few ulps; every field: ``n``, ``m``, ``edf``, ``alpha``, ``notes``)
    for any chunk size. Working memory is a few ``chunk_size`` samples. Cost: the short
    averaging factors take one sweep over the record; each ``m`` beyond about
    ``chunk_size / 2`` reads the record about twice (three times for the Hadamard
    statistics) in streams side by side, so ``taus="all"`` on a long record is slow here
    as it is in memory. ``totdev`` reads the reflected record (three times the length).
    Noise identification streams the record as well
    (:func:`adavar.stream.noise_types`).
    """
    if stat not in STATISTICS:
        raise AdavarInputError(f"unknown stat {stat!r}: use one of {', '.join(STATISTICS)}")
    if noise_id not in NOISE_ID_RULES:
        raise AdavarInputError(f"unknown noise_id {noise_id!r}: use one of {NOISE_ID_RULES}")
    if str(totdev_edf).lower() not in edf_mod.TOTDEV_EDF_METHODS:
        raise AdavarInputError(
            f"unknown totdev_edf {totdev_edf!r}: use one of {edf_mod.TOTDEV_EDF_METHODS}"
        )
    dtype = DATA_TYPE_ALIASES.get(str(data_type).lower())
    if dtype is None:
        raise AdavarInputError(f"unknown data_type {data_type!r}: use 'rate' or 'phase'")
    if confidence is not None and not (0.0 < float(confidence) < 1.0):
        raise AdavarInputError(f"confidence must lie strictly between 0 and 1, got {confidence}")
    step = resolve_tau0(rate, tau0)
    min_length = 4 if dtype == "phase" else 3

    chunked = chunk_size is not None or stream.is_chunked(data)
    if chunked:
        chunk = stream.DEFAULT_CHUNK if chunk_size is None else stream.check_chunk_size(chunk_size)
        source = stream.open_record(data, min_length)
        increments = source if dtype == "rate" else stream.DifferencedSource(source)
        n_samples, n_points = source.size, increments.size + 1
    else:
        x = as_samples(data, min_length=min_length)
        u = x if dtype == "rate" else np.diff(x)
        n_samples, n_points = x.size, u.size + 1

    scale = 1.0 if dtype == "rate" else 1.0 / step**2
    ms, notes = averaging_factors(
        taus, _m_max(stat, n_points), step, points_per_decade=points_per_decade
    )
    if not chunked:
        phase = diff.anchored_phase(u, cluster_stats=confidence is not None)
        kernels = diff
    elif stat != "totdev":
        phase = sstat.streamed_phase(increments, chunk)
        kernels = sstat
    m2 = ms.astype(np.float64) ** 2

    if stat == "oadev":
        n = n_points - 2 * ms
        var = kernels.overlapping_sums(phase, ms, 2) / (2.0 * m2 * n)
    elif stat == "adev":
        sums, n = kernels.strided_sums(phase, ms, 2)
        var = sums / (2.0 * m2 * n)
    elif stat in ("mdev", "tdev"):
        sums, n = kernels.modified_sums(phase, ms)
        var = sums / (2.0 * m2 * m2 * n)
    elif stat == "hdev":
        sums, n = kernels.strided_sums(phase, ms, 3)
        var = sums / (6.0 * m2 * n)
    elif stat == "ohdev":
        n = n_points - 3 * ms
        var = kernels.overlapping_sums(phase, ms, 3) / (6.0 * m2 * n)
    else:  # totdev: reflect the record at both ends (SP 1065), i.e. time-reverse the rate
        pad = n_points - 2
        n = np.full(ms.size, n_points - 2, dtype=np.int64)
        starts = pad + 1 - ms
        if chunked:
            # the reflected record is read through index arithmetic, never built
            extended = sstat.streamed_phase(
                sstat.ReflectedSource(increments, pad),
                chunk,
                shift=sstat.initial_shift(increments),
            )
            sums = sstat.overlapping_sums(extended, ms, 2, starts=starts, counts=n)
        else:
            extended = diff.anchored_phase(np.pad(u, pad, mode="symmetric"), shift=phase.shift)
            sums = diff.overlapping_sums(extended, ms, 2, starts=starts, counts=n)
        var = sums / (2.0 * m2 * n)
    var = var * scale
    tau = ms * step
    if stat == "tdev":
        var = var * tau**2 / 3.0

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
                phase, ms, dmax, data_type=dtype, noise_id=noise_id
            )
        notes = notes + id_notes
        edf_values = np.array(
            [
                edf_mod.edf(stat, int(a), int(m), n_points, totdev_edf=totdev_edf)
                for a, m in zip(alpha, ms, strict=True)
            ]
        )
        if stat == "totdev" and totdev_bias:
            bias = np.array([TOTVAR_BIAS.get(int(a), 0.0) for a in alpha])
            var = var / (1.0 - bias * ms / (n_points - 1))
        var_low, var_high = edf_mod.chi2_interval(var, edf_values, float(confidence))
        low, high = np.sqrt(var_low), np.sqrt(var_high)

    return DeviationResult(
        tau=tau,
        dev=np.sqrt(var),
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

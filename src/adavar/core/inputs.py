"""Input checks and exact scaling shared by every statistic.

What a statistic asks of its input before computing anything: the data type
(:data:`DATA_TYPE_ALIASES`), the confidence level, real finite samples in a 1-D array
(:func:`as_samples`; masked arrays refused, integers beyond 2**53 refused by
:func:`check_exact_integers`), the exact power-of-two scaling of a record
whose magnitude would under- or overflow the double-double sums (:func:`scaled`,
:func:`unscale`; a streamed record: :func:`adavar.io.scaling.scaled_source`), and the
averaging factors of ``taus=``
(:func:`tau_factors`, :func:`largest_factor`). :mod:`adavar.stats.statistics`,
:mod:`adavar.stats.gaps`, :mod:`adavar.stats.stationary_noise` and the DAVAR engines use them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.core.settings import MAX_POINTS_PER_DECADE
from adavar.core.taus import averaging_factors

__all__ = [
    "DATA_TYPES",
    "DATA_TYPE_ALIASES",
    "EXACT_INTEGER",
    "SAFE_EXPONENT",
    "as_samples",
    "check_confidence",
    "check_exact_integers",
    "data_exponent",
    "largest_factor",
    "refuse_masked",
    "scaled",
    "tau_factors",
    "unscale",
]

DATA_TYPES = ("rate", "phase")
DATA_TYPE_ALIASES = {"rate": "rate", "freq": "rate", "frequency": "rate", "phase": "phase"}
#: a record whose largest magnitude lies in ``2**-SAFE_EXPONENT .. 2**SAFE_EXPONENT`` is
#: used as it is; one outside is first scaled by a power of two (:func:`scaled`)
SAFE_EXPONENT = 64
_TINY = float(np.finfo(np.float64).tiny)
#: the largest integer magnitude float64 holds exactly (2**53); integer samples beyond it
#: would be rounded (by up to 128 at 2**60), which can flatten a record's noise to zero
EXACT_INTEGER = 1 << 53


def check_confidence(confidence: object) -> None:
    """``confidence`` is None or a number strictly between 0 and 1 (else a one-line error)."""
    if confidence is None:
        return
    try:
        ok = not isinstance(confidence, (bool, np.bool_)) and 0.0 < float(confidence) < 1.0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise AdavarInputError(
            f"confidence must lie strictly between 0 and 1 (e.g. 0.683), or be None, got "
            f"{confidence!r}"
        )


def refuse_masked(data: object) -> None:
    """Refuse a :class:`numpy.ma.MaskedArray` with masked samples (one-line error).

    The statistics have no way to skip samples: a masked sample would be read as whatever
    value lies under the mask. Without masked samples the array is read as it is.
    """
    if not isinstance(data, np.ma.MaskedArray):
        return
    mask = np.ma.getmaskarray(data)
    if mask.any():
        first = int(np.argmax(mask.ravel()))
        raise AdavarInputError(
            f"data is a masked array with {int(mask.sum())} masked sample(s) (the first is "
            f"sample {first}) and masked samples cannot be skipped: fill them first, e.g. "
            "interpolate over x.filled(np.nan) (what read_record(..., nan='interpolate') and "
            "--nan interpolate do), or pass x.compressed() if dropping them shifts no time"
        )


def check_exact_integers(
    values: np.ndarray, name: str, start: int = 0, where: Callable[[int], str] | None = None
) -> None:
    """Fail when integer ``values`` (samples ``start ..`` of ``name``; ``where(i)`` names
    sample ``i`` otherwise) hold one beyond :data:`EXACT_INTEGER`, which float64, the
    precision of every sum, cannot hold."""
    if values.dtype.kind not in "iu" or values.dtype.itemsize < 8 or values.size == 0:
        return
    low, high = int(values.min()), int(values.max())
    if -EXACT_INTEGER <= low and high <= EXACT_INTEGER:
        return
    first = int(np.argmax((values > EXACT_INTEGER) | (values < -EXACT_INTEGER)))
    at = f"sample {start + first}" if where is None else where(first)
    raise AdavarInputError(
        f"{at} of {name} is the integer {int(values[first])}, beyond 2**53 (9.007e15), "
        "which float64 cannot hold exactly (its noise would be rounded away): subtract an "
        "offset in integers first (e.g. the first value), or give the samples in a larger "
        "unit"
    )


def as_samples(data: object, *, min_length: int = 3, missing_hint: str = "") -> np.ndarray:
    """Validate a record: a finite 1-D numeric array of at least ``min_length`` samples.

    float32 and integer input is promoted to float64 (the sums need the precision);
    integers beyond 2**53, which float64 would round, are refused.
    ``missing_hint`` is added to the error about a NaN sample (a way out the caller has).
    """
    return samples_and_range(data, min_length, missing_hint)[0]


def samples_and_range(
    data: object, min_length: int, missing_hint: str
) -> tuple[np.ndarray, float, float]:
    """:func:`as_samples`, and the record's smallest and largest value (0, 0 if empty)."""
    refuse_masked(data)
    try:
        x = np.asarray(data)
    except Exception as exc:  # pragma: no cover - exotic containers
        raise AdavarInputError(f"cannot read the data as an array: {exc}") from None
    if x.dtype != np.float64:  # float64 is numeric and real
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
    check_exact_integers(x, "data")  # beyond 2**53, float64 would round them
    x = np.asarray(x, dtype=np.float64)
    # min and max are NaN or infinite exactly when some sample is: the range checks them all
    low, high = (float(x.min()), float(x.max())) if x.size else (0.0, 0.0)
    if not (math.isfinite(low) and math.isfinite(high)):
        finite = np.isfinite(x)
        first = int(np.argmin(finite))
        value = float(x[first])
        hint = missing_hint if math.isnan(value) else ""
        raise AdavarInputError(
            f"sample {first} is {value!r}: {hint}remove or interpolate non-finite samples first"
        )
    return x, low, high


# ---------------------------------------------------------------------------------------
# the scale of the data: every statistic here is homogeneous (a variance scales with the
# square of the data), so a record far from 1 is computed at scale 1 and scaled back


def data_exponent(x: np.ndarray) -> int:
    """Binary exponent ``k`` of a record's scale, 0 when no scaling is needed.

    ``x * 2**-k`` has its largest magnitude in ``[0.5, 1)``. A record whose largest
    magnitude already lies within ``2**±SAFE_EXPONENT`` (about 5e-20 .. 2e19), or that is
    all zeros, gets 0 and is used as it is: its sums of squares and fourth powers stay far
    from overflow and underflow.
    """
    if x.size == 0:
        return 0
    return range_exponent(float(x.min()), float(x.max()))


def range_exponent(low: float, high: float) -> int:
    """:func:`data_exponent` of a record whose values lie in ``[low, high]`` (its extremes)."""
    big = max(abs(high), abs(low))
    if not 0.0 < big < math.inf:
        return 0
    exponent = math.frexp(big)[1]
    return exponent if abs(exponent) > SAFE_EXPONENT else 0


def scaled(x: np.ndarray) -> tuple[np.ndarray, int]:
    """``(x * 2**-k, k)`` with ``k = data_exponent(x)``: exact (``numpy.ldexp``), no copy if 0.

    Multiplying by a power of two changes only the exponent of every sample, so results
    computed on the scaled record are those of the record itself times ``2**k`` (a
    deviation) or ``4**k`` (a variance), bit for bit, and a record near 1e306 or of
    subnormal numbers is computed as accurately as one near 1.
    """
    k = data_exponent(x)
    return (np.ldexp(x, -k) if k else x), k


def unscale(values: np.ndarray, exponent: int, what: str, *, underflow: bool = True) -> np.ndarray:
    """``values * 2**exponent`` (exact), or a one-line error when it leaves float64.

    A finite value whose true result exceeds the largest double raises
    :class:`AdavarInputError` instead of becoming inf; with ``underflow=False`` so does a
    nonzero one that would drop below the normal range (2.2e-308) and lose digits (a
    variance; a deviation there is returned as the nearest subnormal).
    """
    values = np.asarray(values)
    if exponent == 0:
        return values
    with np.errstate(over="ignore", under="ignore"):
        out = np.ldexp(values, exponent)
    finite = np.isfinite(values)
    if np.any(finite & ~np.isfinite(out)):
        raise AdavarInputError(
            f"the {what} of this record exceed the float64 range (1.8e308): divide the data "
            "by a power of ten (a larger unit) and scale the result back"
        )
    if not underflow and np.any(finite & (values != 0) & (np.abs(out) < _TINY)):
        raise AdavarInputError(
            f"the {what} of this record fall below the float64 range (2.2e-308) and would "
            "lose digits: multiply the data by a power of ten (a smaller unit) and scale the "
            "result back"
        )
    return out


def tau_factors(
    taus: str | Sequence[float] | np.ndarray,
    m_max: int,
    tau0: float,
    points_per_decade: int,
) -> tuple[np.ndarray, tuple[str, ...]]:
    """:func:`adavar.core.taus.averaging_factors`, with the options checked (one-line errors).

    ``points_per_decade`` must be a whole number in ``1 .. MAX_POINTS_PER_DECADE``; an
    explicit ``taus`` must be numbers; every tau ``m * tau0`` must be a finite float.
    """
    ppd = points_per_decade
    if isinstance(ppd, (float, np.floating)) and float(ppd).is_integer():
        ppd = int(ppd)
    if isinstance(ppd, (bool, np.bool_)) or not isinstance(ppd, (int, np.integer)):
        raise AdavarInputError(f"points_per_decade must be a whole number, got {ppd!r}")
    if not 1 <= ppd <= MAX_POINTS_PER_DECADE:
        raise AdavarInputError(
            f"points_per_decade must lie in 1 .. {MAX_POINTS_PER_DECADE}, got {ppd}: denser "
            "taus add no information (use taus='all' for every averaging factor)"
        )
    if not isinstance(taus, str):
        try:
            values = np.asarray(taus)
            bad = values.dtype.kind not in "iuf"
            if not bad:
                taus = values.astype(np.float64)
        except (TypeError, ValueError):
            bad = True
        if bad:
            raise AdavarInputError(
                f"taus must be a keyword (octave, all, decade, log) or a list of seconds, "
                f"got {taus!r}"
            )
    ms, notes = averaging_factors(taus, m_max, tau0, points_per_decade=int(ppd))
    if not math.isfinite(float(ms[-1]) * tau0):
        raise AdavarInputError(
            f"the sample interval {tau0:g} s makes the tau of {int(ms[-1])} samples overflow "
            "float64: check the rate (rate= is in Hz, tau0= in seconds)"
        )
    return ms, notes


def largest_factor(stat: str, n_points: int) -> int:
    if stat in ("adev", "oadev", "totdev"):
        return (n_points - 1) // 2
    if stat in ("mdev", "tdev"):
        return n_points // 3
    return (n_points - 1) // 3  # hdev, ohdev

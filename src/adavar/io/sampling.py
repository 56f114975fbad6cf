"""The sample interval of a record: declared (a rate or tau0), or read from its own time index.

:func:`resolve_tau0` checks a declared rate (Hz) or interval (s). :func:`resolve_rate`
is the rate of the entry points that take a record (:func:`adavar.deviation`,
:func:`adavar.davar`, :func:`adavar.adaptive_davar`): the one given, else the one its time
index gives, else 1 Hz (:data:`RATE_DEFAULT`, told apart from a rate of 1 Hz given).

A pandas Series/DataFrame with a DatetimeIndex or TimedeltaIndex, or an xarray DataArray
with a datetime or timedelta coordinate, says when each sample was taken.
:func:`index_interval` reads the sample interval from it, and refuses an index that does
not describe evenly spaced samples (jitter beyond :data:`adavar.core.settings.RATE_AGREEMENT`
of the median step, gaps, repeated or backward times, missing times), naming the way out:
resample it, fill its gaps with NaN samples for ``gaps="omit"``, or pass the values with a
rate. pandas and xarray are never imported here: only objects of theirs are read.
"""

from __future__ import annotations

import math

import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.core.settings import RATE_AGREEMENT, RATE_DEFAULT, RATE_LIMITS, RateDefault

__all__ = ["RATE_DEFAULT", "index_interval", "resolve_rate", "resolve_tau0"]


#: a step this many times the median misses samples (a gap), as ``read_record``'s default
#: ``gap_tolerance`` reads a file's time column
_GAP = 1.5


def _time_index(data: object) -> tuple[np.ndarray, str] | None:
    """The times of ``data``'s samples (datetime64 or timedelta64) and the dimension they
    run along (``""`` for pandas): a pandas Series/DataFrame's DatetimeIndex or
    TimedeltaIndex, or the datetime/timedelta coordinate of a 1-D xarray DataArray; None
    for anything else."""
    module = type(data).__module__.split(".")[0]
    if module == "pandas":
        index = getattr(data, "index", None)
        if getattr(getattr(index, "dtype", None), "kind", "") not in ("M", "m"):
            return None
        if getattr(index, "tz", None) is not None:  # the instants, not the wall clock
            index = index.tz_convert("UTC").tz_localize(None)
        return np.asarray(index.to_numpy()), ""
    if module == "xarray":
        dims = getattr(data, "dims", ())
        coords = getattr(data, "coords", None)
        if len(dims) != 1 or coords is None or dims[0] not in coords:
            return None
        values = np.asarray(coords[dims[0]].values)
        return (values, str(dims[0])) if values.dtype.kind in "mM" else None
    return None


def _where(dim: str) -> str:
    """How a message names the index (``dim``: an xarray dimension, "" for pandas)."""
    return f"the time coordinate {dim!r} of data" if dim else "the time index of data"


def _freq(ns: float) -> str:
    """A step of ``ns`` nanoseconds as a pandas frequency string (``"10ms"``)."""
    for unit, size in (("h", 3600e9), ("min", 60e9), ("s", 1e9), ("ms", 1e6), ("us", 1e3)):
        if ns >= size and round(ns) % round(size) == 0:
            return f"{round(ns) // round(size)}{unit}"
    return f"{round(ns)}ns"


def _interval(times: np.ndarray, dim: str) -> float | None:
    """The sample interval (s) a time index gives, or None with fewer than two times.

    Exact when every step is equal (to the nanosecond), else the mean step; an index that
    is not evenly spaced (a step more than :data:`adavar.core.settings.RATE_AGREEMENT` from
    the median: jitter or a gap), that repeats or goes back, or with missing times is an
    error naming the way out.
    """
    where = _where(dim)
    if times.size < 2:
        return None
    if np.isnat(times).any():
        i = int(np.argmax(np.isnat(times)))
        raise AdavarInputError(
            f"{where} is missing (NaT) at sample {i}: drop or fix those samples, or pass the "
            "values (np.asarray(data)) with rate="
        )
    unit = "datetime64[ns]" if times.dtype.kind == "M" else "timedelta64[ns]"
    ns = times.astype(unit).astype(np.int64)
    d = np.diff(ns)
    back = np.flatnonzero(d <= 0)
    if back.size:
        i = int(back[0]) + 1
        what = "repeats" if d[i - 1] == 0 else "goes back"
        raise AdavarInputError(
            f"{where} {what} at sample {i} ({times[i]}): sort it and remove duplicates "
            "(pandas: data.sort_index() and data[~data.index.duplicated()])"
        )
    median = float(np.median(d))
    freq = _freq(float(f"{median:.3g}"))  # a jittery median, rounded to a grid to suggest
    grid = f"data.resample({dim}='{freq}')" if dim else f"data.resample('{freq}')"
    gaps = np.flatnonzero(d > _GAP * median)
    if gaps.size:
        i = int(gaps[0])
        fill = f"{grid}.asfreq()" if dim else f"data.asfreq('{freq}')"
        raise AdavarInputError(
            f"{where} has {gaps.size} gap(s), the first of {d[i] / 1e9:.6g} s after "
            f"{times[i]} (the step is {median / 1e9:.6g} s): fill them with NaN samples "
            f"({fill}) and pass gaps='omit' (deviation, davar), or interpolate them, or pass "
            "the values (np.asarray(data)) with rate= if no sample is missing"
        )
    spread = max(float(d.max()) - median, median - float(d.min()))
    if spread > RATE_AGREEMENT * median:
        raise AdavarInputError(
            f"{where} is not evenly spaced (steps of {d.min() / 1e9:.6g} to "
            f"{d.max() / 1e9:.6g} s, {spread / median:.1%} from their median, more than "
            f"{RATE_AGREEMENT:.0%}): resample it onto a regular grid ({grid}.mean()), or pass "
            "the values (np.asarray(data)) with rate= if they are evenly spaced"
        )
    if d.min() == d.max():
        return float(d[0]) / 1e9
    return float(ns[-1] - ns[0]) / (ns.size - 1) / 1e9


def index_interval(data: object) -> tuple[float, str] | None:
    """The sample interval (s) of ``data``'s time index and how to name that index, or
    None when ``data`` has none (or fewer than two samples).

    Parameters
    ----------
    data : object
        The record: a pandas Series/DataFrame (its DatetimeIndex or TimedeltaIndex), a 1-D
        xarray DataArray (its datetime or timedelta coordinate), or anything else.

    Returns
    -------
    (float, str) or None
        The interval, exact when every step is equal (to the nanosecond), else the mean
        step; and ``"the time index of data"`` or ``"the time coordinate 'time' of data"``.

    Raises
    ------
    AdavarInputError
        An index that is not evenly spaced (a step more than
        :data:`adavar.core.settings.RATE_AGREEMENT` from the median), has gaps, repeats or goes
        back, or has missing times (NaT); the message names the way out.
    """
    found = _time_index(data)
    if found is None:
        return None
    times, dim = found
    step = _interval(times, dim)
    if step is None:
        return None
    return step, _where(dim)


def resolve_tau0(rate: float | None, tau0: float | None) -> float:
    """Sample interval from either a sample rate (Hz) or an interval (s), not both.

    ``rate=None`` needs ``tau0``; a ``bool`` is not a rate. A rate outside
    :data:`adavar.core.settings.RATE_LIMITS` (``tau0`` outside their inverses) is refused
    rather than carried into infinite or digit-less taus and a fit that divides by zero.
    """
    if tau0 is not None:
        if rate is not None and not (_is_real(rate) and float(rate) == 1.0):
            raise AdavarInputError("give either rate or tau0, not both")
        value, name = tau0, "tau0"
    elif rate is None:
        raise AdavarInputError(
            "no sampling rate: give rate= (samples per second, Hz) or tau0= (seconds)"
        )
    else:
        value, name = rate, "rate"
    if isinstance(value, (bool, np.bool_)):
        raise AdavarInputError(f"{name} must be a number, got {value!r}")
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise AdavarInputError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise AdavarInputError(f"{name} must be a positive number, got {value!r}")
    lo, hi = RATE_LIMITS
    if not lo <= (1.0 / value if name == "tau0" else value) <= hi:  # 1 / tiny: inf
        unit = "s" if name == "tau0" else "Hz"
        bounds = f"{1 / hi:g} .. {1 / lo:g} s" if name == "tau0" else f"{lo:g} .. {hi:g} Hz"
        raise AdavarInputError(
            f"{name} = {value:g} {unit} lies outside {bounds} (a sample every 1 ps to "
            f"31,700 years): check its unit ({name} is in {unit})"
        )
    return value if name == "tau0" else 1.0 / value


def _is_real(value: object) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def resolve_rate(
    data: object, rate: float | None, tau0: float | None
) -> tuple[float | None, float | None, float]:
    """``(rate, tau0, interval)`` of ``data``: the rate of an entry point that reads a
    record's own time index, and the sample interval (s) of :func:`resolve_tau0`.

    With neither given (``rate`` :data:`RATE_DEFAULT`, the default of :func:`adavar.deviation`,
    :func:`adavar.davar` and :func:`adavar.adaptive_davar`, and no ``tau0``), the interval
    of the time index of a pandas Series/DataFrame (DatetimeIndex or TimedeltaIndex) or of
    the time coordinate of an xarray DataArray (datetime or timedelta),
    ``(None, interval, interval)``; data without one is sampled at 1 Hz, as before. A rate
    or tau0 given with such data must agree with its index within
    :data:`adavar.core.settings.RATE_AGREEMENT` (and is then used). An index that is not
    evenly spaced, has gaps, repeats or goes back is an error naming the way out
    (:func:`index_interval`). ``rate=None`` without ``tau0`` is an
    error, as before.
    """
    found = index_interval(data)
    if found is not None and isinstance(rate, RateDefault) and tau0 is None:
        rate, tau0 = None, found[0]
    elif found is not None:
        step, where = found
        given = resolve_tau0(rate, tau0)
        if abs(given - step) > RATE_AGREEMENT * step:
            named = f"tau0={tau0!r} s" if tau0 is not None else f"rate={rate!r} Hz"
            raise AdavarInputError(
                f"{named} contradicts {where}, sampled every {step:.6g} s ({1.0 / step:.6g} "
                "Hz): leave out rate= and tau0= (the index gives them), or pass the values "
                "(np.asarray(data)) if the index is wrong"
            )
    return rate, tau0, resolve_tau0(rate, tau0)

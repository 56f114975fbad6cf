"""Declared physical units of inertial-sensor data and of the IEEE noise coefficients.

adavar never guesses a unit: the user declares the unit of the input rate samples
(``"deg/s"``, ``"deg/h"``, ``"rad/s"`` for gyroscopes; ``"m/s^2"``, ``"g"`` for
accelerometers) and this module converts the fitted noise coefficients, which come out of
:func:`adavar.fit.noise_model.fit_noise` in the data's own units with time in seconds, into the
units the inertial community reports (docs/method.md section 4).

Every unit known here is a *rate* unit times a power of time:

=========================  ==========  ======================  ===========================
term                       time power  natural unit            conventional unit (gyro/acc)
=========================  ==========  ======================  ===========================
quantization (Q)           +1          rate * s                arcsec / m/s
angle_random_walk (N)      +1/2        rate * sqrt(s)          deg/sqrt(h) / m/s/sqrt(h)
bias_instability (B)       0           rate                    deg/h / micro-g (``"ug"``)
rate_random_walk (K)       -1/2        rate / sqrt(s)          deg/h/sqrt(h) / m/s^2/sqrt(h)
rate_ramp (R)              -1          rate / s                deg/h^2 / m/s^2/h
=========================  ==========  ======================  ===========================

For accelerometers the "angle random walk" is the velocity random walk (VRW) and the "rate
random walk" the acceleration random walk; the attribute names stay the same. The
acceleration random walk is reported in m/s^2/sqrt(h) (``"ug/sqrt(h)"`` and
``"m/s^2/sqrt(s)"`` are available through ``output_units``/:func:`convert`), and the
accelerometer rate ramp in m/s^2/h. The standard gravity is ``1 g = 9.80665 m/s^2``.

With the rate in deg/h and tau in s this reproduces the checks of docs/method.md:
``N[deg/sqrt(h)] = sqrt(C_-1)/60``, ``K[deg/h/sqrt(h)] = 60 sqrt(3 C_1)``,
``R[deg/h^2] = 3600 sqrt(2 C_2)`` and ``Q[arcsec] = sqrt(C_-2/3)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from adavar.core.terms import SENSOR_KINDS, TERM_LABELS, TERM_NAMES, TERMS

__all__ = [
    "CONVENTIONAL_UNITS",
    "RATE_UNITS",
    "TERM_TIME_POWER",
    "ConvertedNoise",
    "ConvertedTerm",
    "UnitInfo",
    "conventional_units",
    "convert",
    "convert_coefficient",
    "deviation_unit",
    "format_pm",
    "is_known_unit",
    "known_phase_units",
    "rate_unit",
    "rate_unit_info",
    "sensor_kind",
    "term_names",
    "term_unit",
    "unit_info",
]

STANDARD_GRAVITY = 9.80665  # m/s^2 per g (exact, CGPM 1901)

_DEG = math.pi / 180.0  # rad per degree
_ARCSEC = _DEG / 3600.0
_HOUR = 3600.0  # s per hour
_SQRT_HOUR = 60.0  # sqrt(s) per sqrt(h)


@dataclass(frozen=True)
class UnitInfo:
    """What a unit string measures.

    Attributes
    ----------
    sensor : str
        ``"gyro"`` (angles, SI base rad) or ``"accelerometer"`` (velocities, SI base m).
    time_power : float
        Power of time by which the unit differs from a rate: +1 for an angle or a velocity,
        +1/2 for a random walk of angle/velocity, 0 for a rate, -1/2 for a rate random walk,
        -1 for a rate ramp.
    si_factor : float
        Value of 1 of this unit in SI (rad or m, times ``s**(time_power - 1)``).
    """

    sensor: str
    time_power: float
    si_factor: float


def _units_table() -> dict[str, UnitInfo]:
    g = STANDARD_GRAVITY
    gyro, acc = "gyro", "accelerometer"
    table = {
        # gyro rates
        "rad/s": UnitInfo(gyro, 0.0, 1.0),
        "deg/s": UnitInfo(gyro, 0.0, _DEG),
        "deg/h": UnitInfo(gyro, 0.0, _DEG / _HOUR),
        # angles
        "rad": UnitInfo(gyro, 1.0, 1.0),
        "deg": UnitInfo(gyro, 1.0, _DEG),
        "arcsec": UnitInfo(gyro, 1.0, _ARCSEC),
        # angle random walk
        "rad/sqrt(s)": UnitInfo(gyro, 0.5, 1.0),
        "deg/sqrt(s)": UnitInfo(gyro, 0.5, _DEG),
        "deg/sqrt(h)": UnitInfo(gyro, 0.5, _DEG / _SQRT_HOUR),
        # rate random walk
        "rad/s/sqrt(s)": UnitInfo(gyro, -0.5, 1.0),
        "deg/s/sqrt(s)": UnitInfo(gyro, -0.5, _DEG),
        "deg/h/sqrt(h)": UnitInfo(gyro, -0.5, _DEG / _HOUR / _SQRT_HOUR),
        # rate ramp
        "rad/s^2": UnitInfo(gyro, -1.0, 1.0),
        "deg/s^2": UnitInfo(gyro, -1.0, _DEG),
        "deg/h^2": UnitInfo(gyro, -1.0, _DEG / _HOUR**2),
        # accelerations
        "m/s^2": UnitInfo(acc, 0.0, 1.0),
        "g": UnitInfo(acc, 0.0, g),
        "mg": UnitInfo(acc, 0.0, 1e-3 * g),
        "ug": UnitInfo(acc, 0.0, 1e-6 * g),
        # velocities
        "m/s": UnitInfo(acc, 1.0, 1.0),
        # velocity random walk
        "m/s/sqrt(s)": UnitInfo(acc, 0.5, 1.0),
        "m/s/sqrt(h)": UnitInfo(acc, 0.5, 1.0 / _SQRT_HOUR),
        # acceleration random walk
        "m/s^2/sqrt(s)": UnitInfo(acc, -0.5, 1.0),
        "m/s^2/sqrt(h)": UnitInfo(acc, -0.5, 1.0 / _SQRT_HOUR),
        "ug/sqrt(h)": UnitInfo(acc, -0.5, 1e-6 * g / _SQRT_HOUR),
        # acceleration ramp
        "m/s^3": UnitInfo(acc, -1.0, 1.0),
        "m/s^2/h": UnitInfo(acc, -1.0, 1.0 / _HOUR),
        "ug/h": UnitInfo(acc, -1.0, 1e-6 * g / _HOUR),
    }
    return table


_UNITS = _units_table()
_ALIASES = {
    "deg/hr": "deg/h",
    "m/s/s": "m/s^2",
    "m/s2": "m/s^2",
    "micro-g": "ug",
    "µg": "ug",
    "milli-g": "mg",
}

#: Units accepted for the input rate samples (plus the aliases ``deg/hr``, ``m/s/s``,
#: ``m/s2``, ``micro-g``, ``µg``, ``milli-g``).
RATE_UNITS: tuple[str, ...] = tuple(u for u, i in _UNITS.items() if i.time_power == 0.0)

#: Power of time that each noise coefficient carries on top of the rate unit.
TERM_TIME_POWER: dict[str, float] = {t.name: t.unit_power for t in TERMS}

#: The conventional reporting unit of each term, per sensor kind.
CONVENTIONAL_UNITS: dict[str, dict[str, str]] = {
    "gyro": {
        "quantization": "arcsec",
        "angle_random_walk": "deg/sqrt(h)",
        "bias_instability": "deg/h",
        "rate_random_walk": "deg/h/sqrt(h)",
        "rate_ramp": "deg/h^2",
    },
    "accelerometer": {
        "quantization": "m/s",
        "angle_random_walk": "m/s/sqrt(h)",
        "bias_instability": "ug",
        "rate_random_walk": "m/s^2/sqrt(h)",
        "rate_ramp": "m/s^2/h",
    },
}


def _canonical(unit: str) -> str:
    if not isinstance(unit, str):
        raise TypeError(f"a unit must be a string, got {type(unit).__name__}")
    key = unit.strip().replace(" ", "")
    return _ALIASES.get(key, key)


def unit_info(unit: str) -> UnitInfo:
    """Describe a unit string.

    Parameters
    ----------
    unit : str
        Any unit of this module (a rate, an angle/velocity or a noise-coefficient unit).

    Returns
    -------
    UnitInfo

    Raises
    ------
    ValueError
        If the unit is unknown; the message lists the known units.
    """
    key = _canonical(unit)
    try:
        return _UNITS[key]
    except KeyError:
        raise ValueError(f"unknown unit {unit!r}; known units: {', '.join(_UNITS)}") from None


def rate_unit_info(unit: str) -> UnitInfo:
    """Describe a declared *input rate* unit (``time_power == 0``).

    Parameters
    ----------
    unit : str
        One of :data:`RATE_UNITS` or an alias.

    Returns
    -------
    UnitInfo

    Raises
    ------
    ValueError
        If ``unit`` is not an accepted rate unit; the message lists the accepted ones.
    """
    key = _canonical(unit)
    info = _UNITS.get(key)
    if info is None or info.time_power != 0.0:
        raise ValueError(
            f"unknown input rate unit {unit!r}; accepted: {', '.join(RATE_UNITS)} "
            "(aliases: deg/hr, m/s/s, m/s2, micro-g, µg, milli-g)"
        )
    return info


def conventional_units(rate_unit: str) -> dict[str, str]:
    """The conventional unit of every noise term for data declared in ``rate_unit``.

    Parameters
    ----------
    rate_unit : str
        Declared unit of the input rate samples.

    Returns
    -------
    dict
        Term name -> unit string (see the module docstring).
    """
    return dict(CONVENTIONAL_UNITS[rate_unit_info(rate_unit).sensor])


def convert(value: Any, from_unit: str, to_unit: str) -> Any:
    """Convert a value between two units of the same kind.

    Parameters
    ----------
    value : float or array_like
        Value(s) in ``from_unit``.
    from_unit, to_unit : str
        Units of this module; both must measure the same quantity (same sensor kind and
        power of time), e.g. ``"deg/s"`` -> ``"deg/h"`` or ``"ug"`` -> ``"m/s^2"``.

    Returns
    -------
    float or ndarray
        ``value`` expressed in ``to_unit``.

    Raises
    ------
    ValueError
        If a unit is unknown or the two units measure different quantities.
    """
    src, dst = unit_info(from_unit), unit_info(to_unit)
    if src.sensor != dst.sensor or src.time_power != dst.time_power:
        raise ValueError(f"cannot convert {from_unit!r} to {to_unit!r}: different quantities")
    factor = src.si_factor / dst.si_factor
    if np.ndim(value) == 0:
        return float(value) * factor
    return np.asarray(value, dtype=float) * factor


def convert_coefficient(value: Any, term: str, rate_unit: str, to_unit: str) -> Any:
    """Convert a noise coefficient from the data's own units to ``to_unit``.

    The coefficient is in the natural unit of the term: ``rate_unit * s**p`` with ``p`` from
    :data:`TERM_TIME_POWER` (e.g. ``deg/h * sqrt(s)`` for the angle random walk of deg/h
    data).

    Parameters
    ----------
    value : float or array_like
        Coefficient(s) in the natural unit.
    term : str
        One of the keys of :data:`TERM_TIME_POWER`.
    rate_unit : str
        Declared unit of the input rate samples.
    to_unit : str
        Target unit; must measure the term's quantity for that sensor kind.

    Returns
    -------
    float or ndarray
    """
    if term not in TERM_TIME_POWER:
        raise ValueError(f"unknown term {term!r}; valid terms: {', '.join(TERM_TIME_POWER)}")
    src = rate_unit_info(rate_unit)
    dst = unit_info(to_unit)
    power = TERM_TIME_POWER[term]
    if dst.sensor != src.sensor or dst.time_power != power:
        expected = [
            u for u, i in _UNITS.items() if i.sensor == src.sensor and i.time_power == power
        ]
        raise ValueError(
            f"unit {to_unit!r} does not fit the {term} of {rate_unit!r} data; "
            f"use one of: {', '.join(expected)}"
        )
    # natural unit = rate unit * s**power; seconds are SI, so only the rate factor converts.
    factor = src.si_factor / dst.si_factor
    if np.ndim(value) == 0:
        return float(value) * factor
    return np.asarray(value, dtype=float) * factor


@dataclass(frozen=True)
class ConvertedTerm:
    """A noise coefficient in a reporting unit.

    Attributes
    ----------
    value : float or ndarray
    uncertainty : float or ndarray
        1-sigma, converted with the same factor as ``value``.
    unit : str
    upper : float or ndarray
        The one-sided upper bound of a term at 0 (:attr:`adavar.NoiseTerm.upper`), converted
        likewise; NaN elsewhere.
    """

    value: Any
    uncertainty: Any
    unit: str
    upper: Any = float("nan")


@dataclass(frozen=True)
class ConvertedNoise:
    """The five noise coefficients of a fit in reporting units (see :mod:`adavar.core.units`).

    Attributes
    ----------
    quantization, angle_random_walk, bias_instability, rate_random_walk, rate_ramp : ConvertedTerm
    input_unit : str
        The declared unit of the input rate samples.
    sensor : str
        ``"gyro"`` or ``"accelerometer"``.
    """

    quantization: ConvertedTerm
    angle_random_walk: ConvertedTerm
    bias_instability: ConvertedTerm
    rate_random_walk: ConvertedTerm
    rate_ramp: ConvertedTerm
    input_unit: str
    sensor: str

    def __getitem__(self, term: str) -> ConvertedTerm:
        """Access a term by name, ``converted["angle_random_walk"]``."""
        if term not in TERM_TIME_POWER:
            raise KeyError(term)
        return getattr(self, term)

    def as_dict(self) -> dict[str, ConvertedTerm]:
        """Term name -> :class:`ConvertedTerm`."""
        return {name: getattr(self, name) for name in TERM_TIME_POWER}


# --------------------------------------------------------------------------------------
# Units of deviations and coefficients, and numbers with their uncertainty
# --------------------------------------------------------------------------------------


def _times_seconds(unit: str, power: float) -> str:
    """``unit * s**power`` written simply (``deg/s * s -> deg``, ``m/s^2 * sqrt(s) ->
    m/s/sqrt(s)``); ``""`` is dimensionless."""
    if power == 0.0:
        return unit
    per_s = unit.endswith("/s")
    per_s2 = unit.endswith("/s^2")
    base = unit[:-2] if per_s else unit[:-4] if per_s2 else unit
    if power == 1.0:
        if per_s:
            return base
        if per_s2:
            return f"{base}/s"
        return f"{unit}*s" if unit else "s"
    if power == 0.5:
        if per_s:
            return f"{base}/sqrt(s)"
        if per_s2:
            return f"{base}/s/sqrt(s)"
        return f"{unit}*sqrt(s)" if unit else "sqrt(s)"
    if power == -0.5:
        return f"{unit}/sqrt(s)" if unit else "1/sqrt(s)"
    if power == -1.0:
        if per_s:
            return f"{base}/s^2"
        if per_s2:
            return f"{base}/s^3"
        return f"{unit}/s" if unit else "1/s"
    raise ValueError(f"unsupported power of seconds: {power}")


def rate_unit(units: str | None, data_type: str = "rate") -> str | None:
    """Unit of the rate whose deviation is computed, from the unit of the input samples.

    Parameters
    ----------
    units : str or None
        Declared unit of the samples in the file (None if not declared).
    data_type : {"rate", "phase"}
        For ``"rate"`` the samples are the rate (unit unchanged); for ``"phase"`` they are
        its integral and the rate is ``units/s`` (``deg -> deg/s``, ``m/s -> m/s^2``; a time
        error in ``s`` gives a dimensionless fractional frequency, ``""``).

    Returns
    -------
    str or None
    """
    if units is None or data_type == "rate":
        return units
    if units.strip() == "s":
        return ""
    return _times_seconds(units, -1.0)


def is_known_unit(units: str, data_type: str = "rate") -> bool:
    """Whether samples declared in ``units`` are in a unit this module knows.

    Any other unit string is a free label (e.g. ``"mV"``): deviations and coefficients are
    in it as given, without conventional units.

    Parameters
    ----------
    units : str
        Declared unit of the samples.
    data_type : {"rate", "phase"}
        Rate samples must be in one of :data:`RATE_UNITS` (or an alias) or a fractional
        frequency (``1``, ``ns/s``, ...); phase samples in their integral (``deg``, ``rad``,
        ``m/s``, ...) or a clock's time error (``s``, ``ns``, ...: :data:`CLOCK_PHASE_UNITS`,
        whose rate is a dimensionless fractional frequency).

    Returns
    -------
    bool
    """
    if sensor_kind(units, data_type) == "clock":  # a time error (ns) or fractional frequency
        return True
    rate = rate_unit(units, data_type)
    if rate == "":
        return True
    try:
        rate_unit_info(rate or "")
    except (TypeError, ValueError):
        return False
    return True


def known_phase_units() -> tuple[str, ...]:
    """The units of phase samples :func:`is_known_unit` takes: the integrals of
    :data:`RATE_UNITS` it recognises (``rad``, ``deg``, ``m/s``), then a clock's time error
    (:data:`CLOCK_PHASE_UNITS`)."""
    integrals = (_times_seconds(u, 1.0) for u in RATE_UNITS)
    known = [u for u in integrals if is_known_unit(u, "phase")]
    clock = [u for u in ("s", "ms", "us", "ns", "ps", "fs") if u in CLOCK_PHASE_UNITS]
    return tuple(dict.fromkeys([*known, *clock]))


def deviation_unit(stat: str, units: str | None) -> str | None:
    """Unit of a deviation of rate data declared in ``units``.

    Parameters
    ----------
    stat : str
        The statistic; ``"tdev"`` and the other time-like ones (``ttotdev``, ``mtie``,
        ``tierms``) are in the integrated (phase) unit ``units*s``, every other statistic in
        ``units``.
    units : str or None
        Unit of the rate (see :func:`rate_unit`).

    Returns
    -------
    str or None
    """
    if units is None:
        return None
    from adavar.core.extended_statistics import is_time_like

    return _times_seconds(units, 1.0) if is_time_like(stat) else units


def term_unit(term: str, units: str | None) -> str | None:
    """Natural unit of a noise coefficient of rate data declared in ``units``.

    Parameters
    ----------
    term : str
        One of :data:`adavar.fit.noise_model.TERM_NAMES`.
    units : str or None
        Unit of the rate.

    Returns
    -------
    str or None
        ``units*s`` (Q), ``units*sqrt(s)`` (N), ``units`` (B), ``units/sqrt(s)`` (K),
        ``units/s`` (R), simplified (``deg/s -> deg, deg/sqrt(s), deg/s, deg/s/sqrt(s),
        deg/s^2``); None if ``units`` is None.
    """
    if term not in TERM_TIME_POWER:
        raise ValueError(f"unknown noise term {term!r}; valid names: {', '.join(TERM_NAMES)}")
    if units is None:
        return None
    return _times_seconds(units, TERM_TIME_POWER[term])


def format_pm(value: Any, uncertainty: Any, unit: str | None = None, *, digits: int = 2) -> str:
    """A value with its 1-sigma uncertainty, rounded to the uncertainty's digits.

    Parameters
    ----------
    value, uncertainty : float
        NaN value: the term was not fitted. Value 0 with a finite uncertainty: a coefficient
        pinned at 0 by the non-negativity constraint, printed as ``0 (< bound)``.
    unit : str, optional
        Appended after a space.
    digits : int
        Significant digits of the uncertainty.

    Returns
    -------
    str
        E.g. ``"0.30131 ± 0.00056 deg/sqrt(h)"``, ``"(9.75 ± 0.26)e-05 deg"``.
    """
    v, u = float(value), float(uncertainty)
    suffix = f" {unit}" if unit else ""
    if not math.isfinite(v):
        return "not fitted"
    if not math.isfinite(u) or u <= 0.0:
        return f"{v:.6g}{suffix}"
    if v == 0.0:
        return f"0 (< {u:.{digits}g}){suffix}"
    if u >= abs(v):
        return f"{v:.{digits}g} ± {u:.{digits}g}{suffix}"
    exp_u = math.floor(math.log10(u))
    exp_v = math.floor(math.log10(abs(v)))
    if -3 <= exp_v < 5:
        decimals = digits - 1 - exp_u
        if decimals < 0:  # round to tens, hundreds, ...
            return f"{round(v, decimals):.0f} ± {round(u, decimals):.0f}{suffix}"
        return f"{v:.{decimals}f} ± {u:.{decimals}f}{suffix}"
    decimals = max(digits - 1 - (exp_u - exp_v), 0)
    scale = 10.0**exp_v
    body = f"({v / scale:.{decimals}f} ± {u / scale:.{decimals}f})e{exp_v:+03d}"
    return body + suffix


# --------------------------------------------------------------------------------------
# The words of each kind of instrument
# --------------------------------------------------------------------------------------

#: Units of a clock's time error (phase data) and of a fractional frequency (rate data).
CLOCK_PHASE_UNITS = frozenset({"s", "ms", "us", "µs", "ns", "ps", "fs"})
CLOCK_RATE_UNITS = frozenset(
    {"", "1", "s/s", "hz/hz", "ratio", "fractional", "ms/s", "us/s", "µs/s", "ns/s", "ps/s"}
)


def sensor_kind(units: str | None, data_type: str = "rate") -> str:
    """The kind of instrument that data declared in ``units`` come from.

    Parameters
    ----------
    units : str or None
        Declared unit of the samples (None: not declared).
    data_type : {"rate", "phase"}
        How the samples are read (``"freq"``/``"frequency"`` mean ``"rate"``).

    Returns
    -------
    str
        ``"clock"`` for a time error (phase in ``s``, ``ns``, ...) or a dimensionless
        fractional frequency (rate in ``""``, ``"1"``, ``"ratio"``); ``"gyro"`` or
        ``"accelerometer"`` for the inertial units of this module; ``"generic"`` for None or
        any other unit (never guessed).
    """
    if units is None:
        return "generic"
    if not isinstance(units, str):
        raise TypeError(f"a unit must be a string, got {type(units).__name__}")
    phase = str(data_type).lower() == "phase"
    key = units.strip().replace(" ", "")
    if (key in CLOCK_PHASE_UNITS) if phase else (key.lower() in CLOCK_RATE_UNITS):
        return "clock"
    rate = rate_unit(key, "phase" if phase else "rate")
    try:
        return rate_unit_info(rate or "").sensor
    except (TypeError, ValueError):
        return "generic"


def term_names(
    units: str | None, data_type: str = "rate", *, sensor: str | None = None
) -> dict[str, str]:
    """Words that name the noise terms for data declared in ``units``.

    One table (:data:`adavar.core.terms.TERM_LABELS`) holds them: clocks say white PM, flicker
    PM, white FM, flicker FM, random walk FM and frequency drift; gyros quantization,
    angle random walk, bias instability, rate random walk and rate ramp; accelerometers
    velocity random walk and acceleration random walk instead.

    Parameters
    ----------
    units : str or None
        Declared unit of the samples (see :func:`sensor_kind`).
    data_type : {"rate", "phase"}
        How the samples are read.
    sensor : {"gyro", "accelerometer", "clock", "generic"}, optional
        The kind of instrument, overriding the one read from ``units``.

    Returns
    -------
    dict
        Term key -> label, for the keys of both fits: the IEEE terms of
        :func:`adavar.fit_noise` (``"angle_random_walk"``, ...), the power-law terms of
        :func:`adavar.fit_power_law` (``"white_fm"``, ...) and ``"frequency_drift"``.

    Examples
    --------
    >>> term_names("s", "phase")["angle_random_walk"]
    'white FM'
    >>> term_names("m/s^2")["white_fm"]
    'velocity random walk'
    """
    kind = sensor_kind(units, data_type) if sensor is None else sensor
    if kind not in SENSOR_KINDS:
        raise ValueError(f"unknown sensor {sensor!r}; use one of {', '.join(SENSOR_KINDS)}")
    return dict(TERM_LABELS[kind])

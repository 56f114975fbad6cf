"""Exports for other tools: CSV and JSON tables, the coefficient table, a Kalibr ``imu.yaml``.

:func:`write_table_csv` and :func:`write_json` write a file atomically (to a temporary name
in the target folder, then :func:`os.replace`): a reader never sees a half-written file and
a failure leaves any earlier file untouched. :func:`coefficient_rows` turns a
:class:`adavar.fit.noise_model.NoiseFit` into the table of the five noise terms, in the data's
own units and in the conventional ones. :func:`kalibr_imu_yaml` writes the IMU noise file of
the Kalibr camera-IMU calibrator from the fits of a 6-axis static recording. The DAVAR
surface is written by :func:`adavar.io.writers.write_surface` (NetCDF or Parquet).

Every problem with the user's input raises :class:`adavar.core.errors.AdavarInputError` with a
one-line message that names the problem and the way out.
"""

from __future__ import annotations

import json
import math
import numbers
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from adavar.core.atomic import atomic_file
from adavar.core.csv_tables import csv_text
from adavar.core.errors import AdavarInputError
from adavar.core.terms import LETTERS
from adavar.core.units import (
    TERM_TIME_POWER,
    conventional_units,
    convert_coefficient,
    rate_unit_info,
)

__all__ = [
    "COEFFICIENT_COLUMNS",
    "KALIBR_KEYS",
    "coefficient_rows",
    "kalibr_imu_yaml",
    "kalibr_values",
    "write_json",
    "write_table_csv",
    "write_text",
]

#: Columns of :func:`coefficient_rows`, in order.
COEFFICIENT_COLUMNS: tuple[str, ...] = (
    "term",
    "symbol",
    "value",
    "uncertainty",
    "unit",
    "conventional_value",
    "conventional_uncertainty",
    "conventional_unit",
)

#: The keys of a Kalibr ``imu.yaml``, in the order written.
KALIBR_KEYS: tuple[str, ...] = (
    "accelerometer_noise_density",
    "accelerometer_random_walk",
    "gyroscope_noise_density",
    "gyroscope_random_walk",
    "rostopic",
    "update_rate",
)

_SUFFIX_OF_POWER = {1.0: "*s", 0.5: "*sqrt(s)", 0.0: "", -0.5: "/sqrt(s)", -1.0: "/s"}
#: The coefficient's unit: the rate's unit and this (``deg/s*sqrt(s)``, ...).
_NATURAL_SUFFIX = {name: _SUFFIX_OF_POWER[p] for name, p in TERM_TIME_POWER.items()}


def _fail(message: str) -> AdavarInputError:
    return AdavarInputError(message)


# --------------------------------------------------------------------------------------
# atomic files
# --------------------------------------------------------------------------------------


def _atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    with atomic_file(path) as handle:
        handle.write(data)
    return Path(path)


def write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write a UTF-8 text file atomically (temporary name in the same folder, then rename).

    Parameters
    ----------
    path : str or path-like
        The file (replaced if it exists; its folder must exist).
    text : str

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    AdavarInputError
        A missing folder, a folder at ``path``, or a write that fails (no file is left).
    """
    return _atomic_write_bytes(path, text.encode("utf-8"))


def write_table_csv(
    path: str | os.PathLike[str],
    rows: Iterable[Mapping[str, Any] | Sequence[Any]],
    columns: Sequence[str],
    *,
    comment: str | None = None,
) -> Path:
    """Write a table as CSV, atomically.

    The file is plain CSV (:func:`adavar.io.writers.csv_text`: ``pandas.read_csv(path)`` and
    spreadsheets read it as it is): a header line with ``columns``, then one line per row.
    Numbers are written in their shortest exact form (``repr``; NaN as ``nan``), None as an
    empty cell, booleans as ``true``/``false``; a text cell that a spreadsheet would run as
    a formula (``=``, ``+``, ``-``, ``@``, tab, carriage return first, not a number) gets a
    leading ``'``. The whole file is formatted before anything is written, so a bad row
    leaves no file.

    Parameters
    ----------
    path : str or path-like
        The file (replaced if it exists; its folder must exist).
    rows : iterable of mapping or sequence
        A mapping row gives a value per column name (missing names are empty cells;
        a name that is not a column is an error); a sequence row gives the values in
        column order.
    columns : sequence of str
        The column names.
    comment : str, optional
        Free text (may span several lines) written before the header as ``# `` lines: a
        reader then needs ``pandas.read_csv(path, comment="#")``. adavar's own tables have
        none (their metadata is in a JSON file next to them).

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    AdavarInputError
        A missing folder or a failed write.
    ValueError
        A row that does not fit ``columns``.
    TypeError
        A cell that is not a number, text or None.
    """
    columns = [str(c) for c in columns]
    if not columns:
        raise ValueError("a table needs at least one column")
    if len(set(columns)) != len(columns):
        raise ValueError(f"duplicate column names in {columns}")
    table = []
    for k, row in enumerate(rows):
        if isinstance(row, Mapping):
            unknown = [key for key in row if key not in columns]
            if unknown:
                raise ValueError(f"row {k} has a value for {unknown[0]!r}, which is not a column")
            cells = [row.get(c) for c in columns]
        else:
            cells = list(row)
            if len(cells) != len(columns):
                raise ValueError(f"row {k} has {len(cells)} values for {len(columns)} columns")
        table.append(cells)
    return write_text(path, csv_text(columns, table, comment=comment))


def _jsonable(value: Any) -> Any:
    if value is None or isinstance(value, (str, bool)):
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"cannot write a {type(value).__name__} to JSON")


def write_json(path: str | os.PathLike[str], payload: Any, *, indent: int | None = 2) -> Path:
    """Write a JSON document atomically.

    NumPy scalars and arrays become numbers and lists, paths become text, and NaN/Inf
    become ``null`` (strict JSON has no NaN). The document is serialised before anything
    is written, so an unserialisable payload leaves no file.

    Parameters
    ----------
    path : str or path-like
        The file (replaced if it exists; its folder must exist).
    payload : object
        Mappings, sequences, numbers, text, None, NumPy scalars/arrays.
    indent : int or None
        Indentation (None: one line).

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    AdavarInputError
        A missing folder or a failed write.
    TypeError
        A value that cannot be written as JSON.
    """
    text = json.dumps(_jsonable(payload), indent=indent, allow_nan=False, ensure_ascii=False)
    return write_text(path, text + "\n")


# --------------------------------------------------------------------------------------
# the coefficient table
# --------------------------------------------------------------------------------------


def _scalar(value: Any, what: str) -> float:
    arr = np.asarray(value, dtype=float)
    if arr.ndim != 0:
        raise _fail(
            f"{what} holds {arr.size} values (a stack of curves, e.g. DAVAR windows): "
            "give the fit of one curve (the whole-record deviation)"
        )
    return float(arr)


def _none_if_nan(value: float) -> float | None:
    return value if math.isfinite(value) else None


def coefficient_rows(fit: Any, *, units: str | None = None) -> list[dict[str, Any]]:
    """The five noise terms of a fit as table rows.

    Parameters
    ----------
    fit : NoiseFit
        From :func:`adavar.fit_noise` / :func:`adavar.fit_avar`, of one curve.
    units : str, optional
        Unit of the input rate samples (``"deg/s"``, ``"deg/h"``, ``"rad/s"``, ``"m/s^2"``,
        ``"g"``, ...); defaults to the fit's declared unit. Without a unit the
        conventional columns are None and the natural unit is written as ``unit*sqrt(s)``
        etc.

    Returns
    -------
    list of dict
        One row per term (Q, N, B, K, R), keys :data:`COEFFICIENT_COLUMNS`: ``term``
        (attribute name), ``symbol``, ``value`` and ``uncertainty`` (1-sigma) in the
        data's own unit times a power of seconds, ``unit`` (e.g. ``"deg/s*sqrt(s)"``),
        and the same in the conventional unit of :mod:`adavar.core.units` (e.g.
        ``"deg/sqrt(h)"``). NaN (a term not in the model) is None. Write them with
        ``write_table_csv(path, rows, COEFFICIENT_COLUMNS)``.

    Raises
    ------
    AdavarInputError
        An unknown unit, a unit that disagrees with the fit's declared one, or a fit of a
        stack of curves.
    """
    declared = getattr(fit, "units", None)
    if units is None:
        units = declared
    elif declared is not None and units != declared:
        raise _fail(
            f"the fit's data were declared in {declared!r}, not {units!r}: "
            "drop the units argument or refit with the right unit"
        )
    targets: dict[str, str] | None = None
    if units is not None:
        try:
            targets = conventional_units(units)
        except ValueError as exc:
            raise _fail(str(exc)) from None
    base = units if units is not None else "unit"
    rows = []
    for term in TERM_TIME_POWER:
        t = getattr(fit, term)
        value = _scalar(t.value, f"the fit's {term}")
        unc = _scalar(t.uncertainty, f"the fit's {term}")
        row: dict[str, Any] = {
            "term": term,
            "symbol": LETTERS[term],
            "value": _none_if_nan(value),
            "uncertainty": _none_if_nan(unc),
            "unit": base + _NATURAL_SUFFIX[term],
            "conventional_value": None,
            "conventional_uncertainty": None,
            "conventional_unit": None,
        }
        if targets is not None and units is not None:
            row["conventional_value"] = _none_if_nan(
                convert_coefficient(value, term, units, targets[term])
            )
            row["conventional_uncertainty"] = _none_if_nan(
                convert_coefficient(unc, term, units, targets[term])
            )
            row["conventional_unit"] = targets[term]
        rows.append(row)
    return rows


# --------------------------------------------------------------------------------------
# Kalibr imu.yaml
# --------------------------------------------------------------------------------------

_KALIBR_TARGET = {
    # (sensor, term) -> (unit of the coefficient in Kalibr's SI form, Kalibr's unit name)
    ("gyro", "angle_random_walk"): ("rad/sqrt(s)", "rad/s/sqrt(Hz)"),
    ("gyro", "rate_random_walk"): ("rad/s/sqrt(s)", "rad/s^2/sqrt(Hz)"),
    ("accelerometer", "angle_random_walk"): ("m/s/sqrt(s)", "m/s^2/sqrt(Hz)"),
    ("accelerometer", "rate_random_walk"): ("m/s^2/sqrt(s)", "m/s^3/sqrt(Hz)"),
}
_COMBINE = ("max", "mean")
_PINNED = ("error", "bound", "sigma")
_TOPIC = re.compile(r"^[A-Za-z0-9_/~.\-]+$")


def _as_fits(fits: Any, what: str) -> list[Any]:
    if fits is None:
        raise _fail(f"no {what} fits given: pass the fits of the three axes")
    if hasattr(fits, "angle_random_walk"):
        return [fits]
    try:
        out = list(fits)
    except TypeError:
        raise _fail(
            f"{what}_fits must be a NoiseFit or a sequence of them (one per axis)"
        ) from None
    if not out:
        raise _fail(f"no {what} fits given: pass the fits of the three axes")
    for f in out:
        if not hasattr(f, "angle_random_walk") or not hasattr(f, "rate_random_walk"):
            raise _fail(f"{what}_fits must hold NoiseFit objects (from adavar.fit_noise)")
    return out


def _fit_unit(fits: list[Any], given: str | None, what: str, sensor: str, default: str) -> str:
    declared = {f.units for f in fits if getattr(f, "units", None) is not None}
    if len(declared) > 1:
        raise _fail(
            f"the {what} fits were declared in different units ({', '.join(sorted(declared))}): "
            "refit them in one unit"
        )
    unit = given if given is not None else (declared.pop() if declared else default)
    if given is not None and declared and given not in declared:
        raise _fail(
            f"the {what} fits were declared in {declared.pop()!r}, not {given!r}: drop "
            f"{what}_units or refit with the right unit"
        )
    try:
        info = rate_unit_info(unit)
    except ValueError as exc:
        raise _fail(str(exc)) from None
    if info.sensor != sensor:
        kind = (
            "an angular rate (rad/s, deg/s, deg/h)"
            if sensor == "gyro"
            else ("an acceleration (m/s^2, g, mg, ug)")
        )
        raise _fail(
            f"{what}_units {unit!r} (--{what}-units) is not {kind}: declare the unit of the "
            f"{what} data"
        )
    return unit


def _as_names(names: Any, what: str) -> list[str] | None:
    if names is None:
        return None
    if isinstance(names, str) or not all(isinstance(n, str) for n in names):
        raise _fail(f"{what}_names must be a sequence of column names, one per axis, got {names!r}")
    return list(names)


def _axis_values(
    fits: list[Any], term: str, unit: str, what: str, pinned: str, names: list[str] | None,
    bounds: list[str] | None = None,
) -> list[float]:  # fmt: skip
    """The per-axis values of ``term`` in Kalibr's unit; the label of each axis whose value
    is an upper bound (the fit pinned the term at 0, ``pinned``) is appended to ``bounds``."""
    sensor = rate_unit_info(unit).sensor
    target, _ = _KALIBR_TARGET[(sensor, term)]
    symbol = LETTERS[term]
    values: list[float] = []
    for f in fits:
        t = getattr(f, term)
        if getattr(f, "time", None) is not None:
            raise _fail(
                f"the {what} fits are DAVAR fits over time: give the whole-record fits "
                "(adavar.fit_noise(adavar.deviation(x, ...)))"
            )
        vals = np.ravel(np.asarray(t.value, dtype=float))
        shape = np.shape(t.value)
        uncs = np.ravel(np.broadcast_to(np.asarray(t.uncertainty, dtype=float), shape))
        upper = getattr(t, "upper", None)
        uppers = np.ravel(np.broadcast_to(np.asarray(np.nan if upper is None else upper,
                                                     dtype=float), shape))  # fmt: skip
        for v, u, up in zip(vals, uncs, uppers, strict=True):
            axis = len(values)
            label = (
                f"column {names[axis]!r}"
                if names is not None and axis < len(names)
                else f"axis {axis}"
            )
            if not (math.isfinite(v) and v > 0):
                # a term pinned at zero: its bound_level bound (99 %), or the 84 % one of
                # pinned="sigma" (below the truth in 28 of 32 dropped random walks)
                bound = math.isfinite(u) and u > 0
                has_upper = math.isfinite(up) and up > 0
                if pinned == "bound" and has_upper:
                    v = up
                    if bounds is not None:
                        bounds.append(label)
                elif pinned == "sigma" and bound:
                    v = u
                    if bounds is not None:
                        bounds.append(label)
                elif pinned == "bound" and bound:
                    raise _fail(
                        f"the {what} fit of {label} has no {term} ({symbol} = {v:g}) and only "
                        "its 84 % bound (not a GLS fit of a whole record): refit with "
                        "adavar.fit_noise(adavar.deviation(x, ...)), or pass pinned='sigma'"
                    )
                elif not bound:
                    raise _fail(
                        f"the {what} fit of {label} has no {term} ({symbol} = {v:g}) and no "
                        "upper bound to use instead: the data are constant or too short to "
                        "fit; check that it is the right column and that the sensor was "
                        "recording"
                    )
                else:
                    raise _fail(
                        f"the {what} fit of {label} has no {term} ({symbol} = {v:g}): "
                        "fit a longer record with the term in the model, or pass "
                        "pinned='bound' to use its 99 % upper bound"
                    )
            values.append(float(convert_coefficient(v, term, unit, target)))
    if names is not None and len(names) != len(values):
        raise _fail(
            f"{what}_names has {len(names)} names for {len(values)} {what} axes: give one "
            "name per axis"
        )
    return values


def kalibr_values(
    *,
    gyro_fits: Any,
    accel_fits: Any,
    gyro_units: str | None = None,
    accel_units: str | None = None,
    combine: str = "max",
    inflate: float = 1.0,
    pinned: str = "error",
    gyro_names: Sequence[str] | None = None,
    accel_names: Sequence[str] | None = None,
) -> dict[str, Any]:
    """The four Kalibr noise values and the per-axis values they come from.

    Parameters are those of :func:`kalibr_imu_yaml`.

    Returns
    -------
    dict
        ``accelerometer_noise_density``, ``accelerometer_random_walk``,
        ``gyroscope_noise_density``, ``gyroscope_random_walk`` (floats in Kalibr's units,
        combined over the axes and multiplied by ``inflate``), ``axes``: the same four
        keys -> list of per-axis values before combination and inflation, and ``bounds``:
        those keys -> the axes whose value is an upper bound (``pinned``), where any is.
    """
    if combine not in _COMBINE:
        raise _fail(f"unknown combine {combine!r}: use 'max' (conservative) or 'mean'")
    if pinned not in _PINNED:
        raise _fail(f"unknown pinned {pinned!r}: use 'error', 'bound' or 'sigma'")
    if isinstance(inflate, bool) or not isinstance(inflate, numbers.Real):
        raise _fail(f"inflate must be a number >= 1 (1 = no inflation), got {inflate!r}")
    inflate = float(inflate)
    if not math.isfinite(inflate) or inflate <= 0:
        raise _fail(f"inflate must be a positive factor (1 = no inflation), got {inflate!r}")
    gyros = _as_fits(gyro_fits, "gyro")
    accels = _as_fits(accel_fits, "accel")
    g_names = _as_names(gyro_names, "gyro")
    a_names = _as_names(accel_names, "accel")
    g_unit = _fit_unit(gyros, gyro_units, "gyro", "gyro", "rad/s")
    a_unit = _fit_unit(accels, accel_units, "accel", "accelerometer", "m/s^2")
    bounds: dict[str, list[str]] = {key: [] for key in KALIBR_KEYS[:4]}
    axes = {
        "accelerometer_noise_density": _axis_values(
            accels, "angle_random_walk", a_unit, "accel", pinned, a_names,
            bounds["accelerometer_noise_density"],
        ),
        "accelerometer_random_walk": _axis_values(
            accels, "rate_random_walk", a_unit, "accel", pinned, a_names,
            bounds["accelerometer_random_walk"],
        ),
        "gyroscope_noise_density": _axis_values(
            gyros, "angle_random_walk", g_unit, "gyro", pinned, g_names,
            bounds["gyroscope_noise_density"],
        ),
        "gyroscope_random_walk": _axis_values(
            gyros, "rate_random_walk", g_unit, "gyro", pinned, g_names,
            bounds["gyroscope_random_walk"],
        ),
    }  # fmt: skip
    reduce = max if combine == "max" else (lambda v: math.fsum(v) / len(v))
    out: dict[str, Any] = {key: reduce(vals) * inflate for key, vals in axes.items()}
    out["axes"] = axes
    out["bounds"] = {key: labels for key, labels in bounds.items() if labels}
    out["gyro_units"] = g_unit
    out["accel_units"] = a_unit
    return out


def _yaml_float(value: float) -> str:
    # a mantissa with a dot and a signed exponent: a float for YAML 1.1 (PyYAML) and 1.2
    return f"{value:.9e}"


def _factor_text(unit: str, term: str, target: str) -> str:
    factor = float(convert_coefficient(1.0, term, unit, target))
    return "1" if factor == 1.0 else f"{factor:.12g}"


def kalibr_imu_yaml(
    *,
    gyro_fits: Any,
    accel_fits: Any,
    rate: float,
    topic: str = "/imu0",
    gyro_units: str | None = None,
    accel_units: str | None = None,
    combine: str = "max",
    inflate: float = 1.0,
    pinned: str = "error",
    gyro_names: Sequence[str] | None = None,
    accel_names: Sequence[str] | None = None,
) -> str:
    """The Kalibr ``imu.yaml`` of a 6-axis IMU from its noise fits.

    Kalibr (ethz-asl/kalibr, "IMU Noise Model") takes continuous-time white-noise
    densities and bias random walks in SI units. They are the IEEE-952 coefficients of
    :class:`adavar.fit.noise_model.NoiseFit` in SI, with the same numerical value:

    ================================  ==================  ==========================
    key                               Kalibr's unit       adavar term (SI unit)
    ================================  ==================  ==========================
    ``gyroscope_noise_density``       rad/s/sqrt(Hz)      N, rad/sqrt(s)
    ``gyroscope_random_walk``         rad/s^2/sqrt(Hz)    K, rad/s/sqrt(s)
    ``accelerometer_noise_density``   m/s^2/sqrt(Hz)      N (VRW), m/s/sqrt(s)
    ``accelerometer_random_walk``     m/s^3/sqrt(Hz)      K, m/s^2/sqrt(s)
    ================================  ==================  ==========================

    Conversions from the data's units (the fits are in the declared input unit times a
    power of s): gyro data in deg/s: N and K times ``pi/180``; in deg/h: times
    ``pi/180/3600``; in rad/s: unchanged. Accelerometer data in g: times ``9.80665``; mg:
    ``9.80665e-3``; ug: ``9.80665e-6``; m/s^2: unchanged. From the conventional units:
    ``N[rad/s/sqrt(Hz)] = N[deg/sqrt(h)] * (pi/180) / 60``,
    ``K[rad/s^2/sqrt(Hz)] = K[deg/h/sqrt(h)] * (pi/180) / 3600 / 60``,
    ``N[m/s^2/sqrt(Hz)] = VRW[m/s/sqrt(h)] / 60``. ``update_rate`` is the IMU rate in Hz,
    which Kalibr uses to discretise: ``sigma_d = sigma * sqrt(rate)`` for the noise
    density and ``sigma_bd = sigma_b / sqrt(rate)`` for the random walk.

    The three axes of each sensor are combined into the single value Kalibr takes: by
    default the largest (``combine="max"``, conservative), or their mean
    (``combine="mean"``). Common Kalibr practice is to inflate the values of a static
    Allan-variance analysis (often by a factor of about 10 for a low-cost MEMS IMU) to
    cover unmodelled effects (temperature, vibration, scale factor) seen in motion; this
    function does not do that unless asked (``inflate``), and writes the factor used into
    the file's comment block along with the per-axis values and the conversions.

    Parameters
    ----------
    gyro_fits, accel_fits : NoiseFit or sequence of NoiseFit
        The whole-record fits (:func:`adavar.fit_noise`) of the gyro and accelerometer
        axes, usually three each (any number >= 1 is accepted; one fit of a stack of
        curves counts each curve as an axis). DAVAR fits over time are rejected.
    rate : float
        The IMU sample rate in Hz (``update_rate``).
    topic : str
        The ROS topic of the IMU messages (``rostopic``).
    gyro_units, accel_units : str, optional
        Unit of the gyro / accelerometer input samples (:data:`adavar.core.units.RATE_UNITS`).
        Default: the unit the fits were declared in, else ``"rad/s"`` / ``"m/s^2"``. If
        the fits declare a unit, a different one here is an error.
    combine : {"max", "mean"}
        How the axes are combined.
    inflate : float
        Factor applied to all four values (1 = the fitted values).
    pinned : {"error", "bound", "sigma"}
        What to do when an axis has no N or K (the fit pinned it at 0, e.g. K on a short
        record): ``"error"``; ``"bound"`` to use the term's upper bound at the fit's
        ``bound_level`` (``NoiseTerm.upper``, 99 % by default: at or above the truth in 8
        of 12 dropped random walks of an audit, where the 84 % one was in 4 of 32);
        ``"sigma"`` for the 84 % bound (``NoiseTerm.uncertainty``, what ``"bound"`` gave
        before 0.3.0). An axis without a bound (a constant column) is an error in each case.
    gyro_names, accel_names : sequence of str, optional
        The columns the axes come from, one per axis, to name them in the messages
        (default: ``axis 0``, ``axis 1``, ...).

    Returns
    -------
    str
        The YAML text (comment block, then the six keys of :data:`KALIBR_KEYS`); numbers
        are written as ``1.234567890e-04`` (a float for YAML 1.1 and 1.2 parsers).

    Raises
    ------
    AdavarInputError
        Missing fits, units of the wrong kind or disagreeing with the fits, a bad rate,
        topic, ``combine``, ``inflate`` or ``pinned``, a missing N/K with
        ``pinned="error"``, or one without an upper bound.
    """
    if isinstance(rate, bool) or not isinstance(rate, numbers.Real):
        raise _fail(f"the IMU rate must be a number in Hz, got {rate!r}")
    rate = float(rate)
    if not math.isfinite(rate) or rate <= 0:
        raise _fail(f"the IMU rate must be a positive number in Hz, got {rate!r}")
    if not isinstance(topic, str) or not topic.strip() or "\n" in topic:
        raise _fail(f"the ROS topic must be a one-line name such as /imu0, got {topic!r}")
    topic = topic.strip()
    values = kalibr_values(
        gyro_fits=gyro_fits,
        accel_fits=accel_fits,
        gyro_units=gyro_units,
        accel_units=accel_units,
        combine=combine,
        inflate=inflate,
        pinned=pinned,
        gyro_names=gyro_names,
        accel_names=accel_names,
    )
    g_unit, a_unit = values["gyro_units"], values["accel_units"]
    inflate = float(inflate)

    def axes_text(key: str) -> str:
        return ", ".join(_yaml_float(v) for v in values["axes"][key])

    from adavar import __version__

    how = "largest (conservative)" if combine == "max" else "mean"
    lines = [
        f"# Kalibr IMU noise model (imu.yaml), written by adavar {__version__}",
        "# from whole-record Allan-variance fits of a static recording.",
        "#",
        "# Units (Kalibr's continuous time; the same numbers as the IEEE-952 terms in SI):",
        "#   accelerometer_noise_density  m/s^2/sqrt(Hz)   = VRW N in m/s/sqrt(s)",
        "#   accelerometer_random_walk    m/s^3/sqrt(Hz)   = accel. random walk K in m/s^2/sqrt(s)",
        "#   gyroscope_noise_density      rad/s/sqrt(Hz)   = angle random walk N in rad/sqrt(s)",
        "#   gyroscope_random_walk        rad/s^2/sqrt(Hz) = rate random walk K in rad/s/sqrt(s)",
        f"# Data units: gyro {g_unit} (N, K times "
        f"{_factor_text(g_unit, 'angle_random_walk', 'rad/sqrt(s)')}), "
        f"accelerometer {a_unit} (N, K times "
        f"{_factor_text(a_unit, 'angle_random_walk', 'm/s/sqrt(s)')}).",
        "# Conventional units: N[rad/s/sqrt(Hz)] = N[deg/sqrt(h)] * (pi/180) / 60;",
        "#   K[rad/s^2/sqrt(Hz)] = K[deg/h/sqrt(h)] * (pi/180) / 3600 / 60;",
        "#   N[m/s^2/sqrt(Hz)] = VRW[m/s/sqrt(h)] / 60; 1 g = 9.80665 m/s^2.",
        "# Kalibr discretises with update_rate: sigma_d = sigma * sqrt(rate) (noise density),",
        "#   sigma_bd = sigma_b / sqrt(rate) (random walk).",
        f"# Axes combined: {how} of {len(values['axes']['gyroscope_noise_density'])} gyro and "
        f"{len(values['axes']['accelerometer_noise_density'])} accelerometer axes.",
        "# Per-axis values (before combination and inflation):",
    ]
    lines += [f"#   {key}: [{axes_text(key)}]" for key in KALIBR_KEYS[:4]]
    if inflate == 1.0:
        lines.append("# Inflation: none (the fitted values). Kalibr users commonly inflate static")
        lines.append("#   Allan-variance values (e.g. x10) to cover unmodelled effects in motion.")
    else:
        lines.append(f"# Inflation: all four values multiplied by {inflate:g}.")
    if pinned == "bound":
        lines.append("# Where a fit pinned N or K at 0, its upper bound at the fit's bound_level")
        lines.append("#   (99 % unless set otherwise) is used.")
    elif pinned == "sigma":
        lines.append("# Where a fit pinned N or K at 0, its 84 % (1-sigma) upper bound is used.")
    for key, labels in values["bounds"].items():
        lines.append(f"# Upper bounds, not fitted values: {key} of {', '.join(labels)}.")
    topic_text = topic if _TOPIC.match(topic) else json.dumps(topic)
    rate_text = repr(rate) if "e" not in repr(rate) else _yaml_float(rate)
    comments = {
        "accelerometer_noise_density": "m/s^2/sqrt(Hz), continuous-time white noise",
        "accelerometer_random_walk": "m/s^3/sqrt(Hz), bias random walk",
        "gyroscope_noise_density": "rad/s/sqrt(Hz), continuous-time white noise",
        "gyroscope_random_walk": "rad/s^2/sqrt(Hz), bias random walk",
    }
    lines.append("")
    lines.append("#Accelerometers")
    for key in KALIBR_KEYS[:2]:
        lines.append(f"{key}: {_yaml_float(values[key])}  # {comments[key]}")
    lines.append("")
    lines.append("#Gyroscopes")
    for key in KALIBR_KEYS[2:4]:
        lines.append(f"{key}: {_yaml_float(values[key])}  # {comments[key]}")
    lines.append("")
    lines.append(f"rostopic: {topic_text}  # the IMU ROS topic")
    lines.append(f"update_rate: {rate_text}  # Hz (for discretization of the values above)")
    return "\n".join(lines) + "\n"

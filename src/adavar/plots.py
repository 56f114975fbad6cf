"""Figures of deviation curves and noise fits, and the unit labels they need.

Every function builds a :class:`matplotlib.figure.Figure` with an Agg canvas attached and
returns it; nothing touches pyplot's global state (no current figure, no backend switch),
so the functions are safe in scripts, servers and notebooks alike. :func:`save_figure`
writes a figure atomically.

The unit helpers (:func:`rate_unit`, :func:`deviation_unit`, :func:`term_unit`) turn the
unit the user declared into the unit of a deviation or of a noise coefficient, and
:func:`format_pm` prints a value with its uncertainty.
"""

from __future__ import annotations

import contextlib
import math
import os
import secrets
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adavar.noise_model import TERM_NAMES
from adavar.results import DeviationResult

if TYPE_CHECKING:  # matplotlib is imported when a figure is made (fast CLI start-up)
    from matplotlib.figure import Figure

__all__ = [
    "STAT_NAMES",
    "TERM_LABELS",
    "deviation_figure",
    "deviation_unit",
    "format_pm",
    "rate_unit",
    "save_figure",
    "term_unit",
]

#: Axis-label name of each statistic.
STAT_NAMES: dict[str, str] = {
    "adev": "Allan deviation",
    "oadev": "Overlapping Allan deviation",
    "mdev": "Modified Allan deviation",
    "tdev": "Time deviation",
    "hdev": "Hadamard deviation",
    "ohdev": "Overlapping Hadamard deviation",
    "totdev": "Total deviation",
}

#: IEEE Std 952 letter and readable name of each noise term.
TERM_LABELS: dict[str, tuple[str, str]] = {
    "quantization": ("Q", "quantization"),
    "angle_random_walk": ("N", "angle random walk"),
    "bias_instability": ("B", "bias instability"),
    "rate_random_walk": ("K", "rate random walk"),
    "rate_ramp": ("R", "rate ramp"),
}

_TERM_POWER = {
    "quantization": 1.0,
    "angle_random_walk": 0.5,
    "bias_instability": 0.0,
    "rate_random_walk": -0.5,
    "rate_ramp": -1.0,
}


# --------------------------------------------------------------------------------------
# Units and numbers
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


def deviation_unit(stat: str, units: str | None) -> str | None:
    """Unit of a deviation of rate data declared in ``units``.

    Parameters
    ----------
    stat : str
        The statistic; ``"tdev"`` is in the integrated (phase) unit ``units*s``, every other
        statistic in ``units``.
    units : str or None
        Unit of the rate (see :func:`rate_unit`).

    Returns
    -------
    str or None
    """
    if units is None:
        return None
    return _times_seconds(units, 1.0) if stat == "tdev" else units


def term_unit(term: str, units: str | None) -> str | None:
    """Natural unit of a noise coefficient of rate data declared in ``units``.

    Parameters
    ----------
    term : str
        One of :data:`adavar.noise_model.TERM_NAMES`.
    units : str or None
        Unit of the rate.

    Returns
    -------
    str or None
        ``units*s`` (Q), ``units*sqrt(s)`` (N), ``units`` (B), ``units/sqrt(s)`` (K),
        ``units/s`` (R), simplified (``deg/s -> deg, deg/sqrt(s), deg/s, deg/s/sqrt(s),
        deg/s^2``); None if ``units`` is None.
    """
    if term not in _TERM_POWER:
        raise ValueError(f"unknown noise term {term!r}; valid names: {', '.join(TERM_NAMES)}")
    if units is None:
        return None
    return _times_seconds(units, _TERM_POWER[term])


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
# Figures
# --------------------------------------------------------------------------------------


def _new_figure(figsize: tuple[float, float] = (7.5, 5.5)) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _term_labels(fit: Any, units: str | None) -> dict[str, str]:
    """Legend text of every term: value ± uncertainty, in conventional units if possible."""
    converted = None
    with contextlib.suppress(ValueError, TypeError):
        converted = fit.to_units(None if fit.units is not None else units)
    labels = {}
    for name in TERM_NAMES:
        letter, long_name = TERM_LABELS[name]
        if converted is not None:
            term = converted[name]
            text = format_pm(term.value, term.uncertainty, term.unit)
        else:
            term = fit.term(name)
            text = format_pm(term.value, term.uncertainty, term_unit(name, units))
        labels[name] = f"{letter} ({long_name}) = {text}"
    return labels


def deviation_figure(
    result: DeviationResult,
    fit: Any = None,
    *,
    units: str | None = None,
    title: str | None = None,
) -> Figure:
    """Log-log plot of a deviation curve with its confidence bars, and optionally a noise fit.

    Parameters
    ----------
    result : DeviationResult
        From :func:`adavar.deviation`.
    fit : NoiseFit, optional
        From :func:`adavar.fit_noise` (a single curve). Adds the fitted model
        ``fit.model_dev(tau)`` and the asymptote ``fit.term_dev(name, tau)`` of every term
        with a non-zero coefficient, labelled with the term's value ± uncertainty (in the
        conventional units when the data's unit is one of :data:`adavar.units.RATE_UNITS`).
    units : str, optional
        Unit of the rate; defaults to ``result.units``. Omitted from the labels if unknown.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        One axes: the data as an error-bar line (``ax.containers[0]``), then the model and
        the asymptotes as lines, with a legend.
    """
    unit = units if units is not None else result.units
    tau = np.asarray(result.tau, dtype=float)
    dev = np.asarray(result.dev, dtype=float)
    low = np.asarray(result.dev_low, dtype=float)
    high = np.asarray(result.dev_high, dtype=float)

    fig = _new_figure()
    ax = fig.add_subplot()
    ax.set_xscale("log")
    ax.set_yscale("log")

    stat_name = STAT_NAMES.get(result.stat, result.stat)
    has_ci = bool(np.all(np.isfinite(low)) and np.all(np.isfinite(high)))
    label = result.stat.upper()
    if has_ci:
        label += f", {100 * result.confidence:.1f} % confidence"
        yerr = np.vstack([dev - low, high - dev])
    else:
        yerr = None
    ax.errorbar(
        tau, dev, yerr=yerr, fmt="o-", color="C0", markersize=4, linewidth=1.2,
        capsize=2.5, elinewidth=1.0, label=label, zorder=3,
    )  # fmt: skip

    if fit is not None:
        coefficients = np.asarray(fit.coefficients)
        if coefficients.ndim != 1:
            raise ValueError("deviation_figure draws one fit: pass a single-curve NoiseFit")
        grid = np.geomspace(tau.min(), tau.max(), 200) if tau.size > 1 else tau
        red = float(fit.reduced_chi2)
        fit_label = "fitted model"
        if math.isfinite(red):
            fit_label += f" (reduced χ² = {red:.2f})"
        ax.plot(grid, fit.model_dev(grid), "-", color="k", linewidth=1.6, label=fit_label)
        labels = _term_labels(fit, unit)
        for k, name in enumerate(TERM_NAMES):
            if coefficients[k] > 0:
                ax.plot(
                    grid, fit.term_dev(name, grid), "--", color=f"C{k + 1}", linewidth=1.1,
                    label=labels[name],
                )  # fmt: skip

    finite = np.concatenate([dev, low if has_ci else dev, high if has_ci else dev])
    finite = finite[np.isfinite(finite) & (finite > 0)]
    if finite.size:
        ax.set_ylim(finite.min() / 2.5, finite.max() * 2.5)
    dev_unit = deviation_unit(result.stat, unit)
    ax.set_ylabel(f"{stat_name} [{dev_unit}]" if dev_unit else stat_name)
    ax.set_xlabel("tau [s]")
    ax.grid(True, which="major", alpha=0.5)
    ax.grid(True, which="minor", alpha=0.15)
    handles, labels = ax.get_legend_handles_labels()
    order = sorted(range(len(labels)), key=lambda k: labels[k] != label)  # the data first
    ax.legend([handles[k] for k in order], [labels[k] for k in order], fontsize="small",
              loc="best")
    if title:
        ax.set_title(title)
    return fig


def save_figure(
    fig: Figure,
    path_without_suffix: str | os.PathLike[str],
    formats: Sequence[str] = ("png", "svg"),
    *,
    dpi: int = 150,
) -> list[Path]:
    """Write a figure in one or more formats, each file atomically.

    Each file is written under a temporary name in the target folder and moved into place
    with :func:`os.replace`, so a reader never sees a half-written file.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path_without_suffix : str or path-like
        Target path; ``".png"``, ``".svg"``, ... are appended.
    formats : sequence of str
        Matplotlib output formats.
    dpi : int
        Resolution of raster formats.

    Returns
    -------
    list of Path
        The files written, in the order of ``formats``.
    """
    base = Path(path_without_suffix)
    folder = base.parent
    written = []
    for fmt in formats:
        target = Path(f"{base}.{fmt}")
        # not mkstemp: its 0600 mode would stick to the final file; "x" honours the umask
        tmp_name = folder / f".{target.name}.{secrets.token_hex(6)}.tmp"
        try:
            with open(tmp_name, "xb") as handle:
                fig.savefig(handle, format=fmt, dpi=dpi)
            os.replace(tmp_name, target)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp_name)
            raise
        written.append(target)
    return written

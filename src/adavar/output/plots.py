"""Figures of deviation curves, DAVAR surfaces and noise fits, and the unit labels they need.

:func:`deviation_figure` draws one deviation curve and its noise fit;
:func:`davar_surface_figure` (3-D) and :func:`davar_heatmap_figure` (time x tau map) draw a
dynamic Allan deviation surface, and :func:`coefficient_figure` one noise coefficient of
every DAVAR window over time (N(t), B(t), ...) with its uncertainty band. The DAVAR figures
decimate the windows (and taus) before drawing, so a surface of 1e6 windows is drawn as
fast as one of a few hundred.

Every function builds a :class:`matplotlib.figure.Figure` with an Agg canvas attached and
returns it; nothing touches pyplot's global state (no current figure, no backend switch),
so the functions are safe in scripts, servers and notebooks alike. :func:`save_figure`
writes a figure atomically. :func:`deviation_figure`, :func:`davar_heatmap_figure` and
:func:`coefficient_figure` draw on a given ``ax=`` instead (the user's figure, pyplot's or
not); the results' ``.plot()`` (:func:`adavar.output.notebook.plot_of`) makes a pyplot figure
when the caller has imported :mod:`matplotlib.pyplot`, so that ``r.plot();
plt.savefig("r.png")`` writes it.

The unit helpers (:func:`rate_unit`, :func:`deviation_unit`, :func:`term_unit`) turn the
unit the user declared into the unit of a deviation or of a noise coefficient, and
:func:`format_pm` prints a value with its uncertainty.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adavar.core.atomic import partial_name
from adavar.core.terms import TERM_NAMES, TERMS
from adavar.core.thinning import spread_indices, spread_log
from adavar.core.units import (
    conventional_units,
    convert_coefficient,
    deviation_unit,
    format_pm,
    rate_unit,
    term_unit,
)
from adavar.output._figures import (
    DEFAULT_FIGURE_FORMATS,
    PNG_COMPRESS_LEVEL,
    cell_edges,
    colour_limits,
    figure_axes,
    log_scale,
    new_figure,
)
from adavar.output.paper_figures import (
    arw_comparison_figure,
    contribution_figure,
    controller_figure,
    kurtosis_windows_figure,
    threshold_figure,
)

if TYPE_CHECKING:  # matplotlib is imported when a figure is made (fast CLI start-up)
    from matplotlib.figure import Figure

    from adavar.comparison import Comparison
    from adavar.core.results import DavarResult, DeviationResult, NoiseFit
    from adavar.paper.studies import KurtosisStudy, ThresholdStudy

__all__ = [
    "STAT_NAMES",
    "TERM_LABELS",
    "FigureRecipe",
    "arw_comparison_figure",
    "coefficient_figure",
    "comparison_figures",
    "contribution_figure",
    "controller_figure",
    "davar_heatmap_figure",
    "davar_surface_figure",
    "deviation_figure",
    "deviation_unit",
    "format_pm",
    "kurtosis_windows_figure",
    "paper_figure_recipes",
    "rate_unit",
    "save_figure",
    "spread_indices",
    "study_figures",
    "term_label",
    "term_unit",
    "threshold_figure",
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
    "mtotdev": "Modified total deviation",
    "ttotdev": "Time total deviation",
    "htotdev": "Hadamard total deviation",
    "pdev": "Parabolic deviation",
    "theo1": "Theo1 deviation",
    "theobr": "Bias-removed Theo1 deviation",
    "theoh": "Hybrid Theo deviation",
    "mtie": "Maximum time interval error",
    "tierms": "RMS time interval error",
}

#: IEEE Std 952 letter and readable name of each noise term.
TERM_LABELS: dict[str, tuple[str, str]] = {t.name: (t.letter, t.label) for t in TERMS}


def term_label(name: str, units: str | None) -> tuple[str, str]:
    """IEEE letter and the field's name of a noise term for rate data in ``units``.

    Angle random walk for a gyro, velocity random walk for an accelerometer, white FM for
    a clock (:func:`adavar.core.units.term_names`); the IEEE Std 952 name when the unit says
    neither.
    """
    from adavar.core.units import term_names

    try:
        names = term_names(units)
    except (TypeError, ValueError):
        names = {}
    return TERM_LABELS[name][0], names.get(name, TERM_LABELS[name][1])


# --------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------


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
    ax: Any = None,
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
        conventional units when the data's unit is one of :data:`adavar.core.units.RATE_UNITS`).
    units : str, optional
        Unit of the rate; defaults to ``result.units``. Omitted from the labels if unknown.
    title : str, optional
        Figure title.
    ax : matplotlib.axes.Axes, optional
        Draw on these axes (of any figure) instead of a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        ``ax``'s figure, or a new one with one axes: the data as an error-bar line
        (``ax.containers[0]``), then the model,
        the taus the fit left out (hollow grey markers, ``fit.excluded``) and the
        asymptotes as lines, with a legend.
    """
    unit = units if units is not None else result.units
    tau = np.asarray(result.tau, dtype=float)
    dev = np.asarray(result.dev, dtype=float)
    low = np.asarray(result.dev_low, dtype=float)
    high = np.asarray(result.dev_high, dtype=float)

    fig, ax = figure_axes(ax, (7.5, 5.5))
    log_scale(ax, "xy")

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
        used = tau if fit.used is None or not np.any(fit.used) else tau[np.asarray(fit.used)]
        # the model is drawn where it was fitted (a roll-off term is no model below that)
        grid = np.geomspace(used.min(), used.max(), 200) if used.size > 1 else used
        red = float(fit.reduced_chi2)
        fit_label = "fitted model"
        if math.isfinite(red):
            fit_label += f" (reduced χ² = {red:.2f})"
        ax.plot(grid, fit.model_dev(grid), "-", color="k", linewidth=1.6, label=fit_label)
        excluded = fit.excluded
        if excluded is not None and np.any(excluded):
            # the points the fit left out (roll-off, tau range, bandwidth): hollow, grey
            ax.plot(
                tau[excluded], dev[excluded], "o", markerfacecolor="white", color="0.45",
                markersize=7, zorder=4, label=f"not fitted ({int(excluded.sum())} taus)",
            )  # fmt: skip
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
    ax.legend([handles[k] for k in order], [labels[k] for k in order], fontsize="small", loc="best")
    if title:
        ax.set_title(title)
    return fig


# --------------------------------------------------------------------------------------
# DAVAR figures
# --------------------------------------------------------------------------------------


def _log_dev(result: DavarResult, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """log10 of the Allan deviation at the chosen cells; NaN where undefined."""
    avar = np.asarray(result.avar)[np.ix_(rows, cols)]
    good = np.isfinite(avar) & (avar > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(good, 0.5 * np.log10(np.where(good, avar, 1.0)), np.nan)


def _log_label(name: str, unit: str | None) -> str:
    """``log10(name / unit)``, the unit in parentheses when it is compound."""
    if not unit:
        return f"log10 {name}"
    shown = f"({unit})" if any(c in unit for c in "/*^ ") else unit
    return f"log10({name} / {shown})"


def davar_surface_figure(
    result: DavarResult,
    *,
    units: str | None = None,
    title: str | None = None,
    max_times: int = 400,
    max_taus: int = 100,
    cmap: str = "viridis",
    elev: float = 28.0,
    azim: float = -125.0,
) -> Figure:
    """The dynamic Allan deviation as a 3-D surface (the A-DAVAR paper's Fig. 4).

    Axes: ``log10(tau)``, time, and ``log10`` of the Allan deviation of each window.

    Parameters
    ----------
    result : DavarResult
        From :func:`adavar.davar`.
    units : str, optional
        Unit of the rate; defaults to ``result.units``. Omitted from the labels if unknown.
    title : str, optional
        Figure title.
    max_times : int
        At most this many windows are drawn, evenly spread over the record (first and last
        included): drawing cost does not grow with the number of windows.
    max_taus : int
        At most this many taus are drawn, evenly spread in ``log(tau)``.
    cmap : str
        Matplotlib colour map of the surface (coloured by height).
    elev, azim : float
        Viewing angles in degrees (see ``Axes3D.view_init``).

    Returns
    -------
    matplotlib.figure.Figure
        A 3-D axes (``fig.axes[0]``) holding one surface (``ax.collections[0]``,
        rasterized so that SVG files stay small; a line instead if there is a single
        window or a single tau), and a colour bar (``fig.axes[1]``); the title is the
        figure's suptitle. Cells where the deviation is undefined (tau beyond a
        third of the window) are left out.
    """
    from mpl_toolkits.mplot3d import Axes3D  # noqa: F401  (registers the 3-D projection)

    unit = units if units is not None else result.units
    tau = np.asarray(result.tau, dtype=float)
    time_ = np.asarray(result.time, dtype=float)
    rows = spread_indices(time_.size, max_times)
    cols = spread_log(tau, max_taus)
    z = _log_dev(result, rows, cols)
    x, y = np.meshgrid(np.log10(tau[cols]), time_[rows])
    vmin, vmax = colour_limits(z)

    # constrained layout does not see the 3-D axis labels: place the axes by hand
    fig = new_figure((8.0, 6.5), layout=None)
    ax = fig.add_axes((0.02, 0.02, 0.8, 0.88), projection="3d")
    cax = fig.add_axes((0.86, 0.22, 0.025, 0.56))
    if min(z.shape) >= 2:
        mappable: Any = ax.plot_surface(
            x, y, np.ma.masked_invalid(z), cmap=cmap, vmin=vmin, vmax=vmax, rstride=1,
            cstride=1, linewidth=0, antialiased=False, rasterized=True,
        )  # fmt: skip
    else:  # one window or one tau: a surface would have no cells, draw the curve
        from matplotlib.cm import ScalarMappable
        from matplotlib.colors import Normalize

        ax.plot(x.ravel(), y.ravel(), z.ravel(), "o-", color="C0", markersize=3)
        mappable = ScalarMappable(norm=Normalize(vmin, vmax), cmap=cmap)
    dev_label = _log_label("ADEV", unit)
    ax.set_xlabel("log10(tau / s)")
    ax.set_ylabel("time [s]")
    ax.set_zlabel(dev_label)
    if vmin is not None:
        ax.set_zlim(vmin, vmax)
    ax.view_init(elev=elev, azim=azim)
    ax.set_box_aspect(None, zoom=0.92)
    fig.colorbar(mappable, cax=cax, label=_log_label("Allan deviation", unit))
    fig.suptitle(title or _davar_title(result, rows.size, cols.size), fontsize="medium")
    return fig


def _davar_title(result: DavarResult, n_rows: int, n_cols: int) -> str:
    windows = np.asarray(result.window)
    length = (
        f"window {int(windows[0])} samples"
        if windows.size and windows.min() == windows.max()
        else f"windows {int(windows.min())}..{int(windows.max())} samples"
    )
    shown = ""
    if n_rows < windows.size or n_cols < np.size(result.tau):
        shown = f" (drawn: {n_rows} x {n_cols})"
    n_taus = int(np.size(result.tau))
    return (
        f"Dynamic Allan deviation, {length}: {_count(windows.size, 'window')} x "
        f"{_count(n_taus, 'tau')}{shown}"
    )


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def davar_heatmap_figure(
    result: DavarResult,
    *,
    units: str | None = None,
    title: str | None = None,
    max_times: int = 1500,
    max_taus: int = 300,
    cmap: str = "viridis",
    ax: Any = None,
) -> Figure:
    """The dynamic Allan deviation as a colour map over time and tau.

    Parameters
    ----------
    result : DavarResult
        From :func:`adavar.davar`.
    units : str, optional
        Unit of the rate; defaults to ``result.units``. Omitted from the labels if unknown.
    title : str, optional
        Figure title.
    max_times : int
        At most this many windows are drawn, evenly spread over the record.
    max_taus : int
        At most this many taus are drawn, evenly spread in ``log(tau)``.
    cmap : str
        Matplotlib colour map.
    ax : matplotlib.axes.Axes, optional
        Draw the map on these axes (its colour bar takes room from them) instead of a new
        figure.

    Returns
    -------
    matplotlib.figure.Figure
        ``ax``'s figure, or a new one with two axes: the map (time on x, tau on a log y
        axis; ``ax.collections[0]`` is the rasterized ``QuadMesh`` of ``log10`` deviation,
        shape (taus, times), NaN cells masked), and its colour bar labelled
        ``log10(Allan deviation / unit)``.
    """
    unit = units if units is not None else result.units
    tau = np.asarray(result.tau, dtype=float)
    time_ = np.asarray(result.time, dtype=float)
    rows = spread_indices(time_.size, max_times)
    cols = spread_log(tau, max_taus)
    z = _log_dev(result, rows, cols)
    vmin, vmax = colour_limits(z)
    half = 0.5 * float(result.tau0) * max(int(result.step), 1)
    time_edges = cell_edges(time_[rows], False, half)
    tau_edges = cell_edges(tau[cols], True, 0.0)

    fig, ax = figure_axes(ax, (8.0, 5.0))
    mesh = ax.pcolormesh(
        time_edges, tau_edges, np.ma.masked_invalid(z.T), cmap=cmap, vmin=vmin, vmax=vmax,
        shading="flat", rasterized=True,
    )  # fmt: skip
    log_scale(ax, "y")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("tau [s]")
    fig.colorbar(mesh, ax=ax, label=_log_label("Allan deviation", unit))
    ax.set_title(title or _davar_title(result, rows.size, cols.size), fontsize="medium")
    return fig


def coefficient_figure(
    fit: NoiseFit,
    *,
    term: str = "angle_random_walk",
    units: str | None = None,
    truth: float | None = None,
    conventional: bool = True,
    title: str | None = None,
    max_points: int = 4000,
    events: Sequence[Any] = (),
    ax: Any = None,
) -> Figure:
    """One noise coefficient of every DAVAR window over time, with its 1-sigma band.

    Parameters
    ----------
    fit : NoiseFit
        From :func:`adavar.fit_noise` applied to a :class:`DavarResult` (one curve per
        window, ``fit.time`` set).
    term : str
        One of :data:`adavar.core.terms.TERM_NAMES` (default: N, the angle random walk);
        it must be in the fit's model.
    units : str, optional
        Unit of the rate; defaults to ``fit.units``.
    truth : float, optional
        A known value of the coefficient, in the fit's own units (those of
        ``fit.term(term).value``), drawn as a dashed horizontal line.
    conventional : bool
        Draw in the term's conventional unit (deg/sqrt(h), deg/h, ...) when the unit is one
        of :data:`adavar.core.units.RATE_UNITS`; otherwise, or if False, in the fit's own unit
        (:func:`term_unit`).
    title : str, optional
        Figure title.
    max_points : int
        At most this many windows are drawn, evenly spread over time (every k-th window:
        values between them are not drawn, so a feature shorter than ``k`` windows may be
        missed; the coefficient of a window varies on the scale of the window length).
    events : sequence of Event or mapping
        Non-stationary stretches (:func:`adavar.dynamic.events.find_events`), shaded from
        ``start_s`` to ``end_s`` (a line at ``start_s`` if still open).
    ax : matplotlib.axes.Axes, optional
        Draw on these axes (of any figure) instead of a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        ``ax``'s figure, or a new one with one axes: the band ``value ± uncertainty``
        clipped at 0 (``ax.collections[0]``; for a coefficient pinned at 0, from 0 to its
        1-sigma upper bound), the value
        (``ax.get_lines()[0]``; with markers and error bars when at most 50 windows are
        drawn), and the ``truth`` line if given (``ax.get_lines()[1]``). Windows where the
        fit failed (NaN) are gaps.

    Raises
    ------
    ValueError
        If ``fit`` is not a time series of fits, or ``term`` is unknown or not in its model.
    """
    if term not in TERM_NAMES:
        raise ValueError(f"unknown noise term {term!r}; valid names: {', '.join(TERM_NAMES)}")
    if term not in fit.terms:
        raise ValueError(f"{term} is not in the model of this fit (terms: {', '.join(fit.terms)})")
    noise = fit.term(term)
    value = np.asarray(noise.value, dtype=float)
    sigma = np.asarray(noise.uncertainty, dtype=float)
    if fit.time is None or value.ndim != 1:
        raise ValueError(
            "coefficient_figure draws a time series: pass the fit of a DAVAR result, "
            "adavar.fit_noise(adavar.davar(...))"
        )
    unit = units if units is not None else fit.units
    shown_unit = term_unit(term, unit)
    scale = 1.0
    if conventional and unit is not None:
        with contextlib.suppress(ValueError, TypeError):
            target = conventional_units(unit)[term]
            scale = float(convert_coefficient(1.0, term, unit, target))
            shown_unit = target

    rows = spread_indices(value.size, max_points)
    t = np.asarray(fit.time, dtype=float)[rows]
    v = value[rows] * scale
    s = sigma[rows] * scale
    letter, long_name = TERM_LABELS[term]

    fig, ax = figure_axes(ax, (8.0, 4.5))
    ax.fill_between(
        t, np.maximum(v - s, 0.0), v + s, color="C0", alpha=0.3, linewidth=0,
        label="±1 sigma",
    )  # fmt: skip
    few = v.size <= 50  # markers and error bars, or a single window would be invisible
    ax.plot(t, v, "o-" if few else "-", color="C0", linewidth=1.2, markersize=3,
            label=f"{letter}(t), {long_name}")  # fmt: skip
    if few:  # no caps: they would be Line2D objects among ax.get_lines()
        ax.errorbar(t, v, yerr=np.vstack([v - np.maximum(v - s, 0.0), s]), fmt="none",
                    ecolor="C0", elinewidth=1.0, capsize=0)  # fmt: skip
    if truth is not None:
        true_value = float(truth) * scale
        text = f"{true_value:.4g} {shown_unit}" if shown_unit else f"{true_value:.4g}"
        ax.axhline(true_value, color="k", linestyle="--", linewidth=1.1,
                   label=f"true value {text}")  # fmt: skip
    for k, event in enumerate(events):
        start, end = _event_span(event)
        label = "non-stationary stretch" if k == 0 else None
        if end is None:
            ax.axvline(start, color="C3", linewidth=1.2, label=label)
        else:
            ax.axvspan(start, end, color="C3", alpha=0.12, linewidth=0, label=label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"{letter} [{shown_unit}]" if shown_unit else letter)
    ax.grid(True, alpha=0.4)
    ax.legend(fontsize="small", loc="best")
    if title:
        ax.set_title(title)
    return fig


def _event_span(event: Any) -> tuple[float, float | None]:
    if isinstance(event, Mapping):
        return float(event["start_s"]), event["end_s"]
    return float(event.start_s), event.end_s


def save_figure(
    fig: Figure,
    path_without_suffix: str | os.PathLike[str],
    formats: Sequence[str] = DEFAULT_FIGURE_FORMATS,
    *,
    dpi: int = 150,
) -> list[Path]:
    """Write a figure in one or more formats, each file atomically.

    Each file is written under a temporary name in the target folder and moved into place
    with :func:`os.replace`, so a reader never sees a half-written file. PNG files are
    compressed at zlib level :data:`adavar.output._figures.PNG_COMPRESS_LEVEL` (fast).

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
    engine = fig.get_layout_engine()
    # one layout (in inches: every format's), at the raster dpi as savefig would; with no
    # engine (None, not the placeholder "none"; the rc settings held off, else savefig
    # puts one back) savefig skips its draw with rendering disabled: 1/3 of its time
    import matplotlib

    try:
        with matplotlib.rc_context(_NO_AUTO_LAYOUT):
            if engine is not None and formats:
                shown = fig.dpi
                fig.set_dpi(dpi)
                try:
                    engine.execute(fig)
                finally:
                    fig.set_dpi(shown)
                fig.set_layout_engine(None)
            for fmt in formats:
                written.append(_save_one(fig, base, folder, fmt, dpi))
    finally:
        if engine is not None:
            fig.set_layout_engine(engine)
    return written


#: rc settings under which ``Figure.set_layout_engine(None)`` removes the engine
_NO_AUTO_LAYOUT = {"figure.autolayout": False, "figure.constrained_layout.use": False}


def _save_one(fig: Figure, base: Path, folder: Path, fmt: str, dpi: int) -> Path:
    """One format of :func:`save_figure`, written atomically."""
    target = Path(f"{base}.{fmt}")
    # not mkstemp: its 0600 mode would stick to the final file; "x" honours the umask
    tmp_name = partial_name(target)
    try:
        with open(tmp_name, "xb") as handle:
            png = {"pil_kwargs": {"compress_level": PNG_COMPRESS_LEVEL}} if fmt == "png" else {}
            fig.savefig(handle, format=fmt, dpi=dpi, **png)
        os.replace(tmp_name, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp_name)
        raise
    return target


# --------------------------------------------------------------------------------------
# The A-DAVAR paper's figures (adavar.comparison): drawn by adavar.output.paper_figures
# --------------------------------------------------------------------------------------


#: How to draw one figure later (or elsewhere): ``(function, args, keyword args)``
FigureRecipe = tuple[Callable[..., "Figure"], tuple[Any, ...], dict[str, Any]]


def paper_figure_recipes(
    comparison: Comparison | None = None,
    *,
    kurtosis: KurtosisStudy | None = None,
    thresholds: ThresholdStudy | None = None,
    units: str | None = None,
) -> dict[str, FigureRecipe]:
    """The figures of :func:`comparison_figures` by file stem, not yet drawn.

    ``function(*args, **kwargs)`` draws each; the figures can so be drawn one by one, or
    in another process (``adavar demo`` shares them between two). Same parameters as
    :func:`comparison_figures`; without ``comparison``, the study figures only.

    Returns
    -------
    dict
        File stem -> ``(function, args, keyword args)``.
    """
    unit = units if units is not None or comparison is None else comparison.units
    recipes: dict[str, FigureRecipe] = {}
    if kurtosis is not None:
        recipes["fig06_kurtosis_windows"] = (kurtosis_windows_figure, (kurtosis,), {"units": unit})
        recipes["fig07_contribution"] = (contribution_figure, (kurtosis,), {"units": unit})
    if thresholds is not None:
        recipes["fig08_thresholds"] = (threshold_figure, (thresholds,), {})
    if comparison is None:
        return recipes
    runs = list(comparison.methods.values())
    adaptive = comparison.methods.get("a-davar") or next(
        (r for r in runs if r.schedule is not None), None
    )
    if adaptive is not None and adaptive.schedule is not None:
        recipes["fig10_controller"] = (controller_figure, (adaptive.schedule, comparison.time), {
            "change_times": comparison.change_times,
            "title": f"{adaptive.label} controller (paper Fig. 10)"})  # fmt: skip
        recipes["fig11_adavar_surface"] = (davar_surface_figure, (adaptive.result,), {
            "units": unit,
            "title": f"{adaptive.label}: dynamic Allan deviation (paper Fig. 11)"})  # fmt: skip
    recipes["fig12_arw"] = (arw_comparison_figure, (comparison,), {"units": unit})
    return recipes


def study_figures(
    kurtosis: KurtosisStudy | None,
    thresholds: ThresholdStudy | None,
    *,
    units: str | None = None,
) -> dict[str, Figure]:
    """The paper's kurtosis figures (Figs. 6-8) by file stem, those of :func:`comparison_figures`.

    Parameters
    ----------
    kurtosis : KurtosisStudy or None
        ``fig06_kurtosis_windows`` and ``fig07_contribution``.
    thresholds : ThresholdStudy or None
        ``fig08_thresholds``.
    units : str, optional
        Unit of the samples.

    Returns
    -------
    dict
        File stem -> Figure, for the studies given.
    """
    recipes = paper_figure_recipes(kurtosis=kurtosis, thresholds=thresholds, units=units)
    return {stem: draw(*args, **kwargs) for stem, (draw, args, kwargs) in recipes.items()}


def comparison_figures(
    comparison: Comparison,
    *,
    kurtosis: KurtosisStudy | None = None,
    thresholds: ThresholdStudy | None = None,
    units: str | None = None,
) -> dict[str, Figure]:
    """The paper's figures for one :class:`~adavar.comparison.Comparison`, by file stem.

    Parameters
    ----------
    comparison : Comparison
        From :func:`adavar.comparison.compare`.
    kurtosis : KurtosisStudy, optional
        Adds ``fig06_kurtosis_windows`` and ``fig07_contribution``.
    thresholds : ThresholdStudy, optional
        Adds ``fig08_thresholds``.
    units : str, optional
        Unit of the rate samples; defaults to ``comparison.units``.

    Returns
    -------
    dict
        ``{"fig06_kurtosis_windows", "fig07_contribution", "fig08_thresholds",
        "fig10_controller", "fig11_adavar_surface", "fig12_arw"}`` -> Figure, each present
        when its input is (the controller and surface figures need the ``"a-davar"``
        method, or else the first adaptive one).
    """
    recipes = paper_figure_recipes(
        comparison, kurtosis=kurtosis, thresholds=thresholds, units=units
    )
    return {stem: draw(*args, **kwargs) for stem, (draw, args, kwargs) in recipes.items()}

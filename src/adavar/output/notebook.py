"""What the results show in a notebook: a compact HTML table, a small figure, ``.plot()``.

The result classes' ``_repr_html_`` and ``plot`` methods call :func:`html_of` and
:func:`plot_of`; the work is here so the result modules stay plain data. Figures come from
:mod:`adavar.output.plots` (matplotlib, imported on first use); the inline thumbnail is a PNG
embedded in the HTML, so a saved notebook shows it without a kernel.
"""

from __future__ import annotations

import base64
import html
import io
import math
from typing import Any

import numpy as np

__all__ = [
    "deviation_html",
    "deviation_plot",
    "fit_html",
    "fit_plot",
    "html_of",
    "plot_of",
    "surface_html",
    "surface_plot",
]

#: thumbnail size in inches and its resolution
_THUMB = (4.2, 2.8)
_THUMB_DPI = 80


def _fmt(value: Any) -> str:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return html.escape(str(value))
    if not math.isfinite(v):
        return "n/a"
    return f"{v:.4g}"


def _table(rows: list[tuple[str, str]], head: str) -> str:
    body = "".join(
        f"<tr><th style='text-align:left;padding-right:1em'>{html.escape(k)}</th>"
        f"<td style='text-align:left'>{v}</td></tr>"
        for k, v in rows
    )
    caption = f"<caption style='text-align:left'><b>{html.escape(head)}</b></caption>"
    return f"<table>{caption}{body}</table>"


def _thumbnail(fig: Any) -> str:
    """The figure as an inline PNG (closed afterwards: no figure left in pyplot's list)."""
    fig.set_size_inches(*_THUMB)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=_THUMB_DPI)
    data = base64.b64encode(buffer.getvalue()).decode("ascii")
    return f"<img src='data:image/png;base64,{data}' alt='figure'/>"


def _side_by_side(table: str, image: str) -> str:
    return (
        "<div style='display:flex;gap:1.5em;align-items:flex-start;flex-wrap:wrap'>"
        f"<div>{table}</div><div>{image}</div></div>"
    )


def _unit(units: str | None) -> str:
    return f" {html.escape(units)}" if units else ""


def _deviation_rows(result: Any) -> list[tuple[str, str]]:
    tau, dev = np.asarray(result.tau), np.asarray(result.dev)
    rows = [
        ("statistic", html.escape(result.stat)),
        ("samples", f"{int(result.n_samples)} ({result.data_type}, {1 / result.tau0:g} Hz)"),
        ("taus", f"{tau.size}: {_fmt(tau[0])} .. {_fmt(tau[-1])} s" if tau.size else "none"),
    ]
    if dev.size:
        k = int(np.nanargmin(dev)) if np.isfinite(dev).any() else 0
        rows.append(
            ("smallest deviation", f"{_fmt(dev[k])}{_unit(result.units)} at {_fmt(tau[k])} s")
        )
    if math.isfinite(float(result.confidence)):
        rows.append(("intervals", f"{100 * float(result.confidence):.1f} % (chi-square)"))
    rows += [("note", html.escape(n)) for n in result.notes]
    return rows


def _fit_rows(fit: Any) -> list[tuple[str, str]]:
    from adavar.core.units import format_pm, term_unit
    from adavar.output.plots import term_label

    rows = []
    for name in fit.terms:
        letter, label = term_label(name, fit.units)
        term = fit.term(name)
        value = np.asarray(term.value, dtype=float)
        sigma = np.asarray(term.uncertainty, dtype=float)
        if value.ndim:  # a DAVAR stack: the median over the windows
            text = f"median {_fmt(np.nanmedian(value))}{_unit(term_unit(name, fit.units))}"
        else:
            text = html.escape(format_pm(float(value), float(sigma), term_unit(name, fit.units)))
        rows.append((f"{letter} {label}", text))
    return rows


def deviation_html(result: Any) -> str:
    """The notebook view of a :class:`~adavar.core.results.DeviationResult`: its table and
    a small figure of the curve."""
    from adavar.output import plots

    table = _table(_deviation_rows(result), "DeviationResult")
    return _side_by_side(table, _thumbnail(plots.deviation_figure(result)))


def fit_html(fit: Any) -> str:
    """The notebook view of a :class:`~adavar.core.results.NoiseFit`: its coefficients."""
    rows = _fit_rows(fit)
    red = float(np.nanmedian(np.asarray(fit.reduced_chi2, dtype=float)))
    rows.append(("reduced chi2", _fmt(red)))
    rows += [("warning", html.escape(w)) for w in fit.warnings]
    return _table(rows, f"NoiseFit ({fit.method})")


def surface_html(surface: Any) -> str:
    """The notebook view of a :class:`~adavar.core.results.DavarResult` (or an adaptive
    one): its shape and a small heat map."""
    from adavar.output import plots

    time, tau = np.asarray(surface.time), np.asarray(surface.tau)
    window = np.asarray(surface.window)
    rows = [
        ("windows", f"{time.size}, every {surface.step} samples, {_fmt(time[0])} .. "
                    f"{_fmt(time[-1])} s" if time.size else "none"),
        ("window length", f"{int(window.min())} .. {int(window.max())} samples"
                          if window.size else "none"),
        ("taus", f"{tau.size}: {_fmt(tau[0])} .. {_fmt(tau[-1])} s" if tau.size else "none"),
        ("statistic per window", html.escape(str(surface.stat))),
        ("edges", html.escape(surface.edges)),
    ]  # fmt: skip
    rows += [("note", html.escape(n)) for n in surface.notes]
    name = type(surface).__name__
    if time.size and tau.size:
        image = _thumbnail(plots.davar_heatmap_figure(surface, max_times=400, max_taus=100))
        return _side_by_side(_table(rows, name), image)
    return _table(rows, name)


def _drawn(draw: Any, ax: Any, kwargs: dict[str, Any]) -> Any:
    from adavar.output._figures import pyplot_figures

    with pyplot_figures():
        fig = draw(ax=ax, **kwargs)
    return fig.axes[0] if ax is None else ax


def deviation_plot(result: Any, ax: Any = None, **kwargs: Any) -> Any:
    """:func:`adavar.output.plots.deviation_figure` of ``result`` (``fit=`` adds its noise fit);
    the axes drawn on (see :func:`plot_of`)."""
    from adavar.output import plots

    return _drawn(lambda **kw: plots.deviation_figure(result, **kw), ax, kwargs)


def surface_plot(surface: Any, ax: Any = None, **kwargs: Any) -> Any:
    """:func:`adavar.output.plots.davar_heatmap_figure` of ``surface``; the axes drawn on."""
    from adavar.output import plots

    return _drawn(lambda **kw: plots.davar_heatmap_figure(surface, **kw), ax, kwargs)


def fit_plot(fit: Any, ax: Any = None, **kwargs: Any) -> Any:
    """:func:`adavar.output.plots.coefficient_figure` of a DAVAR stack's fit (``term=``); the
    axes drawn on. A whole-record fit is drawn with its curve instead."""
    from adavar.output import plots

    if fit.time is None:
        raise TypeError("a whole-record fit is drawn with its curve: result.plot(fit=fit)")
    return _drawn(lambda **kw: plots.coefficient_figure(fit, **kw), ax, kwargs)


def html_of(obj: Any) -> str:
    """The notebook view of a result: a compact table and, where it helps, a small figure.

    Parameters
    ----------
    obj : DeviationResult, NoiseFit, DavarResult or AdaptiveResult
        The result to show (its ``_repr_html_``: :func:`deviation_html`,
        :func:`fit_html` or :func:`surface_html`).

    Returns
    -------
    str
        HTML (a table next to an inline PNG).
    """
    view = getattr(obj, "_repr_html_", None)
    if view is None:
        raise TypeError(f"no notebook view for {type(obj).__name__}")
    return view()


def plot_of(obj: Any, ax: Any = None, **kwargs: Any) -> Any:
    """The result's standard figure, returning its (first) matplotlib axes.

    Parameters
    ----------
    obj : DeviationResult, NoiseFit, DavarResult or AdaptiveResult
        A deviation curve (with ``fit=`` for its noise fit), a DAVAR surface (heat map) or
        a DAVAR stack's fit (one coefficient over time, ``term=``): its ``plot`` method
        (:func:`deviation_plot`, :func:`surface_plot` or :func:`fit_plot`).
    ax : matplotlib.axes.Axes, optional
        Draw on these axes. Default: a new figure, made by pyplot (``plt.figure()``, the
        current figure: ``plt.savefig`` and ``plt.show`` see it) when the caller has
        imported :mod:`matplotlib.pyplot`, else a plain :class:`~matplotlib.figure.Figure`
        (``ax.figure.savefig``).
    **kwargs
        Passed to :func:`adavar.output.plots.deviation_figure`,
        :func:`~adavar.output.plots.davar_heatmap_figure` or
        :func:`~adavar.output.plots.coefficient_figure`.

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``, or the axes of the new figure (``ax.figure`` is the figure).
    """
    draw = getattr(obj, "plot", None)
    if draw is None:
        raise TypeError(f"no figure for {type(obj).__name__}")
    return draw(ax=ax, **kwargs)

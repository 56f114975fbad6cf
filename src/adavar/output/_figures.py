"""Helpers of the figures (:mod:`adavar.output.plots`, :mod:`adavar.output.report`): matplotlib
set-up (figures, log axes, the PNG writer) and the thinning of what is drawn.

Matplotlib is imported inside the functions, on the first figure (fast CLI start-up).
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import re
import sys
from collections.abc import Iterator
from functools import cache
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: zlib level of the PNG files :func:`adavar.output.plots.save_figure` writes: level 1 encodes a
#: figure 4x faster than the default 6 for files about 6 % larger
PNG_COMPRESS_LEVEL = 1

#: the formats the command line's ``--figures`` accepts (Matplotlib's own backends)
FIGURE_FORMATS = ("png", "svg", "pdf", "eps")

#: the formats a figure is written in unless told otherwise
DEFAULT_FIGURE_FORMATS = ("png", "svg")

_SUPERSCRIPT = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")
# the labels of matplotlib's log formatter: $\mathdefault{10^{-3}}$, $\mathdefault{2\times10^{1}}$
_POWER_LABEL = re.compile(r"\$\\mathdefault\{(?:([0-9.]+)\\times)?10\^\{(-?\d+)\}\}\$")


#: True inside :func:`pyplot_figures`: new figures are pyplot's when the caller uses it
_PYPLOT_FIGURES = contextvars.ContextVar("adavar_pyplot_figures", default=False)


@contextlib.contextmanager
def pyplot_figures() -> Iterator[None]:
    """New figures made within are pyplot figures when :mod:`matplotlib.pyplot` has been
    imported (the results' ``.plot()``: ``plt.savefig`` and ``plt.show`` then see them)."""
    token = _PYPLOT_FIGURES.set(True)
    try:
        yield
    finally:
        _PYPLOT_FIGURES.reset(token)


def new_figure(
    figsize: tuple[float, float] = (7.5, 5.5), layout: str | None = "constrained"
) -> Figure:
    """A figure with an Agg canvas attached (no pyplot state).

    Within :func:`pyplot_figures`, and when the caller has imported
    :mod:`matplotlib.pyplot` (adavar never imports it), ``plt.figure()`` instead: the new
    current figure of pyplot, on its backend.
    """
    plt = sys.modules.get("matplotlib.pyplot") if _PYPLOT_FIGURES.get() else None
    if plt is not None:
        return plt.figure(figsize=figsize, layout=layout)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout=layout)
    FigureCanvasAgg(fig)
    return fig


def figure_axes(
    ax: Any, figsize: tuple[float, float], layout: str | None = "constrained"
) -> tuple[Any, Any]:
    """``(figure, axes)`` to draw on: ``ax`` and its figure when given, else a
    :func:`new_figure` and its one axes."""
    if ax is not None:
        return ax.figure, ax
    fig = new_figure(figsize, layout)
    return fig, fig.add_subplot()


def power_label(label: str) -> str:
    """``"10⁻³"`` for the mathtext ``"$\\mathdefault{10^{-3}}$"`` (others unchanged)."""
    match = _POWER_LABEL.fullmatch(label)
    if match is None:
        return label
    mantissa, exponent = match.groups()
    return f"{mantissa + '×' if mantissa else ''}10{exponent.translate(_SUPERSCRIPT)}"


@cache
def _plain_log_formatter() -> Any:
    from matplotlib.ticker import LogFormatterSciNotation

    class PlainLogFormatter(LogFormatterSciNotation):
        """Matplotlib's log-axis labels as plain Unicode text.

        Each mathtext label costs a parse and a layout per tick and output format (a
        fifth of drawing a deviation figure); the same label in Unicode superscripts
        is drawn as ordinary text.
        """

        def __call__(self, x: float, pos: int | None = None) -> str:
            return power_label(super().__call__(x, pos))

    return PlainLogFormatter


def log_scale(ax: Any, which: str = "xy") -> None:
    """Logarithmic ``x`` and/or ``y`` axes of ``ax``, tick labels as plain text."""
    formatter = _plain_log_formatter()
    for name in which:
        axis = ax.xaxis if name == "x" else ax.yaxis
        (ax.set_xscale if name == "x" else ax.set_yscale)("log")
        # the formatters matplotlib's log scale sets, with the same options
        axis.set_major_formatter(formatter(10.0))
        axis.set_minor_formatter(formatter(10.0, labelOnlyBase=False))


def colour_limits(z: np.ndarray) -> tuple[float, float] | tuple[None, None]:
    """Colour-scale limits of the finite values of ``z`` (None, None if there is none)."""
    finite = z[np.isfinite(z)]
    if finite.size == 0:
        return None, None
    lo, hi = float(finite.min()), float(finite.max())
    return (lo - 0.5, hi + 0.5) if lo == hi else (lo, hi)


def cell_edges(centres: np.ndarray, log: bool, half_width: float) -> np.ndarray:
    """Cell edges around sorted centres (midpoints; geometric midpoints when ``log``)."""
    x = np.log(centres) if log else np.asarray(centres, dtype=float)
    if x.size == 1:
        h = math.log(2.0) / 2 if log else half_width
        edges = np.array([x[0] - h, x[0] + h])
    else:
        mid = 0.5 * (x[1:] + x[:-1])
        edges = np.concatenate([[x[0] - (mid[0] - x[0])], mid, [x[-1] + (x[-1] - mid[-1])]])
    return np.exp(edges) if log else edges


def run_ends(values: np.ndarray, step: bool = False) -> np.ndarray:
    """Indices of the points a piecewise-constant series needs to draw the same shape.

    ``step=True`` (a step plot or fill, ``step="post"``): the first point of every run
    of equal values and the last point. ``step=False`` (a line through the points): the
    first and last point of every run (the points in between lie on the segment joining
    them). A flag or a window length per centre of a long record has a few thousand runs
    among millions of points; the figure then holds those instead of every point.
    """
    v = np.asarray(values)
    n = v.shape[0]
    if n <= 2:
        return np.arange(n)
    change = v[1:] != v[:-1]  # NaN != NaN: every NaN point is kept
    keep = np.ones(n, dtype=bool)
    keep[1:-1] = change[:-1] if step else (change[:-1] | change[1:])
    return np.flatnonzero(keep)


#: a line of more points than four times this is drawn as its envelope (:func:`envelope`)
ENVELOPE_BINS = 4096
#: points :func:`envelope` reads at a time
ENVELOPE_BLOCK = 1 << 16


def envelope(y: Any, bins: int = ENVELOPE_BINS) -> np.ndarray:
    """Indices of the points that draw a long line as it looks.

    The line is cut into ``bins`` runs of consecutive points; each run gives its lowest
    and its highest point, in their order, and the first and last points of the line are
    kept (the axes' limits are then those of the whole line). A run with no finite value
    gives its first point (a NaN: the gap matplotlib leaves). Drawn at a figure's width,
    a few bins a pixel column, it is the line of every point; a line of a 2-hour 200 Hz
    record held 376 MB in matplotlib (Figs. 6 and 7 of ``adavar compare``), its envelope
    a few. Lines of at most ``4 * bins`` points are kept whole (every index).
    """
    v = np.asarray(y, dtype=float)
    n = v.size
    if n <= 4 * bins:
        return np.arange(n)
    width = -(-n // bins)
    bins = -(-n // width)
    # a block of runs at a time: the temporaries (a padded copy, masks) stay at a few
    # hundred kB whatever the line's length, not four copies of it
    per_block = max(1, ENVELOPE_BLOCK // width)
    pairs = [np.zeros(1, dtype=np.int64)]
    for r0 in range(0, bins, per_block):
        r1 = min(bins, r0 + per_block)
        a, b = r0 * width, min(r1 * width, n)
        padded = np.full((r1 - r0) * width, np.nan)
        padded[: b - a] = v[a:b]
        runs = padded.reshape(r1 - r0, width)
        finite = np.isfinite(runs)
        lo = np.where(finite, runs, np.inf).argmin(axis=1)
        hi = np.where(finite, runs, -np.inf).argmax(axis=1)
        empty = ~finite.any(axis=1)
        lo[empty] = hi[empty] = 0  # the run's first point: its NaN is the gap
        start = np.arange(r0, r1) * width
        pairs.append(np.sort(np.stack([lo, hi], axis=1), axis=1).ravel() + np.repeat(start, 2))
    pairs.append(np.array([n - 1], dtype=np.int64))
    return np.unique(np.concatenate(pairs))

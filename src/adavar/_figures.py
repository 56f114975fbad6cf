"""Matplotlib set-up shared by :mod:`adavar.plots`: figures, log axes, the PNG writer.

Matplotlib is imported inside the functions, on the first figure (fast CLI start-up).
"""

from __future__ import annotations

import re
from functools import cache
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: zlib level of the PNG files :func:`adavar.plots.save_figure` writes: level 1 encodes a
#: figure 4x faster than the default 6 for files about 6 % larger
PNG_COMPRESS_LEVEL = 1

_SUPERSCRIPT = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")
# the labels of matplotlib's log formatter: $\mathdefault{10^{-3}}$, $\mathdefault{2\times10^{1}}$
_POWER_LABEL = re.compile(r"\$\\mathdefault\{(?:([0-9.]+)\\times)?10\^\{(-?\d+)\}\}\$")


def new_figure(
    figsize: tuple[float, float] = (7.5, 5.5), layout: str | None = "constrained"
) -> Figure:
    """A figure with an Agg canvas attached (no pyplot state)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout=layout)
    FigureCanvasAgg(fig)
    return fig


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

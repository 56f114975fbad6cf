"""The figures and tables of the HTML report (:mod:`adavar.output.report`).

Each ``*_plot`` function turns a result into a plotly figure as plain JSON-ready dicts
(drawn in the page by a short script, no plotly Python objects); each ``*_table`` into an
HTML table; every user string is escaped here (:func:`escape`) and isolated from the text
around it (:func:`user_text`: a file name with a right-to-left override, U+202E, reversed
the report's title). Large inputs are thinned
before drawing: a DAVAR surface to at most :data:`MAX_SURFACE_TIMES` x
:data:`MAX_SURFACE_TAUS` cells, time series to at most :data:`MAX_SERIES_POINTS` points
(:func:`series_rows`; flags by "any in the bin", window lengths by "shortest in the bin").
"""

from __future__ import annotations

import contextlib
import html as _html
import json
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from adavar.core.terms import TERM_NAMES
from adavar.core.thinning import spread_indices, spread_log
from adavar.core.units import (
    conventional_units,
    convert_coefficient,
    deviation_unit,
    format_pm,
    rate_unit,
    term_unit,
)
from adavar.output.plots import STAT_NAMES, TERM_LABELS, term_label

__all__ = [
    "MAX_SERIES_POINTS",
    "MAX_SURFACE_TAUS",
    "MAX_SURFACE_TIMES",
    "block_fit_of",
    "coefficient_plot",
    "coefficient_table",
    "comparison_plot",
    "comparison_tables",
    "controller_plot",
    "deviation_plot",
    "escape",
    "event_shapes",
    "events_table",
    "mapping_table",
    "notes_html",
    "plain_text",
    "script_json",
    "series_rows",
    "surface_plot",
    "user_text",
    "user_title",
]

#: Most windows (rows) of a DAVAR surface drawn in 3-D.
MAX_SURFACE_TIMES = 300
#: Most taus (columns) of a DAVAR surface drawn in 3-D.
MAX_SURFACE_TAUS = 100
#: Most points of every time series (coefficients, controller panels, N(t) per method).
MAX_SERIES_POINTS = 2000

_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
            "#7f7f7f", "#bcbd22", "#17becf")  # fmt: skip


# --------------------------------------------------------------------------------------
# Escaping and numbers
# --------------------------------------------------------------------------------------


def escape(value: Any) -> str:
    """HTML-escape any value's text (quotes too: safe in text and in attributes)."""
    return _html.escape(str(value), quote=True)


#: The characters that set or change the direction of the text after them (embeddings,
#: overrides, isolates and marks, UAX #9).
_BIDI_CONTROLS = re.compile("[\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069]")
#: First strong isolate and pop directional isolate: the plain-text form of ``<bdi>``.
_FSI, _PDI = "\u2068", "\u2069"


def _isolated(text: str, parts: Iterable[str], start: str, end: str) -> str:
    """``text`` escaped, with every occurrence of each of ``parts`` that holds a direction
    control between ``start`` and ``end`` (a user string inside a composed title, such as
    a file name)."""
    pieces = sorted({p for p in parts if p and _BIDI_CONTROLS.search(p) and p in text},
                    key=len, reverse=True)  # fmt: skip
    if not pieces:
        return escape(text)
    out, pos = [], 0
    for found in re.finditer("|".join(map(re.escape, pieces)), text):
        out += [escape(text[pos : found.start()]), start, escape(found.group()), end]
        pos = found.end()
    return "".join([*out, escape(text[pos:])])


def user_text(value: Any) -> str:
    """A user's text (a file or column name, a unit, a note) for the page: HTML-escaped and
    in ``<bdi>``, so that its direction controls (a right-to-left override, U+202E) and
    right-to-left letters never reorder the text around it."""
    return f"<bdi>{escape(value)}</bdi>"


def user_title(value: Any, parts: Iterable[str] = ()) -> tuple[str, str]:
    """The page's title as (the ``<title>`` element's text, the heading's HTML).

    Both isolate the whole title and, inside it, each of ``parts`` (the file's name, the
    column) that holds a direction control; ``<title>`` takes no markup, so there the
    isolates are the characters FSI and PDI.
    """
    text = str(value)
    parts = [*parts]
    heading = f"<bdi>{_isolated(text, parts, '<bdi>', '</bdi>')}</bdi>"
    return f"{_FSI}{_isolated(text, parts, _FSI, _PDI)}{_PDI}", heading


def script_json(obj: Any) -> str:
    """JSON that is safe inside a ``<script>`` element (no ``<``, ``>``, ``&`` at all)."""
    text = json.dumps(obj, allow_nan=False, separators=(",", ":"), ensure_ascii=False)
    for char, code in (("<", "\\u003c"), (">", "\\u003e"), ("&", "\\u0026"),
                       ("\u2028", "\\u2028"), ("\u2029", "\\u2029")):  # fmt: skip
        text = text.replace(char, code)
    return text


def _num(values: Any, digits: int = 6) -> Any:
    """Floats for JSON, rounded to ``digits`` significant digits; NaN/inf as None (a gap)."""
    arr = np.asarray(values, dtype=float)
    if arr.ndim == 0:
        v = float(arr)
        return float(f"{v:.{digits}g}") if math.isfinite(v) else None
    return (
        [_num(row, digits) for row in arr]
        if arr.ndim > 1
        else [float(f"{v:.{digits}g}") if math.isfinite(v) else None for v in arr.tolist()]
    )


def plain_text(value: Any) -> str:
    """A parameter value as plain text."""
    if isinstance(value, float | np.floating):
        return "NaN" if math.isnan(value) else f"{float(value):.6g}"
    if isinstance(value, Mapping):
        return ", ".join(f"{k}={plain_text(v)}" for k, v in value.items())
    if isinstance(value, list | tuple | np.ndarray):
        return ", ".join(plain_text(v) for v in value)
    return "" if value is None else str(value)


def _unit_label(name: str, unit: str | None) -> str:
    return f"{name} [{unit}]" if unit else name


# --------------------------------------------------------------------------------------
# Thinning
# --------------------------------------------------------------------------------------


def _bins(n: int, most: int) -> np.ndarray | None:
    """Start index of each of at most ``most`` bins over ``n`` points (None: no binning)."""
    if n <= most:
        return None
    return np.unique(np.floor(np.linspace(0.0, n, most, endpoint=False)).astype(np.int64))


def _pool(values: Any, starts: np.ndarray | None, how: str) -> np.ndarray:
    """Reduce ``values`` over the bins starting at ``starts`` (``first``, ``any``, ``min``)."""
    arr = np.asarray(values)
    if starts is None:
        return arr
    if how == "any":
        return np.logical_or.reduceat(arr.astype(bool), starts)
    if how == "min":
        return np.minimum.reduceat(arr, starts)
    return arr[starts]


# --------------------------------------------------------------------------------------
# Figures (plain plotly JSON)
# --------------------------------------------------------------------------------------


def _config() -> dict[str, Any]:
    return {"responsive": True, "displaylogo": False, "showLink": False,
            "showEditInChartStudio": False, "showSendToCloud": False}  # fmt: skip


def _base_layout(height: int) -> dict[str, Any]:
    return {
        "height": height,
        "margin": {"l": 70, "r": 20, "t": 30, "b": 55},
        "hovermode": "closest",
        "legend": {"font": {"size": 11}},
        "template": {"layout": {"plot_bgcolor": "#fafafa"}},
    }


def _stacked_layout(
    heights: Sequence[float], labels: Sequence[str], xlabel: str, height: int
) -> dict[str, Any]:
    """One shared time axis under stacked panels of the given relative heights."""
    layout = _base_layout(height)
    gap = 0.03
    total = float(sum(heights))
    usable = 1.0 - gap * (len(heights) - 1)
    top = 1.0
    for k, (h, label) in enumerate(zip(heights, labels, strict=True)):
        bottom = max(top - usable * h / total, 0.0)
        name = "yaxis" if k == 0 else f"yaxis{k + 1}"
        layout[name] = {"domain": [bottom, top], "anchor": "x",
                        "title": {"text": label, "font": {"size": 11}}}  # fmt: skip
        top = bottom - gap
    layout["xaxis"] = {"anchor": f"y{len(heights)}" if len(heights) > 1 else "y",
                       "title": {"text": xlabel}}  # fmt: skip
    return layout


def _rgba(colour: str, alpha: float) -> str:
    """``#rrggbb`` with an opacity, as ``rgba(...)``."""
    r, g, b = (int(colour[i : i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r},{g},{b},{alpha})"


def _yref(k: int) -> str:
    return "y" if k == 0 else f"y{k + 1}"


def _band_traces(
    t: Any,
    value: np.ndarray,
    sigma: np.ndarray,
    colour: str,
    name: str,
    unit: str | None,
    yaxis: str = "y",
) -> list[dict[str, Any]]:
    """A line with a shaded ±1-sigma band (clipped at 0)."""
    low = np.maximum(value - sigma, 0.0)
    high = value + sigma
    hover_unit = f" {escape(unit)}" if unit else ""
    return [
        {"type": "scatter", "mode": "lines", "x": t, "y": _num(high), "yaxis": yaxis,
         "line": {"width": 0, "color": colour}, "hoverinfo": "skip", "showlegend": False,
         "legendgroup": name},
        {"type": "scatter", "mode": "lines", "x": t, "y": _num(low), "yaxis": yaxis,
         "fill": "tonexty", "fillcolor": _rgba(colour, 0.25), "line": {"width": 0, "color": colour},
         "hoverinfo": "skip", "name": "±1 sigma", "legendgroup": name, "showlegend": False},
        {"type": "scatter", "mode": "lines", "x": t, "y": _num(value), "yaxis": yaxis,
         "name": name, "legendgroup": name, "line": {"width": 1.4, "color": colour},
         "customdata": _num(sigma),
         "hovertemplate": f"t = %{{x:.6g}} s<br>{name} = %{{y:.4g}} ± %{{customdata:.2g}}"
                          f"{hover_unit}<extra></extra>"},
    ]  # fmt: skip


def deviation_plot(deviation: Any, fit: Any, units: str | None) -> dict[str, Any]:
    traces: list[dict[str, Any]] = []
    if deviation is not None:
        unit = rate_unit(deviation.units or units, deviation.data_type)
        stat = deviation.stat
        tau = np.asarray(deviation.tau, dtype=float)
        dev = np.asarray(deviation.dev, dtype=float)
        low = np.asarray(deviation.dev_low, dtype=float)
        high = np.asarray(deviation.dev_high, dtype=float)
        dev_unit = deviation_unit(stat, unit)
        u = f" {escape(dev_unit)}" if dev_unit else ""
        ci = f"{100 * deviation.confidence:.1f} %"
        traces.append({
            "type": "scatter", "mode": "lines+markers", "x": _num(tau), "y": _num(dev),
            "name": f"{escape(stat.upper())} ({ci} confidence)",
            "marker": {"size": 6, "color": _COLOURS[0]}, "line": {"color": _COLOURS[0]},
            "error_y": {"type": "data", "symmetric": False, "array": _num(high - dev),
                        "arrayminus": _num(dev - low), "thickness": 1.2, "width": 3},
            "customdata": [[_num(a), _num(b), _num(c, 3), int(d)] for a, b, c, d in zip(
                low, high, deviation.edf, deviation.n, strict=True)],
            "hovertemplate": ("τ = %{x:.6g} s<br>σ = %{y:.5g}" + u
                              + f"<br>{ci}: [%{{customdata[0]:.4g}}, %{{customdata[1]:.4g}}]"
                              "<br>edf = %{customdata[2]}<br>terms = %{customdata[3]}"
                              "<extra></extra>"),
        })  # fmt: skip
        ylabel = escape(_unit_label(STAT_NAMES.get(stat, stat), dev_unit))
    else:
        unit = fit.units or units
        tau = np.asarray(fit.tau, dtype=float)
        ylabel = escape(_unit_label("Allan deviation", unit))
    if fit is not None:
        used = tau if fit.used is None or not np.any(fit.used) else tau[np.asarray(fit.used)]
        # the model where it was fitted (a roll-off term is no model below that)
        grid = np.geomspace(used.min(), used.max(), 200) if used.size > 1 else used
        excluded = fit.excluded
        if deviation is not None and excluded is not None and np.any(excluded):
            why = [escape(r) for r, e in zip(fit.exclusions, excluded, strict=True) if e]
            traces.append({
                "type": "scatter", "mode": "markers", "x": _num(tau[excluded]),
                "y": _num(dev[excluded]), "name": f"not fitted ({int(excluded.sum())} taus)",
                "marker": {"size": 11, "color": "rgba(0,0,0,0)",
                           "line": {"color": "#777", "width": 1.5}},
                "customdata": why,
                "hovertemplate": "τ = %{x:.6g} s: not fitted<br>%{customdata}<extra></extra>",
            })  # fmt: skip
        red = float(fit.reduced_chi2)
        name = "fitted model" + (f" (reduced χ² = {red:.2f})" if math.isfinite(red) else "")
        traces.append(
            {
                "type": "scatter",
                "mode": "lines",
                "x": _num(grid),
                "y": _num(fit.model_dev(grid)),
                "name": name,
                "line": {"color": "#000", "width": 2},
                "hovertemplate": "τ = %{x:.6g} s<br>model σ = %{y:.5g}<extra></extra>",
            }
        )
        labels = _term_texts(fit, unit)
        coefficients = np.asarray(fit.coefficients)
        for k, term in enumerate(TERM_NAMES):
            if coefficients[k] > 0:
                letter = TERM_LABELS[term][0]
                traces.append({
                    "type": "scatter", "mode": "lines", "x": _num(grid),
                    "y": _num(fit.term_dev(term, grid)), "name": escape(labels[term][0]),
                    "line": {"dash": "dash", "width": 1.3, "color": _COLOURS[k + 1]},
                    "hovertemplate": f"{letter}: τ = %{{x:.6g}} s, σ = %{{y:.4g}}<br>"
                                     f"{escape(labels[term][1])}<extra></extra>",
                })  # fmt: skip
    layout = _base_layout(520)
    layout["xaxis"] = {"type": "log", "title": {"text": "averaging time τ [s]"},
                       "exponentformat": "power"}  # fmt: skip
    layout["yaxis"] = {"type": "log", "title": {"text": ylabel}, "exponentformat": "power"}
    return {"data": traces, "layout": layout, "config": _config()}


def _converted(fit: Any, unit: str | None) -> Any:
    """``fit.to_units`` when the unit is known and convertible, else None."""
    with contextlib.suppress(ValueError, TypeError, KeyError):
        return fit.to_units(None if fit.units is not None else unit)
    return None


def _term_texts(fit: Any, unit: str | None) -> dict[str, tuple[str, str]]:
    """Per term: legend text (conventional units if possible) and data-unit text."""
    converted = _converted(fit, unit)
    out = {}
    for name in TERM_NAMES:
        letter, long_name = term_label(name, unit)
        own = fit.term(name)
        own_text = format_pm(own.value, own.uncertainty, term_unit(name, unit))
        if converted is not None:
            c = converted[name]
            text = format_pm(c.value, c.uncertainty, c.unit)
        else:
            text = own_text
        out[name] = (f"{letter} ({long_name}) = {text}", own_text)
    return out


def surface_plot(surface: Any, units: str | None) -> tuple[dict[str, Any], str, str]:
    """The 3-D surface figure, its caption and the surface's notes (HTML)."""
    drawn = getattr(surface, "drawn", surface)  # a BlockFit holds the drawn rows only
    tau = np.asarray(drawn.tau, dtype=float)
    time = np.asarray(surface.time, dtype=float)
    rows = spread_indices(time.size, MAX_SURFACE_TIMES)
    cols = spread_log(tau, MAX_SURFACE_TAUS)
    if drawn is surface:
        avar = np.asarray(surface.avar, dtype=float)[np.ix_(rows, cols)]
    else:  # the rows' places among those the BlockFit kept
        kept = np.asarray(surface.rows)
        at = np.minimum(np.searchsorted(kept, rows), max(kept.size - 1, 0))
        if kept.size == 0 or not np.array_equal(kept[at], rows):
            raise ValueError(
                f"surface= a BlockFit that kept {kept.size} of {time.size} windows; the "
                f"report draws {rows.size}: fit it with drawn=MAX_SURFACE_TIMES "
                f"({MAX_SURFACE_TIMES})"
            )
        avar = np.asarray(drawn.avar, dtype=float)[np.ix_(at, cols)]
    good = np.isfinite(avar) & (avar > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(good, 0.5 * np.log10(np.where(good, avar, 1.0)), np.nan)
    unit = rate_unit(drawn.units or units, drawn.data_type)
    zlabel = "log10 σ" + (f" [{escape(unit)}]" if unit else "")
    trace = {
        "type": "surface", "x": _num(np.log10(tau[cols]), 5), "y": _num(time[rows], 7),
        "z": _num(z, 4), "colorscale": "Viridis", "connectgaps": False,
        "colorbar": {"title": {"text": "log10 σ"}},
        "hovertemplate": "log10 τ = %{x:.3f}<br>time = %{y:.6g} s<br>log10 σ = %{z:.3f}"
                         "<extra></extra>",
    }  # fmt: skip
    layout = _base_layout(650)
    layout["margin"] = {"l": 0, "r": 0, "t": 20, "b": 0}
    layout["scene"] = {
        "xaxis": {"title": {"text": "log10(τ / s)"}},
        "yaxis": {"title": {"text": "time [s]"}},
        "zaxis": {"title": {"text": zlabel}},
        "camera": {"eye": {"x": 1.6, "y": -1.6, "z": 0.9}},
    }
    caption = (
        f"{rows.size} of {time.size} windows (evenly spread over time) x "
        f"{cols.size} of {tau.size} taus (evenly spread in log τ) drawn; "
        "blank cells: τ beyond a third of the window. Drag to rotate, scroll to zoom."
    )
    return (
        {"data": [trace], "layout": layout, "config": _config()},
        caption,
        notes_html(drawn.notes),
    )


def series_rows(n: int) -> np.ndarray:
    """The points of a series of ``n`` a report's time-series figures draw: the first of
    each of at most :data:`MAX_SERIES_POINTS` bins (all ``n`` when there are no more)."""
    starts = _bins(int(n), MAX_SERIES_POINTS)
    return np.arange(int(n)) if starts is None else starts


#: windows of every window's coefficients read at a time
_SCAN_WINDOWS = 1 << 16


def coefficient_plot(
    fit: Any, units: str | None, every: Any = None
) -> tuple[dict[str, Any], list[str]]:  # fmt: skip
    """The coefficients over time. ``every``: a :class:`~adavar.dynamic.surface_fit.BlockFit`
    whose ``fit`` is ``fit``, kept at the windows :func:`series_rows` draws; its
    coefficients of every window tell which terms are drawn (those above 0 somewhere)."""
    if fit.time is None or np.ndim(fit.coefficients) != 2:
        raise ValueError(
            "coefficients= takes the fit of a DAVAR surface, "
            "adavar.fit_noise(adavar.davar(...)): one fit per window, fit.time set"
        )
    unit = fit.units or units
    time = np.asarray(fit.time, dtype=float)
    starts = _bins(time.size, MAX_SERIES_POINTS)
    t = _num(_pool(time, starts, "first"), 8)

    def positive(name: str) -> bool:  # in some window
        if every is None:
            return bool(np.any(np.asarray(fit.term(name).value) > 0))
        # read by slices: the whole term of a long record is a copy of the samples
        reader = every.term_reader(name)
        return any(bool(np.any(reader[a : a + _SCAN_WINDOWS] > 0))
                   for a in range(0, len(reader), _SCAN_WINDOWS))  # fmt: skip

    terms = [name for name in TERM_NAMES if name in fit.terms and positive(name)]
    traces: list[dict[str, Any]] = []
    labels = []
    for k, name in enumerate(terms):
        letter = TERM_LABELS[name][0]
        term = fit.term(name)
        shown = term_unit(name, unit)
        scale = 1.0
        if unit is not None:
            with contextlib.suppress(ValueError, TypeError, KeyError):
                target = conventional_units(unit)[name]
                scale = float(convert_coefficient(1.0, name, unit, target))
                shown = target
        value = _pool(np.asarray(term.value, dtype=float), starts, "first") * scale
        sigma = _pool(np.asarray(term.uncertainty, dtype=float), starts, "first") * scale
        colour = _COLOURS[TERM_NAMES.index(name)]
        traces += _band_traces(t, value, sigma, colour, f"{letter}(t)", shown, _yref(k))
        labels.append(escape(_unit_label(letter, shown)))
    if not terms:
        return {}, []
    layout = _stacked_layout(
        [1.0] * len(terms), labels, "time (window centre) [s]", 180 + 190 * len(terms)
    )
    names = [f"{TERM_LABELS[n][0]} ({TERM_LABELS[n][1]})" for n in terms]
    return {"data": traces, "layout": layout, "config": _config()}, names


def controller_plot(adaptive: Any) -> dict[str, Any]:
    time = np.asarray(adaptive.time, dtype=float)
    starts = _bins(time.size, MAX_SERIES_POINTS)
    t = _num(_pool(time, starts, "first"), 8)
    p = adaptive.parameters or {}
    paper = p.get("thresholds", "paper") == "paper"
    traces: list[dict[str, Any]] = []
    panels: list[str] = []

    def line(y: Any, name: str, colour: str, k: int, shape: str = "linear") -> None:
        traces.append({"type": "scatter", "mode": "lines", "x": t, "y": y,
                       "name": name, "yaxis": _yref(k),
                       "line": {"color": colour, "width": 1.1, "shape": shape},
                       "hovertemplate": f"t = %{{x:.6g}} s<br>{name} = %{{y:.4g}}"
                                        "<extra></extra>"})  # fmt: skip

    def level(value: Any, name: str, k: int) -> None:
        with contextlib.suppress(TypeError, ValueError):
            v = float(value)
            if math.isfinite(v):
                traces.append({"type": "scatter", "mode": "lines", "x": [t[0], t[-1]],
                               "y": [v, v], "name": escape(f"{name} = {v:g}"),
                               "yaxis": _yref(k), "hoverinfo": "name",
                               "line": {"color": "#000", "dash": "dash", "width": 1}})  # fmt: skip

    used = {} if paper else {n: v[0] for n, v in (p.get("thresholds_used") or {}).items()}
    at = "" if paper else " at Lmax"
    k = 0
    if adaptive.kurtosis is not None:
        line(_num(_pool(adaptive.kurtosis, starts, "first"), 5), "kurtosis", _COLOURS[0], k)
        if paper or used:
            level(p.get("k1") if paper else used.get("k1"), "K1" + at, k)
            level(p.get("k2") if paper else used.get("k2"), "K2" + at, k)
        panels.append("kurtosis")
        k += 1
    if adaptive.s is not None:
        line(_num(_pool(adaptive.s, starts, "first"), 5), "S", _COLOURS[3], k)
        if paper or used:
            level(p.get("s2") if paper else used.get("s2"), "S2" + at, k)
        panels.append("S (last l)")
        k += 1
    for flag, colour in (("f1", _COLOURS[0]), ("f2", _COLOURS[3]), ("f", _COLOURS[2])):
        values = getattr(adaptive, flag, None)
        if values is not None:
            pooled = _pool(values, starts, "any").astype(int).tolist()
            line(pooled, flag, colour, k, shape="hv")
            panels.append(flag)
            k += 1
    window = _pool(np.asarray(adaptive.window, dtype=np.int64), starts, "min")
    line(window.tolist(), "window L", _COLOURS[2], k, shape="hv")
    panels.append("L [samples]")
    heights = [0.5 if name in ("f1", "f2", "f") else 1.5 for name in panels]
    layout = _stacked_layout(heights, panels, "time (window centre) [s]", 760)
    for j, name in enumerate(panels):
        if name in ("f1", "f2", "f"):
            key = "yaxis" if j == 0 else f"yaxis{j + 1}"
            layout[key].update(range=[-0.2, 1.2], tickvals=[0, 1])
    return {"data": traces, "layout": layout, "config": _config()}


def comparison_plot(comparison: Any, units: str | None) -> dict[str, Any]:
    unit = comparison.units or units
    time = np.asarray(comparison.time, dtype=float)
    starts = _bins(time.size, MAX_SERIES_POINTS)
    t = _num(_pool(time, starts, "first"), 8)
    shown = term_unit("angle_random_walk", unit)
    scale = 1.0
    if unit is not None:
        with contextlib.suppress(ValueError, TypeError, KeyError):
            target = conventional_units(unit)["angle_random_walk"]
            scale = float(convert_coefficient(1.0, "angle_random_walk", unit, target))
            shown = target
    traces: list[dict[str, Any]] = []
    hover_unit = f" {escape(shown)}" if shown else ""
    for j, run in enumerate(comparison.methods.values()):
        colour = _COLOURS[j % len(_COLOURS)]
        label = escape(run.label)
        traces.append({"type": "scatter", "mode": "lines", "x": t,
                       "y": _num(_pool(np.asarray(run.arw, dtype=float), starts, "first")
                                 * scale),
                       "name": label, "legendgroup": label,
                       "line": {"color": colour, "width": 1.1},
                       "hovertemplate": f"{label}<br>t = %{{x:.6g}} s<br>N = %{{y:.4g}}"
                                        f"{hover_unit}<extra></extra>"})  # fmt: skip
        traces.append({"type": "scatter", "mode": "lines", "x": t, "yaxis": "y2",
                       "y": _pool(np.asarray(run.window, dtype=np.int64), starts,
                                  "min").tolist(),
                       "name": label, "legendgroup": label, "showlegend": False,
                       "line": {"color": colour, "width": 1.1, "shape": "hv"},
                       "hovertemplate": f"{label}<br>t = %{{x:.6g}} s<br>L = %{{y}}"
                                        "<extra></extra>"})  # fmt: skip
    if comparison.truth is not None:
        truth = _pool(np.asarray(comparison.truth, dtype=float), starts, "first") * scale
        traces.append(
            {
                "type": "scatter",
                "mode": "lines",
                "x": t,
                "y": _num(truth),
                "name": "true N",
                "line": {"color": "#000", "dash": "dash"},
            }
        )
    layout = _stacked_layout(
        [3.0, 1.2],
        [escape(_unit_label("N", shown)), "L [samples]"],
        "time (window centre) [s]",
        620,
    )
    layout["shapes"] = [
        {"type": "line", "xref": "x", "yref": "paper", "x0": c, "x1": c, "y0": 0, "y1": 1,
         "line": {"color": "#888", "dash": "dot", "width": 1}}
        for c in _num(np.asarray(comparison.change_times, dtype=float), 8)
        if c is not None
    ]  # fmt: skip
    return {"data": traces, "layout": layout, "config": _config()}


def event_shapes(events: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Plotly shapes: the non-stationary stretches shaded (a line where one is still open)."""
    return [
        {"type": "rect", "xref": "x", "yref": "paper", "x0": e["start_s"],
         "x1": e["end_s"] if e["end_s"] is not None else None, "y0": 0, "y1": 1,
         "fillcolor": "#d62728", "opacity": 0.12, "line": {"width": 0}, "layer": "below"}
        if e["end_s"] is not None else
        {"type": "line", "xref": "x", "yref": "paper", "x0": e["start_s"],
         "x1": e["start_s"], "y0": 0, "y1": 1, "line": {"color": "#d62728", "width": 1.5}}
        for e in events
    ]  # fmt: skip


def events_table(events: Sequence[Mapping[str, Any]], fit: Any, units: str | None) -> str:
    """HTML table of the non-stationary stretches (``ReportAnalysis.events()["items"]``)."""
    if not events:
        return "<p>No non-stationary stretch: the window never shortened.</p>"
    names = [n for n in (fit.terms if fit is not None else ()) if n in events[0]["before"]]
    head = "".join(f"<th>{escape(TERM_LABELS[n][0])} before / during / after</th>" for n in names)
    rows = []
    for e in events:
        cells = [plain_text(e["start_s"]), "open" if e["end_s"] is None else plain_text(e["end_s"])]
        for n in names:
            parts = [
                "-" if e[k][n]["median"] is None else
                f"{e[k][n]['median']:.4g} [{e[k][n]['low']:.3g}, {e[k][n]['high']:.3g}]"
                for k in ("before", "during", "after")
            ]  # fmt: skip
            cells.append(" / ".join(parts))
        rows.append("<tr>" + "".join(f"<td>{escape(c)}</td>" for c in cells) + "</tr>")
    unit = f" ({escape(units)} units of the fit)" if units else ""
    return (
        f"<table><tr><th>start [s]</th><th>end [s]</th>{head}</tr>{''.join(rows)}</table>"
        f'<p class="caption">Change times estimated from the window; each term: median '
        f"[16 %, 84 %] over the windows wholly before, inside and after the stretch"
        f"{unit}.</p>"
    )


# --------------------------------------------------------------------------------------
# HTML pieces
# --------------------------------------------------------------------------------------


def _table(
    header: Sequence[str], rows: Sequence[Sequence[Any]], numeric: Sequence[bool] | None = None
) -> str:
    """An HTML table; every cell is escaped here."""
    numeric = numeric or [False] * len(header)
    head = "".join(f"<th>{escape(h)}</th>" for h in header)
    body = "".join(
        "<tr>" + "".join(
            f'<td class="num">{escape(c)}</td>' if numeric[i] else f"<td>{user_text(c)}</td>"
            for i, c in enumerate(row)
        ) + "</tr>"
        for row in rows
    )  # fmt: skip
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def notes_html(notes: Sequence[str] | None) -> str:
    if not notes:
        return ""
    items = "".join(f"<li>{user_text(n)}</li>" for n in notes)
    return f'<ul class="notes">{items}</ul>'


def coefficient_table(fit: Any, units: str | None) -> str:
    unit = fit.units or units
    converted = _converted(fit, unit)
    rows = []
    for name in TERM_NAMES:
        letter, long_name = term_label(name, unit)
        term = fit.term(name)
        if name not in fit.terms:
            state = "not in the model"
        elif float(term.value) > 0:
            state = "fitted"
        elif name in fit.dropped:
            state = "not significant, left out (1-sigma upper bound)"
        else:
            state = "pinned at 0 (1-sigma upper bound)"
        row = [
            letter,
            long_name,
            state,
            format_pm(term.value, term.uncertainty, term_unit(name, unit)),
        ]
        if converted is not None:
            c = converted[name]
            row.append(format_pm(c.value, c.uncertainty, c.unit))
        rows.append(row)
    header = ["term", "name", "status", "value ± 1σ (data units)"]
    if converted is not None:
        header.append("value ± 1σ (conventional units)")
    red = float(fit.reduced_chi2)
    summary = (
        f"Fitted ({fit.method}) on {int(fit.n_points)} taus with candidate terms "
        f"{', '.join(fit.terms)}; χ² = {float(fit.chi2):.4g}, dof = {float(fit.dof):.4g}, "
        f"reduced χ² = {red:.3g}; {fit.n_reweight} reweighting passes, spacing "
        f"{fit.spacing!r}."
    )
    for warning in fit.warnings:
        summary += f" Warning: {warning}."
    if unit is None:
        summary += " No unit declared: values in the data's own units."
    elif converted is None:
        summary += f" Unit {unit!r} has no conventional reporting units."
    return _table(header, rows) + f'<p class="caption">{escape(summary)}</p>'


def comparison_tables(comparison: Any) -> str:
    labels = comparison.labels
    names = list(labels)
    rows = comparison.node_rows()
    has_paper = any(row["paper"] for row in rows)
    header = ["change [s]", "node", *[labels[n] for n in names]]
    if has_paper:
        header += [f"paper {labels[n]}" for n in names]
    body = []
    for row in rows:
        cells = [
            plain_text(float(row["change"])),
            row["node"],
            *[plain_text(float(row["values"][n])) for n in names],
        ]
        if has_paper:
            cells += [
                plain_text(float(row["paper"][n])) if n in row["paper"] else "" for n in names
            ]
        body.append(cells)
    numeric = [True, False] + [True] * (len(header) - 2)
    parts = []
    if body:
        parts.append("<h3>Nodes around every change (window-centre times, s)</h3>")
        parts.append(_table(header, body, numeric))
    else:
        parts.append('<p class="caption">No change times given: no node table.</p>')
    intervals = [(a, b) for a, b in comparison.intervals]
    if intervals:
        ih = ["interval [s]", *[labels[n] for n in names]]
        irows = [[f"{plain_text(float(a))} ~ {plain_text(float(b))}",
                  *[plain_text(float(comparison.methods[n].intervals.get((a, b), math.nan)))
                    for n in names]] for a, b in intervals]  # fmt: skip
        parts.append("<h3>Mean N over intervals, ARW(a~b), data units</h3>")
        parts.append(_table(ih, irows, [False] + [True] * len(names)))
    metric_rows = []
    for n in names:
        m = comparison.methods[n].metrics
        if m is not None:
            metric_rows.append(
                [
                    labels[n],
                    plain_text(m.bias),
                    plain_text(m.std),
                    plain_text(m.mad),
                    plain_text(m.error),
                    plain_text(m.abs_delay),
                    plain_text(m.rise),
                ]
            )
    if metric_rows:
        parts.append("<h3>Ground-truth metrics</h3>")
        parts.append(_table(["method", "bias", "std", "mad", "tracking error",
                             "|delay| [s]", "rise [s]"], metric_rows,
                            [False] + [True] * 6))  # fmt: skip
    return "".join(parts)


def mapping_table(mapping: Mapping[str, Any]) -> str:
    return _table(["name", "value"], [[k, plain_text(v)] for k, v in mapping.items()])


def block_fit_of(coefficients: Any, surface: Any) -> Any:
    """The BlockFit whose thinned fit ``coefficients`` is (None: it is a whole fit)."""
    from adavar.dynamic.surface_fit import BlockFit

    if isinstance(surface, BlockFit) and surface.fit is coefficients:
        return surface
    return None

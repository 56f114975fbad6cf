"""One self-contained, interactive HTML report of an analysis.

:func:`build_report` turns the results of an analysis (a deviation curve and its noise fit,
a DAVAR surface, the noise coefficients of every window, an adaptive controller's record, a
method comparison, the parameters and preprocessing used) into one HTML document, and
:func:`write_report` writes it atomically.

The document needs no network: plotly.js (from the ``plotly`` Python package) is embedded
inline once, no file, font or style sheet is referenced, and the figures are plain JSON
drawn by a short inline script. Every string that comes from the user (title, file and
column names, units, parameter values, notes) is HTML-escaped before it reaches the page
and isolated in ``<bdi>`` (its direction controls never reorder the page around it), and
the figure JSON is made safe inside ``<script>`` (``<``, ``>`` and ``&`` written as
``\\u003c`` ...; the text fields plotly renders as pseudo-HTML are HTML-escaped too).

Large inputs are thinned before drawing so the file stays a few MB (plotly.js alone is
about 4.8 MB): a DAVAR surface to at most :data:`MAX_SURFACE_TIMES` windows (evenly spread
over time) x :data:`MAX_SURFACE_TAUS` taus (evenly spread in log tau), the time series to
at most :data:`MAX_SERIES_POINTS` points (flags by "any in the bin", window lengths by
"shortest in the bin", so that a short alarm or a dip of the window still shows).
"""

from __future__ import annotations

import datetime as _dt
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from adavar.core.atomic import atomic_file
from adavar.output.plots import STAT_NAMES
from adavar.output.report_parts import (
    MAX_SERIES_POINTS,
    MAX_SURFACE_TAUS,
    MAX_SURFACE_TIMES,
    block_fit_of,
    coefficient_plot,
    coefficient_table,
    comparison_plot,
    comparison_tables,
    controller_plot,
    deviation_plot,
    escape,
    event_shapes,
    events_table,
    mapping_table,
    notes_html,
    script_json,
    series_rows,
    surface_plot,
    user_text,
    user_title,
)

__all__ = [
    "MAX_SERIES_POINTS",
    "MAX_SURFACE_TAUS",
    "MAX_SURFACE_TIMES",
    "build_report",
    "channel_section",
    "channels_page",
    "series_rows",
    "write_report",
]

_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;
margin:0 auto;max-width:1100px;padding:0 1.2em 2em;color:#222;line-height:1.4}
h1{font-size:1.6em;margin:1em 0 .2em}h2{font-size:1.25em;margin-top:1.8em;
border-bottom:1px solid #ccc;padding-bottom:.2em}
table{border-collapse:collapse;margin:.6em 0;font-size:.92em}
th,td{border:1px solid #ccc;padding:.25em .6em;text-align:left;vertical-align:top}
th{background:#f3f3f3}td.num{text-align:right;font-variant-numeric:tabular-nums}
.plot{width:100%;min-height:300px}.caption{color:#555;font-size:.9em}
.notes{color:#7a4b00;font-size:.9em}footer{margin-top:3em;color:#666;font-size:.85em;
border-top:1px solid #ccc;padding-top:.5em}code{font-size:.95em}
"""

_RENDER_JS = """
(function () {
  var figures = JSON.parse(document.getElementById("adavar-figures").textContent);
  var ids = Object.keys(figures);
  var done = ids.map(function (id) {
    var f = figures[id];
    return Plotly.newPlot(id, f.data, f.layout, f.config);
  });
  Promise.all(done).then(function () {
    document.body.setAttribute("data-adavar-rendered", String(ids.length));
  }, function (err) {
    console.error("adavar report: a plot failed to render: " + err);
  });
})();
"""


# --------------------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------------------


def build_report(
    *,
    title: str,
    source: str | Mapping[str, Any] | None = None,
    deviation: Any = None,
    fit: Any = None,
    surface: Any = None,
    coefficients: Any = None,
    adaptive: Any = None,
    comparison: Any = None,
    parameters: Mapping[str, Any] | None = None,
    preprocessing: Sequence[str] | None = None,
    units: str | None = None,
    events: Sequence[Mapping[str, Any]] | None = None,
) -> str:
    """One self-contained HTML document with interactive plots of an analysis.

    Only the sections whose input is given are written. The document loads nothing: plotly.js
    is embedded inline (once), and every user string is HTML-escaped.

    Parameters
    ----------
    title : str
        Title of the page.
    source : str or mapping, optional
        What was analysed: a file name, or ``{"file": ..., "column": ..., ...}``.
    deviation : DeviationResult, optional
        From :func:`adavar.deviation`: log-log plot with confidence bars (hover shows the
        bounds, edf and number of terms).
    fit : NoiseFit, optional
        A single-curve fit (:func:`adavar.fit_noise` of ``deviation``): the model and every
        non-zero term on the deviation plot, and the coefficient table (data units and,
        when the unit is known, conventional units).
    surface : DavarResult or BlockFit, optional
        From :func:`adavar.davar` (or :func:`adavar.adaptive_davar`): a rotatable 3-D
        surface (log10 tau, time, log10 deviation), thinned to at most
        :data:`MAX_SURFACE_TIMES` x :data:`MAX_SURFACE_TAUS` cells. Or a surface fitted a
        block at a time (:func:`adavar.dynamic.surface_fit.fit_davar_in_blocks` with ``drawn=``
        :data:`MAX_SURFACE_TIMES`): the same figure from the rows it kept.
    coefficients : NoiseFit, optional
        The fit of every DAVAR window (``adavar.fit_noise(surface)``): every term in the
        model that is non-zero somewhere, over time, with its 1-sigma band.
    adaptive : AdaptiveResult, optional
        From :func:`adavar.adaptive_davar`: the controller's kurtosis, S, flags f1, f2, f and
        window length over time.
    comparison : Comparison, optional
        From :func:`adavar.comparison.compare`: N(t) and the window of every method, the node
        table (with the paper's values for its scenarios), the ARW(a~b) intervals and the
        ground-truth metrics when known.
    parameters : mapping, optional
        Settings used (name -> value), shown as a table.
    preprocessing : sequence of str, optional
        Preprocessing steps applied to the data, in order.
    units : str, optional
        Unit of the rate samples, for results that do not carry one.
    events : sequence of mapping, optional
        The non-stationary stretches (``ReportAnalysis.events()["items"]``: ``start_s``,
        ``end_s``, ``before``, ``during``, ``after``), shaded in the coefficient figure and
        listed in an Events section (an empty list: the section says there is none).

    Returns
    -------
    str
        The HTML document.

    Raises
    ------
    ImportError
        If the ``plotly`` package (which ships plotly.js) is missing and a plot is needed.
    ValueError
        If ``fit`` is not a single curve, or ``coefficients`` is not a fit per window.
    """
    from adavar import __version__

    if fit is not None and np.ndim(fit.coefficients) != 1:
        raise ValueError(
            "fit= takes a single-curve NoiseFit; pass the fit of every DAVAR window as "
            "coefficients="
        )
    figures: dict[str, dict[str, Any]] = {}
    sections: list[str] = []

    def plot(key: str, figure: dict[str, Any]) -> str:
        div_id = f"plot-{key}"
        figures[div_id] = figure
        return f'<div class="plot" id="{div_id}"></div>'

    if source is not None:
        if isinstance(source, Mapping):
            body = mapping_table(source)
        else:
            body = f"<p><code>{user_text(source)}</code></p>"
        sections.append(f'<section id="source"><h2>Data</h2>{body}</section>')

    if deviation is not None or fit is not None:
        parts = ['<section id="deviation"><h2>Deviation and noise fit</h2>']
        parts.append(plot("deviation", deviation_plot(deviation, fit, units)))
        if deviation is not None:
            stat = STAT_NAMES.get(deviation.stat, deviation.stat)
            cap = (
                f"{stat} of {deviation.n_samples} samples at {deviation.rate:.6g} Hz "
                f"({deviation.data_type} data), {deviation.tau.size} taus; bars: "
                f"{100 * deviation.confidence:.1f} % confidence interval. Hover for values."
            )
            parts.append(f'<p class="caption">{escape(cap)}</p>{notes_html(deviation.notes)}')
        parts.append("</section>")
        sections.append("".join(parts))

    if fit is not None:
        sections.append('<section id="coefficients-table"><h2>Noise coefficients</h2>'
                        f"{coefficient_table(fit, units)}</section>")  # fmt: skip

    if surface is not None:
        figure, caption, notes = surface_plot(surface, units)
        sections.append(
            '<section id="surface"><h2>Dynamic Allan deviation surface</h2>'
            f'{plot("surface", figure)}<p class="caption">{escape(caption)}</p>'
            f"{notes}</section>"
        )

    if coefficients is not None:
        figure, names = coefficient_plot(coefficients, units, block_fit_of(coefficients, surface))
        if figure and events:
            figure["layout"]["shapes"] = event_shapes(events)
        if figure:
            body = plot("coefficients", figure)
            cap = (
                f"{', '.join(names)} of every window over time; band: ±1σ (clipped at "
                "0; from 0 to the 1-sigma upper bound where a term is pinned at 0)."
            )
        else:
            body, cap = "", "No term is non-zero in any window."
        if events:
            cap += " Shaded: the non-stationary stretches the window detected."
        sections.append(
            '<section id="coefficients-time"><h2>Noise coefficients over time</h2>'
            f'{body}<p class="caption">{escape(cap)}</p></section>'
        )
    if events is not None:
        sections.append(
            '<section id="events"><h2>Events</h2>'
            f"{events_table(events, coefficients, units)}</section>"
        )

    if adaptive is not None:
        method = getattr(adaptive, "method", "adaptive")
        p = adaptive.parameters or {}
        cap = (
            f"{method} controller: kurtosis of every window (K1, K2 band), S of its last "
            f"l samples (S2), the flags f1, f2, f and the window length L "
            f"(Lmax {p.get('lmax')}, Lmin {p.get('lmin')}, l {p.get('l')}, "
            f"thresholds {p.get('thresholds')})."
        )
        sections.append(
            '<section id="adaptive"><h2>Adaptive window controller</h2>'
            f"{plot('adaptive', controller_plot(adaptive))}"
            f'<p class="caption">{escape(cap)}</p>{notes_html(adaptive.notes)}</section>'
        )

    if comparison is not None:
        cap = comparison.description or ""
        sections.append(
            '<section id="comparison"><h2>Method comparison</h2>'
            f'<p class="caption">{escape(cap)}</p>'
            f"{plot('comparison', comparison_plot(comparison, units))}"
            f"{comparison_tables(comparison)}</section>"
        )

    if parameters:
        sections.append('<section id="parameters"><h2>Parameters</h2>'
                        f"{mapping_table(parameters)}</section>")  # fmt: skip

    if preprocessing:
        items = "".join(f"<li>{user_text(step)}</li>" for step in preprocessing)
        sections.append(f'<section id="preprocessing"><h2>Preprocessing</h2><ol>{items}</ol>'
                        "</section>")  # fmt: skip

    scripts: list[str] = []
    plotly_version = ""
    if figures:
        plotly_js, plotly_version = _plotly_js()
        scripts = ["<script>", plotly_js, "</script>\n",
                   '<script type="application/json" id="adavar-figures">',
                   script_json(figures), f"</script>\n<script>{_RENDER_JS}</script>"]  # fmt: skip

    # the file's name and column inside a title composed from them are isolated too
    named = [str(v) for v in (source.values() if isinstance(source, Mapping) else [source])
             if isinstance(v, (str, os.PathLike))]  # fmt: skip
    page_title, heading = user_title(title, [*named, *(Path(v).name for v in named)])
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
    footer = f"Made with adavar {escape(__version__)} on {now}"
    if plotly_version:
        footer += f"; plots by plotly.js {escape(plotly_version)} (embedded)"
    # one join: the page (plotly.js makes it 2 bytes a character) is built once, not
    # copied at every concatenation
    return "".join([
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f'<meta name="generator" content="adavar {escape(__version__)}">\n'
        f"<title>{page_title}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n"
        f"<header><h1>{heading}</h1></header>\n<main>\n",
        "\n".join(sections),
        f"\n</main>\n<footer>{footer}.</footer>\n", *scripts, "\n</body>\n</html>\n",
    ])  # fmt: skip


def channel_section(k: int, name: str, run: Any, figures: dict[str, Any]) -> str:
    """The HTML section of channel number ``k`` of a several-channel report.

    Made of :func:`build_report`'s figure and table builders, with plot ids prefixed by the
    channel's number so that they stay unique (``adavar report --column a,b,c``).

    Parameters
    ----------
    k : int
        The channel's number (from 1).
    name : str
        The channel's name.
    run : ChannelAnalysis
        Its analysis (:func:`adavar.pipeline.analysis.analyse_channel`) with ``events`` (or None).
    figures : dict
        Plot id -> figure; this channel's plots are added.

    Returns
    -------
    str
        The section's HTML.
    """

    def plot(key: str, figure: dict[str, Any]) -> str:
        figures[key] = figure
        return f'<div class="plot" id="{key}"></div>'

    units, dev, fit = run.rate_units, run.result, run.fit
    stat = STAT_NAMES.get(dev.stat, dev.stat)
    cap = (
        f"{stat} of {dev.n_samples} samples at {dev.rate:.6g} Hz ({dev.data_type} data), "
        f"{dev.tau.size} taus; bars: {100 * dev.confidence:.1f} % confidence interval. "
        "Hover for values."
    )
    parts = [
        f'<section id="channel-{k}" class="channel"><h2>Channel {user_text(name)} '
        f"({user_text(run.units)})</h2>",
        "<h3>Deviation and noise fit</h3>",
        plot(f"plot-{k}-deviation", deviation_plot(dev, fit, units)),
        f'<p class="caption">{escape(cap)}</p>{notes_html(dev.notes)}',
        f"<h3>Noise coefficients</h3>{coefficient_table(fit, units)}",
    ]
    surface = run.surface
    if surface is not None:
        figure, caption, notes = surface_plot(surface, units)
        parts += [
            "<h3>Dynamic Allan deviation surface</h3>",
            plot(f"plot-{k}-surface", figure),
            f'<p class="caption">{escape(caption)}</p>{notes}',
        ]
        figure, terms = coefficient_plot(
            run.coefficients, units, block_fit_of(run.coefficients, surface)
        )  # fmt: skip
        events = (run.events or {}).get("items")
        if figure and events:
            figure["layout"]["shapes"] = event_shapes(events)
        parts.append("<h3>Noise coefficients over time</h3>")
        if figure:
            parts.append(plot(f"plot-{k}-coefficients", figure))
            cap = (
                f"{', '.join(terms)} of every window over time; band: ±1σ (clipped at "
                "0; from 0 to the 1-sigma upper bound where a term is pinned at 0)."
            )
        else:
            cap = "No term is non-zero in any window."
        parts.append(f'<p class="caption">{escape(cap)}</p>')
        if events is not None:
            parts.append("<h3>Events</h3>"
                         + events_table(events, run.coefficients, units))  # fmt: skip
    if run.adaptive is not None:
        parts += [
            "<h3>Adaptive window controller</h3>",
            plot(f"plot-{k}-adaptive", controller_plot(run.adaptive)),
        ]
    parts.append("</section>")
    return "".join(parts)


def channels_page(
    *, title: str, source: dict[str, Any], sections: list[str], figures: dict[str, Any],
    parameters: dict[str, Any], preprocessing: list[str],
) -> str:  # fmt: skip
    """One HTML report with a section per channel (:func:`channel_section`).

    The page (head, data, parameters, preprocessing, footer) is :func:`build_report`'s.

    Parameters
    ----------
    title : str
        Title of the page.
    source : dict
        What was analysed (file, columns, format, samples).
    sections : list of str
        The channels' sections, in order.
    figures : dict
        Plot id -> figure of every section.
    parameters : dict
        The parameter table.
    preprocessing : list of str
        The preprocessing steps, in order.

    Returns
    -------
    str
        The document.
    """
    page = build_report(title=title, source=source, parameters=parameters,
                           preprocessing=preprocessing)  # fmt: skip
    plotly_js, plotly_version = _plotly_js()
    scripts = (
        f"<script>{plotly_js}</script>\n"
        f'<script type="application/json" id="adavar-figures">'
        f"{script_json(figures)}</script>\n<script>{_RENDER_JS}</script>\n"
    )
    # after the data section (or at the top of <main>), before the parameters
    anchor = '<section id="parameters">' if parameters else "\n</main>"
    page = page.replace(anchor, "\n".join(sections) + "\n" + anchor, 1)
    page = page.replace(
        ".</footer>", f"; plots by plotly.js {escape(plotly_version)} (embedded).</footer>", 1
    )
    return page.replace("\n</body>", "\n" + scripts + "</body>", 1)  # fmt: skip


def _plotly_js() -> tuple[str, str]:
    """The plotly.js bundle shipped with the ``plotly`` package, and its version."""
    try:
        from plotly.offline import get_plotlyjs, get_plotlyjs_version
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError(
            "the HTML report embeds plotly.js from the plotly package: pip install plotly"
        ) from None
    js = get_plotlyjs()
    # a search without a lower-case copy: the bundle is not ASCII, and str.lower of its
    # 4.8 M characters peaks at 77 MB
    if re.search("</script", js, re.IGNORECASE) or "<!--" in js:  # pragma: no cover
        raise RuntimeError("this plotly.js bundle cannot be embedded in a <script> element")
    return js, get_plotlyjs_version()


def write_report(path: str | os.PathLike[str], html: str) -> Path:
    """Write a report atomically (a temporary file in the same folder, then ``os.replace``).

    Parameters
    ----------
    path : str or path-like
        Destination; its folder must exist.
    html : str
        The document, from :func:`build_report`.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    if not isinstance(html, str):
        raise TypeError(f"html must be a str, got {type(html).__name__}")
    target = Path(path)
    with atomic_file(target) as handle:
        handle.write(html.encode("utf-8"))
    return target

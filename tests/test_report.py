"""The self-contained HTML report: sections, escaping, no network, size, and a real browser."""

from __future__ import annotations

import html
import json
import os
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

import adavar
from adavar.core.results import DavarResult
from adavar.output.report import MAX_SURFACE_TAUS, MAX_SURFACE_TIMES, build_report, write_report

pytest.importorskip("plotly", reason="the report embeds plotly.js from the plotly package")

EVIL_FILE = "<script>alert(1)</script>.csv"
EVIL_COLUMN = '"><img src=x onerror=alert(1)>'
EVIL_UNIT = "<b>u</b></script><!--"
EVIL_TITLE = "Report </script><script>alert('t')</script> & co"

SECTION_IDS = (
    "source", "deviation", "coefficients-table", "surface", "coefficients-time", "adaptive",
    "comparison", "parameters", "preprocessing",
)  # fmt: skip
PLOT_IDS = ("plot-deviation", "plot-surface", "plot-coefficients", "plot-adaptive",
            "plot-comparison")  # fmt: skip


@pytest.fixture(scope="module")
def results() -> dict:
    rng = np.random.default_rng(3)
    x = rng.normal(size=3000) * np.r_[np.ones(1500), 2.0 * np.ones(1500)]
    dev = adavar.deviation(x, rate=10.0, units="deg/s")
    fit = adavar.fit_noise(dev)
    adaptive = adavar.adaptive_davar(x, rate=10.0, units="deg/s", taus="octave")
    coefficients = adavar.fit_noise(adaptive)
    comparison = adavar.compare(
        x, rate=10.0, change_times=[150.0], units="deg/s", taus="octave",
        description=f"record from {EVIL_FILE}",
    )  # fmt: skip
    return {"deviation": dev, "fit": fit, "surface": adaptive, "coefficients": coefficients,
            "adaptive": adaptive, "comparison": comparison}  # fmt: skip


def full_report(results: dict) -> str:
    return build_report(
        title=EVIL_TITLE,
        source={"file": EVIL_FILE, "column": EVIL_COLUMN, "samples": 3000},
        parameters={"window": 600, EVIL_COLUMN: EVIL_FILE, "taus": [1.0, 2.0]},
        preprocessing=[f"dropped column {EVIL_COLUMN}", "removed the mean"],
        **results,
    )


@pytest.fixture(scope="module")
def report(results: dict) -> str:
    return full_report(results)


class _Collector(HTMLParser):
    """Every start tag with its attributes, and the text outside <script>/<style>."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tags: list[tuple[str, dict[str, str | None]]] = []
        self.scripts: list[str] = []
        self.text: list[str] = []
        self._in: str | None = None

    def handle_starttag(self, tag: str, attrs: list) -> None:
        self.tags.append((tag, dict(attrs)))
        if tag in ("script", "style"):
            self._in = tag
            if tag == "script":
                self.scripts.append("")

    def handle_endtag(self, tag: str) -> None:
        if tag == self._in:
            self._in = None

    def handle_data(self, data: str) -> None:
        if self._in == "script":
            self.scripts[-1] += data
        elif self._in is None:
            self.text.append(data)


def parse(document: str) -> _Collector:
    collector = _Collector()
    collector.feed(document)
    collector.close()
    return collector


def figures_of(document: str) -> dict:
    match = re.search(
        r'<script type="application/json" id="adavar-figures">(.*?)</script>', document, re.S
    )
    assert match is not None
    return json.loads(match.group(1))


# --------------------------------------------------------------------------------------
# structure
# --------------------------------------------------------------------------------------


def test_all_sections_and_plots_present(report: str) -> None:
    assert report.startswith("<!DOCTYPE html>")
    for section in SECTION_IDS:
        assert f'<section id="{section}">' in report
    for plot in PLOT_IDS:
        assert f'<div class="plot" id="{plot}"></div>' in report
    assert set(figures_of(report)) == set(PLOT_IDS)
    assert report.count("plotly.js v") == 1  # the bundle, embedded once
    assert f"adavar {adavar.__version__}" in report
    assert re.search(r"on \d{4}-\d\d-\d\d \d\d:\d\d:\d\d UTC", report)
    # coefficient table in data units and in conventional units
    assert "deg/sqrt(h)" in report and "deg/sqrt(s)" in report
    assert "(conventional units)" in report
    # node table of the comparison
    assert "Nodes around every change" in report and "A-DAVAR" in report


def test_sections_only_for_given_inputs(results: dict) -> None:
    doc = build_report(title="only the curve", deviation=results["deviation"])
    assert '<section id="deviation">' in doc
    for section in SECTION_IDS:
        if section != "deviation":
            assert f'<section id="{section}">' not in doc
    assert set(figures_of(doc)) == {"plot-deviation"}

    doc = build_report(title="fit only", fit=results["fit"])
    assert '<section id="deviation">' in doc and '<section id="coefficients-table">' in doc

    doc = build_report(title="no plots", parameters={"a": 1}, preprocessing=["x"])
    assert '<section id="parameters">' in doc and '<section id="preprocessing">' in doc
    assert "<script" not in doc  # nothing to draw: plotly.js is not embedded
    assert len(doc) < 10_000


def test_comparison_with_truth_and_paper_nodes() -> None:
    comparison = adavar.compare(adavar.simulate.paper_scenario(1), taus="octave")
    doc = build_report(title="scenario 1", comparison=comparison)
    assert "Ground-truth metrics" in doc and "paper A-DAVAR" in doc and "true N" in doc
    assert set(figures_of(doc)) == {"plot-comparison"}


def test_rejects_wrong_fit_shapes(results: dict) -> None:
    with pytest.raises(ValueError, match="single-curve"):
        build_report(title="t", fit=results["coefficients"])
    with pytest.raises(ValueError, match="one fit per window"):
        build_report(title="t", coefficients=results["fit"])


def test_surface_is_thinned_and_file_stays_small() -> None:
    n_time, n_tau = 5000, 400
    m = np.unique(np.geomspace(1, 2000, n_tau).astype(np.int64))
    avar = np.tile(1.0 / m.astype(float), (n_time, 1))
    avar[:, -5:] = np.nan  # undefined cells become gaps
    surface = DavarResult(
        time=np.arange(n_time, dtype=float), tau=m.astype(float), avar=avar,
        window=np.full(n_time, 6000), centre=np.arange(n_time), m=m,
        alpha=np.zeros(m.size, dtype=np.int64), tau0=1.0, data_type="rate", edges="mirror",
        step=1, confidence=float("nan"), n_samples=n_time, units="deg/s",
    )  # fmt: skip
    doc = build_report(title="big", surface=surface)
    trace = figures_of(doc)["plot-surface"]["data"][0]
    z = trace["z"]
    assert len(z) <= MAX_SURFACE_TIMES and len(trace["y"]) == len(z)
    assert len(z[0]) <= MAX_SURFACE_TAUS and len(trace["x"]) == len(z[0])
    assert z[0][-1] is None and z[0][0] == pytest.approx(0.0)
    assert len(doc.encode()) < 6_000_000


def test_typical_report_size(report: str) -> None:
    size = len(report.encode())
    assert 4_000_000 < size < 7_000_000  # plotly.js is about 4.8 MB of it


# --------------------------------------------------------------------------------------
# escaping
# --------------------------------------------------------------------------------------


def test_user_strings_are_escaped(report: str) -> None:
    for raw in (EVIL_FILE, EVIL_COLUMN, EVIL_TITLE, "<img", "alert('t')</script>"):
        assert raw not in report
    assert html.escape(EVIL_FILE) in report
    assert html.escape(EVIL_COLUMN) in report
    parsed = parse(report)
    tags = [tag for tag, _ in parsed.tags]
    assert "img" not in tags
    assert tags.count("script") == 3  # plotly.js, the figures' JSON, the drawing code
    assert not any(k.startswith("on") for _, attrs in parsed.tags for k in attrs)
    text = "".join(parsed.text)
    assert EVIL_FILE in text and EVIL_COLUMN in text and EVIL_TITLE in text  # shown as text


RLO = "\u202e"  # right-to-left override: the text after it is shown reversed


def test_user_text_is_isolated_in_bdi(report: str) -> None:
    """A file name with U+202E reversed the report's title (issue 40): every user string
    is in a <bdi> (still escaped), and a file name inside a composed title in its own."""
    assert f"<h1><bdi>{html.escape(EVIL_TITLE)}</bdi></h1>" in report
    assert f"<td><bdi>{html.escape(EVIL_FILE)}</bdi></td>" in report
    assert f"<li><bdi>dropped column {html.escape(EVIL_COLUMN)}</bdi></li>" in report
    name = f"gyro{RLO}v.csv"
    doc = build_report(title=f"{name}, column gx", source={"file": f"/data/{name}",
                                                           "column": "gx"})  # fmt: skip
    assert f"<h1><bdi><bdi>{name}</bdi>, column gx</bdi></h1>" in doc
    assert f"<title>\u2068\u2068{name}\u2069, column gx\u2069</title>" in doc
    assert f"<td><bdi>/data/{name}</bdi></td>" in doc
    plain = build_report(title="a plain title", source="/data/plain.csv")
    assert "<h1><bdi>a plain title</bdi></h1>" in plain
    assert "<code><bdi>/data/plain.csv</bdi></code>" in plain


def test_strings_inside_script_are_safe(results: dict) -> None:
    dev = adavar.deviation(np.random.default_rng(0).normal(size=2000))  # no unit declared
    doc = build_report(title="units", deviation=dev, fit=adavar.fit_noise(dev), units=EVIL_UNIT)
    match = re.search(
        r'<script type="application/json" id="adavar-figures">(.*?)</script>', doc, re.S
    )
    assert match is not None
    blob = match.group(1)
    assert "<" not in blob and ">" not in blob and "&" not in blob
    layout = json.loads(blob)["plot-deviation"]["layout"]
    # plotly renders labels as pseudo-HTML: the unit is entity-escaped, shown literally
    assert html.escape(EVIL_UNIT) in layout["yaxis"]["title"]["text"]
    assert "</script" not in doc.split('id="adavar-figures">')[1].split("</script>")[0]
    assert EVIL_UNIT not in doc


# --------------------------------------------------------------------------------------
# no network
# --------------------------------------------------------------------------------------

_URL_ATTRS = {"src", "href", "action", "data", "poster", "srcset", "xlink:href", "formaction",
              "background", "manifest", "ping"}  # fmt: skip


def test_no_network_references(report: str) -> None:
    parsed = parse(report)
    tags = [tag for tag, _ in parsed.tags]
    for tag in ("link", "iframe", "object", "embed", "base", "img", "audio", "video"):
        assert tag not in tags
    for _tag, attrs in parsed.tags:
        for name, value in attrs.items():
            if name in _URL_ATTRS:
                pytest.fail(f"the report references {name}={value!r}")
    assert all(attrs.get("src") is None for tag, attrs in parsed.tags if tag == "script")
    # outside the embedded plotly.js no URL at all (not even a plain-text link)
    outside = re.sub(r"<script>.*?</script>", "", report, flags=re.S)
    assert "http://" not in outside and "https://" not in outside
    assert "url(" not in outside and "@import" not in outside
    # the figures load nothing either (no images, no map tiles, no mathjax)
    blob = json.dumps(figures_of(report))
    assert "http" not in blob


# --------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------


def test_write_report_atomic(tmp_path: Path) -> None:
    target = tmp_path / "report.html"
    assert write_report(target, "<p>one</p>") == target
    assert target.read_text(encoding="utf-8") == "<p>one</p>"
    assert target.stat().st_mode & 0o777 == 0o644
    write_report(str(target), "<p>two ±</p>")
    assert target.read_text(encoding="utf-8") == "<p>two ±</p>"
    with pytest.raises(TypeError):
        write_report(target, 42)  # type: ignore[arg-type]
    assert target.read_text(encoding="utf-8") == "<p>two ±</p>"  # untouched
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.html"]  # no temp file left


# --------------------------------------------------------------------------------------
# a real browser
# --------------------------------------------------------------------------------------

# Injected at the top of <head> of a copy of the report: records console.error/warn,
# uncaught errors, unhandled rejections, failed resource loads and every resource fetched
# into an attribute that --dump-dom prints (this Chromium logs every console level as
# INFO:CONSOLE, so stderr alone cannot tell an error from a warning).
_PROBE = """<script>
(function () {
  var log = [];
  function put() {
    document.documentElement.setAttribute("data-probe-log", JSON.stringify(log));
  }
  ["error", "warn"].forEach(function (level) {
    var original = console[level];
    console[level] = function () {
      log.push(level + ": " + Array.prototype.map.call(arguments, String).join(" "));
      put();
      return original.apply(console, arguments);
    };
  });
  window.addEventListener("error", function (e) {
    var t = e.target;
    log.push(t && t !== window ? "resource: " + (t.src || t.href) : "uncaught: " + e.message);
    put();
  }, true);
  window.addEventListener("unhandledrejection", function (e) {
    log.push("rejection: " + e.reason);
    put();
  });
  new PerformanceObserver(function (list) {
    list.getEntries().forEach(function (entry) { log.push("fetch: " + entry.name); });
    put();
  }).observe({type: "resource", buffered: true});
  put();
})();
</script>"""


def _browser() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


def chromium_command(browser: str, page: Path, profile: Path, webgl: bool = True) -> list[str]:
    # software WebGL for the 3-D surface (a trusted page); SwiftShader compiles the shaders
    # of every WebGL context anew, about 1.3 s of wall time (2.5 s of CPU) per surface
    gl = "--enable-unsafe-swiftshader" if webgl else "--disable-webgl"
    return [
        browser, "--headless", "--no-sandbox", "--disable-gpu", gl,
        "--disable-dev-shm-usage", f"--user-data-dir={profile}",
        "--host-resolver-rules=MAP * ~NOTFOUND",  # any network access would fail loudly
        "--virtual-time-budget=10000", "--enable-logging=stderr", "--v=0",
        "--dump-dom", page.as_uri(),
    ]  # fmt: skip


def _run_chromium(
    browser: str, page: Path, folder: Path, profile: str, *, timeout: float, webgl: bool = True
) -> subprocess.CompletedProcess:
    """Headless ``browser`` on ``page`` (its profile and HOME in ``folder``)."""
    return subprocess.run(
        chromium_command(browser, page, folder / profile, webgl),
        capture_output=True, text=True, timeout=timeout, check=False,
        env={**os.environ, "HOME": str(folder)},
    )  # fmt: skip


#: Problem starting each browser (None: it starts), checked once per test session.
_START_PROBLEMS: dict[str, str | None] = {}


def _start_problem(browser: str, folder: Path) -> str | None:
    """Why ``browser`` cannot render a trivial page headless, or None if it can."""
    if browser not in _START_PROBLEMS:
        page = folder / "start.html"
        page.write_text('<!DOCTYPE html><p id="adavar-start">ok</p>\n', encoding="utf-8")
        try:
            run = _run_chromium(browser, page, folder, "start-profile", timeout=60)
        except (OSError, subprocess.TimeoutExpired) as exc:
            problem: str | None = f"{type(exc).__name__}: {exc}"
        else:
            problem = None
            if run.returncode != 0 or 'id="adavar-start"' not in run.stdout:
                problem = f"exit code {run.returncode}: {run.stderr.strip()[-500:]}"
        _START_PROBLEMS[browser] = problem
    return _START_PROBLEMS[browser]


def chromium_or_skip(folder: Path) -> str:
    """A headless Chromium that starts, else skip; with ``ADAVAR_REQUIRE_CHROMIUM=1`` (set by
    ``.ci/run`` once it has installed one) fail instead, so CI proves the report renders."""
    required = os.environ.get("ADAVAR_REQUIRE_CHROMIUM", "").strip() not in ("", "0")
    folder.mkdir(parents=True, exist_ok=True)
    browser = _browser()
    if browser is None:
        reason = ("no chromium / chromium-browser / google-chrome on PATH (Debian: apt-get "
                  "install -y chromium)")  # fmt: skip
    else:
        problem = _start_problem(browser, folder)
        if problem is None:
            return browser
        reason = f"{browser} does not start headless: {problem}"
    if required:
        pytest.fail(f"ADAVAR_REQUIRE_CHROMIUM=1, but {reason}", pytrace=False)
    pytest.skip(reason)


def render_in_chromium(document: str, folder: Path, n_plots: int, *, webgl: bool = True) -> str:
    """The DOM of ``document`` after headless Chromium ran it, checked: all ``n_plots``
    plots drawn, nothing logged to the console as an error or warning, nothing fetched.

    ``webgl=False`` runs the browser without WebGL: a 3-D plot then holds plotly's
    "WebGL is not supported" notice instead of its scene (and counts as drawn)."""
    browser = _browser()
    if browser is None:
        chromium_or_skip(folder)  # skips, or fails when a browser is required
    folder.mkdir(parents=True, exist_ok=True)
    page = folder / "report.html"
    head = document.index("<head>") + len("<head>")
    write_report(page, document[:head] + _PROBE + document[head:])
    try:
        run = _run_chromium(browser, page, folder, "profile", timeout=120, webgl=webgl)
    except (OSError, subprocess.TimeoutExpired):
        chromium_or_skip(folder)  # a browser that does not start at all: skip (or fail)
        raise  # it starts: this page hung it
    dom = run.stdout
    if run.returncode != 0 or "data-adavar-rendered" not in dom:
        # whether the browser starts at all is asked only now (a second launch): a browser
        # that cannot render a trivial page skips (or fails, when required); else the
        # report is at fault and the assertions below fail
        chromium_or_skip(folder)
    assert run.returncode == 0, run.stderr[-3000:]
    assert f'data-adavar-rendered="{n_plots}"' in dom, run.stderr[-3000:]

    probe = re.search(r'data-probe-log="([^"]*)"', dom)
    assert probe is not None
    assert json.loads(html.unescape(probe.group(1))) == []  # no error, warning or fetch
    console = [line for line in run.stderr.splitlines() if "CONSOLE" in line]
    bad = [line for line in console if "Uncaught" in line or "ERROR:CONSOLE" in line]
    assert not bad, "\n".join(bad)
    return dom


def test_missing_chromium_skips_or_fails_when_required(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.setattr(f"{__name__}._browser", lambda: None)
    monkeypatch.delenv("ADAVAR_REQUIRE_CHROMIUM", raising=False)
    with pytest.raises(pytest.skip.Exception, match="no chromium"):
        chromium_or_skip(tmp_path)
    monkeypatch.setenv("ADAVAR_REQUIRE_CHROMIUM", "0")
    with pytest.raises(pytest.skip.Exception):
        chromium_or_skip(tmp_path)
    monkeypatch.setenv("ADAVAR_REQUIRE_CHROMIUM", "1")
    with pytest.raises(pytest.fail.Exception, match="ADAVAR_REQUIRE_CHROMIUM=1, but no chromium"):
        chromium_or_skip(tmp_path)
    # a browser that is there but does not start (a broken wrapper script)
    broken = tmp_path / "chromium"
    broken.write_text("#!/bin/sh\necho 'cannot open display' >&2\nexit 1\n")
    broken.chmod(0o755)
    monkeypatch.setattr(f"{__name__}._browser", lambda: str(broken))
    with pytest.raises(pytest.fail.Exception, match=r"does not start headless.*cannot open"):
        chromium_or_skip(tmp_path)
    monkeypatch.delenv("ADAVAR_REQUIRE_CHROMIUM")
    with pytest.raises(pytest.skip.Exception, match="does not start headless"):
        chromium_or_skip(tmp_path)
    # rendering asks whether the browser starts only once the page failed: the same verdict
    page = "<!DOCTYPE html><html><head></head><body></body></html>"
    with pytest.raises(pytest.skip.Exception, match=r"does not start headless.*cannot open"):
        render_in_chromium(page, tmp_path / "render", 1)
    monkeypatch.setenv("ADAVAR_REQUIRE_CHROMIUM", "1")
    with pytest.raises(pytest.fail.Exception, match=r"does not start headless.*cannot open"):
        render_in_chromium(page, tmp_path / "render", 1)


def test_report_renders_in_chromium(report: str, tmp_path: Path) -> None:
    dom = render_in_chromium(report, tmp_path, len(PLOT_IDS))

    # every plot div holds plotly's drawing: SVG for 2-D plots, a WebGL scene for the surface
    for plot in PLOT_IDS:
        start = dom.index(f'id="{plot}"')
        chunk = dom[start : dom.index("</section>", start)]
        assert "main-svg" in chunk, plot
        if plot == "plot-surface":
            assert "gl-container" in chunk and "<canvas" in chunk
            assert "WebGL is not supported" not in chunk
    # the hostile strings are text in the rendered page, never elements
    parsed = parse(dom)
    assert "img" not in [tag for tag, _ in parsed.tags]
    assert EVIL_FILE in "".join(parsed.text)


def test_coefficients_of_a_block_fit_draw_the_same_figure(monkeypatch) -> None:
    """A surface fitted a block at a time keeps the whole fit of the windows the figure
    draws: the same figure as the fit of every window, including a term that is above 0
    only in windows the figure does not draw (it still gets its panel; every window's
    values are read by slices, here of 64 windows)."""
    import dataclasses

    from adavar.output import report, report_parts

    monkeypatch.setattr(report_parts, "_SCAN_WINDOWS", 64)
    from adavar.dynamic.surface_fit import fit_davar_in_blocks

    x = adavar.simulate.sensor(9000, rate=100.0, angle_random_walk=0.01, bias_instability=0.002,
                               bandwidth=30.0, lsb=1e-3, seed=4)  # fmt: skip
    blocks = fit_davar_in_blocks(x, window=600, rate=100.0, taus="octave", block_values=4000,
                                 fit_options={"cells": False}, fit_rows=report.series_rows,
                                 drawn=MAX_SURFACE_TIMES)  # fmt: skip
    whole = adavar.fit_noise(adavar.davar(x, window=600, rate=100.0, taus="octave"), cells=False)
    assert blocks.fit.time.size == report.MAX_SERIES_POINTS < whole.time.size
    got = report_parts.coefficient_plot(blocks.fit, "deg/s", blocks)
    want = report_parts.coefficient_plot(whole, "deg/s")
    assert json.dumps(got) == json.dumps(want)
    # Q above 0 in one window between two drawn ones, 0 elsewhere
    undrawn = np.setdiff1d(np.arange(whole.time.size), blocks.fit_rows)
    hidden = int(undrawn[undrawn.size // 2])  # in a slice of its own, far from the first
    c = np.array(whole.coefficients)
    c[:, 0] = 0.0
    c[hidden, 0] = 1e-6
    whole_q = dataclasses.replace(whole, coefficients=c)
    thin_q = dataclasses.replace(blocks.fit, coefficients=c[blocks.fit_rows])
    blocks_q = dataclasses.replace(blocks, fit=thin_q, coefficients=c)
    got, names = report_parts.coefficient_plot(thin_q, "deg/s", blocks_q)
    want, want_names = report_parts.coefficient_plot(whole_q, "deg/s")
    assert names == want_names and any(n.startswith("Q") for n in names)
    assert json.dumps(got) == json.dumps(want)
    assert report_parts.block_fit_of(thin_q, blocks_q) is blocks_q
    assert report_parts.block_fit_of(whole, blocks) is None

"""Tests of adavar.output.plots: figures, atomic saving, unit labels and number formatting."""

from __future__ import annotations

import re

import matplotlib
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import adavar
from adavar import simulate
from adavar.output._figures import envelope, power_label, run_ends
from adavar.output.plots import (
    deviation_figure,
    deviation_unit,
    format_pm,
    rate_unit,
    save_figure,
    term_unit,
)


@pytest.fixture(scope="module")
def gyro():
    x = simulate.sensor(100_000, rate=100.0, angle_random_walk=2e-3, rate_random_walk=2e-4, seed=7)
    result = adavar.deviation(x, rate=100.0, units="deg/s")
    return result, adavar.fit_noise(result)


def legend_labels(fig: Figure) -> list[str]:
    (ax,) = fig.axes
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_deviation_figure_without_fit(gyro):
    result, _ = gyro
    fig = deviation_figure(result)
    assert isinstance(fig, Figure)
    (ax,) = fig.axes
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert ax.get_xlabel() == "tau [s]"
    assert ax.get_ylabel() == "Overlapping Allan deviation [deg/s]"
    assert len(ax.containers) == 1  # the error bars
    labels = legend_labels(fig)
    assert labels == ["OADEV, 68.3 % confidence"]
    data_line = ax.containers[0].lines[0]
    np.testing.assert_array_equal(data_line.get_xdata(), result.tau)
    np.testing.assert_array_equal(data_line.get_ydata(), result.dev)


def test_deviation_figure_with_fit(gyro):
    result, fit = gyro
    fig = deviation_figure(result, fit, title="my gyro")
    (ax,) = fig.axes
    assert ax.get_title() == "my gyro"
    n_active = int(np.count_nonzero(fit.coefficients > 0))
    assert n_active >= 2
    labels = legend_labels(fig)
    assert len(labels) == 2 + n_active  # data, model, one asymptote per non-zero term
    assert labels[0].startswith("OADEV")
    assert labels[1].startswith("fitted model")
    arw = [lab for lab in labels if lab.startswith("N (angle random walk) = ")]
    assert len(arw) == 1 and arw[0].endswith("deg/sqrt(h)") and " ± " in arw[0]
    assert any(lab.startswith("K (rate random walk) = ") for lab in labels)
    # the model line is fit.model_dev on a grid spanning the taus
    model = next(line for line in ax.get_lines() if line.get_label() == labels[1])
    grid = model.get_xdata()
    assert grid[0] == pytest.approx(result.tau[0]) and grid[-1] == pytest.approx(result.tau[-1])
    np.testing.assert_allclose(model.get_ydata(), fit.model_dev(grid))


def test_labels_without_known_unit():
    x = simulate.white(4000, seed=1)
    result = adavar.deviation(x, stat="mdev")
    fig = deviation_figure(result)
    assert fig.axes[0].get_ylabel() == "Modified Allan deviation"
    # a unit outside adavar.core.units: natural units in the term labels
    res = adavar.deviation(x, rate=10.0, units="V")
    fit = adavar.fit_noise(res, terms=["angle_random_walk"])
    labels = legend_labels(deviation_figure(res, fit))
    assert labels[-1].startswith("N (angle random walk) = ") and labels[-1].endswith("V*sqrt(s)")


def test_units_argument_overrides_and_tdev_unit(gyro):
    x = simulate.white(4000, seed=1)
    result = adavar.deviation(x, stat="tdev", rate=10.0, units="deg/s")
    assert deviation_figure(result).axes[0].get_ylabel() == "Time deviation [deg]"
    assert deviation_figure(result, units="rad/s").axes[0].get_ylabel() == ("Time deviation [rad]")


def test_no_confidence_interval_still_plots():
    result = adavar.deviation(simulate.white(1000, seed=2), confidence=None)
    fig = deviation_figure(result)
    assert legend_labels(fig) == ["OADEV"]


def test_no_pyplot_state(gyro):
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    backend = matplotlib.get_backend()
    result, fit = gyro
    deviation_figure(result, fit)
    assert plt.get_fignums() == before
    assert matplotlib.get_backend() == backend


def test_plot_then_pyplot_savefig_writes_the_plot(tmp_path):
    """``r.plot(); plt.savefig(path)`` writes the figure (it wrote a blank page: the figure
    was not pyplot's), and ``ax=`` draws on the caller's axes."""
    import matplotlib.pyplot as plt
    from matplotlib.image import imread

    x = simulate.white(20_000, seed=3)
    surface = adavar.davar(x, rate=100.0, window=2000, step=2000, units="deg/s")
    curve = adavar.deviation(x, rate=100.0, units="deg/s")
    plt.close("all")
    try:
        for k, result in enumerate((surface, curve, adavar.fit_noise(surface))):
            ax = result.plot()
            assert ax.figure is plt.gcf()
            path = tmp_path / f"plot{k}.png"
            plt.savefig(path)
            assert imread(path)[..., :3].std() > 0.05  # a blank page has none
            _, axes = plt.subplots(1, 2)
            assert result.plot(ax=axes[1]) is axes[1]
            assert axes[1].has_data() and not axes[0].has_data()
    finally:
        plt.close("all")


def test_plot_without_pyplot_leaves_pyplot_alone():
    """A script that does not use pyplot gets a plain figure: pyplot is not imported."""
    import subprocess
    import sys

    code = (
        "import sys, numpy as np, adavar; "
        "ax = adavar.deviation(np.random.default_rng(0).standard_normal(4000)).plot(); "
        "assert ax.figure.canvas is not None; print('matplotlib.pyplot' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


def test_save_figure_both_formats_atomically(gyro, tmp_path):
    result, fit = gyro
    fig = deviation_figure(result, fit)
    written = save_figure(fig, tmp_path / "dev")
    assert written == [tmp_path / "dev.png", tmp_path / "dev.svg"]
    assert (tmp_path / "dev.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "<svg" in (tmp_path / "dev.svg").read_text()[:2000]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dev.png", "dev.svg"]


def _svg_geometry(path) -> str:
    """An SVG without what changes from one save to the next (date, generated ids)."""
    text = path.read_text()
    text = re.sub(r"<dc:date>.*?</dc:date>", "", text)
    return re.sub(r'(clip-path|id)="[^"]*"|url\(#[^)]*\)|xlink:href="#[^"]*"', "", text)


@pytest.mark.parametrize("autolayout", [False, True])
def test_save_figure_lays_out_once(gyro, tmp_path, autolayout):
    """The second format takes the first one's layout (no second layout pass, whatever
    the rc settings): the SVG of savefig after the PNG with the layout frozen by a
    placeholder engine; the figure keeps its layout engine."""
    result, fit = gyro
    fig = deviation_figure(result, fit)
    engine = fig.get_layout_engine()
    with matplotlib.rc_context({"figure.autolayout": autolayout}):
        save_figure(fig, tmp_path / "both")
    assert fig.get_layout_engine() is engine
    plain = deviation_figure(result, fit)
    plain.savefig(tmp_path / "plain.png", dpi=150)
    plain.set_layout_engine("none")
    plain.savefig(tmp_path / "plain.svg", dpi=150)
    assert _svg_geometry(tmp_path / "both.svg") == _svg_geometry(tmp_path / "plain.svg")


def test_save_figure_draws_the_pixels_of_savefig(gyro, tmp_path):
    """The layout solved ahead of savefig (at the PNG's resolution) places every pixel
    where savefig's own layout pass does, for a one-panel and a six-panel figure."""
    from matplotlib.image import imread

    from adavar.output.plots import controller_figure

    schedule = adavar.adaptive_schedule(simulate.white(3000, seed=4), rate=10.0, lmax=300,
                                        lmin=100, l=30)  # fmt: skip
    draws = {
        "deviation": lambda: deviation_figure(*gyro),
        "controller": lambda: controller_figure(schedule, np.arange(3000) / 10.0),
    }
    for name, draw in draws.items():
        save_figure(draw(), tmp_path / name, formats=("png",))
        draw().savefig(tmp_path / f"{name}_plain.png", dpi=150)
        ours, plain = imread(tmp_path / f"{name}.png"), imread(tmp_path / f"{name}_plain.png")
        assert ours.shape == plain.shape and np.array_equal(ours, plain), name


def test_save_figure_failure_leaves_no_temporary(tmp_path):
    fig = deviation_figure(adavar.deviation(simulate.white(500, seed=3)))
    with pytest.raises(ValueError):
        save_figure(fig, tmp_path / "dev", formats=("png", "no-such-format"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dev.png"]


@pytest.mark.parametrize(
    ("term", "unit", "expected"),
    [
        ("quantization", "deg/s", "deg"),
        ("angle_random_walk", "deg/s", "deg/sqrt(s)"),
        ("bias_instability", "deg/s", "deg/s"),
        ("rate_random_walk", "deg/s", "deg/s/sqrt(s)"),
        ("rate_ramp", "deg/s", "deg/s^2"),
        ("quantization", "m/s^2", "m/s"),
        ("angle_random_walk", "m/s^2", "m/s/sqrt(s)"),
        ("rate_ramp", "m/s^2", "m/s^3"),
        ("angle_random_walk", "deg/h", "deg/h*sqrt(s)"),
        ("rate_random_walk", "", "1/sqrt(s)"),
        ("bias_instability", None, None),
    ],
)
def test_term_unit(term, unit, expected):
    assert term_unit(term, unit) == expected


def test_rate_and_deviation_units():
    assert rate_unit("deg/s", "rate") == "deg/s"
    assert rate_unit("deg", "phase") == "deg/s"
    assert rate_unit("m/s", "phase") == "m/s^2"
    assert rate_unit("s", "phase") == ""
    assert rate_unit(None, "phase") is None
    assert deviation_unit("oadev", "deg/s") == "deg/s"
    assert deviation_unit("tdev", "deg/s") == "deg"
    assert deviation_unit("tdev", "") == "s"


@pytest.mark.parametrize(
    ("value", "unc", "unit", "expected"),
    [
        (0.301313, 0.000556, "deg/sqrt(h)", "0.30131 ± 0.00056 deg/sqrt(h)"),
        (6.8796, 0.2833, None, "6.88 ± 0.28"),
        (9.7518e-05, 2.639e-06, "deg", "(9.75 ± 0.26)e-05 deg"),
        (2105.3, 1255.0, "", "2100 ± 1300"),
        (0.0, 1.4e-06, "deg/s^2", "0 (< 1.4e-06) deg/s^2"),
        (2.89, 114.3, None, "2.9 ± 1.1e+02"),
        (float("nan"), float("nan"), "deg", "not fitted"),
        (1.5, float("nan"), "deg", "1.5 deg"),
    ],
)
def test_format_pm(value, unc, unit, expected):
    assert format_pm(value, unc, unit) == expected


@pytest.mark.parametrize(
    ("mathtext", "plain"),
    [
        (r"$\mathdefault{10^{-3}}$", "10⁻³"),
        (r"$\mathdefault{10^{0}}$", "10⁰"),
        (r"$\mathdefault{10^{12}}$", "10¹²"),
        (r"$\mathdefault{2\times10^{-1}}$", "2×10⁻¹"),
        (r"$\mathdefault{10^{-3}}$ ", r"$\mathdefault{10^{-3}}$ "),  # not the whole label
        ("", ""),
        ("0.5", "0.5"),
    ],
)
def test_power_labels_are_plain_text(mathtext, plain):
    assert power_label(mathtext) == plain


def test_log_axes_draw_no_mathtext(gyro, tmp_path):
    # the tick labels of a deviation figure are plain text, the same numbers as matplotlib's
    result, fit = gyro
    fig = deviation_figure(result, fit)
    save_figure(fig, tmp_path / "dev", formats=("png",))
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_xticklabels() + ax.get_yticklabels() if t.get_text()]
    assert labels and not any("$" in label for label in labels)
    assert "10⁻¹" in labels and "10⁰" in labels


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.sampled_from([0.0, 1.0, 2.5, 400.0, float("nan")]), min_size=0, max_size=40),
    st.booleans(),
)
def test_run_ends_draw_the_same_shape(values, step):
    """The points run_ends keeps draw the same line (or step fill) as every point: each
    dropped point lies on the segment (or the step) of the kept points around it."""
    from adavar.output._figures import run_ends

    v = np.array(values)
    at = run_ends(v, step=step)
    n = v.size
    assert np.all(np.diff(at) > 0) and (n == 0 or (at[0] == 0 and at[-1] == n - 1))
    for i in range(n):
        if i in at:
            continue
        before = at[at < i].max()  # kept points on both sides of a dropped one
        after = at[at > i].min()
        if step:  # the value in force since the last kept point
            assert v[i] == v[before]
        else:  # on the segment: both ends equal it
            assert v[before] == v[i] == v[after]
    assert not np.any(np.isnan(v[np.setdiff1d(np.arange(n), at)]))  # every NaN kept


@pytest.mark.parametrize("n", [5000, 60_000])
def test_flag_panels_are_every_points_pixels(n):
    """A flag panel drawn from its runs' ends has the pixels of the panel drawn with every
    point, runs narrower than a pixel included (a snapped path of few vertices lost
    them)."""
    from adavar.output.paper_figures import _step_panel

    rng = np.random.default_rng(5)
    t = np.arange(n) / 200.0
    flag = np.zeros(n, dtype=bool)
    for start in rng.integers(0, n - 50, 40):
        flag[start : start + rng.integers(1, 50)] = True

    def drawn(thinned: bool) -> np.ndarray:
        fig = Figure(figsize=(6.0, 1.5), dpi=100)
        FigureCanvasAgg(fig)
        ax = fig.subplots()
        if thinned:
            _step_panel(ax, t, flag, "f", "C0")
        else:
            ax.fill_between(t, 0, flag.astype(float), step="post", color="C0", alpha=0.6,
                            linewidth=0, rasterized=True)  # fmt: skip
            ax.set_ylim(-0.15, 1.15)
            ax.set_yticks([0, 1])
            ax.set_ylabel("f")
        fig.canvas.draw()
        return np.asarray(fig.canvas.buffer_rgba()).copy()

    np.testing.assert_array_equal(drawn(True), drawn(False))


def _envelope_reference(y: np.ndarray, bins: int) -> np.ndarray:
    """Point by point: the first lowest and first highest finite point of each run of
    ceil(n / bins) points (a run with none: its first point), the first and the last."""
    n = len(y)
    if n <= 4 * bins:
        return np.arange(n)
    width = -(-n // bins)
    keep = {0, n - 1}
    for a in range(0, n, width):
        run = y[a : a + width]
        finite = [i for i in range(len(run)) if np.isfinite(run[i])]
        if not finite:
            keep.add(a)
            continue
        keep.add(a + min(finite, key=lambda i: (run[i], i)))
        keep.add(a + max(finite, key=lambda i: (run[i], -i)))
    return np.array(sorted(keep))


@settings(max_examples=150, deadline=None)
@given(
    st.integers(1, 9),
    st.lists(
        st.one_of(
            st.floats(-1e300, 1e300),
            st.just(np.nan),
            st.just(np.inf),
            st.just(-np.inf),
            st.sampled_from([0.0, 1.0]),
        ),
        min_size=1,
        max_size=200,
    ),
    st.integers(1, 60),
)
def test_envelope_keeps_each_runs_extremes(bins, values, block):
    from adavar.output import _figures

    y = np.array(values, dtype=float)
    saved = _figures.ENVELOPE_BLOCK
    _figures.ENVELOPE_BLOCK = block  # runs read a block at a time: any block size
    try:
        at = envelope(y, bins)
    finally:
        _figures.ENVELOPE_BLOCK = saved
    np.testing.assert_array_equal(at, _envelope_reference(y, bins))
    finite = y[np.isfinite(y)]
    if y.size > 4 * bins and finite.size:  # the axes' limits: the whole line's
        assert np.min(y[at][np.isfinite(y[at])]) == finite.min()
        assert np.max(y[at][np.isfinite(y[at])]) == finite.max()


def test_a_window_of_many_runs_is_drawn_by_the_envelope_of_its_run_ends():
    """Fig. 10 of a long record: the window and its thresholds change at hundreds of
    thousands of centres (217,771 on a 2-hour 200 Hz log); their lines hold at most the
    envelope of those run ends, with the same extremes, and a few runs are drawn whole."""
    import dataclasses

    from adavar.output.plots import controller_figure

    x = simulate.white(3000, seed=4)
    short = adavar.adaptive_schedule(x, rate=200.0, lmax=300, lmin=200, l=50)
    lmin, lmax = 200, 300
    for n, runs in ((3000, None), (400_000, 100_000)):
        schedule = short
        if runs is not None:  # every 4 centres a new length, from lmin to lmax and back
            phase = np.arange(n) // 4 % (2 * (lmax - lmin))
            window = lmin + np.minimum(phase, 2 * (lmax - lmin) - phase)
            rows = {f: np.resize(getattr(short, f), n)
                    for f in ("kurtosis", "s", "f1", "f2", "f", "centre")}  # fmt: skip
            schedule = dataclasses.replace(short, window=window.astype(np.int64), **rows)
        t = np.arange(n) / 200.0
        fig = controller_figure(schedule, t)
        lines = [fig.axes[0].get_lines()[1], fig.axes[5].get_lines()[0]]
        ends = run_ends(schedule.window)
        for line, want in zip(lines, (schedule.thresholds.k1[schedule.window],
                                      schedule.window), strict=True):  # fmt: skip
            y = np.asarray(line.get_ydata())
            if runs is None:
                assert y.size == ends.size  # every run end
            else:
                assert ends.size > 16384 and y.size <= 2 * 4096 + 2
                assert y.min() == want.min() and y.max() == want.max()
                assert line.get_xdata()[0] == t[0] and line.get_xdata()[-1] == t[ends[-1]]


def test_long_lines_are_drawn_by_their_envelope_short_ones_whole():
    """Fig. 6 of a 2-hour 200 Hz record: its lines hold a few thousand points each (they
    held every one: 376 MB in matplotlib with Fig. 7); a short record's, every point."""
    from adavar.output.plots import kurtosis_windows_figure
    from adavar.paper.studies import kurtosis_study

    for n, drawn in ((16_000, 16_000), (1_440_000, 2 * 4096 + 2)):
        x = simulate.white(n, seed=2)
        study = kurtosis_study(x, rate=200.0, windows=(11, 201))
        fig = kurtosis_windows_figure(study)
        for ax in fig.axes:
            line = ax.get_lines()[0]
            assert len(line.get_xdata()) <= drawn
            if n == 16_000:
                assert len(line.get_xdata()) == n
        y = np.asarray(fig.axes[1].get_lines()[0].get_ydata())
        assert np.nanmax(y) == np.nanmax(study.kurtosis[11])

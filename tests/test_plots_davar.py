"""Tests of the DAVAR figures of adavar.output.plots: surface, heat map, coefficient over time."""

from __future__ import annotations

import math
import time

import matplotlib
import numpy as np
import pytest
from matplotlib.figure import Figure

import adavar
from adavar import simulate
from adavar.core.results import DavarResult
from adavar.core.thinning import spread_log as _spread_log
from adavar.output.plots import (
    coefficient_figure,
    davar_heatmap_figure,
    davar_surface_figure,
    save_figure,
)
from adavar.output.plots import (
    spread_indices as _spread,
)

RATE = 10.0
STD = 0.5
TRUE_N = STD / math.sqrt(RATE)  # deg/sqrt(s)


@pytest.fixture(scope="module")
def gyro():
    """White rate noise whose level triples halfway, with a window that grows with it."""
    x = simulate.white(4000, std=STD, rate=RATE, seed=21)
    x[2000:] *= 3.0
    window = np.r_[np.full(2000, 240), np.full(2000, 480)]
    result = adavar.davar(x, window=window, rate=RATE, units="deg/s")
    return result, adavar.fit_noise(result)


def fake_result(n_time: int, n_tau: int) -> DavarResult:
    """A large surface built directly (no computation), for the decimation tests."""
    m = np.unique(np.round(np.geomspace(1, 200, n_tau)).astype(np.int64))
    tau = m / 100.0
    t = np.arange(n_time) / 100.0
    avar = np.broadcast_to(1e-4 / tau, (n_time, m.size)).copy()
    avar[:, -1] = np.nan
    return DavarResult(
        time=t, tau=tau, avar=avar,
        window=np.full(n_time, 600), centre=np.arange(n_time), m=m,
        alpha=np.zeros(m.size, dtype=np.int64), tau0=0.01, data_type="rate",
        edges="mirror", step=1, confidence=float("nan"), n_samples=n_time, units="deg/s",
    )  # fmt: skip


# --------------------------------------------------------------------------------------
# Decimation
# --------------------------------------------------------------------------------------


def test_spread_keeps_ends_and_bounds():
    np.testing.assert_array_equal(_spread(5, 400), np.arange(5))
    idx = _spread(1_000_000, 400)
    assert idx.size == 400 and idx[0] == 0 and idx[-1] == 999_999
    assert np.all(np.diff(idx) > 0)
    tau = np.arange(1, 2001) * 0.01
    idx = _spread_log(tau, 50)
    assert idx.size <= 50 and idx[0] == 0 and idx[-1] == 1999
    ratios = np.diff(np.log(tau[idx]))
    assert ratios[-1] == pytest.approx(np.log(tau[-1] / tau[0]) / 49, rel=0.05)  # even in log
    np.testing.assert_array_equal(_spread_log(tau[:10], 50), np.arange(10))


# --------------------------------------------------------------------------------------
# Surface
# --------------------------------------------------------------------------------------


def test_surface_figure(gyro):
    result, _ = gyro
    fig = davar_surface_figure(result)
    assert isinstance(fig, Figure)
    ax, cbar = fig.axes
    assert ax.name == "3d"
    assert ax.get_xlabel() == "log10(tau / s)"
    assert ax.get_ylabel() == "time [s]"
    assert ax.get_zlabel() == "log10(ADEV / (deg/s))"
    assert cbar.get_ylabel() == "log10(Allan deviation / (deg/s))"
    assert len(ax.collections) == 1
    assert ax.collections[0].get_rasterized()
    title = fig._suptitle.get_text()
    assert "windows 240..480 samples" in title and "4000 windows" in title
    assert "drawn: 400 x" in title
    # the axes span the record and the taus; z spans log10 of the finite deviations
    lo, hi = ax.get_ylim()
    assert lo <= result.time[0] and hi >= result.time[-1]
    finite = result.avar[np.isfinite(result.avar)]
    zlo, zhi = ax.get_zlim()
    assert zlo == pytest.approx(0.5 * np.log10(finite.min()), abs=0.2)
    assert zhi == pytest.approx(0.5 * np.log10(finite.max()), abs=0.2)


def test_surface_units_override_and_no_unit(gyro):
    result, _ = gyro
    assert davar_surface_figure(result, units="rad/s").axes[0].get_zlabel() == (
        "log10(ADEV / (rad/s))"
    )
    x = simulate.white(600, seed=2)
    bare = adavar.davar(x, window=60, confidence=None, taus="octave")
    fig = davar_surface_figure(bare, title="plain")
    assert fig.axes[0].get_zlabel() == "log10 ADEV"
    assert fig._suptitle.get_text() == "plain"


def test_surface_of_one_window_is_a_line():
    x = simulate.white(900, seed=3)
    one = adavar.davar(x, window=900, edges="valid", rate=RATE, units="deg/s")
    assert one.avar.shape[0] == 1
    fig = davar_surface_figure(one)
    ax = fig.axes[0]
    assert len(ax.collections) == 0 and len(ax.get_lines()) == 1
    assert "1 window x" in fig._suptitle.get_text()


# --------------------------------------------------------------------------------------
# Heat map
# --------------------------------------------------------------------------------------


def test_heatmap_figure_masks_undefined_cells(gyro):
    result, _ = gyro
    fig = davar_heatmap_figure(result, max_times=100000, max_taus=100000)
    ax, cbar = fig.axes
    assert ax.get_yscale() == "log"
    assert ax.get_xlabel() == "time [s]" and ax.get_ylabel() == "tau [s]"
    assert cbar.get_ylabel() == "log10(Allan deviation / (deg/s))"
    (mesh,) = ax.collections
    assert mesh.get_rasterized()
    z = mesh.get_array()
    n_time, n_tau = result.avar.shape
    assert z.shape == (n_tau, n_time)  # nothing decimated here
    np.testing.assert_array_equal(np.ma.getmaskarray(z), np.isnan(result.avar).T)
    np.testing.assert_allclose(z.compressed(), 0.5 * np.log10(result.avar.T[~np.isnan(
        result.avar.T)]))  # fmt: skip
    # the first half's windows are 240 samples: no tau beyond 8 s there
    assert np.isnan(result.avar[0, result.tau > 8.0]).all()


def test_large_surfaces_are_decimated_and_fast():
    big = fake_result(200_000, 40)
    start = time.perf_counter()
    surface = davar_surface_figure(big, max_times=300, max_taus=20)
    heatmap = davar_heatmap_figure(big)
    assert time.perf_counter() - start < 10.0
    assert "drawn: 300 x" in surface._suptitle.get_text()
    z = heatmap.axes[0].collections[0].get_array()
    assert z.shape[1] <= 1500 and z.shape[0] <= 300
    assert np.ma.getmaskarray(z)[-1].all()  # the NaN tau is masked


# --------------------------------------------------------------------------------------
# Coefficient over time
# --------------------------------------------------------------------------------------


def test_coefficient_figure_in_conventional_units(gyro):
    _, fit = gyro
    fig = coefficient_figure(fit, truth=TRUE_N, title="N(t)")
    (ax,) = fig.axes
    assert ax.get_ylabel() == "N [deg/sqrt(h)]"
    assert ax.get_xlabel() == "time [s]"
    assert ax.get_title() == "N(t)"
    value = fit.angle_random_walk.value
    line = ax.get_lines()[0]
    np.testing.assert_array_equal(line.get_xdata(), fit.time)
    np.testing.assert_allclose(line.get_ydata(), 60.0 * value)  # deg/sqrt(s) -> deg/sqrt(h)
    truth = ax.get_lines()[1]
    assert truth.get_ydata()[0] == pytest.approx(60.0 * TRUE_N)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["±1 sigma", "N(t), angle random walk", "true value 9.487 deg/sqrt(h)"]
    band = ax.collections[0].get_paths()[0].vertices
    assert band[:, 1].min() >= 0.0
    # the level triples halfway: so does N
    half = fit.time.size // 2
    ratio = np.median(value[half + 300 :]) / np.median(value[: half - 300])
    assert ratio == pytest.approx(3.0, rel=0.1)


def test_coefficient_figure_natural_units_and_other_terms(gyro):
    _, fit = gyro
    fig = coefficient_figure(fit, conventional=False)
    assert fig.axes[0].get_ylabel() == "N [deg/sqrt(s)]"
    np.testing.assert_allclose(fig.axes[0].get_lines()[0].get_ydata(),
                               fit.angle_random_walk.value)  # fmt: skip
    fig = coefficient_figure(fit, term="bias_instability")
    assert fig.axes[0].get_ylabel() == "B [deg/h]"
    fig = coefficient_figure(fit, term="rate_random_walk", units="mV")
    assert fig.axes[0].get_ylabel() == "K [mV/sqrt(s)]"


def test_coefficient_figure_decimates(gyro):
    _, fit = gyro
    fig = coefficient_figure(fit, max_points=100)
    line = fig.axes[0].get_lines()[0]
    assert line.get_xdata().size == 100
    assert line.get_xdata()[0] == fit.time[0] and line.get_xdata()[-1] == fit.time[-1]


def test_coefficient_figure_refuses_bad_input(gyro):
    result, fit = gyro
    with pytest.raises(ValueError, match="not in the model"):
        coefficient_figure(adavar.fit_noise(result, terms=["angle_random_walk"]),
                           term="rate_ramp")  # fmt: skip
    with pytest.raises(ValueError, match="unknown noise term"):
        coefficient_figure(fit, term="drift")
    single = adavar.fit_noise(adavar.deviation(simulate.white(2000, seed=1), units="deg/s"))
    with pytest.raises(ValueError, match="time series"):
        coefficient_figure(single)


def test_coefficient_figure_of_few_windows_has_markers():
    x = simulate.white(3000, std=STD, rate=RATE, seed=5)
    result = adavar.davar(x, window=600, rate=RATE, step=500, units="deg/s", taus="octave")
    fit = adavar.fit_noise(result, terms=["angle_random_walk"])
    ax = coefficient_figure(fit, truth=TRUE_N).axes[0]
    assert ax.get_lines()[0].get_marker() == "o"
    assert len(ax.containers) == 1  # error bars
    assert ax.get_lines()[1].get_ydata()[0] == pytest.approx(60 * TRUE_N)


# --------------------------------------------------------------------------------------
# Saving, pyplot state
# --------------------------------------------------------------------------------------


def test_figures_save_non_empty_files(gyro, tmp_path):
    result, fit = gyro
    for stem, fig in (
        ("surface", davar_surface_figure(result)),
        ("heatmap", davar_heatmap_figure(result)),
        ("arw", coefficient_figure(fit)),
    ):
        png, svg = save_figure(fig, tmp_path / stem)
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert png.stat().st_size > 10_000
        assert "<svg" in svg.read_text()[:2000]
        assert svg.stat().st_size < 2_000_000  # the surface and map are rasterized
    assert len(list(tmp_path.iterdir())) == 6


def test_no_pyplot_state(gyro):
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    backend = matplotlib.get_backend()
    result, fit = gyro
    davar_surface_figure(result)
    davar_heatmap_figure(result)
    coefficient_figure(fit)
    assert plt.get_fignums() == before
    assert matplotlib.get_backend() == backend

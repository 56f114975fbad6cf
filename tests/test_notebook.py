"""The notebook views of the results: ``_repr_html_`` and ``.plot()`` (issue 17)."""

from __future__ import annotations

import numpy as np
import pytest

import adavar
from adavar import simulate


@pytest.fixture(scope="module")
def gyro():
    return simulate.sensor(20_000, rate=100.0, angle_random_walk=0.3, seed=1)


@pytest.fixture(scope="module")
def curve(gyro):
    return adavar.deviation(gyro, rate=100.0, units="deg/s")


@pytest.fixture(scope="module")
def surface(gyro):
    return adavar.davar(gyro, rate=100.0, window=2000, step=500, units="deg/s")


def test_a_deviation_shows_a_table_and_a_figure(curve):
    text = curve._repr_html_()
    assert "<table>" in text and "DeviationResult" in text and "oadev" in text
    assert "data:image/png;base64," in text
    ax = curve.plot()
    assert ax.get_xscale() == "log" and ax.figure is not None


def test_a_fit_shows_its_terms_with_the_field_names(curve):
    fit = adavar.fit_noise(curve)
    text = fit._repr_html_()
    assert "angle random walk" in text and "reduced chi2" in text
    with pytest.raises(TypeError, match=r"result.plot\(fit=fit\)"):
        fit.plot()
    ax = curve.plot(fit=fit)
    assert len(ax.get_lines()) >= 2  # the data and the model


def test_a_davar_surface_shows_a_heat_map(surface):
    text = surface._repr_html_()
    assert "DavarResult" in text and "data:image/png;base64," in text
    ax = surface.plot()
    assert ax.figure is not None
    stack = adavar.fit_noise(surface)
    assert "median" in stack._repr_html_()
    assert stack.plot().figure is not None


def test_an_adaptive_result_is_a_davar_view(gyro):
    x = np.array(gyro[:6000])
    result = adavar.adaptive_davar(x, rate=100.0, lmax=600, lmin=400, step=100)
    text = result._repr_html_()
    assert "AdaptiveResult" in text and " .. 600 samples" in text
    assert result.plot().figure is not None

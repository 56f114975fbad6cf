"""The simulated records of the A-DAVAR paper (adavar.simulate.paper_scenario)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from adavar import simulate
from adavar.simulate import PaperScenario, paper_scenario


def test_scenario_one_levels_and_changes():
    sc = paper_scenario(1, seed=3)
    assert isinstance(sc, PaperScenario)
    assert sc.number == 1 and sc.rate == 1.0 and sc.tau0 == 1.0
    assert sc.data.shape == sc.std.shape == (6000,)
    assert sc.change_times == (3000.0, 4000.0)
    np.testing.assert_array_equal(sc.std[:3000], 1.0)
    np.testing.assert_array_equal(sc.std[3000:4000], 3.0)
    np.testing.assert_array_equal(sc.std[4000:], 1.0)
    np.testing.assert_array_equal(sc.arw, sc.std)  # N = std sqrt(tau0) at 1 Hz
    np.testing.assert_array_equal(sc.time, np.arange(6000.0))
    assert sc.intervals == ((0.0, 2000.0), (3000.0, 4000.0))
    assert not sc.variance_reading and sc.seed == 3
    assert "3000-4000 s" in sc.description and "std x3" in sc.description
    # the samples have the stated levels (1000 samples: the std within a few %)
    assert np.std(sc.data[3000:4000]) == pytest.approx(3.0, rel=0.08)
    assert np.std(sc.data[:3000]) == pytest.approx(1.0, rel=0.05)


def test_scenario_one_is_piecewise_white_with_the_same_draws():
    sc = paper_scenario(1, seed=11)
    want = simulate.piecewise_white(6000, [1.0, 3.0, 1.0], [3000, 4000], seed=11)
    np.testing.assert_array_equal(sc.data, want)
    np.testing.assert_array_equal(paper_scenario(1, seed=11).data, sc.data)  # reproducible
    assert not np.array_equal(paper_scenario(1, seed=12).data, sc.data)


def test_variance_reading_has_variance_three_and_the_same_draws():
    std3 = paper_scenario(1, seed=5)
    var3 = paper_scenario(1, seed=5, variance_reading=True)
    assert var3.variance_reading
    np.testing.assert_allclose(var3.std[3000:4000], math.sqrt(3.0))
    np.testing.assert_allclose(var3.arw[3000:4000] ** 2, 3.0)
    np.testing.assert_array_equal(var3.data[:3000], std3.data[:3000])
    np.testing.assert_allclose(var3.data[3000:4000], std3.data[3000:4000] * math.sqrt(3) / 3)
    assert "variance x3" in var3.description


def test_scenario_two():
    sc = paper_scenario(2, seed=1)
    assert sc.change_times == (1000.0, 2000.0, 4000.0, 5000.0)
    expected = np.ones(6000)
    expected[1000:2000] = 3.0
    expected[4000:5000] = 3.0
    np.testing.assert_array_equal(sc.std, expected)
    assert sc.intervals == ((1000.0, 2000.0), (2500.0, 3500.0), (4000.0, 5000.0))


@pytest.mark.parametrize("bad", [0, 3, True, "1", 1.5])
def test_unknown_scenario_is_refused(bad):
    with pytest.raises(ValueError, match="1 or 2"):
        paper_scenario(bad)

"""The N-cornered hat and the Groslambert covariance (adavar.cornered_hat)."""

from __future__ import annotations

import numpy as np
import pytest

import adavar
from adavar import simulate
from adavar.core.errors import AdavarInputError
from adavar.stats.cornered_hat import cornered_hat, gcodev

from .stable32_data import stable32_root


def _allantools_clocks(n: int = 100_000):
    """allantools' three-cornered-hat example: white PM clocks of 1, 5 and 10 (seed 42)."""
    rs = np.random.RandomState(42)
    a, b, c = rs.randn(n), 5.0 * rs.randn(n), 10.0 * rs.randn(n)
    return a - b, b - c, c - a  # AB, BC, CA


def _slow_gcodev(x: np.ndarray, y: np.ndarray, m: int, tau0: float = 1.0) -> float:
    """allantools' calc_gcodev_phase, term by term (phase data, overlapping)."""
    total, count = 0.0, 0
    for k in range(x.size - 2 * m):
        zx = x[k + 2 * m] - 2.0 * x[k + m] + x[k]
        zy = y[k + 2 * m] - 2.0 * y[k + m] + y[k]
        total += zx * zy
        count += 1
    return total / (2.0 * count * (m * tau0) ** 2)


# --------------------------------------------------------------------------------------
# the Groslambert covariance


def test_gcodev_reproduces_sigmatheta():
    examples = stable32_root() / "examples"
    if not (examples / "gcodev_CA_AB.txt").is_file():
        pytest.skip("allantools' gcodev examples are not in the data folder")
    ab, bc, ca = _allantools_clocks()
    for a, b, name in ((ca, ab, "CA_AB"), (bc, ab, "BC_AB"), (bc, ca, "BC_CA")):
        ref = np.loadtxt(examples / f"gcodev_{name}.txt")
        got = gcodev(a, b, rate=1.0, taus="octave")
        np.testing.assert_array_equal(got.m, ref[:, 0])
        # SigmaTheta's GCoDev keeps the sign: the shared clock enters with opposite signs
        np.testing.assert_allclose(got.codev, ref[:, 1], rtol=1e-11)


def test_gcodev_matches_the_sum_term_by_term():
    rng = np.random.default_rng(1)
    shared = np.cumsum(rng.standard_normal(2000))
    x = shared + 3.0 * rng.standard_normal(2000) + 1e6  # an offset costs no digits
    y = -shared + np.cumsum(0.5 * rng.standard_normal(2000))
    got = gcodev(x, y, tau0=0.5, taus=[0.5, 2.0, 8.0, 64.0])
    for m, c in zip(got.m, got.covar, strict=True):
        assert c == pytest.approx(_slow_gcodev(x, y, int(m), 0.5), rel=1e-9)
    assert np.all(got.covar < 0)  # the shared walk enters with opposite signs
    assert np.all(got.codev == -np.sqrt(-got.covar))
    assert np.all(np.abs(got.correlation) <= 1)


def test_gcodev_rate_input_and_interval():
    rng = np.random.default_rng(2)
    a = rng.standard_normal((3, 1 << 13))
    got = gcodev(a[0] - a[1], a[0] - a[2], rate=2.0, data_type="rate")
    truth = 2.0 / got.tau / 4.0  # white FM of unit samples at 2 Hz: AVAR = tau0 / tau
    assert np.all(got.covar_low <= got.covar) and np.all(got.covar <= got.covar_high)
    assert np.mean((got.covar_low <= truth) & (truth <= got.covar_high)) > 0.5
    plus = gcodev(a[0] - a[1], a[0] - a[2], rate=2.0, data_type="rate", confidence=None)
    assert np.all(np.isnan(plus.covar_low)) and np.array_equal(plus.covar, got.covar)


def test_gcodev_interval_coverage():
    # the covariance of A-B and A-C is sigma_A^2 (A quiet: the estimate often has the
    # wrong sign), over 60 records
    hits = []
    for s in range(60):
        rng = np.random.default_rng(100 + s)
        u = rng.standard_normal((3, 1 << 11)) * np.array([[0.5], [1.0], [2.0]])
        got = gcodev(u[0] - u[1], u[0] - u[2], data_type="rate", taus=[1, 4, 16, 64])
        truth = 0.25 / got.tau
        hits.append((got.covar_low <= truth) & (truth <= got.covar_high))
    assert 0.58 < np.mean(hits) < 0.8


# --------------------------------------------------------------------------------------
# the three-cornered hat


def test_three_cornered_hat_is_the_classic_formula():
    ab, bc, ca = _allantools_clocks(20_000)
    got = cornered_hat([ab, bc, ca], data_type="phase", taus="octave")
    assert got.names == ("A", "B", "C") and got.method == "three-cornered hat"
    s = {p: got.pair_results[p].dev ** 2 for p in got.pairs}
    np.testing.assert_allclose(
        got.var[0], 0.5 * (s["A", "B"] + s["C", "A"] - s["B", "C"]), rtol=1e-12
    )
    np.testing.assert_allclose(
        got.var[2], 0.5 * (s["B", "C"] + s["C", "A"] - s["A", "B"]), rtol=1e-12
    )
    # it is the Groslambert covariance of the two records that share the clock
    np.testing.assert_allclose(
        got.var[0], -gcodev(ab, ca, taus="octave").covar, rtol=1e-9, atol=1e-12
    )
    # allantools' white PM example: AVAR = 3 sigma^2 / tau^2, within 4 standard errors
    truth = 3.0 * np.array([1.0, 25.0, 100.0])[:, None] / got.tau**2
    assert np.all(np.abs(got.var - truth) < 4 * got.var_sigma)
    assert np.all(got.dev_low <= got.dev) and np.all(got.dev <= got.dev_high)


def test_instruments_and_mapping_inputs_agree():
    rng = np.random.default_rng(3)
    common = np.cumsum(rng.standard_normal(4096))  # the table's rate, cancelled
    xs = [common + s * rng.standard_normal(4096) for s in (1.0, 2.0, 3.0)]
    one = cornered_hat(xs, kind="instruments", names=["x", "y", "z"])
    pairs = {("x", "y"): xs[0] - xs[1], ("x", "z"): xs[0] - xs[2], ("y", "z"): xs[1] - xs[2]}
    two = cornered_hat(pairs)
    three = cornered_hat(dict(zip("xyz", xs, strict=True)), kind="instruments")
    np.testing.assert_allclose(one.var, two.var, rtol=1e-12)
    np.testing.assert_allclose(one.var, three.var, rtol=1e-12)
    np.testing.assert_allclose(one.dev_high, two.dev_high, rtol=1e-9)
    truth = np.array([1.0, 4.0, 9.0])[:, None] / one.tau
    assert np.all(np.abs(one.var - truth)[:, :8] < 4 * one.var_sigma[:, :8])


def test_negative_variances_are_reported():
    rng = np.random.default_rng(4)
    u = rng.standard_normal((3, 2048)) * np.array([[0.05], [1.0], [1.0]])
    got = cornered_hat(u, kind="instruments", taus="all")
    neg = got.negative[0]
    assert neg.any(), "a quiet instrument should get negative estimates at some taus"
    assert np.all(got.var[0, neg] < 0) and np.all(np.isnan(got.dev[0, neg]))
    assert np.all(got.dev_low[0, neg] == 0) and np.all(got.dev_high[0, neg] > 0)
    assert any("negative variance" in note for note in got.notes)
    assert "negative var" in got.summary()
    curve = got.deviation("A")
    assert isinstance(curve, adavar.DeviationResult) and np.isnan(curve.dev[neg]).all()


def test_coverage_of_the_three_cornered_hat():
    # 68.3 % intervals, three white FM clocks and a random-walk one; the last taus with
    # fewer than 16 clusters are left out (their EDF is below 4)
    cover, cases = [], ((1.0, 2.0, 3.0), (0.3, 1.0, 1.0))
    n = 1 << 12
    for levels in cases:
        for s in range(40):
            rng = np.random.default_rng(1000 + s)
            u = rng.standard_normal((3, n)) * np.array(levels)[:, None]
            got = cornered_hat(u, kind="instruments")
            keep = got.m <= n // 16
            truth = np.array(levels)[:, None] / np.sqrt(got.tau[keep])
            cover.append((got.dev_low[:, keep] <= truth) & (truth <= got.dev_high[:, keep]))
    rate = np.mean(cover)
    assert 0.63 < rate < 0.76, rate


def test_n_cornered_hat_least_squares():
    levels = np.array([0.5, 1.0, 1.5, 2.0])
    est, cover = [], []
    n = 1 << 12
    for s in range(30):
        rng = np.random.default_rng(2000 + s)
        u = rng.standard_normal((4, n)) * levels[:, None]
        got = cornered_hat(u, kind="instruments", taus=[1, 4, 16, 64])
        truth = levels[:, None] / np.sqrt(got.tau)
        est.append(got.var / truth**2)
        cover.append((got.dev_low <= truth) & (truth <= got.dev_high))
    assert got.method == "least squares" and len(got.pairs) == 6
    np.testing.assert_allclose(np.mean(est, axis=0), 1.0, atol=0.12)
    assert 0.58 < np.mean(cover) < 0.8


def test_a_fit_of_one_instrument():
    rng = np.random.default_rng(5)
    n = 1 << 14
    y = [simulate.white(n, s, seed=rng) for s in (1.0, 2.0, 3.0)]
    got = cornered_hat(y, kind="instruments", units="")
    fit = adavar.fit_power_law(got.deviation("C"), terms=("white_fm",))
    assert fit["white_fm"].value == pytest.approx(2 * 9.0, rel=0.1)  # h_0 = 2 sigma^2 tau0
    assert repr(got).startswith("CorneredHatResult(names=('A', 'B', 'C')")
    assert got["B"].stat == "oadev"
    with pytest.raises(KeyError):
        got.deviation("D")


def test_no_confidence():
    u = np.random.default_rng(6).standard_normal((3, 1024))
    got = cornered_hat(u, kind="instruments", confidence=None, stat="mdev")
    assert np.all(np.isnan(got.dev_low)) and np.all(np.isfinite(got.var))
    assert got.stat == "mdev"


@pytest.mark.parametrize(
    "records,kw,match",
    [
        ([np.ones(64)] * 2, {"kind": "instruments"}, "at least 3 instruments"),
        ([np.ones(64)] * 4, {}, "the three of a three-cornered hat"),
        ({("A", "B"): np.ones(64), ("B", "C"): np.ones(64), ("C", "D"): np.ones(64)}, {},
         "odd cycle"),
        ({("A", "B"): np.ones(64), ("B", "A"): np.ones(64), ("A", "C"): np.ones(64)}, {},
         "appears twice"),
        ({("A", "A"): np.ones(64)}, {}, "distinct names"),
        ([np.ones(64), np.ones(64), np.ones(65)], {}, "one length"),
        ([np.ones(64)] * 3, {"kind": "pairs"}, "unknown kind"),
        ([np.ones(64)] * 3, {"names": ["A", "A", "B"]}, "distinct names"),
        ({("A", "B"): np.ones(64), ("B", "C"): np.ones(64), ("C", "A"): np.ones(64)},
         {"names": ["A", "B", "X"]}, "do not match"),
        ([np.ones(64)] * 3, {"confidence": 2.0}, "confidence"),
    ],
)  # fmt: skip
def test_errors(records, kw, match):
    with pytest.raises(AdavarInputError, match=match) as info:
        cornered_hat(records, **kw)
    assert "\n" not in str(info.value)


def test_gcodev_errors():
    with pytest.raises(AdavarInputError, match="one length"):
        gcodev(np.ones(64), np.ones(65))
    with pytest.raises(AdavarInputError, match="numeric"):
        gcodev(["a"] * 64, np.ones(64))

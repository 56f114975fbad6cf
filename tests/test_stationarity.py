"""The whole-record stationarity test and its warning (issue 39, item 12; long version:
``benchmarks/bench_stationarity.py``).

Before, ``deviation`` on an hour at 100 Hz whose white noise is 2.5 times stronger for 10
minutes gave one curve (N = 0.41 where it is 0.30 for 83 % of the record) and no hint.
Records come from ``tests/independent_noise.py`` (no adavar code).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import adavar
from adavar.core.errors import AdavarInputError
from adavar.stats.stationary_noise import stationarity

from . import independent_noise as ind
from .cli_helpers import run

STATIONARY = {
    "heavy-tailed white": "heavy-tailed white",
    "white+flicker+RRW": "white+flicker+RRW",
    "white+RRW+markov": "white+RRW+markov",
    "filtered+quantised": "filtered+quantised",
    # hard low-passes (1 % and 0.2 % of Nyquist): samples correlated over 50-300 samples
    "low-passed": dict(N=1e-3, B=2e-4, K=1e-5, bandwidth=0.02),
    "low-passed hard": dict(N=1e-3, B=2e-4, K=1e-5, bandwidth=0.004),
}


def _step(seed: int, seconds: float = 3600.0, rate: float = 100.0):
    return ind.changing("step", seconds, rate, seed, factor=2.5, length=600.0)


@pytest.mark.parametrize("mix", sorted(STATIONARY))
def test_stationary_records_rarely_warn(mix):
    # 10 minutes at 100 Hz; at the default level 1e-3 the expected count is 0.06 of 60
    p = np.array(
        [stationarity(ind.record(STATIONARY[mix], 600.0, 100.0, s)[0], rate=100.0).p_value
         for s in range(60)]
    )  # fmt: skip
    assert np.count_nonzero(p < 1e-3) <= 1, np.sort(p)[:3]
    assert np.mean(p < 0.05) <= 0.15, np.sort(p)[:10]  # the p-value is not anti-conservative


@pytest.mark.parametrize("alpha", sorted(ind.POWER_LAWS))
def test_power_law_phase_records_are_stationary(alpha):
    p = [stationarity(ind.power_law(alpha, 20_000, s), data_type="phase").p_value
         for s in range(20)]  # fmt: skip
    assert min(p) >= 1e-3, p


def test_a_stronger_stretch_is_found_and_located():
    # old code: no test at all
    for seed in range(12):
        x, change = _step(seed)
        r = stationarity(x, rate=100.0)
        assert not r.stationary and r.p_value < 1e-6, (seed, r.p_value)
        (a, b), (ta, tb) = r.stretch, change.changes[0]
        assert abs(a - ta) < 30.0 and abs(b - tb) < 30.0, (seed, r.stretch)
        assert 2.2 < r.ratio < 2.8, (seed, r.ratio)


def test_deviation_warns_and_says_where():
    x, _ = _step(3)
    result = adavar.deviation(x, rate=100.0)
    assert len(result.warnings) == 1
    text = result.warnings[0]
    assert "not stationary" in text and "adavar adaptive" in text and " s to " in text
    assert adavar.deviation(x, rate=100.0, stationarity_check=False).warnings == ()
    quiet = adavar.deviation(ind.record("white", 3600.0, 100.0, 3)[0], rate=100.0)
    assert quiet.warnings == ()
    # a warning changes nothing else
    np.testing.assert_array_equal(
        result.dev, adavar.deviation(x, rate=100.0, stationarity_check=False).dev
    )


@pytest.mark.parametrize("offset", [0.0, 1e8, -1e-30])
def test_extremes_given_by_the_caller_give_the_same_result(offset):
    """deviation hands its input check's range on (issue 42: two passes less)."""
    x, _ = _step(4, seconds=600.0)
    x = x * (1e-40 if offset < 0 else 1.0) + offset
    want = stationarity(x, rate=100.0)
    got = stationarity(x, rate=100.0, extremes=(float(x.min()), float(x.max())))
    assert (got.p_value, got.stretch, got.ratio) == (want.p_value, want.stretch, want.ratio)


def test_cli_avar_warns_on_stderr_and_in_json(capsys, tmp_path):
    x, _ = _step(4, seconds=1200.0)  # the default stretch lies in the middle of the record
    path = tmp_path / "gyro.npy"
    np.save(path, x)
    code, out, err = run(capsys, ["avar", str(path), "--rate", "100", "--units", "deg/s"])
    assert code == 0, err  # a warning, not an error: the exit code stays
    assert "adavar: warning:" in err and "not stationary" in err and "adavar adaptive" in err
    code, out, err = run(capsys, ["avar", str(path), "--rate", "100", "--units", "deg/s", "--json"])
    assert code == 0
    warnings = json.loads(out)["warnings"]
    assert len(warnings) == 1 and "not stationary" in warnings[0]


def test_phase_input_tests_the_same_noise():
    x, _ = _step(5, seconds=1200.0)
    rate = stationarity(x, rate=100.0)
    phase = stationarity(np.cumsum(x) / 100.0, rate=100.0, data_type="phase")
    assert not phase.stationary
    assert phase.ratio == pytest.approx(rate.ratio, rel=0.02)


def test_short_constant_and_bad_input():
    short = stationarity(np.random.default_rng(0).standard_normal(200))
    assert short.stationary and math.isnan(short.p_value) and "too short" in short.reason
    assert stationarity(np.ones(5000)).reason.startswith("the record has no short-tau noise")
    # a stuck stretch (no change at all) is a change of the noise
    x = np.random.default_rng(1).standard_normal(20_000)
    x[8000:11000] = x[8000]
    assert not stationarity(x).stationary
    # an LSB above the filtered noise (most differences 0), and a correlation too long for
    # the record: not tested (0.5-10 % of such stationary records were flagged)
    coarse, _ = ind.record(dict(N=1e-3, K=1e-5, bandwidth=0.02, lsb=0.1), 600.0, 100.0, 1)
    assert "quantisation steps" in stationarity(coarse).reason
    smooth, _ = ind.record(dict(N=1e-3, bandwidth=0.002), 20_000.0, 1.0, 1)
    assert "correlated over" in stationarity(smooth).reason
    for bad in ({"level": 0.0}, {"segments": 1}, {"data_type": "angle"}):
        with pytest.raises(AdavarInputError):
            stationarity(x, **bad)
    with pytest.raises(AdavarInputError):
        stationarity(np.r_[x, np.nan])


@pytest.mark.parametrize("order", [1, 2])
def test_block_powers_in_memory_are_numpys(order):
    """The compiled block powers of a record in memory (issue 42) are the NumPy
    version's bit for bit: the squared differences of the scaled samples, summed in the
    pieces the NumPy version reads as NumPy sums them (pairwise), blocks across pieces
    included. So the p-value, the stretch and the ratio are those of before."""
    from adavar.stats.stationary_noise import _block_powers, _record_powers

    rng = np.random.default_rng(order)
    for n, offset, scale in ((300, 0.0, 1.0), (70_001, 1e9, 1e-3), (250_000, -3.0, 1e5)):
        x = offset + scale * rng.standard_normal(n)
        x[n // 3 : n // 2] *= 2.5
        big = float(np.max(np.abs(x)))
        scaled = x / big  # what the NumPy version reads

        def read(a, b, s=scaled):
            return s[a:b]

        for n_blocks, piece in ((16, 1 << 20), (256, 1000), (64, 4093), (5, 7)):
            size = (n - order) // n_blocks
            want = _block_powers(read, n_blocks, size, order, piece=piece)
            got = _record_powers(x, big, n_blocks, size, order, piece=piece)
            assert got.tobytes() == want.tobytes(), (n, n_blocks, piece)

"""``increment_kurtosis``: the kurtosis of a record's first differences (the heavy-tail
correction of the fit's covariance), compiled, against an obviously correct reference."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from adavar.stats import stream
from adavar.stats.statistics import KURTOSIS_SAMPLES, increment_kurtosis


def reference(x: np.ndarray) -> float:
    """Pearson kurtosis of the middle KURTOSIS_SAMPLES differences, with exact sums."""
    n = x.size
    start = max(0, (n - KURTOSIS_SAMPLES) // 2)
    d = [float(b) - float(a) for a, b in zip(x[start:-1], x[start + 1 :], strict=True)]
    d = d[:KURTOSIS_SAMPLES]
    mean = math.fsum(d) / len(d)
    m2 = math.fsum((v - mean) ** 2 for v in d) / len(d)
    m4 = math.fsum((v - mean) ** 4 for v in d) / len(d)
    return m4 / (m2 * m2) if m2 > 0 else math.nan


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(8, 3000),
    seed=st.integers(0, 2**31),
    offset=st.sampled_from([0.0, 1e6, -1e9]),
    scale=st.sampled_from([1e-12, 1.0, 1e8]),
    step=st.booleans(),
    dof=st.sampled_from([None, 3.0]),
    float32=st.booleans(),
)
def test_matches_the_reference(n, seed, offset, scale, step, dof, float32):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n) if dof is None else rng.standard_t(dof, n)
    x = x * scale + offset + np.linspace(0.0, 5.0 * scale, n)  # an offset and a drift
    if step:
        x[n // 2 :] += 100.0 * scale
    if float32:
        x = x.astype(np.float32)
    want = reference(np.asarray(x, dtype=np.float64))
    got = increment_kurtosis(x)
    if math.isnan(want):
        assert math.isnan(got)
    else:
        assert got == pytest.approx(want, rel=1e-9, abs=1e-12)


def test_pieces_and_the_middle_of_a_long_record():
    x = np.random.default_rng(1).standard_t(5.0, KURTOSIS_SAMPLES + 5000) + 1e4
    x[:2000] *= 50.0  # outside the middle 2**20 differences: not read
    want = reference(x)
    assert increment_kurtosis(x) == pytest.approx(want, rel=1e-9)
    assert increment_kurtosis(stream.ArraySource(x), chunk=70_001) == pytest.approx(want, rel=1e-9)


def test_short_and_constant_records_are_nan():
    assert math.isnan(increment_kurtosis(np.arange(5.0)))
    assert math.isnan(increment_kurtosis(np.full(100, 3.0)))

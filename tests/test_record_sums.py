"""Out-of-core deviation: equal to the in-memory one for every chunk size, in O(chunk) memory."""

from __future__ import annotations

import tracemalloc

import dask.array as da
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from adavar._kernels import differences as diff
from adavar.core.errors import AdavarInputError
from adavar.stats import record_sums as sstat
from adavar.stats import stream
from adavar.stats.statistics import STATISTICS, deviation

from . import reference

RTOL = 1e-12
FIELDS = ("tau", "n", "m", "alpha", "stat", "data_type", "tau0", "n_samples", "notes")


def _adversarial(n, seed=0, scale=1.0):
    """White noise on a 1e6-sigma offset with a drift, times ``scale``."""
    rng = np.random.default_rng(seed)
    return scale * (1e6 + 1e-3 * np.arange(n) + rng.standard_normal(n))


def _assert_same(got, want, rtol=RTOL):
    for f in FIELDS:
        a, b = getattr(got, f), getattr(want, f)
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b, err_msg=f)
        else:
            assert a == b, f
    np.testing.assert_allclose(got.dev, want.dev, rtol=rtol, atol=0)
    for f in ("dev_low", "dev_high", "edf"):
        np.testing.assert_allclose(getattr(got, f), getattr(want, f), rtol=rtol, atol=0)


def _both(x, chunk, **kw):
    want = deviation(np.asarray(x), **kw)
    got = deviation(x, chunk_size=chunk, **kw)
    _assert_same(got, want)
    return got


# ---------------------------------------------------------------------------------------
# the building blocks: the same anchors and local sums as the in-memory phase, bit for bit


@pytest.mark.parametrize(
    ("n", "chunk"),
    [
        (n, chunk)
        for n in (1, 5, 1023, 1024, 1025, 5000, 150_000)
        for chunk in (1, 7, 1000, 1 << 20)
        if chunk * 1200 >= n  # pieces of a few samples over 150000: too slow, no new case
    ],
)
def test_streamed_anchors_and_windows_are_the_in_memory_ones(n, chunk):
    # n = 150000 in one piece takes the block-parallel integration
    u = _adversarial(n, seed=n)
    want = diff.anchored_phase(u)
    got = sstat.streamed_phase(stream.ArraySource(u), chunk)
    assert got.shift == want.shift and got.n_points == want.n_points
    np.testing.assert_array_equal(got.hh, want.hh)
    np.testing.assert_array_equal(got.hl, want.hl)
    window = sstat._Window(got)
    rng = np.random.default_rng(n)
    lo = 0
    # forward slides (kept overlap), jumps (fresh starts) and a step back
    for _ in range(20):
        lo = int(rng.integers(max(0, lo - 3), n + 1))
        hi = int(rng.integers(lo, n + 2))
        np.testing.assert_array_equal(window.get(lo, hi), want.r[lo:hi])


# ---------------------------------------------------------------------------------------
# equality with the in-memory result


@pytest.mark.parametrize("stat", STATISTICS)
@pytest.mark.parametrize("data_type", ["rate", "phase"])
@pytest.mark.parametrize("chunk", [1, 3, 17, 1000])
def test_every_tau_of_a_short_record(stat, data_type, chunk):
    # every m from 1 to the largest: long and short m, pieces smaller and larger than N
    _both(_adversarial(150, seed=chunk), chunk, stat=stat, data_type=data_type,
          taus="all", confidence=None)  # fmt: skip


@pytest.mark.parametrize("stat", STATISTICS)
@pytest.mark.parametrize("chunk", [17, 1000, 4099])
def test_octave_taus_across_many_blocks(stat, chunk):
    # 5 anchor blocks; taus on both sides of chunk / order
    x = _adversarial(5000, seed=1)
    _both(x, chunk, stat=stat, taus="octave", confidence=None, rate=100.0)


@pytest.mark.parametrize("stat", ["oadev", "ohdev", "totdev", "mdev"])
def test_long_pieces_take_the_fused_parallel_kernels(stat):
    # pieces of >= 16384 terms: the in-memory kernel fused over taus, parallel integration
    x = _adversarial(150_000, seed=9)
    _both(x, 70_000, stat=stat, taus="octave", confidence=None)


@pytest.mark.parametrize("stat", STATISTICS)
@pytest.mark.parametrize("taus", ["decade", "log", [0.03, 0.1, 2.5, 7.0, 13.0, 1e9]])
def test_tau_grids_and_phase_input(stat, taus):
    x = np.cumsum(_adversarial(3000, seed=2))  # phase of the adversarial rate
    _both(x, 333, stat=stat, data_type="phase", taus=taus, confidence=None, rate=10.0)


@pytest.mark.parametrize("stat", STATISTICS)
@pytest.mark.parametrize("chunk", [50, 400])
def test_confidence_intervals_and_noise_types(stat, chunk):
    rng = np.random.default_rng(3)
    # random walk plus white noise: the identified type changes along the taus
    x = 1e3 + np.cumsum(rng.standard_normal(1500)) * 0.05 + rng.standard_normal(1500)
    got = _both(x, chunk, stat=stat)
    assert np.all(got.alpha >= -2) and np.all(np.isfinite(got.dev_high))


@pytest.mark.parametrize(
    "case", ["scale_small", "scale_large", "float32", "burst", "ramp_phase", "constant"]
)
@pytest.mark.parametrize("stat", STATISTICS)
def test_adversarial_records(case, stat):
    rng = np.random.default_rng(4)
    n, kw = 2100, {"stat": stat, "confidence": None}
    if case == "scale_small":
        x = _adversarial(n, scale=1e-13)
    elif case == "scale_large":
        x = _adversarial(n, scale=1e12)
    elif case == "float32":
        x = (1e3 + rng.standard_normal(n)).astype(np.float32)
    elif case == "burst":
        x = rng.standard_normal(n)
        x[1500:1510] += 1e4
    elif case == "ramp_phase":  # a quadratic phase: the drift in phase units
        x = 1e9 + 1e3 * np.arange(n) + 1e-2 * np.arange(n) ** 2 + rng.standard_normal(n)
        kw["data_type"] = "phase"
    else:  # constant rate: every deviation is exactly 0
        x = np.full(n, 7.25)
    got = _both(x, 250, **kw)
    if case == "constant":
        assert np.all(got.dev == 0.0)


def test_matches_the_exact_reference():
    # the in-memory path is itself checked against math.fsum elsewhere; once directly here
    x = _adversarial(120, seed=5)
    for stat in STATISTICS:
        r = deviation(x, stat=stat, taus=[1, 3, 10, 39], confidence=None, chunk_size=7)
        np.testing.assert_allclose(r.dev, reference.deviation(x, r.m, stat), rtol=1e-9)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=st.integers(4, 400),
    stat=st.sampled_from(STATISTICS),
    chunk=st.integers(1, 500),
    data_type=st.sampled_from(["rate", "phase"]),
    seed=st.integers(0, 2**32 - 1),
)
def test_property_any_length_statistic_and_chunk(n, stat, chunk, data_type, seed):
    x = _adversarial(n, seed=seed, scale=10.0 ** (seed % 25 - 12))
    _both(x, chunk, stat=stat, data_type=data_type, taus="octave", confidence=None)


# ---------------------------------------------------------------------------------------
# the chunked inputs: memory maps, dask arrays, sources


def test_npy_memory_map_and_dask_without_chunk_size(tmp_path):
    x = _adversarial(3000, seed=6).astype(np.float32)
    p = tmp_path / "x.npy"
    np.save(p, x)
    mm = np.load(p, mmap_mode="r")
    assert stream.is_chunked(mm)
    for stat in ("oadev", "mdev", "totdev"):
        _assert_same(deviation(mm, stat=stat), deviation(x, stat=stat))
        want = deviation(x, stat=stat, confidence=None)
        for data, chunk in [
            (mm, 100),
            (da.from_array(x, chunks=777), 500),
            (stream.NpyFileSource(p), 64),
        ]:
            _assert_same(deviation(data, stat=stat, chunk_size=chunk, confidence=None), want)


def test_memory_stays_within_a_few_chunks():
    chunk = 20_000
    src = stream.ArraySource(np.random.default_rng(7).standard_normal(50 * chunk))
    for stat, data_type in [("oadev", "rate"), ("mdev", "phase"), ("hdev", "rate"),
                            ("totdev", "phase")]:  # fmt: skip
        deviation(src, stat=stat, data_type=data_type, chunk_size=chunk, confidence=None)
        tracemalloc.start()
        try:
            deviation(src, stat=stat, data_type=data_type, chunk_size=chunk, confidence=None)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        # measured 4-9 chunks of float64 (the reflected reads of totdev build an index);
        # the record itself is 50
        assert peak < 12 * 8 * chunk, (stat, peak / (8 * chunk))


# ---------------------------------------------------------------------------------------
# mistakes


def test_input_errors():
    x = np.random.default_rng(8).standard_normal(100)
    for bad in (0, -3, 2.5, "many", True):
        with pytest.raises(AdavarInputError, match="chunk_size"):
            deviation(x, chunk_size=bad)
    with pytest.raises(AdavarInputError, match="at least 4"):
        deviation(stream.ArraySource(x[:3]), data_type="phase")
    with pytest.raises(AdavarInputError, match="1-D"):
        deviation(np.ones((10, 2)), chunk_size=4)
    y = x.copy()
    y[77] = np.nan
    with pytest.raises(AdavarInputError, match="sample 77"):
        deviation(y, chunk_size=10, confidence=None)
    with pytest.raises(AdavarInputError, match="sample 77"):
        deviation(y, stat="totdev", data_type="phase", chunk_size=10, confidence=None)

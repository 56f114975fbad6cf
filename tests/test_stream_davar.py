"""Out-of-core DAVAR and noise identification against the in-memory engine, any chunk size."""

from __future__ import annotations

import dataclasses
import tracemalloc

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from adavar import simulate
from adavar._kernels import differences as diff
from adavar.core.errors import AdavarInputError
from adavar.dynamic import surface as davar_mod
from adavar.dynamic.surface import davar
from adavar.stats import edf as edf_mod
from adavar.stats import stream
from adavar.stats.statistics import record_noise_types

RTOL = 1e-12


def _noise(n, seed=0, scale=1.0):
    return scale * np.random.default_rng(seed).standard_normal(n)


def assert_same(got, want, rtol=RTOL):
    """Every field of two DavarResults equal; the surface (and its bounds) to ``rtol``."""
    for f in dataclasses.fields(want):
        if f.name == "_cache":
            continue
        a, b = getattr(got, f.name), getattr(want, f.name)
        if f.name == "record_curve":  # only a record in memory carries its whole curve
            assert a is None or b is None, f.name
            continue
        if f.name == "avar":
            assert a.shape == b.shape
            np.testing.assert_allclose(a, b, rtol=rtol, atol=0.0, equal_nan=True)
        elif isinstance(b, np.ndarray):
            assert a.dtype == b.dtype, f.name
            np.testing.assert_array_equal(a, b, err_msg=f.name)
        elif isinstance(b, float) and np.isnan(b):
            assert np.isnan(a), f.name
        else:
            assert a == b, f.name
    if want.avar_low is not None:
        np.testing.assert_allclose(got.avar_low, want.avar_low, rtol=rtol, equal_nan=True)
        np.testing.assert_allclose(got.avar_high, want.avar_high, rtol=rtol, equal_nan=True)


def check(x, chunk_size, **kw):
    """davar of a chunked source of ``x`` against davar of ``x`` in memory."""
    want = davar(np.asarray(x), **kw)
    got = davar(stream.ArraySource(x), chunk_size=chunk_size, **kw)
    assert_same(got, want)
    return got, want


# ---------------------------------------------------------------------------------------
# the surface equals the in-memory one for any chunk size


def _cases(n):
    rng = np.random.default_rng(11)
    return {
        "fixed window, every centre": dict(window=101),
        "even window, step": dict(window=100, step=7),
        "step longer than the window": dict(window=31, step=200),
        "valid edges, step": dict(window=64, step=5, edges="valid"),
        "per-sample schedule": dict(window=rng.integers(3, 150, n)),
        "per-sample schedule, valid": dict(window=rng.integers(3, 150, n), edges="valid", step=3),
        "per-centre schedule": dict(window=rng.integers(10, 300, -(-n // 9)), step=9),
        "phase input": dict(window=np.full(n - 1, 64), data_type="phase", tau0=0.01),
        "long window, octave taus": dict(window=n - 1, step=50, taus="octave"),
    }


@pytest.mark.parametrize("chunk", [1, 7, 1000, 1 << 22])
@pytest.mark.parametrize("case", sorted(_cases(10)))
def test_chunked_equals_in_memory(case, chunk):
    n = 600 if chunk < 1000 else 3000  # tiny pieces: one window per group, so fewer windows
    x = 1e6 + _noise(n, seed=5) + 1e-3 * np.arange(n)  # 1e6-sigma offset and a drift
    confidence = 0.683 if chunk == 1000 else None  # the identification is tested below
    got, want = check(x, chunk, confidence=confidence, **_cases(n)[case])
    assert got.avar.shape[0] == want.centre.size


@pytest.mark.parametrize("chunk", [5, 333])
def test_float32_and_extreme_scales(chunk):
    x32 = (_noise(2000, seed=6) + 1e3).astype(np.float32)
    check(x32, chunk, window=50, step=3, confidence=None if chunk < 100 else 0.9)
    for scale in (1e-13, 1e12):
        check(_noise(1500, seed=7, scale=scale), chunk, window=41, step=2, taus="octave")


def test_level_step_and_spike():
    """Excursions far from the shift cost the in-memory path digits; the same ones here."""
    x = _noise(5000, seed=8)
    x[2500:] += 1e3
    x[1234] += 1e4
    check(x, 777, window=200, step=3, confidence=None)


def test_long_record_default_chunk_several_groups():
    x = _noise(60_000, seed=9)
    got, _ = check(x, 10_000, window=1001, step=1, taus="octave")
    assert np.isfinite(got.avar).all()


def test_phase_input_through_differenced_source():
    x = np.cumsum(_noise(4000, seed=10) + 5.0)
    check(x, 300, window=np.full(3999, 61), data_type="phase", rate=100.0)
    check(x, 300, window=61, data_type="phase", edges="valid", step=4)


@st.composite
def _random_cases(draw):
    n = draw(st.integers(5, 200))
    kind = draw(st.sampled_from(["fixed", "per-sample", "per-centre"]))
    edges = draw(st.sampled_from(["mirror", "valid"]))
    step = draw(st.integers(1, 40))
    if kind == "fixed":
        window = draw(st.integers(3, n))
    else:
        hi = draw(st.integers(3, n))
        size = n if kind == "per-sample" else -(-n // step)
        seed = draw(st.integers(0, 2**16))
        window = np.random.default_rng(seed).integers(3, hi + 1, size)
        if kind == "per-centre":
            edges = "mirror"
    chunk = draw(st.integers(1, 2 * n + 10))
    data_type = draw(st.sampled_from(["rate", "phase"]))
    return n, window, step, edges, chunk, data_type, draw(st.integers(0, 2**16))


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_random_cases())
def test_property_any_chunk_size(case):
    n, window, step, edges, chunk, data_type, seed = case
    x = _noise(n + (data_type == "phase"), seed=seed) + 1e4
    kw = dict(window=window, step=step, edges=edges, data_type=data_type, confidence=None)
    try:
        want = davar(x, **kw)
    except AdavarInputError as exc:  # e.g. no valid centre: the chunked path says the same
        with pytest.raises(AdavarInputError, match=str(exc)[:20]):
            davar(stream.ArraySource(x), chunk_size=chunk, **kw)
        return
    got = davar(stream.ArraySource(x), chunk_size=chunk, **kw)
    assert_same(got, want)


def test_groups_cover_the_centres_within_the_span():
    rng = np.random.default_rng(12)
    centres = np.sort(rng.choice(100_000, 3000, replace=False)).astype(np.int64)
    lengths = rng.integers(3, 500, centres.size).astype(np.int64)
    for span in (1, 100, 5000):
        bounds, lo, hi = davar_mod._centre_groups(centres, lengths, 250, span, 1 << 16)
        assert bounds[0] == 0 and bounds[-1] == centres.size and np.all(np.diff(bounds) > 0)
        for g in range(lo.size):
            a = centres[bounds[g] : bounds[g + 1]] - (lengths[bounds[g] : bounds[g + 1]] - 1) // 2
            b = a + lengths[bounds[g] : bounds[g + 1]]
            assert lo[g] == a.min() + 250 and hi[g] == b.max() + 250
            assert hi[g] - lo[g] <= max(span, (b - a).max())
    # sparse centres are read window by window, not the gaps between them
    far = np.arange(0, 10**7, 10**5, dtype=np.int64)
    bounds, lo, hi = davar_mod._centre_groups(far, np.full(far.size, 6001), 3000, 1 << 22, 1 << 16)
    assert lo.size == far.size and np.all(hi - lo == 6001)


# ---------------------------------------------------------------------------------------
# noise identification out of core


def _signals(n):
    white = simulate.white(n, seed=1)
    walk = simulate.random_walk(n, 0.05, seed=2)
    return {
        "white": white + 1e6,  # and an offset of 1e6 sigma
        "flicker": simulate.flicker(n, seed=3),
        "random walk": walk,
        "mixed": white + walk + 1e-4 * np.arange(n),  # alpha changes with tau, and a drift
        "white PM": np.diff(simulate.white(n + 1, seed=4)),
    }


MS = np.unique(np.r_[1, 2, 3, 4, 5, 8, 13, 32, 50, 64, 100, 333, 700, 1000, 2500, 6000])


def _check_statistics(u, ms, chunk, dmax=2):
    phase = diff.anchored_phase(u, cluster_stats=True)
    stats, shift = stream._cluster_statistics(stream.ArraySource(u), ms, dmax, chunk)
    assert shift == phase.shift
    for m, got in zip(ms, stats, strict=True):
        if u.size // m >= edf_mod.MIN_POINTS_LAG1:
            r1, den, n, zmax = diff.cluster_lag1(phase, int(m), dmax)
            np.testing.assert_allclose(got[0], r1, rtol=0, atol=1e-12, equal_nan=True)
            np.testing.assert_allclose(got[1], den, rtol=1e-9)
            np.testing.assert_array_equal(got[2], n)
            np.testing.assert_allclose(got[3], zmax, rtol=1e-12)
        else:  # the B1 series: the cluster sums themselves (relative to the shift)
            want = diff.cluster_differences(phase.r, phase.hh, phase.hl, int(m), u.size // m)
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())


@pytest.mark.parametrize("chunk", [333, 1 << 22])
@pytest.mark.parametrize("kind", ["white", "flicker", "random walk", "mixed", "white PM"])
def test_noise_types_equal_in_memory(kind, chunk):
    u = _signals(20_000)[kind]
    _check_statistics(u, MS, chunk)
    want, notes = record_noise_types(diff.anchored_phase(u, cluster_stats=True), MS, 2)
    got, got_notes = stream.noise_types(stream.ArraySource(u), MS, 2, chunk_size=chunk)
    np.testing.assert_array_equal(got, want)
    assert got.dtype == np.int64 and got_notes == notes


@pytest.mark.parametrize("small", [0, 10**9])  # stream every lag-1 series / collect them all
@pytest.mark.parametrize("chunk", [2048, 5000])
def test_noise_types_streamed_or_collected(chunk, small, monkeypatch):
    monkeypatch.setattr(stream, "SMALL_SERIES", small)
    u = _signals(20_000)["mixed"]
    _check_statistics(u, MS, chunk)
    want, _ = record_noise_types(diff.anchored_phase(u, cluster_stats=True), MS, 2)
    np.testing.assert_array_equal(stream.noise_types(u, MS, chunk_size=chunk)[0], want)


def test_noise_types_identify_what_was_simulated():
    sig = _signals(30_000)
    ms = np.array([1, 10, 100])
    for kind, alpha in (("white", 0), ("random walk", -2), ("white PM", 2)):
        got, _ = stream.noise_types(stream.ArraySource(sig[kind]), ms, chunk_size=4000)
        np.testing.assert_array_equal(got, alpha)


@pytest.mark.parametrize("chunk", [1, 2, 3, 64])
def test_noise_types_tiny_pieces(chunk):
    """Pieces shorter than a cluster: partial sums carried across many pieces."""
    u = _signals(600)["mixed"]
    ms = np.arange(1, 200, 7)
    _check_statistics(u, ms, chunk)
    want, _ = record_noise_types(diff.anchored_phase(u, cluster_stats=True), ms, 2)
    got, _ = stream.noise_types(u, ms, chunk_size=chunk)
    np.testing.assert_array_equal(got, want)


def test_noise_types_dmax3_and_constant_record():
    u = _signals(5000)["random walk"]
    ms = np.array([1, 4, 16, 64, 200])
    _check_statistics(u, ms, 999, dmax=3)
    want = record_noise_types(diff.anchored_phase(u, cluster_stats=True), ms, 3)
    got = stream.noise_types(u, ms, 3, chunk_size=999)
    np.testing.assert_array_equal(got[0], want[0])
    # nothing to identify anywhere: white noise assumed, with the in-memory note
    flat = np.full(3000, 2.5)
    want = record_noise_types(diff.anchored_phase(flat, cluster_stats=True), ms, 2)
    got = stream.noise_types(flat, ms, chunk_size=128)
    np.testing.assert_array_equal(got[0], want[0])
    assert got[1] == want[1] and got[1]


def test_davar_record_noise_type_out_of_core():
    u = _signals(20_000)["mixed"]
    got, want = check(u, 1500, window=2001, step=500, taus="octave")
    assert np.unique(want.alpha).size > 1  # the type changes with tau
    # an explicit noise type skips the identification
    got = davar(stream.ArraySource(u), window=2001, step=500, noise_type=-1, chunk_size=99)
    np.testing.assert_array_equal(got.alpha, -1)


# ---------------------------------------------------------------------------------------
# inputs, memory


class _Recording(stream.ArraySource):
    """Records the length of every read."""

    def __init__(self, array):
        super().__init__(array)
        self.reads = []

    def _read_raw(self, start, stop):
        self.reads.append(stop - start)
        return super()._read_raw(start, stop)


def test_memory_stays_within_a_few_chunks():
    chunk = 1 << 14
    x = (_noise(50 * chunk, seed=13) + 3.0).astype(np.float32)  # every read converts
    source = _Recording(x)
    window = 1001
    davar(source, window=window, step=997, taus="octave", chunk_size=chunk)  # compile
    source.reads.clear()
    tracemalloc.start()
    try:
        res = davar(source, window=window, step=997, taus="octave", chunk_size=chunk)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    output = res.avar.nbytes + 4 * res.centre.nbytes
    assert peak < 10 * chunk * 8 + output, (peak, output)
    # by construction: no read is longer than a chunk (or a window) from its anchor block on
    assert max(source.reads) <= max(chunk, window) + diff.BLOCK
    assert sum(source.reads) < 4 * x.size  # the noise passes and the windows, no more


def test_npy_memory_map_is_read_by_file_reads(tmp_path, monkeypatch):
    x = _noise(20_000, seed=14).astype(np.float32) + 7.0
    path = tmp_path / "record.npy"
    np.save(path, x)
    mapped = np.load(path, mmap_mode="r")
    assert stream.is_chunked(mapped)
    calls = []
    raw = stream.NpyFileSource._read_raw
    monkeypatch.setattr(
        stream.NpyFileSource, "_read_raw", lambda self, a, b: calls.append(b - a) or raw(self, a, b)
    )
    got = davar(mapped, window=501, step=250, taus="octave")
    assert calls and max(calls) <= stream.DEFAULT_CHUNK
    assert_same(got, davar(x, window=501, step=250, taus="octave"))
    # and a slice of the map is read at its own position
    got = davar(mapped[5000:], window=301, step=100, chunk_size=2048, confidence=None)
    assert_same(got, davar(x[5000:], window=301, step=100, confidence=None))


def test_dask_array_input():
    da = pytest.importorskip("dask.array")
    x = _noise(5000, seed=15)
    lazy = da.from_array(x, chunks=1500)
    assert stream.is_chunked(lazy)
    assert_same(davar(lazy, window=401, step=37, chunk_size=2048), davar(x, window=401, step=37))


@pytest.mark.parametrize("chunk", [0, -3, 2.5, True, "big"])
def test_bad_chunk_size(chunk):
    with pytest.raises(AdavarInputError, match="chunk_size"):
        davar(_noise(100), window=10, chunk_size=chunk)


def test_bad_chunked_inputs():
    with pytest.raises(AdavarInputError, match="one channel"):
        davar(np.ones((5, 5)), window=3, chunk_size=10)
    with pytest.raises(AdavarInputError, match="at least 3"):
        davar(stream.ArraySource([1.0, 2.0]), window=3)
    with pytest.raises(AdavarInputError, match="at least 4"):
        davar(stream.ArraySource([1.0, 2.0, 3.0]), window=3, data_type="phase")
    x = _noise(500)
    x[321] = np.nan
    with pytest.raises(AdavarInputError, match="sample 321"):
        davar(stream.ArraySource(x), window=11, chunk_size=100)
    with pytest.raises(AdavarInputError, match="longer than the record"):
        davar(stream.ArraySource(_noise(50)), window=51)


def test_short_pieces_run_on_one_thread():
    import numba

    before = numba.get_num_threads()
    with stream.threads_for(stream.PARALLEL_MIN - 1):
        assert numba.get_num_threads() == 1
    assert numba.get_num_threads() == before
    with stream.threads_for(stream.PARALLEL_MIN):
        assert numba.get_num_threads() == before


# --------------------------------------------------------------------------------------
# dask input: a lazy surface


class _CountingArray:
    """An array that records every read (to show that nothing is read before compute)."""

    def __init__(self, values):
        self.values = values
        self.shape, self.dtype, self.ndim = values.shape, values.dtype, 1
        self.reads = 0

    def __getitem__(self, key):
        self.reads += 1
        return self.values[key]


@pytest.mark.parametrize(
    "kw",
    [
        dict(window=601),
        dict(window=600, edges="valid"),
        dict(window=2001, step=7),
        dict(window=601, data_type="phase"),
        dict(window=401, step=50_000),  # centres further apart than a group
    ],
)
@pytest.mark.parametrize("chunk_size", [None, 5_000])
def test_dask_input_gives_a_lazy_surface_equal_to_in_memory(kw, chunk_size):
    da = pytest.importorskip("dask.array")
    rng = np.random.default_rng(7)
    x = (rng.standard_normal(120_001) * (1 + np.arange(120_001) / 4e4) + 1e6).astype(np.float32)
    counting = _CountingArray(x)
    d = da.from_array(counting, chunks=25_000, asarray=True)
    before = counting.reads  # dask looks at an empty slice for the array's metadata
    lazy = davar(d, noise_type=0, taus="octave", chunk_size=chunk_size, **kw)
    assert counting.reads == before  # nothing read: the graph only
    assert type(lazy.avar).__module__.startswith("dask")
    want = davar(x, noise_type=0, taus="octave", **kw)
    got = lazy.avar.compute()
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want.avar))
    np.testing.assert_allclose(got, want.avar, rtol=1e-12)
    np.testing.assert_allclose(lazy.adev_high.compute(), want.adev_high, rtol=1e-12)
    for name in ("time", "centre", "window", "m", "alpha", "edf_table"):
        np.testing.assert_array_equal(getattr(lazy, name), getattr(want, name))
    if chunk_size is not None and kw.get("step", 1) == 1:
        assert lazy.avar.numblocks[0] > 1


def test_dask_input_lazy_xarray_and_eager_options():
    da = pytest.importorskip("dask.array")
    pytest.importorskip("xarray")
    x = np.random.default_rng(8).standard_normal(30_000)
    d = da.from_array(x, chunks=7_000)
    ds = davar(d, window=301, taus=[1, 10], chunk_size=2_000).to_xarray()
    assert type(ds["avar"].data).__module__.startswith("dask")
    want = davar(x, window=301, taus=[1, 10])
    np.testing.assert_allclose(ds["avar"].values, want.avar, rtol=1e-12)
    eager = davar(d, window=301, taus=[1, 10], lazy=False)
    assert isinstance(eager.avar, np.ndarray)
    np.testing.assert_allclose(eager.avar, want.avar, rtol=1e-12)
    with pytest.raises(AdavarInputError, match="lazy=True needs a dask array"):
        davar(x, window=301, lazy=True)


@pytest.mark.parametrize("chunk", [3, 333, 1 << 22])
@pytest.mark.parametrize("dmax", [2, 3])
def test_noise_types_phase_data_equal_in_memory(chunk, dmax):
    """Phase data (issue 11): the decimated-phase lag-1 test and R(n), out of core alike."""
    rng = np.random.default_rng(7)
    for u in (np.diff(rng.standard_normal(6001)), np.diff(np.cumsum(rng.standard_normal(6001)))):
        ms = np.array([1, 2, 4, 8, 16, 64, 150, 256, 500])
        want, _ = record_noise_types(
            diff.anchored_phase(u, cluster_stats=True), ms, dmax, data_type="phase"
        )
        got, _ = stream.noise_types(u, ms, dmax, chunk_size=chunk, data_type="phase")
        np.testing.assert_array_equal(got, want)

"""The adaptive controller out of core: piece by piece, equal to the in-memory pass.

The in-memory :func:`adaptive_schedule` is the reference (it is itself checked against a
literal reading of METHOD.md in ``test_adaptive.py``); the chunked path must give the same
windows and flags and bit-identical kurtosis and S, for any chunk size.
"""

from __future__ import annotations

import itertools
import math
import tracemalloc

import numpy as np
import pytest

from adavar.core.errors import AdavarInputError
from adavar.dynamic import adaptive, controller
from adavar.dynamic.adaptive import adaptive_davar, adaptive_schedule
from adavar.dynamic.windows import window_schedule
from adavar.io import sources
from adavar.simulate import paper_scenario
from adavar.stats import stream
from tests.test_adaptive import literal_controller

SMALL = dict(lmax=200, lmin=120, l=30, thresholds="paper")  # the adapting controller
PAPER = dict(lmax=600, lmin=400, l=100, thresholds="paper")
FIELDS = ("window", "kurtosis", "s", "f1", "f2", "f", "centre")
#: not multiples of REANCHOR (512), tiny ones, and one large enough for parallel segments
CHUNKS = (1, 100, 513, 4133, 70_001)


def record(seed: int, n: int = 150_000, dtype=np.float64) -> np.ndarray:
    """White noise with a burst every few thousand samples: the window keeps adapting."""
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n)
    for a in range(1000, n, 6500):
        x[a : a + 700] *= 3.0
    x[n // 2 : n // 2 + 5] += 40.0  # a short shock
    return x.astype(dtype)


def assert_same(got, want, step=1):
    """``got`` holds the step-th centres of ``want``: identical, bit for bit."""
    rows = want.centre % step == 0
    assert got.step == step
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name)[rows], err_msg=name)
    assert got.parameters == want.parameters
    assert got.method == want.method


@pytest.fixture(scope="module")
def burst():
    x = record(0)
    return x, {edges: adaptive_schedule(x, **SMALL, edges=edges) for edges in ("mirror", "valid")}


def test_the_record_spans_pieces_and_parallel_segments(burst):
    x, want = burst
    assert controller._segments(x.size) > 1  # the in-memory pass runs speculative segments
    assert controller._segments(70_001 // 512 * 512 + 512) > 1  # so does a large piece
    w = want["mirror"].window
    assert w.min() == SMALL["lmin"] and (w < SMALL["lmax"]).mean() > 0.2  # it adapts
    # the window is short at many piece boundaries: the carried length matters
    starts = np.arange(0, x.size, 512)
    assert (w[starts] < SMALL["lmax"]).sum() > 20


@pytest.mark.parametrize("edges", ["mirror", "valid"])
@pytest.mark.parametrize("chunk", CHUNKS)
def test_any_chunk_size_gives_the_in_memory_schedule(burst, edges, chunk):
    x, want = burst
    got = adaptive_schedule(stream.ArraySource(x), **SMALL, edges=edges, chunk_size=chunk)
    assert_same(got, want[edges])
    assert got.centre[0] == (0 if edges == "mirror" else (SMALL["lmax"] - 1) // 2)


@pytest.mark.parametrize("edges", ["mirror", "valid"])
@pytest.mark.parametrize(("step", "chunk"), [(7, 513), (1000, 100), (4096, 70_001), (3, 1)])
def test_step_keeps_the_centres_davar_computes(burst, edges, step, chunk):
    x, want = burst
    got = adaptive_schedule(x, **SMALL, edges=edges, step=step, chunk_size=chunk)
    assert_same(got, want[edges], step=step)
    # the rows are davar's centres for that step (valid: the schedule's windows all fit)
    per_centre = np.full(math.ceil(x.size / step), SMALL["lmax"])
    per_centre[got.centre // step] = got.window
    sched = window_schedule(x.size, per_centre, edges=edges, step=step)
    np.testing.assert_array_equal(sched.centre, got.centre)
    np.testing.assert_array_equal(sched.length, got.window)
    # in memory, step keeps the same rows (copies, not views of the full pass)
    mem = adaptive_schedule(x, **SMALL, edges=edges, step=step)
    assert_same(mem, want[edges], step=step)
    assert mem.window.base is None


OPTIONS = {
    "kurtosis": dict(method="kurtosis"),
    "oracle": dict(method="oracle", change_times=[1000.0, 47_000.5, 90_000.0]),
    "fixed": dict(method="fixed"),
    "band": dict(s_test="band", s1=-0.02),
    "abs": dict(s_test="abs", s2=0.05),
    "and": dict(combine="and"),
    "calibrated": dict(thresholds="calibrated", false_alarm=0.02),
    "asymmetric": dict(dl0=4, dl1=6),
}


@pytest.mark.parametrize("name", list(OPTIONS))
def test_methods_and_options(name):
    x = record(1, n=100_000)
    opts = {**SMALL, **OPTIONS[name]}
    for edges in ("mirror", "valid"):
        want = adaptive_schedule(x, **opts, edges=edges)
        for chunk, step in ((513, 1), (3000, 11)):
            got = adaptive_schedule(x, **opts, edges=edges, chunk_size=chunk, step=step)
            assert_same(got, want, step=step)
    if name == "oracle":  # the oracle's lengths are the given ones, piece by piece too
        np.testing.assert_array_equal(
            got.window, adaptive.oracle_schedule(x.size, [1000, 47_000, 90_000], **{
                k: SMALL[k] for k in ("lmax", "lmin")})[got.centre]
        )  # fmt: skip


@pytest.mark.parametrize("kind", ["offset 1e6 sigma with drift", "float32", "tiny", "huge"])
def test_hard_data(kind):
    x = record(2, n=120_000)
    if kind == "offset 1e6 sigma with drift":
        x = x + 1e6 + np.linspace(0.0, 300.0, x.size)
    elif kind == "float32":
        x = (x + 1e3).astype(np.float32)
    elif kind == "tiny":
        x = x * 1e-13
    else:
        x = x * 1e12
    want = adaptive_schedule(x, **SMALL)
    assert (want.window < SMALL["lmax"]).mean() > 0.2
    for chunk in (100, 5000):
        assert_same(adaptive_schedule(stream.ArraySource(x), **SMALL, chunk_size=chunk), want)


def test_paper_scenario_with_paper_parameters():
    sc = paper_scenario(1, seed=0)
    x = np.tile(sc.data, 12)  # 72 000 s: several pieces, with the paper's disturbance
    for edges in ("mirror", "valid"):
        want = adaptive_schedule(x, edges=edges, **PAPER)
        assert want.window.min() == 400
        for chunk in (1, 2048, 10_000):
            assert_same(adaptive_schedule(x, edges=edges, chunk_size=chunk, **PAPER), want)
    changes = list(sc.change_times)
    want = adaptive_schedule(sc.data, method="oracle", change_times=changes, **PAPER)
    got = adaptive_schedule(sc.data, method="oracle", change_times=changes, chunk_size=700,
                            **PAPER)  # fmt: skip
    assert_same(got, want)


def test_tiny_pieces_follow_method_md_literally():
    """Pieces of one REANCHOR block against the slow literal controller (scipy kurtosis)."""
    x = np.random.default_rng(5).standard_normal(2500)
    x[900:1300] *= 3.0
    got = adaptive_schedule(stream.ArraySource(x), **SMALL, chunk_size=1)
    want = literal_controller(x, **SMALL)
    np.testing.assert_array_equal(got.window, want["window"])
    np.testing.assert_allclose(got.kurtosis, want["kurtosis"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got.s, want["s"], rtol=0, atol=1e-9)
    for flag in ("f1", "f2", "f"):
        np.testing.assert_array_equal(getattr(got, flag), want[flag])
    assert got.window[1100:1300].min() < SMALL["lmax"]


def test_chunked_inputs_go_out_of_core(tmp_path, monkeypatch):
    """A memory map of a .npy file and a dask array are streamed without a chunk size."""
    import dask.array as da

    x = record(3, n=40_000, dtype=np.float32)
    want = adaptive_schedule(x, **SMALL, step=5)
    path = tmp_path / "x.npy"
    np.save(path, x)
    reads = []
    read = stream.ChunkedSource.read
    monkeypatch.setattr(sources, "DEFAULT_CHUNK", 10_000)
    monkeypatch.setattr(
        stream.ChunkedSource, "read", lambda self, a, b: reads.append(b - a) or read(self, a, b)
    )
    for data in (np.load(path, mmap_mode="r"), da.from_array(x, chunks=7000)):
        reads.clear()
        assert_same(adaptive_schedule(data, **SMALL, step=5), want, step=5)
        assert len(reads) > 3 and max(reads) < 12_000  # piece by piece, never the whole


def test_memory_stays_within_a_few_chunks():
    chunk = 4096
    n = 50 * chunk
    x = record(4, n=n)
    source = stream.ArraySource(x)
    step = 64
    adaptive_schedule(source, **SMALL, chunk_size=chunk, step=step)  # compile, warm caches
    tracemalloc.start()
    try:
        got = adaptive_schedule(source, **SMALL, chunk_size=chunk, step=step)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert got.centre.size == n // step
    rows = got.centre.size * 27  # int64 + 2 float64 + 3 bool per kept centre
    piece = chunk + SMALL["lmax"] + 2  # a piece of centres with its margin
    assert peak < 8 * 8 * piece + 2 * rows  # a few chunks of float64, never O(N)
    assert peak < n * 8 / 4  # a quarter of the record itself
    tracemalloc.start()
    try:
        adaptive_schedule(x, **SMALL)
        _, full = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert full > 25 * n  # the in-memory pass: the per-centre schedule and the extension


@pytest.mark.parametrize("method", ["fixed", "adaptive"])
@pytest.mark.parametrize("chunk", [1, 513, 4133, None])
def test_keep_runs_gives_the_runs_of_the_full_flags(burst, method, chunk):
    """keep="runs" (the fixed window's change times, issue 42): the runs of f over every
    centre, joined across pieces, equal to those of the whole in-memory schedule."""
    from adavar.dynamic.events import flag_change_times, run_change_times

    x, _ = burst
    want = adaptive_schedule(x, **{**SMALL, "method": method})
    got = adaptive_schedule(x, **{**SMALL, "method": method}, keep="runs", chunk_size=chunk)
    runs = got.flag_runs()
    assert got.runs is runs and got.centre.size == 0 and got.f.size == 0
    assert len(runs) > 5  # runs cross many piece boundaries of 1 and 513 centres
    np.testing.assert_array_equal(runs, want.flag_runs())
    assert run_change_times(runs, 200, 0.01, 5.0) == flag_change_times(
        want.f, want.centre, 200, 0.01, 5.0
    )
    assert got.parameters == want.parameters


def test_join_runs_across_pieces():
    from adavar.dynamic.events import flag_runs, join_runs

    rng = np.random.default_rng(3)
    flags = rng.random(5000) < 0.7
    flags[1000:1300] = True  # a run over several piece boundaries
    cuts = [0, 1, 1001, 1100, 1101, 2500, 5000]
    pieces = [flag_runs(flags[a:b], a) for a, b in itertools.pairwise(cuts)]
    np.testing.assert_array_equal(join_runs(pieces), flag_runs(flags))
    assert join_runs([]).shape == (0, 2)


def test_keep_runs_holds_no_per_centre_array():
    """Memory of keep="runs" is one piece, not the record (a 2e8-sample file: issue 42)."""
    chunk = 4096
    n = 60 * chunk
    x = record(5, n=n)
    settings = {**SMALL, "method": "fixed", "lmin": SMALL["lmax"]}
    adaptive_schedule(x, **settings, keep="runs", chunk_size=chunk)  # compile, warm caches
    tracemalloc.start()
    try:
        adaptive_schedule(x, **settings, keep="runs", chunk_size=chunk)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < n * 8 / 4  # a quarter of the record itself
    tracemalloc.start()
    try:
        adaptive_schedule(x, **settings)
        _, full = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert full > 25 * n  # keep="all": the per-centre schedule


def test_keep_runs_refuses_ici():
    with pytest.raises(AdavarInputError, match="keep"):
        adaptive_schedule(np.zeros(1000), **SMALL, method="ici", keep="runs")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(chunk_size=0), "chunk_size"),
        (dict(chunk_size=True), "chunk_size"),
        (dict(chunk_size=2.5), "chunk_size"),
        (dict(step=0), "step"),
        (dict(step=1.0), "step"),
    ],
)
def test_bad_arguments(kwargs, message):
    with pytest.raises(AdavarInputError, match=message) as info:
        adaptive_schedule(np.zeros(1000), **SMALL, **kwargs)
    assert "\n" not in str(info.value)


def test_bad_records_out_of_core():
    with pytest.raises(AdavarInputError, match="at least 200"):
        adaptive_schedule(stream.ArraySource(np.ones(150)), **SMALL)
    x = record(6, n=5000)
    x[3333] = np.nan
    with pytest.raises(AdavarInputError, match="sample 3333"):
        adaptive_schedule(x, **SMALL, chunk_size=1000)
    with pytest.raises(AdavarInputError, match="not numeric"):
        adaptive_schedule(np.array(["a"] * 300), **SMALL, chunk_size=100)


# ---------------------------------------------------------------------------------------
# per-centre lengths with edges="valid" (what the out-of-core adaptive_davar passes)


@pytest.mark.parametrize("step", [1, 2, 7, 50])
def test_per_centre_valid_lengths_equal_per_sample_ones(step):
    rng = np.random.default_rng(step)
    n = 301
    per_sample = rng.integers(3, 80, size=n)
    want = window_schedule(n, per_sample, edges="valid", step=step)
    got = window_schedule(n, per_sample[::step], edges="valid", step=step)
    np.testing.assert_array_equal(got.centre, want.centre)
    np.testing.assert_array_equal(got.length, want.length)
    starts = got.centre - (got.length - 1) // 2
    assert starts.min() >= 0 and (starts + got.length).max() <= n


# ---------------------------------------------------------------------------------------
# the surface


def _assert_same_result(got, want):
    np.testing.assert_array_equal(got.centre, want.centre)
    np.testing.assert_array_equal(got.window, want.window)
    np.testing.assert_array_equal(got.time, want.time)
    np.testing.assert_array_equal(got.tau, want.tau)
    for name in ("kurtosis", "s", "f1", "f2", "f"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
    np.testing.assert_allclose(got.avar, want.avar, rtol=1e-12, atol=0)
    assert np.array_equal(np.isnan(got.avar), np.isnan(want.avar))
    assert (got.edges, got.step, got.n_samples) == (want.edges, want.step, want.n_samples)


@pytest.mark.parametrize(
    ("edges", "data_type", "step", "chunk", "dtype"),
    [
        ("mirror", "rate", 1, 4133, np.float64),
        ("mirror", "rate", 37, 513, np.float32),
        ("valid", "rate", 37, 100, np.float64),
        ("valid", "rate", 1, 20_000, np.float64),
        ("mirror", "phase", 101, 2000, np.float64),
        ("valid", "phase", 5, 3000, np.float32),
    ],
)
def test_adaptive_davar_out_of_core_equals_in_memory(edges, data_type, step, chunk, dtype):
    u = record(7, n=60_000) + 1e6 + np.linspace(0.0, 50.0, 60_000)
    x = np.cumsum(u) if data_type == "phase" else u
    x = x.astype(dtype)
    opts = dict(**SMALL, rate=10.0, taus=[0.1, 1.0, 5.0], edges=edges, step=step,
                data_type=data_type)  # fmt: skip
    want = adaptive_davar(x, **opts)
    got = adaptive_davar(stream.ArraySource(x), **opts, chunk_size=chunk)
    _assert_same_result(got, want)
    assert got.window.min() == SMALL["lmin"]


def test_adaptive_davar_memmap_calibrated_oracle(tmp_path):
    x = record(8, n=50_000)
    path = tmp_path / "x.npy"
    np.save(path, x)
    for opts in (
        dict(thresholds="calibrated", false_alarm=0.01, taus="octave"),
        dict(thresholds="calibrated", taus="octave"),  # per hour (the default)
        dict(method="oracle", change_times=[20_000.0], taus=[1.0, 10.0], edges="valid"),
    ):
        want = adaptive_davar(x, **SMALL | opts, step=250)
        got = adaptive_davar(np.load(path, mmap_mode="r"), **SMALL | opts, step=250)
        _assert_same_result(got, want)

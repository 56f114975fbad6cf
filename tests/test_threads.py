"""The thread setting of the parallel kernels (issue 15)."""

from __future__ import annotations

import os
import subprocess
import sys


def _run(code: str, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**os.environ, **env}, check=False)  # fmt: skip


def test_adavar_threads_sets_the_kernels_threads_and_import_changes_no_environment():
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_OPT", "OMP_WAIT_POLICY")}
    code = ("import os, numba, adavar.stats.statistics, adavar.dynamic.surface, "
            "adavar.fit.noise_model; "
            "print(numba.get_num_threads(), os.environ.get('OMP_WAIT_POLICY'), "
            "os.environ.get('NUMBA_OPT'))")  # fmt: skip
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**env, "ADAVAR_THREADS": "1"}, check=False)  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["1", "None", "None"]


def test_the_command_compiles_at_o2_unless_the_environment_says_otherwise():
    # the console script's process, not the library's import, sets it
    code = (
        "import os, sys; sys.argv = ['adavar', '--version']; from adavar.cli import run\n"
        "try:\n    run()\nexcept SystemExit:\n    pass\n"
        "from numba.core import config; config.reload_config(); print(int(config.OPT))"
    )
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_OPT"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, check=False)  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[-1] == "2"
    done = _run(code, NUMBA_OPT="3")
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[-1] == "3"


def test_cached_kernels_give_the_same_numbers_in_a_new_process():
    """A kernel loaded from the on-disk cache computes what the compiled one did, and a
    kernel compiled in this very process (no cache) works too."""
    code = (
        "import sys, numpy as np, adavar\n"
        "x = np.random.default_rng(0).standard_normal(5000)\n"
        "r = adavar.deviation(x, rate=10.0, taus='all', stat=sys.argv[1])\n"
        "print(r.dev.tobytes().hex())\n"
    )

    def run(stat: str) -> str:
        done = subprocess.run([sys.executable, "-c", code, stat], capture_output=True,
                              text=True, env=dict(os.environ), check=False)  # fmt: skip
        assert done.returncode == 0, done.stderr
        return done.stdout.strip()

    first = run("mdev")  # compiles what the cache lacks (a fresh checkout)
    assert run("mdev") == first
    from adavar._kernels._jit import jit

    @jit(cache=False)
    def plus(x):  # pragma: no cover - compiled
        return x + 1.0

    assert plus(np.ones(2)).tolist() == [2.0, 2.0]


def test_a_bad_thread_setting_is_a_one_line_error_on_the_command_line(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("x\n" + "".join(f"{(k * 7919) % 101 / 100}\n" for k in range(200)))
    code = (
        "import sys; from adavar.cli import main; "
        f"sys.exit(main(['avar', {str(path)!r}, '--rate', '1', '--units', 'deg/s']))"
    )
    done = _run(code, ADAVAR_THREADS="many")
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "ADAVAR_THREADS='many'" in lines[0], done.stderr


# --- threaded kernels: one thread and several give the same bits -----------------------

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from adavar._kernels import _jit  # noqa: E402


@pytest.fixture
def force(monkeypatch):
    """Run every threaded kernel on the calling thread alone (``force("serial")``) or on
    every thread from the smallest input (``force("parallel")``)."""

    from adavar._kernels import differences
    from adavar.stats import noise_id

    def choose(which: str) -> None:
        monkeypatch.setattr(_jit, "SERIAL_WORK", 1 << 62 if which == "serial" else 0)
        # the whole-record kernels' own thresholds (issue 42)
        monkeypatch.setattr(differences, "RECORD_THREADS_MIN", 1 << 62 if which == "serial" else 0)
        monkeypatch.setattr(noise_id, "NOISE_THREADS_MIN", 1 << 62 if which == "serial" else 0)

    return choose


def _record(n: int, seed: int = 7) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n) + 1e9  # a large offset
    x[n // 3 :] += 1e4  # a level step
    x += np.linspace(0.0, 50.0, n)  # and a drift
    return x


def _both(force, call):
    force("serial")
    a = call()
    force("parallel")
    b = call()
    return a, b


def test_threaded_davar_window_kernel_is_bit_identical(force):
    from adavar._kernels.window_engine import window_variance

    x = _record(40_000)
    ms = np.array([1, 2, 4, 8, 16, 32, 64], dtype=np.int64)
    centres = np.arange(300, 39_700, dtype=np.int64)
    lengths = np.where(centres % 1000 < 500, 600, 400).astype(np.int64)
    a, b = _both(force, lambda: window_variance(x, ms, centres, lengths, stat="oavar"))
    np.testing.assert_array_equal(a, b)


def test_threaded_modified_sums_are_bit_identical_and_exact(force, monkeypatch):
    """The MVAR numerators in parts of MOD_PART starts (issue 42): the same bits on one
    thread and several, each part's sliding sum exact against a direct sum."""
    from adavar._kernels import differences as diff
    from adavar.stats import record_sums

    monkeypatch.setattr(diff, "MOD_PART", 5000)  # many parts on a short record
    x = _record(40_000, seed=9)
    phase = diff.anchored_phase(x)
    ms = np.array([1, 7, 64, 1000], dtype=np.int64)
    (a, counts), (b, _) = _both(force, lambda: record_sums.modified_sums(phase, ms))
    np.testing.assert_array_equal(a, b)
    s = np.concatenate(([0.0], np.cumsum(x - x.mean())))  # the phase, centred: no offset
    for t, m in enumerate(ms.tolist()):
        d = s[: -2 * m] - 2 * s[m:-m] + s[2 * m :]  # second differences
        inner = np.convolve(d, np.ones(m), mode="valid")[: counts[t]]
        assert a[t] == pytest.approx(float(np.sum(inner**2)), rel=1e-9)
    monkeypatch.setattr(diff, "MOD_PART", 1 << 62)  # one part: the sequential pass
    np.testing.assert_allclose(record_sums.modified_sums(phase, ms)[0], a, rtol=1e-13)


def test_threaded_kurtosis_kernels_are_bit_identical(force):
    from adavar.dynamic.kurtosis import kurtosis_contribution, sliding_kurtosis

    x = _record(30_000, seed=3)
    for call in (
        lambda: sliding_kurtosis(x, window=500),
        lambda: kurtosis_contribution(x, window=500, reference="window", segment=100),
        lambda: kurtosis_contribution(x, window=500, reference="record"),
    ):
        a, b = _both(force, call)
        np.testing.assert_array_equal(a, b)


def test_threaded_adaptive_controller_is_bit_identical(force):
    from adavar.dynamic.adaptive import adaptive_schedule

    x = _record(60_000, seed=5)
    x[30_000:32_000] += 3.0 * np.random.default_rng(1).standard_normal(2000)  # a disturbance
    paper = dict(lmax=600, lmin=400, l=100, thresholds="paper")  # the paper's controller
    a, b = _both(force, lambda: adaptive_schedule(x, rate=1.0, **paper).window)
    np.testing.assert_array_equal(a, b)
    assert a.min() < 600  # the controller did shorten the window


@pytest.mark.parametrize("where", ["spike", "offset step"])
def test_the_controller_survives_a_huge_burst(force, where):
    # a 1e12-sigma burst leaves the window's running sums with nothing but rounding: it
    # used to raise ZeroDivisionError (serial) or SystemError (parallel)
    from adavar.dynamic.adaptive import adaptive_schedule

    x = np.random.default_rng(2).standard_normal(60_000)
    if where == "spike":
        x[30_000:30_010] += 1e12
    else:
        x += 1e9
        x[30_000:32_000] *= 3.0
    paper = dict(lmax=600, lmin=400, l=100, thresholds="paper")  # the paper's controller
    a, b = _both(force, lambda: adaptive_schedule(x, rate=1.0, **paper).window)
    np.testing.assert_array_equal(a, b)
    assert 400 <= a.min() and a.max() <= 600


# --- the thread driver of the kernels ------------------------------------------------


@_jit.threaded_jit(cache=False)
def _count_items(out, fail_at, w_lo, w_hi):  # pragma: no cover - compiled
    for w in range(w_lo, w_hi):
        if w == fail_at:
            raise ValueError("item failed")
        out[w] += w + 1


@pytest.mark.parametrize("items", [1, 2, 7, 64])
def test_every_item_runs_once_on_any_number_of_threads(force, items):
    for which in ("serial", "parallel"):
        force(which)
        out = np.zeros(items)
        _count_items.run(1, items, out, -1)
        np.testing.assert_array_equal(out, np.arange(1, items + 1))


def test_an_error_in_an_item_reaches_the_caller_and_the_pool_goes_on(force):
    force("parallel")
    out = np.zeros(40)
    with pytest.raises(ValueError, match="item failed"):
        _count_items.run(1, 40, out, 17)
    assert out[17] == 0  # items after the failure may or may not have run: never twice
    assert set(np.unique(out)) <= set(np.arange(41.0))
    out = np.zeros(40)
    _count_items.run(1, 40, out, -1)
    np.testing.assert_array_equal(out, np.arange(1, 41))


def test_calls_from_many_threads_at_once_all_finish(force):
    # the batch and the readers call kernels from their own threads: the callers share one
    # pool, and none waits for an item another caller's thread has not started
    from concurrent.futures import ThreadPoolExecutor

    force("parallel")

    def one(k):
        out = np.zeros(50 + k)
        _count_items.run(1, out.size, out, -1)
        return np.array_equal(out, np.arange(1, out.size + 1))

    with ThreadPoolExecutor(8) as pool:
        assert all(pool.map(one, range(32)))


def test_a_forked_child_runs_threaded_kernels(force):
    import multiprocessing

    force("parallel")
    _count_items.run(1, 4, np.zeros(4), -1)  # the parent's pool exists before the fork
    context = multiprocessing.get_context("fork")
    with context.Pool(1) as pool:
        assert pool.apply(_child_sum, (64,)) == 64 * 65 // 2


def _child_sum(items):
    _jit.SERIAL_WORK = 0
    out = np.zeros(items)
    _count_items.run(1, items, out, -1)
    return int(out.sum())


def test_ctrl_c_in_the_calling_thread_stops_the_other_threads(force):
    import _thread
    import signal
    import threading
    import time

    force("parallel")
    out = np.zeros(200)

    def slow(out, lo, hi):  # a Python stand-in for a compiled kernel (sleeps without the GIL)
        for w in range(lo, hi):
            time.sleep(0.01)
            out[w] += 1

    kernel = object.__new__(_jit.ThreadedKernel)
    kernel.kernel = slow
    # a run started in the background ignores SIGINT (and then interrupt_main does nothing):
    # Python's own handler, as a terminal's Ctrl-C finds it
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        threading.Timer(0.1, _thread.interrupt_main).start()
        with pytest.raises(KeyboardInterrupt):
            kernel.run(1, out.size, out)
    finally:
        signal.signal(signal.SIGINT, previous)
    time.sleep(0.05)  # an item that was running when the interrupt came finishes
    done = out.sum()
    time.sleep(0.1)
    assert out.sum() == done < out.size  # and no thread starts another one
    assert set(np.unique(out)) <= {0.0, 1.0}


def test_a_larger_pool_replaces_the_smaller_one_whose_threads_end(monkeypatch):
    import threading
    import time

    monkeypatch.setattr(_jit, "_POOL", {})

    def kernel_threads():
        return [t for t in threading.enumerate() if t.name.startswith("adavar-kernel")]

    before = set(kernel_threads())
    small = _jit._pool(1)
    small.submit(time.sleep, 0.01).result()  # its thread has started
    large = _jit._pool(3)
    assert large is not small and _jit._pool(2) is large  # large enough: kept
    for _ in range(3):
        large.submit(time.sleep, 0.05)
    deadline = time.monotonic() + 5
    while len(set(kernel_threads()) - before) > 3 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert len(set(kernel_threads()) - before) <= 3  # the small pool's thread has ended
    large.shutdown(wait=True)


@pytest.mark.parametrize("least", [1, 16])
def test_grouped_items_cover_every_unit_once(least):
    for units in range(1, 300):
        per, items = _jit.grouped_items(units, least)
        assert per >= least and items <= max(1, _jit.work_items(units))
        assert per * (items - 1) < units <= per * items  # no empty item, none missing


def test_threaded_whole_record_kernels_are_bit_identical(force):
    """The integration pass and the overlapping sums of a record with an offset, a step and
    a drift: the same bits on one thread and on all (issue 42)."""
    from adavar._kernels import differences as diff
    from adavar.stats.statistics import deviation

    x = _record(300_000, seed=5)
    u = np.diff(x)
    a, b = _both(force, lambda: diff.anchored_phase(u, cluster_stats=True))
    for name in ("r", "hh", "hl", "cluster_stats", "fused"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    for stat in ("oadev", "ohdev", "totdev"):
        one, every = _both(force, lambda stat=stat: deviation(x, stat=stat, taus="octave"))
        np.testing.assert_array_equal(one.dev, every.dev, err_msg=stat)
        np.testing.assert_array_equal(one.edf, every.edf, err_msg=stat)


def test_whole_record_kernels_use_every_thread_above_the_threshold(monkeypatch):
    """Below RECORD_THREADS_MIN samples the calling thread alone (a thread's start costs
    more than the work), from it on the pool of the other threads (issue 42)."""
    import numba

    from adavar._kernels import differences as diff
    from adavar.stats.statistics import deviation

    if numba.get_num_threads() < 2:
        pytest.skip("one thread set for the kernels")
    monkeypatch.delenv("ADAVAR_SERIAL_KERNELS", raising=False)
    sizes = []
    real = _jit._pool
    monkeypatch.setattr(_jit, "_pool", lambda size: sizes.append(size) or real(size))
    x = np.random.default_rng(1).standard_normal(1 << 19)
    deviation(x, taus="octave", confidence=None, stationarity_check=False)
    assert sizes == []
    monkeypatch.setattr(diff, "RECORD_THREADS_MIN", 1 << 18)
    deviation(x, taus="octave", confidence=None, stationarity_check=False)
    assert len(sizes) >= 2 and min(sizes) == numba.get_num_threads() - 1


def test_threaded_noise_identification_and_stationarity_are_bit_identical(force):
    """The noise identification over taus and the stationarity check's block powers, of
    records with an offset, a step and a drift: the same bits on one thread and on all
    (issue 42)."""
    from adavar._kernels import differences as diff
    from adavar.stats import stationary_noise as sn
    from adavar.stats.stationary_noise import stationarity
    from adavar.stats.statistics import record_noise_types

    x = _record(300_000, seed=9)
    ms = 2 ** np.arange(17)  # the octaves, and a few taus the fused levels do not cover
    ms = np.unique(np.concatenate([ms, [3, 5, 10, 20, 50, 100, 1000]]))
    for dtype, u in (("rate", x - 1e9), ("phase", np.diff(x))):
        phase = diff.anchored_phase(u, cluster_stats=True)
        for dmax in (2, 3):
            one, every = _both(
                force, lambda p=phase, d=dmax, t=dtype: record_noise_types(p, ms, d, data_type=t)
            )
            np.testing.assert_array_equal(one[0], every[0])
        one, every = _both(force, lambda t=dtype: stationarity(x, data_type=t))
        assert repr(one) == repr(every)
    one, every = _both(force, lambda: sn._record_powers(x, 1e9, 256, 1171, 2, piece=4096))
    np.testing.assert_array_equal(one, every)


def test_noise_identification_and_stationarity_use_every_thread_above_the_threshold(
    monkeypatch,
):
    """The noise identification's passes over the data run their taus on every thread
    from NOISE_THREADS_MIN cluster sums on, the stationarity check its blocks from
    RECORD_THREADS_MIN samples on; below, the calling thread alone (issue 42)."""
    import numba

    from adavar._kernels import differences as diff
    from adavar.stats.stationary_noise import stationarity
    from adavar.stats.statistics import record_noise_types

    if numba.get_num_threads() < 2:
        pytest.skip("one thread set for the kernels")
    monkeypatch.delenv("ADAVAR_SERIAL_KERNELS", raising=False)
    sizes = []
    real = _jit._pool
    monkeypatch.setattr(_jit, "_pool", lambda size: sizes.append(size) or real(size))
    x = np.random.default_rng(1).standard_normal(1 << 19)
    phase = diff.anchored_phase(x, cluster_stats=True)
    # octaves: the fused levels settle m <= 32 without a pass, the longer taus read 6e4
    # cluster sums, below the threshold; m = 3 and 5 add 1.1e6, above it
    octaves = 2 ** np.arange(14)
    record_noise_types(phase, octaves, 2)
    stationarity(x)
    assert sizes == []
    record_noise_types(phase, np.concatenate([octaves, [3, 5]]), 2)
    assert sizes == [numba.get_num_threads() - 1]
    monkeypatch.setattr(diff, "RECORD_THREADS_MIN", 1 << 18)
    stationarity(x)
    assert sizes == [numba.get_num_threads() - 1] * 2

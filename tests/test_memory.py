"""Peak memory (issue 15): the fits of a surface and ``compare`` hold what they return.

tracemalloc sees NumPy's allocations. The fits run in blocks of curves
(``stack_fit.BLOCK_VALUES``, ``KERNEL_VALUES``); they are made small here so that the
bounds below, in surfaces (8 bytes a cell), hold on a record that takes a second.
"""

from __future__ import annotations

import os
import sys
import threading
import tracemalloc

import numpy as np
import pytest

import adavar
import adavar.fit.stack_fit as stack_fit
from adavar import simulate
from adavar.comparison import FIGURE_WINDOWS, compare
from adavar.dynamic import surface as davar_module


@pytest.fixture
def small_blocks(monkeypatch):
    monkeypatch.setattr(stack_fit, "BLOCK_VALUES", 1 << 14)
    monkeypatch.setattr(stack_fit, "KERNEL_VALUES", 1 << 16)
    monkeypatch.setattr(davar_module, "BLOCK_VALUES", 1 << 15)


def _peak(fn):
    """``fn()`` and its peak of traced memory above the start, bytes."""
    tracemalloc.start()
    try:
        out = fn()
        return out, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_compare_holds_one_surface_at_a_time(small_blocks, monkeypatch):
    """Before: every method's surface and its per-cell residuals, 11 surfaces at the peak
    for two methods (8.1 GB for four on a 30-minute 200 Hz record); then one surface at a
    time; now a block of windows of one (``adavar.dynamic.surface_fit``), and the same numbers."""
    x = simulate.white(20_000, seed=3)
    kw = dict(methods=["davar-150", "a-davar"], lmax=150, lmin=100, l=25, taus="all")
    compare(x[:1000], **kw)  # compiled outside the measurement
    lean, peak = _peak(lambda: compare(x, keep="figures", **kw))
    surface = 8 * x.size * 50  # taus m = 1 .. 150 // 3
    monkeypatch.setattr(davar_module, "BLOCK_VALUES", 1 << 30)  # the surface in one block
    _, peak_whole = _peak(lambda: compare(x, keep="figures", **kw))
    # what stays is the per-window output (N, the window and the coefficients of the
    # method being fitted: a few floats a window), the schedules and the record's copies;
    # 1.19 surfaces while the fit of every window was kept whole, 0.80 now
    assert peak < peak_whole - 0.5 * surface, (peak / surface, peak_whole / surface)
    assert peak < 1.0 * surface, peak / surface
    whole = compare(x, **kw)
    for name, run in whole.methods.items():
        got = lean.methods[name]
        np.testing.assert_array_equal(got.arw, run.arw)
        np.testing.assert_array_equal(got.window, run.window)
        # the lengths held once: the schedule's own array, a fixed window one value
        if got.schedule is not None:
            assert got.window is got.schedule.window
        else:
            assert got.window.strides == (0,) and not got.window.flags.writeable
        # the windows the surface figure draws, and only those, with their fits
        assert got.result.avar.shape == (FIGURE_WINDOWS, 50)
        rows = np.searchsorted(run.result.time, got.result.time)
        assert got.fit.coefficients.shape == (FIGURE_WINDOWS, 5)
        np.testing.assert_array_equal(got.fit.coefficients, run.fit.coefficients[rows])
        np.testing.assert_array_equal(got.fit.coefficient_uncertainty,
                                      run.fit.coefficient_uncertainty[rows])  # fmt: skip
        np.testing.assert_array_equal(got.fit.time, run.fit.time[rows])
        assert got.fit.residuals is None and run.fit.residuals is not None
        np.testing.assert_array_equal(got.result.avar, run.result.avar[rows])
        # no bounds that nothing reads; the EDF the fit weighted by is the same, from a
        # table of the drawn windows' rows only (the whole one has a row per edge window)
        assert got.result.avar_low is None and got.result.bound_table is None
        assert run.result.avar_low is not None
        np.testing.assert_array_equal(
            got.result.edf_table[got.result.window_class],
            run.result.edf_table[run.result.window_class[rows]],
        )
        assert got.result.edf_table.shape[0] == np.unique(got.result.window_class).size
        assert got.result.edf_table.shape[0] < run.result.edf_table.shape[0]
    np.testing.assert_array_equal(lean.time, whole.time)


def test_surface_fit_in_blocks_is_the_fit_at_once(small_blocks, monkeypatch):
    """The per-cell temporaries (EDF, masks, model, residuals) are a block's, not the
    surface's (7.2 surfaces at the peak before); the same numbers whatever the blocks."""
    x = simulate.sensor(8000, rate=100.0, angle_random_walk=0.01, rate_random_walk=1e-3,
                        bandwidth=20.0, seed=2)  # fmt: skip
    surface = adavar.davar(x, window=600, rate=100.0, taus="all")
    whole = adavar.fit_noise(adavar.deviation(x, rate=100.0))
    adavar.fit_noise(surface)  # compiled
    lean, peak = _peak(lambda: adavar.fit_noise(surface, cells=False, reference=whole))
    assert peak < 0.6 * surface.avar.nbytes, peak / surface.avar.nbytes
    assert lean.residuals is None and lean.used is None
    full, peak = _peak(lambda: adavar.fit_noise(surface, reference=whole))
    assert peak < 1.8 * surface.avar.nbytes, peak / surface.avar.nbytes  # with residuals
    monkeypatch.setattr(stack_fit, "BLOCK_VALUES", 1 << 30)
    monkeypatch.setattr(stack_fit, "KERNEL_VALUES", 1 << 30)
    once = adavar.fit_noise(surface, reference=whole)
    for field in ("coefficients", "coefficient_uncertainty", "chi2", "dof", "n_points"):
        np.testing.assert_array_equal(getattr(lean, field), getattr(once, field))
        np.testing.assert_array_equal(getattr(full, field), getattr(once, field))
    np.testing.assert_array_equal(full.used, once.used)
    # the model's matrix product may round differently on a block than on the whole
    np.testing.assert_allclose(full.residuals, once.residuals, rtol=1e-13, equal_nan=True)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc_trim")
def test_release_free_memory_returns_the_holes_a_thread_left():
    """What a text file's parser threads leave: freed blocks between live ones in their
    own arena, resident until trimmed (the live ones untouched)."""
    from adavar._kernels._heap import release_free_memory

    def rss() -> int:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

    kept: list[bytearray] = []

    def parse() -> None:
        blocks = [bytearray(40_000) for _ in range(2000)]  # below the mmap threshold
        for b in blocks:
            b[::4096] = b"\1" * len(b[::4096])  # every page resident
        kept.extend(blocks[::2])

    thread = threading.Thread(target=parse)
    thread.start()
    thread.join()
    before = rss()
    if not release_free_memory():
        pytest.skip("no malloc_trim in this C library")
    assert before - rss() > 20e6  # about half of the 80 MB
    assert all(len(b) == 40_000 and b[4096] == 1 for b in kept)

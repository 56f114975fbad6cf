"""A DAVAR surface a block of windows at a time: ``davar(rows=)`` and its block-wise fit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import adavar
from adavar import simulate
from adavar.core.errors import AdavarInputError
from adavar.core.thinning import spread_indices
from adavar.dynamic.surface import davar_blocks
from adavar.dynamic.surface_fit import concatenate_fits, drawn_rows, fit_davar_in_blocks

RATE = 200.0


@pytest.fixture(scope="module")
def gyro():
    """Six seconds of a 200 Hz MEMS gyro (40 Hz filter, LSB 1/131 deg/s) and a schedule
    of three window lengths, as an adaptive pass gives."""
    x = simulate.sensor(
        6000, rate=RATE, angle_random_walk=0.01, bias_instability=0.003, bandwidth=40.0,
        lsb=1 / 131, bias=0.5, seed=11,
    )  # fmt: skip
    window = np.r_[np.full(2500, 300), np.full(2000, 900), np.full(1500, 450)]
    return x, window


FIELDS = ("avar", "time", "window", "centre", "window_class")


@pytest.mark.parametrize(
    "options",
    [
        {},
        {"stat": "ohvar"},
        {"stat": "mvar", "taus": "octave"},
        {"data_type": "phase"},
        {"confidence": None},
        {"shift": "one-sided"},
    ],
    ids=["oavar", "ohvar", "mvar", "phase", "no-confidence", "shifted"],
)
def test_rows_are_the_whole_surfaces_rows(gyro, options):
    x, window = gyro
    options = dict(options)
    if options.get("data_type") == "phase":
        x = np.cumsum(x) / RATE
        window = window[1:]
    if options.get("shift") == "one-sided":
        options["shift"] = -(window // 2)
    whole = adavar.davar(x, window=window, rate=RATE, **options)
    n_rows = whole.time.size
    for start, stop in [(0, 1), (0, 700), (700, 2501), (2499, 4600), (5000, n_rows + 10)]:
        block = adavar.davar(x, window=window, rate=RATE, rows=(start, stop), **options)
        stop = min(stop, n_rows)
        for name in FIELDS:
            got, want = getattr(block, name), getattr(whole, name)
            if want is None:
                assert got is None
                continue
            np.testing.assert_array_equal(got, want[start:stop], err_msg=name)
            assert got.base is None or got.base.size == got.size  # not a view of the whole
        np.testing.assert_array_equal(block.alpha, whole.alpha)
        if whole.edf_table is not None:
            np.testing.assert_array_equal(block.edf_table, whole.edf_table)
            np.testing.assert_array_equal(block.bound_table, whole.bound_table)
            np.testing.assert_array_equal(block.avar_low, whole.avar_low[start:stop])
        if whole.shift is not None:
            np.testing.assert_array_equal(block.shift, whole.shift[start:stop])


def test_rows_refused_where_they_cannot_be_honoured(gyro):
    x, _ = gyro
    with pytest.raises(AdavarInputError, match="rows="):
        adavar.davar(x, window=300, rows=(6000, 6001))
    with pytest.raises(AdavarInputError, match="rows="):
        adavar.davar(x, window=300, rows=(10, 10))
    with pytest.raises(AdavarInputError, match="lazy"):
        adavar.davar(x, window=300, rows=(0, 10), lazy=True)
    gappy = x.copy()
    gappy[100:120] = np.nan
    with pytest.raises(AdavarInputError, match="missing samples"):
        adavar.davar(gappy, window=300, rows=(0, 10), gaps="omit")
    with pytest.raises(AdavarInputError, match="missing samples"):
        next(davar_blocks(gappy, window=300, gaps="omit"))
    with pytest.raises(AdavarInputError, match="rows="):
        davar_blocks(x, window=300, rows=(0, 10))
    with pytest.raises(AdavarInputError, match="block_values"):
        davar_blocks(x, window=300, block_values=0)
    with pytest.raises(TypeError):
        davar_blocks(x, window=300, no_such_option=1)


@pytest.mark.parametrize("block_values", [1, 20_000])
def test_davar_blocks_cover_the_surface(gyro, block_values):
    """Consecutive blocks of whole kernel chunks; together the whole surface, bit for bit."""
    x, window = gyro
    whole = adavar.davar(x, window=window, rate=RATE, taus="octave")
    blocks = list(davar_blocks(x, window=window, rate=RATE, taus="octave",
                               block_values=block_values))  # fmt: skip
    assert len(blocks) > 1
    for name in FIELDS:
        joined = np.concatenate([getattr(b, name) for b in blocks])
        np.testing.assert_array_equal(joined, getattr(whole, name), err_msg=name)
    for b in blocks:
        np.testing.assert_array_equal(b.edf_table, whole.edf_table)
        assert b.notes == whole.notes


@pytest.mark.parametrize("read", ["chunk_size", "memory map"])
def test_blocks_and_rows_of_a_record_read_piece_by_piece(gyro, tmp_path, read):
    """A file too large for memory gets its surface a block of windows at a time too:
    every block, every row and the fit equal those of the record in memory."""
    x, window = gyro
    x = np.concatenate([x, x[::-1], x])  # three kernel pieces and more
    window = np.concatenate([window, window[::-1], window])
    if read == "chunk_size":
        data, extra = x, {"chunk_size": 4096}
    else:
        np.save(tmp_path / "x.npy", x)
        data, extra = np.load(tmp_path / "x.npy", mmap_mode="r"), {}
    options = dict(window=window, rate=RATE, taus="octave", block_values=4000)
    memory = list(davar_blocks(x, **options))
    pieces = list(davar_blocks(data, **options, **extra))
    assert len(pieces) == len(memory) > 2
    for got, want in zip(pieces, memory, strict=True):
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name), name)
    rows = adavar.davar(data, window=window, rate=RATE, taus="octave", rows=(7000, 9000),
                        **extra)  # fmt: skip
    whole = adavar.davar(x, window=window, rate=RATE, taus="octave")
    np.testing.assert_array_equal(rows.avar, whole.avar[7000:9000])
    got = fit_davar_in_blocks(data, fit_options={"cells": False}, drawn=20, **options, **extra)
    want = fit_davar_in_blocks(x, fit_options={"cells": False}, drawn=20, **options)
    # the fit's reference, the whole record's curve, is streamed too: equal to rounding
    np.testing.assert_allclose(got.fit.coefficients, want.fit.coefficients, rtol=1e-9, atol=0)


@pytest.fixture(scope="module")
def whole_fit(gyro):
    """The gyro's whole surface at every tau and its fit (read by each block size)."""
    x, window = gyro
    whole = adavar.davar(x, window=window, rate=RATE, taus="all")
    return whole, adavar.fit_noise(whole, cells=False)


@pytest.mark.parametrize("block_values", [1, 30_000, 10**9])
def test_fit_in_blocks_is_the_fit_of_the_whole_surface(gyro, whole_fit, block_values):
    x, window = gyro
    whole, fit = whole_fit
    got = fit_davar_in_blocks(
        x, window=window, rate=RATE, taus="all", fit_options={"cells": False},
        drawn=50, block_values=block_values,
    )  # fmt: skip
    for name in ("coefficients", "coefficient_uncertainty", "chi2", "dof", "n_points", "time"):
        np.testing.assert_array_equal(getattr(got.fit, name), getattr(fit, name), err_msg=name)
    assert got.fit.tau is fit.tau or np.array_equal(got.fit.tau, fit.tau)
    np.testing.assert_array_equal(got.time, whole.time)
    np.testing.assert_array_equal(got.window, whole.window)
    np.testing.assert_array_equal(got.centre, whole.centre)
    rows, drawn = drawn_rows(whole, 50)
    np.testing.assert_array_equal(got.rows, rows)
    assert got.drawn.avar.shape == (50, whole.m.size)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(got.drawn, name), getattr(drawn, name))
    np.testing.assert_array_equal(got.drawn.time, whole.time[spread_indices(6000, 50)])


def test_fit_in_blocks_refuses_what_it_cannot_block(gyro):
    x, _ = gyro
    with pytest.raises(AdavarInputError, match="mirror"):
        fit_davar_in_blocks(x, window=300, edges="valid")
    with pytest.raises(AdavarInputError, match="rows="):
        fit_davar_in_blocks(x, window=300, rows=(0, 10))


def test_concatenate_fits_joins_the_curves(gyro):
    x, _ = gyro
    surface = adavar.davar(x, window=600, rate=RATE)
    fit = adavar.fit_noise(surface)
    blocks = [adavar.davar(x, window=600, rate=RATE, rows=r)
              for r in [(0, 1000), (1000, 1001), (1001, 6000)]]  # fmt: skip
    parts = [adavar.fit_noise(block) for block in blocks]
    joined = concatenate_fits(parts)
    for name in ("coefficients", "coefficient_uncertainty", "chi2", "reduced_chi2", "used"):
        np.testing.assert_array_equal(getattr(joined, name), getattr(fit, name), err_msg=name)
    # the next block's windows fitted with other terms
    other = adavar.fit_noise(blocks[1], terms=["angle_random_walk", "rate_random_walk"])
    with pytest.raises(ValueError, match="terms and taus"):
        concatenate_fits([parts[0], other])


@pytest.mark.parametrize(("edges", "step"), [("mirror", 7), ("valid", 1), ("valid", 5)])
def test_rows_and_blocks_with_steps_and_valid_edges(gyro, edges, step):
    x, _ = gyro
    whole = adavar.davar(x, window=500, rate=RATE, edges=edges, step=step, taus="octave")
    n_rows = whole.time.size
    block = adavar.davar(x, window=500, rate=RATE, edges=edges, step=step, taus="octave",
                         rows=(3, n_rows - 2))  # fmt: skip
    np.testing.assert_array_equal(block.avar, whole.avar[3 : n_rows - 2])
    np.testing.assert_array_equal(block.centre, whole.centre[3 : n_rows - 2])
    blocks = list(davar_blocks(x, window=500, rate=RATE, edges=edges, step=step,
                               taus="octave", block_values=1))  # fmt: skip
    np.testing.assert_array_equal(np.concatenate([b.avar for b in blocks]), whole.avar)
    if edges == "mirror":
        got = fit_davar_in_blocks(x, window=500, rate=RATE, step=step, taus="octave",
                                  block_values=1, drawn=10)  # fmt: skip
        np.testing.assert_array_equal(got.centre, whole.centre)
        np.testing.assert_array_equal(
            got.fit.coefficients, adavar.fit_noise(whole, cells=False).coefficients
        )
        np.testing.assert_array_equal(got.drawn.centre, whole.centre[spread_indices(n_rows, 10)])


@pytest.fixture(scope="module")
def step_gyro():
    """Twenty seconds of the 200 Hz gyro with a 2-second burst of extra noise (the
    controller shortens its window around it)."""
    x = simulate.sensor(
        4000, rate=RATE, angle_random_walk=0.01, bias_instability=0.003, bandwidth=40.0,
        lsb=1 / 131, bias=0.5, seed=12,
    )  # fmt: skip
    x[2000:2400] += 0.2 * np.random.default_rng(3).standard_normal(400)
    return x


ADAPTIVE_FIELDS = (*FIELDS, "kurtosis", "s", "f1", "f2", "f")


@pytest.mark.parametrize(
    "options",
    [{}, {"step": 7}, {"method": "ici"}, {"data_type": "phase"}, {"edges": "valid"},
     {"method": "kurtosis", "confidence": None}],
    ids=["adaptive", "step", "ici", "phase", "valid", "kurtosis-no-confidence"],
)  # fmt: skip
def test_adaptive_blocks_are_the_adaptive_surface(step_gyro, options):
    from adavar.dynamic.adaptive import adaptive_blocks

    x = np.cumsum(step_gyro) / RATE if options.get("data_type") == "phase" else step_gyro
    whole = adavar.adaptive_davar(x, rate=RATE, taus="octave", lmax=300, lmin=100, l=50,
                                  **options)  # fmt: skip
    assert np.any(whole.window < 300)  # the burst shortened windows
    blocks = list(adaptive_blocks(x, rate=RATE, taus="octave", lmax=300, lmin=100, l=50,
                                  block_values=3000, **options))  # fmt: skip
    assert len(blocks) > 1
    for name in ADAPTIVE_FIELDS:
        want = getattr(whole, name)
        if want is None:
            assert all(getattr(b, name) is None for b in blocks)
            continue
        joined = np.concatenate([getattr(b, name) for b in blocks])
        np.testing.assert_array_equal(joined, want, err_msg=name)
    for b in blocks:
        assert b.parameters == whole.parameters and b.method == whole.method
        assert b.notes == whole.notes
        np.testing.assert_array_equal(b.alpha, whole.alpha)


@pytest.mark.parametrize("options", [{}, {"step": 3}, {"method": "ici"}],
                         ids=["adaptive", "step", "ici"])  # fmt: skip
def test_adaptive_fit_in_blocks_is_the_fit_of_the_whole_surface(step_gyro, options):
    from adavar.dynamic.surface_fit import fit_adaptive_in_blocks

    common = dict(rate=RATE, taus="all", lmax=300, lmin=100, l=50, **options)
    whole = adavar.adaptive_davar(step_gyro, **common)
    fit = adavar.fit_noise(whole, cells=False)
    got = fit_adaptive_in_blocks(step_gyro, fit_options={"cells": False}, drawn=40,
                                 block_values=5000, bounds=False, **common)  # fmt: skip
    for name in ("coefficients", "coefficient_uncertainty", "chi2", "dof", "n_points", "time"):
        np.testing.assert_array_equal(getattr(got.fit, name), getattr(fit, name), err_msg=name)
    windows = got.windows
    assert isinstance(windows, adavar.AdaptiveResult)
    assert windows.avar.shape == (whole.time.size, 0) and windows.tau.size == 0
    for name in ADAPTIVE_FIELDS[1:]:
        if name == "window_class":  # no cells, so no EDF classes
            assert windows.window_class is None and windows.edf_table is None
            continue
        np.testing.assert_array_equal(getattr(windows, name), getattr(whole, name), name)
    assert windows.time is got.time and got.fit.time is got.time  # one copy
    assert got.n_windows == whole.time.size and got.n_taus == whole.tau.size
    rows, drawn = drawn_rows(whole, 40)
    np.testing.assert_array_equal(got.rows, rows)
    for name in ADAPTIVE_FIELDS:
        np.testing.assert_array_equal(getattr(got.drawn, name), getattr(drawn, name), name)
    assert got.drawn.avar_low is None  # bounds=False: none made


@pytest.mark.parametrize("options", [{}, {"step": 7}, {"data_type": "phase"}],
                         ids=["adaptive", "step", "phase"])  # fmt: skip
def test_adaptive_blocks_of_a_record_read_piece_by_piece(step_gyro, tmp_path, options):
    """The controller streams the file and each block reads its windows' span: every row
    equals the record in memory's, on a memory map and with chunk_size."""
    from adavar.dynamic.adaptive import adaptive_blocks

    x = np.cumsum(step_gyro) / RATE if options.get("data_type") == "phase" else step_gyro
    path = tmp_path / "x.npy"
    np.save(path, x)
    common = dict(rate=RATE, taus="octave", lmax=300, lmin=100, l=50, block_values=3000,
                  **options)  # fmt: skip
    memory = list(adaptive_blocks(x, **common))
    for pieces in (list(adaptive_blocks(np.load(path, mmap_mode="r"), **common)),
                   list(adaptive_blocks(x, chunk_size=1000, **common))):  # fmt: skip
        assert len(pieces) == len(memory) > 1
        for name in (*FIELDS, "kurtosis", "s", "f"):
            np.testing.assert_array_equal(
                np.concatenate([getattr(b, name) for b in pieces]),
                np.concatenate([getattr(b, name) for b in memory]), err_msg=name,
            )  # fmt: skip


def test_adaptive_blocks_refuse_what_they_cannot_block(step_gyro):
    import dask.array as da

    from adavar.dynamic.adaptive import adaptive_blocks

    with pytest.raises(AdavarInputError, match="dask"):
        next(adaptive_blocks(da.from_array(step_gyro, chunks=1000), rate=RATE))
    with pytest.raises(AdavarInputError, match="block_values"):
        next(adaptive_blocks(step_gyro, rate=RATE, block_values=0))
    with pytest.raises(TypeError):
        next(adaptive_blocks(step_gyro, rate=RATE, no_such_option=1))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(1, 40), min_size=1, max_size=8), st.integers(0, 5),
       st.sampled_from(["views", "copies", "view-then-copy", "strided"]))  # fmt: skip
def test_joined_rows_are_the_concatenation(sizes, offset, kind):
    """Blocks that are consecutive views of one array join to a view of it; any other
    blocks to a copy; either way the concatenation of the blocks."""
    from adavar.dynamic.surface_fit import _Joined

    total = sum(sizes)
    base = np.arange(offset + 2 * total + 3, dtype=float) * 1.5
    parts, start = [], 0
    for k, size in enumerate(sizes):
        if kind == "views" or (kind == "view-then-copy" and k < len(sizes) - 1):
            part = base[offset + start : offset + start + size]
        elif kind == "strided":
            part = base[offset + 2 * start : offset + 2 * (start + size) : 2]
        else:
            part = base[offset + start : offset + start + size].copy()
        parts.append((part, start))
        start += size
    joined = _Joined(total)
    for part, at in parts:
        joined.add(part, at)
    got = joined.array()
    np.testing.assert_array_equal(got, np.concatenate([p for p, _ in parts]))
    assert np.shares_memory(got, base) == (kind == "views")  # view-then-copy ends in a copy


@pytest.fixture(scope="module")
def step_gyro_fit(step_gyro):
    """The fit of the whole adaptive surface of ``step_gyro`` at octave taus."""
    common = dict(rate=RATE, taus="octave", lmax=300, lmin=100, l=50)
    return adavar.fit_noise(adavar.adaptive_davar(step_gyro, **common), cells=False)


@pytest.mark.parametrize("fit_rows", ["drawn", lambda n: np.array([0, 5, n // 2, n - 1])])
def test_fit_rows_keep_the_whole_fit_of_some_windows(step_gyro, step_gyro_fit, fit_rows):
    """Every window's coefficients, and the whole fit (uncertainties, chi-square) of the
    windows asked for only; the same numbers as the fit of the whole surface."""
    from adavar.dynamic.surface_fit import fit_adaptive_in_blocks

    common = dict(rate=RATE, taus="octave", lmax=300, lmin=100, l=50)
    whole = step_gyro_fit
    got = fit_adaptive_in_blocks(step_gyro, fit_options={"cells": False}, drawn=30,
                                 block_values=2000, fit_rows=fit_rows, **common)  # fmt: skip
    n = whole.time.size
    rows = got.rows if fit_rows == "drawn" else np.array([0, 5, n // 2, n - 1])
    np.testing.assert_array_equal(got.fit_rows, rows)
    np.testing.assert_array_equal(got.coefficients, whole.coefficients)
    for name in ("coefficients", "coefficient_uncertainty", "chi2", "dof", "time"):
        np.testing.assert_array_equal(getattr(got.fit, name), getattr(whole, name)[rows], name)
    for name in whole.terms:
        np.testing.assert_array_equal(got.term_values(name), whole.term(name).value)
    everything = fit_adaptive_in_blocks(step_gyro, fit_options={"cells": False},
                                        block_values=2000, **common)  # fmt: skip
    assert everything.fit_rows is None and everything.coefficients is everything.fit.coefficients
    spilled = fit_adaptive_in_blocks(step_gyro, fit_options={"cells": False}, drawn=30,
                                     block_values=2000, fit_rows=fit_rows, spill=True,
                                     **common)  # fmt: skip
    assert spilled.coefficients is None and spilled.spilled is not None
    np.testing.assert_array_equal(spilled.fit.coefficients, got.fit.coefficients)
    for name in whole.terms:
        want = whole.term(name).value
        np.testing.assert_array_equal(spilled.term_values(name), want)
        for start, stop in ((0, 1), (3, n // 2), (n - 7, None), (n // 3, n // 3)):
            np.testing.assert_array_equal(spilled.term_values(name, start, stop),
                                          want[start:stop])  # fmt: skip
        reader = spilled.term_reader(name)
        assert len(reader) == n
        np.testing.assert_array_equal(reader[5 : n - 5], want[5 : n - 5])
        with pytest.raises(TypeError, match="slices"):
            reader[[1, 2]]
    import pickle

    carried = pickle.loads(pickle.dumps(spilled))  # another process gets the values
    assert carried.spilled.files is None
    for name in whole.terms:
        np.testing.assert_array_equal(carried.term_values(name), whole.term(name).value)
    with pytest.raises(AdavarInputError, match="fit_rows"):
        fit_adaptive_in_blocks(step_gyro, fit_rows="some", **common)
    with pytest.raises(AdavarInputError, match="increasing"):
        fit_adaptive_in_blocks(step_gyro, fit_rows=lambda n: np.array([3, 1]), **common)


def test_spilled_coefficients_fall_back_or_fail_clearly(step_gyro, monkeypatch):
    """No temporary folder: the coefficients stay in memory; a full one: a one-line error
    that names TMPDIR."""
    import tempfile

    from adavar.dynamic import surface_fit

    common = dict(rate=RATE, taus="octave", lmax=300, lmin=100, l=50, block_values=2000,
                  fit_options={"cells": False}, fit_rows="drawn")  # fmt: skip
    want = surface_fit.fit_adaptive_in_blocks(step_gyro, **common)

    def refuse():
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tempfile, "TemporaryFile", refuse)
    held = surface_fit.fit_adaptive_in_blocks(step_gyro, spill=True, **common)
    assert held.spilled is None
    np.testing.assert_array_equal(held.coefficients, want.coefficients)

    class Full:
        def seek(self, offset):
            pass

        def write(self, data):
            raise OSError(28, "No space left on device")

    monkeypatch.setattr(tempfile, "TemporaryFile", Full)
    with pytest.raises(AdavarInputError, match="TMPDIR") as caught:
        surface_fit.fit_adaptive_in_blocks(step_gyro, spill=True, **common)
    assert "\n" not in str(caught.value) and "No space left" in str(caught.value)


@pytest.mark.parametrize("fit_rows", ["all", "drawn"])
def test_blocks_fitted_a_few_windows_at_a_time_are_the_whole_fit(step_gyro, monkeypatch,
                                                                fit_rows):  # fmt: skip
    """A block's windows fitted FIT_ROWS at a time (37 here: every block cut unevenly)
    give the whole surface's fit, bit for bit."""
    from adavar.dynamic import surface_fit

    monkeypatch.setattr(surface_fit, "FIT_ROWS", 37)
    common = dict(rate=RATE, taus="octave", lmax=300, lmin=100, l=50)
    whole = adavar.fit_noise(adavar.adaptive_davar(step_gyro, **common), cells=False)
    got = surface_fit.fit_adaptive_in_blocks(step_gyro, fit_options={"cells": False},
                                             drawn=30, block_values=2000, fit_rows=fit_rows,
                                             spill=fit_rows == "drawn", **common)  # fmt: skip
    for name in whole.terms:
        np.testing.assert_array_equal(got.term_values(name), whole.term(name).value)
    rows = slice(None) if fit_rows == "all" else got.rows
    for name in ("coefficients", "coefficient_uncertainty", "chi2", "dof", "time"):
        np.testing.assert_array_equal(getattr(got.fit, name), getattr(whole, name)[rows], name)

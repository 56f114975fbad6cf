"""Window schedules: centres, lengths, mirror padding and the even-length convention."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from adavar.core.errors import AdavarInputError
from adavar.dynamic import windows as windows_module
from adavar.dynamic.windows import (
    EDGES,
    MIN_WINDOW,
    WindowSchedule,
    centre_range,
    window_classes,
    window_overhang,
    window_schedule,
    window_start,
)


def _expected(n, lengths_per_candidate, edges, step):
    """Centres, lengths and pads straight from the convention."""
    centres = np.arange(0, n, step)
    lengths = np.asarray(lengths_per_candidate)
    starts = centres - (lengths - 1) // 2
    if edges == "valid":
        keep = (starts >= 0) & (starts + lengths <= n)
        centres, lengths, starts = centres[keep], lengths[keep], starts[keep]
        return centres, lengths, 0, 0
    return centres, lengths, max(0, -int(starts.min())), max(0, int((starts + lengths).max()) - n)


def _mirror(v, j):
    """Sample j of the record extended by time reversal about both ends (|overhang| <= N)."""
    n = len(v)
    if j < 0:
        return v[-j - 1]  # w*[-j] = w[j - 1]
    if j >= n:
        return v[2 * n - 1 - j]  # w*[N - 1 + j] = w[N - j]
    return v[j]


def _check(sched, n, lengths_per_candidate, edges, step):
    centres, lengths, before, after = _expected(n, lengths_per_candidate, edges, step)
    assert isinstance(sched, WindowSchedule)
    np.testing.assert_array_equal(sched.centre, centres)
    np.testing.assert_array_equal(sched.length, lengths)
    assert sched.centre.dtype == np.int64 and sched.length.dtype == np.int64
    assert (sched.pad_before, sched.pad_after) == (before, after)
    assert sched.n_samples == n and sched.edges == edges and sched.step == step
    np.testing.assert_array_equal(sched.start, centres - (lengths - 1) // 2 + before)
    v = np.random.default_rng(n).standard_normal(n)
    ext = sched.extend(v)
    np.testing.assert_array_equal(ext, np.pad(v, (before, after), mode="symmetric"))
    assert ext.size == before + n + after
    # every window, read from the extended record, is the mirrored samples it should hold
    for p, L, s in zip(sched.centre, sched.length, sched.start, strict=True):
        a = p - (L - 1) // 2
        assert s >= 0 and s + L <= ext.size
        want = [_mirror(v, j) for j in range(a, a + L)]
        np.testing.assert_array_equal(ext[s : s + L], want)


# ---------------------------------------------------------------------------------------
# fixed lengths


def test_odd_window_mirror_example():
    sched = window_schedule(10, 5)
    np.testing.assert_array_equal(sched.centre, np.arange(10))
    np.testing.assert_array_equal(sched.length, np.full(10, 5))
    assert (sched.pad_before, sched.pad_after) == (2, 2)
    np.testing.assert_array_equal(sched.start, np.arange(10))


def test_even_window_mirror_example():
    """L = 4: one sample before the centre, two after."""
    sched = window_schedule(10, 4)
    assert (sched.pad_before, sched.pad_after) == (1, 2)
    np.testing.assert_array_equal(sched.start, np.arange(10))
    v = np.arange(10.0)
    ext = sched.extend(v)
    # centre 0 holds v[-1], v[0], v[1], v[2] with v[-1] = v[0] (time reversal)
    np.testing.assert_array_equal(ext[sched.start[0] : sched.start[0] + 4], [0, 0, 1, 2])
    # centre 9 holds v[8], v[9], v[10], v[11] = v[8], v[9], v[9], v[8]
    np.testing.assert_array_equal(ext[sched.start[9] : sched.start[9] + 4], [8, 9, 9, 8])


def test_valid_examples():
    sched = window_schedule(10, 4, edges="valid")
    np.testing.assert_array_equal(sched.centre, np.arange(1, 8))
    assert (sched.pad_before, sched.pad_after) == (0, 0)
    np.testing.assert_array_equal(sched.start, sched.centre - 1)
    sched = window_schedule(10, 5, edges="valid")
    np.testing.assert_array_equal(sched.centre, np.arange(2, 8))
    sched = window_schedule(10, 10, edges="valid")
    np.testing.assert_array_equal(sched.centre, [4])
    sched = window_schedule(11, 5, edges="valid", step=3)
    np.testing.assert_array_equal(sched.centre, [3, 6])
    v = np.arange(11.0)
    assert sched.extend(v) is v


def test_step_examples():
    sched = window_schedule(10, 5, step=3)
    np.testing.assert_array_equal(sched.centre, [0, 3, 6, 9])
    assert (sched.pad_before, sched.pad_after) == (2, 2)
    sched = window_schedule(12, 5, step=3)  # last centre 9: window 7..11, no overhang
    np.testing.assert_array_equal(sched.centre, [0, 3, 6, 9])
    assert (sched.pad_before, sched.pad_after) == (2, 0)
    sched = window_schedule(10, 3, step=20)
    np.testing.assert_array_equal(sched.centre, [0])
    assert (sched.pad_before, sched.pad_after) == (1, 0)


@pytest.mark.parametrize("edges", EDGES)
@pytest.mark.parametrize("step", [1, 2, 3, 7])
@pytest.mark.parametrize("L", [3, 4, 5, 8, 15, 16, 29, 30])
def test_fixed_lengths(L, step, edges):
    n = 30
    if edges == "valid" and _expected(n, np.full(math.ceil(n / step), L), edges, step)[0].size == 0:
        with pytest.raises(AdavarInputError):
            window_schedule(n, L, edges=edges, step=step)
        return
    sched = window_schedule(n, L, edges=edges, step=step)
    _check(sched, n, np.full(math.ceil(n / step), L), edges, step)


def test_window_of_the_whole_record_mirrors_it_entirely():
    sched = window_schedule(6, 6)
    assert (sched.pad_before, sched.pad_after) == (2, 3)
    v = np.arange(6.0)
    np.testing.assert_array_equal(sched.extend(v), [1, 0, 0, 1, 2, 3, 4, 5, 5, 4, 3])


def test_window_start():
    assert window_start(10, 5) == 8
    assert window_start(10, 4) == 9
    assert window_start(0, 3) == -1
    np.testing.assert_array_equal(window_start(np.array([5, 5, 5]), np.array([3, 4, 6])), [4, 4, 3])


# ---------------------------------------------------------------------------------------
# per-sample and per-centre lengths


@pytest.mark.parametrize("edges", EDGES)
@pytest.mark.parametrize("step", [1, 2, 5])
def test_per_sample_lengths(step, edges):
    n = 40
    lengths = np.random.default_rng(step).integers(3, 25, size=n)
    sched = window_schedule(n, lengths, edges=edges, step=step)
    _check(sched, n, lengths[::step], edges, step)


@pytest.mark.parametrize("step", [2, 3, 6])
def test_per_centre_lengths(step):
    n = 40
    lengths = np.random.default_rng(step).integers(3, 25, size=math.ceil(n / step))
    sched = window_schedule(n, lengths, step=step)
    _check(sched, n, lengths, "mirror", step)


def test_per_sample_lengths_as_whole_floats():
    lengths = np.array([3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0])
    sched = window_schedule(12, np.r_[lengths, 5.0, 5.0])
    np.testing.assert_array_equal(sched.length, np.r_[lengths, 5, 5].astype(np.int64))


def test_per_sample_valid_keeps_only_fitting_windows():
    lengths = np.array([9, 3, 9, 3, 9, 3, 9, 3, 9, 3])
    sched = window_schedule(10, lengths, edges="valid")
    # L = 9 fits at centres 4 only; L = 3 at every centre but 0 and 9
    np.testing.assert_array_equal(sched.centre, [1, 3, 4, 5, 7])
    np.testing.assert_array_equal(sched.length, [3, 3, 9, 3, 3])


# ---------------------------------------------------------------------------------------
# properties


@st.composite
def _schedules(draw):
    n = draw(st.integers(3, 80))
    step = draw(st.integers(1, 12))
    edges = draw(st.sampled_from(EDGES))
    kind = draw(st.sampled_from(["int", "per_sample", "per_centre"]))
    if kind == "int":
        window = draw(st.integers(MIN_WINDOW, n))
        per_candidate = np.full(math.ceil(n / step), window)
    else:
        count = n if kind == "per_sample" or edges == "valid" else math.ceil(n / step)
        window = np.array(
            draw(st.lists(st.integers(MIN_WINDOW, n), min_size=count, max_size=count))
        )
        per_candidate = window[::step] if count == n else window
    return n, window, per_candidate, edges, step


@settings(max_examples=200, deadline=None)
@given(_schedules())
def test_property_schedule(case):
    n, window, per_candidate, edges, step = case
    centres = _expected(n, per_candidate, edges, step)[0]
    if centres.size == 0:
        with pytest.raises(AdavarInputError):
            window_schedule(n, window, edges=edges, step=step)
        return
    _check(window_schedule(n, window, edges=edges, step=step), n, per_candidate, edges, step)


# ---------------------------------------------------------------------------------------
# bad input


@pytest.mark.parametrize(
    ("window", "kw"),
    [
        (2, {}),
        (31, {}),
        (np.full(29, 5), {}),
        (np.full(30, 5.5), {}),
        (np.r_[np.full(29, 5), 1], {}),
        (np.full((2, 15), 5), {}),
        (True, {}),
        (5, {"step": 0}),
        (5, {"step": -2}),
        (5, {"step": 1.0}),
        (5, {"edges": "wrap"}),
        (30, {"edges": "valid", "step": 4}),
    ],
)
def test_bad_schedules(window, kw):
    with pytest.raises(AdavarInputError) as info:
        window_schedule(30, window, **kw)
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------------------------------
# the EDF classes of the windows, a range at a time


def _classes_at_once(sched: WindowSchedule, edges_apart: bool) -> tuple[np.ndarray, ...]:
    """The classes as the surface found them before (every window at once): interior
    windows by length, edge windows by (length, overhang) in lexicographic order."""
    distinct = np.unique(sched.length)
    classes = np.searchsorted(distinct, sched.length)
    pairs = np.empty((0, 2), dtype=np.int64)
    if edges_apart:
        overhang = window_overhang(sched.window_centre, sched.length, sched.n_samples)
        edge = np.flatnonzero(overhang > 0)
        if edge.size:
            keys = np.stack([sched.length[edge], overhang[edge]], axis=1)
            pairs, inverse = np.unique(keys, axis=0, return_inverse=True)
            classes[edge] = distinct.size + inverse.ravel()
    return distinct, pairs, classes


@settings(max_examples=150, deadline=None)
@given(_schedules(), st.booleans(), st.booleans(), st.integers(1, 9), st.data())
def test_window_classes_by_ranges_are_those_of_every_window_at_once(
    case, shifted, edges_apart, scan, data
):
    n, window, _, edges, step = case
    shift = None
    if shifted:  # one-sided windows of the ICI: centred windows at shifted centres
        shift = np.array(data.draw(st.lists(st.integers(-n // 3, n // 3), min_size=n,
                                            max_size=n)), dtype=np.int64)  # fmt: skip
    try:
        sched = window_schedule(n, window, edges=edges, step=step, shift=shift)
    except AdavarInputError:
        return
    distinct, pairs, want = _classes_at_once(sched, edges_apart)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(windows_module, "_SCAN_ROWS", scan)  # ranges cut across the scans
        classes = window_classes(sched, edges_apart=edges_apart)
        np.testing.assert_array_equal(classes.lengths, distinct)
        np.testing.assert_array_equal(classes.edge_pairs.reshape(-1, 2), pairs)
        assert classes.n_classes == distinct.size + pairs.shape[0]
        np.testing.assert_array_equal(classes.rows(), want)
        a = data.draw(st.integers(0, want.size))
        b = data.draw(st.integers(a, want.size + 3))
        np.testing.assert_array_equal(classes.rows(a, b), want[a:b])


def test_window_classes_of_a_long_window_on_a_long_record():
    """Lengths near the record's and overhangs of many thousands: the codes that order
    the (length, overhang) pairs do not overflow or collide."""
    n = 3_000_000
    sched = window_schedule(n, np.arange(n) % 977 + n // 2, edges="mirror", step=7)
    classes = window_classes(sched)
    distinct, pairs, want = _classes_at_once(sched, True)
    np.testing.assert_array_equal(classes.lengths, distinct)
    np.testing.assert_array_equal(classes.edge_pairs, pairs)
    np.testing.assert_array_equal(classes.rows(), want)


def test_centre_range_is_one_read_only_array_while_held():
    first = centre_range(0, 1000, 3)
    np.testing.assert_array_equal(first, np.arange(0, 1000, 3))
    assert first.dtype == np.int64 and not first.flags.writeable
    assert centre_range(0, 1000, 3) is first  # the controller's and the surface's
    assert centre_range(0, 1000, 1) is not first
    other = centre_range(0, 1001, 3)
    np.testing.assert_array_equal(other, np.arange(0, 1001, 3))
    with pytest.raises(ValueError):
        first[0] = 5

"""Tests of adavar.stats.edf.edf_lengths, the EDF of one (stat, alpha, m) at many record lengths.

The reference is the scalar :func:`adavar.stats.edf.edf` (Greenhall's algorithm one length at a
time): the vectorised values must agree with it to 1e-12 relative (they differ by a few
ulps, the sums being taken in another order) at every statistic, alpha (including values
clamped to the statistic's range), m up to ~5000 and lengths from the shortest valid to
1e9, in particular at the boundaries between Greenhall's cases. ``davar.edf_table`` is
checked against the code it had before (scalar EDFs in list comprehensions, written out
here).
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import PchipInterpolator

from adavar.dynamic import surface_common
from adavar.stats import edf as edf_mod
from adavar.stats.edf import EDF_FLOOR, STAT_ALPHA_RANGE, TOTDEV_EDF_METHODS, edf, edf_lengths

from .test_edf import STATS

# (d, overlapping, modified) of the Greenhall estimator behind each statistic (test_edf's
# table); totdev's Greenhall cases (PM noise, m = 1) are those of oadev
GREENHALL = {**STATS, "totdev": STATS["oadev"]}
J_MAX = 100  # Greenhall's Jmax, the default of greenhall_edf


def _points(stat: str, m: int, terms: int) -> int:
    """The shortest record (phase points) with ``terms`` Greenhall terms M at ``m``."""
    d, overlapping, modified = GREENHALL[stat]
    span = (m if modified else 1) + m * d  # L = m/F + m d
    return span + (terms - 1) * (m if not overlapping else 1)


def _boundary_terms(stat: str, m: int) -> list[int]:
    """Term counts M at and next to every case boundary of Greenhall's algorithm.

    ``M = (d+1)S`` (J reaches its constant, ``r = d + 1``: table or ``m'`` beyond it),
    ``M = J_max`` (the explicit sum's limit when ``(d+1)S > J_max``), ``M = kS`` (white
    PM: ``ceil(r)`` steps), and the shortest records.
    """
    d, overlapping, _ = GREENHALL[stat]
    s = m if overlapping else 1
    marks = {1, 2, 3, J_MAX - 1, J_MAX, J_MAX + 1}
    for k in range(1, d + 3):
        marks |= {k * s - 1, k * s, k * s + 1}
    return sorted(t for t in marks if t >= 1)


def _case(stat: str, alpha: int, m: int, n_phase: int) -> str:
    """Which branch of greenhall_edf a (clamped) case takes."""
    d, overlapping, modified = GREENHALL[stat]
    s = m if overlapping else 1
    terms = 1 + (s * (n_phase - _points(stat, m, 1))) // m
    j = min(terms, (d + 1) * s)
    if alpha == 2 and not modified:
        return "white PM"
    if j <= J_MAX:
        return "sum, J = (d+1)S" if j == (d + 1) * s else "sum, J = M"
    return "table" if terms / s > d + 1 else "m'"


def _scalar(stat: str, alpha: int, m: int, lengths: Any, method: str = "sp1065") -> np.ndarray:
    return np.array([edf(stat, alpha, m, int(n), totdev_edf=method) for n in lengths])


@st.composite
def _cases(draw: Any) -> tuple[str, int, int, str, list[int]]:
    stat = draw(st.sampled_from(sorted(GREENHALL)))
    lo, hi = STAT_ALPHA_RANGE[stat]
    alpha = draw(st.integers(lo - 2, hi + 2))  # beyond the range: clamped as by edf
    m = draw(st.one_of(st.integers(1, 40), st.integers(1, 5000)))
    method = draw(st.sampled_from(TOTDEV_EDF_METHODS))
    shortest = _points(stat, m, 1)
    marks = [_points(stat, m, t) for t in _boundary_terms(stat, m)]
    lengths = [shortest]
    lengths += draw(st.lists(st.sampled_from(marks), max_size=8))
    lengths += [shortest + x for x in draw(st.lists(st.integers(0, 4 * J_MAX * m), max_size=6))]
    lengths += [shortest + x for x in draw(st.lists(st.integers(0, 10**9), max_size=4))]
    return stat, alpha, m, method, lengths


@settings(max_examples=300, deadline=None)
@given(case=_cases(), pick=st.integers(0, 10**6))
def test_edf_lengths_equals_scalar_edf(case, pick):
    stat, alpha, m, method, lengths = case
    got = edf_lengths(stat, alpha, m, np.array(lengths), totdev_edf=method)
    want = _scalar(stat, alpha, m, lengths, method)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
    assert np.all(got >= EDF_FLOOR)
    # a value depends on its own length only: the same alone, with nothing kept from before
    i = pick % len(lengths)
    edf_mod._MPRIME_SUMS.clear()
    alone = edf_lengths(stat, alpha, m, [lengths[i]], totdev_edf=method)
    assert alone[0] == got[i]


@pytest.mark.parametrize("stat", sorted(GREENHALL))
def test_every_case_boundary(stat):
    """Deterministic: every alpha at every case boundary of m's around the thresholds."""
    lo, hi = STAT_ALPHA_RANGE[stat]
    # 25/26 and 33/34: m (d+1) <= J_max decides F of case 2; 34: (d+1) m > J_max
    ms = [1, 2, 3, 7, 24, 25, 26, 33, 34, 35, 50, 51, 99, 100, 101, 1000, 4999]
    seen = set()
    for m in ms:
        lengths = [_points(stat, m, t) for t in _boundary_terms(stat, m)]
        lengths += [_points(stat, m, 1) + 10**9]
        for alpha in range(lo, hi + 1):
            got = edf_lengths(stat, alpha, m, lengths)
            np.testing.assert_allclose(got, _scalar(stat, alpha, m, lengths), rtol=1e-12, atol=0)
            seen |= {_case(stat, alpha, m, n) for n in lengths}
    _, overlapping, modified = GREENHALL[stat]
    want = {"sum, J = (d+1)S", "sum, J = M"}
    if overlapping:  # S = m: J = min(M, (d+1)m) passes J_max (with S = 1, J <= d + 1)
        want |= {"table", "m'"}
    if not modified:  # the modified variances have no white PM case of their own
        want.add("white PM")
    assert want <= seen


def test_shape_repeats_and_empty():
    lengths = np.array([[31, 400, 31], [10**6, 72, 400]], dtype=np.int32)
    got = edf_lengths("oadev", 1, 10, lengths)
    assert got.shape == lengths.shape and got.dtype == np.float64
    np.testing.assert_allclose(
        got.ravel(), _scalar("oadev", 1, 10, lengths.ravel()), rtol=1e-12, atol=0
    )
    assert got[0, 0] == got[0, 2] and got[0, 1] == got[1, 2]
    assert edf_lengths("ohdev", -3, 5, []).shape == (0,)
    assert edf_lengths("oadev", 0, 5, 1000).shape == ()  # a scalar in, a 0-d array out


@pytest.mark.parametrize(
    ("stat", "m", "lengths"),
    [
        ("oadev", 10, [21, 30, 20, 5]),  # the first too short is named
        ("adev", 4, [100, 3]),
        ("mdev", 10, [31, 29]),
        ("hdev", 10, [30]),
        ("ohdev", 3, [13, 9]),
        ("totdev", 10, [21, 20]),
    ],
)
def test_too_short_raises_as_edf(stat, m, lengths):
    first = next(n for n in lengths if n < _points(stat, m, 1))
    with pytest.raises(ValueError) as scalar:
        edf(stat, 0, m, first)
    with pytest.raises(ValueError, match=re.escape(str(scalar.value))):
        edf_lengths(stat, 0, m, lengths)


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        (("vdev", 0, 1, [100]), {}, "unknown statistic"),
        (("adev", 0, 0, [100]), {}, "m must be"),
        (("totdev", 0, 2, [100]), {"totdev_edf": "nist"}, "totdev_edf must be"),
    ],
)
def test_bad_inputs_raise_as_edf(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        edf(*args[:3], args[3][0], **kwargs)
    with pytest.raises(ValueError, match=match):
        edf_lengths(*args, **kwargs)


def test_edf_floor(monkeypatch):
    def below(alpha, d, m, n_phase, **kwargs):
        return np.where(n_phase % 2 == 0, 0.3, np.inf)

    monkeypatch.setattr(edf_mod, "_greenhall_lengths", below)
    np.testing.assert_array_equal(edf_lengths("oadev", 0, 5, [1000, 1001]), EDF_FLOOR)
    # totvar: b T/tau - c at the shortest record is 0.93 * 2 - 0.36 = 1.5, above the floor
    assert edf_lengths("totdev", -2, 10, [21])[0] == pytest.approx(1.5)


def test_case_names_are_sound():
    """The test's own case classifier against the boundaries it is meant to mark."""
    assert _case("oadev", 0, 10, _points("oadev", 10, 30)) == "sum, J = (d+1)S"
    assert _case("oadev", 0, 10, _points("oadev", 10, 29)) == "sum, J = M"
    assert _case("oadev", 0, 50, _points("oadev", 50, 150)) == "m'"
    assert _case("oadev", 0, 50, _points("oadev", 50, 151)) == "table"
    assert _case("adev", 2, 50, _points("adev", 50, 151)) == "white PM"


# ---------------------------------------------------------------------------------------
# davar.edf_table against the code it had before (one scalar EDF per length)


def _old_grid(stat: str, alpha: int, m: int, k_lo: int, k_hi: int) -> tuple[Any, Any, Any]:
    k = np.arange(k_lo, k_hi)
    nodes = np.unique(np.round(64 * 2.0 ** (k / 8))).astype(np.int64)
    width = surface_common.term_width(stat, m)
    values = np.array([edf(stat, alpha, m, int(g) + width) for g in nodes])
    return nodes, values, PchipInterpolator(np.log(nodes), np.log(values))


def _old_edf_of_counts(counts: np.ndarray, alpha: int, m: int, stat: str) -> np.ndarray:
    counts = np.asarray(counts, dtype=np.int64)
    width = surface_common.term_width(stat, m)
    exact = counts <= 64
    out = np.empty(counts.size)
    out[exact] = [edf(stat, alpha, m, int(c) + width) for c in counts[exact]]
    big = counts[~exact]
    if big.size:
        pos = np.log2(big / 64) * 8
        k_lo = max(0, int(np.floor(pos.min())) - 2)
        k_hi = int(np.ceil(pos.max())) + 3
        nodes, values, curve = _old_grid(stat, alpha, m, k_lo, k_hi)
        on_node = np.isin(big, nodes)
        vals = np.exp(curve(np.log(big)))
        vals[on_node] = values[np.searchsorted(nodes, big[on_node])]
        out[~exact] = vals
    return out


def _old_edf_table(lengths, ms, alpha, overhang=None, stat="oadev", exact_pairs=4096):
    """davar.edf_table as it was, with adavar.stats.edf.edf one length at a time."""
    lengths = np.asarray(lengths, dtype=np.int64)
    table = np.full((lengths.size, ms.size), np.nan)
    if overhang is not None:
        overhang = np.asarray(overhang, dtype=np.int64)
        for t, (m, a) in enumerate(zip(ms, alpha, strict=True)):
            m = int(m)
            rows = np.flatnonzero(3 * m <= lengths)
            if rows.size == 0:
                continue
            width = surface_common.term_width(stat, m)
            terms = lengths[rows] + 1 - width
            repeats = np.maximum(0, overhang[rows] - width // 2)
            effective = np.maximum(1, np.round(terms * terms / (terms + 2 * repeats)))
            inner = repeats == 0
            table[rows[inner], t] = [edf(stat, int(a), m, int(c) + width) for c in effective[inner]]
            if (~inner).any():
                counts, where = np.unique(effective[~inner].astype(np.int64), return_inverse=True)
                values = _old_edf_of_counts(counts, int(a), m, stat)
                table[rows[~inner], t] = values[where.ravel()]
        return table
    valid = 3 * ms[None, :] <= lengths[:, None]
    exact_everywhere = int(valid.sum()) <= exact_pairs
    for t, (m, a) in enumerate(zip(ms, alpha, strict=True)):
        lv = lengths[valid[:, t]]
        if lv.size == 0:
            continue
        if exact_everywhere or lv.size <= 32:
            table[valid[:, t], t] = [edf(stat, int(a), int(m), int(L) + 1) for L in lv]
            continue
        x = lv - 3 * m + 1
        nodes = np.unique(np.round(np.geomspace(x[0], x[-1], 32))).astype(np.int64)
        values = [edf(stat, int(a), int(m), int(g + 3 * m - 1) + 1) for g in nodes]
        curve = PchipInterpolator(np.log(nodes), np.log(values))
        table[valid[:, t], t] = np.exp(curve(np.log(x)))
    return table


def _same_table(got: np.ndarray, want: np.ndarray) -> None:
    assert got.shape == want.shape
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    ok = ~np.isnan(want)
    assert ok.any()
    np.testing.assert_allclose(got[ok], want[ok], rtol=1e-12, atol=0)


TABLE_MS = np.array([1, 2, 3, 5, 10, 25, 26, 33, 34, 40, 50, 67, 100, 133, 201])
TABLE_LENGTHS = [
    np.arange(5, 41),
    np.arange(380, 620),
    np.unique(np.geomspace(3, 5000, 70).astype(np.int64)),
]


@pytest.mark.parametrize("stat", ["oadev", "ohdev", "mdev"])
@pytest.mark.parametrize("interpolated", [False, True], ids=["exact", "interpolated"])
@pytest.mark.parametrize("which", range(len(TABLE_LENGTHS)))
def test_edf_table_plain_as_before(stat, interpolated, which, monkeypatch):
    lengths = TABLE_LENGTHS[which]
    exact_pairs = 0 if interpolated else 10**9
    monkeypatch.setattr(surface_common, "EDF_EXACT_PAIRS", exact_pairs)
    lo, hi = STAT_ALPHA_RANGE[stat]
    alpha = np.resize(np.arange(lo, hi + 1), TABLE_MS.size)  # every alpha, at several m
    got = surface_common.edf_table(lengths, TABLE_MS, alpha, stat=stat)
    _same_table(got, _old_edf_table(lengths, TABLE_MS, alpha, stat=stat, exact_pairs=exact_pairs))


@pytest.mark.parametrize("stat", ["oadev", "ohdev", "mdev"])
def test_edf_table_overhang_as_before(stat):
    rng = np.random.default_rng(3)
    lengths = np.concatenate([rng.integers(5, 60, 40), rng.integers(300, 4000, 60)])
    overhang = np.minimum(lengths // 2, rng.integers(0, 2000, lengths.size))
    overhang[::5] = 0  # interior windows among them
    lo, hi = STAT_ALPHA_RANGE[stat]
    for shift in range(hi - lo + 1):
        alpha = np.resize(np.roll(np.arange(lo, hi + 1), shift), TABLE_MS.size)
        got = surface_common.edf_table(lengths, TABLE_MS, alpha, overhang=overhang, stat=stat)
        want = _old_edf_table(lengths, TABLE_MS, alpha, overhang=overhang, stat=stat)
        _same_table(got, want)


def test_edf_of_counts_as_before():
    counts = np.unique(np.geomspace(1, 10**6, 200).astype(np.int64))
    for stat in ("oadev", "ohdev", "mdev"):
        for alpha, m in ((-2, 1), (0, 7), (1, 40), (2, 300), (-1, 2000)):
            got = surface_common.edf_of_counts(counts, alpha, m, stat)
            want = _old_edf_of_counts(counts, alpha, m, stat)
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
            assert math.isfinite(got.sum())


def test_edf_of_counts_do_not_depend_on_the_grid_a_call_finds():
    # a grid kept from an earlier call (built for other counts, then extended) gives each
    # count the same bits as a grid built for that count alone
    small = np.array([70, 90, 130])
    large = np.array([100, 5_000, 300_000])
    for stat, alpha, m in (("oadev", 0, 3), ("mdev", 1, 17), ("ohdev", -2, 5)):
        surface_common._EDF_GRIDS.clear()
        alone = surface_common.edf_of_counts(large, alpha, m, stat)
        surface_common._EDF_GRIDS.clear()
        surface_common.edf_of_counts(small, alpha, m, stat)  # a small grid first
        after = surface_common.edf_of_counts(large, alpha, m, stat)  # then extended
        np.testing.assert_array_equal(after, alone)

"""The covariance basis's cross kernels against the plain loop over the nine shifts
(adavar.stats.avar_covariance evaluates the nine at once, in the loop's order)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from adavar.stats import avar_covariance as ac

_W = (1.0, -2.0, 1.0)


def _slow_kernels(h: np.ndarray, tau_c: float | None) -> np.ndarray:
    a = np.abs(h)
    with np.errstate(divide="ignore", invalid="ignore"):
        flick = np.where(a > 0, h * h * np.log(a), 0.0) / (4.0 * math.log(2.0))
    rows = [-0.5 * a, flick, 0.25 * a**3]
    if tau_c is not None:
        x = a / tau_c
        small = x < 1e-3
        core = np.where(small, x * x * (0.5 - x / 6.0 + x * x / 24.0), x + np.expm1(-x))
        rows.append(-(tau_c**2) * core)
    return np.stack(rows)


def _slow_cross(s, mi, mj, tau0, tau_c):
    """c_ij(s) = sum_{a,b} w_a w_b g((s + b m_j - a m_i) tau0), one shift at a time."""
    out = np.zeros((3 if tau_c is None else 4, s.size))
    for a, wa in enumerate(_W):
        for b, wb in enumerate(_W):
            out += wa * wb * _slow_kernels((s + b * mj - a * mi) * tau0, tau_c)
    return out


@settings(max_examples=60, deadline=None)
@given(
    mi=st.integers(1, 100_000),
    mj=st.integers(1, 100_000),
    tau0=st.sampled_from([1e-6, 1e-3, 0.01, 1.0, 3600.0]),
    lags=st.lists(st.floats(-4e5, 4e5, allow_nan=False), min_size=1, max_size=200),
    integer=st.booleans(),
    tau_c=st.one_of(st.none(), st.floats(1e-4, 1e5)),
)
def test_cross_equals_the_loop_bit_for_bit(mi, mj, tau0, lags, integer, tau_c):
    s = np.array(lags)
    if integer:  # the exact lag sum's integer lags, zero among them
        s = np.round(s)
        s[0] = 0.0
    many = np.full(s.size, mi, dtype=np.int64), np.full(s.size, mj, dtype=np.int64)
    np.testing.assert_array_equal(ac._cross_many(s, *many, tau0, tau_c),
                                  _slow_cross(s, mi, mj, tau0, tau_c))  # fmt: skip


@settings(max_examples=40, deadline=None)
@given(
    mi=st.integers(1, 3000),
    mj=st.integers(1, 3000),
    s_lo=st.integers(-6000, 3000),
    span=st.integers(0, 6000),
    tau0=st.sampled_from([1e-6, 1e-3, 0.01, 1.0, 3600.0]),
    tau_c=st.one_of(st.none(), st.floats(1e-4, 1e5)),
)
def test_integer_lags_from_one_range_are_the_shifts_bit_for_bit(mi, mj, s_lo, span, tau0, tau_c):
    """The exact lag sum's kernels, evaluated once on the union of the nine shifted
    ranges, are those of the plain loop at every lag."""
    s = np.arange(s_lo, s_lo + span + 1, dtype=float)
    np.testing.assert_array_equal(ac._cross_lags(s_lo, s_lo + span, mi, mj, tau0, tau_c),
                                  _slow_cross(s, mi, mj, tau0, tau_c))  # fmt: skip


def _slow_pair(mi, mj, n_i, n_j, tau0, tau_c):
    """One pair's sums as the basis computed them pair by pair before 0.3.1: the point
    masses of Q, then the continuous kernels exactly at integer lags or by quadrature."""
    size = 4 if tau_c is None else 5
    out = np.zeros((size, size))
    lo, hi = -(n_i - 1), n_j - 1
    pts = sorted({a * mi - b * mj for a in range(3) for b in range(3)})
    pts = np.array([p for p in pts if lo <= p <= hi], dtype=float)
    if pts.size:
        cq = np.zeros(pts.size)
        for a, wa in enumerate(_W):
            for b, wb in enumerate(_W):
                cq += wa * wb * (np.abs(pts + b * mj - a * mi) < 0.5) / 3.0
        cnt = ac._counts(pts, n_i, n_j)
        out[0, 0] = np.sum(cnt * cq * cq)
        out[0, 1:] = out[1:, 0] = _slow_cross(pts, mi, mj, tau0, tau_c) @ (cnt * cq)
    grid = ac._pair_grid(mi, mj, n_i, n_j, tau0, tau_c)  # its lags and quadrature weights
    weight = ac._counts(grid.s, n_i, n_j)
    if grid.quad is not None:
        weight = grid.quad * weight
    c = _slow_cross(grid.s, mi, mj, tau0, tau_c)
    out[1:, 1:] = (c * weight) @ c.T
    return out


@settings(max_examples=12, deadline=None)
@given(
    ms=st.lists(st.integers(1, 40_000), min_size=1, max_size=6, unique=True),
    extra=st.integers(0, 200_000),
    tau0=st.sampled_from([1e-3, 0.01, 1.0]),
    tau_c=st.one_of(st.none(), st.floats(1e-3, 1e3)),
)
def test_basis_in_batches_is_the_pair_by_pair_basis_bit_for_bit(ms, extra, tau0, tau_c):
    """The basis computes the kernels of many pairs in one call: every entry is the one
    pair-by-pair computation's, to the last bit."""
    ms = sorted(ms)
    n_points = 2 * ms[-1] + 2 + extra
    basis = ac.covariance_basis(np.array(ms), n_points, tau0, markov_tau=tau_c)
    terms = [n_points - 2 * m for m in ms]
    for i in range(len(ms)):
        for j in range(i, len(ms)):
            want = _slow_pair(ms[i], ms[j], terms[i], terms[j], tau0, tau_c)
            want /= 2.0 * terms[i] * terms[j] * (ms[i] * tau0) ** 2 * (ms[j] * tau0) ** 2
            # (a diagonal block is stored transposed: the product is symmetric to rounding)
            np.testing.assert_array_equal(basis[i, j], want.T if i == j else want)
            np.testing.assert_array_equal(basis[j, i], want.T)

r"""Covariance of overlapping Allan-variance estimates across averaging times.

The overlapping AVAR estimates of one record at different taus are strongly correlated
(they are built from the same samples), and their variances span many decades. A fit that
treats them as independent (diagonal weights) is over-confident and lets the short taus,
with their hundreds of thousands of degrees of freedom, dictate the whole curve. This module
gives the full covariance matrix of the estimates for any mixture of the IEEE 952 noise
terms, so that the noise fit can be a generalised least-squares fit (:mod:`adavar.fit.gls_fit`).

Method
------
With phase (integrated rate) ``x`` and ``z_m[k] = x[k+2m] - 2 x[k+m] + x[k]``, the
overlapping estimate is ``avar_m = sum_k z_m[k]^2 / (2 tau^2 M_m)`` over its
``M_m = n_points - 2m`` terms. For Gaussian noise (Isserlis)

.. math:: \operatorname{Cov}(avar_i, avar_j) =
          \frac{\sum_s n_{ij}(s)\, c_{ij}(s)^2}{2 M_i M_j \tau_i^2 \tau_j^2},

where ``c_ij(s) = Cov(z_{m_i}[k], z_{m_j}[k+s])`` and ``n_ij(s)`` counts the pairs of terms
``s`` apart. ``c_ij`` is a double second difference of the *generalised autocovariance*
``g(h)`` of the phase (Greenhall's approach, also behind :func:`adavar.stats.edf.greenhall_edf`):
``c_ij(s) = sum_{a,b} w_a w_b g((s + b m_j - a m_i) tau0)`` with ``w = (1, -2, 1)``. Per
unit coefficient ``C_n`` (AVAR contribution ``C_n tau^n``):

==================  ======  ===============================================
term                n       g(h)
==================  ======  ===============================================
quantization (Q)    -2      ``delta(h) / 3`` (white phase)
random walk (N)     -1      ``-|h| / 2`` (white rate)
bias inst. (B)      0       ``h^2 ln|h| / (4 ln 2)`` (flicker rate)
rate r. walk (K)    1       ``|h|^3 / 4`` (random-walk rate)
==================  ======  ===============================================

The terms are independent, so ``c_ij`` is linear in the coefficients and the covariance is
a quadratic form in them, ``Cov_ij = sum_{n,n'} C_n C_n' T_ij^{nn'}``: the basis ``T`` is
computed once per (taus, record length) and the covariance of any model follows at the cost
of a few matrix products. The rate ramp (R) is deterministic and adds no variance.

A first-order Gauss-Markov rate process (stationary variance ``sigma^2``, correlation
time ``T``) has the phase structure function ``2 sigma^2 (T |h| - T^2 (1 - e^{-|h|/T}))``, so
per unit ``sigma^2`` its kernel is ``g(h) = -T^2 (|h|/T - 1 + e^{-|h|/T})``; with
``markov_tau=T`` the basis gets it as a fifth random term.

The lag sum is exact (integer lags) when the pair's support is short; otherwise it is an
integral evaluated by Gauss-Legendre quadrature between the kinks of ``c_ij`` and of
``n_ij`` (exact for the polynomial kernels of N and K up to the sum-to-integral error,
below 1e-4 relative for ``m >= 32``). The flicker kernel has infinite support; its tail is
cut at 16 times the longer cluster length, where it has decayed below 1e-4 of the core.
For pure white rate noise the diagonal equals ``2 avar^2 / edf`` with Greenhall's EDF.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

__all__ = ["RANDOM_TERMS", "covariance", "covariance_basis", "fourth_cumulant_basis"]

#: Terms with a random (variance-carrying) process, by index in TERM_NAMES (Q, N, B, K).
RANDOM_TERMS = (0, 1, 2, 3)

_W = (1.0, -2.0, 1.0)
_EXACT_MAX = 6000  # longest lag range summed exactly, integer by integer
_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(12)
_FLICKER_TAIL = 16  # flicker support cut at this many times the longer cluster length
_MARKOV_TAIL = 30  # Gauss-Markov support cut at this many correlation times (e^-30)
_BATCH = 4096  # lags whose kernels a basis evaluates in one call (the arrays stay in cache)


def _markov_kernel(a: np.ndarray, tau_c: float) -> np.ndarray:
    """``-T^2 (x - 1 + e^-x)``, ``x = |h| / T``: the Gauss-Markov kernel per unit variance."""
    x = a / tau_c
    # x - 1 + e^-x = x + expm1(-x) cancels for small x: its series there
    small = x < 1e-3
    core = np.where(small, x * x * (0.5 - x / 6.0 + x * x / 24.0), x + np.expm1(-x))
    return -(tau_c**2) * core


def _kernels(h: np.ndarray, tau_c: float | None = None) -> np.ndarray:
    """Generalised phase autocovariances of N, B, K (and a Gauss-Markov process of
    correlation time ``tau_c``) per unit coefficient, shape (3 or 4, ...)."""
    a = np.abs(h)
    out = np.empty((3 if tau_c is None else 4, *np.shape(h)))
    np.multiply(-0.5, a, out=out[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        out[1] = np.where(a > 0, h * h * np.log(a), 0.0) / (4.0 * math.log(2.0))
    out[2] = 0.25 * a**3
    if tau_c is not None:
        out[3] = _markov_kernel(a, tau_c)
    return out


#: the nine ``(a, b)`` of ``w_a w_b g(s + b m_j - a m_i)``, in the order they are summed
_AB = tuple(itertools.product(range(3), range(3)))


def _cross_lags(s_lo: int, s_hi: int, mi: int, mj: int, tau0: float,
                tau_c: float | None = None) -> np.ndarray:  # fmt: skip
    """:func:`_cross_many` at every integer lag ``s_lo .. s_hi``, bit for bit: the nine shifted
    arguments are integers of one range, so each kernel is evaluated once on that range
    (``S + 2 (mi + mj)`` points, not ``9 S``: for lags that span more than the shifts)
    and read at each shift."""
    shifts = [b * mj - a * mi for a, b in _AB]
    u_lo = s_lo + min(shifts)
    k = _kernels(np.arange(u_lo, s_hi + max(shifts) + 1, dtype=float) * tau0, tau_c)
    size = s_hi - s_lo + 1
    out = np.zeros((k.shape[0], size))
    for n, (a, b) in enumerate(_AB):
        first = s_lo + shifts[n] - u_lo
        out += _W[a] * _W[b] * k[:, first : first + size]
    return out


def _counts(s: np.ndarray, n_i: int, n_j: int) -> np.ndarray:
    """Pairs of terms (k in [0, n_i), l in [0, n_j)) with ``l - k = s``."""
    return np.clip(np.minimum(n_i, n_j - s) - np.maximum(0, -s), 0, None)


def _cross_many(s: np.ndarray, mi: np.ndarray, mj: np.ndarray, tau0: float,
                tau_c: float | None = None) -> np.ndarray:  # fmt: skip
    """``c_ij(s)`` of N, B, K (and the Gauss-Markov term) at lags ``s`` (samples, may be
    fractional), shape (3 or 4, len(s)), for many pairs at once: ``mi``, ``mj`` given for
    every lag. Each value is the sum of the nine shifted kernels in the loop's order, the
    same element-wise arithmetic whatever the pairs beside it (one call, not one a pair:
    a basis has hundreds)."""
    ahead = np.stack([b * mj for _, b in _AB])
    back = np.stack([a * mi for a, _ in _AB])
    k = _kernels((s[None, :] + ahead - back) * tau0, tau_c)
    out = np.zeros((k.shape[0], s.size))
    for n, (a, b) in enumerate(_AB):
        out += _W[a] * _W[b] * k[:, n]
    return out


@dataclass
class _PairGrid:
    """The lags of one pair of averaging factors (``n_i``, ``n_j`` terms): where ``c^Q``
    has its point masses (``pts``), and the lags ``s`` of the continuous kernels' sum,
    exact at the integers ``s_lo .. s_hi`` (``quad`` None) or by Gauss-Legendre quadrature
    (``quad`` its weights, before the counts of pairs)."""

    mi: int
    mj: int
    n_i: int
    n_j: int
    pts: np.ndarray
    s: np.ndarray
    quad: np.ndarray | None
    lags: tuple[int, int] | None  # integer lags evaluated from one range (_cross_lags)


def _pair_grid(mi: int, mj: int, n_i: int, n_j: int, tau0: float,
               tau_c: float | None = None) -> _PairGrid:  # fmt: skip
    """The lags of one pair's sums (:func:`_pair_sums`)."""
    lo, hi = -(n_i - 1), n_j - 1
    # quantization: c^Q is a point mass at each lag where some argument is 0
    pts = sorted({a * mi - b * mj for a in range(3) for b in range(3)})
    pts = np.array([p for p in pts if lo <= p <= hi], dtype=float)
    # N, B, K: continuous kernels; N and K vanish outside [-2 mj, 2 mi], B decays there
    reach = _FLICKER_TAIL * max(mi, mj)
    # the Gauss-Markov term decays as e^(-|s| tau0 / tau_c) outside the clusters
    decay = 0 if tau_c is None else math.ceil(_MARKOV_TAIL * tau_c / tau0)
    reach = max(reach, decay)
    s_lo, s_hi = max(lo, -2 * mj - reach), min(hi, 2 * mi + reach)
    if s_hi - s_lo <= _EXACT_MAX:
        s = np.arange(s_lo, s_hi + 1, dtype=float)
        # the nine shifted ranges overlap while the lags span more than the shifts
        lags = (int(s_lo), int(s_hi)) if 2 * (mi + mj) <= 8 * (s_hi - s_lo + 1) else None
        return _PairGrid(mi, mj, n_i, n_j, pts, s, None, lags)
    kinks = {s_lo, s_hi, 0, n_j - n_i} | {a * mi - b * mj for a in range(3) for b in range(3)}
    big = max(mi, mj)  # the flicker tail decays like s**-4: finer panels near the core
    kinks |= {2 * mi + f * big for f in (1, 2, 4, 8)} | {-2 * mj - f * big for f in (1, 2, 4, 8)}
    if tau_c is not None:  # panels a few correlation times wide along its decay
        step = tau_c / tau0
        kinks |= {int(2 * mi + f * step) for f in (0.5, 1, 2, 4, 8, 16)}
        kinks |= {int(-2 * mj - f * step) for f in (0.5, 1, 2, 4, 8, 16)}
    edges = np.array(sorted(k for k in kinks if s_lo <= k <= s_hi), dtype=float)
    left, right = edges[:-1], edges[1:]
    half = 0.5 * (right - left)
    s = (left[:, None] + half[:, None] * (_NODES[None, :] + 1.0)).ravel()
    return _PairGrid(mi, mj, n_i, n_j, pts, s, (half[:, None] * _WEIGHTS[None, :]).ravel(), None)


def _pair_sums(grids: list[_PairGrid], tau0: float, tau_c: float | None) -> list[np.ndarray]:
    """``sum_s n(s) c^p(s) c^q(s)`` of each pair, shape (4, 4) or (5, 5) with ``tau_c``.

    The point masses' weights, the counts of pairs and the kernels of every pair are
    computed in one call each (element-wise, in the order of a pair's own calls: bit for
    bit those of one pair at a time); the sums are each pair's own."""
    size = 4 if tau_c is None else 5
    # the kernels at the point masses, then at the lags not taken from a range
    kernel_grids = grids + [g for g in grids if g.lags is None]
    parts = [g.pts for g in grids] + [g.s for g in grids if g.lags is None]
    sizes = np.array([p.size for p in parts])

    def each(values: list[int]) -> np.ndarray:
        return np.repeat(np.array(values, dtype=np.int64), sizes)

    mi, mj = each([g.mi for g in kernel_grids]), each([g.mj for g in kernel_grids])
    n_i, n_j = each([g.n_i for g in kernel_grids]), each([g.n_j for g in kernel_grids])
    lags = np.concatenate(parts)
    kernels = _cross_many(lags, mi, mj, tau0, tau_c)
    counts = _counts(lags, n_i, n_j)
    n_pts = int(sum(g.pts.size for g in grids))
    pts, pmi, pmj = lags[:n_pts], mi[:n_pts], mj[:n_pts]
    cq = np.zeros(n_pts)
    for a, wa in enumerate(_W):
        for b, wb in enumerate(_W):
            cq += wa * wb * (np.abs(pts + b * pmj - a * pmi) < 0.5) / 3.0
    bounds = np.concatenate(([0], np.cumsum(sizes))).tolist()
    spans = list(itertools.pairwise(bounds))
    rest = iter(spans[len(grids) :])
    out = []
    for g, (a, b) in zip(grids, spans[: len(grids)], strict=True):
        t = np.zeros((size, size))
        if b > a:
            cnt, q = counts[a:b], cq[a:b]
            t[0, 0] = np.sum(cnt * q * q)
            t[0, 1:] = t[1:, 0] = np.ascontiguousarray(kernels[:, a:b]) @ (cnt * q)
        if g.lags is not None:
            c = _cross_lags(*g.lags, g.mi, g.mj, tau0, tau_c)
            weight = _counts(g.s, g.n_i, g.n_j)
        else:
            u, v = next(rest)
            c = np.ascontiguousarray(kernels[:, u:v])
            weight = counts[u:v] if g.quad is None else g.quad * counts[u:v]
        t[1:, 1:] = (c * weight) @ c.T
        out.append(t)
    return out


@lru_cache(maxsize=16)
def _basis_cached(
    ms: tuple[int, ...], n_points: int, tau0: float, tau_c: float | None = None
) -> np.ndarray:
    k = len(ms)
    size = 4 if tau_c is None else 5
    basis = np.zeros((k, k, size, size))
    terms = [n_points - 2 * m for m in ms]
    taus = [m * tau0 for m in ms]
    pairs = [(i, j) for i in range(k) for j in range(i, k)]
    grids = [_pair_grid(ms[i], ms[j], terms[i], terms[j], tau0, tau_c) for i, j in pairs]
    start = 0
    while start < len(pairs):  # batches of about _BATCH lags: the kernels' arrays in cache
        stop, total = start, 0
        while stop < len(pairs) and (stop == start or total < _BATCH):
            total += grids[stop].pts.size + (grids[stop].s.size if grids[stop].lags is None else 0)
            stop += 1
        sums = _pair_sums(grids[start:stop], tau0, tau_c)
        for (i, j), t in zip(pairs[start:stop], sums, strict=True):
            t /= 2.0 * terms[i] * terms[j] * taus[i] ** 2 * taus[j] ** 2
            basis[i, j] = t
            basis[j, i] = t.T
        start = stop
    basis.setflags(write=False)
    return basis


def covariance_basis(
    ms: np.ndarray, n_points: int, tau0: float, markov_tau: float | None = None
) -> np.ndarray:
    """The basis ``T`` of the covariance of overlapping AVAR estimates.

    Parameters
    ----------
    ms : array_like of int, shape (M,)
        Averaging factors, ``1 <= m <= (n_points - 1) // 2``.
    n_points : int
        Phase points of the record (rate samples + 1).
    tau0 : float
        Sample interval in seconds.
    markov_tau : float, optional
        Correlation time (s) of a first-order Gauss-Markov rate process to include as a
        fifth random term (its coefficient: the process's variance ``sigma^2``).

    Returns
    -------
    ndarray, shape (M, M, 4, 4) or (M, M, 5, 5)
        ``T[i, j, p, q]``: ``Cov(avar_i, avar_j) = sum_{p,q} C_p C_q T[i, j, p, q]`` for the
        coefficients ``C`` of Q, N, B, K (``C_-2 .. C_1`` of :mod:`adavar.fit.noise_model`),
        then ``sigma^2`` of the Gauss-Markov term. Read-only (cached).
    """
    ms_t = tuple(int(m) for m in np.asarray(ms).ravel())
    if any(m < 1 or n_points - 2 * m < 1 for m in ms_t):
        raise ValueError("every averaging factor needs 1 <= m and 2 m < n_points")
    tau_c = None if markov_tau is None else float(markov_tau)
    if tau_c is not None and not (tau_c > 0 and math.isfinite(tau_c)):
        raise ValueError(f"markov_tau must be a positive number of seconds, got {markov_tau!r}")
    return _basis_cached(ms_t, int(n_points), float(tau0), tau_c)


def covariance(basis: np.ndarray, coefficients: np.ndarray, markov_var: float = 0.0) -> np.ndarray:
    """``Cov(avar_i, avar_j)`` of a model with coefficients ``C_-2 .. C_2`` (R is ignored).

    Parameters
    ----------
    basis : ndarray, shape (M, M, 4, 4) or (M, M, 5, 5)
        From :func:`covariance_basis`.
    coefficients : array_like, shape (5,)
        ``C_-2 .. C_2`` of the model (negative values are treated as 0).
    markov_var : float
        ``sigma^2`` of the Gauss-Markov term of a (M, M, 5, 5) basis.

    Returns
    -------
    ndarray, shape (M, M)
    """
    c = np.clip(np.asarray(coefficients, dtype=float)[:4], 0.0, None)
    if basis.shape[-1] == 5:
        c = np.append(c, max(float(markov_var), 0.0))
    return np.einsum("ijpq,p,q->ij", basis, c, c)


def _trapezoid(k: float, width: int, n: int) -> float:
    """How many of the overlapping terms of half-width ``width`` hold sample ``k``."""
    return float(min(k + 1, width, n - k))


def _sum_of_products(m_i: int, m_j: int, n: int) -> float:
    """``sum_k count_i(k) count_j(k)`` over the ``n`` rate samples, exactly: each count is
    a trapezoid (``min(k + 1, L, n - k)``, ``L = min(2m, M)``), so their product is a
    quadratic on the segments between the breakpoints, summed in closed form."""
    widths = [min(2 * m, n + 1 - 2 * m) for m in (m_i, m_j)]
    cuts = {0, n}
    for w in widths:
        cuts |= {w - 1, n - w}
    cuts = sorted(c for c in cuts if 0 <= c <= n)
    total = 0.0
    for a, b in itertools.pairwise(cuts):
        length = b - a
        if length <= 0:
            continue
        f0, g0 = (_trapezoid(a, w, n) for w in widths)
        if length == 1:
            total += f0 * g0
            continue
        f1, g1 = (_trapezoid(a + 1, w, n) for w in widths)
        df, dg = f1 - f0, g1 - g0
        s1 = length * (length - 1) / 2.0
        s2 = (length - 1) * length * (2 * length - 1) / 6.0
        total += length * f0 * g0 + (f0 * dg + df * g0) * s1 + df * dg * s2
    return total


def fourth_cumulant_basis(ms: np.ndarray, n_points: int) -> np.ndarray:
    """What heavy tails add to the covariance of overlapping AVAR estimates.

    With rate samples ``w`` of fourth cumulant ``kappa4`` (``excess kurtosis * sigma^4``),
    the overlapping estimate ``avar_m = sum_t (S_A - S_B)^2 / (2 M m^2)`` holds each
    ``w_k^2`` with the coefficient ``count_m(k) / (2 M m^2)`` (``count_m(k)``: the terms
    whose two clusters hold sample ``k``), and Isserlis's formula gains
    ``kappa4 sum_k c_i(k) c_j(k)``. For white rate noise this is ``excess avar^2 / N`` at
    short taus, against the Gaussian ``2 avar^2 / edf``: a Student-t of 5 degrees of
    freedom (excess 6) triples the variance of the shortest taus' estimates.

    Parameters
    ----------
    ms : array_like of int, shape (M,)
        Averaging factors.
    n_points : int
        Phase points (rate samples + 1).

    Returns
    -------
    ndarray, shape (M, M)
        ``sum_k c_i(k) c_j(k)``: times ``kappa4`` it is the covariance to add.
    """
    ms_t = [int(m) for m in np.asarray(ms).ravel()]
    n = int(n_points) - 1
    out = np.empty((len(ms_t), len(ms_t)))
    norms = [2.0 * (n_points - 2 * m) * m * m for m in ms_t]
    for i, mi in enumerate(ms_t):
        for j in range(i, len(ms_t)):
            value = _sum_of_products(mi, ms_t[j], n) / (norms[i] * norms[j])
            out[i, j] = out[j, i] = value
    return out

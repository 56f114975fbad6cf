"""The lag-1 test on the decimated phase (SP 1065, Riley & Greenhall 2004): its sums.

The test of :mod:`adavar.stats.noise_id` starts, at each averaging factor ``m``, on the decimated
phase ``P[k] = S[k m]``, ``k = 0 .. count``, quadratically detrended: the lag-1
autocorrelation ``r1`` of its residuals ``e``. Two ways to it live here.

* The sequential passes (the definition): :func:`phase_moments` then
  :func:`phase_residual_lag` over the cluster sums ``z[k] = S[(k+1) m] - S[k m]``, the
  phase summed from them in cluster order (in memory and out of core alike), and
  :func:`decimated_phase_stats`, the same two passes over an anchored phase without
  materialising the cluster sums: the same numbers, bit for bit. At ``m = 1`` they are
  two dependent chains of additions over the whole record (about 60 ms at 1e7 samples),
  which no thread can share.
* At the fused levels ``m = 1, 2, .., 32`` (:data:`adavar._kernels.differences.FUSED_LEVELS`),
  :func:`fused_phase_levels`: from sums the integration pass gathers per block (of the
  points ``S[k m]`` about the block's anchor:
  :func:`adavar._kernels.differences._block_phase_moments` via ``cluster_stats``) and those of the
  cluster sums it gathers anyway, in a few operations per block. The fit comes from the sums of
  ``P``, ``u P``, ``u^2 P``; then ``sum e^2 = sum P^2 - sum f P`` (least squares) and ``sum e[k-1]
  e[k] = sum e^2 - (e[0]^2 + e[c]^2) / 2 - sum (e[k] - e[k-1])^2 / 2``, whose differences are the
  cluster sums less the fitted curve's (``c1 + 2 c2 t``). No pass over the data.

The second is not the first bit for bit (its sums run in another order), so it comes
with a bound on the distance between the two, and :func:`adavar.stats.noise_id.rate_noise_types`
takes its decision only where the bound shows the first would have reached the same one
(else it runs the sequential passes). The bound, with ``u = 2**-53``, ``c`` clusters,
``M`` an upper bound of ``|P|``, ``zmax`` of ``|z|``, ``F`` of the fitted curve, and
``g`` the rounding of a sum of ``c + 1`` (sequential) or ``BLOCK + n_blocks`` (fused)
terms, ``g = terms * u``: both are compared with the exact least-squares residuals ``e*``
of the anchored phase. The sequential running sum is off by at most ``g (M + zmax)`` per
point (each addition rounds to ``u |P|``, each cluster sum to a few ``u (|z| + M)``), and
the fit of that error and the rounding of its own sums move the fitted curve by at most
``~110 g (M + zmax)`` (the closed-form fit's coefficients on the symmetric abscissa); so
each residual is within ``A = 256 g (M + zmax) + 8 u (M + F)`` of ``e*``, and each
difference of consecutive residuals within ``512 u (M + zmax + F)`` (the errors above
are smooth: a point's adds ``u |P|``, the fit's a slope). Then, by Cauchy-Schwarz,
``sum e^2`` is within ``(2 rho + rho^2) sum e^2`` (``rho = 2 A sqrt((c+1) / sum e^2)``)
and the sum of the squared differences within ``2 sqrt(c sum) eta + c eta^2``; with the
sums' own rounding (``g``), ``r1 = 1 - K / D`` moves by at most ``(dK + (1 - r1) dD) /
D``. The fused sums' errors are bounded the same way (``g`` of ``BLOCK + n_blocks``
terms, and the cancellation in ``sum P^2 - sum f P``: ``8 g (c+1) (M + F)^2``). The
tolerances returned are the sums of both bounds, times 4. They are far below the
margins the decisions need on noise (``1e-5`` at 1e7 samples of white noise against a
margin of 0.67); a record whose decimated phase is dominated by a trend (a frequency
drift, or the linear trend the integration's shift leaves in a long record) gets wide
bounds, and the sequential passes.
"""

from __future__ import annotations

import math

import numpy as np

from adavar._kernels._jit import jit
from adavar._kernels.difference_runs import BLOCK, SHIFT
from adavar._kernels.differences import AnchoredPhase, cluster_sum

__all__ = [
    "decimated_phase_lag1",
    "decimated_phase_stats",
    "fused_phase_levels",
    "lag1_of_sums",
    "phase_lag1_result",
    "phase_moments",
    "phase_residual_lag",
    "quadratic_coefficients",
    "quadratic_fit",
]


@jit
def phase_moments(zs, nz, k0, count, pm):  # pragma: no cover - compiled
    """First pass over the decimated phase ``P[0] = 0, P[k+1] = P[k] + z[k]``.

    ``zs[:nz]`` are the cluster sums ``k0 .. k0+nz-1``; ``pm`` carries ``[P, sum P,
    sum u P, sum u^2 P, max |P|]`` with ``u = k - count/2`` over the ``count + 1`` points.
    Sequential sums in cluster order: the same numbers whatever the piece boundaries.
    """
    kc = 0.5 * count
    p = pm[0]
    for q in range(nz):
        p += zs[q]
        u = k0 + q + 1 - kc
        pm[1] += p
        pm[2] += u * p
        pm[3] += u * u * p
        pm[4] = max(pm[4], abs(p))
    pm[0] = p


@jit
def phase_residual_lag(zs, nz, k0, count, coef, ps):  # pragma: no cover - compiled
    """Second pass: residuals ``e = P - (c0 + c1 u + c2 u^2)`` and their lag-1 sums.

    ``ps`` carries ``[P, e_prev, sum e, sum e^2, sum e_prev e, e_first]``.
    """
    kc = 0.5 * count
    c0, c1, c2 = coef[0], coef[1], coef[2]
    if k0 == 0:  # the point P[0] = 0 opens the series
        e = -(c0 - c1 * kc + c2 * kc * kc)
        ps[1] = e
        ps[2] += e
        ps[3] += e * e
        ps[5] = e
    p = ps[0]
    prev = ps[1]
    for q in range(nz):
        p += zs[q]
        u = k0 + q + 1 - kc
        e = p - (c0 + c1 * u + c2 * u * u)
        ps[2] += e
        ps[3] += e * e
        ps[4] += prev * e
        prev = e
    ps[0] = p
    ps[1] = prev


def quadratic_coefficients(count: int, b0: float, b1: float, b2: float) -> tuple:
    """Least-squares quadratic ``c0 + c1 u + c2 u^2`` through the ``count + 1`` points
    ``u = -count/2 .. count/2`` from the sums ``b0, b1, b2`` of ``P``, ``u P``, ``u^2 P``."""
    n = count + 1.0
    u2 = n * (n * n - 1.0) / 12.0  # sums of u^2 and u^4 over the symmetric abscissa
    u4 = n * (n * n - 1.0) * (3.0 * n * n - 7.0) / 240.0
    c1 = b1 / u2 if u2 > 0 else 0.0
    det = n * u4 - u2 * u2
    if det > 0:
        c0 = (b0 * u4 - b2 * u2) / det
        c2 = (n * b2 - u2 * b0) / det
    else:
        c0, c2 = b0 / n, 0.0
    return c0, c1, c2


def quadratic_fit(count: int, pm: np.ndarray) -> np.ndarray:
    """:func:`quadratic_coefficients` from the first pass's sums ``pm``
    (:func:`phase_moments`), as an array."""
    return np.array(quadratic_coefficients(count, pm[1], pm[2], pm[3]))


def lag1_of_sums(n: int, s1: float, s2: float, s11: float, first: float, last: float):
    """``(r1, den)`` of ``n`` residuals from their sum, sum of squares, sum of lag
    products, first and last: the lag-1 autocorrelation about their mean."""
    mean = s1 / n
    den = s2 - n * mean * mean
    num = s11 - mean * ((s1 - last) + (s1 - first)) + (n - 1) * mean * mean
    r1 = num / den if den > 0 else math.nan
    return r1, den


def phase_lag1_result(count: int, pm: np.ndarray, ps: np.ndarray) -> tuple[float, float, float]:
    """``(r1, den, scale)`` of the detrended decimated phase from the two passes' sums."""
    r1, den = lag1_of_sums(count + 1, ps[2], ps[3], ps[4], ps[5], ps[1])
    return r1, den, float(pm[4])


def decimated_phase_lag1(z: np.ndarray) -> tuple[float, float, int, float]:
    """Lag-1 autocorrelation of the quadratically detrended decimated phase.

    Parameters
    ----------
    z : ndarray
        The ``count`` cluster sums ``x[(k+1) m] - x[k m]`` (any constant offset per sum,
        i.e. a linear phase trend, is irrelevant: the detrend removes it).

    Returns
    -------
    r1, den, size, scale
        As one order of :func:`adavar.stats.noise_id.alpha_from_lag1`'s inputs: the autocorrelation,
        its denominator ``sum e^2``, the series length ``count + 1`` and ``max |P|``.
    """
    z = np.ascontiguousarray(z, dtype=np.float64)
    count = z.size
    pm = np.zeros(5)
    phase_moments(z, count, 0, count, pm)
    ps = np.zeros(6)
    phase_residual_lag(z, count, 0, count, quadratic_fit(count, pm), ps)
    r1, den, scale = phase_lag1_result(count, pm, ps)
    return r1, den, count + 1, scale


quadratic_coefficients_compiled = jit(quadratic_coefficients)
lag1_of_sums_compiled = jit(lag1_of_sums)


@jit
def decimated_phase_stats(r, hh, hl, m, count):  # pragma: no cover - compiled
    """:func:`decimated_phase_lag1` of the anchored phase's ``count`` m-cluster sums,
    ``(r1, den, scale)``, bit for bit, without materialising them.

    The two passes of :func:`phase_moments` and :func:`phase_residual_lag` with the
    cluster sums computed as they are read (:func:`adavar._kernels.differences.cluster_sum`, as
    :func:`adavar._kernels.differences.cluster_differences` computes them) and the running sums
    held in registers: the same operations in the same order.
    """
    kc = 0.5 * count
    p = 0.0
    b0 = 0.0
    b1 = 0.0
    b2 = 0.0
    big = 0.0
    for q in range(count):
        p += cluster_sum(r, hh, hl, q * m, m)
        u = q + 1 - kc
        b0 += p
        b1 += u * p
        b2 += u * u * p
        big = max(big, abs(p))
    c0, c1, c2 = quadratic_coefficients_compiled(count, b0, b1, b2)
    e = -(c0 - c1 * kc + c2 * kc * kc)  # the point P[0] = 0
    first = e
    prev = e
    s1 = e
    s2 = e * e
    s11 = 0.0
    p = 0.0
    for q in range(count):
        p += cluster_sum(r, hh, hl, q * m, m)
        u = q + 1 - kc
        e = p - (c0 + c1 * u + c2 * u * u)
        s1 += e
        s2 += e * e
        s11 += prev * e
        prev = e
    r1, den = lag1_of_sums_compiled(count + 1, s1, s2, s11, first, prev)
    return r1, den, big


# ---------------------------------------------------------------------------------------
# the fused levels: from the integration's block moments, no pass over the data


@jit
def _fused_levels(stats, hh, hl, r, n, zmax, out):  # pragma: no cover - compiled
    """Per fused level ``m = 2**lev``: ``out[lev] = (r1, den, scale, tol_r1, tol_den)``
    of the decimated phase from the integration's block moments (module notes), NaN
    where the level has fewer than 8 clusters or ``den <= 0``."""
    unit = 2.0**-53
    nb = stats.shape[0]
    for lev in range(stats.shape[1]):
        for k in range(5):
            out[lev, k] = np.nan
        c = n >> lev
        if c < 8:
            continue
        kc = 0.5 * c
        # the sums of P, u P, u^2 P and P^2 over the points k = 0 .. c (u = k - c/2):
        # each block's, about its anchor and its first point, moved to the record's
        b0 = 0.0
        b1 = 0.0
        b2 = 0.0
        pp = 0.0
        s1 = 0.0  # and the rate's sums of z, t z and z^2 (t = k - (c-1)/2)
        st = 0.0
        s2 = 0.0
        big = 0.0  # an upper bound of |P|
        for b in range(nb):
            nq = stats[b, lev, 7]
            if nq <= 0:  # the blocks holding cluster starts are a prefix
                break
            a = hh[b] + hl[b]
            v = ((b << SHIFT) >> lev) - kc  # the abscissa of the block's first point
            q1 = 0.5 * nq * (nq - 1.0)
            q2 = (nq - 1.0) * nq * (2.0 * nq - 1.0) / 6.0
            w0 = stats[b, lev, 8]  # the block's sums of rb, q rb, q^2 rb, rb^2
            w1 = stats[b, lev, 9]
            w2 = stats[b, lev, 10]
            rr = stats[b, lev, 11]
            b0 += nq * a + w0
            b1 += a * (nq * v + q1) + (v * w0 + w1)
            b2 += a * (nq * v * v + 2.0 * v * q1 + q2) + (v * v * w0 + 2.0 * v * w1 + w2)
            pp += (nq * a + 2.0 * w0) * a + rr
            s1 += stats[b, lev, 0]
            st += stats[b, lev, 1]
            s2 += stats[b, lev, 2]
            big = max(big, abs(hh[b]) + abs(hl[b]) + math.sqrt(rr))  # max |rb| <= sqrt(rr)
        j = c << lev  # the last point, S[c m]: no cluster starts there
        last = (hh[j >> SHIFT] + r[j]) + hl[j >> SHIFT]
        b0 += last
        b1 += kc * last
        b2 += kc * kc * last
        pp += last * last
        big = max(big, abs(last))
        c0, c1, c2 = quadratic_coefficients_compiled(c, b0, b1, b2)
        # sum e^2 of the least-squares residuals; the lag products from
        # sum e_(k-1) e_k = sum e^2 - (e_0^2 + e_c^2) / 2 - sum (e_k - e_(k-1))^2 / 2, the
        # differences being the cluster sums less the fitted curve's, c1 + 2 c2 t
        den = pp - (c0 * b0 + c1 * b1 + c2 * b2)
        e0 = -(c0 - c1 * kc + c2 * kc * kc)
        ec = last - (c0 + c1 * kc + c2 * kc * kc)
        stt = c * (c * c - 1.0) / 12.0
        steps = s2 - 2.0 * c1 * s1 - 4.0 * c2 * st + c * c1 * c1 + 4.0 * c2 * c2 * stt
        lag = 0.5 * (steps + e0 * e0 + ec * ec)
        r1 = 1.0 - lag / den if den > 0.0 else math.nan
        # the bounds of the module notes: this computation's (_f) and the sequential
        # passes' (_h), each against the exact residuals of the anchored phase
        points = c + 1.0
        g_f = (BLOCK + nb + 16.0) * unit
        g_h = points * unit
        curve = abs(c0) + abs(c1) * kc + abs(c2) * kc * kc
        ends = abs(e0) + abs(ec)
        zm = zmax[lev]
        d_den_f = 8.0 * g_f * points * (big + curve) ** 2
        terms = s2 + 2.0 * abs(c1 * s1) + 4.0 * abs(c2 * st) + c * c1 * c1 + 4.0 * c2 * c2 * stt
        terms += c * (zm + 2.0 * big) * (zm + curve) + 8.0 * big * math.sqrt(c * abs(steps))
        d_steps_f = 8.0 * g_f * terms
        a_f = 16.0 * g_f * big + 8.0 * unit * (big + curve)
        d_lag_f = 0.5 * d_steps_f + 2.0 * a_f * ends + 4.0 * a_f * a_f
        a_h = 256.0 * g_h * (big + zm) + 8.0 * unit * (big + curve)
        eta_h = 512.0 * unit * (big + zm + curve)
        out[lev, 0] = r1
        out[lev, 1] = den
        out[lev, 2] = big + a_h
        if not den > 0.0:
            continue
        rho = 2.0 * a_h * math.sqrt(points / den)
        d_den_h = (2.0 * rho + rho * rho + 2.0 * g_h) * den
        d_lag_h = math.sqrt(c * abs(steps)) * eta_h + 0.5 * c * eta_h * eta_h
        d_lag_h += 2.0 * a_h * ends + 4.0 * a_h * a_h
        low = den - d_den_f - d_den_h
        if not low > 0.0:
            continue
        x = (d_lag_h + d_lag_f) / low + 4.0 * (g_h + g_f)
        y = (d_den_h + d_den_f) / low
        if 4.0 * y < 1.0:
            out[lev, 3] = 4.0 * (x + abs(1.0 - r1) * y) / (1.0 - 4.0 * y) + 1e-12
        out[lev, 4] = 4.0 * (d_den_h + d_den_f) / den


def fused_phase_levels(phase: AnchoredPhase) -> np.ndarray | None:
    """The decimated phase's lag-1 statistics at every fused level, with their bounds.

    Returns ``None`` without the integration's moments
    (:func:`adavar._kernels.differences.anchored_phase` with ``cluster_stats=True``), else one row
    per level ``m = 2**lev``: ``(r1, den, scale, tol_r1, tol_den)``, NaN where the level
    has fewer than 8 clusters (``tol_r1`` and ``tol_den`` NaN also where no bound holds).
    :func:`decimated_phase_stats` of the level gives an ``r1`` within ``tol_r1`` of this
    one, a ``den`` within ``tol_den * den`` and a ``scale`` of at most this one (module
    notes). No pass over the data: a few operations per block and level.
    """
    stats = phase.cluster_stats
    if stats is None or phase.fused is None:
        return None
    out = np.empty((stats.shape[1], 5))
    zmax = np.ascontiguousarray(phase.fused[:, 2])
    _fused_levels(stats, phase.hh, phase.hl, phase.r, phase.n_points - 1, zmax, out)
    return out

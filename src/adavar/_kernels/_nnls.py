"""The compiled exact NNLS kernel behind :func:`adavar.fit_avar` (diagonal weights).

Moved out of :mod:`adavar.fit.noise_model` unchanged; see its docstring for the method.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from adavar._kernels._jit import jit, threaded_jit

_PIVOT_TOL = 1e-13  # smallest Cholesky pivot of an equilibrated normal matrix
BLOCK = 256  # curves per block of nnls_blocks
PARALLEL_MIN = 1024  # smaller stacks run on the calling thread (no thread start-up cost)

# --------------------------------------------------------------------------------------
# The compiled kernel
# --------------------------------------------------------------------------------------


@jit(error_model="numpy")
def _solve_subset(G, h, sub_idx, mask, s, L, dsc, x):  # pragma: no cover - compiled
    """Solve the normal equations restricted to the terms of ``mask``.

    Jacobi-equilibrated Cholesky of ``G[idx][:, idx]`` into ``L``/``dsc``, then the solve
    into ``x[:s]``. Returns False (and leaves ``x`` undefined) if the sub-matrix is not
    numerically positive definite.
    """
    for a in range(s):
        g = G[sub_idx[mask, a], sub_idx[mask, a]]
        if not g > 0.0:
            return False
        dsc[a] = 1.0 / math.sqrt(g)
    for a in range(s):
        ia = sub_idx[mask, a]
        for b in range(a + 1):
            v = G[ia, sub_idx[mask, b]] * dsc[a] * dsc[b]
            for k in range(b):
                v -= L[a, k] * L[b, k]
            if a == b:
                if not v > _PIVOT_TOL:
                    return False
                L[a, a] = math.sqrt(v)
            else:
                L[a, b] = v / L[b, b]
    for a in range(s):
        v = h[sub_idx[mask, a]] * dsc[a]
        for k in range(a):
            v -= L[a, k] * x[k]
        x[a] = v / L[a, a]
    for a in range(s - 1, -1, -1):
        v = x[a]
        for k in range(a + 1, s):
            v -= L[k, a] * x[k]
        x[a] = v / L[a, a]
    for a in range(s):
        x[a] *= dsc[a]
    return True


@jit(error_model="numpy")
def _inv_diag(s, L, dsc, out, col):  # pragma: no cover - compiled
    """Diagonal of ``G_sub^-1`` from the factor left by :func:`_solve_subset`."""
    # G_sub = D^-1 (L L^T) D^-1, so G_sub^-1 = D L^-T L^-1 D and
    # diag_c = dsc_c^2 * sum_a (L^-1)[a, c]^2 (column c of L^-1 by forward substitution).
    for c in range(s):
        acc = 0.0
        for a in range(c, s):
            v = 1.0 if a == c else 0.0
            for k in range(c, a):
                v -= L[a, k] * col[k]
            col[a] = v / L[a, a]
            acc += col[a] * col[a]
        out[c] = acc * dsc[c] * dsc[c]


@jit(error_model="numpy")
def _try_subset(
    G, h, sub_idx, sub_size, mask, n_terms, L, dsc, x, phi, avar_i, ok, w
):  # pragma: no cover - compiled
    """Solve one active set. Returns (status, objective).

    status 0: singular or infeasible (some coefficient <= 0); 1: feasible; 2: feasible and
    the KKT conditions hold (every excluded term's gradient ``h_k - (G x)_k <= 0``), i.e.
    the NNLS optimum.
    """
    s = sub_size[mask]
    if not _solve_subset(G, h, sub_idx, mask, s, L, dsc, x):
        return 0, 0.0
    for a in range(s):
        if not x[a] > 0.0:
            return 0, 0.0
    obj = 0.0
    for j in range(avar_i.shape[0]):
        if ok[j]:
            r = avar_i[j]
            for a in range(s):
                r -= x[a] * phi[j, sub_idx[mask, a]]
            obj += w[j] * r * r
    for k in range(n_terms):
        if not (mask >> k) & 1:
            dual = h[k]
            for a in range(s):
                dual -= G[k, sub_idx[mask, a]] * x[a]
            if dual > 0.0:
                return 1, obj
    return 2, obj


@jit(error_model="numpy")
def _lawson_hanson(G, h, n_terms, sub_idx, sub_size, L, dsc, x, xcur):  # pragma: no cover
    """Active set of the Lawson-Hanson NNLS iteration on the normal equations.

    Returns the bit mask of the positive coefficients, or -1 if the iteration fails to
    converge (rounding in a degenerate problem); the caller verifies the KKT conditions.
    """
    passive = np.int64(0)
    for k in range(n_terms):
        xcur[k] = 0.0
    for _outer in range(3 * n_terms + 3):
        # most promising excluded term: largest gradient per unit of its column norm
        add = -1
        best = 0.0
        for k in range(n_terms):
            if not (passive >> k) & 1:
                grad = h[k]
                for b in range(n_terms):
                    grad -= G[k, b] * xcur[b]
                v = grad / math.sqrt(G[k, k])
                if v > best:
                    best = v
                    add = k
        if add < 0:
            return passive
        passive |= 1 << add
        for _inner in range(n_terms + 1):
            s = sub_size[passive]
            if not _solve_subset(G, h, sub_idx, passive, s, L, dsc, x):
                return -1
            step = 1.0
            all_pos = True
            for a in range(s):
                if not x[a] > 0.0:
                    all_pos = False
                    k = sub_idx[passive, a]
                    den = xcur[k] - x[a]
                    r = xcur[k] / den if den > 0.0 else 0.0
                    if r < step:
                        step = r
            if all_pos:
                for a in range(s):
                    xcur[sub_idx[passive, a]] = x[a]
                break
            for a in range(s):
                k = sub_idx[passive, a]
                xcur[k] += step * (x[a] - xcur[k])
            for a in range(s):
                k = sub_idx[passive, a]
                if not xcur[k] > 0.0:
                    xcur[k] = 0.0
                    passive &= ~(1 << k)
        else:
            return -1
    return -1


@threaded_jit
def nnls_blocks(
    phi, avar, edf, n_reweight, sub_idx, sub_size, order, sel, unscale, weighted, share,
    coef, coef_sig, chi2, npts, neff, per, k_lo, k_hi,
):  # fmt: skip  # pragma: no cover - compiled
    """Iteratively reweighted exact NNLS of the rows of work items ``k_lo .. k_hi - 1``.

    Work item ``k`` is blocks ``k per .. (k + 1) per - 1`` of :data:`BLOCK` rows (curves).
    Each curve is fitted on its own (the hints change the order in which active sets are
    tried, never the optimum), so the rows come out the same whichever thread fits which
    block. The curve's loop body is written out here rather than called: a separate
    compiled function for it took 0.7 s more to compile on a first run (Numba optimises
    and compiles a callee's code again inside its caller) and ran 13 % slower.

    Each row ``i`` of ``avar`` is a curve (see the module docs). ``phi[j, a]`` is the basis
    of the selected term ``sel[a]`` on the scaled time axis, so the solution ``d_a`` gives
    ``C = d_a * unscale[a]``. Writes, per curve, the five
    ``C_n`` into ``coef`` (0 for unselected or pinned terms; NaN if not fitted), their
    scaled 1-sigma into ``coef_sig`` (unconstrained covariance for pinned terms, NaN for
    unselected ones), the weighted residual sum of squares ``chi2``, the number of valid
    points ``npts`` and their sum of ``share`` ``neff`` (the effective number of points).

    The active sets are tried in a per-curve order (``hints[p]``, the optimum of the
    same pass ``p`` of the previous curve, then this curve's previous pass's optimum, then
    the Lawson-Hanson active set, then all sets from the largest down); the first one that
    is feasible and satisfies the KKT conditions is the unique NNLS optimum, whichever set
    was tried first. (Neighbouring windows of a surface nearly always share the active set
    of each pass, whose weights differ from pass to pass, so the hints spare 98 % of the
    curves' passes the Lawson-Hanson iteration.) If rounding lets no set pass the KKT test
    (a degenerate optimum), the feasible set with the smallest weighted residual is taken
    instead, which is the same optimum by exhaustion. Each pass's optimum is written into
    ``hints`` for the next curve (left alone when the curve is not fitted).
    """
    n_curves, n_tau = avar.shape
    n_terms = phi.shape[1]
    w = np.empty(n_tau)
    ref = np.empty(n_tau)
    ok = np.empty(n_tau, dtype=np.bool_)
    G = np.empty((n_terms, n_terms))
    h = np.empty(n_terms)
    L = np.empty((n_terms, n_terms))
    dsc = np.empty(n_terms)
    x = np.empty(n_terms)
    best_x = np.empty(n_terms)
    xcur = np.empty(n_terms)
    dg = np.empty(n_terms)
    hints = np.zeros(n_reweight + 1, dtype=np.int64)
    n_order = order.shape[0]
    full = (1 << n_terms) - 1
    for i in range(k_lo * per * BLOCK, min(k_hi * per * BLOCK, n_curves)):
        ie = i if edf.shape[0] > 1 else 0  # a single edf row serves every curve
        avar_i = avar[i]
        n = 0
        n_eff = 0.0
        for j in range(n_tau):
            a = avar_i[j]
            e = edf[ie, j]
            good = np.isfinite(a) and np.isfinite(e) and a > 0.0 and e > 0.0
            ok[j] = good
            if good:
                ref[j] = a
                n += 1
                n_eff += share[j]
        npts[i] = n
        neff[i] = n_eff
        for k in range(5):
            coef[i, k] = np.nan
            coef_sig[i, k] = np.nan
        chi2[i] = np.nan
        if n < n_terms:
            continue
        best_mask = np.int64(0)
        best_obj = 0.0
        for _pass in range(n_reweight + 1):
            for j in range(n_tau):
                w[j] = edf[ie, j] / (2.0 * ref[j] * ref[j]) if ok[j] else 0.0
            yy = 0.0
            for a in range(n_terms):
                h[a] = 0.0
                for b in range(a + 1):
                    G[a, b] = 0.0
            for j in range(n_tau):
                if ok[j]:
                    wj = w[j]
                    yj = avar_i[j]
                    yy += wj * yj * yj
                    for a in range(n_terms):
                        wpa = wj * phi[j, a]
                        h[a] += wpa * yj
                        for b in range(a + 1):
                            G[a, b] += wpa * phi[j, b]
            for a in range(n_terms):
                for b in range(a):
                    G[b, a] = G[a, b]
            # candidates: this pass's optimum for the previous curve, this curve's previous
            # pass's optimum, the Lawson-Hanson active set, then every set from the largest
            # down (exhaustive fallback)
            prev = best_mask if _pass > 0 else 0
            hint = hints[_pass]
            lh = -1
            held = -1  # the active set whose factor of this pass's G is in L, dsc
            # the empty set (all zero) is always feasible: the fallback's start
            best_mask = np.int64(0)
            best_obj = yy
            for k in range(n_terms):
                best_x[k] = 0.0
            for t in range(-3, n_order):
                if t == -3:
                    mask = hint
                    if mask == 0:
                        continue
                elif t == -2:
                    mask = prev
                    if mask == 0 or mask == hint:
                        continue
                elif t == -1:
                    lh = _lawson_hanson(G, h, n_terms, sub_idx, sub_size, L, dsc, x, xcur)
                    mask = lh
                    if mask <= 0 or mask == prev or mask == hint:
                        continue
                else:
                    mask = order[t]
                    if mask == prev or mask == lh or mask == hint:
                        continue
                status, obj = _try_subset(
                    G, h, sub_idx, sub_size, mask, n_terms, L, dsc, x, phi, avar_i, ok, w
                )
                if status == 0:
                    continue
                if status == 2 or obj < best_obj:
                    best_obj = obj
                    best_mask = mask
                    for k in range(n_terms):
                        best_x[k] = 0.0
                    for a in range(sub_size[mask]):
                        best_x[sub_idx[mask, a]] = x[a]
                if status == 2:
                    held = mask
                    break
            hints[_pass] = best_mask
            # next pass weights: the model avar (the measured one where the model is 0)
            for j in range(n_tau):
                if ok[j]:
                    m = 0.0
                    for k in range(n_terms):
                        m += best_x[k] * phi[j, k]
                    ref[j] = m if m > 0.0 else avar_i[j]
        chi2[i] = best_obj
        # covariance scale: max(1, chi2/dof) with absolute weights, chi2/dof otherwise
        dof = n_eff - n_terms  # effective: densely spaced taus count by their octave share
        red = best_obj / dof if dof > 0 else np.nan
        if weighted:
            factor = max(1.0, red) if dof > 0 else 1.0
        else:
            factor = red
        for k in range(5):
            coef[i, k] = 0.0
        for a in range(n_terms):
            coef[i, sel[a]] = best_x[a] * unscale[a]
        # 1-sigma of the active coefficients from the active set's covariance...
        if best_mask > 0:
            s = sub_size[best_mask]
            if held == best_mask or _solve_subset(G, h, sub_idx, best_mask, s, L, dsc, x):
                _inv_diag(s, L, dsc, dg, x)
                for a in range(s):
                    b = sub_idx[best_mask, a]
                    coef_sig[i, sel[b]] = math.sqrt(dg[a] * factor) * unscale[b]
        # ...and of the pinned ones from the unconstrained covariance (an upper bound)
        if best_mask != full and _solve_subset(G, h, sub_idx, full, n_terms, L, dsc, x):
            _inv_diag(n_terms, L, dsc, dg, x)
            for a in range(n_terms):
                if not (best_mask >> a) & 1:
                    coef_sig[i, sel[a]] = math.sqrt(dg[a] * factor) * unscale[a]


@lru_cache(maxsize=8)
def subsets(n_terms: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Members and sizes of every active set (bit mask), and the non-empty masks by size."""
    n_sub = 1 << n_terms
    idx = np.zeros((n_sub, max(n_terms, 1)), dtype=np.int64)
    size = np.zeros(n_sub, dtype=np.int64)
    for mask in range(n_sub):
        members = [k for k in range(n_terms) if mask >> k & 1]
        size[mask] = len(members)
        idx[mask, : len(members)] = members
    order = sorted(range(1, n_sub), key=lambda m: (-size[m], m))
    return idx, size, np.array(order, dtype=np.int64)

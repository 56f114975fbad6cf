"""The noise-model fit of one whole-record curve: full covariance, tau range, term selection.

This is the default fit of :func:`adavar.fit_noise` for a single Allan-variance curve (see
``method="gls"`` there). Compared with the diagonally weighted fit of stacks of curves, it
adds what real sensor logs need:

* **Generalised least squares with the estimators' covariance.** The AVAR estimates at
  different taus are correlated; their full covariance for the current model comes from
  :mod:`adavar.avar_covariance` (exact for Gaussian Q, N, B, K noise). The fit minimises
  ``(a - Phi C)^T Cov^-1 (a - Phi C)`` over ``C >= 0``, with ``Cov`` evaluated at the model
  of the previous pass (``n_iter`` passes, started from a diagonal fit), which avoids the
  low bias of data-based weights (Peelle's puzzle). The coefficient covariance is the
  inverse Fisher matrix ``(Phi^T Cov^-1 Phi)^-1`` of the selected terms, scaled by
  ``max(1, chi2/dof)``.
* **Terms only where the data support them.** Backward elimination: the least significant
  term (smallest ``C / sigma_C``) is removed while its significance is below
  ``significance`` (default 2, a one-sided 2.3 % false-inclusion rate), and the fit is
  repeated. A removed term keeps a 1-sigma upper bound.
* **Taus the model cannot describe.** The sensor's anti-aliasing filter and correlated
  short-tau noise make the Allan deviation roll off below the ``N / sqrt(tau)`` line; the
  five-term model cannot follow it and, with the huge weights of the short taus, would
  sacrifice the rest of the curve. With ``exclude="auto"`` the shortest tau is removed while
  the standardised residual of one of the three shortest fitted taus exceeds ``EXCLUDE_Z``
  (and it lies below a third of the curve's minimum), and the fit is repeated; every
  removal is reported with its reason.
* **A filter's roll-off, modelled.** For any short-correlated noise the Allan variance at
  ``tau`` well beyond its correlation time is ``A / tau + C / tau^2`` (a Taylor expansion of
  ``Var`` of the cluster sums: ``A = sum_k R(k)``, ``C = -1.5 tau0^2 sum_k |k| R(k)``).
  Quantization has ``C > 0``; a low-pass filter, whose samples are positively correlated,
  has ``C < 0``. With ``rolloff="model"`` the ``tau^-2`` coefficient may therefore be
  negative: a negative value models the roll-off (``Q`` is then reported as 0 and the
  coefficient as ``NoiseFit.rolloff``), so the taus just above the filter's time constant
  stay in the fit without biasing N low.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from adavar import avar_covariance
from adavar import edf as edf_mod

__all__ = [
    "DIAG_FLOOR",
    "EXCLUDE_Z",
    "MAX_TAUS",
    "SIGNIFICANCE",
    "GlsOutcome",
    "bounded_lsq",
    "fit_curve",
    "inverse_fisher",
    "nnls_gls",
    "thin",
    "whiten",
]

#: Default significance (C / sigma_C) a term needs to stay in the model.
SIGNIFICANCE = 2.0
#: Standardised residual beyond which the shortest tau is excluded (``exclude="auto"``).
EXCLUDE_Z = 3.0
#: The automatic exclusion only reaches taus below this fraction of the curve's minimum.
_EXCLUDE_REACH = 1.0 / 3.0
_EXCLUDE_LOOK = 3  # the shortest fitted taus whose residuals decide an exclusion
MAX_TAUS = 64  # denser grids are thinned for the covariance (4 per octave)
DIAG_FLOOR = 0.25  # Cov_jj >= this * 2 model^2 / edf (a deterministic ramp has no variance)


@dataclass(frozen=True)
class GlsOutcome:
    """What :func:`fit_curve` found (all arrays over the 5 terms or the M taus)."""

    coefficients: np.ndarray
    coefficient_uncertainty: np.ndarray
    coefficient_covariance: np.ndarray
    chi2: float
    dof: int
    n_points: int
    used: np.ndarray
    reasons: tuple[str, ...]
    residuals: np.ndarray
    dropped: tuple[int, ...]


def _weights_from_edf(model: np.ndarray, edf: np.ndarray) -> np.ndarray:
    return 2.0 * model**2 / edf


class _Problem:
    """The fixed parts of one curve's fit: design, data, covariance basis and its scaling."""

    def __init__(self, tau, avar, edf, ms, n_points, tau0, stat, alpha, powers):
        self.tau, self.avar, self.edf = tau, avar, edf
        self.phi = tau[:, None] ** powers[None, :]  # (M, 5)
        self.basis = avar_covariance.covariance_basis(ms, n_points, tau0)
        # adev/totdev: the oadev correlation with the statistic's own variance
        if stat == "oadev":
            self.scale = np.ones(tau.size)
        else:
            ratio = [
                edf_mod.edf("oadev", int(a), int(m), n_points) / e
                for a, m, e in zip(alpha, ms, edf, strict=True)
            ]
            self.scale = np.sqrt(np.asarray(ratio, dtype=float))

    def cov(self, coef: np.ndarray, idx: np.ndarray) -> np.ndarray:
        basis = self.basis[np.ix_(idx, idx)]
        c = avar_covariance.covariance(basis, coef)
        c *= np.outer(self.scale[idx], self.scale[idx])
        model = self.phi[idx] @ coef
        floor = DIAG_FLOOR * _weights_from_edf(model, self.edf[idx])
        d = np.diag(c)
        c[np.diag_indices_from(c)] = np.maximum(d, floor)
        return c


def whiten(cov: np.ndarray, scale: np.ndarray):
    """Cholesky factor of the covariance in relative units (``cov / (scale scale^T)``)."""
    rel = cov / np.outer(scale, scale)
    rel[np.diag_indices_from(rel)] *= 1.0 + 1e-10
    try:
        return np.linalg.cholesky(rel)
    except np.linalg.LinAlgError:
        w, v = np.linalg.eigh(rel)
        w = np.maximum(w, 1e-12 * w.max())
        return np.linalg.cholesky((v * w) @ v.T)


def bounded_lsq(a: np.ndarray, b: np.ndarray, free: np.ndarray) -> np.ndarray:
    """``min ||a x - b||`` with ``x >= 0`` except where ``free`` (columns scaled first)."""
    from scipy.optimize import lsq_linear, nnls

    norms = np.linalg.norm(a, axis=0)
    norms[norms == 0] = 1.0
    if not free.any():
        xs, _ = nnls(a / norms, b, maxiter=50 * a.shape[1])
    else:
        lower = np.where(free, -np.inf, 0.0)
        xs = lsq_linear(a / norms, b, bounds=(lower, np.inf), method="bvls").x
    return xs / norms


def nnls_gls(a, phi, chol, scale, free):
    """``min ||L^-1 (a - phi x) / scale||`` (x >= 0 but ``free``); x, chi2, whitened phi."""
    # a general solve: OpenBLAS's threaded triangular solve spins for milliseconds on a
    # 20 x 20 system when the other core is busy
    both = np.linalg.solve(chol, np.column_stack([phi / scale[:, None], a / scale]))
    aw, bw = both[:, :-1], both[:, -1]
    x = bounded_lsq(aw, bw, free)
    chi2 = float(np.sum((aw @ x - bw) ** 2))
    return x, chi2, aw


def inverse_fisher(aw: np.ndarray) -> np.ndarray:
    """``(A^T A)^-1`` of the whitened design ``aw``, with its columns equilibrated first.

    The columns of a wide tau range differ in scale by many decades (``tau^-2`` against
    ``tau^2``); a plain pseudo-inverse then drops the small singular values of the
    unscaled normal matrix as rank deficiency and reports near-zero uncertainties.
    """
    norms = np.linalg.norm(aw, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    scaled = aw / norms
    return np.linalg.pinv(scaled.T @ scaled) / np.outer(norms, norms)


def _fit_terms(prob: _Problem, idx: np.ndarray, cols: np.ndarray, n_iter: int, signed: bool):
    """IRLS GLS-NNLS of the terms ``cols`` on the taus ``idx``; (coef5, chi2, aw, cov)."""
    a = prob.avar[idx]
    phi = prob.phi[np.ix_(idx, cols)]
    free = (cols == 0) & signed
    # start: diagonal weights from the measured variance, then from the model
    coef = np.zeros(5)
    ref = a.copy()
    for _ in range(3):
        w = np.sqrt(prob.edf[idx] / 2.0) / ref
        x = bounded_lsq(phi * w[:, None], a * w, free)
        coef[:] = 0.0
        coef[cols] = x
        model = phi @ x
        ref = np.where(model > 0, model, a)
    if not np.any(coef[1:4] > 0):  # only a ramp: give the covariance something to work with
        coef[1] = np.median(a * prob.tau[idx])
    chi2, aw, cov = math.nan, None, None
    for _ in range(n_iter + 1):
        model = prob.phi[idx] @ coef
        scale = np.where(model > 0, model, a)
        cov = prob.cov(coef, idx)
        chol = whiten(cov, scale)
        x, chi2, aw = nnls_gls(a, phi, chol, scale, free)
        new = np.zeros(5)
        new[cols] = x
        if not np.any(new[1:4] > 0):
            break
        coef = new
    return coef, chi2, aw, cov


def thin(tau: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """At most 4 taus per octave: a dense grid adds no information, only cost."""
    keep = usable.copy()
    last = -np.inf
    for j in np.flatnonzero(usable):
        if math.log2(tau[j]) - last < 0.25 - 1e-9:
            keep[j] = False
        else:
            last = math.log2(tau[j])
    return keep


def fit_curve(
    tau: np.ndarray,
    avar: np.ndarray,
    edf: np.ndarray,
    *,
    ms: np.ndarray,
    n_points: int,
    tau0: float,
    stat: str,
    alpha: np.ndarray,
    terms: tuple[int, ...],
    usable: np.ndarray,
    reasons: list[str],
    n_iter: int = 3,
    select: str = "significance",
    significance: float = SIGNIFICANCE,
    exclude: str = "auto",
    rolloff: str = "model",
) -> GlsOutcome:
    """Fit one curve (see the module docstring).

    Parameters
    ----------
    tau, avar, edf, ms, alpha : ndarray, shape (M,)
        The curve, its degrees of freedom, averaging factors and identified noise types.
    n_points : int
        Phase points of the record.
    tau0 : float
        Sample interval (s).
    stat : {"oadev", "adev", "totdev"}
        The statistic of ``avar``.
    terms : tuple of int
        Indices (0..4, Q..R) of the candidate terms.
    usable : ndarray of bool, shape (M,)
        Points that may enter the fit (finite, positive, inside the tau range).
    reasons : list of str, length M
        Why each unusable point is out ("" where usable); updated with the exclusions.
    n_iter : int
        GLS passes after the first, each with the covariance of the previous model.
    select : {"significance", "none"}
        Backward elimination of insignificant terms, or every candidate term (NNLS).
    significance : float
        ``C / sigma_C`` a term needs to stay.
    exclude : {"auto", "none"}
        Automatic exclusion of short taus the model cannot describe.
    rolloff : {"model", "none"}
        ``"model"``: the ``tau^-2`` coefficient may be negative (see the module docstring).

    Returns
    -------
    GlsOutcome
    """
    powers = np.arange(-2, 3)
    used = usable.copy()
    thinned = thin(tau, usable) if usable.sum() > MAX_TAUS else usable
    for j in np.flatnonzero(usable & ~thinned):
        reasons[j] = "thinned: a denser tau grid than 4 per octave adds no information"
    used = thinned.copy()
    prob = _Problem(tau, avar, edf, ms, n_points, tau0, stat, alpha, powers)
    dev = np.sqrt(np.where(usable, avar, np.nan))
    tau_min_dev = tau[np.nanargmin(dev)] if np.any(usable) else np.inf
    n_cand = len(terms)

    while True:
        idx = np.flatnonzero(used)
        cols = np.array(terms, dtype=np.int64)
        dropped: list[int] = []
        while True:
            coef, chi2, aw, cov = _fit_terms(prob, idx, cols, n_iter, rolloff == "model")
            dof = idx.size - cols.size
            factor = max(1.0, chi2 / dof) if dof > 0 else 1.0
            fisher = inverse_fisher(aw) * factor
            sig = np.sqrt(np.maximum(np.diag(fisher), 0.0))
            # a negative tau^-2 (roll-off) term is as significant as its magnitude
            z = np.where(sig > 0, np.abs(coef[cols]) / np.where(sig > 0, sig, 1.0), 0.0)
            if select != "significance" or cols.size <= 1:
                break
            worst = int(np.argmin(z))
            if z[worst] >= significance:
                break
            dropped.append(int(cols[worst]))
            cols = np.delete(cols, worst)
        model = prob.phi @ coef
        good = np.flatnonzero(usable)
        full_cov = prob.cov(coef, good)
        resid = np.full(tau.size, np.nan)
        resid[good] = (avar[good] - model[good]) / np.sqrt(np.diag(full_cov))
        j0 = int(idx[0])
        # the fit bends to the shortest point, so judge its neighbours too (not the
        # long taus, whose few-dof estimates are far from Gaussian)
        short = idx[:_EXCLUDE_LOOK]
        short = short[tau[short] < _EXCLUDE_REACH * tau_min_dev]
        worst = float(np.max(np.abs(resid[short]))) if short.size else 0.0
        if (
            exclude == "auto"
            and idx.size > n_cand + 2
            and tau[j0] < _EXCLUDE_REACH * tau_min_dev
            and worst > EXCLUDE_Z
        ):
            used[j0] = False
            reasons[j0] = (
                f"short-tau roll-off: the model misses the short taus by up to {worst:.1f} "
                "sigma (a sensor filter or correlated noise the model cannot describe)"
            )
            continue
        break

    unc = np.full(5, np.nan)
    covariance = np.full((5, 5), np.nan)
    covariance[np.ix_(cols, cols)] = fisher
    unc[cols] = sig
    # a removed or pinned term: 1-sigma upper bound from the fit with it free
    for k in terms:
        if k in cols and coef[k] > 0:
            continue
        trial = np.array(sorted(set(cols.tolist()) | {k}), dtype=np.int64)
        scale = np.where(model[idx] > 0, model[idx], avar[idx])
        _, _, aw_k = nnls_gls(
            avar[idx], prob.phi[np.ix_(idx, trial)], whiten(cov, scale), scale,
            (trial == 0) & (rolloff == "model"),
        )  # fmt: skip
        f_k = inverse_fisher(aw_k) * factor
        unc[k] = math.sqrt(max(f_k[list(trial).index(k), list(trial).index(k)], 0.0))
    return GlsOutcome(
        coefficients=coef,
        coefficient_uncertainty=unc,
        coefficient_covariance=covariance,
        chi2=chi2,
        dof=max(idx.size - cols.size, 0),
        n_points=int(idx.size),
        used=used,
        reasons=tuple(reasons),
        residuals=resid,
        dropped=tuple(sorted(dropped)),
    )

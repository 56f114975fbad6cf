"""The pieces of the full-covariance noise fit (:mod:`adavar.fit.gls_fit`): one curve's design,
data and covariance, the whitened non-negative solves, and the likelihood of a model.

Coefficient vectors have six entries: ``C_-2 .. C_2`` of the IEEE terms and the variance
of a Gauss-Markov term (:data:`MARKOV`; 0 without one).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from adavar.core.terms import markov_avar
from adavar.stats import avar_covariance
from adavar.stats import edf as edf_mod

__all__ = [
    "DIAG_FLOOR",
    "MARKOV",
    "MAX_TAUS",
    "Problem",
    "Whitened",
    "below",
    "below_noise_terms",
    "bounded_lsq",
    "chi2_sf",
    "decorrelated_chi2",
    "fit_terms",
    "inverse_fisher",
    "neg2_log_likelihood",
    "nnls_gls",
    "normal_scores",
    "signed_nnls",
    "solve",
    "thin",
    "wald_sigma",
    "white_excess",
    "whiten",
    "whitened",
]

MAX_TAUS = 64  # denser grids are thinned for the covariance (4 per octave)
MEMO_SIZE = 512  # results a Problem remembers (a fit asks for a few hundred)
DIAG_FLOOR = 0.25  # Cov_jj >= this * 2 model^2 / edf (a deterministic ramp has no variance)
MARKOV = 5  # index of the Gauss-Markov variance after the five IEEE coefficients
_SCORE_CAP = 38.0  # |normal score| of an estimate beyond any float64 tail probability


#: Largest excess kurtosis of the white rate noise the fit's covariance takes (a record of
#: rare steps of a coarse quantiser reads hundreds)
MAX_EXCESS = 100.0


def white_excess(result: Any) -> float:
    """Excess kurtosis of the white rate noise, from the result's
    ``increment_kurtosis`` (that of the first differences: half the samples' excess);
    0 where unknown."""
    k = getattr(result, "increment_kurtosis", None)
    if k is None or not math.isfinite(float(k)):
        return 0.0
    return float(min(max(2.0 * (float(k) - 3.0), -2.0), MAX_EXCESS))


def _weights_from_edf(model: np.ndarray, edf: np.ndarray) -> np.ndarray:
    return 2.0 * model**2 / edf


class Problem:
    """The fixed parts of one curve's fit: design, data, covariance basis and its scaling.

    Coefficient vectors have six entries: ``C_-2 .. C_2`` and the Gauss-Markov variance
    (0 without one); the sixth design column is that term's Allan variance per unit
    variance at :attr:`markov_tau` (zeros when there is none). The covariance is known only
    at the taus ``covered`` (the fitted ones, at most :data:`MAX_TAUS` after thinning): its
    basis costs O(M^2) pairs of lag sums, which a grid of every tau would make hours.
    """

    def __init__(self, tau, avar, edf, ms, n_points, tau0, stat, alpha, powers,
                 excess=0.0, covered=None):  # fmt: skip
        self.tau, self.avar, self.edf = tau, avar, edf
        self.ms, self.n_points, self.tau0 = ms, n_points, tau0
        covered = np.arange(tau.size) if covered is None else np.asarray(covered)
        self.covered = covered
        self.position = np.full(tau.size, -1, dtype=np.int64)
        self.position[covered] = np.arange(covered.size)
        # heavy tails of the white rate noise (excess kurtosis of its samples): the
        # fourth-cumulant part of the estimates' covariance, per unit C_-1^2
        self.tails = None
        if excess and math.isfinite(excess) and stat == "oadev":
            self.tails = (excess / tau0**2) * avar_covariance.fourth_cumulant_basis(
                ms[covered], n_points
            )
        self.phi = np.zeros((tau.size, 6))
        self.phi[:, :5] = tau[:, None] ** powers[None, :]  # (M, 6)
        self.basis = avar_covariance.covariance_basis(ms[covered], n_points, tau0)
        self.markov_tau: float | None = None
        # results of cov() and whitened() by their exact inputs: the model selection and
        # the profile bounds ask for about a third of them again (read-only arrays)
        self.memo: dict[tuple, Any] = {}
        # adev/totdev: the oadev correlation with the statistic's own variance
        if stat == "oadev":
            self.scale = np.ones(tau.size)
        else:
            ratio = [
                edf_mod.edf("oadev", int(a), int(m), n_points) / e
                for a, m, e in zip(alpha, ms, edf, strict=True)
            ]
            self.scale = np.sqrt(np.asarray(ratio, dtype=float))

    def set_markov(self, tau_c: float | None) -> None:
        """Give the sixth column (and the covariance) the Gauss-Markov term at ``tau_c``."""
        if tau_c == self.markov_tau:
            return
        self.markov_tau = tau_c
        self.memo.clear()
        ms = self.ms[self.covered]
        if tau_c is None:
            self.phi[:, MARKOV] = 0.0
            self.basis = avar_covariance.covariance_basis(ms, self.n_points, self.tau0)
        else:
            self.phi[:, MARKOV] = markov_avar(self.tau, 1.0, tau_c)
            self.basis = avar_covariance.covariance_basis(
                ms, self.n_points, self.tau0, markov_tau=tau_c
            )

    def model(self, coef: np.ndarray) -> np.ndarray:
        return self.phi @ coef

    def remembered(self, key: tuple, compute: Callable[[], Any]) -> Any:
        """``compute()``, once for each ``key`` while the model's columns stay
        (:meth:`set_markov` forgets); a key holds every input the result depends on."""
        if key not in self.memo:
            if len(self.memo) >= MEMO_SIZE:
                self.memo.clear()
            self.memo[key] = compute()
        return self.memo[key]

    def cov(self, coef: np.ndarray, idx: np.ndarray) -> np.ndarray:
        """The covariance of the estimates at ``idx`` (taus the problem covers); read-only."""
        key = ("cov", _exact(idx), _exact(coef))
        return self.remembered(key, lambda: _read_only(self._cov(coef, idx)))

    def _cov(self, coef: np.ndarray, idx: np.ndarray) -> np.ndarray:
        basis, scales, tails, phi, edf = self.remembered(
            ("taus", _exact(idx)), lambda: self._at(idx)
        )
        markov = coef[MARKOV] if self.markov_tau is not None else 0.0
        c = avar_covariance.covariance(basis, coef[:5], markov_var=markov)
        c *= scales
        if tails is not None:
            c += tails * max(coef[1], 0.0) ** 2
        model = phi @ coef
        floor = DIAG_FLOOR * _weights_from_edf(model, edf)
        diagonal = np.arange(c.shape[0])
        c[diagonal, diagonal] = np.maximum(c[diagonal, diagonal], floor)
        return c

    def _at(self, idx: np.ndarray) -> tuple:
        """What the covariance at ``idx`` takes of the problem (the same for every model)."""
        pos = self.position[idx]
        if np.any(pos < 0):
            raise ValueError("internal: a covariance asked at taus the problem does not cover")
        rows = np.ix_(pos, pos)
        tails = None if self.tails is None else _read_only(self.tails[rows])
        return (
            _read_only(self.basis[rows]),
            _read_only(np.outer(self.scale[idx], self.scale[idx])),
            tails,
            _read_only(self.phi[idx]),
            _read_only(self.edf[idx]),
        )


def whiten(cov: np.ndarray, scale: np.ndarray):
    """Cholesky factor of the covariance in relative units (``cov / (scale scale^T)``)."""
    rel = cov / np.outer(scale, scale)
    diagonal = np.arange(rel.shape[0])
    rel[diagonal, diagonal] *= 1.0 + 1e-10
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


def signed_nnls(a: np.ndarray, b: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, float]:
    """:func:`bounded_lsq` as one NNLS: a free column is the difference of two
    non-negative ones (fast enough for the hundreds of subsets of the model selection).
    Returns ``(x, chi2)``."""
    from scipy.optimize import nnls

    norms = np.linalg.norm(a, axis=0)
    norms[norms == 0] = 1.0
    scaled = a / norms
    if free.any():
        scaled = np.column_stack([scaled, -scaled[:, free]])
    xs, _ = nnls(scaled, b, maxiter=50 * scaled.shape[1])
    x = xs[: a.shape[1]].copy()
    x[free] -= xs[a.shape[1] :]
    x /= norms
    return x, float(np.sum((a @ x - b) ** 2))


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


def normal_scores(avar: np.ndarray, model: np.ndarray, variance: np.ndarray) -> np.ndarray:
    """Each estimate as a standard normal score under the model's chi-square law.

    An Allan-variance estimate is close to ``model * chi2(nu) / nu`` with
    ``nu = 2 model^2 / variance``; its cumulative probability there, mapped through the
    normal quantile, is a residual with the same meaning at every tau, whether the estimate
    has millions of degrees of freedom (where it equals ``(avar - model) / sd``) or two.
    A model at or below 0 where the data are positive scores ``+_SCORE_CAP``.
    """
    from scipy.special import chdtr, chdtrc, ndtri

    with np.errstate(divide="ignore", invalid="ignore"):
        nu = 2.0 * model**2 / variance
        x = nu * avar / model
        low = chdtr(nu, x)
        score = np.where(low < 0.5, ndtri(low), -ndtri(chdtrc(nu, x)))
    score = np.where(model > 0, score, _SCORE_CAP)
    return np.clip(score, -_SCORE_CAP, _SCORE_CAP)


def fit_terms(prob: Problem, idx: np.ndarray, cols: np.ndarray, n_iter: int, signed: bool):
    """IRLS GLS-NNLS of the columns ``cols`` on the taus ``idx``; (coef6, chi2, aw, cov)."""
    a = prob.avar[idx]
    phi = prob.phi[np.ix_(idx, cols)]
    free = (cols == 0) & signed
    # start: diagonal weights from the measured variance, then from the model
    coef = np.zeros(6)
    ref = a.copy()
    for _ in range(3):
        w = np.sqrt(prob.edf[idx] / 2.0) / ref
        x = bounded_lsq(phi * w[:, None], a * w, free)
        coef[:] = 0.0
        coef[cols] = x
        model = phi @ x
        ref = np.where(model > 0, model, a)
    if not np.any(coef[1:4] > 0) and coef[MARKOV] <= 0:
        # only a ramp: give the covariance something to work with
        coef[1] = np.median(a * prob.tau[idx])
    chi2, aw, cov = math.nan, None, None
    for _ in range(n_iter + 1):
        model = prob.phi[idx] @ coef
        scale = np.where(model > 0, model, a)
        cov = prob.cov(coef, idx)
        chol = whiten(cov, scale)
        x, chi2, aw = nnls_gls(a, phi, chol, scale, free)
        new = np.zeros(6)
        new[cols] = x
        if not np.any(new[1:4] > 0) and new[MARKOV] <= 0:
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


@dataclass
class Whitened:
    """The data and the six design columns whitened by one covariance (Cholesky ``chol``,
    relative to ``scale``): chi-squares of different models are then comparable."""

    chol: np.ndarray
    scale: np.ndarray
    aw: np.ndarray  # (n, 6): the IEEE columns and the Gauss-Markov one
    bw: np.ndarray  # (n,)

    def column(self, values: np.ndarray) -> np.ndarray:
        return np.linalg.solve(self.chol, values / self.scale)


def whitened(prob: Problem, idx: np.ndarray, coef: np.ndarray, *, data: bool = False) -> Whitened:
    """The data and design whitened by the covariance of the model ``coef``; with ``data``,
    by the model's correlation and the data's own scale (each estimate's sd in proportion
    to itself), under which a model far above the data is as far off as one below.
    Read-only arrays, computed once for the same inputs (:meth:`Problem.remembered`)."""
    key = ("whitened", _exact(idx), _exact(coef), data)
    return prob.remembered(key, lambda: _whitened(prob, idx, coef, data))


def _whitened(prob: Problem, idx: np.ndarray, coef: np.ndarray, data: bool) -> Whitened:
    a = prob.avar[idx]
    model = prob.phi[idx] @ coef
    scale = a if data else np.where(model > 0, model, a)
    cov = prob.cov(coef, idx)
    if data:  # the same relative spread, about the data instead of the model
        ratio = np.where(model > 0, a / np.where(model > 0, model, 1.0), 1.0)
        cov = cov * np.outer(ratio, ratio)
    chol = whiten(cov, scale)
    both = np.linalg.solve(chol, np.column_stack([prob.phi[idx] / scale[:, None], a / scale]))
    return Whitened(*map(_read_only, (chol, scale, both[:, :-1], both[:, -1])))


def _exact(values: Any) -> tuple:
    """An array as a memo key: its type, shape and bytes (equal keys, equal arrays)."""
    values = np.asarray(values)
    return values.dtype.str, values.shape, values.tobytes()


def _read_only(values: np.ndarray) -> np.ndarray:
    values.setflags(write=False)
    return values


def solve(w: Whitened, cols, signed: bool, markov: np.ndarray | None = None):
    """NNLS of the columns ``cols`` (and a whitened Gauss-Markov column): (x, chi2)."""
    design = w.aw[:, list(cols)]
    free = [signed and c == 0 for c in cols]
    if markov is not None:
        design = np.column_stack([design, markov])
        free.append(False)
    return signed_nnls(design, w.bw, np.array(free, dtype=bool))


def neg2_log_likelihood(prob: Problem, idx: np.ndarray, coef: np.ndarray) -> float:
    """``-2 ln L`` of the curve under a model (up to a constant the same for every model).

    Each estimate follows its chi-square law under the model (a Gamma marginal with
    ``nu = 2 model^2 / Var`` degrees of freedom), and the estimates are tied together by a
    Gaussian copula whose correlation is the model's: ``sum -2 ln f_i(a_i) + z^T R^-1 z -
    z^T z + ln det R`` with ``z`` the normal scores. Both the scale and the correlation
    depend on the model, so unlike a chi-square under one covariance this compares a model
    that overshoots the data fairly with one that undershoots it. Computed once for the
    same inputs (:meth:`Problem.remembered`).
    """
    key = ("neg2", _exact(idx), _exact(coef))
    return prob.remembered(key, lambda: _neg2_log_likelihood(prob, idx, coef))


def _neg2_log_likelihood(prob: Problem, idx: np.ndarray, coef: np.ndarray) -> float:
    from scipy.special import gammaln

    a = prob.avar[idx]
    model = prob.phi[idx] @ coef
    if not np.all(model > 0):
        return math.inf
    cov = prob.cov(coef, idx)
    var = np.diag(cov)
    nu = 2.0 * model**2 / var
    r = a / model
    # -2 ln f = nu (r - 1 - ln r) + C(nu) + 2 ln a; the last term is the same for every model
    marginal = nu * ((r - 1.0) - np.log(r)) + nu - nu * np.log(nu / 2.0) + 2.0 * gammaln(nu / 2.0)
    z = normal_scores(a, model, var)
    d = np.sqrt(var)
    chol = whiten(cov / np.outer(d, d), np.ones(idx.size))
    zw = np.linalg.solve(chol, z)
    log_det = 2.0 * float(np.sum(np.log(np.diag(chol))))
    return float(np.sum(marginal) + zw @ zw - z @ z + log_det)


def chi2_sf(dof: int, chi2: float) -> float:
    """``P(chi2_dof >= chi2)``."""
    from scipy.special import chdtrc

    return float(chdtrc(dof, max(chi2, 0.0)))


def below(prob: Problem, coef: np.ndarray, j: int) -> float:
    """How many sigma the point ``j`` lies below the model ``coef`` (normal score, negated)."""
    model = float(prob.phi[j] @ coef)
    var = float(prob.cov(coef, np.array([j]))[0, 0])
    return -float(normal_scores(prob.avar[j : j + 1], np.array([model]), np.array([var]))[0])


def below_noise_terms(prob: Problem, coef: np.ndarray, j: int) -> float:
    """:func:`below` the model's non-negative terms (a negative ``tau^-2`` term left out)."""
    return below(prob, np.maximum(coef, 0.0), j)


def wald_sigma(design: np.ndarray) -> float:
    """The 1-sigma of the last column's coefficient (its scale for the bound's search)."""
    f = inverse_fisher(design)
    return math.sqrt(max(float(f[-1, -1]), 0.0))


def decorrelated_chi2(scores: np.ndarray, corr: np.ndarray) -> float:
    """``z^T R^-1 z`` (the scores' correlation ``R`` from the model's covariance)."""
    ok = np.isfinite(scores)
    z, r = scores[ok], corr[np.ix_(ok, ok)]
    if z.size == 0:
        return math.nan
    chol = whiten(r, np.ones(z.size))
    white = np.linalg.solve(chol, z)
    return float(white @ white)

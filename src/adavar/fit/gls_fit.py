"""The noise-model fit of one whole-record curve: full covariance, model selection, adequacy.

This is the default fit of :func:`adavar.fit_noise` for a single Allan-variance curve (see
``method="gls"`` there). Compared with the diagonally weighted fit of stacks of curves, it
adds what real sensor logs need:

* **Generalised least squares with the estimators' covariance.** The AVAR estimates at
  different taus are correlated; their full covariance for the current model comes from
  :mod:`adavar.stats.avar_covariance` (exact for Gaussian Q, N, B, K and Gauss-Markov noise). The
  fit minimises ``(a - Phi C)^T Cov^-1 (a - Phi C)`` over ``C >= 0``, with ``Cov`` evaluated
  at the model of the previous pass (``n_iter`` passes, started from a diagonal fit), which
  avoids the low bias of data-based weights (Peelle's puzzle). The coefficient covariance is
  the inverse Fisher matrix ``(Phi^T Cov^-1 Phi)^-1`` of the selected terms, scaled by
  ``max(1, chi2/dof)``.
* **Model selection by comparing likelihoods.** Every subset of the candidate terms is
  fitted and judged by its own likelihood: each estimate follows its chi-square law under
  that model (a Gamma marginal with ``nu = 2 model^2 / Var`` degrees of freedom) and the
  estimates are tied by a Gaussian copula with the model's correlation
  (:func:`neg2_log_likelihood`). Both the scale and the correlation are the model's own,
  so a model that overshoots the long taus (where the variance of the estimates grows
  with the model) pays for it as one that undershoots does; a chi-square under the
  covariance of one model would not see it. The subset of the least ``-2 ln L + penalty
  * k`` is kept (``k`` its parameters; penalty 2 for ``select="aic"``, ``ln(n)`` for
  ``"bic"``; a rate ramp, whose estimates have almost no variance, counts
  :data:`RAMP_PARAMS`). Dropping a term therefore always pays its price in likelihood;
  the earlier backward elimination by ``C / sigma_C`` (a Wald z computed after the
  uncertainties were inflated by a poor fit) is ``select="significance"``.
* **Bounds of the terms left out.** A term the selection leaves out (or pins at 0) gets a
  one-sided upper bound from its profile likelihood: the largest coefficient whose best
  fit of the other terms (each under its own covariance) costs at most ``z^2`` more than
  the best, which includes the estimate itself, not only its spread.
* **Adequacy judged on the data's own scale.** Each estimate's chi-square law under the
  model turns it into a normal score (:func:`normal_scores`), exact whatever the few
  degrees of freedom of the long taus; the scores, decorrelated with the model's
  correlation matrix, sum to a chi-square with ``n - k`` degrees of freedom
  (``NoiseFit.gof_chi2``). Unlike the GLS residuals, whose scale is the model's own
  variance, a model far above the data is as visible as one far below it.
* **A Gauss-Markov hump.** A first-order Gauss-Markov process (stationary sd ``sigma``,
  correlation time ``T``) rises like a rate random walk below ``T`` and falls like white
  noise beyond; without it, the fit turns the hump into bias instability and a rate random
  walk far above the long taus. Its Allan variance is linear in ``sigma^2`` for a given
  ``T``: after the tau range is settled with the IEEE terms, correlation times on a grid
  of four per octave are screened, the best few judged by their likelihood (with the
  covariance of the process, :mod:`adavar.stats.avar_covariance`), and the term enters only when
  it beats the best model without it by :data:`MARKOV_MARGIN` (it counts as two
  parameters).
* **Taus the model cannot describe.** The sensor's anti-aliasing filter and correlated
  short-tau noise make the Allan deviation roll off below the ``N / sqrt(tau)`` line; the
  five-term model cannot follow it and, with the huge weights of the short taus, would
  sacrifice the rest of the curve. With ``exclude="auto"`` the shortest tau is removed while
  it lies below the model's noise terms and the model either misses one of the three
  shortest fitted taus by more than ``EXCLUDE_Z`` or, fitted without it, passes more than
  ``EXCLUDE_Z`` above it (and it lies below a third of the curve's minimum); an exclusion
  is undone when it does not make the model describe the remaining points better (a bump
  of a process the model lacks, such as a vibration, is not a roll-off). Every removal is
  reported with its reason.
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

from adavar.core.results import ADEQUATE_P
from adavar.core.settings import FitSettings
from adavar.core.terms import AVAR_FACTORS
from adavar.fit.gls_core import (
    MARKOV,
    MAX_TAUS,
    Problem,
    below_noise_terms,
    chi2_sf,
    decorrelated_chi2,
    fit_terms,
    inverse_fisher,
    normal_scores,
    thin,
    wald_sigma,
    whitened,
)
from adavar.fit.gls_select import (
    choose,
    markov_range,
    profile_bound,
    selection_sigma,
    term_support,
)

__all__ = [
    "BOUND_Z",
    "DEFAULT_SELECT",
    "EXCLUDE_Z",
    "SELECTIONS",
    "SIGNIFICANCE",
    "GlsOutcome",
    "MarkovFit",
    "fit_curve",
]

#: How :func:`fit_curve` chooses the terms by default.
DEFAULT_SELECT = FitSettings.select
#: Default significance (C / sigma_C) a term needs to stay with ``select="significance"``.
SIGNIFICANCE = 2.0
#: Ways to choose the terms: information criteria, the old Wald elimination, or none.
SELECTIONS = ("aic", "bic", "significance", "none")
#: how a term's uncertainty treats the choice of the model (``fit_noise(uncertainty=)``)
UNCERTAINTIES = ("conditional", "averaged")
#: Standardised residual beyond which the shortest tau is excluded (``exclude="auto"``).
EXCLUDE_Z = 3.0
#: One-sided normal quantile of the ``uncertainty`` bound of a term left out (84.1 %).
BOUND_Z = 1.0
#: The automatic exclusion only reaches taus below this fraction of the curve's minimum.
_EXCLUDE_REACH = 1.0 / 3.0
_EXCLUDE_LOOK = 3  # the shortest fitted taus whose residuals decide an exclusion
_EXCLUDE_OCTAVES = 4  # ... or those this close to it, when the model misses the curve
_ROLLOFF_Z = 1.0  # an excluded point lies this far below the model's noise terms
#: ... and, without a 3-sigma miss, leaving it out lowers the rest's chi-square this much
_BEND_CHI2 = 9.0
_FAIR_P = 0.01  # an exclusion is kept when the fit of the rest reaches this p-value...
_MARKOV_GATE_P = 1e-6  # ... and a Gauss-Markov term when its model reaches this one
#: next to a roll-off, a Gauss-Markov time at least this many octaves above the first tau
_ROLLOFF_MARKOV_OCTAVES = 2.0
# a filter's rise: the first peak of the deviation within this many octaves of the shortest
# tau, followed by a fall below this fraction of it (short-tau estimates scatter by a few %)
_RISE_OCTAVES = 6.0
_RISE_FALL = 0.8


@dataclass(frozen=True)
class MarkovFit:
    """A first-order Gauss-Markov term found by the fit.

    Attributes
    ----------
    variance : float
        ``sigma^2``, the process's stationary variance (rate unit squared).
    variance_uncertainty : float
        1-sigma uncertainty of ``variance`` at the chosen correlation time.
    tau_c : float
        Correlation time (s).
    tau_c_range : tuple of float
        Correlation times whose best fit costs at most 1 in chi-square (a 68 % profile
        interval, limited to the fitted tau range).
    """

    variance: float
    variance_uncertainty: float
    tau_c: float
    tau_c_range: tuple[float, float]


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
    upper: np.ndarray
    gof_chi2: float
    markov: MarkovFit | None
    correlation: np.ndarray
    better: str | None = None
    support: np.ndarray | None = None


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
    select: str = DEFAULT_SELECT,
    significance: float = SIGNIFICANCE,
    exclude: str = "auto",
    rolloff: str = "model",
    markov: str = "auto",
    bound_z: float = 2.3263478740408408,
    excess: float = 0.0,
    uncertainty: str = FitSettings.uncertainty,
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
    select : {"aic", "bic", "significance", "none"}
        ``"aic"``/``"bic"``: the subset of ``terms`` (and Gauss-Markov term) of the least
        ``chi2 + penalty * parameters`` under one covariance (penalty 2 or ``ln(n)``);
        ``"significance"``: backward elimination while ``C / sigma_C < significance``;
        ``"none"``: every candidate term (NNLS).
    significance : float
        ``C / sigma_C`` a term needs to stay with ``select="significance"``.
    exclude : {"auto", "none"}
        Automatic exclusion of short taus the model cannot describe.
    rolloff : {"model", "none"}
        ``"model"``: the ``tau^-2`` coefficient may be negative (see the module docstring).
    markov : {"auto", "none"}
        ``"auto"``: the selection may add a first-order Gauss-Markov term (``"aic"`` and
        ``"bic"`` only).
    bound_z : float
        One-sided normal quantile of :attr:`GlsOutcome.upper` (2.326: 99 %).
    excess : float
        Excess kurtosis of the white rate noise's samples (0 for Gaussian noise): its
        fourth cumulant enters the estimates' covariance
        (:func:`adavar.stats.avar_covariance.fourth_cumulant_basis`).
    uncertainty : {"conditional", "averaged"}
        ``"averaged"``: each selected term's 1-sigma with the weight of the models without
        it (:func:`adavar.fit.gls_select.selection_sigma`; ``"aic"``/``"bic"`` only).

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
    covered = np.flatnonzero(thinned)
    prob = Problem(tau, avar, edf, ms, n_points, tau0, stat, alpha, powers, excess, covered)
    # the taus thinned out are scored with their own variance only (2 model^2 / edf)
    between = np.flatnonzero(usable & ~thinned)
    dev = np.sqrt(np.where(usable, avar, np.nan))
    tau_min_dev = _descent_minimum(tau, dev) if np.any(usable) else np.inf
    n_cand = len(terms)
    signed = rolloff == "model"
    all_cols = np.array(terms, dtype=np.int64)

    def evaluate(idx: np.ndarray, cols: np.ndarray) -> _State:
        coef, chi2, aw, _ = fit_terms(prob, idx, cols, n_iter, signed)
        # a Gauss-Markov term has a correlation time besides its column
        n_params = cols.size + (1 if prob.markov_tau is not None else 0)
        dof = idx.size - n_params
        factor = max(1.0, chi2 / dof) if dof > 0 else 1.0
        fisher = inverse_fisher(aw) * factor
        model = prob.model(coef)
        resid = np.full(tau.size, np.nan)
        resid[covered] = normal_scores(avar[covered], model[covered],
                                       np.diag(prob.cov(coef, covered)))  # fmt: skip
        if between.size:
            var = 2.0 * model[between] ** 2 / edf[between]
            resid[between] = normal_scores(avar[between], model[between], var)
        # adequacy: the normal scores of the fitted points, decorrelated
        cov_used = prob.cov(coef, idx)
        d = np.sqrt(np.diag(cov_used))
        gof = decorrelated_chi2(resid[idx], cov_used / np.outer(d, d))
        return _State(coef, chi2, n_params, factor, fisher, resid, gof)

    # the tau range first, with the IEEE terms: a Gauss-Markov hump could otherwise
    # imitate a filter's roll-off
    last = None
    while True:
        idx = np.flatnonzero(used)
        forced = _rolloff_forced(signed, reasons, usable)
        cols, dropped, _ = choose(prob, idx, all_cols, n_iter, signed, select, significance,
                                   False, forced)  # fmt: skip
        state = evaluate(idx, cols)
        if last is not None and not _improves(state, idx.size, *last[3:5], last[5]):
            # leaving the point out did not make the model describe the rest better: the
            # misfit is not a roll-off (a bump the model lacks); keep it
            j_back, reason_back, (idx, cols, dropped, state) = last[0], last[1], last[2]
            used[j_back] = True
            reasons[j_back] = reason_back
            break
        j0 = int(idx[0])
        if (
            exclude == "auto"
            and idx.size > n_cand + 2
            and tau[j0] < _EXCLUDE_REACH * tau_min_dev
            and below_noise_terms(prob, state.coef, j0) > _ROLLOFF_Z
        ):
            # the shortest point lies below the model's noise terms (a roll-off, not a
            # bump of something the model lacks): is it one the model cannot follow? The
            # fit bends to it, so its neighbours are judged too: the next two, or, when
            # the model does not describe the curve, every tau up to _EXCLUDE_OCTAVES above
            near = np.arange(idx.size) < _EXCLUDE_LOOK
            dof = idx.size - state.n_params
            if dof > 0 and chi2_sf(dof, state.gof) < ADEQUATE_P:
                near |= tau[idx] <= tau[j0] * 2.0**_EXCLUDE_OCTAVES
            short = idx[near & (tau[idx] < _EXCLUDE_REACH * tau_min_dev)]
            worst = float(np.max(np.abs(state.resid[short])))
            # ... or, short of 3 sigma, one the model leans to while the taus above it sit
            # off the other way (behind a filter: -2.7 sigma there, +1.6 to +2.2 above, N
            # 1-2 % low): kept out if the rest is then better described by _BEND_CHI2
            rest = idx[1:]
            cov_rest = prob.cov(state.coef, rest)
            d = np.sqrt(np.diag(cov_rest))
            bend = decorrelated_chi2(state.resid[rest], cov_rest / np.outer(d, d))
            if worst > EXCLUDE_Z or state.resid[j0] < 0.0:
                last = (
                    j0,
                    reasons[j0],
                    (idx, cols, dropped, state),
                    state.gof,
                    idx.size - state.n_params,
                    None if worst > EXCLUDE_Z else bend,
                )
                used[j0] = False
                reasons[j0] = (
                    f"short-tau roll-off: the model misses the short taus by up to "
                    f"{worst:.1f} sigma (a sensor filter or correlated noise the model "
                    "cannot describe)"
                    if worst > EXCLUDE_Z else
                    "short-tau roll-off: the model leans to this tau and misses the taus "
                    "above it (a sensor filter or correlated noise the model cannot "
                    "describe)"
                )  # fmt: skip
                continue
        break
    # then a Gauss-Markov term, on that tau range; where the fit may not take one, its
    # model is still compared with the best that has one (an unmodelled hump)
    better = None
    how = select if select in ("aic", "bic") else "aic"
    # next to a filter's roll-off a hump is not told from the deficit the roll-off term
    # leaves (an independent audit: a 10 Hz Butterworth at 100 Hz gave a 0.067 s process in
    # 3 of 40 records, and N 12 % low, the fit adequate): its time is then kept
    # _ROLLOFF_MARKOV_OCTAVES above the shortest tau fitted
    floor = float(tau[idx[0]]) * 2.0**_ROLLOFF_MARKOV_OCTAVES if forced else 0.0
    with_markov, dropped_m, rivals = choose(prob, idx, all_cols, n_iter, signed, how,
                                             significance, True, forced, floor)  # fmt: skip
    if prob.markov_tau is not None:
        trial = evaluate(idx, with_markov)
        dof = idx.size - trial.n_params
        # a hump that still leaves the curve far from described is not named a
        # Gauss-Markov process (a vibration's bump is sharper, a roll-off deeper: their
        # adequacy chi-squares stay in the thousands; a real hump's falls to tens, a few
        # long-tau estimates of one or two degrees of freedom way off included)
        if dof > 0 and chi2_sf(dof, trial.gof) >= _MARKOV_GATE_P:
            if markov == "auto" and select in ("aic", "bic"):
                cols, dropped, state = with_markov, dropped_m, trial
            else:
                better = f"a Gauss-Markov process of correlation time {prob.markov_tau:.3g} s"
                prob.set_markov(None)
        else:
            prob.set_markov(None)
    coef, chi2, factor, fisher, resid = (state.coef, state.chi2, state.factor, state.fisher,
                                         state.resid)  # fmt: skip
    sig = np.sqrt(np.maximum(np.diag(fisher), 0.0))
    n_params, gof = state.n_params, state.gof

    # the bounds of the terms left out, and the Gauss-Markov term's spread, under the
    # final model's covariance
    w = whitened(prob, idx, coef)
    col_list = [int(c) for c in cols]
    markov_fit = None
    if prob.markov_tau is not None:
        markov_fit = MarkovFit(
            variance=float(coef[MARKOV]),
            variance_uncertainty=float(sig[col_list.index(MARKOV)]),
            tau_c=float(prob.markov_tau),
            tau_c_range=markov_range(w, prob, idx, [c for c in col_list if c != MARKOV],
                                      signed, float(prob.markov_tau)),
        )  # fmt: skip
    unc = np.full(5, np.nan)
    upper = np.full(5, np.nan)
    covariance = np.full((5, 5), np.nan)
    ieee = [j for j, c in enumerate(col_list) if c < 5]
    covariance[np.ix_(cols[ieee], cols[ieee])] = fisher[np.ix_(ieee, ieee)]
    unc[cols[ieee]] = sig[ieee]
    support = None
    if select in ("aic", "bic"):
        # the rivals of the model kept: with a Gauss-Markov term every model judged, else
        # the IEEE ones (a hump the gate turned down is no rival)
        support = term_support(
            [r for r in rivals if prob.markov_tau is not None or r.markov_tau is None]
        )
        if uncertainty == "averaged":
            for k in cols[ieee]:
                unc[k] = selection_sigma(coef[k], unc[k], support[k], AVAR_FACTORS[k])
    for k in terms:
        if k in col_list and coef[k] > 0:
            continue
        rest = [c for c in col_list if c != k]
        sigma_k = wald_sigma(np.column_stack([w.aw[:, rest], w.aw[:, k]])) * math.sqrt(factor)
        z1, z2 = BOUND_Z * math.sqrt(factor), bound_z * math.sqrt(factor)
        base = coef.copy()
        base[k] = 0.0
        unc[k], upper[k] = profile_bound(prob, idx, rest, k, base, signed, (z1, z2), sigma_k)
    return GlsOutcome(
        coefficients=coef[:5].copy(),
        coefficient_uncertainty=unc,
        coefficient_covariance=covariance,
        chi2=chi2,
        dof=max(idx.size - n_params, 0),
        n_points=int(idx.size),
        used=used,
        reasons=tuple(reasons),
        residuals=resid,
        dropped=tuple(sorted(dropped)),
        upper=upper,
        gof_chi2=gof,
        markov=markov_fit,
        correlation=_correlation(fisher, cols),
        better=better,
        support=support,
    )


@dataclass(frozen=True)
class _State:
    """One fitted model on one tau range."""

    coef: np.ndarray
    chi2: float
    n_params: int
    factor: float
    fisher: np.ndarray
    resid: np.ndarray
    gof: float


def _rolloff_forced(signed: bool, reasons: list[str], usable: np.ndarray) -> tuple[int, ...]:
    """``(0,)`` (the signed ``tau^-2`` term stays in every model compared) when the short
    taus show a filter: some were left out for a roll-off or below ``2 / bandwidth``.
    Its deficit then decays over the next octaves, and a selection that drops the term in
    a third of such records (its evidence is a few percent of the variance there) biases
    N by up to 2 % and doubles N's scatter beyond its uncertainty."""
    if not signed:
        return ()
    hints = ("short-tau roll-off", "below ")
    return (0,) if any(r.startswith(hints) for r in reasons) else ()


def _descent_minimum(tau: np.ndarray, dev: np.ndarray) -> float:
    """The tau of the curve's minimum that ends the white noise's descent (NaN: unusable).

    The global minimum, unless the curve first rises: behind a sensor's low-pass filter the
    shortest taus lie below the white-noise line and the deviation climbs to a peak near
    the filter's time before it falls; with a strong rate random walk the minimum after
    that fall can lie above the shortest tau's deviation (an independent audit: a 10 Hz
    Butterworth at 100 Hz, K crossing N at 1 s, in 7 of 20 records), and the exclusion of
    the roll-off, bounded by this minimum, would never start. A rise counts when the
    curve's first peak lies within :data:`_RISE_OCTAVES` of its shortest tau and the
    deviation then falls below :data:`_RISE_FALL` of the peak.
    """
    ok = np.flatnonzero(np.isfinite(dev))
    d = dev[ok]
    peak = 0
    while peak + 1 < d.size and d[peak + 1] >= d[peak]:
        peak += 1
    after = peak + int(np.argmin(d[peak:]))
    rises = (
        peak > 0
        and tau[ok[peak]] <= tau[ok[0]] * 2.0**_RISE_OCTAVES
        and d[after] < _RISE_FALL * d[peak]
    )
    return float(tau[ok[after]] if rises else tau[ok[int(np.argmin(d))]])


def _improves(
    state: _State, n_points: int, gof_before: float, dof_before: int, bend: float | None = None
) -> bool:
    """Whether a fit after an exclusion describes its points better than before it: its
    adequacy p-value is fair, or its adequacy chi-square per degree of freedom fell by a
    tenth. ``bend`` (the chi-square of the same points under the fit before, for a point
    left out without a 3-sigma miss): the chi-square must have fallen by ``_BEND_CHI2``."""
    if bend is not None:
        return bend - state.gof > _BEND_CHI2
    dof = n_points - state.n_params
    if dof <= 0 or dof_before <= 0:
        return True
    if chi2_sf(dof, state.gof) >= _FAIR_P:
        return True
    return state.gof / dof < 0.9 * gof_before / dof_before


def _correlation(fisher: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Correlation matrix (5 x 5, NaN off the model) of the IEEE coefficients."""
    out = np.full((5, 5), np.nan)
    ieee = [k for k, c in enumerate(cols) if c < 5]
    sub = fisher[np.ix_(ieee, ieee)]
    d = np.sqrt(np.maximum(np.diag(sub), 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        out[np.ix_(cols[ieee], cols[ieee])] = sub / np.outer(d, d)
    return out

"""Model selection of the full-covariance noise fit (:mod:`adavar.fit.gls_fit`): every subset of
the candidate terms judged by its likelihood, a Gauss-Markov term screened on a grid of
correlation times, and the profile-likelihood bounds of the terms left out."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from adavar.core.terms import markov_avar
from adavar.fit.gls_core import (
    MARKOV,
    Problem,
    Whitened,
    fit_terms,
    inverse_fisher,
    neg2_log_likelihood,
    signed_nnls,
    solve,
    whitened,
)

__all__ = [
    "MARKOV_MARGIN",
    "MARKOV_PARAMS",
    "RAMP_PARAMS",
    "Choice",
    "choose",
    "markov_grid",
    "markov_range",
    "own_fit",
    "profile_bound",
    "selection_sigma",
    "subset_choice",
    "term_support",
]

MARKOV_PARAMS = 2  # sigma^2 and the correlation time
_RAMP = 4  # index of the rate ramp
#: Parameters a rate ramp counts for in the selection. A deterministic ramp gives the
#: estimates almost no variance, so over a short record it fits the last octaves of a
#: rate random walk more tightly than the random walk itself: it must earn one parameter
#: more than it has.
RAMP_PARAMS = 2
#: How much better (in ``-2 ln L`` with the penalties) a model with a Gauss-Markov term
#: must be than the best without: a flicker-to-random-walk corner mimics a weak hump
#: (the simulated MEMS gyro of tests/test_fit_real.py gains 4.0), a real one gains
#: 15-65 on 3-hour records (benchmarks/bench_validation.py).
MARKOV_MARGIN = 10.0
_MARKOV_CANDIDATES = 4  # term sets judged with a Gauss-Markov term under their own covariance
_MARKOV_REACH = 3.0  # octaves either side of the screened correlation time the likelihood scans


def markov_grid(tau: np.ndarray, step: float = 0.25, floor: float = 0.0) -> np.ndarray:
    """Correlation times whose hump lies inside the fitted taus (it peaks near 1.9 T), and
    not below ``floor``."""
    lo = math.log2(max(tau.min(), floor))
    hi = math.log2(tau.max() / 4.0)
    if hi < lo:
        return np.empty(0)
    return 2.0 ** np.arange(lo, hi + 1e-9, step)


@dataclass(frozen=True)
class Choice:
    cols: tuple[int, ...]  # IEEE terms (indices 0..4) with a non-zero coefficient
    markov_tau: float | None
    criterion: float
    coef: np.ndarray
    #: every model judged by the criterion on the same taus, this one included
    rivals: tuple[Choice, ...] = ()


def own_fit(prob: Problem, idx: np.ndarray, cols, coef: np.ndarray, signed: bool,
             markov: bool, passes: int = 2) -> np.ndarray:  # fmt: skip
    """``coef`` refitted on the columns ``cols`` (and the Gauss-Markov column) under the
    covariance of its own model, ``passes`` times."""
    for _ in range(passes):
        model = prob.phi[idx] @ coef
        if not np.all(model > 0):
            break
        w = whitened(prob, idx, coef)
        x, _ = solve(w, cols, signed, w.aw[:, MARKOV] if markov else None)
        new = np.zeros(6)
        new[list(cols)] = x[: len(cols)]
        if markov:
            new[MARKOV] = x[-1]
        if not np.any(new[1:4] > 0) and new[MARKOV] <= 0:
            break
        coef = new
    return coef


def subset_choice(
    prob: Problem, idx: np.ndarray, coef_full: np.ndarray, terms: tuple[int, ...],
    signed: bool, penalty: float, markov: bool, forced: tuple[int, ...] = (),
    markov_floor: float = 0.0,
) -> Choice:  # fmt: skip
    """The subset of ``terms`` holding ``forced`` (with or without a Gauss-Markov term of
    correlation time at least ``markov_floor``) of the least ``-2 ln L + penalty *
    parameters``, each model judged under its own covariance."""
    prob.set_markov(None)
    w_full = whitened(prob, idx, coef_full)

    def judge(cols: tuple[int, ...], coef: np.ndarray, tau_c: float | None) -> Choice:
        used = tuple(c for c in cols if coef[c] != 0)
        has_markov = tau_c is not None and coef[MARKOV] > 0
        k = len(used) + (MARKOV_PARAMS if has_markov else 0)
        k += (RAMP_PARAMS - 1) * (_RAMP in used)
        crit = neg2_log_likelihood(prob, idx, coef) + penalty * k
        return Choice(used, tau_c if has_markov else None, crit, coef)

    def better(a: Choice, b: Choice | None) -> bool:
        if b is None or a.criterion < b.criterion - 1e-9:
            return True
        return abs(a.criterion - b.criterion) <= 1e-9 and len(a.cols) < len(b.cols)

    best: Choice | None = None
    judged: list[Choice] = []
    subsets = [
        c for r in range(1, len(terms) + 1) for c in itertools.combinations(terms, r)
        if set(forced) <= set(c)
    ]  # fmt: skip
    for cols in subsets:
        x, _ = solve(w_full, cols, signed)
        coef = np.zeros(6)
        coef[list(cols)] = x
        if not np.any(coef[1:4] > 0):
            continue  # no random term: no covariance, no likelihood
        coef = own_fit(prob, idx, cols, coef, signed, False)
        choice = judge(cols, coef, None)
        judged.append(choice)
        if better(choice, best):
            best = choice
    if best is None:  # only a ramp or a signed tau^-2 term: the richest model
        return Choice(tuple(int(c) for c in terms if coef_full[c] != 0), None, math.inf,
                       coef_full)  # fmt: skip
    best = replace(best, rivals=tuple(judged))
    if not markov:
        return best
    ieee_best = best
    # a Gauss-Markov term. A cheap screen (every term set on a half-octave grid of
    # correlation times, whitened by the IEEE model's correlation on the data's own scale:
    # on the model's own, a model that overshoots the long taus makes their variance so
    # large that nothing there could look better) tells whether a hump may be there and
    # which term sets go with it; the correlation time is then chosen by the likelihood
    # itself, each on its own covariance (one basis per time): the screen's approximate
    # weights pull it towards too short a time when the IEEE model overshoots.
    tau = prob.tau[idx]
    # the hump replaces some of the best IEEE model's terms, rarely adds others
    within = [
        c for r in range(len(ieee_best.cols) + 1)
        for c in itertools.combinations(ieee_best.cols, r)
    ]  # fmt: skip
    w_ieee = whitened(prob, idx, ieee_best.coef, data=True)
    _, chi2_ieee = solve(w_ieee, ieee_best.cols, signed)
    bar = chi2_ieee + penalty * len(ieee_best.cols)
    ranked: dict[tuple, float] = {}  # term set -> its best screened criterion
    screened = math.inf, math.nan  # the best screened criterion and its time
    for t in markov_grid(tau, step=0.5, floor=markov_floor):
        col = w_ieee.column(markov_avar(tau, 1.0, float(t)))
        for cols in within:
            x, chi2 = solve(w_ieee, cols, signed, col)
            if x[-1] > 0:
                crit = chi2 + penalty * (sum(1 for v in x[:-1] if v != 0) + MARKOV_PARAMS)
                if crit < bar and crit < ranked.get(cols, math.inf):
                    ranked[cols] = crit
                screened = min(screened, (crit, float(t)))
    if not ranked:
        return best
    sets = sorted(ranked, key=ranked.__getitem__)[:_MARKOV_CANDIDATES]

    tried: dict[float, list[Choice]] = {}  # correlation time -> the models judged with it

    def with_markov(cols: tuple[int, ...], tc: float, w: Whitened) -> Choice | None:
        """The term set ``cols`` and a Gauss-Markov term of correlation time ``tc``, judged
        under its own covariance (None: no positive Gauss-Markov variance)."""
        x, _ = solve(w, cols, signed, w.aw[:, MARKOV])
        coef = np.zeros(6)
        coef[list(cols)] = x[: len(cols)]
        coef[MARKOV] = x[-1]
        if coef[MARKOV] <= 0:
            return None
        choice = judge(cols, own_fit(prob, idx, cols, coef, signed, True), tc)
        return choice if choice.markov_tau is not None else None

    def trial(tc: float) -> Choice | None:
        """The best of the term sets with a Gauss-Markov term of correlation time tc."""
        prob.set_markov(tc)
        w = whitened(prob, idx, ieee_best.coef)
        found = None
        tried[tc] = []
        for cols in sets:
            choice = with_markov(cols, tc, w)
            if choice is not None:
                tried[tc].append(choice)
                if better(choice, found):
                    found = choice
        return found

    def without_each(top: Choice, tc: float) -> list[Choice]:
        """Rivals of ``top`` without each of its terms that every set tried holds: the
        support of a term needs a model without it (:func:`term_support`)."""
        prob.set_markov(tc)
        w = whitened(prob, idx, ieee_best.coef)
        out = []
        for k in top.cols:
            if any(k not in r.cols for r in tried[tc]):
                continue
            choice = with_markov(tuple(c for c in top.cols if c != k), tc, w)
            if choice is not None:
                out.append(choice)
        return out

    # the likelihood's times: an octave apart, up to _MARKOV_REACH octaves either side of
    # the screen's (which an overshooting IEEE model pulls short by two or three)
    grid = markov_grid(tau, step=1.0, floor=markov_floor)
    near = np.abs(np.log2(grid / screened[1])) <= _MARKOV_REACH
    scan = [(trial(float(t)), float(t)) for t in (grid[near] if near.any() else grid)]
    scan = [(c, t) for c, t in scan if c is not None]
    if not scan:
        return best
    top, t_top = min(scan, key=lambda ct: ct[0].criterion)
    for step in (0.5, 0.25, 0.125):  # a finer time around the best
        for tc in (t_top * 2.0**-step, t_top * 2.0**step):
            if tc < markov_floor:
                continue
            choice = trial(tc)
            if choice is not None and choice.criterion < top.criterion:
                top, t_top = choice, tc
    if top.criterion < ieee_best.criterion - MARKOV_MARGIN and better(top, best):
        # the rivals: the IEEE models and the term sets tried with the chosen time
        best = replace(top, rivals=(*judged, *tried[t_top], *without_each(top, t_top)))
    prob.set_markov(best.markov_tau)
    return best


def markov_range(w: Whitened, prob: Problem, idx, cols, signed, tau_c) -> tuple:
    """The correlation times whose best fit costs at most 1 more in chi-square."""
    tau = prob.tau[idx]

    def chi2_at(t: float) -> float:
        x, c2 = solve(w, cols, signed, w.column(markov_avar(tau, 1.0, t)))
        return c2 if x[-1] > 0 else math.inf

    ref = chi2_at(tau_c)
    grid = 2.0 ** np.arange(math.log2(tau.min()), math.log2(tau.max()) + 1e-9, 0.0625)
    ok = [float(t) for t in grid if chi2_at(float(t)) <= ref + 1.0] + [tau_c]
    return (min(ok), max(ok))


#: the profile bounds are found to this fraction of themselves
BOUND_RTOL = 1e-4


def crossing(f: Callable[[float], float], lo: float, hi: float, rtol: float) -> float:
    """The bisection of a bracket ``f(lo) <= 0 < f(hi)`` of an increasing ``f``'s crossing
    to ``rtol`` of its upper end, which it returns: the rule before 0.3.0, to the last bit,
    in about half the evaluations of ``f``.

    False position with the Illinois modification (the end that stays twice running has its
    value halved: superlinear on a smooth ``f``) first narrows the bracket to an eighth of
    the bisection's last width; the bisection then asks ``f`` only at the midpoints inside
    it (outside, the sign is known). The bisection's answer is a point of its own grid, so
    a perturbation of ``f`` in its last bits (a record read in memory or from a file) moves
    it only where a midpoint lies within that perturbation of the crossing.
    ``tests/test_gls_memo.py`` holds the plain bisection as the reference."""
    a, b = lo, hi  # a proven bracket, narrowed
    f_a, f_b = f(a), f(b)
    stale = 0  # +1: b moved last, -1: a moved last
    for _ in range(60):
        if b - a <= 0.125 * rtol * b:
            break
        x = (a * f_b - b * f_a) / (f_b - f_a) if f_b > f_a else 0.5 * (a + b)
        if not a < x < b:
            x = 0.5 * (a + b)
        f_x = f(x)
        if f_x > 0.0:
            b, f_b = x, f_x
            if stale == 1:
                f_a *= 0.5
            stale = 1
        else:
            a, f_a = x, f_x
            if stale == -1:
                f_b *= 0.5
            stale = -1
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if mid <= a:
            above = False
        elif mid >= b:
            above = True
        else:
            above = f(mid) > 0.0
            a, b = (a, mid) if above else (mid, b)
        if above:
            hi = mid
        else:
            lo = mid
        if hi - lo <= rtol * hi:
            break
    return hi


def profile_bound(prob: Problem, idx: np.ndarray, cols: list[int], k: int,
                   coef: np.ndarray, signed: bool, zs: Sequence[float],
                   sigma: float) -> list[float]:  # fmt: skip
    """The one-sided upper bounds of the coefficient ``C_k`` of a term left out, one for each
    ``z`` of ``zs``, from one profile (its values shared): each the largest
    ``c >= 0`` whose profile likelihood (``C_k = c`` fixed, the model's other columns
    ``cols`` refitted under their own covariance) is within ``z^2`` of the best over
    ``c >= 0``. The covariance grows with ``c``, so the bound is the likelihood's, not a
    chi-square under the covariance of the model without the term.

    Each bound is the profile's :func:`crossing`, to ``BOUND_RTOL`` of itself: the bisection of
    the versions before 0.3.0, bit for bit, in about half the refits."""
    column = prob.phi[idx, k]
    markov = MARKOV in cols
    ieee = [c for c in cols if c != MARKOV]
    cache: dict[float, float] = {}

    def profile(c: float) -> float:
        if c in cache:
            return cache[c]
        trial = coef.copy()
        trial[k] = c
        for _ in range(2):
            model = prob.phi[idx] @ trial
            if not np.all(model > 0):
                break
            w = whitened(prob, idx, trial)
            target = w.bw - c * w.column(column)
            design = w.aw[:, ieee + ([MARKOV] if markov else [])]
            free = np.array([signed and j == 0 for j in ieee] + [False] * markov, dtype=bool)
            x, _ = signed_nnls(design, target, free)
            new = np.zeros(6)
            new[ieee + ([MARKOV] if markov else [])] = x
            new[k] = c
            trial = new
        cache[c] = neg2_log_likelihood(prob, idx, trial)
        return cache[c]

    step = sigma if (sigma > 0 and math.isfinite(sigma)) else 1.0
    # the best c >= 0 (the term may be left out yet not at 0 in its own optimum)
    grid = [0.0] + [step * f for f in (0.25, 0.5, 1.0, 2.0)]
    values = [profile(c) for c in grid]
    best = min(values)
    c_best = grid[int(np.argmin(values))]

    def bound(z: float) -> float:
        target = best + z * z
        lo, hi = c_best, c_best + step
        for _ in range(200):
            if profile(hi) > target:
                break
            lo, hi = hi, hi + 2.0 * (hi - c_best)
        else:
            return math.inf

        def excess(c: float) -> float:
            v = profile(c) - target
            return v if v == v else -1.0  # not a number: within, as the bracket's lo

        return crossing(excess, lo, hi, rtol=BOUND_RTOL)

    return [bound(float(z)) for z in zs]


def choose(prob, idx, all_cols, n_iter, signed, select, significance, markov, forced=(),
           markov_floor=0.0):  # fmt: skip
    """The columns of the final model (IEEE indices, then 5 for a Gauss-Markov term, whose
    correlation time is left set in ``prob``, at least ``markov_floor``), the candidate
    terms dropped and the models the criterion judged (:attr:`Choice.rivals`, empty for
    ``select`` "none" and "significance"); ``forced`` terms stay in every model compared."""
    prob.set_markov(None)
    if select in ("none", "significance"):
        cols = all_cols.copy()
        dropped: list[int] = []
        while select == "significance" and cols.size > 1:
            coef, chi2, aw, _ = fit_terms(prob, idx, cols, n_iter, signed)
            dof = idx.size - cols.size
            factor = max(1.0, chi2 / dof) if dof > 0 else 1.0
            sig = np.sqrt(np.maximum(np.diag(inverse_fisher(aw) * factor), 0.0))
            z = np.where(sig > 0, np.abs(coef[cols]) / np.where(sig > 0, sig, 1.0), 0.0)
            worst = int(np.argmin(z))
            if z[worst] >= significance:
                break
            dropped.append(int(cols[worst]))
            cols = np.delete(cols, worst)
        return cols, dropped, ()
    penalty = 2.0 if select == "aic" else math.log(max(idx.size, 2))
    coef, *_ = fit_terms(prob, idx, all_cols, n_iter, signed)
    terms = tuple(int(c) for c in all_cols)
    forced = tuple(c for c in forced if c in terms)
    choice = subset_choice(prob, idx, coef, terms, signed, penalty, markov, forced,
                           markov_floor)  # fmt: skip
    cols = np.array(choice.cols + ((MARKOV,) if choice.markov_tau else ()), dtype=np.int64)
    return cols, [int(c) for c in all_cols if c not in choice.cols], choice.rivals


def term_support(rivals: Sequence[Choice]) -> np.ndarray:
    """The weight of the models that hold each term (Q..R), among the models the criterion
    judged: each model weighs ``exp(-delta / 2)``, ``delta`` its criterion above the best
    (Akaike weights for "aic", Schwarz weights for "bic"), the weights summing to 1.

    Burnham and Anderson's relative importance of a variable (Model Selection and
    Multimodel Inference, 2nd ed., 2002, section 4.2.7): 1 for a term every model of any
    weight needs, near 0 for one none does; NaN for every term where fewer than two models
    were judged.
    """
    support = np.full(5, np.nan)
    if len(rivals) < 2:
        return support
    best = min(r.criterion for r in rivals)
    weights = [math.exp(-0.5 * (r.criterion - best)) for r in rivals]
    total = math.fsum(weights)  # exactly rounded: a term every model holds has exactly 1
    for k in range(5):
        support[k] = math.fsum(w for w, r in zip(weights, rivals, strict=True)
                               if r.coef[k] > 0) / total  # fmt: skip
    return support


def selection_sigma(coefficient: float, sigma: float, support: float, factor: float) -> float:
    """The 1-sigma of ``C = factor * v^2`` with the doubt of the choice in it: ``v``'s own
    spread ``sigma_v`` and, with weight ``1 - support``, the models without the term
    (``v = 0``): ``sqrt(sigma_v^2 + (1 - support) v^2)``, carried back to ``C`` by the
    first-order rule of :class:`~adavar.core.results.NoiseTerm` (``sigma_C = 2 sqrt(factor
    C) sigma_v``)."""
    if not (coefficient > 0 and support == support):
        return sigma
    slope = 2.0 * math.sqrt(factor * coefficient)  # dC/dv
    value = math.sqrt(coefficient / factor)
    return math.hypot(sigma / slope, math.sqrt(max(1.0 - support, 0.0)) * value) * slope

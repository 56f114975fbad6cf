r"""Several instruments measured against each other: the N-cornered hat and the Groslambert
covariance.

The deviation of a record of the difference of two clocks (or two gyros on one table)
holds both instruments' noise: ``sigma^2_AB = sigma^2_A + sigma^2_B`` when they are
independent. With three instruments the three pairwise variances give each one's
(the three-cornered hat, ``sigma^2_A = (sigma^2_AB + sigma^2_CA - sigma^2_BC) / 2``, as
allantools' ``three_cornered_hat_phase``); with N > 3 the N(N-1)/2 pairs over-determine
the N variances and :func:`cornered_hat` solves them by generalised least squares (the
N-cornered hat). :func:`gcodev` is the Groslambert codeviation of two difference records
sharing an instrument (Vernotte et al. 2016, Lantz et al. 2019): their cross Allan
covariance, whose sign is kept (it estimates ``-sigma^2`` of the shared instrument when it
enters the two records with opposite signs).

Negative variances
------------------
An instrument much quieter than the others can get a negative variance estimate at some
taus (the difference of noisy estimates). It is reported as it is: ``var`` keeps the
estimate, ``dev`` is NaN there, ``negative`` flags it and a note says how many, and the
interval still bounds the variance from above (``dev_low = 0``). Nothing is clipped.

Intervals
---------
Every estimate here is a linear combination of the pairwise variance estimates, so for
Gaussian noise it is a quadratic form in the instruments' noises: ``(1/nu) sum_k u_k^T M
u_k`` over ``nu`` effective independent samples ``u_k ~ N(0, diag(sigma^2))``, i.e. a
weighted sum of independent chi-square variables ``(1/nu) sum_j lambda_j chi2_nu`` with
``lambda`` the eigenvalues of ``diag(sigma) M diag(sigma)``, some of them negative. ``nu``
comes from the EDF of the pairwise records (their geometric mean for each pair of pairs,
weighted as the variance of the combination). Its quantiles are Pearson's three-moment
chi-square approximation, which is the exact chi-square interval when a single instrument
dominates. The interval of ``sigma_i^2`` is found by inverting that test: the other
instruments' variances are held at their estimates (at 0 where negative) and ``[v_low,
v_high]`` are the values of ``sigma_i^2`` whose distribution has the estimate at its
upper and lower quantiles. When the estimate lies below the median of the distribution
at ``sigma_i^2 = 0`` (a negative or very small estimate), the upper bound is the one of an
estimate at that median: a conservative upper limit, never the empty interval that a
strongly negative estimate would otherwise give. The coverage is measured in
``tests/test_cornered_hat.py`` and ``benchmarks/bench_cornered_hat.py``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.special import gammaincinv, ndtri

from adavar.core.errors import AdavarInputError
from adavar.core.inputs import as_samples, check_confidence
from adavar.core.results import DeviationResult
from adavar.stats.statistics import deviation

__all__ = ["CodeviationResult", "CorneredHatResult", "cornered_hat", "gcodev"]

KINDS = ("differences", "instruments")
_BISECT = 60  # bisection steps of the bounds: 1e-30 .. 1e30 (log scale) to 1e-15 relative
_GLS_PASSES = 3


# --------------------------------------------------------------------------------------
# The distribution of a linear combination of variance estimates
# --------------------------------------------------------------------------------------


def _quantile(lam: np.ndarray, nu: np.ndarray, q: float) -> np.ndarray:
    """Quantile ``q`` of ``(1/nu) sum_j lam_j chi2_nu`` (Pearson's 3-moment chi-square).

    ``lam`` has shape (K, N) (eigenvalues), ``nu`` (K,).
    """
    k1 = lam.sum(axis=1)
    k2 = 2.0 * (lam**2).sum(axis=1) / nu
    k3 = 8.0 * (lam**3).sum(axis=1) / nu**2
    sd = np.sqrt(k2)
    z = ndtri(q)
    with np.errstate(divide="ignore", invalid="ignore"):
        shape = 8.0 * k2**3 / k3**2
    normal = ~(np.abs(k3) > 0) | ~(shape < 1e8) | ~(sd > 0)
    h = np.where(normal, 1.0, shape)
    pos = k3 > 0
    # a negatively skewed sum is minus a positively skewed one: mirror the quantile
    qq = np.where(pos, q, 1.0 - q)
    x = (_chi2_ppf_vec(qq, h) - h) / np.sqrt(2.0 * h)
    pearson = k1 + sd * np.where(pos, x, -x)
    return np.where(normal, k1 + sd * z, pearson)


def _chi2_ppf_vec(q: np.ndarray, k: np.ndarray) -> np.ndarray:
    return 2.0 * gammaincinv(0.5 * k, q)


class _Combination:
    """Estimates ``W @ s_hat`` of the pairwise variances ``s_hat``, one row per estimate.

    ``incidence`` (P, N) is the signed incidence of the pairs (``+1`` first, ``-1`` second
    instrument); ``weights`` (K, P) the combinations; ``nu`` (K, P) the pairs' EDF at the
    tau of each row.
    """

    def __init__(self, incidence: np.ndarray, weights: np.ndarray, nu: np.ndarray):
        self.b = incidence
        self.w = weights
        self.inv_nu = 1.0 / np.sqrt(nu[:, :, None] * nu[:, None, :])
        # the quadratic form of each combination in the instruments' noises
        self.forms = np.einsum("kp,pi,pj->kij", weights, incidence, incidence)

    def spectrum(self, variances: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Eigenvalues (K, N) and effective EDF (K,) for instrument variances (K, N)."""
        sd = np.sqrt(np.maximum(variances, 0.0))
        lam = np.linalg.eigvalsh(sd[:, :, None] * self.forms * sd[:, None, :])
        c = np.einsum("pi,ki,qi->kpq", self.b, variances, self.b)  # pair covariances
        ww = self.w[:, :, None] * self.w[:, None, :] * c**2
        num = ww.sum(axis=(1, 2))
        den = (ww * self.inv_nu).sum(axis=(1, 2))
        with np.errstate(divide="ignore", invalid="ignore"):
            # no variance at all (every instrument at 0): a point mass, any nu
            nu = np.where((den > 0) & (num > 0), num / den, np.inf)
        return lam, nu


def _invert(comb: _Combination, est: np.ndarray, base: np.ndarray, target: np.ndarray,
            confidence: float) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Test-inversion interval of the variance ``target`` of each combination.

    ``est`` (K,): the estimates; ``base`` (K, N): the instruments' variances held fixed;
    ``target`` (K,): which instrument's variance is varied.
    """
    k = est.size
    rows = np.arange(k)
    q_hi, q_lo = 0.5 * (1.0 + confidence), 0.5 * (1.0 - confidence)

    def quant(v: np.ndarray, q: float) -> np.ndarray:
        d = base.copy()
        d[rows, target] = v
        lam, nu = comb.spectrum(d)
        return _quantile(lam, nu, q)

    zero = np.zeros(k)
    med0 = quant(zero, 0.5)
    top_hi = quant(zero, q_hi)
    est_up = np.maximum(est, med0)
    scale = np.maximum(np.abs(est), np.abs(base).max(axis=1))
    scale = np.where(scale > 0, scale, 1.0)

    def solve(value: np.ndarray, q: float) -> np.ndarray:
        # the quantile grows with v: bracket in log v, then bisect
        hi = scale.copy()
        for _ in range(200):
            short = quant(hi, q) < value
            if not short.any():
                break
            hi = np.where(short, hi * 4.0, hi)
        lo = np.full(k, 1e-30) * scale
        for _ in range(_BISECT):
            mid = np.sqrt(lo * hi)
            above = quant(mid, q) >= value
            hi = np.where(above, mid, hi)
            lo = np.where(above, lo, mid)
        return np.sqrt(lo * hi)

    v_low = np.where(top_hi >= est, 0.0, solve(est, q_hi))
    v_high = solve(est_up, q_lo)
    return v_low, v_high


# --------------------------------------------------------------------------------------
# The cornered hat
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class CorneredHatResult:
    """Each instrument's deviation from the pairwise records (:func:`cornered_hat`).

    Attributes
    ----------
    names : tuple of str
        The instruments, in the order of the rows below.
    tau : ndarray, shape (M,)
        Averaging times in seconds.
    m : ndarray of int, shape (M,)
        Averaging factors.
    var : ndarray, shape (N, M)
        Each instrument's variance estimate, as solved: may be negative.
    var_sigma : ndarray, shape (N, M)
        Its standard error (Gaussian noise, the variances at their estimates).
    dev : ndarray, shape (N, M)
        ``sqrt(var)``; NaN where ``var < 0``.
    dev_low, dev_high : ndarray, shape (N, M)
        Bounds of the interval at ``confidence`` (``dev_low`` 0 where the data allow a
        vanishing variance); NaN without a confidence level.
    edf : ndarray, shape (N, M)
        Effective degrees of freedom of the estimate (see the module docstring).
    negative : ndarray of bool, shape (N, M)
        Where the variance estimate is negative.
    pairs : tuple of (str, str)
        The pairs, ``(a, b)`` for a record of ``a - b``.
    pair_results : dict
        ``(a, b)`` -> the :class:`~adavar.core.results.DeviationResult` of that record.
    stat, data_type, tau0, confidence, n_samples, units
        As in :class:`~adavar.core.results.DeviationResult`.
    method : str
        ``"three-cornered hat"`` (3 pairs, exact solution) or ``"least squares"``.
    notes : tuple of str
    """

    names: tuple[str, ...]
    tau: np.ndarray
    m: np.ndarray
    var: np.ndarray
    var_sigma: np.ndarray
    dev: np.ndarray
    dev_low: np.ndarray
    dev_high: np.ndarray
    edf: np.ndarray
    negative: np.ndarray
    pairs: tuple[tuple[str, str], ...]
    pair_results: dict[tuple[str, str], DeviationResult]
    stat: str
    data_type: str
    tau0: float
    confidence: float
    n_samples: int
    method: str
    units: str | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)

    def index(self, name: str) -> int:
        """Row of the instrument ``name``."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"{name!r}; instruments: {', '.join(self.names)}") from None

    def deviation(self, name: str) -> DeviationResult:
        """One instrument's curve as a :class:`~adavar.core.results.DeviationResult`.

        ``edf`` is the effective one of the estimate, ``alpha`` the noise type identified
        on the record of its quietest pair, ``n`` that record's counts; ``dev`` is NaN
        where the variance estimate is negative. A fit of it (:func:`adavar.fit_noise`,
        :func:`adavar.fit_power_law`) reads the EDF, but its covariance across taus is
        that of one record, narrower than the cornered hat's.
        """
        i = self.index(name)
        own = [p for p in self.pairs if name in p]
        quiet = min(own, key=lambda p: np.nansum(self.pair_results[p].dev ** 2))
        ref = self.pair_results[quiet]
        return replace(
            ref,
            dev=self.dev[i].copy(),
            dev_low=self.dev_low[i].copy(),
            dev_high=self.dev_high[i].copy(),
            edf=self.edf[i].copy(),
            notes=(*ref.notes, f"{name}: {self.method} from {len(self.pairs)} pairs"),
        )

    def __getitem__(self, name: str) -> DeviationResult:
        return self.deviation(name)

    def summary(self) -> str:
        """A table of each instrument's deviation and interval per tau (text)."""
        head = (
            f"{self.method} ({self.stat}, {len(self.names)} instruments, {len(self.pairs)} pairs)"
        )
        lines = [head, "  tau [s]      " + "".join(f"{n:>34s}" for n in self.names)]
        for j, t in enumerate(self.tau):
            cells = []
            for i in range(len(self.names)):
                if self.negative[i, j]:
                    cell = f"negative var, < {self.dev_high[i, j]:.3g}"
                else:
                    lo, hi = self.dev_low[i, j], self.dev_high[i, j]
                    cell = f"{self.dev[i, j]:.4g} [{lo:.3g}, {hi:.3g}]"
                cells.append(f"{cell:>34s}")
            lines.append(f"  {t:<12.6g} " + "".join(cells))
        lines.extend(f"  note: {n}" for n in self.notes)
        return "\n".join(lines)

    def __repr__(self) -> str:
        return (
            f"CorneredHatResult(names={self.names}, stat={self.stat!r}, "
            f"taus={self.tau.size}, negative={int(self.negative.sum())}, method={self.method!r})"
        )


def _letters(n: int) -> tuple[str, ...]:
    return tuple(chr(ord("A") + k) if n <= 26 else f"clock{k}" for k in range(n))


def _check_names(names: Any, n: int) -> tuple[str, ...]:
    if names is None:
        return _letters(n)
    if isinstance(names, str):
        raise AdavarInputError("names must be a sequence of instrument names, not one string")
    names = tuple(str(v) for v in names)
    if len(names) != n or len(set(names)) != n:
        raise AdavarInputError(f"names must be {n} distinct names, got {names!r}")
    return names


def _pairs_of(records: Any, kind: str, names: Any):
    """(names, pairs, pair records) from the accepted forms of ``records``."""
    if kind not in KINDS:
        raise AdavarInputError(f"unknown kind {kind!r}: use one of {', '.join(KINDS)}")
    if kind == "instruments":
        if isinstance(records, Mapping):
            keys = tuple(str(k) for k in records)
            data = [records[k] for k in records]
            if names is not None:
                raise AdavarInputError("names come from the keys of the records' mapping")
            names = keys
        else:
            data = list(np.asarray(records)) if isinstance(records, np.ndarray) else list(records)
            names = _check_names(names, len(data))
        if len(data) < 3:
            raise AdavarInputError(f"a cornered hat needs at least 3 instruments, got {len(data)}")
        xs = [as_samples(d) for d in data]
        pairs = [(names[a], names[b]) for a in range(len(xs)) for b in range(a + 1, len(xs))]
        _same_length(xs)
        diffs = [xs[a] - xs[b] for a in range(len(xs)) for b in range(a + 1, len(xs))]
        return tuple(names), pairs, diffs
    if isinstance(records, Mapping):
        pairs, data = [], []
        for key, rec in records.items():
            if not (isinstance(key, tuple) and len(key) == 2 and key[0] != key[1]):
                raise AdavarInputError(
                    f"a key of the records' mapping must be a pair of distinct names (a, b) "
                    f"for the record of a - b, got {key!r}"
                )
            pairs.append((str(key[0]), str(key[1])))
            data.append(rec)
        seen = list(dict.fromkeys(n for p in pairs for n in p))
        if names is None:
            names = tuple(seen)
        else:
            names = tuple(str(v) for v in names)
            if sorted(names) != sorted(seen):
                raise AdavarInputError(
                    f"names {names!r} do not match the instruments of the pairs {tuple(seen)!r}"
                )
        keys = [frozenset(p) for p in pairs]
        if len(set(keys)) != len(keys):
            raise AdavarInputError("a pair of instruments appears twice in the records")
    else:
        data = list(records)
        if len(data) != 3:
            raise AdavarInputError(
                f"a sequence of difference records must be the three of a three-cornered hat "
                f"(AB, BC, CA), got {len(data)}; pass a mapping {{(a, b): record}} for more"
            )
        names = _check_names(names, 3)
        a, b, c = names
        pairs = [(a, b), (b, c), (c, a)]
    if len(names) < 3:
        raise AdavarInputError(f"a cornered hat needs at least 3 instruments, got {len(names)}")
    xs = [as_samples(d) for d in data]
    _same_length(xs)
    return tuple(names), pairs, xs


def _same_length(xs: list[np.ndarray]) -> None:
    sizes = sorted({x.size for x in xs})
    if len(sizes) > 1:
        raise AdavarInputError(
            f"the records must be simultaneous and of one length; got lengths {sizes}"
        )


def _solve(design: np.ndarray, incidence: np.ndarray, s: np.ndarray, nu: np.ndarray,
           exact: bool) -> np.ndarray:  # fmt: skip
    """Weights (N, P) of the instruments' variances from the pairs' (one tau)."""
    if exact:
        return np.linalg.inv(design)
    weights = np.linalg.pinv(design)  # ordinary least squares first
    finite = np.all(np.isfinite(nu)) and np.all(nu > 0)
    if not finite:
        return weights
    inv_nu = 1.0 / np.sqrt(np.outer(nu, nu))
    for _ in range(_GLS_PASSES):
        v = weights @ s
        top = max(float(np.max(v)), float(np.max(s)) * 1e-12, 1e-300)
        v = np.maximum(v, 1e-6 * top)  # a negative or vanishing one keeps the matrix definite
        c = incidence @ np.diag(v) @ incidence.T
        cov = 2.0 * c**2 * inv_nu
        ci = np.linalg.pinv(cov)
        weights = np.linalg.pinv(design.T @ ci @ design) @ design.T @ ci
    return weights


def cornered_hat(
    records: Any,
    *,
    kind: str = "differences",
    names: Sequence[str] | None = None,
    rate: float | None = 1.0,
    tau0: float | None = None,
    stat: str = "oadev",
    taus: Any = "octave",
    data_type: str = "rate",
    confidence: float | None = 0.683,
    points_per_decade: int = 5,
    units: str | None = None,
    noise_id: str = "sp1065",
) -> CorneredHatResult:
    """Each instrument's deviation from records of instruments measured against each other.

    Parameters
    ----------
    records : mapping, sequence or 2-D array
        ``kind="differences"`` (default): the pairwise difference records, either a mapping
        ``{(a, b): record of a - b}`` over at least three instruments (any set of pairs
        that determines every instrument, e.g. all N(N-1)/2 of them), or the sequence of
        the three records ``(AB, BC, CA)`` of a three-cornered hat (allantools'
        ``three_cornered_hat_phase`` order; instruments ``names`` or A, B, C).
        ``kind="instruments"``: the N >= 3 simultaneous records themselves (a mapping
        ``{name: record}``, a sequence or an (N, n) array), each the same signal plus the
        instrument's noise (gyros on one table, receivers of one clock): the pairwise
        differences are formed here, cancelling the common signal.
        Every record has the same length and sampling.
    kind : {"differences", "instruments"}
        How to read ``records``.
    names : sequence of str, optional
        Instrument names (sequence input); a mapping's keys give them otherwise.
    rate, tau0, stat, taus, data_type, confidence, points_per_decade, units, noise_id
        As in :func:`adavar.deviation`, for every pairwise record (any of its Allan-family
        statistics: the variance of a difference of independent instruments is the sum of
        theirs for each of them). ``confidence=None`` gives no intervals.

    Returns
    -------
    CorneredHatResult
        Per instrument and tau: the variance estimate (negative ones kept and flagged),
        the deviation, the interval and the effective EDF; the pairwise results.

    Raises
    ------
    AdavarInputError
        Fewer than three instruments, pairs that do not determine every instrument (a
        chain A-B, B-C, C-D: add a pair closing an odd cycle), records of different
        lengths, a repeated pair, or the errors of :func:`adavar.deviation`.

    Notes
    -----
    The instruments are assumed independent; a correlated pair (a common reference, a
    shared environment) biases the estimates and is a usual cause of negative ones. With
    three pairs the solution is exact (the three-cornered hat); with more, the weights are
    those of generalised least squares under the pairs' covariance ``Cov(s_p, s_q) =
    2 c_pq^2 / sqrt(nu_p nu_q)`` (``c_pq`` the covariance of the two difference records,
    ``nu`` their EDF), evaluated at the estimates (3 passes from ordinary least squares).
    """
    check_confidence(confidence)
    names, pairs, xs = _pairs_of(records, kind, names)
    index = {n: k for k, n in enumerate(names)}
    n_inst, n_pairs = len(names), len(pairs)
    incidence = np.zeros((n_pairs, n_inst))
    for p, (a, b) in enumerate(pairs):
        incidence[p, index[a]], incidence[p, index[b]] = 1.0, -1.0
    design = np.abs(incidence)
    if np.linalg.matrix_rank(design) < n_inst:
        raise AdavarInputError(
            f"the pairs {pairs} do not determine every instrument's variance: a cornered hat "
            "needs the pairs to close an odd cycle (e.g. A-B, B-C, C-A)"
        )
    results = {
        pair: deviation(
            x, stat=stat, rate=rate, tau0=tau0, data_type=data_type, taus=taus,
            confidence=confidence, points_per_decade=points_per_decade, units=units,
            noise_id=noise_id,
        )
        for pair, x in zip(pairs, xs, strict=True)
    }  # fmt: skip
    first = results[pairs[0]]
    tau, m = first.tau, first.m
    s = np.array([results[p].dev for p in pairs]) ** 2  # (P, M)
    nu = np.array([results[p].edf for p in pairs])  # (P, M)
    exact = n_pairs == n_inst
    var = np.empty((n_inst, tau.size))
    sigma = np.full((n_inst, tau.size), np.nan)
    low = np.full((n_inst, tau.size), np.nan)
    high = np.full((n_inst, tau.size), np.nan)
    edf = np.full((n_inst, tau.size), np.nan)
    rows_w, rows_nu, rows_j = [], [], []
    for j in range(tau.size):
        weights = _solve(design, incidence, s[:, j], nu[:, j], exact)
        var[:, j] = weights @ s[:, j]
        if confidence is not None and np.all(np.isfinite(nu[:, j]) & (nu[:, j] > 0)):
            rows_w.append(weights)
            rows_nu.append(np.broadcast_to(nu[:, j], (n_inst, n_pairs)))
            rows_j.append(j)
    if rows_j:
        # every (tau, instrument) estimate at once: row j * N + i
        js = np.array(rows_j)
        comb = _Combination(incidence, np.concatenate(rows_w), np.concatenate(rows_nu))
        est = var[:, js].T.reshape(-1)
        base = np.repeat(np.maximum(var[:, js].T, 0.0), n_inst, axis=0)
        target = np.tile(np.arange(n_inst), js.size)
        lam, nu_eff = comb.spectrum(base)
        shape = (js.size, n_inst)
        sigma[:, js] = np.sqrt(2.0 * (lam**2).sum(axis=1) / nu_eff).reshape(shape).T
        edf[:, js] = nu_eff.reshape(shape).T
        v_low, v_high = _invert(comb, est, base, target, float(confidence))
        low[:, js] = np.sqrt(v_low).reshape(shape).T
        high[:, js] = np.sqrt(v_high).reshape(shape).T
    negative = var < 0
    with np.errstate(invalid="ignore"):
        dev = np.where(negative, np.nan, np.sqrt(np.abs(var)))
    notes = tuple(first.notes)
    if negative.any():
        where = ", ".join(
            f"{names[i]} at {int(negative[i].sum())} tau(s)"
            for i in range(n_inst)
            if negative[i].any()
        )
        notes = (*notes, f"negative variance estimates (dev NaN, var kept): {where}")
    return CorneredHatResult(
        names=names,
        tau=tau,
        m=m,
        var=var,
        var_sigma=sigma,
        dev=dev,
        dev_low=low,
        dev_high=high,
        edf=edf,
        negative=negative,
        pairs=tuple(pairs),
        pair_results=results,
        stat=first.stat,
        data_type=first.data_type,
        tau0=first.tau0,
        confidence=first.confidence,
        n_samples=first.n_samples,
        method="three-cornered hat" if exact and n_inst == 3 else (
            "exact solution" if exact else "least squares"),
        units=units,
        notes=notes,
    )  # fmt: skip


# --------------------------------------------------------------------------------------
# The Groslambert covariance
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class CodeviationResult:
    """The Groslambert covariance of two records (:func:`gcodev`).

    Attributes
    ----------
    tau : ndarray, shape (M,)
        Averaging times in seconds.
    m : ndarray of int
    covar : ndarray
        The cross Allan covariance ``sum z_a z_b / (2 tau^2 (N - 2m))`` (``z`` the phase
        second differences), with its sign.
    codev : ndarray
        The Groslambert codeviation ``sign(covar) sqrt(|covar|)`` (SigmaTheta's GCoDev;
        allantools prints ``|codev|``).
    covar_sigma : ndarray
        Standard error of ``covar`` (Gaussian noise): ``sqrt((var_a var_b + covar^2) / nu)``.
    covar_low, covar_high : ndarray
        Interval of the covariance at ``confidence`` (NaN without one).
    var_a, var_b : ndarray
        The two records' own variances (overlapping Allan).
    edf : ndarray
        ``nu``, the geometric mean of the two records' EDF.
    n : ndarray of int
        Terms in each sum.
    data_type, tau0, confidence, n_samples, units, notes
    """

    tau: np.ndarray
    m: np.ndarray
    covar: np.ndarray
    codev: np.ndarray
    covar_sigma: np.ndarray
    covar_low: np.ndarray
    covar_high: np.ndarray
    var_a: np.ndarray
    var_b: np.ndarray
    edf: np.ndarray
    n: np.ndarray
    data_type: str
    tau0: float
    confidence: float
    n_samples: int
    units: str | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def correlation(self) -> np.ndarray:
        """``covar / sqrt(var_a var_b)``, in [-1, 1]."""
        return self.covar / np.sqrt(self.var_a * self.var_b)

    def __repr__(self) -> str:
        codev = np.array2string(self.codev, precision=4)
        return f"CodeviationResult(taus={self.tau.size}, codev={codev})"


def gcodev(
    a: Any,
    b: Any,
    *,
    rate: float | None = 1.0,
    tau0: float | None = None,
    data_type: str = "phase",
    taus: Any = "octave",
    confidence: float | None = 0.683,
    points_per_decade: int = 5,
    units: str | None = None,
) -> CodeviationResult:
    """The Groslambert codeviation (cross Allan covariance) of two simultaneous records.

    For difference records ``a = A - B`` and ``b = A - C`` sharing instrument ``A``, the
    covariance estimates ``sigma^2_A``; for ``a = C - A`` and ``b = A - B`` (``A`` with
    opposite signs) ``-sigma^2_A``. The noises of ``B`` and ``C`` (and of two separate
    measurement systems) average out instead of being subtracted, so the estimate is
    negative only by chance.

    Parameters
    ----------
    a, b : array_like
        Two records of one length, sampled together.
    rate, tau0, data_type, taus, points_per_decade, units
        As in :func:`adavar.deviation` (``data_type`` defaults to ``"phase"`` like
        allantools' ``gcodev``); the overlapping Allan statistic.
    confidence : float or None
        Level of the covariance interval (test inversion of the product's distribution,
        see the module docstring), None for none.

    Returns
    -------
    CodeviationResult

    Notes
    -----
    ``covar = (avar(a + b) - avar(a - b)) / 4`` (the second difference is linear), each
    computed by :func:`adavar.deviation`, so constant offsets and drifts cost no digits.
    Reproduces SigmaTheta's GCoDev values shipped with allantools 2024.6 to 1e-12.
    """
    check_confidence(confidence)
    xa, xb = as_samples(a), as_samples(b)
    _same_length([xa, xb])
    common = dict(stat="oadev", rate=rate, tau0=tau0, data_type=data_type, taus=taus,
                  points_per_decade=points_per_decade, units=units)  # fmt: skip
    ra = deviation(xa, confidence=confidence, **common)
    rb = deviation(xb, confidence=confidence, **common)
    plus = deviation(xa + xb, confidence=None, **common)
    minus = deviation(xa - xb, confidence=None, **common)
    covar = 0.25 * (plus.dev**2 - minus.dev**2)
    var_a, var_b = ra.dev**2, rb.dev**2
    codev = np.sign(covar) * np.sqrt(np.abs(covar))
    nan = np.full(covar.size, np.nan)
    sigma, low, high, nu = nan, nan.copy(), nan.copy(), nan.copy()
    if confidence is not None:
        nu = np.sqrt(ra.edf * rb.edf)
        sigma = np.sqrt((var_a * var_b + covar**2) / nu)
        low, high = _covariance_interval(covar, var_a, var_b, nu, float(confidence))
    return CodeviationResult(
        tau=ra.tau,
        m=ra.m,
        covar=covar,
        codev=codev,
        covar_sigma=sigma,
        covar_low=low,
        covar_high=high,
        var_a=var_a,
        var_b=var_b,
        edf=nu,
        n=ra.n,
        data_type=ra.data_type,
        tau0=ra.tau0,
        confidence=ra.confidence,
        n_samples=ra.n_samples,
        units=units,
        notes=ra.notes,
    )


def _covariance_interval(covar, var_a, var_b, nu, confidence):
    """Interval of ``c`` from ``c_hat ~ (1/nu)[l+ chi2_nu + l- chi2_nu]``, ``l = (c ± s)/2``."""
    s = np.sqrt(var_a * var_b)
    q_hi, q_lo = 0.5 * (1.0 + confidence), 0.5 * (1.0 - confidence)

    def quant(c: np.ndarray, q: float) -> np.ndarray:
        lam = np.stack([0.5 * (c + s), 0.5 * (c - s)], axis=1)
        return _quantile(lam, nu, q)

    def solve(q: float) -> np.ndarray:
        lo, hi = -s.copy(), s.copy()
        for _ in range(_BISECT):
            mid = 0.5 * (lo + hi)
            above = quant(mid, q) >= covar
            hi = np.where(above, mid, hi)
            lo = np.where(above, lo, mid)
        return 0.5 * (lo + hi)

    # the estimate itself may sit on the bound |c| <= s (a single term at the last tau)
    return np.minimum(solve(q_hi), covar), np.maximum(solve(q_lo), covar)

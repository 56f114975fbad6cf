"""Fit the IEEE Std 952 noise model to Allan-variance curves (docs/method.md section 4, Eq. 7).

The model is

.. math::  \\sigma^2(\\tau) = \\sum_{n=-2}^{2} C_n \\tau^n ,

with ``Q = sqrt(C_-2/3)`` (quantization), ``N = sqrt(C_-1)`` (angle/velocity random walk),
``B = sqrt(C_0/(2 ln2/pi))`` (bias instability), ``K = sqrt(3 C_1)`` (rate random walk) and
``R = sqrt(2 C_2)`` (rate ramp).

Two fits
--------
* **One whole-record curve** (a :class:`~adavar.results.DeviationResult`): by default the
  generalised least-squares fit of :mod:`adavar.gls_fit` (``method="gls"``), with the full
  covariance of the estimates across taus (:mod:`adavar.avar_covariance`), term selection
  by significance, automatic exclusion of a sensor filter's roll-off and a signed
  ``tau^-2`` term above it. Its uncertainties are calibrated (``docs/benchmarks.md``).
* **Stacks of curves** (a DAVAR surface, raw arrays in :func:`fit_avar`), and any curve
  with ``method="wls"``: the diagonally weighted fit described below, the default of
  every fit before issue 11.

How the diagonal fit works
--------------------------
* **Non-negative weighted least squares on the variance.** Each ``C_n >= 0``; the residual
  at each tau is weighted by ``1/var(avar_hat)`` with ``var(avar_hat) ~= 2 avar^2 / edf``
  (chi-square statistics of a variance estimate with ``edf`` degrees of freedom). Only the
  selected ``terms`` are in the model.
* **Iteratively reweighted.** Weighting by the *measured* avar biases the fit low (points
  that happen to fall low get more weight). The first pass uses the measured avar in the
  weights; each of the ``n_reweight`` following passes uses the *model* avar of the
  previous pass. Measured on white + rate-random-walk records (N = 1e-2, K = 1e-4, 4e5
  samples at 1 Hz, octave taus and edf from :func:`adavar.statistics.deviation`, 60
  seeds): with the measured-avar weights only (``n_reweight=0``) K comes out 3.9 % low
  with 9.4 % scatter (two-term model; five terms: N -0.27 %, K -6.2 %, scatter 12 %);
  after reweighting, K is 0.2 % low with 2.5 % scatter (five terms: N -0.14 %, K -1.2 %,
  scatter 3.2 %). The largest change over those seeds made by the 3rd reweighting pass
  is 0.05 (two terms) / 0.15 (five terms) of the coefficient's uncertainty, by the 4th
  0.002 / 0.05; the default ``n_reweight=3`` is converged for practical purposes.
* **Exact NNLS, compiled, over stacks of curves.** For every curve and pass the weighted
  normal equations (time axis scaled by the geometric mean of the taus, Jacobi-equilibrated
  Cholesky) are solved on candidate active sets: the previous pass's optimum, then the
  Lawson-Hanson active set, then, only if rounding defeats both, every one of the
  ``2**k - 1`` non-empty subsets. A candidate is accepted when all its coefficients are
  positive and the KKT conditions hold (no excluded term's gradient points into the
  feasible side): that is the unique NNLS optimum. In the exhaustive fallback the feasible
  subset with the smallest weighted residual is kept, which is the optimum by enumeration.
  The loop over curves is a numba kernel (blocks of curves in parallel for stacks of 1024
  curves or more); a single curve is a stack of one and goes through the same per-curve
  code, so stacks and single fits agree bit for bit. Cost: about 3.5 s for 1e6 curves of
  10 taus with all five terms on one core.
* **Any scale.** The model is linear in the coefficients and the weights scale with the
  variance, so variances far from 1 (beyond ``4**±SAFE_EXPONENT``) are fitted scaled by a
  power of four (exact) and the coefficients scaled back: the fit of ``x * 2**k`` is that
  of ``x`` with every coefficient times ``4**k``, bit for bit. Coefficients beyond the
  float64 range are an :class:`~adavar.errors.AdavarInputError` (rescale the data); a GLS
  coefficient covariance beyond it is ``None``.
* **Points ignored.** A point whose avar or edf is NaN/inf, or not strictly positive, gets
  weight 0 (DAVAR windows are NaN beyond a third of the window). A curve with fewer valid
  points than selected terms is not fitted: all its outputs are NaN.

Uncertainties
-------------
The covariance of the ``C_n`` on the active set is the inverse of the weighted normal
matrix of the final pass (weights ``edf/(2 model^2)`` from the previous pass's model). It
is multiplied by ``max(1, reduced_chi2)`` (``reduced_chi2 = chi2 / dof``,
``dof = n_points - len(terms)``; factor 1 when ``dof == 0``): when the scatter about the
model is larger than the weights predict (a wrong model, edf overestimated), the
covariance is inflated to match it, and it is never shrunk below the statistical
prediction. The weights treat the taus as independent, but the taus of an overlapping
statistic are positively correlated, which makes ``reduced_chi2`` small (about 0.6 on
octave taus) and the covariance optimistic: in the simulation above the scatter over seeds
is 1.4 times the reported uncertainty of N and 1.8 times that of K. Read the
uncertainties as a lower bound of that order (the ``"gls"`` fit of one curve has
calibrated ones).
With ``edf=None`` in :func:`fit_avar` the weights are only relative, so the covariance is
scaled by ``reduced_chi2`` itself (as in ``scipy.optimize.curve_fit`` with
``absolute_sigma=False``) and is NaN when ``dof == 0``.
The 1-sigma uncertainty of a coefficient is propagated through the square root,
``sigma_value = sigma_C * dvalue/dC = sigma_C / (2 sqrt(k C))`` for ``C = k value**2``.
A term pinned at 0 by the constraint has value 0 and, as uncertainty, a 1-sigma *upper
bound*: ``sqrt(sigma_C / k)``, the value that ``C = sigma_C`` would give, with
``sigma_C`` from the unconstrained covariance (all selected terms free), scaled by the
same factor. A term not in ``terms`` has value 0 and uncertainty NaN.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from adavar import gls_fit
from adavar._jit import grouped_items, read_only
from adavar._nnls import BLOCK, PARALLEL_MIN, nnls_blocks, subsets
from adavar.errors import AdavarInputError
from adavar.results import ADEQUATE_P, DavarResult, NoiseFit, NoiseTerm
from adavar.slopes import SlopeReadoff, read_slopes
from adavar.statistics import SAFE_EXPONENT, unscale
from adavar.taus import tau_bounds
from adavar.terms import AVAR_FACTORS as _K
from adavar.terms import POWERS as _POWERS
from adavar.terms import TERM_NAMES
from adavar.terms import term_index as _term_index
from adavar.units import rate_unit_info

__all__ = [
    "ADEQUATE_P",
    "ALLAN_STATS",
    "TERM_NAMES",
    "NoiseFit",
    "NoiseTerm",
    "fit_avar",
    "fit_noise",
]

#: Statistics whose variance the IEEE model describes.
ALLAN_STATS = frozenset({"adev", "oadev", "totdev"})
#: Fit methods of :func:`fit_noise`.
METHODS = ("auto", "gls", "wls", "slopes")
#: Shortest tau kept when the sensor's bandwidth is given: this many ``1 / bandwidth``.
BANDWIDTH_FACTOR = 2.0
#: Most reweighting passes: the 3rd pass moves a coefficient by at most 0.15 of its
#: uncertainty, the 4th by 0.05 (module notes); by 100 the fit has converged or is cycling,
#: and each pass costs a whole fit (a stack of a million curves: seconds per pass).
MAX_REWEIGHT = 100
#: Values of a stack of curves handled at a time (whole curves; a multiple of 64 of them):
#: the masks, model and residual temporaries stay at a few MB whatever the size of a DAVAR
#: surface, instead of several copies of it.
BLOCK_VALUES = 1 << 20
#: Values of a stack given to the compiled fit at a time (its EDF and masked variances
#: are formed for that many): each call of the parallel kernel costs a thread start-up
#: (up to tens of ms on a busy machine), so fewer, larger blocks than :data:`BLOCK_VALUES`.
KERNEL_VALUES = 1 << 23


# --------------------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------------------


def _check_reweight(n_reweight: Any) -> int:
    """``n_reweight`` as an int in ``0 .. MAX_REWEIGHT``, or a one-line error."""
    if isinstance(n_reweight, (float, np.floating)) and float(n_reweight).is_integer():
        n_reweight = int(n_reweight)
    if isinstance(n_reweight, (bool, np.bool_)) or not isinstance(n_reweight, (int, np.integer)):
        raise AdavarInputError(f"n_reweight must be a non-negative integer, got {n_reweight!r}")
    if not 0 <= n_reweight <= MAX_REWEIGHT:
        raise AdavarInputError(
            f"n_reweight must lie in 0 .. {MAX_REWEIGHT}, got {n_reweight}: the fit converges "
            "in 3 or 4 passes"
        )
    return int(n_reweight)


def _check_units(units: str) -> None:
    try:
        rate_unit_info(units)
    except (TypeError, ValueError) as exc:
        raise AdavarInputError(str(exc)) from None


def _check_terms(terms: Sequence[str]) -> tuple[str, ...]:
    if isinstance(terms, str):
        terms = (terms,)
    try:
        terms = tuple(terms)
    except TypeError:
        raise AdavarInputError(
            f"terms must be a list of term names ({', '.join(TERM_NAMES)}), got {terms!r}"
        ) from None
    if not terms:
        raise AdavarInputError(f"terms is empty; valid names: {', '.join(TERM_NAMES)}")
    bad = [t for t in terms if t not in TERM_NAMES]
    if bad:
        raise AdavarInputError(
            f"unknown noise term(s) {', '.join(map(repr, bad))}; "
            f"valid names: {', '.join(TERM_NAMES)}"
        )
    if len(set(terms)) != len(terms):
        raise AdavarInputError(f"terms has duplicates: {terms}")
    return tuple(t for t in TERM_NAMES if t in terms)  # canonical order


def fit_avar(
    tau: Any,
    avar: Any,
    edf: Any = None,
    *,
    terms: Sequence[str] = TERM_NAMES,
    units: str | None = None,
    n_reweight: int = 3,
    spacing: str = "octave",
    method: str = "auto",
    select: str = "significance",
    significance: float = gls_fit.SIGNIFICANCE,
    exclude: str = "auto",
    tau_range: tuple[float | None, float | None] | None = None,
    bandwidth: float | None = None,
    rolloff: str = "model",
    reference: NoiseFit | None = None,
    cells: bool = True,
) -> NoiseFit:
    """Fit the noise model to raw Allan-variance arrays.

    Raw arrays carry neither the record length nor the sample interval that the estimators'
    covariance needs, so this is the diagonally weighted fit (``method="wls"``; ``"auto"``
    means it); fit a :class:`~adavar.results.DeviationResult` with :func:`fit_noise` for
    the full-covariance fit. ``select`` and ``exclude`` belong to that fit and are not
    applied here; ``tau_range`` and ``bandwidth`` are.

    Parameters
    ----------
    tau : array_like, shape (M,)
        Averaging times in seconds, positive.
    avar : array_like, shape (..., M)
        Allan variance(s); the leading dimensions are a stack of curves (NaN where
        undefined).
    edf : array_like, optional
        Equivalent degrees of freedom, broadcastable to ``avar``. None means relative
        weights only (``edf = 1`` everywhere, so the fit minimises the squared relative
        residuals) and uncertainties scaled by the reduced chi-square itself.
    terms : sequence of str
        The terms of the model, from :data:`TERM_NAMES`.
    units : str, optional
        Declared unit of the input rate samples (see :mod:`adavar.units`), used by
        :meth:`NoiseFit.to_units`.
    n_reweight : int
        Reweighting passes after the first (model avar in the weights); 0 keeps the
        weights of the measured avar; at most :data:`MAX_REWEIGHT`.
    spacing : {"octave", "independent"}
        ``"octave"`` (default): each tau's weight is multiplied by its local spacing in
        octaves, capped at 1 (``min(1, d log2(tau))``, central differences). Overlapping
        Allan variances within an octave are strongly correlated, so a dense tau grid
        (``taus="all"``, the paper's DAVAR) would otherwise count the same information many
        times over and let the noisy long-tau points outvote the short ones: on unit white
        noise in 600-sample windows with all taus, ``"independent"`` gives N 6 % low with a
        spurious quantization term in most windows, ``"octave"`` gives N within 2 %. Octave
        and decade grids are unchanged. ``"independent"``: the weights as they are.
    method : {"auto", "wls", "slopes"}
        ``"wls"`` (what ``"auto"`` means here) or the slope-line read-offs (which need
        ``edf`` only for their uncertainties).
    select, significance, exclude, rolloff
        See :func:`fit_noise` (full-covariance fit only; not applied here).
    reference : NoiseFit, optional
        See :func:`fit_noise`.
    tau_range : (float or None, float or None), optional
        Fit only the taus in ``[min, max]`` seconds (None: open).
    bandwidth : float, optional
        The sensor's bandwidth in Hz: taus below ``BANDWIDTH_FACTOR / bandwidth`` are left
        out.
    cells : bool
        A stack of curves: also the per-cell ``used`` mask and ``residuals`` (default).
        False leaves them None (see :func:`fit_noise`); one curve has them always.

    Returns
    -------
    NoiseFit

    Raises
    ------
    AdavarInputError
        On a bad ``tau``, inconsistent shapes, unknown terms or units, ``method="gls"``, or
        variances whose coefficients leave the float64 range.
    """
    if units is not None:
        _check_units(units)
    method = _check_options(method, select, significance, exclude, rolloff)
    if method == "gls":
        raise AdavarInputError(
            "method='gls' needs the record length and sample interval: fit the "
            "DeviationResult with fit_noise(result, method='gls')"
        )
    tau_a = _as_floats(tau, "tau")
    avar = _as_floats(avar, "avar")
    if tau_a.ndim != 1 or tau_a.size == 0:
        raise AdavarInputError(f"tau must be a non-empty 1-D array, got shape {tau_a.shape}")
    if avar.ndim == 0 or avar.shape[-1] != tau_a.size:
        raise AdavarInputError(
            f"avar must have shape (..., {tau_a.size}) to match tau, got {avar.shape}"
        )
    keep, reasons = _tau_selection(tau_a, tau_range, bandwidth)
    avar, k = _scaled_avar(avar)
    if method == "slopes":
        dev = np.sqrt(avar)
        return _unscale_fit(_slopes_fit(tau_a, dev, None, None, terms, units), k)
    drop, offset = _reference_columns(tau_a, keep, reference, reasons, k)
    return _unscale_fit(_fit(tau, avar, edf, terms, units, n_reweight, spacing=spacing,
                             reasons=reasons, drop=drop, offset=offset, cells=cells),
                        k)  # fmt: skip


def _as_floats(values: Any, name: str) -> np.ndarray:
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise AdavarInputError(f"{name} must be an array of numbers, got {values!r}") from None


def _deviation_exponent(values: np.ndarray) -> int:
    """Binary exponent of the largest finite positive value, 0 within ``2**±SAFE_EXPONENT``."""
    largest = -math.inf
    for block in _row_blocks(values):  # no mask nor copy of a whole surface
        ok = np.isfinite(block) & (block > 0)
        largest = max(largest, float(np.max(block, where=ok, initial=-math.inf)))
    if largest == -math.inf:
        return 0
    exponent = math.frexp(largest)[1]
    return exponent if abs(exponent) > SAFE_EXPONENT else 0


def _row_blocks(values: np.ndarray) -> list[np.ndarray]:
    """``values`` as blocks of whole rows (last axis) of about :data:`BLOCK_VALUES` values."""
    rows = values.reshape(-1, values.shape[-1]) if values.ndim > 1 else values.reshape(1, -1)
    step = _block_rows(rows.shape[1], BLOCK_VALUES)
    return [rows[a : a + step] for a in range(0, rows.shape[0], step)]


def _block_rows(n_tau: int, values: int) -> int:
    """Curves of ``n_tau`` taus per block of about ``values`` values (a multiple of 64)."""
    return max(64, values // max(1, n_tau) // 64 * 64)


def _scaled_avar(avar: np.ndarray) -> tuple[np.ndarray, int]:
    """``(avar * 4**-k, k)``: variances far from 1 are fitted at scale 1 (exact).

    The model is linear in the coefficients and the weights scale with the variance, so
    the fit of the scaled curve is the fit of the curve with every coefficient (and its
    uncertainty) times ``4**-k``; :func:`_unscale_fit` scales it back. Variances within
    ``4**±SAFE_EXPONENT`` (about 1e-39 .. 1e38) are fitted as they are.
    """
    k = _deviation_exponent(avar) // 2
    return (np.ldexp(avar, -2 * k) if k else avar), k


def _unscale_fit(fit: NoiseFit, k: int) -> NoiseFit:
    """A fit of variances scaled by ``4**-k``, in the data's own units again.

    Coefficients or uncertainties beyond the float64 range raise
    :class:`AdavarInputError`; the coefficient covariance (the square of their scale)
    leaves the range first, and is then ``None`` (not available) instead.
    """
    if k == 0:
        return fit
    what = "noise-model coefficients"
    slopes = fit.slopes
    if slopes is not None:
        slopes = dataclasses.replace(
            slopes,
            values={name: math.ldexp(v, k) for name, v in slopes.values.items()},
            uncertainty={name: math.ldexp(v, k) for name, v in slopes.uncertainty.items()},
        )
    covariance = fit.coefficient_covariance
    if covariance is not None:
        with np.errstate(over="ignore", under="ignore"):
            covariance = np.ldexp(covariance, 4 * k)
        if np.any(np.isfinite(fit.coefficient_covariance) & ~np.isfinite(covariance)):
            covariance = None
    return dataclasses.replace(
        fit,
        coefficients=unscale(fit.coefficients, 2 * k, what, underflow=False),
        coefficient_uncertainty=unscale(fit.coefficient_uncertainty, 2 * k, what, underflow=False),
        coefficient_covariance=covariance,
        slopes=slopes,
    )


def _reference_columns(
    tau: np.ndarray, keep: np.ndarray, reference: NoiseFit | None, reasons: list[str], k: int = 0
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The taus left out (``~keep``, and those below ``reference``'s shortest fitted one)
    and the variance taken out of every curve (``reference``'s roll-off), for :func:`_fit`.

    Returns ``(drop, offset)``: a boolean mask over ``tau`` (None: nothing left out) and
    ``rolloff / tau**2`` scaled by ``4**-k`` (:func:`_scaled_avar`; None without a negative
    roll-off). The fit reads ``where(drop, nan, avar) - offset``, block by block.
    """
    drop = ~np.asarray(keep, dtype=bool)
    offset = None
    if reference is not None:
        if not isinstance(reference, NoiseFit) or np.ndim(reference.coefficients) != 1:
            raise AdavarInputError("reference must be the NoiseFit of one whole-record curve")
        used = reference.used
        shortest = float(np.min(reference.tau[np.asarray(used)])) if used is not None else 0.0
        low = tau < shortest * (1.0 - 1e-9)
        for j in np.flatnonzero(low):
            reasons[j] = reasons[j] or f"below the whole-record fit's shortest tau {shortest:.3g} s"
        drop = drop | low
        roll = math.ldexp(float(reference.rolloff), -2 * k)
        if roll < 0:
            offset = roll / tau**2
    return (drop if drop.any() else None), offset


def _check_options(
    method: str, select: str, significance: float, exclude: str, rolloff: str
) -> str:
    if method not in METHODS:
        raise AdavarInputError(f"unknown method {method!r}: use one of {', '.join(METHODS)}")
    if select not in ("significance", "none"):
        raise AdavarInputError(f"unknown select {select!r}: use 'significance' or 'none'")
    if exclude not in ("auto", "none"):
        raise AdavarInputError(f"unknown exclude {exclude!r}: use 'auto' or 'none'")
    if rolloff not in ("model", "none"):
        raise AdavarInputError(f"unknown rolloff {rolloff!r}: use 'model' or 'none'")
    try:
        ok = float(significance) > 0 and math.isfinite(float(significance))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise AdavarInputError(f"significance must be a positive number, got {significance!r}")
    return method


def _tau_selection(
    tau: np.ndarray, tau_range: Any, bandwidth: float | None
) -> tuple[np.ndarray, list[str]]:
    """Points inside the tau range and above the bandwidth limit, with the reasons."""
    keep = np.ones(tau.shape, dtype=bool)
    reasons = [""] * tau.size
    if tau_range is not None:
        lo, hi = tau_bounds(tau_range)
        for j, t in enumerate(tau):
            if not lo <= t <= hi:
                keep[j] = False
                reasons[j] = f"outside tau_range [{lo:g}, {hi:g}] s"
    if bandwidth is not None:
        try:
            bw = float(bandwidth)
        except (TypeError, ValueError):
            bw = math.nan
        if not (bw > 0 and math.isfinite(bw)):
            raise AdavarInputError(f"bandwidth must be a positive number of Hz, got {bandwidth!r}")
        limit = BANDWIDTH_FACTOR / bw
        for j, t in enumerate(tau):
            if keep[j] and t < limit:
                keep[j] = False
                reasons[j] = f"below {BANDWIDTH_FACTOR:g} / bandwidth = {limit:.3g} s"
    return keep, reasons


def _readoff_reach(result: Any) -> float | None:
    """A tenth of the record (s), where slope read-offs stop; None if unknown."""
    try:
        return 0.1 * float(result.n_samples) * float(result.tau0)
    except (AttributeError, TypeError, ValueError):
        return None


def _slopes_fit(tau, dev, dev_low, dev_high, terms, units, tau_max=None) -> NoiseFit:
    """A NoiseFit whose coefficients are the slope-line read-offs."""
    terms = _check_terms(terms)
    read = read_slopes(tau, dev, dev_low, dev_high, tau_max=tau_max)
    coef = np.zeros(5)
    unc = np.full(5, np.nan)
    for k, name in enumerate(TERM_NAMES):
        if name not in terms:
            continue
        v, u = read.values[name], read.uncertainty[name]
        if math.isfinite(v):
            coef[k] = _K[k] * v * v
            unc[k] = 2.0 * _K[k] * v * u
    n = int(np.isfinite(dev).sum())
    return NoiseFit(
        coefficients=coef, coefficient_uncertainty=unc, tau=np.asarray(tau, float),
        chi2=math.nan, dof=0, reduced_chi2=math.nan, n_points=n, terms=terms, units=units,
        n_reweight=0, weighted=dev_low is not None, method="slopes",
        exclusions=tuple("" for _ in range(np.size(tau))), slopes=read,
    )  # fmt: skip


def _cell_outputs(
    start: int, a2: np.ndarray, e2: np.ndarray, coefficients: np.ndarray, basis: np.ndarray,
    share: np.ndarray, used: np.ndarray, resid: np.ndarray,
) -> None:  # fmt: skip
    """``used`` and ``residuals`` of curves ``start ..`` (the fitted ``a2`` and ``e2``;
    ``e2`` may be one row for all), in blocks of :data:`BLOCK_VALUES`."""
    step = _block_rows(a2.shape[1], BLOCK_VALUES)
    for a in range(0, a2.shape[0], step):
        ab, eb = a2[a : a + step], (e2 if e2.shape[0] == 1 else e2[a : a + step])
        rows = slice(start + a, start + a + ab.shape[0])
        good = np.isfinite(ab) & (ab > 0) & np.isfinite(eb) & (eb > 0)
        used[rows] = good
        model = coefficients[rows] @ basis
        with np.errstate(invalid="ignore", divide="ignore"):
            resid[rows] = np.where(good, (ab - model) / (model * np.sqrt(2.0 / (eb / share))),
                                   np.nan)  # fmt: skip


@dataclasses.dataclass(frozen=True)
class _EdfRows:
    """The EDF of a stack of curves as a per-class table: curve ``i`` has
    ``table[classes[i]]`` (a DAVAR surface's ``edf_table`` and ``window_class``), read
    block by block instead of as one (curves, taus) array."""

    table: np.ndarray
    classes: np.ndarray

    def any_finite(self) -> bool:
        """Whether any curve has a finite EDF."""
        if self.table.shape[0] == 1:
            return bool(np.isfinite(self.table).any())
        present = np.bincount(self.classes, minlength=self.table.shape[0]) > 0
        return bool(np.isfinite(self.table[present]).any())


def _stack_edf(result: Any, avar: np.ndarray) -> Any:
    """``result.edf``; for a DAVAR surface its per-class table (:class:`_EdfRows`)."""
    table = getattr(result, "edf_table", None)
    classes = getattr(result, "window_class", None)
    if (
        getattr(type(result), "edf", None) is DavarResult.edf
        and table is not None
        and classes is not None
        and avar.ndim == 2
    ):
        table = np.asarray(table, dtype=float)
        classes = np.asarray(classes)
        if (
            table.ndim == 2
            and table.shape[1] == avar.shape[1]
            and classes.shape == avar.shape[:1]
            and classes.dtype.kind in "iu"
        ):
            return _EdfRows(table, classes)
    return getattr(result, "edf", None)


def _fit(
    tau: Any,
    avar: Any,
    edf: Any,
    terms: Sequence[str],
    units: str | None,
    n_reweight: int,
    *,
    spacing: str = "octave",
    time: np.ndarray | None = None,
    reasons: list[str] | None = None,
    slopes: SlopeReadoff | None = None,
    drop: np.ndarray | None = None,
    offset: np.ndarray | None = None,
    cells: bool = True,
) -> NoiseFit:
    """The diagonally weighted fit behind :func:`fit_avar` and :func:`fit_noise`.

    ``edf`` is an array broadcastable to ``avar``, an :class:`_EdfRows` or None. Each
    curve is fitted to ``where(drop, nan, avar) - offset`` (``drop``: taus left out,
    ``offset``: a variance per tau taken out). A stack is fitted in blocks of curves
    (:data:`BLOCK_VALUES`), the same numbers as at once; ``cells=False`` leaves a stack's
    per-cell ``used`` and ``residuals`` out (None).
    """
    if spacing not in ("octave", "independent"):
        raise AdavarInputError(f"unknown spacing {spacing!r}: use 'octave' or 'independent'")
    terms = _check_terms(terms)
    n_reweight = _check_reweight(n_reweight)

    tau = np.asarray(tau, dtype=float)
    if tau.ndim != 1 or tau.size == 0:
        raise AdavarInputError(f"tau must be a non-empty 1-D array, got shape {tau.shape}")
    if not np.all(np.isfinite(tau)) or np.any(tau <= 0):
        raise AdavarInputError("tau must be finite and positive")
    avar = np.asarray(avar, dtype=float)
    if avar.ndim == 0 or avar.shape[-1] != tau.size:
        raise AdavarInputError(
            f"avar must have shape (..., {tau.size}) to match tau, got {avar.shape}"
        )
    weighted = edf is not None
    classes = None  # the EDF of curve i is row classes[i] of edf (a DAVAR surface's table)
    if isinstance(edf, _EdfRows):
        edf, classes = np.asarray(edf.table, dtype=float), edf.classes
        fits = edf.ndim == 2 and edf.shape[1] == tau.size and classes.shape == avar.shape[:1]
    else:
        edf = np.ones(tau.size) if edf is None else np.asarray(edf, dtype=float)
        try:
            fits = np.broadcast_shapes(edf.shape, avar.shape) == avar.shape
        except ValueError:
            fits = False
    if not fits:
        raise AdavarInputError(
            f"edf of shape {edf.shape} does not broadcast to avar's {avar.shape}"
        )

    share = np.ones(tau.size)
    if spacing == "octave" and tau.size > 1:
        order = np.argsort(tau)
        share[order] = np.minimum(1.0, np.gradient(np.log2(tau[order])))
    # each block's EDF rows are scaled by their octave shares below: the same products,
    # without a scaled copy of a surface's whole EDF table at every call
    octaves = not np.all(share == 1.0)

    lead = avar.shape[:-1]
    n_tau = tau.size
    a2 = avar.reshape(-1, n_tau)
    if classes is not None and edf.shape[0] == 1:
        edf, classes = edf[0], None  # one length: one row for every curve
    if classes is None:
        if edf.ndim == 2 and edf.shape[0] > 1 and edf.strides[0] == 0:
            edf = edf[0]  # one row broadcast over the stack (a fixed-window DAVAR)
        if edf.ndim <= 1 or math.prod(edf.shape[:-1]) == 1:
            # one edf row shared by every curve (the kernel then reads row 0): no per-curve copy
            e2 = np.ascontiguousarray(np.broadcast_to(edf.reshape(-1), (n_tau,)))[None, :]
        else:
            e2 = np.broadcast_to(edf, avar.shape).reshape(-1, n_tau)
    else:
        e2 = edf
    n_curves = a2.shape[0]

    sel = np.array([_term_index(t) for t in terms], dtype=np.int64)
    powers = _POWERS[sel]
    tau_ref = float(np.exp(np.mean(np.log(tau))))
    phi = np.ascontiguousarray((tau / tau_ref)[:, None] ** powers[None, :])
    sub_idx, sub_size, order = subsets(len(sel))

    coefficients = np.empty((n_curves, 5))
    coef_sig = np.empty((n_curves, 5))
    chi2 = np.empty(n_curves)
    npts = np.empty(n_curves, dtype=np.int64)
    neff = np.empty(n_curves)  # valid points, each counted by its octave share
    # a few ms of work (about 25 ns per curve and tau) run on the calling thread
    work = n_curves * n_tau if n_curves >= PARALLEL_MIN else 0
    cells = cells or not lead
    used = np.empty((n_curves, n_tau), dtype=bool) if cells else None
    resid = np.empty((n_curves, n_tau)) if cells else None
    basis = (tau[:, None] ** _POWERS[None, :]).T
    step = _block_rows(n_tau, KERNEL_VALUES)
    for a in range(0, n_curves, step):
        b = min(a + step, n_curves)
        a2b = a2[a:b]
        if drop is not None:
            a2b = np.where(drop, np.nan, a2b)
        if offset is not None:
            a2b = a2b - offset
        a2b = np.ascontiguousarray(a2b)
        e2b = e2[classes[a:b]] if classes is not None else e2 if e2.shape[0] == 1 else e2[a:b]
        e2b = e2b * share if octaves else np.ascontiguousarray(e2b)
        # inputs as read-only views: one compiled version whether a caller's array is
        # writable or not (a broadcast EDF row is read-only, a stacked one is not); each
        # curve is fitted on its own, so blocks give the numbers of one call
        per, items = grouped_items(-(-(b - a) // BLOCK))
        nnls_blocks.run(
            work, items, read_only(phi, np.float64),
            read_only(a2b, np.float64), read_only(e2b, np.float64),
            n_reweight, read_only(sub_idx), read_only(sub_size), read_only(order),
            read_only(sel), read_only(tau_ref ** (-powers.astype(float)), np.float64),
            weighted, read_only(share, np.float64), coefficients[a:b], coef_sig[a:b],
            chi2[a:b], npts[a:b], neff[a:b], per,
        )  # fmt: skip
        if used is not None and resid is not None:
            _cell_outputs(a, a2b, e2b, coefficients, basis, share, used, resid)
    dof = np.maximum(neff - len(sel), 0.0) if octaves else np.maximum(npts - len(sel), 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        red = np.where(dof > 0, chi2 / dof, np.nan)

    def shaped(x: np.ndarray) -> Any:
        x = x.reshape(lead + x.shape[1:])
        return x[()] if x.ndim == 0 else x

    exclusions: tuple[str, ...] = ()
    if not lead and used is not None:
        base = reasons or [""] * n_tau
        exclusions = tuple(
            r or ("" if used[0, j] else "undefined (NaN or not positive)")
            for j, r in enumerate(base)
        )
    return NoiseFit(
        coefficients=coefficients.reshape((*lead, 5)),
        coefficient_uncertainty=coef_sig.reshape((*lead, 5)),
        tau=tau,
        chi2=shaped(chi2),
        dof=shaped(dof),
        reduced_chi2=shaped(red),
        n_points=shaped(npts),
        terms=terms,
        units=units,
        n_reweight=n_reweight,
        weighted=weighted,
        time=time,
        spacing=spacing,
        method="wls",
        used=None if used is None else used.reshape((*lead, n_tau)),
        exclusions=exclusions,
        residuals=None if resid is None else resid.reshape((*lead, n_tau)),
        slopes=slopes,
    )


def fit_noise(
    result: Any,
    *,
    terms: Sequence[str] = TERM_NAMES,
    units: str | None = None,
    n_reweight: int = 3,
    spacing: str = "octave",
    method: str = "auto",
    select: str = "significance",
    significance: float = gls_fit.SIGNIFICANCE,
    exclude: str = "auto",
    tau_range: tuple[float | None, float | None] | None = None,
    bandwidth: float | None = None,
    rolloff: str = "model",
    reference: NoiseFit | None = None,
    cells: bool = True,
) -> NoiseFit:
    """Fit the IEEE noise model (docs/method.md section 4) to an Allan-deviation result.

    Parameters
    ----------
    result : object
        Anything with ``tau`` (shape (M,)), either ``avar`` or ``dev`` (shape (..., M)) and
        ``edf`` (broadcastable to it): a :class:`adavar.results.DeviationResult`, a DAVAR
        result (2-D ``avar`` and ``edf``, one row per window), ... If it has a ``stat``, it
        must be an Allan-type statistic (``"adev"``, ``"oadev"``, ``"totdev"``).
    terms : sequence of str
        The candidate terms of the model, from :data:`TERM_NAMES`.
    units : str, optional
        Declared unit of the input rate samples; defaults to ``result.units`` if the result
        has one (an explicit value must agree with it). An explicit value is checked here;
        one inherited from the result only when :meth:`NoiseFit.to_units` needs it.
    n_reweight : int
        Passes after the first, each weighted with the previous pass's model (the
        covariance for ``"gls"``, the diagonal weights for ``"wls"``); at most
        :data:`MAX_REWEIGHT` (the fit converges in 3 or 4).
    spacing : {"octave", "independent"}
        Weighting of densely spaced taus in the ``"wls"`` fit, see :func:`fit_avar` (the
        ``"gls"`` fit has the taus' correlation in its covariance instead).
    method : {"auto", "gls", "wls", "slopes"}
        ``"gls"``: generalised least squares with the full covariance of the estimates
        across taus, term selection and automatic exclusion of short taus the model cannot
        describe (:mod:`adavar.gls_fit`); it needs a whole-record result (``m``, ``tau0``,
        ``n_samples``, ``data_type``). ``"wls"``: the non-negative fit with diagonal
        weights ``edf / (2 avar^2)`` of every term in ``terms`` (the behaviour before
        version 0.2, and the fit of DAVAR stacks). ``"slopes"``: the classical slope-line
        read-offs (:mod:`adavar.slopes`) as the coefficients. ``"auto"`` (default):
        ``"gls"`` for one curve of ``oadev``/``adev``/``totdev`` with its record length,
        ``"wls"`` otherwise (a stack of windows: one covariance per window would cost
        O(M^3) each).
    select : {"significance", "none"}
        ``"gls"`` only. ``"significance"`` (default): backward elimination, a term stays
        only while ``C / sigma_C >= significance``; the removed ones are listed in
        ``NoiseFit.dropped`` with value 0 and a 1-sigma upper bound. ``"none"``: every
        term of ``terms`` (non-negative, pinned at 0 where the data push it negative).
    significance : float
        Threshold of the term selection (default 2).
    exclude : {"auto", "none"}
        ``"gls"`` only. ``"auto"`` (default): while the shortest fitted tau lies below a
        third of the curve's minimum and misses the model by more than
        ``gls_fit.EXCLUDE_Z`` standard errors, it is left out (the roll-off of a sensor's
        anti-aliasing filter, correlated short-tau noise); ``NoiseFit.exclusions`` says
        which and why. ``"none"``: every point in the tau range.
    tau_range : (float or None, float or None), optional
        Fit only the taus in ``[min, max]`` seconds (None: open at that end).
    bandwidth : float, optional
        The sensor's -3 dB bandwidth in Hz (datasheet, or the filter setting): taus below
        ``BANDWIDTH_FACTOR / bandwidth`` (2 / bandwidth) are left out.
    rolloff : {"model", "none"}
        ``"gls"`` only. ``"model"`` (default): the ``tau^-2`` coefficient may be negative,
        which is the Allan variance of positively correlated short-tau noise (a sensor's
        low-pass filter) beyond its correlation time; it is reported as
        ``NoiseFit.rolloff`` and Q as 0. Without it the filter's deficit just above the
        excluded taus biases N low (4 % on the 100 Hz simulator with a 10 Hz filter).
        ``"none"``: Q >= 0 like every term.
    reference : NoiseFit, optional
        ``"wls"`` (stacks of windows): the full-covariance fit of the whole record. The
        sensor's filter is the same in every window, so each window's fit leaves out the
        taus below the reference's shortest fitted tau and has the reference's roll-off
        term (``reference.rolloff / tau^2``) taken out of its variance first. On the
        bandwidth-limited simulator (200 Hz, 40 Hz filter) the median N(t) of 12-minute
        windows is 0.995 of the truth with it, 0.48 without (B 0.99 and 13x).
    cells : bool
        A stack of curves (a DAVAR surface): also the per-cell ``used`` mask and
        ``residuals`` of the fit (default). False leaves them None, which spares two arrays
        the size of the surface when only the coefficients are read. One curve has them
        always.

    Returns
    -------
    NoiseFit
        Coefficients in the data's own units: ``unit*s`` (Q), ``unit*sqrt(s)`` (N),
        ``unit`` (B), ``unit/sqrt(s)`` (K), ``unit/s`` (R); arrays over the leading shape
        for a stack of curves. For one curve, ``slopes`` holds the slope-line read-offs
        whatever the method, and ``residuals``, ``exclusions``, ``adequate`` and
        ``warnings`` say how well the model follows the curve.

    Raises
    ------
    AdavarInputError
        For a non-Allan statistic, a result without ``edf``, bad inputs (``n_reweight``
        beyond :data:`MAX_REWEIGHT`, unknown terms or units), or coefficients outside the
        float64 range (see Notes). It is a ``ValueError``.

    Notes
    -----
    Uncertainties of the ``"gls"`` fit are the inverse Fisher matrix of the selected terms
    under the model's own covariance, scaled by ``max(1, chi2/dof)``. Over 200 simulated
    records each of white + rate random walk, white + flicker + rate random walk and the
    bandwidth-limited, quantised sensor simulator, ``(estimate - truth) / uncertainty``
    has a standard deviation near 1 for N, B and K (``benchmarks/bench_fit_real.py``,
    ``docs/benchmarks.md``).
    """
    method = _check_options(method, select, significance, exclude, rolloff)
    stat = getattr(result, "stat", None)
    if stat is not None and str(stat).lower() not in ALLAN_STATS:
        raise AdavarInputError(
            f"the coefficients of the IEEE noise model are defined for the Allan variance, "
            f"not for stat={stat!r}; compute the deviation with stat='oadev'"
        )
    if not hasattr(result, "tau"):
        raise AdavarInputError("result has no 'tau'; use fit_avar(tau, avar, edf) for raw arrays")
    # a deviation is scaled before it is squared (dev**2 overflows from 1.3e154 on)
    dev = getattr(result, "dev", None)
    if dev is not None:
        dev = np.asarray(dev, dtype=float)
        k = _deviation_exponent(dev)
        avar = np.ldexp(dev, -k) ** 2 if k else dev**2
    else:
        avar = getattr(result, "avar", None)
        if avar is None:
            raise AdavarInputError("result has neither 'avar' nor 'dev'")
        avar, k = _scaled_avar(np.asarray(avar, dtype=float))
    edf = _stack_edf(result, avar)
    finite = edf.any_finite() if isinstance(edf, _EdfRows) else (
        edf is not None and np.isfinite(np.asarray(edf, dtype=float)).any()
    )  # fmt: skip
    if not finite:
        raise AdavarInputError(
            "result has no 'edf' (a deviation computed with confidence=None?); compute it "
            "with a confidence level, or use fit_avar(tau, avar, edf=None) for relative weights"
        )
    declared = getattr(result, "units", None)
    if units is not None and declared is not None and units != declared:
        raise AdavarInputError(
            f"units={units!r} contradicts the result's declared units {declared!r}"
        )
    if units is not None:
        _check_units(units)
    else:
        units = declared
    time = getattr(result, "time", None)
    if time is not None and np.ndim(avar) != 2:
        time = None
    tau = np.asarray(result.tau, dtype=float)
    keep, reasons = _tau_selection(tau, tau_range, bandwidth)
    one = avar.ndim == 1
    slopes = None
    if one:
        dev = np.sqrt(avar)
        low, high = getattr(result, "dev_low", None), getattr(result, "dev_high", None)
        if k:
            low = None if low is None else np.ldexp(np.asarray(low, dtype=float), -k)
            high = None if high is None else np.ldexp(np.asarray(high, dtype=float), -k)
        if method == "slopes":
            return _unscale_fit(_slopes_fit(tau, np.where(keep, dev, np.nan), low, high, terms,
                                            units, tau_max=_readoff_reach(result)), k)  # fmt: skip
        slopes = read_slopes(tau, dev, low, high, tau_max=_readoff_reach(result))
    elif method == "slopes":
        raise AdavarInputError("method='slopes' reads one curve; fit a stack with 'wls'")
    record = _record_of(result) if one else None
    if method == "gls" and record is None:
        raise AdavarInputError(
            "method='gls' needs one whole-record curve with its record (m, tau0, n_samples, "
            "data_type): a DeviationResult; use method='wls' for stacks or raw arrays"
        )
    if method == "wls" or record is None:
        drop, offset = _reference_columns(tau, keep, reference, reasons, k)
        return _unscale_fit(_fit(tau, avar, edf, terms, units, n_reweight, spacing=spacing,
                                 time=time, reasons=reasons, slopes=slopes, drop=drop,
                                 offset=offset, cells=cells), k)  # fmt: skip
    if reference is not None:
        raise AdavarInputError(
            "reference is for the fit of DAVAR windows (method='wls'); a whole-record curve "
            "is fitted with its own exclusions and roll-off"
        )
    return _unscale_fit(_gls(result, record, avar, keep, reasons, terms, units, n_reweight,
                             select, float(significance), exclude, rolloff, slopes), k)  # fmt: skip


def _record_of(result: Any) -> tuple[np.ndarray, int, float] | None:
    """(m, n_points, tau0) of a whole-record result of an Allan statistic, else None."""
    try:
        m = np.asarray(result.m, dtype=np.int64)
        tau0 = float(result.tau0)
        n_samples = int(result.n_samples)
        phase = str(result.data_type) == "phase"
        stat = str(getattr(result, "stat", "oadev")).lower()
    except (AttributeError, TypeError, ValueError):
        return None
    if stat not in ALLAN_STATS or m.shape != np.shape(result.tau):
        return None
    n_points = n_samples if phase else n_samples + 1
    if np.any(m < 1) or np.any(n_points - 2 * m < 1):
        return None
    return m, n_points, tau0


def _gls(result, record, avar, keep, reasons, terms, units, n_reweight, select,
         significance, exclude, rolloff, slopes) -> NoiseFit:  # fmt: skip
    """The full-covariance fit of one curve (:mod:`adavar.gls_fit`) as a NoiseFit."""
    terms = _check_terms(terms)
    n_reweight = _check_reweight(n_reweight)
    ms, n_points, tau0 = record
    tau = np.asarray(result.tau, dtype=float)
    edf = np.broadcast_to(np.asarray(result.edf, dtype=float), tau.shape)
    good = np.isfinite(avar) & (avar > 0) & np.isfinite(edf) & (edf > 0)
    for j in np.flatnonzero(~good):
        reasons[j] = "undefined (NaN or not positive)"
    usable = good & keep
    stat = str(getattr(result, "stat", "oadev")).lower()
    alpha = np.asarray(getattr(result, "alpha", np.zeros(tau.size)), dtype=np.int64)
    sel = tuple(_term_index(t) for t in terms)
    if usable.sum() < len(sel):
        return _fit(tau, np.where(usable, avar, np.nan), edf, terms, units, 0,
                    reasons=reasons, slopes=slopes)  # fmt: skip
    out = gls_fit.fit_curve(
        tau, avar, edf, ms=ms, n_points=n_points, tau0=tau0, stat=stat, alpha=alpha,
        terms=sel, usable=usable, reasons=reasons, n_iter=int(n_reweight), select=select,
        significance=significance, exclude=exclude, rolloff=rolloff,
    )  # fmt: skip
    red = out.chi2 / out.dof if out.dof > 0 else math.nan
    dropped = tuple(TERM_NAMES[k] for k in out.dropped)
    return NoiseFit(
        coefficients=out.coefficients,
        coefficient_uncertainty=out.coefficient_uncertainty,
        tau=tau,
        chi2=float(out.chi2),
        dof=int(out.dof),
        reduced_chi2=float(red),
        n_points=int(out.n_points),
        terms=terms,
        units=units,
        n_reweight=int(n_reweight),
        weighted=True,
        spacing="covariance",
        method="gls",
        used=out.used,
        exclusions=out.reasons,
        residuals=out.residuals,
        dropped=dropped,
        coefficient_covariance=out.coefficient_covariance,
        slopes=slopes,
    )

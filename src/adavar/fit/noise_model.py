"""Fit the IEEE Std 952 noise model to Allan-variance curves (docs/method.md section 4, Eq. 7).

The model is

.. math::  \\sigma^2(\\tau) = \\sum_{n=-2}^{2} C_n \\tau^n ,

with ``Q = sqrt(C_-2/3)`` (quantization), ``N = sqrt(C_-1)`` (angle/velocity random walk),
``B = sqrt(C_0/(2 ln2/pi))`` (bias instability), ``K = sqrt(3 C_1)`` (rate random walk) and
``R = sqrt(2 C_2)`` (rate ramp).

Two fits
--------
* **One whole-record curve** (a :class:`~adavar.core.results.DeviationResult`): by default the
  generalised least-squares fit of :mod:`adavar.fit.gls_fit` (``method="gls"``), with the full
  covariance of the estimates across taus (:mod:`adavar.stats.avar_covariance`), term selection
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
  samples at 1 Hz, octave taus and edf from :func:`adavar.stats.statistics.deviation`, 60
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
  float64 range are an :class:`~adavar.core.errors.AdavarInputError` (rescale the data); a GLS
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

from adavar.core.errors import AdavarInputError
from adavar.core.inputs import SAFE_EXPONENT, unscale
from adavar.core.request import settings_keywords
from adavar.core.results import ADEQUATE_P, MarkovTerm, NoiseFit, NoiseTerm
from adavar.core.settings import FitSettings
from adavar.core.taus import tau_bounds
from adavar.core.terms import AVAR_FACTORS as _K
from adavar.core.terms import TERM_NAMES
from adavar.core.terms import term_index as _term_index
from adavar.core.units import rate_unit_info
from adavar.fit import gls_core, gls_fit
from adavar.fit.stack_fit import (
    MAX_REWEIGHT,
    EdfRows,
    check_reweight,
    check_terms,
    fit_stack,
    row_blocks,
    stack_edf,
)
from adavar.stats.slopes import read_slopes

__all__ = [
    "ADEQUATE_P",
    "ALLAN_STATS",
    "MAX_REWEIGHT",
    "TERM_NAMES",
    "NoiseFit",
    "NoiseTerm",
    "fit_avar",
    "fit_noise",
    "record_reference",
]

#: Statistics whose variance the IEEE model describes.
ALLAN_STATS = frozenset({"adev", "oadev", "totdev"})
#: Fit methods of :func:`fit_noise`.
METHODS = ("auto", "gls", "wls", "slopes")
#: Shortest tau kept when the sensor's bandwidth is given: this many ``1 / bandwidth``.
BANDWIDTH_FACTOR = 2.0


# --------------------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------------------


def _check_units(units: str) -> None:
    try:
        rate_unit_info(units)
    except (TypeError, ValueError) as exc:
        raise AdavarInputError(str(exc)) from None


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
    select: str = gls_fit.DEFAULT_SELECT,
    significance: float = gls_fit.SIGNIFICANCE,
    exclude: str = "auto",
    tau_range: tuple[float | None, float | None] | None = None,
    bandwidth: float | None = None,
    rolloff: str = "model",
    reference: NoiseFit | None = None,
    cells: bool = True,
    markov: str = "auto",
    bound_level: float = FitSettings.bound_level,
    uncertainty: str = FitSettings.uncertainty,
) -> NoiseFit:
    """Fit the noise model to raw Allan-variance arrays.

    Raw arrays carry neither the record length nor the sample interval that the estimators'
    covariance needs, so this is the diagonally weighted fit (``method="wls"``; ``"auto"``
    means it); fit a :class:`~adavar.core.results.DeviationResult` with :func:`fit_noise` for
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
        Declared unit of the input rate samples (see :mod:`adavar.core.units`), used by
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
    select, significance, exclude, rolloff, markov, bound_level, uncertainty
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
    method = _check_options(method, select, significance, exclude, rolloff, markov, bound_level,
                            uncertainty)  # fmt: skip
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
    drop, offset, white = _reference_columns(tau_a, keep, reference, reasons, k, terms)
    fit = fit_stack(tau, avar, edf, terms, units, n_reweight, spacing=spacing, reasons=reasons,
                    drop=drop, offset=offset, white_rolloff=white, cells=cells)  # fmt: skip
    return _unscale_fit(_with_reference_warning(fit, reference), k)


def _as_floats(values: Any, name: str) -> np.ndarray:
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise AdavarInputError(f"{name} must be an array of numbers, got {values!r}") from None


def _deviation_exponent(values: np.ndarray) -> int:
    """Binary exponent of the largest finite positive value, 0 within ``2**±SAFE_EXPONENT``."""
    largest = -math.inf
    for block in row_blocks(values):  # no mask nor copy of a whole surface
        ok = np.isfinite(block) & (block > 0)
        largest = max(largest, float(np.max(block, where=ok, initial=-math.inf)))
    if largest == -math.inf:
        return 0
    exponent = math.frexp(largest)[1]
    return exponent if abs(exponent) > SAFE_EXPONENT else 0


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
    markov = fit.markov
    if markov is not None:
        markov = dataclasses.replace(
            markov, sigma=math.ldexp(markov.sigma, k),
            sigma_uncertainty=math.ldexp(markov.sigma_uncertainty, k),
        )  # fmt: skip
    upper = fit.coefficient_upper
    if upper is not None:
        with np.errstate(over="ignore"):
            upper = np.ldexp(upper, 2 * k)
    return dataclasses.replace(
        fit,
        coefficients=unscale(fit.coefficients, 2 * k, what, underflow=False),
        coefficient_uncertainty=unscale(fit.coefficient_uncertainty, 2 * k, what, underflow=False),
        coefficient_covariance=covariance,
        slopes=slopes,
        markov=markov,
        coefficient_upper=upper,
    )


def _with_reference_warning(fit: NoiseFit, reference: NoiseFit | None) -> NoiseFit:
    """``fit`` with :attr:`NoiseFit.reference_warning` set when its reference does not
    describe its own curve: every window inherits its roll-off term and shortest tau."""
    if reference is None or reference.method != "gls" or bool(reference.adequate):
        return fit
    why = (
        f"a better model: {reference.better_model}"
        if reference.better_model is not None
        else f"reduced chi2 {float(reference.reduced_chi2):.3g}, p = {float(reference.p_value):.2g}"
    )
    return dataclasses.replace(fit, reference_warning=(
        f"the whole-record fit that gives the windows their roll-off term and shortest tau "
        f"does not describe the record ({why}): every window inherits it; read the "
        f"whole-record fit's residuals, give the sensor's bandwidth or a tau range"
    ))  # fmt: skip


def _reference_columns(
    tau: np.ndarray, keep: np.ndarray, reference: NoiseFit | None, reasons: list[str],
    k: int = 0, terms: Sequence[str] = TERM_NAMES,
) -> tuple[np.ndarray | None, np.ndarray | None, float | None]:  # fmt: skip
    """The taus left out (``~keep``, and those below ``reference``'s shortest fitted one)
    and ``reference``'s roll-off, for :func:`fit_stack`.

    Returns ``(drop, offset, white_rolloff)``: a boolean mask over ``tau`` (None: nothing
    left out); the roll-off as the white noise's: ``rolloff / C_-1`` of the reference (s),
    so that each window's roll-off follows its own white level (a filter attenuates the
    noise it is given: inside a stretch of doubled noise, a fixed roll-off put N 4-5 % low,
    an independent audit); or, where the windows fit no white noise term or the reference
    has none, the fixed ``rolloff / tau**2`` scaled by ``4**-k`` (:func:`_scaled_avar`)
    taken out of every curve. None where there is no negative roll-off.
    """
    drop = ~np.asarray(keep, dtype=bool)
    offset = white = None
    if reference is not None:
        if not isinstance(reference, NoiseFit) or np.ndim(reference.coefficients) != 1:
            raise AdavarInputError("reference must be the NoiseFit of one whole-record curve")
        used = None if reference.used is None else np.asarray(reference.used)
        # a reference that fitted no tau (a constant record, a tau range beside its curve)
        # has no shortest fitted tau: nothing is left out below it
        shortest = float(np.min(reference.tau[used])) if used is not None and used.any() else 0.0
        low = tau < shortest * (1.0 - 1e-9)
        for j in np.flatnonzero(low):
            reasons[j] = reasons[j] or f"below the whole-record fit's shortest tau {shortest:.3g} s"
        drop = drop | low
        roll = math.ldexp(float(reference.rolloff), -2 * k)
        white_ref = math.ldexp(float(reference.coefficients[1]), -2 * k)
        if roll < 0 and white_ref > 0 and "angle_random_walk" in terms:
            white = roll / white_ref
        elif roll < 0:
            offset = roll / tau**2
    return (drop if drop.any() else None), offset, white


def _check_options(
    method: str, select: str, significance: float, exclude: str, rolloff: str,
    markov: str = "auto", bound_level: float = FitSettings.bound_level,
    uncertainty: str = FitSettings.uncertainty,
) -> str:  # fmt: skip
    if method not in METHODS:
        raise AdavarInputError(f"unknown method {method!r}: use one of {', '.join(METHODS)}")
    if select not in gls_fit.SELECTIONS:
        raise AdavarInputError(
            f"unknown select {select!r}: use one of {', '.join(gls_fit.SELECTIONS)}"
        )
    if markov not in ("auto", "none"):
        raise AdavarInputError(f"unknown markov {markov!r}: use 'auto' or 'none'")
    if uncertainty not in gls_fit.UNCERTAINTIES:
        raise AdavarInputError(
            f"unknown uncertainty {uncertainty!r}: use one of {', '.join(gls_fit.UNCERTAINTIES)}"
        )
    try:
        level_ok = 0.5 < float(bound_level) < 1.0
    except (TypeError, ValueError):
        level_ok = False
    if not level_ok:
        raise AdavarInputError(
            f"bound_level must be a probability between 0.5 and 1, got {bound_level!r}"
        )
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


def _check_some_tau_kept(
    tau: np.ndarray, keep: np.ndarray, tau_range: Any, bandwidth: float | None
) -> None:
    """A stack of curves (a surface's windows) of which ``tau_range`` and ``bandwidth``
    leave no tau has nothing to fit in any window: a one-line error naming the taus there
    are (one curve is reported "not fitted" instead)."""
    if tau.size == 0 or keep.any():
        return
    span = f"{float(np.min(tau)):.3g} .. {float(np.max(tau)):.3g} s"
    if tau_range is not None:
        lo, hi = tau_bounds(tau_range)
        in_range = (tau >= lo) & (tau <= hi)
        if not in_range.any():
            raise AdavarInputError(
                f"no tau of the windows lies in tau_range (--tau-range) [{lo:g}, {hi:g}] s: "
                f"their taus are {span} (up to a third of the window); choose a range that "
                "overlaps them, or a longer window"
            )
    bw = float(bandwidth)  # type: ignore[arg-type]  # what else leaves out a tau
    limit = BANDWIDTH_FACTOR / bw
    raise AdavarInputError(
        f"bandwidth (--bandwidth) {bw:g} Hz leaves no tau of the windows to fit: it "
        f"drops every tau below {BANDWIDTH_FACTOR:g} / bandwidth = {limit:.3g} s and their "
        f"taus are {span} (up to a third of the window); give the sensor's bandwidth in Hz, "
        "or a longer window"
    )


def _readoff_reach(result: Any) -> float | None:
    """A tenth of the record (s), where slope read-offs stop; None if unknown."""
    try:
        return 0.1 * float(result.n_samples) * float(result.tau0)
    except (AttributeError, TypeError, ValueError):
        return None


def _slopes_fit(tau, dev, dev_low, dev_high, terms, units, tau_max=None) -> NoiseFit:
    """A NoiseFit whose coefficients are the slope-line read-offs."""
    terms = check_terms(terms)
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


def fit_noise(
    result: Any,
    *,
    terms: Sequence[str] = TERM_NAMES,
    units: str | None = None,
    n_reweight: int = 3,
    spacing: str = "octave",
    method: str = "auto",
    select: str = gls_fit.DEFAULT_SELECT,
    significance: float = gls_fit.SIGNIFICANCE,
    exclude: str = "auto",
    tau_range: tuple[float | None, float | None] | None = None,
    bandwidth: float | None = None,
    rolloff: str = "model",
    reference: NoiseFit | str | None = "auto",
    cells: bool = True,
    markov: str = "auto",
    bound_level: float = FitSettings.bound_level,
    uncertainty: str = FitSettings.uncertainty,
    settings: FitSettings | None = None,
) -> NoiseFit:
    """Fit the IEEE noise model (docs/method.md section 4) to an Allan-deviation result.

    Parameters
    ----------
    result : object
        Anything with ``tau`` (shape (M,)), either ``avar`` or ``dev`` (shape (..., M)) and
        ``edf`` (broadcastable to it): a :class:`adavar.core.results.DeviationResult`, a DAVAR
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
        describe (:mod:`adavar.fit.gls_fit`); it needs a whole-record result (``m``, ``tau0``,
        ``n_samples``, ``data_type``). ``"wls"``: the non-negative fit with diagonal
        weights ``edf / (2 avar^2)`` of every term in ``terms`` (the behaviour before
        version 0.2, and the fit of DAVAR stacks). ``"slopes"``: the classical slope-line
        read-offs (:mod:`adavar.stats.slopes`) as the coefficients. ``"auto"`` (default):
        ``"gls"`` for one curve of ``oadev``/``adev``/``totdev`` with its record length,
        ``"wls"`` otherwise (a stack of windows: one covariance per window would cost
        O(M^3) each).
    select : {"aic", "bic", "significance", "none"}
        ``"gls"`` only. ``"aic"`` (default): every subset of ``terms`` is fitted and the
        one of the least ``-2 ln L + 2 k`` kept, each model's likelihood under its own
        covariance (:func:`adavar.fit.gls_core.neg2_log_likelihood`; a rate ramp counts two
        parameters); ``"bic"``: the penalty ``ln(n)`` per parameter. The terms left out
        are listed in ``NoiseFit.dropped`` with value 0, an 84 % upper bound as
        uncertainty and the ``bound_level`` one as ``NoiseTerm.upper``.
        ``"significance"``: the backward elimination of adavar 0.2 (a term stays while
        ``C / sigma_C >= significance``, uncertainties inflated by a poor fit first): it
        dropped real rate random walks (issue 39). ``"none"``: every term of ``terms``
        (non-negative, pinned at 0 where the data push it negative).
    significance : float
        Threshold of ``select="significance"`` (default 2).
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
    reference : NoiseFit, "auto" or None
        ``"wls"`` (stacks of windows): the full-covariance fit of the whole record.
        ``"auto"`` (default): a surface of a record in memory carries the record's octave
        curve (:attr:`DavarResult.record_curve`), and its full-covariance fit with the
        same options is the reference (:func:`record_reference`); None: no reference
        (the behaviour of adavar 0.2, whose window fits on a filtered sensor read N about
        half the truth, and 0 in every window behind a filter at a fifth of the Nyquist
        frequency with rounding). A NoiseFit: that one. The
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
    markov : {"auto", "none"}
        ``"gls"`` with ``select="aic"``/``"bic"``: ``"auto"`` (default) adds a
        first-order Gauss-Markov term (``NoiseFit.markov``: sigma, correlation time) when
        it beats the best model without it by ``gls_fit.MARKOV_MARGIN`` and the model
        then describes the curve; ``"none"``: the IEEE terms only (a hump is then read
        as bias instability and a rate random walk, and the adequacy test says so).
    bound_level : float
        One-sided level of ``NoiseTerm.upper`` for terms at 0 (default 0.99: of the
        records where the selection leaves a real term out, its 99 % bound lies above
        the truth in 87-91 %, the 95 % one in 43-66 %).
    uncertainty : {"conditional", "averaged"}
        ``"gls"`` with ``select="aic"``/``"bic"``: ``"averaged"`` (default) puts the doubt
        of the selection's choice in each chosen term's 1-sigma, ``"conditional"`` gives it
        given the model chosen (before 0.3.0). Averaged: ``sqrt(s^2 + (1 - w) v^2)`` for a
        term of value ``v`` and conditional 1-sigma ``s``, ``w`` its
        :attr:`NoiseFit.term_support` (the weight of the models that hold it). Where the
        curve cannot tell two terms apart (bias instability or a rate random walk on a
        record a few crossover times long) the
        conditional 1-sigma of the term chosen is too small for the case where the other
        was the truth; the averaged one covers both, and is larger than needed when the
        chosen term was right (``benchmarks/bench_validation.py --part selection``). Other
        fits ignore it.
    settings : FitSettings, optional
        ``terms``, ``n_reweight``, ``spacing``, ``method``, ``select``, ``significance``,
        ``exclude``, ``rolloff``, ``tau_range``, ``bandwidth``, ``markov``,
        ``bound_level`` and ``uncertainty`` as one object
        (:class:`adavar.core.settings.FitSettings`, what
        :class:`adavar.core.request.AnalysisRequest` holds); its fields replace those keywords.
        A keyword also given with another value is an error.

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
    if settings is not None:
        given = {k: v for k, v in locals().items() if k not in ("result", "settings")}
        return fit_noise(result, **settings_keywords(fit_noise, given, (settings, FitSettings)))
    method = _check_options(method, select, significance, exclude, rolloff, markov, bound_level,
                            uncertainty)  # fmt: skip
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
    edf = stack_edf(result, avar)
    finite = edf.any_finite() if isinstance(edf, EdfRows) else (
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
    if not one:
        _check_some_tau_kept(tau, keep, tau_range, bandwidth)
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
    if isinstance(reference, str):
        if reference != "auto":
            raise AdavarInputError(
                f"reference must be a NoiseFit, 'auto' or None, got {reference!r}"
            )
        reference = None if one else record_reference(
            result, terms=terms, units=units, n_reweight=n_reweight, select=select,
            significance=significance, exclude=exclude, tau_range=tau_range,
            bandwidth=bandwidth, rolloff=rolloff, markov=markov,
        )  # fmt: skip
    if method == "wls" or record is None:
        drop, offset, white = _reference_columns(tau, keep, reference, reasons, k, terms)
        fit = fit_stack(tau, avar, edf, terms, units, n_reweight, spacing=spacing, time=time,
                        reasons=reasons, slopes=slopes, drop=drop, offset=offset,
                        white_rolloff=white, cells=cells)  # fmt: skip
        return _unscale_fit(_with_reference_warning(fit, reference), k)
    if reference is not None:
        raise AdavarInputError(
            "reference is for the fit of DAVAR windows (method='wls'); a whole-record curve "
            "is fitted with its own exclusions and roll-off"
        )
    return _unscale_fit(_gls(result, record, avar, keep, reasons, terms, units, n_reweight,
                             select, float(significance), exclude, rolloff, slopes,
                             markov, float(bound_level), uncertainty), k)  # fmt: skip


def _normal_quantile(p: float) -> float:
    from scipy.special import ndtri

    return float(ndtri(p))


def record_reference(result: Any, **options: Any) -> NoiseFit | None:
    """The reference of a surface's window fits (``fit_noise(surface, reference="auto")``):
    the full-covariance fit of its whole-record curve (:attr:`DavarResult.record_curve`),
    or None (no curve, or it cannot be fitted).

    Parameters
    ----------
    result : DavarResult
        The surface (or a block of it).
    **options
        Keywords of :func:`fit_noise` (``method`` and ``reference`` excepted).
    """
    options = {k: v for k, v in options.items() if k not in ("method", "reference", "cells",
                                                             "spacing")}  # fmt: skip
    curve = getattr(result, "record_curve", None)
    if curve is None:
        return None
    try:
        return fit_noise(curve, method="gls", **options)
    except AdavarInputError:
        return None


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
         significance, exclude, rolloff, slopes, markov, bound_level,
         uncertainty) -> NoiseFit:  # fmt: skip
    """The full-covariance fit of one curve (:mod:`adavar.fit.gls_fit`) as a NoiseFit."""
    terms = check_terms(terms)
    n_reweight = check_reweight(n_reweight)
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
        return fit_stack(tau, np.where(usable, avar, np.nan), edf, terms, units, 0,
                    reasons=reasons, slopes=slopes)  # fmt: skip
    out = gls_fit.fit_curve(
        tau, avar, edf, ms=ms, n_points=n_points, tau0=tau0, stat=stat, alpha=alpha,
        terms=sel, usable=usable, reasons=reasons, n_iter=int(n_reweight), select=select,
        significance=significance, exclude=exclude, rolloff=rolloff, markov=markov,
        bound_z=float(_normal_quantile(bound_level)), excess=gls_core.white_excess(result),
        uncertainty=uncertainty,
    )  # fmt: skip
    red = out.chi2 / out.dof if out.dof > 0 else math.nan
    dropped = tuple(TERM_NAMES[k] for k in out.dropped)
    markov = None
    if out.markov is not None:
        mk = out.markov
        sigma = math.sqrt(mk.variance)
        markov = MarkovTerm(
            sigma=sigma,
            sigma_uncertainty=mk.variance_uncertainty / (2.0 * sigma) if sigma > 0 else math.nan,
            tau_c=mk.tau_c,
            tau_c_range=mk.tau_c_range,
        )
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
        markov=markov,
        coefficient_upper=out.upper,
        bound_level=bound_level,
        gof_chi2=float(out.gof_chi2),
        selection=select,
        better_model=out.better,
        term_support=out.support,
        uncertainty_rule=uncertainty,
    )

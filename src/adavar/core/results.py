"""Result containers shared by the statistics, the DAVAR engine and the fits."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from adavar.core.settings import FitSettings
from adavar.core.terms import AVAR_FACTORS as _K
from adavar.core.terms import POWERS as _POWERS
from adavar.core.terms import TERM_NAMES, markov_avar, term_index
from adavar.core.units import (
    ConvertedNoise,
    ConvertedTerm,
    conventional_units,
    convert_coefficient,
    rate_unit_info,
)

if TYPE_CHECKING:
    from adavar.stats.slopes import SlopeReadoff

__all__ = [
    "ADEQUATE_P",
    "SUPPORT_WARNING",
    "DavarResult",
    "DeviationResult",
    "MarkovTerm",
    "NoiseFit",
    "NoiseTerm",
]

#: ``p_value`` below which a full-covariance fit is flagged as not describing the data.
ADEQUATE_P = 1e-3
#: a term in the model whose :attr:`NoiseFit.term_support` is below this gets a warning:
#: a model without it is within 2 of the criterion (Burnham and Anderson's "substantial
#: support"), its weight at least exp(-1) of the chosen one's
SUPPORT_WARNING = 1.0 / (1.0 + math.exp(-1.0))


@dataclass(frozen=True)
class DeviationResult:
    """Deviation of a whole record at a set of averaging times.

    Attributes
    ----------
    tau : ndarray
        Averaging times in seconds, ``m * tau0``.
    dev : ndarray
        The deviation (square root of the variance) at each ``tau``.
    dev_low, dev_high : ndarray
        Lower and upper bounds of the confidence interval at ``confidence``.
    edf : ndarray
        Equivalent degrees of freedom of each variance estimate.
    n : ndarray
        Number of terms that entered the sum at each ``tau``.
    m : ndarray
        Averaging factors (``tau / tau0``), integers.
    alpha : ndarray
        Identified power-law noise exponent of the fractional-frequency (rate) PSD at each
        ``tau`` (2 white PM/quantization, 1 flicker PM, 0 white FM/ARW, -1 flicker FM/bias
        instability, -2 random walk FM/RRW, ...), used for the EDF.
    stat : str
        The statistic (``"adev"``, ``"oadev"``, ``"mdev"``, ``"hdev"``, ``"ohdev"``,
        ``"tdev"``, ``"totdev"``).
    data_type : str
        ``"rate"`` or ``"phase"``: how the input was interpreted.
    tau0 : float
        Sample interval in seconds; ``rate = 1 / tau0``.
    confidence : float
        Two-sided confidence level of ``dev_low``/``dev_high``.
    n_samples : int
        Length of the input record.
    units : str or None
        Declared unit of the input samples (e.g. ``"deg/s"``), or None if not declared.
    notes : tuple of str
        What the computation changed about the request (taus rounded to multiples of tau0,
        taus dropped because they exceed the record, ...).
    warnings : tuple of str
        What may make the result misleading although it is computed as asked: a record
        whose short-tau noise is not stationary (:func:`adavar.stationarity`), for which
        one whole-record curve averages different noise levels.
    increment_kurtosis : float or None
        Pearson kurtosis of the rate samples' first differences (of at most
        :data:`adavar.stats.statistics.KURTOSIS_SAMPLES` from the middle of a record in memory;
        None out of core): 3 for Gaussian noise. The full-covariance noise fit takes the
        heavy tails of the white rate noise from it (:func:`adavar.fit_noise`).
    """

    tau: np.ndarray
    dev: np.ndarray
    dev_low: np.ndarray
    dev_high: np.ndarray
    edf: np.ndarray
    n: np.ndarray
    m: np.ndarray
    alpha: np.ndarray
    stat: str
    data_type: str
    tau0: float
    confidence: float
    n_samples: int
    units: str | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    warnings: tuple[str, ...] = field(default_factory=tuple)
    increment_kurtosis: float | None = None

    def _repr_html_(self) -> str:
        """Notebook view: a compact table and a small figure (:mod:`adavar.output.notebook`)."""
        from adavar.output.notebook import deviation_html

        return deviation_html(self)

    def plot(self, **kwargs: Any) -> Any:
        """The standard figure; returns its matplotlib axes (:mod:`adavar.output.notebook`:
        ``ax=`` draws on given axes; with :mod:`matplotlib.pyplot` imported the figure is
        pyplot's, so ``plt.savefig`` writes it)."""
        from adavar.output.notebook import deviation_plot

        return deviation_plot(self, **kwargs)

    @property
    def rate(self) -> float:
        """Sample rate in Hz."""
        return 1.0 / self.tau0

    @property
    def var(self) -> np.ndarray:
        """The variance, ``dev**2``."""
        return self.dev**2

    @property
    def avar(self) -> np.ndarray:
        """Alias of :attr:`var` (the variance that the noise model is fitted to)."""
        return self.dev**2


@dataclass(frozen=True, eq=False)
class DavarResult:
    """A dynamic Allan variance surface: one overlapping Allan variance per window.

    Attributes
    ----------
    time : ndarray, shape (T,)
        Time of each window's centre sample, seconds (``t0 + centre * tau0``).
    tau : ndarray, shape (M,)
        Averaging times in seconds, ``m * tau0``.
    avar : ndarray, shape (T, M)
        Overlapping Allan variance of each window at each tau; NaN where ``3 m > L``
        (a tau beyond a third of that window).
    avar_low, avar_high : ndarray, shape (T, M), or None
        Chi-square confidence bounds at ``confidence`` (None when computed with
        ``confidence=None`` or ``bounds=False``). Computed on first access from ``avar``
        and the per-length factors in ``bound_table`` (then kept), so a surface whose
        bounds are never read costs no memory for them.
    window : ndarray of int64, shape (T,)
        Window length (samples) at each centre.
    centre : ndarray of int64, shape (T,)
        Sample index of each centre in the input record (of the rate samples: for phase
        input, of its first differences).
    m : ndarray of int64, shape (M,)
        Averaging factors.
    alpha : ndarray of int64, shape (M,)
        Power-law noise exponent per tau used for the EDF (-1 entries when no confidence
        was computed); see :class:`DeviationResult`.
    tau0 : float
        Sample interval, seconds.
    data_type : str
        ``"rate"`` or ``"phase"``.
    edges : str
        ``"mirror"`` or ``"valid"``.
    step : int
        Spacing of the centres, samples.
    confidence : float
        Two-sided level of the bounds (NaN without bounds).
    n_samples : int
        Length of the input record.
    units : str or None
        Declared unit of the input samples.
    notes : tuple of str
        What the computation changed about the request.
    edf_table : ndarray, shape (K, M), or None
        Equivalent degrees of freedom per distinct window length (row ``window_class``).
    window_class : ndarray of int64, shape (T,), or None
        Row of ``edf_table`` for each centre.
    bound_table : ndarray, shape (2, K, M), or None
        ``avar_low / avar`` and ``avar_high / avar`` per distinct window length
        (``edf / chi2.ppf``; 0 where a tau is undefined).
    terms : ndarray of int64, shape (T, M), or None
        Terms kept in each cell when computed with ``davar(..., gaps="omit")`` on a record
        with missing samples (those touching none; 0 where the cell is NaN), else None
        (every term is kept: :attr:`n_terms`). With it, ``edf_table`` and ``bound_table``
        have one row per centre (``window_class`` is ``arange(T)``): each cell's EDF
        follows its own count.
    shift : ndarray of int64, shape (T,), or None
        Offset of each row's window from its centre (``davar(..., shift=)``; the window of
        centre ``p`` is centred at ``p + shift``), or None: every window centred.
    record_curve : DeviationResult or None
        The overlapping Allan deviation of the whole record at octave taus, for a record
        in memory (None out of core or lazily, where it would cost another read of the
        whole file): :func:`adavar.fit_noise` fits it to carry the sensor's roll-off into
        every window's fit (``reference="auto"``).
    """

    time: np.ndarray
    tau: np.ndarray
    avar: np.ndarray
    window: np.ndarray
    centre: np.ndarray
    m: np.ndarray
    alpha: np.ndarray
    tau0: float
    data_type: str
    edges: str
    step: int
    confidence: float
    n_samples: int
    units: str | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    edf_table: np.ndarray | None = None
    window_class: np.ndarray | None = None
    bound_table: np.ndarray | None = None
    terms: np.ndarray | None = None
    shift: np.ndarray | None = None
    record_curve: DeviationResult | None = None
    _cache: dict[str, np.ndarray] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    #: the statistic of every window (the noise-model fit checks it)
    stat = "oadev"

    def _per_cell(self, table: np.ndarray) -> np.ndarray:
        """A (K, M) per-length table spread to (T, M) (no gather for one length)."""
        if table.shape[0] == 1:
            return np.broadcast_to(table[0], self.avar.shape)
        assert self.window_class is not None
        return table[self.window_class]

    def _bound(self, which: int) -> np.ndarray | None:
        if self.bound_table is None or self.window_class is None:
            return None
        key = ("avar_low", "avar_high")[which]
        if key not in self._cache:
            self._cache[key] = self.avar * self._per_cell(self.bound_table[which])
        return self._cache[key]

    @property
    def avar_low(self) -> np.ndarray | None:
        """Lower confidence bound of :attr:`avar` (None without bounds)."""
        return self._bound(0)

    @property
    def avar_high(self) -> np.ndarray | None:
        """Upper confidence bound of :attr:`avar` (None without bounds)."""
        return self._bound(1)

    def _repr_html_(self) -> str:
        """Notebook view: a compact table and a small figure (:mod:`adavar.output.notebook`)."""
        from adavar.output.notebook import surface_html

        return surface_html(self)

    def plot(self, **kwargs: Any) -> Any:
        """The standard figure; returns its matplotlib axes (:mod:`adavar.output.notebook`:
        ``ax=`` draws on given axes; with :mod:`matplotlib.pyplot` imported the figure is
        pyplot's, so ``plt.savefig`` writes it)."""
        from adavar.output.notebook import surface_plot

        return surface_plot(self, **kwargs)

    @property
    def rate(self) -> float:
        """Sample rate in Hz."""
        return 1.0 / self.tau0

    @property
    def adev(self) -> np.ndarray:
        """The dynamic Allan deviation, ``sqrt(avar)``."""
        return np.sqrt(self.avar)

    @property
    def adev_low(self) -> np.ndarray | None:
        """Lower confidence bound of :attr:`adev` (None without bounds)."""
        return None if self.avar_low is None else np.sqrt(self.avar_low)

    @property
    def adev_high(self) -> np.ndarray | None:
        """Upper confidence bound of :attr:`adev` (None without bounds)."""
        return None if self.avar_high is None else np.sqrt(self.avar_high)

    @property
    def edf(self) -> np.ndarray | None:
        """Equivalent degrees of freedom of every cell, shape (T, M) (None without bounds)."""
        if self.edf_table is None or self.window_class is None:
            return None
        return self._per_cell(self.edf_table)

    @property
    def n_terms(self) -> np.ndarray:
        """Number of squared differences in each cell, ``L - 2m + 1`` (0 where undefined;
        with gaps, the kept ones: :attr:`terms`)."""
        if self.terms is not None:
            return self.terms
        n = self.window[:, None] - 2 * self.m[None, :] + 1
        return np.where(3 * self.m[None, :] <= self.window[:, None], n, 0)

    def to_xarray(self) -> Any:
        """The surface as an ``xarray.Dataset`` (dims ``time``, ``tau``); needs xarray."""
        try:
            import xarray as xr
        except ImportError:  # pragma: no cover - depends on the environment
            raise ImportError("to_xarray needs xarray: pip install xarray") from None
        data_vars: dict[str, Any] = {
            "avar": (("time", "tau"), self.avar),
            "window": ("time", self.window),
            "centre": ("time", self.centre),
            "m": ("tau", self.m),
            "alpha": ("tau", self.alpha),
        }
        if self.avar_low is not None and self.avar_high is not None:
            data_vars["avar_low"] = (("time", "tau"), self.avar_low)
            data_vars["avar_high"] = (("time", "tau"), self.avar_high)
        if self.shift is not None:  # one-sided windows (davar(shift=), adaptive ICI)
            data_vars["shift"] = ("time", self.shift)
        ds = xr.Dataset(data_vars, coords={"time": self.time, "tau": self.tau})
        if self.shift is not None:
            ds["shift"].attrs.update(
                units="samples", long_name="offset of the window's centre from the centre"
            )
        ds["time"].attrs.update(units="s", long_name="window centre time")
        ds["tau"].attrs.update(units="s", long_name="averaging time")
        unit2 = f"({self.units})^2" if self.units else "input unit squared"
        ds["avar"].attrs.update(units=unit2, long_name="overlapping Allan variance")
        ds.attrs.update(self.metadata())
        return ds

    def to_pandas(self) -> Any:
        """The surface as a long ``pandas.DataFrame``, one row per (time, tau) cell."""
        try:
            import pandas as pd
        except ImportError:  # pragma: no cover - depends on the environment
            raise ImportError("to_pandas needs pandas: pip install pandas") from None
        nt, nm = self.avar.shape
        cols: dict[str, Any] = {
            "time": np.repeat(self.time, nm),
            "tau": np.tile(self.tau, nt),
            "window": np.repeat(self.window, nm),
            "avar": self.avar.reshape(-1),
        }
        if self.avar_low is not None and self.avar_high is not None:
            cols["avar_low"] = self.avar_low.reshape(-1)
            cols["avar_high"] = self.avar_high.reshape(-1)
        frame = pd.DataFrame(cols)
        frame.attrs.update(self.metadata())
        return frame

    def metadata(self) -> dict[str, Any]:
        """Scalar description of the computation (for file attributes and JSON)."""
        return {
            "statistic": self.stat,
            "tau0": float(self.tau0),
            "data_type": self.data_type,
            "edges": self.edges,
            "step": int(self.step),
            "confidence": float(self.confidence),
            "n_samples": int(self.n_samples),
            "units": self.units or "",
            "window_convention": "samples p-(L-1)//2 .. p-(L-1)//2+L-1 around centre p",
            "notes": "; ".join(self.notes),
        }


@dataclass(frozen=True)
class NoiseTerm:
    """One fitted noise coefficient.

    Attributes
    ----------
    value : float or ndarray
        The coefficient, in the data's own units (see :class:`NoiseFit`); an array over the
        leading shape for a stack of curves.
    uncertainty : float or ndarray
        1-sigma uncertainty; where ``value`` is 0 (a term the fit left out or pinned), the
        one-sided 84.1 % ("1-sigma") upper bound of the value instead; NaN for a term that
        was not a candidate.
    upper : float or ndarray
        Where ``value`` is 0 in a full-covariance fit: the one-sided upper bound at
        :attr:`NoiseFit.bound_level` (95 % by default) from the profile of the fit's
        chi-square; NaN elsewhere.
    """

    value: Any
    uncertainty: Any
    upper: Any = float("nan")


@dataclass(frozen=True)
class MarkovTerm:
    """A first-order Gauss-Markov process found by the noise fit (a hump in the curve).

    Attributes
    ----------
    sigma : float
        Its stationary standard deviation, in the rate's unit.
    sigma_uncertainty : float
        1-sigma uncertainty of ``sigma`` (at the chosen correlation time).
    tau_c : float
        Correlation time (s).
    tau_c_range : tuple of float
        Correlation times whose best fit costs at most 1 more in chi-square (about a 68 %
        interval; the fitted tau range limits it).
    """

    sigma: float
    sigma_uncertainty: float
    tau_c: float
    tau_c_range: tuple[float, float]

    @property
    def variance(self) -> float:
        """``sigma^2``."""
        return self.sigma**2

    def avar(self, tau: Any) -> np.ndarray:
        """Its Allan variance at ``tau`` (s) (:func:`adavar.core.terms.markov_avar`)."""
        return markov_avar(tau, self.sigma**2, self.tau_c)


def coefficient_value(coefficient: Any, k: int) -> Any:
    """The value of noise term ``k`` (0..4: Q, N, B, K, R) from its coefficient ``C_k`` of
    the Allan variance model (:attr:`NoiseFit.coefficients`), as :class:`NoiseTerm` gives
    it."""
    with np.errstate(divide="ignore", invalid="ignore"):
        # a negative tau^-2 coefficient is the roll-off term (see `rolloff`): Q is 0
        return np.sqrt(np.maximum(coefficient, 0.0) / _K[k])


@dataclass(frozen=True, eq=False)
class NoiseFit:
    """The result of :func:`fit_noise` / :func:`fit_avar`.

    All per-curve arrays have the leading shape of the input (``()`` for a single curve,
    ``(T,)`` for T DAVAR windows, ...).

    Attributes
    ----------
    quantization : NoiseTerm
        Q, in ``unit*s`` (an angle for a gyro, a velocity for an accelerometer).
    angle_random_walk : NoiseTerm
        N, in ``unit*sqrt(s)`` (the velocity random walk for an accelerometer).
    bias_instability : NoiseTerm
        B, in ``unit``.
    rate_random_walk : NoiseTerm
        K, in ``unit/sqrt(s)``.
    rate_ramp : NoiseTerm
        R, in ``unit/s``.
    coefficients : ndarray, shape (..., 5)
        ``C_-2 .. C_2`` (0 for a term not in the model or pinned by the constraint).
    coefficient_uncertainty : ndarray, shape (..., 5)
        1-sigma of each ``C_n`` (scaled as described in the module docstring; from the
        unconstrained covariance for pinned terms; NaN for terms not in the model).
    tau : ndarray, shape (M,)
        The averaging times of the input.
    fitted_avar : ndarray, shape (..., M)
        The model at ``tau`` (also at points that were ignored).
    chi2 : ndarray or float
        Weighted residual sum of squares of the final pass.
    dof : ndarray or int or float
        ``n_points - len(terms)`` (clipped at 0); with ``spacing="octave"`` on a dense tau
        grid, the effective number of points (each tau counted by its octave share) minus
        ``len(terms)``.
    reduced_chi2 : ndarray or float
        ``chi2 / dof`` (NaN when ``dof == 0``): the goodness-of-fit figure, about 1 for
        independent taus when the model and the edf are right (below 1, about 0.6, on the
        positively correlated octave taus of an overlapping statistic).
    n_points : ndarray or int
        Valid points per curve.
    active : ndarray of bool, shape (..., 5)
        Terms with a strictly positive coefficient.
    terms : tuple of str
        The terms of the model.
    units : str or None
        Declared unit of the input rate samples.
    n_reweight : int
        Reweighting passes used.
    weighted : bool
        False when the fit used ``edf=None`` (relative weights only).
    time : ndarray or None
        For a DAVAR result: the window-centre times (the leading axis), else None.
    spacing : str
        The tau-spacing weighting used (see :func:`fit_avar`).
    method : str
        ``"gls"`` (full covariance, one curve), ``"wls"`` (diagonal weights) or
        ``"slopes"`` (slope-line read-offs), see :func:`fit_noise`.
    used : ndarray of bool, shape (..., M), or None
        The points that entered the fit.
    exclusions : tuple of str
        For one curve, per tau: why the point did not enter the fit ("" where it did):
        undefined, outside ``tau_range``, below ``2 / bandwidth``, a short-tau roll-off
        the model cannot describe, a thinned dense grid.
    residuals : ndarray, shape (..., M), or None
        Standardised residuals ``(avar - model) / sigma`` at every valid tau (excluded ones
        too, so a figure can show them), ``sigma`` the model's standard error of the
        estimate (full covariance for ``"gls"``, ``sqrt(2/edf)`` for ``"wls"``).
    dropped : tuple of str
        Terms removed by the term selection (value 0, uncertainty the 84.1 % upper bound,
        ``upper`` the one at :attr:`bound_level`).
    coefficient_covariance : ndarray, shape (5, 5), or None
        Covariance of ``C_-2 .. C_2`` (``"gls"``; NaN rows for terms not selected).
    slopes : SlopeReadoff or None
        The classical slope-line read-offs of the curve (one curve only), see
        :mod:`adavar.stats.slopes`.
    markov : MarkovTerm or None
        A first-order Gauss-Markov process the model selection added (``"gls"``), else None.
        It is part of :attr:`fitted_avar` and :meth:`model_avar`.
    coefficient_upper : ndarray, shape (5,), or None
        ``"gls"``: the one-sided upper bound of ``C_n`` at :attr:`bound_level` for each term
        whose coefficient is 0 (NaN for the others).
    bound_level : float
        The one-sided confidence level of ``coefficient_upper`` (and ``NoiseTerm.upper``).
    gof_chi2 : float
        ``"gls"``: the adequacy statistic, the decorrelated sum of squared normal scores
        (:attr:`residuals`) of the fitted points, a chi-square of :attr:`dof` degrees of
        freedom when the model is right (NaN for other methods).
    selection : str
        How the terms were chosen (``"aic"``, ``"bic"``, ``"significance"``, ``"none"``).
    better_model : str or None
        ``"gls"``: a model the fit was not allowed (a Gauss-Markov term with
        ``markov="none"``, or with ``select`` other than ``"aic"``/``"bic"``) that describes
        the curve far better; the fit is then not :attr:`adequate`. None otherwise.
    term_support : ndarray or None
        ``"gls"`` with ``select="aic"``/``"bic"``, shape (5,): for each term, the weight of
        the models that hold it among those the criterion judged (Akaike or Schwarz
        weights; Burnham and Anderson's relative importance): near 1 where the curve needs
        the term, near 0 where no model of any weight has it. A term in the model with
        support below :data:`SUPPORT_WARNING` gets a warning: the curve hardly tells the
        model from one without the term. None for other fits.
    uncertainty_rule : str
        ``"conditional"`` or ``"averaged"``: how the uncertainties treat the choice of the
        model (``fit_noise(uncertainty=...)``).
    reference_warning : str or None
        A stack of windows fitted with a whole-record reference (``reference=``) that does
        not describe its own curve: the line :attr:`warnings` gives (every window inherits
        the reference's roll-off term and shortest tau). None otherwise.

    Notes
    -----
    A term not in ``terms`` has value 0 and uncertainty NaN.
    """

    coefficients: np.ndarray
    coefficient_uncertainty: np.ndarray
    tau: np.ndarray
    chi2: Any
    dof: Any
    reduced_chi2: Any
    n_points: Any
    terms: tuple[str, ...]
    units: str | None
    n_reweight: int
    weighted: bool = True
    time: np.ndarray | None = None
    spacing: str = "octave"
    method: str = "wls"
    used: np.ndarray | None = None
    exclusions: tuple[str, ...] = ()
    residuals: np.ndarray | None = None
    dropped: tuple[str, ...] = ()
    coefficient_covariance: np.ndarray | None = None
    slopes: SlopeReadoff | None = None
    markov: MarkovTerm | None = None
    coefficient_upper: np.ndarray | None = None
    bound_level: float = FitSettings.bound_level
    gof_chi2: Any = float("nan")
    selection: str = "none"
    better_model: str | None = None
    term_support: np.ndarray | None = None
    uncertainty_rule: str = "conditional"
    reference_warning: str | None = None

    @property
    def rolloff(self) -> Any:
        """The negative ``tau^-2`` coefficient that models a filter's roll-off (else 0).

        In ``unit^2 s^2`` like ``C_-2``: the model's variance holds ``rolloff / tau^2``
        (see :mod:`adavar.fit.gls_fit`, ``rolloff="model"``).
        """
        c = np.minimum(self.coefficients[..., 0], 0.0)
        return c[()] if c.ndim == 0 else c

    @property
    def excluded(self) -> np.ndarray | None:
        """Valid points that the fit left out (tau range, bandwidth, roll-off), or None."""
        if self.used is None or self.residuals is None:
            return None
        return np.isfinite(self.residuals) & ~self.used

    @property
    def p_value(self) -> Any:
        """Probability of a misfit at least this large if the model is right (NaN: no dof).

        For the full-covariance fit the misfit is :attr:`gof_chi2` (normal scores, which see
        a model far above the data as well as one far below); else :attr:`chi2`.
        """
        # scipy.stats.chi2.sf(x, k) is chdtrc(k, x) for x >= 0 (and 1 below): the same
        # numbers, without importing scipy.stats (about a second)
        from scipy.special import chdtrc

        dof = np.asarray(self.dof, dtype=float)
        stat = self.gof_chi2 if self.method == "gls" and np.isfinite(self.gof_chi2) else self.chi2
        x = np.maximum(np.asarray(stat, dtype=float), 0.0)
        with np.errstate(invalid="ignore"):
            p = np.where(dof > 0, chdtrc(np.maximum(dof, 1), x), np.nan)
        return p[()] if p.ndim == 0 else p

    @property
    def adequate(self) -> Any:
        """True where the model describes the points it fitted (``p_value >= 1e-3``, and
        no :attr:`better_model`).

        Judged only for the full-covariance fit, whose chi-square has its nominal
        distribution; the diagonal fit's chi-square ignores the correlation of the taus, so
        there it is ``reduced_chi2 <= 3``.
        """
        if self.method == "gls":
            p = np.asarray(self.p_value, dtype=float)
            out = ~(p < ADEQUATE_P) & (self.better_model is None)
        else:
            out = ~(np.asarray(self.reduced_chi2, dtype=float) > 3.0)
        return out[()] if out.ndim == 0 else out

    @property
    def warnings(self) -> tuple[str, ...]:
        """One line per thing a user must know about this fit (one curve; for a stack of
        windows, only a :attr:`reference_warning`)."""
        if np.ndim(self.chi2) != 0:
            return () if self.reference_warning is None else (self.reference_warning,)
        out = []
        if self.better_model is not None:
            out.append(
                f"the model's terms do not describe the curve: {self.better_model} "
                "describes it far better (markov='auto' with select='aic' fits it)"
            )
        elif not bool(self.adequate):
            out.append(
                f"the noise model does not describe the data (reduced chi2 = "
                f"{float(self.reduced_chi2):.3g}, p = {float(self.p_value):.2g}): read the "
                "per-tau residuals, restrict tau_range, or give the sensor's bandwidth"
            )
        rolled = [j for j, r in enumerate(self.exclusions) if r.startswith("short-tau")]
        if rolled:
            top = self.tau[max(rolled)]
            out.append(
                f"{len(rolled)} taus up to {top:.3g} s excluded: the curve rolls off below "
                "the model there (sensor filter or correlated noise)"
            )
        if float(self.rolloff) < 0:
            out.append(
                f"a negative tau^-2 term ({float(self.rolloff):.3g}) models the roll-off of "
                "a sensor filter or correlated short-tau noise; Q reads 0 (rolloff='none' "
                "keeps Q >= 0)"
            )
        if self.dropped:
            out.append(
                "not supported by the data, left out: " + ", ".join(self.dropped)
                + f" (value 0; uncertainty: the 84 % upper bound, upper: the "
                f"{100 * self.bound_level:.0f} % one)"
            )  # fmt: skip
        if self.markov is not None:
            mk = self.markov
            out.append(
                f"a first-order Gauss-Markov process (sigma {mk.sigma:.3g}, correlation time "
                f"{mk.tau_c:.3g} s, {mk.tau_c_range[0]:.3g}-{mk.tau_c_range[1]:.3g} s) makes "
                f"a hump near {1.89 * mk.tau_c:.3g} s: it is in the model, not read as bias "
                "instability or rate random walk"
            )
        support = self.term_support
        if support is not None:
            for k in np.flatnonzero(np.asarray(self.coefficients) > 0):
                if support[k] < SUPPORT_WARNING:
                    name = TERM_NAMES[k]
                    out.append(
                        f"{name} is in the model, but models without it carry "
                        f"{100 * (1 - support[k]):.0f} % of the {self.selection.upper()} "
                        f"weight (term_support {support[k]:.2f}): the curve does not tell "
                        "whether it is there; "
                        + (
                            "its uncertainty includes that doubt"
                            if self.uncertainty_rule == "averaged"
                            else "uncertainty='averaged' includes that doubt in its uncertainty"
                        )
                    )
        from adavar.core.fit_checks import tradeoff_warnings

        out.extend(tradeoff_warnings(self))
        return tuple(out)

    def _term(self, k: int) -> NoiseTerm:
        c = self.coefficients[..., k]
        sig = self.coefficient_uncertainty[..., k]
        value = coefficient_value(c, k)
        with np.errstate(divide="ignore", invalid="ignore"):
            # sigma_value = sigma_C * dvalue/dC; pinned at 0: sqrt of the 84 % bound on C
            unc = np.where(c > 0, sig / (2.0 * np.sqrt(_K[k] * c)), np.sqrt(sig / _K[k]))
            upper = np.full(np.shape(c), np.nan)
            if self.coefficient_upper is not None:
                cu = self.coefficient_upper[..., k]
                upper = np.where(c > 0, np.nan, np.sqrt(cu / _K[k]))
        return NoiseTerm(value[()], unc[()], upper[()])

    @cached_property
    def quantization(self) -> NoiseTerm:
        """Q, in ``unit*s``."""
        return self._term(0)

    @cached_property
    def angle_random_walk(self) -> NoiseTerm:
        """N, in ``unit*sqrt(s)``."""
        return self._term(1)

    @cached_property
    def bias_instability(self) -> NoiseTerm:
        """B, in ``unit``."""
        return self._term(2)

    @cached_property
    def rate_random_walk(self) -> NoiseTerm:
        """K, in ``unit/sqrt(s)``."""
        return self._term(3)

    @cached_property
    def rate_ramp(self) -> NoiseTerm:
        """R, in ``unit/s``."""
        return self._term(4)

    @cached_property
    def fitted_avar(self) -> np.ndarray:
        """The model variance at :attr:`tau`, shape (..., M)."""
        return self.model_avar(self.tau)

    @property
    def fitted_dev(self) -> np.ndarray:
        """The model deviation at :attr:`tau`, ``sqrt(fitted_avar)`` (NaN where negative)."""
        return self.model_dev(self.tau)

    @property
    def active(self) -> np.ndarray:
        """Terms with a strictly positive coefficient, shape (..., 5) (order of TERM_NAMES)."""
        return self.coefficients > 0

    def model_avar(self, tau: Any) -> np.ndarray:
        """Evaluate the fitted variance ``sum C_n tau^n``.

        Parameters
        ----------
        tau : float or array_like
            Averaging times in seconds.

        Returns
        -------
        ndarray
            Shape ``leading_shape + np.shape(tau)``.
        """
        t = np.asarray(tau, dtype=float)
        basis = t.reshape(-1, 1) ** _POWERS  # (K, 5)
        out = self.coefficients @ basis.T  # (..., K)
        if self.markov is not None:
            out = out + self.markov.avar(t.reshape(-1))
        return out.reshape(self.coefficients.shape[:-1] + t.shape)

    def model_dev(self, tau: Any) -> np.ndarray:
        """Evaluate the fitted deviation ``sqrt(sum C_n tau^n)``.

        Parameters
        ----------
        tau : float or array_like
            Averaging times in seconds.

        Returns
        -------
        ndarray
            Shape ``leading_shape + np.shape(tau)``.
        """
        avar = self.model_avar(tau)
        # a negative roll-off term makes the model negative below its validity: NaN there
        return np.sqrt(np.where(avar >= 0, avar, np.nan))

    def term_dev(self, name: str, tau: Any) -> np.ndarray:
        """The deviation asymptote of one term, ``sqrt(C_n tau^n)``.

        Parameters
        ----------
        name : str
            One of :data:`TERM_NAMES`.
        tau : float or array_like
            Averaging times in seconds.

        Returns
        -------
        ndarray
            Shape ``leading_shape + np.shape(tau)``.
        """
        k = term_index(name)
        t = np.asarray(tau, dtype=float)
        c = np.maximum(self.coefficients[..., k], 0.0)
        return np.sqrt(np.multiply.outer(c, t ** _POWERS[k]))

    def _repr_html_(self) -> str:
        """Notebook view: a compact table and a small figure (:mod:`adavar.output.notebook`)."""
        from adavar.output.notebook import fit_html

        return fit_html(self)

    def plot(self, **kwargs: Any) -> Any:
        """The standard figure; returns its matplotlib axes (:mod:`adavar.output.notebook`)."""
        from adavar.output.notebook import fit_plot

        return fit_plot(self, **kwargs)

    def term(self, name: str) -> NoiseTerm:
        """The :class:`NoiseTerm` called ``name``."""
        term_index(name)
        return getattr(self, name)

    def to_units(
        self, unit: str | None = None, *, output_units: dict[str, str] | None = None
    ) -> ConvertedNoise:
        """Convert the coefficients to the units the inertial community reports.

        Parameters
        ----------
        unit : str, optional
            Unit of the *input* rate samples. Defaults to the fit's declared :attr:`units`;
            if given as well it must agree with them.
        output_units : dict, optional
            Term name -> reporting unit, overriding the conventional units of
            :data:`adavar.core.units.CONVENTIONAL_UNITS` (e.g. ``{"bias_instability": "m/s^2"}``).

        Returns
        -------
        ConvertedNoise
            Each term's value and uncertainty converted with the same factor, with its unit.

        Raises
        ------
        ValueError
            If no input unit is declared, the two declarations disagree, or a unit is unknown.
        """
        if unit is None:
            unit = self.units
        elif self.units is not None and unit != self.units:
            raise ValueError(
                f"the fit's data were declared in {self.units!r}, not {unit!r}; "
                "to_units() takes the *input* unit, choose reporting units with output_units="
            )
        if unit is None:
            raise ValueError(
                "declare the unit of the input rate samples: fit_noise(..., units='deg/s') "
                "or fit.to_units('deg/s')"
            )
        info = rate_unit_info(unit)
        targets = conventional_units(unit)
        for name, target in (output_units or {}).items():
            term_index(name)
            targets[name] = target
        converted = {}
        for name in TERM_NAMES:
            t = getattr(self, name)
            converted[name] = ConvertedTerm(
                convert_coefficient(t.value, name, unit, targets[name]),
                convert_coefficient(t.uncertainty, name, unit, targets[name]),
                targets[name],
                convert_coefficient(t.upper, name, unit, targets[name]),
            )
        return ConvertedNoise(**converted, input_unit=unit, sensor=info.sensor)

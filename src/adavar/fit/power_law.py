r"""The power-law clock model ``S_y(f) = sum h_alpha f^alpha`` fitted to a deviation curve.

Clock users describe an oscillator by the coefficients ``h_-2 .. h_2`` of the one-sided
PSD of its fractional frequency (IEEE Std 1139, NIST SP 1065 section 4): random walk FM
(``h_-2``), flicker FM (``h_-1``), white FM (``h_0``), flicker PM (``h_1``) and white PM
(``h_2``), plus a deterministic linear frequency drift ``D`` (``y(t) = D t``).
:func:`fit_power_law` estimates them, with uncertainties, from a
:class:`~adavar.core.results.DeviationResult` of ``oadev``/``adev``/``totdev`` (AVAR),
``mdev``/``tdev`` (MVAR) or ``hdev``/``ohdev`` (Hadamard variance). The same model fits
inertial data: in a rate unit ``u`` the coefficient ``h_alpha`` is in ``u^2 s^(1+alpha)``
and white FM is the angle (velocity) random walk, ``h_0 = 2 N^2``.

The variances of the model
--------------------------
The phase (integrated rate) ``x`` of each noise is described by its generalised
autocovariance ``g(t)`` per unit ``h`` (one-sided PSD ``S_x = S_y / (2 pi f)^2``):

=================  =====  ==========================================================
noise              alpha  ``4 pi^2 g(t)``
=================  =====  ==========================================================
white PM           2      ``sin(2 pi f_h t) / (2 pi t)`` (``f_h`` at ``t = 0``)
flicker PM         1      ``-(gamma + ln(2 pi f_h t) - Ci(2 pi f_h t))`` (0 at ``t = 0``)
white FM           0      ``-pi^2 t``
flicker FM         -1     ``2 pi^2 t^2 ln t``
random walk FM     -2     ``(2 pi^4 / 3) t^3``
=================  =====  ==========================================================

PM noise is band-limited at ``f_h`` (the measurement bandwidth, SP 1065), FM noise is not.
Every statistic here is ``E[(sum_l w_l x_(k+l))^2] / norm`` for phase weights ``w``
(``1, -2, 1`` at lags ``0, tau, 2 tau`` for AVAR; ``1, -3, 3, -1`` for the Hadamard
variance, ``norm = 6 tau^2``; for MVAR the second difference of ``m``-sample phase
averages, ``norm = 2 m^2 tau^2``), so its expectation is
``sum_k A(k) g(k tau0) / norm`` with ``A`` the autocorrelation of ``w``. That sum is exact
for every ``m``, and reproduces SP 1065's relations where they hold (large ``m``, ``f_h tau
>> 1``); for AVAR:

.. math::
   \sigma_y^2(\tau) = \frac{3 f_h h_2}{4\pi^2\tau^2}
   + \frac{[1.038 + 3\ln(2\pi f_h\tau)]\, h_1}{4\pi^2\tau^2} + \frac{h_0}{2\tau}
   + 2\ln 2\, h_{-1} + \frac{2\pi^2}{3} h_{-2}\tau + \frac{D^2\tau^2}{2}

(the flicker PM term carries ``-4 Ci(2 pi f_h tau) + Ci(4 pi f_h tau)`` besides, 7 % of it
at ``m = 1``); MVAR: ``3 h_2 / (8 pi^2 tau^3)``, ``3.374 h_1 / (4 pi^2 tau^2)``
(``12 ln 2 - 4.5 ln 3``), ``h_0 / (4 tau)``, ``0.9352 h_-1`` (``2 ln(3^(27/16) / 4)``),
``(11 pi^2 / 20) h_-2 tau`` and ``D^2 tau^2 / 2`` for large ``m``; the Hadamard variance
does not see the drift. White PM needs ``f_h`` in AVAR and HVAR (MVAR only through its
short taus), flicker PM everywhere: :func:`fit_power_law` takes it as ``f_h`` and, when
it is not given, uses the Nyquist frequency ``1 / (2 tau0)`` of the record (the bandwidth
of samples taken without an analog filter) and says so in ``notes`` and the summary.

The fit
-------
Generalised least squares on the variance with ``h >= 0``, the machinery of the IEEE
noise-model fit (:mod:`adavar.fit.gls_fit`): its whitening, bounded least-squares and Fisher
helpers, and the covariance of overlapping Allan variances across taus of
:mod:`adavar.stats.avar_covariance`. :func:`adavar.fit.gls_fit.fit_curve` itself cannot be called:
its design is the five ``tau^n`` columns of the IEEE model and its covariance that of AVAR,
while flicker PM (``tau^-2 ln tau``) and the MVAR/HVAR relations are outside both. Here

* the covariance of the estimates is the AVAR covariance of the model's random part
  (flicker PM counted as white PM of the same AVAR at the shortest fitted tau), in
  relative units, carried to the statistic's own variance and EDF: ``Cov_ij =
  rel_ij v_i v_j s_i s_j`` with ``v`` the model and ``s_i^2 = edf_oadev / edf`` at the
  identified noise type (exactly the covariance of the IEEE fit for ``oadev``, its
  correlation for the other statistics), the diagonal floored at a quarter of
  ``2 v^2 / edf`` like the IEEE fit;
* the passes, the term selection (``significance``) and the uncertainties (inverse Fisher
  matrix times ``max(1, chi2/dof)``; a 1-sigma upper bound for a term dropped or pinned
  at 0) follow :func:`adavar.fit.gls_fit.fit_curve`.

Measured (``benchmarks/bench_power_law.py``: 200 simulated clocks of 32768 samples per
case, every true term fitted): the mean relative error is within two Monte Carlo standard
errors for AVAR, MVAR, TDEV and TOTDEV (white and random walk FM within 1 %, flicker PM
+5 % +- 2 % and white PM -3 % +- 1.5 % where both are fitted on MDEV), and the pulls
``(h_hat - h) / sigma_h`` have a standard deviation of 0.85 .. 1.09. The Hadamard
statistics borrow the AVAR correlation across taus, which is stronger than theirs (0.5
against 0.2 .. 0.3 between octaves for white FM): their uncertainties are conservative,
pulls with a standard deviation of 0.55 .. 0.8, and non-overlapping ``hdev`` reads random
walk FM 4.6 % +- 1.2 % low. For one gyro curve the white/random walk FM fit equals the IEEE
fit of :func:`adavar.fit_noise` (``h_0 = 2 N^2``, ``h_-2 = K^2 / (2 pi^2)``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.core.results import NoiseTerm
from adavar.core.taus import tau_bounds
from adavar.core.terms import DRIFT, POWER_LAW_NAMES, POWER_LAW_TERMS
from adavar.core.units import rate_unit, sensor_kind, term_names
from adavar.fit import gls_core, gls_fit
from adavar.stats import avar_covariance
from adavar.stats import edf as edf_mod

__all__ = [
    "POWER_LAW_STATS",
    "PowerLawFit",
    "expected_variance",
    "fit_power_law",
    "power_law_design",
]

#: statistic -> the variance whose relations it follows
_FAMILY = {
    "adev": "avar",
    "oadev": "avar",
    "totdev": "avar",
    "mdev": "mvar",
    "tdev": "tvar",
    "hdev": "hvar",
    "ohdev": "hvar",
}
#: Statistics :func:`fit_power_law` fits.
POWER_LAW_STATS: tuple[str, ...] = tuple(_FAMILY)
#: Every column of the design: the five noises (alpha -2 .. 2), then the drift (D^2).
COLUMNS: tuple[str, ...] = (*POWER_LAW_NAMES, DRIFT)
ALPHAS = np.array([t.alpha for t in POWER_LAW_TERMS])
_PM = (3, 4)  # columns of flicker PM and white PM
_EULER = 0.5772156649015329
_TWO_PI = 2.0 * math.pi
_MVAR_EXACT_MAX = 1 << 16  # longer MVAR taus use the large-m relations (error ~ 1/m^2)
_CHUNK = 1 << 20  # lags per block of the MVAR sums
# large-m MVAR per unit h (times tau^-3, tau^-2, tau^-1, 1, tau), see the module docstring
_MVAR_LIMIT = (
    11.0 * math.pi**2 / 20.0,
    2.0 * (27.0 / 16.0 * math.log(3.0) - 2.0 * math.log(2.0)),
    0.25,
    (12.0 * math.log(2.0) - 4.5 * math.log(3.0)) / (4.0 * math.pi**2),
    3.0 / (8.0 * math.pi**2),
)


# --------------------------------------------------------------------------------------
# The variances of the model
# --------------------------------------------------------------------------------------


def _pm_kernels(t: np.ndarray, f_h: float) -> np.ndarray:
    """Phase (generalised) autocovariances of white and flicker PM per unit h, shape (2, n)."""
    from scipy.special import sici

    t = np.asarray(t, dtype=float)
    u = _TWO_PI * f_h * t
    pos = t > 0
    safe = np.where(pos, t, 1.0)
    white = np.where(pos, np.sin(u) / (_TWO_PI * safe), f_h)
    ci = sici(np.where(pos, u, 1.0))[1]
    flicker = np.where(pos, -(_EULER + np.log(np.where(pos, u, 1.0)) - ci), 0.0)
    return np.stack([flicker, white]) / (4.0 * math.pi**2)


def _fm_kernels(x: np.ndarray) -> np.ndarray:
    """RW, flicker and white FM kernels per unit h at lags ``x`` in units of tau, (3, n).

    Homogeneous in the lag: ``g(tau x) = tau^p g(x)`` up to a polynomial of degree 2 that
    the weights annihilate, so the sums stay O(1) (no cancellation at long taus).
    """
    x = np.asarray(x, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        flick = np.where(x > 0, x * x * np.log(np.where(x > 0, x, 1.0)), 0.0)
    return np.stack([(math.pi**2 / 6.0) * x**3, 0.5 * flick, -0.25 * x])


def _lag_weights(family: str, m: int, start: int = 0, stop: int | None = None):
    """Lags ``k >= 0`` (samples) and ``c_k A(k)``: ``E = sum_k c_k A(k) g(k tau0)``.

    ``A`` is the autocorrelation of the phase weights and ``c_k`` 1 at ``k = 0``, 2 beyond
    (the sum over negative lags folded in). For MVAR the lags ``start .. stop - 1``.
    """
    if family in ("avar", "hvar"):
        a = (6.0, -4.0, 1.0) if family == "avar" else (20.0, -15.0, 6.0, -1.0)
        k = np.arange(len(a), dtype=np.int64) * m
        return k, np.array(a) * np.where(k == 0, 1.0, 2.0)
    stop = 3 * m + 1 if stop is None else stop
    k = np.arange(start, stop, dtype=np.int64)

    def tri(j: np.ndarray) -> np.ndarray:
        return np.maximum(m - np.abs(j), 0).astype(float)

    a = 6.0 * tri(k) - 4.0 * (tri(k - m) + tri(k + m)) + tri(k - 2 * m) + tri(k + 2 * m)
    return k, a * np.where(k == 0, 1.0, 2.0)


def _design_one(family: str, m: int, tau0: float, f_h: float) -> np.ndarray:
    """The six columns (h_-2 .. h_2, D^2) of one tau."""
    tau = m * tau0
    out = np.zeros(6)
    base = "mvar" if family == "tvar" else family
    if base == "mvar" and m > _MVAR_EXACT_MAX:
        powers = np.array([1.0, 0.0, -1.0, -2.0, -3.0])
        out[:5] = np.array(_MVAR_LIMIT) * tau**powers
    else:
        stop = 3 * m + 1 if base == "mvar" else 1
        for start in range(0, stop, _CHUNK):
            k, wa = _lag_weights(base, m, start, min(stop, start + _CHUNK))
            out[:3] += (_fm_kernels(k / m) @ wa) * tau ** np.array([3.0, 2.0, 1.0])
            out[3:5] += _pm_kernels(k * tau0, f_h) @ wa
        norm = 2.0 * tau**2 * (m * m if base == "mvar" else 1.0)
        out[:5] /= 6.0 * tau**2 if base == "hvar" else norm
    out[5] = 0.0 if base == "hvar" else 0.5 * tau**2
    if family == "tvar":
        out *= tau**2 / 3.0
    return out


def _family(stat: str) -> str:
    fam = _FAMILY.get(str(stat).lower())
    if fam is None:
        raise AdavarInputError(
            f"the power-law relations are implemented for {', '.join(POWER_LAW_STATS)}, "
            f"not stat={stat!r}"
        )
    return fam


def power_law_design(stat: str, m: Any, tau0: float, f_h: float) -> np.ndarray:
    """Expected variance of the statistic per unit coefficient, at ``tau = m tau0``.

    Parameters
    ----------
    stat : str
        One of :data:`POWER_LAW_STATS` (``tdev``: the squared time deviation).
    m : array_like of int
        Averaging factors.
    tau0 : float
        Sample interval in seconds.
    f_h : float
        Measurement bandwidth of the PM noise, Hz.

    Returns
    -------
    ndarray, shape (len(m), 6)
        Columns ``h_-2, h_-1, h_0, h_1, h_2`` (random walk FM .. white PM) and ``D^2``
        (the squared linear frequency drift): ``E[var] = design @ (h_-2, ..., h_2, D^2)``.
    """
    fam = _family(stat)
    ms = np.atleast_1d(np.asarray(m)).astype(np.int64)
    if np.any(ms < 1):
        raise AdavarInputError("averaging factors must be >= 1")
    return np.array([_design_one(fam, int(k), float(tau0), float(f_h)) for k in ms])


def expected_variance(
    h: Any,
    tau: Any,
    *,
    stat: str = "oadev",
    tau0: float = 1.0,
    f_h: float | None = None,
    drift: float = 0.0,
) -> np.ndarray:
    """The variance (squared deviation) of a power-law clock model.

    Parameters
    ----------
    h : sequence of 5 float or dict
        ``h_-2 .. h_2`` (random walk FM, flicker FM, white FM, flicker PM, white PM), or a
        dict from the names of :data:`adavar.core.terms.POWER_LAW_NAMES` (missing ones are 0).
    tau : float or array_like
        Averaging times in seconds; MVAR/TVAR are evaluated at the nearest whole multiple
        of ``tau0``.
    stat : str
        One of :data:`POWER_LAW_STATS`.
    tau0 : float
        Sample interval in seconds.
    f_h : float, optional
        Bandwidth of the PM noise in Hz; default the Nyquist frequency ``1 / (2 tau0)``.
    drift : float
        Linear frequency drift ``D`` (rate units per second).

    Returns
    -------
    ndarray
        Shape of ``tau``.
    """
    coef = _as_h(h)
    t = np.asarray(tau, dtype=float)
    f = 0.5 / tau0 if f_h is None else float(f_h)
    flat = _design_taus(stat, t.ravel(), tau0, f)
    return (flat @ np.append(coef, float(drift) ** 2)).reshape(t.shape)


def _as_h(h: Any) -> np.ndarray:
    if isinstance(h, dict):
        bad = sorted(set(h) - set(POWER_LAW_NAMES))
        if bad:
            raise AdavarInputError(
                f"unknown power-law term {bad[0]!r}; valid: {', '.join(POWER_LAW_NAMES)}"
            )
        return np.array([float(h.get(n, 0.0)) for n in POWER_LAW_NAMES])
    coef = np.asarray(h, dtype=float)
    if coef.shape != (5,):
        raise AdavarInputError(f"h must hold 5 coefficients h_-2 .. h_2, got shape {coef.shape}")
    return coef


def _design_taus(stat: str, tau: np.ndarray, tau0: float, f_h: float) -> np.ndarray:
    """Design rows at arbitrary taus: AVAR and HVAR at the exact tau, MVAR at whole m."""
    fam = _family(stat)
    rows = np.empty((tau.size, 6))
    for j, t in enumerate(tau):
        m = t / tau0
        if fam in ("mvar", "tvar") or abs(m - round(m)) < 1e-9 * m:
            rows[j] = _design_one(fam, max(1, round(m)), tau0, f_h)
        else:  # a tau between samples: the same lags in seconds (AVAR, HVAR)
            rows[j] = _design_one(fam, 1, t, f_h)
    return rows


# --------------------------------------------------------------------------------------
# The result
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PowerLawFit:
    """The power-law model of a deviation curve (:func:`fit_power_law`).

    Attributes
    ----------
    h : ndarray, shape (5,)
        ``h_-2 .. h_2`` (random walk FM, flicker FM, white FM, flicker PM, white PM), in
        ``u^2 s^(1 + alpha)`` for rate data in ``u`` (``s^(1 + alpha)`` for a fractional
        frequency); 0 for a term dropped, pinned at 0 or not in the model.
    h_sigma : ndarray, shape (5,)
        1-sigma uncertainties; a 1-sigma upper bound where ``h`` is 0 (dropped or pinned),
        NaN for a term not in the model.
    drift, drift_sigma : float
        Linear frequency drift ``D`` (rate units per second) and its 1-sigma (0 and NaN
        when not fitted; an upper bound when dropped).
    names : tuple of str
        Keys of ``h``: :data:`adavar.core.terms.POWER_LAW_NAMES`.
    alpha : ndarray of int, shape (5,)
        Power of ``f`` of each term, -2 .. 2.
    labels : dict
        Term key -> words of the instrument (:func:`adavar.core.units.term_names`).
    terms : tuple of str
        The candidate terms of the model (``"frequency_drift"`` included if fitted).
    dropped : tuple of str
        Terms removed by the significance selection.
    covariance : ndarray, shape (6, 6)
        Covariance of ``h_-2 .. h_2, D^2`` (NaN rows/columns outside the final model).
    f_h : float
        Measurement bandwidth (Hz) of the PM relations.
    f_h_source : str
        ``"given"`` or ``"default: Nyquist 1/(2 tau0)"``.
    stat : str
        The statistic fitted.
    tau : ndarray, shape (M,)
        Its averaging times.
    var : ndarray, shape (M,)
        The measured variance (``dev**2``).
    fitted_var : ndarray, shape (M,)
        The model's variance at ``tau``.
    residuals : ndarray, shape (M,)
        ``(var - fitted_var) / sigma`` with the model's standard error (NaN where undefined).
    used : ndarray of bool, shape (M,)
        Points that entered the fit.
    exclusions : tuple of str
        Per tau, why it did not enter the fit ("" where it did).
    chi2, dof, n_points
        Generalised chi-square of the final fit, ``n_points - n_terms``, points fitted.
    tau0 : float
    data_type : str
    units : str or None
        Declared unit of the input samples.
    notes : tuple of str
        What the fit assumed (the default ``f_h``, ...).
    """

    h: np.ndarray
    h_sigma: np.ndarray
    drift: float
    drift_sigma: float
    covariance: np.ndarray
    f_h: float
    f_h_source: str
    stat: str
    tau: np.ndarray
    var: np.ndarray
    fitted_var: np.ndarray
    residuals: np.ndarray
    used: np.ndarray
    exclusions: tuple[str, ...]
    chi2: float
    dof: int
    n_points: int
    terms: tuple[str, ...]
    dropped: tuple[str, ...]
    tau0: float
    data_type: str
    units: str | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    names: tuple[str, ...] = POWER_LAW_NAMES

    @property
    def alpha(self) -> np.ndarray:
        """Power of ``f`` of each coefficient, ``-2 .. 2``."""
        return ALPHAS.copy()

    @property
    def labels(self) -> dict[str, str]:
        """Term key -> the words of the instrument (clock, gyro, accelerometer)."""
        return term_names(self.units, self.data_type, sensor=self._sensor)

    @property
    def _sensor(self) -> str | None:
        return "clock" if sensor_kind(self.units, self.data_type) == "generic" else None

    @property
    def reduced_chi2(self) -> float:
        """``chi2 / dof`` (NaN without degrees of freedom)."""
        return self.chi2 / self.dof if self.dof > 0 else math.nan

    @property
    def p_value(self) -> float:
        """Probability of a chi2 at least this large if the model is right."""
        # scipy.stats.chi2.sf(x, k) is chdtrc(k, x) for x >= 0 (and 1 below), without
        # importing scipy.stats
        from scipy.special import chdtrc

        if not self.dof > 0:
            return math.nan
        return float(chdtrc(self.dof, np.maximum(self.chi2, 0.0)))

    @property
    def fitted_dev(self) -> np.ndarray:
        """The model deviation at :attr:`tau`."""
        return np.sqrt(self.fitted_var)

    def __getitem__(self, name: str) -> NoiseTerm:
        """``fit["white_fm"]``: value and 1-sigma of one coefficient (or of the drift)."""
        if name == DRIFT:
            return NoiseTerm(self.drift, self.drift_sigma)
        if name not in self.names:
            raise KeyError(f"{name!r}; valid: {', '.join(COLUMNS)}")
        k = self.names.index(name)
        return NoiseTerm(float(self.h[k]), float(self.h_sigma[k]))

    def as_dict(self) -> dict[str, NoiseTerm]:
        """Every term (and the drift) -> :class:`~adavar.core.results.NoiseTerm`."""
        return {name: self[name] for name in COLUMNS}

    def _coef(self) -> np.ndarray:
        return np.append(self.h, self.drift**2)

    def model_var(self, tau: Any) -> np.ndarray:
        """The model's variance of :attr:`stat` at ``tau`` (seconds)."""
        t = np.asarray(tau, dtype=float)
        rows = _design_taus(self.stat, t.ravel(), self.tau0, self.f_h)
        return (rows @ self._coef()).reshape(t.shape)

    def model_dev(self, tau: Any) -> np.ndarray:
        """The model's deviation at ``tau``."""
        return np.sqrt(self.model_var(tau))

    def term_var(self, name: str, tau: Any) -> np.ndarray:
        """The variance of one term of the model at ``tau`` (its asymptote on a plot)."""
        if name not in COLUMNS:
            raise KeyError(f"{name!r}; valid: {', '.join(COLUMNS)}")
        t = np.asarray(tau, dtype=float)
        rows = _design_taus(self.stat, t.ravel(), self.tau0, self.f_h)
        k = COLUMNS.index(name)
        return (rows[:, k] * self._coef()[k]).reshape(t.shape)

    def term_dev(self, name: str, tau: Any) -> np.ndarray:
        """The deviation of one term of the model at ``tau``."""
        return np.sqrt(self.term_var(name, tau))

    def summary(self) -> str:
        """The fit as text: one line per coefficient, the bandwidth, the goodness of fit."""
        from adavar.core.units import format_pm

        labels = self.labels
        unit = rate_unit(self.units, self.data_type)
        pm = any(n in self.terms for n in ("white_pm", "flicker_pm"))
        band = f", f_h = {self.f_h:.6g} Hz ({self.f_h_source})" if pm else ""
        lines = [f"power-law fit of {self.stat} ({self.n_points} taus{band})"]
        for k, name in enumerate(self.names):
            if name not in self.terms:
                continue
            a = int(ALPHAS[k])
            u = _h_unit(unit, a)
            text = _format_h(self.h[k], self.h_sigma[k], format_pm) + (f" {u}" if u else "")
            if name in self.dropped:
                text += " (dropped: not significant)"
            lines.append(f"  h_{a:<2d} {labels[name]:<24s} {text}")
        if DRIFT in self.terms:
            du = f"{unit}/s" if unit else ("1/s" if unit == "" else "")
            text = _format_h(self.drift, self.drift_sigma, format_pm) + (f" {du}" if du else "")
            if DRIFT in self.dropped:
                text += " (dropped: not significant)"
            lines.append(f"  D    {labels[DRIFT]:<24s} {text}")
        red = self.reduced_chi2
        lines.append(f"  chi2/dof = {self.chi2:.3g}/{self.dof} = {red:.3g}, p = {self.p_value:.3g}")
        lines.extend(f"  note: {n}" for n in self.notes)
        return "\n".join(lines)

    def __repr__(self) -> str:
        parts = ", ".join(
            f"h_{int(a)}={v:.4g}±{s:.2g}"
            for a, v, s, n in zip(ALPHAS, self.h, self.h_sigma, self.names, strict=True)
            if n in self.terms
        )
        if DRIFT in self.terms:
            parts += f", D={self.drift:.4g}±{self.drift_sigma:.2g}"
        return f"PowerLawFit(stat={self.stat!r}, {parts}, f_h={self.f_h:.6g})"


def _format_h(value: float, sigma: float, format_pm: Any) -> str:
    if math.isfinite(sigma) and value == 0.0:
        return f"0 (1-sigma upper bound {sigma:.2g})"
    return format_pm(value, sigma)


def _h_unit(unit: str | None, alpha: int) -> str:
    """``u^2 s^(1+alpha)`` written out ("" for a fractional frequency: ``s^(1+alpha)``)."""
    if unit is None:
        return ""
    p = 1 + alpha
    sec = "" if p == 0 else ("s" if p == 1 else f"s^{p}")
    if unit == "":
        return sec  # h_-1 of a fractional frequency is dimensionless
    u2 = f"({unit})^2"
    return f"{u2} {sec}".strip()


# --------------------------------------------------------------------------------------
# The fit
# --------------------------------------------------------------------------------------


def _record(result: Any) -> tuple[np.ndarray, int, float, str, str]:
    """(m, n_points, tau0, stat, data_type) of a whole-record DeviationResult."""
    try:
        stat = str(result.stat).lower()
        m = np.asarray(result.m, dtype=np.int64)
        tau0 = float(result.tau0)
        n_samples = int(result.n_samples)
        dtype = str(result.data_type)
    except (AttributeError, TypeError, ValueError):
        raise AdavarInputError(
            "fit_power_law needs a DeviationResult (tau, dev, edf, m, tau0, n_samples, stat)"
        ) from None
    _family(stat)
    n_points = n_samples if dtype == "phase" else n_samples + 1
    if m.shape != np.shape(result.tau) or np.any(m < 1) or np.any(n_points - 2 * m < 1):
        raise AdavarInputError("the result's averaging factors do not fit its record length")
    return m, n_points, tau0, stat, dtype


def _check_terms(terms: Any, drift: bool) -> tuple[str, ...]:
    if isinstance(terms, str):
        terms = (terms,)
    try:
        terms = tuple(terms)
    except TypeError:
        raise AdavarInputError(f"terms must be a list of names ({', '.join(COLUMNS)})") from None
    bad = [t for t in terms if t not in COLUMNS]
    if bad:
        raise AdavarInputError(
            f"unknown power-law term {bad[0]!r}; valid names: {', '.join(COLUMNS)}"
        )
    if drift and DRIFT not in terms:
        terms = (*terms, DRIFT)
    if not terms:
        raise AdavarInputError(f"terms is empty; valid names: {', '.join(COLUMNS)}")
    return tuple(c for c in COLUMNS if c in terms)


class _Covariance:
    """The covariance of the curve's estimates for a model (see the module docstring)."""

    def __init__(self, tau, phi, m, n_points, tau0, stat, alpha, edf, f_h, excess=0.0):
        self.tau, self.phi, self.edf = tau, phi, edf
        self.basis = avar_covariance.covariance_basis(m, n_points, tau0)
        # heavy tails of the white FM noise, as the IEEE fit takes them (gls_core.Problem)
        self.tails = None
        if excess and stat == "oadev":
            self.tails = (excess / tau0**2) * avar_covariance.fourth_cumulant_basis(m, n_points)
        self.avar_design = power_law_design("oadev", m, tau0, f_h)
        if stat == "oadev":
            self.scale = np.ones(tau.size)
        else:
            ratio = [
                edf_mod.edf("oadev", int(np.clip(a, -2, 2)), int(k), n_points) / e
                for a, k, e in zip(alpha, m, edf, strict=True)
            ]
            self.scale = np.sqrt(np.asarray(ratio, dtype=float))

    def __call__(self, coef: np.ndarray, model: np.ndarray, idx: np.ndarray) -> np.ndarray:
        h = coef[:5]
        # the IEEE coefficients C_-2 .. C_1 of the same AVAR; PM folded into C_-2 at the
        # shortest tau (flicker PM's ln(tau) only shapes the correlation there)
        j0 = int(idx[0])
        pm = float(self.avar_design[j0, 3:5] @ h[3:5]) * self.tau[j0] ** 2
        c = np.array([pm, h[2] / 2.0, 2.0 * math.log(2.0) * h[1], 2.0 * math.pi**2 / 3.0 * h[0]])
        if not np.any(c > 0):
            c[1] = 1.0
        avar_random = c[0] / self.tau**2 + c[1] / self.tau + c[2] + c[3] * self.tau
        basis = self.basis[np.ix_(idx, idx)]
        rel = avar_covariance.covariance(basis, np.append(c, 0.0))
        rel /= np.outer(avar_random[idx], avar_random[idx])
        # the statistic's random part (the drift has no variance; the floor covers it)
        v = self.phi[idx, :5] @ h
        v = np.where(v > 0, v, avar_random[idx])
        cov = rel * np.outer(v * self.scale[idx], v * self.scale[idx])
        if self.tails is not None:
            cov += self.tails[np.ix_(idx, idx)] * max(h[2] / 2.0, 0.0) ** 2
        floor = gls_core.DIAG_FLOOR * 2.0 * model[idx] ** 2 / self.edf[idx]
        d = np.diag(cov)
        cov[np.diag_indices_from(cov)] = np.maximum(d, floor)
        return cov


def _fit_terms(var, phi, edf, cov_of, idx, cols, n_iter):
    """IRLS GLS-NNLS of the columns ``cols`` on the taus ``idx`` (as gls_fit's own fit)."""
    a = var[idx]
    sub = phi[np.ix_(idx, cols)]
    free = np.zeros(cols.size, dtype=bool)
    coef = np.zeros(6)
    ref = a.copy()
    for _ in range(3):  # diagonal weights, from the data, then from the model
        w = np.sqrt(edf[idx] / 2.0) / ref
        x = gls_core.bounded_lsq(sub * w[:, None], a * w, free)
        coef[:] = 0.0
        coef[cols] = x
        model = sub @ x
        ref = np.where(model > 0, model, a)
    chi2, aw, cov = math.nan, None, None
    for _ in range(n_iter + 1):
        model = phi @ coef
        scale = np.where(model[idx] > 0, model[idx], a)
        cov = cov_of(coef, model, idx)
        chol = gls_core.whiten(cov, scale)
        x, chi2, aw = gls_core.nnls_gls(a, sub, chol, scale, free)
        new = np.zeros(6)
        new[cols] = x
        if not np.any(new[:5] > 0):
            break
        coef = new
    return coef, chi2, aw, cov


def _check_f_h(f_h: Any, tau0: float, needs: bool) -> tuple[float, str, tuple[str, ...]]:
    nyquist = 0.5 / tau0
    if f_h is None:
        notes = ()
        if needs:
            notes = (
                f"f_h not given: the PM relations use the Nyquist frequency 1/(2 tau0) = "
                f"{nyquist:.6g} Hz (pass f_h= for a measurement bandwidth set by a filter)",
            )
        return nyquist, "default: Nyquist 1/(2 tau0)", notes
    try:
        value = float(f_h)
    except (TypeError, ValueError):
        value = math.nan
    if not (value > 0 and math.isfinite(value)):
        raise AdavarInputError(f"f_h must be a positive number of Hz, got {f_h!r}")
    notes = ()
    if value > nyquist * (1 + 1e-12):
        notes = (f"f_h = {value:.6g} Hz exceeds the Nyquist frequency {nyquist:.6g} Hz",)
    return value, "given", notes


def fit_power_law(
    result: Any,
    *,
    f_h: float | None = None,
    terms: Sequence[str] = POWER_LAW_NAMES,
    drift: bool = False,
    select: str = "significance",
    significance: float = gls_fit.SIGNIFICANCE,
    tau_range: tuple[float | None, float | None] | None = None,
    n_iter: int = 3,
) -> PowerLawFit:
    """Fit the power-law coefficients ``h_-2 .. h_2`` (and a drift) to a deviation curve.

    Parameters
    ----------
    result : DeviationResult
        A whole-record curve of one of :data:`POWER_LAW_STATS` computed with a confidence
        level (the fit weighs the taus by their EDF).
    f_h : float, optional
        Measurement bandwidth in Hz of the PM noise (white and flicker PM). Default: the
        Nyquist frequency ``1 / (2 tau0)``, reported in ``notes`` and the summary.
    terms : sequence of str
        Candidate terms from ``"random_walk_fm", "flicker_fm", "white_fm", "flicker_pm",
        "white_pm"`` and ``"frequency_drift"``.
    drift : bool
        Add ``"frequency_drift"`` (``D^2 tau^2 / 2`` in AVAR and MVAR; the Hadamard
        variance does not see it) to ``terms``.
    select : {"significance", "none"}
        ``"significance"`` (default): backward elimination of the terms whose
        ``h / sigma_h`` is below ``significance`` (listed in ``dropped``, value 0 and a
        1-sigma upper bound); ``"none"``: every candidate term (``h >= 0``).
    significance : float
        Threshold of the selection (default 2).
    tau_range : (float or None, float or None), optional
        Fit only the taus in ``[min, max]`` seconds.
    n_iter : int
        GLS passes after the first, each with the covariance of the previous model (0 .. 100).

    Returns
    -------
    PowerLawFit

    Raises
    ------
    AdavarInputError
        For another statistic, a result without EDF, unknown terms, a bad ``f_h``,
        ``select`` or ``tau_range``, or fewer usable taus than terms.
    """
    m, n_points, tau0, stat, dtype = _record(result)
    cand = _check_terms(terms, drift)
    if select not in ("significance", "none"):
        raise AdavarInputError(f"unknown select {select!r}: use 'significance' or 'none'")
    try:
        sig_level = float(significance)
    except (TypeError, ValueError):
        sig_level = math.nan
    if not (sig_level > 0 and math.isfinite(sig_level)):
        raise AdavarInputError(f"significance must be a positive number, got {significance!r}")
    if (
        isinstance(n_iter, bool)
        or not isinstance(n_iter, (int, np.integer))
        or not (0 <= n_iter <= 100)
    ):
        raise AdavarInputError(f"n_iter must be an integer in 0 .. 100, got {n_iter!r}")
    fam = _FAMILY[stat]
    if fam == "hvar" and DRIFT in cand:
        cand = tuple(c for c in cand if c != DRIFT)
        extra: tuple[str, ...] = (
            "the Hadamard variance does not see a frequency drift: not fitted",
        )
    else:
        extra = ()
    needs = any(c in cand for c in ("white_pm", "flicker_pm"))
    f_h_value, f_h_source, notes = _check_f_h(f_h, tau0, needs)
    notes = notes + extra
    if stat == "totdev":
        notes = (*notes, "totdev read with the AVAR relations (its flicker/RW FM bias ignored)")

    tau = np.asarray(result.tau, dtype=float)
    dev = np.asarray(result.dev, dtype=float)
    edf = getattr(result, "edf", None)
    edf = np.full(tau.size, np.nan) if edf is None else np.asarray(edf, dtype=float)
    if not np.isfinite(edf).any():
        raise AdavarInputError(
            "result has no EDF (computed with confidence=None?): compute the deviation with a "
            "confidence level"
        )
    # variances at scale 1 (an exact power of two): clock variances are near 1e-26
    good = np.isfinite(dev) & (dev > 0) & np.isfinite(edf) & (edf > 0)
    k2 = 2 * math.frexp(float(np.median(dev[good])))[1] if good.any() else 0
    var_s = np.ldexp(dev, -k2 // 2) ** 2 if k2 else dev**2
    reasons = ["" if g else "undefined (NaN or not positive)" for g in good]
    usable = good.copy()
    if tau_range is not None:
        lo, hi = tau_bounds(tau_range)
        for j, t in enumerate(tau):
            if usable[j] and not lo <= t <= hi:
                usable[j] = False
                reasons[j] = f"outside tau_range [{lo:g}, {hi:g}] s"
    if usable.sum() > gls_core.MAX_TAUS:  # as the IEEE fit: 4 taus per octave suffice
        thinned = gls_core.thin(tau, usable)
        for j in np.flatnonzero(usable & ~thinned):
            reasons[j] = "thinned: a denser tau grid than 4 per octave adds no information"
        usable = thinned
    cols_all = np.array([COLUMNS.index(c) for c in cand], dtype=np.int64)
    if usable.sum() < cols_all.size:
        raise AdavarInputError(
            f"{int(usable.sum())} usable taus for {cols_all.size} terms: give more taus "
            "(taus='octave' or denser), fewer terms, or a wider tau_range"
        )
    phi = power_law_design(stat, m, tau0, f_h_value)
    alpha = np.asarray(getattr(result, "alpha", np.zeros(tau.size)), dtype=np.int64)
    cov_of = _Covariance(
        tau,
        phi,
        m,
        n_points,
        tau0,
        stat,
        alpha,
        np.where(good, edf, 1.0),
        f_h_value,
        gls_core.white_excess(result),
    )
    idx = np.flatnonzero(usable)
    edf_g = np.where(good, edf, 1.0)

    cols = cols_all.copy()
    dropped: list[int] = []
    while True:
        coef, chi2, aw, cov = _fit_terms(var_s, phi, edf_g, cov_of, idx, cols, n_iter)
        dof = idx.size - cols.size
        factor = max(1.0, chi2 / dof) if dof > 0 else 1.0
        fisher = gls_core.inverse_fisher(aw) * factor
        sig = np.sqrt(np.maximum(np.diag(fisher), 0.0))
        z = np.where(sig > 0, coef[cols] / np.where(sig > 0, sig, 1.0), 0.0)
        if select != "significance" or cols.size <= 1:
            break
        worst = int(np.argmin(z))
        if z[worst] >= sig_level:
            break
        dropped.append(int(cols[worst]))
        cols = np.delete(cols, worst)

    model = phi @ coef
    unc = np.full(6, np.nan)
    covariance = np.full((6, 6), np.nan)
    covariance[np.ix_(cols, cols)] = fisher
    unc[cols] = sig
    scale = np.where(model[idx] > 0, model[idx], var_s[idx])
    for k in cols_all:  # a dropped or pinned term: 1-sigma upper bound with it free
        if k in cols and coef[k] > 0:
            continue
        trial = np.array(sorted(set(cols.tolist()) | {int(k)}), dtype=np.int64)
        _, _, aw_k = gls_core.nnls_gls(
            var_s[idx], phi[np.ix_(idx, trial)], gls_core.whiten(cov, scale), scale,
            np.zeros(trial.size, dtype=bool),
        )  # fmt: skip
        f_k = gls_core.inverse_fisher(aw_k) * factor
        pos = list(trial).index(int(k))
        unc[k] = math.sqrt(max(f_k[pos, pos], 0.0))
    full = cov_of(coef, model, np.flatnonzero(good)) if good.any() else np.zeros((0, 0))
    resid = np.full(tau.size, np.nan)
    resid[good] = (var_s[good] - model[good]) / np.sqrt(np.diag(full))

    # back to the data's scale: variances times 2**k2
    h = np.ldexp(coef[:5], k2)
    h_sigma = np.ldexp(unc[:5], k2)
    covariance = np.ldexp(covariance, 2 * k2)
    c_d, s_d = math.ldexp(coef[5], k2), math.ldexp(unc[5], k2)
    if DRIFT in cand:
        drift_value = math.sqrt(c_d) if c_d > 0 else 0.0
        drift_sigma = s_d / (2.0 * drift_value) if c_d > 0 else math.sqrt(s_d)
    else:
        drift_value, drift_sigma = 0.0, math.nan
    return PowerLawFit(
        h=h,
        h_sigma=h_sigma,
        drift=float(drift_value),
        drift_sigma=float(drift_sigma),
        covariance=covariance,
        f_h=f_h_value,
        f_h_source=f_h_source,
        stat=stat,
        tau=tau,
        var=dev**2,
        fitted_var=np.ldexp(model, k2),
        residuals=resid,
        used=np.isin(np.arange(tau.size), idx),
        exclusions=tuple(reasons),
        chi2=float(chi2),
        dof=int(max(idx.size - cols.size, 0)),
        n_points=int(idx.size),
        terms=cand,
        dropped=tuple(COLUMNS[k] for k in sorted(dropped)),
        tau0=tau0,
        data_type=dtype,
        units=getattr(result, "units", None),
        notes=notes,
    )

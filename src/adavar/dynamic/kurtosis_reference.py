"""The record's own kurtosis: what the controller's tests compare a window with.

The calibrated thresholds (:mod:`adavar.dynamic.thresholds`) are quantiles of the kurtosis (and of
S) of ``L`` *Gaussian* samples. Stationary noise that is not Gaussian breaks them: a
platykurtic gyro (kurtosis 2.7) sits below ``K1`` at long windows, Student-t or Laplace
noise above ``K2``, and the window stays short all along; a heavy tail's lone big samples
fire the upper tests as if each were a shock.

With ``kurtosis_reference="record"`` the controller compares each window with the record's
own stationary noise. The record is mapped, sample by sample, through the monotone
transform ``y = s Phi^-1(F((x - c) / s))`` that makes the stationary noise Gaussian
(``F`` its distribution, standardised; ``Phi`` the normal one), and the Gaussian thresholds
are applied to ``y``. For a stationary record this is exact whatever the distribution: the
kurtosis of ``L`` transformed samples then follows the Gaussian sampling law the
thresholds are calibrated on (the probability integral transform). A change of the noise
level is not undone by a fixed transform: a window straddling a step of the level holds two
scales and stays leptokurtic; a spike far beyond the record's tail stays far out.

``F`` is a member of one family spanning every tail weight, indexed by ``theta``:
generalised normal densities ``exp(-|x|^p)`` for ``theta < 0`` (``p = 2 / (1 + theta)``,
lighter than Gaussian: ``p -> infinity`` is uniform), the Gaussian at 0, Student-t of ``nu
= 4.5 / theta`` degrees of freedom for ``0 < theta <= 1`` and, beyond, the generalised t
``(1 + |x|^p / q)^-(q + 1/p)`` of tail index ``p q = 4.5`` with a more and more peaked body
(``p`` from 2 down to 0.6 at ``theta = 2``): Laplace-like bodies are given a power tail,
heavier than theirs (the safe side: a tail underestimated gives false events, one
overestimated only a less sensitive test). ``theta`` is fitted so that the median kurtosis
of blocks of the transformed record equals that of Gaussian blocks (Anscombe-Glynn, at the
record's effective size ``b / c4``): a median of blocks, so the changes, bursts and spikes
the controller is there to find (a few blocks) do not move it. The centre ``c`` is the
record's median and ``s`` the square root of its median block variance.

A record whose median block kurtosis is within three standard errors of the Gaussian one
keeps ``theta = 0`` (no transform: the Gaussian thresholds as they were). A record the
family cannot make Gaussian (coarsely quantised data: a few atoms, whose kurtosis no
monotone map moves to 3) keeps the residual ``offset`` of its median block kurtosis over
the Gaussian one, measured at the largest block size with at least 16 blocks (up to Lmin)
and added to ``K1`` and ``K2``. A transformed record's band is also widened by two standard
errors of the median its fit matched (:attr:`KurtosisReference.margin`): a fit on the first
8192 samples is rougher than one on 2**20, and the window's kurtosis at long windows has
a spread of a few hundredths.

:func:`record_reference` does the fit on the first samples of the record; the controller
(:func:`adavar.dynamic.controller.make_controller`) calls it on the same head as the correlation
behind the hourly thresholds, so the offline pass and :class:`adavar.OnlineAdaptive` (which
refines both as the record arrives) use the same transform.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from scipy import special
from scipy.optimize import brentq

from adavar._kernels._jit import jit
from adavar.core.errors import AdavarInputError
from adavar.dynamic.thresholds import gaussian_kurtosis_spread

__all__ = [
    "KURTOSIS_REFERENCES",
    "KurtosisReference",
    "check_kurtosis_reference",
    "record_reference",
]

#: ``kurtosis_reference=``: the record's own stationary noise, or Gaussian noise (before 0.2)
KURTOSIS_REFERENCES = ("record", "gaussian")
#: tail index ``p q`` of the heavy-tailed branch of the family (Student-t of 4.5 dof at
#: ``theta = 1``): below 4 the kurtosis has no finite mean
TAIL_INDEX = 4.5
#: the family's range: ``p = 2 / (1 + theta)`` reaches 8 (kurtosis 1.92) at the lower end,
#: the generalised t's ``p`` 0.6 (sharper than Laplace) at the upper
THETA_RANGE = (-0.75, 2.0)
#: standard errors within which a record's median block kurtosis counts as Gaussian
SNAP = 3.0
#: a fitted transform's band is widened by this many standard errors of its fit
WIDEN = 2.0
#: fewest blocks a fit needs (fewer: the record is too short, no transform)
MIN_BLOCKS = 16
#: shortest block, and the head is cut into at least this many blocks while Lmin allows
MIN_BLOCK = 64
BLOCKS = 32
#: most samples the fit transforms per trial (whole blocks spread over the head)
POOL = 1 << 20
#: the transform's table: uniform in ``log(1 + |r|)`` up to ``|r| = 1e8`` (0.0045 sd apart at
#: one sd), so a value's place in it is arithmetic, not a search
_STEP = math.log1p(1e8) / 8191
_GRID = np.expm1(np.arange(8192) * _STEP)
#: largest ``|y|``: ``Phi^-1`` of the smallest positive double's order
_Y_MAX = 37.5


def _shape(theta: float) -> tuple[float, float]:
    """``(p, q)`` of the family member ``theta`` (``q`` infinite: generalised normal)."""
    if theta < 0.0:
        return 2.0 / (1.0 + theta), math.inf
    if theta <= 1.0:
        return 2.0, (TAIL_INDEX / (2.0 * theta) if theta > 0.0 else math.inf)
    p = 2.0 - 1.4 * (theta - 1.0)
    return p, TAIL_INDEX / p


def _sd(p: float, q: float) -> float:
    """Standard deviation of the unscaled member ``(p, q)``."""
    if math.isinf(q):
        return math.exp(0.5 * (special.gammaln(3.0 / p) - special.gammaln(1.0 / p)))
    log_m2 = (
        (2.0 / p) * math.log(q) + special.betaln(3.0 / p, q - 2.0 / p) - special.betaln(1.0 / p, q)
    )
    return math.exp(0.5 * log_m2)


@lru_cache(maxsize=64)
def _table(theta: float) -> np.ndarray:
    """``Phi^-1`` of the member's CDF at the grid points (standardised, ``r >= 0``).

    Computed from the survival function ``P(|X| > r)``, so the tail keeps its digits.
    """
    p, q = _shape(theta)
    u = _GRID * _sd(p, q)
    with np.errstate(over="ignore", under="ignore"):
        if math.isinf(q):
            tail = special.gammaincc(1.0 / p, u**p)
        else:
            tail = special.betainc(q, 1.0 / p, 1.0 / (1.0 + u**p / q))
    y = -special.ndtri(np.maximum(tail, 1e-300) / 2.0)
    y[0] = 0.0
    table = np.maximum.accumulate(np.minimum(y, _Y_MAX))  # monotone after rounding
    table.flags.writeable = False
    return table


@jit
def _map_value(v, centre, scale, table, step):  # pragma: no cover - compiled
    """``s g((v - c) / s)``: the table interpolated linearly in ``log(1 + |r|)``."""
    r = (v - centre) / scale
    u = min(math.log1p(abs(r)) / step, table.size - 1.0)
    i = min(int(u), table.size - 2)
    y = table[i] + (u - i) * (table[i + 1] - table[i])
    return math.copysign(y, r) * scale


@jit
def _map_into(x, centre, scale, table, step, out):  # pragma: no cover - compiled
    for k in range(x.size):
        out[k] = _map_value(x[k], centre, scale, table, step)


@jit
def _mapped_block_kurtosis(x, centre, scale, table, step, block, out):  # pragma: no cover
    """Kurtosis of consecutive blocks of the mapped ``x`` (NaN for a constant block); with
    ``table`` empty, of ``x`` itself. Two passes a block, nothing stored."""
    buf = np.empty(block)
    for b in range(out.size):
        total = 0.0
        for k in range(block):
            v = x[b * block + k]
            if table.size:
                v = _map_value(v, centre, scale, table, step)
            buf[k] = v
            total += v
        mean = total / block
        m2 = 0.0
        m4 = 0.0
        for k in range(block):
            d = buf[k] - mean
            d2 = d * d
            m2 += d2
            m4 += d2 * d2
        out[b] = block * m4 / (m2 * m2) if m2 > 0.0 else np.nan


def _mapped(x: np.ndarray, centre: float, scale: float, theta: float) -> np.ndarray:
    out = np.empty(x.size)
    _map_into(x, centre, scale, _table(theta), _STEP, out)
    return out


def _block_kurtosis(
    x: np.ndarray, block: int, mapping: tuple[float, float, float] | None = None
) -> np.ndarray:
    """Kurtosis ``m4 / m2^2`` of consecutive blocks of ``x`` (constant blocks left out),
    mapped by ``(centre, scale, theta)`` first if given."""
    out = np.empty(x.size // block)
    if mapping is None:
        _mapped_block_kurtosis(x, 0.0, 1.0, np.empty(0), _STEP, block, out)
    else:
        centre, scale, theta = mapping
        _mapped_block_kurtosis(x, centre, scale, _table(theta), _STEP, block, out)
    return out[np.isfinite(out)]


@dataclass(frozen=True)
class KurtosisReference:
    """The transform that makes a record's stationary noise Gaussian (module notes).

    Attributes
    ----------
    theta : float
        The family member (0: Gaussian, no transform).
    centre, scale : float
        ``c`` and ``s`` of the transform, in the units of the samples it was fitted on.
    offset : float
        Added to ``K1`` and ``K2``: the median block kurtosis the transform leaves above
        the Gaussian one (0 unless ``theta`` is at an end of the family's range).
    block : int
        Block length of the fit (samples).
    blocks : int
        Blocks it used.
    kurtosis : float
        The record's median block kurtosis, untransformed.
    gaussian : float
        That of Gaussian blocks of the record's correlation.
    uncertainty : float
        Standard error of the transformed record's median block kurtosis, which the fit
        matches with the Gaussian one: ``K1`` and ``K2`` move out by :data:`WIDEN` of it
        (:attr:`margin`) when the record is transformed, so that a fit on a short head
        (the first stages of a record) does not raise the rate of false events.
    """

    theta: float
    centre: float
    scale: float
    offset: float
    block: int
    blocks: int
    kurtosis: float
    gaussian: float
    uncertainty: float = 0.0

    @property
    def margin(self) -> float:
        """How far ``K1`` and ``K2`` move out (0 for a record tested as it is)."""
        return 0.0 if self.identity and self.offset == 0.0 else WIDEN * self.uncertainty

    @property
    def identity(self) -> bool:
        """True when the record is tested as it is (a Gaussian reference)."""
        return self.theta == 0.0

    def apply(self, x: np.ndarray) -> np.ndarray:
        """The samples mapped (a new array; ``x`` itself when the transform is the identity)."""
        if self.identity:
            return x
        return _mapped(np.asarray(x, dtype=np.float64), self.centre, self.scale, self.theta)

    @classmethod
    def from_dict(cls, fit: dict[str, Any]) -> KurtosisReference:
        """From :meth:`as_dict` (``parameters["kurtosis_reference_fit"]`` of a run)."""
        try:
            values = {name: fit[name] for name in cls.__dataclass_fields__ if name != "uncertainty"}
            values["uncertainty"] = fit.get("uncertainty", 0.0)
            ref = cls(**{name: (int if name in ("block", "blocks") else float)(v)
                         for name, v in values.items()})  # fmt: skip
        except (KeyError, TypeError, ValueError):
            raise AdavarInputError(
                "kurtosis_reference given as a fit needs theta, centre, scale, offset, block, "
                "blocks, kurtosis and gaussian (parameters['kurtosis_reference_fit'] of a run)"
            ) from None
        lo, hi = THETA_RANGE
        if not (lo <= ref.theta <= hi and ref.scale > 0 and math.isfinite(ref.centre)
                and math.isfinite(ref.offset)):  # fmt: skip
            raise AdavarInputError(f"kurtosis_reference fit out of range: {fit!r}")
        return ref

    def as_dict(self) -> dict[str, Any]:
        """For ``parameters["kurtosis_reference_fit"]``."""
        return {"theta": self.theta, "centre": self.centre, "scale": self.scale,
                "offset": self.offset, "block": self.block, "blocks": self.blocks,
                "kurtosis": self.kurtosis, "gaussian": self.gaussian,
                "uncertainty": self.uncertainty, "margin": self.margin}  # fmt: skip


def check_kurtosis_reference(value: Any) -> str | KurtosisReference:
    """One of :data:`KURTOSIS_REFERENCES`, or a fit given (a :class:`KurtosisReference` or
    its :meth:`~KurtosisReference.as_dict`); else an AdavarInputError."""
    if isinstance(value, KurtosisReference):
        return value
    if isinstance(value, dict):
        return KurtosisReference.from_dict(value)
    if value not in KURTOSIS_REFERENCES:
        raise AdavarInputError(
            f"unknown kurtosis_reference {value!r}: use 'record' (the record's own stationary "
            "noise), 'gaussian' (Gaussian noise, as before 0.2) or a fit of a previous run "
            "(parameters['kurtosis_reference_fit'])"
        )
    return str(value)


def record_reference(
    head: np.ndarray, *, lmin: int, dependence: tuple[float, float] = (1.0, 1.0)
) -> KurtosisReference:
    """Fit the transform of :class:`KurtosisReference` to the first samples of a record.

    Parameters
    ----------
    head : ndarray
        The first samples of the record (any number; at least ``16 * 64`` for a fit).
    lmin : int
        The controller's shortest window: the blocks are at most this long (at least 64
        samples, and the head is cut into at least 32 of them while that allows).
    dependence : (float, float)
        The record's short-range correlation ``(c2, c4)``
        (:func:`adavar.dynamic.thresholds.noise_dependence`): Gaussian blocks of ``b`` correlated
        samples have the kurtosis spread of ``b / c4`` independent ones.

    Returns
    -------
    KurtosisReference
        ``theta = 0`` (no transform) for a record whose blocks look Gaussian, or one too
        short for a fit.
    """
    x = np.asarray(head, dtype=np.float64)
    block = int(min(max(MIN_BLOCK, x.size // BLOCKS), max(MIN_BLOCK, int(lmin))))
    c4 = max(1.0, float(dependence[1]))
    centre, median_sd = 0.0, gaussian_kurtosis_spread(block / c4)
    if x.size // block < MIN_BLOCKS:
        return KurtosisReference(0.0, 0.0, 1.0, 0.0, block, x.size // block, math.nan,
                                 median_sd[0])  # fmt: skip
    target, spread = median_sd
    kurt = _block_kurtosis(x, block)
    if kurt.size < MIN_BLOCKS:  # a record of constant runs: nothing to fit
        return KurtosisReference(0.0, 0.0, 1.0, 0.0, block, int(kurt.size), math.nan, target)
    raw = float(np.median(kurt))
    # the median of n values has the spread of sqrt(pi / 2) times their mean's
    error = math.sqrt(math.pi / 2.0) * spread / math.sqrt(kurt.size)
    if abs(raw - target) <= SNAP * error:
        return KurtosisReference(0.0, 0.0, 1.0, 0.0, block, int(kurt.size), raw, target)
    centre = float(np.median(x))
    rows = x[: x.size // block * block].reshape(-1, block)
    scale = math.sqrt(float(np.median(rows.var(axis=1))))
    if not scale > centre_noise(centre):  # most blocks constant (to rounding): no transform
        return KurtosisReference(0.0, 0.0, 1.0, 0.0, block, int(kurt.size), raw, target)
    if rows.shape[0] * block > POOL:  # whole blocks, spread over the head
        rows = rows[np.linspace(0, rows.shape[0] - 1, max(MIN_BLOCKS, POOL // block)).astype(int)]
    pool = rows.ravel()

    def excess(theta: float) -> float:
        return float(np.median(_block_kurtosis(pool, block, (centre, scale, theta)))) - target

    # the transform spreads the tails for theta < 0 and gathers them for theta > 0: the
    # transformed blocks' kurtosis falls as theta grows
    lo, hi = THETA_RANGE
    f_lo, f_hi = excess(lo), excess(hi)
    if f_lo <= 0.0 or f_hi >= 0.0:
        # lighter than the lightest member, heavier than the heaviest, or atoms no monotone
        # map spreads (coarse quantisation): the nearest member, and the band moves
        theta = lo if f_lo <= 0.0 else hi
        offset, error = _residual(x, centre, scale, theta, lmin, c4)
    else:
        theta, offset = float(brentq(excess, lo, hi, xtol=2e-3)), 0.0
    return KurtosisReference(round(theta, 6), centre, scale, float(offset), block,
                             int(kurt.size), raw, target, float(error))  # fmt: skip


def centre_noise(centre: float) -> float:
    """The spread rounding alone gives samples near ``centre`` (a few ulps of it)."""
    return 4.0 * math.ulp(abs(centre)) if math.isfinite(centre) else 0.0


def _residual(
    x: np.ndarray, centre: float, scale: float, theta: float, lmin: int, c4: float
) -> tuple[float, float]:
    """Median block kurtosis of the transformed head over the Gaussian one, at the longest
    block (up to Lmin) of which the head holds at least :data:`MIN_BLOCKS` (the residual
    centre of a record the family cannot make Gaussian), and its standard error."""
    block = max(MIN_BLOCK, min(int(lmin), x.size // MIN_BLOCKS))
    kurt = _block_kurtosis(x, block, (centre, scale, theta))
    if kurt.size == 0:
        return 0.0, 0.0
    median, spread = gaussian_kurtosis_spread(block / c4)
    return float(np.median(kurt)) - median, math.sqrt(math.pi / 2.0 / kurt.size) * spread

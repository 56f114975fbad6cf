"""The five IEEE Std 952 noise terms: one table of their names, letters, labels and powers.

=====================  ======  =====================  =========  =====================
name                   letter  label                  power n    avar = k value^2 tau^n
=====================  ======  =====================  =========  =====================
quantization           Q       quantization           -2         k = 3
angle_random_walk      N       angle random walk      -1         k = 1
bias_instability       B       bias instability       0          k = 2 ln 2 / pi
rate_random_walk       K       rate random walk       1          k = 1/3
rate_ramp              R       rate ramp              2          k = 1/2
=====================  ======  =====================  =========  =====================

(docs/method.md sections 1 and 4.) The coefficient of a term is in ``unit * s**unit_power``
of the rate's unit: Q ``unit*s``, N ``unit*sqrt(s)``, B ``unit``, K ``unit/sqrt(s)``,
R ``unit/s``. Every module that names, orders or labels the terms takes them from here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "ALIASES",
    "AVAR_FACTORS",
    "DRIFT",
    "LETTERS",
    "POWERS",
    "POWER_LAW_NAMES",
    "POWER_LAW_TERMS",
    "SENSOR_KINDS",
    "TERMS",
    "TERM_LABELS",
    "TERM_NAMES",
    "PowerLawTerm",
    "Term",
    "markov_avar",
    "term_index",
]


@dataclass(frozen=True)
class Term:
    """One noise term of the IEEE model.

    Attributes
    ----------
    name : str
        The long name used as an attribute (``fit.angle_random_walk``).
    letter : str
        IEEE Std 952 letter.
    label : str
        Words for tables and figures.
    power : int
        Power of tau in the Allan variance.
    factor : float
        ``k`` in ``avar = k value**2 tau**power``.
    unit_power : float
        The coefficient's unit is the rate's unit times ``s**unit_power``.
    short : str
        Short name, used for file names (``arw.png``).
    """

    name: str
    letter: str
    label: str
    power: int
    factor: float
    unit_power: float
    short: str


#: The five terms in the order of the powers of tau, -2 .. 2.
TERMS: tuple[Term, ...] = (
    Term("quantization", "Q", "quantization", -2, 3.0, 1.0, "q"),
    Term("angle_random_walk", "N", "angle random walk", -1, 1.0, 0.5, "arw"),
    Term("bias_instability", "B", "bias instability", 0, 2.0 * math.log(2.0) / math.pi, 0.0, "bi"),
    Term("rate_random_walk", "K", "rate random walk", 1, 1.0 / 3.0, -0.5, "rrw"),
    Term("rate_ramp", "R", "rate ramp", 2, 0.5, -1.0, "rr"),
)
#: Their names, in that order.
TERM_NAMES: tuple[str, ...] = tuple(t.name for t in TERMS)
#: Powers of tau, ``-2 .. 2``.
POWERS = np.array([t.power for t in TERMS])
#: ``k`` of each term: ``avar = k value**2 tau**n``.
AVAR_FACTORS = np.array([t.factor for t in TERMS])
#: Name -> IEEE letter.
LETTERS: dict[str, str] = {t.name: t.letter for t in TERMS}
#: Lower-case spellings users type (``--terms N,K``, ``arw``, ``rrw``, ...) -> name.
ALIASES: dict[str, str] = {
    **{t.letter.lower(): t.name for t in TERMS},
    **{t.short: t.name for t in TERMS},
    "vrw": "angle_random_walk",
    "bi": "bias_instability",
}


def term_index(name: str) -> int:
    """Position of the term ``name`` in :data:`TERM_NAMES` (ValueError for another name)."""
    try:
        return TERM_NAMES.index(name)
    except ValueError:
        raise ValueError(
            f"unknown noise term {name!r}; valid names: {', '.join(TERM_NAMES)}"
        ) from None


def markov_avar(tau: Any, variance: Any, tau_c: float) -> np.ndarray:
    """Allan variance of a first-order Gauss-Markov rate process (IEEE Std 952 Annex C).

    With stationary variance ``sigma^2 = variance`` and correlation time ``T = tau_c``:
    ``(2 sigma^2 T / tau) (1 - (T / 2 tau)(3 - 4 e^(-tau/T) + e^(-2 tau/T)))``, which rises
    like a rate random walk of ``K^2 = 2 sigma^2 / T`` well below ``T``, peaks near
    ``1.9 T`` at about ``0.44 sigma^2`` and falls like white noise of ``N^2 = 2 sigma^2 T``
    beyond.

    Parameters
    ----------
    tau : float or array_like
        Averaging times (s).
    variance : float or array_like
        ``sigma^2`` (rate unit squared), broadcast against ``tau``.
    tau_c : float
        Correlation time (s).

    Returns
    -------
    ndarray
    """
    tau = np.asarray(tau, dtype=float)
    u = tau / tau_c
    with np.errstate(divide="ignore", invalid="ignore"):
        direct = 1.0 - (3.0 - 4.0 * np.exp(-u) + np.exp(-2.0 * u)) / (2.0 * u)
    # the direct form cancels for u << 1: its series there (u^2/3 - u^3/4 + 7u^4/60 - ...)
    series = u * u * (1.0 / 3.0 - u * (0.25 - u * (7.0 / 60.0 - u / 24.0)))
    bracket = np.where(u < 1e-3, series, direct)
    return 2.0 * np.asarray(variance, dtype=float) * tau_c * bracket / tau


# --------------------------------------------------------------------------------------
# Words per kind of instrument, and the power-law (clock) model
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PowerLawTerm:
    """One term of the power-law model ``S_y(f) = sum h_alpha f^alpha`` (IEEE Std 1139).

    Attributes
    ----------
    name : str
        Key of the term (``fit.h["white_fm"]``).
    alpha : int
        Power of ``f`` in the fractional-frequency (rate) PSD.
    label : str
        Clock words (``"white FM"``).
    ieee : str or None
        The IEEE Std 952 term with the same Allan-variance slope (None for flicker PM, whose
        ``tau^-2 ln(tau)`` has no IEEE counterpart).
    """

    name: str
    alpha: int
    label: str
    ieee: str | None


#: The five noises of IEEE Std 1139 / NIST SP 1065, in the order of alpha, -2 .. 2.
POWER_LAW_TERMS: tuple[PowerLawTerm, ...] = (
    PowerLawTerm("random_walk_fm", -2, "random walk FM", "rate_random_walk"),
    PowerLawTerm("flicker_fm", -1, "flicker FM", "bias_instability"),
    PowerLawTerm("white_fm", 0, "white FM", "angle_random_walk"),
    PowerLawTerm("flicker_pm", 1, "flicker PM", None),
    PowerLawTerm("white_pm", 2, "white PM", "quantization"),
)
#: Their names, in that order.
POWER_LAW_NAMES: tuple[str, ...] = tuple(t.name for t in POWER_LAW_TERMS)
#: The deterministic linear frequency drift (the clock's counterpart of the rate ramp).
DRIFT = "frequency_drift"

#: Kinds of instrument whose words name the terms (see :func:`adavar.core.units.term_names`).
SENSOR_KINDS = ("gyro", "accelerometer", "clock", "generic")

_INERTIAL_PM = {"white_pm": "white angle noise", "flicker_pm": "flicker angle noise"}
_ACCEL_PM = {"white_pm": "white velocity noise", "flicker_pm": "flicker velocity noise"}

#: Kind -> term key -> label. Keys: the IEEE terms (:data:`TERM_NAMES`), the power-law
#: terms (:data:`POWER_LAW_NAMES`) and :data:`DRIFT`; the two sets name the same slopes
#: (white PM ~ quantization, white FM ~ angle random walk, ...), so either fit is labelled
#: in the words of its instrument.
TERM_LABELS: dict[str, dict[str, str]] = {
    "gyro": {
        **{t.name: t.label for t in TERMS},
        **_INERTIAL_PM,
        "white_fm": "angle random walk",
        "flicker_fm": "bias instability",
        "random_walk_fm": "rate random walk",
        DRIFT: "rate ramp",
    },
    "accelerometer": {
        "quantization": "quantization",
        "angle_random_walk": "velocity random walk",
        "bias_instability": "bias instability",
        "rate_random_walk": "acceleration random walk",
        "rate_ramp": "acceleration ramp",
        **_ACCEL_PM,
        "white_fm": "velocity random walk",
        "flicker_fm": "bias instability",
        "random_walk_fm": "acceleration random walk",
        DRIFT: "acceleration ramp",
    },
    "clock": {
        "quantization": "white PM",
        "angle_random_walk": "white FM",
        "bias_instability": "flicker FM",
        "rate_random_walk": "random walk FM",
        "rate_ramp": "frequency drift",
        **{t.name: t.label for t in POWER_LAW_TERMS},
        DRIFT: "frequency drift",
    },
    "generic": {
        **{t.name: t.label for t in TERMS},
        **{t.name: t.label for t in POWER_LAW_TERMS},
        DRIFT: "drift",
    },
}

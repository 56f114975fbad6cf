"""Result containers shared by the statistics and the fits."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["DeviationResult"]


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

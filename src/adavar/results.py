"""Result containers shared by the statistics, the DAVAR engine and the fits."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["DavarResult", "DeviationResult"]


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
        ``confidence=None``). Computed on first access from ``avar`` and the per-length
        factors in ``bound_table`` (then kept), so a surface whose bounds are never read
        costs no memory for them.
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
        """Number of squared differences in each cell, ``L - 2m + 1`` (0 where undefined)."""
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
        ds = xr.Dataset(data_vars, coords={"time": self.time, "tau": self.tau})
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

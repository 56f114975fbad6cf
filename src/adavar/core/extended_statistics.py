"""The statistics beyond the Allan seven, as :func:`adavar.deviation` reaches them.

Each entry of :data:`SPECS` says how one statistic is computed and read: the module that
computes it (imported on first use), whether its value is a frequency-like deviation (in
the units of the rate samples, like ADEV) or a time-like one (in phase units, like TDEV),
how its averaging time follows from the averaging factor, which factors it allows, and how
its degrees of freedom are found. :func:`adavar.deviation` does the rest (scaling, noise
identification, intervals), exactly as for the Allan statistics.

A family module provides, for each of its statistics:

``squared(stat, u, ms, **options) -> (values, n)``
    ``u``: the rate samples (or phase increments) at scale 1, float64, contiguous; ``ms``:
    int64 averaging factors (already filtered by ``factors``). ``values`` is the squared
    statistic for a sample interval of 1 (frequency kind: the variance of the rate;
    time kind: the squared value in units of ``cumsum(u)``), ``n`` the number of terms.
``m_max(stat, n_points) -> int``
    The largest averaging factor for ``n_points`` phase points.
``factors(stat, ms) -> (ms, notes)``
    The usable factors among ``ms`` (e.g. even ones only) and what was changed.
``edf(stat, alpha, m, n_points, **options) -> float``
    Equivalent degrees of freedom (NaN: no interval is defined).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

__all__ = ["SPECS", "StatisticSpec", "is_time_like", "spec_of"]


@dataclass(frozen=True)
class StatisticSpec:
    """How one statistic is computed and read.

    Attributes
    ----------
    name : str
        The ``stat=`` keyword.
    module : str
        The family module (see the module docstring for its functions).
    kind : {"frequency", "time"}
        Frequency-like (units of the rate samples) or time-like (units of their integral).
    tau_factor : float
        ``tau = tau_factor * m * tau0`` (0.75 for the Theo family).
    dmax : int
        Highest difference order of the noise identification (2 Allan-like, 3 Hadamard-like).
    options : tuple of str
        Keywords of :func:`adavar.deviation` passed on to ``squared`` and ``edf``.
    """

    name: str
    module: str
    kind: str
    tau_factor: float = 1.0
    dmax: int = 2
    options: tuple[str, ...] = ()

    def family(self) -> Any:
        """The family module (imported on first use)."""
        return importlib.import_module(self.module)


SPECS: dict[str, StatisticSpec] = {
    "theo1": StatisticSpec("theo1", "adavar.stats.theo_family", "frequency", tau_factor=0.75),
    "theobr": StatisticSpec(
        "theobr", "adavar.stats.theo_family", "frequency", 0.75, options=("theo_ratio_terms",)
    ),
    "theoh": StatisticSpec(
        "theoh", "adavar.stats.theo_family", "frequency", options=("theo_ratio_terms",)
    ),
    "mtie": StatisticSpec("mtie", "adavar.stats.time_error", "time"),
    "tierms": StatisticSpec("tierms", "adavar.stats.time_error", "time"),
    "mtotdev": StatisticSpec(
        "mtotdev",
        "adavar.stats.total_family",
        "frequency",
        options=("bias_correction", "total_edf"),
    ),
    "ttotdev": StatisticSpec(
        "ttotdev", "adavar.stats.total_family", "time", options=("bias_correction", "total_edf")
    ),
    "htotdev": StatisticSpec(
        "htotdev",
        "adavar.stats.total_family",
        "frequency",
        dmax=3,
        options=("bias_correction", "total_edf"),
    ),
    "pdev": StatisticSpec("pdev", "adavar.stats.total_family", "frequency"),
}


def is_time_like(stat: str) -> bool:
    """True for a statistic in phase units (TDEV and the time-kind ones), not rate units."""
    spec = SPECS.get(stat)
    return stat == "tdev" or (spec is not None and spec.kind == "time")


def spec_of(stat: str) -> StatisticSpec | None:
    """The spec of ``stat``, or None for one of the Allan seven."""
    return SPECS.get(stat)

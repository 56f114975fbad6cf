"""adavar: Allan-family statistics, noise-coefficient fits and the adaptive dynamic Allan variance.

The public entry points:

- :func:`deviation`: ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV, TOTDEV of a record, with
  confidence intervals;
- :func:`davar`: the dynamic Allan variance surface (every window, every tau) for a fixed
  window or any per-centre schedule, with per-cell confidence bounds;
- :func:`sliding_kurtosis`, :func:`kurtosis_contribution`: the kurtosis of every window and
  the sliding kurtosis contribution coefficient S (paper Eq. 14-15), exact and O(N);
- :func:`adaptive_davar`: the paper's adaptive-window DAVAR (A-DAVAR) and its baselines
  (DAVAR-K, an oracle schedule, a fixed window), steered by the kurtosis and the sliding
  kurtosis contribution coefficient;
- :class:`OnlineAdaptive`: the same adaptive window on a live stream, sample by sample, equal
  to the offline pass (windows, N(t) and events with a fixed latency);
- :func:`compare` / :func:`compare_seeds`: DAVAR-Lmin, DAVAR-Lmax, DAVAR-K and A-DAVAR on
  one signal (or the paper's scenarios, :func:`adavar.simulate.paper_scenario`, over many
  seeds): node tables beside the paper's, ground-truth tracking metrics;
- :mod:`adavar.paper`: the A-DAVAR paper's scenarios, published values, node rules and
  studies;
- :func:`fit_noise`: the IEEE-952 noise coefficients (Q, N, B, K, R) of a deviation curve, or
  of every DAVAR window at once (N(t), B(t), ...);
- :mod:`adavar.simulate`: seeded generators of the noise processes;
- :class:`AnalysisRequest` (:class:`RecordRequest` and its :class:`UnitGroup`,
  :class:`WindowSettings`, :class:`DeviationSettings`, :class:`ControllerSettings`,
  :class:`FitSettings`, :class:`MethodOptions`): one analysis of a file as typed settings, which
  :func:`adavar.pipeline.analysis.run` computes (the pipeline behind the commands).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# public names -> the module that defines them, imported on first use (PEP 562), so that
# ``import adavar`` does not load NumPy's neighbours, SciPy and Numba before they are needed
_LAZY = {
    "AdaptiveResult": "adavar.dynamic.adaptive",
    "adaptive_davar": "adavar.dynamic.adaptive",
    "adaptive_schedule": "adavar.dynamic.schedule",
    "compare": "adavar.comparison",
    "CodeviationResult": "adavar.stats.cornered_hat",
    "CorneredHatResult": "adavar.stats.cornered_hat",
    "cornered_hat": "adavar.stats.cornered_hat",
    "gcodev": "adavar.stats.cornered_hat",
    "davar": "adavar.dynamic.surface",
    "Duration": "adavar.core.durations",
    "seconds": "adavar.core.durations",
    "AdavarInputError": "adavar.core.errors",
    "AnalysisRequest": "adavar.core.request",
    "DeviationSettings": "adavar.core.request",
    "MethodOptions": "adavar.core.request",
    "RecordRequest": "adavar.core.request",
    "UnitGroup": "adavar.core.request",
    "WindowSettings": "adavar.core.request",
    "ControllerSettings": "adavar.core.settings",
    "FitSettings": "adavar.core.settings",
    "kurtosis_contribution": "adavar.dynamic.kurtosis",
    "sliding_kurtosis": "adavar.dynamic.kurtosis",
    "LongTauChanges": "adavar.dynamic.long_tau",
    "long_tau_changes": "adavar.dynamic.long_tau",
    "NoiseFit": "adavar.fit.noise_model",
    "NoiseTerm": "adavar.fit.noise_model",
    "MarkovTerm": "adavar.core.results",
    "fit_avar": "adavar.fit.noise_model",
    "fit_noise": "adavar.fit.noise_model",
    "OnlineAdaptive": "adavar.dynamic.online",
    "compare_seeds": "adavar.paper.studies",
    "PowerLawFit": "adavar.fit.power_law",
    "fit_power_law": "adavar.fit.power_law",
    "DavarResult": "adavar.core.results",
    "DeviationResult": "adavar.core.results",
    "deviation": "adavar.stats.statistics",
    "StationarityResult": "adavar.stats.stationary_noise",
    "stationarity": "adavar.stats.stationary_noise",
}
_SUBMODULES = ("simulate",)

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from adavar import simulate
    from adavar.comparison import compare
    from adavar.core.durations import Duration, seconds
    from adavar.core.errors import AdavarInputError
    from adavar.core.request import (
        AnalysisRequest,
        DeviationSettings,
        MethodOptions,
        RecordRequest,
        UnitGroup,
        WindowSettings,
    )
    from adavar.core.results import DavarResult, DeviationResult, MarkovTerm
    from adavar.core.settings import ControllerSettings, FitSettings
    from adavar.dynamic.adaptive import AdaptiveResult, adaptive_davar
    from adavar.dynamic.kurtosis import kurtosis_contribution, sliding_kurtosis
    from adavar.dynamic.long_tau import LongTauChanges, long_tau_changes
    from adavar.dynamic.online import OnlineAdaptive
    from adavar.dynamic.schedule import adaptive_schedule
    from adavar.dynamic.surface import davar
    from adavar.fit.noise_model import NoiseFit, NoiseTerm, fit_avar, fit_noise
    from adavar.fit.power_law import PowerLawFit, fit_power_law
    from adavar.paper.studies import compare_seeds
    from adavar.stats.cornered_hat import CodeviationResult, CorneredHatResult, cornered_hat, gcodev
    from adavar.stats.stationary_noise import StationarityResult, stationarity
    from adavar.stats.statistics import deviation


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
    elif name in _SUBMODULES:
        value = importlib.import_module(f"adavar.{name}")
    else:
        raise AttributeError(f"module 'adavar' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = [
    "AdaptiveResult",
    "AdavarInputError",
    "AnalysisRequest",
    "CodeviationResult",
    "ControllerSettings",
    "CorneredHatResult",
    "DavarResult",
    "DeviationResult",
    "DeviationSettings",
    "Duration",
    "FitSettings",
    "LongTauChanges",
    "MarkovTerm",
    "MethodOptions",
    "NoiseFit",
    "NoiseTerm",
    "OnlineAdaptive",
    "PowerLawFit",
    "RecordRequest",
    "StationarityResult",
    "UnitGroup",
    "WindowSettings",
    "adaptive_davar",
    "adaptive_schedule",
    "compare",
    "compare_seeds",
    "cornered_hat",
    "davar",
    "deviation",
    "fit_avar",
    "fit_noise",
    "fit_power_law",
    "gcodev",
    "kurtosis_contribution",
    "long_tau_changes",
    "seconds",
    "simulate",
    "sliding_kurtosis",
    "stationarity",
]

__version__ = "0.1.0"

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
- :class:`AnalysisRequest` (:class:`RecordRequest`, :class:`WindowSettings`,
  :class:`DeviationSettings`, :class:`ControllerSettings`, :class:`FitSettings`,
  :class:`MethodOptions`): one analysis of a file as typed settings, which
  :func:`adavar.analysis.run` computes (the pipeline behind the commands).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# public names -> the module that defines them, imported on first use (PEP 562), so that
# ``import adavar`` does not load NumPy's neighbours, SciPy and Numba before they are needed
_LAZY = {
    "AdaptiveResult": "adavar.adaptive",
    "adaptive_davar": "adavar.adaptive",
    "adaptive_schedule": "adavar.adaptive",
    "compare": "adavar.comparison",
    "CodeviationResult": "adavar.cornered_hat",
    "CorneredHatResult": "adavar.cornered_hat",
    "cornered_hat": "adavar.cornered_hat",
    "gcodev": "adavar.cornered_hat",
    "davar": "adavar.surface",
    "Duration": "adavar.durations",
    "seconds": "adavar.durations",
    "AdavarInputError": "adavar.errors",
    "AnalysisRequest": "adavar.request",
    "DeviationSettings": "adavar.request",
    "MethodOptions": "adavar.request",
    "RecordRequest": "adavar.request",
    "WindowSettings": "adavar.request",
    "ControllerSettings": "adavar.settings",
    "FitSettings": "adavar.settings",
    "kurtosis_contribution": "adavar.kurtosis",
    "sliding_kurtosis": "adavar.kurtosis",
    "LongTauChanges": "adavar.long_tau",
    "long_tau_changes": "adavar.long_tau",
    "NoiseFit": "adavar.noise_model",
    "NoiseTerm": "adavar.noise_model",
    "MarkovTerm": "adavar.results",
    "fit_avar": "adavar.noise_model",
    "fit_noise": "adavar.noise_model",
    "OnlineAdaptive": "adavar.online",
    "compare_seeds": "adavar.paper.studies",
    "PowerLawFit": "adavar.power_law",
    "fit_power_law": "adavar.power_law",
    "DavarResult": "adavar.results",
    "DeviationResult": "adavar.results",
    "deviation": "adavar.statistics",
    "StationarityResult": "adavar.stationary_noise",
    "stationarity": "adavar.stationary_noise",
}
_SUBMODULES = ("simulate",)

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from adavar import simulate
    from adavar.adaptive import AdaptiveResult, adaptive_davar, adaptive_schedule
    from adavar.comparison import compare
    from adavar.cornered_hat import CodeviationResult, CorneredHatResult, cornered_hat, gcodev
    from adavar.durations import Duration, seconds
    from adavar.errors import AdavarInputError
    from adavar.kurtosis import kurtosis_contribution, sliding_kurtosis
    from adavar.long_tau import LongTauChanges, long_tau_changes
    from adavar.noise_model import NoiseFit, NoiseTerm, fit_avar, fit_noise
    from adavar.online import OnlineAdaptive
    from adavar.paper.studies import compare_seeds
    from adavar.power_law import PowerLawFit, fit_power_law
    from adavar.request import (
        AnalysisRequest,
        DeviationSettings,
        MethodOptions,
        RecordRequest,
        WindowSettings,
    )
    from adavar.results import DavarResult, DeviationResult, MarkovTerm
    from adavar.settings import ControllerSettings, FitSettings
    from adavar.stationary_noise import StationarityResult, stationarity
    from adavar.statistics import deviation
    from adavar.surface import davar


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

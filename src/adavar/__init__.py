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
- :func:`compare` / :func:`compare_seeds`: DAVAR-Lmin, DAVAR-Lmax, DAVAR-K and A-DAVAR on
  one signal (or the paper's scenarios, :func:`adavar.simulate.paper_scenario`, over many
  seeds): node tables beside the paper's, ground-truth tracking metrics;
- :mod:`adavar.paper`: the A-DAVAR paper's scenarios, published values, node rules and
  studies;
- :func:`fit_noise`: the IEEE-952 noise coefficients (Q, N, B, K, R) of a deviation curve, or
  of every DAVAR window at once (N(t), B(t), ...);
- :mod:`adavar.simulate`: seeded generators of the noise processes.
"""

from adavar import simulate
from adavar.adaptive import AdaptiveResult, adaptive_davar, adaptive_schedule
from adavar.compare import compare
from adavar.davar import davar
from adavar.durations import Duration, seconds
from adavar.errors import AdavarInputError
from adavar.kurtosis import kurtosis_contribution, sliding_kurtosis
from adavar.noise_model import NoiseFit, NoiseTerm, fit_avar, fit_noise
from adavar.paper.studies import compare_seeds
from adavar.results import DavarResult, DeviationResult
from adavar.statistics import deviation

__all__ = [
    "AdaptiveResult",
    "AdavarInputError",
    "DavarResult",
    "DeviationResult",
    "Duration",
    "NoiseFit",
    "NoiseTerm",
    "adaptive_davar",
    "adaptive_schedule",
    "compare",
    "compare_seeds",
    "davar",
    "deviation",
    "fit_avar",
    "fit_noise",
    "kurtosis_contribution",
    "seconds",
    "simulate",
    "sliding_kurtosis",
]

__version__ = "0.1.0"

"""adavar: Allan-family statistics, noise-coefficient fits and the adaptive dynamic Allan variance.

The public entry points:

- :func:`deviation`: ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV, TOTDEV of a record, with
  confidence intervals;
- :func:`davar`: the dynamic Allan variance surface (every window, every tau) for a fixed
  window or any per-centre schedule, with per-cell confidence bounds;
- :func:`fit_noise`: the IEEE-952 noise coefficients (Q, N, B, K, R) of a deviation curve, or
  of every DAVAR window at once (N(t), B(t), ...);
- :mod:`adavar.simulate`: seeded generators of the noise processes.
"""

from adavar import simulate
from adavar.davar import davar
from adavar.errors import AdavarInputError
from adavar.noise_model import NoiseFit, NoiseTerm, fit_avar, fit_noise
from adavar.results import DavarResult, DeviationResult
from adavar.statistics import deviation

__all__ = [
    "AdavarInputError",
    "DavarResult",
    "DeviationResult",
    "NoiseFit",
    "NoiseTerm",
    "davar",
    "deviation",
    "fit_avar",
    "fit_noise",
    "simulate",
]

__version__ = "0.1.0"

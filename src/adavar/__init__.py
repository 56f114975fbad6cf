"""adavar: Allan-family statistics, noise-coefficient fits and the adaptive dynamic Allan variance.

The public entry points:

- :func:`deviation`: ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV, TOTDEV of a record, with
  confidence intervals;
- :func:`fit_noise`: the IEEE-952 noise coefficients (Q, N, B, K, R) of a deviation curve, or
  of a stack of curves;
- :mod:`adavar.simulate`: seeded generators of the noise processes.
"""

from adavar import simulate
from adavar.errors import AdavarInputError
from adavar.noise_model import NoiseFit, NoiseTerm, fit_avar, fit_noise
from adavar.results import DeviationResult
from adavar.statistics import deviation

__all__ = [
    "AdavarInputError",
    "DeviationResult",
    "NoiseFit",
    "NoiseTerm",
    "deviation",
    "fit_avar",
    "fit_noise",
    "simulate",
]

__version__ = "0.1.0"

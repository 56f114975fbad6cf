"""Seeded simulation of inertial-sensor and clock noise: ``adavar.simulate``.

The public face of the noise generators (:mod:`adavar.simulation.generators`: white noise, random
walks, flicker, Gauss-Markov, sinusoids, the IEEE Std 952 terms, a sensor with its
bandwidth and LSB, piecewise-white records) and of the A-DAVAR paper's simulated records
(:mod:`adavar.paper.scenarios`: :func:`paper_scenario`, :class:`PaperScenario`,
:data:`PAPER_SCENARIOS`). Modules inside adavar import from those two directly.

Examples
--------
>>> from adavar import simulate
>>> gyro = simulate.sensor(1000, rate=100.0, angle_random_walk=1e-3, seed=1)
>>> gyro.shape
(1000,)
"""

from __future__ import annotations

from adavar.paper.scenarios import PAPER_SCENARIOS, PaperScenario, paper_scenario
from adavar.simulation.generators import (
    MAX_SAMPLES,
    angle_random_walk,
    bias_instability,
    flicker,
    markov,
    piecewise_white,
    piecewise_white_times,
    quantization,
    random_walk,
    rate_ramp,
    rate_random_walk,
    sensor,
    sinusoid,
    white,
)

__all__ = [
    "MAX_SAMPLES",
    "PAPER_SCENARIOS",
    "PaperScenario",
    "angle_random_walk",
    "bias_instability",
    "flicker",
    "markov",
    "paper_scenario",
    "piecewise_white",
    "piecewise_white_times",
    "quantization",
    "random_walk",
    "rate_ramp",
    "rate_random_walk",
    "sensor",
    "sinusoid",
    "white",
]

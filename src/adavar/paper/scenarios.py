"""The A-DAVAR paper's simulated records, with their ground truth.

:func:`paper_scenario` draws a realisation of the paper's scenario 1 (its section 2.2 and
Table 1) or 2 (the shape of its section 4.3 and Table 3) as a :class:`PaperScenario`: the
samples, the true noise level of every sample, the change times and the paper's ARW
intervals. :data:`PAPER_SCENARIOS` defines them; the noise is
:func:`adavar.simulate.piecewise_white`. docs/method.md section 9 gives the two readings of
the disturbance (``variance_reading``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from adavar.simulation.generators import FloatArray, SeedLike, piecewise_white

__all__ = ["PAPER_SCENARIOS", "PaperScenario", "paper_scenario"]

#: The paper's simulated records (Micromachines 2018, 9(8), 373, sections 2.2 and 4.3; see
#: docs/method.md section 9): duration (s), disturbed intervals (s), and the intervals over which
#: the paper averages the ARW (its Table 1; scenario 2 uses the intervals of its Table 3).
PAPER_SCENARIOS: dict[int, dict[str, Any]] = {
    1: {
        "duration": 6000.0,
        "disturbances": ((3000.0, 4000.0),),
        "intervals": ((0.0, 2000.0), (3000.0, 4000.0)),
    },
    2: {
        "duration": 6000.0,
        "disturbances": ((1000.0, 2000.0), (4000.0, 5000.0)),
        "intervals": ((1000.0, 2000.0), (2500.0, 3500.0), (4000.0, 5000.0)),
    },
}


@dataclass(frozen=True, eq=False)
class PaperScenario:
    """One realisation of a simulation of the A-DAVAR paper, with its ground truth.

    Attributes
    ----------
    number : int
        1 (one disturbance, 3000-4000 s: the paper's Table 1) or 2 (disturbances at
        1000-2000 s and 4000-5000 s: the shape of its Table 3).
    data : ndarray of float64, shape (N,)
        Rate samples (unit-less white noise ``u``), one every ``1 / rate`` seconds.
    rate : float
        Sample rate, Hz (1 Hz as in the paper).
    change_times : tuple of float
        Times (s) at which the noise level changes (start and end of each disturbance).
    std : ndarray of float64, shape (N,)
        True standard deviation of every sample.
    seed : int or None
        Seed of the noise (None: fresh entropy).
    variance_reading : bool
        True: the disturbance has variance 3 (the paper's text read literally, std
        ``sqrt(3)``); False (default): std 3, the reading that reproduces the paper's node
        times (docs/method.md section 9).
    intervals : tuple of (float, float)
        The paper's ARW averaging intervals for this scenario, seconds.
    description : str
        One line, for reports.
    """

    number: int
    data: FloatArray
    rate: float
    change_times: tuple[float, ...]
    std: FloatArray
    seed: int | None
    variance_reading: bool
    intervals: tuple[tuple[float, float], ...]
    description: str

    @property
    def tau0(self) -> float:
        """Sample interval, seconds."""
        return 1.0 / self.rate

    @property
    def time(self) -> FloatArray:
        """Time of every sample, seconds."""
        return np.arange(self.data.size) / self.rate

    @property
    def arw(self) -> FloatArray:
        """True angle random walk ``N`` of every sample, ``std * sqrt(tau0)`` (u*sqrt(s)).

        White rate noise of standard deviation ``std`` sampled every ``tau0`` has Allan
        variance ``std**2 tau0 / tau``, i.e. ``N = std sqrt(tau0)``: 1 u*sqrt(s) for the
        paper's unit noise at 1 Hz, 3 u*sqrt(s) in a disturbance.
        """
        return self.std * math.sqrt(self.tau0)


def paper_scenario(
    number: int, *, seed: SeedLike = None, variance_reading: bool = False
) -> PaperScenario:
    r"""A simulated record of the A-DAVAR paper with its true noise level at every sample.

    Scenario 1 (the paper's section 2.2 and Table 1): 6000 s at ``tau0 = 1 s`` of unit
    Gaussian white noise, disturbed from 3000 s to 4000 s. Scenario 2 (the shape of the
    paper's section 4.3 and Table 3): disturbances from 1000 s to 2000 s and from 4000 s to
    5000 s. A disturbance multiplies the standard deviation by 3 (variance 9), the reading
    under which the paper's own kurtosis node times are reproduced; ``variance_reading=True``
    takes the text literally (variance 3, standard deviation ``sqrt(3)``). Sample ``k``
    (time ``k`` s) is disturbed when ``start <= k < end``.

    Parameters
    ----------
    number : {1, 2}
        Which scenario.
    seed : int, None, SeedSequence or Generator
        Seed of the noise (:func:`adavar.simulate.piecewise_white`: the same seed gives the same
        standard-normal draws in both readings and both scenarios).
    variance_reading : bool
        Disturbance of variance 3 instead of standard deviation 3.

    Returns
    -------
    PaperScenario
        The samples, the rate (1 Hz), the change times, the true standard deviation and
        ARW of every sample, and the paper's ARW intervals.

    Raises
    ------
    ValueError
        For a scenario other than 1 or 2.
    """
    if isinstance(number, bool) or number not in PAPER_SCENARIOS:
        raise ValueError(
            f"number must be 1 or 2 (the paper's simulations), got {number!r}; "
            "pass number=1 or number=2."
        )
    spec = PAPER_SCENARIOS[int(number)]
    rate = 1.0
    duration = float(spec["duration"])
    n = math.ceil(duration * rate - 1e-9)
    level = math.sqrt(3.0) if variance_reading else 3.0
    changes: list[float] = []
    stds = [1.0]
    for start, end in spec["disturbances"]:
        changes += [start, end]
        stds += [level, 1.0]
    idx = np.ceil(np.asarray(changes) * rate - 1e-9).astype(np.int64)
    lengths = np.diff(np.concatenate([[0], idx, [n]]))
    std = np.repeat(np.asarray(stds, dtype=np.float64), lengths)
    data = piecewise_white(n, stds, idx, rate=rate, seed=seed)
    reading = "variance x3, std sqrt(3)" if variance_reading else "std x3, variance 9"
    spans = ", ".join(f"{a:g}-{b:g} s" for a, b in spec["disturbances"])
    return PaperScenario(
        number=int(number),
        data=data,
        rate=rate,
        change_times=tuple(float(t) for t in changes),
        std=std,
        seed=int(seed) if isinstance(seed, (int, np.integer)) else None,
        variance_reading=bool(variance_reading),
        intervals=tuple((float(a), float(b)) for a, b in spec["intervals"]),
        description=(
            f"paper scenario {int(number)}: {duration:g} s of unit white noise at {rate:g} Hz, "
            f"disturbed ({reading}) at {spans}"
            + (f", seed {int(seed)}" if isinstance(seed, (int, np.integer)) else "")
        ),
    )

"""The built-in demonstration behind ``adavar demo``: data in, numbers out, no printing.

Three parts:

1. The NIST SP 1065 1000-point test data (:func:`adavar.core.datasets.nist_1000`, fractional
   frequency, ``tau0 = 1 s``): ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV and TOTDEV at averaging
   factors 1, 10 and 100 next to the values published in SP 1065 (copied from the
   project's ``REFERENCE.md`` into :data:`NIST_PUBLISHED`).
2. A simulated MEMS gyroscope (:func:`adavar.simulate.sensor`, 1e6 samples at 100 Hz in
   deg/s) with known quantization, angle random walk, bias instability and rate random
   walk: its overlapping Allan deviation with confidence intervals, the fit of the five
   IEEE Std 952 terms, and the known true values to compare with.

3. The A-DAVAR paper's scenario 1 (:func:`adavar.paper.scenarios.paper_scenario`):
   DAVAR-400, DAVAR-600, DAVAR-K and A-DAVAR on one realisation
   (:func:`adavar.comparison.compare`, with the kurtosis studies of the paper's Figs. 6-8,
   :mod:`adavar.paper.studies`), and the node times over :data:`PAPER_SEEDS` realisations
   next to the paper's Table 1 (:func:`adavar.paper.studies.compare_seeds`).

:func:`run_demo` returns a :class:`DemoResult`; the command line prints it and draws the
figures.
"""

from __future__ import annotations

import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from adavar._kernels import _workers
from adavar._kernels._jit import compilations
from adavar.comparison import Comparison, compare
from adavar.core.datasets import nist_1000
from adavar.core.results import DeviationResult, NoiseFit
from adavar.core.terms import TERM_NAMES
from adavar.core.units import ConvertedNoise, conventional_units, convert_coefficient
from adavar.fit.noise_model import fit_noise
from adavar.paper.scenarios import paper_scenario
from adavar.paper.studies import (
    KurtosisStudy,
    SeedStudy,
    ThresholdStudy,
    compare_seeds,
    concatenate_seed_studies,
    kurtosis_study,
    threshold_study,
)
from adavar.simulation import generators as simulate
from adavar.stats.statistics import deviation

__all__ = [
    "GYRO_BANDWIDTH",
    "GYRO_BIAS",
    "GYRO_LSB",
    "GYRO_RATE",
    "GYRO_SAMPLES",
    "GYRO_TRUE",
    "GYRO_UNITS",
    "NIST_AVERAGING_FACTORS",
    "NIST_MEAN",
    "NIST_PUBLISHED",
    "NIST_STD",
    "PAPER_SEEDS",
    "DemoResult",
    "GyroDemo",
    "NistRow",
    "PaperDemo",
    "run_demo",
    "worker_pool",
]

#: Averaging factors of the published NIST values.
NIST_AVERAGING_FACTORS: tuple[int, ...] = (1, 10, 100)

#: NIST SP 1065 (section 12.4) published deviations of the 1000-point data at averaging
#: factors 1, 10, 100 (7 significant digits; REFERENCE.md). The last digit of HDEV at
#: AF = 100 is a rounding case (3.910861e-02 is as good).
NIST_PUBLISHED: dict[str, tuple[float, float, float]] = {
    "adev": (2.922319e-01, 9.965736e-02, 3.897804e-02),
    "oadev": (2.922319e-01, 9.159953e-02, 3.241343e-02),
    "mdev": (2.922319e-01, 6.172376e-02, 2.170921e-02),
    "tdev": (1.687202e-01, 3.563623e-01, 1.253382e00),
    "hdev": (2.943883e-01, 1.052754e-01, 3.910860e-02),
    "ohdev": (2.943883e-01, 9.581083e-02, 3.237638e-02),
    "totdev": (2.922319e-01, 9.134743e-02, 3.406530e-02),
}
#: Published mean and (sample) standard deviation of the same data.
NIST_MEAN = 4.897745e-01
NIST_STD = 2.884664e-01

#: The simulated gyroscope: sample rate (Hz), number of samples, unit of the rate samples,
#: constant turn-on bias (deg/s, invisible to the Allan variance).
GYRO_RATE = 100.0
GYRO_SAMPLES = 1_000_000
GYRO_UNITS = "deg/s"
GYRO_BIAS = 0.2
#: Its output stage, as on a real MEMS part: a 20 Hz digital low-pass (2nd-order
#: Butterworth) and a 16-bit word at +-125 deg/s (LSB 1/262.4 deg/s).
GYRO_BANDWIDTH = 20.0
GYRO_LSB = 1.0 / 262.4

#: True noise coefficients of the simulated gyroscope, in the conventional units
#: (arcsec, deg/sqrt(h), deg/h, deg/h/sqrt(h), deg/h^2): a consumer-grade MEMS gyro. Its
#: angle is not quantised (the LSB quantises the rate, after the filter).
GYRO_TRUE: dict[str, float] = {
    "quantization": 0.0,
    "angle_random_walk": 0.1,
    "bias_instability": 3.0,
    "rate_random_walk": 20.0,
    "rate_ramp": 0.0,
}


#: Realisations of the paper's scenario 1 behind the demo's node table (seeds SEED ..
#: SEED + PAPER_SEEDS - 1).
PAPER_SEEDS = 30


@dataclass(frozen=True)
class NistRow:
    """One computed NIST deviation next to its published value.

    Attributes
    ----------
    stat : str
    averaging_factor : int
    tau : float
        Seconds (``tau0 = 1 s``).
    computed : float
    published : float
    """

    stat: str
    averaging_factor: int
    tau: float
    computed: float
    published: float

    @property
    def rel_diff(self) -> float:
        """``computed / published - 1``."""
        return self.computed / self.published - 1.0


@dataclass(frozen=True)
class GyroDemo:
    """The simulated gyroscope, its deviation and its noise fit.

    Attributes
    ----------
    rate : float
        Sample rate, Hz.
    n_samples : int
    units : str
        Unit of the rate samples (``"deg/s"``).
    seed : int
    true : dict
        True coefficients in the data's own units (deg, deg/sqrt(s), deg/s, deg/s/sqrt(s),
        deg/s^2), as passed to :func:`adavar.simulate.sensor`.
    true_conventional : dict
        The same in the conventional units: term -> (value, unit).
    result : DeviationResult
        Overlapping Allan deviation at octave taus with 68.3 % confidence intervals.
    fit : NoiseFit
        The five-term fit of ``result``.
    """

    rate: float
    n_samples: int
    units: str
    seed: int
    true: dict[str, float]
    true_conventional: dict[str, tuple[float, str]]
    result: DeviationResult
    fit: NoiseFit

    @property
    def fitted_conventional(self) -> ConvertedNoise:
        """The fitted coefficients in the conventional units."""
        return self.fit.to_units(self.units)


@dataclass(frozen=True, eq=False)
class PaperDemo:
    """The A-DAVAR paper's scenario 1, end to end.

    Attributes
    ----------
    comparison : Comparison
        DAVAR-400, DAVAR-600, DAVAR-K and A-DAVAR on the realisation of the demo's seed
        (all taus, as in the paper).
    kurtosis : KurtosisStudy
        Kurtosis at windows 11, 201, 601 and the record-form S of window 11 (Figs. 6-7).
    thresholds : ThresholdStudy
        Crossings of the fixed 600-sample window's kurtosis (Fig. 8).
    study : SeedStudy
        Nodes, metrics and crossings over :data:`PAPER_SEEDS` realisations (octave taus).
    """

    comparison: Comparison
    kurtosis: KurtosisStudy
    thresholds: ThresholdStudy
    study: SeedStudy


@dataclass(frozen=True)
class DemoResult:
    """Everything the demo computed.

    Attributes
    ----------
    nist : tuple of NistRow
        Every statistic at every averaging factor, in the order of :data:`NIST_PUBLISHED`.
    nist_results : dict
        Statistic -> the :class:`DeviationResult` behind the rows.
    nist_mean, nist_std : NistRow
        Summary statistics of the data (``stat`` ``"mean"``/``"std"``, averaging factor 1).
    gyro : GyroDemo
    elapsed : float
        Wall-clock seconds spent in :func:`run_demo`.
    paper : PaperDemo or None
        The paper's scenario 1 (None when run with ``paper=False``).
    """

    nist: tuple[NistRow, ...]
    nist_results: dict[str, DeviationResult]
    nist_mean: NistRow
    nist_std: NistRow
    gyro: GyroDemo
    elapsed: float
    paper: PaperDemo | None = None

    @property
    def nist_max_rel_diff(self) -> float:
        """Largest ``|rel_diff|`` over the published deviations."""
        return max(abs(row.rel_diff) for row in self.nist)


def _nist() -> tuple[tuple[NistRow, ...], dict[str, DeviationResult], NistRow, NistRow]:
    y = nist_1000()
    rows = []
    results = {}
    for stat, published in NIST_PUBLISHED.items():
        res = deviation(y, stat=stat, tau0=1.0, taus=list(NIST_AVERAGING_FACTORS))
        results[stat] = res
        for af, tau, value, ref in zip(
            NIST_AVERAGING_FACTORS, res.tau, res.dev, published, strict=True
        ):
            rows.append(NistRow(stat, af, float(tau), float(value), ref))
    mean = NistRow("mean", 1, 1.0, float(np.mean(y)), NIST_MEAN)
    std = NistRow("std", 1, 1.0, float(np.std(y, ddof=1)), NIST_STD)
    return tuple(rows), results, mean, std


def _gyro(seed: int) -> GyroDemo:
    targets = conventional_units(GYRO_UNITS)
    true_conventional = {name: (GYRO_TRUE[name], targets[name]) for name in TERM_NAMES}
    true = {
        name: GYRO_TRUE[name] / convert_coefficient(1.0, name, GYRO_UNITS, targets[name])
        for name in TERM_NAMES
    }
    samples = simulate.sensor(
        GYRO_SAMPLES, rate=GYRO_RATE, bias=GYRO_BIAS, bandwidth=GYRO_BANDWIDTH, lsb=GYRO_LSB,
        seed=seed, **true,
    )  # fmt: skip
    result = deviation(
        samples, stat="oadev", rate=GYRO_RATE, taus="octave", confidence=0.683, units=GYRO_UNITS
    )
    fit = fit_noise(result)
    return GyroDemo(
        rate=GYRO_RATE,
        n_samples=GYRO_SAMPLES,
        units=GYRO_UNITS,
        seed=seed,
        true=true,
        true_conventional=true_conventional,
        result=result,
        fit=fit,
    )


#: Realisations per work item of the node table: the main process takes the items the
#: worker has not started once its own work is done (about 0.1 s a realisation, warm).
SEED_CHUNK = 3


def _seed_study(first: int, count: int) -> SeedStudy:
    """Realisations ``first .. first + count - 1`` (module level: a worker process runs it)."""
    return compare_seeds(1, range(first, first + count))


def _seed_chunks(seed: int) -> list[tuple[int, int]]:
    """``(first, count)`` of the work items: the first realisation alone, then chunks."""
    chunks = [(seed, 1)]
    for first in range(seed + 1, seed + PAPER_SEEDS, SEED_CHUNK):
        chunks.append((first, min(SEED_CHUNK, seed + PAPER_SEEDS - first)))
    return chunks


class _SharedStudy(_workers.SharedJobs):
    """The node table's realisations, in a worker process and, at the end, in this one.

    The worker takes the chunks from the first (one realisation, which compiles on a
    first run the kernels that the comparison needs); :meth:`result` runs here the chunks
    it has not reached, from the last (:class:`adavar._kernels._workers.SharedJobs`).
    """

    def __init__(self, pool: ProcessPoolExecutor, seed: int) -> None:
        self.chunks = _seed_chunks(seed)
        super().__init__(pool, _seed_study, self.chunks)

    def result(self) -> SeedStudy:
        """The study of every realisation."""
        return concatenate_seed_studies(self.results())


def _paper(seed: int, shared: _SharedStudy | None, warm: bool, keep: str) -> PaperDemo:
    scenario = paper_scenario(1, seed=seed)
    # first what the worker does not compile, then the comparison once it has compiled
    # (on a first run) the kernels that the comparison shares with the seed study;
    # with a warm cache (nothing compiled here so far) there is nothing to wait for
    kurtosis = kurtosis_study(scenario)
    thresholds = threshold_study(scenario)
    if shared is not None and not warm:
        shared.wait_first()
    comparison = compare(scenario, keep=keep)
    return PaperDemo(
        comparison=comparison,
        kurtosis=kurtosis,
        thresholds=thresholds,
        study=_seed_study(seed, PAPER_SEEDS) if shared is None else shared.result(),
    )


def worker_pool(workers: int | None, *, start: bool = False) -> ProcessPoolExecutor | None:
    """One worker process for the seed study (and the caller's figures), or None.

    ``workers=None`` takes a second process when this one may use two cores or more.
    A pool that cannot start (no ``fork``/``spawn`` allowed, no semaphores) is no error:
    the study then runs in this process. The worker imports this module as it starts;
    ``start=True`` starts it now instead of on the first task.

    Parameters
    ----------
    workers : int or None
        1 for none, 2 (or more) for one, None for one where two cores are free to this
        process.
    start : bool
        Start the process now.

    Returns
    -------
    ProcessPoolExecutor or None
        A pool of one process started by ``spawn``; the caller shuts it down.
    """
    return _workers.worker_pool(workers, (__name__,), start=start)


def run_demo(
    seed: int = 2018,
    *,
    paper: bool = True,
    workers: int | None = 1,
    executor: ProcessPoolExecutor | None = None,
    keep: str = "all",
) -> DemoResult:
    """Run the demonstration (a few seconds).

    Parameters
    ----------
    seed : int
        Seed of the simulated gyroscope and of the (first) realisation of the paper's
        scenario 1.
    paper : bool
        Also run the paper's scenario 1 (about 3 s).
    workers : int or None
        Processes to use: 1 runs everything in this one; 2 runs the paper's
        :data:`PAPER_SEEDS` realisations (:func:`adavar.paper.studies.compare_seeds`) in a
        second process meanwhile, which also splits a first run's compilation between two
        cores; None takes 2 when this process may use two cores. The results are the
        same either way.
    executor : ProcessPoolExecutor, optional
        A pool of one worker (:func:`worker_pool`) to use instead of ``workers``; left
        running, for the caller's further work (the command line draws figures in it).
    keep : {"all", "figures"}
        What the paper's comparison keeps (:func:`adavar.comparison.compare`): every
        method's whole surface (default), or the windows its figures draw and no per-cell
        residuals (what the command line writes; faster, every other value the same).

    Returns
    -------
    DemoResult
        The NIST comparison, the simulated gyroscope's deviation, fit and true values, and
        the paper's scenario 1.
    """
    start = time.perf_counter()
    own = executor is None
    pool = (worker_pool(workers) if paper else None) if own else executor
    try:
        # on a first run the worker's first realisation compiles the kernels the
        # comparison needs while this process compiles the statistics' and the kurtosis'
        shared = _SharedStudy(pool, int(seed)) if pool is not None else None
        with compilations() as compiled:
            nist, nist_results, mean, std = _nist()
            gyro = _gyro(int(seed))
        paper_part = _paper(int(seed), shared, not compiled, keep) if paper else None
    finally:
        if own and pool is not None:
            # the worker's exit is waited for here rather than by the interpreter's exit
            # handler, which on Python 3.11 races with the pool's own closing
            pool.shutdown(wait=True, cancel_futures=True)
    return DemoResult(
        nist=nist,
        nist_results=nist_results,
        nist_mean=mean,
        nist_std=std,
        gyro=gyro,
        elapsed=time.perf_counter() - start,
        paper=paper_part,
    )

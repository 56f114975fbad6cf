"""Parameter objects: the adaptive controller's settings and the noise fit's options, with
their defaults in one place.

:class:`ControllerSettings` holds the fourteen keywords of the adaptive window
(docs/method.md section 8) with the library's and the commands' defaults (:data:`PAPER`:
the paper's values); :class:`FitSettings` the keywords of :func:`adavar.fit_noise`. The
command line takes its flags' defaults from them, the library's functions and
:mod:`adavar.pipeline.batch` their keywords, so a default is written once.

The adaptive window's defaults are the same in the library (:func:`adavar.adaptive_davar`,
:class:`adavar.OnlineAdaptive`) and on the command line (``adaptive``, ``report``, ``batch``,
``monitor``): windows from the record (:func:`adavar.dynamic.adaptive.record_windows`; a stream:
:data:`STREAM_LMAX_SECONDS`) and thresholds calibrated for :data:`HOURLY_FALSE_ALARMS` false
events per stationary hour (:data:`THRESHOLDS`, :func:`threshold_mode`). Only the paper's
reproduction (:func:`adavar.compare`, ``adavar compare``, :mod:`adavar.paper`) keeps the
paper's 600/400/100 samples and thresholds, which ``thresholds="paper"`` and ``lmax=600``
give anywhere.
:data:`ANALYSIS_DEFAULTS` lists every analysis option of ``adavar report`` (and so of
``adavar batch``) with its default; ``tests/test_cli_params.py`` checks that the parser
agrees with it.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Any

__all__ = [
    "ANALYSIS_DEFAULTS",
    "BAND_ONLY",
    "CALIBRATED_ONLY",
    "CALIBRATED_REPLACES",
    "CONTROLLER",
    "DATA_TYPE_DEFAULT",
    "DEPENDENCE_FIRST",
    "EFFICIENT_CHUNK",
    "FIT",
    "FIT_OPTION_NAMES",
    "HOURLY_FALSE_ALARMS",
    "HOURLY_ONLY",
    "PAPER",
    "RATE_AGREEMENT",
    "RATE_DEFAULT",
    "RATE_LIMITS",
    "STREAM_LMAX_SECONDS",
    "THRESHOLDS",
    "ControllerSettings",
    "FileDefault",
    "FitSettings",
    "RateDefault",
    "requested_threads",
    "threshold_mode",
]


#: False events per hour of stationary data the default thresholds are calibrated for
#: (the library's and the command line's).
HOURLY_FALSE_ALARMS = 0.1
#: The thresholds of :func:`adavar.adaptive_davar`, :class:`adavar.OnlineAdaptive` and the
#: commands ``adaptive``, ``report``, ``batch`` and ``monitor``: calibrated for
#: :data:`HOURLY_FALSE_ALARMS` false events per stationary hour (:func:`threshold_mode`).
#: ``"paper"`` gives the paper's K1, K2, S2 (a 6 s window at 100 Hz then flags about 5
#: false changes a minute of white noise).
THRESHOLDS = "calibrated"


@dataclass(frozen=True)
class ControllerSettings:
    """The adaptive window's settings, with the defaults of the library and of every
    command but ``compare``: windows from the record (``lmax``, ``lmin``, ``l`` None:
    :func:`adavar.dynamic.adaptive.record_windows`) and thresholds calibrated for
    :data:`HOURLY_FALSE_ALARMS` false events per stationary hour. :data:`PAPER` holds the
    paper's values (600, 400, 100 samples and its K1, K2, S2), which ``compare`` and
    :mod:`adavar.paper` use. (Before 0.3 the defaults were the paper's.)

    Attributes
    ----------
    lmax, lmin : int, str or None
        Longest and shortest window, samples or a duration (None: from the record).
    k1, k2 : float
        Kurtosis band of the f1 test.
    s1, s2 : float
        Thresholds of the f2 test on the contribution coefficient S (``s1`` for the band
        test only).
    l : int, str or None
        Leading segment of the S test, samples or a duration (None: from ``lmax``).
    dl0, dl1 : int
        Regrow and shrink steps, samples.
    s_test : {"upper", "band", "abs"}
        The f2 test (docs/method.md section 8, its ambiguities).
    combine : {"or", "and"}
        How f1 and f2 make f.
    thresholds : {"paper", "calibrated"}
        The given thresholds, or ones calibrated for ``false_alarm``.
    false_alarm : float or None
        Per-step false-alarm rate of the calibrated thresholds (None: not given, the
        per-hour calibration; :func:`threshold_mode`).
    false_alarm_per_hour : float or None
        Calibrate for this many false events per hour of stationary data instead (the
        library and every command but ``compare`` use :data:`HOURLY_FALSE_ALARMS` with
        calibrated thresholds).
    """

    lmax: Any = None
    lmin: Any = None
    k1: float = 2.5
    k2: float = 3.3
    s1: float = 0.0
    s2: float = 0.07
    l: Any = None  # noqa: E741 - the paper's name
    dl0: int = 2
    dl1: int = 2
    s_test: str = "upper"
    combine: str = "or"
    thresholds: str = THRESHOLDS
    false_alarm: float | None = None
    false_alarm_per_hour: float | None = HOURLY_FALSE_ALARMS

    def keywords(self) -> dict[str, Any]:
        """The keywords of :func:`adavar.adaptive_davar` / :func:`adavar.adaptive_schedule`."""
        return asdict(self)

    @classmethod
    def from_options(cls, options: Any) -> ControllerSettings:
        """From an object with the command line's option names (``segment`` for ``l``).

        ``false_alarm`` None (not given) keeps the per-hour calibration; a per-step
        ``false_alarm`` given replaces it (:func:`threshold_mode`, as the library does).
        """
        values = {f.name: getattr(options, f.name, None) for f in fields(cls) if f.name != "l"}
        if values["false_alarm"] is not None:
            values["false_alarm_per_hour"] = None
        return cls(l=options.segment, **values)


#: the command line's names of the :class:`FitSettings` fields that differ from the field's
FIT_OPTION_NAMES = {"method": "fit_method", "uncertainty": "fit_uncertainty"}


@dataclass(frozen=True)
class FitSettings:
    """The options of :func:`adavar.fit_noise` (see its docstring), with its defaults."""

    terms: tuple[str, ...] | None = None  # None: all five
    n_reweight: int = 3
    spacing: str = "octave"
    method: str = "auto"
    select: str = "aic"
    significance: float = 2.0
    exclude: str = "auto"
    rolloff: str = "model"
    tau_range: tuple[float | None, float | None] | None = None
    bandwidth: float | None = None
    markov: str = "auto"
    #: one-sided level of the upper bound of a term the selection leaves out: a term is
    #: left out when its data happen to lie low, and of those records the 95 % profile
    #: bound covers the truth in 43-66 %, the 99 % one in 87-91 %
    #: (benchmarks/bench_validation.py)
    bound_level: float = 0.99
    #: "conditional": each term's uncertainty given the model chosen; "averaged": with the
    #: doubt of the choice in it (the weight of the models without the term)
    uncertainty: str = "averaged"

    @classmethod
    def from_options(cls, options: Any) -> FitSettings:
        """From an object with the command line's option names (``fit_method`` for
        ``method``, ``fit_uncertainty`` for ``uncertainty``); an option it has not takes
        its default."""
        names = {f.name: FIT_OPTION_NAMES.get(f.name, f.name) for f in fields(cls)}
        values = {field: getattr(options, option) for field, option in names.items()
                  if hasattr(options, option)}  # fmt: skip
        if values.get("terms") is not None:
            values["terms"] = tuple(values["terms"])
        return cls(**values)

    def keywords(self) -> dict[str, Any]:
        """The keywords of :func:`adavar.fit_noise` (``terms`` None: all five)."""
        from adavar.core.terms import TERM_NAMES

        values = asdict(self)
        values["terms"] = TERM_NAMES if self.terms is None else tuple(self.terms)
        return values


#: The settings that calibrated thresholds replace (``thresholds="calibrated"`` computes
#: K1, K2 and S2 for every window length; ``k1``, ``k2``, ``s2`` given are not used).
CALIBRATED_REPLACES = ("k1", "k2", "s2")
#: The settings only calibrated thresholds use (``thresholds="paper"`` ignores them).
CALIBRATED_ONLY = ("false_alarm", "false_alarm_per_hour", "kurtosis_reference", "dependence")
#: The settings only the hourly calibration uses (a per-step ``false_alarm`` ignores them).
HOURLY_ONLY = ("dependence",)
#: The settings only ``s_test="band"`` uses.
BAND_ONLY = ("s1",)
#: Samples a ``chunk_size`` should hold at least: below it, reading and setting up each
#: piece costs more than analysing its samples (``adavar avar`` of 1e5 samples: 0.85 s in
#: memory, 0.90 s at 4096, 1.6 s at 64, 4.0 s at 16, 22 s at 1).
EFFICIENT_CHUNK = 4096

#: Longest window (s) of a stream, whose length is not known (:class:`adavar.OnlineAdaptive`,
#: ``adavar monitor``): a tenth of a 30-minute record, as a record's Lmax is a tenth of it
#: (:func:`adavar.dynamic.adaptive.record_windows`). Lmin and l follow it in the same proportions.
STREAM_LMAX_SECONDS = 180.0
#: Samples the first estimate of the record's short-range correlation reads (hourly
#: thresholds, :func:`adavar.dynamic.adaptive.dependence_stages`): fewer give no estimate
#: (:func:`adavar.dynamic.thresholds.noise_dependence` needs four of its 2048-sample blocks). The
#: estimate is refined on the first 2, 4, ... times as many samples, up to
#: :data:`adavar.dynamic.thresholds.DEPENDENCE_SAMPLES`, offline and live alike.
DEPENDENCE_FIRST = 1 << 13
#: ``sides=`` of :func:`adavar.dynamic.ici.ici_schedule`
ICI_SIDES = ("both", "centred")
#: ``edf=`` of :func:`adavar.dynamic.ici.ici_schedule`
ICI_EDF = ("correlation", "engine")
#: default threshold of the ICI window (benchmarks/bench_ici.py, docs/benchmarks.md): with
#: the default candidates no stationary centre of scenario 1 (40 seeds) nor of the 200 Hz
#: records got a shortened window (below 0.02 % on white and band-limited noise at
#: gamma = 2), about 2 % a one-sided window of full length; the spread of N equals
#: DAVAR-Lmax's (gamma = 2.5: 1.025 x, tracking 3.1 % instead of 3.3 %)
ICI_GAMMA = 3.0
#: samples the live ICI pass (:class:`adavar.OnlineAdaptive`, ``adavar monitor --method
#: ici``) measures its correlation EDF on before its first row (5.5 min at 200 Hz); the
#: offline pass equals it given ``ici_edf_samples`` the same
ICI_EDF_SAMPLES = 1 << 16
#: Default budget of ``--max-memory`` (MB): the surface and what is computed from it.
DEFAULT_MAX_MEMORY_MB = 200
#: More taus than this from ``taus="all"`` and the default becomes ``"log"`` (10 a decade).
MAX_ALL_TAUS = 200
#: densest ``taus="log"``: neighbouring taus then differ by 0.23 %, far less than the
#: confidence interval of any Allan-variance estimate; every factor is ``taus="all"``
MAX_POINTS_PER_DECADE = 1000
#: The Allan-family statistics of :func:`adavar.deviation`.
STATISTICS = ("adev", "oadev", "mdev", "hdev", "ohdev", "tdev", "totdev")
#: every ``stat=`` of :func:`adavar.deviation`: the Allan seven, then the statistics of
#: :mod:`adavar.core.extended_statistics`
ALL_STATISTICS = (
    *STATISTICS,
    *("mtotdev", "ttotdev", "htotdev", "pdev"),
    *("theo1", "theobr", "theoh", "mtie", "tierms"),
)
#: A declared rate and a record's time stamps (a file's time column, a series' time index)
#: agree within this fraction; a time index whose steps differ from their median by more
#: is irregular.
RATE_AGREEMENT = 0.01
#: The sample rates accepted, Hz (sample intervals: their inverses, 1 ps .. about 31,700
#: years). No sensor or clock samples outside them, and far beyond them the taus, the fit's
#: design matrix and the time axis leave float64 (a rate of 1e300 divided by zero in the
#: fit, 1e-300 overflowed, 1e100 failed to converge).
RATE_LIMITS = (1e-12, 1e12)
#: The most samples a generator makes (``n``): 8 GB for the float64 result alone, and the
#: generators hold a few arrays of that size while they work. Longer records exhaust the
#: memory of most machines rather than fail cleanly.
MAX_SAMPLES = 1_000_000_000

#: The paper's controller (read-only): its windows (600, 400, 100 samples) and thresholds,
#: which :func:`adavar.compare` and :mod:`adavar.paper` reproduce; the other keywords'
#: defaults everywhere.
PAPER = ControllerSettings(lmax=600, lmin=400, l=100, thresholds="paper", false_alarm=0.01,
                           false_alarm_per_hour=None)  # fmt: skip
#: The same instance, by its historical name.
CONTROLLER = PAPER
#: The noise fit's defaults everywhere (read-only).
FIT = FitSettings()

_CONTROLLER_OPTIONS = {("segment" if k == "l" else k): v for k, v in asdict(CONTROLLER).items()}
_FIT_OPTIONS = {FIT_OPTION_NAMES.get(k, k): v for k, v in asdict(FIT).items()}


class FileDefault(str):
    """A default the file read may override: equal to its value (``"rate"``), and told
    apart from the same value given (by its type) so that a file's own contradicts only
    a value given."""

    __slots__ = ()


class RateDefault(float):
    """``rate=`` not given: 1 Hz, unless the record's own time index gives its rate (a
    pandas or xarray time axis); equal to 1.0, and told apart from 1.0 given by its type."""

    __slots__ = ()


#: ``rate`` of :func:`adavar.deviation`, :func:`adavar.davar` and
#: :func:`adavar.adaptive_davar` when none is given (:func:`adavar.stats.statistics.resolve_rate`)
RATE_DEFAULT = RateDefault(1.0)

#: ``data_type`` (``--data-type``) when none is given: rate data, unless the file says
#: otherwise (a Stable32 ``.phd`` file holds phase: :func:`adavar.readers.file_data_type`)
DATA_TYPE_DEFAULT = FileDefault("rate")

#: Every analysis option of ``adavar report`` and ``adavar batch``, by the flags' names.
ANALYSIS_DEFAULTS: dict[str, Any] = {
    # the record (adavar.readers.read_record) and its preprocessing
    "column": None, "rate": None, "tau0": None, "units": None, "data_type": DATA_TYPE_DEFAULT,
    "time_column": None, "time_format": "auto", "gaps": "error", "gap_tolerance": 0.5,
    "nan": "error", "lazy": None, "dataset": None, "topic": None, "preprocess": None,
    # the analysis
    "taus": "octave", "window": None, "adaptive": False, "step": 1,
    **_CONTROLLER_OPTIONS,
    # the windows follow the record (adavar.pipeline.analysis.resolve_lengths) unless given
    "lmax": None, "lmin": None, "segment": None,
    # thresholds for a rate of false events per stationary hour (issue 13), unless
    # --thresholds paper or a per-step --false-alarm is given
    "thresholds": THRESHOLDS, "false_alarm": None, "false_alarm_per_hour": HOURLY_FALSE_ALARMS,
    **_FIT_OPTIONS,
}  # fmt: skip


def threshold_mode(
    thresholds: str, false_alarm: float | None, false_alarm_per_hour: float | None
) -> tuple[str, float, float | None]:
    """The controller's thresholds from the three keywords of :func:`adavar.adaptive_davar`.

    ``thresholds="calibrated"`` (the default, :data:`THRESHOLDS`) calibrates for
    ``false_alarm_per_hour`` false events per stationary hour; a per-step ``false_alarm``
    given instead (or ``false_alarm_per_hour=None``) calibrates for that many false alarms
    per step (what ``thresholds="calibrated"`` alone meant before 0.2). ``"paper"`` uses
    ``k1``, ``k2``, ``s2`` as given.

    Returns
    -------
    thresholds, false_alarm, false_alarm_per_hour
        ``false_alarm`` a number (the paper's 0.01 when not given), ``false_alarm_per_hour``
        None unless the per-hour calibration is in force.
    """
    if false_alarm is not None:
        false_alarm_per_hour = None  # a per-step rate given replaces the per-hour default
    else:
        false_alarm = PAPER.false_alarm
    if thresholds != "calibrated":
        false_alarm_per_hour = None
    return thresholds, false_alarm, false_alarm_per_hour


def requested_threads() -> int | None:
    """``ADAVAR_THREADS`` as a thread count, or None when it is unset (without Numba).

    :func:`adavar._kernels._jit.thread_setting` applies it to Numba; the text reader's threads
    (:func:`adavar.readers.textscan.parse_threads`) read it here, so reading a file does
    not import Numba.

    Raises
    ------
    AdavarInputError
        When it is set to anything but a positive whole number.
    """
    import os

    text = os.environ.get("ADAVAR_THREADS", "").strip()
    if not text:
        return None
    try:
        count = int(text)
    except ValueError:
        count = 0
    if count < 1:
        from adavar.core.errors import AdavarInputError

        raise AdavarInputError(
            f"ADAVAR_THREADS={text!r} is not a positive whole number: give e.g. "
            "ADAVAR_THREADS=1, or unset it for every core"
        )
    return count

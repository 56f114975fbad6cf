"""Typed analysis requests: what to read and what to compute, as settings objects built once.

A command builds one :class:`AnalysisRequest` from its flags
(:meth:`AnalysisRequest.from_options`) and hands it to :func:`adavar.pipeline.analysis.run`; a
script builds the same objects directly. The request is made of

- :class:`RecordRequest`: the file, its channels, rate or tau0, unit (or a unit per group of
  channels, :class:`UnitGroup`), data type and the reader's policies (gaps, NaN,
  preprocessing, pieces);
- :class:`DeviationSettings`: the whole record's statistic and its intervals;
- :class:`WindowSettings`: the DAVAR window (fixed length or adaptive), its taus and
  centres, the per-cell statistic and bounds;
- :class:`adavar.core.settings.ControllerSettings`: the adaptive window's lengths and thresholds
  (:data:`ANALYSIS_CONTROLLER` by default: windows from the record, thresholds calibrated
  per stationary hour, as the library's :func:`adavar.adaptive_davar`);
- :class:`adavar.core.settings.FitSettings`: the noise fit's options;
- :class:`MethodOptions`: the adaptive method, its change times, the calibration's
  correlation and kurtosis reference, and the ICI options.

The objects are frozen: resolving durations or the record's windows gives a new request
(:meth:`AnalysisRequest.with_lengths`), the one given is never changed.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, fields
from types import SimpleNamespace
from typing import Any

from adavar.core.errors import AdavarInputError
from adavar.core.settings import (
    ANALYSIS_DEFAULTS,
    DATA_TYPE_DEFAULT,
    DEFAULT_MAX_MEMORY_MB,
    FIT,
    FIT_OPTION_NAMES,
    ICI_GAMMA,
    ControllerSettings,
    FitSettings,
)

__all__ = [
    "ANALYSIS_CONTROLLER",
    "AnalysisRequest",
    "DeviationSettings",
    "MethodOptions",
    "RecordRequest",
    "UnitGroup",
    "WindowSettings",
    "settings_keywords",
]


@dataclass(frozen=True)
class UnitGroup:
    """Channels that share one declared unit, and the flag that declares it.

    A record of two sensors (``adavar kalibr``: three gyro and three accelerometer axes)
    declares a unit for each: ``RecordRequest(unit_groups=(UnitGroup(("gx", "gy", "gz"),
    "rad/s", "--gyro-units"), UnitGroup(("ax", "ay", "az"), "m/s^2", "--accel-units")))``.

    Attributes
    ----------
    columns : tuple of str
        The channels.
    units : str or None
        Their unit (None: the one the file declares for the group's first channel, as a
        ROS bag does).
    flag : str
        The option named in an error about it.
    example : str
        Units named as examples when none is declared.
    """

    columns: tuple[str, ...]
    units: str | None = None
    flag: str = "--units"
    example: str = "deg/s"

    def __post_init__(self) -> None:
        if isinstance(self.columns, str) or not self.columns:
            raise AdavarInputError(
                f"UnitGroup(columns=...) takes a tuple of column names, got {self.columns!r}"
            )
        object.__setattr__(self, "columns", tuple(str(c) for c in self.columns))


@dataclass(frozen=True)
class RecordRequest:
    """The record to read (:func:`adavar.pipeline.analysis.read_input`).

    Attributes
    ----------
    file : str
        The file (any format of :func:`adavar.readers.read_record`).
    column : str, list of str or None
        The channel (or several: a list, or names separated by commas); None: the file's
        only channel (or every numeric one where the command analyses them all).
    rate, tau0 : float or None
        The declared sample rate (Hz) or interval (s): at most one; neither: the file's
        time stamps.
    units : str or None
        The samples' unit (None: the file's own, as a ROS bag declares it).
    unit_groups : tuple of UnitGroup
        A unit per group of channels instead of one ``units`` (empty: ``units`` for all).
    data_type : {"rate", "phase"}
        Rate samples or their integral (a Stable32 ``.phd`` file says phase).
    time_column, time_format, gap_tolerance, lazy, dataset, topic
        The reader's options (:func:`adavar.readers.read_record`).
    gaps : {"error", "interpolate", "split", "omit"}
        A gap in the time stamps: an error, filled, the pieces apart, or (``"omit"``) its
        missing samples and NaN cells left out of every statistic.
    nan : {"error", "drop", "interpolate", "keep"}
        NaN or empty cells.
    preprocess : str or None
        Preprocessing steps (:func:`adavar.io.preprocess.preprocess`).
    chunk_size : int or None
        Samples a piece when the record is read piece by piece (None: adavar's choice).
    """

    file: str
    column: Any = None
    rate: float | None = None
    tau0: float | None = None
    units: str | None = None
    data_type: str = DATA_TYPE_DEFAULT
    time_column: str | None = None
    time_format: str = "auto"
    gaps: str = "error"
    gap_tolerance: float = 0.5
    nan: str = "error"
    lazy: bool | None = None
    dataset: str | None = None
    topic: str | None = None
    preprocess: Any = None
    chunk_size: int | None = None
    unit_groups: tuple[UnitGroup, ...] = ()

    def __post_init__(self) -> None:
        groups = tuple(self.unit_groups or ())
        if not all(isinstance(g, UnitGroup) for g in groups):
            raise AdavarInputError("RecordRequest(unit_groups=...) takes UnitGroup objects")
        if groups and self.units is not None:
            raise AdavarInputError(
                f"units={self.units!r} and unit_groups both declare the units: give one of them"
            )
        object.__setattr__(self, "unit_groups", groups)

    @classmethod
    def from_options(cls, options: Any) -> RecordRequest:
        """From an options object or mapping with the flags' names (``file`` needed)."""
        options = _namespace(options)
        if getattr(options, "file", None) is None:
            raise AdavarInputError("an analysis needs a file: give its path")
        return cls(**{**_pick(cls, options), "file": str(options.file)})

    def reader_gaps(self) -> tuple[str, str]:
        """``gaps`` and ``nan`` as the reader takes them: ``gaps="omit"`` reads missing
        time stamps as NaN rows and keeps NaN cells (unless ``nan`` drops or fills them),
        for the statistics to leave out."""
        if self.gaps != "omit":
            return self.gaps, self.nan
        return "nan", "keep" if self.nan == "error" else self.nan

    @property
    def omit(self) -> str:
        """``gaps=`` of the statistics: ``"omit"`` with ``gaps="omit"``, else ``"error"``."""
        return "omit" if self.gaps == "omit" else "error"

    def chunk_keywords(self) -> dict[str, Any]:
        """``chunk_size`` for the library, only when one is given."""
        return {} if self.chunk_size is None else {"chunk_size": self.chunk_size}


@dataclass(frozen=True)
class DeviationSettings:
    """The whole record's statistic (:func:`adavar.deviation`), with its defaults.

    Attributes
    ----------
    stat : str
        The statistic (``"oadev"``, ``"mdev"``, ..., ``"theo1"``, ``"mtie"``).
    taus, confidence, points_per_decade, noise_id, totdev_edf, totdev_bias,
    bias_correction, theo_ratio_terms, total_edf, stationarity_check
        As :func:`adavar.deviation` takes them.
    """

    stat: str = "oadev"
    taus: Any = "octave"
    confidence: float | None = 0.683
    points_per_decade: int = 10
    noise_id: str = "sp1065"
    totdev_edf: str = "sp1065"
    totdev_bias: bool = False
    bias_correction: bool | None = None
    theo_ratio_terms: int | None = None
    total_edf: str | None = None
    stationarity_check: bool = True

    @classmethod
    def from_options(cls, options: Any) -> DeviationSettings:
        """From the flags of ``adavar avar`` (an option not present takes its default).

        Not part of :meth:`AnalysisRequest.from_options`: ``--stat``, ``--taus``,
        ``--confidence`` and ``--points-per-decade`` of ``davar`` and ``report`` are the
        surface's (:class:`WindowSettings`).
        """
        return cls(**_pick(cls, _namespace(options)))

    def keywords(self) -> dict[str, Any]:
        """The keywords of :func:`adavar.deviation`."""
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class WindowSettings:
    """The DAVAR surface to compute (none: ``window`` None and ``adaptive`` False).

    Attributes
    ----------
    window : int, str or None
        A fixed window: samples, or a duration such as ``"10min"``.
    adaptive : bool
        The adaptive window (:class:`~adavar.core.settings.ControllerSettings`,
        :class:`MethodOptions`).
    taus : str, sequence or None
        Taus of the surface (None: chosen to fit ``max_memory``,
        :func:`adavar.dynamic.adaptive.surface_resolution`).
    step : int, str or None
        Centres every ``step`` samples (or a duration; None: chosen to fit ``max_memory``).
    max_memory : float
        MB the surfaces may take when ``taus`` or ``step`` is left to adavar.
    stat : {"oavar", "ohvar", "mvar"}
        The variance of every window.
    edges, confidence, points_per_decade, noise_type, t0, edge_edf
        As :func:`adavar.davar` takes them (``confidence`` None: no bounds, no fit).
    """

    window: Any = None
    adaptive: bool = False
    taus: Any = "octave"
    step: Any = 1
    max_memory: float = DEFAULT_MAX_MEMORY_MB
    stat: str = "oavar"
    edges: str = "mirror"
    confidence: float | None = 0.683
    points_per_decade: int = 10
    noise_type: Any = "record"
    t0: float = 0.0
    edge_edf: str = "distinct"

    def __post_init__(self) -> None:
        if self.adaptive and self.window is not None:
            raise AdavarInputError(
                f"window={self.window!r} asks for a fixed window and adaptive=True for the "
                "adaptive one: give one of them (the adaptive window's lengths are the "
                "controller's lmax and lmin)"
            )

    @property
    def surface(self) -> bool:
        """Whether a DAVAR surface is asked for."""
        return self.adaptive or self.window is not None

    def keywords(self) -> dict[str, Any]:
        """The keywords :func:`adavar.davar` and :func:`adavar.adaptive_davar` share."""
        return dict(taus=self.taus, step=self.step, edges=self.edges,
                    confidence=self.confidence, points_per_decade=self.points_per_decade,
                    noise_type=self.noise_type, t0=self.t0,
                    edge_edf=self.edge_edf)  # fmt: skip


@dataclass(frozen=True)
class MethodOptions:
    """The adaptive method and its options (:func:`adavar.adaptive_davar`).

    Attributes
    ----------
    method : {"adaptive", "kurtosis", "oracle", "fixed", "ici"}
        The controller (docs/method.md sections 8 and 11).
    change_times : sequence of float or None
        Known change times (s), for ``"oracle"``.
    dependence : sequence of float or None
        The record's short-range correlation for the hourly thresholds (None: measured).
    kurtosis_reference : str or dict
        What the kurtosis tests compare with (``"record"``: its own stationary noise).
    ici_gamma, ici_lengths, ici_taus, ici_sides, ici_edf, ici_edf_samples, ici_kurtosis,
    ici_episodes, ici_long_tau
        The options of ``method="ici"`` (:func:`adavar.dynamic.ici.ici_schedule`).
    """

    method: str = "adaptive"
    change_times: Sequence[float] | None = None
    dependence: Sequence[float] | None = None
    kurtosis_reference: Any = "record"
    ici_gamma: float = ICI_GAMMA
    ici_lengths: Sequence[int] | None = None
    ici_taus: Sequence[int] = (1,)
    ici_sides: str = "both"
    ici_edf: str = "correlation"
    ici_edf_samples: int | None = None
    ici_kurtosis: bool = True
    ici_episodes: bool = True
    ici_long_tau: bool = True

    @classmethod
    def from_options(cls, options: Any) -> MethodOptions:
        """From an options object or mapping with the flags' names (an option not present
        takes its default)."""
        return cls(**_pick(cls, _namespace(options)))

    def keywords(self) -> dict[str, Any]:
        """The keywords of :func:`adavar.adaptive_davar`."""
        return dataclasses.asdict(self)


def _namespace(options: Any) -> Any:
    if options is None:
        return SimpleNamespace()
    if isinstance(options, Mapping):
        return SimpleNamespace(**{str(k).replace("-", "_"): v for k, v in options.items()})
    return options


def _pick(cls: type, options: Any, rename: Mapping[str, str] | None = None) -> dict[str, Any]:
    """The fields of ``cls`` that ``options`` has (by the flags' names)."""
    rename = rename or {}
    out = {}
    for f in fields(cls):
        name = rename.get(f.name, f.name)
        if hasattr(options, name):
            out[f.name] = getattr(options, name)
    return out


_CONTROLLER_NAMES = [("segment" if f.name == "l" else f.name) for f in fields(ControllerSettings)]

#: Every option name :meth:`AnalysisRequest.from_options` reads (the flags' names).
_OPTION_NAMES = frozenset(
    {f.name for cls in (RecordRequest, WindowSettings, MethodOptions) for f in fields(cls)}
    | {("segment" if f.name == "l" else f.name) for f in fields(ControllerSettings)}
    | {FIT_OPTION_NAMES.get(f.name, f.name) for f in fields(FitSettings)}
    | {"windows_from"}
)

#: The adaptive window of an analysis when none is given: ``ControllerSettings()``, windows
#: from the record, thresholds calibrated for :data:`adavar.core.settings.HOURLY_FALSE_ALARMS`
#: false events per stationary hour (the library's and every command's but ``compare``).
ANALYSIS_CONTROLLER = ControllerSettings()


@dataclass(frozen=True)
class AnalysisRequest:
    """One analysis of one file: :func:`adavar.pipeline.analysis.run` computes it.

    Attributes
    ----------
    record : RecordRequest
    window : WindowSettings
    deviation : DeviationSettings
        The whole record's statistic (``adavar avar``; the report's is the default, the
        overlapping Allan deviation at octave taus).
    controller : ControllerSettings
    fit : FitSettings
    method_options : MethodOptions
    windows_from : str or None
        Where the adaptive window's lengths came from once resolved (``"flags"``,
        ``"lmax"``, ``"record"``; None before).
    """

    record: RecordRequest
    window: WindowSettings = WindowSettings()
    deviation: DeviationSettings = DeviationSettings()
    controller: ControllerSettings = ANALYSIS_CONTROLLER
    fit: FitSettings = FIT
    method_options: MethodOptions = MethodOptions()
    windows_from: str | None = None

    def __post_init__(self) -> None:
        for name, kind in _PARTS.items():
            value = getattr(self, name)
            if not isinstance(value, kind):
                raise AdavarInputError(
                    f"AnalysisRequest({name}=...) takes a {kind.__name__}, not "
                    f"{type(value).__name__}: e.g. {name}=adavar.{kind.__name__}(...)"
                )

    @classmethod
    def from_options(cls, options: Any) -> AnalysisRequest:
        """The request of a command's options (an ``argparse.Namespace`` or a mapping with
        the flags' destination names: ``segment`` for ``l``, ``fit_method`` and
        ``fit_uncertainty`` for the fit's ``method`` and ``uncertainty``); an option not
        present takes its default.

        A mapping may hold only those names (a typo is an error, not a default); a
        namespace carries the command's other flags too, which are not the request's.

        Raises
        ------
        AdavarInputError
            No ``file``, or a mapping with a name that is no option of the request.
        """
        if isinstance(options, Mapping):
            unknown = sorted(str(k) for k in options
                             if str(k).replace("-", "_") not in _OPTION_NAMES)  # fmt: skip
            if unknown:
                raise AdavarInputError(
                    f"unknown analysis option {unknown[0]!r}: use the names of the flags "
                    f"({', '.join(sorted(_OPTION_NAMES))})"
                )
        options = _namespace(options)
        record = RecordRequest.from_options(options)
        window = WindowSettings(**_pick(WindowSettings, options))
        # a controller option not given takes the analysis default (windows from the
        # record, hourly thresholds), as on the command line
        base = {k: ANALYSIS_DEFAULTS[k] for k in _CONTROLLER_NAMES}
        base.update(_pick(ControllerSettings, options, {"l": "segment"}))
        base["segment"] = base.pop("l", ANALYSIS_DEFAULTS["segment"])
        controller = ControllerSettings.from_options(SimpleNamespace(**base))
        fit = FitSettings.from_options(options)
        method = MethodOptions.from_options(options)
        return cls(record=record, window=window, controller=controller, fit=fit,
                   method_options=method,
                   windows_from=getattr(options, "windows_from", None))  # fmt: skip

    def with_lengths(self, **lengths: Any) -> AnalysisRequest:
        """A copy with ``window``, ``step``, ``taus`` (the window's) and ``lmax``, ``lmin``,
        ``l`` (the controller's) replaced, and ``windows_from`` if given."""
        window = {k: lengths.pop(k) for k in ("window", "step", "taus") if k in lengths}
        windows_from = lengths.pop("windows_from", self.windows_from)
        return dataclasses.replace(
            self, window=dataclasses.replace(self.window, **window),
            controller=dataclasses.replace(self.controller, **lengths),
            windows_from=windows_from,
        )  # fmt: skip

    def options(self) -> SimpleNamespace:
        """Every setting by the flags' names, flat (for the report's parameter table)."""
        flat = {**dataclasses.asdict(self.deviation), **dataclasses.asdict(self.record),
                **dataclasses.asdict(self.window)}  # fmt: skip
        flat.update({("segment" if k == "l" else k): v
                     for k, v in dataclasses.asdict(self.controller).items()})  # fmt: skip
        flat.update({FIT_OPTION_NAMES.get(k, k): v
                     for k, v in dataclasses.asdict(self.fit).items()})  # fmt: skip
        flat.update(dataclasses.asdict(self.method_options))
        flat["windows_from"] = self.windows_from
        return SimpleNamespace(**flat)


def settings_keywords(
    function: Callable[..., Any],
    given: Mapping[str, Any],
    *objects: tuple[Any, type],
    inapplicable: Collection[str] = (),
) -> dict[str, Any]:
    """A function's keywords with the fields of settings objects filled in.

    The thin keyword layer of the functions that take settings objects
    (:func:`adavar.adaptive_davar` ``settings=`` and ``method_options=``,
    :func:`adavar.fit_noise` ``settings=``): ``given`` are the keywords the caller passed
    (their values, defaults included); ``objects`` are ``(object, its class)`` pairs (None:
    not given), and each object's fields (its ``keywords()`` if it has one) replace the
    keywords of the same names. A field the function does not take must be None, or (the
    names in ``inapplicable``, options that mean nothing there) keep its default.

    Raises
    ------
    AdavarInputError
        An object of another class, or a keyword given both with a value of its own and in
        a settings object (ambiguous: give it once).
    """
    parameters = inspect.signature(function).parameters
    out = dict(given)
    for obj, kind in objects:
        if obj is None:
            continue
        if not isinstance(obj, kind):
            raise AdavarInputError(
                f"expected a {kind.__name__}, got {type(obj).__name__}: build one (e.g. "
                f"adavar.{kind.__name__}(...)) or give the keywords"
            )
        values = obj.keywords() if hasattr(obj, "keywords") else dataclasses.asdict(obj)
        defaults = {f.name: f.default for f in fields(obj)}
        for name, value in values.items():
            if name not in parameters:  # an option this function has not (change_times live)
                if value is None or (name in inapplicable and _same(value, defaults[name])):
                    continue
                way_out = "None" if name not in inapplicable else repr(defaults[name])
                raise AdavarInputError(
                    f"{name}={value!r} of the {type(obj).__name__} is not an option of "
                    f"{function.__qualname__.removesuffix('.__init__')}: set it to {way_out}"
                )
            default = parameters[name].default
            mine = given.get(name, default)
            if mine is not default and not _same(mine, default) and not _same(mine, value):
                raise AdavarInputError(
                    f"{name} is given both as a keyword ({mine!r}) and in the "
                    f"{type(obj).__name__} ({value!r}): give it once"
                )
            out[name] = value
    return out


def _same(a: Any, b: Any) -> bool:
    try:
        return bool(a == b)
    except (TypeError, ValueError):  # arrays: not a setting's value
        return False


#: The parts of an :class:`AnalysisRequest` and their classes.
_PARTS = {
    "record": RecordRequest,
    "window": WindowSettings,
    "deviation": DeviationSettings,
    "controller": ControllerSettings,
    "fit": FitSettings,
    "method_options": MethodOptions,
}

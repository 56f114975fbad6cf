"""The adaptive DAVAR (A-DAVAR): the DAVAR surface on the adaptive window's schedule.

:func:`adaptive_davar` runs the window controller (:mod:`adavar.dynamic.schedule`, docs/method.md
section 8: a window's length shrinks where its kurtosis or the sliding kurtosis contribution
of its leading edge says the noise changed, and regrows where it is stationary) and computes
the surface on that schedule with :func:`adavar.davar`, the one place where a DAVAR surface
is computed; :func:`adaptive_blocks` does it a block of windows at a time, and
:func:`false_alarm_rate` measures the controller's false alarms on stationary noise.

Methods (:data:`METHODS`): ``"adaptive"`` (A-DAVAR), ``"kurtosis"`` (DAVAR-K), ``"oracle"``
(known change times), ``"fixed"`` (DAVAR-L) and ``"ici"`` (intersecting confidence
intervals, :mod:`adavar.dynamic.ici`). Out of core, the controller streams the record and
each block of the surface reads its windows' span.
"""

from __future__ import annotations

import inspect
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from adavar.core.durations import Length, to_samples
from adavar.core.errors import AdavarInputError
from adavar.core.inputs import DATA_TYPE_ALIASES, as_samples, refuse_masked
from adavar.core.request import MethodOptions, settings_keywords
from adavar.core.results import DavarResult
from adavar.core.settings import (
    CONTROLLER,
    HOURLY_FALSE_ALARMS,
    ICI_GAMMA,
    RATE_DEFAULT,
    THRESHOLDS,
    ControllerSettings,
)
from adavar.dynamic.controller import check_whole
from adavar.dynamic.events import Event
from adavar.dynamic.schedule import (
    METHODS,
    Schedule,
    adaptive_schedule,
    record_size,
    window_lengths,
)
from adavar.dynamic.surface import davar, davar_blocks
from adavar.dynamic.thresholds import calibrated_thresholds
from adavar.dynamic.window_defaults import (
    dependence_stages,
    record_windows,
    resolve_windows,
    surface_resolution,
)
from adavar.dynamic.windows import oracle_schedule
from adavar.io import sources
from adavar.io.sampling import resolve_rate
from adavar.io.sources import ChunkedSource

__all__ = [
    "METHODS",
    "AdaptiveResult",
    "Schedule",
    "adaptive_blocks",
    "adaptive_davar",
    "adaptive_schedule",
    "calibrated_thresholds",
    "dependence_stages",
    "false_alarm_rate",
    "oracle_schedule",
    "record_windows",
    "resolve_windows",
    "surface_resolution",
    "window_lengths",
]

# ---------------------------------------------------------------------------------------
# the surface


@dataclass(frozen=True, eq=False)
class AdaptiveResult(DavarResult):
    """A DAVAR surface computed on an adaptive (or oracle/fixed) window schedule.

    All the fields of :class:`adavar.core.results.DavarResult` (``window`` is the schedule),
    plus the controller's per-centre record.

    Attributes
    ----------
    kurtosis, s : ndarray
        Kurtosis of each centre's window and the S coefficient of its last ``l`` samples.
    f1, f2, f : ndarray of bool
        The controller's flags (see :class:`Schedule`).
    method : str
        ``"adaptive"``, ``"kurtosis"``, ``"oracle"``, ``"fixed"`` or ``"ici"``.
    parameters : dict
        Every controller setting used.
    events : list of Event
        The non-stationary stretches ``adavar adaptive`` reports (see :attr:`events`).
    """

    kurtosis: np.ndarray | None = None
    s: np.ndarray | None = None
    f1: np.ndarray | None = None
    f2: np.ndarray | None = None
    f: np.ndarray | None = None
    method: str = "adaptive"
    parameters: dict[str, Any] = field(default_factory=dict)

    @property
    def events(self) -> list[Event]:
        """The non-stationary stretches of the record, as ``adavar adaptive`` reports them.

        The change times are those of :func:`adavar.dynamic.events.find_events` on this schedule
        (for ``method="ici"``: its steps, ramps and long-tau changes,
        :func:`adavar.dynamic.ici_events.ici_events`), the same as the command's on the same record
        and settings. Each stretch's ``before``, ``during`` and ``after`` summaries
        need every window's noise coefficients: on first access the noise model is fitted
        to every window (``fit_noise(self, cells=False)``, all five terms; about 1 s per
        100 000 windows), then kept. The command's summaries use the same fit with the
        whole record's full-covariance fit as the reference of a sensor's roll-off: on data
        with a roll-off they can differ slightly; :meth:`events_with` takes any fit (e.g.
        ``fit_noise(result, terms=("angle_random_walk",))``, faster). A surface without
        confidence bounds (``confidence=None``, ``bounds=False``) cannot be fitted: its
        events have empty summaries.
        """
        found = self._cache.get("events")
        if found is None:
            found = self._cache["events"] = self.events_with(None)
        return list(found)

    def events_with(self, fit: Any = None) -> list[Event]:
        """:attr:`events` with the summaries of ``fit`` (a fit of this result's windows,
        :func:`adavar.fit_noise`), or of the default fit when None."""
        from adavar.dynamic.events import find_events
        from adavar.fit.noise_model import fit_noise

        if fit is None and self.edf_table is not None:
            fit = fit_noise(self, cells=False)
        terms = {} if fit is None else {name: fit.term(name).value for name in fit.terms}
        time = np.asarray(self.time, dtype=float)
        t0 = float(time[0] - self.centre[0] * self.tau0) if time.size else 0.0
        if self.method == "ici":  # its own steps, ramps and long-tau changes
            from adavar.dynamic.ici_events import ici_events

            return ici_events(
                self.window, self.centre, time, int(self.parameters["lmax"]), self.tau0,
                terms, t0=t0, duration=t0 + self.n_samples * self.tau0,
                parameters=self.parameters,
            )  # fmt: skip
        changes = None
        # the episodes are classified by N; with nothing fitted, by each window's
        # shortest-tau Allan deviation (the same ratios for white noise)
        level = "angle_random_walk" if "angle_random_walk" in terms else np.sqrt(self.avar[:, 0])
        return find_events(
            self.window, self.centre, time, int(self.parameters["lmax"]), self.tau0, terms,
            t0=t0, duration=t0 + self.n_samples * self.tau0, changes=changes, level=level,
        )  # fmt: skip


def adaptive_davar(
    data: Sequence[float] | np.ndarray | ChunkedSource,
    *,
    rate: float = RATE_DEFAULT,
    method: str = "adaptive",
    lmax: Length | None = None,
    lmin: Length | None = None,
    k1: float = CONTROLLER.k1,
    k2: float = CONTROLLER.k2,
    s1: float = CONTROLLER.s1,
    s2: float = CONTROLLER.s2,
    l: Length | None = None,  # noqa: E741 - the paper's name
    dl0: int = CONTROLLER.dl0,
    dl1: int = CONTROLLER.dl1,
    s_test: str = CONTROLLER.s_test,
    combine: str = CONTROLLER.combine,
    taus: str | Sequence[float] | np.ndarray | None = None,
    edges: str = "mirror",
    change_times: Sequence[float] | None = None,
    thresholds: str = THRESHOLDS,
    false_alarm: float | None = None,
    step: Length | None = None,
    confidence: float | None = 0.683,
    data_type: str = "rate",
    tau0: float | None = None,
    t0: float = 0.0,
    points_per_decade: int = 10,
    noise_type: str | int | Sequence[int] = "record",
    units: str | None = None,
    chunk_size: int | None = None,
    edge_edf: str = "distinct",
    false_alarm_per_hour: float | None = HOURLY_FALSE_ALARMS,
    ici_gamma: float = ICI_GAMMA,
    ici_lengths: Sequence[int] | None = None,
    ici_taus: Sequence[int] = (1,),
    ici_sides: str = "both",
    ici_edf: str = "correlation",
    ici_edf_samples: int | None = None,
    ici_kurtosis: bool = True,
    ici_episodes: bool = True,
    ici_long_tau: bool = True,
    bounds: bool = True,
    dependence: Sequence[float] | None = None,
    kurtosis_reference: str | dict = "record",
    settings: ControllerSettings | None = None,
    method_options: MethodOptions | None = None,
) -> AdaptiveResult:
    """Dynamic Allan variance with the adaptive window of the paper (A-DAVAR), or a baseline.

    Parameters
    ----------
    data : array_like, ChunkedSource, numpy.memmap or dask.array.Array
        The record (rate samples, or phase with ``data_type="phase"``). A source
        (:mod:`adavar.stats.stream`), a memory map of a ``.npy`` file (``np.load(path,
        mmap_mode="r")``) or a dask array is processed out of core.
    rate : float, optional
        Sample rate in Hz (or give ``tau0``). By default that of the time index of a pandas
        Series or xarray DataArray, else 1 Hz, as in :func:`adavar.deviation`
        (:func:`adavar.stats.statistics.resolve_rate`).
    method : {"adaptive", "kurtosis", "oracle", "fixed", "ici"}
        ``"adaptive"``: A-DAVAR, docs/method.md section 8 (``f = f1 combine f2``);
        ``"kurtosis"``: DAVAR-K (``f = f1``); ``"oracle"``: the ideal schedule for
        ``change_times``; ``"fixed"``: DAVAR-``lmax`` (kurtosis and flags recorded along);
        ``"ici"``: the intersection-of-confidence-intervals rule (docs/method.md section
        11, :mod:`adavar.dynamic.ici`), in memory only; the controller's settings (``k1`` ..
        ``false_alarm_per_hour``) are not used, ``kurtosis``/``s`` are NaN, ``f1``/``f2``
        False, ``f`` the centres whose window is not the centred ``lmax`` one, ``shift``
        the one-sided windows, ``parameters["ici_changes"]`` the detected changes
        (samples).
    lmax, lmin : int, str, Duration or timedelta, optional
        Longest (start) and shortest window: samples (paper: 600, 400), or durations
        (``"10min"``, :func:`adavar.seconds`), rounded to whole samples of this record (a
        duration ``lmin`` to the nearest length of ``lmax``'s parity). Default, as
        ``adavar adaptive``: Lmax a tenth of the record and Lmin two thirds of Lmax
        (:func:`record_windows`: the paper's 600 and 400 of its 6000-sample record); given
        ``lmax`` alone, Lmin (and ``l``) follow it. Before 0.2 the default was the
        paper's 600 and 400 samples on any record: give ``lmax=600, lmin=400, l=100``.
    k1, k2 : float
        Kurtosis band of a stationary window (Eq. 16; paper: 2.5, 3.3).
    s1, s2 : float
        S thresholds (Eq. 17; paper: 0, 0.07); ``s1`` is used by ``s_test="band"`` only.
    l : int, str, Duration or timedelta, optional
        Leading segment of the S test: samples (paper: 100) or a duration; default a sixth
        of Lmax.
    dl0, dl1 : int
        Regrow and shrink steps (paper: 2, 2); even, so the parity of ``L`` is kept.
    s_test : {"upper", "band", "abs"}
        The paper's ambiguous f2 test (docs/method.md section 8): ``"upper"`` (default) flags
        ``S > s2``; ``"band"`` (the literal reading) flags ``S`` outside ``[s1, s2]``, which
        fires on about half of all stationary windows; ``"abs"`` flags ``|S| > s2``.
    combine : {"or", "and"}
        ``f = f1 or f2`` (default, reproduces the paper's nodes) or ``f1 and f2``.
    taus, edges, step, confidence, data_type, tau0, t0, points_per_decade, noise_type, units
        As in :func:`adavar.davar`. With ``edges="valid"`` the controller runs on the
        centres whose ``lmax`` window fits in the record. ``taus`` and ``step`` not given
        are chosen as ``adavar adaptive`` chooses them (:func:`surface_resolution`):
        ``"all"`` up to 200 taus, else ``"log"``; every centre while the surface fits the
        default ``--max-memory`` (200 MB at 32 bytes a cell), else every ``step``-th
        (before 0.2: ``taus="all"``, ``step=1``).
    change_times : sequence of float, optional
        Known change times (seconds from the first sample) for ``method="oracle"``.
    thresholds : {"calibrated", "paper"}
        ``"calibrated"`` (default, as every command but ``compare``): per-length thresholds
        for ``false_alarm_per_hour`` false events per hour of stationary data, or (given
        ``false_alarm``) for a per-step false-alarm rate on stationary Gaussian noise
        (:func:`calibrated_thresholds`); ``"paper"``: ``k1, k2, s2`` as given (the default
        before 0.2; with the paper's 600-sample window they flag white noise every few
        seconds at 100 Hz).
    false_alarm : float, optional
        A per-step false-alarm rate for ``thresholds="calibrated"`` instead of the per-hour
        one (:func:`adavar.core.settings.threshold_mode`; ``thresholds="calibrated"`` alone meant
        0.01 per step before 0.2).
    false_alarm_per_hour : float or None
        With ``thresholds="calibrated"``: false events per hour of stationary data
        (default 0.1, :data:`adavar.core.settings.HOURLY_FALSE_ALARMS`;
        :func:`adavar.dynamic.thresholds.hourly_thresholds`, taking the record's short-range
        correlation into account: see ``dependence``); None: per step.
        ``parameters["thresholds_used"]`` records ``K1``, ``K2``, ``S2`` at ``Lmax`` and
        ``Lmin``.
    chunk_size : int, optional
        Process the record out of core, about ``chunk_size`` samples at a time (default
        :data:`adavar.stats.stream.DEFAULT_CHUNK` for a chunked input; give it to stream an
        in-memory array). The controller carries its window length from piece to piece
        (:func:`adaptive_schedule`) and keeps only the ``step``-th centres' lengths, which go
        to ``davar(..., chunk_size=chunk_size)``; the result equals the in-memory one (same
        schedule, surface to rounding). Held in memory: a piece and its overlap, and the
        ``N / step`` rows of the result; never a per-sample array.

    edge_edf : {"distinct", "interior"}
        EDF of a window that reaches into the mirrored extension, see :func:`adavar.davar`.
    ici_gamma : float
        ``method="ici"``: half-width of the intervals in standard normal units (default
        :data:`adavar.core.settings.ICI_GAMMA`; smaller shortens more readily).
    ici_lengths : sequence of int, optional
        ``method="ici"``: the candidate lengths (samples), holding ``lmin`` and ending at
        ``lmax``; those below ``lmin`` are probes. Default
        :func:`adavar.dynamic.ici.ici_candidates`.
    ici_taus : sequence of int
        ``method="ici"``: averaging factors of the estimates (default ``(1,)``).
    ici_sides : {"both", "centred"}
        ``method="ici"``: one-sided windows next to a change (default) or centred only.
    ici_edf : {"correlation", "engine"}
        ``method="ici"``: the estimates' EDF from the record's correlation (default) or the
        engine's Greenhall EDF.
    ici_edf_samples : int, optional
        ``method="ici"``, ``ici_edf="correlation"``: measure the correlation on the first
        ``ici_edf_samples`` samples only (what :class:`adavar.OnlineAdaptive` knows when it
        starts; its default is :data:`adavar.dynamic.online_ici.ICI_EDF_SAMPLES`); default None:
        the whole record.
    ici_kurtosis : bool
        ``method="ici"``: scale the EDF of the intervals by the record's robust excess
        kurtosis (default; :mod:`adavar.dynamic.ici_episodes`). False: the Gaussian EDF, as before
        0.3 (heavy-tailed noise then gives false changes: 4.8 an hour on Student-t noise of
        5 degrees of freedom at 100 Hz with 1-minute windows).
    ici_episodes : bool
        ``method="ici"``: locate each change by segmenting the episode of disagreeing
        ``lmax`` windows around it, report a gradual change as one ramp
        (``parameters["ici_ramps"]``, events with ``ramp=True``) and give the centres a ramp
        reaches the window of least error under the fitted ramp (default). False: the
        largest contrast of the ``lmax`` windows within ``lmax / 2`` and the ICI's windows
        everywhere, as before 0.3 (a staircase of changes on a ramp, a burst reported up to
        ``lmax`` away).
    ici_long_tau : bool
        ``method="ici"``: also look for changes of the long-tau terms (rate random walk,
        bias instability) with :func:`adavar.dynamic.long_tau.long_tau_changes` on records of at
        least :data:`adavar.dynamic.long_tau.LONG_TAU_SAMPLES` samples
        (``parameters["ici_long_tau"]``; :attr:`AdaptiveResult.events` with ``tau_s``);
        default True (about 0.5 s for 2 hours at 100 Hz).
    bounds : bool
        As in :func:`adavar.davar` (False: no per-cell confidence bounds, for a surface
        whose bounds nothing reads).
    dependence : (float, float), optional
        The record's ``(c2, c4)`` for the hourly thresholds
        (:func:`adavar.dynamic.thresholds.noise_dependence`), as ``OnlineAdaptive(dependence=)``.
        Default: measured on the record's head, in stages (:func:`dependence_stages`: the
        first 8192 samples or half Lmax, refined at every doubling up to 2**20 samples, each
        estimate governing the centres whose windows end after it), so that the live pass
        repeats this one; ``parameters["dependence_stages"]`` lists them and
        ``parameters["dependence"]`` is the last.
    kurtosis_reference : {"record", "gaussian"} or dict
        What the calibrated thresholds compare each window with. ``"record"`` (default):
        the record's own stationary noise. Its distribution is fitted on the same head as
        ``dependence`` (a family from uniform through Gaussian to heavy tails, on the median
        kurtosis of blocks of the record, so changes and spikes do not move it) and the
        record is made Gaussian by ``Phi^-1(F(x))`` before the tests
        (:mod:`adavar.dynamic.kurtosis_reference`): stationary noise that is not Gaussian
        (platykurtic, Student-t, Laplace, uniform, quantised) then gives the target rate of
        false events, where the Gaussian band shortened every window; a Gaussian record is
        left as it is. ``kurtosis``, ``s`` and the flags are those of the transformed record;
        ``parameters["kurtosis_reference_fit"]`` gives the fit (which, given here as a dict,
        is used as it is, as ``dependence``). ``"gaussian"``: Gaussian noise (the behaviour
        before 0.2). Not used with ``thresholds="paper"``.
    settings : ControllerSettings, optional
        The controller's keywords (``lmax`` ... ``false_alarm_per_hour``) as one object
        (:class:`adavar.core.settings.ControllerSettings`, whose defaults are this
        function's; :data:`adavar.core.settings.PAPER` the paper's); its fields replace those
        keywords. A keyword also given with another value is an error.
    method_options : MethodOptions, optional
        ``method``, ``change_times``, ``dependence``, ``kurtosis_reference`` and the ICI
        keywords as one object (:class:`adavar.core.request.MethodOptions`), as ``settings``.

    Returns
    -------
    AdaptiveResult
        The DAVAR surface on the schedule, plus ``kurtosis``, ``s``, ``f1``, ``f2``, ``f``,
        and :attr:`AdaptiveResult.events`.

    Notes
    -----
    The controller is an O(N) sequential pass; the surface is :func:`adavar.davar` with
    ``window`` = the schedule, so it costs what a fixed window costs.
    """
    given = {k: v for k, v in locals().items() if k not in ("data", "settings", "method_options")}
    keywords = settings_keywords(
        adaptive_davar, given, (settings, ControllerSettings), (method_options, MethodOptions)
    )
    # the body is shared with adaptive_blocks
    return next(_adaptive_surfaces(data, **keywords, in_blocks=False, block_values=None))


def adaptive_blocks(
    data: Sequence[float] | np.ndarray, *, block_values: int | None = None, **options: Any
) -> Iterator[AdaptiveResult]:
    """:func:`adaptive_davar` a block of consecutive windows at a time.

    The controller runs once over the whole record; its surface is then computed a block
    of windows at a time (:func:`adavar.dynamic.surface.davar_blocks`), for a record whose surface
    is too large to hold while its per-window results are not.

    Parameters
    ----------
    data : array_like or source
        The record: in memory, or read piece by piece (a file memory map, a
        :class:`~adavar.io.sources.ChunkedSource`, ``chunk_size=``): the controller streams
        it, and each block reads its windows' span (not a dask array: use
        ``adaptive_davar``).
    block_values : int, optional
        Surface values per block (default :data:`adavar.dynamic.surface.BLOCK_VALUES`).
    **options
        Keywords of :func:`adaptive_davar`.

    Yields
    ------
    AdaptiveResult
        Consecutive blocks of rows: every row (its variances, window, centre, kurtosis,
        S and flags) equals that row of ``adaptive_davar(data, **options)`` bit for bit;
        ``alpha``, the EDF and bound tables, ``notes`` and ``parameters`` are the whole
        surface's.
    """
    arguments = inspect.signature(adaptive_davar).bind(data, **options)
    arguments.apply_defaults()
    given = dict(arguments.arguments)
    settings, method_options = given.pop("settings"), given.pop("method_options")
    given = settings_keywords(
        adaptive_davar, given, (settings, ControllerSettings), (method_options, MethodOptions)
    )
    if sources.is_dask(data):
        raise AdavarInputError(
            "adaptive_blocks takes an array or a file read piece by piece, not a dask array: "
            "use adaptive_davar(..., chunk_size=), which holds N / step rows"
        )
    if block_values is not None and int(block_values) < 1:
        raise AdavarInputError(f"block_values must be a positive number, got {block_values!r}")
    return _adaptive_surfaces(given.pop("data"), **given, in_blocks=True,
                              block_values=block_values)  # fmt: skip


def _adaptive_surfaces(
    data: Any, *, method: str, lmax: Length | None, lmin: Length | None, k1: float, k2: float,
    s1: float, s2: float, l: Length | None, dl0: int, dl1: int, s_test: str,  # noqa: E741
    combine: str, taus: Any, edges: str, change_times: Any, thresholds: str,
    false_alarm: float | None, step: Length | None, confidence: float | None,
    data_type: str, rate: float, tau0: float | None,
    t0: float, points_per_decade: int, noise_type: Any, units: str | None,
    chunk_size: int | None, edge_edf: str, false_alarm_per_hour: float | None,
    ici_gamma: float, ici_lengths: Any, ici_taus: Any, ici_sides: str, ici_edf: str,
    ici_edf_samples: int | None, ici_kurtosis: bool, ici_episodes: bool, ici_long_tau: bool,
    bounds: bool, in_blocks: bool, block_values: int | None,
    dependence: Sequence[float] | None, kurtosis_reference: str | dict,
) -> Iterator[AdaptiveResult]:  # fmt: skip
    """The body of :func:`adaptive_davar`: one result, or (``in_blocks``) blocks of rows."""
    dtype = DATA_TYPE_ALIASES.get(str(data_type).lower())
    if dtype is None:
        raise AdavarInputError(f"unknown data_type {data_type!r}: use 'rate' or 'phase'")
    refuse_masked(data)
    rate, tau0, dt = resolve_rate(data, rate, tau0)  # a time index gives it, or 1 Hz
    if None in (lmax, lmin, l, taus, step):  # the defaults follow the record
        # the record's length, as the command line counts it (phase: its samples)
        size = record_size(data, chunk_size is not None or sources.is_chunked(data))
        lmax, lmin, l = resolve_windows(size, dt, lmax, lmin, l)  # noqa: E741
        taus, step, _ = surface_resolution(
            check_whole("lmax", to_samples(lmax, dt, "lmax"), 5), size, dt, taus=taus,
            step=step, points_per_decade=points_per_decade,
        )  # fmt: skip
    # durations (``"10min"``) become samples once, with this record's sample interval
    lmax, lmin, l, step = window_lengths(dt, lmax=lmax, lmin=lmin, l=l, step=step)  # noqa: E741
    controller = dict(
        method=method, lmax=lmax, lmin=lmin, k1=k1, k2=k2, s1=s1, s2=s2, l=l, dl0=dl0,
        dl1=dl1, s_test=s_test, combine=combine, edges=edges, change_times=change_times,
        thresholds=thresholds, false_alarm=false_alarm, rate=rate, tau0=tau0,
        false_alarm_per_hour=false_alarm_per_hour, ici_gamma=ici_gamma, ici_lengths=ici_lengths,
        ici_taus=ici_taus, ici_sides=ici_sides, ici_edf=ici_edf,
        ici_edf_samples=ici_edf_samples, ici_kurtosis=ici_kurtosis, ici_episodes=ici_episodes,
        ici_long_tau=ici_long_tau, dependence=dependence, kurtosis_reference=kurtosis_reference,
    )  # fmt: skip
    surface_options = dict(
        rate=rate, data_type=dtype, taus=taus, edges=edges, confidence=confidence, tau0=tau0,
        t0=t0, points_per_decade=points_per_decade, noise_type=noise_type, units=units,
        edge_edf=edge_edf, bounds=bounds,
    )  # fmt: skip
    step = int(step) if isinstance(step, (int, np.integer)) and not isinstance(step, bool) else 0
    if step < 1:
        raise AdavarInputError("step must be a positive integer")
    min_length = 4 if dtype == "phase" else 3
    if method == "ici" and chunk_size is None and sources.is_chunked(data):
        source = sources.as_source(data)  # ICI runs in memory: read the record once
        data = source.read(0, source.size)
    if chunk_size is not None or sources.is_chunked(data):
        source = sources.as_source(data)
        if source.size < min_length:
            raise AdavarInputError(
                f"the record has {source.size} samples; at least {min_length} are needed"
            )
        u = source if dtype == "rate" else sources.DifferencedSource(source)
        # the step-th centres only: O(N / step) memory, the schedule davar computes
        sched = adaptive_schedule(u, **controller, step=step, chunk_size=chunk_size)
        if edges == "valid":
            # one length per candidate centre 0, step, ...; lmax does not fit outside the
            # controller's centres, so davar keeps exactly the schedule's rows
            window = np.full(-(-u.size // step), lmax, dtype=np.int64)
            window[sched.centre // step] = sched.window
        else:
            window = sched.window
            window.flags.writeable = False  # shared with the surface, not copied
        if not in_blocks:
            surface = davar(source, window=window, step=step, chunk_size=chunk_size,
                            **surface_options)  # fmt: skip
            yield _with_record(surface, sched, method)
            return
        for block in davar_blocks(source, window=window, step=step, chunk_size=chunk_size,
                                  block_values=block_values, **surface_options):  # fmt: skip
            rows = _with_record(block, sched, method)
            del block
            yield rows
            del rows
        return
    x = as_samples(data, min_length=min_length)
    u = x if dtype == "rate" else np.diff(x)
    sched = adaptive_schedule(u, **controller)
    shift = sched.shift
    if edges == "valid":
        # the schedule covers the centres where an lmax window fits; others are not
        # computed
        full = np.full(u.size, lmax, dtype=np.int64)
        full[sched.centre] = sched.window
        window = full
        if shift is not None:
            shift = np.zeros(u.size, dtype=np.int64)
            shift[sched.centre] = sched.shift
    else:
        window = sched.window
        window.flags.writeable = False  # shared with the surface, not copied
    if not in_blocks:
        yield _with_record(
            davar(x, window=window, step=step, shift=shift, **surface_options), sched,
            method,
        )  # fmt: skip
        return
    for block in davar_blocks(x, window=window, step=step, shift=shift,
                              block_values=block_values, **surface_options):  # fmt: skip
        rows = _with_record(block, sched, method)
        del block  # the generator holds no block while the next one is made
        yield rows
        del rows


def _with_record(surface: DavarResult, sched: Schedule, method: str) -> AdaptiveResult:
    """The surface (or a block of its rows) with the schedule's record of its centres."""
    # the surface's centres are every (step / sched.step)-th of the schedule's from the
    # first one's row: slices, no copies
    stride = max(1, int(surface.step) // int(sched.step))
    count = int(surface.centre.size)
    first = int(surface.centre[0] - sched.centre[0]) // int(sched.step) if count else 0
    rows = slice(first, first + stride * (count - 1) + 1 if count else first, stride)
    if not np.array_equal(sched.centre[rows], surface.centre):  # pragma: no cover
        raise AssertionError("internal: surface centres outside the schedule")
    fields = {
        name: getattr(surface, name) for name in surface.__dataclass_fields__ if name != "_cache"
    }
    return AdaptiveResult(
        **fields,
        kurtosis=sched.kurtosis[rows], s=sched.s[rows], f1=sched.f1[rows],
        f2=sched.f2[rows], f=sched.f[rows], method=method, parameters=sched.parameters,
    )  # fmt: skip


def false_alarm_rate(
    *,
    n: int = 200_000,
    seeds: Sequence[int] = (0, 1, 2),
    **controller: Any,
) -> dict[str, float]:
    """Fraction of steps at which the controller flags stationary Gaussian white noise.

    Runs :func:`adaptive_schedule` on unit white noise (``n`` samples per seed) with the
    given settings and returns the rates of ``f1``, ``f2`` and ``f`` and the fraction of
    centres whose window is shorter than ``lmax`` (windows shrunk by false alarms), over
    the centres whose ``lmax`` window lies inside the record.

    Parameters
    ----------
    n : int
        Samples per seed.
    seeds : sequence of int
        Seeds of the noise.
    **controller
        Settings of :func:`adaptive_schedule` (``method``, ``k1``, ``thresholds``, ...).

    Returns
    -------
    dict
        ``{"f1": ..., "f2": ..., "f": ..., "shrunk": ...}``.
    """
    totals = {"f1": 0.0, "f2": 0.0, "f": 0.0, "shrunk": 0.0}
    count = 0
    for seed in seeds:
        x = np.random.default_rng(seed).standard_normal(n)
        sched = adaptive_schedule(x, **controller)
        lmax = int(sched.parameters["lmax"])
        inner = slice(lmax, n - lmax)
        totals["f1"] += float(sched.f1[inner].sum())
        totals["f2"] += float(sched.f2[inner].sum())
        totals["f"] += float(sched.f[inner].sum())
        totals["shrunk"] += float((sched.window[inner] < lmax).sum())
        count += sched.f[inner].size
    return {k: v / count for k, v in totals.items()}

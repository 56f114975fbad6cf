"""The adaptive window live: A-DAVAR sample by sample, equal to the offline pass.

:class:`OnlineAdaptive` takes a record in pushes of any size (one sample to millions) and
gives, as the samples arrive, the window schedule of :func:`adavar.adaptive_davar`, the
noise coefficients ``N(t)`` of the emitted windows and the non-stationary stretches of
:func:`adavar.dynamic.events.find_events`, each as soon as it is determined.

How it stays equal to the offline pass
--------------------------------------
The controller (:mod:`adavar.dynamic.controller`) restarts its running sums at every multiple of
:data:`adavar.dynamic.controller.REANCHOR` centres, so a run of centres that starts at such a
centre from the length in force there repeats the sequential pass bit for bit (the
out-of-core path of :func:`adavar.adaptive_schedule` rests on the same property). Each push
runs the controller from the last multiple of REANCHOR reached, over every centre whose
longest window (``Lmax``) now lies inside the samples received, and carries the length in
force at the last multiple of REANCHOR to the next push, which runs again the at most
``REANCHOR - 1`` centres after it (a few microseconds). The left mirror (docs/method.md
section 6) is known from the first ``Lmax / 2 + 1`` samples; the right one only at
:meth:`OnlineAdaptive.finish`, which runs the last ``Lmax / 2`` centres. The record is
used at the scale ``2**-k`` of its first non-zero push (``k = 0`` for data within about
5e-20 .. 2e19): scaling by a power of two is exact, so every sum, moment and decision is
the offline one times a power of two and the windows are identical, whatever ``k`` the
offline pass chose from the whole record (short of fourth powers leaving the float64
range, which the offline scale avoids).

Latency
-------
The row of centre ``c`` is emitted when sample ``c + Lmax // 2`` arrives (:attr:`latency`).
Hourly calibrated thresholds (the default: ``thresholds="calibrated"`` with
``false_alarm_per_hour``) need the record's short-range correlation. Both passes estimate
it in stages (:func:`adavar.dynamic.adaptive.dependence_stages`): on the first ``max(8192, Lmax //
2 + 1)`` samples (41 s at 200 Hz; the first row waits for them, or for
:meth:`~OnlineAdaptive.finish`, unless ``dependence`` is given), then on the first 2, 4,
... times as many up to :data:`adavar.dynamic.thresholds.DEPENDENCE_SAMPLES` (2**20). Each
refined estimate sets the thresholds of the centres from the first multiple of REANCHOR
at or after ``H - Lmax // 2`` (``H`` the samples it read), none of whose rows has been
emitted when those samples arrive: an emitted row or event is never revised, a refinement
changes the tests of the centres still to come only, and the offline pass, which applies
the same stages, gives the same windows. (Before 0.2 the live pass waited for 2**20
samples, 87 minutes at 200 Hz, and the offline one used that one estimate throughout.)
Events are those of :func:`adavar.dynamic.events.find_events` (one :class:`adavar.dynamic.events.
EventTracker` pairs the episodes for both): an episode of shortened windows is decided
once the N of the windows up to ``Lmax / 2 + 2 Lmax`` after its end has been fitted (or
the next episode begins), so the event that ends with it comes about ``3 Lmax`` after its
``end_s`` (plus the row latency). Its ``before`` and ``during`` summaries are final then;
its ``after`` summary is final when the next episode is decided or at
:meth:`~OnlineAdaptive.finish` (:attr:`OnlineAdaptive.final_count`). (Before 0.2 an event
came with the sample after its ``end_s``, paired by parity: one spike inverted the rest.)

The ICI window (``method="ici"``)
---------------------------------
:mod:`adavar.dynamic.online_ici` repeats :func:`adavar.dynamic.ici.ici_schedule` (docs/method.md
section 11) bit for bit: the DAVAR engine computes the candidates' variances in units of
:func:`adavar.dynamic.ici.ici_block` centres (``lmax / 2``) aligned on centre 0, offline and
online alike, so every estimate, interval and decision is the offline one. A unit is
computed when the right ``lmax`` window of its last centre has arrived: the row of centre
``c`` comes by sample ``c + ici_block(lmax) + lmax - 2`` (about ``1.5 lmax``, not
``lmax / 2``: a right-sided window at ``c`` ends at ``c + lmax - 1``), and with
``ici_episodes`` (default) ``1.75 lmax`` later, when no episode's ramp can change its
window any more (:attr:`OnlineAdaptive.latency`, :mod:`adavar.dynamic.online_ici`). Where the left
and right windows tie but disagree (a few centres at a change), a centre's side depends on
its whole run of such centres: those rows come when the run closes. A change is final once
its episode is closed and segmented (``ici_episodes``; without, once the contrast
``lmax / 2`` centres after it is known), and becomes an event when the rows up to it have
been emitted. The EDF is measured on the first ``ici_edf_samples`` samples (default
:data:`adavar.core.settings.ICI_EDF_SAMPLES`, 2**16): nothing is emitted before they have
arrived, and the offline pass equals the online one given the same ``ici_edf_samples``.
The intervals are log variances, which scaling by a power of two shifts by a rounded
constant: the equality holds when the data's magnitude lies within about 5e-20 .. 2e19 (no
scaling, online or offline).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from adavar._kernels._jit import get_num_threads
from adavar._kernels.window_engine import window_variance
from adavar.core.durations import Length
from adavar.core.errors import AdavarInputError
from adavar.core.inputs import data_exponent, refuse_masked, tau_factors, unscale
from adavar.core.request import MethodOptions, settings_keywords
from adavar.core.settings import (
    CONTROLLER,
    HOURLY_FALSE_ALARMS,
    ICI_EDF_SAMPLES,
    ICI_GAMMA,
    THRESHOLDS,
    ControllerSettings,
    threshold_mode,
)
from adavar.core.terms import TERM_NAMES
from adavar.dynamic.controller import REANCHOR, Controller, needs_head
from adavar.dynamic.events import Event, EventTracker, stretch_summary
from adavar.dynamic.ici_episodes import Episode
from adavar.dynamic.ici_events import IciEventTracker
from adavar.dynamic.online_ici import IciTracker
from adavar.dynamic.online_rows import Rows, check_noise_type
from adavar.dynamic.schedule import window_lengths
from adavar.dynamic.surface_common import edf_table
from adavar.dynamic.window_defaults import (
    check_stream_memory,
    dependence_stages,
    resolve_windows,
    stage_controller,
)
from adavar.fit.noise_model import fit_avar
from adavar.io.sampling import resolve_tau0

__all__ = ["ONLINE_METHODS", "OnlineAdaptive"]

#: methods that run live (the oracle needs the change times, a fixed window no pass)
ONLINE_METHODS = ("adaptive", "kurtosis", "ici")


#: binary exponent a push may reach above the scale the first push set (``2**-k``): the
#: controller's sums of fourth powers over up to 2**30 samples stay below 2**1023
RANGE_EXPONENT = 240
#: rows whose variances are computed and fitted together (a backlog goes in blocks)
FIT_ROWS = 1 << 15
#: centres the controller runs at once (a multiple of REANCHOR): the first rows after the
#: calibrated thresholds exist are a backlog of a million centres, whose per-centre
#: outputs would otherwise be held all at once
BACKLOG_CENTRES = 1 << 16
#: the record's length while it is still arriving: no window reaches past its end yet
_UNKNOWN_END = 1 << 60


class OnlineAdaptive:
    """A-DAVAR on a live stream: the schedule, N(t) and events as the samples arrive.

    The results equal those of the offline pass on the same record:
    ``.window`` is ``adaptive_davar(x, rate=rate, ..., step=step).window`` bit for bit,
    ``.coefficients`` (``.arw``) is ``fit_noise(that result, terms=terms,
    reference=None)`` to rounding (a stream has no whole record to take a filter's roll-off
    from: give ``fit_options={"reference": fit}`` of an earlier record of the sensor)
    (1e-12 relative) when the offline pass is given ``taus``, ``noise_type`` and
    ``edge_edf`` alike, and ``.events`` after :meth:`finish` is
    :func:`adavar.dynamic.events.find_events` of those windows and coefficients with
    ``duration = t0 + n / rate`` (what ``adavar adaptive`` reports). See the module
    docstring for how and for the latencies.

    Parameters
    ----------
    rate : float
        Sample rate, Hz.
    lmax, lmin, l : int, str, Duration or timedelta, optional
        Longest (start) and shortest window and the S test's leading segment: samples or
        durations, as in :func:`adavar.adaptive_davar`. ``lmax`` not given:
        :data:`adavar.core.settings.STREAM_LMAX_SECONDS` (180 s, a tenth of a 30-minute record:
        a stream has no length to take a tenth of; the offline default on a 30-minute
        record is the same; before 0.2, the paper's 600 samples). ``lmin`` and ``l`` not
        given: two thirds and a sixth of ``lmax`` (:func:`adavar.dynamic.adaptive.record_windows`;
        the paper's 400 and 100 of 600).
    method : {"adaptive", "kurtosis", "ici"}
        A-DAVAR, DAVAR-K, or the intersection-of-confidence-intervals window
        (docs/method.md section 11; module notes: its latency is about ``3.3 lmax``). For
        ``"ici"`` the kurtosis settings (``k1`` .. ``dependence``) are not used and the
        windows, ``.shift`` and the change points equal
        ``adaptive_davar(x, method="ici", ici_edf_samples=K, ...)``'s.
    k1, k2, s1, s2, dl0, dl1, s_test, combine, thresholds, false_alarm, false_alarm_per_hour
        As in :func:`adavar.adaptive_davar`: thresholds calibrated for 0.1 false events per
        stationary hour by default (before 0.2, the paper's; ``thresholds="paper"`` gives
        them).
    dependence : (float, float), optional
        The record's ``(c2, c4)`` (:func:`adavar.dynamic.thresholds.noise_dependence`) for hourly
        thresholds, given instead of estimated in stages (module notes): no wait at the
        start, and the windows of ``adaptive_davar(..., dependence=)`` given the same
        (``.parameters["dependence"]`` of a previous run is the last estimate).
    kurtosis_reference : {"record", "gaussian"} or dict
        As in :func:`adavar.adaptive_davar`: the record's own stationary noise (default),
        fitted on the same heads as the correlation (stages, module notes; so the wait for
        the first head holds with ``dependence`` given too), Gaussian noise, or the fit of
        a previous run (``.parameters["kurtosis_reference_fit"]``): with ``dependence``
        given too, no wait at the start.
    pairing : {"level", "parity"}
        How the episodes make events, as :func:`adavar.dynamic.events.find_events`.
    step : int, str, Duration or timedelta
        Keep the rows of the centres that are multiples of ``step`` (as
        ``adaptive_davar(..., step=step)``); the controller still visits every centre.
    terms : sequence of str or None
        The noise terms fitted to every kept row (default N only, ``"angle_random_walk"``);
        None or empty: no DAVAR rows and no fit (events then carry no summaries).
    taus : {"octave", "all", "decade", "log"} or sequence of float
        Averaging times of the rows (default octave: with the default windows every EDF
        of the offline surface is then exact, so N(t) matches it to rounding; see Notes).
    noise_type : int or sequence of int
        alpha of the EDF per tau (default 0, white rate noise); ``"record"`` needs a whole
        record and is refused.
    edge_edf : {"distinct", "interior"}
        EDF of the windows that reach into the mirror, as :func:`adavar.davar`.
    units : str, optional
        Declared unit of the rate samples (carried to the fit).
    t0 : float
        Time of the first sample, s.
    fit_options : dict, optional
        More keywords of :func:`adavar.fit_avar` (``n_reweight``, ``spacing``,
        ``tau_range``, ``bandwidth``, ``reference``).
    fit_batch : int
        Fit the rows in batches of at least this many (default 1: every push). A larger
        batch amortises the per-call cost of the fit on small pushes; the coefficients
        then trail the schedule by up to ``fit_batch`` rows (flushed whenever an event needs
        them and at :meth:`finish`).
    keep : {"all", "recent"}
        ``"all"``: every row is kept (``N / step`` rows of window, centre, time and
        coefficients, about 40 bytes each). ``"recent"``: only the rows the pending event
        summaries need (those since the last change, at least the last ``lmax``), for an
        endless stream; ``.first_row`` says which row ``.window[0]`` is. The exact
        percentiles of the summaries need every row since the last change: 32 bytes a
        row with N, so an unbroken stationary day at 200 Hz holds 550 MB at ``step=1``
        and 28 MB at ``step=20``.
    ici_gamma, ici_lengths, ici_taus, ici_sides
        ``method="ici"``: as in :func:`adavar.adaptive_davar`.
    ici_edf : {"correlation"}
        ``method="ici"``: the EDF from the correlation of the first ``ici_edf_samples``
        samples; ``"engine"`` (the whole record's noise type) is refused.
    ici_edf_samples : int
        ``method="ici"``: samples the EDF is measured on before the first row (default
        :data:`adavar.core.settings.ICI_EDF_SAMPLES`, 2**16, 5.5 minutes at 200 Hz); give the
        offline pass the same.
    ici_kurtosis, ici_episodes : bool
        ``method="ici"``: as in :func:`adavar.adaptive_davar` (the live events are the
        steps; ramps change the windows, but are not events here).
    settings, method_options : ControllerSettings, MethodOptions, optional
        The controller's and the method's keywords as the objects of
        :class:`adavar.AnalysisRequest` (their fields replace those keywords; a keyword
        also given with another value is an error). ``MethodOptions.ici_edf_samples``
        None means :data:`adavar.core.settings.ICI_EDF_SAMPLES`; its ``change_times``,
        ``ici_long_tau`` (not options of a stream) must keep their defaults.

    Attributes
    ----------
    window, centre, time : ndarray
        Window length (int64), centre (samples, int64) and time (s) of each kept row so far.
    coefficients : dict of str to ndarray
        Each fitted term's value at the rows fitted so far (``.arw`` for N).
    events : list of Event
        The stretches confirmed so far (:class:`adavar.dynamic.events.Event`), the first
        ``final_count`` of them with every summary final; after :meth:`finish`, the change
        times of ``adaptive_davar(...).events`` on the record with the same settings, and
        the summaries of its ``events_with(fit_noise(result, terms=terms))`` given the
        same ``taus``, ``noise_type`` and ``edge_edf`` (see ``.coefficients``).
    shift : ndarray of int64
        ``method="ici"``: the offset of each kept row's window from its centre (a
        one-sided window, as ``adaptive_davar(...).shift``); zeros otherwise.
    ici_changes : list of int
        ``method="ici"``: the change points found so far (samples), as
        ``adaptive_davar(..., method="ici").parameters["ici_changes"]``; empty otherwise.
    latency : int
        Samples between a centre and the emission of its row: ``lmax // 2``; for
        ``method="ici"`` ``ici_block(lmax) + lmax - 2 + lmax + lmax // 4 + lmax // 2``
        (about ``3.3 lmax``; without ``ici_episodes`` ``ici_block(lmax) + lmax - 2``),
        longer for the centres of a run of tied, disagreeing sides or of an episode (module
        notes).

    Raises
    ------
    AdavarInputError
        For a setting out of range (at construction), a non-finite or non-numeric sample
        (at :meth:`push`), a push after :meth:`finish`, or a record shorter than ``lmax``
        (at :meth:`finish`); ``method="ici"`` with ``ici_edf="engine"`` or
        ``ici_edf_samples=None``.

    Notes
    -----
    Cost: ``method="ici"``: each engine unit of ``ici_block(lmax)`` centres is computed
    once, when complete (O(J) window variances a centre, J the candidates), the side and
    change rules over the newly computed centres only: O(N J) in all, the same work as
    offline. Otherwise the controller is O(1) per sample plus ``REANCHOR`` centres and a
    Python call per push; the rows' variances O(M) per kept row; the fit a few microseconds
    per kept row (``docs/benchmarks.md``, "Online adaptive pass"). Memory: with
    ``keep="recent"`` the last push, the samples of one ``REANCHOR`` block and a window
    (until the last estimate of the correlation of hourly thresholds, the first
    ``DEPENDENCE_SAMPLES``, 8 MB; ICI: an engine unit
    and two ``lmax``, the first ``ici_edf_samples`` until the EDF is set, and the state of
    an open run of tied sides), the rows since the last change (a window length and each
    term's value: 12 bytes a row with N alone; centres and times are computed when asked),
    and the events. N(t) equals the offline one to rounding when the offline EDF table is
    exact (at most 4096 (length, tau) pairs or 32 lengths per tau: octave taus, or every tau
    on short windows); beyond that the offline surface interpolates the EDF between lengths,
    and N differs by up to about 1e-6 relative (``taus="all"`` with the default windows:
    7.9e-7 at worst, 2e-16 in the median on the 200 Hz sensor simulator).

    Examples
    --------
    >>> import numpy as np, adavar
    >>> live = adavar.OnlineAdaptive(rate=100.0, lmax=600)
    >>> x = np.random.default_rng(0).standard_normal(20_000)
    >>> for piece in np.array_split(x, 7):
    ...     new_events = live.push(piece)
    >>> last_events = live.finish()
    >>> offline = adavar.adaptive_davar(x, rate=100.0, lmax=600)
    >>> bool(np.array_equal(live.window, offline.window))
    True
    """

    def __init__(
        self,
        *,
        rate: float,
        lmax: Length | None = None,
        lmin: Length | None = None,
        l: Length | None = None,  # noqa: E741 - the paper's name
        method: str = "adaptive",
        k1: float = CONTROLLER.k1,
        k2: float = CONTROLLER.k2,
        s1: float = CONTROLLER.s1,
        s2: float = CONTROLLER.s2,
        dl0: int = CONTROLLER.dl0,
        dl1: int = CONTROLLER.dl1,
        s_test: str = CONTROLLER.s_test,
        combine: str = CONTROLLER.combine,
        thresholds: str = THRESHOLDS,
        false_alarm: float | None = None,
        false_alarm_per_hour: float | None = HOURLY_FALSE_ALARMS,
        dependence: tuple[float, float] | None = None,
        kurtosis_reference: str | dict = "record",
        pairing: str = "level",
        step: Length = 1,
        terms: Sequence[str] | None = ("angle_random_walk",),
        taus: str | Sequence[float] = "octave",
        noise_type: int | Sequence[int] = 0,
        edge_edf: str = "distinct",
        units: str | None = None,
        t0: float = 0.0,
        fit_options: dict[str, Any] | None = None,
        fit_batch: int = 1,
        keep: str = "all",
        ici_gamma: float = ICI_GAMMA,
        ici_lengths: Sequence[int] | None = None,
        ici_taus: Sequence[int] = (1,),
        ici_sides: str = "both",
        ici_edf: str = "correlation",
        ici_edf_samples: int | None = ICI_EDF_SAMPLES,
        ici_kurtosis: bool = True,
        ici_episodes: bool = True,
        settings: ControllerSettings | None = None,
        method_options: MethodOptions | None = None,
    ) -> None:
        if settings is not None or method_options is not None:
            given = {k: v for k, v in locals().items()
                     if k not in ("self", "settings", "method_options")}  # fmt: skip
            keywords = settings_keywords(
                OnlineAdaptive.__init__,
                given,
                (settings, ControllerSettings),
                (method_options, MethodOptions),
                inapplicable=("ici_long_tau",),  # a stream's long-tau changes: not live
            )
            if keywords["ici_edf_samples"] is None:  # a stream has no whole record to read
                keywords["ici_edf_samples"] = ICI_EDF_SAMPLES
            self.__init__(**keywords)
            return
        if method not in ONLINE_METHODS:
            raise AdavarInputError(
                f"method {method!r} does not run live: use 'adaptive', 'kurtosis' or 'ici'"
            )
        if keep not in ("all", "recent"):
            raise AdavarInputError(f"unknown keep {keep!r}: use 'all' or 'recent'")
        if edge_edf not in ("distinct", "interior"):
            raise AdavarInputError(f"unknown edge_edf {edge_edf!r}: use 'distinct' or 'interior'")
        dt = resolve_tau0(rate, None)
        lmax, lmin, l = resolve_windows(None, dt, lmax, lmin, l)  # noqa: E741
        lmax, lmin, seg, step = window_lengths(dt, lmax=lmax, lmin=lmin, l=l, step=step)
        check_stream_memory(lmax, dt)  # before the thresholds of every length are built
        thresholds, false_alarm, false_alarm_per_hour = threshold_mode(
            thresholds, false_alarm, false_alarm_per_hour
        )
        if (
            isinstance(fit_batch, bool)
            or not isinstance(fit_batch, (int, np.integer))
            or (fit_batch < 1)
        ):
            raise AdavarInputError(f"fit_batch must be an integer >= 1, got {fit_batch!r}")
        try:
            self.t0 = float(t0)
        except (TypeError, ValueError):
            raise AdavarInputError(f"t0 must be a number of seconds, got {t0!r}") from None
        self.rate = float(rate)
        self.tau0 = dt
        self.lmax, self.lmin, self.segment, self.step = lmax, lmin, seg, step
        self.method = method
        self.keep = keep
        self.units = units
        self.fit_batch = int(fit_batch)
        self.latency = lmax // 2
        self._pad = lmax // 2 + 1  # mirror samples each side, as the offline pass
        self._ahead = lmax // 2  # samples after a centre its window reads
        self._ici: IciTracker | None = None
        if method == "ici":  # windows reach lmax - 1 samples either side of their centre
            self._ici = IciTracker(lmax=lmax, lmin=lmin, lengths=ici_lengths, taus=ici_taus,
                                   gamma=ici_gamma, sides=ici_sides, edf=ici_edf,
                                   edf_samples=ici_edf_samples, kurtosis=ici_kurtosis,
                                   episodes=ici_episodes)  # fmt: skip
            self.latency = self._ici.latency
            self._pad, self._ahead = lmax, lmax - 1
            self._ici_queue: list[int] = []  # changes waiting for their rows
            self._ici_found: list[Episode] = []  # steps and ramps waiting for their rows
        self.ici_changes: list[int] = []
        self._settings = dict(
            method=method, lmax=lmax, lmin=lmin, seg=seg, dl0=dl0, dl1=dl1, k1=k1, k2=k2,
            s1=s1, s2=s2, s_test=s_test, combine=combine, thresholds=thresholds,
            false_alarm=false_alarm, false_alarm_per_hour=false_alarm_per_hour, rate=1.0 / dt,
            kurtosis_reference=kurtosis_reference,
        )  # fmt: skip
        self._hourly = thresholds == "calibrated" and false_alarm_per_hour is not None
        self._dependence = dependence
        # the controllers in force from their first centres on (dependence_stages): hourly
        # thresholds wait for each estimate of the record's correlation, others need none
        self._stages: list[tuple[int, Controller]] = []
        self._planned: list[tuple[int, int]] = []  # (first centre, head) still to measure
        self._measured: list[int] = []  # samples each stage's estimate read
        if self._ici:
            pass  # ICI: no kurtosis controller; its EDF is measured on the head
        elif needs_head(thresholds, false_alarm_per_hour, kurtosis_reference, dependence):
            quick = self._settings | {"thresholds": "paper"}
            # the settings checked now, not when the head is in
            stage_controller(quick, dependence=dependence)
            self._planned = dependence_stages(None, lmax)
        else:
            self._stages = [(0, stage_controller(self._settings, dependence=dependence))]
        # the rows' variances and their fit
        self.terms = tuple(terms) if terms else ()
        if self.terms:
            unknown = [t for t in self.terms if t not in TERM_NAMES]
            if unknown:
                raise AdavarInputError(
                    f"unknown term {unknown[0]!r}: use some of {', '.join(TERM_NAMES)}"
                )
            self._ms, _ = tau_factors(taus, lmax // 3, dt, 10)
            self._ms = np.ascontiguousarray(self._ms, dtype=np.int64)
            self._alpha = check_noise_type(noise_type, self._ms.size)
            self.tau = self._ms * dt
        self._edge_edf = edge_edf
        self._fit_options = dict(fit_options or {})
        self._edf_rows: dict[tuple[int, int], np.ndarray] = {}
        # the samples: scaled by 2**-k, record indices [x0, x0 + x.size)
        self._k: int | None = None
        self._x = np.empty(max(4 * lmax, 1 << 16))
        self._x0 = 0
        self._xn = 0  # samples held
        self._n = 0  # samples received
        self._q = 0  # first centre not yet settled (a multiple of REANCHOR)
        self._length = lmax  # the length in force at centre _q
        self._emitted = 0  # centres whose row has been emitted
        self._finished = False
        # the kept rows and their coefficients; row r (over all rows ever) is centre
        # r * step, so centres and times are computed, not held (a stationary stream keeps
        # every row since its start)
        columns = ("window",) + (("shift",) if self._ici else ())
        lengths = np.int32 if lmax < 2**31 else np.int64
        self._rows = Rows(columns, (lengths, np.int64)[: len(columns)])
        self._coef = Rows(self.terms, (float,) * len(self.terms))
        self._fitted = 0  # rows (over all ever) with coefficients
        # rows to fit: centres, lengths, shifts (None: centred)
        self._pending: list[tuple[np.ndarray, np.ndarray, np.ndarray | None]] = []
        self._trimmed_at = 0  # rows held after the last trim (keep="recent")
        # events: the episodes paired as find_events pairs them (one implementation), the
        # state at the last kept row: shortened or not, its centre and length, and the
        # first row of the regrowth under way (where the trailing edge is pinned)
        self._tracker: EventTracker | IciEventTracker
        if self._ici is not None and self._ici.episodes:  # steps and ramps, as ici_events
            self._tracker = IciEventTracker(lmax, dt, self._values)
        else:
            self._tracker = EventTracker(
                lmax, dt, self._values, pairing=pairing, t0=self.t0,
                level="angle_random_walk" if "angle_random_walk" in self.terms else None,
            )  # fmt: skip
        self._last_short = False
        self._last_centre: int | None = None
        self._last_window = lmax
        self._regrowth: tuple[int, int] = (0, lmax)  # (centre, length)

    # ------------------------------------------------------------------ results so far

    @property
    def events(self) -> list[Event]:
        """The events confirmed so far (:class:`adavar.dynamic.events.Event`)."""
        return self._tracker.events

    @property
    def final_count(self) -> int:
        """How many of :attr:`events` have every summary final."""
        return self._tracker.final_count

    @property
    def window(self) -> np.ndarray:
        """Window length of every kept row so far (int64)."""
        return self._rows.column("window").astype(np.int64)

    @property
    def centre(self) -> np.ndarray:
        """Centre (sample index) of every kept row so far."""
        first = self._rows.first
        return np.arange(first, first + self._rows.size, dtype=np.int64) * self.step

    @property
    def shift(self) -> np.ndarray:
        """Offset of each kept row's window from its centre (``method="ici"``: a one-sided
        window next to a change, as ``adaptive_davar(...).shift``; 0 otherwise)."""
        if self._ici is None:
            return np.zeros(self._rows.size, dtype=np.int64)
        return self._rows.column("shift").copy()

    @property
    def time(self) -> np.ndarray:
        """Time (s) of every kept row so far: ``t0 + centre / rate``."""
        with np.errstate(over="ignore"):
            return self.t0 + self.centre / self.rate  # as davar: an integral rate rounds once

    def _row_time(self, row: int) -> float:
        """:attr:`time` of row ``row`` (over all rows ever), computed as that array is."""
        with np.errstate(over="ignore"):
            return float(self.t0 + np.int64(row * self.step) / self.rate)

    def _rows_before(self, when: float, side: str) -> int:
        """Held rows with a time below ``when`` (``side="right"``: at or below), as
        ``np.searchsorted(self.time, when, side)`` without building the array."""
        first = self._rows.first
        at = bisect.bisect_right if side == "right" else bisect.bisect_left
        return at(range(self._rows.size), when, key=lambda r: self._row_time(first + r))

    @property
    def first_row(self) -> int:
        """Index, over all rows emitted, of ``window[0]`` (0 unless ``keep="recent"``)."""
        return self._rows.first

    @property
    def coefficients(self) -> dict[str, np.ndarray]:
        """Each fitted term's value at the rows fitted so far (from ``first_row``)."""
        return {name: self._coef.column(name).copy() for name in self.terms}

    @property
    def arw(self) -> np.ndarray:
        """N(t): the angle (velocity) random walk at the rows fitted so far."""
        if "angle_random_walk" not in self.terms:
            raise AdavarInputError("N was not fitted: include 'angle_random_walk' in terms")
        return self._coef.column("angle_random_walk").copy()

    @property
    def latest(self) -> dict[str, Any]:
        """The last emitted row (cheap, for a status line): ``time``, ``window`` and each
        fitted term's value at the last fitted row; empty before the first row."""
        if self._rows.size == 0:
            return {}
        out: dict[str, Any] = {
            "time": self._row_time(self._rows.first + self._rows.size - 1),
            "window": int(self._rows.last("window")),
        }
        if self._coef.size:
            out.update({name: float(self._coef.last(name)) for name in self.terms})
        return out

    @property
    def waiting(self) -> int:
        """Samples still needed before the first row can be computed: the first head the
        hourly thresholds are measured on (:func:`adavar.dynamic.adaptive.dependence_stages`: the
        larger of 8192 samples and half ``lmax``), or the first half window."""
        if self._ici is not None:
            if not self._ici.ready:
                return max(0, int(self._ici.options.edf_samples or 0) - self._n)
            return max(0, self.lmax - self._n)
        if not self._stages:
            return max(0, self._planned[0][1] - self._n)
        return max(0, self.lmax // 2 + 1 - self._n)

    @property
    def samples(self) -> int:
        """Samples received."""
        return self._n

    @property
    def parameters(self) -> dict[str, Any]:
        """The controller's settings (``dependence`` once measured; ICI: its options)."""
        if self._ici is not None:
            o = self._ici.options
            return dict(method="ici", lmax=self.lmax, lmin=self.lmin, l=self.segment,
                        step=self.step, sample_rate=self.rate, ici_lengths=o.lengths.tolist(),
                        ici_taus=o.ms.tolist(), ici_gamma=o.gamma, ici_sides=o.sides,
                        ici_edf=o.edf, ici_edf_samples=o.edf_samples)  # fmt: skip
        out = {k: v for k, v in self._settings.items() if k != "seg"}
        out.update(l=self.segment, step=self.step, sample_rate=self.rate)
        ctl = self._stages[-1][1] if self._stages else None
        out["dependence"] = None if ctl is None or ctl.dependence is None else list(ctl.dependence)
        out["kurtosis_reference_fit"] = None if ctl is None or ctl.reference is None \
            else ctl.reference.as_dict()  # fmt: skip
        # as adaptive_davar's: [first centre, samples, c2, c4] of each estimate so far
        out["dependence_stages"] = None if not self._hourly or ctl is None or not self._measured \
            else [[c, h, *map(float, k.dependence or ())]
                  for (c, k), h in zip(self._stages, self._measured, strict=True)]  # fmt: skip
        return out

    # ------------------------------------------------------------------ feeding

    def push(self, samples: Any) -> list[Event]:
        """Add samples and run the pass over every centre they complete.

        Parameters
        ----------
        samples : array_like
            The next samples of the record (1-D, any length; ints and float32 are promoted).

        Returns
        -------
        list of Event
            The stretches confirmed by these samples (also appended to :attr:`events`).

        Raises
        ------
        AdavarInputError
            A non-numeric, non-finite or multi-channel input, a masked array with masked
            samples (as :func:`adavar.deviation`), samples spanning more than
            ``2**RANGE_EXPONENT`` (1e72) in magnitude with those pushed before (whose fourth
            powers cannot all be held in float64: refused whether they come in one push or
            many; before 0.3 a later push's were taken and overflowed to inf), or a push
            after :meth:`finish`.
        """
        if self._finished:
            raise AdavarInputError("this pass is finished: start a new OnlineAdaptive")
        x = self._check(samples)
        if x.size == 0:
            return []
        if self._k is None and np.any(x):
            self._k = data_exponent(x)  # any power of two is exact; this keeps sums in range
        if self._k is not None:  # one push or many: the same samples refused
            self._check_range(x)
        if self._k:
            x = np.ldexp(x, -self._k)
        self._append(x)
        return self._advance(final=False)

    def finish(self) -> list[Event]:
        """End the record: the right mirror, the last ``lmax // 2`` rows, the final events.

        Returns
        -------
        list of Event
            The stretches confirmed at the end (the last one may have ``end_s`` None);
            every summary of :attr:`events` is then final.

        Raises
        ------
        AdavarInputError
            If fewer than ``lmax`` samples were pushed.
        """
        if self._finished:
            return []
        if self._n < self.lmax:
            raise AdavarInputError(
                f"the record has {self._n} samples; at least {self.lmax} are needed"
            )
        self._finished = True
        new = self._advance(final=True)
        self._flush_fit()
        new += self._close_events()
        return new

    # ------------------------------------------------------------------ internals

    @staticmethod
    def _check(samples: Any) -> np.ndarray:
        if type(samples) is np.ndarray and samples.dtype == np.float64 and samples.ndim == 1:
            if np.isfinite(samples).all():  # the common case, checked cheaply
                return samples
        refuse_masked(samples)  # as every statistic: a masked sample cannot be skipped
        try:
            x = np.asarray(samples)
        except Exception as exc:  # pragma: no cover - exotic containers
            raise AdavarInputError(f"cannot read the samples as an array: {exc}") from None
        if x.dtype == object or not (np.issubdtype(x.dtype, np.number) or x.dtype == bool):
            raise AdavarInputError("samples must be numeric: push a 1-D array of numbers")
        if np.iscomplexobj(x):
            raise AdavarInputError("samples must be real-valued, not complex")
        if x.ndim == 0:
            x = x.reshape(1)
        elif x.ndim != 1:
            raise AdavarInputError(
                f"samples must be one channel (1-D); got shape {x.shape}: push one column"
            )
        x = np.asarray(x, dtype=np.float64)
        finite = np.isfinite(x)
        if not finite.all():
            first = int(np.argmin(finite))
            raise AdavarInputError(
                f"sample {first} of this push is {float(x[first])!r}: the pass needs finite "
                "samples; drop or interpolate missing ones before pushing"
            )
        return x

    def _check_range(self, x: np.ndarray) -> None:
        """Refuse samples whose magnitudes span more than 2**RANGE_EXPONENT: a push far above
        the scale the first set, or (a scale set by an outlier) mostly far below it."""
        k = self._k or 0
        top = max(-float(x.min()), float(x.max()))  # two reductions: cheap on small pushes
        if top and math.frexp(top)[1] - k > RANGE_EXPONENT:
            where = int(np.argmax(np.abs(x) == top))
        elif k > RANGE_EXPONENT - 64:  # a scale above 2**176 was set by huge samples
            size = np.abs(x)
            small = (size < math.ldexp(1.0, k - RANGE_EXPONENT)) & (size > 0)
            if 2 * int(np.count_nonzero(small)) <= int(np.count_nonzero(size)):
                return
            # name the outlier that set the scale if this push holds it
            where = int(np.argmax(size if math.frexp(top)[1] >= k else small))
        else:
            return
        raise AdavarInputError(
            f"sample {where} of this push is {float(x[where])!r} and the scale of the pass is "
            f"2**{k}: its samples span more than 2**{RANGE_EXPONENT} in magnitude, beyond what "
            "the sums of fourth powers hold in float64; remove the outliers, or analyse the "
            "stretches of different magnitude in separate passes"
        )

    def _append(self, x: np.ndarray) -> None:
        # drop what no window will read again (the head is kept until the last estimate of
        # the correlation has been made: at most DEPENDENCE_SAMPLES samples)
        settled = bool(self._stages) and not self._planned
        if settled or (self._ici is not None and self._ici.ready):
            oldest = min(self._q, self._emitted)
            if self._pending:  # rows waiting for their fit read their windows again
                oldest = min(oldest, int(self._pending[0][0][0]))
            keep_from = max(0, oldest - self._pad - 1)
            if keep_from - self._x0 > self._x.size // 2:
                cut = keep_from - self._x0
                self._x[: self._xn - cut] = self._x[cut : self._xn]
                self._x0 += cut
                self._xn -= cut
        need = self._xn + x.size
        if need > self._x.size:
            grown = np.empty(max(need, 2 * self._x.size))
            grown[: self._xn] = self._x[: self._xn]
            self._x = grown
        self._x[self._xn : need] = x
        self._xn = need
        self._n += x.size

    def _extended(self, r0: int, r1: int, final: bool) -> np.ndarray:
        """Record samples ``r0 .. r1 - 1`` with the mirror (time reversal) beyond the ends."""
        n = self._n
        if r0 >= 0 and r1 <= n:  # inside the record: a view
            return self._x[r0 - self._x0 : r1 - self._x0]
        if r1 > n and not final:  # pragma: no cover - internal consistency
            raise AssertionError("internal: a window beyond the samples received")
        idx = np.arange(r0, r1)
        idx = np.where(idx < 0, -1 - idx, idx)
        idx = np.where(idx >= n, 2 * n - 1 - idx, idx)
        return self._x[idx - self._x0]

    def _make_controller(self, final: bool) -> bool:
        if self._ici is not None:  # the ICI EDF, measured on the head as offline
            head_size = int(self._ici.options.edf_samples or 0)
            if not self._ici.ready and (self._n >= head_size or final):
                self._ici.set_edf(self._x[: min(self._xn, head_size)])
            return self._ici.ready
        # each estimate of the correlation once its head has arrived (the first one at the
        # end of a shorter record): it governs the centres from its first one on, none of
        # which has been emitted yet (adavar.dynamic.adaptive.dependence_stages)
        while self._planned and (self._n >= self._planned[0][1] or (final and not self._stages)):
            centre, size = self._planned.pop(0)
            size = min(size, self._n)
            head = self._x[:size]  # held from sample 0 until the last estimate
            self._stages.append((centre, stage_controller(self._settings, head, self._dependence)))
            self._measured.append(size)
        return bool(self._stages)

    def _advance(self, *, final: bool) -> list[Event]:
        if not self._make_controller(final):
            return []
        if self._ici is not None:
            return self._advance_ici(final)
        avail = self._n if final else self._n - self.lmax // 2  # centres whose windows fit
        new: list[Event] = []
        # a backlog in parts that end at multiples of REANCHOR, as pushes that end there
        while avail - self._q > BACKLOG_CENTRES + self.lmax:
            new += self._advance_to(self._q + BACKLOG_CENTRES, final=False)
        return new + self._advance_to(avail, final)

    def _advance_to(self, avail: int, final: bool) -> list[Event]:
        """The rows of the centres before ``avail`` (every window of which has arrived)."""
        q = self._q
        if avail <= max(q, self._emitted):
            return []
        pad = self._pad
        ext = self._extended(q - pad, avail + pad if final else avail + self.lmax // 2, final)
        # one thread: no speculative segments (their warm-up is pure overhead there)
        segments = 1 if get_num_threads() == 1 else None
        # each stage's centres by its controller, from the length the last one ended with
        starts = [c for c, _ in self._stages]
        k = bisect.bisect_right(starts, q) - 1
        window = np.empty(avail - q, dtype=np.int64)
        end_length, a = self._length, q
        while a < avail:
            b = min(avail, starts[k + 1]) if k + 1 < len(starts) else avail
            end = self._n if final else _UNKNOWN_END
            out, end_length = self._stages[k][1].run(
                ext[a - q :], pad, b - a, end_length, segments=segments, record=(a, end)
            )
            window[a - q : b - q] = out[0]
            a, k = b, k + 1
        settled = q + (avail - q) // REANCHOR * REANCHOR
        if final:
            settled = avail
        self._length = int(window[settled - q]) if settled < avail else end_length
        self._q = settled
        e0, self._emitted = self._emitted, avail
        first = -(-e0 // self.step) * self.step
        centres = np.arange(first, avail, self.step, dtype=np.int64)
        if centres.size == 0:
            return []
        lengths = window[e0 - q :] if self.step == 1 else window[centres - q]
        start_row = self._rows.first + self._rows.size
        self._rows.append(window=lengths)
        if self.terms:
            self._pending.append((centres, lengths, None))
            if final or start_row + centres.size - self._fitted >= self.fit_batch:
                self._flush_fit()
        return self._scan_changes(start_row, lengths, centres)

    def _advance_ici(self, final: bool) -> list[Event]:
        """The ICI rows and changes the samples complete (:mod:`adavar.dynamic.online_ici`)."""
        tracker = self._ici
        assert tracker is not None
        first, window, shift, changes = tracker.advance(self._extended, self._n, final)
        self._q, self._emitted = tracker.computed, tracker.emitted
        if window.size:
            start = -(-first // self.step) * self.step
            centres = np.arange(start, first + window.size, self.step, dtype=np.int64)
            lengths, shifts = window[centres - first], shift[centres - first]
            if centres.size:
                start_row = self._rows.first + self._rows.size
                self._rows.append(window=lengths, shift=shifts)
                if self.terms:
                    self._pending.append((centres, lengths, shifts))
                    if final or start_row + centres.size - self._fitted >= self.fit_batch:
                        self._flush_fit()
        self.ici_changes += changes
        if tracker.episodes:  # steps and ramps, paired by ici_events' rule
            self._ici_found += tracker.take_episodes()
            while self._ici_found and (final or self._ici_found[0].end < tracker.emitted):
                self._tracker.add_episode(self._ici_found.pop(0), self.t0, self.tau0)
            changes = []
        self._ici_queue += changes
        # a change's summaries read the rows before it: wait until they are emitted; each
        # change point is an episode of its own (find_events(changes=...))
        while self._ici_queue and (final or self._ici_queue[0] < tracker.emitted):
            when = float(self.t0 + self._ici_queue.pop(0) * self.tau0)  # as ici_changes
            self._tracker.start(when)
            self._tracker.end(when)
        new = self._tracker.advance(self._horizon())
        if self.keep == "recent" and (new or self._rows.size > 2 * self._trimmed_at + self.lmax):
            self._trim()
        return new

    def _flush_fit(self) -> None:
        """Variances and fit of the kept rows not yet fitted."""
        if not self.terms:
            return
        if not self._pending:
            return
        total = self._rows.first + self._rows.size
        if len(self._pending) == 1:
            centres, lengths, shifts = self._pending[0]
        else:
            centres = np.concatenate([c for c, _, _ in self._pending])
            lengths = np.concatenate([w for _, w, _ in self._pending])
            shifts = None
            if self._ici is not None:
                shifts = np.concatenate([h for _, _, h in self._pending if h is not None])
        self._pending = []
        # a block of rows at a time: the first rows after the thresholds are set are a
        # backlog of up to DEPENDENCE_SAMPLES centres (a surface of hundreds of MB at once);
        # every row is fitted on its own, so the blocks change no number
        for b0 in range(0, centres.size, FIT_ROWS):
            part = slice(b0, b0 + FIT_ROWS)
            self._fit_rows(centres[part], lengths[part],
                           None if shifts is None else shifts[part])  # fmt: skip
        self._fitted = total

    def _fit_rows(self, centres: np.ndarray, lengths: np.ndarray, shifts: Any) -> None:
        """Variances and fit of consecutive rows; their coefficients appended."""
        final = self._finished
        c0, c1 = int(centres[0]), int(centres[-1])
        pad = self._pad
        ext = self._extended(c0 - pad, c1 + pad + 1 if final else c1 + self._ahead + 1, final)
        at = centres if shifts is None else centres + shifts  # a one-sided window's centre
        avar = window_variance(ext, self._ms, at - c0, lengths, stat="oavar", offset=pad)
        avar = unscale(avar, 2 * (self._k or 0), "Allan variances", underflow=False)
        edf = self._edf(at, lengths)
        fit = fit_avar(self.tau, avar, edf, terms=self.terms, units=self.units,
                       **self._fit_options)  # fmt: skip
        self._coef.append(**{name: fit.term(name).value for name in self.terms})

    def _edf(self, centres: np.ndarray, lengths: np.ndarray) -> np.ndarray:
        """EDF of each row: exact per (length, overhang), as the offline surface's table."""
        start = centres - (lengths - 1) // 2
        over = np.maximum(0, -start)
        if self._finished:
            over = over + np.maximum(0, start + lengths - self._n)
        if self._edge_edf == "interior":
            over = np.zeros_like(over)
        keys = lengths * (self.lmax + 1) + over
        distinct, inverse = np.unique(keys, return_inverse=True)
        pairs = [divmod(key, self.lmax + 1) for key in distinct.tolist()]
        missing = [pair for pair in pairs if pair not in self._edf_rows]
        if missing:
            # one table for every new pair (a row's EDF depends on its own length and
            # overhang only, and an overhang of 0 is the interior window's exact EDF)
            length, h = np.array(missing, dtype=np.int64).T
            table = edf_table(length, self._ms, self._alpha, overhang=h)
            self._edf_rows.update(zip(missing, table, strict=True))
        return np.stack([self._edf_rows[pair] for pair in pairs])[inverse.ravel()]

    # ------------------------------------------------------------------ events

    def _values(self, above: float, below: float, names: Any = None) -> dict[str, Any]:
        """The summaries over the held rows with ``above < time < below`` (of ``names``
        only, if given)."""
        chosen = [name for name in self.terms if names is None or name in names]
        if not chosen:
            return {}
        self._flush_fit()
        lo = self._rows_before(above, "right")
        hi = max(lo, self._rows_before(below, "left"))
        return {name: stretch_summary(self._coef.column(name)[lo:hi]) for name in chosen}

    def _horizon(self) -> float:
        """Time of the last row emitted: every window up to it is known."""
        if self._rows.size == 0:
            return -np.inf
        return self._row_time(self._rows.first + self._rows.size - 1)

    def _scan_changes(self, start_row: int, lengths: np.ndarray, centres: np.ndarray) -> list:
        """The episodes the new rows reveal (:func:`adavar.dynamic.events.change_episodes`: each
        run's lead at its start, its trail at its end) and the events they decide."""
        tracker = self._tracker
        if self._last_short or int(lengths.min()) < self.lmax:
            lmax, t0, tau0 = self.lmax, self.t0, self.tau0
            short = lengths < lmax
            before = np.concatenate(([self._last_short], short[:-1]))
            starts = np.flatnonzero(short & ~before).tolist()
            ends = np.flatnonzero(~short & before).tolist()  # the first full row after a run
            run = 0 if self._last_short else None  # first row of the run under way
            for index in sorted(starts + ends):
                if short[index]:  # a run begins: its lead
                    if index > 0:
                        c = int(centres[index - 1])
                    else:
                        c = self._last_centre if self._last_centre is not None else int(centres[0])
                    tracker.start(float(t0 + (c + lmax // 2) * tau0))
                    run = index
                else:  # it ended on the row before: its trail
                    c, w = self._regrowth_start(lengths, centres, index - 1, run)
                    tracker.end(float(t0 + (c - (w - 1) // 2) * tau0))
                    run = None
            if short[-1]:  # a run goes on: where its regrowth under way started
                self._regrowth = self._regrowth_start(lengths, centres, lengths.size - 1, run)
            self._last_short = bool(short[-1])
        self._last_centre = int(centres[-1])
        self._last_window = int(lengths[-1])
        new = tracker.advance(self._horizon())
        if self.keep == "recent" and (new or self._rows.size > 2 * self._trimmed_at + self.lmax):
            self._trim()  # amortised: the held rows are read when they have doubled
        return new

    def _regrowth_start(
        self, lengths: np.ndarray, centres: np.ndarray, last: int, run: int | None
    ) -> tuple[int, int]:
        """(centre, length) of the first row of the increasing lengths that end at row
        ``last`` of these rows (``run``: the run's first row here, None if it began
        before them), as :func:`adavar.dynamic.events.change_episodes` finds it."""
        e = last
        first = 0 if run is None else run
        while e > first and lengths[e - 1] < lengths[e]:
            e -= 1
        if e == 0 and run is None and lengths[0] > self._last_window:
            return self._regrowth  # the regrowth began before these rows
        return int(centres[e]), int(lengths[e])

    def _close_events(self) -> list[Event]:
        """At the end: every episode decided, the last summaries final."""
        return self._tracker.advance(
            np.inf, final=True, end_of_record=self.t0 + self._n / self.rate
        )

    def _trim(self) -> None:
        """keep="recent": rows no summary still to come reads (and older than lmax rows) go."""
        since = self._rows_before(self._tracker.keep_from(), "right")
        recent = max(0, self._rows.size - max(1, self.lmax // self.step))
        self._drop_rows(self._rows.first + min(since, recent))
        self._trimmed_at = self._rows.size

    def _drop_rows(self, index: int) -> None:
        index = min(index, self._fitted)  # rows not yet fitted stay
        self._rows.drop_before(index)
        self._coef.drop_before(index)

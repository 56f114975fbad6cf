"""The adaptive window's schedule (A-DAVAR) and its baselines: docs/method.md section 8.

The controller walks the centres in order. At each centre ``p`` it takes the window of the
current length ``L`` centred at ``p`` (mirror-extended record), computes its kurtosis ``k``
and the sliding kurtosis contribution coefficient ``S`` of its last ``l`` samples, raises

* ``f1`` when ``k`` leaves ``[K1, K2]`` (the window is not Gaussian-stationary, Eq. 16),
* ``f2`` when ``S > S2`` (a shock has just entered the leading edge, Eq. 17),

combines them (``f = f1 or f2``, Eq. 18), records ``L`` as the window of ``p``, and then
shrinks ``L`` by ``dL1`` (``f = 1``) or regrows it by ``dL0`` (``f = 0``) within
``[Lmin, Lmax]`` (Eq. 19-22). The schedule (:func:`adaptive_schedule`) then goes to
:func:`adavar.davar`, the one place where a DAVAR surface is computed
(:mod:`adavar.dynamic.adaptive` puts the two together).

The pass is sequential (each length depends on the last decision) and O(N); it is compiled
in :mod:`adavar.dynamic.controller`, which also checks the settings and sets the thresholds.

Out of core (a memory map, a dask array, a :class:`adavar.stats.stream.ChunkedSource`, or
``chunk_size=``) the pass reads the record piece by piece. Pieces start at multiples of
REANCHOR, where the sums restart anyway, and each starts from the length the previous one
ended with, so the schedule is the in-memory one bit for bit; only the centres that are
multiples of ``step`` are kept.

Methods: ``"adaptive"`` (A-DAVAR, ``f = f1 or f2``), ``"kurtosis"`` (DAVAR-K, the
kurtosis-only controller of Wang/Zhu, ``f = f1``), ``"oracle"`` (the ideal schedule for known
change times), ``"fixed"`` (DAVAR-L with ``L = lmax``, its kurtosis and S recorded along),
``"ici"`` (beyond the paper: the intersection-of-confidence-intervals rule of
:mod:`adavar.dynamic.ici`, with one-sided windows next to a change; not a kurtosis controller).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from adavar.core.durations import Length, count_text, is_duration, to_samples
from adavar.core.errors import AdavarInputError
from adavar.core.inputs import as_samples, refuse_masked, scaled
from adavar.core.settings import (
    CONTROLLER,
    HOURLY_FALSE_ALARMS,
    ICI_GAMMA,
    THRESHOLDS,
    threshold_mode,
)
from adavar.dynamic.controller import REANCHOR, check_whole, controller_outputs, make_controller
from adavar.dynamic.events import flag_runs, join_runs
from adavar.dynamic.ici import ici_schedule
from adavar.dynamic.long_tau import LONG_TAU_SAMPLES, long_tau_changes
from adavar.dynamic.thresholds import Thresholds, threshold_summary
from adavar.dynamic.window_defaults import (
    resolve_windows,
    stage_parameters,
    staged_controllers,
)
from adavar.dynamic.windows import centre_range, oracle_lengths
from adavar.io import sources
from adavar.io.sampling import resolve_tau0
from adavar.io.scaling import scaled_source
from adavar.io.sources import ChunkedSource

__all__ = ["METHODS", "Schedule", "adaptive_schedule", "record_size", "window_lengths"]

METHODS = ("adaptive", "kurtosis", "oracle", "fixed", "ici")

# ---------------------------------------------------------------------------------------
# schedules


@dataclass(frozen=True)
class Schedule:
    """A per-centre window schedule and the controller's decisions.

    The controller visits every centre; the schedule keeps all of them (``step = 1``) or
    only the centres that are multiples of ``step`` (``adaptive_schedule(..., step=k)``, the
    centres :func:`adavar.davar` computes with that step), which is what the out-of-core
    path returns: ``N / step`` rows instead of ``N``.

    Attributes
    ----------
    window : ndarray of int64, shape (N,)
        Window length used at each centre (the length in force before the update).
    kurtosis : ndarray, shape (N,)
        Pearson kurtosis of that window.
    s : ndarray, shape (N,)
        Sliding kurtosis contribution coefficient of its last ``l`` samples (Eq. 15).
    f1, f2, f : ndarray of bool, shape (N,)
        The kurtosis flag (Eq. 16), the S flag (Eq. 17) and their combination (Eq. 18); for
        ``"kurtosis"`` ``f = f1``; for ``"oracle"`` and ``"fixed"`` the flags the
        adaptive controller would have raised on those windows. For ``"ici"`` (no
        kurtosis test runs) ``kurtosis`` and ``s`` are NaN, ``f1`` and ``f2`` False and
        ``f`` marks the centres whose window is not the centred ``lmax`` one (shorter, or
        one-sided next to a change).
    centre : ndarray of int64
        Sample index of each centre.
    method : str
    thresholds : Thresholds
    parameters : dict
        Every setting used, for reports.
    step : int
        The rows are the centres that are multiples of ``step`` (1: every centre).
    shift : ndarray of int64 or None
        ``"ici"``: offset of each window from its centre (a one-sided window next to a
        change, see :mod:`adavar.dynamic.ici`; ``davar(..., shift=)``); None: centred windows.
    runs : ndarray of int64, shape (R, 2), or None
        ``adaptive_schedule(..., keep="runs")``: the first and last centre (sample index)
        of every run of ``f`` over all centres, the per-centre arrays being empty; None
        otherwise (:meth:`flag_runs` computes them from ``f``).
    """

    window: np.ndarray
    kurtosis: np.ndarray
    s: np.ndarray
    f1: np.ndarray
    f2: np.ndarray
    f: np.ndarray
    centre: np.ndarray
    method: str
    thresholds: Thresholds
    parameters: dict[str, Any] = field(default_factory=dict)
    step: int = 1
    shift: np.ndarray | None = None
    runs: np.ndarray | None = None

    def flag_runs(self) -> np.ndarray:
        """``(first, last)`` centre of every run of ``f``, shape (R, 2) int64."""
        if self.runs is not None:
            return self.runs
        runs = flag_runs(self.f)
        return np.asarray(self.centre, dtype=np.int64)[runs] if runs.size else runs


def window_lengths(
    dt: float,
    *,
    lmax: Any,
    lmin: Any,
    l: Any,  # noqa: E741 - the paper's name
    step: Any,
) -> tuple[int, int, int, int]:
    """The window-like parameters in samples (durations converted, docs/method.md section 8).

    A duration rounds to the nearest sample; a duration ``lmin`` then takes the nearest
    length of ``lmax``'s parity (the window keeps the parity of its length).
    """
    big = check_whole("lmax", to_samples(lmax, dt, "lmax"), 5)
    small = check_whole("lmin", to_samples(lmin, dt, "lmin"), 5)
    if is_duration(lmin) and (big - small) % 2:
        small = small + 1 if small + 1 <= big else small - 1
    seg = check_whole("l", to_samples(l, dt, "l"), 1)
    every = check_whole("step", to_samples(step, dt, "step"), 1)
    return big, small, seg, every


def record_size(data: Any, chunked: bool) -> int:
    """Samples of the record (before it is checked: 0 for what is not a 1-D record)."""
    if chunked:
        return int(sources.as_source(data).size)
    shape = np.shape(data)
    return int(shape[0]) if len(shape) == 1 else 0


def adaptive_schedule(
    data: Sequence[float] | np.ndarray | ChunkedSource,
    *,
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
    edges: str = "mirror",
    change_times: Sequence[float] | None = None,
    thresholds: str = THRESHOLDS,
    false_alarm: float | None = None,
    rate: float = 1.0,
    tau0: float | None = None,
    step: Length = 1,
    chunk_size: int | None = None,
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
    dependence: Sequence[float] | None = None,
    kurtosis_reference: str | dict = "record",
    keep: str = "all",
) -> Schedule:
    """The window schedule of A-DAVAR, DAVAR-K, the oracle or a fixed window.

    Parameters are those of :func:`adaptive_davar` (which calls this and then
    :func:`adavar.davar` on the schedule), and:

    Parameters
    ----------
    data : array_like, ChunkedSource, numpy.memmap or dask.array.Array
        The rate record. A source, a memory map of a file or a dask array is streamed
        (see ``chunk_size``).
    step : int, str, Duration or timedelta
        Keep the controller's outputs at the centres that are multiples of ``step`` only
        (the centres of ``davar(..., step=step)``); the controller still visits every centre.
        Samples or a duration. (``lmax``, ``lmin`` and ``l`` take durations as well, see
        :func:`adaptive_davar`.)
    chunk_size : int, optional
        Run out of core: the mirror-extended record is read about ``chunk_size`` centres at a
        time (rounded up to a multiple of :data:`REANCHOR`, plus ``lmax // 2 + 1`` samples
        each side) and the controller carries its window length from piece to piece.
        Default: in memory for an array, :data:`adavar.stats.stream.DEFAULT_CHUNK` for a chunked
        input. The result is identical to the in-memory one (the running sums restart at
        every multiple of REANCHOR, so a piece that starts there from the carried length
        repeats the sequential pass bit for bit). Held in memory: one piece and its
        per-centre outputs (about 40 bytes per centre of the piece) plus the ``N / step``
        kept rows. ``method="ici"`` runs in memory only: a chunked input without
        ``chunk_size`` is read into memory, an explicit ``chunk_size`` is an error.
    ici_gamma, ici_lengths, ici_taus, ici_sides, ici_edf, ici_edf_samples, ici_kurtosis
    ici_episodes, ici_long_tau
        The options of ``method="ici"`` (:func:`adavar.dynamic.ici.ici_schedule`), see
        :func:`adaptive_davar`.
    dependence, kurtosis_reference
        See :func:`adaptive_davar`.
    keep : {"all", "runs"}
        ``"runs"``: keep only the runs of flagged centres (``Schedule.runs``), running the
        controller over pieces of centres (``chunk_size``, default
        :data:`adavar.stats.stream.DEFAULT_CHUNK`) and holding no per-centre array: beyond the
        record (or, out of core, one piece of it) memory is bounded by one piece whatever
        the record's length (the change times of a fixed window,
        :func:`adavar.dynamic.events.run_change_times`). Not for ``method="ici"``.

    Returns
    -------
    Schedule
        One row per centre (``step = 1``) or per kept centre.
    """
    if method not in METHODS:
        raise AdavarInputError(f"unknown method {method!r}: use one of {', '.join(METHODS)}")
    if edges not in ("mirror", "valid"):
        raise AdavarInputError(f"unknown edges {edges!r}: use 'mirror' or 'valid'")
    dt = resolve_tau0(rate, tau0)
    if keep not in ("all", "runs") or (keep == "runs" and method == "ici"):
        raise AdavarInputError(f"keep={keep!r} with method={method!r}: use 'all' (or 'runs' "
                               "with a kurtosis-controller method)")  # fmt: skip
    chunked = chunk_size is not None or sources.is_chunked(data)
    if lmax is None or lmin is None or l is None:
        lmax, lmin, l = resolve_windows(record_size(data, chunked), dt, lmax, lmin, l)  # noqa: E741
    lmax, lmin, seg, step = window_lengths(dt, lmax=lmax, lmin=lmin, l=l, step=step)
    thresholds, false_alarm, false_alarm_per_hour = threshold_mode(
        thresholds, false_alarm, false_alarm_per_hour
    )
    if method == "ici":  # not a kurtosis controller: its own module, in memory
        if chunk_size is None and sources.is_chunked(data):  # a memory map, a lazy channel
            source = sources.as_source(data)
            data, chunked = source.read(0, source.size), False
        if chunked:
            raise AdavarInputError(
                "method='ici' runs in memory: leave chunk_size (--chunk-size) out and pass the "
                "record as an array (numpy.asarray), or use method='adaptive' out of core"
            )
        ici = dict(gamma=ici_gamma, lengths=ici_lengths, taus=ici_taus, sides=ici_sides,
                   edf=ici_edf, edf_samples=ici_edf_samples, kurtosis=ici_kurtosis,
                   episodes=ici_episodes)  # fmt: skip
        return _ici(data, lmax=lmax, lmin=lmin, seg=seg, edges=edges, step=step, dt=dt,
                    options=ici, long_tau=ici_long_tau)  # fmt: skip
    chunk = sources.DEFAULT_CHUNK
    if chunk_size is not None:
        chunk = sources.check_chunk_size(chunk_size)
    settings = dict(
        method=method, lmax=lmax, lmin=lmin, seg=seg, dl0=dl0, dl1=dl1, k1=k1, k2=k2, s1=s1,
        s2=s2, s_test=s_test, combine=combine, thresholds=thresholds, false_alarm=false_alarm,
        false_alarm_per_hour=false_alarm_per_hour, rate=1.0 / dt,
        kurtosis_reference=kurtosis_reference,
    )  # fmt: skip
    # a record shorter than lmax is refused before the thresholds of every window length
    # are built (lmax = 1e21 samples would not fit in memory)
    size = record_size(data, chunked)
    if 0 < size < lmax:
        raise AdavarInputError(_lmax_too_long(size, lmax))
    # the settings checked before the record is read (the calibration waits for it)
    quick = settings | {"thresholds": "paper"} if thresholds == "calibrated" else settings
    make_controller(**quick)
    # the kurtosis is scale-free: the record is run at scale 1 (exact, a power of two), so
    # its fourth powers neither overflow (data near 1e80) nor underflow (near 1e-80)
    refuse_masked(data)
    if chunked:
        source, _ = scaled_source(sources.as_source(data))
        n = source.size
        if n < lmax:
            raise AdavarInputError(_lmax_too_long(n, lmax))

        def head(k: int) -> np.ndarray:  # in pieces of the chunk size (bounded reads)
            k = min(n, k)
            return np.concatenate([source.read(a, min(k, a + chunk)) for a in range(0, k, chunk)])
    else:
        x, _ = scaled(as_samples(data, min_length=lmax))
        n = x.size

        def head(k: int) -> np.ndarray:
            return x[:k]

    stages = staged_controllers(settings, head, n, lmax, dependence)
    ctl = stages[-1][1]  # the controller of the bulk of the record, for the parameters
    th = ctl.thresholds
    measured = ctl.dependence
    changes = None
    if method == "oracle":
        if change_times is None or len(change_times) == 0:
            raise AdavarInputError("method='oracle' needs change_times (seconds)")
        times = np.asarray(change_times, dtype=float)
        for c in times:
            if not 0.0 < c < n * dt:
                raise AdavarInputError(
                    f"change time {c:g} s lies outside the record (0 .. {n * dt:g} s)"
                )
        changes = np.round(times / dt).astype(np.int64)

    # the controller's centre q is sample first + q; "valid": those whose lmax window fits
    first = (lmax - 1) // 2 if edges == "valid" else 0
    n_c = n - lmax + 1 if edges == "valid" else n
    pad = lmax // 2 + 1  # mirror: centre q at ext[q + pad]

    def given(q0: int, q1: int) -> np.ndarray:
        """Lengths of centres q0 .. q1 - 1 for the oracle and fixed methods."""
        if method == "oracle":
            return oracle_lengths(np.arange(first + q0, first + q1), changes, lmax, lmin)
        if method == "fixed":
            return np.full(q1 - q0, lmax, dtype=np.int64)
        return np.zeros(1, dtype=np.int64)

    def run(ext: np.ndarray, offset: int, q0: int, q1: int, start_length: int) -> tuple:
        """Centres q0 .. q1 - 1 (centre q0 at ext[offset]), each stage by its controller."""
        cuts = [c for c, _ in stages[1:] if q0 < c < q1]
        if not cuts:
            stage = len(stages) - 1
            while stages[stage][0] > q0:
                stage -= 1
            record = None if edges == "valid" else (q0, n)
            lengths = given(q0, q1)
            return stages[stage][1].run(ext, offset, q1 - q0, start_length, lengths, record=record)
        out = controller_outputs(q1 - q0)
        length = start_length
        for a, b in zip([q0, *cuts], [*cuts, q1], strict=True):
            part, length = run(ext, offset + a - q0, a, b, length)
            for dst, src in zip(out, part, strict=True):
                dst[a - q0 : b - q0] = src
        return out, length

    # kept rows: the centres that are multiples of step
    c0 = -(-first // step) * step
    # the surface's centres too (mirror); none kept with keep="runs"
    centres = centre_range(c0, first + n_c if keep == "all" else c0, step)
    # pieces start at multiples of REANCHOR, where the running sums restart anyway
    piece = -(-chunk // REANCHOR) * REANCHOR
    runs: list[np.ndarray] = []
    if not chunked and keep == "runs":  # the record in memory, the outputs piece by piece
        ext = x if edges == "valid" else np.pad(x, pad, mode="symmetric")
        out, length = controller_outputs(0), lmax
        for q0 in range(0, n_c, piece):
            part, length = run(ext, (first if edges == "valid" else pad) + q0, q0,
                               min(n_c, q0 + piece), length)  # fmt: skip
            runs.append(flag_runs(part[5], first + q0))
    elif not chunked:
        ext = x if edges == "valid" else np.pad(x, pad, mode="symmetric")
        out, _ = run(ext, first if edges == "valid" else pad, 0, n_c, lmax)
        if step > 1:  # copies: the full per-centre arrays are released
            out = tuple(a[c0 - first :: step].copy() for a in out)
    else:
        out = controller_outputs(0 if keep == "runs" else centres.size)
        length = lmax
        kept = 0
        for q0 in range(0, n_c, piece):
            q1 = min(n_c, q0 + piece)
            if edges == "valid":  # windows of centres q0 .. q1-1 span x[q0 : q1 + lmax - 1]
                ext = source.read(q0, q1 + lmax - 1)
                offset = first
            else:
                ext = sources.read_extended(source, q0, q1 + 2 * pad, pad)
                offset = pad
            part, length = run(ext, offset, q0, q1, length)
            del ext
            if keep == "runs":
                runs.append(flag_runs(part[5], first + q0))
                continue
            rows = slice((-(first + q0)) % step, None, step)
            count = len(range(q1 - q0)[rows])
            for dst, src in zip(out, part, strict=True):
                dst[kept : kept + count] = src[rows]
            kept += count
            del part
        if kept != centres.size:  # pragma: no cover - internal consistency
            raise AssertionError("internal: kept rows do not match the centres")
    if step == 1 and keep == "all":
        centres = centre_range(first, first + n_c)
    window, kurt, scoef, f1, f2, f = out
    parameters = dict(
        method=method, lmax=lmax, lmin=lmin, k1=float(k1), k2=float(k2), s1=float(s1),
        s2=float(s2), l=seg, dl0=dl0, dl1=dl1, s_test=s_test, combine=combine, edges=edges,
        thresholds=thresholds, false_alarm=float(false_alarm) if thresholds == "calibrated"
        and measured is None else None,
        false_alarm_per_hour=None if measured is None else float(false_alarm_per_hour),
        dependence=None if measured is None else list(measured), sample_rate=1.0 / dt,
        dependence_stages=stage_parameters(stages, dependence, n, lmax),
        thresholds_used=threshold_summary(th, lmin, lmax),
        change_times=None if change_times is None else list(map(float, change_times)),
        kurtosis_reference=None if thresholds != "calibrated" else kurtosis_reference
        if isinstance(kurtosis_reference, str) else "given",
        kurtosis_reference_fit=None if ctl.reference is None else ctl.reference.as_dict(),
    )  # fmt: skip
    return Schedule(
        window=window, kurtosis=kurt, s=scoef, f1=f1, f2=f2, f=f, centre=centres,
        method=method, thresholds=th, parameters=parameters, step=step,
        runs=join_runs(runs) if keep == "runs" else None,
    )  # fmt: skip


def _lmax_too_long(size: int, lmax: int) -> str:
    """The message of a record shorter than the longest window."""
    return (
        f"the record has {size} samples; at least {count_text(lmax)} are needed for the "
        f"longest window, lmax (--lmax) {count_text(lmax)}: give an lmax of at most {size} "
        "samples, or a longer record"
    )


#: The keywords of the ICI options of :func:`adaptive_schedule` in ici.py's messages.
_ICI_KEYWORDS = re.compile(r"\bici_(gamma|lengths|taus|sides|edf_samples|edf)\b")


def _ici_flags(message: str) -> str:
    """``message`` with each ICI keyword followed by its flag, once (``ici_lengths
    (--ici-lengths)``), as the other messages name ``chunk_size (--chunk-size)``."""
    seen: set[str] = set()

    def flag(match: re.Match[str]) -> str:
        word = match.group(0)
        option = "--" + word.replace("_", "-")
        if word in seen or option in message:
            return word
        seen.add(word)
        return f"{word} ({option})"

    return _ICI_KEYWORDS.sub(flag, message)


def _ici(
    data: Any, *, lmax: int, lmin: int, seg: int, edges: str, step: int, dt: float,
    options: dict, long_tau: bool = False,
) -> Schedule:  # fmt: skip
    """:func:`adavar.dynamic.ici.ici_schedule` as a :class:`Schedule` (kurtosis fields NaN/False;
    ``f``: the centred ``lmax`` window was not kept; ``parameters["ici_changes"]``: the
    detected steps, samples; ``"ici_ramps"``: the ramps; ``"ici_found"``: both, in order
    (:meth:`adavar.dynamic.ici_episodes.Episode.as_dict`); ``"ici_long_tau"``: the changes
    of :func:`adavar.dynamic.long_tau.long_tau_changes`, with ``long_tau``)."""
    if lmin > lmax:
        raise AdavarInputError(
            f"lmin (--lmin) {count_text(lmin)} must not exceed lmax (--lmax) "
            f"{count_text(lmax)}: give a shorter lmin or a longer lmax"
        )
    refuse_masked(data)
    x, k = scaled(as_samples(data, min_length=lmax))  # scale-free: run at scale 1 (exact)
    try:
        ici = ici_schedule(x, lmax=lmax, lmin=lmin, edges=edges, step=step, **options)
    except AdavarInputError as exc:  # ici.py names its keywords: add the flags
        raise AdavarInputError(_ici_flags(str(exc))) from None
    size = ici.centre.size
    nan = np.full(lmax + 1, np.nan)
    # no kurtosis test runs: its thresholds are recorded as NaN, never as numbers
    parameters = dict(ici.parameters, sample_rate=1.0 / dt, thresholds="none", k1=math.nan,
                      k2=math.nan, s1=math.nan, s2=math.nan, l=seg,
                      ici_changes=ici.changes.tolist(), ici_long_tau=None)  # fmt: skip
    if parameters.get("ici_found"):  # the levels in the record's units (squared)
        parameters["ici_found"] = [
            dict(e, before=math.ldexp(e["before"], 2 * k), after=math.ldexp(e["after"], 2 * k))
            for e in parameters["ici_found"]
        ]
    if long_tau and x.size >= LONG_TAU_SAMPLES:  # the long-tau terms' changes (events)
        found = long_tau_changes(x, tau0=dt, gamma=ici.gamma)
        parameters["ici_long_tau"] = [c.as_dict() for c in found.changes]
    return Schedule(
        window=ici.window, kurtosis=np.full(size, np.nan), s=np.full(size, np.nan),
        f1=np.zeros(size, dtype=bool), f2=np.zeros(size, dtype=bool),
        f=(ici.window < lmax) | (ici.shift != 0), centre=ici.centre, method="ici",
        thresholds=Thresholds(k1=nan, k2=nan, s2=nan, source="none (ICI)"),
        parameters=parameters, step=step, shift=ici.shift,
    )  # fmt: skip

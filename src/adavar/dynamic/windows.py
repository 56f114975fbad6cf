"""Window schedules: which samples each DAVAR window holds, and how the record is extended.

The convention, used everywhere in adavar (the DAVAR engine, the sliding kurtosis, the
adaptive controller): a window of ``L`` samples centred at sample ``p`` holds samples

    ``p - (L - 1) // 2  ..  p - (L - 1) // 2 + L - 1``

(docs/method.md section 5). For odd ``L`` it is symmetric; for even ``L`` it holds ``L/2 - 1``
samples before the centre and ``L/2`` after it. (The specification's sentence says "one more
sample before"; its formula, which is followed here, gives one more after.)

Near the ends of the record a window sticks out. With ``edges="mirror"`` (the paper,
docs/method.md section 6) the rate samples are time-reversed about each end (``numpy.pad(...,
mode="symmetric")``), which is the total-variance reflection of the integrated signal; with
``edges="valid"`` only centres whose whole window lies inside the record are used.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from adavar.core.durations import count_text
from adavar.core.errors import AdavarInputError

__all__ = [
    "EDGES",
    "MIN_WINDOW",
    "WindowClasses",
    "WindowSchedule",
    "centre_range",
    "check_window_times",
    "oracle_lengths",
    "oracle_schedule",
    "window_classes",
    "window_overhang",
    "window_schedule",
    "window_start",
]

EDGES = ("mirror", "valid")
MIN_WINDOW = 3  # the shortest window with one Allan-variance term at m = 1
#: Float64 window times ``t0 + centre * tau0`` must resolve this fraction of the sample
#: interval: a ``t0`` far from the record (``1e18`` s) rounded them to 128 s, so that every
#: window of a 100 Hz record got one of a few times.
TIME_RESOLUTION = 0.1


_LAST_RANGE: list[Any] = [None, None]  # (start, stop, step), a weak reference to it
_RANGE_LOCK = threading.Lock()


def centre_range(start: int, stop: int, step: int = 1) -> np.ndarray:
    """``np.arange(start, stop, step)`` of int64, read-only, and while someone holds it the
    same array for the next caller who asks for the same range.

    The adaptive controller's centres and its surface's are the same N integers: one
    array for both instead of two (a copy of the record each, at an analysis' peak).
    """
    key = (int(start), int(stop), int(step))
    with _RANGE_LOCK:
        held = _LAST_RANGE[1]() if _LAST_RANGE[0] == key else None
        if held is None:
            held = np.arange(*key, dtype=np.int64)
            held.flags.writeable = False
            _LAST_RANGE[:] = [key, weakref.ref(held)]
    return held


def window_start(centre: Any, length: Any) -> Any:
    """First sample of the window of ``length`` samples centred at ``centre``."""
    return centre - (length - 1) // 2


def window_overhang(centre: Any, length: Any, n_samples: int) -> np.ndarray:
    """Samples of each window that lie outside the record (in the mirrored extension).

    Parameters
    ----------
    centre, length : array_like of int
        Window centres and lengths (samples).
    n_samples : int
        Length of the record (rate samples).

    Returns
    -------
    ndarray of int64
        ``max(0, -start) + max(0, start + length - n_samples)`` per window.
    """
    centre = np.asarray(centre, dtype=np.int64)
    length = np.asarray(length, dtype=np.int64)
    start = window_start(centre, length)
    return np.maximum(0, -start) + np.maximum(0, start + length - n_samples)


@dataclass(frozen=True)
class WindowSchedule:
    """The windows of a DAVAR computation.

    Attributes
    ----------
    centre : ndarray of int64
        Sample index of each window's centre in the original record.
    length : ndarray of int64
        Window length (samples) per centre.
    pad_before, pad_after : int
        Samples added by mirroring before the first and after the last sample (0 for
        ``edges="valid"``).
    n_samples : int
        Length of the original record.
    edges : str
        ``"mirror"`` or ``"valid"``.
    step : int
        Spacing of the candidate centres.
    shift : ndarray of int64 or None
        Offset of each window from its centre (None: every window centred on its centre).
        The window of centre ``p`` is the one centred at ``p + shift``: a one-sided window
        (:mod:`adavar.dynamic.ici`) is a centred window at a shifted centre.
    """

    centre: np.ndarray
    length: np.ndarray
    pad_before: int
    pad_after: int
    n_samples: int
    edges: str
    step: int
    shift: np.ndarray | None = None

    @property
    def window_centre(self) -> np.ndarray:
        """The sample each window is centred on (``centre + shift``; the window kernels'
        centres)."""
        return self.centre if self.shift is None else self.centre + self.shift

    @property
    def start(self) -> np.ndarray:
        """First sample of each window, counted in the *extended* record."""
        return window_start(self.window_centre, self.length) + self.pad_before

    def extend(self, samples: np.ndarray) -> np.ndarray:
        """The record with its mirrored ends (the array that ``start`` indexes)."""
        if self.pad_before == 0 and self.pad_after == 0:
            return samples
        return np.pad(samples, (self.pad_before, self.pad_after), mode="symmetric")


#: windows scanned at a time for the ones that reach into a mirrored end
_SCAN_ROWS = 1 << 16


class WindowClasses:
    """The windows of a schedule grouped by what their EDF depends on.

    An interior window's EDF depends on its length only; a window that reaches into a
    mirrored end (``edges="mirror"``) on its length and its overhang
    (:func:`window_overhang`). Class ``k < lengths.size`` is the interior windows of
    length ``lengths[k]``; class ``lengths.size + j`` the edge windows of (length,
    overhang) ``edge_pairs[j]``. :meth:`rows` gives the classes of a range of windows,
    so a surface computed a block of windows at a time never holds every window's.

    Attributes
    ----------
    lengths : ndarray of int64
        The distinct window lengths, increasing.
    edge_pairs : ndarray of int64, shape (k, 2)
        The distinct (length, overhang) of the windows that overhang, in lexicographic
        order (none when the schedule's edge windows are classed by length).
    """

    def __init__(self, schedule: WindowSchedule, edges_apart: bool = True) -> None:
        self.schedule = schedule
        present = np.bincount(schedule.length) > 0
        self.lengths = np.flatnonzero(present)
        # lengths are small integers: classes by a lookup table, not a sort of N values
        self._lookup = np.cumsum(present) - 1
        # the extended record holds every window, so no overhang exceeds the two pads:
        # length * base + overhang orders the pairs as (length, overhang) does
        self._base = schedule.pad_before + schedule.pad_after + 1
        codes = []
        if edges_apart and schedule.pad_before + schedule.pad_after > 0:
            for a in range(0, schedule.centre.size, _SCAN_ROWS):
                length, overhang = self._overhang(a, a + _SCAN_ROWS)
                edge = overhang > 0
                codes.append(length[edge] * self._base + overhang[edge])
        self._codes = np.unique(np.concatenate(codes)) if codes else np.empty(0, np.int64)
        self.edge_pairs = np.stack(np.divmod(self._codes, self._base), axis=1)

    def _overhang(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
        """Lengths and overhangs of windows ``start .. stop - 1``."""
        sched = self.schedule
        centre, length = sched.centre[start:stop], sched.length[start:stop]
        if sched.shift is not None:
            centre = centre + sched.shift[start:stop]
        return length, window_overhang(centre, length, sched.n_samples)

    @property
    def n_classes(self) -> int:
        """Number of classes (rows of an EDF table)."""
        return int(self.lengths.size + self._codes.size)

    def rows(self, start: int = 0, stop: int | None = None) -> np.ndarray:
        """The class of each window ``start .. stop - 1`` (default: every window)."""
        stop = self.schedule.centre.size if stop is None else min(stop, self.schedule.centre.size)
        classes = self._lookup[self.schedule.length[start:stop]]
        if self._codes.size:
            for a in range(start, stop, _SCAN_ROWS):
                length, overhang = self._overhang(a, min(stop, a + _SCAN_ROWS))
                edge = np.flatnonzero(overhang > 0)
                code = length[edge] * self._base + overhang[edge]
                classes[a - start + edge] = self.lengths.size + np.searchsorted(self._codes, code)
        return classes


def window_classes(schedule: WindowSchedule, *, edges_apart: bool = True) -> WindowClasses:
    """The EDF classes of a schedule's windows (:class:`WindowClasses`); ``edges_apart=
    False`` classes the windows that overhang by their length, as interior ones."""
    return WindowClasses(schedule, edges_apart)


def _as_step(step: Any) -> int:
    if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or step < 1:
        raise AdavarInputError(f"step must be a positive integer, got {step!r}")
    return int(step)


def _as_lengths(window: Any, n_samples: int) -> np.ndarray | int:
    """An int, or a 1-D array of ints; checked against the record length."""
    if isinstance(window, bool):
        raise AdavarInputError(f"window must be a number of samples, got {window!r}")
    if isinstance(window, (int, np.integer)):
        lengths: np.ndarray | int = int(window)
        lo = hi = int(window)
    else:
        try:
            arr = np.asarray(window)
        except Exception:  # pragma: no cover - exotic containers
            raise AdavarInputError("window must be an int or an array of ints") from None
        if arr.ndim == 0:
            value = arr.item()
            if isinstance(value, float) and value.is_integer():
                return _as_lengths(int(value), n_samples)
            if isinstance(value, int) and not isinstance(value, bool):
                return _as_lengths(value, n_samples)
            raise AdavarInputError(f"window must be a whole number of samples, got {window!r}")
        if arr.ndim != 1 or arr.size == 0:
            raise AdavarInputError(
                f"window must be an int or a 1-D array of ints, got shape {arr.shape}"
            )
        if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
            raise AdavarInputError("window must hold whole numbers of samples")
        if np.issubdtype(arr.dtype, np.floating):
            if not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
                raise AdavarInputError("window must hold whole numbers of samples")
        if arr.dtype == np.int64 and not arr.flags.writeable:
            lengths = arr  # read-only: safe to share (the adaptive controller's schedule)
        else:
            lengths = arr.astype(np.int64)  # a copy: the result must not alias the caller
        lo, hi = int(lengths.min()), int(lengths.max())
    if lo < MIN_WINDOW:
        raise AdavarInputError(
            f"window of {lo} samples is too short: a window needs at least {MIN_WINDOW} "
            "samples (one Allan-variance term at m = 1)"
        )
    if hi > n_samples:
        raise AdavarInputError(
            f"window of {count_text(hi)} samples is longer than the record ({n_samples} "
            "samples): "
            "choose a shorter window"
        )
    return lengths


def window_schedule(
    n_samples: int, window: Any, *, edges: str = "mirror", step: int = 1, shift: Any = None
) -> WindowSchedule:
    """Centres, lengths and starts of the DAVAR windows of a record.

    Parameters
    ----------
    n_samples : int
        Length of the record (rate samples).
    window : int or array_like of int
        A fixed length (DAVAR-L), or one length per sample of the record (``n_samples``
        values, e.g. an adaptive schedule), or one per candidate centre
        (``ceil(n_samples / step)`` values, for samples ``0, step, 2 step, ...``). With
        ``edges="valid"`` the candidates whose window fits in the record are kept, whichever
        form the lengths come in.
    edges : {"mirror", "valid"}
        ``"mirror"``: every ``step``-th sample is a centre and the record is extended by
        time reversal at both ends; ``"valid"``: only centres whose whole window lies in
        the record.
    step : int
        Spacing of the centres: samples ``0, step, 2 step, ...`` are candidates.
    shift : array_like of int, optional
        Offset of each window from its centre, in the forms ``window`` takes (one per
        sample or one per candidate centre): the window of centre ``p`` holds
        ``p + shift - (L - 1) // 2 .. p + shift - (L - 1) // 2 + L - 1``. None (default):
        centred windows. ``edges="valid"`` keeps the centres whose shifted window fits.

    Returns
    -------
    WindowSchedule

    Raises
    ------
    AdavarInputError
        A window shorter than 3 samples or longer than the record, a bad ``step`` or
        ``edges``, a window or shift array of the wrong length, or no valid centre.
    """
    if edges not in EDGES:
        raise AdavarInputError(f"unknown edges {edges!r}: use 'mirror' or 'valid'")
    step = _as_step(step)
    n_samples = int(n_samples)
    lengths = _as_lengths(window, n_samples)
    candidates = centre_range(0, n_samples, step)
    offsets = _as_shift(shift, n_samples, candidates, step)
    if offsets is not None and isinstance(lengths, int):
        lengths = np.full(candidates.size, lengths, dtype=np.int64)  # per-window starts
    if isinstance(lengths, int):
        length = None
    elif lengths.size == n_samples:
        length = lengths if step == 1 else lengths[candidates]
    elif lengths.size == candidates.size:
        length = lengths
    else:
        per_centre = f" or {candidates.size} (one per centre)" if step > 1 else ""
        raise AdavarInputError(
            f"window array has {lengths.size} values; give {n_samples} (one per sample){per_centre}"
        )
    if isinstance(lengths, int):
        # one length: the starts follow the centres, no per-centre arithmetic needed
        before, after = (lengths - 1) // 2, lengths - 1 - (lengths - 1) // 2
        if edges == "valid":
            candidates = candidates[(candidates >= before) & (candidates + after < n_samples)]
        first = int(candidates[0]) if candidates.size else 0
        last = int(candidates[-1]) if candidates.size else 0
        lowest, highest = first - before, last + after + 1
    else:
        start = window_start(candidates if offsets is None else candidates + offsets, length)
        if edges == "valid":
            keep = (start >= 0) & (start + length <= n_samples)
            candidates, length, start = candidates[keep], length[keep], start[keep]
            if offsets is not None:
                offsets = offsets[keep]
        lowest = int(start.min()) if start.size else 0
        highest = int((start + length).max()) if start.size else 0
    if candidates.size == 0:
        raise AdavarInputError(
            "no window fits inside the record with edges='valid': use a shorter window "
            "or edges='mirror'"
        )
    if isinstance(lengths, int):
        length = np.full(candidates.size, lengths, dtype=np.int64)
    pad_before = max(0, -lowest)
    pad_after = max(0, highest - n_samples)
    return WindowSchedule(
        centre=candidates,
        length=length,
        pad_before=pad_before,
        pad_after=pad_after,
        n_samples=n_samples,
        edges=edges,
        step=step,
        shift=offsets,
    )


def _as_shift(shift: Any, n_samples: int, candidates: np.ndarray, step: int) -> np.ndarray | None:
    """The per-candidate window offsets (int64), or None for centred windows."""
    if shift is None:
        return None
    arr = np.asarray(shift)
    if arr.ndim != 1 or not np.issubdtype(arr.dtype, np.integer):
        raise AdavarInputError("shift must be a 1-D array of whole numbers of samples")
    if arr.size == n_samples:
        arr = arr if step == 1 else arr[candidates]
    elif arr.size != candidates.size:
        per_centre = f" or {candidates.size} (one per centre)" if step > 1 else ""
        raise AdavarInputError(
            f"shift array has {arr.size} values; give {n_samples} (one per sample){per_centre}"
        )
    if arr.size and int(np.abs(arr).max()) > n_samples:
        raise AdavarInputError(
            f"a shift of {int(np.abs(arr).max())} samples is longer than the record "
            f"({n_samples} samples): give offsets within it"
        )
    return arr.astype(np.int64)


def check_window_times(time: np.ndarray, centre: np.ndarray, t0: float, dt: float) -> None:
    """A one-line error when the window times ``t0 + centre * dt`` are not usable.

    Raises
    ------
    AdavarInputError
        The last one overflows float64, or float64 numbers near the largest are further
        apart than :data:`TIME_RESOLUTION` times the sample interval ``dt`` (a ``t0`` far
        from the record: the times would no longer tell the samples apart).
    """
    if time.size == 0:
        return
    if not np.isfinite(time[-1]):
        raise AdavarInputError(
            f"the time of the last centre ({int(centre[-1])} samples of {dt:g} s after "
            f"t0 = {t0:g} s) overflows float64: check the rate (Hz), tau0 (s) and t0 (s)"
        )
    largest = float(max(abs(time[0]), abs(time[-1])))
    spacing = float(np.spacing(largest))
    if spacing > TIME_RESOLUTION * dt:
        raise AdavarInputError(
            f"t0 = {t0:g} s is too far from the record for float64 window times: near "
            f"{largest:.3g} s they are {spacing:g} s apart, coarser than a tenth of the sample "
            f"interval {dt:g} s; give t0 relative to an origin near the record (0 by "
            "default) and add the offset to the times yourself"
        )


def oracle_schedule(
    n_samples: int, change_samples: Sequence[int], *, lmax: int = 600, lmin: int = 400
) -> np.ndarray:
    """The ideal window lengths for changes at known samples (docs/method.md section 8).

    For each change ``X`` the length is ``lmax`` until the window's leading edge reaches
    ``X``, shrinks with the leading edge pinned on ``X`` to ``lmin``, stays there until the
    trailing edge reaches ``X``, and regrows with the trailing edge pinned on ``X``; with
    the window convention of :mod:`adavar.dynamic.windows` (edges ``p + L // 2`` and
    ``p - (L - 1) // 2``) that is ``clamp(max(2 (X - p), 2 (p - X + 1)), lmin, lmax)`` for
    even lengths. Several changes: the shortest of their lengths.

    Parameters
    ----------
    n_samples : int
        Record length.
    change_samples : sequence of int
        Sample indices of the changes.
    lmax, lmin : int
        Longest and shortest window.

    Returns
    -------
    ndarray of int64, shape (n_samples,)
    """
    return oracle_lengths(np.arange(n_samples, dtype=np.int64), change_samples, lmax, lmin)


def oracle_lengths(
    p: np.ndarray, change_samples: Sequence[int], lmax: int, lmin: int
) -> np.ndarray:
    """:func:`oracle_schedule` at the centres ``p`` only (a piece of a long record)."""
    p = np.asarray(p, dtype=np.int64)
    out = np.full(p.size, lmax, dtype=np.int64)
    odd = lmax % 2
    for x in change_samples:
        x = int(x)
        ideal = np.maximum(2 * (x - p), 2 * (p - x + 1)) + odd
        out = np.minimum(out, np.clip(ideal, lmin, lmax))
    return out

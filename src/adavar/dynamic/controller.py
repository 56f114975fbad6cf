"""The adaptive window's controller: the sequential pass of docs/method.md section 8, compiled.

The controller walks the centres in order. At each centre ``p`` it takes the window of the
current length ``L`` centred at ``p`` (mirror-extended record), computes its kurtosis ``k``
and the sliding kurtosis contribution coefficient ``S`` of its last ``l`` samples, raises
``f1`` (``k`` outside ``[K1, K2]``, Eq. 16) and ``f2`` (``S > S2``, Eq. 17), combines them
(Eq. 18), records ``L`` and shrinks it by ``dL1`` or regrows it by ``dL0`` within
``[Lmin, Lmax]`` (Eq. 19-22).

The pass is O(N): the window and its leading segment slide by at most ``max(dL0, dL1)``
samples per step, and their power sums ``sum (x - a)**k``, ``k = 1..4``, are kept in
double-double precision around an anchor ``a`` moved to the window's mean every
:data:`REANCHOR` centres (the sums are then recomputed), so offsets of 1e6 standard
deviations, drifts and bursts cost no digits. Everything from a multiple of REANCHOR on
depends only on the length in force there: a run of centres that starts at such a centre
from the right length repeats the sequential pass bit for bit. That is what lets the pass
run in speculative parallel segments, in pieces out of core (:func:`adavar.adaptive_schedule`)
and live (:class:`adavar.OnlineAdaptive`) with one result.

:func:`make_controller` checks the settings and sets the thresholds once;
:meth:`Controller.run` runs the pass over a stretch of centres.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from adavar._kernels._jit import jit, read_only, threaded_jit, work_items
from adavar._kernels.double_double import two_sum
from adavar.core.durations import count_text
from adavar.core.errors import AdavarInputError
from adavar.dynamic.kurtosis_reference import (
    KurtosisReference,
    check_kurtosis_reference,
    record_reference,
)
from adavar.dynamic.thresholds import (
    DEPENDENCE_SAMPLES,
    Thresholds,
    calibrated_thresholds,
    fixed_thresholds,
    hourly_thresholds,
    noise_dependence,
    shifted,
)

__all__ = [
    "COMBINES",
    "CONTROLLER_METHODS",
    "REANCHOR",
    "S_TESTS",
    "WARM_UP",
    "Controller",
    "check_whole",
    "controller_outputs",
    "make_controller",
    "needs_head",
]

#: methods the kurtosis controller runs (adapting, or recording along a given schedule)
CONTROLLER_METHODS = ("adaptive", "kurtosis", "oracle", "fixed")
S_TESTS = ("upper", "band", "abs")
COMBINES = ("or", "and")
#: centres between re-anchorings of the running power sums (each costs O(L))
REANCHOR = 512
#: centres a speculative segment runs before its own start (see :func:`_speculate`)
WARM_UP = 8192

_S_TEST_CODE = {"upper": 0, "band": 1, "abs": 2}


@jit
def _acc(h, lo, v):  # pragma: no cover - compiled
    """Double-double accumulation; only ``h + v`` is on the loop-carried path."""
    s, e = two_sum(h, v)
    return s, lo + e


@jit
def _fresh_sums(x, i0, i1, anchor):  # pragma: no cover - compiled
    """Double-double ``sum (x[i] - anchor)**k``, k = 1..4, over ``[i0, i1)``: 8 floats."""
    h1 = l1 = h2 = l2 = h3 = l3 = h4 = l4 = 0.0
    for i in range(i0, i1):
        d = x[i] - anchor
        d2 = d * d
        h1, l1 = _acc(h1, l1, d)
        h2, l2 = _acc(h2, l2, d2)
        h3, l3 = _acc(h3, l3, d2 * d)
        h4, l4 = _acc(h4, l4, d2 * d2)
    return h1, l1, h2, l2, h3, l3, h4, l4


@jit
def _central(inv_n, s1, s2, s3, s4):  # pragma: no cover - compiled
    """Second and fourth central moments from power sums about an anchor near the mean."""
    d = s1 * inv_n
    e2 = s2 * inv_n
    m2 = e2 - d * d
    m4 = s4 * inv_n - 4.0 * d * (s3 * inv_n) + 6.0 * d * d * e2 - 3.0 * d * d * d * d
    return m2, m4


@jit
def _minus(h, lo, hs, ls):  # pragma: no cover - compiled
    """``(h + lo) - (hs + ls)`` rounded once the leading parts have cancelled exactly."""
    s, e = two_sum(h, -hs)
    return s + (e + (lo - ls))


@jit
def _moments(
    h1, l1, h2, l2, h3, l3, h4, l4, g1, k1_, g2, k2_, g3, k3_, g4, k4_, inv_x, inv_c
):  # fmt: skip  # pragma: no cover - compiled
    """(m2, m4) of the window (sums h, l) and of the window without its segment (g, k)."""
    m2x, m4x = _central(inv_x, h1 + l1, h2 + l2, h3 + l3, h4 + l4)
    m2c, m4c = _central(
        inv_c, _minus(h1, l1, g1, k1_), _minus(h2, l2, g2, k2_), _minus(h3, l3, g3, k3_),
        _minus(h4, l4, g4, k4_),
    )  # fmt: skip
    return m2x, m4x, m2c, m4c


@jit
def _window_mean(x, a, b):  # pragma: no cover - compiled
    """Mean of ``x[a:b]`` from a double-double sum (a deterministic re-anchoring point)."""
    h = 0.0
    lo = 0.0
    for i in range(a, b):
        h, lo = _acc(h, lo, x[i])
    return (h + lo) / (b - a)


@jit
def _tested_length(L, p, ends):  # pragma: no cover - compiled
    """The effective size of the window of length ``L`` at centre ``p`` (``ends`` as in
    :func:`_run`): ``L^2 / (L + 2 M)`` when it holds ``M`` mirrored samples, each the
    repeat of a sample it also holds (docs/method.md section 8); -1 if it holds none."""
    g = ends[0] + p
    h = (L - 1) // 2
    mirrored = max(0, h - g) + max(0, g - h + L - ends[1])
    if mirrored == 0:
        return -1
    w = L + 2 * mirrored
    return max((L * L + w // 2) // w, ends[2])


@jit(error_model="numpy")  # a window emptied of its variance by cancellation gives NaN
def _run(
    x, offset, p_start, p_end, record_from, L, lmax, lmin, k1, k2, s1, s2, seg, dl0, dl1,
    s_test, use_f2, use_and, adapt, given, ends, e1, e2, window, kurt, scoef, f1, f2, f,
):  # fmt: skip  # pragma: no cover - compiled
    """Run the controller over centres ``p_start .. p_end - 1`` from length ``L``.

    docs/method.md section 8. ``x`` is the extended record, centre ``p`` at ``x[p + offset]``.
    ``k1[L]``, ``k2[L]``, ``s2[L]`` are the thresholds for a window of length ``L``; a
    window that reaches into the mirror-extended ends takes ``e1`` and ``e2`` at its
    effective size instead (:func:`_tested_length`; ``ends`` = (record index of centre 0,
    record length or 0 for no mirror, shortest length of those tables)). With
    ``adapt`` false the lengths come from ``given`` and only the kurtosis, S and flags are
    recorded. Outputs are written for ``p >= record_from``. Returns the length in force
    at ``record_from`` and the length after the last update.

    The power sums of the window and of its leading segment live in scalars (registers;
    written as tuples passed through helper calls the loop ran six times slower). They are
    recomputed afresh, about the window's mean, at ``p_start`` and at every multiple of
    :data:`REANCHOR`: so everything from such a centre on depends only on the length in
    force there, which is what lets :func:`_speculate` run segments in parallel and still
    give the sequential result bit for bit.
    """
    inv = np.empty(lmax + 1)  # 1/n by lookup: no division on the loop-carried path
    inv[0] = np.inf
    for k in range(1, lmax + 1):
        inv[k] = 1.0 / k
    a = 0
    b = 0
    anchor = 0.0
    h1 = l1 = h2 = l2 = h3 = l3 = h4 = l4 = 0.0
    g1 = k1_ = g2 = k2_ = g3 = k3_ = g4 = k4_ = 0.0
    at_record = L
    for p in range(p_start, p_end):
        if not adapt:
            L = given[p]
        if p == record_from:
            at_record = L
        a_new = p + offset - (L - 1) // 2
        b_new = a_new + L
        if p == p_start or p % REANCHOR == 0:  # anchor at the window's mean, sum afresh
            anchor = _window_mean(x, a_new, b_new)
            h1, l1, h2, l2, h3, l3, h4, l4 = _fresh_sums(x, a_new, b_new, anchor)
            g1, k1_, g2, k2_, g3, k3_, g4, k4_ = _fresh_sums(x, b_new - seg, b_new, anchor)
            a = a_new
            b = b_new
        while a < a_new:  # the trailing edge advances: samples leave the window
            d = x[a] - anchor
            d2 = d * d
            h1, l1 = _acc(h1, l1, -d)
            h2, l2 = _acc(h2, l2, -d2)
            h3, l3 = _acc(h3, l3, -(d2 * d))
            h4, l4 = _acc(h4, l4, -(d2 * d2))
            a += 1
        while a > a_new:  # it retreats: samples rejoin
            a -= 1
            d = x[a] - anchor
            d2 = d * d
            h1, l1 = _acc(h1, l1, d)
            h2, l2 = _acc(h2, l2, d2)
            h3, l3 = _acc(h3, l3, d2 * d)
            h4, l4 = _acc(h4, l4, d2 * d2)
        while b < b_new:  # the leading edge advances: a sample enters window and segment
            d = x[b] - anchor
            d2 = d * d
            d3 = d2 * d
            d4 = d2 * d2
            h1, l1 = _acc(h1, l1, d)
            h2, l2 = _acc(h2, l2, d2)
            h3, l3 = _acc(h3, l3, d3)
            h4, l4 = _acc(h4, l4, d4)
            q = x[b - seg] - anchor  # ... and one leaves the segment
            q2 = q * q
            # added and removed separately, so that a burst cancels exactly when it leaves
            g1, k1_ = _acc(g1, k1_, d)
            g2, k2_ = _acc(g2, k2_, d2)
            g3, k3_ = _acc(g3, k3_, d3)
            g4, k4_ = _acc(g4, k4_, d4)
            g1, k1_ = _acc(g1, k1_, -q)
            g2, k2_ = _acc(g2, k2_, -q2)
            g3, k3_ = _acc(g3, k3_, -(q2 * q))
            g4, k4_ = _acc(g4, k4_, -(q2 * q2))
            b += 1
        while b > b_new:  # it retreats
            b -= 1
            d = x[b] - anchor
            d2 = d * d
            d3 = d2 * d
            d4 = d2 * d2
            h1, l1 = _acc(h1, l1, -d)
            h2, l2 = _acc(h2, l2, -d2)
            h3, l3 = _acc(h3, l3, -d3)
            h4, l4 = _acc(h4, l4, -d4)
            q = x[b - seg] - anchor
            q2 = q * q
            g1, k1_ = _acc(g1, k1_, -d)
            g2, k2_ = _acc(g2, k2_, -d2)
            g3, k3_ = _acc(g3, k3_, -d3)
            g4, k4_ = _acc(g4, k4_, -d4)
            g1, k1_ = _acc(g1, k1_, q)
            g2, k2_ = _acc(g2, k2_, q2)
            g3, k3_ = _acc(g3, k3_, q2 * q)
            g4, k4_ = _acc(g4, k4_, q2 * q2)
        m2x, m4x, m2c, m4c = _moments(
            h1, l1, h2, l2, h3, l3, h4, l4, g1, k1_, g2, k2_, g3, k3_, g4, k4_,
            inv[L], inv[L - seg],
        )  # fmt: skip
        # the decisions by products, not quotients: the next window waits only on them
        ok_x = m2x > 0.0
        ok = ok_x and m2c > 0.0
        vx = m2x * m2x
        lt = _tested_length(L, p, ends) if ends[1] > 0 else np.int64(-1)
        lo_k = k1[L] if lt < 0 else e1[lt]
        hi_k = k2[L] if lt < 0 else e2[lt]
        flag1 = not (ok_x and lo_k * vx <= m4x <= hi_k * vx)
        lhs = m4x * (m2c * m2c)  # kx - kc > t kx  <=>  (1 - t) m4x m2c^2 > m4c m2x^2
        rhs = m4c * vx
        above = ok and (1.0 - s2[L]) * lhs > rhs
        if s_test == 0:
            flag2 = above
        elif s_test == 1:
            flag2 = not ok or above or (1.0 - s1) * lhs < rhs
        else:
            flag2 = above or (ok and (1.0 + s2[L]) * lhs < rhs)
        if not use_f2:
            flag = flag1
        elif use_and:
            flag = flag1 and flag2
        else:
            flag = flag1 or flag2
        kx = m4x / vx if ok_x else np.nan
        kc = m4c / (m2c * m2c) if m2c > 0.0 else np.nan
        sv = (kx - kc) / kx if kx != 0.0 else np.nan
        if p >= record_from:
            window[p] = L
            kurt[p] = kx
            scoef[p] = sv
            f1[p] = flag1
            f2[p] = flag2
            f[p] = flag
        if adapt:
            if flag:
                L = max(L - dl1, lmin)
            else:
                L = min(L + dl0, lmax)
    return at_record, L


@jit
def _segment_bounds(n, n_segments):  # pragma: no cover - compiled
    """Bounds of the speculative segments of :func:`_speculate`: multiples of REANCHOR."""
    bounds = np.empty(n_segments + 1, dtype=np.int64)
    for k in range(n_segments + 1):
        bounds[k] = min(n, (k * n // n_segments) // REANCHOR * REANCHOR)
    bounds[n_segments] = n
    return bounds


@threaded_jit
def _speculate(
    x, offset, lmax, lmin, k1, k2, s1, s2, seg, dl0, dl1, s_test, use_f2, use_and, adapt,
    given, ends, e1, e2, window, kurt, scoef, f1, f2, f, bounds, warm_up, start_length,
    start_state, end_state, k_lo, k_hi,
):  # fmt: skip  # pragma: no cover - compiled
    """Segments ``k_lo .. k_hi - 1`` of the controller pass, each from a guessed length.

    The record is cut into pieces at ``bounds`` (multiples of :data:`REANCHOR`). Each
    piece but the first is run speculatively from ``lmax``, starting ``warm_up`` centres
    early (:data:`WARM_UP`) so that its length has forgotten the guess (the length
    coalesces with the true one whenever both sit at ``lmax`` or ``lmin``). Writes the
    length each piece had at its start and had after its end (:func:`_reconcile` then
    checks the guesses).
    """
    for k in range(k_lo, k_hi):
        s0 = bounds[k]
        s1_ = bounds[k + 1]
        if s1_ <= s0:
            continue
        p0 = 0 if k == 0 else max(0, (s0 - warm_up) // REANCHOR * REANCHOR)
        L0 = given[p0] if not adapt else (start_length if k == 0 else lmax)
        start_state[k], end_state[k] = _run(
            x, offset, p0, s1_, s0, L0, lmax, lmin, k1, k2, s1, s2, seg, dl0, dl1, s_test,
            use_f2, use_and, adapt, given, ends, e1, e2, window, kurt, scoef, f1, f2, f,
        )  # fmt: skip


@jit(error_model="numpy")
def _reconcile(
    x, offset, lmax, lmin, k1, k2, s1, s2, seg, dl0, dl1, s_test, use_f2, use_and, adapt,
    given, ends, e1, e2, window, kurt, scoef, f1, f2, f, bounds, start_length, start_state,
    end_state,
):  # fmt: skip  # pragma: no cover - compiled
    """Check the speculative segments in order; returns the length after the last update.

    A piece whose speculative length at its start differs from the length its predecessor
    actually ended with is run again from the true length. Since the running sums restart
    at every multiple of REANCHOR, a piece that starts from the true length reproduces the
    sequential pass exactly.
    """
    if not adapt:
        return start_length
    last = np.int64(-1)
    for k in range(bounds.size - 1):
        s0 = bounds[k]
        s1_ = bounds[k + 1]
        if s1_ <= s0:
            continue
        if last >= 0 and start_state[k] != last:  # the guess did not coalesce: rerun
            start_state[k], end_state[k] = _run(
                x, offset, s0, s1_, s0, last, lmax, lmin, k1, k2, s1, s2, seg, dl0, dl1,
                s_test, use_f2, use_and, adapt, given, ends, e1, e2, window, kurt, scoef, f1, f2, f,
            )  # fmt: skip
        last = end_state[k]
    return last


# ---------------------------------------------------------------------------------------
# the checked settings


def _segments(n: int) -> int:
    """Pieces of the controller pass: a few per thread once the warm-up is cheap."""
    if n < 8 * WARM_UP:
        return 1
    return min(work_items(n), n // (4 * WARM_UP))


def controller_outputs(m: int) -> tuple[np.ndarray, ...]:
    """The controller's output arrays for ``m`` centres: window, kurtosis, S, f1, f2, f."""
    flags = tuple(np.empty(m, dtype=np.bool_) for _ in range(3))
    return (np.empty(m, dtype=np.int64), np.empty(m), np.empty(m), *flags)


@dataclass(frozen=True)
class Controller:
    """A checked controller: lengths and steps in samples, tests, per-length thresholds.

    Attributes
    ----------
    method : {"adaptive", "kurtosis", "oracle", "fixed"}
        ``"oracle"`` and ``"fixed"`` follow a given schedule and only record the tests.
    lmax, lmin, seg, dl0, dl1 : int
        Longest and shortest window, leading segment of the S test, regrow and shrink steps.
    thresholds : Thresholds
        ``K1``, ``K2``, ``S2`` per window length.
    s1 : float
        Lower S threshold of ``s_test="band"``.
    s_test, combine : str
        The f2 test and how f1 and f2 make f.
    dependence : tuple of float or None
        The record's short-range correlation used by hourly thresholds.
    reference : KurtosisReference or None
        ``kurtosis_reference="record"``: the transform the record goes through before the
        tests (:mod:`adavar.dynamic.kurtosis_reference`); None: the record as it is.
    """

    method: str
    lmax: int
    lmin: int
    seg: int
    dl0: int
    dl1: int
    thresholds: Thresholds
    s1: float
    s_test: str
    combine: str
    dependence: tuple[float, ...] | None = None
    reference: KurtosisReference | None = None

    @property
    def adapts(self) -> bool:
        """True when the lengths follow the tests (A-DAVAR, DAVAR-K)."""
        return self.method in ("adaptive", "kurtosis")

    def run(
        self,
        ext: np.ndarray,
        offset: int,
        m: int,
        start_length: int,
        given: np.ndarray | None = None,
        *,
        segments: int | None = None,
        record: tuple[int, int] | None = None,
    ) -> tuple[tuple[np.ndarray, ...], int]:
        """The pass over centres ``0 .. m - 1``, centre ``q`` at ``ext[q + offset]``.

        Parameters
        ----------
        ext : ndarray
            The (extended) record at unit scale, holding every window of the centres.
        offset : int
            Index in ``ext`` of centre 0.
        m : int
            Centres to run.
        start_length : int
            Length in force at centre 0 (``lmax`` at the start of a record, the length the
            previous stretch ended with otherwise). For the result to repeat the sequential
            pass bit for bit, centre 0 must sit at a multiple of :data:`REANCHOR` of the
            whole record.
        given : ndarray of int64, shape (m,), optional
            The lengths for ``"oracle"`` and ``"fixed"``.
        segments : int, optional
            Speculative parallel segments (default: a few per thread on long stretches).
        record : (int, int), optional
            ``(first, size)``: centre 0 is sample ``first`` of a record of ``size`` samples
            whose ends are mirror-extended (``size``: any number beyond the samples yet
            known, live). A window that reaches into the mirror repeats samples it holds,
            and its kurtosis is tested at its effective size (docs/method.md section 8).
            None: the windows stay inside the record (``edges="valid"``).

        Returns
        -------
        outputs : tuple of ndarray
            Window, kurtosis, S, f1, f2, f of every centre.
        end_length : int
            The length after the last update (where the next stretch starts).
        """
        out = controller_outputs(m)
        if given is None:
            given = np.zeros(1, dtype=np.int64)
        if self.reference is not None:  # the tests see the record's noise made Gaussian
            ext = self.reference.apply(ext)  # (itself for a Gaussian record)
        th = self.thresholds
        ends = np.zeros(3, dtype=np.int64)
        if record is not None:
            shortest = int(np.argmax(np.isfinite(th.edge_k1) & np.isfinite(th.edge_k2)))
            ends[:] = int(record[0]), max(1, int(record[1])), shortest
        n_segments = _segments(m) if segments is None else int(segments)
        bounds = _segment_bounds(m, n_segments)
        start_state = np.zeros(n_segments, dtype=np.int64)
        end_state = np.zeros(n_segments, dtype=np.int64)
        args = (
            read_only(ext, np.float64), int(offset), self.lmax, self.lmin, th.k1, th.k2,
            self.s1, th.s2, self.seg, self.dl0, self.dl1, _S_TEST_CODE[self.s_test],
            self.method != "kurtosis", self.combine == "and", self.adapts,
            read_only(given, np.int64), ends, th.edge_k1, th.edge_k2, *out, bounds,
        )  # fmt: skip
        # about eight inner steps per centre (moments, tests, the length update)
        _speculate.run(8 * m, n_segments, *args, WARM_UP, int(start_length), start_state, end_state)
        end = _reconcile(*args, int(start_length), start_state, end_state)
        return out, int(end)


def check_whole(name: str, value: object, minimum: int) -> int:
    """``value`` as an int, or an AdavarInputError naming ``name`` (bools are refused)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise AdavarInputError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _refuse_constant_head(x: np.ndarray) -> None:
    """The head the thresholds are calibrated on (its correlation, its kurtosis) must have
    noise: a constant one (a dead sensor, the wrong column, a stream that starts with a
    held value) has none, and every statistic of it is 0 / 0."""
    x = np.asarray(x)
    if x.size and bool(np.all(x == x[0])):
        raise AdavarInputError(
            f"the first {x.size} samples of the record are constant ({float(x[0]):g} in "
            "every one): the thresholds are calibrated on the noise of this head and it has "
            "none; check the column and that the sensor was recording, or leave out the "
            "constant start"
        )


def make_controller(
    *,
    method: str,
    lmax: int,
    lmin: int,
    seg: int,
    dl0: int,
    dl1: int,
    k1: float,
    k2: float,
    s1: float,
    s2: float,
    s_test: str,
    combine: str,
    thresholds: str,
    false_alarm: float,
    false_alarm_per_hour: float | None,
    rate: float,
    head: Callable[[int], np.ndarray] | None = None,
    kurtosis_reference: str | dict | KurtosisReference = "gaussian",
    dependence: tuple[float, float] | None = None,
) -> Controller:
    """Check the controller's settings and set its thresholds (docs/method.md section 8).

    Parameters
    ----------
    method, k1, k2, s1, s2, s_test, combine, thresholds, false_alarm, false_alarm_per_hour
        As in :func:`adavar.adaptive_davar`.
    lmax, lmin, seg, dl0, dl1 : int
        Lengths and steps in samples (durations already converted).
    rate : float
        Sample rate, Hz (hourly thresholds count hours of it).
    head : callable, optional
        ``head(k)`` returns the first ``k`` samples of the record at unit scale (at most as
        many as it has): hourly thresholds measure its short-range correlation there, and
        ``kurtosis_reference="record"`` fits the record's stationary noise there
        (:func:`adavar.dynamic.kurtosis_reference.record_reference`). The one place both are
        estimated: the offline pass and :class:`adavar.OnlineAdaptive` call this on the
        same heads.
    kurtosis_reference : {"gaussian", "record"} or dict
        With calibrated thresholds: the tests compare the windows with Gaussian noise, or
        with the record's own stationary noise (:mod:`adavar.dynamic.kurtosis_reference`; the
        default of :func:`adavar.adaptive_davar`), or with the one of a fit given
        (``parameters["kurtosis_reference_fit"]`` of a run: no head needed). Not used by
        the paper's thresholds.
    dependence : (float, float), optional
        The record's ``(c2, c4)`` for hourly thresholds, given instead of measured on the
        head.

    Returns
    -------
    Controller

    Raises
    ------
    AdavarInputError
        For any setting out of range, with what to give instead.
    """
    if method not in CONTROLLER_METHODS:
        raise AdavarInputError(
            f"unknown method {method!r}: use one of {', '.join(CONTROLLER_METHODS)}"
        )
    if s_test not in S_TESTS:
        raise AdavarInputError(f"unknown s_test {s_test!r}: use one of {', '.join(S_TESTS)}")
    if combine not in COMBINES:
        raise AdavarInputError(f"unknown combine {combine!r}: use 'or' or 'and'")
    if thresholds not in ("paper", "calibrated"):
        raise AdavarInputError(f"unknown thresholds {thresholds!r}: use 'paper' or 'calibrated'")
    lmax = check_whole("lmax", lmax, 5)
    lmin = check_whole("lmin", lmin, 5)
    seg = check_whole("l", seg, 1)
    dl0 = check_whole("dl0", dl0, 0)
    dl1 = check_whole("dl1", dl1, 0)
    if lmin > lmax:
        raise AdavarInputError(
            f"lmin (--lmin) {count_text(lmin)} must not exceed lmax (--lmax) "
            f"{count_text(lmax)}: give a shorter lmin or a longer lmax"
        )
    if (lmax - lmin) % 2 or dl0 % 2 or dl1 % 2:
        raise AdavarInputError(
            "lmax - lmin, dl0 and dl1 must be even: the window keeps the parity of its length "
            "(docs/method.md section 8)"
        )
    if seg > lmin - 4:
        raise AdavarInputError(
            f"l = {seg} leaves fewer than 4 samples of the shortest window ({lmin}) for S: "
            "choose l < lmin - 3"
        )
    for name, value in (("k1", k1), ("k2", k2), ("s1", s1), ("s2", s2)):
        if not np.isfinite(float(value)):
            raise AdavarInputError(f"{name} must be a finite number, got {value!r}")
    if float(k1) > float(k2):
        raise AdavarInputError(f"k1 ({k1}) must not exceed k2 ({k2})")

    mode = check_kurtosis_reference(kurtosis_reference)
    hourly = thresholds == "calibrated" and false_alarm_per_hour is not None
    if dependence is not None:
        dependence = tuple(float(c) for c in dependence)
        if len(dependence) != 2 or not all(np.isfinite(c) and c >= 1.0 for c in dependence):
            raise AdavarInputError(
                f"dependence must be (c2, c4), two numbers >= 1, got {dependence!r}"
            )
    reference = mode if isinstance(mode, KurtosisReference) and thresholds == "calibrated" else None
    if needs_head(thresholds, false_alarm_per_hour, mode, dependence):
        if head is None:
            raise AdavarInputError(
                "calibrated thresholds need the head of the record (its correlation, its "
                "kurtosis): give the record, or thresholds='paper'"
            )
        x = head(DEPENDENCE_SAMPLES)
        _refuse_constant_head(x)
        measured = tuple(round(c, 3) for c in noise_dependence(x))
        if hourly and dependence is None:
            dependence = measured
        if mode == "record":
            reference = record_reference(x, lmin=lmin, dependence=dependence or measured)
    if hourly:
        th = hourly_thresholds(
            lmin, lmax, seg, rate=float(rate), per_hour=float(false_alarm_per_hour),
            dependence=dependence or (1.0, 1.0), s_test=s_test,
        )  # fmt: skip
    elif thresholds == "calibrated":
        th = calibrated_thresholds(lmin, lmax, seg, false_alarm=float(false_alarm))
    else:
        th = fixed_thresholds(lmax, k1, k2, s2)
    if reference is not None:  # what the transform leaves, and how well it is known
        th = shifted(th, reference.offset, reference.margin)
    if s_test == "band" and not float(s1) < float(np.nanmin(th.s2)):
        raise AdavarInputError(
            f"s_test='band' flags S outside [s1, s2], but s1 {float(s1):g} is not below s2 "
            f"{float(np.nanmin(th.s2)):g}: give s1 < s2"
        )
    return Controller(
        method=method, lmax=lmax, lmin=lmin, seg=seg, dl0=dl0, dl1=dl1, thresholds=th,
        s1=float(s1), s_test=s_test, combine=combine,
        dependence=dependence if hourly else None, reference=reference,
    )  # fmt: skip


def needs_head(
    thresholds: str,
    false_alarm_per_hour: float | None,
    kurtosis_reference: object,
    dependence: object = None,
) -> bool:
    """True when :func:`make_controller` reads the head of the record: hourly thresholds
    without a given ``dependence``, or calibrated ones with ``kurtosis_reference="record"``
    (not a fit given)."""
    if thresholds != "calibrated":
        return False
    hourly = false_alarm_per_hour is not None
    record = isinstance(kurtosis_reference, str) and kurtosis_reference == "record"
    return (hourly and dependence is None) or record

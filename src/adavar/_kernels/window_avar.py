"""The DAVAR engine's arithmetic: a window span in double-double, and its second differences.

The pieces :mod:`adavar._kernels.window_engine` builds every window statistic from.

Each work item takes a chunk of consecutive centres and the span of rate samples (or phase
increments) ``u[lo:hi]`` that their windows cover, and re-centres it on a local reference:
the median ``s`` of up to 65 of its samples (a data value). It integrates ``u - s`` once in
double-double (``P = ph + pl``, renormalised at every step; every ``u - s`` exact by a
two-sum), so a second difference

    ``d_m[i] = P[i + 2m] - 2 P[i + m] + P[i]``

comes out of three two-sums rounded once: correct to an ulp or so of ``d_m`` itself, however
large the offset of the data from ``s``, the drift across the span or a level step inside it.
The squares' prefix sums carry their rounding errors in a second part, and in a third when
a window's error bound says so (after a burst far above its noise, see
:func:`_prefix_squares`).
(The anchored phase of :mod:`adavar._kernels.differences` keeps one double per sample and loses
``1e-13 * D`` relative after a level step of ``D`` standard deviations; a window needs only
its own span, so here the whole span is kept in double-double.) Per averaging factor ``m``,
when the windows overlap, the squares ``d_m**2`` over the span are prefix-summed with
compensation and each window's sum is the difference of two prefix values (O(1) per window
whatever its length); windows far apart are summed one by one over their own span.

Measured against an exact per-window computation (white noise of sigma 1, a 1e9 offset
and a 1e6-sigma level step, tests/test_numeric_robust.py): 2.2e-16 relative at worst over
every cell (the single-double anchored phase: 9.7e-9); quiet windows next to a step or a
spike of 1e12 sigma: 4.4e-16.
"""

from __future__ import annotations

import numpy as np

from adavar._kernels._jit import jit, read_only, work_items
from adavar._kernels.double_double import two_sum

__all__ = [
    "MEDIAN_SAMPLES",
    "chunk_layout",
    "prepare_windows",
    "sample_median",
]

#: samples of a span whose median is its local reference
MEDIAN_SAMPLES = 65


@jit
def sample_median(u, lo, hi, tmp):  # pragma: no cover - compiled
    """Median of up to ``tmp.size`` samples of ``u[lo:hi]`` spread evenly (a data value)."""
    span = hi - lo
    m = min(tmp.size, span)
    for i in range(m):
        v = u[lo + (i * (span - 1)) // max(m - 1, 1)]
        j = i
        while j > 0 and tmp[j - 1] > v:  # insertion sort: m is small
            tmp[j] = tmp[j - 1]
            j -= 1
        tmp[j] = v
    return tmp[(m - 1) // 2]


@jit
def _local_prefix(u, lo, hi, shift, ph, pl):  # pragma: no cover - compiled
    """``ph[k] + pl[k] = sum(u[lo:lo+k] - shift)`` for ``k = 0..hi-lo``, in double-double.

    Each ``u - shift`` is split exactly into a double and its rounding error, and the pair
    is renormalised at every step (``|pl| <= ulp(ph) / 2``), so one step errs by about
    ``eps**2 |P|`` and a second difference over ``2m`` steps by ``2m eps**2 max|P|``,
    whatever the level of the data. No fast-math: the error terms rely on exact IEEE
    rounding. (Once per chunk, shared by every averaging factor.)
    """
    s = 0.0
    e = 0.0
    ph[0] = 0.0
    pl[0] = 0.0
    seg = u[lo:hi]
    for k in range(hi - lo):
        y, q = two_sum(seg[k], -shift)
        t = s + y
        bb = t - s
        e = e + (((s - (t - bb)) + (y - bb)) + q)
        s = t + e
        e = e - (s - t)
        ph[k + 1] = s
        pl[k + 1] = e


@jit
def _fill_differences(ph, pl, m, first, count, out):  # pragma: no cover - compiled
    """``out[k] = P[j + 2m] - 2 P[j + m] + P[j]``, ``j = first + k``, rounded once (k < count)."""
    h0 = ph[first : first + count]
    h1 = ph[first + m : first + m + count]
    h2 = ph[first + 2 * m : first + 2 * m + count]
    l0 = pl[first : first + count]
    l1 = pl[first + m : first + m + count]
    l2 = pl[first + 2 * m : first + 2 * m + count]
    dst = out[:count]
    for k in range(count):
        a, ea = two_sum(h2[k], -h1[k])
        b, eb = two_sum(h1[k], -h0[k])
        h, eh = two_sum(a, -b)
        dst[k] = h + (eh + ((ea - eb) + ((l2[k] - l1[k]) - (l1[k] - l0[k]))))


@jit
def _prefix_squares(d, n, q, full):  # pragma: no cover - compiled
    """Prefix sums of ``d[k]**2`` in three parts: ``P[k] = q[0, k] + q[1, k] + q[2, k]``.

    ``q[0]`` is the running sum and ``q[1]`` gathers its rounding errors (exactly, by
    two-sums); each is one add on the loop-carried path. The rounding of ``q[1]`` itself
    costs a window of ``n`` terms at most ``n 2**-53 max|q[1]|``; the largest ``|q[1]|`` is
    returned so the caller can check that bound. It matters after a burst of ``D`` times
    the noise, when the quiet terms that follow fall below an ulp of ``q[0]`` and are
    absorbed into ``q[1]``: then, with ``full``, ``q[2]`` gathers the rounding errors of
    ``q[1]`` as well (about 1.8x the cost), which leaves ``eps**2 D**2``. Without ``full``,
    ``q[2]`` is zero. No fast-math: the error terms rely on exact IEEE rounding.
    """
    qh, ql, qq = q[0], q[1], q[2]
    s = 0.0
    c = 0.0
    cc = 0.0
    big = 0.0
    qh[0] = 0.0
    ql[0] = 0.0
    qq[0] = 0.0
    if full:
        for k in range(n):
            y = d[k] * d[k]
            t = s + y
            bb = t - s
            e = (s - (t - bb)) + (y - bb)
            s = t
            w = c + e
            b2 = w - c
            cc += (c - (w - b2)) + (e - b2)
            c = w
            qh[k + 1] = s
            ql[k + 1] = c
            qq[k + 1] = cc
        return 0.0
    for k in range(n):
        y = d[k] * d[k]
        t = s + y
        bb = t - s
        c += (s - (t - bb)) + (y - bb)
        s = t
        big = max(big, abs(c))
        qh[k + 1] = s
        ql[k + 1] = c
        qq[k + 1] = 0.0
    return big


@jit
def _difference3(h0, h1, l0, l1, r0, r1):  # pragma: no cover - compiled
    """``(h1 + l1 + r1) - (h0 + l0 + r0)`` with the two leading differences exact."""
    s, e = two_sum(h1, -h0)
    c, f = two_sum(l1, -l0)
    return s + (e + (c + (f + (r1 - r0))))


@jit
def _window_sum(q, a, b):  # pragma: no cover - compiled
    """``P[b] - P[a]`` from the three-part prefix of :func:`_prefix_squares`."""
    return _difference3(q[0, a], q[0, b], q[1, a], q[1, b], q[2, a], q[2, b])


@jit
def _eval_uniform(q, first, n, count, norm, res, at):  # pragma: no cover - compiled
    """Windows ``[first + k, first + k + n)`` into ``res[at + k]``, ``k < count``: vectorises."""
    h0 = q[0, first : first + count]
    h1 = q[0, first + n : first + n + count]
    l0 = q[1, first : first + count]
    l1 = q[1, first + n : first + n + count]
    r0 = q[2, first : first + count]
    r1 = q[2, first + n : first + n + count]
    out = res[at : at + count]
    f = norm / n
    for k in range(count):
        out[k] = max(_difference3(h0[k], h1[k], l0[k], l1[k], r0[k], r1[k]), 0.0) * f


@jit
def chunk_layout(centres, lengths, offset, c0, c1, starts):  # pragma: no cover - compiled
    """Where windows ``c0 .. c1 - 1`` lie: their first samples into ``starts``, and
    ``(lo, hi, spread, need)``: the span ``[lo, hi)`` of their union, whether they lie far
    apart (each is then computed over its own span) and the scratch columns needed."""
    lo = centres[c0] - (lengths[c0] - 1) // 2 + offset
    hi = lo
    covered = 0
    longest = 0
    for k in range(c1 - c0):
        length = lengths[c0 + k]
        starts[k] = centres[c0 + k] - (length - 1) // 2 + offset
        lo = min(lo, starts[k])
        hi = max(hi, starts[k] + length)
        covered += length
        longest = max(longest, length)
    spread = hi - lo > 2 * covered  # far apart: each window over its own span
    need = (longest if spread else hi - lo) + 1
    return lo, hi, spread, need


@jit
def _window_extent(centres, lengths, offset):  # pragma: no cover - compiled
    """First sample and end of the union of the windows (no temporary arrays)."""
    first = centres[0] - (lengths[0] - 1) // 2 + offset
    stop = first + lengths[0]
    for c in range(centres.size):
        a = centres[c] - (lengths[c] - 1) // 2 + offset
        first = min(first, a)
        stop = max(stop, a + lengths[c])
    return first, stop


def prepare_windows(
    samples: np.ndarray,
    ms: np.ndarray,
    centres: np.ndarray,
    lengths: np.ndarray,
    offset: int,
    chunk: int,
    out: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, int, int]:
    """The window kernels' arguments checked and in kernel form (read-only views).

    Returns ``(u, ms, centres, lengths, out, chunk, workers, span)``: ``span`` is the
    number of samples of the windows' union (at least one per window), the kernels' work
    per factor.
    """
    u = read_only(samples, np.float64)
    ms = read_only(ms, np.int64)
    centres = read_only(centres, np.int64)
    lengths = read_only(lengths, np.int64)
    if centres.shape != lengths.shape or centres.ndim != 1:
        raise ValueError("internal: centres and lengths must be 1-D arrays of one shape")
    nc, nt = centres.size, ms.size
    span = 0
    if nc:
        first, stop = _window_extent(centres, lengths, int(offset))
        if first < 0 or stop > u.size:
            raise ValueError("internal: a window runs past the data")
        span = max(nc, stop - first)
    if out is None:
        out = np.empty((nc, nt))
    elif out.shape != (nc, nt):
        raise ValueError("internal: the output has the wrong shape")
    chunk = int(max(chunk, 1))
    workers = work_items(-(-nc // chunk))
    return u, ms, centres, lengths, out, chunk, workers, span

"""The terms of the dynamic Hadamard and modified Allan variances, over a window span.

The pieces :mod:`adavar._kernels.window_engine` runs for these statistics: over the span of
a chunk of windows, integrated once in double-double (``P = ph + pl``, see
``window_avar._local_prefix``), the terms of the statistic at one averaging factor ``m``:

- ``"ohvar"``, the overlapping Hadamard variance (NIST SP 1065): the third
  differences ``P[i + 3m] - 3 P[i + 2m] + 3 P[i + m] - P[i]``, from three exact two-sums of
  the high parts, the next two levels of differences exact as well, and the low parts,
  rounded once (correct to an ulp or so of the term, like the second differences of the
  Allan kernel), over ``n = L - 3m + 1`` starts, times ``1 / (6 m**2 n)``.
- ``"mvar"``, the modified Allan variance (SP 1065): the sums of ``m`` consecutive
  second differences. Each second difference is kept to its last bits, they are
  prefix-summed in two compensated parts (``D``; the errors accumulated before a term are a
  constant that cancels in ``D[j + m] - D[j]``, and ``|D|`` stays near ``m**2`` times the
  local rate however long the span), and each term is that difference rounded once;
  ``n = L - 3m + 2`` terms, times ``1 / (2 m**4 n)``.

Measured against an exact per-window computation (``math.fsum`` of the terms written on
the rate samples, tests/test_davar_stats.py): 3.3e-16 relative at worst over every cell of
1500 random records (offsets of 1e9, level steps of 1e6 sigma, drifts, rate ramps, bursts
of 1e10, scales 1e-13 .. 1e12, float32 input, rate and phase data), and 2.2e-16 in windows
of 5000 samples on a 1e9 offset with a 1e6-sigma step and 1e12-sigma bursts in their span.
"""

from __future__ import annotations

from adavar._kernels._jit import jit
from adavar._kernels.double_double import two_sum

__all__ = ["MVAR", "OHVAR"]

#: the statistic of a call of the window engine (:data:`adavar._kernels.window_engine.KINDS`)
OHVAR = 1
MVAR = 2


@jit
def _fill_third(ph, pl, m, first, count, out):  # pragma: no cover - compiled
    """``out[k] = P[j+3m] - 3 P[j+2m] + 3 P[j+m] - P[j]``, ``j = first + k``, rounded once."""
    h0 = ph[first : first + count]
    h1 = ph[first + m : first + m + count]
    h2 = ph[first + 2 * m : first + 2 * m + count]
    h3 = ph[first + 3 * m : first + 3 * m + count]
    l0 = pl[first : first + count]
    l1 = pl[first + m : first + m + count]
    l2 = pl[first + 2 * m : first + 2 * m + count]
    l3 = pl[first + 3 * m : first + 3 * m + count]
    dst = out[:count]
    for k in range(count):
        a, ea = two_sum(h3[k], -h2[k])
        b, eb = two_sum(h2[k], -h1[k])
        c, ec = two_sum(h1[k], -h0[k])
        s, es = two_sum(a, -b)
        t, et = two_sum(b, -c)
        h, eh = two_sum(s, -t)
        low = ((l3[k] - l2[k]) - (l2[k] - l1[k])) - ((l2[k] - l1[k]) - (l1[k] - l0[k]))
        dst[k] = h + (eh + ((es - et) + (((ea - eb) - (eb - ec)) + low)))


#: steps of the moving sums' prefix between two renormalisations of its two parts
_RENORMALISE = 16


@jit
def _fill_moving(ph, pl, m, first, count, dh, dl, out):  # pragma: no cover - compiled
    """``out[k] = sum_{i=j}^{j+m-1} (P[i+2m] - 2 P[i+m] + P[i])``, ``j = first + k``.

    ``dh + dl`` receives the prefix ``D`` of the second differences, each taken exactly
    to its last bits (high part ``h`` and the sum of its error terms, in a first pass that
    vectorises): ``dh`` is the plain running sum of the ``h``, ``dl`` gathers its rounding
    errors (two-sums) and the low parts, and the pair is renormalised every
    :data:`_RENORMALISE` steps, so ``|dl|`` stays within a few ulps of ``dh`` and the loop
    carries one add per part (not the chain of a double-double add). Every term is
    ``D[k + m] - D[k]`` rounded once.
    """
    total = count + m - 1  # second differences first .. first + total - 1
    h0 = ph[first : first + total]
    h1 = ph[first + m : first + m + total]
    h2 = ph[first + 2 * m : first + 2 * m + total]
    l0 = pl[first : first + total]
    l1 = pl[first + m : first + m + total]
    l2 = pl[first + 2 * m : first + 2 * m + total]
    hs = dh[1 : total + 1]
    ls = dl[1 : total + 1]
    for k in range(total):
        a, ea = two_sum(h2[k], -h1[k])
        b, eb = two_sum(h1[k], -h0[k])
        hs[k], eh = two_sum(a, -b)
        ls[k] = eh + ((ea - eb) + ((l2[k] - l1[k]) - (l1[k] - l0[k])))
    # the prefix in place: each step reads its difference before it writes the sum there
    s = 0.0
    c = 0.0
    dh[0] = 0.0
    dl[0] = 0.0
    k0 = 1
    while k0 <= total:
        k1 = min(k0 + _RENORMALISE, total + 1)
        for k in range(k0, k1):
            h = dh[k]
            t = s + h
            bb = t - s
            c += ((s - (t - bb)) + (h - bb)) + dl[k]
            s = t
            dh[k] = s
            dl[k] = c
        s, c = two_sum(s, c)
        k0 = k1
    dst = out[:count]
    a0 = dh[:count]
    a1 = dh[m : m + count]
    b0 = dl[:count]
    b1 = dl[m : m + count]
    for k in range(count):
        s, e = two_sum(a1[k], -a0[k])
        dst[k] = s + (e + (b1[k] - b0[k]))


@jit
def _fill_terms(work, kind, m, first, count):  # pragma: no cover - compiled
    """The statistic's ``count`` terms from start ``first`` into ``work[4]``."""
    if kind == OHVAR:
        _fill_third(work[0], work[1], m, first, count, work[4])
    else:
        _fill_moving(work[0], work[1], m, first, count, work[2], work[3], work[4])


@jit
def _terms_of(kind, L, m):  # pragma: no cover - compiled
    """Terms of a window of ``L`` samples at ``m`` (``3 m <= L``)."""
    return L - 3 * m + (2 if kind == MVAR else 1)


@jit
def _norm_of(kind, m, scale):  # pragma: no cover - compiled
    """The factor of a window's sum of squares, before the division by its term count."""
    mm = float(m) * float(m)
    return scale / (2.0 * mm * mm) if kind == MVAR else scale / (6.0 * mm)

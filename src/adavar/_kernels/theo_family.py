"""Compiled kernels of the Theo family (:mod:`adavar.theo_family`).

Theo1 at an even averaging factor ``m = 2h`` is (SP 1065 Eq. 30, with ``j = h - delta``)

    S(m) = sum_{j=1}^{h} (1/j) sum_{i=0}^{N-m-1} [D_j(i + m - j) - D_j(i)]^2,

where ``D_j(k) = x[k+j] - x[k] = u[k] + ... + u[k+j-1]`` is a window sum of the increments.
The kernel walks ``j = 1, 2, ...`` once, growing ``D_j`` from ``D_{j-1}`` by one exact
addition per element (kept as a double-double, so the windows carry no rounding however
long they grow), and adds the ``j`` term of every requested ``m`` from the same array.
Each term is a difference of two window sums of the increments: a frequency offset cancels
exactly and a drift costs nothing, as it would in the phase ``x`` itself. The cost is
``sum_m (N - m) m / 2`` multiply-adds (the naive count) plus ``N`` exact additions per ``j``;
the inner loops are contiguous and free of branches.
"""

from __future__ import annotations

import numpy as np

from adavar._jit import jit
from adavar._kernels.double_double import two_sum

__all__ = ["theo1_sums"]


@jit
def _lagged_square_sum(dh, dl, lag, count):  # pragma: no cover - compiled
    """``sum_{i < count} ((dh[i+lag] - dh[i]) + (dl[i+lag] - dl[i]))**2``.

    Four independent accumulators: the additions stay in order within each (no fast-math,
    which could regroup the double-double difference), yet do not wait on one another.
    """
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    a3 = 0.0
    blocks = count // 4
    for b in range(blocks):
        i = 4 * b
        d0 = (dh[i + lag] - dh[i]) + (dl[i + lag] - dl[i])
        d1 = (dh[i + 1 + lag] - dh[i + 1]) + (dl[i + 1 + lag] - dl[i + 1])
        d2 = (dh[i + 2 + lag] - dh[i + 2]) + (dl[i + 2 + lag] - dl[i + 2])
        d3 = (dh[i + 3 + lag] - dh[i + 3]) + (dl[i + 3 + lag] - dl[i + 3])
        a0 += d0 * d0
        a1 += d1 * d1
        a2 += d2 * d2
        a3 += d3 * d3
    for i in range(4 * blocks, count):
        d = (dh[i + lag] - dh[i]) + (dl[i + lag] - dl[i])
        a0 += d * d
    return (a0 + a1) + (a2 + a3)


@jit
def theo1_sums(u, ms, out):  # pragma: no cover - compiled
    """Add ``S(m)`` (the Theo1 double sum, unnormalised) of every even ``m`` to ``out``.

    ``u``: the ``N - 1`` increments of the phase; ``ms``: even factors, ``2 <= m <= N - 1``.
    """
    n = u.size
    n_points = n + 1
    hmax = 0
    for idx in range(ms.size):
        hmax = max(hmax, ms[idx] // 2)
    dh = np.zeros(n)
    dl = np.zeros(n)
    for j in range(1, hmax + 1):
        # D_j(k) = D_{j-1}(k) + u[k + j - 1] for k = 0 .. n - j; the rounding goes to dl
        for k in range(n - j + 1):
            s, e = two_sum(dh[k], u[k + j - 1])
            dh[k] = s
            dl[k] += e
        w = 1.0 / j
        for idx in range(ms.size):
            m = ms[idx]
            if 2 * j <= m:
                out[idx] += w * _lagged_square_sum(dh, dl, m - j, n_points - m)

"""Central moments of a record's first differences in one compiled pass.

:func:`adavar.stats.statistics.increment_kurtosis` reads up to 2**20 differences of every record
``deviation`` analyses; with NumPy that took five temporaries and 6 ms a million samples.
"""

from __future__ import annotations

from adavar._kernels._jit import jit

__all__ = ["difference_moments"]


@jit
def difference_moments(x, mean):  # pragma: no cover - compiled
    """``(sum (d - mean)^2, sum (d - mean)^4)`` over ``d = x[i + 1] - x[i]``."""
    m2 = 0.0
    m4 = 0.0
    for i in range(x.size - 1):
        d = (x[i + 1] - x[i]) - mean
        sq = d * d
        m2 += sq
        m4 += sq * sq
    return m2, m4

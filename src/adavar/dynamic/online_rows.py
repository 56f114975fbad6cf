"""Pieces of :class:`adavar.OnlineAdaptive` that stand alone: its growable row columns and
the check of the ``noise_type`` a live pass can take."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.stats.edf import STAT_ALPHA_RANGE

__all__ = ["Rows", "check_noise_type"]


def check_noise_type(noise_type: Any, size: int) -> np.ndarray:
    """alpha per tau from an integer or one integer per tau (no record to identify it)."""
    if isinstance(noise_type, str):
        raise AdavarInputError(
            f"noise_type={noise_type!r}: a live stream has no whole record to identify the "
            "noise type on; give an integer alpha (0: white rate noise, the default) or one "
            "per tau"
        )
    alpha = np.atleast_1d(np.asarray(noise_type))
    if not np.issubdtype(alpha.dtype, np.integer) or alpha.ndim != 1:
        raise AdavarInputError("noise_type must be an integer alpha or one integer per tau")
    if alpha.size == 1:
        alpha = np.full(size, int(alpha[0]))
    elif alpha.size != size:
        raise AdavarInputError(
            f"noise_type has {alpha.size} values but there are {size} taus: give one"
        )
    lo, hi = STAT_ALPHA_RANGE["oadev"]
    if alpha.min() < lo or alpha.max() > hi:
        raise AdavarInputError(f"noise_type alpha must lie in {lo} .. {hi} for the Allan variance")
    return alpha.astype(np.int64)


class Rows:
    """Append-only columns in growable arrays (amortised O(1) a row), trimmed in front.

    The arrays grow by half (not double): a stationary stream keeps every row since its
    start, and the spare capacity and the copy at each growth set the monitor's peak.
    """

    def __init__(self, names: Sequence[str], dtypes: Sequence[Any]) -> None:
        self.capacity = 1024
        self.data = {n: np.empty(1024, dtype=d) for n, d in zip(names, dtypes, strict=True)}
        self.start = 0  # index in the arrays of the first row held
        self.first = 0  # index (over all rows ever) of the first row held
        self.size = 0  # rows held

    def append(self, **columns: np.ndarray) -> None:
        count = len(next(iter(columns.values())))
        capacity = self.capacity
        if self.start + self.size + count > capacity:  # move the rows down, or grow
            if self.size + count > capacity // 2:
                capacity = max(capacity + capacity // 2, (3 * (self.size + count)) // 2)
            for name, array in self.data.items():
                moved = array if capacity == self.capacity else np.empty(capacity, array.dtype)
                moved[: self.size] = array[self.start : self.start + self.size]
                self.data[name] = moved
            self.capacity = capacity
            self.start = 0
        end = self.start + self.size
        for name, value in columns.items():
            self.data[name][end : end + count] = value
        self.size += count

    def column(self, name: str) -> np.ndarray:
        """The held rows of ``name`` (a view: valid until the next append)."""
        return self.data[name][self.start : self.start + self.size]

    def last(self, name: str) -> Any:
        return self.data[name][self.start + self.size - 1]

    def drop_before(self, index: int) -> None:
        """Forget the rows before ``index`` (over all rows ever)."""
        cut = min(self.size, max(0, index - self.first))
        self.start += cut
        self.first += cut
        self.size -= cut

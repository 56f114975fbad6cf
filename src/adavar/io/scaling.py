"""A streamed record scaled by an exact power of two (:func:`scaled_source`).

:func:`adavar.core.inputs.scaled` out of core: a record whose magnitude would under- or
overflow the double-double sums is read times ``2**-k``, piece by piece.
"""

from __future__ import annotations

import numpy as np

from adavar.core.inputs import data_exponent
from adavar.io.sources import ChunkedSource

__all__ = ["ScaledSource", "scaled_source"]

#: samples of a streamed record whose largest magnitude sets its scale, and pieces tried
_SCALE_SAMPLES = 1 << 10
_SCALE_PIECES = 64


class ScaledSource(ChunkedSource):
    """A streamed record times ``2**-exponent`` (exact): :func:`scaled` out of core."""

    def __init__(self, source: ChunkedSource, exponent: int) -> None:
        self.source = source
        self.exponent = int(exponent)
        self.size = source.size
        self.name = source.name

    def _read_raw(self, start: int, stop: int) -> np.ndarray:
        return np.ldexp(self.source.read(start, stop), -self.exponent)


def scaled_source(source: ChunkedSource) -> tuple[ChunkedSource, int]:
    """``(source * 2**-k, k)`` for a streamed record.

    ``k`` comes from its first 1024 samples (from the first piece of 1024 that is not all
    zeros, within the first 64): any exponent is exact, it only has to keep the sums in
    range, and a record does not change its scale by 2**64 within itself.
    """
    k = 0
    for start in range(0, min(source.size, _SCALE_PIECES * _SCALE_SAMPLES), _SCALE_SAMPLES):
        piece = source.read(start, min(source.size, start + _SCALE_SAMPLES))
        if np.any(piece):
            k = data_exponent(piece)
            break
    return (ScaledSource(source, k) if k else source), k

"""When a file column is read piece by piece instead of into memory.

HDF5 datasets and Parquet columns are returned as :class:`adavar.stats.stream.ChunkedSource`
pieces (read by the out-of-core analyses) when ``lazy=True``, or by default when their
numeric data exceed :data:`LAZY_BYTES` or a quarter of the available memory and nothing
needs the whole record at once (no time column, ``nan="error"``). ``.npy`` and uncompressed
``.npz`` columns are memory-mapped instead (see :mod:`adavar.readers.npy`).
"""

from __future__ import annotations

from typing import Any

from adavar.core.errors import AdavarInputError
from adavar.io.sources import available_memory
from adavar.readers.errors import fail

#: auto ``lazy``: read a file column piece by piece from this size (bytes) or a quarter
#: of the available memory, whichever is smaller
LAZY_BYTES = 1 << 30


def lazy_wanted(opts: dict[str, Any], nbytes: int) -> bool:
    """Whether ``nbytes`` of file columns are read piece by piece (asked, or auto)."""
    lazy = opts.get("lazy")
    if lazy is not None:
        return bool(lazy)
    if opts.get("nan", "error") != "error" or opts.get("time_column") is not None:
        return False
    free = available_memory()
    limit = LAZY_BYTES if free is None else min(LAZY_BYTES, free // 4)
    return nbytes > limit


def lazy_refused(src: str, why: str) -> AdavarInputError:
    """The error for ``lazy=True`` on data that cannot be read piece by piece."""
    return fail(f"{src} cannot be read piece by piece ({why}): leave out lazy=True / --lazy")

"""When a file column is read piece by piece instead of into memory.

HDF5 datasets and Parquet columns are returned as :class:`adavar.stats.stream.ChunkedSource`
pieces (read by the out-of-core analyses) when ``lazy=True``, or by default when their
numeric data exceed :data:`LAZY_BYTES` or a quarter of the available memory and nothing
needs the whole record at once (no time column, ``nan="error"``). ``.npy`` and uncompressed
``.npz`` columns are memory-mapped instead (see :mod:`adavar.readers.npy`).
``time_column="none"`` (:func:`no_time_column`) names no time column: the columns named like
one are then data.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from adavar.core.errors import AdavarInputError
from adavar.io.sources import available_memory
from adavar.readers.errors import fail

#: auto ``lazy``: read a file column piece by piece from this size (bytes) or a quarter
#: of the available memory, whichever is smaller
LAZY_BYTES = 1 << 30
#: ``time_column`` value for no time column (the columns named like one are then data).
NO_TIME_COLUMN = "none"


def lazy_wanted(opts: dict[str, Any], nbytes: int) -> bool:
    """Whether ``nbytes`` of file columns are read piece by piece (asked, or auto)."""
    lazy = opts.get("lazy")
    if lazy is not None:
        return bool(lazy)
    if opts.get("nan", "error") != "error" or has_time_column(opts):
        return False
    free = available_memory()
    limit = LAZY_BYTES if free is None else min(LAZY_BYTES, free // 4)
    return nbytes > limit


def no_time_column(time_column: Any, names: Sequence[str] = ()) -> bool:
    """Whether ``time_column`` asks for no time column (``"none"``, unless a column of
    ``names`` is named so)."""
    return (
        isinstance(time_column, str)
        and time_column.strip().casefold() == NO_TIME_COLUMN
        and not any(n.strip().casefold() == NO_TIME_COLUMN for n in names)
    )


def has_time_column(opts: dict[str, Any], names: Sequence[str] = ()) -> bool:
    """Whether the options name a time column (``time_column="none"`` names none)."""
    time_column = opts.get("time_column")
    return time_column is not None and not no_time_column(time_column, names)


def lazy_refused(src: str, why: str) -> AdavarInputError:
    """The error for ``lazy=True`` on data that cannot be read piece by piece."""
    return fail(f"{src} cannot be read piece by piece ({why}): leave out lazy=True / --lazy")

"""Give the C heap's free pages back to the system between the phases of a command.

glibc keeps memory that Python and NumPy have freed in its arenas, to reuse it. Two
habits of a long analysis make that memory resident for the rest of the process: the
threads that parse a text file each fill an arena of their own, which the main thread
never reuses; and freed multi-megabyte arrays leave holes that later, differently sized
ones do not fit. :func:`release_free_memory` (glibc's ``malloc_trim(0)``, a few
milliseconds) returns those pages at the end of a phase, so the next phase's peak does not
sit on top of them. Elsewhere (another C library, another system) it does nothing.

A fixed ``M_MMAP_THRESHOLD`` (``MALLOC_MMAP_THRESHOLD_=131072``) would save a little
more of the peak, but every large array is then a fresh mapping whose pages fault in
again: ``adavar report --adaptive`` on three 2-hour channels took 30 s instead of 25 s,
so it is left to the user's environment.
"""

from __future__ import annotations

import ctypes
import functools
import sys
from collections.abc import Callable

__all__ = ["release_free_memory"]


@functools.cache
def _trim() -> Callable[[int], int] | None:
    """glibc's ``malloc_trim``, or None where there is none."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        trim = ctypes.CDLL(None).malloc_trim  # the C library the interpreter runs on
    except (OSError, AttributeError):  # musl has no malloc_trim
        return None
    trim.argtypes = [ctypes.c_size_t]
    trim.restype = ctypes.c_int
    return trim


def release_free_memory() -> bool:
    """Return the free pages of every malloc arena to the system (glibc); True if it did.

    Memory in use is untouched: this only lowers the resident size that freed memory
    still counts for, at the end of a phase (a file read on threads, a channel or a file
    analysed).
    """
    trim = _trim()
    if trim is None:
        return False
    trim(0)
    return True

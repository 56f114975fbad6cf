"""Reading one column of a plain text file (:func:`read_text`).

The writers that ``adavar.io`` held before 0.3 are :mod:`adavar.io.writers`'s; they are
still importable from here (and from ``adavar.io``), unchanged. For reading a
record in any format, with time stamps, gaps and units, use :func:`adavar.readers.read_record`.

Every problem with the user's input raises :class:`adavar.core.errors.AdavarInputError` with a
one-line message that names the problem and the way out.

The package holds the io layer's modules. Records in and out (the files layer): sources read
piece by piece, the sample interval, preprocessing, the input checks, writers;
:mod:`adavar.readers` reads files.

The package itself is the public face of :mod:`adavar.io.text_column` (its names, imported
on first use, so that importing one of the package's modules imports nothing else). Modules
inside adavar import from :mod:`adavar.io.text_column`, never from here.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from adavar.io.text_column import (
        COMMENT_PREFIXES,
        SURFACE_FORMATS,
        atomic_directory,
        atomic_file,
        check_output_directory,
        check_surface_format,
        read_text,
        write_surface,
    )

__all__ = [
    "COMMENT_PREFIXES",
    "SURFACE_FORMATS",
    "atomic_directory",
    "atomic_file",
    "check_output_directory",
    "check_surface_format",
    "read_text",
    "write_surface",
]


def __getattr__(name: str) -> Any:  # PEP 562
    if name in __all__:
        value = getattr(importlib.import_module("adavar.io.text_column"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'adavar.io' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

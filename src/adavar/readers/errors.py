"""How a reader reports a problem with its input.

Every problem with a file raises :class:`adavar.core.errors.AdavarInputError` with a one-line
message that names the problem, where it is (:func:`locate`: ``row 12`` of a text file,
``sample 3`` or ``message 3`` elsewhere) and the way out; :func:`require` imports the
optional package a format needs (h5py, pyarrow, rosbags) only when a file of that format is
read, and names the package to install when it is missing.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from adavar.core.errors import AdavarInputError


def fail(message: str) -> AdavarInputError:
    """The error for ``message``, on one line."""
    return AdavarInputError(" ".join(str(message).split()))


class GapError(AdavarInputError):
    """A gap in the time stamps, with ``gaps="error"``. ``problem`` is the message without
    its way out, for a command to name the ``--gaps`` policies it has (only ``avar``
    splits the record, only ``avar`` and ``davar`` omit the missing samples)."""

    def __init__(self, problem: str, way_out: str) -> None:
        self.problem = " ".join(str(problem).split())
        super().__init__(f"{self.problem}: {way_out}")


def one_line(exc: BaseException) -> str:
    """An exception's message on one line (at most 160 characters), to quote in ours."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 160 else text[:157] + "..."


def locate(rows: np.ndarray | None, i: int, word: str = "sample") -> str:
    """Where sample ``i`` is, for a message: its file line (``rows``), else ``word i``."""
    return f"row {int(rows[i])}" if rows is not None else f"{word} {i}"


def require(module: str, what: str) -> Any:
    """Import ``module``, or fail naming the package that reading ``what`` needs."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        package = module.split(".")[0]
        raise fail(
            f"reading {what} needs {package}, which is not installed: pip install {package}"
        ) from None

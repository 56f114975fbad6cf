"""Stable32 phase and frequency files (``.phd``, ``.frd``), the clock-analysis text format.

A Stable32 file is a text file (read by :func:`adavar.readers.text.text_table`, here with
any number of header lines) of one column (the data) or two (an MJD time tag, then the
data). The data column becomes the channel ``"phase"`` (``.phd``) or ``"frequency"``
(``.frd``); a time-tag column is read as Modified Julian Dates unless ``time_format`` says
otherwise. Its samples are phase (``.phd``) or frequency, rate data (``.frd``):
:func:`file_data_type` makes that the data type analysed, and refuses a ``data_type``
given that contradicts it.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from adavar.core.settings import FileDefault
from adavar.readers.errors import fail
from adavar.readers.record import RawRecord
from adavar.readers.table import channels_from_table, time_name_unit
from adavar.readers.text import text_table

#: Stable32 suffix -> the data type of its samples (``data_type`` of the analyses)
STABLE32_DATA_TYPES = {".phd": "phase", ".frd": "rate"}
_NAMES = {".phd": "phase", ".frd": "frequency"}
_SPELLINGS = {"rate": "rate", "freq": "rate", "frequency": "rate", "phase": "phase"}


def file_data_type(path: str | os.PathLike[str], given: str | None) -> str | None:
    """The data type of the samples of ``path``: phase for a Stable32 ``.phd`` file,
    rate (fractional frequency) for a ``.frd`` file, ``given`` for any other file.

    Parameters
    ----------
    path : str or path-like
        The file.
    given : str or None
        The data type asked for: a :class:`adavar.core.settings.FileDefault` (the default,
        ``--data-type`` not given) or None yields to the file's; a value given must agree.

    Raises
    ------
    AdavarInputError
        A given data type that contradicts a Stable32 file's.
    """
    suffix = Path(path).suffix.lower()
    implied = STABLE32_DATA_TYPES.get(suffix)
    if implied is None:
        return given
    if given is None or isinstance(given, FileDefault):
        return implied
    if _SPELLINGS.get(str(given).lower(), given) != implied:
        other = next(s for s in STABLE32_DATA_TYPES if s != suffix)
        raise fail(
            f"{path} is a Stable32 {_NAMES[suffix]} file ({suffix}), so its samples are "
            f"{implied} data, but --data-type {given} was given: leave out --data-type, or "
            f"rename the file to {other} if it holds {_NAMES[other]}"
        )
    return implied


def read_stable32(path: Path, src: str, opts: dict[str, Any]) -> RawRecord:
    """The record of a Stable32 ``.phd`` / ``.frd`` file."""
    tab, meta = text_table(path, src, preamble=True)
    time_column, time_format = opts["time_column"], opts["time_format"]
    columns = opts["columns"]
    quantity = _NAMES[path.suffix.lower()]
    if len(tab.names) > 2:
        raise fail(
            f"{src} has {len(tab.names)} columns; a Stable32 file has one (data) or two "
            "(MJD time tag, data): export one column, or rename the file to .csv"
        )
    if len(tab.names) == 2 and time_column is None:
        time_column = tab.names[0]
        if time_format == "auto" and time_name_unit(time_column)[1] is None:
            time_format = "mjd"  # Stable32 time tags are Modified Julian Dates
    data_name = tab.names[-1]
    if columns is None:
        columns = [data_name]
    meta["quantity"] = quantity
    channels, rel, t0, info = channels_from_table(
        tab, columns=columns, time_column=time_column, time_format=time_format, src=src
    )
    if list(channels) == [tab.names[-1]]:
        channels = {meta["quantity"]: channels[tab.names[-1]]}
        info["channels"] = [meta["quantity"]]
    meta.update(info)
    return RawRecord(channels, rel, t0, tab.rows, "row", meta)

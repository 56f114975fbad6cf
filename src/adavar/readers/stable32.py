"""Stable32 phase and frequency files (``.phd``, ``.frd``), the clock-analysis text format.

A Stable32 file is a text file (read by :func:`adavar.readers.text.text_table`, here with
any number of header lines) of one column (the data) or two (an MJD time tag, then the
data). The data column becomes the channel ``"phase"`` (``.phd``) or ``"frequency"``
(``.frd``); a time-tag column is read as Modified Julian Dates unless ``time_format`` says
otherwise.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from adavar.readers.errors import fail
from adavar.readers.record import RawRecord
from adavar.readers.table import channels_from_table
from adavar.readers.text import text_table


def read_stable32(path: Path, src: str, opts: dict[str, Any]) -> RawRecord:
    """The record of a Stable32 ``.phd`` / ``.frd`` file."""
    tab, meta = text_table(path, src, preamble=True)
    time_column, time_format = opts["time_column"], opts["time_format"]
    columns = opts["columns"]
    quantity = "phase" if path.suffix.lower() == ".phd" else "frequency"
    if len(tab.names) > 2:
        raise fail(
            f"{src} has {len(tab.names)} columns; a Stable32 file has one (data) or two "
            "(MJD time tag, data): export one column, or rename the file to .csv"
        )
    if len(tab.names) == 2 and time_column is None:
        time_column = tab.names[0]
        if time_format == "auto":
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

"""The ``adavar`` command line.

Commands
--------
``adavar avar FILE --rate HZ --units UNIT [...]``
    Allan-family deviation of one column of a text file, with confidence intervals, and
    optionally the IEEE Std 952 noise fit; a table, JSON, or an output folder.
``adavar davar FILE --rate HZ --units UNIT --window L [...]``
    The dynamic Allan variance of a sliding window and the noise coefficients of every
    window over time (N(t), B(t), ...); a summary, JSON, or an output folder with the
    surface (NetCDF or Parquet), the coefficients (CSV) and the figures.
``adavar compare (FILE --rate HZ --units UNIT | --scenario 1|2) [--seeds N] [...]``
    DAVAR-Lmin, DAVAR-Lmax, DAVAR-K and A-DAVAR on the same record: the node times around
    each change next to the paper's Table 1, ARW interval means, ground-truth confidence
    and tracking metrics (simulated scenarios), the kurtosis threshold crossings (Fig. 8);
    ``--out`` writes the tables (CSV, JSON) and the paper's figures.
``adavar monitor SOURCE --rate HZ --units UNIT [...]``
    The adaptive window on a live stream (standard input, a file being appended to, or a
    UDP port): one JSON line per event as it is confirmed, a status line on a terminal.
``adavar demo [--out DIR] [--json] [--seed N]``
    The NIST SP 1065 check values, a simulated MEMS gyroscope and the paper's scenario 1.

``avar``, ``davar``, ``adaptive`` and ``report`` analyse several channels one by one with
``--column gx,gy,gz`` (``avar`` needs it for several numeric columns unless the file
declares each column's unit); on a terminal every
command shows what it is doing on one status line of stderr (nothing when stderr is not a
terminal).

Exit codes: 0 success, 1 internal error (a bug: the traceback with ``--debug`` or
``ADAVAR_DEBUG=1``), 2 a user mistake (bad flag, unreadable file, bad data), reported as
one line ``adavar: error: ...`` on stderr. 130 when interrupted.

Only this module prints; the library functions it calls return data."""

from typing import Any

__all__ = ["build_parser", "main", "run"]


def run() -> None:
    """The console script ``adavar``: :func:`main`, then exit with its code.

    Defined here rather than imported from :mod:`adavar.cli.entry`: a ``spawn`` worker
    process imports the parent's main module, the script, and with it this name, which
    then costs no import of the command line.

    The command is a process of its own: it has Numba compile at LLVM's -O2
    (``NUMBA_OPT=2`` unless the environment says otherwise; a first run compiles about a
    fifth faster, the kernels run as fast), set before Numba is imported. Importing the
    library changes no environment variable.
    """
    import os

    os.environ.setdefault("NUMBA_OPT", "2")
    from adavar.cli.entry import run as run_entry

    run_entry()


def __getattr__(name: str) -> Any:  # PEP 562: ``adavar.cli.options`` alone stays light
    if name in ("build_parser", "main"):
        from adavar.cli import entry

        value = getattr(entry, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'adavar.cli' has no attribute {name!r}")

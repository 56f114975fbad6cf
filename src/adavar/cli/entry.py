"""The ``adavar`` entry point: the parser of every command and :func:`main`."""

from __future__ import annotations

import argparse
import io as _stdio
import os
import sys
import traceback
from collections.abc import Sequence

from adavar import __version__
from adavar.cli.avar import add_avar_parser
from adavar.cli.batch import add_batch_parser
from adavar.cli.compare import add_compare_parser
from adavar.cli.config import with_config
from adavar.cli.davar import add_adaptive_parser, add_davar_parser
from adavar.cli.demo import add_demo_parser
from adavar.cli.kalibr import add_kalibr_parser
from adavar.cli.monitor import add_monitor_parser
from adavar.cli.options import (
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_USAGE,
    UsageError,
)
from adavar.cli.output import clear_status_line, one_line
from adavar.cli.parser import Parser
from adavar.cli.precompile import add_precompile_parser
from adavar.cli.report import add_report_parser
from adavar.cli.simulate import add_simulate_parser
from adavar.core.errors import AdavarInputError

__all__ = ["build_parser", "main", "run"]


def build_parser() -> argparse.ArgumentParser:
    """The ``adavar`` argument parser (its ``error`` raises :class:`UsageError`).

    Returns
    -------
    argparse.ArgumentParser
    """
    parser = Parser(
        prog="adavar",
        description="Allan-family statistics with confidence intervals and IEEE Std 952 "
        "noise-coefficient fits (avar), the dynamic Allan variance of a sliding window with "
        "the noise coefficients over time (davar), fixed and adaptive windows side by side "
        "(compare), the adaptive window on a live stream (monitor), and a demonstration (demo).",
    )
    parser.add_argument("--version", action="version", version=f"adavar {__version__}")
    parser.add_argument(
        "--debug", action="store_true", help="show the traceback of internal errors"
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)

    add_avar_parser(sub)
    add_davar_parser(sub)
    add_adaptive_parser(sub)
    add_compare_parser(sub)
    report_parser = add_report_parser(sub)
    add_batch_parser(sub, report_parser)
    add_kalibr_parser(sub)
    add_monitor_parser(sub)
    add_simulate_parser(sub)
    add_demo_parser(sub)
    add_precompile_parser(sub)
    for cmd in sub.choices.values():  # read by with_config before parsing; listed for --help
        cmd.add_argument(
            "--config", metavar="FILE.toml",
            help="read options from a TOML file (top level or a [command] table, by long "
            "option name); flags on the command line override it",
        )  # fmt: skip
    return parser


def main(argv: Sequence[str] | None = None, *, process_exits: bool = False) -> int:
    """Run the ``adavar`` command line.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments after the program name; ``sys.argv[1:]`` by default.
    process_exits : bool
        Accepted for scripts written against 0.1.0, without effect: no command turns the
        garbage collector off any more.

    Returns
    -------
    int
        The exit code: 0 success, 1 internal error, 2 user error, 130 interrupted.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv or os.environ.get("ADAVAR_DEBUG", "").strip() not in ("", "0")
    args: argparse.Namespace | None = None
    parser: Parser | None = None
    try:
        parser = build_parser()
        argv = with_config(parser, argv)
        args = parser.parse_args(argv)
        if args.command is None:
            raise UsageError(
                "choose a command: avar (deviation of a data file), davar (dynamic Allan "
                "variance of a data file), adaptive (A-DAVAR), compare (fixed and adaptive "
                "windows side by side), report (HTML report), batch (many files, on a "
                "cluster), kalibr (imu.yaml), monitor (a live stream), simulate, demo or "
                "precompile (see 'adavar --help')"
            )
        return int(args.handler(args))
    except SystemExit as exc:  # --help, --version
        code = exc.code
        return code if isinstance(code, int) else (EXIT_OK if code is None else EXIT_USAGE)
    except (UsageError, AdavarInputError) as exc:
        clear_status_line()
        command = parser.commands.get(args.command) if parser and args else None
        ways = command.gap_ways if command is not None else ()
        print(f"adavar: error: {one_line(gap_way_out(exc, ways))}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("adavar: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # e.g. `adavar avar ... | head`
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError, _stdio.UnsupportedOperation):
            pass
        return EXIT_INTERNAL
    except Exception as exc:
        clear_status_line()
        if debug:
            traceback.print_exc()
        hint = "" if debug else " (rerun with --debug or ADAVAR_DEBUG=1 for the traceback)"
        print(
            f"adavar: internal error: {type(exc).__name__}: {one_line(str(exc))}{hint}",
            file=sys.stderr,
        )
        return EXIT_INTERNAL


def gap_way_out(exc: Exception, ways: Sequence[str]) -> str:
    """The message of ``exc``; for a gap in the time stamps (:class:`GapError`), with the
    ``--gaps`` policies ``ways`` that get this command past it (its parser's
    :attr:`~adavar.cli.parser.Parser.gap_ways`), not the reader's list of every policy
    (``--gaps split`` is for ``adavar avar`` only, ``omit`` for ``avar`` and ``davar``)."""
    from adavar.readers.errors import GapError

    if not isinstance(exc, GapError) or not ways:
        return str(exc)
    return f"{exc.problem}: use {' or '.join(f'--gaps {way}' for way in ways)}"


def run() -> None:
    """The console script ``adavar``: :func:`main`, then exit with its code."""
    sys.exit(main())

"""Write ``reference/cli.md`` from the parser itself (mkdocs-gen-files, at build time).

Every command of :func:`adavar.cli.build_parser`: its usage, description and each option
with its metavar, choices, default and help. Nothing here is copied by hand, so the page
is the parser of the version being documented.
"""

from __future__ import annotations

import argparse
import html
import os
import re

import mkdocs_gen_files

from adavar import __version__
from adavar.cli import build_parser

WIDTH = 92


def _escape(text: str) -> str:
    """Plain help text as Markdown: no emphasis, no HTML, no table breaks."""
    text = html.escape(text, quote=False)
    return re.sub(r"([\\`*_\[\]|])", r"\\\1", text)


def _help(action: argparse.Action, parser: argparse.ArgumentParser) -> str:
    if not action.help:
        return ""
    formatter = parser._get_formatter()
    return " ".join(formatter._expand_help(action).split())


def _flags(action: argparse.Action) -> str:
    metavar = action.metavar or action.dest.upper().replace("_", "-")
    if isinstance(metavar, tuple):
        metavar = " ".join(metavar)
    if not action.option_strings:
        return f"`{metavar}`"
    if action.nargs == 0:
        return ", ".join(f"`{name}`" for name in action.option_strings)
    return ", ".join(f"`{name} {metavar}`" for name in action.option_strings)


def _default(action: argparse.Action) -> str:
    if action.option_strings and action.nargs == 0:
        return ""  # a switch: off unless given
    default = action.default
    if default is None or default is argparse.SUPPRESS or default == []:
        return ""
    if isinstance(default, (list, tuple)):
        default = ",".join(map(str, default))
    return f"`{default}`"


def _rows(parser: argparse.ArgumentParser) -> list[str]:
    rows = ["| option | default | description |", "|---|---|---|"]
    for _, _, action in parser.options:
        if action.dest == "help":
            continue
        if action.help is argparse.SUPPRESS:
            continue
        text = _escape(_help(action, parser))
        if action.choices:
            choices = ", ".join(f"`{c}`" for c in action.choices)
            text = f"{text}<br>choices: {choices}" if text else f"choices: {choices}"
        if action.required and action.option_strings:
            text = f"**required.** {text}"
        rows.append(f"| {_flags(action)} | {_default(action)} | {text} |")
    return rows


def _usage(parser: argparse.ArgumentParser) -> str:
    return parser.format_usage().strip()


def _subcommands(parser: argparse.ArgumentParser) -> tuple[dict, dict]:
    return parser.commands, parser.summaries


def page() -> str:
    os.environ["COLUMNS"] = str(WIDTH)
    parser = build_parser()
    commands, summaries = _subcommands(parser)
    out = [
        "# Command line",
        "",
        f"The `adavar` command of adavar {__version__}. This page is generated from the "
        "parser (`adavar.cli.build_parser()`) when the site is built; `adavar COMMAND "
        "--help` prints the same. Every command prints a table, or one JSON object with "
        "`--json`; exit codes: 0 success, 2 bad input or usage (a one-line message), "
        "1 internal error, 130 interrupted.",
        "",
        "```text",
        _usage(parser),
        "```",
        "",
        _escape(parser.description or ""),
        "",
        *_rows(parser),
        "",
        "| command | what it does |",
        "|---|---|",
        *(f"| [`{name}`](#{name}) | {_escape(summaries.get(name, ''))} |" for name in commands),
        "",
    ]
    for name, sub in commands.items():
        out += [
            f"## {name}",
            "",
            f"*{_escape(summaries.get(name, ''))}*",
            "",
            "```text",
            _usage(sub),
            "```",
            "",
            _escape(sub.description or ""),
            "",
            *_rows(sub),
            "",
        ]
        if sub.epilog:
            out += [_escape(sub.epilog), ""]
    return "\n".join(out)


with mkdocs_gen_files.open("reference/cli.md", "w") as fh:
    fh.write(page())
mkdocs_gen_files.set_edit_path("reference/cli.md", "gen/cli_reference.py")

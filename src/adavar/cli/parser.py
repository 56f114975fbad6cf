"""The ``adavar`` argument parser: one-line errors, and the options it was given kept."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any, NoReturn

from adavar.cli.options import UsageError

__all__ = ["OptionGroup", "Parser"]


class Parser(argparse.ArgumentParser):
    """ArgumentParser that raises :class:`UsageError` instead of printing usage and exiting.

    It also keeps what argparse keeps only in private attributes: every option added
    (:attr:`options`, each as ``(flags, keywords, action)``, those of its groups too) and
    its sub-command parsers (:attr:`commands`, their one-line help in :attr:`summaries`),
    for ``--config`` files and for commands that share options.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        # set first: ArgumentParser.__init__ adds --help through add_argument
        self.options: list[tuple[tuple[str, ...], dict[str, Any], argparse.Action]] = []
        self.commands: dict[str, Parser] = {}
        self.summaries: dict[str, str] = {}  # command -> its one-line help
        #: the --gaps policies that get this command past a gap (its message names them)
        self.gap_ways: tuple[str, ...] = ()
        super().__init__(*args, **kwargs)

    def add_argument(self, *args: Any, **kwargs: Any) -> argparse.Action:
        """:meth:`argparse.ArgumentParser.add_argument`, recorded in :attr:`options`."""
        action = super().add_argument(*args, **kwargs)
        self.options.append((tuple(args), dict(kwargs), action))
        return action

    def group(self, title: str) -> OptionGroup:
        """An argument group whose options are recorded in :attr:`options` too."""
        return OptionGroup(self, super().add_argument_group(title))

    def add_subparsers(self, **kwargs: Any) -> Any:
        """:meth:`argparse.ArgumentParser.add_subparsers`; the parsers it adds are kept in
        :attr:`commands` by name."""
        return _Commands(self, super().add_subparsers(**kwargs))

    def copy_options(self, other: Parser, skip: Sequence[str] = ()) -> None:
        """Add every option of ``other`` (but those whose destination is in ``skip``) here,
        with the same flags and keywords: options shared by two commands cannot drift."""
        for args, kwargs, action in other.options:
            if action.dest not in skip:
                # as the option stands now (a command may have widened its help or choices)
                now = {key: getattr(action, key) for key in ("help", "default")}
                if "choices" in kwargs:
                    now["choices"] = action.choices
                self.add_argument(*args, **{**kwargs, **now})

    def option(self, flag: str) -> argparse.Action | None:
        """The action of the option ``flag`` (``--name``), or None."""
        return next((a for _, _, a in self.options if flag in a.option_strings), None)

    def error(self, message: str) -> NoReturn:
        """Raise a one-line :class:`UsageError` pointing at this parser's ``--help``."""
        raise UsageError(f"{message} (see '{self.prog} --help')")


class OptionGroup:
    """An argument group of a :class:`Parser` that records its options in the parser's."""

    def __init__(self, parser: Parser, group: Any) -> None:
        self.parser, self.group = parser, group

    def add_argument(self, *args: Any, **kwargs: Any) -> argparse.Action:
        """Add an option to the group (recorded in the parser's :attr:`Parser.options`)."""
        action = self.group.add_argument(*args, **kwargs)
        self.parser.options.append((tuple(args), dict(kwargs), action))
        return action


class _Commands:
    """The sub-command action of a :class:`Parser`; ``add_parser`` records each parser."""

    def __init__(self, parser: Parser, action: Any) -> None:
        self.parser, self.action = parser, action

    @property
    def choices(self) -> dict[str, Parser]:
        return self.parser.commands

    def add_parser(self, name: str, **kwargs: Any) -> Parser:
        """A new sub-command parser (a :class:`Parser`), kept in ``commands``."""
        cmd = self.action.add_parser(name, **kwargs)
        self.parser.commands[name] = cmd
        self.parser.summaries[name] = kwargs.get("help") or ""
        return cmd

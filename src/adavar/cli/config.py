"""``--config FILE.toml``: options from a TOML file, flags on the command line override them."""

from __future__ import annotations

import argparse

from adavar.cli.options import UsageError


def with_config(parser: argparse.ArgumentParser, argv: list[str]) -> list[str]:
    """``argv`` with the settings of ``--config FILE.toml`` placed before the user's flags.

    The TOML file sets any option of the command by its long name (``window = 600``,
    ``taus = "octave"``, ``fit = true``, ``column = ["gx", "gy"]``), at its top level or
    in a table named after the command (``[davar]``, which wins). Flags given on the
    command line come later and so override the file. The data FILE stays on the command
    line.
    """
    if "--config" not in argv and not any(a.startswith("--config=") for a in argv):
        return argv
    import tomllib

    rest: list[str] = []
    path = None
    it = iter(argv)
    for token in it:
        if token == "--config":
            path = next(it, None)
            if path is None:
                raise UsageError("--config needs a FILE.toml")
        elif token.startswith("--config="):
            path = token.split("=", 1)[1]
        else:
            rest.append(token)
    if not rest or rest[0].startswith("-"):
        raise UsageError("--config belongs after a command, e.g. adavar davar --config run.toml")
    command = rest[0]
    try:
        with open(path, "rb") as fh:
            table = tomllib.load(fh)
    except FileNotFoundError:
        raise UsageError(f"--config {path}: no such file") from None
    except UnicodeDecodeError as exc:  # TOML is UTF-8
        raise UsageError(
            f"--config {path} is not UTF-8 text (byte {exc.start} cannot be decoded): save "
            "it as UTF-8"
        ) from None
    except (OSError, tomllib.TOMLDecodeError) as exc:
        reason = " ".join(str(exc).split())
        raise UsageError(f"--config {path}: not a readable TOML file ({reason})") from None
    settings = {k: v for k, v in table.items() if not isinstance(v, dict)}
    section = table.get(command, {})
    if not isinstance(section, dict):
        raise UsageError(f"--config {path}: [{command}] must be a table")
    settings.update(section)
    cmd_parser = getattr(parser, "commands", {}).get(command)
    if cmd_parser is None:
        return rest  # argparse reports the unknown command
    options = {
        opt[2:]: action
        for _, _, action in cmd_parser.options
        for opt in action.option_strings
        if opt.startswith("--")
    }
    tokens: list[str] = []
    for key, value in settings.items():
        name = str(key).replace("_", "-")
        action = options.get(name)
        if action is None or name in ("config", "help", "debug"):
            raise UsageError(
                f"--config {path}: {key!r} is not an option of 'adavar {command}' (see "
                f"'adavar {command} --help')"
            )
        if action.nargs == 0 and action.const is True:  # store_true
            if not isinstance(value, bool):
                raise UsageError(f"--config {path}: {key} takes true or false")
            if value:
                tokens.append(f"--{name}")
            continue
        if isinstance(action, argparse.BooleanOptionalAction):  # --lazy / --no-lazy
            if not isinstance(value, bool) or name.startswith("no-"):
                raise UsageError(f"--config {path}: {key} takes true or false")
            tokens.append(f"--{name}" if value else f"--no-{name}")
            continue
        if isinstance(value, list):
            value = ",".join(str(v) for v in value)
        elif isinstance(value, bool):
            raise UsageError(f"--config {path}: {key} takes a value, not true/false")
        tokens += [f"--{name}", str(value)]
    return [command, *tokens, *rest[1:]]

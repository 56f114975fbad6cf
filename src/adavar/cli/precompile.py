"""``adavar precompile``: compile every kernel into Numba's on-disk cache, once."""

from __future__ import annotations

import argparse
from typing import Any

from adavar.cli.options import EXIT_OK, UsageError
from adavar.cli.output import Status
from adavar.cli.values import positive_int


def _cmd_precompile(args: argparse.Namespace) -> int:
    from adavar.io.writers import dumps
    from adavar.pipeline.precompile import STAGES, precompile

    stages = None
    if args.stages:
        stages = [name.strip() for name in args.stages.split(",") if name.strip()]
        unknown = [name for name in stages if name not in STAGES]
        if unknown or not stages:
            raise UsageError(
                f"--stages: unknown stage {(unknown or [args.stages])[0]!r}; choose from "
                f"{','.join(STAGES)}"
            )
    workers = args.workers
    if workers is None:
        from adavar._kernels._workers import free_cores

        workers = free_cores()
    Status()(f"compiling the kernels ({workers} process{'es' * (workers > 1)})")
    result = precompile(stages, workers=workers)
    if args.json:
        print(dumps({"stages": list(result.stages), "compiled": result.compiled,
                     "seconds": result.seconds, "cache_dir": result.cache_dir}))  # fmt: skip
    else:
        where = result.cache_dir or "__pycache__ beside adavar's sources"
        print(f"{result.compiled} compilations in {result.seconds:.1f} s "
              f"({len(result.stages)} stages); cache: {where}")  # fmt: skip
    return EXIT_OK


def add_precompile_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``adavar precompile`` to the sub-command parsers ``sub``."""
    from adavar.pipeline.precompile import STAGES

    cmd = sub.add_parser(
        "precompile",
        help="compile every kernel once (after installing), so that no command compiles",
        description="Compile adavar's Numba kernels into the on-disk cache (NUMBA_CACHE_DIR "
        "when set, else __pycache__ beside the sources). Commands compile what they need on "
        "first use anyway; this does it all ahead, for example when a container image is "
        "built. Running it again on a full cache compiles nothing.",
    )
    cmd.add_argument(
        "--workers", type=positive_int, default=None, metavar="N",
        help="processes compiling side by side (default: 2 where two cores are free, else 1)",
    )  # fmt: skip
    cmd.add_argument(
        "--stages", metavar="NAME,...",
        help=f"only these stages (default: all of {','.join(STAGES)})",
    )  # fmt: skip
    cmd.add_argument("--json", action="store_true", help="a JSON summary on stdout")
    cmd.set_defaults(handler=_cmd_precompile)
    return cmd

"""``adavar report``: the self-contained HTML report of one or several channels."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

from adavar import __version__
from adavar.cli.options import (
    EXIT_OK,
    KURTOSIS_CONTROLLER,
    add_controller_arguments,
    add_fit_arguments,
    add_input_arguments,
    check_arguments,
    given_flags,
    ignored,
    listed_flags,
)
from adavar.cli.output import Status, check_output_file, fit_lines, output_error
from adavar.cli.values import length_arg, parse_taus, parse_terms, window_length
from adavar.core.settings import DATA_TYPE_DEFAULT
from adavar.io.writers import dumps, fit_json

if TYPE_CHECKING:
    from adavar.pipeline.analysis import ChannelAnalysis


#: The controller's settings that a fixed window (``report --window L``: its events come
#: from the controller's test on that one window) does not use: it neither grows nor shrinks.
FIXED_WINDOW_UNUSED = ("lmax", "lmin", "dl0", "dl1")


def check_adaptive_only_flags(args: argparse.Namespace) -> None:
    """``adavar report`` and ``batch``: the adaptive window's flags without ``--adaptive``
    are an error (exit 2), not silently dropped (``--lmax 100`` wrote the report of no
    adaptive window). With ``--window L`` the controller's test runs on that fixed window (its
    events), so only the lengths and steps of a changing window are refused."""
    if getattr(args, "adaptive", False):
        return
    given = given_flags(args)
    flags = {dest: flag for dest, flag in (("lmax", "--lmax"), ("lmin", "--lmin"),
                                           ("segment", "--l"))
             if getattr(args, dest, None) is not None}  # fmt: skip
    flags.update((d, f) for d, f in given.items() if d in KURTOSIS_CONTROLLER)
    if getattr(args, "window", None) is not None:
        unused = [flag for dest, flag in flags.items() if dest in FIXED_WINDOW_UNUSED]
        if unused:
            raise ignored(unused, "with --window (a fixed window; only --adaptive grows and "
                           "shrinks one)", f"give --adaptive instead of --window, or drop "
                           f"{listed_flags(unused)}")  # fmt: skip
        return
    if flags:
        unused = list(flags.values())
        raise ignored(unused, "without --adaptive (the report has no adaptive window)",
                       f"add --adaptive, or drop {listed_flags(unused)}")  # fmt: skip


def _cmd_report(args: argparse.Namespace) -> int:
    check_adaptive_only_flags(args)
    check_arguments(args)
    output = check_output_file(args.output, args.force, (".html", ".htm"))
    return _run_report(args, output)


def _run_report(args: argparse.Namespace, output: Any) -> int:
    from adavar._kernels._heap import release_free_memory
    from adavar.core.request import AnalysisRequest
    from adavar.output.report import build_report, channel_section, channels_page, write_report
    from adavar.pipeline.analysis import run as run_analysis
    from adavar.pipeline.analysis import surface_shape
    from adavar.pipeline.report_analysis import report_parameters

    status = Status()
    request = AnalysisRequest.from_options(args)
    segment_given = request.controller.l is not None  # before the windows follow the record
    sections: list[str] = []  # several channels: each one's section, built as it is done
    figures: dict[str, dict[str, Any]] = {}
    several = False

    def each(name: str, run: ChannelAnalysis, samples: Any) -> None:
        run.events = _events(samples, run, segment_given)
        run.shape = surface_shape(run.surface)
        run.controller = None if run.adaptive is None else run.adaptive.parameters
        if several:  # its plots now, and its surface freed before the next one is computed
            sections.append(channel_section(len(sections) + 1, name, run, figures))
            run.result = run.surface = run.adaptive = run.coefficients = None
            release_free_memory()  # the surface's pages, before the next channel's

    def count(request: AnalysisRequest, loaded: Any) -> None:
        nonlocal several
        several = len(loaded.channels) > 1

    # a file is read piece by piece (a record larger than memory), the surfaces too (a
    # block of windows at a time: the report reads a few of its rows)
    done = run_analysis(request, status=status, keep="figures", check=count, each=each)
    meta, tau0 = done.meta, done.tau0
    names, runs = list(done.channels), list(done.channels.values())
    units_of = {name: r.units for name, r in done.channels.items()}
    first = runs[0]
    used = first.options  # the lengths as used: in samples, the record's windows chosen
    units = first.units if not several else "; ".join(
        f"{name}: {units_of[name]}" for name in names
    )  # fmt: skip
    parameters = report_parameters(
        used, units, tau0, meta, first.shape is not None, first.controller
    )
    steps = [step.get("spec", str(step)) for step in meta["preprocessing"]]
    status("building the figures and the HTML")
    if several:
        title = args.title or f"{Path(meta['path']).name}, columns {', '.join(names)}"
        html = channels_page(
            title=title,
            source={"file": meta["path"], "columns": ", ".join(names), "format": meta["kind"],
                    "samples": int(first.samples)},
            sections=sections, figures=figures, parameters=parameters, preprocessing=steps,
        )  # fmt: skip
    else:
        title = args.title or f"{Path(meta['path']).name}, column {meta['column']}"
        html = build_report(
            title=title,
            source={"file": meta["path"], "column": meta["column"], "format": meta["kind"],
                    "samples": int(first.samples)},
            deviation=first.result, fit=first.fit, surface=first.surface,
            coefficients=first.coefficients, adaptive=first.adaptive,
            parameters=parameters, preprocessing=steps, units=first.rate_units,
            events=(first.events or {}).get("items"),
        )  # fmt: skip
    status(f"writing {output}")
    try:
        write_report(output, html)
    except OSError as exc:
        raise output_error(args.output, exc) from None
    status.close()

    def channel_json(name: str, run: ChannelAnalysis) -> dict[str, Any]:
        return {
            "input": {"file": meta["path"], "column": name, "rate": 1.0 / tau0,
                      "units": run.units, "n_samples": int(run.samples),
                      "preprocessing": steps},
            "fit": fit_json(run.fit),
            "surface": run.shape,
            "events": None if run.events is None else run.events["items"],
        }  # fmt: skip

    payload: dict[str, Any] = {
        "adavar_version": __version__,
        "report": str(output),
        "bytes": len(html.encode("utf-8")),
    }
    if several:
        payload["input"] = {"file": meta["path"], "columns": names, "rate": 1.0 / tau0,
                            "preprocessing": steps}  # fmt: skip
        payload["channels"] = {name: channel_json(name, run)
                               for name, run in zip(names, runs, strict=True)}  # fmt: skip
    else:
        payload.update(channel_json(names[0], first))
    if args.json:
        print(dumps(payload))
        return EXIT_OK
    print(f"wrote {output} ({payload['bytes'] / 1e6:.1f} MB): {title}")
    for name, run in zip(names, runs, strict=True):
        if several:
            print(f"  column {name!r} ({run.units}):")
        print("\n".join(fit_lines(run.fit, "    " if several else "  ")))
    return EXIT_OK


def _events(samples: Any, run: ChannelAnalysis, segment_given: bool) -> dict[str, Any] | None:
    """The events of one channel, as :meth:`ReportAnalysis.events` finds them."""
    from adavar.pipeline.analysis import rate_keywords
    from adavar.pipeline.report_analysis import ReportAnalysis

    if run.surface is None:
        return None
    tau0 = 1.0 / run.request.record.rate if run.request.record.tau0 is None else (
        run.request.record.tau0
    )  # fmt: skip
    analysis = ReportAnalysis(
        path=str(run.request.record.file), title="", samples=samples, meta={},
        units=run.units, rate_units=run.rate_units, tau0=float(tau0),
        rate_options=rate_keywords(run.request, tau0),
        # the lengths as the analysis used them (in samples, the record's windows chosen)
        options={**vars(run.options), "segment_given": segment_given},
        deviation=run.result, fit=run.fit, surface=run.surface,
        adaptive=run.adaptive, coefficients=run.coefficients,
    )  # fmt: skip
    return analysis.events()


def add_report_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``adavar report`` to the sub-command parsers ``sub``."""
    rep = sub.add_parser(
        "report",
        help="one self-contained interactive HTML report of a record",
        description="Analyse one column of a record (or several, --column a,b: a section "
        "each) and write ONE self-contained HTML file "
        "(interactive plots, no network): the overlapping Allan deviation with confidence "
        "bars and the fitted noise terms, the coefficient table with uncertainties, and with "
        "--window or --adaptive the rotatable DAVAR surface, the coefficients over time and "
        "(A-DAVAR) the controller's kurtosis, S, flags and window length; plus every "
        "parameter and preprocessing step used.",
    )
    add_input_arguments(rep)
    rep.add_argument(
        "-o", "--output", metavar="FILE.html", required=True,
        help="the report to write (atomically; an existing file needs --force)",
    )  # fmt: skip
    rep.add_argument(
        "--data-type", default=DATA_TYPE_DEFAULT, choices=("rate", "phase"),
        help="rate samples (default; phase for a Stable32 .phd file) or their integral "
        "(angle, velocity, time error)",
    )  # fmt: skip
    rep.add_argument(
        "--window", metavar="L", type=window_length,
        help="also a fixed-window DAVAR of L samples, or of a duration such as 10min "
        "(surface and coefficients over time)",
    )  # fmt: skip
    rep.add_argument(
        "--adaptive", action="store_true",
        help="also the adaptive-window DAVAR (A-DAVAR, the controller settings below)",
    )  # fmt: skip
    add_controller_arguments(rep)
    rep.add_argument(
        "--taus", default="octave", type=parse_taus, metavar="SPEC",
        help="taus of the DAVAR surface: octave (default), all, decade, log or seconds",
    )  # fmt: skip
    rep.add_argument(
        "--step", metavar="S", type=length_arg(1), default=1,
        help="DAVAR centres every S samples (default: 1)",
    )  # fmt: skip
    rep.add_argument(
        "--terms", type=parse_terms, metavar="LIST",
        help="terms of the noise fits (names or Q,N,B,K,R; default: all five)",
    )  # fmt: skip
    add_fit_arguments(rep)
    rep.add_argument("--title", help="title of the report (default: the file and column)")
    rep.add_argument("--json", action="store_true", help="print one JSON object")
    rep.add_argument("--force", action="store_true", help="replace an existing --output")
    rep.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )
    rep.set_defaults(handler=_cmd_report)
    return rep

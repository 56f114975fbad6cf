"""``adavar demo``: the NIST check values, a simulated MEMS gyro, the paper's scenario 1."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from adavar import __version__
from adavar.cli.compare import compare_report, compare_tables, crossings_json
from adavar.cli.options import EXIT_OK, add_figures_argument
from adavar.cli.output import (
    Status,
    deviation_table,
    fit_lines,
    guard_replacement,
    output_error,
    text_table,
)
from adavar.cli.values import parse_seed, positive_int
from adavar.core.atomic import (
    DEMO_MARKER,
    atomic_directory,
    check_output_directory,
    is_adavar_folder,
)
from adavar.core.csv_tables import write_pieces
from adavar.core.errors import AdavarInputError
from adavar.io.writers import deviation_json, dumps, fit_json

# DEMO_MARKER (adavar.io.writers) marks a folder written by ``adavar demo``: such a folder is
# replaced by the next run; --force replaces another folder adavar wrote, never a foreign one.


DEMO_DEFAULT_OUT = "adavar-demo"


def _demo_json(
    demo: Any, out: str, files: list[str], tables: dict[str, str] | None = None
) -> dict[str, Any]:
    gyro = demo.gyro
    return {
        "adavar_version": __version__,
        "nist": {
            "rows": [
                {
                    "stat": r.stat,
                    "averaging_factor": r.averaging_factor,
                    "tau": r.tau,
                    "computed": r.computed,
                    "published": r.published,
                    "rel_diff": r.rel_diff,
                }
                for r in demo.nist
            ],
            "max_rel_diff": demo.nist_max_rel_diff,
            "mean": {"computed": demo.nist_mean.computed, "published": demo.nist_mean.published},
            "std": {"computed": demo.nist_std.computed, "published": demo.nist_std.published},
        },
        "gyro": {
            "rate": gyro.rate,
            "n_samples": gyro.n_samples,
            "units": gyro.units,
            "seed": gyro.seed,
            "true": {
                name: {"value": value, "unit": unit}
                for name, (value, unit) in gyro.true_conventional.items()
            },
            **deviation_json(gyro.result),
            "fit": fit_json(gyro.fit),
        },
        "paper": None
        if demo.paper is None
        else {
            "comparison": demo.paper.comparison.to_dict(),
            "crossings": crossings_json(demo.paper.thresholds),
            "seeds": demo.paper.study.to_dict(),
        },
        "out": {"dir": out, "files": files, "tables": tables or {}},
        "elapsed_s": demo.elapsed,
    }


def _check_demo_out(out: str, force: bool) -> None:
    path = Path(out)
    if path.is_dir() and not path.is_symlink() and not force:
        if any(path.iterdir()) and not (path / DEMO_MARKER).is_file():
            another = (" (it is another adavar output: pass --force to replace it)"
                       if is_adavar_folder(path) else ", or remove it yourself")  # fmt: skip
            raise AdavarInputError(
                f"{out} exists and was not written by adavar demo: choose another --out{another}"
            )
    guard_replacement(out, [])
    check_output_directory(out, replace=True)


def _demo_report(demo: Any) -> str:
    """The demo's HTML report: the simulated gyro, and the paper's scenario 1 with A-DAVAR."""
    from adavar.core.settings import PAPER
    from adavar.dynamic.adaptive import adaptive_davar
    from adavar.fit.noise_model import fit_noise
    from adavar.output.report import build_report

    gyro = demo.gyro
    paper = demo.paper
    adaptive = coefficients = comparison = None
    if paper is not None:
        comparison = paper.comparison
        # the paper's controller, as the scenario's comparison (not the record's defaults)
        adaptive = adaptive_davar(comparison.data, rate=comparison.rate, taus="octave",
                                  **PAPER.keywords())  # fmt: skip
        coefficients = fit_noise(adaptive)
    return build_report(
        title="adavar demo: a simulated MEMS gyro and the A-DAVAR paper's scenario 1",
        source={"gyro": f"simulated, {gyro.n_samples} samples at {gyro.rate:g} Hz in "
                f"{gyro.units}, seed {gyro.seed}",
                "scenario": None if comparison is None else comparison.description},
        deviation=gyro.result, fit=gyro.fit, surface=adaptive, coefficients=coefficients,
        adaptive=adaptive, comparison=comparison,
        parameters={"gyro statistic": "oadev, octave taus",
                    "A-DAVAR": "Lmax 600, Lmin 400, K1 2.5, K2 3.3, S2 0.07, l 100"},
        units=gyro.units,
    )  # fmt: skip


#: The demo's figures, the longest to draw first: the worker takes them from the start,
#: this process (once its tables and report are written) from the end
FIGURE_ORDER = ("fig10_controller", "fig11_adavar_surface", "gyro_oadev",
                "fig06_kurtosis_windows", "fig07_contribution", "fig12_arw",
                "fig08_thresholds")  # fmt: skip


def _figure_recipes(demo: Any) -> dict[str, Any]:
    """File stem -> how to draw it (:data:`adavar.output.plots.FigureRecipe`), in drawing order."""
    from adavar.output.plots import deviation_figure, paper_figure_recipes

    gyro, paper = demo.gyro, demo.paper
    title = (
        f"Simulated MEMS gyro ({gyro.n_samples:,} samples at {gyro.rate:g} Hz, seed {gyro.seed})"
    )
    recipes = {"gyro_oadev": (deviation_figure, (gyro.result, gyro.fit), {"title": title})}
    if paper is not None:
        recipes.update(paper_figure_recipes(
            paper.comparison, kurtosis=paper.kurtosis, thresholds=paper.thresholds
        ))  # fmt: skip
    order = {stem: k for k, stem in enumerate(FIGURE_ORDER)}
    return dict(sorted(recipes.items(), key=lambda item: order.get(item[0], len(order))))


def _draw_figure(
    folder: str, stem: str, formats: tuple[str, ...], draw: Any, args: tuple, kwargs: dict
) -> str:
    """Draw one figure and write it into ``folder`` (in either process); returns the stem."""
    from adavar.output.plots import save_figure

    save_figure(draw(*args, **kwargs), Path(folder) / stem, formats)
    return stem


def _demo_outputs(
    args: argparse.Namespace, status: Status, demo: Any, pool: Any
) -> tuple[list[str], str]:
    """Draw, tabulate and write the demo's folder; the worker shares the figures.

    The figures are submitted first, so that the worker draws while this process writes
    the tables, the report and the JSON, and then takes the figures not yet started.
    Returns the files written and the JSON text.
    """
    from adavar._kernels._workers import SharedJobs

    paper = demo.paper
    try:
        with atomic_directory(args.out, replace=True) as tmp:
            formats = tuple(args.figures)
            recipes = _figure_recipes(demo) if formats else {}
            figures = SharedJobs(pool, _draw_figure, [
                (str(tmp), stem, formats, *recipe) for stem, recipe in recipes.items()
            ])  # fmt: skip
            status("building the HTML report")
            tables: dict[str, Any] = {}
            descriptions: dict[str, str] = {}
            if paper is not None:
                tables = {
                    f"paper_{name}": body
                    for name, body in compare_tables(
                        paper.comparison, paper.study, paper.thresholds, descriptions
                    ).items()
                }
                descriptions = {f"paper_{name}": text for name, text in descriptions.items()}
            for name, pieces in tables.items():
                write_pieces(tmp / name, pieces)
            (tmp / "report.html").write_text(_demo_report(demo), encoding="utf-8")
            drawn = sorted(stem for stem in recipes if stem != "gyro_oadev")
            gyro_files = [f"gyro_oadev.{ext}" for ext in formats]
            files = [*gyro_files, "demo.json", *tables,
                     *(f"{stem}.{ext}" for stem in drawn for ext in formats),
                     "report.html"]  # fmt: skip
            text = dumps(_demo_json(demo, str(args.out), files, descriptions))
            (tmp / "demo.json").write_text(text + "\n", encoding="utf-8")
            if recipes:
                status("drawing the figures")
                figures.results()
            status(f"writing {args.out}")
            (tmp / DEMO_MARKER).write_text(
                "written by adavar demo; the next run replaces this folder\n", encoding="utf-8"
            )
    except OSError as exc:
        raise output_error(args.out, exc) from None
    return files, text


def _cmd_demo(args: argparse.Namespace) -> int:
    from adavar._kernels._workers import worker_pool

    start = time.perf_counter()
    _check_demo_out(args.out, args.force)
    status = Status()
    status("NIST check values, a simulated gyro and the paper's scenario 1")
    # the worker starts before this process imports the demo: both import at once
    pool = worker_pool(args.workers, ("adavar.pipeline.demo",), start=True)
    try:
        from adavar.pipeline.demo import GYRO_BANDWIDTH, GYRO_BIAS, GYRO_LSB, run_demo

        demo = run_demo(seed=args.seed, executor=pool, keep="figures")
        files, text = _demo_outputs(args, status, demo, pool)
    finally:
        if pool is not None:
            # waits for the worker to exit (about 0.06 s; the interpreter's exit would wait
            # as long): Python 3.11's exit handler otherwise races with the pool closing
            # its wake-up pipe and may print "OSError: [Errno 9] Bad file descriptor"
            pool.shutdown(wait=True, cancel_futures=True)
    status.close()
    elapsed = time.perf_counter() - start
    gyro = demo.gyro
    paper = demo.paper

    if args.json:
        print(text)
        print(f"adavar: wrote {args.out}/ ({', '.join(files)})", file=sys.stderr)
        return EXIT_OK

    print("1. NIST SP 1065 1000-point test data (fractional frequency, tau0 = 1 s)")
    rows = [
        [r.stat.upper(), f"{r.averaging_factor}", f"{r.computed:.7e}", f"{r.published:.6e}",
         f"{r.rel_diff:+.1e}"]
        for r in demo.nist
    ]  # fmt: skip
    for r in (demo.nist_mean, demo.nist_std):
        rows.append([r.stat, "", f"{r.computed:.7e}", f"{r.published:.6e}", f"{r.rel_diff:+.1e}"])
    print(text_table(["stat", "AF", "adavar", "published", "rel. diff"], rows, "   "))
    print(
        f"   largest |relative difference| of the deviations: {demo.nist_max_rel_diff:.1e} "
        "(the published values have 7 significant digits)"
    )
    print()
    print(
        f"2. Simulated MEMS gyro: {gyro.n_samples} samples at {gyro.rate:g} Hz in {gyro.units} "
        f"(bias {GYRO_BIAS:g} {gyro.units}, {GYRO_BANDWIDTH:g} Hz low-pass, LSB "
        f"{GYRO_LSB:.3g} {gyro.units}, seed {gyro.seed}), OADEV at octave taus"
    )
    print(deviation_table(gyro.result, "   "))
    print()
    print("\n".join(fit_lines(gyro.fit, "   ", true=gyro.true_conventional)))
    print()
    if paper is not None:
        print(
            "3. The A-DAVAR paper's scenario 1 (Micromachines 2018, 9(8), 373): "
            "DAVAR-400, DAVAR-600, DAVAR-K and A-DAVAR"
        )
        report = "\n".join(compare_report(paper.comparison, paper.study, paper.thresholds))
        print("\n".join("   " + line if line else line for line in report.splitlines()))
        print()
    print(f"wrote {Path(args.out) / files[0]} and {', '.join(files[1:])}")
    print(f"done in {elapsed:.1f} s (computation {demo.elapsed:.2f} s)")
    return EXIT_OK


def add_demo_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``adavar demo`` to the sub-command parsers ``sub``."""
    demo = sub.add_parser(
        "demo",
        help="NIST SP 1065 check values, a simulated MEMS gyro and the paper's scenario 1",
        description="Reproduce the NIST SP 1065 published deviations, fit the noise terms "
        "of a simulated MEMS gyroscope with known coefficients, and run the A-DAVAR paper's "
        "scenario 1 end to end (DAVAR-400/600, DAVAR-K and A-DAVAR: nodes next to the paper's "
        "Table 1, metrics, Fig. 8 crossings); writes the figures and tables.",
    )
    demo.add_argument(
        "--out", metavar="DIR", default=DEMO_DEFAULT_OUT,
        help=f"output folder (default: ./{DEMO_DEFAULT_OUT}; replaced if it is an earlier "
        "demo's folder)",
    )  # fmt: skip
    demo.add_argument("--json", action="store_true", help="print one JSON object")
    add_figures_argument(demo, "", "the tables, report and JSON")
    demo.add_argument(
        "--seed", type=parse_seed, default=2018, metavar="N", help="seed of the simulated gyro"
    )
    demo.add_argument(
        "--workers", metavar="N", type=positive_int, default=None,
        help="processes: 1 runs everything in one; 2 (the default where two cores are "
        "free to this process) runs the paper's realisations in a second one meanwhile",
    )  # fmt: skip
    demo.add_argument(
        "--force", action="store_true",
        help="replace --out even if it is another adavar output than a demo's (never a "
        "folder adavar did not write)",
    )  # fmt: skip
    demo.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )
    demo.set_defaults(handler=_cmd_demo)
    return demo

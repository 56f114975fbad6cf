"""What the commands print and write: JSON, tables, CSV, output folders, the status line."""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from adavar.cli.options import UsageError
from adavar.core.errors import AdavarInputError
from adavar.core.results import DeviationResult
from adavar.core.terms import TERM_NAMES

if TYPE_CHECKING:  # pragma: no cover
    from adavar.core.results import NoiseFit
from adavar.io.writers import conventional


def text_table(headers: Sequence[str], rows: Sequence[Sequence[str]], indent: str = "") -> str:
    """Right-aligned columns (the first left-aligned)."""
    widths = [max(len(h), *(len(r[j]) for r in rows)) for j, h in enumerate(headers)]

    def line(cells: Sequence[str]) -> str:
        parts = [
            cell.ljust(w) if j == 0 else cell.rjust(w)
            for j, (cell, w) in enumerate(zip(cells, widths, strict=True))
        ]
        return indent + "  ".join(parts).rstrip()

    return "\n".join([line(headers), *(line(r) for r in rows)])


def deviation_table(result: DeviationResult, indent: str = "") -> str:
    headers = ["tau [s]", "n", "alpha", "edf", "dev", "dev_low", "dev_high"]
    rows = [
        [
            f"{tau:.6g}",
            f"{n:d}",
            f"{alpha:d}",
            f"{edf:.5g}",
            f"{dev:.6e}",
            f"{low:.6e}",
            f"{high:.6e}",
        ]
        for tau, n, alpha, edf, dev, low, high in zip(
            result.tau,
            result.n,
            result.alpha,
            result.edf,
            result.dev,
            result.dev_low,
            result.dev_high,
            strict=True,
        )
    ]
    return text_table(headers, rows, indent)


def fit_lines(fit: NoiseFit, indent: str = "", true: dict[str, Any] | None = None) -> list[str]:
    from adavar.core.units import format_pm, term_unit
    from adavar.output.plots import TERM_LABELS, term_label

    conv = conventional(fit)
    red = float(fit.reduced_chi2)
    terms = "all five terms" if len(fit.terms) == 5 else ", ".join(fit.terms)
    how = {
        "gls": "generalised least squares with the covariance of the taus, terms chosen by "
        f"{fit.selection.upper() if fit.selection in ('aic', 'bic') else fit.selection}",
        "wls": "non-negative least squares weighted by each point's edf",
        "slopes": "slope-line read-offs",
    }[fit.method]
    lines = [
        f"{indent}Noise fit ({terms}; {how}): reduced chi2 = "
        f"{f'{red:.3g}' if math.isfinite(red) else 'n/a'} "
        f"(chi2 = {float(fit.chi2):.4g}, dof = {int(fit.dof)})"
    ]
    lines += [f"{indent}warning: {w}" for w in fit.warnings]
    if int(fit.n_points) < len(fit.terms):
        lines.append(
            f"{indent}(not fitted: {int(fit.n_points)} usable points for {len(fit.terms)} "
            "terms; use more taus, e.g. --taus all, or fewer --terms)"
        )
    if fit.units and conv is None:
        lines.append(
            f"{indent}(no conventional units for {fit.units!r}: declare deg/s, deg/h, rad/s, "
            "m/s^2 or g to get them)"
        )
    headers = ["term", "value ± 1 sigma (data units)"]
    if conv is not None:
        headers.append("value ± 1 sigma (conventional)")
    if true is not None:
        headers += ["true value", "error"]
    rows = []
    for name in TERM_NAMES:
        letter, long_name = term_label(name, fit.units)
        term = fit.term(name)
        row = [f"{letter}  {long_name}"]
        if name not in fit.terms:
            row += ["not in the model"] * (2 if conv is not None else 1)
        else:
            # a term at 0: its one-sided upper bound at the fit's level, where there is one
            bound = term.uncertainty if not math.isfinite(float(term.upper)) else term.upper
            row.append(format_pm(term.value, term.uncertainty if term.value else bound,
                                 term_unit(name, fit.units)))  # fmt: skip
            if conv is not None:
                c = conv[name]
                bound = c.uncertainty if not math.isfinite(float(c.upper)) else c.upper
                row.append(format_pm(c.value, c.uncertainty if c.value else bound, c.unit))
        if true is not None:
            value, unit = true[name]
            row.append(f"{value:g} {unit}")
            fitted = float(conv[name].value) if conv is not None else float(term.value)
            row.append(f"{100 * (fitted / value - 1):+.1f} %" if value else "")
        rows.append(row)
    lines.append(text_table(headers, rows, indent))
    level = f"{100 * fit.bound_level:.0f} %" if fit.method == "gls" else "1-sigma"
    lines.append(
        f"{indent}(0 (< x): left out by the model selection or pinned at zero, x is its "
        f"one-sided {level} upper bound)"
    )
    if fit.markov is not None:
        mk = fit.markov
        unit = f" {fit.units}" if fit.units else ""
        lo, hi = mk.tau_c_range
        lines.append(
            f"{indent}Gauss-Markov process: sigma = "
            f"{format_pm(mk.sigma, mk.sigma_uncertainty)}{unit}, correlation time "
            f"{mk.tau_c:.3g} s ({lo:.3g}-{hi:.3g} s)"
        )
    if fit.slopes is not None:
        read = []
        for n, v in fit.slopes.values.items():
            if math.isfinite(v):
                unc = fit.slopes.uncertainty[n]
                read.append(f"{TERM_LABELS[n][0]} {format_pm(v, unc, term_unit(n, fit.units))}")
        if read:
            lines.append(f"{indent}slope-line read-offs: " + "; ".join(read))
    return lines


def guard_replacement(out: str, protected: Sequence[Path]) -> None:
    """Refuse to replace a folder that holds the current directory or a protected path."""
    target = Path(out).expanduser().resolve()
    if not target.is_dir():
        return
    for path in (Path.cwd(), *protected):
        resolved = path.resolve()
        if resolved == target or target in resolved.parents:
            raise AdavarInputError(
                f"--out {out} holds {path if path != Path.cwd() else 'the current folder'}; "
                "replacing it would delete that: choose another output folder"
            )


def output_error(out: str | os.PathLike[str], exc: OSError) -> AdavarInputError:
    return AdavarInputError(f"cannot write the output folder {out}: {exc.strerror or exc}")


def safe_name(name: str) -> str:
    """A channel name usable in a file name."""
    cleaned = "".join(c if c.isalnum() or c in "-_." else "_" for c in name).strip("._")
    return cleaned or "channel"


def channel_folders(names: Sequence[str]) -> dict[str, str]:
    """A distinct folder name for every channel (case-insensitively: not every file system
    tells gx from GX), never ``result.json``."""
    folders: dict[str, str] = {}
    used = {"result.json"}
    for name in names:
        base = candidate = safe_name(name)
        k = 2
        while candidate.lower() in used:
            candidate = f"{base}_{k}"
            k += 1
        used.add(candidate.lower())
        folders[name] = candidate
    return folders


class Status:
    """What the command is doing, on one line of stderr, only when stderr is a terminal.

    For steps that cannot report a fraction (reading a file, computing a surface); with
    the elapsed time of the previous step, so a slow step shows itself.
    """

    def __init__(self) -> None:
        self.enabled = sys.stderr.isatty()
        self.start = time.perf_counter()
        self.shown = False

    def __call__(self, what: str) -> None:
        if self.enabled:
            elapsed = time.perf_counter() - self.start
            print(f"\r{what} ... ({elapsed:.1f} s)".ljust(79)[:79], end="", file=sys.stderr,
                  flush=True)  # fmt: skip
            self.shown = True

    def close(self) -> None:
        """Erase the line (the command's output follows on a clean line)."""
        if self.enabled and self.shown:
            print("\r" + " " * 79 + "\r", end="", file=sys.stderr, flush=True)
            self.shown = False


class ProgressBar:
    """A one-line progress bar on stderr, only when stderr is a terminal."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.enabled = sys.stderr.isatty()
        self.start = time.perf_counter()

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled or total <= 0:
            return
        width = 30
        filled = int(width * done / total)
        elapsed = time.perf_counter() - self.start
        bar = "#" * filled + "-" * (width - filled)
        print(f"\r{self.label} [{bar}] {done}/{total} {elapsed:.0f} s", end="",
              file=sys.stderr, flush=True)  # fmt: skip

    def close(self) -> None:
        if self.enabled:
            print("\r" + " " * 79 + "\r", end="", file=sys.stderr, flush=True)


def check_output_file(path: str, force: bool, suffixes: tuple[str, ...]) -> Path:
    """A file the command may write: right suffix, parent exists, not replaced silently."""
    output = Path(path)
    if suffixes and output.suffix.lower() not in suffixes:
        raise UsageError(f"--output {path!r}: name it *{suffixes[0]}")
    if output.is_dir():
        raise UsageError(f"{path} is a folder: give a file name")
    if output.exists() and not force:
        raise UsageError(f"{path} exists: use --force to replace it")
    if not output.parent.exists():
        raise UsageError(f"folder {str(output.parent)!r} does not exist: create it first")
    return output


def one_line(text: str) -> str:
    return " ".join(str(text).split())


def clear_status_line() -> None:
    """Erase a status or progress line a failed command left on the terminal."""
    if sys.stderr.isatty():
        print("\r" + " " * 79 + "\r", end="", file=sys.stderr, flush=True)

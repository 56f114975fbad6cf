"""The validation matrix: adavar's outputs on records generated without adavar's code.

Records come from ``tests/independent_noise.py`` (FFT flicker, AR(1) Gauss-Markov,
Student-t heavy tails, scipy.signal Butterworth filter and rounding, sinusoids, ramps), with
an analytic truth. Two parts:

``fit``: every stationary noise mix at every (record length, rate) cell, ``--seeds``
records each; the whole-record OADEV at octave taus is fitted by the default
``fit_noise`` (and, for comparison in the same run, by the fit before issue 39,
``select="significance", markov="none"``). Printed per cell and term:

* ``mean``: mean estimate / truth (the target: within 5 % for every term that carries most
  of the Allan variance over at least one octave of the fitted taus, marked ``*``),
* ``pull``: the sd of (estimate - truth) / uncertainty over the records where the term is
  in the model (target 0.85-1.2),
* ``drop``: the fraction of records where the term was left out, ``cover``: of those, the
  fraction whose upper bound (95 %) lies above the truth (target >= 84 %),
* ``adequate``: the fraction of records whose fit says the model describes the curve
  (with an unmodelled process, the share that should say it does not: ``markov="none"`` on
  the Gauss-Markov mix, target <= 10 %).

``selection``: the uncertainty of the terms the selection chose, conditional on the choice
and with its doubt in it (``fit_noise(uncertainty=...)``): the pulls of the terms the record
has, and of those it has not, at 1 and 3 hours at 100 Hz.

``windows``: the per-window N and K of ``davar`` + ``fit_noise`` against the truth, on
stationary mixes (white, rate random walk, a filter and rounding) and on a stretch of
doubled noise behind a filter.

``events``: the adaptive window (``adaptive_davar`` defaults, the CLI's) and ICI on
stationary records (false events per hour, heavy tails included) and on records with a
change (step, burst, ramp, spike, long-tau changes): detection rate and start/end errors.

Run: ``python benchmarks/bench_validation.py [--part fit|selection|windows|events|all] [--seeds 40]
[--quick]``. ``--quick`` is the matrix of ``tests/test_validation.py``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _machine import describe  # noqa: E402

import adavar  # noqa: E402
from tests.independent_noise import MIXES, changing, low_pass, record  # noqa: E402

LETTERS = {"N": "angle_random_walk", "B": "bias_instability", "K": "rate_random_walk"}
#: (seconds, rate Hz) cells of the fit matrix: every length at 100 Hz, the extreme rates
#: where the sample count stays below ~1e7
CELLS = [(600, 100.0), (3600, 100.0), (3 * 3600, 100.0), (24 * 3600, 100.0),
         (24 * 3600, 1.0), (600, 1000.0), (3600, 1000.0)]  # fmt: skip
QUICK_CELLS = [(3600, 100.0), (3 * 3600, 100.0)]


OLD_FIT = dict(select="significance", markov="none")  # the fit before issue 39


def fit_cell(mix: str, seconds: float, rate: float, seeds: int, **options) -> dict:
    """Fit ``seeds`` records of one cell with ``options`` and with :data:`OLD_FIT` (the
    same records); per fit and term the statistics described above."""
    rows = {label: {k: [] for k in LETTERS} for label in ("new", "old")}
    adequate = {"new": [], "old": []}
    markov = []
    dominant = None
    for seed in range(seeds):
        x, truth = record(mix, seconds, rate, seed=10_000 + seed)
        r = adavar.deviation(x, rate=rate, taus="octave")
        bw = truth.extras.get("bandwidth_hz")
        for label, opts in (("new", options), ("old", OLD_FIT)):
            fit = adavar.fit_noise(r, bandwidth=bw, **opts)
            if dominant is None:
                dominant = truth.dominant(fit.tau[np.asarray(fit.used, dtype=bool)])
            adequate[label].append(bool(fit.adequate))
            if label == "new":
                markov.append(fit.markov is not None)
            for letter, name in LETTERS.items():
                term = fit.term(name)
                rows[label][letter].append((float(term.value), float(term.uncertainty),
                                            float(term.upper), getattr(truth, letter)))  # fmt: skip
    out = {}
    for label in ("new", "old"):
        cell = {"adequate": float(np.mean(adequate[label])), "markov": float(np.mean(markov)),
                "dominant": dominant}  # fmt: skip
        for letter, values in rows[label].items():
            v = np.array(values)
            true = v[0, 3]
            est, unc, upper = v[:, 0], v[:, 1], v[:, 2]
            dropped = est == 0
            stats = {"true": true, "drop": float(np.mean(dropped))}
            if true > 0:
                stats["mean"] = float(np.mean(est) / true)
                kept = ~dropped & (unc > 0)
                pulls = (est[kept] - true) / unc[kept]
                stats["pull"] = float(np.std(pulls)) if kept.sum() > 2 else math.nan
                # the old fit gave a "1-sigma upper bound" (its uncertainty), the new one
                # its profile bound at bound_level (NoiseTerm.upper)
                bound = upper if label == "new" else unc
                stats["cover"] = (
                    float(np.mean(bound[dropped] > true)) if dropped.any() else math.nan
                )
            else:
                stats["spurious"] = float(np.mean(~dropped))
            cell[letter] = stats
        out[label] = cell
    return out


def print_fit(results: dict, title: str) -> None:
    print(f"\n{title}")
    head = f"{'mix':22s} {'cell':>11s} {'adeq':>5s} {'GM':>5s}  " + "  ".join(
        f"{k + ' mean/pull/drop/cover':>28s}" for k in LETTERS
    )
    print(head)
    for (mix, seconds, rate), cell in results.items():
        parts = []
        for letter in LETTERS:
            s = cell[letter]
            if s["true"] > 0:
                mark = "*" if cell["dominant"].get(letter) else " "
                parts.append(f"{mark}{s['mean']:6.3f} {s['pull']:5.2f} {s['drop']:5.2f} "
                             f"{s['cover']:5.2f}".rjust(28))  # fmt: skip
            else:
                parts.append(f"absent, in model {s['spurious']:4.2f}".rjust(28))
        cell_s = f"{seconds / 3600:g} h {rate:g} Hz"
        print(f"{mix:22s} {cell_s:>11s} {cell['adequate']:5.2f} {cell['markov']:5.2f}  "
              + "  ".join(parts))  # fmt: skip


def run_fit(seeds: int, quick: bool, mixes: list[str] | None = None) -> None:
    cells = QUICK_CELLS if quick else CELLS
    t = time.perf_counter()
    results: dict = {"new": {}, "old": {}}
    for mix in mixes or MIXES:
        for seconds, rate in cells:
            # the 24-hour 100 Hz records (8.6e6 samples) take about 10 s each
            n = seeds if seconds * rate <= 5e6 else min(seeds, 12)
            cell = fit_cell(mix, seconds, rate, n)
            for label in ("new", "old"):
                results[label][(mix, seconds, rate)] = cell[label]
    took = time.perf_counter() - t
    print_fit(results["new"], f"default fit (issue 39): {seeds} records a cell ({took:.0f} s)")
    print_fit(results["old"], "the fit before issue 39 (select='significance', markov='none'), "
                              "same records; cover: its '1-sigma upper bound'")  # fmt: skip
    # an unmodelled process: the Gauss-Markov hump with the Gauss-Markov term switched off
    print("\nadequate with an unmodelled Gauss-Markov process (markov='none'; target <= 0.10):")
    for seconds, rate in cells:
        cell = fit_cell("white+RRW+markov", seconds, rate, seeds, markov="none")
        print(
            f"  {seconds / 3600:g} h {rate:g} Hz: adequate {cell['new']['adequate']:.2f} "
            f"(the fit before issue 39: {cell['old']['adequate']:.2f})"
        )


#: every term the selection judges, by letter
ALL_TERMS = {"Q": "quantization", **LETTERS, "R": "rate_ramp"}
SELECTION_MIXES = ["white", "white+RRW", "white+flicker+RRW", "white+RRW+markov"]


def selection_cell(mix: str, seconds: float, rate: float, seeds: int) -> dict:
    """Per rule (``uncertainty="conditional"``, ``"averaged"``) and term: the pulls
    (estimate - truth) / uncertainty where the term is in the model, split into terms the
    record has and terms it has not (truth 0); and the records warned of a term."""
    pulls = {rule: {"real": {}, "absent": {}} for rule in ("conditional", "averaged")}
    warned = 0
    for seed in range(seeds):
        x, truth = record(mix, seconds, rate, seed=20_000 + seed)
        r = adavar.deviation(x, rate=rate, taus="octave")
        for rule in pulls:
            fit = adavar.fit_noise(r, uncertainty=rule)
            for letter, name in ALL_TERMS.items():
                term = fit.term(name)
                if not term.value > 0:
                    continue
                true = float(getattr(truth, letter))
                kind = "real" if true > 0 else "absent"
                pulls[rule][kind].setdefault(letter, []).append(
                    (float(term.value) - true) / float(term.uncertainty)
                )
            if rule == "averaged":
                warned += any("models without it carry" in w for w in fit.warnings)
    return {"pulls": pulls, "warned": warned / seeds}


def run_selection(seeds: int, quick: bool) -> None:
    """The uncertainty of the terms a model selection chose, given the choice
    (``"conditional"``) and with its doubt in it (``"averaged"``, the default)."""
    cells = QUICK_CELLS[:1] if quick else QUICK_CELLS
    print(f"\nterm uncertainty and the choice of the model: {seeds} records a cell; per "
          "term 'sd' of the pulls where the record has the term (target 0.85-1.2), "
          "'rms (>2 sigma)' where it has not (truth 0)")  # fmt: skip
    for mix in SELECTION_MIXES:
        for seconds, rate in cells:
            cell = selection_cell(mix, seconds, rate, seeds)
            print(f"{mix} {seconds / 3600:g} h {rate:g} Hz: warned of a term in "
                  f"{100 * cell['warned']:.0f} % of the records")  # fmt: skip
            for rule, kinds in cell["pulls"].items():
                parts = []
                for letter in ALL_TERMS:
                    real = np.array(kinds["real"].get(letter, []))
                    absent = np.array(kinds["absent"].get(letter, []))
                    if real.size > 2:
                        parts.append(f"{letter} sd {np.std(real):.2f} (n {real.size})")
                    if absent.size:
                        rms = math.sqrt(float(np.mean(absent**2)))
                        big = int(np.sum(np.abs(absent) > 2))
                        parts.append(f"{letter} absent: rms {rms:.2f} ({big}/{absent.size})")
                print(f"  {rule:11s} " + "; ".join(parts))


#: the stationary mixes of the window part: (label, record() mix)
WINDOW_MIXES = [
    ("white", dict(N=1e-3)),
    ("white + RRW (crossover 5 s)", dict(N=1e-3, K=math.sqrt(3) * 1e-3 / 5)),
    ("filtered + quantised", dict(N=1e-3, bandwidth=0.2, lsb=0.25)),
    ("filtered + quantised + RRW (1 s)", dict(N=1e-3, K=math.sqrt(3) * 1e-3, bandwidth=0.2,
                                              lsb=0.25)),
]  # fmt: skip


def _window_pulls(fit, truth_n, truth_k, keep) -> dict:
    out = {}
    for letter, term, true in (
        ("N", fit.angle_random_walk, truth_n),
        ("K", fit.rate_random_walk, truth_k),
    ):
        if not np.any(true):
            continue
        v, u = np.asarray(term.value)[keep], np.asarray(term.uncertainty)[keep]
        t = np.broadcast_to(true, np.shape(keep))[keep]
        ok = (v > 0) & (u > 0)
        out[letter] = (v / t, ((v - t) / u)[ok], float(np.mean(~ok)))
    return out


def run_windows(seeds: int, quick: bool) -> None:
    """Per-window N and K of ``davar`` + ``fit_noise`` (the commands' defaults) against the
    truth: stationary mixes, and N x2 for 10 minutes behind a filter (inside / outside)."""
    rate, seconds = 100.0, 3600.0
    windows = (300.0,) if quick else (60.0, 300.0)
    print(f"\nwindow fits, {seeds} records of 1 h at 100 Hz a row, a window every 10 s: N and "
          "K mean / truth, pull mean and sd ((estimate - truth) / uncertainty, windows "
          "where the term is in the model; 'zero': share of windows without it)")  # fmt: skip
    rows = []
    for label, mix in WINDOW_MIXES:
        for w in windows:
            acc: dict = {}
            for seed in range(seeds):
                x, truth = record(mix, seconds, rate, seed=30_000 + seed)
                s = adavar.davar(x, rate=rate, window=int(w * rate), step=1000, taus="octave")
                fit = adavar.fit_noise(s)
                keep = np.ones(np.shape(fit.chi2), dtype=bool)
                for k, v in _window_pulls(fit, truth.N, truth.K, keep).items():
                    acc.setdefault(k, []).append(v)
            rows.append((label, w, acc))
    for w in windows:  # a stretch of doubled noise behind a filter
        acc_in: dict = {}
        acc_out: dict = {}
        for seed in range(seeds):
            x, change = changing("step", seconds, rate, 30_000 + seed, N=1e-3, at=1500.0,
                                 length=600.0, factor=2.0)  # fmt: skip
            x = low_pass(x, 0.1 * rate, rate)
            s = adavar.davar(x, rate=rate, window=int(w * rate), step=1000, taus="octave")
            fit = adavar.fit_noise(s)
            c = np.asarray(s.centre) / rate
            inside = (c - w / 2 >= 1500.0) & (c + w / 2 < 2100.0)
            outside = (c + w / 2 < 1500.0) | (c - w / 2 >= 2100.0)
            level = 1e-3 * change.level[np.asarray(s.centre)]
            for where, acc in ((inside, acc_in), (outside, acc_out)):
                for k, v in _window_pulls(fit, level, 0.0, where).items():
                    acc.setdefault(k, []).append(v)
        rows.append(("filtered, N x2 stretch: inside", w, acc_in))
        rows.append(("filtered, N x2 stretch: outside", w, acc_out))
    for label, w, acc in rows:
        parts = []
        for letter, vals in acc.items():
            ratio = np.concatenate([v[0] for v in vals])
            pulls = np.concatenate([v[1] for v in vals])
            zero = np.mean([v[2] for v in vals])
            parts.append(f"{letter} {np.mean(ratio[ratio > 0]):.3f} pull {np.mean(pulls):+.2f} "
                         f"sd {np.std(pulls):.2f} zero {zero:.2f}")  # fmt: skip
        print(f"  {label:36s} {w:4.0f} s  " + " | ".join(parts))


#: (kind, seconds, rate): the records with a change, and the stationary ones
CHANGES = [("step", 3600, 100.0), ("burst", 3600, 100.0), ("ramp", 3600, 100.0),
           ("spike", 3600, 100.0), ("step", 6000, 1.0), ("rrw", 6 * 3600, 10.0),
           ("flicker", 6 * 3600, 10.0)]  # fmt: skip
STATIONARY = [("white", 3600, 100.0, None), ("white", 3600, 100.0, 5.0),
              ("white", 6 * 3600, 1.0, None), ("white", 6 * 3600, 1.0, 5.0),
              ("filtered+quantised", 3600, 100.0, None)]  # fmt: skip
QUICK_CHANGES = [("step", 3600, 100.0), ("spike", 3600, 100.0)]
QUICK_STATIONARY = [("white", 3600, 100.0, 5.0)]


def events_of(x: np.ndarray, rate: float, method: str) -> tuple[list, float]:
    """The events of the library defaults (``adavar adaptive``'s), and Lmin in seconds."""
    res = adavar.adaptive_davar(x, rate=rate, method=method)
    fit = adavar.fit_noise(res, terms=("angle_random_walk",), cells=False)
    return res.events_with(fit), float(res.parameters["lmin"]) / rate


def found(events: list, start: float, end: float | None, tol: float, ramp: bool) -> bool:
    """Whether one event starts within ``tol`` of ``start`` and (if given) ends within
    ``tol`` of ``end``; a ramp may end anywhere after its start."""
    for e in events:
        if abs(e.start_s - start) > tol:
            continue
        if ramp or end is None:
            return True
        if e.end_s is not None and abs(e.end_s - end) <= tol:
            return True
    return False


def run_events(seeds: int, quick: bool) -> None:
    from tests.independent_noise import changing, white

    print("\nfalse events per stationary hour (library defaults; target <= 0.1):")
    for mix, seconds, rate, dof in QUICK_STATIONARY if quick else STATIONARY:
        for method in ("adaptive", "ici"):
            count = 0
            for seed in range(seeds):
                rng = np.random.default_rng(20_000 + seed)
                if dof is None and mix != "white":
                    x, _ = record(mix, seconds, rate, rng)
                else:
                    x = white(int(seconds * rate), 1e-3, rate, rng, dof=dof)
                count += len(events_of(x, rate, method)[0])
            label = f"{mix}{' t' + str(int(dof)) if dof else ''}"
            print(
                f"  {label:22s} {seconds / 3600:g} h {rate:g} Hz {method:8s} "
                f"{count / (seeds * seconds / 3600):.3f} /h ({count} in {seeds} records)"
            )
    print("\nchanges found, start and end within Lmin/2 (target >= 90 % of seeds):")
    for kind, seconds, rate in QUICK_CHANGES if quick else CHANGES:
        for method in ("adaptive", "ici"):
            hits = extra = 0
            errors = []
            for seed in range(seeds):
                x, truth = changing(kind, seconds, rate, 30_000 + seed)
                events, lmin = events_of(x, rate, method)
                tol = lmin / 2
                if kind == "spike":  # nothing but (at most) one short event near it
                    at = seconds / 2
                    ok = all(abs(e.start_s - at) < lmin and e.end_s is not None
                             and e.end_s - e.start_s < 2 * lmin for e in events)  # fmt: skip
                    hits += ok
                    continue
                start, end = truth.changes[0]
                hit = found(events, start, end, tol, truth.ramp)
                hits += hit
                extra += max(0, len(events) - 1)
                near = [e for e in events if abs(e.start_s - start) < 4 * tol]
                if near:
                    errors.append(near[0].start_s - start)
            err = f", start error median {np.median(np.abs(errors)):.0f} s" if errors else ""
            print(
                f"  {kind:8s} {seconds / 3600:g} h {rate:g} Hz {method:8s} "
                f"{hits}/{seeds} found, {extra} other events{err}"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("fit", "selection", "windows", "events", "all"),
                        default="all")  # fmt: skip
    parser.add_argument("--seeds", type=int, default=40)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--mixes", nargs="*", choices=list(MIXES), help="the fit's mixes (all)")
    args = parser.parse_args()
    print(describe())
    if args.part in ("fit", "all"):
        run_fit(args.seeds, args.quick, args.mixes)
    if args.part in ("selection", "all"):
        run_selection(args.seeds, args.quick)
    if args.part in ("windows", "all"):
        run_windows(args.seeds, args.quick)
    if args.part in ("events", "all"):
        run_events(args.seeds, args.quick)


if __name__ == "__main__":
    main()

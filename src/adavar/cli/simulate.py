"""``adavar simulate``: a simulated record as CSV."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from adavar import __version__
from adavar.cli.options import EXIT_OK, Given, UsageError, given_flags
from adavar.cli.output import Status, check_output_file, output_error
from adavar.cli.values import finite_float, number_tuple, parse_seed, positive_float, positive_int
from adavar.core.atomic import atomic_file
from adavar.core.errors import AdavarInputError
from adavar.core.settings import MAX_SAMPLES
from adavar.io.writers import dumps

#: Bytes of memory per sample of ``adavar simulate`` (the generators' arrays; the CSV text
#: is written :data:`CSV_ROWS` rows at a time), for the check of --n.
BYTES_PER_SAMPLE = 256
#: Rows of the CSV formatted at a time.
CSV_ROWS = 1 << 16
#: The options of a simulated sensor's record that ``--scenario`` (the paper's record, 6000
#: samples at 1 Hz) has no use for: refused with it rather than dropped.
SENSOR_SHAPE = ("n", "rate", "bandwidth", "filter_order", "lsb")
#: The flag of each noise coefficient, for the messages.
TERM_FLAGS = {"quantization": "--quantization", "angle_random_walk": "--arw",
              "bias_instability": "--bias-instability", "rate_random_walk": "--rrw",
              "rate_ramp": "--rate-ramp"}  # fmt: skip


def _check_memory(n: int) -> None:
    """A one-line error, before any work, when --n samples would not fit in memory."""
    from adavar.io.sources import available_memory

    need = n * BYTES_PER_SAMPLE
    free = available_memory()
    most = MAX_SAMPLES if free is None else min(MAX_SAMPLES, int(0.8 * free) // BYTES_PER_SAMPLE)
    most = max(1, most)
    if n > most:
        room = "" if free is None else f"; {free / 2**30:.1f} GiB of memory is free"
        raise UsageError(
            f"--n {n} samples need about {need / 2**30:.1f} GiB to simulate and write as CSV"
            f"{room}: give --n {most} or fewer"
        )


def _check_finite(x: np.ndarray, what: str) -> None:
    """A one-line error, before anything is written, when the samples overflow float64
    (``--arw 1e308`` wrote rows of inf with exit 0)."""
    with np.errstate(invalid="ignore", over="ignore"):
        bad = int(x.size - np.count_nonzero(np.isfinite(x)))
    if bad:
        raise UsageError(
            f"{bad} of the {x.size} simulated samples overflow float64 (beyond "
            f"{np.finfo(np.float64).max:.3g}) with {what}: give smaller coefficients"
        )


def _cmd_simulate(args: argparse.Namespace) -> int:
    from adavar.paper.scenarios import paper_scenario
    from adavar.simulation.generators import sensor

    output = check_output_file(args.output, args.force, (".csv",))
    status = Status()
    terms = {"quantization": args.quantization, "angle_random_walk": args.arw,
             "bias_instability": args.bias_instability,
             "rate_random_walk": args.rrw, "rate_ramp": args.rate_ramp}  # fmt: skip
    if args.scenario is not None:
        if any(terms.values()) or args.bias or args.markov or args.sinusoid:
            raise UsageError(
                "--scenario simulates the paper's record; the sensor terms (--arw, --bias, "
                "--markov, ...) describe another one: drop them or --scenario"
            )
        # the paper's record has its own length and rate (paper_scenario takes neither)
        shape = [flag for dest, flag in given_flags(args).items() if dest in SENSOR_SHAPE]
        if shape:
            verb = "are" if len(shape) > 1 else "is"
            raise UsageError(
                f"{' and '.join(shape)} {verb} not used with --scenario (the paper's record: "
                f"6000 samples at 1 Hz): drop {' and '.join(shape)}, or --scenario"
            )
        status(f"simulating scenario {args.scenario}")
        sc = paper_scenario(args.scenario, seed=args.seed, variance_reading=args.variance_reading)
        x, rate, what = np.asarray(sc.data), float(sc.rate), sc.description
    else:
        if args.variance_reading:
            raise UsageError("--variance-reading chooses a --scenario's disturbance")
        negative = [(TERM_FLAGS[k], v) for k, v in terms.items() if v < 0]
        if negative:  # before the check of none given: --arw -1 gives no positive one
            flag, value = negative[0]
            raise UsageError(
                f"{flag} {value:g}: noise coefficients must not be negative (a coefficient "
                "is the size of a noise term): give 0 or more"
            )
        if not any(v > 0 for v in terms.values()) and not (args.markov or args.sinusoid):
            raise UsageError(
                "give at least one noise coefficient (--arw, --bias-instability, --rrw, "
                "--quantization, --rate-ramp, --markov, --sinusoid) or --scenario 1|2"
            )
        _check_memory(args.n)
        status(f"simulating {args.n} samples")
        try:  # an overflow is the one-line error of _check_finite, not numpy's warning
            with np.errstate(over="ignore", invalid="ignore"):
                x = sensor(args.n, rate=args.rate, seed=args.seed, bias=args.bias,
                                    markov=args.markov, sinusoid=args.sinusoid,
                                    bandwidth=args.bandwidth, filter_order=args.filter_order,
                                    lsb=args.lsb, **terms)  # fmt: skip
        except ValueError as exc:  # e.g. a sinusoid above the Nyquist frequency
            raise AdavarInputError(str(exc)) from None
        rate = float(args.rate)
        what = ", ".join(f"{k}={v:g}" for k, v in terms.items() if v > 0)
        for name, value in (("markov", args.markov), ("sinusoid", args.sinusoid)):
            if value:
                what += f"{', ' if what else ''}{name}={','.join(f'{v:g}' for v in value)}"
        for name, one in (("bandwidth", args.bandwidth), ("lsb", args.lsb)):
            if one is not None:
                what += f", {name}={one:g}"
        _check_finite(x, what + (f", bias={args.bias:g}" if args.bias else ""))
    status(f"writing {output}")
    header = (f"# adavar {__version__} simulate, seed {args.seed}: {what}; "
              f"rate {rate:g} Hz, samples in {args.units}\ntime,x\n")  # fmt: skip
    try:
        with atomic_file(output) as handle:
            handle.write(header.encode("utf-8"))
            for start in range(0, x.size, CSV_ROWS):  # the text a block of rows at a time
                part = x[start : start + CSV_ROWS]
                t = np.arange(start, start + part.size) / rate
                rows = zip(t.tolist(), part.tolist(), strict=True)
                handle.write("".join(f"{ti!r},{xi!r}\n" for ti, xi in rows).encode("utf-8"))
    except OSError as exc:
        raise output_error(args.output, exc) from None
    status.close()
    if args.json:
        print(
            dumps(
                {
                    "output": str(output),
                    "n_samples": int(x.size),
                    "rate": rate,
                    "units": args.units,
                    "seed": args.seed,
                    "what": what,
                }
            )
        )
    else:
        print(f"wrote {output}: {x.size} samples at {rate:g} Hz ({what})")
    return EXIT_OK


def add_simulate_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``adavar simulate`` to the sub-command parsers ``sub``."""
    sim = sub.add_parser(
        "simulate",
        help="write a simulated record (a noisy sensor or the paper's scenarios) to CSV",
        description="Simulate rate samples with known noise terms (seeded), or the A-DAVAR "
        "paper's scenario 1 or 2, and write them as a CSV with a time column, ready for the "
        "other commands.",
    )
    sim.add_argument(
        "-o",
        "--output",
        metavar="FILE.csv",
        required=True,
        help="the CSV to write (atomically; existing needs --force)",
    )
    sim.add_argument(
        "--scenario",
        type=int,
        choices=(1, 2),
        help="the paper's scenario 1 or 2 (6000 s at 1 Hz, unit white noise)",
    )
    sim.add_argument(
        "--n",
        action=Given,
        type=positive_int,
        default=100_000,
        metavar="N",
        help="number of samples of a simulated sensor (default: 100000; at most what "
        f"fits in the free memory at {BYTES_PER_SAMPLE} bytes a sample, and {MAX_SAMPLES:,})",
    )
    sim.add_argument(
        "--rate",
        action=Given,
        type=positive_float("Hz"),
        default=100.0,
        metavar="HZ",
        help="sample rate of a simulated sensor (default: 100)",
    )
    for flag, name in (("--quantization", "Q, unit*s"), ("--arw", "N, unit*sqrt(s)"),
                       ("--bias-instability", "B, unit"), ("--rrw", "K, unit/sqrt(s)"),
                       ("--rate-ramp", "R, unit/s")):  # fmt: skip
        sim.add_argument(
            flag,
            type=finite_float,
            default=0.0,
            metavar="VALUE",
            help=f"coefficient {name} (default: 0)",
        )
    sim.add_argument(
        "--bias",
        type=finite_float,
        default=0.0,
        metavar="VALUE",
        help="constant bias added to every sample (default: 0)",
    )
    sim.add_argument("--markov", type=number_tuple("--markov", 2, 2), metavar="STD,TAU",
                     help="first-order Gauss-Markov term: standard deviation (unit) and "
                     "correlation time (s)")  # fmt: skip
    sim.add_argument("--sinusoid", type=number_tuple("--sinusoid", 2, 3),
                     metavar="AMP,HZ[,PHASE]",
                     help="deterministic sinusoid: amplitude (unit), frequency (Hz) and "
                     "phase (rad, default 0)")  # fmt: skip
    sim.add_argument("--bandwidth", action=Given, type=positive_float("Hz"), metavar="HZ",
                     help="the sensor's low-pass filter: -3 dB bandwidth in Hz, below "
                     "rate/2 (default: none)")  # fmt: skip
    sim.add_argument("--filter-order", action=Given, type=positive_int, default=2, metavar="N",
                     help="order of that Butterworth filter (default: 2)")  # fmt: skip
    sim.add_argument("--lsb", action=Given, type=positive_float("units"), metavar="STEP",
                     help="quantise the output to this step (the sensor's LSB, in the "
                     "unit; default: none)")  # fmt: skip
    sim.add_argument("--variance-reading", action="store_true",
                     help="--scenario disturbance of variance 3 (the paper's text read "
                     "literally) instead of standard deviation 3")  # fmt: skip
    sim.add_argument(
        "--units",
        default="deg/s",
        metavar="UNIT",
        help="unit written in the header (default: deg/s)",
    )
    sim.add_argument(
        "--seed", type=parse_seed, default=2018, metavar="N", help="seed (default: 2018)"
    )
    sim.add_argument("--json", action="store_true", help="print one JSON object")
    sim.add_argument("--force", action="store_true", help="replace an existing --output")
    sim.add_argument(
        "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
    )
    sim.set_defaults(handler=_cmd_simulate)
    return sim

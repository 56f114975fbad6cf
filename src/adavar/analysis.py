"""The analysis of one file: the pipeline behind ``adavar avar``, ``davar``, ``adaptive``,
``report`` and ``batch``.

load (:func:`load_input`: read the record, its rate and unit, preprocess it) ->
analyse (:func:`analyse_channel`: deviation and noise fit, the DAVAR surface and the
coefficients over time). The options are any object with the commands' option names as
attributes (an ``argparse.Namespace`` from the command line, or the options of
:func:`adavar.batch.run_batch`); :func:`fit_keywords`, :func:`controller_settings` and
:func:`chunk_keywords` turn them into the library functions' keywords, in one place.
Problems with the input raise :class:`adavar.errors.AdavarInputError`; nothing is printed.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np

from adavar import stream
from adavar.adaptive import adaptive_davar
from adavar.davar import davar
from adavar.errors import AdavarInputError
from adavar.noise_model import TERM_NAMES, fit_noise
from adavar.settings import ControllerSettings
from adavar.statistics import deviation

__all__ = [
    "analyse_channel",
    "chunk_keywords",
    "controller_settings",
    "fit_keywords",
    "load_input",
]


def load_input(
    args: Any,
    *,
    several: bool = False,
    pieces: bool | None = None,
    out_of_core: bool = False,
) -> tuple[Any, dict[str, Any], Any, float]:
    """Read FILE's column, preprocess it, and settle its unit and tau0 (seconds).

    With ``out_of_core`` (commands whose analysis streams: avar, davar, adaptive), a
    memory-mapped ``.npy`` column or a lazy HDF5/Parquet channel is passed on as it is,
    so a record larger than memory is read piece by piece; preprocessing loads it.

    With ``several``, every selected channel (``--column gx,gy,gz``, or all numeric
    columns) is returned: a dict name -> samples, and a dict name -> unit. With
    ``pieces`` (default: ``several``), ``--gaps split`` gives each gap-free piece of a
    channel as a channel of its own.

    The rate comes from --rate/--tau0 or from the file's time stamps (both: they must
    agree); the unit from --units or from the format (ROS bags declare rad/s and m/s^2).
    """
    from adavar.preprocess import preprocess
    from adavar.readers import read_record

    if args.rate is not None and args.tau0 is not None:
        raise AdavarInputError("give exactly one of --rate HZ or --tau0 SECONDS (both given)")
    declared = args.rate if args.rate is not None else (
        1.0 / args.tau0 if args.tau0 is not None else None
    )  # fmt: skip
    option = partial(getattr, args)
    record = read_record(
        args.file, columns=args.column, rate=declared,
        time_column=option("time_column", None), time_format=option("time_format", "auto"),
        gaps=option("gaps", "error"), nan=option("nan", "error"),
        dataset=option("dataset", None), topic=option("topic", None),
        gap_tolerance=option("gap_tolerance", 0.5), lazy=option("lazy", None),
    )  # fmt: skip
    if len(record.names) != 1 and not several:
        raise AdavarInputError(
            f"{args.file} has {len(record.names)} channels ({', '.join(record.names)}): "
            "choose one with --column"
            + ("" if getattr(args, "command", None) == "compare"
               else " (or several, comma-separated, e.g. --column a,b)")
        )  # fmt: skip
    declared_units = record.meta.get("units") or {}
    given = args.units.strip() if args.units and args.units.strip() else None
    units_of = {name: given or declared_units.get(name) for name in record.names}
    if not all(units_of.values()):
        raise AdavarInputError(
            "declare the unit of the samples with --units (e.g. --units deg/s); adavar never "
            "guesses units"
        )
    rate = float(record.rate)
    steps: list[dict[str, Any]] = []
    channels: dict[str, np.ndarray] = {}
    split = record.segments is not None and len(record.segments) > 1
    if split and not (several if pieces is None else pieces):
        raise AdavarInputError(
            f"{args.file} has {len(record.segments)} gap-free pieces: --gaps split is for "
            "adavar avar; here use --gaps interpolate, or give a file with one piece"
        )
    for name in record.names:
        pieces = record.pieces(name) if split else [record.channel(name)]
        for k, piece in enumerate(pieces):
            preprocessing = bool(getattr(args, "preprocess", None))
            if out_of_core and not preprocessing and stream.is_chunked(piece):
                x = piece
            else:
                x = np.asarray(piece, dtype=np.float64)
            if preprocessing:
                x, new_rate, steps = preprocess(x, rate=float(record.rate),
                                                steps=args.preprocess)  # fmt: skip
                rate = float(new_rate)
            key = f"{name} piece {k + 1}" if split else name
            channels[key] = x
            units_of[key] = units_of[name]
    name = next(iter(channels))
    samples = channels[name]
    units = units_of[name]
    if args.tau0 is not None and not steps:
        tau0 = float(args.tau0)
    else:
        tau0 = 1.0 / rate
    if args.rate is not None and not steps:
        args_rate = float(args.rate)
    else:
        args_rate = rate
    args.rate, args.tau0 = (args_rate, None) if args.tau0 is None or steps else (None, tau0)
    meta = {
        "path": str(args.file), "column": name, "kind": record.kind,
        "rate_from": "declared" if declared is not None else "time stamps",
        "reader": record.meta, "preprocessing": steps, "columns": list(record.names),
        "pieces": None if not split else [
            [float(record.time[sl.start]), float(record.time[sl.stop - 1])]
            for sl in record.segments
        ],
    }  # fmt: skip
    if several:
        return channels, meta, units_of, tau0
    return samples, meta, units, tau0


def analyse_channel(
    args: Any, samples: np.ndarray, units: str, tau0: float, status: Callable[[str], None],
    tag: str = "",
) -> dict[str, Any]:  # fmt: skip
    """The analysis of one channel that ``adavar report`` shows and ``adavar batch`` writes.

    The deviation at the chosen taus, its noise fit, and (with ``window`` or ``adaptive``)
    the DAVAR surface and the fit of every window. ``status`` receives one line per step.
    """
    from adavar.plots import rate_unit

    rate_u = rate_unit(units, args.data_type)
    rate_kw = dict(
        rate=args.rate if args.rate is not None else 1.0,
        tau0=None if args.rate is not None else tau0,
    )  # fmt: skip
    status(f"{tag}deviation and noise fit of {samples.size} samples")
    result = deviation(samples, data_type=args.data_type, units=rate_u, **rate_kw)
    try:
        fit = fit_noise(result, **fit_keywords(args))
    except ValueError as exc:
        raise AdavarInputError(str(exc)) from None
    surface = adaptive = coefficients = None
    common = dict(data_type=args.data_type, taus=args.taus, step=args.step, units=rate_u,
                  **rate_kw)  # fmt: skip
    if args.adaptive:
        status(f"{tag}adaptive DAVAR surface")
        adaptive = adaptive_davar(samples, **controller_settings(args), **common)
        surface = adaptive
    elif args.window is not None:
        status(f"{tag}DAVAR surface")
        surface = davar(samples, window=args.window, **common)
    if surface is not None:
        status(f"{tag}noise coefficients of every window")
        try:
            coefficients = fit_noise(surface, **fit_keywords(args))
        except ValueError as exc:
            raise AdavarInputError(str(exc)) from None
    return {
        "result": result, "fit": fit, "surface": surface, "adaptive": adaptive,
        "coefficients": coefficients, "units": units, "rate_units": rate_u,
        "samples": samples.size,
    }  # fmt: skip


def controller_settings(args: Any) -> dict[str, Any]:
    """The controller keywords of :func:`adavar.adaptive_davar` from the options."""
    return ControllerSettings.from_options(args).keywords()


def fit_keywords(args: Any) -> dict[str, Any]:
    """The keywords of :func:`adavar.fit_noise` from the options."""
    return dict(terms=args.terms or TERM_NAMES, n_reweight=args.n_reweight,
                spacing=args.spacing, method=args.fit_method, select=args.select,
                significance=args.significance, exclude=args.exclude, rolloff=args.rolloff,
                tau_range=args.tau_range, bandwidth=args.bandwidth)  # fmt: skip


def chunk_keywords(args: Any) -> dict[str, Any]:
    """``chunk_size`` for the library, only when --chunk-size is given."""
    size = getattr(args, "chunk_size", None)
    return {} if size is None else {"chunk_size": size}

"""The adaptive window's defaults: windows from the record, the surface's resolution, and
the staged estimate of the record's correlation behind the hourly thresholds.

One rule for each, used by :func:`adavar.adaptive_davar`, :class:`adavar.OnlineAdaptive`
and the command line (``adaptive``, ``report``, ``batch``, ``monitor``; the constants are in
:mod:`adavar.core.settings`):

* :func:`record_windows`: Lmax a tenth of the record, Lmin two thirds and l a sixth of it
  (the paper's 600, 400 and 100 of its 6000-sample record); a stream, whose length is not
  known, :data:`adavar.core.settings.STREAM_LMAX_SECONDS` (:func:`resolve_windows`);
* :func:`surface_resolution`: ``taus="all"`` up to 200 taus, else ``"log"``, and every
  centre while the surface fits 200 MB;
* :func:`dependence_stages`: the record's short-range correlation (which sets the hourly
  thresholds) is measured on the first samples and refined as the record goes on, each
  estimate governing only the centres whose rows are due after it, so that the live pass
  can start within minutes and still equal the offline one.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from adavar.core.durations import Length, seconds, to_samples
from adavar.core.errors import AdavarInputError
from adavar.core.settings import (
    DEFAULT_MAX_MEMORY_MB,
    DEPENDENCE_FIRST,
    MAX_ALL_TAUS,
    STREAM_LMAX_SECONDS,
)
from adavar.dynamic.controller import REANCHOR, Controller, check_whole, make_controller, needs_head
from adavar.dynamic.thresholds import DEPENDENCE_SAMPLES

__all__ = [
    "CELL_BYTES",
    "COMPARISON_CENTRE_BYTES",
    "STREAM_BYTES_PER_LMAX",
    "check_stream_memory",
    "comparison_step",
    "dependence_stages",
    "record_windows",
    "resolve_windows",
    "stage_controller",
    "stage_parameters",
    "staged_controllers",
    "surface_resolution",
]


#: Peak bytes a stream's pass holds per sample of ``lmax``: the samples it keeps and the
#: controller's thresholds for every window length, 217 B measured at ``lmax = 2e6`` (the
#: calibrated thresholds being computed when the head has arrived)
STREAM_BYTES_PER_LMAX = 224


def check_stream_memory(lmax: int, dt: float) -> None:
    """A one-line error, before any work, when a window of ``lmax`` samples would not fit
    in the free memory (a stream has no length to bound it by)."""
    from adavar.io.sources import available_memory

    free = available_memory()
    if free is None:  # pragma: no cover - not Linux
        return
    most = max(1, int(0.8 * free) // STREAM_BYTES_PER_LMAX)
    if lmax > most:
        raise AdavarInputError(
            f"lmax (--lmax) of {lmax} samples ({lmax * dt:.3g} s) needs about "
            f"{lmax * STREAM_BYTES_PER_LMAX / 2**30:.3g} GiB for the samples and thresholds of its "
            f"windows, but {free / 2**30:.1f} GiB of memory is free: give an lmax of {most} "
            f"samples ({most * dt:.3g} s) or fewer"
        )


def record_windows(n_samples: int, lmax: int | None = None) -> tuple[int, int, int]:
    """Lmax, Lmin and l in the paper's proportions (600, 400, 100 of a 6000-sample record).

    ``Lmax`` is a tenth of the record (even; at least 12 samples), ``Lmin = Lmax - 2
    round(Lmax / 6)`` (two thirds of it, of the same parity) and ``l = round(Lmax / 6)``.
    Given ``lmax``, only Lmin and l are derived from it.

    Parameters
    ----------
    n_samples : int
        Length of the record (samples).
    lmax : int, optional
        The longest window, if chosen.

    Returns
    -------
    lmax, lmin, l : int
    """
    if lmax is None:
        lmax = max(12, 2 * round(int(n_samples) / 20))
    sixth = max(1, round(lmax / 6))
    return int(lmax), int(lmax - 2 * sixth), int(sixth)


def resolve_windows(
    n_samples: int | None,
    dt: float,
    lmax: Length | None,
    lmin: Length | None,
    l: Length | None,  # noqa: E741 - the paper's name
) -> tuple[int, Length, Length]:
    """Lmax, Lmin and l as given, or chosen for the record (the defaults everywhere).

    ``lmax`` None: a tenth of the ``n_samples``-sample record (:func:`record_windows`), or
    for a stream (``n_samples`` None) :data:`adavar.core.settings.STREAM_LMAX_SECONDS` seconds
    (at least 12 samples). ``lmin`` and ``l`` None: two thirds and a sixth of Lmax. A given
    value is returned as given (a duration is converted by :func:`window_lengths`).
    """
    if lmax is None:
        if n_samples is None:
            stream_lmax = to_samples(seconds(STREAM_LMAX_SECONDS), dt, "lmax")
            big = max(12, int(stream_lmax))
        else:
            big = record_windows(int(n_samples))[0]
    else:
        big = check_whole("lmax", to_samples(lmax, dt, "lmax"), 5)
    _, small, seg = record_windows(0, big)
    return big, small if lmin is None else lmin, seg if l is None else l


def surface_resolution(
    longest: int,
    n_samples: int,
    tau0: float,
    *,
    taus: Any = None,
    step: Any = None,
    points_per_decade: int = 10,
    max_memory: float = DEFAULT_MAX_MEMORY_MB,
    channels: int = 1,
) -> tuple[Any, Any, list[str]]:
    """Taus and centres of a surface left to adavar (``taus`` / ``step`` None).

    ``taus``: ``"all"`` (the paper's) while that is at most
    :data:`~adavar.core.settings.MAX_ALL_TAUS` averaging times (a third of the ``longest``
    window), else ``"log"`` (10 per decade). ``step``: every centre while the surfaces of
    ``channels`` channels fit ``max_memory`` MB together at :data:`CELL_BYTES` a cell, else
    every ``step``-th. The same rule for :func:`adaptive_davar` and ``adavar adaptive`` /
    ``davar`` (:func:`adavar.pipeline.analysis.resolve_resolution`).

    Returns
    -------
    taus, step
        As given, or chosen.
    why : list of str
        What was chosen and why, for the command line's note (empty when nothing was).
    """
    from adavar.core.taus import averaging_factors

    why = []
    if taus is None:
        taus = "all" if int(longest) // 3 <= MAX_ALL_TAUS else "log"
        if taus == "log":
            why.append(f"taus log (10 per decade) instead of all {int(longest) // 3}")
    if step is None:
        ms, _ = averaging_factors(taus, max(1, int(longest) // 3), tau0,
                                  points_per_decade=points_per_decade)  # fmt: skip
        budget = float(max_memory) * 2**20 / max(1, int(channels))
        step = max(1, math.ceil(int(n_samples) * ms.size * CELL_BYTES / budget))
        if step > 1:
            why.append(f"one centre in {step} ({math.ceil(n_samples / step)} windows)")
    return taus, step, why


#: Bytes per surface cell a command holds: the variance, its two bounds and the fit's arrays.
CELL_BYTES = 8 * 4

#: Bytes a comparison (:func:`adavar.compare`) holds per computed centre: the centres'
#: times and indices, and per method its N(t), window lengths and the controller's record
#: (kurtosis, S, flags; measured 150 bytes a centre for four methods, two of them adaptive)
COMPARISON_CENTRE_BYTES = (16, 48)


def comparison_step(
    n_samples: int, n_methods: int, step: int | None = None,
    max_memory: float = DEFAULT_MAX_MEMORY_MB,
) -> tuple[int, list[str]]:  # fmt: skip
    """The centres of a comparison left to adavar (``step`` None), and why.

    Every centre (the paper's) while the per-centre series of the ``n_methods`` methods
    fit ``max_memory`` MB at :data:`COMPARISON_CENTRE_BYTES`, else every ``step``-th: the
    series of a long record stay within the budget instead of growing with it. Returns
    ``(step, why)``, ``why`` empty when nothing was chosen.
    """
    if step is not None:
        return int(step), []
    shared, per_method = COMPARISON_CENTRE_BYTES
    need = int(n_samples) * (shared + per_method * max(1, int(n_methods)))
    chosen = max(1, math.ceil(need / (float(max_memory) * 2**20)))
    if chosen == 1:
        return 1, []
    return chosen, [f"one centre in {chosen} ({math.ceil(n_samples / chosen)} windows)"]


def dependence_stages(n_samples: int | None, lmax: int) -> list[tuple[int, int]]:
    """Where each estimate of the record's short-range correlation takes over.

    Hourly thresholds depend on the record's correlation ``(c2, c4)``
    (:func:`adavar.dynamic.thresholds.noise_dependence`). It is estimated on the first ``H0 =
    max(DEPENDENCE_FIRST, lmax // 2 + 1)`` samples (:data:`adavar.core.settings.DEPENDENCE_FIRST`,
    8192) and re-estimated on the first ``2 H0``, ``4 H0``, ... samples up to
    :data:`~adavar.dynamic.thresholds.DEPENDENCE_SAMPLES` (2**20). The estimate on ``H`` samples
    governs the centres from the first multiple of
    :data:`~adavar.dynamic.controller.REANCHOR` at or after ``H - lmax // 2``: a centre's row never
    depends on a sample that arrives after it is due (sample ``centre + lmax // 2``), so
    :class:`adavar.OnlineAdaptive` starts after ``H0`` samples, never revises a row or an
    event it has emitted, and gives the offline windows bit for bit. Each stage starts
    from the length the previous one ended with, as the out-of-core pass does.

    Parameters
    ----------
    n_samples : int or None
        Length of the record; None: a stream (every stage planned).
    lmax : int
        Longest window, samples.

    Returns
    -------
    list of (int, int)
        ``(first centre, samples estimated on)`` of each stage, the first at centre 0 (on
        ``min(n_samples, H0)`` samples); stages whose ``H`` exceeds the record are left out.
    """
    first = max(DEPENDENCE_FIRST, int(lmax) // 2 + 1)
    stages = [(0, first if n_samples is None else min(first, int(n_samples)))]
    head = first
    while head < DEPENDENCE_SAMPLES:
        head = min(2 * head, DEPENDENCE_SAMPLES)
        if n_samples is not None and head > n_samples:
            break
        stages.append((-(-(head - int(lmax) // 2) // REANCHOR) * REANCHOR, head))
    return stages


def stage_controller(
    settings: dict[str, Any],
    head: np.ndarray | None = None,
    dependence: Sequence[float] | None = None,
) -> Controller:
    """The controller of one stage (:func:`dependence_stages`): hourly thresholds for the
    correlation measured on ``head`` (the first samples, at unit scale) or for the
    ``dependence`` given; other thresholds need neither."""
    # make_controller: the one place the head's correlation and kurtosis reference are set
    return make_controller(**settings, head=None if head is None else lambda _size: head,
                           dependence=dependence)  # fmt: skip


def staged_controllers(
    settings: dict[str, Any],
    head: Callable[[int], np.ndarray],
    n_samples: int,
    lmax: int,
    dependence: Sequence[float] | None,
) -> list[tuple[int, Controller]]:
    """``(first centre, controller)`` of every stage of the record (one without hourly
    thresholds or with ``dependence`` given)."""
    if not needs_head(settings["thresholds"], settings["false_alarm_per_hour"],
                      settings.get("kurtosis_reference", "gaussian"), dependence):  # fmt: skip
        return [(0, stage_controller(settings, dependence=dependence))]
    return [(centre, stage_controller(settings, head(size), dependence))
            for centre, size in dependence_stages(n_samples, lmax)]  # fmt: skip


def stage_parameters(
    stages: list[tuple[int, Controller]], given: Any, n_samples: int, lmax: int
) -> list[list[float]] | None:
    """``parameters["dependence_stages"]``: ``[first centre, samples, c2, c4]`` of each
    measured stage; None when no correlation was measured."""
    if given is not None or stages[-1][1].dependence is None:
        return None
    sizes = dict(dependence_stages(n_samples, lmax))
    return [[int(c), int(sizes[c]), *map(float, ctl.dependence or ())] for c, ctl in stages]

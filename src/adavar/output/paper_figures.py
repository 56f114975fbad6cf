"""The A-DAVAR paper's figures and the controller's (:func:`adavar.compare`, ``adavar
adaptive``): the kurtosis of windows (Fig. 6), the contribution coefficient (Fig. 7), the
threshold study (Fig. 8), the controller's record (Fig. 10) and N(t) of every method
(Fig. 12). :mod:`adavar.output.plots` exports them with the other figures; like them, each builds a
:class:`matplotlib.figure.Figure` with an Agg canvas and touches no pyplot state.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from adavar.core.units import term_unit
from adavar.output._figures import envelope, new_figure, run_ends

if TYPE_CHECKING:  # matplotlib is imported when a figure is made (fast CLI start-up)
    from matplotlib.figure import Figure

    from adavar.comparison import Comparison
    from adavar.dynamic.schedule import Schedule
    from adavar.paper.studies import KurtosisStudy, ThresholdStudy

__all__ = [
    "arw_comparison_figure",
    "contribution_figure",
    "controller_figure",
    "kurtosis_windows_figure",
    "threshold_figure",
]


def _long_line(ax: Any, t: np.ndarray, y: Any, **style: Any) -> None:
    """A line of one point per sample, drawn by its envelope when it is long."""
    at = envelope(y)
    ax.plot(t[at], np.asarray(y)[at], **style)


def _mark_changes(ax: Any, change_times: Sequence[float]) -> None:
    for x in change_times:
        ax.axvline(float(x), color="0.45", linestyle=":", linewidth=1.0, zorder=0)


def _step_panel(ax: Any, t: np.ndarray, flag: np.ndarray, name: str, colour: str) -> None:
    at = run_ends(flag, step=True)  # the same filled shape
    # snap=False: matplotlib snaps a rectilinear path of few vertices to whole pixels,
    # which would drop a flag narrower than a pixel (every point's path was not snapped)
    ax.fill_between(t[at], 0, np.asarray(flag, dtype=float)[at], step="post", color=colour,
                    alpha=0.6, linewidth=0, rasterized=True, snap=False)  # fmt: skip
    ax.set_ylim(-0.15, 1.15)
    ax.set_yticks([0, 1])
    ax.set_ylabel(name)


def kurtosis_windows_figure(
    study: KurtosisStudy, *, units: str | None = None, title: str | None = None
) -> Figure:
    """The record and the kurtosis of windows of several lengths (the paper's Fig. 6).

    Parameters
    ----------
    study : KurtosisStudy
        From :func:`adavar.paper.studies.kurtosis_study`.
    units : str, optional
        Unit of the samples, for the first panel's label.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        One panel for the record, then one per window length (kurtosis, with the Gaussian
        value 3 dashed); change times dotted.
    """
    windows = sorted(study.kurtosis)
    fig = new_figure((8.0, 2.0 + 1.6 * len(windows)))
    axes = fig.subplots(len(windows) + 1, 1, sharex=True)
    t = np.asarray(study.time, dtype=float)
    _long_line(axes[0], t, study.data, color="0.3", linewidth=0.5)
    axes[0].set_ylabel(f"rate [{units}]" if units else "rate")
    for k, (ax, w) in enumerate(zip(axes[1:], windows, strict=True)):
        _long_line(ax, t, study.kurtosis[w], color=f"C{k}", linewidth=0.8)
        ax.axhline(3.0, color="k", linestyle="--", linewidth=0.8)
        ax.set_ylabel(f"kurtosis\nL = {w}")
    for ax in axes:
        _mark_changes(ax, study.change_times)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time (window centre) [s]")
    axes[0].set_title(title or "Kurtosis of sliding windows of different lengths (paper Fig. 6)",
                      fontsize="medium")  # fmt: skip
    return fig


def contribution_figure(
    study: KurtosisStudy, *, units: str | None = None, title: str | None = None
) -> Figure:
    """Kurtosis and the record-form contribution coefficient ``S`` (the paper's Fig. 7).

    Parameters
    ----------
    study : KurtosisStudy
        From :func:`adavar.paper.studies.kurtosis_study`.
    units : str, optional
        Unit of the samples.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Panels: the record; the kurtosis of the ``study.segment``-sample window (if
        computed); ``S = (kurt(record) - kurt(record without the window)) / kurt(record)``.
    """
    seg = study.segment
    has_k = seg in study.kurtosis
    n_panels = 3 if has_k else 2
    fig = new_figure((8.0, 2.0 + 1.7 * (n_panels - 1)))
    axes = fig.subplots(n_panels, 1, sharex=True)
    t = np.asarray(study.time, dtype=float)
    _long_line(axes[0], t, study.data, color="0.3", linewidth=0.5)
    axes[0].set_ylabel(f"rate [{units}]" if units else "rate")
    if has_k:
        _long_line(axes[1], t, study.kurtosis[seg], color="C0", linewidth=0.6)
        axes[1].axhline(3.0, color="k", linestyle="--", linewidth=0.8)
        axes[1].set_ylabel(f"kurtosis\nL = {seg}")
    _long_line(axes[-1], t, study.contribution, color="C3", linewidth=0.7)
    axes[-1].axhline(0.0, color="k", linestyle="--", linewidth=0.8)
    axes[-1].set_ylabel(f"S (window {seg}\nvs the record)")
    for ax in axes:
        _mark_changes(ax, study.change_times)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time (window centre) [s]")
    axes[0].set_title(title or f"Kurtosis and sliding kurtosis contribution coefficient, "
                      f"window {seg} (paper Fig. 7)", fontsize="medium")  # fmt: skip
    return fig


def threshold_figure(study: ThresholdStudy, *, title: str | None = None) -> Figure:
    """Kurtosis of a fixed window and its threshold crossings (the paper's Fig. 8).

    Parameters
    ----------
    study : ThresholdStudy
        From :func:`adavar.paper.studies.threshold_study`.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        One axes: the kurtosis (``ax.get_lines()[0]``), its expectation under the true
        levels if known (dashed), one horizontal line per threshold and markers at the
        crossings, labelled with their times.
    """
    fig = new_figure((8.5, 4.8))
    ax = fig.add_subplot()
    t = np.asarray(study.time, dtype=float)
    _long_line(ax, t, study.kurtosis, color="0.25", linewidth=0.8,
               label=f"kurtosis, fixed window of {study.window} samples")  # fmt: skip
    if study.expected is not None:
        _long_line(ax, t, study.expected, color="0.25", linestyle="--", linewidth=0.9,
                   label="expected from the true levels")  # fmt: skip
    for k, th in enumerate(study.thresholds):
        colour = f"C{k}"
        ax.axhline(th, color=colour, linewidth=0.9, label=f"K2 = {th:g}")
        cross = np.asarray(study.crossings[th], dtype=float).ravel()
        cross = cross[np.isfinite(cross)]
        ax.plot(cross, np.full(cross.size, th), "o", color=colour, markersize=4)
        for x in cross:
            ax.annotate(f"{x:.0f}", (x, th), textcoords="offset points",
                        xytext=(2, 4 + 9 * k), fontsize="x-small", color=colour)  # fmt: skip
    _mark_changes(ax, study.change_times)
    finite = np.asarray(study.kurtosis)[np.isfinite(study.kurtosis)]
    if finite.size:
        ax.set_ylim(max(0.0, float(finite.min()) - 0.2),
                    min(float(finite.max()) + 0.5, 3.0 + 4.0 * (max(study.thresholds) - 3.0)
                        + 1.0))  # fmt: skip
    ax.set_xlabel("time (window centre) [s]")
    ax.set_ylabel("kurtosis")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", loc="upper left")
    ax.set_title(title or "Threshold crossings of the kurtosis of a fixed window (paper Fig. 8)",
                 fontsize="medium")  # fmt: skip
    return fig


def controller_figure(
    schedule: Schedule,
    time: Sequence[float] | np.ndarray,
    *,
    change_times: Sequence[float] = (),
    title: str | None = None,
) -> Figure:
    """The adaptive controller over time: kurtosis, f1, S, f2, f, window (the paper's Fig. 10).

    Parameters
    ----------
    schedule : Schedule
        From :func:`adavar.dynamic.adaptive.adaptive_schedule` (or ``MethodRun.schedule``).
    time : array_like
        Time of each centre, seconds.
    change_times : sequence of float
        Known changes, dotted.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Six panels sharing the time axis; the thresholds in force (``K1``, ``K2`` around
        the kurtosis, ``S2`` on S) are drawn at the window length of each centre.
    """
    t = np.asarray(time, dtype=float)
    w = np.asarray(schedule.window, dtype=np.int64)
    th = schedule.thresholds
    fig = new_figure((8.5, 9.0))
    axes = fig.subplots(6, 1, sharex=True, height_ratios=[2, 0.8, 2, 0.8, 0.8, 1.6])
    ax = axes[0]
    _long_line(ax, t, schedule.kurtosis, color="C0", linewidth=0.7)
    # the window and its thresholds are constant over runs of one length: the runs' ends
    # draw the same lines, by their envelope when they are many (a long record's window
    # changes length hundreds of thousands of times: 140 MB while the SVG was written)
    at = run_ends(w)
    ta, wa = t[at], w[at]
    _long_line(ax, ta, th.k1[wa], color="k", linestyle="--", linewidth=0.8, snap=False)
    _long_line(ax, ta, th.k2[wa], color="k", linestyle="--", linewidth=0.8, snap=False)
    ax.set_ylabel("kurtosis")
    _step_panel(axes[1], t, schedule.f1, "f1", "C0")
    ax = axes[2]
    _long_line(ax, t, schedule.s, color="C3", linewidth=0.7)
    _long_line(ax, ta, th.s2[wa], color="k", linestyle="--", linewidth=0.8, snap=False)
    ax.set_ylabel("S (last l\nof the window)")
    _step_panel(axes[3], t, schedule.f2, "f2", "C3")
    _step_panel(axes[4], t, schedule.f, "f", "C2")
    _long_line(axes[5], ta, wa, color="C2", linewidth=1.0, snap=False)
    axes[5].set_ylabel("window L\n[samples]")
    for ax in axes:
        _mark_changes(ax, change_times)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time (window centre) [s]")
    p = schedule.parameters
    default = (f"{schedule.method} controller: Lmax {p.get('lmax')}, Lmin {p.get('lmin')}, "
               f"l {p.get('l')}, thresholds {th.source} (paper Fig. 10)")  # fmt: skip
    axes[0].set_title(title or default, fontsize="medium")
    return fig


def arw_comparison_figure(
    comparison: Comparison, *, units: str | None = None, title: str | None = None
) -> Figure:
    """``N(t)`` of every method on one plot with the true level (the paper's Fig. 12).

    Parameters
    ----------
    comparison : Comparison
        From :func:`adavar.comparison.compare`.
    units : str, optional
        Unit of the rate samples; defaults to ``comparison.units``.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Two panels: ``N(t)`` per method (``fig.axes[0].get_lines()``, one per method in
        order, then the truth, dashed, if known) and the window length per method.
    """
    unit = units if units is not None else comparison.units
    n_unit = term_unit("angle_random_walk", unit)
    t = np.asarray(comparison.time, dtype=float)
    fig = new_figure((9.0, 6.5))
    ax, axw = fig.subplots(2, 1, sharex=True, height_ratios=[3, 1.2])
    for k, run in enumerate(comparison.methods.values()):
        _long_line(ax, t, run.arw, color=f"C{k}", linewidth=0.9, label=run.label)
        at = run_ends(run.window)
        _long_line(axw, t[at], np.asarray(run.window)[at], color=f"C{k}", linewidth=0.9,
                   label=run.label, snap=False)  # fmt: skip
    if comparison.truth is not None:
        _long_line(ax, t, comparison.truth, color="k", linestyle="--", linewidth=1.1,
                   label="true N")  # fmt: skip
    for a in (ax, axw):
        _mark_changes(a, comparison.change_times)
        a.grid(True, alpha=0.3)
    ax.set_ylabel(f"N [{n_unit}]" if n_unit else "N [sample unit x sqrt(s)]")
    axw.set_ylabel("window L\n[samples]")
    axw.set_xlabel("time (window centre) [s]")
    ax.legend(fontsize="small", loc="upper right")
    if title is None:
        import textwrap

        title = "Angle random walk N(t) per method (paper Fig. 12)\n" + textwrap.shorten(
            comparison.description, 110, placeholder=" ..."
        )
    ax.set_title(title, fontsize="medium")
    return fig

"""Public face of :mod:`adavar.output.plots`:
``import adavar.plots`` works as documented.

The names are defined and documented in :mod:`adavar.output.plots`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.output.plots import (
    STAT_NAMES,
    TERM_LABELS,
    FigureRecipe,
    arw_comparison_figure,
    coefficient_figure,
    comparison_figures,
    contribution_figure,
    controller_figure,
    davar_heatmap_figure,
    davar_surface_figure,
    deviation_figure,
    deviation_unit,
    format_pm,
    kurtosis_windows_figure,
    paper_figure_recipes,
    rate_unit,
    save_figure,
    spread_indices,
    study_figures,
    term_label,
    term_unit,
    threshold_figure,
)

__all__ = [
    "STAT_NAMES",
    "TERM_LABELS",
    "FigureRecipe",
    "arw_comparison_figure",
    "coefficient_figure",
    "comparison_figures",
    "contribution_figure",
    "controller_figure",
    "davar_heatmap_figure",
    "davar_surface_figure",
    "deviation_figure",
    "deviation_unit",
    "format_pm",
    "kurtosis_windows_figure",
    "paper_figure_recipes",
    "rate_unit",
    "save_figure",
    "spread_indices",
    "study_figures",
    "term_label",
    "term_unit",
    "threshold_figure",
]

"""The A-DAVAR paper (Micromachines 2018, 9(8), 373): its scenarios, values, node rules, studies.

Modules
-------
- :mod:`adavar.paper.scenarios`: the paper's simulated records with their ground truth
  (:func:`paper_scenario`, :class:`PaperScenario`, :data:`PAPER_SCENARIOS`);
- :mod:`adavar.paper.reference`: the values the paper publishes (Tables 1 and 3, the
  Figs. 6-8 settings and crossings) and which of them belongs to which scenario;
- :mod:`adavar.paper.nodes`: the node times Beginning, End and Restore of a window around a
  change (:func:`schedule_nodes`, :func:`fixed_nodes`);
- :mod:`adavar.paper.studies`: the paper's Figs. 6-8 (:func:`kurtosis_study`,
  :func:`threshold_study`) and many realisations of a scenario beside its tables
  (:func:`compare_seeds`).

The methods side by side on one record (:func:`adavar.comparison.compare`) and the generic noise
generators (:mod:`adavar.simulate`) are not the paper's and live outside this package;
``adavar compare`` and ``adavar demo`` print the tables. The studies are imported on first
use (:mod:`adavar.paper.studies` imports :mod:`adavar.comparison`, which imports the node rules
and reference values from here).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from adavar.paper.nodes import NODE_NAMES, NODE_TITLES, Nodes, fixed_nodes, schedule_nodes
from adavar.paper.reference import (
    PAPER_FIG6_WINDOWS,
    PAPER_FIG7_SEGMENT,
    PAPER_FIG8_CROSSINGS,
    PAPER_FIG8_THRESHOLDS,
    PAPER_LABELS,
    PAPER_REFERENCE,
    PAPER_TABLE1_ARW,
    PAPER_TABLE1_NODES,
    PAPER_TABLE3_NODES,
    paper_arw,
    paper_crossings,
    paper_nodes,
)
from adavar.paper.scenarios import PAPER_SCENARIOS, PaperScenario, paper_scenario

if TYPE_CHECKING:  # imported on first use by __getattr__ below
    from adavar.paper.studies import (
        KurtosisStudy,
        SeedStudy,
        ThresholdStudy,
        compare_seeds,
        kurtosis_study,
        threshold_study,
    )

__all__ = [
    "NODE_NAMES",
    "NODE_TITLES",
    "PAPER_FIG6_WINDOWS",
    "PAPER_FIG7_SEGMENT",
    "PAPER_FIG8_CROSSINGS",
    "PAPER_FIG8_THRESHOLDS",
    "PAPER_LABELS",
    "PAPER_REFERENCE",
    "PAPER_SCENARIOS",
    "PAPER_TABLE1_ARW",
    "PAPER_TABLE1_NODES",
    "PAPER_TABLE3_NODES",
    "KurtosisStudy",
    "Nodes",
    "PaperScenario",
    "SeedStudy",
    "ThresholdStudy",
    "compare_seeds",
    "fixed_nodes",
    "kurtosis_study",
    "paper_arw",
    "paper_crossings",
    "paper_nodes",
    "paper_scenario",
    "schedule_nodes",
    "threshold_study",
]

_STUDY_NAMES = frozenset({
    "KurtosisStudy", "SeedStudy", "ThresholdStudy", "compare_seeds", "kurtosis_study",
    "threshold_study",
})  # fmt: skip


def __getattr__(name: str) -> Any:
    """The studies of :mod:`adavar.paper.studies`, imported on first use."""
    if name in _STUDY_NAMES:
        from adavar.paper import studies

        return getattr(studies, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_STUDY_NAMES})

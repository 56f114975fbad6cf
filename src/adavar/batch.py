"""Public face of :mod:`adavar.pipeline.batch`:
``import adavar.batch`` works as documented.

The names are defined and documented in :mod:`adavar.pipeline.batch`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.pipeline.batch import (
    BATCH_MARKER,
    DEFAULT_WORKER_TIMEOUT,
    STATUS_ABSENT,
    SUMMARY_COLUMNS,
    BatchResult,
    ReportAnalysis,
    analyse_file,
    collect_files,
    output_names,
    report_options,
    run_batch,
)

__all__ = [
    "BATCH_MARKER",
    "DEFAULT_WORKER_TIMEOUT",
    "STATUS_ABSENT",
    "SUMMARY_COLUMNS",
    "BatchResult",
    "ReportAnalysis",
    "analyse_file",
    "collect_files",
    "output_names",
    "report_options",
    "run_batch",
]

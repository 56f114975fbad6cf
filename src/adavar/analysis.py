"""Public face of :mod:`adavar.pipeline.analysis`:
``import adavar.analysis`` works as documented.

The names are defined and documented in :mod:`adavar.pipeline.analysis`;
modules inside adavar import from there, never from here.
"""

from __future__ import annotations

from adavar.pipeline.analysis import (
    AnalysisRun,
    ChannelAnalysis,
    LoadedInput,
    analyse_channel,
    chunk_keywords,
    controller_settings,
    fit_keywords,
    rate_keywords,
    read_input,
    resolve_lengths,
    resolve_resolution,
    run,
    window_fit_keywords,
)

__all__ = [
    "AnalysisRun",
    "ChannelAnalysis",
    "LoadedInput",
    "analyse_channel",
    "chunk_keywords",
    "controller_settings",
    "fit_keywords",
    "rate_keywords",
    "read_input",
    "resolve_lengths",
    "resolve_resolution",
    "run",
    "window_fit_keywords",
]

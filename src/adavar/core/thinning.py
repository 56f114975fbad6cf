"""Which of many rows or taus to keep: evenly spread by index, or evenly spread in log.

A surface of millions of windows is drawn, and a report embeds it, through a few hundred of
its rows; a curve of thousands of taus through a hundred. These pick them, always keeping
the first and the last, for the figures (:mod:`adavar.output.plots`,
:mod:`adavar.output.report_parts`) and for the rows a surface fitted in blocks keeps
(:mod:`adavar.dynamic.surface_fit`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["spread_indices", "spread_log"]


def spread_indices(n: int, most: int) -> np.ndarray:
    """Indices of at most ``most`` of ``n`` rows, evenly spread, first and last included."""
    if most < 2:
        raise ValueError(f"need room for at least 2 rows, got {most}")
    if n <= most:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0.0, n - 1, most)).astype(np.int64))


def spread_log(values: np.ndarray, most: int) -> np.ndarray:
    """Indices of at most ``most`` of the sorted positive ``values``, evenly spread in log
    (the nearest value to each of ``most`` log-spaced targets), first and last included."""
    n = values.size
    if most < 2:
        raise ValueError(f"need room for at least 2 taus, got {most}")
    if n <= most:
        return np.arange(n)
    logs = np.log(values)
    targets = np.linspace(logs[0], logs[-1], most)
    right = np.clip(np.searchsorted(logs, targets), 1, n - 1)
    nearer_left = (targets - logs[right - 1]) < (logs[right] - targets)
    return np.unique(np.where(nearer_left, right - 1, right))

"""The noise fit of a DAVAR surface computed a block of windows at a time.

A per-sample surface of a long record at many taus does not fit in memory (two hours at
200 Hz and the paper's 200 taus: 2.3 GB) though its fit keeps a few numbers per window.
:func:`fit_davar_in_blocks` computes the surface a block of windows at a time
(``davar(..., rows=)``: every row is the whole surface's, bit for bit), fits each block
(:func:`adavar.fit_noise`: every window is fitted on its own, so the coefficients are those
of the whole surface's fit) and keeps the fits, the time, length and centre of every window,
and the few rows a surface figure draws. Its peak is one block, not the surface.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from adavar._figures import spread_indices
from adavar.errors import AdavarInputError
from adavar.results import DavarResult, NoiseFit

__all__ = ["BlockFit", "concatenate_fits", "drawn_rows", "fit_davar_in_blocks", "fit_rows"]

#: the fields of a :class:`NoiseFit` of a stack that hold one entry per curve
_PER_CURVE = (
    "coefficients", "coefficient_uncertainty", "chi2", "dof", "reduced_chi2", "n_points",
    "time", "used", "residuals", "coefficient_covariance",
)  # fmt: skip

#: the per-window fields of a :class:`DavarResult` (one row each)
_PER_ROW = ("time", "avar", "window", "centre", "window_class", "terms", "shift")


@dataclass(frozen=True)
class BlockFit:
    """What :func:`fit_davar_in_blocks` keeps of a surface.

    Attributes
    ----------
    fit : NoiseFit
        The fit of every window (as ``fit_noise`` of the whole surface).
    drawn : DavarResult
        The surface with only the rows asked for (``drawn_rows``); every other field is
        the whole surface's.
    rows : ndarray of int
        Which rows ``drawn`` holds.
    time, window, centre : ndarray
        Time, window length and centre of every window.
    """

    fit: NoiseFit
    drawn: DavarResult
    rows: np.ndarray
    time: np.ndarray
    window: np.ndarray
    centre: np.ndarray


def drawn_rows(result: DavarResult, most: int) -> tuple[np.ndarray, DavarResult]:
    """``(rows, result with only those rows)``: at most ``most`` of its windows, evenly
    spread (the rows a surface figure draws); every other field unchanged."""
    rows = spread_indices(int(np.size(result.time)), most)
    return rows, _take_rows(result, rows)


def _take_rows(result: DavarResult, rows: np.ndarray) -> DavarResult:
    return dataclasses.replace(result, **{name: None if getattr(result, name) is None
                                          else np.asarray(getattr(result, name))[rows]
                                          for name in _PER_ROW})  # fmt: skip


def fit_rows(fit: NoiseFit, rows: np.ndarray) -> NoiseFit:
    """The fit of a stack of curves with only the curves ``rows`` (the per-curve fields
    taken at them; the rest unchanged)."""
    taken = {name: np.asarray(getattr(fit, name))[rows]
             for name in _PER_CURVE if getattr(fit, name) is not None}  # fmt: skip
    return dataclasses.replace(fit, **taken)


def concatenate_fits(fits: list[NoiseFit]) -> NoiseFit:
    """The fits of consecutive blocks of a stack of curves as one fit of the whole stack.

    The per-curve fields are joined along the stack's axis; the others (taus, terms,
    settings) are the first fit's, and must agree.
    """
    if not fits:
        raise ValueError("internal: no fits to join")
    first = fits[0]
    for other in fits[1:]:
        if other.terms != first.terms or not np.array_equal(other.tau, first.tau):
            raise ValueError("internal: the fits of a stack's blocks must share terms and taus")
    joined = {}
    for name in _PER_CURVE:
        values = [getattr(f, name) for f in fits]
        if all(v is None for v in values):
            continue
        joined[name] = np.concatenate([np.atleast_1d(v) for v in values], axis=0)
    return dataclasses.replace(first, **joined)


def fit_davar_in_blocks(
    data: Any,
    *,
    fit_options: dict[str, Any] | None = None,
    drawn: int = 400,
    block_values: int | None = None,
    **davar_options: Any,
) -> BlockFit:
    """``fit_noise(davar(data, **davar_options), **fit_options)`` a block of windows at a time.

    Parameters
    ----------
    data : array_like
        The record, in memory, without missing samples (:func:`adavar.davar.davar_blocks`).
    fit_options : dict, optional
        Keywords of :func:`adavar.fit_noise` (``terms``, ``cells``...).
    drawn : int
        Windows kept in :attr:`BlockFit.drawn`, evenly spread over the record (first and
        last included).
    block_values : int, optional
        Surface values per block (default :data:`adavar.davar.BLOCK_VALUES`).
    **davar_options
        Keywords of :func:`adavar.davar` (``window``, ``rate``, ``taus``, ``confidence``,
        ``noise_type``...) but ``rows``.

    Returns
    -------
    BlockFit
        The same numbers as fitting the whole surface, bit for bit.
    """
    from adavar.davar import davar_blocks
    from adavar.noise_model import fit_noise

    fit_options = dict(fit_options or {})
    fits: list[NoiseFit] = []
    kept: list[DavarResult] = []
    times, windows, centres = [], [], []
    rows = np.empty(0, dtype=np.int64)
    start = 0  # the block's first row
    for block in davar_blocks(data, block_values=block_values, **davar_options):
        if not kept:  # the first block tells the number of rows
            if block.edges != "mirror":
                raise AdavarInputError(
                    "a surface fitted in blocks has edges='mirror' (a row every step)"
                )
            n = block.n_samples - (1 if block.data_type == "phase" else 0)
            rows = spread_indices(len(range(0, n, block.step)), drawn)
        stop = start + block.centre.size
        fits.append(fit_noise(block, **fit_options))
        kept.append(_take_rows(block, rows[(rows >= start) & (rows < stop)] - start))
        times.append(block.time)
        windows.append(block.window)
        centres.append(block.centre)
        start = stop
    if not kept:
        raise ValueError("internal: a surface has at least one block")
    first = kept[0]
    joined = {name: None if getattr(first, name) is None
              else np.concatenate([getattr(k, name) for k in kept], axis=0)
              for name in _PER_ROW}  # fmt: skip
    return BlockFit(
        fit=concatenate_fits(fits),
        drawn=dataclasses.replace(first, **joined),
        rows=rows,
        time=np.concatenate(times),
        window=np.concatenate(windows),
        centre=np.concatenate(centres),
    )

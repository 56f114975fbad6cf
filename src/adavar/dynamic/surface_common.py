"""Pieces the DAVAR surface engines share, with and without missing samples.

The statistics a surface holds (:data:`STATS`), the EDF of a window from its count of
terms (exact for few lengths, interpolated on a grid beyond), the chi-square bound factors
of every cell, the memory check of a surface and the number of centres a work item takes.
:mod:`adavar.dynamic.surface` (``davar``) and :mod:`adavar.dynamic.davar_gaps` (``gaps="omit"``)
both use them; neither imports the other's internals.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numba
import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.core.results import DavarResult
from adavar.io import sources
from adavar.stats import edf as edf_mod

__all__ = [
    "STATS",
    "DavarStatResult",
    "bound_factors",
    "centre_chunk_size",
    "check_surface_memory",
    "edf_of_counts",
    "edf_table",
    "noise_alpha",
    "plural_name",
    "term_width",
]

#: ``stat=`` of :func:`davar` -> the deviation name of the statistic (``result.stat``)
STATS = {"oavar": "oadev", "ohvar": "ohdev", "mvar": "mdev"}
#: what the variances are called in messages and file attributes
STAT_TITLES = {
    "oadev": "overlapping Allan variance",
    "ohdev": "overlapping Hadamard variance",
    "mdev": "modified Allan variance",
}


def plural_name(stat: str) -> str:
    """The variances of ``stat`` in an error message."""
    return "Allan variances" if stat == "oadev" else f"{STAT_TITLES[stat]}s"


def term_width(stat: str, m: Any) -> Any:
    """Phase steps one term of ``stat`` spans: a window of ``L`` samples has
    ``L + 1 - width`` terms (``L - 2m + 1``, ``L - 3m + 1``, ``L - 3m + 2``)."""
    return {"oadev": 2 * m, "ohdev": 3 * m, "mdev": 3 * m - 1}[stat]


@dataclass(frozen=True, eq=False)
class DavarStatResult(DavarResult):
    """A dynamic Hadamard or modified Allan variance surface (``davar(stat=...)``).

    Every field of :class:`adavar.core.results.DavarResult`; ``avar`` (and its bounds,
    ``adev``, the EDF) hold the statistic named by ``stat`` (``"ohdev"``: the overlapping
    Hadamard variance, ``"mdev"``: the modified Allan variance) of each window. The noise
    model's fit refuses it (its coefficients are defined on the Allan variance).
    """

    stat: str = "ohdev"

    @property
    def n_terms(self) -> np.ndarray:
        """Number of squared terms in each cell (0 where undefined; with gaps, the kept)."""
        if self.terms is not None:
            return self.terms
        n = self.window[:, None] + 1 - term_width(self.stat, self.m[None, :])
        return np.where(3 * self.m[None, :] <= self.window[:, None], n, 0)

    def to_xarray(self) -> Any:
        """The surface as an ``xarray.Dataset``, its ``avar`` named after the statistic."""
        ds = super().to_xarray()
        ds["avar"].attrs["long_name"] = STAT_TITLES[self.stat]
        return ds


#: up to this many (length, tau) pairs every EDF is computed exactly
EDF_EXACT_PAIRS = 4096
#: beyond it, lengths per tau at which the EDF is computed exactly; others are interpolated
EDF_EXACT_LENGTHS = 32


def edf_table(
    lengths: np.ndarray,
    ms: np.ndarray,
    alpha: np.ndarray,
    overhang: np.ndarray | None = None,
    stat: str = "oadev",
) -> np.ndarray:
    """Greenhall EDF of the overlapping Allan (or ``stat``) variance of windows of each length.

    Parameters
    ----------
    lengths : ndarray of int, shape (K,)
        Window lengths (rate samples); sorted and distinct when ``distinct`` is None.
    ms : ndarray of int, shape (M,)
        Averaging factors.
    alpha : ndarray of int, shape (M,)
        Power-law noise exponent per averaging factor.
    overhang : ndarray of int, shape (K,), optional
        Samples of each row's window that lie in the mirrored extension (``h``). Such a
        row gets, exactly, the EDF of an overlapping AVAR with the effective number of
        terms ``M^2 / (M + 2 D)``, where ``M = L - 2m + 1`` and ``D = max(0, h - m)``: the
        reflected phase ``2 x[0] - x[j]`` makes the term centred ``c`` samples before the
        end the negative of the one centred ``c`` after it, so the ``D`` terms centred in
        the extension repeat ``D`` inside and enter the sum with weight 2 (effective count
        ``(sum w)^2 / sum w^2``). Simulated white FM (400 records, L = 200, window centred
        on the first sample): empirical EDF 29.5 / 7.5 / 3.8 / 1.6 at m = 4 / 16 / 32 / 64,
        this rule 29.5 / 7.5 / 3.6 / 1.5, the interior EDF 60 / 15.7 / 7.1 / 2.9.
    stat : {"oadev", "ohdev", "mdev"}
        The statistic of the windows (:func:`adavar.stats.edf.edf`). Its terms span
        ``w = 2m``, ``3m`` or ``3m - 1`` phase steps: ``M = L + 1 - w`` of them, and the
        reflection repeats the ``D = max(0, h - w // 2)`` centred in the extension (the
        reflected Hadamard term is the term itself, the reflected modified one its
        negative, as for the Allan term).

    Returns
    -------
    ndarray, shape (K, M)
        EDF of a window of ``L`` samples (``L + 1`` phase points) at each ``m``; NaN where
        ``3 m > L``. Every entry is exact (:func:`adavar.stats.edf.edf`) when there are at most
        :data:`EDF_EXACT_PAIRS` valid (L, m) pairs, e.g. an adaptive schedule over 200
        lengths at octave taus. Beyond that, a tau with more than
        :data:`EDF_EXACT_LENGTHS` lengths gets exact values at that many lengths spaced
        geometrically in ``L - 3m + 1`` and a monotone cubic (PCHIP) interpolation in
        log-log between them. Measured against exact values (lengths 5-40, 3-199,
        400-600 and 3-5000; alpha -2..2; m up to 200): below 1e-3 relative except for
        flicker PM (alpha = 1), where the Greenhall algorithm changes regime with ``L/m``
        and the error reaches 1.2 %, far inside the EDF's own approximation.
    """
    lengths = np.asarray(lengths, dtype=np.int64)
    if overhang is not None:
        overhang = np.asarray(overhang, dtype=np.int64)
        table = np.full((lengths.size, ms.size), np.nan)
        for t, (m, a) in enumerate(zip(ms, alpha, strict=True)):
            m = int(m)
            rows = np.flatnonzero(3 * m <= lengths)
            if rows.size == 0:
                continue
            width = term_width(stat, m)
            terms = lengths[rows] + 1 - width
            repeats = np.maximum(0, overhang[rows] - width // 2)
            effective = np.maximum(1, np.round(terms * terms / (terms + 2 * repeats)))
            inner = repeats == 0  # no repeated term: the interior window's exact EDF
            table[rows[inner], t] = edf_mod.edf_lengths(
                stat, int(a), m, effective[inner].astype(np.int64) + width
            )
            if (~inner).any():
                counts, where = np.unique(effective[~inner].astype(np.int64), return_inverse=True)
                table[rows[~inner], t] = edf_of_counts(counts, int(a), m, stat)[where.ravel()]
        return table
    table = np.full((lengths.size, ms.size), np.nan)
    valid = 3 * ms[None, :] <= lengths[:, None]
    exact_everywhere = int(valid.sum()) <= EDF_EXACT_PAIRS
    for t, (m, a) in enumerate(zip(ms, alpha, strict=True)):
        lv = lengths[valid[:, t]]
        if lv.size == 0:
            continue
        if exact_everywhere or lv.size <= EDF_EXACT_LENGTHS:
            table[valid[:, t], t] = edf_mod.edf_lengths(stat, int(a), int(m), lv + 1)
            continue
        x = lv - 3 * m + 1
        nodes = np.unique(np.round(np.geomspace(x[0], x[-1], EDF_EXACT_LENGTHS)))
        nodes = nodes.astype(np.int64)
        values = edf_mod.edf_lengths(stat, int(a), int(m), nodes + 3 * m)
        from scipy.interpolate import PchipInterpolator  # lazy: 0.3 s to import

        curve = PchipInterpolator(np.log(nodes), np.log(values))
        table[valid[:, t], t] = np.exp(curve(np.log(x)))
    return table


#: the largest interior EDF table :func:`interior_edf_table` keeps (cells)
EDF_CACHED_CELLS = 100_000


def interior_edf_table(
    lengths: np.ndarray, ms: np.ndarray, alpha: np.ndarray, stat: str
) -> np.ndarray:
    """:func:`edf_table` of a surface's window lengths (a copy of a cached table).

    Surfaces of one record on the same taus with the same lengths (a comparison's two
    adaptive methods, a report's channels) share one table; tables of up to
    :data:`EDF_CACHED_CELLS` cells are kept (16 of them, 13 MB at most).
    """
    if np.size(lengths) * np.size(ms) > EDF_CACHED_CELLS:
        return edf_table(lengths, ms, alpha, stat=stat)
    key = tuple(np.ascontiguousarray(v, dtype=np.int64).tobytes() for v in (lengths, ms, alpha))
    return _cached_edf_table(*key, stat).copy()


@lru_cache(maxsize=16)
def _cached_edf_table(lengths: bytes, ms: bytes, alpha: bytes, stat: str) -> np.ndarray:
    return edf_table(
        np.frombuffer(lengths, dtype=np.int64), np.frombuffer(ms, dtype=np.int64),
        np.frombuffer(alpha, dtype=np.int64), stat=stat,
    )  # fmt: skip


#: Term counts up to this get exact EDFs in :func:`edf_of_counts`; beyond, a fixed
#: geometric grid with :data:`EDF_GRID_PER_OCTAVE` nodes an octave (9 % apart).
EDF_GRID_START = 64
EDF_GRID_PER_OCTAVE = 8


def edf_of_counts(counts: np.ndarray, alpha: int, m: int, stat: str = "oadev") -> np.ndarray:
    """EDF of overlapping AVARs (or ``stat``) with ``counts`` terms (sorted, distinct) at ``m``.

    Exact up to :data:`EDF_GRID_START` terms and at the nodes of a fixed geometric grid
    beyond it; between nodes a monotone cubic (PCHIP) in log-log through the two nodes each
    side, so a count's value depends on the count alone (the same in every call), not on the
    other counts asked for. Against exact values: below 1e-3 relative (tests/test_davar.py).
    """
    counts = np.asarray(counts, dtype=np.int64)
    width = term_width(stat, m)
    exact = counts <= EDF_GRID_START
    out = np.empty(counts.size)
    out[exact] = edf_mod.edf_lengths(stat, alpha, m, counts[exact] + width)
    big = counts[~exact]
    if big.size:
        # grid index k: node round(START * 2**(k / PER_OCTAVE)); two nodes beyond the
        # largest count (the grid starts at START, below every count here)
        pos = np.log2(big.max() / EDF_GRID_START) * EDF_GRID_PER_OCTAVE
        nodes, values, curve = _edf_grid(stat, alpha, m, int(np.ceil(pos)) + 3)
        on_node = np.isin(big, nodes)
        vals = np.exp(curve(np.log(big)))
        vals[on_node] = values[np.searchsorted(nodes, big[on_node])]
        out[~exact] = vals
    return out


#: (stat, alpha, m) -> (k_hi, nodes, values, curve) of :func:`_edf_grid`
_EDF_GRIDS: dict[tuple[str, int, int], tuple[int, Any, Any, Any]] = {}


def _edf_grid(stat: str, alpha: int, m: int, k_hi: int) -> tuple[Any, Any, Any]:
    """Nodes, exact EDFs and log-log PCHIP of the grid indices ``0 .. k_hi - 1`` (or more).

    A PCHIP's piece between two nodes depends only on those nodes and one neighbour each
    side, and every count asked for has two grid nodes beyond it: a grid kept from an
    earlier call that spans the asked range gives the same values, so one curve per
    (stat, alpha, m) serves every call (a DAVAR asks for the same m thousands of times).
    A grid is built an octave beyond what is asked, so that later calls (other windows,
    other methods on the same taus) find it instead of rebuilding it wider.
    """
    key = (stat, alpha, m)
    held = _EDF_GRIDS.get(key)
    if held is not None and k_hi <= held[0]:
        return held[1], held[2], held[3]
    k_hi = max(k_hi + EDF_GRID_PER_OCTAVE, 0 if held is None else held[0])
    k = np.arange(k_hi)
    nodes = np.unique(np.round(EDF_GRID_START * 2.0 ** (k / EDF_GRID_PER_OCTAVE)))
    nodes = nodes.astype(np.int64)
    width = term_width(stat, m)
    values = edf_mod.edf_lengths(stat, alpha, m, nodes + width)
    from scipy.interpolate import PchipInterpolator  # lazy: 0.3 s to import

    curve = PchipInterpolator(np.log(nodes), np.log(values))
    if len(_EDF_GRIDS) > 4096:  # bounded: a long batch of unusual taus cannot grow it
        _EDF_GRIDS.clear()
    _EDF_GRIDS[key] = (k_hi, nodes, values, curve)
    return nodes, values, curve


def bound_factors(table: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    """``edf / chi2.ppf`` factors of the lower and upper bounds (0 where undefined)."""
    ok = np.isfinite(table)
    k = np.where(ok, table, 1.0)
    # the table repeats a few thousand distinct EDFs: each quantile once
    distinct, where = np.unique(k, return_inverse=True)
    upper, lower = edf_mod.chi2_quantiles(distinct, confidence)
    where = where.reshape(k.shape)
    flo = np.where(ok, k / upper[where], 0.0)
    fhi = np.where(ok, k / lower[where], 0.0)
    return flo, fhi


def check_surface_memory(n_centres: int, n_taus: int, n_arrays: int) -> None:
    need = n_centres * n_taus * n_arrays * 8  # the bounds are made only when read
    free = sources.available_memory()
    if free is not None and need > 0.8 * free:
        raise AdavarInputError(
            f"the DAVAR surface would need {need / 2**30:.1f} GiB ({n_centres} centres x "
            f"{n_taus} taus x {n_arrays} arrays) but {free / 2**30:.1f} GiB is free: compute "
            "fewer centres (step) or fewer taus (taus='octave')"
        )


def noise_alpha(
    noise_type: str | int | Sequence[int],
    ms: np.ndarray,
    identify: Callable[[], tuple[np.ndarray, tuple[str, ...]]],
    stat: str = "oadev",
) -> tuple[np.ndarray, tuple[str, ...]]:
    """alpha per tau: ``identify()`` on the record for ``"record"``, else the caller's."""
    if isinstance(noise_type, str):
        if noise_type != "record":
            raise AdavarInputError(
                f"unknown noise_type {noise_type!r}: use 'record', an integer alpha "
                "(2 white PM .. -2 random-walk FM) or one alpha per tau"
            )
        return identify()
    alpha = np.atleast_1d(np.asarray(noise_type))
    if not np.issubdtype(alpha.dtype, np.integer) or alpha.ndim != 1:
        raise AdavarInputError("noise_type must be 'record', an integer, or integers per tau")
    if alpha.size == 1:
        alpha = np.full(ms.size, int(alpha[0]))
    elif alpha.size != ms.size:
        raise AdavarInputError(
            f"noise_type has {alpha.size} values but there are {ms.size} taus: give one"
        )
    lo, hi = edf_mod.STAT_ALPHA_RANGE[stat]
    if np.any(alpha < lo) or np.any(alpha > hi):
        raise AdavarInputError(
            f"noise_type alpha must lie in {lo} .. {hi} for the {STAT_TITLES[stat]}"
        )
    return alpha.astype(np.int64), ()


def centre_chunk_size(n_centres: int, longest: int, step: int) -> int:
    """Centres per work item: spans of a few windows, and enough items for every thread."""
    chunk = max(64, min(1 << 16, math.ceil(8 * longest / step)))
    per_thread = math.ceil(n_centres / (4 * max(1, numba.get_num_threads())))
    return int(max(64, min(chunk, per_thread)))

"""The noise fit of a DAVAR surface computed a block of windows at a time.

A per-sample surface of a long record at many taus does not fit in memory (two hours at
200 Hz and the paper's 200 taus: 2.3 GB) though its fit keeps a few numbers per window.
:func:`fit_davar_in_blocks` computes the surface a block of windows at a time
(``davar(..., rows=)``: every row is the whole surface's, bit for bit), fits each block
(:func:`adavar.fit_noise`: every window is fitted on its own, so the coefficients are those
of the whole surface's fit) and keeps the fits, the time, length and centre of every window,
and the few rows a surface figure draws. Its peak is one block, not the surface.
:func:`fit_adaptive_in_blocks` does the same for :func:`adavar.adaptive_davar` (the
controller runs once; its per-window record is kept). With ``spill=True`` every window's
coefficients go to temporary files (one per term, in the folder ``TMPDIR`` names; in
memory when none can be made) and are read back a range of windows at a time.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from adavar.core.errors import AdavarInputError
from adavar.core.results import DavarResult, NoiseFit, coefficient_value
from adavar.core.thinning import spread_indices

__all__ = [
    "FIT_ROWS",
    "BlockFit",
    "concatenate_fits",
    "drawn_rows",
    "fit_adaptive_in_blocks",
    "fit_blocks",
    "fit_davar_in_blocks",
    "fit_rows",
]

#: the fields of a :class:`NoiseFit` of a stack that hold one entry per curve
_PER_CURVE = (
    "coefficients", "coefficient_uncertainty", "chi2", "dof", "reduced_chi2", "n_points",
    "time", "used", "residuals", "coefficient_covariance",
)  # fmt: skip

#: windows per call of :func:`adavar.fit_noise` in :func:`fit_blocks`
FIT_ROWS = 1 << 14

#: the per-window fields of a :class:`DavarResult` (one row each) and of an
#: :class:`adavar.dynamic.adaptive.AdaptiveResult` (the controller's record)
_PER_ROW = ("time", "avar", "window", "centre", "window_class", "terms", "shift")
_RECORD = ("kurtosis", "s", "f1", "f2", "f")


@dataclass(frozen=True)
class BlockFit:
    """What :func:`fit_davar_in_blocks` keeps of a surface.

    Attributes
    ----------
    fit : NoiseFit
        The fit of every window (as ``fit_noise`` of the whole surface), or with
        ``fit_rows=`` of the windows ``fit_rows`` only.
    fit_rows : ndarray of int or None
        The windows ``fit`` holds (None: every window).
    drawn : DavarResult
        The surface with only the rows asked for (``drawn_rows``); every other field is
        the whole surface's.
    rows : ndarray of int
        Which rows ``drawn`` holds.
    time, window, centre : ndarray
        Time, window length and centre of every window.
    windows : DavarResult or AdaptiveResult
        The surface without its cells: every window's fields (``time``, ``window``,
        ``centre``, ``window_class``, ``shift``; an adaptive surface's ``kurtosis``, ``s``
        and flags), no taus (``tau`` empty, ``avar`` of shape ``(windows, 0)``). Shares
        ``time``, ``window`` and ``centre`` with the fields above.
    coefficients : ndarray, shape (windows, 5), or None
        Every window's model coefficients (:attr:`NoiseFit.coefficients`; ``fit``'s own
        when it holds every window); None when they are in temporary files
        (``fit_blocks(..., spill=True)``): :meth:`term_values` reads them either way.
    spilled : object or None
        The temporary files of the coefficients (None: in memory).
    """

    fit: NoiseFit
    drawn: DavarResult
    rows: np.ndarray
    time: np.ndarray
    window: np.ndarray
    centre: np.ndarray
    windows: DavarResult
    coefficients: np.ndarray | None
    fit_rows: np.ndarray | None = None
    spilled: _Columns | None = None

    def term_values(self, name: str, start: int = 0, stop: int | None = None) -> np.ndarray:
        """The value of the term ``name`` (``fit.term(name).value`` of the whole surface's
        fit) of every window, or of windows ``start .. stop - 1``."""
        from adavar.core.terms import term_index

        k = term_index(name)
        if self.coefficients is not None:
            return coefficient_value(self.coefficients[start:stop, k], k)
        if self.spilled is None:
            raise ValueError("internal: a block fit without coefficients")
        return coefficient_value(self.spilled.column(k, start, stop), k)

    def term_reader(self, name: str) -> _TermReader:
        """The term ``name`` of every window as an object whose slices
        (``reader[start:stop]``) read those windows' values only
        (:func:`adavar.dynamic.events.find_events` takes it)."""
        return _TermReader(self, name)

    @property
    def n_windows(self) -> int:
        """Windows (rows) of the whole surface."""
        return int(self.time.size)

    @property
    def n_taus(self) -> int:
        """Taus (columns) of the surface."""
        return int(np.size(self.drawn.tau))


def drawn_rows(result: DavarResult, most: int) -> tuple[np.ndarray, DavarResult]:
    """``(rows, result with only those rows)``: at most ``most`` of its windows, evenly
    spread (the rows a surface figure draws); every other field unchanged."""
    rows = spread_indices(int(np.size(result.time)), most)
    return rows, _own_edf_rows(_take_rows(result, rows))


def _own_edf_rows(result: DavarResult) -> DavarResult:
    """``result`` with only the rows of its EDF and bound tables that its windows use
    (a few rows drawn from a surface need not keep its whole table: one row for each
    window that reaches into a mirrored end)."""
    table, classes = result.edf_table, result.window_class
    if table is None or classes is None:
        return result
    used, inverse = np.unique(classes, return_inverse=True)
    bound = result.bound_table
    return dataclasses.replace(
        result, edf_table=table[used], window_class=inverse.reshape(classes.shape),
        bound_table=None if bound is None else bound[:, used],
    )  # fmt: skip


def _row_fields(result: DavarResult) -> tuple[str, ...]:
    """The per-window fields of ``result``'s type."""
    return _PER_ROW + tuple(name for name in _RECORD if hasattr(result, name))


def _take_rows(result: DavarResult, rows: np.ndarray) -> DavarResult:
    return dataclasses.replace(result, **{name: None if getattr(result, name) is None
                                          else np.asarray(getattr(result, name))[rows]
                                          for name in _row_fields(result)})  # fmt: skip


def fit_rows(fit: NoiseFit, rows: np.ndarray) -> NoiseFit:
    """The fit of a stack of curves with only the curves ``rows`` (the per-curve fields
    taken at them; the rest unchanged)."""
    return _fit_at(fit, rows)


def _fit_at(fit: NoiseFit, rows: np.ndarray) -> NoiseFit:
    # fancy indexing: copies, not views of ``fit``'s arrays
    taken = {name: np.asarray(getattr(fit, name))[np.asarray(rows, dtype=np.int64)]
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
    fit_rows: str | Callable[[int], np.ndarray] = "all",
    spill: bool = False,
    **davar_options: Any,
) -> BlockFit:
    """``fit_noise(davar(data, **davar_options), **fit_options)`` a block of windows at a time.

    Parameters
    ----------
    data : array_like
        The record without missing samples, in memory or read piece by piece
        (:func:`adavar.dynamic.surface.davar_blocks`).
    fit_options : dict, optional
        Keywords of :func:`adavar.fit_noise` (``terms``, ``cells``...).
    drawn : int
        Windows kept in :attr:`BlockFit.drawn`, evenly spread over the record (first and
        last included).
    block_values : int, optional
        Surface values per block (default :data:`adavar.dynamic.surface.BLOCK_VALUES`).
    fit_rows : {"all", "drawn"} or callable
        The windows whose whole fit :attr:`BlockFit.fit` keeps (:func:`fit_blocks`).
    spill : bool
        Every window's coefficients in temporary files (:func:`fit_blocks`).
    **davar_options
        Keywords of :func:`adavar.davar` (``window``, ``rate``, ``taus``, ``confidence``,
        ``noise_type``...) but ``rows``.

    Returns
    -------
    BlockFit
        The same numbers as fitting the whole surface, bit for bit.
    """
    from adavar.dynamic.surface import davar_blocks

    blocks = davar_blocks(data, block_values=block_values, **davar_options)
    return fit_blocks(blocks, fit_options=fit_options, drawn=drawn, fit_rows=fit_rows, spill=spill)


def fit_adaptive_in_blocks(
    data: Any,
    *,
    fit_options: dict[str, Any] | None = None,
    drawn: int = 400,
    block_values: int | None = None,
    fit_rows: str | Callable[[int], np.ndarray] = "all",
    spill: bool = False,
    **adaptive_options: Any,
) -> BlockFit:
    """``fit_noise(adaptive_davar(data, **adaptive_options), **fit_options)`` a block of
    windows at a time (:func:`adavar.dynamic.adaptive.adaptive_blocks`).

    Parameters
    ----------
    data : array_like
        The record, in memory or read piece by piece
        (:func:`adavar.dynamic.adaptive.adaptive_blocks`).
    fit_options, drawn, block_values, fit_rows, spill
        As in :func:`fit_davar_in_blocks`.
    **adaptive_options
        Keywords of :func:`adavar.adaptive_davar`.

    Returns
    -------
    BlockFit
        ``drawn`` and ``windows`` are :class:`adavar.dynamic.adaptive.AdaptiveResult`; ``windows``
        holds the controller's record (kurtosis, S, flags) of every window.
    """
    from adavar.dynamic.adaptive import adaptive_blocks

    blocks = adaptive_blocks(data, block_values=block_values, **adaptive_options)
    return fit_blocks(blocks, fit_options=fit_options, drawn=drawn, fit_rows=fit_rows, spill=spill)


def fit_blocks(
    blocks: Iterable[DavarResult],
    *,
    fit_options: dict[str, Any] | None = None,
    drawn: int = 400,
    fit_rows: str | Callable[[int], np.ndarray] = "all",
    spill: bool = False,
) -> BlockFit:
    """Fit the consecutive blocks of rows of one surface and keep what :class:`BlockFit`
    holds (each block is dropped once fitted).

    Parameters
    ----------
    blocks : iterable of DavarResult
        The blocks, in order (:func:`adavar.dynamic.surface.davar_blocks`,
        :func:`adavar.dynamic.adaptive.adaptive_blocks`), with ``edges="mirror"``.
    fit_options : dict, optional
        Keywords of :func:`adavar.fit_noise`.
    drawn : int
        Windows kept in :attr:`BlockFit.drawn`.
    fit_rows : {"all", "drawn"} or callable
        The windows whose whole fit (uncertainties, chi-square...) :attr:`BlockFit.fit`
        keeps: every window, the drawn ones, or those a function of the number of windows
        returns (sorted indices). Every window's coefficients are kept either way.
    spill : bool
        With ``fit_rows`` other than ``"all"``: write every window's coefficients to
        temporary files (one per term, deleted with the result) instead of holding them,
        five values a window (:attr:`BlockFit.spilled`); the values are the same.

    Returns
    -------
    BlockFit
    """
    from adavar.fit.noise_model import fit_noise, record_reference

    fit_options = dict(fit_options or {})
    first_fit: NoiseFit | None = None
    fits: list[NoiseFit] = []  # with fit_rows: the fits of those windows
    wanted: np.ndarray | None = None
    kept: list[DavarResult] = []
    # every window's fields and fits, filled a block at a time (no second copy to join)
    fields: dict[str, _Joined] = {}
    curves: dict[str, _Joined] = {}
    columns: _Columns | None = None  # every window's coefficients, with fit_rows
    rows = np.empty(0, dtype=np.int64)
    total = start = 0  # rows of the surface; the block's first row
    for block in blocks:
        if not kept:  # the first block tells the number of rows
            if block.edges != "mirror":
                raise AdavarInputError(
                    "a surface fitted in blocks has edges='mirror' (a row every step)"
                )
            n = block.n_samples - (1 if block.data_type == "phase" else 0)
            total = len(range(0, n, block.step))
            rows = spread_indices(total, drawn)
            wanted = _fit_rows(fit_rows, total, rows)
        stop = start + block.centre.size
        # a few thousand windows per fit: its per-window arrays (a covariance matrix each)
        # are then small beside the block; every window is fitted on its own
        for a in range(start, stop, FIT_ROWS):
            b = min(a + FIT_ROWS, stop)
            part = (
                block if (a, b) == (start, stop) else _take_rows(block, slice(a - start, b - start))
            )
            if fit_options.get("reference", "auto") == "auto":
                # one whole-record reference for every block (fit_noise would fit the
                # curve each block carries again)
                fit_options["reference"] = record_reference(part, **fit_options)
            fit = fit_noise(part, **fit_options)
            if first_fit is None:  # its settings, not its rows
                first_fit = _fit_at(fit, np.arange(0))
            elif fit.terms != first_fit.terms or not np.array_equal(fit.tau, first_fit.tau):
                raise ValueError("internal: the fits of a stack's blocks must share terms and taus")
            if wanted is None:
                _join(curves, fit, _PER_CURVE, a, total)
            else:
                fits.append(_fit_at(fit, wanted[(wanted >= a) & (wanted < b)] - a))
                if columns is None:
                    columns = _Columns(total, np.shape(fit.coefficients)[1], spill)
                columns.add(fit.coefficients, a)
            del fit, part
        _join(fields, block, [name for name in _row_fields(block)
                              if name not in ("avar", "window_class")], start, total)  # fmt: skip
        kept.append(_take_rows(block, rows[(rows >= start) & (rows < stop)] - start))
        start = stop
        del block  # before the next block is made: one block at a time, not two
    if not kept or first_fit is None:
        raise ValueError("internal: a surface has at least one block")
    if start != total:  # pragma: no cover
        raise AssertionError("internal: the blocks do not cover the surface")
    first = kept[0]
    joined = {name: None if getattr(first, name) is None
              else np.concatenate([getattr(k, name) for k in kept], axis=0)
              for name in _row_fields(first)}  # fmt: skip
    every = {name: joined.array() for name, joined in fields.items()}
    per_curve = {name: joined.array() for name, joined in curves.items()}
    # the windows without cells: no taus, so no EDF or bound tables either
    windows = dataclasses.replace(
        first, **{name: every.get(name) for name in _row_fields(first)
                  if name not in ("avar", "window_class")},
        tau=first.tau[:0], avar=np.empty((total, 0)), m=first.m[:0], alpha=first.alpha[:0],
        edf_table=None, bound_table=None, window_class=None,
    )  # fmt: skip
    if wanted is None:
        if np.array_equal(per_curve.get("time"), every["time"]):
            per_curve["time"] = every["time"]  # one copy of the times
        fit = dataclasses.replace(first_fit, **per_curve)
        coefficients, spilled = per_curve["coefficients"], None
    else:
        fit = concatenate_fits(fits)
        if columns is None:  # pragma: no cover - a surface has rows
            raise ValueError("internal: no coefficients")
        columns.finish()
        coefficients, spilled = (columns.array, None) if columns.files is None else (None, columns)
    return BlockFit(
        fit=fit, drawn=_own_edf_rows(dataclasses.replace(first, **joined)), rows=rows,
        time=every["time"], window=every["window"], centre=every["centre"], windows=windows,
        coefficients=coefficients, fit_rows=wanted, spilled=spilled,
    )  # fmt: skip


def _fit_rows(
    fit_rows: str | Callable[[int], np.ndarray], total: int, drawn: np.ndarray
) -> np.ndarray | None:  # fmt: skip
    """The windows whose whole fit a :class:`BlockFit` keeps (None: every window)."""
    if isinstance(fit_rows, str):
        if fit_rows not in ("all", "drawn"):
            raise AdavarInputError(f"unknown fit_rows {fit_rows!r}: use 'all', 'drawn' or a "
                                   "function of the number of windows")  # fmt: skip
        return None if fit_rows == "all" else drawn
    rows = np.asarray(fit_rows(total), dtype=np.int64)
    if (
        rows.ndim != 1
        or np.any(np.diff(rows) <= 0)
        or (rows.size and not 0 <= rows[0] <= rows[-1] < total)
    ):
        raise AdavarInputError(f"fit_rows gave rows that are not increasing indices of the "
                               f"{total} windows")  # fmt: skip
    return rows


class _Columns:
    """Every window's coefficients (rows x width float64), filled a block of rows at a
    time: in one array, or (``spill``) in a temporary file per column, read back a range
    of rows at a time."""

    def __init__(self, total: int, width: int, spill: bool = False) -> None:
        self.total, self.width = int(total), int(width)
        self.array: np.ndarray | None = None
        self.files: list[Any] | None = None
        if spill:
            import tempfile

            try:
                self.files = [tempfile.TemporaryFile() for _ in range(self.width)]
            except OSError:  # no usable temporary folder: hold them after all
                self.files = None
        if self.files is None:
            self.array = np.empty((self.total, self.width))

    @classmethod
    def of(cls, array: np.ndarray) -> _Columns:
        """The columns of an array held as it is."""
        held = cls.__new__(cls)
        held.total, held.width = array.shape
        held.array, held.files = array, None
        return held

    def add(self, values: np.ndarray, start: int) -> None:
        values = np.asarray(values, dtype=np.float64)
        if self.files is None:
            self.array[start : start + values.shape[0]] = values
            return
        try:
            for k, file in enumerate(self.files):
                file.seek(start * 8)
                file.write(np.ascontiguousarray(values[:, k]).tobytes())
        except OSError as exc:
            import tempfile

            raise AdavarInputError(
                f"cannot write the windows' coefficients to the temporary folder "
                f"{tempfile.gettempdir()} ({exc.strerror or exc}): set TMPDIR to a folder "
                "with space"
            ) from None

    def __reduce__(self) -> tuple[Any, tuple[np.ndarray]]:
        # a pickle (for another process) carries the values; the files stay with this one
        every = self.array if self.files is None else np.column_stack(
            [self.column(k) for k in range(self.width)]
        )  # fmt: skip
        return (_Columns.of, (every,))

    def finish(self) -> None:
        """Every row is written: flush the files before the first read."""
        for file in self.files or ():
            file.flush()

    def column(self, k: int, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Rows ``start .. stop - 1`` of column ``k`` (a view when held in memory)."""
        start, stop, _ = slice(start, stop).indices(self.total)
        if self.files is None:
            return self.array[start:stop, k]
        out = np.empty(max(0, stop - start))
        file = self.files[k]
        file.seek(start * 8)
        if out.size and file.readinto(memoryview(out).cast("B")) != out.nbytes:
            raise OSError("a temporary file of window coefficients was cut short")
        return out


class _TermReader:
    """One term of every window of a :class:`BlockFit`, read a slice at a time."""

    def __init__(self, fit: BlockFit, name: str) -> None:
        self.fit, self.name = fit, name

    def __len__(self) -> int:
        return self.fit.n_windows

    def __getitem__(self, rows: slice) -> np.ndarray:
        if not isinstance(rows, slice) or rows.step not in (None, 1):
            raise TypeError("a term reader takes slices of consecutive windows")
        return self.fit.term_values(self.name, rows.start or 0, rows.stop)


class _Joined:
    """One per-row field of a surface's blocks, joined. While the blocks are consecutive
    views of one array (an adaptive schedule's record) it is that array, not a copy;
    otherwise the blocks are copied into one array of ``total`` rows."""

    def __init__(self, total: int) -> None:
        self.total = total
        self.base: np.ndarray | None = None  # the array the blocks are views of
        self.offset = 0  # the first block's first element in ``base``
        self.parts: list[np.ndarray] = []  # the blocks, while they may be views
        self.out: np.ndarray | None = None  # the copy, once they are not

    def add(self, value: np.ndarray, start: int) -> None:
        value = np.asarray(value)
        if self.out is None and self._continues(value, start):
            self.parts.append(value)
            return
        if self.out is None:  # from now on a copy: the views so far first
            self.out = np.empty((self.total, *value.shape[1:]), dtype=value.dtype)
            at = 0
            for part in self.parts:
                self.out[at : at + part.shape[0]] = part
                at += part.shape[0]
            self.parts = []
        self.out[start : start + value.shape[0]] = value

    def _continues(self, value: np.ndarray, start: int) -> bool:
        base = value.base
        if not isinstance(base, np.ndarray) or base.ndim != 1 or value.ndim != 1:
            return False
        if value.strides != base.strides:
            return False
        here = (value.__array_interface__["data"][0]
                - base.__array_interface__["data"][0]) // base.itemsize  # fmt: skip
        if not self.parts:
            self.base, self.offset = base, here - start
            return 0 <= self.offset and self.offset + self.total <= base.size
        return base is self.base and here == self.offset + start

    def array(self) -> np.ndarray:
        if self.out is not None:
            return self.out
        if self.base is None or not self.parts:  # pragma: no cover - a surface has rows
            raise ValueError("internal: no rows to join")
        return self.base[self.offset : self.offset + self.total]


def _join(
    store: dict[str, _Joined], source: Any, names: Any, start: int, total: int
) -> None:  # fmt: skip
    """Add the per-row fields ``names`` of ``source`` (a block's rows from ``start``) to
    ``store``'s joins of ``total`` rows."""
    for name in names:
        value = getattr(source, name)
        if value is not None:
            store.setdefault(name, _Joined(total)).add(value, start)

"""The diagonally weighted noise fit of stacks of curves (``method="wls"``).

Every curve of a stack (the windows of a DAVAR surface, or one curve with
``method="wls"``) is fitted on its own by non-negative least squares with the weights
``edf / (2 avar^2)``, reweighted with the model, by the compiled kernel of
:mod:`adavar._kernels._nnls`, a block of curves at a time; see :mod:`adavar.fit.noise_model` for how
it works and what its uncertainties mean.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from adavar._kernels._jit import grouped_items, read_only
from adavar._kernels._nnls import BLOCK, PARALLEL_MIN, nnls_blocks, subsets
from adavar.core.errors import AdavarInputError
from adavar.core.results import DavarResult, NoiseFit
from adavar.core.terms import POWERS as _POWERS
from adavar.core.terms import TERM_NAMES
from adavar.core.terms import term_index as _term_index
from adavar.stats.slopes import SlopeReadoff

__all__ = [
    "BLOCK_VALUES",
    "KERNEL_VALUES",
    "MAX_REWEIGHT",
    "EdfRows",
    "block_rows",
    "check_reweight",
    "check_terms",
    "fit_stack",
    "row_blocks",
    "stack_edf",
]


#: Most reweighting passes: the 3rd pass moves a coefficient by at most 0.15 of its
#: uncertainty, the 4th by 0.05 (module notes); by 100 the fit has converged or is cycling,
#: and each pass costs a whole fit (a stack of a million curves: seconds per pass).
MAX_REWEIGHT = 100


#: Values of a stack of curves handled at a time (whole curves; a multiple of 64 of them):
#: the masks, model and residual temporaries stay at a few MB whatever the size of a DAVAR
#: surface, instead of several copies of it.
BLOCK_VALUES = 1 << 20


#: Values of a stack given to the compiled fit at a time (its EDF and masked variances
#: are formed for that many): each call of the parallel kernel costs a thread start-up
#: (up to tens of ms on a busy machine), so fewer, larger blocks than :data:`BLOCK_VALUES`.
KERNEL_VALUES = 1 << 23


def check_reweight(n_reweight: Any) -> int:
    """``n_reweight`` as an int in ``0 .. MAX_REWEIGHT``, or a one-line error."""
    if isinstance(n_reweight, (float, np.floating)) and float(n_reweight).is_integer():
        n_reweight = int(n_reweight)
    if isinstance(n_reweight, (bool, np.bool_)) or not isinstance(n_reweight, (int, np.integer)):
        raise AdavarInputError(f"n_reweight must be a non-negative integer, got {n_reweight!r}")
    if not 0 <= n_reweight <= MAX_REWEIGHT:
        raise AdavarInputError(
            f"n_reweight must lie in 0 .. {MAX_REWEIGHT}, got {n_reweight}: the fit converges "
            "in 3 or 4 passes"
        )
    return int(n_reweight)


def check_terms(terms: Sequence[str]) -> tuple[str, ...]:
    if isinstance(terms, str):
        terms = (terms,)
    try:
        terms = tuple(terms)
    except TypeError:
        raise AdavarInputError(
            f"terms must be a list of term names ({', '.join(TERM_NAMES)}), got {terms!r}"
        ) from None
    if not terms:
        raise AdavarInputError(f"terms is empty; valid names: {', '.join(TERM_NAMES)}")
    bad = [t for t in terms if t not in TERM_NAMES]
    if bad:
        raise AdavarInputError(
            f"unknown noise term(s) {', '.join(map(repr, bad))}; "
            f"valid names: {', '.join(TERM_NAMES)}"
        )
    if len(set(terms)) != len(terms):
        raise AdavarInputError(f"terms has duplicates: {terms}")
    return tuple(t for t in TERM_NAMES if t in terms)  # canonical order


def row_blocks(values: np.ndarray) -> list[np.ndarray]:
    """``values`` as blocks of whole rows (last axis) of about :data:`BLOCK_VALUES` values."""
    rows = values.reshape(-1, values.shape[-1]) if values.ndim > 1 else values.reshape(1, -1)
    step = block_rows(rows.shape[1], BLOCK_VALUES)
    return [rows[a : a + step] for a in range(0, rows.shape[0], step)]


def block_rows(n_tau: int, values: int) -> int:
    """Curves of ``n_tau`` taus per block of about ``values`` values (a multiple of 64)."""
    return max(64, values // max(1, n_tau) // 64 * 64)


def _cell_outputs(
    start: int, a2: np.ndarray, e2: np.ndarray, coefficients: np.ndarray, basis: np.ndarray,
    share: np.ndarray, used: np.ndarray, resid: np.ndarray,
) -> None:  # fmt: skip
    """``used`` and ``residuals`` of curves ``start ..`` (the fitted ``a2`` and ``e2``;
    ``e2`` may be one row for all), in blocks of :data:`BLOCK_VALUES`."""
    step = block_rows(a2.shape[1], BLOCK_VALUES)
    for a in range(0, a2.shape[0], step):
        ab, eb = a2[a : a + step], (e2 if e2.shape[0] == 1 else e2[a : a + step])
        rows = slice(start + a, start + a + ab.shape[0])
        good = np.isfinite(ab) & (ab > 0) & np.isfinite(eb) & (eb > 0)
        used[rows] = good
        model = coefficients[rows] @ basis
        with np.errstate(invalid="ignore", divide="ignore"):
            resid[rows] = np.where(good, (ab - model) / (model * np.sqrt(2.0 / (eb / share))),
                                   np.nan)  # fmt: skip


@dataclasses.dataclass(frozen=True)
class EdfRows:
    """The EDF of a stack of curves as a per-class table: curve ``i`` has
    ``table[classes[i]]`` (a DAVAR surface's ``edf_table`` and ``window_class``), read
    block by block instead of as one (curves, taus) array."""

    table: np.ndarray
    classes: np.ndarray

    def any_finite(self) -> bool:
        """Whether any curve has a finite EDF."""
        if self.table.shape[0] == 1:
            return bool(np.isfinite(self.table).any())
        present = np.bincount(self.classes, minlength=self.table.shape[0]) > 0
        return bool(np.isfinite(self.table[present]).any())


def stack_edf(result: Any, avar: np.ndarray) -> Any:
    """``result.edf``; for a DAVAR surface its per-class table (:class:`EdfRows`)."""
    table = getattr(result, "edf_table", None)
    classes = getattr(result, "window_class", None)
    if (
        getattr(type(result), "edf", None) is DavarResult.edf
        and table is not None
        and classes is not None
        and avar.ndim == 2
    ):
        table = np.asarray(table, dtype=float)
        classes = np.asarray(classes)
        if (
            table.ndim == 2
            and table.shape[1] == avar.shape[1]
            and classes.shape == avar.shape[:1]
            and classes.dtype.kind in "iu"
        ):
            return EdfRows(table, classes)
    return getattr(result, "edf", None)


def fit_stack(
    tau: Any,
    avar: Any,
    edf: Any,
    terms: Sequence[str],
    units: str | None,
    n_reweight: int,
    *,
    spacing: str = "octave",
    time: np.ndarray | None = None,
    reasons: list[str] | None = None,
    slopes: SlopeReadoff | None = None,
    drop: np.ndarray | None = None,
    offset: np.ndarray | None = None,
    white_rolloff: float | None = None,
    cells: bool = True,
) -> NoiseFit:
    """The diagonally weighted fit behind :func:`fit_avar` and :func:`fit_noise`.

    ``edf`` is an array broadcastable to ``avar``, an :class:`EdfRows` or None. Each
    curve is fitted to ``where(drop, nan, avar) - offset`` (``drop``: taus left out,
    ``offset``: a variance per tau taken out). ``white_rolloff`` (s, negative): a roll-off
    that rides on the white noise's term, whose column is then ``1/tau + white_rolloff /
    tau^2`` (each curve's roll-off in proportion to its own white level; the coefficients
    stay the IEEE ones, the roll-off is not among them). A stack is fitted in blocks of curves
    (:data:`BLOCK_VALUES`), the same numbers as at once; ``cells=False`` leaves a stack's
    per-cell ``used`` and ``residuals`` out (None).
    """
    if spacing not in ("octave", "independent"):
        raise AdavarInputError(f"unknown spacing {spacing!r}: use 'octave' or 'independent'")
    terms = check_terms(terms)
    n_reweight = check_reweight(n_reweight)

    tau = np.asarray(tau, dtype=float)
    if tau.ndim != 1 or tau.size == 0:
        raise AdavarInputError(f"tau must be a non-empty 1-D array, got shape {tau.shape}")
    if not np.all(np.isfinite(tau)) or np.any(tau <= 0):
        raise AdavarInputError("tau must be finite and positive")
    avar = np.asarray(avar, dtype=float)
    if avar.ndim == 0 or avar.shape[-1] != tau.size:
        raise AdavarInputError(
            f"avar must have shape (..., {tau.size}) to match tau, got {avar.shape}"
        )
    weighted = edf is not None
    classes = None  # the EDF of curve i is row classes[i] of edf (a DAVAR surface's table)
    if isinstance(edf, EdfRows):
        edf, classes = np.asarray(edf.table, dtype=float), edf.classes
        fits = edf.ndim == 2 and edf.shape[1] == tau.size and classes.shape == avar.shape[:1]
    else:
        edf = np.ones(tau.size) if edf is None else np.asarray(edf, dtype=float)
        try:
            fits = np.broadcast_shapes(edf.shape, avar.shape) == avar.shape
        except ValueError:
            fits = False
    if not fits:
        raise AdavarInputError(
            f"edf of shape {edf.shape} does not broadcast to avar's {avar.shape}"
        )

    share = np.ones(tau.size)
    if spacing == "octave" and tau.size > 1:
        order = np.argsort(tau)
        share[order] = np.minimum(1.0, np.gradient(np.log2(tau[order])))
    # each block's EDF rows are scaled by their octave shares below: the same products,
    # without a scaled copy of a surface's whole EDF table at every call
    octaves = not np.all(share == 1.0)

    lead = avar.shape[:-1]
    n_tau = tau.size
    a2 = avar.reshape(-1, n_tau)
    if classes is not None and edf.shape[0] == 1:
        edf, classes = edf[0], None  # one length: one row for every curve
    if classes is None:
        if edf.ndim == 2 and edf.shape[0] > 1 and edf.strides[0] == 0:
            edf = edf[0]  # one row broadcast over the stack (a fixed-window DAVAR)
        if edf.ndim <= 1 or math.prod(edf.shape[:-1]) == 1:
            # one edf row shared by every curve (the kernel then reads row 0): no per-curve copy
            e2 = np.ascontiguousarray(np.broadcast_to(edf.reshape(-1), (n_tau,)))[None, :]
        else:
            e2 = np.broadcast_to(edf, avar.shape).reshape(-1, n_tau)
    else:
        e2 = edf
    n_curves = a2.shape[0]

    sel = np.array([_term_index(t) for t in terms], dtype=np.int64)
    powers = _POWERS[sel]
    tau_ref = float(np.exp(np.mean(np.log(tau))))
    phi = (tau / tau_ref)[:, None] ** powers[None, :]
    basis = (tau[:, None] ** _POWERS[None, :]).T
    if white_rolloff is not None and 1 in sel:
        # C_-1 (1/tau + r/tau^2) = (C_-1/tau_ref) ((tau/tau_ref)^-1 + (r/tau_ref)(tau/tau_ref)^-2)
        white = int(np.flatnonzero(sel == 1)[0])
        phi[:, white] += (white_rolloff / tau_ref) * (tau / tau_ref) ** -2
        basis[1] += white_rolloff / tau**2
    phi = np.ascontiguousarray(phi)
    sub_idx, sub_size, order = subsets(len(sel))

    coefficients = np.empty((n_curves, 5))
    coef_sig = np.empty((n_curves, 5))
    chi2 = np.empty(n_curves)
    npts = np.empty(n_curves, dtype=np.int64)
    neff = np.empty(n_curves)  # valid points, each counted by its octave share
    # a few ms of work (about 25 ns per curve and tau) run on the calling thread
    work = n_curves * n_tau if n_curves >= PARALLEL_MIN else 0
    cells = cells or not lead
    used = np.empty((n_curves, n_tau), dtype=bool) if cells else None
    resid = np.empty((n_curves, n_tau)) if cells else None
    step = block_rows(n_tau, KERNEL_VALUES)
    for a in range(0, n_curves, step):
        b = min(a + step, n_curves)
        a2b = a2[a:b]
        if drop is not None:
            a2b = np.where(drop, np.nan, a2b)
        if offset is not None:
            a2b = a2b - offset
        a2b = np.ascontiguousarray(a2b)
        e2b = e2[classes[a:b]] if classes is not None else e2 if e2.shape[0] == 1 else e2[a:b]
        e2b = e2b * share if octaves else np.ascontiguousarray(e2b)
        # inputs as read-only views: one compiled version whether a caller's array is
        # writable or not (a broadcast EDF row is read-only, a stacked one is not); each
        # curve is fitted on its own, so blocks give the numbers of one call
        per, items = grouped_items(-(-(b - a) // BLOCK))
        nnls_blocks.run(
            work, items, read_only(phi, np.float64),
            read_only(a2b, np.float64), read_only(e2b, np.float64),
            n_reweight, read_only(sub_idx), read_only(sub_size), read_only(order),
            read_only(sel), read_only(tau_ref ** (-powers.astype(float)), np.float64),
            weighted, read_only(share, np.float64), coefficients[a:b], coef_sig[a:b],
            chi2[a:b], npts[a:b], neff[a:b], per,
        )  # fmt: skip
        if used is not None and resid is not None:
            _cell_outputs(a, a2b, e2b, coefficients, basis, share, used, resid)
    dof = np.maximum(neff - len(sel), 0.0) if octaves else np.maximum(npts - len(sel), 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        red = np.where(dof > 0, chi2 / dof, np.nan)

    def shaped(x: np.ndarray) -> Any:
        x = x.reshape(lead + x.shape[1:])
        return x[()] if x.ndim == 0 else x

    exclusions: tuple[str, ...] = ()
    if not lead and used is not None:
        base = reasons or [""] * n_tau
        exclusions = tuple(
            r or ("" if used[0, j] else "undefined (NaN or not positive)")
            for j, r in enumerate(base)
        )
    return NoiseFit(
        coefficients=coefficients.reshape((*lead, 5)),
        coefficient_uncertainty=coef_sig.reshape((*lead, 5)),
        tau=tau,
        chi2=shaped(chi2),
        dof=shaped(dof),
        reduced_chi2=shaped(red),
        n_points=shaped(npts),
        terms=terms,
        units=units,
        n_reweight=n_reweight,
        weighted=weighted,
        time=time,
        spacing=spacing,
        method="wls",
        used=None if used is None else used.reshape((*lead, n_tau)),
        exclusions=exclusions,
        residuals=None if resid is None else resid.reshape((*lead, n_tau)),
        slopes=slopes,
    )

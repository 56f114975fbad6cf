"""Preprocessing of real records: detrend, mean removal, decimation, time-range selection.

These are the paper's real-data steps (docs/method.md section 9: a 100 Hz gyro, a 3rd-order
polynomial detrend, decimation keeping 1 of 100 samples) plus block-average decimation and a
time-range selection. Each step is a plain function on an array (``x`` of shape ``(n,)``, or
``(n, c)`` for ``c`` channels sampled together; the first axis is time); :func:`preprocess`
/ :class:`Pipeline` chain them from short text specifications (``"detrend:3"``,
``"decimate:100"``, ...) and return, besides the data and the new sample rate, a record of
every step that can be stored in a result's metadata to reproduce it.

Every problem with the user's input raises :class:`adavar.core.errors.AdavarInputError` with a
one-line message that names the problem and the way out.

Decimation and the Allan variance
---------------------------------
``method="keep"`` (the paper) keeps 1 of ``k`` samples. For *rate* samples (a gyro's
deg/s, an accelerometer's m/s^2, a clock's fractional frequency) this aliases white noise:
the kept samples still carry the full per-sample variance ``sigma**2`` of the original
``tau0``, but now stand for ``k * tau0``, so the Allan deviation at ``k * tau0`` is
``sqrt(k)`` times the true one there and the fitted angle random walk ``N`` comes out
``sqrt(k)`` too large (10x for ``k = 100``) unless the sensor already low-pass filtered its
output to the new rate. Terms dominated by slow processes (bias instability, rate random
walk, rate ramp) are hardly affected. For *integrated* samples (angles, velocities, clock
phase) keeping 1 of ``k`` is exact: the Allan variance at every multiple of ``k * tau0`` is
unchanged.

``method="average"`` replaces each block of ``k`` samples with its mean. That is exactly the
cluster average of the Allan variance at ``tau = k * tau0``: the Allan variance of the
averaged record at ``tau = j * k * tau0`` is the Allan variance of the original at that tau
(estimated with an overlap stride of ``k`` samples instead of 1, so with somewhat fewer
degrees of freedom), and information below ``k * tau0`` (quantization, the white-noise
slope at short tau) is gone rather than aliased. Prefer it for rate data.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.polynomial import Legendre, Polynomial

from adavar.core.errors import AdavarInputError

__all__ = [
    "DECIMATE_METHODS",
    "MAX_DETREND_ORDER",
    "STEP_NAMES",
    "Pipeline",
    "Step",
    "decimate",
    "detrend",
    "fit_trend",
    "parse_steps",
    "preprocess",
    "remove_mean",
    "select",
]

#: The decimation methods of :func:`decimate`.
DECIMATE_METHODS: tuple[str, ...] = ("keep", "average")

#: The step names understood by :class:`Step` / :func:`preprocess`.
STEP_NAMES: tuple[str, ...] = ("detrend", "mean", "decimate", "select")

#: The highest polynomial degree :func:`detrend` accepts. Higher degrees are
#: ill-conditioned, cost ``O(n * order**2)``, and a polynomial that flexible follows the
#: slow noise (bias instability, rate random walk) that the Allan variance is meant to
#: measure; the paper's detrend is of degree 3.
MAX_DETREND_ORDER = 10

_CHUNK = 1 << 20  # samples per block of the streaming least-squares passes
_TIME_TOL = 1e-9  # relative tolerance when a time lands on a sample


def _fail(message: str) -> AdavarInputError:
    return AdavarInputError(message)


# --------------------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------------------


def _as_record(x: Any, what: str = "x") -> np.ndarray:
    """A float view/array of shape (n,) or (n, c), validated (NaN is checked later)."""
    try:
        arr = np.asarray(x)
    except Exception as exc:  # pragma: no cover - exotic inputs
        raise _fail(f"{what} is not an array of numbers: {exc}") from None
    if arr.dtype.kind not in "biuf":
        raise _fail(f"{what} must hold real numbers, got dtype {arr.dtype}: convert it first")
    if arr.ndim not in (1, 2):
        raise _fail(
            f"{what} must have shape (n,) or (n, channels), got {arr.shape}: "
            "put time on the first axis"
        )
    if arr.shape[0] == 0:
        raise _fail(f"{what} is empty: give a record with samples")
    if arr.dtype.kind != "f":
        arr = arr.astype(np.float64)
    return arr


def _as_rate(rate: Any) -> float:
    if isinstance(rate, bool) or not isinstance(rate, numbers.Real):
        raise _fail(f"the sample rate must be a number in Hz, got {rate!r}")
    value = float(rate)
    if not math.isfinite(value) or value <= 0:
        raise _fail(f"the sample rate must be a positive number in Hz, got {rate!r}")
    return value


def _as_int(value: Any, what: str, minimum: int, hint: str) -> int:
    if isinstance(value, str):
        try:
            value = int(value.strip())
        except ValueError:
            raise _fail(f"{what} must be an integer, got {value!r}: {hint}") from None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise _fail(f"{what} must be an integer, got {value!r}: {hint}")
    if isinstance(value, numbers.Integral):
        out = int(value)
    elif float(value).is_integer():
        out = int(value)
    else:
        raise _fail(f"{what} must be an integer, got {value!r}: {hint}")
    if out < minimum:
        raise _fail(f"{what} must be at least {minimum}, got {out}: {hint}")
    return out


def _as_time(value: Any, what: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, str):
        text = value.strip()
        if not text:
            return None
        try:
            value = float(text)
        except ValueError:
            raise _fail(f"{what} must be a time in seconds, got {value!r}") from None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise _fail(f"{what} must be a time in seconds, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise _fail(f"{what} must be a finite time in seconds, got {value!r}")
    return out


# --------------------------------------------------------------------------------------
# detrending
# --------------------------------------------------------------------------------------


class _LegendreBlocks:
    """The Legendre basis ``P_0..P_order`` on the scaled sample grid, one block at a time.

    Each block is built into buffers reused from block to block (fresh 30 MB arrays cost
    more in page faults than the arithmetic), with :func:`numpy.polynomial.legendre.legvander`'s
    recurrence operation for operation, so every value is legvander's bit for bit. A record
    of one block builds it once for all the passes.
    """

    def __init__(self, n: int, order: int) -> None:
        self.n, self.order = n, order
        size = min(n, _CHUNK)
        self._flat = np.empty((order + 1) * size)
        self._scratch = np.empty(size)
        self._index = np.arange(size, dtype=np.float64)
        self._start: int | None = None

    def starts(self) -> range:
        return range(0, self.n, _CHUNK)

    def basis(self, start: int) -> np.ndarray:
        """The ``(samples, order + 1)`` basis of the block from sample ``start``."""
        m = min(self.n, start + _CHUNK) - start
        # contiguous rows of m values, as legvander's array: the same matrix products
        rows = self._flat[: (self.order + 1) * m].reshape(self.order + 1, m)
        if self._start != start:
            t = rows[1] if self.order > 0 else self._scratch[:m]
            # sample indices start..stop-1 mapped onto [-1, 1] (exact integers first)
            np.add(self._index[:m], start, out=t)
            if self.n == 1:
                t[:] = 0.0
            else:
                np.multiply(t, 2.0 / (self.n - 1), out=t)
                np.subtract(t, 1.0, out=t)
            rows[0] = 1.0
            tmp = self._scratch[:m]
            for i in range(2, self.order + 1):
                np.multiply(rows[i - 1], t, out=rows[i])
                np.multiply(rows[i], 2 * i - 1, out=rows[i])
                np.multiply(rows[i - 2], i - 1, out=tmp)
                np.subtract(rows[i], tmp, out=rows[i])
                np.divide(rows[i], i, out=rows[i])
            self._start = start
        return rows.T


def _check_finite(rhs: np.ndarray, x: np.ndarray) -> None:
    if not np.all(np.isfinite(rhs)):
        bad = np.flatnonzero(~np.all(np.isfinite(x), axis=1))
        first = int(bad[0]) if bad.size else -1
        raise _fail(
            f"the record holds NaN or Inf (first at sample {first}): "
            "drop or interpolate those samples before preprocessing"
        )


def _solve(gram: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    coef, *_ = np.linalg.lstsq(gram, rhs, rcond=None)
    return coef


def _detrend_2d(x: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Detrend the columns of ``x`` (n, c); returns (residual, Legendre coefficients).

    Three streaming passes over blocks (no n x (order+1) matrix is held, so 1e8 samples
    cost only the output array): the Gram matrix and the first right-hand side; the
    first residual and, from it, the second right-hand side; the second residual. The
    second fit sees only the noise-sized residual (iterative refinement), so the rounding
    of the first, relative to a large offset or trend, is removed as well.
    """
    n = x.shape[0]
    if n <= order:
        raise _fail(
            f"a polynomial detrend of order {order} needs at least {order + 1} samples, "
            f"the record has {n}: use a lower order or a longer record"
        )
    blocks = _LegendreBlocks(n, order)
    gram = np.zeros((order + 1, order + 1))
    rhs = np.zeros((order + 1, x.shape[1]))
    for start in blocks.starts():
        v = blocks.basis(start)
        gram += v.T @ v
        rhs += v.T @ x[start : start + v.shape[0]]
    _check_finite(rhs, x)
    coef = _solve(gram, rhs)
    out = np.empty(x.shape, dtype=np.float64)
    rhs = np.zeros((order + 1, x.shape[1]))
    for start in blocks.starts():
        v = blocks.basis(start)
        part = out[start : start + v.shape[0]]
        np.subtract(x[start : start + v.shape[0]], v @ coef, out=part)
        rhs += v.T @ part
    _check_finite(rhs, out)
    second = _solve(gram, rhs)
    for start in blocks.starts():
        v = blocks.basis(start)
        part = out[start : start + v.shape[0]]
        np.subtract(part, v @ second, out=part)
    return out, coef + second


def _as_order(order: Any) -> int:
    out = _as_int(order, "the detrend order", 0, "use 0 (mean), 1 (line), ..., 3 (the paper)")
    if out > MAX_DETREND_ORDER:
        raise _fail(
            f"the detrend order must be at most {MAX_DETREND_ORDER}, got {out}: higher "
            "polynomial degrees are ill-conditioned and remove the slow noise being measured "
            "(bias instability, rate random walk); use 0 to 3 (the paper: 3)"
        )
    return out


def detrend(x: Any, order: int = 3, *, rate: float = 1.0) -> np.ndarray:
    """Remove the least-squares polynomial of degree ``order`` in time.

    The fit uses a Legendre basis in time scaled onto ``[-1, 1]`` (well conditioned for any
    record length; the basis is streamed in blocks, so 1e8 samples need no more memory
    than the output), followed by one pass of iterative refinement on the residual. A
    polynomial of degree ``order`` is therefore removed to rounding level relative to the
    *noise*, not to the offset or trend, even for long records with large offsets.

    Parameters
    ----------
    x : array_like, shape (n,) or (n, channels)
        The record; time runs along the first axis.
    order : int
        Degree of the polynomial, 0 to :data:`MAX_DETREND_ORDER` (the paper: 3; 0 removes
        the mean).
    rate : float
        Sample rate in Hz. The residual does not depend on it (a polynomial in time is one
        in the sample index); it is validated and used by :func:`fit_trend`.

    Returns
    -------
    ndarray, float64, same shape as ``x``
        ``x`` minus its fitted polynomial trend.

    Raises
    ------
    AdavarInputError
        A negative, non-integer or too high (above :data:`MAX_DETREND_ORDER`) order, fewer
        than ``order + 1`` samples, a bad rate, or NaN/Inf in the record.
    """
    order = _as_order(order)
    _as_rate(rate)
    arr = _as_record(x)
    out, _ = _detrend_2d(arr.reshape(arr.shape[0], -1), order)
    return out.reshape(arr.shape)


def fit_trend(x: Any, order: int = 3, *, rate: float = 1.0, t0: float = 0.0) -> list[Polynomial]:
    """The least-squares polynomial trend that :func:`detrend` removes, per channel.

    Parameters
    ----------
    x : array_like, shape (n,) or (n, channels)
        The record.
    order : int
        Degree of the polynomial, 0 to :data:`MAX_DETREND_ORDER`.
    rate : float
        Sample rate in Hz.
    t0 : float
        Time of the first sample in s.

    Returns
    -------
    list of numpy.polynomial.Polynomial
        One per channel (one for a 1-D record), to be evaluated at times in seconds; each
        keeps the scaled domain ``[t0, t0 + (n - 1) / rate]`` of the fit, so its
        ``.coef`` are the coefficients in the scaled variable in ``[-1, 1]``
        (``.convert(domain=..., window=...)`` gives other forms).
    """
    order = _as_order(order)
    rate = _as_rate(rate)
    t0 = float(_as_time(t0, "t0") or 0.0)
    arr = _as_record(x)
    x2 = arr.reshape(arr.shape[0], -1)
    _, coef = _detrend_2d(x2, order)
    n = x2.shape[0]
    domain = [t0, t0 + max(n - 1, 1) / rate]
    return [
        Legendre(coef[:, j], domain=domain).convert(kind=Polynomial) for j in range(x2.shape[1])
    ]


def remove_mean(x: Any) -> np.ndarray:
    """Subtract the mean of each channel (two-pass, exact for large offsets).

    Parameters
    ----------
    x : array_like, shape (n,) or (n, channels)

    Returns
    -------
    ndarray, float64, same shape as ``x``

    Raises
    ------
    AdavarInputError
        An empty or non-numeric record, or NaN/Inf in it.
    """
    arr = _as_record(x)
    with np.errstate(invalid="ignore", over="ignore"):
        mean = arr.mean(axis=0, dtype=np.float64)
    if not np.all(np.isfinite(mean)):
        bad = np.flatnonzero(~np.all(np.isfinite(arr.reshape(arr.shape[0], -1)), axis=1))
        first = int(bad[0]) if bad.size else -1
        raise _fail(
            f"the record holds NaN or Inf (first at sample {first}): "
            "drop or interpolate those samples before preprocessing"
        )
    out = np.asarray(arr, dtype=np.float64) - mean
    out -= out.mean(axis=0)
    return out


# --------------------------------------------------------------------------------------
# decimation and selection
# --------------------------------------------------------------------------------------


def _as_method(method: Any) -> str:
    if not isinstance(method, str) or method.strip().lower() not in DECIMATE_METHODS:
        raise _fail(
            f"unknown decimation method {method!r}: use 'keep' (1 of k samples, the paper) "
            "or 'average' (block means)"
        )
    return method.strip().lower()


def decimate(x: Any, factor: int, *, method: str = "keep") -> np.ndarray:
    """Reduce the sample rate by an integer ``factor``.

    See the module docstring for what each method does to the Allan variance: ``"keep"``
    aliases white rate noise (N comes out ``sqrt(factor)`` too large on rate data),
    ``"average"`` is the cluster average at ``tau = factor * tau0``.

    Parameters
    ----------
    x : array_like, shape (n,) or (n, channels)
        The record.
    factor : int
        Decimation factor ``k >= 1``; the new sample rate is ``rate / k``.
    method : {"keep", "average"}
        ``"keep"`` (the paper): samples ``0, k, 2k, ...`` (``ceil(n / k)`` of them; sample
        ``j`` of the output is at the time of input sample ``j * k``). ``"average"``: the
        mean of each complete block of ``k`` samples (``n // k`` of them; a trailing partial
        block is dropped; output sample ``j`` stands for the block starting at input sample
        ``j * k``).

    Returns
    -------
    ndarray, float64
        Shape ``(m,)`` or ``(m, channels)``.

    Raises
    ------
    AdavarInputError
        A factor below 1 or not an integer, an unknown method, or a record shorter than
        one block for ``"average"``.
    """
    factor = _as_int(factor, "the decimation factor", 1, "keep 1 of k samples with k >= 1")
    method = _as_method(method)
    arr = _as_record(x)
    n = arr.shape[0]
    if method == "keep":
        return np.array(arr[::factor], dtype=np.float64)
    m = n // factor
    if m == 0:
        raise _fail(
            f"block-average decimation by {factor} needs at least {factor} samples, the "
            f"record has {n}: use a smaller factor"
        )
    blocks = arr[: m * factor].reshape((m, factor, *arr.shape[1:]))
    return blocks.mean(axis=1, dtype=np.float64)


def _time_index(t: float, t0: float, rate: float) -> int:
    """Index of the first sample at or after time ``t`` (tolerant of float rounding)."""
    pos = (t - t0) * rate
    nearest = round(pos)
    if abs(pos - nearest) <= _TIME_TOL * max(1.0, abs(pos)):
        return int(nearest)
    return math.ceil(pos)


def _select_bounds(
    n: int, rate: float, start: float | None, stop: float | None, t0: float
) -> tuple[int, int]:
    end = t0 + n / rate  # the end of the last sample's interval
    tol = 0.5 / rate
    span = f"{t0:g}-{end:g} s"
    if start is not None and stop is not None and stop <= start:
        raise _fail(
            f"select: the stop time {stop:g} s is not after the start time {start:g} s: "
            "give start < stop"
        )
    if start is not None and not (t0 - tol <= start < end):
        raise _fail(
            f"select: the start time {start:g} s is outside the record ({span}): "
            "choose a start inside it"
        )
    if stop is not None and not (t0 < stop <= end + tol):
        raise _fail(
            f"select: the stop time {stop:g} s is outside the record ({span}): "
            "choose a stop inside it, or leave it open"
        )
    i0 = 0 if start is None else max(0, _time_index(start, t0, rate))
    i1 = n if stop is None else min(n, _time_index(stop, t0, rate))
    if i1 <= i0:
        raise _fail(
            f"select: no sample lies in [{start:g}, {stop:g}) s at {rate:g} Hz: "
            "widen the time range"
        )
    return i0, i1


def select(
    x: Any,
    *,
    rate: float,
    start: float | None = None,
    stop: float | None = None,
    t0: float = 0.0,
) -> np.ndarray:
    """Keep the samples whose time lies in ``[start, stop)``.

    Sample ``i`` is at time ``t0 + i / rate`` s.

    Parameters
    ----------
    x : array_like, shape (n,) or (n, channels)
        The record.
    rate : float
        Sample rate in Hz.
    start, stop : float, optional
        Time range in s (None: the record's start / end). Both must lie within the record
        ``[t0, t0 + n / rate]`` (to half a sample).
    t0 : float
        Time of the first sample in s.

    Returns
    -------
    ndarray
        A view of ``x`` (as an array) on the selected samples; the first of them is at
        ``t0 + ceil((start - t0) * rate) / rate``.

    Raises
    ------
    AdavarInputError
        A range outside the record, ``stop <= start``, an empty selection or a bad rate.
    """
    rate = _as_rate(rate)
    t0 = _as_time(t0, "t0") or 0.0
    start = _as_time(start, "select start")
    stop = _as_time(stop, "select stop")
    arr = _as_record(x)
    i0, i1 = _select_bounds(arr.shape[0], rate, start, stop, t0)
    return arr[i0:i1]


# --------------------------------------------------------------------------------------
# pipelines
# --------------------------------------------------------------------------------------

_SPEC_HELP = (
    "use detrend[:ORDER], mean, decimate:K[:keep|average] or select:START:STOP "
    "(times in s, either may be empty)"
)


def parse_steps(spec: str) -> list[Step]:
    """The steps of a comma-separated text specification, such as ``--preprocess`` takes.

    Parameters
    ----------
    spec : str
        E.g. ``"detrend:3,decimate:100"``; each item as :meth:`Step.parse` reads it.

    Returns
    -------
    list of Step
        At least one.

    Raises
    ------
    AdavarInputError
        An empty specification, an empty item (``"detrend:3,"``, ``"mean,,decimate:10"``)
        or a bad step.
    """
    if not isinstance(spec, str):
        raise _fail(f"the preprocessing steps must be text such as 'detrend:3', got {spec!r}")
    if not spec.strip():
        raise _fail(f"the preprocessing specification is empty: {_SPEC_HELP}, e.g. detrend:3")
    parts = [part.strip() for part in spec.split(",")]
    for k, part in enumerate(parts, start=1):
        if not part:
            raise _fail(
                f"preprocessing step {k} of {spec.strip()!r} is empty: remove the extra comma"
            )
    return [Step.parse(part) for part in parts]


@dataclass(frozen=True)
class Step:
    """One preprocessing step.

    Attributes
    ----------
    name : str
        One of :data:`STEP_NAMES`.
    parameters : dict
        ``detrend``: ``{"order": int}``; ``mean``: ``{}``; ``decimate``:
        ``{"factor": int, "method": "keep" | "average"}``; ``select``:
        ``{"start": float | None, "stop": float | None}`` (s).
    """

    name: str
    parameters: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        name = self.name.strip().lower() if isinstance(self.name, str) else self.name
        if name not in STEP_NAMES:
            raise _fail(f"unknown preprocessing step {self.name!r}: {_SPEC_HELP}")
        params = dict(self.parameters or {})
        allowed = {
            "detrend": {"order"},
            "mean": set(),
            "decimate": {"factor", "method"},
            "select": {"start", "stop"},
        }[name]
        extra = sorted(set(params) - allowed)
        if extra:
            raise _fail(
                f"step {name!r} has no parameter {extra[0]!r}: its parameters are "
                f"{', '.join(sorted(allowed)) or 'none'}"
            )
        if name == "detrend":
            params = {"order": _as_order(params.get("order", 3))}
        elif name == "decimate":
            if "factor" not in params:
                raise _fail("step 'decimate' needs a factor: write decimate:K, e.g. decimate:100")
            params = {
                "factor": _as_int(
                    params["factor"], "the decimation factor", 1, "keep 1 of k samples, k >= 1"
                ),
                "method": _as_method(params.get("method", "keep")),
            }
        elif name == "select":
            params = {
                "start": _as_time(params.get("start"), "select start"),
                "stop": _as_time(params.get("stop"), "select stop"),
            }
            if params["start"] is not None and params["stop"] is not None:
                if params["stop"] <= params["start"]:
                    raise _fail(
                        f"select: the stop time {params['stop']:g} s is not after the start "
                        f"time {params['start']:g} s: give start < stop"
                    )
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "parameters", params)

    @classmethod
    def parse(cls, spec: str | Mapping[str, Any] | Step) -> Step:
        """Build a step from a text specification, a mapping or a step.

        Parameters
        ----------
        spec : str or mapping or Step
            Text: ``"detrend"`` (order 3), ``"detrend:2"``, ``"mean"``, ``"decimate:100"``
            (keep 1 of 100), ``"decimate:10:average"``, ``"select:100:3600"``,
            ``"select:100:"`` (to the end), ``"select::3600"``. Mapping:
            ``{"name": "decimate", "factor": 10, "method": "average"}`` or
            ``{"name": ..., "parameters": {...}}`` (as in a TOML config or a
            :meth:`describe` record).

        Returns
        -------
        Step
        """
        if isinstance(spec, Step):
            return spec
        if isinstance(spec, Mapping):
            params = dict(spec)
            name = params.pop("name", params.pop("step", None))
            if name is None:
                raise _fail(f"preprocessing step {dict(spec)!r} has no 'name': {_SPEC_HELP}")
            nested = params.pop("parameters", None)
            if nested is not None:
                if not isinstance(nested, Mapping):
                    raise _fail(f"the parameters of step {name!r} must be a mapping")
                params = {**dict(nested), **params}
            for key in ("spec", "n_in", "n_out", "rate_in", "rate_out", "t0_in", "t0_out"):
                params.pop(key, None)  # accept a record of describe()/run() back
            return cls(str(name), params)
        if not isinstance(spec, str):
            raise _fail(f"a preprocessing step must be text or a mapping, got {spec!r}")
        parts = [p.strip() for p in spec.strip().split(":")]
        name, args = parts[0].lower(), parts[1:]
        if name == "detrend":
            if len(args) > 1:
                raise _fail(f"bad preprocessing step {spec!r}: {_SPEC_HELP}")
            return cls("detrend", {"order": args[0]} if args and args[0] else {})
        if name == "mean":
            if any(args):
                raise _fail(f"bad preprocessing step {spec!r}: 'mean' takes no parameters")
            return cls("mean", {})
        if name == "decimate":
            if not args or not args[0] or len(args) > 2:
                raise _fail(f"bad preprocessing step {spec!r}: {_SPEC_HELP}")
            params: dict[str, Any] = {"factor": args[0]}
            if len(args) == 2:
                params["method"] = args[1]
            return cls("decimate", params)
        if name == "select":
            if len(args) != 2:
                raise _fail(f"bad preprocessing step {spec!r}: {_SPEC_HELP}")
            return cls("select", {"start": args[0] or None, "stop": args[1] or None})
        raise _fail(f"unknown preprocessing step {spec!r}: {_SPEC_HELP}")

    @property
    def spec(self) -> str:
        """The text form of the step (``Step.parse(step.spec) == step``)."""
        p = self.parameters
        if self.name == "detrend":
            return f"detrend:{p['order']}"
        if self.name == "decimate":
            return f"decimate:{p['factor']}:{p['method']}"
        if self.name == "select":
            start = "" if p["start"] is None else repr(p["start"])
            stop = "" if p["stop"] is None else repr(p["stop"])
            return f"select:{start}:{stop}"
        return self.name

    def apply(
        self, x: np.ndarray, *, rate: float, t0: float = 0.0
    ) -> tuple[np.ndarray, float, float]:
        """Apply the step.

        Parameters
        ----------
        x : ndarray, shape (n,) or (n, channels)
        rate : float
            Sample rate in Hz.
        t0 : float
            Time of the first sample in s.

        Returns
        -------
        y : ndarray
        rate : float
            The new sample rate.
        t0 : float
            The time of the first output sample (for ``"average"`` decimation, the start
            of the first block).
        """
        p = self.parameters
        if self.name == "detrend":
            return detrend(x, p["order"], rate=rate), rate, t0
        if self.name == "mean":
            return remove_mean(x), rate, t0
        if self.name == "decimate":
            return decimate(x, p["factor"], method=p["method"]), rate / p["factor"], t0
        arr = _as_record(x)
        i0, i1 = _select_bounds(arr.shape[0], rate, p["start"], p["stop"], t0)
        return arr[i0:i1], rate, t0 + i0 / rate


class Pipeline:
    """A sequence of preprocessing steps.

    Parameters
    ----------
    steps : iterable of str, mapping or Step, or str
        See :meth:`Step.parse`; one string may hold several steps separated by commas (see
        :func:`parse_steps`). An empty pipeline returns the record unchanged.
    min_samples : int
        The fewest samples a step may leave (default 3, the fewest for an Allan variance).

    Examples
    --------
    The paper's real-data steps on a 100 Hz gyro record ``x``:

    >>> y, rate, record = Pipeline(["detrend:3", "decimate:100"]).run(x, rate=100.0)
    ... # doctest: +SKIP
    """

    def __init__(
        self, steps: Iterable[str | Mapping[str, Any] | Step] = (), *, min_samples: int = 3
    ) -> None:
        if isinstance(steps, str):
            steps = parse_steps(steps)
        elif isinstance(steps, (Mapping, Step)):
            steps = [steps]
        self.steps: tuple[Step, ...] = tuple(Step.parse(s) for s in steps)
        self.min_samples = _as_int(min_samples, "min_samples", 1, "use 1 or more")

    def __repr__(self) -> str:
        return f"Pipeline({[s.spec for s in self.steps]!r})"

    def __len__(self) -> int:
        return len(self.steps)

    def describe(self) -> list[dict[str, Any]]:
        """The steps as ``{"name", "parameters", "spec"}`` dicts (JSON-ready)."""
        return [
            {"name": s.name, "parameters": dict(s.parameters), "spec": s.spec} for s in self.steps
        ]

    def run(
        self, x: Any, *, rate: float, t0: float = 0.0
    ) -> tuple[np.ndarray, float, list[dict[str, Any]]]:
        """Apply every step in order.

        Parameters
        ----------
        x : array_like, shape (n,) or (n, channels)
            The record; time runs along the first axis.
        rate : float
            Sample rate in Hz.
        t0 : float
            Time of the first sample in s.

        Returns
        -------
        y : ndarray, float64
            The preprocessed record (a float64 copy of ``x`` for an empty pipeline).
        rate : float
            The sample rate of ``y`` in Hz.
        record : list of dict
            One JSON-ready dict per step: ``name``, ``parameters``, ``spec`` (its text
            form), ``n_in``/``n_out`` (samples), ``rate_in``/``rate_out`` (Hz),
            ``t0_in``/``t0_out`` (time of the first sample, s). ``Pipeline(record)``
            rebuilds the pipeline.

        Raises
        ------
        AdavarInputError
            A step that fails, or leaves fewer than ``min_samples`` samples (the message
            names the step).
        """
        rate = _as_rate(rate)
        t0 = _as_time(t0, "t0") or 0.0
        y = np.asarray(_as_record(x), dtype=np.float64)
        if y.shape[0] < self.min_samples:
            raise _fail(
                f"the record has {y.shape[0]} samples, at least {self.min_samples} are "
                "needed: give a longer record"
            )
        record: list[dict[str, Any]] = []
        for k, step in enumerate(self.steps, start=1):
            n_in, rate_in, t0_in = y.shape[0], rate, t0
            try:
                y, rate, t0 = step.apply(y, rate=rate, t0=t0)
            except AdavarInputError as exc:
                raise _fail(f"preprocessing step {k} ({step.spec}): {exc}") from None
            if y.shape[0] < self.min_samples:
                raise _fail(
                    f"after preprocessing step {k} ({step.spec}) only {y.shape[0]} samples "
                    f"remain, at least {self.min_samples} are needed: use a smaller "
                    "decimation factor, a wider time range or a longer record"
                )
            record.append(
                {
                    "name": step.name,
                    "parameters": dict(step.parameters),
                    "spec": step.spec,
                    "n_in": int(n_in),
                    "n_out": int(y.shape[0]),
                    "rate_in": float(rate_in),
                    "rate_out": float(rate),
                    "t0_in": float(t0_in),
                    "t0_out": float(t0),
                }
            )
        return np.asarray(y, dtype=np.float64), rate, record


def preprocess(
    x: Any,
    *,
    rate: float,
    steps: Sequence[str | Mapping[str, Any] | Step] | str = (),
    t0: float = 0.0,
    min_samples: int = 3,
) -> tuple[np.ndarray, float, list[dict[str, Any]]]:
    """Apply preprocessing steps to a record: ``Pipeline(steps).run(x, rate=rate)``.

    Parameters
    ----------
    x : array_like, shape (n,) or (n, channels)
        The record; time runs along the first axis.
    rate : float
        Sample rate in Hz.
    steps : sequence of str, mapping or Step, or str
        E.g. ``["detrend:3", "decimate:100"]`` (the paper), ``["mean", "select:100:3600",
        "decimate:10:average"]``; a single string may hold several steps separated by
        commas (``"detrend:3,decimate:100"``; see :func:`parse_steps`). See
        :meth:`Step.parse`.
    t0 : float
        Time of the first sample in s.
    min_samples : int
        The fewest samples any step may leave.

    Returns
    -------
    y : ndarray
    rate : float
        The new sample rate in Hz.
    record : list of dict
        What each step did (see :meth:`Pipeline.run`), for the output metadata.

    Raises
    ------
    AdavarInputError
        A bad step specification (an empty one, or an empty item between commas), a step
        that fails or leaves too few samples.
    """
    return Pipeline(steps, min_samples=min_samples).run(x, rate=rate, t0=t0)

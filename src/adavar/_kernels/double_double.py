"""Double-double arithmetic for the compiled kernels (never compiled with fast-math: every
function relies on exact IEEE rounding).

A double-double is a pair ``(high, low)`` with ``|low| <= ulp(high) / 2`` that represents
``high + low`` exactly: about 32 significant digits. The anchored phase of
:mod:`adavar._kernels.differences`, the whole-record sums of :mod:`adavar.stats.record_sums`, the
running moments of :mod:`adavar.dynamic.kurtosis` and the controller of
:mod:`adavar.dynamic.adaptive` all build on these few operations (Knuth's two-sum, Dekker's fast
two-sum, and products through a fused multiply-add).
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from adavar._kernels._jit import jit

__all__ = [
    "dd_add",
    "dd_div_d",
    "dd_mul",
    "dd_mul_d",
    "dd_scaled_add",
    "fast_two_sum",
    "fma",
    "two_sum",
]


@jit
def two_sum(a, b):  # pragma: no cover - compiled
    """``a + b`` as (high, low), exactly, for any ``a``, ``b`` (Knuth)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@intrinsic
def fma(typingctx, a, b, c):  # pragma: no cover - compile-time
    """``a * b + c`` with one rounding (``llvm.fma``; a library call on CPUs without FMA)."""
    if not all(isinstance(t, types.Float) for t in (a, b, c)):
        return None
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        args = [
            context.cast(builder, v, t, types.float64)
            for v, t in zip(args, signature.args, strict=True)
        ]
        d = ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d]))
        return builder.call(fn, args)

    return sig, codegen


@jit
def fast_two_sum(a, b):  # pragma: no cover - compiled
    """``a + b`` as (high, low), for ``|a| >= |b|`` (or a == 0)."""
    s = a + b
    return s, b - (s - a)


@jit
def dd_add(ah, al, bh, bl):  # pragma: no cover - compiled
    s, e = two_sum(ah, bh)
    return fast_two_sum(s, e + (al + bl))


@jit
def dd_mul(ah, al, bh, bl):  # pragma: no cover - compiled
    p = ah * bh
    e = fma(ah, bh, -p)
    return fast_two_sum(p, e + (ah * bl + al * bh))


@jit
def dd_mul_d(ah, al, b):  # pragma: no cover - compiled
    p = ah * b
    e = fma(ah, b, -p)
    return fast_two_sum(p, e + al * b)


@jit
def dd_div_d(ah, al, b):  # pragma: no cover - compiled
    q = ah / b
    p = q * b
    e = fma(q, b, -p)
    return fast_two_sum(q, (((ah - p) - e) + al) / b)


@jit(inline="always")  # called in hot loops where LLVM would not inline it
def dd_scaled_add(ah: float, al: float, c: int, bh: float, bl: float) -> tuple[float, float]:
    """``a + c * b`` for a small integer ``c``, by repeated exact additions."""
    if c < 0:
        bh = -bh
        bl = -bl
        c = -c
    for _ in range(c):
        ah, al = dd_add(ah, al, bh, bl)
    return ah, al

"""Digital IIR filtering for the simulator: Butterworth low-pass sections and their cascade.

:func:`adavar.simulate.sensor` passes its output through a sensor's digital low-pass
(``bandwidth=``) and :func:`adavar.simulate.markov` runs an AR(1) recursion. Both were
``scipy.signal`` calls; importing ``scipy.signal`` costs about a second (it imports
``scipy.stats``), more than the filtering itself. This module does the same arithmetic:

- :func:`butter_lowpass_sos`: ``scipy.signal.butter(order, cutoff, fs=rate, output="sos")``
  (analog prototype, prewarped bilinear transform, ``zpk2sos`` with its ``"nearest"``
  pairing, the gain in the first section), operation for operation;
- :func:`sosfilt_zi`: ``scipy.signal.sosfilt_zi``, the steady state of the cascade for a
  unit step (each section's ``lfilter_zi`` scaled by the DC gain of the sections before it);
- :func:`sosfilt`: ``scipy.signal.sosfilt``, the cascade of second-order sections in
  direct form II transposed, in float64, as a small serial compiled kernel.

The numbers are scipy.signal's: bit for bit on the builds tried (the same operations in
the same order, no fused multiply-adds), and tests/test_iir.py compares them to 1e-12 on
random and adversarial inputs.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import ArrayLike, NDArray

from adavar._kernels._jit import jit, read_only

__all__ = ["butter_lowpass_sos", "sosfilt", "sosfilt_zi"]

FloatArray = NDArray[np.float64]

#: relative size of the imaginary part below which a pole counts as real (scipy's
#: ``_cplxreal`` default, ``100 eps``)
_REAL_TOL = 100 * np.finfo(np.float64).eps


def butter_lowpass_sos(order: int, cutoff: float, rate: float) -> FloatArray:
    """Digital Butterworth low-pass as second-order sections.

    The same numbers as ``scipy.signal.butter(order, cutoff, btype="low", fs=rate,
    output="sos")``: the analog prototype's poles ``-exp(i pi m / (2 order))``, the cutoff
    prewarped to ``4 tan(pi cutoff / rate)`` (on scipy's normalised rate of 2), the bilinear
    transform (all zeros at ``z = -1``) and scipy's ``zpk2sos`` pairing ``"nearest"``.

    Parameters
    ----------
    order : int
        Filter order, ``>= 1``.
    cutoff : float
        -3 dB frequency in Hz, ``0 < cutoff < rate / 2``.
    rate : float
        Sampling rate in Hz.

    Returns
    -------
    ndarray of float64, shape (ceil(order / 2), 6)
        One section ``[b0, b1, b2, 1, a1, a2]`` a row, the overall gain in the first row;
        sections whose poles lie closest to the unit circle come last.

    Notes
    -----
    Pairing (scipy's ``zpk2sos``, ``pairing="nearest"``). An odd order gets an extra pole and
    zero at the origin, so every section has two of each. From the last section to the
    first, the remaining pole closest to the unit circle takes its conjugate (or, if real,
    the other real pole) and the two remaining zeros closest to it.
    """
    if isinstance(order, bool) or not isinstance(order, numbers.Integral) or order < 1:
        raise ValueError(f"order must be an integer >= 1, got {order!r}")
    order = int(order)
    rate = float(rate)
    if not (math.isfinite(rate) and rate > 0.0):
        raise ValueError(f"rate must be a positive finite number, got {rate!r}")
    # the expressions below are scipy.signal's (iirfilter, buttap, lp2lp_zpk, bilinear_zpk),
    # written the same way so that every rounding is the same
    wn = np.asarray(cutoff, dtype=np.float64) / (rate / 2)
    if not 0.0 < wn < 1.0:
        raise ValueError(f"cutoff must lie in (0, rate/2) = (0, {rate / 2}), got {cutoff!r}")
    fs = 2.0
    warped = float(2 * fs * np.tan(np.pi * wn / fs))
    m = np.arange(-order + 1, order, 2, dtype=np.float64)
    poles = warped * -np.exp(1j * np.pi * m / (2 * order))
    gain = 1.0 * warped**order
    fs2 = 2.0 * fs
    gain = gain * np.real(np.prod(fs2 - np.zeros(0)) / np.prod(fs2 - poles))
    sos = _pair_sections((fs2 + poles) / (fs2 - poles), order)
    sos[0, :3] *= gain
    return sos


def _pair_sections(poles: NDArray[np.complex128], order: int) -> FloatArray:
    """Second-order sections of the poles ``poles`` and ``order`` zeros at ``-1`` (unit gain).

    scipy's ``zpk2sos(z, p, 1, pairing="nearest")`` for this case: every zero real, the
    complex poles in exact conjugate pairs.
    """
    real = np.abs(poles.imag) <= _REAL_TOL * np.abs(poles)
    upper = poles[~real & (poles.imag > 0)]
    reals = poles[real].real
    zeros = -np.ones(order)
    if order % 2:
        reals = np.concatenate((reals, [0.0]))
        zeros = np.concatenate((zeros, [0.0]))
    # scipy's order: complex poles (one of each pair) by real part, then the real ones
    left = np.concatenate((upper[np.argsort(upper.real, kind="stable")], np.sort(reals)))
    left = left.astype(np.complex128)
    zeros = np.sort(zeros)
    sections = np.zeros(((order + 1) // 2, 6))
    for si in range(sections.shape[0] - 1, -1, -1):
        # the "worst" pole, closest to the unit circle, goes in the last section left
        i = int(np.argmin(np.abs(1 - np.abs(left))))
        p1 = left[i]
        left = np.delete(left, i)
        if p1.imag == 0.0:
            j = np.flatnonzero(left.imag == 0.0)
            j = int(j[np.argmin(np.abs(1 - np.abs(left[j])))])
            p2 = left[j]
            left = np.delete(left, j)
        else:
            p2 = p1.conjugate()
        pair = []
        for _ in range(2):  # the zeros nearest to p1 (every zero is real)
            k = int(np.argsort(np.abs(zeros - p1))[0])
            pair.append(zeros[k])
            zeros = np.delete(zeros, k)
        sections[si, :3] = np.poly(pair)
        sections[si, 3:] = np.real(np.poly([p1, p2]))
    return sections


def _check_sos(sos: ArrayLike) -> FloatArray:
    """``sos`` as a float64 ``(n_sections, 6)`` array of normalised sections."""
    sos = np.asarray(sos, dtype=np.float64)
    if sos.ndim != 2 or sos.shape[1] != 6 or sos.shape[0] < 1:
        raise ValueError(f"sos must have shape (n_sections, 6), got {sos.shape}")
    if not np.all(sos[:, 3] == 1.0):
        raise ValueError("sos[:, 3] must be all ones (normalised sections)")
    return sos


def sosfilt_zi(sos: ArrayLike) -> FloatArray:
    """Initial state of :func:`sosfilt` for the steady state of a unit step.

    ``scipy.signal.sosfilt_zi``: scale by the first sample, ``sosfilt_zi(sos) * x[0]``, so
    that a record starting at ``x[0]`` has no start-up transient.

    Parameters
    ----------
    sos : array_like, shape (n_sections, 6)
        Second-order sections, ``sos[:, 3] == 1``.

    Returns
    -------
    ndarray of float64, shape (n_sections, 2)
        The two delays of each section (direct form II transposed).

    Notes
    -----
    Section ``s`` with coefficients ``b, a`` sees the step scaled by the DC gain
    ``sum(b) / sum(a)`` of the sections before it; its state solves ``zi = A zi + B``
    (``A`` the transposed companion matrix of ``a``, ``B = b[1:] - a[1:] b[0]``), by the
    same 2-by-2 LAPACK solve as scipy's ``lfilter_zi``.
    """
    sos = _check_sos(sos)
    zi = np.empty((sos.shape[0], 2))
    scale = 1.0
    for s in range(sos.shape[0]):
        b = sos[s, :3]
        a = sos[s, 3:]
        i_minus_a = np.array([[1.0 + a[1], -1.0], [0.0 + a[2], 1.0]])
        zi[s] = scale * np.linalg.solve(i_minus_a, b[1:] - a[1:] * b[0])
        scale *= np.sum(b) / np.sum(a)
    return zi


def sosfilt(sos: ArrayLike, x: ArrayLike, zi: ArrayLike | None = None) -> FloatArray:
    """Filter ``x`` through a cascade of second-order sections (direct form II transposed).

    ``scipy.signal.sosfilt(sos, x, zi=zi)[0]`` for a 1-D ``x``, in float64 (a float32 ``x``
    is filtered in float64, as scipy does with float64 sections).

    Parameters
    ----------
    sos : array_like, shape (n_sections, 6)
        Second-order sections, ``sos[:, 3] == 1``.
    x : array_like, shape (n,)
        The samples.
    zi : array_like, shape (n_sections, 2), optional
        Initial delays (:func:`sosfilt_zi`); zeros by default.

    Returns
    -------
    ndarray of float64, shape (n,)
        The filtered samples.
    """
    sos = _check_sos(sos)
    x = np.asarray(x)
    if x.ndim != 1:
        raise ValueError(f"x must be one-dimensional, got shape {x.shape}")
    if zi is None:
        zi = np.zeros((sos.shape[0], 2))
    zi = np.asarray(zi, dtype=np.float64)
    if zi.shape != (sos.shape[0], 2):
        raise ValueError(f"zi must have shape ({sos.shape[0]}, 2), got {zi.shape}")
    return _cascade(read_only(sos), read_only(x, np.float64), read_only(zi))


@jit
def _cascade(sos, x, zi):  # pragma: no cover - compiled
    """``x`` through the sections ``sos`` from the delays ``zi`` (scipy's ``_sosfilt`` loop)."""
    sections = sos.shape[0]
    state = zi.copy()
    y = np.empty(x.size)
    for n in range(x.size):
        cur = x[n]
        for s in range(sections):
            new = sos[s, 0] * cur + state[s, 0]
            state[s, 0] = sos[s, 1] * cur - sos[s, 4] * new + state[s, 1]
            state[s, 1] = sos[s, 2] * cur - sos[s, 5] * new
            cur = new
        y[n] = cur
    return y

"""The GLS fit remembers its covariances, whitenings and likelihoods by their exact inputs:
the fit must be the one it gives when it computes every one of them afresh."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import adavar
from adavar.fit import gls_core


def _curves():
    """Independent of adavar.simulate: white + random walk, a band-limited quantised gyro
    with flicker, and a Gauss-Markov hump."""
    rng = np.random.default_rng(11)
    n = 12_000
    white = 1e-3 * rng.standard_normal(n)
    walk = np.cumsum(3e-6 * rng.standard_normal(n))
    spectrum = np.fft.rfft(rng.standard_normal(n))
    f = np.arange(spectrum.size)
    f[0] = 1
    flicker = np.fft.irfft(spectrum / np.sqrt(f), n) * 2e-4
    smooth = np.convolve(white + flicker, np.ones(8) / 8, mode="same")
    markov = np.zeros(n)
    shocks = 1e-3 * rng.standard_normal(n)
    for i in range(1, n):
        markov[i] = 0.995 * markov[i - 1] + shocks[i]
    return [white + walk, np.round(smooth / 2e-4) * 2e-4, white + markov]


def _fields(fit) -> dict:
    out = {}
    for f in dataclasses.fields(fit):
        value = getattr(fit, f.name)
        out[f.name] = value.tobytes() if isinstance(value, np.ndarray) else repr(value)
    return out


def test_remembered_results_give_the_fit_computed_afresh(monkeypatch):
    _, quantised, markov = _curves()
    cases = [(quantised, {}), (markov, {"markov": "auto"})]
    curves = [(adavar.deviation(x, rate=200.0, units="deg/s"), kw) for x, kw in cases]
    remembered = [_fields(adavar.fit_noise(c, **kw)) for c, kw in curves]
    # the reference: every covariance, whitening and likelihood computed anew
    monkeypatch.setattr(gls_core.Problem, "remembered", lambda self, key, compute: compute())
    afresh = [_fields(adavar.fit_noise(c, **kw)) for c, kw in curves]
    assert remembered == afresh


def test_remembered_arrays_cannot_be_changed_by_a_caller():
    tau = 2.0 ** np.arange(6) * 0.01
    ms = 2 ** np.arange(6)
    prob = gls_core.Problem(tau, 1e-4 / tau, np.full(6, 100.0), ms, 10_001, 0.01, "oadev",
                            np.full(6, 0), np.array([-2, -1, 0, 1, 2]))  # fmt: skip
    idx = np.arange(6)
    coef = np.array([0.0, 1e-4, 0.0, 0.0, 0.0, 0.0])
    cov = prob.cov(coef, idx)
    assert prob.cov(coef, idx) is cov  # the same inputs: the result remembered
    with pytest.raises(ValueError, match="read-only"):
        cov[0, 0] = 0.0
    w = gls_core.whitened(prob, idx, coef)
    with pytest.raises(ValueError, match="read-only"):
        w.aw[0, 0] = 0.0
    prob.set_markov(1.0)  # another model's columns: nothing remembered is used
    assert prob.memo == {}
    assert prob.cov(coef, idx) is not cov


def test_keys_tell_apart_arrays_of_the_same_bytes():
    # int32 [1, 0] and int64 [1] have the same eight bytes: other taus, another key
    assert gls_core._exact(np.array([1, 0], np.int32)) != gls_core._exact(np.array([1]))
    assert gls_core._exact(np.zeros(2)) != gls_core._exact(np.zeros((1, 2)))
    assert gls_core._exact(np.arange(3)) == gls_core._exact(np.arange(3))


def _bisection(f, lo, hi, rtol):
    """The reference of the profile bounds: plain bisection of ``f(lo) <= 0 < f(hi)`` to
    ``rtol`` of its upper end, which it returns (the rule before 0.3.1)."""
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if f(mid) > 0:
            hi = mid
        else:
            lo = mid
        if hi - lo <= rtol * hi:
            break
    return hi


def test_bounds_are_the_bisection_bounds_bit_for_bit(monkeypatch):
    """The 1-sigma and 99 % bounds of the terms a fit leaves out: false position narrows
    the bracket, then the bisection asks only inside it; every number of the fit is the
    plain bisection's, to the last bit, in fewer refits."""
    from adavar.fit import gls_select

    walk, quantised, markov = (adavar.deviation(x, rate=200.0, units="deg/s") for x in _curves())
    cases = [(walk, {}), (walk, {"select": "bic"}), (quantised, {}), (markov, {"markov": "auto"})]
    calls: list[int] = []

    def counting(search):
        """``search`` with the calls it makes of the profile counted in ``calls``."""

        def counted(f, lo, hi, rtol):
            calls.append(0)

            def g(c):
                calls[-1] += 1
                return f(c)

            return search(g, lo, hi, rtol)

        return counted

    monkeypatch.setattr(gls_select, "crossing", counting(gls_select.crossing))
    fast = [_fields(adavar.fit_noise(c, **kw)) for c, kw in cases]
    fast_calls = list(calls)
    calls.clear()
    monkeypatch.setattr(gls_select, "crossing", counting(_bisection))
    slow = [_fields(adavar.fit_noise(c, **kw)) for c, kw in cases]
    assert fast == slow
    assert len(fast_calls) >= 10 and sum(fast_calls) < 0.8 * sum(calls), (fast_calls, calls)

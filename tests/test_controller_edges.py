"""Windows at the record's ends: tested at their effective size (docs/method.md section 8).

A window centred within half its length of an end reaches into the mirror extension, whose
samples repeat ones the window already holds. Its kurtosis then spreads as that of
``L^2 / (L + 2 M)`` samples (``M`` repeated), and with the thresholds of ``L`` the first and
last half-window of every record fired the kurtosis test 3.6 times as often as the
interior (white noise, 2 % per step) and twice as often behind a filter with hourly
thresholds.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from adavar.dynamic.adaptive import adaptive_schedule
from adavar.dynamic.thresholds import thresholds_for


def literal_with_tables(x, th, *, lmax, lmin, l, dl0=2, dl1=2):  # noqa: E741
    """METHOD.md section 5 one step at a time (two-pass moments), thresholds from tables:
    ``K1``, ``K2`` at the window's length inside the record, at its effective size where
    it reaches into the mirror; ``S2`` at its length."""
    n = x.size
    pad = lmax // 2 + 1
    ext = np.pad(np.asarray(x, dtype=float), pad, mode="symmetric")
    L = lmax
    windows, f1s = [], []
    for p in range(n):
        h = (L - 1) // 2
        window = ext[p + pad - h : p + pad - h + L]
        d = window - window.mean()
        k = np.mean(d**4) / np.mean(d**2) ** 2
        rest = window[: L - l] - window[: L - l].mean()
        s = (k - np.mean(rest**4) / np.mean(rest**2) ** 2) / k
        repeated = max(0, h - p) + max(0, p - h + L - n)  # samples of the mirror
        if repeated:
            size = round(L * L / (L + 2 * repeated))
            f1 = not (th.edge_k1[size] <= k <= th.edge_k2[size])
        else:
            f1 = not (th.k1[L] <= k <= th.k2[L])
        f = f1 or s > th.s2[L]
        windows.append(L)
        f1s.append(f1)
        L = max(L - dl1, lmin) if f else min(L + dl0, lmax)
    return np.array(windows), np.array(f1s)


@pytest.mark.parametrize("hourly", [False, True], ids=["per-step", "per-hour"])
def test_the_pass_follows_the_literal_reading_at_both_ends(hourly):
    rng = np.random.default_rng(11)
    x = rng.standard_normal(1500)
    x[700:900] *= 3.0
    options = dict(lmax=200, lmin=120, l=30, thresholds="calibrated",
                   kurtosis_reference="gaussian")  # fmt: skip
    options |= dict(false_alarm_per_hour=50.0) if hourly else dict(false_alarm=0.05)
    got = adaptive_schedule(x, rate=10.0, **options)
    th = thresholds_for(got.parameters)
    window, f1 = literal_with_tables(x, th, lmax=200, lmin=120, l=30)
    np.testing.assert_array_equal(got.window, window)
    np.testing.assert_array_equal(got.f1, f1)
    # the edge tables hold sizes down to half of lmin, and are used there
    assert np.isfinite(th.edge_k1[60])
    assert np.isnan(th.k1[119]) == hourly  # hourly: the edges' own tables
    assert th.edge_k2[100] > th.edge_k2[200]


def _f1_rates(kind: str, options: dict, records: int) -> tuple[float, float, float]:
    """Mean f1 of the first and last 100 centres and of the interior, along a fixed
    window of 400 samples, over ``records`` records of 4000 samples."""
    first = last = inner = 0.0
    b, a = signal.butter(4, 0.2)
    for seed in range(records):
        x = np.random.default_rng(500 + seed).standard_normal(4000)
        if kind == "filtered":
            x = signal.lfilter(b, a, x)
        got = adaptive_schedule(
            x, rate=100.0, method="fixed", lmax=400, lmin=200, l=50, thresholds="calibrated",
            kurtosis_reference="gaussian", **options,
        )  # fmt: skip
        f1 = np.asarray(got.f1, dtype=float)
        first += f1[:100].mean()
        last += f1[-100:].mean()
        inner += f1[400:-400].mean()
    return first / records, last / records, inner / records


def test_white_noise_fires_as_often_at_the_ends_as_inside():
    first, last, inner = _f1_rates("white", {"false_alarm": 0.02}, 600)
    assert 0.016 < inner < 0.026
    # 0.013-0.023 over six sets of seeds; before: 0.07 and 0.075 (the thresholds of 400
    # samples for an effective 200-300)
    for rate in (first, last):
        assert 0.008 < rate < 0.032


def test_filtered_noise_with_hourly_thresholds_fires_no_more_at_the_ends():
    first, last, inner = _f1_rates("filtered", {"false_alarm_per_hour": 30.0}, 300)
    # before: 0.14 and 0.17 against 0.08 inside
    for rate in (first, last):
        assert 0.4 * inner < rate < 1.25 * inner

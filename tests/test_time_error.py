"""MTIE and TIE rms: slow references, Stable32's tables, adversarial records, EDF."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from numpy.lib.stride_tricks import sliding_window_view

import adavar
from adavar.stats import time_error as te
from adavar.stats.edf import greenhall_edf
from tests.stable32_data import read_data, stable32_root

SETTINGS = settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def phase_ref(u):
    return np.concatenate([[0.0], np.cumsum(np.asarray(u, dtype=np.longdouble))])


def mtie_ref(u, m):
    """Max over every window of m + 1 phase points of (max - min), long double."""
    w = sliding_window_view(phase_ref(u), m + 1)
    return float(np.max(w.max(axis=1) - w.min(axis=1)))


def tierms_ref(u, m):
    x = phase_ref(u)
    d = x[m:] - x[:-m]
    return float(np.sqrt(np.mean(d * d)))


REFS = {"mtie": mtie_ref, "tierms": tierms_ref}


@SETTINGS
@given(
    n=st.integers(3, 200),
    seed=st.integers(0, 2**32 - 1),
    stat=st.sampled_from(["mtie", "tierms"]),
    kind=st.sampled_from(["white", "walk", "offset", "drift", "step", "ties", "tiny", "huge"]),
)
# a whole-record lag whose TIE 2.5e4 times smaller than the data: 1.02e-12 off at a 1e200 scale
@example(n=173, seed=167173, stat="tierms", kind="huge")
def test_matches_reference(n, seed, stat, kind):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    if kind == "walk":
        u = np.cumsum(u)
    elif kind == "offset":  # not blind to it: MTIE ~ 1e9 m
        u = u + 1e9
    elif kind == "drift":
        u = u + 1e3 * np.arange(n)
    elif kind == "step":
        u[n // 2 :] += 1e6
    elif kind == "ties":
        u = np.round(u)
    # powers of two (about 1e-200 and 1e200): u * scale is then exactly the scaled record,
    # and the reference on u, times scale, is its exact answer (with 1e200 the rounding
    # of each scaled sample alone moved a cancelling TIE rms by 1e-12)
    scale = {"tiny": 2.0**-665, "huge": 2.0**665}.get(kind, 1.0)
    ms = np.unique(rng.integers(1, n + 1, size=4))
    got = adavar.deviation(u * scale, stat=stat, rate=1.0, taus=ms.astype(float), confidence=None)
    ref = np.array([REFS[stat](u, int(m)) for m in got.m]) * scale
    np.testing.assert_allclose(got.dev, ref, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(got.n, n + 1 - got.m)
    np.testing.assert_array_equal(got.tau, got.m)


def test_rate_data_is_in_phase_units():
    rng = np.random.default_rng(4)
    y = rng.standard_normal(500) + 3.0
    x = np.concatenate([[0.0], np.cumsum(y)]) * 0.25
    for stat in ("mtie", "tierms"):
        a = adavar.deviation(y, stat=stat, rate=4.0, taus="octave", confidence=None)
        b = adavar.deviation(
            x, stat=stat, rate=4.0, data_type="phase", taus="octave", confidence=None
        )
        np.testing.assert_allclose(a.dev, b.dev, rtol=1e-12)
        np.testing.assert_allclose(a.tau, a.m * 0.25)


def test_m_max_and_factors():
    assert te.m_max("mtie", 1001) == 1000
    ms, notes = te.factors("tierms", np.array([1, 5, 7]))
    np.testing.assert_array_equal(ms, [1, 5, 7])
    assert notes == ()
    got = adavar.deviation(np.arange(10.0), stat="mtie", rate=1.0, taus="all", confidence=None)
    assert got.m[-1] == 10  # one window: the whole record


def test_edf():
    assert math.isnan(te.edf("mtie", 0, 4, 1000))
    assert math.isnan(te.edf("tierms", -1, 4, 1000))
    assert te.edf("tierms", 0, 8, 1024) == greenhall_edf(
        0, 1, 8, 1024, overlapping=True, modified=False
    )
    assert te.edf("tierms", 3, 8, 1024) == te.edf("tierms", 2, 8, 1024)


# ---------------------------------------------------------------------------------------
# Stable32


def _rows(path):
    out = []
    with open(path, encoding="latin-1") as f:
        for line in f:
            parts = line.split()
            if not line.startswith("#") and len(parts) == 4:
                out.append([float(v) for v in parts])
    return np.array(out)


CASES = [
    ("phasedat/PHASE.DAT", "phasedat/phase_dat_mtie.txt", "mtie"),
    ("phasedat/PHASE.DAT", "phasedat/phase_dat_tierms.txt", "tierms"),
    ("Cs5071A/5071A_phase.txt.gz", "Cs5071A/mtie_all.txt", "mtie"),
    ("Cs5071A/5071A_phase.txt.gz", "Cs5071A/mtie_decade.txt", "mtie"),
    ("Cs5071A/5071A_phase.txt.gz", "Cs5071A/tierms_decade.txt", "tierms"),
    ("Cs5071A/5071A_phase.txt.gz", "Cs5071A/tierms_all.txt", "tierms"),
    (
        "Keysight53230A_ti_noise_floor/tic_phase.txt",
        "Keysight53230A_ti_noise_floor/tic_tierms.txt",
        "tierms",
    ),
]
_DATA: dict[str, np.ndarray] = {}


@pytest.mark.parametrize("data, table, stat", CASES, ids=[c[1] for c in CASES])
def test_stable32(data, table, stat):
    root = stable32_root() / "tests"
    if data not in _DATA:
        _DATA[data] = read_data(root / data)
    x = _DATA[data]
    rows = _rows(root / table)
    got = adavar.deviation(
        x, stat=stat, rate=1.0, data_type="phase", taus=rows[:, 0], confidence=None
    )
    np.testing.assert_array_equal(got.m, rows[:, 0])
    printed = np.array([float(f"{v:.4e}") for v in got.dev])
    np.testing.assert_array_equal(printed, rows[:, 3])
    if table != "Cs5071A/mtie_decade.txt":  # that table prints N in its "#" column
        np.testing.assert_array_equal(got.n, rows[:, 2])


def test_mtie_table_in_any_factor_order():
    """The doubling table is built in increasing m whatever the order asked, exactly."""
    rng = np.random.default_rng(5)
    u = rng.standard_normal(300) + 1e6  # a frequency offset: MTIE ~ 1e6 m
    ms = np.array([299, 1, 64, 63, 65, 2, 128, 3, 200], dtype=np.int64)
    values, n = te.squared("mtie", u, ms)
    ref = np.array([mtie_ref(u, int(m)) for m in ms])
    np.testing.assert_allclose(np.sqrt(values), ref, rtol=1e-15, atol=0)
    np.testing.assert_array_equal(n, 301 - ms)
    order = np.argsort(ms)
    np.testing.assert_array_equal(te.squared("mtie", u, ms[order])[0], values[order])

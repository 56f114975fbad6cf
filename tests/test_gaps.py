"""``deviation(..., gaps="omit")``: records with missing (NaN) samples (adavar.stats.gaps).

The fast path is checked against a slow, obviously correct reference: a loop over every
term of the statistic that skips the terms touching a missing sample (the rules of the
:mod:`adavar.stats.gaps` docstring, written out again here) and sums the rest exactly
(``math.fsum`` over the terms of :mod:`tests.reference`). The long coverage simulation is
``benchmarks/bench_gaps.py``.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import adavar
from adavar import simulate as sim
from adavar._kernels import differences as diff
from adavar.core.errors import AdavarInputError
from adavar.readers import read_record
from adavar.stats import gaps
from adavar.stats.noise_id import decimated_phase_lag1

from .cli_helpers import assert_one_line_error, run
from .reference import _modified_terms, _pd, d2_terms, d3_terms

STATS = gaps.GAP_STATISTICS


# --------------------------------------------------------------------------------------
# the reference


def touches_missing(missing, i, m, stat, phase):
    """Whether the term of ``stat`` starting at phase point ``i`` uses a missing sample."""
    order = 3 if stat in ("hdev", "ohdev") else 2
    if stat in ("mdev", "tdev"):  # its three m-sums: points i .. i+3m-1
        span = range(i, i + 3 * m) if phase else range(i, i + 3 * m - 1)
    elif phase:  # only its own points
        span = [i + k * m for k in range(order + 1)]
    else:  # the rate samples between its first and last point
        span = range(i, i + order * m)
    return any(missing[j] for j in span)


def reference_variance(y, m, stat, phase):
    """(variance, kept terms) of ``stat`` at ``m``, skipping the terms touching a NaN."""
    missing = np.isnan(y)
    npts = y.size if phase else y.size + 1
    order = 3 if stat in ("hdev", "ohdev") else 2
    if stat in ("oadev", "ohdev"):
        starts = range(npts - order * m)
    elif stat in ("adev", "hdev"):
        starts = [q * m for q in range((npts - 1) // m - order + 1)]
    else:
        starts = range(npts - 3 * m + 1)
    squares = []
    for i in starts:
        if touches_missing(missing, i, m, stat, phase):
            continue
        if stat in ("mdev", "tdev"):
            terms = _modified_terms(y, i, m, phase)
        elif phase:
            terms = _pd(y, i, m, (1, -2, 1) if order == 2 else (-1, 3, -3, 1))
        else:
            terms = d2_terms(y, i, m) if order == 2 else d3_terms(y, i, m)
        value = math.fsum(terms)
        squares.append(value * value)
    n = len(squares)
    if n == 0:
        return math.nan, 0
    total = math.fsum(squares)
    if stat in ("mdev", "tdev"):
        var = total / (2.0 * m**4 * n)
        return (var * m * m / 3.0 if stat == "tdev" else var), n
    return total / ((6.0 if order == 3 else 2.0) * m * m * n), n


def punch(x, seed, fraction=0.1, longest=64):
    """``x`` with about ``fraction`` of its samples missing, in gaps of 1..longest."""
    rng = np.random.default_rng(10_000 + seed)
    x = np.array(x, dtype=np.float64)
    missing = np.zeros(x.size, dtype=bool)
    while missing.mean() < fraction:
        start = int(rng.integers(0, x.size))
        missing[start : start + int(rng.integers(1, longest + 1))] = True
    x[missing] = np.nan
    return x


# --------------------------------------------------------------------------------------
# agreement with the reference


@pytest.mark.parametrize("data_type", ["rate", "phase"])
@pytest.mark.parametrize("stat", STATS)
def test_matches_reference_on_random_gaps(stat, data_type):
    rng = np.random.default_rng(3)
    y = 1e6 + rng.standard_normal(300) + np.linspace(0.0, 40.0, 300)  # offset and drift
    if data_type == "phase":
        y = np.cumsum(y)
    y[rng.random(300) < 0.05] = np.nan
    y[100:117] = np.nan
    r = adavar.deviation(y, stat=stat, data_type=data_type, taus="all", confidence=None,
                         gaps="omit")  # fmt: skip
    for m, dev, n in zip(r.m, r.dev, r.n, strict=True):
        var, kept = reference_variance(y, int(m), stat, data_type == "phase")
        assert n == kept
        assert dev == pytest.approx(math.sqrt(var), rel=1e-9)
    everything = set(range(1, int(r.m[-1]) + 1))
    for m in sorted(everything - set(r.m.tolist())):  # dropped: no term kept there
        assert reference_variance(y, m, stat, data_type == "phase")[1] == 0


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=st.integers(16, 140),
    seed=st.integers(0, 2**32 - 1),
    stat=st.sampled_from(STATS),
    data_type=st.sampled_from(["rate", "phase"]),
    offset=st.sampled_from([0.0, -3e5, 1e9]),
    drift=st.sampled_from([0.0, 5.0, -1e4]),
    level_step=st.sampled_from([0.0, 30.0, -1e3]),
    exponent=st.sampled_from([-960, -40, 0, 40, 960]),  # 1e-289 .. 1e289
    fraction=st.sampled_from([0.02, 0.1, 0.3]),
    run=st.integers(0, 12),
)
def test_property_matches_reference(n, seed, stat, data_type, offset, drift, level_step,
                                    exponent, fraction, run):  # fmt: skip
    rng = np.random.default_rng(seed)
    base = rng.standard_normal(n) + offset + drift * np.arange(n) / n
    base[n // 2 :] += level_step
    phase = data_type == "phase"
    if phase:
        base = np.cumsum(base)
    base[rng.random(n) < fraction] = np.nan
    start = int(rng.integers(0, n))
    base[start : start + run] = np.nan
    y = np.ldexp(base, exponent)  # exact: the reference runs on ``base`` (no overflow)
    if np.count_nonzero(~np.isnan(y)) < (4 if phase else 3):
        with pytest.raises(AdavarInputError, match="not missing"):
            adavar.deviation(y, stat=stat, data_type=data_type, gaps="omit")
        return
    max_m = gaps.inputs.largest_factor(stat, n if phase else n + 1)
    want = {m: reference_variance(base, m, stat, phase) for m in range(1, max_m + 1)}
    try:
        r = adavar.deviation(y, stat=stat, data_type=data_type, taus="all",
                             confidence=None, gaps="omit")  # fmt: skip
    except AdavarInputError as exc:
        assert "no difference term" in str(exc) or "no averaging time" in str(exc)
        assert all(k == 0 for _, k in want.values()) or "no averaging time" in str(exc)
        return
    assert r.m.tolist() == [m for m, (_, k) in want.items() if k > 0]
    assert r.n.tolist() == [want[int(m)][1] for m in r.m]
    expected = np.ldexp(np.sqrt([want[int(m)][0] for m in r.m]), exponent)
    np.testing.assert_allclose(r.dev, expected, rtol=1e-8, atol=0)


def test_no_nan_is_the_gap_free_path_exactly():
    y = np.random.default_rng(0).standard_normal(3000)
    for stat in (*STATS, "totdev", "theo1"):
        for data_type in ("rate", "phase"):
            a = adavar.deviation(y, stat=stat, data_type=data_type)
            b = adavar.deviation(y, stat=stat, data_type=data_type, gaps="omit")
            for field in ("tau", "dev", "dev_low", "dev_high", "edf", "n", "m", "alpha"):
                np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
            assert a.notes == b.notes


@pytest.mark.parametrize("stat", ["oadev", "ohdev", "mdev"])
def test_gaps_equal_the_pooled_terms_of_the_gap_free_pieces(stat):
    """Rate data, overlapping statistics: the kept terms are the terms of the gap-free
    pieces, so the variance is the term-weighted mean of the pieces' variances."""
    rng = np.random.default_rng(8)
    y = rng.standard_normal(2000) + 50.0
    cuts = [(0, 400), (409, 1100), (1101, 1130), (1170, 2000)]
    holes = np.ones(y.size, dtype=bool)
    for a, b in cuts:
        holes[a:b] = False
    gapped = np.where(holes, np.nan, y)
    ms = [1, 2, 5, 13, 40, 100]
    r = adavar.deviation(gapped, stat=stat, taus=np.array(ms, float), confidence=None,
                         gaps="omit")  # fmt: skip
    for m, dev, n in zip(r.m, r.dev, r.n, strict=True):
        sums, count = 0.0, 0
        for a, b in cuts:
            try:
                p = adavar.deviation(y[a:b], stat=stat, taus=[float(m)], confidence=None)
            except AdavarInputError:  # too short for this tau
                continue
            if p.m.size and p.m[0] == m:
                sums += float(p.dev[0]) ** 2 * int(p.n[0])
                count += int(p.n[0])
        assert n == count
        assert dev**2 == pytest.approx(sums / count, rel=1e-10)


# --------------------------------------------------------------------------------------
# the rules, one by one


def test_phase_allan_term_uses_only_its_own_points():
    x = np.cumsum(np.random.default_rng(1).standard_normal(41))
    x[5] = np.nan
    r = adavar.deviation(x, data_type="phase", taus=[4.0], confidence=None, gaps="omit")
    # point 5 is used by the terms starting at 5 (i), 1 (i + m) and none other (i + 2m = 5
    # needs i = -3): 41 - 8 = 33 terms, two dropped
    assert r.n.tolist() == [31]
    m = adavar.deviation(x, stat="mdev", data_type="phase", taus=[4.0], confidence=None,
                         gaps="omit")  # fmt: skip
    assert m.n.tolist() == [41 - 12 + 1 - 6]  # windows i..i+11 holding 5: i = 0..5


def test_rate_term_spans_its_samples():
    y = np.random.default_rng(2).standard_normal(40)
    y[10] = np.nan
    r = adavar.deviation(y, taus=[3.0], confidence=None, gaps="omit")
    assert r.n.tolist() == [41 - 6 - 6]  # terms over samples i..i+5 holding 10: i = 5..10
    h = adavar.deviation(y, stat="hdev", taus=[3.0], confidence=None, gaps="omit")
    assert h.n.tolist() == [40 // 3 - 2 - 3]  # strided starts 3, 6, 9 hold sample 10


def test_notes_count_the_missing_samples():
    y = np.random.default_rng(3).standard_normal(500)
    y[[3, 4, 5, 100]] = np.nan
    r = adavar.deviation(y, gaps="omit")
    note = next(n for n in r.notes if n.startswith("gaps='omit'"))
    assert "4 of 500 samples are missing (NaN), in 2 gap(s) of up to 3 samples" in note
    assert r.n_samples == 500


def test_masked_samples_are_missing_samples():
    y = np.random.default_rng(4).standard_normal(400)
    masked = np.ma.masked_array(y, mask=np.arange(400) % 37 == 0)
    a = adavar.deviation(masked, gaps="omit", confidence=None)
    b = adavar.deviation(masked.filled(np.nan), gaps="omit", confidence=None)
    np.testing.assert_array_equal(a.dev, b.dev)
    with pytest.raises(AdavarInputError, match="masked"):
        adavar.deviation(masked)


# --------------------------------------------------------------------------------------
# errors


def test_nan_without_omit_names_the_way_out():
    y = np.ones(100)
    y[7] = np.nan
    with pytest.raises(AdavarInputError, match="sample 7 is nan: pass gaps='omit'"):
        adavar.deviation(y)


@pytest.mark.parametrize("stat", ["totdev", "theo1", "mtie"])
def test_statistics_without_a_gap_rule_are_refused(stat):
    y = np.random.default_rng(5).standard_normal(200)
    y[50] = np.nan
    with pytest.raises(AdavarInputError, match=f"stat='{stat}' with gaps='omit'.*oadev"):
        adavar.deviation(y, stat=stat, gaps="omit")


def test_bad_values_and_options():
    y = np.random.default_rng(6).standard_normal(200)
    y[50] = np.nan
    with pytest.raises(AdavarInputError, match="unknown gaps 'skip'"):
        adavar.deviation(y, gaps="skip")
    inf = y.copy()
    inf[60] = np.inf
    with pytest.raises(AdavarInputError, match="sample 60 is inf"):
        adavar.deviation(inf, gaps="omit")
    with pytest.raises(AdavarInputError, match="leave out chunk_size"):
        adavar.deviation(y, gaps="omit", chunk_size=64)
    with pytest.raises(AdavarInputError, match="no difference term of oadev"):
        adavar.deviation(np.where(np.arange(200) % 2 == 0, np.nan, y), gaps="omit")
    with pytest.raises(AdavarInputError, match="bias_correction does not apply"):
        adavar.deviation(y, gaps="omit", bias_correction=True)
    with pytest.raises(AdavarInputError, match="2 samples that are not missing"):
        adavar.deviation(np.array([1.0, np.nan, 2.0, np.nan]), gaps="omit")


def test_out_of_core_record_with_nan_is_read_into_memory(tmp_path):
    y = np.random.default_rng(7).standard_normal(5000)
    np.save(tmp_path / "clean.npy", y)
    clean = np.load(tmp_path / "clean.npy", mmap_mode="r")
    a = adavar.deviation(clean, gaps="omit")  # streamed as before
    np.testing.assert_array_equal(a.dev, adavar.deviation(clean).dev)
    y[4000:4010] = np.nan
    np.save(tmp_path / "gapped.npy", y)
    mapped = np.load(tmp_path / "gapped.npy", mmap_mode="r")
    b = adavar.deviation(mapped, gaps="omit")
    np.testing.assert_array_equal(b.dev, adavar.deviation(y, gaps="omit").dev)
    assert any("read into memory" in n for n in b.notes)
    with pytest.raises(AdavarInputError, match="leave out chunk_size"):
        adavar.deviation(mapped, gaps="omit", chunk_size=1024)


# --------------------------------------------------------------------------------------
# noise identification and intervals


@pytest.mark.parametrize("make", [sim.white, sim.flicker, sim.random_walk])
def test_kept_lag1_statistics_without_gaps_are_the_usual_ones(make):
    u = make(6000, seed=3) + 4.0
    phase = diff.anchored_phase(u)
    for m in (1, 3, 32):
        count = (phase.n_points - 1) // m
        z = diff.cluster_differences(phase.r, phase.hh, phase.hl, m, count)
        got = gaps.gap_rate_lag1(z, np.ones(count, dtype=bool), 3)
        want = diff.cluster_lag1(phase, m, 3)
        np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(got[1], want[1], rtol=1e-12)
        np.testing.assert_array_equal(got[2], want[2])
        assert got[3] == want[3]
        p = np.concatenate(([0.0], np.cumsum(z)))
        one = gaps.gap_phase_lag1(p, np.ones(count + 1, dtype=bool))
        ref = decimated_phase_lag1(z)
        assert one[0] == pytest.approx(ref[0], abs=1e-12) and one[2] == ref[2]
        assert one[1] == pytest.approx(ref[1], rel=1e-12) and one[3] == ref[3]


@pytest.mark.parametrize(
    ("make", "data_type", "alpha"),
    [
        (lambda s: sim.white(8192, seed=s), "rate", 0),
        (lambda s: sim.flicker(8192, seed=s), "rate", -1),
        (lambda s: sim.random_walk(8192, seed=s), "rate", -2),
        (lambda s: sim.white(8193, seed=s), "phase", 2),
        (lambda s: np.cumsum(sim.white(8193, seed=s)), "phase", 0),
    ],
)
def test_noise_type_is_identified_on_the_kept_data(make, data_type, alpha):
    """10 % missing in gaps of up to 64: lag-1 on the kept clusters (m <= 16 here), the B1
    ratio on the longest run of kept clusters or the neighbour's type beyond."""
    right = []
    for seed in range(12):
        r = adavar.deviation(punch(make(seed), seed), data_type=data_type, taus=[2, 8, 16],
                             gaps="omit")  # fmt: skip
        right.append(r.alpha == alpha)
    assert np.mean(right) >= 0.75, np.mean(right, axis=0)


def test_edf_is_that_of_a_gap_free_record_with_as_many_terms():
    y = punch(sim.white(4096, seed=1), 1)
    for stat in STATS:
        r = adavar.deviation(y, stat=stat, taus=[1, 4, 16], noise_id="sp1065", gaps="omit")
        for m, n, a, e in zip(r.m, r.n, r.alpha, r.edf, strict=True):
            points = int(gaps.effective_points(stat, int(m), int(n)))
            assert e == adavar.stats.edf.edf(stat, int(a), int(m), points)
            # a gap-free record of that length has exactly n terms
            full = adavar.deviation(sim.white(points - 1, seed=2), stat=stat,
                                    taus=[float(m)], confidence=None)  # fmt: skip
            assert full.n.tolist() == [n]


RECORDS = 300
BAND = (0.60, 0.77)


@pytest.fixture
def one_thread():
    old = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(old)


@pytest.mark.parametrize(
    ("noise", "make"),
    [("white FM", lambda s: sim.white(4096, seed=s)),
     ("flicker FM", lambda s: sim.flicker(4096, seed=s))],
)  # fmt: skip
@pytest.mark.parametrize("stat", ["oadev", "mdev"])
def test_intervals_cover_with_ten_percent_missing(one_thread, noise, make, stat):
    """Coverage of the 68.3 % interval, 10 % of the samples missing in random gaps of
    1..64 samples. Truth: the mean gap-free variance over independent records (exact for
    white FM: 1/m for oadev). 300 records: binomial scatter 2.7 %."""
    taus = [4, 16, 64]
    truth = np.mean([adavar.deviation(make(10**6 + s), stat=stat, taus=taus,
                                      confidence=None).dev ** 2
                     for s in range(150)], axis=0)  # fmt: skip
    if noise == "white FM" and stat == "oadev":
        truth = 1.0 / np.array(taus)
    hits = []
    for seed in range(RECORDS):
        r = adavar.deviation(punch(make(seed), seed), stat=stat, taus=taus, gaps="omit")
        assert r.m.tolist() == taus
        hits.append((r.dev_low**2 <= truth) & (truth <= r.dev_high**2))
    cover = np.mean(hits, axis=0)
    assert np.all((BAND[0] <= cover) & (cover <= BAND[1])), (noise, stat, cover)


# --------------------------------------------------------------------------------------
# reading records with missing samples, and the command line


def _csv_with_missing_rows(path, n=2400, rate=50.0):
    rng = np.random.default_rng(11)
    y = rng.standard_normal(n)
    present = np.ones(n, dtype=bool)
    present[[700, 701, 702]] = False  # missing rows: a gap in the time stamps
    present[1500:1540] = False
    lines = ["time,gx"]
    for k in np.flatnonzero(present):
        cell = "" if k in (40, 41, 900) else repr(float(y[k]))  # empty cells
        lines.append(f"{float(k / rate)!r},{cell}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    expected = y.copy()
    expected[~present] = np.nan
    expected[[40, 41, 900]] = np.nan
    return expected


def test_reader_marks_missing_stamps_and_keeps_nan(tmp_path):
    path = tmp_path / "gapped.csv"
    expected = _csv_with_missing_rows(path)
    record = read_record(path, gaps="nan", nan="keep")
    np.testing.assert_array_equal(record.channel(), expected)  # NaN where missing
    assert record.rate == 50.0 and record.meta["n_missing_inserted"] == 43
    assert record.meta["nan_values_kept"] == {"gx": 3}
    np.testing.assert_allclose(record.time, np.arange(expected.size) / 50.0, atol=1e-12)
    with pytest.raises(AdavarInputError, match="gap of"):
        read_record(path, nan="keep")
    # a row whose time stamp is missing is dropped, then marked missing like a gap
    text = path.read_text().splitlines()
    text[11] = "," + text[11].split(",")[1]
    path.write_text("\n".join(text) + "\n")
    record = read_record(path, gaps="nan", nan="keep")
    assert np.isnan(record.channel()[10]) and record.meta["nan_time_rows_dropped"] == 1
    assert record.channel().size == expected.size


def test_reader_keeps_nan_without_a_time_column(tmp_path):
    path = tmp_path / "cells.csv"
    path.write_text("a,b\n1,2\n,3\n4,\n5,6\n", encoding="utf-8")  # an empty last cell too
    record = read_record(path, rate=1.0, nan="keep")
    np.testing.assert_array_equal(record.channel("a"), [1.0, np.nan, 4.0, 5.0])
    np.testing.assert_array_equal(record.channel("b"), [2.0, 3.0, np.nan, 6.0])
    assert record.meta["nan_values_kept"] == {"a": 1, "b": 1}
    with pytest.raises(AdavarInputError, match="--gaps omit"):
        read_record(path, rate=1.0)


def test_cli_avar_gaps_omit_on_a_csv_with_missing_rows(capsys, tmp_path):
    path = tmp_path / "gapped.csv"
    expected = _csv_with_missing_rows(path)
    code, out, err = run(capsys, ["avar", str(path), "--units", "deg/s", "--gaps", "omit",
                                  "--json"])  # fmt: skip
    assert code == 0, err
    import json

    payload = json.loads(out)
    want = adavar.deviation(expected, rate=50.0, gaps="omit")
    np.testing.assert_allclose(payload["dev"], want.dev, rtol=1e-12)
    assert payload["n"] == want.n.tolist()
    assert any("46 of 2400 samples are missing" in n for n in payload["notes"])
    code, out, err = run(capsys, ["avar", str(path), "--units", "deg/s"])
    assert_one_line_error(code, out, err, "--gaps omit")
    code, out, err = run(capsys, ["avar", str(path), "--units", "deg/s", "--gaps", "omit",
                                  "--stat", "totdev"])  # fmt: skip
    assert_one_line_error(code, out, err, "stat='totdev'", "oadev")

"""``davar(..., gaps="omit")``: the DAVAR surface of a record with missing samples.

The reference is the definition applied to every window alone, on the record with its NaN:
the mirror extension is built explicitly (rate samples repeated, ``np.pad`` symmetric; phase
points reflected, ``2 x[0] - x[j]``, so NaN propagates to where a sample is missing), each
term of the window is written on its samples and left out when one of them is NaN, and the
kept terms are exactly rounded (``math.fsum`` of split products for rate data, fractions for
phase points) before their squares are summed.
"""

from __future__ import annotations

import importlib
import json
import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import adavar
from adavar._kernels import _jit
from adavar.core.errors import AdavarInputError
from adavar.dynamic.surface import davar
from adavar.dynamic.surface_common import edf_of_counts
from adavar.dynamic.windows import window_overhang
from adavar.stats import stream
from adavar.stats.gaps import effective_points

from .cli_helpers import assert_one_line_error, run

davar_mod = importlib.import_module("adavar.dynamic.surface")
gaps_kernel = importlib.import_module("adavar._kernels.window_engine")

#: worst relative error of a kept cell against the exact reference (measured: see the
#: module's report; the gap-free kernels' bound is 1e-15)
EXACT = 1e-15
NAMES = {"oavar": "oadev", "ohvar": "ohdev", "mvar": "mdev"}


def _rate_weights(stat: str, m: int) -> tuple[np.ndarray, float]:
    """Weights of one term on the rate samples, and the normaliser (times the count)."""
    if stat == "oavar":
        return np.r_[-np.ones(m), np.ones(m)], 2.0 * m * m
    if stat == "ohvar":
        return np.r_[np.ones(m), -2.0 * np.ones(m), np.ones(m)], 6.0 * m * m
    w = np.zeros(3 * m - 1)
    for k in range(m):
        w[k : k + m] -= 1.0
        w[k + m : k + 2 * m] += 1.0
    return w, 2.0 * float(m) ** 4


def _point_weights(stat: str, m: int) -> tuple[dict[int, int], float]:
    """Weights of one term on the phase points (offset -> weight), and the normaliser."""
    if stat == "oavar":
        return {0: 1, m: -2, 2 * m: 1}, 2.0 * m * m
    if stat == "ohvar":
        return {0: -1, m: 3, 2 * m: -3, 3 * m: 1}, 6.0 * m * m
    w: dict[int, int] = {}
    for k in range(m):
        for off, c in ((k, 1), (k + m, -2), (k + 2 * m, 1)):
            w[off] = w.get(off, 0) + c
    return w, 2.0 * float(m) ** 4


def _exact(values: np.ndarray, weights: np.ndarray) -> float:
    """``sum weights * values`` exactly rounded (Veltkamp split: every product exact)."""
    c = 134217729.0 * values
    hi = c - (c - values)
    return math.fsum(np.concatenate([hi * weights, (values - hi) * weights]).tolist())


def reference(y, result, stat, data_type):
    """(avar, kept) of every cell of ``result``'s windows by the definition (module notes)."""
    ms, centres, lengths = result.m, result.centre, result.window
    x = np.asarray(y, dtype=np.float64)
    n = x.size if data_type == "rate" else x.size - 1
    start = centres - (lengths - 1) // 2
    pb = max(0, -int(start.min()))
    pa = max(0, int((start + lengths).max()) - n)
    if data_type == "rate":
        ext = np.pad(x, (pb, pa), mode="symmetric")
    else:
        pts: list[Fraction | None] = [None if math.isnan(v) else Fraction(v) for v in x]
        ext_pts: list[Fraction | None] = []
        for j in range(pb, 0, -1):  # 2 x[0] - x[j]: unknown if either is
            ext_pts.append(None if pts[0] is None or pts[j] is None else 2 * pts[0] - pts[j])
        ext_pts += pts
        for j in range(1, pa + 1):
            ok = pts[n] is not None and pts[n - j] is not None
            ext_pts.append(2 * pts[n] - pts[n - j] if ok else None)
    avar = np.full((centres.size, ms.size), np.nan)
    kept = np.zeros((centres.size, ms.size), dtype=np.int64)
    for c in range(centres.size):
        a, L = int(start[c]) + pb, int(lengths[c])
        for t, m in enumerate(int(v) for v in ms):
            if 3 * m > L:
                continue
            squares = []
            if data_type == "rate":
                w, norm = _rate_weights(stat, m)
                for i in range(a, a + L - w.size + 1):
                    seg = ext[i : i + w.size]
                    if not np.isnan(seg).any():
                        squares.append(_exact(seg, w) ** 2)
            else:
                wp, norm = _point_weights(stat, m)
                span = max(wp) + 1
                for i in range(a, a + L + 1 - span + 1):
                    # the modified term uses every point of its span; the others theirs
                    used = range(i, i + span) if stat == "mvar" else [i + o for o in wp]
                    if any(ext_pts[j] is None for j in used):
                        continue
                    term = sum(cw * ext_pts[i + o] for o, cw in wp.items())
                    squares.append(float(term) ** 2)
            kept[c, t] = len(squares)
            if squares:
                avar[c, t] = math.fsum(squares) / (norm * len(squares))
    return avar, kept


def _record(draw_n, seed, data_type, offset, step_size, drift, scale, gap_rate, runs):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(draw_n)
    x[rng.integers(draw_n) :] += step_size
    x += offset + drift * np.linspace(0.0, 1.0, draw_n)
    if data_type == "phase":
        x = np.cumsum(x) if offset == 0 else x  # a phase with a rate offset, or a level
        # on a grid of 2**-20 times a power of two: the increments np.diff are exact, as
        # the reference's points are (the rounding of a phase's differences is the
        # input's, with or without gaps)
        x = np.round(x * 2.0**20) * 2.0 ** (round(math.log2(scale)) - 20)
    else:
        x *= scale
    missing = rng.random(draw_n) < gap_rate
    for _ in range(runs):
        k = int(rng.integers(draw_n))
        missing[k : k + int(rng.integers(1, 12))] = True
    keep = rng.choice(draw_n, 5, replace=False)
    missing[keep] = False  # enough samples left
    x[missing] = np.nan
    return x


CASES = dict(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(30, 110),
    window=st.integers(6, 40),
    step=st.sampled_from([1, 1, 3, 17]),  # 17: windows far apart, each over its own span
    edges=st.sampled_from(["mirror", "valid"]),
    offset=st.sampled_from([0.0, 1e9]),
    step_size=st.sampled_from([0.0, 1e6]),
    drift=st.sampled_from([0.0, 1e3]),
    scale=st.sampled_from([1e-13, 1.0, 1e12]),
    gap_rate=st.sampled_from([0.0, 0.03, 0.2]),
    runs=st.integers(0, 3),
)


def _check_against_reference(stat, data_type, **case):
    n = case.pop("n")
    window = min(case.pop("window"), n - 1)
    edges = case.pop("edges")
    step = case.pop("step")
    step = step if edges == "mirror" else 1  # a valid centre at every step
    y = _record(n, data_type=data_type, **case)
    if np.isnan(y).sum() == 0:
        y[n // 2] = np.nan
    got = davar(y, window=window, stat=stat, data_type=data_type, taus="octave", edges=edges,
                step=step, confidence=None, gaps="omit")  # fmt: skip
    want, kept = reference(y, got, stat, data_type)
    np.testing.assert_array_equal(got.terms, kept)
    np.testing.assert_array_equal(np.isnan(got.avar), np.isnan(want))
    ok = np.isfinite(want)
    # a lone kept term centred on a mirror edge is exactly zero: then so must the cell be
    err = np.abs(got.avar[ok] - want[ok]) / np.where(want[ok] > 0, want[ok], 1.0)
    assert err.max(initial=0.0) <= EXACT, err.max()
    return float(err.max(initial=0.0))


@pytest.mark.parametrize("stat", ["oavar", "ohvar", "mvar"])
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(**CASES)
def test_rate_windows_match_the_reference(stat, **case):
    _check_against_reference(stat, "rate", **case)


@pytest.mark.parametrize("stat", ["oavar", "ohvar", "mvar"])
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(**CASES)
def test_phase_windows_match_the_reference(stat, **case):
    _check_against_reference(stat, "phase", **case)


@pytest.mark.parametrize("stat", ["oavar", "mvar"])
def test_quiet_windows_next_to_a_burst_keep_their_digits(stat):
    """A burst of 1e12 sigma in the span: the quiet windows after it take the three-part
    prefix (the floor test counts the summed terms, kept or zeroed)."""
    rng = np.random.default_rng(14)
    y = rng.standard_normal(400) + 1e9
    y[100:103] += 1e12
    y[rng.random(400) < 0.05] = np.nan
    got = davar(y, window=40, stat=stat, taus="octave", confidence=None, gaps="omit")
    want, kept = reference(y, got, stat, "rate")
    np.testing.assert_array_equal(got.terms, kept)
    np.testing.assert_allclose(got.avar, want, rtol=EXACT)


def test_missing_end_point_of_phase_removes_the_mirrored_terms():
    """Phase data: the reflected points ``2 x[0] - x[j]`` are unknown when ``x[0]`` is."""
    y = np.cumsum(np.random.default_rng(3).standard_normal(60))
    y[0] = np.nan
    got = davar(y, window=20, data_type="phase", taus=[1, 2], confidence=None, gaps="omit")
    want, kept = reference(y, got, "oavar", "phase")
    np.testing.assert_array_equal(got.terms, kept)
    np.testing.assert_allclose(got.avar, want, rtol=EXACT)
    assert got.terms[0, 0] < got.terms[30, 0]  # the first window lost its mirrored terms


@pytest.mark.parametrize("stat", ["oavar", "ohvar", "mvar"])
@pytest.mark.parametrize("data_type", ["rate", "phase"])
def test_without_nan_the_gap_free_result(stat, data_type):
    x = np.random.default_rng(4).standard_normal(900) + 1e6
    options = dict(window=120, stat=stat, data_type=data_type, taus="octave")
    a = davar(x, **options)
    b = davar(x, **options, gaps="omit")
    np.testing.assert_array_equal(a.avar, b.avar)
    np.testing.assert_array_equal(a.edf, b.edf)
    assert b.terms is None and a.notes == b.notes


@pytest.mark.parametrize("stat", ["oadev", "ohdev", "mdev"])
def test_kernel_without_missing_samples_is_the_gap_free_kernel(stat):
    """Zero keep flags change nothing: the same bits as the engine without gaps, on
    overlapping windows, an adaptive schedule and sparse centres."""
    rng = np.random.default_rng(5)
    u = rng.standard_normal(5000) * 1e-3 + 1e9
    u[2000:] += 1e6
    ms = np.array([1, 2, 5, 17, 40], dtype=np.int64)
    zero_cnt = np.zeros(u.size + 2, dtype=np.int64)
    zero_pm = np.zeros(u.size + 1, dtype=np.uint8)
    ws = 2 * ms if stat == "oadev" else 3 * ms
    schedules = [
        (np.arange(100, 4800), np.full(4700, 200)),
        (np.arange(100, 4800), rng.integers(120, 201, 4700)),
        (np.arange(100, 4800, 500), np.full(10, 150)),
    ]
    for centres, lengths in schedules:
        got, kept = gaps_kernel.window_gaps(u, ms, centres, lengths, stat=stat, cnt=zero_cnt,
                                            pm=zero_pm, ws=ws, chunk=256)  # fmt: skip
        want = davar_mod._window_surface(stat, u, ms, centres, lengths, chunk=256)
        np.testing.assert_array_equal(got, want)
        assert np.array_equal(kept == 0, np.isnan(want))


@pytest.mark.parametrize("stat", ["oavar", "mvar"])
def test_serial_and_parallel_twins_agree_bit_for_bit(monkeypatch, stat):
    rng = np.random.default_rng(6)
    y = rng.standard_normal(6000) + 1e8
    y[rng.random(y.size) < 0.02] = np.nan
    y[3000:3100] = np.nan
    out = []
    for work in (1 << 62, 0):
        monkeypatch.setattr(_jit, "SERIAL_WORK", work)
        r = davar(y, window=300, stat=stat, taus="octave", confidence=None, gaps="omit")
        out.append((r.avar, r.terms))
    np.testing.assert_array_equal(out[0][0], out[1][0])
    np.testing.assert_array_equal(out[0][1], out[1][1])


def test_each_cell_gets_the_edf_of_its_kept_count():
    rng = np.random.default_rng(7)
    y = rng.standard_normal(3000)
    y[1000:1060] = np.nan
    r = davar(y, window=400, taus="octave", gaps="omit", edge_edf="interior")
    full = davar(np.nan_to_num(y), window=400, taus="octave", edge_edf="interior")
    assert r.n_terms is r.terms and r.edf.shape == r.avar.shape
    for t in (0, 3):
        m, a = int(r.m[t]), int(r.alpha[t])
        counts = np.unique(r.terms[:, t])
        counts = counts[counts > 0]
        assert np.all(effective_points("oadev", m, counts) == counts + 2 * m)
        want = dict(zip(counts.tolist(), edf_of_counts(counts, a, m), strict=True))
        got = r.edf[:, t]
        np.testing.assert_array_equal(got, [want[int(c)] for c in r.terms[:, t]])
    # where every term is kept, the gap-free window's EDF (to the interpolation, 1e-3)
    whole = (r.terms == r.terms.max(axis=0)).all(axis=1)
    whole &= (r.alpha == full.alpha).all()
    np.testing.assert_allclose(r.edf[whole], full.edf[whole], rtol=2e-3)
    low, high = r.avar_low, r.avar_high
    assert np.all(low[whole] < r.avar[whole]) and np.all(high[whole] > r.avar[whole])
    short = (r.terms > 0) & (r.terms < r.terms.max(axis=0))  # fewer terms: fewer degrees
    top = np.broadcast_to(np.nanmax(r.edf, axis=0), r.edf.shape)
    assert short.any() and np.all(r.edf[short] < top[short])
    assert np.isnan(r.edf[r.terms == 0]).all() and np.isnan(r.avar_low[r.terms == 0]).all()


def test_noise_types_are_those_of_the_whole_record_with_gaps():
    y = np.cumsum(np.random.default_rng(8).standard_normal(4000))  # random walk FM
    y[500:540] = np.nan
    r = davar(y, window=600, taus="octave", gaps="omit")
    dev = adavar.deviation(y, taus=r.tau, gaps="omit")
    np.testing.assert_array_equal(r.alpha, dev.alpha)


def test_mirror_windows_scale_their_kept_count():
    y = np.random.default_rng(9).standard_normal(2000)
    y[1500] = np.nan
    r = davar(y, window=200, taus=[1, 8, 32], gaps="omit")
    edge = window_overhang(r.centre, r.window, y.size) > 0
    full = davar(np.nan_to_num(y), window=200, taus=[1, 8, 32])
    clean = edge & (r.terms == full.n_terms).all(axis=1)
    np.testing.assert_allclose(r.edf[clean], full.edf[clean], rtol=2e-3)


def test_errors_are_one_line_with_the_way_out():
    y = np.random.default_rng(10).standard_normal(500)
    y[10] = np.nan
    with pytest.raises(AdavarInputError, match="gaps='omit'"):
        davar(y, window=100)
    with pytest.raises(AdavarInputError, match="unknown gaps"):
        davar(y, window=100, gaps="drop")
    with pytest.raises(AdavarInputError, match="leave out chunk_size"):
        davar(y, window=100, gaps="omit", chunk_size=64)
    with pytest.raises(AdavarInputError, match="at least 3"):
        davar(np.r_[1.0, np.full(20, np.nan), 2.0], window=10, gaps="omit")


def test_a_lazy_dask_surface_is_refused_with_the_way_out():
    da = pytest.importorskip("dask.array")
    y = np.random.default_rng(13).standard_normal(800)
    y[5] = np.nan
    with pytest.raises(AdavarInputError, match="lazy=False"):
        davar(da.from_array(y, chunks=200), window=100, gaps="omit")
    got = davar(da.from_array(y, chunks=200), window=100, gaps="omit", lazy=False)
    np.testing.assert_array_equal(got.avar, davar(y, window=100, gaps="omit").avar)


def test_chunked_records():
    rng = np.random.default_rng(11)
    y = rng.standard_normal(3000)
    source = stream.as_source(y)
    a = davar(source, window=300, taus="octave", gaps="omit")  # no NaN: out of core
    np.testing.assert_array_equal(a.avar, davar(source, window=300, taus="octave").avar)
    y[100:130] = np.nan
    b = davar(stream.as_source(y), window=300, taus="octave", gaps="omit")
    c = davar(y, window=300, taus="octave", gaps="omit")
    np.testing.assert_array_equal(b.avar, c.avar)
    assert any("read into memory" in note for note in b.notes)
    with pytest.raises(AdavarInputError, match="leave out chunk_size"):
        davar(stream.as_source(y), window=300, gaps="omit", chunk_size=1000)


def _csv_with_missing_rows(path, n=2400, rate=50.0):
    rng = np.random.default_rng(12)
    y = rng.standard_normal(n)
    present = np.ones(n, dtype=bool)
    present[700:703] = False  # missing rows: a gap in the time stamps
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


def test_cli_davar_gaps_omit_on_a_csv_with_missing_rows(capsys, tmp_path):
    path = tmp_path / "gapped.csv"
    expected = _csv_with_missing_rows(path)
    base = ["davar", str(path), "--units", "deg/s", "--window", "400", "--taus", "octave"]
    code, out, err = run(capsys, [*base, "--gaps", "omit", "--json"])
    assert code == 0, err
    payload = json.loads(out)
    want = davar(expected, window=400, taus="octave", rate=50.0, gaps="omit")
    assert payload["terms_kept"]["min"] == want.terms.min(axis=0).tolist()
    assert any("46 of 2400 samples are missing" in n for n in payload["notes"])
    assert payload["fit"]["n_fitted"] == want.avar.shape[0]
    code, out, err = run(capsys, base)
    assert_one_line_error(code, out, err, "--gaps omit")
    code, out, err = run(capsys, [*base, "--gaps", "omit", "--out", str(tmp_path / "o")])
    assert code == 0, err
    assert (tmp_path / "o" / "surface.nc").exists()

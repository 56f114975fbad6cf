"""The dynamic Hadamard and modified Allan variances (``davar(stat="ohvar" | "mvar")``).

The reference is the definition applied to every window alone: each term is written on the
rate samples as a weighted sum (third differences of phase are ``B3 - 2 B2 + B1`` of the
``m``-sample block sums; a modified term is the sum of ``m`` consecutive second
differences) and taken exactly rounded (``math.fsum`` of the exact products), so it is
exact to an ulp whatever the offset, step or drift of the data.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.lib.stride_tricks import sliding_window_view
from scipy.stats import chi2

from adavar._kernels import _jit
from adavar.core.errors import AdavarInputError
from adavar.dynamic.surface import davar
from adavar.dynamic.surface_common import DavarStatResult
from adavar.fit.noise_model import fit_noise
from adavar.stats import edf as edf_mod
from adavar.stats import stream
from adavar.stats.statistics import deviation

from .cli_helpers import assert_one_line_error, run

#: worst relative error of a kernel cell against the exact reference (measured: 3.3e-16
#: over 1500 random cases)
EXACT = 1e-15
NAMES = {"oavar": "oadev", "ohvar": "ohdev", "mvar": "mdev"}


def _weights(stat: str, m: int) -> tuple[np.ndarray, float]:
    """Weights of one term on the rate samples, and the normaliser (times the term count)."""
    if stat == "oavar":
        return np.r_[-np.ones(m), np.ones(m)], 2.0 * m * m
    if stat == "ohvar":
        return np.r_[np.ones(m), -2.0 * np.ones(m), np.ones(m)], 6.0 * m * m
    w = np.zeros(3 * m - 1)
    for k in range(m):  # m second differences, each -B1 + B2, from starts k
        w[k : k + m] -= 1.0
        w[k + m : k + 2 * m] += 1.0
    return w, 2.0 * float(m) ** 4


def _exact_terms(window: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Every term, exactly rounded: the products split (Veltkamp) so each is exact."""
    v = sliding_window_view(window, weights.size)
    c = 134217729.0 * v
    hi = c - (c - v)
    parts = np.concatenate([hi * weights, (v - hi) * weights], axis=1)
    return np.array([math.fsum(row) for row in parts])


def window_variance(window: np.ndarray, m: int, stat: str) -> float:
    """The statistic of one window of rate samples at ``m`` (NaN for ``3m > L``)."""
    if 3 * m > window.size:
        return math.nan
    weights, norm = _weights(stat, m)
    terms = _exact_terms(window, weights)
    return math.fsum(terms * terms) / (norm * terms.size)


def reference(x, window, stat, ms, *, edges="mirror", step=1, data_type="rate", tau0=1.0):
    """``(centre, length, surface)`` straight from the definition, window by window."""
    x = np.asarray(x, dtype=np.float64)
    v = np.diff(x) if data_type == "phase" else x
    unit = 1.0 / tau0**2 if data_type == "phase" else 1.0
    n = v.size
    centres = list(range(0, n, step))
    w = np.asarray(window)
    if w.ndim == 0:
        lengths = [int(w)] * len(centres)
    elif w.size == n:
        lengths = [int(w[p]) for p in centres]
    else:
        lengths = [int(k) for k in w]
    pairs = list(zip(centres, lengths, strict=True))
    if edges == "valid":
        pairs = [(p, L) for p, L in pairs if p - (L - 1) // 2 >= 0 and p - (L - 1) // 2 + L <= n]
    pad = max(L for _, L in pairs)
    ext = np.pad(v, pad, mode="symmetric")
    out = np.full((len(pairs), len(ms)), np.nan)
    for row, (p, L) in enumerate(pairs):
        a = pad + p - (L - 1) // 2
        for col, m in enumerate(ms):
            out[row, col] = unit * window_variance(ext[a : a + L], int(m), stat)
    centre = np.array([p for p, _ in pairs], dtype=np.int64)
    return centre, np.array([L for _, L in pairs], dtype=np.int64), out


def check(x, window, stat, *, rtol=EXACT, **kw):
    """davar against the reference at every cell; returns the result and the worst error."""
    kw.setdefault("confidence", None)
    opts = {k: kw[k] for k in ("edges", "step", "data_type", "tau0") if k in kw}
    res = davar(x, window=window, stat=stat, **kw)
    centre, length, want = reference(x, window, stat, res.m, **opts)
    np.testing.assert_array_equal(res.centre, centre)
    np.testing.assert_array_equal(res.window, length)
    np.testing.assert_array_equal(np.isnan(res.avar), np.isnan(want))
    ok = np.isfinite(want) & (want > 0)
    worst = float(np.max(np.abs(res.avar[ok] / want[ok] - 1.0), initial=0.0))
    assert worst <= rtol, worst
    return res, worst


def _noise(n, seed=0):
    return np.random.default_rng(seed).standard_normal(n)


# ---------------------------------------------------------------------------------------
# the surface against the definition


@pytest.mark.parametrize("stat", ["ohvar", "mvar"])
@pytest.mark.parametrize("L", [3, 4, 7, 20, 33])
def test_every_window_every_tau(stat, L):
    res, _ = check(_noise(120, seed=L), L, stat, taus="all")
    np.testing.assert_array_equal(res.m, np.arange(1, L // 3 + 1))
    assert isinstance(res, DavarStatResult) and res.stat == NAMES[stat]
    n = L + 1 - 3 * res.m + (stat == "mvar")  # L - 3m + 1 third differences, + 1 sums
    np.testing.assert_array_equal(res.n_terms[0], n)


@pytest.mark.parametrize("stat", ["ohvar", "mvar"])
def test_adversarial_records_cost_no_digits(stat):
    """A 1e9 offset with a 1e6-sigma level step, and quiet windows next to 1e12-sigma
    spikes: every cell to an ulp or two (the span is kept in double-double)."""
    x = 1e9 + _noise(1500, seed=3)
    x[700:] += 1e6
    check(x, 40, stat, taus="octave")
    check(x, 150, stat, taus="octave", step=7)
    y = _noise(1200, seed=4)
    for a in (100, 400, 800):
        y[a : a + 5] *= 1e12
    res, _ = check(y, 30, stat, taus="octave")
    assert res.avar[130, 0] < 1e-18 * res.avar[102, 0]  # quiet next to loud: still exact


@pytest.mark.parametrize("stat", ["ohvar", "mvar"])
def test_agrees_with_the_whole_record_statistic(stat):
    """A window inside the record is ``deviation(stat="ohdev" | "mdev")`` of its samples."""
    x = _noise(900, seed=5)
    res = davar(x, window=150, stat=stat, taus="octave", edges="valid", confidence=None)
    for row in (0, 321, res.centre.size - 1):
        a = int(res.centre[row]) - 74
        whole = deviation(x[a : a + 150], stat=NAMES[stat], taus=res.tau, confidence=None)
        np.testing.assert_allclose(res.avar[row], whole.dev**2, rtol=1e-12)


@st.composite
def _cases(draw):
    stat = draw(st.sampled_from(["ohvar", "mvar"]))
    n = draw(st.integers(20, 140))
    seed = draw(st.integers(0, 2**16))
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n)
    kind = draw(st.sampled_from(["noise", "offset", "step", "drift", "ramp", "burst"]))
    if kind == "offset":
        x += 1e9
    elif kind == "step":
        x[draw(st.integers(0, n - 1)) :] += 1e6
    elif kind == "drift":
        x += 1e9 + 1e3 * np.arange(n)
    elif kind == "ramp":  # a rate ramp: quadratic in phase
        x += 1e-3 * np.arange(n) ** 2
    elif kind == "burst":
        x[draw(st.integers(0, n - 1))] *= 1e10
    x *= draw(st.sampled_from([1e-13, 1.0, 1e12]))
    if draw(st.booleans()):
        x = x.astype(np.float32)
    data_type = draw(st.sampled_from(["rate", "phase"]))
    size = n - 1 if data_type == "phase" else n
    if draw(st.booleans()):
        window = draw(st.integers(3, min(size, 45)))
    else:
        window = rng.integers(3, min(size, 45) + 1, size=size)
    opts = {
        "edges": draw(st.sampled_from(["mirror", "valid"])),
        "step": draw(st.integers(1, 3)),
        "data_type": data_type,
        "tau0": draw(st.sampled_from([1.0, 0.1, 3.0])),
    }
    if opts["edges"] == "valid":  # a fixed window with a centre on the step grid
        window = int(min(np.min(window), size - opts["step"] + 1))
    return x, window, stat, opts


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_cases())
def test_random_and_adversarial_inputs(case):
    x, window, stat, opts = case
    check(x, window, stat, taus="octave", rate=None, **opts)


# ---------------------------------------------------------------------------------------
# what the Hadamard variance is for: a rate ramp adds nothing


def _dyadic_noise(n, seed):
    """White noise on a grid of 2**-20: adding an exact ramp to it rounds nothing."""
    return np.random.default_rng(seed).integers(-(2**20), 2**20, size=n) * 2.0**-20


def test_hadamard_is_blind_to_a_rate_ramp():
    n = 4000
    x = _dyadic_noise(n, 6)
    ramp = np.arange(n) * 2.0**-8  # slope 1/256 per sample: exact sums with x
    opts = {"window": 600, "taus": "octave", "edges": "valid", "confidence": None}
    quiet = davar(x, stat="ohvar", **opts).avar
    ramped = davar(x + ramp, stat="ohvar", **opts).avar
    assert np.nanmax(np.abs(ramped / quiet - 1.0)) < 1e-14  # rounding only
    # the Allan surface sees it: R**2 tau**2 / 2 on top of the noise (and a cross term
    # that averages out over the windows)
    allan = davar(x + ramp, **opts)
    extra = allan.avar - davar(x, **opts).avar
    assert np.mean(extra[:, -1]) == pytest.approx((2.0**-8 * allan.m[-1]) ** 2 / 2.0, rel=0.05)
    # mirrored ends fold the ramp into a V: only windows inside the record are blind
    mirror = davar(x + ramp, stat="ohvar", window=600, taus="octave", confidence=None)
    inside = (mirror.centre >= 299) & (mirror.centre <= n - 301)
    np.testing.assert_allclose(mirror.avar[inside], quiet, rtol=1e-14)
    assert mirror.avar[0, -1] > 10 * quiet[0, -1]


def test_a_ramp_on_phase_data_is_a_quadratic():
    n = 2000
    phase = np.cumsum(_dyadic_noise(n, 7))
    k = np.arange(n, dtype=np.float64)
    quadratic = k * k * 2.0**-12  # a rate ramp on phase data: still exact sums
    opts = {"window": 300, "taus": "octave", "edges": "valid", "confidence": None}
    a = davar(phase, stat="ohvar", data_type="phase", **opts).avar
    b = davar(phase + quadratic, stat="ohvar", data_type="phase", **opts).avar
    assert np.nanmax(np.abs(b / a - 1.0)) < 1e-14


# ---------------------------------------------------------------------------------------
# EDF and interval of every cell


def _edf_of_cell(stat, alpha, m, L, overhang):
    """The EDF rule written out: distinct terms of a window reaching into the mirror."""
    width = {"ohdev": 3 * m, "mdev": 3 * m - 1}[stat]
    terms = L + 1 - width
    repeats = max(0, overhang - width // 2)
    count = max(1, round(terms * terms / (terms + 2 * repeats)))
    return edf_mod.edf(stat, alpha, m, count + width)


@pytest.mark.parametrize("stat", ["ohvar", "mvar"])
def test_edf_and_interval_of_every_cell(stat):
    from adavar.dynamic.windows import window_overhang

    x = _noise(300, seed=8)
    lengths = np.random.default_rng(9).integers(6, 40, size=x.size)
    res = davar(x, window=lengths, stat=stat, taus="all", noise_type=-1, confidence=0.9)
    name = NAMES[stat]
    overhang = window_overhang(res.centre, res.window, x.size)
    for row in range(0, res.centre.size, 7):
        L, h = int(res.window[row]), int(overhang[row])
        for col, m in enumerate(res.m):
            got = res.edf[row, col]
            if 3 * m > L:
                assert np.isnan(got) and np.isnan(res.avar_low[row, col])
                continue
            assert got == pytest.approx(_edf_of_cell(name, -1, int(m), L, h), rel=1e-12)
            v = res.avar[row, col]
            assert res.avar_low[row, col] == pytest.approx(v * got / chi2.ppf(0.95, got))
            assert res.avar_high[row, col] == pytest.approx(v * got / chi2.ppf(0.05, got))
    # the interior EDF of the statistic, not of the Allan variance
    inner = davar(x, window=30, stat=stat, taus="octave", noise_type=0, edges="valid")
    want = [edf_mod.edf(name, 0, int(m), 31) for m in inner.m]
    np.testing.assert_allclose(inner.edf[0], want, rtol=1e-12)
    assert not np.allclose(want, [edf_mod.edf("oadev", 0, int(m), 31) for m in inner.m])


def test_noise_identification_follows_the_statistic():
    """Hadamard identifies with third differences (alpha down to -4) as deviation does."""
    walk = np.cumsum(np.cumsum(_noise(4000, seed=10)))  # random-run FM, alpha = -4
    had = davar(walk, window=1200, stat="ohvar", taus="octave", step=50)
    whole = deviation(walk, stat="ohdev", taus=had.tau)
    np.testing.assert_array_equal(had.alpha, whole.alpha)
    assert had.alpha.min() < -2
    assert davar(walk, window=1200, stat="mvar", taus="octave", step=50).alpha.min() >= -2
    assert davar(walk, window=1200, stat="ohvar", noise_type=-4, step=50).alpha[0] == -4
    with pytest.raises(AdavarInputError, match=r"alpha must lie in -2 \.\. 2"):
        davar(walk, window=1200, stat="mvar", noise_type=-3)


# ---------------------------------------------------------------------------------------
# every path of davar


@pytest.mark.parametrize("stat", ["ohvar", "mvar"])
def test_out_of_core_and_lazy_paths_equal_in_memory(stat):
    import dask.array as da

    x = 5e8 + _noise(3000, seed=11)
    x[1800:] += 1e5
    kw = {"window": 250, "stat": stat, "taus": "octave"}
    want = davar(x, **kw)
    for got in (
        davar(stream.ArraySource(x), chunk_size=700, **kw),
        davar(da.from_array(x, chunks=800), chunk_size=700, **kw),
    ):
        assert type(got) is DavarStatResult and got.stat == want.stat
        np.testing.assert_allclose(np.asarray(got.avar), want.avar, rtol=1e-15, equal_nan=True)
        np.testing.assert_array_equal(got.edf, want.edf)
        np.testing.assert_array_equal(got.alpha, want.alpha)


@pytest.mark.parametrize("stat", ["ohvar", "mvar"])
def test_serial_and_parallel_twins_are_bit_identical(monkeypatch, stat):
    from adavar._kernels.window_engine import window_variance as window_hvar

    rng = np.random.default_rng(12)
    x = rng.standard_normal(40_000) + 1e9 + np.linspace(0.0, 50.0, 40_000)
    x[13_000:] += 1e4
    ms = np.array([1, 2, 4, 8, 16, 32, 64], dtype=np.int64)
    centres = np.arange(300, 39_700, dtype=np.int64)
    lengths = np.where(centres % 1000 < 500, 600, 400).astype(np.int64)
    out = []
    for work in (1 << 62, 0):  # everything serial, then everything parallel
        monkeypatch.setattr(_jit, "SERIAL_WORK", work)
        out.append(window_hvar(x, ms, centres, lengths, stat=stat, chunk=512))
    np.testing.assert_array_equal(out[0], out[1])


def test_the_allan_default_is_unchanged():
    x = _noise(500, seed=13)
    a = davar(x, window=60)
    b = davar(x, window=60, stat="oavar")
    assert type(a) is type(b) and a.stat == "oadev"
    np.testing.assert_array_equal(a.avar, b.avar)
    np.testing.assert_array_equal(a.edf, b.edf)
    check(x, 60, "oavar", taus="octave")


def test_bad_stat_and_the_refused_fit():
    x = _noise(400, seed=14)
    with pytest.raises(AdavarInputError, match="use 'oavar', 'ohvar' or 'mvar'"):
        davar(x, window=60, stat="ohdev")
    for stat in ("ohvar", "mvar"):
        res = davar(x, window=60, stat=stat, taus="octave")
        with pytest.raises(AdavarInputError, match="defined for the Allan variance"):
            fit_noise(res)
        long_name = res.to_xarray()["avar"].attrs["long_name"]
        assert long_name == {"ohvar": "overlapping Hadamard variance",
                             "mvar": "modified Allan variance"}[stat]  # fmt: skip
        assert res.metadata()["statistic"] == NAMES[stat]


# ---------------------------------------------------------------------------------------
# the command line


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    x = np.random.default_rng(15).standard_normal(1500) + 1e-3 * np.arange(1500)
    path = tmp_path_factory.mktemp("stats") / "rec.csv"
    path.write_text("x\n" + "".join(f"{v!r}\n" for v in x.tolist()), encoding="utf-8")
    return path, x


@pytest.mark.parametrize("stat", ["oavar", "ohvar", "mvar"])
def test_cli_stat_and_json(capsys, record, stat):
    path, x = record
    argv = ["davar", str(path), "--rate", "10", "--units", "deg/s", "--window", "200",
            "--taus", "octave", "--stat", stat, "--json"]  # fmt: skip
    code, out, err = run(capsys, argv)
    assert code == 0, err
    payload = json.loads(out)
    assert payload["stat"] == stat
    want = davar(x, window=200, rate=10.0, taus="octave", stat=stat)
    np.testing.assert_array_equal(payload["alpha"], want.alpha)
    if stat == "oavar":
        assert payload["fit"] is not None
    else:
        assert payload["fit"] is None and any("Allan variance" in s for s in payload["notes"])
    code, out, err = run(capsys, argv[:-1])
    assert code == 0, err
    title = {"oavar": "Dynamic Allan deviation", "ohvar": "overlapping Hadamard deviation",
             "mvar": "modified Allan deviation"}[stat]  # fmt: skip
    assert title in out
    assert ("no noise fit" in out) == (stat != "oavar")


def test_cli_terms_with_another_stat_is_a_one_line_error(capsys, record):
    path, _ = record
    base = ["davar", str(path), "--rate", "10", "--units", "deg/s", "--window", "200"]
    code, out, err = run(capsys, [*base, "--stat", "ohvar", "--terms", "N"])
    assert_one_line_error(code, out, err, "--stat ohvar", "--stat oavar")
    code, out, err = run(capsys, [*base, "--stat", "hvar"])
    assert code == 2 and "--stat" in err

"""The ICI adaptive window (adavar.dynamic.ici) and one-sided DAVAR windows (davar(shift=)).

A slow, obviously correct reference of each: the Allan variance of one window summed term by
term with ``math.fsum`` over the mirror-extended record, the candidates' intervals and the
intersection rule written as loops; compared with the fast path on random and adversarial
records (offsets of 1e6, level steps, drift, float32, tiny and huge scales).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import ndtr
from scipy.stats import chi2

import adavar
from adavar import simulate
from adavar.comparison import compare
from adavar.core.errors import AdavarInputError
from adavar.dynamic.adaptive import adaptive_davar, adaptive_schedule
from adavar.dynamic.ici import (
    CENTRED,
    LEFT,
    RIGHT,
    correlation_edf,
    ici_candidates,
    ici_schedule,
    side_shift,
)
from adavar.dynamic.ici_episodes import kurtosis_edf
from adavar.paper.scenarios import paper_scenario

from .cli_helpers import assert_one_line_error, run

# ---------------------------------------------------------------------------------------
# the slow reference


def ref_window_avar(x: np.ndarray, start: int, length: int, m: int) -> float:
    """Overlapping AVAR (tau0 = 1) of ``length`` samples of the mirror-extended ``x`` from
    ``start`` (an index of the record; outside it, the time-reversed record)."""
    n = x.size
    idx = np.arange(start, start + length)
    idx = np.where(idx < 0, -idx - 1, idx)
    idx = np.where(idx >= n, 2 * n - 1 - idx, idx)
    w = [float(v) for v in x[idx]]
    terms = []
    for i in range(length - 2 * m + 1):
        d = math.fsum([w[i + m + k] - w[i + k] for k in range(m)])
        terms.append(d * d)
    return math.fsum(terms) / (2.0 * m * m * len(terms))


def ref_interval(v: float, nu: float, gamma: float) -> tuple[float, float]:
    q = float(ndtr(-gamma))
    y = math.log(max(v, np.finfo(float).tiny))
    return y - math.log(chi2.isf(q, nu) / nu), y - math.log(chi2.ppf(q, nu) / nu)


def ref_adapt(intervals: list[list[tuple[float, float]]]) -> tuple[int, float]:
    """Longest prefix whose intervals (each a list over m) all intersect; and the smallest
    gap of any comparison made (a near-tie can go either way in floating point)."""
    best, margin = -1, math.inf
    lo = [-math.inf] * len(intervals[0])
    hi = [math.inf] * len(intervals[0])
    for j, per_m in enumerate(intervals):
        ok = True
        for t, (a, b) in enumerate(per_m):
            lo[t], hi[t] = max(lo[t], a), min(hi[t], b)
            margin = min(margin, abs(hi[t] - lo[t]) / max(1.0, abs(hi[t])))
            ok &= lo[t] <= hi[t]
        if not ok:
            break
        best = j
    return best, margin


def ref_adapted(x, sched, p, side):
    """The adapted candidate index of one side at centre ``p`` (the centred chain with its
    two halves before each length), and the smallest margin."""
    gamma, ms, cand = sched.gamma, sched.ms, sched.lengths

    def intervals(start, length, nu):
        return [ref_interval(ref_window_avar(x, start, length, int(m)), nu[t], gamma)
                for t, m in enumerate(ms)]  # fmt: skip

    chain = []  # (the candidate an entry closes, or None for a half; its intervals)
    for j, L in enumerate(int(v) for v in cand):
        h = L // 2
        if side == CENTRED and h >= 3 * ms[-1]:
            # the Gaussian EDF scaled by the record's excess kurtosis (ici_kurtosis)
            nu_h = kurtosis_edf(correlation_edf(x, np.array([h]), ms), np.array([h]), ms,
                                sched.parameters["ici_excess_kurtosis"])[0]  # fmt: skip
            chain += [(None, intervals(p - h + 1, h, nu_h)), (None, intervals(p + 1, h, nu_h))]
        chain.append((j, intervals(p + side_shift(side, L) - (L - 1) // 2, L, sched.edf[j])))
    k, margin = ref_adapt([c for _, c in chain])
    closed = [j for j, _ in chain[: k + 1] if j is not None]
    return (closed[-1] if closed else -1), margin


records = st.tuples(
    st.integers(0, 2**31 - 1),
    st.sampled_from(["plain", "offset", "step", "drift", "float32", "tiny", "huge"]),
)


def make_record(seed: int, kind: str, n: int = 700) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n)
    x[n // 2 :] *= 3.0  # a change, so the rule has something to do
    if kind == "offset":
        x = x + 1e6
    elif kind == "step":
        x[n // 3 :] += 1e6
    elif kind == "drift":
        x = x + 1e-2 * np.arange(n)
    elif kind == "float32":
        x = x.astype(np.float32).astype(np.float64)
    elif kind == "tiny":
        x = x * 1e-150
    elif kind == "huge":
        x = x * 1e150
    return x


# ---------------------------------------------------------------------------------------
# one-sided surfaces


@settings(max_examples=25, deadline=None)
@given(records, st.integers(0, 2**31 - 1))
def test_shifted_surface_matches_reference(record, seed):
    x = make_record(*record, n=300)
    rng = np.random.default_rng(seed)
    n = x.size
    window = rng.integers(9, 60, n)
    side = rng.integers(-1, 2, n)
    shift = np.array([side_shift(int(s), int(L)) for s, L in zip(side, window, strict=True)])
    r = adavar.davar(x, window=window, shift=shift, taus=[1, 2, 3], confidence=None)
    np.testing.assert_array_equal(r.shift, shift)
    for p in rng.choice(n, 25, replace=False):
        L = int(window[p])
        start = int(p + shift[p] - (L - 1) // 2)
        for t, m in enumerate((1, 2, 3)):
            if 3 * m > L:
                assert np.isnan(r.avar[p, t])
                continue
            want = ref_window_avar(x, start, L, m)
            assert r.avar[p, t] == pytest.approx(want, rel=1e-9, abs=0), (p, m, record)


def test_shifted_windows_edf_follows_the_actual_window():
    x = np.random.default_rng(1).standard_normal(400)
    # a left window at the first sample lies wholly in the mirror; a right one wholly inside
    left = adavar.davar(x, window=np.full(400, 60), shift=np.full(400, -30), taus=[1, 4])
    right = adavar.davar(x, window=np.full(400, 60), shift=np.full(400, 29), taus=[1, 4])
    centred = adavar.davar(x, window=60, taus=[1, 4])
    inside = centred.edf[200]
    np.testing.assert_allclose(right.edf[0], inside)  # no overhang: the interior EDF
    assert np.all(left.edf[0] < inside)  # mirrored terms repeat: fewer degrees of freedom
    np.testing.assert_allclose(right.avar[0], centred.avar[29])  # the same window
    with pytest.raises(AdavarInputError, match="shift array has"):
        adavar.davar(x, window=60, shift=np.zeros(7, dtype=np.int64))
    with pytest.raises(AdavarInputError, match="whole numbers"):
        adavar.davar(x, window=60, shift=np.zeros(400))


def test_valid_edges_keep_the_shifted_windows_that_fit():
    x = np.random.default_rng(2).standard_normal(200)
    r = adavar.davar(x, window=np.full(200, 20), shift=np.full(200, 9), edges="valid")
    start = r.centre + r.shift - 9
    assert start.min() == 0 and (start + 20).max() == 200


# ---------------------------------------------------------------------------------------
# the ICI rule


@settings(max_examples=25, deadline=None)
@given(records)
def test_adapted_lengths_match_reference(record):
    x = make_record(*record)
    lengths = [12, 24, 48, 60]
    sched = ici_schedule(x, lmax=60, lmin=48, lengths=lengths, taus=(1, 2), gamma=2.0)
    rng = np.random.default_rng(record[0])
    checked = 0
    for p in rng.choice(x.size, 10, replace=False):
        for side in (LEFT, CENTRED, RIGHT):
            want, margin = ref_adapted(x, sched, int(p), side)
            got = sched.adapted[side + 1, p]
            if margin < 1e-9:
                continue  # a near-tie: either answer is right
            assert got == (lengths[want] if want >= 0 else 0), (p, side, record)
            checked += 1
    assert checked >= 25


def test_choice_and_shift_follow_the_adapted_lengths():
    x = paper_scenario(1, seed=3).data
    s = ici_schedule(x, lmax=600, lmin=400)
    chosen = s.adapted[s.side.astype(int) + 1, np.arange(s.centre.size)]
    assert np.all(chosen == s.adapted.max(axis=0))  # the longest adapted window wins
    assert np.all(s.window == np.maximum(chosen, 400))
    for side in (LEFT, RIGHT):
        here = s.side == side
        np.testing.assert_array_equal(s.shift[here], side_shift(side, s.window[here]))
    assert np.all(s.shift[s.side == CENTRED] == 0)


def test_step_computes_the_same_rule_at_fewer_centres():
    x = paper_scenario(1, seed=2).data
    every = ici_schedule(x, lmax=600, lmin=400)
    third = ici_schedule(x, lmax=600, lmin=400, step=3)
    np.testing.assert_array_equal(third.centre, every.centre[::3])
    np.testing.assert_array_equal(third.adapted, every.adapted[:, ::3])  # pointwise


def test_degenerate_records():
    flat = ici_schedule(np.full(2000, 7.0), lmax=600, lmin=400)
    assert np.all(flat.window == 600) and np.all(flat.side == 0)  # zero variance agrees
    with pytest.raises(AdavarInputError):
        ici_schedule(np.full(300, np.nan), lmax=60, lmin=48)
    with pytest.raises(AdavarInputError, match="at least"):
        ici_schedule(np.zeros(50), lmax=60, lmin=48)
    with pytest.raises(AdavarInputError, match="lmin"):
        ici_schedule(np.zeros(500), lmax=48, lmin=60)


def test_correlation_edf_against_direct_formula_and_white_noise():
    x = np.random.default_rng(4).standard_normal(200_000)
    nu = correlation_edf(x, np.array([400]), np.array([1]))
    assert nu[0, 0] == pytest.approx(399 / 1.5, rel=0.02)  # rho_1 = -1/2 for white noise
    # band-limited noise is correlated: fewer degrees of freedom than white
    y = simulate.sensor(200_000, rate=200.0, angle_random_walk=0.005, bandwidth=40.0, seed=1)
    assert correlation_edf(y, np.array([400]), np.array([1]))[0, 0] < 0.8 * nu[0, 0]


@pytest.mark.parametrize("m", [1, 2, 3])
def test_correlation_edf_matches_a_loop(m):
    x = np.cumsum(np.random.default_rng(m).standard_normal(3000)) * 0.1  # correlated
    x += np.random.default_rng(9).standard_normal(3000)
    d = np.array([math.fsum(x[i + m : i + 2 * m]) - math.fsum(x[i : i + m])
                  for i in range(x.size - 2 * m + 1)])  # fmt: skip
    d -= d.mean()
    lags = 2 * m + 64
    rho = []
    for k in range(1, lags + 1):
        r = math.fsum(d[:-k] * d[k:]) / math.fsum(d * d) * d.size / (d.size - k)
        rho.append(r if k < 2 * m or abs(r) > 3 / math.sqrt(d.size) else 0.0)
    for L in (40, 300):
        n = L - 2 * m + 1
        c = 1 + 2 * math.fsum((1 - k / n) * rho[k - 1] ** 2 for k in range(1, min(lags, n - 1) + 1))
        got = correlation_edf(x, np.array([L]), np.array([m]))[0, 0]
        assert got == pytest.approx(n / c, rel=1e-9)


def test_candidates():
    c = ici_candidates(400, 600)
    assert c[0] == 50 and c[-1] == 600 and 400 in c and np.all(c % 2 == 0)
    assert np.all(ici_candidates(401, 601) % 2 == 1)


@pytest.mark.parametrize(
    ("options", "fragment"),
    [
        (dict(ici_gamma=0), "ici_gamma"),
        (dict(ici_sides="up"), "ici_sides"),
        (dict(ici_edf="x"), "ici_edf"),
        (dict(ici_taus=[0]), "ici_taus"),
        (dict(ici_lengths=[10, 20]), "ici_lengths"),
        (dict(ici_lengths=[3, 48, 60], ici_taus=[2]), "3 m"),
        (dict(chunk_size=100), "runs in memory"),
    ],
)
def test_bad_options_are_one_line_errors(options, fragment):
    x = np.random.default_rng(0).standard_normal(300)
    with pytest.raises(AdavarInputError, match=fragment):
        adaptive_davar(x, method="ici", lmax=60, lmin=48, **options)


# ---------------------------------------------------------------------------------------
# statistics


@pytest.mark.parametrize("kind", ["white", "band-limited"])
def test_stationary_noise_keeps_the_long_window(kind):
    shortened, moved, changes = [], [], 0
    for seed in range(3):
        if kind == "white":
            x = np.random.default_rng(seed).standard_normal(40_000)
        else:
            x = simulate.sensor(40_000, rate=200.0, angle_random_walk=0.005, bandwidth=40.0,
                                lsb=1 / 131, seed=seed)  # fmt: skip
        s = ici_schedule(x, lmax=600, lmin=400)
        shortened.append(np.mean(s.window < 600))
        moved.append(np.mean(s.side != 0))
        changes += s.changes.size
    assert np.mean(shortened) < 0.01
    assert np.mean(moved) < 0.05
    assert changes <= 2  # about 0.01 per 1000 s of stationary noise in the benchmark


def test_change_is_found_and_tracked():
    x = paper_scenario(1, seed=7).data  # std x3 from 3000 to 4000 s
    s = ici_schedule(x, lmax=600, lmin=400)
    assert len(s.changes) == 2
    assert abs(s.changes[0] - 3000) < 60 and abs(s.changes[1] - 4000) < 60
    # next to the change the window faces away from it
    assert np.all(s.side[2900:2980] == LEFT) and np.all(s.side[3020:3100] == RIGHT)
    sched = adaptive_schedule(x, method="ici", lmax=600, lmin=400)
    assert np.all(np.isnan(sched.kurtosis)) and not sched.f1.any() and not sched.f2.any()
    assert sched.f[2950] and not sched.f[1500]
    assert sched.parameters["ici_changes"] == s.changes.tolist()


def test_compare_runs_ici_and_beats_the_fixed_windows():
    sc = paper_scenario(1, seed=11)
    c = compare(sc, methods=["davar-400", "davar-600", "ici", "ici-centred"], taus="octave",
                terms=("angle_random_walk",), noise_type=0)  # fmt: skip
    assert c.methods["ici"].label == "ICI"
    assert c.methods["ici-centred"].label == "ICI (centred)"
    ici, short, long_ = (c.methods[k].metrics for k in ("ici", "davar-400", "davar-600"))
    assert ici.error < 0.5 * short.error
    assert ici.std < 1.1 * long_.std
    assert c.methods["ici-centred"].result.shift is not None
    assert np.all(c.methods["ici-centred"].result.shift == 0)


def test_compare_seeds_with_ici():
    from adavar.paper.studies import compare_seeds

    study = compare_seeds(1, range(2), methods=["davar-400", "ici"],
                          terms=("angle_random_walk",))  # fmt: skip
    assert "ici" in study.methods
    assert np.all(np.isfinite(study.confidence["ici"]))


def test_adaptive_davar_ici_surface_uses_the_schedule():
    x = paper_scenario(1, seed=5).data
    r = adaptive_davar(x, method="ici", lmax=600, lmin=400, taus="octave", step=7)
    sched = adaptive_schedule(x, method="ici", lmax=600, lmin=400)
    np.testing.assert_array_equal(r.window, sched.window[::7])
    np.testing.assert_array_equal(r.shift, sched.shift[::7])
    valid = adaptive_davar(x, method="ici", lmax=600, lmin=400, taus="octave", edges="valid")
    start = valid.centre + valid.shift - (valid.window - 1) // 2
    assert start.min() >= 0 and (start + valid.window).max() <= x.size
    assert valid.method == "ici"


# ---------------------------------------------------------------------------------------
# command line


@pytest.fixture(scope="module")
def scenario_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("ici") / "rec.csv"
    x = paper_scenario(1, seed=0).data
    path.write_text("x\n" + "".join(f"{v!r}\n" for v in x.tolist()), encoding="utf-8")
    return path


def test_cli_adaptive_method_ici(capsys, scenario_csv):
    code, out, err = run(capsys, ["adaptive", str(scenario_csv), "--rate", "1", "--units",
                                  "deg/h", "--method", "ici", "--lmax", "600", "--lmin", "400",
                                  "--taus", "octave", "--ici-gamma", "2.5", "--json"])  # fmt: skip
    assert code == 0, err
    payload = json.loads(out)
    assert payload["parameters"]["controller"]["method"] == "ici"
    assert payload["parameters"]["controller"]["ici_gamma"] == 2.5
    starts = [e["start_s"] for e in payload["events"]]
    assert len(starts) == 1 and abs(starts[0] - 3000) < 60


@pytest.mark.parametrize(
    ("flags", "fragment"),
    [
        (["--ici-gamma", "-1"], "--ici-gamma"),
        (["--ici-lengths", "10,x"], "--ici-lengths"),
        (["--ici-sides", "up"], "--ici-sides"),
        (["--ici-lengths", "10,20"], "ici_lengths (--ici-lengths) must hold lmin"),
    ],
)
def test_cli_bad_ici_option(capsys, scenario_csv, flags, fragment):
    code, out, err = run(capsys, ["adaptive", str(scenario_csv), "--rate", "1", "--units",
                                  "deg/h", "--method", "ici", "--lmax", "600", "--lmin", "400",
                                  *flags])  # fmt: skip
    assert_one_line_error(code, out, err, fragment)


def test_cli_compare_methods_ici(capsys):
    code, out, err = run(capsys, ["compare", "--scenario", "1", "--methods",
                                  "davar-400,ici", "--taus", "octave", "--json"])  # fmt: skip
    assert code == 0, err
    methods = json.loads(out)["comparison"]["methods"]
    assert methods["ici"]["label"] == "ICI"

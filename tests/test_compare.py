"""adavar.compare: node detection, metrics, compare() and the many-seed study."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import adavar
from adavar.comparison import (
    PAPER_TABLE1_NODES,
    Comparison,
    EdfCache,
    Nodes,
    compare,
    default_methods,
    fixed_nodes,
    run_comparison,
    schedule_nodes,
)
from adavar.core.errors import AdavarInputError
from adavar.core.settings import PAPER
from adavar.dynamic.adaptive import adaptive_schedule, oracle_schedule
from adavar.dynamic.kurtosis import sliding_kurtosis
from adavar.paper.metrics import interval_means, tracking_metrics
from adavar.paper.studies import compare_seeds, kurtosis_study, threshold_study
from adavar.simulate import paper_scenario

LMAX, LMIN = 600, 400


def ramp(w, start, stop, step):
    """Set w[start:] to a run of lengths from w[start - 1] changing by step until stop;
    return the index after the last one set."""
    value = w[start - 1]
    p = start
    while value != stop:
        value += step
        w[p] = value
        p += 1
    return p


def clean_schedule(n=6000, shrink=2702, grow=3150):
    """600 until shrink, down by 2 to 400, 400 until grow, up by 2 to 600."""
    w = np.full(n, LMAX, dtype=np.int64)
    p = ramp(w, shrink, LMIN, -2)
    w[p:grow] = LMIN
    p = ramp(w, grow, LMAX, 2)
    w[p:] = LMAX
    return w


# --------------------------------------------------------------------------------------
# nodes


def test_nodes_of_a_clean_schedule():
    w = clean_schedule()
    (nodes,) = schedule_nodes(w, [3000.0], lmax=LMAX)
    # End is the lowest point of the regrowth run: the last centre at Lmin
    assert nodes == Nodes(3000.0, 2702.0, 3149.0, 3249.0)
    assert nodes.get("end") == 3149.0
    with pytest.raises(KeyError):
        nodes.get("middle")


def test_nodes_ignore_false_alarms_elsewhere_and_use_the_final_regrowth():
    w = clean_schedule()
    # a false alarm long before the change, recovered before the detection
    p = ramp(w, 1000, 580, -2)
    ramp(w, p, LMAX, 2)
    # a false alarm during the regrowth: shrinks for 3 steps, then the final regrowth
    w2 = w.copy()
    k = 3200  # regrowing here: w = 500
    w2[k : k + 3] = [498, 496, 494]
    p = ramp(w2, k + 3, LMAX, 2)
    w2[p:] = LMAX
    (n1,) = schedule_nodes(w, [3000.0], lmax=LMAX)
    assert (n1.beginning, n1.end, n1.restore) == (2702.0, 3149.0, 3249.0)
    (n2,) = schedule_nodes(w2, [3000.0], lmax=LMAX)
    assert n2.beginning == 2702.0
    assert n2.end == k + 2  # the lowest point of the blip starts the final regrowth run
    assert n2.restore == p - 1  # ramp() returns the index after the first Lmax


def test_an_unrecovered_false_alarm_merges_with_the_detection():
    w = clean_schedule()
    w[2650:2702] = 590  # shrunk a little by a false alarm that never regrew
    (nodes,) = schedule_nodes(w, [3000.0], lmax=LMAX)
    assert nodes.beginning == 2650.0 and nodes.end == 3149.0


def test_missed_or_unrestored_changes_give_nan():
    flat = np.full(6000, LMAX, dtype=np.int64)
    (missed,) = schedule_nodes(flat, [3000.0], lmax=LMAX)
    assert all(math.isnan(v) for v in (missed.beginning, missed.end, missed.restore))
    stuck = clean_schedule()
    stuck[3100:] = LMIN  # never back at Lmax
    (nodes,) = schedule_nodes(stuck, [3000.0], lmax=LMAX)
    assert math.isnan(nodes.restore) and math.isnan(nodes.beginning)


def test_nodes_of_two_changes_and_of_a_sampled_record():
    w = np.minimum(clean_schedule(), np.roll(clean_schedule(), 1000))
    n3, n4 = schedule_nodes(w, [3000.0, 4000.0], lmax=LMAX)
    assert (n3.beginning, n3.end, n3.restore) == (2702.0, 3149.0, 3249.0)
    assert (n4.beginning, n4.end, n4.restore) == (3702.0, 4149.0, 4249.0)
    (fast,) = schedule_nodes(clean_schedule(), [300.0], lmax=LMAX, rate=10.0)
    assert (fast.beginning, fast.end, fast.restore) == pytest.approx((270.2, 314.9, 324.9))
    t = 100.0 + np.arange(6000)
    (shifted,) = schedule_nodes(clean_schedule(), [3100.0], lmax=LMAX, time=t)
    assert shifted.beginning == 2802.0


def test_oracle_nodes_sit_one_sample_inside_the_fixed_windows():
    w = oracle_schedule(6000, [3000, 4000], lmax=LMAX, lmin=LMIN)
    for x, nodes in zip((3000, 4000), schedule_nodes(w, [3000, 4000], lmax=LMAX), strict=True):
        assert nodes.beginning == x - LMAX // 2 + 1
        assert nodes.end == x + LMIN // 2 - 1
        assert nodes.restore == x + LMAX // 2 - 1


def test_fixed_window_nodes():
    n3, n4 = fixed_nodes([3000.0, 4000.0], 400)
    assert (n3.beginning, n3.end) == (2800.0, 3200.0)
    assert (n4.beginning, n4.end) == (3800.0, 4200.0)
    assert math.isnan(n3.restore)
    (fast,) = fixed_nodes([30.0], 600, rate=100.0)
    assert (fast.beginning, fast.end) == (27.0, 33.0)
    # the paper's DAVAR-400/600 columns are these definitions (DAVAR-600's 2702 aside)
    for name, length in (("davar-400", 400), ("davar-600", 600)):
        for (node, change), value in PAPER_TABLE1_NODES[name].items():
            (nodes,) = fixed_nodes([change], length)
            assert abs(nodes.get(node) - value) <= 2


# --------------------------------------------------------------------------------------
# interval means and metrics


def test_interval_means():
    t = np.arange(10.0)
    v = np.arange(10.0) * 2
    v[3] = np.nan
    got = interval_means(t, v, [(0, 4), (5, 5), (20, 30)])
    assert got[(0.0, 4.0)] == pytest.approx((0 + 2 + 4 + 8) / 4)
    assert got[(5.0, 5.0)] == 10.0
    assert math.isnan(got[(20.0, 30.0)])


def test_tracking_metrics_of_a_perfect_step_and_a_ramp():
    t = np.arange(1000.0)
    truth = np.where(t < 500, 1.0, 3.0)
    perfect = tracking_metrics(t, truth * 1.01, truth, [500.0], margin=100, span=200)
    assert perfect.bias == pytest.approx(0.01) and perfect.std == pytest.approx(0, abs=1e-12)
    assert perfect.mad == pytest.approx(0, abs=1e-12)
    assert perfect.n_stationary == int(np.sum(np.abs(t - 500) > 100))
    (c,) = perfect.changes
    assert (c.before, c.after, c.delay, c.rise, c.span) == (1.0, 3.0, 0.0, 0.0, 200.0)
    assert c.error == pytest.approx(0.01)
    # a linear ramp from 1 at t = 400 to 3 at t = 600
    est = np.clip(1.0 + (t - 400) / 100.0, 1.0, 3.0)
    (r,) = tracking_metrics(t, est, truth, [500.0], margin=100, span=200).changes
    assert r.delay == 1.0  # first centre strictly past the midpoint 2
    assert r.rise == (581 - 421)  # after the last centre <= 1.2 .. first > 2.8
    assert r.error == pytest.approx(np.mean(np.abs(est - truth)[300:701] / truth[300:701]))
    # a downward step reads the same way
    (d,) = tracking_metrics(t, est[::-1], truth[::-1], [500.0], margin=100, span=200).changes
    assert (d.before, d.after) == (3.0, 1.0) and d.delay == 0.0 and d.rise == 160.0


def test_tracking_metrics_ignore_noise_ahead_of_the_change():
    t = np.arange(1000.0)
    truth = np.where(t < 500, 3.0, 1.0)
    est = truth.copy()
    est[350] = 2.7  # an excursion past 10 % of the step, long before the change
    (c,) = tracking_metrics(t, est, truth, [500.0], margin=100, span=200).changes
    assert c.rise == 0.0 and c.delay == 0.0


def test_tracking_metrics_reject_bad_truth():
    with pytest.raises(AdavarInputError, match="positive"):
        tracking_metrics([0, 1], [1, 1], [1, 0], [], margin=1, span=1)
    with pytest.raises(AdavarInputError, match="same length"):
        tracking_metrics([0, 1], [1, 1], [1], [], margin=1, span=1)


# --------------------------------------------------------------------------------------
# compare


@pytest.fixture(scope="module")
def scenario():
    return paper_scenario(1, seed=7)


@pytest.fixture(scope="module")
def comparison(scenario):
    return compare(scenario, taus="octave")


def test_compare_structure(scenario, comparison):
    c = comparison
    assert isinstance(c, Comparison)
    assert list(c.methods) == list(default_methods()) == ["davar-400", "davar-600", "davar-k",
                                                          "a-davar"]  # fmt: skip
    assert c.labels == {"davar-400": "DAVAR-400", "davar-600": "DAVAR-600",
                        "davar-k": "DAVAR-K-3.3", "a-davar": "A-DAVAR"}  # fmt: skip
    assert c.scenario == 1 and c.change_times == (3000.0, 4000.0)
    assert c.intervals == scenario.intervals and c.rate == 1.0
    np.testing.assert_array_equal(c.time, np.arange(6000.0))
    np.testing.assert_array_equal(c.truth, scenario.arw)
    for name, run in c.methods.items():
        assert run.arw.shape == run.window.shape == (6000,)
        assert len(run.nodes) == 2 and set(run.intervals) == set(scenario.intervals)
        assert run.metrics is not None and len(run.metrics.changes) == 2
        assert run.fit.angle_random_walk.value.shape == (6000,)
        assert (run.schedule is None) == (name in ("davar-400", "davar-600"))
    np.testing.assert_array_equal(c.methods["davar-400"].window, 400)
    paper = PAPER.keywords()  # compare keeps the paper's controller, not the defaults
    np.testing.assert_array_equal(c.methods["a-davar"].window,
                                  adaptive_schedule(scenario.data, **paper).window)  # fmt: skip
    np.testing.assert_array_equal(
        c.methods["davar-k"].window,
        adaptive_schedule(scenario.data, method="kurtosis", **paper).window,
    )
    # N(t) is the fit of the DAVAR surface on the schedule
    res = adavar.davar(scenario.data, window=c.methods["a-davar"].window, taus="octave")
    np.testing.assert_array_equal(
        c.methods["a-davar"].arw, adavar.fit_noise(res).angle_random_walk.value
    )
    # the fixed windows' nodes by definition; the adaptive ones from the schedule
    assert c.methods["davar-600"].node("beginning", 3000.0) == 2700.0
    assert c.methods["a-davar"].nodes == schedule_nodes(
        c.methods["a-davar"].window, c.change_times, lmax=600
    )
    assert math.isnan(c.methods["a-davar"].node("end", 1234.0))
    rows = c.node_rows()
    assert [(r["node"], r["change"]) for r in rows] == [
        ("beginning", 3000.0), ("end", 3000.0), ("restore", 3000.0),
        ("beginning", 4000.0), ("end", 4000.0), ("restore", 4000.0),
    ]  # fmt: skip
    assert rows[0]["paper"] == {"davar-400": 2800.0, "davar-600": 2702.0, "a-davar": 2703.0}
    payload = c.to_dict()
    json.dumps(payload, allow_nan=False)
    assert payload["methods"]["a-davar"]["label"] == "A-DAVAR"


def test_compare_confidence_and_tracking_on_one_realisation(comparison):
    m = {name: run.metrics for name, run in comparison.methods.items()}
    # the longer window is steadier in stationary stretches, the shorter one tracks better
    assert m["davar-600"].std < m["davar-400"].std
    assert m["davar-400"].error < m["davar-600"].error
    # N is near its true level in stationary stretches (the five-term fit reads it a few % low)
    for metrics in m.values():
        assert -0.08 < metrics.bias < 0.0 and metrics.std < 0.1


def test_compare_plain_array_without_truth():
    x = paper_scenario(1, seed=2).data
    c = compare(x, rate=2.0, change_times=[1500.0], methods=["davar-300", "a-davar", "oracle"],
                lmax=300, lmin=200, l=50, taus="octave")  # fmt: skip
    assert c.truth is None and c.scenario is None
    assert all(run.metrics is None for run in c.methods.values())
    assert c.intervals == ((0.0, 1500.0), (1500.0, 3000.0))
    np.testing.assert_allclose(c.time, np.arange(6000) / 2.0)
    assert c.methods["oracle"].node("beginning", 1500.0) == pytest.approx(1500 - 149 / 2)
    assert c.methods["davar-300"].node("end", 1500.0) == 1575.0
    assert c.paper_nodes() == {}


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"methods": ["davar-x"]}, "unknown method"),
        ({"methods": ["a-davar", "adaptive"]}, "repeat"),
        ({"methods": []}, "at least one"),
        ({"methods": ["davar-7000"]}, "longer than the record"),
        ({"change_times": [7000.0]}, "outside the record"),
        ({"change_times": [4000.0, 3000.0]}, "increasing"),
        ({"truth": np.ones(10)}, "truth"),
        ({"intervals": [(5.0, 1.0)]}, "empty"),
        ({"rate": -1.0}, "rate"),
        ({"lmin": 700}, "lmin"),
    ],
)
def test_compare_rejects_bad_input(scenario, kwargs, match):
    with pytest.raises(AdavarInputError, match=match):
        compare(scenario, taus="octave", **kwargs)


def test_oracle_needs_change_times():
    with pytest.raises(AdavarInputError, match="oracle"):
        compare(np.random.default_rng(0).standard_normal(2000), methods=["oracle"])


def test_fast_path_matches_compare_for_white_noise_edfs(scenario):
    full = compare(scenario, taus="octave", noise_type=0)
    fast = run_comparison(
        scenario, methods=None, rate=None, change_times=None, truth=None, intervals=None,
        controller=dict(lmax=600, lmin=400, k1=2.5, k2=3.3, s1=0.0, s2=0.07, l=100, dl0=2,
                        dl1=2, s_test="upper", combine="or", thresholds="paper",
                        false_alarm=0.01),
        taus="octave", terms=adavar.fit.noise_model.TERM_NAMES, confidence=0.683, noise_type=0,
        points_per_decade=10, units=None, description=None, edf_cache=EdfCache(),
    )  # fmt: skip
    for name in full.methods:
        np.testing.assert_allclose(fast.methods[name].arw, full.methods[name].arw, rtol=1e-9)


# --------------------------------------------------------------------------------------
# kurtosis and threshold studies


def test_kurtosis_study(scenario):
    study = kurtosis_study(scenario)
    assert sorted(study.kurtosis) == [11, 201, 601] and study.segment == 11
    np.testing.assert_array_equal(study.kurtosis[601], sliding_kurtosis(scenario.data, window=601))
    assert study.contribution.shape == (6000,) and study.change_times == (3000.0, 4000.0)


def test_threshold_study_expected_crossings_match_the_paper(scenario):
    study = threshold_study(scenario)
    assert study.window == 600 and study.thresholds == (3.3, 3.45, 4.0)
    # the Gaussian-mixture expectation of a std-3 disturbance: the paper's Fig. 8 readings
    exp = study.expected_crossings
    assert exp[3.3][0] == pytest.approx((2700, 3228), abs=3)
    assert exp[3.45][0] == pytest.approx((2700, 3201), abs=3)
    assert exp[4.0][0] == pytest.approx((2700, 3115), abs=8)
    # one realisation: near the expectation
    assert study.crossings[3.3][0, 0] == pytest.approx(2700, abs=40)
    assert study.crossings[3.3][0, 1] == pytest.approx(3230, abs=120)
    with pytest.raises(AdavarInputError, match="change times"):
        threshold_study(scenario.data)


def test_threshold_study_missing_crossing_is_nan():
    x = np.random.default_rng(1).standard_normal(3000)  # no change at all
    study = threshold_study(x, change_times=[1500.0], thresholds=(50.0,))
    assert np.isnan(study.crossings[50.0]).all() and study.expected is None


# --------------------------------------------------------------------------------------
# many seeds


@pytest.fixture(scope="module")
def study():
    return compare_seeds(1, range(30))


def test_adavar_median_nodes_reproduce_table_1(study):
    """Over 30 realisations the A-DAVAR medians lie within 25 s of the paper's Table 1."""
    paper = PAPER_TABLE1_NODES["a-davar"]
    medians = {(r["node"], r["change"]): r["stats"]["a-davar"]["median"]
               for r in study.node_rows()}  # fmt: skip
    for key, value in paper.items():
        assert abs(medians[key] - value) <= 25, (key, medians[key], value)


def test_seed_study_structure(study):
    assert study.seeds == tuple(range(30)) and study.scenario == 1
    assert study.methods == ("davar-400", "davar-600", "davar-k", "a-davar")
    assert study.nodes["a-davar"].shape == (30, 2, 3)
    np.testing.assert_array_equal(study.nodes["davar-400"][:, 0, 0], 2800.0)
    assert study.tracking["davar-k"].shape == (30, 2, 3)
    assert study.confidence["a-davar"].shape == (30, 3)
    assert study.arw["davar-600"].shape == (30, 2)
    assert study.crossings[3.3].shape == (30, 2, 2)
    rows = study.node_rows()
    assert rows[0]["stats"]["davar-600"]["median"] == 2700.0
    assert rows[0]["stats"]["davar-600"]["missed"] == 0
    assert [r["node"] for r in rows].count("restore") == 2
    metrics = {(r["metric"], r["change"]): r["values"] for r in study.metric_rows()}
    assert metrics[("std", None)]["davar-600"] < metrics[("std", None)]["davar-400"]
    assert metrics[("error", 3000.0)]["a-davar"] < metrics[("error", 3000.0)]["davar-600"]
    arw = study.arw_rows()
    assert arw[0]["paper"]["a-davar"] == 3.83
    cross = study.crossing_rows()
    assert cross[0]["paper"] == (2700.0, 3228.0)
    assert cross[0]["rise"]["median"] == pytest.approx(2700, abs=15)
    json.dumps(study.to_dict(), allow_nan=False)


def test_compare_seeds_rejects_bad_input():
    with pytest.raises(AdavarInputError, match="scenario"):
        compare_seeds(3, range(2))
    with pytest.raises(AdavarInputError, match="seed"):
        compare_seeds(1, [])


# --------------------------------------------------------------------------------------
# figures


def test_comparison_figures(scenario, comparison):
    from adavar.output.plots import comparison_figures

    figs = comparison_figures(comparison, kurtosis=kurtosis_study(scenario),
                              thresholds=threshold_study(scenario))  # fmt: skip
    assert list(figs) == ["fig06_kurtosis_windows", "fig07_contribution", "fig08_thresholds",
                          "fig10_controller", "fig11_adavar_surface", "fig12_arw"]  # fmt: skip
    assert len(figs["fig06_kurtosis_windows"].axes) == 4  # the record + 3 window lengths
    assert len(figs["fig07_contribution"].axes) == 3
    assert len(figs["fig10_controller"].axes) == 6
    arw_axes = figs["fig12_arw"].axes[0]
    lines = arw_axes.get_lines()
    assert [ln.get_label() for ln in lines[:5]] == ["DAVAR-400", "DAVAR-600", "DAVAR-K-3.3",
                                                    "A-DAVAR", "true N"]  # fmt: skip
    np.testing.assert_array_equal(lines[3].get_ydata(), comparison.methods["a-davar"].arw)
    # crossings drawn as markers on each threshold line
    thr_ax = figs["fig08_thresholds"].axes[0]
    assert thr_ax.get_ylabel() == "kurtosis"
    only_fixed = compare(scenario, methods=["davar-600"], taus="octave")
    assert list(comparison_figures(only_fixed)) == ["fig12_arw"]


def _gyro_with_bursts(n: int, seed: int) -> np.ndarray:
    """Band-limited gyro noise with two bursts and a level step, written here (not
    adavar.simulate): what a long comparison meets."""
    rng = np.random.default_rng(seed)
    w = rng.standard_normal(n + 8)
    x = np.convolve(w, np.ones(8) / np.sqrt(8), mode="valid")[:n]  # a moving-average filter
    x[n // 3 : n // 3 + n // 20] *= 3.0
    x[2 * n // 3 :] += 0.5
    x[n // 2 : n // 2 + 200] += rng.standard_t(3, 200) * 4.0
    return np.round(x * 64.0) / 64.0  # quantised


def test_a_step_keeps_every_kth_window_of_the_full_comparison():
    x = _gyro_with_bursts(9000, seed=11)
    opts = dict(rate=1.0, change_times=[3000.0], lmax=600, lmin=400, taus="octave",
                methods=["davar-400", "davar-k", "a-davar"])  # fmt: skip
    full = compare(x, step=1, **opts)
    every = compare(x, step=7, **opts)
    assert full.parameters["step"] == 1 and every.parameters["step"] == 7
    np.testing.assert_array_equal(every.time, full.time[::7])
    for name, run in every.methods.items():
        np.testing.assert_array_equal(run.window, full.methods[name].window[::7])
        np.testing.assert_array_equal(run.arw, full.methods[name].arw[::7])
        if run.schedule is not None:
            np.testing.assert_array_equal(run.schedule.kurtosis,
                                          full.methods[name].schedule.kurtosis[::7])  # fmt: skip
        # nodes are read on the coarser grid: within a step of the full ones
        for a, b in zip(run.nodes, full.methods[name].nodes, strict=True):
            for node in ("beginning", "end", "restore"):
                va, vb = getattr(a, node), getattr(b, node)
                assert (math.isnan(va) and math.isnan(vb)) or abs(va - vb) <= 7.0


def test_a_long_record_takes_the_step_that_fits_the_budget():
    x = _gyro_with_bursts(20_000, seed=3)
    opts = dict(rate=100.0, lmax=600, lmin=400, taus=[0.01, 0.04], keep="figures",
                methods=["davar-400", "a-davar"])  # fmt: skip
    small = compare(x[:5000], **opts)
    assert small.parameters["step"] == 1  # short records: every centre, as the paper
    c = compare(x, max_memory=0.5, **opts)  # 20 000 centres of 2 methods do not fit
    step = c.parameters["step"]
    assert step == math.ceil(20_000 * (16 + 2 * 48) / 2**19)
    assert c.time.size == math.ceil(20_000 / step)
    assert all(run.arw.size == c.time.size for run in c.methods.values())
    with pytest.raises(AdavarInputError, match="step"):
        compare(x, step=0, **opts)


def test_the_comparisons_memory_stops_growing_with_the_record():
    """Peak traced memory per sample: with the budget, a record 4x longer costs well under
    4x (the per-centre series are capped; the record's own copies remain)."""
    import tracemalloc

    opts = dict(rate=100.0, lmax=600, lmin=400, taus=[0.01, 0.04], keep="figures",
                max_memory=0.2, methods=["davar-400", "a-davar"])  # fmt: skip
    x = _gyro_with_bursts(80_000, seed=5)
    peaks = []
    for n in (20_000, 80_000):
        y = x[:n].copy()
        compare(y, **opts)  # compiled, caches warm
        tracemalloc.start()
        compare(y, **opts)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    # the record's copies (float64 and its mirror extension: 16 bytes a sample) and the
    # capped series; without the cap the series alone are about 100 bytes a sample
    assert (peaks[1] - peaks[0]) / 60_000 < 60, peaks


def test_a_record_read_piece_by_piece_gives_the_same_comparison(tmp_path):
    from adavar.io.sources import ChunkedSource

    x = _gyro_with_bursts(30_000, seed=8)
    np.save(tmp_path / "x.npy", x)
    mapped = np.load(tmp_path / "x.npy", mmap_mode="r")
    opts = dict(rate=10.0, change_times=[1000.0], lmax=600, lmin=400, taus="octave",
                keep="figures", step=3, methods=["davar-400", "davar-k", "a-davar"])  # fmt: skip
    loaded, streamed = compare(x, **opts), compare(mapped, **opts)
    assert isinstance(streamed.data, ChunkedSource) and streamed.data.size == x.size
    np.testing.assert_array_equal(streamed.time, loaded.time)
    for name, run in streamed.methods.items():
        np.testing.assert_array_equal(run.window, loaded.methods[name].window)
        # the windows' fit reads the whole record's reference curve streamed: 1e-9
        np.testing.assert_allclose(run.arw, loaded.methods[name].arw, rtol=1e-9)
        assert run.nodes == loaded.methods[name].nodes

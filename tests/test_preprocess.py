"""Tests of adavar.io.preprocess: detrend, mean removal, decimation, selection, pipelines."""

from __future__ import annotations

import json

import numpy as np
import pytest

from adavar.core.errors import AdavarInputError
from adavar.io.preprocess import (
    Pipeline,
    Step,
    decimate,
    detrend,
    fit_trend,
    preprocess,
    remove_mean,
    select,
)


def _one_line(exc: pytest.ExceptionInfo) -> str:
    message = str(exc.value)
    assert message and "\n" not in message
    return message


# --------------------------------------------------------------------------------------
# detrend / mean
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(("n", "offset"), [(1000, 0.0), (2_500_000, 1e5)])
def test_detrend_removes_exact_cubic(n, offset):
    rng = np.random.default_rng(7)
    std = 0.01
    noise = rng.normal(0.0, std, n)
    s = np.linspace(0.0, 1.0, n)
    cubic = std * (offset + 3e3 * s - 5e3 * s**2 + 2e3 * s**3)
    clean = detrend(noise, 3, rate=100.0)
    dirty = detrend(noise + cubic, 3, rate=100.0)
    assert np.max(np.abs(dirty - clean)) < 1e-9 * std
    # the residual is orthogonal to the polynomials of degree <= 3
    v = np.polynomial.legendre.legvander(2 * s - 1, 3)
    assert np.max(np.abs(v.T @ clean)) / n < 1e-12


@pytest.mark.parametrize("order", [0, 1, 3, 10])
@pytest.mark.parametrize("n", [11, 999, 1000, 1001, 2501])
def test_detrend_in_blocks_is_the_least_squares_fit(monkeypatch, n, order):
    """Blocks of 1000 samples (the library's are 2**20): the basis of every block is
    legvander's bit for bit, and the residual is the one-shot least-squares residual."""
    import adavar.io.preprocess as pre

    if n <= order:
        pytest.skip("fewer samples than coefficients")
    monkeypatch.setattr(pre, "_CHUNK", 1000)
    rng = np.random.default_rng(n + order)
    t = np.arange(n) * (2.0 / (n - 1)) - 1.0
    blocks = pre._LegendreBlocks(n, order)
    for start in blocks.starts():
        ref = np.polynomial.legendre.legvander(t[start : start + 1000], order)
        got = blocks.basis(start)
        assert np.array_equal(got, ref) and got.strides == ref.strides
    # noise on a large offset and drift: the residual of the full-matrix solution
    x = np.c_[rng.standard_normal(n) + 1e6 + 3e3 * t, rng.standard_normal(n).astype(np.float32)]
    v = np.polynomial.legendre.legvander(t, order)
    ref = x - v @ np.linalg.lstsq(v, x, rcond=None)[0]
    np.testing.assert_allclose(detrend(x, order), ref, rtol=0, atol=1e-8)


def test_detrend_orders_and_channels():
    rng = np.random.default_rng(1)
    n = 500
    t = np.arange(n) / 10.0
    x = np.c_[rng.standard_normal(n) + 5.0 + 0.2 * t, rng.standard_normal(n) - 2.0 * t**2]
    y = detrend(x, 2, rate=10.0)
    assert y.shape == x.shape and y.dtype == np.float64
    for j in range(2):
        np.testing.assert_allclose(y[:, j], detrend(x[:, j], 2, rate=10.0), atol=1e-12)
        coef = np.polynomial.polynomial.polyfit(t, x[:, j], 2)
        ref = x[:, j] - np.polynomial.polynomial.polyval(t, coef)
        np.testing.assert_allclose(y[:, j], ref, atol=1e-9)
    np.testing.assert_allclose(detrend(x[:, 0], 0), x[:, 0] - x[:, 0].mean(), atol=1e-12)
    # an integer record is accepted
    assert detrend(np.arange(10), 1).max() < 1e-12


def test_fit_trend_in_seconds():
    t0, rate, n = 50.0, 4.0, 400
    t = t0 + np.arange(n) / rate
    x = 1.5 - 0.25 * t + 1e-3 * t**3
    (poly,) = fit_trend(x, 3, rate=rate, t0=t0)
    np.testing.assert_allclose(poly(t), x, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(
        poly.convert(domain=[-1, 1], window=[-1, 1]).coef, [1.5, -0.25, 0.0, 1e-3], atol=1e-8
    )


def test_remove_mean_large_offset():
    rng = np.random.default_rng(3)
    noise = rng.standard_normal(10_000)
    y = remove_mean(noise + 1e9)
    np.testing.assert_allclose(y, noise - noise.mean(), atol=1e-6)
    assert abs(y.mean()) < 1e-12
    assert remove_mean(np.ones((4, 3))).shape == (4, 3)


def test_detrend_errors():
    x = np.arange(10.0)
    for bad in (-1, 2.5, "x", True):
        with pytest.raises(AdavarInputError) as exc:
            detrend(x, bad)
        assert "order" in _one_line(exc)
    with pytest.raises(AdavarInputError) as exc:
        detrend(x[:3], 3)
    assert "at least 4 samples" in _one_line(exc)
    with pytest.raises(AdavarInputError) as exc:
        detrend(np.array([1.0, 2.0, np.nan, 4.0, 5.0]), 1)
    assert "first at sample 2" in _one_line(exc)
    with pytest.raises(AdavarInputError) as exc:
        remove_mean(np.array([1.0, np.inf]))
    assert "first at sample 1" in _one_line(exc)
    for bad_x in (np.zeros((2, 2, 2)), np.array([]), np.array(["a", "b"])):
        with pytest.raises(AdavarInputError) as exc:
            detrend(bad_x, 0)
        _one_line(exc)
    with pytest.raises(AdavarInputError) as exc:
        detrend(x, 1, rate=0.0)
    assert "rate" in _one_line(exc)


# --------------------------------------------------------------------------------------
# decimate / select
# --------------------------------------------------------------------------------------


def test_decimate_keep_and_average():
    x = np.arange(1005.0)
    kept = decimate(x, 100)
    assert kept.shape == (11,)
    np.testing.assert_array_equal(kept, np.arange(0.0, 1005.0, 100.0))
    avg = decimate(x, 100, method="average")
    assert avg.shape == (10,)
    np.testing.assert_allclose(avg, np.arange(10) * 100 + 49.5)
    x2 = np.c_[x, -x]
    assert decimate(x2, 10).shape == (101, 2)
    np.testing.assert_allclose(
        decimate(x2, 10, method="AVERAGE")[:, 1], -(np.arange(100) * 10 + 4.5)
    )
    np.testing.assert_array_equal(decimate(x, 1), x)


def test_decimate_average_is_the_cluster_average():
    """Averaging white noise by k divides its variance by k; keeping 1 of k does not."""
    rng = np.random.default_rng(11)
    x = rng.standard_normal(400_000)
    assert decimate(x, 100, method="average").var() == pytest.approx(0.01, rel=0.1)
    assert decimate(x, 100, method="keep").var() == pytest.approx(1.0, rel=0.1)


def test_decimate_errors():
    for bad in (0, -3, 2.5, "ten", None):
        with pytest.raises(AdavarInputError) as exc:
            decimate(np.arange(10.0), bad)
        assert "decimation factor" in _one_line(exc)
    with pytest.raises(AdavarInputError) as exc:
        decimate(np.arange(10.0), 2, method="median")
    assert "keep" in _one_line(exc)
    with pytest.raises(AdavarInputError) as exc:
        decimate(np.arange(10.0), 20, method="average")
    assert "at least 20 samples" in _one_line(exc)


def test_select():
    x = np.arange(1000.0)  # 10 Hz, 100 s
    y = select(x, rate=10.0, start=10.0, stop=20.0)
    np.testing.assert_array_equal(y, np.arange(100.0, 200.0))
    np.testing.assert_array_equal(select(x, rate=10.0, start=95.0), np.arange(950.0, 1000.0))
    np.testing.assert_array_equal(select(x, rate=10.0, stop=0.5), np.arange(5.0))
    np.testing.assert_array_equal(select(x, rate=10.0, stop=100.0), x)
    # t0 shifts the clock; a start between samples rounds up
    np.testing.assert_array_equal(
        select(x, rate=10.0, start=1000.05, stop=1000.3, t0=1000.0), [1.0, 2.0]
    )
    # float rounding of start * rate does not lose a sample
    assert select(x, rate=10.0, start=0.3)[0] == 3.0
    assert select(np.c_[x, x], rate=10.0, start=1.0, stop=2.0).shape == (10, 2)


@pytest.mark.parametrize(
    ("start", "stop", "needle"),
    [
        (200.0, None, "outside the record"),
        (None, 150.0, "outside the record"),
        (-5.0, 10.0, "outside the record"),
        (20.0, 10.0, "not after"),
        (10.0, 10.0, "not after"),
        (10.01, 10.05, "no sample"),
    ],
)
def test_select_errors(start, stop, needle):
    with pytest.raises(AdavarInputError) as exc:
        select(np.arange(1000.0), rate=10.0, start=start, stop=stop)
    assert needle in _one_line(exc)


# --------------------------------------------------------------------------------------
# steps and pipelines
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("spec", "name", "params"),
    [
        ("detrend", "detrend", {"order": 3}),
        ("detrend:1", "detrend", {"order": 1}),
        (" Detrend : 2 ", "detrend", {"order": 2}),
        ("mean", "mean", {}),
        ("decimate:100", "decimate", {"factor": 100, "method": "keep"}),
        ("decimate:10:average", "decimate", {"factor": 10, "method": "average"}),
        ("select:100:3600", "select", {"start": 100.0, "stop": 3600.0}),
        ("select:100:", "select", {"start": 100.0, "stop": None}),
        ("select::3600", "select", {"start": None, "stop": 3600.0}),
        ({"name": "decimate", "factor": 5}, "decimate", {"factor": 5, "method": "keep"}),
        ({"step": "detrend", "parameters": {"order": 0}}, "detrend", {"order": 0}),
        ({"name": "select", "start": 1, "stop": 2.5}, "select", {"start": 1.0, "stop": 2.5}),
    ],
)
def test_step_parse(spec, name, params):
    step = Step.parse(spec)
    assert step.name == name and step.parameters == params
    assert Step.parse(step.spec) == step
    assert Step.parse(step) is step


@pytest.mark.parametrize(
    "spec",
    [
        "smooth:3",
        "detrend:-1",
        "detrend:1:2",
        "detrend:x",
        "mean:3",
        "decimate",
        "decimate:0",
        "decimate:10:median",
        "decimate:1:keep:3",
        "select:100",
        "select:20:10",
        "select:a:b",
        {"factor": 3},
        {"name": "detrend", "degree": 3},
        {"name": "decimate"},
        42,
    ],
)
def test_step_parse_errors(spec):
    with pytest.raises(AdavarInputError) as exc:
        Step.parse(spec)
    _one_line(exc)


def test_preprocess_paper_steps_and_record():
    rng = np.random.default_rng(5)
    rate = 100.0
    n = 60_000  # 600 s at 100 Hz
    t = np.arange(n) / rate
    x = rng.standard_normal(n) + 0.5 + 1e-3 * t - 1e-8 * t**3
    y, new_rate, record = preprocess(x, rate=rate, steps=["detrend:3", "decimate:100"])
    assert new_rate == 1.0
    assert y.shape == (600,)
    np.testing.assert_allclose(y, detrend(x, 3)[::100])
    assert [r["spec"] for r in record] == ["detrend:3", "decimate:100:keep"]
    assert record[0] == {
        "name": "detrend", "parameters": {"order": 3}, "spec": "detrend:3",
        "n_in": n, "n_out": n, "rate_in": 100.0, "rate_out": 100.0, "t0_in": 0.0, "t0_out": 0.0,
    }  # fmt: skip
    assert record[1]["n_out"] == 600 and record[1]["rate_out"] == 1.0
    json.dumps(record)  # JSON-ready metadata
    # the record rebuilds the same pipeline, and re-running it reproduces the result
    y2, rate2, record2 = Pipeline(record).run(x, rate=rate)
    np.testing.assert_array_equal(y2, y)
    assert rate2 == new_rate and record2 == record


def test_preprocess_select_tracks_time():
    x = np.arange(36_000.0)  # 10 Hz, 3600 s
    y, rate, record = preprocess(
        x, rate=10.0, t0=0.0, steps="mean, select:100:3600, decimate:10:average, select:200:"
    )
    assert rate == 1.0
    assert [r["name"] for r in record] == ["mean", "select", "decimate", "select"]
    assert record[1]["t0_out"] == 100.0 and record[1]["n_out"] == 35_000
    assert record[2]["n_out"] == 3500 and record[2]["t0_out"] == 100.0
    assert record[3]["t0_out"] == 200.0 and y.shape == (3400,)
    # the first kept block is input samples 2000..2009 (times 200.0..200.9 s)
    assert y[0] == pytest.approx(np.mean(np.arange(2000.0, 2010.0)) - x.mean())


def test_preprocess_empty_pipeline_copies():
    x = np.arange(10, dtype=np.int32)
    y, rate, record = preprocess(x, rate=2.0, steps=[])
    assert y.dtype == np.float64 and rate == 2.0 and record == []
    np.testing.assert_array_equal(y, x)
    assert repr(Pipeline(["mean", "decimate:2"])) == "Pipeline(['mean', 'decimate:2:keep'])"
    assert len(Pipeline("mean")) == 1
    assert Pipeline(["detrend"]).describe() == [
        {"name": "detrend", "parameters": {"order": 3}, "spec": "detrend:3"}
    ]


def test_preprocess_errors_name_the_step():
    x = np.arange(1000.0)
    with pytest.raises(AdavarInputError) as exc:
        preprocess(x, rate=10.0, steps=["mean", "decimate:500"])
    message = _one_line(exc)
    assert "step 2 (decimate:500:keep)" in message and "only 2 samples" in message
    with pytest.raises(AdavarInputError) as exc:
        preprocess(x, rate=10.0, steps=["select:200:300"])
    assert "step 1 (select:200.0:300.0)" in _one_line(exc)
    with pytest.raises(AdavarInputError) as exc:
        preprocess(x[:2], rate=10.0, steps=["mean"])
    assert "2 samples" in _one_line(exc)
    with pytest.raises(AdavarInputError) as exc:
        preprocess(x, rate=-1.0, steps=["mean"])
    assert "rate" in _one_line(exc)
    with pytest.raises(AdavarInputError) as exc:
        preprocess(x, rate=10.0, steps="mean,smooth")
    assert "smooth" in _one_line(exc)
    # min_samples can be relaxed
    y, _, _ = preprocess(x, rate=10.0, steps=["decimate:500"], min_samples=2)
    assert y.shape == (2,)


def test_keep_decimation_of_rate_data_says_what_it_does_to_n(capsys, tmp_path):
    # decimate:10 keeps 1 sample of 10 (the paper's step): N reads sqrt(10) times the
    # record's, which the output now says; averaging, or phase data, alias nothing

    from .cli_helpers import run

    path = tmp_path / "w.npy"
    np.save(path, np.random.default_rng(2).standard_normal(60_000) * 1e-2)
    base = ["avar", str(path), "--rate", "100", "--units", "deg/s"]
    code, out, _ = run(capsys, [*base, "--preprocess", "decimate:10", "--json"])
    notes = json.loads(out)["input"]["preprocessing_notes"]
    assert code == 0 and len(notes) == 1 and "sqrt(10) = 3.16 times" in notes[0]
    code, out, _ = run(capsys, [*base, "--preprocess", "decimate:10"])
    assert "note: decimate:10:keep kept 1 rate sample of 10" in out
    for extra in (["--preprocess", "decimate:10:average"],
                  ["--preprocess", "decimate:10", "--data-type", "phase"]):  # fmt: skip
        code, out, _ = run(capsys, [*base, *extra, "--json"])
        assert code == 0 and "preprocessing_notes" not in json.loads(out)["input"]

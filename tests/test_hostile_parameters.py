"""Hostile input and parameters get a one-line error (exit 2), never an internal error.

A constant record given to ``monitor``, ``davar``, ``adaptive`` and ``compare``; a
``--tau-range`` or ``--bandwidth`` that leaves no tau of the windows; an ``--lmax`` beyond
the free memory (``monitor``) or of 1e21 samples; a sample rate of 1e300 or 1e-300 Hz; a
tau of 1e300 s (no RuntimeWarning on the way).
"""

from __future__ import annotations

import io
import sys
import warnings

import numpy as np
import pytest

import adavar.io.sources
from adavar import adaptive_davar, davar, fit_noise
from adavar.core.errors import AdavarInputError
from adavar.core.taus import averaging_factors
from adavar.dynamic.kurtosis_reference import record_reference

from .cli_helpers import assert_one_line_error, run

RATE = "100"
N = 3000  # 30 s at 100 Hz


def _csv(path, values):
    path.write_text("gx\n" + "".join(f"{float(v)!r}\n" for v in values), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    here = tmp_path_factory.mktemp("hostile")
    noise = np.random.default_rng(5).normal(size=N)
    return {
        "base": _csv(here / "base.csv", noise),
        "const": _csv(here / "const.csv", np.full(N, 1.5)),
    }


def _stdin(monkeypatch, lines):
    monkeypatch.setattr(sys, "stdin", io.StringIO("".join(f"{v}\n" for v in lines)))


# --------------------------------------------------------------------------------------
# a constant record
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["0.1", "0"])
@pytest.mark.parametrize("method", ["adaptive", "kurtosis"])
def test_monitor_constant_stream(value, method, capsys, monkeypatch):
    _stdin(monkeypatch, [value] * 2000)
    argv = ["monitor", "-", "--rate", RATE, "--units", "deg/s", "--lmax", "240",
            "--method", method]  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # none on the way
        result = run(capsys, argv)
    assert_one_line_error(*result, "constant", f"({value} in every one)", "no", "noise",
                          "leave out the constant start")  # fmt: skip


def test_monitor_constant_start_is_a_stretch_not_an_error(capsys, monkeypatch):
    """A constant start shorter than the head the thresholds are calibrated on is read."""
    noise = np.random.default_rng(7).normal(size=3000)
    _stdin(monkeypatch, ["0.1"] * 300 + [f"{v!r}" for v in noise.tolist()])
    code, _out, err = run(capsys, ["monitor", "-", "--rate", RATE, "--units", "deg/s",
                                   "--lmax", "240"])  # fmt: skip
    assert code == 0, err
    assert "internal error" not in err


def test_library_constant_head_is_refused():
    with pytest.raises(AdavarInputError, match="constant"):
        adaptive_davar(np.full(4000, 0.1), rate=100.0, lmax=200)


def test_kurtosis_reference_of_flat_blocks_is_no_transform():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ref = record_reference(np.full(9000, 0.1), lmin=600)
        half = np.full(9000, 0.1)
        half[:4500] = 0.3
        ref2 = record_reference(half, lmin=600)
    assert ref.theta == 0.0 and ref2.theta == 0.0


@pytest.mark.parametrize(
    "argv, what",
    [
        (["davar", "--window", "1000"], "a dynamic Allan variance"),
        (["adaptive"], "the adaptive window"),
        (["compare"], "the windows to compare"),
    ],
)
def test_constant_column_surface_commands(argv, what, files, capsys):
    cmd, *extra = argv
    code, out, err = run(capsys, [cmd, str(files["const"]), "--units", "deg/s", "--rate", RATE,
                                  *extra, "--json"])  # fmt: skip
    assert_one_line_error(code, out, err, "column 'gx' is constant", "1.5", what, "--column")


# --------------------------------------------------------------------------------------
# fit options that leave no tau of the windows
# --------------------------------------------------------------------------------------


def test_davar_tau_range_outside_the_window(files, capsys):
    code, out, err = run(capsys, ["davar", str(files["base"]), "--units", "deg/s", "--rate",
                                  RATE, "--window", "1000", "--tau-range", "100:200",
                                  "--json"])  # fmt: skip
    assert_one_line_error(code, out, err, "--tau-range", "[100, 200] s", "no tau of the windows",
                          "0.01 .. 3.33 s", "longer window")  # fmt: skip


def test_adaptive_bandwidth_leaves_no_tau(files, capsys):
    code, out, err = run(capsys, ["adaptive", str(files["base"]), "--units", "deg/s", "--rate",
                                  RATE, "--bandwidth", "1e-9", "--json"])  # fmt: skip
    assert_one_line_error(code, out, err, "--bandwidth", "1e-09 Hz", "leaves no tau",
                          "2e+09 s")  # fmt: skip


def test_library_surface_fit_without_taus():
    x = np.random.default_rng(1).normal(size=2000)
    surface = davar(x, window=300, rate=100.0)
    with pytest.raises(AdavarInputError, match="no tau of the windows"):
        fit_noise(surface, tau_range=(100.0, 200.0), cells=False)
    # a constant record: its reference fitted no tau (no shortest one to leave out
    # below), and its windows are not fitted
    flat = davar(np.full(2000, 1.5), window=300, rate=100.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        fit = fit_noise(flat, cells=False)
    assert not np.any(np.isfinite(fit.coefficients))


# --------------------------------------------------------------------------------------
# window lengths beyond memory or any record
# --------------------------------------------------------------------------------------


def test_monitor_lmax_beyond_the_free_memory(capsys, monkeypatch):
    monkeypatch.setattr(adavar.io.sources, "available_memory", lambda: 2**30)  # 1 GiB free
    _stdin(monkeypatch, ["0.5", "0.7"] * 10)
    code, out, err = run(capsys, ["monitor", "-", "--rate", RATE, "--units", "deg/s",
                                  "--lmax", "100000000"])  # fmt: skip
    assert_one_line_error(code, out, err, "--lmax", "100000000 samples", "GiB", "free",
                          "or fewer")  # fmt: skip


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["adaptive", "--lmax", "1e19s"], "at least 1e+21 are needed"),
        (["davar", "--window", "1e19s"], "longer than the record"),
        (["compare", "--lmax", "1e19s"], "longer than the record"),
    ],
)
def test_window_of_1e21_samples(argv, fragment, files, capsys):
    cmd, *extra = argv
    code, out, err = run(capsys, [cmd, str(files["base"]), "--units", "deg/s", "--rate", RATE,
                                  *extra])  # fmt: skip
    assert_one_line_error(code, out, err, fragment)


def test_report_adaptive_lmax_1e19s(files, capsys, tmp_path):
    target = tmp_path / "r.html"
    code, out, err = run(capsys, ["report", str(files["base"]), "--units", "deg/s", "--rate",
                                  RATE, "--adaptive", "--lmax", "1e19s",
                                  "-o", str(target)])  # fmt: skip
    assert_one_line_error(code, out, err, "at least")
    assert not target.exists()


# --------------------------------------------------------------------------------------
# the sample rate
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "flag, value",
    [("--rate", "1e300"), ("--rate", "1e-300"), ("--rate", "1e100"), ("--rate", "1e-50"),
     ("--tau0", "1e100"), ("--tau0", "1e-300")],
)  # fmt: skip
def test_avar_sample_rate_is_bounded(flag, value, files, capsys):
    code, out, err = run(capsys, ["avar", str(files["base"]), "--units", "deg/s", flag, value,
                                  "--fit", "--json"])  # fmt: skip
    assert_one_line_error(code, out, err, flag, "1e-12 .. 1e+12", repr(value))


def test_monitor_sample_rate_is_bounded(capsys, monkeypatch):
    _stdin(monkeypatch, ["0.5", "0.7"] * 10)
    code, out, err = run(capsys, ["monitor", "-", "--rate", "1e300", "--units", "deg/s"])
    assert_one_line_error(code, out, err, "--rate", "1e-12 .. 1e+12 Hz")


def test_sample_rate_bounds_themselves_are_accepted(files, capsys):
    for flag, value in (("--rate", "1e12"), ("--tau0", "1e12")):
        code, _out, err = run(capsys, ["avar", str(files["base"]), "--units", "deg/s", flag,
                                       value, "--json"])  # fmt: skip
        assert code == 0, err


# --------------------------------------------------------------------------------------
# a tau of 1e300 s
# --------------------------------------------------------------------------------------


def test_tau_of_1e300_without_runtime_warning(files, capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        result = run(capsys, ["avar", str(files["base"]), "--units", "deg/s", "--rate", RATE,
                              "--taus", "1e300"])  # fmt: skip
        m, notes = averaging_factors([1e300, 0.02], 1000, 0.01)
    assert_one_line_error(*result, "no requested tau")
    assert m.tolist() == [2]
    assert any("dropped 1 tau" in note for note in notes)

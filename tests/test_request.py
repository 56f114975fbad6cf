"""Typed requests: settings objects built once, one pipeline behind the commands."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import adavar
from adavar import cli
from adavar.cli.entry import build_parser
from adavar.core.errors import AdavarInputError
from adavar.core.request import (
    ANALYSIS_CONTROLLER,
    AnalysisRequest,
    MethodOptions,
    RecordRequest,
    WindowSettings,
)
from adavar.core.settings import PAPER, ControllerSettings, FitSettings
from adavar.pipeline.analysis import read_input, resolve_lengths, run

RATE = 100.0


def _record(n: int = 12_000, seed: int = 3) -> np.ndarray:
    """Band-limited noise, quantised, with a level step (not adavar.simulate)."""
    rng = np.random.default_rng(seed)
    x = np.convolve(rng.standard_normal(n + 7), np.ones(8) / 8, mode="valid")[:n] * 1e-2
    x[n // 2 :] += 2e-2
    return np.round(x / 1e-4) * 1e-4


@pytest.fixture(scope="module")
def gyro_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("request") / "gyro.csv"
    x = _record()
    t = np.arange(x.size) / RATE
    np.savetxt(path, np.c_[t, x, 0.5 * x[::-1]], delimiter=",", header="time,gx,gy",
               comments="")  # fmt: skip
    return path


def test_a_request_built_in_code_equals_the_one_the_command_line_builds(gyro_csv):
    # the library's and the command line's defaults are one: the parser's namespace of
    # `adavar report FILE --units U` gives the request a script writes with two fields
    args = build_parser().parse_args(["report", str(gyro_csv), "--column", "gx", "--units",
                                      "deg/s", "-o", "r.html"])  # fmt: skip
    assert AnalysisRequest.from_options(args) == AnalysisRequest(
        record=RecordRequest(str(gyro_csv), column="gx", units="deg/s")
    )
    # the analyses' controller is the library's: windows from the record, hourly thresholds
    assert ANALYSIS_CONTROLLER.lmax is None and ANALYSIS_CONTROLLER.thresholds == "calibrated"
    assert ANALYSIS_CONTROLLER != PAPER
    from types import SimpleNamespace

    from adavar.settings import ANALYSIS_DEFAULTS

    # one definition: the settings' own defaults are the command line's
    assert ControllerSettings() == ANALYSIS_CONTROLLER
    assert ControllerSettings.from_options(SimpleNamespace(**ANALYSIS_DEFAULTS)) == (
        ControllerSettings()
    )


def test_the_request_given_is_never_changed(gyro_csv):
    request = AnalysisRequest(
        record=RecordRequest(str(gyro_csv), column="gx", units="deg/s"),
        window=WindowSettings(adaptive=True, taus=None, step=None),
        controller=dataclasses.replace(ANALYSIS_CONTROLLER, lmax="5s"),
    )
    before = dataclasses.asdict(request)
    done = run(request, whole="reference")
    assert dataclasses.asdict(request) == before
    used = done.request
    assert used.record.rate == pytest.approx(RATE)  # from the time stamps
    assert used.controller.lmax == 500 and used.windows_from == "lmax"
    assert used.window.taus == "all" and used.window.step == 1
    assert done.channels["gx"].request == used


def test_run_gives_the_library_calls_numbers(gyro_csv):
    request = AnalysisRequest(
        record=RecordRequest(str(gyro_csv), column="gx", units="deg/s", rate=RATE),
        window=WindowSettings(adaptive=True, step=7),
        method_options=MethodOptions(method="kurtosis"),
    )
    done = run(request)
    x = np.loadtxt(gyro_csv, delimiter=",", skiprows=1)[:, 1]
    direct = adavar.adaptive_davar(x, rate=RATE, method="kurtosis", step=7, taus="octave",
                                   units="deg/s")  # fmt: skip
    channel = done.channels["gx"]
    np.testing.assert_array_equal(channel.surface.avar, direct.avar)
    np.testing.assert_array_equal(channel.surface.window, direct.window)
    whole = adavar.fit_noise(adavar.deviation(x, rate=RATE, units="deg/s"))
    assert channel.fit.angle_random_walk.value == whole.angle_random_walk.value


def test_the_adaptive_command_is_the_pipeline(gyro_csv, capsys):
    code = cli.main(["adaptive", str(gyro_csv), "--column", "gx", "--units", "deg/s",
                     "--lmax", "1000", "--step", "50", "--json"])  # fmt: skip
    assert code == 0
    payload = json.loads(capsys.readouterr().out)
    request = AnalysisRequest(
        record=RecordRequest(str(gyro_csv), column="gx", units="deg/s"),
        window=WindowSettings(adaptive=True, taus=None, step=50),
        controller=dataclasses.replace(ANALYSIS_CONTROLLER, lmax=1000),
    )
    channel = run(request, whole="reference").channels["gx"]
    assert payload["window"]["min"] == int(np.min(channel.surface.window))
    assert payload["fit"] is not None
    assert payload["parameters"]["controller"]["lmax"] == 1000


def test_read_input_leaves_the_record_request_and_reports_what_it_read(tmp_path):
    phase = np.cumsum(np.random.default_rng(1).standard_normal(500)) * 1e-9
    path = tmp_path / "clock.phd"
    np.savetxt(path, phase)
    record = RecordRequest(str(path), tau0=1.0, units="s")
    loaded = read_input(record)
    assert record.data_type == "rate" and loaded.record.data_type == "phase"
    assert loaded.record.tau0 == 1.0 and loaded.record.rate is None and loaded.tau0 == 1.0
    with pytest.raises(AdavarInputError, match="exactly one"):
        read_input(dataclasses.replace(record, rate=1.0))


def test_resolve_lengths_returns_a_copy_of_options():
    import argparse

    options = argparse.Namespace(window="10s", lmax=None, lmin=None, segment=None, step=1)
    used = resolve_lengths(options, 0.01, 100_000)
    assert options.window == "10s" and options.lmax is None
    assert used.window == 1000 and used.lmax == 10_000 and used.windows_from == "record"


def test_library_functions_take_the_same_settings_objects():
    x = _record(6000)
    settings = dataclasses.replace(ANALYSIS_CONTROLLER, lmax=600, lmin=400, l=100,
                                   thresholds="paper")  # fmt: skip
    method = MethodOptions(method="kurtosis")
    a = adavar.adaptive_davar(x, rate=RATE, step=5, settings=settings, method_options=method)
    b = adavar.adaptive_davar(x, rate=RATE, step=5, lmax=600, lmin=400, l=100,
                              thresholds="paper", method="kurtosis")  # fmt: skip
    np.testing.assert_array_equal(a.avar, b.avar)
    np.testing.assert_array_equal(a.window, b.window)
    # the defaults given as one object are the defaults
    c = adavar.adaptive_davar(x, rate=RATE, step=5, settings=ANALYSIS_CONTROLLER)
    d = adavar.adaptive_davar(x, rate=RATE, step=5)
    np.testing.assert_array_equal(c.window, d.window)
    with pytest.raises(AdavarInputError, match="lmax is given both"):
        adavar.adaptive_davar(x, rate=RATE, lmax=800, settings=settings)

    result = adavar.deviation(x, rate=RATE, units="deg/s")
    fit = FitSettings(method="wls", n_reweight=2)
    e = adavar.fit_noise(result, settings=fit)
    f = adavar.fit_noise(result, method="wls", n_reweight=2)
    assert e.angle_random_walk.value == f.angle_random_walk.value
    with pytest.raises(AdavarInputError, match="method is given both"):
        adavar.fit_noise(result, method="gls", settings=fit)


def test_controller_settings_round_trip_through_the_flags():
    args = build_parser().parse_args(["adaptive", "f.csv", "--units", "deg/s", "--lmax", "30s",
                                      "--false-alarm", "0.001", "--l", "2s"])  # fmt: skip
    request = AnalysisRequest.from_options(args)
    assert request.controller == ControllerSettings.from_options(args)
    assert request.controller.false_alarm == 0.001
    assert request.controller.false_alarm_per_hour is None
    assert request.record.units == "deg/s" and request.window.taus is None


def test_the_stream_takes_the_same_settings_objects():
    x = _record(8000, seed=5)
    settings = dataclasses.replace(ANALYSIS_CONTROLLER, lmax=400, lmin=200, l=60)
    typed = adavar.OnlineAdaptive(
        rate=RATE, settings=settings, method_options=MethodOptions(method="kurtosis"), step=4
    )
    plain = adavar.OnlineAdaptive(rate=RATE, lmax=400, lmin=200, l=60, method="kurtosis",
                                  step=4)  # fmt: skip
    for live in (typed, plain):
        live.push(x)
        live.finish()
    np.testing.assert_array_equal(typed.window, plain.window)
    np.testing.assert_array_equal(typed.arw, plain.arw)
    with pytest.raises(AdavarInputError, match="change_times"):
        adavar.OnlineAdaptive(rate=RATE, method_options=MethodOptions(change_times=[1.0]))


def test_a_wrong_settings_object_or_option_name_is_an_error():
    x = _record(3000)
    with pytest.raises(AdavarInputError, match="expected a ControllerSettings, got FitSettings"):
        adavar.adaptive_davar(x, rate=RATE, settings=FitSettings())
    with pytest.raises(AdavarInputError, match="expected a FitSettings, got dict"):
        adavar.fit_noise(adavar.deviation(x, rate=RATE), settings={"method": "wls"})
    with pytest.raises(AdavarInputError, match="unknown analysis option 'widnow'"):
        AnalysisRequest.from_options({"file": "f.csv", "widnow": 100})
    with pytest.raises(AdavarInputError, match=r"record=\.\.\.\) takes a RecordRequest, not str"):
        AnalysisRequest(record="f.csv")


def test_run_takes_options_by_the_flags_names(gyro_csv):
    done = run({"file": str(gyro_csv), "column": "gy", "units": "deg/s", "window": "10s",
                "step": 100})  # fmt: skip
    assert done.request.window.window == 1000 and done.channels["gy"].surface is not None


def test_the_comparison_takes_the_controller_settings_object():
    from adavar.settings import PAPER

    scenario = adavar.simulate.paper_scenario(1, seed=2)
    settings = dataclasses.replace(PAPER, k2=3.4, l=80)
    typed = adavar.compare(scenario, methods=["a-davar"], settings=settings)
    plain = adavar.compare(scenario, methods=["a-davar"], k2=3.4, l=80)
    np.testing.assert_array_equal(typed.methods["a-davar"].window, plain.methods["a-davar"].window)
    np.testing.assert_array_equal(typed.methods["a-davar"].arw, plain.methods["a-davar"].arw)
    with pytest.raises(AdavarInputError, match=r"false_alarm_per_hour=0\.1 .* set it to None"):
        adavar.compare(scenario, settings=ControllerSettings(lmax=600, lmin=400, l=100))


def test_a_fixed_and_an_adaptive_window_together_are_an_error(gyro_csv, capsys):
    # before 0.3 the adaptive window won and the fixed one was dropped without a word
    with pytest.raises(AdavarInputError, match="fixed window and adaptive=True"):
        WindowSettings(window=1000, adaptive=True)
    from adavar.batch import run_batch

    with pytest.raises(AdavarInputError, match="give one of them"):
        run_batch(
            [str(gyro_csv)],
            out="never",
            options={"units": "deg/s", "column": "gx", "window": 100, "adaptive": True},
        )
    code = cli.main(["report", str(gyro_csv), "--column", "gx", "--units", "deg/s",
                     "--window", "1000", "--adaptive", "-o", "r.html"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and "--window L asks for a fixed window and --adaptive" in err


def test_a_unit_per_group_of_channels(gyro_csv):
    from adavar.core.request import UnitGroup

    groups = (UnitGroup(("gx",), "deg/s", "--gyro-units"), UnitGroup(("gy",), "g", "--accel-units"))
    request = RecordRequest(str(gyro_csv), column=["gx", "gy"], unit_groups=groups)
    loaded = read_input(request, several=True)
    assert loaded.units == {"gx": "deg/s", "gy": "g"}
    # a group without a unit, in a file that declares none: the flags are named
    missing = dataclasses.replace(request, unit_groups=(groups[0], UnitGroup(("gy",))))
    with pytest.raises(AdavarInputError, match=r"--gyro-units .* and --units .*never guesses"):
        read_input(missing, several=True)
    # one way to declare the units, and groups of names
    with pytest.raises(AdavarInputError, match="give one of them"):
        RecordRequest(str(gyro_csv), units="deg/s", unit_groups=groups)
    with pytest.raises(AdavarInputError, match="tuple of column names"):
        UnitGroup("gx", "deg/s")
    with pytest.raises(AdavarInputError, match="UnitGroup objects"):
        RecordRequest(str(gyro_csv), unit_groups=("deg/s",))


def test_kalibr_runs_the_pipeline_with_a_unit_per_sensor(tmp_path):
    from adavar.cli.kalibr import kalibr_request

    rng = np.random.default_rng(4)
    n = 6000
    cols = [np.arange(n) / 200.0] + [1e-3 * rng.standard_normal(n) for _ in range(6)]
    path = tmp_path / "imu.csv"
    np.savetxt(path, np.column_stack(cols), delimiter=",", header="time,gx,gy,gz,ax,ay,az",
               comments="")  # fmt: skip
    args = build_parser().parse_args(["kalibr", str(path), "--gyro-units", "deg/s",
                                      "--accel-units", "g", "-o", "imu.yaml"])  # fmt: skip
    request = kalibr_request(args)
    done = run(request, whole="fit")
    assert [c.units for c in done.channels.values()] == ["deg/s"] * 3 + ["g"] * 3
    assert done.request.record.rate == 200.0
    # the pipeline's fit is the library's on the same samples
    direct = adavar.fit_noise(adavar.deviation(cols[4], rate=200.0, units="g"))
    np.testing.assert_array_equal(done.channels["ax"].fit.coefficients, direct.coefficients)

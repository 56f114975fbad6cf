"""Every parameter of the library API is reachable from the command line.

Two checks per public function: its keywords (``inspect.signature``) each have a flag on the
command that calls it (an explicit, commented allow-list for the few that are not flags), and
a run of that command with every such flag set to a non-default value hands exactly those
values to the function (the function is replaced by a recorder that stops the command).
A new keyword in the library fails this file until the CLI passes it on.
"""

from __future__ import annotations

import importlib
import inspect
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import adavar
from adavar import cli, readers, simulate
from adavar import comparison as compare_module
from adavar.output.plots import rate_unit
from adavar.paper import scenarios as paper_scenarios
from adavar.paper import studies as paper_studies
from adavar.simulation import generators

from .cli_helpers import patch_cli, run

#: Library keyword -> CLI flag, where the flag is not the keyword with dashes.
RENAMED = {
    "data": "FILE",  # the record: the positional FILE (or compare/simulate --scenario)
    "path": "FILE",  # read_record's file
    "columns": "--column",  # one name or several, comma-separated
    "angle_random_walk": "--arw",  # simulate: the usual abbreviations
    "rate_random_walk": "--rrw",
    "number": "--scenario",  # simulate.paper_scenario(number)
    "truth": "--truth-column",  # compare: the true N of every sample, a column of FILE
}

#: Keywords that are intentionally not flags, and why.
NOT_FLAGS = {
    # the fit's input is what the command just computed (the deviation or the surface)
    "result",
    "tau",
    "avar",
    "edf",
    # compare: the record's description is written from FILE, --column, the rate and unit
    "description",
    # compare --seeds: the command draws its own progress bar with this callback
    "progress",
    # davar: a lazy dask surface is for dask arrays in Python; the CLI reads files (it
    # streams them out of core, and writes the surface it computed)
    "lazy",
    # fit_noise(reference=): the whole-record fit, which the command makes itself
    "reference",
    # fit_noise(settings=), adaptive_davar(settings=, method_options=): the flags as the
    # settings objects of a request, which the command builds from them
    "settings",
    "method_options",
    # davar(shift=): per-centre window offsets, which adaptive --method ici computes itself
    "shift",
    # fit_noise(cells=), compare(keep=): how much of what it computes a result holds; the
    # commands keep only what they write (issue 15: memory)
    "cells",
    "keep",
    # davar(bounds=False): a surface without its bound table, for compare(keep="figures");
    # the davar command writes the bounds
    "bounds",
    # davar(rows=): a block of a surface, for code that works through a long record's
    # surface piece by piece (adavar.dynamic.surface_fit); the command writes the whole surface
    "rows",
    # read_record(memory_map=): the commands always read .npy files with file reads, never
    # through a map (a file cut short meanwhile is then an error, not a SIGBUS crash)
    "memory_map",
}

#: (function, commands that call it with the user's settings)
FUNCTIONS = [
    (adavar.deviation, ("avar",)),
    (adavar.fit_noise, ("avar", "davar", "adaptive", "report")),
    (adavar.fit_avar, ("avar",)),  # fit_noise's curve form: the same options
    (adavar.davar, ("davar",)),
    (adavar.adaptive_davar, ("adaptive",)),
    (adavar.adaptive_schedule, ("adaptive",)),  # called by adaptive_davar with its settings
    (compare_module.compare, ("compare",)),
    (adavar.compare_seeds, ("compare",)),
    (readers.read_record, ("avar", "davar", "adaptive", "report", "compare")),
    (simulate.sensor, ("simulate",)),
    (simulate.paper_scenario, ("simulate", "compare")),
]


def flags_of(command: str) -> set[str]:
    """The long options of ``adavar COMMAND`` (and FILE if it takes one)."""
    parser = cli.build_parser()
    flags = set()
    for _, _, action in parser.commands[command].options:
        flags.update(opt for opt in action.option_strings if opt.startswith("--"))
        if action.dest == "file":
            flags.add("FILE")
    return flags


def keywords(function: Any) -> list[str]:
    return [name for name in inspect.signature(function).parameters if name not in NOT_FLAGS]


#: (function name, keyword) -> CLI flag, where the keyword's flag means something else on
#: a command that calls both (adaptive's --method is the controller's).
RENAMED_IN = {
    ("fit_noise", "method"): "--fit-method",
    ("fit_avar", "method"): "--fit-method",
    ("fit_noise", "uncertainty"): "--fit-uncertainty",
    ("fit_avar", "uncertainty"): "--fit-uncertainty",
}


def flag_for(keyword: str, function: Any = None) -> str:
    name = getattr(function, "__name__", None)
    if (name, keyword) in RENAMED_IN:
        return RENAMED_IN[name, keyword]
    return RENAMED.get(keyword, "--" + keyword.replace("_", "-"))


@pytest.mark.parametrize(
    ("function", "command"),
    [(f, c) for f, commands in FUNCTIONS for c in commands],
    ids=lambda v: v if isinstance(v, str) else v.__name__,
)
def test_every_keyword_has_a_flag(function, command):
    flags = flags_of(command)
    missing = [
        f"{k} ({flag_for(k, function)})"
        for k in keywords(function)
        if flag_for(k, function) not in flags
    ]
    assert not missing, f"adavar {command} has no flag for {function.__name__}: {missing}"


def test_allow_list_is_minimal():
    """Every allow-listed name is a keyword of some function, and no rename is unused."""
    names = {n for f, _ in FUNCTIONS for n in inspect.signature(f).parameters}
    assert NOT_FLAGS <= names
    assert set(RENAMED) <= names


def test_chunk_size_flag_on_the_commands_that_read_records():
    for command in ("avar", "davar", "adaptive"):
        assert "--chunk-size" in flags_of(command)
    for function in (adavar.deviation, adavar.davar, adavar.adaptive_davar):
        if "chunk_size" in inspect.signature(function).parameters:  # once the library has it
            assert flag_for("chunk_size") == "--chunk-size"


# --------------------------------------------------------------------------------------
# The values arrive
# --------------------------------------------------------------------------------------


def _cli_function(name: str) -> Any:
    """The library function ``name`` as the command modules import it."""
    import pkgutil

    for info in pkgutil.iter_modules(cli.__path__):
        if info.name == "__main__":
            continue
        module = importlib.import_module(f"adavar.cli.{info.name}")
        if callable(getattr(module, name, None)):
            return getattr(module, name)
    from .cli_helpers import LIBRARY  # the commands import these when they run

    for module_name in LIBRARY:
        module = importlib.import_module(module_name)
        if callable(getattr(module, name, None)):
            return getattr(module, name)
    raise AssertionError(f"no adavar.cli module uses {name}")


class Stop(Exception):
    """Raised by a recorder: the command ends there (exit 1, an 'internal error')."""


def recorder(monkeypatch, owner: Any, name: str, returns: Any = None) -> dict[str, Any]:
    """Replace ``owner.name`` by a function that records its arguments by name (and then
    raises :class:`Stop`, or returns ``returns``). Keywords the real function does not have
    yet are recorded too (the CLI may pass them ahead of the library)."""
    real = getattr(owner, name) if owner is not cli else _cli_function(name)
    params = inspect.signature(real).parameters
    seen: dict[str, Any] = {}

    def fake(*args, **kwargs):
        # the settings objects of a typed request: their fields are the keywords
        for key in ("settings", "method_options"):
            if kwargs.get(key) is not None and key in params:
                kwargs.update(kwargs.pop(key).keywords())
        extra = {k: kwargs.pop(k) for k in list(kwargs) if k not in params}
        bound = inspect.signature(real).bind(*args, **kwargs)
        passed = {*bound.arguments, *extra}
        bound.apply_defaults()
        if not seen:  # the first call (report fits twice: the curve, then the surface)
            seen.update(bound.arguments, **extra, _passed=passed)
        if returns is None:
            raise Stop
        return returns

    fake.__wrapped__ = real  # inspect.signature(fake) is the real function's
    if owner is cli:  # every command module holds its own reference
        patch_cli(monkeypatch, name, fake)
    else:
        monkeypatch.setattr(owner, name, fake)
    return seen


@pytest.fixture(scope="module")
def record(tmp_path_factory) -> Path:
    """400 samples of white noise, with a second column (the true N of compare)."""
    x = np.random.default_rng(5).standard_normal(400)
    path = tmp_path_factory.mktemp("params") / "rec.csv"
    path.write_text("x,truth\n" + "".join(f"{v!r},0.5\n" for v in x.tolist()), encoding="utf-8")
    return path


def sample_interval(seen: dict[str, Any]) -> float:
    """tau0 as the function received it (as tau0, or as a rate)."""
    return seen["tau0"] if seen.get("tau0") is not None else 1.0 / seen["rate"]


def check(seen: dict[str, Any], function: Any, expected: dict[str, Any]) -> None:
    """Every keyword of ``function`` (but the allow-listed) is expected and arrived as such."""
    names = set(keywords(function)) - {"data", "path", "rate", "tau0"}
    assert names <= set(expected), f"not checked: {sorted(names - set(expected))}"
    for key, value in expected.items():
        got = seen[key]
        if isinstance(value, float):
            assert got == pytest.approx(value), key
        elif isinstance(value, np.ndarray):
            np.testing.assert_array_equal(got, value, err_msg=key)
        else:
            assert got == value, key


def test_deviation_gets_every_avar_flag(capsys, monkeypatch, record):
    seen = recorder(monkeypatch, cli, "deviation")
    code, _, err = run(capsys, ["avar", str(record), "--column", "x", "--rate", "4", "--units",
                                "deg", "--data-type", "phase", "--stat", "mdev", "--taus",
                                "decade", "--confidence", "0.9", "--points-per-decade", "7",
                                "--chunk-size", "64", "--noise-id", "stable32", "--totdev-edf",
                                "legacy", "--totdev-bias", "--no-bias-correction",
                                "--theo-ratio-terms", "9", "--gaps", "omit",
                                "--total-edf", "stable32", "--no-stationarity-check"])  # fmt: skip
    assert code == 1 and "Stop" in err
    check(seen, adavar.deviation, {
        "stat": "mdev", "data_type": "phase", "taus": "decade", "confidence": 0.9,
        "points_per_decade": 7, "units": rate_unit("deg", "phase"), "chunk_size": 64,
        "noise_id": "stable32", "totdev_edf": "legacy", "totdev_bias": True,
        "bias_correction": False, "theo_ratio_terms": 9, "gaps": "omit",
        "total_edf": "stable32", "stationarity_check": False,
    })  # fmt: skip
    assert sample_interval(seen) == pytest.approx(0.25)
    seen.clear()
    code, _, _ = run(capsys, ["avar", str(record), "--column", "x", "--tau0", "0.5", "--units",
                              "deg/s"])  # fmt: skip
    assert code == 1 and sample_interval(seen) == pytest.approx(0.5)
    assert "chunk_size" not in seen["_passed"]  # only passed on when given
    assert seen["gaps"] == "error"  # the reader's --gaps values leave NaN an error


def test_gaps_omit_reaches_the_reader_as_nan_rows(capsys, monkeypatch, record):
    """avar --gaps omit: the reader marks missing stamps and keeps NaN cells (--nan error,
    the default, becomes keep; --nan drop / interpolate are kept as given)."""
    seen = recorder(monkeypatch, readers, "read_record")
    base = ["avar", str(record), "--column", "x", "--rate", "4", "--units", "deg/s"]
    assert run(capsys, [*base, "--gaps", "omit"])[0] == 1
    assert (seen["gaps"], seen["nan"]) == ("nan", "keep")
    seen.clear()
    assert run(capsys, [*base, "--gaps", "omit", "--nan", "interpolate"])[0] == 1
    assert (seen["gaps"], seen["nan"]) == ("nan", "interpolate")
    seen.clear()  # davar --gaps omit too (adaptive has no gap path)
    assert run(capsys, ["davar", str(record), "--column", "x", "--rate", "4", "--units",
                        "deg/s", "--window", "100", "--gaps", "omit"])[0] == 1  # fmt: skip
    assert (seen["gaps"], seen["nan"]) == ("nan", "keep")
    code, _, err = run(capsys, ["adaptive", str(record), "--rate", "4", "--gaps", "omit"])
    assert code == 2 and "invalid choice: 'omit'" in err


@pytest.mark.parametrize("command", ["avar", "davar", "adaptive", "report"])
def test_fit_noise_gets_the_fit_flags(capsys, monkeypatch, record, tmp_path, command):
    seen = recorder(monkeypatch, cli, "fit_noise")
    extra = {"avar": ["--fit"], "davar": ["--window", "100", "--taus", "octave"],
             "adaptive": ["--lmax", "120", "--lmin", "60", "--l", "30", "--taus", "octave"],
             "report": ["-o", str(tmp_path / "r.html")]}[command]  # fmt: skip
    code, _, err = run(capsys, [command, str(record), "--column", "x", "--rate", "4",
                                "--units", "deg/s", "--terms", "N,K", "--n-reweight", "1",
                                "--spacing", "independent", "--fit-method", "wls",
                                "--select", "none", "--significance", "3", "--exclude",
                                "none", "--rolloff", "none", "--tau-range", "1:", "--bandwidth",
                                "1.5", "--markov", "none", "--bound-level", "0.9",
                                "--fit-uncertainty", "conditional", *extra])  # fmt: skip
    assert code == 1 and "Stop" in err
    check(seen, adavar.fit_noise, {
        "terms": ("angle_random_walk", "rate_random_walk"), "n_reweight": 1,
        "spacing": "independent", "method": "wls", "select": "none", "significance": 3.0,
        "exclude": "none", "rolloff": "none", "tau_range": (1.0, None), "bandwidth": 1.5,
        "markov": "none", "bound_level": 0.9, "uncertainty": "conditional",
        "units": None,  # --units reaches the fit through the result it fits
    })  # fmt: skip
    assert seen["result"].units == "deg/s"
    assert set(keywords(adavar.fit_avar)) == set(keywords(adavar.fit_noise))


def test_davar_gets_every_flag(capsys, monkeypatch, record):
    seen = recorder(monkeypatch, cli, "davar")
    code, _, err = run(capsys, ["davar", str(record), "--column", "x", "--rate", "4",
                                "--units", "deg", "--data-type", "phase", "--window", "100",
                                "--taus", "octave", "--edges", "valid", "--step", "3",
                                "--confidence", "0.9", "--t0", "5", "--points-per-decade",
                                "7", "--noise-type", "-1", "--chunk-size", "64",
                                "--edge-edf", "interior", "--stat", "ohvar", "--gaps",
                                "omit"])  # fmt: skip
    assert code == 1 and "Stop" in err
    check(seen, adavar.davar, {
        "window": 100, "stat": "ohvar", "data_type": "phase", "taus": "octave",
        "edges": "valid", "step": 3,
        "confidence": 0.9, "t0": 5.0, "points_per_decade": 7, "noise_type": -1,
        "units": rate_unit("deg", "phase"), "chunk_size": 64, "edge_edf": "interior",
        "gaps": "omit",
    })  # fmt: skip
    assert sample_interval(seen) == pytest.approx(0.25)
    seen.clear()
    code, _, _ = run(capsys, ["davar", str(record), "--column", "x", "--rate", "4", "--units",
                              "deg/s", "--window", "100", "--taus", "octave", "--noise-type",
                              "0,-1,-2", "--confidence", "none"])  # fmt: skip
    assert code == 1 and seen["noise_type"] == [0, -1, -2] and seen["confidence"] is None
    assert "chunk_size" not in seen["_passed"] and seen["gaps"] == "error"


# the thresholds by hand (--thresholds paper): a flag the chosen thresholds ignore is an
# error, so the calibrated ones' flags are checked in runs of their own
CONTROLLER_FLAGS = ["--lmax", "120", "--lmin", "60", "--k1", "2", "--k2", "4", "--s1", "-0.1",
                    "--s2", "0.1", "--l", "30", "--dl0", "3", "--dl1", "4", "--s-test", "band",
                    "--combine", "and", "--thresholds", "paper"]  # fmt: skip
CONTROLLER = {"lmax": 120, "lmin": 60, "k1": 2.0, "k2": 4.0, "s1": -0.1, "s2": 0.1, "l": 30,
              "dl0": 3, "dl1": 4, "s_test": "band", "combine": "and",
              "thresholds": "paper", "false_alarm": None,
              "false_alarm_per_hour": 0.1}  # fmt: skip  # the defaults (unused: paper)
#: the defaults of the ICI window's flags (each given is checked with --method ici)
ICI_DEFAULTS = {"ici_gamma": 3.0, "ici_lengths": None, "ici_taus": [1], "ici_sides": "both",
                "ici_edf": "correlation", "ici_edf_samples": None, "ici_kurtosis": True,
                "ici_episodes": True, "ici_long_tau": True}  # fmt: skip


#: compare keeps the paper's controller (no per-hour calibration; per step 0.01)
COMPARE = {**{k: v for k, v in CONTROLLER.items() if k != "false_alarm_per_hour"},
           "false_alarm": 0.01}  # fmt: skip


def test_adaptive_davar_gets_every_flag(capsys, monkeypatch, record):
    seen = recorder(monkeypatch, cli, "adaptive_davar")
    code, _, err = run(capsys, ["adaptive", str(record), "--column", "x", "--rate", "4",
                                "--units", "deg/s", "--method", "oracle", "--change-times",
                                "50", *CONTROLLER_FLAGS, "--taus", "decade", "--edges",
                                "valid", "--step", "2", "--confidence", "0.9", "--t0", "1",
                                "--points-per-decade", "7", "--noise-type", "0",
                                "--chunk-size", "64", "--edge-edf", "interior"])  # fmt: skip
    assert code == 1 and "Stop" in err
    expected = {
        "method": "oracle", "change_times": [50.0], **CONTROLLER, "dependence": None,
        "kurtosis_reference": "record",
        "taus": "decade",
        "edges": "valid", "step": 2, "confidence": 0.9, "t0": 1.0, "points_per_decade": 7,
        "noise_type": 0, "data_type": "rate", "units": "deg/s", "chunk_size": 64,
        "edge_edf": "interior", **ICI_DEFAULTS,
    }  # fmt: skip
    check(seen, adavar.adaptive_davar, expected)
    seen.clear()
    code, _, err = run(capsys, ["adaptive", str(record), "--column", "x", "--rate", "4",
                                "--units", "deg/s", "--method", "ici", "--ici-gamma", "2",
                                "--ici-lengths", "30,60,90,120", "--ici-taus", "1,2",
                                "--ici-sides", "centred", "--ici-edf", "engine",
                                "--ici-edf-samples", "5000", "--no-ici-kurtosis",
                                "--no-ici-episodes", "--no-ici-long-tau"])  # fmt: skip
    assert code == 1 and "Stop" in err
    given = {"method": "ici", "ici_gamma": 2.0, "ici_lengths": [30, 60, 90, 120],
             "ici_taus": [1, 2], "ici_sides": "centred", "ici_edf": "engine",
             "ici_edf_samples": 5000, "ici_kurtosis": False, "ici_episodes": False,
             "ici_long_tau": False}  # fmt: skip
    assert {key: seen[key] for key in given} == given
    seen.clear()
    code, _, err = run(capsys, ["adaptive", str(record), "--column", "x", "--rate", "4",
                                "--units", "deg/s", "--false-alarm-per-hour", "0.5",
                                "--dependence", "1.5,1.25", "--kurtosis-reference",
                                "gaussian"])  # fmt: skip
    assert code == 1 and seen["false_alarm_per_hour"] == 0.5
    assert seen["thresholds"] == "calibrated" and seen["false_alarm"] is None
    assert seen["dependence"] == (1.5, 1.25) and seen["kurtosis_reference"] == "gaussian"
    seen.clear()
    code, _, err = run(capsys, ["adaptive", str(record), "--column", "x", "--rate", "4",
                                "--units", "deg/s", "--false-alarm", "0.05"])  # fmt: skip
    assert code == 1 and seen["false_alarm"] == 0.05
    assert seen["false_alarm_per_hour"] is None  # a per-step rate replaces it
    # adaptive_schedule (the controller alone) takes a subset of these, all passed on by
    # adaptive_davar
    assert set(keywords(adavar.adaptive_schedule)) <= set(keywords(adavar.adaptive_davar))


def test_compare_gets_every_flag(capsys, monkeypatch, record):
    seen = recorder(monkeypatch, compare_module, "compare")
    code, _, err = run(capsys, ["compare", str(record), "--column", "x", "--rate", "4",
                                "--units", "deg/s", "--change-times", "50", "--truth-column",
                                "truth", "--methods", "davar-100,a-davar", "--intervals",
                                "0:50,50:100", *CONTROLLER_FLAGS, "--taus", "octave",
                                "--terms", "N", "--confidence", "0.9", "--noise-type", "0",
                                "--points-per-decade", "7", "--step", "5",
                                "--max-memory", "300", "--chunk-size", "4096"])  # fmt: skip
    assert code == 1 and "Stop" in err
    check(seen, compare_module.compare, {
        "methods": ["davar-100", "a-davar"], "change_times": [50.0],
        "truth": np.full(400, 0.5), "intervals": [(0.0, 50.0), (50.0, 100.0)], **COMPARE,
        "taus": "octave", "terms": ("angle_random_walk",), "confidence": 0.9,
        "noise_type": 0, "points_per_decade": 7, "units": "deg/s", "step": 5,
        "max_memory": 300.0, "chunk_size": 4096,
    })  # fmt: skip
    assert seen["rate"] == pytest.approx(4.0)


def test_compare_seeds_gets_every_flag(capsys, monkeypatch):
    from types import SimpleNamespace

    recorder(monkeypatch, compare_module, "compare",
             returns=SimpleNamespace(change_times=(), parameters={"step": 1}))  # fmt: skip
    scenario = recorder(monkeypatch, paper_scenarios, "paper_scenario", returns=SimpleNamespace(
        description="scenario"))  # fmt: skip
    seen = recorder(monkeypatch, paper_studies, "compare_seeds")
    code, _, err = run(capsys, ["compare", "--scenario", "2", "--seed", "5", "--seeds", "3",
                                "--variance-reading", "--methods", "davar-400,a-davar",
                                *CONTROLLER_FLAGS, "--taus", "decade", "--terms", "N",
                                "--crossing-window", "500", "--crossing-thresholds",
                                "4,3.5"])  # fmt: skip
    assert code == 1 and "Stop" in err
    check(seen, adavar.compare_seeds, {
        "scenario": 2, "seeds": range(5, 8), "variance_reading": True,
        "methods": ["davar-400", "a-davar"], **COMPARE, "taus": "decade",
        "terms": ("angle_random_walk",), "crossing_window": 500,
        "crossing_thresholds": (3.5, 4.0),
    })  # fmt: skip
    assert callable(seen["progress"])
    check(scenario, simulate.paper_scenario, {"number": 2, "seed": 5, "variance_reading": True})


@pytest.mark.parametrize("command", ["avar", "davar", "adaptive", "report", "compare"])
def test_read_record_gets_every_reader_flag(capsys, monkeypatch, record, tmp_path, command):
    seen = recorder(monkeypatch, readers, "read_record")
    extra = {"davar": ["--window", "100"], "report": ["-o", str(tmp_path / "r.html")]}
    code, _, err = run(capsys, [command, str(record), "--column", "x", "--rate", "4",
                                "--units", "deg/s", "--time-column", "t", "--time-format",
                                "ms", "--gaps", "interpolate", "--nan", "drop", "--dataset",
                                "/d", "--topic", "/imu", "--gap-tolerance", "0.25", "--lazy",
                                *extra.get(command, [])])  # fmt: skip
    assert code == 1 and "Stop" in err
    check(seen, readers.read_record, {
        "columns": "x", "time_column": "t", "time_format": "ms", "gaps": "interpolate",
        "nan": "drop", "dataset": "/d", "topic": "/imu", "gap_tolerance": 0.25, "lazy": True,
    })  # fmt: skip
    assert seen["path"] == str(record) and seen["rate"] == pytest.approx(4.0)


def test_lazy_is_three_way_and_settable_in_a_config(capsys, monkeypatch, record, tmp_path):
    seen = recorder(monkeypatch, readers, "read_record")
    base = ["avar", str(record), "--rate", "4", "--units", "deg/s"]
    assert run(capsys, base)[0] == 1 and seen["lazy"] is None  # auto: the library decides
    seen.clear()
    assert run(capsys, [*base, "--no-lazy"])[0] == 1 and seen["lazy"] is False
    config = tmp_path / "run.toml"
    config.write_text("[avar]\nlazy = true\n")
    seen.clear()
    assert run(capsys, [*base, "--config", str(config)])[0] == 1 and seen["lazy"] is True
    seen.clear()
    assert run(capsys, [*base, "--config", str(config), "--no-lazy"])[0] == 1
    assert seen["lazy"] is False  # the command line overrides the file
    config.write_text("lazy = 1\n")
    code, _, err = run(capsys, [*base, "--config", str(config)])
    assert code == 2 and "lazy takes true or false" in err


def test_simulate_gets_every_flag(capsys, monkeypatch, tmp_path):
    seen = recorder(monkeypatch, generators, "sensor")
    code, _, err = run(capsys, ["simulate", "-o", str(tmp_path / "s.csv"), "--n", "500",
                                "--rate", "50", "--quantization", "1", "--arw", "2",
                                "--bias-instability", "3", "--rrw", "4", "--rate-ramp", "5",
                                "--bias", "6", "--markov", "0.1,10", "--sinusoid", "1,2,0.5",
                                "--seed", "9", "--bandwidth", "12", "--filter-order", "3",
                                "--lsb", "0.01"])  # fmt: skip
    assert code == 1 and "Stop" in err
    check(seen, simulate.sensor, {
        "n": 500, "rate": 50.0, "quantization": 1.0, "angle_random_walk": 2.0,
        "bias_instability": 3.0, "rate_random_walk": 4.0, "rate_ramp": 5.0, "bias": 6.0,
        "markov": (0.1, 10.0), "sinusoid": (1.0, 2.0, 0.5), "seed": 9, "bandwidth": 12.0,
        "filter_order": 3, "lsb": 0.01,
    })  # fmt: skip
    scenario = recorder(monkeypatch, paper_scenarios, "paper_scenario")
    code, _, _ = run(capsys, ["simulate", "-o", str(tmp_path / "s.csv"), "--scenario", "1",
                              "--seed", "3", "--variance-reading"])  # fmt: skip
    assert code == 1
    check(scenario, simulate.paper_scenario, {"number": 1, "seed": 3, "variance_reading": True})


def test_simulate_markov_and_sinusoid_really_shape_the_record(capsys, tmp_path):
    """The new simulate flags end up in the samples: a sinusoid alone is that sinusoid."""
    out = tmp_path / "sin.csv"
    code, stdout, err = run(capsys, ["simulate", "-o", str(out), "--n", "200", "--rate", "10",
                                     "--sinusoid", "2,0.5,0.25"])  # fmt: skip
    assert code == 0, err
    data = np.loadtxt(out, delimiter=",", skiprows=2)
    t = np.arange(200) / 10.0
    np.testing.assert_allclose(data[:, 1], 2.0 * np.sin(2 * math.pi * 0.5 * t + 0.25),
                               rtol=0, atol=1e-12)  # fmt: skip
    assert "sinusoid=2,0.5,0.25" in stdout
    code, _, err = run(capsys, ["simulate", "-o", str(tmp_path / "m.csv"), "--n", "100",
                                "--markov", "0.1,10", "--seed", "1"])  # fmt: skip
    assert code == 0, err
    np.testing.assert_array_equal(
        np.loadtxt(tmp_path / "m.csv", delimiter=",", skiprows=2)[:, 1],
        simulate.sensor(100, rate=100.0, markov=(0.1, 10.0), seed=1),
    )


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["--sinusoid", "1"], "--sinusoid takes 2 or 3 comma-separated numbers"),
        (["--markov", "1,2,3"], "--markov takes 2 comma-separated numbers"),
        (["--sinusoid", "1,80"], "Nyquist"),  # above half the 100 Hz rate
        (["--markov", "0.1,-1"], "correlation_time"),
        (["--scenario", "1", "--arw", "1"], "drop them or --scenario"),
        (["--arw", "1", "--variance-reading"], "--variance-reading"),
    ],
)
def test_simulate_bad_flags(capsys, tmp_path, argv, fragment):
    out = tmp_path / "x.csv"
    code, stdout, err = run(capsys, ["simulate", "-o", str(out), *argv])
    assert code == 2 and stdout == "" and fragment in err, err
    assert len(err.strip().splitlines()) == 1 and not out.exists()


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["--intervals", "5:1"], "A < B"),
        (["--intervals", "x"], "A:B"),
        (["--crossing-thresholds", "0,3"], "positive kurtosis thresholds"),
        (["--crossing-window", "2"], "at least 3"),
        (["--noise-type", "0,3"], "alpha must lie in -2 .. 2"),
        (["--gap-tolerance", "1.5"], "fraction between 0 and 1"),
    ],
)
def test_compare_bad_flags(capsys, argv, fragment):
    code, stdout, err = run(capsys, ["compare", "--scenario", "1", *argv])
    assert code == 2 and stdout == "" and fragment in err, err


def test_truth_column_is_for_a_file(capsys, record):
    code, _, err = run(capsys, ["compare", "--scenario", "1", "--truth-column", "truth"])
    assert code == 2 and "--truth-column describes a data FILE" in err


def test_report_parser_defaults_are_the_analysis_defaults():
    """adavar.core.settings holds every analysis default once; the parser agrees with it."""
    from adavar.core.settings import ANALYSIS_DEFAULTS

    args = cli.build_parser().parse_args(["report", "FILE", "-o", "report.html"])
    cli_only = {"command", "handler", "file", "output", "json", "force", "title", "config",
                "debug", "help"}  # fmt: skip
    parsed = {k: v for k, v in vars(args).items() if k not in cli_only}
    assert parsed == ANALYSIS_DEFAULTS

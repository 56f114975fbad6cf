"""Tests of ``adavar davar`` (in-process through ``main``, plus one subprocess)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from scipy.io import netcdf_file

import adavar
from adavar import simulate
from adavar.io.text_column import read_text
from adavar.io.writers import OUTPUT_MARKER

from .cli_helpers import assert_one_line_error, patch_cli, run

RATE = 10.0
STD = 0.5
TRUE_N = STD / math.sqrt(RATE)  # white rate noise: N = sigma * sqrt(tau0), deg/sqrt(s)
N_SAMPLES = 4000
WINDOW = 400

FILES = [
    "arw.png", "arw.svg", "coefficients.csv", "davar_heatmap.png", "davar_heatmap.svg",
    "davar_surface.png", "davar_surface.svg", "events.csv", "result.json", "surface.nc",
]  # fmt: skip
TABLES = [name for name in FILES if not name.endswith((".png", ".svg"))]


@pytest.fixture(scope="module")
def gyro_csv(tmp_path_factory):
    """4000 samples of white rate noise at 10 Hz (deg/s) plus time and temperature columns."""
    x = simulate.white(N_SAMPLES, std=STD, rate=RATE, seed=12) + 3.0
    path = tmp_path_factory.mktemp("data") / "gyro.csv"
    lines = ["# logger v1, deg/s", "time,gyro_x,temp"]
    lines += [f"{k / RATE!r},{v!r},21.5" for k, v in enumerate(x.tolist())]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def expected(gyro_csv):
    """What the library gives for the default command line."""
    samples, _ = read_text(gyro_csv, column="gyro_x")
    result = adavar.davar(samples, window=WINDOW, rate=RATE, units="deg/s")
    return result, adavar.fit_noise(result)


def davar_args(path, *extra, window=WINDOW):
    return ["davar", str(path), "--column", "gyro_x", "--rate", str(RATE), "--units", "deg/s",
            "--window", str(window), *extra]  # fmt: skip


# --------------------------------------------------------------------------------------
# Summary and JSON
# --------------------------------------------------------------------------------------


def test_summary(capsys, gyro_csv, expected):
    code, out, err = run(capsys, davar_args(gyro_csv))
    assert code == 0 and err == ""
    result, fit = expected
    assert f"{N_SAMPLES} samples, rate data in deg/s, tau0 = 0.1 s (10 Hz)" in out
    assert f"window {WINDOW} samples (40 s)" in out
    assert f"{N_SAMPLES} windows" in out and f"{result.tau.size} taus" in out
    assert "4000 of 4000 windows fitted" in out
    lines = out.splitlines()
    header = next(line for line in lines if line.lstrip().startswith("term"))
    assert header.split()[:5] == ["term", "unit", "median", "5", "%"]
    k = next(i for i, line in enumerate(lines) if "N  angle random walk" in line)
    cells = lines[k].split()
    assert cells[4] == "deg/sqrt(s)"
    value = fit.angle_random_walk.value
    assert float(cells[5]) == pytest.approx(np.median(value), rel=1e-3)
    assert float(cells[6]) == pytest.approx(np.percentile(value, 5), rel=1e-3)
    assert float(cells[7]) == pytest.approx(np.percentile(value, 95), rel=1e-3)
    assert float(cells[8]) == pytest.approx(value.max(), rel=1e-3)
    assert float(cells[9]) == pytest.approx(result.time[np.argmax(value)])
    conv = lines[k + 1].split()
    assert conv[0] == "deg/sqrt(h)"
    assert float(conv[1]) == pytest.approx(60 * np.median(value), rel=1e-3)
    assert float(cells[5]) == pytest.approx(TRUE_N, rel=0.1)


def test_json_summarises_without_the_surface(capsys, gyro_csv, expected):
    code, out, err = run(capsys, davar_args(gyro_csv, "--json"))
    assert code == 0 and err == ""
    assert len(out) < 50_000  # tau lists and statistics, never the T x M surface
    assert "NaN" not in out and "Infinity" not in out
    payload = json.loads(out)
    result, fit = expected
    assert payload["input"] == {
        "file": str(gyro_csv), "column": "gyro_x", "rate": RATE, "tau0": 1 / RATE,
        "units": "deg/s", "data_type": "rate", "n_samples": N_SAMPLES,
    }  # fmt: skip
    assert payload["parameters"] == {
        "window": WINDOW, "window_s": 40.0, "step": 1, "edges": "mirror", "taus": "all",
        "points_per_decade": 10, "confidence": 0.683,
        "terms": list(adavar.fit.noise_model.TERM_NAMES),
        "resolution": None,  # every centre and every tau fit the default --max-memory
    }  # fmt: skip
    assert payload["shape"] == {"time": N_SAMPLES, "tau": result.tau.size}
    np.testing.assert_array_equal(payload["tau"], result.tau)
    np.testing.assert_array_equal(payload["m"], result.m)
    assert payload["time"]["first"] == result.time[0]
    assert payload["time"]["last"] == result.time[-1]
    assert payload["out"] is None
    stats = payload["fit"]["coefficients"]["angle_random_walk"]
    value = fit.angle_random_walk.value
    assert stats["unit"] == "deg/sqrt(s)"
    assert stats["value"]["median"] == np.median(value)
    assert stats["value"]["p05"] == np.percentile(value, 5)
    assert stats["value"]["p95"] == np.percentile(value, 95)
    assert stats["value"]["max"] == value.max()
    assert stats["value"]["time_of_max"] == result.time[np.argmax(value)]
    assert stats["uncertainty"]["median"] == np.median(fit.angle_random_walk.uncertainty)
    assert stats["conventional"]["unit"] == "deg/sqrt(h)"
    assert stats["conventional"]["value"]["median"] == pytest.approx(60 * np.median(value))
    assert payload["fit"]["n_fitted"] == N_SAMPLES
    assert set(payload["fit"]["coefficients"]) == set(adavar.fit.noise_model.TERM_NAMES)


def test_terms_and_failed_windows_do_not_crash(capsys, gyro_csv):
    # 24-sample windows at octave taus: 4 taus, too few for five terms in every window
    code, out, err = run(capsys, davar_args(gyro_csv, "--json", "--taus", "octave",
                                            window=24))  # fmt: skip
    assert code == 0, err
    fit = json.loads(out)["fit"]
    assert fit["n_fitted"] == 0 and fit["n_windows"] == N_SAMPLES
    assert fit["coefficients"]["angle_random_walk"]["value"]["median"] is None
    code, out, err = run(capsys, davar_args(gyro_csv, "--taus", "octave", window=24))
    assert code == 0, err
    assert "0 of 4000 windows fitted" in out and "4000 windows not fitted" in out
    # the same windows with two terms are fitted
    code, out, err = run(capsys, davar_args(gyro_csv, "--json", "--taus", "octave",
                                            "--terms", "N,K", window=24))  # fmt: skip
    fit = json.loads(out)["fit"]
    assert fit["terms"] == ["angle_random_walk", "rate_random_walk"]
    assert fit["n_fitted"] == N_SAMPLES
    assert fit["coefficients"]["quantization"] is None


def test_unconventional_unit_and_phase_data(capsys, gyro_csv):
    code, out, err = run(capsys, ["davar", str(gyro_csv), "--column", "1", "--tau0", "0.1",
                                  "--units", "mV", "--window", "300", "--step", "50",
                                  "--json"])  # fmt: skip
    assert code == 0, err
    payload = json.loads(out)
    assert payload["shape"]["time"] == N_SAMPLES // 50
    arw = payload["fit"]["coefficients"]["angle_random_walk"]
    assert arw["unit"] == "mV*sqrt(s)" and arw["conventional"] is None
    code, out, err = run(capsys, davar_args(gyro_csv, "--data-type", "phase", "--units", "deg",
                                            "--step", "100", "--taus", "octave"))  # fmt: skip
    assert code == 0, err
    assert "phase data in deg" in out and "deg/sqrt(h)" in out
    assert f"{math.ceil((N_SAMPLES - 1) / 100)} windows" in out  # first differences


# --------------------------------------------------------------------------------------
# Output folder
# --------------------------------------------------------------------------------------


def test_out_folder(capsys, gyro_csv, expected, tmp_path):
    out_dir = tmp_path / "result"
    code, out, err = run(capsys, davar_args(gyro_csv, "--json", "--out", str(out_dir)))
    assert code == 0, err
    assert sorted(p.name for p in out_dir.iterdir()) == [OUTPUT_MARKER, *FILES]
    assert [p.name for p in tmp_path.iterdir()] == ["result"]  # no temporary left behind
    assert "wrote" in err  # JSON mode keeps stdout clean
    payload = json.loads(out)
    assert json.loads((out_dir / "result.json").read_text()) == payload
    assert sorted(payload["out"]["files"]) == FILES and payload["out"]["format"] == "nc"

    result, fit = expected
    with netcdf_file(out_dir / "surface.nc", "r", mmap=False) as nc:
        np.testing.assert_array_equal(nc.variables["avar"][:], result.avar)
        np.testing.assert_array_equal(nc.variables["avar_high"][:], result.avar_high)
        np.testing.assert_array_equal(nc.variables["tau"][:], result.tau)
    with xr.open_dataset(out_dir / "surface.nc") as ds:
        np.testing.assert_array_equal(ds["avar_low"].values, result.avar_low)
        np.testing.assert_array_equal(ds["time"].values, result.time)
        assert ds.attrs["units"] == "deg/s"

    csv_path = out_dir / "coefficients.csv"
    assert csv_path.read_text().startswith("time_s,window,")  # plain CSV: the header first
    value, meta = read_text(csv_path, column="angle_random_walk")
    np.testing.assert_array_equal(value, fit.angle_random_walk.value)
    sigma, _ = read_text(csv_path, column="angle_random_walk_uncertainty")
    np.testing.assert_array_equal(sigma, fit.angle_random_walk.uncertainty)
    assert meta["columns"][:2] == ["time_s", "window"]
    assert meta["columns"][-1] == "reduced_chi2"
    np.testing.assert_array_equal(read_text(csv_path, column="time_s")[0], result.time)
    np.testing.assert_array_equal(read_text(csv_path, column="window")[0], WINDOW)

    for stem in ("davar_surface", "davar_heatmap", "arw"):
        png = (out_dir / f"{stem}.png").read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000, stem
        assert "<svg" in (out_dir / f"{stem}.svg").read_text()[:2000], stem


def test_out_folder_parquet_without_fit(capsys, gyro_csv, tmp_path):
    out_dir = tmp_path / "pq"
    argv = davar_args(gyro_csv, "--out", str(out_dir), "--format", "parquet",
                      "--confidence", "none", "--step", "10")  # fmt: skip
    code, out, err = run(capsys, argv)
    assert code == 0, err
    assert sorted(p.name for p in out_dir.iterdir()) == [
        OUTPUT_MARKER, "davar_heatmap.png", "davar_heatmap.svg", "davar_surface.png",
        "davar_surface.svg", "result.json", "surface.parquet",
    ]  # fmt: skip
    assert "no noise fit" in out and "no confidence bounds" in out
    assert f"wrote {out_dir}/" in out
    frame = pd.read_parquet(out_dir / "surface.parquet")
    samples, _ = read_text(gyro_csv, column="gyro_x")
    result = adavar.davar(samples, window=WINDOW, rate=RATE, step=10, confidence=None,
                          units="deg/s")  # fmt: skip
    surface = frame.pivot(index="time", columns="tau", values="avar").to_numpy()
    np.testing.assert_array_equal(surface, result.avar)
    assert "avar_low" not in frame.columns
    assert frame.attrs["step"] == 10
    assert json.loads((out_dir / "result.json").read_text())["fit"] is None


def test_coefficient_figure_of_another_term(capsys, gyro_csv, tmp_path):
    out_dir = tmp_path / "k"
    code, _, err = run(capsys, davar_args(gyro_csv, "--out", str(out_dir), "--terms", "K",
                                          "--step", "20", "--taus", "octave"))  # fmt: skip
    assert code == 0, err
    names = sorted(p.name for p in out_dir.iterdir())
    assert "rrw.png" in names and "arw.png" not in names
    header = (out_dir / "coefficients.csv").read_text().splitlines()[0]
    assert header == "time_s,window,rate_random_walk,rate_random_walk_uncertainty,reduced_chi2"


def test_existing_out_dir_needs_force(capsys, gyro_csv, tmp_path):
    out_dir = tmp_path / "result"
    out_dir.mkdir()
    (out_dir / "keep.txt").write_text("precious")
    # no figures: the folders are the subject here (test_out_folder draws them)
    argv = davar_args(gyro_csv, "--out", str(out_dir), "--step", "40", "--taus", "octave",
                      "--figures", "none")  # fmt: skip
    code, out, err = run(capsys, argv)
    assert_one_line_error(code, out, err, "exists already", "--force")
    assert [p.name for p in out_dir.iterdir()] == ["keep.txt"]
    assert (out_dir / "keep.txt").read_text() == "precious"

    # --force replaces only a folder adavar wrote (tests/test_output_safety.py)
    code, out, err = run(capsys, [*argv, "--force"])
    assert_one_line_error(code, out, err, "not written by adavar")
    assert [p.name for p in out_dir.iterdir()] == ["keep.txt"]
    (out_dir / "keep.txt").unlink()
    for _ in range(2):  # an empty folder, then adavar's
        code, out, err = run(capsys, [*argv, "--force"])
        assert code == 0, err
    assert sorted(p.name for p in out_dir.iterdir()) == [OUTPUT_MARKER, *TABLES]
    assert [p.name for p in tmp_path.iterdir()] == ["result"]

    # --force never replaces the folder holding the input
    folder = gyro_csv.parent
    before = sorted(p.name for p in folder.iterdir())
    code, out, err = run(capsys, davar_args(gyro_csv, "--out", str(folder), "--force"))
    assert_one_line_error(code, out, err, "choose another output folder")
    assert sorted(p.name for p in folder.iterdir()) == before


@pytest.mark.parametrize("command", ["avar", "davar", "adaptive"])
def test_figures_none_writes_the_tables_only_and_says_so(capsys, gyro_csv, tmp_path, command):
    out_dir = tmp_path / command
    argv = [command, str(gyro_csv), "--column", "gyro_x", "--rate", str(RATE), "--units",
            "deg/s", "--json", "--out", str(out_dir), "--figures", " NONE "]  # fmt: skip
    if command == "davar":
        argv += ["--window", str(WINDOW)]
    code, out, err = run(capsys, argv)
    assert code == 0, err
    files = sorted(p.name for p in out_dir.iterdir() if p.name != OUTPUT_MARKER)
    if command == "avar":
        assert files == ["deviation.csv", "result.json"]
    else:
        assert files == TABLES == sorted(json.loads(out)["out"]["files"])


def test_figures_in_the_order_given_each_once(capsys, gyro_csv, tmp_path):
    out_dir = tmp_path / "avar"
    argv = ["avar", str(gyro_csv), "--column", "gyro_x", "--rate", str(RATE), "--units",
            "deg/s", "--out", str(out_dir), "--figures", "svg,eps,svg"]  # fmt: skip
    code, out, err = run(capsys, argv)
    assert code == 0, err
    assert "(deviation.csv, deviation.svg, deviation.eps, result.json)" in out
    assert (out_dir / "deviation.eps").read_text()[:4] == "%!PS"
    assert not (out_dir / "deviation.png").exists()


@pytest.mark.parametrize("value", ["jpg", "png,,gif", "", "none,png"])
def test_unknown_figure_format_is_one_line_and_writes_nothing(capsys, gyro_csv, tmp_path,
                                                              value):  # fmt: skip
    out_dir = tmp_path / "out"
    argv = davar_args(gyro_csv, "--out", str(out_dir), "--figures", value)
    code, out, err = run(capsys, argv)
    assert_one_line_error(code, out, err, "--figures", "png, svg, pdf, eps, or none")
    assert not out_dir.exists()


# --------------------------------------------------------------------------------------
# --------------------------------------------------------------------------------------
# Bad input
# --------------------------------------------------------------------------------------


@pytest.fixture
def nan_csv(tmp_path):
    path = tmp_path / "nan.csv"
    path.write_text("t,x\n" + "".join(f"{k},{k % 7}\n" for k in range(50)) + "50,nan\n")
    return path


BASE = ["--column", "gyro_x", "--rate", "10", "--units", "deg/s"]


@pytest.mark.parametrize(
    ("argv", "fragments"),
    [
        (
            [*BASE, "--window", "5000"],
            ["window of 5000 samples is longer than the record", "4000 samples"],
        ),
        ([*BASE, "--window", "2"], ["--window", "at least 3"]),
        ([*BASE, "--window", "0"], ["--window", "at least 3"]),
        ([*BASE, "--window", "12.5"], ["--window", "whole number"]),
        ([*BASE], ["required", "--window"]),
        (
            ["--column", "gyro_x", "--rate", "0", "--units", "deg/s", "--window", "100"],
            ["--rate", "positive"],
        ),
        (
            ["--column", "gyro_x", "--rate", "-10", "--units", "deg/s", "--window", "100"],
            ["--rate", "positive"],
        ),
        (["--column", "gyro_x", "--rate", "10", "--window", "100"], ["--units"]),
        (
            [
                "--column",
                "gyro_x",
                "--rate",
                "10",
                "--tau0",
                "0.1",
                "--units",
                "deg/s",
                "--window",
                "100",
            ],
            ["exactly one"],
        ),
        (
            ["--column", "gyro_y", "--rate", "10", "--units", "deg/s", "--window", "100"],
            ["unknown column 'gyro_y'", "'time', 'gyro_x', 'temp'"],
        ),
        (["--rate", "10", "--units", "deg/s", "--window", "100"], ["--column", "2 channels"]),
        ([*BASE, "--window", "100", "--step", "0"], ["--step", "positive integer"]),
        ([*BASE, "--window", "100", "--edges", "wrap"], ["--edges", "invalid choice"]),
        ([*BASE, "--window", "100", "--data-type", "angle"], ["--data-type"]),
        ([*BASE, "--window", "100", "--confidence", "1.5"], ["--confidence", "none"]),
        ([*BASE, "--window", "100", "--taus", "1e6,1e7"], ["no requested tau"]),
        ([*BASE, "--window", "100", "--taus", "soon"], ["--taus"]),
        ([*BASE, "--window", "100", "--terms", "N,X"], ["unknown noise term 'X'"]),
        (
            [*BASE, "--window", "100", "--confidence", "none", "--terms", "N"],
            ["--terms needs the confidence bounds"],
        ),
        ([*BASE, "--window", "100", "--format", "hdf5"], ["--format", "invalid choice"]),
        ([*BASE, "--window", "100", "--bogus"], ["unrecognized arguments: --bogus"]),
    ],
)
def test_bad_input_exit_2_one_line_and_no_output(capsys, gyro_csv, tmp_path, argv, fragments):
    out_dir = tmp_path / "out"
    code, out, err = run(capsys, ["davar", str(gyro_csv), *argv, "--out", str(out_dir)])
    assert_one_line_error(code, out, err, *fragments)
    assert not out_dir.exists()
    assert list(tmp_path.iterdir()) == []  # nor a temporary sibling


@pytest.mark.parametrize(
    ("argv", "fragments"),
    [
        (
            ["davar", "{dir}/missing.csv", "--rate", "1", "--units", "deg/s", "--window", "10"],
            ["no such file"],
        ),
        (
            [
                "davar",
                "{nan}",
                "--column",
                "x",
                "--rate",
                "1",
                "--units",
                "deg/s",
                "--window",
                "10",
            ],
            ["row 52", "NaN", "--nan interpolate"],
        ),
        (
            [
                "davar",
                "{nan}",
                "--column",
                "x",
                "--rate",
                "1",
                "--units",
                "deg/s",
                "--window",
                "10",
                "--format",
                "nc",
            ],
            ["--format", "--out"],
        ),
        (["davar"], ["FILE"]),
    ],
)
def test_bad_files(capsys, nan_csv, tmp_path, argv, fragments):
    argv = [a.format(dir=tmp_path, nan=nan_csv) for a in argv]
    code, out, err = run(capsys, argv)
    assert_one_line_error(code, out, err, *fragments)


def test_parquet_without_pyarrow_fails_before_the_work(capsys, gyro_csv, tmp_path,
                                                       monkeypatch):  # fmt: skip
    def never(*args, **kwargs):
        raise AssertionError("computed although the output cannot be written")

    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    patch_cli(monkeypatch, "davar", never)
    out_dir = tmp_path / "out"
    code, out, err = run(capsys, davar_args(gyro_csv, "--out", str(out_dir), "--format",
                                            "parquet"))  # fmt: skip
    assert_one_line_error(code, out, err, "pip install pyarrow")
    assert list(tmp_path.iterdir()) == []


def test_failure_while_writing_leaves_no_folder(capsys, gyro_csv, tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device")

    patch_cli(monkeypatch, "write_surface", broken)
    out_dir = tmp_path / "out"
    code, out, err = run(capsys, davar_args(gyro_csv, "--out", str(out_dir), "--step", "50",
                                            "--taus", "octave"))  # fmt: skip
    assert_one_line_error(code, out, err, "cannot write the output folder",
                          "No space left on device")  # fmt: skip
    assert list(tmp_path.iterdir()) == []


def test_internal_error_exit_1(capsys, gyro_csv, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError("boom")

    patch_cli(monkeypatch, "davar", broken)
    monkeypatch.delenv("ADAVAR_DEBUG", raising=False)
    code, _, err = run(capsys, davar_args(gyro_csv))
    assert code == 1
    assert err.strip().splitlines() == [
        "adavar: internal error: RuntimeError: boom (rerun with --debug or ADAVAR_DEBUG=1 for "
        "the traceback)"
    ]
    code, _, err = run(capsys, davar_args(gyro_csv, "--debug"))
    assert code == 1 and "Traceback" in err


def test_help(capsys):
    code, out, _ = run(capsys, ["davar", "--help"])
    assert code == 0
    for flag in ("--window", "--step", "--taus", "--edges", "--confidence", "--format",
                 "--terms", "--out", "--force", "--json"):  # fmt: skip
        assert flag in out, flag
    code, out, _ = run(capsys, ["--help"])
    assert code == 0 and "davar" in out
    code, out, err = run(capsys, [])
    assert_one_line_error(code, out, err, "davar")


# --------------------------------------------------------------------------------------
# The installed console script
# --------------------------------------------------------------------------------------


def test_console_script(gyro_csv, tmp_path):
    script = Path(sys.executable).parent / ("adavar.exe" if os.name == "nt" else "adavar")
    assert script.exists(), f"console script not installed at {script}"
    env = {k: v for k, v in os.environ.items() if k != "ADAVAR_DEBUG"}
    out_dir = tmp_path / "run"
    done = subprocess.run(
        [str(script), *davar_args(gyro_csv, "--step", "20", "--taus", "log", "--json", "--out",
                                  str(out_dir), "--figures", "none")],
        capture_output=True, text=True, timeout=300, env=env,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    payload = json.loads(done.stdout)
    assert payload["shape"]["time"] == N_SAMPLES // 20
    assert sorted(p.name for p in out_dir.iterdir()) == [OUTPUT_MARKER, *TABLES]
    assert done.stderr.startswith("adavar: wrote ")

    done = subprocess.run(
        [str(script), *davar_args(gyro_csv, window=N_SAMPLES + 1)],
        capture_output=True, text=True, timeout=300, env=env,
    )  # fmt: skip
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.strip().startswith("adavar: error: window of 4001 samples")
    assert len(done.stderr.strip().splitlines()) == 1 and "Traceback" not in done.stderr

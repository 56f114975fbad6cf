"""Tests of the ``adavar`` command line (in-process through ``main``, plus one subprocess)."""

from __future__ import annotations

import gc
import json
import math
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

import adavar
from adavar import simulate
from adavar.cli import main
from adavar.io.text_column import read_text
from adavar.io.writers import DEMO_MARKER, OUTPUT_MARKER

from .cli_helpers import assert_one_line_error, patch_cli, run

RATE = 10.0
STD = 0.5
TRUE_N = STD / math.sqrt(RATE)  # white rate noise: N = sigma * sqrt(tau0), deg/sqrt(s)


@pytest.fixture(scope="module")
def white_csv(tmp_path_factory):
    """20000 samples of white rate noise at 10 Hz (deg/s) plus time and temperature columns,
    with a comment line and a header."""
    x = simulate.white(20_000, std=STD, rate=RATE, seed=11) + 3.0
    path = tmp_path_factory.mktemp("data") / "gyro.csv"
    lines = ["# logger v1, deg/s", "time,gyro_x,temp"]
    lines += [f"{k / RATE!r},{v!r},21.5" for k, v in enumerate(x.tolist())]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def avar_args(path, *extra):
    return ["avar", str(path), "--column", "gyro_x", "--rate", str(RATE), "--units", "deg/s",
            *extra]  # fmt: skip


# --------------------------------------------------------------------------------------
# avar
# --------------------------------------------------------------------------------------


def test_avar_prints_table(capsys, white_csv):
    code, out, err = run(capsys, avar_args(white_csv))
    assert code == 0 and err == ""
    expected = adavar.deviation(read_text(white_csv, column="gyro_x")[0], rate=RATE)
    lines = out.splitlines()
    header = next(k for k, line in enumerate(lines) if line.startswith("tau [s]"))
    for name in ("n", "alpha", "edf", "dev", "dev_low", "dev_high"):
        assert name in lines[header].split()
    rows = lines[header + 1 : header + 1 + expected.tau.size]
    assert [float(r.split()[0]) for r in rows] == pytest.approx(expected.tau.tolist())
    assert [float(r.split()[4]) for r in rows] == pytest.approx(expected.dev.tolist(), 1e-6)
    assert "Overlapping Allan deviation (OADEV) [deg/s]" in out
    assert "20000 samples" in out


def test_avar_json_matches_library_exactly(capsys, white_csv):
    code, out, err = run(capsys, avar_args(white_csv, "--json", "--taus", "log",
                                           "--points-per-decade", "4"))  # fmt: skip
    assert code == 0 and err == ""
    payload = json.loads(out)
    samples, _ = read_text(white_csv, column="gyro_x")
    expected = adavar.deviation(samples, rate=RATE, taus="log", points_per_decade=4)
    for key in ("tau", "dev", "dev_low", "dev_high", "edf", "n", "m", "alpha"):
        np.testing.assert_array_equal(np.array(payload[key]), getattr(expected, key), key)
    assert payload["stat"] == "oadev"
    assert payload["notes"] == list(expected.notes)
    assert payload["input"] == {
        "file": str(white_csv), "column": "gyro_x", "rate": RATE, "tau0": 1 / RATE,
        "units": "deg/s", "data_type": "rate", "n_samples": 20_000,
    }  # fmt: skip
    assert "fit" not in payload


def test_avar_fit_recovers_white_noise_n(capsys, white_csv):
    code, out, err = run(capsys, avar_args(white_csv, "--fit", "--json"))
    assert code == 0 and err == ""
    assert "NaN" not in out and "Infinity" not in out
    fit = json.loads(out)["fit"]
    for name in adavar.fit.noise_model.TERM_NAMES:
        assert set(fit[name]) == {"value", "uncertainty", "upper", "unit"}
    arw = fit["angle_random_walk"]
    assert arw["unit"] == "deg/sqrt(s)"
    assert arw["value"] == pytest.approx(TRUE_N, rel=0.05)
    assert abs(arw["value"] - TRUE_N) < 4 * arw["uncertainty"]
    conv = fit["conventional"]["angle_random_walk"]
    assert conv["unit"] == "deg/sqrt(h)"
    assert conv["value"] == pytest.approx(arw["value"] * 60.0)
    assert fit["dof"] > 0 and fit["chi2"] > 0
    assert fit["reduced_chi2"] == pytest.approx(fit["chi2"] / fit["dof"])


def test_avar_fit_table_and_terms(capsys, white_csv):
    code, out, err = run(capsys, avar_args(white_csv, "--terms", "N,K"))
    assert code == 0 and err == ""
    assert "reduced chi2" in out
    assert "deg/sqrt(h)" in out  # conventional units next to the data's own
    assert "deg/sqrt(s)" in out
    assert out.count("not in the model") == 2 * 3  # Q, B, R in both unit columns


def test_avar_unconventional_unit_fits_in_data_units(capsys, white_csv):
    code, out, err = run(capsys, ["avar", str(white_csv), "--column", "1", "--tau0", "0.1",
                                  "--units", "mV", "--fit", "--json"])  # fmt: skip
    assert code == 0, err
    fit = json.loads(out)["fit"]
    assert fit["conventional"] is None
    assert fit["angle_random_walk"]["unit"] == "mV*sqrt(s)"


def test_avar_out_writes_files_atomically(capsys, white_csv, tmp_path):
    out_dir = tmp_path / "result"
    code, out, err = run(capsys, avar_args(white_csv, "--fit", "--json", "--out", str(out_dir)))
    assert code == 0
    assert sorted(p.name for p in out_dir.iterdir()) == [
        OUTPUT_MARKER, "deviation.csv", "deviation.png", "deviation.svg", "result.json",
    ]  # fmt: skip
    assert [p.name for p in tmp_path.iterdir()] == ["result"]  # no temporary left behind
    assert json.loads((out_dir / "result.json").read_text()) == json.loads(out)
    assert "wrote" in err  # JSON mode keeps stdout clean
    dev, meta = read_text(out_dir / "deviation.csv", column="dev")
    np.testing.assert_array_equal(dev, json.loads(out)["dev"])
    assert meta["columns"] == ["tau_s", "n", "m", "alpha", "edf", "dev", "dev_low", "dev_high"]
    assert (out_dir / "deviation.png").read_bytes()[:4] == b"\x89PNG"


def test_existing_out_dir_is_refused_and_untouched(capsys, white_csv, tmp_path):
    out_dir = tmp_path / "result"
    out_dir.mkdir()
    to_out = ["--out", str(out_dir), "--figures", "none"]
    (out_dir / "keep.txt").write_text("precious")
    code, out, err = run(capsys, avar_args(white_csv, *to_out))
    assert_one_line_error(code, out, err, "exists already", "--force")
    assert [p.name for p in out_dir.iterdir()] == ["keep.txt"]
    assert (out_dir / "keep.txt").read_text() == "precious"
    assert [p.name for p in tmp_path.iterdir()] == ["result"]

    # --force replaces only a folder adavar wrote (tests/test_output_safety.py)
    code, out, err = run(capsys, avar_args(white_csv, *to_out, "--force"))
    assert_one_line_error(code, out, err, "not written by adavar", "remove it yourself")
    assert [p.name for p in out_dir.iterdir()] == ["keep.txt"]
    (out_dir / "keep.txt").unlink()
    code, out, err = run(capsys, avar_args(white_csv, *to_out, "--force"))
    assert code == 0, err  # an empty folder
    code, out, err = run(capsys, avar_args(white_csv, *to_out, "--force"))
    assert code == 0, err  # adavar's
    assert (out_dir / "result.json").is_file()
    assert [p.name for p in tmp_path.iterdir()] == ["result"]


def test_force_never_replaces_the_folder_of_the_input(capsys, white_csv, monkeypatch):
    folder = white_csv.parent
    before = sorted(p.name for p in folder.iterdir())
    code, out, err = run(capsys, avar_args(white_csv, "--out", str(folder), "--force"))
    assert_one_line_error(code, out, err, "choose another output folder")
    monkeypatch.chdir(folder)
    code, out, err = run(capsys, ["demo", "--out", ".", "--force"])
    assert_one_line_error(code, out, err, "current folder")
    assert sorted(p.name for p in folder.iterdir()) == before


@pytest.fixture
def nan_csv(tmp_path):
    path = tmp_path / "nan.csv"
    path.write_text("t,x\n0,1\n1,2\n2,nan\n3,4\n")
    return path


@pytest.mark.parametrize(
    ("argv", "fragments"),
    [
        (["avar", "{dir}/missing.csv", "--rate", "1", "--units", "deg/s"], ["no such file"]),
        (
            ["avar", "{csv}", "--column", "gyro_y", "--rate", "1", "--units", "deg/s"],
            ["unknown column 'gyro_y'", "'time', 'gyro_x', 'temp'"],
        ),
        (
            ["avar", "{nan}", "--column", "x", "--rate", "1", "--units", "deg/s"],
            ["row 4", "NaN", "--nan interpolate"],
        ),
        (
            ["avar", "{csv}", "--column", "gyro_x", "--rate", "0", "--units", "deg/s"],
            ["--rate", "positive"],
        ),
        (
            ["avar", "{csv}", "--column", "gyro_x", "--rate", "-5", "--units", "deg/s"],
            ["--rate", "positive"],
        ),
        (["avar", "{csv}", "--column", "gyro_x", "--rate", "10"], ["--units"]),
        (
            [
                "avar",
                "{csv}",
                "--column",
                "gyro_x",
                "--rate",
                "10",
                "--tau0",
                "0.1",
                "--units",
                "deg/s",
            ],
            ["exactly one"],
        ),
        (
            [
                "avar",
                "{csv}",
                "--column",
                "gyro_x",
                "--rate",
                "10",
                "--units",
                "deg/s",
                "--stat",
                "xdev",
            ],
            ["--stat", "invalid choice", "oadev"],
        ),
        (
            [
                "avar",
                "{csv}",
                "--column",
                "gyro_x",
                "--rate",
                "10",
                "--units",
                "deg/s",
                "--taus",
                "1e6,1e7",
            ],
            ["no requested tau"],
        ),
        (
            [
                "avar",
                "{csv}",
                "--column",
                "gyro_x",
                "--rate",
                "10",
                "--units",
                "deg/s",
                "--taus",
                "soon",
            ],
            ["--taus"],
        ),
        (
            [
                "avar",
                "{csv}",
                "--column",
                "gyro_x",
                "--rate",
                "10",
                "--units",
                "deg/s",
                "--stat",
                "mdev",
                "--fit",
            ],
            ["--fit needs an Allan statistic"],
        ),
        (
            [
                "avar",
                "{csv}",
                "--column",
                "gyro_x",
                "--rate",
                "10",
                "--units",
                "deg/s",
                "--terms",
                "N,X",
            ],
            ["unknown noise term 'X'"],
        ),
        (
            [
                "avar",
                "{csv}",
                "--column",
                "gyro_x",
                "--rate",
                "10",
                "--units",
                "deg/s",
                "--confidence",
                "1.5",
            ],
            ["--confidence"],
        ),
        (["avar"], ["FILE"]),
        (["avar", "{csv}", "--bogus"], ["unrecognized arguments: --bogus"]),
        (["frobnicate"], ["invalid choice"]),
        ([], ["choose a command"]),
    ],
)
def test_bad_input_exit_2_one_line_and_no_output(capsys, white_csv, nan_csv, tmp_path, argv,
                                                 fragments):  # fmt: skip
    out_dir = tmp_path / "out"
    argv = [a.format(dir=tmp_path, csv=white_csv, nan=nan_csv) for a in argv]
    if argv and argv[0] == "avar":
        argv += ["--out", str(out_dir)]
    code, out, err = run(capsys, argv)
    assert_one_line_error(code, out, err, *fragments)
    assert not out_dir.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out")]


def test_internal_error_exit_1_without_traceback(capsys, white_csv, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError("boom")

    patch_cli(monkeypatch, "deviation", broken)
    monkeypatch.delenv("ADAVAR_DEBUG", raising=False)
    code, _, err = run(capsys, avar_args(white_csv))
    assert code == 1
    assert err.strip().splitlines() == [
        "adavar: internal error: RuntimeError: boom (rerun with --debug or ADAVAR_DEBUG=1 for "
        "the traceback)"
    ]
    code, _, err = run(capsys, avar_args(white_csv, "--debug"))
    assert code == 1 and "Traceback" in err and "RuntimeError: boom" in err
    monkeypatch.setenv("ADAVAR_DEBUG", "1")
    code, _out, err = run(capsys, avar_args(white_csv))
    assert code == 1 and "Traceback" in err


def test_help_and_version_exit_0(capsys):
    code, out, _ = run(capsys, ["--version"])
    assert code == 0 and out.strip() == f"adavar {adavar.__version__}"
    code, out, _ = run(capsys, ["avar", "--help"])
    assert code == 0 and "--units" in out and "--tau0" in out


# --------------------------------------------------------------------------------------
# demo
# --------------------------------------------------------------------------------------


PAPER_DEMO_FILES = [
    "paper_arw.csv", "paper_crossings.csv", "paper_intervals.csv", "paper_metrics.csv",
    "paper_nodes.csv", "paper_seeds_nodes.csv",
    *(f"{stem}.{ext}" for stem in ("fig06_kurtosis_windows", "fig07_contribution",
                                   "fig08_thresholds", "fig10_controller",
                                   "fig11_adavar_surface", "fig12_arw")
      for ext in ("png", "svg")),
]  # fmt: skip


def test_demo_table_then_json_replacing_its_folder(capsys, tmp_path, monkeypatch):
    out_dir = tmp_path / "demo"
    monkeypatch.setattr("adavar.pipeline.demo.PAPER_SEEDS", 6)  # fewer realisations than the demo's
    before = set(threading.enumerate())
    code, out, err = run(capsys, ["demo", "--out", str(out_dir)])
    assert code == 0, err
    # the worker pool is shut down and its manager thread joined before the command
    # returns: left running, Python 3.11's exit handler races with it ("OSError: [Errno 9]
    # Bad file descriptor" printed at exit)
    assert [t for t in set(threading.enumerate()) - before if not t.daemon] == []
    assert gc.isenabled()  # no command turns the collector off
    assert "NIST SP 1065" in out and "TOTDEV" in out and "angle random walk" in out
    assert str(out_dir / "gyro_oadev.png") in out
    assert (out_dir / "gyro_oadev.png").is_file() and (out_dir / "gyro_oadev.svg").is_file()
    # 3. the paper's scenario 1, end to end
    assert "3. The A-DAVAR paper's scenario 1" in out
    assert "Beginning(3000)" in out and "paper A-DAVAR" in out and "over 6 realisations" in out
    names = {p.name for p in out_dir.iterdir()}
    assert set(PAPER_DEMO_FILES) <= names, set(PAPER_DEMO_FILES) - names

    monkeypatch.setattr("adavar.pipeline.demo.PAPER_SEEDS", 2)
    # one process (the worker's path is the first run's, and tests/test_demo.py's)
    # no figures: the first run's are gone with its folder, and none is drawn
    argv = ["demo", "--out", str(out_dir), "--json", "--seed", "5", "--workers", "1",
            "--figures", "none"]  # fmt: skip
    code = main(argv, process_exits=True)  # accepted, without effect
    assert gc.isenabled()
    out, err = capsys.readouterr()
    assert code == 0, err
    payload = json.loads(out)
    rows = payload["nist"]["rows"]
    assert len(rows) == 7 * 3
    assert all(abs(r["rel_diff"]) < 1e-6 for r in rows)
    assert payload["nist"]["max_rel_diff"] < 1e-6
    assert payload["gyro"]["seed"] == 5
    true = payload["gyro"]["true"]
    fitted = payload["gyro"]["fit"]["conventional"]
    for name in ("quantization", "angle_random_walk", "bias_instability"):
        assert fitted[name]["value"] == pytest.approx(true[name]["value"], rel=0.15), name
    assert json.loads((out_dir / "demo.json").read_text())["gyro"]["seed"] == 5
    paper = payload["paper"]
    assert paper["seeds"]["n_seeds"] == 2 and paper["seeds"]["seeds"] == [5, 6]
    assert paper["comparison"]["scenario"] == 1
    assert paper["comparison"]["methods"]["a-davar"]["nodes"][0]["change"] == 3000.0
    tables = [name for name in PAPER_DEMO_FILES if name.endswith(".csv")]
    assert sorted(payload["out"]["files"]) == sorted(["demo.json", *tables, "report.html"])
    names = {p.name for p in out_dir.iterdir()}
    assert names == {"demo.json", *tables, "report.html", DEMO_MARKER, OUTPUT_MARKER}
    assert [p.name for p in tmp_path.iterdir()] == ["demo"]


def test_demo_refuses_foreign_folder(capsys, tmp_path):
    out_dir = tmp_path / "mine"
    out_dir.mkdir()
    (out_dir / "thesis.tex").write_text("x")
    code, out, err = run(capsys, ["demo", "--out", str(out_dir)])
    assert_one_line_error(code, out, err, "not written by adavar demo", "remove it yourself")
    assert [p.name for p in out_dir.iterdir()] == ["thesis.tex"]


# --------------------------------------------------------------------------------------
# The installed console script
# --------------------------------------------------------------------------------------


def test_console_script(tmp_path):
    script = Path(sys.executable).parent / ("adavar.exe" if os.name == "nt" else "adavar")
    assert script.exists(), f"console script not installed at {script}"
    env = {k: v for k, v in os.environ.items() if k != "ADAVAR_DEBUG"}
    done = subprocess.run([str(script), "--version"], capture_output=True, text=True,
                          timeout=120, env=env)  # fmt: skip
    assert done.returncode == 0 and done.stdout.strip() == f"adavar {adavar.__version__}"
    done = subprocess.run(
        [str(script), "avar", str(tmp_path / "missing.csv"), "--rate", "100", "--units",
         "deg/s"],
        capture_output=True, text=True, timeout=120, env=env,
    )  # fmt: skip
    assert done.returncode == 2
    assert done.stdout == ""
    assert done.stderr.strip().startswith("adavar: error: ")
    assert "no such file" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "Traceback" not in done.stderr


def test_rate_from_the_time_column_or_declared(capsys, white_csv, tmp_path):
    """A time column gives the rate; without one, --rate or --tau0 is required."""
    code, out, _ = run(capsys, ["avar", str(white_csv), "--column", "gyro_x", "--units",
                                "deg/s", "--json"])  # fmt: skip
    assert code == 0
    assert json.loads(out)["input"]["rate"] == pytest.approx(RATE)
    bare = tmp_path / "bare.csv"
    bare.write_text("\n".join(str(v) for v in range(100)) + "\n")
    code, out, err = run(capsys, ["avar", str(bare), "--units", "deg/s"])
    assert_one_line_error(code, out, err, "--rate")


@pytest.mark.filterwarnings("ignore:Data has no positive values")  # the constant temp column
def test_several_channels_at_once(capsys, white_csv, tmp_path):
    """--column a,b (or no --column: every numeric column but time) analyses each channel."""
    out = tmp_path / "out"
    code, stdout, err = run(
        capsys,
        [
            "avar",
            str(white_csv),
            "--column",
            "gyro_x,temp",
            "--units",
            "deg/s",
            "--json",
            "--out",
            str(out),
        ],
    )
    assert code == 0, err
    payload = json.loads(stdout)
    assert payload["input"]["columns"] == ["gyro_x", "temp"]
    assert set(payload["channels"]) == {"gyro_x", "temp"}
    assert payload["channels"]["gyro_x"]["input"]["column"] == "gyro_x"
    assert (out / "gyro_x_deviation.csv").exists() and (out / "temp_deviation.png").exists()
    # one --units for every numeric column (a temperature too) is refused: name them
    code, stdout, err = run(capsys, ["avar", str(white_csv), "--units", "deg/s"])
    assert code == 2 and "--column" in err and "gyro_x, temp" in err

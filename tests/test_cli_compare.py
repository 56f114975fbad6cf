"""Tests of ``adavar compare`` (in-process through ``main``)."""

from __future__ import annotations

import json

import pytest

from adavar.io.text_column import read_text
from adavar.simulate import paper_scenario

from .cli_helpers import assert_one_line_error, run

FIGURES = ["fig06_kurtosis_windows", "fig07_contribution", "fig08_thresholds",
           "fig10_controller", "fig11_adavar_surface", "fig12_arw"]  # fmt: skip


@pytest.fixture(scope="module")
def scenario_csv(tmp_path_factory):
    """Scenario 1 as a data file (deg/h at 1 Hz), with a time column."""
    x = paper_scenario(1, seed=4).data
    path = tmp_path_factory.mktemp("data") / "gyro.csv"
    lines = ["time,gyro"] + [f"{k},{v!r}" for k, v in enumerate(x.tolist())]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_scenario_table(capsys):
    code, out, err = run(capsys, ["compare", "--scenario", "1", "--taus", "octave"])
    assert code == 0 and err == ""
    for text in ("Beginning(3000)", "End(4000)", "Restore(3000)", "paper A-DAVAR", "DAVAR-K-3.3",
                 "ARW(3000~4000) / ARW(0~2000)", "std of N/N_true - 1", "paper Fig. 8",
                 "2703", "3156", "3740", "2700 / 3228"):  # fmt: skip
        assert text in out, text
    line = next(li for li in out.splitlines() if li.strip().startswith("Beginning(3000)"))
    assert line.split()[1:3] == ["2800", "2700"]  # DAVAR-400, DAVAR-600 by definition


def test_scenario_seeds_json_and_out(capsys, tmp_path):
    out_dir = tmp_path / "cmp"
    code, out, err = run(
        capsys,
        [
            "compare",
            "--scenario",
            "2",
            "--seeds",
            "3",
            "--seed",
            "1",
            "--taus",
            "octave",
            "--json",
            "--out",
            str(out_dir),
        ],
    )
    assert code == 0, err
    payload = json.loads(out)
    assert payload["input"]["scenario"] == 2 and payload["input"]["seed"] == 1
    seeds = payload["seeds"]
    assert seeds["n_seeds"] == 3 and seeds["seeds"] == [1, 3]
    assert {r["change"] for r in seeds["nodes"]} == {1000.0, 2000.0, 4000.0, 5000.0}
    first = seeds["nodes"][0]
    assert first["node"] == "beginning" and first["stats"]["davar-400"]["median"] == 800.0
    assert first["paper"]["a-davar"] == 738.0  # the paper's Table 3
    assert payload["comparison"]["methods"]["a-davar"]["metrics"]["std"] > 0
    files = sorted(p.name for p in out_dir.iterdir())
    expected = ["arw.csv", "crossings.csv", "intervals.csv", "metrics.csv", "nodes.csv",
                "result.json", "seeds_nodes.csv",
                *(f"{s}.{e}" for s in FIGURES for e in ("png", "svg"))]  # fmt: skip
    assert files == sorted([".adavar-output", *expected])  # the marker of adavar's folders
    assert payload["out"]["files"] and sorted(payload["out"]["files"]) == sorted(expected)
    assert json.loads((out_dir / "result.json").read_text()) == payload
    assert [p.name for p in tmp_path.iterdir()] == ["cmp"]  # no temporary left
    medians, meta = read_text(out_dir / "nodes.csv", column="a-davar_median")
    assert medians.size == 12 and "paper_a-davar" in meta["columns"]
    n_true, _ = read_text(out_dir / "arw.csv", column="true_N")
    assert n_true.size == 6000 and set(n_true.tolist()) == {1.0, 3.0}
    assert (out_dir / "fig12_arw.png").read_bytes()[:4] == b"\x89PNG"
    assert "wrote" in err


def test_data_file_with_change_times(capsys, scenario_csv):
    code, out, err = run(capsys, [
        "compare", str(scenario_csv), "--column", "gyro", "--rate", "1", "--units", "deg/h",
        "--change-times", "3000,4000", "--taus", "octave", "--methods", "davar-600,a-davar",
    ])  # fmt: skip
    assert code == 0, err
    assert "Beginning(3000)" in out and "A-DAVAR" in out and "deg/sqrt(h)" not in out
    assert "Ground truth" not in out  # no truth for a data file
    assert "crossing K2" in out
    code, out, err = run(
        capsys,
        [
            "compare",
            str(scenario_csv),
            "--column",
            "gyro",
            "--tau0",
            "1",
            "--units",
            "deg/h",
            "--taus",
            "octave",
            "--json",
        ],
    )
    assert code == 0, err
    payload = json.loads(out)
    assert payload["comparison"]["change_times"] == [] and payload["crossings"] is None
    assert payload["input"]["units"] == "deg/h"


@pytest.mark.parametrize(
    ("argv", "fragments"),
    [
        (["compare"], ["FILE or --scenario"]),
        (["compare", "{csv}", "--scenario", "1"], ["FILE or --scenario"]),
        (["compare", "--scenario", "3"], ["--scenario", "invalid choice"]),
        (["compare", "--scenario", "1", "--rate", "10"], ["--rate", "drop it"]),
        (["compare", "--scenario", "1", "--change-times", "10"], ["--change-times"]),
        (
            [
                "compare",
                "{csv}",
                "--column",
                "gyro",
                "--rate",
                "1",
                "--units",
                "deg/h",
                "--seeds",
                "2",
            ],
            ["--seeds"],
        ),
        (["compare", "{csv}", "--column", "gyro", "--rate", "1"], ["--units"]),
        (
            [
                "compare",
                "{csv}",
                "--column",
                "gyro",
                "--rate",
                "1",
                "--units",
                "deg/h",
                "--change-times",
                "9000",
            ],
            ["outside the record"],
        ),
        (["compare", "--scenario", "1", "--methods", "davar-x"], ["unknown method"]),
        (["compare", "--scenario", "1", "--lmin", "700"], ["lmin"]),
        (["compare", "--scenario", "1", "--k2", "nan"], ["--k2", "finite"]),
        (["compare", "--scenario", "1", "--seeds", "0"], ["--seeds"]),
        (["compare", "{dir}/missing.csv", "--rate", "1", "--units", "deg/h"], ["no such file"]),
    ],
)
def test_bad_input_exit_2_one_line_and_no_output(capsys, scenario_csv, tmp_path, argv,
                                                 fragments):  # fmt: skip
    out_dir = tmp_path / "out"
    argv = [a.format(csv=scenario_csv, dir=tmp_path) for a in argv] + ["--out", str(out_dir)]
    code, out, err = run(capsys, argv)
    assert_one_line_error(code, out, err, *fragments)
    assert not out_dir.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out")]


def test_existing_out_is_refused(capsys, tmp_path):
    out_dir = tmp_path / "cmp"
    out_dir.mkdir()
    (out_dir / "keep.txt").write_text("precious")
    code, out, err = run(capsys, ["compare", "--scenario", "1", "--out", str(out_dir)])
    assert_one_line_error(code, out, err, "exists already", "--force")
    assert [p.name for p in out_dir.iterdir()] == ["keep.txt"]


def test_step_and_max_memory(capsys, scenario_csv):
    base = ["compare", str(scenario_csv), "--rate", "1", "--units", "deg/h", "--taus", "octave",
            "--column", "gyro", "--change-times", "3000,4000"]  # fmt: skip
    code, out, err = run(capsys, [*base, "--max-memory", "0.5", "--json"])
    assert code == 0, err
    payload = json.loads(out)
    step = payload["comparison"]["parameters"]["step"]
    assert step > 1 and payload["input"]["resolution"].startswith("resolution: one centre in")
    code, out, err = run(capsys, [*base, "--max-memory", "0.5"])
    assert code == 0 and f"resolution: one centre in {step}" in out
    code, out, err = run(capsys, [*base, "--step", "3", "--json"])
    assert code == 0, err
    payload = json.loads(out)
    assert payload["comparison"]["parameters"]["step"] == 3
    assert payload["input"]["resolution"] is None
    code, out, err = run(capsys, [*base, "--step", "0"])
    assert_one_line_error(code, out, err, "step")

"""adavar report and adavar adaptive: the command-line front door to the HTML report."""

from __future__ import annotations

import json

import numpy as np
import pytest

from adavar import cli


def run(capsys, argv):
    code = cli.main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.fixture(scope="module")
def step_csv(tmp_path_factory):
    """6000 s of unit white noise at 1 Hz whose deviation triples at 3000-4000 s, ISO times."""
    x = np.random.default_rng(3).standard_normal(6000)
    x[3000:4000] *= 3.0
    path = tmp_path_factory.mktemp("data") / "gyro <x>.csv"
    lines = ["timestamp,gz"]
    lines += [f"2026-11-21T00:{k // 60 % 60:02d}:{k % 60:02d}Z,{v!r}" if k < 3600
              else f"2026-11-21T01:{(k - 3600) // 60:02d}:{k % 60:02d}Z,{v!r}"
              for k, v in enumerate(x.tolist())]  # fmt: skip
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_report_with_adaptive_surface(capsys, step_csv, tmp_path):
    out = tmp_path / "report.html"
    code, stdout, err = run(capsys, ["report", str(step_csv), "--units", "deg/s",
                                     "--adaptive", "--preprocess", "mean", "-o", str(out),
                                     "--json"])  # fmt: skip
    assert code == 0, err
    payload = json.loads(stdout)
    assert payload["input"]["rate"] == pytest.approx(1.0)  # from the ISO time stamps
    assert payload["input"]["preprocessing"] == ["mean"]
    assert payload["surface"]["method"] == "adaptive"
    html = out.read_text(encoding="utf-8")
    assert html.startswith("<!DOCTYPE html>") or html.lower().startswith("<!doctype html>")
    assert "gyro &lt;x&gt;.csv" in html and "gyro <x>.csv" not in html
    assert payload["fit"]["angle_random_walk"]["value"] > 0
    # an existing report is not replaced without --force, and nothing is left behind
    code, _, err = run(capsys, ["report", str(step_csv), "--units", "deg/s", "-o", str(out)])
    assert code == 2 and "--force" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["--units", "deg/s", "-o", "{dir}/r.txt"], "*.html"),
        (["--units", "deg/s", "-o", "{dir}/missing/r.html"], "does not exist"),
        (["-o", "{dir}/r.html"], "--units"),
        (["--units", "deg/s", "--window", "9000", "-o", "{dir}/r.html"], "longer than"),
        (["--units", "deg/s", "--preprocess", "decimate:0", "-o", "{dir}/r.html"], "decimation"),
    ],
)
def test_report_bad_input(capsys, step_csv, tmp_path, argv, fragment):
    argv = [a.format(dir=tmp_path) for a in argv]
    code, out, err = run(capsys, ["report", str(step_csv), *argv])
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and fragment in err
    assert list(tmp_path.iterdir()) == []


def test_adaptive_command_writes_the_controller_panels(capsys, step_csv, tmp_path):
    out = tmp_path / "ada"
    code, stdout, err = run(capsys, ["adaptive", str(step_csv), "--units", "deg/s",
                                     "--taus", "octave", "--out", str(out), "--json"])
    assert code == 0, err
    payload = json.loads(stdout)
    assert payload["window"]["min"] == 400 and payload["window"]["max"] == 600
    assert payload["parameters"]["controller"]["k2"] == 3.3
    assert (out / "controller.png").stat().st_size > 0
    assert (out / "surface.nc").stat().st_size > 0
    code, _, err = run(capsys, ["adaptive", str(step_csv), "--units", "deg/s", "--method",
                                "oracle"])  # fmt: skip
    assert code == 2 and "--change-times" in err

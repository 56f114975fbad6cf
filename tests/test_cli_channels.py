"""Several channels at once: davar, adaptive and report with ``--column gx,gy,gz``.

One channel gives exactly today's output (its JSON is public API); several give a folder
per channel holding that channel's usual files, ``{"channels": {name: ...}}`` JSON whose
entries equal the single-channel runs, one table per channel, and one HTML report with a
section per channel.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from adavar.cli import davar as cli_davar
from adavar.cli import output as cli_output

from .cli_helpers import assert_one_line_error, patch_cli, run

RATE = 10.0
N_SAMPLES = 2000
STDS = {"gx": 0.1, "gy": 0.2, "gz": 0.4}
SINGLE_KEYS = ["adavar_version", "input", "parameters", "units", "shape", "time", "tau", "m",
               "alpha", "notes", "fit", "out", "events", "events_rule", "stat"]  # fmt: skip


@pytest.fixture(scope="module")
def imu_csv(tmp_path_factory):
    """2000 samples at 10 Hz of three gyro axes (white noise of different levels)."""
    rng = np.random.default_rng(21)
    x = rng.standard_normal((N_SAMPLES, 3)) * list(STDS.values())
    path = tmp_path_factory.mktemp("channels") / "imu.csv"
    path.write_text("time,gx,gy,gz\n" + "".join(
        f"{k / RATE!r},{a!r},{b!r},{c!r}\n" for k, (a, b, c) in enumerate(x.tolist())
    ), encoding="utf-8")  # fmt: skip
    return path


def davar_argv(path, columns, *extra):
    return ["davar", str(path), "--column", columns, "--units", "deg/s", "--window", "200",
            "--taus", "octave", *extra]  # fmt: skip


def without_out(payload):
    return {k: v for k, v in payload.items() if k != "out"}


def test_davar_several_channels_json_and_folders(capsys, imu_csv, tmp_path):
    out = tmp_path / "all"
    # PDF figures only, in each channel's folder as in the single channel's
    code, stdout, err = run(capsys, davar_argv(imu_csv, "gx,gy,gz", "--json", "--out", str(out),
                                               "--figures", "pdf"))  # fmt: skip
    assert code == 0, err
    payload = json.loads(stdout)
    assert list(payload) == ["adavar_version", "input", "channels", "out"]
    assert payload["input"]["columns"] == ["gx", "gy", "gz"]
    assert payload["out"]["folders"] == {"gx": "gx", "gy": "gy", "gz": "gz"}
    assert err == f"adavar: wrote {out}/ (gx/, gy/, gz/, result.json)\n"
    assert json.loads((out / "result.json").read_text()) == payload

    # every channel is the single-channel run of that column, files included
    single = tmp_path / "gy"
    code, stdout, err = run(capsys, davar_argv(imu_csv, "gy", "--json", "--out", str(single),
                                               "--figures", "pdf"))  # fmt: skip
    assert code == 0, err
    alone = json.loads(stdout)
    assert sorted(alone["out"]["files"]) == sorted(p.name for p in single.iterdir()
                                                   if p.name != ".adavar-output")  # fmt: skip
    assert {p.suffix for p in single.iterdir()} == {".pdf", ".csv", ".json", ".nc", ""}
    assert (single / "arw.pdf").read_bytes()[:5] == b"%PDF-"
    assert list(alone) == SINGLE_KEYS  # one channel: today's JSON, no "channels"
    assert without_out(payload["channels"]["gy"]) == without_out(alone)
    assert payload["channels"]["gy"]["out"]["dir"] == f"{out}/gy"
    assert payload["channels"]["gy"]["out"]["files"] == alone["out"]["files"]
    assert sorted(p.name for p in out.iterdir()) == [
        ".adavar-output", "gx", "gy", "gz", "result.json"]  # fmt: skip
    for name in ("gx", "gy", "gz"):
        assert sorted(p.name for p in (out / name).iterdir()) == sorted(
            p.name for p in single.iterdir()
        )
    assert (out / "gy" / "coefficients.csv").read_text() == (
        single / "coefficients.csv"
    ).read_text()
    assert json.loads((out / "gy" / "result.json").read_text()) == payload["channels"]["gy"]

    # the fitted white-noise levels follow the three axes: N = std * sqrt(tau0)
    for name, std in STDS.items():
        median = payload["channels"][name]["fit"]["coefficients"]["angle_random_walk"]
        assert median["value"]["median"] == pytest.approx(std / np.sqrt(RATE), rel=0.15)


def test_davar_several_channels_table(capsys, imu_csv, tmp_path):
    out = tmp_path / "o"
    code, stdout, err = run(capsys, davar_argv(imu_csv, "gx,gz", "--out", str(out)))
    assert code == 0 and err == ""
    assert stdout.count("Noise coefficients of every window") == 2
    first, second = stdout.split(f"\n\n{imu_csv}, column 'gz'")
    assert f"{imu_csv}, column 'gx'" in first and "Dynamic Allan deviation" in second
    assert stdout.rstrip().endswith(
        f"wrote {out}/ (gx/, gz/, result.json; in each folder: surface.nc, coefficients.csv, "
        "davar_surface.png, davar_surface.svg, davar_heatmap.png, davar_heatmap.svg, arw.png, "
        "arw.svg, events.csv, result.json)"
    )
    # one channel: the table as before, with its own "wrote" line
    code, single, _ = run(capsys, davar_argv(imu_csv, "gx"))
    assert code == 0 and single.strip() == first.strip()


def test_adaptive_several_channels(capsys, imu_csv, tmp_path):
    out = tmp_path / "ada"
    argv = ["adaptive", str(imu_csv), "--column", "gx,gy", "--units", "deg/s", "--lmax", "200",
            "--lmin", "100", "--l", "30", "--taus", "octave"]  # fmt: skip
    code, stdout, err = run(capsys, [*argv, "--json", "--out", str(out)])
    assert code == 0, err
    payload = json.loads(stdout)
    assert list(payload["channels"]) == ["gx", "gy"]
    for name in ("gx", "gy"):
        channel = payload["channels"][name]
        assert channel["input"]["column"] == name
        assert channel["parameters"]["controller"]["lmax"] == 200
        assert 100 <= channel["window"]["min"] <= channel["window"]["max"] <= 200
        assert (out / name / "controller.png").is_file()
    code, stdout, _ = run(capsys, [*argv, "--column", "gy", "--json"])
    assert code == 0
    assert without_out(json.loads(stdout)) == without_out(payload["channels"]["gy"])


def test_report_one_section_per_channel(capsys, imu_csv, tmp_path):
    from .test_report import figures_of, parse, render_in_chromium

    html_path = tmp_path / "report.html"
    # every 10th centre: the browser draws the same nine plots from a tenth of the cells
    code, stdout, err = run(capsys, ["report", str(imu_csv), "--column", "gx,gy,gz", "--units",
                                     "deg/s", "--window", "200", "--step", "10", "-o",
                                     str(html_path), "--json"])  # fmt: skip
    assert code == 0, err
    payload = json.loads(stdout)
    assert list(payload["channels"]) == ["gx", "gy", "gz"]
    assert payload["input"]["columns"] == ["gx", "gy", "gz"]
    doc = html_path.read_text(encoding="utf-8")
    assert payload["bytes"] == len(doc.encode("utf-8"))
    for k, name in enumerate(["gx", "gy", "gz"], start=1):
        section = doc[doc.index(f'<section id="channel-{k}"') :]
        section = section[: section.index("</section>")]
        assert f"<h2>Channel <bdi>{name}</bdi> (<bdi>deg/s</bdi>)</h2>" in section
        assert "Noise coefficients" in section and "<table>" in section
        for plot in ("deviation", "surface", "coefficients"):
            assert f'id="plot-{k}-{plot}"' in section
    figures = figures_of(doc)
    assert len(figures) == 9 and len(set(figures)) == 9
    assert doc.count("<script>") == 2  # plotly.js once, the drawing code once
    assert '<section id="parameters">' in doc and '<section id="source">' in doc
    assert doc.index('id="channel-3"') < doc.index('<section id="parameters">')

    # each channel's fit is the single-channel report's
    code, stdout, _ = run(capsys, ["report", str(imu_csv), "--column", "gz", "--units", "deg/s",
                                   "-o", str(tmp_path / "gz.html"), "--json"])  # fmt: skip
    assert code == 0
    alone = json.loads(stdout)
    assert "channels" not in alone and alone["input"]["column"] == "gz"
    assert alone["fit"] == payload["channels"]["gz"]["fit"]

    code, stdout, _ = run(capsys, ["report", str(imu_csv), "--column", "gx,gy", "--units",
                                   "deg/s", "-o", str(tmp_path / "two.html")])  # fmt: skip
    assert code == 0
    assert "column 'gx' (deg/s):" in stdout and "column 'gy' (deg/s):" in stdout
    assert stdout.count("Noise fit") == 2

    # the browser draws the nine plots. Without WebGL: the 3-D surface's WebGL scene is
    # test_report's (a single-channel report); here each channel's surface gets as far as
    # asking for a WebGL context, and the three scenes would cost 4 s of software rendering
    dom = render_in_chromium(doc, tmp_path / "browser", 9, webgl=False)
    assert dom.count("main-svg") >= 9
    assert "img" not in [tag for tag, _ in parse(dom).tags]
    for k in (1, 2, 3):
        for plot in ("deviation", "surface", "coefficients"):
            start = dom.index(f'id="plot-{k}-{plot}"')
            ends = [dom.find(end, start + 1) for end in ('id="plot-', "</section>")]
            chunk = dom[start : min(end for end in ends if end > 0)]
            assert "main-svg" in chunk, (k, plot)
            assert ("WebGL is not supported" in chunk) == (plot == "surface"), (k, plot)


def test_report_escapes_channel_names(capsys, tmp_path):
    from .test_report import figures_of, parse

    evil = "<img src=x onerror=alert(1)>"
    path = tmp_path / "evil.csv"
    x = np.random.default_rng(0).standard_normal((600, 2)).tolist()
    path.write_text(f"gx,{evil}\n" + "".join(f"{a!r},{b!r}\n" for a, b in x), encoding="utf-8")
    out = tmp_path / "r.html"
    code, _, err = run(capsys, ["report", str(path), "--column", f"gx,{evil}", "--rate", "10",
                                "--units", "deg/s", "-o", str(out)])  # fmt: skip
    assert code == 0, err
    doc = out.read_text(encoding="utf-8")
    parsed = parse(doc)
    assert "img" not in [tag for tag, _ in parsed.tags]
    assert evil in "".join(parsed.text)  # shown as text
    assert len(figures_of(doc)) == 2


@pytest.mark.parametrize(
    ("argv", "fragments"),
    [
        (["davar", "--window", "200"], ["3 channels", "--column", "several, comma-separated"]),
        (["davar", "--window", "200", "--column", "gx,nope"], ["unknown column 'nope'"]),
        (["adaptive", "--column", "gx,gy", "--lmax", "5000"], ["2000 samples", "at least 5000"]),
        (["report", "--column", "gx,nope", "-o", "{tmp}/r.html"], ["unknown column 'nope'"]),
    ],
)
def test_bad_channels_exit_2_and_no_output(capsys, imu_csv, tmp_path, argv, fragments):
    argv = [a.format(tmp=tmp_path) for a in argv]
    out = tmp_path / "out"
    extra = [] if argv[0] == "report" else ["--out", str(out)]
    code, stdout, err = run(capsys, [argv[0], str(imu_csv), "--units", "deg/s", *argv[1:],
                                     *extra])  # fmt: skip
    assert_one_line_error(code, stdout, err, *fragments)
    assert list(tmp_path.iterdir()) == []


def test_failure_in_a_later_channel_leaves_no_folder(capsys, imu_csv, tmp_path, monkeypatch):
    calls = []
    real = cli_davar.write_surface

    def flaky(path, result, fmt):
        calls.append(path)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        return real(path, result, fmt=fmt)

    patch_cli(monkeypatch, "write_surface", flaky)
    out = tmp_path / "out"
    code, stdout, err = run(capsys, davar_argv(imu_csv, "gx,gy", "--out", str(out), "--figures",
                                               "none"))  # fmt: skip
    assert_one_line_error(code, stdout, err, "No space left on device")
    assert len(calls) == 2 and list(tmp_path.iterdir()) == []


def test_channel_folders_are_distinct():
    folders = cli_output.channel_folders(["a b", "a_b", "A_B", "result.json", "x/y", "..", "gx"])
    assert folders["a b"] == "a_b" and folders["gx"] == "gx"
    assert len({f.lower() for f in folders.values()}) == len(folders)
    assert "result.json" not in {f.lower() for f in folders.values()}
    assert all("/" not in f and f not in (".", "..") for f in folders.values())

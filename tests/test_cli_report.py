"""adavar report and adavar adaptive: the command-line front door to the HTML report."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from adavar.cli.output import ProgressBar, Status

from .cli_helpers import run


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
    code, stdout, err = run(
        capsys,
        [
            "adaptive",
            str(step_csv),
            "--units",
            "deg/s",
            "--taus",
            "octave",
            "--out",
            str(out),
            "--json",
        ],
    )
    assert code == 0, err
    payload = json.loads(stdout)
    assert payload["window"]["min"] == 400 and payload["window"]["max"] == 600
    assert payload["parameters"]["controller"]["k2"] == 3.3
    assert (out / "controller.png").stat().st_size > 0
    assert (out / "surface.nc").stat().st_size > 0
    code, _, err = run(capsys, ["adaptive", str(step_csv), "--units", "deg/s", "--method",
                                "oracle"])  # fmt: skip
    assert code == 2 and "--change-times" in err


def test_kalibr_yaml_from_a_ros2_bag(capsys, tmp_path):
    """A static 6-axis ROS 2 bag in, Kalibr's imu.yaml out, with the fitted densities."""
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    imu_t = store.types["sensor_msgs/msg/Imu"]
    header_t = store.types["std_msgs/msg/Header"]
    quat_t = store.types["geometry_msgs/msg/Quaternion"]
    vec_t = store.types["geometry_msgs/msg/Vector3"]
    time_t = store.types["builtin_interfaces/msg/Time"]
    rate, n = 100.0, 8000
    gyro_n, accel_n = 2e-3, 4e-2  # rad/sqrt(s), m/s/sqrt(s): white noise densities
    rng = np.random.default_rng(4)
    g = rng.standard_normal((n, 3)) * gyro_n * np.sqrt(rate)
    a = rng.standard_normal((n, 3)) * accel_n * np.sqrt(rate) + [0.0, 0.0, 9.81]
    bag = tmp_path / "static"
    cov = np.zeros(9)
    with Writer(bag, version=9) as writer:
        conn = writer.add_connection("/imu0", "sensor_msgs/msg/Imu", typestore=store)
        for i in range(n):
            ns = 1_700_000_000 * 10**9 + round(i * 1e9 / rate)
            msg = imu_t(
                header=header_t(stamp=time_t(sec=ns // 10**9, nanosec=ns % 10**9),
                                frame_id="imu"),
                orientation=quat_t(x=0.0, y=0.0, z=0.0, w=1.0), orientation_covariance=cov,
                angular_velocity=vec_t(x=g[i, 0], y=g[i, 1], z=g[i, 2]),
                angular_velocity_covariance=cov,
                linear_acceleration=vec_t(x=a[i, 0], y=a[i, 1], z=a[i, 2]),
                linear_acceleration_covariance=cov,
            )  # fmt: skip
            writer.write(conn, ns, store.serialize_cdr(msg, "sensor_msgs/msg/Imu"))
    out = tmp_path / "imu.yaml"
    # white noise only: the random walks are pinned at 0, which Kalibr cannot take
    code, _, err = run(capsys, ["kalibr", str(bag), "-o", str(out)])
    assert code == 2 and "--pinned bound" in err and not out.exists()
    code, stdout, err = run(capsys, ["kalibr", str(bag), "-o", str(out), "--pinned", "bound",
                                     "--json"])  # fmt: skip
    assert code == 0, err
    values = json.loads(stdout)["kalibr"]
    text = out.read_text(encoding="utf-8")
    fields = {
        key: value.split("#")[0].strip()
        for key, value in (
            line.split(":", 1) for line in text.splitlines() if line and line[0] != "#"
        )
    }
    density = float(fields["gyroscope_noise_density"])
    assert density == pytest.approx(gyro_n, rel=0.08)  # the largest of three axes
    assert float(fields["accelerometer_noise_density"]) == pytest.approx(accel_n, rel=0.08)
    assert float(fields["update_rate"]) == pytest.approx(rate)
    assert fields["rostopic"].strip() == "/imu0"
    assert values  # the per-axis values are reported too
    # which values are bounds, not fits, is said in both (an audit found it said nowhere)
    assert set(values["bounds"]) == {"gyroscope_random_walk", "accelerometer_random_walk"}
    assert all(len(labels) == 3 for labels in values["bounds"].values())
    assert "# Upper bounds, not fitted values: gyroscope_random_walk of " in text
    code, _, err = run(capsys, ["kalibr", str(bag), "-o", str(out)])
    assert code == 2 and "--force" in err


def test_simulate_then_analyse(capsys, tmp_path):
    out = tmp_path / "gyro.csv"
    code, _, err = run(capsys, ["simulate", "-o", str(out), "--arw", "0.01", "--n", "50000"])
    assert code == 0, err
    code, stdout, err = run(capsys, ["avar", str(out), "--units", "deg/s", "--fit",
                                     "--terms", "N", "--json"])  # fmt: skip
    assert code == 0, err
    payload = json.loads(stdout)
    assert payload["input"]["rate"] == pytest.approx(100.0)
    n_fit = payload["fit"]["angle_random_walk"]["value"]
    assert n_fit == pytest.approx(0.01, rel=0.05)
    code, _, err = run(capsys, ["simulate", "-o", str(tmp_path / "x.csv")])
    assert code == 2 and "--arw" in err


def test_config_file_sets_options_and_flags_override(capsys, step_csv, tmp_path):
    config = tmp_path / "run.toml"
    config.write_text('units = "deg/s"\n[davar]\nwindow = 300\ntaus = "octave"\nstep = 10\n'
                      "json = true\n")  # fmt: skip
    code, out, err = run(capsys, ["davar", str(step_csv), "--config", str(config)])
    assert code == 0, err
    payload = json.loads(out)
    assert payload["parameters"]["window"] == 300 and payload["parameters"]["step"] == 10
    code, out, err = run(capsys, ["davar", str(step_csv), "--config", str(config),
                                  "--window", "200"])  # fmt: skip
    assert code == 0 and json.loads(out)["parameters"]["window"] == 200
    bad = tmp_path / "bad.toml"
    bad.write_text("bogus = 1\n")
    code, _, err = run(capsys, ["avar", str(step_csv), "--config", str(bad)])
    assert code == 2 and "'bogus' is not an option" in err
    code, _, err = run(capsys, ["avar", str(step_csv), "--config", str(tmp_path / "no.toml")])
    assert code == 2 and "no such file" in err
    broken = tmp_path / "broken.toml"
    broken.write_text("window = \n")
    code, _, err = run(capsys, ["davar", str(step_csv), "--config", str(broken)])
    assert code == 2 and "TOML" in err and len(err.strip().splitlines()) == 1


def test_progress_bar_only_on_a_terminal(capsys, monkeypatch):
    bar = ProgressBar("work")
    bar(1, 4)
    assert capsys.readouterr().err == ""  # pytest's stderr is not a terminal
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    bar = ProgressBar("work")
    bar(1, 4)
    bar.close()
    err = capsys.readouterr().err
    assert "work [" in err and "1/4" in err and "\n" not in err


def test_gaps_split_analyses_each_piece(capsys, tmp_path):
    x = np.random.default_rng(0).standard_normal(3000)
    t = np.arange(3000) / 10.0
    t[1500:] += 20.0  # a 20 s gap after 150 s
    path = tmp_path / "gap.csv"
    path.write_text(
        "time,gx\n"
        + "\n".join(f"{a!r},{b!r}" for a, b in zip(t.tolist(), x.tolist(), strict=True))
        + "\n"
    )
    code, _, err = run(capsys, ["avar", str(path), "--units", "deg/s"])
    assert code == 2 and "gap of 20.1 s" in err and "--gaps split" in err
    code, out, err = run(capsys, ["avar", str(path), "--units", "deg/s", "--gaps", "split",
                                  "--json"])  # fmt: skip
    assert code == 0, err
    payload = json.loads(out)
    assert list(payload["channels"]) == ["gx piece 1", "gx piece 2"]
    assert payload["channels"]["gx piece 2"]["input"]["n_samples"] == 1500
    code, _, err = run(capsys, ["davar", str(path), "--units", "deg/s", "--gaps", "split",
                                "--window", "100"])  # fmt: skip
    assert code == 2 and "--gaps interpolate" in err


def test_noise_type_and_t0_flags(capsys, step_csv):
    code, out, err = run(capsys, ["davar", str(step_csv), "--units", "deg/s", "--window",
                                  "300", "--taus", "octave", "--noise-type", "-1", "--t0",
                                  "100", "--json"])  # fmt: skip
    assert code == 0, err
    payload = json.loads(out)
    assert set(payload["alpha"]) == {-1}
    assert payload["time"]["first"] == pytest.approx(100.0)
    code, _, err = run(capsys, ["davar", str(step_csv), "--units", "deg/s", "--window",
                                "300", "--noise-type", "5"])  # fmt: skip
    assert code == 2 and "--noise-type" in err


def test_status_line_only_on_a_terminal(capsys, monkeypatch):
    status = Status()
    status("reading")
    assert capsys.readouterr().err == ""
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    status = Status()
    status("reading")
    status.close()
    err = capsys.readouterr().err
    assert "reading ..." in err and "\n" not in err

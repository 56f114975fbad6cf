"""Bad or contradictory flags are refused (or warned about) in one line, before any work.

Runaway parameters (a polynomial detrend of degree 4000, ``simulate --n`` beyond the free
memory), flags that are silently ignored today (``--force`` without ``--out``, an empty
``--s-test band``, ``--change-times`` beyond the record or without ``--method oracle``,
trailing commas, an empty ``--preprocess``, unknown ``--units``), ``avar`` labelling every
numeric column with one ``--units``, and kalibr's messages about a constant axis.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import adavar.io.sources
from adavar import simulate
from adavar.core.errors import AdavarInputError
from adavar.core.units import is_known_unit
from adavar.fit.noise_model import fit_noise
from adavar.io.preprocess import MAX_DETREND_ORDER, detrend, parse_steps, preprocess
from adavar.output.export import kalibr_values
from adavar.stats.statistics import deviation

from .cli_helpers import assert_one_line_error, run

RATE = 10.0
N = 2000  # 200 s at 10 Hz


@pytest.fixture(scope="module")
def gyro_csv(tmp_path_factory):
    """White rate noise (deg/s) with a time column and a slowly warming temperature."""
    x = simulate.white(N, std=0.5, rate=RATE, seed=3)
    path = tmp_path_factory.mktemp("data") / "gyro.csv"
    lines = ["time,gyro_x,temp"]
    lines += [f"{k / RATE!r},{v!r},{21.5 + 1e-3 * k!r}" for k, v in enumerate(x.tolist())]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def avar(path, *extra):
    return ["avar", str(path), "--column", "gyro_x", "--units", "deg/s", *extra]


def adaptive(path, *extra):
    return ["adaptive", str(path), "--column", "gyro_x", "--units", "deg/s", "--lmax", "200",
            "--lmin", "100", "--taus", "octave", "--json", *extra]  # fmt: skip


# --------------------------------------------------------------------------------------
# Item 10: runaway parameters
# --------------------------------------------------------------------------------------


def test_detrend_degree_is_bounded(capsys, gyro_csv, tmp_path):
    out = tmp_path / "out"
    code, stdout, err = run(capsys, avar(gyro_csv, "--preprocess", "detrend:4000",
                                         "--out", str(out)))  # fmt: skip
    assert_one_line_error(code, stdout, err, "--preprocess", f"at most {MAX_DETREND_ORDER}",
                          "ill-conditioned", "got 4000")  # fmt: skip
    assert not out.exists()
    x = np.arange(100.0)
    with pytest.raises(AdavarInputError, match="ill-conditioned"):
        detrend(x, MAX_DETREND_ORDER + 1)
    with pytest.raises(AdavarInputError, match=f"at most {MAX_DETREND_ORDER}"):
        preprocess(x, rate=1.0, steps="detrend:11")
    assert detrend(x, MAX_DETREND_ORDER).shape == x.shape  # the bound itself is fine


def test_simulate_n_is_bounded_by_the_free_memory(capsys, tmp_path, monkeypatch):
    monkeypatch.setattr(adavar.io.sources, "available_memory", lambda: 2**20)  # 1 MiB free
    target = tmp_path / "sim.csv"
    code, out, err = run(capsys, ["simulate", "--arw", "0.01", "--n", "100000",
                                  "-o", str(target)])  # fmt: skip
    assert_one_line_error(code, out, err, "--n 100000", "GiB", "free", "or fewer")
    assert not target.exists()
    monkeypatch.setattr(adavar.io.sources, "available_memory", lambda: 2**30)
    code, out, err = run(capsys, ["simulate", "--arw", "0.01", "--n", "1000", "-o", str(target)])
    assert code == 0, err


def test_simulate_library_has_a_documented_maximum():
    with pytest.raises(ValueError, match="at most"):
        simulate.white(10**12)
    with pytest.raises(ValueError, match="at most"):
        simulate.sensor(simulate.MAX_SAMPLES + 1, angle_random_walk=1.0)


# --------------------------------------------------------------------------------------
# Item 17: silently accepted flags
# --------------------------------------------------------------------------------------


def test_s_test_band_needs_s1_below_s2(capsys, gyro_csv):
    """With the paper's thresholds S2 is --s2 (calibrated thresholds compute their own)."""
    code, out, err = run(capsys, adaptive(gyro_csv, "--s-test", "band", "--s1", "0.5",
                                          "--s2", "0.07", "--thresholds", "paper"))  # fmt: skip
    assert_one_line_error(code, out, err, "--s-test band", "--s1 0.5", "--s2 0.07")


def test_oracle_change_times_beyond_the_record(capsys, gyro_csv):
    code, out, err = run(capsys, adaptive(gyro_csv, "--method", "oracle",
                                          "--change-times", "50,1000"))  # fmt: skip
    assert_one_line_error(code, out, err, "--change-times 1000 s", "outside the record",
                          "0 .. 200 s")  # fmt: skip


def test_change_times_without_oracle_warn(capsys, gyro_csv):
    code, _, err = run(capsys, adaptive(gyro_csv, "--change-times", "50"))
    assert code == 0, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("adavar: warning: --change-times"), err
    assert "--method oracle" in lines[0]


@pytest.mark.parametrize(
    ("flag", "value"), [("--taus", "1,"), ("--taus", "1,,2"), ("--terms", "N,")]
)
def test_trailing_comma_is_an_error(capsys, gyro_csv, flag, value):
    code, out, err = run(capsys, avar(gyro_csv, flag, value))
    assert_one_line_error(code, out, err, flag, "empty item", repr(value))


def test_trailing_comma_in_change_times_is_an_error(capsys, gyro_csv):
    code, out, err = run(capsys, adaptive(gyro_csv, "--method", "oracle",
                                          "--change-times", "50,"))  # fmt: skip
    assert_one_line_error(code, out, err, "--change-times", "empty item")


@pytest.mark.parametrize(
    ("spec", "fragment"),
    [("", "empty"), ("  ", "empty"), ("detrend:3,", "step 2"), ("mean,,decimate:2", "step 2")],
)
def test_empty_preprocess_is_an_error(capsys, gyro_csv, spec, fragment):
    code, out, err = run(capsys, avar(gyro_csv, "--preprocess", spec))
    assert_one_line_error(code, out, err, "--preprocess", fragment)
    with pytest.raises(AdavarInputError, match=fragment):
        parse_steps(spec)


def test_preprocess_steps_still_parse(capsys, gyro_csv):
    assert [s.spec for s in parse_steps(" detrend:3 , decimate:2 ")] == [
        "detrend:3", "decimate:2:keep",
    ]  # fmt: skip
    code, _, err = run(capsys, avar(gyro_csv, "--preprocess", "detrend:3,decimate:2"))
    assert code == 0 and err == "", err


@pytest.mark.parametrize(
    "extra",
    [[], ["--window", "200", "--taus", "octave"], ["--lmax", "200", "--lmin", "100"]],
    ids=["avar", "davar", "adaptive"],
)
def test_force_without_out_is_an_error(capsys, gyro_csv, extra):
    command = "avar" if not extra else "davar" if "--window" in extra else "adaptive"
    argv = [command, *avar(gyro_csv)[1:], *extra]
    code, out, err = run(capsys, [*argv, "--force"])
    assert_one_line_error(code, out, err, "--force", "--out")


def test_unknown_units_warn_in_one_line(capsys, gyro_csv):
    code, out, err = run(capsys, ["avar", str(gyro_csv), "--column", "gyro_x", "--units",
                                  "furlongs"])  # fmt: skip
    assert code == 0
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("adavar: warning: --units 'furlongs'"), err
    assert "deg/s" in lines[0] and "conventional units" in lines[0]
    assert "furlongs" in out  # the free label is still used
    for units, data_type in (("deg/s", "rate"), ("deg/hr", "rate"), ("deg", "phase"),
                             ("s", "phase")):  # fmt: skip
        code, _, err = run(capsys, ["avar", str(gyro_csv), "--column", "gyro_x", "--units",
                                    units, "--data-type", data_type])  # fmt: skip
        assert code == 0 and err == "", (units, err)
    assert is_known_unit("m/s", "phase") and not is_known_unit("deg/s", "phase")


def test_avar_refuses_to_label_every_column_with_one_unit(capsys, gyro_csv, tmp_path):
    code, out, err = run(capsys, ["avar", str(gyro_csv), "--units", "deg/s"])
    assert_one_line_error(code, out, err, "2 numeric columns", "gyro_x, temp", "--column")
    code, out, err = run(capsys, ["avar", str(gyro_csv), "--units", "deg/s", "--column",
                                  "gyro_x,temp"])  # fmt: skip
    assert code == 0 and "column 'temp'" in out, err  # chosen explicitly: fine
    one = tmp_path / "one.csv"
    one.write_text("\n".join(["time,gyro_x"] + [f"{k / RATE},{(-1) ** k}" for k in range(400)]))
    code, out, err = run(capsys, ["avar", str(one), "--units", "deg/s"])
    assert code == 0 and "column 'gyro_x'" in out, err  # the only candidate


# --------------------------------------------------------------------------------------
# Item 18: kalibr and a constant axis
# --------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def imu_csv(tmp_path_factory):
    """A short static 6-axis log whose gz is constant (a dead axis)."""
    rng = np.random.default_rng(1)
    n = 4000
    cols = [np.arange(n) / 100.0] + [0.01 * rng.standard_normal(n) for _ in range(6)]
    cols[3] = np.zeros(n)
    path = tmp_path_factory.mktemp("imu") / "imu.csv"
    np.savetxt(path, np.column_stack(cols), delimiter=",", header="time,gx,gy,gz,ax,ay,az",
               comments="")  # fmt: skip
    return path


@pytest.mark.parametrize("pinned", ["error", "bound"])
def test_kalibr_constant_axis_named_by_its_column(capsys, imu_csv, tmp_path, pinned):
    out = tmp_path / "imu.yaml"
    code, stdout, err = run(capsys, ["kalibr", str(imu_csv), "--gyro-units", "deg/s",
                                     "--accel-units", "g", "--pinned", pinned,
                                     "-o", str(out)])  # fmt: skip
    assert_one_line_error(code, stdout, err, "column 'gz'", "constant", "--gyro")
    assert "--pinned" not in err and "axis 2" not in err
    assert not out.exists()


def test_kalibr_library_names_the_column_and_suggests_only_what_helps():
    rng = np.random.default_rng(2)
    ok = fit_noise(deviation(0.01 * rng.standard_normal(4000), rate=100.0, units="deg/s"))
    flat = fit_noise(deviation(np.zeros(4000), rate=100.0, units="deg/s"))
    acc = [fit_noise(deviation(0.01 * rng.standard_normal(4000), rate=100.0, units="g"))] * 3
    names = {"gyro_names": ["gx", "gy", "gz"], "accel_names": ["ax", "ay", "az"]}
    with pytest.raises(AdavarInputError) as exc:
        kalibr_values(gyro_fits=[ok, ok, flat], accel_fits=acc, pinned="bound", **names)
    message = str(exc.value)
    assert "column 'gz'" in message and "pinned" not in message and "\n" not in message
    with pytest.raises(AdavarInputError, match="3 names for 2 gyro axes"):
        kalibr_values(gyro_fits=[ok, ok], accel_fits=acc, pinned="bound", **names)


def test_points_per_decade_is_bounded_on_the_command_line(capsys, gyro_csv):
    from adavar.stats.statistics import MAX_POINTS_PER_DECADE

    too_many = str(MAX_POINTS_PER_DECADE + 1)
    code, out, err = run(capsys, avar(gyro_csv, "--taus", "log", "--points-per-decade", too_many))
    assert_one_line_error(code, out, err, "--points-per-decade", f"at most {MAX_POINTS_PER_DECADE}")


# --------------------------------------------------------------------------------------
# Issue 40, item 11: a flag the chosen mode ignores is an error; item 13: --chunk-size
# --------------------------------------------------------------------------------------

IGNORED = [
    (["--k1", "2.0"],
     ["--k1 is not used with --thresholds calibrated, the default", "add --thresholds paper"]),
    (["--k2", "4", "--s2", "0.1", "--thresholds", "calibrated"],
     ["--k2 and --s2 are not used with --thresholds calibrated (", "drop --k2 and --s2"]),
    (["--false-alarm", "0.01", "--false-alarm-per-hour", "0.5"],
     ["--false-alarm (false alarms a step) and --false-alarm-per-hour", "give one of them"]),
    (["--thresholds", "paper", "--false-alarm", "0.01"],
     ["--false-alarm is not used with --thresholds paper", "add --thresholds calibrated"]),
    (["--thresholds", "paper", "--false-alarm-per-hour", "1", "--kurtosis-reference",
      "gaussian"], ["--false-alarm-per-hour and --kurtosis-reference are not used"]),
    (["--s1", "0.01"], ["--s1 is not used with --s-test upper", "add --s-test band"]),
    (["--ici-gamma", "2"], ["--ici-gamma is not used by --method adaptive", "add --method ici"]),
    (["--method", "kurtosis", "--no-ici-episodes"],
     ["--no-ici-episodes is not used by --method kurtosis"]),
    (["--method", "ici", "--k2", "4"],
     ["--k2 is not used by --method ici", "choose --method adaptive"]),
    (["--false-alarm", "0.01", "--dependence", "1,1"],
     ["--dependence is not used with --false-alarm", "drop --false-alarm"]),
]  # fmt: skip


@pytest.mark.parametrize(("extra", "fragments"), IGNORED)
def test_a_flag_the_mode_ignores_is_an_error(capsys, gyro_csv, extra, fragments):
    assert_one_line_error(*run(capsys, adaptive(gyro_csv, *extra)), *fragments)


@pytest.mark.parametrize("command", ["report", "batch", "monitor"])
def test_every_command_with_the_controller_refuses_ignored_flags(capsys, gyro_csv, tmp_path,
                                                                 command):  # fmt: skip
    # report and batch: with --adaptive (without it, every controller flag is unused)
    where = {"report": ["--column", "gyro_x", "-o", str(tmp_path / "r.html"), "--adaptive"],
             "batch": ["--column", "gyro_x", "--out", str(tmp_path / "o"), "--adaptive"],
             "monitor": []}[command]  # fmt: skip
    code, out, err = run(capsys, [command, str(gyro_csv), "--rate", "10", "--units", "deg/s",
                                  *where, "--k1", "2"])  # fmt: skip
    assert_one_line_error(code, out, err, "--k1 is not used with --thresholds calibrated")
    assert list(tmp_path.iterdir()) == []  # refused before any work


def test_the_thresholds_used_are_recorded(capsys, gyro_csv):
    """What the run used: the given K1 with --thresholds paper; the calibrated ones (and the
    rate they were calibrated for) otherwise."""
    code, out, err = run(capsys, adaptive(gyro_csv, "--thresholds", "paper", "--k1", "2.0"))
    assert code == 0, err
    used = json.loads(out)["parameters"]["controller"]
    assert used["thresholds"] == "paper" and used["thresholds_used"]["k1"] == [2.0, 2.0]
    code, out, err = run(capsys, adaptive(gyro_csv, "--false-alarm", "0.02"))
    assert code == 0, err
    used = json.loads(out)["parameters"]["controller"]
    assert used["thresholds"] == "calibrated" and used["false_alarm"] == 0.02
    assert used["false_alarm_per_hour"] is None and used["thresholds_used"]["k1"][0] != 2.5


@pytest.mark.parametrize("value", ["nan", "0", "-1", "inf"])
def test_power_law_bandwidth_must_be_positive(capsys, gyro_csv, value):
    code, out, err = run(capsys, avar(gyro_csv, "--power-law", "on", "--f-h", value))
    assert_one_line_error(code, out, err, "--f-h", "positive number of Hz")


def test_power_law_bandwidth_without_the_power_law_fit(capsys, gyro_csv):
    code, out, err = run(capsys, avar(gyro_csv, "--power-law", "off", "--f-h", "2"))
    assert_one_line_error(code, out, err, "--f-h is not used with --power-law off")


def test_a_tiny_chunk_size_warns(capsys, gyro_csv):
    from adavar.core.settings import EFFICIENT_CHUNK

    code, _, err = run(capsys, avar(gyro_csv, "--chunk-size", "16"))
    assert code == 0, err
    [line] = err.strip().splitlines()
    assert line.startswith("adavar: warning: --chunk-size 16") and str(EFFICIENT_CHUNK) in line
    code, _, err = run(capsys, avar(gyro_csv, "--chunk-size", str(EFFICIENT_CHUNK)))
    assert code == 0 and err == ""


def test_the_constant_check_reads_pieces_and_sees_a_change_in_any():
    from adavar.io.sources import ArraySource
    from adavar.pipeline.analysis import is_constant as _constant

    flat = np.full(10, 2.5)
    assert _constant(ArraySource(flat), chunk_size=3)
    late = flat.copy()
    late[-1] = 2.0  # in the last piece only
    assert not _constant(ArraySource(late), chunk_size=3)
    assert not _constant(ArraySource(np.array([np.nan, np.nan])), chunk_size=1)
    assert not _constant(ArraySource(np.array([], dtype=float)), chunk_size=3)


def test_kalibr_reads_nanosecond_stamps_and_takes_the_filter(capsys, tmp_path):
    """ROS-style integer ns stamps: the error names --time-format, which kalibr has; the
    IMU's bandwidth leaves the short taus out of every axis' fit."""
    rng = np.random.default_rng(4)
    n = 2500
    stamps = 1_700_000_000_000_000_000 + 5_000_000 * np.arange(n, dtype=np.int64)
    path = tmp_path / "imu.csv"
    with open(path, "w") as f:
        f.write("timestamp,gx,gy,gz,ax,ay,az\n")
        for k in range(n):
            cells = ",".join(f"{v:.6e}" for v in 1e-3 * rng.standard_normal(6))
            f.write(f"{stamps[k]},{cells}\n")
    base = ["kalibr", str(path), "--gyro-units", "rad/s", "--accel-units", "m/s^2",
            "--pinned", "bound", "-o", str(tmp_path / "imu.yaml"), "--force", "--json"]  # fmt: skip
    code, stdout, err = run(capsys, base)
    assert_one_line_error(code, stdout, err, "timestamp", "--time-format")
    code, stdout, err = run(capsys, [*base, "--time-format", "ns"])
    assert code == 0, err
    assert json.loads(stdout)["rate"] == 200.0
    code, stdout, err = run(capsys, [*base, "--time-column", "none", "--rate", "200",
                                     "--bandwidth", "20"])  # fmt: skip
    assert code == 0, err
    text = (tmp_path / "imu.yaml").read_text()
    assert "99 %" in text and json.loads(stdout)["n_samples"] == n
    from adavar.cli.entry import build_parser
    from adavar.cli.kalibr import kalibr_request

    args = build_parser().parse_args([*base, "--bandwidth", "20", "--tau-range", "0.5:"])
    fit = kalibr_request(args).fit
    assert fit.bandwidth == 20.0 and fit.tau_range == (0.5, None)

"""The messages of bad input name the problem and a way out that works, in the CLI's terms.

Options that a command cannot honour are errors (``report --lmax`` without ``--adaptive``,
``simulate --scenario 1 --n 1000``); hints name only what works for the command (``--gaps
split`` is for ``avar`` only; FILE ``-`` is for ``monitor``); messages name the flags
(``--gyro``, ``--accel-units``, ``--ici-lengths``, ``--lmax``, ``--stat theo1``); and say
what is true (the minimum length of ThêoH, a count of 1e+302 samples, the phase units
adavar knows, times counted from the first stamp).
"""

from __future__ import annotations

import numpy as np
import pytest

from adavar.core.errors import AdavarInputError
from adavar.core.units import is_known_unit
from adavar.stats.theo_family import ratio_factors

from .cli_helpers import assert_one_line_error, run

RATE = "10"


def _write(path, header, columns):
    rows = zip(*(c.tolist() for c in columns), strict=True)
    path.write_text(header + "\n" + "".join(",".join(map(repr, r)) + "\n" for r in rows))
    return path


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A gap-free record, one with a gap, one with a repeated stamp near 1e6 s, an IMU."""
    folder = tmp_path_factory.mktemp("messages")
    rng = np.random.default_rng(5)
    x = rng.standard_normal(2000)
    t = np.arange(2000) / 10.0
    gap = t.copy()
    gap[1000:] += 5.0  # a 5.1 s gap after 100 s
    late = 1e6 + t
    late[500] = late[499]
    return {
        "base": _write(folder / "base.csv", "gx", [x]),
        "gap": _write(folder / "gap.csv", "time,gx", [gap, x]),
        "dup": _write(folder / "dup.csv", "time,gx", [late, x]),
        "imu": _write(
            folder / "imu.csv", "wx,wy,wz,ax,ay,az", list(rng.standard_normal((6, 2000)))
        ),
        "three": _write(folder / "three.csv", "gx", [x[:3]]),
    }


def base(files, command, *extra):
    return [command, str(files["base"]), "--units", "deg/s", "--rate", RATE, *extra]


# --------------------------------------------------------------------------------------
# 1. Options the command cannot honour
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "extra, fragments",
    [
        (["--lmax", "100"], ["--lmax is not used without --adaptive", "add --adaptive"]),
        (["--k1", "2", "--thresholds", "paper"],
         ["--k1 and --thresholds are not used without --adaptive"]),
        (["--l", "50"], ["--l is not used without --adaptive"]),
        (["--window", "200", "--lmax", "400"],
         ["--lmax is not used with --window", "give --adaptive instead of --window"]),
    ],
)  # fmt: skip
def test_report_refuses_controller_flags_without_adaptive(files, tmp_path, capsys, extra,
                                                          fragments):  # fmt: skip
    target = tmp_path / "r.html"
    code, out, err = run(capsys, base(files, "report", "-o", str(target), *extra))
    assert_one_line_error(code, out, err, *fragments)
    assert not target.exists()


def test_batch_refuses_controller_flags_without_adaptive(files, tmp_path, capsys):
    out_dir = tmp_path / "b"
    code, out, err = run(capsys, base(files, "batch", "--out", str(out_dir), "--lmax", "100"))
    assert_one_line_error(code, out, err, "--lmax is not used without --adaptive")


@pytest.mark.parametrize(
    "extra, named",
    [(["--n", "1000"], "--n is"), (["--n", "1000", "--rate", "5"], "--n and --rate are"),
     (["--lsb", "0.1"], "--lsb is")],
)  # fmt: skip
def test_simulate_scenario_refuses_the_sensor_shape(tmp_path, capsys, extra, named):
    target = tmp_path / "s.csv"
    code, out, err = run(capsys, ["simulate", "--scenario", "1", "-o", str(target), *extra])
    assert_one_line_error(code, out, err, named, "not used with --scenario", "6000 samples")
    assert not target.exists()


def test_simulate_negative_coefficient_is_named(tmp_path, capsys):
    target = tmp_path / "s.csv"
    code, out, err = run(capsys, ["simulate", "-o", str(target), "--n", "1000", "--arw", "-1"])
    assert_one_line_error(code, out, err, "--arw -1", "must not be negative")
    code, out, err = run(capsys, ["simulate", "-o", str(target), "--n", "1000", "--arw", "1",
                                  "--rrw", "-0.5"])  # fmt: skip
    assert_one_line_error(code, out, err, "--rrw -0.5", "must not be negative")


# --------------------------------------------------------------------------------------
# 2. Hints that lead somewhere
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "command, extra, ways",
    [
        ("avar", [], "use --gaps split or --gaps interpolate or --gaps omit"),
        ("davar", ["--window", "100"], "use --gaps interpolate or --gaps omit"),
        ("adaptive", [], "use --gaps interpolate"),
        ("compare", [], "use --gaps interpolate"),
    ],
)
def test_gap_hint_names_what_the_command_has(files, capsys, command, extra, ways):
    code, out, err = run(capsys, [command, str(files["gap"]), "--units", "deg/s", *extra])
    assert_one_line_error(code, out, err, "gap of 5.1 s", "after the first stamp", ways)
    assert err.rstrip().endswith(ways)
    if "split" not in ways:
        assert "split" not in err


def test_batch_gap_hint_has_no_split(files, tmp_path, capsys):
    code, _, err = run(capsys, ["batch", str(files["gap"]), "--units", "deg/s", "--out",
                                  str(tmp_path / "b")])  # fmt: skip
    assert code == 2
    assert "use --gaps interpolate" in err and "split" not in err and "omit" not in err


@pytest.mark.parametrize(
    "argv, monitor",
    [
        (["avar", "-", "--rate", RATE, "--units", "deg/s"], True),
        (["davar", "-", "--rate", RATE, "--units", "deg/s", "--window", "100"], True),
        (["kalibr", "-", "--gyro", "a,b,c", "--accel", "d,e,f", "-o", "k.yaml"], False),
    ],
)
def test_stdin_is_refused_with_the_way_out(capsys, argv, monitor):
    code, out, err = run(capsys, argv)
    assert_one_line_error(code, out, err, f"adavar {argv[0]} does not read standard input",
                          "save the samples to a file")  # fmt: skip
    assert ("'adavar monitor -'" in err) is monitor
    assert "no such file" not in err


# --------------------------------------------------------------------------------------
# 3. The flag named is the user's
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "gyro, accel, where",
    [("wx,wx,wz", "ax,ay,az", "in --gyro ("), ("wx,wy,wz", "ax,wy,az", "in --gyro and --accel")],
)  # fmt: skip
def test_kalibr_repeated_column_names_its_flag(files, tmp_path, capsys, gyro, accel, where):
    code, out, err = run(capsys, ["kalibr", str(files["imu"]), "--rate", RATE, "--gyro", gyro,
                                  "--accel", accel, "--gyro-units", "deg/s", "--accel-units",
                                  "g", "-o", str(tmp_path / "k.yaml")])  # fmt: skip
    assert_one_line_error(code, out, err, "is named twice", where)
    assert "--column" not in err


def test_kalibr_wrong_accel_unit_names_the_flag(files, tmp_path, capsys):
    target = tmp_path / "k.yaml"
    code, out, err = run(capsys, ["kalibr", str(files["imu"]), "--rate", RATE, "--gyro",
                                  "wx,wy,wz", "--accel", "ax,ay,az", "--gyro-units", "deg/s",
                                  "--accel-units", "rad/s", "-o", str(target)])  # fmt: skip
    assert_one_line_error(code, out, err, "(--accel-units)", "'rad/s'", "not an acceleration")


def test_ici_lengths_message_names_the_flag(files, capsys):
    code, out, err = run(capsys, base(files, "adaptive", "--method", "ici", "--ici-lengths",
                                      "5,3"))  # fmt: skip
    assert_one_line_error(code, out, err, "ici_lengths (--ici-lengths) must hold lmin")


def test_lmax_longer_than_the_record_names_the_flag(files, capsys):
    code, out, err = run(capsys, base(files, "adaptive", "--lmax", "2001"))
    assert_one_line_error(code, out, err, "the record has 2000 samples", "at least 2001",
                          "lmax (--lmax) 2001", "at most 2000 samples")  # fmt: skip


def test_theo1_suggestion_names_the_flag():
    with pytest.raises(AdavarInputError, match=r"stat='theo1' \(--stat theo1\)"):
        ratio_factors(10)


# --------------------------------------------------------------------------------------
# 4. What the message says is true
# --------------------------------------------------------------------------------------


def test_theoh_says_its_own_minimum(files, capsys):
    code, out, err = run(capsys, ["avar", str(files["three"]), "--units", "deg/s", "--rate",
                                  RATE, "--stat", "theoh"])  # fmt: skip
    assert_one_line_error(code, out, err, "the record has 3 samples", "(--stat theoh)",
                          "at least 4 samples of rate data")  # fmt: skip
    four = files["three"].with_name("four.csv")
    four.write_text(files["three"].read_text() + "0.5\n")
    code, out, err = run(capsys, ["avar", str(four), "--units", "deg/s", "--rate", RATE,
                                  "--stat", "theoh", "--json"])  # fmt: skip
    assert code == 0, err  # 4 samples are enough, as said


@pytest.mark.parametrize(
    "argv",
    [["adaptive", "--lmin", "1e300s"], ["adaptive", "--lmax", "1e300s"],
     ["davar", "--window", "1e300s"], ["compare", "--lmax", "1e300s"]],
)  # fmt: skip
def test_huge_lengths_are_printed_short(files, capsys, argv):
    command, *extra = argv
    code, out, err = run(capsys, base(files, command, *extra))
    assert_one_line_error(code, out, err, "1e+301")  # 1e300 s at 10 Hz
    assert len(err) < 300 and "0000000000" not in err


def test_phase_units_warning_is_coherent(files, capsys):
    code, _, err = run(capsys, base(files, "avar", "--data-type", "phase", "--units",
                                      "deg/s"))  # fmt: skip
    assert code == 0
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "'deg/s' is a unit of rate data, not of --data-type phase" in lines[0]
    assert "rad, deg, m/s, s, ms, us, ns" in lines[0]
    for units in ("ns", "s", "deg"):  # a clock's time error, an angle: known, no warning
        code, _, err = run(capsys, base(files, "avar", "--data-type", "phase", "--units",
                                          units))  # fmt: skip
        assert code == 0 and err == "", (units, err)
        assert is_known_unit(units, "phase")
    _, _, err = run(capsys, base(files, "avar", "--data-type", "phase", "--units", "ft"))
    assert "not a unit adavar knows for phase data" in err and "deg/s" not in err


def test_repeated_stamp_is_counted_from_the_first(files, capsys):
    code, out, err = run(capsys, ["avar", str(files["dup"]), "--units", "deg/s"])
    assert_one_line_error(code, out, err, "time repeats at row 502",
                          "t = 49.9 s after the first stamp", "as in row 501")  # fmt: skip

"""Window-like parameters as durations: the same results as the samples they round to."""

from __future__ import annotations

import datetime
import json

import numpy as np
import pytest

import adavar
from adavar import simulate
from adavar.core.durations import Duration, parse_duration, to_samples

from .cli_helpers import assert_one_line_error, run


@pytest.mark.parametrize(
    ("text", "seconds"),
    [("600s", 600.0), ("10min", 600.0), ("2h", 7200.0), ("250ms", 0.25), ("1.5 h", 5400.0),
     (" 3 sec ", 3.0), ("1e2s", 100.0), ("1d", 86400.0)],
)  # fmt: skip
def test_parse_duration(text, seconds):
    assert parse_duration(text) == Duration(seconds)


def test_digits_are_samples_and_bad_strings_are_errors():
    assert parse_duration("600") is None
    assert to_samples("600", 0.01, "window") == 600
    for bad in ("10 parsecs", "s", "-5s", "five minutes", ""):
        with pytest.raises(adavar.AdavarInputError, match="neither a number of samples"):
            parse_duration(bad)
    with pytest.raises(adavar.AdavarInputError, match="shorter than one sample"):
        to_samples("1ms", 0.01, "window")
    with pytest.raises(adavar.AdavarInputError, match="positive"):
        adavar.seconds(0)


def test_conversions_round_to_the_nearest_sample():
    assert to_samples("1min", 1 / 200, "window") == 12_000
    assert to_samples(adavar.seconds(0.0149), 0.01, "l") == 1
    assert to_samples(datetime.timedelta(minutes=2), 0.5, "step") == 240
    assert to_samples(7, 0.5, "step") == 7  # samples pass through unchanged


@pytest.fixture(scope="module")
def gyro():
    return simulate.sensor(72_000, rate=200.0, angle_random_walk=0.005, bandwidth=50.0,
                           lsb=1 / 131, seed=3)  # fmt: skip


def test_davar_window_and_step_as_durations_equal_samples(gyro):
    a = adavar.davar(gyro, rate=200.0, window="30s", step="5s", taus="octave")
    b = adavar.davar(gyro, rate=200.0, window=6000, step=1000, taus="octave")
    np.testing.assert_array_equal(a.avar, b.avar)
    np.testing.assert_array_equal(a.centre, b.centre)
    c = adavar.davar(gyro, rate=200.0, window=datetime.timedelta(seconds=30), step=1000,
                     taus="octave")  # fmt: skip
    np.testing.assert_array_equal(c.avar, b.avar)


def test_adaptive_lengths_as_durations_equal_samples(gyro):
    x = gyro[:20_000]
    a = adavar.adaptive_davar(x, rate=200.0, lmax="3s", lmin="2s", l="0.5s", taus="octave",
                              step="0.5s")  # fmt: skip
    b = adavar.adaptive_davar(x, rate=200.0, lmax=600, lmin=400, l=100, taus="octave", step=100)
    np.testing.assert_array_equal(a.window, b.window)
    np.testing.assert_array_equal(a.avar, b.avar)


def test_duration_lmin_takes_the_parity_of_lmax(gyro):
    # 2.005 s at 200 Hz is 401 samples: one sample up to keep lmax - lmin even
    result = adavar.adaptive_schedule(gyro[:20_000], rate=200.0, lmax="3s", lmin="2.005s",
                                      l=100)  # fmt: skip
    assert result.window.min() >= 402 and (600 - result.window.min()) % 2 == 0
    with pytest.raises(adavar.AdavarInputError, match="even"):  # samples are taken as given
        adavar.adaptive_schedule(gyro[:20_000], rate=200.0, lmax=600, lmin=401, l=100)


def test_cli_durations_equal_samples(capsys, tmp_path, gyro):
    path = tmp_path / "gyro.npy"
    np.save(path, gyro)
    common = ["davar", str(path), "--rate", "200", "--units", "deg/s", "--taus", "octave",
              "--json"]  # fmt: skip
    code, out_s, err = run(capsys, [*common, "--window", "30s", "--step", "5s"])
    assert code == 0, err
    code, out_n, err = run(capsys, [*common, "--window", "6000", "--step", "1000"])
    assert code == 0, err
    a, b = json.loads(out_s), json.loads(out_n)
    assert a["parameters"]["window"] == 6000 and a["parameters"]["step"] == 1000
    assert a["fit"] == b["fit"]
    code, out, err = run(capsys, ["adaptive", str(path), "--rate", "200", "--units", "deg/s",
                                  "--lmax", "3s", "--lmin", "2s", "--l", "0.5s", "--taus",
                                  "octave", "--step", "1s", "--json"])  # fmt: skip
    assert code == 0, err
    controller = json.loads(out)["parameters"]["controller"]
    assert (controller["lmax"], controller["lmin"], controller["l"]) == (600, 400, 100)


def test_cli_bad_duration_is_a_one_line_error(capsys, tmp_path, gyro):
    path = tmp_path / "gyro.npy"
    np.save(path, gyro[:5000])
    code, out, err = run(capsys, ["davar", str(path), "--rate", "200", "--units", "deg/s",
                                  "--window", "10parsecs"])  # fmt: skip
    assert_one_line_error(code, out, err, "neither a number of samples nor a duration")
    code, out, err = run(capsys, ["davar", str(path), "--rate", "200", "--units", "deg/s",
                                  "--window", "1ms"])  # fmt: skip
    assert_one_line_error(code, out, err, "shorter than one sample")

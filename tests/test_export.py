"""Tests of adavar.output.export: atomic CSV/JSON writers, the coefficient table, Kalibr
imu.yaml."""

from __future__ import annotations

import csv
import json
import math
import os

import numpy as np
import pytest

from adavar import deviation, fit_noise
from adavar.core.errors import AdavarInputError
from adavar.fit.noise_model import fit_avar
from adavar.output.export import (
    COEFFICIENT_COLUMNS,
    KALIBR_KEYS,
    coefficient_rows,
    kalibr_imu_yaml,
    kalibr_values,
    write_json,
    write_table_csv,
)

G = 9.80665
DEG = math.pi / 180.0
TAU = np.logspace(-2, 3, 30)


def _fit(n: float, k: float, units: str | None, b: float = 0.0):
    """A real NoiseFit whose N and K are (almost exactly) ``n`` and ``k``."""
    avar = n**2 / TAU + k**2 * TAU / 3.0 + (2 * math.log(2) / math.pi) * b**2
    terms = ("angle_random_walk", "rate_random_walk") + (("bias_instability",) if b else ())
    return fit_avar(TAU, avar, terms=terms, units=units)


def _parse_yaml(text: str) -> dict:
    """A tiny parser for the flat ``key: value  # comment`` YAML that Kalibr reads."""
    try:
        import yaml
    except ImportError:
        out = {}
        for line in text.splitlines():
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            key, _, rest = line.partition(":")
            rest = rest.strip()
            if rest.startswith('"'):  # a double-quoted (JSON-compatible) string
                out[key.strip()] = json.JSONDecoder().raw_decode(rest)[0]
                continue
            value = rest.split(" #", 1)[0].strip()
            try:
                out[key.strip()] = float(value)
            except ValueError:
                out[key.strip()] = value
        return out
    return yaml.safe_load(text)


def _one_line(exc: pytest.ExceptionInfo) -> str:
    message = str(exc.value)
    assert message and "\n" not in message
    return message


def _leftovers(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


# --------------------------------------------------------------------------------------
# Kalibr
# --------------------------------------------------------------------------------------


def test_kalibr_from_deg_s_and_g():
    gyro_n = [0.004, 0.005, 0.003]  # deg/s*sqrt(s) = deg/sqrt(s)
    gyro_k = [2e-4, 1e-4, 3e-4]  # deg/s/sqrt(s)
    acc_n = [1e-4, 3e-4, 2e-4]  # g*sqrt(s)
    acc_k = [5e-6, 4e-6, 6e-6]  # g/sqrt(s)
    gyros = [_fit(n, k, "deg/s") for n, k in zip(gyro_n, gyro_k, strict=True)]
    accels = [_fit(n, k, "g") for n, k in zip(acc_n, acc_k, strict=True)]
    text = kalibr_imu_yaml(gyro_fits=gyros, accel_fits=accels, rate=200.0, topic="/imu0")
    data = _parse_yaml(text)
    assert list(data) == list(KALIBR_KEYS)
    assert data["rostopic"] == "/imu0"
    assert data["update_rate"] == 200.0
    assert data["gyroscope_noise_density"] == pytest.approx(0.005 * DEG, rel=1e-6)
    assert data["gyroscope_random_walk"] == pytest.approx(3e-4 * DEG, rel=1e-6)
    assert data["accelerometer_noise_density"] == pytest.approx(3e-4 * G, rel=1e-6)
    assert data["accelerometer_random_walk"] == pytest.approx(6e-6 * G, rel=1e-6)
    for key in KALIBR_KEYS[:4]:
        assert isinstance(data[key], float)
    # the conversions and the per-axis values are documented in the file
    assert "pi/180" in text and "9.80665" in text and "Inflation: none" in text
    assert f"{0.004 * DEG:.4e}"[:5] in text

    mean = _parse_yaml(
        kalibr_imu_yaml(gyro_fits=gyros, accel_fits=accels, rate=200.0, combine="mean")
    )
    assert mean["gyroscope_noise_density"] == pytest.approx(0.004 * DEG, rel=1e-6)
    assert mean["accelerometer_random_walk"] == pytest.approx(5e-6 * G, rel=1e-6)


def test_kalibr_from_conventional_units_and_inflation():
    # N = 0.355 deg/sqrt(h) (the paper's gyro) and K = 1 deg/h/sqrt(h), data in deg/h
    n_conv, k_conv = 0.355, 1.0
    n_deg_h = n_conv * 60.0  # deg/h*sqrt(s)
    k_deg_h = k_conv / 60.0  # deg/h/sqrt(s)
    gyro = _fit(n_deg_h, k_deg_h, "deg/h", b=0.5)
    np.testing.assert_allclose(gyro.to_units().angle_random_walk.value, n_conv, rtol=1e-6)
    vrw = 0.06  # m/s/sqrt(h)
    accel = _fit(vrw / 60.0, 1e-3, "m/s^2")  # m/s/sqrt(h) -> m/s^2*sqrt(s)
    text = kalibr_imu_yaml(gyro_fits=gyro, accel_fits=[accel], rate=100, inflate=10.0)
    data = _parse_yaml(text)
    assert data["gyroscope_noise_density"] == pytest.approx(10 * n_conv * DEG / 60, rel=1e-6)
    assert data["gyroscope_random_walk"] == pytest.approx(10 * k_conv * DEG / 3600 / 60, rel=1e-6)
    assert data["accelerometer_noise_density"] == pytest.approx(10 * vrw / 60, rel=1e-6)
    assert data["accelerometer_random_walk"] == pytest.approx(10 * 1e-3, rel=1e-6)
    assert data["update_rate"] == 100.0
    assert "multiplied by 10" in text


def test_kalibr_units_and_topic_options():
    gyro = _fit(1e-3, 1e-5, None)
    accel = _fit(2e-3, 3e-5, None)
    values = kalibr_values(gyro_fits=[gyro], accel_fits=[accel])  # SI by default
    assert values["gyroscope_noise_density"] == pytest.approx(1e-3, rel=1e-6)
    assert values["gyro_units"] == "rad/s" and values["accel_units"] == "m/s^2"
    declared = kalibr_values(
        gyro_fits=[gyro], accel_fits=[accel], gyro_units="deg/s", accel_units="mg"
    )
    assert declared["gyroscope_random_walk"] == pytest.approx(1e-5 * DEG, rel=1e-6)
    assert declared["accelerometer_noise_density"] == pytest.approx(2e-3 * 1e-3 * G, rel=1e-6)
    text = kalibr_imu_yaml(gyro_fits=gyro, accel_fits=accel, rate=400.5, topic="/imu #1")
    data = _parse_yaml(text)
    assert data["rostopic"] == "/imu #1" and data["update_rate"] == 400.5


def test_kalibr_pinned_term():
    x = np.random.default_rng(3).standard_normal(20_000) * 1e-3
    pinned = fit_noise(deviation(x, rate=100.0, units="rad/s"),
                       terms=("angle_random_walk", "rate_random_walk"))  # fmt: skip
    assert float(pinned.rate_random_walk.value) == 0.0
    accel = _fit(1e-3, 1e-4, "m/s^2")
    with pytest.raises(AdavarInputError) as exc:
        kalibr_imu_yaml(gyro_fits=[pinned], accel_fits=[accel], rate=100.0)
    assert "rate_random_walk" in _one_line(exc) and "pinned='bound'" in str(exc.value)
    # "bound": the 99 % upper bound (the 84 % one lay below the truth in 28 of 32 dropped
    # random walks of an audit); "sigma": the 84 % one, as "bound" gave before 0.3.0
    upper = float(pinned.rate_random_walk.upper)
    sigma = float(pinned.rate_random_walk.uncertainty)
    assert upper > sigma > 0
    for how, want in (("bound", upper), ("sigma", sigma)):
        text = kalibr_imu_yaml(gyro_fits=[pinned], accel_fits=[accel], rate=100.0, pinned=how)
        assert _parse_yaml(text)["gyroscope_random_walk"] == pytest.approx(want, rel=1e-6)
        assert ("99 %" in text) == (how == "bound") and ("84 %" in text) == (how == "sigma")
    # a fit with no bound_level bound (WLS of a curve): "bound" says so, "sigma" works
    wls = fit_avar(TAU, 1e-6 / TAU, terms=("angle_random_walk", "rate_random_walk"),
                   units="rad/s")  # fmt: skip
    assert float(wls.rate_random_walk.value) == 0.0 and np.isnan(wls.rate_random_walk.upper)
    with pytest.raises(AdavarInputError, match="pinned='sigma'"):
        kalibr_imu_yaml(gyro_fits=[wls], accel_fits=[accel], rate=100.0, pinned="bound")
    kalibr_imu_yaml(gyro_fits=[wls], accel_fits=[accel], rate=100.0, pinned="sigma")


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"rate": 0.0}, "rate"),
        ({"rate": float("nan")}, "rate"),
        ({"topic": ""}, "topic"),
        ({"topic": "a\nb"}, "topic"),
        ({"combine": "median"}, "combine"),
        ({"inflate": -1.0}, "inflate"),
        ({"pinned": "zero"}, "pinned"),
        ({"gyro_units": "m/s^2"}, "gyro_units"),
        ({"accel_units": "deg/s"}, "accel_units"),
        ({"gyro_units": "furlong/s"}, "unknown"),
        ({"gyro_fits": []}, "no gyro fits"),
        ({"accel_fits": None}, "no accel fits"),
        ({"accel_fits": [1, 2, 3]}, "NoiseFit"),
    ],
)
def test_kalibr_errors(kwargs, needle):
    args = {
        "gyro_fits": [_fit(1e-3, 1e-5, None)],
        "accel_fits": [_fit(1e-3, 1e-5, None)],
        "rate": 100.0,
    }
    args.update(kwargs)
    with pytest.raises(AdavarInputError) as exc:
        kalibr_imu_yaml(**args)
    assert needle in _one_line(exc)


def test_kalibr_unit_disagreement():
    gyro = _fit(1e-3, 1e-5, "deg/s")
    with pytest.raises(AdavarInputError) as exc:
        kalibr_imu_yaml(
            gyro_fits=[gyro], accel_fits=[_fit(1e-3, 1e-5, "g")], rate=100.0, gyro_units="rad/s"
        )
    assert "declared in 'deg/s'" in _one_line(exc)
    with pytest.raises(AdavarInputError) as exc:
        kalibr_imu_yaml(
            gyro_fits=[gyro, _fit(1e-3, 1e-5, "deg/h")],
            accel_fits=[_fit(1e-3, 1e-5, "g")],
            rate=100.0,
        )
    assert "different units" in _one_line(exc)


# --------------------------------------------------------------------------------------
# coefficient table
# --------------------------------------------------------------------------------------


def test_coefficient_rows():
    fit = _fit(0.355 * 60, 1.0 / 60, "deg/h", b=0.5)
    rows = coefficient_rows(fit)
    assert [r["symbol"] for r in rows] == ["Q", "N", "B", "K", "R"]
    assert all(list(r) == list(COEFFICIENT_COLUMNS) for r in rows)
    n = rows[1]
    assert n["unit"] == "deg/h*sqrt(s)" and n["conventional_unit"] == "deg/sqrt(h)"
    assert n["value"] == pytest.approx(0.355 * 60, rel=1e-6)
    assert n["conventional_value"] == pytest.approx(0.355, rel=1e-6)
    assert rows[2]["conventional_unit"] == "deg/h"
    assert rows[2]["value"] == pytest.approx(0.5, rel=1e-4)
    assert rows[3]["conventional_value"] == pytest.approx(1.0, rel=1e-6)
    # terms not in the model: value 0, uncertainty None (NaN)
    assert rows[0]["value"] == 0.0 and rows[0]["uncertainty"] is None
    json.dumps(rows, allow_nan=False)

    plain = coefficient_rows(_fit(1.0, 0.1, None))
    assert plain[1]["unit"] == "unit*sqrt(s)" and plain[1]["conventional_value"] is None
    given = coefficient_rows(_fit(1.0, 0.1, None), units="g")
    assert given[3]["conventional_unit"] == "m/s^2/sqrt(h)"
    assert given[3]["conventional_value"] == pytest.approx(0.1 * G * 60, rel=1e-6)


def test_coefficient_rows_errors():
    with pytest.raises(AdavarInputError) as exc:
        coefficient_rows(_fit(1.0, 0.1, "deg/s"), units="rad/s")
    assert "declared in 'deg/s'" in _one_line(exc)
    with pytest.raises(AdavarInputError) as exc:
        coefficient_rows(_fit(1.0, 0.1, None), units="parsec")
    _one_line(exc)
    stack = fit_avar(TAU, np.stack([1 / TAU, 2 / TAU]), terms=("angle_random_walk",))
    with pytest.raises(AdavarInputError) as exc:
        coefficient_rows(stack)
    assert "stack of curves" in _one_line(exc)


# --------------------------------------------------------------------------------------
# atomic writers
# --------------------------------------------------------------------------------------


def test_write_table_csv_round_trip(tmp_path):
    fit = _fit(0.355 * 60, 1.0 / 60, "deg/h")
    path = tmp_path / "coefficients.csv"
    out = write_table_csv(
        path,
        coefficient_rows(fit),
        COEFFICIENT_COLUMNS,
        comment="adavar coefficients\nunits: deg/h",
    )
    assert out == path
    lines = path.read_text().splitlines()
    assert lines[:2] == ["# adavar coefficients", "# units: deg/h"]
    rows = list(csv.DictReader(lines[2:]))
    assert [r["term"] for r in rows][1] == "angle_random_walk"
    assert float(rows[1]["value"]) == coefficient_rows(fit)[1]["value"]  # exact round trip
    assert rows[0]["uncertainty"] == ""
    write_table_csv(
        path,
        [
            [1, 2.5, "a,b"],
            (np.float32(0.5), None, True),
            [np.int64(3), float("nan"), np.array(1.0)],
        ],
        ["i", "x", "s"],
    )
    assert path.read_text().splitlines() == ["i,x,s", '1,2.5,"a,b"', "0.5,,true", "3,nan,1.0"]
    assert _leftovers(tmp_path) == ["coefficients.csv"]


def test_write_table_csv_bad_row_leaves_nothing(tmp_path):
    path = tmp_path / "t.csv"
    with pytest.raises(ValueError, match="row 1"):
        write_table_csv(path, [[1, 2], [3]], ["a", "b"])
    with pytest.raises(ValueError, match="not a column"):
        write_table_csv(path, [{"a": 1, "c": 2}], ["a", "b"])
    with pytest.raises(TypeError):
        write_table_csv(path, [[1, object()]], ["a", "b"])
    assert _leftovers(tmp_path) == []
    # an existing file is left as it was
    path.write_text("old\n")
    with pytest.raises(ValueError):
        write_table_csv(path, [[1]], ["a", "b"])
    assert path.read_text() == "old\n" and _leftovers(tmp_path) == ["t.csv"]


def test_write_json(tmp_path):
    path = tmp_path / "result.json"
    payload = {
        "a": np.arange(3),
        "b": np.float64("nan"),
        "c": [np.int32(2), (1.5, None)],
        "d": {"e": np.bool_(True)},
        "p": tmp_path,
        "µ": "ü",
    }
    assert write_json(path, payload) == path
    data = json.loads(path.read_text(encoding="utf-8"))
    assert data == {
        "a": [0, 1, 2],
        "b": None,
        "c": [2, [1.5, None]],
        "d": {"e": True},
        "p": str(tmp_path),
        "µ": "ü",
    }
    with pytest.raises(TypeError):
        write_json(tmp_path / "bad.json", {"x": object()})
    assert _leftovers(tmp_path) == ["result.json"]


def test_writers_fail_cleanly(tmp_path, monkeypatch):
    with pytest.raises(AdavarInputError) as exc:
        write_json(tmp_path / "missing" / "x.json", {})
    assert "does not exist" in _one_line(exc)
    (tmp_path / "folder").mkdir()
    with pytest.raises(AdavarInputError) as exc:
        write_table_csv(tmp_path / "folder", [], ["a"])
    assert "is a folder" in _one_line(exc)

    target = tmp_path / "x.json"
    target.write_text("old")

    def broken_replace(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(AdavarInputError) as exc:
        write_json(target, {"a": 1})
    assert "No space left" in _one_line(exc)
    assert target.read_text() == "old"
    assert _leftovers(tmp_path) == ["folder", "x.json"]

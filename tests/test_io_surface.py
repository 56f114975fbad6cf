"""Tests of adavar.io.text_column.write_surface: NetCDF and Parquet files readable without
adavar."""

from __future__ import annotations

import dataclasses
import sys

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from scipy.io import netcdf_file

import adavar
from adavar import simulate
from adavar.core.errors import AdavarInputError
from adavar.io import writers as adio
from adavar.io.writers import SURFACE_FORMATS, check_surface_format, write_surface

RATE = 10.0


@pytest.fixture(scope="module")
def result():
    """A surface with two window lengths (NaN cells where tau > L/3), every 3rd centre."""
    x = simulate.white(3000, std=0.5, rate=RATE, seed=3)
    window = np.r_[np.full(1500, 150), np.full(1500, 450)]
    res = adavar.davar(x, window=window, rate=RATE, step=3, units="deg/s", taus="log")
    assert np.isnan(res.avar).any() and np.isfinite(res.avar).any()
    return res


@pytest.fixture(scope="module")
def bare():
    """No confidence bounds, no declared unit."""
    x = simulate.white(2000, seed=4)
    return adavar.davar(x, window=200, rate=RATE, step=5, confidence=None, taus="octave")


def read_nc(path):
    with netcdf_file(path, "r", mmap=False) as nc:
        variables = {
            name: (var.dimensions, np.array(var[:]), var.typecode(), dict(var._attributes))
            for name, var in nc.variables.items()
        }
        return variables, dict(nc._attributes)


def assert_same(a, b):
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))  # NaN == NaN here


# --------------------------------------------------------------------------------------
# NetCDF
# --------------------------------------------------------------------------------------


def test_netcdf_round_trip_with_scipy(result, tmp_path):
    path = write_surface(tmp_path / "surface.nc", result)
    assert path == tmp_path / "surface.nc"
    assert [p.name for p in tmp_path.iterdir()] == ["surface.nc"]
    assert path.read_bytes()[:4] == b"CDF\x02"  # classic format, 64-bit offsets
    variables, attrs = read_nc(path)
    assert set(variables) == {
        "time", "tau", "avar", "avar_low", "avar_high", "window", "centre", "m", "alpha",
    }  # fmt: skip
    n_time, n_tau = result.avar.shape
    for name in ("avar", "avar_low", "avar_high"):
        dims, data, code, var_attrs = variables[name]
        assert dims == ("time", "tau") and data.shape == (n_time, n_tau) and code == "d"
        assert_same(data, getattr(result, name))
        assert var_attrs["units"] == b"(deg/s)^2"
        assert np.isnan(var_attrs["_FillValue"])
    for name in ("time", "tau"):
        assert_same(variables[name][1], getattr(result, name))
        assert variables[name][3]["units"] == b"s"
    for name, dim in (("window", "time"), ("centre", "time"), ("m", "tau"), ("alpha", "tau")):
        dims, data, code, var_attrs = variables[name]
        assert dims == (dim,) and code == "i", name  # int32: they fit
        assert_same(data, getattr(result, name))
        assert var_attrs["long_name"]
    assert b"68.3 %" in variables["avar_low"][3]["long_name"]
    assert variables["avar_high"][3]["confidence"] == pytest.approx(0.683)
    # every item of result.metadata() is a global attribute, at full precision
    for key, value in result.metadata().items():
        stored = attrs[key]
        if isinstance(value, str):
            assert stored.decode("utf-8") == value, key
        else:
            assert stored == value, key
    assert attrs["tau0"] == 0.1  # a double, not a 32-bit float
    assert attrs["Conventions"] == b"CF-1.8"
    assert attrs["source"] == f"adavar {adavar.__version__}".encode()


def test_netcdf_round_trip_with_xarray(result, tmp_path):
    path = write_surface(tmp_path / "surface.nc", result)
    with xr.open_dataset(path) as ds:
        ds.load()
    expected = result.to_xarray()
    assert ds.sizes == {"time": result.avar.shape[0], "tau": result.avar.shape[1]}
    for name in ("time", "tau", "avar", "avar_low", "avar_high", "window", "centre", "m",
                 "alpha"):  # fmt: skip
        assert_same(ds[name].values, expected[name].values)
    assert ds["avar"].attrs["units"] == "(deg/s)^2"
    assert ds["time"].attrs["units"] == "s"
    assert ds.attrs["units"] == "deg/s"
    assert ds.attrs["step"] == 3
    assert ds.attrs["window_convention"] == result.metadata()["window_convention"]
    # the NaN cells (tau beyond a third of the window) come back as NaN
    assert_same(np.isnan(ds["avar"].values), np.isnan(result.avar))


def test_netcdf_without_bounds_or_unit(bare, tmp_path):
    path = write_surface(tmp_path / "bare.nc", bare)
    variables, attrs = read_nc(path)
    assert "avar_low" not in variables and "avar_high" not in variables
    assert "units" not in variables["avar"][3]  # never guessed
    assert_same(variables["avar"][1], bare.avar)
    assert np.isnan(attrs["confidence"])
    assert attrs["units"] == b""


def test_dimensionless_unit_is_1(tmp_path):
    x = simulate.white(600, seed=5)
    res = adavar.davar(x, window=60, rate=1.0, step=10, units="", taus="octave")
    variables, _ = read_nc(write_surface(tmp_path / "frac.nc", res))
    assert variables["avar"][3]["units"] == b"1"


def test_large_indices_are_stored_as_doubles(result, tmp_path):
    shifted = dataclasses.replace(result, centre=result.centre + 2**31)
    variables, _ = read_nc(write_surface(tmp_path / "big.nc", shifted))
    _, data, code, _ = variables["centre"]
    assert code == "d"
    assert_same(data.astype(np.int64), shifted.centre)


def test_unicode_metadata(result, tmp_path):
    noted = dataclasses.replace(result, notes=("taus ≥ 1 s, µ-rad",))
    with xr.open_dataset(write_surface(tmp_path / "u.nc", noted)) as ds:
        assert ds.attrs["notes"] == "taus ≥ 1 s, µ-rad"


def test_too_large_for_netcdf_is_refused(result, tmp_path, monkeypatch):
    monkeypatch.setattr(adio, "_NETCDF_MAX_VARIABLE", 1000)
    with pytest.raises(AdavarInputError, match=r"too large for a NetCDF.*Parquet"):
        write_surface(tmp_path / "s.nc", result)
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------------------
# Parquet
# --------------------------------------------------------------------------------------


def test_parquet_round_trip_with_pandas(result, tmp_path):
    path = write_surface(tmp_path / "surface.parquet", result)
    assert path.read_bytes()[:4] == b"PAR1"
    frame = pd.read_parquet(path)
    expected = result.to_pandas()
    n_time, n_tau = result.avar.shape
    assert len(frame) == n_time * n_tau
    assert list(frame.columns) == [
        "time", "tau", "avar", "avar_low", "avar_high", "window", "centre", "m", "alpha",
    ]  # fmt: skip
    for name in expected.columns:
        assert_same(frame[name].to_numpy(), expected[name].to_numpy())
    assert_same(frame["centre"].to_numpy(), np.repeat(result.centre, n_tau))
    assert_same(frame["m"].to_numpy(), np.tile(result.m, n_time))
    # the T x M surface comes back with a pivot
    surface = frame.pivot(index="time", columns="tau", values="avar")
    assert_same(surface.index.to_numpy(), result.time)
    assert_same(surface.columns.to_numpy(), result.tau)
    assert_same(surface.to_numpy(), result.avar)
    for key, value in result.metadata().items():
        assert frame.attrs[key] == value, key


def test_parquet_schema_metadata(result, tmp_path):
    import json

    import pyarrow.parquet as pq

    schema = pq.read_schema(write_surface(tmp_path / "s.pq", result))
    meta = json.loads(schema.metadata[b"adavar"])
    assert meta["shape"] == list(result.avar.shape)
    assert meta["tau0"] == result.tau0 and meta["units"] == "deg/s"
    assert schema.field("avar").metadata[b"units"] == b"(deg/s)^2"
    assert schema.field("tau").metadata[b"units"] == b"s"


def test_parquet_without_bounds_has_json_safe_metadata(bare, tmp_path):
    frame = pd.read_parquet(write_surface(tmp_path / "b.parquet", bare))
    assert "avar_low" not in frame.columns
    assert frame.attrs["confidence"] is None  # NaN is not JSON
    assert_same(frame["avar"].to_numpy(), bare.avar.reshape(-1))


def test_parquet_without_pyarrow_names_the_fix(result, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    with pytest.raises(AdavarInputError, match="pip install pyarrow"):
        write_surface(tmp_path / "s.parquet", result)
    with pytest.raises(AdavarInputError, match="pip install pyarrow"):
        check_surface_format("parquet")
    assert list(tmp_path.iterdir()) == []
    write_surface(tmp_path / "s.nc", result)  # NetCDF needs only scipy


# --------------------------------------------------------------------------------------
# Formats, paths, atomicity
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "fmt", "magic"),
    [
        ("a.nc", None, b"CDF"),
        ("a.parquet", None, b"PAR1"),
        ("a.PQ", None, b"PAR1"),
        ("a", None, b"CDF"),
        ("a.dat", None, b"CDF"),
        ("a.dat", "parquet", b"PAR1"),
        ("a.parquet", "netcdf", b"CDF"),
    ],
)
def test_format_from_suffix_or_argument(bare, tmp_path, name, fmt, magic):
    path = write_surface(tmp_path / name, bare, fmt=fmt)
    assert path.read_bytes().startswith(magic)


def test_check_surface_format():
    assert SURFACE_FORMATS == {"nc": ".nc", "parquet": ".parquet"}
    assert check_surface_format("NetCDF") == "nc"
    assert check_surface_format(".nc") == "nc"
    assert check_surface_format("pq") == "parquet"
    with pytest.raises(AdavarInputError, match="unknown surface format 'hdf5'"):
        check_surface_format("hdf5")


def test_bad_paths(bare, tmp_path):
    with pytest.raises(AdavarInputError, match="does not exist"):
        write_surface(tmp_path / "missing" / "s.nc", bare)
    (tmp_path / "d.nc").mkdir()
    with pytest.raises(AdavarInputError, match="is a folder"):
        write_surface(tmp_path / "d.nc", bare)
    with pytest.raises(AdavarInputError, match="unknown surface format"):
        write_surface(tmp_path / "s.nc", bare, fmt="csv")


def test_replaces_only_on_success_and_leaves_no_temporary(result, bare, tmp_path, monkeypatch):
    path = tmp_path / "s.nc"
    write_surface(path, result)
    before = path.read_bytes()

    def half_written(handle, res):
        handle.write(b"CDF\x02 partial")
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(adio, "_write_netcdf", half_written)
    with pytest.raises(RuntimeError, match="disk on fire"):
        write_surface(path, bare)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["s.nc"]
    monkeypatch.undo()
    write_surface(path, bare)  # a successful write replaces it
    assert read_nc(path)[0]["avar"][1].shape == bare.avar.shape
    assert [p.name for p in tmp_path.iterdir()] == ["s.nc"]

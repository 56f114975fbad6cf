"""The rate a record's own time index gives (issue 40): pandas and xarray time axes.

``deviation``, ``davar`` and ``adaptive_davar`` take the rate of a pandas Series/DataFrame
with a DatetimeIndex or TimedeltaIndex, or of an xarray DataArray with a datetime or
timedelta coordinate, when none is given (before: 1 Hz, whatever the index said); an index
that is not evenly spaced, has gaps or repeats is an error naming the way out; a rate given
that contradicts the index is an error. Data without a time index keep the 1 Hz default,
and ``rate=None`` stays an error.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import adavar
from adavar.core.errors import AdavarInputError

N = 4000


@pytest.fixture(scope="module")
def x():
    return np.random.default_rng(7).standard_normal(N)


@pytest.fixture(scope="module")
def series(x):
    return pd.Series(x, index=pd.date_range("2024-01-01", periods=N, freq="10ms"))


def test_deviation_takes_the_rate_of_a_datetime_index(series, x):
    got = adavar.deviation(series)
    want = adavar.deviation(x, rate=100.0)
    assert got.tau0 == 0.01  # before: 1.0
    np.testing.assert_array_equal(got.tau, want.tau)
    np.testing.assert_array_equal(got.dev, want.dev)


def test_davar_and_adaptive_davar_take_it_too(series):
    assert adavar.davar(series, window=1000, step=500).tau0 == 0.01
    assert adavar.adaptive_davar(series, step=500).tau0 == 0.01


@pytest.mark.parametrize(
    "make",
    [
        lambda x: pd.Series(x, index=pd.timedelta_range(0, periods=N, freq="10ms")),
        lambda x: pd.DataFrame(
            {"gx": x}, index=pd.date_range("2024-01-01", periods=N, freq="10ms")
        ),
        # a time zone whose clocks change: the instants are evenly spaced
        lambda x: pd.Series(
            x,
            index=pd.date_range("2024-03-31 00:59:50", periods=N, freq="10ms", tz="Europe/Berlin"),
        ),
    ],
    ids=["timedelta", "dataframe", "time zone"],
)
def test_other_pandas_time_indexes(x, make):
    assert adavar.deviation(make(x)).tau0 == 0.01


def test_an_xarray_time_coordinate(x, series):
    xr = pytest.importorskip("xarray")
    da = xr.DataArray(x, dims="time", coords={"time": series.index.to_numpy()})
    assert adavar.deviation(da).tau0 == 0.01
    with pytest.raises(AdavarInputError, match="contradicts the time coordinate 'time'"):
        adavar.deviation(da, rate=50.0)


def test_a_rate_that_agrees_with_the_index_is_used(series):
    assert adavar.deviation(series, rate=100.0).tau0 == 0.01
    assert adavar.deviation(series, tau0=0.01).tau0 == 0.01


@pytest.mark.parametrize("given", [{"rate": 50.0}, {"tau0": 0.02}, {"rate": 1.0}])
def test_a_rate_that_contradicts_the_index_is_an_error(series, given):
    # before: rate=50 was used against the 100 Hz index without a word
    with pytest.raises(AdavarInputError, match="contradicts the time index of data") as info:
        adavar.deviation(series, **given)
    assert "100 Hz" in str(info.value) and "leave out rate=" in str(info.value)
    with pytest.raises(AdavarInputError, match="contradicts"):
        adavar.davar(series, window=1000, **given)


def test_gaps_in_the_index_are_an_error_with_the_way_out(series):
    holed = series.drop(series.index[100:105])
    with pytest.raises(AdavarInputError, match="has 1 gap") as info:
        adavar.deviation(holed)
    message = str(info.value)
    assert "data.asfreq('10ms')" in message and "gaps='omit'" in message
    # the way out it names works
    filled = holed.asfreq("10ms")
    got = adavar.deviation(filled, gaps="omit")
    assert got.tau0 == 0.01


def test_an_irregular_index_is_an_error_with_the_way_out(x):
    # before: read at 1 Hz without a word
    base = np.arange(N, dtype=np.int64) * 10_000_000
    jitter = np.random.default_rng(1).integers(0, 300_000, N)  # up to 3 % of 10 ms
    with pytest.raises(AdavarInputError, match="not evenly spaced") as info:
        adavar.deviation(pd.Series(x, index=pd.to_datetime(base + jitter, unit="ns")))
    assert "data.resample('10ms').mean()" in str(info.value)
    assert "np.asarray(data)" in str(info.value)


def test_jitter_within_one_percent_gives_the_mean_step(x):
    from adavar.io.sampling import index_interval

    base = np.arange(N, dtype=np.int64) * 10_000_000
    jitter = np.random.default_rng(2).integers(-40_000, 40_000, N)  # 0.4 %
    s = pd.Series(x, index=pd.to_datetime(base + jitter, unit="ns"))
    step, _ = index_interval(s)
    assert step == pytest.approx((base[-1] + jitter[-1] - jitter[0]) / (N - 1) / 1e9, rel=1e-12)


@pytest.mark.parametrize(
    ("index", "match"),
    [
        (pd.DatetimeIndex(["2024-01-01 00:00:00", "2024-01-01 00:00:01",
                           "2024-01-01 00:00:01", "2024-01-01 00:00:02"]), "repeats"),
        (pd.DatetimeIndex(["2024-01-01 00:00:00", "2024-01-01 00:00:02",
                           "2024-01-01 00:00:01", "2024-01-01 00:00:03"]), "goes back"),
        (pd.DatetimeIndex(["2024-01-01 00:00:00", None, "2024-01-01 00:00:02",
                           "2024-01-01 00:00:03"]), "missing"),
    ],
    ids=["repeats", "goes back", "NaT"],
)  # fmt: skip
def test_a_broken_index_is_an_error(index, match):
    with pytest.raises(AdavarInputError, match=match):
        adavar.deviation(pd.Series(np.arange(4.0), index=index))


def test_data_without_a_time_index_keep_the_1_hz_default(x):
    assert adavar.deviation(x).tau0 == 1.0
    assert adavar.deviation(pd.Series(x)).tau0 == 1.0  # a RangeIndex says nothing
    assert adavar.deviation(x, rate=1.0, tau0=0.5).tau0 == 0.5  # as before


def test_rate_none_is_still_an_error(series):
    with pytest.raises(AdavarInputError, match="no sampling rate"):
        adavar.deviation(series, rate=None)


def test_the_default_rate_still_reads_as_1_hz():
    import inspect

    for function in (adavar.deviation, adavar.davar, adavar.adaptive_davar):
        assert inspect.signature(function).parameters["rate"].default == 1.0

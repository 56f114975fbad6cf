"""Time stamps rounded coarser than the sampling interval are an error that names the rate,
not gaps or duplicates (an independent audit of the readers: 75 Hz written to 0.01 s read
as 100 Hz with a third of the samples invented under ``--gaps interpolate``)."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest

from adavar.core.errors import AdavarInputError
from adavar.readers.dispatch import read_record

from .cli_helpers import run


def _csv(path, t, x, fmt="%.2f"):
    np.savetxt(path, np.c_[t, x], delimiter=",", header="time,gx", comments="", fmt=[fmt, "%.6f"])
    return path


@pytest.fixture
def samples():
    return np.random.default_rng(3).standard_normal(20_000) * 0.05


@pytest.mark.parametrize("gaps", ["error", "interpolate", "split"])
def test_stamps_rounded_to_a_step_shorter_than_two_intervals_name_the_rate(tmp_path, samples, gaps):
    path = _csv(tmp_path / "r75.csv", np.arange(samples.size) / 75.0, samples)
    with pytest.raises(AdavarInputError, match=r"rounded to about 0\.01 s") as err:
        read_record(path, columns="gx", gaps=gaps)
    assert "--time-column none --rate HZ (the stamps give 75 Hz" in str(err.value)
    # a declared rate is not "contradicted by the median interval" (100 Hz): same message
    with pytest.raises(AdavarInputError, match=r"rounded to about 0\.01 s"):
        read_record(path, columns="gx", gaps=gaps, rate=75.0)


def test_stamps_rounded_to_whole_seconds_are_not_duplicates(tmp_path, samples):
    base = dt.datetime(2026, 1, 1, 12, 0, 0)
    stamps = [(base + dt.timedelta(seconds=int(i / 100))).isoformat() for i in range(5000)]
    path = tmp_path / "iso.csv"
    lines = ["time,gx"] + [f"{s},{v:.6f}" for s, v in zip(stamps, samples[:5000], strict=True)]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(AdavarInputError, match=r"4950 of 4999 time stamps repeat the one before"):
        read_record(path, columns="gx")


def test_a_single_duplicate_or_a_dropped_sample_keep_their_messages(tmp_path, samples):
    t = np.arange(samples.size) / 100.0
    duplicate = _csv(
        tmp_path / "dup.csv", np.insert(t, 5000, t[5000]), np.insert(samples, 5000, 0.0)
    )
    with pytest.raises(AdavarInputError, match="time repeats"):
        read_record(duplicate, columns="gx")
    dropped = _csv(tmp_path / "drop.csv", np.delete(t, 12_345), np.delete(samples, 12_345))
    with pytest.raises(AdavarInputError, match=r"gap of 0\.02 s"):
        read_record(dropped, columns="gx")


def test_stamps_rounded_finer_than_the_jitter_tolerance_are_read(tmp_path, samples):
    # 99.8 Hz written to the millisecond: intervals of 0.010 and 0.011 s, no gap
    rec = read_record(_csv(tmp_path / "r998.csv", np.arange(samples.size) / 99.8, samples, "%.3f"),
                      columns="gx")  # fmt: skip
    assert rec.rate == pytest.approx(99.8, rel=1e-5)  # 1 ms over 200 s


def test_the_cli_exits_2_with_the_rate(capsys, tmp_path, samples):
    path = _csv(tmp_path / "r600.csv", np.arange(samples.size) / 600.0, samples, "%.3f")
    code, out, err = run(capsys, ["avar", str(path), "--column", "gx", "--units", "deg/s",
                                  "--gaps", "interpolate"])  # fmt: skip
    assert code == 2 and out == "" and "rounded to about 0.001 s" in err
    assert "the stamps give 600 Hz" in err and err.count("\n") == 1

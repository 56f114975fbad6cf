"""Defaults that fit the record: windows in the paper's proportions of the record's length,
and a surface resolution within --max-memory."""

from __future__ import annotations

import json

import numpy as np
import pytest

from adavar import cli, simulate
from adavar.dynamic.adaptive import record_windows

from .cli_helpers import run


def test_record_windows_are_the_papers_proportions():
    assert record_windows(6000) == (600, 400, 100)  # the paper's record and windows
    assert record_windows(720_000) == (72_000, 48_000, 12_000)  # 1 h at 200 Hz
    lmax, lmin, seg = record_windows(0, 601)  # a given odd Lmax keeps its parity
    assert (lmax - lmin) % 2 == 0 and seg == 100
    assert record_windows(30)[0] == 12  # at least 12 samples


@pytest.fixture(scope="module")
def gyro(tmp_path_factory):
    x = simulate.sensor(120_000, rate=200.0, angle_random_walk=0.005, bandwidth=50.0,
                        lsb=1 / 131, seed=5)  # fmt: skip
    path = tmp_path_factory.mktemp("rec") / "gyro.npy"
    np.save(path, x)
    return path


def test_adaptive_without_window_flags_uses_the_record(capsys, gyro):
    base = ["adaptive", str(gyro), "--rate", "200", "--units", "deg/s", "--taus", "octave",
            "--step", "1000"]  # fmt: skip
    code, out, err = run(capsys, [*base, "--json"])
    assert code == 0, err
    params = json.loads(out)["parameters"]
    assert params["windows_from"] == "record"
    controller = params["controller"]
    assert (controller["lmax"], controller["lmin"], controller["l"]) == (12_000, 8_000, 2_000)
    code, out, err = run(capsys, base)
    assert code == 0, err
    assert "windows: Lmax 12000 samples (60 s), Lmin 8000, l 2000: a tenth of the record" in out
    code, out, err = run(capsys, [*base, "--lmax", "3s", "--json"])  # Lmin and l from Lmax
    assert code == 0, err
    params = json.loads(out)["parameters"]
    assert params["windows_from"] == "lmax"
    assert (params["controller"]["lmin"], params["controller"]["l"]) == (400, 100)


def test_surface_resolution_follows_the_memory_budget(capsys, gyro):
    base = ["davar", str(gyro), "--rate", "200", "--units", "deg/s", "--window", "3000",
            "--json"]  # fmt: skip
    code, out, err = run(capsys, [*base, "--max-memory", "1"])
    assert code == 0, err
    params = json.loads(out)["parameters"]
    # 1000 taus of "all" is more than the default keeps; 1 MB holds one centre in many
    assert params["taus"] == "log" and params["step"] > 1
    assert "--max-memory 1 MB" in params["resolution"]
    cells = 120_000 / params["step"] * len(json.loads(out)["tau"]) * 32
    assert cells <= 1.05 * 2**20
    code, out, err = run(capsys, [*base, "--taus", "octave", "--step", "7"])
    assert code == 0, err
    params = json.loads(out)["parameters"]
    assert (params["taus"], params["step"], params["resolution"]) == ("octave", 7, None)


def test_compare_keeps_the_papers_windows():
    args = cli.build_parser().parse_args(["compare", "--scenario", "1"])
    assert (args.lmax, args.lmin, args.segment) == (600, 400, 100)


def test_s_quantile_draws_in_bounded_batches(monkeypatch):
    """The S simulation behind calibrated thresholds: batches give the numbers of one array."""
    from scipy import stats

    from adavar.dynamic import thresholds

    rng = np.random.default_rng(4)
    x = rng.standard_normal((500, 300))
    kx = stats.kurtosis(x, axis=1, fisher=False)
    kc = stats.kurtosis(x[:, :250], axis=1, fisher=False)
    whole = float(np.quantile((kx - kc) / kx, 0.99))
    monkeypatch.setattr(thresholds, "_DRAW_BATCH", 7 * 300 + 5)  # 7 rows a batch
    assert thresholds._s_quantile(0.99, 300, 50, 500, 4) == whole


def test_compare_refuses_what_does_not_fit_in_memory(monkeypatch, capsys, tmp_path):
    """Before any work: a one-line error and exit 2, not the kernel's OOM killer."""
    import adavar
    from adavar.io import sources

    from .cli_helpers import assert_one_line_error

    x = simulate.white(6000, seed=1)
    monkeypatch.setattr(sources, "available_memory", lambda: 1 << 20)  # 1 MiB free
    with pytest.raises(adavar.AdavarInputError, match=r"keeps .* GiB of surfaces"):
        adavar.compare(x, taus="all")
    path = tmp_path / "x.npy"
    np.save(path, x)
    code, out, err = run(capsys, ["compare", str(path), "--rate", "1", "--units", "deg/s"])
    assert_one_line_error(code, out, err, "of surfaces", "--taus octave")
    monkeypatch.undo()
    assert adavar.compare(x, taus="octave").methods  # with the memory there, it runs

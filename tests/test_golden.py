"""Golden outputs of the command line: the keys, strings and numbers of ``--json`` and the
CSV columns stay as they are unless a change means them to (regenerate with
``ADAVAR_REGENERATE_GOLDEN=1 python -m pytest tests/test_golden.py`` and review the diff)."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

from adavar import simulate

from .cli_helpers import run

GOLDEN = Path(__file__).parent / "golden"
REGENERATE = os.environ.get("ADAVAR_REGENERATE_GOLDEN") == "1"


@pytest.fixture(scope="module")
def record(tmp_path_factory) -> Path:
    """20 minutes of a 100 Hz MEMS gyro (filter, LSB), seeded: the same bytes everywhere."""
    x = simulate.sensor(120_000, rate=100.0, angle_random_walk=0.005, bias_instability=0.002,
                        rate_random_walk=2e-4, bandwidth=20.0, lsb=1 / 262.4, seed=12)  # fmt: skip
    path = tmp_path_factory.mktemp("golden") / "gyro.npy"
    np.save(path, x)
    return path


def _same(got, want, where="$"):
    """Structure and strings exact, numbers to 1e-9 relative (thread counts move the last bit)."""
    if isinstance(want, dict):
        assert isinstance(got, dict) and set(got) == set(want), (where, set(got) ^ set(want))
        for key in want:
            _same(got[key], want[key], f"{where}.{key}")
    elif isinstance(want, list):
        assert isinstance(got, list) and len(got) == len(want), where
        for k, (g, w) in enumerate(zip(got, want, strict=True)):
            _same(g, w, f"{where}[{k}]")
    elif isinstance(want, float) and not isinstance(want, bool):
        assert isinstance(got, (int, float)), where
        assert math.isclose(got, want, rel_tol=1e-9, abs_tol=1e-300), (where, got, want)
    else:
        assert got == want, (where, got, want)


COMMANDS = {
    "avar_fit": ["avar", "{record}", "--rate", "100", "--units", "deg/s", "--fit", "--json"],
    "avar_wls": ["avar", "{record}", "--rate", "100", "--units", "deg/s", "--fit", "--json",
                 "--fit-method", "wls"],
    "davar": ["davar", "{record}", "--rate", "100", "--units", "deg/s", "--window", "6000",
              "--taus", "octave", "--step", "2000", "--json"],
    "adaptive": ["adaptive", "{record}", "--rate", "100", "--units", "deg/s", "--lmax", "600",
                 "--lmin", "400", "--taus", "octave", "--step", "4000", "--json"],
}  # fmt: skip
# what varies from run to run or machine to machine
_VOLATILE = ("elapsed_s", "path", "file", "adavar_version", "finished", "worker")


def _scrub(obj):
    if isinstance(obj, dict):
        return {k: _scrub(v) for k, v in obj.items() if k not in _VOLATILE}
    if isinstance(obj, list):
        return [_scrub(v) for v in obj]
    return obj


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_json_output_is_the_golden_one(capsys, record, name):
    argv = [a.format(record=record) for a in COMMANDS[name]]
    code, out, err = run(capsys, argv)
    assert code == 0, err
    got = _scrub(json.loads(out))
    path = GOLDEN / f"{name}.json"
    if REGENERATE:
        path.write_text(json.dumps(got, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    _same(got, json.loads(path.read_text(encoding="utf-8")))


def test_deviation_csv_columns_are_the_golden_ones(capsys, record, tmp_path):
    out = tmp_path / "out"
    code, _, err = run(capsys, ["avar", str(record), "--rate", "100", "--units", "deg/s",
                                "--fit", "--out", str(out)])  # fmt: skip
    assert code == 0, err
    lines = (out / "deviation.csv").read_text(encoding="utf-8").splitlines()
    assert lines[0] == "tau_s,n,m,alpha,edf,dev,dev_low,dev_high"  # plain CSV: header first
    assert sorted(p.name for p in out.iterdir()) == [
        ".adavar-output",
        "deviation.csv",
        "deviation.png",
        "deviation.svg",
        "result.json",
    ]

"""Stable32's published results on real clock data, from allantools' source distribution.

The data are not part of this repository (data fetched from outside is never committed).
:func:`stable32_root` finds them: the folder named by ``ADAVAR_STABLE32_DATA`` (an unpacked
``allantools-2024.6``), else a copy under ``.cache/stable32/`` (gitignored), downloaded with
``python -m pip download --no-deps --no-binary :all: allantools==2024.6`` and unpacked. If
neither works the tests skip, unless ``ADAVAR_REQUIRE_STABLE32=1``: then they fail.
"""

from __future__ import annotations

import functools
import gzip
import os
import subprocess
import sys
import tarfile
from pathlib import Path

import numpy as np
import pytest

VERSION = "allantools-2024.6"
CACHE = Path(__file__).resolve().parent.parent / ".cache" / "stable32"

_ALL = ("adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev")

#: (data file, data type, scale, {stat: result table}) per record; paths below ``tests/``
RECORDS: dict[str, tuple[str, str, float, dict[str, str]]] = {
    "Cs5071A": (
        "Cs5071A/5071A_phase.txt.gz",
        "phase",
        1.0,
        {s: f"Cs5071A/{s}_decade.txt" for s in _ALL},
    ),
    "Keysight53230A": (  # its adev table has no bounds
        "Keysight53230A_ti_noise_floor/tic_phase.txt",
        "phase",
        1.0,
        {s: f"Keysight53230A_ti_noise_floor/tic_{s}.txt" for s in _ALL[1:]},
    ),
    "gps": (
        "gps/gps_1pps_phase_data.txt.gz",
        "phase",
        1.0,
        {s: f"gps/stable32_{s.upper()}_{'decade' if s == 'adev' else 'octave'}.txt" for s in _ALL},
    ),
    # frequency of a 10 MHz OCXO in Hz; Stable32 read it as a ratio (average 1.000000)
    "ocxo": ("ocxo/ocxo_frequency.txt", "rate", 1e-7, {s: f"ocxo/{s}_octave.txt" for s in _ALL}),
    "phasedat": (
        "phasedat/PHASE.DAT",
        "phase",
        1.0,
        {s: f"phasedat/phase_dat_{s}_octave.txt" for s in _ALL},
    ),
    "pink": (
        "pink_frequency/pink_frequency.txt",
        "rate",
        1.0,
        {"oadev": "pink_frequency/s32_oadev_octave.txt"},
    ),
}


def _unavailable(reason: str) -> None:
    if os.environ.get("ADAVAR_REQUIRE_STABLE32") == "1":
        pytest.fail(f"Stable32 data required (ADAVAR_REQUIRE_STABLE32=1) but {reason}")
    pytest.skip(f"Stable32 data unavailable: {reason}")


def _download() -> Path:
    root = CACHE / VERSION
    if (root / "tests").is_dir():
        return root
    CACHE.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--no-binary", ":all:",
           "allantools==2024.6", "-d", str(CACHE)]  # fmt: skip
    subprocess.run(cmd, check=True, capture_output=True, timeout=300)
    with tarfile.open(CACHE / f"{VERSION}.tar.gz") as tar:
        tar.extractall(CACHE, filter="data")
    return root


def stable32_root() -> Path:
    """The unpacked allantools sdist folder (containing ``tests/``); skips or fails if none."""
    given = os.environ.get("ADAVAR_STABLE32_DATA")
    if given:
        root = Path(given)
        if not (root / "tests").is_dir():
            _unavailable(f"ADAVAR_STABLE32_DATA={given} has no tests/ folder")
        return root
    try:
        return _download()
    except Exception as exc:  # no network, no pip, a broken archive: say which
        _unavailable(f"download of {VERSION} failed ({type(exc).__name__}: {exc})")
    raise AssertionError("unreachable")  # pragma: no cover


@functools.cache
def read_data(path: Path) -> np.ndarray:
    """One number per line, ``#`` comments skipped (gzip by extension); read once per
    process (tens of tests read the same records), returned read-only."""
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt", encoding="latin-1") as f:
        values = np.array([float(v) for v in f if v.strip() and not v.startswith("#")])
    values.flags.writeable = False
    return values


def read_table(path: Path) -> np.ndarray:
    """Stable32 result rows: AF, tau, #, alpha, min sigma, sigma, max sigma (7 columns)."""
    rows = []
    with open(path, encoding="latin-1") as f:
        for line in f:
            parts = line.split()
            if not line.startswith("#") and len(parts) == 7:
                rows.append([float(v) for v in parts])
    return np.array(rows)

"""Records larger than memory: time and peak resident memory of the CLI on a big ``.npy``.

Writes an ``N``-sample float32 ``.npy`` (default 2e8 samples, 800 MB) of unit white noise,
then runs, each in a fresh process under ``/usr/bin/time -v``:

- ``adavar davar FILE --window 6001 --step 100000 --taus 1,10,100,1000`` (issue 6 target:
  peak RSS below 1 GB), ``adavar adaptive`` likewise (paper window 600/400, and
  6001/4001), ``adavar avar --fit``;
- the peer measured in the same run: the same library call on the record loaded into
  memory (``np.load`` without memory map, then the in-memory path), and for the Allan
  deviation ``allantools.oadev`` on the loaded record (``--allantools``; needs about
  10x the record in memory).

Prints wall time and peak RSS of each, and the ratios out-of-core / in-memory.

Usage: python benchmarks/bench_out_of_core.py [--samples N] [--keep] [--allantools]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe

ADAVAR = [sys.executable, "-m", "adavar.cli"]
TIME = "/usr/bin/time"


def measure(cmd: list[str]) -> tuple[float, float]:
    """(wall seconds, peak RSS in MB) of ``cmd`` in a fresh process."""
    run = subprocess.run([TIME, "-v", *cmd], capture_output=True, text=True, check=False)
    if run.returncode != 0:
        raise SystemExit(f"failed ({run.returncode}): {' '.join(cmd)}\n{run.stderr[-2000:]}")
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", run.stderr)
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", run.stderr)
    parts = [float(p) for p in wall.group(1).split(":")]
    seconds = sum(p * 60**k for k, p in enumerate(reversed(parts)))
    return seconds, int(rss.group(1)) / 1024


def in_memory(code: str) -> list[str]:
    """A fresh Python process that loads the record whole, then runs ``code``."""
    return [sys.executable, "-c", "import numpy as np, adavar\n"
            "x = np.array(np.load(PATH), dtype=np.float64)\n" + code]  # fmt: skip


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=float, default=2e8)
    ap.add_argument("--keep", action="store_true", help="keep the .npy file")
    ap.add_argument("--allantools", action="store_true", help="also time allantools.oadev")
    args = ap.parse_args()
    n = int(args.samples)
    if not os.path.exists(TIME):
        raise SystemExit("needs GNU time at /usr/bin/time (Debian package 'time')")

    folder = Path(tempfile.mkdtemp(prefix="adavar-ooc-"))
    path = folder / "gyro.npy"
    out = np.lib.format.open_memmap(path, mode="w+", dtype=np.float32, shape=(n,))
    rng = np.random.default_rng(0)
    for a in range(0, n, 10_000_000):
        b = min(n, a + 10_000_000)
        out[a:b] = rng.standard_normal(b - a, dtype=np.float32)
    out.flush()
    del out
    print(describe())
    print(f"record: {n:.3g} float32 samples, {path.stat().st_size / 1e6:.0f} MB .npy "
          "(in the page cache: written just before)")  # fmt: skip
    common = ["--rate", "1", "--units", "deg/s", "--force"]
    taus = "[1, 10, 100, 1000]"
    cases = [
        ("davar window 6001",
         ["davar", str(path), "--window", "6001", "--step", "100000", "--taus",
          "1,10,100,1000", "--out", str(folder / "d")],
         f"adavar.davar(x, window=6001, step=100000, taus={taus})"),
        ("adaptive 600/400",
         ["adaptive", str(path), "--lmax", "600", "--lmin", "400", "--step", "100000",
          "--taus", "1,10,100,1000", "--out", str(folder / "a")],
         f"adavar.adaptive_davar(x, lmax=600, lmin=400, step=100000, taus={taus})"),
        ("adaptive 6001/4001",
         ["adaptive", str(path), "--lmax", "6001", "--lmin", "4001", "--step", "100000",
          "--taus", "1,10,100,1000", "--out", str(folder / "b")],
         f"adavar.adaptive_davar(x, lmax=6001, lmin=4001, step=100000, taus={taus})"),
        ("avar --fit (oadev)",
         ["avar", str(path), "--fit", "--out", str(folder / "v")],
         "adavar.fit_noise(adavar.deviation(x))"),
    ]  # fmt: skip
    rows = []
    for name, cli, lib in cases:
        t_ooc, m_ooc = measure([*ADAVAR, *cli, *common])
        t_mem, m_mem = measure([c.replace("PATH", repr(str(path))) for c in in_memory(lib)])
        rows.append((name, t_ooc, m_ooc, t_mem, m_mem))
        print(f"{name:22s} out of core (CLI, figures included): {t_ooc:6.1f} s {m_ooc:6.0f} MB"
              f" | in memory (library only): {t_mem:6.1f} s {m_mem:6.0f} MB"
              f" | time x{t_ooc / t_mem:.2f}, memory x{m_ooc / m_mem:.3f}")  # fmt: skip
    if args.allantools:
        code = "import allantools\nallantools.oadev(x, rate=1.0, data_type='freq', taus='octave')"
        t_at, m_at = measure([c.replace("PATH", repr(str(path))) for c in in_memory(code)])
        ooc = next(r for r in rows if r[0].startswith("avar"))
        print(f"allantools.oadev in memory: {t_at:.1f} s {m_at:.0f} MB | adavar avar out of "
              f"core: time x{ooc[1] / t_at:.2f}, memory x{ooc[2] / m_at:.3f}")  # fmt: skip
    if not args.keep:
        for p in sorted(folder.rglob("*"), reverse=True):
            p.unlink() if p.is_file() else p.rmdir()
        folder.rmdir()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

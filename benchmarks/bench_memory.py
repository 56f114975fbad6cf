"""Peak resident memory of every command against the sizes of its input and output.

Each command runs in a fresh process on a simulated 200 Hz MEMS gyro log (three channels
with ARW, bias instability, rate random walk and quantisation, a 50 Hz second-order
Butterworth front end and a 1e-4 deg/s LSB; ``kalibr`` reads three accelerometer channels
too), written as CSV with a time column. Printed per command and record length:

* ``peak``: the command's peak RSS (``os.wait4``; for ``demo`` the larger of its two
  processes);
* ``imports``: the peak RSS of a process that only imports the modules the command had
  loaded when it finished (so the numbers below are the command's data, not its code);
* ``input``: the analysed samples as float64 (channels x samples x 8 bytes);
* ``output``: the bytes the command wrote (folder, HTML, YAML or CSV);
* ``/input``: ``(peak - imports) / input``; ``/output``: ``(peak - imports) / output``;
* ``slope``: between the two record lengths, the extra peak per extra input byte: what a
  command costs per sample of a long record (about 1-5 for "a few copies of the input"; a
  command that holds surfaces grows with those instead).

Run: ``python benchmarks/bench_memory.py [--minutes 4,12] [--only davar,report]``
(under 3 minutes with the defaults on 2 cores; ``--minutes 30,120`` for the numbers in
docs/benchmarks.md, about 12 minutes).

``--large 2e8,1e9``: the records that do not fit comfortably in memory (issue 42): a
float32 ``.npy`` of that many samples (800 MB, 4 GB; written piece by piece in the
temporary folder), analysed with no flag by ``davar`` (the issue's command: window 6001,
step 100000, four taus), ``avar`` (octave taus), ``adaptive`` (the paper's 600/400 windows,
step 100000) and ``report``; printed: peak RSS and ``peak / (input file + output)``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe

RATE = 200.0
#: Record lengths (minutes) by default: the whole run in under 3 minutes on 2 cores.
DEFAULT_MINUTES = "4,12"
UNITS = ["--rate", "200", "--units", "deg/s"]

# run the command in-process through adavar.cli.entry.main, then list the modules it loaded
_DRIVER = (
    "import sys\n"
    "from adavar.cli.entry import main\n"
    "code = main(sys.argv[2:])\n"
    "open(sys.argv[1], 'w').write('\\n'.join(sorted(sys.modules)))\n"
    "sys.exit(code)\n"
)
_IMPORTER = (
    "import importlib, sys\n"
    "for name in open(sys.argv[1]).read().split():\n"
    "    if name.startswith('__') or name == 'this':\n"
    "        continue\n"
    "    try:\n"
    "        importlib.import_module(name)\n"
    "    except Exception:\n"
    "        pass\n"
)


# a small parent that starts the command and reports its peak: a child started from this
# (larger) process would inherit this process's peak as its own (Linux keeps the high-water
# mark of the memory it replaces at exec)
_LAUNCHER = (
    "import os, subprocess, sys\n"
    "proc = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL)\n"
    "_, status, usage = os.wait4(proc.pid, 0)\n"
    "print(usage.ru_maxrss, os.waitstatus_to_exitcode(status))\n"
)


def _peak_mb(cmd: list[str], cwd: str) -> tuple[float, float, int, str]:
    """Peak RSS (MB, the largest of the process and its descendants), seconds, exit code
    and the last line of stderr of ``cmd``."""
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-S", "-c", _LAUNCHER, *cmd], cwd=cwd,
                          capture_output=True, text=True, check=True)  # fmt: skip
    wall = time.perf_counter() - start
    peak, code = done.stdout.split()
    tail = done.stderr.strip().splitlines()[-1:]
    return int(peak) / 1024.0, wall, int(code), "".join(tail)


def _size(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def make_records(folder: Path, minutes: float, seed: int = 1) -> dict[str, Path]:
    """The gyro CSV (time + gx, gy, gz), a copy for ``batch`` and a six-axis IMU CSV."""
    from adavar.simulate import sensor

    n = round(minutes * 60 * RATE)
    gyro = dict(rate=RATE, angle_random_walk=0.005, bias_instability=0.002,
                rate_random_walk=1e-4, quantization=1e-5, bandwidth=50.0, lsb=1e-4)  # fmt: skip
    accel = dict(rate=RATE, angle_random_walk=0.002, rate_random_walk=1e-3)
    cols = [sensor(n, seed=seed + k, **gyro) for k in range(3)]
    cols += [sensor(n, seed=seed + k, **accel) for k in range(3, 6)]
    cols[5] += 9.81
    t = np.arange(n) / RATE
    paths = {"gyro": folder / "gyro.csv", "gyro2": folder / "gyro2.csv", "imu": folder / "imu.csv"}
    for key, k, head in (("gyro", 3, "time,gx,gy,gz"), ("imu", 6, "time,gx,gy,gz,ax,ay,az")):
        np.savetxt(paths[key], np.column_stack([t, *cols[:k]]), delimiter=",", fmt="%.9g",
                   header=head, comments="")  # fmt: skip
    paths["gyro2"].write_bytes(paths["gyro"].read_bytes())
    return paths


#: Label -> (arguments, output name, channels analysed); GYRO, GYRO2, IMU, N: the records
#: and the samples of one channel.
COMMANDS = {
    "avar": ("avar GYRO --column gx,gy,gz --out out", "out", 3),
    "davar --window 60s": ("davar GYRO --column gx,gy,gz --window 60s --out out", "out", 3),
    "adaptive": ("adaptive GYRO --column gx,gy,gz --out out", "out", 3),
    "compare (gz)": ("compare GYRO --column gz --out out", "out", 1),
    "report": ("report GYRO --column gx,gy,gz -o out.html", "out.html", 3),
    "report --adaptive": ("report GYRO --column gx,gy,gz --adaptive -o out.html", "out.html", 3),
    "kalibr": ("kalibr IMU --gyro gx,gy,gz --accel ax,ay,az --gyro-units deg/s --accel-units "
               "m/s^2 --time-column time --pinned bound -o imu.yaml", "imu.yaml", 6),
    "batch (2 files, gz)": ("batch GYRO GYRO2 --column gz --out out", "out", 2),
    "batch --adaptive (2 files, gz)": ("batch GYRO GYRO2 --column gz --adaptive --out out",
                                       "out", 2),
    "monitor (gz)": ("monitor GYRO --column 3 --idle-timeout 0.5", "out", 1),
    "simulate": ("simulate -o sim.csv --n N --rate 200 --arw 0.005 --bias-instability 0.002 "
                 "--rrw 1e-4 --bandwidth 50 --lsb 1e-4", "sim.csv", 1),
    "demo": ("demo --out out", "out", 0),
}  # fmt: skip


def commands(paths: dict[str, Path], n: int) -> dict[str, tuple[list[str], str, int]]:
    """Label -> (arguments, output name, analysed float64 values)."""
    values = {"GYRO": str(paths["gyro"]), "GYRO2": str(paths["gyro2"]),
              "IMU": str(paths["imu"]), "N": str(n)}  # fmt: skip
    out = {}
    for label, (text, written, channels) in COMMANDS.items():
        args = [values.get(word, word) for word in text.split()]
        if args[0] not in ("simulate", "demo", "kalibr"):
            args += UNITS
        out[label] = (args, written, channels * n)
    return out


def measure(minutes: list[float], only: set[str] | None) -> list[dict]:
    """Every command at every record length, in fresh processes one at a time."""
    rows = []
    bases: dict[str, float] = {}
    for m in minutes:
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            n = round(m * 60 * RATE)
            paths = make_records(folder, m)
            for label, (args, out, values) in commands(paths, n).items():
                if only and label.split()[0] not in only:
                    continue
                if label == "demo" and m != minutes[0]:
                    continue  # its input does not change
                work = folder / "work"
                work.mkdir()
                mods = folder / "modules.txt"
                peak, wall, code, err = _peak_mb([sys.executable, "-c", _DRIVER, str(mods),
                                                  *args], str(work))  # fmt: skip
                base = bases.get(label, np.nan)  # the same modules at every length
                if np.isnan(base) and mods.exists():
                    base, _, _, _ = _peak_mb([sys.executable, "-c", _IMPORTER, str(mods)],
                                             str(work))  # fmt: skip
                    bases[label] = base
                written = _size(work / out) if (work / out).exists() else 0
                rows.append(dict(command=label, minutes=m, input=values * 8.0, output=written,
                                 peak=peak, base=base, wall=wall, code=code, err=err))  # fmt: skip
                subprocess.run(["rm", "-rf", str(work)], check=True)
                mods.unlink(missing_ok=True)
                print(_line(rows[-1], None), flush=True, file=sys.stderr)
    return rows


def _line(r: dict, slope: float | None) -> str:
    mb = 2**20
    data = (r["peak"] - r["base"]) * mb
    per_in = f"{data / r['input']:.1f}" if r["input"] else "-"
    per_out = f"{data / r['output']:.1f}" if r["output"] else "-"
    note = "" if r["code"] == 0 else f" (exit {r['code']}: {r['err'][:80]})"
    grows = "-" if slope is None else f"{slope:.1f}"
    return (f"| {r['command']} | {r['minutes']:g} min | {r['input'] / mb:.1f} MB | "
            f"{r['output'] / mb:.1f} MB | {r['peak']:.0f} MB | {r['base']:.0f} MB | {per_in} | "
            f"{per_out} | {grows} | {r['wall']:.1f} s{note} |")  # fmt: skip


#: the large-record commands (issue 42): arguments after the file, output name
LARGE = {
    "davar": ("davar BIG --rate 1 --units deg/s --window 6001 --step 100000 "
              "--taus 1,10,100,1000 --out out", "out"),
    "avar": ("avar BIG --rate 1 --units deg/s --taus octave --out out", "out"),
    "adaptive": ("adaptive BIG --rate 1 --units deg/s --lmax 600 --lmin 400 --step 100000 "
                 "--taus 1,10,100 --out out", "out"),
    "report": ("report BIG --rate 1 --units deg/s -o out.html", "out.html"),
    "report --window": ("report BIG --rate 1 --units deg/s --window 6001 --step 100000 "
                        "-o out.html", "out.html"),
    "report --adaptive": ("report BIG --rate 1 --units deg/s --adaptive --lmax 600 --lmin 400 "
                          "--step 100000 -o out.html", "out.html"),
    "compare": ("compare BIG --rate 1 --units deg/s --lmax 600 --lmin 400 --taus octave "
                "--out out --figures none", "out"),
}  # fmt: skip


def write_large(path: Path, n: int, seed: int = 7) -> None:
    """``n`` float32 samples of white noise as ``.npy``, written a piece at a time."""
    out = np.lib.format.open_memmap(path, mode="w+", dtype=np.float32, shape=(n,))
    rng = np.random.default_rng(seed)
    piece = 1 << 24
    for a in range(0, n, piece):
        b = min(n, a + piece)
        out[a:b] = rng.standard_normal(b - a, dtype=np.float32)
    out.flush()
    del out


def measure_large(sizes: list[int], only: set[str] | None = None) -> None:
    """Peak RSS of each :data:`LARGE` command on float32 files of ``sizes`` samples."""
    mb = 2**20
    print("| command | samples | input file | output | peak | peak / (input + output) | wall |"
          "\n|---|---|---|---|---|---|---|")  # fmt: skip
    for n in sizes:
        with tempfile.TemporaryDirectory(dir=Path.cwd()) as tmp:  # the disk, not a tmpfs
            folder = Path(tmp)
            big = folder / "big.npy"
            write_large(big, n)
            size = big.stat().st_size
            for label, (text, written) in LARGE.items():
                if only and label not in only:
                    continue
                work = folder / "work"
                work.mkdir()
                args = [str(big) if w == "BIG" else w for w in text.split()]
                command = [str(Path(sys.executable).parent / "adavar"), *args]
                peak, wall, code, err = _peak_mb(command, str(work))
                out = _size(work / written) if (work / written).exists() else 0
                note = "" if code == 0 else f" (exit {code}: {err[:80]})"
                print(f"| {label} | {n:.3g} | {size / mb:.0f} MB | {out / mb:.1f} MB | "
                      f"{peak:.0f} MB | {peak * mb / (size + out):.2f} | {wall:.0f} s{note} |",
                      flush=True)  # fmt: skip
                subprocess.run(["rm", "-rf", str(work)], check=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", default=DEFAULT_MINUTES,
                        help=f"record lengths, comma-separated ({DEFAULT_MINUTES})")  # fmt: skip
    parser.add_argument("--only", help="commands to run, comma-separated (e.g. davar,report)")
    parser.add_argument("--large", help="float32 .npy records of these many samples instead "
                        "(e.g. 2e8,1e9: 0.8 and 4 GB on disk)")  # fmt: skip
    args = parser.parse_args()
    if args.large:
        print(f"machine: {describe()}", flush=True)
        only = set(args.only.split(",")) if args.only else None
        measure_large([int(float(v)) for v in args.large.split(",")], only)
        return
    minutes = [float(v) for v in args.minutes.split(",")]
    only = set(args.only.split(",")) if args.only else None
    print(f"machine: {describe()}", flush=True)
    rows = measure(minutes, only)
    print("| command | record | input | output | peak | imports | /input | /output | slope "
          "| wall |\n|---|---|---|---|---|---|---|---|---|---|")  # fmt: skip
    for r in rows:
        same = [q for q in rows if q["command"] == r["command"]]
        slope = None
        if r is same[-1] and len(same) > 1 and same[-1]["input"] > same[0]["input"]:
            slope = ((same[-1]["peak"] - same[0]["peak"]) * 2**20
                     / (same[-1]["input"] - same[0]["input"]))  # fmt: skip
        print(_line(r, slope))


if __name__ == "__main__":
    main()

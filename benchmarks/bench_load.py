"""Start-up, first run, text input and kernels on a busy machine, each against its peer.

* start-up: ``import adavar`` and ``adavar --help`` (fresh processes, best of 5);
* first run: ``adavar demo`` with an empty Numba cache directory, then warm, then warm with
  another process busy on one core; on its default two processes and on one;
* text input: a 720k-row, 5-column CSV through adavar's reader and ``pandas.read_csv``;
* memory: peak resident memory of ``avar``, ``davar``, ``adaptive`` and ``report`` on one
  hour at 200 Hz, against the sizes of the input and of what each writes;
* kernels: the default ``deviation`` (OADEV with intervals) against ``allantools.oadev``
  (without intervals) at N = 1e3 .. 1e7 (``--max-n``), quiet and with another process
  busy on one core, on Numba's default threads and on one (``ADAVAR_THREADS=1``);
* threaded kernels (``--only threaded``): a DAVAR surface, the adaptive schedule, the
  record-form kurtosis contribution and the noise fit of every window, on one hour of a
  simulated MEMS gyro at 200 Hz (50 Hz bandwidth, quantised), in the same four settings;
  and (``--only first-large``) the same calls on 20,000 samples and then on the hour, with
  an empty Numba cache: the first run of a user whose record is large (it compiles the
  kernels' paths for small and for large inputs);
* cold and warm (``--only cold-warm [--baseline OTHER/src]``): ``adavar avar --fit`` on
  an hour at 100 Hz and ``adavar demo``, with an empty Numba cache, warm, and after
  ``adavar precompile``; the baseline tree (the previous main) in the same run.

Run: ``python benchmarks/bench_load.py [--max-n 10000000] [--skip-demo]
[--only memory|threaded|first-large|cold-warm] [--baseline SRC]``.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from _machine import describe, speed_probe


def _best(cmd: list[str], repeats: int = 5, env: dict | None = None) -> float:
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True, env=env)
        best = min(best, time.perf_counter() - start)
    return best


def startup() -> list[str]:
    py = sys.executable
    bare = _best([py, "-c", "pass"])
    imp = _best([py, "-c", "import adavar"])
    numpy = _best([py, "-c", "import numpy"])
    helptime = _best([py, "-m", "adavar.cli", "--help"])
    return [
        f"| python -c pass | {bare:.3f} s |",
        f"| python -c 'import numpy' (peer) | {numpy:.3f} s |",
        f"| python -c 'import adavar' | {imp:.3f} s (target 0.3 s) |",
        f"| adavar --help | {helptime:.3f} s (target 0.3 s) |",
    ]


def first_run() -> list[str]:
    """``adavar demo`` cold and warm, on its default two processes and on one (``--workers
    1``), and warm with another process busy on one core."""
    lines = []
    for workers in ("2", "1"):
        with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as out:
            env = {**os.environ, "NUMBA_CACHE_DIR": cache}
            cmd = [sys.executable, "-m", "adavar.cli", "demo", "--out", f"{out}/d", "--force",
                   "--workers", workers]  # fmt: skip
            start = time.perf_counter()
            subprocess.run(cmd, check=True, capture_output=True, env=env)
            cold = time.perf_counter() - start
            warm = _best(cmd, repeats=3, env=env)
            stop = mp.Event()
            spinner = mp.Process(target=_spin, args=(stop,))
            spinner.start()
            try:
                busy = _best(cmd, repeats=2, env=env)
            finally:
                stop.set()
                spinner.join()
        lines += [
            f"| adavar demo --workers {workers}, empty Numba cache | {cold:.1f} s (target 15 s) |",
            f"| adavar demo --workers {workers}, warm | {warm:.1f} s (target 4 s) |",
            f"| adavar demo --workers {workers}, warm, one core busy | {busy:.1f} s |",
        ]
    return lines


def text_input() -> list[str]:
    import pandas as pd

    from adavar.readers import read_record

    rng = np.random.default_rng(0)
    n = 720_000
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "imu.csv")
        cols = rng.standard_normal((n, 4))
        t = np.arange(n) / 200.0
        np.savetxt(path, np.column_stack([t, cols]), delimiter=",", fmt="%.9g",
                   header="time,gx,gy,gz,temp", comments="")  # fmt: skip
        ours, theirs = np.inf, np.inf
        for _ in range(3):
            start = time.perf_counter()
            read_record(path, columns=["gx", "gy", "gz"], time_column="time")
            ours = min(ours, time.perf_counter() - start)
            start = time.perf_counter()
            pd.read_csv(path)
            theirs = min(theirs, time.perf_counter() - start)
    return [f"| read 720k x 5 CSV: adavar | {ours:.3f} s ({ours / theirs:.2f}x pandas) |",
            f"| pandas.read_csv (peer) | {theirs:.3f} s |"]  # fmt: skip


def _peak_rss_mb(cmd: list[str]) -> float:
    """Peak resident memory of ``cmd`` (MB), read in a fresh parent so no other child counts."""
    code = ("import resource, subprocess, sys; subprocess.run(sys.argv[1:], check=True, "
            "capture_output=True); "
            "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")  # fmt: skip
    done = subprocess.run([sys.executable, "-c", code, *cmd], capture_output=True, text=True,
                          check=True)  # fmt: skip
    return int(done.stdout.split()[-1]) / 1024.0


def _folder_mb(path: str) -> float:
    total = 0
    for root, _, files in os.walk(path):
        total += sum(os.path.getsize(os.path.join(root, f)) for f in files)
    return total / 2**20


def memory() -> list[str]:
    """Peak memory of every command on one hour at 200 Hz, against input and output size."""
    rng = np.random.default_rng(4)
    n = 720_000
    lines = []
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "gyro.csv")
        np.savetxt(path, rng.standard_normal(n) * 0.01, fmt="%.9g", header="gz", comments="")
        cli = [sys.executable, "-m", "adavar.cli"]
        imports = "import adavar.cli, adavar.dynamic.surface, adavar.output.plots"
        base = _peak_rss_mb([sys.executable, "-c", imports])
        runs = {
            "avar --taus all": ["avar", path, "--rate", "200", "--units", "deg/s", "--taus", "all"],
            "davar (window 60 s)": ["davar", path, "--rate", "200", "--units", "deg/s",
                                    "--window", "12000"],
            "adaptive": ["adaptive", path, "--rate", "200", "--units", "deg/s"],
            "report": ["report", path, "--rate", "200", "--units", "deg/s"],
        }  # fmt: skip
        input_mb = n * 8 / 2**20
        for label, args in runs.items():
            out = os.path.join(tmp, label.split()[0])
            flag = ["-o", out + ".html"] if args[0] == "report" else ["--out", out]
            peak = _peak_rss_mb([*cli, *args, *flag])
            written = (
                _folder_mb(out) if os.path.isdir(out) else os.path.getsize(out + ".html") / 2**20
            )
            ratio = (peak - base) / (input_mb + written)
            lines.append(f"| {label}, 720k samples | peak {peak:.0f} MB (imports {base:.0f} MB) | "
                         f"input {input_mb:.1f} MB, output {written:.1f} MB: "
                         f"(peak - imports) / (input + output) = {ratio:.1f} |")  # fmt: skip
    return lines


def _spin(stop: mp.Event) -> None:  # type: ignore[valid-type]
    while not stop.is_set():
        pass


def _kernel_times(max_n: int) -> dict[int, tuple[float, float]]:
    import adavar

    try:
        import allantools
    except ImportError:
        allantools = None
    out = {}
    n = 1000
    while n <= max_n:
        x = np.random.default_rng(1).standard_normal(n)
        adavar.deviation(x, rate=1.0)  # compile
        if allantools is not None:
            allantools.oadev(x, rate=1.0, taus="octave")
        # the two calls alternate, so that both meet the same machine (a process's first
        # milliseconds, a busy core's scheduling); sub-millisecond calls get enough repeats
        # to reach their steady speed (20 calls of 0.15 ms, the first in a fresh process,
        # were 1.5x slower than the same call's best of 200)
        repeats = 200 if n <= 10**4 else 20 if n <= 10**5 else 5 if n < 10**7 else 2
        best = peer = np.inf
        for k in range(repeats):
            start = time.perf_counter()
            adavar.deviation(x, rate=1.0)
            best = min(best, time.perf_counter() - start)
            if allantools is not None and (n < 10**7 or k == 0):
                start = time.perf_counter()
                allantools.oadev(x, rate=1.0, taus="octave")
                peer = min(peer, time.perf_counter() - start)
        out[n] = (best, peer)
        n *= 10
    return out


def _in_four_settings(call: str) -> dict[tuple[str, str | None], object]:
    """``bench_load.<call>`` in a fresh process, quiet and with another process spinning on
    one core, on Numba's default threads and on one; its printed result per setting."""
    results = {}
    for label, busy in (("quiet", False), ("one core busy", True)):
        for threads in (None, "1"):
            env = dict(os.environ)
            if threads:
                env["ADAVAR_THREADS"] = threads
            stop = mp.Event()
            spinner = mp.Process(target=_spin, args=(stop,)) if busy else None  # one core
            if spinner:
                spinner.start()
            code = (f"import sys; sys.path.insert(0, {os.path.dirname(__file__)!r});"
                    f"import bench_load as b; print(b.{call})")  # fmt: skip
            done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                  env=env, check=True)  # fmt: skip
            if spinner:
                stop.set()
                spinner.join()
            results[label, threads] = eval(done.stdout.strip().splitlines()[-1])  # our own
    return results


def kernels(max_n: int) -> list[str]:
    lines = []
    for (label, threads), times in _in_four_settings(f"_kernel_times({max_n})").items():
        for n, (ours, peer) in times.items():
            ratio = f"peer/adavar {peer / ours:.2f}" if np.isfinite(peer) else "-"
            lines.append(f"| deviation (with intervals), N = {n:.0e}, {label}, threads "
                         f"{threads or 'default'} | {1e3 * ours:.3g} ms | allantools.oadev "
                         f"(no intervals) {1e3 * peer:.3g} ms: {ratio} |")  # fmt: skip
    return lines


def _threaded_times() -> dict[str, float]:
    """Best of 3 of each threaded kernel's public call (compiled first)."""
    import adavar
    from adavar.dynamic.kurtosis import kurtosis_contribution

    x = adavar.simulate.sensor(
        720_000, rate=200.0, angle_random_walk=0.01, bias_instability=0.003, bandwidth=50.0,
        lsb=1e-4, seed=3,
    )  # fmt: skip
    surface = adavar.davar(x, rate=200.0, window=12_000, taus="octave")
    calls = {
        "davar, window 12000, octave taus": lambda: adavar.davar(
            x, rate=200.0, window=12_000, taus="octave"
        ),
        "adaptive_schedule (Lmax 12000)": lambda: adavar.adaptive_schedule(
            x, rate=200.0, lmax=12_000, lmin=8_000, l=2_000
        ),
        "kurtosis_contribution, record form": lambda: kurtosis_contribution(
            x, window=12_000, reference="record"
        ),
        "fit_noise of that surface (720k windows)": lambda: adavar.fit_noise(surface),
    }
    out = {}
    for name, call in calls.items():
        call()
        best = np.inf
        for _ in range(3):
            start = time.perf_counter()
            call()
            best = min(best, time.perf_counter() - start)
        out[name] = best
    return out


_FIRST_LARGE = """
import time
t0 = time.perf_counter()
import numpy as np
import adavar
from adavar.dynamic.kurtosis import kurtosis_contribution
from numba.core import event

compiling = [0.0]
depth = [0]
class Timer(event.Listener):
    def on_start(self, ev):
        if depth[0] == 0:
            self.start = time.perf_counter()
        depth[0] += 1
    def on_end(self, ev):
        depth[0] -= 1
        if depth[0] == 0:
            compiling[0] += time.perf_counter() - self.start
event.register("numba:compile", Timer())
small = np.random.default_rng(0).standard_normal(20_000)
x = adavar.simulate.sensor(720_000, rate=200.0, angle_random_walk=0.01,
                           bias_instability=0.003, bandwidth=50.0, lsb=1e-4, seed=3)
for data, w in ((small, 600), (x, 12_000)):
    s = adavar.davar(data, rate=200.0, window=w, taus="octave")
    adavar.fit_noise(s)
    adavar.adaptive_schedule(data, rate=200.0, lmax=w, lmin=2 * w // 3, l=w // 6)
    kurtosis_contribution(data, window=w, reference="record")
    adavar.davar(data, rate=200.0, window=w, taus="octave", stat="ohvar")
print(time.perf_counter() - t0, compiling[0])
"""


def first_run_large() -> list[str]:
    """A first run (empty Numba cache) of the threaded kernels on a small and a large record."""
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        done = subprocess.run([sys.executable, "-c", _FIRST_LARGE], capture_output=True,
                              text=True, env=env, check=True)  # fmt: skip
    total, compiling = map(float, done.stdout.split())
    return [f"| davar, fit_noise, adaptive_schedule, kurtosis_contribution, ohvar davar on "
            f"20k samples then 720k, empty Numba cache | {total:.1f} s, of which compiling "
            f"{compiling:.1f} s |"]  # fmt: skip


def _timed(cmd: list[str], env: dict) -> float:
    start = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env=env)
    return time.perf_counter() - start


def cold_warm(baseline: str | None, repeats: int = 3) -> list[str]:
    """``adavar avar --fit`` (one hour at 100 Hz) and ``adavar demo`` on an empty Numba
    cache (cold), then warm (best of ``repeats``), then on a fresh cache filled by
    ``adavar precompile``; for this tree and, with ``baseline`` (the ``src`` folder of
    another checkout, e.g. the previous main), for that one in the same run."""
    lines = []
    trees = {"this tree": None}
    if baseline:
        trees["baseline"] = baseline
    with tempfile.TemporaryDirectory() as folder:
        data = f"{folder}/gyro.txt"
        rng = np.random.default_rng(1)
        x = 1e-3 * rng.standard_normal(360_000) + np.cumsum(1e-6 * rng.standard_normal(360_000))
        np.savetxt(data, x, fmt="%.9e")
        commands = {
            "avar --fit": ["avar", data, "--rate", "100", "--units", "deg/s", "--fit"],
            "demo": ["demo", "--out", f"{folder}/demo", "--force"],
        }
        for tree, src in trees.items():
            base_env = dict(os.environ)
            if src is not None:
                base_env["PYTHONPATH"] = src
            for name, argv in commands.items():
                cmd = [sys.executable, "-m", "adavar.cli", *argv]
                with tempfile.TemporaryDirectory() as cache:
                    env = {**base_env, "NUMBA_CACHE_DIR": cache}
                    cold = _timed(cmd, env)
                    warm = min(_timed(cmd, env) for _ in range(repeats))
                after = float("nan")
                if src is None:
                    with tempfile.TemporaryDirectory() as cache:
                        env = {**base_env, "NUMBA_CACHE_DIR": cache}
                        pre = _timed([sys.executable, "-m", "adavar.cli", "precompile"], env)
                        after = _timed(cmd, env)
                    after_text = f"{after:.1f} s (precompile {pre:.0f} s)"
                else:
                    after_text = "-"
                lines.append(f"| {tree} | {name} | {cold:.1f} s | {warm:.2f} s | "
                             f"{cold / warm:.1f} | {after_text} |")  # fmt: skip
    return lines


def threaded() -> list[str]:
    """The threaded kernels quiet and with one core busy, default threads and one."""
    times = _in_four_settings("_threaded_times()")
    lines = []
    for name in times["quiet", None]:
        q2, q1 = times["quiet", None][name], times["quiet", "1"][name]
        b2, b1 = times["one core busy", None][name], times["one core busy", "1"][name]
        lines.append(f"| {name} | {1e3 * q2:.0f} / {1e3 * q1:.0f} ms | {1e3 * b2:.0f} / "
                     f"{1e3 * b1:.0f} ms | {q2 / min(q1, q2):.2f} | {b2 / q1:.2f} |")  # fmt: skip
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-n", type=int, default=10**7)
    parser.add_argument("--skip-demo", action="store_true")
    parser.add_argument("--only", choices=("memory", "threaded", "first-large", "cold-warm"),
                        help="run one section")  # fmt: skip
    parser.add_argument("--baseline", metavar="SRC",
                        help="cold-warm: also the adavar of this src folder (a checkout of the "
                        "previous main), in the same run")  # fmt: skip
    args = parser.parse_args()
    print(f"machine: {describe()}")
    print(f"at the start, {speed_probe()}", flush=True)
    try:
        _sections(args)
    finally:
        print(f"at the end, {speed_probe()}")


def _sections(args: argparse.Namespace) -> None:
    if args.only == "memory":
        print("| command | memory | sizes |\n|---|---|---|")
        for line in memory():
            print(line, flush=True)
        return
    if args.only == "first-large":
        print("| what | time |\n|---|---|")
        for line in first_run_large():
            print(line, flush=True)
        return
    if args.only == "cold-warm":
        print("| adavar | command | cold | warm | cold / warm | after precompile |")
        print("|---|---|---|---|---|---|")
        for line in cold_warm(args.baseline):
            print(line, flush=True)
        return
    if args.only == "threaded":
        print("| kernel | quiet: default threads / one | one core busy: default / one | "
              "quiet default / best quiet | busy default / quiet one |")  # fmt: skip
        print("|---|---|---|---|---|")
        for line in threaded():
            print(line, flush=True)
        return
    print("| what | time |\n|---|---|")
    for line in startup() + ([] if args.skip_demo else first_run()) + text_input():
        print(line, flush=True)
    print("\n| kernel | adavar | peer |\n|---|---|---|")
    for line in kernels(args.max_n):
        print(line, flush=True)
    print("\n| command | memory | sizes |\n|---|---|---|")
    for line in memory():
        print(line, flush=True)


if __name__ == "__main__":
    main()

"""DAVAR surface: adavar against a per-window allantools loop, measured in the same run.

Usage: python benchmarks/bench_davar.py [--n 1000000] [--window 6000] [--loop-windows 300]
                                        [--big 10000000] [--repeat 3]

The peer is what users do today: slide a window over the record and call
``allantools.oadev`` on every window (octave taus up to a third of the window). Timing a
million such calls takes hours, so ``--loop-windows`` windows spread over the record are
timed and the per-window cost is scaled to every centre; the same windows are compared with
adavar's surface. adavar computes every centre (mirrored edges, step 1) with the same taus.

Also measured: the same surface on ``--big`` samples (time and peak resident memory of a
fresh process, against the size of the output and of the input), and the noise-model fit of
every window of the 1e6-centre surface (``adavar.fit_noise``).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import allantools
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe, timed

import adavar


def _status_kib(key: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1])
    raise RuntimeError(f"{key} not in /proc/self/status")


def child(n: int, window: int, confidence: float | None) -> None:
    """Run one surface in this (fresh) process and print time and peak memory as JSON.

    The output counted is what the call returns: the surface, its time, window and centre
    arrays (the bounds are formed only when read, at the size of the surface each).
    """
    adavar.davar(np.zeros(3 * window), window=window, taus="octave")  # load the kernels
    y = np.random.default_rng(2).standard_normal(n)
    # reset the high-water mark so that loading and compiling do not count (Linux)
    Path("/proc/self/clear_refs").write_text("5")
    base = _status_kib("VmRSS")
    t = time.perf_counter()
    r = adavar.davar(y, window=window, taus="octave", confidence=confidence)
    seconds = time.perf_counter() - t
    peak = _status_kib("VmHWM")
    arrays = [r.avar, r.time, r.window, r.centre]
    out_bytes = sum(a.nbytes for a in arrays if a is not None)
    print(json.dumps({
        "seconds": seconds, "peak_kib": peak, "before_kib": base, "output_bytes": out_bytes,
        "input_bytes": y.nbytes, "shape": list(r.avar.shape),
    }))  # fmt: skip


def fresh_process(n: int, window: int, confidence: float | None) -> dict:
    cmd = [sys.executable, __file__, "--child", str(n), str(window), str(confidence)]
    done = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--window", type=int, default=6000)
    ap.add_argument("--loop-windows", type=int, default=300)
    ap.add_argument("--big", type=int, default=10_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        n, window, conf = args.child
        child(int(n), int(window), None if conf == "None" else float(conf))
        return

    print(describe())
    n, L = args.n, args.window
    y = np.random.default_rng(1).standard_normal(n)
    adavar.davar(y[:20_000], window=L, taus="octave")  # load the compiled kernels

    # the peer: allantools.oadev on each window, at the same octave taus
    ms = 2 ** np.arange(int(np.log2(L // 3)) + 1)
    centres = np.linspace(L, n - L, args.loop_windows).astype(np.int64)
    starts = centres - (L - 1) // 2
    t = time.perf_counter()
    peer = [
        allantools.oadev(y[a : a + L], rate=1.0, data_type="freq", taus=ms.astype(float))[1]
        for a in starts
    ]
    per_window = (time.perf_counter() - t) / centres.size
    loop_estimate = per_window * n

    bare, bare_first, r = timed(
        lambda: adavar.davar(y, window=L, taus="octave", confidence=None), args.repeat
    )
    full, full_first, rf = timed(lambda: adavar.davar(y, window=L, taus="octave"), args.repeat)
    bounds, bounds_first, _ = timed(
        lambda: adavar.davar(y, window=L, taus="octave").avar_high, args.repeat
    )
    rel = float(np.max(np.abs(r.adev[centres] / np.array(peer) - 1)))

    print(
        f"N = {n:.0e} white-noise samples, window {L}, every sample a centre (mirrored "
        f"edges), {ms.size} octave taus (m = 1..{ms[-1]}); best of {args.repeat}, first "
        "call in brackets"
    )
    print(f"{'':46s}{'seconds':>10s}{'first':>9s}{'speed-up':>10s}")
    print(
        f"{'allantools.oadev per window (x N, estimated)':46s}{loop_estimate:10.1f}"
        f"{'':9s}{1.0:10.0f}"
    )
    print(f"  ({per_window * 1e3:.3f} ms per window, {centres.size} windows timed)")
    print(
        f"{'adavar.davar(confidence=None)':46s}{bare:10.3f}{bare_first:9.3f}"
        f"{loop_estimate / bare:10.0f}"
    )
    print(
        f"{'adavar.davar (noise ID, per-cell EDF)':46s}{full:10.3f}{full_first:9.3f}"
        f"{loop_estimate / full:10.0f}"
    )
    print(
        f"{'  ... and reading the avar_high bounds':46s}{bounds:10.3f}{bounds_first:9.3f}"
        f"{loop_estimate / bounds:10.0f}"
    )
    print(f"max relative difference of adev at the {centres.size} compared windows: {rel:.1e}")

    fit_t, _, fit = timed(lambda: adavar.fit_noise(rf), 1)
    n_ok = int(np.isfinite(fit.angle_random_walk.value).sum())
    print(
        f"adavar.fit_noise on all {n:.0e} windows (5 terms, {ms.size} taus): "
        f"{fit_t:.2f} s ({n_ok} fitted; median N = "
        f"{np.nanmedian(fit.angle_random_walk.value):.4f}, truth 1)"
    )

    if args.big:
        for conf in (None, 0.683):
            res = fresh_process(args.big, L, conf)
            gib = 2.0**30
            peak = res["peak_kib"] * 1024 / gib
            label = "confidence=None" if conf is None else "with noise ID and EDF"
            base = res["before_kib"] * 1024 / gib
            extra = peak - base - res["output_bytes"] / gib
            print(
                f"N = {args.big:.0e}, {label}, fresh process: {res['seconds']:.2f} s; peak "
                f"RSS {peak:.2f} GiB = before the call {base:.2f} (interpreter and input) "
                f"+ output {res['output_bytes'] / gib:.2f} + {extra:.2f} GiB working "
                f"memory ({extra / (res['input_bytes'] / gib):.1f} x the input)"
            )


if __name__ == "__main__":
    main()

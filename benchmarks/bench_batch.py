"""adavar batch: throughput with 1 and 2 dask workers against a loop in one process.

Usage: python benchmarks/bench_batch.py [--files 16] [--n 1000000] [--workers 1,2]
                                        [--adaptive] [--quick]

The records are ``--files`` simulated static gyro logs (``.npy``, ``--n`` samples at 100 Hz in
deg/s: ARW, bias instability and rate random walk, one seed each). Every file gets what
``adavar report FILE`` computes and ``adavar batch`` writes: the whole-record overlapping
Allan deviation with its noise fit, the HTML report, result.json and deviation.csv (with
``--adaptive`` also the A-DAVAR surface, its per-window fit and the events).

The peer, measured in the same run on the same files: the files one by one in a loop in this
process (``run_batch`` without a cluster; numba uses both cores for each file). Then the same
batch on a ``distributed.LocalCluster`` of 1 and of 2 single-threaded worker processes
(``NUMBA_NUM_THREADS=1``), reached with ``run_batch(scheduler=...)`` after every worker has
loaded the compiled kernels (the loop's process too): the rate a long batch runs at. "cold
wall s" is ``run_batch(workers=N)`` from nothing: starting the cluster (about 2-4 s) and each
worker's first call (loading the kernels from numba's cache, about 3 s) included.
``--quick``: 4 files of 2e5 samples.
"""

from __future__ import annotations

import argparse
import logging
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe

from adavar import simulate
from adavar.pipeline.batch import analyse_file, run_batch


def _records(folder: Path, files: int, n: int) -> list[Path]:
    paths = []
    for k in range(files):
        x = simulate.sensor(n, rate=100.0, seed=100 + k, angle_random_walk=0.1,
                            bias_instability=0.01, rate_random_walk=0.001)  # fmt: skip
        path = folder / f"gyro{k:03d}.npy"
        np.save(path, x)
        paths.append(path)
    return paths


def _run(paths: list[Path], out: Path, options: dict, **where: object) -> dict:
    start = time.perf_counter()
    result = run_batch(paths, out=out, options=options, **where)
    wall = time.perf_counter() - start
    assert result.counts["ok"] == len(paths), result.rows
    return {"wall": wall, "rows": result.rows}


def _warm(path: str, options: dict) -> None:
    """One file through the whole task, so that the kernels are loaded (on a worker)."""
    analyse_file(path, options).html()


def _cluster_runs(paths: list[Path], work: Path, options: dict, workers: int) -> dict:
    """Cold: ``run_batch(workers=N)`` (starts its cluster); warm: a running cluster whose
    workers have loaded the kernels, reached by ``run_batch(scheduler=...)``."""
    from distributed import Client, LocalCluster

    cold = _run(paths, work / f"cold{workers}", options, workers=workers)
    with LocalCluster(
        n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
        silence_logs=logging.ERROR, env={"NUMBA_NUM_THREADS": "1"},
    ) as cluster, Client(cluster) as client:  # fmt: skip
        client.run(_warm, str(paths[0]), options)
        warm = _run(paths, work / f"warm{workers}", options, scheduler=cluster.scheduler_address)
    return {**warm, "cold": cold["wall"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", type=int, default=16)
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--workers", default="1,2", help="comma-separated worker counts")
    ap.add_argument("--adaptive", action="store_true", help="also A-DAVAR and its events")
    ap.add_argument("--quick", action="store_true", help="4 files of 2e5 samples")
    args = ap.parse_args()
    if args.quick:
        args.files, args.n = 4, 200_000
    counts = [int(w) for w in args.workers.split(",") if w.strip()]
    options = {"units": "deg/s", "rate": 100.0, "adaptive": args.adaptive}
    print(describe())
    work = Path(tempfile.mkdtemp(prefix="adavar-bench-batch-"))
    try:
        paths = _records(work, args.files, args.n)
        analyse_file(paths[0], options).html()  # this process's kernels, untimed
        loop = _run(paths, work / "loop", options)
        runs = {"loop in one process": {**loop, "cold": float("nan")}}
        for w in counts:
            label = f"LocalCluster, {w} worker{'s' if w > 1 else ''}"
            runs[label] = _cluster_runs(paths, work, options, w)
        # the workers run numba on one thread, the loop on all: equal to the last bits
        reference = np.array([[r["N"], r["K"]] for r in runs["loop in one process"]["rows"]])
        worst = max(
            float(np.max(np.abs(np.array([[r["N"], r["K"]] for r in run["rows"]]) - reference)
                         / np.maximum(np.abs(reference), 1e-300)))
            for run in runs.values()
        )  # fmt: skip
        samples = args.files * args.n
        what = "whole-record fit + report" + (" + A-DAVAR surface and events" if args.adaptive
                                              else "")  # fmt: skip
        print(f"{args.files} files x {args.n:.0e} samples (100 Hz, float64 .npy): {what}")
        print(f"{'':28s}{'wall s':>8s}{'files/min':>11s}{'samples/s':>11s}{'vs loop':>9s}"
              f"{'cold wall s':>13s}")  # fmt: skip
        base = runs["loop in one process"]["wall"]
        for name, run in runs.items():
            cold = "-" if np.isnan(run["cold"]) else f"{run['cold']:.1f}"
            print(f"{name:28s}{run['wall']:8.2f}{60 * args.files / run['wall']:11.1f}"
                  f"{samples / run['wall']:11.3g}{base / run['wall']:9.2f}{cold:>13s}")  # fmt: skip
        per_sample = base / samples
        print(f"loop: {per_sample * 1e9:.0f} ns per sample, {base / args.files:.2f} s per file; "
              f"largest relative difference of N and K between runs: {worst:.1e}")  # fmt: skip
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":  # the worker processes re-import this file: keep the guard
    main()

"""The online adaptive pass (issue 18): samples per second of ``OnlineAdaptive.push``.

* schedule only (``terms=None``) at push sizes 1 .. 1e5, on one core (Numba on one thread),
  quiet and with another process busy on one core (best of 3 runs);
* with N(t) (the N-only fit of every kept window, octave taus) at ``step`` 1 and 10;
* against the offline pass on the same record in the same run (``adaptive_schedule``, and
  ``adaptive_davar`` + ``fit_noise``), as a ratio; every online result is checked equal to
  the offline one;
* ``method="ici"`` (schedule only, push sizes 100 .. 1e5, best of 2) against
  ``adaptive_schedule(method="ici")`` with the same ``ici_edf_samples`` (``--ici-only``:
  this part alone).

The record: the realistic 200 Hz sensor (40 Hz filter, 1/131 LSB) with two x3 bursts,
``--n`` samples (default 2e6), Lmax = 600, the paper's thresholds.

Run: ``python benchmarks/bench_online.py [--n 2000000] [--ici-only]``.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numba
import numpy as np
from _machine import describe

import adavar
from adavar.dynamic.online import OnlineAdaptive
from adavar.simulate import sensor

RATE = 200.0
PUSHES = (1, 10, 100, 1000, 10_000, 100_000)
ICI_PUSHES = (100, 1000, 10_000, 100_000)
#: the ICI pass's EDF head, online and offline alike
#: the figures' controller: the paper's (the defaults follow the record since 0.2)
PAPER = dict(lmax=600, thresholds="paper")
ICI = dict(method="ici", lmax=600, ici_edf_samples=1 << 16)


def busy(stop) -> None:  # pragma: no cover - another process
    while not stop.is_set():
        sum(i * i for i in range(10_000))


def the_record(n: int) -> np.ndarray:
    x = sensor(n, rate=RATE, bandwidth=40, lsb=1 / 131, angle_random_walk=0.01,
               bias_instability=0.002, rate_random_walk=1e-4, seed=18)  # fmt: skip
    for a in (n // 4, 3 * n // 4):
        x[a : a + 6000] *= 3.0
    return x


def online(x: np.ndarray, push: int, total: int, **options) -> tuple[float, OnlineAdaptive]:
    """Samples per second of pushing the first ``total`` samples ``push`` at a time."""
    live = OnlineAdaptive(rate=RATE, **PAPER | options)
    start = time.perf_counter()
    for i in range(0, total, push):
        live.push(x[i : i + push])
    return total / (time.perf_counter() - start), live


def budget(push: int, n: int) -> int:
    """Samples to push: 20000 pushes at most (a small push costs tens of microseconds)."""
    return int(min(n, push * 20_000))


def schedule_rows(x: np.ndarray, n: int) -> list[str]:
    rows = []
    for push in PUSHES:
        total = budget(push, n)
        rate = max(online(x, push, total, terms=None, keep="recent")[0] for _ in range(3))
        rows.append((push, total, rate))
    return [f"| {p} | {t:.3g} | {r / 1e6:.3f} M/s |" for p, t, r in rows]


def ici_part(x: np.ndarray, n: int) -> None:
    """method="ici": samples per second of push, the offline pass, equality."""
    OnlineAdaptive(rate=RATE, terms=None, **ICI).push(x[: 1 << 17])  # compile
    adavar.adaptive_schedule(x[: 1 << 17], rate=RATE, **ICI)
    start = time.perf_counter()
    sched = adavar.adaptive_schedule(x, rate=RATE, **ICI)
    t_sched = time.perf_counter() - start
    print(f"\nICI: offline adaptive_schedule(method='ici'): {n / t_sched / 1e6:.3f} M samples/s")
    print("\n| ICI push size | schedule only, one core | online / offline | equal |")
    print("|---|---|---|---|")
    for push in ICI_PUSHES:
        best, same = 0.0, True
        for _ in range(2):
            rate, live = online(x, push, n, terms=None, keep="recent", **ICI)
            live.finish()
            best = max(best, rate)
            same &= bool(np.array_equal(live.window, sched.window[live.first_row :]))
        print(f"| {push} | {best / 1e6:.3f} M/s | {best * t_sched / n:.2f} | {same} |")
    _, live = online(x, 10_000, n, terms=None, **ICI)
    live.finish()
    print(f"\nICI windows and shifts equal (push 1e4): "
          f"{np.array_equal(live.window, sched.window) and np.array_equal(live.shift, sched.shift)}"
          f"; latency {live.latency} samples")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=2_000_000)
    parser.add_argument("--ici-only", action="store_true", help="the method='ici' part only")
    args = parser.parse_args()
    n = args.n
    numba.set_num_threads(1)
    print(f"Machine: {describe()}; Numba threads: {numba.get_num_threads()}")
    x = the_record(n)
    if args.ici_only:
        ici_part(x, n)
        return
    OnlineAdaptive(rate=RATE, **PAPER).push(x[:5000])  # compile
    adavar.adaptive_schedule(x[:5000], rate=RATE, **PAPER)

    # offline, the same record, the same thread
    start = time.perf_counter()
    sched = adavar.adaptive_schedule(x, rate=RATE, **PAPER)
    t_sched = time.perf_counter() - start
    print(f"\noffline adaptive_schedule: {n / t_sched / 1e6:.2f} M samples/s")

    print("\n| push size | samples pushed | schedule only, one core |")
    print("|---|---|---|")
    for line in schedule_rows(x, n):
        print(line)

    # equality on the whole record, in pieces of 1e4
    _, live = online(x, 10_000, n, terms=None)
    live.finish()
    print(f"\nwindows equal to adaptive_schedule: {np.array_equal(live.window, sched.window)}")

    print("\n| N(t) | push size | online | offline (adaptive_davar + fit_noise) | ratio | equal |")
    print("|---|---|---|---|---|---|")
    for step in (1, 10):
        start = time.perf_counter()
        result = adavar.adaptive_davar(x, rate=RATE, taus="octave", noise_type=0, step=step,
                                       **PAPER)  # fmt: skip
        arw = adavar.fit_noise(result, terms=("angle_random_walk",)).angle_random_walk.value
        t_off = time.perf_counter() - start
        for push, batch in ((1000, 1), (1000, 10_000), (100_000, 1)):
            rate, live = online(x, push, n, step=step, fit_batch=batch)
            live.finish()
            same = np.array_equal(live.window, result.window) and np.allclose(
                live.arw, arw, rtol=1e-12, atol=0
            )
            print(f"| step {step}, fit_batch {batch} | {push} | {rate / 1e6:.3f} M/s "
                  f"| {n / t_off / 1e6:.3f} M/s | {rate * t_off / n:.2f} | {same} |")  # fmt: skip

    ici_part(x, n)

    stop = mp.Event()
    proc = mp.Process(target=busy, args=(stop,), daemon=True)
    proc.start()
    try:
        time.sleep(0.5)
        print("\nwith another process busy on one core:")
        print("\n| push size | samples pushed | schedule only, one core |")
        print("|---|---|---|")
        for line in schedule_rows(x, n):
            print(line)
        start = time.perf_counter()
        adavar.adaptive_schedule(x, rate=RATE, **PAPER)
        print(f"\noffline adaptive_schedule (busy): {n / (time.perf_counter() - start) / 1e6:.2f}"
              " M samples/s")  # fmt: skip
    finally:
        stop.set()
        proc.join()


if __name__ == "__main__":
    main()

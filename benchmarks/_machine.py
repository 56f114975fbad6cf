"""Shared by the benchmarks: the machine they ran on, and a best-of-n timer."""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Callable
from typing import Any


def describe() -> str:
    """One line: CPU model, cores, memory, Python and key library versions."""
    import numba
    import numpy

    cpu = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
        mem_s = f"{mem:.0f} GiB"
    except (ValueError, OSError):
        mem_s = "? GiB"
    return (
        f"{cpu}, {os.cpu_count()} cores, {mem_s}, {platform.system()} {platform.machine()}, "
        f"Python {platform.python_version()}, numpy {numpy.__version__}, "
        f"numba {numba.__version__}"
    )


def speed_probe() -> str:
    """One line: how fast this machine runs right now, on work that is not adavar's.

    A shared virtual machine ran the same code 1.3x slower within an hour and 1.6x slower
    from one session to another; a figure compared with another session's is only
    meaningful next to these two. Best of 3 each: a
    pure-Python loop (5e6 additions: the interpreter) and a NumPy pass over 1e7 float64
    (``cumsum`` then ``diff``: memory bandwidth).
    """
    import numpy as np

    def loop() -> int:
        total = 0
        for k in range(5_000_000):
            total += k
        return total

    x = np.random.default_rng(0).standard_normal(10_000_000)
    python_s = timed(loop, 3)[0]
    numpy_s = timed(lambda: np.diff(np.cumsum(x)), 3)[0]
    return (
        f"speed now: Python loop of 5e6 additions {python_s:.3f} s, NumPy cumsum+diff of "
        f"1e7 float64 {numpy_s * 1e3:.0f} ms"
    )


def timed(fn: Callable[[], Any], repeat: int) -> tuple[float, float, Any]:
    """Best and first of ``repeat`` calls of ``fn`` (seconds), and its last result."""
    times = []
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return min(times), times[0], out

"""A first run's compilation in two processes: a helper compiles the kernels needed last.

On an empty Numba cache a command compiles its kernels one after another as it reaches
them (``adavar davar`` on a 30-minute, 200 Hz record: 18 s of its 29 s). Most of them do
not depend on each other, so a second process started with the command compiles the
stages the command reaches last (the adaptive controller, the noise fit, the surface
kernel), in reverse order, while this one compiles those it reaches first. Each kernel
the helper finishes goes to the on-disk cache, and this process loads it from there when
it gets to it (Numba looks in the cache before it compiles a signature it has not met).
Where the two meet, nothing is compiled twice: a kernel of a stage the helper is
compiling is waited for (:data:`adavar._jit.BEFORE_COMPILING`, asked before each
compilation), and a stage it has not started is compiled here and skipped there.

The helper is started only when it can help: the cache lacks the kernels of at least
one stage it would take, two cores are free to this process, and neither
``ADAVAR_THREADS=1`` nor ``ADAVAR_COMPILE_AHEAD=0`` is set. It prints nothing, ignores
Ctrl-C (the command ends it) and ends with the command: a kernel it was compiling then
is simply not cached (Numba writes cache files under temporary names).

Each stage is compiled by calling public functions on a few thousand samples of white
noise, the same code path as a real call, so the kernels get the same signatures
(``tests/test_compile_ahead.py`` checks that a command then needs none it lacks).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

__all__ = ["STAGES", "ahead_of", "compile_stages", "stage_cached", "start", "stop"]


def _controller() -> None:
    from adavar.adaptive import adaptive_schedule

    x = np.random.default_rng(0).standard_normal(3000)
    adaptive_schedule(x, rate=1.0, lmax=300, lmin=200, l=50)


def _fit() -> None:
    from adavar.noise_model import fit_noise
    from adavar.results import DavarResult

    # a surface built directly: fitting one computed by davar would compile the surface
    # kernels here as well, which the command compiles meanwhile
    m = 2 ** np.arange(7)
    tau = m.astype(float)
    rows = 40
    avar = np.tile(1e-2 / tau + 1e-5 + 1e-7 * tau, (rows, 1))
    edf = np.maximum(1.0, 300.0 / m)[None, :]
    surface = DavarResult(
        time=np.arange(rows, dtype=float), tau=tau, avar=avar, window=np.full(rows, 300),
        centre=np.arange(rows), m=m, alpha=np.zeros(m.size, dtype=np.int64), tau0=1.0,
        data_type="rate", edges="mirror", step=1, confidence=0.683, n_samples=rows,
        edf_table=edf, window_class=np.zeros(rows, dtype=np.int64),
        bound_table=np.stack([0.5 * np.ones_like(edf), 2.0 * np.ones_like(edf)]),
    )  # fmt: skip
    fit_noise(surface, cells=False)


def _surface() -> None:
    from adavar.davar import davar

    x = np.random.default_rng(1).standard_normal(3000)
    davar(x, rate=1.0, window=300, confidence=None)


def _kurtosis() -> None:
    from adavar.kurtosis import kurtosis_contribution, sliding_kurtosis

    x = np.random.default_rng(3).standard_normal(3000)
    sliding_kurtosis(x, window=300)
    kurtosis_contribution(x, window=300, segment=50)
    kurtosis_contribution(x, window=300, reference="record")


def _deviation() -> None:
    from adavar.statistics import deviation

    x = np.random.default_rng(2).standard_normal(3000)
    deviation(x, rate=1.0)


#: stage -> (how to compile its kernels, the kernels it compiles as (module, name); the
#: first one's cache entry says that the stage is compiled)
STAGES: dict[str, tuple[Callable[[], None], tuple[tuple[str, str], ...]]] = {
    "controller": (_controller, (("adavar.controller", "_speculate"),
                                 ("adavar.controller", "_segment_bounds"),
                                 ("adavar.controller", "_reconcile"))),
    "fit": (_fit, (("adavar._nnls", "nnls_blocks"),)),
    "surface": (_surface, (("adavar._kernels.window_avar", "window_avar_kernel"),
                           ("adavar._kernels.window_avar", "_window_extent"))),
    "kurtosis": (_kurtosis, (("adavar.kurtosis", "_sliding"),
                             ("adavar.kurtosis", "_grid_blocks"),
                             ("adavar.kurtosis", "_grid_chain"),
                             ("adavar.kurtosis", "_record"))),
    "deviation": (_deviation, (("adavar.noise_id", "_rate_noise_kernel"),
                               ("adavar.differences", "_anchored_prefix"),
                               ("adavar.differences", "_prefix_blocks"),
                               ("adavar.differences", "_overlap_partials"),
                               ("adavar.differences", "_superblock_totals"),
                               ("adavar.differences", "cluster_differences"))),
}  # fmt: skip


def stage_cached(stage: str) -> bool:
    """Whether the on-disk cache holds the kernel that marks ``stage`` as compiled.

    True also when that cannot be told (a Numba without the cache internals used), so
    that nothing is started then.
    """
    import importlib

    module, name = STAGES[stage][1][0]
    try:
        kernel = getattr(importlib.import_module(module), name)
        dispatcher = getattr(kernel, "kernel", kernel)  # a ThreadedKernel's own dispatcher
        return bool(dispatcher._cache._cache_file._load_index())
    except Exception:  # any doubt: treat it as cached, start nothing
        return True


class _Claims:
    """Who compiles which stage, in a folder both processes see.

    The first to create ``K.claim`` (``O_EXCL``: one of them only) compiles stage ``K``;
    the helper creates ``K.done`` when it is through with a stage of its own.
    """

    def __init__(self, folder: str) -> None:
        self.folder = folder

    def claim(self, k: int) -> bool:
        """Take stage ``k``; False when the other process has. True when the folder is
        gone: the helper removes it as it ends, and then has nothing more to give."""
        try:
            os.close(os.open(os.path.join(self.folder, f"{k}.claim"),
                             os.O_CREAT | os.O_EXCL | os.O_WRONLY))  # fmt: skip
        except FileExistsError:
            return False
        except FileNotFoundError:
            return True
        return True

    def finish(self, k: int) -> None:
        """Mark stage ``k`` done (its kernels cached, or failed: compiled there then)."""
        with (
            contextlib.suppress(FileNotFoundError),
            open(os.path.join(self.folder, f"{k}.done"), "w"),
        ):
            pass

    def done(self, k: int) -> bool:
        """Whether the helper is through with stage ``k``."""
        return os.path.exists(os.path.join(self.folder, f"{k}.done"))


def compile_stages(
    stages: Sequence[str], folder: str | None = None, parent: int | None = None
) -> None:
    """Compile ``stages`` in this order (the helper's work), each unless it is cached or
    the command has taken it (``folder``: the two processes' :class:`_Claims`), while
    the process ``parent`` (the command) is this one's parent."""
    claims = _Claims(folder) if folder is not None else None
    for k, stage in enumerate(stages):
        if parent is not None and os.getppid() != parent:
            return  # the command is gone (killed): nobody needs the rest
        if claims is not None and not claims.claim(k):
            continue
        try:
            if not stage_cached(stage):
                STAGES[stage][0]()
        finally:
            if claims is not None:
                claims.finish(k)


def _helper_main(folder: str | None, stages: Sequence[str], parent: int | None = None) -> None:
    """The helper process (started with its output sent nowhere): deaf to Ctrl-C, which
    reaches it with the command's (the command ends it), then :func:`compile_stages`.

    It ends with the command even when the command is killed: on Linux the kernel sends
    it SIGTERM then (``PR_SET_PDEATHSIG``); elsewhere it stops before its next stage.
    As it ends, it removes the claims' folder (the command, killed, could not).
    """
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))  # through the finally below
    if parent is not None and sys.platform.startswith("linux"):
        with contextlib.suppress(Exception):
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    try:
        if parent is None or os.getppid() == parent:
            compile_stages(stages, folder, parent)
    finally:
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)


def _wanted() -> bool:
    if os.environ.get("ADAVAR_COMPILE_AHEAD", "").strip() == "0":
        return False
    if os.environ.get("ADAVAR_THREADS", "").strip() == "1":
        return False
    affinity = getattr(os, "sched_getaffinity", None)
    cores = len(affinity(0)) if affinity is not None else os.cpu_count() or 1
    return cores >= 2


class _Helper:
    """This process's side: before compiling a kernel of a stage the helper is on, wait."""

    def __init__(self, process: Any, stages: Sequence[str], folder: str) -> None:
        self.process, self.folder = process, folder
        self.claims = _Claims(folder)
        self.mine: set[int] = set()
        self.stage_of = {kernel: k for k, stage in enumerate(stages) for kernel in STAGES[stage][1]}

    def before_compiling(self, py_func: Any) -> bool:
        """Called by :mod:`adavar._jit` when ``py_func`` is not in the cache: True when
        the helper may have compiled it meanwhile (to be loaded again now)."""
        k = self.stage_of.get(
            (getattr(py_func, "__module__", ""), getattr(py_func, "__name__", ""))
        )
        if k is None or k in self.mine:
            return False
        if self.claims.claim(k):  # not started there: compiled here, skipped there
            self.mine.add(k)
            return False
        while not self.claims.done(k) and self.process.poll() is None:
            time.sleep(0.02)
        return True  # load again: compiled there, unless the helper failed or ended


def ahead_of(order: Sequence[str]) -> list[str]:
    """The helper's stages for a command that reaches ``order`` in this order: all but the
    first (the command starts on it at once), the last first."""
    return list(reversed(order[1:]))


def start(stages: Sequence[str]) -> Any:
    """Start the helper on those of ``stages`` (last needed first) not in the cache.

    Returns a handle for :func:`stop`, or None when nothing is to be compiled, the helper
    is not wanted (module notes) or a process cannot start. While it runs, a kernel of
    a stage the helper is compiling is waited for rather than compiled here too.

    The helper is a new interpreter (``python -c``), not a ``multiprocessing`` child: that
    would import the caller's main script again, which a script that calls
    :func:`adavar.cli.main` without a ``__main__`` guard would run a second time.
    """
    import tempfile

    from adavar import _jit

    if not _wanted() or _jit.BEFORE_COMPILING is not None:
        return None
    cold = [stage for stage in stages if not stage_cached(stage)]
    if not cold:
        return None
    folder = tempfile.mkdtemp(prefix="adavar-compile-ahead-")
    # the package this process runs, first on the helper's path
    package_root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    path = os.pathsep.join(p for p in (package_root, os.environ.get("PYTHONPATH")) if p)
    code = ("import sys; from adavar._compile_ahead import _helper_main; "
            "_helper_main(sys.argv[1], sys.argv[3:], int(sys.argv[2]))")  # fmt: skip
    try:
        process = subprocess.Popen(
            [sys.executable, "-c", code, folder, str(os.getpid()), *cold],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            env={**os.environ, "PYTHONPATH": path},
        )  # fmt: skip
    except OSError:
        shutil.rmtree(folder, ignore_errors=True)
        return None
    helper = _Helper(process, cold, folder)
    _jit.BEFORE_COMPILING = helper.before_compiling
    return helper


def stop(helper: Any) -> None:
    """End the helper if it is still compiling (the command needs nothing more of it)."""
    from adavar import _jit

    if helper is None:
        return
    if _jit.BEFORE_COMPILING == helper.before_compiling:
        _jit.BEFORE_COMPILING = None
    if helper.process.poll() is None:
        helper.process.terminate()
        with contextlib.suppress(subprocess.TimeoutExpired):  # one that will not end: left
            helper.process.wait(timeout=5)
    shutil.rmtree(helper.folder, ignore_errors=True)

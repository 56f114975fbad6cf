"""``adavar demo`` in two processes: the worker's seed study is the one computed here."""

from __future__ import annotations

from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool

import numpy as np
import pytest

from adavar import demo

from .cli_helpers import assert_one_line_error, run


def _same_study(a, b):
    assert a.seeds == b.seeds
    assert a.methods == b.methods
    for table in ("nodes", "arw", "confidence", "tracking"):
        for method in a.methods:
            np.testing.assert_array_equal(getattr(a, table)[method], getattr(b, table)[method])
    for threshold in a.crossings:
        np.testing.assert_array_equal(a.crossings[threshold], b.crossings[threshold])


def test_worker_process_gives_the_in_process_seed_study():
    pool = demo.worker_pool(2)
    if pool is None:
        pytest.skip("this machine cannot start a second process")
    with pool:
        remote = pool.submit(demo._seed_study, 2018, 2).result(timeout=600)
    _same_study(remote, demo._seed_study(2018, 2))


def test_one_worker_runs_in_process():
    assert demo.worker_pool(1) is None


class _FakePool:
    """Futures never started (so cancellable), or done with ``outcome(first, count)``."""

    def __init__(self, outcome=None):
        self.outcome = outcome

    def submit(self, func, first, count):
        future: Future = Future()
        if self.outcome is not None:
            result = self.outcome(first, count)
            if isinstance(result, BaseException):
                future.set_exception(result)
            else:
                future.set_result(result)
        return future


def test_shared_study_is_the_study_of_every_seed(monkeypatch):
    monkeypatch.setattr(demo, "PAPER_SEEDS", 6)
    monkeypatch.setattr(demo, "SEED_CHUNK", 2)
    assert demo._seed_chunks(2018) == [(2018, 1), (2019, 2), (2021, 2), (2023, 1)]
    whole = demo._seed_study(2018, 6)
    # the worker did the first two items; the others were never started: done here
    done_two = lambda first, count: (  # noqa: E731
        demo._seed_study(first, count) if first < 2021 else None
    )

    class HalfPool(_FakePool):
        def submit(self, func, first, count):
            return _FakePool(done_two if first < 2021 else None).submit(func, first, count)

    shared = demo._SharedStudy(HalfPool(), 2018)
    _same_study(shared.result(), whole)
    # nothing started: everything here
    _same_study(demo._SharedStudy(_FakePool(), 2018).result(), whole)


def test_a_dead_worker_falls_back_to_this_process(monkeypatch):
    monkeypatch.setattr(demo, "PAPER_SEEDS", 3)
    dead = _FakePool(lambda first, count: BrokenProcessPool("killed"))
    shared = demo._SharedStudy(dead, 2018)
    shared.wait_first()  # no error here: it shows (and is handled) in result()
    _same_study(shared.result(), demo._seed_study(2018, 3))


def test_concatenated_studies_refuse_other_settings():
    from adavar.errors import AdavarInputError
    from adavar.paper.studies import compare_seeds, concatenate_seed_studies

    a = demo._seed_study(2018, 1)
    other = compare_seeds(1, [2019], lmin=300)
    with pytest.raises(AdavarInputError, match="same arguments"):
        concatenate_seed_studies([a, other])
    with pytest.raises(AdavarInputError, match="at least one"):
        concatenate_seed_studies([])
    assert concatenate_seed_studies([a]).seeds == (2018,)


def test_shared_jobs_run_here_what_the_worker_cannot():
    from adavar._workers import SharedJobs

    class DeadPool:
        def submit(self, *args):
            raise BrokenProcessPool("killed")

    calls = []
    job = lambda *args: calls.append(args) or sum(args)  # noqa: E731
    # no worker at all, or one that cannot take work: every job here, results in order
    assert SharedJobs(None, job, [(1, 2), (3,)]).results() == [3, 3]
    assert SharedJobs(DeadPool(), job, [(1,), (2,)]).results() == [1, 2]

    class Pool:  # the worker took the first job and died; the second one it never started
        def submit(self, func, *args):
            future: Future = Future()
            if args == (10,):
                future.set_running_or_notify_cancel()
                future.set_exception(BrokenProcessPool("killed while drawing"))
            return future

    calls.clear()
    assert SharedJobs(Pool(), job, [(10,), (20,)]).results() == [10, 20]
    assert sorted(calls) == [(10,), (20,)]

    class Failing(Pool):  # a real error in the worker is not hidden
        def submit(self, func, *args):
            future: Future = Future()
            future.set_running_or_notify_cancel()
            future.set_exception(OSError("disk full"))
            return future

    with pytest.raises(OSError, match="disk full"):
        SharedJobs(Failing(), job, [(1,)]).results()


def test_demo_figures_longest_first_and_drawn_either_side(tmp_path, monkeypatch):
    from adavar.cli import demo as cli_demo

    monkeypatch.setattr(demo, "PAPER_SEEDS", 1)
    result = demo.run_demo(keep="figures")
    recipes = cli_demo._figure_recipes(result)
    assert list(recipes) == list(cli_demo.FIGURE_ORDER)
    stem = "fig08_thresholds"
    assert cli_demo._draw_figure(str(tmp_path), stem, *recipes[stem]) == stem
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"{stem}.png", f"{stem}.svg"]


def test_demo_workers_must_be_positive(capsys, tmp_path):
    code, out, err = run(capsys, ["demo", "--out", str(tmp_path / "d"), "--workers", "0"])
    assert_one_line_error(code, out, err, "--workers")
    assert not (tmp_path / "d").exists()


def test_compilations_records_compiles_not_cache_loads():
    import numba

    from adavar._jit import compilations

    fresh = numba.njit(lambda v: v + 1)  # never cached: compiles on its first call
    with compilations() as compiled:
        fresh(1)
    assert compiled  # the demo waits for the worker's first realisation then
    with compilations() as compiled:
        fresh(2)  # already compiled in this process
    assert not compiled  # warm: the demo goes straight to the comparison


def test_worker_pool_starts_now_and_can_leave_the_collector_off():
    import gc

    from adavar import _workers

    pool = _workers.worker_pool(2, start=True, collect=False)
    if pool is None:
        pytest.skip("this machine cannot start a second process")
    with pool:
        assert len(pool._processes) == 1  # started before any work was submitted
        assert pool.submit(gc.isenabled).result(timeout=120) is False
    assert _workers.worker_pool(1) is None

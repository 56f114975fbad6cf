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


def test_figures_are_drawn_here_when_the_worker_is_gone():
    from adavar.cli import demo as cli_demo

    class DeadPool:
        def submit(self, *args):
            raise BrokenProcessPool("killed")

    calls = []
    draw = lambda *args: calls.append(args) or ["fig"]  # noqa: E731
    assert cli_demo._submit(DeadPool(), draw, 1, 2) == ["fig"]
    died: Future = Future()
    died.set_exception(BrokenProcessPool("killed during the drawing"))
    assert cli_demo._result_or_here(died, draw, 3) == ["fig"]
    assert calls == [(1, 2), (3,)]
    other: Future = Future()
    other.set_exception(OSError("disk full"))  # a real error is not hidden
    with pytest.raises(OSError, match="disk full"):
        cli_demo._result_or_here(other, draw, 4)


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

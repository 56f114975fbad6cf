"""``adavar demo`` in two processes: the worker's seed study is the one computed here."""

from __future__ import annotations

import json
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool
from functools import partial

import numpy as np
import pytest

from adavar.pipeline import demo

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
    """A worker that runs each job at once (a done future), or whose ``outcome(*args)``
    is an exception: raised by ``submit`` if ``at_submit``, else set on the future."""

    def __init__(self, outcome=None, at_submit=False):
        self.outcome, self.at_submit = outcome, at_submit
        self.calls = []

    def submit(self, func, *args):
        self.calls.append(args)
        result = func(*args) if self.outcome is None else self.outcome(*args)
        if isinstance(result, BaseException) and self.at_submit:
            raise result
        future: Future = Future()
        future.set_running_or_notify_cancel()
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
    # the worker does the first items and then cannot take more: the rest is done here
    done_two = lambda first, count: (  # noqa: E731
        demo._seed_study(first, count) if first < 2021 else BrokenProcessPool("gone")
    )
    half = _FakePool(done_two, at_submit=True)
    _same_study(demo._SharedStudy(half, 2018).result(), whole)
    assert (2018, 1) in half.calls
    # a worker that does everything it reaches, and none at all
    _same_study(demo._SharedStudy(_FakePool(), 2018).result(), whole)
    _same_study(demo._SharedStudy(None, 2018).result(), whole)


def test_a_dead_worker_falls_back_to_this_process(monkeypatch):
    monkeypatch.setattr(demo, "PAPER_SEEDS", 3)
    dead = _FakePool(lambda first, count: BrokenProcessPool("killed"))
    shared = demo._SharedStudy(dead, 2018)
    shared.wait_first()  # no error here: it shows (and is handled) in result()
    _same_study(shared.result(), demo._seed_study(2018, 3))


def test_concatenated_studies_refuse_other_settings():
    from adavar.core.errors import AdavarInputError
    from adavar.paper.studies import compare_seeds, concatenate_seed_studies

    a = demo._seed_study(2018, 1)
    other = compare_seeds(1, [2019], lmin=300)
    with pytest.raises(AdavarInputError, match="same arguments"):
        concatenate_seed_studies([a, other])
    with pytest.raises(AdavarInputError, match="at least one"):
        concatenate_seed_studies([])
    assert concatenate_seed_studies([a]).seeds == (2018,)


def test_shared_jobs_run_here_what_the_worker_cannot():
    from adavar._kernels._workers import SharedJobs

    calls = []
    job = lambda *args: calls.append(args) or sum(args)  # noqa: E731
    # no worker at all, or one that cannot take work: every job here, results in order
    assert SharedJobs(None, job, [(1, 2), (3,)]).results() == [3, 3]
    dead = _FakePool(lambda *args: BrokenProcessPool("killed"), at_submit=True)
    assert SharedJobs(dead, job, [(1,), (2,)]).results() == [1, 2]
    # the worker died during a job: that job and the rest are done here
    calls.clear()
    died = _FakePool(lambda *args: BrokenProcessPool("killed while drawing"))
    assert SharedJobs(died, job, [(10,), (20,), (30,)]).results() == [10, 20, 30]
    assert sorted(calls) == [(10,), (20,), (30,)]
    # a worker that does every job it reaches; each job is run once, by one of the two
    calls.clear()
    pool = _FakePool()
    jobs = [(k,) for k in range(40)]
    assert SharedJobs(pool, job, jobs).results() == list(range(40))
    assert sorted(calls) == jobs  # each job once, by one process or the other
    # a real error in the worker is not hidden
    failing = _FakePool(lambda *args: OSError("disk full"))
    with pytest.raises(OSError, match="disk full"):
        SharedJobs(failing, job, [(1,), (2,)]).results()


def test_demo_figures_longest_first_and_drawn_either_side(tmp_path, monkeypatch):
    from adavar.cli import demo as cli_demo

    monkeypatch.setattr(demo, "PAPER_SEEDS", 1)
    monkeypatch.setattr(demo, "GYRO_SAMPLES", 100_000)  # its figure's recipe all the same
    result = demo.run_demo(keep="figures")
    recipes = cli_demo._figure_recipes(result)
    assert list(recipes) == list(cli_demo.FIGURE_ORDER)
    stem = "fig08_thresholds"
    formats = ("png", "svg")
    assert cli_demo._draw_figure(str(tmp_path), stem, formats, *recipes[stem]) == stem
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"{stem}.png", f"{stem}.svg"]


def test_demo_workers_must_be_positive(capsys, tmp_path):
    code, out, err = run(capsys, ["demo", "--out", str(tmp_path / "d"), "--workers", "0"])
    assert_one_line_error(code, out, err, "--workers")
    assert not (tmp_path / "d").exists()


@pytest.mark.parametrize("value", ["gif", "png,,jpg", "", "none,png"])
def test_demo_bad_figure_formats_are_refused_before_any_work(capsys, tmp_path, value):
    code, out, err = run(capsys, ["demo", "--out", str(tmp_path / "d"), "--figures", value])
    assert_one_line_error(code, out, err, "--figures")
    assert not (tmp_path / "d").exists()


def test_demo_figures_in_the_formats_asked(capsys, tmp_path, monkeypatch):
    monkeypatch.setattr(demo, "run_demo", partial(demo.run_demo, paper=False))
    monkeypatch.setattr(demo, "GYRO_SAMPLES", 100_000)  # the same files
    out_dir = tmp_path / "d"
    argv = ["demo", "--out", str(out_dir), "--workers", "1", "--figures", "pdf", "--json"]
    code, out, err = run(capsys, argv)
    assert code == 0, err
    files = json.loads(out)["out"]["files"]
    assert files == ["gyro_oadev.pdf", "demo.json", "report.html"]
    assert (out_dir / "gyro_oadev.pdf").read_bytes().startswith(b"%PDF")
    assert not list(out_dir.glob("*.png")) and not list(out_dir.glob("*.svg"))


def test_compilations_records_compiles_not_cache_loads():
    import numba

    from adavar._kernels._jit import compilations

    fresh = numba.njit(lambda v: v + 1)  # never cached: compiles on its first call
    with compilations() as compiled:
        fresh(1)
    assert compiled  # the demo waits for the worker's first realisation then
    with compilations() as compiled:
        fresh(2)  # already compiled in this process
    assert not compiled  # warm: the demo goes straight to the comparison


def test_worker_pool_starts_now_and_preloads():
    from adavar._kernels import _workers

    pool = _workers.worker_pool(2, ("adavar.core.units",), start=True)
    if pool is None:
        pytest.skip("this machine cannot start a second process")
    with pool:
        assert len(pool._processes) == 1  # started before any work was submitted
        loaded = pool.submit(eval, "'adavar.core.units' in __import__('sys').modules")
        assert loaded.result(timeout=120) is True
    assert _workers.worker_pool(1) is None


def test_partial_files_of_a_killed_writer_are_removed(tmp_path):
    # a worker killed while it wrote leaves its temporary; the folder is put in place
    # without it (the job was redone by the other process)
    from adavar.io.writers import atomic_directory, partial_name

    out = tmp_path / "out"
    with atomic_directory(out) as tmp:
        (tmp / "fig10_controller.png").write_bytes(b"\x89PNG whole")
        partial_name(tmp / "fig10_controller.png").write_bytes(b"\x89PNG half")
        (tmp / ".keep.tmp").write_text("not a writer's temporary")
    names = sorted(p.name for p in out.iterdir())
    assert [n for n in names if n.endswith(".tmp")] == [".keep.tmp"]
    assert "fig10_controller.png" in names

"""A first run's helper process that compiles the stages a command needs last (issue 15)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time

import pytest

from adavar import _compile_ahead as ahead
from adavar import _jit

# In a fresh interpreter on the (warm) cache: every stage's recipe, then the command in
# this process. A kernel of a stage that the command needs in a signature the recipes did
# not produce would be loaded or compiled anew: its signature count would grow.
_SAME_SIGNATURES = r"""
import importlib, json, sys
import numpy as np
from adavar import _compile_ahead as ahead, simulate
from adavar.cli import main

def signatures():
    out = {}
    for stage, (_recipe, kernels) in ahead.STAGES.items():
        for module, name in kernels:
            kernel = getattr(importlib.import_module(module), name)
            out[f"{module}.{name}"] = len(getattr(kernel, "kernel", kernel).signatures)
    return out

for recipe, _kernels in ahead.STAGES.values():
    recipe()
before = signatures()
# what users have: a bandwidth-limited, quantised gyro at 200 Hz, two minutes
x = simulate.sensor(24000, rate=200.0, bandwidth=50.0, lsb=1e-4, seed=3,
                    angle_random_walk=3e-3, bias_instability=5e-4, rate_random_walk=1e-4)
path = sys.argv[1] + "/gyro.csv"
np.savetxt(path, np.column_stack([np.arange(x.size) / 200.0, x]), delimiter=",",
           header="time,x", comments="")
codes = [main(["davar", path, "--units", "deg/s", "--window", "10s", "--json"]),
         main(["adaptive", path, "--units", "deg/s", "--lmax", "2000", "--lmin", "1000",
               "--json"]),
         main(["compare", "--scenario", "1", "--json"])]
print(json.dumps({"codes": codes, "before": before, "after": signatures()}), file=sys.stderr)
"""


def test_the_recipes_compile_the_signatures_the_commands_use(tmp_path):
    env = {**os.environ, "ADAVAR_COMPILE_AHEAD": "0"}
    done = subprocess.run([sys.executable, "-c", _SAME_SIGNATURES, str(tmp_path)],
                          capture_output=True, text=True, env=env, check=False)  # fmt: skip
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stderr.strip().splitlines()[-1])
    assert report["codes"] == [0, 0, 0]
    assert all(count >= 1 for count in report["before"].values()), report["before"]
    assert report["after"] == report["before"]


class _Process:
    """A stand-in for the helper process: running until ``alive`` is cleared."""

    def __init__(self) -> None:
        self.alive = True

    def poll(self) -> int | None:
        return None if self.alive else 0


def _func(module: str, name: str):
    def f():
        return None

    f.__module__, f.__name__ = module, name
    return f


def test_a_kernel_the_helper_has_not_started_is_compiled_here_and_skipped_there(tmp_path):
    helper = ahead._Helper(_Process(), ["fit", "controller"], str(tmp_path))
    assert not helper.before_compiling(_func("adavar.controller", "_reconcile"))
    # another kernel of the same stage: still this process's, not waited for
    assert not helper.before_compiling(_func("adavar.controller", "_speculate"))
    # a function of no stage, and one of a stage's name in another module: not claimed
    assert not helper.before_compiling(_func("adavar.statistics", "deviation"))
    assert not helper.before_compiling(_func("adavar.window_hvar", "nnls_blocks"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["1.claim"]
    # the helper then skips the stage this process took, and takes the other
    ran = []
    stages = {name: (lambda name=name: ran.append(name), kernels)
              for name, (_recipe, kernels) in ahead.STAGES.items()}  # fmt: skip
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(ahead, "STAGES", stages)
        mp.setattr(ahead, "stage_cached", lambda stage: False)
        ahead.compile_stages(["fit", "controller"], str(tmp_path))
    assert ran == ["fit"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["0.claim", "0.done", "1.claim"]


def test_a_kernel_the_helper_is_compiling_is_waited_for(tmp_path):
    process = _Process()
    helper = ahead._Helper(process, ["fit"], str(tmp_path))
    assert ahead._Claims(str(tmp_path)).claim(0)  # the helper's
    threading.Timer(0.2, ahead._Claims(str(tmp_path)).finish, (0,)).start()
    t = time.perf_counter()
    assert helper.before_compiling(_func("adavar._nnls", "nnls_blocks"))  # load it now
    assert time.perf_counter() - t >= 0.15
    # a helper that has ended is not waited for (a load is tried, then it compiles here)
    helper = ahead._Helper(process, ["controller"], str(tmp_path / "x"))
    (tmp_path / "x").mkdir()
    assert ahead._Claims(str(tmp_path / "x")).claim(0)
    process.alive = False
    t = time.perf_counter()
    assert helper.before_compiling(_func("adavar.controller", "_speculate"))
    assert time.perf_counter() - t < 0.1
    # once the helper has removed its folder as it ended, every stage is this process's
    helper = ahead._Helper(process, ["fit"], str(tmp_path / "gone"))
    assert not helper.before_compiling(_func("adavar._nnls", "nnls_blocks"))


def test_the_helper_skips_cached_stages_and_marks_every_stage_done(monkeypatch, tmp_path):
    ran = []
    stages = {name: (lambda name=name: ran.append(name), kernels)
              for name, (_recipe, kernels) in ahead.STAGES.items()}  # fmt: skip
    monkeypatch.setattr(ahead, "STAGES", stages)
    monkeypatch.setattr(ahead, "stage_cached", lambda stage: stage == "deviation")
    ahead.compile_stages(["controller", "deviation", "surface"], str(tmp_path))
    assert ran == ["controller", "surface"]
    assert all((tmp_path / f"{k}.done").exists() for k in range(3))


@pytest.mark.parametrize("env", [{"ADAVAR_COMPILE_AHEAD": "0"}, {"ADAVAR_THREADS": "1"}])
def test_no_helper_when_switched_off_or_on_one_thread(monkeypatch, env):
    monkeypatch.setattr(ahead, "stage_cached", lambda stage: False)
    monkeypatch.delenv("ADAVAR_COMPILE_AHEAD", raising=False)
    for key, value in env.items():
        monkeypatch.setenv(key, value)
    assert ahead.start(["fit"]) is None
    assert _jit.BEFORE_COMPILING is None


def test_no_helper_when_every_stage_is_cached(monkeypatch):
    monkeypatch.setenv("ADAVAR_COMPILE_AHEAD", "1")
    monkeypatch.setattr(ahead, "stage_cached", lambda stage: True)
    assert ahead.start(["controller", "fit", "surface"]) is None
    assert _jit.BEFORE_COMPILING is None


def test_the_helper_starts_and_stops_with_the_command(monkeypatch):
    monkeypatch.setenv("ADAVAR_COMPILE_AHEAD", "1")
    monkeypatch.setattr(ahead, "_wanted", lambda: True)
    monkeypatch.setattr(ahead, "stage_cached", lambda stage: False)
    helper = ahead.start(["fit"])
    assert helper is not None and helper.process.poll() is None
    try:
        assert _jit.BEFORE_COMPILING == helper.before_compiling
        assert ahead.start(["fit"]) is None  # one helper at a time
    finally:
        ahead.stop(helper)
    assert helper.process.poll() is not None and _jit.BEFORE_COMPILING is None
    assert not os.path.exists(helper.folder)


_NO_GUARD = r"""
import sys
from adavar import _compile_ahead as ahead
with open(sys.argv[1], "a") as log:  # a script without a __main__ guard
    log.write("ran\n")
ahead.stage_cached = lambda stage: False
helper = ahead.start(["fit"])
helper.process.wait(timeout=120)
print("helper exit", helper.process.returncode, flush=True)
ahead.stop(helper)
"""


def test_the_helper_does_not_run_the_callers_script_again_and_says_nothing(tmp_path):
    script, log = tmp_path / "no_guard.py", tmp_path / "log.txt"
    script.write_text(_NO_GUARD)
    env = {**os.environ, "ADAVAR_COMPILE_AHEAD": "1"}
    done = subprocess.run([sys.executable, str(script), str(log)], capture_output=True,
                          text=True, env=env, check=False, timeout=180)  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout == "helper exit 0\n" and done.stderr == ""
    assert log.read_text() == "ran\n"


@pytest.fixture(scope="module")
def gyro_csv(tmp_path_factory):
    import numpy as np

    from adavar import simulate

    x = simulate.sensor(6000, rate=100.0, bandwidth=20.0, lsb=1e-4, seed=5,
                        angle_random_walk=3e-3, bias_instability=5e-4)  # fmt: skip
    path = tmp_path_factory.mktemp("ahead") / "gyro.csv"
    np.savetxt(path, np.column_stack([np.arange(x.size) / 100.0, x]), delimiter=",",
               header="time,x", comments="")  # fmt: skip
    return path


@pytest.mark.parametrize(("argv", "stages"), [
    (["davar", "--window", "10s"], ["controller", "fit", "surface"]),
    (["davar", "--window", "10s", "--confidence", "none"], ["surface"]),
    (["davar", "--window", "10s", "--stat", "mvar"], []),
    (["adaptive", "--lmax", "1000", "--lmin", "500"], ["fit", "surface", "deviation"]),
    (["davar", "--window", "1000s"], ["controller", "fit", "surface"]),  # a user error
    (["report", "--window", "10s"], ["controller", "fit", "surface"]),
    (["report", "--adaptive", "--lmax", "1000", "--lmin", "500"],
     ["fit", "surface", "controller"]),
    (["report"], None),  # the whole record only: no helper
    (["compare", "--change-times", "30"], ["kurtosis", "controller", "fit", "surface"]),
])  # fmt: skip
def test_the_commands_ask_for_the_stages_they_reach_last_and_stop_the_helper(
    monkeypatch, capsys, tmp_path, gyro_csv, argv, stages
):
    from adavar.cli import main

    asked, stopped = [], []
    monkeypatch.setattr(ahead, "start", lambda wanted: asked.append(list(wanted)) or "helper")
    monkeypatch.setattr(ahead, "stop", stopped.append)
    out = ["-o", str(tmp_path / "r.html")] if argv[0] == "report" else ["--json"]
    if argv[0] == "compare":
        out += ["--lmax", "1000", "--lmin", "500", "--l", "100", "--taus", "octave"]
    code = main([argv[0], str(gyro_csv), "--units", "deg/s", *argv[1:], *out])
    assert code == (2 if "1000s" in argv else 0), capsys.readouterr().err
    # stopped after an error too
    assert asked == ([] if stages is None else [stages])
    assert stopped == [None if stages is None else "helper"]


_DEAF = r"""
import sys, time
from adavar import _compile_ahead as ahead
ahead.STAGES = {"x": (lambda: time.sleep(1.5), ())}
ahead.stage_cached = lambda stage: False
print("ready", flush=True)
ahead._helper_main(None, ["x"])
"""


def test_the_helper_leaves_ctrl_c_to_the_command():
    import signal

    process = subprocess.Popen([sys.executable, "-c", _DEAF], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)  # fmt: skip
    assert process.stdout.readline().strip() == "ready"
    time.sleep(0.5)
    process.send_signal(signal.SIGINT)  # what a terminal's Ctrl-C sends the whole group
    out, err = process.communicate(timeout=30)
    assert process.returncode == 0 and out == "" and err == ""


_KILLED = r"""
import os, signal, sys, time
from adavar import _compile_ahead as ahead
helper = ahead.start(["controller", "fit"])  # an empty cache: seconds of work each
while not os.path.exists(os.path.join(helper.folder, "0.claim")):
    time.sleep(0.01)
print(helper.process.pid, helper.folder, flush=True)
os.kill(os.getpid(), signal.SIGKILL)  # no finally, no stop()
"""


def _ended(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] in ("Z", "X")
    except FileNotFoundError:
        return True


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG: Linux")
def test_a_killed_command_takes_its_helper_and_folder_with_it(tmp_path):
    env = {**os.environ, "ADAVAR_COMPILE_AHEAD": "1", "NUMBA_CACHE_DIR": str(tmp_path)}
    done = subprocess.run([sys.executable, "-c", _KILLED], capture_output=True, text=True,
                          env=env, check=False, timeout=120)  # fmt: skip
    assert done.returncode == -9, done.stderr
    pid, folder = done.stdout.split()
    deadline = time.perf_counter() + 3.0  # its two stages take several seconds more
    while not _ended(int(pid)) and time.perf_counter() < deadline:
        time.sleep(0.02)
    assert _ended(int(pid))
    time.sleep(0.2)
    assert not os.path.exists(folder)

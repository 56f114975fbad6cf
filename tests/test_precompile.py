"""``adavar precompile``: the stages compile the signatures the commands use."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from adavar.pipeline.precompile import STAGES, precompile
from tests.cli_helpers import run

# In a fresh interpreter: every stage, then the commands in this process. A kernel that a
# command needs in a signature no stage produced would be compiled (or loaded) anew: the
# signature count of some kernel would grow.
_SAME_SIGNATURES = r"""
import json, sys
import numpy as np
from adavar import simulate
from adavar.cli import main
from adavar.pipeline.precompile import precompile

def signatures():
    out = {}
    for name, module in list(sys.modules.items()):
        if not name.startswith("adavar"):
            continue
        for attr, value in list(vars(module).items()):
            kernel = getattr(value, "kernel", value)  # a ThreadedKernel's dispatcher
            if hasattr(kernel, "signatures") and hasattr(kernel, "py_func"):
                out[f"{name}.{attr}"] = len(kernel.signatures)
    return out

precompile()
before = signatures()
# what users have: a bandwidth-limited, quantised gyro at 200 Hz, two minutes
x = simulate.sensor(24000, rate=200.0, bandwidth=50.0, lsb=1e-4, seed=3,
                    angle_random_walk=3e-3, bias_instability=5e-4, rate_random_walk=1e-4)
path = sys.argv[1] + "/gyro.csv"
np.savetxt(path, np.column_stack([np.arange(x.size) / 200.0, x]), delimiter=",",
           header="time,x", comments="")
codes = [main(["avar", path, "--units", "deg/s", "--fit", "--json"]),
         main(["davar", path, "--units", "deg/s", "--window", "10s", "--json"]),
         main(["adaptive", path, "--units", "deg/s", "--lmax", "2000", "--lmin", "1000",
               "--json"]),
         main(["compare", "--scenario", "1", "--json"])]
after = signatures()
grown = {k: (before.get(k, 0), v) for k, v in after.items() if v > before.get(k, 0)}
print(json.dumps({"codes": codes, "kernels": len(before), "grown": grown}), file=sys.stderr)
"""


def test_the_stages_compile_every_signature_the_commands_use(tmp_path):
    done = subprocess.run([sys.executable, "-c", _SAME_SIGNATURES, str(tmp_path)],
                          capture_output=True, text=True, env=dict(os.environ),
                          check=False, cwd=str(tmp_path))  # fmt: skip
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stderr.strip().splitlines()[-1])
    assert report["codes"] == [0, 0, 0, 0]
    assert report["kernels"] > 40  # the stages reached the kernels at all
    assert report["grown"] == {}


def test_a_second_run_compiles_nothing_and_says_what_it_did():
    first = precompile(["streamed"])
    again = precompile(["streamed"])
    assert again.stages == ("streamed",) and again.compiled == 0
    assert first.seconds >= 0 and again.seconds >= 0


def test_bad_requests_are_errors():
    with pytest.raises(ValueError, match="unknown stage 'surfaces'"):
        precompile(["surfaces"])
    with pytest.raises(ValueError, match="workers"):
        precompile(["streamed"], workers=0)


def test_the_command(capsys):
    code, out, err = run(capsys, ["precompile", "--stages", "streamed,gaps", "--json",
                                  "--workers", "1"])  # fmt: skip
    assert code == 0, err
    payload = json.loads(out)
    assert payload["stages"] == ["gaps", "streamed"]  # in the module's order
    assert payload["compiled"] >= 0 and payload["seconds"] >= 0
    code, out, err = run(capsys, ["precompile", "--stages", "surfaces"])
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "unknown stage 'surfaces'" in err
    assert set(STAGES) >= {"deviation", "surface", "controller", "large"}

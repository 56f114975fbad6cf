"""The thread setting of the parallel kernels (issue 15)."""

from __future__ import annotations

import os
import subprocess
import sys


def _run(code: str, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**os.environ, **env}, check=False)  # fmt: skip


def test_adavar_threads_sets_the_kernels_threads_and_waits_passively():
    done = _run("import os, numba, adavar.statistics; "
                "print(numba.get_num_threads(), os.environ['OMP_WAIT_POLICY'])",
                ADAVAR_THREADS="1")  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["1", "PASSIVE"]


def test_a_bad_thread_setting_is_a_one_line_error_on_the_command_line(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("x\n" + "".join(f"{(k * 7919) % 101 / 100}\n" for k in range(200)))
    code = (
        "import sys; from adavar.cli import main; "
        f"sys.exit(main(['avar', {str(path)!r}, '--rate', '1', '--units', 'deg/s']))"
    )
    done = _run(code, ADAVAR_THREADS="many")
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "ADAVAR_THREADS='many'" in lines[0], done.stderr

"""Files that change, vanish or are not plain files while adavar reads them (issue 40).

A record is never analysed half old, half new: a file whose size, modification time or
identity changes while it is read (text read in blocks, a ``.npy`` read piece by piece by
an out-of-core run) is an error naming it, as is one deleted meanwhile; the command line
never reads a ``.npy`` through a memory map, whose pages past the end of a file cut short
kill the process with SIGBUS. A named pipe, a symbolic link loop or a link to nothing is
an error at once, not a wait or "no such file".
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from adavar import readers
from adavar.core.errors import AdavarInputError
from adavar.io.sources import NpyFileSource
from adavar.readers import read_record, textscan
from adavar.stats.statistics import deviation

from .cli_helpers import assert_one_line_error, run

CHANGED = "changed while being read"


@pytest.fixture()
def text_file(tmp_path):
    x = np.random.default_rng(4).standard_normal(40_000)
    path = tmp_path / "x.csv"
    np.savetxt(path, x, fmt="%.9f")
    return path


def _after_first_part(monkeypatch, action):
    """Run ``action`` once, when the text reader has read its first block part (blocks of
    16 KiB, so that the file is read in many)."""
    monkeypatch.setattr(textscan, "BLOCK", 16 << 10)
    original = textscan._read_part
    done = []

    def wrapped(*args, **kwargs):
        parsed = original(*args, **kwargs)
        if not done:
            done.append(True)
            action()
        return parsed

    monkeypatch.setattr(textscan, "_read_part", wrapped)


def test_a_text_file_truncated_while_read_is_an_error(monkeypatch, text_file):
    # before: 0 to all of the rows, without a word (4.1 M of 12 M in the issue)
    size = text_file.stat().st_size
    _after_first_part(monkeypatch, lambda: os.truncate(text_file, size // 3))
    with pytest.raises(AdavarInputError, match=CHANGED) as info:
        read_record(text_file, rate=100.0)
    message = str(info.value)
    assert f"size {size} -> {size // 3} bytes" in message
    assert "copy it first, or wait until its writer is done" in message


def test_a_text_file_appended_to_while_read_is_an_error(monkeypatch, text_file):
    def append():
        with open(text_file, "a") as fh:
            fh.write("1.5\n" * 1000)

    _after_first_part(monkeypatch, append)
    with pytest.raises(AdavarInputError, match=CHANGED):
        read_record(text_file, rate=100.0)


def test_a_file_deleted_while_read_is_an_error(monkeypatch, text_file):
    # before: "internal error: FileNotFoundError" (exit 1)
    original = textscan.read_columns

    def deleting(path, *args, **kwargs):
        os.remove(path)
        return original(path, *args, **kwargs)

    monkeypatch.setattr("adavar.readers.text.read_columns", deleting)
    with pytest.raises(AdavarInputError, match="deleted or moved while being read"):
        read_record(text_file, rate=100.0)


def test_the_command_line_exits_2_on_a_file_changed_while_read(capsys, monkeypatch, text_file):
    size = text_file.stat().st_size
    _after_first_part(monkeypatch, lambda: os.truncate(text_file, size // 2))
    code, out, err = run(capsys, ["avar", str(text_file), "--rate", "100", "--units", "deg/s"])
    assert_one_line_error(code, out, err, "x.csv", CHANGED)


def test_a_file_read_whole_before_it_changes_is_fine(tmp_path):
    path = tmp_path / "x.csv"
    np.savetxt(path, np.arange(100.0))
    record = read_record(path, rate=1.0)
    with open(path, "a") as fh:
        fh.write("5\n")
    assert record.n_samples == 100  # the samples read are what the file held


# ---------------------------------------------------------------------------------------
# .npy read piece by piece


def _npy(tmp_path, n=50_000):
    path = tmp_path / "x.npy"
    np.save(path, np.random.default_rng(5).standard_normal(n))
    return path


def _change_after_first_read(monkeypatch, action):
    original = NpyFileSource._read_raw
    calls = []

    def wrapped(self, start, stop):
        out = original(self, start, stop)
        if not calls:
            calls.append(True)
            action(self.path)
        return out

    monkeypatch.setattr(NpyFileSource, "_read_raw", wrapped)


def test_a_npy_truncated_during_a_chunked_run_is_an_error(monkeypatch, tmp_path):
    # the library's own memory map (np.load(mmap_mode="r")) is read with file reads
    path = _npy(tmp_path)
    _change_after_first_read(monkeypatch, lambda p: os.truncate(p, 2000))
    with pytest.raises(AdavarInputError, match=CHANGED):
        deviation(np.load(path, mmap_mode="r"), rate=10.0, chunk_size=4096)


def test_a_npy_rewritten_in_place_during_a_chunked_run_is_an_error(monkeypatch, tmp_path):
    # the same size, other samples: before, the record was silently half old, half new
    path = _npy(tmp_path)

    def rewrite(p):
        st = os.stat(p)
        with open(p, "r+b") as fh:
            fh.seek(st.st_size - 8000)
            fh.write(np.zeros(1000).tobytes())
        os.utime(p, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))

    _change_after_first_read(monkeypatch, rewrite)
    with pytest.raises(AdavarInputError, match=CHANGED):
        deviation(np.load(path, mmap_mode="r"), rate=10.0, chunk_size=4096)


def test_the_command_line_never_reads_a_npy_through_a_map(capsys, monkeypatch, tmp_path):
    path = _npy(tmp_path)
    seen = []
    original = read_record

    def spying(*args, **kwargs):
        record = original(*args, **kwargs)
        seen.extend(record.channels.values())
        return record

    monkeypatch.setattr(readers, "read_record", spying)
    code, _, err = run(capsys, ["davar", str(path), "--rate", "10", "--units", "deg/s",
                                "--window", "2001", "--step", "997", "--chunk-size",
                                "4096"])  # fmt: skip
    assert code == 0, err
    assert seen and all(isinstance(v, NpyFileSource) for v in seen)
    assert not any(isinstance(v, np.memmap) for v in seen)


@pytest.mark.parametrize("command", [["avar"], ["davar", "--window", "301"]])
def test_missing_samples_of_a_npy_still_stream_under_gaps_omit(capsys, tmp_path, command):
    # read with file reads as before through the map: streamed until the first NaN, then
    # read into memory (a note says so), and no events where a sample is missing
    import json

    x = np.random.default_rng(6).standard_normal(3000)
    x[1500] = np.nan
    np.save(tmp_path / "x.npy", x)
    code, out, err = run(capsys, [command[0], str(tmp_path / "x.npy"), *command[1:], "--rate",
                                  "1", "--units", "deg/s", "--gaps", "omit", "--json"])  # fmt: skip
    assert code == 0, err
    assert "x.npy holds missing samples: it was read into memory" in json.loads(out)["notes"]


_SCRIPT = """
import importlib, os, sys
from adavar.cli import main

module = importlib.import_module("adavar.{module}")

path, argv = sys.argv[1], sys.argv[2:]
original = module.{function}

def truncating(*args, **kwargs):  # the file is cut short once this step is done
    out = original(*args, **kwargs)
    os.truncate(path, 1000)
    return out

module.{function} = truncating
sys.exit(main([argv[0], path, *argv[1:]]))
"""

#: (module, function after which the file is cut short, command)
_SIGBUS_RUNS = {
    # the events' check of a fixed window read the map: davar --chunk-size (the issue)
    "davar": ("dynamic.surface", "davar", ["davar", "--rate", "10", "--units", "deg/s", "--window",
                                 "2001", "--step", "997", "--chunk-size", "4096"]),
    # preprocessing loaded the record through the map
    "preprocess": ("readers", "read_record", ["avar", "--rate", "10", "--units", "deg/s",
                                              "--preprocess", "mean"]),
}  # fmt: skip


@pytest.mark.skipif(not hasattr(signal, "SIGBUS"), reason="SIGBUS is POSIX")
@pytest.mark.parametrize("case", list(_SIGBUS_RUNS))
def test_a_npy_truncated_under_the_command_line_is_exit_2_not_sigbus(tmp_path, case):
    # before: exit 135 (SIGBUS: a memory map read past the file's new end), nothing on
    # stderr
    module, function, argv = _SIGBUS_RUNS[case]
    path = _npy(tmp_path, 100_000)
    script = textwrap.dedent(_SCRIPT).format(module=module, function=function)
    proc = subprocess.run(
        [sys.executable, "-c", script, str(path), *argv],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    assert "x.npy" in proc.stderr and CHANGED in proc.stderr


# ---------------------------------------------------------------------------------------
# not plain files


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_a_named_pipe_is_refused_at_once(tmp_path):
    # before: open() waited for a writer, forever
    fifo = tmp_path / "stream.csv"
    os.mkfifo(fifo)

    def stuck(*_):
        raise TimeoutError("read_record waited on the pipe")

    previous = signal.signal(signal.SIGALRM, stuck)
    signal.alarm(10)
    try:
        with pytest.raises(AdavarInputError, match="named pipe") as info:
            read_record(fifo, rate=1.0)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert "adavar monitor" in str(info.value)


def test_a_symbolic_link_loop_is_named(tmp_path):
    # before: "no such file: check the path"
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    os.symlink(b, a)
    os.symlink(a, b)
    with pytest.raises(AdavarInputError, match="symbolic link loop"):
        read_record(a, rate=1.0)


def test_a_link_to_nothing_names_its_target(tmp_path):
    link = tmp_path / "x.csv"
    os.symlink(tmp_path / "gone.csv", link)
    with pytest.raises(AdavarInputError, match=r"symbolic link to .*gone\.csv, which does not"):
        read_record(link, rate=1.0)


def test_a_missing_file_is_still_no_such_file(tmp_path):
    with pytest.raises(AdavarInputError, match="no such file"):
        read_record(tmp_path / "nothing.csv", rate=1.0)

"""The CLI on records read piece by piece: memory-mapped .npy, lazy HDF5 and Parquet.

The library's out-of-core paths are compared with the in-memory ones in
tests/test_stream_*.py; here the commands must route file-backed records through them
(never loading the record) and print the same numbers as for the same data in a CSV.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from adavar.stats import stream

from .cli_helpers import assert_one_line_error, run

N = 30_000


@pytest.fixture(scope="module")
def signal():
    rng = np.random.default_rng(11)
    x = rng.standard_normal(N)
    x[N // 2 :] *= 2.5  # a change, so the adaptive window moves
    return (x + 1e3).astype(np.float32)  # float32 and an offset, as a logger writes them


@pytest.fixture()
def files(tmp_path, signal):
    h5py = pytest.importorskip("h5py")
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    np.save(tmp_path / "x.npy", signal)
    np.save(tmp_path / "imu.npy", np.stack([signal, -signal, 2 * signal], axis=1))
    np.savetxt(tmp_path / "x.csv", signal.astype(np.float64), fmt="%.17g")
    with h5py.File(tmp_path / "x.h5", "w") as f:
        f["gyro"] = signal
    pq.write_table(pa.table({"gx": signal}), tmp_path / "x.parquet", row_group_size=7000)
    return tmp_path


def _json(capsys, argv):
    code, out, err = run(capsys, [*argv, "--json"])
    assert code == 0, err
    return json.loads(out)


def _numbers(payload, key):
    return np.array([np.nan if v is None else v for v in np.ravel(payload[key])], dtype=float)


COMMANDS = {
    "avar": ["avar", "--rate", "10", "--units", "deg/s", "--fit"],
    "davar": ["davar", "--rate", "10", "--units", "deg/s", "--window", "3001", "--step",
              "997", "--taus", "0.1,1,10,100"],
    "adaptive": ["adaptive", "--rate", "10", "--units", "deg/s", "--step", "997",
                 "--taus", "0.1,1,10"],
}  # fmt: skip


def _counting_reads(monkeypatch):
    """The sizes of the pieces the analyses read through ``ChunkedSource.read``."""
    sizes = []
    original = stream.ChunkedSource.read

    def counting(self, start, stop):
        sizes.append(stop - start)
        return original(self, start, stop)

    monkeypatch.setattr(stream.ChunkedSource, "read", counting)
    return sizes


@pytest.fixture(scope="module")
def csv_runs(tmp_path_factory, signal):
    """Each of COMMANDS' JSON on the signal as a CSV (in memory), run once for the three
    file-backed sources it is compared with."""
    path = tmp_path_factory.mktemp("csv") / "x.csv"
    np.savetxt(path, signal.astype(np.float64), fmt="%.17g")
    out = {}
    with pytest.MonkeyPatch.context() as monkeypatch:
        sizes = _counting_reads(monkeypatch)
        for command, argv in COMMANDS.items():
            code, text, err = _cli([argv[0], str(path), *argv[1:], "--json"])
            assert code == 0, err
            out[command] = json.loads(text)
        assert not sizes  # the CSV is in memory: the in-memory path
    return out


def _cli(argv):
    """Exit code, stdout and stderr of ``adavar ARGV`` in this process (any fixture scope)."""
    import contextlib
    import io

    from adavar import cli

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(argv)
    return code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize("command", list(COMMANDS))
@pytest.mark.parametrize("source", ["x.npy", "x.h5", "x.parquet"])
def test_file_backed_records_match_the_csv_run(capsys, files, monkeypatch, csv_runs, command,
                                               source):  # fmt: skip
    # count how the analyses read: piece by piece, never the whole record at once
    sizes = _counting_reads(monkeypatch)
    argv = COMMANDS[command]
    lazy = [] if source.endswith(".npy") else ["--lazy"]
    got = _json(capsys, [argv[0], str(files / source), *argv[1:], *lazy,
                         "--chunk-size", "4096"])  # fmt: skip
    assert sizes and max(sizes) < N  # read in pieces
    want = csv_runs[command]
    if command == "avar":
        np.testing.assert_allclose(_numbers(got, "dev"), _numbers(want, "dev"), rtol=1e-12)
        assert got["alpha"] == want["alpha"]
        assert _close(got["fit"], want["fit"])
    else:
        assert (got["shape"], got["time"], got["m"], got["alpha"]) == (
            want["shape"], want["time"], want["m"], want["alpha"]
        )  # fmt: skip
        assert _close(got["fit"], want["fit"])


def _close(a, b):
    """Nested JSON equal up to 1e-9 relative in the numbers."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(_close(u, v) for u, v in zip(a, b, strict=True))
    if isinstance(a, float) and isinstance(b, float):
        return a == pytest.approx(b, rel=1e-9, abs=1e-300)
    return a == b


def test_a_column_of_a_2d_npy_is_streamed(capsys, files, signal):
    got = _json(capsys, ["avar", str(files / "imu.npy"), "--column", "2", "--rate", "10",
                         "--units", "deg/s"])  # fmt: skip
    want = _json(capsys, ["avar", str(files / "x.csv"), "--rate", "10", "--units", "deg/s"])
    np.testing.assert_allclose(_numbers(got, "dev"), 2 * _numbers(want, "dev"), rtol=1e-12)


def test_preprocessing_loads_the_record_and_still_works(capsys, files):
    got = _json(capsys, ["avar", str(files / "x.npy"), "--rate", "10", "--units", "deg/s",
                         "--preprocess", "detrend:1"])  # fmt: skip
    want = _json(capsys, ["avar", str(files / "x.csv"), "--rate", "10", "--units", "deg/s",
                          "--preprocess", "detrend:1"])  # fmt: skip
    np.testing.assert_allclose(_numbers(got, "dev"), _numbers(want, "dev"), rtol=1e-9)


def test_a_nan_deep_in_a_lazy_file_is_a_one_line_error(capsys, tmp_path):
    h5py = pytest.importorskip("h5py")
    x = np.random.default_rng(0).standard_normal(20_000)
    x[15_321] = np.nan
    with h5py.File(tmp_path / "bad.h5", "w") as f:
        f["gyro"] = x
    code, out, err = run(capsys, ["davar", str(tmp_path / "bad.h5"), "--rate", "1", "--units",
                                  "deg/s", "--window", "601", "--lazy", "--out",
                                  str(tmp_path / "o")])  # fmt: skip
    assert_one_line_error(code, out, err, "sample 15321", "nan")
    assert not (tmp_path / "o").exists()


def test_lazy_with_a_time_column_is_refused(capsys, tmp_path):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    pq.write_table(pa.table({"time": np.arange(2000) / 10, "gx": np.ones(2000)}),
                   tmp_path / "t.parquet")  # fmt: skip
    code, out, err = run(capsys, ["avar", str(tmp_path / "t.parquet"), "--units", "deg/s",
                                  "--lazy"])  # fmt: skip
    assert_one_line_error(code, out, err, "time column", "--lazy")


@pytest.mark.parametrize("extra", [[], ["--window", "3001"], ["--adaptive"]])
def test_report_of_a_file(capsys, tmp_path, signal, monkeypatch, extra):
    """report reads a .npy piece by piece (issue 42), its surfaces too (a block of
    windows at a time), fixed or adaptive."""
    np.save(tmp_path / "x.npy", signal)
    sizes = []
    original = stream.ChunkedSource.read

    def counting(self, start, stop):
        sizes.append(stop - start)
        return original(self, start, stop)

    monkeypatch.setattr(stream.ChunkedSource, "read", counting)
    code, _, err = run(capsys, ["report", str(tmp_path / "x.npy"), "--rate", "10",
                                  "--units", "deg/s", *extra,
                                  "-o", str(tmp_path / "r.html")])  # fmt: skip
    assert code == 0, err
    assert (tmp_path / "r.html").stat().st_size > 100_000
    # streamed, the analyses read the file again and again; loaded, once
    assert len(sizes) > 1, sizes


def _traced_growth(capsys, tmp_path, argv, out_flag, seed, suffix=""):
    """Bytes a sample by which the traced peak of ``adavar ARGV FILE ... OUT_FLAG OUT``
    grows from a 1 Mi- to a 2 Mi-sample float32 ``.npy`` (``FILE`` in ``argv``: the file;
    ``suffix``: of the output's name)."""
    import tracemalloc

    peaks = []
    sizes = (1 << 20, 2 << 20)
    for n in sizes:
        path = tmp_path / f"big{n}.npy"
        np.save(path, np.random.default_rng(seed).standard_normal(n).astype(np.float32))
        command = [str(path) if a == "FILE" else a for a in argv]
        if not peaks:  # the kernels compiled before anything is traced
            assert run(capsys, [*command, out_flag, str(tmp_path / f"warm{suffix}")])[0] == 0
        tracemalloc.start()
        try:
            code, _, err = run(capsys, [*command, out_flag, str(tmp_path / f"out{n}{suffix}")])
            peaks.append(tracemalloc.get_traced_memory()[1])
        finally:
            tracemalloc.stop()
        assert code == 0, err
    return (peaks[1] - peaks[0]) / (sizes[1] - sizes[0]), peaks


def test_davar_of_a_file_holds_pieces_not_the_record(capsys, tmp_path):
    """Issue 42: `adavar davar` on a .npy kept the change test's outputs at every centre
    (35 bytes a sample: 10.7 GB for 2e8 samples). Scaled down with --chunk-size: the traced
    peak grows by less than a byte a sample from 1 Mi to 2 Mi samples (the correlation
    estimate on the first 2**20 samples is a constant)."""
    argv = ["davar", "FILE", "--rate", "1", "--units", "deg/s", "--window", "6001",
            "--step", "100000", "--taus", "1,10,100", "--chunk-size", "65536",
            "--figures", "none"]  # fmt: skip
    growth, peaks = _traced_growth(capsys, tmp_path, argv, "--out", seed=4)
    assert growth < 1.0, (growth, peaks)  # before: more than 35 bytes a sample


def test_report_with_a_window_holds_pieces_not_the_record(capsys, tmp_path, monkeypatch):
    """Issue 42: `adavar report --window` loaded the record (9.9 GB for 2e8 float32
    samples), then, streamed, its events read it whole again. With few windows and pieces
    of 64 Ki samples (the default is 4 Mi), the traced peak grows by less than two bytes a
    sample from 1 Mi to 2 Mi samples (the record in memory: 8 and more)."""
    from adavar.io import sources
    from adavar.readers import record
    from adavar.stats import stationary_noise, stream

    for module in (sources, stream, stationary_noise, record):
        monkeypatch.setattr(module, "DEFAULT_CHUNK", 1 << 16)
    argv = ["report", "FILE", "--rate", "1", "--units", "deg/s", "--window", "6001",
            "--step", "50000"]  # fmt: skip
    growth, peaks = _traced_growth(capsys, tmp_path, argv, "-o", seed=5, suffix=".html")
    assert growth < 2.0, (growth, peaks)


def test_compare_of_a_file_holds_pieces_not_the_record(tmp_path, monkeypatch, capsys):
    """Issue 42: `adavar compare` loaded its record and kept every method's series at every
    centre (150 bytes a sample: 1.78 GB for 1e7 samples). It now hands the file on as a
    source, and on a source with a step and pieces of 16 Ki samples the traced peak of a
    fixed and an adaptive window grows by under a byte a sample from 256 Ki to 512 Ki
    samples."""
    import tracemalloc

    from adavar import comparison
    from adavar.cli import compare as compare_command
    from adavar.io.sources import ChunkedSource

    opts = dict(rate=100.0, lmax=600, lmin=400, taus=[0.01, 0.02], keep="figures",
                step=50_000, chunk_size=16384, methods=["davar-400", "a-davar"])  # fmt: skip
    peaks = []
    sizes = (1 << 18, 1 << 19)
    for n in sizes:
        path = tmp_path / f"big{n}.npy"
        np.save(path, np.random.default_rng(6).standard_normal(n).astype(np.float32))
        mapped = np.load(path, mmap_mode="r")
        comparison.compare(mapped, **opts)  # compiled and cached before it is traced
        tracemalloc.start()
        try:
            comparison.compare(mapped, **opts)
            peaks.append(tracemalloc.get_traced_memory()[1])
        finally:
            tracemalloc.stop()
    growth = (peaks[1] - peaks[0]) / (sizes[1] - sizes[0])
    assert growth < 1.0, (growth, peaks)  # before: 150 bytes a sample

    seen = {}

    def record(data, **kwargs):
        seen["data"] = data
        raise RuntimeError("Stop")

    monkeypatch.setattr(comparison, "compare", record)
    monkeypatch.setattr(compare_command, "_in_memory", None)  # no study may load it
    code, _, err = run(capsys, ["compare", str(path), "--rate", "100", "--units", "deg/s"])
    assert code == 1 and "Stop" in err
    assert isinstance(seen["data"], ChunkedSource) and seen["data"].size == sizes[1]


@pytest.mark.parametrize("stat", ["mtie", "theo1", "htotdev"])
def test_statistics_computed_in_memory_load_a_npy_file(capsys, tmp_path, stat):
    """`adavar avar FILE.npy --stat mtie` failed with the library's advice to pass an array
    (the file was handed on to be read piece by piece). The statistics that run in memory
    now load the file, as they do a text file, and give the same numbers."""
    rng = np.random.default_rng(12)
    x = np.cumsum(rng.standard_normal(3000)) * 1e-3 + rng.standard_normal(3000)
    np.save(tmp_path / "x.npy", x)
    np.savetxt(tmp_path / "x.txt", x, fmt="%.17g")
    argv = ["--rate", "10", "--units", "deg/s", "--stat", stat, "--json"]
    results = []
    for name in ("x.npy", "x.txt"):
        code, out, err = run(capsys, ["avar", str(tmp_path / name), *argv])
        assert code == 0, err
        results.append(json.loads(out)["dev"])
    assert results[0] == results[1]
    code, out, err = run(capsys, ["avar", str(tmp_path / "x.npy"), *argv, "--chunk-size",
                                  "4096"])  # fmt: skip
    assert_one_line_error(code, out, err, f"--stat {stat}", "in memory", "--chunk-size")

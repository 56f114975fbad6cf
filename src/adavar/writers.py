"""Writing results: output folders and files atomically, the DAVAR surface, JSON and CSV.

:func:`atomic_directory` builds an output folder under a temporary sibling name and moves it
into place only when everything in it was written, so an interrupted or failed run never
leaves a half-written folder behind (SIGTERM removes the temporary; a later run sweeps the
temporaries of killed runs); every folder it writes holds :data:`OUTPUT_MARKER`, and only
such a folder is ever replaced. :func:`atomic_file` does the same for one file.
:func:`write_surface` writes a DAVAR surface as NetCDF (readable by xarray, netCDF4,
``scipy.io.netcdf_file``, ncdump, ...) or Parquet (pandas, pyarrow, polars, DuckDB, ...),
so that it can be read without adavar. :func:`dumps`, :func:`deviation_json` and
:func:`fit_json` give the JSON that ``adavar ... --json`` prints and ``result.json`` holds;
:func:`csv_text` (from :mod:`adavar.csv_tables`, re-exported here) makes every CSV adavar
writes (plain: the header row first, text cells a spreadsheet would run as a formula
neutralised), :func:`write_deviation_csv` the ``deviation.csv`` of ``avar`` and ``batch``.

Every problem with the user's input raises :class:`adavar.errors.AdavarInputError` with a
one-line message that names the problem and the way out.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import secrets
import shutil
import signal
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

import numpy as np

from adavar.csv_tables import (
    CSV_PIECE_ROWS,
    block_rows,
    csv_cell,
    csv_pieces,
    csv_text,
    spreadsheet_safe,
    write_pieces,
)
from adavar.errors import AdavarInputError

if TYPE_CHECKING:
    from adavar.noise_model import NoiseFit
    from adavar.results import DavarResult, DeviationResult

__all__ = [
    "BATCH_MARKER",
    "CSV_PIECE_ROWS",
    "DEMO_MARKER",
    "OUTPUT_MARKER",
    "SURFACE_FORMATS",
    "atomic_directory",
    "atomic_file",
    "block_rows",
    "check_output_directory",
    "check_surface_format",
    "conventional",
    "csv_cell",
    "csv_pieces",
    "csv_text",
    "deviation_json",
    "dumps",
    "fit_json",
    "is_adavar_folder",
    "jsonable",
    "partial_name",
    "remove_partial_files",
    "spreadsheet_safe",
    "sweep_stale_temporaries",
    "write_deviation_csv",
    "write_marker",
    "write_pieces",
    "write_surface",
]


def _fail(message: str) -> AdavarInputError:
    return AdavarInputError(message)


# --------------------------------------------------------------------------------------
# Output folders
# --------------------------------------------------------------------------------------

#: The file in every folder adavar writes (JSON: who wrote it, its pid and host, when).
#: ``--force`` replaces only a folder that holds it (or an empty one); a temporary folder
#: that holds it is swept by a later run once its writer is gone.
OUTPUT_MARKER = ".adavar-output"
#: The marker of ``adavar demo`` folders (written before :data:`OUTPUT_MARKER` existed).
DEMO_MARKER = ".adavar-demo"
#: The marker of an ``adavar batch`` output folder (only such a folder is reused).
BATCH_MARKER = ".adavar-batch"
_MARKERS = (OUTPUT_MARKER, DEMO_MARKER, BATCH_MARKER)
#: A temporary of a writer on another machine (or a reused pid) is stale after this, s.
STALE_TEMPORARY_S = 6 * 3600.0
#: Test hook: seconds :func:`atomic_directory` sleeps once the folder is written, before
#: it is renamed into place (the tests send SIGTERM then).
PAUSE_BEFORE_RENAME_ENV = "ADAVAR_TEST_PAUSE_BEFORE_RENAME"
#: The hidden siblings :func:`atomic_directory` builds and replaces through.
_SIBLING = re.compile(r"^\..+\.(tmp|old)-[0-9a-f]{12}$")


def is_adavar_folder(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a folder adavar wrote (it holds :data:`OUTPUT_MARKER`, or the
    marker of an older ``adavar demo`` or ``adavar batch`` folder).

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    bool
    """
    folder = Path(path)
    return any((folder / marker).is_file() for marker in _MARKERS)


def write_marker(folder: str | os.PathLike[str], purpose: str = "output") -> Path:
    """Write :data:`OUTPUT_MARKER` into ``folder``: adavar wrote it and may replace it.

    Parameters
    ----------
    folder : str or path-like
        An existing folder.
    purpose : str
        What the folder is (``output``, ``temporary``, ...), for a reader of the marker.

    Returns
    -------
    Path
        The marker file.
    """
    from adavar import __version__

    marker = Path(folder) / OUTPUT_MARKER
    marker.write_text(
        json.dumps({
            "written_by": f"adavar {__version__}", "purpose": purpose, "pid": os.getpid(),
            "host": socket.gethostname(), "created": time.time(),
            "note": "adavar wrote this folder: adavar --force may replace it",
        }) + "\n", encoding="utf-8",
    )  # fmt: skip
    return marker


def check_output_directory(path: str | os.PathLike[str], *, replace: bool = False) -> Path:
    """Check that an output folder can be created at ``path``, before any work is done.

    Parameters
    ----------
    path : str or path-like
        The folder to create.
    replace : bool
        Whether an existing folder may be replaced. Only a folder adavar wrote
        (:func:`is_adavar_folder`) or an empty one is ever replaced.

    Returns
    -------
    Path
        The absolute path.

    Raises
    ------
    AdavarInputError
        If ``path`` exists and ``replace`` is False, exists and was not written by adavar,
        is an existing file, or its parent folder does not exist.
    """
    target = Path(path).expanduser().absolute()
    if target.exists() or target.is_symlink():
        if not target.is_dir() or target.is_symlink():
            raise _fail(f"{path} exists and is not a folder: choose another output folder")
        if not replace:
            raise _fail(
                f"output folder {path} exists already: choose another one, or pass --force "
                "to replace it"
            )
        _check_replaceable(target, path)
    if not target.parent.is_dir():
        raise _fail(
            f"the parent folder of {path} does not exist: create it first or choose "
            "another output folder"
        )
    return target


def _check_replaceable(target: Path, shown: str | os.PathLike[str]) -> None:
    if is_adavar_folder(target):
        return
    try:
        empty = not any(target.iterdir())
    except OSError as exc:
        raise _fail(f"cannot read the folder {shown}: {exc.strerror or exc}") from None
    if not empty:
        raise _fail(
            f"{shown} exists and was not written by adavar (no {OUTPUT_MARKER} in it), so "
            "even --force does not replace it: choose another output folder, or remove it "
            "yourself if you no longer need it"
        )


def _make_sibling(target: Path, tag: str) -> Path:
    """A new hidden folder next to ``target`` that holds only its marker (with this pid, so
    that a later run can tell a dead writer's leftover); os.mkdir honours the umask, where
    tempfile.mkdtemp would leave the final folder at mode 0700."""
    while True:
        candidate = target.parent / f".{target.name}.{tag}-{secrets.token_hex(6)}"
        try:
            candidate.mkdir()
        except FileExistsError:
            continue
        except OSError as exc:
            reason = exc.strerror or exc
            raise _fail(f"cannot create a folder in {target.parent}: {reason}") from None
        try:
            write_marker(candidate, "temporary" if tag == "tmp" else "replaced folder")
        except OSError as exc:
            shutil.rmtree(candidate, ignore_errors=True)
            raise _fail(f"cannot write in {target.parent}: {exc.strerror or exc}") from None
        return candidate


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    if os.name != "posix":
        return True  # no cheap check: the age decides
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # PermissionError: another user's live process
        return True
    return True


def _stale(folder: Path, now: float) -> bool:
    """Whether a hidden sibling is a leftover: its writer (this host) is gone, or it is old."""
    try:
        info = json.loads((folder / OUTPUT_MARKER).read_text(encoding="utf-8"))
        pid, host, created = int(info["pid"]), str(info["host"]), float(info["created"])
    except (OSError, ValueError, TypeError, KeyError):
        return False  # not a temporary of ours (or one we cannot read): never touched
    if host == socket.gethostname() and not _pid_alive(pid):
        return True
    return now - created > STALE_TEMPORARY_S


def sweep_stale_temporaries(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporaries that killed runs of :func:`atomic_directory` left in ``folder``.

    Only hidden ``.NAME.tmp-*`` and ``.NAME.old-*`` folders that hold :data:`OUTPUT_MARKER`
    are considered, and only those whose writer is no longer running on this machine or
    that are older than :data:`STALE_TEMPORARY_S`. A stale ``.NAME.old-*`` (a folder set
    aside while being replaced) is moved back to ``NAME`` if ``NAME`` is missing.

    Parameters
    ----------
    folder : str or path-like

    Returns
    -------
    list of Path
        The temporaries removed (or moved back).
    """
    base = Path(folder)
    try:
        entries = [p for p in base.iterdir() if _SIBLING.match(p.name) and p.is_dir()]
    except OSError:
        return []
    now = time.time()
    removed = []
    for entry in entries:
        if not _stale(entry, now):
            continue
        if ".old-" in entry.name:
            name = entry.name[1 : entry.name.rindex(".old-")]
            kept = entry / name
            with contextlib.suppress(OSError):
                if kept.is_dir() and not (base / name).exists():
                    os.replace(kept, base / name)  # the run died before the new one was in
        shutil.rmtree(entry, ignore_errors=True)
        if not entry.exists():
            removed.append(entry)
    return removed


class _TerminateCleanly:
    """While a folder is being written (main thread only): SIGTERM removes the temporary
    and exits with 143 (128 + SIGTERM), instead of leaving it behind. Inside
    :meth:`critical` (the renames) the signal waits until the renames are done."""

    def __init__(self, tmp: Path, target: Path) -> None:
        self.tmp, self.target = tmp, target
        self.previous: Any = None
        self.installed = False
        self.deferred = False
        self.pending: int | None = None

    def __enter__(self) -> _TerminateCleanly:
        if threading.current_thread() is threading.main_thread():
            try:
                self.previous = signal.signal(signal.SIGTERM, self._handler)
                self.installed = True
            except (ValueError, OSError):  # not the main interpreter, or no signals here
                pass
        return self

    def __exit__(self, *exc: object) -> None:
        if self.installed:
            signal.signal(signal.SIGTERM, self.previous if self.previous is not None
                          else signal.SIG_DFL)  # fmt: skip

    def _handler(self, signum: int, frame: Any) -> None:
        if self.deferred:
            self.pending = signum
            return
        self._terminate(signum)

    def _terminate(self, signum: int) -> None:
        shutil.rmtree(self.tmp, ignore_errors=True)
        with contextlib.suppress(OSError):  # os.write: safe inside a signal handler
            os.write(2, f"adavar: terminated (signal {signum}): {self.target} was not "
                     "written\n".encode(errors="replace"))  # fmt: skip
        raise SystemExit(128 + signum)

    @contextlib.contextmanager
    def critical(self) -> Iterator[None]:
        self.deferred = True
        try:
            yield
        finally:
            self.deferred = False
        if self.pending is not None:
            self._terminate(self.pending)


@contextlib.contextmanager
def atomic_directory(
    path: str | os.PathLike[str], *, replace: bool = False, sweep: bool = True
) -> Iterator[Path]:
    """Build a folder under a temporary sibling name and move it to ``path`` at the end.

    Use as ``with atomic_directory(out) as tmp: write files into tmp``. If the block raises,
    the temporary folder is removed and ``path`` is left as it was. If it completes, the
    temporary folder is renamed to ``path`` (when ``replace`` is True, an existing folder at
    ``path`` is first renamed aside, then deleted once the new one is in place).

    Every folder it writes holds :data:`OUTPUT_MARKER`, and only such a folder (or an empty
    one) is ever replaced. While the block runs in the main thread, SIGTERM removes the
    temporary and exits with status 143; temporaries that a killed run left next to
    ``path`` are swept first (:func:`sweep_stale_temporaries`).

    Parameters
    ----------
    path : str or path-like
        The final folder.
    replace : bool
        Whether an existing folder at ``path`` may be replaced (one adavar wrote).
    sweep : bool
        Sweep stale temporaries in the parent folder first (default). A caller that writes
        many folders into one parent sweeps it once itself.

    Yields
    ------
    Path
        The temporary folder to write into (same parent as ``path``).

    Raises
    ------
    AdavarInputError
        As :func:`check_output_directory` (checked again when the block is entered).
    """
    target = check_output_directory(path, replace=replace)
    if sweep:
        sweep_stale_temporaries(target.parent)
    tmp = _make_sibling(target, "tmp")
    guard = _TerminateCleanly(tmp, target)
    try:
        with guard:
            yield tmp
            remove_partial_files(tmp)  # of a worker process killed while it wrote
            write_marker(tmp)  # the final folder's marker: an output, no longer a temporary
            pause = os.environ.get(PAUSE_BEFORE_RENAME_ENV)
            if pause:
                time.sleep(float(pause))
            with guard.critical():
                _move_into_place(tmp, target, path, replace)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def _move_into_place(tmp: Path, target: Path, shown: str | os.PathLike[str], replace: bool) -> None:
    if not target.exists():
        os.replace(tmp, target)
        return
    if not replace:
        raise _fail(
            f"output folder {shown} appeared while it was being written: choose "
            "another one, or pass --force to replace it"
        )
    _check_replaceable(target, shown)
    old = _make_sibling(target, "old")
    os.replace(target, old / target.name)
    try:
        os.replace(tmp, target)
    except BaseException:
        os.replace(old / target.name, target)  # put the old folder back
        raise
    shutil.rmtree(old, ignore_errors=True)


# --------------------------------------------------------------------------------------
# DAVAR surfaces
# --------------------------------------------------------------------------------------

#: File formats of :func:`write_surface` and the file-name suffix of each.
SURFACE_FORMATS: dict[str, str] = {"nc": ".nc", "parquet": ".parquet"}

_FORMAT_ALIASES = {
    "nc": "nc",
    "netcdf": "nc",
    "cdf": "nc",
    "parquet": "parquet",
    "pq": "parquet",
}
#: A 64-bit-offset (CDF-2) NetCDF file holds variables of at most 4 GiB - 4 bytes.
_NETCDF_MAX_VARIABLE = 2**32 - 4
_INT32 = np.iinfo(np.int32)


def _require_pyarrow() -> tuple[Any, Any]:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise _fail(
            "writing Parquet needs pyarrow, which is not installed: pip install pyarrow "
            "(or write NetCDF, format 'nc', which needs nothing more)"
        ) from None
    return pa, pq


def check_surface_format(fmt: str) -> str:
    """Check a surface file format (and that its writer is installed) before any work.

    Parameters
    ----------
    fmt : str
        ``"nc"`` (also ``"netcdf"``, ``"cdf"``) or ``"parquet"`` (also ``"pq"``), case
        insensitive, with or without a leading dot.

    Returns
    -------
    str
        ``"nc"`` or ``"parquet"`` (a key of :data:`SURFACE_FORMATS`).

    Raises
    ------
    AdavarInputError
        An unknown format, or ``"parquet"`` without pyarrow installed (the message names
        the fix, ``pip install pyarrow``).
    """
    key = _FORMAT_ALIASES.get(str(fmt).strip().lower().lstrip("."))
    if key is None:
        raise _fail(f"unknown surface format {fmt!r}: use 'nc' (NetCDF) or 'parquet'")
    if key == "parquet":
        _require_pyarrow()
    return key


def _surface_format(path: Path, fmt: str | None) -> str:
    if fmt is not None:
        return check_surface_format(fmt)
    key = _FORMAT_ALIASES.get(path.suffix.lower().lstrip("."), "nc")
    return check_surface_format(key)


def _surface_variables(result: DavarResult) -> list[tuple[str, tuple[str, ...], Any, dict]]:
    """(name, dimensions, data, CF attributes) of every variable of a surface file."""
    unit = result.units
    unit2: str | None
    if unit is None:
        unit2 = None
    elif unit.strip() in ("", "1"):
        unit2 = "1"
    else:
        unit2 = f"({unit})^2"

    def with_unit(attrs: dict[str, Any]) -> dict[str, Any]:
        return attrs if unit2 is None else {"units": unit2, **attrs}

    out: list[tuple[str, tuple[str, ...], Any, dict]] = [
        ("time", ("time",), result.time, {"units": "s", "long_name": "window centre time"}),
        ("tau", ("tau",), result.tau, {"units": "s", "long_name": "averaging time"}),
        ("avar", ("time", "tau"), result.avar,
         with_unit({"long_name": "overlapping Allan variance of the window",
                    "comment": "NaN where tau exceeds a third of the window"})),
    ]  # fmt: skip
    if result.avar_low is not None and result.avar_high is not None:
        level = f"{100 * float(result.confidence):.4g} %"
        for name, data, side in (
            ("avar_low", result.avar_low, "lower"),
            ("avar_high", result.avar_high, "upper"),
        ):
            attrs = {
                "long_name": f"{side} bound of the {level} confidence interval of avar",
                "confidence": float(result.confidence),
            }
            out.append((name, ("time", "tau"), data, with_unit(attrs)))
    out += [
        ("window", ("time",), result.window,
         {"units": "1", "long_name": "window length in samples"}),
        ("centre", ("time",), result.centre,
         {"units": "1", "long_name": "index of the window's centre sample in the record"}),
        ("m", ("tau",), result.m, {"units": "1", "long_name": "averaging factor tau / tau0"}),
        ("alpha", ("tau",), result.alpha,
         {"units": "1",
          "long_name": "power-law noise exponent used for the EDF (-1: not identified)"}),
    ]  # fmt: skip
    return out


def _global_attributes(result: DavarResult) -> dict[str, Any]:
    from adavar import __version__

    return {
        "Conventions": "CF-1.8",
        "title": "Dynamic Allan variance",
        "source": f"adavar {__version__}",
        **result.metadata(),
    }


def _nc_attribute(value: Any) -> Any:
    """An attribute value scipy's NetCDF writer stores faithfully (doubles, not floats)."""
    if isinstance(value, str):
        return value.encode("utf-8")
    if isinstance(value, (bool, np.bool_)):
        return np.int32(value)
    if isinstance(value, (int, np.integer)):
        return np.int32(value) if _INT32.min <= value <= _INT32.max else np.float64(value)
    if isinstance(value, (float, np.floating)):
        return np.float64(value)
    return str(value).encode("utf-8")


def _write_netcdf(handle: Any, result: DavarResult) -> None:
    from scipy.io import netcdf_file

    n_time, n_tau = np.shape(result.avar)
    if 8 * n_time * n_tau > _NETCDF_MAX_VARIABLE:
        raise _fail(
            f"a surface of {n_time} windows x {n_tau} taus ({8 * n_time * n_tau / 2**30:.1f} "
            "GiB per variable) is too large for a NetCDF (64-bit offset) file: write Parquet "
            "(pip install pyarrow), or compute fewer windows or taus"
        )
    nc = netcdf_file(handle, "w", version=2)
    nc.createDimension("time", n_time)
    nc.createDimension("tau", n_tau)
    for name, dims, data, attrs in _surface_variables(result):
        array = np.asarray(data)
        if np.issubdtype(array.dtype, np.integer):
            fits = array.size == 0 or (
                _INT32.min <= int(array.min()) and int(array.max()) <= _INT32.max
            )
            typecode = "i" if fits else "d"
        else:
            typecode = "d"
        var = nc.createVariable(name, typecode, dims)
        var[...] = array
        if typecode == "d" and name.startswith("avar"):
            var._FillValue = np.float64(np.nan)  # NaN cells are missing to CF readers
        for key, value in attrs.items():
            setattr(var, key, _nc_attribute(value))
    for key, value in _global_attributes(result).items():
        name = key if not hasattr(nc, key) else f"adavar_{key}"  # never shadow internals
        setattr(nc, name, _nc_attribute(value))
    nc.close()  # writes the file (and closes the handle)


def _json_scalar(value: Any) -> Any:
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, (np.integer, np.bool_)):
        return value.item()
    return value


def _write_parquet(handle: Any, result: DavarResult) -> None:

    pa, pq = _require_pyarrow()
    n_time, n_tau = np.shape(result.avar)
    by_cell = {
        "time": lambda a: np.repeat(a, n_tau),
        "window": lambda a: np.repeat(a, n_tau),
        "centre": lambda a: np.repeat(a, n_tau),
        "tau": lambda a: np.tile(a, n_time),
        "m": lambda a: np.tile(a, n_time),
        "alpha": lambda a: np.tile(a, n_time),
    }
    arrays, fields = [], []
    for name, _dims, data, attrs in _surface_variables(result):
        array = np.asarray(data)
        column = by_cell[name](array) if name in by_cell else array.reshape(-1)
        arrays.append(pa.array(column))
        meta = {key: str(value) for key, value in attrs.items()}
        fields.append(pa.field(name, arrays[-1].type, metadata=meta))
    attributes = {key: _json_scalar(v) for key, v in _global_attributes(result).items()}
    schema_meta = {
        "adavar": json.dumps(
            {**attributes, "shape": [int(n_time), int(n_tau)],
             "layout": "one row per (time, tau) cell, time-major"},
            allow_nan=False,
        ),
        # pandas.read_parquet restores DataFrame.attrs from this key
        "PANDAS_ATTRS": json.dumps(attributes, allow_nan=False),
    }  # fmt: skip
    table = pa.Table.from_arrays(arrays, schema=pa.schema(fields, metadata=schema_meta))
    pq.write_table(table, handle)


def partial_name(target: Path) -> Path:
    """The temporary name a file is written under before it is renamed to ``target``:
    ``.NAME.HEX.tmp`` beside it (hidden, unique, in the same folder so the rename is atomic)."""
    return target.parent / f".{target.name}.{secrets.token_hex(6)}.tmp"


def remove_partial_files(folder: Path) -> None:
    """Delete the :func:`partial_name` files that a killed writer left in ``folder``.

    A writer removes its temporary when it fails; one killed in between (a worker
    process of the demo or of a batch) cannot, and its file is redone by another.
    """
    for stray in folder.glob(".*.tmp"):
        if _PARTIAL.fullmatch(stray.name):
            stray.unlink(missing_ok=True)


_PARTIAL = re.compile(r"\..+\.[0-9a-f]{12}\.tmp")


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike[str]) -> Iterator[BinaryIO]:
    """Write ``path`` all or nothing: a binary handle on a temporary sibling, renamed at the end.

    The temporary file sits in the destination folder (so ``os.replace`` is atomic), is
    created with ``open(..., "x")`` (the umask's permissions, not mkstemp's private 0600), is
    synced before the rename, and is removed if anything fails, so an interrupted or
    failed write leaves neither a half-written file nor a temporary behind.

    Raises
    ------
    AdavarInputError
        The folder does not exist, ``path`` is a folder, or the file cannot be written.
    """
    target = Path(path)
    if not target.parent.is_dir():
        raise _fail(
            f"the folder of {target} does not exist: create it first or choose another path"
        )
    if target.is_dir():
        raise _fail(f"{target} is a folder: give the path of the file to write")
    tmp = partial_name(target)
    try:
        with open(tmp, "xb") as handle:
            yield handle
        # data on disk before the name points at it (the writer may have closed the handle)
        with contextlib.suppress(OSError):
            fd = os.open(tmp, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        os.replace(tmp, target)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise _fail(f"cannot write {target}: {exc.strerror or exc}") from None
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_surface(
    path: str | os.PathLike[str], result: DavarResult, *, fmt: str | None = None
) -> Path:
    """Write a DAVAR surface to a file that can be read without adavar.

    The file is written under a temporary name in the target folder and moved into place
    with :func:`os.replace`: a reader never sees a half-written file, and a failure leaves
    any earlier file at ``path`` untouched.

    Parameters
    ----------
    path : str or path-like
        The file to write (replaced if it exists).
    result : DavarResult
        From :func:`adavar.davar`.
    fmt : {"nc", "parquet"}, optional
        The format; by default from the suffix of ``path`` (``.parquet``/``.pq`` Parquet,
        anything else NetCDF).

        ``"nc"``: NetCDF classic with 64-bit offsets (``scipy.io.netcdf_file``,
        ``version=2``). Dimensions ``time`` (T windows) and ``tau`` (M); variables
        ``time`` and ``tau`` (s), ``avar`` (T x M, in the square of the data's unit; NaN
        where tau exceeds a third of the window, with ``_FillValue = NaN``), ``avar_low``
        and ``avar_high`` (when the result has bounds), ``window``, ``centre``, ``m``,
        ``alpha`` (int32, or double if a value does not fit), each with CF ``units`` and
        ``long_name``; global attributes ``Conventions``, ``title``, ``source`` and
        :meth:`DavarResult.metadata`. Text attributes are UTF-8. Read it with
        ``xarray.open_dataset(path)`` or ``scipy.io.netcdf_file(path)``.

        ``"parquet"`` (needs pyarrow): a long table, one row per (time, tau) cell in
        time-major order, columns ``time, tau, avar, [avar_low, avar_high,] window,
        centre, m, alpha`` with ``units``/``long_name`` field metadata, and the global
        attributes as JSON in the schema metadata (key ``adavar``, and ``PANDAS_ATTRS`` so
        that ``pandas.read_parquet(path).attrs`` holds them). Read it with
        ``pandas.read_parquet(path)``; ``frame.pivot(index="time", columns="tau",
        values="avar")`` gives the T x M surface back.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    AdavarInputError
        An unknown format, Parquet without pyarrow (``pip install pyarrow``), a surface
        too large for NetCDF classic (a variable over 4 GiB), or a folder that cannot be
        written.
    """
    target = Path(path)
    kind = _surface_format(target, fmt)
    with atomic_file(target) as handle:
        if kind == "nc":
            _write_netcdf(handle, result)
        else:
            _write_parquet(handle, result)
    return target


# --------------------------------------------------------------------------------------
# JSON and CSV of the results
# --------------------------------------------------------------------------------------


def jsonable(obj: Any) -> Any:
    """Plain Python objects for json: arrays to lists, NaN/inf to None."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        value = float(obj)
        return value if math.isfinite(value) else None
    return obj


def dumps(payload: dict[str, Any]) -> str:
    """Indented JSON of ``payload``, arrays as lists, NaN and inf as null."""
    return json.dumps(jsonable(payload), indent=2, allow_nan=False)


def deviation_json(result: DeviationResult) -> dict[str, Any]:
    """The ``deviation`` object of the JSON output."""
    return {
        "stat": result.stat,
        "confidence": result.confidence,
        "tau": result.tau,
        "dev": result.dev,
        "dev_low": result.dev_low,
        "dev_high": result.dev_high,
        "edf": result.edf,
        "n": result.n,
        "m": result.m,
        "alpha": result.alpha,
        "notes": list(result.notes),
    }


def conventional(fit: NoiseFit) -> Any:
    """``fit.to_units()`` if the declared unit is an accepted rate unit, else None."""
    if fit.units is None:
        return None
    try:
        return fit.to_units()
    except ValueError:
        return None


def fit_json(fit: NoiseFit) -> dict[str, Any]:
    """The ``fit`` object of the JSON output: every term in data and conventional units."""
    from adavar.noise_model import TERM_NAMES
    from adavar.units import term_unit

    out: dict[str, Any] = {}
    for name in TERM_NAMES:
        term = fit.term(name)
        out[name] = {
            "value": term.value,
            "uncertainty": term.uncertainty,
            "upper": term.upper,
            "unit": term_unit(name, fit.units),
        }
    conv = conventional(fit)
    out["conventional"] = (
        None
        if conv is None
        else {
            name: {"value": t.value, "uncertainty": t.uncertainty, "upper": t.upper,
                   "unit": t.unit}
            for name, t in conv.as_dict().items()
        }
    )  # fmt: skip
    out["reduced_chi2"] = fit.reduced_chi2
    out["chi2"] = fit.chi2
    out["dof"] = fit.dof
    out["n_points"] = fit.n_points
    out["terms"] = list(fit.terms)
    out["method"] = fit.method
    out["dropped"] = list(fit.dropped)
    out["selection"] = fit.selection
    out["bound_level"] = fit.bound_level
    out["adequate"] = bool(fit.adequate)
    out["p_value"] = fit.p_value
    out["gof_chi2"] = fit.gof_chi2
    out["better_model"] = fit.better_model
    mk = fit.markov
    out["markov"] = None if mk is None else {
        "sigma": mk.sigma, "sigma_uncertainty": mk.sigma_uncertainty, "tau_c_s": mk.tau_c,
        "tau_c_range_s": list(mk.tau_c_range), "unit": fit.units,
    }  # fmt: skip
    out["rolloff"] = fit.rolloff
    out["warnings"] = list(fit.warnings)
    out["excluded"] = [
        {"tau_s": float(t), "reason": r} for t, r in zip(fit.tau, fit.exclusions, strict=True) if r
    ]
    out["residuals"] = None if fit.residuals is None else list(fit.residuals)
    if fit.slopes is not None:
        out["slopes"] = {
            n: {"value": v, "uncertainty": fit.slopes.uncertainty[n],
                "anchor_tau_s": fit.slopes.anchor_tau[n], "unit": term_unit(n, fit.units)}
            for n, v in fit.slopes.values.items()
        }  # fmt: skip
    return out


def write_deviation_csv(path: Path, result: DeviationResult, comment: str | None = None) -> None:
    """``deviation.csv``: a header row, then one row per tau (every digit kept).

    ``comment`` (optional, adavar passes none) goes before the header as a ``# `` line.
    """
    columns = ["tau_s", "n", "m", "alpha", "edf", "dev", "dev_low", "dev_high"]
    rows = (
        (float(tau), int(n), int(m), int(alpha), float(edf), float(dev), float(low), float(high))
        for tau, n, m, alpha, edf, dev, low, high in zip(
            result.tau, result.n, result.m, result.alpha, result.edf, result.dev,
            result.dev_low, result.dev_high, strict=True,
        )
    )  # fmt: skip
    path.write_text(csv_text(columns, rows, comment=comment), encoding="utf-8")

"""Outputs written all or nothing, and replaced only where adavar wrote everything.

:func:`atomic_directory` builds an output folder under a temporary sibling name and moves it
into place only when everything in it was written; :func:`atomic_file` does the same for
one file. An interrupted or failed run never leaves a half-written output behind:

- SIGTERM or SIGHUP while a temporary exists (the main thread) removes it and ends the
  process with status 128 + the signal (143 for SIGTERM); Ctrl-C removes it too;
- a run killed outright (SIGKILL, a power cut) cannot clean up: the next write into the
  same folder sweeps its temporaries (:func:`sweep_stale_temporaries` for folders,
  :func:`sweep_partial_files` for files), recognised by their names (and a folder by its
  marker), and only once their writer is no longer running on this machine or after
  :data:`STALE_TEMPORARY_S`.

Every folder it writes holds :data:`OUTPUT_MARKER`, with the list of the files written
(its manifest): ``--force`` (``replace=True``) replaces only such a folder, or an empty
one, and only while it holds nothing but those files; a file put there later stops it,
named in the one-line error (:func:`foreign_files`).

:mod:`adavar.io.writers` re-exports every public name of this module.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import os
import re
import secrets
import shutil
import signal
import socket
import stat
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, BinaryIO

from adavar.core.errors import AdavarInputError

__all__ = [
    "BATCH_MARKER",
    "DEMO_MARKER",
    "OUTPUT_MARKER",
    "PAUSE_BEFORE_RENAME_ENV",
    "PAUSE_FILE_RENAME_ENV",
    "STALE_TEMPORARY_S",
    "atomic_directory",
    "atomic_file",
    "check_output_directory",
    "foreign_files",
    "is_adavar_folder",
    "partial_name",
    "remove_partial_files",
    "sweep_partial_files",
    "sweep_stale_temporaries",
    "write_marker",
]


def _fail(message: str) -> AdavarInputError:
    return AdavarInputError(message)


# --------------------------------------------------------------------------------------
# Output folders
# --------------------------------------------------------------------------------------

#: The file in every folder adavar writes (JSON: who wrote it, its pid and host, when, and
#: the files it wrote). ``--force`` replaces only a folder that holds it (or an empty one)
#: and nothing else; a temporary folder that holds it is swept by a later run once its
#: writer is gone.
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
#: Test hook: the same for :func:`atomic_file`, once the file is written.
PAUSE_FILE_RENAME_ENV = "ADAVAR_TEST_PAUSE_FILE_RENAME"
#: The hidden siblings :func:`atomic_directory` builds and replaces through.
_SIBLING = re.compile(r"^\..+\.(tmp|old)-[0-9a-f]{12}$")
#: A folder of an older adavar has no manifest: a file modified this long after its
#: marker was put there by someone else (the slack: file systems with 2 s timestamps).
_MTIME_SLACK_S = 2.0
#: Files named in an error, at most.
_MAX_NAMED = 5


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


def _files_in(folder: Path) -> list[str]:
    """Every entry of ``folder`` but its folders (files, links), as relative POSIX paths,
    without the markers at its top."""
    out = []
    for root, dirs, files in os.walk(folder):
        base = Path(root).relative_to(folder)
        # a link to a folder is an entry of its own, never followed
        links = [d for d in dirs if (Path(root) / d).is_symlink()]
        for name in [*files, *links]:
            relative = (base / name).as_posix()
            if relative not in _MARKERS:
                out.append(relative)
    return sorted(out)


def write_marker(
    folder: str | os.PathLike[str], purpose: str = "output", *, manifest: bool = False
) -> Path:
    """Write :data:`OUTPUT_MARKER` into ``folder``: adavar wrote it and may replace it.

    Parameters
    ----------
    folder : str or path-like
        An existing folder.
    purpose : str
        What the folder is (``output``, ``temporary``, ...), for a reader of the marker.
    manifest : bool
        Record the files the folder holds now (``files``): they are adavar's, and a file
        that is not among them stops ``--force`` (:func:`foreign_files`).

    Returns
    -------
    Path
        The marker file.
    """
    from adavar import __version__

    marker = Path(folder) / OUTPUT_MARKER
    info: dict[str, Any] = {
        "written_by": f"adavar {__version__}", "purpose": purpose, "pid": os.getpid(),
        "host": socket.gethostname(), "created": time.time(),
        "note": "adavar wrote this folder: adavar --force may replace it while it holds "
        "only the files listed here",
    }  # fmt: skip
    if manifest:
        info["files"] = _files_in(Path(folder))
    marker.write_text(json.dumps(info) + "\n", encoding="utf-8")
    return marker


def foreign_files(path: str | os.PathLike[str]) -> list[str]:
    """The files of an adavar folder that adavar did not write there.

    Parameters
    ----------
    path : str or path-like
        A folder :func:`is_adavar_folder` recognises.

    Returns
    -------
    list of str
        Relative paths of the files (and links) not in its marker's list of the files it
        wrote; for a folder of an older adavar (a marker without that list), those modified
        after the marker was written.
    """
    folder = Path(path)
    found = _files_in(folder)
    try:
        info = json.loads((folder / OUTPUT_MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        info = None
    written = info.get("files") if isinstance(info, dict) else None
    if isinstance(written, list):
        known = {str(name) for name in written}
        return [name for name in found if name not in known]
    stamps = []
    for name in _MARKERS:
        with contextlib.suppress(OSError):
            stamps.append((folder / name).stat().st_mtime)
    if not stamps:
        return found
    newest = max(stamps) + _MTIME_SLACK_S
    later = []
    for name in found:
        try:
            if (folder / name).lstat().st_mtime > newest:
                later.append(name)
        except OSError:
            continue
    return later


def _named(items: list[str]) -> str:
    shown = ", ".join(items[:_MAX_NAMED])
    return shown + (f", ... ({len(items)} in all)" if len(items) > _MAX_NAMED else "")


def check_output_directory(path: str | os.PathLike[str], *, replace: bool = False) -> Path:
    """Check that an output folder can be created at ``path``, before any work is done.

    Parameters
    ----------
    path : str or path-like
        The folder to create.
    replace : bool
        Whether an existing folder may be replaced. Only a folder adavar wrote
        (:func:`is_adavar_folder`) that holds nothing but what adavar wrote there
        (:func:`foreign_files`), or an empty one, is ever replaced.

    Returns
    -------
    Path
        The absolute path.

    Raises
    ------
    AdavarInputError
        If ``path`` exists and ``replace`` is False, exists and was not written by adavar,
        holds files adavar did not write, is an existing file, or its parent folder does
        not exist.
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
        others = foreign_files(target)
        if others:
            raise _fail(
                f"{shown} holds {len(others)} file(s) adavar did not write ({_named(others)}), "
                "so even --force does not replace it: move them out of it (or delete them) "
                "and rerun, or choose another output folder"
            )
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


#: The signals that end a process by default and that a writer turns into a clean exit.
_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


class _TerminateCleanly:
    """While an output is being written (main thread only): SIGTERM (or SIGHUP) runs
    ``cleanup`` (removes the temporary) and exits with 128 + the signal (143 for
    SIGTERM), instead of leaving the temporary behind. Inside :meth:`critical` (the
    renames) the signal waits until the renames are done."""

    def __init__(self, cleanup: Callable[[], None], target: Path) -> None:
        self.cleanup, self.target = cleanup, target
        self.previous: dict[int, Any] = {}
        self.deferred = False
        self.pending: int | None = None

    def __enter__(self) -> _TerminateCleanly:
        if threading.current_thread() is threading.main_thread():
            for signum in _SIGNALS:
                try:
                    self.previous[signum] = signal.signal(signum, self._handler)
                except (ValueError, OSError):  # not the main interpreter, or no signals here
                    break
        return self

    def __exit__(self, *exc: object) -> None:
        for signum, previous in self.previous.items():
            signal.signal(signum, previous if previous is not None else signal.SIG_DFL)
        self.previous = {}

    def _handler(self, signum: int, frame: Any) -> None:
        if self.deferred:
            self.pending = signum
            return
        self._terminate(signum)

    def _terminate(self, signum: int) -> None:
        self.cleanup()
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


def _test_pause(variable: str) -> None:
    pause = os.environ.get(variable)
    if pause:
        time.sleep(float(pause))


@contextlib.contextmanager
def atomic_directory(
    path: str | os.PathLike[str], *, replace: bool = False, sweep: bool = True
) -> Iterator[Path]:
    """Build a folder under a temporary sibling name and move it to ``path`` at the end.

    Use as ``with atomic_directory(out) as tmp: write files into tmp``. If the block raises,
    the temporary folder is removed and ``path`` is left as it was. If it completes, the
    temporary folder is renamed to ``path`` (when ``replace`` is True, an existing folder at
    ``path`` is first renamed aside, then deleted once the new one is in place).

    Every folder it writes holds :data:`OUTPUT_MARKER` with the list of its files, and only
    such a folder that holds nothing else (or an empty one) is ever replaced. While the
    block runs in the main thread, SIGTERM removes the temporary and exits with status
    143; temporaries that a killed run left next to ``path`` are swept first
    (:func:`sweep_stale_temporaries`).

    Parameters
    ----------
    path : str or path-like
        The final folder.
    replace : bool
        Whether an existing folder at ``path`` may be replaced (one adavar wrote, holding
        only what adavar wrote there).
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
        As :func:`check_output_directory` (checked again when the block is entered, and
        before the old folder is replaced).
    """
    target = check_output_directory(path, replace=replace)
    if sweep:
        sweep_stale_temporaries(target.parent)
    tmp = _make_sibling(target, "tmp")
    guard = _TerminateCleanly(lambda: shutil.rmtree(tmp, ignore_errors=True), target)
    try:
        with guard:
            yield tmp
            remove_partial_files(tmp)  # of a worker process killed while it wrote
            # the final folder's marker, with the files written: an output, no longer a
            # temporary, and what --force may replace
            write_marker(tmp, manifest=True)
            _test_pause(PAUSE_BEFORE_RENAME_ENV)
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
# Files
# --------------------------------------------------------------------------------------

#: The name of a file being written by :func:`atomic_file`: ``.NAME.adavar-HOST-PID-HEX.tmp``
#: (HOST: 6 hex digits of a hash of the host name), so that a later run can tell a dead
#: writer's leftover.
_OWNED_PARTIAL = re.compile(
    r"^\.(?P<name>.+)\.adavar-(?P<host>[0-9a-f]{6})-(?P<pid>[0-9]+)-[0-9a-f]{12}\.tmp$"
)
#: The name of such a file before 0.2 (``.NAME.HEX.tmp``): no writer to ask, only its age.
_PARTIAL = re.compile(r"\..+\.[0-9a-f]{12}\.tmp")


@functools.cache
def _host_tag() -> str:
    return hashlib.sha1(socket.gethostname().encode("utf-8", "replace")).hexdigest()[:6]


def partial_name(target: Path) -> Path:
    """The temporary name a file is written under before it is renamed to ``target``:
    ``.NAME.adavar-HOST-PID-HEX.tmp`` beside it (hidden, unique, in the same folder so the
    rename is atomic; the host and pid tell a later run whether its writer still runs)."""
    tag = f"adavar-{_host_tag()}-{os.getpid()}-{secrets.token_hex(6)}"
    return target.parent / f".{target.name}.{tag}.tmp"


def _is_partial(name: str) -> bool:
    return bool(_OWNED_PARTIAL.match(name) or _PARTIAL.fullmatch(name))


def remove_partial_files(folder: Path) -> None:
    """Delete the :func:`partial_name` files that a killed writer left in ``folder``.

    A writer removes its temporary when it fails; one killed in between (a worker
    process of the demo or of a batch) cannot, and its file is redone by another.
    """
    for stray in folder.glob(".*.tmp"):
        if _is_partial(stray.name):
            stray.unlink(missing_ok=True)


def sweep_partial_files(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove the files that killed runs of :func:`atomic_file` left in ``folder``.

    Only files named by :func:`partial_name` are considered, and only those whose writer
    (its pid, on this machine) is no longer running, or that nobody wrote for
    :data:`STALE_TEMPORARY_S` (a writer on another machine sharing the folder, a reused
    pid, a temporary of an adavar before 0.2).

    Parameters
    ----------
    folder : str or path-like

    Returns
    -------
    list of Path
        The files removed.
    """
    removed: list[Path] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    now = time.time()
    for entry in entries:
        name = entry.name
        if not (name.startswith(".") and name.endswith(".tmp")) or not _is_partial(name):
            continue
        try:
            info = entry.stat(follow_symlinks=False)
        except OSError:
            continue
        if not stat.S_ISREG(info.st_mode):
            continue
        owned = _OWNED_PARTIAL.match(name)
        dead = (
            owned is not None and owned["host"] == _host_tag() and not _pid_alive(int(owned["pid"]))
        )
        if dead or now - info.st_mtime > STALE_TEMPORARY_S:
            with contextlib.suppress(OSError):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
    return removed


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike[str], *, sweep: bool = True) -> Iterator[BinaryIO]:
    """Write ``path`` all or nothing: a binary handle on a temporary sibling, renamed at the end.

    The temporary file sits in the destination folder (so ``os.replace`` is atomic), is
    created with ``open(..., "x")`` (the umask's permissions, not mkstemp's private 0600), is
    synced before the rename, and is removed if anything fails, so an interrupted or
    failed write leaves neither a half-written file nor a temporary behind: SIGTERM or
    SIGHUP while it is written (in the main thread) removes it and exits with 128 + the
    signal, Ctrl-C removes it, and the temporaries of runs killed outright are swept from
    the folder first (:func:`sweep_partial_files`).

    Parameters
    ----------
    path : str or path-like
        The file to write (replaced if it exists).
    sweep : bool
        Sweep the folder's stale temporaries first (default).

    Yields
    ------
    BinaryIO
        The handle to write to.

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
    if sweep:
        sweep_partial_files(target.parent)
    tmp = partial_name(target)

    def remove() -> None:
        with contextlib.suppress(OSError):
            os.unlink(tmp)

    guard = _TerminateCleanly(remove, target)
    try:
        with guard:
            with open(tmp, "xb") as handle:
                yield handle
            # data on disk before the name points at it (the writer may have closed it)
            with contextlib.suppress(OSError):
                fd = os.open(tmp, os.O_RDONLY)
                try:
                    os.fsync(fd)
                finally:
                    os.close(fd)
            _test_pause(PAUSE_FILE_RENAME_ENV)
            with guard.critical():
                os.replace(tmp, target)
    except OSError as exc:
        remove()
        raise _fail(f"cannot write {target}: {exc.strerror or exc}") from None
    except BaseException:
        remove()
        raise

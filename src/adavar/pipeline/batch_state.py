"""What an ``adavar batch`` output folder remembers between runs.

Every file of a batch keeps one folder, ``OUT/<stem>-<hash>/`` (the stem of the file and 6
hex digits of a hash of its resolved absolute path, e.g. ``gyro-3f2a9c``): the name depends
on that file alone, never on the other files of a run, and is recorded in
``OUT/.adavar-batch-state.json`` (:data:`BATCH_STATE`) with the path it belongs to, so that
a later run, with more files or fewer, finds it again. A name already taken (the same stem
and hash digits, or any name recorded earlier) gets more digits. A folder written by
adavar before the names had a hash (``gyro``, ``a__gyro``) is adopted under its old name.

A file of an earlier run that is not among a run's inputs keeps its folder and its row in
the summary, with status :data:`STATUS_ABSENT`; a file whose folder was deleted is
forgotten. :data:`OUTPUT_FORMAT` and the options that shape a file's outputs (``html``) are
recorded in its ``result.json`` (``outputs``): a later run redoes a file when they differ
from what it needs or an expected file is missing (:func:`outputs_complete`).

One run at a time writes into a batch folder: :func:`locked` holds an exclusive
``flock`` on ``OUT/.adavar-batch.lock`` (:data:`BATCH_LOCK`) for the whole run, and a second
run into the same folder stops at once with a one-line error naming the first one's pid
(two runs at once each rewrote the summary and the state file from their own rows, and
lost the other's). The lock goes with its process, however it ends (a killed run leaves
no stale lock).
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import socket
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from adavar.core.errors import AdavarInputError

__all__ = [
    "BATCH_LOCK",
    "BATCH_STATE",
    "OUTPUT_FORMAT",
    "STATUS_ABSENT",
    "BatchState",
    "file_key",
    "folder_name",
    "locked",
    "output_names",
    "outputs_complete",
    "outputs_record",
    "read_result",
]

#: The state file of a batch folder: every file's path and folder name (JSON).
BATCH_STATE = ".adavar-batch-state.json"
#: The lock file of a batch folder, held by the run writing into it (its pid inside).
BATCH_LOCK = ".adavar-batch.lock"
#: The layout of a file's outputs (2: plain CSV, the marker, ``outputs`` in result.json).
#: A stored result of another layout is redone.
OUTPUT_FORMAT = 2
#: The summary status of a file of an earlier run that is not among this run's inputs.
STATUS_ABSENT = "absent"
#: Hex digits of the path hash in a folder name, then more where a name is taken.
_DIGITS = (6, 10, 16, 40)
#: Names an output folder must not take (the summary files sit next to the folders).
RESERVED = frozenset({"summary.csv", "summary.parquet", "summary.json"})
_MAX_LISTED = 5


def file_key(path: str | os.PathLike[str]) -> str:
    """The identity of a batch input: its resolved absolute path (symlinks followed).

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    str
    """
    return os.path.realpath(os.path.abspath(os.fspath(path)))


def safe_stem(text: str) -> str:
    """``text`` with only letters, digits, ``-``, ``_`` and ``.`` (others become ``_``),
    without leading dots, underscores or dashes (a hidden folder, an option) or trailing
    dots and underscores; ``record`` if nothing is left."""
    cleaned = "".join(c if c.isalnum() or c in "-_." else "_" for c in text)
    cleaned = cleaned.lstrip("._-").rstrip("._")
    return cleaned or "record"


def folder_name(path: str | os.PathLike[str], digits: int = _DIGITS[0]) -> str:
    """The folder name of one batch input: ``<stem>-<hash>``, e.g. ``gyro-3f2a9c``.

    Parameters
    ----------
    path : str or path-like
        The input (its :func:`file_key` is hashed, so the name does not depend on how the
        path is written or on the other files).
    digits : int
        Hex digits of the SHA-1 of the key.

    Returns
    -------
    str
    """
    key = file_key(path)
    digest = hashlib.sha1(key.encode("utf-8", "surrogateescape")).hexdigest()[:digits]
    return f"{safe_stem(Path(key).stem)}-{digest}"


def output_names(
    paths: Sequence[str | os.PathLike[str]], recorded: Mapping[str, str] | None = None
) -> list[str]:
    """The folder name of every input: the recorded one, else :func:`folder_name`.

    Parameters
    ----------
    paths : sequence of str or path-like
    recorded : mapping, optional
        :func:`file_key` -> name of the files of earlier runs (their names are kept, and
        no new name takes one of them).

    Returns
    -------
    list of str
        One name per path, in order, unique case-insensitively (a name already taken
        gets more hash digits), never a name of :data:`RESERVED`.
    """
    recorded = dict(recorded or {})
    keys = [file_key(p) for p in paths]
    taken = {name.casefold() for key, name in recorded.items()}
    names: list[str] = []
    for path, key in zip(paths, keys, strict=True):
        name = recorded.get(key)
        if name is None:
            for digits in _DIGITS:
                name = folder_name(path, digits)
                if name.casefold() not in taken and name.casefold() not in RESERVED:
                    break
            else:  # 40 digits taken: only a hand-made state does that
                k = 2
                while f"{name}-{k}".casefold() in taken:
                    k += 1
                name = f"{name}-{k}"
            taken.add(name.casefold())
            recorded[key] = name
        names.append(name)
    return names


def _holder(fd: int) -> str:
    """Who holds the lock of ``fd``'s file, from what it wrote there."""
    with contextlib.suppress(OSError, ValueError, TypeError, KeyError):
        info = json.loads(os.pread(fd, 4096, 0).decode("utf-8"))
        host = str(info["host"])
        where = "" if host == socket.gethostname() else f" on {host}"
        return f"pid {int(info['pid'])}{where}"
    return "pid unknown"


@contextlib.contextmanager
def locked(out: Path, shown: str | os.PathLike[str] | None = None) -> Iterator[None]:
    """Hold the batch folder ``out`` for this run (:data:`BATCH_LOCK`), or stop at once.

    Parameters
    ----------
    out : Path
        An existing batch folder.
    shown : str or path-like, optional
        How the folder is named in the error (the ``--out`` as given).

    Raises
    ------
    AdavarInputError
        Another run holds it (the message names its pid), or the lock file cannot be
        written. Where the file system has no locks (``flock`` unsupported), the run goes
        on unlocked.
    """
    shown = out if shown is None else shown
    try:
        import fcntl
    except ImportError:  # not POSIX: no flock
        yield
        return
    try:
        fd = os.open(out / BATCH_LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise AdavarInputError(
            f"cannot write the output folder {out}: {exc.strerror or exc}"
        ) from None
    try:
        held = True
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise AdavarInputError(
                    f"{shown} is being written by another adavar run ({_holder(fd)}); wait "
                    "for it or choose another --out"
                ) from None
            held = False  # a file system without locks (some network ones): unlocked
        if held:
            info = {"pid": os.getpid(), "host": socket.gethostname(), "started": time.time()}
            with contextlib.suppress(OSError):
                os.ftruncate(fd, 0)
                os.pwrite(fd, (json.dumps(info) + "\n").encode("utf-8"), 0)
        yield
    finally:
        os.close(fd)  # releases the lock


def read_result(folder: Path) -> dict[str, Any] | None:
    """``folder/result.json`` as a dict, or None (missing, unreadable, not an object)."""
    try:
        stored = json.loads((folder / "result.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return stored if isinstance(stored, dict) else None


def outputs_record(html: bool, files: Sequence[str]) -> dict[str, Any]:
    """The ``outputs`` of a result.json: the layout, the options that shaped the outputs
    and the files written."""
    return {"format": OUTPUT_FORMAT, "html": bool(html), "files": sorted(files)}


def outputs_complete(stored: Mapping[str, Any], folder: Path, html: bool) -> bool:
    """Whether a stored result has every output a run with ``html`` needs.

    Parameters
    ----------
    stored : mapping
        The file's result.json.
    folder : Path
        Its folder.
    html : bool
        Whether this run writes report.html.

    Returns
    -------
    bool
        False for another :data:`OUTPUT_FORMAT`, a run that wants the report of a result
        written without it, or an expected file that is missing.
    """
    outputs = stored.get("outputs")
    if not isinstance(outputs, Mapping) or outputs.get("format") != OUTPUT_FORMAT:
        return False
    if html and not outputs.get("html"):
        return False
    needed = {"result.json", "deviation.csv", *(("report.html",) if html else ())}
    files = outputs.get("files")
    if not isinstance(files, list) or not needed <= set(files):
        return False
    return all((folder / name).is_file() for name in needed)


def _listed(items: Sequence[str]) -> str:
    shown = ", ".join(items[:_MAX_LISTED])
    return shown + (f", ... ({len(items)} in all)" if len(items) > _MAX_LISTED else "")


@dataclass
class BatchState:
    """The files of a batch folder: :func:`file_key` -> folder name and path.

    Attributes
    ----------
    out : Path
        The batch folder.
    names : dict
        :func:`file_key` -> folder name, of every file of every run still in ``out``.
    files : dict
        :func:`file_key` -> the path as it was given.
    notes : list of str
        What loading found (folders adopted, files forgotten, folders of nobody).
    """

    out: Path
    names: dict[str, str] = field(default_factory=dict)
    files: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @classmethod
    def load(cls, out: Path) -> BatchState:
        """The state of ``out``: its state file, or (a batch folder of an older adavar, or
        a lost state file) the ``result.json`` of its folders."""
        state = cls(out)
        try:
            data = json.loads((out / BATCH_STATE).read_text(encoding="utf-8"))
            entries = data["files"]
            for key, entry in entries.items():
                if isinstance(entry, dict) and isinstance(entry.get("name"), str):
                    state.names[str(key)] = entry["name"]
                    state.files[str(key)] = str(entry.get("file") or key)
            return state
        except FileNotFoundError:
            pass
        except (OSError, ValueError, TypeError, KeyError, AttributeError):
            state.notes.append(f"{BATCH_STATE} was unreadable: rebuilt it from the folders")
            state.names.clear()
            state.files.clear()
        state._adopt()
        return state

    def _adopt(self) -> None:
        """Take over the folders of an older batch (each result.json names its file)."""
        from adavar.core.atomic import OUTPUT_MARKER, write_marker

        found: dict[str, tuple[str, str, str]] = {}  # key -> (finished, name, file)
        for folder in self._folders():
            stored = read_result(folder)
            if stored is None or stored.get("name") != folder.name:
                continue
            path = stored.get("file")
            if not isinstance(path, str):
                continue
            key = file_key(path)
            finished = str(stored.get("finished") or "")
            if key not in found or finished > found[key][0]:  # the newest folder of a file
                found[key] = (finished, folder.name, path)
        for key, (_, name, path) in found.items():
            self.names[key] = name
            self.files[key] = path
            if not (self.out / name / OUTPUT_MARKER).is_file():
                with contextlib.suppress(OSError):
                    write_marker(self.out / name)  # adavar batch wrote it: it may replace it

    def _folders(self) -> list[Path]:
        try:
            return sorted(
                p for p in self.out.iterdir() if p.is_dir() and not p.name.startswith(".")
            )
        except OSError:
            return []

    def assign(self, paths: Sequence[str]) -> list[str]:
        """The folder names of this run's files (recorded ones kept, new ones recorded)."""
        names = output_names(paths, self.names)
        for path, name in zip(paths, names, strict=True):
            key = file_key(path)
            self.names[key] = name
            self.files[key] = path
        return names

    def absent(self, keys: set[str]) -> list[tuple[str, str, dict[str, Any] | None]]:
        """The files of earlier runs not in ``keys``: (path, name, stored result.json).

        A file whose folder is gone is forgotten (with a note).
        """
        out: list[tuple[str, str, dict[str, Any] | None]] = []
        forgotten = []
        for key in sorted(set(self.names) - keys, key=lambda k: self.files.get(k, k)):
            name = self.names[key]
            if not (self.out / name).is_dir():
                forgotten.append(self.files.get(key, key))
                del self.names[key]
                self.files.pop(key, None)
                continue
            out.append((self.files.get(key, key), name, read_result(self.out / name)))
        if forgotten:
            self.notes.append(
                f"forgot {len(forgotten)} file(s) of earlier runs whose folders were removed "
                f"from the output folder: {_listed(forgotten)}"
            )
        if out:
            self.notes.append(
                f"{len(out)} file(s) of earlier runs are not among this run's inputs: their "
                f"folders and rows are kept (status {STATUS_ABSENT} in the summary; delete "
                f"a folder to drop its file): {_listed([path for path, _, _ in out])}"
            )
        return out

    def orphans(self) -> list[str]:
        """Folders of ``out`` that belong to no file (left by hand, or duplicates of an
        older adavar), with a note naming them."""
        names = {name.casefold() for name in self.names.values()}
        found = [p.name for p in self._folders() if p.name.casefold() not in names]
        if found:
            self.notes.append(
                f"{len(found)} folder(s) in the output folder belong to no input file (left "
                f"by an older adavar or put there by hand): {_listed(found)}; delete them if "
                "you no longer need them"
            )
        return found

    def save(self) -> None:
        """Write :data:`BATCH_STATE` atomically."""
        from adavar import __version__
        from adavar.core.atomic import atomic_file

        payload = {
            "adavar_version": __version__,
            "note": "the folder of every file of this batch folder; adavar batch keeps it",
            "files": {key: {"name": self.names[key], "file": self.files.get(key, key)}
                      for key in sorted(self.names)},
        }  # fmt: skip
        with atomic_file(self.out / BATCH_STATE) as handle:
            handle.write((json.dumps(payload, indent=1) + "\n").encode("utf-8"))

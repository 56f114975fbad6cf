"""Where ``adavar monitor`` reads its bytes: standard input, a followed file, a UDP port.

Each source is an iterable of byte chunks as they arrive: ``bytes`` (new data), ``None``
(nothing new within the poll interval, so that the caller can update its status line and
read its stop flag) or :data:`BOUNDARY` (a followed file ended and another begins: a
partial line or sample of the old one cannot continue in the new one). A source never
prints: what happened to it (a file truncated, replaced or deleted; datagrams lost or
malformed) goes to :attr:`Source.notices`, and its counts to :meth:`Source.stats`, for the
command to report.

- Standard input is read as it arrives; the writer waits while the monitor is busy (a
  pipe loses nothing).
- A file is followed like ``tail -F``: read to its end, then polled; truncated, it is read
  again from its start; replaced (``mv`` + a new file: log rotation), the old file is read
  to its end and the new one from its start; deleted or moved away, what is left of it is
  read and a new file at the same path is waited for.
- UDP datagrams are read on a thread of their own into a queue, with the largest receive
  buffer the system allows (``net.core.rmem_max`` on Linux), so that the kernel keeps
  nothing waiting while a push runs; the command takes the whole queue at once (one push
  for every datagram that came meanwhile). Datagrams the kernel still drops are counted
  (Linux: ``SO_RXQ_OVFL`` and ``/proc/net/udp``); a binary datagram that is not a whole
  number of samples is dropped and counted (it would shift every later sample).
"""

from __future__ import annotations

import os
import re
import select
import socket
import stat
import struct
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from adavar.cli.options import UsageError

__all__ = [
    "BOUNDARY",
    "FollowedFile",
    "Source",
    "StdinSource",
    "UdpSource",
    "open_source",
]

#: bytes read at a time from a file or a pipe
READ_BYTES = 1 << 16
#: seconds between polls of a file that has no new data
POLL_SECONDS = 0.05
#: longest wait for data before the caller gets control back (status line, stop flag)
WAIT_SECONDS = 0.25
#: shortest interval between two batches of datagrams: one push for all that came within
#: it (a push costs tens of microseconds of Python whatever its size)
BATCH_SECONDS = 0.02
#: receive buffer asked for (the kernel grants at most its limit: net.core.rmem_max)
RECEIVE_BUFFER = 1 << 26
#: Linux: SO_RXQ_OVFL (the socket's drop count with every datagram), absent from ``socket``
_SO_RXQ_OVFL = getattr(socket, "SO_RXQ_OVFL", 40 if sys.platform.startswith("linux") else None)


class _Boundary:
    def __repr__(self) -> str:
        return "BOUNDARY"


#: a followed file ended (truncated or replaced) and the next bytes begin another
BOUNDARY: Any = _Boundary()


class Source:
    """A stream of byte chunks (see the module notes); iterate it once, then :meth:`close`.

    Attributes
    ----------
    name : str
        The source as given (``-``, a path, ``udp://HOST:PORT``).
    notices : list of str
        What happened to the source since the caller last emptied the list.
    ended : str
        Why the iteration ended: ``"end of input"`` or ``"idle timeout"``.
    """

    def __init__(self, name: str, idle: float | None) -> None:
        self.name = name
        self.idle = idle
        self.notices: list[str] = []
        self.ended = "end of input"

    def _wait(self) -> float:
        return WAIT_SECONDS if self.idle is None else min(WAIT_SECONDS, self.idle)

    def __iter__(self) -> Iterator[Any]:  # pragma: no cover - abstract
        raise NotImplementedError

    def stats(self) -> dict[str, Any]:
        """Counts for the JSON output (none for a pipe)."""
        return {}

    def event_fields(self) -> dict[str, Any]:
        """What every event line carries about the source (UDP: the losses so far)."""
        return {}

    def status(self) -> str:
        """A few words for the status line (UDP: datagrams and losses)."""
        return ""

    def close(self) -> None:
        """Release the file, socket or thread."""

    def drain(self) -> bytes:
        """What was received but not yet given out (read after :meth:`close`)."""
        return b""


class StdinSource(Source):
    """Standard input, read as it arrives."""

    def __iter__(self) -> Iterator[bytes | None]:
        stream = sys.stdin.buffer if hasattr(sys.stdin, "buffer") else None
        try:
            fd = (stream or sys.stdin).fileno()
        except (AttributeError, OSError, ValueError):
            fd = None
        if fd is None:  # an in-memory stdin (tests, notebooks): read it as it is
            data = sys.stdin.read()
            yield data.encode() if isinstance(data, str) else data
            return
        last = time.monotonic()
        while True:
            try:
                ready, _, _ = select.select([fd], [], [], self._wait())
            except (OSError, ValueError):  # not selectable (Windows): blocking reads
                ready = [fd]
            if ready:
                data = os.read(fd, READ_BYTES)
                if not data:
                    return
                last = time.monotonic()
                yield data
            elif self.idle is not None and time.monotonic() - last >= self.idle:
                self.ended = "idle timeout"
                return
            else:
                yield None


def _identity(st: os.stat_result) -> tuple[int, int]:
    return (st.st_dev, st.st_ino)


class FollowedFile(Source):
    """A file followed like ``tail -F`` (module notes); its changes are noticed."""

    def __init__(self, path: Path, name: str, idle: float | None) -> None:
        super().__init__(name, idle)
        self.path = path
        try:
            self._handle = path.open("rb")
        except OSError as exc:
            raise UsageError(f"cannot read {name!r}: {exc.strerror or exc}") from None
        self._id = _identity(os.fstat(self._handle.fileno()))
        self._missing = False
        self.counts = {"truncated": 0, "replaced": 0, "deleted": 0}

    def stats(self) -> dict[str, Any]:
        return {"file_" + key: value for key, value in self.counts.items()}

    def _changed(self) -> bool | bytes:
        """At the end of the file: False (no change), the rest of the old file before a
        switch to a new one (bytes, maybe empty), or True (truncated: read it again)."""
        try:
            st = os.stat(self.path)
        except OSError:
            if not self._missing:
                self._missing = True
                self.counts["deleted"] += 1
                self.notices.append(
                    f"{self.name} was deleted or moved away: what is left of it is read, then "
                    "a new file of that name is waited for"
                )
            return False
        if _identity(st) != self._id:
            try:
                handle = self.path.open("rb")
            except OSError:  # gone again, or not readable yet: the next poll retries
                return False
            rest = self._handle.read()  # what the old file got since the last read
            self._handle.close()
            self._handle, self._id = handle, _identity(os.fstat(handle.fileno()))
            if self._missing:
                self.notices.append(f"{self.name} has appeared: following the new file")
            else:
                self.counts["replaced"] += 1
                self.notices.append(
                    f"{self.name} was replaced (rotated): the old file was read to its end; "
                    "following the new one from its start"
                )
            self._missing = False
            return rest
        self._missing = False  # moved back (the same file)
        if not stat.S_ISREG(st.st_mode):  # a named pipe or a device: no size to compare
            return False
        position = self._handle.tell()
        if st.st_size < position:
            self.counts["truncated"] += 1
            self.notices.append(
                f"{self.name} was truncated (from {position} to {st.st_size} bytes): reading "
                "it again from its start"
            )
            self._handle.seek(0)
            return True
        return False

    def __iter__(self) -> Iterator[Any]:
        last = time.monotonic()
        while True:
            data = self._handle.read(READ_BYTES)
            if data:
                last = time.monotonic()
                yield data
                continue
            change = self._changed()
            if change is not False:
                if isinstance(change, bytes) and change:
                    yield change
                last = time.monotonic()
                yield BOUNDARY
                continue
            if self.idle is not None and time.monotonic() - last >= self.idle:
                self.ended = "idle timeout"
                return
            yield None
            time.sleep(POLL_SECONDS)

    def close(self) -> None:
        self._handle.close()


def _proc_drops(sock: socket.socket) -> int | None:
    """Datagrams the kernel dropped for ``sock`` (Linux ``/proc/net/udp``), None elsewhere."""
    try:
        inode = str(os.fstat(sock.fileno()).st_ino)
    except (OSError, ValueError):
        return None
    for table in ("/proc/net/udp", "/proc/net/udp6"):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            if len(fields) > 12 and fields[9] == inode:
                return int(fields[-1])
    return None


class UdpSource(Source):
    """Datagrams on a local port, read by a thread of their own (module notes).

    Parameters
    ----------
    host, port
        Where to listen.
    itemsize : int or None
        Bytes a binary sample takes (a datagram must hold whole samples); None for text.
    check_text : callable, optional
        Text: what is wrong with a datagram (None: nothing); a bad one is dropped and
        counted, as a binary one of a wrong size is, instead of ending the stream.
    """

    def __init__(
        self, name: str, host: str, port: int, idle: float | None, itemsize: int | None,
        check_text: Callable[[bytes], str | None] | None = None,
    ) -> None:  # fmt: skip
        super().__init__(name, idle)
        self._check_text = check_text
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_DGRAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER)
        except OSError:  # pragma: no cover - the default buffer then
            pass
        self.receive_buffer = int(sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF))
        self._overflow = False
        if _SO_RXQ_OVFL is not None:
            try:
                sock.setsockopt(socket.SOL_SOCKET, _SO_RXQ_OVFL, 1)
                self._overflow = True
            except OSError:  # pragma: no cover - an old kernel: /proc only
                pass
        try:
            sock.bind((host, port))
        except OSError as exc:
            sock.close()
            raise UsageError(f"cannot listen on {name}: {exc.strerror or exc}") from None
        sock.settimeout(0.1)  # the thread looks at its stop flag this often
        self._sock = sock
        self.itemsize = itemsize
        self.datagrams = 0  # taken into the queue
        self.bytes = 0
        self.bad = 0  # dropped: not a whole number of samples
        self.lost = 0  # dropped by the kernel (receive buffer full)
        self._reported = 0  # losses already noticed
        self._checked = 0.0  # last look at /proc
        self._queue: list[bytes] = []
        self._lock = threading.Lock()
        self._ready = threading.Event()
        self._stop = False
        self._error: BaseException | None = None
        self._last = time.monotonic()
        self._thread = threading.Thread(target=self._read, name="adavar-monitor-udp", daemon=True)
        self._thread.start()

    def _read(self) -> None:
        """The reader thread: datagrams into the queue, as fast as they come."""
        sock, size = self._sock, self.itemsize
        room = socket.CMSG_SPACE(4) if self._overflow else 0
        lock, queue, ready = self._lock, self._queue, self._ready
        try:
            while not self._stop:
                try:
                    data, ancillary, _, _ = sock.recvmsg(1 << 16, room)
                except TimeoutError:
                    continue
                for level, kind, value in ancillary:
                    if level == socket.SOL_SOCKET and kind == _SO_RXQ_OVFL and len(value) >= 4:
                        # the socket's drops so far, sent with the next datagram it keeps
                        self.lost = max(self.lost, struct.unpack("=I", value[:4])[0])
                self._last = time.monotonic()
                why = None
                if size and len(data) % size:
                    why = f"of {len(data)} bytes, not a whole number of {size}-byte samples"
                elif not size and self._check_text is not None:
                    problem = self._check_text(data)
                    if problem:
                        why = f"that is not lines of numbers ({problem})"
                if why is not None:
                    self.bad += 1
                    if self.bad == 1:  # the first one said, every one counted
                        self.notices.append(
                            f"{self.name}: dropped a datagram {why} (counted in bad_datagrams)"
                        )
                    continue
                with lock:
                    queue.append(data)
                    self.datagrams += 1
                    self.bytes += len(data)
                    ready.set()
        except BaseException as exc:  # handed to the main thread
            if not self._stop:
                self._error = exc
                ready.set()

    def _take(self) -> list[bytes]:
        with self._lock:
            items = self._queue[:]
            del self._queue[:]
            self._ready.clear()
        return items

    def _update_losses(self, force: bool = False) -> None:
        """Once a second: the kernel's drop count (``/proc`` also sees the drops after the
        last datagram kept) and a notice if it grew."""
        now = time.monotonic()
        if not force and now - self._checked < 1.0:
            return
        self._checked = now
        drops = _proc_drops(self._sock)
        if drops is not None:
            self.lost = max(self.lost, drops)
        if self.lost > self._reported:
            self.notices.append(
                f"{self.name}: {self.lost} datagrams lost so far (the kernel's receive buffer, "
                f"{self.receive_buffer} bytes, was full)"
            )
            self._reported = self.lost

    def drain(self) -> bytes:
        """The datagrams received but not yet taken (after :meth:`close`)."""
        items = self._take()
        if self.itemsize is None:
            items = [d if d.endswith(b"\n") else d + b"\n" for d in items if d]
        return b"".join(items)

    def __iter__(self) -> Iterator[bytes | None]:
        last_batch = 0.0
        while True:
            got = self._ready.wait(self._wait())
            if self._error is not None:
                raise UsageError(f"{self.name}: receiving failed: {self._error}")
            self._update_losses()
            if got:
                pause = BATCH_SECONDS - (time.monotonic() - last_batch)
                if pause > 0:
                    time.sleep(pause)  # let a batch gather: one push for all of it
                last_batch = time.monotonic()
                yield self.drain()
            elif self.idle is not None and time.monotonic() - self._last >= self.idle:
                self.ended = "idle timeout"
                return
            else:
                yield None

    def stats(self) -> dict[str, Any]:
        return {
            "datagrams": self.datagrams,
            "lost_datagrams": self.lost,
            "bad_datagrams": self.bad,
            "receive_buffer": self.receive_buffer,
        }

    def event_fields(self) -> dict[str, Any]:
        return {"lost_datagrams": self.lost, "bad_datagrams": self.bad}

    def status(self) -> str:
        bad = f", {self.bad} bad" if self.bad else ""
        return f", {self.datagrams} datagrams, {self.lost} lost{bad}"

    def close(self) -> None:
        if self._stop:
            return
        self._stop = True
        self._thread.join()
        self._update_losses(force=True)
        self._sock.close()


def open_source(
    source: str, idle: float | None, itemsize: int | None,
    check_text: Callable[[bytes], str | None] | None = None,
) -> Source:  # fmt: skip
    """The source ``SOURCE`` names (``-``, ``udp://HOST:PORT`` or a file path).

    ``itemsize``: bytes of a binary sample (None for text); ``check_text``: for text
    datagrams, what is wrong with one (:class:`UdpSource`).
    """
    if source == "-":
        return StdinSource("standard input", idle)
    if source.startswith("udp://"):
        match = re.fullmatch(r"udp://\[?([^\[\]]+?)\]?:(\d+)", source)
        if match is None or not 0 < int(match.group(2)) < 65536:
            raise UsageError(f"SOURCE {source!r}: give udp://127.0.0.1:PORT (PORT 1-65535)")
        host = "127.0.0.1" if match.group(1) == "localhost" else match.group(1)
        return UdpSource(source, host, int(match.group(2)), idle, itemsize, check_text)
    path = Path(source)
    if not path.exists():
        raise UsageError(f"SOURCE {source!r}: no such file (give -, a file or udp://HOST:PORT)")
    if path.is_dir():
        raise UsageError(f"SOURCE {source!r} is a folder: give a file")
    return FollowedFile(path, source, idle)

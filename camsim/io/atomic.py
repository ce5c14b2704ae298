"""The temporary file of an output: the mechanics under the output policy.

Every file camsim writes is written to a temporary name beside it and renamed into place
(:func:`camsim.io.outputs.writing`, the only way in): a crash, an error or Ctrl-C never
leaves a half-written file under the requested name. The temporary name carries the
writer's process id (``.<name>.<pid>.<8 hex>.tmp``): it is removed when the write fails
(an exception, Ctrl-C, SIGTERM turned into KeyboardInterrupt), and one left by a process
that was killed outright (SIGKILL, a power cut) is removed by the next writer of the same
target, which can prove it abandoned because that process no longer exists
(:func:`remove_stale_temps`).

A writer is handed a :class:`Target`, never a path: it writes through the target's
opened file (:meth:`Target.text`, :meth:`Target.binary`, :meth:`Target.h5`,
:meth:`Target.put_bytes`). Every byte goes through one function (:meth:`Sink.write`),
so the file system's refusals (no space, a quota, an I/O error) are met in one place.

HDF5 and a full disk
--------------------
HDF5 writes much of a file from its caches when objects are closed, inside h5py's
deallocators, where a write error cannot be raised: it is printed ("Exception ignored
in ... Can't decrement id ref count ... No space left on device") and the library goes
on with a file whose state no longer matches its caches. A sweep with ``--keep-traces``
onto a full disk printed 468 such tracebacks and then died of SIGSEGV or SIGBUS. The HDF5
file is therefore opened on a Python file object (h5py's file-object driver) whose
:meth:`Sink.write` *latches* the first error: that write and the ones after it are kept
in memory (up to :data:`OVERLAY_LIMIT`, beyond which raw data is dropped; the file is
discarded anyway) and reported as done, so HDF5 stays consistent and closes cleanly;
the writer sees the error at its next :meth:`Target.check` (a streamed run checks after
each piece) and the policy raises it when the block ends. Same bytes as HDF5's own
driver (checked), same speed.
"""

from __future__ import annotations

import errno
import io
import os
import re
from pathlib import Path
from typing import Any

from camsim.errors import FileSystemError, InputError


def check_writable(target: str | os.PathLike[str]) -> Path:
    """Raise :class:`InputError` unless a file can be created at ``target``.

    Checked before any computation, so that a long run does not end in a write error.
    """
    path = Path(target)
    directory = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, not an output file")
    if not directory.is_dir():
        raise InputError(f"{path}: output directory {directory} does not exist")
    if not os.access(directory, os.W_OK):
        raise InputError(f"{path}: output directory {directory} is not writable")
    try:  # root passes os.access on a mode-0555 folder; a read-only mount says EROFS
        if os.statvfs(directory).f_flag & os.ST_RDONLY:
            raise InputError(f"{path}: output directory {directory} is on a read-only file system")
    except (OSError, AttributeError):
        pass
    if path.exists() and not os.access(path, os.W_OK):
        raise InputError(f"{path}: output file is not writable")
    return path


_TEMP = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.[0-9a-f]{8}\.tmp$")


def temp_path_for(target: str | os.PathLike[str]) -> Path:
    """A fresh temporary name beside ``target`` carrying this process's id.

    ``.<name>.<pid>.<8 hex>.tmp`` in the target's directory (same file system, so the
    final ``os.replace`` is atomic). :func:`remove_stale_temps` recognises it.
    """
    import secrets  # here, not at start-up: every command imports this module

    target = Path(target)
    return target.with_name(f".{target.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")


def pid_alive(pid: int) -> bool:
    """True when a process with this id exists (zombies included)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except OSError as exc:
        return exc.errno == errno.EPERM  # exists, owned by someone else
    return True


def remove_stale_temps(target: str | os.PathLike[str]) -> list[Path]:
    """Remove temporary files of ``target`` whose writer process is dead.

    Only files named by :func:`temp_path_for` for this very target are considered, and
    only when the process id in the name does not exist any more, so the temporary file
    of a writer that is still running is never touched. (A process id reused by an
    unrelated process keeps a stale file until that process ends: safe, not eager.)

    Returns
    -------
    list of Path
        The files removed.
    """
    target = Path(target)
    directory = target.parent if str(target.parent) else Path(".")
    removed = []
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return removed
    for entry in entries:
        m = _TEMP.match(entry.name)
        if not m or m.group("name") != target.name:
            continue
        pid = int(m.group("pid"))
        if pid == os.getpid() or pid_alive(pid):
            continue
        try:
            os.unlink(entry.path)
            removed.append(Path(entry.path))
        except FileNotFoundError:
            pass
    return removed


#: Bytes of writes kept in memory after a latched HDF5 write error (beyond: raw data dropped).
OVERLAY_LIMIT = 64 * 2**20


class Sink(io.RawIOBase):
    """The temporary file of one output, written with ``pwrite`` at an explicit position.

    Parameters
    ----------
    path : Path
        The temporary file (created, must not exist).
    latch : bool
        Keep the first write error instead of raising it (HDF5, see the module docstring).
    """

    def __init__(self, path: Path, latch: bool = False) -> None:
        super().__init__()
        self.fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666)
        self.latch = latch
        self.error: OSError | None = None
        self._pos = 0
        self._size = 0
        self._overlay: list[tuple[int, bytes]] = []
        self._kept = 0

    # io.RawIOBase
    def readable(self) -> bool:
        return True

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def tell(self) -> int:
        return self._pos

    def seek(self, offset: int, whence: int = 0) -> int:
        base = {0: 0, 1: self._pos, 2: self._size}[whence]
        self._pos = base + offset
        return self._pos

    def write(self, data: Any) -> int:
        """Write ``data`` at the current position (all of it, or raise / latch the error)."""
        chunk = bytes(data)
        if self.fd < 0:  # finished or abandoned: a wrapper's late flush has nowhere to go
            return len(chunk)
        if self.error is None:
            try:
                done = 0
                while done < len(chunk):
                    done += raw_write(self.fd, chunk[done:] if done else chunk, self._pos + done)
            except OSError as exc:
                if not self.latch:
                    raise
                self.error = exc
        if self.error is not None and self._kept < OVERLAY_LIMIT:
            self._overlay.append((self._pos, chunk))
            self._kept += len(chunk)
        self._pos += len(chunk)
        self._size = max(self._size, self._pos)
        return len(chunk)

    def readinto(self, buffer: Any) -> int:
        n = len(buffer)
        end = max(0, min(n, self._size - self._pos))
        data = bytearray(os.pread(self.fd, end, self._pos).ljust(end, b"\0"))
        for offset, chunk in self._overlay:
            lo, hi = max(offset, self._pos), min(offset + len(chunk), self._pos + end)
            if lo < hi:
                data[lo - self._pos : hi - self._pos] = chunk[lo - offset : hi - offset]
        buffer[:end] = data
        self._pos += end
        return end

    def truncate(self, size: int | None = None) -> int:
        size = self._pos if size is None else size
        if self.error is None:
            try:
                os.ftruncate(self.fd, size)
            except OSError as exc:
                if not self.latch:
                    raise
                self.error = exc
        self._size = size
        return size

    def flush(self) -> None:
        pass

    def close(self) -> None:
        """Text and binary wrappers close their raw file: that is not the end of the output
        (:meth:`finish` is)."""

    def finish(self) -> None:
        """Make the file durable (``fsync``) and close it; raise the latched error if any."""
        if self.fd < 0:
            return
        try:
            if self.error is None:
                os.fsync(self.fd)
        except OSError as exc:
            if exc.errno not in (errno.EINVAL, errno.EROFS):  # some file systems cannot sync
                self.error = exc
        finally:
            self._release()
        if self.error is not None:
            raise self.error

    def abandon(self) -> None:
        if self.fd >= 0:
            self._release()
        self._overlay = []

    def _release(self) -> None:
        # marked closed before it is closed: Ctrl-C or SIGTERM landing between the two would
        # leave fd set, and the policy's abandon() would close the number again (EBADF, or
        # a file that another part of the process had been given that number since)
        fd, self.fd = self.fd, -1
        self._overlay = []
        os.close(fd)


def raw_write(fd: int, data: bytes, offset: int | None = None) -> int:
    """The one write of every byte camsim puts in a file (the conformance tests inject
    ENOSPC here): at ``offset``, or at the end of a file opened for appending (None)."""
    if offset is None:
        return os.write(fd, data)
    return os.pwrite(fd, data, offset)


def open_journal(path: str | os.PathLike[str]) -> int:
    """A file descriptor appending to the existing journal ``path`` (a row store's).

    The journal is created by :func:`camsim.io.outputs.writing` (its header line, atomically);
    rows are then appended with :func:`append_record`.
    """
    try:
        return os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CLOEXEC)
    except OSError as exc:
        if FileSystemError.applies(exc):
            raise FileSystemError(str(path), exc, "open") from None
        raise


def append_record(fd: int, data: bytes, fsync: bool = True) -> None:
    """Append ``data`` with one ``write`` (and ``fsync`` it); a short write is an ENOSPC."""
    written = raw_write(fd, data)
    if written != len(data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    if fsync:
        os.fsync(fd)


class Target:
    """The opened temporary file of one output, handed to a writer by the output policy.

    Attributes
    ----------
    final : Path
        The output's name (for messages); the file appears there when the policy renames
        the temporary file at the end of a successful write.
    """

    def __init__(self, final: Path) -> None:
        self.final = final
        self._tmp = temp_path_for(final)
        self._sink: Sink | None = None
        self._wrappers: list[Any] = []

    def _open(self, latch: bool = False) -> Sink:
        if self._sink is not None:
            raise RuntimeError(f"{self.final}: the output is already open")
        self._sink = Sink(self._tmp, latch=latch)
        umask = os.umask(0)
        os.umask(umask)
        os.fchmod(self._sink.fd, 0o666 & ~umask)  # the permissions a plain open() would give
        return self._sink

    def h5(self, **options: Any):
        """The HDF5 file (h5py, reproducible settings of :func:`camsim.io.hdf5.create_file`).

        Write errors are latched (module docstring): check :meth:`check` between long
        stretches of writing."""
        from camsim.io.hdf5 import create_file

        return create_file(self._open(latch=True), **options)

    def text(self) -> io.TextIOWrapper:
        """A UTF-8 text file (``newline=""``: the writer's line ends are kept)."""
        wrapper = io.TextIOWrapper(io.BufferedWriter(self._open()), encoding="utf-8", newline="")
        self._wrappers.append(wrapper)
        return wrapper

    def binary(self) -> io.BufferedWriter:
        """A binary file."""
        wrapper = io.BufferedWriter(self._open())
        self._wrappers.append(wrapper)
        return wrapper

    def put_bytes(self, data: bytes) -> None:
        """The whole file at once."""
        with self.binary() as fh:
            fh.write(data)

    def put_text(self, text: str) -> None:
        """The whole file at once, as UTF-8 text."""
        with self.text() as fh:
            fh.write(text)

    @property
    def error(self) -> OSError | None:
        """The latched write error of an HDF5 target (None: none so far)."""
        return None if self._sink is None else self._sink.error

    def check(self) -> None:
        """Raise :class:`FileSystemError` if a write has failed (stop computing for nothing)."""
        if self.error is not None:
            raise FileSystemError(str(self.final), self.error)

    # -- used by the policy only ---------------------------------------------------------
    def _finish(self) -> None:
        """Flush, fsync and close; raise the write error if one happened."""
        for wrapper in self._wrappers:
            try:
                wrapper.flush()  # a writer that did not close its file
            except ValueError:
                pass  # closed by the writer (its raw file stays open: Sink.close)
        if self._sink is None:
            self._open()  # a writer that wrote nothing: an empty file
        self._sink.finish()
        os.replace(self._tmp, self.final)

    def _discard(self) -> None:
        if self._sink is not None:
            self._sink.abandon()
        self._tmp.unlink(missing_ok=True)

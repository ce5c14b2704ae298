"""Advisory locks beside the outputs being written (docs/results.md, "Locks").

While a process writes an output ``dir/run.h5`` it holds an exclusive ``flock`` on
``dir/.run.h5.lock``, a small file holding its process id. A second writer of the same
output finds the lock taken and stops before computing anything (exit 2), naming the
holder's process id. The operating system releases a ``flock`` when its process dies, so
a writer killed outright (SIGKILL, a power cut) never leaves a lock that blocks the next
one: the next writer takes the lock of the dead process's file and carries on.

The lock file is removed when the lock is released. Removing a lock file is safe only if
a writer that opened the old file before it was removed notices: after taking the lock a
writer checks that the file it locked is still the one under the name (same inode), and
starts again otherwise.

Locks are re-entrant within a process (a command that checks an output before computing
and writes it at the end takes the lock once); they are counted and released with the
last release.
"""

from __future__ import annotations

import errno
import fcntl
import os
from dataclasses import dataclass
from pathlib import Path

from camsim.errors import FileSystemError, OutputLockedError

__all__ = ["OutputLock", "acquire", "lock_path_for", "holder"]


def lock_path_for(path: str | os.PathLike[str]) -> Path:
    """The lock file of an output: ``.<name>.lock`` in the output's folder."""
    p = Path(path)
    return p.with_name(f".{p.name}.lock")


def _key(path: Path) -> str:
    return os.path.realpath(path)


@dataclass
class OutputLock:
    """An exclusive advisory lock held by this process on one output."""

    path: Path
    lock_file: Path
    fd: int
    count: int = 1

    def release(self) -> None:
        """Give up one hold; the last one removes the lock file and releases the lock."""
        self.count -= 1
        if self.count > 0:
            return
        _HELD.pop(_key(self.path), None)
        try:
            if _same_file(self.fd, self.lock_file):
                self.lock_file.unlink(missing_ok=True)  # while still locked: nobody else can hold it
        except OSError:
            pass
        try:
            os.close(self.fd)  # releases the flock
        except OSError:
            pass


#: Locks this process holds, by the output's real path.
_HELD: dict[str, OutputLock] = {}


def _same_file(fd: int, path: Path) -> bool:
    try:
        a, b = os.fstat(fd), os.stat(path)
    except OSError:
        return False
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def holder(path: str | os.PathLike[str]) -> int | None:
    """The process id written in the lock file of ``path`` (None when unreadable)."""
    try:
        text = lock_path_for(path).read_text(encoding="ascii", errors="replace").split()
        return int(text[0]) if text else None
    except (OSError, ValueError):
        return None


def acquire(path: str | os.PathLike[str], *, what: str = "this file") -> OutputLock:
    """Lock the output ``path`` for this process (re-entrant; release with :meth:`OutputLock.release`).

    Raises
    ------
    OutputLockedError
        Another live process holds it (the message names its process id).
    FileSystemError
        The lock file cannot be created (a read-only folder, no space).
    """
    target = Path(path)
    key = _key(target)
    held = _HELD.get(key)
    if held is not None:
        held.count += 1
        return held
    lock_file = lock_path_for(target)
    for _ in range(20):
        try:
            fd = os.open(lock_file, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            if FileSystemError.applies(exc):
                raise FileSystemError(str(lock_file), exc, "create the lock file") from None
            raise
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise
            pid = holder(target)
            who = f"another camsim process (PID {pid})" if pid else "another camsim process"
            raise OutputLockedError(
                f"{target}: {who} is writing {what}; wait for it to finish or write to another name"
            ) from None
        if not _same_file(fd, lock_file):  # removed and re-created by another writer meanwhile
            os.close(fd)
            continue
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
        except OSError:
            pass  # the lock holds without the id; a second writer just cannot name it
        lock = OutputLock(target, lock_file, fd)
        _HELD[key] = lock
        return lock
    raise OutputLockedError(f"{target}: the lock file {lock_file} keeps changing; another process is writing it")


def is_locked(path: str | os.PathLike[str]) -> int | None:
    """The process id of a live writer holding the lock of ``path`` (0 when it cannot be read),
    or None when nobody holds it (this process included)."""
    target = Path(path)
    if _key(target) in _HELD:
        return None
    try:
        fd = os.open(lock_path_for(target), os.O_RDONLY | os.O_CLOEXEC)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError:
        return holder(target) or 0
    finally:
        os.close(fd)
    return None


def is_held(path: str | os.PathLike[str]) -> bool:
    """True when this process holds the lock of ``path``."""
    return _key(Path(path)) in _HELD

"""Atomic output: write to a temporary name beside the target, rename on success.

A crash, an error or Ctrl-C never leaves a half-written file under the requested name.
The temporary name carries the writer's process id (``.<name>.<pid>.<8 hex>.tmp``):
it is removed when the block fails (an exception, Ctrl-C, SIGTERM turned into
KeyboardInterrupt), and a temporary file left by a process that was killed outright
(SIGKILL, a power cut) is removed by the next writer of the same target, which can
prove it abandoned because that process no longer exists (:func:`remove_stale_temps`).
"""

from __future__ import annotations

import errno
import os
import re
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from camsim.errors import InputError


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
    if path.exists() and not os.access(path, os.W_OK):
        raise InputError(f"{path}: output file is not writable")
    return path


_TEMP = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.[0-9a-f]{8}\.tmp$")


def temp_path_for(target: str | os.PathLike[str]) -> Path:
    """A fresh temporary name beside ``target`` carrying this process's id.

    ``.<name>.<pid>.<8 hex>.tmp`` in the target's directory (same file system, so the
    final ``os.replace`` is atomic). :func:`remove_stale_temps` recognises it.
    """
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


@contextmanager
def atomic_path(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path in the target's directory; rename it to ``target`` on success.

    Parameters
    ----------
    target : path
        The final file name.

    Yields
    ------
    Path
        Where to write (``.<name>.<pid>.<8 hex>.tmp``). Removed if the block raises
        (including KeyboardInterrupt); stale ones of dead writers are removed first.
    """
    path = check_writable(target)
    remove_stale_temps(path)
    tmp = temp_path_for(path)
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    os.close(fd)
    # mkstemp creates 0600; give the result the permissions a plain open() would.
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise

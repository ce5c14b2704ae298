"""Atomic output: write to a temporary name beside the target, rename on success.

A crash, an error or Ctrl-C never leaves a half-written file under the requested name.
"""

from __future__ import annotations

import os
import tempfile
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
        Where to write. Removed if the block raises (including KeyboardInterrupt).
    """
    path = check_writable(target)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent or ".")
    os.close(fd)
    tmp = Path(tmp_name)
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

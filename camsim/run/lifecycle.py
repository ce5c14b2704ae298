"""Process lifetime: workers that die with their parent, SIGTERM handled like Ctrl-C.

A long job (a sweep's process pool, a Dask LocalCluster started for it) must not leave
worker processes running at full CPU when the process that owns them is killed, even
with SIGKILL, which the owner cannot catch. Two mechanisms, both in the worker:

* Linux's parent-death signal, ``prctl(PR_SET_PDEATHSIG, SIGKILL)`` through ctypes: the
  kernel kills the worker the moment its parent exits (any platform without it skips
  this);
* a daemon thread that checks every :data:`WATCH_INTERVAL_S` whether the worker's parent
  process is still the one it started under (``os.getppid()`` changes when the parent
  dies and the orphan is re-parented) and ends the worker with ``os._exit`` otherwise.

See docs/results.md, "Long runs".
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["WATCH_INTERVAL_S", "set_parent_death_signal", "watch_parent", "guard_worker", "sigterm_as_interrupt"]

#: Seconds between two checks of the parent by :func:`watch_parent`.
WATCH_INTERVAL_S = 0.5
_PR_SET_PDEATHSIG = 1


def set_parent_death_signal(sig: int = signal.SIGKILL) -> bool:
    """Ask the kernel to send ``sig`` to this process when its parent exits (Linux only).

    Returns
    -------
    bool
        True when the request was accepted.
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def watch_parent(parent_pid: int | None = None, interval: float = WATCH_INTERVAL_S) -> threading.Thread:
    """Start a daemon thread that ends this process when its parent changes.

    Parameters
    ----------
    parent_pid : int, optional
        The expected parent (default: the current one).
    interval : float
        Seconds between checks [s].
    """
    expected = os.getppid() if parent_pid is None else parent_pid

    def watch() -> None:
        import time

        while True:
            if os.getppid() != expected:
                os._exit(1)
            time.sleep(interval)

    thread = threading.Thread(target=watch, name="camsim-parent-watch", daemon=True)
    thread.start()
    return thread


def guard_worker(parent_pid: int | None = None, ignore_sigint: bool = True) -> None:  # pragma: no cover - in workers
    """Initialiser of a worker process: die with the parent; leave Ctrl-C to the parent.

    Parameters
    ----------
    parent_pid : int, optional
        The process that started the worker; when it is already gone (it died between
        the fork and this call), the worker exits at once.
    """
    if ignore_sigint:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    expected = os.getppid() if parent_pid is None else parent_pid
    set_parent_death_signal(signal.SIGKILL)
    if os.getppid() != expected:  # the parent died before the death signal was armed
        os._exit(1)
    watch_parent(expected)


@contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM raises KeyboardInterrupt in the main thread (as Ctrl-C does).

    So that ``kill PID`` (a batch system's stop) takes the same orderly way out as
    Ctrl-C: temporary files removed, finished sweep rows kept. Does nothing outside the
    main thread.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):  # noqa: ARG001
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)

"""A process pool that can always be stopped (issue 45).

``concurrent.futures.ProcessPoolExecutor`` could not be stopped reliably: after Ctrl-C or
SIGTERM its workers were terminated while one held the lock of its result queue, and the
executor's manager thread (joined again by an ``atexit`` hook) waited for ever on a pipe
nobody would write: ``camsim sweep ... --workers 2`` printed "interrupted: kept ..." and
hung. This pool has no thread, no shared queue and no lock:

* each worker is a forked process with its own duplex pipe; the parent sends one task at a
  time to an idle worker and waits on the pipes and the processes' sentinels together
  (:func:`multiprocessing.connection.wait`), so a dead worker is seen at once;
* :meth:`WorkerPool.abort` sends SIGKILL to every worker and reaps it: a worker holds
  nothing that must be kept (the parent stores every finished result), so nothing can
  block the way out;
* workers ignore Ctrl-C (the parent's) and die with their parent even on SIGKILL
  (:func:`camsim.run.lifecycle.guard_worker`).

A worker that dies (killed, out of memory) breaks the pool as a broken
``ProcessPoolExecutor`` did: its task and every task not yet finished come back as failed
rows, marked :data:`EXECUTOR_ERROR`, so a resumed job runs them again.
"""

from __future__ import annotations

import os
import signal
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from typing import Any

__all__ = ["WorkerPool", "EXECUTOR_ERROR", "one_line", "WorkerDied"]

#: Key marking a row that an executor failure (a killed worker) produced, not the variant.
EXECUTOR_ERROR = "_executor_error"
#: Seconds a closing pool waits for its workers to leave before it kills them.
CLOSE_WAIT_S = 2.0


class WorkerDied(RuntimeError):
    """A worker process ended without answering (killed, out of memory)."""


def one_line(exc: BaseException) -> str:
    """An exception as one line: ``"SimulationError: message"``."""
    text = str(exc).strip().splitlines()
    message = text[0] if text else ""
    return f"{type(exc).__name__}: {message}" if message else type(exc).__name__


def _failed(args, exc: BaseException) -> dict:
    """The row of a task whose worker failed, when the caller gives no ``failed`` of its own."""
    return {"status": one_line(exc)}


def failed_value(args, exc: BaseException, failed=None):
    """The failed row of a task (``failed(args, exc)``), marked :data:`EXECUTOR_ERROR` so that
    it is not stored as the task's result (``--resume`` reruns it)."""
    return {**(failed or _failed)(args, exc), EXECUTOR_ERROR: True}, None


def _worker_main(conn, parent_pid: int) -> None:  # pragma: no cover - runs in the workers
    """A worker: run each task the parent sends, send back ``(True, value)`` or ``(False, error)``."""
    from camsim.run.lifecycle import guard_worker

    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # the parent's SIGTERM-as-Ctrl-C is not the worker's
    guard_worker(parent_pid)
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            break
        if message is None:
            break
        fn, args = message
        try:
            reply = (True, fn(*args))
        except BaseException as exc:  # noqa: BLE001 - the parent decides what a failure is
            reply = (False, exc)
        try:
            conn.send(reply)
        except Exception as exc:  # noqa: BLE001 - an answer that does not pickle
            try:
                conn.send((False, RuntimeError(f"the result could not be sent back ({one_line(exc)})")))
            except Exception:  # noqa: BLE001
                break
    os._exit(0)


class _Worker:
    def __init__(self, ctx) -> None:
        parent, child = ctx.Pipe(duplex=True)
        self.conn = parent
        self.process = ctx.Process(target=_worker_main, args=(child, os.getpid()), daemon=True,
                                   name="camsim-worker")
        self.process.start()
        child.close()
        self.task: int | None = None

    def kill(self) -> None:
        if self.process.pid is not None and self.process.exitcode is None:
            try:
                os.kill(self.process.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        self.process.join(CLOSE_WAIT_S)
        self.conn.close()

    def why(self) -> str:
        code = self.process.exitcode
        if code is not None and code < 0:
            try:
                return f"a worker process was killed by {signal.Signals(-code).name}"
            except ValueError:
                pass
        return "a worker process died" + (f" (exit code {code})" if code is not None else "")


class WorkerPool:
    """``workers`` forked processes running module-level task functions (see the module doc).

    Parameters
    ----------
    workers : int
        Number of worker processes (started at the first :meth:`run`).
    """

    name = "process pool"

    def __init__(self, workers: int) -> None:
        import multiprocessing

        self.workers = workers
        self._ctx = multiprocessing.get_context("fork")
        self._pool: list[_Worker] = []
        self._broken: str | None = None

    @property
    def pids(self) -> list[int]:
        """The process ids of the live workers."""
        return [w.process.pid for w in self._pool if w.process.pid is not None]

    def _fill(self) -> None:
        while len(self._pool) < self.workers:
            self._pool.append(_Worker(self._ctx))

    def run(self, tasks: Sequence[tuple], fn: Callable[..., Any], failed=None) -> Iterator[tuple[int, Any]]:
        """Run ``fn(*args)`` for every ``args`` of ``tasks``; yield ``(index, value)`` as they finish.

        A task that raises, or whose worker dies, yields its failed row
        (``failed(args, exc)`` marked :data:`EXECUTOR_ERROR`). A generator left before its end
        (an exception in the caller) kills the workers of its unfinished tasks.
        """
        from multiprocessing.connection import wait

        pending = deque(range(len(tasks)))
        if self._broken is None and pending:
            self._fill()
        busy: dict[Any, _Worker] = {}
        try:
            while pending or busy:
                if self._broken is not None:
                    for w in dict.fromkeys(busy.values()):
                        pending.appendleft(w.task)
                    busy.clear()
                    self.abort()  # the answers of the others would come too late to be used
                    while pending:
                        k = pending.popleft()
                        yield k, failed_value(tasks[k], WorkerDied(self._broken), failed)
                    return
                for w in self._pool:
                    if w.task is None and pending:
                        k = pending.popleft()
                        try:
                            w.conn.send((fn, tasks[k]))
                        except (OSError, EOFError):
                            pending.appendleft(k)
                            self._break(w)
                            break
                        except Exception as exc:  # noqa: BLE001 - a task that does not pickle: its failed row
                            yield k, failed_value(tasks[k], exc, failed)
                            continue
                        w.task = k
                        busy[w.conn] = w
                        busy[w.process.sentinel] = w
                if self._broken is not None:
                    continue
                ready = wait(list(busy))
                for handle in ready:
                    w = busy.get(handle)
                    if w is None or w.task is None:
                        continue
                    k = w.task
                    try:
                        if not w.conn.poll():
                            raise EOFError
                        ok, value = w.conn.recv()
                    except (EOFError, OSError):
                        w.process.join(0.5)
                        self._break(w)
                        break
                    w.task = None
                    busy.pop(w.conn, None)
                    busy.pop(w.process.sentinel, None)
                    yield k, value if ok else failed_value(tasks[k], value, failed)
        finally:
            for w in list(self._pool):
                if w.task is not None:  # left mid-way: its answer would reach the next run
                    w.task = None
                    w.kill()
                    self._pool.remove(w)

    def _break(self, worker: _Worker) -> None:
        self._broken = worker.why()

    def abort(self) -> None:
        """Kill every worker now (Ctrl-C, SIGTERM): nothing a worker holds is kept."""
        for w in self._pool:
            if w.process.pid is not None and w.process.exitcode is None:
                try:
                    os.kill(w.process.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
        for w in self._pool:
            w.kill()
        self._pool.clear()

    def close(self) -> None:
        """Ask the workers to leave, and kill those that do not within :data:`CLOSE_WAIT_S`."""
        for w in self._pool:
            try:
                w.conn.send(None)
            except (OSError, ValueError):
                pass
        for w in self._pool:
            w.process.join(CLOSE_WAIT_S)
            w.kill()
        self._pool.clear()

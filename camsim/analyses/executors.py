"""Where many independent runs execute: serially, in a local process pool, or on Dask.

Sweeps, studies and fits hand an executor a list of argument tuples and a module-level
task function (for instance :func:`camsim.analyses.sweep.runner.run_variant`); it yields
``(index, result)`` as tasks finish. Process-pool and LocalCluster workers ignore Ctrl-C (the parent's) and
die with their parent, even on SIGKILL (:mod:`camsim.run.lifecycle`). A task lost with its
worker comes back as a failed row marked :data:`EXECUTOR_ERROR`, so a resumed job reruns it.
"""

from __future__ import annotations

import os

from camsim.analyses.pool import EXECUTOR_ERROR, WorkerPool, failed_value, one_line
from camsim.errors import InputError

__all__ = ["EXECUTOR_ERROR", "one_line", "default_workers", "Serial", "ProcessPool", "DaskCluster", "make_executor"]

#: Seconds to wait for a Dask scheduler before giving up.
SCHEDULER_TIMEOUT_S = 5.0


def default_workers() -> int:
    """Worker processes by default: every core."""
    return os.cpu_count() or 1


class Serial:
    name = "serial"

    def run(self, tasks, fn, failed=None):
        for i, args in enumerate(tasks):
            yield i, fn(*args)

    def abort(self):
        pass

    def close(self):
        pass

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        _leave(self, exc_type)


class ProcessPool(WorkerPool):
    """Local worker processes that ignore Ctrl-C, die with this process and can always be
    stopped (:mod:`camsim.analyses.pool`)."""

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        _leave(self, exc_type)


def _leave(executor, exc_type) -> None:
    """The end of an executor's ``with`` block: abort on an exception (Ctrl-C), close otherwise."""
    if exc_type is not None:
        try:
            executor.abort()
        except Exception:  # noqa: BLE001 - on the way out
            pass
    executor.close()


def future_value(fut, args, failed=None):
    """The result of a finished Dask future; an executor failure becomes a failed row.

    ``failed(args, exc)`` gives that row (the task's parameters and the error); the caller
    knows its tasks' arguments, the executor does not.
    """
    try:
        return fut.result()
    except Exception as exc:  # noqa: BLE001 - e.g. a worker process killed
        return failed_value(args, exc, failed)


def _import_distributed():
    try:
        import distributed
    except ImportError:
        raise InputError(
            "--scheduler/--dask-local need Dask: pip install 'camsim[dask]' (dask.distributed is not installed)"
        ) from None
    return distributed


def _probe_scheduler(address: str, timeout: float) -> None:
    """Ask ``address`` for its identity within ``timeout`` [s]; InputError unless a scheduler answers.

    Done before a :class:`distributed.Client` is made, because a Client that fails to
    connect can block for a further 10 s while it is garbage-collected.
    """
    import asyncio

    from distributed.core import rpc

    async def identity():
        r = rpc(address, timeout=timeout)
        try:
            return await r.identity()
        finally:
            await r.close_rpc()

    import socket

    where = f"--scheduler {address}"
    host, _, port = address.removeprefix("tcp://").rpartition(":")
    if address.startswith("tcp://") and host and port.isdigit():
        # A refused or unroutable address fails here at once (Dask itself retries until timeout).
        try:
            socket.create_connection((host.strip("[]"), int(port)), timeout=timeout).close()
        except TimeoutError:
            raise InputError(f"{where}: no answer within {timeout:g} s") from None
        except OSError as exc:
            raise InputError(f"{where}: cannot connect ({exc.strerror or exc})") from None
    try:
        info = asyncio.run(asyncio.wait_for(identity(), timeout))
    except (asyncio.TimeoutError, TimeoutError):
        raise InputError(f"{where}: no Dask scheduler answered within {timeout:g} s") from None
    except OSError as exc:
        raise InputError(f"{where}: cannot reach a Dask scheduler ({one_line(exc)})") from None
    except Exception as exc:  # noqa: BLE001 - bad address, a server that does not speak Dask
        raise InputError(f"{where}: no Dask scheduler there ({one_line(exc)})") from None
    if not isinstance(info, dict) or info.get("type") != "Scheduler":
        kind = info.get("type") if isinstance(info, dict) else type(info).__name__
        raise InputError(f"{where}: the server there is not a Dask scheduler (it says it is a {kind})")


class DaskCluster:
    """Variants as Dask futures on an existing scheduler or a LocalCluster on loopback."""

    def __init__(self, scheduler: str | None, local_workers: int | None):
        distributed = _import_distributed()
        self.cluster = None
        self.futures: list = []
        self.pids: list[int] = []
        if scheduler is not None:
            self.name = f"Dask scheduler {scheduler}"
            _probe_scheduler(scheduler, SCHEDULER_TIMEOUT_S)
            try:
                self.client = distributed.Client(scheduler, timeout=SCHEDULER_TIMEOUT_S, set_as_default=False)
            except Exception as exc:  # noqa: BLE001 - OSError, TimeoutError
                raise InputError(f"--scheduler {scheduler}: cannot connect a Dask client ({one_line(exc)})") from None
        else:
            import logging

            self.name = f"Dask LocalCluster ({local_workers} workers)"
            self.cluster = distributed.LocalCluster(
                n_workers=local_workers,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
            self.client = distributed.Client(self.cluster, set_as_default=False)
            # issue 16: the worker processes die with this process (their nannies live in it)
            from camsim.run.lifecycle import guard_worker

            self.client.run(guard_worker, None, False)
            # issue 45: their process ids, so that Ctrl-C and SIGTERM stop them at once
            self.pids = [int(p) for p in self.client.run(os.getpid).values()]

    def run(self, tasks, fn, failed=None):
        import uuid

        distributed = _import_distributed()
        tag = uuid.uuid4().hex[:12]
        self.futures = [
            self.client.submit(fn, *args, key=f"camsim-variant-{tag}-{i}", pure=False)
            for i, args in enumerate(tasks)
        ]
        index = {f.key: i for i, f in enumerate(self.futures)}
        for fut in distributed.as_completed(self.futures, loop=self.client.loop):
            i = index[fut.key]
            yield i, future_value(fut, tasks[i], failed)

    def abort(self):
        """Stop now: the local cluster's workers are killed (their nannies are closed with the
        cluster); on an external scheduler the tasks are cancelled."""
        import logging
        import signal

        logging.getLogger("distributed").setLevel(logging.CRITICAL)  # its complaints about the stopped tasks
        try:
            self.client.cancel(self.futures, force=True)
        except Exception:  # noqa: BLE001 - best effort on the way out
            pass
        for pid in self.pids:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass

    def close(self):
        try:
            self.client.close(timeout=2)
        except Exception:  # noqa: BLE001 - a client of killed workers: the cluster is closed next
            pass
        finally:
            if self.cluster is not None:
                self.cluster.close(timeout=3)

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        _leave(self, exc_type)


def make_executor(workers: int, n_tasks: int, scheduler: str | None, dask_local: int | None):
    if scheduler is not None or dask_local is not None:
        return DaskCluster(scheduler, dask_local)
    workers = max(1, min(workers, n_tasks))
    return Serial() if workers == 1 else ProcessPool(workers)

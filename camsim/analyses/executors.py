"""Where many independent runs execute: serially, in a local process pool, or on Dask.

Sweeps, studies and fits hand an executor a list of argument tuples and a module-level
task function (for instance :func:`camsim.analyses.sweep.runner.run_variant`); it yields
``(index, result)`` as tasks finish. Process-pool and LocalCluster workers ignore Ctrl-C (the parent's) and
die with their parent, even on SIGKILL (:mod:`camsim.run.lifecycle`). A task lost with its
worker comes back as a failed row marked :data:`EXECUTOR_ERROR`, so a resumed job reruns it.
"""

from __future__ import annotations

import os

from camsim.errors import InputError

#: Seconds to wait for a Dask scheduler before giving up.
SCHEDULER_TIMEOUT_S = 5.0


def one_line(exc: BaseException) -> str:
    """An exception as one line: ``"SimulationError: message"``."""
    text = str(exc).strip().splitlines()
    message = text[0] if text else ""
    return f"{type(exc).__name__}: {message}" if message else type(exc).__name__


def default_workers() -> int:
    """Worker processes by default: every core."""
    return os.cpu_count() or 1


def _failed(args, exc: BaseException) -> dict:
    """The row of a task whose worker failed, when the caller gives no ``failed`` of its own."""
    return {"status": one_line(exc)}


class Serial:
    name = "serial"

    def run(self, tasks, fn, failed=None):
        for i, args in enumerate(tasks):
            yield i, fn(*args)

    def abort(self):
        pass

    def close(self):
        pass


class ProcessPool:
    """A ProcessPoolExecutor whose workers ignore SIGINT (Ctrl-C is the parent's)."""

    name = "process pool"

    def __init__(self, workers: int):
        from concurrent.futures import ProcessPoolExecutor

        self.workers = workers
        from camsim.run.lifecycle import guard_worker

        # issue 16: workers ignore Ctrl-C and die with this process (even on SIGKILL)
        self.executor = ProcessPoolExecutor(max_workers=workers, initializer=guard_worker, initargs=(os.getpid(),))
        self.futures: list = []

    def run(self, tasks, fn, failed=None):
        from concurrent.futures import as_completed

        self.futures = [self.executor.submit(fn, *args) for args in tasks]
        index = {f: i for i, f in enumerate(self.futures)}
        for fut in as_completed(self.futures):
            yield index[fut], future_value(fut, tasks[index[fut]], failed)

    def abort(self):
        for fut in self.futures:
            fut.cancel()
        self.executor.shutdown(wait=False, cancel_futures=True)
        # Stop the variants in flight now rather than wait for them.
        for proc in list((getattr(self.executor, "_processes", None) or {}).values()):
            if proc.is_alive():
                proc.terminate()

    def close(self):
        self.executor.shutdown(wait=True)


#: Key marking a row that an executor failure (a killed worker) produced, not the variant.
EXECUTOR_ERROR = "_executor_error"


def future_value(fut, args, failed=None):
    """The result of a finished future; an executor failure becomes a failed row.

    ``failed(args, exc)`` gives that row (the task's parameters and the error); the caller
    knows its tasks' arguments, the executor does not.
    """
    try:
        return fut.result()
    except Exception as exc:  # noqa: BLE001 - e.g. a worker process killed
        # Marked so that it is not stored as the task's result (--resume reruns it).
        return {**(failed or _failed)(args, exc), EXECUTOR_ERROR: True}, None


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
        try:
            self.client.cancel(self.futures)
        except Exception:  # noqa: BLE001 - best effort on the way out
            pass

    def close(self):
        try:
            self.client.close()
        finally:
            if self.cluster is not None:
                self.cluster.close()


def make_executor(workers: int, n_tasks: int, scheduler: str | None, dask_local: int | None):
    if scheduler is not None or dask_local is not None:
        return DaskCluster(scheduler, dask_local)
    workers = max(1, min(workers, n_tasks))
    return Serial() if workers == 1 else ProcessPool(workers)

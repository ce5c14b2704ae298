"""The heartbeat of a long computation: one call the engine's inner loops make (issue 45).

The engine cannot import the run layer that watches it (layers import downward only), so the
run hands its progress channel down through this module: :func:`listening` installs a
listener for the duration of a run (a context variable: per thread, inherited by nothing
else), and the engine's loops that do not return to the integrator's loop for a long time
(the power-law contact's windows and DOP853 fallbacks, DOP853 spans, the camshaft's waveform
relaxation) call :func:`beat` with the simulated time they reached. Without a listener a beat
costs one context-variable lookup.

The channel itself -- progress lines every 10 s, the stall watchdog -- is
:class:`camsim.run.watchdog.RunClock`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

__all__ = ["beat", "working", "listening", "listener"]

_LISTENER: ContextVar[Callable[[float | None], None] | None] = ContextVar("camsim_heartbeat", default=None)


def beat(t: float) -> None:
    """Report that the computation reached simulated time ``t`` [s] (no-op without a listener)."""
    listener = _LISTENER.get()
    if listener is not None:
        listener(t)


def working() -> None:
    """Report progress that is not in simulated time: a step of the work after the
    integration (each located extreme refined while the result is assembled), so that the
    stall watchdog sees a long assembly advance (no-op without a listener)."""
    listener = _LISTENER.get()
    if listener is not None:
        listener(None)


def listener() -> Callable[[float | None], None] | None:
    """The listener installed now (None outside a watched run)."""
    return _LISTENER.get()


@contextmanager
def listening(fn: Callable[[float], None]) -> Iterator[None]:
    """Within the block, :func:`beat` calls ``fn(t)``."""
    token = _LISTENER.set(fn)
    try:
        yield
    finally:
        _LISTENER.reset(token)

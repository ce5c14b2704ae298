"""A run's progress channel and its stall watchdog (issue 45, docs/results.md "Progress").

Every route of the engine reports the simulated time it reached through one channel: the
integrator's loop after each stretch, and the inner loops that can run for a long time
without returning to it (the power-law contact's windows and its DOP853 fallbacks, DOP853
spans, the camshaft's waveform relaxation) through :func:`camsim.heartbeat.beat`. The
channel, :class:`RunClock`, does two things with it:

* it forwards the run's fraction done to the command's progress display (a live bar on a
  terminal, a line every 10 s elsewhere: ``camsim.cli.progress``), at most every
  :data:`REPORT_INTERVAL_S`, so a run is never silent off a terminal, whichever route it takes;
* it is the **stall watchdog**: a run whose simulated time has not advanced by one output
  sample interval (1/sample rate) within :func:`stall_seconds` of wall time (default
  :data:`DEFAULT_STALL_S`, the environment variable ``CAMSIM_STALL_SECONDS``) stops with
  :class:`StallError` (a :class:`camsim.errors.SimulationError`: one line, exit 1) naming the
  cause: at that pace one revolution would take days. Before, ``camsim run
  machines/cdtm-power.toml --set element.seat.gap="62500.0 in"`` printed nothing for 600 s.

A pass of the camshaft's waveform relaxation starts again from the beginning of the run:
simulated time going back is a new pass, not a stall.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from camsim import heartbeat
from camsim.errors import SimulationError

__all__ = ["DEFAULT_STALL_S", "REPORT_INTERVAL_S", "STALL_ENV", "StallError", "RunClock", "stall_seconds", "watching"]

#: Wall time without one output sample of simulated progress before a run is stopped [s].
DEFAULT_STALL_S = 60.0
#: The environment variable that sets it (tests use a few seconds).
STALL_ENV = "CAMSIM_STALL_SECONDS"
#: Least wall time between two reports to the progress display [s].
REPORT_INTERVAL_S = 0.1


class StallError(SimulationError):
    """A run that made no progress in simulated time for the stated wall time."""


def stall_seconds() -> float:
    """The stall watchdog's wall time [s]: ``CAMSIM_STALL_SECONDS`` or :data:`DEFAULT_STALL_S`."""
    text = os.environ.get(STALL_ENV, "").strip()
    try:
        value = float(text) if text else DEFAULT_STALL_S
    except ValueError:
        value = DEFAULT_STALL_S
    return value if value > 0 else math.inf


class RunClock:
    """The channel a run's engine reports the simulated time it reached to (see the module doc).

    Parameters
    ----------
    report : callable or None
        ``report(t)``: the run's own progress callback (fraction done from ``t``), or None.
    quantum : float
        The least advance that counts as progress: one output sample interval [s].
    source : str
        The machine file, for the message.
    stall_after : float, optional
        Wall time without progress before :class:`StallError` [s]; default :func:`stall_seconds`.
    clock : callable
        Wall-clock source (tests).
    """

    def __init__(self, report: Callable[[float], None] | None, quantum: float, source: str = "",
                 stall_after: float | None = None, clock: Callable[[], float] = time.monotonic) -> None:
        self.report = report
        self.quantum = quantum
        self.source = source
        self.stall_after = stall_seconds() if stall_after is None else stall_after
        self.clock = clock
        now = clock()
        self.mark = -math.inf  # simulated time of the last progress
        self.progress_at = now  # wall time of the last progress
        self.reported_at = -math.inf
        self.t = 0.0
        self.passes = 0
        self._now = now

    #: What the run is doing when it does not integrate (set by the run: "locating the extremes").
    phase = ""

    def __call__(self, t: float) -> None:
        """A stretch of the integrator's loop ended at simulated time ``t`` [s]: reported always."""
        self.beat(t)
        if self.report is not None and self.reported_at != self._now:
            self.reported_at = self._now
            self.report(t)

    def beat(self, t: float | None) -> None:
        """An inner loop of the engine reached simulated time ``t`` [s] (:func:`camsim.heartbeat.beat`):
        reported at most every :data:`REPORT_INTERVAL_S`. ``t = None``
        (:func:`camsim.heartbeat.working`): progress outside simulated time, a step of the
        assembly after the integration, which resets the watchdog and nothing else."""
        now = self._now = self.clock()
        if t is None:
            self.progress_at = now
            return
        self.t = t
        if t >= self.mark + self.quantum or t < self.mark - self.quantum:
            if t < self.mark:
                self.passes += 1  # the relaxation starts a new pass from the run's beginning
            self.mark, self.progress_at = t, now
        else:
            self._check(now)
        if self.report is not None and now - self.reported_at >= REPORT_INTERVAL_S:
            self.reported_at = now
            self.report(t)

    def tick(self) -> None:
        """A second of wall time passed (the timer of :func:`watching`): the watchdog for the
        routes that do not beat, and the progress display kept alive."""
        now = self.clock()
        self._check(now)
        if self.report is not None and now - self.reported_at >= REPORT_INTERVAL_S:
            self.reported_at = now
            self.report(self.t)

    def _check(self, now: float) -> None:
        if now - self.progress_at <= self.stall_after:
            return
        if self.phase:
            what = f"while {self.phase}: no progress for {self.stall_after:g} s of wall time"
        else:
            what = (f"at t = {self.t:.9g} s: no progress in simulated time for {self.stall_after:g} s of wall time "
                    f"(less than one output sample, {self.quantum:.3g} s)")
        self.progress_at = math.inf  # raised once
        raise StallError(
            f"{self.source}: the run stalled {what}; {STALL_ENV} sets the limit; an element is probably too stiff or "
            "a contact chatters: lower its stiffness or coefficient, or make the contact rigid (law = \"restitution\")"
        )


@contextmanager
def watching(clock: RunClock) -> Iterator[RunClock]:
    """Within the block, the engine's beats go to ``clock`` -- unless a run is watched already
    (a camshaft relaxation's passes report to the run that started them), then to that one."""
    outer = getattr(heartbeat.listener(), "__self__", None)
    if isinstance(outer, RunClock):
        yield outer
        return
    with heartbeat.listening(clock.beat), _timer(clock):
        yield clock


#: Seconds between two ticks of the watchdog's timer.
TICK_S = 1.0


@contextmanager
def _timer(clock: RunClock) -> Iterator[None]:
    """A tick of ``clock`` every :data:`TICK_S` (SIGALRM), for the routes that never beat (a
    scipy solver deep in the extremes' location): only in the main thread, and only when
    nobody else uses SIGALRM. Interval timers are not inherited by forked workers."""
    import signal
    import threading

    if (threading.current_thread() is not threading.main_thread() or not hasattr(signal, "setitimer")
            or signal.getsignal(signal.SIGALRM) not in (signal.SIG_DFL, None)):
        yield
        return

    def on_alarm(signum, frame):  # noqa: ARG001
        clock.tick()

    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, TICK_S, TICK_S)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0, 0.0)
        signal.signal(signal.SIGALRM, previous)

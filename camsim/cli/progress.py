"""Progress of long commands on stderr: one mechanism for run, compare, sweep, study,
optimize and fit; nothing with ``--quiet``.

On a terminal a live bar (what is counted, a bar, done/total, the rate and the time left,
removed when done). Elsewhere (a pipe, a log file, a batch job, CI) a plain line every
:data:`LINE_INTERVAL` seconds with the same figures, e.g.
``run: 1.2/3 rev (40 %), 0.11 rev/s, about 16 s left`` — so a long run is never silent
until it ends; a run that ends before the first interval prints none. stdout is never
touched, so ``--json`` output stays pure.
"""

from __future__ import annotations

import time
from typing import Any

from camsim.cli.app import err_console

__all__ = ["Bar", "FractionBar", "Lines", "LINE_INTERVAL"]

#: Seconds between two progress lines when stderr is not a terminal.
LINE_INTERVAL = 10.0


def _duration(seconds: float) -> str:
    """``42 s``, ``3 min 20 s``, ``2 h 05 min``."""
    s = int(round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {(s % 3600) // 60:02d} min"


class _Clock:
    """When the next plain line is due (:data:`LINE_INTERVAL` apart, the first one after it)."""

    def __init__(self) -> None:
        self.start = time.monotonic()
        self.next = self.start + LINE_INTERVAL

    def due(self) -> float | None:
        """Seconds since the start when a line is due now, else None."""
        now = time.monotonic()
        if now < self.next:
            return None
        self.next = now + LINE_INTERVAL
        return now - self.start


class Bar:
    """Progress counting ``unit`` (e.g. ``"rev"``, ``"variants"``): a live bar on a terminal,
    a line every :data:`LINE_INTERVAL` seconds elsewhere, nothing with ``quiet``.

    Call :meth:`start` with the total, then the object as ``bar(done, total)`` (the
    signature the library's ``progress`` callbacks use; ``note`` adds a short text such as
    the best value so far), then :meth:`close`.

    Parameters
    ----------
    label : str
        Text before the figures, e.g. ``"run"``.
    unit : str
        What is counted, shown in the rate (``12.3 rev/s``).
    quiet : bool
        Show nothing (``--quiet``).
    """

    def __init__(self, label: str, unit: str, quiet: bool = False) -> None:
        self.label = label
        self.unit = unit
        self.enabled = not quiet and err_console.is_terminal  # the live bar
        self.lines = not quiet and not err_console.is_terminal  # plain lines
        self.progress: Any = None
        self.task: Any = None
        self.clock: _Clock | None = None
        self.total = 0.0
        self.detail = ""
        self.note = ""
        self.done = 0.0
        self._ticker: Any = None
        import threading

        self._lock = threading.RLock()  # re-entered by the run watchdog's tick (a signal handler)

    def start(self, total: float, detail: str = "", note: str = "") -> None:
        """Begin counting to ``total`` units (``detail`` is appended to the label)."""
        self.total, self.detail, self.note = total, detail, note
        if self.lines and self.clock is None:
            self.clock = _Clock()
            self._start_ticker()
        if not self.enabled or self.progress is not None:
            return
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, ProgressColumn, TextColumn, TimeRemainingColumn
        from rich.text import Text

        unit = self.unit

        class RateColumn(ProgressColumn):
            def render(self, task):  # noqa: D102 - rich's interface
                speed = task.finished_speed or task.speed
                return Text("" if speed is None else f"{speed:.3g} {unit}/s")

        self.progress = Progress(
            TextColumn(self.label + (f" ({detail})" if detail else "")),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn(unit),
            RateColumn(),
            TextColumn("{task.fields[note]}"),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            console=err_console,
            transient=True,
        )
        self.progress.start()
        self.task = self.progress.add_task(self.label, total=total, note=note)

    def __call__(self, done: float, total: float | None = None, note: str | None = None) -> None:
        if note is not None:
            self.note = note
        if total is not None:
            self.total = total
        self.done = done
        if self.progress is not None:
            self.progress.update(self.task, completed=done, total=self.total, note=self.note)
        elif self.clock is not None:
            self._line_if_due()

    def _line_if_due(self) -> None:
        with self._lock:
            clock = self.clock
            elapsed = clock.due() if clock is not None else None
            if elapsed is not None:
                err_console.print(self.line(self.done, elapsed), markup=False, highlight=False)

    def _start_ticker(self) -> None:
        """Off a terminal, a line every :data:`LINE_INTERVAL` even while nothing finishes (issue 45:
        a sweep's slow variant in a worker process, a study's first runs): from a daemon thread."""
        import threading

        if LINE_INTERVAL <= 0:  # a line at every call already
            return
        stop = threading.Event()
        period = min(1.0, LINE_INTERVAL / 2)

        def tick() -> None:
            while not stop.wait(period):
                self._line_if_due()

        thread = threading.Thread(target=tick, name="camsim-progress-lines", daemon=True)
        self._ticker = (stop, thread)
        thread.start()

    def line(self, done: float, elapsed: float) -> str:
        """The plain progress line after ``elapsed`` seconds with ``done`` units done."""
        head = self.label + (f" ({self.detail})" if self.detail else "")
        total = self.total
        text = f"{head}: {done:.4g}/{total:.4g} {self.unit}"
        if total > 0:
            text += f" ({100.0 * done / total:.0f} %)"
        if done > 0 and elapsed > 0:
            rate = done / elapsed
            text += f", {rate:.3g} {self.unit}/s"
            if total > done:
                text += f", about {_duration((total - done) / rate)} left"
        else:
            text += f", {_duration(elapsed)} so far"
        return text + (f", {self.note}" if self.note else "")

    def close(self) -> None:
        """Remove the bar (plain lines stop)."""
        if self._ticker is not None:
            stop, thread = self._ticker
            stop.set()
            thread.join(2.0)
            self._ticker = None
        if self.progress is not None:
            self.progress.stop()
            self.progress = None
        with self._lock:
            self.clock = None

    def __enter__(self) -> Bar:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class FractionBar(Bar):
    """A bar fed with the fraction done (the ``progress(fraction)`` of ``simulate``).

    Parameters
    ----------
    total : float
        What the whole job counts, e.g. the revolutions of a run (warm-up included).
    """

    def __init__(self, label: str, unit: str, total: float, quiet: bool = False) -> None:
        super().__init__(label, unit, quiet=quiet)
        self.total = total

    def __call__(self, fraction: float, total: float | None = None, note: str | None = None) -> None:
        if self.progress is None and self.clock is None:
            self.start(self.total)
        super().__call__(round(fraction * self.total, 3), self.total, note)


class Lines:
    """Progress told as lines of text (the fit's iterations): every line on a terminal, the
    latest one every :data:`LINE_INTERVAL` seconds elsewhere, none with ``quiet``."""

    def __init__(self, quiet: bool = False) -> None:
        self.quiet = quiet
        self.clock = None if quiet or err_console.is_terminal else _Clock()

    def __call__(self, line: str) -> None:
        if self.quiet or (self.clock is not None and self.clock.due() is None):
            return
        err_console.print(line, markup=False, highlight=False)

"""Progress bars of long commands: on stderr, only on a terminal, never with ``--quiet``.

One bar shape for every command (run: revolutions; compare: runs; sweep: variants):
what is counted, a bar, done/total, the rate and the time left. The bar is drawn on
:data:`camsim.cli.app.err_console` (stderr) and removed when done; stdout is never
touched, so ``--json`` output stays pure. When stderr is not a terminal (a pipe, a log
file, a batch job) nothing is drawn.
"""

from __future__ import annotations

from typing import Any

from camsim.cli.app import err_console

__all__ = ["Bar", "FractionBar"]


class Bar:
    """A rich progress bar counting ``unit`` (e.g. ``"rev"``, ``"variants"``).

    Call :meth:`start` with the total, then the object as ``bar(done, total)`` (the
    signature the library's ``progress`` callbacks use), then :meth:`close`. Every
    method is a no-op when the bar is off.

    Parameters
    ----------
    label : str
        Text before the bar, e.g. ``"run"``.
    unit : str
        What is counted, shown in the rate (``12.3 rev/s``).
    quiet : bool
        Never draw (``--quiet``).
    """

    def __init__(self, label: str, unit: str, quiet: bool = False) -> None:
        self.label = label
        self.unit = unit
        self.enabled = not quiet and err_console.is_terminal
        self.progress: Any = None
        self.task: Any = None

    def start(self, total: float, detail: str = "") -> None:
        """Show the bar for ``total`` units (``detail`` is appended to the label)."""
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
            TextColumn("ETA"),
            TimeRemainingColumn(),
            console=err_console,
            transient=True,
        )
        self.progress.start()
        self.task = self.progress.add_task(self.label, total=total)

    def __call__(self, done: float, total: float | None = None) -> None:
        if self.progress is not None:
            self.progress.update(self.task, completed=done, total=total)

    def close(self) -> None:
        """Remove the bar."""
        if self.progress is not None:
            self.progress.stop()
            self.progress = None

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

    def __call__(self, fraction: float, total: float | None = None) -> None:
        if self.progress is None:
            self.start(self.total)
        super().__call__(round(fraction * self.total, 3), self.total)

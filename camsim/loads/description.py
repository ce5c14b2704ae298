"""A process load's description in SI: what a ``[[load]]`` table of the machine file says.

Plain frozen dataclasses that the machine loader builds (:mod:`camsim.machine.loadreader`) and
the load programs (:mod:`camsim.loads.programs`) evaluate; a
:class:`~camsim.machine.description.Machine` holds a tuple of :class:`Load`.

A load is an external force on one mass, positive along +x (spec §10), given by exactly one
program: a constant, a segment program over the cam angle (the cam's segment table with
``change`` [N] in place of ``lift``), a table over the cam angle or over time, or a sine in
time.
"""

from __future__ import annotations

from dataclasses import dataclass

from camsim.cam.description import Segment

__all__ = ["KINDS", "Load", "LoadTable", "Sine"]

#: The programs a load may have, by the key that gives it.
KINDS = ("force", "segments", "table", "sine")


@dataclass(frozen=True)
class LoadTable:
    """A load's CSV table: the force at given cam angles or times, linear between rows.

    Attributes
    ----------
    over : str
        ``"angle"`` (periodic, covering 0–360°) or ``"time"`` (the first value before the
        first row, the last value after the last row).
    x : tuple of float
        The abscissae, non-decreasing [rad or s]; one written twice is a step.
    force : tuple of float
        The force at each row [N].
    source : str
        The CSV path as written in the machine file.
    """

    over: str
    x: tuple[float, ...]
    force: tuple[float, ...]
    source: str = ""


@dataclass(frozen=True)
class Sine:
    """A harmonic force in time: F = offset + amplitude·sin(2π·f·(t − start) + phase) for
    t ≥ start, zero before.

    Attributes
    ----------
    amplitude : float
        [N].
    frequency : float
        f [Hz], > 0.
    phase : float
        [rad].
    offset : float
        [N].
    start : float
        Where the force starts, on the result's time base [s].
    """

    amplitude: float
    frequency: float
    phase: float = 0.0
    offset: float = 0.0
    start: float = 0.0


@dataclass(frozen=True)
class Load:
    """An external force on one mass, positive along +x (``[[load]]``, spec §10).

    Attributes
    ----------
    name : str
        Unique among elements and loads; names ``/loads/<name>/force``.
    on : str
        The mass it acts on (a driven mass too: it then enters the cam contact force).
    kind : str
        Its program: one of :data:`KINDS`.
    force : float or None
        A constant force [N] (``kind = "force"``).
    segments : tuple of Segment
        A segment program over the cam angle (``kind = "segments"``): each row's ``lift`` is
        the force's change over it [N] (positive; a fall decreases the force).
    base : float
        The segment program's force at its 0° [N].
    table : LoadTable or None
        ``kind = "table"``.
    sine : Sine or None
        ``kind = "sine"``.
    cam : str or None
        The cam whose angle drives an angle program (None: the shaft's angle).
    """

    name: str
    on: str
    kind: str
    force: float | None = None
    segments: tuple[Segment, ...] = ()
    base: float = 0.0
    table: LoadTable | None = None
    sine: Sine | None = None
    cam: str | None = None

    @property
    def peak(self) -> float:
        """A bound on |F| [N]: the constant, |base| + Σ changes, the table's largest |F|, or
        |offset| + |amplitude| (a segment program written from conditions may overshoot its
        changes: their sum, taken twice)."""
        if self.kind == "force":
            return abs(float(self.force))
        if self.kind == "segments":
            return abs(self.base) + 2.0 * sum(abs(s.lift) for s in self.segments)
        if self.kind == "table":
            return max(abs(f) for f in self.table.force)
        return abs(self.sine.offset) + abs(self.sine.amplitude)

    @property
    def over_angle(self) -> bool:
        """Whether its program runs over a cam angle (segments, an angle table)."""
        return self.kind == "segments" or (self.kind == "table" and self.table is not None and self.table.over == "angle")

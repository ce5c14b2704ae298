"""The machine description in SI: plain dataclasses that the rest of camsim uses.

:func:`camsim.loader.load_machine` builds these from a TOML machine file; everything
below the loader (cam program, model, integrator) sees only these floats in SI units:
m, kg, s, N, rad. Node names are ``"ground"``, ``"cam"`` or a mass name.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # issue 14: [cam.geometry]
    from camsim.cam.compensated import CompensatedProfile  # issue 27
    from camsim.cam.geometry import CamGeometry

# Elements are the element kinds' own classes (camsim/elements/); re-exported here because
# a Machine is made of them.
from camsim.elements import (  # noqa: E402,F401 - re-exported
    CAM,
    FIXED_NODES,
    GROUND,
    Contact,
    Damping,
    Element,
    LinearContact,
    PowerContact,
    PreloadedLink,
    RigidContact,
    Spring,
)

MOTIONS = ("rise", "fall", "dwell")
LAWS = ("cycloidal", "harmonic", "modified-trapezoid", "modified-sine", "poly345", "poly4567")
#: Laws written from conditions (issue 27, spec §2 "Motion synthesis").
SYNTHESIS_LAWS = ("polynomial", "constant-velocity", "spline")
#: Derivative keys of a ``start``/``end``/point table and their order (v = 1st …).
DERIVATIVE_KEYS = {"v": 1, "a": 2, "j": 3, "d4": 4, "d5": 5, "d6": 6}

#: Standard gravity [m/s^2] (CGPM 1901), used for ``gravity = true``.
STANDARD_GRAVITY = 9.80665


@dataclass(frozen=True)
class Segment:
    """One row of the cam segment table.

    Attributes
    ----------
    motion : str
        ``"rise"``, ``"fall"`` or ``"dwell"``.
    law : str or None
        Motion law (one of :data:`LAWS`); None for a dwell.
    duration : float
        Cam angle the segment lasts, β [rad].
    lift : float
        Lift at the roller, h [m] (angular lifts already turned into arc length by the
        follower ``arm``); 0 for a dwell. Always positive: a fall descends by ``lift``.
    """

    motion: str
    law: str | None
    duration: float
    lift: float
    # issue 27: motion synthesis (polynomial, constant-velocity, spline); SI, roller side.
    continuity: int | None = None
    start: tuple[tuple[int, float], ...] = ()
    end: tuple[tuple[int, float], ...] = ()
    points: tuple["SegmentPoint", ...] = ()
    velocity: float | None = None
    degree: int | None = None


@dataclass(frozen=True)
class SegmentPoint:
    """An interior condition of a ``polynomial`` or ``spline`` segment (issue 27).

    Attributes
    ----------
    at : float
        Cam angle from the segment's start [rad], strictly inside the segment.
    s : float or None
        Roller lift there [m], measured like the program (from the base circle).
    derivatives : tuple of (int, float)
        (order, value) pairs: v [m/s], a [m/s^2] at the roller at ``cam.speed``.
    """

    at: float
    s: float | None = None
    derivatives: tuple[tuple[int, float], ...] = ()


@dataclass(frozen=True)
class Compensation:
    """``[cam.compensation]`` (issue 27): the written program is wanted at ``output``.

    Attributes
    ----------
    output : str
        The output mass whose motion the written program prescribes.
    speed : float
        Design speed ω [rad/s] of the compensation.
    """

    output: str
    speed: float


@dataclass(frozen=True)
class CamTable:
    """A measured or exported cam profile (the thesis imported DYNACAM tables).

    Attributes
    ----------
    angle : tuple of float
        Cam angles [rad], strictly increasing, spanning less than one revolution.
    displacement : tuple of float
        Roller lift at each angle [m].
    velocity, acceleration : tuple of float or None
        Optional roller velocity [m/s] and acceleration [m/s^2] at the cam's speed, used
        only to check the spline.
    source : str
        The CSV path as written in the machine file.
    """

    angle: tuple[float, ...]
    displacement: tuple[float, ...]
    velocity: tuple[float, ...] | None = None
    acceleration: tuple[float, ...] | None = None
    source: str = ""


@dataclass(frozen=True)
class Cam:
    """The cam: constant speed, a segment table or a table profile, the linkage.

    Attributes
    ----------
    speed : float
        Camshaft speed ω [rad/s], > 0.
    segments : tuple of Segment
        The segment table (empty when ``table`` is given).
    table : CamTable or None
        A table profile replacing the segments.
    ratio : float
        Roller motion → model axis (dimensionless), default 1.
    arm : float or None
        Follower arm [m] that turned angular lifts into arc length at the roller.
    drives : str or None
        Name of the mass whose motion the cam prescribes exactly.
    start_angle : float
        θ0 [rad], cam angle at t = 0.
    geometry : CamGeometry or None
        The cam's shape and follower arrangement (``[cam.geometry]``), None if not given.
    """

    speed: float
    segments: tuple[Segment, ...] = ()
    table: CamTable | None = None
    ratio: float = 1.0
    arm: float | None = None
    drives: str | None = None
    start_angle: float = 0.0
    geometry: CamGeometry | None = None  # issue 14: [cam.geometry]
    # issue 27: [cam.compensation]; ``compensated`` is the computed cam profile and
    # ``output_program`` the written (wanted output) program, both set by the loader.
    compensation: Compensation | None = None
    compensated: CompensatedProfile | None = None
    output_program: "Cam | None" = None

    @property
    def period(self) -> float:
        """One revolution, T = 2π/ω [s]."""
        import math

        return 2.0 * math.pi / self.speed


@dataclass(frozen=True)
class Mass:
    """A lumped mass on the model axis: ``mass`` [kg] > 0."""

    name: str
    mass: float


@dataclass(frozen=True)
class InitialCondition:
    """Initial displacement [m] and/or velocity [m/s] of one free mass."""

    mass: str
    displacement: float | None = None
    velocity: float | None = None


@dataclass(frozen=True)
class Simulation:
    """Run settings.

    Attributes
    ----------
    cycles : int
        Recorded revolutions (≥ 1).
    warmup_cycles : int
        Revolutions computed and discarded first (≥ 0).
    sample_rate : float
        Output samples per second [Hz].
    gravity : float
        Acceleration of gravity along −x [m/s^2]; 0 for none.
    duration : float or None
        Recorded time [s] instead of ``cycles`` (required when there is no cam).
    """

    cycles: int = 1
    warmup_cycles: int = 1
    sample_rate: float = 50_000.0
    gravity: float = 0.0
    duration: float | None = None


@dataclass(frozen=True)
class Machine:
    """A whole machine in SI, as loaded from a machine file.

    Attributes
    ----------
    name : str
        ``[machine] name``.
    cam : Cam or None
        None when the machine has no cam: the ``cam`` node stays at x = 0.
    masses : tuple of Mass
    elements : tuple of Element
    simulation : Simulation
    initial : tuple of InitialCondition
    source : str
        The file the machine came from (for messages), ``"<string>"`` otherwise.
    text : str
        The TOML text as read (stored in result files).
    """

    name: str
    cam: Cam | None
    masses: tuple[Mass, ...]
    elements: tuple[Element, ...]
    simulation: Simulation = field(default_factory=Simulation)
    initial: tuple[InitialCondition, ...] = ()
    source: str = "<string>"
    text: str = ""
    base_dir: str = "."

    def with_values(self, values: dict) -> "Machine":
        """A modified copy: ``{KEY: VALUE}`` in the ``--set`` grammar, checked like the file.

        >>> stiffer = machine.with_values({"element.K12.stiffness": "1.7e6 N/m"})  # doctest: +SKIP

        Keys and values as on the command line (``cam.speed``, ``mass.M2.mass``,
        ``element.seat.stiffness``, ``cam.segments[2].lift``, ``simulation.cycles``...);
        a string value carries its units. Raises :class:`~camsim.errors.MachineFileError`
        naming the key for an unknown key or a bad value.
        """
        from pathlib import Path

        from camsim.loader import assignments, load_machine_text

        return load_machine_text(self.text, source=self.source, base_dir=Path(self.base_dir), overrides=assignments(values))

    def mass_of(self, name: str) -> float:
        """Mass [kg] of the mass called ``name``."""
        for m in self.masses:
            if m.name == name:
                return m.mass
        raise KeyError(name)

    @property
    def free_masses(self) -> tuple[Mass, ...]:
        """Masses that are degrees of freedom (all but the one the cam drives)."""
        driven = self.cam.drives if self.cam is not None else None
        return tuple(m for m in self.masses if m.name != driven)

    def element(self, name: str) -> Element:
        for e in self.elements:
            if e.name == name:
                return e
        raise KeyError(name)

__all__ = [
    "CAM", "FIXED_NODES", "GROUND", "Contact", "Damping", "Element", "LinearContact", "PowerContact",
    "PreloadedLink", "RigidContact", "Spring", "Cam", "CamTable", "InitialCondition", "Machine", "Mass",
    "Segment", "SegmentPoint", "Compensation", "Simulation", "LAWS", "SYNTHESIS_LAWS", "DERIVATIVE_KEYS",
    "MOTIONS", "STANDARD_GRAVITY",
]

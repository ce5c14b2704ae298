"""The machine description in SI: plain dataclasses that the rest of camsim uses.

:func:`camsim.machine.loader.load_machine` builds these from a TOML machine file; everything
below the loader (cam program, model, integrator) sees only these floats in SI units:
m, kg, s, N, rad. Node names are ``"ground"``, ``"cam"`` or a mass name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

from camsim.errors import InputError

if TYPE_CHECKING:
    from camsim.display import DisplayUnits

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

# The cam's own description lives with the cam (camsim/cam/description.py); re-exported here
# because a Machine is made of it.
from camsim.cam.description import (  # noqa: E402,F401 - re-exported
    DERIVATIVE_KEYS,
    LAWS,
    MOTIONS,
    SYNTHESIS_LAWS,
    Cam,
    Camshaft,
    CamshaftSection,
    CamTable,
    Compensation,
    Segment,
    SegmentPoint,
)

# issue 43: process loads ([[load]]) live with their programs (camsim/loads/)
from camsim.loads.description import Load, LoadTable, Sine  # noqa: E402,F401 - re-exported

#: Standard gravity [m/s^2] (CGPM 1901), used for ``gravity = true``.
STANDARD_GRAVITY = 9.80665


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
    steady_state : str
        How the recorded window's start is reached: ``"warmup"`` (``warmup_cycles``
        revolutions from the initial state) or ``"shooting"`` (Newton's iteration on the
        revolution's map, :mod:`camsim.run.steady`; the warm-up where it does not apply).
    """

    cycles: int = 1
    warmup_cycles: int = 1
    sample_rate: float = 50_000.0
    gravity: float = 0.0
    duration: float | None = None
    steady_state: str = "warmup"


@dataclass(frozen=True)
class ClearancePart:
    """One side of a clearance: a mass or cam node and the offset of its edge [m]."""

    node: str
    offset: float = 0.0


@dataclass(frozen=True)
class Clearance:
    """``[[clearance]]`` (spec §9): the distance between two stations' parts.

    The distance is (x_B + offset_B) − (x_A + offset_A) for ``between = [A, B]``; a value below
    ``minimum`` (default 0: the parts touch) is a collision.
    """

    name: str
    a: ClearancePart
    b: ClearancePart
    minimum: float = 0.0


@dataclass(frozen=True)
class Machine:
    """A whole machine in SI, as loaded from a machine file.

    Attributes
    ----------
    name : str
        ``[machine] name``.
    cam : Cam or None
        None when the machine has no cam: the ``cam`` node stays at x = 0. With several
        cams (``[[cam]]`` tables) the first of them (the shaft's speed and start angle are
        every cam's).
    cams : tuple of Cam
        Every cam, in the order of the cam input (a ``[cam]`` file: ``(cam,)``).
    camshaft : Camshaft or None
        ``[camshaft]`` (spec §9); None when the file has none (a rigid shaft at the cam's speed).
    clearances : tuple of Clearance
        ``[[clearance]]`` pairs.
    multi_cam : bool
        The file holds ``[[cam]]`` tables (results under ``/cams/<name>/``).
    masses : tuple of Mass
    elements : tuple of Element
    simulation : Simulation
    initial : tuple of InitialCondition
    loads : tuple of Load
        ``[[load]]`` tables (spec §10), in file order: the order of the engine's load inputs.
    source : str
        The file the machine came from (for messages), ``"<string>"`` otherwise.
    text : str
        The TOML text as read (stored in result files).
    notes : tuple of str
        How the file was read, when it needs saying: each bare number taken as SI in a file
        that otherwise writes units, and each bare number given with ``--set`` (one line each,
        its value in the file's units). Commands print them as warnings.
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
    cams: tuple[Cam, ...] = ()
    camshaft: Camshaft | None = None
    clearances: tuple[Clearance, ...] = ()
    multi_cam: bool = False
    loads: tuple[Load, ...] = ()  # issue 43
    #: Warnings about how the file was read, one line each: a bare number taken as SI where the
    #: file otherwise writes units (:func:`camsim.machine.keys.bare_number_note`, issue 44).
    notes: tuple[str, ...] = field(default=(), compare=False)

    #: Rebuilds a machine from this one's text with ``--set`` assignments; set by the loader
    #: that made it (the description sits below the loader, so it is handed the way back).
    rebuild: Callable[["Machine", dict], "Machine"] | None = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        # One [cam]: cams is (cam,) whatever was given (dataclasses.replace(cam=...) keeps
        # them in step); [[cam]]: cam is the first of them.
        if not self.multi_cam:
            object.__setattr__(self, "cams", (self.cam,) if self.cam is not None else ())
        elif self.cams:
            object.__setattr__(self, "cam", self.cams[0])

    def cam_named(self, name: str) -> Cam:
        """The cam whose node is ``name``."""
        for cam in self.cams:
            if cam.name == name:
                return cam
        raise KeyError(name)

    @property
    def cam_names(self) -> tuple[str, ...]:
        """The cam nodes (``("cam",)`` for a [cam] file; empty without a cam)."""
        return tuple(c.name for c in self.cams)

    @property
    def driven_masses(self) -> dict[str, str]:
        """Driven mass → the cam that drives it."""
        return {c.drives: c.name for c in self.cams if c.drives}

    def with_values(self, values: dict) -> "Machine":
        """A modified copy: ``{KEY: VALUE}`` in the ``--set`` grammar, checked like the file.

        >>> stiffer = machine.with_values({"element.K12.stiffness": "1.7e6 N/m"})  # doctest: +SKIP

        Keys and values as on the command line (``cam.speed``, ``mass.M2.mass``,
        ``element.seat.stiffness``, ``cam.segments[2].lift``, ``simulation.cycles``...);
        a string value carries its units. Raises :class:`~camsim.errors.MachineFileError`
        naming the key for an unknown key or a bad value, and
        :class:`~camsim.errors.InputError` for a machine built in code rather than loaded.
        """
        if self.rebuild is None:
            raise InputError(f"{self.source}: with_values needs a machine loaded from a machine file (camsim.load_machine)")
        return self.rebuild(self, values)

    @cached_property
    def display_units(self) -> DisplayUnits:
        """The units this machine's file was written in, per dimension (issue 36).

        What human output shows by default (``--units file``): counted from :attr:`text` by
        :func:`camsim.display.written_units` (docs/units.md); SI for a machine without text.
        """
        from camsim.display import written_units

        return written_units(self.text)

    def mass_of(self, name: str) -> float:
        """Mass [kg] of the node called ``name``: the mass as written plus what the elements lump
        there (a rod's end adds m/(2N): the node's mass in the model, issue 39)."""
        for m in self.masses:
            if m.name == name:
                return m.mass + sum(e.node_mass(name) for e in self.elements)
        raise KeyError(name)

    @property
    def node_names(self) -> tuple[str, ...]:
        """Every mass node of the model, as the results name them: the masses, then each
        rod's interior nodes ``<rod>[1]`` … (issue 39)."""
        return (*(m.name for m in self.masses), *(n for e in self.elements for n in e.interior_nodes()))

    @property
    def free_masses(self) -> tuple[Mass, ...]:
        """Masses that are degrees of freedom (all but those a cam drives)."""
        driven = self.driven_masses
        return tuple(m for m in self.masses if m.name not in driven)

    def load(self, name: str) -> Load:
        """The ``[[load]]`` called ``name``."""
        for load in self.loads:
            if load.name == name:
                return load
        raise KeyError(name)

    def element(self, name: str) -> Element:
        for e in self.elements:
            if e.name == name:
                return e
        raise KeyError(name)

__all__ = [
    "CAM", "FIXED_NODES", "GROUND", "Contact", "Damping", "Element", "LinearContact", "PowerContact",
    "PreloadedLink", "RigidContact", "Spring", "Cam", "Camshaft", "CamshaftSection", "Clearance", "ClearancePart",
    "CamTable", "InitialCondition", "Load", "LoadTable", "Machine", "Mass", "Sine",
    "Segment", "SegmentPoint", "Compensation", "Simulation", "LAWS", "SYNTHESIS_LAWS", "DERIVATIVE_KEYS",
    "MOTIONS", "STANDARD_GRAVITY",
]

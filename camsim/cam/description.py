"""The cam's description in SI: the segment table or a table profile, the linkage, the speed.

Plain frozen dataclasses that the machine loader builds (:mod:`camsim.machine.loader`) and the
cam program (:mod:`camsim.cam.program`) evaluates; :class:`camsim.machine.description.Machine`
holds one :class:`Cam`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # issue 14: [cam.geometry]
    from camsim.cam.arrangement import CamGeometry

MOTIONS = ("rise", "fall", "dwell")
LAWS = ("cycloidal", "harmonic", "modified-trapezoid", "modified-sine", "poly345", "poly4567")
#: Laws written from conditions (issue 27, spec §2 "Motion synthesis").
SYNTHESIS_LAWS = ("polynomial", "constant-velocity", "spline")
#: Derivative keys of a ``start``/``end``/point table and their order (v = 1st …).
DERIVATIVE_KEYS = {"v": 1, "a": 2, "j": 3, "d4": 4, "d5": 5, "d6": 6}


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
    points: tuple[SegmentPoint, ...] = ()
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
        θ0 [rad], the shaft's angle at t = 0.
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
    # a camsim.cam.compensated.CompensatedProfile: that module builds on this one (it holds
    # the written Cam), so the type is not imported here (no import circle)
    compensated: object | None = None
    output_program: Cam | None = None
    # issue 38: several cams on one camshaft ([[cam]] tables). ``name`` is the cam's node
    # (``cam`` for a [cam] table); ``phase`` is added to the shaft's angle: the cam's angle
    # is θ_shaft + phase.
    name: str = "cam"
    phase: float = 0.0

    @property
    def period(self) -> float:
        """One revolution, T = 2π/ω [s]."""
        import math

        return 2.0 * math.pi / self.speed


#: The camshaft's models (``[camshaft] model``) and drives (``drive``).
CAMSHAFT_MODELS = ("rigid", "dynamic")
CAMSHAFT_DRIVES = ("speed", "motor")


@dataclass(frozen=True)
class CamshaftSection:
    """A torsional section between the drive and one cam (``[[camshaft.section]]``).

    Attributes
    ----------
    cam : str
        The cam at the section's end.
    stiffness : float
        Torsional stiffness k_t [N·m/rad], > 0.
    inertia : float
        The cam's own inertia J [kg·m²], > 0.
    damping_ratio : float
        ζ of the section's own mode (c_t = 2ζ·√(k_t·J)) [-].
    """

    cam: str
    stiffness: float
    inertia: float
    damping_ratio: float = 0.0


@dataclass(frozen=True)
class Camshaft:
    """The camshaft (``[camshaft]``, spec §9): its speed, and optionally its own dynamics.

    Attributes
    ----------
    speed : float
        Nominal (mean) shaft speed ω̄ [rad/s].
    start_angle : float
        Shaft angle at t = 0 [rad].
    model : str
        ``"rigid"`` (constant speed, the default) or ``"dynamic"`` (the shaft angle a state).
    speed_fluctuation : float or None
        Coefficient of speed fluctuation C_s for the flywheel sizing [-].
    inertia : float
        J0, the drive side's inertia (motor rotor, gears) [kg·m²].
    flywheel : float
        A flywheel on the drive side [kg·m²] (added to J0).
    drive : str
        ``"speed"`` (a constant-speed drive through a compliance) or ``"motor"`` (a linear
        torque–speed line).
    drive_stiffness, drive_damping : float
        The speed drive's compliance: k_d [N·m/rad], c_d [N·m·s/rad].
    stall_torque, no_load_speed : float
        The motor's line T = T_stall·(1 − ω/ω_0) [N·m, rad/s].
    sections : tuple of CamshaftSection
        Torsional sections to cams; a cam without one sits rigidly on the drive.
    """

    speed: float
    start_angle: float = 0.0
    model: str = "rigid"
    speed_fluctuation: float | None = None
    inertia: float = 0.0
    flywheel: float = 0.0
    drive: str = "speed"
    drive_stiffness: float | None = None
    drive_damping: float = 0.0
    stall_torque: float | None = None
    no_load_speed: float | None = None
    sections: tuple[CamshaftSection, ...] = ()

    @property
    def drive_inertia(self) -> float:
        """J0 + flywheel [kg·m²]."""
        return self.inertia + self.flywheel

    def section(self, cam: str) -> CamshaftSection | None:
        """The torsional section of ``cam``, None when it sits rigidly on the drive."""
        return next((s for s in self.sections if s.cam == cam), None)

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
    from camsim.cam.compensated import CompensatedProfile  # issue 27

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
    output_program: Cam | None = None

    @property
    def period(self) -> float:
        """One revolution, T = 2π/ω [s]."""
        import math

        return 2.0 * math.pi / self.speed

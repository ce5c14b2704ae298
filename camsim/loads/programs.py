"""Load programs: a load's force F(t) and its exact time derivatives, as the engine reads an input.

The engine integrates a machine driven by input channels in groups of four — a value and its
first three time derivatives (:mod:`camsim.elements.affine`). A cam gives [s, ṡ, s̈, s⃛]; a
load gives [F, Ḟ, F̈, F⃛]. Every program here answers what a cam program answers:

* ``channels(t, side)`` — (N, 4) at times t [s] (simulation clock), the limit from the right
  or the left (``side``) where a derivative jumps;
* ``channels_at(t, side)`` — (4,) at one instant, in floats where that is fast;
* ``break_times(t0, t1)`` — the instants in (t0, t1) where F or a derivative is not smooth:
  a segment program's joins and its laws' inner kinks, a table's rows, a sine's start. The
  engine stops a stretch at each (a node pair with the limits from both sides), so between
  them the input is smooth and its step polynomial exact;
* ``shortest`` — the longest engine step [s] over which that step polynomial (degree 7, from
  the channels at both ends) carries the program exactly: 1/64 of its shortest rise or fall,
  or of a sine's period (as the cam's, :func:`camsim.run.simulation.cam_input_step`); ∞ for a
  constant or a table (linear between rows).

The programs:

* :class:`ConstantLoad` — F constant;
* :class:`AngleLoad` — a program over a cam angle θ(t): a segment program (a
  :class:`~camsim.cam.program.CamProgram` whose "lift" is the force, plus ``base``) or an
  angle table (:class:`AngleTable`, periodic, linear between rows), with
  Ḟ = F′·θ̇, F̈ = F″·θ̇² + F′·θ̈, F⃛ = F‴·θ̇³ + 3F″·θ̇·θ̈ + F′·θ⃛ (a rigid shaft: θ̇ = ω, the rest 0);
* :class:`TimeTable` — a table over time, linear between rows, the first value before the
  first row and the last after the last;
* :class:`SineLoad` — offset + amplitude·sin(2πf·(t − start) + phase) from ``start``, 0 before.

Times of the time programs are on the result's time base (0 at the start of the first
recorded revolution): the program is told the simulation time ``t_offset`` of that instant.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from camsim.cam.description import Cam
from camsim.cam.program import CamProgram
from camsim.loads.description import Load

__all__ = ["AngleLoad", "AngleTable", "ConstantLoad", "SineLoad", "TimeTable", "load_program", "load_programs"]

_TWO_PI = 2.0 * math.pi
_EPS = float(np.finfo(float).eps)
#: Steps of the engine's grid per shortest motion of a load program (as the cam's,
#: camsim.run.simulation.WARMUP_STEPS_PER_MOTION): the step polynomial of the input stays exact.
STEPS_PER_MOTION = 64


def _window(times: np.ndarray, t0: float, t1: float, scale: float) -> np.ndarray:
    """The times strictly inside (t0, t1), more than 1e-12·scale from both ends, unique."""
    tol = 1e-12 * scale
    return np.unique(times[(times > t0 + tol) & (times < t1 - tol)])


# ---------------------------------------------------------------------- piecewise-linear rows
class _Rows:
    """Rows (x_i, F_i), x non-decreasing (a value twice is a step), linear between them;
    constant beyond the ends. ``scale``: the size of x for the rounding tolerance."""

    def __init__(self, x, force, scale: float):
        self.x = np.asarray(x, dtype=float)
        self.f = np.asarray(force, dtype=float)
        self.scale = scale
        dx = np.diff(self.x)
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = np.where(dx > 0.0, np.diff(self.f) / np.where(dx > 0.0, dx, 1.0), 0.0)
        # slope of the piece starting at row i (i = −1: before the first row, n − 1: after the last)
        self.slope = np.concatenate([[0.0], slope, [0.0]])
        self._x_list = self.x.tolist()

    def _index(self, x: np.ndarray, side: str) -> np.ndarray:
        """Index i of the piece [x_i, x_{i+1}] each x falls in (−1 before the first row, n − 1
        after the last); at a row, the piece that starts there (right) or ends there (left)."""
        tol = 64.0 * _EPS * np.maximum(np.abs(x), self.scale)
        if side == "left":
            return np.searchsorted(self.x, x - tol, side="left") - 1
        return np.searchsorted(self.x, x + tol, side="right") - 1

    def values(self, x: np.ndarray, side: str) -> tuple[np.ndarray, np.ndarray]:
        """F and dF/dx at x."""
        i = self._index(x, side)
        n = self.x.size
        inside = (i >= 0) & (i < n - 1)
        k = np.clip(i, 0, n - 1)
        slope = self.slope[i + 1]
        f = np.where(i < 0, self.f[0], np.where(i >= n - 1, self.f[-1], self.f[k] + slope * (x - self.x[k])))
        # at a row (to rounding) the row's own value, exactly
        f = np.where(inside & (x == self.x[k]), self.f[k], f)
        return f, np.where(inside, slope, 0.0)

    def value_at(self, x: float, side: str) -> tuple[float, float]:
        """:meth:`values` at one abscissa, in floats (the same rule)."""
        tol = 64.0 * _EPS * max(abs(x), self.scale)
        xs = self._x_list
        i = (bisect.bisect_left(xs, x - tol) if side == "left" else bisect.bisect_right(xs, x + tol)) - 1
        n = len(xs)
        if i < 0:
            return float(self.f[0]), 0.0
        if i >= n - 1:
            return float(self.f[-1]), 0.0
        slope = float(self.slope[i + 1])
        return (float(self.f[i]) if x == xs[i] else float(self.f[i]) + slope * (x - xs[i])), slope


# ---------------------------------------------------------------------- time programs
class ConstantLoad:
    """F = ``force`` [N] at every instant."""

    def __init__(self, force: float):
        self.force = float(force)
        self.shortest = math.inf

    def channels(self, t, side: str = "right") -> np.ndarray:
        t = np.asarray(t, dtype=float).reshape(-1)
        out = np.zeros((t.size, 4))
        out[:, 0] = self.force
        return out

    def channels_at(self, t: float, side: str = "right") -> np.ndarray:
        return np.array([self.force, 0.0, 0.0, 0.0])

    def break_times(self, t_start: float, t_end: float) -> np.ndarray:
        return np.zeros(0)


class SineLoad:
    """F = offset + A·sin(2πf·τ + φ) for τ = t − t_offset − start ≥ 0, 0 before.

    Parameters
    ----------
    sine : camsim.loads.description.Sine
    t_offset : float
        The simulation time of the result's time 0 [s].
    """

    def __init__(self, sine, t_offset: float = 0.0):
        self.sine = sine
        self.omega = _TWO_PI * float(sine.frequency)
        self.t_start = float(t_offset) + float(sine.start)
        self.shortest = 1.0 / float(sine.frequency) / STEPS_PER_MOTION

    def _on(self, t: np.ndarray, side: str) -> np.ndarray:
        tol = 64.0 * _EPS * np.maximum(np.abs(t), 1.0)
        return t > self.t_start + tol if side == "left" else t >= self.t_start - tol

    def channels(self, t, side: str = "right") -> np.ndarray:
        t = np.asarray(t, dtype=float).reshape(-1)
        s = self.sine
        w = self.omega
        arg = w * (t - self.t_start) + s.phase
        sin, cos = np.sin(arg), np.cos(arg)
        a = s.amplitude
        out = np.stack([s.offset + a * sin, a * w * cos, -a * w * w * sin, -a * w**3 * cos], axis=-1)
        out[~self._on(t, side)] = 0.0
        return out

    def channels_at(self, t: float, side: str = "right") -> np.ndarray:
        """:meth:`channels` at one instant, in floats."""
        t = float(t)
        tol = 64.0 * _EPS * max(abs(t), 1.0)
        if (t <= self.t_start + tol) if side == "left" else (t < self.t_start - tol):
            return np.zeros(4)
        s, w = self.sine, self.omega
        arg = w * (t - self.t_start) + s.phase
        sin, cos = math.sin(arg), math.cos(arg)
        a = s.amplitude
        return np.array([s.offset + a * sin, a * w * cos, -a * w * w * sin, -a * w**3 * cos])

    def break_times(self, t_start: float, t_end: float) -> np.ndarray:
        return _window(np.array([self.t_start]), t_start, t_end, max(abs(self.t_start), 1.0))


class TimeTable:
    """A table of the force over time, linear between rows; the first value before the first
    row, the last after the last.

    Parameters
    ----------
    table : camsim.loads.description.LoadTable
        ``over = "time"``; times on the result's time base [s].
    t_offset : float
        The simulation time of the result's time 0 [s].
    """

    def __init__(self, table, t_offset: float = 0.0):
        self.t_offset = float(t_offset)
        self.rows = _Rows(np.asarray(table.x, dtype=float) + self.t_offset, table.force, 1.0)
        self.shortest = math.inf  # linear between rows: the step polynomial is exact

    def channels(self, t, side: str = "right") -> np.ndarray:
        t = np.asarray(t, dtype=float).reshape(-1)
        f, slope = self.rows.values(t, side)
        out = np.zeros((t.size, 4))
        out[:, 0], out[:, 1] = f, slope
        return out

    def channels_at(self, t: float, side: str = "right") -> np.ndarray:
        """:meth:`channels` at one instant, in floats."""
        f, slope = self.rows.value_at(float(t), side)
        return np.array([f, slope, 0.0, 0.0])

    def break_times(self, t_start: float, t_end: float) -> np.ndarray:
        return _window(self.rows.x, t_start, t_end, max(abs(t_start), abs(t_end), 1.0))


# ---------------------------------------------------------------------- angle programs
class AngleTable:
    """A periodic table of the force over the cam angle, covering 0–2π, linear between rows:
    the profile F(θ) and its θ-derivatives (as :meth:`CamProgram.lift` gives a cam's lift).

    A row at 2π whose force differs from the row at 0 is a step at 0 (as an angle written
    twice)."""

    def __init__(self, table):
        self.rows = _Rows(table.x, table.force, _TWO_PI)

    def _wrap(self, theta: np.ndarray, side: str) -> np.ndarray:
        phi = np.mod(theta, _TWO_PI)
        tol = 64.0 * _EPS * np.maximum(np.abs(theta), _TWO_PI)
        if side == "left":
            return np.where(phi < tol, phi + _TWO_PI, phi)
        return np.where(phi > _TWO_PI - tol, phi - _TWO_PI, phi)

    def lift(self, theta, side: str = "right"):
        """F [N] and dF/dθ [N/rad], d²F/dθ² = d³F/dθ³ = 0, shaped like ``theta``."""
        theta = np.asarray(theta, dtype=float)
        f, slope = self.rows.values(self._wrap(theta.reshape(-1), side), side)
        z = np.zeros(theta.shape)
        return f.reshape(theta.shape), slope.reshape(theta.shape), z, z.copy()

    def lift_at(self, theta: float, side: str = "right"):
        """:meth:`lift` at one angle, in floats (the same rule)."""
        theta = float(theta)
        phi = theta % _TWO_PI
        tol = 64.0 * _EPS * max(abs(theta), _TWO_PI)
        if side == "left" and phi < tol:
            phi += _TWO_PI
        elif side != "left" and phi > _TWO_PI - tol:
            phi -= _TWO_PI
        f, slope = self.rows.value_at(phi, side)
        return f, slope, 0.0, 0.0

    def break_angles(self) -> np.ndarray:
        """Angles [rad] in [0, 2π) of the rows (where dF/dθ may jump)."""
        return np.unique(np.mod(self.rows.x, _TWO_PI))


class _SegmentProfile:
    """A segment program over the angle: a :class:`CamProgram` whose lift is the force, plus
    ``base`` (the force at 0°)."""

    def __init__(self, segments, base: float, speed: float):
        self.program = CamProgram(Cam(speed=speed, segments=tuple(segments), ratio=1.0, start_angle=0.0))
        self.base = float(base)
        motions = [s.duration for s in segments if s.motion != "dwell"]
        self.shortest_angle = min(motions) if motions else math.inf

    def lift(self, theta, side: str = "right"):
        f, d1, d2, d3 = self.program.lift(theta, side=side)
        return f + self.base, d1, d2, d3

    def lift_at(self, theta: float, side: str = "right"):
        f, d1, d2, d3 = self.program.lift_at(theta, side)
        return f + self.base, d1, d2, d3

    def break_angles(self) -> np.ndarray:
        return np.unique(np.concatenate([self.program.boundary_angles(), getattr(self.program, "_breaks", np.zeros(0))]))


class AngleLoad:
    """A force over a cam angle θ(t), as a time signal with exact derivatives.

    Parameters
    ----------
    profile : AngleTable or _SegmentProfile
        F(θ) and its θ-derivatives (``lift``, ``lift_at``, ``break_angles``).
    start_angle : float
        θ at t = 0 [rad] (a rigid shaft: θ = θ0 + ω·t).
    speed : float
        ω [rad/s].
    warp : (callable, callable) or None
        A dynamic camshaft's angle: ``theta(t, order)`` → (order + 1, N) θ and its time
        derivatives, and ``times_at(angles)`` (as :class:`camsim.cam.camshaft.WarpedProgram`).
    """

    def __init__(self, profile, start_angle: float, speed: float, warp=None):
        self.profile = profile
        self.start_angle = float(start_angle)
        self.speed = float(speed)
        self.period = _TWO_PI / self.speed
        self.warp = warp
        self.shortest = getattr(profile, "shortest_angle", math.inf) / self.speed / STEPS_PER_MOTION
        self._breaks = profile.break_angles()

    def channels(self, t, side: str = "right") -> np.ndarray:
        t = np.asarray(t, dtype=float).reshape(-1)
        if self.warp is None:
            d = self.profile.lift(self.start_angle + self.speed * t, side)
            w = self.speed
            return np.stack([d[0], d[1] * w, d[2] * (w * w), d[3] * w**3], axis=-1)
        th = self.warp[0](t, 3)
        d = self.profile.lift(th[0], side)
        w, al, je = th[1], th[2], th[3]
        return np.stack([d[0], d[1] * w, d[2] * w * w + d[1] * al,
                         d[3] * w**3 + 3.0 * d[2] * w * al + d[1] * je], axis=-1)

    def channels_at(self, t: float, side: str = "right") -> np.ndarray:
        if self.warp is not None:
            return self.channels(np.array([float(t)]), side)[0]
        f, d1, d2, d3 = self.profile.lift_at(self.start_angle + self.speed * float(t), side)
        w = self.speed
        return np.array([f, d1 * w, d2 * (w * w), d3 * w**3])

    def break_times(self, t_start: float, t_end: float) -> np.ndarray:
        if not self._breaks.size or not t_end > t_start:
            return np.zeros(0)
        if self.warp is None:
            lo, hi = self.start_angle + self.speed * t_start, self.start_angle + self.speed * t_end
        else:
            lo, hi = self.warp[0](np.array([t_start, t_end]), 0)[0]
        k = np.arange(math.floor(lo / _TWO_PI) - 1, math.ceil(hi / _TWO_PI) + 2)
        theta = (self._breaks[None, :] + _TWO_PI * k[:, None]).reshape(-1)
        theta = np.sort(theta[(theta > lo) & (theta < hi)])
        if not theta.size:
            return np.zeros(0)
        times = (theta - self.start_angle) / self.speed if self.warp is None else self.warp[1](theta)
        return _window(np.asarray(times, dtype=float), t_start, t_end, self.period)


# ---------------------------------------------------------------------- a machine's loads
def load_program(load: Load, machine, t_offset: float = 0.0, warps=None):
    """The program of one load of ``machine``.

    Parameters
    ----------
    load : Load
    machine : Machine
        Its cams give an angle program its angle: the named cam's (``load.cam``: the shaft's
        angle plus that cam's phase) or the shaft's.
    t_offset : float
        The simulation time of the result's time 0 [s] (the warm-up's length).
    warps : sequence or None
        Per cam, None or a dynamic camshaft's (theta, times_at) (camsim.run.shaft).
    """
    if load.kind == "force":
        return ConstantLoad(load.force)
    if load.kind == "sine":
        return SineLoad(load.sine, t_offset)
    if load.kind == "table" and load.table.over == "time":
        return TimeTable(load.table, t_offset)
    cams = machine.cams
    if not cams:
        raise ValueError(f"load {load.name}: an angle program needs a cam")
    names = [c.name for c in cams]
    q = names.index(load.cam) if load.cam is not None else 0
    speed = float(cams[0].speed)
    phase = float(cams[q].phase) if load.cam is not None else 0.0
    start = float(cams[0].start_angle) + phase
    profile = AngleTable(load.table) if load.kind == "table" else _SegmentProfile(load.segments, load.base, speed)
    warp = None
    if warps is not None and warps[q] is not None:
        theta, times_at = warps[q]
        # the shaft's angle at the first cam's station: its angle less its phase
        shift = float(cams[q].phase) - phase
        warp = (theta, times_at) if shift == 0.0 else (
            lambda t, order, theta=theta, shift=shift: theta(t, order) - np.eye(order + 1, 1)[:, :1] * shift,
            lambda angles, times_at=times_at, shift=shift: times_at(np.asarray(angles) + shift))
    return AngleLoad(profile, start, speed, warp)


def load_programs(machine, t_offset: float = 0.0, warps=None) -> list:
    """Every load's program, in the order of ``machine.loads`` (the engine's input groups)."""
    return [load_program(load, machine, t_offset, warps) for load in getattr(machine, "loads", ())]

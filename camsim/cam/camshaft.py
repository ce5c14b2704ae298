"""Several cams on one shaft as one cam input: what the engine reads, cam by cam.

The engine integrates a machine driven by input channels (:mod:`camsim.elements.affine`:
[s, ṡ, s̈, s⃛] per cam, cam by cam) and asks its input for two things: the channels at
times t (``channels(t, side)``) and the instants where some channel's derivatives may
jump (``boundary_times(t0, t1)``). A one-cam machine's input is its
:class:`~camsim.cam.program.CamProgram`; a machine with ``[[cam]]`` tables has a
:class:`CamshaftInput`, which stacks the programs of its cams — each cam's angle is the
shaft's plus its ``phase`` — and merges their segment joins.

For a camshaft with its own dynamics (spec §9, ``[camshaft] model = "dynamic"``) a cam's
angle is no longer θ0 + phase + ω·t but a smooth function θ(t) of time, given by the
shaft's solution. :class:`WarpedProgram` turns a cam's program into the time signal
s(θ(t)) with its exact time derivatives by the chain rule,

    ṡ = s′·θ̇,   s̈ = s″·θ̇² + s′·θ̈,   s⃛ = s‴·θ̇³ + 3·s″·θ̇·θ̈ + s′·θ⃛,

(′ = d/dθ, exact from the laws), and its joins are the instants θ(t) passes a segment
start. The engine then integrates the stations exactly as before.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from camsim.cam.program import CamProgram

__all__ = ["CamshaftInput", "WarpedProgram", "cam_input"]

_TWO_PI = 2.0 * math.pi


class CamshaftInput:
    """The cam input of several cams on one shaft: their programs side by side.

    Parameters
    ----------
    programs : sequence of CamProgram or WarpedProgram
        One per cam, in the order of the cam input (channels 4q … 4q+3 are cam q's).
    names : sequence of str
        The cams' node names.

    Attributes
    ----------
    speed, period, start_angle : float
        The shaft's mean speed ω̄ [rad/s], one revolution 2π/ω̄ [s], its angle at t = 0
        [rad] (:meth:`angle` is the shaft's angle).
    warnings : list of str
        Every cam's warnings, prefixed with its name.
    """

    def __init__(self, programs, names):
        self.programs = list(programs)
        self.names = list(names)
        first = self.programs[0]
        self.speed = first.speed
        self.period = first.period
        base = getattr(first, "base", first)
        self.start_angle = float(base.cam.start_angle) if base.cam is not None else 0.0
        self.kind = "camshaft"
        self.warnings = [f"cam {name}: {w}" for name, p in zip(self.names, self.programs) for w in p.warnings]

    # ------------------------------------------------------------------ the engine's input
    def channels(self, t, side: str = "right") -> np.ndarray:
        """Every cam's [s, ṡ, s̈, s⃛] at times t, cam by cam: (N, 4·c)."""
        return np.concatenate([p.channels(t, side=side) for p in self.programs], axis=1)

    def channels_at(self, t: float, side: str = "right") -> np.ndarray:
        """:meth:`channels` at one instant t [s]: (4·c,) (equal to it to rounding)."""
        return np.concatenate([p.channels_at(t, side=side) for p in self.programs])

    def boundary_times(self, t_start: float, t_end: float) -> np.ndarray:
        """Times in (t_start, t_end) where any cam passes a segment join, sorted, merged."""
        return self._merged([p.boundary_times(t_start, t_end) for p in self.programs])

    def break_times(self, t_start: float, t_end: float) -> np.ndarray:
        """Times in (t_start, t_end) where any cam's motion is not smooth (its joins and its
        laws' inner kinks, :meth:`CamProgram.break_times`), sorted, merged."""
        return self._merged([p.break_times(t_start, t_end) for p in self.programs])

    def _merged(self, parts) -> np.ndarray:
        times = np.unique(np.concatenate(parts)) if parts else np.zeros(0)
        if times.size < 2:
            return times
        # joins of two cams a rounding apart are one instant (a step of 1e-16 s helps nobody)
        keep = np.concatenate([[True], np.diff(times) > 1e-12 * self.period])
        return times[keep]

    # ------------------------------------------------------------------ reporting
    def angle(self, t) -> np.ndarray:
        """The shaft's angle θ0 + ω̄·t [rad] (a cam's is :meth:`cam_angle`)."""
        return self.start_angle + self.speed * np.asarray(t, dtype=float)

    def cam_angle(self, index: int, t) -> np.ndarray:
        """Cam ``index``'s angle at times t [rad] (the shaft's plus its phase, or its warped angle)."""
        return self.programs[index].angle(t)

    def svaj(self, t, side: str = "right"):
        """The first cam's s, v, a, j (a one-cam reader of the input; the cams are :attr:`programs`)."""
        return self.programs[0].svaj(t, side=side)

    def boundary_angles(self) -> np.ndarray:
        """Shaft angles [rad] in [0, 2π) where some cam's segment starts."""
        out = []
        for p in self.programs:
            base = getattr(p, "base", p)
            phase = float(base.cam.phase) if base.cam is not None else 0.0
            out.append(np.mod(base.boundary_angles() - phase, _TWO_PI))
        return np.unique(np.concatenate(out)) if out else np.zeros(0)


class WarpedProgram:
    """A cam program driven by a cam angle θ(t) that is a smooth function of time.

    Parameters
    ----------
    base : CamProgram
        The cam's program (its laws give the lift and its θ-derivatives exactly).
    theta : callable
        ``theta(t, order)`` → (order + 1, N): θ and its first ``order`` time derivatives
        [rad, rad/s, …] at times t (the cam's own angle, phase included).
    times_at : callable
        ``times_at(angles)`` → the times at which θ(t) reaches the given angles [s]
        (θ increasing).
    """

    def __init__(self, base: CamProgram, theta, times_at):
        self.base = base
        self._theta = theta
        self._times_at = times_at
        self.speed = base.speed
        self.period = base.period
        self.ratio = base.ratio
        self.kind = base.kind
        self.warnings = list(base.warnings)
        self.cam = base.cam

    def angle(self, t) -> np.ndarray:
        """The cam's angle θ(t) [rad]."""
        t = np.asarray(t, dtype=float)
        return self._theta(t.reshape(-1), 0)[0].reshape(t.shape)

    def svaj(self, t, side: str = "right"):
        """s, ṡ, s̈, s⃛ on the model axis at times t, by the chain rule through θ(t)."""
        t = np.asarray(t, dtype=float)
        shape = t.shape
        th = self._theta(t.reshape(-1), 3)
        d = self.base.lift(th[0], side=side)
        w, al, je = th[1], th[2], th[3]
        r = self.ratio
        s = r * d[0]
        v = r * d[1] * w
        a = r * (d[2] * w * w + d[1] * al)
        j = r * (d[3] * w**3 + 3.0 * d[2] * w * al + d[1] * je)
        return tuple(x.reshape(shape) for x in (s, v, a, j))

    def channels(self, t, side: str = "right") -> np.ndarray:
        return np.stack(self.svaj(np.asarray(t, dtype=float).reshape(-1), side=side), axis=-1)

    def channels_at(self, t: float, side: str = "right") -> np.ndarray:
        """:meth:`channels` at one instant t [s]: (4,)."""
        return self.channels(np.array([float(t)]), side=side)[0]

    def boundary_times(self, t_start: float, t_end: float) -> np.ndarray:
        """Times in (t_start, t_end) where θ(t) passes a segment start of the program."""
        return self._times_of(self.base.boundary_angles(), t_start, t_end)

    def break_times(self, t_start: float, t_end: float) -> np.ndarray:
        """:meth:`boundary_times` and the times θ(t) passes a law's inner kink (as
        :meth:`CamProgram.break_times`)."""
        breaks = getattr(self.base, "_breaks", np.zeros(0))
        return self._times_of(np.concatenate([self.base.boundary_angles(), breaks]), t_start, t_end)

    def _times_of(self, starts: np.ndarray, t_start: float, t_end: float) -> np.ndarray:
        """Times in (t_start, t_end) where θ(t) passes one of the cam angles ``starts`` + 2πk."""
        if self.kind != "segments" or not starts.size or not t_end > t_start:
            return np.zeros(0)
        lo, hi = self.angle(np.array([t_start, t_end]))
        k = np.arange(math.floor(lo / _TWO_PI) - 1, math.ceil(hi / _TWO_PI) + 2)
        theta = (starts[None, :] + _TWO_PI * k[:, None]).reshape(-1)
        theta = theta[(theta > lo) & (theta < hi)]
        if not theta.size:
            return np.zeros(0)
        times = self._times_at(np.sort(theta))
        tol = 1e-12 * self.period
        return np.unique(times[(times > t_start + tol) & (times < t_end - tol)])

    def boundary_angles(self) -> np.ndarray:
        return self.base.boundary_angles()


@functools.lru_cache(maxsize=4)
def shared_program(description) -> CamProgram:
    """The :class:`CamProgram` of a cam description (hashable, frozen), built once per process.

    A study's or a sweep's runs mostly share their cam: its program, the join checks made
    when it is built and the cam input the engine caches on the grid
    (:class:`camsim.engine.context.EngineContext`) are then computed once per worker, not
    once per run (issue 42). A program is read-only once built, so sharing it changes no
    number; a description that fails to build raises each time (nothing is cached).
    """
    return CamProgram(description)


def cam_input(machine, warps=None, shared: bool = True):
    """The engine's cam input of a machine: its :class:`CamProgram` (one ``[cam]`` or none) or
    a :class:`CamshaftInput` of its ``[[cam]]`` tables. ``warps``: per cam, None or
    (theta, times_at) of a :class:`WarpedProgram` (a dynamic camshaft).

    One ``[cam]`` gives the program of its description shared by every run of this process
    (:func:`shared_program`) unless ``shared`` is False (a caller that sets attributes on it)."""
    if not machine.multi_cam and warps is None:
        return shared_program(machine.cam) if shared else CamProgram(machine.cam)
    programs = []
    for q, cam in enumerate(machine.cams):
        program = CamProgram(cam)
        if warps is not None and warps[q] is not None:
            program = WarpedProgram(program, *warps[q])
        programs.append(program)
    return CamshaftInput(programs, [c.name for c in machine.cams])

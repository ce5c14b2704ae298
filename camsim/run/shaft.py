"""The camshaft's own dynamics (``[camshaft] model = "dynamic"``, spec §9) by waveform relaxation.

The shaft: the drive side (inertia J0 = ``inertia`` + ``flywheel``, angle θ_d) is driven at
constant speed through a compliance (``drive = "speed"``: T_D = k_d·(θ_ref − θ_d) +
c_d·(ω̄ − ω_d), θ_ref = θ0 + ω̄·t) or by a motor's torque–speed line (``drive = "motor"``:
T_D = T_stall·(1 − ω_d/ω_nl)). A cam with a ``[[camshaft.section]]`` is an inertia J on a
torsional spring k_t (damping c_t = 2ζ·√(k_t·J)) from the drive; a cam without one turns with
the drive. Each cam q takes the torque T_q = F_q·ds_q/dθ_q of its station
(:mod:`camsim.run.camshaft`)::

    J0·ω̇_d = T_D − Σ_rigid T_q − Σ_sections [k_q·(θ_d + φ_q − θ_q) + c_q·(ω_d − ω_q)]
    J_q·ω̇_q = k_q·(θ_d + φ_q − θ_q) + c_q·(ω_d − ω_q) − T_q

**Waveform relaxation.** The stations are integrated by the exact engine for a given history
of every cam's angle θ_q(t) (a time-warped cam program, :class:`camsim.cam.camshaft.WarpedProgram`:
s(θ(t)) with its time derivatives by the chain rule), and the shaft, a linear system, is
integrated exactly for the stations' torques given as functions of time (piecewise linear
between the output samples). Starting from the rigid shaft, the two are iterated over the
whole run — warm-up included — until the drive's speed changes by less than
:data:`SPEED_TOL` of ω̄ between iterations. Each cam's angle is then a quintic spline through
the shaft's solution on the output grid. The choice and its measured accuracy: docs/model.md
(§ "The camshaft's dynamics") and docs/camshaft.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from camsim.errors import SimulationError

__all__ = ["ShaftModel", "ShaftSolution", "converge", "SPEED_TOL", "MAX_ITERATIONS"]

#: The iteration stops when the drive's speed changes by less than this fraction of ω̄ (the
#: level of the relaxation's own discretisation error at 20 kHz, docs/camshaft.md).
SPEED_TOL = 1e-8
#: Iterations before the relaxation is declared not to converge.
MAX_ITERATIONS = 40
#: A relaxation that stops improving below this change of the speed (relative to ω̄) has
#: converged to the floor left by the stations' event location (1e-10 s) and sampling.
STAGNATION_TOL = 1e-7
#: Iterates kept by the Anderson acceleration.
ANDERSON_DEPTH = 5


class ShaftModel:
    """The shaft's linear system in deviations from the nominal rotation θ0 + φ_q + ω̄·t.

    State y = [x_d, v_d, x_1, v_1, …] (angle [rad] and speed [rad/s] deviations of the drive
    side and of each sectioned cam); ẏ = A·y + B·T(t) + b with T the cams' torques.

    Parameters
    ----------
    machine : Machine
        With a ``[camshaft]`` table.
    """

    def __init__(self, machine):
        shaft = machine.camshaft
        self.machine = machine
        self.shaft = shaft
        self.omega = float(shaft.speed)
        self.start = float(shaft.start_angle)
        self.names = [c.name for c in machine.cams]
        self.phases = np.array([float(c.phase) for c in machine.cams])
        self.sectioned = [shaft.section(name) for name in self.names]
        self.order = [q for q, s in enumerate(self.sectioned) if s is not None]  # sectioned cams, in state order
        n = 2 + 2 * len(self.order)
        self.n = n
        A = np.zeros((n, n))
        B = np.zeros((n, len(self.names)))
        b = np.zeros(n)
        J0 = shaft.drive_inertia
        A[0, 1] = 1.0
        if shaft.drive == "speed":
            A[1, 0] -= shaft.drive_stiffness / J0
            A[1, 1] -= shaft.drive_damping / J0
        else:
            b[1] += shaft.stall_torque * (1.0 - self.omega / shaft.no_load_speed) / J0
            A[1, 1] -= shaft.stall_torque / shaft.no_load_speed / J0
        for q, section in enumerate(self.sectioned):
            if section is None:
                B[1, q] = -1.0 / J0
        for k, q in enumerate(self.order):
            s = self.sectioned[q]
            i = 2 + 2 * k
            c = 2.0 * s.damping_ratio * math.sqrt(s.stiffness * s.inertia)
            A[i, i + 1] = 1.0
            # the section's torque on the cam: k·(x_d − x_q) + c·(v_d − v_q); the opposite on the drive
            for row, inertia, sign in ((i + 1, s.inertia, 1.0), (1, J0, -1.0)):
                A[row, 0] += sign * s.stiffness / inertia
                A[row, i] -= sign * s.stiffness / inertia
                A[row, 1] += sign * c / inertia
                A[row, i + 1] -= sign * c / inertia
            B[i + 1, q] = -1.0 / s.inertia
        self.A, self.B, self.b = A, B, b

    def natural_frequencies(self) -> np.ndarray:
        """Undamped natural frequencies of the shaft's torsional modes [rad/s] (the
        imaginary parts of A's eigenvalues, one of each pair; rigid-body modes left out)."""
        lam = np.linalg.eigvals(self.A)
        scale = float(np.max(np.abs(lam))) if lam.size else 0.0
        w = np.abs(lam.imag[lam.imag > 1e-6 * scale])  # (a motor's slow rigid-body pair is no mode)
        return np.sort(w)

    def equilibrium(self, torques: np.ndarray) -> np.ndarray:
        """The state of steady rotation under constant torques ``torques`` (per cam) [N·m]:
        the drive's and each section's static twist; for a motor the drive's speed where its
        torque equals the total load."""
        shaft = self.shaft
        y = np.zeros(self.n)
        total = float(np.sum(torques))
        if shaft.drive == "speed":
            y[0] = -total / shaft.drive_stiffness
        else:
            y[1] = shaft.no_load_speed * (1.0 - total / shaft.stall_torque) - self.omega
        for k, q in enumerate(self.order):
            s = self.sectioned[q]
            y[2 + 2 * k] = y[0] - torques[q] / s.stiffness
            y[2 + 2 * k + 1] = y[1]
        return y

    def integrate(self, t: np.ndarray, torques: np.ndarray, y0: np.ndarray) -> np.ndarray:
        """The exact solution on the uniform grid ``t`` [s] for torques piecewise linear
        between the grid points (``torques`` (N, cams) [N·m]): (N, n) states."""
        n, m = self.n, torques.shape[1]
        h = float(t[1] - t[0])
        # [y; T_k; (T_{k+1} − T_k)/h; 1]: one matrix exponential gives the step map
        size = n + 2 * m + 1
        M = np.zeros((size, size))
        M[:n, :n] = self.A
        M[:n, n : n + m] = self.B
        M[n : n + m, n + m : n + 2 * m] = np.eye(m)
        M[:n, -1] = self.b
        E = scipy.linalg.expm(M * h)
        Phi, G0, G1, g = E[:n, :n], E[:n, n : n + m], E[:n, n + m : n + 2 * m], E[:n, -1]
        slopes = np.diff(torques, axis=0) / h
        forcing = torques[:-1] @ G0.T + slopes @ G1.T + g
        out = np.empty((t.size, n))
        out[0] = y0
        y = y0
        for k in range(t.size - 1):
            y = Phi @ y + forcing[k]
            out[k + 1] = y
        return out

    def drive_torque(self, y: np.ndarray) -> np.ndarray:
        """T_D on states (N, n) [N·m]."""
        shaft = self.shaft
        if shaft.drive == "speed":
            return -shaft.drive_stiffness * y[:, 0] - shaft.drive_damping * y[:, 1]
        return shaft.stall_torque * (1.0 - (self.omega + y[:, 1]) / shaft.no_load_speed)


@dataclass
class ShaftSolution:
    """The shaft's motion over a run, as smooth functions of the simulation time.

    Each cam's angle deviation is a quintic interpolating spline through the solution on the
    grid (C⁴: the engine's degree-7 step polynomials see a smooth s(θ(t))).
    """

    model: ShaftModel
    t: np.ndarray
    y: np.ndarray
    torques: np.ndarray

    def __post_init__(self):
        from scipy.interpolate import make_interp_spline

        self._splines = [make_interp_spline(self.t, self.deviation(q), k=5) for q in range(len(self.model.names))]

    def deviation(self, q: int) -> np.ndarray:
        """Cam q's angle deviation from θ0 + φ_q + ω̄·t on the grid [rad]."""
        model = self.model
        if model.sectioned[q] is None:
            return self.y[:, 0]
        return self.y[:, 2 + 2 * model.order.index(q)]

    def theta(self, q: int):
        """``theta(t, order)`` → (order + 1, N): cam q's angle and its time derivatives."""
        model = self.model
        spline = self._splines[q]
        base = model.start + model.phases[q]

        def at(t, order):
            t = np.asarray(t, dtype=float)
            out = np.empty((order + 1, t.size))
            out[0] = base + model.omega * t + spline(t)
            for k in range(1, order + 1):
                out[k] = spline(t, nu=k)
            if order >= 1:
                out[1] += model.omega
            return out

        return at

    def times_at(self, q: int):
        """``times_at(angles)``: the times cam q reaches the given angles [s] (θ increasing)."""
        theta = self.theta(q)
        grid_theta = theta(self.t, 0)[0]

        def at(angles):
            angles = np.asarray(angles, dtype=float)
            t = np.interp(angles, grid_theta, self.t, left=np.nan, right=np.nan)
            # outside the grid: the nominal rotation
            outside = np.isnan(t)
            t[outside] = (angles[outside] - self.model.start - self.model.phases[q]) / self.model.omega
            for _ in range(4):  # Newton on the spline (quadratic from a linear start)
                d = theta(t, 1)
                t = t - (d[0] - angles) / d[1]
            return t

        return at

    def warps(self) -> list:
        """Per cam, the (theta, times_at) of its :class:`~camsim.cam.camshaft.WarpedProgram`."""
        return [(self.theta(q), self.times_at(q)) for q in range(len(self.model.names))]

    def drive_speed(self, t) -> np.ndarray:
        """The drive side's speed ω̄ + v_d [rad/s] at simulation times t (on the grid: exact)."""
        return self.model.omega + np.interp(t, self.t, self.y[:, 1])

    def drive_angle(self, t) -> np.ndarray:
        """The drive side's angle [rad] at simulation times t."""
        return self.model.start + self.model.omega * np.asarray(t, dtype=float) + np.interp(t, self.t, self.y[:, 0])

    def drive_torque(self, t) -> np.ndarray:
        """The drive's torque [N·m] at simulation times t."""
        return np.interp(t, self.t, self.model.drive_torque(self.y))

    def cam_speed(self, q: int, t) -> np.ndarray:
        """Cam q's angular speed [rad/s] at simulation times t (from its spline)."""
        return self.theta(q)(np.asarray(t, dtype=float).reshape(-1), 1)[1]


def station_torques(result, names) -> np.ndarray:
    """(N, cams) torques T_q = F_q·ṡ_q/θ̇_q of a run's samples [N·m]."""
    from camsim.run.camshaft import shaft_torques

    torques = shaft_torques(result)
    return np.column_stack([torques[name] for name in names])


def converge(machine, run_once, t_rec: float, progress=None) -> tuple[ShaftSolution, dict]:
    """Iterate the stations and the shaft to a common solution (waveform relaxation).

    Parameters
    ----------
    machine : Machine
        With ``[camshaft] model = "dynamic"``.
    run_once : callable
        ``run_once(solution)`` → the stations' :class:`RunResult` over the whole run (warm-up
        recorded too, output time −t_rec … t_end − t_rec) for the cams' angle histories of the
        shaft's ``solution`` (None: the rigid shaft).
    t_rec : float
        The simulation time of output time 0 (the warm-up's length) [s].
    progress : callable, optional
        Called with (iteration, change) after each iteration.

    Returns
    -------
    (ShaftSolution, dict)
        The converged shaft, and ``iterations``, ``change`` (the last iteration's largest
        change of the drive's speed relative to ω̄), ``changes`` (every iteration's).

    Raises
    ------
    SimulationError
        When the relaxation does not converge in :data:`MAX_ITERATIONS` (a shaft whose
        inertia is too small for its stations: the coupling is then too strong).
    """
    model = ShaftModel(machine)
    y0 = None
    changes: list[float] = []
    solution = None  # the shaft's motion the stations run on (None: the rigid shaft)
    x = None  # its states on the grid (zero deviations for the rigid shaft)
    history: list[tuple[np.ndarray, np.ndarray]] = []  # (x, f = g(x) − x), scaled, for Anderson
    best = None
    for iteration in range(1, MAX_ITERATIONS + 1):
        result = run_once(solution)
        t = result.time + t_rec
        torques = station_torques(result, model.names)
        if not np.all(np.isfinite(torques)):
            raise SimulationError(f"{machine.source}: the stations' torque is not finite (iteration {iteration})")
        if y0 is None:
            # start in steady rotation under the rigid shaft's mean torques over its last
            # revolution (the settled one: a motor's speed follows the mean torque steeply),
            # the same start for every iteration (updating it with each iteration's torques
            # fed that sensitivity back into the iteration, which then diverged)
            last = t >= t[-1] - 2.0 * math.pi / model.omega
            y0 = model.equilibrium(np.mean(torques[last], axis=0))
        g = model.integrate(t, torques, y0)
        if x is None:
            x = np.zeros_like(g)
        f = g - x
        change = float(np.max(np.abs(f[:, 1]))) / model.omega
        changes.append(change)
        if progress is not None:
            progress(iteration, change)
        if best is None or change < best[0]:
            best = (change, ShaftSolution(model, t, g, torques), iteration)
        if change <= SPEED_TOL:
            return best[1], {"iterations": iteration, "change": change, "changes": changes}
        if len(changes) >= 6 and min(changes[-3:]) > 0.5 * min(changes[:-3]):
            if best[0] <= STAGNATION_TOL:  # at the floor the stations' event location leaves
                return best[1], {"iterations": best[2], "change": best[0], "changes": changes}
            raise SimulationError(
                f"{machine.source}: camshaft: the stations and the shaft do not converge (waveform relaxation: "
                f"speed change {changes[-1]:.3g} of ω̄ after {iteration} iterations); the shaft's inertia is "
                "too small for the stations it drives: raise camshaft.inertia (or flywheel), or use "
                'model = "rigid"')
        x = _anderson(history, x, g, f, model.omega)
        solution = ShaftSolution(model, t, x, torques)
    raise SimulationError(f"{machine.source}: camshaft: no convergence in {MAX_ITERATIONS} iterations "
                          f"(last speed change {changes[-1]:.3g} of ω̄)")


def _anderson(history: list, x: np.ndarray, g: np.ndarray, f: np.ndarray, omega: float) -> np.ndarray:
    """The next iterate by Anderson acceleration (depth :data:`ANDERSON_DEPTH`) of the fixed
    point x = g(x): the combination of the last iterates whose residuals g − x cancel best in
    the least-squares sense (Walker & Ni, SIAM J. Numer. Anal. 49 (2011) 1715). Plain
    relaxation converged by a factor 0.75 per iteration on a flywheel line (the stations'
    torque acts on the shaft as a slow spring); accelerated, in a handful.

    Speeds are scaled by 1/ω̄ against angles [rad] so that both count."""
    scale = np.ones(x.shape[1])
    scale[1::2] = 1.0 / omega
    xs, fs = (x * scale).ravel(), (f * scale).ravel()
    history.append((xs, fs))
    if len(history) > ANDERSON_DEPTH + 1:
        history.pop(0)
    if len(history) < 2:
        return g
    dX = np.column_stack([history[k + 1][0] - history[k][0] for k in range(len(history) - 1)])
    dF = np.column_stack([history[k + 1][1] - history[k][1] for k in range(len(history) - 1)])
    gamma, *_ = np.linalg.lstsq(dF, fs, rcond=None)
    nxt = xs + fs - (dX + dF) @ gamma
    return nxt.reshape(x.shape) / scale


def dynamics_summary(solution: ShaftSolution, info: dict) -> dict:
    """What the summary says about a dynamic shaft's solution: the relaxation's iterations
    and last change, the torsional natural frequencies [Hz], the drive's mean speed over the
    run [rad/s]."""
    model = solution.model
    return {
        "method": "waveform relaxation (stations by the exact engine, the shaft exactly, iterated)",
        "iterations": info["iterations"],
        "speed_change": info["change"],
        "natural_frequencies_hz": [float(w / (2.0 * math.pi)) for w in model.natural_frequencies()],
        "drive_inertia": model.shaft.drive_inertia,
        "mean_drive_speed": float(model.omega + np.mean(solution.y[:, 1])),
    }

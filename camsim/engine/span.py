"""DOP853 spans with events: a configuration with closed nonlinear contacts, stepped towards a stop.

:func:`dop853_span` steps scipy's DOP853 (or a stepper with its interface, such as
:class:`camsim.engine.dop853.OneContactDOP853`) from one state towards a stop time with every
guard as a terminal event, filling the grid points it passes from the dense output. The
general route (:mod:`camsim.engine.rk`) and the bounces of the exponential stepper
(:mod:`camsim.engine.bounce`) are built on it.
"""

from __future__ import annotations

import math

import numpy as np

from camsim.errors import SimulationError
from camsim.heartbeat import beat
from camsim.elements.affine import reads_acceleration, times_rate
from camsim.engine.context import EngineContext
from camsim.engine.crossing import analytic_input, root_near
from camsim.engine.state import TIME_EPS
from camsim.engine.stepping import _FACT, _P, step_input_derivatives, taylor_rows


def _guard_on_step(dense, cam_input, gz, gu, ge):
    """g(t) = gz·z(t) + gu·u(t) + ge on one DOP853 step, z from its dense output: in plain
    floats where the dense output and the cam input can be projected on gz and gu (the
    root finder calls it a dozen times per event), else by their vector calls."""
    dense_g = dense.project(gz) if hasattr(dense, "project") else None
    input_g = cam_input.project(gu) if hasattr(cam_input, "project") else None
    if dense_g is None or input_g is None:
        return lambda t: float(gz @ dense(t) + gu @ cam_input(t)) + ge
    return lambda t: dense_g(t) + input_g(t) + ge


class _StepInput:
    """The cam input u(t) ([s, ṡ, s̈, s⃛] per cam) inside [t0, t1] from per-step Hermite polynomials.

    A right-hand side evaluated tens of thousands of times would otherwise evaluate the
    cam laws point by point; the degree-7 Hermite of each grid step (exact to ~1e-20
    relative, as in the linear integrator) is built once per step and then costs a dot
    product. [t0, t1] never straddles a cam segment join (stretches stop there).
    """

    def __init__(self, integrator: EngineContext, t0: float, t1: float):
        self.integrator = integrator
        self.t0, self.t1 = t0, t1
        self.cache: dict[int, tuple[float, np.ndarray]] = {}
        j = np.arange(_P + 1)
        self.fact = _FACT[: _P + 1]
        self.j = j

    def __call__(self, t: float) -> np.ndarray:
        integ = self.integrator
        k = math.floor((t - integ.t_ref) / integ.h)
        hit = self.cache.get(k)
        if hit is None:
            a = max(self.t0, integ.t_ref + k * integ.h)
            b = min(self.t1, integ.t_ref + (k + 1) * integ.h)
            if b <= a:  # t at (or rounding past) the window's ends
                b = a + integ.h * 1e-9
            ua = integ.inputs(np.array([a]))
            ub = integ.cam.channels(np.array([b]), side="left")
            D = step_input_derivatives(ua, ub, np.array([b - a]))[0]
            # coefficient matrix: u_c(τ) = Σ_j D[j + c] τ^j / j! (per cam)
            C = taylor_rows(D) / self.fact
            hit = (a, C)
            self.cache[k] = hit
        a, C = hit
        return C @ ((t - a) ** self.j)


def dop853_span(ctx: EngineContext, rhs, z0, t0: float, t_stop: float, guards, cam_input, solver=None, forces=None):
    """DOP853 (rtol ``rtol_nonlinear``) from t0 towards t_stop with every guard as a
    terminal event; returns (grid points in [t0, t_end), the states there, the state at
    t_end, the guard that fired or None, t_end).

    scipy's DOP853 stepped here rather than through ``solve_ivp``: the same steps, dense
    output and event roots (``brentq`` on the dense output, as ``solve_ivp`` does), but
    the dense output is built only for the steps that hold a grid point or a root, and
    no solution object is kept (a third of the cost of a bounce).

    A guard that sits at zero at the start (the one just crossed) is watched for a
    real re-crossing, below −tol, so the solver does not stop at once; a root at the
    very start is ignored for the same reason.

    ``solver``: a stepper with the same interface started at (t0, z0) towards t_stop
    (:class:`camsim.engine.dop853.OneContactDOP853`); default scipy's DOP853 on ``rhs``.

    ``forces(t, z)``: the closed power-law contacts' forces F_nl (p,). A guard that
    depends on them (a stuck rigid contact's force λ where a closed power-law contact
    acts on the masses it holds) is evaluated with them; without ``forces`` such a guard
    read only its linear part and missed its crossing (issue 25: a rider's release
    recorded at the next event, 3.9e-5 s late).
    """
    from scipy.integrate import DOP853  # only contact phases of nonlinear contacts
    from scipy.optimize import brentq

    # every guard's value in one product: G_z·z + G_u·u(t) + e (+ tol for a guard at
    # zero at the start)
    events = bool(guards)
    if events:
        Gz = np.array([guard.value.Cz[0] for guard in guards])
        Gu = np.array([guard.value.Du[0] for guard in guards])
        tol = np.array([guard.tol for guard in guards])
        ge = np.array([float(guard.value.e[0]) for guard in guards])
        Gf = np.array([guard.value.Fn[0] for guard in guards]) if forces is not None else None
        if Gf is not None and (Gf.size == 0 or not np.any(Gf)):
            Gf = None  # no guard reads F_nl (the usual case)

        def linear_part(t, z):
            value = Gz @ z + Gu @ cam_input(t)
            return value + Gf @ forces(t, z) if Gf is not None else value

        ge = ge + np.where(np.abs(linear_part(t0, z0) + ge) <= tol, tol, 0.0)
    if solver is None:
        solver = DOP853(rhs, t0, z0, t_stop, rtol=ctx.rtol_nonlinear, atol=ctx.nonlinear_atol(z0.size),
                        max_step=ctx.dop853_max_step())
    grid = ctx.grid_between(t0, t_stop)
    Z = np.empty((grid.size, z0.size))
    done = 0  # grid points filled
    if grid.size and grid[0] <= t0:
        Z[0] = z0
        done = 1
    g_old = linear_part(t0, z0) + ge if events else None
    if events:
        rate_old = _guard_rates(Gz, Gu, solver, cam_input, t0)
        # the guards whose rate is known from the state's derivative (not reading F_nl)
        affine_guards = ~np.any(Gf, axis=1) if Gf is not None else np.ones(len(guards), dtype=bool)
    fired = None
    eps = np.finfo(float).eps
    analytic = ctx.cam if ctx.cam is not None and hasattr(ctx.cam, "channels") else None
    while True:
        beat(solver.t)  # issue 45: the run's progress channel and stall watchdog
        message = solver.step()
        if solver.status == "failed":
            raise SimulationError(f"nonlinear contact phase failed at t = {solver.t:.9g} s: {message}")
        t_old, t_new, z_new = solver.t_old, solver.t, solver.y
        dense = None
        t_end, z_end = t_new, z_new
        if events:
            g_new = linear_part(t_new, z_new) + ge
            rate_new = _guard_rates(Gz, Gu, solver, cam_input, t_new)
            # a crossing downwards (solve_ivp's test), and a dip below zero inside the step
            # that sign changes at its ends cannot see (issue 34: a preloaded link that
            # separated for 18 µs inside one DOP853 step was missed at one sample rate)
            crossing = (g_old >= 0.0) & (g_new <= 0.0)
            h_step = t_new - t_old
            maybe = (~crossing & (g_old > 0.0) & (g_new > 0.0) & affine_guards
                     & (np.minimum(g_old, g_new) - (4.0 / 27.0) * h_step * (np.abs(rate_old) + np.abs(rate_new)) <= 0.0))
            for k in np.flatnonzero(crossing | maybe).tolist():
                if dense is None:
                    dense = solver.dense_output()
                if Gf is not None and np.any(Gf[k]):
                    guard_k = (lambda t, k=k: float(Gz[k] @ dense(t) + Gu[k] @ cam_input(t)
                                                    + Gf[k] @ forces(t, dense(t))) + ge[k])
                else:
                    guard_k = _guard_on_step(dense, cam_input, Gz[k], Gu[k], float(ge[k]))
                if crossing[k]:
                    lo, hi = t_old, t_new
                else:
                    bracket = _dip_bracket(guard_k, t_old, t_new)
                    if bracket is None:
                        continue  # the guard stays above zero through the step
                    lo, hi = bracket
                root = brentq(guard_k, lo, hi, xtol=4 * eps, rtol=4 * eps)
                if analytic is not None and reads_acceleration(Gu[k]):
                    # The guard reads s̈ (a stuck rigid contact's force): located again
                    # with the cam law itself, not the step polynomials of cam_input,
                    # whose s̈ inside a short grid step carries the rounding of s
                    # amplified by ~1/h² (issue 25; 2.9e-8 s at 500 kHz).
                    def guard_law(t, k=k):
                        z_t = dense(t)
                        value = Gz[k] @ z_t + Gu[k] @ analytic_input(ctx.cam, t, t_stop) + ge[k]
                        return float(value + Gf[k] @ forces(t, z_t)) if Gf is not None else float(value)

                    better = root_near(guard_law, t_old, t_new, root)
                    if better is not None:
                        root = better
                if root > t0 + TIME_EPS and (fired is None or root < t_end):
                    fired, t_end = guards[k], root
            g_old, rate_old = g_new, rate_new
            if fired is not None:
                z_end = dense(t_end)
        ended = fired is not None or solver.status == "finished"
        # grid points reached by this step (before the root when a guard fired)
        last = int(np.searchsorted(grid, t_end, side="left" if ended else "right"))
        if last > done:
            if dense is None:
                dense = solver.dense_output()
            Z[done:last] = dense(grid[done:last]).T
            done = last
        if ended:
            return grid[:done], Z[:done], np.asarray(z_end, dtype=float).copy(), fired, float(t_end)

# ------------------------------------------------------------------ nonlinear


def _guard_rates(Gz, Gu, solver, cam_input, t: float) -> np.ndarray:
    """dg/dt of affine guards at the solver's current point: Gz·ż + Gu·u̇ (ż the solver's
    derivative there, u̇ = [ṡ, s̈, s⃛] per cam; guards do not read the jerk)."""
    u = cam_input(t)
    return Gz @ np.asarray(solver.f, dtype=float) + times_rate(Gu, u)


#: Points of a DOP853 step at which a guard that may dip below zero inside it is evaluated
#: on the dense output, and golden-section steps towards its minimum when none is negative.
DIP_POINTS = 33
DIP_GOLDEN = 40


def _dip_bracket(guard, t0: float, t1: float) -> tuple[float, float] | None:
    """(a, b) with guard(a) > 0 ≥ guard(b) inside (t0, t1), the first dip of a guard positive
    at both ends, or None when it stays positive (its minimum located by golden section
    from the best of :data:`DIP_POINTS` points of the dense output)."""
    ts = np.linspace(t0, t1, DIP_POINTS)
    values = [guard(float(t)) for t in ts]
    for k in range(1, len(ts)):
        if values[k] <= 0.0:
            return float(ts[k - 1]), float(ts[k])
    k = int(np.argmin(values))
    a, b = float(ts[max(k - 1, 0)]), float(ts[min(k + 1, len(ts) - 1)])
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    c, d = b - ratio * (b - a), a + ratio * (b - a)
    gc, gd = guard(c), guard(d)
    for _ in range(DIP_GOLDEN):
        if gc <= 0.0:
            return a, c
        if gd <= 0.0:
            return (c, d) if gc > 0.0 else (a, d)
        if gc < gd:
            b, d, gd = d, c, gc
            c = b - ratio * (b - a)
            gc = guard(c)
        else:
            a, c, gc = c, d, gd
            d = a + ratio * (b - a)
            gd = guard(d)
    return None

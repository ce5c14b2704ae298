"""DOP853 across a closed contact's bounce: one contact force, the linear structure around it.

Where the exponential stepper's iteration does not converge (a contact's onset, a bounce,
a release), :func:`bounce_span` takes the configuration a few grid steps further with
:class:`camsim.engine.dop853.OneContactDOP853`, the cam input from :class:`_FastInput` and
every guard as a terminal event (:func:`camsim.engine.rk.dop853_span`).
"""

from __future__ import annotations

import math

import numpy as np

from camsim.elements.affine import N_INPUT
from camsim.engine.span import dop853_span
from camsim.engine.state import TIME_EPS, Stretch
from camsim.engine.stepping import _FACT, _P, step_input_derivatives

#: Grid steps per call of the collocation (solved together, camsim.engine.collocation).
COLLOC_STEPS = 8


#: Loop gain c·h·|∂δ̈/∂F| of the contact's damping over one grid step from which a span is
#: integrated by scipy's Radau instead of DOP853 (see :func:`_stiff_solver`).
STIFF_GAIN = 100.0


def _stiff_solver(A, L, Mz, input_at, stepper, v_impact, t0, z0, t_stop, integ):
    """scipy's Radau (implicit, L-stable) on the one-contact system, for a contact whose
    damping dominates: a Hunt–Crossley law with a restitution near 0 resting closed has a
    tangent damping c = F·χ of 1e7 N·s/m and more, a time constant m/c of ~1e-9 s that
    limits an explicit method's steps (DOP853 took ~1e5 steps per grid step and a run
    did not end, issue 34), while the motion itself is a slow creep. Same tolerances as
    DOP853; the Jacobian is exact: A + L·(k·∂δ/∂z + c·∂δ̇/∂z)."""
    from scipy.integrate import Radau

    n = z0.size
    element = stepper.element

    def rhs(t, z):
        w = input_at(t)
        d, r = Mz @ z + w[n:]
        return A @ z + w[:n] + L * element.nonlinear_force_scalar(float(d), float(r), v_impact)

    def jac(t, z):
        w = input_at(t)
        d, r = Mz @ z + w[n:]
        _, k, c = element.nonlinear_tangent(np.array([d]), np.array([r]), v_impact)
        return A + np.outer(L, float(k[0]) * Mz[0] + float(c[0]) * Mz[1])

    return Radau(rhs, t0, z0, t_stop, rtol=integ.rtol_nonlinear, atol=integ.nonlinear_atol(n),
                 max_step=integ.dop853_max_step(), jac=jac)


def _releasing(delta, rate, h):
    """A contact unloading so fast that it releases within one collocation call at its
    present rate (the collocation would refuse the step; DOP853 goes on)."""
    return rate < 0.0 and delta + rate * COLLOC_STEPS * h < 0.0


class _FastInput:
    """u(t) = [s, ṡ, s̈, s⃛] on [t0, t1] from the grid steps' degree-7 Hermite polynomials,
    built for the whole span in one vectorised pass (a right-hand side evaluated
    thousands of times then costs one small matrix product)."""

    def __init__(self, integ, t0, t1):

        h = integ.h
        k0 = math.ceil((t0 - integ.t_ref) / h - 1e-7)
        k1 = math.floor((t1 - integ.t_ref) / h + 1e-7)
        if k0 <= k1 and integ.t_ref + k0 * h <= t0 + TIME_EPS:
            k0 += 1
        inner = integ.t_ref + np.arange(k0, k1 + 1) * h
        inner = inner[(inner > t0 + TIME_EPS) & (inner < t1 - TIME_EPS)]
        nodes = np.concatenate([[t0], inner, [t1]])
        U = np.empty((nodes.size, N_INPUT))
        U[0] = integ._node_input(t0)
        if inner.size:
            ks = np.round((inner - integ.t_ref) / h).astype(int)
            U[1:-1] = integ._grid_inputs(int(ks[0]), int(ks[-1]) + 1)
        U[-1] = integ._node_input(t1)
        if t1 in integ._joins:
            s_, v_, a_, j_ = integ.cam.svaj(np.array([t1]), side="left")
            U[-1] = [s_[0], v_[0], a_[0], j_[0]]
        D = step_input_derivatives(U[:-1], U[1:], np.diff(nodes), h)
        Dp = np.concatenate([D, np.zeros((D.shape[0], 3))], axis=1)
        fact = _FACT[: _P + 1]
        # C[k, c, j] = D_{j+c}/j!  so that u_c(τ) = Σ_j C[k, c, j]·τ^j
        self.C = np.stack([Dp[:, c : c + _P + 1] / fact for c in range(N_INPUT)], axis=1)
        self.starts = nodes[:-1]
        self.powers = np.arange(_P + 1)
        self.last = nodes.size - 2

        self.h = h
        self.t1 = float(self.starts[1]) if self.starts.size > 1 else math.inf

    def index(self, t: float) -> int:
        """The step holding t (the first from its start node on)."""
        if t < self.t1:
            return 0
        k = 1 + int((t - self.t1) / self.h)
        if k > self.last:
            return self.last
        if t < self.starts[k]:  # rounding at a node
            k -= 1
        return k

    def __call__(self, t):
        k = self.index(t)
        return self.C[k] @ ((t - self.starts[k]) ** self.powers)

    def project(self, g):
        """g·u(t) as a function of a float t, in plain floats (Horner on the projected
        polynomial of the step holding t)."""
        coeffs = [row[::-1] for row in np.einsum("c,kcj->kj", g, self.C).tolist()]
        starts, index = self.starts.tolist(), self.index

        def at(t):
            k = index(t)
            x = t - starts[k]
            y = 0.0
            for c in coeffs[k]:
                y = y * x + c
            return y

        return at


def bounce_span(integ, t0, state, config, z0, guards, t_stop, record, stepper, releasing_to=None):
    """DOP853 (rtol of the integrator) from (t0, z0) to ``t_stop`` or the first event;
    returns (t_end, z_end, the recorded stretch or None, the guard that fired or None).
    ``state`` gives the branches and approach speeds of the stretch. With
    ``releasing_to``: if at ``t_stop`` the contact is releasing (unloading so fast that
    δ + δ̇·COLLOC_STEPS·h < 0, the test advance_power applies before the collocation),
    the same solver goes on to ``releasing_to`` (its step history kept; a new span would
    start with a guessed step).

    The same method, tolerances, events and output as
    :meth:`camsim.engine.integrator.Integrator._advance_nonlinear`, with the cam input from
    :class:`_FastInput` and the one contact's force in scalar arithmetic, stepped by
    :class:`camsim.engine.dop853.OneContactDOP853` (the linear structure around the one force).
    Its first step is the one that worked last time: at an onset (δ = 0 at the start) the
    first accepted step after the last onset, elsewhere the largest accepted step of the
    last span.
    """

    from camsim.engine.dop853 import OneContactDOP853
    from camsim.elements.base import LENGTH_TOL

    v_imp = state.v_impacts
    cam_input = _FastInput(integ, t0, t_stop if releasing_to is None else max(t_stop, releasing_to))
    A, B, b, L = config.A, config.B, config.b, stepper.L
    Mz = np.vstack([stepper.dz, stepper.rz])
    Mu = np.vstack([stepper.du, stepper.ru])
    me = np.array([stepper.de, stepper.re])
    v_impact = stepper.v_impact
    # One matrix product per evaluation gives ż's linear part and the contact's δ, δ̇:
    # rows [A; Mz] on z, and per step the cam input's polynomial pushed through [B; Mu]
    # (its coefficients of τ^j) with the constants [b; me] folded into the τ^0 column.
    BMC = np.einsum("mc,kcj->kmj", np.vstack([B, Mu]), cam_input.C)
    BMC[:, :, 0] += np.concatenate([b, me])
    starts, powers = cam_input.starts, cam_input.powers.astype(float)

    def inputs(ts, t_lo, t_hi):
        """[B·u + b; Mu·u + me] at the times ts ⊂ [t_lo, t_hi]: (len(ts), n + 2)."""
        k0 = index(t_lo)
        if k0 == index(t_hi):  # the usual case: one grid step's polynomial
            return ((ts - start_list[k0])[:, None] ** powers) @ BMC[k0].T
        ks = np.searchsorted(later_starts, ts, side="right")
        return (BMC[ks] @ ((ts - starts[ks])[:, None] ** powers)[:, :, None])[:, :, 0]

    start_list, index, later_starts = starts.tolist(), cam_input.index, starts[1:]

    def input_at(t):
        k = index(t)
        return BMC[k] @ ((t - start_list[k]) ** powers)

    force = stepper.element.scalar_force(v_impact)

    # the first step: what worked last time (see the docstring)
    memory = integ.__dict__.setdefault("_dop853_first_steps", {})
    # (δ within LENGTH_TOL of zero: an impact event leaves δ at zero only to rounding)
    onset = bool(Mz[0] @ z0 + input_at(t0)[-2] <= LENGTH_TOL)
    structure = stepper.__dict__.get("dop853_structure")
    if structure is None:
        structure = stepper.dop853_structure = OneContactDOP853.structure(A, L, Mz)
    n_z = z0.size
    d0, r0 = (Mz @ z0 + input_at(t0)[n_z:]).tolist()
    c0 = float(stepper.element.nonlinear_tangent(np.array([d0]), np.array([r0]), v_impact)[2][0])
    if c0 * integ.h * abs(float(Mz[1] @ L)) >= STIFF_GAIN:
        solver = _stiff_solver(A, L, Mz, input_at, stepper, v_impact, t0, z0, t_stop, integ)
    else:
        solver = OneContactDOP853(A, L, Mz, inputs, input_at, force, t0, z0, t_stop, integ.rtol_nonlinear,
                                  integ.nonlinear_atol(z0.size), integ.dop853_max_step(), memory.get(onset), structure,
                                  exponent=getattr(stepper.element, "exponent", 1.0), onset=onset,
                                  crossing_step=memory.get(True))

    def forces(t, z):
        """The one contact's force F_nl at (t, z), for guards that read it (issue 25)."""
        delta, rate = (Mz @ z + input_at(t)[n_z:]).tolist()
        return np.array([force(delta, rate)])

    grid, Zs, z_end, fired, t_end = dop853_span(integ, None, z0, t0, t_stop, guards, cam_input, solver, forces=forces)
    if fired is None and releasing_to is not None and releasing_to > t_end:
        n = z0.size
        delta, rate = (Mz @ z_end + input_at(t_end)[n:]).tolist()
        if _releasing(delta, rate, integ.h):
            solver.t_bound, solver.status = float(releasing_to), "running"
            grid2, Zs2, z_end, fired, t_end = dop853_span(integ, None, z_end, t_end, releasing_to, guards, cam_input,
                                                                solver, forces=forces)
            grid, Zs = np.concatenate([grid, grid2]), np.concatenate([Zs, Zs2])
    if onset and getattr(solver, "first_accepted", None) is not None:
        memory[True] = solver.first_accepted
    elif not onset and getattr(solver, "largest", 0.0) > 0.0:
        memory[False] = solver.largest
    stretch = None
    if record and grid.size:
        ks = np.round((grid - integ.t_ref) / integ.h).astype(int)
        Us = integ._grid_inputs(int(ks[0]), int(ks[-1]) + 1)  # exact cam values, as on every grid point
        fn = integ.nonlinear_forces(config, Zs, Us, v_imp)
        stretch = Stretch(state.branches, config, grid, Zs, Us, fn, dict(v_imp))
    return t_end, z_end, stretch, fired

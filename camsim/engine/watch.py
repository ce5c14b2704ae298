"""Jump warnings as located events: the cam contact force of a driven mass crossing zero.

A driven mass moves with its cam (``drives`` of a cam; a machine with several cams may have
one per cam, each watched on its own); the force the cam must exert on it,

    F_c = m·(s̈ + g) + Σ_upper f_i − Σ_lower f_i     (f_i the tension of each element on it)

(:meth:`camsim.model.assembly.Model.cam_contact_force`), turning negative means a
force-closed follower would leave the cam: a ``jump`` row (spec §4, §7). F_c changes no
branch, so it is *watched*, not acted on: the trajectory is the same bits with or without
the watch. It is located like every event (issue 25):

- in a linear configuration F_c is affine in (z, u) with an exact time derivative, so each
  chunk's nodes give its values and rates; every step where it may cross (a sign change, or
  a cubic-Hermite dip bound that reaches zero) is searched on the exact solution and the
  crossing polished on the analytic cam law (:func:`camsim.engine.crossing.polish_crossing`),
  to 1e-10 s whatever the sample rate;
- in a stretch where a power-law contact is closed (no exact solution between samples) a
  sign change of F_c between two known states (the stretch's ends and its recorded
  samples) is bracketed there, and the bracket integrated again from its first state by
  DOP853 at rtol 1e-12 with F_c as a terminal event on the analytic cam law
  (:meth:`CamForceWatch._locate_nonlinear`). Interpolating between samples instead (the
  cubic Hermite through them, or the chord where F_c reads a power-law force) moved the
  jump by up to 2.5e-6 s between 5 and 500 kHz (issue 25, invariant a);
- F_c may jump where a stretch ends (a cam segment join, where s̈ jumps, or an event that
  changes the forces on the driven mass): its value before and after are compared there, and
  a drop below zero is a jump at that instant.

A crossing counts when F_c falls below −:data:`FORCE_TOL` (1e-9 N) — a force resting at
zero to rounding (a dwell without preload) is no jump — and it is placed where F_c = 0.
The watch keeps F_c's last value across stretches and runs: a recording integrator that
continues a warm-up starts with the warm-up's last value, so the recorded window starts
with no jump the continuous run does not have.
"""

from __future__ import annotations

import math

import numpy as np

from camsim.elements import FORCE_TOL
from camsim.elements.affine import N_INPUT, Affine, channel, input_rate
from camsim.elements.events import Event, EventKind
from camsim.engine.crossing import analytic_input, polish_crossing, root_near
from camsim.engine.roots import refine
from camsim.engine.state import Guard, cubic_root
from camsim.engine.stepping import exact_partial, forcing_coefficients, step_input_derivatives


#: A bracket of a power-law stretch without recorded samples is re-integrated when it spans
#: at most this many grid steps (see CamForceWatch.samples).
SHORT_BRACKET_STEPS = 16


class CamForceWatch:
    """Locates the zero crossings of every driven mass's cam contact force.

    Parameters
    ----------
    integrator : camsim.engine.integrator.Integrator
        The integrator whose stretches are watched; jump rows go to its ``events``.
    """

    def __init__(self, integrator):
        self.integrator = integrator
        model = integrator.model
        self.model = model
        #: (driven mass, index of its cam) of every driven mass, by cam name (two jumps at one
        #: instant are recorded in that order, whatever the order of the cams in the file).
        self.drives: list[tuple[str, int]] = sorted(model.drives.items(), key=lambda d: model.cam_names[d[1]])
        self.active = bool(self.drives)
        #: False: the jumps are not looked for, only F_c's sign where each watched piece ends
        #: is kept (a warm-up whose events are not reported: its ``last`` is all the recording
        #: reads of it).
        self.locating = True
        #: Per driven mass, (t [s], F_c [N]) at the end of the last watched piece (absent
        #: before the first).
        self.last: dict[str, tuple[float, float]] = {}
        self._affines: dict = {}

    # ------------------------------------------------------------------ the force
    def affine(self, config, driven: str | None = None):
        """(F_c, dF_c/dt or None) of a driven mass (default the first) in a configuration as
        affine maps of (z, u, F_nl)."""
        driven = driven or self.model.driven
        key = (config.key, driven)
        hit = self._affines.get(key)
        if hit is not None:
            return hit
        model = self.model
        m = config.dim
        p = len(config.power_contacts)
        Cz = np.zeros((1, m))
        Du = np.zeros((1, model.n_input))
        Fn = np.zeros((1, p))
        e = np.zeros(1)
        mass = model.driven_masses[driven]
        Du[0, channel(model.drives[driven], 2)] = mass
        e[0] = mass * model.gravity
        for k, load in enumerate(getattr(model, "loads", ())):  # issue 43: F_c = m·s̈ − Σ f − loads on it
            if load.on == driven:
                Du[0, model.load_column(k)] -= 1.0
        for i, element in enumerate(model.elements):
            if driven not in element.nodes:
                continue
            # the force on the driven mass: −f on the upper node, +f on the lower (tension
            # f), a compressive contact force F acts +σF on the upper node
            on_upper = 1.0 if element.upper == driven else -1.0
            branch = model.branch_of(config.branches, i)
            if i in config.stuck_contacts:
                sigma = element.contact_side(branch)[0]
                k = config.stuck_contacts.index(i)
                lam = config.lam.rows(slice(k, k + 1))
                w = -on_upper * sigma
                Cz, Du, Fn, e = Cz + w * lam.Cz, Du + w * lam.Du, Fn + w * lam.Fn, e + w * lam.e
                continue
            if i in config.saturated:  # a stuck friction pair beside a stuck contact: ±F_B
                law = (0.0, 0.0, config.saturated[i])
            elif i in config.power_contacts:
                sigma = element.contact_side(branch)[0] * float(element.acts(branch))
                Fn[0, config.power_contacts.index(i)] -= on_upper * sigma
                law = element.linear_part(branch, model.damping[i])  # its linear part, if any
            else:
                law = model.linear_branch(i, branch)
            if law is None:
                continue
            k_, c_, f0 = law
            a_in = element.input_force(branch) if getattr(element, "programmed", False) else 0.0
            if a_in:  # a sliding pair's ±μ·N(t) (its normal force follows a program)
                Du[0, model.normal_column(i)] += on_upper * a_in
            # f = k·d + c·ḋ + f0, d = G·x + g_s·s, ḋ = G·v + g_s·ṡ; F_c gains +f (upper), −f (lower)
            geo = model.geometry[i]
            d = Affine.combine([(geo.G.reshape(1, -1), config.x)], const=np.zeros(1), du=_du(0, geo.g_s, model.n_input))
            rate = Affine.combine([(geo.G.reshape(1, -1), config.v)], const=np.zeros(1),
                                  du=_du(1, geo.g_s, model.n_input))
            w = on_upper
            Cz = Cz + w * (k_ * d.Cz + c_ * rate.Cz)
            Du = Du + w * (k_ * d.Du + c_ * rate.Du)
            Fn = Fn + w * (k_ * d.Fn + c_ * rate.Fn)
            e = e + w * (k_ * d.e + c_ * rate.e + f0)
        value = Affine(Cz, Du, Fn, e)
        rate = None
        if not np.any(value.Fn) and not np.any(value.Du[:, 3::N_INPUT]):
            integ = self.integrator
            rate = integ._rate(config, Affine(Cz, Du, np.zeros_like(Fn), e))
        hit = (value, rate)
        if len(self._affines) > 4096:
            self._affines.clear()
        self._affines[key] = hit
        return hit

    # ------------------------------------------------------------------ recording
    def _jump(self, t: float, driven: str) -> None:
        cam = self.model.cam_names[self.model.drives[driven]]
        self.integrator.events.append(
            Event(time=float(t), element=cam, kind=EventKind.JUMP, masses=f"{cam}/{driven}")
        )

    def _boundary(self, t0: float, f0: float, driven: str) -> None:
        """A piece starts at t0 with F_c = f0: a drop below zero since the last piece ends
        (a jump of F_c at a join or an event, or the run's very first instant)."""
        last = self.last.get(driven)
        if f0 < -FORCE_TOL and (last is None or last[1] >= -FORCE_TOL):
            self._jump(t0, driven)

    # ------------------------------------------------------------------ linear stretches
    def linear_chunk(self, config, nodes, Z, U, D, t_cut=None, z_cut=None, index=None):
        """Watch one chunk of a linear stretch: nodes (N,), exact states Z (N, m), inputs U
        (N, 4·c), the steps' Hermite derivatives D (N − 1, 8·c); with ``t_cut`` the chunk
        ends at an event at t_cut (state ``z_cut``) inside step ``index``."""
        if not self.active:
            return
        integ = self.integrator
        if not self.locating:
            # the chunk's last node (the event's instant when it ends at one): F_c there
            if t_cut is None:
                t_last, z_last, u_last = nodes[-1], Z[-1:], U[-1:]
            elif t_cut - nodes[index] > 0.0:
                t_last, z_last, u_last = t_cut, z_cut[None, :], integ.inputs(np.array([t_cut]))
            else:
                t_last, z_last, u_last = nodes[index], Z[index : index + 1], U[index : index + 1]
            for driven, _ in self.drives:
                value, _ = self.affine(config, driven)
                self.last[driven] = (float(t_last), float((z_last @ value.Cz.T + u_last @ value.Du.T + value.e)[0, 0]))
            return
        if t_cut is not None:
            # the chunk up to the event: nodes ≤ index, then the partial step to t_cut
            u_cut = integ.inputs(np.array([t_cut]))
            if t_cut - nodes[index] > 0.0:
                nodes = np.concatenate([nodes[: index + 1], [t_cut]])
                Z = np.vstack([Z[: index + 1], z_cut[None, :]])
                U = np.vstack([U[: index + 1], u_cut])
                D = np.vstack([D[:index], step_input_derivatives(U[index : index + 1], u_cut, np.array([t_cut - nodes[index]]))])
            else:
                nodes, Z, U, D = nodes[: index + 1], Z[: index + 1], U[: index + 1], D[:index]
        for driven, _ in self.drives:
            self._linear_piece(config, nodes, Z, U, D, driven)

    def _linear_piece(self, config, nodes, Z, U, D, driven: str) -> None:
        """Watch one driven mass over a chunk (see :meth:`linear_chunk`)."""
        value, rate = self.affine(config, driven)
        G = (Z @ value.Cz.T + U @ value.Du.T + value.e)[:, 0]
        self._boundary(float(nodes[0]), float(G[0]), driven)
        if nodes.size >= 2:
            guard_value = Affine(value.Cz, value.Du, value.Fn, value.e + FORCE_TOL)
            guard = Guard(-1, None, guard_value, 0.0, rate)
            g = G + FORCE_TOL
            steps = np.diff(nodes)
            g0, g1 = g[:-1], g[1:]
            # a cam break is a step of length zero: F_c may jump there (s̈ does), and a drop
            # below zero across it is a jump at that instant
            moving = steps > 0.0
            flagged = ~moving & (g0 > 0.0) & (g1 <= 0.0)
            Gd = None
            if rate is not None:
                Gd = (Z @ rate.Cz.T + U @ rate.Du.T + rate.e)[:, 0]
                # a crossing, or a step whose cubic bound reaches zero (engine.linear.screen_steps)
                rates = np.abs(Gd)
                low = np.minimum(g0, g1) - (4.0 / 27.0) * steps * (rates[:-1] + rates[1:])
                flagged |= moving & (g0 > 0.0) & (low <= 0.0)
            for k in np.flatnonzero(flagged).tolist():  # in time order
                if moving[k]:
                    self._locate_linear(config, guard, value, nodes, Z, D, Gd, g, k, driven)
                else:
                    self._jump(float(nodes[k]), driven)
        self.last[driven] = (float(nodes[-1]), float(G[-1]))

    def _locate_linear(self, config, guard, value, nodes, Z, D, Gd, g, k, driven):
        """The first crossing of F_c + FORCE_TOL downwards inside step k, placed where
        F_c = 0 on the exact solution and the cam law (None found: a dip that stays above)."""
        integ = self.integrator
        hk = float(nodes[k + 1] - nodes[k])
        t_k = float(nodes[k])
        Ek = forcing_coefficients(config, D[k : k + 1])[0]
        z_k = Z[k]

        def state_at(tau):
            return exact_partial(config, z_k, Ek, tau) if tau > 0 else z_k

        ends = (float(g[k]), float(g[k + 1]), float(Gd[k]), float(Gd[k + 1]))
        root = refine(config, guard, z_k, D[k], Ek, hk, False, ends)
        if root is None:
            return
        polished = polish_crossing(integ, config, guard, t_k, hk, root[0], root[1], D[k], state_at=state_at)
        if polished is None:
            return
        tau = polished[0]

        def force(t_local):
            u = analytic_input(integ.cam, t_k + t_local, t_k + hk)  # the left limit at the step's end
            return float(value(state_at(t_local)[None, :], u[None, :])[0, 0])

        # the jump is where F_c = 0, a hair before it passes −FORCE_TOL
        at_zero = root_near(force, 0.0, tau, tau) if tau > 0.0 else None
        self._jump(t_k + (at_zero if at_zero is not None else tau), driven)

    # ------------------------------------------------------------------ other stretches
    def samples(self, start, end, stretch, config, rhs_rates=True):
        """Watch a stretch integrated without an exact solution between samples (a closed
        power-law contact): its start state, recorded samples and end state."""
        if not self.active:
            return
        if not self.locating:  # F_c where the stretch ends (see linear_chunk)
            integ = self.integrator
            u = integ.inputs(np.array([end.t]))
            z = config.state_from_input(end.x, end.v, u[0])
            fn = integ.nonlinear_forces(config, z[None, :], u, end.v_impacts)
            for driven, _ in self.drives:
                value, _ = self.affine(config, driven)
                self.last[driven] = (float(end.t), float(value(z[None, :], u, fn)[0, 0]))
            return
        for driven, _ in self.drives:
            self._samples(start, end, stretch, config, driven)

    def _samples(self, start, end, stretch, config, driven):
        """Watch one driven mass over a stretch (see :meth:`samples`)."""
        integ = self.integrator
        value, _ = self.affine(config, driven)
        ts, Fs, Rs = [], [], []
        for st in (start, end):
            u = integ.inputs(np.array([st.t]))
            z = config.state_from_input(st.x, st.v, u[0])
            fn = integ.nonlinear_forces(config, z[None, :], u, st.v_impacts)
            ts.append(np.array([st.t]))
            Fs.append(value(z[None, :], u, fn)[:, 0])
            Rs.append(self._rates(config, value, z[None, :], u, fn))
        t = [ts[0]]
        F = [Fs[0]]
        R = [Rs[0]]
        if stretch is not None and stretch.t.size:
            inner = (stretch.t > start.t) & (stretch.t < end.t)
            if np.any(inner):
                z, u, fn = stretch.z[inner], stretch.u[inner], stretch.fn[inner]
                t.append(stretch.t[inner])
                F.append(value(z, u, fn)[:, 0])
                R.append(self._rates(config, value, z, u, fn))
        t.append(ts[1])
        F.append(Fs[1])
        R.append(Rs[1])
        t, F, R = np.concatenate(t), np.concatenate(F), np.concatenate(R)
        self._boundary(float(t[0]), float(F[0]), driven)
        g = F + FORCE_TOL
        for k in np.flatnonzero((g[:-1] > 0.0) & (g[1:] <= 0.0)).tolist():
            if k == 0:
                z_k = config.state_from_input(start.x, start.v, integ.inputs(np.array([start.t]))[0])
            else:
                z_k = stretch.z[inner][k - 1]
            # Re-integrate a bracket between recorded samples (or a short stretch); an
            # unrecorded warm-up stretch is one long bracket whose rows are not kept -- only
            # the sign at its end is -- so it is interpolated (a whole warm-up revolution at
            # rtol 1e-12 took minutes on a stiff machine).
            short = stretch is not None or t[k + 1] - t[k] <= SHORT_BRACKET_STEPS * integ.h
            located = (self._locate_nonlinear(config, value, float(t[k]), float(t[k + 1]), z_k, start.v_impacts)
                       if short else None)
            self._jump(located if located is not None else _hermite_zero(t[k], t[k + 1], F[k], F[k + 1], R[k], R[k + 1]),
                       driven)
        self.last[driven] = (float(t[-1]), float(F[-1]))

    def _locate_nonlinear(self, config, value, t0: float, t1: float, z0, v_impacts) -> float | None:
        """Where F_c crosses zero downwards in [t0, t1] of a stretch with closed power-law
        contacts: the configuration integrated again from its state z0 at t0 by DOP853
        (rtol 1e-12, the cam input from its laws) with F_c as a terminal event; None when
        the re-integration finds no crossing (then the caller interpolates)."""
        from scipy.integrate import solve_ivp

        integ = self.integrator
        cam, A, B, b, L = integ.cam, config.A, config.B, config.b, config.L

        def parts(t, z):
            u = analytic_input(cam, t, t1)[None, :]
            fn = integ.nonlinear_forces(config, z[None, :], u, v_impacts)
            return u, fn

        def rhs(t, z):
            u, fn = parts(t, z)
            out = A @ z + B @ u[0] + b
            return out + L @ fn[0] if L.shape[1] else out

        def force(t, z):
            u, fn = parts(t, z)
            return float(value(z[None, :], u, fn)[0, 0])

        force.terminal, force.direction = True, -1
        atol = integ.nonlinear_atol(z0.size) * 1e-2
        sol = solve_ivp(rhs, (t0, t1), np.asarray(z0, dtype=float), method="DOP853", rtol=1e-12, atol=atol,
                        events=force, max_step=max(integ.h, (t1 - t0) / 8))
        if sol.status == -1 or not sol.t_events[0].size:
            return None
        return float(sol.t_events[0][0])

    def _rates(self, config, value, z, u, fn):
        """dF_c/dt on samples: exact where F_c reads no power-law force, else NaN."""
        if np.any(value.Fn):
            return np.full(z.shape[0], np.nan)
        zdot = z @ config.A.T + u @ config.B.T + config.b
        if config.L.shape[1]:
            zdot = zdot + fn @ config.L.T
        udot = input_rate(u)
        return (zdot @ value.Cz.T + udot @ value.Du.T)[:, 0]


def _du(order: int, coefficients: np.ndarray, width: int) -> np.ndarray:
    """An input row of ``width`` columns with ``coefficients`` (one per cam) on each cam's
    channel ``order`` (the loads' groups after the cams' carry none)."""
    du = np.zeros((1, width))
    du[0, order : coefficients.size * N_INPUT : N_INPUT] = coefficients
    return du


def _hermite_zero(t0, t1, f0, f1, d0, d1) -> float:
    """The zero of F between samples (f0 ≥ 0 > f1): of the cubic Hermite with the exact
    rates d0, d1 [N/s] where known, else of the chord."""
    h = t1 - t0
    if not (math.isfinite(d0) and math.isfinite(d1)) or h <= 0.0:
        return float(t0 + h * f0 / (f0 - f1) if f0 != f1 else t1)
    return float(t0 + h * cubic_root(f0, f1, d0 * h, d1 * h))

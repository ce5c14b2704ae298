"""The event-driven integrator: exact between events, events located on the exact solution.

Between events a configuration is linear time-invariant with a cam input, advanced by
exact step maps (:mod:`camsim.engine.stepping`) over chunks of the output grid.

Event guards are affine in (z, u); their values and time derivatives are known exactly
at every grid point, so a cubic Hermite interpolant per step reveals crossings that sign
changes alone miss (a graze that crosses and re-crosses inside one step). Candidate
roots are then polished by Newton's method on the exact solution to ~1e-15 s.

Configurations with a closed power-law contact are nonlinear: one such contact goes to the
exponential stepper of :mod:`camsim.engine.nonlinear`; others to ``scipy.integrate.solve_ivp``
(DOP853, rtol 1e-11) with terminal events. Rigid contacts are resolved together as one
linear complementarity problem (:mod:`camsim.engine.rigid`); every located crossing is polished
on the analytic cam law (:mod:`camsim.engine.crossing`).
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from camsim.errors import SimulationError, ZenoError
from camsim.engine.crossing import analytic_input, polish_crossing, root_near
from camsim.elements.events import Event, EventKind
from camsim.elements.affine import N_INPUT, Affine
from camsim.elements import Branch, GuardKind
from camsim.model.assembly import Configuration, Model
from camsim.engine.nonlinear import advance_power
from camsim.engine.watch import CamForceWatch
from camsim.engine.state import TIME_EPS, Guard, State, Stretch  # noqa: F401 - also the integrator's public names
from camsim.engine.state import cubic_root as _cubic_root
from camsim.engine.rigid import resolve as resolve_rigid
from camsim.engine.stepping import (  # noqa: F401 - also re-exported for camsim.engine.nonlinear and camsim.engine.crossing
    _FACT,
    _P,
    HERMITE_DEGREE,
    StepMaps,
    exact_partial,
    expm_balanced,
    forcing_coefficients,
    input_at,
    step_input_derivatives,
    _hermite_maps,
)


#: Guard tolerances (LENGTH_TOL [m], FORCE_TOL [N]) are the elements' (camsim.elements.base):
#: a guard within them of zero at the start of a stretch counts as "just crossed".
#: More events than this at one instant (within INSTANT_TIME) is a failure to resolve.
MAX_EVENTS_PER_INSTANT = 64
#: Events closer than this [s] count as one instant for MAX_EVENTS_PER_INSTANT.
INSTANT_TIME = 1e-12
#: A time within this fraction of the grid step of a grid point is that grid point: grid
#: times are t_ref + k·h computed from k, so only rounding (~1e-16·k) separates them.
GRID_SNAP = 1e-7
#: Newton on a guard stops when its bracket is this narrow [s] (about one ulp of t ~ 10 s).
ROOT_BRACKET = 1e-15
#: The search for a grazing dip bisects the exact guard rate to this fraction of the step.
DIP_RESOLUTION = 1e-10
#: Closed power-law contacts by the iterated-remainder stepper (camsim.engine.nonlinear); False:
#: DOP853 throughout (the reference for the stepper's tests and benchmark).
NONLINEAR_STEPPER = True


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
    """The cam input u(t) = [s, ṡ, s̈, s⃛] inside [t0, t1] from per-step Hermite polynomials.

    A right-hand side evaluated tens of thousands of times would otherwise evaluate the
    cam laws point by point; the degree-7 Hermite of each grid step (exact to ~1e-20
    relative, as in the linear integrator) is built once per step and then costs a dot
    product. [t0, t1] never straddles a cam segment join (stretches stop there).
    """

    def __init__(self, integrator: "Integrator", t0: float, t1: float):
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
            s_, v_, a_, j_ = integ.cam.svaj(np.array([b]), side="left")
            ub = np.array([[s_[0], v_[0], a_[0], j_[0]]])
            D = step_input_derivatives(ua, ub, np.array([b - a]))[0]
            # coefficient matrix: u_c(τ) = Σ_j D[j + c] τ^j / j!
            Dp = np.concatenate([D, np.zeros(3)])
            C = np.array([Dp[c : c + _P + 1] / self.fact for c in range(N_INPUT)])
            hit = (a, C)
            self.cache[k] = hit
        a, C = hit
        return C @ ((t - a) ** self.j)


class _GuardContext:
    """What an element needs to state its guards in one configuration at one state."""

    def __init__(self, integrator: "Integrator", config: Configuration, state: State, index: int):
        self.integrator = integrator
        self.config = config
        self.state = state
        self.index = index
        self.damping = integrator.model.damping[index]
        self.v_impact = state.v_impacts.get(index)

    def deflection(self) -> tuple[Affine, Affine]:
        """d = x_upper − x_lower and ḋ as affine maps."""
        return self.integrator._deflection(self.config, self.index)

    def penetration(self) -> tuple[Affine, Affine]:
        """δ = gap − d and δ̇ of a contact as affine maps."""
        return self.integrator._delta(self.config, self.index)

    def constraint_force(self) -> Affine:
        """The compressive force of a constraint (a stuck rigid contact) as an affine map."""
        k = self.config.stuck_contacts.index(self.index)
        return self.config.lam.rows(slice(k, k + 1))

    def now(self, value: Affine) -> float:
        """An affine map evaluated at the current state."""
        integ = self.integrator
        z = self.config.state_from_full(self.state.x, self.state.v, *integ.inputs(np.array([self.state.t]))[0, :2])
        u = integ.inputs(np.array([self.state.t]))
        return float(value(z[None, :], u)[0, 0])


class Integrator:
    """Event-driven integration of a :class:`Model` driven by a cam program.

    Parameters
    ----------
    model : Model
    cam : CamProgram
        Provides ``svaj(t)`` and ``boundary_times(t0, t1)``.
    step : float
        Internal grid step h [s]; the grid is t_ref + k·h.
    t_ref : float
        A time on the grid [s].
    """

    #: Grid points per block of cached cam input.
    _BLOCK = 4096

    def __init__(self, model: Model, cam, step: float, t_ref: float = 0.0):
        self.model = model
        self.cam = cam
        self.h = step
        self.t_ref = t_ref
        self.events: list[Event] = []
        self._maps: dict[tuple[Branch, ...], StepMaps] = {}
        self._deltas: dict[tuple[tuple[Branch, ...], int], tuple[Affine, Affine]] = {}
        self._instant_count = 0
        self._instant_time = -math.inf
        self.rtol_nonlinear = 1e-11
        self._chunk = 512
        self._input_cache: dict[float, np.ndarray] = {}
        self._grid_cache: dict[int, np.ndarray] = {}  # cam input on the grid, per block
        self._join_array: list[float] | None = None  # sorted cam joins of the current run
        self._joins: set[float] = set()  # cam segment joins of the current run
        self._stacked = None  # the current stretch's guards stacked into matrices
        #: Jump warnings: the driven mass's cam contact force located like an event (issue 25).
        self.watch = CamForceWatch(self)

    # ------------------------------------------------------------------ inputs
    def inputs(self, t: np.ndarray) -> np.ndarray:
        """[s, ṡ, s̈, s⃛] at times t: (N, 4). Single instants are cached (events ask repeatedly)."""
        t = np.asarray(t, dtype=float)
        if t.size == 1:
            key = float(t.reshape(-1)[0])
            hit = self._input_cache.get(key)
            if hit is None:
                hit = self._input_between_grid_points(key)
                if hit is None:
                    s, v, a, j = self.cam.svaj(t.reshape(1))
                    hit = np.stack([s, v, a, j], axis=-1)
                if len(self._input_cache) > 64:
                    self._input_cache.clear()
                self._input_cache[key] = hit
            return hit.copy()
        s, v, a, j = self.cam.svaj(t)
        return np.stack([s, v, a, j], axis=-1)

    def analytic_inputs(self, t: float) -> np.ndarray:
        """[s, ṡ, s̈, s⃛] at one instant from the cam laws (the limit from the right at a join):
        (4,). Unlike :meth:`inputs`, never the step's Hermite polynomial, whose s̈ and s⃛
        inside a short step carry the rounding of s amplified by ~1/h² and ~1/h³."""
        s_, v_, a_, j_ = self.cam.svaj(np.array([float(t)]))
        return np.array([s_[0], v_[0], a_[0], j_[0]])

    def chunk_inputs(self, nodes: np.ndarray, k0: int, k1: int) -> np.ndarray:
        """Cam input [s, ṡ, s̈, s⃛] at a chunk's nodes: its start, grid points k0 ≤ k < k1, its end.

        The last step ends at the chunk's end, maybe a cam segment join: its end values are
        the limits from the left there (acceleration or jerk may jump).
        """
        U = np.empty((nodes.size, N_INPUT))
        U[0] = self._node_input(float(nodes[0]))
        U[1:-1] = self._grid_inputs(k0, k1)
        U[-1] = self._node_input(float(nodes[-1]))
        if nodes[-1] in self._joins:
            s_, v_, a_, j_ = self.cam.svaj(nodes[-1:], side="left")
            U[-1] = [s_[0], v_[0], a_[0], j_[0]]
        return U

    def _node_input(self, t: float) -> np.ndarray:
        """Cam input at a chunk's first or last node: the cached grid value when the node
        is a grid point (so a sample's value never depends on where a stretch began)."""
        k = round((t - self.t_ref) / self.h)
        if abs(self.t_ref + k * self.h - t) <= TIME_EPS:
            return self._grid_inputs(k, k + 1)[0]
        return self.inputs(np.array([t]))[0]

    def _input_between_grid_points(self, t: float) -> np.ndarray | None:
        """Cam input at one instant from the Hermite polynomial of its grid step.

        The same degree-7 representation the step maps integrate (exact to ~1e-20
        relative), built from the cached grid values: a tenth of the cost of evaluating
        the cam laws at a single point. None where the step holds a cam segment join (the
        polynomial does not reach across one) or outside a run.
        """
        if self._join_array is None:
            return None
        h = self.h
        k = math.floor((t - self.t_ref) / h)
        t_k = self.t_ref + k * h
        i = bisect.bisect_right(self._join_array, t_k + TIME_EPS)
        if i < len(self._join_array) and self._join_array[i] <= t_k + h + TIME_EPS:
            return None
        grid = self._grid_inputs(k, k + 2)
        P0, P1 = _hermite_maps(h)
        D = np.concatenate([grid[0] @ P0 + grid[1] @ P1, np.zeros(N_INPUT - 1)])
        powers = (t - t_k) ** np.arange(_P + 1) / _FACT[: _P + 1]
        return np.array([[D[c : c + _P + 1] @ powers for c in range(N_INPUT)]])

    def _grid_inputs(self, k0: int, k1: int) -> np.ndarray:
        """Cam input at grid points k0 ≤ k < k1: (k1 − k0, 4), from blocks evaluated once."""
        out = np.empty((max(k1 - k0, 0), N_INPUT))
        block = self._BLOCK
        k = k0
        while k < k1:
            b = k // block
            values = self._grid_cache.get(b)
            if values is None:
                t = self.t_ref + np.arange(b * block, (b + 1) * block) * self.h
                s_, v_, a_, j_ = self.cam.svaj(t)
                values = np.stack([s_, v_, a_, j_], axis=-1)
                if len(self._grid_cache) > 64:
                    self._grid_cache.clear()
                self._grid_cache[b] = values
            stop = min(k1, (b + 1) * block)
            out[k - k0 : stop - k0] = values[k - b * block : stop - b * block]
            k = stop
        return out

    def maps(self, config: Configuration) -> StepMaps:
        maps = self._maps.get(config.branches)
        if maps is None:
            maps = StepMaps(config, self.h)
            self._maps[config.branches] = maps
        return maps

    # ------------------------------------------------------------------ guards
    def _deflection(self, config: Configuration, i: int) -> tuple[Affine, Affine]:
        """Deflection d = x_upper − x_lower of element i and its rate, as affine maps."""
        geo = self.model.geometry[i]
        G = geo.G.reshape(1, -1)
        du = np.zeros((1, N_INPUT))
        du[0, 0] = geo.g_s
        d = Affine.combine([(G, config.x)], const=np.zeros(1), du=du)
        du = np.zeros((1, N_INPUT))
        du[0, 1] = geo.g_s
        rate = Affine.combine([(G, config.v)], const=np.zeros(1), du=du)
        return d, rate

    def _delta(self, config: Configuration, i: int) -> tuple[Affine, Affine]:
        """Penetration δ = gap − d of contact i and its rate δ̇, as affine maps (built once
        per configuration and contact: every sample of a closed power-law contact's force
        reads them)."""
        key = (config.branches, i)
        hit = self._deltas.get(key)
        if hit is None:
            d, rate = self._deflection(config, i)
            sign, gap = self.model.elements[i].contact_side(self.model.branch_of(config.branches, i))
            if sign < 0:  # the upper side of a two-sided element: δ = d − gap (issue 12 hook)
                hit = Affine(d.Cz, d.Du, d.Fn, d.e - gap), rate
            else:
                hit = Affine(-d.Cz, -d.Du, -d.Fn, gap - d.e), Affine(-rate.Cz, -rate.Du, -rate.Fn, -rate.e)
            self._deltas[key] = hit
        return hit

    def guards(self, state: State, config: Configuration) -> list[Guard]:
        """Guards of the configuration at ``state``, as each element declares them."""
        model = self.model
        out: list[Guard] = []
        for pos, i in enumerate(model.switching):
            context = _GuardContext(self, config, state, i)
            for kind, value, tol in model.elements[i].guards(state.branches[pos], context):
                out.append(Guard(i, kind, value, tol))
        if config.linear:
            for guard in out:
                guard.rate = self._rate(config, guard.value)
        return out

    @staticmethod
    def _rate(config: Configuration, g: Affine) -> Affine:
        """d/dt of an affine guard in a linear configuration."""
        Du = g.Cz @ config.B
        Du[:, 1:] += g.Du[:, :-1]
        if np.any(g.Du[:, -1]):
            raise AssertionError("guards may not depend on the jerk")
        return Affine(g.Cz @ config.A, Du, np.zeros_like(g.Fn), g.Cz @ config.b)

    # ------------------------------------------------------------------ grid helpers
    def grid_between(self, t0: float, t1: float) -> np.ndarray:
        """Grid points in [t0, t1) (tolerant to rounding)."""
        k0 = math.ceil((t0 - self.t_ref) / self.h - GRID_SNAP)
        k1 = math.ceil((t1 - self.t_ref) / self.h - GRID_SNAP)
        if k1 <= k0:
            return np.zeros(0)
        return self.t_ref + np.arange(k0, k1) * self.h

    # ------------------------------------------------------------------ advancing
    def advance(self, state: State, t_stop: float, record: bool) -> tuple[State, Stretch | None, Guard | None]:
        """Integrate one configuration from ``state`` until an event or ``t_stop``.

        Returns the state at the end, the recorded samples (grid points in
        [state.t, end)), and the guard that fired (None when ``t_stop`` was reached).
        """
        config = self.model.configuration(state.branches)
        guards = self.guards(state, config)
        u0 = self.inputs(np.array([state.t]))[0]
        z0 = config.state_from_full(state.x, state.v, u0[0], u0[1])
        if config.linear:
            return self._advance_linear(state, config, z0, guards, t_stop, record)
        if (len(config.power_contacts) == 1 and config.dim and NONLINEAR_STEPPER
                and hasattr(self.model.elements[config.power_contacts[0]], "nonlinear_tangent")):
            out = advance_power(self, state, config, z0, guards, t_stop, record)  # issue 12 hook
        else:
            out = self._advance_nonlinear(state, config, z0, guards, t_stop, record)
        self.watch.samples(state, out[0], out[1], config)
        return out

    def _advance_linear(self, state, config, z0, guards, t_stop, record):
        maps = self.maps(config)
        h = self.h
        t0 = state.t
        chunk = self._chunk
        collected_t, collected_z, collected_u = [], [], []
        first_chunk = True
        z_start = z0
        t_start = t0
        while True:
            # Chunk ends on a grid point computed from its index, t_ref + k·h, so that a
            # sample's time (and the cam input there) is the same whatever the history.
            k_end = math.floor((t_start - self.t_ref) / h + GRID_SNAP) + chunk
            t_chunk_end = min(t_stop, self.t_ref + k_end * h)
            k0 = math.ceil((t_start - self.t_ref) / h - GRID_SNAP)
            k1 = math.ceil((t_chunk_end - self.t_ref) / h - GRID_SNAP)
            if k0 < k1 and self.t_ref + k0 * h <= t_start + TIME_EPS:
                k0 += 1  # the start is that grid point: it is node 0 already
            if k0 < k1 and self.t_ref + (k1 - 1) * h >= t_chunk_end - TIME_EPS:
                k1 -= 1  # the end is that grid point: it is the last node
            # Nodes: the start, the interior grid points, the end.
            nodes = np.concatenate([[t_start], self.t_ref + np.arange(k0, k1) * h, [t_chunk_end]])
            U = self.chunk_inputs(nodes, k0, k1)
            steps = np.diff(nodes)
            D = step_input_derivatives(U[:-1], U[1:], steps, h)
            Z = np.empty((nodes.size, config.dim))
            Z[0] = z_start
            # A grid step's computed length differs from h by the rounding of t (an ulp of t
            # grows with it: beyond t ≈ 500 s, 1e-9·h alone sent every step through expm,
            # 7x slower; long runs, camsim.run.stream).
            full = np.abs(steps - h) <= max(1e-9 * h, 4.0 * float(np.spacing(abs(nodes[-1]))))
            # Steps are full except possibly the first and the last: runs of full steps go
            # through the cached maps, the others through an exact map of their own length.
            k = 0
            for p in [*np.flatnonzero(~full).tolist(), steps.size]:
                if p > k:
                    Z[k + 1 : p + 1] = maps.propagate(Z[k], D[k:p])
                if p < steps.size:
                    Z[p + 1] = exact_partial(config, Z[p], forcing_coefficients(config, D[p : p + 1])[0], steps[p])
                k = p + 1
            hit = self._first_crossing(config, guards, nodes, Z, U, D, first_chunk)
            if hit is not None:
                self._chunk = 512  # events come in clusters: look ahead a little after one
                t_event, z_event, guard, index = hit
                self.watch.linear_chunk(config, nodes, Z, U, D, t_cut=t_event, z_cut=z_event, index=index)
                keep = nodes[: index + 1]
                mask = self._on_grid(keep)
                if record:
                    collected_t.append(keep[mask])
                    collected_z.append(Z[: index + 1][mask])
                    collected_u.append(U[: index + 1][mask])
                end = self._state_from(config, z_event, t_event, state)
                return end, self._stretch(state, config, collected_t, collected_z, collected_u), guard
            self.watch.linear_chunk(config, nodes, Z, U, D)
            mask = self._on_grid(nodes[:-1])
            if record:
                collected_t.append(nodes[:-1][mask])
                collected_z.append(Z[:-1][mask])
                collected_u.append(U[:-1][mask])
            t_start, z_start = nodes[-1], Z[-1]
            first_chunk = False
            if t_start >= t_stop - TIME_EPS:
                end = self._state_from(config, z_start, t_stop, state)
                return end, self._stretch(state, config, collected_t, collected_z, collected_u), None
            chunk = min(chunk * 2, 16384)
            self._chunk = chunk

    def _on_grid(self, t: np.ndarray) -> np.ndarray:
        k = (t - self.t_ref) / self.h
        return np.abs(k - np.round(k)) < GRID_SNAP

    def _stretch(self, state, config, ts, zs, us) -> Stretch | None:
        if not ts:
            return None
        t = np.concatenate(ts)
        if t.size == 0:
            return None
        z = np.concatenate(zs)
        u = np.concatenate(us)
        fn = self.nonlinear_forces(config, z, u, state.v_impacts)
        return Stretch(state.branches, config, t, z, u, fn, dict(state.v_impacts))

    def _state_from(self, config: Configuration, z: np.ndarray, t: float, previous: State) -> State:
        u = self.inputs(np.array([t]))
        fn = self.nonlinear_forces(config, z[None, :], u, previous.v_impacts)
        x = config.x(z[None, :], u, fn)[0]
        v = config.v(z[None, :], u, fn)[0]
        return State(t, x, v, previous.branches, dict(previous.v_impacts))

    def nonlinear_forces(self, config: Configuration, z: np.ndarray, u: np.ndarray, v_impacts) -> np.ndarray:
        """Forces of closed power-law contacts on samples (N, p)."""
        if not config.power_contacts:
            return np.zeros((z.shape[0], 0))
        out = np.empty((z.shape[0], len(config.power_contacts)))
        for k, i in enumerate(config.power_contacts):
            delta, rate = self._delta(config, i)
            out[:, k] = self.model.power_force(i, delta(z, u)[:, 0], rate(z, u)[:, 0], v_impacts.get(i))
        return out

    # ------------------------------------------------------------------ crossings
    def _first_crossing(self, config, guards, nodes, Z, U, D, first_chunk):
        """Earliest guard crossing in the chunk: (t, z, guard, step index) or None."""
        if not guards:
            return None
        steps = np.diff(nodes)[:, None]
        # All guards at once: values and exact time derivatives at every node.
        if self._stacked is None or self._stacked[0] is not guards:
            self._stacked = (
                guards,
                np.vstack([g.value.Cz for g in guards]).T, np.vstack([g.value.Du for g in guards]).T,
                np.concatenate([g.value.e for g in guards]),
                np.vstack([g.rate.Cz for g in guards]).T, np.vstack([g.rate.Du for g in guards]).T,
                np.concatenate([g.rate.e for g in guards]),
                np.array([g.tol for g in guards]),
            )
        _, Cz, Du, e, Cz_d, Du_d, e_d, tol = self._stacked
        G = Z @ Cz + U @ Du + e
        Gd = Z @ Cz_d + U @ Du_d + e_d
        g0 = G[:-1].copy()
        g1 = G[1:]
        if first_chunk:
            now = np.flatnonzero(g0[0] < -tol)
            if now.size:
                return nodes[0], Z[0], guards[int(now[0])], 0
            just = np.abs(g0[0]) <= tol
            g0[0, just] = tol[just]  # just crossed: do not find it again
        d0 = Gd[:-1] * steps
        d1 = Gd[1:] * steps
        crossing = (g1 <= 0.0) & (g0 > 0.0)
        # A cubic Hermite interpolant stays above min(g0, g1) − 4/27·(|d0| + |d1|): only
        # the steps where that bound is not positive can hide a dip below zero.
        maybe = ~crossing & (np.minimum(g0, g1) - (4.0 / 27.0) * (np.abs(d0) + np.abs(d1)) <= 0.0)
        dip = np.zeros_like(crossing)
        if np.any(maybe):
            k_idx, j_idx = np.nonzero(maybe)
            a0, a1, b0, b1 = g0[k_idx, j_idx], g1[k_idx, j_idx], d0[k_idx, j_idx], d1[k_idx, j_idx]
            c2 = 3 * (a1 - a0) - 2 * b0 - b1
            c3 = 2 * (a0 - a1) + b0 + b1
            qa, qb, qc = 3 * c3, 2 * c2, b0
            disc = qb * qb - 4 * qa * qc
            found = np.zeros(k_idx.size, dtype=bool)
            with np.errstate(divide="ignore", invalid="ignore"):
                sq = np.sqrt(np.maximum(disc, 0.0))
                for sign in (-1.0, 1.0):
                    sig = np.where(np.abs(qa) > 1e-300, (-qb + sign * sq) / (2 * qa), -qc / qb)
                    ok = (disc >= 0) & (sig > 0) & (sig < 1) & np.isfinite(sig)
                    val = a0 + b0 * sig + c2 * sig**2 + c3 * sig**3
                    found |= ok & (val <= 0.0)
            dip[k_idx[found], j_idx[found]] = True
        candidates = []
        hits = crossing | dip
        for j, guard in enumerate(guards):
            for k in np.flatnonzero(hits[:, j])[:4]:  # the earliest few; false alarms are rare
                candidates.append((nodes[k], int(k), guard, "scan", (g0[k, j], g1[k, j], Gd[k, j], Gd[k + 1, j])))
        if not candidates:
            return None
        candidates.sort(key=lambda c: (c[0], c[1]))
        # Several guards may cross inside one step: every candidate of the earliest step
        # that holds a crossing is located and the earliest root wins (sorting by step
        # alone handled them in guard order; issue 25: a seat impact 8.6e-5 s before a
        # rider's inside one 10 kHz step was found only after it, as a penetration).
        best = None
        for t_k, k, guard, how, ends in candidates:
            if best is not None and k != best[3]:
                break
            Ek = forcing_coefficients(config, D[k : k + 1])[0]
            root = self._refine(config, guard, Z[k], D[k], Ek, float(steps[k, 0]), first_chunk and k == 0, ends)
            if root is not None:
                tau, z = root
                # issue 12 hook: polish on the analytic cam law to a 1e-10 s bracket; issue 25:
                # over the whole step on the exact state when the step's input polynomial
                # misplaced the root (None: no crossing in this step after all)
                z_k = Z[k]
                polished = polish_crossing(self, config, guard, nodes[k], float(steps[k, 0]), tau, z, D[k],
                                           state_at=lambda t, z_k=z_k, Ek=Ek: exact_partial(config, z_k, Ek, t) if t > 0 else z_k)
                if polished is None:
                    continue
                tau, z = polished
                if best is None or nodes[k] + tau < best[0]:
                    best = (nodes[k] + tau, z, guard, k)
        return best

    def _refine(self, config, guard, z0, Dk, Ek, hk, just_started, ends=None):
        """Locate the first root of the guard in one step on the exact solution.

        ``ends`` = (g0, g1, ġ0, ġ1), the exact guard values and rates at the step's ends,
        when known: a sign change then brackets the root, and the root of their cubic
        Hermite interpolant starts Newton's iteration one or two digits from the answer.
        """

        def evaluate(tau):
            z = exact_partial(config, z0, Ek, tau) if tau > 0 else z0
            u = input_at(Dk, tau)
            g = guard.value(z[None, :], u[None, :])[0, 0]
            gd = guard.rate(z[None, :], u[None, :])[0, 0]
            return g, gd, z

        lo = hi = None
        if ends is not None:
            g0, g1, d0, d1 = ends
            if just_started:
                g0 = max(g0, guard.tol)
            if g0 > 0 and g1 <= 0:
                sigma = _cubic_root(g0, g1, d0 * hk, d1 * hk)
                lo = (0.0, g0, d0, z0)
                hi = (hk, g1, d1, None)
                return self._newton(evaluate, lo, hi, sigma * hk, hk)
        samples = np.linspace(0.0, hk, 9)
        values = []
        for tau in samples:
            g, gd, z = evaluate(tau)
            values.append((tau, g, gd, z))
        if just_started:
            values[0] = (0.0, max(values[0][1], guard.tol), values[0][2], values[0][3])
        for a, b in zip(values[:-1], values[1:]):
            if a[1] > 0 and b[1] <= 0:
                lo, hi = a, b
                break
        if lo is None:
            # Grazing dip: look for the minimum of the exact guard (where its exact rate
            # changes sign), stopping as soon as the guard is seen at or below zero.
            dip = self._dip(evaluate, values, hk)
            if dip is None:
                return None
            t_min = dip[0]
            left = [v for v in values if v[0] < t_min and v[1] > 0]
            if not left:
                return None
            lo, hi = left[-1], dip
        a_t, a_g = lo[0], lo[1]
        b_t, b_g = hi[0], hi[1]
        guess = b_t - b_g * (b_t - a_t) / (b_g - a_g) if b_g != a_g else 0.5 * (a_t + b_t)
        return self._newton(evaluate, lo, hi, guess, hk)

    @staticmethod
    def _dip(evaluate, values, hk):
        """A point where the guard is ≤ 0 near its smallest sample, or None if it stays > 0.

        ``values`` are (τ, g, ġ, z) samples across the step; the minimum lies where ġ turns
        from negative to positive. Bisection on the sign of the exact ġ, to 1e-10 of the step.
        """
        k = min(range(len(values)), key=lambda i: values[i][1])
        a = values[max(k - 1, 0)]
        b = values[min(k + 1, len(values) - 1)]
        if a[2] >= 0 or b[2] <= 0:  # no interior minimum between the neighbours
            return values[k] if values[k][1] <= 0 else None
        lo_t, hi_t = a[0], b[0]
        while hi_t - lo_t > DIP_RESOLUTION * hk:
            mid = 0.5 * (lo_t + hi_t)
            g, gd, z = evaluate(mid)
            if g <= 0:
                return (mid, g, gd, z)
            if gd < 0:
                lo_t = mid
            else:
                hi_t = mid
        return None

    @staticmethod
    def _newton(evaluate, lo, hi, t, hk):
        """Safeguarded Newton between lo (g > 0) and hi (g ≤ 0) on the exact guard.

        Returns the instant where the guard is zero to rounding, and the state there.
        """
        a_t = lo[0]
        b_t = hi[0]
        z = lo[3]
        if not (a_t < t < b_t):
            t = 0.5 * (a_t + b_t)
        for _ in range(60):
            g, gd, z = evaluate(t)
            if g > 0:
                a_t = t
            else:
                b_t = t
            if g == 0 or b_t - a_t <= ROOT_BRACKET:
                break
            t_new = t - g / gd if gd != 0 else 0.5 * (a_t + b_t)
            if not (a_t < t_new < b_t):
                t_new = 0.5 * (a_t + b_t)
            if abs(t_new - t) <= 1e-16 + 1e-15 * hk:
                t = t_new
                g, gd, z = evaluate(t)
                break
            t = t_new
        return t, z

    @staticmethod
    def nonlinear_atol(dim: int) -> np.ndarray:
        """Absolute tolerances of a nonlinear phase's state: 1e-13 m on the positions,
        1e-10 m/s on the velocities (DOP853's, and the collocation's local-error test)."""
        return np.concatenate([np.full(dim // 2, 1e-13), np.full(dim // 2, 1e-10)])

    def dop853_max_step(self) -> float:
        """Largest DOP853 step of a nonlinear phase [s] (four grid steps)."""
        return max(self.h * 4, 1e-6)

    def dop853_span(self, rhs, z0, t0: float, t_stop: float, guards, cam_input, solver=None, forces=None):
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
            solver = DOP853(rhs, t0, z0, t_stop, rtol=self.rtol_nonlinear, atol=self.nonlinear_atol(z0.size),
                            max_step=self.dop853_max_step())
        grid = self.grid_between(t0, t_stop)
        Z = np.empty((grid.size, z0.size))
        done = 0  # grid points filled
        if grid.size and grid[0] <= t0:
            Z[0] = z0
            done = 1
        g_old = linear_part(t0, z0) + ge if events else None
        fired = None
        eps = np.finfo(float).eps
        analytic = self.cam if self.cam is not None and hasattr(self.cam, "svaj") else None
        while True:
            message = solver.step()
            if solver.status == "failed":
                raise SimulationError(f"nonlinear contact phase failed at t = {solver.t:.9g} s: {message}")
            t_old, t_new, z_new = solver.t_old, solver.t, solver.y
            dense = None
            t_end, z_end = t_new, z_new
            if events:
                g_new = linear_part(t_new, z_new) + ge
                # a crossing downwards (solve_ivp's test)
                for k in np.flatnonzero((g_old >= 0.0) & (g_new <= 0.0)).tolist():
                    if dense is None:
                        dense = solver.dense_output()
                    if Gf is not None and np.any(Gf[k]):
                        guard_k = (lambda t, k=k: float(Gz[k] @ dense(t) + Gu[k] @ cam_input(t)
                                                        + Gf[k] @ forces(t, dense(t))) + ge[k])
                    else:
                        guard_k = _guard_on_step(dense, cam_input, Gz[k], Gu[k], float(ge[k]))
                    root = brentq(guard_k, t_old, t_new, xtol=4 * eps, rtol=4 * eps)
                    if analytic is not None and np.any(Gu[k, 2:]):
                        # The guard reads s̈ (a stuck rigid contact's force): located again
                        # with the cam law itself, not the step polynomials of cam_input,
                        # whose s̈ inside a short grid step carries the rounding of s
                        # amplified by ~1/h² (issue 25; 2.9e-8 s at 500 kHz).
                        def guard_law(t, k=k):
                            z_t = dense(t)
                            value = Gz[k] @ z_t + Gu[k] @ analytic_input(self.cam, t, t_stop) + ge[k]
                            return float(value + Gf[k] @ forces(t, z_t)) if Gf is not None else float(value)

                        better = root_near(guard_law, t_old, t_new, root)
                        if better is not None:
                            root = better
                    if root > t0 + TIME_EPS and (fired is None or root < t_end):
                        fired, t_end = guards[k], root
                g_old = g_new
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
    def _advance_nonlinear(self, state, config, z0, guards, t_stop, record):
        v_imp = state.v_impacts
        cam_input = _StepInput(self, state.t, t_stop)
        contacts = []
        for i in config.power_contacts:
            delta, rate = self._delta(config, i)
            contacts.append((i, delta.Cz[0], delta.Du[0], float(delta.e[0]), rate.Cz[0], rate.Du[0], float(rate.e[0])))
        A, B, b, L = config.A, config.B, config.b, config.L
        fn = np.zeros(len(contacts))
        force_of = [self.model.elements[i].nonlinear_force_scalar for i in config.power_contacts]

        def rhs(t, z):
            u = cam_input(t)
            for k, (i, dcz, ddu, de, rcz, rdu, re) in enumerate(contacts):
                delta = dcz @ z + ddu @ u + de
                rate = rcz @ z + rdu @ u + re
                fn[k] = force_of[k](delta, rate, v_imp.get(i))
            return A @ z + B @ u + b + L @ fn

        t0 = state.t
        def forces(t, z):
            u = cam_input(t)
            out = np.empty(len(contacts))
            for k, (i, dcz, ddu, de, rcz, rdu, re) in enumerate(contacts):
                out[k] = force_of[k](dcz @ z + ddu @ u + de, rcz @ z + rdu @ u + re, v_imp.get(i))
            return out

        grid, Zs, z_end, fired, t_end = self.dop853_span(rhs, z0, t0, t_stop, guards, cam_input, forces=forces)
        stretch = None
        if record and grid.size:
            Us = self.inputs(grid)
            fn = self.nonlinear_forces(config, Zs, Us, v_imp)
            stretch = Stretch(state.branches, config, grid, Zs, Us, fn, dict(v_imp))
        end = self._state_from(config, z_end, t_end, state)
        return end, stretch, fired

    # ------------------------------------------------------------------ events
    def relative_rate(self, state: State, i: int) -> tuple[float, float]:
        """(δ, δ̇) of element i at a full state."""
        geo = self.model.geometry[i]
        u = self.inputs(np.array([state.t]))[0]
        d = state.x @ geo.G + geo.g_s * u[0]
        dd = state.v @ geo.G + geo.g_s * u[1]
        return self.model.elements[i].penetration(d), -dd

    def handle(self, state: State, guard: Guard) -> State:
        """Apply the event of ``guard`` at ``state``; returns the state after it."""
        if abs(state.t - self._instant_time) <= INSTANT_TIME:
            self._instant_count += 1
            if self._instant_count > MAX_EVENTS_PER_INSTANT:
                raise ZenoError(
                    f"events pile up at t = {state.t:.12g} s on element "
                    f"{self.model.elements[guard.element].name} without resolving (chatter)"
                )
        else:
            self._instant_time = state.t
            self._instant_count = 0
        model = self.model
        i = guard.element
        pos = model.switching.index(i)
        branches = list(state.branches)
        v_imp = dict(state.v_impacts)
        if guard.kind != GuardKind.UNLIFT and Branch.STUCK in model.branch_options(i):
            return resolve_rigid(self, state, i, guard.kind)  # issue 12 hook: rigid contacts as one LCP
        _, rate = self.relative_rate(state, i)
        d = float(model.deflection(i, state.x, self.inputs(np.array([state.t]))[0, 0]))
        outcome = model.elements[i].outcome_at(guard.kind, rate, d)  # issue 12 hook: two-sided elements
        if outcome.event is not None:
            self._record(state.t, i, outcome.event, outcome.velocity)
        if outcome.branch is not None:
            branches[pos] = outcome.branch
        if outcome.v_impact is not None:
            v_imp[i] = outcome.v_impact
        return State(state.t, state.x.copy(), state.v.copy(), tuple(branches), v_imp)

    def _record(self, t: float, i: int, kind: EventKind, relative_velocity: float) -> None:
        element = self.model.elements[i]
        self.events.append(
            Event(
                time=t, element=element.name, kind=kind, relative_velocity=float(relative_velocity),
                masses=f"{element.lower}/{element.upper}", element_index=i,
            )
        )

    def violated(self, state: State) -> Guard | None:
        """A guard of the state's configuration that is already violated, if any."""
        config = self.model.configuration(state.branches)
        u = self.inputs(np.array([state.t]))
        z = config.state_from_full(state.x, state.v, u[0, 0], u[0, 1])
        fn = self.nonlinear_forces(config, z[None, :], u, state.v_impacts)
        for guard in self.guards(state, config):
            if guard.kind == GuardKind.UNLIFT:
                continue
            if guard.value(z[None, :], u, fn)[0, 0] < -guard.tol:
                return guard
        return None

    def settle(self, state: State) -> State:
        """Resolve every guard violated at one instant (cascading events)."""
        for _ in range(MAX_EVENTS_PER_INSTANT):
            guard = self.violated(state)
            if guard is None:
                return state
            state = self.handle(state, guard)
        raise ZenoError(f"cannot find a consistent contact state at t = {state.t:.12g} s")

    # ------------------------------------------------------------------ driver
    def run(self, state: State, t_end: float, record_from: float, stops: tuple[float, ...] = (), on_stop=None, progress=None,
            on_stretch=None):
        """Integrate from ``state`` to ``t_end``; return the stretches recorded from ``record_from``.

        ``stops`` are extra times at which integration halts (``on_stop(state)`` is called),
        e.g. the start of a cycle for the periodicity residual.

        ``on_stretch(stretch, t)``, when given, receives each recorded stretch instead of the
        returned list (which stays empty: memory does not grow with the run), called once
        every event up to ``t`` [s] (the stretch's end) is in :attr:`events`; later events
        and later stretches' samples all lie at or after ``t`` (camsim.run.stream). The consumer
        may remove the events it has read from :attr:`events` (the integrator only appends).
        """
        stretches: list[Stretch] = []
        state = self.settle(state)
        if on_stop and any(abs(s - state.t) <= TIME_EPS for s in stops):
            on_stop(state)
        joins = [float(t) for t in self.cam.boundary_times(state.t - self.h, t_end + self.h)]
        self._joins = set(joins)
        self._join_array = sorted(joins)
        joins = [t for t in joins if state.t < t < t_end]
        boundaries = joins + [s for s in stops if state.t < s < t_end]
        boundaries = sorted(set(boundaries)) + [t_end]
        bi = 0
        max_stretches = 10_000_000
        count = 0
        while state.t < t_end - TIME_EPS:
            while bi < len(boundaries) and boundaries[bi] <= state.t + TIME_EPS:
                if on_stop and boundaries[bi] in stops and abs(boundaries[bi] - state.t) <= TIME_EPS:
                    on_stop(state)
                bi += 1
            t_stop = boundaries[bi] if bi < len(boundaries) else t_end
            record = t_stop > record_from - TIME_EPS
            new_state, stretch, guard = self.advance(state, t_stop, record)
            kept = None
            if stretch is not None:
                keep = stretch.t >= record_from - GRID_SNAP * self.h
                if np.any(keep):
                    kept = Stretch(stretch.branches, stretch.config, stretch.t[keep], stretch.z[keep], stretch.u[keep], stretch.fn[keep], stretch.v_impacts)
                    if on_stretch is None:
                        stretches.append(kept)
            if not np.all(np.isfinite(new_state.x)) or not np.all(np.isfinite(new_state.v)):
                raise SimulationError(f"the run diverged before t = {new_state.t:.9g} s (non-finite state)")
            state = new_state
            if guard is not None:
                state = self.handle(state, guard)
                state = self.settle(state)
            if on_stretch is not None and kept is not None:  # streaming hook (camsim.run.stream)
                on_stretch(kept, state.t)
            if progress is not None:
                progress(state.t)
            count += 1
            if count > max_stretches:
                raise ZenoError("too many events; the run does not progress")
        if on_stop and any(abs(s - t_end) <= TIME_EPS for s in stops):
            on_stop(state)
        return state, stretches

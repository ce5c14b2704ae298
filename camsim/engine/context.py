"""The engine's shared context: cam input, grid, step maps, guards, forces, the event list.

Every way of advancing a configuration (:mod:`camsim.engine.linear`,
:mod:`camsim.engine.nonlinear`, :mod:`camsim.engine.rk`) and every event handler
(:mod:`camsim.engine.rigid`, :mod:`camsim.engine.watch`) works on an
:class:`EngineContext`; the event loop on top (:class:`camsim.engine.integrator.Integrator`)
is one. The cam input u — [s, ṡ, s̈, s⃛] of every cam, cam by cam
(:mod:`camsim.elements.affine`) — is evaluated once per grid block and cached; single
instants come from the cam laws in floats (``channels_at``). The engine knows input
channels only: which cam is which, and how a cam's motion is made, is the cam program's
business (``channels(t, side)``, ``channels_at(t, side)``, ``break_times(t0, t1)``).
"""

from __future__ import annotations

import bisect
import math
import weakref

import numpy as np

from camsim.elements import Branch
from camsim.elements.affine import N_INPUT, Affine, shift_rate
from camsim.elements.events import Event, EventKind
from camsim.model.assembly import Configuration, Model
from camsim.engine.state import TIME_EPS, Guard, State, Stretch
from camsim.engine.stepping import StepMaps

#: A time within this fraction of the grid step of a grid point is that grid point: grid
#: times are t_ref + k·h computed from k, so only rounding (~1e-16·k) separates them.
GRID_SNAP = 1e-7


class _GuardContext:
    """What an element needs to state its guards in one configuration at one state."""

    def __init__(self, integrator: "EngineContext", config: Configuration, state: State, index: int):
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

    def normal_force(self) -> Affine:
        """A friction pair's programmed normal force N(t) as an affine map (its input column)."""
        integ = self.integrator
        du = np.zeros((1, integ.n_input))
        du[0, integ.model.normal_column(self.index)] = 1.0
        p = len(self.config.power_contacts)
        return Affine(np.zeros((1, self.config.dim)), du, np.zeros((1, p)), np.zeros(1))

    def constraint_force(self) -> Affine:
        """The compressive force of a constraint (a stuck rigid contact) as an affine map."""
        k = self.config.stuck_contacts.index(self.index)
        return self.config.lam.rows(slice(k, k + 1))

    def now(self, value: Affine) -> float:
        """An affine map evaluated at the current state."""
        integ = self.integrator
        z = self.config.state_from_input(self.state.x, self.state.v, integ.inputs(np.array([self.state.t]))[0])
        u = integ.inputs(np.array([self.state.t]))
        return float(value(z[None, :], u)[0, 0])


#: Per engine input object (a cam program shared by a worker's runs,
#: :func:`camsim.cam.camshaft.shared_program`), stores of what the engine reads of it at
#: fixed times: the cam input on a grid t_ref + k·h per block of :attr:`EngineContext._BLOCK`
#: points, and at the cam's break times. Weak keys: a run's own input object takes its
#: stores with it.
_INPUT_STORES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
#: Stores kept per input object, the least recently asked for dropped first (a study's
#: recording grid, its breaks and scales, and each design's warm-up grid, whose step follows
#: the design's highest natural frequency; a grid's store keeps at most 65 blocks of 128 kB per
#: cam: 8 MB).
_STORES_PER_INPUT = 6


def input_store(cam, key: tuple) -> dict:
    """The store ``key`` of the engine input ``cam``: the same dict for every run of this
    process on that input (issue 42: a study's runs share their cam, and each evaluated its
    laws on the same grid and at the same breaks again). What is stored is what ``cam``
    returns for those times, so a run reads the same bits either way."""
    try:
        stores = _INPUT_STORES.get(cam)
    except TypeError:  # an input that cannot be weakly referenced: a store of the run's own
        return {}
    if stores is None:
        stores = _INPUT_STORES[cam] = {}
    store = stores.pop(key, None)
    if store is None:
        store = {}
        while len(stores) >= _STORES_PER_INPUT:
            stores.pop(next(iter(stores)))  # the least recently asked for (a design's own warm-up grid)
    stores[key] = store  # the most recent last
    return store


class EngineContext:
    """What every stepper shares: the model, the cam input, the grid, the caches, the events.

    The event loop (:class:`camsim.engine.integrator.Integrator`) is an ``EngineContext``
    that also drives the steppers; a stepper receives the context and never imports the
    driver (the layout of ``scipy.integrate._ivp``: ``common`` under the methods under
    ``ivp``).

    Parameters
    ----------
    model : Model
    cam : CamProgram or a camshaft input
        Provides ``channels(t, side)`` — the cam input at times t, (N, 4·c) — and
        ``break_times(t0, t1)`` (where any cam's motion is not smooth).
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
        #: Columns of the cam input (four per cam).
        self.n_input = model.n_input
        self.h = step
        self.t_ref = t_ref
        self.events: list[Event] = []
        self._maps: dict[tuple[Branch, ...], StepMaps] = {}
        self._held_maps: dict = {}  # (branches, holds) -> StepMaps (stuck friction pairs)
        self._deltas: dict[tuple[tuple[Branch, ...], int], tuple[Affine, Affine]] = {}
        self._instant_count = 0
        self._instant_time = -math.inf
        #: DOP853's relative tolerance in a closed nonlinear contact (see camsim.engine.nonlinear.RTOL).
        self.rtol_nonlinear = 3e-13
        self._chunk = 512
        #: The period of the input [s] (a cam's revolution), or None: events of one period
        #: predict the next period's (chunk_steps).
        self.period: float | None = None
        self._predicted: list[float] = []  # one period after each event that ended a stretch [s], ascending
        self._noted_since: float | None = None  # events are noted from this time on [s]
        self._input_cache: dict[float, np.ndarray] = {}
        self._grid_cache = input_store(cam, ("grid", float(t_ref), float(step)))  # cam input on the grid, per block
        self._break_cache = input_store(cam, ("breaks",))  # cam input at each break time, both limits
        self._join_array: list[float] | None = None  # sorted cam joins of the current run
        self._joins: set[float] = set()  # cam segment joins of the current run
        self._stacked = None  # the current stretch's guards stacked into matrices
        self._guard_cache: dict = {}  # (branches, guard keys) -> the guards (EngineContext.guards)

    # ------------------------------------------------------------------ inputs
    def inputs(self, t: np.ndarray) -> np.ndarray:
        """The cam input at times t: (N, 4·c). A single instant comes from the cam laws in
        floats (:meth:`channels_at`, microseconds) and is cached (events ask repeatedly)."""
        t = np.asarray(t, dtype=float)
        if t.size == 1:
            key = float(t.reshape(-1)[0])
            hit = self._input_cache.get(key)
            if hit is None:
                hit = self.cam.channels_at(key)[None, :]
                if len(self._input_cache) > 64:
                    self._input_cache.clear()
                self._input_cache[key] = hit
            return hit.copy()
        return self.cam.channels(t)

    def input_left(self, t: float) -> np.ndarray:
        """The cam input at one instant, the limit from the left (a stretch's end, which may
        be a cam break): (4·c,), from the cam laws."""
        return self.cam.channels_at(float(t), side="left")

    def breaks_between(self, t0: float, t1: float) -> list[float]:
        """The cam's break times (joins, inner kinks) in (t0, t1) of the current run, each more
        than :data:`~camsim.engine.state.TIME_EPS` from both ends, ascending."""
        joins = self._join_array
        if not joins:
            return []
        i = bisect.bisect_right(joins, t0 + TIME_EPS)
        j = bisect.bisect_left(joins, t1 - TIME_EPS)
        return joins[i:j]

    def analytic_inputs(self, t: float) -> np.ndarray:
        """The cam input at one instant from the cam laws (the limit from the right at a
        join): (4·c,)."""
        return self.cam.channels_at(float(t))

    def analytic_inputs_at(self, t: np.ndarray, step_end) -> np.ndarray:
        """The input channels ([s, ṡ, s̈, s⃛] per cam) at times t from the cam laws:
        (N, 4·c); a time at or past ``step_end`` (a float, or one per time) takes the limit
        from the left (the end of a stretch may be a cam segment join)."""
        t = np.asarray(t, dtype=float)
        right = t < step_end
        out = np.empty((t.size, self.n_input))
        for side, mask in (("right", right), ("left", ~right)):
            if np.any(mask):
                out[mask] = self.cam.channels(t[mask], side=side)
        return out

    def chunk_nodes(self, t_start: float, t_end: float) -> tuple[np.ndarray, np.ndarray, list[int], bool]:
        """The nodes of a chunk of the grid and the cam input there.

        Nodes: its start, the grid points strictly between, its end; each cam break
        strictly between is a node pair (the limits from the left and from the right, a
        step of length zero) that replaces a grid point within :data:`GRID_SNAP` of it.

        Returns
        -------
        (ndarray, ndarray, list of int, bool)
            Node times (N,), the cam input (N, 4·c), the index of each break's left node,
            and whether the chunk ends on a break (its last input is then the limit from
            the left, and the next chunk starts on the break's right side).
        """
        h = self.h
        k0 = math.ceil((t_start - self.t_ref) / h - GRID_SNAP)
        k1 = math.ceil((t_end - self.t_ref) / h - GRID_SNAP)
        if k0 < k1 and self.t_ref + k0 * h <= t_start + TIME_EPS:
            k0 += 1  # the start is that grid point: it is node 0 already
        if k0 < k1 and self.t_ref + (k1 - 1) * h >= t_end - TIME_EPS:
            k1 -= 1  # the end is that grid point: it is the last node
        grid = self.t_ref + np.arange(k0, k1) * h
        nodes = np.concatenate([[t_start], grid, [t_end]])
        U = self.chunk_inputs(nodes, k0, k1)
        at_break = t_end in self._joins
        breaks = self.breaks_between(t_start, t_end)
        if not breaks:
            return nodes, U, [], at_break
        # each break replaces the grid point it falls on (its right node is that sample)
        for b in breaks:
            near = np.flatnonzero(np.abs(nodes[1:-1] - b) <= GRID_SNAP * h) + 1
            if near.size:
                nodes = np.delete(nodes, near)
                U = np.delete(U, near, axis=0)
        at = np.searchsorted(nodes, breaks, side="left")
        pair_u = [self._break_input(b) for b in breaks]
        t_parts, u_parts, pairs, prev = [], [], [], 0
        for b, i, uu in zip(breaks, at.tolist(), pair_u):
            t_parts += [nodes[prev:i], np.array([b, b])]
            u_parts += [U[prev:i], uu]
            pairs.append(sum(part.size for part in t_parts) - 2)
            prev = i
        t_parts.append(nodes[prev:])
        u_parts.append(U[prev:])
        return np.concatenate(t_parts), np.concatenate(u_parts), pairs, at_break

    def _break_input(self, b: float) -> np.ndarray:
        """The cam input's limits from the left and from the right at a break time: (2, 4·c),
        kept in the input's store of breaks (a break is at the same time in every run on the
        same cam)."""
        hit = self._break_cache.get(b)
        if hit is None:
            hit = np.stack([self.cam.channels_at(b, side="left"), self.cam.channels_at(b, side="right")])
            if len(self._break_cache) > 4096:
                self._break_cache.clear()
            self._break_cache[b] = hit
        return hit

    # ------------------------------------------------------------------ chunk sizes
    def note_event(self, t: float) -> None:
        """An event ended a stretch at t [s]: one period later it predicts the next (chunk_steps)."""
        if self.period is None:
            return
        self._predicted.append(t + self.period)  # in time order: the run goes forwards
        if len(self._predicted) > 4096 and self._predicted[0] < t - self.period:
            del self._predicted[: bisect.bisect_left(self._predicted, t - self.period)]

    def noting_from(self, t: float) -> None:
        """Events are noted from t [s] on (a run's start): a period later they predict."""
        if self._noted_since is None:
            self._noted_since = t

    def predict_from(self, other: "EngineContext") -> None:
        """Take ``other``'s predictions (a warm-up's, for the recording that continues it)."""
        if self.period is not None and other.period == self.period and other._noted_since is not None:
            self._predicted = list(other._predicted)
            self._noted_since = other._noted_since

    def chunk_steps(self, t_start: float) -> int | None:
        """Grid steps for a chunk from ``t_start`` that ends a little past the next event
        predicted by the events one period earlier, or None without a prediction.

        A chunk is one pass of numpy work whatever its length, and the steps computed past
        an event are thrown away: after an event the next one is looked for in a chunk
        sized to reach it (the events of a periodic machine recur every revolution, within
        the transient's drift), where doubling from 512 steps took four chunks and half a
        chunk's waste to cross a gap of 4,000 steps. Where no event comes in the predicted
        chunk, the next ones double from its length (at least 512 steps) as before: a
        prediction only ever moves the chunks' ends, and every step is screened whatever
        they are."""
        if self.period is None or self._noted_since is None or t_start < self._noted_since + self.period:
            return None  # the period before is not all seen: an event may come before any predicted
        i = bisect.bisect_right(self._predicted, t_start + 0.5 * self.h)
        if i == len(self._predicted):
            return None
        steps = (self._predicted[i] - t_start) / self.h
        if steps > 16384:
            return None
        return int(max(math.ceil(steps) + 8 + int(steps) // 64, 16))

    def chunk_inputs(self, nodes: np.ndarray, k0: int, k1: int) -> np.ndarray:
        """Cam input at a chunk's nodes: its start, grid points k0 ≤ k < k1, its end.

        The last step ends at the chunk's end, maybe a cam segment join: its end values are
        the limits from the left there (acceleration or jerk may jump).
        """
        U = np.empty((nodes.size, self.n_input))
        U[0] = self._node_input(float(nodes[0]))
        U[1:-1] = self._grid_inputs(k0, k1)
        U[-1] = self._node_input(float(nodes[-1]))
        if nodes[-1] in self._joins:
            U[-1] = self._break_input(float(nodes[-1]))[0]
        return U

    def _node_input(self, t: float) -> np.ndarray:
        """Cam input at a chunk's first or last node: the cached grid value when the node
        is a grid point (so a sample's value never depends on where a stretch began)."""
        k = round((t - self.t_ref) / self.h)
        if abs(self.t_ref + k * self.h - t) <= TIME_EPS:
            return self._grid_inputs(k, k + 1)[0]
        return self.inputs(np.array([t]))[0]

    def _grid_inputs(self, k0: int, k1: int) -> np.ndarray:
        """Cam input at grid points k0 ≤ k < k1: (k1 − k0, 4·c), from blocks evaluated once."""
        out = np.empty((max(k1 - k0, 0), self.n_input))
        block = self._BLOCK
        k = k0
        while k < k1:
            b = k // block
            values = self._grid_cache.get(b)
            if values is None:
                t = self.t_ref + np.arange(b * block, (b + 1) * block) * self.h
                values = self.cam.channels(t)
                if len(self._grid_cache) > 64:
                    self._grid_cache.clear()
                self._grid_cache[b] = values
            stop = min(k1, (b + 1) * block)
            out[k - k0 : stop - k0] = values[k - b * block : stop - b * block]
            k = stop
        return out

    def maps(self, config: Configuration) -> StepMaps:
        if config.holds:
            # a stuck friction pair's hold moves only the constant term b: the maps of its
            # branches with that term replaced (no matrix exponential per stick)
            maps = self._held_maps.get(config.key)
            if maps is None:
                maps = self.maps(self.model.configuration(config.branches)).with_constant(config)
                if len(self._held_maps) > 1024:
                    self._held_maps.clear()
                self._held_maps[config.key] = maps
            return maps
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
        cams = N_INPUT * geo.g_s.size  # the cams' channels (the loads' follow them: no deflection)
        du = np.zeros((1, self.n_input))
        du[0, 0:cams:N_INPUT] = geo.g_s
        d = Affine.combine([(G, config.x)], const=np.zeros(1), du=du)
        du = np.zeros((1, self.n_input))
        du[0, 1:cams:N_INPUT] = geo.g_s
        rate = Affine.combine([(G, config.v)], const=np.zeros(1), du=du)
        return d, rate

    def _delta(self, config: Configuration, i: int) -> tuple[Affine, Affine]:
        """Penetration δ = gap − d of contact i and its rate δ̇, as affine maps (built once
        per configuration and contact: every sample of a closed power-law contact's force
        reads them)."""
        key = (config.key, i)
        hit = self._deltas.get(key)
        if hit is None:
            d, rate = self._deflection(config, i)
            sign, gap = self.model.elements[i].contact_side(self.model.branch_of(config.branches, i))
            if sign < 0:  # the upper side of a two-sided element: δ = d − gap (issue 12 hook)
                hit = Affine(d.Cz, d.Du, d.Fn, d.e - gap), rate
            else:
                hit = Affine(-d.Cz, -d.Du, -d.Fn, gap - d.e), Affine(-rate.Cz, -rate.Du, -rate.Fn, -rate.e)
            if len(self._deltas) > 4096:
                self._deltas.clear()
            self._deltas[key] = hit
        return hit

    def guards(self, state: State, config: Configuration) -> list[Guard]:
        """Guards of the configuration at ``state``, as each element declares them; kept per
        configuration and what else they read (:meth:`~camsim.elements.base.Element.guard_key`),
        so a configuration entered again reuses its guards and their stacked matrices."""
        model = self.model
        contexts = [_GuardContext(self, config, state, i) for i in model.switching]
        key = (config.key, tuple(model.elements[i].guard_key(state.branches[pos], c)
                                      for pos, (i, c) in enumerate(zip(model.switching, contexts))))
        hit = self._guard_cache.get(key)
        if hit is not None:
            return hit
        out: list[Guard] = []
        for pos, (i, context) in enumerate(zip(model.switching, contexts)):
            for kind, value, tol in model.elements[i].guards(state.branches[pos], context):
                out.append(Guard(i, kind, value, tol))
        if config.linear:
            for guard in out:
                guard.rate = self._rate(config, guard.value)
        if len(self._guard_cache) > 4096:
            self._guard_cache.clear()
        self._guard_cache[key] = out
        return out

    def stacked_guards(self, guards: list[Guard]):
        """Every guard's value and rate as one matrix each: (Cz (m, g), Du (4·c, g), e (g,),
        the rate's, tolerances (g,)); kept with the guard list (linear configurations)."""
        if self._stacked is None or self._stacked[0] is not guards:
            self._stacked = (
                guards,
                np.vstack([g.value.Cz for g in guards]).T, np.vstack([g.value.Du for g in guards]).T,
                np.concatenate([g.value.e for g in guards]),
                np.vstack([g.rate.Cz for g in guards]).T, np.vstack([g.rate.Du for g in guards]).T,
                np.concatenate([g.rate.e for g in guards]),
                np.array([g.tol for g in guards]),
            )
        return self._stacked[1:]

    @staticmethod
    def guard_rate(config: Configuration, guard: Guard, z: np.ndarray, u: np.ndarray, fn: np.ndarray) -> float:
        """ġ of a guard at one state (z: (m,), u: (1, 4), fn: (1, p)); NaN where it is not
        known: a guard of a nonlinear configuration that reads the nonlinear forces or the jerk."""
        if guard.rate is not None:
            return float(guard.rate(z[None, :], u)[0, 0])
        g = guard.value
        if np.any(g.Fn) or np.any(g.Du[:, -1]):
            return math.nan
        zdot = config.A @ z + config.B @ u[0] + config.b + config.L @ fn[0]
        return float((g.Cz @ zdot + g.Du[:, :-1] @ u[0, 1:])[0])

    @staticmethod
    def _rate(config: Configuration, g: Affine) -> Affine:
        """d/dt of an affine guard in a linear configuration."""
        Du = g.Cz @ config.B
        shift_rate(g.Du, Du)
        return Affine(g.Cz @ config.A, Du, np.zeros_like(g.Fn), g.Cz @ config.b)

    # ------------------------------------------------------------------ grid helpers
    def grid_between(self, t0: float, t1: float) -> np.ndarray:
        """Grid points in [t0, t1) (tolerant to rounding)."""
        k0 = math.ceil((t0 - self.t_ref) / self.h - GRID_SNAP)
        k1 = math.ceil((t1 - self.t_ref) / self.h - GRID_SNAP)
        if k1 <= k0:
            return np.zeros(0)
        return self.t_ref + np.arange(k0, k1) * self.h

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
        return State(t, x, v, previous.branches, dict(previous.v_impacts), previous.holds)

    def nonlinear_forces(self, config: Configuration, z: np.ndarray, u: np.ndarray, v_impacts) -> np.ndarray:
        """Forces of closed power-law contacts on samples (N, p)."""
        if not config.power_contacts:
            return np.zeros((z.shape[0], 0))
        out = np.empty((z.shape[0], len(config.power_contacts)))
        for k, i in enumerate(config.power_contacts):
            delta, rate = self._delta(config, i)
            out[:, k] = self.model.power_force(i, config.branches, delta(z, u)[:, 0], rate(z, u)[:, 0],
                                               v_impacts.get(i))
        return out

    @staticmethod
    def nonlinear_atol(dim: int) -> np.ndarray:
        """Absolute tolerances of a nonlinear phase's state: 3e-15 m on the positions,
        3e-12 m/s on the velocities (DOP853's, and the collocation's local-error test)."""
        return np.concatenate([np.full(dim // 2, 3e-15), np.full(dim // 2, 3e-12)])

    def dop853_max_step(self) -> float:
        """Largest DOP853 step of a nonlinear phase [s] (four grid steps)."""
        return max(self.h * 4, 1e-6)

    def relative_rate(self, state: State, i: int) -> tuple[float, float]:
        """(δ, δ̇) of element i at a full state."""
        geo = self.model.geometry[i]
        u = self.inputs(np.array([state.t]))[0]
        d = state.x @ geo.G + geo.cam_term(u[0::N_INPUT])
        dd = state.v @ geo.G + geo.cam_term(u[1::N_INPUT])
        return self.model.elements[i].penetration(d), -dd

    def _record(self, t: float, i: int, kind: EventKind, relative_velocity: float, branch=None) -> None:
        element = self.model.elements[i]
        self.events.append(
            Event(
                time=t, element=element.name, kind=kind, relative_velocity=float(relative_velocity),
                masses=f"{element.lower}/{element.upper}", element_index=i, branch=branch,
            )
        )


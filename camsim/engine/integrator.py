"""The event loop: the driver on top of the steppers, exact between events.

Between events one configuration (a branch per switching element) is advanced by the
stepper that applies to it (:data:`STEPPERS`, the first whose ``applies`` holds: the exact
linear stepper, the exponential stepper of one closed nonlinear contact, DOP853 for the
rest), which stops at the first guard crossing located on its solution. The driver then
applies the event (:meth:`Integrator.handle`: the element's outcome, or the rigid contacts'
complementarity problem of :mod:`camsim.engine.rigid`), settles every guard violated at
that instant, and goes on. No stepper imports this module: they receive the
:class:`~camsim.engine.context.EngineContext` this class extends (the shape of
``scipy.integrate._ivp``: methods behind one protocol, :mod:`camsim.engine.base`, under the
driver).
"""

from __future__ import annotations

import math

import numpy as np

from camsim.errors import SimulationError, ZenoError
from camsim.elements import Branch, GuardKind
from camsim.elements.affine import N_INPUT
from camsim.engine import friction
from camsim.engine.base import Stepper
from camsim.engine.context import GRID_SNAP, EngineContext
from camsim.engine.linear import LinearStepper
from camsim.engine.nonlinear import ExponentialStepper
from camsim.engine.rigid import CHATTER_SPAN, resolve as resolve_rigid
from camsim.engine.rk import RungeKuttaStepper
from camsim.engine.state import TIME_EPS, Guard, State, Stretch, leaving_zero
from camsim.engine.watch import CamForceWatch
from camsim.model.assembly import Model

#: More events than this at one instant (within INSTANT_TIME) is a failure to resolve.
MAX_EVENTS_PER_INSTANT = 64
#: Events closer than this [s] count as one instant for MAX_EVENTS_PER_INSTANT.
INSTANT_TIME = 1e-12

#: The ways of advancing a configuration, tried in order: the first whose ``applies``
#: holds advances it (scipy's ``METHODS``: the driver never compares kinds again).
STEPPERS: tuple[Stepper, ...] = (LinearStepper(), ExponentialStepper(), RungeKuttaStepper())


def stepper_for(ctx: EngineContext, config) -> Stepper:
    """The stepper that advances ``config``."""
    for stepper in STEPPERS:
        if stepper.applies(ctx, config):
            return stepper
    raise AssertionError("no stepper applies")  # RungeKuttaStepper applies to every configuration


class Integrator(EngineContext):
    """Event-driven integration of a :class:`Model` driven by a cam program.

    Parameters
    ----------
    model : Model
    cam : CamProgram or a camshaft input
        Provides ``channels(t, side)`` and ``break_times(t0, t1)``.
    step : float
        Internal grid step h [s]; the grid is t_ref + k·h.
    t_ref : float
        A time on the grid [s].
    """

    def __init__(self, model: Model, cam, step: float, t_ref: float = 0.0):
        super().__init__(model, cam, step, t_ref)
        self._instant_count = 0
        self._instant_time = -math.inf
        self._taken = 0  # events already handed out by take_events
        #: Jump warnings: the driven mass's cam contact force located like an event (issue 25).
        self.watch = CamForceWatch(self)

    def take_events(self) -> list:
        """The events recorded since the last call, for a consumer that streams them (the
        streamed run). The engine itself reads its recent events (a rigid contact's chatter
        within :data:`~camsim.engine.rigid.CHATTER_SPAN`): those stay in ``events``, the older
        ones are dropped, so a long streamed run holds a bounded list and takes the same
        decisions as an in-memory one (a consumer that emptied the list hid every chatter
        from the engine: a streamed run chattered for ever where the in-memory run stuck)."""
        new = self.events[self._taken:]
        if self.events:
            horizon = self.events[-1].time - 2.0 * CHATTER_SPAN
            keep = 0
            while keep < len(self.events) and self.events[keep].time < horizon:
                keep += 1
            del self.events[:keep]
        self._taken = len(self.events)
        return new

    def advance(self, state: State, t_stop: float, record: bool) -> tuple[State, Stretch | None, Guard | None]:
        """Integrate one configuration from ``state`` until an event or ``t_stop``.

        Returns the state at the end, the stretch with every node of its solution (when
        ``record``; :class:`~camsim.engine.state.Stretch`) and the guard that fired (None
        when ``t_stop`` was reached). The exact linear stepper crosses the cam's breaks
        inside the stretch; the others stop at the next one.
        """
        config = self.model.configuration(state.branches, state.holds)
        guards = self.guards(state, config)
        u0 = self.inputs(np.array([state.t]))[0]
        z0 = config.state_from_input(state.x, state.v, u0)
        stepper = stepper_for(self, config)
        if not stepper.crosses_breaks:
            later = self.breaks_between(state.t, t_stop)
            if later:
                t_stop = later[0]
        out = stepper.advance(self, state, config, z0, guards, t_stop, record)
        if not stepper.exact:
            self.watch.samples(state, out[0], out[1], config)
        if record and (out[1] is None or out[1].samples is None):
            out = self._with_ends(state, z0, config, stepper.exact, out)
        return out

    def _with_ends(self, start: State, z0, config, exact: bool, out):
        """A stepper's grid-point stretch with its start and end as nodes (the one-sided
        limits there: the located extremes read them); its grid points are its samples."""
        end, stretch, guard = out
        t0, t1 = start.t, end.t
        if t1 - t0 <= TIME_EPS and (stretch is None or not stretch.t.size):
            return end, None, guard
        u0 = self.inputs(np.array([t0]))[0]
        u1 = self.input_left(t1)  # the limit from the left
        z1 = config.state_from_input(end.x, end.v, u1)
        if stretch is not None and stretch.t.size:
            inner = (stretch.t > t0 + TIME_EPS) & (stretch.t < t1 - TIME_EPS)
            first = bool(abs(stretch.t[0] - t0) <= TIME_EPS)  # the start is a grid point: a sample
            nodes = np.concatenate([[t0], stretch.t[inner], [t1]])
            Z = np.vstack([z0[None, :], stretch.z[inner], z1[None, :]])
            U = np.vstack([u0[None, :], stretch.u[inner], u1[None, :]])
            samples = np.concatenate([[first], np.ones(int(inner.sum()), dtype=bool), [False]])
        else:
            nodes, Z, U = np.array([t0, t1]), np.vstack([z0, z1]), np.vstack([u0, u1])
            samples = np.zeros(2, dtype=bool)
        fn = self.nonlinear_forces(config, Z, U, start.v_impacts)
        if stretch is not None and stretch.t.size and fn.shape[1]:
            fn[1:-1] = stretch.fn[inner]  # the stepper's own (a rigid contact's v_impacts may differ at the ends)
        return end, Stretch(start.branches, config, nodes, Z, U, fn, dict(start.v_impacts), samples=samples,
                            exact=exact), guard

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
            # issue 12 hook: rigid contacts as one LCP; an impulse may start or stop a friction pair
            return friction.after_impulse(self, resolve_rigid(self, state, i, guard.kind))
        if guard.kind == GuardKind.HALT:
            return friction.halt(self, state, i)  # spec §10: the stick test
        if guard.kind == GuardKind.GRIP:
            return friction.grip(self, state, i)  # a programmed normal force rises above zero
        _, rate = self.relative_rate(state, i)
        d = float(model.deflection(i, state.x, self.inputs(np.array([state.t]))[0, 0::N_INPUT]))
        outcome = model.elements[i].outcome_at(guard.kind, rate, d)  # issue 12 hook: two-sided elements
        if outcome.event is not None:
            self._record(state.t, i, outcome.event, outcome.velocity, outcome.branch)
        if outcome.branch is not None:
            branches[pos] = outcome.branch
        if outcome.v_impact is not None:
            v_imp[i] = outcome.v_impact
        holds = friction.pruned(model, branches, state.holds) if state.holds else ()  # a slipping pair lets go
        return State(state.t, state.x.copy(), state.v.copy(), tuple(branches), v_imp, holds)

    def violated(self, state: State) -> Guard | None:
        """A guard of the state's configuration that is already violated, if any (the first
        in the elements' order)."""
        config = self.model.configuration(state.branches, state.holds)
        u = self.inputs(np.array([state.t]))
        z = config.state_from_input(state.x, state.v, u[0])
        guards = self.guards(state, config)
        if not guards:
            return None
        if config.linear:
            # every guard at once (the stacked matrices the linear stepper screens with)
            Cz, Du, e, Cz_d, Du_d, e_d, tol = self.stacked_guards(guards)
            values = z @ Cz + u[0] @ Du + e
            low = np.flatnonzero(values < -tol)
            if not low.size:
                return None
            rates = z @ Cz_d + u[0] @ Du_d + e_d
            for k in low.tolist():
                if guards[k].kind != GuardKind.UNLIFT and not leaving_zero(values[k], rates[k], tol[k]):
                    return guards[k]
            return None
        fn = self.nonlinear_forces(config, z[None, :], u, state.v_impacts)
        for guard in guards:
            if guard.kind == GuardKind.UNLIFT:
                continue
            value = guard.value(z[None, :], u, fn)[0, 0]
            if value < -guard.tol and not leaving_zero(value, self.guard_rate(config, guard, z, u, fn), guard.tol):
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
            on_stretch=None, check=None, on_advance=None):
        """Integrate from ``state`` to ``t_end``; return the stretches recorded from ``record_from``.

        ``stops`` are extra times at which integration halts (``on_stop(state)`` is called),
        e.g. the start of a cycle for the periodicity residual.

        ``on_stretch(stretch, t)``, when given, receives each recorded stretch instead of the
        returned list (which stays empty: memory does not grow with the run), called once
        every event up to ``t`` [s] (the stretch's end) is in :attr:`events`; later events
        and later stretches' samples all lie at or after ``t`` (camsim.run.stream). The consumer
        reads new events with :meth:`take_events`.

        A recorded stretch's samples before ``record_from`` are not samples (a stretch
        never straddles it when it is one of ``stops``).

        ``check(state)``, when given, sees the state after every stretch and raises to stop
        the run (the physical bounds of camsim.run.bounds: a comparison per stretch).

        ``on_advance(start, end, guard, after)``, when given, sees every stretch: its start
        and end states, the guard that fired at its end (None at a stop) and the state once
        that instant's events are resolved (the revolution's derivative,
        :class:`camsim.engine.monodromy.Monodromy`).
        """
        stretches: list[Stretch] = []
        state = self.settle(state)
        self.noting_from(state.t)
        if on_stop and any(abs(s - state.t) <= TIME_EPS for s in stops):
            on_stop(state)
        joins = [float(t) for t in self.cam.break_times(state.t - self.h, t_end + self.h)]  # joins and inner kinks
        self._joins = set(joins)
        self._join_array = sorted(joins)
        boundaries = sorted({s for s in stops if state.t < s < t_end}) + [t_end]
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
            if stretch is not None:
                if stretch.t[0] < record_from - GRID_SNAP * self.h:
                    stretch.samples = stretch.samples & (stretch.t >= record_from - GRID_SNAP * self.h)
                if on_stretch is None:
                    stretches.append(stretch)
            if not np.all(np.isfinite(new_state.x)) or not np.all(np.isfinite(new_state.v)):
                raise SimulationError(f"the run diverged before t = {new_state.t:.9g} s (non-finite state)")
            start, state = state, new_state
            if guard is not None:
                self.note_event(new_state.t)
                state = self.handle(state, guard)
                state = self.settle(state)
            if on_advance is not None:
                on_advance(start, new_state, guard, state)
            if on_stretch is not None and stretch is not None:  # streaming hook (camsim.run.stream)
                on_stretch(stretch, state.t)
            if check is not None:
                check(state)
            if progress is not None:
                progress(state.t)
            count += 1
            if count > max_stretches:
                raise ZenoError("too many events; the run does not progress")
        if on_stop and any(abs(s - t_end) <= TIME_EPS for s in stops):
            on_stop(state)
        return state, stretches

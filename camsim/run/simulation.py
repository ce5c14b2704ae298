"""Running a machine: initial state, warm-up, recording, traces and the event table.

:func:`simulate` is what ``camsim run`` calls; it returns a :class:`RunResult` that the
HDF5 writer, the plots and the summary table all read.
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from dataclasses import dataclass, replace

import numpy as np
from threadpoolctl import threadpool_limits

from camsim.cam.program import CamProgram
from camsim.errors import InputError, SimulationError
from camsim.elements.events import Event, EventKind, EventTable
from camsim.elements import CAM, GROUND, Branch
from camsim.engine.integrator import Integrator, State, Stretch
from camsim.machine.description import Machine
from camsim.model.assembly import Model
from camsim.model.rigidity import check_cam_resolvable, check_not_rigid
from camsim.run.result import RunResult

#: Internal steps per period of the highest natural frequency (guard sampling density).
SAMPLES_PER_PERIOD = 12
#: Internal steps per output sample beyond which a machine is refused as input (issue 26).
MAX_STEPS_PER_SAMPLE = 1e7
#: A linear static equilibrium whose stiffness matrix is worse conditioned than this has
#: no unique solution (a mass held by nothing stiff): ask for an [initial] state instead.
#: 1e14 leaves two digits of a double for the positions.
EQUILIBRIUM_MAX_CONDITION = 1e14
#: A nonlinear (power-law) static equilibrium is accepted when its force residual is below
#: this fraction of the residual at the unloaded position (1e-6: well below any reported digit).
EQUILIBRIUM_RESIDUAL = 1e-6
#: Penetrations [m] from which Powell's method is started in turn: δ^a has no slope at
#: δ = 0, which can stall the first try (0.1 µm .. 0.1 mm spans seats from hard to soft).
EQUILIBRIUM_STARTS = (0.0, 1e-6, 1e-5, 1e-4)


# ---------------------------------------------------------------------- initial state
def static_equilibrium(model: Model, integrator: Integrator, t0: float) -> State:
    """Static equilibrium at t0 with zero velocities, iterating over branches until consistent.

    Raises
    ------
    InputError
        When no consistent equilibrium exists (e.g. a mass held by nothing but gravity).
    """
    n = model.n
    branches = tuple(
        Branch.BILATERAL if Branch.BILATERAL in model.branch_options(i) else model.branch_options(i)[0]
        for i in model.switching
    )
    u = integrator.inputs(np.array([t0]))[0]
    seen = set()
    for _ in range(4 * len(model.switching) + 8):
        if branches in seen:
            break
        seen.add(branches)
        config = model.configuration(branches)
        nq = config.dim // 2
        A21 = config.A[nq:, :nq]
        rhs = config.B[nq:] @ u + config.b[nq:]
        if not nq:  # every free mass held by stuck rigid contacts: nothing to solve
            q = np.zeros(0)
        elif config.linear:
            try:
                q = np.linalg.solve(A21, -rhs)
            except np.linalg.LinAlgError:
                q = None
            if q is not None and nq and np.linalg.cond(A21) > EQUILIBRIUM_MAX_CONDITION:
                q = None
        else:
            q = _nonlinear_static(model, integrator, config, u, t0)
        if q is None:
            raise InputError(
                f"{model.machine.source}: initial: no static equilibrium at the start (a mass is held "
                "by nothing stiff); give its position in an [initial] table"
            )
        z = np.concatenate([q, np.zeros(nq)])
        x = config.x(z[None, :], u[None, :], integrator.nonlinear_forces(config, z[None, :], u[None, :], {}))[0]
        v = np.zeros(n)
        state = State(t0, x, v, branches, {})
        new = _consistent_branches(model, integrator, state)
        if new == branches:
            return state
        branches = new
    raise InputError(
        f"{model.machine.source}: initial: the static equilibrium does not settle on one branch of "
        "the contacts and links; give the start in an [initial] table"
    )


def _nonlinear_static(model, integrator, config, u, t0):
    from scipy import optimize  # only power-law contacts need it; keeps start-up light

    nq = config.dim // 2
    # each contact's penetration at rest: δ = c·q + e (the affine maps evaluated once)
    contacts = []
    for i in config.power_contacts:
        delta, _ = integrator._delta(config, i)
        contacts.append((model.elements[i], delta.Cz[0][:nq], float(delta.Du[0] @ u + delta.e[0])))
    A21 = config.A[nq:, :nq]
    L2 = config.L[nq:]
    base = config.B[nq:] @ u + config.b[nq:]

    def residual(q):
        fn = [element.nonlinear_force(np.array([c @ q + e]), np.zeros(1), None)[0] for element, c, e in contacts]
        return A21 @ q + base + L2 @ np.array(fn)

    def jacobian(q):
        # analytic: ∂F/∂δ of each contact at rest (Powell's method then needs no
        # finite differences, a tenth of the residual evaluations)
        J = A21.copy()
        for k, (element, c, e) in enumerate(contacts):
            kt = element.nonlinear_tangent(np.array([c @ q + e]), np.zeros(1), None)[1][0]
            J += np.outer(L2[:, k], kt * c)
        return J

    def accepted(q):
        return np.max(np.abs(residual(q))) < EQUILIBRIUM_RESIDUAL * max(1.0, np.max(np.abs(residual(np.zeros(nq)))))

    if len(contacts) == 1:
        q = _one_contact_static(A21, L2[:, 0], base, contacts[0])
        if q is not None and accepted(q):
            return q
    # Powell's hybrid method from the unloaded position, then from a few small
    # penetrations (δ^a has no slope at δ = 0, which can stall the first try).
    guess = np.zeros(nq)
    best = None
    for scale in EQUILIBRIUM_STARTS:
        sol = optimize.root(residual, guess + scale, jac=jacobian, method="hybr", options={"xtol": 1e-14})
        if sol.success and accepted(sol.x):
            best = sol.x
            break
    return best


def _one_contact_static(A21, L2, base, contact):
    """Static equilibrium with one power-law contact as a scalar equation in its force.

    With the contact force f as an input, the equilibrium A21·q + base + L2·f = 0 is
    linear: q = q0 + w·f, and the penetration δ = δ0 + s·f. Where s ≤ 0 (the force pushes
    the contact open, as any contact between a body and its support does) and F grows
    with δ, the contact's equation f = F(δ0 + s·f) has exactly one root in [0, F(δ0)],
    which Brent's method finds to rounding (a tenth of the cost of Powell's method on q).
    None where that reduction does not apply (A21 singular or ill-conditioned: a body held
    by the contact alone; s > 0; no bracket), and Powell's method on q takes over.
    """
    from scipy import optimize

    element, c, e = contact
    if A21.shape[0] == 0 or np.linalg.cond(A21) > EQUILIBRIUM_MAX_CONDITION:
        return None
    q0, w = np.linalg.solve(A21, -np.column_stack([base, L2])).T
    delta0, s = float(c @ q0 + e), float(c @ w)
    if s > 0.0:
        return None

    def excess(f):  # f − F(δ(f)): increasing in f where F increases with δ
        return f - element.nonlinear_force_scalar(delta0 + s * f, 0.0, None)

    top = -excess(0.0)
    if top <= 0.0:
        return q0  # open at rest: no force (the caller's branch check opens the contact)
    if excess(top) < 0.0:
        return None  # F not increasing with δ: no bracket
    f = optimize.brentq(excess, 0.0, top, xtol=1e-300, rtol=4 * np.finfo(float).eps)
    return q0 + w * f


def _consistent_branches(model: Model, integrator: Integrator, state: State) -> tuple[Branch, ...]:
    """Branches implied by positions at rest (static equilibrium iteration)."""
    branches = list(state.branches)
    config = model.configuration(state.branches)
    u = integrator.inputs(np.array([state.t]))
    z = config.state_from_full(state.x, state.v, u[0, 0], u[0, 1])
    # the constraint forces balance the closed power-law contacts' forces too
    fn = integrator.nonlinear_forces(config, z[None, :], u, {})
    for pos, i in enumerate(model.switching):
        d = float(model.deflection(i, state.x, u[0, 0]))

        def constraint_force(i=i) -> float:
            return float(config.lam(z[None, :], u, fn)[0, config.stuck_contacts.index(i)])

        branches[pos] = model.elements[i].branch_at_rest(branches[pos], d, constraint_force)
    return tuple(branches)


def initial_state(model: Model, integrator: Integrator, t0: float) -> State:
    """Static equilibrium, then the machine file's ``[initial]`` values on top."""
    machine = model.machine
    given = {ic.mass: ic for ic in machine.initial}
    try:
        state = static_equilibrium(model, integrator, t0)
    except InputError:
        missing = [name for name in model.free_names if name not in given or given[name].displacement is None]
        if missing:
            raise
        branches = tuple(model.branch_options(i)[0] for i in model.switching)
        state = State(t0, np.zeros(model.n), np.zeros(model.n), branches, {})
    if not given:
        return state
    x, v = state.x.copy(), state.v.copy()
    for name, ic in given.items():
        k = model.index[name]
        if ic.displacement is not None:
            x[k] = ic.displacement
        if ic.velocity is not None:
            v[k] = ic.velocity
    # Branches from the given state: links by deflection, contacts by penetration.
    branches = []
    u = integrator.inputs(np.array([t0]))[0]
    for i in model.switching:
        geo = model.geometry[i]
        d = x @ geo.G + geo.g_s * u[0]
        try:
            branches.append(model.elements[i].branch_from_state(d, model.no_impact))
        except ValueError as exc:
            raise InputError(f"{machine.source}: initial: {exc}") from None
    return State(t0, x, v, tuple(branches), {})


# ---------------------------------------------------------------------- the run
def highest_frequency(model: Model) -> float:
    """Highest undamped natural frequency over the linear configurations [Hz]."""
    combos = model.all_branch_combinations()
    if len(combos) > 256:
        combos = combos[:256]
    best = 0.0
    for branches in combos:
        try:
            config = model.configuration(branches)
        except InputError:
            continue
        if config.dim == 0:
            continue
        if not np.all(np.isfinite(config.A)):
            return math.inf  # an element beyond float range (1e300 N/m): rigid, check_not_rigid says which
        lam = np.linalg.eigvals(config.A)
        best = max(best, float(np.max(np.abs(lam))) / (2 * math.pi))
    return best


def simulate(
    machine: Machine,
    *,
    no_impact: bool = False,
    cycles: int | None = None,
    warmup_cycles: int | None = None,
    sample_rate: float | None = None,
    progress=None,
) -> RunResult:
    """Simulate a machine and return its traces and events.

    Parameters
    ----------
    machine : Machine
    no_impact : bool
        Run the no-impact variant (spec §4).
    cycles, warmup_cycles : int, optional
        Override ``[simulation]`` cycles and warm-up cycles.
    sample_rate : float, optional
        Override the output sample rate [Hz].
    progress : callable, optional
        Called with the fraction done (0..1) now and then.

    Returns
    -------
    RunResult

    Raises
    ------
    InputError
        For settings that cannot run (no equilibrium and no initial state, ...).
    SimulationError
        When the run diverges or events pile up without resolution.
    """
    # The matrices are tiny (≤ ~40×40): a multi-threaded BLAS only adds synchronisation,
    # and when the other cores are busy it slows a run tenfold (measured on 2 cores).
    with threadpool_limits(limits=1, user_api="blas"):
        return _simulate(machine, no_impact, cycles, warmup_cycles, sample_rate, progress)


def _simulate(machine, no_impact, cycles, warmup_cycles, sample_rate, progress, stream=None) -> RunResult:
    """The run; ``stream(run)`` (camsim.run.stream), when given, makes the consumer of the
    stretches (see :class:`RunSetup`) and its ``finish()`` returns the result instead."""
    sim = machine.simulation
    if cycles is not None or warmup_cycles is not None or sample_rate is not None:
        sim = replace(
            sim,
            cycles=cycles if cycles is not None else sim.cycles,
            warmup_cycles=warmup_cycles if warmup_cycles is not None else sim.warmup_cycles,
            sample_rate=sample_rate if sample_rate is not None else sim.sample_rate,
            duration=None if cycles is not None else sim.duration,
        )
        machine = replace(machine, simulation=sim)
    if sim.sample_rate <= 0:
        raise InputError("simulation.sample_rate: must be positive")
    cam = CamProgram(machine.cam)
    model = Model(machine, no_impact=no_impact)
    warnings = list(cam.warnings)
    period = cam.period
    has_cam = machine.cam is not None
    warm = sim.warmup_cycles if has_cam else 0
    if sim.duration is not None:
        record_len = sim.duration
    elif has_cam:
        record_len = sim.cycles * period
    else:
        raise InputError(f"{machine.source}: simulation.duration: required for a machine without a cam")
    t_rec = warm * period if warm else 0.0
    t_end = t_rec + record_len
    h_out = 1.0 / sim.sample_rate
    check_cam_resolvable(machine)  # issue 25: a cam faster than events can be located
    f_max = highest_frequency(model)
    check_not_rigid(model, f_max, SAMPLES_PER_PERIOD)  # issue 25: exit 2 naming the element
    if f_max > 0 and sim.sample_rate < 2 * f_max:
        warnings.append(
            f"sample rate {sim.sample_rate:g} Hz is below twice the highest natural frequency "
            f"({f_max:.4g} Hz): the traces alias (events are still located exactly)"
        )
    steps_per_sample = h_out * f_max * SAMPLES_PER_PERIOD
    if not math.isfinite(steps_per_sample) or steps_per_sample > MAX_STEPS_PER_SAMPLE:
        # e.g. --set element.k12.stiffness="1e300 N/m": no run can resolve that (issue 26)
        raise InputError(
            f"{machine.source}: the highest natural frequency, {f_max:.3g} Hz, needs {steps_per_sample:.3g} internal "
            f"steps per output sample (at most {MAX_STEPS_PER_SAMPLE:.0e}): a stiffness or a mass is out of any "
            "physical range"
        )
    # The cam input is carried over each step as the Hermite of s, ṡ, s̈, s⃛ at its ends: a
    # step no longer than 1/WARMUP_STEPS_PER_MOTION of the shortest rise keeps it exact
    # (warmup_step). A coarse output grid on a soft machine (5 kHz, one step per sample)
    # otherwise moved a power-law contact's traces by 1e-6 of peak against 500 kHz (issue 25,
    # invariant a); machines whose natural frequencies already ask for finer steps keep them.
    motion_step = cam_input_step(machine)
    substeps = max(1, math.ceil(steps_per_sample), math.ceil(h_out / motion_step * (1 - 1e-12)))
    integrator = Integrator(model, cam, h_out / substeps, t_ref=t_rec)
    run = RunSetup(machine, model, cam, integrator, t_rec, t_end, h_out, warnings, no_impact, period if has_cam else None)
    consumer = stream(run) if stream is not None else None  # before integrating: it may refuse the settings
    state = initial_state(model, integrator, 0.0)
    saved: dict[float, State] = {}
    # The state one revolution apart gives the periodicity residual: the last warm-up cycle
    # against the first recorded one (or the first two recorded cycles without warm-up).
    if warm >= 1:
        stops = (t_rec - period, t_rec)
    elif has_cam and sim.duration is None and sim.cycles >= 2:
        stops = (0.0, period)
    else:
        stops = ()

    def on_stop(st: State) -> None:
        saved[round(st.t, 9)] = st

    # The cam design's energy quantities are taken over exactly one revolution, closed at its
    # end with the state the integrator stops at there, not with the samples around it
    # (issue 26: the last sample of one revolution falls short of the period unless the
    # period is a multiple of the sample spacing).
    t_period_end = None
    if has_cam and getattr(machine.cam, "geometry", None) is not None and t_end >= t_rec + period * (1 - 1e-12):
        t_period_end = t_rec + period
    all_stops = tuple(stops) + ((t_period_end,) if t_period_end is not None and t_period_end not in stops else ())

    total = t_end
    report = (lambda t: progress(min(1.0, t / total))) if progress else None
    t_final = t_end + 0.5 * h_out
    # Warm-up cycles are not recorded: integrate them on a coarser grid, just dense
    # enough to see every guard and to carry the cam input exactly (warmup_step).
    h_warm = warmup_step(machine, f_max, integrator.h)
    # A nonlinear (power-law) contact has no natural frequency in f_max: a coarser warm-up
    # grid hands its contact phases to DOP853, and a warm-up revolution cost several recorded
    # ones (issue 26). Such machines warm up on the recording grid: the same cost per revolution.
    if any(e.is_nonlinear(b) for e in model.elements for b in Branch):
        h_warm = integrator.h
    with numerical_failure(machine):
        if t_rec > 0 and h_warm > 1.5 * integrator.h:
            warm_integrator = Integrator(model, cam, h_warm, t_ref=0.0)
            state, _ = warm_integrator.run(state, t_rec, record_from=math.inf, stops=stops, on_stop=on_stop, progress=report)
            # the cam contact force's sign where the warm-up ends: the recorded window starts
            # with no jump row the continuous run does not have (issue 25)
            integrator.watch.last = warm_integrator.watch.last
        if consumer is None:
            _, stretches = integrator.run(state, t_final, record_from=t_rec, stops=all_stops, on_stop=on_stop, progress=report)
            result = _assemble(run, stretches)
            peak = lambda name, quantity: float(np.max(np.abs(result.masses[name][quantity])))  # noqa: E731
        else:
            integrator.run(state, t_final, record_from=t_rec, stops=all_stops, on_stop=on_stop, progress=report, on_stretch=consumer.on_stretch)
            result = consumer.finish()
            peak = result.peak
    if t_period_end is not None and round(t_period_end, 9) in saved:
        end = period_end(run, saved[round(t_period_end, 9)])
        result.period_end = end
        design = getattr(result, "_design", None)  # a streamed run's accumulator (camsim.run.stream)
        if design is not None and end is not None:
            design.period_end = (end["time"], end["torque"])
    result.periodicity_residual = _residual(model, saved, stops, peak)
    result.sample_rate = sim.sample_rate
    if consumer is not None:
        consumer.close(result)
    return result


@contextmanager
def numerical_failure(machine: Machine):
    """Turn a numerical breakdown inside the engine into a :class:`SimulationError` (exit 1,
    one line) instead of a traceback.

    A singular Newton matrix or an overflow comes from a machine at the edge of what the
    engine resolves -- in practice a power-law contact far stiffer than its neighbours (the
    CDTM's seat coefficient x 1e9: singular collocation matrix after 44 s, issue 25) --
    which the up-front checks (:mod:`camsim.model.rigidity`, linear laws only) cannot see.
    """
    try:
        yield
    except (np.linalg.LinAlgError, FloatingPointError, OverflowError) as exc:
        raise SimulationError(
            f"{machine.source}: the integration broke down numerically ({type(exc).__name__}: {exc}); an element "
            f"is probably too stiff to resolve: lower its stiffness or coefficient, or make the contact rigid "
            f'(law = "restitution")'
        ) from exc


#: Warm-up steps per shortest cam motion (rise or fall). A step carries the cam input as
#: the degree-7 Hermite of s, ṡ, s̈, s⃛ at its ends; over a fifth of a rise (the former
#: warm-up grid of a soft machine) that is 1e-7 of the lift off, and across the jerk
#: steps inside a modified trapezoid or sine (not segment joins) worse. 64 steps per
#: motion keep the recorded revolution after a warm-up equal to the same revolution of a
#: continuous run to 1e-9 of peak (tests/invariants, invariant b; issue 25).
WARMUP_STEPS_PER_MOTION = 64


def cam_input_step(machine: Machine) -> float:
    """Longest step [s] over which the cam input stays exact: 1/WARMUP_STEPS_PER_MOTION of
    the shortest rise or fall (of a revolution for a table cam); inf without a cam."""
    cam = machine.cam
    if cam is None:
        return math.inf
    motions = [seg.duration for seg in (cam.segments or ()) if seg.motion != "dwell"]
    shortest = min(motions) if motions else 2 * math.pi / WARMUP_STEPS_PER_MOTION  # a table cam: by revolution
    return shortest / cam.speed / WARMUP_STEPS_PER_MOTION


def warmup_step(machine: Machine, f_max: float, h: float) -> float:
    """Step [s] of the unrecorded warm-up grid: at most 1/(12·f_max) (every guard seen)
    and :func:`cam_input_step` (the cam input exact); ``h`` (the recording step) when
    neither bounds it."""
    bounds = [cam_input_step(machine)]
    if f_max > 0:
        bounds.append(1.0 / (SAMPLES_PER_PERIOD * f_max))
    best = min(bounds)
    return best if math.isfinite(best) else h


@dataclass(frozen=True)
class RunSetup:
    """What turns a run's stretches into output samples and events (both assembly paths).

    Attributes
    ----------
    machine, model, cam, integrator
        The machine (with the run's overrides), its model, cam program and the recording
        integrator (its ``events`` are the raw event list).
    t_rec : float
        Start of the recorded window on the simulation clock [s] (output time 0).
    t_end : float
        End of the recorded window [s].
    h_out : float
        Output sample interval [s].
    warnings : list of str
        The run's warnings so far (appended to).
    no_impact : bool
    period : float or None
        One cam revolution [s] (None without a cam).
    """

    machine: Machine
    model: Model
    cam: CamProgram
    integrator: Integrator
    t_rec: float
    t_end: float
    h_out: float
    warnings: list
    no_impact: bool
    period: float | None


def stretch_samples(run: RunSetup, st: Stretch):
    """The output-grid samples of one stretch: ``(t, x, v, a, u, forces)`` or None.

    ``t`` [s] on the simulation clock; x, v, a (N, n) of the free masses; u (N, 4) the
    cam input s, ṡ, s̈, s⃛; forces (N, elements) [N]. Used by :func:`_assemble` and by the
    streaming assembler alike, so both give the same bits.
    """
    t_rec, t_end, h_out = run.t_rec, run.t_end, run.h_out
    k = (st.t - t_rec) / h_out
    keep = (np.abs(k - np.round(k)) < 1e-6) & (st.t <= t_end + 1e-9 * h_out)
    if not np.any(keep):
        return None
    if np.all(keep):  # the usual case: no copies
        z, u, fn, t = st.z, st.u, st.fn, st.t
    else:
        z, u, fn, t = st.z[keep], st.u[keep], st.fn[keep], st.t[keep]
    config = st.config
    x = config.x(z, u, fn)
    v = config.v(z, u, fn)
    a = config.a(z, u, fn)
    lam = config.lam(z, u, fn)
    forces = run.model.element_forces(st.branches, x, v, u[:, 0], u[:, 1], lam, config, st.v_impacts)
    return t, x, v, a, u, forces


def sample_traces(run: RunSetup, time, x, v, a, u, forces) -> dict:
    """The traces of a run (or of a stretch of it) from its samples (element by element,
    so any split of the samples gives the same bits): keyword arguments of
    :class:`RunResult` ``time``, ``cam``, ``masses``, ``elements``,
    ``cam_contact_force``, ``transducer_force``."""
    machine, model, cam = run.machine, run.model, run.cam
    masses: dict[str, dict[str, np.ndarray]] = {}
    for m in machine.masses:
        if m.name == model.driven:
            masses[m.name] = {"displacement": u[:, 0], "velocity": u[:, 1], "acceleration": u[:, 2]}
        else:
            k = model.index[m.name]
            masses[m.name] = {"displacement": x[:, k], "velocity": v[:, k], "acceleration": a[:, k]}
    elements = {e.name: forces[:, i] for i, e in enumerate(model.elements)}
    cam_force = model.cam_contact_force(forces, u[:, 2])
    transducer_idx = [i for i, e in enumerate(model.elements) if getattr(e, "transducer", False)]
    transducer = forces[:, transducer_idx].sum(axis=1) if transducer_idx else None
    # Cam angle on the recorded time base: θ0 + ω·t, t = 0 at the first recorded cycle.
    angle = np.degrees(cam.angle(time)) if machine.cam is not None else np.zeros_like(time)
    cam_traces = {"angle": angle, "displacement": u[:, 0], "velocity": u[:, 1], "acceleration": u[:, 2], "jerk": u[:, 3]}
    return {"time": time, "cam": cam_traces, "masses": masses, "elements": elements,
            "cam_contact_force": cam_force, "transducer_force": transducer}


def period_end(run: RunSetup, state: State) -> dict | None:
    """The cam force and camshaft torque at the exact state ``state`` (the end of the first
    recorded revolution): ``{"time": t [s, recorded clock], "cam_force": Fc [N], "torque": T
    [N*m]}``, through the same force code as the samples; None without a cam force."""
    from camsim.cam.design import camshaft_torque

    model, integrator = run.model, run.integrator
    t = np.array([state.t])
    u = integrator.inputs(t)
    config = model.configuration(state.branches)
    z = config.state_from_full(state.x, state.v, u[0, 0], u[0, 1])[None, :]
    fn = integrator.nonlinear_forces(config, z, u, state.v_impacts)
    x, v, a = config.x(z, u, fn), config.v(z, u, fn), config.a(z, u, fn)
    lam = config.lam(z, u, fn)
    forces = model.element_forces(state.branches, x, v, u[:, 0], u[:, 1], lam, config, state.v_impacts)
    kw = sample_traces(run, t - run.t_rec, x, v, a, u, forces)
    probe = RunResult(machine=run.machine, events=[], periodicity_residual=float("nan"), **kw)
    force = probe.cam_force
    if force is None:
        return None
    torque = camshaft_torque(force, u[:, 1], run.cam.speed)
    return {"time": float(state.t - run.t_rec), "cam_force": float(force[0]), "torque": float(torque[0])}


def boundaries_deg(run: RunSetup) -> np.ndarray:
    """Cam angles of the segment joins [deg] (empty without a cam)."""
    cam = run.cam
    if run.machine.cam is None or not hasattr(cam, "boundary_angles"):
        return np.zeros(0)
    return np.asarray(np.degrees(cam.boundary_angles()), dtype=float)


def negative_cam_force_warning(driven: str, minimum: float, at: float) -> str:
    """The warning of a cam contact force that goes negative (minimum [N] at time [s])."""
    return (
        f"cam contact force on {driven} goes negative (minimum {minimum:.4g} N at "
        f"t = {at:.6g} s): a force-closed follower would leave the cam"
    )


def _assemble(run: RunSetup, stretches: list[Stretch]) -> RunResult:
    t_rec, h_out = run.t_rec, run.h_out
    ts, xs, vs, as_, us, fs = [], [], [], [], [], []
    for st in stretches:
        samples = stretch_samples(run, st)
        if samples is None:
            continue
        for parts, arr in zip((ts, xs, vs, as_, us, fs), samples):
            parts.append(arr)
    if not ts:
        raise SimulationError("the run recorded no samples")
    t = np.concatenate(ts)
    x, v, a, u, forces = (np.concatenate(parts) for parts in (xs, vs, as_, us, fs))
    # Stretches come in time order; a grid point shared by two of them (an event exactly on
    # a sample) keeps the later value, the state just after the event.
    grid_index = np.round((t - t_rec) / h_out)
    if np.any(np.diff(grid_index) <= 0):
        order = np.argsort(t, kind="stable")
        t, x, v, a, u, forces, grid_index = (arr[order] for arr in (t, x, v, a, u, forces, grid_index))
        keep = np.concatenate([np.diff(grid_index) != 0, [True]])
        t, x, v, a, u, forces, grid_index = (arr[keep] for arr in (t, x, v, a, u, forces, grid_index))
    time = grid_index * h_out
    traces = sample_traces(run, time, x, v, a, u, forces)
    machine, model, cam, warnings = run.machine, run.model, run.cam, run.warnings
    cam_force = traces["cam_contact_force"]
    events = EventTable(_events(machine, model, cam, run.integrator.events, t_rec, run.t_end, time, traces["elements"]))
    if cam_force is not None:
        # jump rows are events of the integrator (camsim.engine.watch), located on the
        # exact solution like every other; here only the warning of the sampled minimum
        events.sort(key=lambda e: e.time)
        if np.min(cam_force) < 0:
            k = int(np.argmin(cam_force))
            warnings.append(negative_cam_force_warning(model.driven, cam_force[k], time[k]))
    from camsim.machine.compensation import assumption_warnings

    warnings.extend(assumption_warnings(machine, events))  # issue 35: the compensation checks itself
    return RunResult(
        machine=machine, **traces, events=events,
        periodicity_residual=float("nan"), warnings=warnings, no_impact=run.no_impact,
        boundaries_deg=boundaries_deg(run),
    )


def _events(machine, model, cam, raw: list[Event], t_rec, t_end, time, element_forces) -> list[Event]:
    out = []
    recorded = [e for e in raw if t_rec - 1e-12 <= e.time <= t_end + 1e-12]
    for k, ev in enumerate(recorded):
        ev = replace(ev, time=ev.time - t_rec)
        ev.angle_deg = float(np.degrees(cam.angle(np.array([ev.time]))[0])) if machine.cam is not None else float("nan")
        if ev.kind.is_impact:
            _annotate(model, ev, recorded[k + 1 :], t_rec, time, element_forces)
        out.append(ev)
    return out


def _node_mass(model: Model, node: str) -> float:
    if node in (GROUND, CAM) or node == model.driven:
        return math.inf
    return model.machine.mass_of(node)


def johnson_annotate(model: Model, ev: Event):
    """Set Johnson's bounds of one impact; return its element when the impact is annotated
    further (peak force, contact duration), None when it is not (no finite mass, no
    approach, or no bounds for this element)."""
    element = model.elements[ev.element_index]
    m_lo, m_up = _node_mass(model, element.lower), _node_mass(model, element.upper)
    finite = sorted(m for m in (m_lo, m_up) if math.isfinite(m))
    if not finite or ev.relative_velocity <= 0:
        return None
    m2 = finite[0]  # the struck (lighter) mass; the other is the driver
    m1 = finite[1] if len(finite) > 1 else math.inf
    v = ev.relative_velocity
    try:
        bounds = element.johnson_bounds(m1, m2, v)
    except InputError:
        return None
    if bounds is None:
        return None
    ev.johnson_lower, ev.johnson_upper = (float(b) for b in bounds)
    return element


def _annotate(model: Model, ev: Event, later: list[Event], t_rec, time, element_forces) -> None:
    """Johnson bounds, simulated peak force and contact duration of one impact."""
    element = johnson_annotate(model, ev)
    if element is None:
        return
    t_close = ev.time
    t_open = next((e.time - t_rec for e in later if e.element == element.name and e.kind == element.closing_ends), None)
    if t_open is not None:
        ev.contact_duration = t_open - t_close
    t_stop = t_open if t_open is not None else time[-1] + 1e-12
    window = (time >= t_close - 1e-12) & (time <= t_stop + 1e-12)
    force = element.impact_force(element_forces[element.name][window])
    if force is not None and force.size:
        ev.peak_force = _peak(force)


def _peak(samples: np.ndarray) -> float:
    """Largest value of a sampled smooth pulse, refined by the parabola through the top
    three samples (a contact a few samples long would otherwise lose up to a few % of its
    peak between samples)."""
    k = int(np.argmax(samples))
    top = float(samples[k])
    if 0 < k < samples.size - 1:
        return refined_peak(float(samples[k - 1]), top, float(samples[k + 1]))
    return top


def refined_peak(left: float, top: float, right: float) -> float:
    """The top of the parabola through three samples around a sampled maximum ``top``
    (``top`` itself when they do not curve down)."""
    curvature = left - 2.0 * top + right
    if curvature < 0.0:
        return top - 0.125 * (right - left) ** 2 / curvature
    return top


def _residual(model: Model, saved: dict, stops, peak) -> float:
    """Largest change over one revolution of the free masses' state, relative to each peak
    (``peak(name, quantity)``: largest |sample| of a mass's recorded trace)."""
    if len(stops) != 2 or model.n == 0:
        return float("nan")
    before, after = (saved.get(round(s, 9)) for s in stops)
    if before is None or after is None:
        return float("nan")
    worst = 0.0
    for name in model.free_names:
        k = model.index[name]
        for quantity, b, a in (("displacement", before.x, after.x), ("velocity", before.v, after.v)):
            scale = peak(name, quantity) or 1.0
            worst = max(worst, abs(a[k] - b[k]) / scale)
    return worst

"""Running a machine: initial state, warm-up, recording, traces and the event table.

:func:`simulate` is what ``camsim run`` calls; it returns a :class:`RunResult` that the
HDF5 writer, the plots and the summary table all read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from threadpoolctl import threadpool_limits

from camsim.cam.program import CamProgram
from camsim.errors import InputError, SimulationError
from camsim.impact import johnson_bounds
from camsim.integrate import FORCE_TOL, LENGTH_TOL, Event, Integrator, State, Stretch
from camsim.machine import CAM, GROUND, Contact, Machine, PreloadedLink
from camsim.model import Branch, Model

#: Internal steps per period of the highest natural frequency (guard sampling density).
SAMPLES_PER_PERIOD = 12


@dataclass
class RunResult:
    """Traces and events of one run, all SI, on a uniform time grid.

    Attributes
    ----------
    machine : Machine
    time : ndarray (N,)
        [s], 0 at the start of the first recorded cycle.
    cam : dict
        ``angle`` [deg] (continuing past 360), ``displacement`` [m], ``velocity`` [m/s],
        ``acceleration`` [m/s^2], ``jerk`` [m/s^3] on the model axis.
    masses : dict
        name → {``displacement``, ``velocity``, ``acceleration``} (a driven mass too).
    elements : dict
        name → force [N] (tension-positive springs/links, compressive-positive contacts).
    cam_contact_force : ndarray or None
        Force of the cam on the driven mass [N].
    transducer_force : ndarray or None
        Sum of the contacts marked ``transducer = true`` [N].
    events : list of Event
        Events of the recorded window, times on the ``time`` base.
    periodicity_residual : float
        Largest difference between the state at the start of the first recorded cycle and
        one revolution before, relative to each quantity's peak (NaN when not computed).
    warnings : list of str
    no_impact : bool
        True for the no-impact variant (spec §4).
    """

    machine: Machine
    time: np.ndarray
    cam: dict[str, np.ndarray]
    masses: dict[str, dict[str, np.ndarray]]
    elements: dict[str, np.ndarray]
    cam_contact_force: np.ndarray | None
    transducer_force: np.ndarray | None
    events: list[Event]
    periodicity_residual: float
    warnings: list[str] = field(default_factory=list)
    no_impact: bool = False
    boundaries_deg: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sample_rate: float = 0.0

    def impacts(self) -> list[Event]:
        """Impact-like events (contacts closing and links rejoining)."""
        return [e for e in self.events if e.kind in ("impact", "rejoin")]

    def summary(self) -> dict:
        """Peaks, forces, impacts and residual as plain JSON-able values (SI)."""
        out: dict = {"machine": self.machine.name, "no_impact": self.no_impact, "masses": {}}
        for name, traces in self.masses.items():
            entry = {}
            for quantity, data in traces.items():
                k = int(np.argmax(np.abs(data))) if data.size else 0
                entry[quantity] = {"peak": float(np.abs(data[k])) if data.size else 0.0, "time": float(self.time[k]) if data.size else 0.0}
            out["masses"][name] = entry
        if self.transducer_force is not None and self.transducer_force.size:
            k = int(np.argmax(self.transducer_force))
            out["peak_transducer_force"] = {"value": float(self.transducer_force[k]), "time": float(self.time[k])}
        else:
            out["peak_transducer_force"] = None
        if self.cam_contact_force is not None and self.cam_contact_force.size:
            kmax = int(np.argmax(self.cam_contact_force))
            kmin = int(np.argmin(self.cam_contact_force))
            out["max_cam_contact_force"] = {"value": float(self.cam_contact_force[kmax]), "time": float(self.time[kmax])}
            out["min_cam_contact_force"] = {"value": float(self.cam_contact_force[kmin]), "time": float(self.time[kmin])}
        else:
            out["max_cam_contact_force"] = out["min_cam_contact_force"] = None
        out["jump"] = self.follower_jumps()
        out["impacts"] = [event_dict(e) for e in self.impacts()]
        out["events"] = len(self.events)
        out["periodicity_residual"] = None if math.isnan(self.periodicity_residual) else float(self.periodicity_residual)
        out["warnings"] = list(self.warnings)
        design = self.design_summary()  # issue 14: cam design scalars when [cam.geometry] is given
        if design is not None:
            out["design"] = design
        return out

    # issue 14: cam design quantities, derived from the traces when [cam.geometry] is given
    def design_traces(self) -> dict:
        """Cam design traces: path → (SI array, units, long name) (:func:`camsim.cam.design.design_traces`)."""
        from camsim.cam.design import design_traces

        return design_traces(self)

    def design_summary(self, cs: float | None = None) -> dict | None:
        """Cam design scalars (:func:`camsim.cam.design.design_summary`); None without geometry."""
        from camsim.cam.design import design_summary

        return design_summary(self, cs)

    def follower_jumps(self) -> bool:
        """True when the follower leaves the cam (negative cam contact force, or a cam contact opens)."""
        if self.cam_contact_force is not None and self.cam_contact_force.size and float(np.min(self.cam_contact_force)) < 0:
            return True
        cam_contacts = {e.name for e in self.machine.elements if isinstance(e, Contact) and CAM in e.nodes}
        return any(ev.kind == "release" and ev.element in cam_contacts for ev in self.events)


def event_dict(event: Event) -> dict:
    """An event as a JSON-able dict (NaN → None)."""
    out = {}
    for key in ("time", "angle_deg", "element", "kind", "masses", "relative_velocity", "johnson_lower",
                "johnson_upper", "peak_force", "contact_duration"):
        value = getattr(event, key, None)
        if isinstance(value, float) and math.isnan(value):
            value = None
        out[key] = value
    return out


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
        if config.linear:
            try:
                q = np.linalg.solve(A21, -rhs) if nq else np.zeros(0)
            except np.linalg.LinAlgError:
                q = None
            if q is not None and nq and np.linalg.cond(A21) > 1e14:
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

    def residual(q):
        z = np.concatenate([q, np.zeros(nq)])
        fn = integrator.nonlinear_forces(config, z[None, :], u[None, :], {})[0]
        return (config.A @ z + config.B @ u + config.b + config.L @ fn)[nq:]

    # Powell's hybrid method from the unloaded position, then from a few small
    # penetrations (δ^a has no slope at δ = 0, which can stall the first try).
    guess = np.zeros(nq)
    best = None
    for scale in (0.0, 1e-6, 1e-5, 1e-4):
        sol = optimize.root(residual, guess + scale, method="hybr", options={"xtol": 1e-14})
        if sol.success and np.max(np.abs(residual(sol.x))) < 1e-6 * max(1.0, np.max(np.abs(residual(guess)))):
            best = sol.x
            break
    return best


def _consistent_branches(model: Model, integrator: Integrator, state: State) -> tuple[Branch, ...]:
    """Branches implied by positions at rest (static equilibrium iteration)."""
    branches = list(state.branches)
    config = model.configuration(state.branches)
    u = integrator.inputs(np.array([state.t]))
    z = config.state_from_full(state.x, state.v, u[0, 0], u[0, 1])
    for pos, i in enumerate(model.switching):
        element = model.elements[i]
        branch = branches[pos]
        if branch == Branch.BILATERAL:
            continue
        if isinstance(element, PreloadedLink):
            d = float(model.deflection(i, state.x, u[0, 0]))
            branches[pos] = Branch.SEPARATED if d > element.separation_deflection + LENGTH_TOL else Branch.JOINED
            continue
        delta, _ = integrator.relative_rate(state, i)
        if branch == Branch.STUCK:
            k = config.stuck_contacts.index(i)
            lam = config.lam(z[None, :], u)[0, k]
            if lam < -FORCE_TOL:
                branches[pos] = Branch.OPEN
        elif branch == Branch.CLOSED:
            if delta <= 0:
                branches[pos] = Branch.OPEN
        else:
            if delta > LENGTH_TOL:
                branches[pos] = Branch.STUCK if element.law == "restitution" else Branch.CLOSED
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
        element = model.elements[i]
        geo = model.geometry[i]
        d = x @ geo.G + geo.g_s * u[0]
        if isinstance(element, PreloadedLink):
            branches.append(Branch.SEPARATED if d > element.separation_deflection and not model.no_impact else Branch.JOINED)
        elif model.no_impact:
            branches.append(Branch.BILATERAL)
        else:
            delta = element.gap - d
            if delta > LENGTH_TOL:
                if element.law == "restitution":
                    raise InputError(
                        f"{machine.source}: initial: the initial state penetrates the rigid contact "
                        f"{element.name} by {delta:.3g} m"
                    )
                branches.append(Branch.CLOSED)
            elif element.law == "restitution" and abs(delta) <= LENGTH_TOL:
                branches.append(Branch.STUCK)
            else:
                branches.append(Branch.OPEN)
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


def _simulate(machine, no_impact, cycles, warmup_cycles, sample_rate, progress) -> RunResult:
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
    f_max = highest_frequency(model)
    if f_max > 0 and sim.sample_rate < 2 * f_max:
        warnings.append(
            f"sample rate {sim.sample_rate:g} Hz is below twice the highest natural frequency "
            f"({f_max:.4g} Hz): the traces alias (events are still located exactly)"
        )
    substeps = max(1, math.ceil(h_out * f_max * SAMPLES_PER_PERIOD))
    integrator = Integrator(model, cam, h_out / substeps, t_ref=t_rec)
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

    total = t_end
    report = (lambda t: progress(min(1.0, t / total))) if progress else None
    t_final = t_end + 0.5 * h_out
    # Warm-up cycles are not recorded: integrate them on a coarser grid, just dense
    # enough to see every guard (each step is exact whatever its length).
    h_warm = 1.0 / (SAMPLES_PER_PERIOD * f_max) if f_max > 0 else integrator.h
    if t_rec > 0 and h_warm > 1.5 * integrator.h:
        warm_integrator = Integrator(model, cam, h_warm, t_ref=0.0)
        state, _ = warm_integrator.run(state, t_rec, record_from=math.inf, stops=stops, on_stop=on_stop, progress=report)
    _, stretches = integrator.run(state, t_final, record_from=t_rec, stops=stops, on_stop=on_stop, progress=report)
    result = _assemble(machine, model, cam, integrator, stretches, t_rec, t_end, h_out, warnings, no_impact)
    result.periodicity_residual = _residual(model, saved, stops, result)
    result.sample_rate = sim.sample_rate
    return result


def _assemble(machine, model, cam, integrator, stretches: list[Stretch], t_rec, t_end, h_out, warnings, no_impact) -> RunResult:
    ts, xs, vs, as_, us, fs = [], [], [], [], [], []
    for st in stretches:
        k = (st.t - t_rec) / h_out
        keep = (np.abs(k - np.round(k)) < 1e-6) & (st.t <= t_end + 1e-9 * h_out)
        if not np.any(keep):
            continue
        if np.all(keep):  # the usual case: no copies
            z, u, fn, t = st.z, st.u, st.fn, st.t
        else:
            z, u, fn, t = st.z[keep], st.u[keep], st.fn[keep], st.t[keep]
        config = st.config
        x = config.x(z, u, fn)
        v = config.v(z, u, fn)
        a = config.a(z, u, fn)
        lam = config.lam(z, u, fn)
        forces = model.element_forces(st.branches, x, v, u[:, 0], u[:, 1], lam, config, st.v_impacts)
        ts.append(t)
        xs.append(x)
        vs.append(v)
        as_.append(a)
        us.append(u)
        fs.append(forces)
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
    masses: dict[str, dict[str, np.ndarray]] = {}
    for m in machine.masses:
        if m.name == model.driven:
            masses[m.name] = {"displacement": u[:, 0], "velocity": u[:, 1], "acceleration": u[:, 2]}
        else:
            k = model.index[m.name]
            masses[m.name] = {"displacement": x[:, k], "velocity": v[:, k], "acceleration": a[:, k]}
    elements = {e.name: forces[:, i] for i, e in enumerate(model.elements)}
    cam_force = model.cam_contact_force(forces, u[:, 2])
    transducer_idx = [i for i, e in enumerate(model.elements) if isinstance(e, Contact) and e.transducer]
    transducer = forces[:, transducer_idx].sum(axis=1) if transducer_idx else None
    # Cam angle on the recorded time base: θ0 + ω·t, t = 0 at the first recorded cycle.
    angle = np.degrees(cam.angle(time)) if machine.cam is not None else np.zeros_like(t)
    cam_traces = {"angle": angle, "displacement": u[:, 0], "velocity": u[:, 1], "acceleration": u[:, 2], "jerk": u[:, 3]}
    events = _events(machine, model, cam, integrator.events, t_rec, t_end, time, elements)
    if cam_force is not None:
        events.extend(_jump_rows(cam, time, cam_force, t_rec, model.driven))
        events.sort(key=lambda e: e.time)
        if np.min(cam_force) < 0:
            k = int(np.argmin(cam_force))
            warnings.append(
                f"cam contact force on {model.driven} goes negative (minimum {cam_force[k]:.4g} N at "
                f"t = {time[k]:.6g} s): a force-closed follower would leave the cam"
            )
    boundaries = np.degrees(cam.boundary_angles()) if machine.cam is not None and hasattr(cam, "boundary_angles") else np.zeros(0)
    return RunResult(
        machine=machine, time=time, cam=cam_traces, masses=masses, elements=elements,
        cam_contact_force=cam_force, transducer_force=transducer, events=events,
        periodicity_residual=float("nan"), warnings=warnings, no_impact=no_impact,
        boundaries_deg=np.asarray(boundaries, dtype=float),
    )


def _events(machine, model, cam, raw: list[Event], t_rec, t_end, time, element_forces) -> list[Event]:
    out = []
    recorded = [e for e in raw if t_rec - 1e-12 <= e.time <= t_end + 1e-12]
    for k, ev in enumerate(recorded):
        ev = replace(ev, time=ev.time - t_rec)
        ev.angle_deg = float(np.degrees(cam.angle(np.array([ev.time]))[0])) if machine.cam is not None else float("nan")
        if ev.kind in ("impact", "rejoin"):
            _annotate(model, ev, recorded[k + 1 :], t_rec, time, element_forces)
        out.append(ev)
    return out


def _node_mass(model: Model, node: str) -> float:
    if node in (GROUND, CAM) or node == model.driven:
        return math.inf
    return model.machine.mass_of(node)


def _annotate(model: Model, ev: Event, later: list[Event], t_rec, time, element_forces) -> None:
    """Johnson bounds, simulated peak force and contact duration of one impact."""
    element = model.elements[ev.element_index]
    m_lo, m_up = _node_mass(model, element.lower), _node_mass(model, element.upper)
    finite = sorted(m for m in (m_lo, m_up) if math.isfinite(m))
    if not finite or ev.relative_velocity <= 0:
        return
    m2 = finite[0]  # the struck (lighter) mass; the other is the driver
    m1 = finite[1] if len(finite) > 1 else math.inf
    v = ev.relative_velocity
    try:
        if isinstance(element, PreloadedLink):
            lower, upper = johnson_bounds("linear", m1, m2, v, 0.0, stiffness=element.push_stiffness)
        elif element.law == "linear":
            lower, upper = johnson_bounds("linear", m1, m2, v, 0.0, stiffness=element.stiffness)
        elif element.law == "power":
            lower, upper = johnson_bounds("power", m1, m2, v, 0.0, coefficient=element.coefficient, exponent=element.exponent)
        else:
            lower = upper = math.inf  # a rigid stop: an impulse, no finite peak
    except InputError:
        return
    ev.johnson_lower, ev.johnson_upper = float(lower), float(upper)
    end_kind = "separation" if isinstance(element, PreloadedLink) else "release"
    t_close = ev.time
    t_open = next((e.time - t_rec for e in later if e.element == element.name and e.kind == end_kind), None)
    if t_open is not None:
        ev.contact_duration = t_open - t_close
    t_stop = t_open if t_open is not None else time[-1] + 1e-12
    window = (time >= t_close - 1e-12) & (time <= t_stop + 1e-12)
    if isinstance(element, Contact) and element.law == "restitution":
        return
    force = element_forces[element.name][window]
    if isinstance(element, PreloadedLink):
        force = element.preload - force  # compression at the interface of the two parts
    if force.size:
        ev.peak_force = _peak(force)


def _peak(samples: np.ndarray) -> float:
    """Largest value of a sampled smooth pulse, refined by the parabola through the top
    three samples (a contact a few samples long would otherwise lose up to a few % of its
    peak between samples)."""
    k = int(np.argmax(samples))
    top = float(samples[k])
    if 0 < k < samples.size - 1:
        left, right = float(samples[k - 1]), float(samples[k + 1])
        curvature = left - 2.0 * top + right
        if curvature < 0.0:
            return top - 0.125 * (right - left) ** 2 / curvature
    return top


def _jump_rows(cam, time, cam_force, t_rec, driven) -> list[Event]:
    rows = []
    negative = cam_force < 0
    starts = np.flatnonzero(negative[1:] & ~negative[:-1]) + 1
    if negative[0]:
        starts = np.concatenate([[0], starts])
    for k in starts:
        if k == 0:
            t_cross = time[0]
        else:
            f0, f1 = cam_force[k - 1], cam_force[k]
            t_cross = time[k - 1] + (time[k] - time[k - 1]) * f0 / (f0 - f1)
        ev = Event(time=float(t_cross), element="cam", kind="jump", masses=f"cam/{driven}")
        ev.angle_deg = float(np.degrees(cam.angle(np.array([t_cross]))[0]))
        rows.append(ev)
    return rows


def _residual(model: Model, saved: dict, stops, result: RunResult) -> float:
    """Largest change over one revolution of the free masses' state, relative to each peak."""
    if len(stops) != 2 or model.n == 0:
        return float("nan")
    before, after = (saved.get(round(s, 9)) for s in stops)
    if before is None or after is None:
        return float("nan")
    worst = 0.0
    for name in model.free_names:
        k = model.index[name]
        for quantity, b, a in (("displacement", before.x, after.x), ("velocity", before.v, after.v)):
            peak = float(np.max(np.abs(result.masses[name][quantity]))) or 1.0
            worst = max(worst, abs(a[k] - b[k]) / peak)
    return worst

"""From recorded stretches to traces, events and a RunResult (both assembly paths).

:func:`stretch_samples` and :func:`sample_traces` turn a stretch's grid points into output
samples and traces, used alike by the in-memory path (:func:`_assemble`) and the streaming
one (:mod:`camsim.run.stream`), so both give the same bits; :func:`johnson_annotate` puts
Johnson's bounds on an impact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from camsim.cam.program import CamProgram
from camsim.errors import InputError, SimulationError
from camsim.elements.events import Event, EventTable
from camsim.elements import CAM, GROUND
from camsim.engine.integrator import Integrator, State, Stretch
from camsim.machine.description import Machine
from camsim.model.assembly import Model
from camsim.run.result import RunResult


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

"""From recorded stretches to traces, events, located extremes and a RunResult (in memory).

The samples come from :mod:`camsim.run.samples`, the located extremes and impact peaks from
:mod:`camsim.run.extremes`, by the same code the streamed path (:mod:`camsim.run.stream`)
uses, so both give the same bits.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from camsim.errors import SimulationError
from camsim.elements.affine import N_INPUT
from camsim.elements.events import Event, EventTable
from camsim.engine.integrator import State, Stretch
from camsim.run.extremes import ExtremesFolder, digest, ingest_event, johnson_annotate  # noqa: F401 - johnson_annotate: also this module's
from camsim.run.result import RunResult
from camsim.run.samples import RunSetup, sample_traces, stretch_samples  # noqa: F401 - also this module's names


def after_run_warnings(machine, events) -> list[str]:
    """Rods that saw impacts too fast for their segments; Hertz contacts past yield (camsim.run.checks);
    a compensated cam whose assumptions the run broke (issue 35: a path contact opened...)."""
    from camsim.machine.compensation import assumption_warnings
    from camsim.run.checks import contact_stress_rows, rod_warnings, stress_warnings

    return (rod_warnings(machine, events) + stress_warnings(contact_stress_rows(machine, events))
            + assumption_warnings(machine, events))


def period_end(run: RunSetup, state: State) -> dict | None:
    """The cam force and camshaft torque at the exact state ``state`` (the end of the first
    recorded revolution): ``{"time": t [s, recorded clock], "cam_force": Fc [N], "torque": T
    [N*m]}``, through the same force code as the samples; None without a cam force."""
    from camsim.cam.design import camshaft_torque

    model, integrator = run.model, run.integrator
    t = np.array([state.t])
    u = integrator.inputs(t)
    config = model.configuration(state.branches, state.holds)
    z = config.state_from_input(state.x, state.v, u[0])[None, :]
    fn = integrator.nonlinear_forces(config, z, u, state.v_impacts)
    x, v, a = config.x(z, u, fn), config.v(z, u, fn), config.a(z, u, fn)
    lam = config.lam(z, u, fn)
    forces = model.element_forces(state.branches, x, v, u[:, 0::N_INPUT], u[:, 1::N_INPUT], lam, config, state.v_impacts, u=u)
    kw = sample_traces(run, t - run.t_rec, x, v, a, u, forces)
    probe = RunResult(machine=run.machine, events=[], periodicity_residual=float("nan"), **kw)
    out = {"time": float(state.t - run.t_rec)}
    from camsim.run.camshaft import active, drive_power, shaft_power

    if active(run.machine):  # issue 38: the power into the stations and the drive's there
        out["power"] = float(shaft_power(probe)[0])
        out["drive_power"] = float(drive_power(probe)[0])
    force = probe.cam_force
    if force is None:
        return out if "power" in out else None
    torque = camshaft_torque(force, u[:, 1], run.cam.speed)
    out.update(cam_force=float(force[0]), torque=float(torque[0]))
    return out


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
        _, samples = digest(run, st)
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
    machine, warnings = run.machine, run.warnings
    events, located = fold_events_and_extremes(run, stretches)
    warnings += after_run_warnings(machine, events)  # issue 39: rods vs impacts, contacts vs yield
    cam_force_warnings(run, events, located, traces, time)
    result = RunResult(
        machine=machine, **traces, events=events,
        periodicity_residual=float("nan"), warnings=warnings, no_impact=run.no_impact,
        boundaries_deg=boundaries_deg(run), located=located,
        load_work=run.load_work.values() if run.load_work is not None else None,  # issue 43
        friction_energy=run.friction_work.values() if run.friction_work is not None else None,
    )
    if machine.clearances:  # issue 38: a collision of two stations' parts is a warning row
        from camsim.run.camshaft import CamshaftAccumulator

        probe = CamshaftAccumulator(machine)
        probe.add(result)
        warnings.extend(probe.warnings())
    return result


def assemble_summary(run: RunSetup, stretches: list[Stretch]) -> RunResult:
    """A result that holds the run's summary without its traces: the events, the located
    extremes and what follows from them (:func:`_assemble` without the samples; the
    scalars-only evaluation, camsim.run.evaluation)."""
    from camsim.run.samples import empty_traces

    for st in stretches:
        digest(run, st, samples=False)
    events, located = fold_events_and_extremes(run, stretches)
    run.warnings.extend(after_run_warnings(run.machine, events))
    traces = empty_traces(run)
    cam_force_warnings(run, events, located, traces, traces["time"])
    return RunResult(machine=run.machine, **traces, events=events, periodicity_residual=float("nan"),
                     warnings=run.warnings, no_impact=run.no_impact, boundaries_deg=boundaries_deg(run), located=located,
                     load_work=run.load_work.values() if run.load_work is not None else None,
                     friction_energy=run.friction_work.values() if run.friction_work is not None else None)


def cam_force_warnings(run: RunSetup, events, located, traces: dict, time: np.ndarray) -> None:
    """The warning of every driven mass whose cam contact force goes negative (several cams:
    each its own, issue 38), from its located minimum (its samples where it was not
    located); the events sorted by time (the jump rows come with the integrator's events,
    camsim.engine.watch, located on the exact solution like every other)."""
    model, machine = run.model, run.machine
    cam_force = traces["cam_contact_force"]
    forces_by_mass = ({model.driven: ("cam_contact/force", cam_force)} if cam_force is not None else
                      {m: (f"cams/{model.cam_names[q]}/contact_force", traces["cam_contact_forces"][model.cam_names[q]])
                       for m, q in model.drives.items()} if machine.multi_cam else {})
    if not forces_by_mass:
        return
    events.sort(key=lambda e: e.time)
    for driven, (path, force) in forces_by_mass.items():
        low = located.get(path, {}).get("min") if located else None
        if low is not None and low.value < 0:
            run.warnings.append(negative_cam_force_warning(driven, low.value, low.time))
        elif low is None and force.size and np.min(force) < 0:
            k = int(np.argmin(force))
            run.warnings.append(negative_cam_force_warning(driven, force[k], time[k]))


def recorded_event(run: RunSetup, raw: Event) -> Event:
    """The output row of one integrator event: on the recorded clock, with its cam angle."""
    ev = replace(raw, time=raw.time - run.t_rec)
    ev.angle_deg = event_angle(run, ev.time)
    return ev


def event_angle(run: RunSetup, t: float) -> float:
    """The cam angle of an event at output time t [deg]: the cam's (the shaft's with several
    cams, issue 38; a dynamic shaft's own drive angle); NaN without a cam."""
    if run.machine.cam is None:
        return float("nan")
    dynamics = getattr(run.cam, "dynamics", None)
    if dynamics is not None:
        back = 2.0 * np.pi * round(run.t_rec / run.period) if run.period else 0.0
        return float(np.degrees(dynamics.drive_angle(np.array([t + run.t_rec]))[0] - back))
    return float(np.degrees(run.cam.angle(np.array([t]))[0]))


def fold_events_and_extremes(run: RunSetup, stretches: list[Stretch]) -> tuple[EventTable, dict | None]:
    """The recorded event table (Johnson's bounds, located peak force and contact duration of
    every impact) and the run's located extremes (:meth:`ExtremesFolder.finish`; None when
    the run observed nothing), folding events and stretches in time order."""
    t_rec, t_end = run.t_rec, run.t_end
    raw = [e for e in run.integrator.events if t_rec - 1e-12 <= e.time <= t_end + 1e-12]
    folder = ExtremesFolder(run.observables, t_rec) if run.observables is not None else None
    events = EventTable()
    k = 0

    def ingest(until: float) -> None:
        nonlocal k
        while k < len(raw) and raw[k].time <= until:
            ev = recorded_event(run, raw[k])
            if folder is not None:
                ingest_event(folder, run.model, ev, raw[k].time)
            else:
                johnson_annotate(run.model, ev)
            events.append(ev)
            k += 1

    for st in stretches:
        if st.extremes is None:
            continue
        ingest(st.extremes.t1 + 1e-12)
        folder.add(st.extremes)
    ingest(np.inf)
    located = folder.finish() if folder is not None else None
    return events, located


def refined_peak(left: float, top: float, right: float) -> float:
    """The top of the parabola through three samples around a sampled maximum ``top``
    (``top`` itself when they do not curve down)."""
    curvature = left - 2.0 * top + right
    if curvature < 0.0:
        return top - 0.125 * (right - left) ** 2 / curvature
    return top

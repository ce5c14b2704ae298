"""A run's setup and the samples of its stretches: the code every trace and extreme goes through.

:func:`stretch_samples` turns a stretch's grid points into output samples and
:func:`sample_traces` the samples into traces, for the in-memory path
(:func:`camsim.run.assemble._assemble`) and the streamed one (:mod:`camsim.run.stream`) alike;
:func:`derived_traces` is the part the located extremes evaluate too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from camsim.cam.program import CamProgram
from camsim.elements.affine import N_INPUT
from camsim.engine.integrator import Integrator, Stretch
from camsim.machine.description import Machine
from camsim.model.assembly import Model


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
    observables : Observables or None
        What the engine observes for located extremes.
    """

    machine: Machine
    model: Model
    cam: CamProgram  # or a CamshaftInput (several cams, issue 38)
    integrator: Integrator
    t_rec: float
    t_end: float
    h_out: float
    warnings: list
    no_impact: bool
    period: float | None
    #: The observables whose extremes the engine locates (camsim.run.extremes.Observables;
    #: None: not observed).
    observables: object = None
    #: Each load's work over the first recorded revolution, accumulated stretch by stretch
    #: (camsim.run.loads.LoadWork; None without loads, issue 43).
    load_work: object = None
    #: Each friction pair's dissipated energy (camsim.run.friction.FrictionWork; None without pairs).
    friction_work: object = None


def node_quantities(run: RunSetup, st: Stretch, rows=slice(None)):
    """Positions, velocities, accelerations of the free masses and every element's force
    at nodes ``rows`` of a stretch: ``(x, v, a, forces)``, each (N, ·) [SI]. The traces and
    the located extremes both read these (one evaluation per node)."""
    z, u, fn = st.z[rows], st.u[rows], st.fn[rows]
    config = st.config
    x = config.x(z, u, fn)
    v = config.v(z, u, fn)
    a = config.a(z, u, fn)
    lam = config.lam(z, u, fn)
    forces = run.model.element_forces(st.branches, x, v, u[:, 0::N_INPUT], u[:, 1::N_INPUT], lam, config, st.v_impacts, u=u)
    return x, v, a, forces


def sample_rows(run: RunSetup, st: Stretch) -> np.ndarray:
    """The nodes of a stretch that are output samples: its samples on the output grid, up
    to the end of the record."""
    rows = np.arange(st.t.size) if st.samples is None else np.flatnonzero(st.samples)
    integ = run.integrator
    if rows.size and integ is not None and integ.t_ref == run.t_rec and abs(integ.h - run.h_out) <= 1e-12 * run.h_out:
        # the grid is the output grid (one step per sample): every sample is one, to the end
        stop = int(np.searchsorted(st.t[rows], run.t_end + 1e-9 * run.h_out, side="right"))
        return rows[:stop]
    t = st.t[rows]
    k = (t - run.t_rec) / run.h_out
    keep = (np.abs(k - np.round(k)) < 1e-6) & (t <= run.t_end + 1e-9 * run.h_out)
    return rows[keep]


def take_rows(arr: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``arr[rows]`` for ascending rows, by contiguous runs where there are few (a stretch's
    samples are all its nodes but the few at its breaks and its end: copies of slices, not
    a gather)."""
    if rows.size < 64:
        return arr[rows]
    cuts = np.flatnonzero(np.diff(rows) != 1) + 1
    if cuts.size > 32:
        return arr[rows]
    starts = np.concatenate([[0], cuts])
    ends = np.concatenate([cuts, [rows.size]])
    if starts.size == 1:
        return arr[rows[0] : rows[-1] + 1]
    return np.concatenate([arr[rows[a] : rows[b - 1] + 1] for a, b in zip(starts.tolist(), ends.tolist())])


def stretch_samples(run: RunSetup, st: Stretch, quantities=None):
    """The output-grid samples of one stretch: ``(t, x, v, a, u, forces)`` or None.

    ``t`` [s] on the simulation clock; x, v, a (N, n) of the free masses; u (N, 4·c) the
    cam input (s, ṡ, s̈, s⃛ of every cam); forces (N, elements) [N]. ``quantities``: the
    stretch's :func:`node_quantities` at every node, when the caller has them. Used by
    :func:`_assemble` and by the streaming assembler alike, so both give the same bits.
    """
    rows = sample_rows(run, st)
    if not rows.size:
        return None
    if quantities is None:
        x, v, a, forces = node_quantities(run, st, rows)
    else:
        x, v, a, forces = (take_rows(q, rows) for q in quantities)
    return take_rows(st.t, rows), x, v, a, take_rows(st.u, rows), forces


def derived_traces(run: RunSetup, x, v, a, u, forces) -> dict:
    """The per-mass, per-element, cam-contact and transducer traces of samples (the part of
    :func:`sample_traces` that the located extremes evaluate too, :mod:`camsim.run.extremes`):
    ``masses``, ``elements``, ``cam_contact_force``, ``transducer_force``, ``element_traces``,
    ``loads`` (each load's force, issue 43: it enters the cam contact force of a driven mass)."""
    machine, model = run.machine, run.model
    masses: dict[str, dict[str, np.ndarray]] = {}
    for name in machine.node_names:  # the masses, then the rods' interior nodes (issue 39)
        if name in model.drives:
            c = N_INPUT * model.drives[name]  # the channels of the cam that drives it (issue 38)
            masses[name] = {"displacement": u[:, c], "velocity": u[:, c + 1], "acceleration": u[:, c + 2]}
        else:
            k = model.index[name]
            masses[name] = {"displacement": x[:, k], "velocity": v[:, k], "acceleration": a[:, k]}
    elements = {e.name: forces[:, i] for i, e in enumerate(model.elements) if e.parent() is None}
    element_traces: dict[str, dict[str, np.ndarray]] = {}
    for name, compound in model.compounds.items():  # a rod: its end forces and largest stress (1-D each)
        element_traces[name] = compound.result_traces(forces[:, model.parts[name]])
    transducer_idx = [i for i, e in enumerate(model.elements) if getattr(e, "transducer", False)]
    transducer = forces[:, transducer_idx].sum(axis=1) if transducer_idx else None
    loads = model.load_values(u) if model.n_loads else None
    out = {"masses": masses, "elements": elements, "transducer_force": transducer, "element_traces": element_traces,
           "loads": {load.name: loads[:, k] for k, load in enumerate(model.loads)} if loads is not None else {}}
    if machine.multi_cam:  # issue 38: each cam's contact force on the mass it drives
        out["cam_contact_force"] = None
        out["cam_contact_forces"] = {model.cam_names[q]: model.cam_contact_force(forces, u[:, N_INPUT * q + 2], driven,
                                                                                 loads)
                                     for driven, q in model.drives.items()}
    else:
        out["cam_contact_force"] = model.cam_contact_force(forces, u[:, 2], loads=loads)
    return out


def sample_traces(run: RunSetup, time, x, v, a, u, forces) -> dict:
    """The traces of a run (or of a stretch of it) from its samples (element by element,
    so any split of the samples gives the same bits): keyword arguments of
    :class:`RunResult` ``time``, ``cam``, ``masses``, ``elements``,
    ``cam_contact_force``, ``transducer_force``, ``element_traces``."""
    machine, cam = run.machine, run.cam
    dynamics = getattr(cam, "dynamics", None)  # issue 38: a dynamic camshaft's solution
    if dynamics is None and not machine.multi_cam:
        # Cam angle on the recorded time base: θ0 + ω·t, t = 0 at the first recorded cycle.
        angle = np.degrees(cam.angle(time)) if machine.cam is not None else np.zeros_like(time)
        cam_traces = {"angle": angle, "displacement": u[:, 0], "velocity": u[:, 1], "acceleration": u[:, 2], "jerk": u[:, 3]}
        return {"time": time, "cam": cam_traces, **derived_traces(run, x, v, a, u, forces)}
    return {"time": time, **camshaft_traces(run, time, u), **derived_traces(run, x, v, a, u, forces)}


def empty_traces(run: RunSetup) -> dict:
    """:func:`sample_traces` of no samples: every trace of the run, empty (a result that
    holds its summary only)."""
    n, n_el = run.model.n, len(run.model.elements)
    z = np.zeros((0, n))
    return sample_traces(run, np.zeros(0), z, z, z, np.zeros((0, run.model.n_input)), np.zeros((0, n_el)))


def camshaft_traces(run: RunSetup, time, u) -> dict:
    """Several cams, or a dynamic camshaft (issue 38): every cam's traces (``cam`` the first's,
    ``cams`` all of them), the shaft's angle, and a dynamic shaft's speeds and drive torque.
    Angles are on the recorded clock, continuing from the start angle at output time 0."""
    machine, model, cam = run.machine, run.model, run.cam
    dynamics = getattr(cam, "dynamics", None)
    out: dict = {}
    if dynamics is not None:
        t_sim, back = time + run.t_rec, 2.0 * np.pi * round(run.t_rec / run.period) if run.period else 0.0
        out = {"shaft_angle": np.degrees(dynamics.drive_angle(t_sim) - back),
               "shaft_speed": dynamics.drive_speed(t_sim), "drive_torque": dynamics.drive_torque(t_sim),
               "cam_speeds": {name: dynamics.cam_speed(q, t_sim) for q, name in enumerate(model.cam_names)}}

        def angle_of(q):
            return np.degrees(cam.cam_angle(q, t_sim) - back)
    else:
        out["shaft_angle"] = np.degrees(cam.angle(time))

        def angle_of(q):
            return np.degrees(cam.cam_angle(q, time))
    cams = {}
    for q, name in enumerate(model.cam_names):
        c = N_INPUT * q
        cams[name] = {"angle": angle_of(q), "displacement": u[:, c], "velocity": u[:, c + 1],
                      "acceleration": u[:, c + 2], "jerk": u[:, c + 3]}
    out["cam"] = cams[model.cam_names[0]]
    if machine.multi_cam:
        out["cams"] = cams
    return out

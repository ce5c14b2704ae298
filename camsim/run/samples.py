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
    cam: CamProgram
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


def derived_traces(run: RunSetup, x, v, a, u, forces) -> dict:
    """The per-mass, per-element, cam-contact and transducer traces of samples (the part of
    :func:`sample_traces` that the located extremes evaluate too, :mod:`camsim.run.extremes`):
    ``masses``, ``elements``, ``cam_contact_force``, ``transducer_force``, ``element_traces``."""
    machine, model = run.machine, run.model
    masses: dict[str, dict[str, np.ndarray]] = {}
    for name in machine.node_names:  # the masses, then the rods' interior nodes (issue 39)
        if name == model.driven:
            masses[name] = {"displacement": u[:, 0], "velocity": u[:, 1], "acceleration": u[:, 2]}
        else:
            k = model.index[name]
            masses[name] = {"displacement": x[:, k], "velocity": v[:, k], "acceleration": a[:, k]}
    elements = {e.name: forces[:, i] for i, e in enumerate(model.elements) if e.parent() is None}
    element_traces: dict[str, dict[str, np.ndarray]] = {}
    for name, compound in model.compounds.items():  # a rod: its end forces and largest stress (1-D each)
        element_traces[name] = compound.result_traces(forces[:, model.parts[name]])
    cam_force = model.cam_contact_force(forces, u[:, 2])
    transducer_idx = [i for i, e in enumerate(model.elements) if getattr(e, "transducer", False)]
    transducer = forces[:, transducer_idx].sum(axis=1) if transducer_idx else None
    return {"masses": masses, "elements": elements, "cam_contact_force": cam_force, "transducer_force": transducer,
            "element_traces": element_traces}


def sample_traces(run: RunSetup, time, x, v, a, u, forces) -> dict:
    """The traces of a run (or of a stretch of it) from its samples (element by element,
    so any split of the samples gives the same bits): keyword arguments of
    :class:`RunResult` ``time``, ``cam``, ``masses``, ``elements``,
    ``cam_contact_force``, ``transducer_force``, ``element_traces``."""
    machine, cam = run.machine, run.cam
    # Cam angle on the recorded time base: θ0 + ω·t, t = 0 at the first recorded cycle.
    angle = np.degrees(cam.angle(time)) if machine.cam is not None else np.zeros_like(time)
    cam_traces = {"angle": angle, "displacement": u[:, 0], "velocity": u[:, 1], "acceleration": u[:, 2], "jerk": u[:, 3]}
    return {"time": time, "cam": cam_traces, **derived_traces(run, x, v, a, u, forces)}

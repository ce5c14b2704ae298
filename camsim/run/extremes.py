"""The located extremes of a run: what is observed, and how the stretches' extremes add up.

The engine locates, per stretch, the maximum and minimum of every observable on the
continuous solution (:mod:`camsim.engine.extremes`). This module says what the observables
are — :class:`Observables`, computed from the state by the same code as the traces
(:func:`camsim.run.samples.derived_traces`, which :func:`camsim.run.samples.sample_traces` calls),
so a figure reported in two places is one number — and folds the stretches' records into
the run's extremes and each impact's peak force (:class:`ExtremesFolder`), for the in-memory
and the streamed run alike.
"""

from __future__ import annotations

import math
import numpy as np

from camsim.errors import InputError
from camsim.elements import CAM, GROUND
from camsim.elements.events import Event
from camsim.engine.extremes import StretchExtremes
from camsim.model.assembly import Model
from camsim.run.samples import RunSetup, derived_traces
from camsim.run.result import MASS_QUANTITIES, QUANTITY_UNITS, Extreme

#: The pseudo-path of the cam force when the cam acts through contact elements (the sum of
#: their forces, :attr:`camsim.run.result.RunResult.cam_force`).
CAM_FORCE = "cam_force"


class Observables:
    """The quantities whose extremes a run reports, as columns evaluated from the state.

    ``paths`` are result paths (``masses/<m>/<quantity>``, ``elements/<e>/force``,
    ``cam_contact/force``, ``transducer/force``, ``camshaft/torque``) and :data:`CAM_FORCE`.
    """

    def __init__(self, run: RunSetup):
        self.run = run
        model, machine = run.model, run.machine
        paths = [f"masses/{name}/{q}" for name in machine.node_names for q in MASS_QUANTITIES]
        #: the elements of the machine (a rod's segments are parts of it: its traces instead)
        self.elements = [i for i, e in enumerate(model.elements) if e.parent() is None]
        paths += [f"elements/{model.elements[i].name}/force" for i in self.elements]
        self.compound_traces = [(name, q) for name, compound in model.compounds.items()
                                for q in compound.result_quantities]
        paths += [f"elements/{name}/{q}" for name, q in self.compound_traces]
        self.has_cam_contact = bool(model.driven)
        if self.has_cam_contact:
            paths.append("cam_contact/force")
        self.transducer = [i for i, e in enumerate(model.elements) if getattr(e, "transducer", False)]
        if self.transducer:
            paths.append("transducer/force")
        self.cam_contacts = [i for i, e in enumerate(model.elements) if e.unilateral and CAM in e.nodes]
        if not self.has_cam_contact and self.cam_contacts:
            paths.append(CAM_FORCE)
        geometry = getattr(machine.cam, "geometry", None) if machine.cam is not None else None
        self.torque_speed = float(run.cam.speed) if geometry is not None and self.has_cam_contact else None
        if self.torque_speed is not None:
            paths.append("camshaft/torque")
        self.paths = paths
        self.index = {p: k for k, p in enumerate(paths)}

    def __call__(self, config, branches, v_impacts, Z: np.ndarray, U: np.ndarray) -> np.ndarray:
        """The observables at states Z (N, m) with inputs U (N, 4): (N, len(paths))."""
        run = self.run
        integrator, model = run.integrator, run.model
        fn = integrator.nonlinear_forces(config, Z, U, v_impacts)
        x, v, a = config.x(Z, U, fn), config.v(Z, U, fn), config.a(Z, U, fn)
        lam = config.lam(Z, U, fn)
        forces = model.element_forces(branches, x, v, U[:, 0], U[:, 1], lam, config, v_impacts)
        traces = derived_traces(run, x, v, a, U, forces)
        cols = [traces["masses"][name][q] for name in run.machine.node_names for q in MASS_QUANTITIES]
        cols += [forces[:, i] for i in self.elements]
        cols += [traces["element_traces"][name][q] for name, q in self.compound_traces]
        if self.has_cam_contact:
            cols.append(traces["cam_contact_force"])
        if self.transducer:
            cols.append(traces["transducer_force"])
        if not self.has_cam_contact and self.cam_contacts:
            cols.append(np.sum(forces[:, self.cam_contacts], axis=1))
        if self.torque_speed is not None:
            from camsim.cam.design import camshaft_torque

            cols.append(camshaft_torque(traces["cam_contact_force"], U[:, 1], self.torque_speed))
        return np.column_stack(cols) if cols else np.zeros((Z.shape[0], 0))


def observable_units(path: str) -> str:
    """The SI unit of an observable (a result path, or :data:`CAM_FORCE`)."""
    if path.startswith("masses/"):
        return QUANTITY_UNITS[path.rsplit("/", 1)[1]]
    if path == "camshaft/torque":
        return "N*m"
    if path.endswith("/max_stress"):
        return "Pa"
    return "N"


def fold_best(records, j: int, sense: int, best: tuple[float, float] | None) -> tuple[float, float] | None:
    """The located maximum (sense +1) or minimum (−1) of observable ``j`` over ``records``
    and ``best`` (a value and time found before, or None): the record with the best node
    value first, whose located value then prunes the others by their screening bounds (in
    time order, every record would be refined until the best so far is high). Ties keep the
    earlier time (the first occurrence, as ``argmax``)."""
    nodes = [(sense * float(r.node_max[j] if sense > 0 else r.node_min[j]), r.t0) for r in records]
    for k in sorted(range(len(records)), key=lambda k: (-nodes[k][0], nodes[k][1])):
        r = records[k]
        if best is not None and sense * r.bound(j, sense) <= sense * best[0]:
            continue
        value, t = r.extreme(j, sense)
        if best is None or sense * value > sense * best[0] or (value == best[0] and t < best[1]):
            best = (value, t)
    return best


class _Window:
    """One impact's contact window: the located extremes of its element's force in it."""

    def __init__(self, event, element, column: int, t_close: float):
        self.event, self.element, self.column = event, element, column
        self.t_close = t_close
        self.t_open = math.inf
        self.records: list[StretchExtremes] = []

    def add(self, record: StretchExtremes) -> None:
        if record.t0 < self.t_close - 1e-12 or record.t1 > self.t_open + 1e-12:
            return
        self.records.append(record)

    def finish(self, t_rec: float) -> None:
        """Set the event's located peak force and its instant (the element's own measure of
        an impact's force: :meth:`~camsim.elements.base.Element.impact_force`)."""
        top = fold_best(self.records, self.column, 1, None)
        bottom = fold_best(self.records, self.column, -1, None)
        self.records = []
        if top is None or bottom is None:
            return
        measure = self.element.impact_force(np.array([top[0], bottom[0]]))
        if measure is None:
            return
        k = int(np.argmax(measure))
        self.event.peak_force = float(measure[k])
        self.event.peak_time = float((top, bottom)[k][1] - t_rec)


#: Records held before they are folded into the run's extremes (bounded memory in long
#: streamed runs; a revolution of the CDTM is about a dozen).
BUFFER = 256


class ExtremesFolder:
    """Folds the stretches' records into the run's located extremes and impact peaks.

    Records arrive in time order (:meth:`add`); impacts open a window on their element's
    force (:meth:`open_impact`), its release closes it (:meth:`close_impact`). A record is
    refined only where its screening bound could beat the best value so far, so most
    stretches cost their node screen alone.
    """

    def __init__(self, observables: Observables, t_rec: float):
        self.observables = observables
        self.t_rec = t_rec
        n = len(observables.paths)
        self.best: dict[int, list[tuple[float, float] | None]] = {1: [None] * n, -1: [None] * n}
        self.windows: list[_Window] = []
        self._waiting: list[StretchExtremes] = []

    def open_impact(self, event, element, t_close: float) -> None:
        """An impact at ``t_close`` [s, simulation clock] on ``element`` (its row ``event``)."""
        column = self.observables.index.get(f"elements/{element.name}/force")
        if column is not None:
            self.windows.append(_Window(event, element, column, t_close))

    def close_impact(self, element_name: str, kind, t_open: float) -> None:
        """An event of ``kind`` on ``element_name`` at ``t_open`` [s]: it ends the open window
        of that element when it is the element's closing end (a contact's release, a link's
        separation); the impact's contact duration is then known."""
        for w in self.windows:
            if w.t_open == math.inf and w.element.name == element_name and kind == w.element.closing_ends:
                w.t_open = t_open
                w.event.contact_duration = t_open - w.t_close

    def add(self, record: StretchExtremes | None) -> None:
        """Fold one stretch's record (the run's extremes once :data:`BUFFER` records are
        waiting, or at :meth:`finish`; the impact windows at once)."""
        if record is None:
            return
        self._waiting.append(record)
        if len(self._waiting) >= BUFFER:
            self._fold_waiting()
        still = []
        for w in self.windows:
            w.add(record)
            if record.t1 >= w.t_open - 1e-12:
                w.finish(self.t_rec)
            else:
                still.append(w)
        self.windows = still

    def _fold_waiting(self) -> None:
        """The waiting records into the run's extremes (:func:`fold_best`)."""
        records, self._waiting = self._waiting, []
        for sense in (1, -1):
            best = self.best[sense]
            for j in range(len(best)):
                best[j] = fold_best(records, j, sense, best[j])

    def finish(self) -> dict[str, dict[str, Extreme]]:
        """The run's located extremes: path → {"max": Extreme, "min": Extreme} (recorded clock);
        windows still open (the contact outlasts the record) are closed at its end."""
        self._fold_waiting()
        for w in self.windows:
            w.finish(self.t_rec)
        self.windows = []
        out = {}
        for j, path in enumerate(self.observables.paths):
            top, bottom = self.best[1][j], self.best[-1][j]
            if top is None or bottom is None:
                continue
            out[path] = {"max": Extreme(top[0], top[1] - self.t_rec), "min": Extreme(bottom[0], bottom[1] - self.t_rec)}
        return out


def ingest_event(folder: ExtremesFolder, model, event, t_sim: float) -> None:
    """One recorded event (its output row ``event``, already shifted, at ``t_sim`` on the
    simulation clock): Johnson's bounds on an impact and a window for its peak force; the
    end of an open window. Both assembly paths call this, in time order."""
    folder.close_impact(event.element, event.kind, t_sim)
    if event.kind.is_impact:
        element = johnson_annotate(model, event)
        if element is not None:
            folder.open_impact(event, element, t_sim)


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

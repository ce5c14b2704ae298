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
from camsim.heartbeat import working
from camsim.elements import CAM, GROUND
from camsim.elements.affine import N_INPUT
from camsim.elements.events import Event
from camsim.engine.extremes import TIE, StretchExtremes
from camsim.model.assembly import Model
from camsim.run.samples import RunSetup, derived_traces
from camsim.run.result import MASS_QUANTITIES, QUANTITY_UNITS, Extreme

#: The pseudo-path of the cam force when the cam acts through contact elements (the sum of
#: their forces, :attr:`camsim.run.result.RunResult.cam_force`).
CAM_FORCE = "cam_force"


class Observables:
    """The quantities whose extremes a run reports, as columns evaluated from the state.

    ``paths`` are result paths (``masses/<m>/<quantity>``, ``elements/<e>/force``,
    ``cam_contact/force``, ``transducer/force``, ``camshaft/torque``; with several cams
    ``cams/<name>/contact_force`` and ``cams/<name>/torque``) and :data:`CAM_FORCE`.
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
        #: issue 43: each load's force (an input; its extremes located like every other)
        self.loads = [load.name for load in model.loads]
        paths += [f"loads/{name}/force" for name in self.loads]
        multi = machine.multi_cam
        self.has_cam_contact = bool(model.driven) and not multi
        if self.has_cam_contact:
            paths.append("cam_contact/force")
        self.transducer = [i for i, e in enumerate(model.elements) if getattr(e, "transducer", False)]
        if self.transducer:
            paths.append("transducer/force")
        self.cam_contacts = [i for i, e in enumerate(model.elements) if e.unilateral and CAM in e.nodes and not multi]
        if not self.has_cam_contact and self.cam_contacts:
            paths.append(CAM_FORCE)
        from camsim.run import camshaft

        # issue 38: each station's cam force; the shaft's torques (a rigid shaft's: a dynamic
        # one's θ̇ is not a function of the state, its torques are read off the samples)
        self.stations = [name for name in model.cam_names
                         if name in {model.cam_names[q] for q in model.drives.values()}
                         or any(e.unilateral and name in e.nodes for e in machine.elements)] if multi else []
        paths += [f"cams/{name}/contact_force" for name in self.stations]
        shaft = camshaft.active(machine)
        self.shaft_speed = (float(machine.cams[0].speed) if shaft and (machine.camshaft is None
                            or machine.camshaft.model == "rigid") else None)
        if self.shaft_speed is not None:
            paths.append("camshaft/torque")
            if multi:
                paths += [f"cams/{name}/torque" for name in model.cam_names]
        geometry = getattr(machine.cam, "geometry", None) if machine.cam is not None else None
        self.torque_speed = (float(run.cam.speed) if geometry is not None and self.has_cam_contact and not shaft
                             else None)
        if self.torque_speed is not None:
            paths.append("camshaft/torque")
        self.paths = paths
        self.index = {p: k for k, p in enumerate(paths)}

    def __call__(self, config, branches, v_impacts, Z: np.ndarray, U: np.ndarray) -> np.ndarray:
        """The observables at states Z (N, m) with inputs U (N, 4·c): (N, len(paths))."""
        run = self.run
        integrator, model = run.integrator, run.model
        fn = integrator.nonlinear_forces(config, Z, U, v_impacts)
        x, v, a = config.x(Z, U, fn), config.v(Z, U, fn), config.a(Z, U, fn)
        lam = config.lam(Z, U, fn)
        forces = model.element_forces(branches, x, v, U[:, 0::N_INPUT], U[:, 1::N_INPUT], lam, config, v_impacts, u=U)
        return self.columns(x, v, a, U, forces)

    def columns(self, x, v, a, U: np.ndarray, forces) -> np.ndarray:
        """The observables from the nodes' quantities (:func:`camsim.run.samples.node_quantities`)
        and inputs: (N, len(paths))."""
        cols = self._columns(x, v, a, U, forces)
        return np.column_stack(cols) if cols else np.zeros((x.shape[0], 0))

    def rows(self, x, v, a, U: np.ndarray, forces) -> np.ndarray:
        """:meth:`columns` transposed, one contiguous row per observable: (len(paths), N)."""
        cols = self._columns(x, v, a, U, forces)
        return np.stack(cols) if cols else np.zeros((0, x.shape[0]))

    def _columns(self, x, v, a, U: np.ndarray, forces) -> list:
        run = self.run
        traces = derived_traces(run, x, v, a, U, forces)
        cols = [traces["masses"][name][q] for name in run.machine.node_names for q in MASS_QUANTITIES]
        cols += [forces[:, i] for i in self.elements]
        cols += [traces["element_traces"][name][q] for name, q in self.compound_traces]
        cols += [traces["loads"][name] for name in self.loads]
        if self.has_cam_contact:
            cols.append(traces["cam_contact_force"])
        if self.transducer:
            cols.append(traces["transducer_force"])
        if not self.has_cam_contact and self.cam_contacts:
            cols.append(np.sum(forces[:, self.cam_contacts], axis=1))
        if self.stations or self.shaft_speed is not None:
            cols += self._camshaft_columns(traces, U)
        if self.torque_speed is not None:
            from camsim.cam.design import camshaft_torque

            cols.append(camshaft_torque(traces["cam_contact_force"], U[:, 1], self.torque_speed))
        return cols

    def _camshaft_columns(self, traces: dict, U: np.ndarray) -> list[np.ndarray]:
        """Each station's cam force, then the shaft's torque and each cam's (issue 38), by the
        code of the traces (:mod:`camsim.run.camshaft`)."""
        from camsim.run import camshaft

        model, machine = self.run.model, self.run.machine
        contact = traces.get("cam_contact_forces") or {}
        if not machine.multi_cam and traces["cam_contact_force"] is not None:
            contact = {machine.cams[0].name: traces["cam_contact_force"]}
        cols = [camshaft.station_force(machine, name, contact, traces["elements"]) for name in self.stations]
        if self.shaft_speed is not None:
            forces = camshaft.forces_on_cams(model, contact, traces["elements"], U.shape[0])
            torques = [forces[name] * U[:, N_INPUT * q + 1] / self.shaft_speed for q, name in enumerate(model.cam_names)]
            total = np.zeros(U.shape[0])
            for torque in torques:
                total = total + torque
            cols.append(total)
            if machine.multi_cam:
                cols += torques
        return cols


def digest(run: RunSetup, st, samples: bool = True):
    """One recorded stretch's located-extremes record
    (:func:`camsim.engine.extremes.stretch_extremes`) and its output samples, from one
    evaluation of its nodes' quantities: ``(record or None, samples or None)``
    (:func:`camsim.run.samples.stretch_samples`)."""
    from camsim.engine.extremes import stretch_extremes
    from camsim.run.samples import node_quantities, stretch_samples

    quantities = node_quantities(run, st)
    if run.load_work is not None:  # issue 43: each load's work, on the exact solution
        run.load_work.add(run.integrator, st)
    if run.friction_work is not None:  # each friction pair's dissipated energy, likewise
        run.friction_work.add(run.integrator, st)
    record = None
    if run.observables is not None:
        QT = run.observables.rows(*quantities[:3], st.u, quantities[3])
        record = stretch_extremes(run.integrator, st, QT, run.observables, (run.t_rec, run.t_end))
        st.extremes = record
    return record, stretch_samples(run, st, quantities) if samples else None


def observable_units(path: str) -> str:
    """The SI unit of an observable (a result path, or :data:`CAM_FORCE`)."""
    if path.startswith("masses/"):
        return QUANTITY_UNITS[path.rsplit("/", 1)[1]]
    if path == "camshaft/torque" or path.endswith("/torque"):
        return "N*m"
    if path.endswith("/max_stress"):
        return "Pa"
    return "N"


def magnitudes(records) -> np.ndarray:
    """Each observable's largest magnitude at the nodes of ``records`` (n_obs,); zeros
    without a record."""
    if not records:
        return np.zeros(0)
    return np.max(np.abs([(r.node_max, r.node_min) for r in records]), axis=(0, 1))


def fold(records, queries, before: dict, scale: np.ndarray) -> dict:
    """Located maxima (sense +1) and minima (−1) of observables over ``records`` and the
    heights found before (:func:`fold_jobs`, one job).

    Parameters
    ----------
    records : list of StretchExtremes
    queries : list of (int, int)
        (observable, sense) pairs.
    before : dict
        (observable, sense) → the (value, time) heights found before (may be absent).
    scale : ndarray (n_obs,)
        Each observable's magnitude.

    Returns
    -------
    dict
        (observable, sense) → the heights within the tie of the best (value, time).
    """
    return fold_jobs([(records, queries, before, scale)])[0]


def fold_jobs(jobs) -> list[dict]:
    """Several folds (``(records, queries, before, scale)`` each, as :func:`fold`) with one
    batched refinement for all of them.

    Values within the tie (:data:`~camsim.engine.extremes.TIE` of ``scale[j]``, the
    observable's magnitude over these records and those before) of the best are one height,
    of which :func:`earliest` is the one reported. A record is refined only where it can
    reach that height: its bound (a loose one first, known without a screen; then its
    screening bound) must come within the tie of the best node value there is. Every
    record's refinement for every query of every job is one batch
    (:func:`camsim.engine.extremes.refine_requests`): the run's extremes and the peaks of
    the impacts that ended meanwhile.
    """
    # which records each query must screen: those whose loose bound (known without a
    # screen) comes within the tie of the best node value there is
    passes, wanted = [], {}
    for n, (records, queries, before, scale) in enumerate(jobs):
        if not records:
            continue
        node_max = np.array([r.node_max for r in records])
        node_min = np.array([r.node_min for r in records])
        loose = [r.loose_bounds() for r in records]
        upper = np.array([up for up, _ in loose])
        lower = np.array([low for _, low in loose])
        for j, sense in queries:
            tie = TIE * float(scale[j])
            prior = [sense * v for v, _ in before.get((j, sense)) or []]
            nodes = node_max[:, j] if sense > 0 else -node_min[:, j]
            loose = upper[:, j] if sense > 0 else -lower[:, j]
            best = max(float(np.max(nodes)), max(prior, default=-np.inf))
            ks = np.flatnonzero(loose >= best - tie).tolist()
            for k in ks:
                wanted.setdefault(id(records[k]), (records[k], set()))[1].add((j, sense))
            passes.append((n, records, j, sense, tie, best, ks))
    # each record's columns screened together, both senses in one pass (the same bounds, bit
    # for bit, as column by column: engine/screen.py)
    for r, queries in wanted.values():
        working()  # each screen a step the stall watchdog sees (a chattering revolution has thousands)
        r.screen(sorted(queries))
    requests, owner = [], []
    for n, records, j, sense, tie, best, ks in passes:
        for k in ks:
            r = records[k]
            if sense * r.bound(j, sense) >= best - tie:
                requests.append((r, j, sense, tie))
                owner.append((n, j, sense))
    from camsim.engine.extremes import refine_requests

    found: dict = {}
    for key, value in zip(owner, refine_requests(requests)):
        found.setdefault(key, []).append(value)
    results = []
    for n, (records, queries, before, scale) in enumerate(jobs):
        out = {}
        for j, sense in queries:
            tie = TIE * float(scale[j])
            heights = list(before.get((j, sense)) or []) + found.get((n, j, sense), [])
            if heights:
                top = max(sense * v for v, _ in heights)
                heights = [(v, t) for v, t in heights if sense * v >= top - tie]
            out[(j, sense)] = heights
        results.append(out)
    return results


def earliest(heights: list[tuple[float, float]], sense: int = 1) -> tuple[float, float]:
    """The first instant among values of one height (:func:`fold`); of values at one instant
    (the two sides of an event: a contact's force at its release, and 0 N open), the extreme
    one (the larger for a maximum, ``sense`` +1; the smaller for a minimum, −1)."""
    return min(heights, key=lambda h: (h[1], -sense * h[0]))


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

    def job(self):
        """The fold of its records (:func:`fold_jobs`), or None without a record."""
        if not self.records:
            return None
        return self.records, [(self.column, 1), (self.column, -1)], {}, magnitudes(self.records)

    def finish(self, t_rec: float, found: dict | None = None) -> None:
        """Set the event's located peak force and its instant (the element's own measure of
        an impact's force: :meth:`~camsim.elements.base.Element.impact_force`), from its
        fold's result ``found`` (folded here when not given)."""
        if not self.records:
            return
        if found is None:
            found = fold(*self.job())
        tops, bottoms = found[(self.column, 1)], found[(self.column, -1)]
        self.records = []
        if not tops or not bottoms:
            return
        top, bottom = earliest(tops, 1), earliest(bottoms, -1)
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
        # per sense and observable: the located values of the best height (fold)
        self.best: dict[int, list[list[tuple[float, float]]]] = {1: [[] for _ in range(n)], -1: [[] for _ in range(n)]}
        self.scale = np.zeros(n)  # each observable's largest magnitude so far
        self.windows: list[_Window] = []
        self._closed: list[_Window] = []  # windows whose contact ended, folded with the run's next batch
        self._waiting: list[StretchExtremes] = []

    def open_impact(self, event, element, t_close: float) -> None:
        """An impact at ``t_close`` [s, simulation clock] on ``element`` (its row ``event``).

        No window for an impact without a finite peak (a rigid contact's: an impulse, no
        duration): it would never close, and a chattering rigid stop would keep every later
        stretch in memory and in every window's fold. A new impact on an element ends the
        element's window still open (its contact must have ended)."""
        column = self.observables.index.get(f"elements/{element.name}/force")
        if column is None or element.impact_force(np.zeros(1)) is None:
            return
        still = []
        for w in self.windows:
            if w.element.name == element.name:
                self._closed.append(w)
            else:
                still.append(w)
        self.windows = [*still, _Window(event, element, column, t_close)]

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
        still = []
        for w in self.windows:
            w.add(record)
            if record.t1 >= w.t_open - 1e-12:
                self._closed.append(w)
            else:
                still.append(w)
        self.windows = still
        if len(self._waiting) >= BUFFER:
            self._fold_waiting()

    def _fold_waiting(self) -> None:
        """The waiting records into the run's extremes, and the impact windows closed
        meanwhile into their peaks: one batch (:func:`fold_jobs`)."""
        records, self._waiting = self._waiting, []
        closed, self._closed = self._closed, []
        jobs, windows = [], []
        if records:
            self.scale = np.maximum(self.scale, magnitudes(records))
            n = len(self.best[1])
            queries = [(j, sense) for sense in (1, -1) for j in range(n)]
            jobs.append((records, queries, {(j, sense): self.best[sense][j] for j, sense in queries}, self.scale))
        for w in closed:
            job = w.job()
            if job is not None:
                jobs.append(job)
                windows.append(w)
        if not jobs:
            return
        results = fold_jobs(jobs)
        if records:
            found = results.pop(0)
            for j, sense in queries:
                self.best[sense][j] = found[(j, sense)]
        for w, found in zip(windows, results):
            w.finish(self.t_rec, found)

    def finish(self) -> dict[str, dict[str, Extreme]]:
        """The run's located extremes: path → {"max": Extreme, "min": Extreme} (recorded clock);
        windows still open (the contact outlasts the record) are closed at its end."""
        self._closed.extend(self.windows)
        self.windows = []
        self._fold_waiting()
        out = {}
        for j, path in enumerate(self.observables.paths):
            if not self.best[1][j] or not self.best[-1][j]:
                continue
            top, bottom = earliest(self.best[1][j], 1), earliest(self.best[-1][j], -1)
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
    if node == GROUND or node in model.cam_index or node in model.drives:
        return math.inf
    return model.machine.mass_of(node)


def johnson_annotate(model: Model, ev: Event):
    """Set Johnson's bounds of one impact; return its element when the impact is annotated
    further (peak force, contact duration), None when it is not (no finite mass, no
    approach, or no bounds for this element)."""
    element = model.elements[ev.element_index].acting(ev.branch)  # a lash's side: that side's law
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

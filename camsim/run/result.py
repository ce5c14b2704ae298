"""The run result: the hub every command, writer and plot reads.

:func:`camsim.run.simulation.simulate` returns a :class:`RunResult`; :func:`open_result` reads
the same object back from an HDF5 file. Every derived quantity (peaks, the cam force and
its extremes, the jump flag, impact summaries, the flat scalars of sweeps and studies) is
computed here, once, so ``run``, ``sweep``, ``compare``, ``study`` and ``fit`` cannot
disagree about it. The HDF5 layout (spec §7) is :meth:`RunResult.traces`: the writer
only iterates over it.

Adding an output quantity: compute it in :meth:`RunResult.traces` (a trace) or
:meth:`RunResult.scalars` (a number) with its units; the writers, ``--json``, sweeps,
studies and fits pick it up from there.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from camsim.errors import ResultFileError
from camsim.elements.events import Event, EventKind, EventTable
from camsim.machine.description import Machine
from camsim.run.checks import contact_stress_rows, rod_rows

#: SI units of the per-mass kinematic quantities.
QUANTITY_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2", "jerk": "m/s^3"}
MASS_QUANTITIES = ("displacement", "velocity", "acceleration")

#: Scalars of every run after the per-mass peaks, with their SI units.
FIXED_SCALARS: tuple[tuple[str, str], ...] = (
    ("peak_transducer_force", "N"),
    ("max_cam_contact_force", "N"),
    ("min_cam_contact_force", "N"),
    ("jump", ""),
    ("cam_separation", "m"),
    ("cam_separation_angle", "deg"),
    ("impacts", ""),
    ("max_impact_velocity", "m/s"),
    ("periodicity_residual", ""),
)


@dataclass(frozen=True)
class Trace:
    """One sampled quantity on the run's time base.

    Attributes
    ----------
    data : ndarray (N,)
        The samples, SI.
    units : str
        Their unit (``"N"``, ``"m/s^2"``, ``"deg"``...).
    long_name : str
        What they are, for files and axis labels.
    """

    data: np.ndarray
    units: str
    long_name: str


@dataclass
class Extreme:
    """A located maximum or minimum (spec §4): its value [SI] and instant [s, recorded clock]."""

    value: float
    time: float


def missing_scalar(name: str):
    """The value a table shows for a scalar a run did not produce (a failed or cancelled
    run): no jump, no impacts, NaN for every number."""
    return {"jump": False, "impacts": 0}.get(name, float("nan"))


def missing_reason(machine: Machine, name: str, row: dict[str, Any]) -> str | None:
    """Why scalar ``name`` of a run's row (:meth:`RunResult.scalars`, a sweep or study row)
    has no value, or None when it has one (issue 26: never a bare "–" or NaN).

    ``row`` holds the run's other scalars and its ``status`` (a sweep row); the reasons
    depend on the machine (no transducer, no cam force) and on the run (no impact).
    """
    value = row.get(name)
    if not (isinstance(value, float) and math.isnan(value)) and value is not None:
        return None
    status = row.get("status", "ok")
    if status != "ok":
        return "the run did not complete (" + ("cancelled" if status == "cancelled" else "failed: see status") + ")"
    if name == "peak_transducer_force":
        return "no element of the machine has transducer = true"
    if name in ("max_cam_contact_force", "min_cam_contact_force"):
        return "the machine has no cam force (no cam.drives mass and no contact with the cam)"
    if name == "max_impact_velocity":
        return "no impact in the run"
    if name in ("cam_separation", "cam_separation_angle"):
        if machine.cam is not None and machine.cam.drives:
            return (f"the cam drives {machine.cam.drives} (x = s): it never leaves the cam; its jump is "
                    "min_cam_contact_force < 0 (and jump)")
        return "the machine has no contact with the cam"
    if name == "periodicity_residual":
        return "needs a warm-up revolution or two recorded ones (the state one revolution apart)"
    if name.startswith("peak_"):
        return "no samples"
    return "not computed for this run (see the run's summary)"


def unreachable_limit(machine: Machine, quantity: str, op: str, threshold: float) -> str | None:
    """A warning when a limit on ``quantity`` can never be crossed for this machine, naming
    the quantity to use instead; None when it can (issue 26).

    For a cam acting through a contact element (``between = ["cam", ...]``, no driven mass)
    the cam contact force is a contact's force, never below 0: ``min_cam_contact_force < 0``
    never fires, however often the follower jumps. Sweeps, studies and optimisations call
    this on each limit or constraint they are given.
    """
    below = op in ("<", "<=") and (threshold < 0 or (threshold == 0 and op == "<"))
    if quantity in ("min_cam_contact_force", "max_cam_contact_force") and below:
        cam = machine.cam
        if cam is not None and not cam.drives:
            return (f"{quantity} {op} {threshold:g} N never happens for this machine: its cam acts through a "
                    "contact element, whose force is never below 0; the follower leaves the cam when "
                    "cam_separation > 0 (or jump is true): use --limit \"cam_separation>0m\" or \"jump>0\"")
    return None


def scalar_columns(masses: list[str] | tuple[str, ...]) -> list[tuple[str, str]]:
    """Names and SI units of :meth:`RunResult.scalars` for a machine with ``masses``."""
    cols = [(f"peak_{q}:{m}", QUANTITY_UNITS[q]) for m in masses for q in MASS_QUANTITIES]
    return cols + list(FIXED_SCALARS)


@dataclass
class RunResult:
    """Traces, events and derived quantities of one run, all SI, on a uniform time grid.

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
        Force of the cam on the driven mass [N] (``cam.drives``).
    transducer_force : ndarray or None
        Sum of the contacts marked ``transducer = true`` [N].
    events : EventTable
        Events of the recorded window, times on the ``time`` base.
    periodicity_residual : float
        Largest difference between the state at the start of the first recorded cycle and
        one revolution before, relative to each quantity's peak (NaN when not computed).
    steady_state : dict or None
        How the recorded window's start was reached: ``{"method": "warmup" or "shooting",
        "revolutions": unrecorded revolutions integrated}`` (camsim.run.steady); None for a
        result not made by a run (a file read back without it).
    warnings : list of str
    no_impact : bool
        True for the no-impact variant (spec §4).
    boundaries_deg : ndarray
        Cam angles of the segment joins [deg].
    sample_rate : float
        Output sample rate [Hz].
    cams : dict or None
        Several cams (``[[cam]]``, issue 38): name → the traces of ``cam`` for each
        (``cam`` is then the first cam's).
    cam_contact_forces : dict or None
        Several cams: cam name → force on the mass it drives [N] (``cam_contact_force`` is
        then None).
    shaft_angle : ndarray or None
        The camshaft's angle [deg] (drive side) where it differs from the first cam's.
    shaft_speed, cam_speeds, drive_torque : ndarray, dict, ndarray or None
        A dynamic camshaft: the drive side's speed [rad/s], each cam's [rad/s], the drive's
        torque [N·m] (None on a rigid shaft).
    loads : dict
        Process loads (``[[load]]``, issue 43): name → force [N], positive along +x.
    load_work : dict or None
        Each load's work ∫F·ẋ dt over the first recorded revolution (the record without a
        cam) [J], integrated on the solution (:mod:`camsim.run.loads`); None when not computed.
    """

    machine: Machine
    time: np.ndarray
    cam: dict[str, np.ndarray]
    masses: dict[str, dict[str, np.ndarray]]
    elements: dict[str, np.ndarray]
    cam_contact_force: np.ndarray | None
    transducer_force: np.ndarray | None
    events: EventTable
    periodicity_residual: float
    warnings: list[str] = field(default_factory=list)
    no_impact: bool = False
    boundaries_deg: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sample_rate: float = 0.0
    #: The exact state's cam force and torque at the end of the first recorded revolution
    #: (camsim.run.simulation.period_end; None when not computed): closes the revolution of
    #: the cam design's energy quantities (issue 26).
    period_end: dict | None = None
    # issue 38: several cams, the camshaft
    cams: dict[str, dict[str, np.ndarray]] | None = None
    cam_contact_forces: dict[str, np.ndarray] | None = None
    shaft_angle: np.ndarray | None = None
    shaft_speed: np.ndarray | None = None
    cam_speeds: dict[str, np.ndarray] | None = None
    drive_torque: np.ndarray | None = None
    shaft_dynamics: dict | None = None
    steady_state: dict | None = None
    #: Extremes located on the solution (spec §4, camsim.run.extremes): path →
    #: {"max": Extreme, "min": Extreme}, values SI, times on the recorded clock; None for a
    #: result without them (the extremes then come from the samples).
    located: dict | None = None
    #: Traces of compound elements, which have no single force: name → {quantity: samples};
    #: a rod's ``force_lower``, ``force_upper`` [N] and ``max_stress`` [Pa] (issue 39).
    element_traces: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    loads: dict[str, np.ndarray] = field(default_factory=dict)  # issue 43
    load_work: dict[str, float] | None = None
    #: Energy each friction pair dissipates over the work window [J] (camsim.run.friction).
    friction_energy: dict[str, float] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.events, EventTable):
            self.events = EventTable(self.events)

    # ------------------------------------------------------------------ traces
    def traces(self) -> dict[str, Trace]:
        """Every trace of the result file, by its path (spec §7), in file order."""
        return dict(self._traces)

    @cached_property
    def _traces(self) -> dict[str, Trace]:
        out: dict[str, Trace] = {"time": Trace(self.time, "s", "time")}
        if self.cams is None:
            out["cam/angle"] = Trace(self.cam["angle"], "deg", "cam angle θ0 + ω·t")
            for quantity in ("displacement", "velocity", "acceleration", "jerk"):
                out[f"cam/{quantity}"] = Trace(self.cam[quantity], QUANTITY_UNITS[quantity], f"cam {quantity} on the model axis")
            if self.cam_speeds:  # one cam on a dynamic camshaft
                out["cam/speed"] = Trace(next(iter(self.cam_speeds.values())), "rad/s", "angular speed of the cam")
        else:  # issue 38: /cams/<name>/...
            for name, traces in self.cams.items():
                out[f"cams/{name}/angle"] = Trace(traces["angle"], "deg", f"angle of cam {name}, θ_shaft + phase")
                for quantity in ("displacement", "velocity", "acceleration", "jerk"):
                    out[f"cams/{name}/{quantity}"] = Trace(traces[quantity], QUANTITY_UNITS[quantity],
                                                           f"cam {name} {quantity} on the model axis")
                if self.cam_contact_forces and name in self.cam_contact_forces:
                    out[f"cams/{name}/contact_force"] = Trace(self.cam_contact_forces[name], "N",
                                                              f"force of cam {name} on the mass it drives")
                if self.cam_speeds and name in self.cam_speeds:  # a dynamic camshaft
                    out[f"cams/{name}/speed"] = Trace(self.cam_speeds[name], "rad/s", f"angular speed of cam {name}")
        for name, traces in self.masses.items():
            for quantity in MASS_QUANTITIES:
                out[f"masses/{name}/{quantity}"] = Trace(traces[quantity], QUANTITY_UNITS[quantity], f"{quantity} of {name}")
        for element in self.machine.elements:
            if element.name not in self.elements:
                continue
            sense = element.force_sense
            out[f"elements/{element.name}/force"] = Trace(
                self.elements[element.name], "N", f"force of {element.name} ({sense})"
            )
        for element in self.machine.elements:  # issue 39: a rod's end forces and largest stress
            for quantity, data in self.element_traces.get(element.name, {}).items():
                unit, long_name = element.result_quantities[quantity]
                out[f"elements/{element.name}/{quantity}"] = Trace(data, unit, f"{long_name} {element.name}")
        if self.cam_contact_force is not None:
            out["cam_contact/force"] = Trace(self.cam_contact_force, "N", "force of the cam on the driven mass")
        if self.transducer_force is not None:
            out["transducer/force"] = Trace(self.transducer_force, "N", "force read by the transducer")
        for name, data in self.loads.items():  # issue 43
            out[f"loads/{name}/force"] = Trace(data, "N", f"process load {name} (positive along +x)")
        from camsim.cam.design import design_traces  # issue 14: cam design traces with [cam.geometry]

        for path, (data, units, long_name) in design_traces(self).items():
            out[path] = Trace(data, units, long_name)
        from camsim.run import camshaft  # issue 38: the camshaft's torque, speed, clearances

        if camshaft.active(self.machine):
            for path, (data, units, long_name) in camshaft.shaft_traces(self).items():
                out[path] = Trace(data, units, long_name)
        return out

    def trace(self, path: str) -> np.ndarray:
        """The samples of one trace, by its result path (``"transducer/force"``,
        ``"masses/M3/acceleration"``, ``"elements/K23/force"``; a leading ``/`` is allowed).

        Raises
        ------
        KeyError
            With the list of the paths this result has.
        """
        key = path.strip().lstrip("/")
        hit = self._traces.get(key)
        if hit is None:
            raise KeyError(f"no trace {path!r} in this result; it has: {', '.join(self._traces)}")
        return hit.data

    def units(self, path: str) -> str:
        """SI unit of a trace (see :meth:`trace`) or of a scalar (see :meth:`scalars`)."""
        key = path.strip().lstrip("/")
        if key in self._traces:
            return self._traces[key].units
        units = dict(scalar_columns(list(self.masses)))
        from camsim.run import families  # the design's, the camshaft's, the loads', the friction pairs'

        units.update(families.columns(self.machine))
        if key in units:
            return units[key]
        raise KeyError(f"no trace or scalar {path!r} in this result")

    # ------------------------------------------------------------------ derived quantities
    @cached_property
    def cam_force(self) -> np.ndarray | None:
        """Force of the cam on the follower [N], compressive-positive.

        The cam contact force of a driven mass (``cam.drives``); for a cam that acts
        through contact elements (``between = ["cam", ...]``), the sum of their forces;
        None when the machine has neither.
        """
        if self.cam_contact_force is not None:
            return self.cam_contact_force
        if self.cams is not None:  # issue 38: the station whose cam force comes lowest
            from camsim.run.camshaft import _station_forces

            forces = list(_station_forces(self).values())
            if not forces:
                return None
            return forces[int(np.argmin([float(np.min(f)) if f.size else np.inf for f in forces]))]
        names = [e.name for e in self._cam_contacts if e.name in self.elements]
        if not names:
            return None
        return np.sum([np.asarray(self.elements[n], dtype=float) for n in names], axis=0)

    def _station_extreme(self, which: str) -> tuple[float, float] | None:
        """(value, time) of the largest (``"max"``) or smallest (``"min"``) cam force over
        every station of a multi-cam machine: each station's located extreme (spec §4) when
        the run located it, else its extreme sample (issue 38)."""
        from camsim.run.camshaft import _station_forces

        hits = []
        for name, force in _station_forces(self).items():
            hit = (self.located or {}).get(f"cams/{name}/contact_force")
            if hit is not None:
                hits.append((hit[which].value, hit[which].time))
            elif force.size:
                k = int(np.argmax(force)) if which == "max" else int(np.argmin(force))
                hits.append((float(force[k]), float(self.time[k])))
        if not hits:
            return None
        pick = max if which == "max" else min
        return pick(hits, key=lambda h: h[0])

    @property
    def _cam_contacts(self) -> list:
        return [e for e in self.machine.elements if e.unilateral and e.at_cam]

    def impacts(self) -> EventTable:
        """Impact-like events (contacts closing and links rejoining)."""
        return self.events.impacts()

    def follower_jumps(self) -> bool:
        """True when the follower leaves the cam (negative cam force, or a cam contact opens)."""
        return bool(self._scalars["jump"])

    def scalars(self) -> dict[str, Any]:
        """The flat summary of the run (SI; NaN where a quantity does not apply).

        ``peak_<quantity>:<mass>`` (largest |sample|), ``peak_transducer_force``,
        ``max_cam_contact_force`` / ``min_cam_contact_force`` (of :attr:`cam_force`),
        ``jump``, ``impacts`` (count), ``max_impact_velocity``, ``periodicity_residual``.
        Units: :func:`scalar_columns`. Sweeps, studies and fits read these.
        """
        return dict(self._scalars)

    def peak(self, name: str, quantity: str) -> float:
        """The largest |value| of a mass's ``quantity`` (``displacement``...) [SI], located on
        the solution (spec §4); NaN when the run has neither located it nor sampled it."""
        hit = self.extreme(f"masses/{name}/{quantity}", "abs")
        return hit[0] if hit is not None else float("nan")

    def extreme(self, path: str, which: str) -> tuple[float, float] | None:
        """(value, time) of the largest (``which = "max"``), smallest (``"min"``) or largest
        absolute (``"abs"``) value of a quantity: located on the solution (spec §4) when the
        run located it, else its extreme sample (first occurrence); None without samples.

        ``path`` is a trace path (``"masses/M3/acceleration"``, ``"transducer/force"``...)
        or ``"cam_force"`` (:attr:`cam_force`); times on the recorded clock [s].
        """
        hit = (self.located or {}).get(path)
        if hit is None and path == "cam_force" and self.cam_contact_force is not None:
            hit = (self.located or {}).get("cam_contact/force")
        if hit is not None:
            top, bottom = hit["max"], hit["min"]
            if which == "max":
                return top.value, top.time
            if which == "min":
                return bottom.value, bottom.time
            return (abs(top.value), top.time) if abs(top.value) >= abs(bottom.value) else (abs(bottom.value), bottom.time)
        data = self.cam_force if path == "cam_force" else self._traces.get(path, Trace(np.zeros(0), "", "")).data
        if data is None or not data.size:
            return None
        values = np.abs(data) if which == "abs" else data
        k = int(np.argmin(values)) if which == "min" else int(np.argmax(values))
        return float(values[k]), float(self.time[k])

    @cached_property
    def _scalars(self) -> dict[str, Any]:
        nan = float("nan")
        out: dict[str, Any] = {}

        def value(path, which):
            hit = self.extreme(path, which)
            return hit[0] if hit is not None else nan

        for name in self.masses:
            for quantity in MASS_QUANTITIES:
                out[f"peak_{quantity}:{name}"] = value(f"masses/{name}/{quantity}", "abs")
        out["peak_transducer_force"] = value("transducer/force", "max") if self.transducer_force is not None else nan
        cf = self.cam_force
        out["max_cam_contact_force"] = value("cam_force", "max") if cf is not None else nan
        out["min_cam_contact_force"] = value("cam_force", "min") if cf is not None else nan
        if self.cams is not None:  # issue 38: the extremes over every station
            for which in ("max", "min"):
                hit = self._station_extreme(which)
                if hit is not None:
                    out[f"{which}_cam_contact_force"] = hit[0]
        cam_contacts = {e.name for e in self._cam_contacts}
        out["jump"] = bool(
            (cf is not None and out["min_cam_contact_force"] < 0)
            or any(ev.kind == EventKind.RELEASE and ev.element in cam_contacts for ev in self.events)
        )
        out["cam_separation"], out["cam_separation_angle"] = self._cam_separation()
        impacts = self.impacts()
        out["impacts"] = len(impacts)
        speeds = np.abs(np.array([e.relative_velocity for e in impacts], dtype=float))
        out["max_impact_velocity"] = float(np.nanmax(speeds)) if speeds.size and np.any(np.isfinite(speeds)) else nan
        out["periodicity_residual"] = float(self.periodicity_residual)
        from camsim.cam.design import design_row  # issue 14: design scalars with [cam.geometry]

        out.update(design_row(self))
        if self.camshaft_accumulator() is not None:  # issue 38
            out.update(self.camshaft_accumulator().row(self.located))
        from camsim.run import families  # issue 43: the loads', the friction pairs'

        out.update(families.rows(self))
        return out

    def camshaft_accumulator(self, cs: float | None = None):
        """The camshaft's scalars over this run (:class:`camsim.run.camshaft.CamshaftAccumulator`),
        None for a machine without camshaft outputs (one ``[cam]`` and no ``[camshaft]``)."""
        from camsim.run import camshaft

        if not camshaft.active(self.machine):
            return None
        if cs is None and getattr(self, "_shaft_acc", None) is not None:
            return self._shaft_acc
        acc = camshaft.CamshaftAccumulator(self.machine, cs)
        acc.add(self)
        if cs is None:
            self._shaft_acc = acc
        return acc

    def camshaft_summary(self, cs: float | None = None) -> dict | None:
        """The camshaft section of the summary (torques, work, E_k, flywheel, motor, clearances)."""
        acc = self.camshaft_accumulator(cs)
        return None if acc is None else acc.summary(self.located)

    def missing_reasons(self) -> dict[str, str]:
        """Why each scalar without a value (NaN in :meth:`scalars`) is absent (issue 26)."""
        scalars = self._scalars
        out = {}
        design = None
        for name in scalars:
            why = missing_reason(self.machine, name, {**scalars, "status": "ok"})
            if why is None:
                continue
            if why.startswith("not computed"):
                if design is None:
                    design = (self.design_summary() or {}).get("reasons", {})
                why = design.get(name, why)
            out[name] = why
        return out

    def _cam_separation(self) -> tuple[float, float]:
        """(largest gap between the follower and the cam [m], largest cam-angle span off the
        cam [deg]) of a cam acting through contact elements; NaN for a driven mass (it never
        leaves the cam: its jump is a negative contact force) or without a cam.

        The gap is the contact's opening −δ = d − gap over the samples (its largest sample);
        the span runs from each release of a cam contact to its next closing, at the exact
        event times (to the end of the record when it does not close again).
        """
        nan = float("nan")
        names = {e.name for e in self._cam_contacts}
        if not names or self.machine.cam is None:
            return nan, nan
        gap = 0.0
        if self.time.size:
            from camsim.model.assembly import Model

            model = Model(self.machine, no_impact=self.no_impact)
            x = (np.column_stack([self.masses[n]["displacement"] for n in model.free_names]) if model.n
                 else np.zeros((self.time.size, 0)))
            cams = self.cams if self.cams is not None else {model.cam_names[0]: self.cam}
            s = np.column_stack([cams[name]["displacement"] for name in model.cam_names])
            for i, element in enumerate(model.elements):
                if element.name in names:
                    geo = model.geometry[i]
                    d = x @ geo.G + geo.cam_term(s)
                    gap = max(gap, float(np.max(-np.asarray(element.penetration(d), dtype=float))))
        return gap, self.separation_span(float(self.time[-1]) if self.time.size else None)

    def separation_span(self, end: float | None) -> float:
        """Largest cam-angle span off the cam [deg] from the events (a release of a cam
        contact to its next closing; to ``end`` [s] when it does not close again); NaN
        without a cam contact."""
        names = {e.name for e in self._cam_contacts}
        if not names or self.machine.cam is None:
            return float("nan")
        span = 0.0
        opened: dict[str, float] = {}
        for ev in self.events:
            if ev.element not in names:
                continue
            if ev.kind == EventKind.RELEASE:
                opened.setdefault(ev.element, ev.time)
            elif ev.kind == EventKind.IMPACT and ev.element in opened:
                span = max(span, ev.time - opened.pop(ev.element))
        if end is not None:
            for t in opened.values():
                span = max(span, end - t)
        return math.degrees(span * abs(float(self.machine.cam.speed)))

    def design_summary(self, cs: float | None = None) -> dict | None:
        """Cam design checks, stress, torque and flywheel (:func:`camsim.cam.design.design_summary`).

        ``cs`` is the coefficient of speed fluctuation for the flywheel inertia. None
        without ``[cam.geometry]``.
        """
        from camsim.cam.design import design_summary  # issue 14

        return design_summary(self, cs)

    def summary(self) -> dict:
        """Peaks (with when), forces, impacts and residual as plain JSON-able values (SI)."""
        out: dict = {"machine": self.machine.name, "no_impact": self.no_impact, "masses": {}}
        for name, traces in self.masses.items():
            entry = {}
            for quantity in traces:
                hit = self.extreme(f"masses/{name}/{quantity}", "abs")
                entry[quantity] = {"peak": hit[0], "time": hit[1]} if hit is not None else {"peak": 0.0, "time": 0.0}
            out["masses"][name] = entry

        def extreme(path, which, present):
            hit = self.extreme(path, which) if present else None
            return {"value": hit[0], "time": hit[1]} if hit is not None else None

        out["peak_transducer_force"] = extreme("transducer/force", "max", self.transducer_force is not None)
        out["max_cam_contact_force"] = extreme("cam_force", "max", self.cam_force is not None)
        out["min_cam_contact_force"] = extreme("cam_force", "min", self.cam_force is not None)
        if self.cams is not None:  # issue 38: the extremes over every station
            for which in ("max", "min"):
                hit = self._station_extreme(which)
                if hit is not None:
                    out[f"{which}_cam_contact_force"] = {"value": hit[0], "time": hit[1]}
        out["located"] = self.located is not None
        out["jump"] = self.follower_jumps()
        out["impacts"] = [e.to_dict() for e in self.impacts()]
        out["events"] = len(self.events)
        out["periodicity_residual"] = None if math.isnan(self.periodicity_residual) else float(self.periodicity_residual)
        out["warnings"] = list(self.warnings)
        out["reasons"] = self.missing_reasons()  # issue 26: why a value is null
        design = self.design_summary()  # issue 14: with [cam.geometry]
        if design is not None:
            out["design"] = design
        rods, stress = self.rod_summary(), contact_stress_rows(self.machine, self.events)  # issue 39
        if rods:
            out["rods"] = rods
        if stress:
            out["contact_stress"] = stress
        shaft = self.camshaft_summary()  # issue 38: several cams, or a [camshaft]
        if shaft is not None:
            if self.shaft_dynamics is not None:
                shaft["dynamics"] = self.shaft_dynamics
            out["camshaft"] = shaft
        from camsim.run import families  # issue 43: the loads', the friction pairs'

        out.update(families.summaries(self))
        return out

    def rod_summary(self) -> dict[str, dict]:
        """Each rod's discretisation (:func:`camsim.run.checks.rod_rows`) with its largest
        stress and end force (``{"value", "time"}``, SI; located, spec §4) (issue 39)."""
        rows = rod_rows(self.machine)
        for name, row in rows.items():
            traces = self.element_traces.get(name, {})
            stress = self.extreme(f"elements/{name}/max_stress", "max") if "max_stress" in traces else None
            row["max_stress"] = {"value": stress[0], "time": stress[1]} if stress is not None else None
            ends = [self.extreme(f"elements/{name}/{k}", "abs") for k in ("force_lower", "force_upper") if k in traces]
            ends = [e for e in ends if e is not None]
            top = max(ends, key=lambda e: e[0]) if ends else None
            row["max_end_force"] = {"value": top[0], "time": top[1]} if top is not None else None
        return rows

    # ------------------------------------------------------------------ views
    def to_pandas(self):
        """The traces as a :class:`pandas.DataFrame` indexed by time [s].

        Columns are the result paths; ``frame.attrs["units"]`` maps each to its unit.
        The event table is ``result.events.to_pandas()``.
        """
        from camsim.extras import require

        pd = require("pandas", "pandas")
        traces = self._traces
        columns, units = {}, {}
        for path, t in traces.items():
            if path == "time":
                continue
            if t.data.ndim == 2:  # issue 14: x-y curves (cam/pitch_curve, cam/surface) as two columns
                for k, axis in enumerate("xy"):
                    columns[f"{path}/{axis}"], units[f"{path}/{axis}"] = t.data[:, k], t.units
            else:
                columns[path], units[path] = t.data, t.units
        frame = pd.DataFrame(columns, index=pd.Index(self.time, name="time"))
        frame.attrs["units"] = {"time": "s", **units}
        return frame

    def to_xarray(self):
        """The traces as an :class:`xarray.Dataset`: time as the coordinate, one variable
        per result path, ``units`` and ``long_name`` attributes kept; the event table on
        an ``event`` dimension."""
        from camsim.extras import require

        xr = require("xarray", "xarray")
        traces = self._traces
        data_vars = {
            path: (("time", "xy") if t.data.ndim == 2 else "time", t.data, {"units": t.units, "long_name": t.long_name})
            for path, t in traces.items() if path != "time"
        }  # ("time", "xy"): issue 14's x-y curves
        for name, (values, units) in self.events.columns().items():
            data_vars[f"events/{name}"] = ("event", values, {"units": units})
        return xr.Dataset(
            data_vars,
            coords={"time": ("time", self.time, {"units": "s", "long_name": "time"})},
            attrs={"machine_name": self.machine.name, "no_impact": int(self.no_impact), "sample_rate": self.sample_rate},
        )


# ---------------------------------------------------------------------- reading back
def open_result(path: str | os.PathLike[str], group: str | None = None) -> RunResult:
    """Read a run file (or one side of a comparison file) back as a :class:`RunResult`.

    Parameters
    ----------
    path : path
        A file written by ``camsim run`` or ``camsim compare`` (or :meth:`write`).
    group : str, optional
        ``"impact"`` or ``"no_impact"`` for a comparison file.

    Raises
    ------
    ResultFileError
        Not a camsim run or comparison file, or its machine text cannot be loaded.
    """
    from camsim.errors import MachineFileError
    from camsim.io.results import attr_text, file_kind, open_h5, read_events
    from camsim.machine.loader import load_machine_text

    with open_h5(path) as f:
        kind = file_kind(f)
        if kind == "compare":
            group = group or "impact"
            if group not in ("impact", "no_impact"):
                raise ResultFileError(f"{path}: a comparison file has groups impact and no_impact, not {group!r}")
            g = f[group]
        elif kind == "run":
            if group:
                raise ResultFileError(f"{path}: a run file has no group {group!r}")
            g = f
        else:
            raise ResultFileError(f"{path}: a {kind} file, not a run result")
        text = attr_text(f, "machine_toml")
        try:
            machine = load_machine_text(text, source=f"{path}:machine_toml", base_dir=Path(path).parent)
        except MachineFileError as exc:
            raise ResultFileError(f"{path}: cannot rebuild its machine from machine_toml ({exc})") from None
        stations: dict[str, Any] = {}
        try:
            time = g["time"][()]
            quantities = ("angle", "displacement", "velocity", "acceleration", "jerk")
            if machine.multi_cam:  # issue 38: /cams/<name>/...
                stations["cams"] = {c.name: {q: g[f"cams/{c.name}/{q}"][()] for q in quantities} for c in machine.cams}
                stations["cam_contact_forces"] = {c.name: g[f"cams/{c.name}/contact_force"][()] for c in machine.cams
                                                  if f"cams/{c.name}/contact_force" in g}
                cam = stations["cams"][machine.cams[0].name]
            else:
                cam = {q: g[f"cam/{q}"][()] for q in quantities}
            if "camshaft/angle" in g and machine.camshaft is not None and machine.camshaft.model == "dynamic":
                stations["shaft_angle"] = g["camshaft/angle"][()]
                stations["shaft_speed"] = g["camshaft/speed"][()]
                stations["drive_torque"] = g["camshaft/motor_torque"][()]
                stations["cam_speeds"] = ({c.name: g[f"cams/{c.name}/speed"][()] for c in machine.cams
                                           if f"cams/{c.name}/speed" in g} if machine.multi_cam else
                                          {machine.cams[0].name: g["cam/speed"][()]} if "cam/speed" in g else None) or None
            masses = {name: {q: g[f"masses/{name}/{q}"][()] for q in MASS_QUANTITIES} for name in g["masses"]}
        except KeyError:  # a run stored with --record or --summary-only (camsim.run.stream)
            stored = json.loads(g["summary"].attrs["recorded"]) if "summary" in g and "recorded" in g["summary"].attrs else []
            raise ResultFileError(
                f"{path}: holds only some traces ({', '.join(stored) or 'none'}; recorded with --record or "
                "--summary-only), a RunResult needs them all: read them with h5py, the summary from /summary"
            ) from None
        elements = {name: g[f"elements/{name}/force"][()] for name in g.get("elements", {})
                    if "force" in g[f"elements/{name}"]}
        extra = {name: {q: g[f"elements/{name}/{q}"][()] for q in g[f"elements/{name}"] if q != "force"}
                 for name in g.get("elements", {})}  # issue 39: a rod's end forces and max_stress
        cam_force = g["cam_contact/force"][()] if "cam_contact/force" in g else None
        transducer = g["transducer/force"][()] if "transducer/force" in g else None
        table = read_events(g) or {}
        events = EventTable()
        n = len(next(iter(table.values()))) if table else 0
        for k in range(n):
            row = {name: values[k] for name, values in table.items()}
            events.append(Event(**{name: (str(v) if isinstance(v, (str, bytes, np.str_)) or name in ("element", "kind", "masses") else float(v))
                                   for name, v in row.items()}))
        boundaries = g["cam/boundaries_deg"][()] if "cam/boundaries_deg" in g else (
            g["camshaft/boundaries_deg"][()] if "camshaft/boundaries_deg" in g else np.zeros(0))
        located = read_extremes(g)
        residual = float(g.attrs.get("periodicity_residual", float("nan")))
        summary_attrs = g["summary"].attrs if "summary" in g else {}
        loads = {load.name: g[f"loads/{load.name}/force"][()] for load in machine.loads
                 if f"loads/{load.name}/force" in g}  # issue 43
        work = {load.name: float(summary_attrs[f"load_work:{load.name}"]) for load in machine.loads
                if f"load_work:{load.name}" in summary_attrs} or None
        from camsim.run.friction import pairs

        energy = {e.name: float(summary_attrs[f"friction_energy:{e.name}"]) for e in pairs(machine)
                  if f"friction_energy:{e.name}" in summary_attrs} or None
        warnings = json.loads(summary_attrs["warnings"]) if "warnings" in summary_attrs else []  # issue 44
        return RunResult(
            machine=machine, time=time, cam=cam, masses=masses, elements=elements,
            cam_contact_force=cam_force, transducer_force=transducer, events=events,
            periodicity_residual=residual, warnings=warnings, no_impact=bool(g.attrs.get("no_impact", False)),
            boundaries_deg=boundaries, sample_rate=float(g.attrs.get("sample_rate", 0.0)), located=located,
            element_traces={name: q for name, q in extra.items() if q}, loads=loads, load_work=work,
            friction_energy=energy, **stations,
        )


def read_extremes(group) -> dict | None:
    """The ``extremes`` table of a run layout as :attr:`RunResult.located` (None without one)."""
    from camsim.io.hdf5 import read_table

    if "extremes" not in group:
        return None
    table = read_table(group["extremes"])
    return {
        str(q): {"max": Extreme(float(a), float(ta)), "min": Extreme(float(b), float(tb))}
        for q, a, ta, b, tb in zip(table["quantity"], table["max"], table["max_time"], table["min"], table["min_time"])
    }

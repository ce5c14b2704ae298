"""The camshaft of a run: each cam's torque, the shaft's, work, energy excursion, flywheel, clearances.

Spec §9. Every station's cam contact force loads the shaft; by the power balance the torque
a cam takes is

    T_q = F_q·ds_q/dθ_q,   ds/dθ = ṡ/θ̇ (= ṡ/ω̄ on a rigid shaft)

with F_q the force the cam exerts on what it touches along the model axis: the cam
contact force of the mass it drives (``drives``) plus, for every element joining the cam's
node, the force that keeps the cam on its prescribed motion (a contact's force for a cam
below its follower). Impacts are in it: the contact forces are the simulated ones. The
shaft's torque is the sum over cams, T = Σ T_q.

Over one revolution (the first recorded one, closed with the exact state at its end):

* the work per cycle W = ∮ P dt, P = Σ_q F_q·ṡ_q the power into the stations (∮ T dθ on a
  rigid shaft): zero for a conservative machine, the energy dissipated per cycle otherwise;
* the energy excursion E_k = max − min of E(t) = ∫ (P − P̄) dt (∫ (T − T̄) dθ on a rigid
  shaft);
* with ``[camshaft] speed_fluctuation`` C_s (or ``--cs``) the flywheel inertia
  I = E_k/(C_s·ω̄²) that keeps (ω_max − ω_min)/ω̄ at C_s (Norton, *Design of Machinery*,
  §11.11);
* the motor's torque: the shaft torque on a rigid shaft (a constant-speed motor supplies
  it), the drive's torque on a dynamic one (its compliance, or its torque–speed line).

``[[clearance]]`` pairs: d(t) = (x_B + offset_B) − (x_A + offset_A) over the recorded motion,
its smallest value and the shaft angle there; below ``minimum`` a warning.

Computed here, once, for the result (:class:`~camsim.run.result.RunResult`) and for a
streamed run piece by piece (:class:`CamshaftAccumulator`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["active", "cam_forces", "shaft_torques", "shaft_traces", "CamshaftAccumulator", "camshaft_columns",
           "clearance_distance"]


def active(machine) -> bool:
    """Whether a machine has camshaft outputs: several cams, or a ``[camshaft]`` table."""
    return bool(machine.cams) and (machine.multi_cam or machine.camshaft is not None)


def _cam_traces(result) -> dict[str, dict[str, np.ndarray]]:
    cams = getattr(result, "cams", None)
    if cams:
        return cams
    return {result.machine.cams[0].name: result.cam}


def _model(result):
    model = getattr(result, "_camshaft_model", None)
    if model is None:
        from camsim.model.assembly import Model

        model = Model(result.machine, no_impact=result.no_impact)
        try:
            result._camshaft_model = model
        except AttributeError:  # a frozen view
            pass
    return model


def cam_forces(result) -> dict[str, np.ndarray]:
    """Per cam, the force it exerts on what it touches along the model axis [N] (the force
    conjugate to its ṡ in the power balance); zeros for a cam that touches nothing."""
    machine = result.machine
    contact = getattr(result, "cam_contact_forces", None) or {}
    if not machine.multi_cam and result.cam_contact_force is not None:
        contact = {machine.cams[0].name: result.cam_contact_force}
    return forces_on_cams(_model(result), contact, result.elements, result.time.size)


def forces_on_cams(model, contact: dict, elements: dict, n: int) -> dict[str, np.ndarray]:
    """:func:`cam_forces` from the traces' parts: ``contact`` cam name → the contact force
    on the mass it drives, ``elements`` element name → force, ``n`` samples (the located
    extremes evaluate it on the solution, :mod:`camsim.run.extremes`)."""
    out = {name: np.zeros(n) for name in model.cam_names}
    for _driven, q in model.drives.items():
        name = model.cam_names[q]
        force = contact.get(name)
        if force is not None:
            out[name] = out[name] + np.asarray(force, dtype=float)
    for element in model.elements:
        for node in element.nodes:
            if node not in model.cam_index or element.name not in elements:
                continue
            f = np.asarray(elements[element.name], dtype=float)
            # force of the element on the node: a contact F acts +F on its upper node, a
            # tension f −f; the cam supplies the opposite to keep its motion
            on_upper = f if element.unilateral else -f
            on_node = on_upper if node == element.upper else -on_upper
            out[node] = out[node] - on_node
    return out


def station_force(machine, name: str, contact: dict, elements: dict) -> np.ndarray | None:
    """The cam force of station ``name`` reported as its contact force: that of the mass
    it drives, else the sum of the contacts it touches (None: neither)."""
    if name in contact:
        return np.asarray(contact[name], dtype=float)
    names = [e.name for e in machine.elements if e.unilateral and name in e.nodes and e.name in elements]
    if not names:
        return None
    return np.sum([np.asarray(elements[n], dtype=float) for n in names], axis=0)


def _cam_rates(result) -> dict[str, np.ndarray | float]:
    """Each cam's angular speed θ̇ [rad/s] (the shaft's ω̄ on a rigid shaft)."""
    speeds = getattr(result, "cam_speeds", None)
    omega = float(result.machine.cams[0].speed)
    return {name: (speeds[name] if speeds and name in speeds else omega) for name in _cam_traces(result)}


def shaft_torques(result) -> dict[str, np.ndarray]:
    """Per cam, T_q = F_q·ṡ_q/θ̇_q [N·m] (see the module docstring)."""
    forces = cam_forces(result)
    rates = _cam_rates(result)
    return {name: forces[name] * np.asarray(traces["velocity"], dtype=float) / rates[name]
            for name, traces in _cam_traces(result).items()}


def shaft_power(result) -> np.ndarray:
    """P = Σ_q F_q·ṡ_q, the power the shaft delivers to the stations [W]."""
    forces = cam_forces(result)
    total = np.zeros(result.time.size)
    for name, traces in _cam_traces(result).items():
        total = total + forces[name] * np.asarray(traces["velocity"], dtype=float)
    return total


def drive_power(result, traces=None) -> np.ndarray:
    """The power the drive delivers [W]: the shaft's power P on a rigid shaft; on a dynamic
    one the drive's torque times the speed of what drives it (the constant-speed source, ω̄,
    for a speed drive; the motor's own speed for a motor)."""
    machine = result.machine
    if getattr(result, "shaft_speed", None) is None:
        return shaft_power(result)
    torque = np.asarray(result.drive_torque, dtype=float)
    if machine.camshaft.drive == "speed":
        return torque * float(machine.camshaft.speed)
    return torque * np.asarray(result.shaft_speed, dtype=float)


def clearance_distance(result, clearance) -> np.ndarray:
    """d(t) = (x_B + offset_B) − (x_A + offset_A) of a ``[[clearance]]`` pair [m]."""
    def position(part):
        if part.node in result.masses:
            x = result.masses[part.node]["displacement"]
        else:
            x = _cam_traces(result)[part.node]["displacement"]
        return np.asarray(x, dtype=float) + part.offset

    return position(clearance.b) - position(clearance.a)


def shaft_traces(result) -> dict[str, tuple[np.ndarray, str, str]]:
    """The camshaft's traces of a run: result path → (data, units, long name)."""
    machine = result.machine
    out: dict[str, tuple[np.ndarray, str, str]] = {}
    torques = shaft_torques(result)
    dynamic = getattr(result, "shaft_speed", None) is not None
    multi = machine.multi_cam
    if multi:
        for name, torque in torques.items():
            out[f"cams/{name}/torque"] = (torque, "N*m", f"torque cam {name} takes from the shaft, F·ds/dθ")
    angle = getattr(result, "shaft_angle", None)
    if angle is None:
        angle = np.degrees(float(machine.cams[0].start_angle) + float(machine.cams[0].speed) * result.time)
    out["camshaft/angle"] = (np.asarray(angle, dtype=float), "deg", "camshaft angle (drive side)")
    speed = result.shaft_speed if dynamic else np.full(result.time.size, float(machine.cams[0].speed))
    out["camshaft/speed"] = (np.asarray(speed, dtype=float), "rad/s", "camshaft speed (drive side)")
    total = np.zeros(result.time.size)
    for torque in torques.values():
        total = total + torque
    out["camshaft/torque"] = (total, "N*m", "camshaft torque, the sum over cams of F·ds/dθ")
    drive = getattr(result, "drive_torque", None)
    out["camshaft/motor_torque"] = (np.asarray(drive if drive is not None else total, dtype=float), "N*m",
                                    "torque the drive delivers" + ("" if drive is not None else " (rigid shaft: the shaft torque)"))
    for c in machine.clearances:
        out[f"clearances/{c.name}/distance"] = (clearance_distance(result, c), "m",
                                                f"distance {c.a.node} to {c.b.node} (edges)")
    return out


def camshaft_columns(machine) -> list[tuple[str, str]]:
    """The run scalars a machine's camshaft adds (name, SI unit); [] without camshaft outputs."""
    if not active(machine):
        return []
    cols = [("peak_camshaft_torque", "N*m"), ("rms_camshaft_torque", "N*m"), ("camshaft_work", "J"),
            ("energy_excursion", "J"), ("flywheel_inertia", "kg*m^2"), ("peak_motor_torque", "N*m"),
            ("rms_motor_torque", "N*m"), ("speed_fluctuation", "")]
    if machine.multi_cam:
        for cam in machine.cams:
            cols += [(f"peak_cam_torque:{cam.name}", "N*m"), (f"max_cam_contact_force:{cam.name}", "N"),
                     (f"min_cam_contact_force:{cam.name}", "N")]
    cols += [(f"min_clearance:{c.name}", "m") for c in machine.clearances]
    return cols


def _refined_min(values: np.ndarray, time: np.ndarray) -> tuple[float, float]:
    """The smallest value of a sampled smooth signal and its time, refined by the parabola
    through the three samples around the smallest one."""
    k = int(np.argmin(values))
    v, t = float(values[k]), float(time[k])
    if 0 < k < values.size - 1:
        left, right = float(values[k - 1]), float(values[k + 1])
        curvature = left - 2.0 * v + right
        if curvature > 0.0:
            shift = 0.5 * (left - right) / curvature  # in samples, within ±1/2
            return v - 0.125 * (right - left) ** 2 / curvature, t + shift * float(time[k + 1] - time[k])
    return v, t


class CamshaftAccumulator:
    """The camshaft's scalars folded over a run's samples, piece by piece (a streamed run)
    or at once (an in-memory one): peaks with their times, RMS from running sums, the power
    over the first recorded revolution for the work and the energy excursion, the speed's
    extremes, each clearance's smallest distance.

    Parameters
    ----------
    machine : Machine
    cs : float, optional
        C_s for the flywheel (default ``[camshaft] speed_fluctuation``).
    """

    def __init__(self, machine, cs: float | None = None):
        self.machine = machine
        shaft = machine.camshaft
        self.cs = cs if cs is not None else (shaft.speed_fluctuation if shaft is not None else None)
        self.omega = float(machine.cams[0].speed)
        self.period = 2.0 * math.pi / self.omega
        self.peaks: dict[str, tuple[float, float]] = {}  # name -> (|value|, time)
        self.sums: dict[str, float] = {}
        self.count = 0
        self.force_max: dict[str, tuple[float, float]] = {}
        self.force_min: dict[str, tuple[float, float]] = {}
        self.speed_extremes: tuple[float, float] | None = None
        self.clearance: dict[str, tuple[float, float]] = {}
        self.first_time: list[np.ndarray] = []
        self.first_power: list[np.ndarray] = []
        self.first_drive: list[np.ndarray] = []
        #: (t [s], P [W], drive power [W]) at the end of the first recorded revolution (the
        #: exact state there).
        self.period_end: tuple[float, float, float] | None = None

    def add(self, result) -> None:
        """Fold in one piece (or a whole run)."""
        time = np.asarray(result.time, dtype=float)
        if not time.size:
            return
        end = getattr(result, "period_end", None)
        if end is not None and self.period_end is None and "power" in end:
            self.period_end = (float(end["time"]), float(end["power"]), float(end["drive_power"]))
        traces = shaft_traces(result)
        series = {"camshaft": traces["camshaft/torque"][0], "motor": traces["camshaft/motor_torque"][0]}
        torques = shaft_torques(result)
        if self.machine.multi_cam:
            for name, tq in torques.items():
                series[f"cam:{name}"] = tq
            for name, force in _station_forces(result).items():
                k_hi, k_lo = int(np.argmax(force)), int(np.argmin(force))
                old = self.force_max.get(name)
                if old is None or force[k_hi] > old[0]:
                    self.force_max[name] = (float(force[k_hi]), float(time[k_hi]))
                old = self.force_min.get(name)
                if old is None or force[k_lo] < old[0]:
                    self.force_min[name] = (float(force[k_lo]), float(time[k_lo]))
        for name, data in series.items():
            k = int(np.argmax(np.abs(data)))
            old = self.peaks.get(name)
            if old is None or abs(data[k]) > old[0]:
                self.peaks[name] = (float(abs(data[k])), float(time[k]))
            self.sums[name] = self.sums.get(name, 0.0) + float(np.sum(np.asarray(data) ** 2))
        self.count += time.size
        speed = traces["camshaft/speed"][0]
        lo, hi = float(np.min(speed)), float(np.max(speed))
        self.speed_extremes = (lo, hi) if self.speed_extremes is None else (
            min(lo, self.speed_extremes[0]), max(hi, self.speed_extremes[1]))
        shaft_angle = np.asarray(traces["camshaft/angle"][0], dtype=float)
        for c in self.machine.clearances:
            d = traces[f"clearances/{c.name}/distance"][0]
            value = _refined_min(d, time)
            old = self.clearance.get(c.name)
            if old is None or value[0] < old[0]:
                # the shaft's angle there (a dynamic shaft's own, not θ0 + ω̄·t)
                self.clearance[c.name] = (*value, float(np.interp(value[1], time, shaft_angle)) % 360.0)
        if self._needs_more():
            n = int(np.count_nonzero(time <= self.period * (1.0 + 1e-12))) + 1
            self.first_time.append(time[:n])
            self.first_power.append(shaft_power(result)[:n])
            self.first_drive.append(drive_power(result, traces)[:n])

    def _needs_more(self) -> bool:
        if not self.first_time:
            return True
        last = self.first_time[-1]
        return last.size == 0 or last[-1] <= self.period * (1.0 + 1e-12)

    def _revolution(self, drive: bool = False):
        if not self.first_time:
            return None
        time = np.concatenate(self.first_time)
        power = np.concatenate(self.first_drive if drive else self.first_power)
        period = self.period
        if self.period_end is not None:
            keep = time < self.period_end[0] - 1e-9 * period
            if not keep.any():
                return None
            end = self.period_end[2] if drive else self.period_end[1]
            return np.append(time[keep], self.period_end[0]), np.append(power[keep], end)
        from camsim.cam.design import _one_revolution  # the cam design's revolution, closed at T

        return _one_revolution(time, power, period)

    def summary(self, located: dict | None = None) -> dict:
        """The camshaft section of the run summary (SI; None where a value does not apply).
        ``located``: the run's located extremes (spec §4, :mod:`camsim.run.extremes`); a
        rigid shaft's torques and each station's cam force are located there, the rest (and
        a dynamic shaft's torques) are the extreme samples."""
        located = located or {}
        out: dict = {"model": self.machine.camshaft.model if self.machine.camshaft is not None else "rigid",
                     "mean_speed": self.omega}
        reasons: dict[str, str] = {}
        rms = {k: math.sqrt(v / self.count) if self.count else None for k, v in self.sums.items()}

        def peak(name):
            hit = self.peaks.get(name)
            path = {"camshaft": "camshaft/torque", "motor": "camshaft/torque"}.get(name, f"cams/{name[4:]}/torque")
            where = located.get(path) if hit is not None else None  # a rigid shaft's only
            if where is not None:
                top, bottom = where["max"], where["min"]
                best = top if abs(top.value) >= abs(bottom.value) else bottom
                return abs(best.value), best.time
            return (None, None) if hit is None else hit

        out["peak_torque"], out["peak_torque_time"] = peak("camshaft")
        out["rms_torque"] = rms.get("camshaft")
        out["peak_motor_torque"], out["peak_motor_torque_time"] = peak("motor")
        out["rms_motor_torque"] = rms.get("motor")
        rev = self._revolution()
        out["cycle_work"] = out["energy_excursion"] = out["flywheel_inertia"] = out["drive_work"] = None
        drive_rev = self._revolution(drive=True)
        if drive_rev is not None:
            t, p = drive_rev
            out["drive_work"] = float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(t)))
        if rev is None:
            why = f"the run records less than one revolution ({self.period:.6g} s)"
            reasons["cycle_work"] = reasons["energy_excursion"] = why
        else:
            t, p = rev
            increments = 0.5 * (p[1:] + p[:-1]) * np.diff(t)
            work = float(np.sum(increments))
            energy = np.concatenate([[0.0], np.cumsum(increments)]) - (work / float(t[-1] - t[0])) * (t - t[0])
            out["cycle_work"] = work
            out["energy_excursion"] = float(np.max(energy) - np.min(energy))
        out["cs"] = self.cs
        if self.cs is not None and out["energy_excursion"] is not None:
            out["flywheel_inertia"] = out["energy_excursion"] / (self.cs * self.omega**2)
        elif self.cs is None:
            reasons["flywheel_inertia"] = "give [camshaft] speed_fluctuation (C_s) or --cs"
        lo, hi = self.speed_extremes if self.speed_extremes is not None else (None, None)
        out["min_speed"], out["max_speed"] = lo, hi
        out["speed_fluctuation"] = (hi - lo) / self.omega if lo is not None else None
        if self.machine.multi_cam:
            out["cams"] = {}
            for cam in self.machine.cams:
                p_, t_ = peak(f"cam:{cam.name}")
                hi_f, lo_f = self.force_max.get(cam.name), self.force_min.get(cam.name)
                where = located.get(f"cams/{cam.name}/contact_force")
                if where is not None:
                    hi_f, lo_f = (where["max"].value, where["max"].time), (where["min"].value, where["min"].time)
                out["cams"][cam.name] = {
                    "phase_deg": math.degrees(cam.phase), "drives": cam.drives,
                    "peak_torque": p_, "peak_torque_time": t_, "rms_torque": rms.get(f"cam:{cam.name}"),
                    "max_contact_force": None if hi_f is None else hi_f[0],
                    "min_contact_force": None if lo_f is None else lo_f[0],
                    "min_contact_force_time": None if lo_f is None else lo_f[1],
                }
        out["clearances"] = {}
        for c in self.machine.clearances:
            d, t, angle = self.clearance.get(c.name, (None, None, None))
            out["clearances"][c.name] = {"between": [c.a.node, c.b.node], "minimum_distance": d, "time": t,
                                         "shaft_angle_deg": angle, "allowed": c.minimum,
                                         "collides": d is not None and d < c.minimum}
        out["reasons"] = {k: v for k, v in reasons.items() if out.get(k) is None}
        return out

    def row(self, located: dict | None = None) -> dict:
        """The :func:`camshaft_columns` scalars (NaN where they do not apply)."""
        s = self.summary(located)
        nan = float("nan")

        def f(x):
            return nan if x is None else float(x)

        out = {"peak_camshaft_torque": f(s["peak_torque"]), "rms_camshaft_torque": f(s["rms_torque"]),
               "camshaft_work": f(s["cycle_work"]), "energy_excursion": f(s["energy_excursion"]),
               "flywheel_inertia": f(s["flywheel_inertia"]), "peak_motor_torque": f(s["peak_motor_torque"]),
               "rms_motor_torque": f(s["rms_motor_torque"]), "speed_fluctuation": f(s["speed_fluctuation"])}
        for name, entry in s.get("cams", {}).items():
            out[f"peak_cam_torque:{name}"] = f(entry["peak_torque"])
            out[f"max_cam_contact_force:{name}"] = f(entry["max_contact_force"])
            out[f"min_cam_contact_force:{name}"] = f(entry["min_contact_force"])
        for name, entry in s["clearances"].items():
            out[f"min_clearance:{name}"] = f(entry["minimum_distance"])
        return out

    def warnings(self) -> list[str]:
        """A warning per clearance whose smallest distance is below its minimum (a collision)."""
        out = []
        for name, entry in self.summary()["clearances"].items():
            if entry["collides"]:
                a, b = entry["between"]
                out.append(f"clearance {name}: {a} and {b} come to {1e3 * entry['minimum_distance']:.4g} mm "
                           f"(allowed {1e3 * entry['allowed']:.4g} mm) at shaft angle {entry['shaft_angle_deg']:.2f} deg, "
                           f"t = {entry['time']:.6g} s: the stations' parts collide")
        return out


def _station_forces(result) -> dict[str, np.ndarray]:
    """Per cam, its station's cam force (:func:`station_force`; as :attr:`RunResult.cam_force`
    of a one-cam machine)."""
    contact = getattr(result, "cam_contact_forces", None) or {}
    out = {}
    for cam in result.machine.cams:
        force = station_force(result.machine, cam.name, contact, result.elements)
        if force is not None:
            out[cam.name] = force
    return out

"""Dynamic cam design quantities: contact normal force, side load, Hertz stress, torque.

Functions of the cam geometry (:mod:`camsim.cam.geometry`), the cam-side kinematics and
the **simulated** cam contact force, so that impacts, over-travel and jump show up in the
stress and torque (a kinematic-only tool works from m·a + k·s alone).

Forces and the linkage: the run's cam contact force Fc acts on the model axis; the cam
sees it through the linkage ``ratio`` r (model axis = r × roller motion). Power balance
gives the force along the roller's direction of motion, F_r = r·Fc, and

* normal force along the common normal      Fn = F_r / cos φ;
* side load, normal to a translating axis   Fs = F_r · tan φ (zero for a flat face,
  friction neglected);
* camshaft torque                           T = Fc·ṡ / ω   (T·ω = Fc·ṡ, ṡ on the model axis);
* Hertz line-contact peak pressure (two cylinders of length w, radii R1 = cam surface
  radius of curvature, signed, R2 = Rr; a flat face R2 = ∞)::

      p_max = √(Fn·E*·(1/R1 + 1/R2) / (π·w)),   1/E* = (1 − ν1²)/E1 + (1 − ν2²)/E2,

  zero while Fn ≤ 0 (no contact);
* energy fluctuation over one revolution (Norton, *Design of Machinery*, §11.11): with
  E(θ) = ∫(T − T_avg) dθ, ΔE = max E − min E, and the flywheel inertia for a coefficient
  of speed fluctuation Cs = (ω_max − ω_min)/ω_avg is I = ΔE/(Cs·ω²).
"""

from __future__ import annotations

import math

import numpy as np

from camsim.cam.geometry import (
    CamGeometry,
    Material,
    geometry_datasets,
    geometry_summary,
    pitch_radius,
    pressure_angle,
    roller_side_motion,
)

__all__ = [
    "DESIGN_COLUMNS",
    "camshaft_torque",
    "check_machine",
    "design_columns",
    "design_comparison",
    "design_row",
    "design_summary",
    "design_traces",
    "effective_modulus",
    "energy_fluctuation",
    "flywheel_inertia",
    "hertz_line_stress",
    "normal_force",
    "side_load",
]

#: Sweep columns added when the machine has geometry: name, SI unit.
DESIGN_COLUMNS: tuple[tuple[str, str], ...] = (
    ("max_pressure_angle", "deg"),
    ("min_pitch_radius", "m"),
    ("min_surface_radius", "m"),
    ("peak_hertz_stress", "Pa"),
    ("peak_torque", "N*m"),
    ("rms_torque", "N*m"),
    ("energy_fluctuation", "J"),
)


# --------------------------------------------------------------------------------------
# Formulas
# --------------------------------------------------------------------------------------
def normal_force(roller_force, phi) -> np.ndarray:
    """Contact force along the common normal, Fn = F_r/cos φ [N].

    Parameters
    ----------
    roller_force : array_like
        Force on the roller along its direction of motion [N] (ratio × cam contact force).
    phi : array_like
        Pressure angle [rad].
    """
    return np.asarray(roller_force, dtype=float) / np.cos(np.asarray(phi, dtype=float))


def side_load(roller_force, phi) -> np.ndarray:
    """Force normal to a translating follower's axis, F_r·tan φ [N]."""
    return np.asarray(roller_force, dtype=float) * np.tan(np.asarray(phi, dtype=float))


def effective_modulus(a: Material, b: Material) -> float:
    """E* [Pa] with 1/E* = (1 − ν1²)/E1 + (1 − ν2²)/E2."""
    return 1.0 / ((1.0 - a.poisson_ratio**2) / a.youngs_modulus + (1.0 - b.poisson_ratio**2) / b.youngs_modulus)


def hertz_line_stress(force, width: float, cam_radius, follower_radius: float | None, e_star: float) -> np.ndarray:
    """Peak Hertz pressure of a line contact [Pa].

    Parameters
    ----------
    force : array_like
        Normal force [N]; ≤ 0 means no contact (stress 0).
    width : float
        Contact length w [m].
    cam_radius : array_like
        Cam surface radius of curvature [m], positive convex, negative concave.
    follower_radius : float or None
        Roller radius [m]; None for a flat face.
    e_star : float
        Effective modulus E* [Pa] (:func:`effective_modulus`).

    Returns
    -------
    ndarray
        p_max = √(F·E*·Σ/(π·w)), Σ = 1/R1 + 1/R2 [1/m]; NaN where Σ ≤ 0 (a cusp or an
        undercut: no physical contact).
    """
    force = np.maximum(np.asarray(force, dtype=float), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        curvature = 1.0 / np.asarray(cam_radius, dtype=float)
        if follower_radius is not None:
            curvature = curvature + 1.0 / follower_radius
        out = np.sqrt(force * e_star * curvature / (math.pi * width))
    return np.where(curvature > 0, out, np.nan)


def camshaft_torque(contact_force, velocity, speed: float) -> np.ndarray:
    """Camshaft torque from the power balance T·ω = Fc·ṡ [N·m].

    Parameters
    ----------
    contact_force : array_like
        Cam contact force on the model axis [N], compressive positive.
    velocity : array_like
        Cam velocity ṡ on the model axis [m/s].
    speed : float
        ω [rad/s].
    """
    return np.asarray(contact_force, dtype=float) * np.asarray(velocity, dtype=float) / speed


def energy_fluctuation(theta, torque) -> tuple[float, float]:
    """Net work and energy fluctuation of a torque over one revolution (Norton §11.11).

    Parameters
    ----------
    theta : array_like
        Cam angles [rad] covering exactly one revolution, first to last.
    torque : array_like
        T [N·m] at those angles.

    Returns
    -------
    work : float
        ∫T dθ over the revolution [J] (trapezoidal rule): zero for a conservative machine.
    delta_e : float
        max − min of E(θ) = ∫(T − T_avg) dθ [J].
    """
    theta = np.asarray(theta, dtype=float)
    torque = np.asarray(torque, dtype=float)
    steps = np.diff(theta)
    increments = 0.5 * (torque[1:] + torque[:-1]) * steps
    work = float(np.sum(increments))
    span = float(theta[-1] - theta[0])
    energy = np.concatenate([[0.0], np.cumsum(increments)]) - (work / span) * (theta - theta[0])
    return work, float(np.max(energy) - np.min(energy))


def flywheel_inertia(delta_e: float, cs: float, speed: float) -> float:
    """Flywheel inertia I = ΔE/(Cs·ω²) [kg·m²] for a coefficient of speed fluctuation Cs."""
    return delta_e / (cs * speed * speed)


# --------------------------------------------------------------------------------------
# From a run
# --------------------------------------------------------------------------------------
def check_machine(machine, cs: float | None = None) -> None:
    """Checks before a run: a followable profile (spec §2) and a usable ``--cs``.

    Raises
    ------
    InputError
        ``--cs`` not positive and finite, or given for a machine without
        ``[cam.geometry]``; :class:`MachineFileError` (key ``cam.geometry``, naming the
        cam angles) for an undercut or a cusp.
    """
    from camsim.errors import InputError

    geometry = None if machine.cam is None else getattr(machine.cam, "geometry", None)
    if cs is not None:
        if not (math.isfinite(cs) and cs > 0):
            raise InputError(f"--cs: must be a positive number (e.g. 0.05), got {cs:g}")
        if geometry is None:
            raise InputError(f"--cs: {machine.source} has no [cam.geometry]; the flywheel needs the camshaft torque")
    if geometry is not None:
        from camsim.cam.geometry import check_followable
        from camsim.cam.program import CamProgram

        check_followable(geometry, CamProgram(machine.cam), machine.source)


def _trace(result, name: str):
    """The one place that reads a run result's base quantities.

    Not through ``RunResult.trace``: the design traces are themselves part of the
    result's traces, computed from these.
    """
    if name == "cam_contact/force":
        return result.cam_force  # the driven mass's, or the sum of the cam's contacts
    if name.startswith("cam/"):
        return result.cam[name[4:]]
    if name == "time":
        return result.time
    raise KeyError(name)


def _design_traces_of(result) -> dict[str, tuple[np.ndarray, str, str]]:
    """The design traces, from the result's own (cached) traces when it has them."""
    traces = getattr(result, "traces", None)
    if traces is None:
        return design_traces(result)
    return {path: (t.data, t.units, t.long_name) for path, t in traces().items() if path in _DESIGN_PATHS}


_DESIGN_PATHS = (
    "cam/pressure_angle", "cam/pitch_radius_of_curvature", "cam/surface_radius_of_curvature", "cam/pitch_curve",
    "cam/surface", "cam_contact/normal_force", "cam_contact/side_load", "cam_contact/hertz_stress", "camshaft/torque",
)


def _geometry(result) -> CamGeometry | None:
    cam = result.machine.cam
    return None if cam is None else getattr(cam, "geometry", None)


def _program(result):
    from camsim.cam.program import CamProgram

    return CamProgram(result.machine.cam)


def _kinematics(result):
    geometry = _geometry(result)
    program = _program(result)
    theta = np.radians(_trace(result, "cam/angle"))
    s, s1, s2, s3 = roller_side_motion(program, theta)
    return geometry, program, theta, (s, s1, s2, s3)


def design_traces(result) -> dict[str, tuple[np.ndarray, str, str]]:
    """Design traces of a run whose machine has ``[cam.geometry]`` ({} otherwise).

    Returns
    -------
    dict
        result path → (SI array on the run's time base, units, long name):
        ``cam/pressure_angle`` [deg], ``cam/pitch_radius_of_curvature`` [m],
        ``cam/surface_radius_of_curvature`` [m], ``cam/pitch_curve`` and ``cam/surface``
        (N, 2) [m], and with a cam contact force ``cam_contact/normal_force`` [N],
        ``cam_contact/side_load`` [N] (translating followers), ``cam_contact/hertz_stress``
        [Pa] (when ``width`` is given) and ``camshaft/torque`` [N*m].
    """
    geometry = _geometry(result)
    if geometry is None:
        return {}
    _, program, theta, (s, s1, s2, s3) = _kinematics(result)
    phi = pressure_angle(geometry, s, s1)
    rho_s = pitch_radius(geometry, s, s1, s2, s3) - geometry.roller_radius
    out = geometry_datasets(geometry, program, theta)
    force = _trace(result, "cam_contact/force")
    if force is None:
        return out
    roller_force = program.ratio * np.asarray(force, dtype=float)
    fn = normal_force(roller_force, phi)
    out["cam_contact/normal_force"] = (fn, "N", "cam contact force along the common normal")
    if geometry.follower.startswith("translating"):
        out["cam_contact/side_load"] = (side_load(roller_force, phi), "N", "force on the follower normal to its axis")
    if geometry.width is not None:
        e_star = effective_modulus(geometry.cam_material, geometry.follower_material)
        radius = geometry.roller_radius if geometry.is_roller else None
        stress = hertz_line_stress(fn, geometry.width, rho_s, radius, e_star)
        out["cam_contact/hertz_stress"] = (stress, "Pa", "peak Hertz line-contact pressure, cam on follower")
    torque = camshaft_torque(force, _trace(result, "cam/velocity"), program.speed)
    out["camshaft/torque"] = (torque, "N*m", "camshaft torque from T·ω = Fc·ṡ")
    return out


def _one_revolution(time: np.ndarray, values: np.ndarray, period: float):
    """Samples of the first recorded revolution, closed at t = T by linear interpolation."""
    if time.size < 2 or time[-1] < period * (1.0 - 1e-9):
        return None
    keep = time <= period * (1.0 + 1e-12)
    t, v = time[keep], values[keep]
    if t[-1] < period * (1.0 - 1e-12):
        k = t.size
        frac = (period - time[k - 1]) / (time[k] - time[k - 1])
        t = np.append(t, period)
        v = np.append(v, values[k - 1] + frac * (values[k] - values[k - 1]))
    return t, v


def design_summary(result, cs: float | None = None) -> dict | None:
    """The design scalars of a run with ``[cam.geometry]`` (None without geometry).

    Parameters
    ----------
    result : RunResult
    cs : float, optional
        Coefficient of speed fluctuation Cs [-] for the flywheel inertia.

    Returns
    -------
    dict
        The static checks of :func:`camsim.cam.geometry.geometry_summary`
        (``max_pressure_angle`` [deg] and ``max_pressure_angle_at`` [deg],
        ``min_pitch_radius``, ``min_surface_radius``, ``min_concave_radius`` [m] and
        their ``…_at`` [deg], ``warnings``, ``defects`` as text), and from the simulated
        force: ``peak_normal_force`` [N], ``peak_hertz_stress`` [Pa] and
        ``peak_hertz_stress_time`` [s], ``peak_torque`` (largest |T|) [N*m] and
        ``peak_torque_time`` [s], ``rms_torque`` [N*m], ``cycle_work`` (∫T dθ over the
        first recorded revolution) [J], ``energy_fluctuation`` ΔE [J], ``cs`` and
        ``flywheel_inertia`` [kg*m^2] (None without ``cs``). Values that do not apply
        are None.
    """
    accumulator = DesignAccumulator.for_machine(result.machine)
    if accumulator is None:
        return None
    accumulator.add(result)
    return accumulator.summary(cs, getattr(result, "located", None))


class DesignAccumulator:
    """The dynamic design scalars folded over a run's samples, piece by piece.

    An in-memory run feeds its whole result once; a streamed run (:mod:`camsim.run.stream`)
    feeds each piece as it is written, so the summary covers every revolution in bounded
    memory: peaks and their times (first occurrence wins, as ``argmax``), the RMS torque
    from the running sum of squares, and the torque of the first recorded revolution
    (one revolution of samples) for the energy fluctuation.
    """

    def __init__(self, geometry: CamGeometry, program):
        self.geometry = geometry
        self.program = program
        self.peak_normal = None
        self.peak_stress = None  # (value, time)
        self.peak_torque = None  # (|value|, time)
        self.sum_squares = 0.0
        self.count = 0
        self.first_time: list[np.ndarray] = []
        self.first_torque: list[np.ndarray] = []
        #: (t [s], T [N*m]) at the end of the first recorded revolution, t = one period, from
        #: the exact state the integrator stopped at there (camsim.run.simulation); the
        #: revolution is closed with it rather than with the samples around it (issue 26).
        self.period_end: tuple[float, float] | None = None

    @classmethod
    def for_machine(cls, machine) -> "DesignAccumulator | None":
        """An empty accumulator for a machine with ``[cam.geometry]``, else None."""
        cam = machine.cam
        geometry = None if cam is None else getattr(cam, "geometry", None)
        if geometry is None:
            return None
        from camsim.cam.program import CamProgram

        return cls(geometry, CamProgram(cam))

    def add(self, result) -> None:
        """Fold in the samples of one result (a whole run, or one streamed piece)."""
        traces = _design_traces_of(result)
        time = np.asarray(_trace(result, "time"), dtype=float)
        if not time.size:
            return
        end = getattr(result, "period_end", None)
        if end is not None and self.period_end is None:
            self.period_end = (float(end["time"]), float(end["torque"]))
        if "cam_contact/normal_force" in traces:
            value = float(np.max(traces["cam_contact/normal_force"][0]))
            self.peak_normal = value if self.peak_normal is None else max(self.peak_normal, value)
        if "cam_contact/hertz_stress" in traces:
            stress = traces["cam_contact/hertz_stress"][0]
            if np.any(np.isfinite(stress)):
                k = int(np.nanargmax(stress))
                if self.peak_stress is None or stress[k] > self.peak_stress[0]:
                    self.peak_stress = (float(stress[k]), float(time[k]))
        if "camshaft/torque" in traces:
            torque = np.asarray(traces["camshaft/torque"][0], dtype=float)
            k = int(np.argmax(np.abs(torque)))
            if self.peak_torque is None or abs(torque[k]) > self.peak_torque[0]:
                self.peak_torque = (float(abs(torque[k])), float(time[k]))
            self.sum_squares += float(np.sum(torque**2))
            self.count += torque.size
            period = self.program.period
            reach = time <= period * (1.0 + 1e-12)
            # keep the first revolution, and the sample after it (to close it at t = T)
            if self._needs_more(period):
                n = int(np.count_nonzero(reach)) + 1
                self.first_time.append(time[:n])
                self.first_torque.append(torque[:n])

    def _needs_more(self, period: float) -> bool:
        if not self.first_time:
            return True
        last = self.first_time[-1]
        return last.size == 0 or last[-1] <= period * (1.0 + 1e-12)

    def summary(self, cs: float | None = None, located: dict | None = None) -> dict:
        """The design dict of :func:`design_summary`; the peak torque is the located one of
        ``located`` (the run's located extremes, spec §4) when it has it."""
        static = geometry_summary(self.geometry, self.program)
        out = {k: v for k, v in static.items() if k not in ("defects",)}
        out["defects"] = [d.describe(self.geometry) for d in static["defects"]]
        nan = None
        out.update(peak_normal_force=nan, peak_hertz_stress=nan, peak_hertz_stress_time=nan, peak_torque=nan,
                   peak_torque_time=nan, rms_torque=nan, cycle_work=nan, energy_fluctuation=nan, cs=cs,
                   flywheel_inertia=nan)
        reasons: dict[str, str] = {}  # why a value is None (issue 26: never a bare "–")
        if self.peak_torque is None:
            why = "the run records no camshaft torque (no cam contact force)"
            for name in ("peak_torque", "peak_torque_time", "rms_torque", "cycle_work", "energy_fluctuation"):
                reasons[name] = why
        if self.peak_stress is None:
            reasons["peak_hertz_stress"] = reasons["peak_hertz_stress_time"] = (
                "no Hertz stress: the contact force or the surface curvature is never positive")
        if self.peak_normal is None:
            reasons["peak_normal_force"] = "the run records no cam contact force"
        if self.peak_normal is not None:
            out["peak_normal_force"] = self.peak_normal
        if self.peak_stress is not None:
            out["peak_hertz_stress"], out["peak_hertz_stress_time"] = self.peak_stress
        if self.peak_torque is not None:
            out["peak_torque"], out["peak_torque_time"] = self.peak_torque
            hit = (located or {}).get("camshaft/torque")
            if hit is not None:
                top, bottom = hit["max"], hit["min"]
                best = top if abs(top.value) >= abs(bottom.value) else bottom
                out["peak_torque"], out["peak_torque_time"] = abs(best.value), best.time
            out["rms_torque"] = float(np.sqrt(self.sum_squares / self.count))
            time = np.concatenate(self.first_time)
            torque = np.concatenate(self.first_torque)
            period = self.program.period
            if self.period_end is not None:
                t_end, tq_end = self.period_end
                keep = time < t_end - 1e-9 * period  # samples of [0, T); T itself is the exact end
                rev = (np.append(time[keep], t_end), np.append(torque[keep], tq_end)) if keep.any() else None
            else:
                rev = _one_revolution(time, torque, period)
            if rev is None:
                why = (f"the run records less than one revolution ({period:.6g} s); the energy over a revolution "
                       "needs a whole one (--cycles 1 or more)")
                for name in ("cycle_work", "energy_fluctuation"):
                    reasons.setdefault(name, why)
            if rev is not None:
                t, tq = rev
                work, delta = energy_fluctuation(self.program.speed * t, tq)
                out["cycle_work"] = work
                out["energy_fluctuation"] = delta
                if cs is not None:
                    out["flywheel_inertia"] = flywheel_inertia(delta, cs, self.program.speed)
        if cs is None:
            reasons["flywheel_inertia"] = "give --cs, the coefficient of speed fluctuation"
        elif out["flywheel_inertia"] is None:
            reasons["flywheel_inertia"] = reasons.get("energy_fluctuation", "no energy fluctuation")
        out["reasons"] = {k: v for k, v in reasons.items() if out.get(k) is None}
        return out


def design_columns(machine) -> list[tuple[str, str]]:
    """Sweep summary columns for a machine: :data:`DESIGN_COLUMNS` if it has geometry."""
    cam = machine.cam
    return list(DESIGN_COLUMNS) if cam is not None and getattr(cam, "geometry", None) is not None else []


def design_row(result) -> dict:
    """The :data:`DESIGN_COLUMNS` of one run (NaN where they do not apply); {} without geometry."""
    return design_row_from(design_summary(result))


def design_row_from(summary: dict | None) -> dict:
    """The :data:`DESIGN_COLUMNS` of a :func:`design_summary` dict; {} for None."""
    if summary is None:
        return {}
    return {name: (float("nan") if summary.get(name) is None else float(summary[name])) for name, _ in DESIGN_COLUMNS}


def design_comparison(impact, no_impact) -> list[dict]:
    """Peak stress and torque with and without impact, side by side.

    Returns
    -------
    list of dict
        ``quantity``, ``units``, ``impact``, ``no_impact``, ``change_percent``
        (100·(impact − no impact)/no impact); empty without geometry.
    """
    a, b = design_summary(impact), design_summary(no_impact)
    if a is None or b is None:
        return []
    rows = []
    for key, units in (("peak_normal_force", "N"), ("peak_hertz_stress", "Pa"), ("peak_torque", "N*m"),
                       ("rms_torque", "N*m"), ("energy_fluctuation", "J")):
        va, vb = a.get(key), b.get(key)
        change = None
        if va is not None and vb is not None and vb != 0:
            change = 100.0 * (va - vb) / abs(vb)
        row = {"quantity": key, "units": units, "impact": va, "no_impact": vb, "change_percent": change}
        why = (a.get("reasons") or {}).get(key) or (b.get("reasons") or {}).get(key)
        if why and (va is None or vb is None):
            row["reason"] = why  # issue 35: a missing value says why
        rows.append(row)
    return rows

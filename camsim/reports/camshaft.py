"""The camshaft section of a run page (issue 38): timing diagram, torques, speed, flywheel, clearances.

Every number comes from the run result hub (:meth:`camsim.run.result.RunResult.camshaft_summary`)
or the file's traces; nothing is recomputed here.
"""

from __future__ import annotations

import numpy as np

from camsim.reports.display import shown
from camsim.reports.envelope import envelope
from camsim.reports.figures import trace_figure, xy_figure
from camsim.reports.page import Plot, Section, Source, esc, fmt, table

__all__ = ["camshaft_section"]


def unit_label(si_unit: str) -> tuple[str, float]:
    """(unit shown, scale from SI) of a quantity in the page's units (as the run sections)."""
    unit, scale = shown(si_unit, "si")
    return (unit or "-"), scale


def camshaft_section(source: Source, view) -> Section | None:
    """Several cams, or a [camshaft] (issue 38): the timing diagram (every cam's follower motion
    against the shaft angle over one revolution), each cam's and the shaft's torque, the speed
    of a dynamic shaft, and the camshaft table of the hub's summary."""
    shaft_angle, torque = view.data("camshaft/angle"), view.data("camshaft/torque")
    if shaft_angle is None or torque is None:
        return None
    s = Section(source.name("camshaft"), "Camshaft: timing, torque, flywheel")
    one = shaft_angle <= shaft_angle[0] + 360.0
    cams = sorted({p.split("/")[1] for p in view.traces if p.startswith("cams/")},
                  key=lambda c: list(view.traces).index(f"cams/{c}/angle"))
    if cams:
        unit, scale = unit_label("m")
        series = []
        for c in cams:
            x, y, _ = envelope(shaft_angle[one], view.data(f"cams/{c}/displacement")[one] * scale)
            series.append((c, x, y))
        p = xy_figure(source.name("timing"), "Timing diagram: every cam's follower motion", "shaft angle [deg]",
                      f"displacement [{unit}]", series, height=260)
        s.add(Plot(p, f"Each cam's displacement on the model axis [{unit}] against the shaft's angle [deg] over the "
                      "first recorded revolution."))
    series = [(f"cam {c}", *envelope(view.time, view.data(f"cams/{c}/torque"))[:2]) for c in cams
              if view.data(f"cams/{c}/torque") is not None]
    series.append(("shaft", *envelope(view.time, torque)[:2]))
    s.add(Plot(trace_figure(source.name("torque"), "Camshaft torque (F·ds/dθ, simulated contact forces)",
                            "torque [N·m]", series), "Each cam's torque and their sum, the shaft's [N·m], against time [s]."))
    speed = view.data("camshaft/speed")
    if speed is not None and np.ptp(speed) > 1e-12 * float(np.max(np.abs(speed))):
        s.add(Plot(trace_figure(source.name("speed"), "Camshaft speed (dynamic shaft)", "speed [rad/s]",
                                [("drive side", *envelope(view.time, speed)[:2])]),
                   "The drive side's speed [rad/s] against time [s]."))
    shaft = _camshaft(source, view)
    if shaft is not None:
        rows = [("peak |shaft torque|", shaft["peak_torque"], "N·m"), ("RMS shaft torque", shaft["rms_torque"], "N·m"),
                ("work per revolution", shaft["cycle_work"], "J"), ("energy excursion E_k", shaft["energy_excursion"], "J"),
                ("peak |motor torque|", shaft["peak_motor_torque"], "N·m"), ("RMS motor torque", shaft["rms_motor_torque"], "N·m"),
                ("(max − min)/ω̄", shaft["speed_fluctuation"], "")]
        if shaft.get("cs") is not None:
            rows.append((f"flywheel inertia for C_s = {shaft['cs']:g}", shaft["flywheel_inertia"], "kg·m²"))
        s.add(table(["quantity", "value", "unit"], [(esc(n), fmt(v), esc(u)) for n, v, u in rows],
                    numeric=[False, True, False], caption="The camshaft, from the run result hub"))
        for name, c in (shaft.get("clearances") or {}).items():
            s.add(f"<p>Clearance {esc(name)} ({esc(' – '.join(c['between']))}): smallest "
                  f"{fmt(None if c['minimum_distance'] is None else 1e3 * c['minimum_distance'])} mm at shaft angle "
                  f"{fmt(c['shaft_angle_deg'])} deg, allowed {fmt(1e3 * c['allowed'])} mm"
                  f"{': COLLISION' if c['collides'] else ''}.</p>")
    return s


def _camshaft(source: Source, view) -> dict | None:
    """The hub's camshaft summary when the file holds every trace."""
    if source.path is None:
        return None
    from camsim.errors import ResultFileError
    from camsim.run.result import open_result

    try:
        return open_result(source.path, view.label or None).camshaft_summary()
    except ResultFileError:
        return None

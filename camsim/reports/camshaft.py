"""The camshaft section of a run page (issue 38): timing diagram, torques, speed, flywheel, clearances.

Every number comes from the run result hub (:meth:`camsim.run.result.RunResult.camshaft_summary`)
or the file's traces; nothing is recomputed here.
"""

from __future__ import annotations

import numpy as np

from camsim.reports.envelope import envelope
from camsim.reports.figures import trace_figure, xy_figure
from camsim.reports.page import Plot, Section, Source, esc, table

__all__ = ["camshaft_section"]


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
        label = source.show(1.0, "m").label("displacement")
        series = []
        for c in cams:
            x, y, _ = envelope(shaft_angle[one], source.show(view.data(f"cams/{c}/displacement")[one], "m").values)
            series.append((c, x, y))
        p = xy_figure(source.name("timing"), "Timing diagram: every cam's follower motion", "shaft angle [deg]",
                      label, series, height=260)
        s.add(Plot(p, f"Each cam's {label} on the model axis against the shaft's angle [deg] over the "
                      "first recorded revolution."))
    # Issue 44: torques and speeds in the page's units (they were N·m and rad/s on an inch page).
    series = [(f"cam {c}", *envelope(view.time, source.show(view.data(f"cams/{c}/torque"), "N*m").values)[:2]) for c in cams
              if view.data(f"cams/{c}/torque") is not None]
    series.append(("shaft", *envelope(view.time, source.show(torque, "N*m").values)[:2]))
    t_label = source.show(1.0, "N*m").label("torque")
    s.add(Plot(trace_figure(source.name("torque"), "Camshaft torque (F·ds/dθ, simulated contact forces)", t_label, series),
               f"Each cam's torque and their sum, the shaft's, {t_label}, against time [s]."))
    speed = view.data("camshaft/speed")
    if speed is not None and np.ptp(speed) > 1e-12 * float(np.max(np.abs(speed))):
        shown = source.show(speed, "rad/s")
        s.add(Plot(trace_figure(source.name("speed"), "Camshaft speed (dynamic shaft)", shown.label("speed"),
                                [("drive side", *envelope(view.time, shown.values)[:2])]),
                   f"The drive side's {shown.label('speed')} against time [s]."))
    shaft = _camshaft(source, view)
    if shaft is not None:
        rows = [("peak |shaft torque|", shaft["peak_torque"], "N*m"), ("RMS shaft torque", shaft["rms_torque"], "N*m"),
                ("work per revolution", shaft["cycle_work"], "J"), ("energy excursion E_k", shaft["energy_excursion"], "J"),
                ("peak |motor torque|", shaft["peak_motor_torque"], "N*m"), ("RMS motor torque", shaft["rms_motor_torque"], "N*m"),
                ("(max − min)/ω̄", shaft["speed_fluctuation"], "")]
        if shaft.get("cs") is not None:
            rows.append(("flywheel inertia for C_s = <span class=rule>" + f"{shaft['cs']:g}</span>", shaft["flywheel_inertia"], "kg*m^2"))
        s.add(table(["quantity", "value", "unit"],
                    [(n, source.number(v, u), esc(source.show(1.0, u).unit or "-")) for n, v, u in rows],
                    numeric=[False, True, False], caption="The camshaft, from the run result hub"))
        for name, c in (shaft.get("clearances") or {}).items():
            s.add(f"<p>Clearance {esc(name)} ({esc(' – '.join(c['between']))}): smallest "
                  f"{source.quantity(c['minimum_distance'], 'm')} at shaft angle "
                  f"{source.quantity(c['shaft_angle_deg'], 'deg')}, allowed {source.quantity(c['allowed'], 'm')}"
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

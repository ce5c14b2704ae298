"""Human-readable summaries of runs (rich tables on stderr), in display units.

Every value is shown through :class:`camsim.display.DisplayUnits` (``--units``: the machine
file's units by default), every header carries its unit.
"""

from __future__ import annotations

import math

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from camsim.display import DisplayUnits, in_units
from camsim.reports.display import as_display

#: SI unit of each mass quantity (shown in the display units).
_SI_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}


def _fmt(value, fmt: str = ".4g") -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    if isinstance(value, float) and math.isinf(value):
        return "∞"
    return format(value, fmt)


#: Impact rows the human summary prints (a long run has thousands; the file has them all).
MAX_IMPACT_ROWS = 40


def render_run_summary(result, console: Console, units: DisplayUnits | str | None = None, cs: float | None = None) -> None:
    """Print the summary of a :class:`~camsim.run.result.RunResult` (or a streamed run's summary).

    Every column header carries the unit its values are printed in (escaped, so rich
    does not take ``[mm]`` for markup); ``units`` are the display units (default: the
    machine file's, :attr:`Machine.display_units`; ``"si"``/``"us"`` name the fixed ones).
    ``cs`` is the coefficient of speed fluctuation for the flywheel inertia (machines with
    ``[cam.geometry]`` only).
    """
    system = as_display(units, result.machine)
    summary = result.summary()
    title = f"{result.machine.name}" + (" — no-impact variant" if result.no_impact else "")
    table = Table(title=escape(title), title_justify="left")
    table.add_column("mass")
    units = {q: system.shown(u) for q, u in _SI_UNITS.items()}
    for quantity, (unit, _) in units.items():
        table.add_column(escape(f"peak |{quantity[:5]}.| [{unit}]"), justify="right")
        table.add_column(escape("at t [s]"), justify="right")
    interior = {n for e in result.machine.elements for n in e.interior_nodes()}  # issue 39: rods
    for name, entry in summary["masses"].items():
        if name in interior:
            continue
        row = [escape(name)]
        for quantity, (_, scale) in units.items():
            row += [_fmt(entry[quantity]["peak"] * scale), _fmt(entry[quantity]["time"], ".5f")]
        table.add_row(*row)
    console.print(table)
    render_rods(summary, console, system)
    render_loads(summary, console, system)
    render_friction(summary, console, system)
    if summary["peak_transducer_force"]:
        p = summary["peak_transducer_force"]
        console.print(f"peak transducer force: {system.quantity(p['value'], 'N')} at t = {p['time']:.5f} s", markup=False)
    if summary["max_cam_contact_force"]:
        hi, lo = summary["max_cam_contact_force"], summary["min_cam_contact_force"]
        console.print(f"cam contact force: max {system.quantity(hi['value'], 'N')} at t = {hi['time']:.5f} s, "
                      f"min {system.quantity(lo['value'], 'N')} at t = {lo['time']:.5f} s", markup=False)
    impacts = result.impacts()
    if impacts:
        shown_rows = impacts[:MAX_IMPACT_ROWS]
        title = "impacts" if len(impacts) == len(shown_rows) else f"impacts (the first {len(shown_rows)} of {len(impacts)})"
        t = Table(title=escape(title), title_justify="left")
        v_unit, v_scale = system.shown("m/s")
        f_unit, f_scale = system.shown("N")
        # Issue 44: Johnson's bounds estimate the impulsive peak, the simulated peak minus the preload
        # the interface holds at rest; the table shows it beside them when an impact has a preload.
        from camsim.run.checks import impact_preload

        elements = {e.name: e for e in result.machine.elements}
        preload = {e.element: impact_preload(elements[e.element]) for e in shown_rows if e.element in elements}
        impulsive = any(preload.values())
        columns = ["t [s]", "angle [deg]", "element", "masses", f"approach [{v_unit}]", f"Johnson lower [{f_unit}]",
                   f"Johnson upper [{f_unit}]", f"simulated peak [{f_unit}]"]
        columns += [f"impulsive [{f_unit}]"] if impulsive else []
        for col in columns + ["duration [ms]"]:
            t.add_column(escape(col), justify="right", min_width=len(col) if col.startswith(("duration", "t [")) else None)
        for e in shown_rows:
            row = [f"{e.time:.6f}", _fmt(e.angle_deg, ".2f"), escape(e.element), escape(e.masses), _fmt(e.relative_velocity * v_scale),
                   _fmt(e.johnson_lower * f_scale), _fmt(e.johnson_upper * f_scale), _fmt(e.peak_force * f_scale)]
            row += [_fmt((e.peak_force - preload.get(e.element, 0.0)) * f_scale)] if impulsive else []
            t.add_row(*row, _fmt(e.contact_duration * 1e3 if not math.isnan(e.contact_duration) else float("nan")))
        console.print(t)
        if impulsive:
            console.print("impulsive: the simulated peak minus the preload the interface holds at rest ("
                          + ", ".join(f"{name} {system.quantity(p, 'N')}" for name, p in preload.items() if p)
                          + "), the part Johnson's bounds estimate", markup=False)
        for note in _dash_notes(shown_rows):  # issue 35: every "–" says why
            console.print(note, markup=False)
        if len(impacts) > len(shown_rows):
            console.print(f"... {len(impacts) - len(shown_rows)} more impacts: all are in the file's /events table and in --json")
    else:
        console.print("no impacts")
    others = [e for e in result.events if e.kind not in ("impact", "rejoin")]
    if others:
        kinds = {}
        for e in others:
            kinds[e.kind] = kinds.get(e.kind, 0) + 1
        console.print("other events: " + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())))
    if "design" in summary:  # issue 14: cam design checks and dynamic quantities
        design = summary["design"] if cs is None else result.design_summary(cs)
        render_geometry_checks(design, console, units=system)
        render_design_dynamics(design, console, units=system)
    if "camshaft" in summary:  # issue 38: several cams, or a [camshaft]
        shaft = summary["camshaft"] if cs is None else {**result.camshaft_summary(cs),
                                                         "dynamics": summary["camshaft"].get("dynamics")}
        render_camshaft(shaft, console, system)
    residual = result.periodicity_residual
    console.print(
        "periodicity residual (state one revolution apart, relative to peak): "
        + ("not computed" if math.isnan(residual) else f"{residual:.3g}")
        + (f" (steady state by shooting, {result.steady_state['revolutions']} "
           f"revolution{'' if result.steady_state['revolutions'] == 1 else 's'})"
           if (result.steady_state or {}).get("method") == "shooting" else "")
        + (" [-], above 1e-3: not a steady state (add warm-up revolutions, --warmup); per-revolution figures "
           "such as work and energy are of this revolution only" if residual > 1e-3 else "")
    )
    for warning in result.warnings:
        console.print(f"warning: {in_units(warning, system)}", style="yellow", markup=False)


def render_loads(summary: dict, console: Console, system: DisplayUnits) -> None:
    """The process loads (issue 43): each one's mass, program, located largest and smallest
    force with when, and its work per cycle (over the record without a revolution)."""
    loads = summary.get("loads")
    if not loads:
        return
    f_unit, f_scale = system.shown("N")
    w_unit, w_scale = system.shown("J")
    over = next(iter(loads.values()))["work_over"]
    table = Table(title="process loads", title_justify="left")
    for col in ("load", "on", "program", f"max [{f_unit}]", "at t [s]", f"min [{f_unit}]", "at t [s]",
                f"work {'per cycle' if over == 'revolution' else 'over the record'} [{w_unit}]"):
        table.add_column(escape(col), justify="left" if col in ("load", "on", "program") else "right")
    for name, row in loads.items():
        cells = [escape(name), escape(row["on"]), escape(row["program"])]
        for which in ("max", "min"):
            hit = row[which]
            cells += [_fmt(hit["value"] * f_scale), _fmt(hit["time"], ".5f")] if hit else ["–", "–"]
        cells.append(_fmt(row["work"] * w_scale) if row["work"] is not None else "–")
        table.add_row(*cells)
    console.print(table)
    if over == "revolution":
        console.print("work per cycle: ∫F·ẋ dt over the first recorded revolution, on the solution (docs/machine-file.md, "
                      "loads); positive when the load drives the mass", markup=False)
    else:
        console.print("work over the record (no whole revolution recorded): ∫F·ẋ dt on the solution", markup=False)


def render_friction(summary: dict, console: Console, system: DisplayUnits) -> None:
    """The friction pairs (spec §10): each one's nodes, Coulomb and break-away forces, the
    energy it dissipates per cycle (over the record without a revolution) and its stick and
    slip counts."""
    pairs = summary.get("friction")
    if not pairs:
        return
    f_unit, f_scale = system.shown("N")
    w_unit, w_scale = system.shown("J")
    over = next(iter(pairs.values()))["over"]
    table = Table(title="friction", title_justify="left")
    for col in ("pair", "between", f"F_C [{f_unit}]", f"F_B [{f_unit}]",
                f"dissipated {'per cycle' if over == 'revolution' else 'over the record'} [{w_unit}]", "sticks", "slips"):
        table.add_column(escape(col), justify="left" if col in ("pair", "between") else "right")
    for name, row in pairs.items():
        programmed = row.get("normal_force")  # F_C, F_B follow the normal force's program
        table.add_row(escape(name), escape(" / ".join(row["between"])),
                      f"μ·N ({programmed})" if programmed else _fmt(row["coulomb_force"] * f_scale),
                      "μ_s·N" if programmed else _fmt(row["breakaway_force"] * f_scale),
                      _fmt(row["energy"] * w_scale) if row["energy"] is not None else "–",
                      str(row["sticks"]), str(row["slips"]))
    console.print(table)
    console.print("dissipated: ∫f·ḋ dt " + ("over the first recorded revolution" if over == "revolution" else
                  "over the recorded time") + ", on the solution (docs/forces.md); sticks and slips: the pair's rows "
                  "of the event table", markup=False)


def render_rods(summary: dict, console: Console, system: DisplayUnits) -> None:
    """Rods (discretisation, largest stress and end force) and Hertz contacts against yield (issue 39),
    in the display units ``system``."""
    f_unit, f_scale = system.shown("N")
    s_unit, s_scale = system.shown("Pa")
    for name, row in summary.get("rods", {}).items():
        stress, force = row.get("max_stress"), row.get("max_end_force")
        inner = row["interior_nodes"]
        reason = in_units(row["segments_reason"], system)  # composed in SI (the approach speed)
        text = (f"rod {name}: {reason}; interior nodes {inner[0]} … {inner[-1]} in the file"
                if inner else f"rod {name}: {reason}")
        console.print(text, markup=False)
        if stress is not None:
            limit = row.get("yield_strength")
            versus = f" ({100 * stress['value'] / limit:.3g} % of the yield strength)" if limit else ""
            console.print(f"  largest |axial stress| {stress['value'] * s_scale:.4g} {s_unit} at t = {stress['time']:.6f} s{versus}; "
                          f"largest end force {force['value'] * f_scale:.4g} {f_unit} at t = {force['time']:.6f} s",
                          markup=False)
    rows = summary.get("contact_stress", [])
    if rows:
        t = Table(title="contact stress at the largest impact (Hertz)", title_justify="left")
        for col in ("element", "materials", f"peak force [{f_unit}]", f"peak pressure [{s_unit}]",
                    f"first yield [{s_unit}]", "ratio"):
            t.add_column(escape(col), justify="right")
        for r in rows:
            t.add_row(escape(r["element"]), escape(" / ".join(r["materials"])), _fmt(r["peak_force"] * f_scale),
                      _fmt(r["peak_pressure"] * s_scale),
                      "no yield strength given for these materials" if r["yield_pressure"] is None
                      else f"{r['yield_pressure'] * s_scale:.4g} ({escape(r['yields_first'])})",
                      _fmt(r["ratio"], ".3g"))
        console.print(t)


def _dash_notes(impacts) -> list[str]:
    """Why an impact row shows "–": one line per column that has one."""
    notes = []
    if any(math.isnan(e.contact_duration) for e in impacts):
        notes.append("duration –: the contact is still closed when the recording ends (it outlasts the recorded "
                     "revolutions; record more with --cycles to see it open)")
    if any(math.isnan(e.peak_force) for e in impacts):
        notes.append("simulated peak –: no output sample fell inside the contact (sample faster with --sample-rate "
                     "to resolve it)")
    if any(math.isnan(e.johnson_lower) or math.isnan(e.johnson_upper) for e in impacts):
        notes.append("Johnson –: no common-velocity estimate for this contact (its law has no closed form; the "
                     "simulated peak is the figure)")
    if any(math.isnan(e.relative_velocity) for e in impacts):
        notes.append("approach –: the contact closed without relative speed (a closing at rest)")
    return notes


def _at(value, fmt=".4g", unit="deg") -> str:
    return "–" if value is None else f"{format(value, fmt)} {unit}"


def render_geometry_checks(summary: dict, console: Console, title: str = "cam geometry checks",
                           units: DisplayUnits | str | None = None) -> None:
    """Print the static cam design checks (:func:`camsim.cam.geometry.geometry_summary`), lengths in ``units``."""
    system = as_display(units)
    length, k = system.shown("m")
    table = Table(title=escape(title), title_justify="left")
    for column in ("check", "value", "unit", "at cam angle [deg]", "limit"):
        table.add_column(escape(column), justify="left" if column == "check" else "right")
    roller = summary["follower"] != "translating-flat"
    if roller:
        table.add_row("max |pressure angle|", _fmt(summary["max_pressure_angle"]), "deg",
                      _fmt(summary["max_pressure_angle_at"], ".5g"), f"{summary['pressure_angle_limit']:.4g}")
    ln = lambda v: None if v is None else k * v  # noqa: E731
    if roller:
        table.add_row("min convex pitch radius", _fmt(ln(summary["min_pitch_radius"])), length,
                      _fmt(summary["min_pitch_radius_at"], ".5g"), f"> Rr = {k * summary['roller_radius']:.4g}")
    table.add_row("min convex surface radius" if roller else "min surface radius Rb+s+s''",
                  _fmt(ln(summary["min_surface_radius"])), length,
                  _fmt(summary["min_surface_radius_at"], ".5g"), "> 0")
    table.add_row("min concave surface radius", _fmt(ln(summary["min_concave_radius"])), length,
                  _fmt(summary["min_concave_radius_at"], ".5g"), "")
    if not roller:
        table.add_row("face width needed", _fmt(ln(summary["face_width"])), length, "", "")
        table.add_row("contact from axis", f"{k * summary['face_min_contact']:.4g} to {k * summary['face_max_contact']:.4g}",
                      length, "", "")
    console.print(table)
    for key in ("min_pitch_radius", "min_surface_radius", "min_concave_radius"):  # issue 35: every "–" says why
        if (roller or key != "min_pitch_radius") and summary.get(key) is None:
            console.print(f"{key.replace('_', ' ')} –: " + {"min_concave_radius": "the cam has no concave part",
                                                            }.get(key, "no convex part of the curve"), markup=False)
    for warning in summary.get("warnings", ()):
        console.print(f"warning: {in_units(warning, system)}", style="yellow", markup=False)


def render_design_dynamics(summary: dict, console: Console, units: DisplayUnits | str | None = None) -> None:
    """Print stress, torque and flywheel figures of :func:`camsim.cam.design.design_summary` in ``units``."""
    system = as_display(units)
    table = Table(title="cam design, from the simulated contact force", title_justify="left")
    for column in ("quantity", "value", "unit", "at t [s]"):
        table.add_column(escape(column), justify="left" if column == "quantity" else "right")
    rows = (
        ("peak normal force", summary["peak_normal_force"], "N", None),
        ("peak Hertz stress", summary["peak_hertz_stress"], "Pa", summary["peak_hertz_stress_time"]),
        ("peak |camshaft torque|", summary["peak_torque"], "N*m", summary["peak_torque_time"]),
        ("RMS camshaft torque", summary["rms_torque"], "N*m", None),
        ("work per revolution", summary["cycle_work"], "J", None),
        ("energy fluctuation ΔE", summary["energy_fluctuation"], "J", None),
    )
    keys = ("peak_normal_force", "peak_hertz_stress", "peak_torque", "rms_torque", "cycle_work", "energy_fluctuation")
    reasons = summary.get("reasons", {})
    notes = []
    for key, (name, value, si_unit, when) in zip(keys, rows):
        unit, k = system.shown(si_unit)
        why = reasons.get(key)
        if value is None and why:
            notes.append(f"{name}: {why}")
            table.add_row(name, f"n/a ({len(notes)})", unit, "")
        else:
            table.add_row(name, _fmt(None if value is None else value * k), unit, _fmt(when, ".5f") if when is not None else "")
    if summary.get("cs") is not None:
        value = summary["flywheel_inertia"]
        name = f"flywheel inertia (Cs = {summary['cs']:g})"
        unit, k = system.shown("kg*m^2")
        if value is None and reasons.get("flywheel_inertia"):
            notes.append(f"{name}: {reasons['flywheel_inertia']}")
            table.add_row(name, f"n/a ({len(notes)})", unit, "")
        else:
            table.add_row(name, _fmt(None if value is None else value * k), unit, "")
    console.print(table)
    for k, note in enumerate(notes, 1):
        console.print(f"  ({k}) {note}", markup=False)


def render_camshaft(summary: dict, console: Console, units: DisplayUnits | str | None = None) -> None:
    """Print the camshaft section (:meth:`camsim.run.result.RunResult.camshaft_summary`): each
    cam's torque and contact force, the shaft's torque, work, energy excursion, flywheel,
    motor torque, speed, and the clearances, in the display units ``units`` (issue 44: they were
    N·m, J, kg·m², mm and rad/s whatever the file or --units)."""
    system = as_display(units)
    torque, force, length = system.shown("N*m"), system.shown("N"), system.shown("m")
    cams = summary.get("cams") or {}
    if cams:
        table = Table(title="cams on the shaft (torque T = F·ds/dθ from the simulated contact force)",
                      title_justify="left")
        for column in ("cam", "phase [deg]", "drives", f"peak |T| [{torque[0]}]", "at t [s]", f"RMS T [{torque[0]}]",
                       f"contact force max [{force[0]}]", f"min [{force[0]}]", "at t [s]"):
            table.add_column(escape(column), justify="left" if column in ("cam", "drives") else "right")
        for name, c in cams.items():
            table.add_row(escape(name), _fmt(c["phase_deg"], ".5g"), escape(c["drives"] or "–"),
                          _fmt(_scaled(c["peak_torque"], torque)), _fmt(c["peak_torque_time"], ".5f"),
                          _fmt(_scaled(c["rms_torque"], torque)), _fmt(_scaled(c["max_contact_force"], force)),
                          _fmt(_scaled(c["min_contact_force"], force)), _fmt(c["min_contact_force_time"], ".5f"))
        console.print(table)
    table = Table(title=escape(f"camshaft ({summary['model']}, {system.quantity(summary['mean_speed'], 'rad/s', '.6g')})"),
                  title_justify="left")
    for column in ("quantity", "value", "unit", "at t [s]"):
        table.add_column(escape(column), justify="left" if column == "quantity" else "right")
    reasons = summary.get("reasons", {})
    rows = [
        ("peak |shaft torque|", summary["peak_torque"], "N*m", summary["peak_torque_time"], "peak_torque"),
        ("RMS shaft torque", summary["rms_torque"], "N*m", None, "rms_torque"),
        ("work per revolution (into the stations)", summary["cycle_work"], "J", None, "cycle_work"),
        ("energy excursion E_k", summary["energy_excursion"], "J", None, "energy_excursion"),
        ("drive work per revolution", summary.get("drive_work"), "J", None, "drive_work"),
        ("peak |motor torque|", summary["peak_motor_torque"], "N*m", summary["peak_motor_torque_time"], "peak_motor_torque"),
        ("RMS motor torque", summary["rms_motor_torque"], "N*m", None, "rms_motor_torque"),
    ]
    if summary.get("cs") is not None:
        rows.append((f"flywheel inertia for C_s = {summary['cs']:g}", summary["flywheel_inertia"], "kg*m^2", None,
                     "flywheel_inertia"))
    if summary["model"] == "dynamic":
        rows += [("speed min", summary["min_speed"], "rad/s", None, "min_speed"),
                 ("speed max", summary["max_speed"], "rad/s", None, "max_speed"),
                 ("(max − min)/ω̄", summary["speed_fluctuation"], "", None, "speed_fluctuation")]
    notes = []
    for name, value, si_unit, when, key in rows:
        unit, k = system.shown(si_unit)
        why = reasons.get(key)
        if value is None and why:
            notes.append(f"{name}: {why}")
            table.add_row(escape(name), f"n/a ({len(notes)})", unit or "-", "")
        else:
            table.add_row(escape(name), _fmt(_scaled(value, (unit, k))), unit or "-", _fmt(when, ".5f") if when is not None else "")
    console.print(table)
    for k, note in enumerate(notes, 1):
        console.print(f"  ({k}) {note}", markup=False)
    dynamics = summary.get("dynamics")
    if dynamics:
        freqs = ", ".join(f"{f:.4g}" for f in dynamics["natural_frequencies_hz"]) or "none"
        console.print(f"dynamic camshaft: {dynamics['iterations']} relaxation iterations (last speed change "
                      f"{dynamics['speed_change']:.2g} of ω̄), torsional modes {freqs} Hz, mean drive speed "
                      f"{system.quantity(dynamics['mean_drive_speed'], 'rad/s', '.6g')}", markup=False)
    clearances = summary.get("clearances") or {}
    if clearances:
        table = Table(title="clearances (smallest distance over the recorded motion)", title_justify="left")
        for column in ("pair", "between", f"smallest [{length[0]}]", "shaft angle [deg]", "at t [s]", f"allowed [{length[0]}]", ""):
            table.add_column(escape(column), justify="left" if column in ("pair", "between", "") else "right")
        for name, c in clearances.items():
            table.add_row(escape(name), escape(" – ".join(c["between"])), _fmt(_scaled(c["minimum_distance"], length)),
                          _fmt(c["shaft_angle_deg"], ".2f"), _fmt(c["time"], ".5f"), _fmt(_scaled(c["allowed"], length)),
                          "COLLISION" if c["collides"] else "ok")
        console.print(table)


def _scaled(value, shown: tuple[str, float]):
    """An SI value (or None) in the display unit of ``shown`` (unit, factor)."""
    return None if value is None else value * shown[1]

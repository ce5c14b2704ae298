"""Human-readable summaries of runs (rich tables on stderr)."""

from __future__ import annotations

import math

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from camsim.reports.display import shown
from camsim.units import LBF

#: SI unit of each mass quantity (printed as camsim.reports.display.shown gives it).
_SI_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}


def _lbf(newton: float, system: str = "si") -> str:
    if system == "us":
        return f"{newton / LBF:.4g} lbf ({newton:.4g} N)"
    return f"{newton:.4g} N ({newton / LBF:.4g} lbf)"


def _fmt(value, fmt: str = ".4g") -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    if isinstance(value, float) and math.isinf(value):
        return "∞"
    return format(value, fmt)


#: Impact rows the human summary prints (a long run has thousands; the file has them all).
MAX_IMPACT_ROWS = 40


def render_run_summary(result, console: Console, system: str = "si", cs: float | None = None) -> None:
    """Print the summary of a :class:`~camsim.run.result.RunResult` (or a streamed run's summary).

    Every column header carries the unit its values are printed in (escaped, so rich
    does not take ``[mm]`` for markup); ``system`` is ``"si"`` (mm, m/s, N) or ``"us"``
    (in, in/s, lbf), see :mod:`camsim.reports.display`. ``cs`` is the coefficient of speed
    fluctuation for the flywheel inertia (machines with ``[cam.geometry]`` only).
    """
    summary = result.summary()
    title = f"{result.machine.name}" + (" — no-impact variant" if result.no_impact else "")
    table = Table(title=escape(title), title_justify="left")
    table.add_column("mass")
    units = {q: shown(u, system) for q, u in _SI_UNITS.items()}
    for quantity, (unit, _) in units.items():
        table.add_column(escape(f"peak |{quantity[:5]}.| [{unit}]"), justify="right")
        table.add_column(escape("at t [s]"), justify="right")
    for name, entry in summary["masses"].items():
        row = [escape(name)]
        for quantity, (_, scale) in units.items():
            row += [_fmt(entry[quantity]["peak"] * scale), _fmt(entry[quantity]["time"], ".5f")]
        table.add_row(*row)
    console.print(table)
    if summary["peak_transducer_force"]:
        p = summary["peak_transducer_force"]
        console.print(f"peak transducer force: {_lbf(p['value'], system)} at t = {p['time']:.5f} s", markup=False)
    if summary["max_cam_contact_force"]:
        hi, lo = summary["max_cam_contact_force"], summary["min_cam_contact_force"]
        console.print(f"cam contact force: max {_lbf(hi['value'], system)} at t = {hi['time']:.5f} s, min {_lbf(lo['value'], system)} at t = {lo['time']:.5f} s", markup=False)
    impacts = result.impacts()
    if impacts:
        shown_rows = impacts[:MAX_IMPACT_ROWS]
        title = "impacts" if len(impacts) == len(shown_rows) else f"impacts (the first {len(shown_rows)} of {len(impacts)})"
        t = Table(title=escape(title), title_justify="left")
        v_unit, v_scale = shown("m/s", system)
        f_unit, f_scale = shown("N", system)
        for col in ("t [s]", "angle [deg]", "element", "masses", f"approach [{v_unit}]", f"Johnson lower [{f_unit}]",
                    f"Johnson upper [{f_unit}]", f"simulated peak [{f_unit}]", "duration [ms]"):
            t.add_column(escape(col), justify="right")
        for e in shown_rows:
            t.add_row(
                f"{e.time:.6f}", _fmt(e.angle_deg, ".2f"), escape(e.element), escape(e.masses), _fmt(e.relative_velocity * v_scale),
                _fmt(e.johnson_lower * f_scale), _fmt(e.johnson_upper * f_scale), _fmt(e.peak_force * f_scale),
                _fmt(e.contact_duration * 1e3 if not math.isnan(e.contact_duration) else float("nan")),
            )
        console.print(t)
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
        render_geometry_checks(design, console)
        render_design_dynamics(design, console)
    residual = result.periodicity_residual
    console.print(
        "periodicity residual (state one revolution apart, relative to peak): "
        + ("not computed" if math.isnan(residual) else f"{residual:.3g}")
    )
    from camsim.reports.display import in_system

    for warning in result.warnings:
        console.print(f"warning: {in_system(warning, system)}", style="yellow", markup=False)


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


def render_geometry_checks(summary: dict, console: Console, title: str = "cam geometry checks") -> None:
    """Print the static cam design checks (:func:`camsim.cam.geometry.geometry_summary`)."""
    table = Table(title=title, title_justify="left")
    for column in ("check", "value", "unit", "at cam angle [deg]", "limit"):
        table.add_column(escape(column), justify="left" if column == "check" else "right")
    roller = summary["follower"] != "translating-flat"
    if roller:
        table.add_row("max |pressure angle|", _fmt(summary["max_pressure_angle"]), "deg",
                      _fmt(summary["max_pressure_angle_at"], ".5g"), f"{summary['pressure_angle_limit']:.4g}")
    mm = lambda v: None if v is None else 1e3 * v  # noqa: E731
    if roller:
        table.add_row("min convex pitch radius", _fmt(mm(summary["min_pitch_radius"])), "mm",
                      _fmt(summary["min_pitch_radius_at"], ".5g"), f"> Rr = {1e3 * summary['roller_radius']:.4g}")
    table.add_row("min convex surface radius" if roller else "min surface radius Rb+s+s''",
                  _fmt(mm(summary["min_surface_radius"])), "mm",
                  _fmt(summary["min_surface_radius_at"], ".5g"), "> 0")
    table.add_row("min concave surface radius", _fmt(mm(summary["min_concave_radius"])), "mm",
                  _fmt(summary["min_concave_radius_at"], ".5g"), "")
    if not roller:
        table.add_row("face width needed", _fmt(mm(summary["face_width"])), "mm", "", "")
        table.add_row("contact from axis", f"{1e3 * summary['face_min_contact']:.4g} to {1e3 * summary['face_max_contact']:.4g}",
                      "mm", "", "")
    console.print(table)
    for key in ("min_pitch_radius", "min_surface_radius", "min_concave_radius"):  # issue 35: every "–" says why
        if (roller or key != "min_pitch_radius") and summary.get(key) is None:
            console.print(f"{key.replace('_', ' ')} –: " + {"min_concave_radius": "the cam has no concave part",
                                                            }.get(key, "no convex part of the curve"), markup=False)
    for warning in summary.get("warnings", ()):
        console.print(f"warning: {warning}", style="yellow")


def render_design_dynamics(summary: dict, console: Console) -> None:
    """Print stress, torque and flywheel figures of :func:`camsim.cam.design.design_summary`."""
    table = Table(title="cam design, from the simulated contact force", title_justify="left")
    for column in ("quantity", "value", "unit", "at t [s]"):
        table.add_column(escape(column), justify="left" if column == "quantity" else "right")
    mpa = None if summary["peak_hertz_stress"] is None else summary["peak_hertz_stress"] / 1e6
    rows = (
        ("peak normal force", summary["peak_normal_force"], "N", None),
        ("peak Hertz stress", mpa, "MPa", summary["peak_hertz_stress_time"]),
        ("peak |camshaft torque|", summary["peak_torque"], "N·m", summary["peak_torque_time"]),
        ("RMS camshaft torque", summary["rms_torque"], "N·m", None),
        ("work per revolution", summary["cycle_work"], "J", None),
        ("energy fluctuation ΔE", summary["energy_fluctuation"], "J", None),
    )
    keys = ("peak_normal_force", "peak_hertz_stress", "peak_torque", "rms_torque", "cycle_work", "energy_fluctuation")
    reasons = summary.get("reasons", {})
    notes = []
    for key, (name, value, unit, when) in zip(keys, rows):
        why = reasons.get(key)
        if value is None and why:
            notes.append(f"{name}: {why}")
            table.add_row(name, f"n/a ({len(notes)})", unit, "")
        else:
            table.add_row(name, _fmt(value), unit, _fmt(when, ".5f") if when is not None else "")
    if summary.get("cs") is not None:
        value = summary["flywheel_inertia"]
        name = f"flywheel inertia (Cs = {summary['cs']:g})"
        if value is None and reasons.get("flywheel_inertia"):
            notes.append(f"{name}: {reasons['flywheel_inertia']}")
            table.add_row(name, f"n/a ({len(notes)})", "kg·m²", "")
        else:
            table.add_row(name, _fmt(value), "kg·m²", "")
    console.print(table)
    for k, note in enumerate(notes, 1):
        console.print(f"  ({k}) {note}", markup=False)

"""``camsim validate``: load a machine file and show it as loaded (in its own units), or say what is wrong.

A thin layer over :func:`camsim.machine.loader.load_machine` and
:func:`camsim.machine.loader.machine_to_dict`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
from pathlib import Path

import typer
from rich.markup import escape
from rich.table import Table

from camsim.cli.app import app, err_console, print_json, user_errors, warn_notes
from camsim.cli.units_option import check_units, machine_units, units_option
from camsim.display import in_units

if TYPE_CHECKING:  # numpy and the element kinds: imported by the command, not by --help
    from camsim.display import DisplayUnits
    from camsim.elements import Param
    from camsim.machine.description import Machine


@app.command("validate")
def validate(
    machine_file: Path = typer.Argument(
        ..., metavar="MACHINE.toml", help="Machine file (TOML, schema 1; see docs/machine-file.md)."
    ),
    overrides: list[str] = typer.Option(
        [],
        "--set",
        metavar="KEY=VALUE",
        help=(
            'Override a value before validation, with units as in the file: --set cam.speed="150 rpm", '
            "--set mass.M2.mass=\"1.7 lb\", --set element.seat.stiffness=9e6 (bare numbers are SI), "
            "--set cam.segments[2].lift=\"0.4 in\" (indices start at 0). Repeatable."
        ),
    ),
    json_output: bool = typer.Option(
        False, "--json", help="Print only the machine in SI as JSON on stdout (units in its 'units' map)."
    ),
    max_nodes: int = typer.Option(None, "--max-nodes", min=1, metavar="N", help="Refuse (exit 2, when the machine is loaded) a model of more nodes -- masses and rod interior nodes -- than this; default 500 (docs/results.md, \"Sizes\")."),
    max_cams: int = typer.Option(None, "--max-cams", min=1, metavar="N", help="Refuse a machine of more [[cam]] tables than this; default 100."),
    units: str = units_option(),
) -> None:
    """Check a machine file and print the machine as loaded (in the file's units; --units si for SI).

    Exit 0 if the file is valid; exit 2 with one line naming the file and the key
    (e.g. element[3].stiffness: expected [force]/[length], got "25 lbf") if not.
    """
    from camsim.machine.loader import load_machine, machine_to_dict

    from camsim.machine.limits import raised

    with user_errors(), raised(nodes=max_nodes, cams=max_cams):
        check_units(units)
        machine = load_machine(machine_file, overrides=overrides)
        warn_notes(machine)
        shown = machine_units(units, machine)
    if json_output:
        print_json(machine_to_dict(machine))
        return
    _print_machine(machine, shown)


def _g(x: float | None, si_unit: str, u: DisplayUnits) -> str:
    if x is None:
        return "-"
    return u.quantity(x, si_unit, ".6g")


def _shown(p: Param, element) -> bool:
    """Parameters worth a column: not the damping keys (their own column), not unset ones."""
    if p.dimension == "string" or p.key in ("damping", "damping_ratio", "reference_mass"):
        return False
    value = getattr(element, p.attribute)
    if p.key in _SHOWN_WHEN_SET and not value:
        return False
    return value is not None and value is not False


#: Keys a later camsim added whose default leaves the element as it was: shown only when set.
_SHOWN_WHEN_SET = ("quadratic_damping",)


def _param_text(p: Param, value, element, u: DisplayUnits) -> str:
    if p.dimension == "law_table":  # a lash's side: its law and its own keys
        own = {q.key for q in element.params}
        keys = [_param_text(q, getattr(value, q.attribute), value, u) for q in value.params
                if q.key not in own and _shown(q, value)]
        return f"{p.key} {{{', '.join([f'law {value.law_name}', *keys])}}}"
    if value is True:
        return p.key
    if isinstance(value, str):
        return f"{p.key} {value}"
    if p.dimension in ("material", "materials"):  # issue 39: materials by name
        return f"{p.key} " + "/".join(m.name for m in (value if isinstance(value, tuple) else (value,)))
    if p.dimension == "integer":
        return f"{p.key} {value}"
    if p.dimension == "power_coefficient":
        unit, k = u.power_coefficient(getattr(element, "exponent", 1.0))
        return f"{p.key} {value * k:.6g} {unit}"
    return f"{p.key} {u.quantity(value, p.unit, '.6g')}".strip()


def _print_cam(cam, u: DisplayUnits, title: str = "cam") -> None:
    """One cam's table, segments, table profile and geometry, in ``u``."""
    length = u.shown("m")[0]
    head = Table(title=escape(title), title_justify="left", show_header=False)
    head.add_column("key")
    head.add_column("value")
    head.add_row("speed", _g(cam.speed, "rad/s", u))
    head.add_row("period", f"{cam.period:.6g} s")
    head.add_row("ratio (roller -> model axis)", f"{cam.ratio:.6g}")
    head.add_row("arm", _g(cam.arm, "m", u))
    head.add_row("drives", escape(cam.drives or "- (no driven mass)"))
    head.add_row("start_angle", _g(cam.start_angle, "rad", u))
    err_console.print(head)
    if cam.segments:
        angle = u.shown("rad")[0]
        seg = Table(title="cam segments (lift at the roller; on the model axis = ratio x lift)",
                    title_justify="left")
        for col in ("#", "motion", "law", f"duration [{angle}]", f"lift [{length}]", f"model axis [{length}]"):
            seg.add_column(escape(col), justify="right" if col not in ("motion", "law") else "left")
        for i, s in enumerate(cam.segments):
            seg.add_row(str(i), s.motion, s.law or "-", f"{u.convert(s.duration, 'rad'):.6g}",
                        f"{u.convert(s.lift, 'm'):.6g}", f"{u.convert(s.lift * cam.ratio, 'm'):.6g}")
        err_console.print(seg)
    if cam.table is not None:
        t = cam.table
        err_console.print(
            f"cam table: {escape(t.source)}, {len(t.angle)} rows, angle {_g(t.angle[0], 'rad', u)} to "
            f"{_g(t.angle[-1], 'rad', u)}, roller lift {_g(min(t.displacement), 'm', u)} to "
            f"{_g(max(t.displacement), 'm', u)}"
        )
    if cam.geometry is not None:  # issue 14: [cam.geometry]
        from camsim.cam.arrangement import geometry_to_dict

        geo = Table(title="cam geometry (checks: camsim cam)", title_justify="left", show_header=False)
        geo.add_column("key")
        geo.add_column("value")
        units = {"max_pressure_angle": "rad"}
        for key, value in geometry_to_dict(cam.geometry).items():
            if isinstance(value, dict):
                value = f"E {_g(value['youngs_modulus'], 'Pa', u)}, nu {value['poisson_ratio']:.6g}"
            elif isinstance(value, float):
                value = _g(value, units.get(key, "m"), u)
            geo.add_row(key, escape(str(value if value is not None else "-")))
        err_console.print(geo)


def _print_machine(machine: Machine, u: DisplayUnits) -> None:
    """Human summary on stderr: cam, masses, elements (with damping coefficients), settings, in ``u``."""
    from camsim.display import engineering
    from camsim.machine.loader import damping_coefficients, reference_mass_of

    err_console.print(f"{machine.name}  ({machine.source}): valid", markup=False, style="bold")
    length = u.shown("m")[0]
    cam = machine.cam
    if cam is None:
        err_console.print("cam: none (the cam node stays at x = 0)")
    elif not machine.multi_cam:
        _print_cam(cam, u)
    else:  # issue 38: every cam on the shaft
        for c in machine.cams:
            _print_cam(c, u, f"cam {c.name} (phase {_g(c.phase, 'rad', u)}; speed and start angle: the shaft's)")
    if machine.camshaft is not None:
        import dataclasses

        units = {"speed": "rad/s", "start_angle": "rad", "inertia": "kg*m^2", "flywheel": "kg*m^2",
                 "drive_stiffness": "N*m/rad", "drive_damping": "N*m*s/rad", "stall_torque": "N*m",
                 "no_load_speed": "rad/s"}
        shaft = Table(title="camshaft", title_justify="left", show_header=False)
        shaft.add_column("key")
        shaft.add_column("value")
        torque, k = u.shown("N*m")  # torsional rates per radian of twist, in the torque shown (issue 44)
        per_rad = {"N*m/rad": "/rad", "N*m*s/rad": "·s/rad"}
        for key, value in dataclasses.asdict(machine.camshaft).items():
            if key == "sections":
                for sec in value:
                    shaft.add_row(f"section {sec['cam']}", escape(f"k_t {sec['stiffness'] * k:.6g} {torque}/rad, J "
                                                                  f"{_g(sec['inertia'], 'kg*m^2', u)}, zeta {sec['damping_ratio']:g}"))
                continue
            if isinstance(value, float) and units.get(key) in per_rad:
                text = f"{value * k:.6g} {torque}{per_rad[units[key]]}"
            elif isinstance(value, float) and key in units:
                text = _g(value, units[key], u)
            elif isinstance(value, float):
                text = f"{value:.6g}"
            else:
                text = "-" if value is None else str(value)
            shaft.add_row(key, escape(text))
        err_console.print(shaft)
    for c in machine.clearances:
        err_console.print(f"clearance {escape(c.name)}: {escape(c.a.node)} (offset {_g(c.a.offset, 'm', u)}) to "
                          f"{escape(c.b.node)} (offset {_g(c.b.offset, 'm', u)}), at least {_g(c.minimum, 'm', u)}")
    masses = Table(title="masses", title_justify="left")
    masses.add_column("name")
    masses.add_column(escape(u.header("mass", "kg")), justify="right")
    masses.add_column("role")
    for m in machine.masses:
        driver = machine.driven_masses.get(m.name)
        role = "free" if driver is None else ("driven by the cam" if not machine.multi_cam else f"driven by cam {driver}")
        masses.add_row(escape(m.name), f"{u.convert(m.mass, 'kg'):.6g}", role)
    err_console.print(masses)

    elements = Table(title="elements (force tension-positive; contacts compressive-positive)", title_justify="left")
    for col in ("name", "type", "between", "parameters", "damping"):
        elements.add_column(col)
    for e in machine.elements:
        kind = f"{e.type_name} ({e.law_name})" if e.law_name else e.type_name
        params = ", ".join(_param_text(p, getattr(e, p.attribute), e, u) for p in e.params if _shown(p, e))
        coefficients = damping_coefficients(machine, e)
        if e.damping.ratio is not None:
            damping = f"zeta {e.damping.ratio:g} (m_ref {reference_mass_of(e)}): " + ", ".join(
                f"{k} {_g(v, 'N*s/m', u)}" for k, v in coefficients.items())
        elif e.damping.coefficient is not None:
            damping = ", ".join(f"{k} {_g(v, 'N*s/m', u)}" for k, v in coefficients.items())
        else:
            damping = e.damping_note() or "none"
        elements.add_row(*(escape(x) for x in (e.name, kind, f"{e.lower} -> {e.upper}", params, damping)))
    err_console.print(elements)
    for e in machine.elements:  # issue 39: how each rod is discretised, and why
        if e.compound:
            err_console.print(
                f"rod {e.name}: {in_units(e.segments_reason, u)}; c = {_g(e.wave_speed, 'm/s', u)}, Z = A*sqrt(E*rho) = "
                f"{_g(e.impedance, 'N*s/m', u)}, mass {_g(e.rod_mass, 'kg', u)}, 2L/c = {e.transit_time:.4g} s, interior nodes "
                + (f"{e.interior_nodes()[0]} ... {e.interior_nodes()[-1]}" if e.interior_nodes() else "none"),
                markup=False)

    _print_loads(machine, u)
    sim = machine.simulation
    run = (f"{sim.duration:.6g} s recorded" if sim.duration is not None else f"{sim.cycles} cycle(s) recorded")
    start = (f"steady state by shooting ({sim.warmup_cycles} warm-up cycle(s) where it does not apply)"
             if sim.steady_state == "shooting" else f"{sim.warmup_cycles} warm-up cycle(s)")
    err_console.print(
        f"simulation: {run}, {start}, {engineering(sim.sample_rate, 'Hz', 6)}, "
        f"gravity {_g(sim.gravity, 'm/s^2', u)}"
    )
    for ic in machine.initial:
        err_console.print(
            f"initial {escape(ic.mass)}: displacement {_g(ic.displacement, 'm', u)}, velocity {_g(ic.velocity, 'm/s', u)}"
        )


def _print_loads(machine: Machine, u: DisplayUnits) -> None:
    """The ``[[load]]`` tables (issue 43): each load's mass and program, in ``u``."""
    if not machine.loads:
        return
    table = Table(title="process loads (force positive along +x)", title_justify="left")
    for col in ("name", "on", "program", "values"):
        table.add_column(col)
    for load in machine.loads:
        angle = f" over the angle of cam {load.cam}" if load.cam else ""
        if load.kind == "force":
            program, values = "constant", _g(load.force, "N", u)
        elif load.kind == "segments":
            program = f"segments{angle or ' over the shaft angle'}"
            rows = [f"{s.motion} {s.law or ''} {_g(s.duration, 'rad', u)}".replace("  ", " ")
                    + (f" {'+' if s.motion == 'rise' else '-'}{_g(s.lift, 'N', u)}" if s.motion != "dwell" else "")
                    for s in load.segments]
            values = f"base {_g(load.base, 'N', u)}; " + "; ".join(rows)
        elif load.kind == "table":
            t = load.table
            program = f"{t.over} table {t.source}{angle}"
            span = (f"{_g(t.x[0], 'rad', u)} to {_g(t.x[-1], 'rad', u)}" if t.over == "angle"
                    else f"{t.x[0]:.6g} s to {t.x[-1]:.6g} s")
            values = f"{len(t.x)} rows, {span}, force {_g(min(t.force), 'N', u)} to {_g(max(t.force), 'N', u)}"
        else:
            s = load.sine
            program = "sine"
            values = (f"amplitude {_g(s.amplitude, 'N', u)}, frequency {s.frequency:.6g} Hz, phase "
                      f"{_g(s.phase, 'rad', u)}, offset {_g(s.offset, 'N', u)}, from {s.start:.6g} s")
        table.add_row(*(escape(x) for x in (load.name, load.on, program, values)))
    err_console.print(table)


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, declare
declare("validate", reads=[Reads("machine_file", "machine")], example=("validate", "{in:machine_file}"))

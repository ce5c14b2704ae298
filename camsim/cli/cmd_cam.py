"""``camsim cam``: the cam program of a machine — peaks per segment, warnings, s/v/a/j traces.

The library calls behind it: :class:`camsim.cam.CamProgram` (peaks, warnings) and
:func:`camsim.cam.sample_revolution` (traces); :func:`write_cam_hdf5` and
:func:`write_cam_csv` below write the traces.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING
from pathlib import Path

import typer
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from camsim.cli.app import app, err_console, print_json, user_errors, warn_notes
from camsim.cli.units_option import check_units, machine_units, units_option
from camsim.errors import InputError, MachineFileError

if TYPE_CHECKING:
    from camsim.cam import CamProgram
    from camsim.display import DisplayUnits


def __getattr__(name: str):
    # write_cam_csv/write_cam_hdf5 live in camsim.cam.files (h5py): imported when asked for,
    # so that `camsim --help` does not load h5py (issue 25, fast start)
    if name in ("write_cam_csv", "write_cam_hdf5"):
        from camsim.cam import files

        return getattr(files, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

#: The traces written by ``camsim cam -o``: name, units, long name.
def _num(value: float | None, fmt: str = ".4g") -> str:
    return "-" if value is None else format(value, fmt)


def _print_table(machine, program: CamProgram, peaks: list[dict], heading: str = "", units: DisplayUnits | None = None) -> None:
    u = units if units is not None else machine.display_units
    (lu, lk), (vu, vk), (au, ak), (ju, jk) = (u.shown(x) for x in ("m", "m/s", "m/s^2", "m/s^3"))
    title = (
        f"{machine.name}{': ' + heading if heading else ''}: cam at {u.quantity(program.speed, 'rad/s', '.6g')}, "
        f"ratio {program.ratio:.6g}, start angle {u.quantity(program.start_angle, 'rad', '.6g')}; model axis; "
        "@ = cam angle of the peak"
    )
    table = Table(title=escape(title), title_justify="left", box=box.SIMPLE_HEAD, pad_edge=False)
    headers = (
        "#", "segment", "cam angle [deg]", f"lift [{lu}]",
        f"|v| [{vu}]", "@ [deg]", f"|a| [{au}]", "@ [deg]", f"|j| [{ju}]", "@ [deg]",
    )  # fmt: skip
    for header in headers:
        table.add_column(escape(header), justify="left" if header == "segment" else "right")
    for p in peaks:
        name = p["motion"] if p["law"] is None else f"{p['motion']} {p['law']}"
        end = p["start_deg"] + p["duration_deg"]
        moving = p["peak_velocity_deg"] is not None
        table.add_row(
            str(p["index"]),
            name,
            f"{p['start_deg']:.5g}-{end:.5g}",
            f"{lk * p['lift_m']:.5g}" if moving else "-",
            _num(vk * p["peak_velocity"] if moving else None),
            _num(p["peak_velocity_deg"], ".5g"),
            _num(ak * p["peak_acceleration"] if moving else None),
            _num(p["peak_acceleration_deg"], ".5g"),
            _num(jk * p["peak_jerk"] if moving else None),
            _num(p["peak_jerk_deg"], ".5g"),
        )
    # Off a terminal (a log, a pipe) do not squeeze the table into 80 columns.
    console = err_console if err_console.is_terminal else Console(stderr=True, width=140, highlight=False, emoji=False)
    console.print(table)


def _tolerance(tol: float, unit: str) -> str:
    """The chordal tolerance in the profile's own length unit (in: 0.0001 in; mm: 0.001 mm)."""
    return f"{tol / 0.0254:.4g} in" if unit == "in" else f"{tol * 1e3:.4g} mm"


def _parse_tolerance(text: str) -> float:
    from camsim.units import QuantityError, to_si

    try:
        value = to_si(text, "length")
    except QuantityError as exc:
        raise InputError(f"--tolerance: {exc}") from None
    if not value > 0:
        raise InputError(f"--tolerance: must be positive, got {text!r}")
    return value


@app.command("cam")
def cam_command(
    machine_file: Path = typer.Argument(..., metavar="MACHINE.toml", help="The machine file (TOML)."),
    output: Path | None = typer.Option(
        None,
        "-o",
        "--output",
        help=(
            "Write one revolution of s [m], v [m/s], a [m/s²], j [m/s³] (SI) on the model axis "
            "against time [s] and cam angle [deg]: .h5 (HDF5) or .csv. With [cam.geometry] the "
            ".h5 file also holds /cam/pressure_angle [deg], /cam/pitch_radius_of_curvature, "
            "/cam/surface_radius_of_curvature [m], /cam/pitch_curve, /cam/surface (N, 2) [m]."
        ),
    ),
    points: int = typer.Option(3600, "--points", min=2, help="Samples over the revolution written by -o."),
    as_json: bool = typer.Option(False, "--json", help="Print the peaks, the geometry checks and warnings as JSON on stdout."),
    overrides: list[str] = typer.Option(
        [],
        "--set",
        metavar="KEY=VALUE",
        help='Override a machine-file value, units as in the file, e.g. --set cam.speed="150 rpm". Repeatable.',
    ),
    plot: Path | None = typer.Option(
        None, "--plot", metavar="CAM.png",
        help="With [cam.geometry]: draw SVAJ at the roller, pressure angle and radii of curvature against cam "
        "angle, and the cam to scale with its follower (.png, .svg or .pdf). Without it: s, v, a, j on the model "
        "axis against cam angle. With [cam.compensation]: the wanted output motion and the compensated cam side "
        "by side (the design figure, with geometry, goes to STEM-design.EXT).",
    ),
    profile: Path | None = typer.Option(
        None, "--profile", metavar="CAM.csv",
        help="Needs [cam.geometry]: write the cam surface and pitch curve x, y (cam frame, --unit) at the chordal "
        "--tolerance as CSV; the last row closes the contour.",
    ),
    dxf: Path | None = typer.Option(
        None, "--dxf", metavar="CAM.dxf",
        help="Needs [cam.geometry]: write the cam as DXF (closed polylines on layers CAM_PROFILE and "
        "CAM_PITCH_CURVE, base circle, centre mark, $INSUNITS from --unit).",
    ),
    unit: str = typer.Option("mm", "--unit", metavar="mm|in", help="Length unit of --profile and --dxf."),
    tolerance: str = typer.Option(
        "1 um", "--tolerance", metavar="LENGTH",
        help='Chordal tolerance of --profile and --dxf, with units (e.g. "1um", "0.0001 in"; bare number: m).',
    ),
    force: bool = typer.Option(False, "--force", help="Replace an existing result of another camsim command under -o."),
    units: str = units_option(),
) -> None:
    """Show the cam program: per segment its law, duration, lift and peak |v|, |a|, |j|.

    Values are on the model axis (roller lift times the cam ratio) at the machine's cam
    speed, in the machine file's units (--units); angles are cam angles in degrees. Jumps of displacement, velocity or
    acceleration where segments meet are printed as warnings on stderr.

    With [cam.geometry] it also prints the design checks: the largest |pressure angle|
    and where, the smallest radii of curvature and where, the face width of a flat
    face, and a warning above max_pressure_angle. A profile the follower cannot follow
    (an undercut roller, a cusp under a flat face) is an error (exit 2) naming the cam
    angles; nothing is written then.
    """
    from camsim.cam import CamProgram
    from camsim.cam.files import write_cam_csv, write_cam_hdf5
    from camsim.display import in_units

    with user_errors():
        from camsim.io.outputs import CSV, FIGURES, HDF5, check_output, output_format, same_file

        check_units(units)
        kind = None
        inputs = [("machine file", machine_file)]
        named = [(o, p) for o, p in (("-o", output), ("--plot", plot), ("--profile", profile), ("--dxf", dxf)) if p is not None]
        for i, (o1, p1) in enumerate(named):
            for o2, p2 in named[i + 1:]:
                if same_file(p1, p2):
                    raise InputError(f"{p1}: {o1} and {o2} name the same file; give each output its own name")
        if output is not None:
            fmt = output_format(output, {**HDF5, **CSV})
            kind = "h5" if fmt == "hdf5" else "csv"
            check_output(output, fmt, owner="cam" if fmt == "hdf5" else "csv", force=force, inputs=inputs)
        from camsim.cam.profile import UNITS

        if unit not in UNITS:
            raise InputError(f"--unit: unknown unit {unit!r}; use mm or in")
        tol = _parse_tolerance(tolerance)
        if plot is not None:
            check_output(plot, output_format(plot, FIGURES, "--plot"), owner="figure", inputs=inputs, option="--plot")
        if profile is not None:
            check_output(profile, output_format(profile, CSV, "--profile"), owner="csv", inputs=inputs, option="--profile")
        if dxf is not None:
            check_output(dxf, output_format(dxf, {".dxf": "dxf"}, "--dxf"), owner="dxf", inputs=inputs, option="--dxf")
        from camsim.machine.loader import load_machine

        machine = load_machine(machine_file, overrides=overrides)
        warn_notes(machine)
        shown = machine_units(units, machine)
        if machine.cam is None:
            raise MachineFileError(str(machine_file), "cam", "the machine has no cam")
        if machine.multi_cam:  # issue 38: several cams on one shaft
            _several_cams(machine, machine_file, output, kind, points, as_json, plot, profile, dxf, unit, tol, shown)
            return
        try:
            program = CamProgram(machine.cam)
        except ValueError as exc:
            raise MachineFileError(str(machine_file), "cam", str(exc)) from None
        geometry = machine.cam.geometry
        if geometry is None:
            for option, path in (("--profile", profile), ("--dxf", dxf)):
                if path is not None:
                    raise MachineFileError(str(machine_file), "cam.geometry",
                                           f"{option} needs the cam's shape: add a [cam.geometry] table")
        checks = None
        if geometry is not None:
            from camsim.cam.geometry import check_followable

            checks = check_followable(geometry, program, str(machine_file))  # exit 2 before any output
        peaks = program.segment_peaks()
        output_program = None
        if machine.cam.compensated is not None:  # issue 27: the wanted output motion too
            output_program = CamProgram(machine.cam.output_program)
        if as_json:
            payload = {
                "machine": machine.name,
                "speed_rad_s": program.speed,
                "ratio": program.ratio,
                "start_angle_deg": math.degrees(program.start_angle),
                "segments": peaks,
                "warnings": list(program.warnings),
            }
            if checks is not None:
                payload["geometry"] = {k: v for k, v in checks.items() if k != "defects"}
            if output_program is not None:
                comp = machine.cam.compensated
                payload["compensation"] = {"output": comp.output, "speed_rad_s": comp.speed, "kind": comp.kind,
                                           "path": list(comp.path),
                                           "output_program": output_program.segment_peaks()}
            print_json(payload)
        else:
            if output_program is not None:
                comp = machine.cam.compensated
                _print_table(machine, output_program, output_program.segment_peaks(),
                             heading=f"wanted motion of {comp.output} (the written program)", units=shown)
                _print_table(machine, program, peaks, heading=f"compensated cam ({comp.kind}, design speed "
                             f"{shown.quantity(comp.speed, 'rad/s', '.6g')}, path {' - '.join(comp.path)})", units=shown)
            else:
                _print_table(machine, program, peaks, units=shown)
            if checks is not None:
                from camsim.reports.summary import render_geometry_checks

                console = err_console if err_console.is_terminal else Console(stderr=True, width=140, highlight=False, emoji=False)
                render_geometry_checks(checks, console, units=shown, title=(
                    f"cam geometry: {geometry.follower}, Rb {shown.quantity(geometry.base_radius, 'm', '.5g')}"
                    + (f", Rr {shown.quantity(geometry.roller_radius, 'm', '.5g')}" if geometry.is_roller else "")
                    + f", {geometry.rotation}; angles are cam angles, lift at the roller"))
        for message in program.warnings:
            err_console.print(f"camsim: warning: {in_units(message, shown)}", markup=False)
        if checks is not None and as_json:
            for message in checks["warnings"]:
                err_console.print(f"camsim: warning: {in_units(message, shown)}", markup=False)
        written = []
        if kind == "h5":
            write_cam_hdf5(output, machine, program, points)  # type: ignore[arg-type]
            written.append(f"{output} ({points} samples over one revolution)")
        elif kind == "csv":
            write_cam_csv(output, program, points)  # type: ignore[arg-type]
            written.append(f"{output} ({points} samples over one revolution)")
        if profile is not None or dxf is not None:
            from camsim.cam.profile import profile_points, write_profile_csv, write_profile_dxf

            pts = profile_points(geometry, program, tol)
            if profile is not None:
                write_profile_csv(profile, pts, unit)
                written.append(f"{profile} ({pts['theta'].size} points, chordal tolerance {_tolerance(tol, unit)}, {unit})")
            if dxf is not None:
                write_profile_dxf(dxf, pts, geometry, unit)
                written.append(f"{dxf} ({pts['theta'].size} points, chordal tolerance {_tolerance(tol, unit)}, {unit})")
        if plot is not None:
            from camsim.figures.cam import plot_cam_design
            from camsim.figures.style import save_figure

            fmt = plot.suffix.lower().lstrip(".")
            figures = []
            if geometry is not None and output_program is None:
                figures.append((plot, plot_cam_design(geometry, program, title=f"{machine.name}: cam design", units=shown)))
            else:
                from camsim.figures.svaj import plot_svaj

                if output_program is not None:
                    name = machine.cam.compensated.output
                    curves = [(f"wanted motion of {name}", output_program), ("compensated cam", program)]
                else:
                    curves = [("cam", program)]
                figures.append((plot, plot_svaj(curves, title=f"{machine.name}: SVAJ on the model axis", units=shown)))
                if geometry is not None:
                    design = plot.with_name(f"{plot.stem}-design{plot.suffix}")
                    check_output(design, fmt, owner="figure", inputs=inputs, option="--plot (its design figure)")
                    figures.append((design, plot_cam_design(geometry, program, title=f"{machine.name}: "
                                                                                      "compensated cam design", units=shown)))
            for path_, fig in figures:
                save_figure(fig, path_, fmt, dpi=150)
                written.append(str(path_))
        if not as_json:
            for line in written:
                err_console.print(f"wrote {line}", markup=False)


def _geometry_console():
    return err_console if err_console.is_terminal else Console(stderr=True, width=140, highlight=False, emoji=False)


def _several_cams(machine, machine_file, output, kind, points, as_json, plot, profile, dxf, unit, tol, shown) -> None:
    """``camsim cam`` on a machine with ``[[cam]]`` tables (issue 38): every cam's table and
    geometry checks, the clearances (a collision is an error, exit 2, before any output),
    the timing diagram (--plot), every cam under /cams/<name>/ (-o), a profile per cam with
    geometry (--profile/--dxf: STEM-<cam>.EXT); values in the display units ``shown``."""
    from camsim.cam import CamProgram
    from camsim.cam.files import write_cams_csv, write_cams_hdf5
    from camsim.cam.timing import kinematic_clearances

    source = str(machine_file)
    programs, checks = {}, {}
    for i, cam in enumerate(machine.cams):
        try:
            programs[cam.name] = CamProgram(cam)
        except ValueError as exc:
            raise MachineFileError(source, f"cam[{i}]", str(exc)) from None
        if cam.geometry is not None:
            from camsim.cam.geometry import check_followable

            try:
                checks[cam.name] = check_followable(cam.geometry, programs[cam.name], source)
            except MachineFileError as exc:
                raise MachineFileError(exc.file, f"cam[{i}].geometry", exc.message) from None
    if profile is not None or dxf is not None:
        if not checks:
            raise MachineFileError(source, "cam", "--profile and --dxf need a cam's shape: give a [[cam]] a geometry")
        from camsim.io.outputs import check_output

        for option, target, fmt in (("--profile", profile, "csv"), ("--dxf", dxf, "dxf")):
            for cam in machine.cams:  # each cam's own file, checked before anything is written
                if target is not None and cam.geometry is not None:
                    check_output(target.with_name(f"{target.stem}-{cam.name}{target.suffix}"), fmt, owner=fmt,
                                 inputs=[("machine file", machine_file)], option=option)
    clearances = kinematic_clearances(machine)
    if as_json:
        payload = {
            "machine": machine.name,
            "speed_rad_s": machine.cams[0].speed,
            "start_angle_deg": math.degrees(machine.cams[0].start_angle),
            "cams": [
                {"name": cam.name, "phase_deg": math.degrees(cam.phase), "ratio": cam.ratio, "drives": cam.drives,
                 "segments": programs[cam.name].segment_peaks(), "warnings": list(programs[cam.name].warnings),
                 **({"geometry": {k: v for k, v in checks[cam.name].items() if k != "defects"}} if cam.name in checks else {})}
                for cam in machine.cams
            ],
            "clearances": clearances,
        }
        print_json(payload)
    else:
        for cam in machine.cams:
            _print_table(machine, programs[cam.name], programs[cam.name].segment_peaks(),
                         heading=f"cam {cam.name}, phase {math.degrees(cam.phase):.6g} deg"
                         + (f", drives {cam.drives}" if cam.drives else ""), units=shown)
            if cam.name in checks:
                from camsim.reports.summary import render_geometry_checks

                g = cam.geometry
                render_geometry_checks(checks[cam.name], _geometry_console(), units=shown, title=(
                    f"cam {cam.name} geometry: {g.follower}, Rb {shown.quantity(g.base_radius, 'm', '.5g')}; cam angles, "
                    "lift at the roller"))
        if clearances:
            table = Table(title="clearances over one revolution (kinematic)", title_justify="left", box=box.SIMPLE_HEAD)
            length, k = shown.shown("m")
            for header in ("pair", "between", f"smallest [{length}]", "shaft angle [deg]", f"allowed [{length}]", ""):
                table.add_column(escape(header), justify="left" if header in ("pair", "between", "") else "right")
            for c in clearances:
                d = c["minimum_distance"]
                table.add_row(escape(c["name"]), escape(" – ".join(c["between"])), _num(None if d is None else k * d),
                              _num(c["shaft_angle_deg"], ".2f"), _num(k * c["allowed"]),
                              escape(c.get("reason") or ("COLLISION" if c["collides"] else "ok")))
            _geometry_console().print(table)
    for cam in machine.cams:
        for message in programs[cam.name].warnings:
            err_console.print(f"camsim: warning: cam {cam.name}: {message}", markup=False)
    for i, c in enumerate(clearances):  # a collision of two stations' parts: an error, nothing written
        if c["collides"]:
            index = [x.name for x in machine.clearances].index(c["name"])
            raise MachineFileError(source, f"clearance[{index}]",
                                   f"{c['between'][0]} and {c['between'][1]} collide: their distance comes to "
                                   f"{1e3 * c['minimum_distance']:.4g} mm (allowed {1e3 * c['allowed']:.4g} mm) at "
                                   f"shaft angle {c['shaft_angle_deg']:.3f} deg; change a phase or a lift")
    written = []
    if kind == "h5":
        write_cams_hdf5(output, machine, points)
        written.append(f"{output} ({points} samples over one revolution, {len(machine.cams)} cams)")
    elif kind == "csv":
        write_cams_csv(output, machine, points)
        written.append(f"{output} ({points} samples over one revolution, {len(machine.cams)} cams)")
    for option, target in (("--profile", profile), ("--dxf", dxf)):
        if target is None:
            continue
        from camsim.cam.profile import profile_points, write_profile_csv, write_profile_dxf

        for cam in machine.cams:
            if cam.geometry is None:
                continue
            path_ = target.with_name(f"{target.stem}-{cam.name}{target.suffix}")
            pts = profile_points(cam.geometry, programs[cam.name], tol)
            (write_profile_csv(path_, pts, unit) if option == "--profile" else write_profile_dxf(path_, pts, cam.geometry, unit))
            written.append(f"{path_} (cam {cam.name}, {pts['theta'].size} points, {unit})")
    if plot is not None:
        from camsim.figures.style import save_figure
        from camsim.figures.timing import plot_timing

        fig = plot_timing(machine, title=f"{machine.name}: timing diagram", units=shown)
        save_figure(fig, plot, plot.suffix.lower().lstrip("."), dpi=150)
        written.append(f"{plot} (timing diagram)")
    if not as_json:
        for line in written:
            err_console.print(f"wrote {line}", markup=False)


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, Writes, declare
from camsim.io.outputs import HDF5, CSV, FIGURES, DXF
declare("cam", reads=[Reads("machine_file", "machine", fixture="geometry")], force=True,
        writes=[Writes("output", "-o", {**HDF5, **CSV}, "cam", optional=True),
                Writes("plot", "--plot", FIGURES, "figure", optional=True),
                Writes("profile", "--profile", CSV, "csv", optional=True),
                Writes("dxf", "--dxf", DXF, "dxf", optional=True)],
        example=("cam", "{in:machine_file}", "--points", "60", "-o", "{out:-o}", "--plot", "{out:--plot}",
                 "--profile", "{out:--profile}", "--tolerance", "10um", "--dxf", "{out:--dxf}"))


__all__ = ["cam_command", "write_cam_csv", "write_cam_hdf5"]

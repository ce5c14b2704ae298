"""``camsim cam``: the cam program of a machine — peaks per segment, warnings, s/v/a/j traces.

The library calls behind it: :class:`camsim.cam.CamProgram` (peaks, warnings) and
:func:`camsim.cam.sample_revolution` (traces); :func:`write_cam_hdf5` and
:func:`write_cam_csv` below write the traces.
"""

from __future__ import annotations

import math
from pathlib import Path

import typer
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from camsim.cam import CamProgram
from camsim.cli.app import app, err_console, print_json, user_errors
from camsim.errors import InputError, MachineFileError
from camsim.io.atomic import check_writable
from camsim.io.camfile import write_cam_csv, write_cam_hdf5

#: The traces written by ``camsim cam -o``: name, units, long name.
def _num(value: float | None, fmt: str = ".4g") -> str:
    return "-" if value is None else format(value, fmt)


def _print_table(machine, program: CamProgram, peaks: list[dict]) -> None:
    rpm = program.speed * 60.0 / (2.0 * math.pi)
    title = (
        f"{machine.name}: cam at {rpm:.6g} rpm, ratio {program.ratio:.6g}, "
        f"start angle {math.degrees(program.start_angle):.6g} deg; model axis, SI; "
        "@ = cam angle of the peak"
    )
    table = Table(title=escape(title), title_justify="left", box=box.SIMPLE_HEAD, pad_edge=False)
    headers = (
        "#", "segment", "cam angle [deg]", "lift [mm]",
        "|v| [m/s]", "@ [deg]", "|a| [m/s^2]", "@ [deg]", "|j| [m/s^3]", "@ [deg]",
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
            f"{1e3 * p['lift_m']:.5g}" if moving else "-",
            _num(p["peak_velocity"] if moving else None),
            _num(p["peak_velocity_deg"], ".5g"),
            _num(p["peak_acceleration"] if moving else None),
            _num(p["peak_acceleration_deg"], ".5g"),
            _num(p["peak_jerk"] if moving else None),
            _num(p["peak_jerk_deg"], ".5g"),
        )
    # Off a terminal (a log, a pipe) do not squeeze the table into 80 columns.
    console = err_console if err_console.is_terminal else Console(stderr=True, width=140, highlight=False)
    console.print(table)


@app.command("cam")
def cam_command(
    machine_file: Path = typer.Argument(..., metavar="MACHINE.toml", help="The machine file (TOML)."),
    output: Path | None = typer.Option(
        None,
        "-o",
        "--output",
        help=(
            "Write one revolution of s [m], v [m/s], a [m/s^2], j [m/s^3] on the model axis "
            "against time [s] and cam angle [deg]: .h5 (HDF5) or .csv."
        ),
    ),
    points: int = typer.Option(3600, "--points", min=2, help="Samples over the revolution written by -o."),
    as_json: bool = typer.Option(False, "--json", help="Print the peaks and warnings as JSON on stdout."),
    overrides: list[str] = typer.Option(
        [],
        "--set",
        metavar="KEY=VALUE",
        help='Override a machine-file value, units as in the file, e.g. --set cam.speed="150 rpm". Repeatable.',
    ),
) -> None:
    """Show the cam program: per segment its law, duration, lift and peak |v|, |a|, |j|.

    Values are on the model axis (roller lift times the cam ratio) at the machine's cam
    speed, in SI; angles are cam angles in degrees. Jumps of displacement, velocity or
    acceleration where segments meet are printed as warnings on stderr.
    """
    with user_errors():
        kind = None
        if output is not None:
            suffix = output.suffix.lower()
            if suffix in (".h5", ".hdf5"):
                kind = "h5"
            elif suffix == ".csv":
                kind = "csv"
            else:
                raise InputError(f"{output}: -o: unknown output type {output.suffix or '(none)'!r}; use .h5 or .csv")
            check_writable(output)
        from camsim.loader import load_machine

        machine = load_machine(machine_file, overrides=overrides)
        if machine.cam is None:
            raise MachineFileError(str(machine_file), "cam", "the machine has no cam")
        try:
            program = CamProgram(machine.cam)
        except ValueError as exc:
            raise MachineFileError(str(machine_file), "cam", str(exc)) from None
        peaks = program.segment_peaks()
        if as_json:
            print_json(
                {
                    "machine": machine.name,
                    "speed_rad_s": program.speed,
                    "ratio": program.ratio,
                    "start_angle_deg": math.degrees(program.start_angle),
                    "segments": peaks,
                    "warnings": list(program.warnings),
                }
            )
        else:
            _print_table(machine, program, peaks)
        for message in program.warnings:
            err_console.print(f"camsim: warning: {message}", markup=False)
        if kind == "h5":
            write_cam_hdf5(output, machine, program, points)  # type: ignore[arg-type]
        elif kind == "csv":
            write_cam_csv(output, program, points)  # type: ignore[arg-type]
        if output is not None and not as_json:
            err_console.print(f"wrote {output} ({points} samples over one revolution)", markup=False)


__all__ = ["cam_command", "write_cam_csv", "write_cam_hdf5"]

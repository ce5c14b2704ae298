"""``camsim plot``: figures from a result file (run, compare or sweep)."""

from __future__ import annotations

from pathlib import Path

import typer

from camsim.cli.app import app, print_json, user_errors
from camsim.cli.units_option import check_units, units_option


@app.command("plot")
def plot_command(
    file: Path = typer.Argument(..., metavar="FILE.h5", help="A camsim result file (.h5): a run, a comparison or a sweep."),
    what: list[str] = typer.Option(
        None,
        "--what",
        metavar="KINDS",
        help=(
            "Which plots (comma-separated or repeated): svaj (cam s, v, a, j against cam angle [deg]), "
            "masses (displacement, velocity, acceleration of each mass against time [s], "
            "impacts marked), forces (element, cam-contact, transducer and process-load forces; a negative cam-contact "
            "force, i.e. jump, is shaded), compare (impact vs no-impact with the % difference), sweep (peaks "
            "against the swept parameter), design (with [cam.geometry]: pressure angle [deg], surface radius of "
            "curvature, contact normal force, Hertz stress, camshaft torque), camshaft (several cams or a [camshaft]: "
            "each cam's and the shaft's torque, a dynamic shaft's speed). Values in --units. Default: all "
            "that the file holds."
        ),
    ),
    mass: list[str] = typer.Option(None, "--mass", metavar="NAME", help="Plot only this mass (repeatable). Default: all masses."),
    quantity: list[str] = typer.Option(
        None, "--quantity", metavar="QUANTITY", help="displacement, velocity or acceleration (repeatable). Default: all three."
    ),
    time: str = typer.Option(None, "--time", metavar="T0:T1", help="Time window [s], e.g. 0.1:0.3 (an end may be left out)."),
    angle: str = typer.Option(
        None, "--angle", metavar="A0:A1", help="Cam-angle window [deg] of the continuing angle, e.g. 90:180."
    ),
    fmt: str = typer.Option("png", "--format", metavar="FORMAT", help="Image format: png, svg or pdf."),
    out: Path = typer.Option(
        None, "-o", "--output-dir", metavar="DIR", help="Directory for the images (created). Default: <input stem>_plots next to the input."
    ),
    dpi: float = typer.Option(150.0, "--dpi", metavar="DPI", help="Resolution of png images [dots per inch], 20 to 2400."),
    json_: bool = typer.Option(False, "--json", help="Print the written paths as a JSON list on stdout."),
    units: str = units_option("Units of the axes: file (the result's machine file's own units, recorded in the result; "
                              "the default), si (mm, N, kg, m/s) or us (in, lbf, lb, in/s)."),
) -> None:
    """Plot a result file: one image per figure, named <stem>_<what>.<format>; prints the paths."""
    with user_errors():
        check_units(units)
        from camsim.figures import plots as plot  # matplotlib is imported only by this command

        figures = plot.make_plots(
            file,
            what=what,
            masses=mass,
            quantities=quantity,
            time_window=plot.parse_window(time, "--time"),
            angle_window=plot.parse_window(angle, "--angle"),
            units=units,
        )
        written = plot.save_figures(figures, out if out is not None else plot.default_output_dir(file), fmt, dpi)
    if json_:
        print_json([str(p) for p in written])
    else:
        for p in written:
            typer.echo(str(p))


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, Writes, declare
from camsim.io.outputs import FIGURES
declare("plot", reads=[Reads("file", "result", ("run", "compare", "sweep"), fixture="run")],
        writes=[Writes("out", "-o", FIGURES, "figure", directory="{stem}_masses_M_velocity.{fmt}")],
        example=("plot", "{in:file}", "--what", "masses", "--quantity", "velocity", "-o", "{out:-o}"))

"""``camsim lump``: reduce a parts file to a machine file (lumped masses and springs)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from camsim.cli.app import app, err_console, print_json, user_errors
from camsim.cli.units_option import check_units


@app.command("lump")
def lump_command(
    parts: Path = typer.Argument(
        ...,
        help="Parts file (TOML): components, levers and the groups that become M1, K12, ... "
        "See docs/lumping.md.",
        show_default=False,
        metavar="PARTS",
    ),
    output: Path | None = typer.Option(
        None,
        "-o",
        "--output",
        help="Write the machine file here (TOML, a comment on every computed value). "
        "Without it, only the table (and --json) is printed.",
        show_default=False,
    ),
    units: str = typer.Option(
        "file",
        "--units",
        metavar="file|si|us",
        help="Units of the computed values, in the table and in the machine file: 'file' = the units the parts "
        "file is written in, per dimension (the default); 'us' = lb, lbf/in, lbf; 'si' = kg, N/m, N.",
    ),
    json_out: bool = typer.Option(
        False, "--json", help="Print the lumped values and parts in SI (kg, N/m, N) with their provenance, as JSON on stdout."
    ),
    force: bool = typer.Option(False, "--force", help="Replace an existing machine file that `camsim lump` did not write."),
) -> None:
    """Lump components (masses, inertias about pivots, helical springs, rods, series and
    parallel springs, lever ratios) into the masses and elements of a machine file."""
    from camsim.io.atomic import check_writable
    from camsim.analyses.lump.lumping import load_parts, write_machine

    with user_errors():
        check_units(units)
        if output is not None:
            from camsim.io.outputs import TOML, check_output, output_format

            check_output(output, output_format(output, TOML), owner="lump", force=force, inputs=[("parts file", parts)])
        result = load_parts(parts, units=units)
        if output is not None:
            write_machine(result, output)
    table = Table(title=f"Lumped values of {parts}", title_justify="left")
    table.add_column("value")
    table.add_column("lumped", justify="right")
    table.add_column("how it was obtained", overflow="fold")
    for v in result.values:
        written = v.text if isinstance(v.text, str) else f"{v.text:.7g}"
        table.add_row(v.key, written, v.provenance.split(" = ", 1)[1])
    err_console.print(table)
    if output is not None:
        err_console.print(f"wrote {output}", markup=False)
    if json_out:
        print_json(result.to_json())


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, Writes, declare
from camsim.io.outputs import TOML
declare("lump", reads=[Reads("parts", "parts")], force=True, writes=[Writes("output", "-o", TOML, "lump")],
        example=("lump", "{in:parts}", "-o", "{out:-o}"))

"""``camsim lump``: reduce a parts file to a machine file (lumped masses and springs)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from camsim.cli.app import app, err_console, fail, print_json, user_errors


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
        "us",
        "--units",
        help="Units of the computed values in the machine file: 'us' = lb, lbf/in, lbf "
        "(the thesis's); 'si' = kg, N/m, N.",
    ),
    json_out: bool = typer.Option(
        False, "--json", help="Print the lumped values and parts in SI (kg, N/m, N) with their provenance, as JSON on stdout."
    ),
    force: bool = typer.Option(False, "--force", help="Replace an existing machine file that `camsim lump` did not write."),
) -> None:
    """Lump components (masses, inertias about pivots, helical springs, rods, series and
    parallel springs, lever ratios) into the masses and elements of a machine file."""
    from camsim.io.atomic import check_writable
    from camsim.analyses.lump.lumping import UNIT_SYSTEMS, load_parts, write_machine

    with user_errors():
        if units not in UNIT_SYSTEMS:
            raise fail(f"--units: expected one of {', '.join(UNIT_SYSTEMS)}, got {units!r}", 2)
        if output is not None:
            from camsim.io.outputs import TOML, check_output, output_format

            check_output(output, output_format(output, TOML), owner="lump", force=force, inputs=[("parts file", parts)])
        result = load_parts(parts, units=units)
        if output is not None:
            write_machine(result, output)
    table = Table(title=f"Lumped values of {parts}", title_justify="left")
    table.add_column("value")
    table.add_column("written", justify="right")
    table.add_column("SI", justify="right")
    table.add_column("how it was obtained", overflow="fold")
    si_units = {"mass": "kg", "stiffness": "N/m", "force": "N", "dimensionless": ""}
    for v in result.values:
        written = v.text if isinstance(v.text, str) else f"{v.text:.7g}"
        table.add_row(v.key, written, f"{v.value:.6g} {si_units[v.kind]}".strip(), v.provenance.split(" = ", 1)[1])
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

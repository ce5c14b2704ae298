"""``camsim export``: the traces and events of a result file as CSV."""

from __future__ import annotations

from pathlib import Path

import typer

from camsim.cli.app import app, print_json, user_errors
from camsim.cli.units_option import check_units


@app.command("export")
def export_command(
    file: Path = typer.Argument(..., metavar="FILE.h5", help="A camsim run file (or a comparison file with --group)."),
    csv_: bool = typer.Option(
        True, "--csv", help="Write CSV (the only format so far; the flag is accepted for clarity)."
    ),
    out: Path = typer.Option(None, "-o", "--output", metavar="OUT.csv", help="Trace CSV. Default: <input stem>.csv next to the input."),
    columns: list[str] = typer.Option(
        None,
        "--columns",
        metavar="PATH,...",
        help="Only these traces, by HDF5 path (e.g. masses/M2/velocity), comma-separated or repeated; time is always first.",
    ),
    events_csv: Path = typer.Option(
        None, "--events-csv", metavar="EVENTS.csv", help="Events table CSV. Default: <out stem>_events.csv."
    ),
    no_events: bool = typer.Option(False, "--no-events", help="Do not write the events CSV."),
    group: str = typer.Option(
        None, "--group", metavar="GROUP", help="For a comparison file: impact, no_impact or difference."
    ),
    json_: bool = typer.Option(False, "--json", help="Print what was written as JSON on stdout."),
    units: str = typer.Option(
        None, "--units", metavar="file|si|us",
        help="Write the values in display units: file (the result's machine file's own, recorded in the result), "
        "si (mm, N, kg, m/s) or us (in, lbf, lb, in/s); the header names them. Default: the SI values as stored, exact.",
    ),
) -> None:
    """Export traces as CSV: header 'path [unit]' (SI units, or --units), full float precision (exact round trip)."""
    with user_errors():
        if units is not None:
            check_units(units)
        from camsim.analyses.export import export_csv

        picked = [p.strip() for c in columns or () for p in c.split(",") if p.strip()]
        result = export_csv(file, out, picked or None, events_csv, events=not no_events, group=group, units=units)
    if json_:
        print_json(
            {
                "csv": str(result.csv),
                "events_csv": None if result.events_csv is None else str(result.events_csv),
                "columns": list(result.columns),
                "rows": result.rows,
            }
        )
    else:
        typer.echo(str(result.csv))
        if result.events_csv is not None:
            typer.echo(str(result.events_csv))


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, Writes, declare
from camsim.io.outputs import CSV
declare("export", reads=[Reads("file", "result", ("run", "compare"), fixture="run")],
        writes=[Writes("out", "-o", CSV, "csv"), Writes("events_csv", "--events-csv", CSV, "csv")],
        example=("export", "{in:file}", "-o", "{out:-o}", "--events-csv", "{out:--events-csv}"))

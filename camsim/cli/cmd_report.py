"""``camsim report``: one self-contained, interactive HTML page of result files (camsim.reports)."""

from __future__ import annotations

from pathlib import Path

import typer

from camsim.cli.app import app, err_console, user_errors
from camsim.cli.units_option import check_units, units_option


@app.command("report")
def report_command(
    results: list[Path] = typer.Argument(..., metavar="RESULT.h5...", help="camsim result files: run, compare, sweep, study, or an optimize history (several give one page)."),
    output: Path = typer.Option(None, "-o", "--output", help="The HTML page. Default: the first result's name with .html."),
    pdf: Path = typer.Option(None, "--pdf", help="Also print the page to this PDF through the local Chromium (see docs/report.md)."),
    units: str = units_option("Units of the page: file (each result's machine file's own units, recorded in the result; "
                              "the default), si (mm, N, kg, m/s) or us (in, lbf, lb, in/s)."),
) -> None:
    """Write one self-contained, interactive HTML page of RESULT.h5: verdicts, tables, zoomable traces.

    The page opens from disk with no network (JavaScript and CSS inlined) and prints
    tidily. Exit 0 when written, 2 on bad input (not a camsim result, a kind without a
    page, an unwritable output, no browser for --pdf); nothing is written then.
    """
    with user_errors():
        check_units(units)
        target = output if output is not None else results[0].with_suffix(".html")
        from camsim.reports.build import build_report

        build_report(results, target, pdf=pdf, units=units)
    err_console.print(f"wrote {target}" + (f" and {pdf}" if pdf is not None else ""), markup=False)

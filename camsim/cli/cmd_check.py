"""``camsim check``: compare a result file with a golden file (regression test)."""

from __future__ import annotations

from pathlib import Path

import typer

from camsim.cli.app import app, err_console, print_json, user_errors
from camsim.cli.units_option import check_units, units_option
from camsim.analyses.tolerances import DEFAULT_ATOL, DEFAULT_RTOL


@app.command("check")
def check_command(
    result: Path = typer.Argument(..., metavar="RESULT.h5", help="The result file under test."),
    against: Path = typer.Option(..., "--against", metavar="GOLDEN.h5", help="The golden (reference) result file."),
    rtol: float = typer.Option(
        DEFAULT_RTOL, "--rtol", metavar="R", help="Tolerance relative to each golden dataset's peak |value| [-]."
    ),
    atol: float = typer.Option(
        DEFAULT_ATOL, "--atol", metavar="A", help="Absolute tolerance in each dataset's SI unit (m, m/s, N, s, ...)."
    ),
    show: int = typer.Option(10, "--show", metavar="N", help="Rows of the table of worst differences."),
    json_: bool = typer.Option(False, "--json", help="Print the full report as JSON on stdout."),
    units: str = units_option("Units of the differences shown: file (the result's machine file's own, recorded in the "
                              "result; the default), si or us. --rtol and --atol are SI; --json is SI."),
) -> None:
    """Check every trace and the events table: pass when |result - golden| <= atol + rtol*max|golden|.

    Exit 0 within tolerance, 1 on a difference (the failing datasets are named),
    2 when the files cannot be compared (missing datasets, other time grid, not camsim files).
    """
    with user_errors():
        from camsim.analyses.check import check_files, render_report, summary_line
        from camsim.io.results import file_display_units, open_h5

        check_units(units)
        report = check_files(result, against, rtol=rtol, atol=atol)
        with open_h5(result) as f:
            shown = file_display_units(f, units)
    if json_:
        print_json(report.to_dict())
    else:
        render_report(report, err_console, limit=max(show, 1), units=shown)
    if not report.passed:
        if json_:
            err_console.print(summary_line(report, shown), markup=False, highlight=False)
        raise typer.Exit(code=1)


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, declare
declare("check", reads=[Reads("result", "result", ("run", "compare", "sweep")), Reads("against", "result", ("run", "compare", "sweep"))],
        example=("check", "{in:result}", "--against", "{in:against}"))

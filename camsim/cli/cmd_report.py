"""``camsim report``: one self-contained, interactive HTML page of result files (camsim.reports)."""

from __future__ import annotations

from pathlib import Path

import typer

from camsim.cli.app import app, err_console, user_errors
from camsim.cli.units_option import check_units, units_option
from camsim.errors import InputError


@app.command("report")
def report_command(
    results: list[Path] = typer.Argument(..., metavar="RESULT.h5...", help="camsim result files: run, compare, sweep, study, or an optimize history (several give one page)."),
    output: Path = typer.Option(None, "-o", "--output", help="The HTML page. Default: the first result's name with .html."),
    pdf: Path = typer.Option(None, "--pdf", help="Also print the page to this PDF through the local Chromium (see docs/report.md)."),
    units: str = units_option("Units of the page: file (each result's machine file's own units, recorded in the result; "
                              "the default), si (mm, N, kg, m/s) or us (in, lbf, lb, in/s)."),
    force: bool = typer.Option(False, "--force", help="Replace an existing HTML page that camsim did not write (a file of another kind or an input is never replaced)."),
) -> None:
    """Write one self-contained, interactive HTML page of RESULT.h5: verdicts, tables, zoomable traces.

    The page opens from disk with no network (JavaScript and CSS inlined) and prints
    tidily. Exit 0 when written, 2 on bad input (not a camsim result, a kind without a
    page, an unwritable output, no browser for --pdf); nothing is written then.
    """
    with user_errors():
        check_units(units)
        from camsim.io.outputs import HTML, PDF, check_output, output_format, same_file

        target = output if output is not None else results[0].with_suffix(".html")
        inputs = [(f"result file {p}" if len(results) > 1 else "result file", p) for p in results]
        check_output(target, output_format(target, HTML), owner="report", inputs=inputs, force=force)
        if pdf is not None:
            if same_file(pdf, target):
                raise InputError(f"{pdf}: --pdf and -o name the same file; give each output its own name")
            check_output(pdf, output_format(pdf, PDF, "--pdf"), owner="report", inputs=inputs, option="--pdf")
        from camsim.reports.build import build_report

        build_report(results, target, pdf=pdf, units=units)
    err_console.print(f"wrote {target}" + (f" and {pdf}" if pdf is not None else ""), markup=False)


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, Writes, declare
from camsim.io.outputs import HTML, PDF
declare("report", reads=[Reads("results", "result", ("run", "compare", "sweep", "study", "optimize"), fixture="run")], force=True,
        writes=[Writes("output", "-o", HTML, "report"), Writes("pdf", "--pdf", PDF, "report", optional=True)],
        example=("report", "{in:results}", "-o", "{out:-o}", "--pdf", "{out:--pdf}"), slow=True)

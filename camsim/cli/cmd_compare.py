"""``camsim compare``: a machine with and without impact, or two result files, side by side."""

from __future__ import annotations

import math
from pathlib import Path

import typer
from rich.table import Table

from camsim.cli.helptext import CYCLES_HELP, SAMPLE_RATE_HELP, WARMUP_HELP
from camsim.cli.app import app, err_console, fail, print_json, user_errors, warn_notes
from camsim.cli.report_option import REPORT_HELP, check_report_target, write_report_page
from camsim.cli.units_option import check_units, machine_units, units_option

_SI_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}


def render_comparison(comparison, console, units=None) -> None:
    """The comparison table in ``units`` (a DisplayUnits, ``si``/``us``; default SI)."""
    from rich.markup import escape

    from camsim.reports.display import as_display

    system = as_display(units or "si")
    a, b = comparison.labels
    table = Table(title=escape(f"{a} vs {b}: difference = 100·(A − B)/max|A|"), title_justify="left")
    for column in ("mass", "quantity [unit]", f"peak A ({a})", f"peak B ({b})", "largest |difference| [%]", "at t [s]"):
        table.add_column(escape(column), justify="right" if column not in ("mass", "quantity [unit]") else "left")
    for row in comparison.rows():
        unit, scale = system.shown(_SI_UNITS[row.quantity])
        diff = row.max_difference_percent
        table.add_row(
            escape(row.mass), escape(f"{row.quantity} [{unit}]"), f"{row.peak_impact * scale:.4g}", f"{row.peak_no_impact * scale:.4g}",
            f"{diff:.3g}" if math.isfinite(diff) else "∞", f"{row.time:.5f}",
        )
    console.print(table)


def render_design_comparison(rows, console, units=None) -> None:
    """Peak stress and torque with and without impact (issue 14), in ``units``."""
    from rich.markup import escape

    from camsim.reports.display import as_display

    system = as_display(units or "si")
    table = Table(title="cam design: impact vs no impact", title_justify="left")
    for column in ("quantity", "impact", "no impact", "unit", "change [%]"):
        table.add_column(escape(column), justify="left" if column == "quantity" else "right")
    for row in rows:
        unit, factor = system.shown(row["units"])
        fmt = lambda v: "–" if v is None else f"{v * factor:.4g}"  # noqa: E731
        change = row["change_percent"]
        table.add_row(row["quantity"], fmt(row["impact"]), fmt(row["no_impact"]), unit,
                      "–" if change is None else f"{change:+.3g}")
    console.print(table)
    for row in rows:  # issue 35: every "–" says why
        if row["impact"] is None or row["no_impact"] is None:
            console.print(f"– in {row['quantity']}: {row.get('reason') or 'not computed for that run'}", markup=False)
        elif row["change_percent"] is None:
            console.print(f"– change of {row['quantity']}: the no-impact value is 0 (no relative change)", markup=False)


@app.command("compare")
def compare_command(
    inputs: list[Path] = typer.Argument(..., help="A machine file (TOML), or two run result files (HDF5) to compare."),
    output: Path = typer.Option(None, "-o", "--output", help="Comparison file (HDF5): /impact, /no_impact, /difference. Default for a machine: next to it, <stem>_compare.h5; for two files: none."),
    cycles: int = typer.Option(None, "--cycles", min=1, help=CYCLES_HELP),
    warmup: int = typer.Option(None, "--warmup", min=0, help=WARMUP_HELP),
    sample_rate: str = typer.Option(None, "--sample-rate", help=SAMPLE_RATE_HELP),
    set_: list[str] = typer.Option([], "--set", help='Override a machine key, e.g. --set cam.speed="150 rpm" (repeatable).'),
    json_: bool = typer.Option(False, "--json", help="Print the comparison table as JSON on stdout."),
    force: bool = typer.Option(False, "--force", help="Replace an existing result of another camsim command (a file of another kind or an input is never replaced)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress (a bar on a terminal, a line every 10 s elsewhere)."),
    units: str = units_option(),
    report: Path = typer.Option(None, "--report", metavar="PAGE.html", help=REPORT_HELP + " Of the comparison file; of both run files when two are compared without -o."),
) -> None:
    """Compare the machine with impact and over-travel against its no-impact variant (thesis §8.4).

    With one machine file: runs both variants on the same time grid (the no-impact variant
    removes contacts, fixes over-travel links joined and makes cam contacts bilateral) and
    prints, per mass and quantity, both peaks and the largest percent difference
    100·(impact − no impact)/max|impact| with its time. With two run files (two designs,
    two speeds): the same table for A against B when their time grids match.
    """
    from camsim.cli.app import parse_sample_rate
    from camsim.cli.progress import FractionBar
    from camsim.run.lifecycle import sigterm_as_interrupt
    from camsim.analyses.compare import compare_files, compare_machine, write_file_comparison

    with user_errors(), sigterm_as_interrupt():
        check_units(units)
        check_report_target(report, [(f"input {i + 1}", p) for i, p in enumerate(inputs)], force)
        if len(inputs) == 2:
            if set_ or cycles or warmup is not None or sample_rate:
                raise fail("--set, --cycles, --warmup and --sample-rate apply to a machine file, not to two result files")
            a, b = inputs
            if output is not None:
                from camsim.io.outputs import HDF5, check_output, output_format

                check_output(output, output_format(output, HDF5), owner="compare", force=force,
                             inputs=[("result file A", a), ("result file B", b)])
            comparison = compare_files(a, b)
            from camsim.io.results import file_display_units, open_h5

            with open_h5(a) as f:  # the display units of file A's machine file
                shown = file_display_units(f, units)
            if output is not None:
                write_file_comparison(comparison, a, b, output)
        elif len(inputs) == 1:
            from camsim.io.atomic import check_writable
            from camsim.run.runfile import write_comparison
            from camsim.machine.loader import load_machine

            machine_path = inputs[0]
            from camsim.io.outputs import HDF5, beside, check_output, output_format, sniff_kind

            if sniff_kind(machine_path) == "hdf5":
                raise fail(f"{machine_path}: a result file alone: compare takes one machine file (TOML: the machine "
                           "with and without impact) or two result files (HDF5: A against B)")
            rate = parse_sample_rate(sample_rate)
            machine = load_machine(machine_path, overrides=set_)
            warn_notes(machine)
            shown = machine_units(units, machine)
            target = output if output is not None else beside(machine_path, "_compare.h5")
            check_output(target, output_format(target, HDF5), owner="compare", force=force,
                         inputs=[("machine file", machine_path)])
            from camsim.cam.design import check_machine  # issue 14: undercut/cusp is an error

            check_machine(machine)
            progress = FractionBar("compare (impact, no impact)", "%", 100.0, quiet=quiet)
            try:
                comparison = compare_machine(machine, cycles=cycles, warmup_cycles=warmup, sample_rate=rate, progress=progress)
            finally:
                progress.close()
            write_comparison(comparison, target)
            output = target
        else:
            raise fail("compare takes one machine file or two result files")
        design_rows = []
        if comparison.impact is not None and comparison.no_impact is not None:  # issue 14: stress and torque
            from camsim.cam.design import design_comparison

            design_rows = design_comparison(comparison.impact, comparison.no_impact)
        if json_:
            payload = comparison.to_dict()
            if design_rows:
                payload["design"] = design_rows
            payload["output"] = str(output) if output is not None else None
            print_json(payload)
        else:
            render_comparison(comparison, err_console, shown)
            if design_rows:  # issue 14
                render_design_comparison(design_rows, err_console, shown)
            if output is not None:
                err_console.print(f"wrote {output}")
        write_report_page([output] if output is not None else list(inputs), report, quiet=json_, units=units)


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, Writes, declare
from camsim.io.outputs import HDF5, HTML
declare("compare", reads=[Reads("inputs", "machine"),
                          Reads("inputs", "result", ("run",), fixture="run", example=("compare", "{in:inputs}", "{run}"))],
        writes=[Writes("output", "-o", HDF5, "compare"), Writes("report", "--report", HTML, "report", optional=True)],
        force=True, example=("compare", "{in:inputs}", "-o", "{out:-o}", "-q", "--report", "{out:--report}"))

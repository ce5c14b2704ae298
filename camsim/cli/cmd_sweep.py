"""``camsim sweep``: run a machine over a grid of parameter values, one summary row each."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from camsim.cli.helptext import CYCLES_HELP, SAMPLE_RATE_HELP, WARMUP_HELP
from camsim.cli.app import app, err_console, fail, print_json, user_errors, warn
from camsim.cli.report_option import REPORT_HELP, check_report_target, write_report_page
from camsim.cli.units_option import check_units, machine_units, units_option


def _default_output(machine: Path) -> Path:
    """``machines/cdtm.toml`` → ``machines/cdtm_sweep.h5``."""
    from camsim.io.outputs import beside

    return beside(machine, "_sweep.h5")


def _render(result, err, system=None) -> None:
    """The sweep's table and verdicts in ``system`` (DisplayUnits; default the machine file's units)."""
    from rich.table import Table
    from rich.text import Text

    from camsim.display import in_units
    from camsim.reports.display import as_display

    system = as_display(system, result.machine)

    rows = result.rows
    params = [name for name, _ in result.columns if name.startswith("param:")]
    units = dict(result.columns)
    if len(rows) <= 40:
        table = Table(show_edge=False, pad_edge=False)
        columns = params + ["peak_transducer_force", "min_cam_contact_force", "jump", "impacts", "status"]
        design = [n for n in ("max_pressure_angle", "min_surface_radius", "peak_hertz_stress", "peak_torque") if n in units]
        columns[-1:-1] = design  # issue 14: cam design columns with [cam.geometry]
        display = {name: system.shown(units.get(name, "")) for name in columns}
        for name in columns:
            unit = display[name][0]
            table.add_column(Text(f"{name.removeprefix('param:')}" + (f" [{unit}]" if unit else "")), overflow="fold")
        from camsim.run.result import missing_reason

        notes: dict[str, str] = {}  # column -> why it has no value in some row (issue 26)
        for row in rows:
            cells = []
            for name in columns:
                value = row[name]
                if isinstance(value, float) and math.isnan(value) and row["status"] == "ok":
                    notes.setdefault(name, missing_reason(result.machine, name, row) or "not computed")
                    cells.append(Text("n/a"))
                elif isinstance(value, float) and math.isnan(value):
                    cells.append(Text("not run"))
                else:
                    cells.append(Text(_cell(_scaled(value, display[name][1]))))
            table.add_row(*cells)
        err.print(table)
        for name, why in notes.items():
            err.print(f"n/a in {name.removeprefix('param:')}: {why}", markup=False)
    ok = sum(r["status"] == "ok" for r in rows)
    cancelled = sum(r["status"] == "cancelled" for r in rows)
    failed = len(rows) - ok - cancelled
    line = f"{len(rows)} variants ({result.executor}): {ok} ok"
    if failed:
        line += f", {failed} failed (see the status column)"
    if cancelled:
        line += f", {cancelled} cancelled"
    err.print(line, markup=False)
    if "param:cam.speed" in params:
        if result.first_jump_rpm is None and result.incomplete:
            pass  # no conclusion from rows that did not run: the note says why (issue 26)
        elif result.first_jump_rpm is None:
            err.print("the follower does not jump at any swept speed", markup=False)
        else:
            err.print(f"lowest swept speed at which the follower jumps: {_rpm(result.first_jump_rpm, system, '.6g')}", markup=False)
        if result.jump_onset_rpm is not None:
            lo, hi = result.jump_bracket_rpm
            err.print(
                f"jump onset (bisection): {_rpm(result.jump_onset_rpm, system, '.5g')} (no jump at {_rpm(lo, system, '.7g')}, "
                f"jump at {_rpm(hi, system, '.7g')})",
                markup=False,
            )
    for note in result.notes:
        err.print(f"note: {in_units(note, system)}", markup=False)


def _rpm(rpm: float, system, spec: str) -> str:
    """A speed the sweep reports in rpm, in the display units of speeds (rpm unless the file writes rad/s)."""
    return system.quantity(rpm * 2.0 * math.pi / 60.0, "rad/s", spec)


def _scaled(value, factor: float):
    if isinstance(value, float) and factor != 1.0:
        return value * factor
    return value


def _cell(value) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return "—" if math.isnan(value) else f"{value:.5g}"
    return str(value)


@app.command("sweep")
def sweep_command(
    machine: Path = typer.Argument(..., help="Machine file (TOML)."),
    vary: list[str] = typer.Option(
        [],
        "--vary",
        metavar="KEY=START:STOP:STEP[UNIT]",
        help=(
            "A range of one machine key, e.g. cam.speed=60:600:10rpm or "
            "element.seat.stiffness=1e6:4e6:1e6N/m (STOP included when on the grid; a bare "
            "number is SI). Repeatable: the grid is all combinations."
        ),
    ),
    values: list[str] = typer.Option(
        [],
        "--values",
        metavar="KEY=v1,v2,...",
        help='A list of values of one key, e.g. cam.speed=100rpm,250rpm or mass.M2.mass=0.5,0.7,0.9kg (a unit after the last bare number applies to all). Repeatable.',
    ),
    output: Path = typer.Option(
        None, "-o", "--output", help="Sweep file (HDF5, table /sweep/summary); a CSV with the same stem is written beside it. Default: <machine>_sweep.h5 next to the machine file."
    ),
    workers: int = typer.Option(None, "--workers", min=1, help="Local worker processes (default: the number of cores; 1 runs serially)."),
    scheduler: str = typer.Option(None, "--scheduler", metavar="tcp://HOST:PORT", help="Run the variants on this running Dask scheduler (needs camsim[dask], and camsim on the workers)."),
    dask_local: int = typer.Option(None, "--dask-local", min=1, metavar="N", help="Start a Dask LocalCluster of N single-threaded worker processes on 127.0.0.1 for the sweep."),
    keep_traces: bool = typer.Option(False, "--keep-traces", help="Also store each variant's traces under /sweep/variants/<k>/ (run layout; k = row index from 0)."),
    refine_jump: bool = typer.Option(False, "--refine-jump", help="For a sweep of cam.speed alone: bisect the jump onset to 0.1 rpm (stored as attribute jump_onset_rpm)."),
    max_variants: int = typer.Option(1000, "--max-variants", min=1, help="Refuse grids with more variants than this unless --yes is given."),
    yes: bool = typer.Option(False, "--yes", "-y", help="Run a grid larger than --max-variants."),
    json_: bool = typer.Option(False, "--json", help='Print {"rows": [...], "jump_onset_rpm": ...} as JSON on stdout (and nothing else there).'),
    set_: list[str] = typer.Option([], "--set", help='Override a machine key for every variant, e.g. --set element.seat.stiffness="9e6 N/m" (repeatable).'),
    cycles: int = typer.Option(None, "--cycles", min=1, help=CYCLES_HELP),
    warmup: int = typer.Option(None, "--warmup", min=0, help=WARMUP_HELP),
    sample_rate: str = typer.Option(None, "--sample-rate", help='Output sample rate with units, e.g. "10 kHz" (bare number: Hz). Default: the machine file\'s. Peaks are taken over the samples.'),
    resume: bool = typer.Option(False, "--resume", help="Continue an interrupted sweep into the same output: run only the variants missing from <output>.journal (same machine, ranges, --set and settings, else exit 2). Without a journal: a fresh sweep."),
    fresh: bool = typer.Option(False, "--fresh", help="Discard the journal an interrupted run of this command left and start again (without it, and without --resume, such a journal is an error)."),
    force: bool = typer.Option(False, "--force", help="Replace an existing result of another camsim command (a file of another kind or an input is never replaced)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress (a bar on a terminal, a line every 10 s elsewhere)."),
    units: str = units_option(),
    report: Path = typer.Option(None, "--report", metavar="PAGE.html", help=REPORT_HELP),
) -> None:
    """Run MACHINE for every combination of the varied keys; one summary row per variant.

    Columns (SI in the files; the table on stderr in --units): param:<key> per varied key; peak_displacement:<mass>,
    peak_velocity:<mass>, peak_acceleration:<mass> per mass; peak_transducer_force,
    max_cam_contact_force, min_cam_contact_force [N]; jump; impacts;
    max_impact_velocity [m/s]; periodicity_residual; status ("ok" or the error of a
    variant that failed; the sweep goes on). For a cam.speed sweep the lowest swept
    speed at which the follower jumps is reported. Each row is stored as its variant
    finishes (<output>.journal, and the HDF5 file, readable while the sweep runs), so a
    killed sweep keeps its finished rows: rerun with --resume. Exit 0 when the sweep
    ran every variant to a result; 1 when a variant failed or did not run (a worker
    process died: --resume runs it), the file then has incomplete = True and no jump
    onset is concluded across rows that did not run; 2 on bad input; 130 after Ctrl-C
    or SIGTERM (finished rows are written, the rest marked "cancelled").
    """
    from camsim.cli.app import parse_sample_rate
    from camsim.errors import FileSystemError
    from camsim.io.atomic import check_writable
    from camsim.cli.progress import Bar
    from camsim.run.lifecycle import sigterm_as_interrupt
    from camsim.analyses.sweep.runner import csv_path_for, finish_sweep, jsonable_rows, run_sweep, write_sweep

    rate = parse_sample_rate(sample_rate)
    bar = Bar("sweep", "variants", quiet=quiet)
    with user_errors(), sigterm_as_interrupt():
        check_units(units)
        target = output if output is not None else _default_output(machine)
        from camsim.io.outputs import CSV, HDF5, check_journal, check_output, output_format
        from camsim.io.rowstore import journal_path_for

        inputs = [("machine file", machine)]
        check_output(target, output_format(target, HDF5), owner="sweep", force=force, inputs=inputs)
        check_output(csv_path_for(target), output_format(csv_path_for(target), CSV), owner="csv", inputs=inputs,
                     option="-o (the CSV beside it)")
        check_journal(target, journal_path_for(target), resume=resume, fresh=fresh, what="sweep")
        check_report_target(report, inputs, force)
        try:
            result = run_sweep(
                machine,
                vary,
                values,
                fixed=set_,
                workers=workers,
                scheduler=scheduler,
                dask_local=dask_local,
                keep_traces=keep_traces,
                refine_jump=refine_jump,
                cycles=cycles,
                warmup_cycles=warmup,
                sample_rate=rate,
                max_variants=None if yes else max_variants,
                progress=bar,
                on_start=bar.start,
                output=target,
                resume=resume,
                warn=warn,
            )
        finally:
            bar.close()
        try:
            h5_path, csv_path = write_sweep(result, target, units=machine_units(units, result.machine, [*vary, *values, *set_]))
        except FileSystemError as exc:  # the journal has every finished row
            again = "--fresh (the traces of --keep-traces are not in the journal)" if keep_traces else "--resume"
            raise exc.with_advice(f"{result.journal} keeps the finished rows: free space and run the same command "
                                  f"with {again}") from None
        finish_sweep(result)
        if json_:
            print_json(
                {
                    "rows": jsonable_rows(result),
                    "jump_onset_rpm": result.jump_onset_rpm,
                    "first_jump_rpm": result.first_jump_rpm,
                    "interrupted": result.stopped,
                    "incomplete": result.incomplete,
                    "not_run": result.not_run,
                    "notes": list(result.notes),
                    "output": str(h5_path),
                    "csv": str(csv_path),
                }
            )
        elif not result.interrupted:  # interrupted: one line, below (issue 45)
            if result.resumed:
                err_console.print(f"resumed: {result.resumed} of {len(result.rows)} variants were in {result.journal}", markup=False)
            shown = machine_units(units, result.machine, [*vary, *values, *set_])
            _render(result, err_console, shown)
            err_console.print(f"wrote {h5_path} and {csv_path}", markup=False)
        write_report_page([h5_path], report, quiet=json_,
                          units=machine_units(units, result.machine, [*vary, *values, *set_]))
        if result.interrupted:
            done = sum(r["status"] != "cancelled" for r in result.rows)
            if not done:
                raise fail(f"interrupted before any of the {len(result.rows)} variants finished: nothing was kept", 130)
            raise fail(
                f"interrupted: kept the {done} finished variants of {len(result.rows)} in {h5_path} (the rest have status 'cancelled'); rerun with --resume to complete it",
                130,
            )
        if result.executor_failures:
            raise fail(
                f"incomplete: {result.executor_failures} variants did not run (a worker process failed); "
                f"{h5_path} keeps the others; rerun the same command with --resume to run them",
                1,
            )
        if result.incomplete:
            raise fail(
                f"incomplete: {len(result.failed)} of {len(result.rows)} variants failed (their status column "
                "holds the reason); no conclusion is drawn from them",
                1,
            )


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, Writes, declare
from camsim.io.outputs import HDF5, CSV, HTML
declare("sweep", reads=[Reads("machine", "machine")], force=True,
        writes=[Writes("output", "-o", HDF5, "sweep", journal=True), Writes(None, "-o", CSV, "csv", beside="-o:.csv"),
                Writes("report", "--report", HTML, "report", optional=True)],
        example=("sweep", "{in:machine}", "--vary", "cam.speed=100:140:20rpm", "--workers", "1", "-q", "-o", "{out:-o}",
                 "--report", "{out:--report}"))

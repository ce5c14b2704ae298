"""``camsim run``: simulate a machine file and write its HDF5 traces."""

from __future__ import annotations

from pathlib import Path

import typer

from camsim.cli.helptext import CYCLES_HELP, SAMPLE_RATE_HELP, WARMUP_HELP
from camsim.cli.app import app, err_console, parse_sample_rate, print_json, user_errors, warn_notes
from camsim.cli.report_option import REPORT_HELP, check_report_target, write_report_page
from camsim.cli.units_option import check_units, machine_units, units_option


def default_output(machine_path: Path, suffix: str = "") -> Path:
    """``machines/cdtm.toml`` → ``machines/cdtm.h5`` (next to the input)."""
    from camsim.io.outputs import beside

    return beside(machine_path, suffix + ".h5")


@app.command("run")
def run_command(
    machine: Path = typer.Argument(..., help="Machine file (TOML)."),
    output: Path = typer.Option(None, "-o", "--output", help="Result file (HDF5). Default: next to the machine file, e.g. machines/cdtm.h5."),
    cycles: int = typer.Option(None, "--cycles", min=1, help=CYCLES_HELP),
    warmup: int = typer.Option(None, "--warmup", min=0, help=WARMUP_HELP),
    sample_rate: str = typer.Option(None, "--sample-rate", help=SAMPLE_RATE_HELP),
    no_impact: bool = typer.Option(False, "--no-impact", help="Run the no-impact variant: contacts removed, links fixed joined, cam contacts bilateral."),
    set_: list[str] = typer.Option([], "--set", help='Override a machine key, e.g. --set cam.speed="150 rpm" (repeatable).'),
    json_: bool = typer.Option(False, "--json", help="Print the summary as JSON on stdout (and nothing else there)."),
    check_against: Path = typer.Option(None, "--check-against", help="After the run, compare the result with this golden file (exit 1 on a regression)."),
    rtol: float = typer.Option(None, "--rtol", help="Relative tolerance for --check-against (default 1e-06, as camsim check)."),
    atol: float = typer.Option(None, "--atol", help="Absolute tolerance for --check-against, in each dataset's SI unit (default 1e-12, as camsim check)."),
    max_output: str = typer.Option("2GB", "--max-output", metavar="SIZE", help="Refuse (exit 2, before integrating) a run whose estimated output is larger, e.g. 500MB, 10GB; the message gives the estimate and the options that reduce it."),
    yes: bool = typer.Option(False, "--yes", "-y", help="Run even when the estimated output exceeds --max-output or the run would take more than 1e8 integration steps forced by a fast mode."),
    record: list[str] = typer.Option([], "--record", metavar="PATTERN[,PATTERN]", help="Store only the traces whose result path matches a pattern (fnmatch), e.g. 'transducer/*,masses/M3/*' (repeatable); time is stored with them. The summary and events cover everything."),
    record_last: int = typer.Option(None, "--record-last", min=1, metavar="N", help="Store only the last N recorded revolutions of traces; the summary and events cover every revolution."),
    summary_only: bool = typer.Option(False, "--summary-only", help="Store no traces: the event table and the summary (/summary) only."),
    compress: bool = typer.Option(False, "--compress", help="gzip the stored traces (smaller file, more CPU)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress (a bar on a terminal, a line every 10 s elsewhere)."),
    max_nodes: int = typer.Option(None, "--max-nodes", min=1, metavar="N", help="Refuse (exit 2, when the machine is loaded) a model of more nodes -- masses and rod interior nodes -- than this; default 500 (docs/results.md, \"Sizes\")."),
    max_cams: int = typer.Option(None, "--max-cams", min=1, metavar="N", help="Refuse a machine of more [[cam]] tables than this; default 100."),
    units: str = units_option(),
    force: bool = typer.Option(False, "--force", help="Replace an existing result of another camsim command (a file of another kind or an input is never replaced)."),
    report: Path = typer.Option(None, "--report", metavar="PAGE.html", help=REPORT_HELP),
    cs: float = typer.Option(None, "--cs", help="Coefficient of speed fluctuation (e.g. 0.05) for the flywheel inertia I = ΔE/(Cs·ω²) in the cam design summary; needs [cam.geometry] (default: none, no flywheel inertia)."),
) -> None:
    """Simulate MACHINE and write displacement, velocity, acceleration, forces and events to HDF5.

    The traces are written to the file while the run proceeds, so memory does not grow
    with the number of revolutions; --record, --record-last and --summary-only store
    less (the summary and the event table always cover every revolution). The summary
    (peaks per mass, forces, impacts with their approach velocities and Johnson bounds,
    periodicity residual) goes to stderr and to the file's /summary group. Before
    integrating, the output size and the number of integration steps are estimated; above
    --max-output or 1e8 steps forced by a fast mode the run is refused (exit 2) unless --yes, and a model too
    stiff to integrate (numerically rigid) or a cam too fast to follow is refused (exit 2,
    naming the key). The file is written atomically: Ctrl-C or SIGTERM leaves the
    previous result and no temporary file (exit 130). Exit 0 on success, 1 when the run
    fails (diverges, unresolved chatter) or --check-against finds a regression, 2 on bad
    input.
    """
    from camsim.run.budget import check_budget, estimate_run, parse_size, record_fraction
    from camsim.cli.progress import FractionBar
    from camsim.errors import InputError
    from camsim.io.atomic import check_writable, remove_stale_temps
    from camsim.run.lifecycle import sigterm_as_interrupt
    from camsim.machine.loader import load_machine
    from camsim.reports.summary import render_run_summary
    from camsim.run.stream import limit_heap_growth, machine_trace_layout, select_traces, simulate_to_file

    rate = parse_sample_rate(sample_rate)
    patterns = [p.strip() for item in record for p in item.split(",") if p.strip()]
    from camsim.machine.limits import raised

    with user_errors(), sigterm_as_interrupt(), raised(nodes=max_nodes, cams=max_cams):
        check_units(units)
        limit = parse_size(max_output)
        if summary_only and (patterns or record_last is not None):
            raise InputError("--summary-only: stores no traces; it cannot be combined with --record or --record-last")
        if record and not patterns:
            raise InputError("--record: give at least one pattern, e.g. 'transducer/*'")
        loaded = load_machine(machine, overrides=set_)
        warn_notes(loaded)
        shown = machine_units(units, loaded)  # also the units of the errors below
        if record_last is not None and loaded.cam is None:
            raise InputError(f"--record-last {record_last}: needs a cam (revolutions); {machine} has none")
        target = output if output is not None else default_output(machine)
        from camsim.io.outputs import HDF5, check_output, output_format

        check_output(target, output_format(target, HDF5), owner="run", force=force,
                     inputs=[("machine file", machine), ("golden file", check_against)])
        check_report_target(report, [("machine file", machine), ("golden file", check_against)], force)
        from camsim.cam.design import check_machine  # issue 14: undercut/cusp and --cs checks

        check_machine(loaded, cs)
        remove_stale_temps(target)  # left by a run that was killed outright
        stored = select_traces(machine_trace_layout(loaded, no_impact), patterns or None, summary_only)
        estimate = estimate_run(loaded, cycles=cycles, warmup_cycles=warmup, sample_rate=rate, traces=len(stored),
                                record_fraction=record_fraction(loaded, record_last, cycles), no_impact=no_impact)
        if not yes:
            check_budget(estimate, limit, str(machine))
        if check_against is not None:
            from camsim.io.results import open_h5

            open_h5(check_against).close()
        limit_heap_growth()  # memory must not grow with revolutions (camsim.run.stream)
        revs = estimate.revolutions  # seconds for a machine without a cam
        progress = FractionBar("run", "rev" if revs else "s", revs or estimate.recorded_s, quiet=quiet)
        try:
            result = simulate_to_file(
                loaded, target, no_impact=no_impact, cycles=cycles, warmup_cycles=warmup, sample_rate=rate,
                progress=progress, record=patterns or None, record_last=record_last, summary_only=summary_only,
                compress=compress,
            )
        finally:
            progress.close()
        if json_:
            payload = result.summary()
            if cs is not None and "design" in payload:  # issue 14
                payload["design"] = result.design_summary(cs)
            payload["output"] = str(target)
            print_json(payload)
        else:
            render_run_summary(result, err_console, shown, cs=cs)
            err_console.print(f"wrote {target}")
        write_report_page([target], report, quiet=json_, units=units)
        if check_against is not None:
            from camsim.analyses.check import check_files, render_report

            kwargs = {k: v for k, v in (("rtol", rtol), ("atol", atol)) if v is not None}
            report = check_files(target, check_against, **kwargs)
            render_report(report, err_console, units=shown)
            if not report.passed:
                raise typer.Exit(code=1)


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, Writes, declare
from camsim.io.outputs import HDF5, HTML
declare("run", reads=[Reads("machine", "machine"),
                      Reads("check_against", "result", ("run",), fixture="run",
                            example=("run", "{machine}", "-o", "{out:-o}", "-q", "--check-against", "{in:check_against}"))],
        writes=[Writes("output", "-o", HDF5, "run"), Writes("report", "--report", HTML, "report", optional=True)],
        force=True, example=("run", "{in:machine}", "-o", "{out:-o}", "-q", "--report", "{out:--report}"))

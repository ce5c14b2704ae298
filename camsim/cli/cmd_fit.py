"""``camsim fit``: calibrate a machine file to measured traces (a thin layer over camsim.fit)."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from camsim.cli.app import app, err_console, fail, parse_sample_rate, print_json, user_errors


def evaluation_store_for(target: Path) -> Path:
    """Where a fit keeps its finished simulations until it completes: FITTED.toml.evaluations.h5."""
    return target.with_name(target.name + ".evaluations.h5")


def _default_output(machine: Path) -> Path:
    """``machines/cdtm.toml`` → ``machines/cdtm_fitted.toml``."""
    return machine.with_name(machine.stem + "_fitted.toml")


def _render(result, err) -> None:
    from rich.table import Table
    from rich.text import Text

    table = Table(show_edge=False, pad_edge=False)
    for name in ("parameter", "unit", "start", "fitted", "std. error", "95 % interval"):
        table.add_column(Text(name), overflow="fold")
    for i, key in enumerate(result.keys):
        lo, hi = result.ci95[i]
        table.add_row(
            Text(key),
            Text(result.units[i] or "—"),
            Text(f"{result.initial[i]:.6g}"),
            Text(f"{result.values[i]:.6g}"),
            Text(f"{result.stderr[i]:.3g}"),
            Text(f"{lo:.6g} to {hi:.6g}" if math.isfinite(lo) and math.isfinite(hi) else "not determined"),
        )
    err.print(table)
    if len(result.keys) > 1:
        err.print("correlation: " + "; ".join(
            f"{result.keys[i]} / {result.keys[j]} {result.correlation[i, j]:+.3f}"
            for i in range(len(result.keys)) for j in range(i + 1, len(result.keys))
        ), markup=False)
    for path, rms in result.rms_residual.items():
        err.print(f"rms residual {path}: {rms:.4g} (noise level used: {result.sigma.get(path, float('nan')):.4g})", markup=False)
    state = "converged" if result.converged else "NOT converged"
    err.print(
        f"{state}: cost {result.cost:.6g}, residual variance {result.residual_variance:.4g} "
        f"({result.dof} degrees of freedom), {result.n_evaluations} simulations; {result.message}",
        markup=False,
    )
    for w in result.warnings:
        err.print(f"warning: {w}", markup=False)


@app.command("fit")
def fit_command(
    machine: Path = typer.Argument(..., help="Machine file (TOML) to calibrate."),
    measured: Path = typer.Argument(
        None,
        metavar="[MEASURED.csv]",
        help="Measured traces: CSV with 'time [s]' first (any time unit), then columns named by result paths with units, e.g. 'transducer/force [lbf]', 'masses/M3/acceleration [m/s^2]'. Optional with --target.",
    ),
    param: list[str] = typer.Option(
        [],
        "--param",
        metavar="KEY=LOW:HIGH[:START][UNIT]",
        help="A machine key to fit (--set grammar) with its bounds and optional start, e.g. element.K23.push_stiffness=6000:10000lbf/in or element.seat.damping_ratio=0.01:0.3:0.06. Default start: the file's value. Repeatable.",
    ),
    log: list[str] = typer.Option([], "--log", metavar="KEY", help="Fit this --param key on a log scale (positive bounds; for values spanning decades). Repeatable."),
    target: list[str] = typer.Option(
        [],
        "--target",
        metavar="NAME=VALUE[UNIT]",
        help="A scalar of the run to match, e.g. max_transducer_force=148lbf, first_impact_time=0.31s, peak_acceleration:M3=900m/s^2 (default uncertainty 1 % of the value; see --sigma). Repeatable.",
    ),
    sigma: list[str] = typer.Option(
        [],
        "--sigma",
        metavar="PATH=VALUE[UNIT]",
        help="Noise level of a measured column or a target, e.g. transducer/force=0.5lbf (default: estimated from the data). Repeatable.",
    ),
    align: str = typer.Option("none", "--align", metavar="none|offset", help="offset: also fit a time shift between measured and simulated time (bounded by --max-shift)."),
    max_shift: str = typer.Option(None, "--max-shift", metavar="VALUE[UNIT]", help="Bound of the fitted time shift, e.g. 5ms (default: 5 % of the cam period)."),
    window: str = typer.Option(None, "--window", metavar="START:STOP[UNIT]", help="Compare only measured times in this window, e.g. 0.1:0.3 or 100:300ms (default unit s)."),
    drop_nan: bool = typer.Option(False, "--drop-nan", help="Leave out NaN or empty cells of the measured file (else they are an error)."),
    output: Path = typer.Option(None, "-o", "--output", help="Fitted machine file: the input with the fitted values in place, in the units written, with comments. Default: <machine>_fitted.toml."),
    report: Path = typer.Option(None, "--report", help="Figure of measured vs fitted traces with residuals (.png, .svg or .pdf), or with .html the interactive report page (parameters, intervals, correlation, measured vs fitted; see docs/report.md)."),
    json_: bool = typer.Option(False, "--json", help="Print the fit as JSON on stdout (schema in docs/fitting.md)."),
    workers: int = typer.Option(1, "--workers", min=1, help="Processes running the simulations of one Jacobian in parallel (like sweep)."),
    starts: int = typer.Option(1, "--starts", min=1, help="Solver starts: the given start plus N-1 Latin-hypercube points in the bounds; the lowest cost wins."),
    seed: int = typer.Option(0, "--seed", help="Seed of the Latin hypercube of --starts."),
    max_evaluations: int = typer.Option(None, "--max-evaluations", min=1, help="Largest number of residual evaluations per start (default 100 per parameter); a fit stopped by it exits 1."),
    resume: bool = typer.Option(False, "--resume", help="Continue a fit that was interrupted (Ctrl-C, SIGTERM, SIGKILL): the simulations it finished are kept in FITTED.toml.evaluations.h5 (and its .journal) and are not run again. The same machine, parameters, traces and settings are required."),
    set_: list[str] = typer.Option([], "--set", help='Override a machine key for every run, e.g. --set element.seat.stiffness="9e6 N/m" (repeatable).'),
    cycles: int = typer.Option(None, "--cycles", min=1, help="Recorded revolutions of every run (overrides simulation.cycles)."),
    warmup: int = typer.Option(None, "--warmup", min=0, help="Warm-up revolutions of every run (overrides simulation.warmup_cycles)."),
    sample_rate: str = typer.Option(None, "--sample-rate", help='Output sample rate of every run, e.g. "50 kHz" (default: the machine file\'s); the simulation is interpolated linearly at the measured times.'),
) -> None:
    """Calibrate MACHINE to MEASURED traces: fit the --param keys by weighted least squares.

    Each measured channel is weighted by 1/(its noise level); the simulation is
    interpolated at the measured times (time 0 = start of the first recorded cycle).
    Prints the fitted values with standard errors, 95 % intervals, correlations and
    identifiability warnings, and writes FITTED.toml (-o). Exit 0 on a converged fit,
    1 when the fit does not converge or a run fails (nothing written), 2 on bad input.
    """
    from camsim.fit import fit, write_fitted
    from camsim.io.atomic import check_writable

    rate = parse_sample_rate(sample_rate)
    show = err_console.print if err_console.is_terminal else None
    with user_errors():
        target_path = output if output is not None else _default_output(machine)
        check_writable(target_path)
        if report is not None:
            from camsim.fit.report import REPORT_FORMATS

            if report.suffix.lower() == ".html":
                from camsim.cli.report_option import check_report_target

                check_report_target(report)
            elif report.suffix.lstrip(".").lower() not in REPORT_FORMATS:
                raise fail(f"--report {report}: unknown figure format '{report.suffix}' (use .png, .svg, .pdf or .html)")
            check_writable(report)
        result = fit(
            machine,
            measured,
            param,
            targets=target,
            sigma=sigma,
            log=log,
            fixed=set_,
            align=align,
            max_shift=max_shift,
            window=window,
            drop_nan=drop_nan,
            cycles=cycles,
            warmup_cycles=warmup,
            sample_rate=rate,
            workers=workers,
            starts=starts,
            seed=seed,
            max_evaluations=max_evaluations,
            progress=(lambda line: show(line, markup=False)) if show else None,
            evaluations=evaluation_store_for(target_path),
            resume=resume,
        )
        if json_:
            print_json(result.to_json())
        else:
            _render(result, err_console)
        if not result.converged:
            raise fail("the fit did not converge (above: what it reached); nothing was written", 1)
        from camsim.fit import fitted_text
        from camsim.loader import read_machine_text

        text = read_machine_text(machine)
        fitted_text(text, result, source=str(machine))  # any problem shows before a file is written
        if report is not None and report.suffix.lower() == ".html":
            from camsim.cli.report_option import command_line
            from camsim.reports.page import build_report_from

            build_report_from((result, machine, text), "fit", report, command=command_line(), title=f"{machine} — fit report")
        elif report is not None:
            from camsim.fit.report import write_report

            write_report(report, result, title=str(machine))
        written = write_fitted(target_path, text, result, source=str(machine))
        if not json_:
            err_console.print(f"wrote {written}" + (f" and {report}" if report is not None else ""), markup=False)

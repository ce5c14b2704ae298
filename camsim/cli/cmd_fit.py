"""``camsim fit``: calibrate a machine file to measured traces (a thin layer over camsim.analyses.fit)."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from camsim.cli.helptext import CYCLES_HELP, SAMPLE_RATE_HELP, WARMUP_HELP
from camsim.cli.app import app, err_console, fail, parse_sample_rate, print_json, user_errors, warn_notes
from camsim.cli.units_option import check_units, machine_units, units_option


def evaluation_store_for(target: Path) -> Path:
    """Where a fit keeps its finished simulations until it completes: FITTED.toml.evaluations.h5."""
    return target.with_name(target.name + ".evaluations.h5")


def _default_output(machine: Path) -> Path:
    """``machines/cdtm.toml`` → ``machines/cdtm_fitted.toml``."""
    from camsim.io.outputs import beside

    return beside(machine, "_fitted.toml")


def written_units(params: list[str], targets: list[str]) -> dict[str, str]:
    """The unit the user wrote for each --param key and --target name (``""``: none, SI).

    ``element.K23.push_stiffness=6000:10000lbf/in`` → ``{"element.K23.push_stiffness":
    "lbf/in"}``; the fit table and its messages show values in these units (issue 26).
    """
    from camsim.analyses.fit.objective import ALIASES
    from camsim.analyses.fit.params import _NUMBER

    out: dict[str, str] = {}
    for text in params:
        key, _, spec = text.partition("=")
        m = _NUMBER.match(spec.split(":")[-1])
        if m and m.group(2):
            out[key.strip()] = m.group(2)
    for text in targets:
        name, _, spec = text.partition("=")
        m = _NUMBER.match(spec)
        if m and m.group(2):
            out[ALIASES.get(name.strip(), name.strip())] = m.group(2)
    return out


def _converter(si_unit: str, unit: str | None, display=None):
    """(unit shown, SI -> shown function): the unit written for this key when it converts,
    else the display units (issue 36; SI without them)."""
    from camsim.reports.display import as_display

    shown_unit, factor = as_display(display or "si").shown(si_unit or "")
    fallback = (shown_unit, lambda v: v * factor)
    if not unit or not si_unit:
        return fallback
    from camsim.units import ureg

    try:
        factor = float(ureg.Quantity(1.0, si_unit.replace("²", "^2")).to(unit).magnitude)
    except Exception:  # noqa: BLE001 - an offset unit or a unit pint cannot scale: the display units
        return fallback
    return unit, lambda v: v * factor


def measured_units(measured: Path | None) -> list[str]:
    """The units in the header of the measured CSV (``transducer/force [lbf]`` → ``"1 lbf"``): units
    the user wrote, shown first like the command line's (issue 36). Nothing for an unreadable file."""
    import re

    if measured is None:
        return []
    try:
        with open(measured, encoding="utf-8-sig") as fh:
            header = fh.readline()
    except (OSError, UnicodeDecodeError):
        return []
    return [f"1 {u.strip()}" for u in re.findall(r"\[([^\]]+)\]", header)]


def _path_unit(path: str) -> str:
    from camsim.analyses.study.outputs import scalar_unit, trace_unit

    return trace_unit(path) if "/" in path else scalar_unit(path)


def misfit_lines(result, written: dict[str, str], display=None) -> list[str]:
    """:attr:`FitResult.misfits` with each target in the unit the user wrote (else the display units)."""
    lines = []
    for name, t in result.targets.items():
        error = t["achieved"] - t["value"]
        if math.isfinite(error) and abs(error) <= t["sigma"]:
            continue
        unit, conv = _converter(t["unit"], written.get(name), display)
        lines.append(f"{name}: fitted {conv(t['achieved']):.6g} {unit}, target {conv(t['value']):.6g} {unit} "
                     f"± {conv(t['sigma']):.3g} (missed by {abs(error) / t['sigma']:.3g} sigma)")
    lines += [m for m in result.misfits if m.startswith("residual variance")]
    return lines


def _render(result, err, written: dict[str, str] | None = None, display=None) -> None:
    """The fit's table and lines: each key in the unit written for it, else in ``display``."""
    from rich.table import Table
    from rich.text import Text

    from camsim.display import in_units
    from camsim.reports.display import as_display

    display = as_display(display or "si")
    written = written or {}
    table = Table(show_edge=False, pad_edge=False)
    for name in ("parameter", "unit", "start", "fitted", "std. error", "95 % interval"):
        table.add_column(Text(name), overflow="fold")
    for i, key in enumerate(result.keys):
        unit, conv = _converter(result.units[i], written.get(key), display)
        lo, hi = conv(result.ci95[i][0]), conv(result.ci95[i][1])
        table.add_row(
            Text(key),
            Text(unit or "—"),
            Text(f"{conv(result.initial[i]):.6g}"),
            Text(f"{conv(result.values[i]):.6g}"),
            Text(f"{conv(result.stderr[i]):.3g}"),
            Text(f"{lo:.6g} to {hi:.6g}" if math.isfinite(lo) and math.isfinite(hi) else "not determined"),
        )
    err.print(table)
    if len(result.keys) > 1:
        err.print("correlation: " + "; ".join(
            f"{result.keys[i]} / {result.keys[j]} {result.correlation[i, j]:+.3f}"
            for i in range(len(result.keys)) for j in range(i + 1, len(result.keys))
        ), markup=False)
    for path, rms in result.rms_residual.items():
        si_unit = result.targets[path]["unit"] if path in result.targets else _path_unit(path)
        unit, conv = _converter(si_unit, written.get(path), display)
        shown = f" {unit}" if unit else ""
        err.print(f"rms residual {path}: {conv(rms):.4g}{shown} (noise level used: {conv(result.sigma.get(path, float('nan'))):.4g}{shown})", markup=False)
    state = "converged" if result.converged else "NOT converged"
    err.print(
        f"{state}: cost {result.cost:.6g}, residual variance {result.residual_variance:.4g} "
        f"({result.dof} degrees of freedom), {result.n_evaluations} simulations; {result.message}",
        markup=False,
    )
    for w in result.warnings:
        err.print(f"warning: {in_units(w, display)}", markup=False)


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
    cycles: int = typer.Option(None, "--cycles", min=1, help=CYCLES_HELP),
    warmup: int = typer.Option(None, "--warmup", min=0, help=WARMUP_HELP),
    sample_rate: str = typer.Option(None, "--sample-rate", help='Output sample rate of every run, e.g. "50 kHz" (default: the machine file\'s); the simulation is interpolated linearly at the measured times.'),
    accept_misfit: bool = typer.Option(False, "--accept-misfit", help="Write the fitted file (exit 0) even when a --target is missed by more than its sigma or the residual variance of a trace fit is above 2 (the misfit is printed as a warning)."),
    fresh: bool = typer.Option(False, "--fresh", help="Discard the evaluations an interrupted fit left (FITTED.toml.evaluations.h5) and start again."),
    force: bool = typer.Option(False, "--force", help="Replace an existing FITTED.toml that is not the result of a fit (a machine file written by hand or by lump)."),
    units: str = units_option("Units of the human output: file (the machine file's units per dimension, with the units "
                              "written in --param/--target/--sigma and in the measured CSV's header first; the default), "
                              "si or us. A --param or --target is shown in the unit written for it. --json is SI."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress (each iteration on a terminal, the latest every 10 s elsewhere)."),
) -> None:
    """Calibrate MACHINE to MEASURED traces: fit the --param keys by weighted least squares.

    Each measured channel is weighted by 1/(its noise level); the simulation is
    interpolated at the measured times (time 0 = start of the first recorded cycle).
    Prints the fitted values with standard errors, 95 % intervals, correlations and
    identifiability warnings, and writes FITTED.toml (-o). Exit 0 on a converged fit
    that matches; 1 when the fit does not converge, a run fails, or the fitted machine
    does not match (a --target missed by more than its sigma, a residual variance above
    2 for traces; unless --accept-misfit): nothing written then; 2 on bad input.
    """
    from camsim.analyses.fit import fit as _fit, write_fitted
    from camsim.io.atomic import check_writable

    rate = parse_sample_rate(sample_rate)
    from camsim.cli.progress import Lines

    show = Lines(quiet)
    from camsim.run.lifecycle import sigterm_as_interrupt

    with user_errors(), sigterm_as_interrupt():  # issue 45: SIGTERM stops the workers as Ctrl-C does
        check_units(units)
        target_path = output if output is not None else _default_output(machine)
        from camsim.io.outputs import FIGURES, HDF5, TOML, check_journal, check_output, output_format
        from camsim.io.rowstore import journal_path_for

        inputs = [("machine file", machine), ("measured file", measured)]
        check_output(target_path, output_format(target_path, TOML), owner="fit", force=force, inputs=inputs)
        store = evaluation_store_for(target_path)
        # the store is a row-store view with file_kind "fit": another file there needs --force
        check_output(store, output_format(store, HDF5), owner="fit", inputs=inputs, option="-o (its evaluation store)",
                     force=force)
        check_journal(target_path, journal_path_for(store), resume=resume, fresh=fresh, what="fit")
        if report is not None and report.suffix.lower() in (".html", ".htm"):
            from camsim.cli.report_option import check_report_target

            check_report_target(report, inputs, force)
        elif report is not None:
            check_output(report, output_format(report, {**FIGURES, ".html": "html"}, "--report"), owner="figure",
                         inputs=inputs, option="--report")
        try:
            result = _fit(
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
                progress=show,
                evaluations=evaluation_store_for(target_path),
                resume=resume,
            )
        except KeyboardInterrupt:
            kept = journal_path_for(store).exists()
            raise fail(f"interrupted: the finished simulations are kept in {store} (and its .journal); run the same "
                       "command with --resume to continue" if kept else "interrupted before any simulation finished: "
                       "nothing was kept", 130) from None
        written_in = written_units(param, target)
        from camsim.machine.loader import load_machine

        loaded = load_machine(machine, overrides=set_)
        warn_notes(loaded)
        shown = machine_units(units, loaded, [*param, *target, *sigma, *set_, *measured_units(measured)])
        if json_:
            print_json(result.to_json())
        else:
            _render(result, err_console, written_in, shown)
        if not result.converged:
            raise fail("the fit did not converge (above: what it reached); nothing was written", 1)
        misfit = misfit_lines(result, written_in, shown)
        if misfit and not accept_misfit:
            raise fail("the fit did not match: " + "; ".join(misfit)
                       + "; nothing was written (--accept-misfit writes it anyway)", 1)
        for line in misfit:
            err_console.print(f"warning: did not match: {line}", markup=False)
        from camsim.analyses.fit import fitted_text
        from camsim.machine.loader import read_machine_text

        text = read_machine_text(machine)
        fitted_text(text, result, source=str(machine))  # any problem shows before a file is written
        if report is not None and report.suffix.lower() in (".html", ".htm"):
            from camsim.cli.report_option import command_line
            from camsim.reports.build import build_report_from

            build_report_from((result, machine, text), "fit", report, command=command_line(),
                              title=f"{loaded.name} — fit report", units=shown)
        elif report is not None:
            from camsim.figures.fit import write_report

            write_report(report, result, title=loaded.name, units=shown)
        written = write_fitted(target_path, text, result, source=str(machine))
        if not json_:
            err_console.print(f"wrote {written}" + (f" and {report}" if report is not None else ""), markup=False)


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, Writes, declare
from camsim.io.outputs import HDF5, TOML, FIGURES
declare("fit", reads=[Reads("machine", "machine"),
                      Reads("measured", "csv", fixture="measured",
                            example=("fit", "{machine}", "{in:measured}", "--param", "element.K.preload=0:100", "-o", "{out:-o}"))],
        writes=[Writes("output", "-o", TOML, "fit"), Writes(None, "-o", HDF5, "fit", beside="-o:+.evaluations.h5", journal=True,
                                                           transient=True),
                Writes("report", "--report", FIGURES, "figure", optional=True)],
        force=True, example=("fit", "{in:machine}", "--target", "max_cam_contact_force=100N", "--param", "element.K.preload=0:100",
                             "-o", "{out:-o}", "--report", "{out:--report}"))

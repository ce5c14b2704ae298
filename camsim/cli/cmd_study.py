"""``camsim study``: tolerance analysis — Monte Carlo statistics, limit probabilities, Sobol' indices."""

from __future__ import annotations

import math
import re
from pathlib import Path

import typer

from camsim.cli.helptext import CYCLES_HELP, SAMPLE_RATE_HELP, WARMUP_HELP
from camsim.cli.app import app, err_console, fail, print_json, user_errors
from camsim.cli.report_option import REPORT_HELP, check_report_target, write_report_page
from camsim.cli.units_option import check_units, machine_units, units_option


class _Start:
    """What is printed when the runs start (after every check passed), and the progress bar."""

    def __init__(self, bar) -> None:
        self.bar = bar
        self.message = ""

    def __call__(self, total: int, todo: int, executor: str) -> None:
        if self.message:
            err_console.print(self.message, markup=False)
        if todo < total:
            err_console.print(f"resuming: {total - todo} of {total} runs already done", markup=False)
        if todo:
            self.bar.start(total, executor)
            self.bar(total - todo, total)


def _fmt(value: float) -> str:
    return "—" if value is None or (isinstance(value, float) and not math.isfinite(value)) else f"{value:.5g}"


def _render(result, err, system=None) -> None:
    """The study's tables in ``system`` (DisplayUnits; default the machine file's units)."""
    from rich.table import Table
    from rich.text import Text

    from camsim.display import in_units
    from camsim.reports.display import as_display

    system = as_display(system, getattr(result, "machine", None))

    units = dict(result.columns)
    table = Table(show_edge=False, pad_edge=False, title=f"{result.n_runs} runs ({result.method}, seed {result.seed}), 95 % bootstrap intervals of the mean")
    # Issue 44: a name is never cut (three rows of "peak_displacement:…" on an 80-column terminal): the
    # name columns keep their longest name, the numbers wrap instead.
    longest = max((len(q) for q in result.stats), default=6)
    for head in ("output", "unit", "mean", "mean 95 %", "std", "p1", "p50", "p99", "min", "max"):
        table.add_column(Text(head), min_width=longest if head == "output" else None, overflow="fold")
    for q, s in result.stats.items():
        unit, k = system.shown(units.get(q, ""))
        ci = s["ci95"]["mean"]

        def v(x):
            return _fmt(None if x is None else x * k)

        table.add_row(
            Text(q), Text(unit or "-"), Text(v(s["mean"])), Text(f"{v(ci[0])} … {v(ci[1])}"),
            Text(v(s["std"])), Text(v(s["percentiles"]["1"])), Text(v(s["percentiles"]["50"])),
            Text(v(s["percentiles"]["99"])), Text(v(s["min"])), Text(v(s["max"])),
        )
    err.print(table)
    shown_values = [x for s in result.stats.values() for x in (s["mean"], *s["ci95"]["mean"], s["std"], s["min"], s["max"])]
    if any(_fmt(x) == "—" for x in shown_values):  # issue 35: every "—" says why
        err.print("—: not defined for these runs (one run has no spread and no bootstrap interval; a statistic of "
                  "runs that all failed has no value)", markup=False)
    for lim in result.limits:
        if lim.get("reason"):
            err.print(f"P({lim['expr']}): not determined: {lim['reason']}", markup=False)
            continue
        lo, hi = lim["ci95"]
        err.print(
            f"P({lim['expr']}) = {_fmt(lim['probability'])} ({lim['crossed']} of {lim['n']} runs; 95 % Clopper-Pearson "
            f"{_fmt(lo)} … {_fmt(hi)}), {_fmt(lim['per_million'])} per million machines",
            markup=False,
        )
    if result.sensitivity is not None:
        sens = Table(show_edge=False, pad_edge=False, title="Sobol' indices: first order S1, total ST (95 % bootstrap intervals)")
        widths = {"output": max((len(q) for q in result.sensitivity), default=6),
                  "input": max((len(k) for per in result.sensitivity.values() if per for k in per), default=5)}
        for head in ("output", "input", "S1", "S1 95 %", "ST", "ST 95 %"):
            sens.add_column(Text(head), min_width=widths.get(head), overflow="fold")
        for q, per in result.sensitivity.items():
            if not per:
                continue
            for key, v in per.items():
                sens.add_row(
                    Text(q), Text(key), Text(f"{v['first']:.3f}"), Text(f"{v['first_ci95'][0]:.3f} … {v['first_ci95'][1]:.3f}"),
                    Text(f"{v['total']:.3f}"), Text(f"{v['total_ci95'][0]:.3f} … {v['total_ci95'][1]:.3f}"),
                )
        err.print(sens)
        if result.ranking:
            what = "the limited outputs" if result.limits else "any output"
            err.print(f"tolerances to tighten first (largest total index over {what}):", markup=False)
            for k, (key, total) in enumerate(result.ranking, 1):
                err.print(f"  {k}. {key}  (ST = {total:.3f})", markup=False)
    for note in result.notes:
        err.print(f"note: {in_units(note, system)}", markup=False)


#: A trace reduction (--reduce), mistaken for the study file.
_REDUCTION = re.compile(r"^(max|min|maxabs|rms|mean|ptp):[\w/\[\]]")


@app.command("study")
def study_command(
    machine: Path = typer.Argument(None, help="Machine file (TOML); may come from the [study] table of --config instead."),
    dist: list[str] = typer.Option(
        [], "--dist", metavar="KEY=SPEC",
        help=(
            "An input and its distribution (repeatable). SPEC: normal:MEAN:STD[UNIT], uniform:LOW:HIGH[UNIT], "
            "lognormal:MEDIAN:GSD[UNIT], truncnormal:MEAN:STD:LOW:HIGH[UNIT], tol:NOMINAL:PLUSMINUS[UNIT] "
            "(normal, sigma = tolerance/--tol-sigma, truncated at the limits) or tol:NOMINAL:+UP:-DOWN[UNIT]. "
            "The unit after the last number applies to all; a bare number is SI. "
            "e.g. element.seat.stiffness=tol:8.6e6:0.5e6N/m"
        ),
    ),
    samples: int = typer.Option(None, "--samples", "-n", help="Number of samples N (with --sensitivity: N (d+2) runs, N a power of two). Default 256."),
    out: Path = typer.Option(None, "-o", "--output", "--out", help="Study file (HDF5, table /study/rows); a CSV with the same stem is written beside it. Default: <machine>_study.h5."),
    method: str = typer.Option(None, "--method", help="Sampling: mc (Monte Carlo, default), lhs (Latin hypercube) or sobol (scrambled Sobol'; use a power-of-two N)."),
    seed: int = typer.Option(None, "--seed", min=0, help="Seed of every random draw (default 0): the same seed gives the same rows, bit for bit, whatever --workers."),
    tol_sigma: float = typer.Option(None, "--tol-sigma", help="Standard deviations between a tol: nominal and its limits (default 3)."),
    correlate: list[str] = typer.Option([], "--correlate", metavar="KEY1,KEY2=RHO", help="Correlate two inputs (Gaussian copula on their normal scores; repeatable)."),
    output_expr: list[str] = typer.Option([], "--reduce", metavar="REDUCER:PATH", help="An extra output per run, a trace reduced to one number: max|min|rms|mean of a trace, e.g. max:masses/M3/acceleration, rms:transducer/force (repeatable; was --output, which now names the study file as -o does)."),
    limit: list[str] = typer.Option([], "--limit", metavar="QUANTITY<VALUE", help='Probability of crossing a limit, e.g. "min_cam_contact_force<0N" (<, <=, >, >=; repeatable).'),
    sensitivity: bool = typer.Option(None, "--sensitivity/--no-sensitivity", help="First-order and total Sobol' indices of every output to every input (Saltelli design, N (d+2) runs)."),
    config: Path = typer.Option(None, "--config", help="Read the study from the [study] table of this TOML file (command-line options win)."),
    set_: list[str] = typer.Option([], "--set", help="Override a machine key for every run (repeatable)."),
    cycles: int = typer.Option(None, "--cycles", min=1, help=CYCLES_HELP),
    warmup: int = typer.Option(None, "--warmup", min=0, help=WARMUP_HELP),
    sample_rate: str = typer.Option(None, "--sample-rate", help=SAMPLE_RATE_HELP),
    workers: int = typer.Option(None, "--workers", min=1, help="Local worker processes (default: the number of cores; 1 runs serially)."),
    scheduler: str = typer.Option(None, "--scheduler", metavar="tcp://HOST:PORT", help="Run on this Dask scheduler (needs camsim[dask])."),
    dask_local: int = typer.Option(None, "--dask-local", min=1, metavar="N", help="Start a Dask LocalCluster of N workers for the study."),
    resume: bool = typer.Option(False, "--resume", help="Continue an interrupted study (same command): only the missing runs are made."),
    plot: Path = typer.Option(None, "--plot", metavar="FILE.png", help="Write a figure: histograms with limits, most influential input against each output, Sobol' indices."),
    json_: bool = typer.Option(False, "--json", help="Print the statistics as JSON on stdout (schema in docs/tolerance.md)."),
    fresh: bool = typer.Option(False, "--fresh", help="Discard the journal an interrupted run of this command left and start again (without it, and without --resume, such a journal is an error)."),
    force: bool = typer.Option(False, "--force", help="Replace an existing result of another camsim command (a file of another kind or an input is never replaced)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress (a bar on a terminal, a line every 10 s elsewhere)."),
    units: str = units_option(),
    report: Path = typer.Option(None, "--report", metavar="PAGE.html", help=REPORT_HELP),
    max_runs: int = typer.Option(100_000, "--max-runs", min=1, help="Refuse (exit 2, before anything runs) a study of more simulation runs (--samples, x (d + 2) with --sensitivity)."),
    yes: bool = typer.Option(False, "--yes", "-y", help="Run a study above --max-runs (or whose runs exceed the 2 GB output estimate)."),
) -> None:
    """Tolerance study of MACHINE: sample the --dist inputs, run every sample, report statistics.

    Each run records every summary quantity of the run (peaks per mass, min/max cam
    contact force, peak transducer force, jump, impacts, ...) and the --reduce
    reductions, in SI. Statistics: mean, std, percentiles 1/5/50/95/99, min/max with
    95 % bootstrap intervals; --limit gives the probability of crossing each limit;
    --sensitivity the Sobol' indices. Rows are kept as they finish; after Ctrl-C or a
    kill, run the same command with --resume. Exit 0 when every run ran; 1 when a run
    failed (its row holds the reason; incomplete = True in the file and the JSON, and no
    limit probability is concluded), 2 on bad input, 130 after Ctrl-C or SIGTERM.
    """
    from camsim.cli.progress import Bar
    from camsim.errors import InputError
    from camsim.io.atomic import check_writable
    from camsim.run.lifecycle import sigterm_as_interrupt
    from camsim.analyses.study import StudyInterrupted, study
    from camsim.analyses.study.config import merge_dists, read_config
    from camsim.analyses.study.files import csv_path_for

    bar = Bar("study", "runs", quiet=quiet)
    start = _Start(bar)
    with user_errors(), sigterm_as_interrupt():
        check_units(units)
        cfg = read_config(config) if config is not None else {}
        if machine is None:
            if "machine" not in cfg:
                raise InputError("study: give the MACHINE file (or machine = ... in the [study] table of --config)")
            machine = Path(cfg["machine"])
        rate_text = sample_rate if sample_rate is not None else cfg.get("sample_rate")
        rate = None
        if rate_text is not None:
            from camsim.units import QuantityError, to_si

            try:
                rate = to_si(rate_text if isinstance(rate_text, str) else float(rate_text), "frequency")
            except QuantityError as exc:
                raise InputError(f"--sample-rate: {exc}") from None
        from camsim.io.outputs import beside

        if out is not None and _REDUCTION.match(str(out)):  # issue 44: -o/--output is the file, as in every command
            raise InputError(f"-o/--output {out}: names the study file (HDF5); '{out}' is a reduction of a trace: "
                             f"give it with --reduce {out}")
        target = out if out is not None else beside(machine, "_study.h5")
        from camsim.io.outputs import CSV, HDF5, check_journal, check_output, output_format
        from camsim.io.rowstore import journal_path_for

        inputs = [("machine file", machine), ("config file", config)]
        check_output(target, output_format(target, HDF5), owner="study", force=force, inputs=inputs)
        check_output(csv_path_for(target), output_format(csv_path_for(target), CSV), owner="csv", inputs=inputs,
                     option="-o (the CSV beside it)")
        check_journal(target, journal_path_for(target), resume=resume, fresh=fresh, what="study")
        check_report_target(report, inputs, force)
        if plot is not None:
            from camsim.io.outputs import FIGURES

            check_output(plot, output_format(plot, FIGURES, "--plot"), owner="figure", inputs=inputs, option="--plot")
        n = samples if samples is not None else cfg.get("samples", 256)
        if samples is not None and samples < 1:
            raise InputError(f"--samples {samples}: needs at least 1")
        sens = sensitivity if sensitivity is not None else cfg.get("sensitivity", False)
        if sens:
            from camsim.analyses.study.sampling import n_runs

            d = len(merge_dists(cfg.get("dist", []), dist))
            start.message = f"sensitivity: Saltelli's design needs N (d + 2) = {n} x {d + 2} = {n_runs(n, d, True)} runs"
        try:
            result = study(
                machine,
                merge_dists(cfg.get("dist", []), dist),
                n,
                method=method if method is not None else cfg.get("method", "mc"),
                seed=seed if seed is not None else cfg.get("seed", 0),
                tol_sigma=tol_sigma if tol_sigma is not None else float(cfg.get("tol_sigma", 3.0)),
                correlate=cfg.get("correlate", []) + correlate,
                outputs=cfg.get("reduce", cfg.get("output", [])) + output_expr,
                limits=cfg.get("limit", []) + limit,
                sensitivity=sens,
                fixed=cfg.get("set", []) + set_,
                cycles=cycles if cycles is not None else cfg.get("cycles"),
                warmup_cycles=warmup if warmup is not None else cfg.get("warmup"),
                sample_rate=rate,
                workers=workers if workers is not None else cfg.get("workers"),
                scheduler=scheduler,
                dask_local=dask_local,
                output=target,
                resume=resume,
                progress=bar,
                on_start=start,
                max_runs=math.inf if yes else max_runs,
                max_output=math.inf if yes else None,
            )
        except StudyInterrupted as exc:
            bar.close()
            if not exc.done:
                raise fail(f"interrupted before any of the {exc.total} runs finished: nothing was kept", 130) from None
            raise fail(
                f"interrupted: {exc.done} of {exc.total} runs are kept in {exc.store} (and its .journal); "
                "run the same command with --resume to finish",
                130,
            ) from None
        finally:
            bar.close()
        from camsim.display import in_units

        written = [*(cfg.get("dist", []) or []), *dist, *(cfg.get("limit", []) or []), *limit, *(cfg.get("set", []) or []), *set_]
        shown = machine_units(units, getattr(result, "machine", None), written)
        for w in result.warnings:
            err_console.print(f"warning: {in_units(w, shown)}", markup=False)
        if plot is not None:
            from camsim.figures.study import save_study_plot

            save_study_plot(result, plot, units=shown)
        if json_:
            print_json(result.to_json())
        else:
            _render(result, err_console, shown)
            err_console.print(f"wrote {result.output} and {result.csv}" + (f" and {plot}" if plot is not None else ""), markup=False)
        write_report_page([Path(result.output)], report, quiet=json_, units=shown)
        if result.not_run:
            raise fail(f"incomplete: {result.not_run} of {result.n_runs} runs did not run (a worker process failed); "
                       f"{result.output} keeps the others and its .journal; run the same command with --resume to "
                       "run them (no probability is concluded meanwhile)", 1)
        if result.failed:
            raise fail(f"incomplete: {result.failed} of {result.n_runs} runs failed (their rows hold the reason in "
                       "'status'); no probability is concluded from the others", 1)


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, Writes, declare
from camsim.io.outputs import HDF5, CSV, FIGURES, HTML
declare("study", reads=[Reads("machine", "machine"), Reads("config", "config", fixture="config",
                                                           example=("study", "--config", "{in:config}", "-o", "{out:-o}"))],
        writes=[Writes("out", "-o", HDF5, "study", journal=True), Writes(None, "-o", CSV, "csv", beside="-o:.csv"),
                Writes("plot", "--plot", FIGURES, "figure", optional=True), Writes("report", "--report", HTML, "report", optional=True)],
        force=True, example=("study", "{in:machine}", "--dist", "element.K.preload=normal:40N:1N", "-n", "3", "--workers", "1", "-q",
                             "-o", "{out:-o}", "--plot", "{out:--plot}", "--report", "{out:--report}"))

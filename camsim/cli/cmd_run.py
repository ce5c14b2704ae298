"""``camsim run``: simulate a machine file and write its HDF5 traces."""

from __future__ import annotations

import time
from pathlib import Path

import typer

from camsim.cli.app import app, err_console, fail, print_json, user_errors
from camsim.units import QuantityError, to_si


def default_output(machine_path: Path, suffix: str = "") -> Path:
    """``machines/cdtm.toml`` → ``machines/cdtm.h5`` (next to the input)."""
    return machine_path.with_name(machine_path.stem + suffix + ".h5")


def parse_sample_rate(text: str | None) -> float | None:
    if text is None:
        return None
    try:
        value = to_si(text, "frequency")
    except QuantityError as exc:
        raise fail(f"--sample-rate: {exc}") from None
    if value <= 0:
        raise fail("--sample-rate: must be positive")
    return value


class ProgressAfterOneSecond:
    """A progress bar on stderr that appears only for runs longer than a second on a terminal."""

    def __init__(self, description: str):
        self.description = description
        self.start = time.monotonic()
        self.progress = None
        self.task = None

    def __call__(self, fraction: float) -> None:
        if not err_console.is_terminal:
            return
        if self.progress is None:
            if time.monotonic() - self.start < 1.0:
                return
            from rich.progress import Progress

            self.progress = Progress(console=err_console, transient=True)
            self.progress.start()
            self.task = self.progress.add_task(self.description, total=1.0)
        self.progress.update(self.task, completed=fraction)

    def close(self) -> None:
        if self.progress is not None:
            self.progress.stop()


@app.command("run")
def run_command(
    machine: Path = typer.Argument(..., help="Machine file (TOML)."),
    output: Path = typer.Option(None, "-o", "--output", help="Result file (HDF5). Default: next to the machine file, e.g. machines/cdtm.h5."),
    cycles: int = typer.Option(None, "--cycles", min=1, help="Recorded revolutions (overrides simulation.cycles)."),
    warmup: int = typer.Option(None, "--warmup", min=0, help="Revolutions computed and discarded first (overrides simulation.warmup_cycles)."),
    sample_rate: str = typer.Option(None, "--sample-rate", help='Output sample rate with units, e.g. "50 kHz" (bare number: Hz).'),
    no_impact: bool = typer.Option(False, "--no-impact", help="Run the no-impact variant: contacts removed, links fixed joined, cam contacts bilateral."),
    set_: list[str] = typer.Option([], "--set", help='Override a machine key, e.g. --set cam.speed="150 rpm" (repeatable).'),
    json_: bool = typer.Option(False, "--json", help="Print the summary as JSON on stdout (and nothing else there)."),
    check_against: Path = typer.Option(None, "--check-against", help="After the run, compare the result with this golden file (exit 1 on a regression)."),
    rtol: float = typer.Option(None, "--rtol", help="Relative tolerance for --check-against (see camsim check)."),
    atol: float = typer.Option(None, "--atol", help="Absolute tolerance for --check-against (SI)."),
    cs: float = typer.Option(None, "--cs", help="Coefficient of speed fluctuation (e.g. 0.05) for the flywheel inertia I = dE/(Cs*w^2) in the cam design summary; needs [cam.geometry]."),
) -> None:
    """Simulate MACHINE and write displacement, velocity, acceleration, forces and events to HDF5.

    The summary (peaks per mass, forces, impacts with their approach velocities and
    Johnson bounds, periodicity residual) goes to stderr. Exit 0 on success, 1 when the
    run fails (diverges, unresolved chatter) or --check-against finds a regression,
    2 on bad input.
    """
    from camsim.io.atomic import check_writable
    from camsim.io.runfile import write_run
    from camsim.loader import load_machine
    from camsim.report import render_run_summary
    from camsim.simulate import simulate

    rate = parse_sample_rate(sample_rate)
    with user_errors():
        loaded = load_machine(machine, overrides=set_)
        target = output if output is not None else default_output(machine)
        check_writable(target)
        from camsim.cam.design import check_machine  # issue 14: undercut/cusp and --cs checks

        check_machine(loaded, cs)
        if check_against is not None:
            from camsim.io.results import open_result

            open_result(check_against).close()
        progress = ProgressAfterOneSecond(f"simulating {loaded.name}")
        try:
            result = simulate(loaded, no_impact=no_impact, cycles=cycles, warmup_cycles=warmup, sample_rate=rate, progress=progress)
        finally:
            progress.close()
        write_run(result, target)
        if json_:
            payload = result.summary()
            if cs is not None and "design" in payload:  # issue 14
                payload["design"] = result.design_summary(cs)
            payload["output"] = str(target)
            print_json(payload)
        else:
            render_run_summary(result, err_console, cs=cs)
            err_console.print(f"wrote {target}")
        if check_against is not None:
            from camsim.check import check_files, render_report

            kwargs = {k: v for k, v in (("rtol", rtol), ("atol", atol)) if v is not None}
            report = check_files(target, check_against, **kwargs)
            render_report(report, err_console)
            if not report.passed:
                raise typer.Exit(code=1)

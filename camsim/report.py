"""Human-readable summaries of runs (rich tables on stderr)."""

from __future__ import annotations

import math

from rich.console import Console
from rich.table import Table

from camsim.units import LBF  # noqa: E402

_UNITS = {"displacement": ("mm", 1e3), "velocity": ("m/s", 1.0), "acceleration": ("m/s²", 1.0)}


def _lbf(newton: float) -> str:
    return f"{newton:.4g} N ({newton / LBF:.4g} lbf)"


def _fmt(value, fmt: str = ".4g") -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    if isinstance(value, float) and math.isinf(value):
        return "∞"
    return format(value, fmt)


def render_run_summary(result, console: Console) -> None:
    """Print the summary of a :class:`~camsim.simulate.RunResult`."""
    summary = result.summary()
    title = f"{result.machine.name}" + (" — no-impact variant" if result.no_impact else "")
    table = Table(title=title, title_justify="left")
    table.add_column("mass")
    for quantity, (unit, _) in _UNITS.items():
        table.add_column(f"peak |{quantity[:5]}.| [{unit}]", justify="right")
        table.add_column("at t [s]", justify="right")
    for name, entry in summary["masses"].items():
        row = [name]
        for quantity, (_, scale) in _UNITS.items():
            row += [_fmt(entry[quantity]["peak"] * scale), _fmt(entry[quantity]["time"], ".5f")]
        table.add_row(*row)
    console.print(table)
    if summary["peak_transducer_force"]:
        p = summary["peak_transducer_force"]
        console.print(f"peak transducer force: {_lbf(p['value'])} at t = {p['time']:.5f} s")
    if summary["max_cam_contact_force"]:
        hi, lo = summary["max_cam_contact_force"], summary["min_cam_contact_force"]
        console.print(f"cam contact force: max {_lbf(hi['value'])} at t = {hi['time']:.5f} s, min {_lbf(lo['value'])} at t = {lo['time']:.5f} s")
    impacts = result.impacts()
    if impacts:
        t = Table(title="impacts", title_justify="left")
        for col in ("t [s]", "angle [deg]", "element", "masses", "approach [m/s]", "Johnson lower [N]",
                    "Johnson upper [N]", "simulated peak [N]", "duration [ms]"):
            t.add_column(col, justify="right")
        for e in impacts:
            t.add_row(
                f"{e.time:.6f}", _fmt(e.angle_deg, ".2f"), e.element, e.masses, _fmt(e.relative_velocity),
                _fmt(e.johnson_lower), _fmt(e.johnson_upper), _fmt(e.peak_force),
                _fmt(e.contact_duration * 1e3 if not math.isnan(e.contact_duration) else float("nan")),
            )
        console.print(t)
    else:
        console.print("no impacts")
    others = [e for e in result.events if e.kind not in ("impact", "rejoin")]
    if others:
        kinds = {}
        for e in others:
            kinds[e.kind] = kinds.get(e.kind, 0) + 1
        console.print("other events: " + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())))
    residual = result.periodicity_residual
    console.print(
        "periodicity residual (state one revolution apart, relative to peak): "
        + ("not computed" if math.isnan(residual) else f"{residual:.3g}")
    )
    for warning in result.warnings:
        console.print(f"warning: {warning}", style="yellow")

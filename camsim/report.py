"""Human-readable summaries of runs (rich tables on stderr)."""

from __future__ import annotations

import math

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from camsim.display import shown
from camsim.units import LBF

#: SI unit of each mass quantity (printed as camsim.display.shown gives it).
_SI_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}


def _lbf(newton: float, system: str = "si") -> str:
    if system == "us":
        return f"{newton / LBF:.4g} lbf ({newton:.4g} N)"
    return f"{newton:.4g} N ({newton / LBF:.4g} lbf)"


def _fmt(value, fmt: str = ".4g") -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    if isinstance(value, float) and math.isinf(value):
        return "∞"
    return format(value, fmt)


#: Impact rows the human summary prints (a long run has thousands; the file has them all).
MAX_IMPACT_ROWS = 40


def render_run_summary(result, console: Console, system: str = "si") -> None:
    """Print the summary of a :class:`~camsim.simulate.RunResult`.

    Every column header carries the unit its values are printed in (escaped, so rich
    does not take ``[mm]`` for markup); ``system`` is ``"si"`` (mm, m/s, N) or ``"us"``
    (in, in/s, lbf), see :mod:`camsim.display`.
    """
    summary = result.summary()
    title = f"{result.machine.name}" + (" — no-impact variant" if result.no_impact else "")
    table = Table(title=escape(title), title_justify="left")
    table.add_column("mass")
    units = {q: shown(u, system) for q, u in _SI_UNITS.items()}
    for quantity, (unit, _) in units.items():
        table.add_column(escape(f"peak |{quantity[:5]}.| [{unit}]"), justify="right")
        table.add_column(escape("at t [s]"), justify="right")
    for name, entry in summary["masses"].items():
        row = [escape(name)]
        for quantity, (_, scale) in units.items():
            row += [_fmt(entry[quantity]["peak"] * scale), _fmt(entry[quantity]["time"], ".5f")]
        table.add_row(*row)
    console.print(table)
    if summary["peak_transducer_force"]:
        p = summary["peak_transducer_force"]
        console.print(f"peak transducer force: {_lbf(p['value'], system)} at t = {p['time']:.5f} s", markup=False)
    if summary["max_cam_contact_force"]:
        hi, lo = summary["max_cam_contact_force"], summary["min_cam_contact_force"]
        console.print(f"cam contact force: max {_lbf(hi['value'], system)} at t = {hi['time']:.5f} s, min {_lbf(lo['value'], system)} at t = {lo['time']:.5f} s", markup=False)
    impacts = result.impacts()
    if impacts:
        shown_rows = impacts[:MAX_IMPACT_ROWS]
        title = "impacts" if len(impacts) == len(shown_rows) else f"impacts (the first {len(shown_rows)} of {len(impacts)})"
        t = Table(title=escape(title), title_justify="left")
        v_unit, v_scale = shown("m/s", system)
        f_unit, f_scale = shown("N", system)
        for col in ("t [s]", "angle [deg]", "element", "masses", f"approach [{v_unit}]", f"Johnson lower [{f_unit}]",
                    f"Johnson upper [{f_unit}]", f"simulated peak [{f_unit}]", "duration [ms]"):
            t.add_column(escape(col), justify="right")
        for e in shown_rows:
            t.add_row(
                f"{e.time:.6f}", _fmt(e.angle_deg, ".2f"), escape(e.element), escape(e.masses), _fmt(e.relative_velocity * v_scale),
                _fmt(e.johnson_lower * f_scale), _fmt(e.johnson_upper * f_scale), _fmt(e.peak_force * f_scale),
                _fmt(e.contact_duration * 1e3 if not math.isnan(e.contact_duration) else float("nan")),
            )
        console.print(t)
        if len(impacts) > len(shown_rows):
            console.print(f"... {len(impacts) - len(shown_rows)} more impacts: all are in the file's /events table and in --json")
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

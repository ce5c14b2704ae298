"""``camsim impact --materials``: rank material pairs for a machine's Hertz contact.

The option handling and the table of the command; the work is
:func:`camsim.analyses.materials.rank_materials`.
"""

from __future__ import annotations

import math
from pathlib import Path

from rich.markup import escape
from rich.table import Table

from camsim.cli.app import err_console, fail, print_json, warn_notes
from camsim.errors import InputError

__all__ = ["materials_command"]


def _pairs(pair: list[str], candidates: str | None) -> list[tuple[str, str]] | None:
    from camsim.analyses.materials import candidate_pairs

    if pair and candidates:
        raise InputError("give --pair or --candidates, not both")
    if candidates:
        names = [n.strip() for n in candidates.split(",") if n.strip()]
        if not names:
            raise InputError("--candidates: give material names separated by commas, e.g. steel,bronze,acetal")
        return candidate_pairs(names)
    out = []
    for text in pair:
        names = [n.strip() for n in text.split(",")]
        if len(names) != 2 or not all(names):
            raise InputError(f'--pair {text}: give two material names, "body,flat" (e.g. --pair steel,bronze)')
        out.append((names[0], names[1]))
    return out or None


def materials_command(machine: Path | None, contact: str | None, pair: list[str], candidates: str | None,
                      overrides: list[str], workers: int, json_out: bool, units: str = "file") -> None:
    """Load, rank, print (stderr table or JSON on stdout). Raises InputError on bad options."""
    from camsim.analyses.materials import rank_materials
    from camsim.cli.progress import Bar
    from camsim.machine.loader import load_machine

    if machine is None:
        raise InputError("--materials needs --machine FILE: a machine whose contact has law = \"hertz\" "
                         "(e.g. machines/ball-drop-hertz.toml)")
    loaded = load_machine(machine, overrides=overrides)
    warn_notes(loaded)
    from camsim.cli.units_option import machine_units

    shown = machine_units(units, loaded, overrides)  # issue 44: the table in the file's units (or --units)
    (pu, pk), (fu, fk), (vu, vk) = (shown.shown(u) for u in ("Pa", "N", "m/s"))
    pairs = _pairs(pair, candidates)
    finished = [0]

    with Bar("materials", "pairs", quiet=json_out) as bar:
        bar.start(len(pairs) if pairs else 0)

        def progress(done, total):
            finished[0] = done
            bar(done, total)

        try:
            ranking = rank_materials(loaded, contact, pairs, workers=workers, progress=progress)
        except KeyboardInterrupt:  # the workers are stopped (issue 45)
            raise fail(f"interrupted after {finished[0]} finished pairs: no ranking is drawn from part of them; "
                       "nothing was written", 130) from None
    if json_out:
        print_json(ranking.to_dict())
        return
    table = Table(title=escape(f"{ranking.machine}: material pairs for {ranking.contact} ({ranking.geometry}), "
                               "best first"), title_justify="left")
    for col in ("#", "body / flat", f"E* [{pu}]", f"peak force [{fu}]", f"peak pressure [{pu}]", f"first yield [{pu}]",
                "p/p_yield", "rebound", "duration [µs]"):
        table.add_column(escape(col), justify="left" if col == "body / flat" else "right",
                         no_wrap=col == "body / flat")

    def g(value, fmt=".4g", scale=1.0):
        return "–" if value is None or (isinstance(value, float) and not math.isfinite(value)) else format(value * scale, fmt)

    for i, r in enumerate(ranking.rows, 1):
        if r.status != "ok":
            table.add_row(str(i), escape(" / ".join(r.materials)), g(r.e_star, scale=pk), escape(r.status),
                          *["–"] * 5)
            continue
        flag = " yields" if r.yields else ""
        table.add_row(str(i), escape(" / ".join(r.materials)), g(r.e_star, scale=pk), g(r.peak_force, scale=fk),
                      g(r.peak_pressure, scale=pk), g(r.yield_pressure, scale=pk),
                      g(r.pressure_ratio, ".3g") + flag, g(r.rebound, ".3g"), g(r.contact_duration, ".4g", 1e6))
    err_console.print(table)
    for note in _dash_notes(ranking.rows):  # issue 35: every "–" says why
        err_console.print(note, markup=False)
    speeds = [r.approach_velocity for r in ranking.rows if r.status == "ok"]
    if speeds:
        err_console.print(f"approach speed of the largest impact: {min(speeds) * vk:.4g} to {max(speeds) * vk:.4g} {vu}",
                          markup=False)
    err_console.print("ranked: below first yield before yielding, then by peak force, then by rebound "
                      "(docs/impact.md, materials)", markup=False)


def _dash_notes(rows) -> list[str]:
    """Why a cell of the ranking shows "–"."""
    notes = []
    if any(r.status != "ok" for r in rows):
        notes.append("–: that pair did not run to a result (the column after E* says why)")
    ok = [r for r in rows if r.status == "ok"]
    if any(r.yield_pressure is None for r in ok):
        notes.append("first yield –, p/p_yield –: no yield strength in the library for that pair's materials")
    if any(r.contact_duration is None or not math.isfinite(r.contact_duration) for r in ok):
        notes.append("duration –: the contact was still closed when the run ended")
    return notes


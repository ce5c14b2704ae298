"""The report page's friction section (spec §10): each friction pair's nodes, Coulomb and
break-away forces, the energy it dissipates per cycle and its stick and slip counts, from
the run file's ``/summary``.

Every value reaches the page through :class:`camsim.reports.page.Source`; nothing is
recomputed here: the numbers are the run result hub's (:mod:`camsim.run.friction`).
"""

from __future__ import annotations

from camsim.reports.page import Section, Source, esc, table


def friction_section(source: Source, view) -> Section | None:
    """The friction pairs of a run layout (a file root or a comparison's side), None without any."""
    from camsim.run.friction import pairs
    from camsim.run.loads import work_over

    found = pairs(view.machine)
    if not found:
        return None
    over = work_over(view.machine)
    forces = source.column("F_C", "N")
    breakaway = source.column("F_B", "N")
    energy = source.column("dissipated per cycle" if over == "revolution" else "dissipated over the record", "J")
    rows = []
    for e in found:
        programmed = e.programmed  # F_C = μ·N(t), F_B = μ_s·N(t)
        rows.append([esc(e.name), esc(f"{e.lower} / {e.upper}"),
                     esc(f"μ·N ({e.normal_program.kind} program)") if programmed else forces.cell(e.sliding_force),
                     esc("μ_s·N") if programmed else breakaway.cell(e.holding_force),
                     energy.cell(view.summary.get(f"friction_energy:{e.name}"), key=f"friction_energy:{e.name}"),
                     esc(str(view.summary.get(f"sticks:{e.name}", "–"))),
                     esc(str(view.summary.get(f"slips:{e.name}", "–")))])
    label = f"-{view.label}" if view.label else ""
    s = Section(source.name("friction" + label), "Friction")
    caption = ("Friction pairs (type = \"friction\"): energy dissipated ∫f·ḋ dt "
               + ("over the first recorded revolution" if over == "revolution" else "over the recorded time")
               + ", integrated on the solution; sticks and slips: the pair's rows of the event table")
    s.add(table(["pair", "between", forces.header, breakaway.header, energy.header, "sticks", "slips"], rows,
                cls="friction", id=source.name("friction-table" + label),
                numeric=[False, False, True, True, True, True, True], caption=caption))
    return s

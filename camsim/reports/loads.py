"""The report page's process-load section (issue 43): each ``[[load]]``'s mass, program, located
largest and smallest force and work per cycle, from the run file's ``/summary`` and ``extremes``.

Every value reaches the page through :class:`camsim.reports.page.Source` (a unit text never
travels apart from the values converted to it); nothing is recomputed here: the numbers are
the run result hub's (:mod:`camsim.run.loads`).
"""

from __future__ import annotations

from camsim.reports.page import Section, Source, esc, table


def loads_section(source: Source, view) -> Section | None:
    """The process loads of a run layout (a file root or a comparison's side), None without loads."""
    machine = view.machine
    loads = getattr(machine, "loads", ())
    if not loads:
        return None
    from camsim.run.loads import program_text, work_over

    over = work_over(machine)
    located = _located(view.group)
    force_max, force_min = source.column("max", "N"), source.column("min", "N")
    when = source.column("at t", "s")
    work = source.column("work per cycle" if over == "revolution" else "work over the record", "J")
    rows = []
    for load in loads:
        hit = located.get(f"loads/{load.name}/force")
        top = (view.summary.get(f"max_load:{load.name}"), hit["max"].time if hit else float("nan"))
        low = (view.summary.get(f"min_load:{load.name}"), hit["min"].time if hit else float("nan"))
        rows.append([esc(load.name), esc(load.on), esc(program_text(load)),
                     force_max.cell(top[0], key=f"max_load:{load.name}"), when.cell(top[1], ".5f"),
                     force_min.cell(low[0], key=f"min_load:{load.name}"), when.cell(low[1], ".5f"),
                     work.cell(view.summary.get(f"load_work:{load.name}"), key=f"load_work:{load.name}")])
    s = Section(source.name("loads" + (f"-{view.label}" if view.label else "")), "Process loads")
    caption = ("Process loads ([[load]]): force positive along +x; largest and smallest force located on the solution; "
               + ("work per cycle ∫F·ẋ dt over the first recorded revolution" if over == "revolution" else
                  "work ∫F·ẋ dt over the recorded time (no whole revolution)")
               + ", integrated on the solution (positive when the load drives its mass)")
    s.add(table(["load", "on", "program", force_max.header, when.header, force_min.header, when.header, work.header], rows,
                cls="loads", id=source.name("load-table" + (f"-{view.label}" if view.label else "")),
                numeric=[False, False, False, True, True, True, True, True], caption=caption))
    return s


def _located(group) -> dict:
    from camsim.run.result import read_extremes

    return read_extremes(group) or {}

"""The page of an optimisation history (``camsim optimize ... -r HISTORY.h5``).

Registered as the ``optimize`` kind of :data:`camsim.reports.page.BUILDERS`. Every number
comes from the history as :func:`camsim.analyses.optimize.files.write_history` wrote it:
the rows of ``/optimize/candidates`` and ``/optimize/front`` and the attributes of
``/optimize``, whose ``json`` attribute (the ``--json`` payload) says which row is the
optimum, the sense of each objective, the constraint limits and the machine file's values.
A history without that payload still gets a page; the optimum is then picked from the rows
(the best feasible objective, else the least violation) and the file values are left out.
Values are shown in the page's display units through :class:`camsim.reports.page.Source` (the
machine file's by default), speeds in rpm and angles in deg unless the file writes them otherwise.
"""

from __future__ import annotations

import json

import numpy as np

from camsim.reports.figures import PALETTE, finish_legend, xy_figure
from camsim.reports.page import (
    Plot,
    Section,
    Source,
    esc,
    fmt,
    register,
    table,
    verdict,
)
from camsim.reports.sections import (
    _machine,
    header_section,
    machine_section,
)

#: Largest candidates table shown on a page (a DE run has thousands; the file has them all).
MAX_CANDIDATE_ROWS = 2000


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _si(dset, column: str) -> str:
    """The SI unit of a history column (its ``units:<column>`` attribute)."""
    return _text(dset.attrs.get(f"units:{column}", ""))


def _column(source: Source, dset, column: str, name: str = ""):
    """A history column in the page's display units (speeds in rpm, durations in deg, like the sweep page)."""
    return source.column(name or column, _si(dset, column))


def _best_row(rows: dict, payload: dict, objectives: list[str]) -> int:
    """Row of the optimum: the payload's candidate index, else chosen from the rows as the solver does."""
    cand = np.asarray(rows["candidate"], dtype=float)
    index = (payload.get("optimum") or {}).get("index")
    if index is not None and np.any(cand == index):
        return int(np.flatnonzero(cand == index)[0])
    feasible = np.asarray(rows.get("feasible", np.zeros(cand.size, bool)), dtype=bool)
    if objectives and feasible.any():
        sense = (payload.get("objectives") or [{}])[0].get("sense", "min")
        f = np.asarray(rows[objectives[0]], dtype=float) * (1.0 if sense == "min" else -1.0)
        return int(np.nanargmin(np.where(feasible & np.isfinite(f), f, np.inf)))
    return int(np.nanargmin(np.nan_to_num(np.asarray(rows["violation"], dtype=float), nan=np.inf)))


def _at(rows: dict, column: str, i: int) -> float:
    """Row ``i`` of a numeric column, NaN when the history has no such column."""
    return float(rows[column][i]) if column in rows else float("nan")


@register("optimize")
def optimize_sections(source: Source) -> list[Section]:
    """Sections of an optimisation history: header, verdicts, convergence, optimum, constraints, front, candidates, machine.

    Parameters
    ----------
    source : Source
        The history, open read-only (``source.h5``).

    Returns
    -------
    list of Section

    Raises
    ------
    ResultFileError
        The file says it is an optimisation but has no ``/optimize/candidates`` (nothing was
        evaluated, or the job never finished writing the history).
    """
    from camsim.errors import ResultFileError
    from camsim.io.hdf5 import read_table
    from camsim.io.results import attr_text

    f = source.h5
    if "optimize" not in f or "candidates" not in f["optimize"]:
        raise ResultFileError(f"{source.path}: optimize: no /optimize/candidates (no candidate evaluated, or not a finished history)")
    machine = _machine(f, source.path)
    g = f["optimize"]
    payload = json.loads(attr_text(g, "json", "{}") or "{}")
    dset = g["candidates"]
    rows = read_table(dset)
    names = list(dset.dtype.names)
    params = [c for c in names if c.startswith("param:")]
    objectives = [c for c in names if c.startswith("objective:")]
    best = _best_row(rows, payload, objectives)
    status = attr_text(g, "status", payload.get("status", "?"))
    feasible = np.asarray(rows["feasible"], dtype=bool) if "feasible" in rows else np.zeros(len(rows["candidate"]), bool)
    speeds = [s for s in payload.get("speeds_rpm") or [] if s is not None]
    extra = [("method", f"<span data-key=method>{esc(attr_text(g, 'method', '?'))}</span>"),
             ("status", f"<span data-key=status>{esc(status)}</span>"),
             ("seed", esc(_text(g.attrs.get("seed", "–")))), ("budget", esc(_text(g.attrs.get("budget", "–")))),
             ("evaluations", esc(_text(g.attrs.get("evaluations", len(feasible))))), ("runs", esc(_text(g.attrs.get("runs", "–")))),
             ("speeds", ", ".join(source.number(s * 2.0 * np.pi / 60.0, "rad/s") for s in speeds)
              + f" {source.show(1.0, 'rad/s').unit}" if speeds else "the machine file's speed")]
    out = [header_section(source, machine.name, extra)]
    out.append(_verdicts(source, status, rows, best, payload, objectives, dset))
    out.append(_convergence(source, rows, feasible, best, payload, objectives, dset))
    out.append(_optimum(source, rows, best, payload, params, dset))
    cons = [c for c in names if c.startswith("constraint:")]
    if cons:
        out.append(_constraints(source, rows, best, payload, cons, dset))
    if "front" in g:
        out.append(_front(source, g["front"], rows, feasible, objectives, dset))
    out.append(_candidates(source, rows, names, best, dset))
    out.append(machine_section(source, attr_text(f, "machine_toml")))
    return out


def _verdicts(source, status, rows, best, payload, objectives, dset) -> Section:
    s = Section(source.name("verdicts"), "Verdicts")
    k = int(rows["candidate"][best])
    if status == "optimal":
        tiles = [verdict("Feasible optimum", "ok", f"Found: candidate {source.number(k, '', key='optimum')} meets every constraint.", "optimum")]
    else:
        # The solver's fallback (run.py): the least-violating candidate stands in for the optimum.
        tiles = [verdict("Feasible optimum", "fail", f"No feasible candidate: none meets the constraints ({esc(status)}). "
                         f"The least-violating one, candidate {source.number(k, '', key='optimum')} (violation "
                         f"{source.number(rows['violation'][best], '')}), is shown as the optimum below.", "optimum")]
    info = payload.get("objectives") or [{"expr": c[10:]} for c in objectives]
    where = "at the optimum" if status == "optimal" else "at the least-violating candidate"
    # The payload's reference candidate is the file's values, or START when --var gave one.
    start = (payload.get("initial") or {}).get("values") or {}
    file_values = {v["key"]: v.get("initial") for v in payload.get("variables") or []}
    ref_name = "the machine file's values" if all(start.get(k) == v for k, v in file_values.items()) else "the START values of --var"
    for c, o in zip(objectives, info):
        value = float(rows[c][best])
        detail = (f"{esc(o.get('sense', ''))} <code>{esc(o['expr'])}</code>: {source.quantity(value, _si(dset, c), key='objective')} {where}")
        if o.get("initial") is not None:
            ref = float(o["initial"])
            change = 100.0 * (value - ref) / abs(ref) if ref else float("nan")
            detail += (f" against {source.quantity(ref, _si(dset, c))} with {ref_name} "
                       f"(change <span class=derived data-of='change'>{fmt(change, '+.3g')}</span> %).")
        else:
            detail += "; the machine file's values were not evaluated (outside the bounds, or not in this history)."
        tiles.append(verdict("Objective", "info", detail, "objective"))
    if payload.get("active"):
        tiles.append(verdict("Active constraints", "info", ", ".join(f"<code>{esc(a)}</code>" for a in payload["active"])
                             + " at their limit (within 0.1 %).", "active"))
    for note in payload.get("notes") or []:
        tiles.append(verdict("Note", "warn", esc(note), "note"))
    return s.add('<div class="verdicts">' + "".join(tiles) + "</div>")


def _convergence(source, rows, feasible, best, payload, objectives, dset) -> Section:
    s = Section(source.name("convergence"), "Convergence")
    senses = [o.get("sense", "min") for o in payload.get("objectives") or []] + ["min"] * len(objectives)
    order = np.asarray(rows["candidate"], dtype=float)
    for j, c in enumerate(objectives):
        shown = source.show(np.asarray(rows[c], dtype=float), _si(dset, c))
        y, unit = shown.values, shown.unit or "-"
        # Best so far among the feasible candidates only: an infeasible one is no answer yet.
        ranked = np.where(feasible & np.isfinite(y), y if senses[j] == "min" else -y, np.inf)
        run = np.minimum.accumulate(ranked) if ranked.size else ranked
        best_so_far = np.where(np.isfinite(run), run if senses[j] == "min" else -run, np.nan)
        name = source.name("optimize-convergence" + (f"-{j + 1}" if j else ""))
        p = xy_figure(name, f"{c[10:]} per candidate ({senses[j]})", "candidate (evaluation order) [-]", f"{c[10:]} [{unit}]", [], height=300)
        # Marker shape and colour both tell feasibility apart (greyscale printouts, colour vision).
        p.scatter(order[feasible], y[feasible], marker="circle", size=7, fill_color=PALETTE[1], line_color=PALETTE[1], legend_label="feasible")
        p.scatter(order[~feasible], y[~feasible], marker="x", size=8, line_color=PALETTE[2], line_width=2, legend_label="infeasible")
        p.step(order, best_so_far, mode="after", line_color=PALETTE[0], line_width=2, legend_label="best feasible so far")
        p.scatter([order[best]], [y[best]], marker="star", size=16, fill_color=PALETTE[5], line_color=PALETTE[0], legend_label="optimum")
        finish_legend(p)
        s.add(Plot(p, f"{c[10:]} [{unit}] of each candidate in evaluation order: feasible as blue circles, infeasible as "
                      "vermillion crosses, the best feasible value so far as a black step line, the optimum as a star."))
    if not objectives:
        s.add("<p>No objective column in the history.</p>")
    return s


def _optimum(source, rows, best, payload, params, dset) -> Section:
    s = Section(source.name("optimum"), "Parameters of the optimum")
    initial = {v["key"]: v.get("initial") for v in payload.get("variables") or []}
    absorb = payload.get("absorb") or {}
    if absorb.get("key"):
        initial[absorb["key"]] = absorb.get("initial")
    body = []
    for c in params:
        column = _column(source, dset, c)
        key = c[6:]
        ref = initial.get(key)
        body.append([f"<span data-key='{esc(key)}'>{esc(key)}</span>" + (" (absorbing)" if key == absorb.get("key") else ""),
                     esc(source.show(1.0, _si(dset, c)).unit or "-"), column.cell(rows[c][best]),
                     "–" if ref is None else column.cell(ref)])
    return s.add(table(["key", "unit", "optimum", "file value"], body, id=source.name("optimum-table"),
                       numeric=[False, False, True, True],
                       caption=f"Values of candidate {int(rows['candidate'][best])} in the unit of column 2; "
                               "file value: the machine file's"))


def _constraints(source, rows, best, payload, cons, dset) -> Section:
    s = Section(source.name("constraints"), "Constraints at the optimum")
    limits = {c["expr"]: c for c in payload.get("constraints") or []}
    robust = any(f"probability:{c[11:]}" in rows for c in cons)
    body = []
    for c in cons:
        label = c[11:]
        # Columns are constraint:<expr>@<speed>rpm (several speeds) or constraint:<expr>.
        expr, _, speed = label.rpartition("@") if label.endswith("rpm") and "@" in label else (label, "", "")
        column = _column(source, dset, c)
        lim = limits.get(expr, {})
        margin = _at(rows, f"g:{label}", best)
        speed_cell = source.number(float(speed[:-3]) * 2.0 * np.pi / 60.0, "rad/s") if speed else "–"
        row = [f"<code>{esc(expr)}</code>", speed_cell, column.cell(rows[c][best]),
               f"{esc(lim.get('op', ''))} {column.cell(float(lim['limit']))}" if "limit" in lim else "–",
               esc(source.show(1.0, _si(dset, c)).unit or "-"),
               "–" if not np.isfinite(margin) else ("yes" if margin <= 0 else "no")]
        if robust:
            row.insert(5, source.number(_at(rows, f"probability:{label}", best), ""))
        body.append(row)
    headers = ["constraint", source.column("speed", "rad/s").header, "value", "limit", "unit"] + \
        (["probability [-]"] if robust else []) + ["satisfied"]
    return s.add(table(headers, body, id=source.name("constraints-table"), numeric=[False, True, True, True, False] + [True] * robust + [False],
                       caption="Value at the optimum (with --robust the mean) and limit in the unit of column 5; speed –: the machine file's; "
                               "satisfied: the solver's scaled margin g ≤ 0"))


def _front(source, front, rows, feasible, objectives, dset) -> Section:
    from camsim.io.hdf5 import read_table

    s = Section(source.name("front"), "Pareto front")
    pts = read_table(front)
    objs = [c for c in front.dtype.names if c.startswith("objective:")]
    if len(objs) < 2 or not len(pts[objs[0]]):
        return s.add("<p>The front has fewer than two objectives or no point.</p>")
    xs_, ys_ = (source.show(np.asarray(pts[o], dtype=float), _si(front, o)) for o in objs[:2])
    (x, xu), (y, yu) = (xs_.values, xs_.unit or "-"), (ys_.values, ys_.unit or "-")
    order = np.argsort(x)
    p = xy_figure(source.name("optimize-front"), "Pareto front", f"{objs[0][10:]} [{xu}]", f"{objs[1][10:]} [{yu}]",
                  [("front", x[order], y[order])], markers=True, height=340)
    if objs[0] in rows and objs[1] in rows:
        # The other feasible candidates behind the front show what it dominates.
        p.scatter(source.show(np.asarray(rows[objs[0]], dtype=float)[feasible], _si(front, objs[0])).values,
                  source.show(np.asarray(rows[objs[1]], dtype=float)[feasible], _si(front, objs[1])).values,
                  marker="circle", size=5, fill_alpha=0.0, line_color="#999999", legend_label="feasible candidates")
    s.add(Plot(p, f"Pareto front: {objs[1][10:]} [{yu}] against {objs[0][10:]} [{xu}] (line with markers), "
                  "every feasible candidate as grey rings."))
    cols = list(front.dtype.names)
    columns = [_column(source, front, c) for c in cols]
    body = [[col.cell(pts[c][i]) for c, col in zip(cols, columns)] for i in order]
    return s.add(table([col.header for col in columns], body, id=source.name("front-table"),
                       numeric=[True] * len(cols), caption="Points of the front, by the first objective"))


def _candidates(source, rows, names, best, dset) -> Section:
    s = Section(source.name("candidates"), "Candidates")
    columns = [_column(source, dset, c) for c in names]
    n = len(rows[names[0]])
    body = [[col.cell(rows[c][i]) for c, col in zip(names, columns)] for i in range(min(n, MAX_CANDIDATE_ROWS))]
    headers = [c if c in ("candidate", "feasible", "status") or not _si(dset, c) else col.header for c, col in zip(names, columns)]
    note = "" if n <= MAX_CANDIDATE_ROWS else f"<p class=note>The first {MAX_CANDIDATE_ROWS} of {n} candidates; the file has them all.</p>"
    return s.add(table(headers, body, cls="candidates", id=source.name("candidates-table"),
                       numeric=[c not in ("status", "feasible") for c in names],
                       caption=f"Every evaluated candidate in order (the optimum: candidate {int(rows['candidate'][best])}); "
                               "g: the solver's scaled constraint value, ≤ 0 satisfied") + note)

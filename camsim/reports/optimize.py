"""The page of an optimisation history (``camsim optimize ... -r HISTORY.h5``).

Registered as the ``optimize`` kind of :data:`camsim.reports.page.BUILDERS`. Every number
comes from the history as :func:`camsim.analyses.optimize.files.write_history` wrote it:
the rows of ``/optimize/candidates`` and ``/optimize/front`` and the attributes of
``/optimize``, whose ``json`` attribute (the ``--json`` payload) says which row is the
optimum, the sense of each objective, the constraint limits and the machine file's values.
A history without that payload still gets a page; the optimum is then picked from the rows
(the best feasible objective, else the least violation) and the file values are left out.
Values are shown in the page's display units (:meth:`camsim.reports.page.Source.unit`, the
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


def _unit(source: Source, dset, column: str) -> tuple[str, float]:
    """(unit shown, factor from SI) of a history column in the page's display units (speeds in rpm,
    durations in deg, like the sweep page)."""
    return source.unit(_text(dset.attrs.get(f"units:{column}", "")))


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


def _cell(value, scale: float = 1.0, spec: str = ".4g") -> str:
    """A table cell: text as text, booleans as yes/no, numbers scaled to the shown unit."""
    if isinstance(value, (str, bytes)):
        return esc(_text(value))
    if isinstance(value, (bool, np.bool_)):
        return fmt(bool(value))
    return fmt(float(value) * scale, spec)


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
             ("speeds", ", ".join(fmt(s) for s in speeds) + " rpm" if speeds else "the machine file's speed")]
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
        tiles = [verdict("Feasible optimum", "ok", f"Found: candidate <span class=value data-key=optimum>{k}</span> meets every constraint.", "optimum")]
    else:
        # The solver's fallback (run.py): the least-violating candidate stands in for the optimum.
        tiles = [verdict("Feasible optimum", "fail", f"No feasible candidate: none meets the constraints ({esc(status)}). "
                         f"The least-violating one, candidate <span class=value data-key=optimum>{k}</span> (violation "
                         f"{fmt(rows['violation'][best])}), is shown as the optimum below.", "optimum")]
    info = payload.get("objectives") or [{"expr": c[10:]} for c in objectives]
    where = "at the optimum" if status == "optimal" else "at the least-violating candidate"
    # The payload's reference candidate is the file's values, or START when --var gave one.
    start = (payload.get("initial") or {}).get("values") or {}
    file_values = {v["key"]: v.get("initial") for v in payload.get("variables") or []}
    ref_name = "the machine file's values" if all(start.get(k) == v for k, v in file_values.items()) else "the START values of --var"
    for c, o in zip(objectives, info):
        unit, scale = _unit(source, dset, c)
        value = float(rows[c][best]) * scale
        detail = (f"{esc(o.get('sense', ''))} <code>{esc(o['expr'])}</code>: <span class=value data-key=objective>{fmt(value)}</span> {esc(unit)} {where}")
        if o.get("initial") is not None:
            ref = float(o["initial"]) * scale
            change = 100.0 * (value - ref) / abs(ref) if ref else float("nan")
            detail += f" against {fmt(ref)} {esc(unit)} with {ref_name} (change {fmt(change, '+.3g')} %)."
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
        unit, scale = _unit(source, dset, c)
        y = np.asarray(rows[c], dtype=float) * scale
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
        unit, scale = _unit(source, dset, c)
        key = c[6:]
        ref = initial.get(key)
        body.append([f"<span data-key='{esc(key)}'>{esc(key)}</span>" + (" (absorbing)" if key == absorb.get("key") else ""),
                     esc(unit), _cell(rows[c][best], scale), "–" if ref is None else _cell(ref, scale)])
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
        unit, scale = _unit(source, dset, c)
        lim = limits.get(expr, {})
        margin = _at(rows, f"g:{label}", best)
        row = [f"<code>{esc(expr)}</code>", esc(speed[:-3]) if speed else "–", _cell(rows[c][best], scale),
               f"{esc(lim.get('op', ''))} {fmt(float(lim['limit']) * scale)}" if "limit" in lim else "–", esc(unit),
               "–" if not np.isfinite(margin) else ("yes" if margin <= 0 else "no")]
        if robust:
            row.insert(5, fmt(_at(rows, f"probability:{label}", best)))
        body.append(row)
    headers = ["constraint", "speed [rpm]", "value", "limit", "unit"] + (["probability [-]"] if robust else []) + ["satisfied"]
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
    (xu, xs), (yu, ys) = _unit(source, front, objs[0]), _unit(source, front, objs[1])
    x, y = np.asarray(pts[objs[0]], dtype=float) * xs, np.asarray(pts[objs[1]], dtype=float) * ys
    order = np.argsort(x)
    p = xy_figure(source.name("optimize-front"), "Pareto front", f"{objs[0][10:]} [{xu}]", f"{objs[1][10:]} [{yu}]",
                  [("front", x[order], y[order])], markers=True, height=340)
    if objs[0] in rows and objs[1] in rows:
        # The other feasible candidates behind the front show what it dominates.
        p.scatter(np.asarray(rows[objs[0]], dtype=float)[feasible] * xs, np.asarray(rows[objs[1]], dtype=float)[feasible] * ys,
                  marker="circle", size=5, fill_alpha=0.0, line_color="#999999", legend_label="feasible candidates")
    s.add(Plot(p, f"Pareto front: {objs[1][10:]} [{yu}] against {objs[0][10:]} [{xu}] (line with markers), "
                  "every feasible candidate as grey rings."))
    cols = list(front.dtype.names)
    units = [_unit(source, front, c) for c in cols]
    body = [[_cell(pts[c][i], sc) for c, (_, sc) in zip(cols, units)] for i in order]
    return s.add(table([f"{c} [{u}]" for c, (u, _) in zip(cols, units)], body, id=source.name("front-table"),
                       numeric=[True] * len(cols), caption="Points of the front, by the first objective"))


def _candidates(source, rows, names, best, dset) -> Section:
    s = Section(source.name("candidates"), "Candidates")
    units = [_unit(source, dset, c) for c in names]
    n = len(rows[names[0]])
    body = [[_cell(rows[c][i], sc) for c, (_, sc) in zip(names, units)] for i in range(min(n, MAX_CANDIDATE_ROWS))]
    headers = [c if c in ("candidate", "feasible", "status") or u == "-" else f"{c} [{u}]" for c, (u, _) in zip(names, units)]
    note = "" if n <= MAX_CANDIDATE_ROWS else f"<p class=note>The first {MAX_CANDIDATE_ROWS} of {n} candidates; the file has them all.</p>"
    return s.add(table(headers, body, cls="candidates", id=source.name("candidates-table"),
                       numeric=[c not in ("status", "feasible") for c in names],
                       caption=f"Every evaluated candidate in order (the optimum: candidate {int(rows['candidate'][best])}); "
                               "g: the solver's scaled constraint value, ≤ 0 satisfied") + note)

"""Section builders of the analyses' result kinds: sweep, study and fit pages.

Registered in :data:`camsim.reports.page.BUILDERS` like the run and comparison builders of
:mod:`camsim.reports.sections`, whose shared parts (header, machine section) they use.
Every value is shown in the page's display units through :class:`camsim.reports.page.Source`
(``number``/``quantity``/``column``/``show``): the units of the result's machine file by
default, the command line's first.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from camsim.reports.figures import PALETTE, bokeh, finish_legend, trace_figure, xy_figure
from camsim.reports.page import Plot, Section, Source, esc, fmt, register, table, verdict
from camsim.reports.sections import _machine, header_section, machine_section


# ---------------------------------------------------------------------- sweep
def _column_unit(dset, name: str) -> str:
    from camsim.io.results import attr_text

    return attr_text(dset, f"units:{name}")




def _quantity_groups(columns: list[str]) -> dict[str, list[str]]:
    """Output columns grouped by quantity: ``peak_acceleration:M1``.. under ``peak_acceleration``."""
    groups: dict[str, list[str]] = {}
    for c in columns:
        groups.setdefault(c.split(":")[0], []).append(c)
    return groups


@register("sweep")
def sweep_sections(source: Source) -> list[Section]:
    from camsim.io.hdf5 import read_table
    from camsim.io.results import attr_text

    _, models = bokeh()
    f = source.h5
    machine = _machine(f, source.path)
    g = f["sweep"]
    dset = g["summary"]
    rows = read_table(dset)
    names = list(dset.dtype.names)
    varied = [str(k.decode() if isinstance(k, bytes) else k) for k in g.attrs.get("varied_keys", [])]
    params = [f"param:{k}" for k in varied if f"param:{k}" in names]
    outputs = [c for c in names if not c.startswith("param:") and c != "status" and np.asarray(rows[c]).dtype.kind in "fiub"]
    onset, first = float(dset.attrs.get("jump_onset_rpm", np.nan)), float(dset.attrs.get("first_jump_rpm", np.nan))
    extra = [("varied", esc(", ".join(varied))), ("points", str(len(rows[names[0]]) if names else 0)),
             ("interrupted", "yes" if bool(g.attrs.get("interrupted", False)) else "no")]
    out = [header_section(source, machine.name, extra)]
    s = Section(source.name("verdicts"), "Verdicts")
    rad_s = 2.0 * math.pi / 60.0  # the attributes are in rpm
    if np.isfinite(first):
        detail = (f"Checked: the cam contact force against <span class=rule>0</span> at every point. The follower first "
                  f"leaves the cam at "
                  f"{source.quantity(first * rad_s, 'rad/s', key='first_jump_rpm')}"
                  + (f"; jump onset (bracketed) {source.quantity(onset * rad_s, 'rad/s', key='jump_onset_rpm')}."
                     if np.isfinite(onset) else "."))
        tile = verdict("Follower jump", "fail", detail, "jump")
    else:
        tile = verdict("Follower jump", "ok", "Checked: the cam contact force against <span class=rule>0</span> at every "
                       "point. No point of the "
                       "sweep jumps.", "jump")
    s.add('<div class="verdicts">' + tile + "</div>")
    out.append(s)
    # Plots: every output column against the first varied key (series: the other keys' values).
    p_sec = Section(source.name("columns"), "Every column against the varied key")
    if params:
        x_name = params[0]
        x_shown = source.show(np.asarray(rows[x_name], dtype=float), _column_unit(dset, x_name))
        x, x_unit = x_shown.values, x_shown.unit
        others = params[1:]
        combos = sorted({tuple(float(rows[o][i]) for o in others) for i in range(x.size)}) if others else [()]
        x_range = None
        for base, cols in _quantity_groups(outputs).items():
            unit = source.show(1.0, _column_unit(dset, cols[0])).unit or "-"
            series = []
            for c in cols:
                y = source.show(np.asarray(rows[c], dtype=float), _column_unit(dset, c)).values
                for combo in combos[: len(PALETTE)]:
                    mask = np.ones(x.size, bool)
                    for o, v in zip(others, combo):
                        mask &= np.asarray(rows[o], dtype=float) == v
                    order = np.argsort(x[mask])
                    label = (c.split(":")[1] if ":" in c else base) + ("".join(f", {o[6:]}={v:.4g}" for o, v in zip(others, combo)))
                    series.append((label, x[mask][order], y[mask][order]))
            p = xy_figure(source.name(f"sweep-{base}"), base.replace("_", " "), f"{x_name[6:]} [{x_unit}]", f"{base} [{unit}]",
                          series, markers=True, height=260, x_range=x_range)
            x_range = p.x_range
            if x_name == "param:cam.speed":
                for value, label in ((source.show(onset * rad_s, "rad/s").values, "jump onset"),
                                     (source.show(first * rad_s, "rad/s").values, "first jump")):
                    if np.isfinite(value):
                        p.add_layout(models.Span(location=value, dimension="height", line_color=PALETTE[2], line_dash="dashed", line_width=2))
                        p.add_layout(models.Label(x=value, y=5, y_units="screen", text=label, text_font_size="9pt", x_offset=3))
            p_sec.add(Plot(p, f"{base} [{unit}] against {x_name[6:]} [{x_unit}]" + (", jump onset marked" if np.isfinite(first) else "") + "."))
    out.append(p_sec)
    t_sec = Section(source.name("table"), "Sweep table")
    columns = [source.column(c, _column_unit(dset, c)) for c in names]
    headers = [col.header if c != "status" else c for c, col in zip(names, columns)]
    body = []
    for i in range(len(rows[names[0]])):
        row = []
        for c, col in zip(names, columns):
            v = rows[c][i]
            row.append(col.cell(bool(v) if np.asarray(v).dtype.kind == "b" else v))
        body.append(row)
    t_sec.add(table(headers, body, cls="sweep", id=source.name("sweep-table"), numeric=[c != "status" for c in names],
                    caption="One row per point of the sweep"))
    out.append(t_sec)
    out.append(machine_section(source, attr_text(f, "machine_toml")))
    return out


# ---------------------------------------------------------------------- study
@register("study")
def study_sections(source: Source) -> list[Section]:
    from camsim.io.hdf5 import read_table
    from camsim.io.results import attr_text
    from camsim.analyses.study.statistics import parse_limit, varies

    f = source.h5
    machine = _machine(f, source.path)
    g = f["study"]
    payload = json.loads(attr_text(g, "summary_json", "{}"))
    dset = g["rows"]
    rows = read_table(dset)
    units = {c: _column_unit(dset, c) for c in dset.dtype.names}
    texts = lambda key: [str(v.decode() if isinstance(v, bytes) else v) for v in g.attrs.get(key, []) if str(v.decode() if isinstance(v, bytes) else v)]  # noqa: E731
    extra = [("distributions", "<br>".join(esc(d) for d in texts("dist"))), ("method", esc(attr_text(g, "method"))),
             ("samples / runs", f"{source.number(payload.get('n_samples'), '')} / {source.number(payload.get('n_runs'), '')}"),
             ("seed", esc(payload.get("seed"))), ("failed runs", source.number(payload.get("failed", 0), ""))]
    out = [header_section(source, machine.name, extra)]
    # Probabilities of crossing the limits, with their Clopper–Pearson intervals.
    s = Section(source.name("limits"), "Limits: probability of crossing")
    lim_rows = []
    for lim in payload.get("limits", []):
        lo, hi = lim["ci95"]
        pct = lambda v: source.number(v, "", as_unit="%")  # noqa: E731
        lim_rows.append([esc(lim["expr"]), source.number(lim["crossed"], ""), source.number(lim["n"], ""), pct(lim["probability"]),
                         f"{pct(lo)} to {pct(hi)}", source.number(lim["per_million"], "")])
    s.add(table(["limit", "runs crossing [-]", "runs [-]", "probability [%]", "95 % interval [%]", "per million machines [-]"],
                lim_rows, id=source.name("limits-table"), numeric=[False, True, True, True, False, True],
                caption="Probability of crossing each limit (Clopper–Pearson 95 % interval)") if lim_rows else "<p>No --limit given.</p>")
    out.append(s)
    # Statistics of every output.
    st = Section(source.name("statistics"), "Statistics of the outputs")
    stat_rows = []
    for name, o in payload.get("outputs", {}).items():
        si_unit = units.get(name, "")
        ci = o.get("ci95", {}).get("mean", [None, None])
        p = o.get("percentiles", {})
        sc = lambda v, si_unit=si_unit: "–" if v is None else source.number(v, si_unit)  # noqa: E731
        stat_rows.append([esc(name), esc(source.show(1.0, si_unit).unit or "-"), sc(o.get("mean")), f"{sc(ci[0])} to {sc(ci[1])}",
                          sc(o.get("std")), sc(p.get("5")), sc(p.get("50")), sc(p.get("95")), sc(o.get("min")), sc(o.get("max"))])
    st.add(table(["output", "unit", "mean", "mean 95 % interval", "std", "p5", "p50", "p95", "min", "max"], stat_rows,
                 id=source.name("statistics-table"), numeric=[False, False] + [True] * 8,
                 caption="Each value in the output's unit (column 2); intervals by bootstrap"))
    out.append(st)
    # Histograms with the limits drawn.
    from camsim.reports.figures import bar_figure, histogram_figure

    h = Section(source.name("histograms"), "Histograms with limits")
    limits = []
    for text in texts("limit"):
        try:
            limits.append(parse_limit(text, units))
        except Exception:  # noqa: BLE001 - a limit the page cannot draw is still in the table
            continue
    # Issue 44: over the runs the statistics use (blocks A and B of Saltelli's design with
    # --sensitivity, the runs that did not fail), and none for an output that does not vary.
    used = _statistics_rows(rows)
    for name, o in payload.get("outputs", {}).items():
        values = np.asarray(rows[name], dtype=float)[used]
        if not varies(values):
            continue
        shown = source.show(values, units.get(name, ""))
        lims = [(lim.expr, source.show(lim.threshold, units.get(name, "")).values) for lim in limits if lim.quantity == name]
        p = histogram_figure(source.name(f"hist-{name.replace(':', '-')}"), name, shown.values, shown.label(name), lims)
        h.add(Plot(p, f"Histogram of {shown.label(name)} over the runs" + (f", limits {', '.join(e for e, _ in lims)} drawn" if lims else "") + "."))
    out.append(h)
    sens = {k: v for k, v in (payload.get("sensitivity") or {}).items() if v}
    if sens:
        b = Section(source.name("sobol"), "Sobol' indices: which tolerance to tighten")
        keys = sorted({k for v in sens.values() for k in v})
        groups = {k: [sens[o].get(k, {}).get("total", np.nan) for o in sens] for k in keys}
        errs = {k: ([sens[o].get(k, {}).get("total_ci95", [np.nan, np.nan])[0] for o in sens],
                    [sens[o].get(k, {}).get("total_ci95", [np.nan, np.nan])[1] for o in sens]) for k in keys}
        p = bar_figure(source.name("sobol-total"), "Total Sobol' index of each tolerance per output", list(sens), groups,
                       "total Sobol' index [-]", errs)
        b.add(Plot(p, "Bars: total Sobol' index [-] of each toleranced key for each output, with 95 % intervals."))
        rank = payload.get("ranking") or []
        if rank:
            b.add(table(["key", "total index [-]"], [[esc(r["key"]), source.number(r["total"], "")] for r in rank], id=source.name("ranking-table"),
                        numeric=[False, True], caption="Ranking (largest total index first)"))
        out.append(b)
    out.append(machine_section(source, attr_text(f, "machine_toml")))
    return out


# ---------------------------------------------------------------------- fit
@register("fit")
def fit_sections(source: Source) -> list[Section]:
    """A fit has no result file: ``source.obj`` is ``(FitResult, machine path, machine text)``."""
    from camsim.reports.figures import image_figure

    _, models = bokeh()
    result, machine_path, machine_text = source.obj
    if source.units is None:  # the machine file's own units (a page built from Python)
        from camsim.display import written_units

        source.units = written_units(machine_text)
    extra = [("machine file", f"<code>{esc(machine_path)}</code>"), ("simulations", source.number(result.n_evaluations, "")),
             ("cost", source.number(result.cost, "", ".6g")), ("solver", esc(result.message))]
    out = [header_section(source, _machine_name(machine_text, machine_path), extra)]
    v = Section(source.name("verdicts"), "Verdicts")
    tiles = [verdict("Convergence", "ok" if result.converged else "fail",
                     f"{'Converged' if result.converged else 'Not converged'}; residual variance "
                     f"{source.number(result.residual_variance, '')} ({source.number(result.dof, '')} degrees of freedom); "
                     f"Jacobian condition {source.number(result.condition, '', '.3g')}.", "converged")]
    for w in result.warnings:
        tiles.append(verdict("Warning", "warn", esc(w), "warning"))
    v.add('<div class="verdicts">' + "".join(tiles) + "</div>")
    out.append(v)
    p = Section(source.name("parameters"), "Fitted parameters")
    rows = []
    for i, key in enumerate(result.keys):
        lo, hi = result.ci95[i]
        u = result.units[i] or ""
        rows.append([esc(key), esc(source.show(1.0, u).unit or "-"), source.number(result.file_values[i], u, ".6g"),
                     source.number(result.initial[i], u, ".6g"), source.number(result.values[i], u, ".6g"),
                     source.number(result.stderr[i], u, ".3g"),
                     f"{source.number(lo, u, '.6g')} to {source.number(hi, u, '.6g')}" if np.isfinite(lo) and np.isfinite(hi)
                     else "not determined"])
    p.add(table(["parameter", "unit", "file value", "start", "fitted", "std. error", "95 % interval"], rows,
                id=source.name("parameter-table"), numeric=[False, False, True, True, True, True, False],
                caption="Values in the unit of column 2"))
    if len(result.keys) > 1:
        fig = image_figure(source.name("correlation"), "Correlation of the fitted parameters", list(result.keys), np.asarray(result.correlation))
        p.add(Plot(fig, "Correlation matrix of the fitted parameters [-], values written in the cells."))
    out.append(p)
    c = Section(source.name("channels"), "Measured against fitted")
    x_range = None
    for k, (path, t, measured, fitted) in enumerate(result.channels):
        t_unit = _trace_unit(path)
        unit = source.show(1.0, t_unit).unit or "-"
        fig = trace_figure(source.name(f"fit-{k}"), f"{path}: measured and fitted", f"{path.split('/')[-1]} [{unit}]",
                           [], x_range=x_range)
        x_range = fig.x_range
        # Measured first, the fitted line over it (drawn in the order added).
        fig.scatter(np.asarray(t, dtype=float), source.show(np.asarray(measured, dtype=float), t_unit).values, size=3, marker="circle",
                    fill_alpha=0.0, line_color=PALETTE[5], line_alpha=0.7, legend_label="measured")
        fig.line(np.asarray(t, dtype=float), source.show(np.asarray(fitted, dtype=float), t_unit).values, line_color=PALETTE[0], line_width=1.6,
                 legend_label="fitted")
        finish_legend(fig)
        res = trace_figure(source.name(f"fit-{k}-residual"), f"{path}: residual (fitted − measured)", f"residual [{unit}]",
                           [("residual", t, source.show(np.asarray(fitted) - np.asarray(measured), t_unit).values)], x_range=x_range)
        res.height = 160
        rms = source.text(result.rms_residual.get(path, float("nan")), t_unit)
        c.add(Plot(fig, f"{path} [{unit}] against time [s]: measured (circles) and fitted (line)."),
              Plot(res, f"Residual of {path} [{unit}] against time [s]; RMS {rms}."))
    if not result.channels:
        c.add("<p>No measured trace (targets only).</p>")
    if result.rms_residual:
        body = []
        for name, r in result.rms_residual.items():
            u = _trace_unit(name) if "/" in name else _scalar_unit(name)
            body.append([esc(name), source.number(r, u), source.number(result.sigma.get(name, float("nan")), u),
                         esc(source.show(1.0, u).unit or "-")])
        c.add(table(["channel or target", "RMS residual", "noise level used", "unit"], body,
                    id=source.name("residual-table"), numeric=[False, True, True, False]))
    out.append(c)
    out.append(machine_section(source, machine_text))
    return out


def _statistics_rows(rows: dict) -> np.ndarray:
    """The rows the study's statistics are taken over (camsim.analyses.study.analysis.analyse): the
    runs that did not fail, of blocks A and B when the study has Sobol' blocks AB."""
    n = len(next(iter(rows.values())))
    text = lambda col: np.array([v.decode() if isinstance(v, bytes) else str(v) for v in rows[col]]) if col in rows \
        else np.full(n, "")  # noqa: E731
    ok = text("status") == "ok" if "status" in rows else np.ones(n, bool)
    design = text("design")
    if any(d.startswith("AB:") for d in design):
        ok &= np.isin(design, ("A", "B"))
    return ok


def _machine_name(text: str, path) -> str:
    """The ``[machine] name`` of a machine file's text (the file's name when it has none)."""
    import tomllib

    try:
        name = tomllib.loads(text).get("machine", {}).get("name")
    except (tomllib.TOMLDecodeError, AttributeError):
        name = None
    return str(name) if name else Path(str(path)).name


def _scalar_unit(name: str) -> str:
    from camsim.analyses.study.outputs import scalar_unit

    try:
        return scalar_unit(name)
    except Exception:  # noqa: BLE001 - an unknown scalar is shown without a unit
        return ""


def _trace_unit(path: str) -> str:
    from camsim.analyses.study.outputs import trace_unit

    try:
        return trace_unit(path)
    except Exception:  # noqa: BLE001 - an unknown path is shown in SI without a unit
        return ""

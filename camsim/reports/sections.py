"""Section builders of each result kind, registered in :data:`camsim.reports.page.BUILDERS`.

Every number shown comes from the result file as written by the run result hub
(:class:`camsim.run.result.RunResult`): the ``/summary`` scalars, the event table with its
Johnson bounds and peaks, the traces; the cam design summary comes from
:meth:`RunResult.design_summary`. Nothing here recomputes a quantity the hub offers.
Values are shown in the units of camsim's human output (:func:`camsim.reports.display.shown`,
SI with mm for lengths); every header and axis label carries its unit.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from camsim.reports.display import shown
from camsim.reports.envelope import DEFAULT_COLUMNS, envelope
from camsim.reports.figures import PALETTE, bokeh, trace_figure, xy_figure
from camsim.reports.page import Plot, Section, Source, definition_list, esc, fmt, provenance, register, table, verdict

#: Impacts offered at full resolution in the impact detail (largest approach speeds first).
MAX_DETAIL_IMPACTS = 200
#: Largest event table shown on a page (a long run has thousands; the file has them all).
MAX_EVENT_ROWS = 2000


def unit_label(si_unit: str) -> tuple[str, float]:
    """(unit shown, factor from SI); ``-`` for a number without unit."""
    unit, scale = shown(si_unit, "si")
    return (unit or "-"), scale


def _attr(obj, name, default=float("nan")):
    v = obj.attrs.get(name, default)
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.generic):
        return v.item()
    return v


def _machine(f, path):
    """The machine of a result file, rebuilt from its ``machine_toml`` (as open_result does)."""
    from camsim.errors import MachineFileError, ResultFileError
    from camsim.io.results import attr_text
    from camsim.machine.loader import load_machine_text

    try:
        return load_machine_text(attr_text(f, "machine_toml"), source=f"{path}:machine_toml", base_dir=Path(path).parent)
    except MachineFileError as exc:
        raise ResultFileError(f"{path}: cannot rebuild its machine from machine_toml ({exc})") from None


# ---------------------------------------------------------------------- run
class RunView:
    """What the run sections read from one run layout (a file root or a comparison side)."""

    def __init__(self, source: Source, group, machine, label: str = ""):
        from camsim.io.results import list_traces, read_events, table_units

        self.source = source
        self.group = group
        self.machine = machine
        self.label = label
        self.traces = list_traces(group)
        self.time = self.traces["time"][()] if "time" in self.traces else np.zeros(0)
        self.events = read_events(group) or {}
        self.event_units = table_units(group["events"]) if "events" in group else {}
        self.summary = {k: _attr(group["summary"], k) for k in group["summary"].attrs if not k.startswith("units:")} if "summary" in group else {}
        self.summary_units = {k[6:]: _attr(group["summary"], k, "") for k in group["summary"].attrs if k.startswith("units:")} if "summary" in group else {}

    def data(self, path: str) -> np.ndarray | None:
        d = self.traces.get(path)
        return None if d is None else d[()]

    def units(self, path: str) -> str:
        from camsim.io.results import units_of

        return units_of(self.traces[path])

    @property
    def n_events(self) -> int:
        return len(self.events.get("time", ()))

    def impact_rows(self) -> list[int]:
        """Indices of the impact-like events (the hub's definition: EventKind.is_impact)."""
        from camsim.elements.events import EventKind

        kinds = [k.decode() if isinstance(k, bytes) else str(k) for k in self.events.get("kind", ())]
        return [i for i, k in enumerate(kinds) if k in EventKind.__members__.values() and EventKind(k).is_impact]

    def event(self, i: int, column: str):
        v = self.events[column][i]
        return v.decode() if isinstance(v, bytes) else v

    def angle_axis(self) -> tuple[float, float] | None:
        """(θ0 [deg], ω [deg/s]) of cam/angle = θ0 + ω·t (stored linear in time)."""
        angle = self.traces.get("cam/angle")
        if angle is None or self.time.size < 2:
            return None
        a0, a1 = float(angle[0]), float(angle[-1])
        t0, t1 = float(self.time[0]), float(self.time[-1])
        omega = (a1 - a0) / (t1 - t0)
        return a0 - omega * t0, omega


def header_section(source: Source, machine_name: str, extra: list[tuple[str, str]] = ()) -> Section:
    s = Section(source.name("header"), "Result and provenance")
    return s.add(definition_list(provenance(source, machine_name) + list(extra)))


def _speed_rpm(machine) -> float:
    cam = getattr(machine, "cam", None)
    return cam.speed * 60.0 / (2.0 * math.pi) if cam is not None else float("nan")


def verdict_section(source: Source, view: RunView, design: dict | None, title: str = "Verdicts", summary: bool = True) -> Section:
    """Jump, impacts against Johnson's bounds, stress/torque, periodicity: the run's answers."""
    s = Section(source.name("verdicts" + (f"-{view.label}" if view.label else "")), title)
    sm = view.summary
    rpm = _speed_rpm(view.machine)
    tiles = []
    # Jump: the hub's flag; the first jump/release at a cam contact says where.
    cam_contacts = {e.name for e in view.machine.elements if e.unilateral and "cam" in e.nodes}
    if "jump" not in sm:
        tiles.append(verdict("Follower jump", "nodata", "no data: the file has no /summary with the run's jump flag "
                             "(written by an older camsim)", "jump"))
    elif sm.get("jump"):
        where = ""
        for i in range(view.n_events):
            kind, element = view.event(i, "kind"), view.event(i, "element")
            if kind == "jump" or (kind == "release" and element in cam_contacts):
                where = f" first at cam angle <span class=value data-key=jump_angle>{fmt(view.event(i, 'angle_deg'), '.2f')}</span> deg (t = {fmt(view.event(i, 'time'), '.5f')} s)"
                break
        tiles.append(verdict("Follower jump", "fail", f"The follower leaves the cam at {fmt(rpm)} rpm;{where}.", "jump"))
    else:
        lo = sm.get("min_cam_contact_force", float("nan"))
        if isinstance(lo, float) and math.isnan(lo):  # issue 35: no bare "–"
            from camsim.run.result import missing_reason

            why = missing_reason(view.machine, "min_cam_contact_force", {**sm, "status": "ok"}) or "not in the file"
            force = f"no smallest cam contact force: {esc(why)}"
        else:
            force = f"smallest cam contact force <span class=value data-key=min_cam_contact_force data-unit=N>{fmt(lo)}</span> N"
        tiles.append(verdict("Follower jump", "ok", f"None at <span class=value data-key=speed_rpm>{fmt(rpm)}</span> rpm; {force}.", "jump"))
    impacts = view.impact_rows()
    n = int(sm.get("impacts", len(impacts)))
    if n:
        peaks = np.array([float(view.event(i, "peak_force")) for i in impacts]) if impacts else np.zeros(0)
        detail = (f"<span class=value data-key=impacts>{n}</span> impacts; largest approach speed "
                  f"<span class=value data-key=max_impact_velocity data-unit=m/s>{fmt(sm.get('max_impact_velocity'))}</span> m/s.")
        state = "warn"
        if peaks.size and np.any(np.isfinite(peaks)):
            k = impacts[int(np.nanargmax(peaks))]
            lo, hi = float(view.event(k, "johnson_lower")), float(view.event(k, "johnson_upper"))
            detail += (f" Largest simulated peak <span class=value data-key=largest_peak_force data-unit=N>{fmt(peaks[np.nanargmax(peaks)])}</span> N "
                       f"({esc(view.event(k, 'element'))}) against Johnson's bounds {fmt(lo)} to {fmt(hi)} N.")
        tiles.append(verdict("Impacts", state, detail, "impacts"))
    else:
        tiles.append(verdict("Impacts", "ok", "<span class=value data-key=impacts>0</span> impacts.", "impacts"))
    if design is not None:
        stress_unit, stress_scale = "MPa", 1e-6
        pa, limit = design.get("max_pressure_angle"), design.get("pressure_angle_limit")
        state = "fail" if (pa is not None and limit is not None and pa > limit) else "ok"
        tiles.append(verdict("Cam stress and torque", state,
                             f"Peak Hertz stress <span class=value data-key=peak_hertz_stress data-unit={stress_unit}>{fmt((design.get('peak_hertz_stress') or float('nan')) * stress_scale)}</span> {stress_unit} "
                             "(no allowable stress in the machine file); peak torque "
                             f"<span class=value data-key=peak_torque data-unit=N·m>{fmt(design.get('peak_torque'))}</span> N·m; "
                             f"pressure angle {fmt(pa)} deg against the limit {fmt(limit)} deg.", "design"))
    res = sm.get("periodicity_residual", float("nan"))
    if not np.isfinite(res):  # issue 35: no data is not a verdict
        from camsim.run.result import missing_reason

        why = "the file has no /summary" if not sm else missing_reason(view.machine, "periodicity_residual", {"periodicity_residual": res})
        tiles.append(verdict("Periodicity", "nodata", f"no data: {esc(why or 'not computed')}.", "periodicity"))
    else:
        tiles.append(verdict("Periodicity", "ok" if res < 1e-3 else "warn", f"Residual one revolution apart, relative to peak: "
                             f"<span class=value data-key=periodicity_residual>{fmt(res, '.3g')}</span> [-] "
                             "(below 1e-3: a steady state).", "periodicity"))
    s.add('<div class="verdicts">' + "".join(tiles) + "</div>")
    if not summary:
        return s
    # The flat summary of the run, every scalar with its unit.
    rows = []
    for name, value in sm.items():
        if name in ("recorded", "record_last"):
            continue
        unit, scale = unit_label(str(view.summary_units.get(name, "")))
        shown_value = fmt(value) if isinstance(value, (bool, np.bool_)) or name == "impacts" else fmt(float(value) * scale)
        rows.append([f"<span data-key='{esc(name)}'>{esc(name)}</span>", shown_value, esc(unit)])
    s.add(table(["quantity", "value", "unit"], rows, cls="summary", id=source.name("summary-table" + (f"-{view.label}" if view.label else "")),
                caption="Summary values (over every revolution run)", numeric=[False, True, False]))
    return s


EVENT_COLUMNS = (
    ("time", "t", "s", ".6f"), ("angle_deg", "angle", "deg", ".2f"), ("element", "element", None, None),
    ("kind", "kind", None, None), ("masses", "masses", None, None), ("relative_velocity", "approach speed", "m/s", ".4g"),
    ("johnson_lower", "Johnson lower", "N", ".4g"), ("johnson_upper", "Johnson upper", "N", ".4g"),
    ("peak_force", "simulated peak", "N", ".4g"), ("contact_duration", "contact duration", "ms", ".4g"),
)


def event_section(source: Source, view: RunView, detail_names: dict[int, int] | None = None, title: str = "Impacts and events") -> Section:
    s = Section(source.name("events" + (f"-{view.label}" if view.label else "")), title)
    if not view.n_events:
        return s.add("<p>No events in the recorded window.</p>")
    headers = [f"{h} [{u}]" if u else h for _, h, u, _ in EVENT_COLUMNS]
    numeric = [u is not None for _, _, u, _ in EVENT_COLUMNS]
    rows = []
    detail_names = detail_names or {}
    for i in range(min(view.n_events, MAX_EVENT_ROWS)):
        row = []
        for col, _, unit, spec in EVENT_COLUMNS:
            v = view.event(i, col)
            if unit is None:
                row.append(esc(v))
            else:
                v = float(v) * (1e3 if unit == "ms" else 1.0)
                row.append(fmt(abs(v) if col == "relative_velocity" else v, spec))
        if i in detail_names:
            sel = source.name("impact-select")
            row[3] += (f' <button class="show-impact" type="button" aria-label="show impact at t = {fmt(view.event(i, "time"), ".5f")} s at full resolution" '
                       f"onclick=\"var m=Bokeh.documents[0].get_model_by_name('{sel}');m.value='{detail_names[i]}';"
                       f"document.getElementById('{source.name('detail')}').scrollIntoView()\">detail</button>")
        rows.append(row)
    note = "" if view.n_events <= MAX_EVENT_ROWS else f"<p class=note>The first {MAX_EVENT_ROWS} of {view.n_events} events; the file has them all.</p>"
    s.add(table(headers, rows, cls="events", id=source.name("event-table" + (f"-{view.label}" if view.label else "")), numeric=numeric,
                caption="Events (approach speed as |relative velocity|; Johnson's bounds and the simulated peak for impacts; "
                        "– where a column does not apply to the kind of event, and for an impact's contact duration "
                        "where the contact is still closed when the recording ends: it outlasts the recorded revolutions)") + note)
    return s


def _trace_groups(view: RunView) -> list[tuple[str, str, list[str]]]:
    """(title, quantity key, trace paths) of the trace plots, in the order of camsim plot."""
    paths = list(view.traces)
    groups = []
    masses = sorted({p.split("/")[1] for p in paths if p.startswith("masses/")}, key=lambda m: paths.index(f"masses/{m}/" + next(q for q in ("displacement", "velocity", "acceleration") if f"masses/{m}/{q}" in paths)))
    for q in ("displacement", "velocity", "acceleration"):
        members = [f"masses/{m}/{q}" for m in masses if f"masses/{m}/{q}" in paths]
        if q == "displacement" and "cam/displacement" in paths:
            members = ["cam/displacement"] + members
        if members:
            groups.append((f"{q.capitalize()} per mass", q, members))
    forces = [p for p in paths if p.startswith("elements/")]
    if forces:
        groups.append(("Element forces", "elements", forces))
    contact = [p for p in ("cam_contact/force", "transducer/force") if p in paths]
    if contact:
        groups.append(("Cam contact and transducer force", "contact", contact))
    return groups


def _series_label(path: str) -> str:
    parts = path.split("/")
    if path.startswith("masses/") or path.startswith("elements/"):
        return parts[1]
    return {"cam/displacement": "cam (model axis)", "cam_contact/force": "cam contact", "transducer/force": "transducer"}.get(path, path)


def trace_section(source: Source, views: list[RunView], x_range=None, title: str = "Traces") -> tuple[Section, object]:
    """The trace plots on one shared, linked time axis (cam angle on top), impacts marked."""
    s = Section(source.name("traces"), title)
    main = views[0]
    groups = _trace_groups(main)
    impact_times = np.array([float(main.event(i, "time")) for i in main.impact_rows()])
    n = main.time.size
    s.add(f"<p class=note>Wheel: zoom the time axis; drag: box zoom; all trace plots share the time axis. "
          f"Dashed vertical lines: impacts ({impact_times.size}). {n} samples per trace"
          + (f", shown as a min/max envelope over {DEFAULT_COLUMNS} columns: every peak is kept; the impact detail below "
             "shows any impact at full resolution." if n > 2 * DEFAULT_COLUMNS else ".") + "</p>")
    for title_, q, members in groups:
        unit_si = main.units(members[0])
        unit, scale = unit_label(unit_si)
        series = []
        reduced = False
        for view in views:
            for path in members:
                y = view.data(path)
                if y is None:
                    continue
                x, yy, r = envelope(view.time, y * scale)
                reduced |= r
                label = _series_label(path) + (f" ({view.label})" if len(views) > 1 else "")
                series.append((label, x, yy))
        note = (f"min/max envelope per screen column of {n} samples: peaks are never lost" if reduced else "")
        name = source.name(f"trace-{q}")
        quantity = q if q in ("displacement", "velocity", "acceleration") else "force"
        p = trace_figure(name, title_, f"{quantity} [{unit}]", series, x_range=x_range, angle_axis=main.angle_axis(),
                         impact_times=impact_times, note=note)
        x_range = p.x_range
        s.add(Plot(p, f"{title_} [{unit}] against time [s] with the cam angle [deg] on top; "
                      f"series: {', '.join(lbl for lbl, _, _ in series)}; impacts marked by dashed lines."))
    return s, x_range


def impact_detail_section(source: Source, view: RunView) -> tuple[Section | None, dict[int, int]]:
    """Any impact at full resolution: the impacting element's force and the masses' accelerations."""
    _, models = bokeh()
    rows = view.impact_rows()
    has_force = any(p.startswith("elements/") for p in view.traces)
    has_acc = any(p.startswith("masses/") and p.endswith("/acceleration") for p in view.traces)
    if not rows or view.time.size < 2 or not (has_force or has_acc):
        return None, {}  # nothing stored to show at full resolution (--record, --summary-only)
    speeds = np.array([abs(float(view.event(i, "relative_velocity"))) for i in rows])
    order = np.argsort(-np.nan_to_num(speeds, nan=-1.0), kind="stable")[:MAX_DETAIL_IMPACTS]
    chosen = sorted(rows[k] for k in order)
    dt = float(view.time[1] - view.time[0])
    cols = {"t": [], "force": [], "acc_a": [], "acc_b": []}
    offsets, labels, names = [0], [], {}
    a_unit, a_scale = unit_label("m/s^2")
    for j, i in enumerate(chosen):
        t_i, element = float(view.event(i, "time")), str(view.event(i, "element"))
        duration = float(view.event(i, "contact_duration"))
        # 1 ms before, the contact (at most 4 ms of it: a link may stay joined for long) and 1 ms after.
        after = min(duration, 4e-3) if np.isfinite(duration) else 2e-3
        k0 = int(np.searchsorted(view.time, t_i - 1e-3))
        k1 = int(np.searchsorted(view.time, t_i + after + 1e-3))
        k0, k1 = max(0, k0), min(view.time.size, max(k1, k0 + 2), k0 + 4000)
        t = view.time[k0:k1]
        cols["t"].append(t)
        force_ds = view.traces.get(f"elements/{element}/force")
        cols["force"].append(force_ds[k0:k1] if force_ds is not None else np.full(t.size, np.nan))
        masses = [m for m in str(view.event(i, "masses")).split("/") if m and m != "ground"]
        for key, m in zip(("acc_a", "acc_b"), masses + [None, None]):
            ds = view.traces.get(f"masses/{m}/acceleration") if m else None
            cols[key].append(ds[k0:k1] * a_scale if ds is not None else np.full(t.size, np.nan))
        offsets.append(offsets[-1] + t.size)
        labels.append((str(j), f"t = {t_i:.5f} s, {element} ({view.event(i, 'masses')}), approach {abs(float(view.event(i, 'relative_velocity'))):.4g} m/s"))
        names[i] = j
    every = {k: np.concatenate(v).astype(float) for k, v in cols.items()}
    everything = models.ColumnDataSource(every)
    first = {k: v[offsets[0]:offsets[1]] for k, v in every.items()}
    shown_src = models.ColumnDataSource(first)
    sel = models.Select(title="Impact shown at full resolution", value="0", options=labels, name=source.name("impact-select"))
    sel.js_on_change("value", models.CustomJS(args={"all": everything, "shown": shown_src, "offsets": offsets}, code="""
        const k = parseInt(cb_obj.value), a = offsets[k], b = offsets[k + 1], d = {};
        for (const c of Object.keys(all.data)) d[c] = all.data[c].slice(a, b);
        shown.data = d;
    """))
    plotting, _ = bokeh()
    f_unit, _ = unit_label("N")
    figures, x_range = [], None
    if has_force:
        pf = trace_figure(source.name("impact-detail-force"), "Impacting element force (full resolution)", f"force [{f_unit}]", [])
        pf.line("t", "force", source=shown_src, legend_label="element force", line_width=1.6, line_color=PALETTE[0])
        figures.append(pf)
        x_range = pf.x_range
    if has_acc:
        pa = trace_figure(source.name("impact-detail-acceleration"), "Accelerations of the impacting masses (full resolution)",
                          f"acceleration [{a_unit}]", [], x_range=x_range)
        pa.line("t", "acc_a", source=shown_src, legend_label="first mass", line_width=1.6, line_color=PALETTE[1])
        pa.line("t", "acc_b", source=shown_src, legend_label="second mass", line_width=1.6, line_color=PALETTE[2], line_dash="dashed")
        figures.append(pa)
    for p in figures:
        p.legend.location = "top_right"
    from bokeh.layouts import column

    s = Section(source.name("detail"), "Impact detail (full resolution)")
    note = "" if len(rows) <= MAX_DETAIL_IMPACTS else f" The {MAX_DETAIL_IMPACTS} impacts with the largest approach speeds of {len(rows)} are offered."
    s.add(f"<p class=note>Every sample around the chosen impact, {dt * 1e6:.3g} µs apart (no envelope).{note} "
          "Choose an impact in the list or with the detail button of the event table.</p>")
    box = column(sel, *figures, sizing_mode="stretch_width", name=source.name("impact-detail"))
    s.add(Plot(box, "The force of the impacting element [N] and the accelerations of the masses it joins [m/s²] "
                    "against time [s], every sample around the chosen impact."))
    return s, names


def cam_section(source: Source, view: RunView) -> Section | None:
    """SVAJ over one revolution, and the cam drawn to scale when its geometry is given."""
    angle = view.data("cam/angle")
    if angle is None:
        return None
    s = Section(source.name("cam"), "Cam: SVAJ and profile")
    one = angle <= angle[0] + 360.0
    x_range = None
    for q, unit_si in (("displacement", "m"), ("velocity", "m/s"), ("acceleration", "m/s^2"), ("jerk", "m/s^3")):
        y = view.data(f"cam/{q}")
        if y is None:
            continue
        unit, scale = unit_label(unit_si)
        x, yy, _ = envelope(angle[one], y[one] * scale)
        p = xy_figure(source.name(f"svaj-{q}"), f"Cam {q} (model axis)", "cam angle [deg]", f"{q} [{unit}]", [(q, x, yy)],
                      height=190, x_range=x_range)
        x_range = p.x_range
        p.legend.visible = False
        s.add(Plot(p, f"Cam {q} [{unit}] against cam angle [deg] over one revolution."))
    surface, pitch = view.traces.get("cam/surface"), view.traces.get("cam/pitch_curve")
    if surface is not None:
        curves = []
        for label, ds in (("cam surface", surface), ("pitch curve", pitch)):
            if ds is None:
                continue
            xy = ds[()][one] * 1e3
            idx = np.unique(np.concatenate([np.linspace(0, xy.shape[0] - 1, 1500).astype(int)]))
            curves.append((label, xy[idx, 0], xy[idx, 1]))
        p = xy_figure(source.name("cam-profile"), "Cam drawn to scale (cam frame)", "x [mm]", "y [mm]", curves, equal=True)
        s.add(Plot(p, "The cam surface and the pitch curve in the cam frame, x and y in mm, equal scales."))
    return s


def machine_section(source: Source, text: str) -> Section:
    s = Section(source.name("machine"), "Machine file")
    return s.add(f"<details><summary>The machine file of the run (TOML, {len(text.splitlines())} lines)</summary><pre>{esc(text)}</pre></details>")


def _design(source: Source, view: RunView) -> dict | None:
    """The hub's cam design summary when the machine has a geometry and the file every trace."""
    if getattr(getattr(view.machine, "cam", None), "geometry", None) is None or source.path is None:
        return None
    from camsim.errors import ResultFileError
    from camsim.run.result import open_result

    try:
        return open_result(source.path, view.label or None).design_summary()
    except ResultFileError:
        return None  # a run stored with --record/--summary-only: the scalars in /summary still show


def _stored_text(view: RunView, recorded: list[str]) -> str:
    """How many traces the file stores (a --summary-only run: none)."""
    stored = max(len(view.traces) - 1, 0)  # without time
    if not stored:
        return "none (a --summary-only run: the events and the summary)"
    listed = max(len([p for p in recorded if p != "time"]), stored) if recorded else stored
    return f"{stored} of {listed}"


@register("run")
def run_sections(source: Source) -> list[Section]:
    from camsim.io.results import attr_text

    f = source.h5
    machine = _machine(f, source.path)
    view = RunView(source, f, machine)
    recorded = json.loads(_attr(f["summary"], "recorded", "[]")) if "summary" in f else []
    extra = [("sample rate", f"{fmt(_attr(f, 'sample_rate'))} Hz"), ("speed", f"{fmt(_speed_rpm(machine))} rpm"),
             ("variant", "no-impact" if _attr(f, "no_impact", False) else "with impact"),
             ("traces stored", _stored_text(view, recorded))]
    out = [header_section(source, machine.name, extra), verdict_section(source, view, _design(source, view))]
    detail, names = impact_detail_section(source, view)
    out.append(event_section(source, view, names))
    if len(view.traces) > 1:
        out.append(trace_section(source, [view])[0])
    if detail is not None:
        out.append(detail)
    cam = cam_section(source, view)
    if cam is not None:
        out.append(cam)
    out.append(machine_section(source, attr_text(f, "machine_toml")))
    return out


# ---------------------------------------------------------------------- compare
@register("compare")
def compare_sections(source: Source) -> list[Section]:
    from camsim.io.results import attr_text, list_traces

    f = source.h5
    machine = _machine(f, source.path)
    imp = RunView(source, f["impact"], machine, "impact")
    non = RunView(source, f["no_impact"], machine, "no impact")
    out = [header_section(source, machine.name, [("speed", f"{fmt(_speed_rpm(machine))} rpm")])]
    # The difference table: each summary scalar of both runs and the change.
    s = Section(source.name("difference"), "Impact against no impact")
    rows = []
    for name, a in imp.summary.items():
        if name in ("recorded", "record_last") or name not in non.summary:
            continue
        b = non.summary[name]
        unit, scale = unit_label(str(imp.summary_units.get(name, "")))
        if isinstance(a, (bool, np.bool_)) or name in ("impacts", "jump"):
            rows.append([esc(name), fmt(a), fmt(b), "–", esc(unit)])
            continue
        a, b = float(a), float(b)
        change = 100.0 * (a - b) / abs(b) if b not in (0.0,) and np.isfinite(b) else float("nan")
        rows.append([esc(name), fmt(a * scale), fmt(b * scale), fmt(change, "+.3g"), esc(unit)])
    s.add(table(["quantity", "with impact", "no impact", "change [%]", "unit"], rows, cls="difference",
                id=source.name("difference-table"), numeric=[False, True, True, True, False],
                caption="Summary values of both runs; change = 100·(impact − no impact)/|no impact|"))
    out.append(s)
    out.append(verdict_section(source, imp, None, "Verdicts: run with impact", summary=False))
    out.append(event_section(source, imp, None, "Impacts and events (run with impact)"))
    traces, x_range = trace_section(source, [imp, non], title="Both runs overlaid")
    out.append(traces)
    diff = list_traces(f["difference"]) if "difference" in f else {}
    if len(diff) > 1:
        time = diff["time"][()]
        ds = Section(source.name("difference-traces"), "Difference traces")
        for q in ("displacement", "velocity", "acceleration"):
            series = []
            for path, dset in diff.items():
                if path.endswith(f"/{q}"):
                    x, y, _ = envelope(time, dset[()])
                    series.append((path.split("/")[1], x, y))
            if series:
                p = trace_figure(source.name(f"diff-{q}"), f"Difference of {q}: 100·(impact − no impact)/max|impact|",
                                 f"{q} difference [%]", series, x_range=x_range)
                ds.add(Plot(p, f"Difference of {q} between the runs [%] against time [s], per mass."))
        out.append(ds)
    out.append(machine_section(source, attr_text(f, "machine_toml")))
    return out


# ---------------------------------------------------------------------- sweep
def _column_unit(dset, name: str) -> str:
    from camsim.io.results import attr_text

    return attr_text(dset, f"units:{name}")


def _shown_param(name: str, si_unit: str) -> tuple[str, float]:
    """A varied key as shown: speeds in rpm (as the sweep is written on the command line)."""
    if si_unit == "rad/s":
        return "rpm", 60.0 / (2.0 * math.pi)
    return unit_label(si_unit)


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
    if np.isfinite(first):
        detail = (f"The follower first leaves the cam at <span class=value data-key=first_jump_rpm>{fmt(first)}</span> rpm"
                  + (f"; jump onset (bracketed) <span class=value data-key=jump_onset_rpm>{fmt(onset)}</span> rpm." if np.isfinite(onset) else "."))
        tile = verdict("Follower jump", "fail", detail, "jump")
    else:
        tile = verdict("Follower jump", "ok", "No point of the sweep jumps.", "jump")
    s.add('<div class="verdicts">' + tile + "</div>")
    out.append(s)
    # Plots: every output column against the first varied key (series: the other keys' values).
    p_sec = Section(source.name("columns"), "Every column against the varied key")
    if params:
        x_name = params[0]
        x_unit, x_scale = _shown_param(x_name, _column_unit(dset, x_name))
        x = np.asarray(rows[x_name], dtype=float) * x_scale
        others = params[1:]
        combos = sorted({tuple(float(rows[o][i]) for o in others) for i in range(x.size)}) if others else [()]
        x_range = None
        for base, cols in _quantity_groups(outputs).items():
            unit, scale = unit_label(_column_unit(dset, cols[0]))
            series = []
            for c in cols:
                y = np.asarray(rows[c], dtype=float) * scale
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
                for value, label in ((onset, "jump onset"), (first, "first jump")):
                    if np.isfinite(value):
                        p.add_layout(models.Span(location=value, dimension="height", line_color=PALETTE[2], line_dash="dashed", line_width=2))
                        p.add_layout(models.Label(x=value, y=5, y_units="screen", text=label, text_font_size="9pt", x_offset=3))
            p_sec.add(Plot(p, f"{base} [{unit}] against {x_name[6:]} [{x_unit}]" + (", jump onset marked" if np.isfinite(first) else "") + "."))
    out.append(p_sec)
    t_sec = Section(source.name("table"), "Sweep table")
    headers, units = [], []
    for c in names:
        u, sc = _shown_param(c, _column_unit(dset, c)) if c.startswith("param:") else unit_label(_column_unit(dset, c))
        headers.append(f"{c} [{u}]" if c != "status" else c)
        units.append(sc)
    body = []
    for i in range(len(rows[names[0]])):
        row = []
        for c, sc in zip(names, units):
            v = rows[c][i]
            if isinstance(v, (bytes, str)):
                row.append(esc(v.decode() if isinstance(v, bytes) else v))
            elif np.asarray(v).dtype.kind == "b" or c in ("impacts", "jump"):
                row.append(fmt(bool(v)) if np.asarray(v).dtype.kind == "b" else fmt(v))
            else:
                row.append(fmt(float(v) * sc))
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
    from camsim.analyses.study.statistics import parse_limit

    f = source.h5
    machine = _machine(f, source.path)
    g = f["study"]
    payload = json.loads(attr_text(g, "summary_json", "{}"))
    dset = g["rows"]
    rows = read_table(dset)
    units = {c: _column_unit(dset, c) for c in dset.dtype.names}
    texts = lambda key: [str(v.decode() if isinstance(v, bytes) else v) for v in g.attrs.get(key, []) if str(v.decode() if isinstance(v, bytes) else v)]  # noqa: E731
    extra = [("distributions", "<br>".join(esc(d) for d in texts("dist"))), ("method", esc(attr_text(g, "method"))),
             ("samples / runs", f"{payload.get('n_samples')} / {payload.get('n_runs')}"), ("seed", esc(payload.get("seed"))),
             ("failed runs", esc(payload.get("failed", 0)))]
    out = [header_section(source, machine.name, extra)]
    # Probabilities of crossing the limits, with their Clopper–Pearson intervals.
    s = Section(source.name("limits"), "Limits: probability of crossing")
    lim_rows = []
    for lim in payload.get("limits", []):
        lo, hi = lim["ci95"]
        lim_rows.append([esc(lim["expr"]), fmt(lim["crossed"]), fmt(lim["n"]), fmt(100 * lim["probability"]),
                         f"{fmt(100 * lo)} to {fmt(100 * hi)}", fmt(lim["per_million"])])
    s.add(table(["limit", "runs crossing [-]", "runs [-]", "probability [%]", "95 % interval [%]", "per million machines [-]"],
                lim_rows, id=source.name("limits-table"), numeric=[False, True, True, True, False, True],
                caption="Probability of crossing each limit (Clopper–Pearson 95 % interval)") if lim_rows else "<p>No --limit given.</p>")
    out.append(s)
    # Statistics of every output.
    st = Section(source.name("statistics"), "Statistics of the outputs")
    stat_rows = []
    for name, o in payload.get("outputs", {}).items():
        unit, scale = unit_label(units.get(name, ""))
        ci = o.get("ci95", {}).get("mean", [None, None])
        p = o.get("percentiles", {})
        sc = lambda v: None if v is None else float(v) * scale  # noqa: E731
        stat_rows.append([esc(name), esc(unit), fmt(sc(o.get("mean"))), f"{fmt(sc(ci[0]))} to {fmt(sc(ci[1]))}", fmt(sc(o.get("std"))),
                          fmt(sc(p.get("5"))), fmt(sc(p.get("50"))), fmt(sc(p.get("95"))), fmt(sc(o.get("min"))), fmt(sc(o.get("max")))])
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
    for name, o in payload.get("outputs", {}).items():
        if not o.get("std"):
            continue
        unit, scale = unit_label(units.get(name, ""))
        values = np.asarray(rows[name], dtype=float) * scale
        lims = [(lim.expr, lim.threshold * scale) for lim in limits if lim.quantity == name]
        p = histogram_figure(source.name(f"hist-{name.replace(':', '-')}"), name, values, f"{name} [{unit}]", lims)
        h.add(Plot(p, f"Histogram of {name} [{unit}] over the runs" + (f", limits {', '.join(e for e, _ in lims)} drawn" if lims else "") + "."))
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
            b.add(table(["key", "total index [-]"], [[esc(r["key"]), fmt(r["total"])] for r in rank], id=source.name("ranking-table"),
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
    extra = [("machine file", f"<code>{esc(machine_path)}</code>"), ("simulations", fmt(result.n_evaluations)),
             ("cost", fmt(result.cost, ".6g")), ("solver", esc(result.message))]
    out = [header_section(source, str(machine_path), extra)]
    v = Section(source.name("verdicts"), "Verdicts")
    tiles = [verdict("Convergence", "ok" if result.converged else "fail",
                     f"{'Converged' if result.converged else 'Not converged'}; residual variance {fmt(result.residual_variance)} "
                     f"({result.dof} degrees of freedom); Jacobian condition {fmt(result.condition, '.3g')}.", "converged")]
    for w in result.warnings:
        tiles.append(verdict("Warning", "warn", esc(w), "warning"))
    v.add('<div class="verdicts">' + "".join(tiles) + "</div>")
    out.append(v)
    p = Section(source.name("parameters"), "Fitted parameters")
    rows = []
    for i, key in enumerate(result.keys):
        lo, hi = result.ci95[i]
        rows.append([esc(key), esc(result.units[i] or "-"), fmt(result.file_values[i], ".6g"), fmt(result.initial[i], ".6g"),
                     fmt(result.values[i], ".6g"), fmt(result.stderr[i], ".3g"),
                     f"{fmt(lo, '.6g')} to {fmt(hi, '.6g')}" if np.isfinite(lo) and np.isfinite(hi) else "not determined"])
    p.add(table(["parameter", "unit", "file value", "start", "fitted", "std. error", "95 % interval"], rows,
                id=source.name("parameter-table"), numeric=[False, False, True, True, True, True, False],
                caption="Values in the parameter's SI unit (column 2)"))
    if len(result.keys) > 1:
        fig = image_figure(source.name("correlation"), "Correlation of the fitted parameters", list(result.keys), np.asarray(result.correlation))
        p.add(Plot(fig, "Correlation matrix of the fitted parameters [-], values written in the cells."))
    out.append(p)
    c = Section(source.name("channels"), "Measured against fitted")
    x_range = None
    for k, (path, t, measured, fitted) in enumerate(result.channels):
        unit, scale = unit_label(_trace_unit(path))
        fig = trace_figure(source.name(f"fit-{k}"), f"{path}: measured and fitted", f"{path.split('/')[-1]} [{unit}]",
                           [], x_range=x_range)
        x_range = fig.x_range
        # Measured first, the fitted line over it (drawn in the order added).
        fig.scatter(np.asarray(t, dtype=float), np.asarray(measured, dtype=float) * scale, size=3, marker="circle",
                    fill_alpha=0.0, line_color=PALETTE[5], line_alpha=0.7, legend_label="measured")
        fig.line(np.asarray(t, dtype=float), np.asarray(fitted, dtype=float) * scale, line_color=PALETTE[0], line_width=1.6,
                 legend_label="fitted")
        fig.legend.location = "top_right"
        res = trace_figure(source.name(f"fit-{k}-residual"), f"{path}: residual (fitted − measured)", f"residual [{unit}]",
                           [("residual", t, (np.asarray(fitted) - np.asarray(measured)) * scale)], x_range=x_range)
        res.height = 160
        rms = result.rms_residual.get(path, float("nan")) * scale
        c.add(Plot(fig, f"{path} [{unit}] against time [s]: measured (circles) and fitted (line)."),
              Plot(res, f"Residual of {path} [{unit}] against time [s]; RMS {fmt(rms)} {unit}."))
    if not result.channels:
        c.add("<p>No measured trace (targets only).</p>")
    if result.rms_residual:
        c.add(table(["channel or target", "RMS residual [SI]", "noise level used [SI]"],
                    [[esc(k), fmt(r), fmt(result.sigma.get(k, float("nan")))] for k, r in result.rms_residual.items()],
                    id=source.name("residual-table"), numeric=[False, True, True]))
    out.append(c)
    out.append(machine_section(source, machine_text))
    return out


def _trace_unit(path: str) -> str:
    from camsim.analyses.study.outputs import trace_unit

    try:
        return trace_unit(path)
    except Exception:  # noqa: BLE001 - an unknown path is shown in SI without a unit
        return ""

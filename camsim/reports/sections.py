"""Section builders of each result kind, registered in :data:`camsim.reports.page.BUILDERS`.

Every number shown comes from the result file as written by the run result hub
(:class:`camsim.run.result.RunResult`): the ``/summary`` scalars, the event table with its
Johnson bounds and peaks, the traces; the cam design summary comes from
:meth:`RunResult.design_summary`. Nothing here recomputes a quantity the hub offers.
Values are shown in the page's display units through :class:`camsim.reports.page.Source` only
(``number``/``quantity``/``column``/``show``: a unit text never travels apart from the values
converted to it; the units of the result's machine file by default, ``--units si|us``); every
header and axis label carries its unit. The verdict tiles are in :mod:`camsim.reports.verdicts`,
the sweep, study and fit pages in :mod:`camsim.reports.studies`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from camsim.display import engineering
from camsim.reports.envelope import DEFAULT_COLUMNS, envelope
from camsim.reports.figures import PALETTE, bokeh, finish_legend, trace_figure, xy_figure
from camsim.reports.page import Plot, Section, Source, definition_list, esc, fmt, provenance, register, table
from camsim.reports.verdicts import verdict_tiles

#: Impacts offered at full resolution in the impact detail (largest approach speeds first).
MAX_DETAIL_IMPACTS = 200
#: Largest event table shown on a page (a long run has thousands; the file has them all).
MAX_EVENT_ROWS = 2000


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
#: Attributes of ``/summary`` that are not scalars of the run.
_NOT_SCALARS = ("recorded", "record_last", "warnings", "notes")


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
        attrs = group["summary"].attrs if "summary" in group else {}
        self.summary = {k: _attr(group["summary"], k) for k in attrs if not k.startswith("units:") and k not in _NOT_SCALARS}
        self.summary_units = {k[6:]: _attr(group["summary"], k, "") for k in attrs if k.startswith("units:")}
        #: What the run printed (issue 44): its warnings (SI, shown in the page's units) and how the
        #: machine file was read (Machine.notes, as printed); None for a file written before they were stored.
        self.warnings = json.loads(_attr(group["summary"], "warnings")) if "warnings" in attrs else None
        self.notes = json.loads(_attr(group["summary"], "notes")) if "notes" in attrs else []

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

    def event_list(self):
        """The event table as :class:`~camsim.elements.events.Event` rows (what the hub's checks read)."""
        from camsim.elements.events import Event, EventTable

        names = list(self.events)
        rows = EventTable()
        for i in range(self.n_events):
            rows.append(Event(**{c: (str(self.event(i, c)) if c in ("element", "kind", "masses") else float(self.event(i, c)))
                                 for c in names}))
        return rows

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


def _speed(source: Source, machine) -> str:
    """The cam speed in the page's units (rpm unless the file writes speeds otherwise)."""
    cam = getattr(machine, "cam", None)
    return source.quantity(cam.speed, "rad/s", ".6g") if cam is not None else "–"


def verdict_section(source: Source, view: RunView, design: dict | None, title: str = "Verdicts", summary: bool = True,
                    hub: dict | None = None) -> Section:
    """The run's answers, each with its criterion (:mod:`camsim.reports.verdicts`), then every summary scalar."""
    s = Section(source.name("verdicts" + (f"-{view.label}" if view.label else "")), title)
    s.add('<div class="verdicts">' + "".join(verdict_tiles(source, view, design, hub)) + "</div>")
    if not summary:
        return s
    # The flat summary of the run, every scalar with its unit.
    rows = []
    for name, value in view.summary.items():
        si_unit = str(view.summary_units.get(name, ""))
        column = source.column("value", si_unit)
        cell = fmt(value) if isinstance(value, (bool, np.bool_)) else column.cell(value, ".6g" if name == "impacts" else ".4g")
        rows.append([f"<span data-key='{esc(name)}'>{esc(name)}</span>", cell, esc(source.show(1.0, si_unit).unit or "-")])
    s.add(table(["quantity", "value", "unit"], rows, cls="summary", id=source.name("summary-table" + (f"-{view.label}" if view.label else "")),
                caption="Summary values (over every revolution run)", numeric=[False, True, False]))
    return s


#: The event table's columns: (file column, header, SI unit or None for text, format, presentation unit).
EVENT_COLUMNS = (
    ("time", "t", "s", ".6f", ""), ("angle_deg", "angle", "deg", ".2f", ""), ("element", "element", None, None, ""),
    ("kind", "kind", None, None, ""), ("masses", "masses", None, None, ""),
    ("relative_velocity", "approach speed", "m/s", ".4g", ""),
    ("johnson_lower", "Johnson lower (impulsive)", "N", ".4g", ""), ("johnson_upper", "Johnson upper (impulsive)", "N", ".4g", ""),
    ("peak_force", "simulated peak (with preload)", "N", ".4g", ""), ("impulsive", "impulsive peak", "N", ".4g", ""),
    ("contact_duration", "contact duration", "s", ".4g", "ms"),
)


def event_section(source: Source, view: RunView, detail_names: dict[int, int] | None = None, title: str = "Impacts and events") -> Section:
    from camsim.run.checks import impact_preload

    s = Section(source.name("events" + (f"-{view.label}" if view.label else "")), title)
    if not view.n_events:
        return s.add("<p>No events in the recorded window.</p>")
    columns = [source.column(h, u, presentation) if u is not None else None for _, h, u, _, presentation in EVENT_COLUMNS]
    headers = [c.header if c is not None else h for c, (_, h, _, _, _) in zip(columns, EVENT_COLUMNS)]
    numeric = [u is not None for _, _, u, _, _ in EVENT_COLUMNS]
    by_name = {e.name: e for e in view.machine.elements}
    rows = []
    detail_names = detail_names or {}
    for i in range(min(view.n_events, MAX_EVENT_ROWS)):
        row = []
        for (col, _, unit, spec, _), column in zip(EVENT_COLUMNS, columns):
            if unit is None:
                row.append(esc(view.event(i, col)))
            elif col == "impulsive":  # Johnson's bounds estimate this part (run.checks.johnson_rows)
                peak, element = float(view.event(i, "peak_force")), by_name.get(str(view.event(i, "element")))
                value = peak - impact_preload(element) if element is not None and np.isfinite(peak) else float("nan")
                row.append(column.cell(value, spec))
            else:
                v = float(view.event(i, col))
                row.append(column.cell(abs(v) if col == "relative_velocity" else v, spec))
        if i in detail_names:
            sel = source.name("impact-select")
            row[3] += (f' <button class="show-impact" type="button" aria-label="show impact at t = {fmt(view.event(i, "time"), ".5f")} s at full resolution" '
                       f"onclick=\"var m=Bokeh.documents[0].get_model_by_name('{sel}');m.value='{detail_names[i]}';"
                       f"document.getElementById('{source.name('detail')}').scrollIntoView()\">detail</button>")
        rows.append(row)
    note = "" if view.n_events <= MAX_EVENT_ROWS else f"<p class=note>The first {MAX_EVENT_ROWS} of {view.n_events} events; the file has them all.</p>"
    s.add(table(headers, rows, cls="events", id=source.name("event-table" + (f"-{view.label}" if view.label else "")), numeric=numeric,
                caption="Events (approach speed as |relative velocity|; for impacts Johnson's bounds estimate the impulsive "
                        "peak, the simulated peak minus the preload the interface holds at rest, and the simulated peak is "
                        "the event table's, preload included; – where a column does not apply to the kind of event, and for "
                        "an impact's contact duration where the contact is still closed when the recording ends: it "
                        "outlasts the recorded revolutions)") + note)
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
    forces = [p for p in paths if p.startswith("elements/") and view.units(p) == "N"]
    if forces:
        groups.append(("Element forces", "elements", forces))
    stresses = [p for p in paths if p.startswith("elements/") and view.units(p) == "Pa"]  # issue 39: a rod's stress
    if stresses:
        groups.append(("Element stresses", "stress", stresses))
    contact = [p for p in ("cam_contact/force", "transducer/force") if p in paths]
    contact += [p for p in paths if p.startswith("cams/") and p.endswith("/contact_force")]  # issue 38
    if contact:
        groups.append(("Cam contact and transducer force", "contact", contact))
    loads = [p for p in paths if p.startswith("loads/")]  # issue 43: process loads
    if loads:
        groups.append(("Process loads", "loads", loads))
    return groups


def _series_label(path: str) -> str:
    parts = path.split("/")
    if path.startswith("elements/") and len(parts) > 2 and parts[2] != "force":  # a rod's end forces, stress
        return f"{parts[1]} {parts[2].replace('_', ' ')}"
    if path.startswith("masses/") or path.startswith("elements/") or path.startswith("loads/"):
        return parts[1]
    if path.startswith("cams/"):  # issue 38
        return f"cam {parts[1]}"
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
        unit = source.show(1.0, unit_si).unit
        series = []
        reduced = False
        for view in views:
            for path in members:
                y = view.data(path)
                if y is None:
                    continue
                x, yy, r = envelope(view.time, source.show(y, view.units(path)).values)
                reduced |= r
                label = _series_label(path) + (f" ({view.label})" if len(views) > 1 else "")
                series.append((label, x, yy))
        note = (f"{n} samples per trace, drawn as their min/max envelope over {DEFAULT_COLUMNS} screen columns: "
                "peaks are never lost" if reduced else "")
        name = source.name(f"trace-{q}")
        quantity = q if q in ("displacement", "velocity", "acceleration", "stress") else "force"
        p = trace_figure(name, title_, source.show(1.0, unit_si).label(quantity), series, x_range=x_range, angle_axis=main.angle_axis(),
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
    offsets, labels, names, partners = [0], [], {}, []
    a_unit = source.show(1.0, "m/s^2").unit
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
        # In the page's force unit (issue 44: newtons were drawn under an [lbf] label).
        cols["force"].append(source.show(force_ds[k0:k1], "N").values if force_ds is not None else np.full(t.size, np.nan))
        masses = [m for m in str(view.event(i, "masses")).split("/") if m and m != "ground"]
        partners.append([m or "–" for m in (masses + [None, None])[:2]])
        for key, m in zip(("acc_a", "acc_b"), masses + [None, None]):
            ds = view.traces.get(f"masses/{m}/acceleration") if m else None
            cols[key].append(source.show(ds[k0:k1], "m/s^2").values if ds is not None else np.full(t.size, np.nan))
        offsets.append(offsets[-1] + t.size)
        labels.append((str(j), f"t = {t_i:.5f} s, {element} ({view.event(i, 'masses')}), approach "
                               f"{source.text(abs(float(view.event(i, 'relative_velocity'))), 'm/s')}"))
        names[i] = j
    every = {k: np.concatenate(v).astype(float) for k, v in cols.items()}
    everything = models.ColumnDataSource(every)
    first = {k: v[offsets[0]:offsets[1]] for k, v in every.items()}
    shown_src = models.ColumnDataSource(first)
    sel = models.Select(title="Impact shown at full resolution", value="0", options=labels, name=source.name("impact-select"))
    legend_items = []
    plotting, _ = bokeh()
    f_unit = source.show(1.0, "N").unit
    figures, x_range = [], None
    if has_force:
        pf = trace_figure(source.name("impact-detail-force"), "Impacting element force (full resolution)", f"force [{f_unit}]", [])
        pf.line("t", "force", source=shown_src, legend_label="element force", line_width=1.6, line_color=PALETTE[0])
        figures.append(pf)
        x_range = pf.x_range
    if has_acc:
        pa = trace_figure(source.name("impact-detail-acceleration"), "Accelerations of the impacting masses (full resolution)",
                          f"acceleration [{a_unit}]", [], x_range=x_range)
        # The legend names the masses of the impact shown (M2, M3), updated with the choice.
        pa.line("t", "acc_a", source=shown_src, legend_label=partners[0][0], line_width=1.6, line_color=PALETTE[1])
        pa.line("t", "acc_b", source=shown_src, legend_label=partners[0][1], line_width=1.6, line_color=PALETTE[2],
                line_dash="dashed")
        legend_items = list(pa.legend[0].items)
        figures.append(pa)
    for p in figures:
        finish_legend(p)
    sel.js_on_change("value", models.CustomJS(
        args={"all": everything, "shown": shown_src, "offsets": offsets, "items": legend_items, "partners": partners},
        code="""
        const k = parseInt(cb_obj.value), a = offsets[k], b = offsets[k + 1], d = {};
        for (const c of Object.keys(all.data)) d[c] = all.data[c].slice(a, b);
        shown.data = d;
        for (let j = 0; j < items.length; j++) items[j].label = {value: partners[k][j]};
    """))
    from bokeh.layouts import column

    s = Section(source.name("detail"), "Impact detail (full resolution)")
    note = "" if len(rows) <= MAX_DETAIL_IMPACTS else f" The {MAX_DETAIL_IMPACTS} impacts with the largest approach speeds of {len(rows)} are offered."
    s.add(f"<p class=note>Every sample around the chosen impact, {dt * 1e6:.3g} µs apart (no envelope).{note} "
          "Choose an impact in the list or with the detail button of the event table.</p>")
    box = column(sel, *figures, sizing_mode="stretch_width", name=source.name("impact-detail"))
    s.add(Plot(box, f"The force of the impacting element [{f_unit}] and the accelerations of the masses it joins [{a_unit}] "
                    "against time [s], every sample around the chosen impact."))
    return s, names


#: The short axis labels of the SVAJ panels.
SVAJ_SYMBOL = {"displacement": "s", "velocity": "v", "acceleration": "a", "jerk": "j"}


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
        shown = source.show(y[one], unit_si)
        unit = shown.unit
        x, yy, _ = envelope(angle[one], shown.values)
        # A short label (s, v, a, j; the title names the quantity): a low plot, lower still on
        # paper, never cuts it ("displacem").
        p = xy_figure(source.name(f"svaj-{q}"), f"Cam {q} (model axis)", "cam angle [deg]", f"{SVAJ_SYMBOL[q]} [{unit}]", [(q, x, yy)],
                      height=190, x_range=x_range)
        x_range = p.x_range
        p.legend.visible = False
        s.add(Plot(p, f"Cam {q} [{unit}] against cam angle [deg] over one revolution."))
    surface, pitch = view.traces.get("cam/surface"), view.traces.get("cam/pitch_curve")
    length = source.show(1.0, "m").unit
    if surface is not None:
        curves = []
        for label, ds in (("cam surface", surface), ("pitch curve", pitch)):
            if ds is None:
                continue
            xy = source.show(ds[()][one], "m").values
            idx = np.unique(np.concatenate([np.linspace(0, xy.shape[0] - 1, 1500).astype(int)]))
            curves.append((label, xy[idx, 0], xy[idx, 1]))
        p = xy_figure(source.name("cam-profile"), "Cam drawn to scale (cam frame)", f"x [{length}]", f"y [{length}]", curves, equal=True)
        s.add(Plot(p, f"The cam surface and the pitch curve in the cam frame, x and y in {length}, equal scales."))
    return s


def machine_section(source: Source, text: str) -> Section:
    s = Section(source.name("machine"), "Machine file")
    return s.add(f"<details><summary>The machine file of the run (TOML, {len(text.splitlines())} lines)</summary><pre>{esc(text)}</pre></details>")


def _hub(source: Source, view: RunView) -> tuple[dict | None, dict | None]:
    """The hub's cam design summary (with a geometry) and its run summary (rods' stresses), when the
    file holds every trace; (None, None) otherwise (--record/--summary-only: /summary still shows)."""
    if source.path is None:
        return None, None
    from camsim.errors import ResultFileError
    from camsim.run.result import open_result

    try:
        result = open_result(source.path, view.label or None)
    except ResultFileError:
        return None, None
    design = result.design_summary() if getattr(getattr(view.machine, "cam", None), "geometry", None) is not None else None
    return design, (result.summary() if any(e.compound for e in view.machine.elements) else None)


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
    extra = [("sample rate", esc(engineering(float(_attr(f, 'sample_rate')), "Hz"))), ("speed", _speed(source, machine)),
             ("variant", "no-impact" if _attr(f, "no_impact", False) else "with impact"),
             ("traces stored", _stored_text(view, recorded))]
    design, hub = _hub(source, view)
    out = [header_section(source, machine.name, extra), verdict_section(source, view, design, hub=hub)]
    detail, names = impact_detail_section(source, view)
    out.append(event_section(source, view, names))
    if len(view.traces) > 1:
        out.append(trace_section(source, [view])[0])
    if detail is not None:
        out.append(detail)
    cam = cam_section(source, view)
    if cam is not None:
        out.append(cam)
    from camsim.reports.camshaft import camshaft_section  # issue 38

    shaft = camshaft_section(source, view)
    if shaft is not None:
        out.append(shaft)
    from camsim.reports.loads import loads_section  # issue 43

    loads = loads_section(source, view)
    if loads is not None:
        out.append(loads)
    from camsim.reports.friction import friction_section  # issue 43

    friction = friction_section(source, view)
    if friction is not None:
        out.append(friction)
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
    out = [header_section(source, machine.name, [("speed", _speed(source, machine))])]
    # The difference table: each summary scalar of both runs and the change.
    s = Section(source.name("difference"), "Impact against no impact")
    rows = []
    for name, a in imp.summary.items():
        if name not in non.summary:
            continue
        b = non.summary[name]
        si_unit = str(imp.summary_units.get(name, ""))
        column, unit = source.column("value", si_unit), source.show(1.0, si_unit).unit or "-"
        if isinstance(a, (bool, np.bool_)) or name in ("impacts", "jump"):
            rows.append([esc(name), column.cell(a), column.cell(b), "–", esc(unit)])
            continue
        a, b = float(a), float(b)
        change = (a - b) / abs(b) if b not in (0.0,) and np.isfinite(b) else float("nan")
        rows.append([esc(name), column.cell(a), column.cell(b),
                     f"<span class=derived data-of='change'>{fmt(100.0 * change, '+.3g')}</span>", esc(unit)])
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

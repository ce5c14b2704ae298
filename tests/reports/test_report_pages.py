"""Report pages in a real browser: offline load, plots drawn, numbers equal the file's, zoom.

References: the numbers are checked against the result file read here with h5py (the
event table and ``/summary``), with the page's units converted by pint from the column
headers (an independent unit library); the page shows 4 significant digits, so values
agree to 5e-4 relative (times to 1e-6 s, printed with 6 decimals).
"""

from __future__ import annotations

import math
import re

import h5py
import numpy as np
import pint
import pytest

from conftest import CANVASES_JS

UREG = pint.UnitRegistry()
#: Relative agreement of a value shown with 4 significant digits.
RTOL = 5e-4


def to_si(value: float, unit: str, si_unit: str) -> float:
    """``value`` in ``unit`` (as shown on the page) converted to ``si_unit`` by pint."""
    unit = unit.replace("²", "**2").replace("³", "**3").replace("·", "*")
    if unit in ("-", ""):
        return value
    return UREG.Quantity(value, unit).to(si_unit.replace("^", "**")).magnitude


def number(text: str) -> float:
    text = text.strip().replace("−", "-")
    if text in ("–", ""):
        return math.nan
    return float(text.split()[0])


def table_cells(page, table_id: str) -> tuple[list[str], list[list[str]]]:
    headers = page.eval_on_selector_all(f"#{table_id} thead th", "els => els.map(e => e.textContent)")
    rows = page.eval_on_selector_all(f"#{table_id} tbody tr",
                                     "rows => rows.map(r => [...r.querySelectorAll('td')].map(td => td.firstChild ? td.firstChild.textContent : ''))")
    return headers, rows


def close(shown: float, true: float, rtol: float = RTOL, atol: float = 0.0) -> bool:
    if math.isnan(true):
        return math.isnan(shown)
    return math.isclose(shown, true, rel_tol=rtol, abs_tol=atol)


# ---------------------------------------------------------------------- loading
@pytest.mark.parametrize("fixture", ["cdtm_run", "cdtm_compare"])
def test_page_loads_offline_and_every_plot_draws(fixture, request, open_page):
    """The page opens from file:// with every non-file request aborted, logs no console
    error, requests nothing that fails, and each plot canvas has ink (non-blank pixels)."""
    h5, html = request.getfixturevalue(fixture)
    loaded = open_page(html)
    assert loaded.blocked == [], f"the page asked the network for {loaded.blocked}"
    assert loaded.failed == [] and loaded.errors == []
    names = loaded.page.eval_on_selector_all("[data-plot]", "els => els.map(e => e.dataset.plot)")
    assert names, "no plot on the page"
    canvases = loaded.page.evaluate(CANVASES_JS)
    plots = [c for c in canvases if c["w"] > 200 and c["h"] > 100]
    # Each Bokeh plot paints on at least one large canvas layer; a blank layer has no ink.
    assert len(plots) >= len(names)
    assert sum(1 for c in plots if c["ink"] > 1000) >= len(names)
    text = html.read_text(encoding="utf-8")
    assert "cdn.bokeh.org" not in text and "<script src=" not in text and "<link " not in text


# ---------------------------------------------------------------------- numbers
def test_run_page_event_table_equals_file(cdtm_run, open_page):
    """Every event row on the page equals the file's /events row (time, angle, element,
    kind, masses, |relative velocity|, Johnson bounds, simulated peak, duration), units
    converted by pint from the column headers."""
    h5, html = cdtm_run
    page = open_page(html).page
    headers, rows = table_cells(page, "event-table")
    with h5py.File(h5, "r") as f:
        ev = f["events"][()]
    assert len(rows) == len(ev) > 0
    columns = ["time", "angle_deg", "element", "kind", "masses", "relative_velocity", "johnson_lower",
               "johnson_upper", "peak_force", "impulsive", "contact_duration"]
    si = {"time": "s", "angle_deg": "deg", "relative_velocity": "m/s", "johnson_lower": "N", "johnson_upper": "N",
          "peak_force": "N", "contact_duration": "s"}
    for k, row in enumerate(rows):
        for j, col in enumerate(columns):
            if col == "impulsive":  # peak minus preload: tests/reports/test_report_numbers.py
                continue
            true = ev[col][k]
            if col not in si:
                assert row[j].strip() == (true.decode() if isinstance(true, bytes) else str(true))
                continue
            unit = re.search(r"\[(.+)\]", headers[j]).group(1)
            true = abs(float(true)) if col == "relative_velocity" else float(true)
            shown = to_si(number(row[j]), unit, si[col]) if not math.isnan(number(row[j])) else math.nan
            tol = {"time": (0, 1e-6), "angle_deg": (0, 0.006)}.get(col, (RTOL, 0))
            assert close(shown, true, *tol), (col, k, row[j], true)


def test_run_page_summary_and_verdicts_equal_file(cdtm_run, open_page):
    """The summary table and the verdict numbers equal /summary of the file (pint units)."""
    h5, html = cdtm_run
    page = open_page(html).page
    _, rows = table_cells(page, "summary-table")
    with h5py.File(h5, "r") as f:
        attrs = dict(f["summary"].attrs)
    shown_names = set()
    for name_cell, value, unit in rows:
        name = name_cell.strip()
        shown_names.add(name)
        true = attrs[name]
        if isinstance(true, (bool, np.bool_)):
            assert value.strip() == ("yes" if true else "no")
            continue
        si_unit = attrs[f"units:{name}"] or "-"
        assert close(to_si(number(value), unit.strip(), si_unit), float(true)), (name, value, unit, true)
    assert {k for k in attrs if not k.startswith("units:")} - {"recorded", "record_last", "warnings", "notes"} == shown_names
    spans = page.eval_on_selector_all(".verdict .value", "els => els.map(e => [e.dataset.key, e.textContent, e.dataset.unit || ''])")
    keys = {k for k, _, _ in spans}
    assert {"impacts", "max_impact_velocity", "min_cam_contact_force", "periodicity_residual"} <= keys
    for key, text, unit in spans:
        if key in attrs:
            si_unit = attrs.get(f"units:{key}") or "-"
            assert close(to_si(number(text), unit or "-", si_unit), float(attrs[key]), rtol=2e-3), (key, text)
        if key == "largest_peak_force":
            with h5py.File(h5, "r") as f:
                assert close(to_si(number(text), unit, "N"), float(np.nanmax(f["events"]["peak_force"]))), text
    # The verdict names the run's speed: 120 rpm in the CDTM machine file.
    assert page.eval_on_selector("[data-key=speed_rpm]", "e => e.textContent") == "120"


def test_compare_page_difference_table_equals_file(cdtm_compare, open_page):
    """The difference table holds both runs' /summary values (pint units) and the change
    100·(a − b)/|b| computed here from the file's values."""
    h5, html = cdtm_compare
    page = open_page(html).page
    _, rows = table_cells(page, "difference-table")
    with h5py.File(h5, "r") as f:
        a = dict(f["impact/summary"].attrs)
        b = dict(f["no_impact/summary"].attrs)
    assert rows
    for name, va, vb, change, unit in rows:
        name = name.strip()
        if isinstance(a[name], (bool, np.bool_)) or name == "impacts":
            continue
        si_unit = a[f"units:{name}"] or "-"
        assert close(to_si(number(va), unit.strip(), si_unit), float(a[name]))
        assert close(to_si(number(vb), unit.strip(), si_unit), float(b[name]))
        if np.isfinite(b[name]) and b[name] != 0 and not math.isnan(number(change)):
            true = 100.0 * (float(a[name]) - float(b[name])) / abs(float(b[name]))
            assert math.isclose(number(change), true, rel_tol=5e-3, abs_tol=5e-3 * max(1.0, abs(true)))


# ---------------------------------------------------------------------- interaction
X_RANGE_JS = "n => { const m = Bokeh.documents[0].get_model_by_name(n); return [m.x_range.start, m.x_range.end]; }"


def test_wheel_zoom_changes_range_and_linked_plots_follow(cdtm_run, open_page):
    """A wheel turn over the acceleration plot narrows its time range; the displacement
    and force plots (shared axis) show the same range afterwards."""
    h5, html = cdtm_run
    page = open_page(html).page
    before = page.evaluate(X_RANGE_JS, "trace-acceleration")
    plot = page.locator("[data-plot=trace-acceleration]")
    plot.scroll_into_view_if_needed()
    box = plot.bounding_box()
    page.mouse.move(box["x"] + box["width"] * 0.5, box["y"] + box["height"] * 0.5)
    for _ in range(3):
        page.mouse.wheel(0, -300)
        page.wait_for_timeout(100)
    after = page.evaluate(X_RANGE_JS, "trace-acceleration")
    assert after[1] - after[0] < 0.9 * (before[1] - before[0])
    for other in ("trace-displacement", "trace-elements", "trace-contact"):
        assert page.evaluate(X_RANGE_JS, other) == after


def test_impact_detail_shows_full_resolution_window(cdtm_run, open_page):
    """Choosing an impact (its detail button) fills the detail plot with every sample
    around that impact: the shown times are consecutive file samples around the event."""
    h5, html = cdtm_run
    page = open_page(html).page
    with h5py.File(h5, "r") as f:
        time = f["time"][()]
        ev = f["events"][()]
    buttons = page.locator("#event-table button.show-impact")
    assert buttons.count() >= 2
    buttons.nth(1).click()
    page.wait_for_timeout(200)
    t = page.evaluate("""() => { const p = Bokeh.documents[0].get_model_by_name('impact-detail-force');
                         return Array.from(p.renderers[0].data_source.data.t); }""")
    kinds = [k.decode() for k in ev["kind"]]
    impact_times = [float(ev["time"][i]) for i, k in enumerate(kinds) if k in ("impact", "rejoin")]
    assert t[0] < impact_times[1] < t[-1]
    k0 = int(np.searchsorted(time, t[0]))
    np.testing.assert_array_equal(np.array(t), time[k0:k0 + len(t)])


# ---------------------------------------------------------------------- sections
@pytest.mark.parametrize("fixture, expected", [
    ("cdtm_run", ["header", "verdicts", "events", "traces", "detail", "cam", "machine"]),
    ("cdtm_compare", ["header", "difference", "verdicts-impact", "events-impact", "traces", "difference-traces", "machine"]),
])
def test_page_has_its_sections(fixture, expected, request):
    """Each kind's page has the sections issue 29 lists, each with a heading."""
    h5, html = request.getfixturevalue(fixture)
    text = html.read_text(encoding="utf-8")
    for sid in expected:
        assert f'<section id="{sid}"' in text and f'id="{sid}-h"' in text, sid
    assert text.count('role="img" aria-label=') >= 3


# ---------------------------------------------------------------------- print
@pytest.mark.slow
@pytest.mark.parametrize("fixture", ["cdtm_run", "cdtm_compare"])
def test_printed_pdf_fits_its_sections_and_clips_no_table(fixture, request, browser, tmp_path):
    """``--pdf`` through Chromium: the PDF has no more pages than the page has sections
    (pages counted as /Type /Page objects of the PDF), and under print media no table is
    wider than its box (nothing cut at the right edge)."""
    import subprocess
    import sys

    from camsim.reports.browser import wait_rendered

    h5, _ = request.getfixturevalue(fixture)
    html, pdf = tmp_path / "page.html", tmp_path / "page.pdf"
    # A process of its own: this one already drives the session's browser (Playwright's
    # sync API runs one driver per thread).
    r = subprocess.run([sys.executable, "-m", "camsim", "report", str(h5), "-o", str(html), "--pdf", str(pdf)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF")
    pages = len(re.findall(rb"/Type\s*/Page[^s]", data))
    sections = html.read_text(encoding="utf-8").count("<section id=")
    assert 1 <= pages <= sections, (pages, sections)
    ctx = browser.new_context(viewport={"width": 1047, "height": 718})  # A4 landscape, 10 mm margins, at 96 dpi
    try:
        page = ctx.new_page()
        page.goto(html.resolve().as_uri())
        wait_rendered(page)
        page.emulate_media(media="print")
        page.wait_for_timeout(300)
        boxes = page.evaluate("""() => [...document.querySelectorAll('.table-wrap')].map(w => {
            const t = w.querySelector('table'); return [t.id, t.scrollWidth, w.clientWidth, document.body.clientWidth]; })""")
    finally:
        ctx.close()
    assert boxes
    for table_id, table_width, box_width, body_width in boxes:
        assert table_width <= box_width + 1 and box_width <= body_width + 1, table_id


def test_partial_runs_on_one_page(tmp_path, open_page):
    """A run stored with --record (some traces) and one with --summary-only (none) on one
    page: it loads without console error, the --record file's plots are drawn, and the
    summary-only file's summary table equals its /summary (the hub's scalars over every
    revolution)."""
    from typer.testing import CliRunner

    from camsim.cli import app
    from conftest import CDTM

    fast = ["--warmup", "0", "--sample-rate", "5 kHz", "-q"]
    rec, summ, html = tmp_path / "rec.h5", tmp_path / "summ.h5", tmp_path / "both.html"
    for extra, out in ((["--record", "transducer/*,masses/M3/*"], rec), (["--summary-only"], summ)):
        r = CliRunner().invoke(app, ["run", str(CDTM), "-o", str(out), *fast, *extra])
        assert r.exit_code == 0, r.output
    r = CliRunner().invoke(app, ["report", str(rec), str(summ), "-o", str(html)])
    assert r.exit_code == 0, r.output
    loaded = open_page(html)
    assert loaded.errors == [] and loaded.failed == [] and loaded.blocked == []
    names = loaded.page.eval_on_selector_all("[data-plot]", "els => els.map(e => e.dataset.plot)")
    assert "f0-trace-acceleration" in names and not any(n.startswith("f1-") for n in names)
    _, rows = table_cells(loaded.page, "f1-summary-table")
    with h5py.File(summ, "r") as f:
        attrs = dict(f["summary"].attrs)
    for name, value, unit in rows:
        if isinstance(attrs[name.strip()], (bool, np.bool_)):
            continue
        assert close(to_si(number(value), unit.strip(), attrs[f"units:{name.strip()}"] or "-"), float(attrs[name.strip()])), name

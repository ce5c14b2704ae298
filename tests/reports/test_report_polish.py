"""The report polish of issue 36 on the CDTM run page: legends clear of the traces, the
impact partners named, frequencies with a prefix, the envelope note, one typographic form.

References: the file itself (the trace length, the sample rate, the event table's masses,
read with h5py); Bokeh's own model (where each legend sits); Chromium for the legend that
follows the chosen impact.
"""

from __future__ import annotations

import json
import re

import h5py
import pytest


def _plots(h5):
    """The Bokeh models of the run page's sections, layouts opened."""
    from camsim.io.results import file_display_units, open_h5
    from camsim.reports.build import sections_for
    from camsim.reports.page import Plot, Source

    with open_h5(h5) as f:
        sections = sections_for(Source(h5, "run", h5=f, units=file_display_units(f)))
    out = []

    def walk(model):
        if hasattr(model, "renderers"):
            out.append(model)
        for child in getattr(model, "children", None) or ():
            walk(child)

    for s in sections:
        for b in s.blocks:
            if isinstance(b, Plot):
                walk(b.model)
    return out


def test_legends_sit_above_the_plots(cdtm_run):
    """No legend inside a plot frame (over the traces); every labelled plot has one above it."""
    from bokeh.models import Legend

    plots = _plots(cdtm_run[0])
    assert len(plots) >= 10
    labelled = 0
    for p in plots:
        assert not [r for r in p.center if isinstance(r, Legend)], p.name
        above = [r for r in p.above if isinstance(r, Legend)]
        labelled += bool(above)
        for legend in above:
            assert legend.items, p.name  # an empty legend is not left above a plot
    assert labelled >= 6


def test_impact_detail_names_the_masses_of_the_impact(cdtm_run, open_page):
    """The accelerations of the impact detail are labelled with the two masses of the impact
    shown (the file's event table: M2/M3 for the first, a K23 rejoin), never "first mass";
    choosing a seat impact (ground/M3) relabels them M3 and –."""
    h5, html = cdtm_run
    with h5py.File(h5, "r") as f:
        ev = f["events"][()]
    impacts = [i for i, k in enumerate(ev["kind"]) if k.decode() in ("impact", "rejoin")]
    masses = [ev["masses"][i].decode() for i in impacts]
    assert masses[0] == "M2/M3" and masses[1] == "ground/M3"
    text = html.read_text(encoding="utf-8")
    assert "first mass" not in text and "second mass" not in text
    page = open_page(html).page
    labels_js = """() => { const p = Bokeh.documents[0].get_model_by_name('impact-detail-acceleration');
        const legend = p.above.find(r => r.items !== undefined);
        return legend.items.map(i => i.label.value); }"""
    select = "v => { const m = Bokeh.documents[0].get_model_by_name('impact-select'); m.value = v; }"
    page.evaluate(select, "0")
    assert page.evaluate(labels_js) == ["M2", "M3"]
    page.evaluate(select, "1")
    page.wait_for_timeout(100)
    assert page.evaluate(labels_js) == ["M3", "–"]
    page.evaluate(select, "0")


def test_header_envelope_note_and_typography(cdtm_run):
    """The sample rate as 50 kHz (the file's 50000 Hz), the envelope note with the trace's own
    length, and no m/s^3, m/s**2 or N*m anywhere on the page (text and axis labels)."""
    h5, html = cdtm_run
    with h5py.File(h5, "r") as f:
        n, rate = f["time"].shape[0], float(f.attrs["sample_rate"])
    assert rate == 50000.0
    text = html.read_text(encoding="utf-8")
    assert "<dd>50 kHz</dd>" in text and not re.search(r"(?<![\d.])5e\+04 Hz", text)
    assert f"{n} samples per trace, drawn as their min/max envelope over 2000 screen columns" in text
    assert "per screen column of" not in text
    labels = [json.loads(f'"{label}"') for label in re.findall(r'"axis_label":"([^"]*)"', text)]
    visible = re.sub(r"<script.*?</script>|<pre>.*?</pre>", " ", text, flags=re.S)
    for t in [visible, *labels]:
        assert not re.search(r"\w(\^|\*\*)[23]|N\*m|N\*s", t), t[:200]
    assert any(label.endswith("[in/s²]") for label in labels)
    # a low plot keeps a short label: the SVAJ panels are s, v, a, j
    assert {"s [in]", "v [in/s]", "a [in/s²]", "j [in/s³]"} <= set(labels)


@pytest.mark.parametrize("system, force", [("si", "N"), ("us", "lbf")])
def test_report_units_option(cdtm_run, tmp_path, system, force):
    """``camsim report --units si|us`` re-shows the same file in those units."""
    from typer.testing import CliRunner

    from camsim.cli import app

    out = tmp_path / f"{system}.html"
    r = CliRunner().invoke(app, ["report", str(cdtm_run[0]), "-o", str(out), "--units", system])
    assert r.exit_code == 0, r.output
    text = out.read_text(encoding="utf-8")
    assert f"simulated peak (with preload) [{force}]" in text and f"impulsive peak [{force}]" in text

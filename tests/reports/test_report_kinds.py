"""Sweep, study and fit pages: their sections, and the numbers of their tables against
the result (the sweep table and the study's /study attributes read here with h5py; the
fit's values from a FitResult whose numbers are written in this test).

Tolerance: the page shows 4 significant digits (6 for fitted values), so 5e-4 relative.
The page text is parsed with Python's html.parser (no browser); loading the pages in
Chromium is the slow test at the end.
"""

from __future__ import annotations

import json
import math
import re
from html.parser import HTMLParser

import h5py
import numpy as np
import pytest

from conftest import CANVASES_JS

RTOL = 5e-4


class Tables(HTMLParser):
    """Tables of a page by id: header texts and cell texts."""

    def __init__(self):
        super().__init__()
        self.tables, self._id, self._cell, self._row, self.sections = {}, None, None, None, []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "section":
            self.sections.append(a.get("id"))
        if tag == "table" and a.get("id"):
            self._id = a["id"]
            self.tables[self._id] = {"head": [], "rows": []}
        elif self._id and tag == "tr":
            self._row = []
        elif self._id and tag in ("td", "th"):
            self._cell = ""

    def handle_endtag(self, tag):
        if self._id is None:
            return
        if tag in ("td", "th") and self._cell is not None:
            self._row.append(self._cell.strip())
            self._cell = None
        elif tag == "tr" and self._row is not None:
            t = self.tables[self._id]
            (t["rows"] if t["head"] else t["head"]).extend([self._row] if t["head"] else self._row)
            self._row = None
        elif tag == "table":
            self._id = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data


def parse(html_path) -> Tables:
    p = Tables()
    p.feed(html_path.read_text(encoding="utf-8"))
    return p


def si(value: float, unit: str, si_unit: str) -> float:
    """``value`` shown in ``unit`` back in ``si_unit``, by pint (the reference conversion)."""
    if unit in ("", "-") or not si_unit or math.isnan(value):
        return value
    from camsim.units import registry

    unit = unit.replace("²", "**2").replace("³", "**3").replace("·", "*")
    return float(registry().Quantity(value, unit).to(si_unit.replace("^", "**")).magnitude)


def num(text: str) -> float:
    text = text.replace("−", "-").strip()
    return math.nan if text in ("–", "") else float(text)


@pytest.mark.slow  # a 3-point sweep: about 10 s on a shared machine
def test_sweep_page_sections_and_table(cdtm_sweep):
    """Sections of a sweep page; every cell of its table equals /sweep/summary, converted by
    pint from the unit its header names (the machine file's units: speed in rpm, lengths in
    in, forces in lbf; issue 36), the jump marked."""
    h5, html = cdtm_sweep
    page = parse(html)
    assert {"header", "verdicts", "columns", "table", "machine"} <= set(page.sections)
    t = page.tables["sweep-table"]
    with h5py.File(h5, "r") as f:
        rows = f["sweep/summary"][()]
        first = float(f["sweep/summary"].attrs["first_jump_rpm"])
        units = {n: f["sweep/summary"].attrs[f"units:{n}"] for n in rows.dtype.names}
    assert len(t["rows"]) == len(rows) == 3
    shown = {}
    for j, name in enumerate(rows.dtype.names):
        assert t["head"][j].startswith(name)
        shown[name] = t["head"][j][len(name):].strip(" []")
        for i, cells in enumerate(t["rows"]):
            v = rows[name][i]
            if name == "status":
                assert cells[j] == v.decode()
            elif rows.dtype[name].kind == "b":
                assert cells[j] == ("yes" if v else "no")
            else:
                true = float(v)
                value = si(num(cells[j]), shown[name], units[name])
                assert math.isclose(value, true, rel_tol=RTOL) or (math.isnan(true) and math.isnan(value))
    assert shown["param:cam.speed"] == "rpm" and shown["peak_transducer_force"] == "lbf"
    assert 300 <= first <= 500, "the CDTM jumps between 300 and 500 rpm (README: about 400 rpm)"
    assert re.search(rf"data-key='first_jump_rpm'[^>]*data-unit='rpm'>{first:.4g}<", html.read_text())


@pytest.mark.slow  # 16 runs
def test_study_page_sections_and_numbers(cdtm_study):
    """Sections of a study page; the limit's probability and interval and the statistics
    equal /study/summary_json; one histogram per output that varies, the Sobol' bars."""
    h5, html = cdtm_study
    page = parse(html)
    assert {"header", "limits", "statistics", "histograms", "sobol", "machine"} <= set(page.sections)
    with h5py.File(h5, "r") as f:
        payload = json.loads(f["study"].attrs["summary_json"])
    (lim,) = payload["limits"]
    (row,) = page.tables["limits-table"]["rows"]
    assert row[0] == lim["expr"] and int(row[1]) == lim["crossed"] and int(row[2]) == lim["n"]
    assert math.isclose(num(row[3]), 100 * lim["probability"], rel_tol=RTOL, abs_tol=1e-12)
    lo, hi = (num(x) for x in row[4].split(" to "))
    assert math.isclose(lo, 100 * lim["ci95"][0], rel_tol=RTOL, abs_tol=1e-12)
    assert math.isclose(hi, 100 * lim["ci95"][1], rel_tol=RTOL)
    stats = {r[0]: r for r in page.tables["statistics-table"]["rows"]}
    o = payload["outputs"]["peak_transducer_force"]
    r = stats["peak_transducer_force"]
    assert r[1] == "lbf"  # issue 36: the unit written first for a force (--dist ...:3lbf before the limit in N)
    for col, true in ((2, o["mean"]), (4, o["std"]), (5, o["percentiles"]["5"]), (7, o["percentiles"]["95"]), (8, o["min"]), (9, o["max"])):
        assert math.isclose(si(num(r[col]), "lbf", "N"), true, rel_tol=RTOL)
    r = stats["peak_displacement:M3"]
    assert r[1] == "in" and math.isclose(si(num(r[2]), "in", "m"), payload["outputs"]["peak_displacement:M3"]["mean"], rel_tol=RTOL)
    text = html.read_text()
    varying = [k for k, v in payload["outputs"].items() if v["std"]]
    for k in varying:
        assert f'data-plot="hist-{k.replace(":", "-")}"' in text
    assert 'data-plot="sobol-total"' in text


def _fit_result():
    """A FitResult with numbers chosen here (the page only shows them)."""
    from camsim.analyses.fit import FitResult

    t = np.linspace(0.0, 0.1, 201)
    measured = 100.0 * np.sin(40 * t) + 0.5 * np.cos(900 * t)
    fitted = 100.0 * np.sin(40 * t)
    return FitResult(
        keys=["element.K23.push_stiffness", "element.seat.damping_ratio"], units=["N/m", ""],
        values=np.array([1.33056e6, 0.0996383]), initial=np.array([1.42623e6, 0.06]), file_values=np.array([1.42623e6, 0.06]),
        stderr=np.array([3.93e3, 6.42e-4]), ci95=np.array([[1.32286e6, 1.33826e6], [0.0983805, 0.100896]]),
        correlation=np.array([[1.0, -0.39], [-0.39, 1.0]]), bounds=[(1e6, 2e6), (0.01, 0.3)], log=[False, False],
        cost=4777.1, rms_residual={"transducer/force": 0.5 / math.sqrt(2)}, sigma={"transducer/force": 0.36},
        n_evaluations=20, converged=True, message="`ftol` termination condition is satisfied.", warnings=["a warning line"],
        condition=1.51, residual_variance=0.9554, dof=199, channels=[("transducer/force", t, measured, fitted)],
    )


def test_fit_page_sections_and_numbers(tmp_path):
    """The fit page (built from an in-memory FitResult, as ``fit --report x.html`` does)
    shows each parameter's values and interval as given, and its sections."""
    pytest.importorskip("bokeh")
    from conftest import CDTM

    from camsim.reports.build import build_report_from

    from camsim.units import registry

    ureg = registry()
    result = _fit_result()
    out = build_report_from((result, CDTM, CDTM.read_text()), "fit", tmp_path / "fit.html")
    page = parse(out)
    assert {"header", "verdicts", "parameters", "channels", "machine"} <= set(page.sections)
    rows = page.tables["parameter-table"]["rows"]
    # issue 36: in the machine file's units (cdtm.toml: lbf/in), converted back here by pint
    assert [row[1] for row in rows] == ["lbf/in", "-"]
    for i, row in enumerate(rows):
        si = (lambda v: ureg.Quantity(v, row[1]).to(result.units[i]).magnitude) if row[1] != "-" else (lambda v: v)
        assert row[0] == result.keys[i]
        assert math.isclose(si(num(row[4])), result.values[i], rel_tol=1e-6)
        assert math.isclose(si(num(row[5])), result.stderr[i], rel_tol=5e-3)
        lo, hi = (si(num(x)) for x in row[6].split(" to "))
        assert math.isclose(lo, result.ci95[i, 0], rel_tol=1e-6) and math.isclose(hi, result.ci95[i, 1], rel_tol=1e-6)
    text = out.read_text()
    # the page is titled and headed with the machine's name, not the machine file's path
    assert "<dd>CDTM with impact and over-travel</dd>" in text and f"<dd>{CDTM}</dd>" not in text
    assert 'data-plot="correlation"' in text and 'data-plot="fit-0-residual"' in text and "a warning line" in text


@pytest.mark.slow
@pytest.mark.parametrize("fixture", ["cdtm_sweep", "cdtm_study"])
def test_sweep_and_study_pages_load_offline_and_draw(fixture, request, open_page):
    """In Chromium with the network blocked: no console error or failed request, every
    plot canvas has ink."""
    h5, html = request.getfixturevalue(fixture)
    loaded = open_page(html)
    assert loaded.blocked == [] and loaded.failed == [] and loaded.errors == []
    names = loaded.page.eval_on_selector_all("[data-plot]", "els => els.map(e => e.dataset.plot)")
    canvases = [c for c in loaded.page.evaluate(CANVASES_JS) if c["w"] > 200 and c["h"] > 100]
    assert names and sum(1 for c in canvases if c["ink"] > 1000) >= len(names)

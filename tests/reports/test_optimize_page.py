"""The page of an optimisation history (``camsim report HISTORY.h5``).

The histories are real: ``camsim optimize`` on ``tests/study/driven_follower.toml`` at
720 rpm, 4.8 kHz (as in ``tests/test_optimize_cli.py``), where the smallest preload keeping
the cam contact force ≥ 5 N is 41.85 N. References:

* the optimum row is found here from ``/optimize/candidates`` itself (the feasible row of
  least objective for ``--minimize``), independently of the builder and of the ``json``
  attribute; the page shows 4 significant digits, so each cell must equal the file's value
  formatted to 4 significant digits;
* the infeasible history asks for a preload in 0–10 N, below the 38.85 N the constraint
  needs, so no candidate is feasible;
* the Pareto history has two objectives, so ``/optimize/front`` exists.

The page text is parsed with Python's html.parser (no browser).
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from test_report_kinds import parse
from typer.testing import CliRunner

from camsim.cli import app

pytest.importorskip("bokeh", reason="bokeh not installed (pip install 'camsim[report]')")

MACHINE = Path(__file__).resolve().parents[1] / "study" / "driven_follower.toml"
RATE = ["--set", "simulation.sample_rate=4.8kHz", "--workers", "1"]
FAST = ["--set", "cam.speed=720rpm", *RATE]
CONSTRAINT = ["--constraint", "min_cam_contact_force>=5N"]


def _history_and_page(d: Path, args: list[str], exit_code: int, fast: list[str] = FAST) -> tuple[Path, Path, object]:
    """Run ``camsim optimize`` (expecting ``exit_code``) into ``d/hist.h5``, then ``camsim report`` it."""
    machine, hist, page = d / "m.toml", d / "hist.h5", d / "page.html"
    shutil.copy(MACHINE, machine)
    r = CliRunner().invoke(app, ["optimize", str(machine), *args, *fast, "-r", str(hist)])
    assert r.exit_code == exit_code, r.output
    rep = CliRunner().invoke(app, ["report", str(hist), "-o", str(page)])
    return hist, page, rep


@pytest.fixture(scope="module")
def feasible(tmp_path_factory):
    """Least preload in 0–100 N with the contact force ≥ 5 N (COBYLA, 7 evaluations)."""
    return _history_and_page(tmp_path_factory.mktemp("opt"), ["--var", "element.closure.preload=0:100N", "--minimize",
                             "param:element.closure.preload", *CONSTRAINT, "--method", "local", "--budget", "30"], 0)


@pytest.fixture(scope="module")
def infeasible(tmp_path_factory):
    """Preload in 0–10 N cannot reach the constraint: exit 1, the history still written."""
    return _history_and_page(tmp_path_factory.mktemp("opt-inf"), ["--var", "element.closure.preload=0:10:5N", "--minimize",
                             "param:element.closure.preload", *CONSTRAINT, "--method", "local", "--budget", "20"], 1)


@pytest.fixture(scope="module")
def pareto(tmp_path_factory):
    """Least preload against highest speed: a four-point front."""
    return _history_and_page(tmp_path_factory.mktemp("opt-pareto"), ["--var", "element.closure.preload=0:100N", "--var",
                             "cam.speed=300:900rpm", "--minimize", "param:element.closure.preload", "--maximize", "param:cam.speed",
                             *CONSTRAINT, "--method", "pareto", "--points", "4", "--budget", "40"], 0, RATE)


def _best_row(hist: Path) -> tuple[dict, dict]:
    """The feasible candidate of least first objective, and the column units, read with h5py."""
    with h5py.File(hist) as f:
        d = f["optimize/candidates"]
        rows = d[()]
        units = {k[6:]: (v.decode() if isinstance(v, bytes) else str(v)) for k, v in d.attrs.items() if k.startswith("units:")}
    objective = next(n for n in rows.dtype.names if n.startswith("objective:"))
    y = np.where(rows["feasible"], rows[objective], np.inf)
    return {n: rows[n][int(np.argmin(y))] for n in rows.dtype.names}, units


def _as_shown(value: float) -> float:
    return float(format(float(value), ".4g"))


def test_page_written_names_method_and_status(feasible):
    """Exit 0; the header names the method and the status as /optimize's attributes say."""
    hist, page, rep = feasible
    assert rep.exit_code == 0, rep.output
    text = page.read_text(encoding="utf-8")
    with h5py.File(hist) as f:
        method, status = f["optimize"].attrs["method"], f["optimize"].attrs["status"]
    assert (method, status) == ("local", "optimal")
    assert f"<dt>method</dt><dd><span data-key=method>{method}</span>" in text
    assert f"<dt>status</dt><dd><span data-key=status>{status}</span>" in text
    assert {"header", "verdicts", "convergence", "optimum", "constraints", "candidates", "machine"} <= set(parse(page).sections)
    assert 'data-verdict="optimum"><span class="state">OK</span>' in text


def test_parameter_table_equals_best_row(feasible):
    """Every number of the parameter table equals the best row of /optimize/candidates (4
    significant digits); the file value is the machine file's 20 N."""
    hist, page, _ = feasible
    best, units = _best_row(hist)
    t = parse(page).tables["optimum-table"]
    assert t["head"] == ["key", "unit", "optimum", "file value"]
    keys = [n[6:] for n in best if n.startswith("param:")]
    assert [r[0] for r in t["rows"]] == keys
    for key, unit, shown, file_value in t["rows"]:
        assert units[f"param:{key}"] == "N" and unit == "N"  # a force: shown in SI
        assert float(shown) == _as_shown(best[f"param:{key}"])
    assert abs(best["param:element.closure.preload"] - 41.85) < 0.01  # P + k h − m c = 5 N (driven_follower.toml)
    assert float(t["rows"][0][3]) == 20.0


def test_constraint_and_candidate_tables_equal_file(feasible):
    """The constraint at the optimum (value, limit, satisfied) and every candidate row equal the file's."""
    hist, page, _ = feasible
    best, _ = _best_row(hist)
    tables = parse(page).tables
    (con,) = tables["constraints-table"]["rows"]
    assert con[0] == "min_cam_contact_force>=5N"
    assert float(con[2]) == _as_shown(best["constraint:min_cam_contact_force>=5N"])
    assert con[3] == ">= 5" and con[4] == "N" and con[-1] == "yes"
    with h5py.File(hist) as f:
        rows = f["optimize/candidates"][()]
    cand = tables["candidates-table"]
    assert len(cand["rows"]) == rows.shape[0]
    for i, r in enumerate(cand["rows"]):
        for j, name in enumerate(rows.dtype.names):
            v = rows[name][i]
            if name == "status":
                assert r[j] == v.decode()
            elif name == "feasible":
                assert r[j] == ("yes" if v else "no")
            else:
                assert float(r[j].replace("−", "-")) == _as_shown(v)


def test_convergence_plot_models(feasible):
    """The convergence plot is in the page by its name; feasible and infeasible candidates
    differ in marker and colour, with a best-so-far line (read from the Bokeh model)."""
    hist, page, _ = feasible
    text = page.read_text(encoding="utf-8")
    assert 'data-plot="optimize-convergence"' in text and '"name":"optimize-convergence"' in text
    assert "optimize-front" not in text  # no front without --method pareto
    from camsim.reports.optimize import optimize_sections
    from camsim.reports.page import Plot, Source

    with h5py.File(hist) as f:
        sections = optimize_sections(Source(hist, "optimize", h5=f))
    plot = next(b.model for s in sections for b in s.blocks if isinstance(b, Plot) and b.model.name == "optimize-convergence")
    glyphs = {}
    for item in plot.legend[0].items:
        glyphs[item.label.value] = item.renderers[0].glyph
    feas, infeas = glyphs["feasible"], glyphs["infeasible"]
    assert feas.marker != infeas.marker and feas.line_color != infeas.line_color
    assert type(glyphs["best feasible so far"]).__name__ == "Step"


def test_infeasible_history_says_no_feasible(infeasible):
    """No candidate feasible: the verdict fails with "No feasible candidate", the least-violating
    candidate (the largest preload, 10 N) is the one shown."""
    hist, page, rep = infeasible
    assert rep.exit_code == 0, rep.output
    text = page.read_text(encoding="utf-8")
    assert re.search(r'data-verdict="optimum"><span class="state">FAIL</span>.*?No feasible candidate', text)
    assert "<span data-key=status>infeasible</span>" in text
    with h5py.File(hist) as f:
        rows = f["optimize/candidates"][()]
        assert not rows["feasible"].any()
    least = rows[int(np.argmin(rows["violation"]))]
    shown = parse(page).tables["optimum-table"]["rows"][0][2]
    assert float(shown) == _as_shown(least["param:element.closure.preload"]) == 10.0


def test_pareto_front_plot_and_table(pareto):
    """With /optimize/front: the front plot by its name, and its table equal to the file's
    front (speeds in rpm = rad/s · 60/2π)."""
    hist, page, rep = pareto
    assert rep.exit_code == 0, rep.output
    text = page.read_text(encoding="utf-8")
    assert 'data-plot="optimize-front"' in text and '"name":"optimize-front"' in text
    with h5py.File(hist) as f:
        front = f["optimize/front"][()]
        payload = json.loads(f["optimize"].attrs["json"])
    assert payload["method"] == "pareto"
    t = parse(page).tables["front-table"]
    order = np.argsort(front[front.dtype.names[2]])
    assert len(t["rows"]) == front.shape[0]
    for r, i in zip(t["rows"], order):
        for j, name in enumerate(front.dtype.names):
            scale = 60.0 / (2.0 * np.pi) if "cam.speed" in name else 1.0
            assert t["head"][j].endswith("[rpm]" if scale != 1.0 else "[N]")
            assert float(r[j]) == _as_shown(front[name][i] * scale)

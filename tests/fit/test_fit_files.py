"""Files written by ``camsim fit``: the fitted machine file, the report figure, --json.

* Round trip: the fitted file is the input text with only the fitted lines changed; the
  changed lines keep the unit written and carry the old value and the interval; loading
  the fitted file gives the fitted values (to the 7 significant digits written).
* A value inside an inline table (a cam segment) is replaced and commented on its line.
* The report figure has the same bytes for the same fit; --json has exactly the
  documented keys.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from machines import H, K_TRUE, MASS, OMEGA, OSC_K, OSC_ZETA, OSCILLATOR, P_TRUE
from typer.testing import CliRunner

from camsim.cli import app
from camsim.analyses.fit import fit, fitted_text
from camsim.analyses.fit.measured import write_measured
from camsim.analyses.fit.result import FitResult
from camsim.machine.loader import load_machine_text
from camsim.run.simulation import simulate
from camsim.analyses.sweep.runner import machine_value

runner = CliRunner()


@pytest.fixture
def osc_data(tmp_path):
    machine = load_machine_text(OSCILLATOR.replace("20 N/mm", "21.5 N/mm").replace(f"damping_ratio = {OSC_ZETA!r}", "damping_ratio = 0.07"))
    run = simulate(machine)
    acc = run.masses["M"]["acceleration"] + np.random.default_rng(8).normal(0, 0.5, run.time.size)
    return write_measured(tmp_path / "osc.csv", run.time * 1e3, {"masses/M/acceleration": (acc / 9.80665, "g0")}, time_unit="ms")


def test_fitted_file_keeps_comments_and_units(oscillator, osc_data):
    r = fit(oscillator, osc_data, ["element.K.stiffness=10:40N/mm", "element.K.damping_ratio=0.01:0.2"])
    assert r.converged
    assert r.values[0] == pytest.approx(21500.0, rel=0.01) and r.values[1] == pytest.approx(0.07, abs=0.01)
    text = oscillator.read_text()
    new = fitted_text(text, r, str(oscillator))
    old_lines, new_lines = text.splitlines(), new.splitlines()
    assert len(old_lines) == len(new_lines)
    changed = [i for i, (a, b) in enumerate(zip(old_lines, new_lines)) if a != b]
    assert [old_lines[i].split("=")[0].strip() for i in changed] == ["stiffness", "damping_ratio"]
    stiff = new_lines[changed[0]]
    m = re.match(r'^stiffness = "([0-9.eE+-]+) N/mm" +# fitted: was "20 N/mm"; 95 % CI ([0-9.eE+-]+) to ([0-9.eE+-]+) N/mm \| spring to the cam$', stiff)
    assert m, stiff
    value, lo, hi = (float(g) for g in m.groups())
    assert value == pytest.approx(r.values[0] / 1000, rel=1e-6)
    assert (lo, hi) == pytest.approx(tuple(r.ci95[0] / 1000), rel=1e-6)
    assert new_lines[changed[1]].startswith("damping_ratio = 0.0") and "# fitted: was 0.05; 95 % CI" in new_lines[changed[1]]
    fitted = load_machine_text(new)
    assert machine_value(fitted, "element.K.stiffness") == pytest.approx(r.values[0], rel=1e-6)
    assert machine_value(fitted, "element.K.damping_ratio") == pytest.approx(r.values[1], rel=1e-6)


def _hand_result(keys, values, units, ci, file_values):
    n = len(keys)
    return FitResult(
        keys=keys, units=units, values=np.array(values), initial=np.array(file_values), file_values=np.array(file_values),
        stderr=np.ones(n), ci95=np.array(ci), correlation=np.eye(n), bounds=[(0, 1)] * n, log=[False] * n, cost=0.0,
        rms_residual={}, sigma={}, n_evaluations=0, converged=True, message="", warnings=[],
    )  # fmt: skip


def test_inline_table_value_and_missing_key(tmp_path):
    # pure text editing: a segment's duration (inline table) and a key the file leaves at its default
    text = OSCILLATOR
    r = _hand_result(
        ["cam.segments[1].duration", "element.K.preload"],
        [np.pi, 2.5],
        ["rad", "N"],
        [[3.1, 3.2], [2.0, 3.0]],
        [np.pi, 0.0],
    )
    new = fitted_text(text, r)
    line = next(l for l in new.splitlines() if "fall" in l)
    assert 'duration = "180 deg"' in line and line.endswith('# fitted: was "180 deg"; 95 % CI 177.6169 to 183.3465 deg')
    assert 'preload = 2.5 # fitted: was the default 0 N; 95 % CI 2 to 3 N' in new
    assert load_machine_text(new).elements[0].preload == 2.5


def test_cli_json_schema_report_bytes_and_files(oscillator, osc_data, tmp_path):
    out, png = tmp_path / "fitted.toml", tmp_path / "fit.png"
    args = ["fit", str(oscillator), str(osc_data), "--param", "element.K.stiffness=10:40N/mm", "--param",
            "element.K.damping_ratio=0.01:0.2", "-o", str(out), "--json"]  # fmt: skip
    res = runner.invoke(app, args + ["--report", str(png)])
    assert res.exit_code == 0, res.stderr
    payload = json.loads(res.stdout)
    assert list(payload) == ["parameters", "correlation", "cost", "rms_residual", "n_evaluations", "converged",
                             "residual_variance", "targets", "matched", "misfits", "warnings"]  # issue 26: matched, misfits
    entry = payload["parameters"]["element.K.stiffness"]
    assert list(entry) == ["value", "unit", "stderr", "ci95", "initial"]
    assert entry["unit"] == "N/m" and entry["initial"] == 20000.0 and entry["ci95"][0] < entry["value"] < entry["ci95"][1]
    assert payload["converged"] is True and len(payload["correlation"]) == 2 and payload["correlation"][0][0] == 1.0
    assert list(payload["rms_residual"]) == ["masses/M/acceleration"]
    first = png.read_bytes()
    assert first[:8] == b"\x89PNG\r\n\x1a\n" and out.exists()
    png2 = tmp_path / "again.png"
    res = runner.invoke(app, args + ["--report", str(png2)])
    assert res.exit_code == 0 and png2.read_bytes() == first


def test_cli_align_offset_recovers_a_time_shift(oscillator, tmp_path):
    # measured times lag the simulation by 3 ms: sample the true run at t + 3 ms
    run = simulate(load_machine_text(OSCILLATOR))
    t = np.arange(0.0, 0.09, 0.0005)
    acc = np.interp(t + 0.003, run.time, run.masses["M"]["acceleration"]) + np.random.default_rng(9).normal(0, 0.2, t.size)
    csv = write_measured(tmp_path / "lag.csv", t, {"masses/M/acceleration": (acc, "m/s^2")})
    res = runner.invoke(app, ["fit", str(oscillator), str(csv), "--param", "element.K.stiffness=10:40N/mm",
                              "--align", "offset", "--max-shift", "5ms", "-o", str(tmp_path / "f.toml"), "--json"])  # fmt: skip
    assert res.exit_code == 0, res.stderr
    p = json.loads(res.stdout)["parameters"]
    assert p["align.offset"]["unit"] == "s"
    lo, hi = p["align.offset"]["ci95"]
    assert lo <= 0.003 <= hi and abs(p["align.offset"]["value"] - 0.003) < 2e-4
    lo, hi = p["element.K.stiffness"]["ci95"]
    assert lo <= OSC_K <= hi


def test_targets_only(driven, tmp_path):
    # the peak cam contact force of the driven machine, closed form: max over t of m·s̈ + P + k·s
    t = np.arange(0, 501) / 1000.0
    s = H / 2 * (1 - np.cos(OMEGA * t))
    a = H / 2 * OMEGA**2 * np.cos(OMEGA * t)
    peak = float(np.max(MASS * a + 60.0 + K_TRUE * s))
    r = fit(driven, None, ["element.K.preload=0:100"], targets=[f"max_cam_contact_force={peak}N"])
    assert r.converged and r.values[0] == pytest.approx(60.0, abs=1e-6)
    assert r.rms_residual["max_cam_contact_force"] < 1e-6
    assert any("no degrees of freedom" in w for w in r.warnings)
    assert P_TRUE == 40.0  # the file's value, which the target moved

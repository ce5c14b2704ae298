"""Every command on a machine with several cams (issue 38, item 2), end to end through the CLI.

A small two-station machine (a driven feed and a force-closed clamp on one shaft, a
clearance pair) goes through run, cam, validate, compare, sweep, study, fit, optimize,
report, plot, export and check. Each test checks what the command must say about several
cams — the `/cams/<name>/…` layout, the camshaft's numbers, cam-addressed keys — against the
same quantities read from an in-memory run (the result hub), not against stored numbers.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from camsim import simulate
from camsim.cli.app import app
from camsim.machine.loader import load_machine

from .stations import multi_toml

runner = CliRunner()

SIM = '\n[simulation]\ncycles = 1\nwarmup_cycles = 1\nsample_rate = "5 kHz"\n'
CLEARANCE = '''
[[clearance]]
name = "lanes"
between = [{ part = "A1" }, { part = "clamp", offset = "20 mm" }]
minimum = "2 mm"
'''


@pytest.fixture(scope="module")
def machine(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("line") / "line.toml"
    path.write_text(multi_toml(stations=("feed", "clamp"), phases={"feed": 0.0, "clamp": 120.0},
                               camshaft="speed_fluctuation = 0.02", extra=CLEARANCE, sim=SIM))
    return path


@pytest.fixture(scope="module")
def result(machine):
    return simulate(load_machine(machine))


@pytest.fixture(scope="module")
def runfile(machine, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("run") / "line.h5"
    res = runner.invoke(app, ["run", str(machine), "-o", str(out), "-q"])
    assert res.exit_code == 0, res.output
    return out


def _json(args):
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_run_writes_every_cam_and_the_camshaft(runfile, result):
    with h5py.File(runfile) as f:
        for cam in ("feed", "clamp"):
            for q in ("angle", "displacement", "velocity", "acceleration", "jerk", "torque"):
                assert f"cams/{cam}/{q}" in f, (cam, q)
            np.testing.assert_array_equal(f[f"cams/{cam}/displacement"][()], result.cams[cam]["displacement"])
        assert "cams/feed/contact_force" in f and "cams/clamp/contact_force" not in f  # clamp drives nothing
        assert "cam" not in f  # /cam/... is a one-cam file's
        for q in ("angle", "speed", "torque", "motor_torque", "boundaries_deg"):
            assert f"camshaft/{q}" in f
        np.testing.assert_array_equal(f["camshaft/torque"][()], result.trace("camshaft/torque"))
        assert f["camshaft/torque"].attrs["units"] == "N*m"
        assert "clearances/lanes/distance" in f


def test_run_summary_has_the_camshaft(machine, result):
    payload = _json(["run", str(machine), "--summary-only", "-o", str(machine.parent / "s.h5"), "--json", "-q"])
    shaft, ref = payload["camshaft"], result.camshaft_summary()
    for key in ("peak_torque", "rms_torque", "cycle_work", "energy_excursion", "flywheel_inertia"):
        assert shaft[key] == pytest.approx(ref[key], rel=1e-12), key
    assert shaft["flywheel_inertia"] == pytest.approx(ref["energy_excursion"] / (0.02 * (300 * math.pi / 30) ** 2))
    assert set(shaft["cams"]) == {"feed", "clamp"}
    assert shaft["clearances"]["lanes"]["minimum_distance"] == pytest.approx(
        ref["clearances"]["lanes"]["minimum_distance"], rel=1e-12)
    res = runner.invoke(app, ["run", str(machine), "-o", str(machine.parent / "h.h5"), "--cs", "0.01"])
    assert res.exit_code == 0, res.output
    assert "flywheel inertia for C_s = 0.01" in res.stderr and "cams on the shaft" in res.stderr


def test_cam_prints_every_cam_and_the_clearance(machine, tmp_path):
    payload = _json(["cam", str(machine), "--json"])
    assert [c["name"] for c in payload["cams"]] == ["feed", "clamp"]
    assert payload["cams"][1]["phase_deg"] == pytest.approx(120.0)
    (lanes,) = payload["clearances"]
    # feed at its top (10 mm, shaft 90..180 deg) while the clamp's lane sits at 20 mm: 10 mm
    assert lanes["minimum_distance"] == pytest.approx(0.010, abs=1e-9)
    out, plot = tmp_path / "cams.h5", tmp_path / "timing.png"
    res = runner.invoke(app, ["cam", str(machine), "-o", str(out), "--plot", str(plot), "--points", "720"])
    assert res.exit_code == 0, res.output
    assert plot.stat().st_size > 10_000
    with h5py.File(out) as f:
        assert f["cams/clamp/angle"][0] == pytest.approx(120.0)
        assert f["cams/feed/displacement"].shape == (720,)


def test_cam_fails_on_a_collision(machine):
    res = runner.invoke(app, ["cam", str(machine), "--set", 'clearance.lanes.minimum="15 mm"'])
    assert res.exit_code == 2
    assert "clearance[0]: A1 and clamp collide" in res.stderr


def test_run_warns_of_a_collision(machine, tmp_path):
    res = runner.invoke(app, ["run", str(machine), "-o", str(tmp_path / "r.h5"), "--set", 'clearance.lanes.minimum="15 mm"'])
    assert res.exit_code == 0, res.output
    assert "warning: clearance lanes: A1 and clamp come to 10 mm" in res.stderr


def test_validate_lists_every_cam(machine):
    res = runner.invoke(app, ["validate", str(machine)])
    assert res.exit_code == 0, res.output
    assert "cam feed (phase 0 deg" in res.stderr and "cam clamp (phase 120 deg" in res.stderr
    assert "driven by cam feed" in res.stderr and "\ncamshaft\n" in res.stderr


def test_compare_keeps_the_clamp_roller_bilateral(machine, tmp_path):
    out = tmp_path / "cmp.h5"
    res = runner.invoke(app, ["compare", str(machine), "-o", str(out), "-q"])
    assert res.exit_code == 0, res.output
    with h5py.File(out) as f:
        assert "no_impact/elements/rollB/force" in f  # a contact at a cam is kept (bilateral)
        assert "no_impact/cams/clamp/displacement" in f


def test_sweep_a_phase(machine, tmp_path):
    out = tmp_path / "sw.h5"
    res = runner.invoke(app, ["sweep", str(machine), "--vary", "cam.clamp.phase=60:120:60deg", "-o", str(out),
                              "--workers", "1", "-q"])
    assert res.exit_code == 0, res.output
    with h5py.File(out) as f:
        rows = f["sweep/summary"][()]
        names = rows.dtype.names
        assert "peak_camshaft_torque" in names and "min_clearance:lanes" in names
        np.testing.assert_allclose(rows["param:cam.clamp.phase"], np.radians([60.0, 120.0]), rtol=1e-12)


@pytest.mark.slow
def test_study_fit_optimize_on_cam_keys(machine, tmp_path, result):
    res = runner.invoke(app, ["study", str(machine), "--dist", "mass.B.mass=normal:0.4:0.01kg", "--samples", "2",
                              "--workers", "1", "-o", str(tmp_path / "st.h5"), "--json"])
    assert res.exit_code == 0, res.output
    assert "energy_excursion" in json.loads(res.stdout)["outputs"]
    target = result.scalars()["peak_camshaft_torque"]
    res = runner.invoke(app, ["fit", str(machine), "--param", "cam.feed.phase=-5:5:2deg", "--target",
                              f"peak_camshaft_torque={target!r}N*m", "-o", str(tmp_path / "fit.toml")])
    assert res.exit_code in (0, 1), res.output  # the phase is fitted (0 by symmetry is a valid answer)
    res = runner.invoke(app, ["optimize", str(machine), "--var", "cam.clamp.phase=90:150deg", "--minimize",
                              "peak_camshaft_torque", "--method", "local", "--budget", "6", "--workers", "1",
                              "-o", str(tmp_path / "opt.toml")])
    assert res.exit_code == 0, res.output
    text = (tmp_path / "opt.toml").read_text()
    assert "# optimised: was" in text and 'name = "clamp"' in text


def test_report_plot_export_check(runfile, tmp_path):
    res = runner.invoke(app, ["report", str(runfile), "-o", str(tmp_path / "r.html")])
    assert res.exit_code == 0, res.output
    html = (tmp_path / "r.html").read_text()
    assert "Camshaft: timing, torque, flywheel" in html and "Clearance lanes" in html
    res = runner.invoke(app, ["plot", str(runfile), "-o", str(tmp_path / "p"), "--what", "svaj,camshaft"])
    assert res.exit_code == 0, res.output
    assert {p.name for p in (tmp_path / "p").iterdir()} >= {"line_cam_svaj.png", "line_camshaft.png"}
    res = runner.invoke(app, ["export", str(runfile), "-o", str(tmp_path / "e.csv")])
    assert res.exit_code == 0, res.output
    header = (tmp_path / "e.csv").read_text().splitlines()[0]
    assert "cams/clamp/displacement [m]" in header and "camshaft/torque [N*m]" in header
    res = runner.invoke(app, ["check", str(runfile), "--against", str(runfile)])
    assert res.exit_code == 0, res.output


def test_open_result_reads_every_cam_back(runfile, result):
    from camsim import open_result

    back = open_result(runfile)
    assert set(back.cams) == {"feed", "clamp"}
    np.testing.assert_array_equal(back.cam_contact_forces["feed"], result.cam_contact_forces["feed"])
    assert back.camshaft_summary()["energy_excursion"] == pytest.approx(
        result.camshaft_summary()["energy_excursion"], rel=1e-12)

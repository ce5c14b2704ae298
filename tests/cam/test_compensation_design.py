"""Dynamic compensation (issue 27): overrides and sweeps reach the new keys, and the cam
design checks are those of the compensated cam.

References are physics and closed forms, not numbers taken from the code:

* the written program of machines/cdtm-compensated.toml is four 0.5 in lifts over 50 deg,
  each the polynomial of continuity 5 between dwells, i.e. the regularised incomplete beta
  function I_u(6, 6) (derivative u^5 (1 - u)^5 / B(6, 6)); on the model axis times the
  ratio 0.63648;
* off design, to first order in the path's compliance, the cam designed at w_d and run at
  w moves M3 as y - (w^2 - w_d^2) G y'' while the uncompensated cam (the program itself)
  moves it as y - w^2 G y'' (G: the path's inertia compliance; the damping terms act on
  the relative motions, one order higher). So the off-design error is
  |w^2/w_d^2 - 1| x (the uncompensated error at w_d), and |w_d^2/w^2 - 1| x (the
  uncompensated error at w) when the design speed is varied at a fixed running speed;
* pressure angle and pitch radius of curvature of a translating roller follower with
  offset e (Norton; docs/cam-design.md):
  phi = atan((s' - e)/(d + s)), d = sqrt(Rp^2 - e^2),
  rho = (y^2 + (s' - e)^2)^1.5 / (y^2 + (s' - e)(2 s' - e) - y s''), y = d + s,
  from the roller-side motion s, s' = v/(ratio w), s'' = a/(ratio w^2).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest
from numpy.polynomial import Polynomial
from scipy.special import beta as beta_fn, betainc
from typer.testing import CliRunner

from camsim import load_machine, simulate
from camsim.cam import CamProgram
from camsim.cli import app

ROOT = Path(__file__).resolve().parents[2]
COMPENSATED = ROOT / "machines" / "cdtm-compensated.toml"
CONVEYOR = ROOT / "machines" / "conveyor-match.toml"
runner = CliRunner()

INCH = 0.0254
RATIO = 0.63648
LIFT = 0.5 * INCH  # at the roller
H = RATIO * LIFT  # on the model axis: the level of M3 in the top dwells
DESIGN_RPM = 120.0
BETA = math.radians(50.0)
# (start [deg], +1 rise / -1 fall) of the four moves; the dwells fill the rest.
MOVES = ((0.0, 1), (90.0, -1), (180.0, 1), (270.0, -1))
FAST = ["--cycles", "1", "--warmup", "0", "--sample-rate", "20 kHz", "--workers", "1"]


def rpm(x: float) -> float:
    return x * 2.0 * math.pi / 60.0


def written_lift(theta_deg, order: int = 2):
    """Roller-side written program L(θ) and dL/dθ, d²L/dθ² [m/rad^n], closed form."""
    d = np.mod(np.asarray(theta_deg, dtype=float), 360.0)
    dshape = Polynomial([0, 1]) ** 5 * Polynomial([1, -1]) ** 5 / beta_fn(6, 6)  # dI/du
    out = [np.zeros_like(d) for _ in range(order + 1)]
    for start, sign in MOVES:
        u = np.clip((d - start) / 50.0, 0.0, 1.0)
        out[0] += np.where(d >= start, sign * LIFT * betainc(6, 6, u), 0.0)
        inside = (d > start) & (d < start + 50.0)
        p = dshape
        for n in range(1, order + 1):
            out[n] += np.where(inside, sign * LIFT * p(u) / BETA**n, 0.0)
            p = p.deriv()
    return out


def m3_errors(angle_deg, x3):
    """max |M3 - y| over the record, and max |M3 - H| in the top dwell after the first rise."""
    err = np.max(np.abs(x3 - RATIO * written_lift(angle_deg, 0)[0]))
    wrapped = np.mod(angle_deg, 360.0)
    dwell = (wrapped > 50.0) & (wrapped < 90.0)
    return float(err), float(np.max(np.abs(x3[dwell] - H)))


def sweep(tmp_path, name, *args):
    out = tmp_path / f"{name}.h5"
    result = runner.invoke(app, ["sweep", *args, "--keep-traces", "-o", str(out), "--json", *FAST])
    assert result.exit_code == 0, result.stderr
    rows = json.loads(result.stdout)["rows"]
    assert all(r["status"] == "ok" for r in rows)
    with h5py.File(out) as f:
        traces = [{name: f[f"sweep/variants/{k}/{name}"][()] for name in
                   ("cam/angle", "cam/velocity", "masses/M3/displacement")
                   if f"sweep/variants/{k}/{name}" in f} for k in range(len(rows))]
    return rows, traces


@pytest.fixture(scope="module")
def plain_text() -> str:
    """cdtm-compensated.toml without [cam.compensation]: its program is then the cam."""
    text = COMPENSATED.read_text()
    table = '[cam.compensation]\noutput = "M3"\nspeed = "120 rpm"\n'
    assert text.count(table) == 1
    return text.replace(table, "")


@pytest.fixture(scope="module")
def plain_error_at_design(tmp_path_factory, plain_text) -> float:
    """max |M3 - y| of the uncompensated machine at 120 rpm (one revolution, 20 kHz)."""
    path = tmp_path_factory.mktemp("plain") / "plain.toml"
    path.write_text(plain_text)
    run = simulate(load_machine(path), cycles=1, warmup_cycles=0, sample_rate=20e3)
    err, _ = m3_errors(run.trace("cam/angle"), run.trace("masses/M3/displacement"))
    assert err > 1e-4 * H  # the machine has a dynamic error to compensate (13 um of 8 mm)
    return err


# ------------------------------------------------------------------ 1. sweeps reach the keys
def test_speed_sweep_residual_is_smallest_at_the_design_speed(tmp_path, plain_error_at_design):
    """`camsim sweep --vary cam.speed=100:140:10rpm` of the 120 rpm design. From the kept
    traces: at 120 rpm M3 follows the written program (closed form) to 1e-6 of the lift and
    its residual in the dwell is at least 100x smaller than at any other speed; off design
    the error grows on both sides, as |w^2/w_d^2 - 1| x the uncompensated error at 120 rpm
    (first-order physics, 3 %). The sweep table's own peak_displacement:M3 shows it too:
    no overshoot of the dwell level at 120 rpm (1e-9 of H), an overshoot off design."""
    rows, traces = sweep(tmp_path, "speed", str(COMPENSATED), "--vary", "cam.speed=100:140:10rpm")
    speeds = [100.0, 110.0, 120.0, 130.0, 140.0]
    assert [r["param:cam.speed"] for r in rows] == pytest.approx([rpm(x) for x in speeds], rel=1e-12)
    errors = [m3_errors(t["cam/angle"], t["masses/M3/displacement"]) for t in traces]
    total = [e for e, _ in errors]
    dwell = [d for _, d in errors]
    design = speeds.index(DESIGN_RPM)
    assert total[design] <= 1e-6 * H
    for k, x in enumerate(speeds):
        if k == design:
            continue
        assert dwell[k] >= 100 * dwell[design], (x, dwell)
        predicted = abs((x / DESIGN_RPM) ** 2 - 1.0) * plain_error_at_design
        assert total[k] == pytest.approx(predicted, rel=0.03), (x, total[k], predicted)
    # grows off design on both sides
    assert total[0] > total[1] > total[2] < total[3] < total[4]
    overshoot = [r["peak_displacement:M3"] - H for r in rows]
    assert abs(overshoot[design]) <= 1e-9 * H
    assert all(overshoot[k] > 1e-9 * H for k in range(len(speeds)) if k != design), overshoot


def test_vary_compensation_speed_reaches_the_design(tmp_path, plain_error_at_design):
    """`--vary cam.compensation.speed=100:140:20rpm` at the file's running speed of 120 rpm:
    the param column holds the design speed in rad/s (docs/sweeps.md: SI of the key), the
    cam changes with it (peak acceleration of the driven M1 differs), M3 follows the program
    (1e-6 of the lift) only when the design speed is the running speed, and otherwise errs
    by |w_d^2/w^2 - 1| x the uncompensated error (3 %)."""
    rows, traces = sweep(tmp_path, "design", str(COMPENSATED), "--vary", "cam.compensation.speed=100:140:20rpm")
    designs = [100.0, 120.0, 140.0]
    assert [r["param:cam.compensation.speed"] for r in rows] == pytest.approx([rpm(x) for x in designs], rel=1e-12)
    peaks_m1 = [r["peak_acceleration:M1"] for r in rows]
    assert len(set(peaks_m1)) == 3
    total = [m3_errors(t["cam/angle"], t["masses/M3/displacement"])[0] for t in traces]
    assert total[1] <= 1e-6 * H
    for k in (0, 2):
        predicted = abs((designs[k] / DESIGN_RPM) ** 2 - 1.0) * plain_error_at_design
        assert total[k] == pytest.approx(predicted, rel=0.03), (designs[k], total[k], predicted)


def test_set_compensation_speed_moves_the_design(tmp_path):
    """`--set cam.compensation.speed="100 rpm"` with the machine run at 100 rpm: on design
    again, M3 follows the program to 1e-6 of the lift (the 120 rpm design run at 100 rpm
    errs by about 4 um, see the speed sweep). Also `camsim cam --set`: the cam's peaks move
    with the design speed, and setting the file's own 120 rpm changes nothing."""
    rows, traces = sweep(tmp_path, "set", str(COMPENSATED), "--set", "cam.compensation.speed=100 rpm",
                         "--values", "cam.speed=100rpm")
    assert m3_errors(traces[0]["cam/angle"], traces[0]["masses/M3/displacement"])[0] <= 1e-6 * H

    def cam_json(*extra):
        result = runner.invoke(app, ["cam", str(COMPENSATED), "--json", *extra])
        assert result.exit_code == 0, result.stderr
        return json.loads(result.stdout)["segments"]

    base = cam_json()
    assert cam_json("--set", "cam.compensation.speed=120 rpm") == base
    moved = cam_json("--set", "cam.compensation.speed=100 rpm")
    assert moved[0]["peak_acceleration"] != pytest.approx(base[0]["peak_acceleration"], rel=1e-6)


def test_set_and_values_reach_a_polynomial_end_condition(tmp_path):
    """machines/conveyor-match.toml, segment 1 (0-based; the polynomial rise into the 200 mm/s
    hand-over at 120 deg): `--set cam.segments[1].end.v=150mm/s` and
    `--values cam.segments[1].end.v=150,200mm/s` are accepted; the param column is in m/s;
    the driven head's velocity just before 120 deg is the end velocity written (sampled
    0.12 deg before the join, 1e-5), and the hand-over itself stays at 200 mm/s."""
    def end_speed(trace):
        angle, v = trace["cam/angle"], trace["cam/velocity"]
        before = int(np.flatnonzero(angle < 120.0)[-1])
        assert 120.0 - angle[before] < 0.2
        return v[before], v[before + 2]

    rows, traces = sweep(tmp_path, "conv-set", str(CONVEYOR), "--set", "cam.segments[1].end.v=150mm/s",
                         "--values", "cam.speed=60rpm", "--sample-rate", "3 kHz")
    v_end, v_cv = end_speed(traces[0])
    assert v_end == pytest.approx(0.150, rel=1e-5)
    assert v_cv == pytest.approx(0.200, rel=1e-12)
    rows, traces = sweep(tmp_path, "conv-values", str(CONVEYOR), "--values", "cam.segments[1].end.v=150,200mm/s",
                         "--sample-rate", "3 kHz")
    assert [r["param:cam.segments[1].end.v"] for r in rows] == pytest.approx([0.150, 0.200], rel=1e-12)
    assert [end_speed(t)[0] for t in traces] == pytest.approx([0.150, 0.200], rel=1e-5)
    assert np.max(np.abs(traces[0]["cam/velocity"] - traces[1]["cam/velocity"])) >= 0.01  # m/s


# ------------------------------------------------------------------ 2. design checks
RB, RR, OFFSET = 2.0 * INCH, 0.5 * INCH, 0.25 * INCH
GEOMETRY = """
[cam.geometry]
follower = "translating-roller"
base_radius = "{rb} m"
roller_radius = "{rr} m"
offset = "{offset} m"
rotation = "ccw"
width = "0.5 in"
max_pressure_angle = "30 deg"
"""


def with_geometry(text: str, rb: float = RB, rr: float = RR) -> str:
    marker = "\n# Masses:"
    assert text.count(marker) == 1
    return text.replace(marker, GEOMETRY.format(rb=rb, rr=rr, offset=OFFSET) + marker)


def closed_form(s, s1, s2, rp):
    """Translating roller with offset: pressure angle [rad] and pitch radius [m] (Norton)."""
    d = math.sqrt(rp**2 - OFFSET**2)
    y, w = d + s, s1 - OFFSET
    phi = np.arctan(w / y)
    rho = (y**2 + w**2) ** 1.5 / (y**2 + w * (2.0 * s1 - OFFSET) - y * s2)
    return phi, rho


def test_design_checks_are_those_of_the_compensated_cam(tmp_path, plain_text):
    """cdtm-compensated + a translating roller [cam.geometry] (Rb 2 in, Rr 0.5 in, offset
    0.25 in). One run at the design speed: M3 follows the written program (1e-6 of the lift),
    so its cam is the compensated one; the pressure angle and pitch/surface radii the run
    writes at every sample equal the closed forms from that run's cam s, v, a (phi to 1e-9 of
    max|phi|; rho to 1e-9 relative where the curve is not near an inflection, 1/rho to 1e-9
    of max|1/rho| everywhere), and differ from the closed forms of the written
    (uncompensated) program by far more. `camsim cam --json` reports max|phi| and the
    smallest convex pitch radius of the compensated cam (closed form at the reported angle,
    1e-9; no sample of a 0.02 deg scan beyond it), which differ from the report on the
    uncompensated machine."""
    comp_path, plain_path = tmp_path / "comp.toml", tmp_path / "plain.toml"
    comp_path.write_text(with_geometry(COMPENSATED.read_text()))
    plain_path.write_text(with_geometry(plain_text))
    w = rpm(DESIGN_RPM)
    rp = RB + RR

    run = simulate(load_machine(comp_path), cycles=1, warmup_cycles=0, sample_rate=36e3)
    angle = run.trace("cam/angle")
    assert m3_errors(angle, run.trace("masses/M3/displacement"))[0] <= 1e-6 * H
    s = run.trace("cam/displacement") / RATIO
    s1 = run.trace("cam/velocity") / (RATIO * w)
    s2 = run.trace("cam/acceleration") / (RATIO * w * w)
    phi_ref, rho_ref = closed_form(s, s1, s2, rp)
    assert run.units("cam/pressure_angle") == "deg"
    phi = np.radians(run.trace("cam/pressure_angle"))
    rho = run.trace("cam/pitch_radius_of_curvature")
    assert np.max(np.abs(phi - phi_ref)) <= 1e-9 * np.max(np.abs(phi_ref))
    kappa, kappa_ref = 1.0 / rho, 1.0 / rho_ref
    assert np.max(np.abs(kappa - kappa_ref)) <= 1e-9 * np.max(np.abs(kappa_ref))
    away = np.abs(kappa_ref) >= 1e-3 * np.max(np.abs(kappa_ref))
    assert away.mean() > 0.9
    assert np.max(np.abs(rho[away] / rho_ref[away] - 1.0)) <= 1e-9
    assert np.allclose(run.trace("cam/surface_radius_of_curvature")[away], rho_ref[away] - RR, rtol=1e-9, atol=0)

    # The uncompensated program's geometry (closed form) is measurably different.
    lw = written_lift(angle)
    phi_plain, rho_plain = closed_form(lw[0], lw[1], lw[2], rp)
    assert np.max(np.abs(phi_plain - phi_ref)) >= 1e5 * 1e-9 * np.max(np.abs(phi_ref))
    assert np.max(np.abs(1.0 / rho_plain - kappa_ref)) >= 1e5 * 1e-9 * np.max(np.abs(kappa_ref))

    def report(path):
        result = runner.invoke(app, ["cam", str(path), "--json"])
        assert result.exit_code == 0, result.stderr
        return json.loads(result.stdout)["geometry"]

    geo, geo_plain = report(comp_path), report(plain_path)
    program = CamProgram(load_machine(comp_path).cam)
    t = angle / 360.0 * (2.0 * math.pi / w)
    assert np.allclose(np.array(program.svaj(t)[0]), run.trace("cam/displacement"), rtol=0, atol=1e-12 * H)

    def at(deg):
        ls = program.lift(np.radians([deg]))
        return closed_form(ls[0], ls[1], ls[2], rp)

    phi_at, _ = at(geo["max_pressure_angle_at"])
    assert geo["max_pressure_angle"] == pytest.approx(math.degrees(abs(phi_at[0])), rel=1e-9)
    assert geo["max_pressure_angle"] >= math.degrees(np.max(np.abs(phi_ref))) * (1 - 1e-9)
    _, rho_at = at(geo["min_pitch_radius_at"])
    assert geo["min_pitch_radius"] == pytest.approx(rho_at[0], rel=1e-9)
    assert geo["min_pitch_radius"] <= np.min(rho_ref[rho_ref > 0]) * (1 + 1e-9)
    assert geo["min_surface_radius"] == pytest.approx(rho_at[0] - RR, rel=1e-9)
    for key in ("max_pressure_angle", "min_pitch_radius"):
        assert abs(geo[key] / geo_plain[key] - 1.0) > 1e-4, (key, geo[key], geo_plain[key])
    # the plain report is the written program's closed form (what the compensated one must not be)
    plain_at = written_lift([geo_plain["min_pitch_radius_at"]])
    assert geo_plain["min_pitch_radius"] == pytest.approx(closed_form(*plain_at, rp)[1][0], rel=1e-9)


def test_undercut_check_judges_the_compensated_cam(tmp_path, plain_text):
    """Same prime radius Rp = 2.5 in, roller radius put between the smallest convex pitch
    radius of the written program (closed form, 0.01 deg scan) and that of the compensated
    cam: the undercut check (exit 2, an error naming the cam angles) fires on the machine
    whose profile has the smaller minimum and not on the other. Reference: the closed-form
    pitch radii of both profiles."""
    rp = RB + RR
    theta = np.arange(0.0, 360.0, 0.01)
    lw = written_lift(theta)
    rho_plain = closed_form(lw[0], lw[1], lw[2], rp)[1]
    plain_min = float(np.min(rho_plain[rho_plain > 0]))
    comp_text = COMPENSATED.read_text()
    ls = CamProgram(load_machine(_write(tmp_path / "c.toml", with_geometry(comp_text))).cam).lift(np.radians(theta))
    rho_comp = closed_form(ls[0], ls[1], ls[2], rp)[1]
    comp_min = float(np.min(rho_comp[rho_comp > 0]))
    assert abs(comp_min - plain_min) > 1e-5  # 0.17 mm apart
    low, high = sorted((plain_min, comp_min))
    middle = 0.5 * (low + high)

    def check(text, rr):
        path = _write(tmp_path / "m.toml", with_geometry(text, rb=rp - rr, rr=rr))
        return runner.invoke(app, ["cam", str(path), "--json"])

    smaller_is_comp = comp_min < plain_min
    for text, is_comp in ((comp_text, True), (plain_text, False)):
        result = check(text, middle)
        cut = is_comp == smaller_is_comp  # the profile whose minimum is below the roller
        assert result.exit_code == (2 if cut else 0), result.stderr
        if cut:
            assert "undercut at cam angle" in result.stderr


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path

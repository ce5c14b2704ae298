"""A friction pair whose normal force follows a program (spec §10: a cam-actuated clamp or
brake): F_C = μ·N(t), F_B = μ_s·N(t), the pair free while N ≤ 0.

References (closed forms, 1e-9 where the motion is piecewise linear):

* a brake that closes at t1 on a block sliding at v0: N steps from 0 to N0, the block
  decelerates at μ·N0/m and stops at t1 + m·v0/(μ·N0), at v0·t1 + m·v0²/(2·μ·N0); the energy
  dissipated is the block's kinetic energy;
* a clamp that holds a mass on a spring at x0 and lets go at t1 (a time table dropping to 0
  N): x = x0·cos(ω·(t − t1)) after it, the clamp carrying k·x0 before;
* a clamp whose normal force falls linearly: it slips when k·x0 = μ_s·N(t), at the
  closed-form instant (a slip row there, 1e-9 s).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from camsim.run.simulation import simulate


def _machine(tmp_path, table_rows: str, body: str, initial: str, duration: str = "1 s") -> str:
    (tmp_path / "normal.csv").write_text("time [s],force [N]\n" + table_rows)
    text = f"""
schema = 1
[machine]
name = "a programmed normal force"
[[mass]]
name = "m"
mass = "2 kg"
{body}
[initial.m]
{initial}
[simulation]
duration = "{duration}"
sample_rate = "1 kHz"
"""
    path = tmp_path / "machine.toml"
    path.write_text(text)
    return str(path)


def _load(path: str):
    from camsim.machine.loader import load_machine

    return load_machine(path)


BRAKE = """
[[element]]
name = "brake"
type = "friction"
between = ["ground", "m"]
coefficient = 0.25
normal_force = { table = "normal.csv" }
"""


def test_brake_that_closes_stops_the_block_at_the_closed_form(tmp_path):
    m, v0, mu, n0, t1 = 2.0, 1.0, 0.25, 20.0, 0.1
    r = simulate(_load(_machine(tmp_path, f"0,0\n{t1},0\n{t1},{n0}\n1,{n0}\n", BRAKE,
                                'displacement = "0 m"\nvelocity = "1 m/s"')))
    sticks = [e for e in r.events if e.kind == "stick"]
    assert len(sticks) == 1
    assert sticks[0].time == pytest.approx(t1 + m * v0 / (mu * n0), abs=1e-9)
    assert r.masses["m"]["displacement"][-1] == pytest.approx(v0 * t1 + m * v0**2 / (2 * mu * n0), abs=1e-9)
    assert r.summary()["friction"]["brake"]["energy"] == pytest.approx(0.5 * m * v0**2, rel=1e-9)
    # free before it closes, μ·N0 while it slides
    f = r.elements["brake"]
    assert np.all(f[r.time < t1 - 1e-9] == 0.0)
    assert np.allclose(f[(r.time > t1 + 1e-9) & (r.time < 0.5 - 1e-9)], mu * n0, rtol=1e-12)


CLAMP = """
[[element]]
name = "spring"
type = "spring"
between = ["ground", "m"]
stiffness = "2e4 N/m"
[[element]]
name = "clamp"
type = "friction"
between = ["ground", "m"]
coefficient = 0.2
static_coefficient = 0.3
normal_force = { table = "normal.csv" }
"""


def test_clamp_that_lets_go_releases_a_harmonic_oscillation(tmp_path):
    k, m, x0, t1 = 2e4, 2.0, 5e-3, 0.05
    # N drops from 1000 N to 0 at t1 (a step): held at x0 before, free (no friction force) after
    r = simulate(_load(_machine(tmp_path, f"0,1000\n{t1},1000\n{t1},0\n1,0\n", CLAMP,
                                'displacement = "5 mm"\nvelocity = "0 m/s"', duration="0.2 s")))
    t, x = r.time, r.masses["m"]["displacement"]
    before = t < t1 - 1e-9
    assert np.all(np.abs(x[before] - x0) <= 1e-15)
    assert np.allclose(r.elements["clamp"][before], -k * x0, rtol=1e-12)  # it pulls against the spring
    after = t > t1 + 1e-9
    w = math.sqrt(k / m)
    assert np.max(np.abs(x[after] - x0 * np.cos(w * (t[after] - t1)))) < 1e-9 * x0
    assert np.all(r.elements["clamp"][after] == 0.0)


def test_clamp_slips_when_its_breakaway_force_falls_below_the_spring_force(tmp_path):
    k, x0, mu_s = 2e4, 5e-3, 0.3
    # N falls linearly from 1000 N at t = 0 to 0 at 1 s: μ_s·N(t) = k·x0 at t* = 1 − k·x0/(μ_s·1000)
    r = simulate(_load(_machine(tmp_path, "0,1000\n1,0\n", CLAMP, 'displacement = "5 mm"\nvelocity = "0 m/s"',
                                duration="0.8 s")))
    slips = [e for e in r.events if e.kind == "slip"]
    assert slips, [(e.time, e.kind) for e in r.events]
    assert slips[0].time == pytest.approx(1.0 - k * x0 / (mu_s * 1000.0), abs=1e-9)


def test_refused_with_a_stribeck_velocity(tmp_path):
    from camsim.errors import MachineFileError

    body = BRAKE + 'stribeck_velocity = "0.01 m/s"\nstatic_coefficient = 0.3\n'
    with pytest.raises(MachineFileError, match="stribeck_velocity"):
        _load(_machine(tmp_path, "0,0\n1,10\n", body, 'displacement = "0 m"'))

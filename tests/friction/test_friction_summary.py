"""The summary of a run with friction pairs (spec §10: "the summary gives the energy each
friction element dissipates per cycle and its stick and slip counts").

References:

* Coulomb friction dissipates F_C·Σ|Δd| (Δd over each sliding stretch, where ḋ keeps its
  sign): on the cam-driven carriage, Σ|Δd| and the rows in closed form
  (friction_machines.CarriageReference); energy to 1e-9 relative, counts exact;
* with viscous friction the energy balance: a block at v0 on a Coulomb + viscous slide
  dissipates all of ½·m·v0², F_C·x* of it in Coulomb friction (x* the closed-form stop
  distance) and the rest, ½·m·v0² − F_C·x*, in the viscous part; 1e-9 relative.

The summary's layout: ``summary()["friction"][name]`` with ``energy`` [J], ``sticks``,
``slips`` (camsim.run.friction.friction_summary).
"""

from __future__ import annotations

import math

import pytest

from camsim.machine.loader import load_machine_text
from camsim.run.simulation import simulate

from friction_machines import CarriageReference, block, carriage



def friction_summary(result, name: str) -> dict:
    """{"energy": J per cycle, "sticks": n, "slips": n} of friction element ``name`` from the
    run's summary, and the same from its flat scalars (one value, two routes)."""
    entry = result.summary()["friction"][name]
    scalars = result.scalars()
    assert scalars[f"friction_energy:{name}"] == entry["energy"]
    assert scalars[f"sticks:{name}"] == entry["sticks"] and scalars[f"slips:{name}"] == entry["slips"]
    return {"energy": entry["energy"], "sticks": entry["sticks"], "slips": entry["slips"]}


@pytest.mark.parametrize("fc, fb", [(0.3, 0.4), (0.4, 0.4), (0.2, 0.45)])
def test_carriage_dissipates_coulomb_force_times_sliding_distance(fc, fb):
    """Reference: the pad dissipates F_C·Σ|Δd| over the revolution, Σ|Δd| from the
    closed-form motion (CarriageReference); the stick and slip counts are its rows.
    Tolerance: 1e-9 relative; counts exact."""
    r = simulate(load_machine_text(carriage(fc, fb)))
    ref = CarriageReference(fc, fb)
    got = friction_summary(r, "pad")
    assert got["energy"] == pytest.approx(fc * ref.sliding_distance, rel=1e-9)
    assert got["sticks"] == sum(1 for _, k in ref.events if k == "stick")
    assert got["slips"] == sum(1 for _, k in ref.events if k == "slip")


def test_block_dissipates_its_kinetic_energy():
    """Reference: a block at v0 on a Coulomb (F_C) + viscous (c) slide comes to rest: all of
    ½·m·v0² is dissipated, F_C·x* by Coulomb friction, x* = (m/c)(v0 + F_C/c)(1 − e^(−ct*/m))
    − F_C·t*/c, t* = (m/c)·ln(1 + c·v0/F_C). A machine without a cam has one "cycle": the
    run. Tolerance 1e-9 relative; one stick, no slip."""
    m, v0, fc, c = 2.0, 1.5, 5.0, 3.0
    r = simulate(load_machine_text(block(m=m, v0=v0, fc=fc, cv=c)))
    t_stop = (m / c) * math.log1p(c * v0 / fc)
    x_stop = (m / c) * (v0 + fc / c) * (1 - math.exp(-c * t_stop / m)) - fc * t_stop / c
    got = friction_summary(r, "slide")
    assert got["energy"] == pytest.approx(0.5 * m * v0**2, rel=1e-9)
    assert 0.5 * m * v0**2 - fc * x_stop > 0.1 * 0.5 * m * v0**2  # the viscous share matters here
    assert got["sticks"] == 1 and got["slips"] == 0


def test_spring_mass_counts_and_energy():
    """Reference: the spring–mass released from 10.5 mm on a Coulomb slide (k = 1e4 N/m,
    F_C = 10 N) slides 10.5 + 2(8.5 + 6.5 + 4.5 + 2.5) + 0.5 = 55 mm in five half-waves and
    sticks at −0.5 mm: it dissipates F_C·0.055 m = 0.55 J = ½k(x0² − x*²); one slip (at
    t = 0), one stick. Tolerance 1e-9 relative."""
    from friction_machines import spring_mass

    r = simulate(load_machine_text(spring_mass(x0=10.5e-3, fc=10.0)))
    got = friction_summary(r, "slide")
    assert got["energy"] == pytest.approx(10.0 * 0.055, rel=1e-9)
    assert got["energy"] == pytest.approx(0.5 * 1e4 * (10.5e-3**2 - 0.5e-3**2), rel=1e-9)
    assert got["sticks"] == 1 and got["slips"] == 1

"""Materials and contacts whose law follows from geometry and materials (issue 39).

References and tolerances:

- Sphere on a flat: F = (4/3)·E*·√R·δ^1.5 (Johnson, *Contact Mechanics* 1985, eq. 4.23); for
  two bodies of one material with ν = 0.3 the coefficient is the thesis's 0.518·E·√D (eq. C.10,
  spec §5) to the 3 digits printed; peak pressure p₀ = 3F/(2πa²), a = (3FR/4E*)^(1/3) (eq. 4.22),
  to 1e-12.
- Cylinder on a flat: Johnson's δ = F/(πL)·Σᵢ(1 − νᵢ²)/Eᵢ·(2 ln(4R/b) − 1), b = √(4FR/(πLE*))
  (eq. 5.36 applied to both bodies; docs/contacts.md), written out by hand below; camsim's
  force law inverts it to 1e-12. W₋₁ against ``scipy.special.lambertw`` to 1e-13 (away from
  the branch point, where both lose digits).
- The ball drop with the law from materials reproduces thesis table 6's common-velocity
  column (57.66 lbf at 1 in) to 0.2 % (the 1 MHz sampling; as tests/test_validation.py).
- A cylinder-on-flat contact stopping a free mass, undamped: peak = the energy balance
  ∫F dδ = ½·m·v² (Johnson's upper bound for this law) to 1e-6; with restitution e the
  rebound is e to 1e-5 (the exact Hunt–Crossley mapping holds for any elastic law).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import lambertw

from camsim.errors import MachineFileError
from camsim.machine.loader import load_machine, load_machine_text
from camsim.physics import hertz
from camsim.physics.materials import LIBRARY, effective_modulus, lookup
from camsim.run.simulation import simulate

LBF = 4.4482216152605
INCH = 0.0254


def test_lambert_w_lower_branch():
    z = -np.logspace(-14, math.log10(1 / math.e) - 1e-3, 400)
    ours = hertz.lambert_w_lower(z)
    assert ours == pytest.approx(lambertw(z, -1).real, rel=1e-13)
    assert ours * np.exp(ours) == pytest.approx(z, rel=1e-13)


def test_sphere_coefficient_is_the_thesis_factor():
    steel = lookup("steel")
    same = type(steel)("s", 2.9e7 * LBF / INCH**2, 0.3)
    e_star = effective_modulus(same, same)
    d = 0.375 * INCH
    assert hertz.sphere_coefficient(e_star, d / 2) / (same.youngs_modulus * math.sqrt(d)) == pytest.approx(0.518, abs=5e-4)
    force = 250.0
    a = float(hertz.sphere_contact_radius(force, e_star, d / 2))
    assert float(hertz.sphere_pressure(force, e_star, d / 2)) == pytest.approx(3 * force / (2 * math.pi * a * a), rel=1e-12)


def johnson_line_approach(force, m1, m2, radius, length):
    """Johnson's line-contact approach, written out: each body compressed to the depth R."""
    e_star = effective_modulus(m1, m2)
    b = math.sqrt(4 * force * radius / (math.pi * length * e_star))
    v = sum((1 - m.poisson_ratio**2) / m.youngs_modulus for m in (m1, m2))
    return force / (math.pi * length) * v * (2 * math.log(4 * radius / b) - 1)


@pytest.mark.parametrize("pair", [("steel", "steel"), ("hardened-steel", "bronze"), ("acetal", "cast-iron")])
def test_line_law_inverts_johnsons_formula(pair):
    m1, m2 = (LIBRARY[n] for n in pair)
    e_star, radius, length = effective_modulus(m1, m2), 0.01, 0.02
    for force in (1.0, 1e2, 1e4, 1e5):
        delta = johnson_line_approach(force, m1, m2, radius, length)
        assert float(hertz.line_force(np.array([delta]), e_star, radius, length)[0]) == pytest.approx(force, rel=1e-12)
        assert hertz.line_force_scalar(delta, e_star, radius, length) == pytest.approx(force, rel=1e-12)
        # stiffness and energy against numerical derivative and quadrature of the law
        h = 1e-6 * delta
        slope = (hertz.line_force_scalar(delta + h, e_star, radius, length)
                 - hertz.line_force_scalar(delta - h, e_star, radius, length)) / (2 * h)
        assert float(hertz.line_tangent(force, e_star, radius, length)) == pytest.approx(slope, rel=1e-6)
        work = quad(lambda d: hertz.line_force_scalar(d, e_star, radius, length), 0, delta, limit=200)[0]
        assert float(hertz.line_energy(force, e_star, radius, length)) == pytest.approx(work, rel=1e-7)


def test_library_values_and_sources():
    """Every library material has E, ν < 0.5, ρ, a yield strength and a source; steel is camsim's
    default for the cam's Hertz stress (206.8 GPa, 0.28: Norton table C-1)."""
    assert set(LIBRARY) >= {"steel", "stainless-steel", "aluminium-6061", "bronze", "cast-iron", "brass",
                            "polyurethane-90a", "nylon-66", "acetal"}
    for m in LIBRARY.values():
        assert m.youngs_modulus > 0 and 0 <= m.poisson_ratio < 0.5 and m.density > 0 and m.yield_strength > 0
        assert len(m.source) > 20
    assert (LIBRARY["steel"].youngs_modulus, LIBRARY["steel"].poisson_ratio) == (206.8e9, 0.28)
    assert LIBRARY["aluminium-6061"].yield_strength == 276e6


# ------------------------------------------------------------------ simulated
def test_ball_drop_from_materials_reproduces_table6():
    """machines/ball-drop-hertz.toml: the thesis's steel as [[material]] gives C = 9.2e6
    lbf/in^1.5 and table 6's 57.66 lbf from 1 in (0.2 %)."""
    machine = load_machine("machines/ball-drop-hertz.toml")
    stop = machine.element("stop")
    assert stop.coefficient / (LBF / INCH**1.5) == pytest.approx(9.2e6, rel=1e-3)
    r = simulate(machine)
    (impact,) = r.impacts()
    assert impact.peak_force / LBF == pytest.approx(57.66, rel=2e-3)
    (row,) = r.summary()["contact_stress"]
    assert row["peak_pressure"] == pytest.approx(float(hertz.sphere_pressure(impact.peak_force, stop.e_star,
                                                                                stop.radius)), rel=1e-12)
    assert row["yield_pressure"] == pytest.approx(1.60 * 2034e6)


def _cylinder_drop(restitution: str = "") -> str:
    return f"""
schema = 1
[machine]
name = "a roller dropped on a flat"
[[mass]]
name = "m"
mass = "0.5 kg"
[[element]]
name = "stop"
type = "contact"
between = ["ground", "m"]
law = "hertz"
geometry = "cylinder-on-flat"
radius = "5 mm"
length = "10 mm"
materials = ["steel", "bronze"]
{restitution}
[initial.m]
displacement = "1e-6 m"
velocity = "-0.5 m/s"
[simulation]
duration = "0.2 ms"
sample_rate = "50 MHz"
"""


def test_cylinder_contact_peak_is_the_energy_balance():
    machine = load_machine_text(_cylinder_drop())
    stop = machine.element("stop")
    r = simulate(machine)
    impact = r.impacts()[0]
    m, v = 0.5, 0.5
    lower, upper = stop.johnson_bounds(math.inf, m, v)
    assert lower == upper
    assert float(hertz.line_energy(upper, stop.e_star, stop.radius, stop.length)) == pytest.approx(0.5 * m * v * v, rel=1e-12)
    assert impact.peak_force == pytest.approx(upper, rel=1e-6)
    # the duration estimate the rod discretisation uses, against the simulated contact time
    assert stop.impact_duration(math.inf, m, v) == pytest.approx(impact.contact_duration, rel=1e-3)
    assert r.masses["m"]["velocity"][-1] == pytest.approx(v, rel=1e-7)


def test_cylinder_contact_restitution_is_exact():
    r = simulate(load_machine_text(_cylinder_drop("restitution = 0.7")))
    assert r.masses["m"]["velocity"][-1] / 0.5 == pytest.approx(0.7, rel=1e-5)


def test_yield_warning():
    """Steel on bronze at 0.5 m/s on a 5 mm × 10 mm roller exceeds 1.67 × 125 MPa: warned."""
    r = simulate(load_machine_text(_cylinder_drop()))
    assert any("exceeds the first-yield pressure" in w and "bronze" in w for w in r.warnings)


# ------------------------------------------------------------------ file
def test_material_tables_and_names():
    text = _cylinder_drop().replace('materials = ["steel", "bronze"]', 'materials = ["mine", "steel"]') + """
[[material]]
name = "mine"
youngs_modulus = "100 GPa"
poisson_ratio = 0.3
yield_strength = "1 GPa"
"""
    stop = load_machine_text(text).element("stop")
    assert stop.materials[0].name == "mine" and stop.materials[0].youngs_modulus == 100e9
    with pytest.raises(MachineFileError) as info:
        load_machine_text(text.replace('name = "mine"', 'name = "steel"'), source="m.toml")
    assert info.value.key == "material[0].name" and "library" in info.value.message
    with pytest.raises(MachineFileError) as info:
        load_machine_text(_cylinder_drop().replace('length = "10 mm"\n', ""), source="m.toml")
    assert info.value.key == "element[0].length"


def test_cam_geometry_material_by_name():
    """cam_material / follower_material may name a library material (issue 39)."""
    machine = load_machine("machines/cdtm-geometry.toml", overrides=['cam.geometry.cam_material="cast-iron"'])
    geometry = machine.cam.geometry
    assert geometry.cam_material.youngs_modulus == LIBRARY["cast-iron"].youngs_modulus
    assert geometry.cam_material.poisson_ratio == LIBRARY["cast-iron"].poisson_ratio

"""``law = "hertz"``: a contact whose law follows from its geometry and materials (spec §3).

``geometry = "sphere-on-flat"`` (``radius`` R) or ``"cylinder-on-flat"`` (``radius`` R,
``length`` L) and ``materials = [body, flat]`` (library names or ``[[material]]`` names):

* sphere on a flat: the Hertz power law F = (4/3)·E*·√R·δ^1.5 — a :class:`PowerContact`
  whose C and a are derived, nothing else changes;
* cylinder on a flat: Johnson's line contact δ = F/(πLE*)·(2 ln(4R/b) − 1), inverted in
  closed form (:mod:`camsim.physics.hertz`); not a power law, so this class supplies the
  nonlinear-contact protocol (``nonlinear_force``, ``nonlinear_force_scalar``,
  ``nonlinear_tangent``, ``scalar_force``) for it.

Damping as a power-law contact: ``restitution`` e with Hunt–Crossley F·(1 + χ·δ̇), χ = α(e)/v.
The exact α(e) holds for any elastic law F(δ), not only power laws: along an isolated impact
m·v·dv/(1 + χ·v) = −F(δ)·dδ, whose left side alone fixes the rebound. Peak contact pressure is
reported against the weaker material's yield (:meth:`HertzContact.stress`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from camsim.elements.base import Param, pair_mass, register
from camsim.elements.contact import CONTACT_PARAMS
from camsim.elements.power_contact import PowerContact
from camsim.physics import hertz
from camsim.physics.materials import Material, effective_modulus

#: The geometries a Hertz contact takes.
GEOMETRIES = ("sphere-on-flat", "cylinder-on-flat")
_SPHERE, _CYLINDER = GEOMETRIES


@register
@dataclass(frozen=True)
class HertzContact(PowerContact):
    """Hertz contact from ``geometry``, ``radius`` [m], ``length`` [m] and two ``materials``."""

    geometry: str = _SPHERE
    radius: float = 0.0
    length: float | None = None
    materials: tuple[Material, Material] | None = None

    law_name: ClassVar[str] = "hertz"
    summary: ClassVar[str] = ("compliant contact whose law follows from geometry and materials: Hertz sphere "
                              "on a flat, or Johnson's cylinder on a flat; Hunt–Crossley damped with restitution")
    params: ClassVar[tuple[Param, ...]] = (
        *CONTACT_PARAMS,
        Param("geometry", "choice", "the contacting shapes", required=True, choices=GEOMETRIES),
        Param("radius", "length", "R of the sphere or cylinder (the flat has none)", required=True, minimum=0.0,
              strict=True, example='"4.76 mm"'),
        Param("length", "length", "L of the cylinder's line of contact (`cylinder-on-flat` only)", minimum=0.0,
              strict=True),
        Param("materials", "materials", "[sphere or cylinder, flat]: library names or `[[material]]` names, e.g. "
              "`[\"steel\", \"bronze\"]`", required=True, example='["steel", "steel"]'),
        *PowerContact.params[len(CONTACT_PARAMS) + 2:],  # restitution, damping_model, hysteresis_damping
    )

    @classmethod
    def check(cls, values, error, driven) -> None:
        super().check(values, error, driven)
        cylinder = values.get("geometry") == _CYLINDER
        if cylinder and values.get("length") is None:
            raise error("length", 'missing: a cylinder-on-flat contact needs the length of its line of contact')
        if not cylinder and values.get("length") is not None:
            raise error("length", f'only used with geometry = "{_CYLINDER}"')

    def __post_init__(self) -> None:
        if self.materials is not None and self.geometry == _SPHERE:
            object.__setattr__(self, "coefficient", hertz.sphere_coefficient(self.e_star, self.radius))
            object.__setattr__(self, "exponent", 1.5)
        elif self.materials is not None:
            # The engine shapes its first steps into a closing contact by the law's exponent
            # (camsim.engine.dop853); the line law is linear up to a logarithm.
            object.__setattr__(self, "exponent", 1.0)

    # ------------------------------------------------------------------ properties
    @property
    def e_star(self) -> float:
        """E* [Pa] of the two materials."""
        return effective_modulus(*self.materials)

    @property
    def line(self) -> bool:
        return self.geometry == _CYLINDER

    def pressure(self, force) -> np.ndarray:
        """Peak contact pressure p₀ [Pa] at ``force`` [N] (array)."""
        force = np.maximum(np.asarray(force, dtype=float), 0.0)
        if self.line:
            return hertz.line_pressure(force, self.e_star, self.radius, self.length)
        return hertz.sphere_pressure(force, self.e_star, self.radius)

    def pressure_limit(self) -> tuple[float, str] | None:
        """(p₀ at first yield [Pa], the material that yields first), None without yield strengths."""
        given = [m for m in self.materials if m.yield_strength]
        if not given:
            return None
        weak = min(given, key=lambda m: m.yield_strength)
        factor = hertz.LINE_YIELD_FACTOR if self.line else hertz.SPHERE_YIELD_FACTOR
        return factor * weak.yield_strength, weak.name

    def stress(self, peak_force: float) -> dict:
        """Peak pressure at ``peak_force`` [N] against the first-yield pressure (JSON-able, SI)."""
        p0 = float(self.pressure(peak_force))
        limit = self.pressure_limit()
        return {"element": self.name, "geometry": self.geometry, "materials": [m.name for m in self.materials],
                "peak_force": float(peak_force), "peak_pressure": p0,
                "yield_pressure": None if limit is None else limit[0],
                "yields_first": None if limit is None else limit[1],
                "ratio": None if limit is None else p0 / limit[0]}

    # ------------------------------------------------------------------ the line law
    def nonlinear_force(self, delta, delta_rate, v_impact):
        if not self.line:
            return super().nonlinear_force(delta, delta_rate, v_impact)
        force = hertz.line_force(np.maximum(delta, 0.0), self.e_star, self.radius, self.length)
        chi = self.hysteresis(v_impact)
        if chi:
            force = force * (1.0 + chi * delta_rate)
        return np.maximum(force, 0.0)

    def nonlinear_force_scalar(self, delta, delta_rate, v_impact):
        if not self.line:
            return super().nonlinear_force_scalar(delta, delta_rate, v_impact)
        if delta <= 0.0:
            return 0.0
        force = hertz.line_force_scalar(delta, self.e_star, self.radius, self.length)
        chi = self.hysteresis(v_impact)
        if chi:
            force *= 1.0 + chi * delta_rate
        return force if force > 0.0 else 0.0

    def scalar_force(self, v_impact):
        if not self.line:
            return super().scalar_force(v_impact)
        e_star, radius, length, chi = self.e_star, self.radius, self.length, self.hysteresis(v_impact)
        law = hertz.line_force_scalar

        def force(delta: float, delta_rate: float) -> float:
            if delta <= 0.0:
                return 0.0
            f = law(delta, e_star, radius, length) * (1.0 + chi * delta_rate)
            return f if f > 0.0 else 0.0

        return force

    def nonlinear_tangent(self, delta, delta_rate, v_impact):
        if not self.line:
            return super().nonlinear_tangent(delta, delta_rate, v_impact)
        delta = np.asarray(delta, dtype=float)
        chi = self.hysteresis(v_impact)
        pen = np.maximum(delta, 0.0)
        base = hertz.line_force(pen, self.e_star, self.radius, self.length)
        on = base > 0.0
        kt = np.zeros_like(base)
        kt[on] = hertz.line_tangent(base[on], self.e_star, self.radius, self.length)
        factor = 1.0 + chi * np.asarray(delta_rate, dtype=float)
        F = base * factor
        off = F <= 0.0
        return np.where(off, 0.0, F), np.where(off, 0.0, kt * factor), np.where(off, 0.0, base * chi)

    # ------------------------------------------------------------------ impacts
    def _peak(self, mass: float, v: float) -> float:
        """Peak force [N] of the undamped law stopping ``mass`` [kg] arriving at ``v`` [m/s] (energy balance)."""
        from scipy.optimize import brentq

        energy = 0.5 * mass * v * v
        k = hertz.line_stiffness_scale(self.e_star, self.length)
        top = 4.0 * k * self.radius / math.exp(2.0)  # dδ/dF = 0 there: the law's end
        if energy >= float(hertz.line_energy(top, self.e_star, self.radius, self.length)):
            return top
        return brentq(lambda f: float(hertz.line_energy(f, self.e_star, self.radius, self.length)) - energy,
                      top * 1e-300, top, xtol=1e-300, rtol=1e-14)

    def johnson_bounds(self, m1, m2, v):
        if not self.line:
            return super().johnson_bounds(m1, m2, v)
        return self._peak(pair_mass(m1, m2), v), self._peak(pair_mass(math.inf, m2), v)

    def impact_duration(self, m1, m2, v):
        if not self.line:
            return super().impact_duration(m1, m2, v)
        from scipy.integrate import quad

        mu = pair_mass(m1, m2)
        f_max = self._peak(mu, v)
        e_star, radius, length = self.e_star, self.radius, self.length

        def integrand(s: float) -> float:
            # F = F_max·(1 − s²): dδ = δ'(F)·dF, speed √(v² − 2W(F)/μ); finite at s = 0.
            f = f_max * (1.0 - s * s)
            if f <= 0.0:
                return 0.0
            slope = 1.0 / float(hertz.line_tangent(f, e_star, radius, length))
            speed2 = v * v - 2.0 * float(hertz.line_energy(f, e_star, radius, length)) / mu
            return slope * 2.0 * f_max * s / math.sqrt(max(speed2, 1e-300))

        return 2.0 * quad(integrand, 0.0, 1.0, limit=200)[0]

    def describe(self) -> dict:
        out = super().describe()
        out["materials"] = [m.name for m in self.materials]
        out["e_star"] = self.e_star
        if not self.line:
            out["coefficient"], out["exponent"] = self.coefficient, self.exponent
        return out

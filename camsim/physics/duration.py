"""How long an undamped compliant impact lasts: closed forms for linear and power-law contacts.

A rod is discretised finely enough for the fastest impact it takes part in
(:func:`camsim.elements.rod.choose_segments`); these give that impact's contact duration τ
from the contact's law, the masses and the approach speed, before any run.

* Linear contact k on a reduced mass μ: half a period, τ = π·√(μ/k).
* Power law F = C·δ^a (Hertz: a = 1.5): energy balance gives the largest penetration
  δₘ = ((a+1)·μ·v²/(2C))^(1/(a+1)), and the time in and out is
  τ = 2·(δₘ/v)·∫₀¹ dx/√(1 − x^(a+1)) = 2·(δₘ/v)·B(1/(a+1), 1/2)/(a+1)
  (Goldsmith, *Impact*, 1960, §4.2; for a = 1.5 the factor is 2.943, the "2.94·δₘ/v" of
  docs/contacts.md).
"""

from __future__ import annotations

import math

from scipy.special import beta

__all__ = ["linear_contact_duration", "power_contact_duration"]


def linear_contact_duration(stiffness: float, mass: float) -> float:
    """τ = π·√(μ/k) [s] of a linear contact ``stiffness`` k [N/m] on reduced mass μ [kg]."""
    return math.pi * math.sqrt(mass / stiffness)


def power_contact_duration(coefficient: float, exponent: float, mass: float, velocity: float) -> float:
    """τ [s] of an undamped contact F = C·δ^a stopping and returning reduced mass μ [kg] at ``velocity`` [m/s]."""
    a = exponent
    delta_max = ((a + 1.0) * mass * velocity**2 / (2.0 * coefficient)) ** (1.0 / (a + 1.0))
    return 2.0 * delta_max / velocity * beta(1.0 / (a + 1.0), 0.5) / (a + 1.0)

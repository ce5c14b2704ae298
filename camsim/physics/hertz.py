"""Hertz contact laws from geometry and materials: sphere on a flat, cylinder on a flat.

Plain functions over SI floats (numpy arrays where noted). E* is the contact modulus of the
two bodies, 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂ (:func:`camsim.physics.materials.effective_modulus`).

* **Sphere on a flat** (point contact; Johnson, K. L., *Contact Mechanics*, Cambridge 1985,
  §4.2, eqs. 4.22–4.25): F = (4/3)·E*·√R·δ^1.5, contact radius a = √(R·δ) = (3FR/4E*)^(1/3),
  peak pressure p₀ = 3F/(2πa²) = (6F·E*²/(π³R²))^(1/3). For two equal materials with ν = 0.3
  the coefficient is the thesis's 0.518·E·√D (eq. C.10).
* **Cylinder on a flat** (line contact of length L; Johnson 1985 §4.3 and §5.6; Norton,
  *Machine Design*, §7.10): contact half-width b = √(4FR/(πLE*)), peak pressure
  p₀ = 2F/(πbL) = √(F·E*/(πLR)). Its force–approach relation is not a power law: the
  approach of each body's centre to the contact is logarithmic in the load, Johnson's
  δᵢ = F(1 − νᵢ²)/(πLEᵢ)·(2 ln(4R/b) − 1) (eq. 5.36, the compression of a cylinder from its
  contact to its axis). camsim takes the flat's compression over the same depth (its datum
  at the depth of the cylinder's axis, where a half-space's displacement under a line load
  is otherwise undefined), so that

      δ = F/(πLE*)·(2 ln(4R/b) − 1) = (F/k)·(ln(4kR/F) − 1),      k = πLE*,

  which inverts in closed form with the lower branch of Lambert's W:
  F = k·δ / (−W₋₁(−e·δ/(4R))), valid for δ < 4R/e² (b < 1.47 R: every elastic contact).
  Its stiffness dF/dδ = k/(ln(4kR/F) − 2) and energy ∫F dδ = F²/(2k)·(ln(4kR/F) − 3/2) are
  closed forms too.

First yield (Johnson 1985 §6.2, Tresca, ν = 0.3): beneath the surface when p₀ reaches
1.60·Y for a point contact and 1.67·Y for a line contact, Y the yield strength of the
weaker body.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "SPHERE_YIELD_FACTOR", "LINE_YIELD_FACTOR", "sphere_coefficient", "sphere_pressure", "sphere_contact_radius",
    "line_stiffness_scale", "line_force", "line_force_scalar", "line_approach", "line_tangent", "line_energy",
    "line_pressure", "line_half_width", "lambert_w_lower",
]

#: p₀/Y at the first yield of a point contact (Johnson 1985 §6.2, Tresca, ν = 0.3).
SPHERE_YIELD_FACTOR = 1.60
#: p₀/Y at the first yield of a line contact (Johnson 1985 §6.2, Tresca, ν = 0.3).
LINE_YIELD_FACTOR = 1.67


# ------------------------------------------------------------------------------ sphere
def sphere_coefficient(e_star: float, radius: float) -> float:
    """C of F = C·δ^1.5 [N/m^1.5]: (4/3)·E*·√R (Johnson 1985 eq. 4.23)."""
    return 4.0 / 3.0 * e_star * math.sqrt(radius)


def sphere_contact_radius(force, e_star: float, radius: float):
    """Radius a [m] of the contact circle under ``force`` [N]: (3FR/(4E*))^(1/3)."""
    return np.cbrt(3.0 * np.asarray(force, dtype=float) * radius / (4.0 * e_star))


def sphere_pressure(force, e_star: float, radius: float):
    """Peak contact pressure p₀ [Pa] of a sphere on a flat: (6F·E*²/(π³R²))^(1/3)."""
    return np.cbrt(6.0 * np.asarray(force, dtype=float) * e_star**2 / (math.pi**3 * radius**2))


# ------------------------------------------------------------------------------ cylinder
def line_stiffness_scale(e_star: float, length: float) -> float:
    """k = π·L·E* [N/m], the scale of the line-contact law (module docstring)."""
    return math.pi * length * e_star


def lambert_w_lower(z):
    """W₋₁(z) for z in [−1/e, 0) (numpy array or float): the root w ≤ −1 of w·eʷ = z.

    An asymptotic start (near 0: ln(−z) − ln(−ln(−z)); near −1/e: the branch-point series)
    polished by Halley's iteration to rounding; checked against ``scipy.special.lambertw``
    (k = −1) in tests/elements/test_hertz.py.
    """
    z = np.asarray(z, dtype=float)
    scalar = z.ndim == 0
    z = np.atleast_1d(z)
    if np.any(z >= 0.0) or np.any(z < -1.0 / math.e - 1e-15):
        raise ValueError("W_-1 is real only for -1/e <= z < 0")
    p = -np.sqrt(np.maximum(2.0 * (1.0 + math.e * z), 0.0))
    near = p - p * p / 3.0 + 11.0 / 72.0 * p**3 - 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = np.log(-z)
        l2 = np.log(-l1)
        far = l1 - l2 + l2 / l1
    w = np.where(z < -0.25, near, far)
    for _ in range(12):
        ew = np.exp(w)
        f = w * ew - z
        denom = ew * (w + 1.0) - (w + 2.0) * f / (2.0 * w + 2.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(denom != 0.0, f / denom, 0.0)
        w = w - step
        if np.all(np.abs(step) <= 4e-16 * np.abs(w)):
            break
    return float(w[0]) if scalar else w


def line_force(delta, e_star: float, radius: float, length: float):
    """Force [N] of a cylinder (radius, length) pressed ``delta`` [m] into a flat (module docstring).

    Zero where δ ≤ 0; numpy arrays in and out.
    """
    delta = np.asarray(delta, dtype=float)
    out = np.zeros_like(delta)
    on = delta > 0.0
    if np.any(on):
        d = delta[on]
        w = lambert_w_lower(-math.e * d / (4.0 * radius))
        out[on] = line_stiffness_scale(e_star, length) * d / (-w)
    return out


def line_force_scalar(delta: float, e_star: float, radius: float, length: float) -> float:
    """:func:`line_force` of one float, in plain Python (the integrator's hot path)."""
    if delta <= 0.0:
        return 0.0
    z = -math.e * delta / (4.0 * radius)
    l1 = math.log(-z)
    l2 = math.log(-l1)
    w = l1 - l2 + l2 / l1
    for _ in range(8):
        ew = math.exp(w)
        f = w * ew - z
        step = f / (ew * (w + 1.0) - (w + 2.0) * f / (2.0 * w + 2.0))
        w -= step
        if abs(step) <= 4e-16 * abs(w):
            break
    return math.pi * length * e_star * delta / (-w)


def line_approach(force, e_star: float, radius: float, length: float):
    """Approach δ [m] under ``force`` [N] > 0: (F/k)·(ln(4kR/F) − 1), k = πLE*."""
    force = np.asarray(force, dtype=float)
    k = line_stiffness_scale(e_star, length)
    return force / k * (np.log(4.0 * k * radius / force) - 1.0)


def line_tangent(force, e_star: float, radius: float, length: float):
    """dF/dδ [N/m] at ``force`` [N] > 0: k/(ln(4kR/F) − 2)."""
    force = np.asarray(force, dtype=float)
    k = line_stiffness_scale(e_star, length)
    return k / (np.log(4.0 * k * radius / force) - 2.0)


def line_energy(force, e_star: float, radius: float, length: float):
    """Elastic energy ∫F dδ [J] stored at ``force`` [N] > 0: F²/(2k)·(ln(4kR/F) − 3/2)."""
    force = np.asarray(force, dtype=float)
    k = line_stiffness_scale(e_star, length)
    return force**2 / (2.0 * k) * (np.log(4.0 * k * radius / force) - 1.5)


def line_half_width(force, e_star: float, radius: float, length: float):
    """Half-width b [m] of the contact band: √(4FR/(πLE*))."""
    return np.sqrt(4.0 * np.asarray(force, dtype=float) * radius / (math.pi * length * e_star))


def line_pressure(force, e_star: float, radius: float, length: float):
    """Peak contact pressure p₀ [Pa] of a line contact: √(F·E*/(πLR))."""
    return np.sqrt(np.asarray(force, dtype=float) * e_star / (math.pi * length * radius))

"""Coefficient of restitution of compliant contacts: the damping an isolated impact needs.

A compliant contact dissipates energy through its damping; the coefficient of restitution
e an *isolated* impact achieves (rebound speed / approach speed) is then a property of the
damping. This module maps a requested e to the damping that achieves it exactly, and back.

Hunt–Crossley (power-law) contacts
----------------------------------
F = C·δ^a·(1 + χ·δ̇). Along an isolated impact of a mass m arriving at v, with
w = δ̇ and m·w·dw/dδ = −C·δ^a·(1 + χ·w), the first integral is

    (m/χ²)·[(χw − ln(1 + χw)) − (α − ln(1 + α))] = −C·δ^(a+1)/(a + 1),   α = χ·v,

and the rebound (δ back to 0, w = −e·v) gives

    α·(1 + e) + ln(1 − α·e) − ln(1 + α) = 0,                         (1)

which depends on α = χ·v only, not on C, a or m (spec §3). :func:`hc_alpha` solves (1)
for α ∈ [0, 1/e): α = 0 at e = 1; near e = 1 a series in ε = 1 − e
(α = ε·(3/2)·(1 + …)); as e → 0, α·e → 1 and α ≈ 1/e − 1 + …, so α → ∞: a perfectly
plastic (e = 0) Hunt–Crossley contact needs infinite damping, and :func:`hc_alpha`
returns ``inf`` there. Published small-damping approximations:

- Lankarani–Nikravesh: α = 3(1 − e²)/4 (the small-damping limit of (1): for e = 0.8 it
  rebounds at 0.847);
- Flores et al. (2011): α = 8(1 − e)/(5e).

:func:`hc_rebound` gives the restitution a given α actually achieves (the inverse of (1)),
and :func:`hc_first_integral` the exact contact velocity δ̇(δ) through the Lambert W
function, a reference for tests.

Damped linear contacts
----------------------
F = max(0, k·δ + c·δ̇) while δ > 0 (force clamped at zero, spec §3). For an isolated
impact of the reduced mass m at v, with ζ = c/(2√(k·m)), the force reaches zero (the
contact releases) at ω_d·t_r = π − 2·arcsin ζ and the rebound is exactly

    e(ζ) = exp(−ζ·(π − 2·arcsin ζ)/√(1 − ζ²))          (ζ < 1)
    e(ζ) = exp(−2ζ·arccosh(ζ)/√(ζ² − 1))               (ζ > 1)
    e(1) = e⁻²,

decreasing from 1 (ζ = 0) to 0 (ζ → ∞, e ≈ 1/(4ζ²)). :func:`linear_damping_ratio`
inverts it once (Brent's method on ln e, to 1e-15 relative).
"""

from __future__ import annotations

import functools
import math

import numpy as np

__all__ = [
    "DAMPING_MODELS",
    "hc_alpha",
    "hc_alpha_exact",
    "hc_alpha_flores",
    "hc_alpha_lankarani_nikravesh",
    "hc_first_integral",
    "hc_rebound",
    "elastogap_damping_ratio",
    "elastogap_restitution",
    "linear_damping_ratio",
    "linear_restitution",
    "reduced_mass",
]


# ---------------------------------------------------------------------- Hunt–Crossley
def _residual(alpha: float, e: float) -> float:
    """Left side of (1), written with log1p for accuracy near α = 0."""
    return alpha * (1.0 + e) + math.log1p(-alpha * e) - math.log1p(alpha)


def _g(alpha: float, e: float) -> float:
    """f(α)/α² of (1), from its series Σ_{k≥2} ((−1)^k − e^k)·α^(k−2)/k for small α."""
    if alpha * max(1.0, e) < 0.25:
        log_e = math.log1p(-(1.0 - e)) if e > 0.5 else (math.log(e) if e > 0 else -math.inf)
        total = 0.0
        for k in range(64, 1, -1):
            # (−1)^k − e^k; for even k, 1 − e^k = −expm1(k·ln e) keeps its digits as e → 1
            coeff = -math.expm1(k * log_e) if k % 2 == 0 else -1.0 - e**k
            total = total * alpha + coeff / k
        return total
    return _residual(alpha, e) / (alpha * alpha)


def hc_alpha_exact(e: float) -> float:
    """α = χ·v that makes a Hunt–Crossley impact rebound with exactly ``e``.

    Parameters
    ----------
    e : float
        Coefficient of restitution, 0 ≤ e ≤ 1 [-].

    Returns
    -------
    float
        α [-] solving α(1 + e) + ln(1 − αe) − ln(1 + α) = 0; 0 for e = 1, ``inf`` for
        e = 0 (a plastic impact needs infinite damping).

    Notes
    -----
    f(α) = α(1 + e) + ln(1 − αe) − ln(1 + α) has a double zero at α = 0
    (f = Σ_{k≥2} ((−1)^k − e^k)·α^k/k), so the root is sought for g(α) = f(α)/α², which is
    (1 − e²)/2 > 0 at 0 (its series, 63 terms, is used for α < 0.25, free of cancellation, which keeps
    full relative precision as e → 1 where α ≈ 3(1 − e)/2) and tends to −∞ at α = 1/e:
    exactly one sign change. Safeguarded Newton on f inside the shrinking bracket runs to
    machine precision. As e → 0 the root approaches 1/e from below
    (1 − α·e ≈ e^(−1−1/e)/e), so α ≈ 1/e.
    """
    e = float(e)
    if not 0.0 <= e <= 1.0 or math.isnan(e):
        raise ValueError(f"restitution must lie in [0, 1], got {e!r}")
    if e == 1.0:
        return 0.0
    if e == 0.0:
        return math.inf

    def g(alpha: float) -> float:
        return _g(alpha, e)

    lo = 0.0
    hi = (1.0 / e) * (1.0 - 1e-16)
    if g(hi) > 0:  # e so small that the root is within rounding of 1/e
        return hi
    x = min(0.75 * (1.0 - e * e), 0.5 * hi)  # the Lankarani–Nikravesh value as a start
    for _ in range(300):
        if not lo < x < hi:
            x = 0.5 * (lo + hi)
        if g(x) > 0:
            lo = x
        else:
            hi = x
        if hi - lo <= 2e-16 * hi:
            return 0.5 * (lo + hi)
        df = (1.0 + e) - e / (1.0 - x * e) - 1.0 / (1.0 + x)
        x_new = x - _residual(x, e) / df if df != 0.0 else 0.5 * (lo + hi)
        if not lo < x_new < hi:
            x_new = 0.5 * (lo + hi)
        if abs(x_new - x) <= 1e-16 * x:
            return x_new
        x = x_new
    return x


def hc_alpha_lankarani_nikravesh(e: float) -> float:
    """Lankarani–Nikravesh (1990) factor α = 3(1 − e²)/4 [-] (small-damping limit)."""
    return 0.75 * (1.0 - e * e)


def hc_alpha_flores(e: float) -> float:
    """Flores et al. (2011) factor α = 8(1 − e)/(5e) [-] (``inf`` at e = 0)."""
    return math.inf if e == 0.0 else 8.0 * (1.0 - e) / (5.0 * e)


#: ``damping_model`` names (spec §3) → α(e).
DAMPING_MODELS = {
    "exact": hc_alpha_exact,
    "lankarani-nikravesh": hc_alpha_lankarani_nikravesh,
    "flores": hc_alpha_flores,
}


@functools.lru_cache(maxsize=1024)
def hc_alpha(e: float, model: str = "exact") -> float:
    """α = χ·v for restitution ``e`` under a ``damping_model`` [-] (see :data:`DAMPING_MODELS`)."""
    try:
        return DAMPING_MODELS[model](e)
    except KeyError:
        raise ValueError(f"unknown damping model {model!r}; expected one of {', '.join(DAMPING_MODELS)}") from None


def hc_rebound(alpha: float) -> float:
    """Restitution an isolated Hunt–Crossley impact achieves with α = χ·v [-].

    The inverse of (1): solves (1) for e ∈ (0, 1] given α ≥ 0 (e = 1 at α = 0).
    """
    alpha = float(alpha)
    if alpha < 0 or math.isnan(alpha):
        raise ValueError(f"alpha must be >= 0, got {alpha!r}")
    if alpha == 0.0:
        return 1.0
    if math.isinf(alpha):
        return 0.0
    from scipy.optimize import brentq

    hi = min(1.0, 1.0 / alpha) * (1.0 - 1e-16)
    def f(e: float) -> float:
        return _g(alpha, e)

    if f(hi) > 0:
        return hi
    return brentq(f, 1e-300, hi, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=500)


def hc_first_integral(delta, v0: float, alpha: float, mass: float, coefficient: float, exponent: float, branch: str):
    """Exact δ̇(δ) of an isolated Hunt–Crossley impact (Lambert W) [m/s].

    Parameters
    ----------
    delta : array_like
        Penetration δ ≥ 0 [m].
    v0 : float
        Approach speed, δ̇ at δ = 0 on the way in [m/s], > 0.
    alpha : float
        χ·v0 [-], > 0.
    mass : float
        Reduced mass [kg].
    coefficient, exponent : float
        C [N/m^a] and a [-] of F = C·δ^a·(1 + χ·δ̇).
    branch : {"approach", "rebound"}
        δ̇ > 0 (Lambert W branch −1) or δ̇ < 0 (branch 0).

    Returns
    -------
    ndarray
        δ̇ [m/s]. With y = 1 + χ·δ̇: y − ln y = K(δ) =
        1 + α − ln(1 + α) − χ²·C·δ^(a+1)/((a + 1)·m), so y = −W_k(−e^(−K)).
    """
    from scipy.special import lambertw

    chi = alpha / v0
    delta = np.asarray(delta, dtype=float)
    K = 1.0 + alpha - math.log1p(alpha) - chi * chi * coefficient * delta ** (exponent + 1) / ((exponent + 1) * mass)
    k = -1 if branch == "approach" else 0
    y = -np.real(lambertw(-np.exp(-K), k))
    return (y - 1.0) / chi


# ---------------------------------------------------------------------- linear contacts
def linear_restitution(zeta: float) -> float:
    """Rebound of an isolated impact on a clamped linear spring-damper [-].

    Parameters
    ----------
    zeta : float
        Damping ratio c/(2√(k·m)) ≥ 0 [-], m the reduced mass of the impact.

    Returns
    -------
    float
        e(ζ) (module docstring): the mass leaves when F = k·δ + c·δ̇ reaches 0, at
        ω_d·t_r = π − 2·arcsin ζ.
    """
    z = float(zeta)
    if z < 0 or math.isnan(z):
        raise ValueError(f"damping ratio must be >= 0, got {zeta!r}")
    if z == 0.0:
        return 1.0
    if math.isinf(z):
        return 0.0
    if z == 1.0:
        return math.exp(-2.0)
    # π − 2·arcsin ζ = 2·arccos ζ; both forms are free of cancellation near ζ = 1.
    if z < 1.0:
        return math.exp(-2.0 * z * math.acos(z) / math.sqrt((1.0 - z) * (1.0 + z)))
    return math.exp(-2.0 * z * math.acosh(z) / math.sqrt((z - 1.0) * (z + 1.0)))


def linear_damping_ratio(e: float) -> float:
    """ζ for which an isolated impact on a clamped linear contact rebounds with ``e`` [-].

    Parameters
    ----------
    e : float
        Coefficient of restitution, 0 ≤ e ≤ 1 [-].

    Returns
    -------
    float
        ζ ≥ 0; 0 for e = 1, ``inf`` for e = 0. The damping coefficient is then
        c = 2ζ·√(k·m) with the contact's stiffness k and reduced mass m.
    """
    return _damping_ratio_for(linear_restitution, e, xtol=1e-300, rtol=4 * np.finfo(float).eps)


def _damping_ratio_for(restitution_of, e: float, xtol: float, rtol: float, largest: float = math.inf) -> float:
    """ζ with ``restitution_of(ζ) = e``, by Brent's method on ln e (a decreasing mapping with
    e(0) = 1): 0 for e = 1, ``inf`` for e = 0 or where no ζ up to ``largest`` gets there."""
    from scipy.optimize import brentq

    e = float(e)
    if not 0.0 <= e <= 1.0 or math.isnan(e):
        raise ValueError(f"restitution must lie in [0, 1], got {e!r}")
    if e == 1.0:
        return 0.0
    if e == 0.0:
        return math.inf
    target = math.log(e)

    def excess(z):
        return math.log(max(restitution_of(z), 1e-300)) - target

    hi = 1.0
    while excess(hi) > 0.0:
        hi *= 2.0
        if hi > largest:
            return math.inf
    return brentq(excess, 0.0, hi, xtol=xtol, rtol=rtol, maxiter=500)


# ---------------------------------------------------------------------- ElastoGap
@functools.lru_cache(maxsize=256)
def elastogap_restitution(zeta: float) -> float:
    """Rebound of an isolated impact on Modelica's ElastoGap law (n = 1) [-].

    F = k·δ + clip(c·δ̇, −k·δ, k·δ) for a reduced mass m arriving at v; in τ = ω·t
    (ω = √(k/m)), δ in units of v/ω and ζ = c/(2√(k·m)), three phases in closed form:

    1. the approach's clip, F = 2kδ: δ = sin(√2·τ)/√2, δ̇ = cos(√2·τ), until
       2ζ·δ̇ = δ, i.e. √2·τ₁ = arctan(2√2·ζ);
    2. the law, δ'' + 2ζ·δ̇ + δ = 0 (its exact 2 × 2 exponential), until the force
       δ + 2ζ·δ̇ reaches zero (Brent's method on the exact solution, to rounding);
    3. the rebound's clip, F = 0: the bodies part at the velocity reached, e = −δ̇₂.

    Parameters
    ----------
    zeta : float
        Damping ratio c/(2√(k·m)) ≥ 0 [-].

    Returns
    -------
    float
        e(ζ), 1 at ζ = 0, decreasing.
    """
    from scipy.linalg import expm
    from scipy.optimize import brentq

    z = float(zeta)
    if z < 0 or math.isnan(z):
        raise ValueError(f"damping ratio must be >= 0, got {zeta!r}")
    if z == 0.0:
        return 1.0
    if math.isinf(z):
        return 0.0
    x1 = math.atan(2.0 * math.sqrt(2.0) * z)
    y1 = np.array([math.sin(x1) / math.sqrt(2.0), math.cos(x1)])
    M = np.array([[0.0, 1.0], [-1.0, -2.0 * z]])

    def state(tau):
        return expm(M * tau) @ y1

    def force(tau):
        y = state(tau)
        return y[0] + 2.0 * z * y[1]

    # the force falls to zero within a few natural periods or decay times
    step, tau = 0.05, 0.0
    while force(tau + step) > 0.0:
        tau += step
        if tau > 1e4 * (1.0 + z):
            raise ValueError(f"no rebound found for damping ratio {zeta!r}")
        step = min(step * 1.2, 0.5 * (1.0 + z))
    root = brentq(force, tau, tau + step, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=500)
    return float(min(max(-state(root)[1], 0.0), 1.0))


def elastogap_damping_ratio(e: float) -> float:
    """ζ for which an isolated impact on the ElastoGap law (n = 1) rebounds with ``e`` [-]
    (:func:`elastogap_restitution` inverted by Brent's method on ln e); 0 for e = 1, ``inf``
    for e = 0."""
    return _damping_ratio_for(elastogap_restitution, e, xtol=1e-15, rtol=1e-13, largest=1e8)


def reduced_mass(machine, element) -> float:
    """m1·m2/(m1 + m2) of an element's two nodes [kg]; ground, the cam and a driven mass
    count as infinite (they do not yield to the contact)."""
    # the cam nodes and the driven masses of every cam (issue 38: several cams)
    cams = {"cam", *getattr(machine, "cam_names", ())}
    driven = set(getattr(machine, "driven_masses", {}) or ((machine.cam.drives,) if machine.cam is not None else ()))
    inverse = 0.0
    for node in (element.lower, element.upper):
        if node == "ground" or node in cams or node in driven:
            continue
        inverse += 1.0 / machine.mass_of(node)
    if inverse == 0.0:
        raise ValueError(f"element {element.name}: no free mass on either side")
    return 1.0 / inverse

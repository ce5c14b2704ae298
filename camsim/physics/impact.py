"""Closed-form impact-force estimates (thesis §3.3 and appendix C; spec §5).

Plain functions over SI floats (or numpy arrays where noted). Every formula names its
source:

* Johnson, R. C. (1958) "Impact forces in mechanisms", as summarised in thesis §3.3.3
  (eqs. 3.24-3.29 linear contact, 3.34-3.35 power-law contact): the *common velocity*
  bounds.
* Burr, A. H. (1982) "Mechanical Analysis and Design", pp. 591-600, as summarised in thesis
  §3.3.2 (eqs. 3.15-3.23, *deflection and correction factor*) and §3.3.4 (eqs. 3.36-3.49,
  *wave method*).
* Hertz contact of a sphere on a flat (Johnson, K. L. "Contact Mechanics", ch. 4), in the
  form the thesis uses: eq. 3.33 / C.1 (deflection) and eq. C.10 (coefficient).

Naming follows the thesis. In the Johnson bounds ``m1`` is the *driving* mass (the one
the upper bound takes as infinite: a frame, a hard stop, a motor-driven cam) moving at
``v1``, and ``m2`` the *driven* mass moving at ``v2``; they approach when ``v1 - v2 > 0``.
In Burr's formulas ``m1`` is the *striking* mass and ``m2`` the mass of the struck elastic
member.

All quantities are SI: kg, m, s, N, N/m, Pa, kg/m³; a power-law coefficient ``C`` of
``F = C·δ^a`` is in N/m^a.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from camsim.errors import InputError

#: Standard acceleration of gravity [m/s²] (used for drop heights and weights).
STANDARD_GRAVITY = 9.80665

#: Exponent of a Hertzian sphere-on-flat contact ``F = C·δ^1.5``.
HERTZ_SPHERE_EXPONENT = 1.5

__all__ = [
    "HERTZ_SPHERE_EXPONENT",
    "STANDARD_GRAVITY",
    "PowerLawFit",
    "burr_correction_factor",
    "burr_impact_force",
    "burr_impact_force_from_velocity",
    "common_velocity",
    "drop_velocity",
    "fit_power_law",
    "hertz_sphere_coefficient",
    "hertz_sphere_deflection",
    "johnson_bounds",
    "johnson_linear_lower",
    "johnson_linear_upper",
    "johnson_power_lower",
    "johnson_power_upper",
    "ImpactEstimates",
    "estimate_impact",
    "reduced_mass",
    "wave_impact_force",
    "wave_initial_stress",
]


# --------------------------------------------------------------------------- checks


def _positive(name: str, value, *, allow_inf: bool = False) -> None:
    arr = np.asarray(value, dtype=float)
    if np.any(np.isnan(arr)) or np.any(arr <= 0):
        raise InputError(f"{name} must be positive, got {_show(value)}")
    if not allow_inf and np.any(np.isinf(arr)):
        raise InputError(f"{name} must be finite, got {_show(value)}")


def _finite(name: str, value) -> None:
    if not np.all(np.isfinite(np.asarray(value, dtype=float))):
        raise InputError(f"{name} must be finite, got {_show(value)}")


def _non_negative(name: str, value) -> None:
    arr = np.asarray(value, dtype=float)
    if np.any(np.isnan(arr)) or np.any(arr < 0) or np.any(np.isinf(arr)):
        raise InputError(f"{name} must be zero or positive and finite, got {_show(value)}")


def _show(value) -> str:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        return f"{float(arr):g}"
    return f"an array with min {np.nanmin(arr):g}"


def _approach(v1, v2):
    _finite("velocity v1", v1)
    _finite("velocity v2", v2)
    dv = np.asarray(v1, dtype=float) - np.asarray(v2, dtype=float)
    if np.any(dv <= 0):
        raise InputError(
            f"the bodies do not approach: v1 - v2 must be positive, got {_show(dv)} m/s"
        )
    return dv


# --------------------------------------------------------------------- Johnson bounds


def common_velocity(m1, m2, v1, v2):
    """Common velocity at maximum deflection (thesis eq. 3.24, Johnson 1958).

    ``vc = (m1·v1 + m2·v2) / (m1 + m2)``; with ``m1 = inf`` it is ``v1``.

    Parameters
    ----------
    m1, m2 : float or array
        Driving and driven masses [kg]; ``m1`` may be ``inf``.
    v1, v2 : float or array
        Their velocities just before impact [m/s].

    Returns
    -------
    float or array
        Common velocity [m/s].
    """
    _positive("mass m1", m1, allow_inf=True)
    _positive("mass m2", m2)
    m1 = np.asarray(m1, dtype=float)
    share = np.where(np.isinf(m1), 1.0, m1 / (m1 + m2))
    return share * v1 + (1.0 - share) * v2


def reduced_mass(m1, m2):
    """Reduced mass ``m1·m2/(m1 + m2)`` [kg]; ``m2`` when ``m1 = inf``.

    It carries the energy stored at maximum deflection (thesis eq. 3.25):
    ``m1·v1² + m2·v2² − (m1 + m2)·vc² = m1·m2/(m1 + m2)·(v1 − v2)²``, the form used
    here because it is free of cancellation and defined for ``m1 = inf``.

    Parameters
    ----------
    m1, m2 : float or array
        Masses [kg]; ``m1`` may be ``inf``, ``m2`` must be finite.
    """
    _positive("mass m1", m1, allow_inf=True)
    _positive("mass m2", m2)
    m1 = np.asarray(m1, dtype=float)
    m2 = np.asarray(m2, dtype=float)
    with np.errstate(invalid="ignore"):
        mu = np.where(np.isinf(m1), m2, m1 * m2 / (m1 + m2))
    return mu[()] if mu.ndim == 0 else mu


def johnson_linear_lower(stiffness, m1, m2, v1, v2):
    """Johnson's lower bound (finite driving mass) for a linear contact.

    ``F = sqrt(k·[m1·v1² + m2·v2² − (m1 + m2)·vc²])`` (thesis eq. 3.27): the stored
    energy of eq. 3.25, all in a spring of rate ``k``.

    Parameters
    ----------
    stiffness : float or array
        Contact stiffness k [N/m].
    m1, m2 : float or array
        Driving and driven masses [kg]; ``m1`` may be ``inf`` (then equal to the upper bound).
    v1, v2 : float or array
        Velocities before impact [m/s], with ``v1 - v2 > 0``.

    Returns
    -------
    float or array
        Peak contact force [N].
    """
    _positive("stiffness", stiffness)
    dv = _approach(v1, v2)
    return np.sqrt(stiffness * reduced_mass(m1, m2) * dv**2)


def johnson_linear_upper(stiffness, m2, v1, v2):
    """Johnson's upper bound (infinite driving mass) for a linear contact.

    ``F = (v1 − v2)·sqrt(k·m2)`` (thesis eq. 3.29): the peak force of an undamped spring
    ``k`` stopping a mass ``m2`` that arrives at ``v1 − v2``.

    Parameters
    ----------
    stiffness : float or array
        Contact stiffness k [N/m].
    m2 : float or array
        Driven mass [kg].
    v1, v2 : float or array
        Velocities before impact [m/s], with ``v1 - v2 > 0``.

    Returns
    -------
    float or array
        Peak contact force [N].
    """
    _positive("stiffness", stiffness)
    _positive("mass m2", m2)
    dv = _approach(v1, v2)
    return dv * np.sqrt(stiffness * np.asarray(m2, dtype=float))


def _power_force(coefficient, exponent, energy_mass, dv):
    # C^(1/(a+1)) · {(a+1)/2 · m·dv²}^(a/(a+1))
    a = np.asarray(exponent, dtype=float)
    return np.asarray(coefficient, dtype=float) ** (1.0 / (a + 1.0)) * (
        (a + 1.0) / 2.0 * energy_mass * dv**2
    ) ** (a / (a + 1.0))


def johnson_power_lower(coefficient, exponent, m1, m2, v1, v2):
    """Johnson's lower bound (finite driving mass) for a power-law contact ``F = C·δ^a``.

    ``F = C^(1/(a+1))·{(a+1)/2·[m1·v1² + m2·v2² − (m1+m2)·vc²]}^(a/(a+1))``
    (thesis eq. 3.34): the energy ``C·δ^(a+1)/(a+1)`` stored at maximum deflection
    equals the kinetic energy lost to the common velocity.

    Parameters
    ----------
    coefficient : float or array
        C [N/m^a].
    exponent : float or array
        a [-], positive (1.5 for a Hertzian sphere).
    m1, m2 : float or array
        Driving and driven masses [kg]; ``m1`` may be ``inf``.
    v1, v2 : float or array
        Velocities before impact [m/s], with ``v1 - v2 > 0``.

    Returns
    -------
    float or array
        Peak contact force [N].
    """
    _positive("coefficient", coefficient)
    _positive("exponent", exponent)
    dv = _approach(v1, v2)
    return _power_force(coefficient, exponent, reduced_mass(m1, m2), dv)


def johnson_power_upper(coefficient, exponent, m2, v1, v2):
    """Johnson's upper bound (infinite driving mass) for a power-law contact ``F = C·δ^a``.

    ``F = C^(1/(a+1))·{(a+1)/2·m2·(v1 − v2)²}^(a/(a+1))`` (thesis eq. 3.35): exactly the
    peak force of an undamped contact ``C·δ^a`` stopping ``m2`` arriving at ``v1 − v2``.
    With a = 1.5 this is the thesis's "common velocity" column of table 6 (eq. C.9).

    Parameters
    ----------
    coefficient : float or array
        C [N/m^a].
    exponent : float or array
        a [-], positive.
    m2 : float or array
        Driven mass [kg].
    v1, v2 : float or array
        Velocities before impact [m/s], with ``v1 - v2 > 0``.

    Returns
    -------
    float or array
        Peak contact force [N].
    """
    _positive("coefficient", coefficient)
    _positive("exponent", exponent)
    _positive("mass m2", m2)
    dv = _approach(v1, v2)
    return _power_force(coefficient, exponent, np.asarray(m2, dtype=float), dv)


def johnson_bounds(
    law: Literal["linear", "power"],
    m1: float,
    m2: float,
    v1: float,
    v2: float,
    *,
    stiffness: float | None = None,
    coefficient: float | None = None,
    exponent: float | None = None,
) -> tuple[float, float]:
    """Johnson's lower and upper bounds of the peak impact force, for one impact.

    Used to annotate each simulated impact. ``law = "linear"`` needs ``stiffness``
    (eqs. 3.27, 3.29); ``law = "power"`` needs ``coefficient`` and ``exponent``
    (eqs. 3.34, 3.35).

    Parameters
    ----------
    law : {"linear", "power"}
        Contact law.
    m1 : float
        Driving mass [kg]; ``inf`` for the ground, a frame or a cam (then lower == upper).
    m2 : float
        Driven mass [kg], finite.
    v1, v2 : float
        Velocities just before impact [m/s]; the approach speed ``v1 - v2`` must be > 0.
    stiffness : float, optional
        Linear contact rate k [N/m].
    coefficient : float, optional
        C of ``F = C·δ^a`` [N/m^a].
    exponent : float, optional
        a of ``F = C·δ^a`` [-], > 0.

    Returns
    -------
    (float, float)
        ``(lower, upper)`` peak contact force [N], lower <= upper.

    Raises
    ------
    InputError
        For an unknown law, a missing or non-positive parameter, a non-positive mass or
        bodies that do not approach.
    """
    formulas = {"linear": (johnson_linear, ("stiffness",)), "power": (johnson_power, ("coefficient", "exponent"))}
    if law not in formulas:
        raise InputError(f'johnson_bounds: law must be "linear" or "power", got {law!r}')
    function, needs = formulas[law]
    given = {"stiffness": stiffness, "coefficient": coefficient, "exponent": exponent}
    if any(given[k] is None for k in needs):
        raise InputError(f'johnson_bounds: law "{law}" needs ' + " and ".join(needs))
    extra = [k for k, v in given.items() if v is not None and k not in needs]
    if extra:
        raise InputError(f'johnson_bounds: law "{law}" takes no ' + " or ".join(extra))
    return function(m1, m2, v1, v2, *(given[k] for k in needs))


def johnson_linear(m1, m2, v1, v2, stiffness) -> tuple[float, float]:
    """Johnson's (lower, upper) peak force [N] of a linear contact k [N/m] (eqs. 3.27, 3.29).

    Masses [kg] (``m1`` may be ``inf``), velocities before impact [m/s].
    """
    lower = float(johnson_linear_lower(stiffness, m1, m2, v1, v2))
    upper = float(johnson_linear_upper(stiffness, m2, v1, v2))
    return min(lower, upper), upper  # equal up to rounding when m1 = inf


def johnson_power(m1, m2, v1, v2, coefficient, exponent) -> tuple[float, float]:
    """Johnson's (lower, upper) peak force [N] of a contact F = C·δ^a (eqs. 3.34, 3.35)."""
    lower = float(johnson_power_lower(coefficient, exponent, m1, m2, v1, v2))
    upper = float(johnson_power_upper(coefficient, exponent, m2, v1, v2))
    return min(lower, upper), upper


# ------------------------------------------------------------------------------ Burr


def drop_velocity(height, gravity=STANDARD_GRAVITY):
    """Impact velocity of a body dropped from rest, ``v = sqrt(2·g·h)`` (thesis eq. C.4).

    Parameters
    ----------
    height : float or array
        Drop height h [m], >= 0.
    gravity : float
        g [m/s²].

    Returns
    -------
    float or array
        Impact velocity [m/s].
    """
    _non_negative("drop height", height)
    _positive("gravity", gravity)
    return np.sqrt(2.0 * gravity * np.asarray(height, dtype=float))


def burr_correction_factor(m1, m2):
    """Burr's correction factor ``η = m1/(m1 + m2/3)`` (thesis eq. 3.20; Burr p. 593).

    The share of the striking mass's kinetic energy left after it sets the struck
    elastic member moving, assuming the member's particle velocities are proportional to
    its static deflection (a bar fixed at its far end).

    Parameters
    ----------
    m1 : float or array
        Striking mass [kg].
    m2 : float or array
        Mass of the struck elastic member [kg], >= 0 (0: a massless spring, η = 1).

    Returns
    -------
    float or array
        η [-], in (0, 1].
    """
    _positive("striking mass m1", m1)
    _non_negative("struck member mass m2", m2)
    return np.asarray(m1, dtype=float) / (m1 + np.asarray(m2, dtype=float) / 3.0)


def burr_impact_force(weight, stiffness, height, eta=1.0):
    """Burr's deflection and correction factor estimate for a dropped weight.

    ``F = W′·(1 + sqrt(1 + 2·η·h/δst))`` with ``δst = W′/k`` (thesis eq. 3.16, C.5;
    Burr p. 591). ``h = 0`` gives ``2·W′``, a suddenly applied load.

    Parameters
    ----------
    weight : float or array
        Weight of the striking body W′ = m1·g [N].
    stiffness : float or array
        Stiffness of the struck member k [N/m] (δst = W′/k is its static deflection under W′).
    height : float or array
        Drop height h [m], >= 0.
    eta : float or array
        Correction factor η [-] in (0, 1] (see :func:`burr_correction_factor`); the thesis
        used η = 1 in appendix C (eq. C.6).

    Returns
    -------
    float or array
        Peak force [N].
    """
    _positive("weight", weight)
    _positive("stiffness", stiffness)
    _non_negative("drop height", height)
    _positive("correction factor eta", eta)
    if np.any(np.asarray(eta, dtype=float) > 1.0):
        raise InputError(f"correction factor eta must be at most 1, got {_show(eta)}")
    weight = np.asarray(weight, dtype=float)
    static_deflection = weight / stiffness
    return weight * (1.0 + np.sqrt(1.0 + 2.0 * eta * np.asarray(height, dtype=float) / static_deflection))


def burr_impact_force_from_velocity(mass, stiffness, velocity, eta=1.0, gravity=STANDARD_GRAVITY):
    """Burr's estimate with an impact velocity in place of the drop height.

    ``F = W′·(1 + sqrt(1 + η·m1·v0²/(m1·g·δst)))`` (thesis eq. 3.23), i.e.
    :func:`burr_impact_force` with ``W′ = m1·g`` and ``h = v0²/(2g)`` (eq. 3.22).

    Parameters
    ----------
    mass : float or array
        Striking mass m1 [kg].
    stiffness : float or array
        Stiffness of the struck member k [N/m].
    velocity : float or array
        Impact speed v0 [m/s], >= 0.
    eta : float or array
        Correction factor η [-].
    gravity : float
        g [m/s²], which sets both the weight W′ and the equivalent height.

    Returns
    -------
    float or array
        Peak force [N].
    """
    _positive("mass", mass)
    _positive("gravity", gravity)
    _finite("velocity", velocity)
    velocity = np.asarray(velocity, dtype=float)
    if np.any(velocity < 0):
        raise InputError(f"impact speed must be zero or positive, got {_show(velocity)} m/s")
    height = velocity**2 / (2.0 * gravity)
    return burr_impact_force(np.asarray(mass, dtype=float) * gravity, stiffness, height, eta)


def wave_initial_stress(velocity, modulus, density):
    """Initial stress of a striking impact on a bar, ``σ0 = v0·sqrt(E·ρ)`` (thesis eq. 3.43).

    Parameters
    ----------
    velocity : float or array
        Impact speed v0 [m/s].
    modulus : float or array
        Young's modulus of the bar E [Pa].
    density : float or array
        Mass density of the bar ρ [kg/m³].

    Returns
    -------
    float or array
        σ0 [Pa].
    """
    _positive("modulus", modulus)
    _positive("density", density)
    _finite("velocity", velocity)
    return np.asarray(velocity, dtype=float) * np.sqrt(np.asarray(modulus, dtype=float) * density)


def wave_impact_force(velocity, modulus, density, area, length, striking_mass):
    """Burr's wave-method force on a bar fixed at its far end (thesis eq. 3.49).

    ``F = σ0·A·(1 + sqrt(1/β + 2/3))`` with ``σ0 = v0·sqrt(E·ρ)`` and
    ``β = ρ·A·L / m1`` (bar mass over striking mass). Burr p. 600: an approximation of the
    peak stress at the struck end (Timoshenko's), good for β small (a heavy striker).

    Parameters
    ----------
    velocity : float or array
        Impact speed v0 [m/s], > 0.
    modulus : float or array
        Young's modulus of the bar E [Pa].
    density : float or array
        Mass density of the bar ρ [kg/m³].
    area : float or array
        Bar cross-section A [m²].
    length : float or array
        Bar length L [m].
    striking_mass : float or array
        Striking mass m1 [kg].

    Returns
    -------
    float or array
        Peak force [N].
    """
    _positive("impact speed", velocity)
    _positive("bar area", area)
    _positive("bar length", length)
    _positive("striking mass", striking_mass)
    sigma0 = wave_initial_stress(velocity, modulus, density)
    beta = np.asarray(density, dtype=float) * area * length / striking_mass
    return sigma0 * np.asarray(area, dtype=float) * (1.0 + np.sqrt(1.0 / beta + 2.0 / 3.0))


# ----------------------------------------------------------------------------- Hertz


def hertz_sphere_coefficient(modulus, diameter):
    """Coefficient C of a sphere pressed on a flat, ``F = C·δ^1.5`` (thesis eq. C.10).

    ``C = 0.518·E·sqrt(D)``: Hertz's ``F = 4/3·E*·sqrt(R)·δ^1.5`` for two bodies of the
    same material with ν ≈ 0.3 (``E* = E/(2(1 − ν²))``, ``R = D/2``; K. L. Johnson,
    Contact Mechanics, §4.2).

    Parameters
    ----------
    modulus : float or array
        Young's modulus E [Pa].
    diameter : float or array
        Sphere diameter D [m].

    Returns
    -------
    float or array
        C [N/m^1.5].
    """
    _positive("modulus", modulus)
    _positive("diameter", diameter)
    return 0.518 * np.asarray(modulus, dtype=float) * np.sqrt(np.asarray(diameter, dtype=float))


def hertz_sphere_deflection(force, modulus, diameter):
    """Approach of a sphere on a flat under a force, ``δ = 1.55·(F²/(E²·D))^(1/3)``.

    Thesis eq. 3.33 / C.1 (same material, ν ≈ 0.3); the inverse of
    :func:`hertz_sphere_coefficient` up to the rounding of its constants.

    Parameters
    ----------
    force : float or array
        Contact force F [N], >= 0.
    modulus : float or array
        Young's modulus E [Pa].
    diameter : float or array
        Sphere diameter D [m].

    Returns
    -------
    float or array
        Deflection δ [m].
    """
    _non_negative("force", force)
    _positive("modulus", modulus)
    _positive("diameter", diameter)
    force = np.asarray(force, dtype=float)
    return 1.55 * np.cbrt(force**2 / (np.asarray(modulus, dtype=float) ** 2 * diameter))


# ------------------------------------------------------------------------------- fit


@dataclass(frozen=True)
class PowerLawFit:
    """A power law ``F = coefficient·δ^exponent`` fitted to force-deflection samples.

    Attributes
    ----------
    coefficient : float
        C [N/m^a] (in the units of the samples if they were not SI).
    exponent : float
        a [-].
    r_squared : float
        Coefficient of determination of the straight-line fit in log-log space [-].
    """

    coefficient: float
    exponent: float
    r_squared: float


def fit_power_law(deflection, force) -> PowerLawFit:
    """Fit ``F = C·δ^a`` by least squares on ``log F = log C + a·log δ`` (thesis §3.3.3).

    This is how the thesis obtains (C, a) of a contact from its force-deflection curve
    ("the slope ... plotted on a log-log scale", eq. 3.30; eq. 7.1).

    Parameters
    ----------
    deflection : array_like
        Deflections δ [m], all positive.
    force : array_like
        Forces F [N], all positive, same length.

    Returns
    -------
    PowerLawFit
        C [N/m^a], a [-] and R² [-] of the log-log fit.

    Raises
    ------
    InputError
        Fewer than 3 points, arrays of different lengths, non-finite or non-positive
        values, or all deflections equal.
    """
    x = np.asarray(deflection, dtype=float).ravel()
    y = np.asarray(force, dtype=float).ravel()
    if x.shape != y.shape:
        raise InputError(f"deflection and force differ in length ({x.size} and {y.size})")
    if x.size < 3:
        raise InputError(f"a power-law fit needs at least 3 points, got {x.size}")
    for name, values in (("deflection", x), ("force", y)):
        if not np.all(np.isfinite(values)):
            raise InputError(f"{name} values must be finite")
        bad = np.flatnonzero(values <= 0)
        if bad.size:
            raise InputError(
                f"{name} values must be positive for a log-log fit; point {bad[0] + 1} is {values[bad[0]]:g}"
            )
    lx, ly = np.log(x), np.log(y)
    if np.ptp(lx) == 0:
        raise InputError("all deflections are equal; the exponent is undetermined")
    design = np.column_stack([np.ones_like(lx), lx])
    (log_c, a), *_ = np.linalg.lstsq(design, ly, rcond=None)
    residual = ly - (log_c + a * lx)
    total = np.sum((ly - ly.mean()) ** 2)
    r_squared = 1.0 - float(np.sum(residual**2)) / float(total) if total > 0 else 1.0
    return PowerLawFit(coefficient=float(math.exp(log_c)), exponent=float(a), r_squared=r_squared)


# ------------------------------------------------------------------- the calculator


@dataclass(frozen=True)
class ImpactEstimates:
    """Every estimate :func:`estimate_impact` could make for one striking impact.

    Attributes
    ----------
    velocity : float
        Approach speed of the striking mass [m/s].
    johnson_law : {"linear", "power"} or None
        Contact law of the Johnson bounds (``"power"`` when a coefficient was given).
    johnson_lower, johnson_upper : float or None
        Johnson's bounds [N].
    burr : float or None
        Burr's deflection and correction factor estimate [N].
    eta : float or None
        The correction factor η used for ``burr`` [-].
    wave : float or None
        Burr's wave-method estimate [N].
    missing : dict of str to tuple of str
        For each estimate not made (``"johnson"``, ``"burr"``, ``"wave"``), the
        parameters of :func:`estimate_impact` it needs.
    """

    velocity: float
    johnson_law: str | None
    johnson_lower: float | None
    johnson_upper: float | None
    burr: float | None
    eta: float | None
    wave: float | None
    missing: dict[str, tuple[str, ...]]


def estimate_impact(
    mass: float,
    velocity: float | None = None,
    *,
    drop_height: float | None = None,
    target_mass: float = math.inf,
    stiffness: float | None = None,
    coefficient: float | None = None,
    exponent: float | None = None,
    bar_area: float | None = None,
    bar_length: float | None = None,
    modulus: float | None = None,
    density: float | None = None,
    eta: float | None = None,
    gravity: float = STANDARD_GRAVITY,
) -> ImpactEstimates:
    """Make every impact-force estimate the given inputs allow (the ``camsim impact`` calculator).

    A striking mass ``mass`` approaches a target of mass ``target_mass`` (at rest; fixed by
    default) at ``velocity``, or after falling ``drop_height`` from rest
    (``v = sqrt(2·g·h)``).

    * Johnson bounds (:func:`johnson_bounds`): the target is the driving mass m1 (the one
      the upper bound takes as immovable), the striking mass is m2; with a power-law contact
      when ``coefficient`` and ``exponent`` are given, else linear with ``stiffness``.
      With the fixed target, lower == upper.
    * Burr (:func:`burr_impact_force`): ``W′ = mass·g``, ``k = stiffness``, ``h`` the drop
      height or ``v²/(2g)``; η is ``eta`` if given, else ``mass/(mass + target_mass/3)``
      for a finite target (the target as the struck elastic member), else 1 (a massless
      spring on a rigid base, as the thesis took it in appendix C).
    * Wave (:func:`wave_impact_force`): the target is a bar of ``bar_area``, ``bar_length``,
      ``modulus`` and ``density`` fixed at its far end.

    Parameters
    ----------
    mass : float
        Striking mass [kg].
    velocity : float, optional
        Approach speed [m/s], > 0. Exactly one of ``velocity`` and ``drop_height``.
    drop_height : float, optional
        Drop height [m], > 0.
    target_mass : float
        Target mass [kg]; ``inf`` (default) for a fixed target.
    stiffness : float, optional
        Linear contact stiffness [N/m].
    coefficient, exponent : float, optional
        Power-law contact ``F = C·δ^a``: C [N/m^a], a [-].
    bar_area, bar_length, modulus, density : float, optional
        Bar for the wave method: A [m²], L [m], E [Pa], ρ [kg/m³].
    eta : float, optional
        Burr's correction factor [-], in (0, 1].
    gravity : float
        g [m/s²] for the drop height and the weight.

    Returns
    -------
    ImpactEstimates

    Raises
    ------
    InputError
        Bad values, both or neither of velocity and drop height, half of a power law or
        of a bar, or inputs for no estimate at all.
    """
    _positive("mass", mass)
    _positive("target mass", target_mass, allow_inf=True)
    _positive("gravity", gravity)
    if (velocity is None) == (drop_height is None):
        raise InputError("give exactly one of velocity and drop_height")
    if velocity is not None:
        _positive("approach speed", velocity)
        height = velocity**2 / (2.0 * gravity)
    else:
        _positive("drop height", drop_height)
        height = float(drop_height)
        velocity = float(drop_velocity(height, gravity))
    if (coefficient is None) != (exponent is None):
        raise InputError("a power-law contact needs both coefficient and exponent")
    bar = {"bar_area": bar_area, "bar_length": bar_length, "modulus": modulus, "density": density}
    bar_missing = tuple(name for name, value in bar.items() if value is None)
    if 0 < len(bar_missing) < len(bar):
        raise InputError("the wave estimate needs " + ", ".join(bar_missing))

    if eta is not None and stiffness is None:
        raise InputError("eta applies to the Burr estimate, which needs stiffness")

    missing: dict[str, tuple[str, ...]] = {}
    law = lower = upper = burr = used_eta = wave = None
    if coefficient is not None:
        law = "power"
        lower, upper = johnson_bounds(
            "power", target_mass, mass, 0.0, -velocity, coefficient=coefficient, exponent=exponent
        )
    elif stiffness is not None:
        law = "linear"
        lower, upper = johnson_bounds("linear", target_mass, mass, 0.0, -velocity, stiffness=stiffness)
    else:
        missing["johnson"] = ("stiffness", "coefficient", "exponent")
    if stiffness is not None:
        if eta is not None:
            used_eta = float(eta)
        elif math.isinf(target_mass):
            used_eta = 1.0
        else:
            used_eta = float(burr_correction_factor(mass, target_mass))
        burr = float(burr_impact_force(mass * gravity, stiffness, height, used_eta))
    else:
        missing["burr"] = ("stiffness",)
    if not bar_missing:
        wave = float(wave_impact_force(velocity, modulus, density, bar_area, bar_length, mass))
    else:
        missing["wave"] = bar_missing
    if law is None and burr is None and wave is None:
        raise InputError(
            "no estimate possible: give stiffness (Johnson linear, Burr), coefficient and "
            "exponent (Johnson power law), or bar_area, bar_length, modulus, density (wave)"
        )
    return ImpactEstimates(
        velocity=float(velocity),
        johnson_law=law,
        johnson_lower=lower,
        johnson_upper=upper,
        burr=burr,
        eta=used_eta,
        wave=wave,
        missing=missing,
    )


def coefficient_in_units(coefficient: float, exponent: float, force_unit: str, length_unit: str) -> tuple[float, str]:
    """C of F = C·δ^a expressed in other units: C_u = C_SI·(1 length_unit in m)^a / (1 force_unit in N).

    Parameters
    ----------
    coefficient : float
        C [N/m^a].
    exponent : float
        a [-].
    force_unit, length_unit : str
        The units to express it in (``"lbf"``, ``"in"``).

    Returns
    -------
    (float, str)
        The value and its unit text, e.g. ``"lbf/in**1.425"``.
    """
    from camsim.units import to_si

    value = coefficient * to_si(f"1 {length_unit}", "length") ** exponent / to_si(f"1 {force_unit}", "force")
    return value, f"{force_unit}/{length_unit}**{exponent:.6g}"

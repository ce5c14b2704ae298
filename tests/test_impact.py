"""Tests of camsim.physics.impact: the closed-form impact-force estimates (spec §5).

References: thesis appendix C (table 6 and the constants printed next to it), closed-form
and numerically integrated peaks of undamped contacts (scipy's solve_ivp, independent of
the code under test), and hand calculations written out in the tests.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from camsim.physics import impact
from camsim.errors import InputError

# Unit factors written out (exact definitions), so the tests do not lean on camsim.units.
INCH = 0.0254  # m
LBF = 4.4482216152605  # N
PSI = LBF / INCH**2  # Pa
MASS_IN = LBF / INCH  # kg per lbf*s^2/in

# ----------------------------------------------------------------- thesis table 6

HEIGHTS_IN = [1.0, 1.25, 1.75, 2.25]
TABLE6_COMMON_VELOCITY_LBF = [57.66, 65.93, 80.67, 93.8]
TABLE6_DEFLECTION_CORRECTION_LBF = [30.88, 34.53, 40.85, 46.32]

# Appendix C inputs: a 0.375 in ball, rho = 0.0007349 "lb/in^3" (in fact lbf*s^2/in^4, since
# W' = (4/3) pi r^3 rho g), E = 2.9e7 psi, hard stop 60 800 lbf/in, g = 386.4 in/s^2.
BALL_DIAMETER = 0.375 * INCH
BALL_MASS = 4.0 / 3.0 * math.pi * (0.375 / 2) ** 3 * 0.0007349 * MASS_IN  # kg
BALL_MODULUS = 2.9e7 * PSI
HARD_STOP = 60800 * LBF / INCH
THESIS_G = 386.4 * INCH


def test_appendix_c_constants():
    """Thesis appendix C prints m = 2.029e-5 slug [sic: lbf*s^2/in], W' = 7.841e-3 lb,
    delta_st = 1.289e-7 in and C = 9.2e6; all to the digits printed (0.05 %)."""
    assert BALL_MASS / MASS_IN == pytest.approx(2.029e-5, rel=5e-4)
    weight = BALL_MASS * THESIS_G
    assert weight / LBF == pytest.approx(7.841e-3, rel=5e-4)
    assert weight / HARD_STOP / INCH == pytest.approx(1.289e-7, rel=5e-4)
    c = impact.hertz_sphere_coefficient(BALL_MODULUS, BALL_DIAMETER)
    assert c / (LBF / INCH**1.5) == pytest.approx(9.2e6, rel=5e-4)


@pytest.mark.parametrize("gravity", [THESIS_G, impact.STANDARD_GRAVITY], ids=["thesis_g", "standard_g"])
@pytest.mark.parametrize("index", range(4))
def test_table6_common_velocity(index, gravity):
    """Thesis table 6, 'Common Velocity' column, to 0.2 %: Johnson's power-law upper bound
    (eq. 3.35 = C.9) with the Hertz sphere-on-flat C (a = 1.5), the ball as the driven mass
    and the hard stop as the infinite driving mass; v = sqrt(2 g h)."""
    height = HEIGHTS_IN[index] * INCH
    v = impact.drop_velocity(height, gravity)
    c = impact.hertz_sphere_coefficient(BALL_MODULUS, BALL_DIAMETER)
    upper = impact.johnson_power_upper(c, impact.HERTZ_SPHERE_EXPONENT, BALL_MASS, v, 0.0)
    lower, upper2 = impact.johnson_bounds(
        "power", math.inf, BALL_MASS, 0.0, -v, coefficient=c, exponent=1.5
    )
    expected = TABLE6_COMMON_VELOCITY_LBF[index]
    assert upper / LBF == pytest.approx(expected, rel=2e-3)
    assert upper2 == pytest.approx(upper, rel=1e-12)
    assert lower == pytest.approx(upper, rel=1e-12)


@pytest.mark.parametrize("gravity", [THESIS_G, impact.STANDARD_GRAVITY], ids=["thesis_g", "standard_g"])
@pytest.mark.parametrize("index", range(4))
def test_table6_deflection_correction(index, gravity):
    """Thesis table 6, 'D&C Factor' column, to 0.2 %: Burr's eq. C.6 with eta = 1,
    W' = m g (the ball's weight) and delta_st = W'/k_hs (hard stop 60 800 lbf/in)."""
    height = HEIGHTS_IN[index] * INCH
    force = impact.burr_impact_force(BALL_MASS * gravity, HARD_STOP, height, eta=1.0)
    assert force / LBF == pytest.approx(TABLE6_DEFLECTION_CORRECTION_LBF[index], rel=2e-3)
    via_velocity = impact.burr_impact_force_from_velocity(
        BALL_MASS, HARD_STOP, impact.drop_velocity(height, gravity), eta=1.0, gravity=gravity
    )
    assert via_velocity == pytest.approx(force, rel=1e-12)


# ------------------------------------------------ Johnson against integrated contacts


def _peak_force_stopping(mass, law, speed):
    """Peak force of an undamped contact stopping `mass` arriving at `speed` (solve_ivp)."""

    def rhs(_t, y):
        return [y[1], -law(max(y[0], 0.0)) / mass]

    def turned(_t, y):
        return y[1]

    turned.terminal = True
    turned.direction = -1
    sol = solve_ivp(rhs, [0, 10.0], [0.0, speed], events=turned, rtol=1e-12, atol=1e-15, method="DOP853")
    return law(sol.y_events[0][0][0])


def _peak_force_two_bodies(m1, m2, v1, v2, law):
    """Peak force between two free masses joined by a contact at first touch (solve_ivp)."""

    def rhs(_t, y):
        delta = y[0] - y[2]  # m1 behind m2, moving into it
        force = law(max(delta, 0.0))
        return [y[1], -force / m1, y[3], force / m2]

    def closing_stops(_t, y):
        return y[1] - y[3]

    closing_stops.terminal = True
    closing_stops.direction = -1
    sol = solve_ivp(
        rhs, [0, 10.0], [0.0, v1, 0.0, v2], events=closing_stops, rtol=1e-12, atol=1e-15, method="DOP853"
    )
    y = sol.y_events[0][0]
    return law(y[0] - y[2])


def test_linear_upper_is_spring_stopping_a_mass():
    """F = v sqrt(k m): closed-form peak of x = (v/w) sin(w t); also integrated, to 1e-8."""
    k, m, v = 2.0e6, 0.8, 1.7
    upper = impact.johnson_linear_upper(k, m, v, 0.0)
    assert upper == pytest.approx(k * v / math.sqrt(k / m), rel=1e-12)
    assert upper == pytest.approx(_peak_force_stopping(m, lambda d: k * d, v), rel=1e-8)


@pytest.mark.parametrize("a", [1.0, 1.425, 1.5, 2.3])
def test_power_upper_is_energy_balance_peak(a):
    """Power-law upper bound == integrated peak of m x'' = -C x^a stopping m, to 1e-8."""
    c, m, v = 4.3e9, 0.35, 0.9
    upper = impact.johnson_power_upper(c, a, m, 0.4 + v, 0.4)
    assert upper == pytest.approx(_peak_force_stopping(m, lambda d: c * d**a, v), rel=1e-8)


@pytest.mark.parametrize("law", ["linear", "power"])
def test_lower_is_peak_between_two_free_masses(law):
    """Johnson's lower bound == integrated peak force between two free masses, to 1e-8."""
    m1, m2, v1, v2 = 1.3, 0.45, 2.0, -0.5
    if law == "linear":
        k = 7.0e5
        lower, _ = impact.johnson_bounds("linear", m1, m2, v1, v2, stiffness=k)
        peak = _peak_force_two_bodies(m1, m2, v1, v2, lambda d: k * d)
    else:
        c, a = 2.0e9, 1.425
        lower, _ = impact.johnson_bounds("power", m1, m2, v1, v2, coefficient=c, exponent=a)
        peak = _peak_force_two_bodies(m1, m2, v1, v2, lambda d: c * d**a)
    assert lower == pytest.approx(peak, rel=1e-8)


def test_power_law_with_exponent_one_is_linear():
    """a = 1, C = k: eqs. 3.34/3.35 reduce to 3.27/3.29 (to rounding)."""
    args = (2.0, 0.5, 1.1, -0.2)
    lin = impact.johnson_bounds("linear", *args, stiffness=3.0e6)
    power = impact.johnson_bounds("power", *args, coefficient=3.0e6, exponent=1.0)
    assert power == pytest.approx(lin, rel=1e-12)


def test_lower_energy_form_matches_reduced_mass():
    """m1 v1^2 + m2 v2^2 - (m1+m2) vc^2 written out (eq. 3.25) gives the same lower bound."""
    m1, m2, v1, v2, k = 3.0, 1.0, 2.0, 0.5, 1.0e5
    vc = impact.common_velocity(m1, m2, v1, v2)
    assert vc == pytest.approx((3.0 * 2.0 + 1.0 * 0.5) / 4.0, rel=1e-15)
    energy_form = math.sqrt(k * (m1 * v1**2 + m2 * v2**2 - (m1 + m2) * vc**2))
    assert impact.johnson_linear_lower(k, m1, m2, v1, v2) == pytest.approx(energy_form, rel=1e-12)


@settings(max_examples=200, deadline=None)
@given(
    m1=st.floats(1e-4, 1e4),
    m2=st.floats(1e-4, 1e4),
    v2=st.floats(-10, 10),
    dv=st.floats(1e-3, 20),
    a=st.floats(0.5, 3.0),
)
def test_lower_never_exceeds_upper(m1, m2, v2, dv, a):
    """lower <= upper for any finite masses (the reduced mass is below m2)."""
    lo, up = impact.johnson_bounds("linear", m1, m2, v2 + dv, v2, stiffness=1e6)
    assert lo <= up * (1 + 1e-12)
    lo, up = impact.johnson_bounds("power", m1, m2, v2 + dv, v2, coefficient=1e9, exponent=a)
    assert lo <= up * (1 + 1e-12)


@pytest.mark.parametrize("law,kw", [("linear", {"stiffness": 5e6}), ("power", {"coefficient": 1e10, "exponent": 1.5})])
def test_lower_tends_to_upper_as_driving_mass_grows(law, kw):
    """lower -> upper as m1 -> inf; equal at m1 = inf (relative gap ~ m2/m1)."""
    m2, v1, v2 = 0.2, 1.5, 0.0
    _, upper = impact.johnson_bounds(law, 1.0, m2, v1, v2, **kw)
    gaps = []
    for m1 in [1.0, 1e2, 1e4, 1e6, 1e8]:
        lower, up = impact.johnson_bounds(law, m1, m2, v1, v2, **kw)
        assert up == pytest.approx(upper, rel=1e-14)  # the upper bound does not depend on m1
        gaps.append((upper - lower) / upper)
    assert all(later < earlier for earlier, later in zip(gaps, gaps[1:]))
    assert gaps[-1] < 1e-8
    lower, up = impact.johnson_bounds(law, math.inf, m2, v1, v2, **kw)
    assert lower == up == pytest.approx(upper, rel=1e-14)


def test_arrays():
    """The formulas broadcast over numpy arrays."""
    v = np.array([0.5, 1.0, 2.0])
    f = impact.johnson_linear_upper(4.0, 1.0, v, 0.0)
    np.testing.assert_allclose(f, 2.0 * v, rtol=1e-15)


@pytest.mark.parametrize(
    "args,kw,message",
    [
        (("linear", 1.0, -1.0, 1.0, 0.0), {"stiffness": 1.0}, "mass m2 must be positive"),
        (("linear", 0.0, 1.0, 1.0, 0.0), {"stiffness": 1.0}, "mass m1 must be positive"),
        (("linear", 1.0, math.inf, 1.0, 0.0), {"stiffness": 1.0}, "mass m2 must be finite"),
        (("linear", 1.0, 1.0, 0.0, 1.0), {"stiffness": 1.0}, "do not approach"),
        (("linear", 1.0, 1.0, 1.0, 1.0), {"stiffness": 1.0}, "do not approach"),
        (("linear", 1.0, 1.0, 1.0, 0.0), {"stiffness": -1.0}, "stiffness must be positive"),
        (("linear", 1.0, 1.0, 1.0, 0.0), {}, "needs stiffness"),
        (("power", 1.0, 1.0, 1.0, 0.0), {"coefficient": 1.0, "exponent": 0.0}, "exponent must be positive"),
        (("power", 1.0, 1.0, 1.0, 0.0), {"coefficient": 1.0}, "needs coefficient and exponent"),
        (("hertz", 1.0, 1.0, 1.0, 0.0), {"stiffness": 1.0}, "law must be"),
        (("linear", 1.0, 1.0, math.nan, 0.0), {"stiffness": 1.0}, "must be finite"),
    ],
)
def test_johnson_bounds_rejects_bad_input(args, kw, message):
    with pytest.raises(InputError, match=message):
        impact.johnson_bounds(*args, **kw)


# ----------------------------------------------------------------------------- Burr


def test_burr_hand_numbers():
    """W' = 10 N, k = 1000 N/m (delta_st = 0.01 m), h = 0.1 m, eta = 1:
    F = 10 (1 + sqrt(1 + 20)) = 55.8258 N (hand); eta = 0.5: 10 (1 + sqrt(11)) = 43.1662 N."""
    assert impact.burr_impact_force(10.0, 1000.0, 0.1) == pytest.approx(55.825757, rel=1e-7)
    assert impact.burr_impact_force(10.0, 1000.0, 0.1, eta=0.5) == pytest.approx(43.166248, rel=1e-7)


def test_burr_suddenly_applied_load_is_twice_the_weight():
    """Thesis §3.3.2: h = 0 gives 2 W' (a support removed instantly)."""
    assert impact.burr_impact_force(3.0, 1e5, 0.0) == pytest.approx(6.0, rel=1e-15)


def test_burr_correction_factor_hand():
    """eta = m1/(m1 + m2/3) (eq. 3.20): m1 = 1, m2 = 3 -> 0.5; a massless member -> 1."""
    assert impact.burr_correction_factor(1.0, 3.0) == pytest.approx(0.5, rel=1e-15)
    assert impact.burr_correction_factor(2.0, 0.0) == 1.0


def test_burr_rejects_bad_input():
    with pytest.raises(InputError, match="eta must be at most 1"):
        impact.burr_impact_force(1.0, 1.0, 1.0, eta=1.5)
    with pytest.raises(InputError, match="drop height"):
        impact.burr_impact_force(1.0, 1.0, -1.0)
    with pytest.raises(InputError, match="weight must be positive"):
        impact.burr_impact_force(0.0, 1.0, 1.0)


def test_wave_hand_numbers():
    """Steel bar E = 200 GPa, rho = 7850 kg/m^3, A = 1 cm^2, L = 0.1 m (78.5 g) struck by
    78.5 g at 1 m/s: beta = 1, sigma0 = sqrt(1.57e15) = 3.96232255e7 Pa,
    F = 3962.32255 N * (1 + sqrt(5/3)) = 9077.659 N (hand)."""
    assert impact.wave_initial_stress(1.0, 200e9, 7850.0) == pytest.approx(3.96232255e7, rel=1e-8)
    force = impact.wave_impact_force(1.0, 200e9, 7850.0, 1e-4, 0.1, 0.0785)
    assert force == pytest.approx(9077.659, rel=1e-6)


# ---------------------------------------------------------------------------- Hertz


def test_hertz_coefficient_hand():
    """C = 0.518 E sqrt(D): E = 200 GPa, D = 10 mm -> 0.518 * 2e11 * 0.1 = 1.036e10 N/m^1.5."""
    assert impact.hertz_sphere_coefficient(200e9, 0.01) == pytest.approx(1.036e10, rel=1e-14)


def test_hertz_deflection_thesis_appendix_c():
    """Thesis appendix C: 25 lb on a 3 in sphere, E = 30e6 psi -> 9.52e-5 in (3 digits)."""
    delta = impact.hertz_sphere_deflection(25 * LBF, 30e6 * PSI, 3 * INCH)
    assert delta / INCH == pytest.approx(9.52e-5, rel=1e-3)


def test_hertz_deflection_hand_and_inverse():
    """F = 1000 N, E = 200 GPa, D = 10 mm: 1.55 (1e6/4e20)^(1/3) = 2.103674e-5 m (hand);
    and C delta^1.5 gives F back to the rounding of 0.518 and 1.55 (0.1 %)."""
    delta = impact.hertz_sphere_deflection(1000.0, 200e9, 0.01)
    assert delta == pytest.approx(2.103674e-5, rel=1e-6)
    assert impact.hertz_sphere_coefficient(200e9, 0.01) * delta**1.5 == pytest.approx(1000.0, rel=1e-3)


# ------------------------------------------------------------------------------ fit


@pytest.mark.parametrize("c,a", [(1.11e7 * LBF / INCH**1.425, 1.425), (3.0e5, 1.0), (7.5e12, 2.2)])
def test_fit_recovers_exact_power_law(c, a):
    """Exact samples of F = C d^a: (C, a) back to 1e-10, R^2 = 1."""
    d = np.geomspace(1e-6, 1e-4, 12)
    fit = impact.fit_power_law(d, c * d**a)
    assert fit.coefficient == pytest.approx(c, rel=1e-10)
    assert fit.exponent == pytest.approx(a, rel=1e-10)
    assert fit.r_squared == pytest.approx(1.0, abs=1e-12)


def test_fit_r_squared_below_one_for_scattered_data():
    """Scattered data: R^2 < 1. Hand-checked three points (0, 0), (1, 1), (2, 1.5) in
    natural logs: slope 0.75, SSres = 1/24, SStot = 7/6."""
    d = np.exp([0.0, 1.0, 2.0])
    f = np.exp([0.0, 1.0, 1.5])
    fit = impact.fit_power_law(d, f)
    # x = 0,1,2 (mean 1), y = 0,1,1.5 (mean 5/6): Sxy = 5/6 + 2/3 = 1.5, Sxx = 2 -> a = 0.75;
    # intercept 1/12, residuals -1/12, 2/12, -1/12.
    assert fit.exponent == pytest.approx(0.75, rel=1e-12)
    assert fit.r_squared == pytest.approx(1 - (1 / 24) / (7 / 6), rel=1e-12)


@pytest.mark.parametrize(
    "d,f,message",
    [
        ([1e-5, 2e-5], [1.0, 2.0], "at least 3 points"),
        ([1e-5, 0.0, 3e-5], [1.0, 2.0, 3.0], "deflection values must be positive.*point 2"),
        ([1e-5, 2e-5, 3e-5], [1.0, -2.0, 3.0], "force values must be positive"),
        ([1e-5, 2e-5, 3e-5], [1.0, 2.0], "differ in length"),
        ([1e-5, 1e-5, 1e-5], [1.0, 2.0, 3.0], "all deflections are equal"),
        ([1e-5, np.nan, 3e-5], [1.0, 2.0, 3.0], "finite"),
    ],
)
def test_fit_rejects_bad_data(d, f, message):
    with pytest.raises(InputError, match=message):
        impact.fit_power_law(d, f)


# ------------------------------------------------------------------- the calculator


def test_estimate_impact_fixed_target_drop():
    """A drop from h equals a velocity sqrt(2 g h); fixed target: Johnson lower == upper,
    eta = 1; the wave estimate is absent and says what it needs."""
    m, h, k = 0.5, 0.02, 1e6
    by_height = impact.estimate_impact(m, drop_height=h, stiffness=k)
    by_speed = impact.estimate_impact(m, math.sqrt(2 * 9.80665 * h), stiffness=k)
    assert by_height.johnson_upper == pytest.approx(by_speed.johnson_upper, rel=1e-12)
    assert by_height.burr == pytest.approx(by_speed.burr, rel=1e-12)
    assert by_height.johnson_lower == by_height.johnson_upper
    assert by_height.johnson_law == "linear"
    assert by_height.eta == 1.0
    assert by_height.wave is None
    assert by_height.missing == {"wave": ("bar_area", "bar_length", "modulus", "density")}
    # Burr W'(1 + sqrt(1 + 2h k / W')) by hand: W' = 4.903325 N
    w = 0.5 * 9.80665
    assert by_height.burr == pytest.approx(w * (1 + math.sqrt(1 + 2 * h * k / w)), rel=1e-12)


def test_estimate_impact_finite_target_eta():
    """Finite target M: eta = m/(m + M/3); m = 1, M = 3 -> 0.5."""
    est = impact.estimate_impact(1.0, 1.0, target_mass=3.0, stiffness=1e6)
    assert est.eta == pytest.approx(0.5, rel=1e-15)
    assert est.johnson_lower < est.johnson_upper


@pytest.mark.parametrize(
    "kw,message",
    [
        ({"velocity": 1.0, "drop_height": 1.0, "stiffness": 1.0}, "exactly one"),
        ({"stiffness": 1.0}, "exactly one"),
        ({"velocity": 1.0}, "no estimate possible"),
        ({"velocity": 1.0, "coefficient": 1.0}, "both coefficient and exponent"),
        ({"velocity": 1.0, "bar_area": 1.0}, "wave estimate needs bar_length, modulus, density"),
        ({"velocity": -1.0, "stiffness": 1.0}, "approach speed must be positive"),
        ({"velocity": 1.0, "coefficient": 1.0, "exponent": 1.5, "eta": 0.5}, "eta applies"),
    ],
)
def test_estimate_impact_rejects_bad_input(kw, message):
    with pytest.raises(InputError, match=message):
        impact.estimate_impact(1.0, **kw)

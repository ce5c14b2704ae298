"""The first root of a guard inside one step, on the exact solution of a linear configuration.

Given the state at a step's start and the step's polynomial cam input, the exact state at
any τ in the step is one exact map (:func:`camsim.engine.stepping.exact_partial`); a guard
(affine in the state and the input, with an exact rate) is then located by a safeguarded
Newton iteration bracketed by its sign, started from the root of the cubic Hermite through
its values and rates at the step's ends. A graze that dips below zero and comes back inside
the step is found by bisecting the guard's exact rate for its minimum.
"""

from __future__ import annotations

import numpy as np

from camsim.engine.state import cubic_root
from camsim.engine.stepping import exact_partial, input_at
from camsim.engine.taylor import StepPolynomial, poly_value, poly_value_and_slope

#: Newton on a guard stops when its bracket is this narrow [s] (about one ulp of t ~ 10 s).
ROOT_BRACKET = 1e-15
#: The search for a grazing dip bisects the exact guard rate to this fraction of the step.
DIP_RESOLUTION = 1e-10


#: Points of a step at which a guard's polynomial is screened for its first crossing.
SCREEN_POINTS = 65
_SCREEN = np.linspace(0.0, 1.0, SCREEN_POINTS)
#: Powers of the screen's points (enough for any Taylor polynomial of a step): a polynomial's
#: values on the screen are one product with its coefficients.
_SCREEN_POWERS = _SCREEN[:, None] ** np.arange(96)[None, :]


def _derivative(coef: np.ndarray) -> np.ndarray:
    """The coefficients (low to high) of a polynomial's derivative."""
    return coef[1:] * np.arange(1, coef.size) if coef.size > 1 else np.zeros(1)


def refine(config, guard, z0, Dk, Ek, hk, just_started, ends=None):
    """Locate the first root of the guard in one step on the exact solution: (τ, z) or None.

    The state over the step is its Taylor polynomial (:class:`camsim.engine.taylor.StepPolynomial`),
    so the guard is a scalar polynomial in σ = τ/h: screened at :data:`SCREEN_POINTS`
    points, a sign change brackets the root; without one, each local minimum of the screen
    is polished by Newton's method on the polynomial's derivative, and one at or below zero
    brackets a grazing dip. The root is then found by a safeguarded Newton iteration on the
    polynomial to rounding. A step too long for the series (never one of the grid's) is
    searched on the matrix exponential instead (:func:`refine_expm`).
    """
    poly = StepPolynomial(config, z0, Dk, hk)
    if not poly.ok:
        return refine_expm(config, guard, z0, Dk, Ek, hk, just_started, ends)
    coef = poly.affine(guard.value)
    values = (_SCREEN_POWERS[:, : coef.size] @ coef) if coef.size <= _SCREEN_POWERS.shape[1] else \
        np.polynomial.polynomial.polyval(_SCREEN, coef)
    if just_started:
        values[0] = max(values[0], guard.tol)
    if values[0] <= 0.0:
        return None
    below = np.flatnonzero(values <= 0.0)
    first = int(below[0]) if below.size else values.size
    # a dip between two positive points before the first point at or below zero comes first
    bracket = _polynomial_dip(coef, values[: first + 1] if first < values.size else values)
    if bracket is None:
        if first == values.size:
            return None
        bracket = float(_SCREEN[first - 1]), float(_SCREEN[first])
    x = _polynomial_root(coef, *bracket)
    return x * hk, poly.state(x)


def _polynomial_dip(coef, values):
    """(a, b) with p(a) > 0 ≥ p(b) at the earliest local minimum of the screen (all its
    points positive) that Newton's method on p′ takes to or below zero, or None."""
    d1 = _derivative(coef)
    d2 = _derivative(d1)
    # Horner in Python floats over lists: iterating numpy arrays element by element made
    # each step's scalars numpy objects (the same IEEE arithmetic, several times slower)
    coef, d1, d2 = coef.tolist(), d1.tolist(), d2.tolist()
    inner = np.flatnonzero((values[1:-1] <= values[:-2]) & (values[1:-1] <= values[2:]) & (values[1:-1] > 0.0)) + 1
    for k in inner.tolist():
        a, b = float(_SCREEN[k - 1]), float(_SCREEN[k + 1])
        x = float(_SCREEN[k])
        for _ in range(30):
            slope, curv = poly_value(d1, x), poly_value(d2, x)
            if curv <= 0.0:
                break
            x_new = min(max(x - slope / curv, a), b)
            if abs(x_new - x) <= 1e-16:
                x = x_new
                break
            x = x_new
        if poly_value(coef, x) <= 0.0:
            return a, x  # p(a) > 0: a point of the screen before the minimum
    return None


def _polynomial_root(coef, lo: float, hi: float) -> float:
    """The root of p in (lo, hi], p(lo) > 0 ≥ p(hi): safeguarded Newton to rounding."""
    coef = coef.tolist() if hasattr(coef, "tolist") else coef  # plain floats (see _polynomial_dip)
    x = 0.5 * (lo + hi)
    for _ in range(100):
        p, dp = poly_value_and_slope(coef, x)
        if p > 0.0:
            lo = x
        else:
            hi = x
        if p == 0.0 or hi - lo <= 2e-16 * max(hi, 1e-300):
            break
        x_new = x - p / dp if dp != 0.0 else 0.5 * (lo + hi)
        if not (lo < x_new < hi):
            x_new = 0.5 * (lo + hi)
        x = x_new
    return hi if poly_value(coef, hi) <= 0.0 and hi - lo <= 2e-16 * max(hi, 1e-300) else x


def refine_expm(config, guard, z0, Dk, Ek, hk, just_started, ends=None):
    """:func:`refine` on the exact matrix exponential of each evaluated point (a step too long
    for the Taylor series).

    ``ends`` = (g0, g1, ġ0, ġ1), the exact guard values and rates at the step's ends,
    when known: a sign change then brackets the root, and the root of their cubic
    Hermite interpolant starts Newton's iteration one or two digits from the answer.
    """

    def evaluate(tau):
        z = exact_partial(config, z0, Ek, tau) if tau > 0 else z0
        u = input_at(Dk, tau)
        g = guard.value(z[None, :], u[None, :])[0, 0]
        gd = guard.rate(z[None, :], u[None, :])[0, 0]
        return g, gd, z

    lo = hi = None
    if ends is not None:
        g0, g1, d0, d1 = ends
        if just_started:
            g0 = max(g0, guard.tol)
        if g0 > 0 and g1 <= 0:
            sigma = cubic_root(g0, g1, d0 * hk, d1 * hk)
            lo = (0.0, g0, d0, z0)
            hi = (hk, g1, d1, None)
            return _newton(evaluate, lo, hi, sigma * hk, hk)
    samples = np.linspace(0.0, hk, 9)
    values = []
    for tau in samples:
        g, gd, z = evaluate(tau)
        values.append((tau, g, gd, z))
    if just_started:
        values[0] = (0.0, max(values[0][1], guard.tol), values[0][2], values[0][3])
    for a, b in zip(values[:-1], values[1:]):
        if a[1] > 0 and b[1] <= 0:
            lo, hi = a, b
            break
    if lo is None:
        # Grazing dip: look for the minimum of the exact guard (where its exact rate
        # changes sign), stopping as soon as the guard is seen at or below zero.
        dip = _dip(evaluate, values, hk)
        if dip is None:
            return None
        t_min = dip[0]
        left = [v for v in values if v[0] < t_min and v[1] > 0]
        if not left:
            return None
        lo, hi = left[-1], dip
    a_t, a_g = lo[0], lo[1]
    b_t, b_g = hi[0], hi[1]
    guess = b_t - b_g * (b_t - a_t) / (b_g - a_g) if b_g != a_g else 0.5 * (a_t + b_t)
    return _newton(evaluate, lo, hi, guess, hk)


def _dip(evaluate, values, hk):
    """A point where the guard is ≤ 0 near its smallest sample, or None if it stays > 0.

    ``values`` are (τ, g, ġ, z) samples across the step; the minimum lies where ġ turns
    from negative to positive. Bisection on the sign of the exact ġ, to 1e-10 of the step.
    """
    k = min(range(len(values)), key=lambda i: values[i][1])
    a = values[max(k - 1, 0)]
    b = values[min(k + 1, len(values) - 1)]
    if a[2] >= 0 or b[2] <= 0:  # no interior minimum between the neighbours
        return values[k] if values[k][1] <= 0 else None
    lo_t, hi_t = a[0], b[0]
    while hi_t - lo_t > DIP_RESOLUTION * hk:
        mid = 0.5 * (lo_t + hi_t)
        g, gd, z = evaluate(mid)
        if g <= 0:
            return (mid, g, gd, z)
        if gd < 0:
            lo_t = mid
        else:
            hi_t = mid
    return None


def _newton(evaluate, lo, hi, t, hk):
    """Safeguarded Newton between lo (g > 0) and hi (g ≤ 0) on the exact guard.

    Returns the instant where the guard is zero to rounding, and the state there.
    """
    a_t = lo[0]
    b_t = hi[0]
    z = lo[3]
    if not (a_t < t < b_t):
        t = 0.5 * (a_t + b_t)
    for _ in range(60):
        g, gd, z = evaluate(t)
        if g > 0:
            a_t = t
        else:
            b_t = t
        if g == 0 or b_t - a_t <= ROOT_BRACKET:
            break
        t_new = t - g / gd if gd != 0 else 0.5 * (a_t + b_t)
        if not (a_t < t_new < b_t):
            t_new = 0.5 * (a_t + b_t)
        if abs(t_new - t) <= 1e-16 + 1e-15 * hk:
            t = t_new
            g, gd, z = evaluate(t)
            break
        t = t_new
    return t, z


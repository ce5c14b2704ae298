"""Event location to 1e-9 s at any slope: the final polish of a guard crossing.

The integrator finds a guard's crossing inside one step on the exact solution, with the
cam input represented by the step's degree-7 Hermite polynomial
(:func:`camsim.engine.integrator._refine`). That polynomial is exact to ~1e-20 *relative* to the
cam's own scale, but a guard that crosses zero at a shallow slope (a follower that barely
leaves the cam near its jump speed, where the contact force touches zero almost
tangentially) turns a guard error ε into a time error ε/|ġ|. :func:`polish_crossing`
therefore re-evaluates the guard with the cam input from its **analytic law**
(:meth:`CamProgram.channels`) and the state carried from the located root by its exact
derivatives (z + ż·τ + ½·z̈·τ², ż = A·z + B·u + b; over the ≤ 1e-8 s involved the
neglected (ω·τ)³/6 is below 1e-12 relative for modes up to 10⁵ rad/s), and brackets the
crossing:

0. if the analytic guard already changes sign across the located root ± 5e-11 s, the
   root stands (the usual case, which keeps earlier results bit-identical);
1. else one Newton correction of the root on the analytic guard;
2. the guard at the corrected time ± k·2.5e-11 s (k = 0, 1, 2, one vectorised cam
   evaluation): a sign change between neighbours is a bracket of 2.5e-11 s, inside which
   the crossing is placed by linear interpolation;
3. if no sign change shows (the Hermite root was off by more than 5e-11 s), bisection on
   the analytic guard from a bracket grown around the root (up to ±1e-8 s,
   :data:`MAX_SHIFT`), until it is below 1e-10 s;
4. if the crossing is not within ±1e-8 s either, the guard is located afresh over the
   whole step on the **exact** state (``state_at``: the step's exact map from its start)
   and the analytic cam input (:func:`locate_exact`, Brent's method to 1e-14 s). This is
   the case of a guard that reads the cam acceleration directly — a stuck rigid contact's
   force λ = m·s̈ + … — at a fine grid: the step's Hermite polynomial matches s, ṡ, s̈, s⃛
   at both ends, but inside a step of a few µs its second derivative carries the rounding
   of s amplified by ~1/h² (1e-6 relative at 200 kHz), which moved the Hermite root of a
   release near the jump speed by up to 1e-6 s (issue 25). When the analytic guard does
   not cross inside the step at all (the Hermite "crossing" was that rounding), there is
   no event in this step: ``None``.

The guarantee (docs/model.md): every event is located within 1e-10 s of the crossing
of its guard evaluated with the exact cam law and the exact state, at any slope, except
where the guard is flat to rounding (|ġ|·1e-10 s below the guard's rounding error),
where no time is better defined than the rounding allows.
"""

from __future__ import annotations

import numpy as np

from camsim.elements.affine import N_INPUT, times_rate
from camsim.engine.stepping import input_at

#: Half-width of the final bracket of a crossing [s] (the guarantee is the full width).
BRACKET = 1e-10
#: Largest correction the polish applies to a located root [s].
MAX_SHIFT = 1e-8
_OFFSETS = np.array([-2.0, -1.0, 0.0, 1.0, 2.0]) * 2.5e-11


#: Up to this many instants the cam law is evaluated instant by instant in floats
#: (``channels_at``: microseconds each, where the array path costs tens).
FEW = 8


def _analytic_inputs(cam, t: np.ndarray, step_end: float) -> np.ndarray:
    """The cam input from the cam laws; points at or past a step end take the left limit."""
    if t.size <= FEW and hasattr(cam, "channels_at"):
        return np.array([cam.channels_at(x, side="right" if x < step_end else "left") for x in t.tolist()])
    right = t < step_end
    out = None
    for side, mask in (("right", right), ("left", ~right)):
        if np.any(mask):
            values = cam.channels(t[mask], side=side)
            if out is None:
                out = np.empty((t.size, values.shape[1]))
            out[mask] = values
    return out


def polish_crossing(integrator, config, guard, t_step: float, h_step: float, tau: float, z: np.ndarray, Dk=None,
                    state_at=None):
    """Refine a located crossing on the analytic cam law to a 1e-10 s bracket.

    Parameters
    ----------
    integrator : camsim.engine.integrator.Integrator
        Provides ``cam`` (``channels``).
    config : camsim.model.assembly.Configuration
        The (linear) configuration the crossing belongs to.
    guard : camsim.engine.integrator.Guard
        The guard that crosses (value and exact rate, affine in z and u).
    t_step, h_step : float
        Start and length of the step holding the crossing [s].
    tau : float
        The crossing located on the Hermite input, from ``t_step`` [s].
    z : ndarray
        The exact state there.
    Dk : ndarray (8·c,), optional
        The step's Hermite derivatives of the cam input. The state was integrated with
        that input: where its s differs from the analytic law by more than 1e-11
        relative (a coarse warm-up grid; on a recording grid it agrees to ~1e-15) state and analytic input are not consistent and
        the root is kept as located.

    Returns
    -------
    (tau, z)
        The polished crossing and the state there.
    """
    cam = integrator.cam
    if cam is None or not hasattr(cam, "channels") or guard.rate is None:
        return tau, z
    A, B, b = config.A, config.B, config.b
    t_root = t_step + tau
    step_end = t_step + h_step
    u0 = _analytic_inputs(cam, np.array([t_root]), step_end)[0]
    if Dk is not None:

        u_h = input_at(Dk, tau, channels=1)  # every cam's s is all the check reads
        s_h, s_0 = u_h[0::N_INPUT], u0[0::N_INPUT]  # every cam's s
        if np.any(np.abs(s_h - s_0) > 1e-11 * (np.abs(s_0) + np.abs(s_h)) + 1e-300):
            return tau, z
    if z.size:
        zdot = A @ z + B @ u0 + b
        # u̇ = [ṡ, s̈, s⃛, s⁗] per cam: the jerk channels carry no weight in B
        zddot = A @ zdot + times_rate(B, u0)
    else:
        zdot = zddot = z

    # A stuck rigid contact's release guard is λ + FORCE_TOL (it fires only once the force
    # is really tensile, so that a contact that has just stuck does not release on
    # rounding); the event itself is where λ reaches zero.
    offset = guard.tol if guard.kind == "release" and guard.element in config.stuck_contacts else 0.0

    def guard_at(times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        U = _analytic_inputs(cam, times, step_end)
        dt = (times - t_root)[:, None]
        Z = z[None, :] + dt * zdot[None, :] + 0.5 * dt**2 * zddot[None, :] if z.size else np.zeros((times.size, 0))
        return guard.value(Z, U)[:, 0] - offset, Z

    if offset == 0.0:
        # Already certified? The analytic guard changes sign across t_root ± 5e-11 s: the
        # located root stands as it is (the usual case; results stay bit-identical).
        ends, _ = guard_at(np.array([t_root - 0.5 * BRACKET, t_root + 0.5 * BRACKET]))
        if ends[0] > 0.0 >= ends[1]:
            return tau, z
    g0, _ = guard_at(np.array([t_root]))
    gd = float(guard.rate(z[None, :], u0[None, :])[0, 0])
    t_c = t_root - float(g0[0]) / gd if gd != 0.0 and abs(g0[0] / gd) < 10 * BRACKET else t_root
    times = t_c + _OFFSETS
    g, Z = guard_at(times)
    for i in range(times.size - 1):
        if g[i] > 0.0 >= g[i + 1]:
            frac = g[i] / (g[i] - g[i + 1])
            t_new = times[i] + frac * (times[i + 1] - times[i])
            z_new = Z[i] + frac * (Z[i + 1] - Z[i])
            return _clip(t_new - t_step, z_new, tau, z, h_step, zdot, t_root, t_step)
    if np.all(g <= 0.0) or np.all(g > 0.0):
        # Bisection from a bracket grown around the root (rare: the Hermite root was off
        # by more than 5e-11 s, or the guard is flat to rounding here).
        width = 1e-10
        lo, hi = t_c - width, t_c + width
        for _ in range(40):
            gl, _ = guard_at(np.array([lo, hi]))
            if gl[0] > 0.0 >= gl[1]:
                break
            width *= 2.0
            lo, hi = t_c - width, t_c + width
            if width > MAX_SHIFT:
                # Not within MAX_SHIFT (where the carried state holds): on the exact state
                # over the whole step when it is known, else keep the located root (a
                # guard flat to rounding here).
                if state_at is not None:
                    return locate_exact(cam, guard, offset, t_step, h_step, tau, z, state_at)
                return tau, z
        while hi - lo > BRACKET:
            mid = 0.5 * (lo + hi)
            gm, _ = guard_at(np.array([mid]))
            if gm[0] > 0.0:
                lo = mid
            else:
                hi = mid
        t_new = 0.5 * (lo + hi)
        dt = t_new - t_root
        return _clip(t_new - t_step, z + dt * zdot + 0.5 * dt * dt * zddot, tau, z, h_step, zdot, t_root, t_step)
    return tau, z


def _clip(tau_new, z_new, tau, z, h_step, zdot, t_root, t_step):
    """Keep the polished root inside the step (else the located one)."""
    if 0.0 < tau_new <= h_step:
        return tau_new, z_new
    return tau, z


def locate_exact(cam, guard, offset: float, t_step: float, h_step: float, tau: float, z: np.ndarray, state_at):
    """The first crossing of the guard inside the step on the exact state and the analytic
    cam law, searched from the located root ``tau`` outwards (Brent's method to 1e-14 s).

    Returns (τ, z) of the crossing, the located root unchanged when the guard is already
    ≤ 0 at the step start (nothing better defined), or None when the guard stays > 0 over
    the step (the located root was an artefact of the step's polynomial input).
    """
    from scipy.optimize import brentq  # only on this rare path

    step_end = t_step + h_step

    def g(t_local: float) -> float:
        zt = state_at(t_local) if z.size else z
        u = _analytic_inputs(cam, np.array([t_step + t_local]), step_end)
        return float(guard.value(zt[None, :], u)[0, 0]) - offset

    g_tau = g(tau)
    width = BRACKET
    if g_tau > 0.0:
        lo = tau
        while True:
            hi = min(tau + width, h_step)
            if g(hi) <= 0.0:
                break
            if hi >= h_step:
                return None
            lo = hi
            width *= 4.0
    else:
        hi = tau
        while True:
            lo = max(tau - width, 0.0)
            if g(lo) > 0.0:
                break
            if lo <= 0.0:
                return tau, z
            hi = lo
            width *= 4.0
    root = brentq(g, lo, hi, xtol=1e-14, rtol=4 * np.finfo(float).eps)
    if g(root) > 0.0:  # the event is where the guard is at or below zero: the bracket's far side
        root = min(root + 2e-14, hi)
    if not 0.0 < root <= h_step:
        return tau, z
    return root, (state_at(root) if z.size else z)


def root_near(g, t_lo: float, t_hi: float, t_guess: float) -> float | None:
    """The crossing (g > 0 before, ≤ 0 at it) of a scalar g nearest to ``t_guess`` inside
    [t_lo, t_hi], searched outwards from the guess (brackets of 1e-10 s growing ×4) and
    closed by Brent's method to 1e-14 s; None when g shows no such sign change there."""
    from scipy.optimize import brentq  # only where an event is located

    g_guess = g(t_guess)
    width = BRACKET
    if g_guess > 0.0:
        lo = t_guess
        while True:
            hi = min(t_guess + width, t_hi)
            if g(hi) <= 0.0:
                break
            if hi >= t_hi:
                return None
            lo = hi
            width *= 4.0
    else:
        hi = t_guess
        while True:
            lo = max(t_guess - width, t_lo)
            if g(lo) > 0.0:
                break
            if lo <= t_lo:
                return None
            hi = lo
            width *= 4.0
    root = brentq(g, lo, hi, xtol=1e-14, rtol=4 * np.finfo(float).eps)
    return min(root + 2e-14, hi) if g(root) > 0.0 else root


def grazes(cam, config, guard, t: float, step_end: float, z: np.ndarray) -> bool:
    """True when a located zero of the guard is a touch, not a crossing (issue 34).

    A guard that reaches zero and turns back before it falls below −tol (a follower that
    meets a disc tangentially where the lobe's base circle touches it, a contact force
    that touches zero and rises again) never leaves its branch's validity by more than
    its tolerance: no event, so no pair of rows at one instant that changes nothing. The
    guard is taken to second order at the zero, with the cam input from its analytic law
    (the left limit at ``step_end``): g, ġ, g̈. Only a guard curving up (g̈ > 0) can touch;
    its minimum is then g − ġ²/(2·g̈), whether the root was placed before the vertex or
    after it. A guard curving down at its zero (a rebound too small to resolve, landing
    again) is always a crossing, whatever the sign of ġ where its root was placed.
    """
    if cam is None or not hasattr(cam, "svaj") or guard.rate is None:
        return False
    u = analytic_input(cam, t, step_end)
    g = float(guard.value(z[None, :], u[None, :])[0, 0])
    g_rate = float(guard.rate(z[None, :], u[None, :])[0, 0])
    zdot = config.A @ z + config.B @ u + config.b
    # ü = [ṡ, s̈, s⃛, s⁗] per cam: s⁗ is not an input; the jerk term of ġ (a guard reading s̈) is left out
    curvature = float((guard.rate.Cz @ zdot + times_rate(guard.rate.Du, u))[0])
    return curvature > 0.0 and g - g_rate * g_rate / (2.0 * curvature) >= -guard.tol


def analytic_input(cam, t: float, end: float) -> np.ndarray:
    """The cam input at one instant from the cam laws (the left limit at ``end``): (4·c,)."""
    return _analytic_inputs(cam, np.array([t]), end)[0]

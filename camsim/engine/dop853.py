"""DOP853 for a linear system with one scalar nonlinear contact force (issue 12).

A closed power-law contact obeys

    ż = A·z + g(t) + L·F(ν),     ν = (δ, δ̇) = M·z + m(t),

with A, L, M constant and g, m the cam input's terms. This module takes the same steps as
scipy's :class:`scipy.integrate.DOP853` (Hairer's eighth-order pair, its error norm, dense
output and step-size control, tableau read from scipy's class) but exploits that
structure, which scipy cannot see:

* **The stages as one linear map.** With X_s = A·y + g_s + L·F_s the stages are
  K = Σ_p (h·a)^p·X·(Aᵀ)^p (a, the strictly lower tableau, is nilpotent: p < 12). The
  contact's ν at stage s is therefore N0_s + Σ_{j<s} β_sj·F_j, where N0 (everything but
  the forces) and β (the forces' influence) come from a few batched products with
  precomputed M·A^p and a^(p+1). Only the twelve scalar forces are found one stage
  after the other; the state vectors of all stages are built afterwards in one pass.
  Per step this costs about half of scipy's stage-by-stage loop of Python calls (a
  bounce of the CDTM seat takes ~20 steps, a revolution ~250).
* **Steps at a contact's singular ends.** F ∝ δ^a is not smooth where δ = 0, at a
  bounce's onset and release, so the local error there grows like h^(a+1), not h^8.
  After two rejections from the same point the shrink factor uses the order measured
  from them (scipy's −1/8 exponent shrinks by at most 5× per try, and needed eight tries
  at each onset of the CDTM seat); a span may start from a given first step (the
  caller's memory of the last one).
* **Steps shaped by the contact's singular ends** (when the caller names the law's
  exponent a; without it the control is scipy's, step for step). After an accepted step:

  - *onset ramp*: from an onset the local error of a step h at a distance d from it
    behaves like h⁹·d^(a−8) (the force's eighth derivative there), so the step may grow
    faster than the h⁸ law assumes, by (SAFETY/err)^(1/9)·(1 + h/d)^((8−a)/9), while
    h/d ≥ :data:`RAMP_MIN_RATIO`;
  - *release approach*: an unloading contact's release is predicted from δ, δ̇ and the
    last step's change of δ̇; a step takes at most :data:`RELEASE_APPROACH` of the
    distance left, and once that distance is within a step known to cross a singular end
    (the first step after an onset; before any onset, the step the control proposes) the
    next step lands just past the release. (A step that crosses the release from farther
    away is rejected: its error grows with its length, and scipy's control shrinks it by
    halves, one rejection after another -- or, worse, it is accepted: the error estimate
    compares solutions built from the same stages, and a release a third of the way into
    a step leaves the later stages on the open side, where F = 0; both estimates then
    miss the error of the force's singular end. A contact closed since the run's start
    released so, 47 % into a 6.9 µs step, with its speed 1.4e-8 m/s off at the step's end
    and 3.5e-10 m/s off at the release, where the error norm read 0.09.)

  On one revolution of the CDTM seat these cut the tries from 250 to 221 and the
  rejected ones from 61 to 37 (docs/performance.md).

The results agree with scipy's DOP853 taking the same steps to rounding
(tests/test_dop853.py); only the initial step's choice and the shrink after repeated
rejections differ.
"""

from __future__ import annotations

import math
from operator import mul

import numpy as np
from threadpoolctl import threadpool_limits
from scipy.integrate import DOP853

#: scipy's DOP853 step-size control constants (scipy.integrate._ivp.rk).
SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
ERROR_EXPONENT = -1.0 / 8.0
#: Smallest shrink factor when the order is measured from two rejections.
SMALLEST_FACTOR = 1e-3
#: Onset ramp: the first step after an onset is taken as if h/d were this ratio, and the
#: ramp applies while h/d is at least RAMP_MIN_RATIO (beyond, the error is smooth again).
FIRST_RATIO = 1.0
RAMP_MIN_RATIO = 0.5
#: Largest fraction of the predicted distance to the release per step, and how far past
#: the predicted release the landing step reaches (as a multiple of the distance).
RELEASE_APPROACH = 0.6
LANDING = 1.05

_A = DOP853.A  # (12, 12)
_B = DOP853.B  # (12,)
_C = DOP853.C  # (12,)
_E3 = DOP853.E3  # (13,)
_E5 = DOP853.E5  # (13,)
_D = DOP853.D  # (4, 16)
_A_EXTRA = DOP853.A_EXTRA  # (3, 16)
_C_EXTRA = DOP853.C_EXTRA  # (3,)
_STAGES = _A.shape[0]
assert _C[-1] == 1.0  # the last stage sits at t + h (see _attempt)
_PP = np.arange(_STAGES, dtype=float)
#: a^(p+1) for p = 0..11 (a^12 = 0) laid out [s, j, p], and a^p laid out [t, p, s] (so
#: that the sums over p and j, or p and s, are one matrix product each).
#: (one BLAS thread, as in a run: the rounding of a product may depend on the thread count)
with threadpool_limits(limits=1, user_api="blas"):
    _APOW1 = np.ascontiguousarray(np.array([np.linalg.matrix_power(_A, p + 1) for p in _PP.astype(int)]).transpose(1, 2, 0))
    _APOW0 = np.ascontiguousarray(np.array([np.linalg.matrix_power(_A, p) for p in _PP.astype(int)]).transpose(1, 0, 2))
#: The same as matrices: [s, (j, p)], [(s, j), p] and [t, (p, s)] (the powers of h are
#: applied to the smaller operand of each product).
_APOW1_S_JP = _APOW1.reshape(_STAGES, _STAGES * _STAGES)
_APOW1_SJ_P = _APOW1.reshape(_STAGES * _STAGES, _STAGES)
_APOW0_T_PS = _APOW0.reshape(_STAGES, _STAGES * _STAGES)


class OneContactDOP853:
    """DOP853 from (t0, z0) towards t_bound for ż = A·z + g(t) + L·F(M·z + m(t)).

    Parameters
    ----------
    A : ndarray (n, n)
        The linear part [1/s, 1/s²].
    L : ndarray (n,)
        Where the contact force acts [per N].
    M : ndarray (2, n)
        δ and δ̇ of the contact from the state.
    inputs, input_at : callable
        ``inputs(ts, t_lo, t_hi)`` → ndarray (len(ts), n + 2): g(t) and m(t) at the times
        ``ts`` [s], all in [t_lo, t_hi];
        ``input_at(t)`` the same at one time → (n + 2,).
    force : callable
        ``force(delta, rate)`` → F [N] (plain floats).
    t0, z0, t_bound : float, ndarray (n,), float
        Start, initial state, end [s].
    rtol, atol : float, ndarray (n,)
        Tolerances, as in scipy.
    max_step : float
        Largest step [s].
    first_step : float or None
        First step to try [s] (None: Hairer's starting-step algorithm, as scipy).
    structure : tuple or None
        :meth:`structure` of (A, L, M), when the caller keeps it.
    exponent : float or None
        a of F ∝ δ^a near δ = 0: turns on the steps shaped by the contact (module
        docstring). None: scipy's control.
    onset : bool
        The span starts at a contact's onset (δ = 0, closing): the onset ramp.
    crossing_step : float or None
        A step known to cross a singular end [s] (the caller's memory of the first step
        after an onset); for the release approach (None: this span's first step when it
        starts at an onset, else the step the control proposes: a step never crosses a
        predicted release by more than :data:`LANDING` of the distance to it).
    measured_order : bool
        After two rejections from one point, shrink by the order measured from them
        (False: scipy's shrink, so that without ``exponent`` the steps are scipy's, step
        for step, to the rounding of the stages).

    The interface is the part of :class:`scipy.integrate.OdeSolver` the caller uses:
    :meth:`step`, ``status``, ``t``, ``t_old``, ``y``, :meth:`dense_output`; besides,
    ``first_accepted`` and ``largest`` (the first and the largest accepted step [s]).
    """

    def __init__(self, A, L, M, inputs, input_at, force, t0, z0, t_bound, rtol, atol, max_step, first_step=None,
                 structure=None, exponent=None, onset=False, crossing_step=None, measured_order=True):
        self.A, self.L, self.M = A, L, M
        self.inputs, self.input_at, self.force = inputs, input_at, force
        self.t = float(t0)
        self.t_old = None
        self.y = np.array(z0, dtype=float)
        self.t_bound = float(t_bound)
        self.rtol, self.atol = rtol, np.asarray(atol, dtype=float)
        self.max_step = max_step
        self.status = "running" if self.t_bound > self.t else "finished"
        self.MAp, self.MApT, self.MApL, self.ApT = structure if structure is not None else self.structure(A, L, M)
        self.K = np.empty((16, self.y.size))
        self.f, self.F, self.nu = self._derivative(self.y, self.input_at(self.t))
        self.exponent = exponent
        self.t_onset = self.t if onset else None
        self.crossing_step = crossing_step
        self.measured_order = measured_order
        self.first_accepted = None
        self.largest = 0.0
        self.h_abs = min(first_step, max_step) if first_step else self._initial_step()
        if exponent is not None:
            # a span that starts inside an unloading contact: the release approach applies
            # to its first step too (δ̈ unknown: the release predicted from δ, δ̇)
            self.h_abs = self._release_limit(self.h_abs, self.nu, 0.0)
        self.h_previous = None
        self.y_old = None
        self._dense = None

    @staticmethod
    def structure(A, L, M):
        """M·A^p, its transpose, M·A^p·L and (Aᵀ)^p for p = 0..11: constant per
        configuration, so a caller that starts many spans passes them as ``structure``."""
        n = A.shape[0]
        Ap = [np.eye(n)]
        for _ in range(_STAGES - 1):
            Ap.append(Ap[-1] @ A)
        MAp = np.array([M @ P for P in Ap]).reshape(2 * _STAGES, n)  # [(p, k), n]
        MApL = (MAp @ L).reshape(_STAGES, 2)  # [p, k]
        return MAp, MAp.T.copy(), MApL, np.array([P.T for P in Ap])  # ApT: (12, n, n)

    # ------------------------------------------------------------------ evaluation
    def _derivative(self, z, gm):
        """ż, F and [δ, δ̇] at a state z whose inputs [g; m] are ``gm`` (n + 2,)."""
        n = z.size
        delta, rate = nu = (self.M @ z + gm[n:]).tolist()
        F = self.force(delta, rate)
        return self.A @ z + gm[:n] + self.L * F, F, nu

    def _initial_step(self):
        """Hairer's starting step (Solving ODE I, II.4), as scipy's select_initial_step."""
        y0, f0 = self.y, self.f
        scale = self.atol + np.abs(y0) * self.rtol
        d0 = float(np.sqrt(np.mean((y0 / scale) ** 2)))
        d1 = float(np.sqrt(np.mean((f0 / scale) ** 2)))
        h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
        h0 = min(h0, self.t_bound - self.t)
        f1 = self._derivative(y0 + h0 * f0, self.input_at(self.t + h0))[0]
        d2 = float(np.sqrt(np.mean(((f1 - f0) / scale) ** 2))) / h0
        if d1 <= 1e-15 and d2 <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
        return min(100 * h0, h1, self.max_step)

    def _attempt(self, t, y, h):
        """One DOP853 step of length h: (y_new, f_new, F_new, [δ, δ̇]_new); fills self.K[:13]."""
        n = y.size
        gm = self.inputs(t + _C * h, t, t + h)  # (12, n + 2)
        G, m = gm[:, :n], gm[:, n:]
        hp = h**_PP
        hp1 = hp * h
        Ay = self.A @ y
        # ν_s = M·y + m_s + Σ_p h^(p+1)·[a^(p+1)·(1·(M A^p A y)ᵀ + G·(M A^p)ᵀ + F·(M A^p L)ᵀ)]_s
        Q = (G @ self.MApT + self.MAp @ Ay).reshape(_STAGES, _STAGES, 2) * hp1[:, None]  # [j, p, k]: h^(p+1)·M A^p (A y + g_j)
        N0 = (_APOW1_S_JP @ Q.reshape(_STAGES * _STAGES, 2) + (self.M @ y) + m).T.tolist()  # [k][s]
        beta = (_APOW1_SJ_P @ (self.MApL * hp1[:, None])).reshape(_STAGES, _STAGES, 2).transpose(2, 0, 1).tolist()  # [k][s][j]
        # the stages' forces one after the other, in plain floats (12 scalars; map and sum
        # stop at the forces known so far)
        F = [self.F]
        force = self.force
        for delta, rate, bd, br in zip(N0[0][1:], N0[1][1:], beta[0][1:], beta[1][1:]):
            F.append(force(delta + sum(map(mul, bd, F)), rate + sum(map(mul, br, F))))
        F = np.array(F)
        # all stages at once: K = Σ_p h^p·a^p·X·(Aᵀ)^p, X = 1·(A y)ᵀ + G + F·Lᵀ
        X = G + Ay + np.outer(F, self.L)
        XA = (X @ self.ApT) * hp[:, None, None]  # [p, s, m]: h^p·(X (Aᵀ)^p)_sm
        Kst = _APOW0_T_PS @ XA.reshape(_STAGES * _STAGES, n)
        K = self.K
        K[:_STAGES] = Kst
        y_new = y + h * (_B @ Kst)
        # ż at t + h: the last stage's node is t + h (c = 1), whose inputs are at hand
        f_new, F_new, nu_new = self._derivative(y_new, gm[-1])
        K[_STAGES] = f_new
        return y_new, f_new, F_new, nu_new

    # ------------------------------------------------------------------ stepping
    def step(self):
        """One accepted step (scipy's control; shrink by the measured order after two
        rejections from the same point; with ``exponent``, the steps shaped by the
        contact). Sets ``status``; returns a message or None."""
        t, y = self.t, self.y
        min_step = 10 * abs(np.nextafter(t, np.inf) - t)
        h_abs = min(max(self.h_abs, min_step), self.max_step)
        proposed = h_abs
        rejected = None  # (h, error) of the last rejected try from t
        step_rejected = False
        while True:
            if h_abs < min_step:
                self.status = "failed"
                return "Required step size is less than spacing between numbers."
            t_new = min(t + h_abs, self.t_bound)
            h = t_new - t
            h_abs = abs(h)
            y_new, f_new, F_new, nu_new = self._attempt(t, y, h)
            scale = self.atol + np.maximum(np.abs(y), np.abs(y_new)) * self.rtol
            error = self._error_norm(h, scale)
            if error < 1:
                factor = MAX_FACTOR if error == 0 else min(MAX_FACTOR, SAFETY * error**ERROR_EXPONENT)
                if step_rejected:
                    factor = min(1.0, factor)
                elif self.t_onset is not None and self.exponent is not None:
                    factor = max(factor, self._ramp(t, h_abs, error))
                break
            factor = max(MIN_FACTOR, SAFETY * error**ERROR_EXPONENT)
            if self.measured_order and rejected is not None and rejected[1] > error and rejected[0] > h_abs:
                # the error's order in h, measured from the two tries (a singular end:
                # about a + 1 for F ∝ δ^a)
                order = min(max(math.log(rejected[1] / error) / math.log(rejected[0] / h_abs), 1.0), 9.0)
                factor = max(SMALLEST_FACTOR, min(factor, (SAFETY / error) ** (1.0 / order)))
            rejected = (h_abs, error)
            h_abs *= factor
            step_rejected = True
        if self.first_accepted is None:
            self.first_accepted = h_abs
        self.largest = max(self.largest, h_abs)
        self.h_previous = h
        self.t_old, self.y_old, self.f_old = t, y, self.f
        self.t, self.y, self.f, self.F = t_new, y_new, f_new, F_new
        self.h_abs = h_abs * factor
        if self.exponent is not None:
            self.h_abs = self._release_limit(self.h_abs, nu_new, 0.5 * (nu_new[1] - self.nu[1]) / h)
        self.nu = nu_new
        if not step_rejected and t_new == self.t_bound:
            # a step cut short by t_bound: a caller that moves t_bound on (a span going
            # on, dop853_span) continues with the step the control had proposed
            self.h_abs = max(self.h_abs, proposed)
        self._dense = None
        if self.t >= self.t_bound:
            self.status = "finished"
        return None

    def _ramp(self, t, h, error):
        """The onset ramp's growth factor after an accepted step (t, h) with ``error``
        (1.0 once the step is no longer small against its distance from the onset)."""
        ratio = h / (t - self.t_onset) if t > self.t_onset else FIRST_RATIO
        if ratio < RAMP_MIN_RATIO:
            return 1.0
        grow = (SAFETY / max(error, 1e-300)) ** (1.0 / 9.0) * (1.0 + ratio) ** ((8.0 - self.exponent) / 9.0)
        return min(MAX_FACTOR, grow)

    def _release_limit(self, h, nu, half_accel):
        """h limited by the release approach at a point with [δ, δ̇] = ``nu`` and
        ½·δ̈ ≈ ``half_accel``: a step that would cross the predicted release lands just past
        it when the distance is within a step known to cross a singular end (without one --
        no onset yet, a contact closed since the run's start -- the proposed step h itself:
        before, such a span crossed its release with whatever step the control proposed,
        which DOP853's error estimate cannot judge; see the module docstring)."""
        delta, rate = nu
        crossing = self.crossing_step or (self.first_accepted if self.t_onset is not None else None) or h
        if delta > 0.0 and rate < 0.0:
            to_release = _first_root(delta, rate, half_accel)
            if h > RELEASE_APPROACH * to_release:
                h = LANDING * to_release if to_release <= crossing else max(RELEASE_APPROACH * to_release, crossing)
        return h

    def _error_norm(self, h, scale):
        """scipy's DOP853 error norm (the 5th- and 3rd-order estimates combined)."""
        K = self.K[: _STAGES + 1]
        err5 = (_E5 @ K) / scale
        err3 = (_E3 @ K) / scale
        e5 = float(err5 @ err5)
        e3 = float(err3 @ err3)
        if e5 == 0.0 and e3 == 0.0:
            return 0.0
        return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * scale.size)

    def dense_output(self):
        """The last step's interpolant (scipy's DOP853 dense output): callable on a time
        (→ (n,)) or an array of times (→ (n, k))."""
        if self._dense is None:
            K, h = self.K, self.h_previous
            gm = self.inputs(self.t_old + _C_EXTRA * h, self.t_old, self.t_old + h)  # the extra stages' inputs at once
            for i, (s, a) in enumerate(zip(range(_STAGES + 1, _STAGES + 4), _A_EXTRA)):
                K[s] = self._derivative(self.y_old + h * (a[:s] @ K[:s]), gm[i])[0]
            dy = self.y - self.y_old
            Fc = np.empty((7, dy.size))
            Fc[0] = dy
            Fc[1] = h * self.f_old - dy
            Fc[2] = 2 * dy - h * (self.f + self.f_old)
            Fc[3:] = h * (_D @ K)
            self._dense = _Dense(self.t_old, h, self.y_old, Fc)
        return self._dense


def _first_root(c0, c1, c2):
    """The smallest positive root of c0 + c1·τ + c2·τ² (c0 > 0 > c1), inf if none."""
    if c2 == 0.0:
        return -c0 / c1
    disc = c1 * c1 - 4.0 * c2 * c0
    if disc < 0.0:
        return math.inf
    q = -0.5 * (c1 - math.sqrt(disc))  # c1 < 0: the sum without cancellation (q > 0)
    roots = [r for r in (q / c2, c0 / q) if r > 0.0]
    return min(roots) if roots else math.inf


class _Dense:
    """DOP853's degree-7 interpolant on [t_old, t_old + h]."""

    def __init__(self, t_old, h, y_old, F):
        self.t_old, self.h, self.y_old, self.F = t_old, h, y_old, F

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        x = (t - self.t_old) / self.h
        if t.ndim == 0:
            y = np.zeros_like(self.y_old)
        else:
            x = x[:, None]
            y = np.zeros((x.shape[0], self.y_old.size))
        for i, f in enumerate(self.F[::-1]):
            y = y + f
            y = y * x if i % 2 == 0 else y * (1 - x)
        y = y + self.y_old
        return y if t.ndim == 0 else y.T

    def project(self, g):
        """g·z(t) as a function of a float t, in plain floats (the same recurrence as
        :meth:`__call__` on the projected coefficients)."""
        coeffs = (self.F[::-1] @ g).tolist()
        base = float(self.y_old @ g)
        t_old, h = self.t_old, self.h

        def at(t):
            x = (t - t_old) / h
            y = 0.0
            for i, f in enumerate(coeffs):
                y = (y + f) * (x if i % 2 == 0 else 1.0 - x)
            return y + base

        return at

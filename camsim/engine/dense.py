"""The exact solution between a stretch's nodes, and the maximum of an observable on one step.

A stretch's record (:mod:`camsim.engine.extremes`) holds the solution at its nodes; the
refinement of an extreme needs it between them:

- a linear configuration's state anywhere in a step is the Taylor series of its exact
  solution (:func:`camsim.engine.taylor.taylor_states`); a closed nonlinear contact's is
  DOP853's at rtol :data:`DENSE_RTOL` from the step's start node (:class:`DenseStretch`);
- an observable is evaluated at :data:`CHEBYSHEV_POINTS` Chebyshev–Lobatto points of a step,
  with the cam input from its law, and the interpolant's maximum located by Newton's method
  on its derivative (:func:`maximise`): error far below 1e-12 of the observable's range for
  steps of at most 1/12 period;
- :func:`batch_values` evaluates the steps of many records at once: one Taylor series per
  configuration, one evaluation of the cam law, one of the observables (issue 42: per
  record and observable these calls were most of a revolution's cost).
"""

from __future__ import annotations

import numpy as np

from camsim.errors import SimulationError
from camsim.engine.stepping import _FACT, _P, step_input_derivatives, taylor_rows
from camsim.engine.taylor import taylor_states

#: Chebyshev–Lobatto points per refined step (the interpolant's degree + 1).
CHEBYSHEV_POINTS = 13
#: Newton steps on an interpolant's derivative from its best point of a 65-point grid.
NEWTON_STEPS = 3
#: DOP853 tolerance of a nonlinear step integrated again for its dense states.
DENSE_RTOL = 1e-13
#: A step of one closed contact is integrated by camsim.engine.dop853.OneContactDOP853 (scipy's
#: steps, its stages as one linear map); False: scipy's solve_ivp, as for several contacts.
ONE_CONTACT = True

_X = np.cos(np.pi * np.arange(CHEBYSHEV_POINTS)[::-1] / (CHEBYSHEV_POINTS - 1))  # −1 … 1
_SIGMA = 0.5 * (_X + 1.0)  # 0 … 1 along a step


def _lobatto_to_chebyshev(points: int) -> np.ndarray:
    """The matrix from values at the Chebyshev–Lobatto points (ascending) to the Chebyshev
    coefficients of their interpolant, in closed form (the discrete cosine transform): an
    inverse computed by LAPACK at import would round differently with the number of BLAS
    threads, and so would every located extreme (a Dask worker's against the caller's)."""
    n = points - 1
    j = np.arange(points)
    M = (2.0 / n) * np.cos(np.pi * np.outer(j, j) / n)  # k × (index j of x_j = cos(πj/n))
    M[:, [0, n]] *= 0.5
    M[[0, n], :] *= 0.5
    return M[:, ::-1]  # the points ascending, as _X


_TO_COEF = _lobatto_to_chebyshev(CHEBYSHEV_POINTS)
_FINE = np.linspace(-1.0, 1.0, 65)
_FINE_V = np.polynomial.chebyshev.chebvander(_FINE, CHEBYSHEV_POINTS - 1)
#: The first and second derivatives of a Chebyshev series as matrices on its coefficients.
_DER1 = np.array([np.polynomial.chebyshev.chebder(e) for e in np.eye(CHEBYSHEV_POINTS)]).T
_DER2 = np.array([np.polynomial.chebyshev.chebder(e, 2) for e in np.eye(CHEBYSHEV_POINTS)]).T


# ---------------------------------------------------------------------- dense states of a stretch
class DenseStretch:
    """The exact states inside a stretch's steps, on demand.

    A linear configuration's state anywhere in a step is its Taylor series
    (:func:`taylor_states`); a closed nonlinear contact's is DOP853's at rtol
    :data:`DENSE_RTOL` from the step's start node, integrated once per step and kept (its
    dense output then serves every later point). The cam input in a step is the step's
    degree-7 polynomial, as the steppers integrate it.
    """

    def __init__(self, ctx, config, branches, v_impacts, exact: bool, nodes, Z, U, observe):
        self.ctx, self.config, self.branches, self.v_impacts = ctx, config, branches, v_impacts
        self.exact, self.nodes, self.Z, self.U, self.observe = exact, nodes, Z, U, observe
        self.h = np.diff(nodes)
        self._solutions: dict[int, object] = {}

    def step_derivatives(self, steps: np.ndarray) -> np.ndarray:
        """The Hermite derivatives of the cam input of ``steps`` (S, 8·c): only the steps a
        refinement reads (a stretch has tens of thousands)."""
        steps = np.asarray(steps, dtype=int)
        return step_input_derivatives(self.U[steps], self.U[steps + 1], self.h[steps], self.ctx.h)

    def states(self, steps: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(S, P, m) states and (S, P, 4·c) inputs at fractions ``sigma`` ((P,) or (S, P)) of ``steps``."""
        steps = np.asarray(steps, dtype=int)
        S = steps.size
        sigma = np.broadcast_to(np.asarray(sigma, dtype=float), (S, np.shape(sigma)[-1]))
        h = self.h[steps]
        # the cam input from its law: inside a short step, the step's degree-7 polynomial
        # carries the rounding of s amplified into s̈ (7.5e-7 m/s², 6e-8 of the CDTM cam's
        # peak acceleration, in a 20 µs step), and a driven mass's acceleration *is* s̈
        times = self.nodes[steps][:, None] + h[:, None] * sigma
        ends = np.broadcast_to(self.nodes[steps + 1][:, None], times.shape)
        # one evaluation of the law for every point (the limit from the left at a step's end)
        Us = self.ctx.analytic_inputs_at(times.reshape(-1), ends.reshape(-1)).reshape(times.shape + (self.ctx.n_input,))
        if self.exact:
            return taylor_states(self.config, self.Z[steps], self.step_derivatives(steps), h, sigma), Us
        P, m = sigma.shape[1], self.Z.shape[1]
        Zs = np.empty((S, P, m))
        # the rows of one step (several requests zooming into it) from one call of its dense
        # output: its interpolant is evaluated time by time, so the values are those of a call
        # per row (scipy's per-call cost was most of a zoom)
        rows_of: dict[int, list[int]] = {}
        for r, k in enumerate(steps.tolist()):
            rows_of.setdefault(k, []).append(r)
        for k, rows in rows_of.items():
            if not self.h[k] > 0.0:
                Zs[rows] = self.Z[k]
                continue
            times = self.nodes[k] + h[rows][:, None] * sigma[rows]
            Zs[rows] = self._solution(k)(times.reshape(-1)).T.reshape(len(rows), P, m)
        return Zs, Us

    def values(self, steps, sigma) -> np.ndarray:
        """The observables at fractions ``sigma`` of ``steps``: (S, P, n_obs)."""
        Zs, Us = self.states(steps, sigma)
        S, P, m = Zs.shape
        return self.observe(self.config, self.branches, self.v_impacts, Zs.reshape(S * P, m),
                            Us.reshape(S * P, -1)).reshape(S, P, -1)

    def _solution(self, k: int):
        sol = self._solutions.get(k)
        if sol is None:
            sol = self._solutions[k] = integrate_step(self.ctx, self.config, self.v_impacts, float(self.nodes[k]),
                                                      float(self.h[k]), self.Z[k], self.step_derivatives([k])[0])
        return sol


def integrate_step(ctx, config, v_impacts, t_a: float, h: float, z0: np.ndarray, Dk: np.ndarray):
    """DOP853 (rtol :data:`DENSE_RTOL`) over one step of a closed nonlinear contact from its
    start node, the cam input the step's polynomial; returns the dense solution."""
    from scipy.integrate import solve_ivp

    A, B, b, L = config.A, config.B, config.b, config.L
    contacts = []
    for k, i in enumerate(config.power_contacts):
        delta, rate = ctx._delta(config, i)
        contacts.append((L[:, k], delta.Cz[0], delta.Du[0], float(delta.e[0]), rate.Cz[0], rate.Du[0], float(rate.e[0]),
                         ctx.model.acting(i, config.branches).nonlinear_force_scalar, v_impacts.get(i)))
    # u_c(τ) = Σ_j D[j + c]·τ^j/j! (per cam): the coefficient matrix of τ^j per channel
    C = taylor_rows(Dk) / _FACT[: _P + 1]
    powers = np.arange(_P + 1)
    atol = ctx.nonlinear_atol(z0.size) * 1e-3
    if ONE_CONTACT and len(contacts) == 1 and z0.size:  # (no coordinate: every mass held by rigid contacts)
        return _one_contact(A, B, b, C, contacts[0], t_a, h, z0, atol)

    def rhs(t, z):
        u = C @ ((t - t_a) ** powers)
        out = A @ z + B @ u + b
        for Lk, dz, du, de, rz, ru, re, force, v in contacts:
            out = out + Lk * force(float(dz @ z + du @ u + de), float(rz @ z + ru @ u + re), v)
        return out

    sol = solve_ivp(rhs, (t_a, t_a + h), np.asarray(z0, dtype=float), method="DOP853", rtol=DENSE_RTOL,
                    atol=atol, dense_output=True)
    if not sol.success:
        raise SimulationError(f"dense states of a closed contact's step at t = {t_a:.9g} s: {sol.message}")
    return sol.sol


def _one_contact(A, B, b, C, contact, t_a: float, h: float, z0: np.ndarray, atol: np.ndarray):
    """:func:`integrate_step` for one closed contact: DOP853 with scipy's control and
    tableau, step for step (:class:`camsim.engine.dop853.OneContactDOP853` without the
    contact-shaped steps: the same steps as scipy's solver, to rounding; tests/test_dop853.py),
    its stages built as one linear map around the contact's force instead of twelve calls of
    a right-hand side: about half the time a step, which a power-law seat's located extremes
    spend most of theirs in."""
    from scipy.integrate import OdeSolution

    from camsim.engine.dop853 import OneContactDOP853

    Lk, dz, du, de, rz, ru, re, force, v = contact
    # [B·u + b; δ's and δ̇'s input terms] as polynomials in τ: one product per evaluation
    BMC = np.vstack([B, du[None, :], ru[None, :]]) @ C
    BMC[:, 0] += np.concatenate([b, [de, re]])
    powers = np.arange(_P + 1, dtype=float)

    def inputs(ts, t_lo, t_hi):
        return ((np.asarray(ts) - t_a)[:, None] ** powers) @ BMC.T

    def input_at(t):
        return BMC @ ((t - t_a) ** powers)

    solver = OneContactDOP853(A, Lk, np.vstack([dz, rz]), inputs, input_at, lambda d, r: force(d, r, v), t_a,
                              np.asarray(z0, dtype=float), t_a + h, DENSE_RTOL, atol, np.inf, measured_order=False)
    ts, pieces = [t_a], []
    while solver.status == "running":
        message = solver.step()
        if solver.status == "failed":
            raise SimulationError(f"dense states of a closed contact's step at t = {t_a:.9g} s: {message}")
        ts.append(solver.t)
        pieces.append(solver.dense_output())
    if not pieces:
        raise SimulationError(f"dense states of a closed contact's step at t = {t_a:.9g} s: an empty step")
    return OdeSolution(ts, pieces)


def row_products(A: np.ndarray, M: np.ndarray, lone: bool = False) -> np.ndarray:
    """``A @ M.T``; with ``lone``, each row's products as numpy makes them for a row alone
    (BLAS's matrix-vector kernel, which rounds differently from the matrix-matrix one that
    two rows or more take): a step refined alone gives the same bits in a batch."""
    if lone:
        return (A[:, None, :] @ M.T)[:, 0, :]
    return A @ M.T


def maximise(values: np.ndarray, lone: bool = False) -> np.ndarray:
    """Where on [−1, 1] each row's Chebyshev interpolant (values at the Chebyshev–Lobatto
    points) is largest: its best point on a fine grid, polished by Newton on its derivative
    (``lone``: every row's products as for a row alone, :func:`row_products`)."""
    coef = row_products(values, _TO_COEF, lone)
    fine = row_products(coef, _FINE_V, lone)
    k = np.argmax(fine, axis=1)
    x = _FINE[k]
    lo = _FINE[np.maximum(k - 1, 0)]
    hi = _FINE[np.minimum(k + 1, _FINE.size - 1)]
    d1, d2 = row_products(coef, _DER1, lone), row_products(coef, _DER2, lone)
    # from a point within 1/64 of the maximum, three Newton steps on the derivative reach it
    # to rounding (quadratic convergence: 1e-2, 1e-4, 1e-8, 1e-16 in x; the value's error is
    # the square of x's)
    for _ in range(NEWTON_STEPS):
        g = chebval_rows(x, d1)
        gg = chebval_rows(x, d2)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(gg < 0.0, g / gg, 0.0)
        x = np.clip(x - step, lo, hi)
    better = chebval_rows(x, coef) >= fine[np.arange(fine.shape[0]), k]
    return np.where(better, x, _FINE[k])


def chebval_rows(x: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """Chebyshev series coef[i] at x[i] ∈ [−1, 1] for each row i: T_k(x) = cos(k·arccos x)."""
    T = np.cos(np.arccos(np.clip(x, -1.0, 1.0))[:, None] * np.arange(coef.shape[1]))
    return np.einsum("rk,rk->r", coef, T)




def _ends_piece(dense: "DenseStretch", steps: np.ndarray) -> np.ndarray:
    """Whether each step ends a smooth piece of the record (its last, or the one before a
    break's step of length zero)."""
    after = np.minimum(steps + 1, dense.h.size - 1)
    return (steps + 1 >= dense.h.size) | (dense.h[after] <= 0.0)


def batch_values(items) -> list[np.ndarray]:
    """The observables at the Chebyshev points of given steps of many records at once.

    Parameters
    ----------
    items : list of (DenseStretch, ndarray of int)
        Records' dense states and the steps wanted of each.

    Returns
    -------
    list of ndarray (S_i, CHEBYSHEV_POINTS, n_obs)
        In the order of ``items``. The steps of linear records that share a configuration
        (branches, impact speeds, observables) are evaluated together: one Taylor series,
        one evaluation of the cam law (the limit from the left at the end of each smooth
        piece, which may be a break; inside a piece the law is smooth), one of the
        observables.
    """
    out: list = [None] * len(items)
    groups: dict = {}
    for idx, (dense, steps) in enumerate(items):
        if dense.exact and steps.size:
            key = (id(dense.config), dense.branches, tuple(sorted(dense.v_impacts.items())), id(dense.observe))
            groups.setdefault(key, []).append(idx)
        else:
            out[idx] = dense.values(steps, _SIGMA)
    for idxs in groups.values():
        first = items[idxs[0]][0]
        ctx, config = first.ctx, first.config
        z0 = np.concatenate([items[i][0].Z[items[i][1]] for i in idxs])
        D = np.concatenate([items[i][0].step_derivatives(items[i][1]) for i in idxs])
        h = np.concatenate([items[i][0].h[items[i][1]] for i in idxs])
        t0 = np.concatenate([items[i][0].nodes[items[i][1]] for i in idxs])
        # a step that ends a smooth piece (the record's last, or one before a break's step of
        # length zero) ends on a node that may be a break: its last point takes the limit from the left
        last = np.concatenate([_ends_piece(items[i][0], items[i][1]) for i in idxs])
        Zs = taylor_states(config, z0, D, h, _SIGMA)
        S, P, m = Zs.shape
        times = t0[:, None] + h[:, None] * _SIGMA[None, :]
        U = ctx.cam.channels(times.reshape(-1)).reshape(S, P, -1)
        if np.any(last):
            U[last, -1] = ctx.cam.channels(times[last, -1], side="left")
        vals = first.observe(config, first.branches, first.v_impacts, Zs.reshape(S * P, m),
                             U.reshape(S * P, -1)).reshape(S, P, -1)
        k = 0
        for i in idxs:
            n = items[i][1].size
            out[i] = vals[k : k + n]
            k += n
    return out

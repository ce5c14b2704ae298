"""The solvers: differential evolution, a local refinement, and the Pareto front of two objectives.

All of them work on solver coordinates: each continuous variable mapped to [0, 1] between
its bounds (logarithmically with ``--log``), each choice to an integer 0 … n − 1, so that
every variable has the same scale. Constraints are the evaluator's scaled values g ≤ 0.

* ``de``: :func:`scipy.optimize.differential_evolution`, seeded, ``updating="deferred"``
  and ``vectorized=True`` so that a whole population is one batch for the executor (and
  the result does not depend on the order in which the runs finish); constraints as a
  :class:`~scipy.optimize.NonlinearConstraint` (Lampinen's feasibility rules), choices
  through ``integrality``; no polish (its trust-constr step would cost more runs than the
  budget allows). The population is 10 per variable (at least 10); the number of
  generations follows from ``--budget``.
* ``local``: from the file's values (or START), a gradient-free method: bounded Brent
  (:func:`scipy.optimize.minimize_scalar`) for one unconstrained variable, otherwise
  COBYLA (:func:`scipy.optimize.minimize`, ``method="COBYLA"``, Powell's linear
  approximations of the objective and constraints built from the runs themselves: no
  finite differences, whose steps would be lost in the noise of event times). COBYQA was
  tried and dropped: on a one-variable problem with one linear constraint (the closure
  preload of the tests) it stopped at an infeasible point; COBYLA lands on the bound in 8
  evaluations. Trust region from :data:`RHOBEG` down to :data:`RHOEND` in coordinates.
* ``pareto``: an ε-constraint sweep (Haimes et al. 1971): the two anchors (each objective
  alone, then the other objective at that best value: lexicographic), then ``points`` − 2
  levels ε between them, alternately on each objective (minimise the other one subject to
  it ≤ ε), each from the previous solution of its kind with the local method; the
  non-dominated ones of these solutions are the front (not every candidate the local
  searches visited: on their way they pass points that nothing evaluated happens to
  dominate, yet lie off the front). Why this and not
  NSGA-II: ``docs/optimize.md`` ("Pareto fronts") and ``bench/bench_pareto.py``.
"""

from __future__ import annotations

import math

import numpy as np

from camsim.analyses.optimize.evaluate import BudgetExhausted, Evaluator

__all__ = ["solve_de", "solve_local", "solve_pareto", "pareto_front", "POPSIZE"]

#: Population per variable of the differential evolution (scipy's ``popsize``).
POPSIZE = 10
#: Smallest population.
MIN_POPULATION = 10
#: Initial and final trust-region radius of COBYLA, in coordinates scaled to the bounds.
RHOBEG = 0.25
RHOEND = 1e-9


def _senses(ev: Evaluator) -> list[str]:
    return [g.sense for g in ev.problem.goals]


def _bounds(ev: Evaluator):
    lo = [0.0] * len(ev.problem.variables)
    hi = [v.high if v.is_choice else 1.0 for v in ev.problem.variables]
    return lo, hi


def _start(ev: Evaluator) -> np.ndarray:
    return np.array([v.to_unit(v.start) for v in ev.problem.variables], dtype=float)


def solve_de(ev: Evaluator, seed: int, budget: int, goal: int = 0, notes: list[str] | None = None) -> None:
    """Differential evolution over the variables (see the module docstring)."""
    from scipy.optimize import NonlinearConstraint, differential_evolution

    n = len(ev.problem.variables)
    pop = max(MIN_POPULATION, POPSIZE * n)
    popsize = max(1, math.ceil(pop / n))
    pop = popsize * n
    maxiter = max(1, budget // pop - 1)
    lo, hi = _bounds(ev)
    senses = _senses(ev)
    integrality = [v.is_choice for v in ev.problem.variables]

    def objective(xt):
        xs = np.atleast_2d(np.asarray(xt).T)
        cands = ev.evaluate([tuple(x) for x in xs])
        return np.array([c.f(senses)[goal] for c in cands])

    def constraint(xt):
        xs = np.atleast_2d(np.asarray(xt).T)
        cands = ev.evaluate([tuple(x) for x in xs])
        return np.array([c.g for c in cands]).T

    constraints = ()
    if ev.n_constraints():
        constraints = (NonlinearConstraint(constraint, -np.inf, 0.0),)
    x0 = _start(ev)
    try:
        differential_evolution(
            objective,
            list(zip(lo, hi)),
            constraints=constraints,
            rng=np.random.default_rng(seed),
            popsize=popsize,
            maxiter=maxiter,
            tol=0.0,
            atol=0.0,
            polish=False,
            init="latinhypercube",
            updating="deferred",
            vectorized=True,
            integrality=integrality if any(integrality) else None,
            x0=x0 if np.all((x0 >= np.array(lo)) & (x0 <= np.array(hi))) else None,
        )
    except BudgetExhausted:
        if notes is not None:
            notes.append(f"stopped at the budget of {budget} evaluations")


def solve_local(ev: Evaluator, budget: int, x0=None, goal: int = 0, extra=None, notes: list[str] | None = None):
    """Local refinement from ``x0`` (default: the file's values) within ``budget`` evaluations.

    Returns the coordinates of the best point it visited that satisfies every constraint
    (and ``extra(candidate) ≥ 0``), or None when it visited none.

    Raises
    ------
    BudgetExhausted
        The evaluator's overall budget is used up.
    """
    from scipy.optimize import NonlinearConstraint, minimize, minimize_scalar

    senses = _senses(ev)
    x0 = _start(ev) if x0 is None else np.asarray(x0, dtype=float)
    x0 = np.clip(x0, 0.0, 1.0)
    n = len(x0)
    limit = len(ev.candidates) + budget
    visited: list = []

    def candidate(x):
        if len(ev.candidates) >= limit and ev._key(ev.values_of(x)) not in ev.by_key:
            raise _StepBudget()
        c = ev.evaluate([tuple(np.atleast_1d(x))])[0]
        visited.append(c)
        return c

    def f(x):
        v = candidate(x).f(senses)[goal]
        return v if math.isfinite(v) else 1e30  # a failed run or an infeasible absorb: a value the model can use

    def g(x):
        c = candidate(x)
        out = -np.asarray(c.g, dtype=float)  # COBYLA: g(x) >= 0; ours: g <= 0
        if extra is not None:
            out = np.concatenate([out, [extra(c)]])
        return out

    has_constraints = ev.n_constraints() > 0 or extra is not None
    try:
        if n == 1 and not has_constraints:
            minimize_scalar(lambda u: f([u]), bounds=(0.0, 1.0), method="bounded",
                            options={"xatol": 1e-9, "maxiter": max(1, budget)})
        else:
            # COBYLA's first steps are +rhobeg along each axis, and it treats bounds as
            # constraints it may step across (the evaluator clips): from a point at an upper
            # bound every first step would land on the same clipped point. So it works on
            # d = s (x − x0), s = −1 for coordinates above the middle: its first steps go inward.
            s = np.where(x0 > 0.5, -1.0, 1.0)

            def x_of(d):
                return np.clip(x0 + s * np.asarray(d, dtype=float), 0.0, 1.0)

            bounds = list(zip(np.where(s > 0, -x0, x0 - 1.0), np.where(s > 0, 1.0 - x0, x0)))
            cons = [NonlinearConstraint(lambda d: g(x_of(d)), 0.0, np.inf)] if has_constraints else []
            minimize(lambda d: f(x_of(d)), np.zeros(n), method="COBYLA", bounds=bounds, constraints=cons,
                     options={"maxiter": max(n + 2, budget), "rhobeg": RHOBEG, "tol": RHOEND})
    except _StepBudget:
        pass
    except BudgetExhausted:
        if notes is not None:
            notes.append(f"stopped at the budget of {ev.budget} evaluations")
        raise
    ok = [c for c in visited if c.feasible and (extra is None or extra(c) >= 0)]
    if not ok:
        return None
    return np.array(min(ok, key=lambda c: (c.f(senses)[goal], c.index)).x, dtype=float)


class _StepBudget(Exception):
    """The budget of one local step (not the whole job) is used up."""


def pareto_front(cands, senses) -> list:
    """The non-dominated feasible candidates, by the first objective."""
    feas = [c for c in cands if c.feasible]
    pts = [(c, c.f(senses)) for c in feas]
    front = []
    for c, f in pts:
        dominated = any(all(a <= b for a, b in zip(h, f)) and any(a < b for a, b in zip(h, f)) for _, h in pts)
        if not dominated and not any(o.values == c.values for o in front):
            front.append(c)
    return sorted(front, key=lambda c: c.f(senses)[0])


def solve_pareto(ev: Evaluator, budget: int, points: int, notes: list[str] | None = None) -> list:
    """ε-constraint sweep (module docstring); returns the front."""
    senses = _senses(ev)
    if len(senses) != 2:
        from camsim.errors import InputError

        raise InputError("--method pareto: needs two objectives (--minimize A --minimize B, or --maximize)")
    n = len(ev.problem.variables)
    solutions: list = []
    steps = points + 2  # two anchors, two lexicographic refinements, points - 2 levels
    end = len(ev.candidates) + budget

    def share(left: int) -> int:
        return max(n + 3, (end - len(ev.candidates)) // max(left, 1))

    try:
        solve_local(ev, share(steps), goal=0, notes=notes)
        ca = ev.best(0)
        solve_local(ev, share(steps - 1), goal=1, notes=notes)
        cb = ev.best(1)
        if ca is None or cb is None:
            return pareto_front(ev.candidates, senses)
        # Lexicographic anchors: the best of one objective may be reached by many points;
        # of those, the one best in the other objective is on the front.
        span0 = abs(ca.f(senses)[0] - cb.f(senses)[0]) or 1.0
        span1 = abs(ca.f(senses)[1] - cb.f(senses)[1]) or 1.0
        limit_a, limit_b = ca.f(senses)[0], cb.f(senses)[1]
        solve_local(ev, share(steps - 2), x0=np.array(ca.x), goal=1, notes=notes,
                    extra=lambda c: (limit_a - c.f(senses)[0]) / span0 if math.isfinite(c.f(senses)[0]) else -1e6)
        solve_local(ev, share(steps - 3), x0=np.array(cb.x), goal=0, notes=notes,
                    extra=lambda c: (limit_b - c.f(senses)[1]) / span1 if math.isfinite(c.f(senses)[1]) else -1e6)
        # the refined anchors: the best of the other objective at each anchor's best value
        at_a = [c for c in ev.candidates if c.feasible and c.f(senses)[0] <= limit_a]
        at_b = [c for c in ev.candidates if c.feasible and c.f(senses)[1] <= limit_b]
        ca = min(at_a, key=lambda c: (c.f(senses)[1], c.index))
        cb = min(at_b, key=lambda c: (c.f(senses)[0], c.index))
        solutions += [ca, cb]
        # ε levels alternate between the two objectives (constrain one, minimise the other),
        # each set evenly spaced between the anchors: levels on one objective alone crowd
        # where the front is steep in it (a ∝ ω²: equal steps in a leave the low speeds bare).
        ends = [(cb.f(senses)[0], ca.f(senses)[0]), (ca.f(senses)[1], cb.f(senses)[1])]
        spans = [span0, span1]
        m = points - 2
        counts = [(m + 1) // 2, m // 2]
        plan = []
        for j in (0, 1):
            hi_end, lo_end = ends[j]
            plan += [(j, hi_end + (lo_end - hi_end) * i / (counts[j] + 1), i / (counts[j] + 1))
                     for i in range(1, counts[j] + 1)]
        plan.sort(key=lambda item: (item[2], item[0]))
        starts = {0: np.array(cb.x, dtype=float), 1: np.array(ca.x, dtype=float)}
        for left, (j, eps, _) in zip(range(len(plan), 0, -1), plan):

            def extra(c, j=j, eps=eps):
                v = c.f(senses)[j]
                return (eps - v) / spans[j] if math.isfinite(v) else -1e6

            x_new = solve_local(ev, share(left), x0=starts[j], goal=1 - j, extra=extra, notes=notes)
            if x_new is not None:
                starts[j] = x_new
                solutions.append(ev.evaluate([tuple(x_new)])[0])
    except BudgetExhausted:
        pass
    return pareto_front(solutions or ev.candidates, senses)


"""Pareto fronts: camsim's ε-constraint sweep against pymoo's NSGA-II, by measurement (issue 28).

Run from the repository root (pymoo is optional: ``pip install pymoo``)::

    python bench/bench_pareto.py                # budget 120 candidate evaluations each
    python bench/bench_pareto.py --budget 240

The problem has a known front. A rigidly driven follower on a cycloidal rise peaks at
a_max = 2π h ω² / β²; the variables are the cam speed ω (60–600 rpm) and the rise's
duration β (60–120°, the dwell after it absorbing the difference), a_max read over the
rise alone (0–180°; the fall keeps 90°). Throughput (ω) is maximised and a_max minimised: for every ω the best β is the longest, so the front is
a = 2π h ω² / β_max² over the whole speed range, and every candidate with β < β_max is
dominated. Both solvers get the same number of candidate evaluations (each one a camsim
run) through the same evaluator; the script prints, per solver, the wall time, the
evaluations used, the number of front points, the largest relative distance of a front
point from the true front, the median distance, and the fraction of the speed range the
front covers (largest gap between neighbouring front speeds, relative to the range).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

H = 0.010
BETA_MAX = math.radians(120.0)
LO, HI = 60 * math.pi / 30, 600 * math.pi / 30
MACHINE = """\
schema = 1
[machine]
name = "rigidly driven follower, cycloidal rise"
[cam]
speed = "120 rpm"
drives = "F"
segments = [
  { motion = "rise",  law = "cycloidal", duration = "90 deg", lift = "10 mm" },
  { motion = "dwell", duration = "90 deg" },
  { motion = "fall",  law = "cycloidal", duration = "90 deg", lift = "10 mm" },
  { motion = "dwell", duration = "90 deg" },
]
[[mass]]
name = "F"
mass = "0.5 kg"
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "20 kHz"
"""
#: The rise's peak acceleration: the window ends where the fall begins (rise + absorbing dwell = 180 deg).
ACCEL = "maxabs:masses/F/acceleration@0:180deg"
VARS = ["cam.speed=60:600rpm", "cam.segments[0].duration=60:120deg"]
ABSORB = "cam.segments[1].duration"


def metrics(front) -> dict:
    """Distance of the front from the true one and its coverage of the speed range."""
    w = np.array([c.values["cam.speed"] for c in front])
    a = np.array([c.objectives[0] for c in front])  # maxabs acceleration (the minimised goal comes first)
    dev = np.abs(a / (2 * math.pi * H * w**2 / BETA_MAX**2) - 1)
    ws = np.sort(np.concatenate([[LO, HI], w]))
    return {"points": len(front), "max_dev": float(dev.max()), "median_dev": float(np.median(dev)),
            "largest_gap": float(np.diff(ws).max() / (HI - LO))}


def eps_constraint(path: Path, budget: int):
    import camsim

    t0 = time.perf_counter()
    res = camsim.optimize(path, VARS, absorb=ABSORB, maximize="param:cam.speed", minimize=ACCEL,
                          method="pareto", budget=budget, points=11, workers=1)
    return time.perf_counter() - t0, len(res.candidates), res.front


def nsga2(path: Path, budget: int, pop: int = 20, seed: int = 0):
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.problem import Problem as PymooProblem
    from pymoo.optimize import minimize

    from camsim.analyses.optimize.evaluate import Evaluator, RunSpec
    from camsim.analyses.optimize.problem import build_problem, expression_units
    from camsim.analyses.optimize.solvers import pareto_front
    from camsim.analyses.sweep.runner import MachineSource
    from camsim.run.simulation import simulate

    source = MachineSource.from_path(path)
    problem = build_problem(source, [], VARS, [], [], ABSORB, [ACCEL], ["param:cam.speed"], [], None)
    expression_units(problem, simulate(source.load()))
    ev = Evaluator(source, [], problem, RunSpec())
    senses = [g.sense for g in problem.goals]

    class P(PymooProblem):
        def __init__(self):
            super().__init__(n_var=2, n_obj=2, xl=0.0, xu=1.0)

        def _evaluate(self, x, out, *args, **kwargs):
            cands = ev.evaluate([tuple(row) for row in x])
            out["F"] = np.array([c.f(senses) for c in cands])

    t0 = time.perf_counter()
    minimize(P(), NSGA2(pop_size=pop), ("n_evals", budget), seed=seed, verbose=False)
    return time.perf_counter() - t0, len(ev.candidates), pareto_front(ev.candidates, senses)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=int, default=120)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "cycloidal.toml"
        path.write_text(MACHINE)
        rows = [("eps-constraint (scipy COBYLA)", *eps_constraint(path, args.budget))]
        try:
            rows.append(("NSGA-II (pymoo, pop 20)", *nsga2(path, args.budget)))
        except ImportError:
            print("pymoo is not installed: pip install pymoo for the comparison")
    print(f"budget {args.budget} candidate evaluations; true front a = 2 pi h w^2 / beta_max^2")
    print(f"{'solver':32s} {'time':>7s} {'evals':>6s} {'points':>6s} {'max dev':>9s} {'median dev':>10s} {'largest gap':>11s}")
    for name, dt, n, front in rows:
        m = metrics(front)
        print(f"{name:32s} {dt:6.1f}s {n:6d} {m['points']:6d} {m['max_dev']:9.2e} {m['median_dev']:10.2e} {m['largest_gap']:11.3f}")


if __name__ == "__main__":
    main()

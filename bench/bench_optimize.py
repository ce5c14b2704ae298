"""Benchmark of ``camsim optimize``: three variables of the CDTM over 100-140 rpm (issue 28).

Run from the repository root::

    python bench/bench_optimize.py                  # --budget 300, 2 workers
    python bench/bench_optimize.py --budget 120 --workers 1

The problem of the issue: the K23 preload, the seat stiffness and the first rise's
duration (the dwell after it absorbs the difference, keeping 360 deg), for the least
peak transducer force, with no jump at any of 100, 110, 120, 130, 140 rpm; differential
evolution (``--method de``, seed 0). It prints the wall time, the number of candidate
evaluations and of runs, the time per run, the optimum against the file's values, and
the time of one serial run of the CDTM measured in the same process (the baseline: the
optimisation's time divided by runs x that is its overhead ratio). Target (issue 28):
under 10 minutes on 2 cores.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import camsim  # noqa: E402

CDTM = ROOT / "machines" / "cdtm.toml"
VARS = [
    "element.K23.preload=20:40lbf",
    "element.seat.stiffness=4e6:1.2e7N/m",
    "cam.segments[0].duration=40:60deg",
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=int, default=300)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--speeds", default="100:140:10rpm")
    args = ap.parse_args()

    from camsim.analyses.sweep.runner import MachineSource, SweepSettings, run_variant

    source = MachineSource.from_path(CDTM)
    run_variant(source, ["cam.speed=120 rpm"], SweepSettings())  # imports and caches warm
    t0 = time.perf_counter()
    for rpm in (100, 120, 140):
        run_variant(source, [f"cam.speed={rpm} rpm"], SweepSettings())
    one_run = (time.perf_counter() - t0) / 3

    t0 = time.perf_counter()
    res = camsim.optimize(CDTM, VARS, absorb="cam.segments[1].duration", minimize="peak_transducer_force",
                          constraints=["jump<=0"], speeds=args.speeds, method="de", budget=args.budget, seed=0,
                          workers=args.workers)
    dt = time.perf_counter() - t0
    print(f"camsim optimize (de, budget {args.budget}, {args.workers} workers, speeds {args.speeds})")
    print(f"  wall time        {dt:8.1f} s   ({dt / 60:.2f} min; target < 10 min)")
    print(f"  evaluations      {len(res.candidates):8d}")
    print(f"  runs             {res.runs:8d}   ({1e3 * dt / max(res.runs, 1):.0f} ms per run)")
    print(f"  one serial run   {1e3 * one_run:8.0f} ms   (baseline, same process)")
    print(f"  parallel speed-up vs serial runs: {res.runs * one_run / dt:.2f}x")
    print(f"  status           {res.status}")
    for v in res.problem.variables:
        print(f"  {v.key:28s} {res.values[v.key]:.6g}  (file {v.initial:.6g}) {v.unit}")
    print(f"  {res.problem.absorb:28s} {math.degrees(res.values[res.problem.absorb]):.6g} deg "
          f"(file {math.degrees(res.problem.absorb_initial):.6g} deg)")
    print(f"  peak_transducer_force worst over the speeds: {res.objective:.6g} N (file {res.initial.objectives[0]:.6g} N, "
          f"{100 * (res.objective / res.initial.objectives[0] - 1):+.1f} %)")
    for s in res.best.per_speed:
        print(f"    {s['speed'] * 60 / (2 * math.pi):5.0f} rpm: {s['objectives'][0]:.6g} N")


if __name__ == "__main__":
    main()

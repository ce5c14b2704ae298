"""Benchmark of ``camsim study``: time for 10 000 runs of the CDTM (issue 15).

Run from the repository root::

    python bench/bench_study.py                  # 200 measured runs, extrapolated to 10 000
    python bench/bench_study.py --runs 10000     # the real thing (about half an hour on 2 cores)
    python bench/bench_study.py --dask           # also the same study on a local Dask cluster

It runs a Monte Carlo study of ``machines/cdtm.toml`` with the four over-travel spring
and seat tolerances of ``docs/tolerance.md`` (machine file's 50 kHz sampling, one
warm-up and one recorded revolution per run) on ``--workers`` processes, with the row
store on disk (one fsync per finished run), and reports:

* the wall time of the measured runs and the time per run;
* the time of the statistics (bootstrap intervals of every output) over 10 000 rows,
  measured on 10 000 rows drawn from the measured ones;
* the time of the Sobol' indices with their bootstrap for N = 2048 (4 inputs: 12 288
  runs), measured the same way;
* the extrapolated wall time of a 10 000-run study: 10 000 x (time per run) + statistics;
* with ``--dask``: the same study (same runs, seed and workers) on a local Dask cluster
  (``dask_local``, as ``camsim study --dask-local N``), its wall time against the process
  pool's (issue 37 target: within 10 %), run in the order pool, Dask, pool, the pool's
  time the mean of its two runs (a steady drift of the load cancels). Both times include starting the executor (the
  pool's processes, the cluster's scheduler and workers), as a user pays them; the
  extrapolation to 10 000 runs is printed for both. The rows are checked identical.

The extrapolation is linear in the number of runs: the runs are independent, the
samples are drawn up front and a finished row costs one append to the row file.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from camsim.analyses.study import study  # noqa: E402
from camsim.analyses.study.sensitivity import sobol_from_outputs  # noqa: E402
from camsim.analyses.study.statistics import summarize  # noqa: E402

CDTM = ROOT / "machines" / "cdtm.toml"
DISTS = [
    "element.K23.pull_stiffness=tol:219:22lbf/in",
    "element.K23.preload=tol:28.12:3lbf",
    "element.seat.gap=tol:0.0625:0.005in",
    "element.seat.stiffness=tol:8.6e6:1.3e6N/m",
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200, help="runs actually made (default 200)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--dask", action="store_true",
                        help="also run the same study on a local Dask cluster of --workers workers")
    args = parser.parse_args()
    print(f"machine: {platform.machine()} {platform.processor() or ''}, {os.cpu_count()} cores, Python {platform.python_version()}")
    print(f"load average at start: {load()} (1/5/15 min; the figures are noisy when others use the cores)")
    res, wall = timed_study(args.runs, workers=args.workers)
    print(f"{args.runs} CDTM runs on {args.workers} workers: {wall:.1f} s wall, {wall / args.runs * 1e3:.0f} ms per run "
          f"({res.failed} failed), including start-up, statistics and file writing", flush=True)
    dask_wall = None
    if args.dask:
        dres, dask_wall = timed_study(args.runs, dask_local=args.workers)
        print(f"{args.runs} CDTM runs on a local Dask cluster of {args.workers} workers: {dask_wall:.1f} s wall", flush=True)
        _, wall2 = timed_study(args.runs, workers=args.workers)  # pool, Dask, pool: a steady drift cancels
        print(f"{args.runs} CDTM runs on {args.workers} workers again: {wall2:.1f} s wall; the pool's time is the mean "
              f"{(wall + wall2) / 2:.1f} s", flush=True)
        wall = (wall + wall2) / 2
        same = res.rows.drop(columns=["seconds"], errors="ignore").equals(dres.rows.drop(columns=["seconds"], errors="ignore"))
        print(f"Dask: {dask_wall / args.runs * 1e3:.0f} ms per run ({dres.failed} failed), including the cluster's start-up; "
              f"Dask / process pool = {dask_wall / wall:.3f} (target <= 1.10: {'met' if dask_wall <= 1.1 * wall else 'MISSED'}); "
              f"rows identical: {'yes' if same else 'NO'}", flush=True)
    per_run = wall / args.runs

    rng = np.random.default_rng(0)
    ok = res.rows[res.rows["status"] == "ok"]
    names = list(res.stats)
    idx = rng.integers(0, len(ok), 10_000)
    cols = {q: ok[q].to_numpy(dtype=float)[idx] for q in names}
    t0 = time.perf_counter()
    summarize(cols, names, 0)
    t_stats = time.perf_counter() - t0
    print(f"statistics of {len(names)} outputs over 10 000 rows (bootstrap, 999 resamples): {t_stats:.1f} s")

    n, d = 2048, len(DISTS)
    varying = [q for q in names if np.ptp(cols[q]) > 0]
    y = np.array([ok[q].to_numpy(dtype=float)[rng.integers(0, len(ok), n * (d + 2))] for q in varying])
    t0 = time.perf_counter()
    sobol_from_outputs(y[:, :n], y[:, n:2 * n], np.stack([y[:, (2 + i) * n:(3 + i) * n] for i in range(d)]),
                       [x.partition("=")[0] for x in DISTS], varying, 0)
    t_sens = time.perf_counter() - t0
    print(f"Sobol' indices of {len(varying)} outputs, N = {n}, d = {d} ({n * (d + 2)} runs), with bootstrap: {t_sens:.1f} s")

    total = 10_000 * per_run + t_stats
    if args.runs >= 10_000:
        print(f"10 000 runs: measured {wall:.0f} s = {wall / 60:.1f} min")
    else:
        print(f"10 000 runs (extrapolated from {args.runs}): {total:.0f} s = {total / 60:.1f} min on {args.workers} workers "
              f"(target <= 10 min: {'met' if total <= 600 else 'MISSED'})")
        if dask_wall is not None:
            dtotal = 10_000 * dask_wall / args.runs + t_stats
            print(f"10 000 runs on Dask (extrapolated from {args.runs}): {dtotal:.0f} s = {dtotal / 60:.1f} min")
    print(f"load average at end: {load()}")


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def cpu_seconds() -> float:
    """CPU time [s] of this process and of its finished (reaped) descendants: the workers."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def timed_study(runs: int, **executor):
    """(StudyResult, wall [s]) of the benchmark study on ``executor`` (workers= or dask_local=).

    Also prints the CPU time of the call, workers included (they are reaped when the study
    closes its executor): on a loaded machine, CPU time / workers estimates the wall time
    the study would take on idle cores.
    """
    with tempfile.TemporaryDirectory() as tmp:
        c0, t0 = cpu_seconds(), time.perf_counter()
        res = study(CDTM, DISTS, runs, method="mc", seed=1, output=Path(tmp) / "bench.h5",
                    limits=["peak_transducer_force>100lbf"], **executor)
        wall, cpu = time.perf_counter() - t0, cpu_seconds() - c0
    print(f"  ({executor}: {wall:.1f} s wall, {cpu:.1f} s CPU with the workers, {cpu / runs * 1e3:.0f} ms CPU per run)",
          flush=True)
    return res, wall


if __name__ == "__main__":
    main()

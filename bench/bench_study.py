"""Benchmark of ``camsim study``: time for 10 000 runs of the CDTM (issue 15).

Run from the repository root::

    python bench/bench_study.py                  # 200 measured runs, extrapolated to 10 000
    python bench/bench_study.py --runs 10000     # the real thing (about half an hour on 2 cores)

It runs a Monte Carlo study of ``machines/cdtm.toml`` with the four over-travel spring
and seat tolerances of ``docs/tolerance.md`` (machine file's 50 kHz sampling, one
warm-up and one recorded revolution per run) on ``--workers`` processes, with the row
store on disk (one fsync per finished run), and reports:

* the wall time of the measured runs and the time per run;
* the time of the statistics (bootstrap intervals of every output) over 10 000 rows,
  measured on 10 000 rows drawn from the measured ones;
* the time of the Sobol' indices with their bootstrap for N = 2048 (4 inputs: 12 288
  runs), measured the same way;
* the extrapolated wall time of a 10 000-run study: 10 000 x (time per run) + statistics.

The extrapolation is linear in the number of runs: the runs are independent, the
samples are drawn up front and a finished row costs one append to the row file.
"""

from __future__ import annotations

import argparse
import os
import platform
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
    args = parser.parse_args()
    print(f"machine: {platform.machine()} {platform.processor() or ''}, {os.cpu_count()} cores, Python {platform.python_version()}")
    print(f"load average at start: {os.getloadavg()[0]:.2f} (the figures are noisy when others use the cores)")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        res = study(CDTM, DISTS, args.runs, method="mc", seed=1, workers=args.workers, output=Path(tmp) / "bench.h5",
                    limits=["peak_transducer_force>100lbf"])
        wall = time.perf_counter() - t0
    per_run = wall / args.runs
    print(f"{args.runs} CDTM runs on {args.workers} workers: {wall:.1f} s wall, {per_run * 1e3:.0f} ms per run "
          f"({res.failed} failed), including start-up, statistics and file writing")

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
        print(f"10 000 runs (extrapolated from {args.runs}): {total:.0f} s = {total / 60:.1f} min on {args.workers} workers")


if __name__ == "__main__":
    main()

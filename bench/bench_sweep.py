"""Benchmark of ``camsim sweep``: a 200-speed sweep of the CDTM (issue 6).

Run from the repository root::

    python bench/bench_sweep.py                 # 60..657 rpm step 3 (200 speeds)
    python bench/bench_sweep.py --sample-rate 50000 --no-dask

It times the sweep serially (``--workers 1``: one process, no pool) and with the
process pool at 2 workers, prints the wall times and the scaling, and the per-variant
overhead of Dask's LocalCluster (2 single-threaded worker processes): its time per
variant minus the serial time per variant (cluster start-up timed separately). The
rows of every executor are checked to be identical. Target (issue 6): <= 10 s on 2
cores with the process pool.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from camsim.analyses.sweep.runner import run_sweep  # noqa: E402

CDTM = ROOT / "machines" / "cdtm.toml"


def same_rows(a, b) -> bool:
    for ra, rb in zip(a, b, strict=True):
        for k in ra:
            x, y = ra[k], rb[k]
            if isinstance(x, float) and math.isnan(x) and isinstance(y, float) and math.isnan(y):
                continue
            if x != y:
                return False
    return True


def cpu_seconds() -> float:
    """CPU time [s] of this process and of its finished (reaped) descendants: the workers."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def timed(label: str, cpu_of_workers: bool = True, **kwargs):
    """Run the sweep; print its wall time and, when its workers have exited by the end of the
    call (serial, process pool; not a Dask cluster, still up), its CPU time with theirs."""
    c0, t0 = cpu_seconds(), time.perf_counter()
    result = run_sweep(CDTM, **kwargs)
    dt, cpu = time.perf_counter() - t0, cpu_seconds() - c0
    n = len(result.rows)
    failed = len(result.failed)
    cpu_note = f"; CPU {cpu:.1f} s with the workers" if cpu_of_workers else ""
    print(f"{label:34s} {dt:7.2f} s  {1e3 * dt / n:7.1f} ms/variant  ({n} variants, {failed} failed{cpu_note})",
          flush=True)
    return result, dt


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vary", default="cam.speed=60:657:3rpm", help="the range (default 200 speeds)")
    parser.add_argument("--sample-rate", type=float, default=10000.0, help="output sample rate [Hz] (default 10 kHz; the machine file has 50 kHz)")
    parser.add_argument("--workers", type=int, default=2, help="pool size to compare with 1 (default 2)")
    parser.add_argument("--no-dask", action="store_true", help="skip the Dask LocalCluster measurement")
    args = parser.parse_args()

    common = {"vary": [args.vary], "sample_rate": args.sample_rate}
    print(f"CDTM sweep {args.vary}, sample rate {args.sample_rate:g} Hz, machine cycles/warm-up; {os.cpu_count()} cores")
    serial, t1 = timed("serial (--workers 1)", workers=1, **common)
    pooled, tn = timed(f"process pool (--workers {args.workers})", workers=args.workers, **common)
    assert same_rows(serial.rows, pooled.rows), "pool rows differ from serial rows"
    print(f"scaling 1 -> {args.workers} workers: {t1 / tn:.2f}x (ideal {args.workers}x)")
    if serial.first_jump_rpm is not None:
        print(f"lowest swept speed at which M1 leaves the cam: {serial.first_jump_rpm:.6g} rpm")
    if not args.no_dask:
        import logging

        import distributed

        t0 = time.perf_counter()
        cluster = distributed.LocalCluster(
            n_workers=args.workers, threads_per_worker=1, processes=True, host="127.0.0.1",
            dashboard_address=None, silence_logs=logging.ERROR,
        )
        startup = time.perf_counter() - t0
        print(f"Dask LocalCluster start-up ({args.workers} workers): {startup:.2f} s")
        try:
            dasked, td = timed(f"Dask LocalCluster ({args.workers} workers)", False, scheduler=cluster.scheduler_address, **common)
        finally:
            cluster.close()
        assert same_rows(serial.rows, dasked.rows), "Dask rows differ from serial rows"
        n = len(serial.rows)
        per_serial = t1 / n
        per_dask = td / n
        print(
            f"Dask per-variant time {1e3 * per_dask:.1f} ms vs serial {1e3 * per_serial:.1f} ms: "
            f"overhead {1e3 * (per_dask - per_serial):+.1f} ms/variant wall "
            f"({1e3 * (per_dask * args.workers - per_serial):+.1f} ms/variant of worker time)"
        )
    print("rows identical across executors: yes")


if __name__ == "__main__":
    main()

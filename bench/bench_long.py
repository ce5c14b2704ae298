"""Long runs (issue 16): peak memory and time of ``camsim run`` against revolutions.

    python bench/bench_long.py                      # CDTM at 10 kHz: 10, 100, 1000 revolutions
    python bench/bench_long.py --revs 10 100 2000   # other counts
    python bench/bench_long.py --summary-only       # store no traces

Each run is a fresh ``python -m camsim run`` process; its peak resident set size is the
kernel's (``resource.getrusage(RUSAGE_CHILDREN)`` of a one-child probe process), its time
the wall clock and the CPU time (user + system; less sensitive to other jobs) of the run.
A streamed run's memory does not grow with revolutions and its time grows linearly: the
table prints CPU time per revolution and memory for each count.
The load average is printed before and after: the figures are only as quiet as the machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

PROBE = (
    "import resource, subprocess, sys, time\n"
    "t = time.perf_counter()\n"
    "subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)\n"
    "r = resource.getrusage(resource.RUSAGE_CHILDREN)\n"
    "print(time.perf_counter() - t, r.ru_utime + r.ru_stime, r.ru_maxrss)\n"
)


def measure(revs: int, rate: str, extra: list[str], workdir: Path) -> tuple[float, float, float, float]:
    """(wall time [s], CPU time [s], peak RSS [MB], file size [MB]) of one run."""
    out = workdir / f"cdtm-{revs}.h5"
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    cmd = [sys.executable, "-m", "camsim", "run", str(ROOT / "machines" / "cdtm.toml"), "-o", str(out),
           "--cycles", str(revs), "--sample-rate", rate, "-q", "--yes", *extra]
    res = subprocess.run([sys.executable, "-c", PROBE, *cmd], env=env, check=True, capture_output=True, text=True)
    seconds, cpu, kb = res.stdout.split()
    size = out.stat().st_size / 1e6
    out.unlink()
    return float(seconds), float(cpu), int(kb) / 1024.0, size


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--revs", type=int, nargs="+", default=[10, 100, 1000])
    parser.add_argument("--sample-rate", default="10kHz")
    parser.add_argument("--summary-only", action="store_true")
    parser.add_argument("--compress", action="store_true")
    args = parser.parse_args(argv)
    extra = (["--summary-only"] if args.summary_only else []) + (["--compress"] if args.compress else [])
    print(f"camsim run machines/cdtm.toml --sample-rate {args.sample_rate} {' '.join(extra)}".rstrip())
    print(f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}; "
          f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'revolutions':>11} {'wall [s]':>9} {'CPU [s]':>8} {'CPU s/rev':>9} {'peak RSS [MB]':>13} {'file [MB]':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        for revs in args.revs:
            seconds, cpu, rss, size = measure(revs, args.sample_rate, extra, Path(tmp))
            print(f"{revs:>11} {seconds:>9.1f} {cpu:>8.1f} {cpu / revs:>9.4f} {rss:>13.0f} {size:>9.1f}", flush=True)
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

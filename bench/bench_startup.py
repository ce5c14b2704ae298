"""Start-up time of the command line (issue 25 item 5) against the floor of its imports.

    python bench/bench_startup.py            # best of 7 per command
    python bench/bench_startup.py -n 15      # best of 15
    python bench/bench_startup.py --also /tmp/old   # also time the commands of another source
                                                    # tree (e.g. `git archive 51d2923`), interleaved

The floor is ``python -c "import numpy, scipy.linalg, h5py"``: what a run cannot avoid
importing. Each command runs in a fresh process, N times, interleaved with the others (so
that a burst of load on a shared machine hits all of them alike); the best wall time of
each is compared with the best floor, as a ratio and a difference. CPU time (user + sys,
less sensitive to other jobs) is printed beside it. The targets on the 2-core development
machine: ``--help`` <= floor, ``validate`` <= floor + 0.25 s, ``run`` <= floor + 0.6 s.

The pint registry is read from its disk cache (``camsim.units.cache_folder``); one
warm-up ``validate`` before the timed rounds fills it, as any first use does. camsim's
modules are byte-compiled first (``compileall``), as Python does on any first import: with
``PYTHONDONTWRITEBYTECODE=1`` (set on the development machine) every start would compile
the package from source again, 0.14-0.25 s that no user pays.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

TARGETS = {"help": 0.0, "validate": 0.25, "run": 0.6}


def timed(cmd: list[str], cwd: Path = ROOT) -> tuple[float, float]:
    """(wall [s], CPU user + sys [s]) of one process run in ``cwd`` (``-m camsim`` imports it from there)."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=cwd)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"failed ({proc.returncode}): {' '.join(cmd)}")
    return wall, usage.ru_utime + usage.ru_stime


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, default=7, help="runs per command (best is kept); default 7")
    ap.add_argument("--also", type=Path, default=None, metavar="DIR",
                    help="also time the commands run from this source tree (its camsim/ package)")
    args = ap.parse_args(argv)
    py = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "cdtm.h5")
        commands = {
            "floor": [py, "-c", "import numpy, scipy.linalg, h5py"],
            "help": [py, "-m", "camsim", "--help"],
            "validate": [py, "-m", "camsim", "validate", "machines/cdtm.toml"],
            "run": [py, "-m", "camsim", "run", "machines/cdtm.toml", "-o", out, "-q"],
        }
        import numpy

        print(f"python {platform.python_version()}, numpy {numpy.__version__}, {platform.machine()}, "
              f"{os.cpu_count()} CPUs, load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
        import compileall

        for tree in [ROOT] + ([args.also.resolve()] if args.also is not None else []):
            compileall.compile_dir(str(tree / "camsim"), quiet=1)  # what a first import writes
        print("camsim byte-compiled (__pycache__), as after its first import")
        timed(commands["validate"])  # fills the pint cache, as the first use does
        runs = [(name, cmd, ROOT) for name, cmd in commands.items()]
        if args.also is not None:
            runs += [(f"{name} ({args.also})", cmd, args.also.resolve()) for name, cmd in commands.items() if name != "floor"]
        best = {name: (float("inf"), float("inf")) for name, _, _ in runs}
        for _ in range(args.n):
            for name, cmd, cwd in runs:
                wall, cpu = timed(cmd, cwd)
                best[name] = (min(best[name][0], wall), min(best[name][1], cpu))
    floor_wall, floor_cpu = best["floor"]
    print(f"best of {args.n} (fresh process each), load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'command':<48} {'wall [s]':>9} {'/floor':>7} {'-floor [s]':>11} {'cpu [s]':>8} {'target':>16}")
    shown = {"floor": 'python -c "import numpy, scipy.linalg, h5py"', "help": "camsim --help",
             "validate": "camsim validate machines/cdtm.toml", "run": "camsim run machines/cdtm.toml"}
    ok = True
    for name, (wall, cpu) in best.items():
        if name == "floor":
            print(f"{shown[name]:<48} {wall:9.3f} {1.0:7.2f} {0.0:11.3f} {cpu:8.3f}")
            continue
        base, _, other = name.partition(" (")
        if other:
            print(f"{shown[base] + ' (' + other:<48} {wall:9.3f} {wall / floor_wall:7.2f} {wall - floor_wall:11.3f} {cpu:8.3f}")
            continue
        margin = TARGETS[name]
        met = wall <= floor_wall + margin
        ok &= met
        target = f"floor + {margin:g} s" if margin else "<= floor"
        print(f"{shown[name]:<48} {wall:9.3f} {wall / floor_wall:7.2f} {wall - floor_wall:11.3f} {cpu:8.3f} "
              f"{target:>11} {'met' if met else 'MISSED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

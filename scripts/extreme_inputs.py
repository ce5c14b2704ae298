"""Run the shipped machines with one value scaled far from its design value (issue 25, item 3).

    python scripts/extreme_inputs.py                   # the grid below, 90 s per case
    python scripts/extreme_inputs.py --timeout 30 -j 2 # quicker look, two cases at a time
    python scripts/extreme_inputs.py --only dynacam    # cases whose label contains "dynacam"
    python scripts/extreme_inputs.py --named           # the cases issue 25 names, only

Every case is ``camsim run MACHINE --set KEY=VALUE -o TMP/out.h5`` in its own subprocess,
with a wall-clock timeout. The promise it checks: every well-formed machine ends in a
result (exit 0), or exit 2 naming the key and why, or exit 1 with a one-line reason --
never a traceback, never a silent hang. A case "hangs" when it reaches the timeout; a
"traceback" is any stderr that contains ``Traceback``. The table gives, per case, the
outcome, the exit code, the wall and CPU time and the last line of stderr (the error
line when there is one).

The grid: for each machine file under machines/ that ``camsim run`` takes (the parts file
of ``camsim lump`` is skipped), its first stiffness (or contact coefficient), damping
ratio, mass, preload and the cam speed, each scaled by every factor of ``--factors``
(default 1e-6, 1e6, 1e9), keeping the units the file wrote. Exit status: 0 when
no case hung or ended in a traceback, 1 otherwise.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
import tomllib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MACHINES = ROOT / "machines"
FACTORS = (1e-6, 1e6, 1e9)

#: The cases issue 25 ("Why", extreme input) names, with the outcome it asks for.
NAMED = (
    ("cdtm-power.toml", "element.K23.preload", '"0.02812 lbf"'),
    ("dynacam-2mass.toml", "element.k12.stiffness", '"1e300 N/m"'),
    ("dynacam-2mass.toml", "element.k12.stiffness", '"1e18 N/m"'),
)

_NUMBER = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)(.*)$", re.S)


@dataclass
class Case:
    machine: str
    key: str
    value: str  # as written after ``=`` (TOML)

    @property
    def label(self) -> str:
        return f"{self.machine} {self.key}={self.value}"


@dataclass
class Outcome:
    case: Case
    code: int | None  # None: timed out
    seconds: float  # wall
    cpu: float  # user + sys of the process
    last_line: str
    traceback: bool

    @property
    def kind(self) -> str:
        if self.code is None:
            return "HANG"
        if self.traceback:
            return "TRACEBACK"
        return {0: "result", 1: "exit 1", 2: "exit 2"}.get(self.code, f"exit {self.code}")


def scaled(value, factor: float) -> str:
    """``"9051 lbf/in"`` × 1e6 → ``'"9.051e+09 lbf/in"'`` (TOML text); a bare number stays bare."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return repr(float(value) * factor)
    m = _NUMBER.match(str(value))
    if not m:
        raise ValueError(f"not a number with units: {value!r}")
    return f'"{float(m.group(1)) * factor:.6g}{m.group(2)}"'


def picks(doc: dict) -> list[tuple[str, object]]:
    """The keys of one machine document that the grid scales (first of each kind)."""
    out: list[tuple[str, object]] = []
    elements = [e for e in doc.get("element", []) if isinstance(e, dict)]
    # the last stiffness and damping ratio (the stiffest part of the shipped machines: the
    # seat, the coupler k12), the first preload (the closure spring)
    for names, order in ((("stiffness", "push_stiffness", "coefficient"), -1), (("damping_ratio",), -1), (("preload",), 1)):
        for e in elements[::order]:
            hit = next((n for n in names if n in e), None)
            if hit is not None:
                out.append((f"element.{e['name']}.{hit}", e[hit]))
                break
    masses = [m for m in doc.get("mass", []) if isinstance(m, dict)]
    if masses:
        out.append((f"mass.{masses[-1]['name']}.mass", masses[-1]["mass"]))
    if isinstance(doc.get("cam"), dict) and "speed" in doc["cam"]:
        out.append(("cam.speed", doc["cam"]["speed"]))
    return out


def grid(factors) -> list[Case]:
    cases = []
    for path in sorted(MACHINES.glob("*.toml")):
        doc = tomllib.loads(path.read_text())
        if "part" in doc or "lever" in doc:  # a lump parts file, not a machine to run
            continue
        for key, value in picks(doc):
            for f in factors:
                cases.append(Case(path.name, key, scaled(value, f)))
    return cases


def run_case(case: Case, timeout: float) -> Outcome:
    """One case in a fresh process; wall time, and CPU time (user + sys, from wait4: on a
    busy machine the wall time says little)."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "camsim", "run", str(MACHINES / case.machine),
               "--set", f"{case.key}={case.value}", "-o", str(Path(tmp) / "out.h5")]
        err_path = Path(tmp) / "stderr.txt"
        t0 = time.perf_counter()
        with open(err_path, "w") as err_file:
            proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err_file, cwd=ROOT)
            code, cpu = None, 0.0
            while True:
                pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
                if pid:
                    code, cpu = os.waitstatus_to_exitcode(status), usage.ru_utime + usage.ru_stime
                    proc.returncode = code
                    break
                if time.perf_counter() - t0 > timeout:
                    proc.kill()
                    _, _, usage = os.wait4(proc.pid, 0)
                    cpu = usage.ru_utime + usage.ru_stime
                    proc.returncode = -9
                    break
                time.sleep(0.05)
        dt = time.perf_counter() - t0
        err = err_path.read_text(errors="replace")
    lines = [ln for ln in err.replace("\r", "\n").splitlines() if ln.strip()]
    errors = [ln for ln in lines if ln.startswith("camsim: error:")]
    last = errors[-1] if errors else (lines[-1] if lines else "(nothing on stderr)")
    return Outcome(case, code, dt, cpu, last, "Traceback" in err)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--timeout", type=float, default=90.0, help="seconds per case (default 90, as in issue 25)")
    ap.add_argument("-j", "--jobs", type=int, default=1, help="cases run at once (default 1)")
    ap.add_argument("--factors", default=",".join(f"{f:g}" for f in FACTORS), help="comma-separated scale factors")
    ap.add_argument("--only", default=None, help="run only the cases whose label contains this text")
    ap.add_argument("--named", action="store_true", help="run only the cases issue 25 names")
    args = ap.parse_args(argv)
    named = [Case(*c) for c in NAMED]
    cases = named if args.named else named + grid([float(f) for f in args.factors.split(",")])
    if args.only:
        cases = [c for c in cases if args.only in c.label]
    print(f"{len(cases)} cases, timeout {args.timeout:g} s, {args.jobs} at a time", flush=True)
    width = max(len(c.label) for c in cases)
    results: list[Outcome] = []
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        for out in pool.map(lambda c: run_case(c, args.timeout), cases):
            results.append(out)
            code = "-" if out.code is None else str(out.code)
            print(f"{out.case.label:<{width}}  {out.kind:<9} {code:>2} {out.seconds:6.1f} s {out.cpu:6.1f} s cpu  "
                  f"{out.last_line[:150]}", flush=True)
    counts: dict[str, int] = {}
    for out in results:
        counts[out.kind] = counts.get(out.kind, 0) + 1
    print("; ".join(f"{k}: {v}" for k, v in sorted(counts.items())))
    bad = [o for o in results if o.kind in ("HANG", "TRACEBACK")]
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

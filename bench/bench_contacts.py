"""Cost of a compliant power-law contact against a linear one (issue 12).

Run from the repository root::

    python bench/bench_contacts.py            # about 30 s (the accuracy reference is DOP853)
    python bench/bench_contacts.py --quick    # timings only, about 8 s

The problem is one revolution of ``machines/cdtm-power.toml`` (the thesis's power-law
seat, exact restitution 0.8) from static equilibrium, sampled at 50 kHz, no warm-up,
against the same machine with a *linear* seat of similar stiffness: k = the power law's
tangent stiffness a·C^(1/a)·F^((a−1)/a) at F = 150 lbf (the thesis's simulated seat
force), damped with the ratio that gives the same restitution 0.8 for an isolated impact
(:func:`camsim.physics.restitution.linear_damping_ratio`). It prints:

1. the machine (CPU, cores, Python, numpy, scipy, load average);
2. steady-state time per revolution of each (best of N calls in one process, alternated
   so that a change of load hits both) and their ratio (issue-12 target: ≤ 1.5);
3. unless ``--quick``: the accuracy of the power-law run (the iterated-remainder stepper
   of :mod:`camsim.engine.nonlinear`) and of the former DOP853-only path (rtol 1e-11) against a
   DOP853 run at rtol 1e-13 — largest displacement error of M2 and M3 relative to their
   peak, largest seat-force error relative to its peak, largest event-time difference.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
import scipy  # noqa: E402

import camsim.engine.integrator as integrate  # noqa: E402
import camsim.engine.nonlinear as nonlinear  # noqa: E402
from camsim.machine.loader import load_machine, load_machine_text  # noqa: E402
from camsim.physics.restitution import linear_damping_ratio  # noqa: E402
from camsim import simulate  # noqa: E402

POWER = ROOT / "machines" / "cdtm-power.toml"
LBF = 4.4482216152605  # [N]
INCH = 0.0254  # [m]
TARGET_RATIO = 1.5


def linear_twin() -> tuple[object, float, float]:
    """The CDTM with a linear seat of similar stiffness; (machine, k [N/m], ζ)."""
    power = load_machine(POWER)
    seat = next(e for e in power.elements if e.name == "seat")
    a, C = seat.exponent, seat.coefficient
    F = 150.0 * LBF
    k = a * C ** (1.0 / a) * F ** ((a - 1.0) / a)
    zeta = linear_damping_ratio(seat.restitution)
    text = POWER.read_text(encoding="utf-8")
    start = text.index('name = "seat"')
    end = text.index("[simulation]")
    block = (
        'name = "seat"\ntype = "contact"\nbetween = ["ground", "M3"]\nlaw = "linear"\n'
        f'gap = "0.0625 in"\nstiffness = "{k!r} N/m"\ndamping_ratio = {zeta!r}\ntransducer = true\n\n'
    )
    return load_machine_text(text[:start] + block + text[end:], source="cdtm-linear-twin"), k, zeta


def machine_info() -> None:
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}", file=sys.stderr)
    try:
        print("load average: " + " ".join(f"{x:.2f}" for x in os.getloadavg()), file=sys.stderr)
    except OSError:
        pass


def timings(power, linear, repeats: int) -> tuple[float, float]:
    simulate(power, cycles=1, warmup_cycles=0)
    simulate(linear, cycles=1, warmup_cycles=0)
    best_p = best_l = math.inf
    for _ in range(repeats):
        t = time.perf_counter()
        simulate(linear, cycles=1, warmup_cycles=0)
        best_l = min(best_l, time.perf_counter() - t)
        t = time.perf_counter()
        simulate(power, cycles=1, warmup_cycles=0)
        best_p = min(best_p, time.perf_counter() - t)
    return best_p, best_l


def accuracy(power) -> None:
    orig_init = integrate.Integrator.__init__
    rtol = {"value": 1e-11}

    def init(self, *args, **kwargs):
        orig_init(self, *args, **kwargs)
        self.rtol_nonlinear = rtol["value"]

    integrate.Integrator.__init__ = init
    try:
        runs = {}
        for label, stepper, tol in (("reference DOP853 rtol 1e-13", False, 1e-13),
                                    ("DOP853 rtol 1e-11 (before issue 12)", False, 1e-11),
                                    ("iterated-remainder stepper", True, 1e-11)):
            nonlinear.ENABLED = stepper
            rtol["value"] = tol
            t = time.perf_counter()
            runs[label] = simulate(power, cycles=1, warmup_cycles=0)
            print(f"  {label:38s} {time.perf_counter() - t:7.3f} s", file=sys.stderr)
    finally:
        integrate.Integrator.__init__ = orig_init
        nonlinear.ENABLED = True
    ref = runs.pop("reference DOP853 rtol 1e-13")
    print("accuracy against DOP853 rtol 1e-13:", file=sys.stderr)
    for label, run in runs.items():
        dx = max(float(np.max(np.abs(run.masses[m]["displacement"] - ref.masses[m]["displacement"])))
                 / float(np.max(np.abs(ref.masses[m]["displacement"]))) for m in ("M2", "M3"))
        df = float(np.max(np.abs(run.elements["seat"] - ref.elements["seat"]))) / float(np.max(ref.elements["seat"]))
        same = [e.kind for e in run.events] == [e.kind for e in ref.events]
        dt = max(abs(a.time - b.time) for a, b in zip(run.events, ref.events)) if same else math.nan
        print(f"  {label:38s} displacement {dx:.2e}  seat force {df:.2e}  events {dt:.2e} s"
              f"{'' if same else '  (event sequence differs)'}", file=sys.stderr)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="timings only (about 8 s)")
    parser.add_argument("--repeats", type=int, default=15, help="calls per machine, alternated, best kept (default 15)")
    args = parser.parse_args(argv)
    machine_info()
    power = load_machine(POWER)
    linear, k, zeta = linear_twin()
    print(f"linear twin: k = {k:.4g} N/m ({k / LBF * INCH:.4g} lbf/in), damping_ratio = {zeta:.4f}", file=sys.stderr)
    t_p, t_l = timings(power, linear, args.repeats)
    ratio = t_p / t_l
    print(f"one revolution, 50 kHz, steady state (best of {args.repeats}):", file=sys.stderr)
    print(f"  power-law seat   {t_p * 1e3:8.1f} ms", file=sys.stderr)
    print(f"  linear seat      {t_l * 1e3:8.1f} ms", file=sys.stderr)
    print(f"  power/linear cost ratio {ratio:.2f} (target <= {TARGET_RATIO}: {'met' if ratio <= TARGET_RATIO else 'NOT met'})",
          file=sys.stderr)
    if not args.quick:
        accuracy(power)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

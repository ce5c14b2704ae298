"""camsim's cost per revolution against the numpy/scipy floor measured in the same run (issue 37).

Run from the repository root::

    python bench/bench_floor.py                 # 15 interleaved rounds
    python bench/bench_floor.py --quick         # 4 rounds
    python bench/bench_floor.py --repeat 40
    python bench/bench_floor.py --also /tmp/camsim-old   # A/B: another source tree's camsim too

The floor (``bench/floor_model.py``) makes the 25,001 samples of one revolution of
``machines/cdtm.toml`` at 50 kHz of camsim's no-impact variant with numpy and scipy alone:
the reference solver's equations, the exact step (matrix exponential, degree-7 Hermite
input), modal :func:`scipy.signal.lfilter` recurrences, the cam law vectorised
(:meth:`camsim.cam.program.CamProgram.svaj`), outputs vectorised. Before timing, its traces
are checked against camsim's no-impact run: every trace to 1e-9 of its peak, else the
bench stops (it would compare different work).

Each round times three calls of the floor (1 and 3 revolutions, its set-up included:
from the loaded machine to the traces, as ``simulate`` does), in this process, and one of
``camsim.simulate(machine, cycles=C, warmup_cycles=0, sample_rate=R)`` with impact and
with ``no_impact=True`` for C = 1 and 3 at 50 kHz and C = 1 at 2 Hz, in a child process
that imports this tree's camsim (warmed up by one call of each first), the order rotating
from round to round. Wall (``time.perf_counter``) and CPU (``time.process_time``) time
of each call; the table gives the minimum and the median over the rounds. Derived
figures: the marginal revolution (3 revolutions − 1, halved: the steady state without the
start-up), the cost per event ((with impact − without) / branch-change events per
revolution, at 50 kHz, marginal, and at 2 Hz where the samples cost almost nothing).
The targets of issue 37, judged on the minima: with impact ≤ 3× the floor per
revolution, without impact ≤ 1.5×, ≤ 0.2 ms per event. Both camsim and the floor run
with BLAS limited to one thread.

The machine is shared: the load average is printed at the start and the end; CPU time
is less sensitive to other jobs than wall time, and the ratios to the floor measured in
the same rounds carry over between runs on differently loaded machines better than the
absolute times.

Each single-run call starts without the cam programs and input stores that a process's
earlier runs leave (``camsim.cam.camshaft.shared_program``): a ``camsim run`` pays its cam's
laws on the grid, as the floor does. One design evaluation (issue 42) is what a study pays per run of the file:
``camsim.run.evaluation.evaluate(machine)`` with the file's own settings (a warm-up revolution
and one recorded revolution, every located scalar, no traces); its target is 2× the floor's
revolution.

``--also DIR`` times the camsim of another source tree (its ``camsim/`` package, e.g. a
``git worktree`` of an older commit) in a second child process of the same kind, the two
trees alternating first and second from round to round, and prints its figures, its
ratios to the same floor and this tree / DIR for every figure: an A/B comparison of the
engine on one machine state. Both trees run this tree's ``machines/cdtm.toml``.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CDTM = ROOT / "machines" / "cdtm.toml"
RATE = 50e3  # [Hz] the output rate of the figures
SLOW_RATE = 2.0  # [Hz] output so sparse that a revolution's cost is its events
TOLERANCE = 1e-9  # floor against camsim's no-impact traces, of each trace's peak
TARGETS = {"impact": 3.0, "no_impact": 1.5, "event_ms": 0.2, "evaluation": 2.0}
BRANCH_KINDS = ("impact", "release", "separation", "rejoin")
FLOOR_CALLS = 3  # floor calls per round (each ~15 ms of CPU)

#: camsim calls of a round: label -> simulate() keywords.
CAMSIM_CASES = {
    "impact-1": {"cycles": 1, "sample_rate": RATE},
    "free-1": {"cycles": 1, "sample_rate": RATE, "no_impact": True},
    "impact-3": {"cycles": 3, "sample_rate": RATE},
    "free-3": {"cycles": 3, "sample_rate": RATE, "no_impact": True},
    "impact-2Hz": {"cycles": 1, "sample_rate": SLOW_RATE},
    "free-2Hz": {"cycles": 1, "sample_rate": SLOW_RATE, "no_impact": True},
}


def timed(fn) -> tuple[float, float]:
    """(wall [s], CPU [s]) of one call of ``fn``, after a garbage collection."""
    gc.collect()
    w0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w0, time.process_time() - c0


class CamsimCalls:
    """The camsim calls of a round, for the camsim importable in this process."""

    def __init__(self):
        import camsim

        self.camsim = camsim
        self.machine = camsim.load_machine(CDTM)
        # a run of `camsim run` builds its cam's program and evaluates its laws on the grid:
        # each single-run call starts without the programs and stores a process's earlier runs
        # left (camsim.cam.camshaft.shared_program); a design evaluation reuses them, as a
        # study's runs on one cam do
        def single(kw):
            _forget_shared_inputs()
            return camsim.simulate(self.machine, warmup_cycles=0, **kw)

        self.calls = {label: (lambda kw=kw: single(kw)) for label, kw in CAMSIM_CASES.items()}
        # issue 42: one design evaluation, what a study pays per run of the file (its warm-up and
        # one recorded revolution, every located scalar, no traces); a tree without the
        # scalars-only evaluation pays a full run of the file's settings
        try:
            from camsim.run.evaluation import evaluate
        except ImportError:
            evaluate = camsim.simulate
        self.calls["evaluation"] = lambda: evaluate(self.machine)
        run = self.calls["impact-1"]()  # warm: imports, caches
        for call in self.calls.values():
            call()
        self.events = sum(1 for e in run.events if str(getattr(e.kind, "value", e.kind)) in BRANCH_KINDS)

    def round(self, order: list[str]) -> dict[str, tuple[float, float]]:
        return {label: timed(self.calls[label]) for label in order}


def _forget_shared_inputs() -> None:
    """Drop the cam programs and input stores shared by a process's runs (a tree without them: nothing)."""
    try:
        from camsim.cam.camshaft import shared_program
        from camsim.engine import context
    except ImportError:
        return
    shared_program.cache_clear()
    context._INPUT_STORES.clear()


def serve() -> None:
    """A child process (one per source tree): one round of camsim calls per input line, one JSON line back."""
    calls = CamsimCalls()
    print(json.dumps({"events": calls.events, "camsim": str(Path(calls.camsim.__file__).parent)}), flush=True)
    for line in sys.stdin:
        print(json.dumps(calls.round(json.loads(line))), flush=True)


class Child:
    """A ``serve()`` process importing camsim from ``tree``."""

    def __init__(self, tree: Path):
        env = dict(os.environ, PYTHONPATH=str(tree))
        self.proc = subprocess.Popen([sys.executable, __file__, "--serve", str(tree)], cwd=tree, env=env,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        hello = json.loads(self.proc.stdout.readline())
        self.events, self.where = hello["events"], hello["camsim"]

    def round(self, order: list[str]) -> dict[str, tuple[float, float]]:
        self.proc.stdin.write(json.dumps(order) + "\n")
        self.proc.stdin.flush()
        return {k: tuple(v) for k, v in json.loads(self.proc.stdout.readline()).items()}

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait()


def check_floor(floor_run, trace_errors, machine, camsim) -> float:
    """Worst relative difference of the floor's traces from camsim's no-impact run (printed)."""
    errs = trace_errors(floor_run(machine, 1, RATE), camsim.simulate(machine, no_impact=True, cycles=1,
                                                                    warmup_cycles=0, sample_rate=RATE))
    worst = max(errs, key=errs.get)
    print(f"floor check   {len(errs)} traces of the no-impact run, worst {errs[worst]:.1e} of peak ({worst}); "
          f"bar {TOLERANCE:.0e}", flush=True)
    return errs[worst]


def summarise(samples: dict[str, list[tuple[float, float]]], events: int) -> dict[str, tuple[float, ...]]:
    """(wall min, wall median, CPU min, CPU median) of every figure, derived ones included [s]."""
    def stat(label):
        walls = [w for w, _ in samples[label]]
        cpus = [c for _, c in samples[label]]
        return (min(walls), statistics.median(walls), min(cpus), statistics.median(cpus))

    out = {label: stat(label) for label in samples}

    def combine(f, *labels):
        return tuple(f(*(out[lab][i] for lab in labels)) for i in range(4))

    if "floor-1" in out:
        out["floor-marginal"] = combine(lambda a, b: (b - a) / 2, "floor-1", "floor-3")
    out["impact-marginal"] = combine(lambda a, b: (b - a) / 2, "impact-1", "impact-3")
    out["free-marginal"] = combine(lambda a, b: (b - a) / 2, "free-1", "free-3")
    if events:
        out["event"] = combine(lambda a, b: (a - b) / events, "impact-1", "free-1")
        out["event-marginal"] = combine(lambda a, b: (a - b) / events, "impact-marginal", "free-marginal")
        out["event-2Hz"] = combine(lambda a, b: (a - b) / events, "impact-2Hz", "free-2Hz")
    return out


ROWS = [
    ("floor-1", "floor, 1 revolution (set-up included)"),
    ("floor-marginal", "floor, a further revolution"),
    ("impact-1", "camsim, with impact, 1 revolution"),
    ("free-1", "camsim, without impact, 1 revolution"),
    ("impact-marginal", "camsim, with impact, a further revolution"),
    ("free-marginal", "camsim, without impact, a further revolution"),
    ("impact-2Hz", "camsim, with impact, 1 revolution at 2 Hz"),
    ("free-2Hz", "camsim, without impact, 1 revolution at 2 Hz"),
    ("event", "per event (1 revolution)"),
    ("event-marginal", "per event (a further revolution)"),
    ("event-2Hz", "per event (2 Hz output)"),
    ("evaluation", "one design evaluation (warm-up + 1 revolution, scalars)"),
]


def ms(x: float) -> str:
    return f"{x * 1e3:9.2f}"


def print_table(fig: dict, title: str, floor: dict) -> None:
    print(f"\n{title}")
    print(f"  {'figure [ms]':46s} {'wall min':>9} {'wall med':>9} {'cpu min':>9} {'cpu med':>9}")
    for key, label in ROWS:
        if key in fig:
            print(f"  {label:46s} " + " ".join(ms(x) for x in fig[key]))
    print(f"  {'ratios and targets':46s} {'wall min':>9} {'wall med':>9} {'cpu min':>9} {'cpu med':>9}   target")
    rows = [("impact-1", "floor-1", "with impact / floor", TARGETS["impact"]),
            ("free-1", "floor-1", "without impact / floor", TARGETS["no_impact"]),
            ("evaluation", "floor-1", "design evaluation / floor revolution", TARGETS["evaluation"]),
            ("impact-marginal", "floor-marginal", "with impact / floor, further revolution", None),
            ("free-marginal", "floor-marginal", "without impact / floor, further revolution", None)]
    for num, den, label, target in rows:
        r = [fig[num][i] / floor[den][i] for i in range(4)]
        mark = ""
        if target is not None:
            mark = f"  <= {target:g}: {'met' if r[0] <= target else 'MISSED'} (cpu {'met' if r[2] <= target else 'MISSED'})"
        print(f"  {label:46s} " + " ".join(f"{x:9.2f}" for x in r) + mark)
    if "event" in fig:
        e = fig["event"]
        print(f"  {'cost per event [ms]':46s} " + " ".join(ms(x) for x in e)
              + f"  <= {TARGETS['event_ms']:g} ms: {'met' if e[0] * 1e3 <= TARGETS['event_ms'] else 'MISSED'}"
              f" (cpu {'met' if e[2] * 1e3 <= TARGETS['event_ms'] else 'MISSED'})")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=15, help="interleaved rounds (default 15; --quick: 4)")
    ap.add_argument("--quick", action="store_true", help="4 rounds")
    ap.add_argument("--also", type=Path, default=None, metavar="DIR",
                    help="also time the camsim of this source tree, interleaved (A/B)")
    ap.add_argument("--serve", type=Path, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.serve is not None:
        serve()
        return 0
    repeat = 4 if args.quick and args.repeat == 15 else args.repeat
    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(ROOT / "bench"))
    from threadpoolctl import threadpool_limits

    from floor_model import floor_run, floor_system, trace_errors
    from peer_models import load_average, print_machine

    print_machine("Floor benchmark (issue 37): camsim against the numpy/scipy floor, one CDTM revolution at 50 kHz")
    import camsim

    machine = camsim.load_machine(CDTM)
    floor_system(machine, RATE)  # warm scipy's imports
    if check_floor(floor_run, trace_errors, machine, camsim) > TOLERANCE:
        print("the floor does not reproduce camsim's no-impact run: no timing", file=sys.stderr)
        return 1

    def floor(cycles):
        with threadpool_limits(limits=1, user_api="blas"):
            return floor_run(machine, cycles, RATE)

    # camsim runs in a child process per source tree, this one's too: A and B alike.
    mine = Child(ROOT)
    child = Child(args.also.resolve()) if args.also is not None else None
    print(f"camsim        {mine.where}: {mine.events} branch-change events per revolution", flush=True)
    if child is not None:
        print(f"also          {child.where}: {child.events} events per revolution", flush=True)
    cases_all = [*CAMSIM_CASES, "evaluation"]
    print(f"rounds        {repeat}, each: the floor (1, 3 revolutions; {FLOOR_CALLS} calls each) and "
          f"{len(cases_all)} camsim calls per tree, rotating order", flush=True)
    labels = ["floor-1", "floor-3", *cases_all]
    ours = {label: [] for label in labels}
    theirs = {label: [] for label in cases_all}
    floor_calls = {"floor-1": lambda: floor(1), "floor-3": lambda: floor(3)}
    try:
        for r in range(repeat):
            order = labels[r % len(labels):] + labels[:r % len(labels)]  # rotate: no fixed neighbour
            cases = [lab for lab in order if lab in cases_all]
            trees = [(mine, ours), (child, theirs)] if child is not None else [(mine, ours)]
            for proc, into in trees[r % len(trees):] + trees[:r % len(trees)]:  # A B, B A, ...
                for label, t in proc.round(cases).items():
                    into[label].append(t)
                if proc is mine:  # the floor is cheap: several calls a round, for its best
                    for label in order:
                        if label in floor_calls:
                            ours[label] += [timed(floor_calls[label]) for _ in range(FLOOR_CALLS)]
    finally:
        for proc in (mine, child):
            if proc is not None:
                proc.close()
    fig = summarise(ours, mine.events)
    print_table(fig, f"this tree ({ROOT}), {repeat} rounds", fig)
    if child is not None:
        other = summarise(theirs, child.events)
        print_table(other, f"--also {args.also} (same rounds, same floor)", fig)
        print(f"\n  {'this tree / --also':46s} {'wall min':>9} {'wall med':>9} {'cpu min':>9} {'cpu med':>9}")
        for key, label in ROWS[2:]:
            if key in other and key in fig:
                print(f"  {label:46s} " + " ".join(f"{a / b:9.2f}" for a, b in zip(fig[key], other[key])))
    print(f"\nload     {load_average()} (1/5/15 min) at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())

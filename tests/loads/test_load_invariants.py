"""The engine's invariants (issue 25, spec §4) on a machine with process loads (issue 43).

One machine carries every kind of load — a segment program, a time table with a ramp and a
step, a sine that starts inside the record, a constant and an angle table with a step, on a
free mass and on the driven follower — and a damped seat the free mass bounces on, so the run
has impacts, releases and jump rows. The checks are those of ``tests/invariants`` (their
tolerances: events to 1e-9 s, traces and located extremes to 1e-9 of their peak, the US text
to 1e-12), reused as they are:

* (a) two sample rates: the same events and the same traces at the shared instants, and (g)
  the same located extremes (the loads' own among them), and the same work per cycle;
* (c) the file's tables reordered (masses, elements and loads: the input's groups change
  order) and (d) the machine written in US units (lb, in, lbf, the CSVs in lbf): the same run;
* (b) the streamed run equals the in-memory one bit for bit, the loads' traces and work too.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest


def _invariant_checks():
    """tests/invariants/invariant_checks.py, loaded by its path (no folder on sys.path: each test
    folder's conftest stays its own)."""
    name = "camsim_invariant_checks"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, Path(__file__).parents[1] / "invariants" / "invariant_checks.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


inv = _invariant_checks()

LBF = 0.45359237 * 9.80665
LB = 0.45359237
INCH = 0.0254

#: (time [s], force [N]) rows of the time table: a ramp, a hold, a step (a time written twice).
GAS = [(-1.0, 0.0), (0.02, 0.0), (0.04, 15.0), (0.09, 15.0), (0.09, -5.0), (0.2, 0.0)]
#: (angle [deg], force [N]) rows of the angle table, a step at 230 deg.
CUTTER = [(0.0, 0.0), (200.0, 0.0), (230.0, 40.0), (230.0, 10.0), (300.0, 0.0), (360.0, 0.0)]


def _csv(path: Path, head: str, rows, scale: float) -> str:
    path.write_text(head + "\n" + "".join(f"{x!r}, {f / scale!r}\n" for x, f in rows))
    return path.as_posix()


def machine_text(folder: Path, us: bool = False) -> str:
    """The machine, in SI or in US units (the same SI values to rounding)."""
    def q(value: float, si: str, us_unit: str, factor: float) -> str:
        return f'"{value / factor!r} {us_unit}"' if us else f'"{value!r} {si}"'

    def force(value):
        return q(value, "N", "lbf", LBF)

    suffix = "-us" if us else ""
    gas = _csv(folder / f"gas{suffix}.csv", "time [s], force [lbf]" if us else "time [s], force [N]", GAS, LBF if us else 1.0)
    cutter = _csv(folder / f"cutter{suffix}.csv", "angle [deg], force [lbf]" if us else "angle [deg], force [N]", CUTTER,
                  LBF if us else 1.0)
    return f"""
schema = 1
[machine]
name = "loads invariants"
[cam]
speed = "240 rpm"
drives = "M1"
segments = [
  {{ motion = "rise", law = "modified-trapezoid", duration = "100 deg", lift = {q(0.008, "m", "in", INCH)} }},
  {{ motion = "dwell", duration = "80 deg" }},
  {{ motion = "fall", law = "cycloidal", duration = "100 deg", lift = {q(0.008, "m", "in", INCH)} }},
  {{ motion = "dwell", duration = "80 deg" }},
]
[[mass]]
name = "M1"
mass = {q(0.8, "kg", "lb", LB)}
[[mass]]
name = "M2"
mass = {q(0.3, "kg", "lb", LB)}
[[element]]
name = "k12"
type = "spring"
between = ["M1", "M2"]
stiffness = {q(6e4, "N/m", "lbf/in", LBF / INCH)}
damping_ratio = 0.04
[[element]]
name = "seat"
type = "contact"
between = ["ground", "M2"]
gap = {q(0.0005, "m", "in", INCH)}
stiffness = {q(2e6, "N/m", "lbf/in", LBF / INCH)}
damping_ratio = 0.05
[[load]]
name = "press"
on = "M2"
base = {force(-10.0)}
segments = [
  {{ motion = "dwell", duration = "60 deg" }},
  {{ motion = "rise", law = "cycloidal", duration = "40 deg", change = {force(90.0)} }},
  {{ motion = "dwell", duration = "20 deg" }},
  {{ motion = "fall", law = "modified-sine", duration = "50 deg", change = {force(90.0)} }},
  {{ motion = "dwell", duration = "190 deg" }},
]
[[load]]
name = "gas"
on = "M2"
table = "{gas}"
[[load]]
name = "kick"
on = "M2"
sine = {{ amplitude = {force(6.0)}, frequency = "31 Hz", phase = "15 deg", offset = {force(1.0)}, start = "0.05 s" }}
[[load]]
name = "weight"
on = "M1"
force = {force(-12.0)}
[[load]]
name = "cutter"
on = "M1"
table = "{cutter}"
[simulation]
cycles = 1
warmup_cycles = 1
sample_rate = "20 kHz"
"""


@pytest.fixture(scope="module")
def text(tmp_path_factory) -> str:
    return machine_text(tmp_path_factory.mktemp("loads"))


def test_the_machine_exercises_every_kind_of_event_and_load(text):
    """The machine is worth the checks below: impacts and releases of the seat, jump rows of
    the driven follower, every load kind (a check that cannot fail on an empty run is none)."""
    run = inv.simulate(inv.load(text))
    kinds = {str(e.kind) for e in run.events}
    assert {"impact", "release", "jump"} <= kinds
    assert sorted(run.loads) == ["cutter", "gas", "kick", "press", "weight"]
    assert {load.kind for load in run.machine.loads} == {"segments", "table", "sine", "force"}


def test_a_sample_rate_changes_no_event_trace_extreme_or_work(text):
    """(a) and (g) at 10 and 20 kHz: events to 1e-9 s, traces at the shared samples and the
    located extremes (``loads/<name>/force`` among them) to 1e-9 of their peak; each load's
    work per cycle to 1e-10 relative (integrated on the solution, camsim.run.loads) at 7 and
    20 kHz."""
    assert inv.check_sample_rate(text, (10_000.0, 20_000.0)) == []
    assert inv.check_located_extremes(text, (10_000.0, 20_000.0)) == []
    machine = inv.load(text)
    lo, hi = (inv.simulate(machine, sample_rate=r) for r in (7_000.0, 20_000.0))
    assert {p for p in lo.located if p.startswith("loads/")} == {f"loads/{n}/force" for n in lo.loads}
    for name in lo.loads:
        a, b = lo.load_work[name], hi.load_work[name]
        # relative, or of 1 mJ (a load's force times the lift, 0.1 J, for the constant's zero)
        assert abs(a - b) <= 1e-10 * max(abs(b), 1e-3), (name, a, b)


def test_reordered_tables_change_nothing(text):
    """(c) masses, elements and loads shuffled (the loads' input groups in another order)."""
    for seed in (1, 2):
        other = inv.permute_text(text, seed)
        assert other != text
        assert inv.check_permutation(text, other) == []


def test_us_units_give_the_same_si_numbers(tmp_path):
    """(d) the machine in lb, in, lbf, lbf/in (and its CSVs in lbf): the same SI parameters
    (1e-15) and the same run to 1e-12 (events, traces)."""
    assert inv.check_units(machine_text(tmp_path), machine_text(tmp_path, us=True)) == []


def test_streamed_run_equals_in_memory_run(text, tmp_path):
    """(b) camsim run's streamed path: the same traces and events bit for bit; the summary's
    loads (extremes and work) equal the in-memory result's."""
    assert inv.check_streamed(text, tmp_path) == []
    machine = inv.load(text)
    memory = inv.simulate(machine)
    streamed = inv.simulate_to_file(machine, tmp_path / "again.h5")
    assert streamed.summary()["loads"] == memory.summary()["loads"]
    assert streamed.open().load_work == memory.load_work

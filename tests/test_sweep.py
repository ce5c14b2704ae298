"""Sweeps (camsim.analyses.sweep.runner): grid parsing, rows against individual runs, executors, jump onset, files.

Expected values and their sources:

* rows: every number is recomputed here from an individual ``simulate()`` of the same
  machine with the same override (the way ``camsim run --set`` would run it) and must
  agree exactly (bit for bit): a sweep is nothing but those runs.
* executors: serial, process pool and Dask LocalCluster rows must be identical (exact).
* jump onset of machines/barkan-follower.toml: the closed form of the file's comment
  (rigid follower leaves the cam when m·ω²·s''(θ) + P + k·s(θ) < 0, cycloidal rise),
  solved here with scipy from the machine's own parameters; tolerance 0.1 rpm (the
  bisection's resolution).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.optimize

from camsim.errors import InputError, MachineFileError
from camsim.io.hdf5 import read_table
from camsim.machine.loader import load_machine
from camsim.run.simulation import simulate
from camsim.analyses.sweep.runner import (
    MachineSource,
    build_grid,
    csv_path_for,
    parse_values,
    parse_vary,
    run_sweep,
    write_sweep,
)

MACHINES = Path(__file__).resolve().parents[1] / "machines"
BARKAN = MACHINES / "barkan-follower.toml"
DYNACAM = MACHINES / "dynacam-2mass.toml"
#: Fast settings for tests: one recorded revolution, no warm-up, 2 kHz output.
FAST = {"cycles": 1, "warmup_cycles": 0, "sample_rate": 2000.0}
RPM = 2 * math.pi / 60  # rpm -> rad/s


# ------------------------------------------------------------------------- parsing
@pytest.mark.parametrize(
    ("text", "key", "values"),
    [
        ("cam.speed=60:100:10rpm", "cam.speed", ["60 rpm", "70 rpm", "80 rpm", "90 rpm", "100 rpm"]),  # stop on grid: included
        ("cam.speed=60:95:10 rpm", "cam.speed", ["60 rpm", "70 rpm", "80 rpm", "90 rpm"]),  # stop off grid: last below it
        ("cam.speed=60rpm:80rpm:10rpm", "cam.speed", ["60 rpm", "70 rpm", "80 rpm"]),
        ("x=0.1:0.3:0.1", "x", ["0.1", "0.2", "0.3"]),  # decimal arithmetic, no 0.30000000000000004
        ("element.k.stiffness=1e6:3e6:1e6N/m", "element.k.stiffness", ["1000000 N/m", "2000000 N/m", "3000000 N/m"]),
        ("initial.M.velocity=-0.2:0.2:0.2 m/s", "initial.M.velocity", ["-0.2 m/s", "0 m/s", "0.2 m/s"]),
        ("x=5:1:-2", "x", ["5", "3", "1"]),
        ("x=7:7:1", "x", ["7"]),
    ],
)
def test_parse_vary(text, key, values):
    assert parse_vary(text) == (key, values)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("cam.speed=60:600:0rpm", "the step is zero"),
        ("cam.speed=600:60:10rpm", "empty range"),
        ("cam.speed=60:600:-10rpm", "empty range"),
        ("cam.speed=60:600rpm", "START:STOP:STEP"),
        ("cam.speed", "KEY=START:STOP:STEP"),
        ("cam.speed=a:b:c", "is not a number"),
        ("cam.speed=60Hz:600:10rpm", "may only repeat the unit"),
    ],
)
def test_parse_vary_rejects(text, message):
    with pytest.raises(InputError, match=message):
        parse_vary(text)


def test_parse_values_unit_after_last_applies_to_all():
    assert parse_values("cam.speed=100,250,400rpm") == ("cam.speed", ["100 rpm", "250 rpm", "400 rpm"])
    assert parse_values("mass.M.mass=1 kg, 2 lb") == ("mass.M.mass", ["1 kg", "2 lb"])
    with pytest.raises(InputError, match="empty value"):
        parse_values("cam.speed=100rpm,,200rpm")


def test_grid_is_all_combinations_last_key_fastest():
    grid = build_grid([("a", ["1", "2"]), ("b", ["x", "y", "z"])])
    assert grid == [("a=1", "b=x"), ("a=1", "b=y"), ("a=1", "b=z"), ("a=2", "b=x"), ("a=2", "b=y"), ("a=2", "b=z")]
    with pytest.raises(InputError, match="given twice"):
        build_grid([("a", ["1"]), ("a", ["2"])])


# ------------------------------------------------------------------------- rows = runs
def expected_row(path: Path, overrides: list[str], **settings) -> dict:
    """The summary columns of one individual run: its located extremes (spec §4), and the
    rest computed here from its events."""
    machine = load_machine(path, overrides=overrides)
    r = simulate(machine, **settings)
    row = {}
    for name in r.masses:
        for quantity in ("displacement", "velocity", "acceleration"):
            row[f"peak_{quantity}:{name}"] = r.extreme(f"masses/{name}/{quantity}", "abs")[0]
    row["max_cam_contact_force"] = r.extreme("cam_force", "max")[0]
    row["min_cam_contact_force"] = r.extreme("cam_force", "min")[0]
    row["peak_transducer_force"] = r.extreme("transducer/force", "max")[0] if r.transducer_force is not None else np.nan
    # the located peaks bound the samples: never below the largest sample
    assert row["peak_transducer_force"] >= np.max(r.transducer_force) if r.transducer_force is not None else True
    row["jump"] = r.follower_jumps()
    impacts = [e for e in r.events if e.kind in ("impact", "rejoin")]
    row["impacts"] = len(impacts)
    row["max_impact_velocity"] = max((abs(e.relative_velocity) for e in impacts), default=np.nan)
    row["periodicity_residual"] = r.periodicity_residual
    row["status"] = "ok"
    return row


def assert_same(actual: dict, expected: dict) -> None:
    for key, value in expected.items():
        got = actual[key]
        if isinstance(value, (float, np.floating)) and np.isnan(value):
            assert isinstance(got, float) and np.isnan(got), key
        else:
            assert got == value, (key, got, value)  # exact: the same computation


def test_rows_equal_individual_runs_two_keys_grid_order():
    """dynacam-2mass over 2 speeds x 2 stiffnesses: each row is that run (exact), grid order."""
    result = run_sweep(
        DYNACAM, ["cam.speed=150:200:50rpm"], ["element.k12.stiffness=5e5,7e5N/m"], workers=1, **FAST
    )
    assert [c for c, _ in result.columns] == [
        "param:cam.speed", "param:element.k12.stiffness",
        "peak_displacement:m1", "peak_velocity:m1", "peak_acceleration:m1",
        "peak_displacement:m2", "peak_velocity:m2", "peak_acceleration:m2",
        "peak_transducer_force", "max_cam_contact_force", "min_cam_contact_force",
        "jump", "cam_separation", "cam_separation_angle", "impacts", "max_impact_velocity", "periodicity_residual", "status",
    ]  # fmt: skip
    combos = [(150, "5e5"), (150, "7e5"), (200, "5e5"), (200, "7e5")]
    assert len(result.rows) == 4
    for row, (rpm, k) in zip(result.rows, combos):
        # SI parameter values: rpm -> rad/s as the loader converts them
        assert row["param:cam.speed"] == pytest.approx(rpm * RPM, rel=1e-15)
        assert row["param:element.k12.stiffness"] == float(k)
        assert_same(row, expected_row(DYNACAM, [f"cam.speed={rpm} rpm", f"element.k12.stiffness={k} N/m"], **FAST))
    assert result.jump_onset_rpm is None and result.first_jump_rpm is None


BARKAN_VALUES = ["cam.speed=400,460,520rpm"]


@pytest.fixture(scope="module")
def barkan_serial():
    return run_sweep(BARKAN, [], BARKAN_VALUES, workers=1, **FAST)


def test_rows_equal_individual_runs_with_impacts(barkan_serial):
    """barkan-follower below and above the jump: impacts and approach velocities per run."""
    rows = barkan_serial.rows
    for row, rpm in zip(rows, (400, 460, 520)):
        assert_same(row, expected_row(BARKAN, [f"cam.speed={rpm} rpm"], **FAST))
    assert [r["jump"] for r in rows] == [False, True, True]
    assert rows[2]["impacts"] >= 1 and rows[2]["max_impact_velocity"] > 0
    assert barkan_serial.first_jump_rpm == pytest.approx(460.0, rel=1e-12)


def test_process_pool_rows_identical_to_serial(barkan_serial):
    pooled = run_sweep(BARKAN, [], BARKAN_VALUES, workers=2, **FAST)
    assert pooled.executor == "process pool"
    assert_rows_identical(pooled.rows, barkan_serial.rows)


def assert_rows_identical(a: list[dict], b: list[dict]) -> None:
    assert len(a) == len(b)
    for ra, rb in zip(a, b):
        assert list(ra) == list(rb)
        for key in ra:
            x, y = ra[key], rb[key]
            if isinstance(x, float) and math.isnan(x):
                assert isinstance(y, float) and math.isnan(y), key
            else:
                assert x == y and type(x) is type(y), (key, x, y)


def test_dask_local_rows_identical_to_serial(barkan_serial):
    pytest.importorskip("distributed")
    dasked = run_sweep(BARKAN, [], BARKAN_VALUES, dask_local=2, **FAST)
    assert dasked.executor.startswith("Dask LocalCluster")
    assert_rows_identical(dasked.rows, barkan_serial.rows)


# ------------------------------------------------------------------------- jump onset
def analytic_jump_onset_rpm(path: Path) -> float:
    """Barkan's onset from the machine's own values: min over θ of m ω² s'' + P + k s = 0.

    Cycloidal rise of lift h over β: s = h (u − sin 2πu / 2π), s'' = 2π h sin(2πu) / β²
    (per rad²), u = θ/β. The fall is the mirror image, so the rise decides.
    """
    machine = load_machine(path)
    m = machine.masses[0].mass
    spring = next(e for e in machine.elements if e.name == "closure")
    k, preload = spring.stiffness, spring.preload
    rise = machine.cam.segments[0]
    assert rise.law == "cycloidal" and rise.motion == "rise"
    h, beta = rise.lift * machine.cam.ratio, rise.duration

    def min_force(omega):
        def fc(u):
            s = h * (u - math.sin(2 * math.pi * u) / (2 * math.pi))
            s2 = 2 * math.pi * h * math.sin(2 * math.pi * u) / beta**2
            return m * omega**2 * s2 + preload + k * s

        res = scipy.optimize.minimize_scalar(fc, bounds=(0.5, 1.0), method="bounded", options={"xatol": 1e-12})
        return res.fun

    omega = scipy.optimize.brentq(min_force, 10.0, 200.0, xtol=1e-12)
    return omega / RPM


def test_analytic_onset_matches_the_file_comment():
    # the file states 46.8767 rad/s = 447.6 rpm
    assert analytic_jump_onset_rpm(BARKAN) == pytest.approx(46.8767 / RPM, abs=1e-3)


def test_refined_jump_onset_matches_analytic():
    """Bisection to 0.1 rpm (machine's own sample rate and cycles; the jump is an event)."""
    result = run_sweep(BARKAN, ["cam.speed=430:460:10rpm"], workers=1, refine_jump=True)
    expected = analytic_jump_onset_rpm(BARKAN)
    assert result.first_jump_rpm == pytest.approx(450.0, rel=1e-12)
    lo, hi = result.jump_bracket_rpm
    assert hi - lo <= 0.1 and 440.0 <= lo < hi <= 450.0
    assert abs(result.jump_onset_rpm - expected) <= 0.1


def test_refine_not_possible_when_lowest_speed_jumps():
    result = run_sweep(BARKAN, ["cam.speed=460:470:10rpm"], workers=1, refine_jump=True, **FAST)
    assert result.jump_onset_rpm is None and result.first_jump_rpm == pytest.approx(460.0)
    assert "below the swept range" in result.notes[0]


# ------------------------------------------------------------------------- failures, Ctrl-C
def test_failing_variant_is_recorded_and_the_sweep_goes_on():
    result = run_sweep(BARKAN, [], ["mass.F.mass=0.5,-1,0.6kg"], workers=1, **FAST)
    status = [r["status"] for r in result.rows]
    assert status[0] == "ok" and status[2] == "ok"
    # the loader's one-line message, naming file and key
    assert status[1].startswith("MachineFileError: ") and "barkan-follower.toml: mass[0].mass: must be greater than 0" in status[1]
    assert "\n" not in status[1]
    assert math.isnan(result.rows[1]["peak_displacement:F"])
    assert result.rows[1]["param:mass.F.mass"] == -1.0  # the value, from its text
    assert result.failed == [1]


def test_ctrl_c_keeps_finished_rows(monkeypatch):
    import camsim.analyses.sweep.runner as sweep

    calls = []
    real = sweep.run_variant

    def interrupted_on_third(*args):
        calls.append(args)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(*args)

    monkeypatch.setattr(sweep, "run_variant", interrupted_on_third)
    result = run_sweep(BARKAN, ["cam.speed=400:440:10rpm"], workers=1, **FAST)
    assert result.interrupted
    assert [r["status"] for r in result.rows] == ["ok", "ok", "cancelled", "cancelled", "cancelled"]
    assert result.rows[3]["param:cam.speed"] == pytest.approx(430 * RPM, rel=1e-12)
    assert math.isnan(result.rows[3]["peak_velocity:F"])


def test_ctrl_c_in_process_pool_stops_the_workers():
    seen = []

    def progress(done, total):
        seen.append(done)
        if done == 1:
            raise KeyboardInterrupt

    result = run_sweep(BARKAN, ["cam.speed=400:600:10rpm"], workers=2, progress=progress, **FAST)
    assert result.interrupted
    status = [r["status"] for r in result.rows]
    assert status.count("ok") >= 1 and status.count("cancelled") >= 10


# ------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"vary": ["cam.sped=400:500:50rpm"]}, MachineFileError, "cam.sped: unknown key; did you mean 'cam.speed'"),
        ({"vary": ["cam.speed=400:500:50kg"]}, MachineFileError, r"cam.speed: expected \[angle\]/\[time\].*--vary/--values"),
        ({"values": ["mass.F.mass=0.5kg,-1kg"]}, MachineFileError, "mass.F.mass"),  # last variant checked too
        ({"vary": ["cam.speed=1:2000:1rpm"], "max_variants": 1000}, InputError, "2000 variants exceed --max-variants 1000"),
        ({"vary": ["cam.speed=400:500:50rpm"], "scheduler": "tcp://127.0.0.1:1", "dask_local": 2}, InputError, "not both"),
        ({"vary": ["cam.speed=400:500:50rpm", "mass.F.mass=1:2:1kg"], "refine_jump": True}, InputError, "cam.speed alone"),
        ({}, InputError, "give at least one"),
    ],
)
def test_bad_input_raises_before_running(kwargs, error, message):
    with pytest.raises(error, match=message):
        run_sweep(BARKAN, workers=1, **kwargs)


def test_missing_dask_is_a_clear_error(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_distributed(name, *args, **kw):
        if name == "distributed" or name.startswith("distributed."):
            raise ImportError("No module named 'distributed'")
        return real_import(name, *args, **kw)

    monkeypatch.setattr(builtins, "__import__", no_distributed)
    with pytest.raises(InputError, match=r"pip install 'camsim\[dask\]'"):
        run_sweep(BARKAN, ["cam.speed=400:500:50rpm"], dask_local=1)


# ------------------------------------------------------------------------- files
@pytest.mark.slow  # the default pytest's 3 minutes: CI runs it
def test_hdf5_and_csv_agree_and_keep_traces(tmp_path):
    result = run_sweep(BARKAN, ["cam.speed=440:460:20rpm"], workers=1, keep_traces=True, refine_jump=True, **FAST)
    h5, csvp = write_sweep(result, tmp_path / "s.h5")
    assert csvp == csv_path_for(h5) == tmp_path / "s.csv"
    with h5py.File(h5) as f:
        assert f.attrs["file_kind"] == "sweep"
        ds = f["sweep/summary"]
        table = read_table(ds)
        assert ds.attrs["units:param:cam.speed"] == "rad/s" and ds.attrs["units:peak_velocity:F"] == "m/s"
        assert ds.attrs["jump_onset_rpm"] == result.jump_onset_rpm
        assert ds.attrs["first_jump_rpm"] == pytest.approx(460.0)
        # traces of variant 1 in the run layout, equal to an individual run
        v = expected_row(BARKAN, ["cam.speed=460 rpm"], **FAST)
        # the row's peak is located on the solution (spec §4): never below the stored samples'
        assert np.max(np.abs(f["sweep/variants/1/masses/F/velocity"][()])) <= v["peak_velocity:F"]
        assert list(f["sweep/variants/1"].attrs["overrides"]) == ["cam.speed=460 rpm"]
    with open(csvp, newline="") as fh:
        lines = list(csv.reader(fh))
    assert [h.split(" [")[0] for h in lines[0]] == [name for name, _ in result.columns]
    assert len(lines) == 3
    units = dict(result.columns)
    for i, line in enumerate(lines[1:]):
        for header, cell in zip(lines[0], line):
            name = header.split(" [")[0]
            value = table[name][i]
            if name == "status":
                assert cell == value
            elif name == "jump":
                assert cell == ("true" if value else "false")
            elif name == "impacts":
                assert int(cell) == value
            else:  # in the header's display unit (issue 44), back in SI by pint
                import pint

                unit = header.split(" [")[1].rstrip("]").replace("²", "**2").replace("·", "*") if " [" in header else ""
                x = pint.UnitRegistry().Quantity(float(cell), unit).to(units[name].replace("^", "**")).magnitude \
                    if unit and units[name] else float(cell)
                assert (math.isnan(x) and math.isnan(value)) or math.isclose(x, value, rel_tol=1e-12), name


def test_machine_source_from_text_equals_file():
    """A sweep given the machine text (what a remote worker gets) runs the same machine."""
    source = MachineSource.from_path(BARKAN)
    a = run_sweep(source, [], ["cam.speed=420rpm"], workers=1, **FAST).rows
    b = run_sweep(BARKAN, [], ["cam.speed=420rpm"], workers=1, **FAST).rows
    assert_rows_identical(a, b)

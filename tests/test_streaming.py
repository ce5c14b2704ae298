"""Streamed runs (issue 16): traces written while the run proceeds, bounded memory,
recording options, a summary over every revolution.

References:
* the in-memory run (:func:`camsim.run.simulation.simulate` + :func:`camsim.run.runfile.write_run`),
  whose numbers the analytic and reference-solver tests check: a streamed file must hold
  the same values bit for bit (tolerance 0: ``array_equal`` of the raw bytes), and the
  streamed summary must equal the in-memory one exactly (NaN equal to NaN);
* the result layout of spec §7 for what ``--record`` selects;
* for memory: the kernel's peak resident set size of the child process
  (``resource.getrusage(RUSAGE_CHILDREN)``), which must not grow with revolutions.
"""

from __future__ import annotations

import json
import math
import os
import resource
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

import camsim.run.stream as stream
from camsim.cli import app
from camsim.run.runfile import write_run
from camsim.machine.loader import load_machine, load_machine_text
from camsim.run.simulation import simulate

ROOT = Path(__file__).resolve().parents[1]
MACHINES = ROOT / "machines"
CDTM = MACHINES / "cdtm.toml"
runner = CliRunner()

sys.path.insert(0, str(ROOT / "tests"))
from cli.test_run_cli import DRIVEN  # noqa: E402  - a cam force that turns negative (jump rows)
from test_engine_analytic import BOUNCE_TOML  # noqa: E402 - a bouncing ball (impacts, no cam)


def env() -> dict:
    e = dict(os.environ)
    e["PYTHONPATH"] = str(ROOT) + os.pathsep + e.get("PYTHONPATH", "")
    return e


def _same(a, b) -> bool:
    """Equal bit for bit (float arrays compared as raw bytes), or both NaN."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def _datasets(path: Path) -> dict[str, np.ndarray]:
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: out.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
    return out


def _machine(case: str):
    if case == "driven":
        return load_machine_text(DRIVEN, source="<driven>", base_dir=ROOT)
    if case == "bounce":
        return load_machine_text(BOUNCE_TOML, source="<bounce>", base_dir=ROOT)
    return load_machine(MACHINES / f"{case}.toml")


# CDTM: impacts and link separations whose peak windows span many pieces; driven: jump
# rows across pieces; bounce: no cam, repeated impacts; cdtm-power: power-law seat.
# Pieces of 97 samples, and of 1 sample (every window and crossing spans pieces) for the
# faster cases.
CASES = [
    ("cdtm", {"cycles": 2, "sample_rate": 4000.0}, False, 1),
    ("cdtm", {"cycles": 2, "sample_rate": 4000.0}, False, 97),
    ("cdtm", {"cycles": 1, "sample_rate": 20000.0}, True, 97),
    pytest.param("cdtm-power", {"cycles": 1, "sample_rate": 10000.0}, False, 97, marks=pytest.mark.slow),
    ("driven", {}, False, 1),
    ("driven", {}, False, 97),
    ("bounce", {}, False, 97),
]


@pytest.mark.parametrize(("case", "options", "no_impact", "flush"), CASES)
def test_streamed_file_and_summary_equal_the_in_memory_run(tmp_path, monkeypatch, case, options, no_impact, flush):
    """Every dataset of the streamed file equals the in-memory file's bit for bit, and the
    summary (scalars, peaks with their times, events with their annotation) is equal,
    whatever the piece size (1 sample: every impact window and jump spans pieces), written
    in HDF5 chunks of 1000 samples (whole chunks, then the rest at the end)."""
    from camsim.run import streamfile

    monkeypatch.setattr(stream, "FLUSH", flush)
    monkeypatch.setattr(streamfile, "CHUNK", 1000)
    machine = _machine(case)
    reference = simulate(machine, no_impact=no_impact, **options)
    write_run(reference, tmp_path / "memory.h5")
    streamed = stream.simulate_to_file(machine, tmp_path / "stream.h5", no_impact=no_impact, **options)
    want, got = _datasets(tmp_path / "memory.h5"), _datasets(tmp_path / "stream.h5")
    assert list(want) == list(got)
    for name in want:
        if want[name].dtype.names:  # the event table: column by column
            for col in want[name].dtype.names:
                assert list(want[name][col]) == list(got[name][col]) if want[name][col].dtype.kind == "O" else _same(want[name][col], got[name][col]), (name, col)
        else:
            assert _same(want[name], got[name]), name
    a, b = reference.scalars(), streamed.scalars()
    assert list(a) == list(b) and all(_same(a[k], b[k]) for k in a), {k: (a[k], b[k]) for k in a if not _same(a[k], b[k])}
    assert json.dumps(reference.summary(), sort_keys=True) == json.dumps(streamed.summary(), sort_keys=True)
    assert reference.warnings == streamed.warnings
    assert len(reference.impacts()) > 0 or no_impact or case == "driven"
    with h5py.File(tmp_path / "stream.h5") as f, h5py.File(tmp_path / "memory.h5") as g:
        assert f.attrs.keys() == g.attrs.keys() and all(_same(f.attrs[k], g.attrs[k]) for k in g.attrs)
        stored = {k: v for k, v in f["summary"].attrs.items()}
        assert stored.keys() == dict(g["summary"].attrs).keys()
        assert all(_same(float(stored[k]), float(a[k])) for k in a)


def _cli(tmp_path, *extra, out="r.h5"):
    target = tmp_path / out
    res = runner.invoke(app, ["run", str(CDTM), "-o", str(target), "--cycles", "3", "--sample-rate", "4kHz", "-q", "--json", *extra])
    return res, target


@pytest.fixture(scope="module")
def cdtm_reference():
    """The in-memory 3-revolution CDTM run at 4 kHz (what the CLI runs below stream)."""
    return simulate(load_machine(CDTM), cycles=3, sample_rate=4000.0)


def test_record_patterns_store_exactly_the_matching_traces(tmp_path, cdtm_reference):
    """--record stores time and the traces whose path matches a pattern (spec §7 paths),
    with the in-memory values; the summary still covers every trace."""
    res, out = _cli(tmp_path, "--record", "transducer/*,masses/M3/*", "--record", "elements/K*/force")
    assert res.exit_code == 0, res.output
    want = ["time", "masses/M3/displacement", "masses/M3/velocity", "masses/M3/acceleration",
            "elements/K01/force", "elements/K12/force", "elements/K23/force", "transducer/force"]
    with h5py.File(out) as f:
        traces = []
        f.visititems(lambda n, o: traces.append(n) if isinstance(o, h5py.Dataset) and "long_name" in o.attrs else None)
        assert sorted(traces) == sorted(want)
        assert json.loads(f["summary"].attrs["recorded"]) == want
        for path in want:
            assert _same(f[path][()], cdtm_reference.trace(path)), path
        assert "events" in f and "cam" not in f
    payload = json.loads(res.stdout)
    ref = cdtm_reference.summary()
    assert payload["masses"] == ref["masses"]  # M1 and M2 peaks too, though not stored
    assert payload["max_cam_contact_force"] == ref["max_cam_contact_force"]


def test_record_last_keeps_the_last_revolutions_summary_covers_all(tmp_path, cdtm_reference):
    """--record-last 1 of 3 revolutions: the stored time is [1.0, 1.5] s (CDTM: 0.5 s per
    revolution at 120 rpm), each trace the in-memory trace on it; the summary and event
    table are those of all three revolutions."""
    res, out = _cli(tmp_path, "--record-last", "1")
    assert res.exit_code == 0, res.output
    keep = cdtm_reference.time >= 1.0
    assert keep.sum() == 0.5 * 4000 + 1
    with h5py.File(out) as f:
        assert f["time"][0] == 1.0 and f["time"][-1] == 1.5
        for path, trace in cdtm_reference.traces().items():
            assert _same(f[path][()], trace.data[keep]), path
        assert len(f["events"]) == len(cdtm_reference.events)
        assert f["summary"].attrs["record_last"] == 1
    payload = json.loads(res.stdout)
    assert json.dumps(payload["masses"]) == json.dumps(cdtm_reference.summary()["masses"])
    assert len(payload["impacts"]) == len(cdtm_reference.impacts()) > 2


def test_summary_only_stores_events_and_summary(tmp_path, cdtm_reference):
    """--summary-only: no trace at all; the event table, the located extremes and /summary
    equal the in-memory run's."""
    res, out = _cli(tmp_path, "--summary-only")
    assert res.exit_code == 0, res.output
    with h5py.File(out) as f:
        datasets = []
        f.visititems(lambda n, o: datasets.append(n) if isinstance(o, h5py.Dataset) else None)
        assert datasets == ["events", "extremes"]
        assert json.loads(f["summary"].attrs["recorded"]) == []
        table = f["extremes"][()]
        for row in table:
            located = cdtm_reference.located[row["quantity"].decode()]
            assert (row["max"], row["max_time"], row["min"], row["min_time"]) == (
                located["max"].value, located["max"].time, located["min"].value, located["min"].time)
        times = f["events"]["time"]
        assert _same(times, np.array([e.time for e in cdtm_reference.events]))
        peaks = np.array([e.peak_force for e in cdtm_reference.events])
        assert _same(f["events"]["peak_force"], peaks)
        for key, value in cdtm_reference.scalars().items():
            assert _same(float(f["summary"].attrs[key]), float(value)), key
    from camsim import ResultFileError, open_result

    with pytest.raises(ResultFileError, match="holds only some traces \\(none; recorded with --record or --summary-only\\)"):
        open_result(out)


def test_compress_stores_the_same_values_gzipped(tmp_path, cdtm_reference):
    res, out = _cli(tmp_path, "--compress", "--record", "masses/*")
    assert res.exit_code == 0, res.output
    with h5py.File(out) as f:
        assert f["masses/M3/acceleration"].compression == "gzip"
        assert f["masses/M3/acceleration"].maxshape == (None,)
        assert _same(f["masses/M3/acceleration"][()], cdtm_reference.trace("masses/M3/acceleration"))


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--record", "bogus/*"], "--record bogus/*: matches no trace; this run has time, cam/angle"),
        (["--summary-only", "--record", "time"], "--summary-only: stores no traces"),
        (["--summary-only", "--record-last", "1"], "--summary-only: stores no traces"),
    ],
)
def test_bad_recording_options_exit_2_one_line_nothing_written(tmp_path, args, message):
    res, out = _cli(tmp_path, *args)
    assert res.exit_code == 2
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "Traceback" not in res.output
    assert list(tmp_path.iterdir()) == []


def test_record_last_needs_a_cam(tmp_path):
    path = tmp_path / "bounce.toml"
    path.write_text(BOUNCE_TOML)
    res = runner.invoke(app, ["run", str(path), "-o", str(tmp_path / "b.h5"), "--record-last", "2"])
    assert res.exit_code == 2 and "--record-last 2: needs a cam" in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bounce.toml"]


def test_size_guard_counts_what_is_stored(tmp_path):
    """The estimate follows the recording options (closed form: samples = T·rate + 1, 8
    bytes each per stored trace; CDTM 100000 revolutions = 5e4 s at 50 kHz); the message
    names the options that reduce it."""
    base = ["run", str(CDTM), "-o", str(tmp_path / "r.h5"), "--set", "simulation.cycles=100000"]
    res = runner.invoke(app, base)
    assert res.exit_code == 2
    for option in ("--record PATTERN", "--record-last N", "--summary-only", "--cycles", "--sample-rate", "--yes"):
        assert option in res.output
    samples = 100000 * 0.5 * 50e3 + 1
    assert f"{samples:.3g} samples x 21 traces" in res.output
    res = runner.invoke(app, base + ["--record", "transducer/*"])
    assert res.exit_code == 2 and f"{samples:.3g} samples x 2 traces" in res.output
    # the last 10 of 100000 revolutions: 10 x 0.5 s x 50 kHz + 1 samples x 21 traces = 42 MB, under 2 GB
    from camsim.run.budget import estimate_run, record_fraction

    machine = load_machine(CDTM, overrides=["simulation.cycles=100000"])
    est = estimate_run(machine, traces=21, record_fraction=record_fraction(machine, 10))
    assert est.samples == 10 * 0.5 * 50e3 + 1 and est.bytes < 2e9
    assert estimate_run(machine, traces=0).bytes == 0  # --summary-only


def test_interrupt_while_streaming_leaves_previous_result_and_no_temp(tmp_path, monkeypatch):
    """SIGTERM (as Ctrl-C) arriving in the middle of the stream: exit 130, the previous
    result untouched, the temporary file removed."""
    import signal
    import time

    from camsim.run.streamfile import TraceStreamWriter

    monkeypatch.setattr(stream, "FLUSH", 500)
    res, out = _cli(tmp_path)
    assert res.exit_code == 0
    previous = out.read_bytes()
    original = TraceStreamWriter.append
    calls = []

    def interrupted(self, traces):
        original(self, traces)
        calls.append(1)
        if len(calls) == 3:  # a few pieces are in the temporary file (beside it: r.h5 and its lock)
            assert sorted(p.name for p in tmp_path.iterdir() if not p.name.endswith(".tmp")) == [".r.h5.lock", "r.h5"]
            assert len(list(tmp_path.iterdir())) == 3
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1.0)

    monkeypatch.setattr(TraceStreamWriter, "append", interrupted)
    res, _ = _cli(tmp_path)
    assert res.exit_code == 130
    assert [p.name for p in tmp_path.iterdir()] == ["r.h5"] and out.read_bytes() == previous


def test_streamed_run_reads_back(tmp_path):
    """The streamed file opens as a RunResult (camsim.open_result) with the streamed values."""
    machine = load_machine(CDTM)
    streamed = stream.simulate_to_file(machine, tmp_path / "s.h5", cycles=1, sample_rate=2000.0)
    back = streamed.open()
    reference = simulate(machine, cycles=1, sample_rate=2000.0)
    assert _same(back.trace("transducer/force"), reference.trace("transducer/force"))
    assert back.scalars()["impacts"] == streamed.scalars()["impacts"] == reference.scalars()["impacts"]


# --------------------------------------------------------------------------------------
# memory
# --------------------------------------------------------------------------------------
def _peak_rss_mb(args: list[str]) -> float:
    """Peak resident set size [MB] of ``camsim <args>`` run in a fresh process."""
    probe = (
        "import resource, subprocess, sys\n"
        "subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)\n"
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
    )
    out = subprocess.run([sys.executable, "-c", probe, sys.executable, "-m", "camsim", *args],
                         env=env(), check=True, capture_output=True, text=True)
    return int(out.stdout.strip()) / 1024.0  # Linux: kB


@pytest.mark.full
def test_peak_memory_does_not_grow_with_revolutions(tmp_path):
    """CDTM at 10 kHz: 50 and 500 revolutions (25 s and 250 s simulated; the traces of
    500 would take 2.5e6 samples x 21 traces x 8 B = 420 MB in memory). The peak RSS of
    the 500-revolution run stays within 25 MB of the 50-revolution run (the event list,
    ~20 events per revolution, is all that grows) and under 300 MB."""
    rss = {}
    for n in (50, 500):
        rss[n] = _peak_rss_mb(["run", str(CDTM), "-o", str(tmp_path / f"r{n}.h5"), "--cycles", str(n), "--sample-rate", "10kHz", "-q"])
    with h5py.File(tmp_path / "r500.h5") as f:
        assert f["time"].shape == (500 * 0.5 * 10000 + 1,)
    assert rss[500] < rss[50] + 25.0, rss
    assert rss[500] < 300.0, rss


@pytest.mark.parametrize("t0", [0.0, 1000.0, 5000.0])
def test_grid_steps_stay_on_the_cached_map_late_in_a_long_run(monkeypatch, t0):
    """Cost linear in revolutions: 400 grid steps (h = 50 µs, no event) starting at t0 use
    the cached step map, never the exact map of an odd-length step, whatever t0. Beyond
    t ≈ 500 s the rounding of t made every few steps 'odd' (44 of 400 at t0 = 1000 s,
    and the CDTM run 7x slower after 1000 revolutions). Reference: the count is 0 at t0 = 0."""
    import camsim.engine.integrator as integrate
    from camsim.cam.program import CamProgram
    from camsim.model.assembly import Model
    from camsim.run.simulation import initial_state

    machine = load_machine(CDTM)
    model = Model(machine)
    integrator = integrate.Integrator(model, CamProgram(machine.cam), 5e-5, t_ref=0.0)
    state = initial_state(model, integrator, t0)
    calls = []
    import camsim.engine.linear as linear  # the linear stepper calls exact_partial for partial steps

    original = linear.exact_partial
    monkeypatch.setattr(linear, "exact_partial", lambda *a, **k: calls.append(1) or original(*a, **k))
    _, stretches = integrator.run(state, t0 + 0.02, record_from=t0)
    assert integrator.events == [] and sum(int(s.samples.sum()) for s in stretches) == 400  # the end node is no sample
    assert calls == []


def test_human_summary_lists_at_most_40_impacts(tmp_path):
    """A long run has thousands of impacts: the table on stderr shows the first 40 and
    says how many more the file's /events table holds (all of them)."""
    out = tmp_path / "r.h5"
    res = runner.invoke(app, ["run", str(CDTM), "-o", str(out), "--cycles", "12", "--sample-rate", "2kHz", "-q"])
    assert res.exit_code == 0, res.output
    with h5py.File(out) as f:
        kinds = [k.decode() if isinstance(k, bytes) else k for k in f["events"]["kind"]]
    n = sum(k in ("impact", "rejoin") for k in kinds)
    assert n > 40
    assert f"impacts (the first 40 of {n})" in res.output
    assert f"... {n - 40} more impacts: all are in the file's /events table" in res.output


@pytest.mark.parametrize("flush", [700, 65536])
def test_streamed_cam_design_summary_equals_the_in_memory_one(tmp_path, monkeypatch, flush):
    """With [cam.geometry] the design quantities of a streamed run (folded piece by piece,
    pieces of `flush` samples) equal those computed from the whole in-memory run: peaks and
    their times exactly, RMS torque and the energy fluctuation to 1e-12 relative; and the
    (N, 2) shape traces stream like the others."""
    from camsim import load_machine, open_result, simulate
    from camsim.run.stream import simulate_to_file

    machine = load_machine(ROOT / "machines" / "cdtm-geometry.toml")
    memory = simulate(machine, sample_rate=5000.0, cycles=2)
    monkeypatch.setattr(stream, "FLUSH", flush)
    streamed = simulate_to_file(machine, tmp_path / "g.h5", sample_rate=5000.0, cycles=2)
    a, b = memory.design_summary(0.05), streamed.design_summary(0.05)
    for key in ("peak_normal_force", "peak_hertz_stress", "peak_hertz_stress_time", "peak_torque", "peak_torque_time",
                "max_pressure_angle", "min_surface_radius"):
        assert a[key] == b[key], key
    for key in ("rms_torque", "energy_fluctuation", "flywheel_inertia", "cycle_work"):
        assert b[key] == pytest.approx(a[key], rel=1e-12, abs=1e-12 * abs(a["peak_torque"])), key
    back = open_result(tmp_path / "g.h5")
    assert np.array_equal(back.trace("camshaft/torque"), memory.trace("camshaft/torque"))
    assert np.array_equal(back.trace("cam/pitch_curve"), memory.trace("cam/pitch_curve"))

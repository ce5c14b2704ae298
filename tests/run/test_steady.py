"""The periodic steady state by shooting (issue 42 item 5, camsim.run.steady).

References:
- the revolution map's derivative (camsim.engine.monodromy) against central finite differences
  of the map itself, F(y ± ε·e_j), on a machine with 49 events a revolution (every saltation
  counts): 1e-5 of the matrix's norm (the differences' own truncation and rounding);
- the steady state against the recorded run: a run of two recorded revolutions from the shot
  state repeats itself, its samples one revolution apart equal to 1e-12 of each quantity's
  peak (the recording integrates the map again, with its own chunks and extremes);
- against warm-up: thirty warm-up revolutions of the same machine (residual 5e-13) give the
  same located scalars to 1e-9 relative (slow tier);
- where shooting does not apply, the run is the warm-up run to the bit and says why.
"""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from camsim.engine.integrator import Integrator
from camsim.engine.monodromy import Monodromy
from camsim.machine.loader import load_machine
from camsim.model.assembly import Model
from camsim.run.simulation import simulate

ROOT = Path(__file__).resolve().parents[2]
CDTM = ROOT / "machines" / "cdtm.toml"


def light_cdtm(tmp_path: Path) -> Path:
    """The CDTM with 0.2 % of critical damping instead of 6 %: its start transient outlives
    tens of revolutions, and its over-travel link chatters (49 events a revolution)."""
    text = CDTM.read_text()
    assert text.count("damping_ratio = 0.06") >= 4
    path = tmp_path / "cdtm-light.toml"
    path.write_text(text.replace("damping_ratio = 0.06", "damping_ratio = 0.002"))
    return path


def with_steady(machine, mode: str, **sim):
    return dataclasses.replace(machine, simulation=dataclasses.replace(machine.simulation, steady_state=mode, **sim))


def assert_same_scalars(got: dict, ref: dict, rel: float, abs_: float) -> None:
    """Every finite float scalar of ``ref`` (the periodicity residual aside: it is what the
    runs differ in) equals ``got``'s to ``rel`` relative, ``abs_`` absolute."""
    for key, value in ref.items():
        if key == "periodicity_residual" or not isinstance(value, float) or not math.isfinite(value):
            continue
        assert got[key] == pytest.approx(value, rel=rel, abs=abs_), key


def test_the_monodromy_matrix_is_the_derivative_of_the_revolution_map(tmp_path):
    """M = ∂F/∂y against central differences, ε = 1e-7 of each coordinate's scale."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):  # as simulate() runs the engine
        _check_monodromy(tmp_path)


def _check_monodromy(tmp_path):
    from camsim.cam.camshaft import cam_input
    from camsim.loads.inputs import engine_input
    from camsim.run.initial import initial_state
    from camsim.run.simulation import cam_input_step, highest_frequency, warmup_step

    machine = load_machine(light_cdtm(tmp_path))
    model = Model(machine)
    cam = cam_input(machine, None)
    period = cam.period
    # the warm-up grid a run shoots on (camsim.run.simulation.warmup_step)
    step = min(warmup_step(machine, highest_frequency(model), 2e-5), cam_input_step(machine))
    engine = Integrator(model, engine_input(cam, []), step, t_ref=0.0)
    start = initial_state(model, engine, 0.0)
    n = model.n

    def revolution(y, mono=None):
        state = dataclasses.replace(start, x=y[:n].copy(), v=y[n:].copy())
        engine.events.clear()
        end, _ = engine.run(state, period, record_from=math.inf,
                            on_advance=mono.after_stretch if mono is not None else None)
        return np.concatenate([end.x, end.v]), len(engine.events)

    # a state near the steady one: two revolutions on
    y = np.concatenate([start.x, start.v])
    for _ in range(2):
        y, _ = revolution(y)
    mono = Monodromy(engine)
    _, events = revolution(y, mono)
    assert mono.declined is None and mono.events >= 20  # the saltations are exercised
    scale = np.maximum(mono.scale, 1e-12)
    fd = np.empty((2 * n, 2 * n))
    for j in range(2 * n):
        eps = 1e-7 * scale[j]
        e = np.zeros(2 * n)
        e[j] = eps
        plus, n_plus = revolution(y + e)
        minus, n_minus = revolution(y - e)
        assert n_plus == n_minus == events  # the same event sequence: F is smooth there
        fd[:, j] = (plus - minus) / (2 * eps)
    # compare in the scaled coordinates (positions against velocities)
    M = mono.matrix * scale[None, :] / scale[:, None]
    D = fd * scale[None, :] / scale[:, None]
    assert np.max(np.abs(M - D)) <= 1e-5 * max(np.max(np.abs(D)), 1e-3)


def test_shooting_reaches_a_state_the_recorded_revolution_repeats(tmp_path):
    """The periodicity residual is measured on the first recorded revolution (its end against
    its start); the traces one revolution apart agree to 1e-12 of each peak."""
    machine = with_steady(load_machine(light_cdtm(tmp_path)), "shooting")
    result = simulate(machine, cycles=2, sample_rate=50e3)
    assert result.steady_state == {"method": "shooting", "revolutions": result.steady_state["revolutions"]}
    assert 2 <= result.steady_state["revolutions"] <= 8
    assert result.periodicity_residual <= 1e-12
    assert not [w for w in result.warnings if "steady_state" in w]
    one = 25_000  # samples a revolution at 50 kHz (0.5 s)
    assert result.time[one] - result.time[0] == pytest.approx(0.5, abs=1e-12)
    for name in ("M2", "M3"):
        for quantity in ("displacement", "velocity"):
            trace = result.masses[name][quantity]
            assert abs(trace[one] - trace[0]) <= 1e-12 * np.max(np.abs(trace)), (name, quantity)


def test_warm_up_leaves_the_lightly_damped_machine_far_from_its_steady_state(tmp_path):
    """What shooting is for: one warm-up revolution leaves a residual of 5e-2 here."""
    result = simulate(load_machine(light_cdtm(tmp_path)), sample_rate=2.0)
    assert result.periodicity_residual > 1e-2
    assert result.steady_state == {"method": "warmup", "revolutions": 1}


@pytest.mark.slow
def test_shooting_gives_the_scalars_of_thirty_warm_up_revolutions(tmp_path):
    """Reference: 30 warm-up revolutions (periodicity residual 5e-13); 1e-9 relative."""
    machine = load_machine(light_cdtm(tmp_path))
    shot = simulate(with_steady(machine, "shooting"), sample_rate=2.0).scalars()
    warm = simulate(with_steady(machine, "warmup", warmup_cycles=30), sample_rate=2.0)
    assert warm.periodicity_residual < 1e-11
    ref = warm.scalars()
    assert_same_scalars(shot, ref, rel=1e-9, abs_=1e-12)


def test_shooting_on_the_cdtm_takes_the_one_revolution_a_warm_up_takes():
    """The CDTM forgets its start within a revolution (its monodromy's norm is ~1e-16): after
    one revolution the contraction bound says F(y) is the steady state, so shooting costs
    what the warm-up costs; its recorded revolution repeats itself to rounding (the residual
    measured on it, 1e-14 at most, where the warm-up's residual of 1e-4 measures the static
    start), and its located scalars are the warm-up run's to 1e-12 relative."""
    machine = load_machine(CDTM)
    shot = simulate(with_steady(machine, "shooting"), sample_rate=2.0)
    warm = simulate(machine, sample_rate=2.0)
    assert shot.steady_state == {"method": "shooting", "revolutions": 1}
    assert shot.periodicity_residual <= 1e-14 < 1e-5 < warm.periodicity_residual
    a, b = shot.scalars(), warm.scalars()
    assert_same_scalars(a, b, rel=1e-12, abs_=1e-15)


@pytest.mark.parametrize("name, why", [
    ("barkan-follower", "element roller is a rigid contact"),
    pytest.param("cdtm-power", "element seat has a nonlinear law", marks=pytest.mark.slow),
    ("press-station", "is a friction pair"),
    ("ball-drop", "the machine has no cam"),
])
def test_where_shooting_does_not_apply_the_run_warms_up_and_says_why(name, why):
    machine = load_machine(ROOT / "machines" / f"{name}.toml")
    shot = simulate(with_steady(machine, "shooting"), sample_rate=2.0)
    warm = simulate(machine, sample_rate=2.0)
    said = [w for w in shot.warnings if w.startswith('steady_state = "shooting"')]
    assert len(said) == 1 and why in said[0] and "warmed up" in said[0]
    a, b = shot.scalars(), warm.scalars()
    assert [k for k in a if not (a[k] == b[k] or (a[k] != a[k] and b[k] != b[k]))] == []  # to the bit
    if machine.cam is not None:
        assert shot.steady_state == {"method": "warmup", "revolutions": machine.simulation.warmup_cycles}


def test_a_load_in_time_is_not_periodic(tmp_path):
    text = CDTM.read_text() + '\n[[load]]\nname = "shake"\non = "M3"\nsine = { amplitude = "1 N", frequency = "7 Hz" }\n'
    path = tmp_path / "shaken.toml"
    path.write_text(text)
    result = simulate(with_steady(load_machine(path), "shooting"), sample_rate=2.0)
    assert any("load shake is a function of time" in w for w in result.warnings)
    assert result.steady_state["method"] == "warmup"


def test_an_unknown_steady_state_is_one_line_exit_2(tmp_path):
    out = tmp_path / "run.h5"
    proc = subprocess.run([sys.executable, "-m", "camsim", "run", str(CDTM), "--set", "simulation.steady_state=newton",
                           "-o", str(out)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "simulation.steady_state" in proc.stderr and "warmup, shooting" in proc.stderr
    assert not out.exists()


def test_the_run_file_says_how_the_steady_state_was_reached(tmp_path):
    import h5py

    from camsim.run.runfile import write_run

    result = simulate(with_steady(load_machine(CDTM), "shooting"), sample_rate=2.0)
    write_run(result, tmp_path / "run.h5")
    with h5py.File(tmp_path / "run.h5") as f:
        assert f.attrs["steady_state"] == "shooting"
        assert f.attrs["steady_state_revolutions"] == 1


def test_validate_says_how_the_steady_state_is_reached():
    proc = subprocess.run([sys.executable, "-m", "camsim", "validate", str(CDTM), "--set",
                           "simulation.steady_state=shooting"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    line = [x for x in (proc.stdout + proc.stderr).splitlines() if x.startswith("simulation:")]
    assert line and "steady state by shooting (1 warm-up cycle(s) where it does not apply)" in line[0]


def test_the_shot_steady_state_is_the_same_at_any_sample_rate(tmp_path):
    """Invariant (spec §4): the located scalars of a shot run are the same at 10 and 50 kHz,
    to 1e-9 relative (the events to 1e-9 s), as a warmed-up run's are."""
    machine = with_steady(load_machine(light_cdtm(tmp_path)), "shooting")
    a = simulate(machine, sample_rate=1e4)
    b = simulate(machine, sample_rate=5e4)
    assert a.steady_state["method"] == b.steady_state["method"] == "shooting"
    assert [e.kind for e in a.events] == [e.kind for e in b.events]
    assert max(abs(x.time - y.time) for x, y in zip(a.events, b.events)) <= 1e-9
    sa, sb = a.scalars(), b.scalars()
    assert_same_scalars(sa, sb, rel=1e-9, abs_=1e-12)


def test_a_recorded_revolution_that_does_not_repeat_itself_is_said(tmp_path, monkeypatch):
    """The recorded revolution's residual is checked against the shooting's claim: above
    SHOT_RESIDUAL_CHECK a warning says so (here the check is set below the 8e-14 this machine
    reaches, so that it fires)."""
    import camsim.run.simulation as simulation

    monkeypatch.setattr(simulation, "SHOT_RESIDUAL_CHECK", 1e-16)
    result = simulate(with_steady(load_machine(light_cdtm(tmp_path)), "shooting"), sample_rate=2e3)
    assert result.periodicity_residual > 1e-16
    said = [w for w in result.warnings if "repeats itself only to" in w]
    assert len(said) == 1 and f"{result.periodicity_residual:.3g}" in said[0]


def test_camsim_run_prints_how_the_steady_state_was_reached(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "camsim", "run", str(CDTM), "--set", "simulation.steady_state=shooting",
                           "--set", "simulation.sample_rate=2 kHz", "-o", str(tmp_path / "run.h5")],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    line = [x for x in (proc.stdout + proc.stderr).splitlines() if x.startswith("periodicity residual")]
    assert line and line[0].endswith("(steady state by shooting, 1 revolution)")

"""Physical bounds of a run (issue 34): a state far outside them stops the run (exit 1).

References: the guard must fire on machines that really diverge (a negative damping, whose
growth e^(|ζ|·ω·t) is a closed form; the issue-34 blow-up of the compensated CDTM when the
old derivative recursion is forced) and never on the shipped machines (their peaks against
the limit: a margin of at least BOUND_FACTOR).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from camsim.cli import app
from camsim.engine.integrator import Integrator
from camsim.errors import SimulationError
from camsim.machine.loader import load_machine
from camsim.model.assembly import Model
from camsim.run.bounds import BOUND_FACTOR, physical_bounds
from camsim.run.initial import initial_state
from camsim.run.simulation import simulate

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from cli.test_run_cli import OSCILLATOR as _OSC  # noqa: E402 - one mass on a spring to the cam

# The base-excited oscillator of the CLI tests, damped at ζ = 0.5 (negated below), two revolutions.
OSCILLATOR = _OSC.replace("damping_ratio = 0.05", "damping_ratio = 0.5").replace("cycles = 1\n", "cycles = 2\n")


def _bounds(machine):
    from camsim.cam.camshaft import cam_input

    from camsim.loads.inputs import engine_input
    from camsim.loads.programs import load_programs

    model = Model(machine)
    cam = cam_input(machine, None)  # one cam: its program; [[cam]] tables: every cam's (as the run)
    sim = machine.simulation
    t_rec = sim.warmup_cycles * cam.period if machine.cam is not None else 0.0
    inputs = engine_input(cam, load_programs(machine, t_rec))  # the loads' channels after the cams' (as the run)
    state = initial_state(model, Integrator(model, inputs, 1e-4, t_ref=t_rec), 0.0)
    t_end = (sim.warmup_cycles + sim.cycles) * cam.period if machine.cam is not None else sim.duration
    return physical_bounds(model, cam, state, t_end)


def test_negative_damping_stops_with_exit_1_naming_the_element(tmp_path, monkeypatch):
    """An injected unstable machine: the spring's damping made negative (ζ = −0.5, the loader
    refuses it, so the law is patched). The free motion then grows as e^(0.5·ω·t), ω = 100
    rad/s: 10 mm of lift become e^20 ≈ 5e8 times larger over the 0.4 s run, far beyond the
    limit (100 × 3 × the machine's length scale, a few metres). Exit 1, one line naming the
    mass and element.k.damping_ratio, nothing written."""
    from camsim.elements.spring import Spring

    law = Spring.linear_law
    monkeypatch.setattr(Spring, "linear_law", lambda self, branch, damping: (lambda k, c, p: (k, -c, p))(*law(self, branch, damping)))
    path = tmp_path / "osc.toml"
    path.write_text(OSCILLATOR)
    out = tmp_path / "o.h5"
    result = CliRunner().invoke(app, ["run", str(path), "-o", str(out)])
    assert result.exit_code == 1, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1, result.output
    assert "diverged" in lines[0] and " m reached " in lines[0] and "element.k.damping_ratio" in lines[0]
    assert not out.exists()


def test_the_issue_34_blowup_is_stopped(monkeypatch):
    """The compensated CDTM with K23 at ζ = 6e-8, its cam computed by the old derivative
    recursion (forced): the cam table swings by metres and M3 ran to 5.4e5 mm with exit 0.
    With the bounds the run stops within the first revolution, naming M3 and
    element.K23.damping_ratio (the least damped element on it)."""
    import camsim.machine.compensation as comp

    monkeypatch.setattr(comp, "_expansion_plan", lambda laws, lift, omega: ([0] * len(laws), 0))
    machine = load_machine(ROOT / "machines" / "cdtm-compensated.toml",
                           ["element.K23.damping_ratio=6e-08", "simulation.sample_rate=5 kHz"])
    with pytest.raises(SimulationError) as info:
        simulate(machine)
    text = str(info.value)
    assert "M3 reached" in text and "element.K23.damping_ratio" in text


def _shipped():
    out = []
    for path in sorted((ROOT / "machines").glob("*.toml")):
        try:
            load_machine(path)
        except Exception:  # noqa: BLE001 - a parts file (lump input), not a machine
            continue
        # the dynamic camshaft (13.5 s) and the rod (10.7 s): before a release (.ci/run's 15 minutes)
        heavy = path.stem in ("camshaft-line-dynamic", "cdtm-rod")
        out.append(pytest.param(path, marks=pytest.mark.full) if heavy else path)
    return out


@pytest.mark.parametrize("path", [ROOT / "machines" / "cdtm.toml", ROOT / "machines" / "ball-drop.toml"], ids=lambda p: p.stem)
def test_shipped_machines_stay_far_inside_the_bounds(path):
    """The guard never fires on a legitimate machine: every free mass's peak displacement of
    a run (its summary) stays below the limit by BOUND_FACTOR or more."""
    machine = load_machine(path, ["simulation.sample_rate=5 kHz"] if path.stem != "ball-drop" else [])
    res = simulate(machine)
    peak = max(float(np.max(np.abs(res.trace(f"masses/{m}/displacement")))) for m in Model(machine).free_names)
    assert BOUND_FACTOR * peak <= _bounds(machine).limit


@pytest.mark.slow
@pytest.mark.parametrize("path", _shipped(), ids=lambda p: p.stem)
def test_every_shipped_machine_stays_far_inside_the_bounds(path):
    """As above, for every shipped machine (their own sample rates)."""
    machine = load_machine(path)
    res = simulate(machine)
    names = Model(machine).free_names
    if not names:
        return
    peak = max(float(np.max(np.abs(res.trace(f"masses/{m}/displacement")))) for m in names)
    assert BOUND_FACTOR * peak <= _bounds(machine).limit

"""A nearly plastic Hunt–Crossley contact resting closed (issue 34): it finishes, and the
implicit route it takes agrees with the explicit one.

`camsim run machines/cdtm-power.toml --set element.seat.restitution=8e-07` gave no answer
in 300 s: with α(e) ≈ 1/e = 1.25e6 the seat's tangent damping c = F·α/v reaches 1e7 N·s/m
while M3 rests on it (a creep with a time constant m/c ~ 1e-9 s); every collocation step
was rejected and DOP853 crossed the 100 ms rest in steps of ~1e-9 s. Such a span now goes
to scipy's Radau (camsim.engine.bounce._stiff_solver).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from camsim.machine.loader import load_machine
from camsim.run.simulation import simulate

POWER = Path(__file__).resolve().parents[1] / "machines" / "cdtm-power.toml"
LIFT = 0.63648 * 0.5 * 25.4e-3  # model axis [m]


@pytest.mark.slow  # the default pytest's 3 minutes: CI runs it
def test_nearly_plastic_seat_finishes():
    """e = 8e-7: the run ends (it did not in 300 s), and the seat holds M3 as a nearly
    plastic stop: an isolated impact would rebound at e·v ≈ 1.3e-7 m/s, so after each seat
    impact M3 rests on the seat (the seat's next event comes more than 10 ms later, when
    the link lifts M3 off) instead of bouncing."""
    machine = load_machine(POWER, ["element.seat.restitution=8e-07"])
    res = simulate(machine)
    seat = [ev for ev in res.events if ev.element == "seat"]
    impacts = [k for k, ev in enumerate(seat) if ev.kind == "impact" and ev.relative_velocity > 1e-3]
    assert len(impacts) >= 2, "the seat is hit once a revolution"
    for k in impacts:
        if k + 1 < len(seat):
            assert seat[k + 1].time - seat[k].time > 10e-3


@pytest.mark.full
def test_stiff_route_agrees_with_dop853():
    """Reference: the same run with the Radau route switched off (DOP853 throughout, the
    route every contact took before; 24 s against 4 s) at e = 1e-5, where both finish.
    Displacements agree to 1e-10 of the lift (measured 5.4e-12), M3's velocity to 1e-7 of
    its peak (1.1e-8)."""
    import camsim.engine.bounce as bounce

    machine = load_machine(POWER, ["element.seat.restitution=1e-05"])
    stiff = simulate(machine)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(bounce, "STIFF_GAIN", float("inf"))
        explicit = simulate(machine)
    for name in ("M2", "M3"):
        a, b = stiff.trace(f"masses/{name}/displacement"), explicit.trace(f"masses/{name}/displacement")
        assert np.max(np.abs(a - b)) <= 1e-10 * LIFT
    v_a, v_b = stiff.trace("masses/M3/velocity"), explicit.trace("masses/M3/velocity")
    assert np.max(np.abs(v_a - v_b)) <= 1e-7 * np.max(np.abs(v_b))

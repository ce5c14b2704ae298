"""The dynamics engine against an independent reference solver of the same equations.

Source of the expected values: ``tests/data/reference/<machine>.npz``, written by
``tests/reference/make_reference.py`` with the solver in
``tests/reference/reference_solver.py`` — written from the model contract (spec §3-§4)
only, integrating with ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-12, atol 1e-15 m and
1e-12 m/s) and restarting at every branch change located as a terminal event. Its own
accuracy is checked here against closed forms (``test_reference_solver_*``); regenerating
its data at rtol 1e-11 changes event times by < 1e-13 s.

camsim runs the same machine on the same 10 kHz grid (1 warm-up + 1 recorded cycle).
Tolerances (relative to each trace's peak): displacement 1e-6, velocity 1e-5,
acceleration 1e-4; event times 1e-7 s with the same sequence of elements and kinds.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from camsim.machine.loader import load_machine, load_machine_text
from camsim.run.simulation import simulate

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "reference"
sys.path.insert(0, str(ROOT / "tests" / "reference"))

from reference_solver import reference_run  # noqa: E402
from scenarios import ContactRelease  # noqa: E402

MACHINES = ("cdtm", "dynacam-2mass")
BRANCH_KINDS = ("impact", "release", "separation", "rejoin", "stick")


def _load(name: str) -> dict:
    with np.load(DATA / f"{name}.npz") as data:
        out = {key: data[key] for key in data.files}
    out["meta"] = json.loads(str(out["meta"]))
    return out


@pytest.fixture(scope="module", params=MACHINES)
def pair(request):
    """(reference data, camsim RunResult) for one machine, camsim at the reference's grid."""
    ref = _load(request.param)
    meta = ref["meta"]
    machine = load_machine(ROOT / meta["machine"])
    run = simulate(machine, warmup_cycles=meta["warmup_cycles"], cycles=meta["cycles"],
                   sample_rate=meta["sample_rate_hz"])
    return request.param, ref, run


def test_reference_data_is_of_this_machine(pair):
    """The stored data were made from the machine as it is now (SHA-256 of its SI physics)."""
    from make_reference import machine_digest

    name, ref, run = pair
    assert machine_digest(run.machine) == ref["meta"]["machine_sha256"], (
        f"machines/{name}.toml changed: regenerate with python tests/reference/make_reference.py {name}")
    assert ref["meta"]["rtol"] <= 1e-10


def test_same_time_grid(pair):
    """camsim's grid is t_rec + k/sample_rate like the reference's (to 1e-12 s)."""
    _, ref, run = pair
    assert run.time.shape == ref["time"].shape
    assert np.max(np.abs(run.time - ref["time"])) < 1e-12


@pytest.mark.parametrize("quantity,tol", [("displacement", 1e-6), ("velocity", 1e-5), ("acceleration", 1e-4)])
def test_traces_match_reference(pair, quantity, tol):
    """Every mass's trace agrees with the reference solver (rtol 1e-12) to ``tol`` of its peak."""
    name, ref, run = pair
    for mass in ref["meta"]["masses"]:
        expected = ref[f"{mass}/{quantity}"]
        got = run.masses[mass][quantity]
        peak = np.max(np.abs(expected))
        err = np.abs(got - expected) / peak
        k = int(np.argmax(err))
        assert err[k] < tol, f"{name} {mass} {quantity}: {err[k]:.3g} of peak at t = {ref['time'][k]:.6f} s"


def test_events_match_reference(pair):
    """Same sequence of (element, kind) in the recorded cycle; times to 1e-7 s.

    The reference locates each branch change as a solve_ivp terminal event (root finding
    on the DOP853 dense output, rtol 1e-12).
    """
    name, ref, run = pair
    got = [e for e in run.events if e.kind in BRANCH_KINDS]
    expected = list(zip(ref["event_element"].tolist(), ref["event_kind"].tolist()))
    assert [(e.element, e.kind) for e in got] == expected, name
    if expected:
        dt = np.abs(np.array([e.time for e in got]) - ref["event_time"])
        assert np.max(dt) < 1e-7, f"{name}: event time errors {dt}"


def test_cdtm_reference_has_impacts():
    """The CDTM reference is not trivial: seat impacts, releases, K23 separations and rejoins."""
    ref = _load("cdtm")
    kinds = set(ref["event_kind"].tolist())
    assert {"impact", "release", "separation", "rejoin"} <= kinds


# ---------------------------------------------------------------------------------------
# The reference solver itself against closed forms (so that its data can be trusted)
# ---------------------------------------------------------------------------------------
def test_reference_solver_damped_free_vibration():
    """Mass on a damped spring to ground, released from x0 at rest.

    Closed form: x = x0·e^(−ζωt)·(cos ω_d t + ζω/ω_d·sin ω_d t). Tolerance 1e-9 of x0 at
    rtol 1e-11.
    """
    m, k, zeta, x0 = 2.0, 5.0e4, 0.05, 1.0e-3
    machine = load_machine_text(f"""
schema = 1
[machine]
name = "free vibration"
[[mass]]
name = "M"
mass = "{m} kg"
[[element]]
name = "k"
type = "spring"
between = ["ground", "M"]
stiffness = "{k} N/m"
damping_ratio = {zeta}
[initial.M]
displacement = "{x0} m"
velocity = "0 m/s"
[simulation]
duration = "0.2 s"
warmup_cycles = 0
sample_rate = "5 kHz"
""")
    ref = reference_run(machine, rtol=1e-11)
    w = math.sqrt(k / m)
    wd = w * math.sqrt(1 - zeta**2)
    t = ref.time
    x = x0 * np.exp(-zeta * w * t) * (np.cos(wd * t) + zeta * w / wd * np.sin(wd * t))
    assert np.max(np.abs(ref.masses["M"]["displacement"] - x)) < 1e-9 * x0


def test_reference_solver_damped_contact_release():
    """A mass arriving at v0 on a damped linear contact (no gravity) leaves it when F = 0.

    Closed form: in contact δ = (v0/ω_d)·e^(−ζωt)·sin ω_d t, and F = kδ + cδ̇ = 0 when
    ω_d·t_r = π − arctan(2ζ√(1−ζ²)/(1 − 2ζ²)) — before δ returns to 0. Impact at
    t0 = x0/v0. Tolerance 1e-9 s on both event times, at rtol 1e-11.
    """
    case = ContactRelease()
    ref = reference_run(case.machine("10 kHz"), rtol=1e-11)
    t0, tr = case.impact_time, case.contact_time
    assert [(e[1], e[2]) for e in ref.events] == [("seat", "impact"), ("seat", "release")]
    assert abs(ref.events[0][0] - t0) < 1e-9
    assert abs(ref.events[1][0] - (t0 + tr)) < 1e-9

"""The floor of ``bench/bench_floor.py`` does camsim's no-impact work, sample for sample.

So that the benchmark cannot compare camsim with different work: the floor
(``bench/floor_model.py``: the independent reference solver's equations, stepped exactly
and filtered by ``scipy.signal.lfilter``) must make every trace camsim writes for the
no-impact variant of ``machines/cdtm.toml`` (one revolution from equilibrium, 50 kHz:
25,001 samples) and agree with each to 1e-9 of its peak. camsim and the floor are
independent here (the floor imports neither ``camsim.model`` nor ``camsim.engine``), so
the agreement also checks camsim's no-impact run. A negative control shows the bar's
power: K12 stiffer by 1e-6 moves the floor 4.5e-7 of a peak away.

The floor's exact step is checked on its own against a closed form: an undamped
oscillator ẍ + ω²·x = ω²·s(t) driven by a degree-7 polynomial s has the particular
solution x = s − s″/ω² + s⁗/ω⁴ − s⁽⁶⁾/ω⁶, which one step must reproduce to rounding.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

from bench_floor import summarise  # noqa: E402
from floor_model import floor_run, step_maps, trace_errors  # noqa: E402

import camsim  # noqa: E402

CDTM = ROOT / "machines" / "cdtm.toml"
RATE = 50e3  # [Hz]
TOLERANCE = 1e-9  # of each trace's peak (measured worst: 1.7e-10, M3's acceleration)


@pytest.fixture(scope="module")
def machine():
    return camsim.load_machine(CDTM)


@pytest.fixture(scope="module")
def camsim_free(machine):
    return camsim.simulate(machine, no_impact=True, cycles=1, warmup_cycles=0, sample_rate=RATE)


def test_floor_makes_every_no_impact_trace_to_1e9_of_peak(machine, camsim_free):
    floor = floor_run(machine, 1, RATE)
    assert set(floor) == set(camsim_free.traces())  # the same outputs, no more, no fewer
    assert floor["time"].size == 25_001
    errs = trace_errors(floor, camsim_free)
    worst = max(errs, key=errs.get)
    assert errs[worst] <= TOLERANCE, f"{worst}: {errs[worst]:.2e} of peak"


def test_negative_control_k12_1e6_stiffer_is_seen(machine, camsim_free):
    k12 = next(e for e in machine.elements if e.name == "K12").stiffness
    stiffer = machine.with_values({"element.K12.stiffness": f"{k12 * (1 + 1e-6)!r} N/m"})
    errs = trace_errors(floor_run(stiffer, 1, RATE), camsim_free)
    assert max(errs.values()) > 100 * TOLERANCE


def test_step_reproduces_polynomial_forced_oscillator():
    w, h = 2 * math.pi * 300.0, 1.3e-3  # ω·h ≈ 2.5: the step spans much of a period
    A = np.array([[0.0, 1.0], [-w * w, 0.0]])
    es, ev, f0 = np.array([0.0, w * w]), np.zeros(2), np.zeros(2)
    coeffs = np.array([1e-3, -2.0, 30.0, 4e3, -2e6, 5e8, -3e10, 7e12])  # s(t) = Σ c_m t^m [m]
    s = np.polynomial.Polynomial(coeffs)

    def exact(t):
        """[x, v] of the particular solution x = s − s″/ω² + s⁗/ω⁴ − s⁽⁶⁾/ω⁶."""
        x = s - s.deriv(2) / w**2 + s.deriv(4) / w**4 - s.deriv(6) / w**6
        return np.array([x(t), x.deriv(1)(t)])

    def u(t):  # [s, h·ṡ, h²·s̈, h³·s⃛]
        return np.array([s.deriv(i)(t) * h**i for i in range(4)])

    phi, P, Q, c0 = step_maps(A, es, ev, f0, h)
    t0 = 0.4e-3
    got = phi @ exact(t0) + P @ u(t0) + Q @ u(t0 + h) + c0
    want = exact(t0 + h)
    scale = np.max(np.abs([exact(t) for t in np.linspace(t0, t0 + h, 50)]), axis=0)
    assert np.all(np.abs(got - want) <= 1e-12 * scale), (got - want) / scale


def test_summarise_derives_marginal_and_event_costs():
    samples = {"floor-1": [(1.0, 0.5)], "floor-3": [(2.0, 1.5)], "impact-1": [(10.0, 9.0)],
               "impact-3": [(26.0, 23.0)], "free-1": [(6.0, 5.0)], "free-3": [(14.0, 13.0)],
               "impact-2Hz": [(8.0, 7.0)], "free-2Hz": [(4.0, 3.0)]}
    fig = summarise(samples, events=4)
    assert fig["floor-marginal"] == (0.5, 0.5, 0.5, 0.5)
    assert fig["impact-marginal"] == (8.0, 8.0, 7.0, 7.0)
    assert fig["event"] == (1.0, 1.0, 1.0, 1.0)  # (10 − 6) / 4
    assert fig["event-marginal"] == (1.0, 1.0, 0.75, 0.75)  # (8 − 4) / 4, (7 − 4) / 4
    assert fig["event-2Hz"] == (1.0, 1.0, 1.0, 1.0)

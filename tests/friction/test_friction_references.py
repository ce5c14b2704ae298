"""Friction pairs (``type = "friction"``, spec §10) against independent references.

Every test names its reference and tolerance in its docstring. The references:

* closed forms of the piecewise linear motions (F_B = F_C or no Stribeck drop; spec §10's
  "References it must reproduce"): a block on a Coulomb slide, with and without viscous
  friction; a spring–mass released on a Coulomb slide; the stick–slip oscillator on a belt;
  two free masses rubbing on each other (momentum); a part on a cam-driven carriage (event
  instants by brentq on the closed-form cam law); a part hitting a rigid stop on its guide.
  Event times to 1e-9 s (spec §4), positions and velocities to 1e-9 of their scale or
  tighter, as each test says;
* scipy's DOP853 at rtol 1e-13 on the Stribeck law written out in friction_machines.py,
  for the nonlinear sliding phases: stop times and positions to 1e-8 relative;
* the same closed forms at sample rates up to 1 MHz (the rows must not depend on the grid).

The fine sample rates caught a slip the engine lost where a step's polynomial missed a
crossing its exact ends bracket (camsim/engine/linear.py now starts from the ends' cubic).

Conventions: tension-positive element forces; d = x_upper − x_lower; the pair acts −f on
its upper node (camsim/elements/friction.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from camsim.elements.events import EventKind
from camsim.machine.loader import load_machine_text
from camsim.run.simulation import simulate

from friction_machines import (
    MC,
    TR,
    CarriageReference,
    G,
    SlideReference,
    StickSlip,
    belt,
    block,
    carriage,
    coulomb_oscillator,
    cycloidal,
    spring_mass,
)

EVENT_TOL = 1e-9  # [s], spec §4


def run(text: str, **settings):
    return simulate(load_machine_text(text), **settings)


def rows(r, element: str | None = None, kinds=(EventKind.STICK, EventKind.SLIP)) -> list[tuple[float, str]]:
    """(time, kind) of the friction rows of a run (of ``element`` if given)."""
    return [(float(e.time), str(e.kind)) for e in r.events
            if e.kind in kinds and (element is None or e.element == element)]


def away_from(t: np.ndarray, instants, margin: float = 1e-9) -> np.ndarray:
    """The samples farther than ``margin`` from every instant (a sample at an event is on
    either side of it)."""
    keep = np.ones(t.shape, dtype=bool)
    for s in instants:
        keep &= np.abs(t - s) > margin
    return keep


def assert_rows(got, want, tol: float = EVENT_TOL):
    assert [k for _, k in got] == [k for _, k in want], (got, want)
    worst = max((abs(a[0] - b[0]) for a, b in zip(got, want)), default=0.0)
    assert worst <= tol, (worst, got, want)


# =========================================================================== 1. block
@pytest.mark.parametrize("v0", [1.5, -1.5])
def test_block_on_a_coulomb_slide_stops_at_the_closed_form(v0):
    """Reference (spec §10): a block m at v0 on a Coulomb slide F_C decelerates at F_C/m:
    x = v0·t − sign(v0)·F_C·t²/(2m), stopping at t = m·|v0|/F_C after m·v0²/(2F_C), then
    stays (x constant, force 0), with one ``stick`` row at the stop. Tolerances: the row
    1e-9 s; x 1e-12 m (of 0.45 m); the force exactly ±F_C sliding, |f| ≤ 1e-12 N stuck."""
    m, fc = 2.0, 5.0
    r = run(block(m=m, v0=v0, fc=fc))
    t_stop, dist = m * abs(v0) / fc, m * v0**2 / (2 * fc)
    assert_rows(rows(r), [(t_stop, "stick")])
    assert [e.element for e in r.events] == ["slide"]
    t, x, f = r.time, r.masses["block"]["displacement"], r.elements["slide"]
    sliding, stuck = t < t_stop - 1e-9, t > t_stop + 1e-9
    sign = math.copysign(1.0, v0)
    assert np.max(np.abs(x[sliding] - (v0 * t[sliding] - sign * fc * t[sliding] ** 2 / (2 * m)))) < 1e-12
    assert np.max(np.abs(x[stuck] - sign * dist)) < 1e-12
    assert np.max(np.abs(r.masses["block"]["velocity"][stuck])) < 1e-12
    assert np.all(f[sliding] == sign * fc)  # tension-positive: sign(ḋ)·F_C
    assert np.max(np.abs(f[stuck])) < 1e-12
    # the located extreme of x is the stop itself
    top, when = r.extreme("masses/block/displacement", "abs")
    assert top == pytest.approx(dist, rel=1e-12)
    assert when == pytest.approx(t_stop, abs=EVENT_TOL)


def test_block_with_coulomb_and_viscous_friction():
    """Reference: m·v̇ = −F_C − c·v gives v(t) = (v0 + F_C/c)·e^(−ct/m) − F_C/c, stopping at
    t* = (m/c)·ln(1 + c·v0/F_C) after x(t*) = (m/c)(v0 + F_C/c)(1 − e^(−ct*/m)) − F_C·t*/c;
    then stuck. Tolerances: the stick row 1e-9 s; v and x 1e-12 of v0 and of x(t*); the
    force F_C + c·v to 1e-9 N."""
    m, v0, fc, c = 2.0, 1.5, 5.0, 3.0
    r = run(block(m=m, v0=v0, fc=fc, cv=c))
    t_stop = (m / c) * math.log1p(c * v0 / fc)

    def x_of(t):
        return (m / c) * (v0 + fc / c) * (1.0 - np.exp(-c * t / m)) - fc * t / c

    dist = float(x_of(t_stop))
    assert_rows(rows(r), [(t_stop, "stick")])
    t = r.time
    sliding, stuck = t < t_stop - 1e-9, t > t_stop + 1e-9
    v_ref = (v0 + fc / c) * np.exp(-c * t / m) - fc / c
    assert np.max(np.abs(r.masses["block"]["velocity"][sliding] - v_ref[sliding])) < 1e-12 * v0
    assert np.max(np.abs(r.masses["block"]["displacement"][sliding] - x_of(t[sliding]))) < 1e-12 * dist
    assert np.max(np.abs(r.masses["block"]["displacement"][stuck] - dist)) < 1e-12 * dist
    assert np.max(np.abs(r.elements["slide"][sliding] - (fc + c * v_ref[sliding]))) < 1e-9
    assert np.max(np.abs(r.elements["slide"][stuck])) < 1e-12


def test_block_on_a_purely_viscous_slide_never_sticks():
    """Reference: F_C = F_B = 0, c > 0: v = v0·e^(−ct/m), x = (m·v0/c)(1 − e^(−ct/m)); the
    velocity never reaches zero, so no row. Tolerance 1e-12 of v0 and of m·v0/c."""
    m, v0, c = 2.0, 1.5, 3.0
    r = run(block(m=m, v0=v0, fc=0.0, cv=c))
    assert rows(r) == []
    t = r.time
    assert np.max(np.abs(r.masses["block"]["velocity"] - v0 * np.exp(-c * t / m))) < 1e-12 * v0
    assert np.max(np.abs(r.masses["block"]["displacement"] - m * v0 / c * -np.expm1(-c * t / m))) < 1e-12 * m * v0 / c


# =========================================================================== 3. spring–mass
@pytest.mark.parametrize(
    "x0, fb, n_half",
    [
        (10.5e-3, 10.0, 5),  # F_B = F_C: 10.5 → −8.5 → 6.5 → −4.5 → 2.5 → −0.5 mm, stuck within F_B/k = 1 mm
        (-7.3e-3, 10.0, 4),  # from below: −7.3 → 5.3 → −3.3 → 1.3 → 0.7 mm
        (10.5e-3, 30.0, 4),  # F_B = 3·F_C: stuck at 2.5 mm (k·x = 25 N ≤ 30 N)
        (7.3e-3, 25.0, 3),  # F_B/k = 2.5 mm: 7.3 → −5.3 → 3.3 → −1.3 mm
    ],
)
def test_spring_mass_on_a_coulomb_slide_rings_down_in_half_waves(x0, fb, n_half):
    """Reference (spec §10): each half-cycle a harmonic half-wave about ±F_C/k of half
    period π√(m/k), the amplitude falling by 2F_C/k per half-cycle, stuck in the first
    half-cycle that ends within |k·x| ≤ F_B (F_B = F_C and F_B > F_C), then the pair holds
    the spring's pull −k·x. The run starts held; k·|x0| > F_B, so it slips at t = 0.
    Tolerances: the stick row 1e-9 s; x 1e-12 m (of 10 mm), v 1e-12 m/s·(ω·10 mm = 1 m/s);
    the friction force 1e-8 N (of 10 N; the held force is −k·x, k = 1e4 N/m)."""
    m, k, fc = 1.0, 1e4, 10.0
    r = run(spring_mass(m=m, k=k, fc=fc, fb=fb, x0=x0))
    x, v, f, starts, t_stick, x_stick = coulomb_oscillator(m, k, fc, fb, x0, r.time)
    assert len(starts) == n_half
    assert t_stick == pytest.approx(n_half * math.pi * math.sqrt(m / k), rel=1e-15)
    assert_rows(rows(r), [(0.0, "slip"), (t_stick, "stick")])
    keep = away_from(r.time, [*starts, t_stick])
    assert np.max(np.abs(r.masses["m"]["displacement"] - x)[keep]) < 1e-12
    assert np.max(np.abs(r.masses["m"]["velocity"] - v)[keep]) < 1e-12
    assert np.max(np.abs(r.elements["slide"] - f)[keep]) < 1e-8
    assert r.masses["m"]["displacement"][-1] == pytest.approx(x_stick, abs=1e-12)
    assert r.elements["spring"][-1] == pytest.approx(k * x_stick, abs=1e-8)


def test_spring_mass_within_the_breakaway_force_stays_put():
    """Reference: released from x0 with k·|x0| ≤ F_B the pair holds at once: no row, x = x0,
    the friction force −k·x0 (holding the spring's pull), to 1e-12 m and 1e-9 N."""
    m, k, fc, fb, x0 = 1.0, 1e4, 10.0, 30.0, 2.9e-3
    r = run(spring_mass(m=m, k=k, fc=fc, fb=fb, x0=x0, duration="50 ms"))
    assert list(r.events) == []
    assert np.max(np.abs(r.masses["m"]["displacement"] - x0)) < 1e-12
    assert np.max(np.abs(r.elements["slide"] + k * x0)) < 1e-9


def test_spring_mass_with_viscous_and_coulomb_friction():
    """Reference: scipy DOP853 (rtol 1e-13) on m·ẍ = −k·x − sign(ẋ)·F_C − c·ẋ with the stick
    test at every ẋ = 0 (friction_machines.SlideReference): the pair is linear on each
    branch, so the stick row to 1e-9 s, x to 1e-9 of x0."""
    m, k, fc, c, x0 = 1.0, 1e4, 10.0, 20.0, 10.5e-3
    r = run(spring_mass(m=m, k=k, fc=fc, cv=c, x0=x0, duration="0.2 s"))
    ref = SlideReference(m, k, 0.0, fc, fc, None, c, x0, 0.0, 0.2)
    assert_rows(rows(r), ref.events)
    keep = away_from(r.time, [t for t, _ in ref.events + ref.reversals], 1e-7)
    assert np.max(np.abs(r.masses["m"]["displacement"] - ref.x(r.time))[keep]) < 1e-9 * x0


def test_run_starts_held_at_the_equilibrium_without_the_pair():
    """Reference (spec §10): "at t = 0 the static equilibrium is computed without the
    friction pairs; each then starts stuck there, carrying no force (no stick row)": a
    spring–mass under gravity (k = 1e4 N/m, m = 1 kg) on a slide rests at −m·g/k (1e-15 m),
    the pair carries 0 N (exactly) and there is no row."""
    text = spring_mass(fc=2.0, fb=3.0).replace('[initial.m]\ndisplacement = "0.0105 m"\nvelocity = "0.0 m/s"\n', "")
    text = text.replace("[simulation]\n", "[simulation]\ngravity = true\n")
    assert "[initial" not in text
    r = run(text)
    assert list(r.events) == []
    assert np.max(np.abs(r.masses["m"]["displacement"] + G / 1e4)) < 1e-15
    assert np.all(r.elements["slide"] == 0.0)


def test_coefficient_and_normal_force_are_coulomb_and_breakaway_forces():
    """Reference (spec §10): F_C = μ·N and F_B = μ_s·N: μ = 0.5, μ_s = 1.5, N = 20 N is the
    pair F_C = 10 N, F_B = 30 N; the two runs agree bit for bit (rows and traces)."""
    keys = 'coulomb_force = "10.0 N"\nbreakaway_force = "30.0 N"'
    text = spring_mass(x0=10.5e-3, fc=10.0, fb=30.0)
    assert keys in text
    a = run(text)
    b = run(text.replace(keys, 'coefficient = 0.5\nnormal_force = "20 N"\nstatic_coefficient = 1.5'))
    assert rows(a) == rows(b) and len(rows(a)) == 2
    for q in ("displacement", "velocity", "acceleration"):
        assert np.array_equal(a.masses["m"][q], b.masses["m"][q])
    assert np.array_equal(a.elements["slide"], b.elements["slide"])


def test_normal_force_program_brakes_a_block():
    """Reference (spec §10: F_C follows N(t), an input, exact): a block m = 2 kg at
    v0 = 1.5 m/s under a brake μ = 0.25, N(t) = 20 N + 5 N·sin(2π·1 Hz·t):
    v(t) = v0 − (μ/m)[20t + 5(1 − cos 2πt)/(2π)] until it is 0 (brentq), then stuck.
    The stick row 1e-9 s, v on every sample 1e-12 m/s."""
    from scipy.optimize import brentq

    m, v0, mu = 2.0, 1.5, 0.25
    text = block(m=m, v0=v0, fc=5.0).replace(
        'coulomb_force = "5.0 N"',
        'coefficient = 0.25\nnormal_force = { sine = { amplitude = "5 N", frequency = "1 Hz", offset = "20 N" } }')
    r = run(text)

    def v_of(t):
        return v0 - (mu / m) * (20.0 * t + 5.0 * (1.0 - np.cos(2 * np.pi * t)) / (2 * np.pi))

    t_stop = brentq(v_of, 0.1, 1.0, xtol=1e-16)
    assert_rows(rows(r), [(t_stop, "stick")])
    sliding = r.time < t_stop - 1e-9
    assert np.max(np.abs(r.masses["block"]["velocity"][sliding] - v_of(r.time[sliding]))) < 1e-12


# =========================================================================== 4. belt
def test_stick_slip_limit_cycle_period_stick_time_and_amplitude():
    """Reference (spec §10): the stick–slip oscillator (m = 1 kg, k = 1e4 N/m, F_C = 10 N,
    F_B = 15 N, belt at V = 0.05 m/s, no Stribeck), started stuck on its limit cycle at
    x = 2x_C − x_B moving with the belt: stuck for 2(x_B − x_C)/V, slipping for
    (π + 2α)/ω, α = atan2(V/ω, x_B − x_C); x between x_C ± √((x_B − x_C)² + (V/ω)²).
    Tolerances: every row 1e-9 s; the located extremes (max and min of x) 1e-9 of the
    amplitude and their instants 1e-9 s; x on every sample within what a 1e-9 s shift of
    the rows moves it (1e-9 s × the peak speed R·ω); the held force within ±F_B but for
    the 1e-10 s to which a slip is located (docs/model.md): k·V·1e-10 s."""
    m, k, fc, fb, V = 1.0, 1e4, 10.0, 15.0, 0.05
    ref = StickSlip(m, k, fc, fb, V)
    r = run(belt(m=m, k=k, fc=fc, fb=fb, V=V, x0=2 * ref.xc - ref.xb, v0=V))
    t_end = float(r.time[-1])
    want = []
    for n in range(int(t_end / ref.period) + 1):
        slip = n * ref.period + ref.stick_duration
        want += [(slip, "slip"), (slip + ref.slip_duration, "stick")]
    assert_rows(rows(r), [w for w in want if w[0] <= t_end])
    top, t_top = r.extreme("masses/m/displacement", "max")
    low, t_low = r.extreme("masses/m/displacement", "min")
    assert abs(top - (ref.xc + ref.radius)) < 1e-9 * ref.radius
    assert abs(low - (ref.xc - ref.radius)) < 1e-9 * ref.radius
    # each is reached once per cycle: at α/ω and (π + α)/ω into a slip
    phase_top = (t_top - ref.stick_duration - ref.alpha / ref.w) / ref.period
    phase_low = (t_low - ref.stick_duration - (math.pi + ref.alpha) / ref.w) / ref.period
    assert abs(phase_top - round(phase_top)) * ref.period < EVENT_TOL
    assert abs(phase_low - round(phase_low)) * ref.period < EVENT_TOL
    assert np.max(np.abs(r.masses["m"]["displacement"] - ref.x(r.time))) < EVENT_TOL * ref.radius * ref.w
    f_low, _ = r.extreme("elements/belt/force", "min")  # held against the spring: f = −k·x
    assert -f_low == pytest.approx(fb, abs=k * V * 1e-10)


def test_stick_slip_from_rest_reaches_the_closed_form_cycle():
    """Reference: the mass at rest at x = 0 under the belt at V slides first (ḋ = −V): a
    harmonic about x_C from rest, x = x_C(1 − cos ωt), until ẋ = V at t1 = asin(V/(ω·x_C))/ω
    (V < ω·x_C); there k·x ≤ F_B, so it sticks, and slips at k·x = F_B, at
    t1 + (x_B − x(t1))/V; from then on the limit cycle of the previous test. Every row to
    1e-9 s."""
    m, k, fc, fb, V = 1.0, 1e4, 10.0, 15.0, 0.05
    ref = StickSlip(m, k, fc, fb, V)
    r = run(belt(m=m, k=k, fc=fc, fb=fb, V=V, x0=0.0, v0=0.0, duration="0.5 s"))
    t1 = math.asin(V / (ref.w * ref.xc)) / ref.w
    x1 = ref.xc * (1 - math.cos(ref.w * t1))
    slip = t1 + (ref.xb - x1) / V
    want = [(t1, "stick")]
    while slip < 0.5:
        want += [(slip, "slip"), (slip + ref.slip_duration, "stick")]
        slip += ref.period
    assert_rows(rows(r), [w for w in want if w[0] <= 0.5])


def test_stick_slip_with_viscous_friction_against_dop853():
    """Reference: DOP853 (rtol 1e-13) on m·ẍ = −k·x − [−F_C + c·(ẋ − V)] while slipping
    (friction_machines.SlideReference; stuck phases in closed form). The law is linear on
    each branch: rows to 1e-9 s, x to 1e-9 of x_B."""
    m, k, fc, fb, c, V = 1.0, 1e4, 10.0, 15.0, 8.0, 0.05
    x0 = 0.5e-3
    r = run(belt(m=m, k=k, fc=fc, fb=fb, cv=c, V=V, x0=x0, v0=V, duration="0.4 s"))
    ref = SlideReference(m, k, V, fc, fb, None, c, x0, V, 0.4)
    assert len(ref.events) >= 8
    assert_rows(rows(r), ref.events)
    keep = away_from(r.time, [t for t, _ in ref.events], 1e-7)
    assert np.max(np.abs(r.masses["m"]["displacement"] - ref.x(r.time))[keep]) < 1e-9 * fb / k


# =========================================================================== 5. Stribeck
def test_stribeck_block_stops_like_dop853():
    """Reference: DOP853 (rtol 1e-13, event v = 0) on m·v̇ = −[F_C + (F_B − F_C)e^(−v/v_S)] − c·v
    (the law written independently in friction_machines.SlideReference). The stop time and
    the stop position to 1e-8 relative; x on every sample to 1e-8 of the distance."""
    m, v0, fc, fb, vs, c = 2.0, 1.5, 5.0, 9.0, 0.2, 1.0
    r = run(block(m=m, v0=v0, fc=fc, fb=fb, vs=vs, cv=c))
    ref = SlideReference(m, 0.0, 0.0, fc, fb, vs, c, 0.0, v0, 1.0)
    (t_ref, kind), = ref.events
    (t_got, kind_got), = rows(r)
    assert kind_got == kind == "stick"
    assert abs(t_got - t_ref) < 1e-8 * t_ref
    dist = float(ref.x(np.array([1.0]))[0])
    assert abs(r.masses["block"]["displacement"][-1] - dist) < 1e-8 * dist
    keep = away_from(r.time, [t_ref], 1e-6)
    assert np.max(np.abs(r.masses["block"]["displacement"] - ref.x(r.time))[keep]) < 1e-8 * dist
    # the sliding force is the law itself (tension-positive) to 1e-8 of F_B
    sliding = r.time < t_ref - 1e-6
    vel = r.masses["block"]["velocity"][sliding]
    law = fc + (fb - fc) * np.exp(-vel / vs) + c * vel
    assert np.max(np.abs(r.elements["slide"][sliding] - law)) < 1e-8 * fb


@pytest.mark.parametrize("x0", [10.5e-3, -6.2e-3])
def test_stribeck_spring_mass_ring_down_like_dop853(x0):
    """Reference: DOP853 (rtol 1e-13, events ḋ = 0, the stick test |k·x| ≤ F_B there) on a
    spring–mass released from x0 on a slide with F_C = 10 N, F_B = 18 N, v_S = 0.05 m/s,
    c = 2 N·s/m. The stick row and the stop position to 1e-8 relative; x on every sample
    to 1e-8 of |x0|."""
    m, k, fc, fb, vs, c = 1.0, 1e4, 10.0, 18.0, 0.05, 2.0
    r = run(spring_mass(m=m, k=k, fc=fc, fb=fb, vs=vs, cv=c, x0=x0, duration="0.25 s"))
    ref = SlideReference(m, k, 0.0, fc, fb, vs, c, x0, 0.0, 0.25)
    got = rows(r)
    assert [kd for _, kd in got] == [kd for _, kd in ref.events] == ["slip", "stick"]
    t_ref = ref.events[-1][0]
    assert abs(got[-1][0] - t_ref) < 1e-8 * t_ref
    x_end = float(ref.x(np.array([0.25]))[0])
    assert abs(r.masses["m"]["displacement"][-1] - x_end) < 1e-8 * abs(x_end)
    keep = away_from(r.time, [t for t, _ in ref.reversals + ref.events], 1e-6)
    assert np.max(np.abs(r.masses["m"]["displacement"] - ref.x(r.time))[keep]) < 1e-8 * abs(x0)


def test_stribeck_stick_slip_on_a_belt_like_dop853():
    """Reference: DOP853 (rtol 1e-13) on the stick–slip oscillator with a Stribeck drop
    (F_C = 10 N, F_B = 15 N, v_S = 0.02 m/s, c = 1 N·s/m), belt at V = 0.05 m/s, started
    stuck at x = 0.5 mm: slip rows where k·x = F_B (stuck phases are exact: 1e-9 s), stick
    rows at the end of each nonlinear slip (1e-8 relative of the time), x on every
    sample to 1e-8 of x_B."""
    m, k, fc, fb, vs, c, V = 1.0, 1e4, 10.0, 15.0, 0.02, 1.0, 0.05
    x0 = 0.5e-3
    r = run(belt(m=m, k=k, fc=fc, fb=fb, vs=vs, cv=c, V=V, x0=x0, v0=V, duration="0.4 s"))
    ref = SlideReference(m, k, V, fc, fb, vs, c, x0, V, 0.4)
    got = rows(r)
    assert len(ref.events) >= 6
    assert [kd for _, kd in got] == [kd for _, kd in ref.events]
    for (tg, kd), (tr, _) in zip(got, ref.events):
        assert abs(tg - tr) < 1e-8 * tr, (kd, tg, tr)
    keep = away_from(r.time, [t for t, _ in ref.events], 1e-6)
    assert np.max(np.abs(r.masses["m"]["displacement"] - ref.x(r.time))[keep]) < 1e-8 * fb / k


# =========================================================================== 6. other pairs
def _two_masses(ma, mb, va, vb, fc, cv=None) -> str:
    visc = f'viscous = "{cv!r} N*s/m"' if cv is not None else ""
    return f"""
schema = 1
[machine]
name = "two parts rubbing"
[[mass]]
name = "a"
mass = "{ma!r} kg"
[[mass]]
name = "b"
mass = "{mb!r} kg"
[[element]]
name = "pair"
type = "friction"
between = ["a", "b"]
coulomb_force = "{fc!r} N"
{visc}
[initial.a]
displacement = "0 m"
velocity = "{va!r} m/s"
[initial.b]
displacement = "0.1 m"
velocity = "{vb!r} m/s"
[simulation]
duration = "1 s"
sample_rate = "1 kHz"
"""


def test_two_free_masses_rubbing_stick_at_the_common_velocity():
    """Reference: two free masses with a Coulomb pair between them: the relative velocity
    u = v_b − v_a falls at F_C(1/m_a + 1/m_b) and reaches 0 at t* = |u0|/(F_C(1/m_a + 1/m_b));
    momentum is conserved: both then move at (m_a·v_a + m_b·v_b)/(m_a + m_b); the energy
    dissipated is F_C·|Δd| = ½·μ·u0² (μ the reduced mass). Tolerances: the stick row 1e-9 s;
    velocities 1e-12 m/s; momentum on every sample 1e-12 N·s; Δd 1e-12 m."""
    ma, mb, va, vb, fc = 2.0, 3.0, 1.0, -0.5, 6.0
    r = run(_two_masses(ma, mb, va, vb, fc))
    u0 = vb - va
    t_stop = abs(u0) / (fc * (1 / ma + 1 / mb))
    assert_rows(rows(r), [(t_stop, "stick")])
    assert r.events[0].masses == "a/b"
    p = ma * r.masses["a"]["velocity"] + mb * r.masses["b"]["velocity"]
    assert np.max(np.abs(p - (ma * va + mb * vb))) < 1e-12
    vc = (ma * va + mb * vb) / (ma + mb)
    stuck = r.time > t_stop + 1e-9
    for name in ("a", "b"):
        assert np.max(np.abs(r.masses[name]["velocity"][stuck] - vc)) < 1e-12
    d = r.masses["b"]["displacement"] - r.masses["a"]["displacement"]
    mu = ma * mb / (ma + mb)
    assert fc * abs(d[-1] - d[0]) == pytest.approx(0.5 * mu * u0**2, abs=1e-12 * fc)
    sliding = r.time < t_stop - 1e-9
    assert np.all(r.elements["pair"][sliding] == -fc)  # ḋ < 0: f = −F_C
    assert np.max(np.abs(r.elements["pair"][stuck])) < 1e-12


@pytest.mark.parametrize("fc, fb", [(0.3, 0.4), (0.4, 0.4), (0.2, 0.45)])
def test_part_on_a_cam_driven_carriage(fc, fb):
    """Reference: a part on a carriage (friction between the cam node and a free mass): the
    cam's cycloidal rise and fall in closed form, the part stuck (x = s + D) or sliding at
    ±F_C/m, event instants by brentq (friction_machines.CarriageReference). Every row
    1e-9 s; x on every sample 1e-11 m (of 20 mm); stuck, the pad carries −m·s̈ (1e-9 N)."""
    r = run(carriage(fc, fb))
    ref = CarriageReference(fc, fb)
    assert len(ref.events) >= 3
    assert_rows(rows(r), ref.events)
    keep = away_from(r.time, [t for t, _ in ref.events])
    assert np.max(np.abs(r.masses["part"]["displacement"] - ref.x(r.time))[keep]) < 1e-11
    s, _, a = cycloidal(r.time)
    assert np.max(np.abs(r.cam["displacement"] - s)) < 1e-15  # the cam node is the closed form
    stuck = np.zeros(r.time.shape, dtype=bool)
    for t0, t1, state in ref.pieces:
        if state[0] == "stuck":
            stuck |= (r.time > t0 + 1e-9) & (r.time < t1 - 1e-9)
    assert stuck.any()
    assert np.max(np.abs(r.elements["pad"][stuck] + MC * a[stuck])) < 1e-9


def _stop(e: float, fc: float, fb: float | None = None, m: float = 1.0, x0: float = 0.2, v0: float = -1.0,
          gravity: bool = False) -> str:
    fbl = f'breakaway_force = "{fb!r} N"' if fb is not None else ""
    return f"""
schema = 1
[machine]
name = "a part on its guide and a rigid stop"
[[mass]]
name = "m"
mass = "{m!r} kg"
[[element]]
name = "guide"
type = "friction"
between = ["ground", "m"]
coulomb_force = "{fc!r} N"
{fbl}
[[element]]
name = "stop"
type = "contact"
between = ["ground", "m"]
law = "restitution"
restitution = {e!r}
[initial.m]
displacement = "{x0!r} m"
velocity = "{v0!r} m/s"
[simulation]
duration = "1 s"
sample_rate = "1 kHz"
gravity = {'true' if gravity else 'false'}
"""


@pytest.mark.parametrize("e", [0.5, 0.0])
def test_part_slides_onto_a_rigid_stop_rebounds_and_sticks(e):
    """Reference (no gravity): a part at x0 = 0.2 m moving at −1 m/s on a guide (F_C = 2 N,
    m = 1 kg) decelerates at F_C/m, reaches the stop at x = 0 with v_i = √(v0² − 2F_C·x0/m)
    at t1 = m(|v0| − v_i)/F_C, leaves at e·v_i (Newton) and stops at t1 + m·e·v_i/F_C,
    x = m(e·v_i)²/(2F_C), where it sticks (e = 0: the impulse brings ḋ to 0, the stick test
    at the impact: spec §10). Tolerances: rows 1e-9 s; the impact speed 1e-12 m/s; the
    final x 1e-12 m; no force left on either element (1e-12 N)."""
    m, fc, x0, v0 = 1.0, 2.0, 0.2, -1.0
    r = run(_stop(e, fc, m=m, x0=x0, v0=v0))
    vi = math.sqrt(v0**2 - 2 * fc * x0 / m)
    t1 = m * (abs(v0) - vi) / fc
    t2 = t1 + m * e * vi / fc
    got = [(float(ev.time), ev.element, str(ev.kind)) for ev in r.events]
    assert [g[1:] for g in got] == [("stop", "impact"), ("guide", "stick")]
    assert abs(got[0][0] - t1) < EVENT_TOL and abs(got[1][0] - t2) < EVENT_TOL
    assert r.events[0].relative_velocity == pytest.approx(vi, abs=1e-12)
    assert r.masses["m"]["displacement"][-1] == pytest.approx(m * (e * vi) ** 2 / (2 * fc), abs=1e-12)
    assert abs(r.elements["guide"][-1]) < 1e-12 and abs(r.elements["stop"][-1]) < 1e-12


@pytest.mark.parametrize("e, fb", [(0.5, None), (0.0, None), (0.5, 15.0)])
def test_falling_part_lands_on_a_stop_and_sticks_on_its_guide(e, fb):
    """Reference (gravity g, vertical guide with F_C = 12 N > m·g, m = 1 kg): thrown down at
    3 m/s from 0.2 m it decelerates at F_C/m − g, lands with v_i = √(9 − 2(F_C/m − g)·0.2)
    at t1 = m(3 − v_i)/(F_C − m·g), rebounds at e·v_i, decelerates at g + F_C/m and stops
    at t1 + e·v_i/(g + F_C/m), x = (e·v_i)²/(2(g + F_C/m)); m·g ≤ F_B, so it sticks in the
    air (e = 0.5) or on the stop (e = 0: the friction pair carries m·g first, spec §10, the
    stop nothing). Then the guide holds the weight: f = −m·g. Tolerances: rows 1e-9 s; x
    1e-12 m; forces 1e-9 N."""
    m, fc, v0, x0 = 1.0, 12.0, -3.0, 0.2
    r = run(_stop(e, fc, fb=fb, m=m, x0=x0, v0=v0, gravity=True))
    dec = fc / m - G
    vi = math.sqrt(v0**2 - 2 * dec * x0)
    t1 = (abs(v0) - vi) / dec
    t2 = t1 + e * vi / (G + fc / m)
    got = [(float(ev.time), ev.element, str(ev.kind)) for ev in r.events]
    assert [g[1:] for g in got] == [("stop", "impact"), ("guide", "stick")]
    assert abs(got[0][0] - t1) < EVENT_TOL and abs(got[1][0] - t2) < EVENT_TOL
    assert r.masses["m"]["displacement"][-1] == pytest.approx((e * vi) ** 2 / (2 * (G + fc / m)), abs=1e-12)
    assert r.elements["guide"][-1] == pytest.approx(-m * G, abs=1e-9)
    assert abs(r.elements["stop"][-1]) < 1e-9


@pytest.mark.parametrize("e", [0.0, 0.5])
def test_part_heavier_than_its_breakaway_force_rests_on_the_stop(e):
    """Reference (spec §10: "where a stuck pair and a resting rigid contact hold the same
    mass, the friction pair carries the holding force first, within ±F_B, and the contact
    the rest"): a part of m = 1 kg on a vertical guide with F_C = F_B = 4 N < m·g, at rest at
    0.2 m, slips at t = 0 and slides down at g − F_C/m; it lands at t1 = √(2·0.2/(g − F_C/m))
    (1e-9 s); with e = 0.5 it rebounds at q = e√((g − a)/(g + a)) times its previous speed
    each landing (a = F_C/m: up at g + a, down at g − a; the first three landings to 1e-9 s);
    it ends at rest on the stop with the guide carrying F_B (f = −F_B, 1e-9 N) and the stop
    m·g − F_B."""
    m, fc = 1.0, 4.0
    r = run(_stop(e, fc, m=m, x0=0.2, v0=0.0, gravity=True))
    a = fc / m
    vi = math.sqrt(2 * (G - a) * 0.2)
    t = vi / (G - a)
    impacts = [float(ev.time) for ev in r.events if ev.element == "stop" and ev.kind == EventKind.IMPACT]
    want = [t]
    v = vi
    for _ in range(2):
        t += e * v / (G + a) + e * v * math.sqrt((G - a) / (G + a)) / (G - a)
        v *= e * math.sqrt((G - a) / (G + a))
        want.append(t)
    n = 1 if e == 0 else 3
    assert np.max(np.abs(np.array(impacts[:n]) - want[:n])) < EVENT_TOL
    assert abs(r.masses["m"]["displacement"][-1]) < 1e-12
    assert r.elements["guide"][-1] == pytest.approx(-fc, abs=1e-9)
    assert r.elements["stop"][-1] == pytest.approx(m * G - fc, abs=1e-9)


# =========================================================================== the sample rate


def _belt_rows(ref: StickSlip, t_end: float) -> list[tuple[float, str]]:
    want, n = [], 0
    while n * ref.period + ref.stick_duration <= t_end:
        slip = n * ref.period + ref.stick_duration
        want.append((slip, "slip"))
        if slip + ref.slip_duration <= t_end:
            want.append((slip + ref.slip_duration, "stick"))
        n += 1
    return want


@pytest.mark.parametrize("rate", [
    "10 kHz", "20 kHz",
    pytest.param("50 kHz"),
    pytest.param("200 kHz"),
    pytest.param("1 MHz"),
])
def test_stick_slip_rows_at_any_sample_rate(rate):
    """Reference: the closed-form limit cycle of test_stick_slip_limit_cycle_period_stick_time_and_amplitude
    over 0.3 s (nine rows) at sample rates from 10 kHz to 1 MHz (spec §4: the output grid
    only chooses where traces are recorded); every row to 1e-9 s. The first slip falls on
    a node of every grid here (t = 0.02 s)."""
    m, k, fc, fb, V = 1.0, 1e4, 10.0, 15.0, 0.05
    ref = StickSlip(m, k, fc, fb, V)
    r = run(belt(m=m, k=k, fc=fc, fb=fb, V=V, x0=2 * ref.xc - ref.xb, v0=V, duration="0.3 s", rate=rate))
    assert_rows(rows(r), _belt_rows(ref, 0.3))
    assert np.max(np.abs(r.elements["belt"])) <= fb + k * V * 1e-10


@pytest.mark.parametrize("fc, fb, rate, duration", [
    (0.4, 0.4, "30 kHz", None),
    (0.2, 0.45, "200 kHz", None),
    pytest.param(0.4, 0.4, "100 kHz", None),
    pytest.param(0.4, 0.4, "200 kHz", None),
    pytest.param(0.3, 0.4, "200 kHz", None),
    pytest.param(0.2, 0.45, "1 MHz", "0.15 s"),
])
def test_carriage_rows_at_any_sample_rate(fc, fb, rate, duration):
    """Reference: CarriageReference (closed form, brentq) at finer grids than
    test_part_on_a_cam_driven_carriage; every row to 1e-9 s, and the held pad never carries
    more than F_B (1e-10 s of its rate m·|s⃛| ≤ 8 N/s: 1e-9 N)."""
    t_end = float(duration.split()[0]) if duration else 2 * TR
    r = run(carriage(fc, fb, rate=rate, duration=duration))
    ref = CarriageReference(fc, fb, t_end=t_end)
    assert_rows(rows(r), ref.events)
    assert np.max(np.abs(r.elements["pad"])) <= fb + 1e-9

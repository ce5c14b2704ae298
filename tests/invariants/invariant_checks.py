"""The invariants of issue 25 as plain functions of machine-file text.

Each ``check_*`` runs camsim on one or two machine texts and returns a list of
discrepancies (empty: the invariant holds). The hypothesis tests call them on generated
machines; regression tests call them on the reduced machines that once failed, so any
failure is reproduced by pasting the printed TOML into a call.

References and tolerances are those of the spec (§4: every event located to 1e-9 s,
the output grid only chooses where traces are recorded):

* events compare by sequence of (element, kind) and by time, |Δt| ≤ 1e-9 s (1e-12 s for
  the US-units invariant);
* traces compare at the instants both runs share, max |Δ| ≤ tol × peak |trace|.
"""

from __future__ import annotations

import math
import os
import random
import tomllib
from pathlib import Path

import numpy as np
import tomli_w

from camsim.machine.loader import load_machine_text
from camsim.run.simulation import simulate
from camsim.run.stream import simulate_to_file

#: Event times agree to this [s] (spec §4).
EVENT_TOL = 1e-9
#: Traces agree to this fraction of their peak.
TRACE_TOL = 1e-9
#: ... except in a machine with a numerically integrated contact law (power, adams-impact,
#: hertz, a power-law lash): there the state is integrated to a tolerance (camsim.engine.nonlinear:
#: RTOL 3e-12, DOP853 rtol 3e-13), and where the steps fall -- set by the output grid --
#: moves it by ~1e-12 relative, which the impacts that follow amplify: a sample beside an
#: impact reads an event time shifted by 1e-12 s times an acceleration of 1e4 m/s². Measured
#: worst over 30 generated machines between 5 and 50 kHz (issue 34): 7e-9 of peak (4e-9 with
#: DOP853 alone), where it was 1.3e-7 (power law) and 5e-7 (IMPACT) before the cam laws'
#: inner kinks stopped stretches and the tolerances were tightened 30-fold. Event times hold
#: EVENT_TOL for every law (IMPACT's kinks are located like events, issue 34).
NONLINEAR_TRACE_TOL = 1e-8
#: Adams's IMPACT law: the same (its kinks are events since issue 34, on a lash's sides too).
ADAMS_TRACE_TOL = 1e-8
ADAMS_EVENT_TOL = EVENT_TOL


def load(text: str):
    """The machine of ``text`` (source ``<hypothesis>``). With $CAMSIM_INVARIANT_TRACE set,
    each machine loaded is appended to that file with the time (to find a slow example)."""
    trace = os.environ.get("CAMSIM_INVARIANT_TRACE")
    if trace:
        import time

        with open(trace, "a") as f:
            f.write(f"### {time.time():.3f}\n{text}\n")
    return load_machine_text(text, source="<hypothesis>")


def _adams(machine) -> bool:
    """An Adams IMPACT contact in ``machine`` (alone or as a lash's law)."""
    return any("adams-impact" in (getattr(e, "law_name", None), getattr(getattr(e, "contact", None), "law_name", None))
               for e in machine.elements)


def trace_tol(machine) -> float:
    """TRACE_TOL; NONLINEAR_TRACE_TOL when a contact law of ``machine`` is integrated
    numerically in some branch; ADAMS_TRACE_TOL with an Adams IMPACT contact."""
    from camsim.elements.base import Branch

    if _adams(machine):
        return ADAMS_TRACE_TOL
    nonlinear = any(e.is_nonlinear(b) for e in machine.elements for b in Branch)
    return NONLINEAR_TRACE_TOL if nonlinear else TRACE_TOL


def event_tol(machine) -> float:
    """EVENT_TOL, or ADAMS_EVENT_TOL with an Adams IMPACT contact (see ADAMS_TRACE_TOL)."""
    return ADAMS_EVENT_TOL if _adams(machine) else EVENT_TOL


def event_rows(result, t0: float = 0.0, t1: float = math.inf, shift: float = 0.0) -> list[tuple]:
    """(time − shift [s], element, kind) of the events with t0 ≤ time ≤ t1."""
    return [(e.time - shift, e.element, str(e.kind)) for e in result.events if t0 <= e.time <= t1]


def compare_events(a: list[tuple], b: list[tuple], tol: float, edges: tuple[float, float] | None = None) -> list[str]:
    """Discrepancies between two event lists: sequence of (element, kind) and times.

    ``edges`` (t0, t1): events within ``tol`` of a window edge may be missing from the
    other list (they belong to either side of the edge).
    """
    if edges is not None:
        near = lambda t: abs(t - edges[0]) <= tol or abs(t - edges[1]) <= tol  # noqa: E731
        a_in = [r for r in a if not near(r[0])]
        b_in = [r for r in b if not near(r[0])]
        if [r[1:] for r in a_in] == [r[1:] for r in b_in]:
            a, b = a_in, b_in
    a, b = _simultaneous_in_order(a, tol), _simultaneous_in_order(b, tol)
    problems = []
    seq_a, seq_b = [r[1:] for r in a], [r[1:] for r in b]
    if seq_a != seq_b:
        k = next((i for i, (x, y) in enumerate(zip(seq_a, seq_b)) if x != y), min(len(a), len(b)))
        problems.append(
            f"event sequences differ from row {k}: {len(a)} vs {len(b)} events; "
            f"first: {a[k] if k < len(a) else None} vs {b[k] if k < len(b) else None}; "
            f"a[k-1:k+3] = {a[max(0, k - 1):k + 3]}; b[k-1:k+3] = {b[max(0, k - 1):k + 3]}"
        )
        return problems
    worst, at = 0.0, None
    for x, y in zip(a, b):
        d = abs(x[0] - y[0])
        if d > worst:
            worst, at = d, (x, y)
    if worst > tol:
        problems.append(f"event time differs by {worst:.3g} s > {tol:g} s: {at[0]} vs {at[1]}")
    return problems


def _simultaneous_in_order(rows: list[tuple], tol: float) -> list[tuple]:
    """The events with those at one instant (within ``tol`` of the first of them) sorted by
    (element, kind): two contacts closing at one instant have no order the invariants can
    ask for (a shuffled file listed a seat's and a stop's impact 6e-14 s apart the other way)."""
    out, i = [], 0
    while i < len(rows):
        j = i + 1
        while j < len(rows) and rows[j][0] - rows[i][0] <= tol:
            j += 1
        out.extend(sorted(rows[i:j], key=lambda r: (r[1], r[2])))
        i = j
    return out


def shared_instants(ta: np.ndarray, tb: np.ndarray, tol: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """Indices (ia, ib) of the samples of two time bases that fall on the same instant."""
    ib = np.clip(np.searchsorted(tb, ta), 0, len(tb) - 1)
    ib_left = np.clip(ib - 1, 0, len(tb) - 1)
    pick = np.where(np.abs(tb[ib_left] - ta) < np.abs(tb[ib] - ta), ib_left, ib)
    ok = np.abs(tb[pick] - ta) <= tol
    return np.flatnonzero(ok), pick[ok]


#: A mass's (element's) trace is compared relative to at least this fraction of the largest
#: peak of the same quantity over all masses and the cam (over all elements): a mass resting
#: on a rigid seat for the whole run has a velocity of 3e-14 m/s and an acceleration of
#: 1e-11 m/s^2 of rounding (beside the cam's 0.8 m/s and 130 m/s^2), a spring between two
#: resting masses 6e-11 N (beside a 1565 N closure spring), which no tolerance relative to
#: their own peak compares. The rounding of a mass at rest grows with the number of exact
#: steps: measured 6e-14, 3e-12 and 5.5e-12 m/s at 20 kHz, 200 kHz and 1 MHz beside a cam
#: velocity of 1.24 m/s (4.5e-12 of it); 1e-9 of 1 % of the machine's scale is 1e-11 of it.
FAMILY_FLOOR = 1e-2


def _family_peaks(ta, tb) -> dict[str, float]:
    """Largest |value| of each mass quantity (the last path component) over all masses
    and the cam (its displacement, velocity, acceleration on the model axis), and of the
    element forces over all elements."""
    out: dict[str, float] = {}
    for traces in (ta, tb):
        for path, trace in traces.items():
            if path.startswith(("masses/", "elements/")) or path in ("cam/displacement", "cam/velocity", "cam/acceleration"):
                q = path.rsplit("/", 1)[-1]
                out[q] = max(out.get(q, 0.0), float(np.max(np.abs(np.asarray(trace.data)), initial=0.0)))
    return out


def compare_traces(a, b, tol: float, ia=None, ib=None, skip_near: list[float] = ()) -> list[str]:
    """Largest difference of every trace at the samples ``ia`` of ``a`` and ``ib`` of ``b``,
    relative to the trace's peak over both runs (a trace absent from one is a problem); a
    mass's trace relative to at least :data:`FAMILY_FLOOR` of its quantity's largest peak."""
    ta, tb = a.traces(), b.traces()
    family = _family_peaks(ta, tb)
    problems = []
    if set(ta) != set(tb):
        problems.append(f"trace sets differ: {sorted(set(ta) ^ set(tb))}")
    if ia is None:
        ia = ib = slice(None)
    for path in sorted(set(ta) & set(tb)):
        if path == "time":
            continue
        xa, xb = np.asarray(ta[path].data), np.asarray(tb[path].data)
        if path == "cam/boundaries_deg" or xa.shape != a.time.shape:
            if xa.shape != xb.shape or np.any(np.abs(xa - xb) > tol * max(1.0, np.max(np.abs(xa), initial=0.0))):
                problems.append(f"{path}: differs")
            continue
        pa, pb = xa[ia], xb[ib]
        peak = max(np.max(np.abs(xa), initial=0.0), np.max(np.abs(xb), initial=0.0))
        if path.startswith(("masses/", "elements/")):
            peak = max(peak, FAMILY_FLOOR * family[path.rsplit("/", 1)[-1]])
        diff = np.abs(pa - pb)
        if diff.size == 0:
            continue
        k = int(np.argmax(diff))
        if diff[k] > tol * peak or not np.isfinite(diff[k]):
            t = a.time[ia][k] if not isinstance(ia, slice) else a.time[k]
            problems.append(f"{path}: differs by {diff[k] / peak if peak else diff[k]:.3g} of its peak "
                            f"{peak:.4g} at t = {t:.9g} s ({pa[k]!r} vs {pb[k]!r})")
    return problems


# --------------------------------------------------------------------------- rounding floor
#: Two runs of one machine agree to the invariant's tolerance or to this multiple of the
#: rounding floor, whichever is larger (check_units, and (a), (b), (c), (g) on machines that
#: sensitive: rigid impacts chattering against stiff branches amplify a last-bit change).
FLOOR_FACTOR = 10.0


def rounding_floor(text: str, nudged_texts: tuple[str, ...], **settings) -> tuple[float, float]:
    """(event time [s], fraction of each trace's peak): the most the run of ``text`` (with
    ``settings``: sample_rate, cycles...) moves when every value of the machine moves by one
    ulp (``nudged_texts``, :func:`machine_gen.nudged`). Infinite when the event sequence
    itself changes (the machine sits at a threshold: no tolerance compares its runs)."""
    a = simulate(load(text), **settings)
    floor_t, floor_x = 0.0, 0.0
    for other in nudged_texts:
        c = simulate(load(other), **settings)
        floor_t = max(floor_t, _event_spread(a, c))
        if math.isinf(floor_t):
            return math.inf, math.inf
        floor_x = max(floor_x, _trace_spread(a, c))
    return floor_t, floor_x


def tolerances(machine, floor: tuple[float, float]) -> tuple[float, float]:
    """The event [s] and trace (of peak) tolerances of ``machine``, widened to
    :data:`FLOOR_FACTOR` times the rounding ``floor`` where that is larger."""
    return max(event_tol(machine), FLOOR_FACTOR * floor[0]), max(trace_tol(machine), FLOOR_FACTOR * floor[1])


# --------------------------------------------------------------------------- (a)
def check_sample_rate(text: str, rates: tuple[float, float], floor: tuple[float, float] = (0.0, 0.0)) -> list[str]:
    """(a) The same machine at two sample rates: the same events (sequence, times to
    1e-9 s) and the same traces at the instants both grids share (1e-9 of each peak);
    at each rate no phantom row and no rigid contact penetrated (:func:`check_no_phantoms`,
    :func:`check_rigid_contacts_hold`, (f)). ``floor``: the rounding floor
    (:func:`rounding_floor`) where the machine is that sensitive."""
    machine = load(text)
    lo, hi = (simulate(machine, sample_rate=r) for r in rates)
    if math.isinf(floor[0]):  # at a threshold: a one-ulp change changes the events already
        return [f"at {rate:g} Hz: {p}" for run, rate in ((lo, rates[0]), (hi, rates[1]))
                for p in check_no_phantoms(run) + check_rigid_contacts_hold(run)]
    ev_tol, tr_tol = tolerances(machine, floor)
    problems = compare_events(event_rows(lo), event_rows(hi), ev_tol)
    for run, rate in ((lo, rates[0]), (hi, rates[1])):
        problems += [f"at {rate:g} Hz: {p}" for p in check_no_phantoms(run) + check_rigid_contacts_hold(run)]
    ia, ib = shared_instants(lo.time, hi.time)
    if len(ia) < len(lo.time) // 2:
        problems.append(f"only {len(ia)} of {len(lo.time)} samples shared")
    return problems + compare_traces(lo, hi, tr_tol, ia, ib)


# --------------------------------------------------------------------------- (b)
def check_warmup(text: str, floor: tuple[float, float] = (0.0, 0.0)) -> list[str]:
    """(b) ``cycles = 2`` equals ``warmup_cycles = 1, cycles = 1`` over the second
    revolution: events (1e-9 s) and traces (1e-9 of each peak), on a sample rate near
    20 kHz that puts a whole number of samples in a revolution."""
    machine = load(text)
    from camsim.cam.program import CamProgram

    period = CamProgram(machine.cam).period
    rate = round(period * 20_000) / period
    if math.isinf(floor[0]):
        return []
    ev_tol, tr_tol = tolerances(machine, floor)
    both = simulate(machine, warmup_cycles=0, cycles=2, sample_rate=rate)
    second = simulate(machine, warmup_cycles=1, cycles=1, sample_rate=rate)
    problems = compare_events(event_rows(both, period - 1e-12, 2 * period + 1e-12, shift=period),
                              event_rows(second), ev_tol, edges=(0.0, period))
    # the cam angle of a continuous run goes on past 360 deg (spec §7): one turn less
    both.cam["angle"] = both.cam["angle"] - 360.0
    if both.cams is not None:  # several cams (issue 38): every cam's, and the shaft's
        for name, traces in both.cams.items():
            if traces is not both.cam:
                traces["angle"] = traces["angle"] - 360.0
        both.shaft_angle = both.shaft_angle - 360.0
    ia, ib = shared_instants(both.time - period, second.time)
    if len(ib) != len(second.time):
        problems.append(f"only {len(ib)} of {len(second.time)} samples of the second revolution found")
    return problems + compare_traces(both, second, tr_tol, ia, ib)


def check_streamed(text: str, tmp: Path) -> list[str]:
    """(b) A streamed run (simulate_to_file) equals the in-memory one: traces and events
    bit for bit (the two share their sample assembly; docs/streaming)."""
    machine = load(text)
    memory = simulate(machine)
    path = Path(tmp) / "streamed.h5"
    streamed = simulate_to_file(machine, path)
    back = streamed.open()
    problems = compare_traces(memory, back, 0.0)
    if len(memory.time) != len(back.time) or np.any(memory.time != back.time):
        problems.append("time bases differ")
    cols = ("time", "element", "kind", "relative_velocity", "peak_force", "contact_duration")

    def rows(events):
        return [tuple(getattr(e, c) for c in cols) for e in events]

    a, b = rows(memory.events), rows(streamed.events)
    if len(a) != len(b) or any(
        x[:3] != y[:3] or any(not (u == v or (math.isnan(u) and math.isnan(v))) for u, v in zip(x[3:], y[3:]))
        for x, y in zip(a, b)
    ):
        problems.append(f"event tables differ: in memory {a} vs streamed {b}")
    return problems


# --------------------------------------------------------------------------- (c)
def permute_text(text: str, seed: int) -> str:
    """The machine of ``text`` with its [[mass]] and [[element]] tables shuffled (and reversed
    if the shuffle left them in order)."""
    doc = tomllib.loads(text)
    rng = random.Random(seed)
    for key in ("mass", "element", "cam", "load"):  # [[cam]] and [[load]] tables too (issues 38, 43): the input's channel order
        if not isinstance(doc.get(key), list):
            continue
        rows = list(doc.get(key, []))
        if len(rows) > 1:
            order = list(range(len(rows)))
            rng.shuffle(order)
            if order == sorted(order):
                order.reverse()
            doc[key] = [rows[i] for i in order]
    return tomli_w.dumps(doc)


def in_order_of(text: str, other: str) -> str:
    """The machine of ``text`` with its [[mass]] and [[element]] tables in the order their
    names have in ``other`` (a station alone, ordered as in a permuted multi-cam file)."""
    doc, ref = tomllib.loads(text), tomllib.loads(other)
    for key in ("mass", "element"):
        rank = {row["name"]: k for k, row in enumerate(ref.get(key, []))}
        if isinstance(doc.get(key), list):
            doc[key] = sorted(doc[key], key=lambda row: rank.get(row["name"], -1))
    return tomli_w.dumps(doc)


def check_permutation(text: str, other: str, floor: tuple[float, float] = (0.0, 0.0)) -> list[str]:
    """(c) Two orderings of one machine: the same events (1e-9 s) and the same traces by
    name (1e-9 of each peak; or within the rounding floor, :func:`rounding_floor`)."""
    machine = load(text)
    if math.isinf(floor[0]):
        return []
    ev_tol, tr_tol = tolerances(machine, floor)
    a, b = simulate(machine), simulate(load(other))
    problems = compare_events(event_rows(a), event_rows(b), ev_tol)
    return problems + compare_traces(a, b, tr_tol)


# --------------------------------------------------------------------------- (d)
#: The SI and US texts of one machine agree to this (times [s] and fraction of peaks)...
UNITS_TOL = 1e-12


def check_units(si_text: str, us_text: str, nudged_texts: tuple[str, ...] = ()) -> list[str]:
    """(d) The machine written in SI and in US units: the same SI parameters (1e-15
    relative: the unit conversion itself) and the same run, events and traces to 1e-12.

    A unit conversion rounds each value by about one ulp, and on a machine with impacts a
    one-ulp change of its parameters alone moves the traces by up to ~1e-10 of peak
    (measured: a mass changed by one ulp, tests/invariants/test_regressions.py). So the
    run of the US text must agree with the SI run to 1e-12, or, where the machine is that
    sensitive, to within FLOOR_FACTOR times the change of the SI run under the
    ``nudged_texts`` (the SI machine with every value moved by ±1 ulp): no worse than
    rounding."""
    ma, mb = load(si_text), load(us_text)
    problems = compare_parameters(ma, mb)
    a, b = simulate(ma), simulate(mb)
    floor_t, floor_x = 0.0, 0.0
    for text in nudged_texts:
        c = simulate(load(text))
        floor_t = max(floor_t, _event_spread(a, c))
        floor_x = max(floor_x, _trace_spread(a, c))
    if math.isinf(floor_t):
        # a one-ulp change of the SI machine already changes its event sequence (a grazing
        # contact at its threshold): no run can be compared at any tolerance, only the
        # parameters
        return problems
    problems += compare_events(event_rows(a), event_rows(b), max(UNITS_TOL, FLOOR_FACTOR * floor_t))
    return problems + compare_traces(a, b, max(UNITS_TOL, FLOOR_FACTOR * floor_x))


def _event_spread(a, b) -> float:
    ra, rb = event_rows(a), event_rows(b)
    if [r[1:] for r in ra] != [r[1:] for r in rb]:
        return math.inf  # a one-ulp change changes the event sequence: no floor applies
    return max((abs(x[0] - y[0]) for x, y in zip(ra, rb)), default=0.0)


def _trace_spread(a, b) -> float:
    worst = 0.0
    ta, tb = a.traces(), b.traces()
    for path in ta:
        if path == "time" or ta[path].data.shape != a.time.shape:
            continue
        x, y = np.asarray(ta[path].data), np.asarray(tb[path].data)
        peak = max(np.max(np.abs(x), initial=0.0), np.max(np.abs(y), initial=0.0))
        if peak > 0:
            worst = max(worst, float(np.max(np.abs(x - y))) / peak)
    return worst


#: Loaded SI parameters of the two texts agree to this (a few roundings of the conversion).
PARAMETER_TOL = 1e-15


def compare_parameters(a, b) -> list[str]:
    """Every number of the two loaded machines (``machine_to_dict``, SI) agrees to
    :data:`PARAMETER_TOL` relative: the unit conversion itself, apart from the run."""
    from camsim.machine.loader import machine_to_dict

    problems = []

    def walk(x, y, path):
        if isinstance(x, dict):
            for key in x:
                if key in ("units", "source", "text", "name"):
                    continue
                walk(x[key], y.get(key) if isinstance(y, dict) else None, f"{path}.{key}")
        elif isinstance(x, (list, tuple)):
            for k, (u, v) in enumerate(zip(x, y or ())):
                walk(u, v, f"{path}[{k}]")
        elif isinstance(x, float) and isinstance(y, float):
            if abs(x - y) > PARAMETER_TOL * max(abs(x), abs(y)):
                problems.append(f"parameter {path}: {x!r} vs {y!r} (relative {abs(x - y) / max(abs(x), abs(y)):.2g})")

    walk(machine_to_dict(a), machine_to_dict(b), "machine")
    return problems


# --------------------------------------------------------------------------- (f)
#: Two rows of one element closer than this [s] are at one instant (the engine's INSTANT_TIME).
SAME_INSTANT = 1e-12
#: Rows of a rigid contact that may share an instant: a plastic landing (impact, stick), and
#: the last bounces of a chatter (each impact a real jump of the velocities; flights of
#: 4e-13 s at 1e-11 m/s before it rests, tests/invariants/machines/chatter-between-stops.toml).
RIGID_SAME_INSTANT = {("impact", "stick"), ("impact", "impact")}


def _law(element) -> str | None:
    """The contact law of a contact or a lash (None for other elements)."""
    return getattr(element, "law_name", None) or getattr(getattr(element, "contact", None), "law_name", None)


def check_no_phantoms(result) -> list[str]:
    """(f) Every row of the event table is a real change (spec §3-§4, issue 34).

    * an impact (or a rejoin) has a positive approach speed;
    * a compliant contact's impact has a finite simulated peak when an output sample lies
      inside its contact (a contact shorter than a sample is the located extremes' case);
    * one element has no two rows at one instant (1e-12 s), except a rigid contact's
      ``impact`` and ``stick`` (a plastic landing) or two impacts (a chatter's last bounces);
    * a compliant contact has no impact while it is closed (two impacts without a release
      between them). Two releases in a row are possible: a lifted contact whose law pushes
      again takes up force without an impact row.
    """
    machine = result.machine
    elements = {e.name: e for e in machine.elements}
    problems = []
    last: dict[str, object] = {}
    time = np.asarray(result.time)
    events = list(result.events)
    for k, ev in enumerate(events):
        element = elements.get(ev.element)
        kind = str(ev.kind)
        rigid = _law(element) == "restitution"
        if kind in ("impact", "rejoin") and not ev.relative_velocity > 0.0:
            problems.append(f"{kind} of {ev.element} at t = {ev.time:.12g} s with approach speed {ev.relative_velocity!r}")
        if kind == "impact" and not rigid:
            t_open = next((e.time for e in events[k + 1:] if e.element == ev.element and str(e.kind) == "release"), time[-1])
            sampled = np.any((time >= ev.time) & (time <= t_open))
            if sampled and not math.isfinite(ev.peak_force):
                problems.append(f"impact of {ev.element} at t = {ev.time:.12g} s without a finite peak")
        prev = last.get(ev.element)
        if prev is not None:
            prev_kind = str(prev.kind)
            if abs(ev.time - prev.time) <= SAME_INSTANT and not (rigid and (prev_kind, kind) in RIGID_SAME_INSTANT):
                problems.append(f"{ev.element}: {prev_kind} and {kind} at one instant, t = {ev.time:.12g} s")
            if not rigid and element is not None and _law(element) is not None and (prev_kind, kind) == ("impact", "impact"):
                problems.append(f"{ev.element}: impact at t = {ev.time:.12g} s while closed (impact at {prev.time:.12g} s)")
        if kind != "jump":
            last[ev.element] = ev
    return problems


#: A rigid contact's penetration on the samples stays below this [m] (the engine removes
#: what a coarse warm-up grid leaves, "≤ nm"; docs/model.md, rigid contacts).
RIGID_PENETRATION_TOL = 1e-9


def check_rigid_contacts_hold(result) -> list[str]:
    """(f) No rigid contact (``law = "restitution"``, alone or as a lash's law) is penetrated
    by more than :data:`RIGID_PENETRATION_TOL` at any sample: a landing that was taken for a
    touch, or a crossing missed at a restart, would leave the bodies inside each other
    (found so: 20 µm for 2.4 ms after a chatter whose last flight was below the event
    accuracy, issue 34)."""
    problems = []
    x = {name: np.asarray(traces["displacement"]) for name, traces in result.masses.items()}
    x["ground"] = np.zeros_like(result.time)
    x["cam"] = np.asarray(result.cam["displacement"])
    for name, traces in (getattr(result, "cams", None) or {}).items():  # several cams (issue 38)
        x[name] = np.asarray(traces["displacement"])
    for element in result.machine.elements:
        if _law(element) != "restitution":
            continue
        d = x[element.upper] - x[element.lower]
        if element.type_name == "lash":
            low, high = element.low, element.high
            pen = np.maximum(low - d, d - high)
        else:
            pen = element.gap - d
        k = int(np.argmax(pen))
        if pen[k] > RIGID_PENETRATION_TOL:
            problems.append(f"rigid contact {element.name} penetrated by {pen[k]:.3g} m at t = {result.time[k]:.9g} s")
    return problems


# --------------------------------------------------------------------------- (g)
def check_located_extremes(text: str, rates: tuple[float, float], floor: tuple[float, float] = (0.0, 0.0)) -> list[str]:
    """(g) The same machine at two sample rates: the same events, then the same located
    extremes (:func:`check_extremes`) to the machine's trace tolerance (or within the
    rounding ``floor``, :func:`rounding_floor`)."""
    machine = load(text)
    if math.isinf(floor[0]):
        return []
    ev_tol, tr_tol = tolerances(machine, floor)
    lo, hi = (simulate(machine, sample_rate=r) for r in rates)
    problems = compare_events(event_rows(lo), event_rows(hi), ev_tol)
    return problems or check_extremes(lo, hi, tr_tol, max(PEAK_TIME_TOL, FLOOR_FACTOR * floor[0]))


#: The instant of a located maximum agrees to this [s] where the maximum is sharp (see
#: check_extremes): the event accuracy.
PEAK_TIME_TOL = 1e-9
#: Two runs whose peak values agree but whose instants lie further apart than this [s] have
#: found two maxima of one height (a link's rejoin pressing twice as hard, 9e-5 s apart): the
#: instant is not defined, the value is compared.
EQUAL_PEAKS = 1e-6


def check_extremes(a, b, tol: float, time_tol: float | None = None) -> list[str]:
    """(g) The extremes two runs of one machine located on the solution (spec §4): the same
    values and instants at any sample rate.

    * every impact's simulated peak force (the event table's ``peak_force``) to ``tol`` of
      the largest impact peak of the run, and its instant (``peak_time``) to
      :data:`PEAK_TIME_TOL` where the peak is sharp — not at a plateau, an impact's first
      instant, or between two maxima of one height (:data:`EQUAL_PEAKS`), where a maximum's
      instant is not defined to better than √(δF/F̈);
    * every located maximum and minimum of the summary (``RunResult.located``: masses'
      displacement, velocity, acceleration, element forces, cam contact force...) to ``tol``
      of the quantity's scale (its own largest magnitude, at least :data:`FAMILY_FLOOR` of
      the largest of its kind in the machine and the cam, as the traces).

    ``tol`` is the machine's trace tolerance (:func:`trace_tol`): an extreme is a value of
    the solution, as invariant as the solution itself.
    """
    time_tol = PEAK_TIME_TOL if time_tol is None else time_tol
    problems = []
    impacts_a, impacts_b = a.events.impacts(), b.events.impacts()
    peaks = [e.peak_force for e in (*impacts_a, *impacts_b) if math.isfinite(e.peak_force)]
    scale = max((abs(p) for p in peaks), default=0.0)
    for x, y in zip(impacts_a, impacts_b):
        if math.isnan(x.peak_force) and math.isnan(y.peak_force):
            continue
        if not abs(x.peak_force - y.peak_force) <= tol * scale:
            problems.append(f"peak force of the {x.element} impact at t = {x.time:.9g} s: {x.peak_force!r} vs "
                            f"{y.peak_force!r} ({abs(x.peak_force - y.peak_force) / scale:.3g} of the largest peak)")
        elif (x.peak_time - x.time > time_tol and time_tol < abs(x.peak_time - y.peak_time) <= EQUAL_PEAKS
              and _sharp(a, x)):
            problems.append(f"peak instant of the {x.element} impact at t = {x.time:.9g} s: {x.peak_time!r} vs "
                            f"{y.peak_time!r}")
    la, lb = a.located or {}, b.located or {}
    if set(la) != set(lb):
        problems.append(f"located quantities differ: {sorted(set(la) ^ set(lb))}")
    family: dict[str, float] = {}
    for located in (la, lb):
        for path, hit in located.items():
            kind = path.rsplit("/", 1)[-1]
            family[kind] = max(family.get(kind, 0.0), abs(hit["max"].value), abs(hit["min"].value))
    for run in (a, b):  # the cam's motion is a mass quantity's scale too (as for the traces)
        for kind in ("displacement", "velocity", "acceleration"):
            family[kind] = max(family.get(kind, 0.0), float(np.max(np.abs(run.cam[kind]), initial=0.0)))
    for path in sorted(set(la) & set(lb)):
        kind = path.rsplit("/", 1)[-1]
        own = max(abs(h[w].value) for h in (la[path], lb[path]) for w in ("max", "min"))
        qscale = max(own, FAMILY_FLOOR * family[kind])
        for which in ("max", "min"):
            u, v = la[path][which].value, lb[path][which].value
            if not abs(u - v) <= tol * qscale:
                problems.append(f"located {which} of {path}: {u!r} vs {v!r} ({abs(u - v) / qscale:.3g} of its scale)")
    return problems


def _sharp(run, impact) -> bool:
    """Whether an impact's located peak is a sharp maximum: the force's samples around it
    fall by more than 1e-6 of the peak within 1e-5 s (a plateau's instant is arbitrary)."""
    force = run.elements.get(impact.element)
    if force is None:
        return False
    near = np.abs(run.time - impact.peak_time) <= 1e-5
    if np.count_nonzero(near) < 2:
        return True
    values = np.abs(np.asarray(force)[near])
    return float(np.max(values) - np.min(values)) > 1e-6 * abs(impact.peak_force)


# --------------------------------------------------------------------------- (h) several cams
#: (h): a station on the shaft against the station alone. The two runs step on different
#: internal grids (the combined machine's fastest mode sets its step), so their located
#: events differ by the location's own accuracy (1e-10 s guaranteed, ~1e-12 s typical) and a
#: stiff contact's force near an impact by that times its rate: measured up to 5e-9 of peak.
STATION_TRACE_TOL = 1e-7


def check_stations(multi_text: str, station_texts: list[str], prefixes: list[str]) -> list[str]:
    """(h) Several cams on a rigid shaft couple nothing (spec §9): every station of the
    multi-cam machine equals the same station run alone with its phase — its masses' and
    elements' traces (:data:`STATION_TRACE_TOL` of each peak, compared by name) and its
    events (1e-9 s)."""
    try:
        multi = simulate(load(multi_text))
    except Exception as exc:  # noqa: BLE001 - a station that runs alone must run on the shaft
        alone_ok = []
        for text in station_texts:
            try:
                simulate(load(text))
                alone_ok.append(True)
            except Exception:  # noqa: BLE001
                alone_ok.append(False)
        if all(alone_ok):
            return [f"the multi-cam machine fails where every station alone runs: {type(exc).__name__}: {exc}"]
        return []  # a station that cannot run alone cannot run on the shaft either: nothing to compare
    problems = []
    for text, pre in zip(station_texts, prefixes):
        machine = load(text)
        alone = simulate(machine)
        tol = max(trace_tol(machine), STATION_TRACE_TOL)
        mine = [r for r in event_rows(multi) if r[1].startswith(pre) or r[1] == f"c{pre[1:-1]}"]
        ref = [r if not r[1] == "cam" else (r[0], f"c{pre[1:-1]}", r[2]) for r in event_rows(alone)]
        problems += [f"station {pre}: {p}" for p in compare_events(mine, ref, event_tol(machine))]
        for name, traces in alone.masses.items():
            for quantity, data in traces.items():
                peak = max(float(np.max(np.abs(data), initial=0.0)), 1e-300)
                diff = float(np.max(np.abs(multi.masses[name][quantity] - data), initial=0.0))
                if diff > tol * peak:
                    problems.append(f"station {pre}: masses/{name}/{quantity} differs by {diff / peak:.3g} of its peak")
        for name, data in alone.elements.items():
            peak = max(float(np.max(np.abs(data), initial=0.0)), 1e-300)
            diff = float(np.max(np.abs(multi.elements[name] - data), initial=0.0))
            if diff > tol * peak and diff > 1e-12:
                problems.append(f"station {pre}: elements/{name}/force differs by {diff / peak:.3g} of its peak")
    return problems

"""Resolving the discretisation of distributed elements (rods) when a machine is loaded.

A rod without ``segments`` gets the smallest N whose highest mode is above ten times the
cam's significant harmonic and above 5/τ of the fastest impact it takes part in
(:func:`camsim.elements.rod.choose_segments`, spec §3). τ is estimated before any run:
every element that shares a node with the rod and has a compliant impact
(``impact_duration``: linear, power-law, Hertz, Adams contacts, the rejoin of a preloaded
link) is asked how long an undamped impact of its two nodes lasts,

* each node's mass being its own plus half the mass of every rod ending there (the rod's
  N-independent share; ground, the cam and a driven mass count as infinite) — and, when the
  impact so estimated lasts longer than such a rod's wave round trip 2L/c, the whole rod and
  the mass at its far end (the impact then moves them together: a screw backed by its
  carrier), and
* at the approach speed v: the largest of the cam's peak speed on the model axis, the
  ``[initial]`` speeds and √(2·g·h) of an ``[initial]`` drop height h with gravity
  (1 m/s when none of these is known).

After the run, impacts that were faster than the discretisation resolves are reported
(camsim.run.rodcheck).
"""

from __future__ import annotations

import dataclasses
import math

from camsim.elements import FIXED_NODES, Element
from camsim.machine.description import Cam, InitialCondition, Mass, Simulation

__all__ = ["resolve_segments", "approach_speed", "fastest_impact"]

#: Approach speed [m/s] assumed when the machine gives none (no cam, no initial speeds).
DEFAULT_SPEED = 1.0


def approach_speed(cam: Cam | None, initial: list[InitialCondition], simulation: Simulation,
                   cams=()) -> tuple[float, str]:
    """(v [m/s], where it comes from) for the impact-duration estimates (module docstring);
    ``cams``: every cam of a machine with several (default ``cam`` alone; issue 38)."""
    candidates: list[tuple[float, str]] = []
    for one in _cams(cam, cams):
        from camsim.cam.peaks import sample_revolution
        from camsim.cam.program import CamProgram

        program = CamProgram(one)
        if program.speed:
            v = float(max(abs(sample_revolution(program, 3600)["velocity"])))
            candidates.append((v, "the cam's peak speed" if len(cams) < 2 else f"cam {one.name}'s peak speed"))
    for ic in initial:
        if ic.velocity:
            candidates.append((abs(ic.velocity), f"initial.{ic.mass}.velocity"))
        if ic.displacement and ic.displacement > 0 and simulation.gravity > 0:
            candidates.append((math.sqrt(2.0 * simulation.gravity * ic.displacement), f"a drop from initial.{ic.mass}"))
    candidates = [c for c in candidates if c[0] > 0]
    if not candidates:
        return DEFAULT_SPEED, "assumed (no cam and no initial speed)"
    return max(candidates)


def fastest_impact(rod: Element, elements: list[Element], node_mass, v: float) -> tuple[float, str] | None:
    """(τ [s], element name) of the shortest estimated impact among the elements that share a
    node with ``rod`` (None when none has a compliant impact).

    ``node_mass(node, far)`` [kg]: the node's mass for the estimate, with (``far``) or without
    the rods ending there and what they carry (module docstring).
    """
    best = None
    for e in elements:
        if e is rod or e.compound or not set(e.nodes) & set(rod.nodes):
            continue
        tau = e.impact_duration(node_mass(e.lower, False), node_mass(e.upper, False), v)
        transits = [r.transit_time for r in elements if r.compound and set(r.nodes) & set(e.nodes)]
        if tau is not None and transits and tau > min(transits):
            tau = e.impact_duration(node_mass(e.lower, True), node_mass(e.upper, True), v)
        if tau is not None and tau > 0 and (best is None or tau < best[0]):
            best = (tau, e.name)
    return best


def _cams(cam: Cam | None, cams) -> list[Cam]:
    return list(cams) if len(cams) > 1 else ([cam] if cam is not None else [])


def resolve_segments(elements: list[Element], masses: list[Mass], cam: Cam | None, simulation: Simulation,
                     initial: list[InitialCondition], cams=()) -> list[Element]:
    """``elements`` with every compound element's N resolved (and its reason set);
    ``cams``: every cam of a machine with several (default ``cam`` alone; issue 38: the
    highest significant harmonic of any cam, each cam and what it drives prescribed)."""
    compound = [e for e in elements if e.compound]
    if not compound:
        return elements
    written = {m.name: m.mass for m in masses}
    every = _cams(cam, cams)
    fixed = set(FIXED_NODES) | {c.name for c in every if c.name} | {c.drives for c in every if c.drives}
    harmonic_n, harmonic = 0, 0.0
    for one in every:
        from camsim.cam.harmonics import significant_harmonic
        from camsim.cam.program import CamProgram

        n_one, f_one = significant_harmonic(CamProgram(one))
        if f_one > harmonic or not harmonic_n:
            harmonic_n, harmonic = n_one, f_one
    v, v_from = approach_speed(cam, initial, simulation, cams=cams)

    def node_mass(node: str, far: bool = False) -> float:
        if node in fixed:
            return math.inf
        if not far:
            return written[node] + sum(0.5 * e.rod_mass for e in compound if node in e.nodes)
        total = written[node]
        for e in compound:
            if node in e.nodes:
                other = e.upper if e.lower == node else e.lower
                total += e.rod_mass + (math.inf if other in fixed else written[other])
        return total

    out = []
    for e in elements:
        if e.compound:
            if e.segments is not None:
                e = dataclasses.replace(e, segments_reason=f"{e.segments} segments (given); highest mode "
                                        f"f_N = N*c/(pi*L) = {e.highest_frequency():.4g} Hz")
            else:
                impact = fastest_impact(e, elements, node_mass, v)
                n, reason = e.choose_segments(harmonic, impact[0] if impact else None)
                where = []
                if harmonic_n:
                    where.append(f"cam harmonic n = {harmonic_n}")
                if impact:
                    where.append(f"fastest impact: element {impact[1]} at {v:.3g} m/s ({v_from})")
                e = dataclasses.replace(e, segments=n, segments_reason=f"{n} segments (default): {reason}"
                                        + (f" [{'; '.join(where)}]" if where else ""))
        out.append(e)
    return out

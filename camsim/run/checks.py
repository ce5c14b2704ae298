"""After a run: rods against the impacts they saw, Hertz contacts against their materials' yield.

Both read only the machine and the event table, so an in-memory and a streamed run give the
same rows and warnings (issue 39).

* A rod's discretisation resolves impacts whose contact duration τ satisfies 5/τ ≤ f_N, its
  highest mode (camsim.elements.rod). An impact on an element that shares a node with the
  rod and lasted less is *too fast for the discretisation*: the warning names the rod and the
  ``segments`` that would resolve it.
* A Hertz contact's peak pressure at its largest simulated impact force, against the
  pressure at which the weaker material first yields (1.60·Y point, 1.67·Y line contact;
  camsim.physics.hertz).
* Each impact's simulated peak against Johnson's bounds (issue 44): the bounds estimate the
  *impulsive* force, the part above what the interface holds at rest (a preloaded link's
  preload; nothing for a contact with a gap), so the comparison takes the peak minus that
  (:func:`johnson_rows`).
"""

from __future__ import annotations

import math

__all__ = ["JOHNSON_BAND", "impact_preload", "johnson_rows", "rod_rows", "rod_warnings", "contact_stress_rows", "stress_warnings"]

#: How far outside Johnson's bounds an impulsive peak may lie and still agree with them: the
#: closed forms take the two bodies alone, with the rest of the machine removed (thesis §3.3).
JOHNSON_BAND = 0.2


def _impacts_on(machine, rod, events) -> list:
    """Impacts with a duration on elements sharing a node with ``rod``."""
    near = {e.name for e in machine.elements if e is not rod and set(e.nodes) & set(rod.nodes)}
    return [ev for ev in events if ev.kind.is_impact and ev.element in near
            and math.isfinite(ev.contact_duration) and ev.contact_duration > 0]


def rod_warnings(machine, events) -> list[str]:
    """One warning per rod whose fastest observed impact is too fast for its segments."""
    out = []
    for rod in machine.elements:
        if not rod.compound:
            continue
        impacts = _impacts_on(machine, rod, events)
        if not impacts:
            continue
        fastest = min(impacts, key=lambda ev: ev.contact_duration)
        tau = fastest.contact_duration
        top = rod.highest_frequency()
        if 5.0 / tau <= top * (1 + 1e-9):
            continue
        need = math.ceil(5.0 / tau / (top / rod.segments))
        out.append(
            f"rod {rod.name}: the impact of {fastest.element} at t = {fastest.time:.6g} s lasted {tau:.3g} s; "
            f"5/tau = {5.0 / tau:.4g} Hz is above the rod's highest mode {top:.4g} Hz ({rod.segments} segments): "
            f"too fast for the discretisation (the wave it sends is smeared); set element.{rod.name}.segments "
            f"to at least {need}"
        )
    return out


def rod_rows(machine) -> dict[str, dict]:
    """Each rod's discretisation and properties (JSON-able, SI), by name."""
    out = {}
    for rod in machine.elements:
        if rod.compound:
            out[rod.name] = {
                "segments": rod.segments, "segments_reason": rod.segments_reason,
                "highest_mode_hz": rod.highest_frequency(), "wave_speed": rod.wave_speed,
                "impedance": rod.impedance, "mass": rod.rod_mass, "transit_time": rod.transit_time,
                "yield_strength": rod.yield_strength,
                "interior_nodes": [rod.interior_nodes()[0], rod.interior_nodes()[-1]] if rod.interior_nodes() else [],
            }
    return out


def contact_stress_rows(machine, events) -> list[dict]:
    """Hertz contacts: peak pressure at their largest simulated impact force, against yield."""
    rows = []
    for element in machine.elements:
        forces = [(ev.peak_force, ev.time) for ev in events
                  if ev.kind.is_impact and ev.element == element.name and math.isfinite(ev.peak_force)]
        if not forces:
            continue
        force, time = max(forces)
        row = element.stress(force)
        if row is not None:
            rows.append({**row, "time": time})
    return rows


def stress_warnings(rows: list[dict]) -> list[str]:
    """A warning for each contact whose peak pressure exceeds its first-yield pressure."""
    return [
        f"contact {r['element']}: peak Hertz pressure {r['peak_pressure'] / 1e6:.4g} MPa at the impact of t = "
        f"{r['time']:.6g} s ({r['peak_force']:.4g} N) exceeds the first-yield pressure {r['yield_pressure'] / 1e6:.4g} "
        f"MPa of {r['yields_first']}: the contact yields (the elastic law then over-predicts force and rebound)"
        for r in rows if r["ratio"] is not None and r["ratio"] > 1.0
    ]


def impact_preload(element) -> float:
    """The force [N] an impact's interface holds at rest, when the element carries no force: a
    preloaded link's preload (its parts are pressed together by it), 0 for a contact with a gap.

    The element's own :meth:`~camsim.elements.base.Element.impact_force` at zero element force,
    so every kind answers through the protocol."""
    import numpy as np

    force = element.impact_force(np.zeros(1))
    return 0.0 if force is None or not np.isfinite(force[0]) else float(force[0])


def johnson_rows(machine, events) -> list[dict]:
    """Each impact's simulated peak against Johnson's bounds, preload excluded (issue 44).

    Returns
    -------
    list of dict
        Per impact with finite bounds and peak: ``element``, ``time`` [s], ``peak`` (the
        simulated peak, as the event table has it) [N], ``preload`` (held at rest) [N],
        ``impulsive`` = peak − preload [N], ``lower``/``upper`` (Johnson's bounds) [N],
        ``within``: whether ``impulsive`` lies within the bounds widened by :data:`JOHNSON_BAND`.
    """
    by_name = {e.name: e for e in machine.elements}
    rows = []
    for ev in events:
        if not ev.kind.is_impact or ev.element not in by_name:
            continue
        lo, hi, peak = ev.johnson_lower, ev.johnson_upper, ev.peak_force
        if not (math.isfinite(lo) and math.isfinite(hi) and math.isfinite(peak)):
            continue
        preload = impact_preload(by_name[ev.element])
        impulsive = peak - preload
        within = (1.0 - JOHNSON_BAND) * lo <= impulsive <= (1.0 + JOHNSON_BAND) * hi
        rows.append({"element": ev.element, "time": ev.time, "peak": peak, "preload": preload, "impulsive": impulsive,
                     "lower": lo, "upper": hi, "within": bool(within)})
    return rows

"""The verdict tiles of a run page: each says what it checked, against what limit, and by which rule.

A tile is OK, CHECK or FAIL by a rule written on it (issue 44: "every CDTM page is CHECK
without a criterion"):

==================  ========================================================  =====================
tile                checked against                                           FAIL / CHECK when
==================  ========================================================  =====================
Follower jump       the cam contact force against 0 (its smallest value is    it crosses 0 (FAIL)
                    the jump margin)
Impacts             each impact's impulsive peak (simulated peak minus the    outside (CHECK)
                    preload the interface holds at rest) against Johnson's
                    bounds widened by ``JOHNSON_BAND``
Contact stress      a Hertz contact's peak pressure against the first-yield   above it (FAIL)
                    pressure of its weaker material
Rod stress          a rod's largest axial stress against its yield strength   above it (FAIL)
Cam geometry        the pressure angle against its limit (the Hertz stress    above it (FAIL)
                    is shown; no allowable stress is written for it)
Periodicity         the state one revolution apart, relative to its peak,     above (CHECK)
                    against 1e-3
Warnings            every warning the run printed (stored in the file)        any (CHECK)
==================  ========================================================  =====================

Every value comes from the result file or the run result hub (:mod:`camsim.run.checks`,
:meth:`camsim.run.result.RunResult.summary`) and is shown through the page's display units.
"""

from __future__ import annotations

import math

import numpy as np

from camsim.reports.page import Source, esc, fmt, verdict

__all__ = ["PERIODIC_RESIDUAL", "verdict_tiles"]

#: Largest periodicity residual (relative to peak) of a steady state.
PERIODIC_RESIDUAL = 1e-3


def verdict_tiles(source: Source, view, design: dict | None, hub: dict | None) -> list[str]:
    """The tiles of one run layout (``view``: a :class:`camsim.reports.sections.RunView`).

    ``design`` is the hub's cam design summary (with ``[cam.geometry]``), ``hub`` the hub's
    summary of the run (None for a file that does not hold every trace: the rod row is then
    left out).
    """
    tiles = [_jump(source, view), _impacts(source, view)]
    tiles += _contact_stress(source, view)
    tiles += _rod_stress(source, hub)
    if design is not None:
        tiles.append(_design(source, design))
    tiles.append(_periodicity(source, view))
    tiles.append(_warnings(source, view))
    return tiles


def _rule(value: float) -> str:
    """A limit camsim states (not a value of the result): marked as such for a reader and for tests."""
    return f"<span class=rule>{fmt(value)}</span>"


def _jump(source: Source, view) -> str:
    sm = view.summary
    speed = getattr(getattr(view.machine, "cam", None), "speed", float("nan"))
    at = source.quantity(speed, "rad/s", ".6g", "speed_rpm")
    rule = f"Checked: the cam contact force against {_rule(0)} (the follower leaves the cam where it would pull)."
    if "jump" not in sm:
        return verdict("Follower jump", "nodata", "no data: the file has no /summary with the run's jump flag "
                       "(written by an older camsim)", "jump")
    if sm.get("jump"):
        cam_contacts = {e.name for e in view.machine.elements if e.unilateral and "cam" in e.nodes}
        where = ""
        for i in range(view.n_events):
            kind, element = view.event(i, "kind"), view.event(i, "element")
            if kind == "jump" or (kind == "release" and element in cam_contacts):
                where = (f"; first at cam angle {source.quantity(view.event(i, 'angle_deg'), 'deg', '.2f', 'jump_angle')} "
                         f"(t = {source.quantity(view.event(i, 'time'), 's', '.5f')})")
                break
        return verdict("Follower jump", "fail", f"{rule} FAIL: the follower leaves the cam at {at}{where}.", "jump")
    lo = sm.get("min_cam_contact_force", float("nan"))
    if isinstance(lo, float) and math.isnan(lo):  # issue 35: no bare "–"
        from camsim.run.result import missing_reason

        why = missing_reason(view.machine, "min_cam_contact_force", {**sm, "status": "ok"}) or "not in the file"
        return verdict("Follower jump", "ok", f"{rule} None at {at}; no smallest cam contact force: {esc(why)}.", "jump")
    return verdict("Follower jump", "ok", f"{rule} None at {at}: the smallest cam contact force "
                   f"{source.quantity(lo, 'N', key='min_cam_contact_force')} stays above {_rule(0)} (the jump margin).", "jump")


def _impacts(source: Source, view) -> str:
    from camsim.run.checks import JOHNSON_BAND, johnson_rows

    sm = view.summary
    n = int(sm.get("impacts", len(view.impact_rows())))
    if not n:
        return verdict("Impacts", "ok", f"{source.number(0, '', key='impacts')} impacts: nothing to check.", "impacts")
    rule = (f"Checked: each impact's impulsive peak (the simulated peak minus the preload its interface holds at rest) "
            f"against Johnson's bounds ±{_rule(100 * JOHNSON_BAND)} % (closed forms of the two bodies alone).")
    detail = (f"{source.number(n, '', key='impacts')} impacts; largest approach speed "
              f"{source.quantity(sm.get('max_impact_velocity'), 'm/s', key='max_impact_velocity')}.")
    rows = johnson_rows(view.machine, view.event_list())
    if not rows:
        return verdict("Impacts", "info", f"{detail} No impact has finite Johnson bounds (rigid contacts): nothing to "
                       "compare.", "impacts")
    outside = [r for r in rows if not r["within"]]
    worst = max(outside or rows, key=lambda r: r["impulsive"])
    shown = (f"{esc(worst['element'])} at t = {source.quantity(worst['time'], 's', '.5f')}: impulsive peak "
             f"{source.quantity(worst['impulsive'], 'N', key='impulsive_peak')} (simulated "
             f"{source.quantity(worst['peak'], 'N')} − preload {source.quantity(worst['preload'], 'N')}) against "
             f"{source.quantity(worst['lower'], 'N')} to {source.quantity(worst['upper'], 'N')}")
    if outside:
        return verdict("Impacts", "warn", f"{rule} CHECK: {source.number(len(outside), '', key='impacts_outside')} of "
                       f"{source.number(len(rows), '')} outside, e.g. {shown}; {detail}", "impacts")
    return verdict("Impacts", "ok", f"{rule} All {source.number(len(rows), '')} within; the largest: {shown}. {detail}",
                   "impacts")


def _contact_stress(source: Source, view) -> list[str]:
    from camsim.run.checks import contact_stress_rows

    tiles = []
    for r in contact_stress_rows(view.machine, view.event_list()):
        if r.get("ratio") is None or not np.isfinite(r.get("yield_pressure", np.nan)):
            continue
        fails = r["ratio"] > 1.0
        tiles.append(verdict(
            f"Contact stress: {r['element']}", "fail" if fails else "ok",
            f"Checked: the peak Hertz pressure at the largest impact against the first-yield pressure of "
            f"{esc(r['yields_first'])}. {'FAIL: the contact yields' if fails else 'Below it'}: "
            f"{source.quantity(r['peak_pressure'], 'Pa', key='peak_pressure')} at "
            f"{source.quantity(r['peak_force'], 'N')} (t = {source.quantity(r['time'], 's', '.6f')}) against "
            f"{source.quantity(r['yield_pressure'], 'Pa', key='yield_pressure')}"
            + (" (the elastic law then over-predicts force and rebound)." if fails else "."), "contact-stress"))
    return tiles


def _rod_stress(source: Source, hub: dict | None) -> list[str]:
    tiles = []
    for name, row in ((hub or {}).get("rods") or {}).items():
        stress, limit = row.get("max_stress"), row.get("yield_strength")
        if stress is None:
            continue
        value = stress["value"]
        if not limit:
            tiles.append(verdict(f"Rod stress: {name}", "info", f"Largest |axial stress| {source.quantity(value, 'Pa')} "
                                 "at t = " + source.quantity(stress["time"], "s", ".6f") + "; no yield strength "
                                 "given for its material: not checked.", "rod-stress"))
            continue
        fails = value > limit
        tiles.append(verdict(
            f"Rod stress: {name}", "fail" if fails else "ok",
            f"Checked: the largest |axial stress| against the yield strength. {'FAIL: above it' if fails else 'Below it'}: "
            f"{source.quantity(value, 'Pa', key='rod_stress')} at t = {source.quantity(stress['time'], 's', '.6f')} against "
            f"{source.quantity(limit, 'Pa', key='yield_strength')} (<span class=derived data-of='ratio'>{fmt(100 * value / limit, '.3g')}</span> %).",
            "rod-stress"))
    return tiles


def _design(source: Source, design: dict) -> str:
    pa, limit = design.get("max_pressure_angle"), design.get("pressure_angle_limit")
    fails = pa is not None and limit is not None and pa > limit
    return verdict(
        "Cam geometry", "fail" if fails else "ok",
        "Checked: the pressure angle against its limit (max_pressure_angle). "
        f"{'FAIL: above it' if fails else 'Within it'}: {source.quantity(pa, 'deg', key='max_pressure_angle')} against "
        f"{source.quantity(limit, 'deg', key='pressure_angle_limit')}. Shown, not checked (no allowable stress in the "
        f"machine file): peak Hertz stress {source.quantity(design.get('peak_hertz_stress'), 'Pa', key='peak_hertz_stress')}, "
        f"peak torque {source.quantity(design.get('peak_torque'), 'N*m', key='peak_torque')}.", "design")


def _periodicity(source: Source, view) -> str:
    sm = view.summary
    res = sm.get("periodicity_residual", float("nan"))
    rule = f"Checked: the state one revolution apart, relative to its peak, against {_rule(PERIODIC_RESIDUAL)} (a steady state)."
    if not np.isfinite(res):  # issue 35: no data is not a verdict
        from camsim.run.result import missing_reason

        why = "the file has no /summary" if not sm else missing_reason(view.machine, "periodicity_residual", {"periodicity_residual": res})
        return verdict("Periodicity", "nodata", f"no data: {esc(why or 'not computed')}.", "periodicity")
    ok = res < PERIODIC_RESIDUAL
    return verdict("Periodicity", "ok" if ok else "warn",
                   f"{rule} {'Steady' if ok else 'CHECK: not yet steady (add warm-up revolutions)'}: residual "
                   f"{source.number(res, '', '.3g', key='periodicity_residual')} [-].", "periodicity")


def _warnings(source: Source, view) -> str:
    """Every warning the run printed, as it printed them (in the page's units)."""
    from camsim.display import in_units

    if view.warnings is None:
        return verdict("Warnings", "nodata", "no data: the file does not record the run's warnings (written by an "
                       "older camsim).", "warnings")
    texts = [esc(n) for n in view.notes] + [esc(in_units(w, source.display)) for w in view.warnings]
    if not texts:
        return verdict("Warnings", "ok", "Checked: the warnings the run printed. None.", "warnings")
    items = "".join(f"<br><span class=message>• {t}</span>" for t in texts)
    return verdict("Warnings", "warn", f"Checked: the warnings the run printed. CHECK: {source.number(len(texts), '')} "
                   f"printed:{items}", "warnings")

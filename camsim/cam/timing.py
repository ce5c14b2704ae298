"""The timing of several cams on one shaft: every cam's follower motion on one angle axis,
and the kinematic clearances between stations (spec §9, ``camsim cam``).

A cam's follower motion on the model axis is s_q(θ + φ_q) at shaft angle θ (φ_q its
phase). A ``[[clearance]]`` pair's distance is d(θ) = (x_B + offset_B) − (x_A + offset_A);
kinematically a part's position is known where a cam prescribes it: a cam node (x = s_q)
or a mass a cam drives. Pairs with a free mass need the dynamics (``camsim run``).

The smallest distance over a revolution is located, not sampled: the minimum of the dense
samples (0.01°) is refined by bounded Brent minimisation on the cam laws (to 1e-12 rad).
"""

from __future__ import annotations

import math

import numpy as np

from camsim.cam.program import CamProgram

__all__ = ["timing_samples", "kinematic_position", "kinematic_clearances"]

_TWO_PI = 2.0 * math.pi


def _program(cam) -> CamProgram:
    return CamProgram(cam)


def timing_samples(machine, points: int = 3601) -> dict[str, np.ndarray]:
    """Every cam's displacement on the model axis over one revolution of the shaft.

    Returns
    -------
    dict
        ``angle`` [deg] (the shaft's, from its start angle over 360°), and per cam name its
        displacement [m] there.
    """
    cams = machine.cams
    start = float(cams[0].start_angle)
    theta = start + np.linspace(0.0, _TWO_PI, points)
    out = {"angle": np.degrees(theta)}
    for cam in cams:
        program = _program(cam)
        out[cam.name] = program.ratio * program.lift(theta + float(cam.phase))[0]
    return out


def kinematic_position(machine, node: str):
    """x(θ_shaft) of a node a cam prescribes (a cam node or a driven mass) as a function of
    shaft angles [rad] → [m]; None for a free mass."""
    for cam in machine.cams:
        if node in (cam.name, cam.drives):
            program = _program(cam)
            phase = float(cam.phase)
            return lambda theta, p=program, ph=phase: p.ratio * p.lift(np.asarray(theta, dtype=float) + ph)[0]
    return None


def kinematic_clearances(machine, points: int = 36001) -> list[dict]:
    """The smallest distance of each ``[[clearance]]`` pair over one revolution, kinematically.

    Returns
    -------
    list of dict
        Per pair: ``name``, ``between``, ``allowed`` [m], and ``minimum_distance`` [m] with
        ``shaft_angle_deg`` [deg, 0–360] where it occurs and ``collides`` (below ``allowed``)
        — or ``reason`` (a part is a free mass: its motion needs ``camsim run``).
    """
    out = []
    start = float(machine.cams[0].start_angle) if machine.cams else 0.0
    for c in machine.clearances:
        entry = {"name": c.name, "between": [c.a.node, c.b.node], "allowed": c.minimum}
        xa, xb = kinematic_position(machine, c.a.node), kinematic_position(machine, c.b.node)
        if xa is None or xb is None:
            free = c.a.node if xa is None else c.b.node
            entry.update(minimum_distance=None, shaft_angle_deg=None, collides=None,
                         reason=f"{free} is a free mass: its motion needs the dynamics (camsim run checks it)")
            out.append(entry)
            continue

        def distance(theta, xa=xa, xb=xb, c=c):
            return (xb(theta) + c.b.offset) - (xa(theta) + c.a.offset)

        theta = start + np.linspace(0.0, _TWO_PI, points)
        d = distance(theta)
        k = int(np.argmin(d))
        best_t, best_d = float(theta[k]), float(d[k])
        step = _TWO_PI / (points - 1)
        from scipy.optimize import minimize_scalar  # only where a clearance is asked for

        res = minimize_scalar(lambda x: float(distance(np.array([x]))[0]), bounds=(best_t - step, best_t + step),
                              method="bounded", options={"xatol": 1e-12})
        if res.fun < best_d:
            best_t, best_d = float(res.x), float(res.fun)
        entry.update(minimum_distance=best_d, shaft_angle_deg=math.degrees(best_t) % 360.0,
                     collides=best_d < c.minimum)
        out.append(entry)
    return out

"""Cam geometry: pressure angle, radii of curvature, pitch curve and cam surface (spec §2).

Pure, vectorised functions of the **roller-side** motion s(θ) and its derivatives with
respect to cam angle, s′ = ds/dθ, s″, s‴ (what :meth:`camsim.cam.CamProgram.lift`
returns, before the linkage ``ratio``: the ratio maps roller motion to the model axis and
has no place in the cam's shape). Lengths in m, angles in rad, unless a name says deg.

Frames and signs (see ``docs/cam-design.md`` for the labelled figure):

* **Ground frame**: cam centre O at the origin, x to the right, y up, as the profile is
  drawn. At θ = 0 (the start of the first segment) a translating follower's axis is
  vertical above O; an oscillating follower's roller sits on the prime circle straight
  above O, its pivot to the right of the roller.
* **Rotation** σ = +1 for ``"ccw"`` and −1 for ``"cw"``. A cam point fixed to the cam at
  ground position r(0) is at Rot(σθ)·r(0) at cam angle θ; cam-frame coordinates of a
  ground point X are Rot(−σθ)·X. At θ = 0 the cam frame and the ground frame coincide.
* **Offset** ε of a translating follower: the axis is the line x = σ·ε, i.e. positive
  toward the side the cam surface comes from (for ``ccw`` the surface at the top moves
  toward −x, so it comes from +x).
* **Pressure angle** φ: the angle from the follower's direction of motion e (up the axis;
  for an oscillating arm, perpendicular to the arm in the rising sense) to the common
  normal, positive when the normal leans so that a rise (s′ > 0, ε = 0) gives φ > 0:
  tan φ = (s′ − σ·R×e)/(R·e), R the roller centre. For a translating roller this is
  Norton's φ = atan((s′ − ε)/(s + d)), d = √(Rp² − ε²); a flat face has φ = 0.
* **Radius of curvature** ρ: positive where the curve is convex (bulges away from O),
  negative where concave, infinite on a straight stretch.

With q = R′ − σ·J·R (J the rotation by +90°; R′ = s′·e the roller-centre motion
along its path), the cam-frame pitch curve p(θ) = Rot(−σθ)·R has p′ = Rot(−σθ)·q and

    ρ = |q|³ / (|q|² − σ·q×q′),    q′ = s″·e + s′²·de/ds − σ·s′·J·e,

which for a translating roller is the spec's (y² + (s′ − ε)²)^{3/2} /
(y² + (s′ − ε)(2s′ − ε) − y·s″), y = d + s. The cam surface of a roller follower is the
pitch curve moved Rr inward along its normal; its radius is ρ − Rr. A flat face touches
the cam at x = σ·s′ on the face (height Rb + s), and the surface radius is Rb + s + s″.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# The [cam.geometry] table (keys, CamGeometry, parsing) is camsim.cam.arrangement; these are
# also this module's names, as __all__ says, so that `geometry.CamGeometry` reads naturally.
from camsim.cam.arrangement import (  # noqa: F401
    DEFAULT_LIMIT_OSCILLATING_DEG,
    DEFAULT_LIMIT_TRANSLATING_DEG,
    FOLLOWERS,
    GEOMETRY_KEYS,
    GEOMETRY_PARAMS,
    MATERIAL_KEYS,
    MATERIAL_PARAMS,
    ROTATIONS,
    SAMPLES_PER_DEG,
    STEEL,
    CamGeometry,
    Material,
    _FAR,
    geometry_to_dict,
    parse_geometry,
)
from camsim.errors import MachineFileError

__all__ = [
    "FOLLOWERS",
    "GEOMETRY_KEYS",
    "GEOMETRY_PARAMS",
    "MATERIAL_KEYS",
    "MATERIAL_PARAMS",
    "STEEL",
    "CamGeometry",
    "Defect",
    "GeometryTrace",
    "Material",
    "contact_points",
    "design_grid",
    "evaluate",
    "evaluate_program",
    "face_width",
    "find_defects",
    "geometry_datasets",
    "geometry_summary",
    "geometry_to_dict",
    "parse_geometry",
    "pitch_curve",
    "pitch_radius",
    "pressure_angle",
    "roller_side_motion",
    "surface_points",
    "surface_radius",
]

@dataclass(frozen=True)
class GeometryTrace:
    """Geometry sampled at cam angles ``theta`` (arrays of one length N).

    Attributes
    ----------
    theta : ndarray
        Cam angle [rad].
    pressure_angle : ndarray
        φ [rad], signed.
    pitch_radius : ndarray
        Pitch-curve radius of curvature [m], positive convex (the surface itself for a
        flat face).
    surface_radius : ndarray
        Cam-surface radius of curvature [m], positive convex.
    pitch_curve, surface : ndarray (N, 2)
        x-y in the cam frame [m], origin at the cam centre.
    """

    theta: np.ndarray
    pressure_angle: np.ndarray
    pitch_radius: np.ndarray
    surface_radius: np.ndarray
    pitch_curve: np.ndarray
    surface: np.ndarray


@dataclass(frozen=True)
class Defect:
    """A stretch of cam angle where the follower cannot follow the profile.

    Attributes
    ----------
    kind : str
        ``"undercut"`` (roller: convex pitch curve with ρ ≤ Rr) or ``"cusp"`` (flat face:
        ρ ≤ 0).
    start_deg, end_deg : float
        Cam angles [deg] of the first and last offending samples.
    worst : float
        The smallest pitch radius (roller) or surface radius (flat face) there [m].
    """

    kind: str
    start_deg: float
    end_deg: float
    worst: float

    def describe(self, geometry: CamGeometry) -> str:
        where = (
            f"at cam angle {self.start_deg:.4g} deg"
            if abs(self.end_deg - self.start_deg) < 1e-9
            else f"at cam angles {self.start_deg:.4g}-{self.end_deg:.4g} deg"
        )
        if self.kind == "undercut":
            return (
                f"undercut {where}: pitch radius of curvature down to {1e3 * self.worst:.4g} mm, "
                f"not more than the roller radius {1e3 * geometry.roller_radius:.4g} mm"
            )
        return f"cusp {where}: surface radius of curvature Rb + s + s'' down to {1e3 * self.worst:.4g} mm (<= 0)"


# --------------------------------------------------------------------------------------
# Parsing [cam.geometry]
# --------------------------------------------------------------------------------------
# --------------------------------------------------------------------------------------
# Kinematics of the roller centre (ground frame)
# --------------------------------------------------------------------------------------
def _rot(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def _J(v: np.ndarray) -> np.ndarray:
    """Rotate (…, 2) vectors by +90°."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]


def arm_setup(geometry: CamGeometry) -> tuple[float, float]:
    """Oscillating roller: arm angle ψ0 at s = 0 and the frame turn γ [rad].

    In an auxiliary frame with the pivot at (C, 0) the roller centre is
    (C − L·cos ψ, L·sin ψ), ψ the angle between the arm and the pivot-to-cam-centre line;
    ψ0 puts it on the prime circle. The ground frame is that frame turned by γ so that
    the roller at s = 0 sits straight above the cam centre.
    """
    c, length, rp = geometry.pivot_distance, geometry.arm_length, geometry.prime_radius
    psi0 = math.acos((c * c + length * length - rp * rp) / (2.0 * c * length))
    alpha0 = math.atan2(length * math.sin(psi0), c - length * math.cos(psi0))
    return psi0, math.pi / 2 - alpha0


def _roller_frame(geometry: CamGeometry, s, s1, s2):
    """Roller centre R, direction of motion e, q and q′ in the ground frame, shape (N, 2)."""
    sigma = geometry.sense
    n = s.shape[0]
    if geometry.follower == "translating-roller":
        d = math.sqrt(geometry.prime_radius**2 - geometry.offset**2)
        R = np.stack([np.full(n, sigma * geometry.offset), d + s], axis=-1)
        e = np.tile([0.0, 1.0], (n, 1))
        de = np.zeros((n, 2))
    else:
        c, length = geometry.pivot_distance, geometry.arm_length
        psi0, gamma = arm_setup(geometry)
        psi = psi0 + s / length
        cp, sp = np.cos(psi), np.sin(psi)
        turn = _rot(gamma)
        R = np.stack([c - length * cp, length * sp], axis=-1) @ turn.T
        e = np.stack([sp, cp], axis=-1) @ turn.T
        de = np.stack([cp, -sp], axis=-1) @ turn.T / length  # de/ds
    q = s1[:, None] * e - sigma * _J(R)
    q1 = s2[:, None] * e + (s1 * s1)[:, None] * de - sigma * s1[:, None] * _J(e)
    return R, e, q, q1


def _flat_frame(geometry: CamGeometry, s, s1, s2, s3):
    """Flat face: contact point c = (σ·s′, Rb + s) and q, q′ in the ground frame."""
    sigma = geometry.sense
    c = np.stack([sigma * s1, geometry.base_radius + s], axis=-1)
    c1 = np.stack([sigma * s2, s1], axis=-1)
    c2 = np.stack([sigma * s3, s2], axis=-1)
    q = c1 - sigma * _J(c)
    q1 = c2 - sigma * _J(c1)
    return c, q, q1


def _signed_radius(sigma: float, ref: np.ndarray, q: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """ρ = sgn(q·fwd)·|q|³/(|q|² − σ·q×q′), fwd = −σ·J·ref the direction a circle runs."""
    qq = _dot(q, q)
    denom = qq - sigma * _cross(q, q1)
    forward = np.sign(_dot(q, -sigma * _J(ref)))
    with np.errstate(divide="ignore", invalid="ignore"):
        return forward * qq**1.5 / denom


def _to_cam(sigma: float, theta: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Ground points X (N, 2) at cam angles θ into the cam frame: Rot(−σθ)·X."""
    c, s = np.cos(sigma * theta), np.sin(sigma * theta)
    return np.stack([c * X[:, 0] + s * X[:, 1], -s * X[:, 0] + c * X[:, 1]], axis=-1)


def _arrays(*values):
    out = [np.atleast_1d(np.asarray(v, dtype=float)).reshape(-1) for v in values]
    return out


def pressure_angle(geometry: CamGeometry, s, s1) -> np.ndarray:
    """Pressure angle φ [rad], signed (module docstring); zero for a flat face.

    Parameters
    ----------
    geometry : CamGeometry
    s, s1 : array_like
        Roller lift [m] and ds/dθ [m/rad].
    """
    s, s1 = _arrays(s, s1)
    if not geometry.is_roller:
        return np.zeros_like(s)
    R, e, _, _ = _roller_frame(geometry, s, s1, np.zeros_like(s))
    return np.arctan2(s1 - geometry.sense * _cross(R, e), _dot(R, e))


def pitch_radius(geometry: CamGeometry, s, s1, s2, s3=None) -> np.ndarray:
    """Pitch-curve radius of curvature [m], positive convex.

    For a flat face the pitch curve is taken as the cam surface (Rb + s + s″); it then
    needs ``s3`` (d³s/dθ³ [m/rad³]) for the envelope's derivatives.
    """
    if geometry.is_roller:
        s, s1, s2 = _arrays(s, s1, s2)
        R, _, q, q1 = _roller_frame(geometry, s, s1, s2)
        return _signed_radius(geometry.sense, R, q, q1)
    s, s1, s2, s3 = _arrays(s, s1, s2, np.zeros_like(np.asarray(s, dtype=float)) if s3 is None else s3)
    c, q, q1 = _flat_frame(geometry, s, s1, s2, s3)
    return _signed_radius(geometry.sense, c, q, q1)


def surface_radius(geometry: CamGeometry, s, s1, s2, s3=None) -> np.ndarray:
    """Cam-surface radius of curvature [m], positive convex: ρ_pitch − Rr (roller)."""
    return pitch_radius(geometry, s, s1, s2, s3) - geometry.roller_radius


def pitch_curve(geometry: CamGeometry, theta, s, s1) -> np.ndarray:
    """Pitch curve (roller-centre path) in the cam frame, (N, 2) [m].

    For a flat face this is the cam surface (:func:`surface_points`).
    """
    theta, s, s1 = _arrays(theta, s, s1)
    if not geometry.is_roller:
        return surface_points(geometry, theta, s, s1)
    R, _, _, _ = _roller_frame(geometry, s, s1, np.zeros_like(s))
    return _to_cam(geometry.sense, theta, R)


def surface_points(geometry: CamGeometry, theta, s, s1) -> np.ndarray:
    """Cam surface in the cam frame, (N, 2) [m].

    Roller: the pitch point moved Rr along the inward normal (the normal of the pitch
    curve, which passes through the contact point). Flat face: the envelope point
    (σ·s′, Rb + s) of the face, turned into the cam frame.
    """
    theta, s, s1 = _arrays(theta, s, s1)
    sigma = geometry.sense
    if not geometry.is_roller:
        zeros = np.zeros_like(s)
        c, _, _ = _flat_frame(geometry, s, s1, zeros, zeros)
        return _to_cam(sigma, theta, c)
    R, _, q, _ = _roller_frame(geometry, s, s1, np.zeros_like(s))
    outward = sigma * _J(q) / np.sqrt(_dot(q, q))[:, None]
    return _to_cam(sigma, theta, R - geometry.roller_radius * outward)


def contact_points(geometry: CamGeometry, s, s1) -> tuple[np.ndarray, np.ndarray]:
    """Contact point and unit common normal (from the cam toward the follower), ground frame.

    Returns
    -------
    point, normal : ndarray (N, 2)
        [m] and [-].
    """
    s, s1 = _arrays(s, s1)
    sigma = geometry.sense
    zeros = np.zeros_like(s)
    if not geometry.is_roller:
        c, _, _ = _flat_frame(geometry, s, s1, zeros, zeros)
        return c, np.tile([0.0, 1.0], (s.size, 1))
    R, _, q, _ = _roller_frame(geometry, s, s1, zeros)
    outward = sigma * _J(q) / np.sqrt(_dot(q, q))[:, None]
    return R - geometry.roller_radius * outward, outward


def face_width(geometry: CamGeometry, s1) -> dict:
    """Flat face: where on the face the contact runs, from the range of s′.

    The contact is s′ − ε from the follower axis (toward the side the surface comes
    from). Returns ``{"min_contact": [m], "max_contact": [m], "width": [m]}``; the width
    is max − min, without a margin (add one for the edge radius and tolerances).
    """
    (s1,) = _arrays(s1)
    x = s1 - geometry.offset
    lo, hi = float(np.min(x)), float(np.max(x))
    return {"min_contact": lo, "max_contact": hi, "width": hi - lo}


def evaluate(geometry: CamGeometry, theta, s, s1, s2, s3=None) -> GeometryTrace:
    """Every geometric quantity at cam angles ``theta`` [rad] from the roller-side motion."""
    theta, s, s1, s2 = _arrays(theta, s, s1, s2)
    s3 = np.zeros_like(s) if s3 is None else _arrays(s3)[0]
    rho = pitch_radius(geometry, s, s1, s2, s3)
    return GeometryTrace(
        theta=theta,
        pressure_angle=pressure_angle(geometry, s, s1),
        pitch_radius=rho,
        surface_radius=rho - geometry.roller_radius,
        pitch_curve=pitch_curve(geometry, theta, s, s1),
        surface=surface_points(geometry, theta, s, s1),
    )


# --------------------------------------------------------------------------------------
# From a cam program
# --------------------------------------------------------------------------------------
def roller_side_motion(program, theta, side: str = "right"):
    """Roller lift s [m] and s′, s″, s‴ [m/rad^k] at cam angles θ [rad] (before ``ratio``).

    The one place that asks the cam program for the geometry's motion: segment laws give
    it exactly, a table cam through its periodic spline.
    """
    return program.lift(np.asarray(theta, dtype=float), side=side)


def evaluate_program(geometry: CamGeometry, program, theta, side: str = "right") -> GeometryTrace:
    """:func:`evaluate` at cam angles θ [rad] of a :class:`~camsim.cam.CamProgram`."""
    s, s1, s2, s3 = roller_side_motion(program, theta, side)
    return evaluate(geometry, theta, s, s1, s2, s3)


def geometry_datasets(geometry: CamGeometry, program, theta, side: str = "right") -> dict:
    """The spec's static ``/cam/...`` design datasets at cam angles θ [rad].

    Returns
    -------
    dict
        path → (array, units, long name): ``cam/pressure_angle`` [deg],
        ``cam/pitch_radius_of_curvature`` [m], ``cam/surface_radius_of_curvature`` [m],
        ``cam/pitch_curve`` and ``cam/surface`` (N, 2) [m].
    """
    trace = evaluate_program(geometry, program, theta, side)
    return {
        "cam/pressure_angle": (np.degrees(trace.pressure_angle), "deg", "pressure angle (signed)"),
        "cam/pitch_radius_of_curvature": (trace.pitch_radius, "m", "pitch-curve radius of curvature (positive convex)"),
        "cam/surface_radius_of_curvature": (trace.surface_radius, "m", "cam-surface radius of curvature (positive convex)"),
        "cam/pitch_curve": (trace.pitch_curve, "m", "pitch curve x, y in the cam frame"),
        "cam/surface": (trace.surface, "m", "cam surface x, y in the cam frame"),
    }


def design_grid(program, per_deg: int = SAMPLES_PER_DEG) -> tuple[np.ndarray, np.ndarray]:
    """Cam angles covering one revolution segment by segment, joins from both sides.

    Returns
    -------
    theta : ndarray
        [rad], each segment sampled from its start to its end inclusive.
    left : ndarray of bool
        True for a segment's last sample (evaluate with ``side="left"``, the limit from
        inside the segment).
    """
    starts = program.boundary_angles() if program.kind == "segments" else np.zeros(0)
    if starts.size == 0:
        n = 360 * per_deg
        return np.linspace(0.0, 2 * math.pi, n, endpoint=False), np.zeros(n, dtype=bool)
    ends = np.append(starts[1:], 2 * math.pi)
    thetas, lefts = [], []
    for a, b in zip(starts, ends):
        n = max(16, int(math.ceil(math.degrees(b - a) * per_deg))) + 1
        thetas.append(np.linspace(a, b, n))
        flag = np.zeros(n, dtype=bool)
        flag[-1] = True
        lefts.append(flag)
    return np.concatenate(thetas), np.concatenate(lefts)


def _motion_on_grid(program, theta, left):
    s, s1, s2, s3 = (np.array(x) for x in roller_side_motion(program, theta, "right"))
    if np.any(left):
        ls = roller_side_motion(program, theta[left], "left")
        for arr, val in zip((s, s1, s2, s3), ls):
            arr[left] = val
    return s, s1, s2, s3


def find_defects(geometry: CamGeometry, theta, pitch_rho, surface_rho) -> list[Defect]:
    """Stretches where the follower cannot follow: undercut (roller) or cusp (flat face).

    Parameters
    ----------
    theta : array_like
        Cam angles [rad] in increasing order.
    pitch_rho, surface_rho : array_like
        Radii of curvature [m] at those angles.
    """
    theta = np.asarray(theta, dtype=float)
    pitch_rho = np.asarray(pitch_rho, dtype=float)
    surface_rho = np.asarray(surface_rho, dtype=float)
    if geometry.is_roller:
        bad = (pitch_rho > 0) & (pitch_rho <= geometry.roller_radius)
        kind, values = "undercut", pitch_rho
    else:
        bad = surface_rho <= 0
        kind, values = "cusp", surface_rho
    out: list[Defect] = []
    idx = np.flatnonzero(bad)
    if idx.size == 0:
        return out
    breaks = np.flatnonzero(np.diff(idx) > 1)
    for run in np.split(idx, breaks + 1):
        out.append(Defect(kind, math.degrees(theta[run[0]]) % 360.0, math.degrees(theta[run[-1]]) % 360.0,
                          float(np.min(values[run]))))
    return out


def _refine_min(func, lo: float, hi: float, x0: float, f0: float) -> tuple[float, float]:
    """Bounded Brent minimisation of a scalar function on [lo, hi]; keeps the sample if better."""
    if not hi > lo:
        return x0, f0
    from scipy.optimize import minimize_scalar  # the summary only; keeps imports light

    res = minimize_scalar(lambda z: float(func(z)), bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-11})
    if res.fun < f0:
        return float(res.x), float(res.fun)
    return x0, f0


def geometry_summary(geometry: CamGeometry, program, per_deg: int = SAMPLES_PER_DEG) -> dict:
    """The design checks over one revolution: extremes, where they occur, defects, warnings.

    The revolution is sampled segment by segment (``per_deg`` samples per degree, joins
    from both sides); each extreme is refined by bounded Brent minimisation between the
    neighbouring samples (inside one segment, ``xatol`` 1e-11 rad).

    Returns
    -------
    dict
        ``follower``; ``max_pressure_angle`` [deg] (largest |φ|) and
        ``max_pressure_angle_at`` [deg cam angle]; ``pressure_angle_limit`` [deg];
        ``min_pitch_radius`` [m] (smallest convex pitch radius) and ``…_at`` [deg];
        ``min_surface_radius`` [m] (roller: smallest surface radius where the pitch
        curve is convex, negative when undercut; flat face: smallest Rb + s + s″,
        ≤ 0 at a cusp) and ``…_at``; ``min_concave_radius`` [m] (smallest |surface radius|
        where concave, None if nowhere) and ``…_at``; for a flat face ``face_width``,
        ``face_min_contact``, ``face_max_contact`` [m]; ``defects`` (list of
        :class:`Defect`); ``warnings`` (list of str).
    """
    theta, left = design_grid(program, per_deg)
    s, s1, s2, s3 = _motion_on_grid(program, theta, left)
    phi = pressure_angle(geometry, s, s1)
    rho = pitch_radius(geometry, s, s1, s2, s3)
    rho_s = rho - geometry.roller_radius
    bounds_of = _segment_bounds(program, theta)

    def scalar(kind: str):
        def f(z: float) -> float:
            z = float(np.asarray(z, dtype=float).reshape(-1)[0])
            ss = [float(np.asarray(v).reshape(-1)[0]) for v in roller_side_motion(program, np.array([z]))]
            if kind == "phi":
                return -abs(float(pressure_angle(geometry, ss[0], ss[1])[0]))
            r = float(pitch_radius(geometry, *ss)[0])
            if kind == "signed":
                return r
            if kind == "convex":
                return r if r > 0 else _FAR
            return -r if r < 0 else _FAR  # concave: smallest |ρ_s| = |ρ| + Rr
        return f

    def extreme(values: np.ndarray, kind: str):
        if not np.any(np.isfinite(values)):
            return None, None
        k = int(np.nanargmin(values))
        lo, hi = bounds_of(k)
        x, v = _refine_min(scalar(kind), lo, hi, float(theta[k]), float(values[k]))
        return v, math.degrees(x) % 360.0

    phi_val, phi_at = extreme(-np.abs(phi), "phi")
    convex = np.where(rho > 0, rho, _FAR)
    concave = np.where(rho < 0, -rho, _FAR)
    rmin, rmin_at = extreme(convex, "convex")
    cmin, cmin_at = extreme(concave, "concave")
    if rmin is not None and rmin >= _FAR:
        rmin = rmin_at = None
    if cmin is not None and cmin >= _FAR:
        cmin = cmin_at = None
    smin, smin_at = (rmin, rmin_at) if geometry.is_roller else extreme(rho, "signed")
    out = {
        "follower": geometry.follower,
        "rotation": geometry.rotation,
        "base_radius": geometry.base_radius,
        "roller_radius": geometry.roller_radius,
        "max_pressure_angle": math.degrees(-phi_val) if phi_val is not None else 0.0,
        "max_pressure_angle_at": phi_at,
        "pressure_angle_limit": math.degrees(geometry.pressure_angle_limit),
        "min_pitch_radius": rmin,
        "min_pitch_radius_at": rmin_at,
        "min_surface_radius": None if smin is None else smin - geometry.roller_radius,
        "min_surface_radius_at": smin_at,
        "min_concave_radius": None if cmin is None else cmin + geometry.roller_radius,
        "min_concave_radius_at": cmin_at,
    }
    if not geometry.is_roller:
        out.update({f"face_{k}" if k != "width" else "face_width": v for k, v in face_width(geometry, s1).items()})
    defects = find_defects(geometry, theta, rho, rho_s)
    out["defects"] = defects
    warnings = []
    if geometry.is_roller and out["max_pressure_angle"] > out["pressure_angle_limit"]:
        over = np.abs(phi) > geometry.pressure_angle_limit
        spans = _spans(theta, over) if np.any(over) else f"{phi_at:.4g}"
        warnings.append(
            f"pressure angle {out['max_pressure_angle']:.4g} deg at cam angle {phi_at:.4g} deg exceeds "
            f"max_pressure_angle {out['pressure_angle_limit']:.4g} deg (over it at cam angles {spans})"
        )
    out["warnings"] = warnings
    return out


def _spans(theta: np.ndarray, mask: np.ndarray) -> str:
    idx = np.flatnonzero(mask)
    parts = []
    for run in np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1):
        a, b = math.degrees(theta[run[0]]) % 360.0, math.degrees(theta[run[-1]]) % 360.0
        parts.append(f"{a:.4g}-{b:.4g}")
    return ", ".join(parts)


def _segment_bounds(program, theta: np.ndarray):
    """For sample k: the cam-angle interval between its neighbours, inside one segment."""
    starts = program.boundary_angles() if program.kind == "segments" else np.zeros(0)
    edges = np.append(starts, 2 * math.pi) if starts.size else None
    n = theta.size

    def bounds(k: int) -> tuple[float, float]:
        lo = theta[max(k - 1, 0)]
        hi = theta[min(k + 1, n - 1)]
        if edges is not None:
            i = int(np.searchsorted(edges, theta[k], side="right")) - 1
            i = min(max(i, 0), edges.size - 2)
            lo, hi = max(lo, edges[i]), min(hi, edges[i + 1])
        if hi < lo:
            lo, hi = hi, lo
        return float(lo), float(hi)

    return bounds


def check_followable(geometry: CamGeometry, program, source: str, summary: dict | None = None) -> dict:
    """Raise when the follower cannot follow the profile (spec §2: an error, not a warning).

    Returns the :func:`geometry_summary` (computed here unless given).

    Raises
    ------
    MachineFileError
        Key ``cam.geometry``, naming the cam angles of every undercut or cusp.
    """
    summary = geometry_summary(geometry, program) if summary is None else summary
    if summary["defects"]:
        text = "; ".join(d.describe(geometry) for d in summary["defects"])
        hint = ("increase base_radius or reduce roller_radius" if geometry.is_roller
                else "increase base_radius or ease the acceleration")
        raise MachineFileError(source, "cam.geometry", f"the follower cannot follow the cam: {text} ({hint})")
    return summary

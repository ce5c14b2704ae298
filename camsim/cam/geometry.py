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

import difflib
import math
from dataclasses import dataclass, field

import numpy as np

from camsim.elements import Param
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
    "apply_geometry_override",
    "contact_points",
    "design_grid",
    "evaluate",
    "evaluate_program",
    "face_width",
    "find_defects",
    "geometry_datasets",
    "geometry_key_unit",
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

FOLLOWERS = ("translating-roller", "translating-flat", "oscillating-roller")
ROTATIONS = ("ccw", "cw")
#: The keys of ``[cam.geometry]`` (the schema's description: docs, ``--set``/``--vary`` units).
GEOMETRY_PARAMS: tuple[Param, ...] = (
    Param("follower", "string", "`translating-roller`, `translating-flat` or `oscillating-roller`", required=True),
    Param("base_radius", "length", "Rb, the smallest radius of the cam surface", required=True, minimum=0.0,
          strict=True),
    Param("roller_radius", "length", "Rr < Rb, roller followers (required there, **not allowed** for a flat "
          "face); the prime circle is Rp = Rb + Rr", minimum=0.0, strict=True),
    Param("offset", "length", "ε, translating followers only: the axis displaced from the cam centre, positive "
          "toward the side the cam surface comes from; \\|ε\\| < Rp for a roller", default=0.0),
    Param("pivot_distance", "length", "cam centre to arm pivot, `oscillating-roller` (required there); "
          "\\|C − L\\| < Rp < C + L", minimum=0.0, strict=True),
    Param("arm_length", "length", "pivot to roller centre L, `oscillating-roller`; default `cam.arm` (equal to it "
          "if both are given)", minimum=0.0, strict=True),
    Param("rotation", "string", "`ccw` or `cw`, as the profile is drawn", default="ccw"),
    Param("width", "length", "face width in contact (for the Hertz stress; none: no stress)", minimum=0.0,
          strict=True),
    Param("cam_material", "table", "`youngs_modulus`, `poisson_ratio` (below); default steel"),
    Param("follower_material", "table", "`youngs_modulus`, `poisson_ratio` (below); default steel"),
    Param("max_pressure_angle", "angle", "a warning above it; < 90°; bare number = degrees; default 30° "
          "translating, 35° oscillating", minimum=0.0, strict=True),
)
#: The keys of ``cam_material`` and ``follower_material``.
MATERIAL_PARAMS: tuple[Param, ...] = (
    Param("youngs_modulus", "pressure", "E (steel 206.8 GPa)", default=206.8e9, minimum=0.0, strict=True),
    Param("poisson_ratio", "number", "ν, in [0, 0.5) (steel 0.28)", default=0.28, minimum=0.0),
)
GEOMETRY_KEYS = tuple(p.key for p in GEOMETRY_PARAMS)
MATERIAL_KEYS = tuple(p.key for p in MATERIAL_PARAMS)

#: Default limits on |pressure angle| [deg] (spec §2): translating, oscillating.
DEFAULT_LIMIT_TRANSLATING_DEG = 30.0
DEFAULT_LIMIT_OSCILLATING_DEG = 35.0
#: Stand-in for "no such radius" in the extreme searches [m] (finite, for the optimiser).
_FAR = 1e30
#: Samples per degree of cam angle for the checks and the summary extremes.
SAMPLES_PER_DEG = 10


@dataclass(frozen=True)
class Material:
    """Elastic constants for line-contact (Hertz) stress.

    Attributes
    ----------
    youngs_modulus : float
        E [Pa] (default steel, 206.8 GPa = 30e6 psi).
    poisson_ratio : float
        ν [-] (default 0.28).
    """

    youngs_modulus: float = 206.8e9
    poisson_ratio: float = 0.28


STEEL = Material()


@dataclass(frozen=True)
class CamGeometry:
    """The cam's shape and follower arrangement, SI (``[cam.geometry]``).

    Attributes
    ----------
    follower : str
        ``"translating-roller"``, ``"translating-flat"`` or ``"oscillating-roller"``.
    base_radius : float
        Rb, smallest radius of the cam surface [m].
    roller_radius : float
        Rr [m] (0 for a flat face).
    offset : float
        ε of a translating follower [m], positive toward the side the cam surface comes
        from (module docstring).
    pivot_distance : float or None
        Cam centre to arm pivot [m] (oscillating roller).
    arm_length : float or None
        Pivot to roller centre [m] (oscillating roller).
    rotation : str
        ``"ccw"`` or ``"cw"`` as the profile is drawn.
    width : float or None
        Face width in contact [m]; None: no contact stress.
    cam_material, follower_material : Material
        For the Hertz stress.
    max_pressure_angle : float or None
        Warning limit on |φ| [rad]; None: 30° translating, 35° oscillating.
    """

    follower: str
    base_radius: float
    roller_radius: float = 0.0
    offset: float = 0.0
    pivot_distance: float | None = None
    arm_length: float | None = None
    rotation: str = "ccw"
    width: float | None = None
    cam_material: Material = field(default_factory=Material)
    follower_material: Material = field(default_factory=Material)
    max_pressure_angle: float | None = None

    @property
    def sense(self) -> float:
        """σ = +1 for ccw, −1 for cw."""
        return 1.0 if self.rotation == "ccw" else -1.0

    @property
    def is_roller(self) -> bool:
        return self.follower != "translating-flat"

    @property
    def prime_radius(self) -> float:
        """Rp = Rb + Rr [m] (Rb for a flat face)."""
        return self.base_radius + self.roller_radius

    @property
    def pressure_angle_limit(self) -> float:
        """The warning limit on |φ| [rad] (the given one or the spec's default)."""
        if self.max_pressure_angle is not None:
            return self.max_pressure_angle
        deg = DEFAULT_LIMIT_OSCILLATING_DEG if self.follower == "oscillating-roller" else DEFAULT_LIMIT_TRANSLATING_DEG
        return math.radians(deg)


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
def _suggest(word: str, choices) -> str:
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    if close:
        return f"did you mean '{close[0]}'?"
    return "valid: " + ", ".join(choices)


def _fmt(value) -> str:
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


class _Reader:
    def __init__(self, source: str, path: str):
        self.source = source
        self.path = path

    def error(self, key: str, message: str) -> MachineFileError:
        return MachineFileError(self.source, f"{self.path}.{key}" if key else self.path, message)

    def check_keys(self, table: dict, valid, prefix: str = "", what: str = "") -> None:
        for key in table:
            if key not in valid:
                raise self.error(prefix + key, f"unknown key{what}; {_suggest(key, valid)}")

    def quantity(self, table: dict, key: str, dimension: str, *, required=False, positive=False,
                 example: str = "", prefix: str = "") -> float | None:
        from camsim.units import QuantityError, to_si

        if key not in table:
            if required:
                hint = f" (e.g. {key} = {example})" if example else ""
                raise self.error(prefix + key, f"missing required key{hint}")
            return None
        value = table[key]
        try:
            if dimension == "angle":
                number = _angle(value)
            else:
                number = to_si(value, dimension)
        except QuantityError as exc:
            raise self.error(prefix + key, str(exc)) from None
        if positive and not number > 0:
            raise self.error(prefix + key, f"must be greater than 0, got {_fmt(value)}")
        return number

    def choice(self, table: dict, key: str, choices, default: str | None = None) -> str:
        if key not in table:
            if default is None:
                raise self.error(key, f"missing required key (one of {', '.join(choices)})")
            return default
        value = table[key]
        if not isinstance(value, str):
            raise self.error(key, f"expected a string, got {_fmt(value)}")
        if value not in choices:
            raise self.error(key, f'unknown {key} "{value}"; {_suggest(value, choices)}')
        return value

    def material(self, table: dict, key: str) -> Material:
        if key not in table:
            return Material()
        value = table[key]
        if not isinstance(value, dict):
            raise self.error(key, f"expected a table ({key} = {{ youngs_modulus = \"206.8 GPa\", poisson_ratio = 0.28 }}), "
                             f"got {_fmt(value)}")
        self.check_keys(value, MATERIAL_KEYS, prefix=f"{key}.")
        modulus = self.quantity(value, "youngs_modulus", "pressure", positive=True, prefix=f"{key}.")
        nu = STEEL.poisson_ratio
        if "poisson_ratio" in value:
            raw = value["poisson_ratio"]
            if isinstance(raw, bool) or not isinstance(raw, (int, float)) or not math.isfinite(raw):
                raise self.error(f"{key}.poisson_ratio", f"expected a number, got {_fmt(raw)}")
            if not 0.0 <= raw < 0.5:
                raise self.error(f"{key}.poisson_ratio", f"must be in [0, 0.5), got {_fmt(raw)}")
            nu = float(raw)
        return Material(youngs_modulus=STEEL.youngs_modulus if modulus is None else modulus, poisson_ratio=nu)


def _angle(value) -> float:
    """An angle [rad]; a bare number (or a number in a string) means degrees."""
    from camsim.units import QuantityError, registry, to_si

    if isinstance(value, str):
        try:
            q = registry().Quantity(value.strip())
            unitless = getattr(q, "unitless", True)
        except Exception:  # unparsable: to_si gives the message
            unitless = False
        if not unitless:
            return to_si(value, "angle")
    if isinstance(value, bool):
        raise QuantityError(f"expected [angle], got {value!r}")
    return to_si(value, "angle", bare_unit="deg")


def parse_geometry(table, source: str, cam_arm: float | None = None, path: str = "cam.geometry") -> CamGeometry:
    """Read and check a ``[cam.geometry]`` table.

    Parameters
    ----------
    table : dict
        The parsed TOML table.
    source : str
        The machine file's name, for error messages.
    cam_arm : float or None
        ``cam.arm`` [m]: the default ``arm_length`` of an oscillating roller.
    path : str
        Key path of the table in the file.

    Returns
    -------
    CamGeometry

    Raises
    ------
    MachineFileError
        Naming ``cam.geometry.<key>``: unknown keys (with a suggestion), missing keys,
        wrong dimensions, non-positive radii or width, roller radius not smaller than the
        base radius, an offset outside the prime circle, a pivot from which the roller
        cannot reach the prime circle, keys the follower kind does not use.
    """
    r = _Reader(source, path)
    if not isinstance(table, dict):
        raise MachineFileError(source, path, f"expected a table [{path}], got {_fmt(table)}")
    r.check_keys(table, GEOMETRY_KEYS)
    follower = r.choice(table, "follower", FOLLOWERS)
    not_used = {
        "translating-roller": ("pivot_distance", "arm_length"),
        "translating-flat": ("roller_radius", "pivot_distance", "arm_length"),
        "oscillating-roller": ("offset",),
    }[follower]
    for key in not_used:
        if key in table:
            raise r.error(key, f'not used by a follower = "{follower}"')
    rb = r.quantity(table, "base_radius", "length", required=True, positive=True, example='"40 mm"')
    rr = 0.0
    if follower != "translating-flat":
        rr = r.quantity(table, "roller_radius", "length", required=True, positive=True, example='"10 mm"')
        if rr >= rb:
            raise r.error("roller_radius", f"must be smaller than base_radius ({1e3 * rr:.6g} mm >= "
                          f"{1e3 * rb:.6g} mm): the roller would not fit the cam")
    offset = r.quantity(table, "offset", "length") or 0.0
    if follower == "translating-roller" and not abs(offset) < rb + rr:
        raise r.error("offset", f"|offset| {1e3 * abs(offset):.6g} mm must be smaller than the prime radius "
                      f"Rb + Rr = {1e3 * (rb + rr):.6g} mm")
    pivot = arm = None
    if follower == "oscillating-roller":
        pivot = r.quantity(table, "pivot_distance", "length", required=True, positive=True, example='"7 in"')
        arm = r.quantity(table, "arm_length", "length", positive=True)
        if arm is None:
            if cam_arm is None:
                raise r.error("arm_length", "missing required key (the pivot-to-roller length; or set cam.arm)")
            arm = cam_arm
        elif cam_arm is not None and abs(arm - cam_arm) > 1e-9 * max(arm, cam_arm):
            raise r.error("arm_length", f"{1e3 * arm:.6g} mm differs from cam.arm {1e3 * cam_arm:.6g} mm "
                          "(they are the same arm: give one, or make them equal)")
        rp = rb + rr
        if not abs(pivot - arm) < rp < pivot + arm:
            raise r.error("pivot_distance", f"the roller cannot touch the prime circle Rp = {1e3 * rp:.6g} mm "
                          f"from a pivot {1e3 * pivot:.6g} mm away with an arm of {1e3 * arm:.6g} mm "
                          "(need |pivot_distance - arm_length| < Rp < pivot_distance + arm_length)")
    rotation = r.choice(table, "rotation", ROTATIONS, default="ccw")
    width = r.quantity(table, "width", "length", positive=True)
    limit = r.quantity(table, "max_pressure_angle", "angle", positive=True)
    if limit is not None and not limit < math.pi / 2:
        raise r.error("max_pressure_angle", f"must be below 90 deg, got {_fmt(table['max_pressure_angle'])}")
    return CamGeometry(
        follower=follower,
        base_radius=rb,
        roller_radius=rr,
        offset=offset,
        pivot_distance=pivot,
        arm_length=arm,
        rotation=rotation,
        width=width,
        cam_material=r.material(table, "cam_material"),
        follower_material=r.material(table, "follower_material"),
        max_pressure_angle=limit,
    )


def apply_geometry_override(cam: dict, key: str, rest: list[tuple[str, int | None]], value, source: str) -> str:
    """Set ``cam.geometry.<key>`` (or ``cam.geometry.<material>.<key>``) in a parsed document.

    Parameters
    ----------
    cam : dict
        The document's ``[cam]`` table (``geometry`` is created if missing).
    key : str
        The whole override key, for messages.
    rest : list of (name, index)
        The key parts after ``cam.geometry``.
    value
        The parsed value.
    source : str
        The machine file's name.

    Returns
    -------
    str
        The canonical key path set.
    """
    if not rest or any(index is not None for _, index in rest):
        raise MachineFileError(source, key, "address one geometry key, e.g. cam.geometry.base_radius=40mm")
    name = rest[0][0]
    if name not in GEOMETRY_KEYS:
        raise MachineFileError(source, key, f"unknown key; {_suggest(name, GEOMETRY_KEYS)}")
    geometry = cam.setdefault("geometry", {})
    if not isinstance(geometry, dict):
        raise MachineFileError(source, "cam.geometry", "expected a table")
    if name in ("cam_material", "follower_material"):
        if len(rest) != 2 or rest[1][0] not in MATERIAL_KEYS:
            word = rest[1][0] if len(rest) > 1 else ""
            raise MachineFileError(source, key, f"unknown key; {_suggest(word, MATERIAL_KEYS)}")
        material = geometry.setdefault(name, {})
        if not isinstance(material, dict):
            raise MachineFileError(source, f"cam.geometry.{name}", "expected a table")
        material[rest[1][0]] = value
        return f"cam.geometry.{name}.{rest[1][0]}"
    if len(rest) != 1:
        raise MachineFileError(source, key, f"cam.geometry.{name} has no sub-keys")
    geometry[name] = value
    return f"cam.geometry.{name}"


def geometry_key_unit(key: str) -> str:
    """SI unit of an override key ``cam.geometry.…`` (``""`` for numbers and strings)."""
    leaf = key.rsplit(".", 1)[-1]
    return next((p.unit for p in (*GEOMETRY_PARAMS, *MATERIAL_PARAMS) if p.key == leaf), "")


def geometry_to_dict(geometry: CamGeometry | None) -> dict | None:
    """A JSON-able description in SI (``max_pressure_angle`` resolved, in rad)."""
    if geometry is None:
        return None
    return {
        "follower": geometry.follower,
        "base_radius": geometry.base_radius,
        "roller_radius": geometry.roller_radius,
        "offset": geometry.offset,
        "pivot_distance": geometry.pivot_distance,
        "arm_length": geometry.arm_length,
        "rotation": geometry.rotation,
        "width": geometry.width,
        "cam_material": {"youngs_modulus": geometry.cam_material.youngs_modulus,
                         "poisson_ratio": geometry.cam_material.poisson_ratio},
        "follower_material": {"youngs_modulus": geometry.follower_material.youngs_modulus,
                              "poisson_ratio": geometry.follower_material.poisson_ratio},
        "max_pressure_angle": geometry.pressure_angle_limit,
    }


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

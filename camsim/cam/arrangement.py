"""The ``[cam.geometry]`` table: the follower arrangement, the materials, and their keys.

What a designer writes about the cam's shape (follower kind, base and roller radii, offset,
pivot, rotation, width, materials, the pressure-angle limit): the keys with their dimensions
(read by the machine-file schema and validator), the :class:`CamGeometry` they build, its
parsing in SI with one-line errors, ``--set cam.geometry.*`` overrides, and the table written
back. The geometry itself — pressure angle, curvature, pitch curve, surface — is computed in
:mod:`camsim.cam.geometry`.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field

from camsim.elements import Param
from camsim.errors import MachineFileError

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
    Param("cam_material", "table", "a material name (library or `[[material]]`, e.g. `\"cast-iron\"`) or a table "
          "of `youngs_modulus`, `poisson_ratio` (below); default steel"),
    Param("follower_material", "table", "a material name or a table of `youngs_modulus`, `poisson_ratio` (below); "
          "default steel"),
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
    def __init__(self, source: str, path: str, materials: dict | None = None):
        self.source = source
        self.path = path
        self.materials = materials or {}

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
        if isinstance(value, str):  # issue 39: a library or [[material]] name
            from camsim.physics.materials import library_names, lookup

            try:
                named = lookup(value, self.materials)
            except KeyError:
                raise self.error(key, f'unknown material "{value}"; '
                                 f"{_suggest(value, [*self.materials, *library_names()])}") from None
            return Material(youngs_modulus=named.youngs_modulus, poisson_ratio=named.poisson_ratio)
        if not isinstance(value, dict):
            raise self.error(key, f"expected a material name (\"steel\") or a table ({key} = {{ youngs_modulus = "
                             f"\"206.8 GPa\", poisson_ratio = 0.28 }}), got {_fmt(value)}")
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


def parse_geometry(table, source: str, cam_arm: float | None = None, path: str = "cam.geometry",
                   materials: dict | None = None) -> CamGeometry:
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
    materials : dict, optional
        The file's ``[[material]]`` tables by name (issue 39): ``cam_material`` and
        ``follower_material`` may name one of them or a library material instead of a table.

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
    r = _Reader(source, path, materials)
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

"""Display units: the unit each dimension is shown in, and the conversion from SI.

A :class:`DisplayUnits` maps each *dimension* (length, force, stiffness, ...) to the unit its
values are printed in and that unit's size in SI. Code that shows a value knows its SI unit
text (``"m/s^2"``, ``"N"``, ``"deg"``, the ``units`` attribute of a trace); :meth:`shown`
turns that into the text to print and the factor from SI. Three choices exist
(``--units``): ``file`` (the units the machine file was written in, per dimension:
:mod:`camsim.display.written`), ``si`` (:data:`SI`) and ``us`` (:data:`US`).

Nothing here imports pint: a choice is a table of texts and factors, so a result file can
record the one it was made with (a JSON root attribute) and ``plot`` or ``report`` can read it
back without building the unit registry.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

__all__ = [
    "SYSTEMS", "SI", "US", "DisplayUnits", "Unit", "si_dimension", "typographic", "pint_text", "compose", "system_units",
]

#: Choices of ``--units``: the machine file's own units, SI, US customary.
SYSTEMS = ("file", "si", "us")

#: One inch [m], one pound-force [N], one pound [kg] (all exact).
INCH = 0.0254
LBF = 0.45359237 * 9.80665
POUND = 0.45359237

#: SI unit texts used in camsim's code and files → (dimension, size of that unit in the
#: dimension's coherent SI unit). Times and frequencies are left out on purpose: they are the
#: same in every system and printed in s / ms and Hz / kHz by magnitude.
_SI_TEXT: dict[str, tuple[str, float]] = {
    "m": ("length", 1.0), "mm": ("length", 1e-3), "um": ("length", 1e-6), "µm": ("length", 1e-6),
    "m/s": ("velocity", 1.0),
    "m/s^2": ("acceleration", 1.0), "m/s**2": ("acceleration", 1.0), "m/s²": ("acceleration", 1.0),
    "m/s^3": ("jerk", 1.0), "m/s**3": ("jerk", 1.0), "m/s³": ("jerk", 1.0),
    "m/s^4": ("length/time^4", 1.0), "m/s⁴": ("length/time^4", 1.0),
    "m/s^5": ("length/time^5", 1.0), "m/s⁵": ("length/time^5", 1.0),
    "m/s^6": ("length/time^6", 1.0), "m/s⁶": ("length/time^6", 1.0),
    "N": ("force", 1.0), "kN": ("force", 1e3),
    "N/m": ("stiffness", 1.0),
    "N*s/m": ("damping", 1.0), "N·s/m": ("damping", 1.0), "N s/m": ("damping", 1.0),
    "N*s^2/m^2": ("quadratic_damping", 1.0), "N·s²/m²": ("quadratic_damping", 1.0),
    "kg": ("mass", 1.0),
    "Pa": ("pressure", 1.0), "MPa": ("pressure", 1e6), "GPa": ("pressure", 1e9),
    "N*m": ("torque", 1.0), "N·m": ("torque", 1.0), "N m": ("torque", 1.0),
    "J": ("energy", 1.0),
    "rad": ("angle", 1.0), "deg": ("angle", math.pi / 180.0), "°": ("angle", math.pi / 180.0),
    "rad/s": ("angular_speed", 1.0), "rpm": ("angular_speed", 2.0 * math.pi / 60.0),
    "kg*m^2": ("inertia", 1.0), "kg·m²": ("inertia", 1.0), "kg*m**2": ("inertia", 1.0),
    "kg/m^3": ("density", 1.0), "kg/m³": ("density", 1.0), "kg/m**3": ("density", 1.0),
    "m^2": ("area", 1.0), "m²": ("area", 1.0), "m**2": ("area", 1.0),
    "s/m": ("slowness", 1.0),
}


@dataclass(frozen=True)
class Unit:
    """A display unit: its text and its size in the dimension's coherent SI unit.

    ``size`` is SI per displayed unit (1 lbf = 4.448 N → 4.448), so a value is shown as
    ``si_value / size``.
    """

    text: str
    size: float


def _u(text: str, size: float) -> Unit:
    return Unit(text, size)


#: The ``si`` choice: mm for lengths (the scale of a cam), coherent SI otherwise; rpm, deg.
SI: dict[str, Unit] = {
    "length": _u("mm", 1e-3),
    "velocity": _u("m/s", 1.0),
    "acceleration": _u("m/s²", 1.0),
    "jerk": _u("m/s³", 1.0),
    "length/time^4": _u("m/s⁴", 1.0),
    "length/time^5": _u("m/s⁵", 1.0),
    "length/time^6": _u("m/s⁶", 1.0),
    "force": _u("N", 1.0),
    "stiffness": _u("N/m", 1.0),
    "damping": _u("N·s/m", 1.0),
    "quadratic_damping": _u("N·s²/m²", 1.0),
    "mass": _u("kg", 1.0),
    "pressure": _u("MPa", 1e6),
    "torque": _u("N·m", 1.0),
    "energy": _u("J", 1.0),
    "angle": _u("deg", math.pi / 180.0),
    "angular_speed": _u("rpm", 2.0 * math.pi / 60.0),
    "inertia": _u("kg·m²", 1.0),
    "density": _u("kg/m³", 1.0),
    "area": _u("mm²", 1e-6),
    "slowness": _u("s/m", 1.0),
}

#: The ``us`` choice: inch, pound-force, pound; psi; rpm, deg.
US: dict[str, Unit] = {
    "length": _u("in", INCH),
    "velocity": _u("in/s", INCH),
    "acceleration": _u("in/s²", INCH),
    "jerk": _u("in/s³", INCH),
    "length/time^4": _u("in/s⁴", INCH),
    "length/time^5": _u("in/s⁵", INCH),
    "length/time^6": _u("in/s⁶", INCH),
    "force": _u("lbf", LBF),
    "stiffness": _u("lbf/in", LBF / INCH),
    "damping": _u("lbf·s/in", LBF / INCH),
    "quadratic_damping": _u("lbf·s²/in²", LBF / INCH**2),
    "mass": _u("lb", POUND),
    "pressure": _u("psi", LBF / INCH**2),
    "torque": _u("lbf·in", LBF * INCH),
    "energy": _u("in·lbf", LBF * INCH),
    "angle": _u("deg", math.pi / 180.0),
    "angular_speed": _u("rpm", 2.0 * math.pi / 60.0),
    "inertia": _u("lb·in²", POUND * INCH**2),
    "density": _u("lb/in³", POUND / INCH**3),
    "area": _u("in²", INCH**2),
    "slowness": _u("s/in", 1.0 / INCH),
}

#: Dimensions a machine file's units are counted for directly; the others are composed.
BASE = ("length", "force", "mass", "angle", "angular_speed")
#: Metric length symbols: their derived units are the coherent SI ones (m/s, N/m, not mm/s).
_METRIC_LENGTHS = {"m", "mm", "cm", "dm", "km", "µm", "um", "nm"}
_METRIC_FORCES = {"N", "kN", "mN", "MN", "kgf"}
_METRIC_MASSES = {"kg", "g", "t", "mg"}

_SUPERSCRIPT = {"2": "²", "3": "³", "4": "⁴", "5": "⁵", "6": "⁶", "-1": "⁻¹"}


def typographic(text: str) -> str:
    """One typographic form of a unit text for human output: ``m/s^2``, ``m/s**2`` → ``m/s²``;
    ``N*s/m`` → ``N·s/m``."""
    for power, sup in _SUPERSCRIPT.items():
        text = text.replace(f"**{power}", sup).replace(f"^{power}", sup)
    return text.replace("*", "·")


def pint_text(text: str) -> str:
    """A display unit text as pint reads it: ``lbf·s²/in`` → ``lbf*s**2/in`` (for files written in it)."""
    for power, sup in _SUPERSCRIPT.items():
        text = text.replace(sup, f"**{power}")
    return text.replace("·", "*")


def si_dimension(si_unit: str) -> tuple[str, float] | None:
    """(dimension, size in coherent SI) of an SI unit text as the code writes it, or None."""
    return _SI_TEXT.get(si_unit.strip())


def compose(base: Mapping[str, Unit]) -> dict[str, Unit]:
    """Every dimension's unit from the base choices (length, force, mass, angle, angular speed).

    Metric lengths (mm, m, µm) give the coherent SI derived units (m/s, m/s², N/m, N·s/m,
    MPa, N·m, J, kg·m²) with the force and mass chosen; inch-pound lengths give their own
    (in/s, in/s², lbf/in, lbf·s/in, psi when the force is lbf, lbf·in, in·lbf, lb·in²).
    A force of one system with lengths of the other (N with in) gives force/length units in
    the force's system (N/m, N·s/m). Lengths themselves, areas and the base dimensions stay as
    chosen.
    """
    length, force, mass = base["length"], base["force"], base["mass"]
    if length.text in _METRIC_LENGTHS:
        k = Unit("m", 1.0)
    elif length.text in ("thou", "mil"):
        k = Unit("in", INCH)
    else:
        k = length
    out = dict(base)
    out["velocity"] = Unit(f"{k.text}/s", k.size)
    out["acceleration"] = Unit(f"{k.text}/s²", k.size)
    out["jerk"] = Unit(f"{k.text}/s³", k.size)
    for n, sup in ((4, "⁴"), (5, "⁵"), (6, "⁶")):
        out[f"length/time^{n}"] = Unit(f"{k.text}/s{sup}", k.size)
    if (force.text in _METRIC_FORCES) != (k.text == "m"):
        # A force of one system and lengths of the other (N with in, lbf with mm): the
        # force/length units follow the force's system, never N·s/in or lbf/m.
        k_force = Unit("m", 1.0) if force.text in _METRIC_FORCES else Unit("in", INCH)
    else:
        k_force = k
    out["stiffness"] = Unit(f"{force.text}/{k_force.text}", force.size / k_force.size)
    out["damping"] = Unit(f"{force.text}·s/{k_force.text}", force.size / k_force.size)
    out["quadratic_damping"] = Unit(f"{force.text}·s²/{k_force.text}²", force.size / k_force.size**2)
    if force.text == "lbf" and k_force.text == "in":
        out["pressure"] = Unit("psi", LBF / INCH**2)
    elif k_force.text == "m" and force.text == "N":
        out["pressure"] = Unit("MPa", 1e6)
    else:
        out["pressure"] = Unit(f"{force.text}/{k_force.text}²", force.size / k_force.size**2)
    out["torque"] = Unit(f"{force.text}·{k_force.text}", force.size * k_force.size)
    out["energy"] = (Unit("J", 1.0) if (k_force.text == "m" and force.text == "N")
                     else Unit(f"{k_force.text}·{force.text}", force.size * k_force.size))
    # A mass of one system with lengths of the other (lb with mm): inertia and density in the
    # mass's system (lb·in², never lb·m²), as force/length units follow the force's.
    if (mass.text in _METRIC_MASSES) != (k.text == "m"):
        k_mass = Unit("m", 1.0) if mass.text in _METRIC_MASSES else Unit("in", INCH)
    else:
        k_mass = k
    out["inertia"] = Unit(f"{mass.text}·{k_mass.text}²", mass.size * k_mass.size**2)
    out["density"] = Unit(f"{mass.text}/{k_mass.text}³", mass.size / k_mass.size**3)
    out["area"] = Unit(f"{length.text}²", length.size**2)
    out["slowness"] = Unit(f"s/{k.text}", 1.0 / k.size)
    return out


@dataclass(frozen=True)
class DisplayUnits:
    """The units human output is shown in: dimension → :class:`Unit`.

    Attributes
    ----------
    system : str
        ``"file"`` (what the machine file wrote), ``"si"`` or ``"us"``.
    units : tuple of (str, Unit)
        Dimension → unit, sorted by dimension (hashable, deterministic JSON).
    """

    system: str
    units: tuple[tuple[str, Unit], ...]

    # -- construction ---------------------------------------------------------------
    @classmethod
    def of(cls, system: str, units: Mapping[str, Unit]) -> DisplayUnits:
        full = {**SI, **units}
        return cls(system, tuple(sorted(full.items())))

    @classmethod
    def si(cls) -> DisplayUnits:
        return cls.of("si", SI)

    @classmethod
    def us(cls) -> DisplayUnits:
        return cls.of("us", US)

    def to_json(self) -> str:
        """``{"system": ..., "units": {dimension: [text, size]}}`` (sorted keys: same bytes each run)."""
        return json.dumps({"system": self.system, "units": {d: [u.text, u.size] for d, u in self.units}},
                          sort_keys=True, ensure_ascii=False)

    @classmethod
    def from_json(cls, text: str) -> DisplayUnits:
        """The choice :meth:`to_json` wrote; ValueError for anything else."""
        data = json.loads(text)
        units = {str(d): Unit(str(t), float(s)) for d, (t, s) in data["units"].items()}
        if not all(math.isfinite(u.size) and u.size > 0 for u in units.values()):
            raise ValueError("display units: sizes must be finite and positive")
        return cls.of(str(data.get("system", "file")), units)

    # -- use ------------------------------------------------------------------------
    def unit(self, dimension: str) -> Unit:
        """The unit of ``dimension`` (a key of :data:`SI`)."""
        return dict(self.units)[dimension]

    def shown(self, si_unit: str) -> tuple[str, float]:
        """(printed unit, factor from SI) of a value whose SI unit is ``si_unit``.

        ``"N"`` → ``("lbf", 0.2248)`` under an inch-pound choice; units that are the same in
        every system (s, Hz, %, numbers) come back as they are, in typographic form.
        """
        found = si_dimension(si_unit)
        if found is None:
            return typographic(si_unit), 1.0
        dimension, size = found
        unit = self.unit(dimension)
        return unit.text, size / unit.size

    def convert(self, value: Any, si_unit: str) -> Any:
        """``value`` (a float or an array in ``si_unit``) in its display unit."""
        return value * self.shown(si_unit)[1]

    def quantity(self, value: float | None, si_unit: str, fmt: str = ".4g") -> str:
        """``"50.66 lbf"``: a value with its display unit (``"–"`` for None or NaN)."""
        if value is None or (isinstance(value, float) and math.isnan(value)):
            return "–"
        unit, k = self.shown(si_unit)
        return f"{format(value * k, fmt)} {unit}".rstrip()

    def power_coefficient(self, exponent: float) -> tuple[str, float]:
        """(printed unit, factor from SI) of a power-law coefficient C of F = C·δ^a [N/m^a]:
        the force and the stiffness's length unit, ``lbf/in^1.425``."""
        force, stiffness = self.unit("force"), self.unit("stiffness")
        length = stiffness.text.rsplit("/", 1)[-1]
        length_size = force.size / stiffness.size
        return f"{force.text}/{length}^{exponent:g}", length_size**exponent / force.size

    def header(self, name: str, si_unit: str) -> str:
        """``"force [lbf]"``: a column header with its display unit (no brackets for numbers)."""
        unit = self.shown(si_unit)[0]
        return f"{name} [{unit}]" if unit else name


def system_units(system: str) -> DisplayUnits:
    """The fixed choices ``si`` and ``us`` (``file`` needs a machine: :mod:`camsim.display.written`)."""
    if system == "us":
        return DisplayUnits.us()
    return DisplayUnits.si()

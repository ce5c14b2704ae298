"""The data of a lumping: the parts file's vocabulary, each part's and each lumped value with
its provenance, and the lumped result (see :mod:`camsim.analyses.lump.lumping`, the API)."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from camsim import elements as element_kinds

#: Unit systems the lumped values can be written in: quantity kind -> unit.
UNIT_SYSTEMS: dict[str, dict[str, str]] = {
    "us": {"mass": "lb", "stiffness": "lbf/in", "force": "lbf", "length": "in", "dimensionless": ""},
    "si": {"mass": "kg", "stiffness": "N/m", "force": "N", "length": "m", "dimensionless": ""},
}
_SI_UNIT = {"mass": "kg", "stiffness": "N/m", "force": "N", "length": "m", "dimensionless": ""}

#: Part types: required keys and their dimensions, optional keys, the kind of the result.
_PART_TYPES: dict[str, dict[str, Any]] = {
    "mass": {"required": {"mass": "mass"}, "optional": {}, "kind": "mass"},
    "inertia": {"required": {"inertia": "inertia", "arm": "length"}, "optional": {}, "kind": "mass"},
    "sum": {"required": {"of": "parts"}, "optional": {}, "kind": None},
    "stiffness": {"required": {"stiffness": "stiffness"}, "optional": {}, "kind": "stiffness"},
    "load-deflection": {"required": {"load": "force", "deflection": "length"}, "optional": {}, "kind": "stiffness"},
    "helical": {
        "required": {
            "wire_diameter": "length",
            "coil_diameter": "length",
            "active_coils": "dimensionless",
            "shear_modulus": "pressure",
        },
        "optional": {},
        "kind": "stiffness",
    },
    "rod": {
        "required": {"length": "length", "modulus": "pressure"},
        "optional": {"area": "area", "outer_diameter": "length", "inner_diameter": "length"},
        "kind": "stiffness",
    },
    "series": {"required": {"of": "parts"}, "optional": {}, "kind": "stiffness"},
    "parallel": {"required": {"of": "parts"}, "optional": {}, "kind": "stiffness"},
    "force": {"required": {"force": "force"}, "optional": {}, "kind": "force"},
    "spring-preload": {
        "required": {"spring": "part", "length": "length", "free_length": "length"},
        "optional": {"initial_tension": "force"},
        "kind": "force",
    },
    "transfer": {"required": {"of": "part", "lever": "lever"}, "optional": {}, "kind": None},
}
_COMMON_PART_KEYS = ("type", "note", "round", "unused")

_TOP_KEYS = ("schema", "machine", "lever", "part", "cam", "mass", "element", "simulation", "initial")
_LEVER_KEYS = ("from_arm", "to_arm", "note")
_MASS_KEYS = ("name", "parts", "lever", "mass", "note")
#: Every key an element may carry: the element kinds' schema (camsim/elements/), plus a note.
_ELEMENT_PARAMS = {p.key: p for cls in element_kinds.classes() for p in (*element_kinds.COMMON_PARAMS, *cls.params)}
_ELEMENT_KEYS = (*_ELEMENT_PARAMS, "note")
#: Element keys that may hold a part reference, and the kind they need (stiffnesses and forces).
# (a key is a stiffness or a force for some kind: `stiffness` is also a lash's or Adams
# contact's power-law coefficient, whichever class registers last)
_ELEMENT_VALUE_KEYS = {p.key: p.dimension for cls in element_kinds.classes() for p in cls.params
                       if p.dimension in ("stiffness", "force")}
_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_KIND_TEXT = {"mass": "a mass", "stiffness": "a stiffness", "force": "a force"}


@dataclass(frozen=True)
class PartValue:
    """One component of the parts file, evaluated.

    Attributes
    ----------
    name : str
        The part's name (``[part.<name>]``).
    kind : str
        ``"mass"`` [kg], ``"stiffness"`` [N/m] or ``"force"`` [N].
    value : float
        The value in SI.
    provenance : str
        How it was obtained, e.g. ``"k_cs = G*d^4/(8*D^3*N) = ... = 25.641 lbf/in"``.
    note : str
        The part's ``note`` (where the data come from).
    unused : str or None
        Why a part that no lumped value uses was kept (its ``unused`` reason).
    """

    name: str
    kind: str
    value: float
    provenance: str
    note: str = ""
    unused: str | None = None


@dataclass(frozen=True)
class LumpedValue:
    """A computed value of the machine file.

    Attributes
    ----------
    key : str
        Where it sits, addressed as in ``--set``: ``mass.M1.mass``, ``element.K23.preload``,
        ``cam.ratio``.
    kind : str
        ``"mass"``, ``"stiffness"``, ``"force"`` or ``"dimensionless"``.
    value : float
        The value in SI [kg, N/m, N or 1].
    text : str
        The value as written in the machine file (a string with units, or a number).
    provenance : str
        The formula with the numbers, e.g. ``"M1 = (m_la + m_cr)*(7.75 in/2.375 in)^2 = ..."``.
    note : str
        The ``note`` of the lumped mass or element, if any.
    """

    key: str
    kind: str
    value: float
    text: str | float
    provenance: str
    note: str = ""


@dataclass
class LumpResult:
    """The machine a parts file reduces to, with the provenance of every computed value.

    Attributes
    ----------
    machine : dict
        The machine file as a dict (spec §6), ready for ``tomli_w``.
    values : list of LumpedValue
        The computed values, in file order.
    parts : dict of str to PartValue
        Every part of the parts file, evaluated.
    source : str
        The parts file, for messages and the header of the written file.
    units : str
        ``"us"`` or ``"si"``: how the computed values are written.
    base_dir : Path
        The parts file's directory (a relative cam ``table`` path is relative to it).
    checked : bool
        True when :mod:`camsim.machine.loader` validated the whole machine (pass-through sections
        included); False when no loader was available.
    """

    machine: dict[str, Any]
    values: list[LumpedValue]
    parts: dict[str, PartValue]
    source: str = "<string>"
    units: str = "us"
    base_dir: Path = Path(".")
    checked: bool = False
    _comments: dict[tuple[str, ...], list[str]] = field(default_factory=dict, repr=False)

    def to_toml(self) -> str:
        """The machine file text, with a ``# ...`` comment above every computed value.

        Returns
        -------
        str
            TOML that :mod:`tomllib` reads back to :attr:`machine`.
        """
        from camsim.analyses.lump.files import render_machine

        return render_machine(self)

    def to_json(self) -> dict[str, Any]:
        """The lumped values and the parts in SI, with their provenance (for ``--json``)."""
        return {
            "machine": self.machine.get("machine", {}).get("name", ""),
            "parts_file": self.source,
            "values": [
                {
                    "key": v.key,
                    "quantity": v.kind,
                    "value": v.value,
                    "unit": _SI_UNIT[v.kind],
                    "written": v.text,
                    "provenance": v.provenance,
                    "note": v.note,
                }
                for v in self.values
            ],
            "parts": [
                {
                    "name": p.name,
                    "quantity": p.kind,
                    "value": p.value,
                    "unit": _SI_UNIT[p.kind],
                    "provenance": p.provenance,
                    "note": p.note,
                    "unused": p.unused,
                }
                for p in self.parts.values()
            ],
        }


# --------------------------------------------------------------------------- reading

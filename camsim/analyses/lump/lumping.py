"""Lumped-parameter reduction: from a designer's parts file to a camsim machine file.

A *parts file* (TOML, documented in ``docs/lumping.md``) lists the components of a
machine — masses, moments of inertia about pivots, helical springs, axial rods, stiffnesses
from a load and a deflection, series and parallel combinations — the levers that transfer
them to the model axis, and which parts become each lumped mass and each element. This
module computes the lumped values as in the thesis (appendix A: lumping techniques,
appendices D–F, chapter 6.1–6.2) and returns a complete machine (spec §6) as a dict ready
for ``tomli_w``, with a provenance text for every computed value.

Formulas (every value in SI inside):

* rotating part: m = I / r²                                   (thesis eq. A.1)
* lever transfer from arm r_a to arm r_b of the same rigid lever: mass and stiffness
  × (r_a/r_b)², force × (r_a/r_b), motion × (r_b/r_a)          (thesis appendix A, fig 6.4/6.6)
* helical spring: k = G·d⁴ / (8·D³·N)                        (thesis appendix E, eq. 1)
* axial rod: k = A·E / L                                      (thesis eq. A.3)
* stiffness from a load and its deflection: k = F / δ         (thesis eq. A.2)
* series 1/k = Σ 1/kᵢ, parallel k = Σ kᵢ                      (thesis appendices E, F)
* spring preload: P = k·(L − L0) + F_initial                  (thesis appendix E)

This module is the API and the result; the parts are evaluated in :mod:`camsim.analyses.lump.parts`
and the machine file is written by :mod:`camsim.analyses.lump.files`.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from camsim import elements as element_kinds
from camsim.errors import InputError, MachineFileError

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


def load_parts(path: str | Path, *, units: str = "us") -> LumpResult:
    """Read a parts file and reduce it to a machine.

    Parameters
    ----------
    path : path
        The parts file (TOML).
    units : {"us", "si"}
        Units of the computed values in the machine: lb, lbf/in, lbf (the thesis's) or
        kg, N/m, N.

    Returns
    -------
    LumpResult

    Raises
    ------
    MachineFileError
        An error in the parts file, naming the file and the key path.
    InputError
        The file cannot be read.
    """
    name = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"{name}: no such file") from None
    except OSError as exc:
        raise InputError(f"{name}: cannot read: {exc.strerror}") from None
    return lump_text(text, file=name, units=units, base_dir=Path(path).parent)


def lump_text(
    text: str, *, file: str = "<string>", units: str = "us", base_dir: str | Path = "."
) -> LumpResult:
    """Reduce the parts file given as TOML text (see :func:`load_parts`).

    ``base_dir`` is the directory a relative cam ``table`` path is relative to.
    """
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MachineFileError(file, "", f"not valid TOML: {exc}") from None
    return lump(document, file=file, units=units, base_dir=base_dir)


def lump(
    document: dict[str, Any], *, file: str = "<string>", units: str = "us", base_dir: str | Path = "."
) -> LumpResult:
    """Reduce a parsed parts file to a machine (see :func:`load_parts`).

    The machine is then validated with :func:`camsim.machine.loader.load_machine_text` when that
    loader exists (errors name the parts file and the same key path).
    """
    if units not in UNIT_SYSTEMS:
        raise InputError(f"units must be one of {', '.join(UNIT_SYSTEMS)}, got {units!r}")
    from camsim.analyses.lump.parts import Lumper

    result = Lumper(document, file, units).run()
    result.base_dir = Path(base_dir)
    result.checked = _validate_text(result, result.to_toml(), result.base_dir)
    return result


def write_machine(result: LumpResult, target: str | Path, *, validate: bool = True) -> Path:
    """Write the machine file atomically; check it with the machine loader first if present.

    Parameters
    ----------
    result : LumpResult
    target : path
        The machine file to write (replaced if it exists).
    validate : bool
        Load the written text with :func:`camsim.machine.loader.load_machine` before renaming it
        into place, when that loader exists; its errors are reported against the parts file.

    Returns
    -------
    Path
        ``target``.
    """
    import os

    from camsim.io.atomic import atomic_path

    table = result.machine.get("cam", {}).get("table")
    if isinstance(table, str) and not Path(table).is_absolute():
        # keep a relative CSV path pointing at the same file from the output's directory
        where = Path(os.path.relpath(result.base_dir / table, Path(target).parent or Path(".")))
        result.machine["cam"]["table"] = where.as_posix()
    text = result.to_toml()
    with atomic_path(target) as tmp:
        tmp.write_text(text, encoding="utf-8")
        if validate:
            check_with_loader(result, tmp)
    return Path(target)


def check_with_loader(result: LumpResult, machine_path: str | Path) -> bool:
    """Load ``machine_path`` with :func:`camsim.machine.loader.load_machine`, if the loader exists.

    Returns
    -------
    bool
        True if the file was loaded, False if there is no loader to check with.

    Raises
    ------
    MachineFileError
        The loader rejected the machine; the message names the parts file and the key.
    """
    path = Path(machine_path)
    return _validate_text(result, path.read_text(encoding="utf-8"), path.parent)


def _validate_text(result: LumpResult, text: str, base_dir: Path) -> bool:
    try:
        from camsim.machine.loader import load_machine_text
    except ImportError:  # the loader is optional for lumping
        return False
    try:
        load_machine_text(text, source=result.source, base_dir=base_dir)
    except MachineFileError as exc:
        raise MachineFileError(result.source, exc.key, f"{exc.message} (in the lumped machine)") from None
    except InputError as exc:
        raise MachineFileError(result.source, "", f"lumped machine rejected: {exc}") from None
    return True

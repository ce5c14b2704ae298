"""Evaluating a parts file: each part's value, with the formula that gave it (see :mod:`camsim.analyses.lump.lumping`).

:class:`Lumper` walks the parts file, resolves references between parts (with cycle
detection), applies the lumping formulas of the thesis (appendix A, D–F) and builds the
lumped masses and elements with a provenance text for each value.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from camsim.errors import MachineFileError
from camsim.analyses.lump.values import (
    _COMMON_PART_KEYS,
    _ELEMENT_KEYS,
    _ELEMENT_VALUE_KEYS,
    _IDENTIFIER,
    _KIND_TEXT,
    _LEVER_KEYS,
    _MASS_KEYS,
    _PART_TYPES,
    _SI_UNIT,
    _TOP_KEYS,
    UNIT_SYSTEMS,
    LumpedValue,
    LumpResult,
    PartValue,
)
from camsim.units import QuantityError, to_si, ureg


@dataclass
class _Ref:
    """A reference from a lumped value to a part, optionally through levers."""

    parts: list[str]
    levers: list[str]


class Lumper:
    def __init__(self, document: dict[str, Any], file: str, units: str):
        self.doc = document
        self.file = file
        self.units = units
        self.levers: dict[str, tuple[float, float, str, str]] = {}
        self.raw_parts: dict[str, dict[str, Any]] = {}
        self.parts: dict[str, PartValue] = {}
        self.used: set[str] = set()
        self.values: list[LumpedValue] = []
        self.comments: dict[tuple[str, ...], list[str]] = {}

    # -- errors and helpers
    def error(self, key: str, message: str) -> MachineFileError:
        return MachineFileError(self.file, key, message)

    def table(self, value: Any, key: str) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.error(key, f"expected a table, got {value!r}")
        return value

    def check_keys(self, table: dict[str, Any], allowed: tuple[str, ...] | list[str], key: str) -> None:
        for k in table:
            if k not in allowed:
                hint = difflib.get_close_matches(k, allowed, n=1)
                extra = f" (did you mean {hint[0]!r}?)" if hint else f"; allowed: {', '.join(allowed)}"
                raise self.error(f"{key}.{k}" if key else k, f"unknown key{extra}")

    def quantity(self, value: Any, dimension: str, key: str, *, positive: bool = True) -> float:
        try:
            if dimension == "inertia":
                number = _inertia_to_si(value)
            else:
                number = to_si(value, dimension)
        except QuantityError as exc:
            raise self.error(key, str(exc)) from None
        if positive and not number > 0:
            raise self.error(key, f"must be > 0, got {value!r}")
        if not positive and number < 0:
            raise self.error(key, f"must be ≥ 0, got {value!r}")
        return number

    def show(self, value: float, kind: str) -> str:
        """A value in the display units, 6 significant digits: ``16.3514 lb``."""
        unit = unit_table(self.units)[kind]
        return f"{_num(_convert(value, kind, unit))} {unit}".strip()

    def written(self, value: float, kind: str) -> str | float:
        """A value as written in the machine file: 7 significant digits with its unit."""
        unit = unit_table(self.units)[kind]
        if not unit:
            return float(f"{value:.7g}")
        return f"{_convert(value, kind, unit):.7g} {unit}"

    # -- the whole file
    def run(self) -> LumpResult:
        doc = self.table(self.doc, "")
        self.check_keys(doc, _TOP_KEYS, "")
        if doc.get("schema") != 1:
            raise self.error("schema", f"expected schema = 1, got {doc.get('schema')!r}")
        for name, lever in self.table(doc.get("lever", {}), "lever").items():
            self.read_lever(name, lever)
        self.raw_parts = dict(self.table(doc.get("part", {}), "part"))
        for name in self.raw_parts:
            self.evaluate(name, [])
        machine: dict[str, Any] = {"schema": 1}
        machine["machine"] = dict(self.table(doc.get("machine", {"name": Path(self.file).stem}), "machine"))
        if "cam" in doc:
            machine["cam"] = self.read_cam(self.table(doc["cam"], "cam"))
        masses = doc.get("mass", [])
        if not isinstance(masses, list) or not masses:
            raise self.error("mass", "expected at least one [[mass]] table")
        machine["mass"] = [self.read_mass(i, m) for i, m in enumerate(masses)]
        elements = doc.get("element", [])
        if not isinstance(elements, list):
            raise self.error("element", "expected [[element]] tables")
        machine["element"] = [self.read_element(i, e) for i, e in enumerate(elements)]
        for section in ("simulation", "initial"):
            if section in doc:
                machine[section] = self.table(doc[section], section)
        self.check_attached()
        result = LumpResult(machine, self.values, self.parts, self.file, self.units)
        result._comments = self.comments
        return result

    def read_lever(self, name: str, lever: Any) -> None:
        key = f"lever.{name}"
        lever = self.table(lever, key)
        self.check_keys(lever, _LEVER_KEYS, key)
        arms = []
        for arm in ("from_arm", "to_arm"):
            if arm not in lever:
                raise self.error(key, f"missing key {arm!r} (distance from the pivot) ")
            value = self.quantity(lever[arm], "length", f"{key}.{arm}", positive=False)
            if value == 0:
                raise self.error(f"{key}.{arm}", f"lever arm of zero ({lever[arm]!r}): nothing can be transferred")
            arms.append(value)
        self.levers[name] = (arms[0], arms[1], _given(lever["from_arm"], "m"), _given(lever["to_arm"], "m"))

    def lever_factor(self, names: Any, key: str, power: int) -> tuple[float, str]:
        """Factor and text of a lever chain: (r_a/r_b)^power per lever."""
        if isinstance(names, str):
            names = [names]
        if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
            raise self.error(key, f"expected a lever name or a list of lever names, got {names!r}")
        factor, texts = 1.0, []
        for i, name in enumerate(names):
            if name not in self.levers:
                raise self.error(key if len(names) == 1 else f"{key}[{i}]", _undefined("lever", name, self.levers))
            ra, rb, ta, tb = self.levers[name]
            if power < 0:
                ra, rb, ta, tb = rb, ra, tb, ta
            factor *= (ra / rb) ** abs(power)
            texts.append(f"({ta}/{tb})" + (f"^{abs(power)}" if abs(power) != 1 else ""))
        return factor, "*".join(texts)

    # -- parts
    def evaluate(self, name: str, chain: list[str]) -> PartValue:
        if name in self.parts:
            return self.parts[name]
        key = f"part.{name}"
        if name in chain:
            raise self.error(key, "circular reference: " + " -> ".join(chain[chain.index(name):] + [name]))
        spec = self.table(self.raw_parts[name], key)
        kind_name = spec.get("type")
        if kind_name not in _PART_TYPES:
            hint = difflib.get_close_matches(str(kind_name), _PART_TYPES, n=1)
            extra = f" (did you mean {hint[0]!r}?)" if hint else f"; one of {', '.join(_PART_TYPES)}"
            raise self.error(f"{key}.type", f"unknown part type {kind_name!r}{extra}")
        rule = _PART_TYPES[kind_name]
        self.check_keys(spec, [*_COMMON_PART_KEYS, *rule["required"], *rule["optional"]], key)
        for k in rule["required"]:
            if k not in spec:
                raise self.error(key, f"a {kind_name!r} part needs key {k!r}")
        chain = [*chain, name]
        kind, value, expr = getattr(self, "part_" + kind_name.replace("-", "_"))(spec, key, chain)
        provenance = f"{name} = {expr}"
        if "round" in spec:
            step = self.quantity(spec["round"], _DIMENSION_OF_KIND[kind], f"{key}.round")
            value = round(value / step) * step
            provenance += f", rounded to {_given(spec['round'], _SI_UNIT[kind])} as the source prints it: {self.show(value, kind)}"
        note = spec.get("note", "")
        unused = spec.get("unused")
        for k, v in (("note", note), ("unused", unused)):
            if v is not None and not isinstance(v, str):
                raise self.error(f"{key}.{k}", f"expected a text, got {v!r}")
        part = PartValue(name, kind, value, provenance, note, unused)
        self.parts[name] = part
        return part

    def ref(self, name: Any, key: str, chain: list[str], kinds: tuple[str, ...] | None = None) -> PartValue:
        if not isinstance(name, str):
            raise self.error(key, f"expected a part name, got {name!r}")
        if name not in self.raw_parts:
            raise self.error(key, _undefined("part", name, self.raw_parts))
        part = self.evaluate(name, chain)
        if kinds is not None and part.kind not in kinds:
            wanted = " or ".join(_KIND_TEXT[k] for k in kinds)
            raise self.error(key, f"part {name!r} is {_KIND_TEXT[part.kind]}, expected {wanted}")
        self.used.add(name)
        return part

    def refs(self, names: Any, key: str, chain: list[str], kinds: tuple[str, ...]) -> list[PartValue]:
        if not isinstance(names, list) or not names:
            raise self.error(key, f"expected a non-empty list of part names, got {names!r}")
        parts = [self.ref(n, f"{key}[{i}]", chain, kinds) for i, n in enumerate(names)]
        if len({p.kind for p in parts}) > 1:
            raise self.error(key, "cannot combine " + ", ".join(f"{p.name} ({p.kind})" for p in parts))
        return parts

    def part_mass(self, spec, key, chain):
        m = self.quantity(spec["mass"], "mass", f"{key}.mass")
        return "mass", m, f"{_given(spec['mass'], 'kg')} (given)"

    def part_inertia(self, spec, key, chain):
        inertia = self.quantity(spec["inertia"], "inertia", f"{key}.inertia")
        arm = self.quantity(spec["arm"], "length", f"{key}.arm", positive=False)
        if arm == 0:
            raise self.error(f"{key}.arm", f"lever arm of zero ({spec['arm']!r}): m = I/r^2 is undefined")
        m = inertia / arm**2
        return "mass", m, f"I/r^2 = {_given(spec['inertia'], 'kg*m^2')}/({_given(spec['arm'], 'm')})^2 = {self.show(m, 'mass')}"

    def part_sum(self, spec, key, chain):
        parts = self.refs(spec["of"], f"{key}.of", chain, ("mass", "force"))
        kind = parts[0].kind
        total = math.fsum(p.value for p in parts)
        names = " + ".join(p.name for p in parts)
        numbers = " + ".join(self.show(p.value, kind) for p in parts)
        return kind, total, f"{names} = {numbers} = {self.show(total, kind)}"

    def part_stiffness(self, spec, key, chain):
        k = self.quantity(spec["stiffness"], "stiffness", f"{key}.stiffness")
        return "stiffness", k, f"{_given(spec['stiffness'], 'N/m')} (given)"

    def part_load_deflection(self, spec, key, chain):
        f = self.quantity(spec["load"], "force", f"{key}.load")
        d = self.quantity(spec["deflection"], "length", f"{key}.deflection")
        k = f / d
        return "stiffness", k, f"F/delta = {_given(spec['load'], 'N')}/{_given(spec['deflection'], 'm')} = {self.show(k, 'stiffness')}"

    def part_helical(self, spec, key, chain):
        d = self.quantity(spec["wire_diameter"], "length", f"{key}.wire_diameter")
        D = self.quantity(spec["coil_diameter"], "length", f"{key}.coil_diameter")
        n = self.quantity(spec["active_coils"], "dimensionless", f"{key}.active_coils")
        G = self.quantity(spec["shear_modulus"], "pressure", f"{key}.shear_modulus")
        if D <= d:
            raise self.error(f"{key}.coil_diameter", "mean coil diameter must exceed the wire diameter")
        k = G * d**4 / (8.0 * D**3 * n)
        g = {k2: _given(spec[k2], u) for k2, u in
             (("wire_diameter", "m"), ("coil_diameter", "m"), ("active_coils", ""), ("shear_modulus", "Pa"))}
        return "stiffness", k, (
            f"G*d^4/(8*D^3*N) = {g['shear_modulus']}*({g['wire_diameter']})^4/(8*({g['coil_diameter']})^3"
            f"*{g['active_coils']}) = {self.show(k, 'stiffness')}"
        )

    def part_rod(self, spec, key, chain):
        L = self.quantity(spec["length"], "length", f"{key}.length")
        E = self.quantity(spec["modulus"], "pressure", f"{key}.modulus")
        has_area, has_od = "area" in spec, "outer_diameter" in spec
        if has_area == has_od:
            raise self.error(key, "a 'rod' part needs either 'area' or 'outer_diameter' (and optional 'inner_diameter')")
        if has_area:
            if "inner_diameter" in spec:
                raise self.error(f"{key}.inner_diameter", "give 'inner_diameter' with 'outer_diameter', not with 'area'")
            A = self.quantity(spec["area"], "area", f"{key}.area")
            a_text = _given(spec["area"], "m^2")
        else:
            do = self.quantity(spec["outer_diameter"], "length", f"{key}.outer_diameter")
            di = self.quantity(spec.get("inner_diameter", 0.0), "length", f"{key}.inner_diameter", positive=False)
            if di >= do:
                raise self.error(f"{key}.inner_diameter", "inner diameter must be smaller than the outer diameter")
            A = math.pi / 4.0 * (do**2 - di**2)
            a_text = f"pi/4*(({_given(spec['outer_diameter'], 'm')})^2"
            a_text += f" - ({_given(spec['inner_diameter'], 'm')})^2)" if "inner_diameter" in spec else ")"
        k = A * E / L
        return "stiffness", k, (
            f"A*E/L = {a_text}*{_given(spec['modulus'], 'Pa')}/{_given(spec['length'], 'm')} = {self.show(k, 'stiffness')}"
        )

    def part_series(self, spec, key, chain):
        parts = self.refs(spec["of"], f"{key}.of", chain, ("stiffness",))
        k = 1.0 / math.fsum(1.0 / p.value for p in parts)
        names = " + ".join(f"1/{p.name}" for p in parts)
        numbers = " + ".join(f"1/{self.show(p.value, 'stiffness')}" for p in parts)
        return "stiffness", k, f"1/({names}) = 1/({numbers}) = {self.show(k, 'stiffness')}"

    def part_parallel(self, spec, key, chain):
        parts = self.refs(spec["of"], f"{key}.of", chain, ("stiffness",))
        k = math.fsum(p.value for p in parts)
        names = " + ".join(p.name for p in parts)
        numbers = " + ".join(self.show(p.value, "stiffness") for p in parts)
        return "stiffness", k, f"{names} = {numbers} = {self.show(k, 'stiffness')}"

    def part_force(self, spec, key, chain):
        f = self.quantity(spec["force"], "force", f"{key}.force", positive=False)
        return "force", f, f"{_given(spec['force'], 'N')} (given)"

    def part_spring_preload(self, spec, key, chain):
        spring = self.ref(spec["spring"], f"{key}.spring", chain, ("stiffness",))
        L = self.quantity(spec["length"], "length", f"{key}.length")
        L0 = self.quantity(spec["free_length"], "length", f"{key}.free_length")
        fi = self.quantity(spec.get("initial_tension", 0.0), "force", f"{key}.initial_tension", positive=False)
        p = spring.value * (L - L0) + fi
        text = (
            f"k*(L - L0) + Fi = {spring.name}*({_given(spec['length'], 'm')} - {_given(spec['free_length'], 'm')})"
            f" + {_given(spec.get('initial_tension', 0.0), 'N')}"
            f" = {self.show(spring.value, 'stiffness')}*({_given(spec['length'], 'm')} - {_given(spec['free_length'], 'm')})"
            f" + {_given(spec.get('initial_tension', 0.0), 'N')} = {self.show(p, 'force')}"
        )
        return "force", p, text

    def part_transfer(self, spec, key, chain):
        part = self.ref(spec["of"], f"{key}.of", chain, None)
        power = 1 if part.kind == "force" else 2
        factor, text = self.lever_factor(spec["lever"], f"{key}.lever", power)
        value = part.value * factor
        return part.kind, value, (
            f"{part.name}*{text} = {self.show(part.value, part.kind)}*{_num(factor)} = {self.show(value, part.kind)}"
        )

    # -- lumped values
    def record(self, path, key, kind, value, label, expr, note, parts=()):
        text = self.written(value, kind)
        provenance = f"{label} = {expr}"
        self.values.append(LumpedValue(key, kind, value, text, provenance, note))
        lines = [provenance]
        lines += [f"  where {self.parts[p].provenance}" for p in parts if not self.parts[p].provenance.endswith("(given)")]
        self.comments[path] = lines
        return text

    def combine(self, ref: _Ref, key: str, kind: str, label: str, ref_key: str) -> tuple[float, str]:
        parts = [self.ref(n, f"{ref_key}[{i}]" if len(ref.parts) > 1 else ref_key, [], (kind,))
                 for i, n in enumerate(ref.parts)]
        total = math.fsum(p.value for p in parts)
        names = " + ".join(p.name for p in parts)
        numbers = " + ".join(self.show(p.value, kind) for p in parts)
        if ref.levers:
            power = 1 if kind == "force" else 2
            factor, ftext = self.lever_factor(ref.levers, f"{key}.lever", power)
            value = total * factor
            if len(parts) > 1:
                expr = f"({names})*{ftext} = ({numbers})*{_num(factor)} = {self.show(value, kind)}"
            else:
                expr = f"{names}*{ftext} = {numbers}*{_num(factor)} = {self.show(value, kind)}"
        else:
            value = total
            expr = f"{names} = {numbers}" + (f" = {self.show(value, kind)}" if len(parts) > 1 else "")
        return value, expr

    def note(self, entry: dict[str, Any], key: str, path: tuple[str, ...]) -> str:
        """The ``note`` of a lumped mass or element: checked, and written under its header."""
        note = entry.get("note", "")
        if not isinstance(note, str):
            raise self.error(f"{key}.note", f"expected a text, got {note!r}")
        if note:
            self.comments[(*path, "")] = [f"note: {note}"]
        return note

    def read_mass(self, i: int, entry: Any) -> dict[str, Any]:
        key = f"mass[{i}]"
        entry = self.table(entry, key)
        self.check_keys(entry, _MASS_KEYS, key)
        name = entry.get("name")
        if not isinstance(name, str) or not name:
            raise self.error(f"{key}.name", f"expected a name, got {name!r}")
        if ("parts" in entry) == ("mass" in entry):
            raise self.error(key, "give either 'parts' (lumped from the parts file) or 'mass' (a value)")
        note = self.note(entry, key, ("mass", str(i)))
        if "mass" in entry:
            if "lever" in entry:
                raise self.error(f"{key}.lever", "'lever' applies to 'parts', not to a given 'mass'")
            self.quantity(entry["mass"], "mass", f"{key}.mass")
            return {"name": name, "mass": entry["mass"]}
        names = entry["parts"]
        if isinstance(names, str):
            names = [names]
        if not isinstance(names, list) or not names:
            raise self.error(f"{key}.parts", f"expected a list of part names, got {entry['parts']!r}")
        ref = _Ref(names, _as_list(entry.get("lever")))
        value, expr = self.combine(ref, key, "mass", name, f"{key}.parts")
        text = self.record(("mass", str(i), "mass"), f"mass.{name}.mass", "mass", value, name, expr, note, ref.parts)
        return {"name": name, "mass": text}

    def read_element(self, i: int, entry: Any) -> dict[str, Any]:
        key = f"element[{i}]"
        entry = self.table(entry, key)
        self.check_keys(entry, _ELEMENT_KEYS, key)
        name = entry.get("name")
        if not isinstance(name, str) or not name:
            raise self.error(f"{key}.name", f"expected a name, got {name!r}")
        note = self.note(entry, key, ("element", str(i)))
        out: dict[str, Any] = {}
        for k, v in entry.items():
            if k == "note":
                continue
            if k not in _ELEMENT_VALUE_KEYS:
                out[k] = v
                continue
            kind = _ELEMENT_VALUE_KEYS[k]
            ref = self.value_ref(v, f"{key}.{k}")
            if ref is None:  # a given quantity: checked and passed through as written
                self.quantity(v, _DIMENSION_OF_KIND[kind], f"{key}.{k}", positive=kind != "force")
                out[k] = v
                continue
            value, expr = self.combine(ref, f"{key}.{k}", kind, f"{name} {k}", f"{key}.{k}")
            out[k] = self.record(
                ("element", str(i), k), f"element.{name}.{k}", kind, value, f"{name} {k}", expr, note, ref.parts
            )
        return out

    def value_ref(self, value: Any, key: str) -> _Ref | None:
        """A part reference (name, or {part, lever}) or None for a given quantity."""
        if isinstance(value, dict):
            self.check_keys(value, ("part", "lever"), key)
            if "part" not in value:
                raise self.error(key, "a reference needs key 'part'")
            return _Ref(_as_list(value["part"]), _as_list(value.get("lever")))
        if isinstance(value, str) and _IDENTIFIER.match(value.strip()):
            name = value.strip()
            if name not in self.raw_parts:
                raise self.error(key, _undefined("part", name, self.raw_parts))
            return _Ref([name], [])
        return None

    def read_cam(self, cam: dict[str, Any]) -> dict[str, Any]:
        out = dict(cam)
        ratio = cam.get("ratio")
        if isinstance(ratio, dict):
            self.check_keys(ratio, ("lever",), "cam.ratio")
            if "lever" not in ratio:
                raise self.error("cam.ratio", "a computed ratio needs key 'lever' (a lever or a list of levers)")
            factor, text = self.lever_factor(ratio["lever"], "cam.ratio.lever", -1)
            out["ratio"] = float(f"{factor:.7g}")
            expr = f"{text} = {_num(factor)} (motion at the roller -> model axis)"
            self.values.append(LumpedValue("cam.ratio", "dimensionless", factor, out["ratio"], f"ratio = {expr}"))
            self.comments[("cam", "ratio")] = [f"ratio = {expr}"]
        return out

    def check_attached(self) -> None:
        """Every part feeds a lumped value, or is marked ``unused`` with a reason."""
        reachable = set(self.used)
        # a part used only by an unused part is kept for that one's sake
        for name, part in self.parts.items():
            if part.unused is not None:
                reachable.add(name)
                reachable |= self.dependencies(name)
        for name in self.raw_parts:
            if name not in reachable:
                raise self.error(
                    f"part.{name}",
                    "attached to nothing: no lumped mass or element uses it "
                    "(use it, or say why it is kept with unused = \"...\")",
                )

    def dependencies(self, name: str) -> set[str]:
        spec = self.raw_parts[name]
        out: set[str] = set()
        for k in ("of", "spring"):
            refs = _as_list(spec.get(k))
            for r in refs:
                if r in self.raw_parts and r not in out:
                    out.add(r)
                    out |= self.dependencies(r)
        return out


_DIMENSION_OF_KIND = {"mass": "mass", "stiffness": "stiffness", "force": "force"}


def _num(x: float) -> str:
    """6 significant digits, without an exponent between 1e-4 and 1e9: ``4638219``, ``0.0924188``."""
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    e = math.floor(math.log10(abs(x)))
    if -4 <= e < 9:
        text = f"{x:.{max(0, 5 - e)}f}"
        return text.rstrip("0").rstrip(".") if "." in text else text
    return f"{x:.6g}"


def _as_list(value: Any) -> list[Any]:
    if value is None:
        return []
    return list(value) if isinstance(value, list) else [value]


def _undefined(what: str, name: str, known: Any) -> str:
    hint = difflib.get_close_matches(name, list(known), n=1)
    return f"no {what} named {name!r}" + (f" (did you mean {hint[0]!r}?)" if hint else "")


def _given(value: Any, si_unit: str) -> str:
    """A given value as the user wrote it (bare numbers are SI)."""
    if isinstance(value, str):
        return value.strip()
    return f"{value:g} {si_unit}".strip()


def unit_table(units: str | dict[str, str]) -> dict[str, str]:
    """Quantity kind → unit of the lumped values: a named system of :data:`UNIT_SYSTEMS`, or a table."""
    return units if isinstance(units, dict) else UNIT_SYSTEMS[units]


def _convert(value: float, kind: str, unit: str) -> float:
    if not unit:
        return value
    return float(ureg.Quantity(value, _SI_UNIT[kind]).to(unit).magnitude)


def _inertia_to_si(value: Any) -> float:
    """A mass moment of inertia [kg·m²] (camsim.units has no such dimension yet)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if not math.isfinite(value):
            raise QuantityError(f"expected a finite [mass]*[length]^2, got {value!r}")
        return float(value)
    if not isinstance(value, str):
        raise QuantityError(f"expected [mass]*[length]^2, got {value!r}")
    # parsed by the shared registry; the conversion to kg*m^2 checks the dimension
    try:
        quantity = ureg.Quantity(value.strip())
        return float(quantity.to("kg*m**2").magnitude)
    except Exception:
        raise QuantityError(f'expected [mass]*[length]^2, got "{value}"') from None


# --------------------------------------------------------------------------- writing

"""Checking a parsed machine document and building the :class:`~camsim.machine.description.Machine` in SI.

Every value is parsed with :func:`camsim.units.to_si` and checked for its dimension and
range against the schema; every problem raises :class:`camsim.errors.MachineFileError`
naming the file and the key path (``element[3].stiffness``, ``cam.segments[2].lift``) with a
one-line message. :mod:`camsim.machine.loader` is the entry point. The cam tables are read
by :mod:`camsim.machine.camreader`, the camshaft and clearances by :mod:`camsim.machine.shaft`, the
``[[load]]`` tables by :mod:`camsim.machine.loadreader`.
"""

from __future__ import annotations

from typing import Any

from camsim import elements as element_kinds
from camsim.machine import schema
from camsim.elements import CAM, FIXED_NODES, GROUND, Damping, Element, Param
from camsim.machine.camreader import (  # noqa: F401 - re-exported for the loader and overrides
    CAM_KEYS,
    DURATION_TOLERANCE_DEG,
    LIFT_TOLERANCE,
    MULTI_CAM_KEYS,
    SEGMENT_KEYS,
)
from camsim.machine.description import (
    STANDARD_GRAVITY,
    Cam,
    InitialCondition,
    Machine,
    Mass,
    Simulation,
)
from camsim.loads.description import Load
from camsim.machine.loadreader import LoadReader
from camsim.machine.materials import MaterialKeys
from camsim.machine.reading import _fmt, _suggest  # noqa: F401 - _suggest re-exported
from camsim.machine.shaft import ShaftReader

# --------------------------------------------------------------------------------------
# Which keys each table may hold: the schema (camsim/machine/schema.py and the element kinds)
# --------------------------------------------------------------------------------------
TOP_KEYS = schema.keys("top")
MACHINE_KEYS = schema.keys("machine")
MASS_KEYS = schema.keys("mass")
SIMULATION_KEYS = schema.keys("simulation")
#: [simulation] steady_state: the warm-up revolutions, or shooting on the revolution's map (camsim.run.steady)
STEADY_STATES = ("warmup", "shooting")
INITIAL_KEYS = schema.keys("initial")
ELEMENT_COMMON_KEYS = tuple(p.key for p in element_kinds.COMMON_PARAMS)
_DAMPING_KEYS = ("damping", "damping_ratio", "reference_mass")

#: The machine-file schema this loader reads (top-level ``schema = 1``).
SCHEMA_VERSION = 1


class _Validator(ShaftReader, LoadReader, MaterialKeys):
    """Walk a parsed document and build the Machine, raising on the first problem."""

    def __init__(self, source: str, base_dir: Path):
        super().__init__(source, base_dir)
        self.materials: dict = {}  # the file's [[material]] tables (issue 39)

    # -- document -----------------------------------------------------------------
    def machine(self, doc: dict) -> Machine:
        self.check_keys(doc, TOP_KEYS, "")
        if "schema" not in doc:
            raise self.error("schema", f"missing required key (write schema = {SCHEMA_VERSION} at the top)")
        schema = doc["schema"]
        if isinstance(schema, bool) or schema != SCHEMA_VERSION:
            raise self.error("schema", f"this camsim reads schema {SCHEMA_VERSION}, got {_fmt(schema)}")
        head = self.table(doc, "machine", "machine", required=True)
        self.check_keys(head, MACHINE_KEYS, "machine")
        name = self.string(head, "name", "machine", required=True)
        if not name.strip():
            raise self.error("machine.name", "must not be empty")
        self.string(head, "description", "machine")

        from camsim.machine.limits import current
        from camsim.machine.names import check_names

        check_names(doc, self.error)  # every named table, once (issue 45)
        self.materials = self.material_tables(doc)  # issue 39: [[material]]
        masses = self.masses(doc)
        mass_names = [m.name for m in masses]
        cams, camshaft, multi = self.cam_tables(doc, mass_names)
        if len(cams) > current().cams:
            raise self.error("cam", f"{len(cams)} [[cam]] tables, above the limit of {current().cams} cams (--max-cams)")
        cam = cams[0] if cams else None
        elements = self.elements(doc, mass_names, masses, cams)
        simulation = self.simulation(doc, cam)
        initial = self.initial(doc, mass_names, cams)
        self.connectivity(masses, elements, cams)
        elements = self.distributed(elements, masses, cam, simulation, initial, cams=cams)  # issue 39: rods
        clearances = self.clearances(doc, mass_names, cams)
        loads = self.loads(doc, mass_names, cams, [e.name for e in elements])  # issue 43: [[load]]
        return Machine(
            name=name,
            cam=cam,
            masses=tuple(masses),
            elements=tuple(elements),
            simulation=simulation,
            initial=tuple(initial),
            source=self.source,
            cams=tuple(cams),
            camshaft=camshaft,
            clearances=tuple(clearances),
            multi_cam=multi,
            loads=tuple(loads),
        )

    # -- masses -------------------------------------------------------------------
    def masses(self, doc: dict) -> list[Mass]:
        rows = self.rows(doc, "mass", "mass")
        if not rows:
            raise self.error("mass", 'the machine has no masses: add [[mass]] tables (name = "M1", mass = "2 kg")')
        result: list[Mass] = []
        for i, row in enumerate(rows):
            path = f"mass[{i}]"
            self.check_keys(row, MASS_KEYS, path)
            name = self.string(row, "name", path, required=True)
            if not name.strip():
                raise self.error(f"{path}.name", "must not be empty")
            if name in FIXED_NODES:
                raise self.error(f"{path}.name", f'"{name}" is a reserved node name (ground, cam)')
            if any(m.name == name for m in result):
                raise self.error(f"{path}.name", f'duplicate mass name "{name}"')
            # 0 kg is allowed for a node that only holds a rod end (checked in distributed())
            mass = self.quantity(row, "mass", path, "mass", required=True, example='"1.6388 lb"')
            if not mass >= 0.0:
                raise self.error(f"{path}.mass", f"must be greater than 0, got {_fmt(row['mass'])}")
            result.append(Mass(name=name, mass=mass))
        return result

    # -- elements -----------------------------------------------------------------
    def elements(self, doc: dict, mass_names: list[str], masses: list[Mass], cams: list[Cam]) -> list[Element]:
        rows = self.rows(doc, "element", "element")
        cam_names = [c.name for c in cams] or [CAM]
        nodes = [GROUND, *cam_names, *mass_names]
        drives = {c.drives: c.name for c in cams if c.drives}  # driven mass -> its cam
        result: list[Element] = []
        for i, row in enumerate(rows):
            path = f"element[{i}]"
            name = self.string(row, "name", path, required=True)
            if not name.strip():
                raise self.error(f"{path}.name", "must not be empty")
            if any(e.name == name for e in result):
                raise self.error(f"{path}.name", f'duplicate element name "{name}"')
            kind = self.choice(row, "type", path, element_kinds.element_types(), required=True)
            self.check_keys(row, ELEMENT_COMMON_KEYS + element_kinds.type_keys(kind), path, f"for a {kind} element")
            lower, upper = self.between(row, path, nodes, mass_names)
            cls = self.element_class(row, path, kind)
            values: dict[str, Any] = dict(name=name, lower=lower, upper=upper)
            values["damping"] = self.damping(row, path, lower, upper, mass_names)
            driven = next((n for n in (lower, upper) if n in drives), None)
            for p in cls.params:
                if p.dimension == "string" or p.key in _DAMPING_KEYS:
                    continue
                if p.dimension == "force_program" and isinstance(row.get(p.key), dict):
                    # a force that follows a program like a load's (spec §10: a friction
                    # pair's normal force, a cam-actuated clamp or brake)
                    speed = float(cams[0].speed) if cams else None
                    program_kind, program, cam = self.force_program(row[p.key], f"{path}.{p.key}", speed,
                                                                    [c.name for c in cams])
                    values[p.attribute] = None
                    values["normal_program"] = Load(name=f"{name}.{p.key}", on=name, kind=program_kind, cam=cam,
                                                    **program)
                    continue
                if p.dimension == "law_table":  # a lash's side (spec §10)
                    values[p.attribute] = self.law_table(row, p, path, kind, cls, values, mass_names, driven)
                    continue
                values[p.attribute] = self.param(row, p, path, values)
            cls.check(values, lambda key, message: self.error(f"{path}.{key}", message), driven)
            element = cls(**values)
            if driven is not None and drives[driven] in (lower, upper):
                own = "the cam (cam.drives)" if drives[driven] == CAM else f"cam {drives[driven]}"
                raise self.error(f"{path}.between", f"{driven} is driven by {own}, so an element between it and "
                                 f"{'the cam' if drives[driven] == CAM else drives[driven]} never deflects")
            if len(cam_names) > 1 or cam_names[0] != CAM:
                element = element.on_cams(tuple(cam_names))
            result.append(element)
        return result

    def element_class(self, row: dict, path: str, kind: str) -> type[Element]:
        """The class that reads an element table (or a side table): the variant its keys
        select (:meth:`Element.for_table`), else its ``law``'s, each key checked against the
        laws that take it."""
        laws = element_kinds.laws_of(kind)
        law = None
        if laws:
            law = self.choice(row, "law", path, laws, required=False) or element_kinds.element_class(kind).law_name
        cls = element_kinds.element_class(kind, law)
        variant = cls.for_table(row)
        if laws and variant is cls:
            key_laws = element_kinds.key_laws(kind)
            for key in row:
                if key in key_laws and law not in key_laws[key]:
                    takes = " or ".join(f'law = "{x}"' for x in key_laws[key])
                    raise self.error(f"{path}.{key}", f'not used by a {kind} with law = "{law}" (only {takes})'
                                     + self.law_hint(kind, law, key))
        used = {p.key for p in variant.params} | set(ELEMENT_COMMON_KEYS)
        for key in row:
            if key not in used:
                raise self.error(f"{path}.{key}", f"not used by this {kind}" + self.law_hint(kind, law, key, variant))
        return variant

    def law_table(self, row: dict, p: Param, path: str, kind: str, owner: type[Element], values: dict[str, Any],
                  mass_names: list[str], driven: str | None) -> Element | None:
        """A table holding one law of ``kind`` and its keys (a lash's ``lower`` or ``upper``
        side), read like the element's own table: an element of that law with the element's
        name and nodes, and the keys the owner keeps for itself (a lash's ``clearance`` and
        ``offset``) copied from ``values``."""
        where = f"{path}.{p.key}"
        if p.key not in row:
            if p.required:
                others = " and ".join(f"`{q.key}`" for q in owner.params if q.dimension == "law_table")
                raise self.error(where, f"missing: a {kind} with side tables gives {others}, e.g. {p.key} = {p.example}")
            return None
        table = row[p.key]
        if not isinstance(table, dict):
            raise self.error(where, f"expected a table such as {p.example}, got {_fmt(table)}")
        shared = tuple(q.key for q in owner.params if q.dimension not in ("law_table", "string"))
        for key in table:
            if key in shared:
                raise self.error(f"{where}.{key}", "belongs to the element, not to one side (both sides share it)")
        allowed = tuple(k for k in element_kinds.type_keys(kind)
                        if k not in shared and k not in {q.key for q in owner.params})
        self.check_keys(table, allowed, where, f"for a side of a {kind}")
        cls = self.element_class(table, where, kind)
        side: dict[str, Any] = dict(name=values["name"], lower=values["lower"], upper=values["upper"])
        side["damping"] = self.damping(table, where, values["lower"], values["upper"], mass_names)
        for q in cls.params:
            if q.dimension in ("string", "law_table") or q.key in _DAMPING_KEYS:
                continue
            side[q.attribute] = values[q.attribute] if q.key in shared else self.param(table, q, where, side)
        cls.check(side, lambda key, message: self.error(f"{path if key in shared else where}.{key}", message), driven)
        return cls(**side)

    @staticmethod
    def law_hint(kind: str, law: str, key: str, cls: type[Element] | None = None) -> str:
        """Why a key is refused for a law, when the law's class says (``refused_hints``)."""
        hints = (cls or element_kinds.element_class(kind, law)).refused_hints
        hint = next((text for prefix, text in hints.items() if key.startswith(prefix)), "")
        return f"; {hint}" if hint else ""

    def param(self, row: dict, p: Param, path: str, values: dict[str, Any]) -> Any:
        """One key of an element table, read and checked as its schema says."""
        if p.dimension == "bool":
            value = row.get(p.key, p.default)
            if not isinstance(value, bool):
                raise self.error(f"{path}.{p.key}", f"expected true or false, got {_fmt(value)}")
            return value
        if p.dimension == "number":
            return self.number(row, p.key, path, required=p.required, default=p.default, minimum=p.minimum,
                               strict=p.strict, maximum=p.maximum)
        if p.dimension == "choice":
            value = self.choice(row, p.key, path, p.choices, required=p.required)
            return p.default if value is None else value
        if p.dimension == "integer":
            if p.key not in row:
                if p.required:
                    raise self.error(f"{path}.{p.key}", "missing required key (a whole number)")
                return p.default
            return self.integer(row, p.key, path, p.default, int(p.minimum or 0))
        if p.dimension in ("material", "materials"):  # issue 39
            return self.material_value(row, p, path)
        dimension = f"power_coefficient:{values['exponent']!r}" if p.dimension == "power_coefficient" else p.dimension
        if dimension == "force_program":  # a plain force (a table is read as a program: elements())
            dimension = "force"
        return self.quantity(row, p.key, path, dimension, required=p.required, default=p.default, minimum=p.minimum,
                             strict=p.strict, example=p.example)

    def between(self, row: dict, path: str, nodes: list[str], mass_names: list[str] = ()) -> tuple[str, str]:
        where = f"{path}.between"
        if "between" not in row:
            raise self.error(where, 'missing required key (e.g. between = ["M2", "M3"], lower node first)')
        value = row["between"]
        if not (isinstance(value, list) and len(value) == 2 and all(isinstance(v, str) for v in value)):
            raise self.error(where, f'expected two node names, [lower, upper], got {_fmt(value)}')
        for node in value:
            if node not in nodes:
                raise self.error(where, f'unknown node "{node}"; {_suggest(node, nodes)} '
                                 "(nodes are ground, the cams and the mass names)")
        lower, upper = value
        if lower == upper:
            raise self.error(where, f'an element joins two different nodes, got "{lower}" twice')
        if lower not in mass_names and upper not in mass_names:
            raise self.error(where, f'joins "{lower}" and "{upper}": at least one end must be a mass')
        return lower, upper

    def damping(self, row: dict, path: str, lower: str, upper: str, mass_names: list[str]) -> Damping:
        if "damping" in row and "damping_ratio" in row:
            raise self.error(f"{path}.damping_ratio", "give damping (a coefficient) or damping_ratio, not both")
        coefficient = self.quantity(row, "damping", path, "damping", minimum=0.0)
        ratio = self.number(row, "damping_ratio", path, minimum=0.0)
        reference = self.string(row, "reference_mass", path)
        if reference is not None:
            if reference not in mass_names:
                raise self.error(f"{path}.reference_mass", f'"{reference}" is not a mass; '
                                 f"{_suggest(reference, mass_names)}")
            if ratio is None:
                raise self.error(f"{path}.reference_mass", "only used with damping_ratio")
        return Damping(coefficient=coefficient, ratio=ratio, reference_mass=reference)

    # -- simulation and initial state -------------------------------------------------
    def simulation(self, doc: dict, cam: Cam | None) -> Simulation:
        table = self.table(doc, "simulation", "simulation") or {}
        self.check_keys(table, SIMULATION_KEYS, "simulation")
        cycles = self.integer(table, "cycles", "simulation", 1, 1)
        warmup = self.integer(table, "warmup_cycles", "simulation", 1, 0)
        rate = self.quantity(table, "sample_rate", "simulation", "frequency", default=50_000.0,
                             minimum=0.0, strict=True)
        gravity_value = table.get("gravity", False)
        if isinstance(gravity_value, bool):
            gravity = STANDARD_GRAVITY if gravity_value else 0.0
        else:
            gravity = self.quantity(table, "gravity", "simulation", "acceleration", minimum=0.0)
        duration = self.quantity(table, "duration", "simulation", "time", minimum=0.0, strict=True)
        if duration is not None and "cycles" in table:
            raise self.error("simulation.duration", "give cycles or duration, not both")
        steady = table.get("steady_state", "warmup")
        if steady not in STEADY_STATES:
            raise self.error("simulation.steady_state", f"expected one of {', '.join(STEADY_STATES)}, got {_fmt(steady)}")
        if cam is None and duration is None:
            raise self.error("simulation.duration", 'missing required key: a machine without [cam] has no '
                             'cycle, give the recorded time (e.g. duration = "5 ms")')
        return Simulation(cycles=cycles, warmup_cycles=warmup, sample_rate=rate, gravity=gravity,
                          duration=duration, steady_state=steady)

    def initial(self, doc: dict, mass_names: list[str], cams: list[Cam]) -> list[InitialCondition]:
        table = self.table(doc, "initial", "initial")
        if table is None:
            return []
        drives = {c.drives for c in cams if c.drives}
        result = []
        for name, entry in table.items():
            path = f"initial.{name}"
            if name not in mass_names:
                raise self.error(path, f'"{name}" is not a mass; {_suggest(name, mass_names)}')
            if name in drives:
                raise self.error(path, f"{name} is driven by the cam (cam.drives): its motion is prescribed, "
                                 "so it takes no initial condition")
            if not isinstance(entry, dict):
                raise self.error(path, f"expected a table [initial.{name}], got {_fmt(entry)}")
            self.check_keys(entry, INITIAL_KEYS, path)
            if not entry:
                raise self.error(path, "empty: give displacement and/or velocity")
            result.append(InitialCondition(
                mass=name,
                displacement=self.quantity(entry, "displacement", path, "length"),
                velocity=self.quantity(entry, "velocity", path, "velocity"),
            ))
        return result

    def connectivity(self, masses: list[Mass], elements: list[Element], cams: list[Cam]) -> None:
        drives = {c.drives for c in cams if c.drives}
        for i, m in enumerate(masses):
            if m.name in drives:
                continue
            if not any(m.name in e.nodes for e in elements):
                raise self.error(f"mass[{i}]", f"{m.name} is connected to no element: a free mass needs at "
                                 "least one element (spring, link or contact)")

"""Reading materials and resolving rods while a machine file is validated (issue 39).

:class:`MaterialKeys` is the part of :class:`camsim.machine.validator._Validator` that reads
``[[material]]`` tables, the ``material`` / ``materials`` keys of rods and Hertz contacts
(a name of the file's materials or of the library, :mod:`camsim.physics.materials`), and,
once every element is read, resolves each rod's default segments
(:func:`camsim.machine.rods.resolve_segments`) and checks the nodes rods add or lean on. It
uses the validator's own helpers (``error``, ``rows``, ``string``, ``number``, ``quantity``,
``check_keys``).
"""

from __future__ import annotations

from camsim.cam.arrangement import _fmt, _suggest  # the file's messages, one spelling
from camsim.elements import Element, Param
from camsim.machine import schema
from camsim.machine.description import Cam, InitialCondition, Mass, Simulation

__all__ = ["MaterialKeys"]


class MaterialKeys:
    """Materials and rods of a machine document (a mixin of the validator)."""

    #: The file's ``[[material]]`` tables by name, set by :meth:`material_tables`.
    materials: dict = {}

    def material_tables(self, doc: dict) -> dict:
        """The file's ``[[material]]`` tables, by name (physics.materials.Material, SI)."""
        from camsim.physics.materials import LIBRARY, Material

        out: dict[str, Material] = {}
        for i, row in enumerate(self.rows(doc, "material", "material")):
            path = f"material[{i}]"
            self.check_keys(row, schema.keys("material"), path)
            name = self.string(row, "name", path, required=True)
            if not name.strip():
                raise self.error(f"{path}.name", "must not be empty")
            if name in LIBRARY:
                raise self.error(f"{path}.name", f'"{name}" is a library material; give yours another name '
                                 "(the library's values: docs/impact.md)")
            if name in out:
                raise self.error(f"{path}.name", f'duplicate material name "{name}"')
            nu = self.number(row, "poisson_ratio", path, required=True, minimum=0.0)
            if not nu < 0.5:
                raise self.error(f"{path}.poisson_ratio", f"must be below 0.5, got {_fmt(row['poisson_ratio'])}")
            out[name] = Material(
                name=name,
                youngs_modulus=self.quantity(row, "youngs_modulus", path, "pressure", required=True, minimum=0.0,
                                             strict=True, example='"206.8 GPa"'),
                poisson_ratio=nu,
                density=self.quantity(row, "density", path, "density", minimum=0.0, strict=True),
                yield_strength=self.quantity(row, "yield_strength", path, "pressure", minimum=0.0, strict=True),
            )
        return out

    def material_value(self, row: dict, p: Param, path: str):
        """A ``material`` key (one name) or ``materials`` key (two names), resolved."""
        from camsim.physics.materials import library_names, lookup

        where = f"{path}.{p.key}"
        if p.key not in row:
            if p.required:
                hint = f" (e.g. {p.key} = {p.example})" if p.example else ""
                raise self.error(where, f"missing required key{hint}")
            return None
        value = row[p.key]
        names = [value] if p.dimension == "material" else value
        if p.dimension == "materials" and not (isinstance(value, list) and len(value) == 2):
            raise self.error(where, f'expected two material names [body, flat], got {_fmt(value)}')
        known = [*self.materials, *library_names()]
        found = []
        for name in names:
            if not isinstance(name, str):
                raise self.error(where, f"expected a material name, got {_fmt(name)}")
            try:
                found.append(lookup(name, self.materials))
            except KeyError:
                raise self.error(where, f'unknown material "{name}"; {_suggest(name, known)}') from None
        return found[0] if p.dimension == "material" else tuple(found)

    def check_sizes(self, elements: list[Element], masses: list[Mass], cams=()) -> None:
        """Refuse a machine beyond the limits of :mod:`camsim.machine.limits`, naming the key and
        the estimate, before anything of its size is allocated."""
        from camsim.machine.limits import current

        limits = current()
        interior = {i: max(0, int(e.segments or 1) - 1) for i, e in enumerate(elements) if e.compound}
        nodes = len(masses) + sum(interior.values())
        if nodes > limits.nodes:
            if interior and max(interior.values()) >= len(masses):
                i = max(interior, key=interior.get)
                e = elements[i]
                given = "(given)" in e.segments_reason
                why = (f"segments = {e.segments}" if given else
                       f"its default of {e.segments:.4g} segments, from its modulus, density and length "
                       f"({e.segments_reason.split(':', 1)[-1].split(' [')[0].strip()})")
                raise self.error(f"element[{i}].segments", f"the rod {e.name}: {why} makes a model of {nodes:.4g} "
                                 f"nodes, above the limit of {limits.nodes} (--max-nodes)"
                                 + ("" if given else "; check its modulus, density and length, or give segments"))
            raise self.error("mass", f"{len(masses)} masses and {sum(interior.values())} rod nodes make a model of "
                             f"{nodes} nodes, above the limit of {limits.nodes} (--max-nodes)")
        traces = 1 + 5 * max(1, len(cams)) + 3 * nodes + sum(3 if e.compound else 1 for e in elements) + 2
        if traces > limits.traces:
            raise self.error("cam" if 5 * len(cams) > 3 * nodes else "mass",
                             f"the result would hold {traces} traces ({len(cams)} cams, {nodes} nodes, {len(elements)} "
                             f"elements), above the {limits.traces} that one HDF5 time base can carry")

    def distributed(self, elements: list[Element], masses: list[Mass], cam: Cam | None, simulation: Simulation,
                    initial: list[InitialCondition], cams=()) -> list[Element]:
        """Rods: their default segments resolved; interior node names free; 0 kg only at rod ends.
        ``cams``: every cam of a machine with several (issue 38)."""
        from camsim.machine.rods import resolve_segments

        elements = resolve_segments(elements, masses, cam, simulation, initial, cams=cams)
        self.check_sizes(elements, masses, cams)  # before a rod's nodes are made (issue 45)
        taken = {m.name: f"mass {m.name}" for m in masses} | {e.name: f"element {e.name}" for e in elements}
        for i, e in enumerate(elements):
            for node in e.interior_nodes():
                if node in taken:
                    raise self.error(f"element[{i}].name", f"the rod's interior node {node} has the name of "
                                     f"{taken[node]}; rename one of them")
        for i, m in enumerate(masses):
            if m.mass == 0.0 and not any(e.node_mass(m.name) > 0.0 for e in elements):
                raise self.error(f"mass[{i}].mass", "must be greater than 0 (0 kg only for a node that holds a "
                                 "rod end, whose mass the rod gives it)")
        return elements


"""Where the machine becomes a model: distributed elements (rods) expanded into lumped masses and springs.

:func:`expand` returns the machine the model is assembled from: every compound element
(a rod, :class:`camsim.elements.rod.Rod`) replaced in place by its N segment springs, its
interior nodes ``<rod>[1]`` … ``<rod>[N-1]`` added as masses of m/N, and every node's mass
the one :meth:`Machine.mass_of` gives (what the rod ends lump there). The engine then sees
only masses and linear springs, so a rod is integrated as exactly as any spring.

Initial state: an interior node takes the straight-line interpolation of the ``[initial]``
displacements of the rod's two end nodes when both are known (ground counts as 0: the
uniform strain of a rod loaded only at its ends), and their velocity when both ends are
given the same one (the rod moves as a whole: a striker written with both ends at v₀ starts
at v₀ throughout). Otherwise an interior node keeps the static equilibrium and zero
velocity, as any mass not named in ``[initial]``: a rod struck at one end starts at rest.
"""

from __future__ import annotations

import dataclasses

from camsim.elements import GROUND
from camsim.machine.description import InitialCondition, Machine, Mass

__all__ = ["expand"]


def _end_value(machine: Machine, node: str, quantity: str) -> float | None:
    if node == GROUND:
        return 0.0
    for ic in machine.initial:
        if ic.mass == node:
            return getattr(ic, quantity)
    return None


def _interior_initial(machine: Machine, nodes: tuple[str, ...]) -> list[InitialCondition]:
    n = len(nodes) - 1
    ends = {q: (_end_value(machine, nodes[0], q), _end_value(machine, nodes[-1], q))
            for q in ("displacement", "velocity")}
    out = []
    for k, node in enumerate(nodes[1:-1], start=1):
        values = {}
        lo, hi = ends["displacement"]
        values["displacement"] = None if lo is None or hi is None else lo + (hi - lo) * k / n
        lo, hi = ends["velocity"]
        values["velocity"] = lo if lo is not None and lo == hi else None
        if values["displacement"] is not None or values["velocity"] is not None:
            out.append(InitialCondition(mass=node, **values))
    return out


def expand(machine: Machine) -> tuple[Machine, dict]:
    """(the machine with every compound element expanded, {name: compound element}).

    A machine without compound elements is returned as it is.
    """
    compounds = {e.name: e for e in machine.elements if e.compound}
    if not compounds:
        return machine, {}
    masses = [Mass(m.name, machine.mass_of(m.name)) for m in machine.masses]
    elements = []
    initial = list(machine.initial)
    for e in machine.elements:
        if not e.compound:
            elements.append(e)
            continue
        parts = e.expand()
        elements.extend(parts.segments)
        masses.extend(Mass(node, parts.interior_mass) for node in parts.nodes[1:-1])
        initial.extend(_interior_initial(machine, parts.nodes))
    expanded = dataclasses.replace(machine, masses=tuple(masses), elements=tuple(elements), initial=tuple(initial))
    return expanded, compounds

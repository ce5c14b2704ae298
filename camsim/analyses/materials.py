"""Ranking material pairs for an impact contact (``camsim impact --materials``; thesis ch. 10, rec. 3).

"By researching ideal pairs of materials to be used for the impact, a minimum impact force
output as well as minimum wear from the impacts can be obtained" (thesis p. 83). Given a
machine with a contact whose law follows from its geometry and materials (``law = "hertz"``),
:func:`rank_materials` simulates the machine once per pair of materials, with everything else
as the file has it, and ranks the pairs:

1. pairs whose peak Hertz pressure stays below first yield (1.60·Y point, 1.67·Y line
   contact, Y of the weaker material) before those that yield (they dent and wear);
2. then by the simulated peak force of the contact's largest impact (lower first);
3. then by the rebound of its first impact (lower first: less bounce and chatter).

The rebound is the contact's opening speed over its approach speed at its first impact, as
simulated: with the file's ``restitution`` (Hunt–Crossley) it is close to that e for every
pair in an isolated impact, and differs through the machine's dynamics; without damping it
is near 1. The elastic law knows no plasticity: a pair flagged as yielding would in reality
rebound less and peak lower than simulated. The masses stay the file's: changing the
material of an insert, a tip or a pad, not of the whole body.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

from camsim.errors import InputError
from camsim.machine.description import Machine

__all__ = ["PairResult", "MaterialRanking", "material_contacts", "candidate_pairs", "rank_materials"]


@dataclass
class PairResult:
    """One pair's simulated impact (SI).

    Attributes
    ----------
    materials : (str, str)
        [body, flat] as the contact's ``materials`` key takes them.
    e_star : float
        Contact modulus E* [Pa].
    peak_force : float
        Largest simulated impact peak force of the contact [N] (NaN: no impact).
    approach_velocity : float
        Approach speed of that impact [m/s].
    contact_duration : float
        Its duration [s].
    peak_pressure : float
        Hertz peak pressure at ``peak_force`` [Pa].
    yield_pressure : float or None
        Pressure at first yield [Pa] (None: no yield strengths).
    yields_first : str or None
        The material that yields first.
    pressure_ratio : float or None
        peak_pressure / yield_pressure.
    rebound : float
        Opening over approach speed of the contact's first impact (NaN: it did not open).
    impacts : int
        Impacts of the contact in the run.
    status : str
        ``"ok"`` or why the run failed.
    """

    materials: tuple[str, str]
    e_star: float = math.nan
    peak_force: float = math.nan
    approach_velocity: float = math.nan
    contact_duration: float = math.nan
    peak_pressure: float = math.nan
    yield_pressure: float | None = None
    yields_first: str | None = None
    pressure_ratio: float | None = None
    rebound: float = math.nan
    impacts: int = 0
    status: str = "ok"

    @property
    def yields(self) -> bool:
        return self.pressure_ratio is not None and self.pressure_ratio > 1.0

    def sort_key(self) -> tuple:
        failed = self.status != "ok" or math.isnan(self.peak_force)
        rebound = self.rebound if math.isfinite(self.rebound) else math.inf
        return (failed, self.yields, self.peak_force if not failed else math.inf, rebound, self.materials)


@dataclass
class MaterialRanking:
    """The ranked pairs of one contact, best first."""

    machine: str
    contact: str
    geometry: str
    rows: list[PairResult] = field(default_factory=list)

    def to_dict(self) -> dict:
        def clean(value):
            return None if isinstance(value, float) and not math.isfinite(value) else value

        return {"machine": self.machine, "contact": self.contact, "geometry": self.geometry,
                "ranking": [{**{k: clean(v) for k, v in asdict(r).items()}, "materials": list(r.materials),
                             "yields": r.yields, "rank": i + 1} for i, r in enumerate(self.rows)]}


def material_contacts(machine: Machine) -> list[str]:
    """Names of the machine's elements whose law takes ``materials`` (Hertz contacts)."""
    return [e.name for e in machine.elements if any(p.key == "materials" for p in e.params)]


def candidate_pairs(names: list[str] | None = None) -> list[tuple[str, str]]:
    """Every unordered pair (with repetition) of ``names`` (default: the library)."""
    from camsim.physics.materials import library_names

    names = list(names) if names else list(library_names())
    return list(itertools.combinations_with_replacement(names, 2))


def _pair_run(text: str, source: str, base_dir: str, contact: str, pair: tuple[str, str]) -> PairResult:
    """Simulate the machine with ``contact``'s materials set to ``pair`` (a worker's task)."""
    from camsim.elements.events import EventKind
    from camsim.errors import CamsimError
    from camsim.machine.loader import assignments, load_machine_text
    from camsim.run.simulation import simulate

    row = PairResult(materials=tuple(pair))
    try:
        machine = load_machine_text(text, source=source, base_dir=Path(base_dir),
                                    overrides=assignments({f"element.{contact}.materials": list(pair)}))
        element = machine.element(contact)
        row.e_star = element.e_star
        result = simulate(machine)
    except CamsimError as exc:
        row.status = str(exc)
        return row
    events = [e for e in result.events if e.element == contact]
    impacts = [e for e in events if e.kind.is_impact]
    row.impacts = len(impacts)
    if not impacts:
        row.status = "no impact of the contact in the run"
        return row
    worst = max(impacts, key=lambda e: e.peak_force if math.isfinite(e.peak_force) else -math.inf)
    row.peak_force, row.approach_velocity = worst.peak_force, worst.relative_velocity
    row.contact_duration = worst.contact_duration
    stress = element.stress(worst.peak_force)
    row.peak_pressure, row.yield_pressure = stress["peak_pressure"], stress["yield_pressure"]
    row.yields_first, row.pressure_ratio = stress["yields_first"], stress["ratio"]
    first = impacts[0]
    opening = next((e for e in events if e.time > first.time and e.kind == EventKind.RELEASE), None)
    if opening is not None and first.relative_velocity > 0:
        row.rebound = abs(opening.relative_velocity) / first.relative_velocity
    return row


def rank_materials(machine: Machine, contact: str | None = None, pairs: list[tuple[str, str]] | None = None,
                   *, workers: int = 1, progress=None) -> MaterialRanking:
    """Simulate ``machine`` once per material pair of ``contact`` and rank the pairs (module docstring).

    Parameters
    ----------
    machine : Machine
        Loaded from a machine file (its text is re-loaded per pair, with the contact's
        ``materials`` overridden).
    contact : str, optional
        The contact; default the machine's only Hertz contact.
    pairs : list of (str, str), optional
        [body, flat] material names (library or the file's ``[[material]]``); default every
        unordered pair of the library (:func:`candidate_pairs`).
    workers : int
        Processes (1: in this process).
    progress : callable, optional
        Called with (done, total) after each pair.

    Raises
    ------
    InputError
        No such contact, or a contact whose law takes no materials.
    """
    from camsim.run.budget import check_in_memory

    check_in_memory(machine, str(machine.source))  # each pair's run is held in memory (issue 45)
    candidates = material_contacts(machine)
    if contact is None:
        if len(candidates) != 1:
            raise InputError(f"{machine.source}: --contact: give the contact to rank materials for (law = \"hertz\" "
                             f"contacts here: {', '.join(candidates) or 'none'})")
        contact = candidates[0]
    if contact not in candidates:
        names = [e.name for e in machine.elements]
        why = "no such element" if contact not in names else "its law takes no materials (use law = \"hertz\")"
        raise InputError(f"{machine.source}: --contact {contact}: {why}; contacts with materials: "
                         f"{', '.join(candidates) or 'none'}")
    if not machine.text:
        raise InputError(f"{machine.source}: rank_materials needs a machine loaded from a machine file")
    pairs = [tuple(p) for p in (pairs or candidate_pairs())]
    from camsim.analyses.executors import make_executor
    from camsim.machine.loader import assignments, load_machine_text

    from camsim.errors import MachineFileError

    for pair in dict.fromkeys(pairs):  # a bad name is bad input (exit 2), not a failed row
        try:
            load_machine_text(machine.text, source=machine.source, base_dir=Path(machine.base_dir),
                              overrides=assignments({f"element.{contact}.materials": list(pair)}))
        except MachineFileError as exc:
            why = exc.message.split(" (value from --set")[0]
            raise InputError(f"{machine.source}: materials {pair[0]},{pair[1]} for {contact}: {why}") from None

    tasks = [(machine.text, machine.source, machine.base_dir, contact, pair) for pair in pairs]
    rows: list[PairResult | None] = [None] * len(tasks)
    with make_executor(workers, len(tasks), None, None) as executor:  # Ctrl-C: the workers are stopped
        for done, (i, row) in enumerate(executor.run(tasks, _pair_run), 1):
            rows[i] = row if isinstance(row, PairResult) else PairResult(materials=pairs[i], status=str(row))
            if progress is not None:
                progress(done, len(tasks))
    ranked = sorted(rows, key=PairResult.sort_key)
    return MaterialRanking(machine=machine.name, contact=contact, geometry=machine.element(contact).geometry, rows=ranked)

"""The event table of a run: what happened, when, and how hard (spec §7).

An :class:`Event` is one row; its ``kind`` is an :class:`EventKind`, never a free string.
:class:`EventTable` is the list of a run's events in time order, with the selections
and the tabular views every consumer (summary, writers, plots, sweeps) reads.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from enum import StrEnum

import numpy as np


class EventKind(StrEnum):
    """What an event is (spec §7). The value is the text written to result files."""

    IMPACT = "impact"  #: a contact closes
    RELEASE = "release"  #: a contact opens
    SEPARATION = "separation"  #: a preloaded link separates
    REJOIN = "rejoin"  #: a preloaded link closes again (an impact, annotated like one)
    STICK = "stick"  #: a rigid contact becomes persistent; a friction pair sticks
    SLIP = "slip"  #: a stuck friction pair breaks away (spec §10)
    JUMP = "jump"  #: a driven mass's cam contact force turns negative (a warning row)

    @property
    def is_impact(self) -> bool:
        """True for the kinds that are impacts (annotated with Johnson bounds and peaks)."""
        return self in (EventKind.IMPACT, EventKind.REJOIN)


@dataclass(slots=True)  # a long run holds thousands (camsim.run.stream): no per-row __dict__
class Event:
    """One event of a run (times on the simulation clock until shifted for output).

    Attributes
    ----------
    time : float
        When it happened [s].
    element : str
        The element's name (``"cam"`` for a jump row).
    kind : EventKind
    relative_velocity : float
        Approach (impacts) or opening speed of the element's two nodes [m/s].
    angle_deg : float
        Cam angle at ``time`` [deg].
    masses : str
        ``"lower/upper"`` node names.
    johnson_lower, johnson_upper : float
        Johnson's impact-force bounds [N] (impacts only; NaN otherwise).
    peak_force : float
        Simulated peak force of the impact [N], located on the solution (spec §4).
    peak_time : float
        When the peak force is reached [s].
    contact_duration : float
        Time until the contact opens again [s].
    element_index : int
        Index of the element in the model (internal; not written).
    branch : Branch or None
        The branch the element took with the event (internal; not written): the side a lash
        closed on, whose law annotates the impact (:meth:`~camsim.elements.base.Element.acting`).
    """

    time: float
    element: str
    kind: EventKind
    relative_velocity: float = float("nan")
    angle_deg: float = float("nan")
    masses: str = ""
    johnson_lower: float = float("nan")
    johnson_upper: float = float("nan")
    peak_force: float = float("nan")
    peak_time: float = float("nan")
    contact_duration: float = float("nan")
    element_index: int = -1
    branch: object = None

    def __post_init__(self) -> None:
        self.kind = EventKind(self.kind)

    def to_dict(self) -> dict:
        """The event as a JSON-able dict (NaN → None), the written columns only."""
        out = {}
        for name, _ in EVENT_COLUMNS:
            value = getattr(self, name)
            if isinstance(value, EventKind):
                value = value.value
            elif isinstance(value, float) and math.isnan(value):
                value = None
            out[name] = value
        return out


#: Columns of the written event table, in order, with their units.
EVENT_COLUMNS: tuple[tuple[str, str], ...] = (
    ("time", "s"),
    ("angle_deg", "deg"),
    ("element", ""),
    ("kind", ""),
    ("masses", ""),
    ("relative_velocity", "m/s"),
    ("johnson_lower", "N"),
    ("johnson_upper", "N"),
    ("peak_force", "N"),
    ("peak_time", "s"),
    ("contact_duration", "s"),
)
_TEXT_COLUMNS = {"element", "kind", "masses"}
assert {name for name, _ in EVENT_COLUMNS} <= {f.name for f in fields(Event)}


class EventTable(list):
    """A run's events in time order (a list of :class:`Event`) with typed selections."""

    def of_kind(self, *kinds: EventKind | str) -> "EventTable":
        """The events of the given kinds."""
        wanted = {EventKind(k) for k in kinds}
        return EventTable(e for e in self if e.kind in wanted)

    def impacts(self) -> "EventTable":
        """Impact-like events: contacts closing and links rejoining."""
        return EventTable(e for e in self if e.kind.is_impact)

    def columns(self) -> dict[str, tuple[np.ndarray, str]]:
        """Column name → (values, units), as written to result files."""
        out = {}
        for name, units in EVENT_COLUMNS:
            values = [getattr(e, name) for e in self]
            if name in _TEXT_COLUMNS:
                out[name] = (np.array([str(v) for v in values], dtype=object), units)
            else:
                out[name] = (np.array(values, dtype=float), units)
        return out

    def to_pandas(self):
        """The table as a :class:`pandas.DataFrame` (``attrs["units"]`` per column)."""
        import pandas as pd

        columns = self.columns()
        frame = pd.DataFrame({name: values for name, (values, _) in columns.items()})
        frame.attrs["units"] = {name: units for name, (_, units) in columns.items()}
        return frame

"""What a sweep is run with and what it returns: :class:`SweepSettings` and :class:`SweepResult`.

The data the sweep's runner (:mod:`camsim.analyses.sweep.runner`) fills and its files
(:mod:`camsim.analyses.sweep.files`) write; a module of its own below both, so that
neither imports the other for its types.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["SweepResult", "SweepSettings"]


@dataclass(frozen=True)
class SweepSettings:
    """Run settings shared by every variant (``None``: the machine file's value).

    Attributes
    ----------
    cycles : int, optional
        Recorded revolutions.
    warmup_cycles : int, optional
        Revolutions computed and discarded first.
    sample_rate : float, optional
        Output sample rate [Hz]. Peaks are taken over the samples, so they depend on it.
    keep_traces : bool
        Return each variant's :class:`~camsim.run.simulation.RunResult` too.
    """

    cycles: int | None = None
    warmup_cycles: int | None = None
    sample_rate: float | None = None
    keep_traces: bool = False


def _column_array(rows, name, unit="") -> np.ndarray:
    values = [r[name] for r in rows]
    if name == "status":
        return np.array(values, dtype=object)
    if name == "jump":
        return np.array(values, dtype=bool)
    if name == "impacts":
        return np.array(values, dtype=np.int64)
    if any(isinstance(v, str) for v in values):
        return np.array([str(v) for v in values], dtype=object)
    return np.array(values, dtype=float)


@dataclass
class SweepResult:
    """Rows of a sweep in grid order, with the jump onset of a speed sweep.

    Attributes
    ----------
    rows : list of dict
        One per variant: column name -> value (SI; NaN where a value does not exist).
    columns : list of (str, str)
        Column names in order, with their SI units.
    jump_onset_rpm : float or None
        Jump onset found by bisection [rpm]: the middle of a bracket at most 0.1 rpm wide
        whose lower end does not jump and upper end does. None when not refined, when
        nothing jumps, or when the lowest swept speed already jumps.
    first_jump_rpm : float or None
        Lowest swept ``cam.speed`` whose variant jumps [rpm] (None if none or no speed sweep).
    jump_bracket_rpm : tuple of float or None
        The final bisection bracket (no jump, jump) [rpm].
    machine : Machine
        The machine with the fixed ``--set`` overrides (root attributes of the file).
    overrides : list of tuple of str
        The varied overrides of each row.
    runs : list
        Each variant's RunResult with ``keep_traces`` (None for failed ones), else empty.
    settings : SweepSettings
    interrupted : bool
        True when Ctrl-C stopped the sweep; unfinished rows have status ``"cancelled"``.
    executor : str
        What ran the variants.
    notes : list of str
        Remarks for the reader (e.g. why the jump onset was not refined).
    journal : Path or None
        The row journal when the sweep was stored as it ran (``output``).
    resumed : int
        Rows taken from the journal of an earlier run (``resume``).
    executor_failures : int
        Variants whose row is an executor failure (e.g. a killed worker process), not a
        result of the variant: not stored in the journal, so ``resume`` reruns them.
    """

    rows: list[dict[str, Any]]
    columns: list[tuple[str, str]]
    jump_onset_rpm: float | None = None
    first_jump_rpm: float | None = None
    jump_bracket_rpm: tuple[float, float] | None = None
    machine: Any = None
    overrides: list[tuple[str, ...]] = field(default_factory=list)
    fixed_overrides: list[str] = field(default_factory=list)
    runs: list[Any] = field(default_factory=list)
    settings: SweepSettings = field(default_factory=SweepSettings)
    interrupted: bool = False
    executor: str = "serial"
    notes: list[str] = field(default_factory=list)
    journal: Path | None = None
    resumed: int = 0
    executor_failures: int = 0

    @property
    def failed(self) -> list[int]:
        """Row indices whose status is neither ok nor cancelled."""
        return [i for i, r in enumerate(self.rows) if r["status"] not in ("ok", "cancelled")]

    @property
    def not_run(self) -> int:
        """Rows without a result: failed, cancelled or lost with a worker process."""
        return sum(r["status"] != "ok" for r in self.rows)

    @property
    def incomplete(self) -> bool:
        """True when any row did not run to a result (the sweep exits 1; issue 26)."""
        return self.not_run > 0

    @property
    def stopped(self) -> bool:
        """True when the sweep did not run every variant it was given: Ctrl-C, or a worker
        process that died (its rows are not in the journal; ``--resume`` runs them)."""
        return self.interrupted or self.executor_failures > 0

    def column(self, name: str) -> np.ndarray:
        """One column as an array (floats, bools, ints or strings)."""
        return _column_array(self.rows, name, dict(self.columns).get(name, ""))

"""The scalar families a machine adds to its runs' summaries, in one list.

Besides the scalars every run has (peaks per mass, impacts, the cam's, :func:`camsim.run.result.scalar_columns`),
a machine's own parts add families of scalars: the cam design's (``[cam.geometry]``), the
camshaft's (several cams or a ``[camshaft]``), each process load's, each friction pair's.
Every consumer — a result's units, its scalars and summary (in memory and streamed), the run
file's summary group, the columns of a sweep or a fit — reads them from here, so a family
added once appears everywhere (issue 44: a family missing from one list showed its values
without units).
"""

from __future__ import annotations

from typing import Any

__all__ = ["columns", "rows", "summaries"]


def columns(machine) -> list[tuple[str, str]]:
    """(name, SI unit) of every family's scalars of ``machine``."""
    from camsim.cam.design import design_columns
    from camsim.run.camshaft import camshaft_columns
    from camsim.run.friction import friction_columns
    from camsim.run.loads import load_columns

    return design_columns(machine) + camshaft_columns(machine) + load_columns(machine) + friction_columns(machine)


def rows(result) -> dict[str, Any]:
    """The scalars of the families computed from a result's own fields (the loads', the
    friction pairs'; the design's and the camshaft's come from their accumulators)."""
    from camsim.run.friction import friction_row
    from camsim.run.loads import load_row

    return {**load_row(result), **friction_row(result)}


def summaries(result) -> dict[str, dict]:
    """The summary sections of those families that the machine has: ``loads``, ``friction``."""
    from camsim.run.friction import friction_summary
    from camsim.run.loads import load_summary

    out = {}
    for key, section in (("loads", load_summary(result)), ("friction", friction_summary(result))):
        if section is not None:
            out[key] = section
    return out

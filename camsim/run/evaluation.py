"""A design evaluation: what an analysis reads of a run, without its traces (issue 42).

A study, a sweep's summary, the optimiser and ``fit``'s screening read a run's summary
scalars (:meth:`camsim.run.result.RunResult.scalars`): located extremes, the event table and
what follows from them. :func:`evaluate` computes exactly those: the same integration on
the same grid as :func:`~camsim.run.simulation.simulate` (so the same numbers, bit for
bit), the same located extremes, but no output samples — no traces assembled, no copies
of every node's quantities into them. A machine whose scalars read samples (a cam with
geometry: torque RMS and energy fluctuation; several cams or a camshaft: the shaft's
accumulators; a cam that acts through contact elements: the largest gap off the cam, a
sampled figure; clearances) is simulated in full, so :func:`evaluate` always gives the
scalars :func:`simulate` gives.

The result is a :class:`~camsim.run.result.RunResult` whose traces are empty: ``scalars()``,
``summary()``, ``impacts()``, ``located``, ``events`` and ``warnings`` as after a full run.
"""

from __future__ import annotations

from threadpoolctl import threadpool_limits

from camsim.elements import CAM
from camsim.machine.description import Machine
from camsim.run.assemble import assemble_summary
from camsim.run.result import RunResult
from camsim.run.simulation import _simulate, simulate

__all__ = ["evaluate", "reads_samples"]


def reads_samples(machine: Machine) -> bool:
    """Whether some summary scalar of a run of ``machine`` is read off its samples (then
    :func:`evaluate` runs it in full)."""
    if machine.multi_cam or machine.camshaft is not None or machine.clearances:
        return True
    cam = machine.cam
    if cam is not None and getattr(cam, "geometry", None) is not None:
        return True
    # a cam acting through contact elements: the follower's largest gap off the cam is sampled
    cams = {c.name for c in machine.cams} | {CAM}
    return cam is not None and not cam.drives and any(
        getattr(e, "unilateral", False) and (e.lower in cams or e.upper in cams) for e in machine.elements)


def evaluate(
    machine: Machine,
    *,
    no_impact: bool = False,
    cycles: int | None = None,
    warmup_cycles: int | None = None,
    sample_rate: float | None = None,
) -> RunResult:
    """The summary of a run of ``machine`` without its traces.

    Parameters
    ----------
    machine : Machine
    no_impact : bool
        Run the no-impact variant (spec §4).
    cycles, warmup_cycles : int, optional
        Override ``[simulation]`` cycles and warm-up cycles.
    sample_rate : float, optional
        Override the output sample rate [Hz]: it sets the engine's grid, as for a full run
        (the located extremes hold to 1e-9 across rates, spec §4; on the same grid they
        are the full run's bit for bit).

    Returns
    -------
    RunResult
        Empty traces; events, located extremes, warnings, periodicity residual and the
        summary scalars of :func:`~camsim.run.simulation.simulate`.
    """
    if reads_samples(machine):
        return simulate(machine, no_impact=no_impact, cycles=cycles, warmup_cycles=warmup_cycles,
                        sample_rate=sample_rate)
    with threadpool_limits(limits=1, user_api="blas"):
        return _simulate(machine, no_impact, cycles, warmup_cycles, sample_rate, None, assemble=assemble_summary)

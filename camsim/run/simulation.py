"""Running a machine: its grid, the warm-up, the recording.

:func:`simulate` is what ``camsim run`` calls; it returns a :class:`RunResult` that the
HDF5 writer, the plots and the summary table all read. The start state is
:mod:`camsim.run.initial`'s; turning the recorded stretches into traces and events is
:mod:`camsim.run.assemble`'s.
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from dataclasses import replace

import numpy as np
from threadpoolctl import threadpool_limits

from camsim.cam.camshaft import cam_input
from camsim.loads.inputs import engine_input
from camsim.loads.programs import load_program, load_programs
from camsim.errors import InputError, SimulationError
from camsim.elements import Branch
from camsim.engine.integrator import Integrator, State
from camsim.machine.description import Machine
from camsim.model.assembly import Model
from camsim.model.rigidity import check_cam_resolvable, check_not_rigid
from camsim.run.assemble import (  # noqa: F401 - also this module's names (tests, camsim.run.stream)
    RunSetup,
    _assemble,
    after_run_warnings,
    boundaries_deg,
    johnson_annotate,
    negative_cam_force_warning,
    period_end,
    refined_peak,
    sample_traces,
    stretch_samples,
)
from camsim.run.bounds import physical_bounds
from camsim.run.extremes import Observables
from camsim.run.initial import _one_contact_static, initial_state, static_equilibrium  # noqa: F401 - tests
from camsim.run.result import RunResult
from camsim.run.steady import find_steady_state
from camsim.run.watchdog import RunClock, watching

#: Internal steps per period of the highest natural frequency (guard sampling density).
SAMPLES_PER_PERIOD = 12
#: Internal steps per output sample beyond which a machine is refused as input (issue 26).
MAX_STEPS_PER_SAMPLE = 1e7
#: A linear static equilibrium whose stiffness matrix is worse conditioned than this has

# ---------------------------------------------------------------------- the run
def highest_frequency(model: Model) -> float:
    """Highest undamped natural frequency over the linear configurations [Hz]."""
    combos = model.all_branch_combinations()
    if len(combos) > 256:
        combos = combos[:256]
    best = 0.0
    for branches in combos:
        try:
            config = model.configuration(branches)
        except InputError:
            continue
        if config.dim == 0:
            continue
        if not np.all(np.isfinite(config.A)):
            return math.inf  # an element beyond float range (1e300 N/m): rigid, check_not_rigid says which
        lam = np.linalg.eigvals(config.A)
        best = max(best, float(np.max(np.abs(lam))) / (2 * math.pi))
    return best


def simulate(
    machine: Machine,
    *,
    no_impact: bool = False,
    cycles: int | None = None,
    warmup_cycles: int | None = None,
    sample_rate: float | None = None,
    progress=None,
) -> RunResult:
    """Simulate a machine and return its traces and events.

    Parameters
    ----------
    machine : Machine
    no_impact : bool
        Run the no-impact variant (spec §4).
    cycles, warmup_cycles : int, optional
        Override ``[simulation]`` cycles and warm-up cycles.
    sample_rate : float, optional
        Override the output sample rate [Hz].
    progress : callable, optional
        Called with the fraction done (0..1) now and then.

    Returns
    -------
    RunResult

    Raises
    ------
    InputError
        For settings that cannot run (no equilibrium and no initial state, ...).
    SimulationError
        When the run diverges or events pile up without resolution.
    """
    # The matrices are tiny (≤ ~40×40): a multi-threaded BLAS only adds synchronisation,
    # and when the other cores are busy it slows a run tenfold (measured on 2 cores).
    with threadpool_limits(limits=1, user_api="blas"):
        return _simulate(machine, no_impact, cycles, warmup_cycles, sample_rate, progress)


def _simulate(machine, no_impact, cycles, warmup_cycles, sample_rate, progress, stream=None, shaft=None,
              record_all=False, rigid_shaft=False, assemble=None) -> RunResult:
    """:func:`_run` watched by the run's progress channel and stall watchdog (issue 45,
    :mod:`camsim.run.watchdog`); a camshaft relaxation's passes report to the run that started them."""
    rate = sample_rate if sample_rate is not None else machine.simulation.sample_rate
    clock = RunClock(None, 1.0 / rate if rate > 0 else math.inf, machine.source)
    with watching(clock) as active:
        return _run(machine, no_impact, cycles, warmup_cycles, sample_rate, progress, stream, shaft, record_all,
                    rigid_shaft, active if active is clock else None, active, assemble)


def _run(machine, no_impact, cycles, warmup_cycles, sample_rate, progress, stream, shaft, record_all, rigid_shaft,
         own_clock, clock, assemble=None) -> RunResult:
    """The run; ``stream(run)`` (camsim.run.stream), when given, makes the consumer of the
    stretches (see :class:`RunSetup`) and its ``finish()`` returns the result instead.
    ``shaft``: a dynamic camshaft's solution (camsim.run.shaft.ShaftSolution; None: the
    rigid shaft, or the solution still to find); ``record_all``: record the warm-up too (its samples before output time 0);
    ``rigid_shaft``: a dynamic camshaft's machine on a rigid shaft (the relaxation's start)."""
    sim = machine.simulation
    if cycles is not None or warmup_cycles is not None or sample_rate is not None:
        sim = replace(
            sim,
            cycles=cycles if cycles is not None else sim.cycles,
            warmup_cycles=warmup_cycles if warmup_cycles is not None else sim.warmup_cycles,
            sample_rate=sample_rate if sample_rate is not None else sim.sample_rate,
            duration=None if cycles is not None else sim.duration,
        )
        machine = replace(machine, simulation=sim)
    if sim.sample_rate <= 0:
        raise InputError("simulation.sample_rate: must be positive")
    dynamics = (shaft, None) if shaft is not None else None
    if shaft is None and not rigid_shaft and machine.cams and machine.camshaft is not None \
            and machine.camshaft.model == "dynamic":
        # issue 38: the camshaft's own dynamics, iterated with the stations to one solution
        # (waveform relaxation, camsim.run.shaft); then the run below on the converged angles
        from camsim.run.shaft import converge

        t_rec_dyn = (sim.warmup_cycles * 2.0 * math.pi / machine.cams[0].speed) if sim.warmup_cycles else 0.0
        if own_clock is not None and progress is not None:  # each pass of the relaxation, 0 to its end
            t_all = t_rec_dyn + (sim.duration if sim.duration is not None else
                                 sim.cycles * 2.0 * math.pi / machine.cams[0].speed)
            own_clock.report = lambda t: progress(min(1.0, t / t_all))
        dynamics = converge(machine, lambda solution: _simulate(
            machine, no_impact, None, None, None, None, shaft=solution, record_all=True, rigid_shaft=solution is None),
            t_rec_dyn)
    warps = dynamics[0].warps() if dynamics is not None else None
    cam = cam_input(machine, warps, shared=dynamics is None)  # one cam: its CamProgram; [[cam]]: every cam's, stacked (issue 38)
    if dynamics is not None:
        cam.dynamics = dynamics[0]
    model = Model(machine, no_impact=no_impact)
    warnings = list(cam.warnings)
    period = cam.period
    has_cam = machine.cam is not None
    warm = sim.warmup_cycles if has_cam else 0
    if sim.duration is not None:
        record_len = sim.duration
    elif has_cam:
        record_len = sim.cycles * period
    else:
        raise InputError(f"{machine.source}: simulation.duration: required for a machine without a cam")
    t_rec = warm * period if warm else 0.0
    t_end = t_rec + record_len
    h_out = 1.0 / sim.sample_rate
    check_cam_resolvable(machine)  # issue 25: a cam faster than events can be located
    f_max = highest_frequency(model)
    check_not_rigid(model, f_max, SAMPLES_PER_PERIOD)  # issue 25: exit 2 naming the element
    if f_max > 0 and sim.sample_rate < 2 * f_max:
        warnings.append(
            f"sample rate {sim.sample_rate:g} Hz is below twice the highest natural frequency "
            f"({f_max:.4g} Hz): the traces alias (events are still located exactly)"
        )
    steps_per_sample = h_out * f_max * SAMPLES_PER_PERIOD
    if not math.isfinite(steps_per_sample) or steps_per_sample > MAX_STEPS_PER_SAMPLE:
        # e.g. --set element.k12.stiffness="1e300 N/m": no run can resolve that (issue 26)
        raise InputError(
            f"{machine.source}: the highest natural frequency, {f_max:.3g} Hz, needs {steps_per_sample:.3g} internal "
            f"steps per output sample (at most {MAX_STEPS_PER_SAMPLE:.0e}): a stiffness or a mass is out of any "
            "physical range"
        )
    # The cam input is carried over each step as the Hermite of s, ṡ, s̈, s⃛ at its ends: a
    # step no longer than 1/WARMUP_STEPS_PER_MOTION of the shortest rise keeps it exact
    # (warmup_step). A coarse output grid on a soft machine (5 kHz, one step per sample)
    # otherwise moved a power-law contact's traces by 1e-6 of peak against 500 kHz (issue 25,
    # invariant a); machines whose natural frequencies already ask for finer steps keep them.
    # issue 43: each load is one more input group after the cams' ([F, Ḟ, F̈, F⃛], camsim.loads);
    # its times are on the recorded clock (t_rec is its 0)
    programs = load_programs(machine, t_rec, warps)
    # spec §10: a friction pair's normal force that follows a program is one more group after the loads'
    programs += [load_program(p, machine, t_rec, warps) for _, p in model.normal_programs]
    inputs = engine_input(cam, programs)
    motion_step = min([cam_input_step(machine)] + [p.shortest for p in programs])
    substeps = max(1, math.ceil(steps_per_sample), math.ceil(h_out / motion_step * (1 - 1e-12)))
    integrator = Integrator(model, inputs, h_out / substeps, t_ref=t_rec)
    if has_cam:
        integrator.period = period  # a revolution's events size the next one's chunks (chunk_steps)
    run = RunSetup(machine, model, cam, integrator, t_rec, t_end, h_out, warnings, no_impact, period if has_cam else None)
    run = replace(run, observables=Observables(run))  # the located extremes' quantities (spec §4)
    work_stop = None
    from camsim.run.friction import FrictionWork, pairs

    if programs or pairs(model.machine):
        from camsim.run.loads import LoadWork, work_window

        window, whole = work_window(machine, t_rec, t_end, period if has_cam else None)
        if programs:
            run = replace(run, load_work=LoadWork(model, window))
        if pairs(model.machine):
            run = replace(run, friction_work=FrictionWork(model, window))
        work_stop = window[1] if whole else None  # the revolution's end is a node of the solution
    consumer = stream(run) if stream is not None else None  # before integrating: it may refuse the settings
    state = initial_state(model, integrator, 0.0)
    bounds = physical_bounds(model, cam, state, t_end)  # a state beyond them is a divergence (issue 34)
    saved: dict[float, State] = {}
    # The state one revolution apart gives the periodicity residual: the last warm-up cycle
    # against the first recorded one (or the first two recorded cycles without warm-up).
    if warm >= 1:
        stops = (t_rec - period, t_rec)
    elif has_cam and sim.duration is None and sim.cycles >= 2:
        stops = (0.0, period)
    else:
        stops = ()

    def on_stop(st: State) -> None:
        saved[round(st.t, 9)] = st

    # The cam design's energy quantities are taken over exactly one revolution, closed at its
    # end with the state the integrator stops at there, not with the samples around it
    # (issue 26: the last sample of one revolution falls short of the period unless the
    # period is a multiple of the sample spacing).
    t_period_end = None
    if has_cam and (any(getattr(c, "geometry", None) is not None for c in machine.cams) or machine.multi_cam
                    or machine.camshaft is not None) and t_end >= t_rec + period * (1 - 1e-12):
        t_period_end = t_rec + period
    all_stops = tuple(stops) + ((t_period_end,) if t_period_end is not None and t_period_end not in stops else ())
    if work_stop is not None and work_stop not in all_stops:
        all_stops = all_stops + (work_stop,)

    total = t_end
    if own_clock is not None:  # this run's fraction done, through its channel (rate-limited)
        own_clock.report = (lambda t: progress(min(1.0, t / total))) if progress else None
    report = clock  # every stretch's end: the channel (progress display and stall watchdog)
    t_final = t_end + 0.5 * h_out
    # Warm-up cycles are not recorded: integrate them on a coarser grid, just dense
    # enough to see every guard and to carry the cam input exactly (warmup_step).
    h_warm = min(warmup_step(machine, f_max, integrator.h), motion_step)
    # A nonlinear (power-law) contact has no natural frequency in f_max: a coarser warm-up
    # grid hands its contact phases to DOP853, and a warm-up revolution cost several recorded
    # ones (issue 26). Such machines warm up on the recording grid: the same cost per revolution.
    if any(e.is_nonlinear(b) for e in model.elements for b in Branch):
        h_warm = integrator.h
    shot_residual = None
    found = None  # a steady state found by shooting (camsim.run.steady): no warm-up revolution
    with numerical_failure(machine):
        if sim.steady_state == "shooting" and not record_all:
            state, found = find_steady_state(machine, model, inputs, integrator.h, state, period, t_rec, bounds, report,
                                             warnings)
        if found is not None:
            integrator.watch.last = found.watch_last
            if t_end >= t_rec + period * (1 - 1e-12):
                # its residual is the recorded revolution's own: its end against its start
                stops = (t_rec, t_rec + period)
                if t_rec + period not in all_stops:
                    all_stops = all_stops + (t_rec + period,)
            elif found.shooting.contracted:
                shot_residual = found.shooting.residual  # the contraction bound
            else:
                saved[round(t_rec - period, 9)] = replace(found.shooting.start, t=t_rec - period)
                saved[round(t_rec, 9)] = state
                stops = (t_rec - period, t_rec)
        if t_rec > 0 and h_warm > 1.5 * integrator.h and not record_all and found is None:
            warm_integrator = Integrator(model, inputs, h_warm, t_ref=0.0)
            warm_integrator.watch.locating = False  # its events are not reported: F_c's last sign is enough
            warm_integrator.period = integrator.period
            state, _ = warm_integrator.run(state, t_rec, record_from=math.inf, stops=stops, on_stop=on_stop, progress=report,
                                           check=bounds.check)
            # the cam contact force's sign where the warm-up ends: the recorded window starts
            # with no jump row the continuous run does not have (issue 25)
            integrator.watch.last = warm_integrator.watch.last
            integrator.predict_from(warm_integrator)
        if consumer is None:
            _, stretches = integrator.run(state, t_final, record_from=0.0 if record_all else t_rec, stops=all_stops,
                                          on_stop=on_stop, progress=report, check=bounds.check)
            clock.phase = "locating the extremes and assembling the result"  # the watchdog's message
            result = (assemble or _assemble)(run, stretches)
            clock.phase = ""
            peak = result.peak
        else:
            integrator.run(state, t_final, record_from=t_rec, stops=all_stops, on_stop=on_stop, progress=report,
                           on_stretch=consumer.on_stretch, check=bounds.check)
            clock.phase = "locating the extremes and assembling the result"
            result = consumer.finish()
            clock.phase = ""
            peak = result.peak
    if t_period_end is not None and round(t_period_end, 9) in saved:
        end = period_end(run, saved[round(t_period_end, 9)])
        result.period_end = end
        design = getattr(result, "_design", None)  # a streamed run's accumulator (camsim.run.stream)
        if design is not None and end is not None and "torque" in end:
            design.period_end = (end["time"], end["torque"])
        shaft = getattr(result, "_shaft", None)  # issue 38: the streamed camshaft accumulator
        if shaft is not None and end is not None and "power" in end:
            shaft.period_end = (end["time"], end["power"], end["drive_power"])
    result.periodicity_residual = _residual(model, saved, stops, peak) if shot_residual is None else shot_residual
    if has_cam and not record_all:
        result.steady_state = ({"method": "shooting", "revolutions": found.shooting.iterations} if found is not None
                               else {"method": "warmup", "revolutions": warm})
        if found is not None and result.periodicity_residual > SHOT_RESIDUAL_CHECK:
            # the iteration's own residual (or its contraction bound) said rounding; the
            # recorded revolution says otherwise: say so rather than report it as steady
            result.warnings.append(
                f'steady_state = "shooting": the recorded revolution repeats itself only to '
                f"{result.periodicity_residual:.3g} of each peak (the event sequence changed from the shooting's)")
    result.sample_rate = sim.sample_rate
    if dynamics is not None and dynamics[1] is not None:
        from camsim.run.shaft import dynamics_summary

        result.shaft_dynamics = dynamics_summary(*dynamics)
    if consumer is not None:
        consumer.close(result)
    return result


@contextmanager
def numerical_failure(machine: Machine):
    """Turn a numerical breakdown inside the engine into a :class:`SimulationError` (exit 1,
    one line) instead of a traceback.

    A singular Newton matrix or an overflow comes from a machine at the edge of what the
    engine resolves -- in practice a power-law contact far stiffer than its neighbours (the
    CDTM's seat coefficient x 1e9: singular collocation matrix after 44 s, issue 25) --
    which the up-front checks (:mod:`camsim.model.rigidity`, linear laws only) cannot see.
    """
    try:
        yield
    except (np.linalg.LinAlgError, FloatingPointError, OverflowError) as exc:
        raise SimulationError(
            f"{machine.source}: the integration broke down numerically ({type(exc).__name__}: {exc}); an element "
            f"is probably too stiff to resolve: lower its stiffness or coefficient, or make the contact rigid "
            f'(law = "restitution")'
        ) from exc


#: Warm-up steps per shortest cam motion (rise or fall). A step carries the cam input as
#: the degree-7 Hermite of s, ṡ, s̈, s⃛ at its ends; over a fifth of a rise (the former
#: warm-up grid of a soft machine) that is 1e-7 of the lift off, and across the jerk
#: steps inside a modified trapezoid or sine (not segment joins) worse. 64 steps per
#: motion keep the recorded revolution after a warm-up equal to the same revolution of a
#: continuous run to 1e-9 of peak (tests/invariants, invariant b; issue 25).
WARMUP_STEPS_PER_MOTION = 64


def cam_input_step(machine: Machine) -> float:
    """Longest step [s] over which the cam input stays exact: 1/WARMUP_STEPS_PER_MOTION of
    the shortest rise or fall (of a revolution for a table cam); inf without a cam."""
    cams = machine.cams
    if not cams:
        return math.inf
    shortest = math.inf
    for cam in cams:  # every cam of the shaft (issue 38)
        motions = [seg.duration for seg in (cam.segments or ()) if seg.motion != "dwell"]
        shortest = min(shortest, min(motions) if motions else 2 * math.pi / WARMUP_STEPS_PER_MOTION)  # a table: by revolution
    return shortest / cams[0].speed / WARMUP_STEPS_PER_MOTION


def warmup_step(machine: Machine, f_max: float, h: float) -> float:
    """Step [s] of the unrecorded warm-up grid: at most 1/(12·f_max) (every guard seen)
    and :func:`cam_input_step` (the cam input exact); ``h`` (the recording step) when
    neither bounds it."""
    bounds = [cam_input_step(machine)]
    if f_max > 0:
        bounds.append(1.0 / (SAMPLES_PER_PERIOD * f_max))
    best = min(bounds)
    return best if math.isfinite(best) else h



#: A shot steady state whose recorded revolution repeats itself less well than this (relative to
#: each peak) gets a warning: the shooting had converged on another event sequence.
SHOT_RESIDUAL_CHECK = 1e-9


def _residual(model: Model, saved: dict, stops, peak) -> float:
    """Largest change over one revolution of the free masses' state, relative to each peak
    (``peak(name, quantity)``: largest |sample| of a mass's recorded trace)."""
    if len(stops) != 2 or model.n == 0:
        return float("nan")
    before, after = (saved.get(round(s, 9)) for s in stops)
    if before is None or after is None:
        return float("nan")
    worst = 0.0
    for name in model.free_names:
        k = model.index[name]
        for quantity, b, a in (("displacement", before.x, after.x), ("velocity", before.v, after.v)):
            scale = peak(name, quantity) or 1.0
            worst = max(worst, abs(a[k] - b[k]) / scale)
    return worst

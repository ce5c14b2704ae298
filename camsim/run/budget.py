"""Know before you start: the number of samples and bytes a run will store.

A run's output grows with recorded time × sample rate × number of traces. A mistyped
``--set simulation.sample_rate=1e12Hz`` or ``simulation.cycles=100000`` would otherwise
be accepted and fill the disk. :func:`estimate_run` gives the size from the machine alone
(no integration, milliseconds), and :func:`check_budget` refuses a run above
``--max-output`` (default :data:`DEFAULT_MAX_OUTPUT`) with one line that gives the
estimate and the options that reduce it.

The estimate is an upper bound of the stored size: float64 samples, uncompressed, of the
traces the run stores — all of them (time, cam angle, displacement, velocity,
acceleration and jerk, three traces per mass, one force per element, the cam contact and
transducer forces) unless ``--record``, ``--record-last`` or ``--summary-only`` say
otherwise. ``camsim run`` streams its traces to the file, so memory does not grow with
this size; the disk does.

The estimate also counts the integration steps: the engine takes
``SAMPLES_PER_PERIOD`` steps per period of the fastest mode (or one per output sample,
whichever is finer), so a very stiff element or a very long recorded time makes the run
long whatever it stores. When the fastest mode sets the step and the run would take more
than :data:`DEFAULT_MAX_STEPS`, it is refused up front with the element that sets the pace
(steps at the output rate are what the user asked for: the size guard covers them); a
model too fast to integrate at all (numerically rigid, :mod:`camsim.model.rigidity`) or a
cam too fast to follow is refused outright.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from camsim.errors import InputError

__all__ = ["check_in_memory", "DEFAULT_MAX_OUTPUT", "DEFAULT_MAX_RUNS", "DEFAULT_MAX_STEPS", "check_runs", "Estimate", "estimate_run", "check_budget", "record_fraction", "parse_size", "format_size"]

#: Default largest estimated output of a run without ``--yes`` [bytes] (2 GB).
DEFAULT_MAX_OUTPUT = 2_000_000_000

#: Largest number of integration steps forced by a fast mode without ``--yes``: from half a
#: minute to several minutes of one core (measured on dynacam-2mass, issue 25: 2.7 M
#: steps/s with k12 = 1e14 N/m, 0.23 M steps/s with 6e14 N/m, where the modal recurrence
#: is ill-conditioned and the steps go one by one).
DEFAULT_MAX_STEPS = 1e8

_SIZE = re.compile(r"^\s*(\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)\s*([kKMGT]i?B|B)?\s*$")
_FACTORS = {"B": 1, "kB": 1e3, "KB": 1e3, "MB": 1e6, "GB": 1e9, "TB": 1e12, "KiB": 2**10, "kiB": 2**10, "MiB": 2**20, "GiB": 2**30, "TiB": 2**40}


def parse_size(text: str, option: str = "--max-output") -> int:
    """Bytes of a size text: ``2GB``, ``500 MB``, ``1.5GiB``, ``1e9`` (bare: bytes).

    Raises
    ------
    InputError
        Not a size.
    """
    m = _SIZE.match(str(text))
    if not m or (m.group(2) or "B") not in _FACTORS:
        raise InputError(f"{option} {text}: expected a size such as 2GB, 500MB or 1.5GiB")
    return int(float(m.group(1)) * _FACTORS[m.group(2) or "B"])


def format_size(n: float) -> str:
    """``2.1 GB``, ``340 MB``, ``12 kB`` (decimal prefixes)."""
    for unit, factor in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= factor:
            return f"{n / factor:.3g} {unit}"
    return f"{int(n)} B"


@dataclass(frozen=True)
class Estimate:
    """Size of a run's output, computed before it runs.

    Attributes
    ----------
    samples : float
        Output samples per trace.
    traces : int
        Traces stored.
    bytes : float
        ``samples × traces × 8`` [B] (float64, uncompressed).
    revolutions : float
        Revolutions integrated (warm-up included; 0 for a machine without a cam).
    recorded_s : float
        Recorded duration [s].
    steps : float
        Integration steps, warm-up included (0 when not estimated).
    pace : str
        What sets the step: ``"the output samples"`` or the fastest element and its
        frequency.
    """

    samples: float
    traces: int
    bytes: float
    revolutions: float
    recorded_s: float
    steps: float = 0.0
    pace: str = ""

    @property
    def paced_by_mode(self) -> bool:
        """True when the fastest mode, not the output sample rate, sets the step."""
        return self.pace.startswith(tuple("0123456789"))


def count_traces(machine) -> int:
    """Traces a run of ``machine`` writes (time and cam traces included).

    The layout (spec §7) has the five cam traces even without a cam (zeros); the cam
    contact force when the cam drives a mass. ``camsim run`` counts the paths of
    :func:`camsim.run.stream.machine_trace_layout` instead, which also knows ``--record``.
    """
    n = 1  # time
    n += 5  # cam angle, displacement, velocity, acceleration, jerk
    if machine.cam is not None and machine.cam.drives:
        n += 1  # cam contact force
    n += 3 * len(machine.node_names)  # a rod's interior nodes too (issue 39)
    n += sum(len(e.result_quantities) or 1 for e in machine.elements)  # a rod: its ends' forces and stress
    if any(getattr(e, "transducer", False) for e in machine.elements):
        n += 1
    n += len(getattr(machine, "loads", ()))  # issue 43: /loads/<name>/force
    return n


def estimate_run(
    machine,
    cycles: int | None = None,
    warmup_cycles: int | None = None,
    sample_rate: float | None = None,
    traces: int | None = None,
    record_fraction: float = 1.0,
    no_impact: bool = False,
) -> Estimate:
    """Estimate what a run of ``machine`` with these settings stores (as ``simulate`` would run it).

    Parameters
    ----------
    machine : Machine
    cycles, warmup_cycles : int, optional
        Overrides of ``[simulation]`` (as in :func:`camsim.run.simulation.simulate`).
    sample_rate : float, optional
        Override of the output sample rate [Hz].
    traces : int, optional
        Traces stored (default: all, :func:`count_traces`); 0 for a summary-only run.
    record_fraction : float
        Fraction of the recorded time whose samples are kept (``--record-last``).
    no_impact : bool
        The no-impact variant (its fastest mode differs).

    Raises
    ------
    InputError
        A cam too fast to follow, a numerically rigid model (before anything runs).
    """
    sim = machine.simulation
    rate = sample_rate if sample_rate is not None else sim.sample_rate
    n_cycles = cycles if cycles is not None else sim.cycles
    warm = warmup_cycles if warmup_cycles is not None else sim.warmup_cycles
    duration = None if cycles is not None else sim.duration
    period = None
    if machine.cam is not None:
        from camsim.cam import CamProgram

        period = CamProgram(machine.cam).period
    if duration is not None:
        recorded = float(duration)
    elif period is not None:
        recorded = float(n_cycles) * period
    else:
        recorded = 0.0
    revolutions = 0.0 if period is None else recorded / period + (warm or 0)
    samples = math.floor(recorded * rate * record_fraction) + 1 if rate > 0 else 0
    n = count_traces(machine) if traces is None else traces
    steps, pace = integration_steps(machine, recorded, (warm or 0) * period if period else 0.0, rate, no_impact)
    return Estimate(samples=float(samples), traces=n, bytes=float(samples) * n * 8.0, revolutions=revolutions,
                    recorded_s=recorded, steps=steps, pace=pace)


def integration_steps(machine, recorded: float, warmup: float, rate: float, no_impact: bool = False) -> tuple[float, str]:
    """Integration steps of a run and what sets their length (as ``simulate`` chooses them).

    Refuses (:class:`InputError`) a cam too fast to follow and a numerically rigid model
    (:mod:`camsim.model.rigidity`), before anything runs.

    Parameters
    ----------
    recorded, warmup : float
        Recorded and warm-up durations [s].
    rate : float
        Output sample rate [Hz].
    """
    from camsim.model.assembly import Model
    from camsim.model.rigidity import check_cam_resolvable, check_not_rigid, fastest_element
    from camsim.run.simulation import SAMPLES_PER_PERIOD, highest_frequency

    check_cam_resolvable(machine)
    model = Model(machine, no_impact=no_impact)
    f_max = highest_frequency(model)
    check_not_rigid(model, f_max, SAMPLES_PER_PERIOD)
    if rate <= 0:
        return 0.0, ""
    h_out = 1.0 / rate
    substeps = max(1, math.ceil(h_out * f_max * SAMPLES_PER_PERIOD))
    h = h_out / substeps
    h_warm = 1.0 / (SAMPLES_PER_PERIOD * f_max) if f_max > 0 else h
    if h_warm <= 1.5 * h:
        h_warm = h
    steps = recorded / h + warmup / h_warm
    if substeps == 1:
        return steps, "one step per output sample"
    fast = fastest_element(model)
    who = f", element.{fast.element}.{fast.key}" if fast is not None else ""
    return steps, f"{SAMPLES_PER_PERIOD} steps per period of the fastest mode, {f_max:.3g} Hz{who}"


def record_fraction(machine, record_last: int | None, cycles: int | None = None) -> float:
    """Fraction of the recorded time that ``--record-last N`` keeps (1 without it)."""
    if not record_last or machine.cam is None:
        return 1.0
    from camsim.cam import CamProgram

    period = CamProgram(machine.cam).period
    sim = machine.simulation
    recorded = float(cycles) * period if cycles is not None else (sim.duration if sim.duration is not None else sim.cycles * period)
    return min(1.0, record_last * period / recorded) if recorded > 0 else 1.0


#: What reduces a run's output, as the guard's message names it.
REDUCE_HINT = (
    "store less with --record PATTERN (e.g. transducer/*,masses/M3/*), --record-last N "
    "(revolutions) or --summary-only, or record less with --cycles (simulation.cycles or "
    "simulation.duration) or --sample-rate; or raise --max-output, or pass --yes to run it anyway"
)


def check_budget(estimate: Estimate, max_bytes: float, where: str, max_steps: float = DEFAULT_MAX_STEPS) -> None:
    """Raise :class:`InputError` when the estimate exceeds ``max_bytes`` or ``max_steps``.

    The message gives the estimate and the options that reduce it (exit 2 on the
    command line; nothing has run, nothing is written).
    """
    if estimate.bytes > max_bytes:
        raise InputError(
            f"{where}: the run would store {estimate.samples:.3g} samples x {estimate.traces} traces "
            f"= {format_size(estimate.bytes)} ({estimate.recorded_s:.4g} s recorded), above --max-output "
            f"{format_size(max_bytes)}; {REDUCE_HINT}"
        )
    # Steps at the output rate are what the user asked for (cycles x sample rate; a long
    # --summary-only run shows its progress bar); steps forced by a fast mode are not.
    if estimate.steps > max_steps and estimate.paced_by_mode:
        raise InputError(
            f"{where}: the run would take {estimate.steps:.3g} integration steps ({estimate.pace}; "
            f"{estimate.recorded_s:.4g} s recorded), above {max_steps:.3g} (minutes to hours of computing); "
            f"lower the stiffness or damping that sets the pace (or make that contact rigid, "
            f'law = "restitution"), record less with --cycles or simulation.duration, or pass --yes to run it anyway'
        )


def check_in_memory(machine, where: str, *, cycles=None, warmup_cycles=None, sample_rate=None) -> None:
    """Refuse (InputError) a run held in memory -- a comparison's two, a sweep's variant, a fit's
    evaluation, a material pair -- whose traces would exceed :data:`DEFAULT_MAX_OUTPUT`, or whose
    steps forced by a fast mode exceed :data:`DEFAULT_MAX_STEPS` (issue 45: estimated before
    anything is allocated; ``camsim run`` streams its traces and has ``--max-output``)."""
    estimate = estimate_run(machine, cycles=cycles, warmup_cycles=warmup_cycles, sample_rate=sample_rate)
    if estimate.bytes > DEFAULT_MAX_OUTPUT:
        raise InputError(
            f"{where}: each run of this command is held in memory, and this one would hold {estimate.samples:.3g} "
            f"samples x {estimate.traces} traces = {format_size(estimate.bytes)} ({estimate.recorded_s:.4g} s "
            f"recorded), above {format_size(DEFAULT_MAX_OUTPUT)}; record less with --cycles (simulation.cycles or "
            "simulation.duration) or --sample-rate (camsim run streams its traces to the file instead: --max-output)"
        )
    if estimate.steps > DEFAULT_MAX_STEPS and estimate.paced_by_mode:
        raise InputError(
            f"{where}: the run would take {estimate.steps:.3g} integration steps ({estimate.pace}; "
            f"{estimate.recorded_s:.4g} s recorded), above {DEFAULT_MAX_STEPS:.3g} (minutes to hours of computing); "
            'lower the stiffness or damping that sets the pace (or make that contact rigid, law = "restitution"), '
            "or record less with --cycles or simulation.duration"
        )


#: Largest number of simulation runs a job (an optimisation, a study) starts without ``--yes``:
#: at 0.1 to 0.3 s per run and core (CDTM, docs/performance.md), hours of computing.
DEFAULT_MAX_RUNS = 100_000


def check_runs(runs: float, max_runs: float | None, where: str, counted: str, fewer: str) -> None:
    """Raise :class:`InputError` when a job would make more than ``max_runs`` simulation runs.

    Parameters
    ----------
    runs : float
        The runs the job would make at most.
    max_runs : float or None
        ``--max-runs`` (None: ``--yes``, no limit).
    where : str
        The command, for the message (``"optimize"``).
    counted : str
        How ``runs`` was counted, e.g. ``"300 evaluations x 3 speeds x 32 samples"``.
    fewer : str
        The options that make fewer runs.
    """
    if max_runs is not None and runs > max_runs:
        raise InputError(
            f"{where}: up to {runs:,.0f} simulation runs ({counted}), above --max-runs {max_runs:,.0f} "
            f"(hours of computing at 0.1 to 0.3 s per run and core); {fewer}; or raise --max-runs, "
            "or pass --yes to run them anyway"
        )

"""Physical bounds of a run: a state far outside them is a divergence, not a result.

A run whose masses end up hundreds of metres away (issue 34: a compensated cam computed
from an ill-conditioned recursion moved M3 to 5.4e5 mm and was reported as a result, exit
0) is not a machine's motion. :func:`physical_bounds` sets, before integrating, a limit
on the displacement of every free mass that no machine made of these parts can reach,
and :meth:`Bounds.check` compares the state with it after every stretch (one
comparison: it does not slow the run). Beyond the limit the run stops with a
:class:`~camsim.errors.SimulationError` (exit 1) naming the mass and the key most likely
at fault.

The limit is :data:`BOUND_FACTOR` x (1 + revolutions) x the machine's length scale, the
sum of

* the cam's largest displacement on the model axis (its lift);
* every length an element declares (gaps, clearances, offsets);
* the static deflection of the softest element that holds a free mass under every force
  scale at once: the preloads, the weights, and the masses accelerated as the cam
  accelerates (Σ|P| + Σm·(g + a_cam))/k_min;
* the amplitude a mass of the whole free mass m_free can reach on that softest element
  when thrown at the cam's peak speed (and the initial speeds), v·√(m_free/k_min), and
  the height of a ballistic flight at that speed, v²/(2g);
* the initial displacements (static equilibrium and ``[initial]``), and, for a machine
  given an ``[initial]`` state (which may hold a free body), the free flight v·t + g·t²/2
  over the whole run;
* with process loads (issue 43): their peaks among the forces, the flight of the lightest free
  mass under all of them for the whole run, and a sine's periods counted as revolutions (a
  sine at resonance grows linearly, as a cam does).

Every term is a displacement the machine can produce by itself; the sum bounds any of
them with margin. The factor (1 + revolutions) lets an undamped machine driven at
resonance grow linearly, as it does (the cam's work per revolution is bounded by its
force times its travel, and the force grows with the amplitude at most linearly, so the
amplitude grows at most linearly in time). A numerical divergence grows exponentially
and crosses the limit within a few stretches; energy that grows without input shows
there too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from camsim.cam.program import CamProgram
from camsim.elements import GROUND
from camsim.engine.context import input_store
from camsim.errors import SimulationError

__all__ = ["BOUND_FACTOR", "Bounds", "physical_bounds"]

#: How far beyond the machine's own length scale (per revolution run) a mass may go
#: before the run is stopped as diverged.
BOUND_FACTOR = 100.0


@dataclass(frozen=True)
class Bounds:
    """The displacement limit of a run and where it came from.

    Attributes
    ----------
    limit : float
        Largest |x| of a free mass [m].
    scale : float
        The machine's length scale [m] (see the module docstring).
    revolutions : float
        Revolutions the run integrates (0 without a cam).
    source : str
        The machine file (for the message).
    names : tuple of str
        The free masses, in the order of the state.
    suspects : tuple of str
        For each free mass, the key most likely at fault when it runs away.
    """

    limit: float
    scale: float
    revolutions: float
    source: str
    names: tuple[str, ...]
    suspects: tuple[str, ...]

    def check(self, state) -> None:
        """Raise :class:`SimulationError` when a free mass of ``state`` is beyond :attr:`limit`."""
        x = state.x
        if x.size and float(np.max(np.abs(x))) > self.limit:
            i = int(np.argmax(np.abs(x)))
            raise SimulationError(
                f"{self.source}: the run diverged at t = {state.t:.6g} s: {self.names[i]} reached "
                f"{x[i]:.3g} m, beyond {self.limit:.3g} m ({BOUND_FACTOR:g} x {1 + self.revolutions:g} x the machine's "
                f"{self.scale * 1e3:.3g} mm of lift, gaps and static deflection); likely {self.suspects[i]}"
            )


def _prescribed(model, node: str) -> bool:
    return node == GROUND or node in model.cam_index or node in model.drives  # every cam and what it drives


def _stiffnesses(model) -> list[tuple[int, float, float]]:
    """(element index, k, c) of every linear branch with k > 0 of an element on a free mass."""
    out = []
    for i, element in enumerate(model.elements):
        if all(_prescribed(model, n) for n in (element.lower, element.upper)):
            continue  # between prescribed nodes (ground, cam, the driven mass): moves nothing
        for branch in model.branch_options(i) or (None,):
            law = model.linear_branch(i, branch)
            if law is not None and float(law[0]) > 0.0:
                out.append((i, abs(float(law[0])), abs(float(law[1]))))
    return out


def _suspect(model, name: str, laws) -> str:
    """The key most likely at fault when ``name`` runs away: its least damped element."""
    m = model.machine.mass_of(name)
    best = None
    for i, k, c in laws:
        element = model.elements[i]
        if name not in (element.lower, element.upper):
            continue
        zeta = c / (2.0 * math.sqrt(k * m))
        if best is None or zeta < best[0]:
            best = (zeta, element)
    if best is None:
        return f"mass.{name} (no element holds it elastically)"
    zeta, element = best
    if getattr(element, "restitution", None) is not None:
        key = "restitution"
    else:
        key = "damping" if element.damping.coefficient is not None else "damping_ratio"
    return f"element.{element.name}.{key} (damping ratio {zeta:.3g} on {name}, the least damped element on it)"


def _cam_scales(description, cam) -> tuple[float, float, float]:
    """Largest |s|, |ṡ|, |s̈| of the cam on the model axis [m, m/s, m/s²], as designed.

    A compensated cam given as a table (:mod:`camsim.machine.compensation`) is taken at
    its nodes for s and from the written output motion for ṡ and s̈ (the compensated cam
    follows it up to the path's deflections): its interpolant and its higher derivatives
    are what went wrong in issue 34 (a third derivative 1e15 times too large made it swing
    by metres), and a bound read from them would have grown with the fault it is there
    to catch.
    """
    times = np.linspace(0.0, cam.period, 3601)
    comp = getattr(description, "compensated", None)
    if comp is not None and comp.kind == "table":
        _, v, a, _ = CamProgram(description.output_program).svaj(times)
        lift = float(np.max(np.abs(comp.jets[0]))) * cam.ratio
        return lift, float(np.max(np.abs(v))), float(np.max(np.abs(a)))
    s, v, a, _ = cam.svaj(times)
    return tuple(float(np.max(np.abs(q))) for q in (s, v, a))


def physical_bounds(model, cam, state, t_end: float) -> Bounds:
    """The displacement limit of a run of ``model`` from ``state`` to ``t_end`` [s].

    Parameters
    ----------
    model : Model
    cam : CamProgram or CamshaftInput
    state : State
        The initial state (its displacements and velocities enter the scale).
    t_end : float
        End of the run [s], warm-up included.
    """
    machine = model.machine
    g = abs(float(machine.simulation.gravity))
    lift = v_cam = a_cam = 0.0
    revolutions = 0.0
    if machine.cam is not None:
        if machine.multi_cam:  # issue 38: every cam pushes; the lifts add up, the rates do not
            scales = [_cam_scales(c, p) for c, p in zip(machine.cams, cam.programs)]
            lift = sum(q[0] for q in scales)
            v_cam, a_cam = max(q[1] for q in scales), max(q[2] for q in scales)
        else:
            # kept with the cam's program: a worker's runs share it (camsim.cam.camshaft.shared_program)
            store = input_store(cam, ("scales",))
            if "scales" not in store:
                store["scales"] = _cam_scales(machine.cam, cam)
            lift, v_cam, a_cam = store["scales"]
        revolutions = t_end / cam.period
    lengths = forces = 0.0
    for element in machine.elements:
        for p in element.params:
            value = getattr(element, p.attribute, None)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                continue
            if p.dimension == "length":
                lengths += abs(value)
            elif p.dimension == "force":
                forces += abs(value)
    loads = getattr(machine, "loads", ())  # issue 43: process loads push like preloads, and may throw
    forces += sum(load.peak for load in loads)
    for load in loads:  # a sine at resonance grows linearly, like a cam's: per period of it
        if load.kind == "sine":
            revolutions = max(revolutions, t_end * float(load.sine.frequency))
    free_mass = sum(machine.mass_of(n) for n in model.free_names)
    laws = _stiffnesses(model)
    k_min = min((k for _, k, _ in laws), default=0.0)
    v_top = v_cam + (float(np.max(np.abs(state.v))) if state.v.size else 0.0)
    scale = lift + lengths + (float(np.max(np.abs(state.x))) if state.x.size else 0.0)
    if k_min > 0.0:
        scale += (forces + free_mass * (g + a_cam)) / k_min + v_top * math.sqrt(free_mass / k_min)
    if g > 0.0:
        scale += v_top * v_top / (2.0 * g)
    if machine.initial:
        scale += v_top * t_end + 0.5 * g * t_end * t_end
    if loads and model.n:  # the lightest free mass thrown by every load at once, for the whole run
        lightest = min(machine.mass_of(n) for n in model.free_names)
        if lightest > 0.0:
            scale += 0.5 * sum(load.peak for load in loads) / lightest * t_end * t_end
    scale = max(scale, 1e-3)  # a machine of zero size (no lift, no gap, no load) still moves
    limit = BOUND_FACTOR * (1.0 + revolutions) * scale
    suspects = tuple(_suspect(model, name, laws) for name in model.free_names)
    return Bounds(limit, scale, revolutions, machine.source, tuple(model.free_names), suspects)

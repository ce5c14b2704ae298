"""Which element makes a model fast, and when it is too fast to integrate (numerically rigid).

The integrator takes a fixed number of steps per period of the fastest mode of the model
(``SAMPLES_PER_PERIOD`` in :mod:`camsim.run.simulation`) and locates events to
:data:`EVENT_ACCURACY`. An element stiff enough (or damped hard enough) that its time scale
approaches that accuracy cannot be resolved: its mode would need steps of a few
nanoseconds (a stiffness of 1e18 N/m on 4 kg: 8e7 Hz, 1e9 steps per second simulated) and
its deflection drowns in the rounding of the positions. Physically the element is rigid,
and camsim has a model for that: a rigid contact (``law = "restitution"``), or a lower
stiffness. :func:`check_not_rigid` says so before anything runs, naming the element key.

The element's own rate is that of its law on the reduced mass of the two nodes it joins
(ground, the cam and a driven mass count as infinite): the fastest root |λ| of
m·λ² + c·λ + k = 0, which is ω = √(k/m) when underdamped and (c + √(c² − 4mk))/(2m)
when overdamped (a huge damping ratio is as fast as a huge stiffness). It names the
culprit; the decision uses the model's own highest frequency (the eigenvalues of every
configuration, :func:`camsim.run.simulation.highest_frequency`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from camsim.errors import InputError
from camsim.physics.restitution import reduced_mass

__all__ = ["EVENT_ACCURACY", "RIGID_STEP", "ElementRate", "element_rates", "fastest_element", "check_not_rigid",
           "rigid_frequency"]

#: Accuracy to which events are located [s] (spec §4, docs/model.md).
EVENT_ACCURACY = 1e-9

#: Shortest integration step the engine is asked to take [s]: a hundred times the event
#: accuracy, ten times the bracket (up to 1e-8 s) over which camsim.engine.crossing carries
#: the state to second order to polish a crossing, so that a located event stays a small
#: fraction of a step of the fastest mode. With 12 steps per period: 833 kHz. Beyond it the
#: runs that still end are slow (dynacam-2mass with k12 = 6e14 N/m, 1.95 MHz: 69 s of CPU
#: for one revolution and its warm-up, an ill-conditioned modal recurrence stepping one by one).
RIGID_STEP = 100 * EVENT_ACCURACY


def rigid_frequency(samples_per_period: int) -> float:
    """Highest natural frequency [Hz] whose step 1/(samples_per_period·f) is >= :data:`RIGID_STEP`."""
    return 1.0 / (samples_per_period * RIGID_STEP)


@dataclass(frozen=True)
class ElementRate:
    """The fastest rate of one element's law on its reduced mass.

    Attributes
    ----------
    element : str
        Element name.
    key : str
        The element key that sets the rate (``stiffness``, ``push_stiffness``,
        ``damping_ratio``, ...).
    frequency : float
        |λ|/(2π) [Hz].
    stiffness, damping, mass : float
        k [N/m], c [N·s/m] and the reduced mass [kg] it came from.
    """

    element: str
    key: str
    frequency: float
    stiffness: float
    damping: float
    mass: float

    @property
    def damped(self) -> bool:
        """True when the damping sets the rate (overdamped: c² > 4mk)."""
        return self.damping**2 > 4.0 * self.mass * self.stiffness


def _stiffness_key(element, k: float) -> str:
    for p in element.params:
        if p.dimension == "stiffness" and getattr(element, p.attribute, None) == k:
            return p.key
    return "stiffness"


def _damping_key(element) -> str:
    return "damping_ratio" if element.damping.ratio is not None else "damping"


def element_rates(model) -> list[ElementRate]:
    """The fastest rate of each element with a linear law, over its branches (see module doc)."""
    out: list[ElementRate] = []
    for i, element in enumerate(model.elements):
        try:
            m = reduced_mass(model.machine, element)
        except (ValueError, KeyError):
            continue
        best: ElementRate | None = None
        for branch in model.branch_options(i) or (None,):
            law = model.linear_branch(i, branch)
            if law is None:
                continue
            k, c = abs(float(law[0])), abs(float(law[1]))
            disc = c * c - 4.0 * m * k
            lam = (c + math.sqrt(disc)) / (2.0 * m) if disc > 0 else math.sqrt(k / m)
            key = _damping_key(element) if disc > 0 and c > 0 else _stiffness_key(element, k)
            rate = ElementRate(element.name, key, lam / (2.0 * math.pi), k, c, m)
            if best is None or rate.frequency > best.frequency:
                best = rate
        if best is not None:
            out.append(best)
    return out


def fastest_element(model) -> ElementRate | None:
    """The element whose own rate is the highest (None for a model without linear elements)."""
    rates = element_rates(model)
    return max(rates, key=lambda r: r.frequency) if rates else None


def check_not_rigid(model, f_max: float, samples_per_period: int) -> None:
    """Refuse a model whose highest natural frequency ``f_max`` [Hz] is numerically rigid.

    Raises
    ------
    InputError
        Naming the element key, its frequency and what to do (exit 2 on the command line).
    """
    limit = rigid_frequency(samples_per_period)
    if not (f_max > limit):  # also catches a NaN frequency
        if math.isfinite(f_max):
            return
    source = model.machine.source
    culprit = fastest_element(model)
    if culprit is None:
        raise InputError(f"{source}: highest natural frequency {f_max:.3g} Hz is numerically rigid "
                         f"(above {limit:.3g} Hz): lower the stiffnesses or use rigid contacts")
    element = next(e for e in model.elements if e.name == culprit.element)
    where = "element.{}.{}".format(*element.reported_as(culprit.key))  # a rod's segment: its rod's `segments`
    if culprit.damped:
        why = (f"damping {culprit.damping:.3g} N*s/m on {culprit.mass:.3g} kg has a time constant of "
               f"{1.0 / (2 * math.pi * culprit.frequency):.3g} s")
        fix = "lower the damping (a damping ratio refers to the element's reference mass)"
    else:
        why = (f"stiffness {culprit.stiffness:.3g} N/m on {culprit.mass:.3g} kg gives a natural frequency of "
               f"{culprit.frequency:.3g} Hz")
        fix = ('use a rigid contact (type = "contact", law = "restitution") or a lower stiffness'
               if element.unilateral
               else "use a lower stiffness, or join the masses into one (a rigid link), or a rigid contact "
                    '(law = "restitution") if it is a contact')
        if element.parent() is not None:  # issue 39: a rod's segment N·E·A/L on its m/N
            fix = "use fewer segments (a rod of N segments has its highest mode at N*c/(pi*L))"
    raise InputError(
        f"{source}: {where}: {why}, faster than the engine can resolve (highest natural frequency "
        f"{f_max:.3g} Hz, limit {limit:.3g} Hz: steps of {RIGID_STEP:g} s against events located to "
        f"{EVENT_ACCURACY:g} s): the configuration is numerically rigid; {fix}"
    )


#: Shortest cam segment (or table interval) the engine is asked to follow [s]: a thousand
#: times the event accuracy, so that an event's located time is a negligible fraction of it.
SHORTEST_SEGMENT = 1000 * EVENT_ACCURACY


def check_cam_resolvable(machine) -> None:
    """Refuse a cam so fast that a segment lasts less than :data:`SHORTEST_SEGMENT`.

    At 4e11 rpm a 90 deg segment lasts 4e-11 s, below the 1e-9 s to which events are
    located: no event on it can be placed, and the run would stall on the first.

    Raises
    ------
    InputError
        Naming ``cam.speed`` (exit 2 on the command line).
    """
    cam = machine.cam
    if cam is None:
        return
    speed = float(cam.speed)
    if cam.segments:
        angle = min(s.duration for s in cam.segments)
        what = f"its shortest segment ({math.degrees(angle):.4g} deg)"
    elif cam.table is not None and len(cam.table.angle) > 1:
        steps = [b - a for a, b in zip(cam.table.angle[:-1], cam.table.angle[1:]) if b > a]
        angle = min(steps) if steps else 2 * math.pi
        what = f"its finest table interval ({math.degrees(angle):.4g} deg)"
    else:
        angle, what = 2 * math.pi, "a revolution"
    lasts = angle / speed if speed > 0 else math.inf
    if lasts >= SHORTEST_SEGMENT:
        return
    rpm = speed * 60.0 / (2 * math.pi)
    fastest = angle / SHORTEST_SEGMENT * 60.0 / (2 * math.pi)
    raise InputError(
        f"{machine.source}: cam.speed: at {rpm:.3g} rpm {what} lasts {lasts:.3g} s, below "
        f"{SHORTEST_SEGMENT:g} s (1000 x the {EVENT_ACCURACY:g} s to which events are located): the engine "
        f"cannot resolve it; run at most {fastest:.3g} rpm"
    )

"""The state of the machine and the records of the engine, shared by every stepper.

:class:`State` is the machine at one instant, :class:`Stretch` the output-grid samples of one
branch configuration, :class:`Guard` one scalar condition that keeps a configuration valid.
The integrator (:mod:`camsim.engine.integrator`) and the contact solvers below it
(:mod:`camsim.engine.nonlinear`, :mod:`camsim.engine.collocation`, :mod:`camsim.engine.rigid`,
:mod:`camsim.engine.crossing`) exchange them; this module sits under all of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from camsim.elements import Branch, GuardKind
from camsim.elements.affine import Affine
from camsim.model.assembly import Configuration

#: Two times closer than this [s] are the same instant (a stretch end on a grid point, a
#: boundary reached): far below the 1e-9 s event accuracy, far above rounding of t ~ 1e3 s.
TIME_EPS = 1e-13
#: An event is placed within this time [s] of its guard's zero (camsim.engine.crossing):
#: where integration restarts after it, a guard of the new branches may read up to its
#: rate times this on the wrong side of zero (issue 34: a lobe contact released where its
#: force was still +5e-9 N, 1.5e-13 s early, and its lifted guard read -5e-9 N < -1e-9 N).
RESTART_TIME = 1e-10


def leaving_zero(g, g_rate, tol):
    """True where a guard is at its zero to the event accuracy and moving into validity.

    At the instant integration restarts (after an event) a guard ``g`` with |g| within its
    tolerance plus |ġ|·:data:`RESTART_TIME` is at its zero; if its rate ġ is positive it is
    leaving zero on the valid side, so it is neither violated nor crossing there, whatever
    the sign its value was rounded or located to (spec §4: a contact that releases does not
    close again at the same instant). Works on floats and arrays.
    """
    return (g_rate > 0.0) & (np.abs(g) <= tol + np.abs(g_rate) * RESTART_TIME)

@dataclass
class Guard:
    """A scalar condition that keeps the configuration valid while it is > 0."""

    element: int
    kind: GuardKind
    value: Affine  # one row
    tol: float
    rate: Affine | None = None  # time derivative (linear configurations)


@dataclass
class Stretch:
    """One configuration between two events: its nodes, and which of them are output samples.

    A stretch from the engine's steppers holds **every node** of its solution: its start,
    its grid points, the cam's break times inside it as node pairs (the limits from the
    left and from the right: the cam's acceleration or jerk may jump there, the state does
    not), and its end (an event, a stop). ``samples`` marks the nodes that are grid points
    recorded as output samples (the stretch's end is the next one's start: never a sample
    here). A stepper that only knows its grid points (``samples`` None) returns those alone;
    the integrator adds the start and the end (:meth:`Integrator.advance`).

    Attributes
    ----------
    t : ndarray (N,)
        Node times [s], non-decreasing (a break is two nodes at one time).
    z, u, fn : ndarray
        States (N, m), cam inputs (N, 4·c) and nonlinear contact forces (N, p) there.
    samples : ndarray (N,) of bool, or None
        Output samples among the nodes (None: every node is one, a stepper's grid points).
    exact : bool
        A linear configuration (the state inside a step is its exact Taylor series); False:
        a closed nonlinear contact (integrated again for states between nodes).
    extremes : StretchExtremes or None
        Its located extremes in the recording window (set by the run that observes it).
    """

    branches: tuple[Branch, ...]
    config: Configuration
    t: np.ndarray
    z: np.ndarray
    u: np.ndarray
    fn: np.ndarray
    v_impacts: dict[int, float] = field(default_factory=dict)
    extremes: object = None
    samples: np.ndarray | None = None
    exact: bool = True

    def sample_rows(self) -> np.ndarray | slice:
        """Index of the nodes that are output samples (a slice when all are)."""
        return slice(None) if self.samples is None else np.flatnonzero(self.samples)


@dataclass
class State:
    """Full state of the machine at one instant."""

    t: float
    x: np.ndarray
    v: np.ndarray
    branches: tuple[Branch, ...]
    v_impacts: dict[int, float]
    #: The deflection each stuck friction pair is held at: ((element index, d [m]), ...) in
    #: index order (spec §10; part of the configuration, :meth:`Model.configuration`).
    holds: tuple[tuple[int, float], ...] = ()


def cubic_root(g0: float, g1: float, d0: float, d1: float) -> float:
    """Root in (0, 1] of the cubic Hermite p with p(0)=g0 > 0, p(1)=g1 ≤ 0, p'(0)=d0, p'(1)=d1."""
    c2 = 3 * (g1 - g0) - 2 * d0 - d1
    c3 = 2 * (g0 - g1) + d0 + d1
    a, b = 0.0, 1.0
    x = g0 / (g0 - g1) if g0 != g1 else 0.5
    for _ in range(40):
        p = g0 + x * (d0 + x * (c2 + x * c3))
        if p > 0:
            a = x
        else:
            b = x
        dp = d0 + x * (2 * c2 + 3 * x * c3)
        x_new = x - p / dp if dp != 0 else 0.5 * (a + b)
        if not (a < x_new < b):
            x_new = 0.5 * (a + b)
        if abs(x_new - x) < 1e-15:
            return x_new
        x = x_new
    return x

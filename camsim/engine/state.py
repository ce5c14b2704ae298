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
    """Samples of one configuration on the output grid."""

    branches: tuple[Branch, ...]
    config: Configuration
    t: np.ndarray
    z: np.ndarray
    u: np.ndarray
    fn: np.ndarray
    v_impacts: dict[int, float] = field(default_factory=dict)


@dataclass
class State:
    """Full state of the machine at one instant."""

    t: float
    x: np.ndarray
    v: np.ndarray
    branches: tuple[Branch, ...]
    v_impacts: dict[int, float]

"""A dynamically compensated cam profile (issue 27; computed by :mod:`camsim.machine.compensation`).

The profile is the roller lift s(θ)/ratio that makes the output mass follow the written
program at the design speed. Two representations:

``"algebraic"`` (undamped path)
    lift(θ) = Σₙ aₙ·L⁽ⁿ⁾(θ) + offset, a finite combination of the written program's lift L
    and its exact θ-derivatives: derivatives of any order are exact.
``"table"`` (a damped element on the path)
    a periodic piecewise Hermite polynomial (``scipy.interpolate.PPoly``, built vectorised)
    through the lift and its θ-derivatives computed on a uniform grid of cam angles:
    s, s′, s″ (and s‴ where the construction gives it) are matched at every grid point,
    so s, v, a are continuous and exact at the nodes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from camsim.cam.description import Cam

__all__ = ["CompensatedProfile"]

_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, eq=False)
class CompensatedProfile:
    """The compensated cam lift at the roller.

    Attributes
    ----------
    written : Cam
        The written program (the motion wanted at the output, model axis = ratio × lift).
    output : str
        The output mass.
    speed : float
        Design speed ω [rad/s].
    kind : str
        ``"algebraic"`` or ``"table"``.
    coefficients : tuple of (int, float)
        Algebraic: (n, aₙ) with lift = Σ aₙ·dⁿL/dθⁿ + offset [m/radⁿ per m/radⁿ … i.e. m·radⁿ].
    offset : float
        Algebraic: constant lift offset [m] (preloads, gravity).
    theta : ndarray
        Table: grid of cam angles [rad], uniform over one revolution (without the end).
    jets : ndarray
        Table: lift and its θ-derivatives at the grid, shape (orders, len(theta)) [m/radⁿ].
    path : tuple of str
        Element names from the output up to the cam (for reports).
    """

    written: Cam
    output: str
    speed: float
    kind: str
    coefficients: tuple[tuple[int, float], ...] = ()
    offset: float = 0.0
    theta: np.ndarray | None = None
    jets: np.ndarray | None = None
    path: tuple[str, ...] = ()
    _bpoly: list = field(default_factory=list, repr=False)

    def _table(self):
        """The periodic Hermite interpolant as a ``scipy.interpolate.PPoly`` (built vectorised)."""
        if not self._bpoly:
            from scipy.interpolate import PPoly

            x = np.append(self.theta, _TWO_PI)
            y = np.concatenate([self.jets, self.jets[:, :1]], axis=1)
            orders = y.shape[0]
            h = np.diff(x)
            # Local variable τ = (θ − θ_k)/h ∈ [0, 1]: dⁿ/dτⁿ at both ends = hⁿ·L⁽ⁿ⁾.
            deg = 2 * orders - 1
            basis = np.zeros((2 * orders, deg + 1))
            for n in range(orders):
                for j in range(n, deg + 1):
                    fac = math.perm(j, n)
                    basis[n, j] = fac * (1.0 if j == n else 0.0)  # at τ = 0
                    basis[orders + n, j] = fac  # at τ = 1
            data = np.concatenate([y[:, :-1] * h**np.arange(orders)[:, None],
                                   y[:, 1:] * h**np.arange(orders)[:, None]], axis=0)
            a = np.linalg.solve(basis, data)  # (deg+1, intervals), power basis in τ
            c = a / h[None, :] ** np.arange(deg + 1)[:, None]
            self._bpoly.append(PPoly(c[::-1], x))
        return self._bpoly[0]

    def lift_derivatives(self, written_program, theta: np.ndarray, order: int, side: str = "right") -> np.ndarray:
        """Compensated lift and its θ-derivatives 0…order at ``theta`` [rad], shape (order+1, n)."""
        th = np.asarray(theta, dtype=float).reshape(-1)
        if self.kind == "algebraic":
            top = max(n for n, _ in self.coefficients)
            base = written_program.lift_derivatives(th, top + order, side=side)
            out = np.zeros((order + 1, th.size))
            for q in range(order + 1):
                for n, a in self.coefficients:
                    out[q] += a * base[n + q]
            out[0] += self.offset
            return out
        poly = self._table()
        phi = np.mod(th, _TWO_PI)
        out = np.zeros((order + 1, th.size))
        degree = poly.c.shape[0] - 1  # the jets' Hermite degree
        for q in range(min(order, degree) + 1):
            out[q] = poly(phi, nu=q)
        return out

"""Quadratic damping of springs and links (spec §10): f_q = c_q·ḋ·|ḋ| on top of the element's law.

The element keeps its linear law in the linear system (its stiffness sets the grid and the
natural frequencies) and adds f_q as a nonlinear force F_nl, integrated to the engine's
tolerance with the rest of the configuration (:mod:`camsim.engine.rk`). In the engine's
terms F_nl is compressive-positive along δ = −d (a contact at gap 0 on the lower side):
F = −f_q = c_q·δ̇·|δ̇|. It vanishes at rest, so the static equilibrium stays linear.
"""

from __future__ import annotations

import math

import numpy as np


class QuadraticDamping:
    """What a spring or link with ``quadratic_damping`` c_q [N·s²/m²] adds to its protocol."""

    quadratic_damping: float = 0.0

    def is_nonlinear(self, branch) -> bool:
        return self.quadratic_damping > 0.0

    def linear_part(self, branch, damping):
        return self.linear_law(branch, damping) if self.quadratic_damping > 0.0 else None

    def nonlinear_at_rest(self, branch) -> bool:
        return False

    def nonlinear_force(self, delta: np.ndarray, delta_rate: np.ndarray, v_impact=None) -> np.ndarray:
        """F_nl = c_q·δ̇·|δ̇| (= −f_q, δ̇ = −ḋ) [N] on samples."""
        return self.quadratic_damping * delta_rate * np.abs(delta_rate)

    def nonlinear_force_scalar(self, delta: float, delta_rate: float, v_impact=None) -> float:
        return self.quadratic_damping * delta_rate * math.fabs(delta_rate)

    def quadratic_force(self, d_rate: np.ndarray) -> np.ndarray:
        """f_q = c_q·ḋ·|ḋ| (tension-positive) [N]."""
        return self.quadratic_damping * d_rate * np.abs(d_rate)

    def describe(self) -> dict:
        """The element's parameters, without ``quadratic_damping`` at its default 0 (files
        written before §10 describe the same element)."""
        out = super().describe()
        if not self.quadratic_damping:
            out.pop("quadratic_damping", None)
        return out

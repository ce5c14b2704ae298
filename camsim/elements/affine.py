"""Affine maps of the state: how every observable depends on (z, u, F_nl).

Everything observable in a linear configuration (positions, velocities, accelerations of
the free masses, element deflections, constraint forces, event guards) is an affine map
of the reduced state z, the cam input u = [s, ṡ, s̈, s⃛] and the forces F_nl of the
nonlinear (power-law) contacts, so the integrator evaluates it on whole arrays at once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Number of cam-input channels: s, ṡ, s̈, s⃛.
N_INPUT = 4


@dataclass
class Affine:
    """An affine map  q = Cz·z + Du·u + Fn·F_nl + e  evaluated on arrays.

    Attributes
    ----------
    Cz : ndarray (k, m)
    Du : ndarray (k, 4)
    Fn : ndarray (k, p)
    e : ndarray (k,)
    """

    Cz: np.ndarray
    Du: np.ndarray
    Fn: np.ndarray
    e: np.ndarray

    def __call__(self, z: np.ndarray, u: np.ndarray, fn: np.ndarray | None = None) -> np.ndarray:
        """Evaluate on samples: z (N, m), u (N, 4), fn (N, p) -> (N, k)."""
        out = z @ self.Cz.T + u @ self.Du.T + self.e
        if self.Fn.shape[1] and fn is not None:
            out = out + fn @ self.Fn.T
        return out

    def rows(self, index) -> "Affine":
        return Affine(self.Cz[index], self.Du[index], self.Fn[index], self.e[index])

    @staticmethod
    def combine(terms: list[tuple[np.ndarray, "Affine"]], const: np.ndarray, du: np.ndarray) -> "Affine":
        """Σ W_i·Affine_i + du·u + const (W_i are (k, rows_i) weight matrices)."""
        W0, a0 = terms[0]
        Cz = W0 @ a0.Cz
        Du = W0 @ a0.Du + du
        Fn = W0 @ a0.Fn
        e = W0 @ a0.e + const
        for W, a in terms[1:]:
            Cz = Cz + W @ a.Cz
            Du = Du + W @ a.Du
            Fn = Fn + W @ a.Fn
            e = e + W @ a.e
        return Affine(Cz, Du, Fn, e)

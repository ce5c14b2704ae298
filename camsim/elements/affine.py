"""Affine maps of the state: how every observable depends on (z, u, F_nl).

Everything observable in a linear configuration (positions, velocities, accelerations of
the free masses, element deflections, constraint forces, event guards) is an affine map
of the reduced state z, the cam input u and the forces F_nl of the nonlinear (power-law)
contacts, so the integrator evaluates it on whole arrays at once.

The cam input holds :data:`N_INPUT` channels per cam, laid out cam by cam:
u = [s₁, ṡ₁, s̈₁, s⃛₁, s₂, ṡ₂, …] (4·c columns for c cams; a machine with one cam, or none,
has the four channels [s, ṡ, s̈, s⃛]). Channel d of cam q is column 4·q + d
(:func:`channel`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Cam-input channels per cam: s, ṡ, s̈, s⃛ (the input of c cams has 4·c columns).
N_INPUT = 4


def channel(cam: int, order: int) -> int:
    """Column of d^order s/dt^order of cam number ``cam`` in the cam input u."""
    return N_INPUT * cam + order


def n_cams(width: int) -> int:
    """Number of cams of a cam input with ``width`` columns."""
    return width // N_INPUT


def input_rate(u: np.ndarray) -> np.ndarray:
    """u̇ from u: [ṡ, s̈, s⃛, 0] per cam (the fourth derivative is not carried: nothing
    reads it), shaped like u (..., 4·c)."""
    out = np.zeros(u.shape)
    for q in range(u.shape[-1] // N_INPUT):
        out[..., N_INPUT * q : N_INPUT * q + 3] = u[..., N_INPUT * q + 1 : N_INPUT * (q + 1)]
    return out


def times_rate(M: np.ndarray, u: np.ndarray) -> np.ndarray:
    """M·u̇ for one input row u (4·c,) without forming u̇: Σ_q M[..., 4q:4q+3]·u[4q+1:4q+4]
    (M (k, 4·c) or (4·c,)); with one cam exactly ``M[..., :3] @ u[1:]``."""
    out = M[..., 0:3] @ u[1:4]
    for q in range(1, u.shape[-1] // N_INPUT):
        out = out + M[..., N_INPUT * q : N_INPUT * q + 3] @ u[N_INPUT * q + 1 : N_INPUT * q + 4]
    return out


def shift_rate(Du: np.ndarray, Du_rate: np.ndarray) -> None:
    """Add to ``Du_rate`` the input part of d/dt of an affine map whose input part is ``Du``
    (each cam's channel d moves to d + 1), in place; the jerk channels must carry no weight."""
    for q in range(Du.shape[1] // N_INPUT):
        if np.any(Du[:, N_INPUT * q + 3]):
            raise AssertionError("guards may not depend on the jerk")
    for q in range(Du.shape[1] // N_INPUT):
        Du_rate[:, N_INPUT * q + 1 : N_INPUT * (q + 1)] += Du[:, N_INPUT * q : N_INPUT * q + 3]


def reads_acceleration(du: np.ndarray) -> bool:
    """Whether an input row (4·c,) reads any cam's s̈ or s⃛."""
    return bool(np.any(du.reshape(-1, N_INPUT)[:, 2:]))


@dataclass
class Affine:
    """An affine map  q = Cz·z + Du·u + Fn·F_nl + e  evaluated on arrays.

    Attributes
    ----------
    Cz : ndarray (k, m)
    Du : ndarray (k, 4·c)
    Fn : ndarray (k, p)
    e : ndarray (k,)
    """

    Cz: np.ndarray
    Du: np.ndarray
    Fn: np.ndarray
    e: np.ndarray

    def __call__(self, z: np.ndarray, u: np.ndarray, fn: np.ndarray | None = None) -> np.ndarray:
        """Evaluate on samples: z (N, m), u (N, 4·c), fn (N, p) -> (N, k)."""
        out = z @ self.Cz.T + u @ self.Du.T + self.e
        if self.Fn.shape[1] and fn is not None:
            out = out + fn @ self.Fn.T
        return out

    def rows(self, index) -> "Affine":
        return Affine(self.Cz[index], self.Du[index], self.Fn[index], self.e[index])

    @staticmethod
    def combine(terms: list[tuple[np.ndarray, "Affine"]], const: np.ndarray, du: np.ndarray | None = None) -> "Affine":
        """Σ W_i·Affine_i + du·u + const (W_i are (k, rows_i) weight matrices; ``du`` None:
        no input term of its own)."""
        W0, a0 = terms[0]
        Cz = W0 @ a0.Cz
        Du = W0 @ a0.Du
        Du = Du + (du if du is not None else np.zeros_like(Du))
        Fn = W0 @ a0.Fn
        e = W0 @ a0.e + const
        for W, a in terms[1:]:
            Cz = Cz + W @ a.Cz
            Du = Du + W @ a.Du
            Fn = Fn + W @ a.Fn
            e = e + W @ a.e
        return Affine(Cz, Du, Fn, e)

"""Normalised cam motion laws: a rise y(u) from 0 to 1 and its exact derivatives.

Every law is a function of the normalised angle u = (θ − Θ)/β ∈ [0, 1] with y(0) = 0 and
y(1) = 1; a fall is 1 − y(u). The derivatives y′, y″, y‴ are taken with respect to u and
are analytic (closed forms, not finite differences). Scaling to a segment of lift h [m]
and duration β [rad] at camshaft speed ω [rad/s]::

    s = h·y,   v = h·y′·ω/β,   a = h·y″·(ω/β)²,   j = h·y‴·(ω/β)³

Laws (Norton, *Design of Machinery*, ch. 8; Norton, *Cam Design and Manufacturing
Handbook*, ch. 3):

``cycloidal``
    y = u − sin(2πu)/(2π).
``harmonic``
    y = (1 − cos πu)/2. Its acceleration does not vanish at u = 0 and 1, so it jumps when
    joined to a dwell (infinite jerk there).
``modified-trapezoid``
    Constant acceleration ramped by quarter sines over eighths of the interval:
    sine ramp 1/8, constant 1/4, sine 1/4 (through zero), constant 1/4, sine ramp 1/8.
``modified-sine``
    Sine ramp 1/8, a slower sine over 3/4, sine ramp 1/8 (Norton's 1/8–3/4–1/8).
``poly345``
    y = 10u³ − 15u⁴ + 6u⁵.
``poly4567``
    y = 35u⁴ − 84u⁵ + 70u⁶ − 20u⁷.

The two piecewise laws are built here from the shape of their acceleration
(:class:`_PiecewiseAcceleration`): each piece is A·cos(k(u − c)) + B, integrated in
closed form with continuity of y and y′ and scaled so that y(1) = 1. No published
decimal constants enter them, so their peaks are a check against Norton's tables.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from camsim.cam.description import LAWS

__all__ = ["LAWS", "NORTON_PEAKS", "evaluate_law", "rise", "rise_derivatives", "fall"]

_PI = math.pi

#: Norton's published peak factors of the normalised rise (|y′|max, |y″|max, |y‴|max):
#: Norton, *Design of Machinery*, table 8-2 (Cv, Ca) and *Cam Design and Manufacturing
#: Handbook*, ch. 3 (Cj). For ``harmonic`` the jerk is infinite at the ends when joined
#: to a dwell; the value given is the finite interior peak π³/2.
NORTON_PEAKS: dict[str, tuple[float, float, float]] = {
    "cycloidal": (2.0, 6.2832, 39.478),
    "harmonic": (1.5708, 4.9348, 15.503),
    "modified-trapezoid": (2.0, 4.8881, 61.426),
    "modified-sine": (1.7596, 5.5280, 69.466),
    "poly345": (1.875, 5.7735, 60.0),
    "poly4567": (2.1875, 7.5107, 52.5),
}


@dataclass(frozen=True)
class _Piece:
    """One piece of a piecewise acceleration: y″ = a·cos(k·(u − c)) + b on [u0, u1]."""

    u0: float
    u1: float
    a: float
    k: float
    c: float
    b: float


class _PiecewiseAcceleration:
    """A rise law defined by a piecewise sine/constant acceleration shape.

    Integrates y″ = a·cos(k(u − c)) + b piece by piece with y(0) = y′(0) = 0 and
    continuity of y, y′ at each join, then scales so that y(1) = 1. Pieces with k = 0
    must have a = 0 (pure constant acceleration b).
    """

    def __init__(self, pieces: list[_Piece]):
        self.pieces = pieces
        # Unscaled integration constants: y′ = (a/k)·sin(k(u−c)) + b·u + d1,
        # y = −(a/k²)·cos(k(u−c)) + b·u²/2 + d1·u + d0.
        consts = []
        y_prev, v_prev = 0.0, 0.0
        for p in pieces:
            s_part, c_part = self._trig(p, p.u0)
            v_no_d = (p.a / p.k * s_part if p.k else 0.0) + p.b * p.u0
            d1 = v_prev - v_no_d
            y_no_d = (-p.a / p.k**2 * c_part if p.k else 0.0) + 0.5 * p.b * p.u0**2 + d1 * p.u0
            d0 = y_prev - y_no_d
            consts.append((d1, d0))
            y_prev, v_prev = self._eval_piece(p, d1, d0, np.array([p.u1]), 1.0)[:2]
            y_prev, v_prev = float(y_prev[0]), float(v_prev[0])
        self.consts = consts
        self.scale = 1.0 / y_prev

    @staticmethod
    def _trig(p: _Piece, u):
        arg = p.k * (np.asarray(u, dtype=float) - p.c)
        return np.sin(arg), np.cos(arg)

    @classmethod
    def _eval_piece(cls, p: _Piece, d1: float, d0: float, u: np.ndarray, scale: float):
        s_part, c_part = cls._trig(p, u)
        if p.k:
            y = -p.a / p.k**2 * c_part + 0.5 * p.b * u**2 + d1 * u + d0
            y1 = p.a / p.k * s_part + p.b * u + d1
            y2 = p.a * c_part + p.b
            y3 = -p.a * p.k * s_part
        else:
            y = 0.5 * p.b * u**2 + d1 * u + d0
            y1 = p.b * u + d1
            y2 = np.full_like(u, p.b)
            y3 = np.zeros_like(u)
        return y * scale, y1 * scale, y2 * scale, y3 * scale

    def derivatives(self, u: np.ndarray, order: int) -> np.ndarray:
        """y and its derivatives up to ``order`` (rows), closed form on each piece."""
        out = np.zeros((order + 1, u.size))
        low = self(u)
        for n in range(min(order, 3) + 1):
            out[n] = low[n]
        for i, (p, _) in enumerate(zip(self.pieces, self.consts)):
            if order < 4 or not p.k:
                continue
            mask = self._mask(i, u)
            arg = p.k * (u[mask] - p.c)
            for n in range(4, order + 1):
                # d^(n-2)/du^(n-2) of a·cos(k(u−c)) = a·k^(n−2)·cos(k(u−c) + (n−2)π/2)
                out[n, mask] = self.scale * p.a * p.k ** (n - 2) * np.cos(arg + (n - 2) * _PI / 2)
        return out

    def _mask(self, i: int, u: np.ndarray) -> np.ndarray:
        p = self.pieces[i]
        if i == len(self.pieces) - 1:
            return u >= p.u0
        return (u >= p.u0) & (u < p.u1) if i else u < p.u1

    def __call__(self, u: np.ndarray):
        out = [np.empty_like(u) for _ in range(4)]
        for i, (p, (d1, d0)) in enumerate(zip(self.pieces, self.consts)):
            # Half-open pieces [u0, u1); the last one is closed at 1.
            if i == len(self.pieces) - 1:
                mask = u >= p.u0
            else:
                mask = (u >= p.u0) & (u < p.u1) if i else u < p.u1
            if not np.any(mask):
                continue
            vals = self._eval_piece(p, d1, d0, u[mask], self.scale)
            for o, v in zip(out, vals):
                o[mask] = v
        return tuple(out)


# Modified trapezoid: quarter-sine ramps of period 1/2 (k = 4π), flats at ±1.
_MOD_TRAP = _PiecewiseAcceleration(
    [
        _Piece(0.0, 1 / 8, 1.0, 4 * _PI, 1 / 8, 0.0),  # sin(4πu) rising to 1
        _Piece(1 / 8, 3 / 8, 0.0, 0.0, 0.0, 1.0),  # constant +1
        _Piece(3 / 8, 5 / 8, 1.0, 4 * _PI, 3 / 8, 0.0),  # cos from +1 through 0 to −1
        _Piece(5 / 8, 7 / 8, 0.0, 0.0, 0.0, -1.0),  # constant −1
        _Piece(7 / 8, 1.0, -1.0, 4 * _PI, 7 / 8, 0.0),  # −cos from −1 back to 0
    ]
)

# Modified sine: fast quarter sines (k = 4π) at the ends, a slow half-cosine (k = 4π/3)
# over the middle 3/4.
_MOD_SINE = _PiecewiseAcceleration(
    [
        _Piece(0.0, 1 / 8, 1.0, 4 * _PI, 1 / 8, 0.0),
        _Piece(1 / 8, 7 / 8, 1.0, 4 * _PI / 3, 1 / 8, 0.0),
        _Piece(7 / 8, 1.0, -1.0, 4 * _PI, 7 / 8, 0.0),
    ]
)


def _cycloidal(u):
    w = 2 * _PI
    s, c = np.sin(w * u), np.cos(w * u)
    return u - s / w, 1.0 - c, w * s, w * w * c


def _harmonic(u):
    s, c = np.sin(_PI * u), np.cos(_PI * u)
    return 0.5 * (1.0 - c), 0.5 * _PI * s, 0.5 * _PI**2 * c, -0.5 * _PI**3 * s


def _polynomial(coeffs: dict[int, float]):
    """A polynomial law Σ c_n·u^n with its exact derivatives."""

    powers = sorted(coeffs)
    derivs = []
    for order in range(4):
        terms = []
        for n in powers:
            if n - order < 0:
                continue
            factor = math.prod(range(n - order + 1, n + 1))
            terms.append((n - order, coeffs[n] * factor))
        derivs.append(terms)

    def law(u):
        out = []
        for terms in derivs:
            acc = np.zeros_like(u)
            for n, c in terms:
                acc = acc + c * u**n
            out.append(acc)
        return tuple(out)

    return law


_POLY_COEFFS = {"poly345": {3: 10.0, 4: -15.0, 5: 6.0}, "poly4567": {4: 35.0, 5: -84.0, 6: 70.0, 7: -20.0}}

_FUNCTIONS = {
    "cycloidal": _cycloidal,
    "harmonic": _harmonic,
    "modified-trapezoid": _MOD_TRAP,
    "modified-sine": _MOD_SINE,
    "poly345": _polynomial(_POLY_COEFFS["poly345"]),
    "poly4567": _polynomial(_POLY_COEFFS["poly4567"]),
}
assert set(_FUNCTIONS) == set(LAWS)


#: Where inside a law (u in (0, 1)) a derivative of y jumps: the joins of the pieces of the
#: piecewise laws (their jerk jumps there). The engine stops a stretch at each, as at a
#: segment join, so that no integration step carries the cam input across a kink (issue 34:
#: across them, the step's polynomial input depended on the grid by ~1e-9 of a trace).
INNER_BREAKS: dict[str, tuple[float, ...]] = {
    "modified-trapezoid": tuple(p.u0 for p in _MOD_TRAP.pieces[1:]),
    "modified-sine": tuple(p.u0 for p in _MOD_SINE.pieces[1:]),
}


def rise(name: str, u) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Normalised rise y(u) and its derivatives with respect to u.

    Parameters
    ----------
    name : str
        One of :data:`camsim.machine.description.LAWS`.
    u : array_like
        Normalised angle [-], expected in [0, 1] (values outside are clipped).

    Returns
    -------
    y, y1, y2, y3 : ndarray
        y [-] and y′, y″, y‴ [-] (derivatives with respect to u), shaped like ``u``.

    Raises
    ------
    ValueError
        For an unknown law name.
    """
    try:
        func = _FUNCTIONS[name]
    except KeyError:
        raise ValueError(f"unknown cam law {name!r}; expected one of {', '.join(LAWS)}") from None
    u_arr = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    shape = u_arr.shape
    values = func(u_arr.reshape(-1))
    return tuple(np.asarray(v, dtype=float).reshape(shape) for v in values)  # type: ignore[return-value]


def rise_derivatives(name: str, u, order: int) -> np.ndarray:
    """Normalised rise y(u) and its derivatives 0…``order`` with respect to u, in closed form.

    Parameters
    ----------
    name : str
        One of :data:`camsim.machine.description.LAWS`.
    u : array_like
        Normalised angle [-] (clipped to [0, 1]), 1-D.
    order : int
        Highest derivative wanted (≥ 0).

    Returns
    -------
    ndarray
        Shape (order + 1, len(u)): row n is dⁿy/duⁿ [-].
    """
    u_arr = np.clip(np.atleast_1d(np.asarray(u, dtype=float)), 0.0, 1.0).reshape(-1)
    if name not in _FUNCTIONS:
        raise ValueError(f"unknown cam law {name!r}; expected one of {', '.join(LAWS)}")
    if name in ("modified-trapezoid", "modified-sine"):
        return _FUNCTIONS[name].derivatives(u_arr, order)
    out = np.zeros((order + 1, u_arr.size))
    low = _FUNCTIONS[name](u_arr)
    for n in range(min(order, 3) + 1):
        out[n] = low[n]
    if order < 4:
        return out
    if name == "cycloidal":  # y″ = w·sin(wu), w = 2π
        w = 2 * _PI
        for n in range(4, order + 1):
            out[n] = w ** (n - 1) * np.sin(w * u_arr + (n - 2) * _PI / 2)
    elif name == "harmonic":  # y = (1 − cos πu)/2
        for n in range(4, order + 1):
            out[n] = -0.5 * _PI**n * np.cos(_PI * u_arr + n * _PI / 2)
    else:  # the two polynomials
        coeffs = _POLY_COEFFS[name]
        for n in range(4, order + 1):
            acc = np.zeros_like(u_arr)
            for p, c in coeffs.items():
                if p >= n:
                    acc = acc + c * math.prod(range(p - n + 1, p + 1)) * u_arr ** (p - n)
            out[n] = acc
    return out


#: Alias of :func:`rise` (the name the rest of camsim uses).
evaluate_law = rise


def fall(name: str, u) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Normalised fall 1 − y(u) and its derivatives (see :func:`rise`)."""
    y, y1, y2, y3 = rise(name, u)
    return 1.0 - y, -y1, -y2, -y3

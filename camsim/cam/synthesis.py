"""Motion synthesis: segments written from conditions (spec §2, "Motion synthesis").

Three laws are not fixed shapes but are built from the segment's conditions:

``polynomial``
    The unique polynomial y(u), u = (θ − Θ)/β ∈ [0, 1], that satisfies the segment's
    conditions: y(0) = 0 and y(1) = 1 (the lift), the derivatives 1…``continuity`` at both
    ends (default 3) and any interior ``points``. Its degree is the number of conditions
    − 1. It is written in the Legendre basis on x = 2u − 1 (orthogonal on the segment, so
    the condition matrix stays well conditioned where the monomial Vandermonde matrix does
    not) and evaluated by Clenshaw's recurrence; derivatives of any order are the
    Legendre series' own (``numpy.polynomial.legendre.legder``), exact to rounding.
``constant-velocity``
    y = u: the lift grows linearly with cam angle (v = lift·ω/β).
``spline``
    An interpolating B-spline of odd ``degree`` (default 5) through the ``points`` and both
    ends, knots at the points, with the derivatives 1…(degree − 1)/2 fixed at both ends
    (``scipy.interpolate.make_interp_spline`` with ``bc_type``).

**End conditions and their defaults.** An end's derivative of order k is either given
(``start``/``end``: v, a, j, d4…d6 in roller-side units per time at ``cam.speed``) or
defaults to the neighbouring segment's value at the join: zero next to a dwell, the law's
own value next to a standard law or a constant-velocity segment. Where two synthesised
segments meet and both leave order k to default, neither value is known in advance: the
whole program is solved as one linear system whose unknowns are the coefficients of every
polynomial and the defaulted end values of every spline. Each defaulted pair gives one
equation (the two derivatives are equal) where each segment counted one condition, so the
join also takes the next orders as continuous (orders K+1…K+m for m defaulted pairs, K the
highest order either side lists). That is the unique choice that minimises the integral of
the squared (K+1)-th derivative across the join — the two segments join as one spline —
and keeps the system square.

Errors (:class:`SynthesisError`, naming the segment): a singular set of conditions (two
conditions at the same place, a point on an end), a spline given an end derivative above
(degree − 1)/2. A polynomial whose lift leaves the range of its end values by more than its
own lift is a warning (the wild overshoot of a high degree).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.polynomial import legendre as _leg

from camsim.cam.laws import rise_derivatives
from camsim.cam.description import Cam, Segment

__all__ = ["SynthesisError", "SegmentShape", "build_shapes", "DEFAULT_CONTINUITY", "DEFAULT_SPLINE_DEGREE"]

#: ``continuity`` of a polynomial segment when not given (the 4-5-6-7 polynomial between dwells).
DEFAULT_CONTINUITY = 3
#: ``degree`` of a spline segment when not given.
DEFAULT_SPLINE_DEGREE = 5
#: Reciprocal condition number (after row equilibration) below which the conditions are singular.
_RCOND = 1e-12


class SynthesisError(ValueError):
    """Conditions of a synthesised segment that cannot be met.

    Attributes
    ----------
    segment : int
        0-based index of the segment (the loader reports ``cam.segments[i]``).
    key : str
        The key inside the segment the message is about (``""``: the segment itself).
    """

    def __init__(self, segment: int, message: str, key: str = ""):
        super().__init__(f"segment {segment + 1}: {message}")
        self.segment = segment
        self.key = key
        self.message = message


@dataclass
class SegmentShape:
    """The normalised shape y(u) of one segment and its derivatives of any order.

    ``lift = h0 + h·y(u)`` with h the signed lift; ``evaluate(u, order)`` returns the
    array (order + 1, len(u)) of dⁿy/duⁿ.
    """

    kind: str  # "dwell", "law", "polynomial", "constant-velocity", "spline"
    law: str | None = None
    legendre: np.ndarray | None = None
    spline: object | None = None
    warnings: list[str] = field(default_factory=list)

    def evaluate(self, u: np.ndarray, order: int) -> np.ndarray:
        u = np.clip(np.asarray(u, dtype=float).reshape(-1), 0.0, 1.0)
        out = np.zeros((order + 1, u.size))
        if self.kind == "dwell":
            return out
        if self.kind == "law":
            return rise_derivatives(str(self.law), u, order)
        if self.kind == "constant-velocity":
            out[0] = u
            if order >= 1:
                out[1] = 1.0
            return out
        if self.kind == "polynomial":
            x = 2.0 * u - 1.0
            c = self.legendre
            for n in range(order + 1):
                if c.size == 0:
                    break
                out[n] = (2.0**n) * _leg.legval(x, c)
                c = _leg.legder(c) if c.size > 1 else np.zeros(0)
            return out
        spl = self.spline
        for n in range(order + 1):
            if n > spl.k:  # type: ignore[attr-defined]
                break
            out[n] = spl(u, nu=n)  # type: ignore[operator]
        return out


# ------------------------------------------------------------------------ the linear system
def _orders(seg: Segment, side: str) -> dict[int, float | None]:
    """Derivative orders an end lists: k → given time-derivative value [m/s^k] or None (default)."""
    given = dict(seg.start if side == "start" else seg.end)
    if seg.law == "spline":
        top = ((seg.degree or DEFAULT_SPLINE_DEGREE) - 1) // 2
    else:
        top = DEFAULT_CONTINUITY if seg.continuity is None else seg.continuity
    out: dict[int, float | None] = {k: None for k in range(1, top + 1)}
    out.update(given)
    return dict(sorted(out.items()))


class _Flex:
    """A segment whose shape is unknown until the system is solved (polynomial or spline)."""

    def __init__(self, index: int, seg: Segment, h0: float, h: float, omega: float):
        self.index, self.seg, self.h0, self.h, self.beta = index, seg, h0, h, seg.duration
        self.omega = omega
        self.start = _orders(seg, "start")
        self.end = _orders(seg, "end")
        self.offset = 0  # first unknown in the global vector

    def to_y(self, order: int, value: float) -> float:
        """A time derivative [m/s^k] at ``cam.speed`` → dᵏy/duᵏ of this segment."""
        return value * (self.beta / self.omega) ** order / self.h

    def theta_scale(self, order: int) -> float:
        """dᵏlift/dθᵏ per unit dᵏy/duᵏ."""
        return self.h / self.beta**order


class _Poly(_Flex):
    def __init__(self, index, seg, h0, h, omega):
        super().__init__(index, seg, h0, h, omega)
        self.n = 2 + len(self.start) + len(self.end)
        for p in seg.points:
            self.n += (p.s is not None) + len(p.derivatives)

    def row(self, order: int, u: float) -> tuple[np.ndarray, float]:
        x = np.array([2.0 * u - 1.0])
        out = np.empty(self.n)
        for j in range(self.n):
            e = np.zeros(j + 1)
            e[j] = 1.0
            c = _leg.legder(e, order) if order else e
            out[j] = (2.0**order) * float(_leg.legval(x, c)[0]) if c.size else 0.0
        return out, 0.0

    def intrinsic(self) -> list[tuple[int, float, float]]:
        """(order, u, y-value) conditions that do not involve a neighbour."""
        out = [(0, 0.0, 0.0), (0, 1.0, 1.0)]
        for p in self.seg.points:
            u = p.at / self.beta
            if p.s is not None:
                out.append((0, u, (p.s - self.h0) / self.h))
            for k, v in p.derivatives:
                out.append((k, u, self.to_y(k, v)))
        for side, u in (("start", 0.0), ("end", 1.0)):
            for k, v in getattr(self, side).items():
                if v is not None:
                    out.append((k, u, self.to_y(k, v)))
        return out

    def shape(self, p: np.ndarray) -> SegmentShape:
        shape = SegmentShape("polynomial", legendre=np.array(p, dtype=float))
        u = np.linspace(0.0, 1.0, 2001)
        y = shape.evaluate(u, 0)[0]
        if y.min() < -1.0 or y.max() > 2.0:  # leaves [min, max] of its ends by more than its lift
            over = max(-y.min(), y.max() - 1.0) * abs(self.h)
            shape.warnings.append(
                f"segment {self.index + 1} polynomial overshoots its end lifts by {1e3 * over:.4g} mm at the roller "
                f"(degree {self.n - 1}): more than its own lift; check its conditions")
        return shape


class _Spline(_Flex):
    def __init__(self, index, seg, h0, h, omega):
        super().__init__(index, seg, h0, h, omega)
        from scipy.interpolate import make_interp_spline

        self.k = seg.degree or DEFAULT_SPLINE_DEGREE
        nbc = (self.k - 1) // 2
        for side in ("start", "end"):
            extra = [k for k in getattr(self, side) if k > nbc]
            if extra:
                raise SynthesisError(index, f"a spline of degree {self.k} fixes end derivatives up to order {nbc}; "
                                     f"{side} gives order {extra[0]} too (overdetermined)", side)
        self.x = np.array([0.0] + [p.at / self.beta for p in seg.points] + [1.0])
        self.y = np.array([0.0] + [(p.s - h0) / h for p in seg.points] + [1.0])
        self.unknowns = [(side, k) for side in ("start", "end") for k, v in getattr(self, side).items() if v is None]
        self.n = len(self.unknowns)
        self._make = make_interp_spline

        def build(y, values):
            bc = tuple([(k, values[(side, k)]) for k in range(1, nbc + 1)] or None for side in ("start", "end"))
            return make_interp_spline(self.x, y, k=self.k, bc_type=bc)

        known = {(side, k): (0.0 if v is None else self.to_y(k, v))
                 for side in ("start", "end") for k, v in getattr(self, side).items()}
        self.base = build(self.y, known)
        zero = {key: 0.0 for key in known}
        self.units = []
        for key in self.unknowns:
            unit = dict(zero)
            unit[key] = 1.0
            self.units.append(build(np.zeros_like(self.y), unit))

    def row(self, order: int, u: float) -> tuple[np.ndarray, float]:
        if order > self.k:
            return np.zeros(self.n), 0.0
        vec = np.array([float(s(u, nu=order)) for s in self.units])
        return vec, float(self.base(u, nu=order))

    def intrinsic(self) -> list[tuple[int, float, float]]:
        return []

    def shape(self, p: np.ndarray) -> SegmentShape:
        spline = self.base
        if self.n:
            from scipy.interpolate import BSpline

            c = self.base.c + sum(pi * s.c for pi, s in zip(p, self.units))
            spline = BSpline(self.base.t, c, self.k)
        return SegmentShape("spline", spline=spline)


def build_shapes(cam: Cam, omega: float) -> tuple[list[SegmentShape], list[str]]:
    """Every segment's normalised shape, the synthesised ones solved as one linear system.

    Parameters
    ----------
    cam : Cam
        A segment cam (SI).
    omega : float
        The speed [rad/s] at which the start/end/point derivatives are given (``cam.speed``).

    Returns
    -------
    shapes : list of SegmentShape
    warnings : list of str
        Polynomial overshoot warnings.

    Raises
    ------
    SynthesisError
        Conditions that are singular or overdetermined, naming the segment.
    """
    segs = cam.segments
    n_seg = len(segs)
    signed = [s.lift if s.motion == "rise" else -s.lift if s.motion == "fall" else 0.0 for s in segs]
    h0 = np.concatenate(([0.0], np.cumsum(signed)[:-1]))
    shapes: list[SegmentShape | None] = [None] * n_seg
    flex: dict[int, _Flex] = {}
    for i, seg in enumerate(segs):
        if seg.motion == "dwell":
            shapes[i] = SegmentShape("dwell")
        elif seg.law == "constant-velocity":
            shapes[i] = SegmentShape("constant-velocity")
        elif seg.law == "polynomial":
            flex[i] = _Poly(i, seg, float(h0[i]), signed[i], omega)
        elif seg.law == "spline":
            flex[i] = _Spline(i, seg, float(h0[i]), signed[i], omega)
        else:
            shapes[i] = SegmentShape("law", law=seg.law)
    if not flex:
        return shapes, []  # type: ignore[return-value]
    total = 0
    for f in flex.values():
        f.offset = total
        total += f.n
    rows: list[np.ndarray] = []
    rhs: list[float] = []
    owner: list[int] = []

    def add(entries: list[tuple[_Flex, int, float, float]], value: float, who: int) -> None:
        """Σ weight·y_f^(k)(u) = value over (flex, k, u, weight) entries."""
        row = np.zeros(total)
        b = value
        for f, k, u, w in entries:
            vec, const = f.row(k, u)
            row[f.offset:f.offset + f.n] += w * vec
            b -= w * const
        rows.append(row)
        rhs.append(b)
        owner.append(who)

    def fixed_value(j: int, k: int, u: float) -> float:
        """dᵏlift/dθᵏ of a non-synthesised segment j at u."""
        seg = segs[j]
        if seg.motion == "dwell":
            return 0.0
        y = shapes[j].evaluate(np.array([u]), k)[k, 0]  # type: ignore[union-attr]
        return signed[j] * y / seg.duration**k

    for i, f in flex.items():
        for order, u, value in f.intrinsic():
            add([(f, order, u, 1.0)], value, i)
    # Joins: between segment a (its end) and b = a + 1 (its start), cyclically.
    for a in range(n_seg):
        b = (a + 1) % n_seg
        fa, fb = flex.get(a), flex.get(b)
        if fa is None and fb is None:
            continue
        mutual = 0
        top = 0
        for f, side, u, other, ou in ((fa, "end", 1.0, b, 0.0), (fb, "start", 0.0, a, 1.0)):
            if f is None:
                continue
            top = max(top, max(getattr(f, side), default=0))
            of = flex.get(other)
            oside = "start" if side == "end" else "end"
            for k, v in getattr(f, side).items():
                if v is not None:
                    continue  # a given value: an intrinsic condition
                if of is None:
                    value = fixed_value(other, k, ou) / f.theta_scale(k)
                    add([(f, k, u, 1.0)], value, f.index)
                    continue
                ov = getattr(of, oside).get(k, "absent")
                if ov is not None and ov != "absent":
                    add([(f, k, u, 1.0)], f.to_y(k, ov), f.index)  # the neighbour's given value
                elif ov == "absent" or f is fa:
                    # equal derivatives at the join (once for a mutual default: written by a's side)
                    add([(f, k, u, f.theta_scale(k) * f.beta**k / abs(f.h)),
                         (of, k, ou, -of.theta_scale(k) * f.beta**k / abs(f.h))], 0.0, f.index)
                    if ov is None:
                        mutual += 1
        if mutual and fa is not None and fb is not None:
            top = max(top, max(fa.end, default=0), max(fb.start, default=0))
            for k in range(top + 1, top + mutual + 1):
                add([(fa, k, 1.0, fa.theta_scale(k) * fa.beta**k / abs(fa.h)),
                     (fb, k, 0.0, -fb.theta_scale(k) * fa.beta**k / abs(fa.h))], 0.0, a)
    A = np.array(rows)
    rhs_arr = np.array(rhs)
    if A.shape[0] != A.shape[1]:  # cannot happen by construction; a guard for the bookkeeping
        raise SynthesisError(min(flex), f"{A.shape[0]} conditions for {A.shape[1]} unknowns")
    scale = np.max(np.abs(A), axis=1)
    scale[scale == 0.0] = 1.0
    As = A / scale[:, None]
    bs = rhs_arr / scale
    u_, sv, vt = np.linalg.svd(As)
    if sv[-1] <= _RCOND * sv[0]:
        null = np.abs(vt[-1])
        bad = sorted({f.index for f in flex.values() if np.any(null[f.offset:f.offset + f.n] > 1e-3 * null.max())})
        which = bad[0] if bad else min(flex)
        names = ", ".join(str(i + 1) for i in bad)
        raise SynthesisError(which, "the conditions are singular (two conditions at the same place, or "
                             f"conditions that contradict each other){'' if len(bad) < 2 else f' (segments {names})'}")
    p = vt.T @ ((u_.T @ bs) / sv)
    warnings: list[str] = []
    for i, f in flex.items():
        shapes[i] = f.shape(p[f.offset:f.offset + f.n])
        warnings.extend(shapes[i].warnings)  # type: ignore[union-attr]
    return shapes, warnings  # type: ignore[return-value]

"""The cam program: follower displacement, velocity, acceleration and jerk against time.

:class:`CamProgram` turns a :class:`camsim.machine.description.Cam` into the prescribed motion s(t)
of the ``cam`` node on the model axis, with its exact time derivatives v, a, j:

* the camshaft turns at constant speed ω: cam angle θ(t) = θ0 + ω·t, one cycle being one
  revolution T = 2π/ω;
* a **segment table** lays its rows end to end from θ = 0: segment i spans
  [Θ_i, Θ_i + β_i] with Θ_i the sum of the earlier durations; with u = (θ − Θ_i)/β_i,
  the roller lift is h0_i + h_i·y(u) for a rise starting at height h0_i (h0_i − h_i·y(u)
  for a fall, h0_i for a dwell), the first segment starting at height 0;
* a **table** cam uses a periodic quintic spline of the measured lift
  (:mod:`camsim.cam.spline`);
* the model axis sees ``ratio`` × the roller lift:
  s = ratio·lift, v = ratio·(dlift/dθ)·ω, a = ratio·(d²lift/dθ²)·ω², j = ratio·(d³lift/dθ³)·ω³.

Jumps of s, v or a where two segments meet violate the fundamental law of cam design; they
are reported in :attr:`CamProgram.warnings` (computed from the law values on both sides of
each join, not from a list of "bad" laws). Derivatives jump at joins, so an integrator
should not step across one: :meth:`CamProgram.boundary_times` lists them.
"""

from __future__ import annotations

import math

import numpy as np

from camsim.cam.evaluation import SegmentEvaluator
from camsim.cam.laws import INNER_BREAKS, rise
from camsim.cam.description import SYNTHESIS_LAWS, Cam

__all__ = ["CamProgram"]

_TWO_PI = 2.0 * math.pi
_EPS = np.finfo(float).eps
#: The segment durations must add up to 2π within this [rad].
DURATION_TOLERANCE = 1e-6
#: Jumps smaller than this fraction of the cam's largest |s|, |v| or |a| are rounding.
_JUMP_TOLERANCE = 1e-9
#: Boundary times closer than this fraction of a period to a window end are dropped.
_BOUNDARY_TOLERANCE = 1e-12

_QUANTITIES = (("displacement", "m"), ("velocity", "m/s"), ("acceleration", "m/s^2"))


#: Shapes that are a function of their law's name alone (camsim.cam.synthesis.SegmentShape).
_NAMED_SHAPES = ("law", "constant-velocity", "dwell")
#: (kind, law, order, points) -> their values (read-only; see CamProgram._shape_values).
_SHAPE_VALUES: dict[tuple, np.ndarray] = {}
#: Law names already checked by evaluating them once (an unknown name raises, every time).
_KNOWN_LAWS: set[str] = set()


class CamProgram:
    """Prescribed motion of the ``cam`` node on the model axis.

    Parameters
    ----------
    cam : Cam or None
        The machine's cam (SI). None means no cam: s = v = a = j = 0 for all times, no
        segment boundaries.

    Attributes
    ----------
    speed : float
        Camshaft speed ω [rad/s]; 0 without a cam.
    period : float
        One revolution 2π/ω [s]; ``math.inf`` without a cam.
    start_angle : float
        θ0, the cam angle at t = 0 [rad].
    ratio : float
        Roller motion → model axis [-].
    kind : str
        ``"segments"``, ``"table"`` or ``"none"``.
    warnings : list of str
        Jumps of s, v or a at segment joins, and table columns that disagree with the
        spline. Warnings, not errors.

    Raises
    ------
    ValueError
        If the segment durations do not add up to 360° (within 1e-6 rad), a duration is
        not positive, a law is unknown, or the cam table is unusable.
    """

    def __init__(self, cam: Cam | None):
        self.cam = cam
        self.warnings: list[str] = []
        self._table = None  # a TableSpline for table cams
        if cam is None:
            self.kind = "none"
            self.speed = 0.0
            self.period = math.inf
            self.start_angle = 0.0
            self.ratio = 1.0
            self._starts = np.zeros(0)
            return
        self.speed = float(cam.speed)
        self.period = _TWO_PI / self.speed
        # the cam's angle at t = 0: the shaft's plus the cam's phase (issue 38; 0 for [cam])
        self.start_angle = float(cam.start_angle) + float(getattr(cam, "phase", 0.0))
        self.ratio = float(cam.ratio)
        if cam.table is not None:
            from camsim.cam.spline import TableSpline

            self.kind = "table"
            self._table = TableSpline(cam.table, self.speed)
            self._starts = np.zeros(0)
            self.warnings.extend(self._table.warnings)
            return
        if getattr(cam, "compensated", None) is not None:  # issue 27: a compensated cam
            self._init_compensated(cam)
            return
        self.kind = "segments"
        segments = cam.segments
        if not segments:
            raise ValueError("cam: neither segments nor a table given")
        betas = np.array([seg.duration for seg in segments], dtype=float)
        if np.any(betas <= 0):
            bad = ", ".join(str(i + 1) for i in np.flatnonzero(betas <= 0))
            raise ValueError(f"cam: segment duration must be positive (segment {bad})")
        total = float(betas.sum())
        if abs(total - _TWO_PI) > DURATION_TOLERANCE:
            raise ValueError(f"cam: segment durations add up to {math.degrees(total):.6g} deg, not 360 deg")
        laws: list[str | None] = []
        signed = np.zeros(len(segments))
        for i, seg in enumerate(segments):
            if seg.motion == "dwell":
                laws.append(None)
            elif seg.motion in ("rise", "fall"):
                if seg.law not in SYNTHESIS_LAWS and seg.law not in _KNOWN_LAWS:
                    rise(str(seg.law), 0.0)  # raises ValueError on an unknown law
                    _KNOWN_LAWS.add(seg.law)
                laws.append(seg.law)
                signed[i] = seg.lift if seg.motion == "rise" else -seg.lift
            else:
                raise ValueError(f"cam: segment {i + 1}: unknown motion {seg.motion!r}")
        self._betas = betas
        self._starts = np.concatenate(([0.0], np.cumsum(betas)[:-1]))
        self._signed = signed
        self._h0 = np.concatenate(([0.0], np.cumsum(signed)[:-1]))
        self._laws = laws
        self._breaks = _inner_break_angles(self._starts, betas, laws)
        # issue 27: every segment's shape; polynomial/spline ones solved together (synthesis.py)
        from camsim.cam.synthesis import build_shapes

        self._shapes, synthesis_warnings = build_shapes(cam, self.speed)
        self._custom = [i for i, law in enumerate(laws) if law in SYNTHESIS_LAWS]
        self._law_names = sorted({law for law in laws if law is not None and law not in SYNTHESIS_LAWS})
        codes = [-1 if law is None or law in SYNTHESIS_LAWS else self._law_names.index(law) for law in laws]
        self._codes = np.array(codes, dtype=int)
        self._evaluator = SegmentEvaluator(self._starts, betas, signed, self._h0, laws, self._shapes, self._custom)
        self.warnings.extend(synthesis_warnings)
        self.warnings.extend(self._join_warnings())

    def _init_compensated(self, cam: Cam) -> None:
        """A cam whose profile was computed by dynamic compensation (issue 27)."""
        comp = cam.compensated
        self._comp = comp
        self._written = CamProgram(comp.written)
        self.warnings.extend(self._written.warnings)
        w = self._written
        if comp.kind == "algebraic":
            # Same joins as the written program: the integrator must not step across them.
            self.kind = "segments"
            self._starts, self._betas = w._starts, w._betas
            self._breaks = w._breaks
        else:
            self.kind = "table"
            self._starts = np.zeros(0)
        self._laws = w._laws if comp.kind == "algebraic" else []
        self.warnings.extend(self._generic_join_warnings())

    def _generic_join_warnings(self) -> list[str]:
        """Jumps of lift, d/dθ, d²/dθ² at the written program's joins (compensated cam)."""
        w = self._written
        if w.kind != "segments":
            return []
        starts = w.boundary_angles()
        left = np.array(self.lift(starts, side="left")[:3])
        right = np.array(self.lift(starts, side="right")[:3])
        theta = np.linspace(0.0, _TWO_PI, 7201)
        scale = np.max(np.abs(np.array(self.lift(theta)[:3])), axis=1)
        out = []
        factors = (self.ratio, self.ratio * self.speed, self.ratio * self.speed**2)
        for q, (name, unit) in enumerate(_QUANTITIES):
            for k, th in enumerate(starts):
                jump = right[q, k] - left[q, k]
                if abs(jump) > 1e-6 * scale[q] and jump != 0.0:
                    out.append(f"compensated cam: {name} jumps by {jump * factors[q]:.3g} {unit} at "
                               f"{math.degrees(float(th)):g} deg")
        return out

    def _shape_values(self, i: int, u, order: int, keep: bool = False) -> np.ndarray:
        """Normalised y and derivatives 0…order of segment ``i`` at u (array (order+1, n)).
        ``keep``: a standard law's values (a function of its name alone) are kept per law and
        points, read-only (every new program of an optimiser's search checks its joins on
        the same few points)."""
        shape = self._shapes[i]
        u = np.atleast_1d(np.asarray(u, dtype=float))
        if not keep or shape.kind not in _NAMED_SHAPES:
            return shape.evaluate(u, order)
        key = (shape.kind, str(getattr(shape, "law", "")), order, u.tobytes())
        hit = _SHAPE_VALUES.get(key)
        if hit is None:
            hit = shape.evaluate(u, order)
            hit.setflags(write=False)
            if len(_SHAPE_VALUES) > 256:
                _SHAPE_VALUES.clear()
            _SHAPE_VALUES[key] = hit
        return hit

    def lift_derivatives(self, theta, order: int, side: str = "right") -> np.ndarray:
        """Roller lift and its derivatives 0…``order`` with respect to cam angle, exact.

        Parameters
        ----------
        theta : array_like
            Cam angle [rad] (wrapped), 1-D.
        order : int
            Highest derivative wanted.
        side : {"right", "left"}
            Limit at a segment boundary (see :meth:`lift`).

        Returns
        -------
        ndarray
            Shape (order + 1, len(theta)): dⁿlift/dθⁿ [m/radⁿ]. Segment cams only (the
            written program of a compensation); a table cam gives its spline's own
            derivatives (zero above degree 5).
        """
        th = np.atleast_1d(np.asarray(theta, dtype=float)).reshape(-1)
        if self.kind == "none":
            return np.zeros((order + 1, th.size))
        if self._table is not None:
            sp = self._table._spline
            phi = self._table.phase(th)
            return np.array([sp(phi, nu=n) if n <= sp.k else np.zeros_like(phi) for n in range(order + 1)])
        if getattr(self, "_comp", None) is not None:
            return self._comp.lift_derivatives(self._written, th, order, side)
        idx, u = self._locate(th, side)
        out = np.zeros((order + 1, th.size))
        for i in np.unique(idx):
            mask = idx == i
            y = self._shape_values(int(i), u[mask], order)
            h, beta = self._signed[i], self._betas[i]
            for n in range(order + 1):
                out[n, mask] = h * y[n] / beta**n
            out[0, mask] += self._h0[i]
        return out

    def _locate(self, th: np.ndarray, side: str) -> tuple[np.ndarray, np.ndarray]:
        """Segment index and normalised angle u of each cam angle (boundary rule of :meth:`lift`)."""
        phi = np.mod(th, _TWO_PI)
        tol = 64.0 * _EPS * np.maximum(np.abs(th), _TWO_PI)
        if side == "left":
            phi = np.where(phi < tol, phi + _TWO_PI, phi)
            idx = np.searchsorted(self._starts, phi - tol, side="left") - 1
        else:
            phi = np.where(phi > _TWO_PI - tol, phi - _TWO_PI, phi)
            idx = np.searchsorted(self._starts, phi + tol, side="right") - 1
        np.clip(idx, 0, len(self._starts) - 1, out=idx)
        u = np.clip((phi - self._starts[idx]) / self._betas[idx], 0.0, 1.0)
        return idx, u

    # ------------------------------------------------------------------ evaluation
    def angle(self, t) -> np.ndarray:
        """Cam angle θ = θ0 + ω·t [rad], not wrapped, at times ``t`` [s]."""
        t_arr = np.asarray(t, dtype=float)
        return self.start_angle + self.speed * t_arr

    def lift(self, theta, side: str = "right") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Roller lift and its derivatives with respect to cam angle.

        Parameters
        ----------
        theta : array_like
            Cam angle [rad], any value (wrapped modulo 2π). At a segment boundary (to
            within rounding of θ) the segment that starts there is used.
        side : {"right", "left"}
            ``"left"`` takes the limit from below at a segment boundary (the segment
            that ends there, at u = 1): the integrator needs it for a step that ends at
            a join where the acceleration or jerk jumps.

        Returns
        -------
        lift, d1, d2, d3 : ndarray
            Roller lift [m], d lift/dθ [m/rad], d²/dθ² [m/rad²], d³/dθ³ [m/rad³]
            (before ``ratio``), shaped like ``theta``.
        """
        theta = np.asarray(theta, dtype=float)
        if self.kind == "none":
            z = np.zeros_like(theta)
            return z, z.copy(), z.copy(), z.copy()
        if self._table is not None:
            return self._table(theta)
        if getattr(self, "_comp", None) is not None:  # issue 27
            d = self._comp.lift_derivatives(self._written, theta.reshape(-1), 3, side)
            return tuple(row.reshape(theta.shape) for row in d)  # type: ignore[return-value]
        out = self._evaluator.lift(theta.reshape(-1), side)
        return tuple(o.reshape(theta.shape) for o in out)  # type: ignore[return-value]

    def lift_at(self, theta: float, side: str = "right") -> tuple[float, float, float, float]:
        """:meth:`lift` at one angle, in floats: a few microseconds for a segment program (equal
        to :meth:`lift` to rounding, :mod:`camsim.cam.evaluation`), the array path otherwise."""
        evaluator = getattr(self, "_evaluator", None)
        if evaluator is not None and getattr(self, "_comp", None) is None:
            return evaluator.lift_at(float(theta), side)
        return tuple(float(v[0]) for v in self.lift(np.array([float(theta)]), side=side))  # type: ignore[return-value]

    def svaj(self, t, side: str = "right") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Displacement, velocity, acceleration and jerk of the cam on the model axis.

        Parameters
        ----------
        t : array_like
            Times [s] (θ = θ0 + ω·t).
        side : {"right", "left"}
            Which limit to take at a segment boundary (see :meth:`lift`).

        Returns
        -------
        s, v, a, j : ndarray
            [m], [m/s], [m/s^2], [m/s^3], shaped like ``t``; zeros without a cam.
        """
        lift, d1, d2, d3 = self.lift(self.angle(t), side=side)
        w, r = self.speed, self.ratio
        return r * lift, (r * w) * d1, (r * w * w) * d2, (r * w**3) * d3

    def channels(self, t, side: str = "right") -> np.ndarray:
        """The cam input of the engine at times ``t``: [s, ṡ, s̈, s⃛] per time, (N, 4)
        (:meth:`svaj` stacked; the engine reads input channels, not cams)."""
        t = np.asarray(t, dtype=float).reshape(-1)
        if self.kind == "segments" and getattr(self, "_comp", None) is None:
            d = self._evaluator.lift(self.start_angle + self.speed * t, side)
            w, r = self.speed, self.ratio
            d[0] *= r
            d[1] *= r * w
            d[2] *= r * w * w
            d[3] *= r * w**3
            return d.T
        return np.stack(self.svaj(t, side=side), axis=-1)

    def channels_at(self, t: float, side: str = "right") -> np.ndarray:
        """:meth:`channels` at one instant t [s]: (4,) (equal to it to rounding)."""
        if self.kind == "none":
            return np.zeros(4)
        lift, d1, d2, d3 = self.lift_at(self.start_angle + self.speed * float(t), side)
        w, r = self.speed, self.ratio
        return np.array([r * lift, (r * w) * d1, (r * w * w) * d2, (r * w**3) * d3])

    def boundary_times(self, t_start: float, t_end: float) -> np.ndarray:
        """Times in the open interval (t_start, t_end) where a segment boundary passes.

        A boundary is θ = Θ_i + 2πk (Θ_i the start of segment i, including Θ_0 = 0, the
        join of the last segment to the first). Times within 1e-12·T of either end are
        left out. Empty for a table cam (smooth everywhere) and without a cam.

        Parameters
        ----------
        t_start, t_end : float
            The window [s].

        Returns
        -------
        ndarray
            Sorted times [s].
        """
        if self.kind != "segments" or not t_end > t_start:
            return np.zeros(0)
        w, th0 = self.speed, self.start_angle
        lo = th0 + w * t_start
        hi = th0 + w * t_end
        k = np.arange(math.floor(lo / _TWO_PI) - 1, math.ceil(hi / _TWO_PI) + 2)
        theta = (self._starts[None, :] + _TWO_PI * k[:, None]).reshape(-1)
        times = (theta - th0) / w
        tol = _BOUNDARY_TOLERANCE * self.period
        keep = (times > t_start + tol) & (times < t_end - tol)
        return np.unique(times[keep])

    def break_times(self, t_start: float, t_end: float) -> np.ndarray:
        """:meth:`boundary_times` and the times where a law's derivative jumps inside its
        segment (the piece joins of the modified trapezoid and sine, :data:`INNER_BREAKS`):
        every time in (t_start, t_end) across which the cam motion is not smooth. The
        engine stops a stretch at each (no step carries the input across a kink)."""
        joins = self.boundary_times(t_start, t_end)
        breaks = getattr(self, "_breaks", np.zeros(0))
        if not breaks.size or not t_end > t_start:
            return joins
        w, th0 = self.speed, self.start_angle
        lo, hi = th0 + w * t_start, th0 + w * t_end
        k = np.arange(math.floor(lo / _TWO_PI) - 1, math.ceil(hi / _TWO_PI) + 2)
        times = ((breaks[None, :] + _TWO_PI * k[:, None]).reshape(-1) - th0) / w
        tol = _BOUNDARY_TOLERANCE * self.period
        times = times[(times > t_start + tol) & (times < t_end - tol)]
        return np.unique(np.concatenate([joins, times]))

    # ------------------------------------------------------------------ reporting
    def boundary_angles(self) -> np.ndarray:
        """Cam angles [rad] in [0, 2π) where segments start (empty for a table or no cam)."""
        return self._starts.copy()

    def _describe(self, i: int) -> str:
        law = self._laws[i]
        seg = self.cam.segments[i]  # type: ignore[union-attr]
        return f"segment {i + 1} {seg.motion}" if law is None else f"segment {i + 1} {law} {seg.motion}"

    def _segment_values(self, i: int, u: float) -> np.ndarray:
        """Model-axis s [m], v [m/s], a [m/s^2] of segment ``i`` at normalised angle u."""
        beta, h, h0 = self._betas[i], self._signed[i], self._h0[i]
        law = self._laws[i]
        if law is None:
            y = (0.0, 0.0, 0.0)
        else:
            y = tuple(float(v) for v in self._shape_values(i, u, 2, keep=True)[:, 0])
        k = self.speed / beta
        return self.ratio * np.array([h0 + h * y[0], h * y[1] * k, h * y[2] * k * k])

    def _join_warnings(self) -> list[str]:
        n = len(self._laws)
        # Scale of s, v, a for the jump threshold: sampled peaks are plenty for a relative
        # tolerance of 1e-9 (the refined peaks of segment_peaks need scipy.optimize, which
        # would cost every run a tenth of a second of imports).
        u = np.linspace(0.0, 1.0, 257)
        speed_peak = accel_peak = 0.0
        for i, law in enumerate(self._laws):
            if law is None:
                continue
            k = self.speed / self._betas[i]
            y = self._shape_values(i, u, 2, keep=True)
            speed_peak = max(speed_peak, abs(self.ratio * self._signed[i]) * k * float(np.max(np.abs(y[1]))))
            accel_peak = max(accel_peak, abs(self.ratio * self._signed[i]) * k * k * float(np.max(np.abs(y[2]))))
        scale = np.array(
            [
                max(abs(self.ratio) * float(np.max(np.abs(np.append(self._h0, self._h0 + self._signed)))), 0.0),
                speed_peak,
                accel_peak,
            ]
        )
        out = []
        for i in range(n):
            nxt = (i + 1) % n
            jumps = self._segment_values(nxt, 0.0) - self._segment_values(i, 1.0)
            where = math.degrees(float(self._starts[nxt]))
            for q, (name, unit) in enumerate(_QUANTITIES):
                if abs(jumps[q]) > _JUMP_TOLERANCE * scale[q] and jumps[q] != 0.0:
                    out.append(
                        f"{name} jumps by {jumps[q]:.3g} {unit} at {where:g} deg "
                        f"({self._describe(i)} -> {self._describe(nxt)})"
                    )
        return out

    def segment_peaks(self) -> list[dict]:
        """Per segment: lift and the peaks of |v|, |a|, |j| on the model axis, with angles
        (:func:`camsim.cam.peaks.segment_peaks`)."""
        from camsim.cam.peaks import segment_peaks

        return segment_peaks(self)


def _inner_break_angles(starts: np.ndarray, betas: np.ndarray, laws) -> np.ndarray:
    """Cam angles [rad] inside the segments where a law's derivative jumps (INNER_BREAKS)."""
    out = [start + u * beta for start, beta, law in zip(starts, betas, laws) for u in INNER_BREAKS.get(law, ())]
    return np.array(sorted(out), dtype=float)

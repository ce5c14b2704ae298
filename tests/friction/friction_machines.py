"""Machines with friction pairs (spec §10) as TOML text, and the references they are checked
against, written independently of camsim: closed forms of the piecewise linear motions,
event-driven closed-form solutions (roots by brentq) and scipy's DOP853 on the friction law
written out here (the Stribeck phase).

Sign conventions (spec §1, §10): ``between = [lower, upper]``, d = x_upper − x_lower; the
friction force f is tension-positive and acts −f on the upper node; sliding it is
f = sign(ḋ)·[F_C + (F_B − F_C)·e^(−|ḋ|/v_S)] + c_v·ḋ.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

G = 9.80665  # [m/s²], standard gravity (``gravity = true``)


def _opt(key: str, value, unit: str) -> str:
    return f'{key} = "{value!r} {unit}"' if value is not None else ""


def friction_keys(fc: float, fb: float | None = None, vs: float | None = None, cv: float | None = None) -> str:
    """The keys of a friction pair: F_C, F_B, v_S, c_v (None: not given)."""
    return "\n".join(k for k in (_opt("coulomb_force", fc, "N"), _opt("breakaway_force", fb, "N"),
                                 _opt("stribeck_velocity", vs, "m/s"), _opt("viscous", cv, "N*s/m")) if k)


# --------------------------------------------------------------------------- machines
def block(m: float = 2.0, v0: float = 1.5, fc: float = 5.0, fb: float | None = None, vs: float | None = None,
          cv: float | None = None, duration: str = "1 s", rate: str = "1 kHz") -> str:
    """A block of mass m leaving x = 0 at v0 on a slide (friction to ground), nothing else."""
    return f"""
schema = 1
[machine]
name = "a block on a slide"
[[mass]]
name = "block"
mass = "{m!r} kg"
[[element]]
name = "slide"
type = "friction"
between = ["ground", "block"]
{friction_keys(fc, fb, vs, cv)}
[initial.block]
displacement = "0 m"
velocity = "{v0!r} m/s"
[simulation]
duration = "{duration}"
sample_rate = "{rate}"
"""


def spring_mass(m: float = 1.0, k: float = 1e4, fc: float = 10.0, fb: float | None = None, vs: float | None = None,
                cv: float | None = None, x0: float = 10.5e-3, v0: float = 0.0, duration: str = "0.3 s",
                rate: str = "10 kHz") -> str:
    """A mass m on a spring k to ground, on a slide (friction to ground), released from x0."""
    return f"""
schema = 1
[machine]
name = "a spring-mass on a slide"
[[mass]]
name = "m"
mass = "{m!r} kg"
[[element]]
name = "spring"
type = "spring"
between = ["ground", "m"]
stiffness = "{k!r} N/m"
[[element]]
name = "slide"
type = "friction"
between = ["ground", "m"]
{friction_keys(fc, fb, vs, cv)}
[initial.m]
displacement = "{x0!r} m"
velocity = "{v0!r} m/s"
[simulation]
duration = "{duration}"
sample_rate = "{rate}"
"""


def belt(m: float = 1.0, k: float = 1e4, fc: float = 10.0, fb: float = 15.0, vs: float | None = None,
         cv: float | None = None, V: float = 0.05, rpm: float = 60.0, duration: str = "0.8 s",
         rate: str = "10 kHz", x0: float | None = None, v0: float | None = None, warmup: int = 0) -> str:
    """The stick–slip oscillator: a mass on a spring k to ground, on a belt (the cam node
    moving at V over a 300° constant-velocity rise, then a polynomial fall back). With
    ``duration`` shorter than the rise the run sees the belt at V only."""
    rise = 300.0
    lift = V * (60.0 / rpm) * rise / 360.0
    initial = ""
    if x0 is not None:
        initial = f'[initial.m]\ndisplacement = "{x0!r} m"\nvelocity = "{v0 if v0 is not None else 0.0!r} m/s"\n'
    return f"""
schema = 1
[machine]
name = "stick-slip on a belt"
[cam]
speed = "{rpm!r} rpm"
segments = [
  {{ motion = "rise", law = "constant-velocity", duration = "{rise!r} deg", velocity = "{V!r} m/s" }},
  {{ motion = "fall", law = "polynomial", duration = "{360 - rise!r} deg", lift = "{lift!r} m", start = {{ v = "{V!r} m/s" }} }},
]
[[mass]]
name = "m"
mass = "{m!r} kg"
[[element]]
name = "spring"
type = "spring"
between = ["ground", "m"]
stiffness = "{k!r} N/m"
[[element]]
name = "belt"
type = "friction"
between = ["cam", "m"]
{friction_keys(fc, fb, vs, cv)}
[simulation]
duration = "{duration}"
warmup_cycles = {warmup}
sample_rate = "{rate}"
{initial}"""


# --------------------------------------------------------------------------- closed forms
def coulomb_oscillator(m: float, k: float, fc: float, fb: float, x0: float, t: np.ndarray):
    """A spring–mass released at rest from x0 on a Coulomb slide (no Stribeck, no viscous):
    half-waves about ±F_C/k (half period π√(m/k)), each ending at rest at 2c − x where it
    sticks if |k·x| ≤ F_B.

    Returns (x, v, friction force, half-wave start times, stick time, stick position), the
    traces on ``t``."""
    w = math.sqrt(k / m)
    half = math.pi / w
    waves, t0, xa = [], 0.0, x0
    while abs(k * xa) > fb:
        c = math.copysign(fc / k, xa)  # moving towards −sign(x): the slide pushes back by sign(x)·F_C
        waves.append((t0, xa, c))
        xa, t0 = 2.0 * c - xa, t0 + half
    x, v, f = (np.full_like(t, np.nan) for _ in range(3))
    for start, xs, c in waves:
        sel = (t >= start) & (t < start + half)
        tau = t[sel] - start
        x[sel] = c + (xs - c) * np.cos(w * tau)
        v[sel] = -(xs - c) * w * np.sin(w * tau)
        f[sel] = -k * c  # f = sign(ḋ)·F_C, sign(ḋ) = −sign(x_s)
    sel = t >= t0
    x[sel], v[sel], f[sel] = xa, 0.0, -k * xa  # stuck: the pair holds the spring's pull
    return x, v, f, [w_[0] for w_ in waves], t0, xa


@dataclass
class StickSlip:
    """The limit cycle of the stick–slip oscillator (belt at V, F_B > F_C, no Stribeck, no
    viscous): stuck from x = 2x_C − x_B until k·x = F_B, then a harmonic slip about x_C
    = F_C/k until the mass moves with the belt again."""

    m: float
    k: float
    fc: float
    fb: float
    V: float

    @property
    def w(self) -> float:
        return math.sqrt(self.k / self.m)

    @property
    def a(self) -> float:
        """x_B − x_C [m]."""
        return (self.fb - self.fc) / self.k

    @property
    def xc(self) -> float:
        return self.fc / self.k

    @property
    def xb(self) -> float:
        return self.fb / self.k

    @property
    def alpha(self) -> float:
        return math.atan2(self.V / self.w, self.a)

    @property
    def slip_duration(self) -> float:
        return (math.pi + 2.0 * self.alpha) / self.w

    @property
    def stick_duration(self) -> float:
        return 2.0 * self.a / self.V

    @property
    def period(self) -> float:
        return self.slip_duration + self.stick_duration

    @property
    def radius(self) -> float:
        return math.hypot(self.a, self.V / self.w)

    def x(self, t: np.ndarray) -> np.ndarray:
        """The displacement on the cycle that starts stuck at x = 2x_C − x_B at t = 0."""
        tau = np.mod(t, self.period)
        stuck = tau < self.stick_duration
        phase = self.w * (tau - self.stick_duration) - self.alpha  # R·cos(phase) = y at slip: a
        return np.where(stuck, self.xc - self.a + self.V * tau, self.xc + self.radius * np.cos(phase))


# --------------------------------------------------------------------------- DOP853
@dataclass
class Piece:
    t0: float
    t1: float
    kind: str  # "stuck" or "slide"
    data: object  # stuck: x at t0; slide: the dense output


@dataclass
class SlideReference:
    """A mass m on a spring k to ground, with a friction pair to a node moving at constant
    velocity V (V = 0: the ground), integrated independently of camsim: sliding phases by
    scipy's DOP853 (rtol 1e-13) on the law of spec §10 written out here, each ended by the
    event ḋ = 0; there the stick test (the belt does not accelerate, so the force that holds
    the pair is k·x: within ±F_B it sticks, else it reverses); stuck phases in closed form
    (x = x_s + V·(t − t_s) until |k·x| = F_B)."""

    m: float
    k: float
    V: float
    fc: float
    fb: float
    vs: float | None
    cv: float
    x0: float
    v0: float
    t_end: float
    events: list = field(default_factory=list)  # (time, "stick" | "slip")
    reversals: list = field(default_factory=list)  # (time, x)
    pieces: list = field(default_factory=list)

    def __post_init__(self):
        self._solve()

    def law(self, sign: float, rate: float) -> float:
        """f(ḋ) on the branch ``sign`` (tension-positive)."""
        drop = (self.fb - self.fc) * math.exp(-abs(rate) / self.vs) if self.vs else 0.0
        return sign * (self.fc + drop) + self.cv * rate

    def _slide(self, t0: float, x0: float, v0: float, sign: float) -> tuple[float, float, float]:
        def rhs(_t, y):
            return [y[1], (-self.k * y[0] - self.law(sign, y[1] - self.V)) / self.m]

        def halt(_t, y):
            return sign * (y[1] - self.V)
        halt.terminal, halt.direction = True, -1

        sol = solve_ivp(rhs, (t0, self.t_end), [x0, v0], method="DOP853", rtol=1e-13, atol=1e-18, events=[halt],
                        dense_output=True)
        t1 = float(sol.t_events[0][0]) if sol.t_events[0].size else self.t_end
        self.pieces.append(Piece(t0, t1, "slide", sol.sol))
        x1 = float(sol.y_events[0][0][0]) if sol.t_events[0].size else float(sol.y[0, -1])
        return t1, x1, bool(sol.t_events[0].size)

    def _solve(self):
        t, x, v = 0.0, self.x0, self.v0
        if abs(v - self.V) > 0.0:
            sign = math.copysign(1.0, v - self.V)
        elif abs(self.k * x) > self.fb:
            sign = -math.copysign(1.0, x)
            self.events.append((0.0, "slip"))
        else:
            sign = 0.0
        while t < self.t_end:
            if sign == 0.0:  # stuck at x, moving with the belt
                if self.V == 0.0:
                    self.pieces.append(Piece(t, self.t_end, "stuck", x))
                    return
                t1 = t + (self.fb / self.k - x) / self.V  # the spring pulls back: the pair holds it up to F_B
                self.pieces.append(Piece(t, min(t1, self.t_end), "stuck", x))
                if t1 >= self.t_end:
                    return
                t, x, sign = t1, self.fb / self.k, -1.0
                self.events.append((t, "slip"))
                v = self.V
                continue
            t, x, halted = self._slide(t, x, v, sign)
            if not halted:
                return
            v = self.V
            if abs(self.k * x) <= self.fb:
                self.events.append((t, "stick"))
                sign = 0.0
            else:
                self.reversals.append((t, x))
                sign = -math.copysign(1.0, x)

    def x(self, t: np.ndarray) -> np.ndarray:
        out = np.full_like(t, np.nan)
        for p in self.pieces:
            sel = (t >= p.t0) & (t <= p.t1)
            if not sel.any():
                continue
            out[sel] = p.data + self.V * (t[sel] - p.t0) if p.kind == "stuck" else p.data(t[sel])[0]
        return out


# --------------------------------------------------------------------------- roots
def first_root(f, t0: float, t1: float, step: float = 2e-4) -> float | None:
    """The first t in (t0, t1] where f (vectorised) goes from > 0 to ≤ 0, by a scan of
    ``step`` and brentq (xtol 1e-16)."""
    ts = np.append(np.arange(t0, t1, step), t1)
    vals = f(ts)
    for i in range(1, len(ts)):
        if vals[i - 1] > 0 >= vals[i]:
            return brentq(lambda s: float(f(np.array([s]))[0]), ts[i - 1], ts[i], xtol=1e-16, rtol=1e-15)
    return None


# --------------------------------------------------------------------------- carriage
H, RPM, MC = 0.02, 60.0, 1.0  # carriage: cycloidal lift [m], cam speed [rpm], the part's mass [kg]
TR = 60.0 / RPM / 2.0  # one cycloidal rise or fall [s]


def carriage(fc: float, fb: float, cv: float | None = None, rate: str = "10 kHz", duration: str | None = None) -> str:
    """A part on a carriage: friction between the cam node (a cycloidal rise of H over 180°,
    the cycloidal fall back) and a free mass, nothing else; the part starts at rest at 0.
    One revolution, or ``duration``."""
    length = f'duration = "{duration}"' if duration else "cycles = 1"
    return f"""
schema = 1
[machine]
name = "a part on a cam-driven carriage"
[cam]
speed = "{RPM!r} rpm"
segments = [
  {{ motion = "rise", law = "cycloidal", duration = "180 deg", lift = "{H!r} m" }},
  {{ motion = "fall", law = "cycloidal", duration = "180 deg", lift = "{H!r} m" }},
]
[[mass]]
name = "part"
mass = "{MC!r} kg"
[[element]]
name = "pad"
type = "friction"
between = ["cam", "part"]
{friction_keys(fc, fb, None, cv)}
[initial.part]
displacement = "0 m"
velocity = "0 m/s"
[simulation]
{length}
warmup_cycles = 0
sample_rate = "{rate}"
"""


def cycloidal(t):
    """s, ṡ, s̈ of the carriage's cam: a cycloidal rise of H over TR, then the fall."""
    t = np.asarray(t, dtype=float)
    ph = np.mod(t, 2 * TR)
    up = ph < TR
    u = np.where(up, ph, ph - TR) / TR
    y = u - np.sin(2 * np.pi * u) / (2 * np.pi)
    yd = (1 - np.cos(2 * np.pi * u)) / TR
    ydd = 2 * np.pi * np.sin(2 * np.pi * u) / TR**2
    return np.where(up, H * y, H * (1 - y)), np.where(up, H * yd, -H * yd), np.where(up, H * ydd, -H * ydd)


@dataclass
class CarriageReference:
    """The part on the carriage, event by event (Coulomb, F_B ≥ F_C, no viscous): stuck, it
    moves with the cam (x = s + D) until m|s̈| = F_B; slipping, it accelerates at σ·F_C/m (σ
    the side the cam drags it to) until its velocity is the cam's again, where it sticks if
    m|s̈| ≤ F_B, else slides on towards sign(s̈) (a reversal, no row). Event instants by
    brentq on these closed forms (xtol 1e-16).

    ``pieces``: (t0, t1, ("stuck", D) | ("slide", x0, v0, σ)); ``events``: (time, kind)."""

    fc: float
    fb: float
    t_end: float = 2 * TR
    events: list = field(default_factory=list)
    pieces: list = field(default_factory=list)

    def __post_init__(self):
        t0, state = 0.0, ("stuck", 0.0)
        while True:
            t1, nxt = self._next(t0, state)
            self.pieces.append((t0, self.t_end if t1 is None else t1, state))
            if t1 is None:
                return
            t0, state = t1, nxt

    def _next(self, t0, state):
        fc, fb = self.fc, self.fb
        if state[0] == "stuck":
            t1 = first_root(lambda t: fb - np.abs(MC * cycloidal(t)[2]), t0 + 1e-12, self.t_end)
            if t1 is None:
                return None, None
            s1, v1, a1 = (float(q) for q in cycloidal(t1))
            self.events.append((t1, "slip"))
            return t1, ("slide", s1 + state[1], v1, math.copysign(1.0, a1))
        _, x0, v0, sig = state

        def lag(t):
            return sig * (cycloidal(t)[1] - (v0 + sig * fc / MC * (t - t0)))

        t1 = first_root(lag, t0 + 1e-9, self.t_end)
        if t1 is None:
            return None, None
        x1 = x0 + v0 * (t1 - t0) + sig * fc / (2 * MC) * (t1 - t0) ** 2
        s1, v1, a1 = (float(q) for q in cycloidal(t1))
        if MC * abs(a1) <= fb:
            self.events.append((t1, "stick"))
            return t1, ("stuck", x1 - s1)
        return t1, ("slide", x1, v1, math.copysign(1.0, a1))

    def x(self, t: np.ndarray) -> np.ndarray:
        out = np.full_like(t, np.nan)
        for a, b, st in self.pieces:
            sel = (t >= a) & (t < b) if b < self.t_end else (t >= a) & (t <= b)
            if st[0] == "stuck":
                out[sel] = cycloidal(t[sel])[0] + st[1]
            else:
                tau = t[sel] - a
                out[sel] = st[1] + st[2] * tau + st[3] * self.fc / (2 * MC) * tau**2
        return out

    @property
    def sliding_distance(self) -> float:
        """Σ|Δd| over the sliding pieces, d = x − s (ḋ keeps its sign on each)."""
        total = 0.0
        for a, b, st in self.pieces:
            if st[0] == "slide":
                ends = np.array([a, b])
                d = self.x(ends) - cycloidal(ends)[0]
                total += abs(d[1] - d[0])
        return total

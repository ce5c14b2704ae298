"""``type = "friction"``: a sliding pair with Coulomb, break-away, Stribeck and viscous friction
and an exact stuck state (spec §10).

The pair opposes the relative sliding velocity ḋ of its nodes. Sliding, its force is
(tension-positive, like a spring's: it acts −f on the upper node)

    f(ḋ) = sign(ḋ)·[F_C + (F_B − F_C)·e^(−|ḋ|/v_S)] + c_v·ḋ

with F_C the Coulomb force, F_B ≥ F_C the break-away force, v_S the Stribeck velocity and
c_v the viscous coefficient. Without ``stribeck_velocity`` the force drops from F_B to F_C as
soon as the pair slides (the classic stick–slip law). Three branches:

- ``sliding-up`` (ḋ > 0) and ``sliding-down`` (ḋ < 0): f = ±F_C + c_v·ḋ is linear, exact like
  the rest of the engine; a Stribeck drop adds the nonlinear remainder
  ±(F_B − F_C)·e^(−|ḋ|/v_S) (F_nl, integrated to the engine's tolerance). The guard
  ``halt`` keeps ±ḋ > 0: when ḋ reaches zero the engine asks what force would hold the pair
  (:meth:`camsim.engine.integrator.Integrator.handle`): within ±F_B it sticks (event
  ``stick``), beyond it reverses at once (no row);
- ``held`` (stuck): a constraint d = d_stick, the deflection at which it stuck (the engine's
  *hold*, kept with the state); the element carries the holding force f = −λ (λ the
  constraint's compressive force). The guards ``slip-up`` (F_B − f > 0) and ``slip-down``
  (F_B + f > 0) end it: the pair slips (event ``slip``) towards the side that pushes.

Nothing regularises the law (no tanh, no creep velocity): a stuck pair does not move at all.
The direction of a Stribeck slide is the element's memory in the state (``v_impacts``, where
a power-law contact keeps its impact speed): +1 up, −1 down.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from camsim.elements.affine import Affine
from camsim.elements.base import FIXED_NODES, FORCE_TOL, Branch, Element, GuardKind, Outcome, Param, register
from camsim.elements.events import EventKind

#: A sliding pair whose relative velocity is within this of zero has halted [m/s].
VELOCITY_TOL = 1e-12

#: Branches of a friction pair: stuck, sliding with ḋ > 0, sliding with ḋ < 0.
HELD, UP, DOWN = Branch.HELD, Branch.SLIDING_UP, Branch.SLIDING_DOWN


@register
@dataclass(frozen=True)
class Friction(Element):
    """Sliding pair: Coulomb force F_C [N], break-away force F_B [N], Stribeck velocity v_S
    [m/s], viscous coefficient c_v [N·s/m] (see the module docstring)."""

    coulomb_force: float | None = None
    coefficient: float | None = None
    normal_force: float | None = None
    static_coefficient: float | None = None
    breakaway_force: float | None = None
    stribeck_velocity: float | None = None
    viscous: float = 0.0
    #: The normal force's program when ``normal_force`` is a table (a
    #: :class:`camsim.loads.description.Load` the machine reader builds): N(t) is then an input
    #: of the engine like a load's force, F_C = μ·N(t), F_B = μ_s·N(t).
    normal_program: object = field(default=None, compare=False)

    type_name: ClassVar[str] = "friction"
    summary: ClassVar[str] = ("sliding pair: Coulomb F_C, break-away F_B, Stribeck v_S and viscous c_v friction "
                              "opposing ḋ; sticks exactly (a constraint) while the holding force is within ±F_B")
    params: ClassVar[tuple[Param, ...]] = (
        Param("coulomb_force", "force", "F_C: the sliding (Coulomb) force (or coefficient with normal_force)",
              minimum=0.0, example='"12 N"'),
        Param("coefficient", "number", "μ: F_C = μ·N, with normal_force", minimum=0.0),
        Param("normal_force", "force_program", "N: the force pressing the pair (with coefficient): a force, or a "
              "program like a load's ({ segments = [...] }, { table = \"clamp.csv\" }, { sine = {...} }); the pair "
              "is free while N ≤ 0", minimum=0.0),
        Param("static_coefficient", "number", "μ_s ≥ μ: F_B = μ_s·N (with coefficient)", minimum=0.0),
        Param("breakaway_force", "force", "F_B ≥ F_C: the largest force a stuck pair holds (default F_C)",
              minimum=0.0),
        Param("stribeck_velocity", "velocity", "v_S: the sliding force falls from F_B to F_C as e^(−|ḋ|/v_S) "
              "(without it, at once)", minimum=0.0, strict=True),
        Param("viscous", "damping", "c_v: viscous friction c_v·ḋ while sliding", default=0.0, minimum=0.0),
    )

    # ------------------------------------------------------------------ loading
    @classmethod
    def check(cls, values, error, driven) -> None:
        fc, mu, normal = values.get("coulomb_force"), values.get("coefficient"), values.get("normal_force")
        mu_s, fb = values.get("static_coefficient"), values.get("breakaway_force")
        program = values.get("normal_program")
        if (fc is None) == (mu is None):
            raise error("coulomb_force" if fc is not None else "coefficient",
                        "give coulomb_force, or coefficient with normal_force (exactly one)")
        if mu is not None and normal is None and program is None:
            raise error("normal_force", "missing: coefficient μ needs the normal force N (F_C = μ·N)")
        if (normal is not None or program is not None) and mu is None:
            raise error("normal_force", "a normal force needs coefficient μ (F_C = μ·N); or give coulomb_force alone")
        if mu_s is not None:
            if mu is None:
                raise error("static_coefficient", "needs coefficient and normal_force; with coulomb_force give "
                            "breakaway_force")
            if fb is not None:
                raise error("static_coefficient", "give static_coefficient or breakaway_force, not both")
            if mu_s < mu:
                raise error("static_coefficient", f"must be at least coefficient ({mu:g}), got {mu_s:g}")
        if program is not None:
            # F_C = μ·N(t) and F_B = μ_s·N(t) follow the program
            if fb is not None:
                raise error("breakaway_force", "with a normal force that follows a program give static_coefficient "
                            "(F_B = μ_s·N follows it)")
            if values.get("stribeck_velocity") is not None:
                raise error("stribeck_velocity", "a Stribeck drop with a normal force that follows a program is not "
                            "supported: give a constant normal_force, or leave out stribeck_velocity")
            if not (mu > 0.0 or (mu_s or 0.0) > 0.0 or values.get("viscous", 0.0) > 0.0):
                raise error("coefficient", "a friction pair with no Coulomb, break-away or viscous force does nothing")
            cls._check_nodes(values, error, driven)
            return
        f_c = fc if fc is not None else mu * normal
        if fb is not None and fb < f_c:
            raise error("breakaway_force", f"must be at least the Coulomb force F_C = {f_c:.6g} N, got {fb:.6g} N")
        f_b = fb if fb is not None else (mu_s * normal if mu_s is not None else f_c)
        if f_b == 0.0 and not values.get("viscous", 0.0) > 0.0:
            raise error("coulomb_force" if fc is not None else "coefficient",
                        "a friction pair with no Coulomb, break-away or viscous force does nothing")
        cls._check_nodes(values, error, driven)

    @staticmethod
    def _check_nodes(values, error, driven) -> None:
        lower, upper = values["lower"], values["upper"]
        if driven is not None and driven in (lower, upper):
            other = upper if lower == driven else lower
            if other in FIXED_NODES:
                raise error("between", f"{driven} is driven by the cam (cam.drives): its motion is prescribed, so "
                            f"friction between it and {other} could never stick or slip; put the friction on a free "
                            "mass, or give the guide's force as a [[load]] program")

    # ------------------------------------------------------------------ the law
    @property
    def programmed(self) -> bool:
        """True when the normal force follows a program (an input of the engine)."""
        return self.normal_program is not None

    @property
    def sliding_factor(self) -> float:
        """μ of F_C = μ·N(t) (a programmed normal force)."""
        return float(self.coefficient or 0.0)

    @property
    def holding_factor(self) -> float:
        """μ_s of F_B = μ_s·N(t) (a programmed normal force; μ without static_coefficient)."""
        return float(self.static_coefficient if self.static_coefficient is not None else self.sliding_factor)

    @property
    def sliding_force(self) -> float:
        """F_C [N] (NaN with a programmed normal force: :meth:`forces_at`)."""
        if self.programmed:
            return math.nan
        return self.coulomb_force if self.coulomb_force is not None else self.coefficient * self.normal_force

    @property
    def holding_force(self) -> float:
        """F_B [N]: the break-away force, the largest a stuck pair carries (NaN with a
        programmed normal force: :meth:`forces_at`)."""
        if self.programmed:
            return math.nan
        if self.breakaway_force is not None:
            return self.breakaway_force
        if self.static_coefficient is not None:
            return self.static_coefficient * self.normal_force
        return self.sliding_force

    def forces_at(self, normal: float | None = None) -> tuple[float, float]:
        """(F_C, F_B) [N], with the normal force ``normal`` [N] when it follows a program (the
        pair carries nothing while N ≤ 0)."""
        if not self.programmed:
            return self.sliding_force, self.holding_force
        n = max(float(normal), 0.0)
        return self.sliding_factor * n, self.holding_factor * n

    @property
    def stribeck(self) -> bool:
        """True when the sliding force falls continuously from F_B (nonlinear while sliding)."""
        return (self.stribeck_velocity is not None and not self.programmed
                and self.holding_force > self.sliding_force)

    def describe(self) -> dict:
        out = super().describe()
        if self.programmed:
            from_program = f"{self.normal_program.kind} program"
            return {**out, "normal_force": from_program, "sliding_force": None, "breakaway": None}
        return {**out, "sliding_force": self.sliding_force, "breakaway": self.holding_force}

    def branches(self, no_impact):
        # free first: the static equilibrium a run starts from is computed without the pair
        # (spec §10), which then starts held there (camsim.run.initial); a programmed pair is
        # also free while its normal force is not positive
        return (Branch.FREE, HELD, UP, DOWN)

    def is_constraint(self, branch):
        return branch == HELD

    def reported_constraint_force(self, branch, lam):
        return -lam  # the constraint's compressive λ is a tension −λ

    @staticmethod
    def direction(branch) -> float:
        """+1 sliding up, −1 sliding down, 0 held or free."""
        return 1.0 if branch == UP else (-1.0 if branch == DOWN else 0.0)

    def linear_law(self, branch, damping):
        sign = self.direction(branch)
        if not sign:
            return None
        return 0.0, self.viscous, 0.0 if self.programmed else sign * self.sliding_force

    def input_force(self, branch) -> float:
        """a of the tension force's input term a·N(t) on ``branch`` (a programmed normal force
        sliding: ±μ; the model puts it in B like a load)."""
        return self.direction(branch) * self.sliding_factor if self.programmed else 0.0

    def is_nonlinear(self, branch):
        return self.stribeck and branch in (UP, DOWN)

    def linear_part(self, branch, damping):
        return self.linear_law(branch, damping)

    def _drop(self, rate: np.ndarray) -> np.ndarray:
        """(F_B − F_C)·e^(−|ḋ|/v_S) [N]."""
        return (self.holding_force - self.sliding_force) * np.exp(-np.abs(rate) / self.stribeck_velocity)

    def nonlinear_force(self, delta, delta_rate, v_impact=None):
        """The Stribeck remainder as F_nl (compressive along δ = −d): −σ·(F_B − F_C)·e^(−|ḋ|/v_S),
        σ = ``v_impact`` the direction of the slide."""
        sign = 1.0 if v_impact is None else float(v_impact)
        return -sign * self._drop(np.asarray(delta_rate, dtype=float))

    def nonlinear_force_scalar(self, delta: float, delta_rate: float, v_impact=None) -> float:
        sign = 1.0 if v_impact is None else float(v_impact)
        return -sign * (self.holding_force - self.sliding_force) * math.exp(-abs(delta_rate) / self.stribeck_velocity)

    def force(self, branch, d, d_rate, damping, v_impact, normal=None):
        """The reported force on a sliding or free branch [N]; ``normal``: N(t) on the samples
        (a programmed normal force)."""
        sign = self.direction(branch)
        if not sign:
            return np.zeros_like(d)
        rate = np.asarray(d_rate, dtype=float)
        if self.programmed:
            return sign * self.sliding_factor * np.maximum(np.asarray(normal, dtype=float), 0.0) + self.viscous * rate
        f = sign * self.sliding_force + self.viscous * rate
        if self.stribeck:
            f = f + sign * self._drop(rate)
        return f

    # ------------------------------------------------------------------ guards and events
    def guards(self, branch, ctx):
        out = []
        if self.programmed:
            normal = ctx.normal_force()  # N(t): the pair grips while N > 0
            if branch == Branch.FREE:
                return [(GuardKind.GRIP, Affine(-normal.Cz, -normal.Du, -normal.Fn, -normal.e), FORCE_TOL)]
            out.append((GuardKind.LOOSEN, normal, FORCE_TOL))
        elif branch == Branch.FREE:
            return []
        if branch == HELD:
            if ctx.index in ctx.config.saturated:
                return out  # beside a stuck contact, carrying ±F_B: the contact's release ends it
            lam = ctx.constraint_force()  # f = −λ
            if self.programmed:  # F_B(t) = μ_s·N(t)
                f_b = self.holding_factor
                return out + [
                    (GuardKind.SLIP_UP, Affine(lam.Cz, lam.Du + f_b * normal.Du, lam.Fn, lam.e), FORCE_TOL),
                    (GuardKind.SLIP_DOWN, Affine(-lam.Cz, f_b * normal.Du - lam.Du, -lam.Fn, -lam.e), FORCE_TOL)]
            f_b = self.holding_force
            return out + [(GuardKind.SLIP_UP, Affine(lam.Cz, lam.Du, lam.Fn, lam.e + f_b), FORCE_TOL),
                          (GuardKind.SLIP_DOWN, Affine(-lam.Cz, -lam.Du, -lam.Fn, f_b - lam.e), FORCE_TOL)]
        _, rate = ctx.deflection()
        sign = self.direction(branch)
        return out + [(GuardKind.HALT, Affine(sign * rate.Cz, sign * rate.Du, sign * rate.Fn, sign * rate.e),
                       VELOCITY_TOL)]

    def guard_key(self, branch, ctx):
        return None

    def outcome_at(self, kind, rate, d):
        # rate = −ḋ; the halt is the engine's (it needs the holding force: Integrator.handle)
        if kind == GuardKind.SLIP_UP:
            return Outcome(UP, EventKind.SLIP, 0.0, 1.0)
        if kind == GuardKind.SLIP_DOWN:
            return Outcome(DOWN, EventKind.SLIP, 0.0, -1.0)
        if kind == GuardKind.LOOSEN:  # the normal force reaches zero: the pair lets go (no row)
            return Outcome(Branch.FREE)
        return Outcome()

    def sliding(self, sign: float) -> Outcome:
        """The outcome of sliding off in direction ``sign`` (no row: a reversal or the start)."""
        return Outcome(UP if sign > 0 else DOWN, None, 0.0, 1.0 if sign > 0 else -1.0)

    def branch_at_rest(self, branch, d, constraint_force):
        return Branch.FREE

    def branch_from_state(self, d, no_impact):
        return Branch.FREE  # camsim.run.initial holds it, or lets it slide, from the state

    def damping_note(self):
        return "friction (its keys: parameters)"

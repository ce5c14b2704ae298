"""Friction pairs in a run: the energy each dissipates per cycle, its stick and slip counts.

**Energy dissipated.** E = ∫ f·ḋ dt of a friction pair (spec §10) over the first recorded
revolution (over the record for a machine without a cam, or one shorter than a revolution:
the window of the loads' work, :func:`camsim.run.loads.work_window`). A stuck pair does no
work (ḋ = 0). While it slides ḋ keeps its sign (the pair stops sliding when ḋ reaches zero),
so

    E = F_C·Σ|Δd| + ∫ c_v·ḋ² dt + ∫ (F_B − F_C)·e^(−|ḋ|/v_S)·|ḋ| dt

over the sliding stretches: the Coulomb part exactly from the deflections at the ends of
each stretch, the viscous and Stribeck parts by Gauss–Legendre with :data:`POINTS` points
per step on the exact states between the engine's nodes (:class:`camsim.engine.dense.DenseStretch`:
the Taylor series of a linear configuration, exact to rounding for the polynomial ḋ² of a
step; DOP853 at rtol 1e-12 in a Stribeck slide). It is integrated on the engine's solution,
not the output samples: the sample rate does not change it.

**Counts.** ``sticks:<name>`` and ``slips:<name>``: the pair's ``stick`` and ``slip`` rows in
the recorded event table.
"""

from __future__ import annotations

import math

import numpy as np

from camsim.elements import Branch
from camsim.elements.affine import N_INPUT
from camsim.elements.events import EventKind

__all__ = ["POINTS", "FrictionWork", "friction_columns", "friction_row", "friction_summary", "pairs"]

#: Gauss–Legendre points per step of the viscous and Stribeck integrals.
POINTS = 6
_X, _W = np.polynomial.legendre.leggauss(POINTS)
_SIGMA = 0.5 * (_X + 1.0)
_WEIGHT = 0.5 * _W

_SLIDING = (Branch.SLIDING_UP, Branch.SLIDING_DOWN)


def pairs(machine) -> list:
    """The machine's friction elements, in file order."""
    return [e for e in machine.elements if e.type_name == "friction"]


class FrictionWork:
    """∫ f·ḋ dt of every friction pair over a window, stretch by stretch (module docstring).

    Parameters
    ----------
    model : Model
    window : (float, float)
        The interval [s] on the simulation clock.
    """

    def __init__(self, model, window: tuple[float, float]):
        self.model = model
        self.lo, self.hi = float(window[0]), float(window[1])
        self.index = [i for i, e in enumerate(model.elements) if e.type_name == "friction"]
        self.energy = np.zeros(len(self.index))
        self.covered = 0.0

    def add(self, ctx, st) -> None:
        """Add one stretch of the integrator ``ctx``."""
        t = st.t
        if t.size < 2 or t[-1] <= self.lo or t[0] >= self.hi:
            return
        a = np.maximum(t[:-1], self.lo)
        b = np.minimum(t[1:], self.hi)
        steps = np.flatnonzero(b > a)
        if not steps.size:
            return
        self.covered += float(np.sum(b[steps] - a[steps]))
        model = self.model
        sliding = [(k, i) for k, i in enumerate(self.index) if model.branch_of(st.branches, i) in _SLIDING]
        if not sliding:
            return
        h = t[steps + 1] - t[steps]
        lo = (a[steps] - t[steps]) / h
        hi = (b[steps] - t[steps]) / h
        whole = bool(np.all(lo == 0.0) and np.all(hi == 1.0))
        from camsim.engine.dense import DenseStretch

        dense = DenseStretch(ctx, st.config, st.branches, st.v_impacts, st.exact, t, st.z, st.u, None)
        sigma = lo[:, None] + (hi - lo)[:, None] * _SIGMA[None, :]
        Zs, Us = dense.states(steps, sigma)
        S, P, m = Zs.shape
        Zf, Uf = Zs.reshape(S * P, m), Us.reshape(S * P, -1)
        fn = ctx.nonlinear_forces(st.config, Zf, Uf, st.v_impacts)
        v = st.config.v(Zf, Uf, fn)
        width = (hi - lo) * h
        for k, i in sliding:
            element = model.elements[i]
            geo = model.geometry[i]
            rate = (v @ geo.G + geo.cam_term(Uf[:, 1 : N_INPUT * model.n_cams : N_INPUT])).reshape(S, P)
            g = element.viscous * rate**2
            if element.stribeck:
                g = g + element._drop(rate) * np.abs(rate)
            extra = float(np.sum(width * (g @ _WEIGHT)))
            if element.programmed:  # F_C = μ·N(t): the Coulomb part by the same rule
                normal = np.maximum(Us[:, :, model.normal_column(i)], 0.0)
                coulomb = element.sliding_factor * float(np.sum(width * ((normal * np.abs(rate)) @ _WEIGHT)))
            elif whole:  # the Coulomb part exactly: F_C·|Δd| over the stretch's steps
                d0 = self._deflection(st, i, steps[0], 0)
                d1 = self._deflection(st, i, steps[-1], 1)
                coulomb = element.sliding_force * abs(d1 - d0)
            else:  # a window's edge inside the stretch: |ḋ| by the same rule
                coulomb = element.sliding_force * float(np.sum(width * (np.abs(rate) @ _WEIGHT)))
            self.energy[k] += coulomb + extra

    def _deflection(self, st, i: int, step: int, end: int) -> float:
        model = self.model
        z, u = st.z[step + end][None, :], st.u[step + end][None, :]
        fn = st.fn[step + end][None, :] if st.fn is not None and st.fn.size else np.zeros((1, 0))
        x = st.config.x(z, u, fn)[0]
        return float(model.deflection(i, x, u[0, 0 : N_INPUT * model.n_cams : N_INPUT]))

    def values(self) -> dict[str, float]:
        """Each pair's dissipated energy [J] over the window (NaN when the run did not cover it)."""
        complete = self.covered >= (self.hi - self.lo) * (1.0 - 1e-9)
        return {self.model.elements[i].name: (float(e) if complete else math.nan)
                for i, e in zip(self.index, self.energy)}


# ---------------------------------------------------------------------- scalars and summary
def friction_columns(machine) -> list[tuple[str, str]]:
    """Each friction pair's scalars with their SI units: ``friction_energy:<name>`` [J] (per
    cycle), ``sticks:<name>`` and ``slips:<name>`` (counts)."""
    out = []
    for e in pairs(machine):
        out += [(f"friction_energy:{e.name}", "J"), (f"sticks:{e.name}", ""), (f"slips:{e.name}", "")]
    return out


def _counts(result, name: str) -> tuple[int, int]:
    sticks = slips = 0
    for ev in result.events:
        if ev.element != name:
            continue
        kind = EventKind(ev.kind)
        sticks += kind == EventKind.STICK
        slips += kind == EventKind.SLIP
    return sticks, slips


def friction_row(result) -> dict[str, float]:
    """The :func:`friction_columns` scalars of a result."""
    energy = getattr(result, "friction_energy", None) or {}
    out: dict[str, float] = {}
    for e in pairs(result.machine):
        sticks, slips = _counts(result, e.name)
        out[f"friction_energy:{e.name}"] = float(energy.get(e.name, math.nan))
        out[f"sticks:{e.name}"] = sticks
        out[f"slips:{e.name}"] = slips
    return out


def friction_summary(result) -> dict[str, dict] | None:
    """Per friction pair: its nodes, F_C and F_B [N], the energy it dissipates [J] per cycle
    (``over``: ``"revolution"`` or ``"record"``) and its stick and slip counts; None without
    friction pairs."""
    from camsim.run.loads import work_over

    found = pairs(result.machine)
    if not found:
        return None
    energy = getattr(result, "friction_energy", None) or {}
    over = work_over(result.machine)
    out = {}
    for e in found:
        sticks, slips = _counts(result, e.name)
        value = energy.get(e.name)
        programmed = e.programmed
        out[e.name] = {"between": [e.lower, e.upper],
                       "coulomb_force": None if programmed else e.sliding_force,
                       "breakaway_force": None if programmed else e.holding_force,
                       "normal_force": f"{e.normal_program.kind} program" if programmed else None,
                       "energy": None if value is None or math.isnan(value) else float(value), "over": over,
                       "sticks": sticks, "slips": slips}
    return out

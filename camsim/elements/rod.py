"""``type = "rod"``: a slender elastic member whose stress wave matters (spec §3; thesis §3.3.4).

A striker, a push rod, a long connecting rod: length L, cross-section A (``area`` or
``diameter``), a material (library name or ``[[material]]``) or ``modulus`` E and
``density`` ρ. Wave speed c = √(E/ρ), impedance Z = A·√(E·ρ), mass m = ρ·A·L.

camsim never integrates a partial differential equation: the model turns the rod into
``segments`` N equal lumped segments (:meth:`Rod.expand`), each a spring k = N·E·A/L whose
mass m/N is split between its two ends, so the engine sees only masses and linear springs
and stays exact. The rod's ends add m/(2N) to the nodes it joins (a node that exists only to
hold a rod end may have ``mass = "0 kg"``); its interior nodes are ``<rod>[1]`` …
``<rod>[N-1]`` from the lower node up.

**Highest mode.** The N-segment chain, free at both ends, has natural frequencies
ωⱼ = 2·(N·c/L)·sin(jπ/2N), j = 0 … N (the continuum's are jπc/L); its highest,
f_N = N·c/(π·L), is what the default N is chosen against (:func:`choose_segments`).

**Damping** (``damping_ratio`` ζ): Kelvin–Voigt material damping, σ = E·(ε + β·ε̇), i.e. a
dashpot c = β·k across every segment (stiffness-proportional damping of the rod). β is
matched at the rod's first free-free axial mode: β = 2ζ/ω₁, so that mode has ratio ζ
exactly for every N, and mode j has ζ·ωⱼ/ω₁ (≈ j·ζ): the damping of a real material grows
with frequency, and the discretisation's own highest modes, which carry no physics, are the
most damped. Mass-proportional (Rayleigh α) damping would need dashpots to ground, which
would brake the rod's rigid motion, so camsim does not offer it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from camsim.elements.base import FIXED_NODES, Damping, Element, Param, register
from camsim.elements.spring import Spring
from camsim.physics.materials import Material

#: Segments a default discretisation has at least (one interior node: a wave in the rod).
MIN_SEGMENTS = 2
#: The default never puts the rod's highest mode above this [Hz]: half the frequency camsim
#: refuses as numerically rigid (camsim.model.rigidity, 833 kHz), a run there costs 12
#: integration steps per period (about 5 M steps per simulated second).
MAX_DEFAULT_FREQUENCY = 400e3
#: The default puts the highest mode at least this many times the cam's significant harmonic...
CAM_HARMONIC_FACTOR = 10.0
#: ...and at least this over the contact duration τ of the fastest impact on the rod (spec §3).
IMPACT_FACTOR = 5.0


@dataclass(frozen=True)
class RodSegment(Spring):
    """One of a rod's N segments: a spring N·E·A/L with its Kelvin–Voigt dashpot.

    Not a machine-file kind (never registered): the model makes it from a :class:`Rod`.
    ``rod`` is the rod's name, ``index`` 1 … N from the lower end.
    """

    rod: str = ""
    index: int = 0

    def reported_as(self, key: str) -> tuple[str, str]:
        return self.rod, "segments"

    def parent(self) -> str | None:
        return self.rod


@dataclass(frozen=True)
class RodExpansion:
    """A rod turned into lumped segments (:meth:`Rod.expand`).

    Attributes
    ----------
    nodes : tuple of str
        All N + 1 node names from the lower end: lower, ``<rod>[1]`` … ``<rod>[N-1]``, upper.
    interior_mass : float
        Mass of each interior node [kg] (m/N).
    end_mass : float
        Mass each end adds to its node [kg] (m/(2N)).
    segments : tuple of RodSegment
        The springs, lower end first.
    """

    nodes: tuple[str, ...]
    interior_mass: float
    end_mass: float
    segments: tuple[RodSegment, ...]


def chain_frequencies(n_segments: int, wave_speed: float, length: float) -> np.ndarray:
    """Natural frequencies [Hz] of the free-free N-segment lumped rod: (N c/(π L))·sin(jπ/2N), j = 0 … N."""
    j = np.arange(n_segments + 1)
    return n_segments * wave_speed / (math.pi * length) * np.sin(j * math.pi / (2 * n_segments))


def choose_segments(wave_speed: float, length: float, cam_harmonic: float, fastest_impact: float | None,
                    limit: float = MAX_DEFAULT_FREQUENCY) -> tuple[int, str]:
    """The default N and why: the smallest N ≥ :data:`MIN_SEGMENTS` whose highest mode
    f_N = N·c/(π·L) is at least 10 × ``cam_harmonic`` [Hz] and 5/τ (``fastest_impact`` τ [s],
    None: no impact on the rod), capped where f_N would exceed ``limit`` [Hz].
    """
    per_segment = wave_speed / (math.pi * length)  # f_N / N [Hz]
    needs = {"the minimum": MIN_SEGMENTS}
    why = []
    if cam_harmonic > 0:
        target = CAM_HARMONIC_FACTOR * cam_harmonic
        needs["the cam"] = math.ceil(target / per_segment * (1 - 1e-12))
        why.append(f"10 x the cam's significant harmonic {cam_harmonic:.4g} Hz")
    if fastest_impact is not None and fastest_impact > 0:
        target = IMPACT_FACTOR / fastest_impact
        needs["the impact"] = math.ceil(target / per_segment * (1 - 1e-12))
        why.append(f"5/tau = {target:.4g} Hz of the fastest impact on it (tau ~ {fastest_impact:.3g} s)")
    n = max(needs.values())
    cap = max(1, int(limit / per_segment))
    note = ""
    if n > cap:
        n = cap
        note = (f"; capped at {cap} (highest mode {cap * per_segment:.4g} Hz: camsim integrates at most "
                f"{limit:.3g} Hz by default; more segments with `segments`)")
    reason = (f"highest mode f_N = N*c/(pi*L) = {n * per_segment:.4g} Hz"
              + (f" >= {' and '.join(why)}" if why and not note else (f", wanted >= {' and '.join(why)}" if why else ""))
              + (f" (at least {MIN_SEGMENTS} segments)" if n == MIN_SEGMENTS and not note else "") + note)
    return n, reason


@register
@dataclass(frozen=True)
class Rod(Element):
    """Slender elastic rod: ``length`` L [m], ``area`` A [m²] (or ``diameter``), material or E, ρ.

    ``segments`` is N, resolved by the loader when the file leaves it out
    (``segments_reason`` says how).
    """

    length: float = 0.0
    area: float | None = None
    diameter: float | None = None
    material: Material | None = None
    modulus: float | None = None
    density: float | None = None
    segments: int | None = None
    segments_reason: str = ""

    type_name: ClassVar[str] = "rod"
    summary: ClassVar[str] = ("slender elastic rod carrying an axial stress wave, discretised into N lumped "
                              "segments (tension-positive end forces)")
    compound: ClassVar[bool] = True
    params: ClassVar[tuple[Param, ...]] = (
        Param("length", "length", "L", required=True, minimum=0.0, strict=True, example='"200 mm"'),
        Param("area", "area", "cross-section A (or `diameter`, not both)", minimum=0.0, strict=True),
        Param("diameter", "length", "d of a solid round rod, A = πd²/4 (instead of `area`)", minimum=0.0, strict=True),
        Param("material", "material", "a library name (`steel`, `aluminium-6061`, …; docs/impact.md) or the `name` "
              "of a `[[material]]` of the file; instead of `modulus` and `density`"),
        Param("modulus", "pressure", "E (with `density`, instead of `material`)", minimum=0.0, strict=True),
        Param("density", "density", "ρ (with `modulus`)", minimum=0.0, strict=True),
        Param("damping_ratio", "number", "ζ of the rod's first free-free axial mode; stiffness-proportional "
              "(Kelvin–Voigt) damping, mode j gets ≈ j·ζ (docs/machine-file.md, rods)", minimum=0.0),
        Param("segments", "integer", "N equal lumped segments; default: the smallest N ≥ 2 whose highest mode "
              "N·c/(π·L) is ≥ 10 × the cam's significant harmonic and ≥ 5/τ of the fastest impact on the rod",
              minimum=1),
    )

    @classmethod
    def check(cls, values, error, driven) -> None:
        if (values.get("area") is None) == (values.get("diameter") is None):
            raise error("area", "give the cross-section as area or diameter (one of them)")
        has_material = values.get("material") is not None
        has_own = [k for k in ("modulus", "density") if values.get(k) is not None]
        if has_material and has_own:
            raise error(has_own[0], "give material or modulus and density, not both")
        if not has_material and len(has_own) < 2:
            missing = next(k for k in ("modulus", "density") if values.get(k) is None)
            raise error(missing if has_own else "material",
                        "missing: a rod needs a material (e.g. material = \"steel\") or modulus and density")
        if has_material and not values["material"].density:
            raise error("material", f"material {values['material'].name} has no density; a rod needs one")

    # ------------------------------------------------------------------ properties
    @property
    def cross_section(self) -> float:
        """A [m²]."""
        return self.area if self.area is not None else math.pi * self.diameter**2 / 4.0

    @property
    def youngs_modulus(self) -> float:
        """E [Pa]."""
        return self.material.youngs_modulus if self.material is not None else self.modulus

    @property
    def mass_density(self) -> float:
        """ρ [kg/m³]."""
        return self.material.density if self.material is not None else self.density

    @property
    def yield_strength(self) -> float | None:
        """The material's yield strength [Pa] (None with modulus and density)."""
        return self.material.yield_strength if self.material is not None else None

    @property
    def wave_speed(self) -> float:
        """c = √(E/ρ) [m/s]."""
        return math.sqrt(self.youngs_modulus / self.mass_density)

    @property
    def impedance(self) -> float:
        """Z = A·√(E·ρ) [N·s/m]."""
        return self.cross_section * math.sqrt(self.youngs_modulus * self.mass_density)

    @property
    def rod_mass(self) -> float:
        """m = ρ·A·L [kg]."""
        return self.mass_density * self.cross_section * self.length

    @property
    def axial_stiffness(self) -> float:
        """E·A/L [N/m], the whole rod as one spring."""
        return self.youngs_modulus * self.cross_section / self.length

    @property
    def transit_time(self) -> float:
        """2L/c [s], a wave's round trip."""
        return 2.0 * self.length / self.wave_speed

    def highest_frequency(self, n: int | None = None) -> float:
        """f_N = N·c/(π·L) [Hz] of N segments (default: the rod's)."""
        return (n or self.segments) * self.wave_speed / (math.pi * self.length)

    def choose_segments(self, cam_harmonic: float, fastest_impact: float | None) -> tuple[int, str]:
        """The default N and why (:func:`choose_segments` with this rod's c and L)."""
        return choose_segments(self.wave_speed, self.length, cam_harmonic, fastest_impact)

    def chain_frequencies(self) -> np.ndarray:
        """Free-free natural frequencies of the discretised rod [Hz] (module docstring)."""
        return chain_frequencies(self.segments, self.wave_speed, self.length)

    def continuum_frequencies(self, count: int) -> np.ndarray:
        """The first ``count`` free-free natural frequencies of the continuous rod, j·c/(2L) [Hz]."""
        return np.arange(1, count + 1) * self.wave_speed / (2.0 * self.length)

    # ------------------------------------------------------------------ the machine's view
    def interior_nodes(self) -> tuple[str, ...]:
        """``<rod>[1]`` … ``<rod>[N-1]`` (empty before N is resolved)."""
        return tuple(f"{self.name}[{k}]" for k in range(1, (self.segments or 1)))

    def node_mass(self, node: str) -> float:
        """The mass m/(2N) [kg] this rod's end adds to ``node`` (0 for other nodes or before N)."""
        if not self.segments or node not in self.nodes or node in FIXED_NODES:
            return 0.0
        return self.rod_mass / (2.0 * self.segments)

    def branches(self, no_impact: bool):
        return ()

    def expand(self) -> RodExpansion:
        """The N lumped segments (module docstring): springs, node names, node masses."""
        n = self.segments
        k = n * self.axial_stiffness
        omega1 = 2.0 * n * self.wave_speed / self.length * math.sin(math.pi / (2 * n))
        beta = 2.0 * (self.damping.ratio or 0.0) / omega1
        nodes = (self.lower, *self.interior_nodes(), self.upper)
        segments = tuple(
            RodSegment(name=f"{self.name}#{i}", lower=nodes[i - 1], upper=nodes[i], stiffness=k,
                       damping=Damping(coefficient=beta * k), rod=self.name, index=i)
            for i in range(1, n + 1)
        )
        return RodExpansion(nodes=nodes, interior_mass=self.rod_mass / n, end_mass=self.rod_mass / (2 * n),
                            segments=segments)

    # ------------------------------------------------------------------ results
    #: The rod's result traces: name → (unit, long name) (docs/results.md).
    result_quantities: ClassVar[dict[str, tuple[str, str]]] = {
        "force_lower": ("N", "axial force at the lower end (tension-positive) of"),
        "force_upper": ("N", "axial force at the upper end (tension-positive) of"),
        "max_stress": ("Pa", "largest |axial stress| along"),
    }

    def result_traces(self, segment_forces: np.ndarray) -> dict[str, np.ndarray]:
        """The rod's traces from its segments' tensions (N_samples, N) [N].

        ``force_lower``, ``force_upper``: the axial force at the lower and the upper end
        (tension-positive; the end segments' tensions) [N]; ``max_stress``: max over the
        segments of |tension|/A [Pa].
        """
        if not segment_forces.size:
            empty = np.zeros(segment_forces.shape[0])
            return {"force_lower": empty, "force_upper": empty.copy(), "max_stress": empty.copy()}
        return {"force_lower": segment_forces[:, 0].copy(), "force_upper": segment_forces[:, -1].copy(),
                "max_stress": np.max(np.abs(segment_forces), axis=1) / self.cross_section}

    def describe(self) -> dict:
        out = super().describe()
        out["material"] = self.material.name if self.material is not None else None
        out.update({"cross_section": self.cross_section, "youngs_modulus": self.youngs_modulus,
                    "mass_density": self.mass_density, "wave_speed": self.wave_speed, "impedance": self.impedance,
                    "rod_mass": self.rod_mass, "highest_frequency": self.highest_frequency() if self.segments else None,
                    "segments_reason": self.segments_reason})
        return out

"""Materials of impact parts and rods: a small library by name, with the source of every value.

A :class:`Material` carries what camsim needs of a material: Young's modulus E [Pa],
Poisson's ratio ν [-], density ρ [kg/m³] (the rod's wave speed and mass) and a yield
strength [Pa] (the contact and rod stresses are reported against it). The library
(:data:`LIBRARY`) holds typical handbook values for the materials cam-driven machines make
their strikers, stops, rollers and pads of; a machine file adds its own with
``[[material]]`` tables (docs/machine-file.md). Values are typical, not guaranteed: a design
that depends on a margin should use the supplier's data sheet.

Sources (docs/impact.md, "Materials", repeats them with the reasons for each choice):

* ``steel``: E and ν of carbon steel, Norton, *Machine Design* (5th ed.), table C-1
  (30.0 Mpsi = 206.8 GPa, 0.28: camsim's default for the cam's Hertz stress); ρ = 7850 kg/m³,
  the steel density of the thesis's ball (0.0007349 lbf·s²/in⁴, appendix C p. 104); yield
  530 MPa of AISI 1045 cold-drawn, Budynas & Nisbett, *Shigley's Mechanical Engineering
  Design* (9th ed.), table A-20.
* ``hardened-steel``: AISI 52100 through-hardened (HRC 60–67), the steel of bearing balls:
  E 29.5 Mpsi (203.4 GPa), ρ 0.283 lb/in³ (7833 kg/m³), yield 295 ksi (2034 MPa), a ball
  maker's data sheet ("AISI 52100 Chrome Steel", Materials & Specifications); ν 0.28 (the
  0.27–0.30 of the same data).
* ``stainless-steel``: AISI 304 annealed, ASM Aerospace Specification Metals data sheet
  (MatWeb): E 193 GPa, ν 0.29, ρ 8000 kg/m³, yield 215 MPa (0.2 % offset).
* ``aluminium-6061``: 6061-T6, Aluminum Association typical values as tabulated by ASM
  (MatWeb): E 68.9 GPa, ν 0.33, ρ 2700 kg/m³, yield 276 MPa.
* ``bronze``: UNS C93200 (SAE 660) bearing bronze, MatWeb / AZoM data sheet: E 100 GPa,
  ν 0.34, ρ 8930 kg/m³, yield 125 MPa (0.5 % extension under load).
* ``cast-iron``: ductile (nodular) iron ASTM A536 grade 65-45-12: yield 45 ksi = 310 MPa
  (the grade's specified minimum), E 170 GPa, ν 0.29, ρ 7100 kg/m³ (MakeItFrom.com, ASTM
  grade 65-45-12). Gray iron has no yield point; ductile iron is the cast iron of cams and
  stops that take impact.
* ``brass``: UNS C36000 free-cutting brass, half hard (H02), 1 in rod, Copper Development
  Association typical values: yield 45 ksi = 310 MPa, E 14 000 ksi = 96.5 GPa, ρ 0.307 lb/in³
  = 8500 kg/m³; ν 0.31 (MatWeb).
* ``polyurethane-90a``: a 90 Shore A polyurethane elastomer: E 21 MPa from Gent's relation
  between Shore A hardness and Young's modulus (A. N. Gent, *Trans. Inst. Rubber Ind.* 34
  (1958) 46), ν 0.49 (nearly incompressible), ρ 1190 kg/m³ and tensile strength 26 MPa of a
  90A TPU data sheet (ASTM D792, D412). An elastomer has no yield point: the tensile
  strength stands in for it. The Hertz laws are small-strain elasticity: for a pad this soft
  they are an estimate.
* ``nylon-66``: unreinforced PA 66, dry as moulded, DuPont Zytel 103HSL NC010 data sheet:
  tensile modulus 3100 MPa, yield stress 85 MPa (ISO 527); ρ 1140 kg/m³ (Beer & Johnston,
  *Mechanics of Materials*, appendix B: 0.0412 lb/in³), ν 0.40 (the nylon 6-6 row of the
  material table of *Multimedia Engineering Mechanics*, ecoursesbook.com); conditioned at 50 % RH the modulus drops to about
  1.4 GPa and the yield stress to 55 MPa: give a ``[[material]]`` for a part in service).
* ``acetal``: POM homopolymer (Delrin 100 class), Margolis, *Engineering Plastics
  Handbook* (2006), table 5.5: tensile modulus 3.0 GPa, tensile strength 72 MPa (it yields
  there), specific gravity 1.41; ν 0.35 (DuPont Delrin design guide, module III).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Material", "LIBRARY", "MATERIAL_KEYS", "library_names", "effective_modulus", "lookup"]


@dataclass(frozen=True)
class Material:
    """One material, SI.

    Attributes
    ----------
    name : str
        Its library or ``[[material]]`` name.
    youngs_modulus : float
        E [Pa], > 0.
    poisson_ratio : float
        ν [-], in [0, 0.5).
    density : float or None
        ρ [kg/m³] (None: not given; a rod needs it).
    yield_strength : float or None
        The stress [Pa] contact and rod stresses are reported against (None: not given,
        no check).
    source : str
        Where the values come from (library) or ``"[[material]]"``.
    """

    name: str
    youngs_modulus: float
    poisson_ratio: float
    density: float | None = None
    yield_strength: float | None = None
    source: str = "[[material]]"

    @property
    def reduced_modulus(self) -> float:
        """E/(1 − ν²) [Pa], this body's share of the contact modulus."""
        return self.youngs_modulus / (1.0 - self.poisson_ratio**2)

    @property
    def wave_speed(self) -> float:
        """c = √(E/ρ) [m/s], the speed of an axial stress wave in a slender rod."""
        if not self.density:
            raise ValueError(f"material {self.name}: no density, no wave speed")
        return math.sqrt(self.youngs_modulus / self.density)

    def describe(self) -> dict:
        """The material as a JSON-able dict (SI)."""
        return {"name": self.name, "youngs_modulus": self.youngs_modulus, "poisson_ratio": self.poisson_ratio,
                "density": self.density, "yield_strength": self.yield_strength, "source": self.source}


#: Keys of a ``[[material]]`` table besides ``name`` (and of this dataclass).
MATERIAL_KEYS = ("youngs_modulus", "poisson_ratio", "density", "yield_strength")

_MPA, _GPA = 1e6, 1e9

#: The library by name (module docstring: the sources).
LIBRARY: dict[str, Material] = {m.name: m for m in (
    Material("steel", 206.8 * _GPA, 0.28, 7850.0, 530 * _MPA,
             "E, nu: Norton, Machine Design, table C-1 (carbon steel); rho: thesis appendix C p. 104; "
             "yield: AISI 1045 cold drawn, Shigley's MED 9th ed., table A-20"),
    Material("hardened-steel", 203.4 * _GPA, 0.28, 7833.0, 2034 * _MPA,
             "AISI 52100 through-hardened (HRC 60-67), chrome-steel ball data sheet: E 29.5 Mpsi, "
             "rho 0.283 lb/in^3, yield 295 ksi; nu 0.28"),
    Material("stainless-steel", 193 * _GPA, 0.29, 8000.0, 215 * _MPA,
             "AISI 304 annealed, ASM Aerospace Specification Metals data sheet (MatWeb)"),
    Material("aluminium-6061", 68.9 * _GPA, 0.33, 2700.0, 276 * _MPA,
             "6061-T6, Aluminum Association typical values (ASM / MatWeb)"),
    Material("bronze", 100 * _GPA, 0.34, 8930.0, 125 * _MPA,
             "UNS C93200 (SAE 660) bearing bronze, MatWeb / AZoM data sheet (yield at 0.5 % extension)"),
    Material("cast-iron", 170 * _GPA, 0.29, 7100.0, 310 * _MPA,
             "ductile iron ASTM A536 65-45-12: yield the grade's minimum 45 ksi; E, nu, rho MakeItFrom.com"),
    Material("brass", 96.5 * _GPA, 0.31, 8500.0, 310 * _MPA,
             "UNS C36000 free-cutting brass, half hard, 1 in rod, Copper Development Association typical "
             "values; nu MatWeb"),
    Material("polyurethane-90a", 21 * _MPA, 0.49, 1190.0, 26 * _MPA,
             "90 Shore A polyurethane: E from Gent's relation (1958); rho, tensile strength (no yield point) "
             "from a 90A TPU data sheet; nu 0.49"),
    Material("nylon-66", 3.1 * _GPA, 0.40, 1140.0, 85 * _MPA,
             "PA 66 dry as moulded, DuPont Zytel 103HSL NC010 data sheet (ISO 527); rho Beer & Johnston, "
             "Mechanics of Materials, app. B; nu Multimedia Engineering Mechanics, material table"),
    Material("acetal", 3.0 * _GPA, 0.35, 1410.0, 72 * _MPA,
             "POM homopolymer, Margolis, Engineering Plastics Handbook (2006), table 5.5; nu DuPont Delrin "
             "design guide"),
)}


def library_names() -> tuple[str, ...]:
    """The library's material names, in the order of the docs."""
    return tuple(LIBRARY)


def lookup(name: str, extra: dict[str, Material] | None = None) -> Material:
    """A material by name: the file's own (``extra``, from ``[[material]]``) first, then the library.

    Raises
    ------
    KeyError
        With the valid names.
    """
    if extra and name in extra:
        return extra[name]
    if name in LIBRARY:
        return LIBRARY[name]
    raise KeyError(name)


def effective_modulus(a: Material, b: Material) -> float:
    """The Hertz contact modulus E* [Pa]: 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂ (Johnson 1985, eq. 4.22)."""
    return 1.0 / (1.0 / a.reduced_modulus + 1.0 / b.reduced_modulus)

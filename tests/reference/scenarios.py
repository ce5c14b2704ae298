"""Closed-form test scenarios shared by the engine tests and the reference-solver tests.

Each scenario is a small machine with a known solution; the engine (tests/test_engine_analytic.py)
and the independent reference solver (tests/test_engine_reference.py) are both checked against it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from camsim.machine.loader import load_machine_text
from camsim.machine.description import Machine


@dataclass(frozen=True)
class ContactRelease:
    """A mass arriving at v0 on a damped linear seat, no gravity (ζ = 0.2).

    Closed form: in contact δ = (v0/ω_d)·e^(−ζωt)·sin ω_d t, and F = kδ + cδ̇ reaches 0 at
    ω_d·t_r = π − arctan(2ζ√(1−ζ²)/(1 − 2ζ²)) — before δ returns to 0 (spec §3: the contact
    opens when its force would turn tensile). Impact at t0 = x0/v0.
    """

    m: float = 0.5
    k: float = 2.0e5
    zeta: float = 0.2
    x0: float = 1.0e-3
    v0: float = 0.4

    @property
    def omega(self) -> float:
        return math.sqrt(self.k / self.m)

    @property
    def omega_d(self) -> float:
        return self.omega * math.sqrt(1 - self.zeta**2)

    @property
    def impact_time(self) -> float:
        return self.x0 / self.v0

    @property
    def contact_time(self) -> float:
        """t_r, from impact to release [s]."""
        z = self.zeta
        return (math.pi - math.atan(2 * z * math.sqrt(1 - z**2) / (1 - 2 * z**2))) / self.omega_d

    def machine(self, sample_rate: str) -> Machine:
        return load_machine_text(f"""
schema = 1
[machine]
name = "contact release"
[[mass]]
name = "M"
mass = "{self.m} kg"
[[element]]
name = "seat"
type = "contact"
between = ["ground", "M"]
stiffness = "{self.k} N/m"
damping_ratio = {self.zeta}
[initial.M]
displacement = "{self.x0} m"
velocity = "{-self.v0} m/s"
[simulation]
duration = "0.01 s"
warmup_cycles = 0
sample_rate = "{sample_rate}"
""")

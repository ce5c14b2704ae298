"""Figure for docs/contacts.md: restitution achieved by an isolated impact vs requested.

Run from the repository root::

    python scripts/restitution_figure.py            # writes docs/figures/restitution.png

For each Hunt–Crossley ``damping_model`` the achieved restitution is the exact rebound of
an isolated impact with α = χ·v from that model (:func:`camsim.physics.restitution.hc_rebound`,
the inverse of the rebound equation, checked against simulated impacts in
tests/test_restitution.py). Markers: camsim runs of a Hertz impact (m = 0.01 kg,
C = 1e10 N/m^1.5, v = 1 m/s) with the exact mapping, and of a clamped linear contact with
the mapped damping ratio, rebound speed from the release event.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from camsim.machine.loader import load_machine_text  # noqa: E402
from camsim.physics.restitution import DAMPING_MODELS, hc_rebound, linear_damping_ratio, linear_restitution  # noqa: E402
from camsim import simulate  # noqa: E402

LABELS = {
    "exact": "exact (default)",
    "lankarani-nikravesh": "Lankarani–Nikravesh 3(1−e²)/4",
    "flores": "Flores 8(1−e)/(5e)",
}


def simulated_rebound(text: str) -> float:
    result = simulate(load_machine_text(text))
    impact = [e for e in result.events if e.kind == "impact"][0]
    release = [e for e in result.events if e.kind == "release"][0]
    return -release.relative_velocity / impact.relative_velocity


def power_machine(e: float) -> str:
    return f"""
schema = 1
[machine]
name = "Hertz impact"
[[mass]]
name = "M"
mass = "0.01 kg"
[[element]]
name = "stop"
type = "contact"
between = ["ground", "M"]
law = "power"
gap = 0
coefficient = "1e10 N/m**1.5"
exponent = 1.5
restitution = {e!r}
[initial.M]
displacement = "2e-6 m"
velocity = "-1 m/s"
[simulation]
duration = "150 us"
warmup_cycles = 0
sample_rate = "2 MHz"
"""


def linear_machine(e: float) -> str:
    zeta = linear_damping_ratio(e)
    return f"""
schema = 1
[machine]
name = "linear impact"
[[mass]]
name = "M"
mass = "0.5 kg"
[[element]]
name = "stop"
type = "contact"
between = ["ground", "M"]
stiffness = "2e5 N/m"
damping_ratio = {zeta!r}
[initial.M]
displacement = "1e-3 m"
velocity = "-0.4 m/s"
[simulation]
duration = "20 ms"
warmup_cycles = 0
sample_rate = "100 kHz"
"""


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default="docs/figures/restitution.png", help="PNG to write")
    args = parser.parse_args(argv)
    requested = np.linspace(0.02, 1.0, 197)
    fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=120)
    ax.plot([0, 1], [0, 1], color="0.85", lw=4, label="achieved = requested")
    for model, alpha in DAMPING_MODELS.items():
        achieved = [hc_rebound(alpha(float(e))) for e in requested]
        ax.plot(requested, achieved, label=f"power law, {LABELS[model]}")
    linear = [linear_restitution(linear_damping_ratio(float(e))) for e in requested]
    ax.plot(requested, linear, ls=":", color="k", label="linear, mapped damping ratio")
    marks = [0.1, 0.3, 0.5, 0.8, 0.95]
    ax.plot(marks, [simulated_rebound(power_machine(e)) for e in marks], "o", mfc="none", color="C0",
            label="camsim run, power law (exact)")
    ax.plot(marks, [simulated_rebound(linear_machine(e)) for e in marks], "s", mfc="none", color="k",
            label="camsim run, linear")
    ax.set_xlabel("requested restitution e")
    ax.set_ylabel("restitution achieved by an isolated impact")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title("Contact damping: requested vs achieved restitution")
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(out, metadata={"Software": None})
    print(out)


if __name__ == "__main__":
    main()

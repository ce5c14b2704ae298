"""Make a synthetic rig trace of the CDTM for the worked example of docs/fitting.md.

The "rig" is machines/cdtm.toml with two values changed (the truth the fit should find):

    element.K23.push_stiffness = 7600 lbf/in   (file: 8144 lbf/in)
    element.seat.damping_ratio = 0.10          (file: 0.06)

One revolution (0.5 s at 120 rpm, after the file's warm-up revolution) is sampled at
10 kHz; seeded Gaussian noise is added: 2 N on the transducer force, 20 m/s^2 on the M3
acceleration. The CSV is written in the units a rig would log: time in ms, the force in
lbf, the acceleration in m/s^2.

    python examples/make_rig_trace.py                # writes examples/rig_trace.csv
    python examples/make_rig_trace.py -o trace.csv --seed 3
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from camsim.analyses.fit.measured import write_measured
from camsim.machine.loader import load_machine
from camsim.run.simulation import simulate
from camsim.units import ureg

HERE = Path(__file__).resolve().parent
MACHINE = HERE.parent / "machines" / "cdtm.toml"
#: The values the synthetic rig has (the fit's truth).
TRUTH = ("element.K23.push_stiffness=7600 lbf/in", "element.seat.damping_ratio=0.10")
#: Sample rate of the rig's data logger [Hz].
RATE = 10_000.0
#: Noise standard deviations: transducer force [N], M3 acceleration [m/s^2].
SIGMA_FORCE = 2.0
SIGMA_ACCEL = 20.0


def main(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, default=HERE / "rig_trace.csv")
    parser.add_argument("--seed", type=int, default=2007)
    args = parser.parse_args(argv)
    machine = load_machine(MACHINE, overrides=list(TRUTH))
    run = simulate(machine, sample_rate=RATE)
    rng = np.random.default_rng(args.seed)
    force = run.transducer_force + rng.normal(0.0, SIGMA_FORCE, run.time.size)
    accel = run.masses["M3"]["acceleration"] + rng.normal(0.0, SIGMA_ACCEL, run.time.size)
    lbf = ureg.Quantity(force, "N").to("lbf").magnitude
    out = write_measured(
        args.output,
        np.round(run.time * 1e3, 6),
        {"transducer/force": (lbf, "lbf"), "masses/M3/acceleration": (accel, "m/s^2")},
        time_unit="ms",
    )
    try:  # as the user would name it from where they stand (examples/rig_trace.csv)
        shown = Path(out).resolve().relative_to(Path.cwd().resolve())
    except ValueError:
        shown = out
    print(f"wrote {shown} ({run.time.size} samples, truth: {', '.join(TRUTH)})")
    return out


if __name__ == "__main__":
    main()

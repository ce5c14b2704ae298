"""Figure for docs/cam.md: the thesis machine's M3 with and without compensation, 120 and 150 rpm.

Run from the repository root::

    python scripts/compensation_figure.py       # writes docs/img/cdtm_compensation.png

Four runs of machines/cdtm-compensated.toml (two recorded revolutions after one warm-up;
``--seat`` adds back the seat of machines/cdtm.toml, over-travel included):
the compensated cam (design speed 120 rpm) and the written program used directly as the
cam (``[cam.compensation]`` removed), each at 120 rpm and at 150 rpm (``cam.speed``; the
compensation's design speed stays 120 rpm). Top row: M3's displacement and the wanted
motion y (the written program at that speed, model axis). Bottom row: M3 − y, the error
of the output motion, in µm.
"""

from __future__ import annotations

import argparse
import tomllib
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from camsim import simulate  # noqa: E402
from camsim.cam import CamProgram  # noqa: E402
from camsim.machine.loader import load_machine  # noqa: E402

MACHINE = Path("machines/cdtm-compensated.toml")


def runs(seat: bool = False):
    doc = tomllib.loads(MACHINE.read_text(encoding="utf-8"))
    if seat:
        full = tomllib.loads(Path("machines/cdtm.toml").read_text(encoding="utf-8"))
        doc["element"] = doc["element"] + [e for e in full["element"] if e["name"] == "seat"]
    plain = {**doc, "cam": {k: v for k, v in doc["cam"].items() if k != "compensation"}}
    out = {}
    for rpm in (120, 150):
        for label, d in (("compensated at 120 rpm", doc), ("not compensated", plain)):
            m = load_machine(d, {"cam.speed": f"{rpm} rpm", "simulation.cycles": 2}, base_dir=MACHINE.parent)
            r = simulate(m)
            wanted = CamProgram(m.cam.output_program if m.cam.output_program is not None else m.cam)
            y = wanted.svaj(r.time)[0]
            angle = r.trace("cam/angle") - r.trace("cam/angle")[0]
            out[(rpm, label)] = (angle, r.trace("masses/M3/displacement"), y)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default="docs/img/cdtm_compensation.png")
    parser.add_argument("--seat", action="store_true", help="add the seat (over-travel) of cdtm.toml back")
    args = parser.parse_args(argv)
    data = runs(args.seat)
    fig, axes = plt.subplots(2, 2, figsize=(11, 6.5), sharex=True, layout="constrained")
    for col, rpm in enumerate((120, 150)):
        top, bottom = axes[0, col], axes[1, col]
        for label, style in (("not compensated", dict(color="tab:red", lw=0.9)),
                             ("compensated at 120 rpm", dict(color="tab:blue", lw=0.9))):
            angle, x, y = data[(rpm, label)]
            top.plot(angle, 1e3 * x, label=f"M3, {label}", **style)
            bottom.plot(angle, 1e6 * (x - y), label=label, **style)
        top.plot(angle, 1e3 * y, color="k", lw=0.7, ls="--", label="wanted (written program)")
        top.set_title(f"{rpm} rpm")
        top.set_ylabel("M3 displacement [mm]")
        bottom.set_ylabel("M3 − wanted [µm]")
        bottom.set_xlabel("cam angle [deg] (two revolutions)")
        bottom.set_yscale("symlog", linthresh=0.01)
        top.legend(loc="upper right", fontsize=7)
    fig.suptitle("CDTM (machines/cdtm-compensated.toml" + (" + seat" if args.seat else "") +
                 "): M3 with and without compensation (design speed 120 rpm)")
    fig.savefig(args.output, dpi=130, metadata={"Software": None})
    print(f"wrote {args.output}")
    for key, (angle, x, y) in data.items():
        dwell = (np.mod(angle, 360) > 50) & (np.mod(angle, 360) < 90)  # the top dwell after the first rise
        print(f"{key[0]} rpm, {key[1]}: max |M3 - wanted| over the revolutions {1e6 * np.max(np.abs(x - y)):.3g} um, "
              f"in the top dwell 50-90 deg {1e6 * np.max(np.abs(x[dwell] - y[dwell])):.3g} um")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

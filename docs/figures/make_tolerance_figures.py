"""Make the worked CDTM tolerance study of docs/tolerance.md and its figure.

Run from the repository root (about 7 minutes on 2 cores)::

    python docs/figures/make_tolerance_figures.py

It is the same as::

    camsim study machines/cdtm.toml \\
        --dist "element.K23.pull_stiffness=tol:219:22lbf/in" \\
        --dist "element.K23.preload=tol:28.12:3lbf" \\
        --dist "element.seat.gap=tol:0.0625:0.005in" \\
        --dist "element.seat.stiffness=tol:8.6e6:1.3e6N/m" \\
        -n 256 --method sobol --seed 1 --sensitivity \\
        --limit "peak_transducer_force>100lbf" --limit "peak_transducer_force>240N" \\
        --limit "min_cam_contact_force<0N" \\
        -o cdtm_study.h5 --plot docs/figures/cdtm-tolerance.png --json

and prints the --json payload (the numbers quoted in docs/tolerance.md).
"""

from __future__ import annotations

import argparse
import json
import pickle
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from camsim.analyses.study import study  # noqa: E402
from camsim.figures.study import save_study_plot  # noqa: E402

DISTS = [
    "element.K23.pull_stiffness=tol:219:22lbf/in",
    "element.K23.preload=tol:28.12:3lbf",
    "element.seat.gap=tol:0.0625:0.005in",
    "element.seat.stiffness=tol:8.6e6:1.3e6N/m",
]
LIMITS = ["peak_transducer_force>100lbf", "peak_transducer_force>240N", "min_cam_contact_force<0N"]


#: The outputs shown in the figure (the plot's default shows every varying output).
SHOWN = ["peak_transducer_force", "min_cam_contact_force", "peak_acceleration:M3", "max_impact_velocity"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", type=Path, help="keep the study result in this pickle file and reuse it (re-plot without re-running)")
    args = parser.parse_args()
    if args.cache is not None and args.cache.exists():
        with open(args.cache, "rb") as fh:
            res = pickle.load(fh)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            res = study(ROOT / "machines" / "cdtm.toml", DISTS, 256, method="sobol", seed=1, sensitivity=True,
                        limits=LIMITS, workers=2, output=Path(tmp) / "cdtm_study.h5")
        if args.cache is not None:
            with open(args.cache, "wb") as fh:
                pickle.dump(res, fh)
    save_study_plot(res, ROOT / "docs" / "figures" / "cdtm-tolerance.png", dpi=100, outputs=SHOWN)
    payload = res.to_json()
    payload.pop("output"), payload.pop("csv")
    print(json.dumps(payload, indent=1, allow_nan=True))


if __name__ == "__main__":
    main()

"""Generate the engine reference data in ``tests/data/reference/`` (not run by the tests).

For each reference machine (``machines/cdtm.toml``, ``machines/dynacam-2mass.toml``, and
the issue-34 regression machines ``tests/invariants/machines/disc-lobe-follower.toml`` and
``lobe-reengage.toml``) this runs the independent solver of :mod:`reference_solver` (scipy ``solve_ivp``, DOP853,
rtol 1e-12, atol 1e-15 m / 1e-12 m/s, every branch change a terminal event) with the
machine's own warm-up and recorded cycles, sampled at 10 kHz on camsim's
grid t_rec + k/10 kHz, and writes ``tests/data/reference/<machine>.npz`` holding

- ``time`` [s] (0 at the start of the recorded cycle);
- ``<mass>/displacement`` [m], ``<mass>/velocity`` [m/s], ``<mass>/acceleration`` [m/s^2]
  for every mass (the driven one too);
- ``event_time`` [s], ``event_element``, ``event_kind``, ``event_rate`` [m/s] (δ̇ for a
  contact, ḋ for a preloaded link) of the recorded cycle;
- ``reengage_time`` [s], ``reengage_element``: where a lifted linear contact's law turned
  positive again (a branch change without a row, issue 34);
- ``meta`` (a JSON string: solver, method, rtol, atol, sample rate, cycles, the SHA-256 of the
  machine's SI physics (:func:`machine_digest`); no date, so that regenerating gives the same file).

Regenerate (from the repository root)::

    python tests/reference/make_reference.py            # every machine, about 30-70 s
    python tests/reference/make_reference.py cdtm       # one machine

Run times on one core: cdtm 14-50 s (machine load), dynacam-2mass about 1 s, disc-lobe-follower
about 8 s, lobe-reengage about 4 s. The tests that read these files are in
``tests/test_engine_reference.py`` and ``tests/invariants/test_no_phantom_events.py``; they
re-run camsim, never this script.
"""

from __future__ import annotations

import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))

from reference_solver import ATOL_V, ATOL_X, ReferenceSolver, located_extremes  # noqa: E402

from camsim.machine.loader import load_machine, machine_to_dict  # noqa: E402

#: Machines and their reference settings.
MACHINES = ("cdtm", "dynacam-2mass", "disc-lobe-follower", "lobe-reengage")
#: Machines that are not shipped: their files, relative to the repository root.
TEST_MACHINES = {name: f"tests/invariants/machines/{name}.toml" for name in ("disc-lobe-follower", "lobe-reengage")}
RTOL = 1e-12
METHOD = "DOP853"
SAMPLE_RATE = 10_000.0  # [Hz]
OUT_DIR = ROOT / "tests" / "data" / "reference"


def machine_digest(machine) -> str:
    """SHA-256 of the machine's physics in SI (cam, masses, elements, initial state, cycles,
    gravity): comments and the output sample rate of the file do not change it."""
    d = machine_to_dict(machine)
    # Keys a later camsim added, at their defaults, leave the physics and the digest alone
    # (motion synthesis, issue 27: a segment's continuity, degree, velocity, start, end,
    # points; the cam's compensation).
    unset = (None, {}, [])
    for seg in d["cam"].get("segments") or []:
        for key in ("continuity", "degree", "velocity", "start", "end", "points"):
            if key in seg and seg[key] in unset:
                del seg[key]
    if d["cam"].get("compensation", 0) is None:
        del d["cam"]["compensation"]
    # Quadratic damping (issue 43) at its default 0 adds nothing.
    for row in d["elements"]:
        if row.get("quadratic_damping", None) == 0.0:
            del row["quadratic_damping"]
    sim = {k: v for k, v in d["simulation"].items() if k != "sample_rate"}
    if sim.get("steady_state") == "warmup":  # issue 42's key at its default: the warm-up as before
        del sim["steady_state"]
    physics = {"cam": d["cam"], "masses": d["masses"], "elements": d["elements"],
               "initial": d["initial"], "simulation": sim}
    return hashlib.sha256(json.dumps(physics, sort_keys=True).encode()).hexdigest()


def make(name: str) -> Path:
    """Compute and write the reference of ``machines/<name>.toml`` (or a test machine,
    :data:`TEST_MACHINES`); return the file path."""
    relative = TEST_MACHINES.get(name, f"machines/{name}.toml")
    path = ROOT / relative
    machine = load_machine(path)
    t_start = time.perf_counter()
    ref = ReferenceSolver(machine, rtol=RTOL, method=METHOD).run(sample_rate=SAMPLE_RATE)
    elapsed = time.perf_counter() - t_start
    arrays: dict[str, np.ndarray] = {"time": ref.time}
    for mass, traces in ref.masses.items():
        for quantity, values in traces.items():
            arrays[f"{mass}/{quantity}"] = np.asarray(values, dtype=float)
    arrays["event_time"] = np.array([e[0] for e in ref.events], dtype=float)
    arrays["event_element"] = np.array([e[1] for e in ref.events], dtype="U32")
    arrays["event_kind"] = np.array([e[2] for e in ref.events], dtype="U16")
    arrays["event_rate"] = np.array([e[3] for e in ref.events], dtype=float)
    t_rec = machine.simulation.warmup_cycles * ReferenceSolver(machine).cam.period if machine.cam is not None else 0.0
    reengage = [e for e in ref.all_events if e[2] == "reengage" and e[0] >= t_rec - 1e-12]
    arrays["reengage_time"] = np.array([e[0] - t_rec for e in reengage], dtype=float)
    arrays["reengage_element"] = np.array([e[1] for e in reengage], dtype="U32")
    meta = {
        "machine": relative,
        "machine_sha256": machine_digest(machine),
        "solver": "tests/reference/reference_solver.py (scipy.integrate.solve_ivp, terminal events)",
        "method": METHOD,
        "rtol": RTOL,
        "atol_displacement_m": ATOL_X,
        "atol_velocity_m_per_s": ATOL_V,
        "sample_rate_hz": SAMPLE_RATE,
        "warmup_cycles": machine.simulation.warmup_cycles,
        "cycles": machine.simulation.cycles,
        "masses": [m.name for m in machine.masses],
    }
    arrays["meta"] = np.array(json.dumps(meta, sort_keys=True))
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    out = OUT_DIR / f"{name}.npz"
    np.savez_compressed(out, **arrays)
    print(f"{out.relative_to(ROOT)}: {len(ref.time)} samples, {len(ref.events)} events, "
          f"{out.stat().st_size / 1e3:.0f} kB, {elapsed:.1f} s", file=sys.stderr)
    return out


def make_extremes(name: str) -> Path:
    """The extremes of ``machines/<name>.toml``'s recorded revolution located on the
    reference's dense solution (:func:`reference_solver.located_extremes`): each contact's
    and link's peak force per piece, each free mass's peak |acceleration|; written to
    ``tests/data/reference/<name>_extremes.json`` (spec §4: camsim's located extremes are
    tested against it, tests/run/test_located_extremes.py)."""
    machine = load_machine(ROOT / "machines" / f"{name}.toml")
    solver = ReferenceSolver(machine, rtol=RTOL, method=METHOD)
    t_start = time.perf_counter()
    data = located_extremes(solver, machine.simulation.warmup_cycles, machine.simulation.cycles)
    data["meta"] = {"machine": f"machines/{name}.toml", "machine_sha256": machine_digest(machine), "method": METHOD,
                    "rtol": RTOL, "located": "best of 4001 dense-output samples per piece, then bounded Brent"}
    out = OUT_DIR / f"{name}_extremes.json"
    out.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    print(f"{out.relative_to(ROOT)}: {time.perf_counter() - t_start:.1f} s", file=sys.stderr)
    return out


def main(argv: list[str]) -> None:
    for name in argv or MACHINES:
        make(name)
        if name not in TEST_MACHINES:  # the issue-34 test machines check events and traces only
            make_extremes(name)


if __name__ == "__main__":
    main(sys.argv[1:])

"""Digest every output dataset of every shipped and test machine (refactor guard).

    python scripts/golden.py                 # compare with scripts/golden-digests.json
    python scripts/golden.py --write         # record the digests (before a refactor)
    python scripts/golden.py --save DIR      # also keep the arrays in DIR/<case>.npz
    python scripts/golden.py --against DIR   # on a digest mismatch, the largest relative
                                             # difference against DIR's full arrays
    python scripts/golden.py --strict        # any bit that moved is a failure

A *case* is one machine run through the library exactly as ``camsim run`` does
(``load_machine`` → ``simulate`` → ``write_run``), with and without impact. Every
dataset of the written HDF5 file (traces, the event table, the cam file datasets) is
hashed with SHA-256 over its raw bytes, so "bit-identical" means what it says. Root
attributes that name the camsim version are left out: they change with every release.

The cases are ``machines/*.toml`` (all but the ``lump`` parts file) and the small
machines the engine tests define (tests/test_engine_analytic.py, tests/cli/test_run_cli.py).
Digests are bit-level, and BLAS kernels round differently on different CPUs (AVX2 against
AVX-512). So each float dataset's record also keeps its peak |value| and its values at
SAMPLES evenly spaced indices (plus the index of the peak): a dataset whose bits moved is
reported with its largest relative difference at those points, |new − old| / peak(old),
and a case whose datasets all moved by no more than ``--tolerance`` (default 1e-12 of the
peak: rounding, not a change) reads "same to 3e-15", not as a failure. ``--strict``
demands bit identity (the refactor guard on the machine that recorded the digests).

A refactor that must not change the numbers is checked by running this before (``--write
--save /tmp/golden``) and after (``--strict --against /tmp/golden``, whose full arrays give
the exact largest difference): exit 0 when every case holds, 1 otherwise, listing each
dataset that moved and by how much.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DIGESTS = ROOT / "scripts" / "golden-digests.json"
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

#: Root attributes that change with the release, not with the numbers.
_VOLATILE_ATTRS = {"camsim_version"}
#: Values of each float dataset kept in the record (evenly spaced, ends included).
SAMPLES = 33
#: Default largest relative difference that still reads as "the same numbers" (rounding).
TOLERANCE = 1e-12


def _test_machines() -> dict[str, str]:
    """Machine texts the engine tests define, by a readable case name."""
    import test_engine_analytic as ea  # noqa: PLC0415 - test module, found through sys.path
    from cli import test_run_cli as rc  # noqa: PLC0415

    texts = {
        "test-bounce": ea.BOUNCE_TOML,
        "test-rest": ea.REST_TOML,
        "test-oscillator": rc.OSCILLATOR,
        "test-driven": rc.DRIVEN,
    }
    for law in ("poly345", "poly4567", "harmonic"):
        texts[f"test-base-{law}"] = ea._base_toml(law)
    for phase in (0.0, 0.5):
        texts[f"test-graze-{phase}"] = ea._graze_toml(phase)
    return texts


def cases() -> dict[str, tuple[str, str, Path]]:
    """case name -> (TOML text, source name, base directory)."""
    out = {}
    for path in sorted((ROOT / "machines").glob("*.toml")):
        text = path.read_text(encoding="utf-8")
        if "[[part]]" in text or "[lever" in text:  # a lump parts file, not a machine
            continue
        out[path.stem] = (text, f"machines/{path.name}", path.parent)
    for name, text in _test_machines().items():
        out[name] = (text, f"<{name}>", ROOT)
    return out


def _dataset_bytes(dset: h5py.Dataset) -> bytes:
    """The dataset's values as bytes: raw for numbers, text for strings (an object array's
    raw bytes would be pointers), column by column for a table."""
    data = dset[()]
    if not isinstance(data, np.ndarray):
        return repr(data).encode()
    columns = data.dtype.names or (None,)
    out = []
    for col in columns:
        values = data if col is None else data[col]
        if values.dtype.kind in "OSU":
            out.append(json.dumps([v.decode() if isinstance(v, bytes) else str(v) for v in values.ravel()]).encode())
        else:
            out.append(np.ascontiguousarray(values).tobytes())
    return b"\0".join(out)


def digest_file(path: Path) -> tuple[dict[str, str], dict[str, np.ndarray]]:
    """SHA-256 of every dataset (and of the stable root attributes), and the float arrays."""
    digests: dict[str, str] = {}
    arrays: dict[str, np.ndarray] = {}
    with h5py.File(path, "r") as f:
        attrs = {k: str(v) for k, v in f.attrs.items() if k not in _VOLATILE_ATTRS}
        digests["@root"] = hashlib.sha256(json.dumps(attrs, sort_keys=True).encode()).hexdigest()

        def visit(name: str, item) -> None:
            if isinstance(item, h5py.Dataset):
                digests[name] = hashlib.sha256(_dataset_bytes(item)).hexdigest()
                data = item[()]
                if isinstance(data, np.ndarray):
                    if data.dtype.names:
                        for col in data.dtype.names:
                            if data[col].dtype.kind == "f":
                                arrays[f"{name}:{col}"] = np.asarray(data[col])
                    elif data.dtype.kind == "f":
                        arrays[name] = data

        f.visititems(visit)
    return digests, arrays


def fingerprint(values: np.ndarray) -> dict:
    """Peak |value|, and the values at SAMPLES evenly spaced indices and at the peak."""
    flat = np.asarray(values, dtype=float).ravel()
    if flat.size == 0:
        return {"n": 0, "peak": 0.0, "index": [], "values": []}
    finite = np.where(np.isfinite(flat), np.abs(flat), -1.0)
    peak_at = int(np.argmax(finite))
    index = sorted(set(np.linspace(0, flat.size - 1, min(SAMPLES, flat.size)).round().astype(int).tolist()) | {peak_at})
    return {"n": int(flat.size), "peak": float(max(finite[peak_at], 0.0)), "index": index, "values": [float(flat[i]) for i in index]}


def record_of(digests: dict[str, str], arrays: dict[str, np.ndarray]) -> dict[str, dict]:
    """The recorded form of a case: per dataset its SHA-256 and, for float data, fingerprints
    per float column (key ``""`` for a plain array)."""
    out: dict[str, dict] = {}
    for key, sha in digests.items():
        entry: dict = {"sha256": sha}
        columns = {name.partition(":")[2]: arr for name, arr in arrays.items() if name == key or name.startswith(key + ":")}
        if columns:
            entry["float"] = {col: fingerprint(arr) for col, arr in sorted(columns.items())}
        out[key] = entry
    return out


def sampled_difference(entry: dict, key: str, arrays: dict[str, np.ndarray]) -> float | None:
    """Largest |new − old| / peak(old) at the recorded points of dataset ``key`` (None when
    the record keeps no float values for it; inf when the shape changed)."""
    worst = None
    for col, fp in (entry.get("float") or {}).items():
        new = arrays.get(key if col == "" else f"{key}:{col}")
        if new is None or new.size != fp["n"]:
            return float("inf")
        flat = np.asarray(new, dtype=float).ravel()
        old = np.asarray(fp["values"], dtype=float)
        cur = flat[np.asarray(fp["index"], dtype=int)] if fp["index"] else old
        both_nan = np.isnan(old) & np.isnan(cur)
        diff = np.where(both_nan, 0.0, np.abs(cur - old))
        if np.isnan(diff).any():
            return float("inf")
        scale = fp["peak"]
        value = float(diff.max(initial=0.0)) / scale if scale > 0 else float(diff.max(initial=0.0))
        worst = value if worst is None else max(worst, value)
    return worst


def run_case(text: str, source: str, base_dir: Path, no_impact: bool, workdir: Path):
    from camsim.run.runfile import write_run
    from camsim.machine.loader import load_machine_text
    from camsim.run.simulation import simulate

    machine = load_machine_text(text, source=source, base_dir=base_dir)
    result = simulate(machine, no_impact=no_impact)
    target = workdir / "run.h5"
    write_run(result, target)
    return digest_file(target)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="record the digests in scripts/golden-digests.json")
    parser.add_argument("--save", type=Path, help="keep the float arrays of each case in DIR/<case>.npz")
    parser.add_argument("--against", type=Path, help="arrays saved earlier with --save, to size a mismatch")
    parser.add_argument("--strict", action="store_true", help="any dataset whose bits moved is a failure")
    parser.add_argument("--tolerance", type=float, default=TOLERANCE,
                        help=f"largest relative difference (of each dataset's peak) that reads as the same numbers (default {TOLERANCE:g})")
    parser.add_argument("only", nargs="*", help="case names (default: all)")
    args = parser.parse_args(argv)
    recorded = json.loads(DIGESTS.read_text()) if DIGESTS.exists() else {}
    current: dict[str, dict[str, str]] = {}
    failures = 0
    with tempfile.TemporaryDirectory() as tmp:
        for name, (text, source, base_dir) in cases().items():
            for no_impact in (False, True):
                case = f"{name}{'+no-impact' if no_impact else ''}"
                if args.only and name not in args.only and case not in args.only:
                    continue
                digests, arrays = run_case(text, source, base_dir, no_impact, Path(tmp))
                current[case] = record_of(digests, arrays)
                if args.save:
                    args.save.mkdir(parents=True, exist_ok=True)
                    np.savez(args.save / f"{case}.npz", **{k.replace("/", "|"): v for k, v in arrays.items()})
                if args.write:
                    print(f"{case}: {len(digests)} datasets")
                    continue
                want = recorded.get(case)
                if want is None:
                    print(f"{case}: no recorded digests")
                    failures += 1
                    continue
                want = {k: (v if isinstance(v, dict) else {"sha256": v}) for k, v in want.items()}
                moved = sorted(k for k in set(want) | set(digests) if want.get(k, {}).get("sha256") != digests.get(k))
                if not moved:
                    print(f"{case}: {len(digests)} datasets bit-identical")
                    continue
                saved = None
                if args.against and (args.against / f"{case}.npz").exists():
                    saved = np.load(args.against / f"{case}.npz")
                sizes: dict[str, float | None] = {}
                for key in moved:
                    if key not in want or key not in digests:
                        sizes[key] = float("inf")  # a dataset added or removed
                    elif saved is not None:
                        sizes[key] = _relative_difference(key, arrays, saved)
                    else:
                        sizes[key] = sampled_difference(want[key], key, arrays)
                known = [s for s in sizes.values() if s is not None]
                worst = max(known) if known else None
                same = len(known) == len(sizes) and worst <= args.tolerance
                where = "at the full arrays" if saved is not None else "at the recorded points"
                if same and not args.strict:
                    print(f"{case}: same to {worst:.2g} of each peak ({len(moved)} of {len(want)} datasets differ in their last bits, {where})")
                    continue
                failures += 1
                print(f"{case}: {len(moved)} of {len(want)} datasets differ" + (f", by up to {worst:.3g} of the peak ({where})" if worst is not None else ""))
                for key in moved:
                    size = sizes[key]
                    detail = "" if size is None else (" (added or removed, or its shape changed)" if size == float("inf") else f" (largest relative difference {size:.3g})")
                    print(f"    {key}{detail}")
    if args.write:
        if args.only:
            recorded.update(current)
            current = recorded
        DIGESTS.write_text(json.dumps(current, indent=1, sort_keys=True) + "\n")
        print(f"wrote {DIGESTS.relative_to(ROOT)}")
        return 0
    return 1 if failures else 0


def _relative_difference(key: str, arrays: dict[str, np.ndarray], saved) -> float | None:
    """Largest |new − old| / max|old| over the float arrays of dataset ``key``."""
    worst = None
    for name, new in arrays.items():
        if name != key and not name.startswith(key + ":"):
            continue
        store = name.replace("/", "|")
        if store not in saved.files:
            continue
        old = saved[store]
        if old.shape != new.shape:
            return float("inf")
        finite = np.abs(old[np.isfinite(old)])
        scale = float(finite.max()) if finite.size else 0.0
        both_nan = np.isnan(old) & np.isnan(new)
        diff = np.where(both_nan, 0.0, np.abs(new - old))
        value = float(np.nanmax(diff)) / scale if scale > 0 else float(np.nanmax(diff, initial=0.0))
        worst = value if worst is None else max(worst, value)
    return worst


if __name__ == "__main__":
    raise SystemExit(main())

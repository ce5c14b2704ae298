"""Readers that distrust, values that cannot overflow (issue 45, items 5 and 6).

References: the issue's damaged results. Before the fix, 16 flipped bytes in the HDF5
metadata of a run, compare, sweep, study or optimize file ended `export`, `check` and
`report` in "internal error (KeyError ... incorrect metadata checksum)", exit 1, without
naming the file; NaN or 1e300 in a trace or a reversed /time passed `report`, `plot` and
`export` with exit 0; a study file without its attributes reported "samples / runs None /
None"; `initial.<mass>.velocity = 1e+300` ran to exit 0, and `gap = 1e+300` printed numpy's
overflow warnings before its error. The damage is seeded (random.Random(seed)) so that each
case is the same on every run; the metadata bytes are those outside every dataset's raw data
(h5py's storage offsets).
"""

from __future__ import annotations

import random
import shutil
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from camsim.cli import app

ROOT = Path(__file__).resolve().parents[2]
BARKAN = str(ROOT / "machines" / "barkan-follower.toml")
FAST = ["--sample-rate", "2kHz", "-q"]
runner = CliRunner()


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> dict[str, Path]:
    """One small file of each kind (Barkan's follower at 2 kHz)."""
    d = tmp_path_factory.mktemp("results")
    commands = {
        "run": ["run", BARKAN, "-o", str(d / "run.h5")],
        "compare": ["compare", BARKAN, "-o", str(d / "compare.h5")],
        "sweep": ["sweep", BARKAN, "--vary", "cam.speed=100:300:100rpm", "--workers", "1", "-o", str(d / "sweep.h5")],
        "study": ["study", BARKAN, "--dist", "element.closure.preload=normal:40N:1N", "-n", "4", "--workers", "1",
                  "-o", str(d / "study.h5")],
        "optimize": ["optimize", BARKAN, "--var", "element.closure.preload=20:60N", "--minimize",
                     "max_cam_contact_force", "--budget", "4", "--workers", "1", "-r", str(d / "optimize.h5")],
    }
    out = {}
    for kind, args in commands.items():
        r = runner.invoke(app, args + FAST)
        assert r.exit_code == 0, (kind, r.stderr)
        out[kind] = d / f"{kind}.h5"
    return out


def _metadata_bytes(path: Path) -> np.ndarray:
    """Offsets of the bytes of ``path`` that are not raw data of a dataset (superblock, object
    headers, B-trees, heaps)."""
    mask = np.ones(path.stat().st_size, bool)
    with h5py.File(path, "r") as f:
        def visit(_, item):
            if isinstance(item, h5py.Dataset):
                if item.chunks is None:
                    offset = item.id.get_offset()
                    if offset is not None:
                        mask[offset:offset + item.id.get_storage_size()] = False
                else:
                    for k in range(item.id.get_num_chunks()):
                        info = item.id.get_chunk_info(k)
                        mask[info.byte_offset:info.byte_offset + info.size] = False
        f.visititems(visit)
    return np.flatnonzero(mask)


COMMANDS = {
    "export": lambda p, d, ref: ["export", str(p), "-o", str(d / "out.csv")],
    "check": lambda p, d, ref: ["check", str(p), "--against", str(ref)],
    "report": lambda p, d, ref: ["report", str(p), "-o", str(d / "out.html")],
}
READERS = {"run": ("export", "check", "report"), "compare": ("export", "check", "report"), "sweep": ("export", "report"),
           "study": ("report",), "optimize": ("report",)}


def _flip_params():
    out = []
    for kind, commands in READERS.items():
        for command in commands:
            fast = kind == "run" and command != "report"
            out.append(pytest.param(kind, command, id=f"{kind}-{command}", marks=() if fast else (pytest.mark.slow,)))
    return out


@pytest.mark.parametrize("kind,command", _flip_params())
def test_flipped_metadata_bytes_are_bad_input_naming_the_file(kind, command, results, tmp_path):
    """16 flipped metadata bytes, 8 seeded trials: exit 0 (the damage missed what the command
    reads) or exit 2 with one line naming the file; never "internal error", never exit 1."""
    src = results[kind]
    data = src.read_bytes()
    meta = _metadata_bytes(src)
    damaged = tmp_path / f"flipped-{kind}.h5"
    refused = 0
    for seed in range(8):
        rng = random.Random(seed)
        b = bytearray(data)
        for i in rng.sample(list(meta), 16):
            b[i] ^= 0xFF
        damaged.write_bytes(bytes(b))
        r = runner.invoke(app, COMMANDS[command](damaged, tmp_path, src))
        text = r.stderr
        assert "internal error" not in text and "Traceback" not in text, (seed, text)
        assert r.exit_code in (0, 2), (seed, r.exit_code, text)
        if r.exit_code == 2:
            refused += 1
            lines = [line for line in text.splitlines() if line.startswith("camsim: error:")]
            assert len(lines) == 1 and damaged.name in lines[0], (seed, text)
    assert refused, "no trial damaged anything the command reads: the test would not see a failure"


@pytest.mark.parametrize("damage,where", [("nan", "/masses/F/velocity"), ("huge", "/masses/F/displacement"),
                                          ("reversed", "/time")])
@pytest.mark.parametrize("command", ["export", "plot", "report"])
def test_values_the_layout_refuses(damage, where, command, results, tmp_path):
    """NaN or 1e300 in a trace, a reversed /time: exit 2 naming the
    file and the dataset (they passed report, plot and export with exit 0)."""
    path = tmp_path / "bad.h5"
    shutil.copy(results["run"], path)
    with h5py.File(path, "r+") as f:
        if damage == "nan":
            f["masses/F/velocity"][3] = np.nan
        elif damage == "huge":
            f["masses/F/displacement"][3] = 1e300
        else:
            f["time"][...] = f["time"][()][::-1]
    args = {"export": ["export", str(path), "-o", str(tmp_path / "o.csv")],
            "plot": ["plot", str(path), "-o", str(tmp_path / "o.png")],
            "report": ["report", str(path), "-o", str(tmp_path / "o.html")]}[command]
    r = runner.invoke(app, args)
    assert r.exit_code == 2, r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "bad.h5" in lines[0] and where in lines[0], r.stderr
    assert not [p for p in tmp_path.iterdir() if p.name.startswith("o.")]


def test_a_study_without_its_attributes_is_refused(results, tmp_path):
    """A study file stripped of its /study attributes reported "samples / runs None / None"."""
    path = tmp_path / "study.h5"
    shutil.copy(results["study"], path)
    with h5py.File(path, "r+") as f:
        for key in list(f["study"].attrs):
            del f["study"].attrs[key]
    r = runner.invoke(app, ["report", str(path), "-o", str(tmp_path / "o.html")])
    assert r.exit_code == 2, r.stderr
    assert "study.h5" in r.stderr and "/study" in r.stderr and "summary_json" in r.stderr, r.stderr


@pytest.mark.parametrize("key,value", [("initial.F.velocity", "1e+300"), ("element.roller.gap", "1e+300"),
                                       ("element.closure.preload", "1e35 N"), ("mass.F.mass", "1e31 kg")])
def test_values_beyond_the_range_are_refused_at_load(key, value, tmp_path):
    """One line naming the file and the key, exit 2, no numpy warning: `initial.ball.velocity =
    1e+300` ran to a 1.2e299 m peak with exit 0, `gap = 1e+300` printed overflow warnings."""
    out = tmp_path / "r.h5"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a numpy RuntimeWarning fails the test
        r = runner.invoke(app, ["run", BARKAN, "--set", f"{key}={value}", "-o", str(out)])
    assert r.exit_code == 2, r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, r.stderr
    assert "barkan-follower.toml" in lines[0] and "beyond the range" in lines[0] and key.rsplit(".", 1)[1] in lines[0]
    assert "Warning" not in r.stderr and not out.exists()

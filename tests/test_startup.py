"""Fast start (issue 25 item 5): what the commands import, and pint's disk cache.

Structural checks, not timings (those are in bench/bench_startup.py): ``camsim --help``
imports none of scipy, matplotlib, h5py and pint (checked on ``sys.modules`` in a fresh
subprocess); ``camsim validate`` none of h5py, matplotlib and scipy.linalg. The cached pint
registry is checked against pint without a cache (the independent reference: pint parsing
its definition files) on every quantity of the shipped machine files: the same SI magnitude,
bit for bit, and the same dimensionality.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from camsim import units

ROOT = Path(__file__).resolve().parents[1]

PROBE = """
import json, sys
sys.argv = ["camsim"] + sys.argv[1:]
try:
    from camsim.cli import main
    main()
except SystemExit:
    pass
json.dump(sorted(sys.modules), sys.__stderr__)
"""


def modules_after(*args: str, env: dict | None = None) -> set[str]:
    proc = subprocess.run([sys.executable, "-c", PROBE, *args], capture_output=True, text=True, cwd=ROOT,
                          env=env, timeout=300)
    return set(json.loads(proc.stderr.strip().splitlines()[-1]))


def _top(mods: set[str]) -> set[str]:
    return {m.split(".")[0] for m in mods}


def test_help_imports_no_heavy_module():
    """camsim --help: no scipy, matplotlib, h5py or pint in sys.modules."""
    mods = _top(modules_after("--help"))
    assert not mods & {"scipy", "matplotlib", "h5py", "pint"}, sorted(mods & {"scipy", "matplotlib", "h5py", "pint"})


def test_validate_imports_no_result_or_solver_module():
    """camsim validate: no h5py, matplotlib or scipy.linalg (it needs pint and numpy only)."""
    mods = modules_after("validate", "machines/cdtm.toml")
    assert not _top(mods) & {"h5py", "matplotlib"}
    assert "scipy.linalg" not in mods


def _quantities() -> list[str]:
    """Every string value with a unit in the shipped machine files."""
    found: set[str] = set()

    def walk(node):
        if isinstance(node, dict):
            for v in node.values():
                walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)
        elif isinstance(node, str) and re.match(r"^\s*[-+]?[\d.]", node):
            found.add(node)

    for path in sorted((ROOT / "machines").glob("*.toml")):
        walk(tomllib.loads(path.read_text()))
    return sorted(found)


def test_cached_registry_parses_as_pint_does(tmp_path):
    """A registry built from the cache (second build in the same folder) and the one that
    filled it give every quantity of machines/*.toml the same base-unit magnitude (exact) and
    dimensionality as pint without a cache."""
    texts = _quantities()
    assert len(texts) > 30
    reference = units.build_registry(None)
    units.build_registry(tmp_path)  # fills the cache
    assert list(tmp_path.iterdir()), "pint wrote no cache"
    cached = units.build_registry(tmp_path)
    for text in texts:
        a = reference.Quantity(text).to_base_units()
        b = cached.Quantity(text).to_base_units()
        assert a.magnitude == b.magnitude, text
        assert a.dimensionality == b.dimensionality, text
        assert str(a.units) == str(b.units), text


def test_corrupt_cache_falls_back(tmp_path):
    """Cache files overwritten with garbage (a half-written file): the registry is still built,
    and parses as pint does."""
    units.build_registry(tmp_path)
    for f in tmp_path.iterdir():
        if f.is_file():
            f.write_bytes(b"\x00not a pickle")
    ureg = units.build_registry(tmp_path)
    assert ureg.Quantity("25.62 lbf/in").to("N/m").magnitude == pytest.approx(25.62 * 4.4482216152605 / 0.0254, rel=1e-15)


def test_unusable_cache_folder_is_none(tmp_path, monkeypatch):
    """$CAMSIM_CACHE_DIR under a regular file (mkdir fails, as in a read-only home; a test
    running as root would pass a permission check) or empty: no cache, no error."""
    blocker = tmp_path / "file"
    blocker.write_text("x")
    monkeypatch.setenv(units.CACHE_ENV, str(blocker / "cache"))
    assert units.cache_folder() is None
    monkeypatch.setenv(units.CACHE_ENV, "")
    assert units.cache_folder() is None
    monkeypatch.setenv(units.CACHE_ENV, str(tmp_path / "c"))
    assert units.cache_folder() == tmp_path / "c" / "pint"


@pytest.mark.slow
def test_validate_runs_with_an_unusable_cache(tmp_path):
    """camsim validate with the cache folder impossible to create: exit 0, the same output."""
    blocker = tmp_path / "file"
    blocker.write_text("x")
    env = dict(os.environ, **{units.CACHE_ENV: str(blocker / "cache")})
    bad = subprocess.run([sys.executable, "-m", "camsim", "validate", "machines/cdtm.toml"], capture_output=True,
                         text=True, cwd=ROOT, env=env, timeout=300)
    env[units.CACHE_ENV] = str(tmp_path / "cache")
    good = subprocess.run([sys.executable, "-m", "camsim", "validate", "machines/cdtm.toml"], capture_output=True,
                          text=True, cwd=ROOT, env=env, timeout=300)
    assert bad.returncode == 0 and good.returncode == 0, bad.stderr + good.stderr
    assert bad.stdout + bad.stderr == good.stdout + good.stderr


def test_pint_import_leaves_dask_importable():
    """pint is imported with dask hidden (camsim.units._import_pint); dask stays importable."""
    pytest.importorskip("dask")
    code = ("import sys; from camsim.units import registry; registry(); "
            "assert 'dask' not in sys.modules; import dask.base; print('ok')")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert proc.stdout.strip() == "ok", proc.stderr

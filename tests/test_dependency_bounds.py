"""The committed lowest-versions constraints agree with pyproject.toml's lower bounds.

Reference: scripts/lowest_constraints.py run on pyproject.toml (the file is that script's
output, so the two cannot drift); the bound parser checked on hand-written requirements.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "scripts" / "lowest_constraints.py"


def _module():
    spec = importlib.util.spec_from_file_location("lowest_constraints", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_committed_constraints_equal_the_generated_ones():
    result = subprocess.run(
        [sys.executable, str(SCRIPT), "--check", str(ROOT / ".ci" / "constraints-lowest.txt")],
        capture_output=True, text=True,
    )
    assert result.returncode == 0, result.stderr


def test_bounds_extras_duplicates_and_missing_bound(tmp_path):
    mod = _module()
    text = mod.constraints({"project": {
        "name": "camsim",
        "dependencies": ["numpy>=1.26", "typer>=0.16,<1"],
        "optional-dependencies": {"a": ["dask[distributed]>=2024.1", "pandas>=2.0"], "b": ["pandas>=2.1", "camsim[a]"]},
    }})
    assert text.splitlines()[3:] == ["dask==2024.1", "numpy==1.26", "pandas==2.1", "typer==0.16"]
    bad = tmp_path / "pyproject.toml"
    bad.write_text('[project]\nname = "x"\ndependencies = ["plotly"]\n')
    result = subprocess.run([sys.executable, str(SCRIPT), "--pyproject", str(bad)], capture_output=True, text=True)
    assert result.returncode == 2 and "plotly" in result.stderr and result.stderr.count("\n") == 1
    out = tmp_path / "c.txt"
    out.write_text("numpy==1.0\n")
    result = subprocess.run([sys.executable, str(SCRIPT), "--check", str(out)], capture_output=True, text=True)
    assert result.returncode == 1


@pytest.mark.parametrize("req", ["plotly", "bokeh<4", "x!=1.0"])
def test_no_lower_bound_is_an_error(req):
    mod = _module()
    with pytest.raises(mod.BoundError, match=req.split("<")[0].split("!")[0]):
        mod.constraints({"project": {"name": "camsim", "dependencies": [req]}})

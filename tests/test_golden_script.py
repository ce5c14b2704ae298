"""scripts/golden.py (issue 25 item 6): a digest mismatch is sized, so rounding on another CPU
reads as "same to 3e-15" and a real change does not.

Reference: the perturbations are made in the test, so the expected relative differences are
known exactly (|δ| / peak of the unperturbed array).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("golden_script", ROOT / "scripts" / "golden.py")
golden = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(golden)


def _record(arrays):
    digests = {key.partition(":")[0]: "sha-of-" + key.partition(":")[0] for key in arrays}
    return golden.record_of(digests, arrays)


def test_rounding_sized_at_the_recorded_points():
    """A last-bits change (3e-15 of the peak at the peak itself) is found at the peak, which
    every record keeps, to 1e-3 of its size."""
    t = np.linspace(0.0, 1.0, 10_001)
    x = np.sin(7.0 * t) * 2.5
    record = _record({"masses/M1/displacement": x})["masses/M1/displacement"]
    moved = x.copy()
    peak_at = int(np.argmax(np.abs(x)))
    moved[peak_at] += 3e-15 * 2.5
    size = golden.sampled_difference(record, "masses/M1/displacement", {"masses/M1/displacement": moved})
    assert size == pytest.approx(3e-15, rel=1e-3)
    assert size <= golden.TOLERANCE


def test_a_real_change_is_sized_not_hidden():
    """A change of 1e-6 of the peak everywhere is reported as 1e-6 (to 1e-9), far above the
    tolerance."""
    x = np.cos(np.linspace(0.0, 20.0, 5000)) * 4.0
    record = _record({"elements/seat/force": x})["elements/seat/force"]
    size = golden.sampled_difference(record, "elements/seat/force", {"elements/seat/force": x + 4e-6})
    assert size == pytest.approx(1e-6, rel=1e-9)
    assert size > golden.TOLERANCE


def test_table_columns_and_shape_changes():
    """Event tables are sized column by column; a different number of rows is infinite."""
    times = np.array([0.1, 0.2, 0.35])
    speed = np.array([-0.4, np.nan, -0.2])
    record = _record({"events:time": times, "events:relative_velocity": speed})["events"]
    same = golden.sampled_difference(record, "events", {"events:time": times, "events:relative_velocity": speed})
    assert same == 0.0
    more = golden.sampled_difference(record, "events", {"events:time": np.append(times, 0.4), "events:relative_velocity": np.append(speed, 0.0)})
    assert more == float("inf")

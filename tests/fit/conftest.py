"""Fixtures of the fit tests: the small machines of machines.py written to files."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from machines import DRIVEN, OSCILLATOR, PRODUCT  # noqa: E402


@pytest.fixture
def driven(tmp_path: Path) -> Path:
    path = tmp_path / "driven.toml"
    path.write_text(DRIVEN)
    return path


@pytest.fixture
def oscillator(tmp_path: Path) -> Path:
    path = tmp_path / "osc.toml"
    path.write_text(OSCILLATOR)
    return path


@pytest.fixture
def product(tmp_path: Path) -> Path:
    path = tmp_path / "product.toml"
    path.write_text(PRODUCT)
    return path

"""Shared fixtures: paths of the repository, the case study and the shared Duplex IFC."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
CASE_STUDY = REPO / "data" / "case_study"
DUPLEX = CASE_STUDY / "model" / "Duplex_A_20110907.ifc"


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def duplex_ifc() -> Path:
    if not DUPLEX.is_file():  # pragma: no cover - the case study ships it
        pytest.skip("Duplex IFC not present")
    return DUPLEX

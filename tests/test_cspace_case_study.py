"""Configuration-space builds on the case study (world layer, B4/B5): ``cspace_fft.free_maps`` on windows
of the Duplex's storey map (the 2022-05-10 state, storage outside) gives the free maps of the build before
session 11 (the grid padded with occupied cells, each bin transformed for itself) and of a binary dilation,
cell for cell, for the robot's base and the case study's carry footprints."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kbplanner.model.dates import parse_date
from kbplanner.project import Project
from kbplanner.world import cspace_fft
from kbplanner.world.build import build_world
from kbplanner.world.footprint import Footprint, Rect
from kbplanner.world.maps import storey_map
from test_cspace_unpadded import CARRIED, _dilated, _padded_build

CASE = Path(__file__).resolve().parents[1] / "data" / "case_study"
pytestmark = pytest.mark.skipif(not (CASE / "project.toml").is_file(), reason="case study not present")
BASE = Footprint((Rect(0.0, 0.0, 0.99, 0.67),), name="base")


@pytest.fixture(scope="module")
def occupied() -> np.ndarray:
    project = Project.load(CASE, scenario="storage-outside")
    world = build_world(project, parse_date(str(project.manifest.simulation["date"])))
    grid = storey_map(world).grid
    assert grid.resolution == pytest.approx(0.05)
    return np.asarray(grid.occupied, dtype=bool)


def _windows(shape: tuple[int, int]) -> list[tuple[int, int, int, int]]:
    """(y0, y1, x0, x1): a corner, the middle, a strip along each axis, as large as B4's and B5's."""
    ny, nx = shape
    return [(0, min(ny, 121), 0, min(nx, 121)),
            (max(0, ny // 2 - 150), min(ny, ny // 2 + 149), max(0, nx // 2 - 200), min(nx, nx // 2 + 199)),
            (ny // 3, min(ny, ny // 3 + 40), 0, min(nx, 400)),
            (0, min(ny, 260), nx - min(nx, 45), nx)]


@pytest.mark.parametrize("fp", [BASE, *CARRIED], ids=lambda f: f.name)
def test_storey_windows_give_the_padded_builds_free_maps(occupied: np.ndarray, fp: Footprint) -> None:
    assert occupied.any()
    for y0, y1, x0, x1 in _windows(occupied.shape):
        occ = occupied[y0:y1, x0:x1]
        free = cspace_fft.free_maps(occ, fp.rects, 0.05, 72, 0.0)
        assert np.array_equal(free, _padded_build(occ, fp, 0.05, 72, 0.0)), (y0, y1, x0, x1)
        for k in (5, 40):
            assert np.array_equal(free[k], _dilated(occ, fp, 0.05, k, 72, 0.0)), (y0, y1, x0, x1, k)

"""Footprints and configuration space: look-ups are conservative but tight, and respect asymmetric loads."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from kbplanner.core.errors import KbplannerError
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

RES = 0.05


def _random_grid(seed: int) -> OccupancyGrid:
    rng = np.random.default_rng(seed)
    occ = np.zeros((80, 120), dtype=bool)
    for _ in range(12):
        x, y = rng.integers(0, 120), rng.integers(0, 80)
        w, h = rng.integers(1, 12), rng.integers(1, 12)
        occ[y : y + h, x : x + w] = True
    return OccupancyGrid(occ, origin=(-1.0, 2.0), resolution=RES)


def _occupied_cells(grid: OccupancyGrid) -> shapely.Geometry:
    iy, ix = np.nonzero(grid.occupied)
    x0 = grid.origin[0] + ix * RES
    y0 = grid.origin[1] + iy * RES
    return shapely.union_all(shapely.box(x0, y0, x0 + RES, y0 + RES))


@pytest.mark.parametrize("seed", [1, 2])
def test_a_free_look_up_means_the_exact_footprint_touches_no_occupied_cell(seed: int) -> None:
    grid = _random_grid(seed)
    fp = Footprint((Rect(0.0, 0.0, 0.99, 0.67), Rect(0.3, 0.0, 0.4, 1.2, yaw=0.2)), name="base+load")
    cs = ConfigurationSpace.build(grid, fp, n_yaw_bins=72)
    obstacles = _occupied_cells(grid)
    rng = np.random.default_rng(seed)
    ext = grid.extent
    sweep = fp.radius_m * cs.bin_width  # how far a corner moves within a yaw bin
    n_free = n_loose = 0
    for x, y, yaw in zip(rng.uniform(ext.xmin, ext.xmax, 400), rng.uniform(ext.ymin, ext.ymax, 400),
                         rng.uniform(-math.pi, math.pi, 400), strict=True):
        exact = fp.polygon(float(x), float(y), float(yaw))
        area = shapely.box(ext.xmin, ext.ymin, ext.xmax, ext.ymax)
        if cs.is_free(float(x), float(y), float(yaw)):
            n_free += 1
            assert area.contains(exact) and not exact.intersects(obstacles)
        else:
            # The look-up may block up to one cell diagonal plus a yaw bin's sweep more, not beyond.
            grown = exact.buffer(RES * math.sqrt(2) + sweep + 1e-6)
            n_loose += int(area.contains(grown) and not grown.intersects(obstacles))
    assert n_free > 20 and n_loose == 0


def test_an_asymmetric_load_blocks_only_the_side_it_sticks_out() -> None:
    occ = np.zeros((60, 100), dtype=bool)
    occ[:, 60] = True  # a wall at x = 3.0-3.05 m
    grid = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=RES)
    load_ahead = Footprint((Rect(0.0, 0.0, 0.99, 0.67), Rect(0.9, 0.0, 0.8, 0.2)))  # sticks out 1.3 m ahead
    cs = ConfigurationSpace.build(grid, load_ahead)
    assert not cs.is_free(2.0, 1.5, 0.0)  # facing the wall: the load hits it
    assert cs.is_free(2.0, 1.5, math.pi)  # facing away: only the base's 0.5 m rear, 1 m clear
    assert cs.is_free_many([(2.0, 1.5, 0.0), (2.0, 1.5, math.pi)]).tolist() == [False, True]


def test_yaw_bins_wrap_around() -> None:
    grid = OccupancyGrid(np.zeros((40, 40), dtype=bool), origin=(0.0, 0.0), resolution=RES)
    cs = ConfigurationSpace.build(grid, Footprint((Rect(0, 0, 0.5, 0.3),)), n_yaw_bins=72)
    assert cs.yaw_bin(math.pi) == cs.yaw_bin(-math.pi) == 36
    assert cs.yaw_bin(-0.01) == cs.yaw_bin(2 * math.pi - 0.01) == 0


def test_empty_or_degenerate_footprints_are_refused() -> None:
    with pytest.raises(KbplannerError, match="at least one rectangle"):
        Footprint(())
    with pytest.raises(KbplannerError, match="non-positive size"):
        Footprint((Rect(0, 0, 0.0, 0.5),))

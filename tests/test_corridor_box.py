"""The carry cell route's corridor search on the corridor's bounding box (B5, simulation/corridor_cells.py):
the same cells as the search over the whole window (bfs_cells on the window's free maps and the corridor)."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from kbplanner.simulation.cell_path import bfs_cells
from kbplanner.simulation.corridor_cells import CORRIDOR_RADIUS_M, corridor_cells
from kbplanner.simulation.grid_yardstick import shortest_cells
from kbplanner.simulation.nav_path import Pose2D, wrap
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

FP = Footprint((Rect(0, 0, 0.5, 0.3), Rect(0.4, 0.1, 0.2, 0.9, 0.3)), "carry")


def _whole_window(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D) -> list[Pose2D] | None:
    """corridor_cells as it was: the breadth-first search over the whole window."""
    g = cs.grid
    ends = []
    for p in (start, goal):
        ix, iy = g.cell_of(p[0], p[1])
        ends.append((cs.yaw_bin(p[2]), iy, ix))
    if not (cs.free[ends[0]] and cs.free[ends[1]]):
        return None
    path = shortest_cells(cs, start, goal)
    if path is None:
        return None
    off = np.ones(g.shape, dtype=bool)
    ys, xs = zip(*path, strict=True)
    off[list(ys), list(xs)] = False
    near = ndimage.distance_transform_edt(off) <= CORRIDOR_RADIUS_M / g.resolution
    nodes = bfs_cells(cs.free & near[None, :, :], ends[0], ends[1])
    if nodes is None:
        return None
    cell = np.asarray(np.unravel_index(np.asarray(nodes, dtype=np.int64), cs.free.shape), dtype=np.int64).T
    res, (ox, oy), w = g.resolution, g.origin, cs.bin_width
    return [(ox + (float(x) + 0.5) * res, oy + (float(y) + 0.5) * res, wrap(float(b) * w))
            for b, y, x in cell.tolist()]


def test_the_box_search_gives_the_whole_windows_cells() -> None:
    found = 0
    for seed in range(6):
        rng = np.random.default_rng(seed)
        occ = np.zeros((100, 130), dtype=bool)
        occ[0] = occ[-1] = occ[:, 0] = occ[:, -1] = True
        for _ in range(8):
            y, x = rng.integers(0, 100), rng.integers(0, 130)
            occ[y:y + rng.integers(1, 30), x:x + rng.integers(1, 6)] = True
        cs = ConfigurationSpace.build(OccupancyGrid(occ, origin=(0.3, -1.0), resolution=0.05), FP)
        fy, fx = np.nonzero(cs.free[0])
        for _ in range(5):
            i, j = rng.integers(0, len(fy), 2)
            a = (0.3 + (fx[i] + 0.5) * 0.05, -1.0 + (fy[i] + 0.5) * 0.05, 0.0)
            b = (0.3 + (fx[j] + 0.5) * 0.05, -1.0 + (fy[j] + 0.5) * 0.05, 0.0)
            got = corridor_cells(cs, a, b)
            assert got == _whole_window(cs, a, b)
            found += got is not None
    assert found >= 20  # most pairs are joined: the comparison is about paths, not Nones

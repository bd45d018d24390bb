"""Navigation (B5, NV-2), the cell route's search in a corridor: free configuration cells joining start
and goal, searched only near the grid's shortest path.

Takes a :class:`~kbplanner.world.footprint.ConfigurationSpace` and start and goal poses;
:func:`corridor_cells` finds the 8-connected shortest path over the cells where the footprint fits at
some heading (the path-quality yardstick's search, :mod:`kbplanner.simulation.grid_yardstick`), keeps the
free (x, y, yaw bin) cells within ``radius_m`` of it, and searches those breadth-first over face-adjacent
cells (:func:`kbplanner.simulation.cell_path.bfs_cells`): a fraction of the volume the whole window's
search visits. Every cell it returns is free, so the path is as certain as the whole window's; where
the corridor holds none (the load must swing out further to turn), None, and the caller searches the
whole window. Used by :func:`kbplanner.simulation.carry_paths.cells_first`. A route an earlier run
searched over the same configuration space is read instead (:mod:`kbplanner.simulation.cell_store`).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from kbplanner.simulation import cell_store
from kbplanner.simulation.cell_path import bfs_cells
from kbplanner.simulation.grid_yardstick import shortest_cells
from kbplanner.simulation.nav_path import Pose2D, wrap
from kbplanner.world.footprint import ConfigurationSpace

CORRIDOR_RADIUS_M = 0.5  # free cells this close to the grid's shortest path are searched


def corridor_cells(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D,
                   radius_m: float = CORRIDOR_RADIUS_M) -> list[Pose2D] | None:
    """Cell centres (yaw at the bin centre) of a path through face-adjacent free cells within
    ``radius_m`` of the grid's shortest path from start to goal, or None (no such path, or none there)."""
    g = cs.grid
    ny, nx = g.shape
    ends = []
    for p in (start, goal):
        ix, iy = g.cell_of(p[0], p[1])
        if not (0 <= ix < nx and 0 <= iy < ny):
            return None
        ends.append((cs.yaw_bin(p[2]), iy, ix))
    if not (cs.free[ends[0]] and cs.free[ends[1]]):
        return None
    space = None
    if cell_store.active():  # the route an earlier run searched over the same space (cell_store)
        memo_key = ("space_key", float(g.resolution))
        space = cs.path_memo.get(memo_key)
        if space is None:
            space = cs.path_memo[memo_key] = cell_store.space_key(cs.free, g.resolution)
        route_of = (*ends[0], *ends[1], float(radius_m))
        kept, route = cell_store.lookup_route(space, route_of)
        if kept:
            return None if route is None else _centres(cs, np.array(route, dtype=np.int64).reshape(-1, 3))
    cell = _route(cs, start, goal, ends, radius_m)
    if space is not None:
        cell_store.keep_route(space, route_of, None if cell is None else tuple(map(tuple, cell.tolist())))
    return None if cell is None else _centres(cs, cell)


def _centres(cs: ConfigurationSpace, cell: npt.NDArray[np.int64]) -> list[Pose2D]:
    """The centres of cells (bin, y, x) as poses (yaw at the bin centre)."""
    g = cs.grid
    res, (ox, oy), w = g.resolution, g.origin, cs.bin_width
    return [(ox + (float(x) + 0.5) * res, oy + (float(y) + 0.5) * res, wrap(float(b) * w))
            for b, y, x in cell.tolist()]


def _route(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D, ends: list[tuple[int, int, int]],
           radius_m: float) -> npt.NDArray[np.int64] | None:
    """The cells (bin, y, x) of :func:`corridor_cells`' path (its ends' cells free), or None."""
    g = cs.grid
    path = shortest_cells(cs, start, goal)
    if path is None:
        return None
    near, (y0, y1, x0, x1) = corridor_box(g.shape, path, radius_m / g.resolution)
    box = cs.free[:, y0:y1, x0:x1] & near[None, :, :]
    (b0, sy, sx), (b1, gy, gx) = ends
    nodes = bfs_cells(box, (b0, sy - y0, sx - x0), (b1, gy - y0, gx - x0))
    if nodes is None:
        return None
    cell = np.asarray(np.unravel_index(np.asarray(nodes, dtype=np.int64), box.shape), dtype=np.int64).T
    cell[:, 1] += y0
    cell[:, 2] += x0
    return cell


def corridor_box(shape: tuple[int, int], path: list[tuple[int, int]], reach: float
                 ) -> tuple[npt.NDArray[np.bool_], tuple[int, int, int, int]]:
    """The cells (y, x) of a grid of ``shape`` within ``reach`` cells (Euclidean, from centre to centre)
    of a path's cells, on their bounding box ``(y0, y1, x0, x1)``: the corridor :func:`corridor_cells`
    searches (the box is where the search runs: every cell off it is blocked anyway, and the search's
    path does not depend on where its cells lie, the same cells as on the whole window).

    The distance to the path is found on the path's bounding box grown by more than ``reach`` only: a
    cell off it is farther than ``reach`` from every path cell, and one on it is as near as on the
    whole grid (its nearest path cell lies in it), so the same corridor as a distance transform of the
    whole grid (tests/test_grid_route_searches.py)."""
    from scipy import ndimage

    ys, xs = np.array(path, dtype=np.int64).reshape(-1, 2).T
    grow = math.floor(reach) + 1
    wy0, wx0 = max(0, int(ys.min()) - grow), max(0, int(xs.min()) - grow)
    wy1, wx1 = min(shape[0], int(ys.max()) + grow + 1), min(shape[1], int(xs.max()) + grow + 1)
    off = np.ones((wy1 - wy0, wx1 - wx0), dtype=bool)
    off[ys - wy0, xs - wx0] = False
    near = ndimage.distance_transform_edt(off) <= reach
    rows, cols = np.flatnonzero(near.any(axis=1)), np.flatnonzero(near.any(axis=0))
    y0, y1, x0, x1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    return near[y0:y1, x0:x1], (y0 + wy0, y1 + wy0, x0 + wx0, x1 + wx0)

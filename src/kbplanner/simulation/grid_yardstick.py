"""Navigation (B5), the yardstick for path quality: the grid shortest path length for a footprint.

Takes an occupancy grid (or a configuration space), start and goal; :func:`grid_shortest_path_length`
is 8-connected Dijkstra over the cells where the footprint fits at some yaw, then line-of-sight
shortcutting: a slightly optimistic length to compare planned paths with (benchmarks and tests).
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from kbplanner.core.errors import KbplannerError
from kbplanner.simulation.nav_path import Pose2D
from kbplanner.world.footprint import ConfigurationSpace, Footprint
from kbplanner.world.occupancy import OccupancyGrid


def grid_shortest_path_length(
    grid: OccupancyGrid | ConfigurationSpace,
    start: Pose2D | tuple[float, float],
    goal: Pose2D | tuple[float, float],
    footprint: Footprint | None = None,
    n_yaw_bins: int = 72,
) -> float:
    """Length (m) of the shortest path for a footprint on the grid; ``inf`` when there is none.

    Dijkstra, 8-connected, over the cells where the footprint fits at some yaw (a relaxation: it
    may turn anywhere), then greedy line-of-sight shortcutting through those cells, which removes
    most of the 8-connected metric's excess (up to 8 %) over straight lines.
    """
    if isinstance(grid, ConfigurationSpace):
        cs = grid
    else:
        if footprint is None:
            raise KbplannerError("grid_shortest_path_length on a grid needs a footprint",
                                 element="grid_shortest_path_length", fix="pass footprint=...")
        cs = ConfigurationSpace.build(grid, footprint, n_yaw_bins)
    free = cs.free_any_yaw()
    g = cs.grid
    ny, nx = g.shape
    (sx, sy), (gx, gy) = g.cell_of(start[0], start[1]), g.cell_of(goal[0], goal[1])
    if not (0 <= sx < nx and 0 <= sy < ny and 0 <= gx < nx and 0 <= gy < ny):
        return math.inf
    if not (free[sy, sx] and free[gy, gx]):
        return math.inf
    dist = np.full((ny, nx), np.inf)
    prev = np.full((ny, nx), -1, dtype=np.int64)
    dist[sy, sx] = 0.0
    heap: list[tuple[float, int, int]] = [(0.0, sy, sx)]
    moves = [(dy, dx, math.hypot(dy, dx)) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]
    free_l = free.tolist()
    dist_l = dist.tolist()
    while heap:
        d, y, x = heapq.heappop(heap)
        if d > dist_l[y][x]:
            continue
        if y == gy and x == gx:
            break
        for dy, dx, c in moves:
            yy, xx = y + dy, x + dx
            if 0 <= yy < ny and 0 <= xx < nx and free_l[yy][xx]:
                nd = d + c
                if nd < dist_l[yy][xx]:
                    dist_l[yy][xx] = nd
                    prev[yy, xx] = y * nx + x
                    heapq.heappush(heap, (nd, yy, xx))
    if not math.isfinite(dist_l[gy][gx]):
        return math.inf
    cells = [(gy, gx)]
    while cells[-1] != (sy, sx):
        p = int(prev[cells[-1]])
        cells.append((p // nx, p % nx))
    cells.reverse()
    pts = [(float(start[0]), float(start[1]))]
    pts += [g.center_of(x, y) for y, x in cells[1:-1]]
    pts.append((float(goal[0]), float(goal[1])))

    def visible(a: tuple[float, float], b: tuple[float, float]) -> bool:
        n = max(1, math.ceil(math.hypot(b[0] - a[0], b[1] - a[1]) / (g.resolution / 2)))
        u = np.linspace(0.0, 1.0, n + 1)
        xs, ys = a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])
        ix = np.floor((xs - g.origin[0]) / g.resolution).astype(np.int64)
        iy = np.floor((ys - g.origin[1]) / g.resolution).astype(np.int64)
        inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        return bool(inside.all() and free[iy, ix].all())

    length = 0.0
    i = 0
    while i < len(pts) - 1:
        j = len(pts) - 1
        while j > i + 1 and not visible(pts[i], pts[j]):
            j -= 1
        length += math.hypot(pts[j][0] - pts[i][0], pts[j][1] - pts[i][1])
        i = j
    return length

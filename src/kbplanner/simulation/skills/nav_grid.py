"""B5 skills NV-1 and NV-2, the part of the navigation grid a step plans on: a window around start and
goal (:func:`window`), and the nearest free pose for a robot that stands where the conservative
configuration space calls it blocked (:func:`nearest_free_pose`, within ``UNSTICK_RADIUS_M``).
"""

from __future__ import annotations

import math

from kbplanner.planning.base_poses import PoseChecker
from kbplanner.world.footprint import Footprint
from kbplanner.world.occupancy import OccupancyGrid

Pose2D = tuple[float, float, float]


def window(grid: OccupancyGrid, points: list[tuple[float, float]], margin_m: float | None) -> OccupancyGrid:
    """The part of ``grid`` around ``points`` plus ``margin_m`` (None: the whole grid)."""
    if margin_m is None:
        return grid
    res = grid.resolution
    ny, nx = grid.shape
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    ix0 = max(0, math.floor((min(xs) - margin_m - grid.origin[0]) / res))
    iy0 = max(0, math.floor((min(ys) - margin_m - grid.origin[1]) / res))
    ix1 = min(nx, math.ceil((max(xs) + margin_m - grid.origin[0]) / res))
    iy1 = min(ny, math.ceil((max(ys) + margin_m - grid.origin[1]) / res))
    return OccupancyGrid(occupied=grid.occupied[iy0:iy1, ix0:ix1].copy(),
                         origin=(grid.origin[0] + ix0 * res, grid.origin[1] + iy0 * res), resolution=res,
                         band=grid.band)


UNSTICK_RADIUS_M = 0.5  # how far the robot may move straight to leave a blocked start pose


def nearest_free_pose(checker: PoseChecker, start: Pose2D, footprints: list[Footprint]) -> Pose2D | None:
    """The nearest pose (rings of 2.5 cm, 16 bearings, same heading) where any of the footprints is free."""
    for k in range(1, int(UNSTICK_RADIUS_M / 0.025) + 1):
        r = 0.025 * k
        for j in range(16):
            x = start[0] + r * math.cos(j * math.pi / 8)
            y = start[1] + r * math.sin(j * math.pi / 8)
            if any(checker.free(f, x, y, start[2]) for f in footprints):
                return (x, y, start[2])
    return None

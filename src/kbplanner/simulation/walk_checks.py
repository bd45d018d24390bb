"""B5 reactive workers, the geometric checks the crowd (:mod:`kbplanner.simulation.crowd`) repeats
every period: where a worker may stand on the walking map, sample fractions along a leg, and whether
a point is certainly clear of the robot's footprint without a distance query.

Takes points (site frame, metres), the walking map (free cells of an occupancy grid) and the robot as
the workers see it (:class:`~kbplanner.simulation.social_force.Obstacle`); answers with arrays or
booleans, the same numbers as the checks they replace.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import numpy.typing as npt

from kbplanner.simulation.separation import reach_m
from kbplanner.simulation.social_force import Obstacle
from kbplanner.world.occupancy import OccupancyGrid

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


def maybe_within(p: FloatArray, robot: Obstacle, limit_m: float) -> bool:
    """False only where ``p`` is certainly farther than ``limit_m`` from the robot's footprint: its
    distance from the base centre less the footprint's reach exceeds it (with 1 um to spare for
    rounding); then the distance query need not be made."""
    return math.hypot(p[0] - robot.pose[0], p[1] - robot.pose[1]) - reach_m(robot.rects) <= limit_m + 1e-6


@functools.lru_cache(maxsize=512)
def unit_steps(n: int) -> FloatArray:
    """``np.linspace(0, 1, n)`` (read only, the same array for the same ``n``)."""
    out = np.linspace(0.0, 1.0, n)
    out.flags.writeable = False
    return out


def free_cells(pts: FloatArray, free: BoolArray, g: OccupancyGrid) -> BoolArray:
    """Whether each point lies in a free cell of the walking map ``free`` on grid ``g`` (off it: not)."""
    ix = np.floor((pts[:, 0] - g.origin[0]) / g.resolution).astype(np.int64)
    iy = np.floor((pts[:, 1] - g.origin[1]) / g.resolution).astype(np.int64)
    inside = (ix >= 0) & (iy >= 0) & (iy < free.shape[0]) & (ix < free.shape[1])
    ok = np.zeros(len(pts), dtype=bool)
    ok[inside] = free[iy[inside], ix[inside]].astype(bool)
    return ok

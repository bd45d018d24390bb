"""B5 reactive workers, the geometric checks the crowd (:mod:`kbplanner.simulation.crowd`) repeats
every period: where a worker may stand on the walking map, whether a step, a walk or many legs at
once stay on it and clear of the robot's footprint, sample fractions along a leg, the next stretch
of a route, and whether a point is certainly clear of the footprint without a distance query.

Takes points (site frame, metres), the walking map (free cells of an occupancy grid) and the robot as
the workers see it (:class:`~kbplanner.simulation.social_force.Obstacle`); answers with arrays or
booleans, the same numbers as the checks they replace.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from kbplanner.simulation.separation import WORKER_RADIUS_M, reach_m, rects_distance
from kbplanner.simulation.social_force import Obstacle
from kbplanner.world.occupancy import OccupancyGrid

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
_hypot = np.hypot  # on two floats: the numbers of np.hypot on numpy rows


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


def stretch(pts: FloatArray, length_m: float, step_m: float = 0.25) -> FloatArray:
    """The first ``length_m`` of a polyline, sampled every ``step_m`` (n, 2)."""
    out = [pts[0]]
    walked = 0.0
    for p, q in itertools.pairwise(pts):
        seg = float(np.hypot(*(q - p)))
        n = max(1, math.ceil(seg / step_m))
        for k in range(1, n + 1):
            if walked + seg * k / n > length_m:
                return np.array(out)
            out.append(p + (q - p) * k / n)
        walked += seg
    return np.array(out)


def free_at(q: FloatArray, free: BoolArray | None, g: OccupancyGrid | None) -> bool:
    """Whether a worker may stand at ``q`` (a free cell of the walking map; no map: anywhere)."""
    if free is None or g is None:
        return True
    ix = math.floor((q[0] - g.origin[0]) / g.resolution)
    iy = math.floor((q[1] - g.origin[1]) / g.resolution)
    return 0 <= iy < free.shape[0] and 0 <= ix < free.shape[1] and bool(free[iy, ix])


def walkable_step(old: FloatArray, new: FloatArray, free: BoolArray | None, g: OccupancyGrid | None) -> bool:
    """Whether a step from ``old`` to ``new`` stays on the walking map (or starts off it)."""
    if free is None or g is None:
        return True

    def ok(p: FloatArray) -> bool:
        ix = math.floor((p[0] - g.origin[0]) / g.resolution)
        iy = math.floor((p[1] - g.origin[1]) / g.resolution)
        return 0 <= iy < free.shape[0] and 0 <= ix < free.shape[1] and bool(free[iy, ix])

    return ok(new) or not ok(old)


def walkable_along(pts: FloatArray, free: BoolArray | None, g: OccupancyGrid | None) -> bool:
    """:func:`walkable_step` for every step between consecutive points, vectorised."""
    if free is None or g is None:
        return True
    ok = free_cells(pts, free, g)
    return bool(np.all(ok[1:] | ~ok[:-1]))


def free_cell_check(free: BoolArray | None, g: OccupancyGrid | None) -> Callable[[float, float], bool] | None:
    """Whether a point (two floats) lies in a free cell of the walking map (no map: None), as
    :func:`walkable_step` tests it (the same numbers, without numpy rows)."""
    if free is None or g is None:
        return None
    ox, oy, res = g.origin[0], g.origin[1], g.resolution
    ny, nx = free.shape
    cells = np.ascontiguousarray(free, dtype=bool).tobytes()  # row-major, one byte a cell (a copy)

    def ok(x: float, y: float) -> bool:
        ix = math.floor((x - ox) / res)
        iy = math.floor((y - oy) / res)
        return 0 <= iy < ny and 0 <= ix < nx and cells[iy * nx + ix] != 0

    return ok


def legs_clear_of(legs: Sequence[FloatArray], robot: Obstacle | None, clear_m: float) -> list[bool]:
    """Per leg (sampled points): whether it keeps ``clear_m`` from the robot's footprint, or never
    comes closer to it than where it starts (one distance query for all legs)."""
    if robot is None or not legs:
        return [True] * len(legs)
    pts = np.concatenate(legs)
    d_all, _, _ = rects_distance(pts[:, 0], pts[:, 1], robot.pose, robot.rects)
    out = []
    start = 0
    for leg in legs:
        d = d_all[start : start + len(leg)]
        start += len(leg)
        out.append(bool(d.min() >= min(clear_m, float(d[0])) - 1e-9))
    return out


LEAVES_SOON_SAMPLES = 12  # clear_legs first looks this far along each leg for a step off the walking map


@functools.lru_cache(maxsize=512)
def _first_steps(n: int) -> tuple[float, ...]:
    """The fractions of :func:`unit_steps` ``(n)`` after 0.0, the first :data:`LEAVES_SOON_SAMPLES`."""
    return tuple(unit_steps(n)[1 : LEAVES_SOON_SAMPLES + 1].tolist())


def _leaves_soon(p: FloatArray, q: FloatArray, walk: Callable[[float, float], bool]) -> bool:
    """Whether the leg p -> q, sampled as :func:`clear_legs` samples it (the same count, fractions and
    points), steps out of the walkable cells within its first :data:`LEAVES_SOON_SAMPLES` samples:
    then it is not walkable, whatever the rest of it (and its distances) are."""
    px, py = float(p[0]), float(p[1])
    dx, dy = float(q[0]) - px, float(q[1]) - py
    n = max(int(float(_hypot(dx, dy)) / 0.1) + 1, 2)
    was = walk(px, py)  # the first sample: fraction 0.0
    for f in _first_steps(n):
        now = walk(px + f * dx, py + f * dy)
        if was and not now:
            return True
        was = now
    return False


def clear_legs(legs: Sequence[tuple[FloatArray, FloatArray]], robot: Obstacle, free: BoolArray | None,
               g: OccupancyGrid | None, walk: Callable[[float, float], bool] | None = None) -> list[bool]:
    """Per leg (p, q): sampled every 0.1 m, clear of the footprint and walkable. All legs at once
    (element-wise the same numbers as one query per leg and :func:`walkable_along` per leg).

    (A leg that steps off the walking map within its first samples is not walkable: told without
    sampling it all (:func:`_leaves_soon`); the others are sampled together, each on its own, so
    the answers are those of sampling every leg. ``walk``: :func:`free_cell_check` of ``free`` and
    ``g`` when the caller keeps it.)"""
    if not legs:
        return []
    if walk is None:
        walk = free_cell_check(free, g)
    if walk is not None:
        soon = [_leaves_soon(p, q, walk) for p, q in legs]
        if any(soon):
            rest = iter(_clear_legs([leg for leg, out in zip(legs, soon, strict=True) if not out], robot,
                                    free, g))
            return [False if out else next(rest) for out in soon]
    return _clear_legs(legs, robot, free, g)


def _clear_legs(legs: Sequence[tuple[FloatArray, FloatArray]], robot: Obstacle, free: BoolArray | None,
                g: OccupancyGrid | None) -> list[bool]:
    """:func:`clear_legs` by sampling every leg whole."""
    if not legs:
        return []
    ps = np.array([p for p, _ in legs], dtype=np.float64).reshape(-1, 2)
    dq = np.array([q for _, q in legs], dtype=np.float64).reshape(-1, 2) - ps
    counts = np.maximum((np.hypot(dq[:, 0], dq[:, 1]) / 0.1).astype(np.int64) + 1, 2)
    leg = np.repeat(np.arange(len(legs)), counts)
    f = np.concatenate([unit_steps(int(n)) for n in counts])[:, None]
    pts = ps[leg] + f * dq[leg]
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    d_all, _, _ = rects_distance(pts[:, 0], pts[:, 1], robot.pose, robot.rects)
    clear = np.minimum.reduceat(d_all, starts) >= WORKER_RADIUS_M + 0.3
    if free is None or g is None:
        return [bool(c) for c in clear]
    ok = free_cells(pts, free, g)
    leaves = ok[:-1] & ~ok[1:]  # a step out of the walkable cells
    leaves[starts[1:] - 1] = False  # (not between one leg's last sample and the next one's first)
    left = np.add.reduceat(np.append(leaves, False), starts) > 0
    return [bool(c and not lv) for c, lv in zip(clear, left, strict=True)]

"""B5 skill NV-2, where to turn the carried element when it fits only one way at the start or at the goal.

Takes a test of whether both carry footprints fit at a pose (the skill's pose checker on the navigation
grid), the pose to turn near (start or goal), the far end of the route and a planner of the short leg
to a candidate (the skill's own, in the carry mode that fits there) with its timed duration. Returns the
pose where the load is turned: of the poses where both fit, in rings of 0.25 m around the start or goal,
the few nearest to a straight line through the far end are planned and timed, and the one whose leg
plus the straight remainder at top speed takes least is taken (the nearest pose, the former choice,
is always among them).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TypeVar

Pose2D = tuple[float, float, float]
R = TypeVar("R")

RING_M = 0.25
MAX_RINGS = 12
RINGS_AFTER = 2  # rings searched beyond the first one with a pose where the load can turn
TRIES = 5  # candidates planned and timed


def turn_poses(free: Callable[[float, float, float], bool], near: Pose2D) -> list[Pose2D]:
    """Poses around ``near`` where ``free`` (both carry footprints fit), nearest ring first.

    Rings of ``RING_M`` (up to ``MAX_RINGS``), 16 bearings from behind the robot, yaws: the robot's,
    turned by +-90 degrees, reversed; from the first ring with such a pose and ``RINGS_AFTER`` more.
    """
    out: list[Pose2D] = []
    first: int | None = None
    for k in range(1, MAX_RINGS + 1):
        if first is not None and k > first + RINGS_AFTER:
            break
        r = RING_M * k
        for j in range(16):
            bearing = near[2] + math.pi + j * math.pi / 8  # behind the robot first
            x, y = near[0] + r * math.cos(bearing), near[1] + r * math.sin(bearing)
            for yaw in (near[2], near[2] + math.pi / 2, near[2] - math.pi / 2, near[2] + math.pi):
                if free(x, y, yaw):
                    out.append((x, y, math.atan2(math.sin(yaw), math.cos(yaw))))
                    first = k if first is None else first
    return out


def best_turn_pose(
    candidates: list[Pose2D],
    near: Pose2D,
    far: Pose2D,
    speed: float,
    leg: Callable[[Pose2D], tuple[R, float] | None],
) -> tuple[Pose2D, R] | None:
    """The candidate whose planned leg (``leg``: the route between ``near`` and it, and its duration)
    plus the straight distance to ``far`` at ``speed`` takes least; None when no leg is found.

    The first candidate (the nearest) and the ``TRIES - 1`` others with the shortest detour
    (straight near -> candidate -> far) are tried, in that order; ties keep the earlier one.
    """
    if not candidates:
        return None

    def detour(c: Pose2D) -> float:
        return math.hypot(c[0] - near[0], c[1] - near[1]) + math.hypot(far[0] - c[0], far[1] - c[1])

    ranked = sorted(range(1, len(candidates)), key=lambda i: (round(detour(candidates[i]), 9), i))
    best: tuple[float, Pose2D, R] | None = None
    for i in [0, *ranked[: TRIES - 1]]:
        c = candidates[i]
        found = leg(c)
        if found is None:
            continue
        route, seconds = found
        cost = seconds + math.hypot(far[0] - c[0], far[1] - c[1]) / speed
        if best is None or cost < best[0] - 1e-9:
            best = (cost, c, route)
    return None if best is None else (best[1], best[2])

"""B5 skill NV-2, a route that turns the carried element once on the way: where the load fits only one way
at the start and only the other way at the goal.

Takes a test of whether both carry footprints fit at a pose (the skill's pose checker), start and goal,
and two planners: of the leg from the start to a pose in the start's carry mode and of the leg from a
pose to the goal in the goal's carry mode (the skill's own, each with its timed duration). The poses
where the load can turn are those of :func:`kbplanner.simulation.skills.load_turn.turn_poses` round the
start and round the goal; of each ring set the nearest and the ``TRIES - 1`` with the shortest straight
detour (start -> pose -> goal) are planned both ways and timed, and the pair of legs that drives quickest
is returned. The skill's former route (turn near the start, a carry-mode leg, turn near the goal) drives
back into the start's mode on the middle leg where the wide load passes (the turn near the start then
is a detour for nothing: storage-inside's last frame, driven / shortest 1.34-1.40 on seeds 1 and 2); the
skill keeps whichever of the two routes is quicker.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TypeVar

from kbplanner.simulation.skills.load_turn import TRIES, turn_poses

Pose2D = tuple[float, float, float]
R = TypeVar("R")


def _ranked(candidates: list[Pose2D], start: Pose2D, goal: Pose2D) -> list[Pose2D]:
    """The nearest candidate and the ``TRIES - 1`` others with the shortest straight detour."""
    if not candidates:
        return []

    def detour(c: Pose2D) -> float:
        return math.hypot(c[0] - start[0], c[1] - start[1]) + math.hypot(goal[0] - c[0], goal[1] - c[1])

    rest = sorted(range(1, len(candidates)), key=lambda i: (round(detour(candidates[i]), 9), i))
    return [candidates[i] for i in [0, *rest[: TRIES - 1]]]


def one_turn(
    fits: Callable[[float, float, float], bool],
    start: Pose2D,
    goal: Pose2D,
    to_turn: Callable[[Pose2D], tuple[R, float] | None],
    from_turn: Callable[[Pose2D], tuple[R, float] | None],
) -> tuple[Pose2D, R, R, float] | None:
    """The turning pose, the two legs (start -> pose, pose -> goal) and their drive time, of the
    candidates round start and goal the quickest; None when no candidate has both legs.

    Candidates are tried round the start first, then round the goal; ties keep the earlier one.
    """
    best: tuple[Pose2D, R, R, float] | None = None
    seen: set[Pose2D] = set()
    for near in (start, goal):
        for c in _ranked(turn_poses(fits, near), start, goal):
            if c in seen:
                continue
            seen.add(c)
            a = to_turn(c)
            if a is None:
                continue
            if best is not None and a[1] >= best[3] - 1e-9:
                continue  # its first leg alone is slower than the best pair
            b = from_turn(c)
            if b is None:
                continue
            seconds = a[1] + b[1]
            if best is None or seconds < best[3] - 1e-9:
                best = (c, a[0], b[0], seconds)
    return best

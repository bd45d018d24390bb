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

With ``bound`` (a lower bound on a leg's drive time between two poses, :func:`leg_time_bound`), a
candidate whose legs cannot beat the best pair found so far is not planned (its first leg's bound plus
its second's, or its first leg's time plus its second's bound, at least the best): the same pair is
returned, with fewer legs planned.
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
    bound: Callable[[Pose2D, Pose2D], float] | None = None,
) -> tuple[Pose2D, R, R, float] | None:
    """The turning pose, the two legs (start -> pose, pose -> goal) and their drive time, of the
    candidates round start and goal the quickest; None when no candidate has both legs.

    Candidates are tried round the start first, then round the goal; ties keep the earlier one. With
    ``bound`` (never more than a leg's time), candidates that cannot be quicker than the best are skipped.
    """
    best: tuple[Pose2D, R, R, float] | None = None
    seen: set[Pose2D] = set()
    for near in (start, goal):
        for c in _ranked(turn_poses(fits, near), start, goal):
            if c in seen:
                continue
            seen.add(c)
            if best is not None and bound is not None and bound(start, c) + bound(c, goal) >= best[3] - 1e-9:
                continue  # neither leg planned: even at their bounds the pair is not quicker
            a = to_turn(c)
            if a is None:
                continue
            if best is not None and a[1] >= best[3] - 1e-9:
                continue  # its first leg alone is slower than the best pair
            if best is not None and bound is not None and a[1] + bound(c, goal) >= best[3] - 1e-9:
                continue  # its first leg and the second's bound are not quicker
            b = from_turn(c)
            if b is None:
                continue
            seconds = a[1] + b[1]
            if best is None or seconds < best[3] - 1e-9:
                best = (c, a[0], b[0], seconds)
    return best


def _trapezoid_s(dist: float, vmax: float, amax: float) -> float:
    """The least time to move ``dist`` from rest to rest within the speed and the acceleration."""
    if dist <= 0.0:
        return 0.0
    if dist >= vmax * vmax / amax:
        return dist / vmax + vmax / amax
    return 2.0 * math.sqrt(dist / amax)


def leg_time_bound(a: Pose2D, b: Pose2D, max_speed_mps: float, max_accel_mps2: float,
                   max_yaw_rate_rps: float, slack_m: float = 0.05, slack_rad: float = 0.05) -> float:
    """A lower bound on the drive time of any path from ``a`` to ``b`` as the skill times it
    (:func:`~kbplanner.simulation.base_trajectory.time_parameterize`): its runs go from rest to rest
    within the top speed and the acceleration over at least the straight distance (a trapezoid), and
    its runs and turns on the spot change the yaw at most at the top yaw rate. ``slack_m`` and
    ``slack_rad`` are taken off both (a planner's end pose a little off the asked one), and the result
    by a millionth (rounding), so it stays below the time."""
    dist = max(0.0, math.hypot(b[0] - a[0], b[1] - a[1]) - slack_m)
    dyaw = max(0.0, abs(math.atan2(math.sin(b[2] - a[2]), math.cos(b[2] - a[2]))) - slack_rad)
    return max(_trapezoid_s(dist, max_speed_mps, max_accel_mps2), dyaw / max_yaw_rate_rps) * (1.0 - 1e-6)

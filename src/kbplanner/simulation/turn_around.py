"""Navigation (B5), a skid-steer path that drove backwards turned round where the base can turn.

Where a turn on the spot is blocked (a carried frame next to the storage stack, in a corridor),
:func:`~kbplanner.simulation.motion_check.turn_drive_turn` keeps the planner's SE(2) motion, and OMPL's SE(2)
space does not know which way the base faces: whole carry legs were driven backwards, into the
scanner's blind sector. :func:`turned_round` walks along the planner's path (every
``STEP_M``) and flips the base's yaw by half a turn on the stretches it would drive backwards, each begun
and ended at a pose where a whole turn on the spot is free in the leg's configuration space (with its
load): the base backs up only to such a pose, turns round there, drives on facing the other way and
turns back where the path goes forwards again. :func:`skid_steer`, turn-drive-turn with that, keeps the
result only where it is free (exact check) and drives backwards less; the planner's paths and the cell
routes take it. No random numbers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from kbplanner.simulation.back_out import backed_in, backed_out, estimate_s
from kbplanner.simulation.base_trajectory import time_parameterize
from kbplanner.simulation.motion_check import ExactMotion, backward_m, turn_drive_turn
from kbplanner.simulation.nav_path import Pose2D, path_length, wrap
from kbplanner.world.footprint import ConfigurationSpace

STEP_M = 0.1  # spacing of the poses tried along the path
REVERSE_TOLERANCE_M = 0.05  # backward driving below this is not worth turning round for
SPIN_PARTS = 8  # a whole turn checked as this many motions (each under half a turn)
TIMED = 2  # backed-out rewrites timed exactly, the quickest by the estimate
LONGER = 1.1  # a backed-out rewrite drives at most this times as far as the path it replaces


def _starts(poses: Sequence[Pose2D]) -> list[int]:
    """Per pose of :func:`_along`, its step along its segment (0: the segment's first waypoint)."""
    return [j for k in range(len(poses) - 1)
            for j in range(max(1, math.ceil(math.hypot(poses[k + 1][0] - poses[k][0],
                                                       poses[k + 1][1] - poses[k][1]) / STEP_M)))]


def _along(poses: Sequence[Pose2D]) -> list[tuple[int, Pose2D]]:
    """Poses every ``STEP_M`` along the path with the index of their segment (yaw linear, the short way)."""
    out: list[tuple[int, Pose2D]] = []
    for k in range(len(poses) - 1):
        a, b = poses[k], poses[k + 1]
        n = max(1, math.ceil(math.hypot(b[0] - a[0], b[1] - a[1]) / STEP_M))
        turn = wrap(b[2] - a[2])
        out += [(k, (a[0] + j / n * (b[0] - a[0]), a[1] + j / n * (b[1] - a[1]), wrap(a[2] + j / n * turn)))
                for j in range(n)]
    return out


def turned_round(cs: ConfigurationSpace, poses: Sequence[Pose2D]) -> list[Pose2D] | None:
    """``poses`` with the base's yaw flipped by half a turn on the stretches it would drive backwards, each
    stretch begun and ended at a pose where the base turns round freely (module doc); None where nothing
    can be flipped or the result is not free.

    Along the path (every ``STEP_M``): unflipped, at a pose where the base can turn round and the motion
    ahead goes backwards, it turns round if the flipped motion is free; flipped, it turns back at such a
    pose where the motion ahead goes forwards. Where a flipped motion is blocked (the load is not
    symmetric), the stretch is undone back to the last pose of it where the base could turn, and no new
    stretch begins before the blocked motion is passed; a stretch still open at the goal is undone
    likewise unless the base can turn at the goal."""
    exact = ExactMotion(cs)
    dense = _along(poses)
    keep = [j == 0 for j in _starts(poses)] + [True]
    pts = [p for _, p in dense] + [poses[-1]]
    n = len(pts)
    memo: dict[int, bool] = {}

    def spins(i: int) -> bool:
        if i not in memo:
            x, y, t = pts[i]
            memo[i] = any(exact.path_free([(x, y, wrap(t + s * k * 2 * math.pi / SPIN_PARTS))
                                           for k in range(SPIN_PARTS + 1)]) for s in (1, -1))
        return memo[i]

    def flip(p: Pose2D) -> Pose2D:
        return (p[0], p[1], wrap(p[2] + math.pi))

    flipped = [False] * (n - 1)  # per motion i -> i + 1
    state, last_turn, calm_until = False, 0, 0
    for i in range(n - 1):
        if math.hypot(pts[i + 1][0] - pts[i][0], pts[i + 1][1] - pts[i][1]) > 1e-9:
            back = backward_m([pts[i], pts[i + 1]]) > 0.0
            if back != state and (state or i >= calm_until) and spins(i) and (
                    state or exact.motion_free(flip(pts[i]), flip(pts[i + 1]))):
                state = back
            if state and spins(i):
                last_turn = i
        if state and not exact.motion_free(flip(pts[i]), flip(pts[i + 1])):
            flipped[last_turn:i] = [False] * (i - last_turn)
            state, calm_until = False, i + 1
        flipped[i] = state
    if state and not spins(n - 1):
        flipped[last_turn:] = [False] * (n - 1 - last_turn)
    if not any(flipped):
        return None
    out: list[Pose2D] = [pts[0]]
    if flipped[0]:
        out.append(flip(pts[0]))
    for i in range(1, n):
        before, after = flipped[i - 1], flipped[i] if i < n - 1 else False
        if before != after or keep[i]:
            out.append(flip(pts[i]) if before else pts[i])
        if before != after:
            out.append(flip(pts[i]) if after else pts[i])
    out = [p for i, p in enumerate(out) if i == 0 or p != out[i - 1]]
    return out if exact.path_free(out) else None


def skid_steer(cs: ConfigurationSpace, poses: Sequence[Pose2D], *, allow_reverse: bool = True,
               limits: tuple[float, float, float, float] = (0.5, 2.0, 1.0, 2.0),
               reverse_s_per_m: float = 0.0, trace: list[tuple[str, float]] | None = None
               ) -> tuple[list[Pose2D], int]:
    """:func:`~kbplanner.simulation.motion_check.turn_drive_turn`; without ``allow_reverse``, where that
    drives backwards over ``REVERSE_TOLERANCE_M``: the path :func:`turned_round`, turn-drive-turn, if it is
    free and drives backwards less (by over ``REVERSE_TOLERANCE_M``; ``trace`` then gets ``("turned
    round", backward_m)``). Then the planner's path and that one with their start backed out and their
    end backed in straight (:mod:`~kbplanner.simulation.back_out`), each turn-drive-turn and free, that
    drive backwards no more than that choice: the one of least drive time (``limits``: the base's top
    speed, yaw rate, acceleration and yaw acceleration, :func:`~kbplanner.simulation.base_trajectory.
    time_parameterize`) plus ``reverse_s_per_m`` per metre backwards is taken, that choice included (of
    the rewrites, the ``TIMED`` quickest by :func:`~kbplanner.simulation.back_out.estimate_s` are timed)
    (``trace`` then gets ``("backed out", backward_m)``); with ``reverse_s_per_m`` 0, none of them."""
    got = turn_drive_turn(cs, poses, allow_reverse=allow_reverse, trace=trace)
    if allow_reverse or len(poses) < 2 or backward_m(got[0]) <= REVERSE_TOLERANCE_M:
        return got
    exact = ExactMotion(cs)
    best_back = backward_m(got[0])
    choice, why = got, ""
    flipped = turned_round(cs, poses)
    if flipped is not None:
        other = turn_drive_turn(cs, flipped, allow_reverse=allow_reverse)
        if backward_m(other[0]) < best_back - REVERSE_TOLERANCE_M and exact.path_free(other[0]):
            choice, why, best_back = other, "turned round", backward_m(other[0])
    if reverse_s_per_m > 0:
        limit = min(best_back + 1e-9, backward_m(got[0]) - REVERSE_TOLERANCE_M)

        def cost(way: list[Pose2D]) -> float:
            return time_parameterize(way, *limits, space=cs).duration_s + reverse_s_per_m * backward_m(way)

        speed, yaw_rate = limits[0], limits[1]
        length = path_length(choice[0])
        found: list[tuple[float, int, tuple[list[Pose2D], int]]] = []
        for base in [list(poses)] + ([flipped] if flipped is not None else []):
            outs = backed_out(cs, base, speed, yaw_rate, limit, reverse_s_per_m=reverse_s_per_m)
            ways = [*outs, *backed_in(cs, base, speed, yaw_rate, limit, reverse_s_per_m=reverse_s_per_m)]
            if outs:
                ways += backed_in(cs, outs[0], speed, yaw_rate, limit, reverse_s_per_m=reverse_s_per_m)
            for way in ways:
                other = turn_drive_turn(cs, way, allow_reverse=allow_reverse)
                if backward_m(other[0]) <= limit and path_length(other[0]) <= LONGER * length:
                    found.append((estimate_s(other[0], speed, yaw_rate, reverse_s_per_m), len(found), other))
        best = cost(choice[0]) if found else 0.0
        for _, _, other in sorted(found, key=lambda f: (round(f[0], 9), f[1]))[:TIMED]:
            c = cost(other[0])
            if c < best - 1e-9 and exact.path_free(other[0]):
                choice, why, best = other, "backed out", c
    if why and trace is not None:
        trace.append((why, backward_m(choice[0])))
    return choice

"""Navigation (B5), a skid-steer path that drove backwards turned round where the base can turn.

Where a turn on the spot is blocked (a carried frame next to the storage stack, in a corridor),
:func:`~kbplanner.simulation.motion_check.turn_drive_turn` keeps the planner's SE(2) motion, and OMPL's SE(2)
space does not know which way the base faces: whole carry legs were driven backwards, into the
scanner's blind sector. :func:`turned_round` finds the first and the last pose along the path (every
``STEP_M``) where a whole turn on the spot is free in the leg's configuration space, and flips the base's
yaw by half a turn between them: the base backs up only to the first such pose, turns round there, drives
the middle facing the other way and turns back at the last one. The caller keeps the result only where it
is free (exact check) and drives backwards less: :func:`skid_steer`, turn-drive-turn with that, which the
planner's paths and the cell routes take. No random numbers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from kbplanner.simulation.motion_check import ExactMotion, backward_m, turn_drive_turn
from kbplanner.simulation.nav_path import Pose2D, wrap
from kbplanner.world.footprint import ConfigurationSpace

STEP_M = 0.1  # spacing of the poses tried along the path
REVERSE_TOLERANCE_M = 0.05  # backward driving below this is not worth turning round for
SPIN_PARTS = 8  # a whole turn checked as this many motions (each under half a turn)


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
    """``poses`` with the yaw flipped between the first and the last pose where the base turns round freely
    (module doc), or None where there are not two such poses or the flipped middle is not free."""
    exact = ExactMotion(cs)

    def spins(p: Pose2D) -> bool:
        return any(exact.path_free([(p[0], p[1], wrap(p[2] + s * k * 2 * math.pi / SPIN_PARTS))
                                    for k in range(SPIN_PARTS + 1)]) for s in (1, -1))

    along = _along(poses)
    first = next((i for i, (_, p) in enumerate(along) if spins(p)), None)
    last = next((i for i in range(len(along) - 1, -1, -1) if spins(along[i][1])), None)
    if first is None or last is None or last <= first:
        return None
    (ka, pa), (kb, pb) = along[first], along[last]
    middle = [(x, y, wrap(t + math.pi)) for x, y, t in [pa, *poses[ka + 1 : kb + 1], pb]]
    out = [*poses[: ka + 1], pa, *middle, pb, *poses[kb + 1 :]]
    out = [p for i, p in enumerate(out) if i == 0 or p != out[i - 1]]
    return out if exact.path_free(out) else None


def skid_steer(cs: ConfigurationSpace, poses: Sequence[Pose2D], *, allow_reverse: bool = True,
               trace: list[tuple[str, float]] | None = None) -> tuple[list[Pose2D], int]:
    """:func:`~kbplanner.simulation.motion_check.turn_drive_turn`; without ``allow_reverse``, where that
    drives backwards over ``REVERSE_TOLERANCE_M``, the path :func:`turned_round` rewritten so, if it is
    free and drives backwards less (``trace`` then gets ``("turned round", backward_m)``)."""
    got = turn_drive_turn(cs, poses, allow_reverse=allow_reverse, trace=trace)
    if allow_reverse or len(poses) < 2 or backward_m(got[0]) <= REVERSE_TOLERANCE_M:
        return got
    flipped = turned_round(cs, poses)
    if flipped is None:
        return got
    other = turn_drive_turn(cs, flipped, allow_reverse=allow_reverse)
    less = backward_m(other[0]) < backward_m(got[0]) - REVERSE_TOLERANCE_M
    if less and ExactMotion(cs).path_free(other[0]):
        if trace is not None:
            trace.append(("turned round", backward_m(other[0])))
        return other
    return got

"""Navigation (B5), a planned route's needless corners cut out: turn there, drive straight on.

A turn-drive-turn route (x, y, yaw waypoints, as :func:`~kbplanner.simulation.motion_check.turn_drive_turn`
writes an OMPL path) can keep short zigzags of the sampling planner - a hop of a few centimetres the
wrong way at its start, with a turn on the spot to face it and another to face back: seconds of turning
for nothing, which the SE(2) shortcut (:func:`~kbplanner.simulation.motion_check.shortcut`) cannot cut
where a straight SE(2) motion, turning while it drives, would sweep the footprint into an obstacle.

:func:`pull_corners` tries, from each waypoint in turn and the farthest first, to replace the route up
to a later waypoint by a turn on the spot to face it, a straight drive forwards (never reversing) and a
turn on the spot into that waypoint's yaw. A replacement is kept where the exact motion check of the
space passes (:class:`~kbplanner.simulation.motion_check.ExactMotion`, the planner's own validator) and
the route is then quicker to drive (``seconds``, the caller's timing at the base's limits). First and
last pose unchanged. No random numbers.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from kbplanner.simulation.motion_check import ExactMotion
from kbplanner.simulation.nav_path import Pose2D
from kbplanner.world.footprint import ConfigurationSpace

EPS_M = 1e-9


def _straight(a: Pose2D, b: Pose2D) -> list[Pose2D]:
    """a, turn on the spot to face b, drive straight to b, turn into b's yaw (repeated poses left out)."""
    h = math.atan2(b[1] - a[1], b[0] - a[0])
    out = [a]
    for p in ((a[0], a[1], h), (b[0], b[1], h), b):
        if p != out[-1]:
            out.append(p)
    return out


def pull_corners(cs: ConfigurationSpace, poses: Sequence[Pose2D],
                 seconds: Callable[[list[Pose2D]], float]) -> list[Pose2D]:
    """``poses`` with stretches replaced by turn, straight drive forwards, turn where that is free and
    quicker by ``seconds`` (module doc). Returns the poses as they were where nothing was quicker."""
    out = list(poses)
    if len(out) < 3:
        return out
    exact = ExactMotion(cs)
    best = seconds(out)
    a = 0
    while a < len(out) - 2:
        for b in range(len(out) - 1, a + 1, -1):
            pa, pb = out[a], out[b]
            if math.hypot(pb[0] - pa[0], pb[1] - pa[1]) <= EPS_M:
                continue
            way = _straight(pa, pb)
            if len(way) >= b - a + 1 and way == out[a:b + 1]:
                continue
            if not exact.path_free(way):
                continue
            cand = [*out[:a], *way, *out[b + 1:]]
            took = seconds(cand)
            if took < best - 1e-9:
                out, best = cand, took
                break
        a += 1
    return out

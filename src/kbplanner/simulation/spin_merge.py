"""Navigation (B5), a cell route's turns on the spot partly taken while driving.

Takes the waypoints of a route (x, y, yaw; turn-drive-turn, as the cell routes of
:mod:`kbplanner.simulation.cell_path` write them) and the configuration space it was planned in.
:func:`turn_while_driving` moves each turn on the spot next to a straight drive, wholly or in part
(:data:`FRACTIONS`, largest first), into that drive: the base then turns while it drives (x, y and yaw
linear, as the planner's motions). A move is kept only where

- the exact motion check of the space passes (:class:`~kbplanner.simulation.motion_check.ExactMotion`,
  the planner's own validator), and
- the direction of travel stays within ``MAX_OFF_HEADING_RAD`` of where the base faces over the whole
  drive: never a backward component, so speed and separation monitoring (forwards only: the scanner's
  blind sector is behind) still sees where the base goes.

The drives' x, y are unchanged (the same length); only turns on the spot get shorter. Used for the cell
routes timed against a leg that went round the long way
(:meth:`~kbplanner.simulation.skills.navigation.NavigationSkill._cells_instead`): a short cell route made of
turns on the spot and short drives can then also be the quicker one. No random numbers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from kbplanner.simulation.motion_check import ExactMotion
from kbplanner.simulation.nav_path import Pose2D, wrap
from kbplanner.world.footprint import ConfigurationSpace

FRACTIONS = (1.0, 0.75, 0.5, 0.25)  # share of a turn on the spot moved into the drive next to it, tried
MAX_OFF_HEADING_RAD = math.pi / 2  # direction of travel against the base's yaw, at most (no reversing)
DRIVEN_OFF_HEADING_RAD = math.radians(45.0)  # the same, for every route driven (NavigationSkill._enqueue)
EPS_M = 1e-9


def _forward(a: Pose2D, c: Pose2D, max_off_rad: float = MAX_OFF_HEADING_RAD) -> bool:
    """Whether the straight motion a -> c (yaw linear, the short way) never travels backwards: the angle
    between the direction of travel and the yaw changes linearly, so its two ends decide."""
    heading = math.atan2(c[1] - a[1], c[0] - a[0])
    off = wrap(heading - a[2])
    end = off - wrap(c[2] - a[2])
    return abs(off) <= max_off_rad + 1e-9 and abs(end) <= max_off_rad + 1e-9


def _is_spin(a: Pose2D, b: Pose2D) -> bool:
    return math.hypot(b[0] - a[0], b[1] - a[1]) <= EPS_M


def turn_while_driving(cs: ConfigurationSpace, poses: Sequence[Pose2D],
                       max_off_rad: float = MAX_OFF_HEADING_RAD) -> list[Pose2D]:
    """``poses`` with each turn on the spot next to a drive taken into the drive as far as it may (module
    doc; the direction of travel within ``max_off_rad`` of the yaw); the first and last pose unchanged.
    Returns the poses as they were where nothing moved."""
    out = list(poses)
    if len(out) < 3:
        return out
    exact = ExactMotion(cs)

    def fits(a: Pose2D, c: Pose2D) -> bool:
        return _forward(a, c, max_off_rad) and exact.motion_free(a, c)

    i = 1
    while i < len(out) - 1:
        a, m, c = out[i - 1], out[i], out[i + 1]
        before, after = _is_spin(a, m), _is_spin(m, c)
        if before and not after:  # turn a -> m on the spot, drive m -> c: turn less, the rest on the drive
            turn = wrap(m[2] - a[2])
            for f in FRACTIONS:
                mid = (a[0], a[1], wrap(a[2] + (1.0 - f) * turn))
                if fits(mid, c):
                    if f == 1.0:
                        del out[i]
                        i -= 1
                    else:
                        out[i] = mid
                    break
        elif after and not before:  # drive a -> m, turn m -> c on the spot: turn on the drive first
            turn = wrap(c[2] - m[2])
            for f in FRACTIONS:
                mid = (m[0], m[1], wrap(m[2] + f * turn))
                if fits(a, mid):
                    if f == 1.0:
                        del out[i]
                        i -= 1
                    else:
                        out[i] = mid
                    break
        i += 1
    return out

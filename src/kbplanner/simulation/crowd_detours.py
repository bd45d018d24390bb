"""B5 reactive workers, a way round the robot: a walking worker held up by the robot walks round it.

Takes the crowd (:class:`~kbplanner.simulation.crowd.Crowd`) and the robot as the workers see it now
(:class:`~kbplanner.simulation.social_force.Obstacle`); a walking worker slower than ``STUCK_SPEED_MPS``
for ``STUCK_S`` gets a via point beside the robot's footprint (its reach plus the worker's comfort
distance, 16 bearings) in their route: the one that keeps the walk shortest with both legs walkable and
clear of the footprint (:func:`kbplanner.simulation.walk_checks.clear_legs`), if any. A look with the very
same inputs as a look that found none (bit for bit: where, whereto, the robot's pose and footprint) is
not made again.
"""

from __future__ import annotations

import math
import struct

import numpy as np

from kbplanner.simulation.crowd_agents import STUCK_S, STUCK_SPEED_MPS, CrowdState, FloatArray
from kbplanner.simulation.separation import WORKER_RADIUS_M, reach_m
from kbplanner.simulation.social_force import Obstacle


def detours(crowd: CrowdState, robot: Obstacle) -> None:
    """A walking worker held up by the robot for STUCK_S walks round it (see module docstring)."""
    sp = crowd.speed_list()
    for i, a in enumerate(crowd.agents):
        if not a.walking or sp[i] >= STUCK_SPEED_MPS:
            a.slow_s = 0.0
            continue
        a.slow_s += crowd.dt
        if a.slow_s < STUCK_S:
            continue
        a.slow_s = 0.0
        p = np.array([crowd._xs[i], crowd._ys[i]], dtype=np.float64)
        goal = a.path[min(a.wp, len(a.path) - 1)]
        radius = reach_m(robot.rects) + WORKER_RADIUS_M + a.params.comfort_distance_m
        # the same look (bit for bit: where, whereto, the robot's pose and footprint) found no way
        # round last time: it finds none again
        key = (struct.pack("5d", p[0], p[1], goal[0], goal[1], radius) + struct.pack("3d", *robot.pose),
               tuple(robot.rects))
        if crowd._no_detour.get(i) == key:
            continue
        vias = [
            np.array([robot.pose[0] + radius * math.cos(j * math.pi / 8),
                      robot.pose[1] + radius * math.sin(j * math.pi / 8)])
            for j in range(16)
        ]
        first = crowd._clear_many([(p, via) for via in vias], robot)
        ways = [via for via, ok in zip(vias, first, strict=True) if ok]
        second = crowd._clear_many([(via, goal) for via in ways], robot)
        best: tuple[float, FloatArray] | None = None
        for via, ok in zip(ways, second, strict=True):
            if not ok:
                continue
            cost = float(np.hypot(*(via - p)) + np.hypot(*(goal - via)))
            if best is None or cost < best[0]:
                best = (cost, via)
        if best is not None:
            a.path = np.vstack([a.path[: a.wp], best[1][None, :], a.path[a.wp :]])
            crowd._no_detour.pop(i, None)
        else:
            crowd._no_detour[i] = key

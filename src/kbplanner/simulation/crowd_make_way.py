"""B5 reactive workers, making way: a worker the stopped robot has waited for steps aside, then goes back.

Takes the crowd (:class:`~kbplanner.simulation.crowd.Crowd`), the worker asked, the robot's remaining
path and how far it must pass them (asked by the navigation, :mod:`kbplanner.simulation.skills.make_way`);
gives the spot the worker walks to: on rings of 0.5 m, 16 bearings, nearest first, walkable in a
straight line from where the worker stands and never closer to the robot's footprint than now or than
``LEG_CLEAR_M`` (not through the robot), preferring a walk that never comes closer to it than now; the
first at the clearance plus the worker's comfort distance from every path point, else the first at the
clearance, else the walkable spot farthest from the path if it gains 0.5 m. Each period
(:func:`release`) a worker who made way goes back once the robot has passed: its centre and the rest of
its path are the clearance away from where the worker goes back to (their stop, or the next stretch of
a walking worker's route), or it reached the path's end or left the path; at ``MAKE_WAY_MAX_HOLD_S`` at
the latest.
"""

from __future__ import annotations

import math

import numpy as np

from kbplanner.simulation.crowd_agents import (
    HOME_STRETCH_M,
    LEG_CLEAR_M,
    MAKE_WAY_MAX_HOLD_S,
    MAKE_WAY_RINGS_M,
    OFF_PATH_M,
    CrowdState,
    FloatArray,
    Yield,
)
from kbplanner.simulation.social_force import Obstacle
from kbplanner.simulation.walk_checks import legs_clear_of, stretch


def make_way(crowd: CrowdState, i: int, path: FloatArray, clear_m: float) -> tuple[float, float] | None:
    """Worker ``i`` makes way for the robot, whose remaining ``path`` (n, 2, base centre) must pass
    them by ``clear_m`` (footprint reach + S_p + the worker's radius): the spot (see module docstring),
    or None (nowhere better to stand). The worker stays there until the robot has passed."""
    a = crowd.agents[i]
    if len(path) == 0:
        return None
    p = crowd.pos[i]
    robot = crowd._history[-1] if crowd._history else None

    def clearance(q: FloatArray) -> float:
        return float(np.min(np.hypot(path[:, 0] - q[0], path[:, 1] - q[1])))

    comfort = clear_m + a.params.comfort_distance_m
    # tiers, best first: (away from the robot, comfort), (away, clear), (by it, comfort), (by it, clear)
    firsts: dict[tuple[bool, bool], FloatArray] = {}
    farthest: tuple[float, FloatArray] | None = None
    step = crowd.router.grid.resolution / 2 if crowd.router.grid is not None else 0.05
    for r in MAKE_WAY_RINGS_M:
        cands = [p + r * np.array([math.cos(j * math.pi / 8), math.sin(j * math.pi / 8)])
                 for j in range(16)]
        f = np.linspace(0.0, 1.0, max(2, int(r / step) + 1))[:, None]  # no wall skipped
        legs = [p[None, :] + f * (q - p)[None, :] for q in cands]
        by_it = legs_clear_of(legs, robot, LEG_CLEAR_M)
        away = legs_clear_of(legs, robot, math.inf)  # never closer to the robot than now
        for q, leg, ok, aw in zip(cands, legs, by_it, away, strict=True):
            if not ok or not crowd._free_at(q) or not crowd._walkable_along(leg):
                continue
            c = clearance(q)
            if c >= clear_m:
                firsts.setdefault((aw, c >= comfort), q)
            if farthest is None or c > farthest[0]:
                farthest = (c, q)
        if (True, True) in firsts:
            break
    best = next((firsts[k] for k in ((True, True), (True, False), (False, True), (False, False))
                 if k in firsts), None)
    if best is None:
        if farthest is None or farthest[0] < clearance(p) + 0.5:
            return None
        best = farthest[1]
    spot = (float(best[0]), float(best[1]))
    if a.yielding is not None:
        home, walking = a.yielding.home, a.yielding.walking
    elif a.walking:  # they will walk on along their route: the robot must have passed its next stretch
        home, walking = stretch(np.vstack([p[None, :], a.path[a.wp :]]), HOME_STRETCH_M), True
    else:
        stop = a.spec.stops[a.k]
        home, walking = np.array([[stop.x, stop.y]]), False
    a.yielding = Yield(np.array(path, dtype=np.float64), clear_m, home, walking,
                       crowd.t + MAKE_WAY_MAX_HOLD_S)
    a.making_way = True
    if a.walking:  # wait there, then walk on to the next stop
        a.walking, a.slow_s, a.until = False, 0.0, math.inf
    a.anchor = spot
    return spot


def release(crowd: CrowdState, robot: Obstacle | None) -> None:
    """Workers who made way go back once the robot has passed (see module docstring)."""
    for a in crowd.agents:
        y = a.yielding
        if y is None:
            continue
        passed = crowd.t >= y.deadline
        if not passed and robot is not None:
            rx, ry = robot.pose[0], robot.pose[1]
            rest = y.path[y.progress :]
            d = np.hypot(rest[:, 0] - rx, rest[:, 1] - ry)
            k = int(np.argmin(d))
            y.progress += k
            hx, hy = y.home[:, 0], y.home[:, 1]
            far = float(np.min(np.hypot(hx - rx, hy - ry))) >= y.clear_m
            ahead = y.path[y.progress + 1 :]
            clear_ahead = len(ahead) == 0 or float(
                np.min(np.hypot(ahead[:, 0, None] - hx[None, :], ahead[:, 1, None] - hy[None, :]))
            ) >= y.clear_m
            passed = far and (clear_ahead or float(d[k]) > OFF_PATH_M)
        if not passed:
            continue
        a.yielding, a.making_way = None, False
        if y.walking:
            a.until = crowd.t  # walks on to the next stop (from the spot)
        else:
            stop = a.spec.stops[a.k]
            a.anchor = (stop.x, stop.y)

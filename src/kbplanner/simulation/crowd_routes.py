"""B5 reactive workers, route following: the velocity each worker of the crowd wants this period.

Takes the crowd (:class:`~kbplanner.simulation.crowd.Crowd`: its workers, their positions, the clock and
the walking router); gives per worker the desired velocity of the social-force step
(:mod:`kbplanner.simulation.social_force`): a walking worker heads for the next waypoint of their route at
their walking speed and, arrived at the last, starts the stop's dwell; a waiting worker whose wait is
over sets off to the next stop along the router's path; a waiting worker heads back to their anchor (the
stop, or the spot where they make way), straight when near it, else along a walking path planned again
when they make little headway (pushed aside by the robot, sliding along a wall).

(In plain floats: the same subtractions, divisions and products as on numpy rows, ``math.hypot`` where
the former code took it and ``np.hypot`` where it did, so the numbers are identical.)
"""

from __future__ import annotations

import math

import numpy as np

from kbplanner.simulation.crowd_agents import (
    ARRIVED_M,
    HEADWAY_M,
    STUCK_S,
    WAY_ROUTED_M,
    WAYPOINT_REACHED_M,
    Agent,
    CrowdState,
    FloatArray,
)

_hypot = np.hypot  # on two floats: the numbers of np.hypot on numpy rows


def desired_rows(crowd: CrowdState) -> list[tuple[float, float]]:
    """The desired velocity (x, y) of every worker: along their route, or back to their anchor."""
    rows: list[tuple[float, float]] = []
    xs, ys = crowd._xs, crowd._ys
    t = crowd.t
    for i, a in enumerate(crowd.agents):
        px, py = xs[i], ys[i]
        if not a.walking and t >= a.until and a.yielding is None:
            a.making_way = False
            there = a.spec.stops[(a.k + 1) % len(a.spec.stops)]
            a.path = crowd.router.path((px, py), (there.x, there.y))
            a.wp, a.walking = 1, True
        if a.walking:
            pts = a.points()
            last = len(pts) - 1
            while a.wp < last and math.hypot(pts[a.wp][0] - px, pts[a.wp][1] - py) < WAYPOINT_REACHED_M:
                a.wp += 1
            gx, gy = pts[a.wp]
            d = math.hypot(gx - px, gy - py)
            if a.wp == last and d < ARRIVED_M:
                a.walking = False
                a.k = (a.k + 1) % len(a.spec.stops)
                stop = a.spec.stops[a.k]
                a.anchor = (stop.x, stop.y)
                a.until = t + stop.dwell_s * float(a.rng.uniform(0.8, 1.2))
            else:
                m = max(d, 1e-9)
                rows.append(((gx - px) / m * a.v0, (gy - py) / m * a.v0))
                continue
        # waiting: back to the stop (or the spot where they make way), at walking pace at most
        ax, ay = a.anchor
        dx, dy = ax - px, ay - py
        d = float(_hypot(dx, dy))
        if d <= WAY_ROUTED_M:  # near the anchor: straight there (the very offsets and distance)
            a.way, a.way_slow_s, a.way_best_m = None, 0.0, math.inf
        else:
            tx, ty = crowd._way_target(a, np.array([px, py], dtype=np.float64)).tolist()
            dx, dy = tx - px, ty - py
            d = float(_hypot(dx, dy))
        if d > 0.05:
            f = min(a.v0, d / a.params.relaxation_time_s)
            rows.append((dx / d * f, dy / d * f))
        else:
            rows.append((0.0, 0.0))
    return rows


def way_target(crowd: CrowdState, a: Agent, p: FloatArray) -> FloatArray:
    """Where a waiting worker heads for: their anchor, along a walking path (the router's) when it is
    more than ``WAY_ROUTED_M`` away; the path is planned again from where they are when they have
    made little headway for ``STUCK_S`` (not ``HEADWAY_M`` nearer along it: pushed aside by the robot,
    sliding along a wall, or to and fro at full speed), and from then on, making way, they walk it
    regardless of the robot's push (the crowd's step)."""
    anchor = np.array(a.anchor)
    if float(np.hypot(*(anchor - p))) <= WAY_ROUTED_M:
        a.way, a.way_slow_s, a.way_best_m = None, 0.0, math.inf
        return anchor
    if a.way is None or a.way_to != a.anchor:
        a.way_slow_s, a.way_best_m = 0.0, math.inf
    elif a.way_best_m - walk_left(a, p) >= HEADWAY_M:
        a.way_best_m = walk_left(a, p)
        if not (a.making_way and a.way_slow_s >= STUCK_S):  # making way, once stuck they walk on
            a.way_slow_s = 0.0
    else:
        a.way_slow_s += crowd.dt  # headway, not speed: pushed to and fro by the robot is no headway
    if a.way is None or a.way_to != a.anchor or STUCK_S <= a.way_slow_s < STUCK_S + crowd.dt:
        step = crowd.router.grid.resolution / 2 if crowd.router.grid is not None else 0.05
        f = np.linspace(0.0, 1.0, max(2, int(float(np.hypot(*(anchor - p))) / step) + 1))[:, None]
        if crowd._walkable_along(p[None, :] + f * (anchor - p)[None, :]):
            a.way = np.array([p, anchor])  # straight there
        else:
            a.way = crowd.router.path((float(p[0]), float(p[1])), a.anchor)
        a.way_i, a.way_to, a.way_best_m = 1, a.anchor, math.inf  # headway counted on the new way
    while a.way_i < len(a.way) - 1 and float(np.hypot(*(a.way[a.way_i] - p))) < WAYPOINT_REACHED_M:
        a.way_i += 1
    if not math.isfinite(a.way_best_m):
        a.way_best_m = walk_left(a, p)
    return np.asarray(a.way[min(a.way_i, len(a.way) - 1)], dtype=np.float64)


def walk_left(a: Agent, p: FloatArray) -> float:
    """How far a waiting worker at ``p`` has left to walk along their ``way`` (from its next point)."""
    assert a.way is not None
    rest = a.way[min(a.way_i, len(a.way) - 1):]
    return float(np.hypot(*(rest[0] - p)) + np.sum(np.hypot(*np.diff(rest, axis=0).T)))

# Over 500 lines: the reactive crowd (route following, social-force step, making way); next to split.
"""B5 reactive workers: people who walk their routes and yield to the robot and to each other.

Takes the site's workers (:func:`kbplanner.simulation.workers.load_workers`: route stops, dwell times,
walking speed, social-force parameters from the site Turtle) and the ground occupancy grid; gives a
:class:`Crowd` that the simulation environment steps once per control period together with the
robot. Each worker, as in the scripted model (:mod:`kbplanner.simulation.workers`), waits
``kbp:dwellTime`` at a stop, then walks to the next stop along the shortest free path on the ground
map (the same router, so people walk around buildings and fences) and repeats the route; the seed
draws the same things (speed x0.9-1.1, dwell x0.8-1.2, where on the route a worker starts). Unlike
the scripted model, the motion is not precomputed: the walking direction is the route's next
waypoint and the velocity follows the social-force model (:mod:`kbplanner.simulation.social_force`),
so workers slow down, step aside and wait for the robot and each other. A waiting worker stands at
their stop and also steps aside when the robot comes close, then returns. A worker for whom the
stopped robot has waited (the navigation asks, :meth:`Crowd.make_way`) walks to the nearest walkable
spot clear of the robot's remaining path by the protective separation distance plus their comfort
distance (reached without passing the robot), as people on a site let a machine pass, and stays there
until the robot has passed: until the rest of its path and the robot itself are that far from where
the worker will go back to (their stop, or a walking worker's next stop); then a waiting
worker goes back to their stop and a walking worker walks on. ``MAKE_WAY_MAX_HOLD_S`` bounds the wait
(a robot that gave up or went another way).

Deterministic: per-worker random generators seeded by the run seed and the worker's IRI, numpy in
a fixed order; the same inputs and seed give the same motion.
"""

from __future__ import annotations

import math
import struct
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from kbplanner.simulation.separation import WORKER_RADIUS_M, reach_m, rects_distance
from kbplanner.simulation.social_force import (
    SMALL_CROWD,
    Obstacle,
    SocialForceParams,
    accelerations,
    accelerations_of,
    constants_of,
)
from kbplanner.simulation.walk_checks import (
    clear_legs,
    free_at,
    free_cell_check,
    legs_clear_of,
    maybe_within,
    stretch,
    walkable_along,
    walkable_step,
)
from kbplanner.simulation.workers import WorkerSpec, _rng_for, _Router
from kbplanner.world.occupancy import OccupancyGrid

FloatArray = npt.NDArray[np.float64]
_hypot = np.hypot  # on two floats: the numbers of np.hypot on numpy rows

STUCK_SPEED_MPS = 0.2  # a walking worker slower than this for STUCK_S looks for a way round the robot
STUCK_S = 2.0
HEADWAY_M = STUCK_SPEED_MPS * STUCK_S  # a worker walking to their anchor who has not come this much
# nearer (along their way) for STUCK_S has made little headway (pushed to and fro by the robot)
WAYPOINT_REACHED_M = 0.35
ARRIVED_M = 0.2
LEG_CLEAR_M = WORKER_RADIUS_M + 0.3  # the walk to a make-way spot keeps this clear of the robot's footprint
HOME_STRETCH_M = 10.0  # how much of a walking worker's route the robot must have passed before they walk on
WAY_ROUTED_M = 1.0  # a waiting worker farther than this from their anchor walks there along the router's path
CONTACT_MARGIN_M = 0.01  # a worker's own step keeps at least this much clear of the robot
MAKE_WAY_MAX_HOLD_S = 300.0  # a worker who made way goes back after this even if the robot has not passed
OFF_PATH_M = 1.0  # a robot this far from the path it asked for has left it (replanned, gave up)
MAKE_WAY_RINGS_M = tuple(0.5 * k for k in range(1, 13))  # where a worker looks for a spot to make way


@dataclass
class _Yield:
    """A worker who made way: the robot's path they wait for, how far it passes, where they go back to."""

    path: FloatArray  # the robot's remaining path (base centre, n x 2) when it asked
    clear_m: float  # from the base centre: footprint reach + S_p + the worker's radius
    home: FloatArray  # (n, 2): their stop, or the next HOME_STRETCH_M of a walking worker's route
    walking: bool  # walk on to the next stop when released (else: back to the stop)
    deadline: float  # released at this time at the latest
    progress: int = 0  # index of the path point the robot has reached


@dataclass
class _Agent:
    spec: WorkerSpec
    params: SocialForceParams
    rng: np.random.Generator
    v0: float
    k: int  # the stop the worker is at or walked from
    walking: bool = False
    until: float = 0.0  # end of the current wait
    path: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    wp: int = 0
    anchor: tuple[float, float] = (0.0, 0.0)
    slow_s: float = 0.0  # how long the worker has made little headway on their walk
    making_way: bool = False  # on the way to (or at) a spot where the worker lets the robot pass
    yielding: _Yield | None = None  # made way: waits there until the robot has passed
    way: FloatArray | None = None  # a waiting worker's walking path to their anchor (far from it)
    way_i: int = 0
    way_to: tuple[float, float] = (math.nan, math.nan)  # the anchor ``way`` leads to
    way_slow_s: float = 0.0  # how long they have made little headway on it
    way_best_m: float = math.inf  # the shortest walk left along ``way`` so far
    _points: tuple[FloatArray, list[list[float]]] | None = None  # ``path`` as floats, and of which array

    def points(self) -> list[list[float]]:
        """``path`` as lists of floats (the same numbers; converted once per path)."""
        if self._points is None or self._points[0] is not self.path:
            self._points = (self.path, self.path.tolist())
        return self._points[1]


class Crowd:
    """The reactive workers of a run (see module docstring)."""

    def __init__(
        self, specs: Sequence[WorkerSpec], grid: OccupancyGrid | None, *, seed: int, control_hz: float = 10.0
    ) -> None:
        self.specs = tuple(specs)
        self.router = _Router(grid, WORKER_RADIUS_M)
        self.dt = 1.0 / control_hz
        self.agents: list[_Agent] = []
        pos = []
        for s in self.specs:
            rng = _rng_for(s, seed)
            v0 = s.speed_mps * float(rng.uniform(0.9, 1.1))
            a = _Agent(s, s.social or SocialForceParams(), rng, v0, 0)
            if len(s.stops) > 1:
                a.k = int(rng.integers(len(s.stops)))
                done = float(rng.uniform(0.0, s.stops[a.k].dwell_s))
                a.until = s.stops[a.k].dwell_s * float(rng.uniform(0.8, 1.2)) - done
            else:
                a.until = math.inf
            stop = s.stops[a.k]
            a.anchor = (stop.x, stop.y)
            pos.append(a.anchor)
            self.agents.append(a)
        self.pos = np.array(pos, dtype=np.float64).reshape(-1, 2)
        self.vel = np.zeros_like(self.pos)
        self.heading = np.zeros(len(self.agents))
        self.t = 0.0
        delays = sorted({max(0, round(a.params.reaction_time_s * control_hz)) for a in self.agents})
        self._delays = delays
        self._positions: tuple[FloatArray, list[tuple[float, float, float]]] | None = None
        # per-worker constants of every step
        self._params = [a.params for a in self.agents]
        self._v0 = np.array([a.v0 for a in self.agents])
        self._masks = [np.array([round(a.params.reaction_time_s / self.dt) == delay for a in self.agents])
                       for delay in delays]
        self._history: deque[Obstacle | None] = deque(maxlen=(delays[-1] if delays else 0) + 1)
        self._active = np.ones(len(self.agents), dtype=bool)
        self._k = constants_of(self._params)
        self._vmax = self._v0 * self._k["vmax_factor"]  # cap_speed's limits: the same product
        self._vmax_list: list[float] = self._vmax.tolist()
        self._speeds: tuple[FloatArray, list[float]] | None = None  # the speeds of ``vel`` (that array)
        self._walk = free_cell_check(self.router.free, self.router.grid)  # the walking map is fixed
        self._active.flags.writeable = False
        self._one_delay = len(self._masks) == 1 and bool(self._masks[0].all())
        self._no_detour: dict[int, tuple[bytes, tuple[object, ...]]] = {}  # detours looked for in vain

    def __len__(self) -> int:
        return len(self.agents)

    # ---- route following ---------------------------------------------------------------------------
    def _desired(self) -> FloatArray:
        """The desired velocity (n, 2) of every worker: along their route, or back to their anchor."""
        return np.array(self._desired_rows(), dtype=np.float64).reshape(-1, 2)

    def _desired_rows(self) -> list[tuple[float, float]]:
        """:meth:`_desired` as (x, y) float pairs.

        (In plain floats: the same subtractions, divisions and products as on numpy rows, ``math.hypot``
        where the former code took it and ``np.hypot`` where it did, so the numbers are identical.)"""
        rows: list[tuple[float, float]] = []
        pos = self.pos.tolist()
        for i, a in enumerate(self.agents):
            px, py = pos[i]
            if not a.walking and self.t >= a.until and a.yielding is None:
                a.making_way = False
                there = a.spec.stops[(a.k + 1) % len(a.spec.stops)]
                a.path = self.router.path((px, py), (there.x, there.y))
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
                    a.until = self.t + stop.dwell_s * float(a.rng.uniform(0.8, 1.2))
                else:
                    m = max(d, 1e-9)
                    rows.append(((gx - px) / m * a.v0, (gy - py) / m * a.v0))
                    continue
            # waiting: back to the stop (or the spot where they make way), at walking pace at most
            ax, ay = a.anchor
            if float(_hypot(ax - px, ay - py)) <= WAY_ROUTED_M:  # near the anchor: straight there
                a.way, a.way_slow_s, a.way_best_m = None, 0.0, math.inf
                tx, ty = ax, ay
            else:
                tx, ty = self._way_target(a, self.pos[i]).tolist()
            dx, dy = tx - px, ty - py
            d = float(_hypot(dx, dy))
            if d > 0.05:
                f = min(a.v0, d / a.params.relaxation_time_s)
                rows.append((dx / d * f, dy / d * f))
            else:
                rows.append((0.0, 0.0))
        return rows

    def _way_target(self, a: _Agent, p: FloatArray) -> FloatArray:
        """Where a waiting worker heads for: their anchor, along a walking path (the router's) when it is
        more than ``WAY_ROUTED_M`` away; the path is planned again from where they are when they have
        made little headway for ``STUCK_S`` (not ``HEADWAY_M`` nearer along it: pushed aside by the robot,
        sliding along a wall, or to and fro at full speed), and from then on, making way, they walk it
        regardless of the robot's push (:meth:`step`)."""
        anchor = np.array(a.anchor)
        if float(np.hypot(*(anchor - p))) <= WAY_ROUTED_M:
            a.way, a.way_slow_s, a.way_best_m = None, 0.0, math.inf
            return anchor
        if a.way is None or a.way_to != a.anchor:
            a.way_slow_s, a.way_best_m = 0.0, math.inf
        elif a.way_best_m - self._walk_left(a, p) >= HEADWAY_M:
            a.way_best_m = self._walk_left(a, p)
            if not (a.making_way and a.way_slow_s >= STUCK_S):  # making way, once stuck they walk on
                a.way_slow_s = 0.0
        else:
            a.way_slow_s += self.dt  # headway, not speed: pushed to and fro by the robot is no headway
        if a.way is None or a.way_to != a.anchor or STUCK_S <= a.way_slow_s < STUCK_S + self.dt:
            step = self.router.grid.resolution / 2 if self.router.grid is not None else 0.05
            f = np.linspace(0.0, 1.0, max(2, int(float(np.hypot(*(anchor - p))) / step) + 1))[:, None]
            if self._walkable_along(p[None, :] + f * (anchor - p)[None, :]):
                a.way = np.array([p, anchor])  # straight there
            else:
                a.way = self.router.path((float(p[0]), float(p[1])), a.anchor)
            a.way_i, a.way_to, a.way_best_m = 1, a.anchor, math.inf  # headway counted on the new way
        while a.way_i < len(a.way) - 1 and float(np.hypot(*(a.way[a.way_i] - p))) < WAYPOINT_REACHED_M:
            a.way_i += 1
        if not math.isfinite(a.way_best_m):
            a.way_best_m = self._walk_left(a, p)
        return np.asarray(a.way[min(a.way_i, len(a.way) - 1)], dtype=np.float64)

    @staticmethod
    def _walk_left(a: _Agent, p: FloatArray) -> float:
        """How far a waiting worker at ``p`` has left to walk along their ``way`` (from its next point)."""
        assert a.way is not None
        rest = a.way[min(a.way_i, len(a.way) - 1):]
        return float(np.hypot(*(rest[0] - p)) + np.sum(np.hypot(*np.diff(rest, axis=0).T)))

    # ---- stepping ----------------------------------------------------------------------------------
    def step(self, robot: Obstacle | None) -> None:
        """Advance one control period with the robot where it is now (workers see it with a delay).

        (On plain floats: the same additions, products and divisions as the former numpy rows, numpy's
        ``hypot`` and ``arctan2`` on whole arrays where it took them, so the numbers are identical.)"""
        self._history.append(robot)
        self._release(robot)
        if robot is not None:
            self._detours(robot)
        rows = self._desired_rows()
        n = len(self.agents)
        pos = self.pos.tolist()
        vel0 = self.vel.tolist()
        xs, ys = [p[0] for p in pos], [p[1] for p in pos]
        vxs, vys = [v[0] for v in vel0], [v[1] for v in vel0]
        on = [True] * n
        if len(self._delays) == 1 and self._one_delay:  # everyone sees the robot with the same delay
            idx = len(self._history) - 1 - self._delays[0]
            ax, ay = self._accelerations(xs, ys, vxs, vys, rows, self._history[max(idx, 0)], on)
        else:
            ax, ay = [0.0] * n, [0.0] * n
            for delay, mask in zip(self._delays, self._masks, strict=True):
                idx = len(self._history) - 1 - delay
                seen = self._history[max(idx, 0)]
                if mask.any():
                    bx, by = self._accelerations(xs, ys, vxs, vys, rows, seen, on)
                    for i in np.flatnonzero(mask).tolist():
                        ax[i], ay[i] = bx[i], by[i]
        dt = self.dt
        # cap_speed: limited to vmax (the same products and quotient)
        ux = [vxs[i] + ax[i] * dt for i in range(n)]
        uy = [vys[i] + ay[i] * dt for i in range(n)]
        sp = _hypot(np.array(ux, dtype=np.float64), np.array(uy, dtype=np.float64)).tolist() if n else []
        vmax = self._vmax_list
        for i in range(n):
            f = vmax[i] / max(sp[i], 1e-12) if sp[i] > vmax[i] else 1.0
            ux[i], uy[i] = ux[i] * f, uy[i] * f
        near_m = WORKER_RADIUS_M + CONTACT_MARGIN_M + 1e-6  # maybe_within's bound
        reach = reach_m(robot.rects) if robot is not None else 0.0
        rx, ry = (robot.pose[0], robot.pose[1]) if robot is not None else (0.0, 0.0)
        walk = self._walk
        nxs: list[float] = []
        nys: list[float] = []
        for i in range(n):
            ox, oy, vx, vy = xs[i], ys[i], ux[i], uy[i]
            qx, qy = ox + vx * dt, oy + vy * dt
            if robot is not None and math.hypot(qx - rx, qy - ry) - reach <= near_m:
                q, v = self._constrain(np.array([ox, oy]), np.array([qx, qy]), np.array([vx, vy]), robot)
                (qx, qy), (vx, vy) = q.tolist(), v.tolist()
            elif walk is not None and not walk(qx, qy) and walk(ox, oy):
                # certainly clear of the robot, out of the walkable cells: :meth:`_constrain`'s wall
                # rule in plain floats (the same numbers): slide along one axis, else stay
                if walk(qx, oy):
                    qx, qy, vx, vy = qx, oy, (qx - ox) / dt, (oy - oy) / dt
                elif walk(ox, qy):
                    qx, qy, vx, vy = ox, qy, (ox - ox) / dt, (qy - oy) / dt
                else:
                    qx, qy, vx, vy = ox, oy, 0.0, 0.0
            a = self.agents[i]
            dx, dy = rows[i]
            if a.making_way and (dx != 0 or dy != 0) and ((vx == 0 and vy == 0) or a.way_slow_s >= STUCK_S):
                # pinned (the robot's push against a wall) or held in place by its push for STUCK_S: making
                # way, the worker walks the way they want (still never into the robot or a wall)
                old, want = np.array([ox, oy]), np.array([dx, dy])
                q, v = self._constrain(old, old + want * dt, want, robot)
                (qx, qy), (vx, vy) = q.tolist(), v.tolist()
            nxs.append(qx)
            nys.append(qy)
            ux[i], uy[i] = vx, vy
        vel = np.array([ux, uy], dtype=np.float64).T.reshape(n, 2)
        speed = np.hypot(vel[:, 0], vel[:, 1])
        moving = speed > 0.05
        if moving.any():
            self.heading = np.where(moving, np.arctan2(vel[:, 1], vel[:, 0]), self.heading)
        self.pos, self.vel = np.array([nxs, nys], dtype=np.float64).T.reshape(n, 2), vel
        self._speeds = (vel, speed.tolist())
        self.t += self.dt

    def _accelerations(self, xs: list[float], ys: list[float], vxs: list[float], vys: list[float],
                       rows: list[tuple[float, float]], seen: Obstacle | None, on: list[bool]
                       ) -> tuple[list[float], list[float]]:
        """The social-force accelerations (:func:`accelerations`), on plain floats for a few workers."""
        if len(xs) <= SMALL_CROWD:
            return accelerations_of(xs, ys, vxs, vys, rows, self._k, seen, on)
        acc = accelerations(self.pos, self.vel, np.array(rows, dtype=np.float64).reshape(-1, 2), self._params,
                            seen, self._active, constants=self._k)
        return acc[:, 0].tolist(), acc[:, 1].tolist()

    def _detours(self, robot: Obstacle) -> None:
        """A walking worker held up by the robot for STUCK_S walks round it: a via point beside the
        robot's footprint (its reach plus the comfort distance, 16 bearings), the one that keeps the
        walk shortest with both legs walkable and clear of the footprint."""

        kept = self._speeds
        sp = kept[1] if kept is not None and kept[0] is self.vel else np.hypot(self.vel[:, 0], self.vel[:, 1])
        for i, a in enumerate(self.agents):
            if not a.walking or sp[i] >= STUCK_SPEED_MPS:
                a.slow_s = 0.0
                continue
            a.slow_s += self.dt
            if a.slow_s < STUCK_S:
                continue
            a.slow_s = 0.0
            p = self.pos[i]
            goal = a.path[min(a.wp, len(a.path) - 1)]
            radius = reach_m(robot.rects) + WORKER_RADIUS_M + a.params.comfort_distance_m
            # the same look (bit for bit: where, whereto, the robot's pose and footprint) found no way
            # round last time: it finds none again
            key = (struct.pack("5d", p[0], p[1], goal[0], goal[1], radius) + struct.pack("3d", *robot.pose),
                   tuple(robot.rects))
            if self._no_detour.get(i) == key:
                continue
            vias = [
                np.array([robot.pose[0] + radius * math.cos(j * math.pi / 8),
                          robot.pose[1] + radius * math.sin(j * math.pi / 8)])
                for j in range(16)
            ]
            first = self._clear_many([(p, via) for via in vias], robot)
            ways = [via for via, ok in zip(vias, first, strict=True) if ok]
            second = self._clear_many([(via, goal) for via in ways], robot)
            best: tuple[float, FloatArray] | None = None
            for via, ok in zip(ways, second, strict=True):
                if not ok:
                    continue
                cost = float(np.hypot(*(via - p)) + np.hypot(*(goal - via)))
                if best is None or cost < best[0]:
                    best = (cost, via)
            if best is not None:
                a.path = np.vstack([a.path[: a.wp], best[1][None, :], a.path[a.wp :]])
                self._no_detour.pop(i, None)
            else:
                self._no_detour[i] = key

    def make_way(self, i: int, path: FloatArray, clear_m: float) -> tuple[float, float] | None:
        """Worker ``i`` makes way for the robot, whose remaining ``path`` (n, 2, base centre) must pass
        them by ``clear_m`` (footprint reach + S_p + the worker's radius). The spot: on rings of 0.5 m,
        16 bearings, nearest first, walkable in a straight line from where the worker stands and never
        closer to the robot's footprint than now or than ``LEG_CLEAR_M`` (not through the robot),
        preferring a walk that never comes closer to it than now (away from the robot); the first at
        ``clear_m`` plus the worker's comfort distance from every path point, else the first at
        ``clear_m``, else the walkable spot farthest from the path if it gains 0.5 m. The worker stays
        there until the robot has passed (:meth:`_release`). Returns the spot, or None (nowhere
        better to stand)."""
        a = self.agents[i]
        if len(path) == 0:
            return None
        p = self.pos[i]
        robot = self._history[-1] if self._history else None

        def clearance(q: FloatArray) -> float:
            return float(np.min(np.hypot(path[:, 0] - q[0], path[:, 1] - q[1])))

        comfort = clear_m + a.params.comfort_distance_m
        # tiers, best first: (away from the robot, comfort), (away, clear), (by it, comfort), (by it, clear)
        firsts: dict[tuple[bool, bool], FloatArray] = {}
        farthest: tuple[float, FloatArray] | None = None
        step = self.router.grid.resolution / 2 if self.router.grid is not None else 0.05
        for r in MAKE_WAY_RINGS_M:
            cands = [p + r * np.array([math.cos(j * math.pi / 8), math.sin(j * math.pi / 8)])
                     for j in range(16)]
            f = np.linspace(0.0, 1.0, max(2, int(r / step) + 1))[:, None]  # no wall skipped
            legs = [p[None, :] + f * (q - p)[None, :] for q in cands]
            by_it = legs_clear_of(legs, robot, LEG_CLEAR_M)
            away = legs_clear_of(legs, robot, math.inf)  # never closer to the robot than now
            for q, leg, ok, aw in zip(cands, legs, by_it, away, strict=True):
                if not ok or not self._free_at(q) or not self._walkable_along(leg):
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
        a.yielding = _Yield(np.array(path, dtype=np.float64), clear_m, home, walking,
                            self.t + MAKE_WAY_MAX_HOLD_S)
        a.making_way = True
        if a.walking:  # wait there, then walk on to the next stop
            a.walking, a.slow_s, a.until = False, 0.0, math.inf
        a.anchor = spot
        return spot

    def _release(self, robot: Obstacle | None) -> None:
        """Workers who made way go back once the robot has passed: the robot's centre is ``clear_m``
        from where they go back to, and so is the rest of its path (from the point it has reached), or
        it reached the path's end or left the path; at the yield's deadline at the latest."""
        for a in self.agents:
            y = a.yielding
            if y is None:
                continue
            passed = self.t >= y.deadline
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
                a.until = self.t  # walks on to the next stop (from the spot)
            else:
                stop = a.spec.stops[a.k]
                a.anchor = (stop.x, stop.y)

    def _clear_many(self, legs: Sequence[tuple[FloatArray, FloatArray]], robot: Obstacle) -> list[bool]:
        """Per leg (p, q): sampled every 0.1 m, clear of the footprint and walkable (:func:`clear_legs`)."""
        return clear_legs(legs, robot, self.router.free, self.router.grid, self._walk)

    def _free_at(self, q: FloatArray) -> bool:
        """Whether a worker may stand at ``q`` (a free cell of the walking map; no map: anywhere)."""
        return free_at(q, self.router.free, self.router.grid)

    def _walkable_along(self, pts: FloatArray) -> bool:
        """:meth:`_walkable` for every step between consecutive points, vectorised."""
        return walkable_along(pts, self.router.free, self.router.grid)

    def _constrain(
        self, old: FloatArray, new: FloatArray, vel: FloatArray, robot: Obstacle | None
    ) -> tuple[FloatArray, FloatArray]:
        """A worker's own step never ends in the robot's footprint or in a wall (see module doc)."""
        if robot is not None and maybe_within(new, robot, WORKER_RADIUS_M + CONTACT_MARGIN_M):
            d, ux, uy = rects_distance(new[None, 0], new[None, 1], robot.pose, robot.rects)
            if d[0] < WORKER_RADIUS_M + CONTACT_MARGIN_M:
                n = np.array([ux[0], uy[0]])
                into = float(vel @ n)
                if into < 0 and (n != 0).any():
                    vel = vel - into * n
                cand = old + vel * self.dt
                d2, _, _ = rects_distance(cand[None, 0], cand[None, 1], robot.pose, robot.rects)
                d0, _, _ = rects_distance(old[None, 0], old[None, 1], robot.pose, robot.rects)
                if d2[0] < WORKER_RADIUS_M + CONTACT_MARGIN_M and d2[0] <= d0[0]:
                    return old.copy(), np.zeros(2)
                new = cand
        if not self._walkable(old, new):
            for cand in (np.array([new[0], old[1]]), np.array([old[0], new[1]])):
                if self._walkable(old, cand):
                    return cand, (cand - old) / self.dt
            return old.copy(), np.zeros(2)
        return new, vel

    def _walkable(self, old: FloatArray, new: FloatArray) -> bool:
        return walkable_step(old, new, self.router.free, self.router.grid)

    def positions(self) -> list[tuple[float, float, float]]:
        """(x, y, heading) of every worker now."""
        if self._positions is None or self._positions[0] is not self.pos:
            rows = [(x, y, h) for (x, y), h in zip(self.pos.tolist(), self.heading.tolist(), strict=True)]
            self._positions = (self.pos, rows)
        return list(self._positions[1])

    def speeds(self) -> FloatArray:
        """Walking speed (m/s) of every worker now."""
        return np.asarray(np.hypot(self.vel[:, 0], self.vel[:, 1]), dtype=np.float64)

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
their stop and also steps aside when the robot comes close, then returns. A waiting worker for whom the
stopped robot has waited (the navigation asks, :meth:`Crowd.make_way`) walks to the nearest walkable
spot clear of the robot's remaining path, as people on a site let a machine pass, and goes back to
their stop after ``MAKE_WAY_HOLD_S`` (a walking worker waits there as long, then walks on).

Deterministic: per-worker random generators seeded by the run seed and the worker's IRI, numpy in
a fixed order; the same inputs and seed give the same motion.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from kbplanner.simulation.separation import WORKER_RADIUS_M, reach_m, rects_distance
from kbplanner.simulation.social_force import Obstacle, SocialForceParams, accelerations, cap_speed
from kbplanner.simulation.workers import WorkerSpec, _rng_for, _Router
from kbplanner.world.occupancy import OccupancyGrid

FloatArray = npt.NDArray[np.float64]

STUCK_SPEED_MPS = 0.2  # a walking worker slower than this for STUCK_S looks for a way round the robot
STUCK_S = 2.0
WAYPOINT_REACHED_M = 0.35
ARRIVED_M = 0.2
CONTACT_MARGIN_M = 0.01  # a worker's own step keeps at least this much clear of the robot
MAKE_WAY_HOLD_S = 60.0  # a worker who made way for the robot goes back to their stop after this
MAKE_WAY_RINGS_M = tuple(0.5 * k for k in range(1, 13))  # where a worker looks for a spot to make way


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
    aside_until: float | None = None  # made way for the robot: back to the stop at this time
    making_way: bool = False  # on the way to (or at) a spot where the worker lets the robot pass


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

    def __len__(self) -> int:
        return len(self.agents)

    # ---- route following ---------------------------------------------------------------------------
    def _desired(self) -> FloatArray:
        out = np.zeros_like(self.pos)
        for i, a in enumerate(self.agents):
            p = self.pos[i]
            if not a.walking and self.t >= a.until:
                a.making_way = False
                here, there = a.spec.stops[a.k], a.spec.stops[(a.k + 1) % len(a.spec.stops)]
                a.path = self.router.path((float(p[0]), float(p[1])), (there.x, there.y))
                a.wp, a.walking = 1, True
                del here
            if a.walking:
                while a.wp < len(a.path) - 1 and math.hypot(*(a.path[a.wp] - p)) < WAYPOINT_REACHED_M:
                    a.wp += 1
                goal = a.path[a.wp]
                d = math.hypot(*(goal - p))
                if a.wp == len(a.path) - 1 and d < ARRIVED_M:
                    a.walking, a.aside_until = False, None
                    a.k = (a.k + 1) % len(a.spec.stops)
                    stop = a.spec.stops[a.k]
                    a.anchor = (stop.x, stop.y)
                    a.until = self.t + stop.dwell_s * float(a.rng.uniform(0.8, 1.2))
                else:
                    out[i] = (goal - p) / max(d, 1e-9) * a.v0
                    continue
            if a.aside_until is not None and self.t >= a.aside_until:
                stop = a.spec.stops[a.k]
                a.anchor, a.aside_until, a.making_way = (stop.x, stop.y), None, False
            # waiting: back to the stop (or the spot where they make way), at walking pace at most
            d_vec = np.array(a.anchor) - p
            d = float(np.hypot(*d_vec))
            if d > 0.05:
                out[i] = d_vec / d * min(a.v0, d / a.params.relaxation_time_s)
        return out

    # ---- stepping ----------------------------------------------------------------------------------
    def step(self, robot: Obstacle | None) -> None:
        """Advance one control period with the robot where it is now (workers see it with a delay)."""
        self._history.append(robot)
        if robot is not None:
            self._detours(robot)
        desired = self._desired()
        params = self._params
        v0 = self._v0
        active = np.ones(len(self.agents), dtype=bool)
        acc = np.zeros_like(self.pos)
        for delay, mask in zip(self._delays, self._masks, strict=True):
            idx = len(self._history) - 1 - delay
            seen = self._history[max(idx, 0)]
            if mask.any():
                a_all = accelerations(self.pos, self.vel, desired, params, seen, active)
                acc[mask] = a_all[mask]
        vel = cap_speed(self.vel + acc * self.dt, v0, params)
        new = self.pos + vel * self.dt
        for i, a in enumerate(self.agents):
            new[i], vel[i] = self._constrain(self.pos[i], new[i], vel[i], robot)
            if a.making_way and not vel[i].any() and desired[i].any():
                # pinned (the robot's push against a wall): making way, the worker walks the way they want
                new[i], vel[i] = self._constrain(self.pos[i], self.pos[i] + desired[i] * self.dt, desired[i],
                                                 robot)
        moving = np.hypot(vel[:, 0], vel[:, 1]) > 0.05
        self.heading = np.where(moving, np.arctan2(vel[:, 1], vel[:, 0]), self.heading)
        self.pos, self.vel = new, vel
        self.t += self.dt

    def _detours(self, robot: Obstacle) -> None:
        """A walking worker held up by the robot for STUCK_S walks round it: a via point beside the
        robot's footprint (its reach plus the comfort distance, 16 bearings), the one that keeps the
        walk shortest with both legs walkable and clear of the footprint."""

        sp = np.hypot(self.vel[:, 0], self.vel[:, 1])
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

    def make_way(self, i: int, path: FloatArray, clear_m: float) -> tuple[float, float] | None:
        """Worker ``i`` makes way for the robot: the nearest spot (rings of 0.5 m,
        16 bearings, in that order) that is walkable in a straight line from where the worker stands
        and at least ``clear_m`` from every point of the robot's remaining ``path`` (n, 2); else the
        walkable spot farthest from the path if it gains 0.5 m. A waiting worker stands there until
        ``MAKE_WAY_HOLD_S`` has passed, then goes back to their stop; a walking worker waits there as
        long, then walks on to their next stop. Returns the spot, or None (nowhere better to stand)."""
        a = self.agents[i]
        if len(path) == 0:
            return None
        p = self.pos[i]

        def clearance(q: FloatArray) -> float:
            return float(np.min(np.hypot(path[:, 0] - q[0], path[:, 1] - q[1])))

        best: tuple[float, FloatArray] | None = None
        step = self.router.grid.resolution / 2 if self.router.grid is not None else 0.05
        for r in MAKE_WAY_RINGS_M:
            for j in range(16):
                q = p + r * np.array([math.cos(j * math.pi / 8), math.sin(j * math.pi / 8)])
                f = np.linspace(0.0, 1.0, max(2, int(r / step) + 1))[:, None]  # no wall skipped
                if not self._free_at(q) or not self._walkable_along(p[None, :] + f * (q - p)[None, :]):
                    continue
                c = clearance(q)
                if c >= clear_m:
                    best = (math.inf, q)
                    break
                if best is None or c > best[0]:
                    best = (c, q)
            if best is not None and best[0] == math.inf:
                break
        if best is None or (best[0] != math.inf and best[0] < clearance(p) + 0.5):
            return None
        spot = (float(best[1][0]), float(best[1][1]))
        a.making_way = True
        if a.walking:  # wait there, then walk on to the next stop
            a.walking, a.slow_s = False, 0.0
            a.anchor, a.until, a.aside_until = spot, self.t + MAKE_WAY_HOLD_S, None
        else:
            a.anchor, a.aside_until = spot, self.t + MAKE_WAY_HOLD_S
        return spot

    def _clear_many(self, legs: Sequence[tuple[FloatArray, FloatArray]], robot: Obstacle) -> list[bool]:
        """Per leg (p, q): sampled every 0.1 m, clear of the footprint and walkable. One distance query
        for all legs' samples (element-wise the same numbers as one query per leg)."""
        if not legs:
            return []
        samples = []
        for p, q in legs:
            n = max(2, int(np.hypot(*(q - p)) / 0.1) + 1)
            f = np.linspace(0.0, 1.0, n)[:, None]
            samples.append(p[None, :] + f * (q - p)[None, :])
        pts = np.concatenate(samples)
        d_all, _, _ = rects_distance(pts[:, 0], pts[:, 1], robot.pose, robot.rects)
        out = []
        start = 0
        for leg in samples:
            d = d_all[start : start + len(leg)]
            start += len(leg)
            out.append(float(d.min()) >= WORKER_RADIUS_M + 0.3 and self._walkable_along(leg))
        return out

    def _free_at(self, q: FloatArray) -> bool:
        """Whether a worker may stand at ``q`` (a free cell of the walking map; no map: anywhere)."""
        free, g = self.router.free, self.router.grid
        if free is None or g is None:
            return True
        ix = math.floor((q[0] - g.origin[0]) / g.resolution)
        iy = math.floor((q[1] - g.origin[1]) / g.resolution)
        return 0 <= iy < free.shape[0] and 0 <= ix < free.shape[1] and bool(free[iy, ix])

    def _walkable_along(self, pts: FloatArray) -> bool:
        """:meth:`_walkable` for every step between consecutive points, vectorised."""
        free = self.router.free
        g = self.router.grid
        if free is None or g is None:
            return True
        ix = np.floor((pts[:, 0] - g.origin[0]) / g.resolution).astype(np.int64)
        iy = np.floor((pts[:, 1] - g.origin[1]) / g.resolution).astype(np.int64)
        inside = (ix >= 0) & (iy >= 0) & (iy < free.shape[0]) & (ix < free.shape[1])
        ok = np.zeros(len(pts), dtype=bool)
        ok[inside] = free[iy[inside], ix[inside]].astype(bool)
        return bool(np.all(ok[1:] | ~ok[:-1]))

    def _constrain(
        self, old: FloatArray, new: FloatArray, vel: FloatArray, robot: Obstacle | None
    ) -> tuple[FloatArray, FloatArray]:
        """A worker's own step never ends in the robot's footprint or in a wall (see module doc)."""
        if robot is not None:
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
        free = self.router.free
        g = self.router.grid
        if free is None or g is None:
            return True

        def ok(p: FloatArray) -> bool:
            ix = math.floor((p[0] - g.origin[0]) / g.resolution)
            iy = math.floor((p[1] - g.origin[1]) / g.resolution)
            return 0 <= iy < free.shape[0] and 0 <= ix < free.shape[1] and bool(free[iy, ix])

        return ok(new) or not ok(old)

    def positions(self) -> list[tuple[float, float, float]]:
        """(x, y, heading) of every worker now."""
        if self._positions is None or self._positions[0] is not self.pos:
            rows = [(float(p[0]), float(p[1]), float(h)) for p, h in zip(self.pos, self.heading, strict=True)]
            self._positions = (self.pos, rows)
        return list(self._positions[1])

    def speeds(self) -> FloatArray:
        """Walking speed (m/s) of every worker now."""
        return np.asarray(np.hypot(self.vel[:, 0], self.vel[:, 1]), dtype=np.float64)

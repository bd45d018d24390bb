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

The parts: a worker's state (:mod:`~kbplanner.simulation.crowd_agents`), route following
(:mod:`~kbplanner.simulation.crowd_routes`), a way round the robot
(:mod:`~kbplanner.simulation.crowd_detours`), making way (:mod:`~kbplanner.simulation.crowd_make_way`);
here the step that moves everyone.

Deterministic: per-worker random generators seeded by the run seed and the worker's IRI, numpy in
a fixed order; the same inputs and seed give the same motion.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from kbplanner.simulation import crowd_detours, crowd_make_way, crowd_routes, walk_store
from kbplanner.simulation.crowd_agents import (
    ARRIVED_M,
    CONTACT_MARGIN_M,
    HEADWAY_M,
    HOME_STRETCH_M,
    LEG_CLEAR_M,
    MAKE_WAY_MAX_HOLD_S,
    MAKE_WAY_RINGS_M,
    OFF_PATH_M,
    STUCK_S,
    STUCK_SPEED_MPS,
    WAY_ROUTED_M,
    WAYPOINT_REACHED_M,
    Agent,
    Yield,
)
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
    maybe_within,
    walkable_along,
    walkable_step,
)
from kbplanner.simulation.workers import WorkerSpec, _rng_for, _Router
from kbplanner.world.occupancy import OccupancyGrid

__all__ = ["ARRIVED_M", "CONTACT_MARGIN_M", "HEADWAY_M", "HOME_STRETCH_M", "LEG_CLEAR_M",
           "MAKE_WAY_MAX_HOLD_S", "MAKE_WAY_RINGS_M", "OFF_PATH_M", "STUCK_S", "STUCK_SPEED_MPS",
           "WAYPOINT_REACHED_M", "WAY_ROUTED_M", "Crowd", "Obstacle"]

FloatArray = npt.NDArray[np.float64]
_hypot = np.hypot  # on two floats: the numbers of np.hypot on numpy rows
_Agent, _Yield = Agent, Yield  # (the former names)


class Crowd:
    """The reactive workers of a run (see module docstring)."""

    def __init__(
        self, specs: Sequence[WorkerSpec], grid: OccupancyGrid | None, *, seed: int, control_hz: float = 10.0
    ) -> None:
        self.specs = tuple(specs)
        # (the walking map's cells kept by an earlier run or the early builds, where a folder is given)
        self.router = _Router(grid, WORKER_RADIUS_M,
                              walk_store.walk_cells_kept(grid, WORKER_RADIUS_M) if grid is not None else None)
        self.dt = 1.0 / control_hz
        self.agents: list[Agent] = []
        pos = []
        for s in self.specs:
            rng = _rng_for(s, seed)
            v0 = s.speed_mps * float(rng.uniform(0.9, 1.1))
            a = Agent(s, s.social or SocialForceParams(), rng, v0, 0)
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
        # the state in plain floats (the arrays pos, vel and heading are made from them when asked)
        self._xs: list[float] = [float(x) for x, _ in pos]
        self._ys: list[float] = [float(y) for _, y in pos]
        self._vxs: list[float] = [0.0] * len(pos)
        self._vys: list[float] = [0.0] * len(pos)
        self._hs: list[float] = [0.0] * len(pos)
        self._pos: FloatArray | None = np.array(pos, dtype=np.float64).reshape(-1, 2)
        self._vel: FloatArray | None = np.zeros_like(self._pos)
        self._heading: FloatArray | None = np.zeros(len(self.agents))
        self._sp: list[float] | None = [0.0] * len(pos)  # the speeds of the velocities (None: not known)
        self.t = 0.0
        delays = sorted({max(0, round(a.params.reaction_time_s * control_hz)) for a in self.agents})
        self._delays = delays
        self._positions: list[tuple[float, float, float]] | None = None  # positions(), until the next step
        self._xy: list[tuple[float, float]] | None = None  # xy(), until the next step
        self._on = [True] * len(self.agents)  # (nobody is left out of the social force)
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
        self._walk = free_cell_check(self.router.free, self.router.grid)  # the walking map is fixed
        self._active.flags.writeable = False
        self._one_delay = len(self._masks) == 1 and bool(self._masks[0].all())
        self._no_detour: dict[int, tuple[bytes, tuple[object, ...]]] = {}  # detours looked for in vain

    def __len__(self) -> int:
        return len(self.agents)

    # ---- the state as arrays -------------------------------------------------------------------------
    @property
    def pos(self) -> FloatArray:
        """(n, 2) positions (the same array until the workers move; read it, do not change it)."""
        if self._pos is None:
            self._pos = np.array([self._xs, self._ys], dtype=np.float64).T.reshape(len(self._xs), 2)
        return self._pos

    @pos.setter
    def pos(self, value: FloatArray) -> None:
        arr = np.asarray(value, dtype=np.float64).reshape(-1, 2)
        self._xs, self._ys = arr[:, 0].tolist(), arr[:, 1].tolist()
        self._pos, self._positions, self._xy = arr, None, None

    @property
    def vel(self) -> FloatArray:
        """(n, 2) velocities (the same array until the workers move)."""
        if self._vel is None:
            self._vel = np.array([self._vxs, self._vys], dtype=np.float64).T.reshape(len(self._vxs), 2)
        return self._vel

    @vel.setter
    def vel(self, value: FloatArray) -> None:
        arr = np.asarray(value, dtype=np.float64).reshape(-1, 2)
        self._vxs, self._vys = arr[:, 0].tolist(), arr[:, 1].tolist()
        self._vel, self._sp = arr, None

    @property
    def heading(self) -> FloatArray:
        """(n,) walking directions (rad; kept while standing)."""
        if self._heading is None:
            self._heading = np.array(self._hs, dtype=np.float64)
        return self._heading

    @heading.setter
    def heading(self, value: FloatArray) -> None:
        arr = np.asarray(value, dtype=np.float64)
        self._hs, self._heading, self._positions = arr.tolist(), arr, None

    def speed_list(self) -> list[float]:
        """The walking speed of every worker (``np.hypot`` of the velocities), as floats."""
        if self._sp is None:
            self._sp = _hypot(np.array(self._vxs, dtype=np.float64), np.array(self._vys, dtype=np.float64)
                              ).tolist()
        return self._sp

    # ---- route following ---------------------------------------------------------------------------
    def _desired(self) -> FloatArray:
        """The desired velocity (n, 2) of every worker: along their route, or back to their anchor."""
        return np.array(self._desired_rows(), dtype=np.float64).reshape(-1, 2)

    def _desired_rows(self) -> list[tuple[float, float]]:
        """:meth:`_desired` as (x, y) float pairs (:func:`kbplanner.simulation.crowd_routes.desired_rows`)."""
        return crowd_routes.desired_rows(self)

    def _way_target(self, a: Agent, p: FloatArray) -> FloatArray:
        """Where a waiting worker heads for (:func:`kbplanner.simulation.crowd_routes.way_target`)."""
        return crowd_routes.way_target(self, a, p)

    @staticmethod
    def _walk_left(a: Agent, p: FloatArray) -> float:
        """How far a waiting worker at ``p`` has left to walk along their ``way`` (from its next point)."""
        return crowd_routes.walk_left(a, p)

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
        xs, ys, vxs, vys = self._xs, self._ys, self._vxs, self._vys
        on = self._on
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
        same = True  # every velocity is the one whose speed is sp[i] (then speed = sp: the same hypot)
        for i in range(n):
            if sp[i] > vmax[i]:
                f = vmax[i] / max(sp[i], 1e-12)
                ux[i], uy[i] = ux[i] * f, uy[i] * f
                same = False
            # (else times 1.0, as before: the very same number, not worked out)
        near_m = WORKER_RADIUS_M + CONTACT_MARGIN_M + 1e-6  # maybe_within's bound
        reach = reach_m(robot.rects) if robot is not None else 0.0
        rx, ry = (robot.pose[0], robot.pose[1]) if robot is not None else (0.0, 0.0)
        walk = self._walk
        agents = self.agents
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
            a = agents[i]
            dx, dy = rows[i]
            if a.making_way and (dx != 0 or dy != 0) and ((vx == 0 and vy == 0) or a.way_slow_s >= STUCK_S):
                # pinned (the robot's push against a wall) or held in place by its push for STUCK_S: making
                # way, the worker walks the way they want (still never into the robot or a wall)
                old, want = np.array([ox, oy]), np.array([dx, dy])
                q, v = self._constrain(old, old + want * dt, want, robot)
                (qx, qy), (vx, vy) = q.tolist(), v.tolist()
            nxs.append(qx)
            nys.append(qy)
            if same and (vx != ux[i] or vy != uy[i]):
                same = False  # (a zero's sign may change: hypot ignores it; arctan2 is taken below)
            ux[i], uy[i] = vx, vy
        # speeds and headings: numpy's hypot and arctan2 on the velocities, as on the former (n, 2) rows
        # (the speeds are those of the capped velocities when no step changed one: the same hypot)
        if same:
            speed = sp
        else:
            speed = _hypot(np.array(ux, dtype=np.float64), np.array(uy, dtype=np.float64)).tolist()
        moving = [v > 0.05 for v in speed]
        if any(moving):
            atan = np.arctan2(np.array(uy, dtype=np.float64), np.array(ux, dtype=np.float64)).tolist()
            self._hs = [atan[i] if moving[i] else self._hs[i] for i in range(n)]
            self._heading = None
        self._xs, self._ys, self._vxs, self._vys, self._sp = nxs, nys, ux, uy, speed
        self._pos = self._vel = None
        self._positions = self._xy = None
        self.t += self.dt

    def _accelerations(self, xs: list[float], ys: list[float], vxs: list[float], vys: list[float],
                       rows: list[tuple[float, float]], seen: Obstacle | None, on: list[bool]
                       ) -> tuple[list[float], list[float]]:
        """The social-force accelerations (:func:`accelerations`), on plain floats for a few workers."""
        if len(xs) <= SMALL_CROWD:
            return accelerations_of(xs, ys, vxs, vys, rows, self._k, seen, on)
        pos = np.array([xs, ys], dtype=np.float64).T.reshape(len(xs), 2)
        vel = np.array([vxs, vys], dtype=np.float64).T.reshape(len(xs), 2)
        acc = accelerations(pos, vel, np.array(rows, dtype=np.float64).reshape(-1, 2), self._params,
                            seen, self._active, constants=self._k)
        return acc[:, 0].tolist(), acc[:, 1].tolist()

    def _detours(self, robot: Obstacle) -> None:
        """A walking worker held up by the robot walks round it
        (:func:`kbplanner.simulation.crowd_detours.detours`)."""
        crowd_detours.detours(self, robot)

    def make_way(self, i: int, path: FloatArray, clear_m: float) -> tuple[float, float] | None:
        """Worker ``i`` makes way for the robot, whose remaining ``path`` (n, 2, base centre) must pass
        them by ``clear_m`` (footprint reach + S_p + the worker's radius); the spot, or None
        (:func:`kbplanner.simulation.crowd_make_way.make_way`)."""
        return crowd_make_way.make_way(self, i, path, clear_m)

    def _release(self, robot: Obstacle | None) -> None:
        """Workers who made way go back once the robot has passed
        (:func:`kbplanner.simulation.crowd_make_way.release`)."""
        crowd_make_way.release(self, robot)

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
        if self._positions is None:
            self._positions = list(zip(self._xs, self._ys, self._hs, strict=True))
        return list(self._positions)

    def xy(self) -> list[tuple[float, float]]:
        """(x, y) of every worker now, as floats (the same list until the workers move: read it, do not
        change it)."""
        if self._xy is None:
            self._xy = list(zip(self._xs, self._ys, strict=True))
        return self._xy

    def speeds(self) -> FloatArray:
        """Walking speed (m/s) of every worker now."""
        return np.asarray(np.hypot(self.vel[:, 0], self.vel[:, 1]), dtype=np.float64)

"""B5 skills NV-1 (navigation) and NV-2 (navigation with object): drive the base along an OMPL path.

Takes the step's base pose (B4) or its destination input, the environment's navigation grid (the
storey's occupancy grid with the elements installed so far) and the step's effective parameters
(``maxSpeed``, ``safetyStopDistance``); drives the robot base kinematically, one control period per update:

- **Plan.** NV-1: :func:`kbplanner.simulation.navigation.plan_path` with the robot's footprint. NV-2:
  :func:`kbplanner.simulation.navigation.plan_with_carry_modes` with the footprints of the robot and the held
  element in its normal and narrow carry (:mod:`kbplanner.planning.carry`, by forward kinematics of the plan's
  carry poses). Planning runs on a window of the grid around start and goal (4 m, then 10 m margin,
  then the whole map: cells off a window count as occupied, so a path found in a window is valid),
  seeded from the run seed and the step number.
- **Time.** :func:`kbplanner.simulation.navigation.time_parameterize` at the control rate with the step's
  ``maxSpeed`` (capped at the base's top speed), the base's yaw rate and accelerations.
- **Carry modes.** NV-2 first turns the element from the lift pose into the carry pose of the first
  stretch ("carry_pose"); before each narrow stretch the arm turns it on its side ("rotate_to_narrow",
  the base standing still) and after it back ("rotate_back"), at the arm's joint speed.
- **Speed and separation monitoring** (ISO/TS 15066, :mod:`kbplanner.simulation.separation_monitor`):
  every period the lidar's view of people sets how much of the timed trajectory the robot drives: full
  speed, slower ("slow" ... "slow_end", with the time lost), or a protective stop ("stop" ... "resume");
  forwards only (no reversing into the scanner's blind sector). Stopped for ``replan_after_s``, it plans
  again around the person ("replan") and asks a waiting worker to make way ("make_way",
  :mod:`~kbplanner.simulation.skills.make_way`); stopped for ``give_up_after_s`` the step fails.
  ``ExecSettings.monitoring = "off"`` drives the trajectory regardless (what monitoring prevents).
"""

from __future__ import annotations

import itertools
import logging
import math
import zlib
from dataclasses import dataclass

import shapely

from kbplanner.planning.base_poses import PoseChecker, mark_polygon
from kbplanner.planning.carry import NARROW, NORMAL, CarryGeometry, geometry_from_joints
from kbplanner.planning.manipulation import KIND_NAVIGATION, KIND_NAVIGATION_WITH_OBJECT
from kbplanner.planning.plan_model import Pose2
from kbplanner.planning.pose_frames import as_pose6_list
from kbplanner.robot.lidar import LidarSpec, lidar_spec
from kbplanner.simulation.base_trajectory import time_parameterize
from kbplanner.simulation.carry_paths import CarryPlan, plan_with_carry_modes
from kbplanner.simulation.grid_yardstick import grid_shortest_path_length
from kbplanner.simulation.nav_path import NavSettings
from kbplanner.simulation.navigation import plan_path
from kbplanner.simulation.path_quality import YARDSTICK_MARGIN_M, shortest_path_m
from kbplanner.simulation.separation import reach_m
from kbplanner.simulation.separation_monitor import SeparationMonitor
from kbplanner.simulation.skills.base import JointPath, Skill, Status
from kbplanner.simulation.skills.make_way import ask_way
from kbplanner.simulation.workers import WORKER_RADIUS_M
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

Pose2D = tuple[float, float, float]


def window(grid: OccupancyGrid, points: list[tuple[float, float]], margin_m: float | None) -> OccupancyGrid:
    """The part of ``grid`` around ``points`` plus ``margin_m`` (None: the whole grid)."""
    if margin_m is None:
        return grid
    res = grid.resolution
    ny, nx = grid.shape
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    ix0 = max(0, math.floor((min(xs) - margin_m - grid.origin[0]) / res))
    iy0 = max(0, math.floor((min(ys) - margin_m - grid.origin[1]) / res))
    ix1 = min(nx, math.ceil((max(xs) + margin_m - grid.origin[0]) / res))
    iy1 = min(ny, math.ceil((max(ys) + margin_m - grid.origin[1]) / res))
    return OccupancyGrid(occupied=grid.occupied[iy0:iy1, ix0:ix1].copy(),
                         origin=(grid.origin[0] + ix0 * res, grid.origin[1] + iy0 * res), resolution=res,
                         band=grid.band)


UNSTICK_RADIUS_M = 0.5  # how far the robot may move straight to leave a blocked start pose


def _nearest_free_pose(checker: PoseChecker, start: Pose2D, footprints: list[Footprint]) -> Pose2D | None:
    """The nearest pose (rings of 2.5 cm, 16 bearings, same heading) where any of the footprints is free."""
    for k in range(1, int(UNSTICK_RADIUS_M / 0.025) + 1):
        r = 0.025 * k
        for j in range(16):
            x = start[0] + r * math.cos(j * math.pi / 8)
            y = start[1] + r * math.sin(j * math.pi / 8)
            if any(checker.free(f, x, y, start[2]) for f in footprints):
                return (x, y, start[2])
    return None


@dataclass
class _Route:
    """A planned route: pieces of path, each with the carry mode to drive it in ("" without a load)."""

    pieces: list[tuple[list[Pose2D], str]]
    length_m: float
    narrow_length_m: float


def _route_of(cp: CarryPlan) -> _Route:
    poses = list(cp.path.poses)
    cuts = sorted({0, len(poses) - 1, *(i for seg in cp.segments for i in (seg.start_index, seg.end_index))})
    spans = [(seg.start_index, seg.end_index) for seg in cp.segments]
    pieces = []
    for a, b in itertools.pairwise(cuts):
        inside = any(lo <= a and b <= hi for lo, hi in spans)
        pieces.append((poses[a:b + 1], NARROW if inside else NORMAL))
    return _Route(pieces or [(poses, NORMAL)], cp.path.length_m, float(cp.extra.get("narrow_length_m", 0.0)))


@dataclass
class _Drive:
    t: list[Pose2D]  # timed poses at the control rate, the first one where the drive starts
    mode: str
    s: float = 0.0  # progress in samples (1 per control period at full speed)

    def at(self, s: float) -> Pose2D:
        i = min(int(s), len(self.t) - 2)
        u = s - i
        a, b = self.t[i], self.t[i + 1]
        dyaw = math.atan2(math.sin(b[2] - a[2]), math.cos(b[2] - a[2]))
        return (a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1]), a[2] + u * dyaw)


@dataclass
class _Turn:
    path: JointPath
    event: str | None
    mode: str


class NavigationSkill(Skill):
    """NV-1: drive to the base pose with the arm in the navigation pose."""

    kind = KIND_NAVIGATION
    carrying = False

    def start(self) -> None:
        call = self.step
        goal = call.base_pose
        if goal is None:
            dest = as_pose6_list(call.by_role("DestinationRole"))
            if dest is not None:
                goal = Pose2(dest[0], dest[1], dest[5])
        if goal is None:
            self.fail("no destination: neither a base pose (B4) nor a destination input")
            return
        self.goal: Pose2D = (goal.x, goal.y, goal.yaw)
        env = self.c.env
        s = self.c.settings
        params = call.parameters
        self.max_speed = min(float(params.get("maxSpeed", env.robot.spec.base.max_speed_mps)),
                             env.robot.spec.base.max_speed_mps)
        self.stop_m = float(params.get("safetyStopDistance", s.default_stop_distance_m))
        self.lidar: LidarSpec = lidar_spec(env.robot, s.lidar_step_deg)
        self.monitor = SeparationMonitor(env, self.lidar, params, max_speed=self.max_speed,
                                         enabled=s.monitoring != "off")
        self.queue: list[_Drive | _Turn] = []
        self.geo: CarryGeometry | None = None
        self.stopped_since: float | None = None
        self.slow_since: float | None = None
        self.slow_lost = 0.0
        self.blocked_s = 0.0
        self.replanned_at: float | None = None
        self.replans = 0
        self.stops = 0
        self.slowdowns = 0
        self.driven_m = 0.0
        self.details.update({"planning_time_s": 0.0, "path_length_m": 0.0, "stops": 0, "stop_time_s": 0.0,
                             "slowdowns": 0, "slow_time_s": 0.0, "time_lost_s": 0.0,
                             "replans": 0, "carry_modes": [], "narrow_length_m": 0.0, "planner": ""})
        if self.carrying:
            problem = self._carry_geometry()
            if problem:
                self.fail(problem)
                return
        elif call.arm_poses.get("initial"):
            q = call.arm_poses["initial"]
            if max(abs(a - b) for a, b in zip(env.robot.arm_positions(), q, strict=True)) > 1e-6:
                self.queue.append(_Turn(self._joint_path([("navigation pose", q)]), None, ""))
        start = env.base_pose()
        self.spaces: list[ConfigurationSpace] | None = []  # of the first plan's legs, for the yardstick
        result = self._plan(start, None)
        spaces, self.spaces = self.spaces or [], None
        if isinstance(result, str):
            self.fail(result)
            return
        self._yardstick(start, spaces)
        self._enqueue(result, first=True)

    def _yardstick(self, start: Pose2D, spaces: list[ConfigurationSpace]) -> None:
        """The shortest collision-free path and the top speed (:mod:`kbplanner.simulation.path_quality`):
        on the configuration space the step planned its one leg in (the footprint it planned with,
        the planner's window), else for the step's most permissive footprint around start and goal."""
        length = grid_shortest_path_length(spaces[0], start, self.goal) if len(spaces) == 1 else math.inf
        if not math.isfinite(length):
            normal, narrow = self._footprints()
            grid = self.c.env.grid
            near = window(grid, [(start[0], start[1]), (self.goal[0], self.goal[1])], YARDSTICK_MARGIN_M)
            length = shortest_path_m(near, grid, start, self.goal, narrow or normal)
        self.details.update(shortest_m=round(length, 4) if math.isfinite(length) else None,
                            max_speed_mps=self.max_speed)

    def _joint_path(self, waypoints: list[tuple[str, list[float] | tuple[float, ...]]]) -> JointPath:
        env = self.c.env
        arm = env.robot.spec.arm
        limits = arm.velocity_rps if arm is not None else None
        hz, speed = env.control_hz, self.c.settings.joint_speed_rps
        return JointPath(env.robot.arm_positions(), waypoints, speed, hz, limits)

    def _carry_geometry(self) -> str | None:
        env = self.c.env
        call = self.step
        held = env.held
        if held is None:
            return "nothing is held: navigation with object needs a grasped element"
        normal, narrow = call.arm_poses.get("carry_normal"), call.arm_poses.get("carry_narrow")
        if not normal or not narrow:
            return "no carry poses in the plan (B4 did not refine this step)"
        bounds = held.element.local_bounds
        assert bounds is not None
        self.geo = geometry_from_joints(env.robot, bounds, held.tool_in_element, normal, narrow)
        return None

    def _footprints(self) -> tuple[Footprint, Footprint | None]:
        env = self.c.env
        if self.geo is None:
            return env.robot.spec.footprint(), None
        return self.geo.footprint(NORMAL), self.geo.footprint(NARROW)

    def _settings(self) -> NavSettings:
        seed = zlib.crc32(f"{self.c.seed}/{self.step.step}/{self.replans}".encode()) % (2**31 - 1) + 1
        return NavSettings(time_limit_s=self.c.settings.nav_time_limit_s, seed=seed,
                           allow_reverse=self.c.settings.monitoring == "off")

    def _leg(self, grid: OccupancyGrid, start: Pose2D, goal: Pose2D, fp: Footprint,
             narrow: Footprint | None) -> _Route | str:
        """One planned leg, in growing windows: a plain path (``narrow`` None) or a carry-mode path."""
        s = self.c.settings
        settings = self._settings()
        reasons: list[str] = []
        for margin in s.window_margins_m:
            sub = window(grid, [(start[0], start[1]), (goal[0], goal[1])], margin)
            if narrow is None:
                cs = ConfigurationSpace.build(sub, fp, settings.n_yaw_bins, settings.margin_m)
                path = plan_path(cs, start, goal, settings=settings)  # as plan_path(sub, ..., fp) builds it
                self.details["planning_time_s"] += path.planning_time_s
                if path.ok and self.spaces is not None:
                    self.spaces.append(cs)
                    self.details["planner"] = path.planner
                    mode = ""
                    if self.geo is not None:
                        mode = NORMAL if fp == self.geo.footprint(NORMAL) else NARROW
                    return _Route([(list(path.poses), mode)], path.length_m, 0.0 if mode != NARROW else
                                  path.length_m)
                why = path.reason
            else:
                cp = plan_with_carry_modes(sub, start, goal, fp, narrow, settings, margin_m=s.carry_margin_m)
                self.details["planning_time_s"] += cp.path.planning_time_s
                if cp.ok:
                    self.details["planner"] = cp.path.planner
                    if cp.space is not None and self.spaces is not None:
                        self.spaces.append(cp.space)
                    return _route_of(cp)
                why = cp.path.reason
            reasons.append(f"{'whole map' if margin is None else f'{margin:g} m window'}: {why}")
            if "in collision" in why or "off the map" in why:
                break  # a bigger window does not help
        return "; ".join(reasons)

    def _via(self, checker: PoseChecker, near: Pose2D) -> Pose2D | None:
        """The nearest pose to ``near`` where both carry footprints fit (rings of 0.25 m, 16 bearings)."""
        assert self.geo is not None
        fps = (self.geo.footprint(NORMAL), self.geo.footprint(NARROW))
        for k in range(1, 13):
            r = 0.25 * k
            for j in range(16):
                bearing = near[2] + math.pi + j * math.pi / 8  # behind the robot first
                x, y = near[0] + r * math.cos(bearing), near[1] + r * math.sin(bearing)
                for yaw in (near[2], near[2] + math.pi / 2, near[2] - math.pi / 2, near[2] + math.pi):
                    if all(checker.free(f, x, y, yaw) for f in fps):
                        return (x, y, math.atan2(math.sin(yaw), math.cos(yaw)))
        return None

    def _plan(self, start: Pose2D, obstacle: shapely.Geometry | None) -> _Route | str:
        """The route to the goal; NV-2 turns the load at a pose near start or goal when it must.

        A robot that stands where the (conservative) configuration space calls it blocked - a few
        centimetres off its planned pose next to a wall, or where an earlier step failed - first moves
        straight to the nearest free pose within ``UNSTICK_RADIUS_M`` (event ``unstick``).
        """
        env = self.c.env
        grid = env.grid
        if obstacle is not None:
            grid = mark_polygon(grid, obstacle)
        normal, narrow = self._footprints()
        checker = PoseChecker(grid)
        fps = [normal] if narrow is None else [normal, narrow]
        if not any(checker.free(f, *start) for f in fps):
            free = _nearest_free_pose(checker, start, fps)
            if free is not None:
                rest = self._plan_from(grid, free, normal, narrow)
                if isinstance(rest, str):
                    return rest
                mode = (self.c.carry_mode or NORMAL) if self.geo is not None else ""
                step = math.hypot(free[0] - start[0], free[1] - start[1])
                self.c.emit("unstick", x=round(start[0], 3), y=round(start[1], 3), distance_m=round(step, 3))
                return _Route([([start, free], mode), *rest.pieces], rest.length_m + step,
                              rest.narrow_length_m)
        return self._plan_from(grid, start, normal, narrow)

    def _plan_from(self, grid: OccupancyGrid, start: Pose2D, normal: Footprint,
                   narrow: Footprint | None) -> _Route | str:
        first = self._leg(grid, start, self.goal, normal, narrow)
        if not isinstance(first, str):
            return first
        if narrow is None or self.geo is None:
            return f"no path to the base pose ({first})"
        # The carried element may fit only one way at the start and the other way at the goal: turn it
        # at a pose near either where both ways fit, and plan the legs in between.
        checker = PoseChecker(grid)
        free_start = [m for m in (NORMAL, NARROW) if checker.free(self.geo.footprint(m), *start)]
        free_goal = [m for m in (NORMAL, NARROW) if checker.free(self.geo.footprint(m), *self.goal)]
        if not free_start or not free_goal:
            where = "start" if not free_start else "base pose"
            return f"no path to the base pose: the held element fits neither way at the {where} ({first})"
        v1 = start if len(free_start) == 2 else self._via(checker, start)
        v2 = self.goal if len(free_goal) == 2 else self._via(checker, self.goal)
        if v1 is None or v2 is None:
            return f"no path to the base pose: no room to turn the held element ({first})"
        legs: list[_Route] = []
        plan = [(start, v1, free_start[0]), (v1, v2, ""), (v2, self.goal, free_goal[0])]
        for a, b, mode in plan:
            if math.hypot(a[0] - b[0], a[1] - b[1]) < 1e-6 and abs(a[2] - b[2]) < 1e-6:
                continue
            leg = self._leg(grid, a, b, normal, narrow) if not mode else \
                self._leg(grid, a, b, self.geo.footprint(mode), None)
            if isinstance(leg, str):
                return f"no path to the base pose ({first}; turning the load on the way: {leg})"
            legs.append(leg)
        return _Route([p for leg in legs for p in leg.pieces], sum(leg.length_m for leg in legs),
                      sum(leg.narrow_length_m for leg in legs))

    def _enqueue(self, route: _Route, *, first: bool) -> None:
        """Queue drives (and carry turns) for a planned route; ``first``: the step's first plan."""
        env = self.c.env
        base = env.robot.spec.base
        self.details["path_length_m"] += route.length_m
        self.details["narrow_length_m"] += route.narrow_length_m
        mode = self.c.carry_mode
        for piece, pmode in route.pieces:
            if self.geo is not None and pmode != mode:
                q = list(self.geo.mode(pmode).joints)
                if first and mode not in (NORMAL, NARROW):
                    event = "carry_pose"
                else:
                    event = "rotate_to_narrow" if pmode == NARROW else "rotate_back"
                self.queue.append(_Turn(self._joint_path([(f"carry {pmode}", q)]), event, pmode))
                mode = pmode
            if len(piece) >= 2:
                traj = time_parameterize(piece, self.max_speed, base.max_yaw_rate_rps, base.max_accel_mps2,
                                         base.max_yaw_accel_rps2, rate_hz=env.control_hz)
                if len(traj.poses) >= 2:
                    self.queue.append(_Drive(list(traj.poses), pmode))
            first = False

    # ---- running -------------------------------------------------------------------------------------
    def tick(self) -> Status:
        env = self.c.env
        while self.queue:
            head = self.queue[0]
            if isinstance(head, _Turn):
                if head.event and head.path._i == 0:
                    x, y, yaw = env.base_pose()
                    self.c.emit(head.event, mode=head.mode, x=round(x, 3), y=round(y, 3))
                    if head.mode not in self.details["carry_modes"]:
                        self.details["carry_modes"].append(head.mode)
                sample = head.path.next()
                if sample is None:
                    self.queue.pop(0)
                    continue
                env.set_arm(sample[0])
                if head.path.done:
                    self.c.carry_mode = head.mode or self.c.carry_mode
                    self.queue.pop(0)
                return Status.RUNNING
            last = len(head.t) - 1
            if head.s >= last - 1e-9:
                self.queue.pop(0)
                continue
            here = head.at(head.s)
            nxt = head.at(min(head.s + 1.0, last))
            f = self._monitor(here, nxt)
            if f < 0:
                return self.fail(f"blocked by a worker for {self.blocked_s:.0f} s")
            if f > 0:
                head.s = min(head.s + f, last)
                x, y, yaw = head.at(head.s)
                env.set_base_pose(x, y, yaw)
                self.driven_m += math.hypot(x - here[0], y - here[1])
            return Status.RUNNING
        self._end_slow()
        self.details.update(driven_m=round(self.driven_m, 3), stops=self.stops, replans=self.replans,
                            slowdowns=self.slowdowns, stop_time_s=round(self.details["stop_time_s"], 3),
                            slow_time_s=round(self.details["slow_time_s"], 3),
                            time_lost_s=round(self.details["time_lost_s"], 3))
        x, y, yaw = env.base_pose()
        err = math.hypot(x - self.goal[0], y - self.goal[1])
        if err > self.c.settings.pose_tol_m:
            return self.fail(f"ended {err:.3f} m from the base pose")
        return Status.SUCCESS

    def _rects(self) -> list[Rect]:
        env = self.c.env
        if env.hazard is not None:
            return list(env.hazard().rects)
        return list(env.robot.spec.footprint().rects)

    def _end_slow(self) -> None:
        if self.slow_since is not None:
            self.c.emit("slow_end", duration_s=round(self.c.env.t - self.slow_since, 3),
                        time_lost_s=round(self.slow_lost, 3))
            self.slow_since = None

    def _monitor(self, here: Pose2D, nxt: Pose2D) -> float:
        """Speed and separation monitoring for one period: the fraction of the step to drive (-1: give up)."""
        env = self.c.env
        s = self.c.settings
        d = self.monitor.decide(self._rects(), here, nxt)
        f = d.fraction
        dt = env.dt
        if f < 1.0:
            self.details["time_lost_s"] += (1.0 - f) * dt
            if self.slow_since is None:
                self.slow_since = env.t
                self.slow_lost = 0.0
                self.slowdowns += 1
                self.c.emit("slow", worker=d.sensed.worker if d.sensed else None,
                            separation_m=round(d.sensed.separation_m, 3) if d.sensed else None,
                            protective_m=round(d.protective_m, 3), fraction=round(f, 3))
            self.slow_lost += (1.0 - f) * dt
            self.details["slow_time_s"] += dt
        else:
            self._end_slow()
        self.details.update(stops=self.stops, replans=self.replans, slowdowns=self.slowdowns)
        if d.stopped:
            self.details["stop_time_s"] += dt
            if self.stopped_since is None:
                self.stopped_since = env.t
                self.replanned_at = None
                self.stops += 1
                assert d.sensed is not None
                self.c.emit("stop", worker=d.sensed.worker, separation_m=round(d.sensed.separation_m, 3),
                            stop_distance_m=round(self.monitor.stop_m, 3),
                            protective_m=round(d.protective_m, 3))
            self.blocked_s = env.t - self.stopped_since
            if self.blocked_s >= s.give_up_after_s:
                return -1.0
            if self.blocked_s >= s.replan_after_s and self.replanned_at is None and d.sensed is not None:
                self.replanned_at = env.t
                self._replan(d.sensed.worker, d.sensed.separation_m)
                pts = [(p[0], p[1]) for q in self.queue if isinstance(q, _Drive) for p in q.t[int(q.s)::5]]
                ask_way(env, d.sensed.worker, pts, reach_m(self._rects()) + d.protective_m, self.c.emit)
            return 0.0 if self.replanned_at == env.t else f  # f > 0: a step away from everyone seen
        if self.stopped_since is not None:
            self.c.emit("resume", waited_s=round(env.t - self.stopped_since, 3),
                        separation_m=round(d.sensed.separation_m, 3) if d.sensed else None)
            self.stopped_since = None
        return f

    def _replan(self, who: str, separation_m: float) -> None:
        env = self.c.env
        self.replans += 1
        k = next(i for i, w in enumerate(env.workers) if w.slug == who)
        wx, wy = (float(v) for v in env.worker_xy()[k])
        disc = shapely.Point(wx, wy).buffer(WORKER_RADIUS_M + self.stop_m, quad_segs=8)
        result = self._plan(env.base_pose(), disc)
        if isinstance(result, str):
            self.c.emit("replan", worker=who, outcome="failed", reason=result)
            return
        keep: list[_Drive | _Turn] = []
        for q in self.queue:  # a carry turn already under way is finished first
            if isinstance(q, _Turn) and q.path._i > 0:
                keep.append(q)
                break
        self.queue = keep
        self._enqueue(result, first=False)
        self.details["replans"] = self.replans
        self.c.emit("replan", worker=who, outcome="ok", path_length_m=round(result.length_m, 3),
                    separation_m=round(separation_m, 3))


class NavigationWithObjectSkill(NavigationSkill):
    """NV-2: drive to the base pose holding the element, narrow where the normal carry does not fit."""

    kind = KIND_NAVIGATION_WITH_OBJECT
    carrying = True

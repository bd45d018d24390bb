# Over 500 lines: the skill's planning (legs, load turns, unstick at start and base pose) and its
# monitored execution share one state; split candidates: the planning half.
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
- **Time.** :func:`kbplanner.simulation.base_trajectory.time_parameterize` at the control rate with the step's
  ``maxSpeed`` (capped at the base's top speed), the base's yaw rate and accelerations; corners are rounded
  where the curve is free in the configuration space the piece was planned in (turning while driving).
- **Carry modes.** NV-2 first turns the element from the lift pose into the carry pose of the first
  stretch ("carry_pose"); before each narrow stretch the arm turns it on its side ("rotate_to_narrow",
  the base standing still) and after it back ("rotate_back"), at the arm's joint speed.
- **Speed and separation monitoring** (ISO/TS 15066, :mod:`kbplanner.simulation.separation_monitor`):
  every period the lidar's view of people sets how much of the timed trajectory the robot drives: full
  speed, slower ("slow" ... "slow_end", with the time lost), or a protective stop ("stop" ... "resume");
  forwards only (no reversing into the scanner's blind sector). With ``monitor_load_turns`` (off by
  default), while the arm turns the carried load (the base standing still) the load's ends sweep at
  the fastest joint's rate times the footprint's reach (with the load either way): the turn slows or
  waits as a drive would. Stopped for
  ``replan_after_s``, it plans again around the person ("replan") and asks a waiting worker to make
  way ("make_way", :mod:`~kbplanner.simulation.skills.make_way`); stopped for ``give_up_after_s``
  the step fails.
  ``ExecSettings.monitoring = "off"`` drives the trajectory regardless (what monitoring prevents).
"""

from __future__ import annotations

import itertools
import logging
import math
import zlib
from collections.abc import Callable, Sequence
from dataclasses import replace

import shapely

from kbplanner.planning.base_poses import PoseChecker, mark_polygon
from kbplanner.planning.carry import NARROW, NORMAL, CarryGeometry, geometry_from_joints
from kbplanner.planning.plan_model import Pose2
from kbplanner.planning.pose_frames import as_pose6_list
from kbplanner.planning.step_kinds import KIND_NAVIGATION, KIND_NAVIGATION_WITH_OBJECT
from kbplanner.robot.lidar import LidarSpec, lidar_spec
from kbplanner.simulation.back_out import reversing_cost
from kbplanner.simulation.base_trajectory import Trajectory, time_parameterize
from kbplanner.simulation.carry_paths import cell_alternatives, cells_first, plan_with_carry_modes
from kbplanner.simulation.corner_pull import pull_corners
from kbplanner.simulation.grid_yardstick import grid_shortest_path_length
from kbplanner.simulation.nav_path import NavSettings, path_length
from kbplanner.simulation.navigation import WALLED_OFF, is_walled_off, plan_path
from kbplanner.simulation.path_quality import YARDSTICK_MARGIN_M, shortest_path_m
from kbplanner.simulation.separation import reach_m
from kbplanner.simulation.separation_monitor import SeparationMonitor
from kbplanner.simulation.skills.base import JointPath, Skill, Status
from kbplanner.simulation.skills.load_turn import best_turn_pose, turn_poses
from kbplanner.simulation.skills.load_turn_once import leg_time_bound, one_turn
from kbplanner.simulation.skills.make_way import ask_way
from kbplanner.simulation.skills.nav_grid import nearest_free_pose, window
from kbplanner.simulation.skills.nav_queue import Drive, Route, Turn, route_of
from kbplanner.simulation.spin_merge import DRIVEN_OFF_HEADING_RAD, MAX_OFF_HEADING_RAD, turn_while_driving
from kbplanner.simulation.workers import WORKER_RADIUS_M
from kbplanner.world.cspace_cache import configuration_space
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

DETOUR_RATIO = 1.25  # a leg longer than this x the grid yardstick is planned again ...
DETOUR_MIN_M = 2.0  # ... when the yardstick is at least this long (short hops are mostly turning)
DETOUR_RETRIES = 2  # with this many other seeds
LegMemo = tuple[Route | str, ConfigurationSpace | None, str | None]  # a leg, its space, its planner

Pose2D = tuple[float, float, float]


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
        self.reverse_s_per_m = reversing_cost(params.get("reversingCost"))
        self.lidar: LidarSpec = lidar_spec(env.robot, s.lidar_step_deg)
        self.monitor = SeparationMonitor(env, self.lidar, params, max_speed=self.max_speed,
                                         enabled=s.monitoring != "off")
        self.queue: list[Drive | Turn] = []
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
        # legs planned in this route search (None outside one) and the timed pieces of routes, by id
        self._legs: dict[tuple[Pose2D, Pose2D, Footprint, Footprint | None], LegMemo] | None = None
        self._timings: dict[int, tuple[list[Pose2D], tuple[Pose2D, ...], ConfigurationSpace | None,
                                       Trajectory]] = {}
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
                self.queue.append(Turn(self._joint_path([("navigation pose", q)]), None, ""))
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
        """An arm motion that starts where the arm will be once the turns already queued are done."""
        env = self.c.env
        arm = env.robot.spec.arm
        limits = arm.velocity_rps if arm is not None else None
        hz, speed = env.control_hz, self.c.settings.joint_speed_rps
        ends = [q.path.samples[-1][0] for q in self.queue if isinstance(q, Turn) and q.path.samples]
        start = ends[-1] if ends else env.robot.arm_positions()
        return JointPath(start, waypoints, speed, hz, limits)

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
        base = self.c.env.robot.spec.base
        return NavSettings(time_limit_s=self.c.settings.nav_time_limit_s, seed=seed,
                           allow_reverse=self.c.settings.monitoring == "off",
                           carry_cells_first=self.c.settings.carry_cells_first,
                           base_limits=(self.max_speed, base.max_yaw_rate_rps, base.max_accel_mps2,
                                        base.max_yaw_accel_rps2),
                           reverse_s_per_m=self.reverse_s_per_m)

    def _leg(self, grid: OccupancyGrid, start: Pose2D, goal: Pose2D, fp: Footprint,
             narrow: Footprint | None) -> Route | str:
        """One planned leg, in growing windows: a plain path (``narrow`` None) or a carry-mode path.

        In a route search (:meth:`_plan_from`, on one grid) a leg asked again - the former route's turn
        legs are the one-turn search's - is not planned again: the same route (or reason) is returned,
        its configuration space kept again and its planner named, as planning it again would."""
        if self._legs is None:
            return self._leg_planned(grid, start, goal, fp, narrow)[0]
        key = (start, goal, fp, narrow)
        if key not in self._legs:
            before = self.details["planner"]
            found, space = self._leg_planned(grid, start, goal, fp, narrow)
            self._legs[key] = (found, space, self.details["planner"] if self.details["planner"] != before
                               or not isinstance(found, str) else None)
            return found
        found, space, planner = self._legs[key]
        if space is not None and self.spaces is not None:
            self.spaces.append(space)
        if planner is not None:
            self.details["planner"] = planner
        return found

    def _leg_planned(self, grid: OccupancyGrid, start: Pose2D, goal: Pose2D, fp: Footprint,
                     narrow: Footprint | None) -> tuple[Route | str, ConfigurationSpace | None]:
        """:meth:`_leg` planned, with the configuration space kept for the yardstick (None: none).

        Where a window finds the goal walled off, whether it is on the whole map is asked once (for the
        leg's footprints): a footprint walled off there is walled off in every window, and is not planned
        in the bigger ones (:func:`~kbplanner.simulation.navigation.plan_path`'s ``known_walled_off``,
        the same reason as planning it)."""
        s = self.c.settings
        settings = self._settings()
        reasons: list[str] = []
        walled: frozenset[Footprint] | None = None  # walled off on the whole map (None: not asked)
        for margin in s.window_margins_m:
            sub = window(grid, [(start[0], start[1]), (goal[0], goal[1])], margin)
            found = self._leg_in(sub, start, goal, fp, narrow, settings, walled or frozenset())
            if isinstance(found, str):
                reasons.append(f"{'whole map' if margin is None else f'{margin:g} m window'}: {found}")
                if "in collision" in found or "off the map" in found:
                    break  # a bigger window does not help
                if walled is None and margin is not None and WALLED_OFF in found:
                    walled = frozenset(f for f in (fp, narrow) if f is not None
                                       and self._walled_whole(sub, grid, start, goal, f, settings))
                continue
            route, space = self._shorter(sub, start, goal, fp, narrow, settings, *found)
            if space is not None and self.spaces is not None:
                self.spaces.append(space)
            return route, space
        return "; ".join(reasons), None

    def _walled_whole(self, sub: OccupancyGrid, grid: OccupancyGrid, start: Pose2D, goal: Pose2D,
                      fp: Footprint, settings: NavSettings) -> bool:
        """Whether start and goal are walled off for ``fp`` on the whole ``grid`` (False at once where they
        are not in the window ``sub``: then the window's answer was another footprint's)."""
        bins, margin = settings.n_yaw_bins, settings.margin_m
        if not is_walled_off(configuration_space(sub, fp, bins, margin), start, goal):
            return False
        return is_walled_off(configuration_space(grid, fp, bins, margin), start, goal)

    def _leg_in(self, sub: OccupancyGrid, start: Pose2D, goal: Pose2D, fp: Footprint,
                narrow: Footprint | None, settings: NavSettings, walled: frozenset[Footprint] = frozenset()
                ) -> tuple[Route, ConfigurationSpace | None] | str:
        """A leg planned on ``sub`` with its configuration space, or why there is none (footprints in
        ``walled`` are known to be walled off: :meth:`_leg_planned`)."""
        if narrow is None:
            cs = configuration_space(sub, fp, settings.n_yaw_bins, settings.margin_m)  # kept per process
            # a carry leg in one mode through a narrow passage takes the cell route, as NV-2's legs do
            # (none where the goal is walled off: free cells do not join them)
            carry = self.geo is not None and fp not in walled
            routed = cells_first(cs, start, goal, settings) if carry else None
            # (plan_path(cs, ...) as plan_path(sub, ..., fp) builds it)
            path = routed or plan_path(cs, start, goal, settings=settings, known_walled_off=fp in walled)
            self.details["planning_time_s"] += path.planning_time_s
            if not path.ok:
                return path.reason
            self.details["planner"] = path.planner
            mode = "" if self.geo is None else NORMAL if fp == self.geo.footprint(NORMAL) else NARROW
            return Route([(list(path.poses), mode, cs)], path.length_m,
                          path.length_m if mode == NARROW else 0.0), cs
        margin = self.c.settings.carry_margin_m
        cp = plan_with_carry_modes(sub, start, goal, fp, narrow, settings, margin_m=margin, walled_off=walled)
        self.details["planning_time_s"] += cp.path.planning_time_s
        if not cp.ok:
            return cp.path.reason
        self.details["planner"] = cp.path.planner
        return route_of(cp), cp.space

    def _shorter(self, sub: OccupancyGrid, start: Pose2D, goal: Pose2D, fp: Footprint,
                 narrow: Footprint | None, settings: NavSettings, route: Route,
                 space: ConfigurationSpace | None) -> tuple[Route, ConfigurationSpace | None]:
        """A leg whose yardstick on its space is at least ``DETOUR_MIN_M`` and whose path is over
        ``DETOUR_RATIO`` x that (the planner went round the long way) is planned again with up to
        ``DETOUR_RETRIES`` other seeds (derived from the step's); the quickest to drive is kept. With
        ``ExecSettings.detour_retry_cell_paths`` False, not a leg that ended on the cell path.

        A path within ``DETOUR_RATIO`` x the straight distance is within that of the yardstick (a line
        from start to goal, never shorter than the straight one): it is kept without the search."""
        straight = math.hypot(goal[0] - start[0], goal[1] - start[1])
        if route.length_m <= DETOUR_RATIO * straight * (1.0 - 1e-9):
            return route, space
        best = grid_shortest_path_length(space, start, goal) if space is not None else math.inf
        if not (DETOUR_MIN_M <= best < math.inf) or route.length_m <= DETOUR_RATIO * best:
            return route, space
        if not self.c.settings.detour_retry_cell_paths and str(self.details["planner"]).endswith("+cells"):
            return route, space
        seconds = self._drive_s(route)
        for k in range(1, DETOUR_RETRIES + 1):
            again = self._leg_in(sub, start, goal, fp, narrow,
                                 replace(settings, seed=(settings.seed + 7919 * k) % (2**31 - 1) + 1))
            if not isinstance(again, str) and self._drive_s(again[0]) < seconds - 1e-9:
                route, space = again
                seconds = self._drive_s(route)
            if route.length_m <= DETOUR_RATIO * best:
                break
        if route.length_m > DETOUR_RATIO * best and space is not None:
            route = self._cells_instead(route, space, start, goal, settings, seconds)
        return route, space

    def _cells_instead(self, route: Route, space: ConfigurationSpace, start: Pose2D, goal: Pose2D,
                       settings: NavSettings, seconds: float) -> Route:
        """A one-mode leg still round the long way: the quickest to drive of it and the cell routes on its
        space (:func:`~kbplanner.simulation.carry_paths.cell_alternatives`), each also with its turns on
        the spot taken into its drives where they fit, never reversing
        (:func:`~kbplanner.simulation.spin_merge.turn_while_driving`)."""
        modes = {(m, id(sp)) for _, m, sp in route.pieces}
        if len(modes) != 1 or route.pieces[0][2] is not space:
            return route
        mode = route.pieces[0][1]
        for alt in cell_alternatives(space, start, goal, settings):
            self.details["planning_time_s"] += alt.planning_time_s
            narrow = alt.length_m if mode == NARROW else 0.0
            poses = list(alt.poses)
            turning = turn_while_driving(space, poses)
            for way in (poses, turning) if turning != poses else (poses,):
                other = Route([(way, mode, space)], alt.length_m, narrow)
                if self._drive_s(other) < seconds - 1e-9:
                    route, seconds = other, self._drive_s(other)
                    self.details["planner"] = alt.planner
        return route

    def _timed(self, leg: Route | str, why: list[str]) -> tuple[Route, float] | None:
        """A planned leg and how long driving it takes (None, the reason kept in ``why``, if it failed)."""
        if isinstance(leg, str):
            why.append(leg)
            return None
        leg = self._turning(leg)
        return leg, self._drive_s(leg)

    def _turning(self, route: Route, max_off_rad: float = MAX_OFF_HEADING_RAD) -> Route:
        """``route`` with each piece's turns on the spot taken into its drives where they fit, never
        reversing and the direction of travel within ``max_off_rad`` of the yaw
        (:func:`~kbplanner.simulation.spin_merge.turn_while_driving`), where that is quicker; first its
        needless corners cut out (:func:`~kbplanner.simulation.corner_pull.pull_corners`), the route's
        length shortened by what they saved."""
        pieces = []
        saved_m = saved_narrow_m = 0.0
        for poses, mode, space in route.pieces:
            if space is not None and len(poses) >= 3:
                pulled = pull_corners(space, poses, self._untimed(space))
                if pulled != poses:
                    cut = path_length(poses) - path_length(pulled)
                    saved_m += cut
                    saved_narrow_m += cut if mode == NARROW else 0.0
                    poses = pulled
                turning = turn_while_driving(space, poses, max_off_rad)
                if turning != poses and (self._trajectory(turning, space).duration_s
                                         < self._trajectory(poses, space).duration_s - 1e-9):
                    poses = turning
            pieces.append((poses, mode, space))
        if all(a[0] is b[0] for a, b in zip(pieces, route.pieces, strict=True)):
            return route
        return Route(pieces, route.length_m - saved_m, route.narrow_length_m - saved_narrow_m)

    def _untimed(self, space: ConfigurationSpace | None) -> Callable[[list[Pose2D]], float]:
        """How long driving a piece on ``space`` takes, timed as :meth:`_trajectory` times it, not kept."""
        base = self.c.env.robot.spec.base

        def seconds(piece: list[Pose2D]) -> float:
            return time_parameterize(piece, self.max_speed, base.max_yaw_rate_rps, base.max_accel_mps2,
                                     base.max_yaw_accel_rps2, self.c.env.control_hz, space).duration_s
        return seconds

    def _drive_s(self, route: Route) -> float:
        """How long driving a route takes (its timed pieces; the load's turns between them left out)."""
        return sum(self._trajectory(p, space).duration_s for p, _, space in route.pieces if len(p) >= 2)

    def _trajectory(self, piece: list[Pose2D], space: ConfigurationSpace | None) -> Trajectory:
        """A route piece timed (:func:`time_parameterize`), once: legs timed to be compared and the
        route driven are timed by the same call (kept by the piece's identity and its poses)."""
        got = self._timings.get(id(piece))
        if got is not None and got[0] is piece and got[2] is space and got[1] == tuple(piece):
            return got[3]
        base = self.c.env.robot.spec.base
        traj = time_parameterize(piece, self.max_speed, base.max_yaw_rate_rps, base.max_accel_mps2,
                                 base.max_yaw_accel_rps2, self.c.env.control_hz, space)
        self._timings[id(piece)] = (piece, tuple(piece), space, traj)
        return traj

    def _plan(self, start: Pose2D, obstacle: shapely.Geometry | None) -> Route | str:
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
            free = nearest_free_pose(checker, start, fps)
            if free is not None:
                rest = self._plan_to(grid, free, normal, narrow)
                if isinstance(rest, str):
                    return rest
                mode = (self.c.carry_mode or NORMAL) if self.geo is not None else ""
                step = math.hypot(free[0] - start[0], free[1] - start[1])
                self.c.emit("unstick", x=round(start[0], 3), y=round(start[1], 3), distance_m=round(step, 3))
                return Route([([start, free], mode, None), *rest.pieces], rest.length_m + step,
                              rest.narrow_length_m)
        return self._plan_to(grid, start, normal, narrow)

    def _plan_to(self, grid: OccupancyGrid, start: Pose2D, normal: Footprint,
                 narrow: Footprint | None) -> Route | str:
        """The route from ``start``; a base pose that the (conservative) map calls blocked for every
        footprint - the held element a few centimetres into the cells of a wall or of an element
        installed before - is reached by a route to the nearest free pose within ``UNSTICK_RADIUS_M``
        and a short straight move from there (event ``unstick`` with ``at`` "base pose")."""
        checker, goal = PoseChecker(self.c.env.grid), self.goal
        fps = [normal] if narrow is None else [normal, narrow]
        near = None if any(checker.free(f, *goal) for f in fps) else nearest_free_pose(checker, goal, fps)
        if near is None:
            return self._plan_from(grid, start, normal, narrow)
        try:
            self.goal = near
            rest = self._plan_from(grid, start, normal, narrow)
        finally:
            self.goal = goal
        if isinstance(rest, str):
            return rest
        step = math.hypot(goal[0] - near[0], goal[1] - near[1])
        self.c.emit("unstick", at="base pose", x=round(near[0], 3), y=round(near[1], 3),
                    distance_m=round(step, 3))
        mode = rest.pieces[-1][1] if rest.pieces else ""
        return Route([*rest.pieces, ([near, goal], mode, None)], rest.length_m + step, rest.narrow_length_m)

    def _plan_from(self, grid: OccupancyGrid, start: Pose2D, normal: Footprint,
                   narrow: Footprint | None) -> Route | str:
        """The route from ``start`` to the goal on ``grid``; a leg asked twice is planned once."""
        self._legs = {}
        try:
            return self._route_from(grid, start, normal, narrow)
        finally:
            self._legs = None

    def _route_from(self, grid: OccupancyGrid, start: Pose2D, normal: Footprint,
                    narrow: Footprint | None) -> Route | str:
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
        geo = self.geo
        why: list[str] = []

        def fits(x: float, y: float, yaw: float) -> bool:
            return all(checker.free(geo.footprint(m), x, y, yaw) for m in (NORMAL, NARROW))

        once = self._turn_once(grid, start, free_start, free_goal, fits, why)
        turns: list[tuple[Pose2D, Route | None]] = []  # where the load turns, near start and goal
        for i, (near, modes) in enumerate(((start, free_start), (self.goal, free_goal))):
            if len(modes) == 2:
                turns.append((near, None))
                continue
            fp, far = geo.footprint(modes[0]), (self.goal if i == 0 else turns[0][0])

            def leg(v: Pose2D, i: int = i, near: Pose2D = near, fp: Footprint = fp
                    ) -> tuple[Route, float] | None:
                a, b = (near, v) if i == 0 else (v, near)
                return self._timed(self._leg(grid, a, b, fp, None), why)

            got = best_turn_pose(turn_poses(fits, near), near, far, self.max_speed, leg)
            if got is None:
                reason = "; ".join([first, *why[:1]])
                return once or f"no path to the base pose: no room to turn the held element ({reason})"
            turns.append(got)
        (v1, leg_a), (v2, leg_c) = turns
        mid: Route | None = None
        if math.hypot(v1[0] - v2[0], v1[1] - v2[1]) >= 1e-6 or abs(v1[2] - v2[2]) >= 1e-6:
            found = self._leg(grid, v1, v2, geo.footprint(NORMAL), geo.footprint(NARROW))
            if isinstance(found, str):
                return once or f"no path to the base pose ({first}; turning the load on the way: {found})"
            mid = found
        legs = [r for r in (leg_a, mid, leg_c) if r is not None]
        route = Route([p for leg in legs for p in leg.pieces], sum(leg.length_m for leg in legs),
                      sum(leg.narrow_length_m for leg in legs))
        return once if once is not None and self._turns_s(once) < self._turns_s(route) - 1e-9 else route

    def _turn_once(self, grid: OccupancyGrid, start: Pose2D, free_start: list[str], free_goal: list[str],
                   fits: Callable[[float, float, float], bool], why: list[str]) -> Route | None:
        """Where the load fits only one way at the start and only the other at the goal: the quickest
        route that turns it once on the way (:mod:`~kbplanner.simulation.skills.load_turn_once`)."""
        if self.geo is None or len(free_start) != 1 or len(free_goal) != 1 or free_start == free_goal:
            return None
        fa, fb = self.geo.footprint(free_start[0]), self.geo.footprint(free_goal[0])
        base = self.c.env.robot.spec.base
        got = one_turn(fits, start, self.goal,
                       lambda v: self._timed(self._leg(grid, start, v, fa, None), why),
                       lambda v: self._timed(self._leg(grid, v, self.goal, fb, None), why),
                       lambda a, b: leg_time_bound(a, b, self.max_speed, base.max_accel_mps2,
                                                   base.max_yaw_rate_rps))
        if got is None:
            return None
        _, a, b, _ = got
        return Route([*a.pieces, *b.pieces], a.length_m + b.length_m, a.narrow_length_m + b.narrow_length_m)

    def _turns_s(self, route: Route) -> float:
        """How long a route takes: its drive (:meth:`_drive_s`) and the load's turns between its pieces."""
        assert self.geo is not None
        arm = self.c.env.robot.spec.arm
        turn = JointPath(self.geo.normal.joints, [("", self.geo.narrow.joints)],
                         self.c.settings.joint_speed_rps, self.c.env.control_hz,
                         arm.velocity_rps if arm is not None else None).duration_s
        modes = [m for _, m, _ in route.pieces]
        return self._drive_s(route) + turn * sum(1 for a, b in itertools.pairwise(modes) if a != b)

    def _enqueue(self, route: Route, *, first: bool) -> None:
        """Queue drives (and carry turns) for a planned route; ``first``: the step's first plan."""
        route = self._turning(route, DRIVEN_OFF_HEADING_RAD)
        self.details["path_length_m"] += route.length_m
        self.details["narrow_length_m"] += route.narrow_length_m
        mode = self.c.carry_mode
        for piece, pmode, space in route.pieces:
            if self.geo is not None and pmode != mode:
                q = list(self.geo.mode(pmode).joints)
                if first and mode not in (NORMAL, NARROW):
                    event = "carry_pose"
                else:
                    event = "rotate_to_narrow" if pmode == NARROW else "rotate_back"
                self.queue.append(Turn(self._joint_path([(f"carry {pmode}", q)]), event, pmode))
                mode = pmode
            if len(piece) >= 2:
                traj = self._trajectory(piece, space)
                if len(traj.poses) >= 2:
                    self.queue.append(Drive(list(traj.poses), pmode))
            first = False

    # ---- running -------------------------------------------------------------------------------------
    def tick(self) -> Status:
        env = self.c.env
        while self.queue:
            head = self.queue[0]
            if isinstance(head, Turn):
                if head.event and not head.announced:
                    head.announced = True
                    x, y, yaw = env.base_pose()
                    self.c.emit(head.event, mode=head.mode, x=round(x, 3), y=round(y, 3))
                    if head.mode not in self.details["carry_modes"]:
                        self.details["carry_modes"].append(head.mode)
                if self.geo is not None and self.c.settings.monitor_load_turns and not head.path.done:
                    head.share = min(head.share + self._monitor_turn(head), 1.0)
                    if head.share < 0:
                        return self.fail(f"blocked by a worker for {self.blocked_s:.0f} s")
                    if head.share < 1.0 - 1e-9:
                        return Status.RUNNING  # the load's turn waits (stopped) or goes slower
                    head.share = 0.0
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
                full = f == 1.0  # (then the pose is ``nxt``: the same progress)
                head.s = min(head.s + f, last)
                x, y, yaw = nxt if full else head.at(head.s)
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

    def _rects(self) -> Sequence[Rect]:
        """The hazard footprint's rectangles now (the very list, not a copy: nobody changes it)."""
        env = self.c.env
        return env.hazard().rects if env.hazard is not None else env.robot.spec.footprint().rects

    def _end_slow(self) -> None:
        if self.slow_since is not None:
            self.c.emit("slow_end", duration_s=round(self.c.env.t - self.slow_since, 3),
                        time_lost_s=round(self.slow_lost, 3))
            self.slow_since = None

    def _monitor_turn(self, turn: Turn) -> float:
        """Monitoring while the arm turns the carried load, the base standing still: the load's ends sweep
        at the fastest joint's rate times the reach of the footprint with the load either way. The
        fraction of the next arm sample to make (0: a protective stop), -1: give up."""
        env = self.c.env
        assert self.geo is not None
        rects = [*self.geo.footprint(NORMAL).rects, *self.geo.footprint(NARROW).rects]
        # at most the joint speed (a turn queued before the last one ended starts from where that one did)
        rate = min(turn.joint_rate(env.robot.arm_positions(), env.control_hz),
                   self.c.settings.joint_speed_rps)
        sweep = rate * reach_m(rects)
        return self._monitor(env.base_pose(), env.base_pose(), sweep_mps=sweep, rects=rects, replan=False)

    def _monitor(self, here: Pose2D, nxt: Pose2D, *, sweep_mps: float = 0.0,
                 rects: Sequence[Rect] | None = None, replan: bool = True) -> float:
        """Speed and separation monitoring for one period: the fraction of the step to drive (-1: give up);
        ``replan`` False: stopped for ``replan_after_s``, only ask the person to make way."""
        env = self.c.env
        s = self.c.settings
        d = self.monitor.decide(self._rects() if rects is None else rects, here, nxt, sweep_mps=sweep_mps)
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
                if replan:
                    self._replan(d.sensed.worker, d.sensed.separation_m)
                pts = [(p[0], p[1]) for q in self.queue if isinstance(q, Drive) for p in q.t[int(q.s)::5]]
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
        keep: list[Drive | Turn] = []
        for q in self.queue:  # a carry turn already under way is finished first
            if isinstance(q, Turn) and q.path._i > 0:
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

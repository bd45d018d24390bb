"""B4, the search state shared by pick and install: settings, IK at the settings' tolerances, the
navigation arm pose, the arm's reach, and seeded base-pose candidates around a target.

Takes the plan, the :class:`~kbplanner.world.world_types.World`, the robot loaded in PyBullet
(:class:`~kbplanner.robot.robot_model.RobotModel`) and the task storey's occupancy grid; :class:`PoseSearch`
is the base of the pick search (:mod:`kbplanner.planning.grasp_poses`), the install search
(:mod:`kbplanner.planning.install_poses`) and the refiner of :mod:`kbplanner.planning.manipulation`.
:class:`RefineSettings` holds B4's offsets, sample counts and tolerances.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import shapely

from kbplanner.planning.base_poses import PoseChecker
from kbplanner.planning.carry import CarryGeometry, Matrix, base_transform, rpy_of
from kbplanner.planning.carry_reach import CarryReach
from kbplanner.planning.plan_model import Plan, Pose2
from kbplanner.planning.pose_frames import pose2
from kbplanner.robot.arm_ik import IkMethod, IkResult, solve_ik
from kbplanner.robot.lidar import sensor_view_hits
from kbplanner.robot.robot_model import RobotModel
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import World


@dataclass(frozen=True)
class RefineSettings:
    """Offsets (m), sample counts and tolerances of B4."""

    base_samples: int = 400
    max_ik_bases: int = 10  # free candidates whose arm poses are checked, nearest first
    approach_offsets_m: tuple[float, ...] = (0.35, 0.25, 0.15)
    pre_grasp_offsets_m: tuple[float, ...] = (0.10, 0.05)
    lift_heights_m: tuple[float, ...] = (0.30, 0.20, 0.10, 0.05, 0.03)
    orient_back_m: float = 0.15
    orient_up_m: tuple[float, ...] = (0.25, 0.15, 0.08)
    pre_place_back_m: float = 0.15
    pre_place_up_m: float = 0.02
    retract_m: float = 0.15
    place_pos_tol_m: float = 0.005
    place_rot_tol_rad: float = math.radians(1.0)
    min_reach_m: float = 0.35  # closest arm mount - target distance sampled
    grasp_tilts_deg: tuple[float, ...] = tuple(float(t) for t in range(0, 65, 5))
    max_arm_penetration_m: float = 0.03  # accepted, and reported, only when no clear grasp exists
    ik_refinements: int = 4  # IK restarts per seed while searching (8 for the place pose)
    # IK: the closed form (exact, fast) first; an element it cannot refine is refined again with the
    # numeric solver, whose near-misses (within the tolerances) sometimes keep the arm clearer
    ik_method: IkMethod = "closed_form"
    fallback_ik_method: IkMethod | None = "numeric"
    escape_radius_m: float = 3.0  # after an install the robot must get this far (escapes())
    blocking_radius_m: float = 3.0  # elements installed this near an unreachable install may block it
    max_regrasps: int = 3  # an element whose install fails is picked again with another grasp
    max_reorder_rounds: int = 6  # B4 runs again at most this often with a blocked element moved first
    bearing_spread_rad: float = math.radians(70.0)
    yaw_spread_rad: float = math.radians(60.0)
    # the deterministic second pass of the base-pose search (PoseSearch.closest_free)
    fixed_bearing_step_rad: float = math.radians(10.0)
    fixed_radial_step_m: float = 0.02
    fixed_turns_rad: tuple[float, ...] = tuple(math.radians(t) for t in (0.0, -20.0, 20.0, -40.0, 40.0))


class PoseSearch:
    """The robot, world, grid and settings of one B4 run, with the look-ups both pick and install use."""

    def __init__(self, plan: Plan, world: World, robot: RobotModel, grid: OccupancyGrid, seed: int,
                 settings: RefineSettings) -> None:
        self.plan = plan
        self.world = world
        self.robot = robot
        self.checker = PoseChecker(grid)
        self.base_grid = grid  # before any install
        self.installed: list[tuple[str, str, shapely.Geometry]] = []  # (iri, label, floor polygon), in order
        self.reach_cache: dict[object, CarryReach] = {}
        self.seed = seed
        self.s = settings
        self.base_fp = robot.spec.footprint()
        start = plan.robot_start
        if start is None and world.robot_start is not None:
            start = Pose2(world.robot_start.x, world.robot_start.y, world.robot_start.yaw)
        self.robot_at = start or Pose2(0.0, 0.0, 0.0)
        self.picked: set[str] = set()
        self.carry_cache: dict[bytes, CarryGeometry] = {}
        self.method: IkMethod = settings.ik_method
        self.fallbacks = 0
        self.excluded_grasps: set[tuple[float, bool]] = set()  # (tilt, flip) whose install failed
        self.last_grasp: tuple[float, bool] | None = None
        self._nav_pose_cache: dict[tuple[float, ...] | None, tuple[tuple[float, ...], str]] = {}
        assert robot.spec.arm is not None
        self.arm = robot.spec.arm

    # ---- arm poses ---------------------------------------------------------------------------
    def nav_pose(self, wanted: tuple[float, ...] | None) -> tuple[tuple[float, ...], str]:
        """The navigation arm pose: the skill's when it keeps the sensors clear, else the robot's stow."""
        if wanted in self._nav_pose_cache:
            return self._nav_pose_cache[wanted]
        stow = self.robot.spec.poses.get("stow", (0.0,) * len(self.robot.arm_joints))
        result = (tuple(stow), "navigation arm pose: the robot's stow pose")
        if wanted is not None:
            saved = self.robot.arm_positions()
            self.robot.set_arm(wanted)
            hits = sensor_view_hits(self.robot)
            clear = self.robot.arm_clearance()
            pos, _ = self.robot.tool_pose()
            self.robot.set_arm(saved)
            bx, by, byaw = self.robot.base_pose()
            local = np.linalg.inv(base_transform(bx, by, byaw)) @ np.array([*pos, 1.0])
            inside = abs(local[0]) <= self.robot.spec.base.length_m / 2 and abs(local[1]) <= \
                self.robot.spec.base.width_m / 2
            if hits["lidar"] == 0 and hits["camera"] == 0 and clear >= 0.0 and inside:
                result = (wanted, "navigation arm pose: the skill's armPose (sensors clear)")
            else:
                why = []
                if hits["lidar"] or hits["camera"]:
                    why.append(f"{hits['lidar']} lidar and {hits['camera']} camera rays hit the arm")
                if clear < 0.0:
                    why.append("the arm touches the base")
                if not inside:
                    why.append("the tool is outside the base footprint")
                result = (tuple(stow), "navigation arm pose: the robot's stow pose (the skill's armPose: "
                          + "; ".join(why) + ")")
        self._nav_pose_cache[wanted] = result
        return result

    def ik(self, frame: Matrix, seeds: Sequence[Sequence[float]] = (), *, tight: bool = False,
           fallback: bool = True) -> IkResult:
        """IK for a tool frame (site): ``seeds`` first, then (``fallback``) arm_ik's default seeds."""
        pos_tol = self.s.place_pos_tol_m if tight else 0.01
        rot_tol = self.s.place_rot_tol_rad if tight else math.radians(3.0)
        n = 8 if tight else self.s.ik_refinements
        xyz = (float(frame[0, 3]), float(frame[1, 3]), float(frame[2, 3]))
        if seeds:
            res = solve_ik(self.robot, xyz, rpy_of(frame), seeds=list(seeds), pos_tol_m=pos_tol,
                           rot_tol_rad=rot_tol, refinements=n, method=self.method)
            if res.reachable or not fallback:
                return res
        return solve_ik(self.robot, xyz, rpy_of(frame), pos_tol_m=pos_tol, rot_tol_rad=rot_tol, refinements=n,
                        method=self.method)

    def horizontal_reach(self, z: float) -> float:
        shoulder = self.robot.floor_z + self.robot.spec.arm_mount_xyz[2] + self.arm.d[0]
        reach = self.arm.reach_m + self.robot.spec.tcp_m
        return math.sqrt(max(0.0, reach * reach - (z - shoulder) ** 2))

    def beyond_reach(self, target: npt.NDArray[np.float64]) -> str:
        """The reason for a target the arm cannot reach from any base pose (too high or too low)."""
        shoulder = self.robot.floor_z + self.robot.spec.arm_mount_xyz[2] + self.arm.d[0]
        reach = self.arm.reach_m + self.robot.spec.tcp_m
        return (f"out of reach from any base pose: the tool would have to be at {float(target[2]):.2f} m, "
                f"the arm of {self.robot.spec.name} reaches {shoulder - reach:.2f}..{shoulder + reach:.2f} m "
                f"high and needs {self.s.min_reach_m} m in front of its mount")

    # ---- base pose candidates ----------------------------------------------------------------
    def candidates(self, target: npt.NDArray[np.float64], rng: np.random.Generator,
                   side: tuple[float, float] | None, ref: Pose2) -> list[Pose2]:
        """Seeded base poses with the arm mount around ``target``, nearest to ``ref`` first."""
        reach = self.horizontal_reach(float(target[2]))
        if reach <= self.s.min_reach_m:
            return []
        mx, my = self.robot.spec.arm_mount_xyz[0], self.robot.spec.arm_mount_xyz[1]
        tx, ty = float(target[0]), float(target[1])
        spread_yaw = self.s.yaw_spread_rad
        out: list[Pose2] = []
        for _ in range(self.s.base_samples):
            r = float(rng.uniform(self.s.min_reach_m, reach))
            if side is None:
                bearing = float(rng.uniform(-math.pi, math.pi))
            else:
                spread = float(rng.uniform(-1.0, 1.0)) * self.s.bearing_spread_rad
                bearing = math.atan2(side[1], side[0]) + spread
            ax, ay = tx + r * math.cos(bearing), ty + r * math.sin(bearing)
            # np.clip's value, without its dispatch on one float
            turn = min(max(float(rng.normal(0.0, spread_yaw / 3)), -spread_yaw), spread_yaw)
            yaw = math.atan2(ty - ay, tx - ax) + turn
            x = ax - (math.cos(yaw) * mx - math.sin(yaw) * my)
            y = ay - (math.sin(yaw) * mx + math.cos(yaw) * my)
            out.append(pose2(x, y, yaw))
        out.sort(key=lambda b: (math.hypot(b.x - ref.x, b.y - ref.y), b.x, b.y, b.yaw))
        return out

    def closest_free(self, target: npt.NDArray[np.float64], checker: PoseChecker,
                     side: tuple[float, float] | None, ref: Pose2) -> list[Pose2]:
        """Seed-independent base poses: per bearing and turn, the free one whose arm mount is closest.

        The second pass of the base-pose search, independent of the seed: on a regular set of bearings
        (every ``fixed_bearing_step_rad`` around the target, or within ``bearing_spread_rad`` of
        ``side``) and base turns (``fixed_turns_rad`` off facing the target), the arm mount steps out
        from ``min_reach_m`` by ``fixed_radial_step_m`` until the base footprint is free on
        ``checker`` (each pose at the centre of its grid cell, :meth:`_cell_centre`). The target's near
        side of a stack or a wall, where random samples rarely land, is always covered. Sorted by
        mount-target distance (closest first, the most reachable), then by distance to ``ref``.
        """
        reach = self.horizontal_reach(float(target[2]))
        if reach <= self.s.min_reach_m:
            return []
        mx, my = self.robot.spec.arm_mount_xyz[0], self.robot.spec.arm_mount_xyz[1]
        if side is None:
            n = max(1, round(2 * math.pi / self.s.fixed_bearing_step_rad))
            bearings = [-math.pi + i * 2 * math.pi / n for i in range(n)]
        else:
            centre = math.atan2(side[1], side[0])
            k = int(self.s.bearing_spread_rad // self.s.fixed_bearing_step_rad)
            bearings = [centre + i * self.s.fixed_bearing_step_rad for i in range(-k, k + 1)]
        steps = int((reach - self.s.min_reach_m) // self.s.fixed_radial_step_m) + 1
        found: list[tuple[float, Pose2]] = []
        for bearing in bearings:
            cb, sb = math.cos(bearing), math.sin(bearing)
            for turn in self.s.fixed_turns_rad:
                for i in range(steps):
                    r = self.s.min_reach_m + i * self.s.fixed_radial_step_m
                    ax, ay = float(target[0]) + r * cb, float(target[1]) + r * sb
                    yaw = math.atan2(float(target[1]) - ay, float(target[0]) - ax) + turn
                    x = ax - (math.cos(yaw) * mx - math.sin(yaw) * my)
                    y = ay - (math.sin(yaw) * mx + math.cos(yaw) * my)
                    x, y = self._cell_centre(checker, x, y)
                    if checker.free(self.base_fp, x, y, yaw):
                        found.append((round(r, 6), pose2(x, y, yaw)))
                        break
        found.sort(key=lambda t: (t[0], math.hypot(t[1].x - ref.x, t[1].y - ref.y), t[1].x, t[1].y, t[1].yaw))
        return [b for _, b in found]

    @staticmethod
    def _cell_centre(checker: PoseChecker, x: float, y: float) -> tuple[float, float]:
        """(x, y) moved to the centre of its grid cell.

        The free test depends only on the cell of (x, y) and the yaw bin. A pose on a cell border
        (the first free pose along a ray often is one) may fall into the next cell on the grid window
        the navigation plans in (another origin, another rounding) and be called blocked there; at a
        cell's centre it falls into the same cell on every window of the grid.
        """
        g = checker.grid
        res = g.resolution
        ix = math.floor((x - g.origin[0]) / res)
        iy = math.floor((y - g.origin[1]) / res)
        return g.origin[0] + (ix + 0.5) * res, g.origin[1] + (iy + 0.5) * res

    def carry_free(self, checker: PoseChecker, geo: CarryGeometry, base: Pose2) -> list[str]:
        """The carry modes whose footprint is free at ``base``."""
        return [m for m in ("normal", "narrow") if checker.free(geo.footprint(m), base.x, base.y, base.yaw)]

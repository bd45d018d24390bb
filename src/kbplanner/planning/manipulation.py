"""B4, arm and base poses per skill: refine an action-level plan with inverse kinematics.

Takes a :class:`~kbplanner.planning.plan_model.Plan` (B1-B3, from :mod:`kbplanner.planning.planner`) and the
:class:`~kbplanner.world.build.World` it runs in; returns a copy of the plan in which every step of every
element has its base pose and its arm poses (joint angles of the robot's arm, radians), found with
PyBullet IK on the robot's URDF (:mod:`kbplanner.robot.arm_ik`), or is infeasible with the reason.

Per element, for the wall-frame task of the paper (NV-1, MM-G-1, NV-2, MM-R-1); other
specifications are refined step by step by skill kind:

- **NV-1** (navigation): the arm in the navigation pose, which is the skill's ``armPose`` parameter
  when that pose keeps the lidar and the camera clear and the arm off the base (checked with rays,
  :func:`kbplanner.robot.lidar.sensor_view_hits`), else the robot table's ``stow`` pose (said in the
  notes). It drives to the base pose chosen for the pick.
- **MM-G-1** (pick): the element where it lies in the world (its storage), the grasp point from
  the model; grasps as in :mod:`kbplanner.planning.carry` (straight down onto the upper face, else tilted
  towards the robot). Arm poses: ``initial`` (navigation pose), ``approach`` and ``pre_grasp``
  (back along the approach, 0.35/0.25 m and 0.10/0.05 m, the longest that is reachable), ``grasp``,
  ``lift`` (straight up 0.30 m, or less when out of reach), ``final`` (= ``lift``). The element's
  mass must not exceed the arm's payload.
- **NV-2** (navigation with object): ``carry_normal`` and ``carry_narrow`` (both carry modes,
  :func:`kbplanner.planning.carry.carry_modes`, with the skill's ``armPose`` parameter as the first IK seed),
  ``initial``/``final`` = ``carry_normal``. It drives to the base pose chosen for the install.
- **MM-R-1** (install): ``initial`` (carry), ``orient`` (the element in its installed orientation
  0.15 m back along the approach and 0.25 m up, or less when out of reach: the paper's
  intermediate pose), ``pre_place``
  (0.15 m back, 0.02 m up), ``place`` (the installed pose, IK to 5 mm and 1 degree), ``retract``
  (the tool 0.15 m back along its axis, the element left in place), ``final`` (navigation pose).

Base poses. For a pick, the NV-1 destination (the storage's pickup location) is used when the arm
reaches the grasp from there. Otherwise, and always for an install (NV-2's destination is the
element's installed pose, which is where the element goes, not where the robot stands), base poses
are sampled around the target (seeded: ``seed``, element IRI, step): the arm mount within the arm's
horizontal reach at the target's height, on the side the gripper comes from, the base turned
towards the target within 60 degrees. A candidate must be free on the storey's occupancy grid for
the base footprint (the same conservative test as the navigation's configuration space, with the
installed elements of earlier steps and the element's own installed footprint marked occupied) and
for at least one carry footprint (base + held element), and every arm pose of the step must be
reachable without the held element touching the robot. Candidates are tried in order of distance to
where the incoming path starts (the robot's previous base pose), so the choice is deterministic; it
is written into ``SkillCall.notes``. After an install the robot must not be shut in by what it
installed (:func:`escapes`). A stud frame whose box is symmetric about its vertical axis may be
placed turned by 180 degrees about it when only that way the gripper (which holds the face that was
up at the storage) can reach. The held element should stay clear of the arm and base; when no
candidate achieves that, the best one overlapping by at most ``max_arm_penetration_m`` is used and
the overlap is written in the notes. A pick also needs the element to be on top of its stack (no
element still at the storage lies on it) and its mass within the arm's payload. When nothing works
the step is infeasible with the reason, and the element's later steps are infeasible as "skipped".

Example:
    >>> from kbplanner.planning.planner import plan_task  # doctest: +SKIP
    >>> plan = refine_plan(plan_task(project), world, seed=7)  # doctest: +SKIP
    >>> plan.steps[1].arm_poses["grasp"]  # doctest: +SKIP
"""

from __future__ import annotations

import copy
import logging
import math
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import shapely
from scipy.spatial.transform import Rotation

from kbplanner.core.vocab import KBP
from kbplanner.planning.carry import (
    CarryGeometry,
    ElementProbe,
    Grasp,
    Matrix,
    base_transform,
    carry_modes,
    carry_problem,
    from_pos_quat,
    grasp_candidates,
    rpy_of,
    transform,
)
from kbplanner.planning.plan_model import Plan, Pose2, Pose6, SkillCall
from kbplanner.robot.arm_ik import IkMethod, IkResult, solve_ik
from kbplanner.robot.lidar import sensor_view_hits
from kbplanner.robot.robot_model import RobotModel
from kbplanner.world.build import Bounds, World, WorldElement
from kbplanner.world.footprint import Footprint
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

KIND_NAVIGATION = str(KBP.Navigation)
KIND_NAVIGATION_WITH_OBJECT = str(KBP.NavigationWithObject)
KIND_GRASP = str(KBP.MoveManipulatorAndGrasp)
KIND_RELEASE = str(KBP.MoveManipulatorAndRelease)
NAVIGATION_KINDS = (KIND_NAVIGATION, KIND_NAVIGATION_WITH_OBJECT)
N_YAW_BINS = 72


# Reasons of B4 failures that do not depend on the IK (no retry with the fallback IK).
_NOT_IK_FAILURES = ("no free base pose", "the element lies under", "the element is not at a storage",
                    "out of reach from any base pose", "skipped", "the element weighs")


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
    bearing_spread_rad: float = math.radians(70.0)
    yaw_spread_rad: float = math.radians(60.0)


# --------------------------------------------------------------------------------------------
# Where the robot can stand: exact look-ups of the navigation's configuration space
# --------------------------------------------------------------------------------------------


def element_polygon(bounds: Bounds, frame: Matrix) -> shapely.Geometry:
    """The floor projection (convex hull) of an element's box at ``frame`` (site)."""
    corners = np.c_[bounds.corners(), np.ones(8)] @ frame.T
    return shapely.MultiPoint(corners[:, :2]).convex_hull


def mark_polygon(grid: OccupancyGrid, polygon: shapely.Geometry) -> OccupancyGrid:
    """A copy of ``grid`` with every cell that ``polygon`` overlaps marked occupied."""
    occ = grid.occupied.copy()
    ny, nx = occ.shape
    res = grid.resolution
    x0, y0, x1, y1 = polygon.bounds
    ix0 = max(0, math.floor((x0 - grid.origin[0]) / res))
    iy0 = max(0, math.floor((y0 - grid.origin[1]) / res))
    ix1 = min(nx - 1, math.floor((x1 - grid.origin[0]) / res))
    iy1 = min(ny - 1, math.floor((y1 - grid.origin[1]) / res))
    if ix1 >= ix0 and iy1 >= iy0:
        xs = grid.origin[0] + np.arange(ix0, ix1 + 1) * res
        ys = grid.origin[1] + np.arange(iy0, iy1 + 1) * res
        gx, gy = np.meshgrid(xs, ys)
        boxes = shapely.box(gx, gy, gx + res, gy + res)
        hit = shapely.intersects(boxes, polygon) & ~shapely.touches(boxes, polygon)
        occ[iy0:iy1 + 1, ix0:ix1 + 1] |= hit
    return OccupancyGrid(occupied=occ, origin=grid.origin, resolution=grid.resolution, band=grid.band)


class PoseChecker:
    """Is a footprint at (x, y, yaw) free on a grid? The navigation's conservative test, one pose at a time.

    The look-up is the same as :class:`~kbplanner.world.footprint.ConfigurationSpace` (the footprint swept
    over the pose's yaw bin, grown by a cell), so a pose found free here is a valid start or goal for
    the planner; kernels are cached per footprint and bin.
    """

    def __init__(self, grid: OccupancyGrid, n_bins: int = N_YAW_BINS) -> None:
        self.grid = grid
        self.n_bins = n_bins
        self._kernels: dict[tuple[Footprint, int], npt.NDArray[np.bool_]] = {}

    def with_grid(self, grid: OccupancyGrid) -> PoseChecker:
        """The same checker (and kernel cache) on another grid of the same shape."""
        other = PoseChecker(grid, self.n_bins)
        other._kernels = self._kernels
        return other

    def free(self, footprint: Footprint, x: float, y: float, yaw: float) -> bool:
        """Whether the footprint at the pose touches no occupied cell (cells off the grid are occupied)."""
        g = self.grid
        w = 2 * math.pi / self.n_bins
        k = math.floor((yaw + w / 2) / w) % self.n_bins
        kern = self._kernels.get((footprint, k))
        if kern is None:
            kern = footprint.kernel(g.resolution, k * w - w / 2, k * w + w / 2)
            self._kernels[(footprint, k)] = kern
        h = kern.shape[0] // 2
        ix = math.floor((x - g.origin[0]) / g.resolution)
        iy = math.floor((y - g.origin[1]) / g.resolution)
        ny, nx = g.shape
        if not (0 <= ix < nx and 0 <= iy < ny):
            return False
        lo_y, hi_y, lo_x, hi_x = iy - h, iy + h + 1, ix - h, ix + h + 1
        if lo_y < 0 or lo_x < 0 or hi_y > ny or hi_x > nx:  # the kernel reaches off the map
            window = np.ones(kern.shape, dtype=bool)
            sy0, sx0 = max(lo_y, 0), max(lo_x, 0)
            sy1, sx1 = min(hi_y, ny), min(hi_x, nx)
            window[sy0 - lo_y:sy1 - lo_y, sx0 - lo_x:sx1 - lo_x] = g.occupied[sy0:sy1, sx0:sx1]
        else:
            window = g.occupied[lo_y:hi_y, lo_x:hi_x]
        return not bool((window & kern).any())


def escapes(grid: OccupancyGrid, footprint: Footprint, pose: Pose2, *, radius_m: float = 3.0,
            n_bins: int = N_YAW_BINS) -> bool:
    """Whether a robot at ``pose`` is not shut in: its free configurations reach ``radius_m`` away.

    The configuration space of ``footprint`` is built on the grid around the pose; free
    (x, y, yaw-bin) cells are labelled with face connectivity only (6 neighbours, the yaw axis closed
    into a ring), which under-connects, so "reaches the window border" means the robot can get out
    of the neighbourhood (a 26-connected labelling would let it squeeze through diagonal gaps).

    Example:
        >>> occ = np.zeros((80, 80), dtype=bool); occ[20:60, [20, 59]] = True; occ[[20, 59], 20:60] = True
        >>> g = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05)
        >>> from kbplanner.world.footprint import Rect
        >>> escapes(g, Footprint((Rect(0, 0, 0.5, 0.3),)), Pose2(2.0, 2.0, 0.0), radius_m=1.5)
        False
    """
    from kbplanner.world.footprint import ConfigurationSpace

    res = grid.resolution
    ny, nx = grid.shape
    ix0 = max(0, math.floor((pose.x - radius_m - grid.origin[0]) / res))
    iy0 = max(0, math.floor((pose.y - radius_m - grid.origin[1]) / res))
    ix1 = min(nx, math.ceil((pose.x + radius_m - grid.origin[0]) / res))
    iy1 = min(ny, math.ceil((pose.y + radius_m - grid.origin[1]) / res))
    sub = OccupancyGrid(occupied=grid.occupied[iy0:iy1, ix0:ix1], origin=(grid.origin[0] + ix0 * res,
                        grid.origin[1] + iy0 * res), resolution=res, band=grid.band)
    cs = ConfigurationSpace.build(sub, footprint, n_bins)
    labels = cs.components()
    root = cs.component_of(labels, pose.x, pose.y, pose.yaw)
    if root == 0:
        return False
    # Off the window counts as occupied, so free cells stop a footprint radius short of its border:
    # the band of that width (plus two cells) along the border is "away". The map's own edges are not.
    band = math.ceil((footprint.radius_m + 2 * res) / res)
    border = np.zeros(labels.shape[1:], dtype=bool)
    if ix0 > 0:
        border[:, :band] = True
    if ix1 < nx:
        border[:, -band:] = True
    if iy0 > 0:
        border[:band, :] = True
    if iy1 < ny:
        border[-band:, :] = True
    return bool((labels[:, border] == root).any())


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------


def target_variants(bounds: Bounds, target: Matrix) -> list[tuple[bool, Matrix]]:
    """The installed pose, and the same pose turned 180 degrees about the element's vertical local axis
    when the element's box is symmetric about that axis (a stud frame: the same box either way).

    Example:
        >>> from kbplanner.world.build import Bounds
        >>> len(target_variants(Bounds(-0.3, -0.045, 0.0, 0.3, 0.045, 2.4), np.eye(4)))
        2
        >>> len(target_variants(Bounds(0.0, 0.0, 0.0, 0.6, 0.09, 2.4), np.eye(4)))
        1
    """
    out = [(False, target)]
    up = int(np.argmax(np.abs(target[2, :3])))  # the local axis nearest to the site's vertical
    centre = np.asarray(bounds.center)
    others = [i for i in range(3) if i != up]
    if all(abs(centre[i]) < 1e-3 for i in others):
        axis = np.zeros(3)
        axis[up] = 1.0
        half = np.eye(4)
        half[:3, :3] = Rotation.from_rotvec(math.pi * axis).as_matrix()
        out.append((True, np.asarray(target @ half, dtype=np.float64)))
    return out


def pose6_matrix(p: Pose6 | Sequence[float]) -> Matrix:
    """4x4 transform of a Pose6 or an [x, y, z, roll, pitch, yaw] list."""
    v = p.as_list() if isinstance(p, Pose6) else [float(a) for a in p]
    return transform(*v[:6])


def _joints(q: Sequence[float]) -> list[float]:
    return [round(float(v), 9) + 0.0 for v in q]


def _pose2(x: float, y: float, yaw: float) -> Pose2:
    return Pose2(round(float(x), 6) + 0.0, round(float(y), 6) + 0.0,
                 round((yaw + math.pi) % (2 * math.pi) - math.pi, 6) + 0.0)


def _as_pose6_list(v: object) -> list[float] | None:
    if isinstance(v, (list, tuple)) and len(v) >= 3 and all(isinstance(a, (int, float)) for a in v):
        vals = [float(a) for a in v] + [0.0] * (6 - len(v))
        return vals[:6]
    if isinstance(v, dict) and {"x", "y", "z"} <= set(v):
        return [float(v.get(k, 0.0)) for k in ("x", "y", "z", "roll", "pitch", "yaw")]
    return None


def _as_joints(v: object, n: int) -> tuple[float, ...] | None:
    if isinstance(v, (list, tuple)) and len(v) == n and all(isinstance(a, (int, float)) for a in v):
        return tuple(float(a) for a in v)
    return None


def tool_frame(robot: RobotModel, q: Sequence[float]) -> Matrix:
    """Forward kinematics of the tool (site frame) at the robot's current base pose; the arm is restored."""
    saved = robot.arm_positions()
    try:
        robot.set_arm(q)
        pos, orn = robot.tool_pose()
    finally:
        robot.set_arm(saved)
    return from_pos_quat(pos, orn)


def _shifted(frame: Matrix, offset: npt.NDArray[np.float64]) -> Matrix:
    m = frame.copy()
    m[:3, 3] = m[:3, 3] + offset
    return m


# --------------------------------------------------------------------------------------------
# The refiner
# --------------------------------------------------------------------------------------------


@dataclass
class _Pick:
    base: Pose2
    grasp: Grasp
    tie: Matrix  # tool in element, from the grasp joints' forward kinematics
    poses: dict[str, list[float]]
    geometry: CarryGeometry
    note: str
    clearance_m: float = 0.0  # arm - element at grasp and lift (negative: they overlap)


@dataclass
class _Install:
    base: Pose2
    poses: dict[str, list[float]]
    note: str
    clearance_m: float = 0.0


class _Refiner:
    def __init__(self, plan: Plan, world: World, robot: RobotModel, grid: OccupancyGrid, seed: int,
                 settings: RefineSettings) -> None:
        self.plan = plan
        self.world = world
        self.robot = robot
        self.checker = PoseChecker(grid)
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
        self._nav_pose_cache: dict[tuple[float, ...] | None, tuple[tuple[float, ...], str]] = {}
        assert robot.spec.arm is not None
        self.arm = robot.spec.arm

    def stacked_on(self, we: WorldElement) -> list[WorldElement]:
        """Elements of the same storage lying higher on the stack that are not picked yet."""
        if we.pose is None or we.bounds is None:
            return []
        out = []
        for e in self.world.task_elements:
            if e.iri == we.iri or e.iri in self.picked or e.storage != we.storage or e.pose is None:
                continue
            b = e.bounds
            if b is None or e.pose.z <= we.pose.z + 1e-6:
                continue
            if b.xmax > we.bounds.xmin and b.xmin < we.bounds.xmax and b.ymax > we.bounds.ymin and \
                    b.ymin < we.bounds.ymax:
                out.append(e)
        return out

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
        out: list[Pose2] = []
        for _ in range(self.s.base_samples):
            r = float(rng.uniform(self.s.min_reach_m, reach))
            if side is None:
                bearing = float(rng.uniform(-math.pi, math.pi))
            else:
                spread = float(rng.uniform(-1.0, 1.0)) * self.s.bearing_spread_rad
                bearing = math.atan2(side[1], side[0]) + spread
            ax, ay = target[0] + r * math.cos(bearing), target[1] + r * math.sin(bearing)
            turn = float(np.clip(rng.normal(0.0, self.s.yaw_spread_rad / 3), -self.s.yaw_spread_rad,
                                 self.s.yaw_spread_rad))
            yaw = math.atan2(target[1] - ay, target[0] - ax) + turn
            x = ax - (math.cos(yaw) * mx - math.sin(yaw) * my)
            y = ay - (math.sin(yaw) * mx + math.cos(yaw) * my)
            out.append(_pose2(x, y, yaw))
        out.sort(key=lambda b: (math.hypot(b.x - ref.x, b.y - ref.y), b.x, b.y, b.yaw))
        return out

    def carry_free(self, checker: PoseChecker, geo: CarryGeometry, base: Pose2) -> list[str]:
        """The carry modes whose footprint is free at ``base``."""
        return [m for m in ("normal", "narrow") if checker.free(geo.footprint(m), base.x, base.y, base.yaw)]

    # ---- pick (MM-G-1) -----------------------------------------------------------------------
    def pick(self, step: SkillCall, we: WorldElement, nominal: Pose2 | None, nav_q: tuple[float, ...],
             carry_seed: tuple[float, ...] | None) -> _Pick | str:
        assert we.pose is not None and we.local_bounds is not None
        frame = pose6_matrix([we.pose.x, we.pose.y, we.pose.z, we.pose.roll, we.pose.pitch, we.pose.yaw])
        gp_in = _as_pose6_list(step.inputs.get("grasp point"))
        gp: tuple[float, float, float] = (
            (gp_in[0], gp_in[1], gp_in[2]) if gp_in is not None else we.local_bounds.center)
        target = (frame @ np.array([*gp, 1.0]))[:3]
        rng = np.random.default_rng([self.seed, zlib.crc32(we.iri.encode()), step.step])
        ref = nominal or self.robot_at
        if self.horizontal_reach(float(target[2])) <= self.s.min_reach_m:
            return self.beyond_reach(target)
        bases: list[tuple[Pose2, str]] = []
        if nominal is not None:
            bases.append((nominal, "the NV-1 destination (pickup location)"))
        bases += [(b, "sampled") for b in self.candidates(target, rng, None, ref)]
        tried = free_count = 0
        best: _Pick | None = None
        last_reason = "no base pose around the grasp point is free"
        for base, how in bases:
            if not self.checker.free(self.base_fp, base.x, base.y, base.yaw):
                continue
            free_count += 1
            if tried >= self.s.max_ik_bases:
                break
            tried += 1
            self.robot.set_base_pose(base.x, base.y, base.yaw)
            mount_h = np.array([*self.robot.spec.arm_mount_xyz, 1.0])
            mount = (base_transform(base.x, base.y, base.yaw) @ mount_h)[:2]
            toward = (float(mount[0] - target[0]), float(mount[1] - target[1]))
            norm = math.hypot(*toward) or 1.0
            seeds = [nav_q, *(self.robot.spec.poses[k] for k in ("pre_grasp",) if k in self.robot.spec.poses)]
            for tilt in self.s.grasp_tilts_deg:
                direction = (toward[0] / norm, toward[1] / norm)
                cands = grasp_candidates(we.local_bounds, frame, gp, direction, (tilt,))
                done = False
                for grasp in cands:
                    if not self.ik(grasp.tool_at(frame), seeds, fallback=False).reachable:
                        continue
                    res = self._pick_at(base, grasp, frame, we, nav_q, carry_seed)
                    if isinstance(res, str):
                        last_reason = res
                        continue
                    done = True  # larger tilts only bring the forearm closer to the element
                    nearest = "" if how.startswith("the") else f", nearest of {free_count} free samples"
                    res.note = (f"base pose: {how} ({base.x:.3f}, {base.y:.3f}, "
                                f"{math.degrees(base.yaw):.1f} deg){nearest}; grasp {grasp.label}; "
                                f"{res.note}")
                    if res.clearance_m >= 0.0:
                        return res
                    if best is None or res.clearance_m > best.clearance_m:
                        best = res
                if done:
                    break
        if best is not None:
            log.info("%s: no collision-free grasp; the best reachable one overlaps by %.3f m", we.label,
                        -best.clearance_m)
            return best
        if nominal is not None and tried == 0 and free_count == 0:
            return "no free base pose near the grasp point (pickup location and samples blocked)"
        return f"grasp point out of reach from {tried} free base pose(s) tried: {last_reason}"

    def _pick_at(self, base: Pose2, grasp: Grasp, frame: Matrix, we: WorldElement, nav_q: tuple[float, ...],
                 carry_seed: tuple[float, ...] | None) -> _Pick | str:
        assert we.local_bounds is not None
        tool = grasp.tool_at(frame)
        seeds = [nav_q, *(self.robot.spec.poses[k] for k in ("pre_grasp",) if k in self.robot.spec.poses)]
        g = self.ik(tool, seeds, fallback=False)
        if not g.reachable:
            return f"grasp {g.reason}"
        # The carry footprints depend on the grasp only (cached): check them first, it is cheap and it
        # rejects most base poses next to a stack.
        tie0 = np.linalg.inv(frame) @ tool_frame(self.robot, g.joints)
        geo = self._carry_geometry(frame, tool, tie0, we, carry_seed)
        problem = carry_problem(geo)
        if problem:
            return problem
        modes = self.carry_free(self.checker, geo, base)
        if not modes:
            return "neither carry footprint is free at the pick base pose"
        z_tool = tool[:3, 2]
        poses: dict[str, list[float]] = {"initial": _joints(nav_q)}
        found: dict[str, IkResult] = {}
        chain = (("pre_grasp", self.s.pre_grasp_offsets_m), ("approach", self.s.approach_offsets_m))
        for key, offsets in chain:
            for off in offsets:
                seed = found["pre_grasp"].joints if key == "approach" else g.joints
                r = self.ik(_shifted(tool, -off * z_tool), [seed], fallback=False)
                if r.reachable:
                    found[key] = r
                    break
            if key not in found:
                return f"{key.replace('_', '-')} pose unreachable"
        tie = np.linalg.inv(frame) @ tool_frame(self.robot, g.joints)
        probe = ElementProbe(self.robot, we.local_bounds)
        try:
            self.robot.set_arm(g.joints)
            probe.place(frame)
            grasp_clear = probe.clearance()
            lift: tuple[IkResult, float, float] | None = None
            for h in self.s.lift_heights_m:
                r = self.ik(_shifted(tool, np.array([0.0, 0.0, h])), [g.joints], fallback=False)
                if not r.reachable:
                    continue
                self.robot.set_arm(r.joints)
                probe.place(tool_frame(self.robot, r.joints) @ np.linalg.inv(tie))
                clear = probe.clearance()
                if lift is None or clear > lift[2] + 1e-4:
                    lift = (r, h, clear)
                if clear >= 0.0:
                    break
            self.robot.set_arm(nav_q)
            if lift is None:
                return "no lift pose is reachable"
            clearance = min(grasp_clear, lift[2])
            if clearance < -self.s.max_arm_penetration_m:
                return (f"the arm would reach {-clearance:.3f} m into the element at the grasp "
                        f"(more than {self.s.max_arm_penetration_m} m)")
        finally:
            probe.close()
        poses.update({"approach": _joints(found["approach"].joints),
                      "pre_grasp": _joints(found["pre_grasp"].joints),
                      "grasp": _joints(g.joints), "lift": _joints(lift[0].joints)})
        poses["final"] = poses["lift"]
        note = (f"lift {lift[1]:.2f} m; arm-element clearance {clearance:.3f} m"
                f"{' (the arm reaches into the element: not resolved)' if clearance < 0 else ''}; "
                f"carry footprints (robot frame): normal "
                f"{geo.normal.rect.length:.2f} x {geo.normal.rect.width:.2f} m, narrow "
                f"{geo.narrow.rect.length:.2f} x {geo.narrow.rect.width:.2f} m")
        return _Pick(base, grasp, np.asarray(tie, dtype=np.float64), poses, geo, note, clearance)

    def _carry_geometry(self, frame: Matrix, tool: Matrix, tie: Matrix, we: WorldElement,
                        carry_seed: tuple[float, ...] | None) -> CarryGeometry:
        """Both carry modes of the element held with ``tie``, computed once per grasp and element shape.

        Keyed by the nominal grasp (the candidate's tool pose in the element frame), not by the IK's
        ``tie``, which differs within the IK tolerance from one base pose to the next.
        """
        assert we.local_bounds is not None
        nominal_tie = np.linalg.inv(frame) @ tool
        cache_key = (np.round(nominal_tie, 3).tobytes()
                     + np.round(np.asarray(we.local_bounds.as_list()), 4).tobytes() + self.method.encode())
        geo = self.carry_cache.get(cache_key)
        if geo is None:
            cseeds = [carry_seed] if carry_seed is not None else []
            geo = carry_modes(self.robot, we.local_bounds, tie, seeds=cseeds,
                              refinements=self.s.ik_refinements, method=self.method)
            self.carry_cache[cache_key] = geo
        return geo

    # ---- install (MM-R-1) --------------------------------------------------------------------
    def install(self, step: SkillCall, we: WorldElement, pick: _Pick, nav_q: tuple[float, ...],
                target: Matrix) -> _Install | str:
        """Base and arm poses to place the element at ``target`` (or its symmetric twin).

        A solution whose held element stays clear of the robot wins; otherwise the one with the
        largest clearance (down to ``-max_arm_penetration_m``), with a note.
        """
        assert we.local_bounds is not None
        reasons = []
        best: _Install | None = None
        for turned, goal in target_variants(we.local_bounds, target):
            res = self._install_target(step, we, pick, nav_q, goal)
            if isinstance(res, str):
                if res not in reasons:
                    reasons.append(res if not turned else f"turned 180 deg: {res}")
                continue
            if turned:
                res.note += ("; placed turned 180 deg about its vertical axis (its box is symmetric about "
                             "it), so the gripper can reach the face it holds")
            if res.clearance_m >= 0.0:
                return res
            if best is None or res.clearance_m > best.clearance_m:
                best = res
        if best is not None:
            log.info("%s: no install pose keeps the element clear of the robot; best overlap %.3f m",
                        we.label, -best.clearance_m)
            return best
        return "; ".join(reasons)

    def _install_target(self, step: SkillCall, we: WorldElement, pick: _Pick, nav_q: tuple[float, ...],
                        target: Matrix) -> _Install | str:
        assert we.local_bounds is not None
        tool = target @ pick.tie
        z_tool = tool[:3, 2]
        flat = np.array([z_tool[0], z_tool[1], 0.0])
        if np.linalg.norm(flat) < 1e-6:  # tool vertical at the target: any side
            side = None
            back = np.zeros(3)
        else:
            flat /= np.linalg.norm(flat)
            side = (-float(flat[0]), -float(flat[1]))
            back = -flat
        own = element_polygon(we.local_bounds, target)
        checker = self.checker.with_grid(mark_polygon(self.checker.grid, own))
        rng = np.random.default_rng([self.seed, zlib.crc32(we.iri.encode()), step.step])
        bases = self.candidates(tool[:3, 3], rng, side, pick.base)
        if not bases:
            return self.beyond_reach(tool[:3, 3])
        up = np.array([0.0, 0.0, 1.0])
        probe = ElementProbe(self.robot, we.local_bounds)
        tried = free_count = 0
        last = "no base pose near the installed pose is free"
        best: _Install | None = None
        try:
            for base in bases:
                if not checker.free(self.base_fp, base.x, base.y, base.yaw):
                    continue
                modes = self.carry_free(checker, pick.geometry, base)
                if not modes:
                    continue
                free_count += 1
                if tried >= self.s.max_ik_bases:
                    break
                tried += 1
                self.robot.set_base_pose(base.x, base.y, base.yaw)
                res = self._install_at(tool, back, up, pick, nav_q, probe)
                if isinstance(res, str):
                    last = res
                    continue
                poses, clear = res
                if not escapes(checker.grid, self.base_fp, base, radius_m=self.s.escape_radius_m):
                    last = "the robot would be shut in by the installed element"
                    continue
                note = (f"base pose: sampled ({base.x:.3f}, {base.y:.3f}, {math.degrees(base.yaw):.1f} deg), "
                        f"nearest to the pick base pose of {free_count} free samples; arrives carrying "
                        f"{'/'.join(modes)}; element-robot clearance {clear:.3f} m"
                        f"{' (the element reaches into the robot: not resolved)' if clear < 0 else ''}")
                found = _Install(base, poses, note, clear)
                if clear >= 0.0:
                    return found
                if best is None or clear > best.clearance_m:
                    best = found
        finally:
            probe.close()
        if best is not None:
            return best
        return f"installed pose out of reach from {tried} free base pose(s) tried: {last}"

    def _install_at(
        self,
        tool: Matrix,
        back: npt.NDArray[np.float64],
        up: npt.NDArray[np.float64],
        pick: _Pick,
        nav_q: tuple[float, ...],
        probe: ElementProbe,
    ) -> tuple[dict[str, list[float]], float] | str:
        place = self.ik(tool, [pick.geometry.normal.joints], tight=True)
        if not place.reachable:
            return f"place {place.reason}"
        chain = [("pre_place", self.s.pre_place_back_m, (self.s.pre_place_up_m,)),
                 ("orient", self.s.orient_back_m, self.s.orient_up_m)]
        found = {"place": place}
        prev = place.joints
        for key, b, ups in chain:
            r = place
            for u in ups:
                r = self.ik(_shifted(tool, b * back + u * up), [prev], fallback=False)
                if r.reachable:
                    break
            if not r.reachable:
                return f"{key.replace('_', '-')} pose {r.reason}"
            found[key] = r
            prev = r.joints
        retract = self.ik(_shifted(tool, -self.s.retract_m * tool[:3, 2]), [place.joints], fallback=False)
        if not retract.reachable:
            return f"retract pose {retract.reason}"
        clear = math.inf
        for key in ("orient", "pre_place", "place"):
            self.robot.set_arm(found[key].joints)
            probe.place(tool_frame(self.robot, found[key].joints) @ np.linalg.inv(pick.tie))
            clear = min(clear, probe.clearance())
        self.robot.set_arm(nav_q)
        if clear < -self.s.max_arm_penetration_m:
            return f"the element would reach {-clear:.3f} m into the robot while placed"
        poses = {"initial": _joints(pick.geometry.normal.joints), "orient": _joints(found["orient"].joints),
                 "pre_place": _joints(found["pre_place"].joints), "place": _joints(place.joints),
                 "retract": _joints(retract.joints), "final": _joints(nav_q)}
        return poses, clear

    # ---- one element ---------------------------------------------------------------------------
    def element(self, iri: str) -> None:
        """B4 for one element with the IK of the settings; again with the fallback IK if that fails."""
        steps = self.plan.steps_for(iri)
        if not steps:
            return
        saved = ([(s.feasible, s.reason, s.base_pose, dict(s.arm_poses), list(s.notes)) for s in steps],
                 set(self.picked), self.robot_at, self.checker)
        self.method = self.s.ik_method
        self._element(iri, steps)
        fallback = self.s.fallback_ik_method
        if fallback is None or fallback == self.method or all(s.feasible for s in steps):
            return
        first = next(s.reason for s in steps if not s.feasible) or ""
        if first.startswith(_NOT_IK_FAILURES):
            return  # another IK cannot help
        for s, (feasible, reason, base, arm, notes) in zip(steps, saved[0], strict=True):
            s.feasible, s.reason, s.base_pose, s.arm_poses, s.notes = feasible, reason, base, arm, notes
        self.picked, self.robot_at, self.checker = saved[1], saved[2], saved[3]
        self.method = fallback
        self._element(iri, steps)
        self.method = self.s.ik_method
        self.fallbacks += 1
        if all(s.feasible for s in steps):
            steps[0].notes.append(f"B4 arm poses by the {fallback} IK (the {self.s.ik_method} IK gave: "
                                  f"{first})")

    def _element(self, iri: str, steps: list[SkillCall]) -> None:
        bad = next((i for i, s in enumerate(steps) if not s.feasible), None)
        if bad is not None:
            _skip_after(steps, bad)
            return
        we = self.world.element(iri)
        if we is None or not we.is_movable or we.pose is None or we.local_bounds is None:
            why = next((o.reason for o in self.world.omitted if o.iri == iri), "not in the world")
            first = next((i for i, s in enumerate(steps) if s.skill_kind == KIND_GRASP), 0)
            _fail(steps, first, f"the element is not at a storage in the world: {why}")
            return
        info = next((e for e in self.plan.elements if e.iri == iri), None)
        pending: SkillCall | None = None
        pick: _Pick | None = None
        installed = False
        for i, s in enumerate(steps):
            want = _as_joints(s.parameters.get("armPose"), len(self.robot.arm_joints))
            if s.skill_kind in NAVIGATION_KINDS:
                pending = s
                continue
            if s.skill_kind == KIND_GRASP:
                nav_q, nav_note = self.nav_pose(_as_joints(pending.parameters.get("armPose"), 6)
                                                if pending is not None else None)
                above = self.stacked_on(we)
                if above:
                    names = ", ".join(sorted(e.label for e in above)[:3])
                    names += ", ..." if len(above) > 3 else ""
                    _fail(steps, i, f"the element lies under {len(above)} element(s) still at its storage "
                                    f"({names}): the plan's element order ({self.plan.order_rule}) does not "
                                    "follow the stack; give the elements kbp:workSequence (top of the stack "
                                    "first) or restack them (kbp:stackIndex)")
                    return
                mass = info.mass_kg if info is not None and info.mass_kg is not None else we.mass_kg
                payload = self.arm.payload_kg
                if mass is not None and mass > payload:
                    _fail(steps, i, f"the element weighs {mass:g} kg, more than the arm's payload of "
                                    f"{payload:g} kg ({self.robot.spec.name})")
                    return
                nominal = None
                if pending is not None:
                    dest = _as_pose6_list(pending.inputs.get("destination"))
                    if dest is not None:
                        nominal = _pose2(dest[0], dest[1], dest[5])
                carry_seed = None
                nxt = next((t for t in steps[i + 1:] if t.skill_kind == KIND_NAVIGATION_WITH_OBJECT), None)
                if nxt is not None:
                    carry_seed = _as_joints(nxt.parameters.get("armPose"), 6)
                res = self.pick(s, we, nominal, nav_q, carry_seed)
                if isinstance(res, str):
                    _fail(steps, i, res)
                    return
                pick = res
                self.picked.add(we.iri)
                s.base_pose = res.base
                s.arm_poses = res.poses
                s.notes.append(res.note)
                if pending is not None:
                    pending.base_pose = res.base
                    pending.arm_poses = {"initial": _joints(nav_q), "final": _joints(nav_q)}
                    pending.notes.append(nav_note)
                    pending.notes.append("drives to the pick base pose of the next step")
                    pending = None
                self.robot_at = res.base
                continue
            if s.skill_kind == KIND_RELEASE:
                if pick is None:
                    _fail(steps, i, "nothing is held: no pick step before this release")
                    return
                target_in = _as_pose6_list(s.inputs.get("target pose"))
                inst = we.installed_pose
                if target_in is None and inst is not None:
                    target_in = [inst.x, inst.y, inst.z, inst.roll, inst.pitch, inst.yaw]
                target = pose6_matrix(target_in if target_in is not None else [0.0] * 6)
                nav_q, nav_note = self.nav_pose(want)
                res_i = self.install(s, we, pick, nav_q, target)
                if isinstance(res_i, str):
                    _fail(steps, i, res_i)
                    return
                s.base_pose = res_i.base
                s.arm_poses = res_i.poses
                s.notes.append(res_i.note)
                s.notes.append(nav_note.replace("navigation arm pose", "final arm pose"))
                if pending is not None:
                    geo = pick.geometry
                    pending.base_pose = res_i.base
                    pending.arm_poses = {"initial": _joints(geo.normal.joints),
                                         "carry_normal": _joints(geo.normal.joints),
                                         "carry_narrow": _joints(geo.narrow.joints),
                                         "final": _joints(geo.normal.joints)}
                    seed_note = ("the skill's armPose was the first IK seed" if want is not None
                                 else "IK from the robot's carry pose")
                    pending.notes.append(f"carry poses by IK ({seed_note}); drives to the install base pose "
                                         "of the next step")
                    pending = None
                self.robot_at = res_i.base
                pick = None
                installed = True
                self.checker = self.checker.with_grid(
                    mark_polygon(self.checker.grid, element_polygon(we.local_bounds, target)))
                continue
            s.notes.append(f"no B4 refinement for skill kind {s.skill_kind}")
        if pending is not None:
            dest = _as_pose6_list(pending.inputs.get("destination"))
            if dest is not None:
                pending.base_pose = _pose2(dest[0], dest[1], dest[5])
                self.robot_at = pending.base_pose
        log.info("B4 %s: %s", we.label, "refined" if installed else "refined (no install step)")


def _fail(steps: list[SkillCall], i: int, reason: str) -> None:
    steps[i].feasible = False
    steps[i].reason = reason
    _skip_after(steps, i)


def _skip_after(steps: list[SkillCall], i: int) -> None:
    for s in steps[i + 1:]:
        if s.feasible:
            s.feasible = False
            s.reason = (f"skipped: step {steps[i].step} ({steps[i].action_label}) of this element is "
                        "infeasible")


def elements_in_order(plan: Plan) -> list[str]:
    """Element IRIs in the order of their first step."""
    seen: dict[str, None] = {}
    for s in sorted(plan.steps, key=lambda s: s.step):
        seen.setdefault(s.element, None)
    return list(seen)


def robot_name(plan: Plan) -> str:
    """The robot table's name of the plan's robot: the one whose URDF the plan names, else its id.

    Example:
        >>> p = Plan("p", None, "T", "", "S", "husky-ur5", "Husky UR5", "husky_ur5.urdf", "rule")
        >>> robot_name(p)
        'husky_ur5'
    """
    from kbplanner.robot.robot_model import load_robot_specs

    specs = load_robot_specs()
    by_urdf = {s.urdf_name: name for name, s in specs.items()}
    if plan.robot_urdf and plan.robot_urdf.rsplit("/", 1)[-1] in by_urdf:
        return by_urdf[plan.robot_urdf.rsplit("/", 1)[-1]]
    return plan.robot_id.replace("-", "_")


def refine_plan(
    plan: Plan,
    world: World,
    *,
    seed: int,
    grid: OccupancyGrid | None = None,
    settings: RefineSettings | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> Plan:
    """B4: a copy of ``plan`` with base and arm poses for every step (see module docstring).

    ``grid`` is the task storey's occupancy grid (default: :func:`kbplanner.world.exports.storey_map`
    of the world). ``progress(label, done, total)`` is called after each element.

    Raises:
        InputFileError: the plan names a robot whose URDF cannot be loaded.
    """
    out = copy.deepcopy(plan)
    if not out.robot_id:
        out.notes.append("B4 not run: no robot selected")
        return out
    if grid is None:
        from kbplanner.world.exports import storey_map

        grid = storey_map(world).grid
    robot = RobotModel.load(robot_name(out))
    robot.floor_z = float(out.storey_elevation_m)  # the robot works on the task's storey
    fallbacks = 0
    try:
        if robot.spec.arm is None:
            for s in out.steps:
                if s.skill_kind in (KIND_GRASP, KIND_RELEASE) and s.feasible:
                    s.feasible = False
                    s.reason = f"robot {out.robot_id} has no arm"
            return out
        refiner = _Refiner(out, world, robot, grid, seed, settings or RefineSettings())
        order = elements_in_order(out)
        for n, iri in enumerate(order, start=1):
            refiner.element(iri)
            if progress is not None:
                progress(iri, n, len(order))
        fallbacks = refiner.fallbacks
    finally:
        robot.close()
    used = settings or RefineSettings()
    again = (f"; {fallbacks} element(s) tried again with the {used.fallback_ik_method} IK"
             if fallbacks else "")
    out.notes.append(f"B4: arm and base poses by the {used.ik_method} IK (seed {seed}){again}")
    return out

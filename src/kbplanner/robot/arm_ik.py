"""Arm inverse kinematics (B4 arm poses per skill): can the arm reach a tool pose, and from where?

Takes a :class:`~kbplanner.robot.robot_model.RobotModel` (a robot loaded in PyBullet) and a target tool
pose in the site frame (position, optionally roll/pitch/yaw); returns an :class:`IkResult` with the
joint angles and whether the pose is *reachable*: PyBullet's forward kinematics must land within
1 cm and 3 degrees of the target, inside the joint limits and without the arm touching the base.
Solvers (``method``): ``numeric`` is PyBullet's damped least squares IK
(``calculateInverseKinematics`` with joint limits and rest poses, refined from a few seeds);
``closed_form``, for a full pose and an arm whose DH table has the UR structure
(:func:`kbplanner.robot.arm_analytic_ik.ur_structure`), checks the up to 8 exact solutions of
:mod:`kbplanner.robot.arm_analytic_ik`, those near a seed first, and for a pose just out of reach the
solutions of a pose within the tolerances that the arm reaches
(:func:`~kbplanner.robot.arm_analytic_ik.near_reach`; each judged against the pose asked for, as
always); ``auto`` (the default) lets the closed
form settle poses that are out of reach by more than the tolerances and the numeric solver the
rest, so that its outcomes are the numeric solver's, faster. :func:`reach_base_poses`
samples base poses around a target from which the arm reaches it and the base footprint is free on
an occupancy grid. Everything is deterministic: fixed seeds, the robot's joint state restored
afterwards.

Example:
    >>> from kbplanner.robot.robot_model import RobotModel
    >>> robot = RobotModel.load("husky_ur5")
    >>> solve_ik(robot, (0.7, 0.0, 0.5), (0.0, math.pi, 0.0)).reachable
    True
    >>> solve_ik(robot, (3.0, 0.0, 0.5)).reason
    'unreachable: best position error 2.05 m > 0.01 m'
    >>> robot.close()
"""

from __future__ import annotations

import functools
import logging
import math
import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

from kbplanner.robot.arm_analytic_ik import (
    DhArm,
    beyond_reach_m,
    closed_form,
    forward_kinematics,
    ik_best_effort,
    near_reach,
    place_nearest,
    ur_structure,
    wrist_centre,
)
from kbplanner.robot.robot_model import RobotModel
from kbplanner.world.footprint import ConfigurationSpace
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

POS_TOL_M = 0.01
ROT_TOL_RAD = math.radians(3.0)

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class IkResult:
    """Outcome of an IK query: joint angles (arm order) and whether they reach the target."""

    reachable: bool
    joints: tuple[float, ...]
    position_error_m: float
    orientation_error_rad: float
    reason: str


@dataclass(frozen=True)
class ReachPose:
    """A base pose (x, y, yaw) from which the arm reaches a target, with the arm solution."""

    x: float
    y: float
    yaw: float
    ik: IkResult
    clearance_m: float  # distance from the base centre to the nearest occupied cell


Matrix = npt.NDArray[np.float64]
_CALIBRATION_Q = (0.4, -1.1, 0.9, -0.7, 1.2, 0.5)  # a second, generic pose to check the calibration
_CALIBRATION_TOL = 1e-6
# A closed-form solution counts as "near" a seed (first pass) when its shoulder and elbow joints are
# within a quarter turn of the seed's: about where PyBullet's numeric IK, started at the seed, still
# converges to that solution (compared on the B4 queries of the case study and a generated building).
LOCAL_RAD = math.pi / 2
# closed_form: a pose out of reach that the closed form on poses within the tolerances
# (arm_analytic_ik.near_reach) does not reach, and whose stretched arm lands within POLISH_RANGE
# position tolerances, is polished by the numeric solver when POLISH is on
POLISH = False
POLISH_RANGE = 3.0


@dataclass(frozen=True)
class AnalyticArm:
    """The closed-form model of a robot's arm: its DH table and the constant transforms around it.

    ``base_in_arm_base`` is DH frame 0 in PyBullet's ``arm_base_link`` frame, ``tool_in_flange`` the
    tool link (TCP) in DH frame 6, so that ``tool = arm_base_link @ base_in_arm_base @ FK(q) @
    tool_in_flange``.
    """

    arm: DhArm
    base_in_arm_base: Matrix
    tool_in_flange: Matrix

    @functools.cached_property
    def flange_in_tool(self) -> Matrix:
        """``_rigid_inv(tool_in_flange)``, once per arm (the same floats)."""
        return _rigid_inv(self.tool_in_flange)


_ANALYTIC: weakref.WeakKeyDictionary[RobotModel, AnalyticArm | None] = weakref.WeakKeyDictionary()


def _matrix(pos: Sequence[float], orn: Sequence[float]) -> Matrix:
    import pybullet as p

    t = np.eye(4)
    t[:3, :3] = np.asarray(p.getMatrixFromQuaternion(orn), dtype=float).reshape(3, 3)
    t[:3, 3] = pos
    return t


def _rigid_inv(t: Matrix) -> Matrix:
    out = np.eye(4)
    out[:3, :3] = t[:3, :3].T
    out[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return out


def analytic_arm(robot: RobotModel) -> AnalyticArm | None:
    """The closed-form model of ``robot``'s arm, or ``None`` if its DH table lacks the UR structure.

    DH frame 0 is ``arm_base_link`` (how :mod:`kbplanner.robot.robot_model` builds the URDF); the tool
    offset is calibrated from PyBullet's forward kinematics at the zero pose and checked at a second
    pose, so a URDF that does not follow the DH table falls back to the numeric solver (logged).
    Cached per robot; the arm's joint angles are restored.
    """
    if robot in _ANALYTIC:
        return _ANALYTIC[robot]
    result: AnalyticArm | None = None
    spec = robot.spec.arm
    if spec is not None and robot.tool_link is not None and "arm_base_link" in robot.links:
        lo, hi = robot.arm_limits()
        arm = DhArm(tuple(spec.d), tuple(spec.a), tuple(spec.alpha), tuple(lo), tuple(hi))
        if ur_structure(arm) is not None:
            saved = robot.arm_positions()
            saved_base = robot.base_pose()
            robot.set_base_pose(0.0, 0.0, 0.0, z=0.0)  # far from the origin PyBullet's poses lose digits
            try:
                base_in_arm_base = np.eye(4)
                tool = []
                for q in ((0.0,) * 6, _CALIBRATION_Q):
                    robot.set_arm(q)
                    ab = _matrix(*robot.link_pose(robot.links["arm_base_link"]))
                    tool.append(_rigid_inv(ab) @ _matrix(*robot.tool_pose()))
                tool_in_flange = _rigid_inv(forward_kinematics(arm, (0.0,) * 6)) @ tool[0]
                check = forward_kinematics(arm, _CALIBRATION_Q) @ tool_in_flange
                err = float(np.abs(check - tool[1]).max())
                if err < _CALIBRATION_TOL:
                    result = AnalyticArm(arm, base_in_arm_base, tool_in_flange)
                else:
                    log.warning("arm of %s: the URDF does not follow its DH table (%.2g); numeric IK",
                                robot.spec.name, err)
            finally:
                robot.set_arm(saved)
                robot.set_base_pose(*saved_base)
    _ANALYTIC[robot] = result
    return result


def _check(robot: RobotModel, q: tuple[float, ...], target_xyz: Vec3, orn: Sequence[float] | None,
           pos_tol_m: float, rot_tol_rad: float, check_collision: bool) -> IkResult:
    """Put the arm at ``q`` and judge it by PyBullet's forward kinematics (arm left at ``q``)."""
    robot.set_arm(q)
    pos, cur = robot.tool_pose()
    perr = math.dist(pos, target_xyz)
    rerr = _quat_angle(cur, orn) if orn is not None else 0.0
    if perr > pos_tol_m:
        reason = f"unreachable: best position error {perr:.2f} m > {pos_tol_m} m"
    elif rerr > rot_tol_rad:
        reason = (f"unreachable: best orientation error {math.degrees(rerr):.1f} deg > "
                  f"{math.degrees(rot_tol_rad):.0f} deg")
    elif check_collision and robot.arm_touches_body():
        reason = "unreachable: the arm would touch the robot's base or sensors"
    else:
        reason = "reachable"
    return IkResult(reason == "reachable", q, perr, rerr, reason)


def _near_seed(q: Sequence[float], seed: Sequence[float]) -> bool:
    """The first three joints (which place the wrist) each within ``LOCAL_RAD`` of the seed's.

    Whole turns aside; the wrist joints may differ more (a numeric solver turns them freely).
    """
    return all(abs((float(a) - float(b) + math.pi) % (2 * math.pi) - math.pi) <= LOCAL_RAD
               for a, b in zip(list(q)[:3], list(seed)[:3], strict=True))


def _better(a: IkResult | None, b: IkResult | None) -> IkResult | None:
    """The reachable one of two results, else the one closer to the target."""
    if a is None or b is None:
        return a if b is None else b
    if a.reachable != b.reachable:
        return a if a.reachable else b
    closer = (a.position_error_m, a.orientation_error_rad) <= (b.position_error_m, b.orientation_error_rad)
    return a if closer else b


@dataclass
class _Analytic:
    """One closed-form query: the solutions (or the stretched poses when out of reach), checked once each."""

    model: AnalyticArm
    exact: list[tuple[float, ...]]
    stretched: list[tuple[float, ...]]
    tried: set[tuple[float, ...]]
    target: Matrix  # the flange pose asked for, in DH frame 0
    #: ``place_nearest(exact, seed)`` per seed (the local and the second pass ask the same seeds)
    placed: dict[tuple[float, ...], list[tuple[float, ...]]] = field(default_factory=dict)

    @classmethod
    def start(cls, robot: RobotModel, model: AnalyticArm, target_xyz: Vec3, orn: Sequence[float],
              seeds: Sequence[Sequence[float]]) -> _Analytic:
        ab = _matrix(*robot.link_pose(robot.links["arm_base_link"]))
        target = (_rigid_inv(ab @ model.base_in_arm_base) @ _matrix(target_xyz, orn)
                  @ model.flange_in_tool)
        exact = closed_form(model.arm, target, seeds[0]) if seeds else []
        stretched = ik_best_effort(model.arm, target, seeds[0]) if seeds and not exact else []
        return cls(model, exact, stretched, set(), target)

    @property
    def beyond_reach_m(self) -> float:
        """A lower bound on how far the wrist centre is out of reach (``method="auto"`` only asks it)."""
        return beyond_reach_m(self.model.arm, self.target)

    @property
    def tool_reach_m(self) -> float:
        """Distance from the wrist centre to the tool point."""
        tool = (self.target @ self.model.tool_in_flange)[:3, 3]
        return float(np.linalg.norm(tool - wrist_centre(self.model.arm, self.target)))

    def near(self, robot: RobotModel, target_xyz: Vec3, orn: Sequence[float],
             seeds: Sequence[Sequence[float]], pos_tol_m: float, rot_tol_rad: float,
             check_collision: bool) -> IkResult | None:
        """The closed form on a pose within the tolerances that the arm reaches (``None``: none checked).

        :func:`~kbplanner.robot.arm_analytic_ik.near_reach` from the first seed; the solutions of each
        pose it finds, in turn, are judged by :func:`_check` against the pose asked for, near a seed
        first, then any; the first reachable one wins, else the closest checked.
        """
        if not seeds:
            return None
        tool = self.target @ self.model.tool_in_flange
        best: IkResult | None = None
        for _moved, sols in near_reach(self.model.arm, tool, self.model.tool_in_flange, seeds[0], pos_tol_m,
                                       rot_tol_rad, stretched=None if self.exact else self.stretched):
            moved = _Analytic(self.model, sols, [], set(), self.target)
            for local in (True, False):
                best = _better(best, moved.solve(robot, target_xyz, orn, seeds, pos_tol_m, rot_tol_rad,
                                                 check_collision, local=local))
                if best is not None and best.reachable:
                    return best
        return best

    def solve(self, robot: RobotModel, target_xyz: Vec3, orn: Sequence[float],
              seeds: Sequence[Sequence[float]], pos_tol_m: float, rot_tol_rad: float,
              check_collision: bool, *, local: bool) -> IkResult | None:
        """Check the solutions for each seed in turn, nearest first (``local``: only those near it).

        Returns the first reachable one, else the closest checked one (``None``: none checked).
        Solutions a whole turn apart put the arm in the same place: each is checked once per query.
        """
        best: IkResult | None = None
        for seed in seeds:
            sols = self._placed(seed) if self.exact else self.stretched
            for q in sols:
                if local and not _near_seed(q, seed):
                    continue
                key = tuple(round((v + math.pi) % (2 * math.pi) - math.pi, 6) for v in q)
                if key in self.tried:
                    continue
                self.tried.add(key)
                result = _check(robot, q, target_xyz, orn, pos_tol_m, rot_tol_rad, check_collision)
                if result.reachable:
                    return result
                best = _better(best, result)
        return best


    def _placed(self, seed: Sequence[float]) -> list[tuple[float, ...]]:
        """:func:`place_nearest` of the exact solutions for ``seed``, once per seed (the same list)."""
        key = tuple(float(v) for v in seed)
        out = self.placed.get(key)
        if out is None:
            out = self.placed[key] = place_nearest(self.model.arm, self.exact, seed)
        return out


def _quat_angle(q1: Sequence[float], q2: Sequence[float]) -> float:
    d = abs(float(np.dot(np.asarray(q1), np.asarray(q2))))
    return 2.0 * math.acos(min(1.0, d))


def _directed_seeds(robot: RobotModel, target_xyz: Vec3) -> list[tuple[float, ...]]:
    """Elbow-up and elbow-down seeds with the shoulder panned towards the target."""
    import pybullet as p

    base_pos, base_orn = robot.link_pose(robot.links["arm_base_link"])
    inv_pos, inv_orn = p.invertTransform(base_pos, base_orn)
    local, _ = p.multiplyTransforms(inv_pos, inv_orn, target_xyz, (0.0, 0.0, 0.0, 1.0))
    # At pan 0 the DH arm stretches along -x of its base, so pan phi - pi points it at phi.
    pan = math.atan2(local[1], local[0]) - math.pi
    pan = (pan + math.pi) % (2 * math.pi) - math.pi
    return [(pan, -1.2, 1.6, -1.9, -1.5708, 0.0), (pan, -1.9, -1.6, -1.2, -1.5708, 0.0),
            (pan, -0.6, 1.2, -2.2, 1.5708, 0.0)]


IkMethod = Literal["auto", "closed_form", "numeric"]


def solve_ik(
    robot: RobotModel,
    target_xyz: Vec3,
    target_rpy: Vec3 | None = None,
    *,
    pos_tol_m: float = POS_TOL_M,
    rot_tol_rad: float = ROT_TOL_RAD,
    seeds: Sequence[Sequence[float]] | None = None,
    check_collision: bool = True,
    refinements: int = 8,
    method: IkMethod = "auto",
) -> IkResult:
    """Solve IK for the tool centre point at ``target_xyz`` (and ``target_rpy`` if given), site frame.

    The robot's base stays where it is. Seeds default to three poses with the shoulder turned
    towards the target, the robot's named poses (sorted by name) and the zero pose; the first
    reachable solution wins (closed form: each seed's solutions nearest it first), otherwise the
    closest one is returned with the reason it is not reachable. ``refinements`` applies to the
    numeric solver only; ``method="numeric"`` forces it (for comparisons). The arm's joint angles
    are restored afterwards.
    """
    import pybullet as p

    robot._need_arm()
    assert robot.tool_link is not None
    orn = p.getQuaternionFromEuler(target_rpy) if target_rpy is not None else None
    if seeds is None:
        named = [robot.spec.poses[k] for k in sorted(robot.spec.poses)]
        seeds = [*_directed_seeds(robot, target_xyz), *named, (0.0,) * len(robot.arm_joints)]
    saved = robot.arm_positions()
    try:
        model = analytic_arm(robot) if orn is not None and method != "numeric" else None
        if model is None or orn is None:
            return _solve_numeric(robot, target_xyz, orn, seeds, pos_tol_m, rot_tol_rad, check_collision,
                                  refinements)
        query = _Analytic.start(robot, model, target_xyz, orn, seeds)
        if method == "auto":
            # closed form only where it cannot change the outcome: the pose is out of reach by more
            # than the tolerances allow (the numeric solver would try every seed in vain)
            if not query.exact and query.beyond_reach_m > pos_tol_m + rot_tol_rad * query.tool_reach_m:
                best = query.solve(robot, target_xyz, orn, seeds, pos_tol_m, rot_tol_rad, check_collision,
                                   local=False)
                if best is not None:
                    return best
            return _solve_numeric(robot, target_xyz, orn, seeds, pos_tol_m, rot_tol_rad, check_collision,
                                  refinements)
        # closed form: first the solutions near a seed, then any (nearest the seeds in their order)
        best = query.solve(robot, target_xyz, orn, seeds, pos_tol_m, rot_tol_rad, check_collision, local=True)
        if best is None or not best.reachable:
            best = _better(best, query.solve(robot, target_xyz, orn, seeds, pos_tol_m, rot_tol_rad,
                                             check_collision, local=False))
        if best is not None and not best.reachable and not query.exact:
            # just out of reach: the closed form on the pose moved within the tolerances towards the
            # arm's reach (arm_analytic_ik.near_reach), checked against the pose asked for
            best = _better(best, query.near(robot, target_xyz, orn, seeds, pos_tol_m, rot_tol_rad,
                                            check_collision))
            if best is not None and not best.reachable and POLISH \
                    and best.position_error_m < POLISH_RANGE * pos_tol_m:
                best = _better(best, _solve_numeric(robot, target_xyz, orn, query.stretched, pos_tol_m,
                                                    rot_tol_rad, check_collision, 2))
        if best is None:
            return IkResult(False, tuple(saved), math.inf, math.inf, "unreachable: no seed given")
        return best
    finally:
        robot.set_arm(saved)


def _solve_numeric(robot: RobotModel, target_xyz: Vec3, orn: Sequence[float] | None,
                   seeds: Sequence[Sequence[float]], pos_tol_m: float, rot_tol_rad: float,
                   check_collision: bool, refinements: int) -> IkResult:
    """PyBullet's damped least squares IK from each seed in turn (the arm is left moved)."""
    import pybullet as p

    lower_all = [robot.lower[j] for j in robot.movable]
    upper_all = [robot.upper[j] for j in robot.movable]
    ranges_all = [hi - lo for lo, hi in zip(lower_all, upper_all, strict=True)]
    arm_idx = [robot.movable.index(j) for j in robot.arm_joints]
    lo_arm, hi_arm = robot.arm_limits()
    best: IkResult | None = None
    for seed in seeds:
        robot.set_arm(seed)
        rest_all = [0.0] * len(robot.movable)
        for k, i in enumerate(arm_idx):
            rest_all[i] = float(seed[k])
        q: tuple[float, ...] = tuple(seed)
        for _ in range(refinements):
            kwargs = dict(lowerLimits=lower_all, upperLimits=upper_all, jointRanges=ranges_all,
                          restPoses=rest_all, maxNumIterations=200, residualThreshold=1e-6,
                          physicsClientId=robot.client)
            robot.place_pending()  # inverse kinematics starts from the robot's PyBullet state
            if orn is not None:
                sol = p.calculateInverseKinematics(robot.body, robot.tool_link, target_xyz, orn, **kwargs)
            else:
                sol = p.calculateInverseKinematics(robot.body, robot.tool_link, target_xyz, **kwargs)
            q = tuple(float(np.clip(sol[i], lo_arm[k], hi_arm[k])) for k, i in enumerate(arm_idx))
            robot.set_arm(q)
            pos, cur = robot.tool_pose()
            perr = math.dist(pos, target_xyz)
            rerr = _quat_angle(cur, orn) if orn is not None else 0.0
            if perr < pos_tol_m / 10 and rerr < rot_tol_rad / 10:
                break
        result = _check(robot, q, target_xyz, orn, pos_tol_m, rot_tol_rad, check_collision)
        if result.reachable:
            return result
        best = _better(best, result)
    if best is None:
        return IkResult(False, robot.arm_positions(), math.inf, math.inf, "unreachable: no seed given")
    return best


def reach_base_poses(
    target_xyz: Vec3,
    robot: RobotModel,
    occupancy: OccupancyGrid,
    n_samples: int = 64,
    seed: int = 0,
    *,
    target_rpy: Vec3 | None = None,
    cspace: ConfigurationSpace | None = None,
    min_distance_m: float = 0.3,
) -> list[ReachPose]:
    """Base poses around ``target_xyz`` from which the arm reaches it and the footprint is free.

    ``n_samples`` candidate poses are drawn (seeded): the arm's mount at a horizontal distance
    between ``min_distance_m`` and the arm's horizontal reach at the target's height, any base yaw.
    Candidates whose footprint is blocked on ``occupancy`` are dropped, the rest are checked with
    :func:`solve_ik`. Returns the reachable ones, most clearance first. The robot is put back.
    """
    robot._need_arm()
    arm = robot.spec.arm
    assert arm is not None
    cs = cspace or ConfigurationSpace.build(occupancy, robot.spec.footprint())
    mx, my, mz = robot.spec.arm_mount_xyz
    shoulder_z = mz + arm.d[0]
    dz = target_xyz[2] - shoulder_z
    reach = arm.reach_m + robot.spec.tcp_m
    horizontal = math.sqrt(max(0.0, reach * reach - dz * dz))
    if horizontal <= min_distance_m:
        return []
    rng = np.random.default_rng(seed)
    dist = rng.uniform(min_distance_m, horizontal, n_samples)
    phi = rng.uniform(-math.pi, math.pi, n_samples)
    yaw = rng.uniform(-math.pi, math.pi, n_samples)
    saved_base = robot.base_pose()
    out: list[ReachPose] = []
    try:
        for d, f, t in zip(dist.tolist(), phi.tolist(), yaw.tolist(), strict=True):
            ax, ay = target_xyz[0] - d * math.cos(f), target_xyz[1] - d * math.sin(f)
            x = ax - (math.cos(t) * mx - math.sin(t) * my)
            y = ay - (math.sin(t) * mx + math.cos(t) * my)
            if not cs.is_free(x, y, t):
                continue
            robot.set_base_pose(x, y, t)
            ik = solve_ik(robot, target_xyz, target_rpy)
            if ik.reachable:
                out.append(ReachPose(x, y, t, ik, occupancy.clearance_at(x, y)))
    finally:
        robot.set_base_pose(*saved_base)
    out.sort(key=lambda r: (-r.clearance_m, r.ik.position_error_m, r.x, r.y))
    log.info("reach_base_poses: %d of %d samples reach (%.2f, %.2f, %.2f)", len(out), n_samples, *target_xyz)
    return out

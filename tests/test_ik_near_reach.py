"""B4's closed-form IK near the reach boundary (arm_analytic_ik.near_reach via arm_ik.solve_ik): every
pose it accepts passes the same check as the numeric solver's (PyBullet's forward kinematics within the
tolerances, the arm clear of the base), it finds poses the numeric polish misses, and it is deterministic."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pybullet as p
import pytest
from scipy.spatial.transform import Rotation

from kbplanner.robot.arm_analytic_ik import forward_kinematics, near_reach, pose_error
from kbplanner.robot.arm_ik import POS_TOL_M, ROT_TOL_RAD, analytic_arm, solve_ik
from kbplanner.robot.robot_model import RobotModel

ROBOTS = ("husky_ur5", "husky_ur16e")


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request: pytest.FixtureRequest) -> Iterator[RobotModel]:
    model = RobotModel.load(request.param)
    yield model
    model.close()


def _matrix(pos: tuple[float, ...], orn: tuple[float, ...]) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = np.asarray(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
    t[:3, 3] = pos
    return t


def _boundary_targets(robot: RobotModel, n: int, seed: int) -> list[tuple[tuple[float, float, float],
                                                                          tuple[float, float, float]]]:
    """Tool poses (site frame) 0-4 cm beyond the stretched arm: stretched arms turned at random, the
    tool point pushed away from the shoulder and the tool turned by up to 4 degrees."""
    model = analytic_arm(robot)
    assert model is not None
    rng = np.random.default_rng(seed)
    base = _matrix(*robot.link_pose(robot.links["arm_base_link"])) @ model.base_in_arm_base
    shoulder = (base @ np.array([0.0, 0.0, model.arm.d[0], 1.0]))[:3]
    out = []
    while len(out) < n:
        q = (float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(-math.pi, 0.0)),
             float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-math.pi, math.pi)),
             float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(-math.pi, math.pi)))
        tool = base @ forward_kinematics(model.arm, q) @ model.tool_in_flange
        away = tool[:3, 3] - shoulder
        tool[:3, 3] += float(rng.uniform(0.0, 0.04)) * away / np.linalg.norm(away)
        axis = rng.normal(size=3)
        rot = p.getQuaternionFromAxisAngle((axis / np.linalg.norm(axis)).tolist(),
                                           math.radians(float(rng.uniform(0.0, 4.0))))
        turn = np.asarray(p.getMatrixFromQuaternion(rot)).reshape(3, 3)
        tool[:3, :3] = turn @ tool[:3, :3]
        rpy = Rotation.from_matrix(tool[:3, :3]).as_euler("xyz")
        if tool[2, 3] < robot.floor_z + 0.1:
            continue
        out.append(((float(tool[0, 3]), float(tool[1, 3]), float(tool[2, 3])),
                    (float(rpy[0]), float(rpy[1]), float(rpy[2]))))
    return out


def _judged_by_pybullet(robot: RobotModel, joints: tuple[float, ...], xyz: tuple[float, float, float],
                        rpy: tuple[float, float, float], pos_tol: float, rot_tol: float) -> bool:
    """The numeric solver's check, written out: PyBullet's forward kinematics, tolerances, clearance."""
    saved = robot.arm_positions()
    try:
        robot.set_arm(joints)
        pos, orn = robot.tool_pose()
        want = p.getQuaternionFromEuler(rpy)
        angle = 2.0 * math.acos(min(1.0, abs(float(np.dot(orn, want)))))
        return math.dist(pos, xyz) <= pos_tol and angle <= rot_tol and robot.arm_clearance() >= 0.0
    finally:
        robot.set_arm(saved)


@pytest.mark.parametrize(("pos_tol", "rot_tol"), [(POS_TOL_M, ROT_TOL_RAD), (0.005, math.radians(1.0))])
def test_every_pose_accepted_near_the_reach_boundary_passes_the_numeric_check(
        robot: RobotModel, pos_tol: float, rot_tol: float) -> None:
    robot.set_base_pose(1.0, -2.0, 0.7)
    found_out_of_reach = 0
    for xyz, rpy in _boundary_targets(robot, 40, seed=11):
        ik = solve_ik(robot, xyz, rpy, pos_tol_m=pos_tol, rot_tol_rad=rot_tol, method="closed_form")
        if ik.reachable:
            assert _judged_by_pybullet(robot, ik.joints, xyz, rpy, pos_tol, rot_tol), (xyz, rpy, ik)
            assert ik.position_error_m <= pos_tol and ik.orientation_error_rad <= rot_tol
            exact = solve_ik(robot, xyz, rpy, pos_tol_m=1e-5, rot_tol_rad=1e-5, method="closed_form")
            found_out_of_reach += not exact.reachable
    # the targets straddle the boundary: some are found only within the tolerances
    assert found_out_of_reach >= 5


def test_near_reach_moves_the_pose_within_the_share_of_the_tolerances(robot: RobotModel) -> None:
    model = analytic_arm(robot)
    assert model is not None
    robot.set_base_pose(0.0, 0.0, 0.0)
    base = _matrix(*robot.link_pose(robot.links["arm_base_link"])) @ model.base_in_arm_base
    found = 0
    for xyz, rpy in _boundary_targets(robot, 40, seed=5):
        tool = np.linalg.inv(base) @ _matrix(xyz, p.getQuaternionFromEuler(rpy))
        seed = (0.0, -1.2, 1.6, -1.9, -1.5708, 0.0)
        found_here = list(near_reach(model.arm, tool, model.tool_in_flange, seed, POS_TOL_M, ROT_TOL_RAD,
                                     branches=4))
        again = list(near_reach(model.arm, tool, model.tool_in_flange, seed, POS_TOL_M, ROT_TOL_RAD,
                                branches=4))
        assert len(again) == len(found_here)  # deterministic
        for (m1, s1), (m2, s2) in zip(found_here, again, strict=True):
            assert s1 == s2 and np.array_equal(m1, m2)
        found += bool(found_here)
        for moved, sols in found_here:
            assert sols
            dist, angle = pose_error(moved, tool)
            assert dist <= 0.97 * POS_TOL_M + 1e-12 and angle <= 0.97 * ROT_TOL_RAD + 1e-12
            for q in sols:
                dist, angle = pose_error(forward_kinematics(model.arm, q) @ model.tool_in_flange, moved)
                assert dist < 1e-6 and angle < 1e-6
    assert found >= 5


def test_arm_touches_body_answers_as_the_arm_clearance_does(robot: RobotModel) -> None:
    """The IK's cheaper test that the arm touches the base (bounding boxes first) gives the same answers."""
    rng = np.random.default_rng(2)
    lo, hi = robot.arm_limits()
    saved = robot.arm_positions()
    touching = 0
    try:
        for x, y, yaw in ((0.0, 0.0, 0.0), (12.5, -7.25, 2.3)):
            robot.set_base_pose(x, y, yaw)
            for _ in range(300):
                robot.set_arm([float(rng.uniform(max(a, -math.pi), min(b, math.pi)))
                               for a, b in zip(lo, hi, strict=True)])
                touches = robot.arm_touches_body()
                assert touches == (robot.arm_clearance() < 0.0)
                touching += touches
    finally:
        robot.set_arm(saved)
    assert 0 < touching < 600  # both answers were given

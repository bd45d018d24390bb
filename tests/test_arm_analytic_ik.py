"""Closed-form arm IK (B4): numpy FK matches PyBullet, every solution reproduces the pose, solve_ik
reaches what the numeric solver reaches, non-UR tables are refused, far poses get a reason."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from kbplanner.robot.arm_analytic_ik import (
    DhArm,
    beyond_reach_m,
    forward_kinematics,
    ik_best_effort,
    ik_solutions,
    pose_error,
    ur_structure,
    wrap_to_limits,
)
from kbplanner.robot.arm_ik import _near_seed, analytic_arm, solve_ik
from kbplanner.robot.robot_model import RobotModel
from kbplanner.robot.robot_table import load_robot_specs
from kbplanner.robot.urdf_generation import urdf_text

ROBOTS = ("husky_ur5", "husky_ur16e")
HALF = math.pi / 2


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


def _random_q(rng: np.random.Generator, arm: DhArm) -> tuple[float, ...]:
    return tuple(float(rng.uniform(max(lo, -math.pi), min(hi, math.pi)))
                 for lo, hi in zip(arm.lower, arm.upper, strict=True))


def _same_angles(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    return all(abs((x - y + math.pi) % (2 * math.pi) - math.pi) < 1e-6 for x, y in zip(a, b, strict=True))


def test_both_shipped_arms_have_the_ur_structure_and_a_calibrated_tool(robot: RobotModel) -> None:
    model = analytic_arm(robot)
    assert model is not None
    # robot_model puts the TCP tcp_m along the flange's z axis, and DH frame 0 at arm_base_link
    expected = np.eye(4)
    expected[2, 3] = robot.spec.tcp_m
    np.testing.assert_allclose(model.tool_in_flange, expected, atol=1e-6)  # URDF: 9 decimals
    np.testing.assert_allclose(model.base_in_arm_base, np.eye(4), atol=1e-12)


def test_numpy_fk_equals_pybullet_fk_of_the_flange_for_random_joint_angles(robot: RobotModel) -> None:
    model = analytic_arm(robot)
    assert model is not None and robot.flange_link is not None
    rng = np.random.default_rng(3)
    saved = robot.arm_positions()
    try:
        for _ in range(25):
            q = _random_q(rng, model.arm)
            robot.set_arm(q)
            base = _matrix(*robot.link_pose(robot.links["arm_base_link"]))
            flange = np.linalg.inv(base) @ _matrix(*robot.link_pose(robot.flange_link))
            pos_err, rot_err = pose_error(forward_kinematics(model.arm, q), flange)
            assert pos_err < 1e-6 and rot_err < 1e-6, (q, pos_err, rot_err)
    finally:
        robot.set_arm(saved)


def _round_trip(arm: DhArm, n: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = _random_q(rng, arm)
        target = forward_kinematics(arm, q)
        sols = ik_solutions(arm, target, seed=q)
        assert 1 <= len(sols) <= 8
        assert _same_angles(sols[0], q)  # the seed's own solution comes first
        for s in sols:
            pos_err, rot_err = pose_error(forward_kinematics(arm, s), target)
            assert pos_err < 1e-6 and rot_err < 1e-6
            assert all(lo <= v <= hi for v, lo, hi in zip(s, arm.lower, arm.upper, strict=True))


def test_every_closed_form_solution_reproduces_the_pose(robot: RobotModel) -> None:
    model = analytic_arm(robot)
    assert model is not None
    _round_trip(model.arm, 200, seed=11)


def test_the_closed_form_holds_for_other_signs_and_offsets_of_the_ur_structure() -> None:
    arm = DhArm((0.2, 0.05, -0.03, 0.1, 0.09, 0.08), (0.07, 0.4, 0.35, 0.06, 0.0, 0.02),
                (-HALF, 0.0, 0.0, -HALF, HALF, 0.3))
    assert ur_structure(arm) is not None
    _round_trip(arm, 200, seed=5)


def test_singular_poses_give_solutions_without_errors(robot: RobotModel) -> None:
    model = analytic_arm(robot)
    assert model is not None
    arm = model.arm
    # wrist singular: q5 = 0 (joints 4 and 6 aligned); q6 comes from the seed
    q = (0.4, -1.2, 1.3, -0.6, 0.0, 0.9)
    sols = ik_solutions(arm, forward_kinematics(arm, q), seed=q)
    assert sols and _same_angles(sols[0], q)
    # shoulder singular: the wrist centre on the cylinder of radius d2+d3+d4 about the base axis
    q = (0.0, -0.5, 0.0, 0.0, 0.7, 0.0)
    t = forward_kinematics(arm, q)
    ur = ur_structure(arm)
    assert ur is not None
    p5 = t[:3, 3] - arm.d[5] * t[:3, 2]
    shift = ur.shoulder_m / math.hypot(p5[0], p5[1])  # scale the wrist centre onto the cylinder
    t[:2, 3] = p5[:2] * shift + arm.d[5] * t[:2, 2]
    for s in ik_solutions(arm, t):
        assert pose_error(forward_kinematics(arm, s), t)[0] < 1e-6
    # straight up: the elbow stretched (q3 = 0)
    sols = ik_solutions(arm, forward_kinematics(arm, (0.0, -HALF, 0.0, -HALF, 0.0, 0.0)))
    assert sols


def test_out_of_reach_pose_has_no_solution_but_a_stretched_best_effort(robot: RobotModel) -> None:
    model = analytic_arm(robot)
    assert model is not None
    far = np.eye(4)
    far[:3, 3] = (3.0, 0.0, 0.0)
    assert ik_solutions(model.arm, far) == []
    best = ik_best_effort(model.arm, far)
    assert best
    reach = float(np.linalg.norm(forward_kinematics(model.arm, best[0])[:3, 3]))
    assert reach > 0.8 * (abs(model.arm.a[1]) + abs(model.arm.a[2]))  # stretched out, towards it


def test_wrap_to_limits_picks_the_whole_turn_nearest_the_seed() -> None:
    assert wrap_to_limits(-0.5, -2 * math.pi, 2 * math.pi, 5.0) == pytest.approx(-0.5 + 2 * math.pi)
    assert wrap_to_limits(0.5, -2 * math.pi, 2 * math.pi, -5.0) == pytest.approx(0.5 - 2 * math.pi)
    assert wrap_to_limits(0.5, -2 * math.pi, 2 * math.pi, 6.0) == pytest.approx(0.5)  # +1 turn: beyond
    assert wrap_to_limits(3.0, -math.pi, math.pi, 0.0) == pytest.approx(3.0)
    assert wrap_to_limits(2.0, -1.0, 1.0, 0.0) is None


def test_a_non_ur_dh_table_does_not_qualify() -> None:
    ur5 = load_robot_specs()["husky_ur5"].arm
    assert ur5 is not None
    base = DhArm(ur5.d, ur5.a, ur5.alpha)
    assert ur_structure(base) is not None
    puma_like = DhArm((0.67, 0.0, 0.15, 0.43, 0.0, 0.06), (0.0, 0.43, 0.02, 0.0, 0.0, 0.0),
                      (HALF, 0.0, -HALF, HALF, -HALF, 0.0))
    assert ur_structure(puma_like) is None  # joints 2, 3, 4 not parallel (spherical wrist)
    assert ur_structure(dataclasses.replace(base, alpha=(HALF, 0.0, 0.3, HALF, -HALF, 0.0))) is None
    assert ur_structure(dataclasses.replace(base, a=(0.0, -0.425, -0.39, 0.0, 0.05, 0.0))) is None
    assert ur_structure(dataclasses.replace(base, a=(0.0, 0.0, -0.39, 0.0, 0.0, 0.0))) is None
    assert ik_solutions(puma_like, np.eye(4)) == []


def test_a_robot_with_a_non_ur_arm_keeps_the_numeric_solver(tmp_path: Path) -> None:
    spec = load_robot_specs()["husky_ur5"]
    assert spec.arm is not None
    odd_arm = dataclasses.replace(spec.arm, alpha=(HALF, 0.0, -HALF, HALF, -HALF, 0.0),
                                  d=(0.089159, 0.0, 0.0, 0.30, 0.0, 0.0823),
                                  a=(0.0, -0.425, 0.0, 0.0, 0.0, 0.0))
    odd = dataclasses.replace(spec, name="odd_arm", arm=odd_arm)
    urdf = tmp_path / "odd_arm.urdf"
    urdf.write_text(urdf_text(odd), encoding="utf-8")
    model = RobotModel.load(odd, urdf=urdf)
    try:
        assert analytic_arm(model) is None
        q = (0.3, -1.0, 0.8, -1.0, -1.2, 0.2)
        model.set_arm(q)
        pos, orn = model.tool_pose()
        model.set_named_pose("stow")
        res = solve_ik(model, pos, p.getEulerFromQuaternion(orn), check_collision=False)
        assert res.reachable, res.reason
    finally:
        model.close()


Pose = tuple[tuple[float, float, float], tuple[float, float, float]]


def _reachable_targets(robot: RobotModel, n: int, seed: int) -> list[Pose]:
    """Tool poses of random collision-free arm configurations (reachable by construction)."""
    rng = np.random.default_rng(seed)
    saved = robot.arm_positions()
    out: list[Pose] = []
    try:
        while len(out) < n:
            q = tuple(float(v) for v in rng.uniform(-math.pi, math.pi, 6))
            robot.set_arm(q)
            if robot.arm_clearance() < 0.02:
                continue
            pos, orn = robot.tool_pose()
            r, pi, y = p.getEulerFromQuaternion(orn)
            out.append((pos, (r, pi, y)))
    finally:
        robot.set_arm(saved)
    return out


def test_solve_ik_reaches_what_the_numeric_solver_reaches(robot: RobotModel) -> None:
    down = (0.0, math.pi, 0.0)
    targets = [((0.7, 0.0, 0.5), down), ((0.6, -0.2, 0.7), down), ((0.55, 0.3, 0.45), down),
               *_reachable_targets(robot, 6, seed=2)]
    saved = robot.arm_positions()
    numeric_reached = 0
    for xyz, rpy in targets:
        numeric = solve_ik(robot, xyz, rpy, method="numeric")
        closed = solve_ik(robot, xyz, rpy, method="closed_form")
        assert robot.arm_positions() == saved  # the arm is put back
        if numeric.reachable:
            numeric_reached += 1
            assert closed.reachable, (xyz, rpy, closed.reason)
        if closed.reachable:
            # the orientation error is measured by acos of a quaternion dot product: ~1e-4 rad resolution
            assert closed.position_error_m < 1e-6 and closed.orientation_error_rad < 1e-3
            robot.set_arm(closed.joints)
            assert robot.arm_clearance() >= 0.0
            robot.set_arm(saved)
    assert numeric_reached >= 3


def test_solve_ik_takes_the_seeds_nearest_solution_and_is_deterministic(robot: RobotModel) -> None:
    (xyz, rpy), = _reachable_targets(robot, 1, seed=9)
    model = analytic_arm(robot)
    assert model is not None
    seed = (0.1, -1.0, 1.0, -1.5, -1.5, 0.0)
    a = solve_ik(robot, xyz, rpy, seeds=[seed], check_collision=False, method="closed_form")
    b = solve_ik(robot, xyz, rpy, seeds=[seed], check_collision=False, method="closed_form")
    assert a == b and a.reachable
    ab = _matrix(*robot.link_pose(robot.links["arm_base_link"]))
    target = (np.linalg.inv(ab) @ _matrix(xyz, p.getQuaternionFromEuler(rpy))
              @ np.linalg.inv(model.tool_in_flange))
    sols = ik_solutions(model.arm, target, seed=seed)
    near = [q for q in sols if _near_seed(q, seed)]  # shoulder and elbow within a quarter turn
    assert np.allclose(a.joints, (near or sols)[0], atol=1e-6)


@pytest.mark.parametrize("method", ["auto", "closed_form"])
def test_unreachable_target_gets_a_reason(robot: RobotModel, method: str) -> None:
    res = solve_ik(robot, (3.0, 0.0, 0.5), (0.0, math.pi, 0.0), method=method)  # type: ignore[arg-type]
    assert not res.reachable
    assert res.reason.startswith("unreachable: best position error")
    assert res.position_error_m > 1.0
    # in reach but inside the base: reachable by the kinematics, refused for the collision
    inside = solve_ik(robot, (0.0, 0.0, 0.3), (0.0, math.pi, 0.0), method=method)  # type: ignore[arg-type]
    assert not inside.reachable
    assert inside.reason.startswith("unreachable:")


def test_beyond_reach_is_a_lower_bound_never_positive_for_reachable_poses(robot: RobotModel) -> None:
    model = analytic_arm(robot)
    assert model is not None
    rng = np.random.default_rng(4)
    for _ in range(300):
        assert beyond_reach_m(model.arm, forward_kinematics(model.arm, _random_q(rng, model.arm))) <= 1e-9
    far = np.eye(4)
    far[:3, 3] = (1.5, 0.0, 0.3)
    assert beyond_reach_m(model.arm, far) > 0.3


def test_auto_gives_the_numeric_result_for_poses_in_reach_and_the_closed_form_reason_beyond(
        robot: RobotModel) -> None:
    down = (0.0, math.pi, 0.0)
    for xyz in ((0.7, 0.0, 0.5), (0.6, -0.2, 0.7)):
        assert solve_ik(robot, xyz, down) == solve_ik(robot, xyz, down, method="numeric")
    far = solve_ik(robot, (2.0, 0.0, 0.5), down)
    numeric = solve_ik(robot, (2.0, 0.0, 0.5), down, method="numeric")
    assert not far.reachable and not numeric.reachable
    assert far.reason.split(" m > ")[1] == numeric.reason.split(" m > ")[1]
    # the arm stretched towards the target: about as close as the numeric solver gets
    assert far.position_error_m == pytest.approx(numeric.position_error_m, rel=0.2)


def test_the_closed_form_is_calibrated_wherever_the_robot_stands() -> None:
    """Far from the origin PyBullet's poses are single precision: calibration must not depend on that."""
    from kbplanner.robot.arm_ik import analytic_arm
    from kbplanner.robot.robot_model import RobotModel

    robot = RobotModel.load("husky_ur16e")
    try:
        robot.floor_z = 27.0
        robot.set_base_pose(85.3, 7.1, 2.0)
        assert analytic_arm(robot) is not None
        x, y, _yaw = robot.base_pose()
        assert (x, y) == pytest.approx((85.3, 7.1), abs=1e-4)  # put back where it was
    finally:
        robot.close()

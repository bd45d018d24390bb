"""Arm IK (B4): poses in reach are reached within 1 cm / 3 deg, far ones are reported, deterministically."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pybullet as p
import pytest
import trimesh

from kbplanner.robot.arm_ik import reach_base_poses, solve_ik
from kbplanner.robot.robot_model import RobotModel
from kbplanner.world.footprint import ConfigurationSpace
from kbplanner.world.occupancy import Box, occupancy_from_meshes

DOWN = (0.0, math.pi, 0.0)  # tool z axis pointing at the floor


@pytest.fixture(scope="module")
def robot() -> Iterator[RobotModel]:
    model = RobotModel.load("husky_ur5")
    yield model
    model.close()


def _tool_errors(robot: RobotModel, q: tuple[float, ...], xyz: tuple[float, float, float],
                 rpy: tuple[float, float, float] | None) -> tuple[float, float]:
    saved = robot.arm_positions()
    robot.set_arm(q)
    pos, orn = robot.tool_pose()
    robot.set_arm(saved)
    perr = math.dist(pos, xyz)
    if rpy is None:
        return perr, 0.0
    want = p.getQuaternionFromEuler(rpy)
    return perr, 2 * math.acos(min(1.0, abs(float(np.dot(orn, want)))))


@pytest.mark.parametrize(
    ("xyz", "rpy"),
    [
        ((0.75, 0.0, 0.55), DOWN),  # in front, pointing down (pick from a storage)
        ((0.55, 0.35, 0.90), None),  # front left, position only
        ((0.40, -0.45, 1.10), (0.0, math.pi / 2, 0.0)),  # right side, pointing forward
        ((-0.30, 0.50, 0.70), DOWN),  # behind left
    ],
)
def test_ik_reaches_tool_poses_inside_the_reach(
    robot: RobotModel, xyz: tuple[float, float, float], rpy: tuple[float, float, float] | None
) -> None:
    robot.set_base_pose(0.0, 0.0, 0.0)
    res = solve_ik(robot, xyz, rpy)
    assert res.reachable, res.reason
    perr, rerr = _tool_errors(robot, res.joints, xyz, rpy)
    assert perr < 0.01 and rerr < math.radians(3)
    assert res.position_error_m == pytest.approx(perr, abs=1e-9)
    lo, hi = robot.arm_limits()
    assert all(lo[i] <= v <= hi[i] for i, v in enumerate(res.joints))


def test_ik_works_in_the_site_frame_wherever_the_base_stands(robot: RobotModel) -> None:
    robot.set_base_pose(5.0, 3.0, math.pi / 2)  # facing +y: "in front" is now +y
    target = (5.0, 3.75, 0.55)
    res = solve_ik(robot, target, DOWN)
    assert res.reachable, res.reason
    assert _tool_errors(robot, res.joints, target, DOWN)[0] < 0.01
    robot.set_base_pose(0.0, 0.0, 0.0)


@pytest.mark.parametrize("xyz", [(3.0, 0.0, 0.5), (0.0, 0.0, 2.5), (-1.6, 0.4, 0.6)])
def test_far_targets_are_reported_unreachable_with_the_error(
    robot: RobotModel, xyz: tuple[float, float, float]
) -> None:
    robot.set_base_pose(0.0, 0.0, 0.0)
    res = solve_ik(robot, xyz)
    assert not res.reachable
    assert res.reason.startswith("unreachable: best position error")
    assert res.position_error_m > 0.3


def test_a_target_inside_the_robot_body_is_unreachable_because_of_collision(robot: RobotModel) -> None:
    robot.set_base_pose(0.0, 0.0, 0.0)
    res = solve_ik(robot, (0.45, 0.0, 0.25), DOWN)  # down at the lidar, below the plate
    assert not res.reachable
    assert "touch" in res.reason or "error" in res.reason


def test_ik_is_deterministic_and_leaves_the_arm_as_it_was(robot: RobotModel) -> None:
    robot.set_base_pose(0.0, 0.0, 0.0)
    robot.set_named_pose("stow")
    before = robot.arm_positions()
    a = solve_ik(robot, (0.6, -0.2, 0.7), DOWN)
    b = solve_ik(robot, (0.6, -0.2, 0.7), DOWN)
    assert a == b
    assert robot.arm_positions() == before


def _room_meshes() -> list[trimesh.Trimesh]:
    walls = []
    sides = [(-0.2, -0.2, 6.2, 0.0), (-0.2, 4.0, 6.2, 4.2), (-0.2, 0.0, 0.0, 4.0), (6.0, 0.0, 6.2, 4.0)]
    for x0, y0, x1, y1 in sides:
        box = trimesh.creation.box(extents=(x1 - x0, y1 - y0, 2.7))
        box.apply_translation(((x0 + x1) / 2, (y0 + y1) / 2, 1.35))
        walls.append(box)
    return walls


def test_reach_base_poses_finds_free_base_poses_from_which_the_arm_reaches_a_wall_target(
    robot: RobotModel,
) -> None:
    grid = occupancy_from_meshes(_room_meshes(), (0.05, 1.5), Box(-0.5, -0.5, 6.5, 4.5))
    cs = ConfigurationSpace.build(grid, robot.spec.footprint())
    target = (3.0, 0.35, 0.9)  # 0.35 m in front of the south wall
    robot.set_base_pose(1.0, 2.0, 0.0)
    poses = reach_base_poses(target, robot, grid, n_samples=40, seed=7, cspace=cs)
    assert poses, "no base pose reaches a target next to a wall"
    for rp in poses:
        assert cs.is_free(rp.x, rp.y, rp.yaw)
        robot.set_base_pose(rp.x, rp.y, rp.yaw)
        assert _tool_errors(robot, rp.ik.joints, target, None)[0] < 0.01
    assert robot.base_pose() != pytest.approx((1.0, 2.0, 0.0))  # moved by this test, not by the function
    robot.set_base_pose(1.0, 2.0, 0.0)
    again = reach_base_poses(target, robot, grid, n_samples=40, seed=7, cspace=cs)
    assert again == poses
    assert robot.base_pose() == pytest.approx((1.0, 2.0, 0.0))
    assert [r.clearance_m for r in poses] == sorted((r.clearance_m for r in poses), reverse=True)


def test_reach_base_poses_returns_none_for_a_target_out_of_reach_of_any_free_pose(
    robot: RobotModel,
) -> None:
    grid = occupancy_from_meshes(_room_meshes(), (0.05, 1.5), Box(-0.5, -0.5, 6.5, 4.5))
    assert reach_base_poses((3.0, 2.0, 2.6), robot, grid, n_samples=20, seed=1) == []  # at the ceiling

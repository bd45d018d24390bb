"""Robot descriptions: the URDFs are generated from robots.toml, load in PyBullet, and match the DH chain."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from kbplanner.core.errors import InputFileError
from kbplanner.robot.robot_model import RobotModel, write_urdfs
from kbplanner.robot.robot_table import load_robot_specs, robot_spec, robots_toml
from kbplanner.robot.urdf_generation import ARM_JOINT_NAMES, urdf_text

ROBOTS = ("husky_ur5", "husky_ur16e", "jackal")


@pytest.fixture(scope="module")
def husky_ur5() -> Iterator[RobotModel]:
    robot = RobotModel.load("husky_ur5")
    yield robot
    robot.close()


def test_regenerating_the_urdfs_gives_the_checked_in_files_byte_for_byte(tmp_path: Path) -> None:
    written = write_urdfs(out_dir=tmp_path)
    assert sorted(w.name for w in written) == sorted(f"{r}.urdf" for r in ROBOTS)
    for w in written:
        shipped = robots_toml().parent / w.name
        assert w.read_bytes() == shipped.read_bytes(), f"{w.name} is stale: run python sim/tools/make_urdf.py"


def test_the_table_carries_the_published_husky_ur5_ur16e_and_jackal_figures() -> None:
    specs = load_robot_specs()
    assert set(specs) == set(ROBOTS)
    husky = specs["husky_ur5"].base
    assert (husky.length_m, husky.width_m, husky.mass_kg, husky.wheel_radius_m) == (0.99, 0.67, 50.0, 0.165)
    assert husky.lidar.params["fov_deg"] == 270.0 and husky.lidar.params["range_max_m"] == 20.0
    assert husky.lidar.xyz[2] == pytest.approx(0.30)
    ur5 = specs["husky_ur5"].arm
    assert ur5 is not None
    assert ur5.d == (0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823)
    assert ur5.a[1:3] == (-0.425, -0.39225)
    ur16e = specs["husky_ur16e"].arm
    assert ur16e is not None
    assert ur16e.d == (0.1807, 0.0, 0.0, 0.17415, 0.11985, 0.11655)
    assert ur16e.a[1:3] == (-0.4784, -0.36)
    jackal = specs["jackal"]
    assert jackal.arm is None and (jackal.base.length_m, jackal.base.width_m) == (0.508, 0.43)
    assert specs["husky_ur5"].footprint().bounds_m() == pytest.approx((-0.495, -0.335, 0.495, 0.335))


@pytest.mark.parametrize("name", ROBOTS)
def test_every_robot_loads_with_a_massive_root_and_its_links_found(name: str) -> None:
    robot = RobotModel.load(name)
    try:
        root_mass = p.getDynamicsInfo(robot.body, -1, physicsClientId=robot.client)[0]
        assert root_mass > 1.0  # a root of mass 0 would be static
        total = root_mass + sum(
            p.getDynamicsInfo(robot.body, j, physicsClientId=robot.client)[0]
            for j in range(p.getNumJoints(robot.body, physicsClientId=robot.client))
        )
        assert total == pytest.approx(robot.spec.mass_kg, rel=1e-6)
        assert robot.lidar_link >= 0 and robot.camera_link >= 0
        lidar_z = robot.link_pose(robot.lidar_link)[0][2]
        assert lidar_z == pytest.approx(0.30, abs=0.01)
        if robot.spec.arm is None:
            assert robot.arm_joints == () and robot.tool_link is None
        else:
            assert len(robot.arm_joints) == 6 and robot.tool_link is not None
    finally:
        robot.close()


def _dh_tool_position(q: tuple[float, ...], d: tuple[float, ...], a: tuple[float, ...],
                      alpha: tuple[float, ...], tcp: float) -> np.ndarray:
    t = np.eye(4)
    for i in range(6):
        ct, st, ca, sa = math.cos(q[i]), math.sin(q[i]), math.cos(alpha[i]), math.sin(alpha[i])
        t = t @ np.array([[ct, -st * ca, st * sa, a[i] * ct],
                          [st, ct * ca, -ct * sa, a[i] * st],
                          [0.0, sa, ca, d[i]],
                          [0.0, 0.0, 0.0, 1.0]])
    return (t @ np.array([0.0, 0.0, tcp, 1.0]))[:3]


@pytest.mark.parametrize("name", ["husky_ur5", "husky_ur16e"])
def test_the_urdf_arm_follows_the_published_dh_chain(name: str) -> None:
    robot = RobotModel.load(name)
    spec = robot.spec
    assert spec.arm is not None
    rng = np.random.default_rng(3)
    try:
        for _ in range(5):
            q = tuple(float(v) for v in rng.uniform(-math.pi, math.pi, 6))
            robot.set_arm(q)
            got = np.array(robot.tool_pose()[0])
            local = _dh_tool_position(q, spec.arm.d, spec.arm.a, spec.arm.alpha, spec.tcp_m)
            want = local + np.array(spec.arm_mount_xyz)  # mount yaw is 0 in the table
            assert np.allclose(got, want, atol=1e-5)
    finally:
        robot.close()


def test_the_stow_pose_keeps_the_arm_inside_the_footprint_and_clear_of_lidar_and_camera(
    husky_ur5: RobotModel,
) -> None:
    robot = husky_ur5
    robot.set_base_pose(0.0, 0.0, 0.0)
    robot.set_named_pose("stow")
    boxes = [p.getAABB(robot.body, link, physicsClientId=robot.client) for link in robot.arm_links]
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    assert lo[0] > -0.495 and hi[0] < 0.495 and lo[1] > -0.335 and hi[1] < 0.335
    assert lo[2] > robot.spec.base.height_m  # above the top plate: the lidar plane (0.3 m) is free
    assert robot.min_distance(robot.arm_links, [robot.lidar_link, robot.camera_link]) > 0.02
    # No part of the arm in the camera's field of view (rays from the lens, 87 x 58 degrees, 2 m).
    cam, orn = robot.link_pose(robot.camera_link)
    rot = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
    start = np.array(cam) + rot @ np.array([0.02, 0.0, 0.0])
    dirs = [rot @ np.array([math.cos(v) * math.cos(h), math.cos(v) * math.sin(h), math.sin(v)])
            for h in np.radians(np.linspace(-43.5, 43.5, 15)) for v in np.radians(np.linspace(-29, 29, 9))]
    hits = p.rayTestBatch([start.tolist()] * len(dirs), [(start + 2.0 * d).tolist() for d in dirs],
                          physicsClientId=robot.client)
    assert not [h for h in hits if h[0] == robot.body and h[1] in robot.arm_links]


def test_named_poses_put_the_tool_where_their_comments_say(husky_ur5: RobotModel) -> None:
    robot = husky_ur5
    robot.set_base_pose(0.0, 0.0, 0.0)
    robot.set_named_pose("pre_grasp")
    pos, orn = robot.tool_pose()
    z_axis = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)[:, 2]
    assert pos == pytest.approx((0.80, 0.0, 0.70), abs=0.01) and z_axis[2] < -0.999
    robot.set_named_pose("carry")
    pos, orn = robot.tool_pose()
    z_axis = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)[:, 2]
    assert pos[2] > 1.2 and z_axis[2] > 0.999 and abs(pos[0]) < 0.495
    assert robot.arm_clearance() > 0.0
    robot.set_named_pose("stow")


def test_setting_the_base_pose_moves_the_whole_robot(husky_ur5: RobotModel) -> None:
    robot = husky_ur5
    robot.set_base_pose(2.0, -1.0, math.pi / 2)
    assert robot.base_pose() == pytest.approx((2.0, -1.0, math.pi / 2))
    lidar = robot.link_pose(robot.lidar_link)[0]
    assert lidar == pytest.approx((2.0, -1.0 + 0.4475, 0.30), abs=1e-6)  # the lidar faces +y now
    robot.set_base_pose(0.0, 0.0, 0.0)


def test_a_robot_without_an_arm_refuses_arm_poses_with_a_message() -> None:
    robot = RobotModel.load("jackal")
    try:
        with pytest.raises(InputFileError, match="no arm"):
            robot.set_named_pose("stow")
    finally:
        robot.close()


def test_an_unknown_pose_or_robot_names_the_known_ones(husky_ur5: RobotModel) -> None:
    with pytest.raises(InputFileError, match="carry"):
        husky_ur5.named_pose("dance")
    with pytest.raises(InputFileError, match="husky_ur5"):
        robot_spec("r2d2")


def test_a_broken_robot_table_is_reported_with_its_file_and_the_fix(tmp_path: Path) -> None:
    bad = tmp_path / "robots.toml"
    bad.write_text("[robot.x]\nbase = 'nowhere'\n", encoding="utf-8")
    with pytest.raises(InputFileError, match="unknown base 'nowhere'") as err:
        load_robot_specs(bad)
    assert str(bad) in str(err.value) and "fix:" in str(err.value)
    bad.write_text("[robot.x\n", encoding="utf-8")
    with pytest.raises(InputFileError, match="not valid TOML"):
        load_robot_specs(bad)
    text = robots_toml().read_text(encoding="utf-8")
    text = text.replace("d = [0.089159, 0.0, 0.0, 0.10915", "d = [0.089159")
    bad.write_text(text, encoding="utf-8")
    with pytest.raises(InputFileError, match=r"arm\.ur5\.d"):
        load_robot_specs(bad)


def test_urdf_text_is_deterministic_and_names_every_ur_joint() -> None:
    spec = robot_spec("husky_ur16e")
    assert urdf_text(spec) == urdf_text(spec)
    assert all(f'name="{j}"' in urdf_text(spec) for j in ARM_JOINT_NAMES)


def _per_joint_reset(robot: RobotModel, q: tuple[float, ...]) -> None:
    """The former ``set_arm``: one ``resetJointState`` per arm joint (velocity zero)."""
    for j, v in zip(robot.arm_joints, q, strict=True):
        p.resetJointState(robot.body, j, float(v), physicsClientId=robot.client)


def _robot_state(robot: RobotModel) -> tuple[object, ...]:
    joints = p.getJointStates(robot.body, robot.movable, physicsClientId=robot.client)
    links = [p.getLinkState(robot.body, link, computeLinkVelocity=1, computeForwardKinematics=True,
                            physicsClientId=robot.client)
             for link in sorted(set(robot.links.values())) if link >= 0]
    return (tuple(joints), tuple(links), robot.arm_clearance(), robot.tool_pose())


def test_set_arm_gives_the_joint_states_poses_and_distances_of_one_reset_per_joint() -> None:
    """``set_arm`` sets the six joints in one call: bit for bit the state of a reset per joint, also from
    moving joints (velocities set to zero) and after stepping the simulation from it."""
    a, b = RobotModel.load("husky_ur5"), RobotModel.load("husky_ur5")
    try:
        rng = np.random.default_rng(3)
        lo, hi = a.arm_limits()
        for k in range(60):
            q = tuple(float(v) for v in rng.uniform(lo, hi))
            base = (float(rng.uniform(-20, 20)), float(rng.uniform(-20, 20)), float(rng.uniform(-3, 3)))
            for robot in (a, b):
                robot.set_base_pose(*base)
                if k % 3 == 0:  # joints moving before the reset
                    for j in robot.arm_joints:
                        p.resetJointState(robot.body, j, 0.3, targetVelocity=0.7,
                                          physicsClientId=robot.client)
            a.set_arm(q)
            _per_joint_reset(b, q)
            assert _robot_state(a) == _robot_state(b)
            if k % 5 == 0:
                for robot in (a, b):
                    p.stepSimulation(physicsClientId=robot.client)
                assert _robot_state(a) == _robot_state(b)
    finally:
        a.close()
        b.close()

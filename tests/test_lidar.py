"""Simulated sensors (B5 laser scan): the 270 degree scanner sees what is in front of it, at the right
distance, not what is behind it or inside its blind zone; navigation poses keep lidar and camera clear."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pybullet as p
import pytest

from kbplanner.robot.arm_ik import solve_ik
from kbplanner.robot.lidar import lidar_spec, scan, sensor_view_hits
from kbplanner.robot.robot_model import RobotModel

WORKER_RADIUS_M = 0.25


@pytest.fixture(scope="module")
def robot() -> Iterator[RobotModel]:
    model = RobotModel.load("husky_ur16e")
    model.set_base_pose(0.0, 0.0, 0.0)
    model.set_named_pose("stow")
    yield model
    model.close()


def _capsule(robot: RobotModel, x: float, y: float) -> int:
    shape = p.createCollisionShape(p.GEOM_CAPSULE, radius=WORKER_RADIUS_M, height=1.2,
                                   physicsClientId=robot.client)
    return int(p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape, basePosition=[x, y, 0.85],
                                 physicsClientId=robot.client))


def test_the_scanner_has_the_robot_tables_field_of_view_and_resolution(robot: RobotModel) -> None:
    spec = lidar_spec(robot)
    assert math.degrees(spec.fov_rad) == pytest.approx(270.0)
    assert spec.n_rays == 541 and spec.range_min_m == 0.5 and spec.range_max_m == 20.0


@pytest.mark.parametrize(("x", "y"), [(3.0, 0.0), (1.2, 1.5), (0.6, -1.5)])
def test_a_worker_in_the_field_of_view_is_seen_at_the_distance_of_their_surface(robot: RobotModel, x: float,
                                                                               y: float) -> None:
    body = _capsule(robot, x, y)
    try:
        hit = scan(robot, lidar_spec(robot)).nearest({body: "worker"})
        assert hit is not None
        (lx, ly, _), _ = robot.link_pose(robot.lidar_link)
        expected = math.hypot(x - lx, y - ly) - WORKER_RADIUS_M
        assert hit[0] == "worker" and hit[1] == pytest.approx(expected, abs=0.02)
        assert hit[2] == pytest.approx(math.atan2(y - ly, x - lx), abs=math.radians(3))
    finally:
        p.removeBody(body, physicsClientId=robot.client)


@pytest.mark.parametrize(("x", "y", "why"), [(-2.5, 0.0, "behind the scanner"), (25.0, 0.0, "out of range")])
def test_a_worker_outside_the_scanners_view_is_not_seen(robot: RobotModel, x: float, y: float,
                                                        why: str) -> None:
    body = _capsule(robot, x, y)
    try:
        assert scan(robot, lidar_spec(robot)).nearest({body: "worker"}) is None, why
    finally:
        p.removeBody(body, physicsClientId=robot.client)


def test_hits_on_ignored_bodies_such_as_the_held_element_count_as_no_hit(robot: RobotModel) -> None:
    body = _capsule(robot, 2.0, 0.0)
    try:
        spec = lidar_spec(robot)
        assert scan(robot, spec).nearest({body: "worker"}) is not None
        assert scan(robot, spec, ignore=[body]).nearest({body: "worker"}) is None
    finally:
        p.removeBody(body, physicsClientId=robot.client)


def test_a_scan_of_the_rays_near_people_reports_their_hits_as_a_whole_scan_does(robot: RobotModel) -> None:
    """The separation monitor casts only the rays that pass near a worker: every ray it casts reports
    the same hit (body, range and point, bit for bit) as in a whole scan, people hidden behind others
    or behind a wall included, and the workers' hits are all there."""
    import numpy as np

    people = [(2.0, 0.3), (3.5, 0.5), (0.9, -1.1), (-0.2, 2.4), (6.0, -4.0), (-3.0, 0.1)]
    bodies = [_capsule(robot, x, y) for x, y in people]
    box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.05, 1.0, 1.0], physicsClientId=robot.client)
    wall = int(p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=box, basePosition=[5.0, -3.2, 1.0],
                                 physicsClientId=robot.client))
    spec = lidar_spec(robot)
    xy = np.array(people, dtype=np.float64)
    try:
        for pose in [(0.0, 0.0, 0.0), (0.4, -0.3, 0.7), (1.0, 1.0, -2.5), (-1.0, 0.5, 3.0)]:
            robot.set_base_pose(*pose)
            whole = scan(robot, spec)
            part = scan(robot, spec, near=xy, near_radius_m=WORKER_RADIUS_M + 0.25)
            cast = np.isfinite(part.ranges)
            assert cast.sum() < len(part.ranges) / 2  # most rays are not cast at all
            for b in bodies:
                mask = whole.bodies == b
                assert (part.bodies == b).tolist() == mask.tolist()
                assert part.points[mask].tobytes() == whole.points[mask].tobytes()
                assert part.ranges[mask].tobytes() == whole.ranges[mask].tobytes()
            assert part.bodies[cast].tolist() == whole.bodies[cast].tolist()
            assert part.ranges[cast].tobytes() == whole.ranges[cast].tobytes()
            assert any((whole.bodies == b).any() for b in bodies)
    finally:
        robot.set_base_pose(0.0, 0.0, 0.0)
        for b in [*bodies, wall]:
            p.removeBody(b, physicsClientId=robot.client)


def test_the_stow_pose_keeps_lidar_and_camera_clear_and_an_arm_in_front_does_not(robot: RobotModel) -> None:
    robot.set_named_pose("stow")
    assert sensor_view_hits(robot) == {"lidar": 0, "camera": 0}
    reach = solve_ik(robot, (0.75, 0.0, 0.55), (0.0, math.pi, 0.0))  # gripper down in front of the camera
    assert reach.reachable, reach.reason
    robot.set_arm(reach.joints)
    hits = sensor_view_hits(robot)
    robot.set_named_pose("stow")
    assert hits["lidar"] + hits["camera"] > 0

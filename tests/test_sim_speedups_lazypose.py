"""B5 per-period loop speed-up of session 12 (lazypose12) that claims identical results: the
environment robot placed in PyBullet when looked at (``SimRobot.place_pending``) against placing it at
every base and arm setting, over random moves and every kind of look at the robot."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from kbplanner.planning.manipulation import robot_name
from kbplanner.robot.lidar import lidar_spec, scan, sensor_view_hits
from kbplanner.simulation.sim_bodies import SimRobot
from kbplanner.simulation.sim_env import SimEnv
from sim_project_factory import load_sim_case


def _bits(*values: float) -> bytes:
    return struct.pack(f"{len(values)}d", *values)


def _links(env: SimEnv) -> bytes:
    """Every robot link's pose and the base's as PyBullet has them now, bit for bit."""
    import pybullet as p

    robot = env.robot
    pos, orn = p.getBasePositionAndOrientation(robot.body, physicsClientId=env.client)
    out = _bits(*pos, *orn)
    for link in range(p.getNumJoints(robot.body, physicsClientId=env.client)):
        s = p.getLinkState(robot.body, link, computeForwardKinematics=True, physicsClientId=env.client)
        out += _bits(*s[4], *s[5])
    return out


@pytest.fixture(scope="module")
def case(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return load_sim_case(tmp_path_factory.mktemp("lazypose") / "p", high_panel=False)


def test_the_robot_placed_when_looked_at_answers_every_query_as_placing_it_at_every_setting(case) -> None:  # type: ignore[no-untyped-def]
    """Two environments do the same random base and arm settings (and put-backs, follows, periods);
    the first puts the robot in PyBullet at every setting (as the former code did), the second when
    looked at. Every look (base pose, link and tool poses, arm clearance and self-touch, a lidar scan,
    the sensor-view rays, a sync and the raw PyBullet state, the held element's frame) answers the
    same bit for bit."""
    import pybullet as p

    envs = [SimEnv(case.world, robot_name(case.refined), grid=case.grid) for _ in range(2)]
    rng = np.random.default_rng(12)
    try:
        for env in envs:
            env.reset(seed=1)
            env.set_base_pose(2.5, -2.3, math.pi / 2)
        eager, lazy = envs[0].robot, envs[1].robot
        assert isinstance(eager, SimRobot) and isinstance(lazy, SimRobot)
        spec = lidar_spec(eager)
        iri = case.world.task_elements[0].iri
        held = False
        lower, upper = eager.arm_limits()
        looks = moves = 0
        kinds: set[int] = set()
        for k in range(500):
            what = int(rng.integers(14))
            if what <= 2:  # the base drives (sometimes on another floor elevation)
                pose = (2.5 + float(rng.normal(0, 0.3)), -2.3 + float(rng.normal(0, 0.3)),
                        float(rng.uniform(-4, 4)))
                z = float(rng.uniform(0, 0.5)) if what == 2 else None
                for env in envs:
                    env.robot.set_base_pose(*pose, z)
                moves += 1
            elif what <= 4:  # the arm moves
                q = [float(rng.uniform(lo, hi)) * 0.3 for lo, hi in zip(lower, upper, strict=True)]
                if k % 7 == 0:
                    q[int(rng.integers(len(q)))] = -0.0
                for env in envs:
                    env.set_arm(q)
                moves += 1
            elif what == 5:  # a put-back to the last setting after another pose
                kept = eager.pose_set()
                if kept is not None:
                    other = (kept[0], tuple(rng.uniform(-1, 1, len(kept[1])).tolist()))
                    for env in envs:
                        robot = env.robot
                        assert isinstance(robot, SimRobot)
                        robot.put(other)
                        robot.put(kept)
            elif what == 6:  # grasp or follow, a control period
                for env in envs:
                    if not held:
                        env.attach(iri)
                    env.follow()
                    env.step()
                held = True
            else:  # a look, of one kind
                kinds.add(what)
                if what == 7:
                    assert eager.base_pose() == lazy.base_pose()
                elif what == 8:
                    assert _bits(*eager.tool_pose()[0], *eager.tool_pose()[1]) == \
                        _bits(*lazy.tool_pose()[0], *lazy.tool_pose()[1])
                    assert eager.link_pose(-1) == lazy.link_pose(-1)
                elif what == 9:
                    assert _bits(eager.arm_clearance()) == _bits(lazy.arm_clearance())
                    assert eager.arm_touches_body() == lazy.arm_touches_body()
                elif what == 10:  # the monitor's scan: the bodies synced first, the robot by the scan
                    for env in envs:
                        env.sync()
                        env.robot.set_base_pose(*(env.robot.base_set or (0.0, 0.0, 0.0, None)))
                    a, b = scan(eager, spec), scan(lazy, spec)
                    assert a.ranges.tobytes() == b.ranges.tobytes()
                    assert a.bodies.tobytes() == b.bodies.tobytes()
                    assert sensor_view_hits(eager) == sensor_view_hits(lazy)
                elif what == 11:
                    assert eager.arm_positions() == lazy.arm_positions()
                    read = [tuple(float(s[0]) for s in p.getJointStates(
                        r.body, r.arm_joints, physicsClientId=r.client)) for r in (eager, lazy)]
                    for env in envs:  # (PyBullet's joints of the lazy robot may lag until a look)
                        env.sync()
                    assert _bits(*read[0]) == _bits(*(float(s[0]) for s in p.getJointStates(
                        lazy.body, lazy.arm_joints, physicsClientId=lazy.client)))
                else:
                    for env in envs:
                        env.sync()
                    assert _links(envs[0]) == _links(envs[1]), k
                    if held:
                        assert envs[0].element_frame(iri).tobytes() == envs[1].element_frame(iri).tobytes()
                looks += 1
            # the eager robot: in PyBullet after every setting, as before
            eager.place_pending()
        assert looks > 150 and moves > 150 and kinds == set(range(7, 14))
    finally:
        for env in envs:
            env.close()


def test_a_setting_is_not_placed_until_looked_at_and_a_bad_one_fails_at_once(case) -> None:  # type: ignore[no-untyped-def]
    import pybullet as p

    from kbplanner.core.errors import InputFileError

    env = SimEnv(case.world, robot_name(case.refined), grid=case.grid)
    try:
        env.reset(seed=1)
        env.sync()
        robot = env.robot
        before = p.getBasePositionAndOrientation(robot.body, physicsClientId=env.client)
        env.set_base_pose(7.0, 1.0, 0.5)
        assert p.getBasePositionAndOrientation(robot.body, physicsClientId=env.client) == before
        x, y, yaw = env.base_pose()
        assert (round(x, 6), round(y, 6), round(yaw, 6)) == (7.0, 1.0, 0.5)
        with pytest.raises(InputFileError, match="joint angles"):
            env.set_arm([0.0, 1.0])
    finally:
        env.close()


def test_the_stored_pose_is_the_pose_pybullet_reports_bit_for_bit(case) -> None:  # type: ignore[no-untyped-def]
    """``stored_pose`` (Bullet's quaternion -> matrix -> quaternion in Python) against PyBullet's report
    after placing the base, over random poses, the branches of the matrix-to-quaternion conversion
    (yaw near 0, pi/2, pi, signed zeros) and floor elevations."""
    import pybullet as p

    from kbplanner.simulation.sim_bodies import stored_pose

    env = SimEnv(case.world, robot_name(case.refined), grid=case.grid)
    try:
        env.reset(seed=1)
        robot = env.robot
        rng = np.random.default_rng(3)
        special = [0.0, -0.0, math.pi, -math.pi, math.pi / 2, -math.pi / 2, 1e-300, 2 * math.pi, 1e-9]
        for k in range(3000):
            x, y = rng.uniform(-300, 300, 2).tolist()
            yaw = special[k % len(special)] if k % 4 == 0 else float(rng.uniform(-7, 7))
            z = [0.0, -0.0, 3.2, float(rng.uniform(-10, 40))][k % 4]
            robot._reset_base(x, y, yaw, z)
            got = p.getBasePositionAndOrientation(robot.body, physicsClientId=env.client)
            pos, orn = stored_pose(robot, x, y, yaw, z)
            assert _bits(*got[0], *got[1]) == _bits(*pos, *orn), (x, y, yaw, z)
        assert isinstance(robot, SimRobot)
        robot.set_base_pose(1.0, 2.0, 3.0)
        assert robot.round_trip_ok()
    finally:
        env.close()

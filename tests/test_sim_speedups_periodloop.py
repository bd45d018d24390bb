"""B5 per-period loop speed-ups of session 11 (periodloop) that claim identical results, each against
the full computation: bodies placed in PyBullet when looked at against placing them every period, the
environment robot's kept arm joints and put-back pose against PyBullet's state, the written-out social
force against the array code on the edge cases of the footprint distance."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from kbplanner.planning.manipulation import robot_name
from kbplanner.simulation import social_force
from kbplanner.simulation.sim_bodies import SimRobot
from kbplanner.simulation.sim_env import SimEnv
from kbplanner.simulation.social_force import Obstacle, SocialForceParams
from kbplanner.simulation.workers import RouteStop, WorkerMotion, WorkerSpec
from kbplanner.world.footprint import Rect
from sim_project_factory import load_sim_case


def _bits(*values: float) -> bytes:
    return struct.pack(f"{len(values)}d", *values)


def _state(env: SimEnv, bodies: list[int]) -> bytes:
    """The PyBullet poses of ``bodies`` and of every robot link, bit for bit."""
    import pybullet as p

    env.robot.place_pending()  # (a reader of PyBullet's robot places it first)
    out = b""
    for b in bodies:
        pos, orn = p.getBasePositionAndOrientation(b, physicsClientId=env.client)
        out += _bits(*pos, *orn)
    robot = env.robot
    for link in range(p.getNumJoints(robot.body, physicsClientId=env.client)):
        s = p.getLinkState(robot.body, link, computeForwardKinematics=True, physicsClientId=env.client)
        out += _bits(*s[4], *s[5])
    return out


@pytest.fixture(scope="module")
def case(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return load_sim_case(tmp_path_factory.mktemp("periodloop") / "p", high_panel=False)


def _walker(name: str, y: float) -> WorkerMotion:
    spec = WorkerSpec(f"urn:test:{name}", name, "carpenter", 1.0,
                      (RouteStop("a", "A", 0.0, y, 1.0), RouteStop("b", "B", 5.0, y, 1.0)))
    pts = np.array([[0.0, y], [5.0, y]])
    return WorkerMotion(spec, [(0.0, 50.0, pts, np.array([0.0, 5.0]))])


def test_bodies_placed_when_looked_at_are_where_placing_them_every_period_puts_them(case) -> None:  # type: ignore[no-untyped-def]
    """Two environments do the same random moves; one places the held element and the worker capsules
    right away at every follow and step (as the former code did), the other when looked at; whenever
    the second is looked at, both have the same PyBullet state bit for bit, robot links included."""
    workers = [_walker("w1", -4.0), _walker("w2", -6.0)]
    envs = [SimEnv(case.world, robot_name(case.refined), grid=case.grid, workers=workers) for _ in range(2)]
    rng = np.random.default_rng(5)
    try:
        for env in envs:
            env.reset(seed=1)
            env.set_base_pose(2.5, -2.3, math.pi / 2)
        iri = case.world.task_elements[0].iri
        held = [env.attach(iri) for env in envs]
        lower, upper = envs[0].robot.arm_limits()
        looks = moves = 0
        for k in range(400):
            what = rng.integers(6)
            if what == 0:  # the base drives
                pose = (2.5 + float(rng.normal(0, 0.3)), -2.3 + float(rng.normal(0, 0.3)),
                        float(rng.uniform(-4, 4)))
                for env in envs:
                    env.set_base_pose(*pose)
                moves += 1
            elif what == 1:  # the arm moves
                q = [float(rng.uniform(lo, hi)) * 0.3 for lo, hi in zip(lower, upper, strict=True)]
                if k % 7 == 0:
                    q[int(rng.integers(len(q)))] = -0.0
                for env in envs:
                    env.set_arm(q)
                moves += 1
            elif what == 2:  # the skill asks the element to follow
                for env in envs:
                    env.follow()
                envs[0].sync()
            elif what == 3:  # a control period
                for env in envs:
                    env.step()
                envs[0].sync()
            else:  # a look: a scan, a key frame, a body's frame
                envs[1].sync()
                bodies = [held[0].body, *(w.body for w in envs[0].workers)]
                assert _state(envs[0], bodies) == _state(envs[1], bodies), k
                assert envs[0].element_frame(iri).tobytes() == envs[1].element_frame(iri).tobytes()
                assert envs[0].base_pose() == envs[1].base_pose()
                looks += 1
        assert looks > 100 and moves > 100
    finally:
        for env in envs:
            env.close()


def test_the_environment_robots_kept_arm_joints_and_put_back_pose_are_pybullets(case) -> None:  # type: ignore[no-untyped-def]
    import pybullet as p

    env = SimEnv(case.world, robot_name(case.refined), grid=case.grid)
    try:
        env.reset(seed=1)
        robot = env.robot
        assert isinstance(robot, SimRobot)
        rng = np.random.default_rng(6)
        for k in range(300):
            q = (rng.normal(size=len(robot.arm_joints)) * 10.0 ** rng.uniform(-12, 0.5)).tolist()
            q[k % len(q)] = -0.0 if k % 2 else 0.0
            robot.set_arm(q)
            robot.place_pending()
            read = tuple(float(s[0]) for s in p.getJointStates(robot.body, robot.arm_joints,
                                                               physicsClientId=robot.client))
            assert _bits(*robot.arm_positions()) == _bits(*read) == _bits(*q)
            robot.set_base_pose(*rng.uniform(-20, 20, 2).tolist(), float(rng.uniform(-7, 7)))
            kept = robot.pose_set()
            assert kept is not None
            before = _state(env, [])
            robot.put((robot.base_set or kept[0], tuple(rng.uniform(-1, 1, len(q)).tolist())))
            robot.set_base_pose(1.0, 2.0, 3.0)
            robot.put(kept)
            assert _state(env, []) == before
        robot.forget_base()  # physics may have moved it: read again
        assert robot.pose_set() is None and robot.arm_positions() == tuple(
            float(s[0]) for s in p.getJointStates(robot.body, robot.arm_joints, physicsClientId=robot.client))
    finally:
        env.close()


def _array_accelerations(*args: object) -> np.ndarray:
    old = social_force.SMALL_CROWD
    social_force.SMALL_CROWD = -1
    try:
        return social_force.accelerations(*args)  # type: ignore[arg-type]
    finally:
        social_force.SMALL_CROWD = old


def test_written_out_social_force_is_the_array_codes_on_the_footprints_edges() -> None:
    """Workers on a rectangle's sides and corners (offsets of exactly 0 either side), inside it, at the
    robot's centre, two on one spot, standing and walking, one to seven workers, one to three
    rectangles: the written-out floats give the array code's numbers bit for bit."""
    rng = np.random.default_rng(17)
    shapes = [[Rect(0.0, 0.0, 0.99, 0.67)],
              [Rect(0.0, 0.0, 0.99, 0.67), Rect(-0.005, -0.1741, 0.7166, 2.4)],
              [Rect(0.0, 0.0, 0.99, 0.67), Rect(0.3, 0.1, 1.5, 0.4, 0.3), Rect(-0.2, 0.0, 0.5, 2.0, 1.2)]]
    cases = {"edge": 0, "inside": 0}
    for trial in range(3000):
        n = int(rng.integers(1, 8))
        rects = shapes[trial % 3]
        yaw = float(rng.choice([0.0, -0.0, math.pi / 2, float(rng.uniform(-4, 4))]))
        seen = Obstacle((float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2)), yaw), rects)
        c, s = math.cos(yaw), math.sin(yaw)
        pos = rng.uniform(-4, 4, (n, 2))
        for i in range(n):
            kind = rng.integers(5)
            if kind == 0:  # on a side or a corner of a rectangle (robot frame -> site frame)
                r = rects[int(rng.integers(len(rects)))]
                lx = r.cx + float(rng.choice([-1, 1, 0])) * r.length / 2
                ly = r.cy + float(rng.choice([-1, 1])) * r.width / 2
                pos[i] = (seen.pose[0] + c * lx - s * ly, seen.pose[1] + s * lx + c * ly)
                cases["edge"] += 1
            elif kind == 1:  # inside, or at the centre
                centre = np.array(seen.pose[:2])
                pos[i] = centre if rng.random() < 0.5 else centre + rng.normal(0, 0.1, 2)
                cases["inside"] += 1
        if n > 2 and rng.random() < 0.2:
            pos[1] = pos[0]
        vel = rng.normal(0, 1, (n, 2)) * (rng.random((n, 1)) > 0.3)
        desired = rng.normal(0, 1, (n, 2))
        params = [SocialForceParams(anisotropy=float(rng.uniform(0, 1)),
                                    comfort_distance_m=float(rng.uniform(0.5, 1.5))) for _ in range(n)]
        robot = None if rng.random() < 0.1 else seen
        active = np.ones(n, dtype=bool)
        got = social_force.accelerations(pos, vel, desired, params, robot, active)
        want = _array_accelerations(pos, vel, desired, params, robot, active)
        assert got.tobytes() == want.tobytes(), trial
    assert min(cases.values()) > 500, cases

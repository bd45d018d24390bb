"""B5 per-tick speed-ups of session 10 (crowdfast) that claim identical results, each against the full
computation they skip or the former code."""

from __future__ import annotations

import math

import numpy as np

from kbplanner.simulation import separation, walk_checks
from kbplanner.simulation.social_force import Obstacle
from kbplanner.world.footprint import Rect
from kbplanner.world.occupancy import OccupancyGrid


def _site() -> OccupancyGrid:
    """A corridor with an alcove, a pillar and a few walls: legs that leave the walking map early,
    late, or never."""
    res, x0, y0 = 0.05, -7.0, -2.0
    ys, xs = np.mgrid[0:140, 0:280]
    cx, cy = x0 + (xs + 0.5) * res, y0 + (ys + 0.5) * res
    free = (np.abs(cy) < 1.2) | ((cx > 2.0) & (cx < 4.0) & (cy < 4.5))
    free &= ~((np.abs(cx + 1.0) < 0.3) & (np.abs(cy - 0.3) < 0.3))
    return OccupancyGrid(occupied=~free, origin=(x0, y0), resolution=res)


def test_legs_that_leave_the_walking_map_soon_get_the_answers_of_sampling_them_whole() -> None:
    grid = _site()
    free = grid.clearance_m() >= 0.25
    rng = np.random.default_rng(21)
    rects = [Rect(0.0, 0.0, 0.99, 0.67), Rect(0.3, 0.0, 2.4, 0.3, 0.2)]
    seen = {"soon": 0, "passes": 0, "fails later": 0}
    for _ in range(300):
        pose = (float(rng.uniform(-6, 6)), float(rng.uniform(-1.5, 4)), float(rng.uniform(-4, 4)))
        robot = Obstacle(pose, rects)
        p = np.array([rng.uniform(-7, 7), rng.uniform(-2, 5)])
        if rng.random() < 0.5:  # from a walkable cell, as the crowd's workers stand
            p = np.array([rng.uniform(-7, 7), rng.uniform(-1.1, 1.1)])
        radius = float(rng.uniform(1.0, 4.0))
        vias = [np.array([robot.pose[0] + radius * math.cos(j * math.pi / 8),
                          robot.pose[1] + radius * math.sin(j * math.pi / 8)]) for j in range(16)]
        legs = [(p, v) for v in vias] + [(v, p) for v in vias[::3]]
        got = walk_checks.clear_legs(legs, robot, free, grid)
        want = walk_checks._clear_legs(legs, robot, free, grid)
        assert got == want
        walk = walk_checks.free_cell_check(free, grid)
        assert walk is not None
        for (a, b), ok in zip(legs, want, strict=True):
            soon = walk_checks._leaves_soon(a, b, walk)
            assert not (soon and ok)
            seen["soon" if soon else "passes" if ok else "fails later"] += 1
    assert min(seen.values()) > 20, seen
    assert walk_checks.clear_legs(legs, robot, None, None) == walk_checks._clear_legs(legs, robot, None, None)


def test_reach_kept_per_footprint_list_follows_the_list() -> None:
    rng = np.random.default_rng(22)
    rects = [Rect(0.0, 0.0, 0.99, 0.67)]
    for _ in range(200):
        assert separation.reach_m(rects) == separation._reach(tuple(rects))
        if rng.random() < 0.5:
            rects.append(Rect(*rng.uniform(-1, 1, 2).tolist(), *rng.uniform(0.1, 3, 2).tolist(),
                              float(rng.uniform(-3, 3))))
        elif len(rects) > 1:
            rects[int(rng.integers(len(rects)))] = Rect(0.0, 0.0, float(rng.uniform(0.1, 5)), 0.5)
        copy = list(rects)  # another list of the same rectangles
        assert separation.reach_m(copy) == separation.reach_m(rects) == separation._reach(tuple(rects))


def test_a_kinematic_robots_kept_base_pose_is_the_one_pybullet_gives() -> None:
    import pybullet as p

    from kbplanner.robot.robot_model import RobotModel

    robot = RobotModel.load("husky_ur16e")
    free = RobotModel.load("husky_ur16e")  # not kinematic: reads PyBullet every time
    try:
        robot.kinematic = True
        rng = np.random.default_rng(23)
        for k in range(200):
            pose = (*rng.uniform(-50, 50, 2).tolist(), float(rng.uniform(-4, 4)))
            if k % 4:
                robot.set_base_pose(*pose)
                free.set_base_pose(*pose)
            else:  # physics stepped (the environment's settle): the robot is told
                quat = p.getQuaternionFromEuler([0.0, 0.0, pose[2]])
                for r in (robot, free):
                    p.resetBasePositionAndOrientation(r.body, [pose[0], pose[1], 0.2], quat,
                                                      physicsClientId=r.client)
                robot.forget_base()
            first = robot.base_pose()
            assert first == free.base_pose()
            assert robot.base_pose() is first  # kept: the same tuple until the base is set again
    finally:
        robot.close()
        free.close()


def test_separation_of_one_speed_in_floats_is_the_arrays() -> None:
    rng = np.random.default_rng(24)
    for _ in range(2000):
        ssm = separation.SsmParameters(*rng.uniform(0.0, 3.0, 2).tolist(), float(rng.uniform(0.1, 5.0)),
                                       *rng.uniform(0.0, 0.5, 2).tolist())
        v = float(rng.normal() * 10.0 ** rng.uniform(-9, 1))
        assert ssm.separation_at(v) == float(ssm.separation_m(v))
        assert ssm.separation_at(0.0) == float(ssm.separation_m(0.0))


def test_crowds_of_mixed_delays_and_many_workers_step_as_the_former_code() -> None:
    """The float step against the former numpy step (test_sim_speedups_tick's), for what the case study
    does not have: workers seeing the robot with different delays, more workers than SMALL_CROWD,
    people standing where another stands."""
    from kbplanner.simulation.crowd import Crowd
    from kbplanner.simulation.social_force import SMALL_CROWD, SocialForceParams
    from kbplanner.simulation.workers import RouteStop, WorkerSpec
    from test_sim_speedups_tick import _FormerCrowd
    from test_sim_speedups_tick import _site as corridor

    def spec(k: int, reaction: float) -> WorkerSpec:
        return WorkerSpec(f"urn:test:w{k}", f"W{k}", "carpenter", 1.0 + 0.05 * k,
                          (RouteStop("a", "A", -6.0 + 0.5 * k, -0.9 + 0.2 * (k % 9), 1.0 + k % 3),
                           RouteStop("b", "B", 6.0 - 0.5 * k, 0.9 - 0.2 * (k % 9), 1.0),
                           RouteStop("c", "C", 3.0, 3.5, 2.0)),
                          SocialForceParams(reaction_time_s=reaction))

    rects = [Rect(0.0, 0.0, 0.99, 0.67), Rect(0.3, 0.0, 2.4, 0.3)]
    crowds = [[spec(k, (0.3, 0.5, 0.8)[k % 3]) for k in range(5)],
              [spec(k, 0.5) for k in range(SMALL_CROWD + 3)],
              [spec(0, 0.5), spec(0, 0.5), spec(1, 0.2)]]  # two at the same spot
    for specs in crowds:
        grid = corridor()
        new, old = Crowd(specs, grid, seed=3), _FormerCrowd(specs, grid, seed=3)
        for k in range(400):
            x = -5.0 + 10.0 * abs(((k / 200.0) % 2.0) - 1.0)
            robot = None if 150 <= k < 170 else Obstacle((x, 0.1 * math.sin(k / 30), 0.2 * math.sin(k / 50)),
                                                         rects)
            new.step(robot)
            old.step(robot)
            for a, b in ((new.pos, old.pos), (new.vel, old.vel), (new.heading, old.heading)):
                assert a.tobytes() == b.tobytes(), (len(specs), k)
        assert new.positions() == [(float(p[0]), float(p[1]), float(h))
                                   for p, h in zip(old.pos, old.heading, strict=True)]

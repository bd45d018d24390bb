"""B5 NV-2: where the carried element is turned when it fits only one way at the start or the goal."""

from __future__ import annotations

import math

from kbplanner.simulation.skills.load_turn import TRIES, best_turn_pose, turn_poses


def test_turn_poses_start_at_the_nearest_ring_behind_the_robot_and_look_two_rings_further() -> None:
    # both ways fit only more than 0.6 m from (0, 0)
    poses = turn_poses(lambda x, y, yaw: math.hypot(x, y) > 0.6, (0.0, 0.0, 0.0))
    radii = sorted({round(math.hypot(x, y), 6) for x, y, _ in poses})
    assert radii == [0.75, 1.0, 1.25]
    assert poses[0][0] == -0.75 and abs(poses[0][1]) < 1e-12 and poses[0][2] == 0.0  # behind the robot first
    assert len(poses) == 3 * 16 * 4
    assert turn_poses(lambda x, y, yaw: False, (0.0, 0.0, 0.0)) == []


def test_the_turn_pose_is_the_one_whose_planned_leg_and_the_rest_take_least() -> None:
    near, far = (0.0, 0.0, 0.0), (10.0, 0.0, 0.0)
    candidates = [(-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (1.0, 0.0, math.pi), (5.0, 5.0, 0.0)]
    tried: list[tuple[float, float, float]] = []

    def leg(c: tuple[float, float, float]) -> tuple[str, float] | None:
        tried.append(c)
        if c[2] == math.pi:
            return None  # no leg found
        return f"leg to {c}", 4.0 * math.hypot(c[0], c[1])

    got = best_turn_pose(candidates, near, far, 0.5, leg)
    assert got == ((1.0, 0.0, 0.0), "leg to (1.0, 0.0, 0.0)")  # 4 s + 18 s, against 4 + 22 s behind
    assert tried[0] == candidates[0] and len(tried) == min(TRIES, len(candidates))
    assert best_turn_pose(candidates, near, far, 0.5, lambda c: None) is None
    assert best_turn_pose([], near, far, 0.5, leg) is None

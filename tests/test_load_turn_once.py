"""B5 NV-2: a route that turns the carried element once on the way (fits one way at the start, the other
way at the goal)."""

from __future__ import annotations

import math

from kbplanner.simulation.skills.load_turn_once import one_turn

Pose = tuple[float, float, float]


def test_the_turn_pose_of_the_quickest_pair_of_legs_is_taken() -> None:
    start, goal = (0.0, 0.0, 0.0), (10.0, 0.0, 0.0)

    def fits(x: float, y: float, yaw: float) -> bool:  # the load turns only in a band 0.5-1 m off the line
        return 0.5 <= abs(y) <= 1.0

    def to_turn(c: Pose) -> tuple[str, float] | None:  # the wide load: 2 s a metre, not past x = 6
        return None if c[0] > 6.0 else (f"a {c[:2]}", 2.0 * math.hypot(c[0], c[1]))

    def from_turn(c: Pose) -> tuple[str, float] | None:  # on its side: 1 s a metre
        return f"b {c[:2]}", math.hypot(goal[0] - c[0], goal[1] - c[1])

    got = one_turn(fits, start, goal, to_turn, from_turn)
    assert got is not None
    pose, a, b, seconds = got
    # near the start (the goal's candidates are past x = 6): 0.75 m ahead to the right (1.5 s + 9.48 s),
    # quicker than the nearest, 0.5 m to the side (1.0 s + 10.01 s)
    assert math.isclose(pose[0], 0.75 * math.cos(math.pi / 4)) and math.isclose(pose[1], -pose[0])
    assert a == f"a {pose[:2]}" and b == f"b {pose[:2]}"
    assert math.isclose(seconds, 2.0 * 0.75 + math.hypot(10.0 - pose[0], pose[1]))


def test_no_turn_pose_or_no_legs_give_none() -> None:
    start, goal = (0.0, 0.0, 0.0), (4.0, 0.0, 0.0)
    legs = lambda c: ("leg", 1.0)  # noqa: E731
    assert one_turn(lambda x, y, yaw: False, start, goal, legs, legs) is None
    assert one_turn(lambda x, y, yaw: True, start, goal, lambda c: None, legs) is None
    assert one_turn(lambda x, y, yaw: True, start, goal, legs, lambda c: None) is None

"""B5 navigation (heading14): under monitoring, a loaded base that stands facing into a pocket backs out
straight only until it can turn to face its way and then drives forwards; one whose goal faces out of a
pocket drives forwards to the pocket's mouth and backs in straight (``back_out``, taken by
``turn_around.skid_steer`` where it is quicker, backward driving counted)."""

from __future__ import annotations

import itertools
import math

from kbplanner.simulation.back_out import backed_in, backed_out, estimate_s
from kbplanner.simulation.motion_check import backward_m, path_is_free, turn_drive_turn
from kbplanner.simulation.turn_around import skid_steer, turned_round
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import Box, occupancy_from_meshes
from test_navigation import box

LOAD = Footprint((Rect(0.0, 0.0, 0.99, 0.67), Rect(0.0, 0.0, 1.6, 0.5)), name="husky + load")
LIMITS = (0.3, 2.0, 1.0, 2.0)  # speed, yaw rate, acceleration, yaw acceleration
COST = 8.0  # kbp:reversingCost, seconds per backward metre (the value measured in docs/scale.md)


def _room_and_pocket() -> ConfigurationSpace:
    """A 10 x 4 m room (y 2-6) with a 1.0 m wide, 2 m deep pocket south of it (x 4.5-5.5, y 0-2)."""
    walls = [box(-0.2, 1.8, 4.5, 2.0), box(5.5, 1.8, 10.2, 2.0), box(4.3, -0.2, 4.5, 2.0),
             box(5.5, -0.2, 5.7, 2.0), box(4.3, -0.2, 5.7, 0.0), box(-0.2, 6.0, 10.2, 6.2),
             box(-0.2, 1.8, 0.0, 6.2), box(10.0, 1.8, 10.2, 6.2)]
    grid = occupancy_from_meshes(walls, (0.05, 1.5), Box(-0.5, -0.5, 10.5, 6.5), 0.05)
    return ConfigurationSpace.build(grid, LOAD)


def _forwards_after(poses: list[tuple[float, float, float]], k: int) -> bool:
    """Whether every motion from waypoint ``k`` on drives forwards or turns on the spot."""
    return all(backward_m([a, b]) == 0.0 for a, b in itertools.pairwise(poses[k:]))


def test_facing_into_a_pocket_the_base_backs_out_straight_and_then_drives_forwards() -> None:
    cs = _room_and_pocket()
    # the planner's way: back out of the pocket facing its end, then on to the room's east
    poses = [(5.0, 0.9, -math.pi / 2), (5.0, 3.0, -math.pi / 2), (9.0, 4.5, 0.0)]
    assert path_is_free(cs, poses)
    plain, _ = turn_drive_turn(cs, poses, allow_reverse=False)
    got = backed_out(cs, poses, LIMITS[0], LIMITS[1], backward_m(plain), reverse_s_per_m=COST)
    assert got
    for way in got:
        assert path_is_free(cs, way) and way[0] == poses[0] and way[-1] == poses[-1]
        # straight back along the yaw (a pure reverse), then nothing but forwards and turns on the spot
        assert way[1][2] == poses[0][2] and abs(way[1][0] - 5.0) < 1e-9
        assert _forwards_after(way, 1)
        # out of the pocket (the 1.6 m load turns only once clear of it), but less far than planned
        assert 1.2 < backward_m(way) < backward_m(plain)
    assert estimate_s(got[0], *LIMITS[:2], COST) <= estimate_s(got[-1], *LIMITS[:2], COST)


def test_a_goal_facing_out_of_a_pocket_is_backed_into_straight_from_its_mouth() -> None:
    cs = _room_and_pocket()
    poses = [(9.0, 4.5, 0.0), (5.0, 3.0, math.pi / 2), (5.0, 0.9, math.pi / 2)]
    assert path_is_free(cs, poses)
    plain, _ = turn_drive_turn(cs, poses, allow_reverse=False)
    got = backed_in(cs, poses, LIMITS[0], LIMITS[1], backward_m(plain), reverse_s_per_m=COST)
    assert got
    way = got[0]
    assert path_is_free(cs, way) and way[0] == poses[0] and way[-1] == poses[-1]
    # forwards to the pocket's mouth, then straight back in along the goal's yaw
    assert way[-2][2] == poses[-1][2] and abs(way[-2][0] - 5.0) < 1e-9
    assert all(backward_m([a, b]) == 0.0 for a, b in itertools.pairwise(way[:-1]))
    assert 1.2 < backward_m(way) < backward_m(plain)


def test_skid_steer_under_monitoring_backs_up_less_and_with_reversing_allowed_is_unchanged() -> None:
    cs = _room_and_pocket()
    poses = [(5.0, 0.9, -math.pi / 2), (5.0, 3.0, -math.pi / 2), (9.0, 4.5, 0.0)]
    plain, _ = turn_drive_turn(cs, poses, allow_reverse=False)
    trace: list[tuple[str, float]] = []
    got, _ = skid_steer(cs, poses, allow_reverse=False, limits=LIMITS, reverse_s_per_m=8.0, trace=trace)
    assert path_is_free(cs, got) and got[0] == poses[0] and got[-1] == poses[-1]
    assert backward_m(got) < backward_m(plain) - 0.05
    assert trace[-1][0] in ("backed out", "turned round")
    assert skid_steer(cs, poses, allow_reverse=True, limits=LIMITS, reverse_s_per_m=8.0) == turn_drive_turn(
        cs, poses)


def test_with_no_time_for_a_backward_metre_the_rewrites_are_not_tried() -> None:
    """``reverse_s_per_m`` 0 (NavSettings' default): turn-drive-turn or the path turned round, as before."""
    cs = _room_and_pocket()
    poses = [(5.0, 0.9, -math.pi / 2), (5.0, 3.0, -math.pi / 2), (9.0, 4.5, 0.0)]
    trace: list[tuple[str, float]] = []
    got, _ = skid_steer(cs, poses, allow_reverse=False, limits=LIMITS, trace=trace)
    flipped = turned_round(cs, poses)
    assert flipped is not None
    assert got == turn_drive_turn(cs, flipped, allow_reverse=False)[0]
    assert all(how != "backed out" for how, _ in trace)


def test_nothing_to_back_out_of_gives_no_rewrite() -> None:
    cs = _room_and_pocket()
    poses = [(3.0, 4.0, 0.0), (6.0, 4.0, 0.0), (9.0, 4.5, 0.0)]  # in the open room, forwards already
    assert backed_out(cs, poses, LIMITS[0], LIMITS[1], 0.0, reverse_s_per_m=COST) == []
    assert backed_out(cs, poses[:2], LIMITS[0], LIMITS[1], reverse_s_per_m=COST) == []

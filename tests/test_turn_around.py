"""B5 navigation (reverse12): under monitoring (no reversing) a skid-steer path whose turn on the spot is
blocked backs up only to where the base can turn round, turns there and drives on forwards
(``turn_around.skid_steer``)."""

from __future__ import annotations

import math

from kbplanner.simulation.motion_check import backward_m, path_is_free, turn_drive_turn
from kbplanner.simulation.turn_around import skid_steer, turned_round
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import Box, occupancy_from_meshes
from test_navigation import box

LOAD = Footprint((Rect(0.0, 0.0, 0.99, 0.67), Rect(0.0, 0.0, 1.6, 0.5)), name="husky + load")


def _alcove_and_room() -> ConfigurationSpace:
    """An 8 x 4 m room (x 0-8) with a 0.9 m wide, 2.5 m deep alcove east of it (x 8-10.5, y 1.55-2.45)."""
    walls = [box(-0.2, -0.2, 10.7, 0.0), box(-0.2, 4.0, 10.7, 4.2), box(-0.2, 0.0, 0.0, 4.0),
             box(8.0, 0.0, 10.7, 1.55), box(8.0, 2.45, 10.7, 4.0), box(10.5, 1.55, 10.7, 2.45)]
    grid = occupancy_from_meshes(walls, (0.05, 1.5), Box(-0.5, -0.5, 11.0, 4.5), 0.05)
    return ConfigurationSpace.build(grid, LOAD)


def test_a_base_facing_into_an_alcove_backs_out_only_as_far_as_it_must() -> None:
    cs = _alcove_and_room()
    poses = [(9.6, 2.0, 0.0), (1.5, 2.0, 0.0)]  # in the alcove facing its end; the goal far west, same yaw
    assert path_is_free(cs, poses)
    plain, _ = turn_drive_turn(cs, poses, allow_reverse=False)
    got, _ = skid_steer(cs, poses, allow_reverse=False)
    assert path_is_free(cs, got)
    assert got[0] == poses[0] and got[-1] == poses[-1]
    # it has to back out of the alcove (1.6 m load, 0.9 m wide), but no further than just out of it
    assert 1.0 < backward_m(got) < 2.6 < backward_m(plain)


def test_where_the_base_can_turn_at_once_nothing_changes() -> None:
    cs = _alcove_and_room()
    poses = [(4.0, 2.0, 0.0), (1.5, 2.0, 0.0)]  # in the open room: turn, drive, turn back
    got = skid_steer(cs, poses, allow_reverse=False)
    assert got == turn_drive_turn(cs, poses, allow_reverse=False)
    assert backward_m(got[0]) == 0.0


def test_with_reversing_allowed_the_path_is_turn_drive_turns() -> None:
    cs = _alcove_and_room()
    poses = [(9.6, 2.0, 0.0), (1.5, 2.0, 0.0)]
    assert skid_steer(cs, poses, allow_reverse=True) == turn_drive_turn(cs, poses, allow_reverse=True)


def test_no_room_to_turn_anywhere_gives_none() -> None:
    cs = _alcove_and_room()
    assert turned_round(cs, [(10.2, 2.0, 0.0), (8.6, 2.0, math.pi / 90)]) is None


def test_a_load_ahead_of_the_base_past_a_stub_wall_also_backs_out_only_as_far_as_it_must() -> None:
    walls = [box(-0.2, -0.2, 10.7, 0.0), box(-0.2, 4.0, 10.7, 4.2), box(-0.2, 0.0, 0.0, 4.0),
             box(8.0, 0.0, 10.7, 1.55), box(8.0, 2.45, 10.7, 4.0), box(10.5, 1.55, 10.7, 2.45),
             box(3.0, 0.0, 3.2, 1.3)]  # a stub wall on the way west
    grid = occupancy_from_meshes(walls, (0.05, 1.5), Box(-0.5, -0.5, 11.0, 4.5), 0.05)
    ahead = Footprint((Rect(0.0, 0.0, 0.99, 0.67), Rect(0.5, 0.0, 1.4, 0.5)), name="husky + load ahead")
    cs = ConfigurationSpace.build(grid, ahead)
    poses = [(9.2, 2.0, 0.0), (1.5, 2.0, 0.0)]
    assert path_is_free(cs, poses)
    plain, _ = turn_drive_turn(cs, poses, allow_reverse=False)
    got, _ = skid_steer(cs, poses, allow_reverse=False)
    assert path_is_free(cs, got) and got[0] == poses[0] and got[-1] == poses[-1]
    assert backward_m(got) < backward_m(plain)

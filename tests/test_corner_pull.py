"""B5 navigation (pathq14): a route's needless corners cut out where a turn on the spot, a straight
forward drive and a turn are free and quicker (``corner_pull.pull_corners``)."""

from __future__ import annotations

import itertools
import math

from kbplanner.simulation.base_trajectory import time_parameterize
from kbplanner.simulation.corner_pull import pull_corners
from kbplanner.simulation.motion_check import path_is_free, turn_drive_turn
from kbplanner.simulation.nav_path import Pose2D, wrap
from kbplanner.world.footprint import ConfigurationSpace
from test_navigation import BASE, two_rooms


def _time(cs: ConfigurationSpace, poses: list[Pose2D]) -> float:
    return time_parameterize(poses, 0.5, 2.0, 1.0, 2.0, 10.0, cs).duration_s


def _turned_on_the_spot(poses: list[Pose2D]) -> float:
    return sum(abs(wrap(b[2] - a[2])) for a, b in itertools.pairwise(poses)
               if math.hypot(b[0] - a[0], b[1] - a[1]) <= 1e-9)


def _never_backwards(poses: list[Pose2D]) -> bool:
    for a, b in itertools.pairwise(poses):
        if math.hypot(b[0] - a[0], b[1] - a[1]) <= 1e-9:
            continue
        heading = math.atan2(b[1] - a[1], b[0] - a[0])
        if abs(wrap(heading - a[2])) > math.pi / 2 or abs(wrap(heading - b[2])) > math.pi / 2:
            return False
    return True


def test_a_hop_of_a_few_centimetres_the_wrong_way_is_cut_out() -> None:
    cs = ConfigurationSpace.build(two_rooms(1.2), BASE)
    # a sampling planner's zigzag: 3 cm backwards-left first, then on to the north-east
    route, _ = turn_drive_turn(cs, [(1.5, 1.5, 0.0), (1.47, 1.52, 2.5), (3.0, 2.5, 0.0)], allow_reverse=False)
    got = pull_corners(cs, route, lambda p: _time(cs, p))
    assert got[0] == route[0] and got[-1] == route[-1]
    assert path_is_free(cs, got) and _never_backwards(got)
    assert _turned_on_the_spot(got) < _turned_on_the_spot(route) - 1.0  # the turn to face the hop is gone
    assert _time(cs, got) < _time(cs, route)
    assert (1.47, 1.52) not in [(x, y) for x, y, _ in got]


def test_a_corner_round_the_wall_is_kept_and_the_route_stays_free() -> None:
    cs = ConfigurationSpace.build(two_rooms(1.2), BASE)
    route, _ = turn_drive_turn(cs, [(1.5, 1.0, 0.0), (3.4, 2.0, 0.0), (4.9, 2.0, 0.0), (6.5, 3.0, -1.0)],
                               allow_reverse=False)
    assert path_is_free(cs, route)
    got = pull_corners(cs, route, lambda p: _time(cs, p))
    assert got[0] == route[0] and got[-1] == route[-1]
    assert path_is_free(cs, got) and _never_backwards(got)
    assert _time(cs, got) <= _time(cs, route)


def test_a_straight_route_is_returned_as_it_was() -> None:
    cs = ConfigurationSpace.build(two_rooms(1.2), BASE)
    route = [(1.5, 1.5, 0.0), (3.0, 1.5, 0.0), (3.0, 1.5, 1.0)]
    assert pull_corners(cs, route, lambda p: _time(cs, p)) == route
